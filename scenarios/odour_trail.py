"""Odour trail following with fixed or sweeping antennae (the I2Bot paper's §2.5.1, Fig. 6a–d).

An odour trail is drawn on the floor (:class:`neuronav.odour.PolylineTrail`, concentration 1 on it,
0 off it, widths narrow 0.11 m, normal 0.27 m, wide 1.4 m). The ant starts on the trail, 0.4 m
from its beginning, facing along it, with the trail's end 5 m away in a straight line (the paper:
every agent starts at the same place with the same heading, walking toward the end). The trail
bends three times (:data:`TRAIL_VERTICES_M`: 63° right, 127° left, 63° right), so that an ant that
only walked straight would leave it.

Once per gait cycle (0.64 s) the brain reads the odour at its two antenna tips and steers by the
paper's Table 3 (:class:`brains.trail_following.TrailFollowing`: search with random turns when
neither antenna smells the trail, turn toward the stronger side when they differ, else straight).
The antennae are ``fixed`` at rest, or ``moving``: both sweep in yaw ±0.7 rad with a noisy rhythm
(:class:`bodies.antennae.AntennaSweep`, the defaults of ``bodies/antennae.py``, seeded per trial).
``both`` alternates them by the trial seed (even: fixed, odd: moving), so one run compares them.

Metrics per trial
-----------------
``success``: the body centre came within ``max(success_radius_m, width / 2)`` of the trail's end.
``finish_time_s``: when it did (NaN when it never did). ``completion``: how far along the trail
the ant got, the furthest arc length of its body centre's projection on the centre line among the
moments it was within reach of the trail (centre within ``width / 2 + reach_m``), from the start's
arc length to the end (1 when it succeeded). ``time_on_trail``: the fraction of gait cycles at
which the body centre or an antenna stood on the trail (concentration >= 0.5).

What the model does (measured; the paper's finding does not emerge)
-------------------------------------------------------------------
``neuronav run odour-trail --backend B --trials 20 --seed 0 --set width=W`` (``both``: 10 fixed,
10 moving; defaults otherwise: the body's 0.541 m antennae, Table 3's thresholds, timeout 90 s):

========  ======  ====================  ====================  ============================
backend   width   completion fixed/mov  success fixed/mov     median finish fixed/mov (s)
========  ======  ====================  ====================  ============================
mujoco    normal  0.155 / 0.151         0 / 0                 — / —
mujoco    wide    0.827 / 0.730         5/10 / 3/10           82.2 / 81.5
pybullet  normal  0.021 / 0.027         0 / 0                 — / —
pybullet  wide    0.752 / 0.727         3/10 / 2/10           67.1 / 55.8
kinematic normal  0.069 / 0.074         0 / 0                 — / —
kinematic wide    0.637 / 0.738         0 / 3/10              — / 62.2
========  ======  ====================  ====================  ============================

With ``--set antenna_length_m=0.25`` (odour sites 0.24 m apart, inside the normal trail) on MuJoCo:
normal 0.396 / 0.544 completion (no success), wide 0.841 / 0.703 (5/10 / 1/10, 28.4 / 75.6 s).

Normal trail: the body's odour sites sit 0.43 m apart (tips of 0.541 m antennae), wider than the
0.27 m trail, so whenever the ant is centred on it neither site smells it and Table 3 searches on
the spot; both modes stay near the start. Wide trail: both modes
walk straight along it and get round the first bend; at the 127° bend most ants turn back along
the trail (Table 3 has no sense of direction), some walk back to the trail's start, turn there and
come back (hence finish times near 80 s). On the physics ants sweeping did not help at that bend
(on the kinematic unicycle it did, a little).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bodies.antennae import AntennaSweep, AntennaYawHook, SweptAntennaeGait
from brains.trail_following import K_D, SENSOR_SCALE, T_D, T_O, TrailFollowing
from neuronav.chemistry import OdourScene
from neuronav.config import field
from neuronav.errors import ConfigError
from neuronav.loop import AgentLoop, Clocks, integer_ratio
from neuronav.odour import TRAIL_WIDTHS_M, PolylineTrail
from neuronav.scenario import Scenario, ScenarioResult
from neuronav.scenery import vision_appearance
from neuronav.world import Ground, World
from scenarios import EVERY_BACKEND
from scenarios.trial_loop import pack_cycle_logs, run_loop, trials_one_by_one
from scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine

ANTENNA_MODES = ("fixed", "moving")
WIDTHS = tuple(TRAIL_WIDTHS_M)
# The trail's centre line (m), the ant starting at the origin facing +y (heading 0): it begins 0.4 m
# behind the start and ends 5.0 m from it; 7.9 m long, bending 63° right, 127° left, 63° right (a
# straight walk from the start to the end leaves even the wide trail: (0, 2.5) is 0.89 m from it).
TRAIL_VERTICES_M = ((0.0, -0.4), (0.0, 1.5), (2.0, 2.5), (0.0, 3.5), (0.0, 5.0))
START_HEADING_RAD = 0.0
DEFAULT_ANTENNA_LENGTH_M = 0.541
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
    t_d: float = field(T_D, "Table 3 dead band on |O_l - O_r|, sensor units (paper: 5)", min=0.0, max=1e4)
    t_o: float = field(T_O, "Table 3 odour threshold, sensor units (paper: 900)", min_exclusive=0.0, max=1e4)
    k_d: float = field(K_D, "Table 3 turn gain: turn = O_d / k_d (paper: 400)", min_exclusive=0.0, max=1e5)
    sensor_scale: float = field(SENSOR_SCALE, "sensor units per unit of trail concentration (O = scale c)",
                                min_exclusive=0.0, max=1e5)
    success_radius_m: float = field(0.5, "success: the body centre within max(this, width / 2) of the trail's end (m)",
                                    min_exclusive=0.0, max=3.0)
    reach_m: float = field(0.5, "completion counts progress while the body centre is within width / 2 + this "
                           "of the trail (m)", min=0.0, max=3.0)
    timeout_s: float = field(90.0, "a trial gives up after this long (s)", min_exclusive=0.0, max=3600.0)
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


class TrailBrain:
    """Antennae -> Table 3 -> (θ, S_l), once per gait cycle; logs what it sensed and did."""

    def __init__(self, config: OdourTrailConfig, trail: PolylineTrail, seed: int) -> None:
        self.controller, self.trail = config.controller(), trail
        self.rng = np.random.default_rng([seed, 12])
        self.log: dict[str, list] = {k: [] for k in ("time_s", "position_m", "heading_rad", "odour_L", "odour_R",
                                                     "centre_odour", "turn", "stride_rad")}

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed = loop.backend.read(("odour", "position", "heading"))
        left, right = (float(v) for v in sensed["odour"][0, :2, 0])
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
                                                 antenna_length_m=config.antenna_length_m)
    sweep = AntennaSweep(mode, seed=seed)
    hooks = ()
    if gait is None:
        hooks = (AntennaYawHook(sweep, seed=seed),)
    else:
        gait = SweptAntennaeGait(gait, sweep, body, CONTROL_S, seed=seed)
    brain = TrailBrain(config, trail, seed)
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
    end = np.asarray(trail.vertices_m[-1], float)
    radius = success_radius(config)

    def arrived(lp: AgentLoop) -> bool:
        position = lp.backend.read(("position",))["position"][0]
        return bool(np.hypot(*(position - end)) <= radius)

    loop, final, wall_s = run_loop(engine, trail_world(trail), body, gait, clocks, brain, heading_rad=START_HEADING_RAD,
                                   seed=seed, duration_s=config.timeout_s, until=arrived, hooks=hooks,
                                   video_path=video_path)
    log = {k: np.array(v, float) for k, v in brain.log.items()}
    log["position_m"] = np.vstack([log["position_m"], final[None]])
    return trail_metrics(log, config, trail, mode, loop.time_s, wall_s), log


def success_radius(config: OdourTrailConfig) -> float:
    return max(config.success_radius_m, TRAIL_WIDTHS_M[config.width] / 2)


def trail_metrics(log: dict, config: OdourTrailConfig, trail: PolylineTrail, mode: str, trial_time_s: float,
                  wall_s: float) -> dict:
    """Success, finish time, completion and time on the trail of one trial (the module docstring)."""
    path = log["position_m"]
    end = np.asarray(trail.vertices_m[-1], float)
    reached = bool(np.hypot(*(path[-1] - end)) <= success_radius(config))
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
        from scenarios.odour_trail_figures import write_trail_figures

        return write_trail_figures(result, config, Path(out_dir))


def pack_logs(logs: list[dict]) -> dict[str, np.ndarray]:
    """Per-cycle logs of unequal length as NaN-padded arrays (trials, cycles, ...)."""
    return pack_cycle_logs(logs, ("time_s", "heading_rad", "odour_L", "odour_R", "centre_odour", "turn",
                                  "stride_rad"))
