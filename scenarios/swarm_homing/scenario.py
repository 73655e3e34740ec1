"""``swarm-homing``: many ants in one world, each with its own CX, forage from scattered starts and home.

The embodied homing protocol (:mod:`neuronav.scenarios.path_integration.embodied`) for a swarm: ``ants``
ants share one world, each with its own Stone et al. 2017 CX (one circuit compiled with ``batch=ants``,
ant j's noise seeded by its trial seed), reading its body's heading and displacement once per gait cycle
(0.64 s) and steering through the locomotion command (eqs. 3.6-3.7). Ant j starts at its home on a
sunflower spiral (:func:`home_positions`, neighbours ``spacing_m`` apart), forages by a random walk of
turn commands for ``outbound_s``, then the CX walks it home; an ant within ``nest_radius_m`` of home
stops, and the swarm runs until all are home or ``homing_timeout_s`` has passed. Bodies: unicycle point
agents on ``kinematic``; desert ants walked by their own FK tripod in one world on ``mujoco``
(``MujocoSwarm``, at most 31) and ``pybullet`` (``PybulletSwarm``), where they collide.

``variability=on``: sensor and motor noise per gait cycle from each ant's seed, as in path integration's
embodied protocol (:func:`~neuronav.scenarios.path_integration.embodied.homing_noise`, ``motor_noise``).

Rows are ants: trial i (seed s = seed + i) is ant ``s mod ants`` of swarm ``s // ants``; a swarm follows
from its index and the settings alone, so a row re-run alone, in any chunk or batch, is the same.
``swarm_position_m`` holds the first trial's whole swarm (``swarm_trajectories.png``, ``--video``: ``film.py``).

Metrics per ant: ``success`` (home after the outbound phase), ``homing_time_s`` (NaN if never),
``closest_distance_m``, ``home_distance_m`` (at the turn back), ``straightness``, ``decode_error_deg`` (CPU4's
home vector at the turn back against the true one), ``ant_contact_s`` (time touching another ant), ``ant``,
``swarm``; timing: ``ant_seconds_per_wall_s`` (ants x simulated seconds / wall seconds of the swarm's run).

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav import registry
from neuronav.angles import angle_difference_rad
from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.config import field
from neuronav.engine.loop import integer_ratio
from neuronav.errors import ConfigError
from neuronav.runs import sweep
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import settings
from neuronav.scenarios.motor_noise import stride_noise_field, turn_noise_field
from neuronav.scenarios.path_integration.embodied import homing_noise, motor_noise
from neuronav.scenarios.trial_loop import VIDEO_EVERY  # the other scenarios' frame rate
from neuronav.scenarios.variability import variability_field
from neuronav.spec.world import Ground, PointAgents, World

CYCLE_S = 0.64  # one tripod gait cycle: the brain's period
CONTROL_S = 0.008
MIN_STRIDE_RAD = np.radians(5.0)
EXTRA_STRIDE_RAD = np.radians(20.0)
MAX_PHYSICS_ANTS = 31  # neuronav.backends.mujoco.swarm.MAX_ANTS: one contact bit per ant
# Memory of one swarm (kinematic, --trials 1, peak RSS of the whole command): 5000 ants for 313 gait
# cycles took 54.6 MB more than for 11 (36 B per ant and cycle: the float64 trajectories, their float32
# record and its copy on the way to the file), 20000 ants 99 MB more than 5000 (6.6 KB per ant: the
# ants' random generators, CX state, bodies). With variability=on (issue 22: two sensor errors per ant and
# cycle drawn up front, each ant's motor-noise generator) 5000 ants for 313 cycles took 177.5 MB more than
# 11, so 87 B per ant and cycle beside the 8 KB per ant. Rounded up:
SWARM_BYTES_PER_ANT_CYCLE = 96
SWARM_BYTES_PER_ANT = 8192
# Per trial (row): its own trajectory, float64 and float32, and its clock, float32 (28 B per cycle, rounded up),
# and its row.
TRIAL_BYTES_PER_CYCLE = 32
TRIAL_BYTES = 2048
GOLDEN_ANGLE_RAD = np.pi * (3.0 - np.sqrt(5.0))
SWARM_WORLD = World(ground=Ground(size_m=80.0))  # flat: the ground plane collides everywhere


@dataclass
class SwarmHomingConfig:
    """Settings of swarm homing (the CX and foraging defaults are embodied homing's)."""

    ants: int = field(1000, "ants in one world (mujoco: at most 31)", min=1, max=100_000)
    spacing_m: float = field(3.0, "distance between neighbouring homes (m)", min_exclusive=0.0, max=100.0)
    outbound_s: float = settings.outbound_field()
    homing_timeout_s: float = settings.homing_timeout_field()
    nest_radius_m: float = settings.nest_radius_field("an ant is home within this distance of its home (m)")
    k_pi: float = settings.homing_gain_field()
    noise: float = settings.cx_noise_field()
    memory_gain: float = settings.cpu4_gain_field()
    memory_leak: float = settings.cpu4_leak_field()
    foraging_turn_std: float = settings.foraging_turn_field("std of the random turn command per gait cycle "
                                                            "(clipped to [-1, 1])")
    foraging_stride_deg: float = settings.foraging_stride_field()
    timestep_s: float = field(0.002, "physics step (s), a whole fraction of the 8 ms control step",
                              min=1e-4, max=0.008)
    variability: str = variability_field()
    compass_noise_deg: float = settings.compass_noise_field()
    odometry_noise_fraction: float = settings.odometry_noise_field()
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()


def home_positions(ants: int, spacing_m: float) -> np.ndarray:
    """Homes (ants, 2) m on a sunflower (Vogel) spiral about the origin: ant j at radius c·sqrt(j + 1/2),
    turned by the golden angle from ant j - 1. Its nearest neighbours are at least 1.546 c apart
    (for every count; measured), so c = spacing_m / 1.54 keeps homes ``spacing_m`` apart (checked by
    a test) while filling a disc evenly."""
    index = np.arange(ants)
    radius = spacing_m / 1.54 * np.sqrt(index + 0.5)
    angle = index * GOLDEN_ANGLE_RAD
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])


def steering_commands(cpu1: np.ndarray, k_pi: float) -> tuple[np.ndarray, np.ndarray]:
    """(turn θ, stride S_l), each (N,), from CPU1 rates (N, 16): eqs. 3.6-3.7 for every ant at once."""
    theta = np.clip(k_pi * (cpu1[:, 8:].sum(axis=1) - cpu1[:, :8].sum(axis=1)), -1.0, 1.0)
    return theta, MIN_STRIDE_RAD + EXTRA_STRIDE_RAD * (1.0 - np.abs(theta))


class SwarmBodies:
    """The swarm's bodies on one backend: start, command (turn, stride) per ant, advance one control step."""

    def __init__(self, backend: str, config: SwarmHomingConfig) -> None:
        self.backend, self.count = backend, config.ants
        if backend == "kinematic":  # point agents: the batched single backend carries any number
            self.engine = registry.load("backend", "kinematic")(timestep_s=CONTROL_S)
            self.engine.load(SWARM_WORLD, [PointAgents(count=self.count, mode="unicycle")])
            self.gaits, self.physics_steps = None, 1
        else:  # articulated ants colliding in one world: the engine's registered swarm backend
            from neuronav.bodies.desert_ant import desert_ant
            from neuronav.bodies.gaits import make_gait

            ant = desert_ant()
            self.engine = registry.load("swarm_backend", backend)(timestep_s=config.timestep_s)
            self.engine.load(SWARM_WORLD, [ant] * self.count)
            self.gaits = [make_gait("tripod", ant) for _ in range(self.count)]
            self.physics_steps = integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def reset(self, starts_m: np.ndarray, headings_rad: np.ndarray) -> None:
        """Every ant at rest at its start (N, 2) m facing its heading (N,) rad (clockwise from +y); gaits restart."""
        self.engine.reset(position_m=starts_m, heading_rad=headings_rad)
        for gait in self.gaits or ():
            gait.reset()

    def control_step(self, turn: np.ndarray, stride_rad: np.ndarray) -> None:
        """One 8 ms control step at this command: the unicycle takes it, or each ant's gait walks it."""
        if self.gaits is None:
            self.engine.write({"turn": turn[:, None], "stride": stride_rad[:, None]})
        else:
            targets = np.stack([g.step(float(t), float(s)) for g, t, s in zip(self.gaits, turn, stride_rad)])
            self.engine.write({"joint_targets": targets})
        self.engine.step(self.physics_steps)

    def touching(self) -> np.ndarray:
        """Bool (N,): which ants touch another ant (never on the kinematic backend)."""
        return np.zeros(self.count, bool) if self.gaits is None else self.engine.ant_contacts()


def run_swarm(config: SwarmHomingConfig, backend: str, swarm: int, video_path: Path | None = None) -> dict:
    """Simulate swarm number ``swarm``: every ant's log and metrics (see the module docstring); with
    ``video_path``, filmed from above into that MP4 (:class:`~neuronav.scenarios.swarm_homing.film.SwarmFilm`)."""
    film, finished = None, False
    try:
        if video_path is not None:
            from neuronav.scenarios.swarm_homing.film import SwarmFilm  # lazily: only videos need it

            film = SwarmFilm(video_path, SWARM_WORLD, home_positions(config.ants, config.spacing_m),
                             config.nest_radius_m, CONTROL_S, VIDEO_EVERY)
        log = _run_swarm(config, backend, swarm, film)
        finished = True
        return log
    finally:
        if film is not None:
            film.close(finished)


def _run_swarm(config: SwarmHomingConfig, backend: str, swarm: int, film) -> dict:
    n = config.ants
    seeds = [swarm * n + j for j in range(n)]
    homes = home_positions(n, config.spacing_m)
    headings = np.array([np.random.default_rng([s, 3]).uniform(0.0, 2.0 * np.pi) for s in seeds])
    walks = [np.random.default_rng([s, 2]) for s in seeds]
    started = time.perf_counter()
    bodies = SwarmBodies(backend, config)
    bodies.reset(homes, headings)
    cx = stone2017(noise=config.noise, memory_gain=config.memory_gain,
                   memory_leak=config.memory_leak).compile(batch=n, seeds=seeds)
    controls_per_cycle = integer_ratio(CYCLE_S, CONTROL_S, "gait cycle / control step")
    cycles = int(np.ceil((config.outbound_s + config.homing_timeout_s) / CYCLE_S - 1e-9))
    errors = homing_noise(config, seeds, cycles)  # per ant and cycle, from each ant's seed; None: exact
    motors = [motor_noise(config, s) for s in seeds] if errors is not None else None
    positions = np.full((cycles + 1, n, 2), np.nan)
    last = homes.copy()
    turn, stride = np.zeros(n), np.zeros(n)
    home_at = np.full(n, np.nan)
    closest = np.full(n, np.inf)  # nearest approach to home while homing (m), every control step
    contact_s = np.zeros(n)
    turnback_memory = None
    cycle = 0
    for cycle in range(cycles):
        time_s = cycle * CYCLE_S
        sensed = bodies.engine.read(("heading", "position"))
        position = sensed["position"]
        positions[cycle] = position
        heading, velocity = sensed["heading"], position - last  # rad, metres per gait cycle
        if errors is not None:
            heading = heading + errors["compass"][:, cycle, None]
            velocity = velocity * (1.0 + errors["odometry"][:, cycle, None])
        cx.step({"heading": heading, "velocity": velocity})
        last = position
        if time_s < config.outbound_s:
            noise = np.array([w.normal(0.0, config.foraging_turn_std) for w in walks])
            turn = np.clip(0.7 * turn + noise, -1.0, 1.0)
            stride = np.full(n, np.radians(config.foraging_stride_deg))
        else:
            if turnback_memory is None:
                turnback_memory = cx.memory("CPU4").copy()
                _arrivals(position, homes, home_at, closest, time_s, config.nest_radius_m)
            if np.isfinite(home_at).all():
                break
            turn, stride = steering_commands(cx.rates("CPU1"), config.k_pi)
        command_turn, command_stride = turn, stride
        if motors is not None:  # what each ant's legs make of its command (the foraging walk's state stays exact)
            command_turn, command_stride = np.array([m(float(t), float(s))
                                                     for m, t, s in zip(motors, turn, stride)]).reshape(n, 2).T.copy()
        for step in range(controls_per_cycle):
            done = np.isfinite(home_at)
            command_turn[done], command_stride[done] = 0.0, 0.0  # an ant at home stands
            bodies.control_step(command_turn, command_stride)
            contact_s += CONTROL_S * bodies.touching()
            if turnback_memory is not None:
                position = bodies.engine.read(("position",))["position"]
                _arrivals(position, homes, home_at, closest, time_s + (step + 1) * CONTROL_S,
                          config.nest_radius_m)
            if film is not None and (cycle * controls_per_cycle + step) % film.every == 0:
                pose = bodies.engine.read(("position", "heading"))
                film.film(pose["position"], pose["heading"], home_at, turnback_memory is not None,
                          time_s + (step + 1) * CONTROL_S, cx.memory("CPU4")[0])
    else:
        cycle = cycles
    end_s = cycle * CYCLE_S
    positions[cycle] = bodies.engine.read(("position",))["position"]
    if turnback_memory is None:
        turnback_memory = cx.memory("CPU4").copy()
    wall_s = time.perf_counter() - started
    return {"positions": positions, "homes": homes, "home_at": home_at, "contact_s": contact_s,
            "turnback_memory": turnback_memory, "closest": closest, "end_s": end_s, "wall_s": wall_s}


def _arrivals(position: np.ndarray, homes: np.ndarray, home_at: np.ndarray, closest: np.ndarray, time_s: float,
              radius_m: float) -> None:
    """Mark ``time_s`` in ``home_at`` for the ants not yet home that are within ``radius_m`` of home now,
    and lower ``closest`` (m) to each ant's distance from home where it is nearer."""
    distance = np.hypot(*(position - homes).T)
    np.minimum(closest, distance, out=closest)
    home_at[np.isnan(home_at) & (distance <= radius_m)] = time_s


def ant_metrics(log: dict, ant: int, swarm: int, config: SwarmHomingConfig) -> dict:
    """One ant's row: success, homing time, closest approach, straightness, decode error, contact time."""
    path = log["positions"][:, ant] - log["homes"][ant]
    path = path[np.isfinite(path[:, 0])]
    turnback = min(int(round(config.outbound_s / CYCLE_S)), len(path) - 1)
    distance = np.hypot(path[:, 0], path[:, 1])
    homing = distance[turnback:]
    closest = int(np.argmin(homing))
    walked = np.linalg.norm(np.diff(path[turnback:turnback + closest + 1], axis=0), axis=1).sum()
    decoded, _ = decode_home_vector(log["turnback_memory"][ant][None, :])
    true_home = np.arctan2(-path[turnback, 0], -path[turnback, 1])
    reached = bool(np.isfinite(log["home_at"][ant]))
    n = config.ants
    return {
        "success": reached, "status": "ok", "error": "", "ant": ant, "swarm": swarm,
        "homing_time_s": float(log["home_at"][ant] - config.outbound_s) if reached else float("nan"),
        "closest_distance_m": float(min(log["closest"][ant], homing.min())),
        "home_distance_m": float(distance[turnback]),
        "straightness": float((distance[turnback] - homing.min()) / walked) if walked > 0 else float("nan"),
        "decode_error_deg": float(np.degrees(abs(angle_difference_rad(decoded[0], true_home)))),
        "ant_contact_s": float(log["contact_s"][ant]),
        "ant_seconds_per_wall_s": float(n * log["end_s"] / log["wall_s"]) if log["wall_s"] > 0 else float("nan"),
    }


def check_bodies(config: SwarmHomingConfig, backend: str) -> None:
    """MuJoCo: at most 31 ants (one contact bit each); physics: a whole fraction of the 8 ms control step.

    Raises
    ------
    ConfigError
        Naming the setting and what is allowed.
    """
    if backend == "kinematic":
        return
    if backend == "mujoco" and config.ants > MAX_PHYSICS_ANTS:
        raise ConfigError(f"swarm-homing on {backend}: ants must be at most {MAX_PHYSICS_ANTS} (one contact "
                          f"bit each), got {config.ants}; e.g. --set ants=16")
    integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")


class SwarmHoming(Scenario):
    """Many ants, each with its own CX, in one world: foraging walks from scattered homes, then homing."""

    name = "swarm-homing"
    description = "many ants in one world, each with its own CX: scattered foraging walks, then homing"
    config_type = SwarmHomingConfig
    backends = ("kinematic", "mujoco", "pybullet")
    default_backend = "kinematic"
    timing_metrics = ("ant_seconds_per_wall_s",)
    records_video = True  # the first trial's swarm from above (film.py), on every backend
    # An ant that never gets home has no homing time; one that did not move on its way home no straightness.
    optional_metrics = ("homing_time_s", "straightness")

    def smoke_config(self) -> dict:
        return {"ants": 4, "outbound_s": 3.2, "homing_timeout_s": 3.2}

    def statistics(self, config: SwarmHomingConfig) -> Statistics:
        """One group (the ants of the run): success with its Wilson interval and the ants' homing
        measures with bootstrap intervals (not ``ant`` and ``swarm``, which are indices)."""
        return Statistics(condition=None, metrics=("homing_time_s", "closest_distance_m", "home_distance_m",
                                                   "straightness", "decode_error_deg", "ant_contact_s"))

    def leading_series(self, config: SwarmHomingConfig, backend: str) -> dict[str, int]:
        """The first trial's whole swarm, stored once."""
        return dict.fromkeys(("swarm_position_m", "swarm_home_m", "swarm_home_at_s"), 1)

    @staticmethod
    def swarm_bytes(config: SwarmHomingConfig) -> int:
        """Memory one swarm of ``config.ants`` ants needs for the whole of one run (see ``SWARM_BYTES_PER_*``)."""
        cycles = int(np.ceil((config.outbound_s + config.homing_timeout_s) / CYCLE_S - 1e-9)) + 1
        return config.ants * (SWARM_BYTES_PER_ANT_CYCLE * cycles + SWARM_BYTES_PER_ANT)

    def estimate_bytes(self, config: SwarmHomingConfig, trials: int) -> int | None:
        """Memory one batch of ``trials`` trials needs: every swarm it touches (trials of one swarm may
        straddle two, from any seed) and each trial's own trajectory."""
        cycles = int(np.ceil((config.outbound_s + config.homing_timeout_s) / CYCLE_S - 1e-9)) + 1
        swarms = min(trials, -(-trials // config.ants) + 1)
        return swarms * self.swarm_bytes(config) + trials * (TRIAL_BYTES_PER_CYCLE * cycles + TRIAL_BYTES)

    def check(self, config: SwarmHomingConfig, backend: str) -> None:
        """One swarm must fit in the memory available (:meth:`swarm_bytes`), and :func:`check_bodies`.

        Raises
        ------
        ConfigError
            Naming the settings and what is allowed.
        """
        needed, available = self.swarm_bytes(config), sweep.available_memory_bytes()
        if available is not None and needed > available:
            raise ConfigError(f"swarm-homing: ants={config.ants} for outbound_s + homing_timeout_s = "
                              f"{config.outbound_s + config.homing_timeout_s:g} s need about {needed / 2**30:.1f} GiB "
                              f"for one swarm, more than the {available / 2**30:.1f} GiB available; fewer ants or "
                              "shorter times")
        check_bodies(config, backend)

    def run(self, config: SwarmHomingConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        check_bodies(config, backend)  # (the memory was checked when the run was planned, not per chunk)
        n = config.ants
        logs: dict[int, dict] = {}
        rows, paths, homes = [], [], []
        for s in range(seed, seed + trials):
            swarm, ant = divmod(s, n)
            if swarm not in logs:  # the first trial's swarm filmed (a run's first chunk gets the video path)
                logs[swarm] = run_swarm(config, backend, swarm, video_path if s == seed else None)
            log = logs[swarm]
            rows.append(ant_metrics(log, ant, swarm, config))
            paths.append(log["positions"][:, ant])
            homes.append(log["homes"][ant])
        first = logs[seed // n]
        positions = np.array(paths, np.float32)  # (trials, cycles + 1, 2), NaN after the swarm stopped
        clock_s = np.arange(positions.shape[1], dtype=np.float32) * np.float32(CYCLE_S)
        timeseries = {
            "position_m": positions,
            "time_s": np.where(np.isfinite(positions[..., 0]), clock_s, np.float32(np.nan)),  # each sample's time
            "home_m": np.array(homes),
            # The first trial's whole swarm, with a leading axis of 1 (not per trial): (1, ants, cycles + 1, 2).
            "swarm_position_m": first["positions"].transpose(1, 0, 2)[None].astype(np.float32),
            "swarm_home_m": first["homes"][None],
            "swarm_home_at_s": first["home_at"][None],
        }
        return ScenarioResult(trials=rows, timeseries=timeseries,
                              simulated_time_s=float(np.mean([log["end_s"] for log in logs.values()])))

    def figures(self, result: ScenarioResult, config: SwarmHomingConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.swarm_homing.figures import write_figures

        return write_figures(result, config, Path(out_dir))
