"""Embodied path integration (the I2Bot paper's §2.3, Fig. 3): the CX walks the ant home.

The Stone et al. 2017 circuit reads the body's heading and velocity once per gait cycle
(0.64 s = 80 control steps of 8 ms) and steers the FK tripod gait through the locomotion command:

    θ   = k_PI · (ΣCPU1_left − ΣCPU1_right)      (eq. 3.6; left = CPU1 8–15, right = 0–7)
    S_l = 5° + 20° · (1 − min(|θ|, 1))            (eq. 3.7)

Outbound, the ant forages: a random walk of turn commands (one per gait cycle) at a fixed
stride, starting at the nest with an initial heading uniform in [0, 2π). Then it homes until it
is within ``nest_radius_m`` of the nest or ``homing_timeout_s`` runs out.

The velocity the CX integrates is the body's displacement over the last gait cycle (metres per
brain step, ``velocity_input = "pose"``, smooth like the paper's supervisor input), or the root's
instantaneous velocity sensor times the cycle length (``"measured"``: it carries the gait's
wobble). The same protocol runs on the kinematic backend's unicycle, driven by the same command,
so the three bodies can be compared.

Metrics per trial: ``success`` (within ``nest_radius_m``), ``homing_time_s``, ``closest_distance_m``,
``home_distance_m`` at the turn-back, ``straightness`` of the homing path, ``decode_error_deg`` (home
vector decoded from CPU4 at the turn-back vs the true one), ``trial_time_s``, ``real_time_factor``.

Variability (``variability=on``, the default): each gait cycle the CX reads the heading with a
Gaussian error of ``compass_noise_deg`` and the displacement scaled by 1 + N(0, ``odometry_noise_fraction``)
(:func:`homing_noise`), and the legs execute its command with the motor noise of every walking scenario
(:class:`neuronav.scenarios.motor_noise.MotorNoise`: ``turn_noise_sd``, ``stride_noise_fraction``); each
source from the trial's own generator. The start (at the nest, facing a uniform random heading) and the
foraging walk differ per trial in both settings.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

import numpy as np

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.gaits import make_gait
from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.brains.sky_compass import decode_heading, sky_stone2017
from neuronav.engine.loop import AgentLoop, Clocks, integer_ratio
from neuronav.engine.video_overlay import Marker, PopulationInset, VideoContent
from neuronav.errors import ConfigError
from neuronav.runs.scenario import ScenarioResult
from neuronav.scenarios.motor_noise import MotorNoise
from neuronav.scenarios.path_integration.inputs import (
    FlowOdometer,
    LegOdometer,
    SkyView,
    StrideCounter,
    body_to_world,
    inputs_label,
    kinematic_ventral_camera,
    level_rim_mount,
    run_sky,
    trial_inputs,
    world_to_body,
)
from neuronav.scenarios.trial_loop import run_loop, trials_one_by_one
from neuronav.scenarios.variability import is_on, normal_per_trial, trial_generators
from neuronav.scenarios.worlds.scenes import pack_world
from neuronav.spec.world import Appearance, Ground, PointAgents, World

CYCLE_S = 0.64
CONTROL_S = 0.008
MIN_STRIDE_RAD = np.radians(5.0)
# What the brain logs every gait cycle (``compass_heading_rad``: the heading its compass gives, the true one
# with its noise or the sky compass's decoded TB1 plus the sun's azimuth).
LOG_KEYS = ("time_s", "position_m", "heading_rad", "compass_heading_rad", "cpu4", "fed_velocity",
            "measured_velocity", "turn", "stride_rad")
EXTRA_STRIDE_RAD = np.radians(20.0)


def steering_command(cpu1: np.ndarray, k_pi: float) -> tuple[float, float]:
    """(turn θ, stride S_l) from CPU1 rates (16,), eqs. 3.6–3.7; θ > 0 turns left."""
    theta = float(np.clip(k_pi * (cpu1[8:].sum() - cpu1[:8].sum()), -1.0, 1.0))
    return theta, float(MIN_STRIDE_RAD + EXTRA_STRIDE_RAD * (1.0 - min(abs(theta), 1.0)))


# The sensor noise sources of embodied homing, each drawn per gait cycle from its own stream of the trial's seed.
NOISE_SOURCES = ("compass", "odometry")


def homing_noise(config, seeds, cycles: int) -> dict[str, np.ndarray] | None:
    """Per-cycle sensor noise of embodied homing for the trials (ants) of ``seeds``, or None with
    ``variability=off``.

    Returns ``{source: array (len(seeds), cycles)}``: ``compass`` (rad, added to the heading the CX
    reads) and ``odometry`` (relative: the displacement read is scaled by 1 + it). Row i depends on
    ``seeds[i]`` alone
    (:func:`neuronav.scenarios.variability.trial_generators`), so a trial re-run alone, in any chunk,
    or as a swarm's ant draws the same numbers.
    """
    if not is_on(config):
        return None
    scales = {"compass": np.radians(config.compass_noise_deg), "odometry": config.odometry_noise_fraction}
    return {source: normal_per_trial(trial_generators(seeds, source), (cycles,), float(scales[source]))
            for source in NOISE_SOURCES}


def motor_noise(config, seed: int) -> MotorNoise:
    """The trial's motor noise: the configured sizes with ``variability=on``, none with ``off``."""
    on = is_on(config)
    return MotorNoise(seed, config.turn_noise_sd if on else 0.0, config.stride_noise_fraction if on else 0.0)


def noise_cycles(duration_s: float) -> int:
    """Brain calls (gait cycles) a trip of ``duration_s`` can take, with one to spare."""
    return int(np.ceil(duration_s / CYCLE_S - 1e-9)) + 2


class HomingBrain:
    """The CX, its sensing and its steering, called by the agent loop once per gait cycle.

    ``noise`` (:func:`homing_noise`, one row) adds the cycle's sensor errors to what the CX reads
    (None: it reads exactly); the command goes through the trial's :func:`motor_noise`.
    """

    def __init__(self, config, seed: int, outbound_s: float, noise: dict[str, np.ndarray] | None = None,
                 compass: str = "true", odometer=None, sky_view: SkyView | None = None) -> None:
        self.config = config
        self.noise = noise
        self.motor = motor_noise(config, seed)
        self.cycle = 0
        self.rng = np.random.default_rng([seed, 2])
        self.compass, self.odometer, self.sky_view = compass, odometer, sky_view
        if compass == "sky":
            self.cx = sky_stone2017(noise=config.embodied_noise, pol_noise=config.pol_noise,
                                    compass_gain=config.compass_gain, memory_gain=config.embodied_memory_gain,
                                    memory_leak=config.memory_leak).compile(batch=1, seeds=[seed])
        else:
            self.cx = stone2017(noise=config.embodied_noise, memory_gain=config.embodied_memory_gain,
                                memory_leak=config.memory_leak).compile(batch=1, seeds=[seed])
        self.outbound_s = outbound_s
        self.turn = 0.0
        self.last_position = None
        self.turnback_memory = None
        self.log: dict[str, list] = {k: [] for k in LOG_KEYS}

    def _odometry(self, sensed: dict, position: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
        """What the odometer says the body moved over the last gait cycle: (world (x, y), None) from the
        true displacement, (None, body (forward, left)) from a step or stride odometer."""
        if self.odometer is not None:
            return None, self.odometer.take()
        if self.config.velocity_input == "pose":
            moved = position - self.last_position  # metres per gait cycle
        else:
            moved = sensed["velocity"][0] * CYCLE_S
        if self.noise is not None:
            moved = moved * (1.0 + self.noise["odometry"][self.cycle])
        return moved, None

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed = loop.backend.read(("heading", "position", "velocity"))
        heading, position = sensed["heading"][0, 0], sensed["position"][0]
        if self.last_position is None:
            self.last_position = position
        moved_world, moved_body = self._odometry(sensed, position)
        self.last_position = position
        if self.compass == "sky":
            if moved_body is None:  # the true displacement, in the body frame the TN cells read
                moved_body = world_to_body(moved_world, heading)
            self.cx.step({"pol": self.sky_view(loop.backend), "body_velocity": moved_body[None, :]})
            read = float(decode_heading(self.cx.rates("TB1"))[0]) + self.sky_view.sky.sun_azimuth_rad
        else:
            read = heading + (self.noise["compass"][self.cycle] if self.noise is not None else 0.0)
            if moved_world is None:  # turned into the world by the heading the CX reads (its TN encoder turns
                moved_world = body_to_world(moved_body, read)  # it back with the same one)
            self.cx.step({"heading": np.array([[read]]), "velocity": moved_world[None, :]})
        fed_world = moved_world if moved_body is None else body_to_world(moved_body, heading)
        if loop.time_s < self.outbound_s:
            # Foraging: a smooth random walk of turn commands at the configured stride.
            self.turn = float(np.clip(0.7 * self.turn + self.rng.normal(0.0, self.config.foraging_turn_std),
                                      -1.0, 1.0))
            command = (self.turn, np.radians(self.config.foraging_stride_deg))
        else:
            if self.turnback_memory is None:
                self.turnback_memory = self.cx.memory("CPU4")[0]
            command = steering_command(self.cx.rates("CPU1")[0], self.config.k_pi)
        if isinstance(self.odometer, StrideCounter):
            self.odometer.command = command  # the efference copy the unicycle's stride counter reads
        command = self.motor(*command)
        self.cycle += 1
        for key, value in (("time_s", loop.time_s), ("position_m", position), ("heading_rad", heading),
                           ("compass_heading_rad", read),
                           ("cpu4", self.cx.memory("CPU4")[0]),
                           ("fed_velocity", fed_world / CYCLE_S),
                           ("measured_velocity", sensed["velocity"][0]), ("turn", command[0]),
                           ("stride_rad", command[1])):
            self.log[key].append(np.array(value, float))
        return command


# Physics bounds of the embodied protocol: every trial ends in bounded time.
MIN_TIMESTEP_S = 1e-4
MAX_PHYSICS_PER_CONTROL = 80
MAX_PHYSICS_STEPS = 4_000_000


def check_embodied(config, backend_name: str) -> None:
    """The embodied protocol's cross-field rules: a trial lasts at least one gait cycle (the brain's period);
    on a physics backend (the kinematic one steps per control step) ``embodied_timestep_s`` at least
    ``MIN_TIMESTEP_S`` and a whole fraction of the 8 ms control step (at
    most ``MAX_PHYSICS_PER_CONTROL`` physics steps per control step); a trial of at most
    ``outbound_s + homing_timeout_s`` needs at most ``MAX_PHYSICS_STEPS`` physics steps (at the default
    2 ms: 8000 s, more than the settings' own maxima).

    Raises
    ------
    ConfigError
        Naming the setting and the bound.
    """
    trip_s = config.outbound_s + config.homing_timeout_s
    if trip_s < CYCLE_S:  # (below one control step no trial ran at all)
        raise ConfigError(f"outbound_s + homing_timeout_s = {trip_s:g} s is shorter than one gait cycle "
                          f"({CYCLE_S} s), the brain's period")
    if backend_name == "kinematic":
        return
    timestep_s = config.embodied_timestep_s
    if not (np.isfinite(timestep_s) and timestep_s >= MIN_TIMESTEP_S):
        raise ConfigError(f"embodied_timestep_s must be at least {MIN_TIMESTEP_S} s, got {timestep_s!r}")
    ratio = integer_ratio(CONTROL_S, timestep_s, "control step (8 ms) / embodied_timestep_s")
    if ratio > MAX_PHYSICS_PER_CONTROL:
        raise ConfigError(f"8 ms control step / embodied_timestep_s = {ratio}: at most {MAX_PHYSICS_PER_CONTROL}")
    steps = (config.outbound_s + config.homing_timeout_s) / timestep_s
    if steps > MAX_PHYSICS_STEPS:
        raise ConfigError(f"(outbound_s + homing_timeout_s) / embodied_timestep_s = {steps:.3g} physics steps per "
                          f"trial; at most {MAX_PHYSICS_STEPS:,} (shorten the trip or raise embodied_timestep_s)")


def run_embodied(config, backend_name: str, trials: int, seed: int, video_path=None) -> ScenarioResult:
    """All trials of the embodied protocol, one after another (one body per engine).

    With ``video_path``, the first trial is filmed by the follow camera: an MP4 that plays in real
    time (:func:`neuronav.scenarios.trial_loop.run_loop`).
    """
    check_embodied(config, backend_name)
    rows, logs = trials_one_by_one(lambda s, video: embodied_trial(config, backend_name, s, video), trials, seed,
                                   video_path)
    steps = max(len(log["time_s"]) for log in logs)
    timeseries = {}
    for key in logs[0]:
        sample = np.asarray(logs[0][key][0])
        padded = np.full((trials, steps, *sample.shape), np.nan)
        for i, log in enumerate(logs):
            padded[i, : len(log[key])] = np.array(log[key])
        timeseries[key] = padded
    timeseries["turnback_s"] = np.full(trials, config.outbound_s)
    world = []  # the nest, and where the ant turned for home (the feeder)
    for log in logs:
        times, path = np.array(log["time_s"], float), np.array(log["position_m"], float)
        homing = times >= config.outbound_s
        world.append({"nest_m": np.zeros(2), "turnback_m": path[int(np.argmax(homing)) if homing.any() else -1]})
    timeseries.update(pack_world(world))
    simulated = float(np.nanmean([r["trial_time_s"] for r in rows]))
    return ScenarioResult(trials=rows, timeseries=timeseries, simulated_time_s=simulated)


def homing_video(config, brain: HomingBrain) -> VideoContent:
    """What the video shows: the nest and the central complex's TB1 (heading) and CPU4 (home vector memory,
    scaled to its own range) bumps; from above, the nest in view."""
    return VideoContent(markers=(Marker("nest", (0.0, 0.0), max(config.nest_radius_m, 0.2), (250, 200, 0)),),
                        insets=(PopulationInset("TB1 (heading)", lambda loop: brain.cx.rates("TB1")[0]),
                                PopulationInset("CPU4 (home vector)", lambda loop: brain.cx.memory("CPU4")[0],
                                                low=None, high=None)),
                        keep_in_view=((0.0, 0.0),))


def embodied_trial(config, backend_name: str, seed: int, video_path=None, extra_hooks=()) -> tuple[dict, dict]:
    """One foraging trip and homing; returns the metrics row and the per-cycle log. ``extra_hooks`` ride
    along in the loop without feeding the brain (a benchmark's probe)."""
    rng = np.random.default_rng([seed, 3])
    heading0 = float(rng.uniform(0.0, 2.0 * np.pi))
    world = World(ground=Ground(size_m=80.0), appearance=Appearance(ground_texture=config.ground_texture))
    engine_class = registry.load("backend", backend_name)
    compass, odometry = trial_inputs(config, seed)
    if backend_name == "kinematic":
        engine, gait, physics_dt = engine_class(timestep_s=CONTROL_S), None, CONTROL_S
        body = PointAgents(count=1, mode="unicycle",
                           cameras=(kinematic_ventral_camera(),) if odometry == "optic_flow" else ())
    else:
        engine = engine_class(timestep_s=config.embodied_timestep_s)
        body = desert_ant(ventral_eye=odometry == "optic_flow")
        gait, physics_dt = make_gait("tripod", body), config.embodied_timestep_s
    noise = homing_noise(config, [seed], noise_cycles(config.outbound_s + config.homing_timeout_s))
    if compass == "sky":
        world = World(ground=world.ground, appearance=world.appearance, sky=run_sky(config))
    hooks, odometer = list(extra_hooks), None
    if odometry == "steps":
        # The body the brain believes it has: the desert ant as built (fixed for the trial).
        odometer = StrideCounter(engine.calibration) if backend_name == "kinematic" else LegOdometer(body)
        hooks.append(odometer)
    elif odometry == "optic_flow":
        # The ventral eye and the height the brain believes it at: above the ground at the body's rest pose.
        camera = next(c for c in body.cameras if c.name == "ventral")
        height_m = camera.pos_m[2] if backend_name == "kinematic" else body.spawn_height_m + camera.pos_m[2]
        odometer = FlowOdometer(camera, height_m)
        hooks.append(odometer)
    brain = HomingBrain(config, seed, config.outbound_s, None if noise is None else {k: v[0] for k, v in noise.items()},
                        compass=compass, odometer=odometer,
                        sky_view=(SkyView(world.sky, world, mount=None if backend_name == "kinematic"
                                          else level_rim_mount(body)) if compass == "sky" else None))
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)

    def home(lp: AgentLoop) -> bool:
        if lp.time_s < config.outbound_s:
            return False
        position = lp.backend.read(("position",))["position"][0]
        return bool(np.hypot(*position) <= config.nest_radius_m)

    loop, final, wall_s = run_loop(engine, world, body, gait, clocks, brain, heading_rad=heading0, seed=seed,
                                   duration_s=config.outbound_s + config.homing_timeout_s, until=home,
                                   hooks=hooks, video_path=video_path, video_content=homing_video(config, brain))
    log = {k: list(v) for k, v in brain.log.items()}
    log["time_s"].append(np.array(loop.time_s))
    log["position_m"].append(final)
    for key in LOG_KEYS[2:]:
        log[key].append(np.full_like(log[key][-1], np.nan))
    row = embodied_metrics(log, brain, config, loop.time_s, wall_s)
    return dict(row, inputs=inputs_label(compass, odometry)), log


def embodied_metrics(log: dict, brain: HomingBrain, config, trial_time_s: float, wall_s: float) -> dict:
    """Success, homing time, closest approach, straightness and decode error of one trial."""
    times = np.array(log["time_s"])
    positions = np.array(log["position_m"])
    homing = times >= config.outbound_s
    turnback = int(np.argmax(homing)) if homing.any() else len(times) - 1
    distance = np.hypot(positions[:, 0], positions[:, 1])
    home_distance = float(distance[turnback])
    homing_distance = distance[turnback:]
    closest_index = int(np.argmin(homing_distance))
    path = np.linalg.norm(np.diff(positions[turnback:turnback + closest_index + 1], axis=0), axis=1).sum()
    reached = bool(homing_distance.min() <= config.nest_radius_m)
    memory = brain.turnback_memory if brain.turnback_memory is not None else brain.cx.memory("CPU4")[0]
    decoded, _ = decode_home_vector(memory[None, :])
    if brain.compass == "sky":  # the sky compass's memory is kept relative to the sun's azimuth
        decoded = decoded + brain.sky_view.sky.sun_azimuth_rad
    true_home = np.arctan2(-positions[turnback, 0], -positions[turnback, 1])
    # The compass's error each gait cycle, and what the odometer made of the path: its length over the true one.
    compass_error = np.angle(np.exp(1j * (np.array(log["compass_heading_rad"][:-1])
                                          - np.array(log["heading_rad"][:-1]))))
    true_path_m = np.linalg.norm(np.diff(positions[:-1], axis=0), axis=1).sum()  # sampled when the brain read
    fed_path_m = np.linalg.norm(np.array(log["fed_velocity"][1:-1]).reshape(-1, 2), axis=1).sum() * CYCLE_S
    return {
        "success": reached, "status": "ok", "error": "",
        "homing_time_s": float(trial_time_s - config.outbound_s) if reached else float("nan"),
        "closest_distance_m": float(homing_distance.min()),
        "home_distance_m": home_distance,
        # How much of the walked homing path brought the ant nearer: 1 for a straight line.
        "straightness": float((home_distance - homing_distance.min()) / path) if path > 0 else float("nan"),
        "decode_error_deg": float(np.degrees(abs(np.angle(np.exp(1j * (decoded[0] - true_home)))))),
        # Root-mean-square over the gait cycles.
        "compass_error_deg": (float(np.degrees(np.sqrt(np.mean(compass_error ** 2)))) if compass_error.size
                              else float("nan")),
        "odometer_ratio": float(fed_path_m / true_path_m) if true_path_m > 0 else float("nan"),
        "trial_time_s": float(trial_time_s),
        "real_time_factor": float(trial_time_s / wall_s) if wall_s > 0 else float("nan"),
    }
