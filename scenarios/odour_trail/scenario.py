"""Odour trail following with fixed or sweeping antennae (the I2Bot paper's §2.5.1, Fig. 6a–d).

An odour trail is drawn on the floor (:class:`neuronav.senses.odour.PolylineTrail` along
:data:`TRAIL_VERTICES_M`, concentration 1 on it, 0 off it; ``width`` narrow 0.11 m, normal 0.27 m,
wide 1.4 m). The ant starts on it, 0.4 m from its beginning, facing along it, its end 5 m away.
Once per gait cycle (0.64 s) the brain steers by Table 3 (:class:`neuronav.brains.trail_following.TrailFollowing`)
from what its two odour sites sensed: each site's highest concentration during the cycle, sampled every
8 ms control step (``sensing=cycle_peak``, :class:`OdourPeakHook`), or the concentration at that moment
(``sensing=instant``). The antennae rest ``antenna_yaw_rad`` outward and are ``fixed`` or ``moving``
(swept in yaw ±0.7 rad with a noisy rhythm, :class:`neuronav.bodies.antennae.AntennaSweep`, seeded per
trial); ``both`` alternates them by the trial seed (even: fixed, odd: moving).

Metrics per trial: ``success`` (the body centre reached the trail's last ``success_radius_m`` of arc
length, within ``width / 2 + reach_m`` of the centre line), ``finish_time_s`` (NaN if never),
``completion`` (the furthest arc length reached while within that reach, from the start to the end;
1 on success), ``time_on_trail`` (the fraction of gait cycles with the body centre or an antenna on the
trail, concentration >= 0.5), ``mean_offset_m`` (the body centre's mean distance from the trail's centre
line, once per gait cycle and at the end); per antenna mode their means and the median finish time. Each row's
``antennae_moving`` (0 fixed, 1 moving) is the condition the summary's statistics compare.

Variability (``variability=on``, the default): start jitter (:func:`start_pose`), odour-reading and motor
noise (:class:`TrailNoise`), each from its own stream of the trial's seed; ``off``: the paper's protocol.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav.bodies.antennae import AntennaSweep, AntennaYawHook, SweptAntennaeGait
from neuronav.brains.trail_following import K_D, SENSOR_SCALE, T_D, T_O, TrailFollowing
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.engine.video_overlay import OdourInset, VideoContent
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.aggregation import finite_median_of, mean_of, per_condition, success_rate
from neuronav.scenarios.motor_noise import MotorNoise, stride_noise_field, turn_noise_field
from neuronav.scenarios.trial_loop import pack_cycle_logs, run_loop, trials_one_by_one
from neuronav.scenarios.variability import is_on, jitter_start, normal_per_trial, trial_generators, variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.scenarios.worlds.scenes import pack_world, vision_appearance, world_record
from neuronav.senses.chemistry import OdourScene
from neuronav.senses.odour import TRAIL_WIDTHS_M, PolylineTrail
from neuronav.spec.world import Ground, World

ANTENNA_MODES = ("fixed", "moving")
WIDTHS = tuple(TRAIL_WIDTHS_M)
# The trail's centre line (m), the ant starting at the origin facing +y (heading 0): it begins 0.4 m
# behind the start and ends 5.0 m from it; 7.9 m long, bending 63° right, 127° left, 63° right (a
# straight walk from the start to the end leaves even the wide trail: (0, 2.5) is 0.89 m from it).
TRAIL_VERTICES_M = ((0.0, -0.4), (0.0, 1.0), (0.8, 2.0), (0.8, 3.0), (0.0, 4.0), (0.0, 5.0))
START_HEADING_RAD = 0.0
DEFAULT_ANTENNA_LENGTH_M = 0.541
# Rest yaw of the antennae (rad, outward): their odour sites 0.23 m apart, inside the normal trail.
DEFAULT_ANTENNA_YAW_RAD = 0.25
SENSING = ("cycle_peak", "instant")
# Concentration at or above which a point is "on the trail" (the trail's border, full width at half maximum).
ON_TRAIL = 0.5


@dataclass
class OdourTrailConfig:
    antennae: str = field("both", "fixed antennae, moving (swept ±0.7 rad), or both (trial seed even: fixed, "
                          "odd: moving)", choices=("both", *ANTENNA_MODES))
    width: str = field("normal", "trail width: narrow 0.11 m, normal 0.27 m, wide 1.4 m", choices=WIDTHS)
    edge_m: float = field(0.02, "width of the trail's raised-cosine border (m; at most the trail's width)",
                          min=0.0, max=1.4)
    antenna_length_m: float = field(DEFAULT_ANTENNA_LENGTH_M, "the ant's antenna length (scape + funiculus), m",
                                    min=0.1, max=1.5)
    antenna_yaw_rad: float = field(DEFAULT_ANTENNA_YAW_RAD, "rest yaw of the antennae, outward (rad; the body's "
                                   "default 0.6 puts the odour sites 0.43 m apart, 0.25: 0.23 m)", min=-0.9, max=0.9)
    sensing: str = field("cycle_peak", "what the brain reads once per gait cycle: each antenna's highest "
                         "concentration since the last cycle (cycle_peak) or its concentration now (instant)",
                         choices=SENSING)
    t_d: float = field(T_D, "Table 3 dead band on |O_l - O_r|, sensor units (paper: 5)", min=0.0, max=1e4)
    t_o: float = field(T_O, "Table 3 odour threshold, sensor units (paper: 900)", min_exclusive=0.0, max=1e4)
    k_d: float = field(K_D, "Table 3 turn gain: turn = O_d / k_d (paper: 400)", min_exclusive=0.0, max=1e5)
    sensor_scale: float = field(SENSOR_SCALE, "sensor units per unit of trail concentration (O = scale c)",
                                min_exclusive=0.0, max=1e5)
    success_radius_m: float = field(0.5, "success: the body centre reaches the trail's last this many metres, "
                                    "within width / 2 + reach_m of it (m)", min_exclusive=0.0, max=3.0)
    reach_m: float = field(0.5, "completion counts progress while the body centre is within width / 2 + this "
                           "of the trail (m)", min=0.0, max=3.0)
    timeout_s: float = settings.trial_timeout_field(90.0, "sniff")
    timestep_s: float = settings.timestep_field()
    variability: str = variability_field()
    start_position_sd_m: float = field(0.02, "std of the start's offset in x and in y (m; variability=on)",
                                       min=0.0, max=0.5)
    start_heading_sd_deg: float = field(5.0, "std of the start heading's offset from along the trail (deg; "
                                        "variability=on)", min=0.0, max=90.0)
    odour_noise_sd: float = field(1.0, "std of the error on each antenna's odour reading, per gait cycle "
                                  "(sensor units, as t_d and t_o; variability=on)", min=0.0, max=1e3)
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()

    def controller(self) -> TrailFollowing:
        return TrailFollowing(t_d=self.t_d, t_o=self.t_o, k_d=self.k_d, sensor_scale=self.sensor_scale)


def antenna_mode(config: OdourTrailConfig, seed: int) -> str:
    """The antennae trial ``seed`` uses."""
    return ANTENNA_MODES[seed % 2] if config.antennae == "both" else config.antennae


def start_pose(config: OdourTrailConfig, seed: int) -> tuple[np.ndarray, float]:
    """Trial ``seed``'s start: position (x, y) m and heading (clockwise from +y) rad — the origin
    facing along the trail, moved by the start jitter when ``variability`` is on."""
    origin = np.zeros(2)
    if not is_on(config):
        return origin, START_HEADING_RAD
    position, heading = jitter_start(trial_generators([seed], "start"), origin[None], np.array([START_HEADING_RAD]),
                                     config.start_position_sd_m, np.radians(config.start_heading_sd_deg))
    return position[0], float(heading[0])


class TrailNoise:
    """Trial ``seed``'s sensor and motor noise, one draw per gait cycle from its own streams (none
    with ``variability=off``): the odour readings (:meth:`odour`), then the command
    (:class:`neuronav.scenarios.motor_noise.MotorNoise`, :attr:`command`)."""

    def __init__(self, config: OdourTrailConfig, seed: int) -> None:
        on = is_on(config)
        self.odour_sd = config.odour_noise_sd / config.sensor_scale if on else 0.0
        self.odour_rng = trial_generators([seed], "odour")
        self.command = MotorNoise(seed, config.turn_noise_sd if on else 0.0,
                                  config.stride_noise_fraction if on else 0.0)

    def odour(self, left: float, right: float) -> tuple[float, float]:
        """The readings (concentration) with this cycle's errors."""
        error = normal_per_trial(self.odour_rng, (2,), self.odour_sd)[0]
        return left + float(error[0]), right + float(error[1])


def make_trail(width: str, edge_m: float = 0.02) -> PolylineTrail:
    """The scenario's trail (:data:`TRAIL_VERTICES_M`) at a preset width, its border ``edge_m`` wide
    (at most the width)."""
    return PolylineTrail(np.array(TRAIL_VERTICES_M), width, min(edge_m, TRAIL_WIDTHS_M[width]))


def trail_world(trail: PolylineTrail) -> World:
    """A plain floor (the trail shows on it in the videos) smelling of ``trail``."""
    return World(ground=Ground(size_m=16.0), appearance=vision_appearance(), odour=OdourScene(trails=(trail,)))


def arc_length_m(trail: PolylineTrail, points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Arc length (m) along the centre line of each point's nearest point on it, and the distance.

    Parameters
    ----------
    points_m : ndarray, shape (P, 2)

    Returns
    -------
    arc_m, distance_m : ndarray, shape (P,)
    """
    vertices = np.asarray(trail.vertices_m, float)
    starts, deltas = vertices[:-1], np.diff(vertices, axis=0)
    lengths = np.linalg.norm(deltas, axis=1)
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    rel = np.asarray(points_m, float)[:, None, :] - starts[None]
    t = np.clip(np.einsum("psk,sk->ps", rel, deltas) / lengths**2, 0.0, 1.0)
    off = rel - t[..., None] * deltas[None]
    distance = np.linalg.norm(off, axis=2)
    nearest = np.argmin(distance, axis=1)
    rows = np.arange(len(rel))
    return cumulative[nearest] + t[rows, nearest] * lengths[nearest], distance[rows, nearest]


class OdourPeakHook(Hook):
    """Keeps each antenna's highest concentration since it was last taken, read after every control
    step (8 ms): what the antennae met during a gait cycle, sweeping or not."""

    def __init__(self) -> None:
        self.peak: np.ndarray | None = None

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.peak = None

    def after_step(self, loop: AgentLoop) -> None:
        now = loop.backend.read(("odour",))["odour"][0, :2, 0]
        self.peak = now.copy() if self.peak is None else np.maximum(self.peak, now)

    def take(self) -> np.ndarray | None:
        """The (left, right) peaks since the last take (None before the first step), and start again."""
        peak, self.peak = self.peak, None
        return peak


class TrailBrain:
    """Antennae -> Table 3 -> (θ, S_l), once per gait cycle; logs what it sensed and did.

    With ``sensing="cycle_peak"`` it reads ``peaks`` (an :class:`OdourPeakHook` in the loop), else the
    concentrations at that moment.
    """

    def __init__(self, config: OdourTrailConfig, trail: PolylineTrail, seed: int,
                 peaks: OdourPeakHook | None = None) -> None:
        self.controller, self.trail, self.peaks = config.controller(), trail, peaks
        self.rng = np.random.default_rng([seed, 12])
        self.noise = TrailNoise(config, seed)
        self.log: dict[str, list] = {k: [] for k in ("time_s", "position_m", "heading_rad", "odour_L", "odour_R",
                                                     "centre_odour", "turn", "stride_rad")}

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed = loop.backend.read(("odour", "position", "heading"))
        odour = sensed["odour"][0, :2, 0]
        peak = self.peaks.take() if self.peaks is not None else None
        left, right = self.noise.odour(*(float(v) for v in (np.maximum(peak, odour) if peak is not None else odour)))
        turn, stride = self.noise.command(*self.controller(left, right, self.rng))
        position = sensed["position"][0]
        centre = float(self.trail.concentration_at(position))
        for key, value in (("time_s", loop.time_s), ("position_m", position), ("heading_rad", sensed["heading"][0, 0]),
                           ("odour_L", left), ("odour_R", right), ("centre_odour", centre), ("turn", turn),
                           ("stride_rad", stride)):
            self.log[key].append(np.array(value, float))
        return turn, stride


def trail_trial(config: OdourTrailConfig, backend_name: str, seed: int, video_path=None) -> tuple[dict, dict]:
    """One trial: the metrics row and the per-cycle log."""
    mode = antenna_mode(config, seed)
    trail = make_trail(config.width, config.edge_m)
    engine, body, gait, physics_dt = make_engine(backend_name, config.timestep_s,
                                                 antenna_length_m=config.antenna_length_m,
                                                 antenna_yaw_rad=config.antenna_yaw_rad)
    sweep = AntennaSweep(mode, seed=seed)
    hooks = ()
    if gait is None:
        hooks = (AntennaYawHook(sweep, seed=seed),)
    else:
        gait = SweptAntennaeGait(gait, sweep, body, CONTROL_S, seed=seed)
    peaks = OdourPeakHook() if config.sensing == "cycle_peak" else None
    hooks = (*hooks, *([peaks] if peaks is not None else []))
    brain = TrailBrain(config, trail, seed, peaks)
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)

    def arrived(lp: AgentLoop) -> bool:
        position = lp.backend.read(("position",))["position"][0]
        return bool(at_trail_end(trail, config, position[None])[0])

    start_m, heading_rad = start_pose(config, seed)
    loop, final, wall_s = run_loop(engine, trail_world(trail), body, gait, clocks, brain, heading_rad=heading_rad,
                                   seed=seed, duration_s=config.timeout_s, until=arrived, hooks=hooks,
                                   video_path=video_path, position_m=tuple(start_m),
                                   video_content=VideoContent(insets=(OdourInset(full_scale=1.0),)))
    log = {k: np.array(v, float) for k, v in brain.log.items()}
    log["position_m"] = np.vstack([log["position_m"], final[None]])
    log["world"] = world_record(trail_world(trail), finish_line_m=end_line_m(trail, config))
    return trail_metrics(log, config, trail, mode, loop.time_s, wall_s), log


def at_trail_end(trail: PolylineTrail, config: OdourTrailConfig, points_m: np.ndarray) -> np.ndarray:
    """Whether each point (P, 2) reached the trail's end: within reach of the trail (``width / 2 +
    reach_m`` of its centre line) and in its last ``success_radius_m`` (arc length)."""
    arc, distance = arc_length_m(trail, points_m)
    return (distance <= trail.width_m / 2 + config.reach_m) & (arc >= trail.length_m - config.success_radius_m)


def end_line_m(trail: PolylineTrail, config: OdourTrailConfig) -> np.ndarray:
    """The finish line (2, 2): across the trail, ``success_radius_m`` before its end, as wide as the
    reach that counts (``width / 2 + reach_m`` either side)."""
    vertices = np.asarray(trail.vertices_m, float)
    direction = vertices[-1] - vertices[-2]
    direction /= np.linalg.norm(direction)
    centre = vertices[-1] - config.success_radius_m * direction  # the last segment is longer than the radius
    across = np.array([-direction[1], direction[0]]) * (trail.width_m / 2 + config.reach_m)
    return np.array([centre - across, centre + across])


def trail_metrics(log: dict, config: OdourTrailConfig, trail: PolylineTrail, mode: str, trial_time_s: float,
                  wall_s: float) -> dict:
    """Success, finish time, completion and time on the trail of one trial (the module docstring)."""
    path = log["position_m"]
    reached = bool(at_trail_end(trail, config, path[-1:])[0])
    arc, distance = arc_length_m(trail, path)
    start_arc = float(arc[0])
    within = distance <= trail.width_m / 2 + config.reach_m
    furthest = float(arc[within].max()) if within.any() else start_arc
    completion = 1.0 if reached else float(np.clip((furthest - start_arc) / (trail.length_m - start_arc), 0.0, 1.0))
    on = ((log["centre_odour"] >= ON_TRAIL) | (log["odour_L"] >= ON_TRAIL) | (log["odour_R"] >= ON_TRAIL))
    return {
        "success": reached, "status": "ok", "error": "",
        "antennae_moving": float(ANTENNA_MODES.index(mode)),
        "width_m": float(trail.width_m),
        "finish_time_s": float(trial_time_s) if reached else float("nan"),
        "completion": completion,
        "time_on_trail": float(on.mean()) if on.size else 0.0,
        "mean_offset_m": float(distance.mean()),
        "trial_time_s": float(trial_time_s),
        "real_time_factor": float(trial_time_s / wall_s) if wall_s > 0 else float("nan"),
    }


class OdourTrail(Scenario):
    """Trail following with fixed or sweeping antennae on every backend."""

    name = "odour-trail"
    description = "follow an odour trail on the floor with fixed or sweeping antennae: Table 3 control (paper §2.5.1)"
    config_type = OdourTrailConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    timing_metrics = ("real_time_factor",)
    # NaN by definition: the finish time of an ant that never reached the end (per trial, and the
    # median of a condition none of whose trials did).
    optional_metrics = ("finish_time_s", *(f"median_finish_{m}_s" for m in ANTENNA_MODES))

    def smoke_config(self) -> dict:
        return {"timeout_s": 2.0}

    def check(self, config: OdourTrailConfig, backend: str) -> None:
        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")
        if config.success_radius_m >= 5.0:
            raise ConfigError(f"success_radius_m ({config.success_radius_m:g}) must be < 5 m: the ant would "
                              f"succeed where it starts")

    def aggregate(self, trials: list[dict], config: OdourTrailConfig) -> dict:
        """Per antenna mode (among the finished trials): the fraction that reached the end, the mean
        completion and time on the trail, and the median finish time of those that finished."""
        return per_condition(trials, "antennae_moving", {
            "success_{}": success_rate, "completion_{}": mean_of("completion"),
            "time_on_trail_{}": mean_of("time_on_trail"), "median_finish_{}_s": finite_median_of("finish_time_s"),
        }, labels=dict(enumerate(ANTENNA_MODES)))

    def statistics(self, config: OdourTrailConfig) -> Statistics:
        """Moving antennae (``antennae_moving`` 1.0) against fixed ones (0.0): finish time, completion,
        time on the trail and the mean offset from it (Mann-Whitney U), reaching the end (Fisher's exact
        test)."""
        return Statistics(condition="antennae_moving", metrics=("finish_time_s", "completion", "time_on_trail",
                                                                "mean_offset_m"), reference=0.0)

    def run(self, config: OdourTrailConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        rows, logs = trials_one_by_one(lambda s, video: trail_trial(config, backend, s, video), trials, seed,
                                       video_path)
        return ScenarioResult(trials=rows, timeseries=pack_logs(logs), aggregates=self.aggregate(rows, config),
                              simulated_time_s=float(np.mean([r["trial_time_s"] for r in rows])))

    def figures(self, result: ScenarioResult, config: OdourTrailConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.odour_trail.figures import write_trail_figures

        return write_trail_figures(result, config, Path(out_dir))


def pack_logs(logs: list[dict]) -> dict[str, np.ndarray]:
    """Per-cycle logs of unequal length as NaN-padded arrays (trials, cycles, ...), and the world: the
    trail's centre line ``trail_m`` and its finish line ``finish_line_m`` (:func:`end_line_m`)."""
    packed = pack_cycle_logs(logs, ("time_s", "heading_rad", "odour_L", "odour_R", "centre_odour", "turn",
                                    "stride_rad"))
    packed.update(pack_world([log["world"] for log in logs]))
    return packed
