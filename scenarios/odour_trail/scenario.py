"""Odour trail following with fixed or sweeping antennae (the I2Bot paper's §2.5.1, Fig. 6a–d).

An odour trail is drawn on the floor (:class:`neuronav.senses.odour.PolylineTrail`, concentration 1 on it,
0 off it, widths narrow 0.11 m, normal 0.27 m, wide 1.4 m). The ant starts on the trail, 0.4 m
from its beginning, facing along it, with the trail's end 5 m away in a straight line (the paper:
every agent starts at the same place with the same heading, walking toward the end). The trail
(:data:`TRAIL_VERTICES_M`, 6.0 m) steps 0.8 m to the right and back, with four 39° bends, so that an
ant that only walked straight would leave it (even the wide one: 0.8 m from its centre line).

Once per gait cycle (0.64 s) the brain steers by the paper's Table 3
(:class:`neuronav.brains.trail_following.TrailFollowing`: search with random turns when neither antenna smells
the trail, turn toward the stronger side when they differ, else straight) from what its two odour
sites sensed: by default (``sensing=cycle_peak``) each site's highest concentration during the cycle
(sampled every 8 ms control step, :class:`OdourPeakHook`: what the antenna met, as a receptor's
response outlasts a brief contact), or (``sensing=instant``) the concentration at that moment.
The antennae are ``fixed`` at rest, or ``moving``: both sweep in yaw ±0.7 rad with a noisy rhythm
(:class:`neuronav.bodies.antennae.AntennaSweep`, the defaults of ``bodies/antennae.py``, seeded per trial).
``both`` alternates them by the trial seed (even: fixed, odd: moving), so one run compares them.
They rest 0.25 rad outward (``antenna_yaw_rad``; the body's default is I2Bot's 0.6): their odour
sites 0.23 m apart, inside the normal trail. The paper's finding needs it: with the body's 0.6 rad
the sites sit 0.43 m apart, both off the 0.27 m trail whenever the ant is centred on it, and no
ant follows the normal trail (measured before this default: completion 0.02–0.16 on both engines).

Metrics per trial
-----------------
``success``: the body centre reached the trail's end — its last ``success_radius_m`` of arc length,
within ``width / 2 + reach_m`` of the centre line (the finish line in the figure).
``finish_time_s``: when it did (NaN when it never did). ``completion``: how far along the trail
the ant got, the furthest arc length of its body centre's projection on the centre line among the
moments it was within reach of the trail (centre within ``width / 2 + reach_m``), from the start's
arc length to the end (1 when it succeeded). ``time_on_trail``: the fraction of gait cycles at
which the body centre or an antenna stood on the trail (concentration >= 0.5).

The paper's finding, measured
-----------------------------
``neuronav run odour-trail --backend B --trials 20 --seed 0 --set width=W`` (``both``: 10 fixed,
10 moving; every other setting at its default; timeout 90 s):

=========  ======  ======================  ===================  ============================
backend    width   completion fixed/mov    success fixed/mov    median finish fixed/mov (s)
=========  ======  ======================  ===================  ============================
mujoco     normal  0.966 / 0.957           8/10 / 9/10          28.8 / 23.5
mujoco     wide    0.936 / 1.000           8/10 / 10/10         21.4 / 15.8
pybullet   normal  1.000 / 1.000           10/10 / 10/10        26.2 / 21.4
pybullet   wide    0.885 / 1.000           7/10 / 10/10         24.1 / 17.3
kinematic  normal  1.000 / 1.000           10/10 / 10/10        36.5 / 29.5
kinematic  wide    0.901 / 1.000           7/10 / 10/10         29.1 / 19.4
=========  ======  ======================  ===================  ============================

On the normal trail moving antennae do as well as fixed ones (both follow it to the end); on the
wide trail they do clearly better: every moving trial reaches the end, 26–33 % sooner, while 2–3
fixed trials of 10 lose the trail. Seeds 20–39 on MuJoCo (``--seed 20``): normal 10/10 and 10/10
(28.8 / 24.4 s), wide 9/10 and 10/10 (21.4 / 15.5 s). Why: on the wide trail the fixed sites, 0.23 m
apart in a 1.4 m trail, both smell it until the ant is nearly off it, so at a bend the ant walks
straight until one leaves, and sometimes both leave together (Table 3 then searches on the spot and
may not find it again); the sweep reaches 0.3 m to either side, so the cycle's peak loses one side
first and the ant turns back earlier. On the normal trail the sweep's extra reach costs nothing,
because the cycle's peak still finds the trail under each site.

Reading one moment per cycle (``--set sensing=instant``, MuJoCo, seed 0) loses this: the fixed ant
leaves the normal trail at its bends (0/10 reach the end, completion 0.76; moving 1/10, 0.66), and on
the wide trail fixed and moving ants do alike (10/10 and 9/10, 18.3 / 19.4 s).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav.bodies.antennae import AntennaSweep, AntennaYawHook, SweptAntennaeGait
from neuronav.brains.trail_following import K_D, SENSOR_SCALE, T_D, T_O, TrailFollowing
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.scenarios import EVERY_BACKEND
from neuronav.scenarios.trial_loop import pack_cycle_logs, run_loop, trials_one_by_one
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.scenarios.worlds.scenes import vision_appearance
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
    timeout_s: float = field(90.0, "a trial gives up after this long (s): at least one gait cycle, one sniff",
                             min=CYCLE_S, max=3600.0)
    timestep_s: float = field(0.002, "physics step of the body (s); the kinematic unicycle steps every 8 ms",
                              min=1e-4, max=0.008)

    def controller(self) -> TrailFollowing:
        return TrailFollowing(t_d=self.t_d, t_o=self.t_o, k_d=self.k_d, sensor_scale=self.sensor_scale)


def antenna_mode(config: OdourTrailConfig, seed: int) -> str:
    """The antennae trial ``seed`` uses."""
    return ANTENNA_MODES[seed % 2] if config.antennae == "both" else config.antennae


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
        self.log: dict[str, list] = {k: [] for k in ("time_s", "position_m", "heading_rad", "odour_L", "odour_R",
                                                     "centre_odour", "turn", "stride_rad")}

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed = loop.backend.read(("odour", "position", "heading"))
        odour = sensed["odour"][0, :2, 0]
        peak = self.peaks.take() if self.peaks is not None else None
        left, right = (float(v) for v in (np.maximum(peak, odour) if peak is not None else odour))
        turn, stride = self.controller(left, right, self.rng)
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

    loop, final, wall_s = run_loop(engine, trail_world(trail), body, gait, clocks, brain, heading_rad=START_HEADING_RAD,
                                   seed=seed, duration_s=config.timeout_s, until=arrived, hooks=hooks,
                                   video_path=video_path)
    log = {k: np.array(v, float) for k, v in brain.log.items()}
    log["position_m"] = np.vstack([log["position_m"], final[None]])
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
        result = {}
        for k, mode in enumerate(ANTENNA_MODES):
            rows = [t for t in trials if t.get("status", "ok") == "ok" and t.get("antennae_moving") == k]
            if not rows:
                continue
            times = [t["finish_time_s"] for t in rows if np.isfinite(t["finish_time_s"])]
            result[f"success_{mode}"] = float(np.mean([bool(t["success"]) for t in rows]))
            result[f"completion_{mode}"] = float(np.mean([t["completion"] for t in rows]))
            result[f"time_on_trail_{mode}"] = float(np.mean([t["time_on_trail"] for t in rows]))
            result[f"median_finish_{mode}_s"] = float(np.median(times)) if times else float("nan")
        return result

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
    """Per-cycle logs of unequal length as NaN-padded arrays (trials, cycles, ...)."""
    return pack_cycle_logs(logs, ("time_s", "heading_rad", "odour_L", "odour_R", "centre_odour", "turn",
                                  "stride_rad"))
