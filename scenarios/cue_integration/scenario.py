"""``cue-integration``: path integration and visual homing combined in the ring attractor (Sun et al. 2020).

An ant with a full home vector is released where its views point home and its home vector points
``conflict`` to one side; its initial heading shows how it weights the two cues. Per trial (seed s):

- The world: a forest of ``trees`` 8–40 m around the nest (``forest_seed``: the same for every trial), and
  ``snapshots`` panoramas ray cast facing the nest on a circle of ``snapshot_radius_m`` (the panoramic camera, or
  ``eyes=compound``: one ``eye_channel`` of the compound eyes, :mod:`neuronav.scenarios.route_following.compound_view`).
- The home vector: the CX integrates a straight outbound walk of ``pi_distance_m`` whose home vector
  points ``conflict`` to a random side of the nest direction seen from the release point; the ant is
  then released ``release_distance_m`` from the nest at a random bearing, facing a random heading.
- Homing: every gait cycle the brain (:mod:`neuronav.scenarios.cue_integration.brain`) feeds the PI and
  visual cues into the ring attractor by reliability and steers toward its bump through CPU1 (``cues``
  may leave one out). The trial ends at the nest (``nest_radius_m``) or at ``timeout_s``.

On kinematic all trials run as one batch of agents (panoramas at ``kinematic_supersample`` rays per pixel side),
on MuJoCo and PyBullet one ant per trial.

Metrics per trial (degrees, signed, relative to the nest direction from the release point, positive
toward the PI cue's side): ``initial_heading_deg`` (bearing of where the path first reaches
``initial_distance_m`` from the release point), ``pi_cue_deg``, ``vision_cue_deg``, ``weight_pi`` and
``predicted_heading_deg`` (the amplitude-weighted circular mean) at release, ``error_to_pi_deg``,
``error_to_vision_deg``, ``error_to_prediction_deg``, ``success`` (reached the nest), ``time_to_nest_s``.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from neuronav import registry
from neuronav.angles import angle_difference_rad
from neuronav.config import field
from neuronav.engine.loop import Clocks, integer_ratio
from neuronav.engine.video_overlay import EyeInset, Marker, VideoContent
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.aggregation import finished_trials, per_condition, success_rate
from neuronav.scenarios.cue_integration.brain import CueBrain, weighted_direction
from neuronav.scenarios.route_following.compound_view import EYE_CHANNELS, EYE_SENSORS, CompoundPanorama, ant_eyes
from neuronav.scenarios.trial_loop import run_loop
from neuronav.scenarios.variability import variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine, point_agent_cameras
from neuronav.scenarios.worlds.scenes import forest, pack_world, vision_appearance, world_record
from neuronav.spec.world import Ground, PointAgents, World

CUE_MODES = ("both", "pi", "vision")
EYES = ("camera", "compound")
OUTBOUND_STEP_M = 0.29
FOREST_RADII_M = (8.0, 40.0)


@dataclass
class CueIntegrationConfig:
    cues: str = field("both", "cues into the ring: both, pi (path integration alone) or vision (views alone); a "
                      "comma list (both,pi,vision) is cycled over trials by seed, each cue for a whole cycle of the "
                      "conflict angles")
    conflict_deg: str = field("0,30,60,90,120,150", "angle between the PI and the visual home directions at "
                              "release (deg, 0–180); a comma list is cycled over trials by seed")
    pi_distance_m: float = field(10.0, "length of the outbound walk the home vector integrates (m)",
                                 min_exclusive=0.0, max=40.0)
    release_distance_m: float = field(4.0, "release point's distance from the nest (m)", min_exclusive=0.0,
                                      max=8.0)
    snapshots: int = field(16, "views stored facing the nest on a circle around it", min=1, max=128)
    snapshot_radius_m: float = field(3.0, "radius of the circle of stored views (m)", min_exclusive=0.0, max=7.0)
    trees: int = field(60, "trees in the forest around the nest (8–40 m away)", min=0, max=300)
    forest_seed: int = field(1, "seed of the forest (the same world for every trial)", min=0, max=2**31 - 1)
    band_deg: float = field(45.0, "views: the panorama's band from the horizon up to this elevation (deg)",
                            min_exclusive=0.0, max=90.0)
    pi_full_m: float = field(20.0, "PI reliability = min(1, home vector length / pi_full_m)", min_exclusive=0.0,
                             max=1000.0)
    vision_full: float = field(0.3, "visual reliability = min(1, RIDF depth / vision_full)", min_exclusive=0.0,
                               max=1.0)
    k_pi: float = field(1.0, "turn = k_pi (sum CPU1 left - sum CPU1 right) (eq. 3.6)", min_exclusive=0.0, max=100.0)
    initial_distance_m: float = field(1.5, "initial heading: measured where the path first gets this far from "
                                      "the release point (m)", min_exclusive=0.0, max=8.0)
    nest_radius_m: float = field(0.7, "success: the body comes this close to the nest (m)", min_exclusive=0.0,
                                 max=8.0)
    timeout_s: float = settings.trial_timeout_field(30.0, "look")
    timestep_s: float = settings.timestep_field()
    kinematic_supersample: int = field(1, "kinematic batch: rays per pixel side of the panorama (the ant's "
                                       "camera: 4)", min=1, max=4)
    eyes: str = field("camera", "what the visual cue sees: camera (the ant's panoramic camera, grey) or compound (its "
                      "two compound eyes' ommatidia, one channel: eye_channel)", choices=EYES)
    eye_channel: str = field("uv", "eyes=compound: the ommatidia's channel the views are made of: green, uv, or "
                             "uv_green (the UV-green contrast (UV - G) / (UV + G))", choices=EYE_CHANNELS)
    variability: str = variability_field()
    heading_noise_deg: float = field(2.0, "variability: Gaussian noise on every heading the brain reads (the "
                                     "compass), outbound and homing (standard deviation, deg)", min=0.0, max=90.0)
    odometry_noise: float = field(0.1, "variability: each gait cycle's displacement the CX integrates scaled by "
                                  "1 + this standard deviation times a Gaussian draw (relative)", min=0.0, max=1.0)
    eye_noise: float = field(0.02, "variability: Gaussian noise on every pixel of the panorama the brain reads "
                             "(standard deviation, grey levels 0-1; with eyes=compound in the channel's units)",
                             min=0.0, max=1.0)
    turn_noise: float = field(0.03, "variability: Gaussian noise on each gait cycle's turn θ (standard deviation; "
                              "θ = ±1 turns on the spot)", min=0.0, max=1.0)
    stride_noise_deg: float = field(1.0, "variability: Gaussian noise on each gait cycle's stride (standard "
                                    "deviation, deg)", min=0.0, max=10.0)

    def cross_check(self) -> None:
        conflicts_deg(self)
        cue_modes(self)
        if self.nest_radius_m >= self.release_distance_m:
            raise ConfigError(f"nest_radius_m ({self.nest_radius_m:g}) must be < release_distance_m "
                              f"({self.release_distance_m:g}): the ant would succeed where it is released")


def conflicts_deg(config: CueIntegrationConfig) -> tuple[float, ...]:
    """The conflict angles of ``config.conflict_deg`` (one or a comma list, each 0–180)."""
    return settings.number_list("conflict_deg", config.conflict_deg, 0.0, 180.0, "degrees", "angle")


def cue_modes(config: CueIntegrationConfig) -> tuple[str, ...]:
    """The cues of ``config.cues`` (one, or a comma list of both, pi, vision)."""
    return settings.choice_list("cues", config.cues, CUE_MODES)


def trial_cue_modes(trials: list[dict], config: CueIntegrationConfig) -> list[str]:
    """The cue modes the finished trials ran under: those of ``config.cues`` in its order, then any other
    a row names (rows without a ``cues`` column count as ``config.cues``'s first)."""
    present = {t.get("cues", cue_modes(config)[0]) for t in finished_trials(trials)}
    return [m for m in cue_modes(config) if m in present] + sorted(present - set(cue_modes(config)))


def trial_setup(config: CueIntegrationConfig, seed: int) -> dict:
    """Cues, conflict, release bearing, start heading and the side of the conflict of trial ``seed``.

    Angles in rad, clockwise from +y. The conflict cycles over its list by seed; the cues (``cues``) by
    whole cycles of the conflict list, so that every cue meets every conflict. The home vector points
    ``conflict`` clockwise (side +1) or counter-clockwise (side -1) of the nest, at random: a bias of the
    body to one side (the calibrated unicycle drifts 0.02–0.08 rad/s counter-clockwise at turn 0, as the
    MuJoCo tripod does) then cancels in the mean instead of looking like a weight.
    """
    conflicts, modes = conflicts_deg(config), cue_modes(config)
    rng = np.random.default_rng([seed, 14])
    bearing = float(rng.uniform(0.0, 2.0 * np.pi))
    heading = float(rng.uniform(-np.pi, np.pi))
    side = 1.0 if rng.random() < 0.5 else -1.0
    nest = float(angle_difference_rad(bearing + np.pi, 0.0))
    conflict_deg = conflicts[seed % len(conflicts)]
    conflict = float(np.radians(conflict_deg))
    return {"cues": modes[(seed // len(conflicts)) % len(modes)], "conflict_deg": conflict_deg,
            "conflict_rad": conflict,
            "release_m": config.release_distance_m * np.array([np.sin(bearing), np.cos(bearing)]),
            "heading_rad": heading, "nest_rad": nest, "side": side, "pi_rad": nest + side * conflict}


def cue_world(config: CueIntegrationConfig) -> World:
    """The nest at the origin in a forest (8–40 m away) seeded by ``forest_seed``."""
    trees = forest(config.trees, seed=config.forest_seed, inner_radius_m=FOREST_RADII_M[0],
                   outer_radius_m=FOREST_RADII_M[1]) if config.trees else ()
    return World(ground=Ground(size_m=2.5 * FOREST_RADII_M[1]), objects=trees, appearance=vision_appearance())


def panorama_camera(supersample: int | None = None):
    """The ant's panoramic camera on a point agent (its own supersampling, or ``supersample``)."""
    from neuronav.bodies.desert_ant import desert_ant

    camera = next(c for c in point_agent_cameras(desert_ant()) if c.name == "panorama")
    return camera if supersample is None else replace(camera, supersample=int(supersample))


class CueEyes:
    """The eyes the visual cue reads: the panoramic camera, or (``eyes=compound``) the two compound eyes, one
    channel laid out on the panorama's grid
    (:class:`~neuronav.scenarios.route_following.compound_view.CompoundPanorama`)."""

    def __init__(self, config: CueIntegrationConfig) -> None:
        self.layout = CompoundPanorama(*ant_eyes(), config.eye_channel) if config.eyes == "compound" else None
        self.sensors = EYE_SENSORS if self.layout else ("panorama",)

    def point_agents(self, count: int, supersample: int | None = None) -> PointAgents:
        """``count`` unicycle agents carrying these eyes (the camera at ``supersample``, or its own)."""
        if self.layout:
            return PointAgents(count=count, mode="unicycle", compound_eyes=ant_eyes()[0])
        return PointAgents(count=count, mode="unicycle", cameras=(panorama_camera(supersample),))

    def read(self, backend, also=("heading", "position")) -> tuple[dict, np.ndarray]:
        """(the sensors ``also`` read with the eyes, the panoramas (N, H, W))."""
        sensed = backend.read((*also, *self.sensors))
        return sensed, (self.layout(sensed) if self.layout else sensed["panorama"])


def snapshot_points_m(config: CueIntegrationConfig) -> np.ndarray:
    """Where the stored views were taken (K, 2): ``snapshots`` points on the circle about the nest."""
    angles = 2.0 * np.pi * np.arange(config.snapshots) / config.snapshots
    return config.snapshot_radius_m * np.stack([np.sin(angles), np.cos(angles)], axis=1)


def cue_world_record(config: CueIntegrationConfig) -> dict[str, np.ndarray]:
    """The world as a trial's time series record it (the same in every trial): the forest ``objects_m``,
    ``nest_m`` and the stored views' points ``snapshots_m``."""
    return world_record(cue_world(config), nest_m=(0.0, 0.0), snapshots_m=snapshot_points_m(config))


def take_snapshots(config: CueIntegrationConfig, world: World) -> np.ndarray:
    """Skyline views (K, R, W) from ``snapshots`` points on the circle, each facing the nest."""
    from neuronav.brains.visual_homing import skyline_view

    angles = 2.0 * np.pi * np.arange(config.snapshots) / config.snapshots
    positions = snapshot_points_m(config)
    eyes = CueEyes(config)
    engine = registry.load("backend", "kinematic")(timestep_s=CONTROL_S)
    with engine:
        engine.load(world, [eyes.point_agents(config.snapshots)])
        engine.reset(seed=0, heading_rad=angles + np.pi, position_m=positions)
        return skyline_view(eyes.read(engine, also=())[1], config.band_deg)


def charge_home_vector(brain: CueBrain, pi_rad: np.ndarray, distance_m: float) -> None:
    """Integrate a straight outbound walk whose home vector points ``pi_rad`` (N,), ``distance_m`` long."""
    outbound = np.asarray(pi_rad, float) + np.pi
    step = OUTBOUND_STEP_M * np.stack([np.sin(outbound), np.cos(outbound)], axis=1)
    for _ in range(int(round(distance_m / OUTBOUND_STEP_M))):
        brain.integrate(outbound, step)


def translated(world: World, offset_m) -> World:
    """``world`` with every object moved by ``offset_m`` (x, y): the same scene seen from elsewhere."""
    dx, dy = (float(v) for v in offset_m)
    objects = tuple(replace(o, position_m=(o.position_m[0] + dx, o.position_m[1] + dy, o.position_m[2]))
                    for o in world.objects)
    return replace(world, objects=objects)


def start_brain(config: CueIntegrationConfig, snapshots: np.ndarray, seeds, setups) -> CueBrain:
    """The brains of trials ``seeds``, their home vectors charged by the outbound walks."""
    brain = CueBrain(config, snapshots, seeds, cues=[s["cues"] for s in setups])
    charge_home_vector(brain, np.array([s["pi_rad"] for s in setups]), config.pi_distance_m)
    return brain


def run_kinematic(config: CueIntegrationConfig, trials: int, seed: int) -> tuple[list[dict], dict]:
    """Every trial at once: one batch of point agents carrying the ant's panoramic camera."""
    started = time.perf_counter()
    world = cue_world(config)
    seeds = [seed + i for i in range(trials)]
    setups = [trial_setup(config, s) for s in seeds]
    brain = start_brain(config, take_snapshots(config, world), seeds, setups)
    releases = np.array([s["release_m"] for s in setups])
    engine = registry.load("backend", "kinematic")(timestep_s=CONTROL_S)
    eyes = CueEyes(config)
    body = eyes.point_agents(trials, config.kinematic_supersample)
    controls = integer_ratio(CYCLE_S, CONTROL_S, "gait cycle / control step")
    done_s = np.full(trials, np.nan)
    with engine:
        engine.load(world, [body])
        engine.reset(seed=seed, heading_rad=np.array([s["heading_rad"] for s in setups]), position_m=releases)
        positions = [engine.read(("position",))["position"]]
        while engine.time < config.timeout_s - 1e-9 and np.isnan(done_s).any():
            sensed, panorama = eyes.read(engine)
            turn, stride = brain(engine.time, sensed["heading"][:, 0], sensed["position"], panorama)
            arrived = np.isfinite(done_s)
            turn[arrived], stride[arrived] = 0.0, 0.0
            engine.write({"turn": turn[:, None], "stride": stride[:, None]})
            for _ in range(controls):
                engine.step(1)
                near = np.hypot(*engine.read(("position",))["position"].T) <= config.nest_radius_m
                done_s[near & np.isnan(done_s)] = engine.time
            positions.append(engine.read(("position",))["position"])
    wall_s = time.perf_counter() - started
    paths = np.stack(positions, axis=1)  # (trials, cycles + 1, 2)
    logs = {k: np.stack(v, axis=1) for k, v in brain.log.items()}
    # A trial's record ends at its arrival: later cycles (standing at the nest) belong to no trial.
    ended = np.where(np.isfinite(done_s), done_s, np.inf)
    after = logs["time_s"] >= ended[:, None]
    for key in logs:
        logs[key][after] = np.nan
    path_times = np.arange(paths.shape[1]) * CYCLE_S
    paths[(path_times[None, :] > ended[:, None] + CYCLE_S - 1e-9)] = np.nan
    rows = [dict(cue_metrics(config, setups[i], paths[i], {k: v[i] for k, v in logs.items()}, done_s[i],
                             min(engine.time, done_s[i]) if np.isfinite(done_s[i]) else engine.time,
                             wall_s / trials), trial=i, seed=seeds[i]) for i in range(trials)]
    return rows, dict(logs, position_m=paths)


def physics_trial(config: CueIntegrationConfig, backend_name: str, snapshots: np.ndarray, seed: int,
                  video_path=None) -> tuple[dict, dict]:
    """One ant on a physics backend: released at the origin of a world moved so the nest is where it belongs."""
    started = time.perf_counter()
    setup = trial_setup(config, seed)
    release = setup["release_m"]
    world = translated(cue_world(config), -release)
    engine, body, gait, physics_dt = make_engine(backend_name, config.timestep_s,
                                                 **({"compound_eyes": True} if config.eyes == "compound" else {}))
    brain = start_brain(config, snapshots, [seed], [setup])
    eyes = CueEyes(config)
    positions: list[np.ndarray] = []

    def steer(loop) -> tuple[float, float]:
        sensed, panorama = eyes.read(loop.backend)
        position = sensed["position"] + release
        positions.append(position[0])
        turn, stride = brain(loop.time_s, sensed["heading"][:, 0], position, panorama)
        return float(turn[0]), float(stride[0])

    def at_nest(loop) -> bool:
        return bool(np.hypot(*(loop.backend.read(("position",))["position"][0] + release)) <= config.nest_radius_m)

    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
    loop, final, _ = run_loop(engine, world, body, gait, clocks, steer, heading_rad=setup["heading_rad"], seed=seed,
                              duration_s=config.timeout_s, until=at_nest, video_path=video_path,
                              video_content=VideoContent(
                                  markers=(Marker("nest", tuple(-release), config.nest_radius_m),),
                                  insets=(EyeInset(("panorama",), "panorama", height_px=144),)))
    path = np.array([*positions, final + release])
    reached = bool(np.hypot(*(final + release)) <= config.nest_radius_m)
    log = {k: np.array(v, float)[:, 0] for k, v in brain.log.items()}
    row = cue_metrics(config, setup, path, log, loop.time_s if reached else np.nan, loop.time_s,
                      time.perf_counter() - started)
    return row, dict(log, position_m=path)


def signed_deg(angle_rad, reference_rad) -> float:
    """``angle - reference`` wrapped to (-180, 180] degrees."""
    return float(np.degrees(angle_difference_rad(angle_rad, reference_rad)))


def crossing_bearing(path: np.ndarray, origin: np.ndarray, distance_m: float) -> float:
    """Bearing (rad, clockwise from +y) from ``origin`` of where ``path`` (P, 2) first reaches ``distance_m``
    from it, interpolated along the segment that crosses; NaN if it never does."""
    finite = path[np.isfinite(path[:, 0])] - origin
    reach = np.hypot(finite[:, 0], finite[:, 1])
    beyond = np.flatnonzero(reach >= distance_m)
    if beyond.size == 0:
        return float("nan")
    k = int(beyond[0])
    point = finite[k]
    if k > 0:  # solve |a + t (b - a)| = d on the crossing segment
        a, b = finite[k - 1], finite[k]
        d = b - a
        qa, qb, qc = d @ d, 2.0 * a @ d, a @ a - distance_m ** 2
        t = (-qb + np.sqrt(max(qb * qb - 4.0 * qa * qc, 0.0))) / (2.0 * qa) if qa > 0 else 1.0
        point = a + np.clip(t, 0.0, 1.0) * d
    return float(np.arctan2(point[0], point[1]))


def cue_metrics(config: CueIntegrationConfig, setup: dict, path: np.ndarray, log: dict, arrival_s: float,
                trial_time_s: float, wall_s: float) -> dict:
    """One trial's row: the initial heading against the two cues and their weighted prediction."""
    nest, side = setup["nest_rad"], setup["side"]
    initial = crossing_bearing(path, setup["release_m"], config.initial_distance_m)
    pi_cue, vision_cue = log["pi_rad"][0], log["vision_rad"][0]
    weight_pi = log["weight_pi"][0]
    predicted = weighted_direction(pi_cue, weight_pi, vision_cue, 1.0 - weight_pi)
    relative = {name: side * signed_deg(value, nest) for name, value in
                (("initial", initial), ("pi", pi_cue), ("vision", vision_cue), ("predicted", predicted))}
    return {
        "success": bool(np.isfinite(arrival_s)), "status": "ok", "error": "",
        "cues": setup["cues"],
        "conflict_deg": float(setup["conflict_deg"]),  # as listed (30.0, not 29.999999999999996)
        "initial_heading_deg": relative["initial"],
        "initial_heading_rad": float(np.radians(relative["initial"])),
        "pi_cue_deg": relative["pi"], "vision_cue_deg": relative["vision"],
        "weight_pi": float(weight_pi), "pi_length_m": float(log["pi_length_m"][0]),
        "vision_certainty": float(log["certainty"][0]),
        "predicted_heading_deg": relative["predicted"],
        "error_to_pi_deg": abs(signed_deg(initial, pi_cue)),
        "error_to_vision_deg": abs(signed_deg(initial, vision_cue)),
        "error_to_prediction_deg": abs(signed_deg(initial, predicted)),
        "time_to_nest_s": float(arrival_s),
        "trial_time_s": float(trial_time_s),
        "real_time_factor": float(trial_time_s / wall_s) if wall_s > 0 else float("nan"),
    }


class CueIntegration(Scenario):
    """PI and visual homing as two cues into the ring attractor, alone, together and in conflict."""

    name = "cue-integration"
    description = ("PI home vector + visual homing (RIDF on stored views) combined in the ring attractor, steering "
                   "through CPU1; cue conflict by a displaced release (Sun et al. 2020; Wystrach et al. 2015)")
    config_type = CueIntegrationConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    timing_metrics = ("real_time_factor",)
    condition_columns = ("cues",)
    # One kinematic batch of 1000 agents takes about 7 min on the 2-core machine (README): bigger runs are
    # cut into batches of at most this many, each written (and resumable) on its own.
    chunk_trials = 1000
    # NaN by definition: the time to the nest of an ant that never arrives; the initial heading (and its
    # errors) of one that never got initial_distance_m from the release point.
    optional_metrics = ("time_to_nest_s", "initial_heading_deg", "initial_heading_rad", "error_to_pi_deg",
                        "error_to_vision_deg", "error_to_prediction_deg")

    def smoke_config(self) -> dict:
        return {"timeout_s": 1.28, "trees": 6, "snapshots": 4}

    def check(self, config: CueIntegrationConfig, backend: str) -> None:
        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def statistics(self, config: CueIntegrationConfig) -> Statistics:
        """The condition the run varies: the cues (``cues`` a comma list; against the first listed) or else
        the conflict angle (against the first listed). Per condition the initial heading (signed, toward the
        PI cue's side; and as a circular heading), its errors to each cue and to the weighted prediction,
        the time to the nest and success."""
        modes, conflicts = cue_modes(config), conflicts_deg(config)
        by_cues = len(modes) > 1 or len(conflicts) == 1
        return Statistics(condition="cues" if by_cues else "conflict_deg",
                          reference=modes[0] if by_cues else conflicts[0],
                          metrics=("initial_heading_deg", "error_to_pi_deg", "error_to_vision_deg",
                                   "error_to_prediction_deg", "time_to_nest_s"),
                          circular=("initial_heading_rad",))

    def aggregate(self, trials: list[dict], config: CueIntegrationConfig) -> dict:
        """Per conflict angle: the circular mean initial heading (where any was measured), the mean
        prediction, the success rate (``initial_heading_90_deg``, ...). With several cue modes (``cues`` a
        comma list, cycled over the trials) per cue mode and conflict (``initial_heading_pi_90_deg``, ...):
        the modes are never pooled."""
        def initial(group: list[dict]) -> float | None:  # None where no ant of the group got initial_distance_m away
            value = circular_mean_deg([t["initial_heading_deg"] for t in group])
            return value if np.isfinite(value) else None

        statistics = {
            "initial_heading_{}_deg": initial,
            "predicted_heading_{}_deg": lambda group: circular_mean_deg([t["predicted_heading_deg"] for t in group]),
            "success_{}": success_rate,
        }
        modes = trial_cue_modes(trials, config)
        if len(modes) <= 1:
            return per_condition(trials, "conflict_deg", statistics)
        result = {}
        for mode in modes:
            group = [t for t in finished_trials(trials) if t.get("cues") == mode]
            conflicts = sorted({t["conflict_deg"] for t in group})
            result.update(per_condition(group, "conflict_deg", statistics,
                                        labels={c: f"{mode}_{c:g}" for c in conflicts}))
        return result

    def check_video(self, config: CueIntegrationConfig, backend: str) -> None:
        """The kinematic trials run as one batch of point agents, with no agent loop to film."""
        if backend == "kinematic":
            raise ConfigError("--video films cue-integration on mujoco, dm_control or pybullet; on kinematic its "
                              "trials run as one batch with no agent loop to film")

    def run(self, config: CueIntegrationConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        if backend == "kinematic":
            rows, timeseries = run_kinematic(config, trials, seed)
        else:
            snapshots = take_snapshots(config, cue_world(config))
            rows, logs = [], []
            for i in range(trials):
                row, log = physics_trial(config, backend, snapshots, seed + i, video_path if i == 0 else None)
                rows.append(dict(row, trial=i, seed=seed + i))
                logs.append(log)
            timeseries = pack_logs(logs)
        timeseries.update(pack_world([cue_world_record(config)] * trials))
        return ScenarioResult(trials=rows, timeseries=timeseries, aggregates=self.aggregate(rows, config),
                              simulated_time_s=float(np.mean([r["trial_time_s"] for r in rows])))

    def figures(self, result: ScenarioResult, config: CueIntegrationConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.cue_integration.figures import write_cue_figures

        return write_cue_figures(result, config, Path(out_dir))


def circular_mean_deg(values_deg) -> float:
    """Circular mean of the finite angles (deg), NaN when there are none."""
    values = np.radians([v for v in values_deg if np.isfinite(v)])
    return float(np.degrees(np.angle(np.exp(1j * values).sum()))) if values.size else float("nan")


def pack_logs(logs: list[dict]) -> dict[str, np.ndarray]:
    """Per-cycle logs of unequal length as NaN-padded arrays: (trials, cycles) and paths (trials, points, 2)."""
    cycles = max(len(log["time_s"]) for log in logs)
    packed = {key: np.full((len(logs), cycles), np.nan) for key in CueBrain.LOG_KEYS}
    points = max(len(log["position_m"]) for log in logs)
    packed["position_m"] = np.full((len(logs), points, 2), np.nan)
    for i, log in enumerate(logs):
        for key in CueBrain.LOG_KEYS:
            packed[key][i, : len(log[key])] = log[key]
        packed["position_m"][i, : len(log["position_m"])] = log["position_m"]
    return packed
