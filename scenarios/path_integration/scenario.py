"""``path-integration``: Stone et al. 2017's central-complex model walks its agent home.

Protocol (Stone et al. 2017, docs/parameters.md §3): each trial starts at the nest, follows a smooth
random outbound route (von Mises turns, smoothed; smoothly varying acceleration) while the CX
integrates heading and velocity, then the CX's motor output steers the agent for the inbound
phase. All trials run as one batch through one compiled circuit; trial i uses seed ``seed + i``
for both its route and its neural noise, so any trial re-run alone gives the same numbers.

Metrics per trial: ``closest_distance`` to the nest during homing, ``success`` (closest distance
within ``success_radius``), ``tortuosity_mu`` and ``tortuosity`` (Stone's straightness measure),
``decode_error_deg`` (home vector decoded from CPU4 vs the true one at the turn-back point),
``home_distance`` and ``decoded_distance`` at the turn-back point, ``homing_steps`` (steps until
within the success radius, NaN if never). Aggregate: Stone's tortuosity τ = 1 / (1 − mean μ).
``protocol=i2bot`` (the default on physics backends) runs :mod:`.embodied` instead.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav import bind, registry
from neuronav.angles import angle_difference_rad
from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.brains.sky_compass import sky_stone2017
from neuronav.config import field
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.motor_noise import stride_noise_field, turn_noise_field
from neuronav.scenarios.path_integration.inputs import SkyView, compasses, inputs_label, odometers, run_sky
from neuronav.scenarios.variability import variability_field
from neuronav.spec.world import PointAgents, World


@dataclass
class PathIntegrationConfig:
    """Settings of the path-integration scenario (defaults: Stone et al. 2017)."""

    noise: float = field(0.1, "std of the Gaussian noise on every CX population's rates", min=0.0, max=1.0)
    outbound_steps: int = field(1500, "steps of the random outbound route", min=1, max=100_000)
    inbound_steps: int = field(1500, "steps of CX-driven homing", min=1, max=100_000)
    success_radius: float = field(20.0, "success: homing comes this close to the nest (distance units)",
                                  min_exclusive=0.0, max=10_000.0)
    kappa: float = field(100.0, "von Mises concentration of the outbound turns", min_exclusive=0.0, max=1e6)
    turn_smoothing: float = field(0.4, "outbound turns are low-pass filtered: y_t = x_t + a*y_(t-1)",
                                  min=0.0, max_exclusive=1.0)
    # Accelerations in distance units per step²: at drag d the speed settles at a (1 - d) / d, 0.85 for
    # Stone's 0.15 and 0.15; 1 allows 5.7 units per step, far beyond what the TN cells encode.
    min_acceleration: float = field(0.0, "outbound acceleration, lower bound (<= max_acceleration)", min=0.0, max=1.0)
    max_acceleration: float = field(0.15, "outbound acceleration, upper bound", min=0.0, max=1.0)
    inbound_acceleration: float = field(0.1, "acceleration while homing", min=0.0, max=1.0)
    drag: float = field(0.15, "fraction of the velocity lost per step", min=0.0, max_exclusive=1.0)
    # The CPU4 memory lives in [0, 1]: a gain of 1 fills it in one step of full drive.
    memory_gain: float = field(0.0025, "CPU4 integration gain h per step", min_exclusive=0.0, max=1.0)
    memory_leak: float = settings.cpu4_leak_field()
    dtype: str = field("float32", "arithmetic of the CX (float32 is faster; float64 for reference runs)",
                       choices=("float32", "float64"))
    noise_method: str = field("table", "CX noise sampler: 'table' (16-bit normal quantiles, faster) or "
                              "'gaussian' (numpy's exact sampler)", choices=("table", "gaussian"))
    record_every: int = field(5, "record positions and neural activity every k steps "
                              "(<= outbound_steps + inbound_steps)", min=1, max=200_000)
    record_trials: int = field(20, "trials whose neural activity is recorded", min=0, max=10_000)
    protocol: str = field("auto", "stone2017 (point agents, steps) or i2bot (a body walked by a gait, metres "
                          "and seconds); auto: stone2017 on kinematic, i2bot on physics backends",
                          choices=("auto", "stone2017", "i2bot"))
    outbound_s: float = settings.outbound_field("i2bot")
    homing_timeout_s: float = settings.homing_timeout_field("i2bot")
    nest_radius_m: float = settings.nest_radius_field("i2bot: success when the body comes this close to the nest (m)")
    k_pi: float = settings.homing_gain_field("i2bot")
    embodied_noise: float = settings.cx_noise_field("i2bot")
    embodied_memory_gain: float = settings.cpu4_gain_field("i2bot")
    velocity_input: str = field("pose", "i2bot: velocity fed to the CX: displacement per gait cycle (pose) or "
                                "the instantaneous velocity sensor (measured)", choices=("pose", "measured"))
    foraging_turn_std: float = settings.foraging_turn_field("i2bot: std of the random turn command per gait cycle "
                                                            "(the command is clipped to [-1, 1])")
    foraging_stride_deg: float = settings.foraging_stride_field("i2bot")
    embodied_timestep_s: float = field(0.002, "i2bot: physics step of the body (s)", min_exclusive=0.0,
                                       max=0.008)
    # Trial-to-trial variability of the i2bot protocol (stone2017's trials differ by their seeded routes and
    # CX noise, Stone et al. 2017's own protocol, in either setting).
    variability: str = variability_field()
    compass_noise_deg: float = settings.compass_noise_field("i2bot")
    odometry_noise_fraction: float = settings.odometry_noise_field("i2bot")
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()
    # The CX's own senses (issue 23): inputs.py in this folder.
    compass: str = field("true", "heading the CX reads: the body's true heading (true) or its dorsal rims' view of "
                         "the polarised sky (sky); a comma list (true,sky) is cycled over trials by seed "
                         "[true, sky or a comma list of them]")
    odometry: str = field("true", "distance the CX integrates: the true displacement (true), the step odometer "
                          "(steps: joint angles and leg loads through the believed legs; strides x believed "
                          "stride length on the kinematic unicycle) or the image motion of a ventral eye on the "
                          "ground (optic_flow: needs ground_texture=checker); i2bot only; a comma list (true,steps) "
                          "is cycled by whole cycles of the compass list [true, steps, optic_flow or a comma list]")
    ground_texture: str = field("checker", "i2bot: the ground the cameras see: checker squares of 0.5 m or plain "
                                "(one colour: the optic-flow odometer sees no motion on it)",
                                choices=("checker", "plain"))
    sun_elevation_deg: float = field(45.0, "compass=sky: the sun's elevation (deg)", min=0.0, max=90.0)
    sun_azimuth_deg: float = field(120.0, "compass=sky: the sun's azimuth, clockwise from +y (north) (deg)",
                                   min=-360.0, max=360.0)
    cloud_cover: float = field(0.0, "compass=sky: fraction of the sky overcast (0 clear - 1 overcast: no "
                               "polarisation)", min=0.0, max=1.0)
    pol_noise: float = field(0.1, "compass=sky: std of the Gaussian noise on each POL-neuron's response per brain "
                             "step", min=0.0, max=10.0)
    compass_gain: float = field(2.0, "compass=sky: gain of the POL -> compass-layer weights (brains/sky_compass.py)",
                                min_exclusive=0.0, max=20.0)

    def cross_check(self) -> None:
        """Rules between settings that hold on every backend (called by :func:`neuronav.config.validate`)."""
        if self.min_acceleration > self.max_acceleration:
            raise ConfigError(f"min_acceleration ({self.min_acceleration:g}) must be <= max_acceleration "
                              f"({self.max_acceleration:g})")
        compasses(self)
        odometers(self)


class PathIntegration(Scenario):
    """Stone et al. 2017's path integration: point agents (stone2017) or an embodied ant (i2bot)."""

    name = "path-integration"
    description = "CX path integration (Stone et al. 2017): random outbound route, then the CX steers home"
    config_type = PathIntegrationConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    timing_metrics = ("real_time_factor",)
    # Undefined (NaN) in some trials by definition: an agent that never comes within the success
    # radius has no homing_steps (homing_time_s for the embodied ant), one that never gets closer
    # than where it turned back has mu = 1, so no per-trial tortuosity 1 / (1 - mu), and a body that
    # did not move on its way home has no straightness, and one that never left the nest (max_acceleration
    # 0) no tortuosity_mu (it divides by the distance from home at the turn back).
    # An embodied body that never moved has no odometer ratio (its odometer over its true path length).
    optional_metrics = ("homing_steps", "tortuosity", "tortuosity_mu", "homing_time_s", "straightness",
                        "odometer_ratio")
    records_video = True  # on backends that render: the embodied protocol films its first trial
    condition_columns = ("inputs",)  # compass/odometry of each trial: true/true, sky/steps, ...

    def smoke_config(self) -> dict:
        return {"outbound_steps": 120, "inbound_steps": 120, "record_trials": 2}

    def leading_series(self, config: PathIntegrationConfig, backend: str) -> dict[str, int]:
        """stone2017: the neural activity of the first ``record_trials`` trials only."""
        if self.protocol(config, backend) != "stone2017":
            return {}
        return dict.fromkeys(("cpu4_memory", "tb1_rates", "heading_rad"), config.record_trials)

    @staticmethod
    def protocol(config: PathIntegrationConfig, backend: str) -> str:
        """The protocol a run uses: the configured one, or by backend when ``auto``."""
        if config.protocol != "auto":
            return config.protocol
        return "stone2017" if backend == "kinematic" else "i2bot"

    def check_video(self, config: PathIntegrationConfig, backend: str) -> None:
        """The stone2017 protocol steps its point agents as one batch, with no agent loop to film."""
        if self.protocol(config, backend) == "stone2017":
            raise ConfigError("--video films the i2bot protocol (an agent loop); the stone2017 protocol has none: "
                              "give --set protocol=i2bot")

    def estimate_bytes(self, config: PathIntegrationConfig, trials: int) -> int | None:
        """Memory one batch of ``trials`` point-agent trials needs (stone2017); None for i2bot.

        Per trial, in float64: the positions of every step (2 per step), the outbound route's turns,
        accelerations and their step-major copies (5 per outbound step), the distance arrays of the
        metrics (3 per step), the recorded positions, and the compiled circuit's state; and the neural
        activity of the first ``record_trials`` trials (CPU4, TB1 and heading: 25 float32 per sample).
        Measured at the defaults (peak RSS of ``neuronav run path-integration --trials N`` for N = 2000
        and 20000): about 155 KB per trial; this estimate gives 198 KB. The embodied protocol runs its
        trials one after another, each in its own small batch: no estimate.
        """
        if config.protocol == "i2bot":
            return None
        steps = config.outbound_steps + config.inbound_steps
        samples = steps // config.record_every
        per_trial = 8 * (2 * (steps + 1) + 5 * config.outbound_steps + 3 * steps) + 12 * 2 * (samples + 1)
        activity = min(trials, config.record_trials) * samples * 25 * 4
        circuit = stone2017(noise=config.noise).compile(batch=1, dtype=np.dtype(config.dtype))
        return int(trials * (per_trial + circuit.bytes_per_agent()) + activity)

    def check(self, config: PathIntegrationConfig, backend: str) -> None:
        """Refuse, before any trial, settings that cannot run on ``backend``.

        ``protocol=stone2017`` moves point agents: kinematic backend only; its recording needs
        ``record_every <= outbound_steps + inbound_steps``. The i2bot protocol's rules are
        :func:`neuronav.scenarios.path_integration.embodied.check_embodied`'s.

        Raises
        ------
        ConfigError
            Naming the setting, the backend and what is allowed.
        """
        protocol = self.protocol(config, backend)
        if protocol == "i2bot":
            from neuronav.scenarios.path_integration.embodied import check_embodied

            check_embodied(config, backend)
            return
        if "optic_flow" in odometers(config):
            raise ConfigError(f"odometry={config.odometry!r}: the stone2017 protocol's point agents move in steps "
                              f"over no rendered ground, so a ventral eye has no image motion to read; "
                              f"odometry=optic_flow needs protocol=i2bot (a body walking over a textured ground)")
        if odometers(config) != ("true",):
            raise ConfigError(f"odometry={config.odometry!r}: the stone2017 protocol's point agents have no legs to "
                              f"count strides with; odometry=steps needs protocol=i2bot (a body walked by a gait)")
        if len(compasses(config)) > 1:
            raise ConfigError(f"compass={config.compass!r}: a stone2017 run compiles one circuit for all its trials, "
                              f"so one compass per run (compare true and sky with two runs, or protocol=i2bot)")
        if backend != "kinematic":
            raise ConfigError(f"the stone2017 protocol moves point agents: it runs on the kinematic backend only, "
                              f"not {backend!r} (use protocol=i2bot or auto)")
        steps = config.outbound_steps + config.inbound_steps
        if config.record_every > steps:
            raise ConfigError(f"record_every={config.record_every} records nothing: a trial has only "
                              f"outbound_steps + inbound_steps = {steps} steps")

    def aggregate(self, trials: list[dict], config: PathIntegrationConfig) -> dict:
        """Stone's tortuosity τ = 1 / (1 − mean μ) over all finished trials (stone2017 protocol)."""
        mus = np.array([t.get("tortuosity_mu", np.nan) for t in trials if t.get("status", "ok") == "ok"], float)
        mus = mus[np.isfinite(mus)]
        if not mus.size:
            return {}
        mean_mu = mus.mean()
        return {"tortuosity": float(1.0 / (1.0 - mean_mu)) if mean_mu < 1 else float("nan")}

    def statistics(self, config: PathIntegrationConfig) -> Statistics:
        """Per ``inputs`` (compass/odometry, when ``compass`` or ``odometry`` is a comma list: each against the
        first combination), else one group: success with its Wilson interval and every metric of the
        protocol's rows (stone2017: closest approach, μ, decode error, homing steps; i2bot: homing time,
        closest approach, straightness, decode error, compass error, odometer ratio) with bootstrap intervals."""
        combinations = [inputs_label(c, o) for o in odometers(config) for c in compasses(config)]
        if len(combinations) > 1:
            return Statistics(condition="inputs", reference=combinations[0])
        return Statistics(condition=None)

    def compare_overrides(self, backends: list[str]) -> dict:
        """Comparing a physics body with the kinematic one only makes sense under one protocol."""
        return {"protocol": "i2bot"} if any(b != "kinematic" for b in backends) else {}

    # -- running -------------------------------------------------------------------------------
    def run(self, config: PathIntegrationConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        protocol = self.protocol(config, backend)
        if protocol == "i2bot":
            from neuronav.scenarios.path_integration.embodied import run_embodied

            return run_embodied(config, backend, trials, seed, video_path)
        if backend != "kinematic":
            raise ConfigError(f"the stone2017 protocol moves point agents: it runs on the kinematic backend, "
                              f"not {backend!r} (use protocol=i2bot)")
        n, t_out, t_in = trials, config.outbound_steps, config.inbound_steps
        seeds = [seed + i for i in range(n)]
        rotation, acceleration = outbound_routes(config, seeds)

        engine = registry.load("backend", backend)()
        engine.load(World(), [PointAgents(count=n, mode="stone", drag=config.drag)])
        engine.reset(seed)
        compass = compasses(config)[0]
        sky_view, frame_rad = None, 0.0
        if compass == "sky":
            # The sky compass's TB1 and memory are in the sun's frame: decoded directions + the sun's azimuth.
            sky = run_sky(config)
            sky_view, frame_rad = SkyView(sky, World(sky=sky)), sky.sun_azimuth_rad
            brain = sky_stone2017(noise=config.noise, pol_noise=config.pol_noise, compass_gain=config.compass_gain,
                                  memory_gain=config.memory_gain, memory_leak=config.memory_leak).compile(
                batch=n, seeds=seeds, dtype=config.dtype, noise_method=config.noise_method)
        else:
            brain = stone2017(noise=config.noise, memory_gain=config.memory_gain,
                              memory_leak=config.memory_leak).compile(
                batch=n, seeds=seeds, dtype=config.dtype, noise_method=config.noise_method)
            bind(brain.sensors, engine.capabilities.sensors, consumer="stone2017", provider=f"backend {backend!r}")

        k, recorded = config.record_every, min(n, config.record_trials)
        positions = np.zeros((t_out + t_in + 1, n, 2))
        samples = (t_out + t_in) // k
        cpu4 = np.zeros((recorded, samples, 16), np.float32)
        tb1 = np.zeros((recorded, samples, 8), np.float32)
        heading = np.zeros((recorded, samples), np.float32)
        inbound_acceleration = np.full((n, 1), config.inbound_acceleration)
        # Step-major copies: each step's commands for all agents are then contiguous.
        rotation_by_step = np.ascontiguousarray(rotation.T)[:, :, None]
        acceleration_by_step = np.ascontiguousarray(acceleration.T)[:, :, None]
        for t in range(t_out + t_in):
            sensed = engine.read(("heading", "velocity"))
            if sky_view is None:
                motor = brain.step(sensed)["motor"]
            else:  # the dorsal rims' view, and the agents' own (body-frame) velocity: no heading is read
                own_velocity = body_velocity(sensed["velocity"], sensed["heading"][:, 0])
                motor = brain.step({"pol": sky_view(engine), "body_velocity": own_velocity})["motor"]
            if t < t_out:
                engine.write({"rotation": rotation_by_step[t], "acceleration": acceleration_by_step[t]})
            else:
                if t == t_out:
                    turnback_memory = brain.memory("CPU4")
                engine.write({"rotation": motor, "acceleration": inbound_acceleration})
            engine.step()
            positions[t + 1] = engine.position
            if (t + 1) % k == 0 and (t + 1) // k <= samples and recorded:
                s = (t + 1) // k - 1
                cpu4[:, s] = brain.memory("CPU4")[:recorded]
                tb1[:, s] = brain.rates("TB1")[:recorded]
                heading[:, s] = sensed["heading"][:recorded, 0]
        if t_in == 0:
            turnback_memory = brain.memory("CPU4")

        rows, _ = trial_metrics(positions, t_out, turnback_memory, config, seeds, frame_rad)
        for row in rows:
            row["inputs"] = inputs_label(compass, "true")
        aggregates = self.aggregate(rows, config)
        timeseries = {
            "position": np.ascontiguousarray(positions[::k].transpose(1, 0, 2)).astype(np.float32),
            "cpu4_memory": cpu4, "tb1_rates": tb1, "heading_rad": heading,
            "turnback_step": np.full(n, t_out, np.int32),
        }
        return ScenarioResult(trials=rows, timeseries=timeseries, aggregates=aggregates,
                              simulated_time_s=float(t_out + t_in))

    # -- figures -------------------------------------------------------------------------------
    def figures(self, result: ScenarioResult, config: PathIntegrationConfig, out_dir: Path) -> list[Path]:
        if "fed_velocity" in result.timeseries:
            from neuronav.scenarios.path_integration.embodied_figures import write_embodied_figures

            return write_embodied_figures(result, config, Path(out_dir))
        from neuronav.scenarios.path_integration.figures import write_figures

        return write_figures(result, config, Path(out_dir))


def outbound_routes(config: PathIntegrationConfig, seeds: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Per-trial rotation (rad/step) and acceleration sequences of the outbound route.

    Turns are von Mises(0, κ) samples low-pass filtered (y_t = x_t + a·y_{t−1}); acceleration
    follows a cubic spline through random key values in [min, max], one key per 50 steps (at least
    4), clipped to that range. Each trial draws from its own generator seeded with ``(seed, 1)``.

    Returns
    -------
    rotation, acceleration : ndarray, shape (trials, outbound_steps)
    """
    # Imported here: scipy.signal and scipy.interpolate cost 0.4 s at start-up (``neuronav list``).
    from scipy.interpolate import CubicSpline
    from scipy.signal import lfilter

    steps = config.outbound_steps
    low, high = config.min_acceleration, config.max_acceleration
    keys = max(4, steps // 50)
    turns = np.zeros((len(seeds), steps))
    acceleration = np.zeros((len(seeds), steps))
    knots, times = np.linspace(0.0, 1.0, keys), np.linspace(0.0, 1.0, steps)
    # Each trial from its own stream and its own spline (a spline through many trials at once solves
    # them together, which LAPACK may round differently for another number of trials).
    for i, seed in enumerate(seeds):
        rng = np.random.default_rng([seed, 1])
        turns[i] = rng.vonmises(0.0, config.kappa, steps)
        acceleration[i] = CubicSpline(knots, rng.uniform(low, high, keys))(times)
    np.clip(acceleration, low, high, out=acceleration)
    rotation = lfilter([1.0], [1.0, -config.turn_smoothing], turns, axis=1)  # row by row
    rotation[:, 0] = 0.0
    return rotation, acceleration


def stone_tortuosity_mu(distances: np.ndarray, steps: np.ndarray, home_distance) -> np.ndarray | float:
    """Stone's straightness of homing paths (one, or one per column).

    With L the straight-line distance home at the turn-back point: the closest the agent has come
    to the nest so far, divided by L, at the moment its homing path length first reaches L (or at
    the end of homing if it never does). 0 for a straight path home.

    Parameters
    ----------
    distances : ndarray, shape (T + 1,) or (T + 1, trials)
        Distance to the nest from the turn-back point onward.
    steps : ndarray, shape (T,) or (T, trials)
        Length of each homing step.
    home_distance : float or ndarray, shape (trials,)
        L.

    Returns
    -------
    float or ndarray, shape (trials,)
        μ; NaN where L is not positive.
    """
    single = np.ndim(distances) == 1
    distances = distances.reshape(len(distances), -1)
    steps = steps.reshape(len(steps), -1)
    home = np.broadcast_to(np.asarray(home_distance, float), distances.shape[1:])
    reached = np.cumsum(steps, axis=0) >= home
    # Index into distances of the first step whose path length reaches L, else the last one.
    index = np.where(reached.any(axis=0), reached.argmax(axis=0) + 1, len(distances) - 1)
    closest_so_far = np.minimum.accumulate(distances, axis=0)[index, np.arange(distances.shape[1])]
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = np.where(home > 0, closest_so_far / home, np.nan)
    return float(mu[0]) if single else mu


def body_velocity(velocity: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """World-frame velocities (N, 2) of agents at ``heading_rad`` (N,) in their body frames: (forward, left)."""
    s, c = np.sin(heading_rad), np.cos(heading_rad)
    return np.stack([velocity[:, 0] * s + velocity[:, 1] * c, -velocity[:, 0] * c + velocity[:, 1] * s], axis=1)


def trial_metrics(positions: np.ndarray, t_out: int, turnback_memory: np.ndarray,
                  config: PathIntegrationConfig, seeds: list[int],
                  frame_rad: float = 0.0) -> tuple[list[dict], np.ndarray]:
    """Per-trial metric rows and Stone's μ per trial from the positions, shape (T + 1, trials, 2).

    ``frame_rad``: the direction the memory's zero stands for (the sun's azimuth for the sky compass)."""
    homing = np.hypot(positions[t_out:, :, 0], positions[t_out:, :, 1])  # distance to the nest, (T_in + 1, n)
    home_distance = homing[0]
    steps = np.diff(positions[t_out:], axis=0)
    step_lengths = np.hypot(steps[..., 0], steps[..., 1])
    true_home = np.arctan2(-positions[t_out, :, 0], -positions[t_out, :, 1])
    decoded_direction, decoded_distance = decode_home_vector(turnback_memory, config.memory_gain)
    decoded_direction = decoded_direction + frame_rad
    decode_error = np.degrees(np.abs(angle_difference_rad(decoded_direction, true_home)))
    finite_trials = np.isfinite(positions).all(axis=(0, 2))
    closest_all = homing.min(axis=0)
    mus = np.where(finite_trials, stone_tortuosity_mu(homing, step_lengths, home_distance), np.nan)
    arrived = homing <= config.success_radius
    first_arrival = np.where(arrived.any(axis=0), arrived.argmax(axis=0), -1)
    rows = []
    for i, seed in enumerate(seeds):
        finite = bool(finite_trials[i])
        closest = float(closest_all[i]) if finite else float("nan")
        mu = float(mus[i])
        rows.append({
            "trial": i, "seed": seed, "success": bool(finite and closest <= config.success_radius),
            "status": "ok" if finite else "failed", "error": "" if finite else "diverged: position not finite",
            "closest_distance": closest, "tortuosity_mu": mu,
            "tortuosity": float(1.0 / (1.0 - mu)) if np.isfinite(mu) and mu < 1 else float("nan"),
            "decode_error_deg": float(decode_error[i]), "home_distance": float(home_distance[i]),
            "decoded_distance": float(decoded_distance[i]),
            "homing_steps": float(first_arrival[i]) if first_arrival[i] >= 0 else float("nan"),
        })
    return rows, mus
