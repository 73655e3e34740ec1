"""Visual beacon (the I2Bot paper's §2.4.1, Fig. 4): the ant walks to a dark landmark it sees.

A black cylinder (r 1 m, h 6 m) stands 25 m from the start, at (0, 25) m, among trees that are too
light to pass the dark threshold. Once per gait cycle (0.64 s) the brain reads its eyes, finds the
landmark's dark pixels and turns their offset from the image centre into a shift of the heading
code (eqs. 3.8–3.9, :mod:`neuronav.brains.vision`); the copy-and-shift circuit
(:func:`neuronav.brains.steering.copy_and_shift`) copies the current TB1 heading bump, rolls it by that shift
and steers toward it through CPU1:

    θ   = k_vb · (ΣCPU1_left − ΣCPU1_right)      (as eq. 3.6, with the visual beacon's gain)
    S_l = 5° + 20° · (1 − min(|θ|, 1))            (eq. 3.7)

``eye`` picks the left eye, the right one, both, or ``cycle`` (trial seed mod 3: left, right,
both — one run shows all three). Start headings as the paper's (I2Bot §3.3.4; docs/parameters.md §7): the landmark
0–90° to the left for the left eye, 0–90° to the right for the right eye, within ±45° for both.

Trials differ (``variability=on``): start jitter, eye pixel and motor noise, each a setting
(:mod:`neuronav.scenarios.eye_noise`, :mod:`neuronav.scenarios.motor_noise`); ``variability=off``: the paper's protocol.

Metrics per trial: ``success`` (within ``success_radius_m`` of the landmark), ``time_to_landmark_s``,
``closest_distance_m``, the signed ``lateral_offset_m`` (largest) and ``mean_lateral_offset_m`` from the
start–landmark line (+ = left), ``path_ratio``; per eye mode the median time, success and the mean of each
trial's peak offset; statistics: each monocular mode against both eyes (``eye_mode`` 0 left, 1 right, 2 both).

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from neuronav.brains.steering import copy_and_shift
from neuronav.brains.vision import beacon_shift
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, integer_ratio
from neuronav.engine.video_overlay import EyeInset, Marker, PopulationInset, VideoContent
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.aggregation import finite_median_of, mean_of, per_condition, success_rate
from neuronav.scenarios.eye_noise import EyeNoise, eye_pixel_noise_field
from neuronav.scenarios.motor_noise import MotorNoise, stride_noise_field, turn_noise_field
from neuronav.scenarios.path_integration.embodied import steering_command
from neuronav.scenarios.trial_loop import pack_cycle_logs, run_loop, trials_one_by_one
from neuronav.scenarios.variability import is_on, jitter_start, trial_generators, variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.scenarios.worlds.scenes import forest, landmark, pack_world, vision_appearance, world_record
from neuronav.senses.compound_eye_vision import CAMERA_EYE_AZIMUTH_DEG, CAMERA_EYE_FOV_RAD, beacon_eye_image
from neuronav.spec.world import Ground, World

EYE_MODES = ("left", "right", "both")
EYES = {"left": ("eye_L",), "right": ("eye_R",), "both": ("eye_L", "eye_R")}
# Start headings (clockwise from +y; the landmark is at bearing 0): the paper's ranges.
START_HEADINGS_RAD = {"left": (0.0, np.pi / 2), "right": (-np.pi / 2, 0.0), "both": (-np.pi / 4, np.pi / 4)}
# What the compound eyes see of the black landmark, (green, UV): a matt black surface (ours: a few per cent
# reflectance), darker than the vegetation's 0.12 / 0.04 (neuronav.spec.world.OBJECT_GREEN_UV).
LANDMARK_GREEN_UV = (0.02, 0.02)
EYE_KINDS = ("camera", "compound")


@dataclass
class VisualBeaconConfig:
    eye: str = field("cycle", "which eyes the brain reads: left, right, both, or cycle (trial seed mod 3)",
                     choices=("cycle", *EYE_MODES))
    eyes: str = field("camera", "what the eyes are: camera (the binocular 74 x 19 cameras) or compound (the "
                      "compound eyes' green channel on the cameras' grids)", choices=EYE_KINDS)
    eye_midline_deg: float = field(90.0, "each eye sees at most this far across the midline (deg): cells beyond are "
                                   "blank (bright); 90 = all (the cameras reach 27 deg, the compound eyes 10)",
                                   min=0.0, max=90.0)
    landmark_distance_m: float = field(25.0, "the landmark's distance from the start (m)", min=5.0, max=100.0)
    trees: int = field(40, "trees around the scene (seeded by the trial)", min=0, max=500)
    dark_threshold: float = field(0.08, "grey level (0–1) at or below which a pixel is the landmark "
                                  "(0.08 ≈ 20 of 255; the paper: 10–25 of 255)", min=0.0, max=1.0)
    k_vb: float = field(0.1, "turn = k_vb (sum CPU1 left - sum CPU1 right)", min_exclusive=0.0, max=100.0)
    success_radius_m: float = field(3.0, "success: the body comes this close to the landmark's axis (m)",
                                    min_exclusive=0.0, max=50.0)
    timeout_s: float = settings.trial_timeout_field(120.0, "look")
    timestep_s: float = settings.timestep_field()
    variability: str = variability_field()
    start_position_sd_m: float = field(0.5, "start jitter: std of each start coordinate's Gaussian offset (m), with "
                                       "variability=on (0.5: half the ant's body length at x100)", min=0.0, max=5.0)
    eye_pixel_noise_sd: float = eye_pixel_noise_field()
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()

    def cross_check(self) -> None:
        if self.success_radius_m >= self.landmark_distance_m:
            raise ConfigError(f"success_radius_m ({self.success_radius_m:g}) must be < landmark_distance_m "
                              f"({self.landmark_distance_m:g}): the ant would succeed where it starts")


def eye_mode(config: VisualBeaconConfig, seed: int) -> str:
    """The eyes trial ``seed`` uses."""
    return EYE_MODES[seed % 3] if config.eye == "cycle" else config.eye


def beacon_world(config: VisualBeaconConfig, seed: int) -> World:
    """The landmark at (0, landmark_distance_m) and a seeded forest clear of the ant's corridor."""
    distance = config.landmark_distance_m
    # No tree between the start and the landmark, nor where a monocular path bows (about a third of
    # the distance to either side), nor right behind the landmark (it must stand out).
    clear = [(0.0, y, 0.45 * distance) for y in np.linspace(0.0, distance, 6)]
    trees = forest(config.trees, seed=seed, inner_radius_m=0.0, outer_radius_m=2.2 * distance,
                   centre_m=(0.0, distance / 2), clear=clear) if config.trees else ()
    objects = (replace(landmark((0.0, distance)), green_uv=LANDMARK_GREEN_UV), *trees)
    return World(ground=Ground(size_m=4.0 * distance), objects=objects, appearance=vision_appearance())


class BeaconBrain:
    """Eyes → shift (eqs. 3.8–3.9) → copy-and-shift → CPU1 → (θ, S_l), once per gait cycle."""

    def __init__(self, config: VisualBeaconConfig, mode: str, seed: int, compound_eyes=()) -> None:
        self.config, self.mode = config, mode
        # eyes=compound: each compound eye's green channel on its camera eye's grid (the detector unchanged).
        self.adapters = {f"eye_{eye.name[-1]}": (eye.name, beacon_eye_image(eye, eye.name[-1]))
                         for eye in compound_eyes} if config.eyes == "compound" else {}
        self.circuit = copy_and_shift().compile(batch=1, seeds=[seed])
        noisy = is_on(config)
        self.eye_noise = EyeNoise(seed, config.eye_pixel_noise_sd if noisy else 0.0)
        self.motor_noise = MotorNoise(seed, config.turn_noise_sd if noisy else 0.0,
                                      config.stride_noise_fraction if noisy else 0.0)
        self.log: dict[str, list] = {k: [] for k in ("time_s", "position_m", "heading_rad", "shift", "turn",
                                                     "stride_rad")}
        self.first_view: dict[str, np.ndarray] = {}

    def look(self, backend, eyes: tuple[str, ...], noise: bool = True) -> dict[str, np.ndarray]:
        """The grey images (N, H, W) of ``eyes`` (``eye_L``, ``eye_R``): the cameras' renders, or the compound
        eyes' reads (receptor noise on every ommatidium) laid out on the cameras' grids."""
        add = self.eye_noise if noise else (lambda image: image)
        if not self.adapters:
            rendered = backend.read(eyes)
            images = {name: add(rendered[name]) for name in eyes}
        else:
            sensed = backend.read(tuple(self.adapters[name][0] for name in eyes))
            images = {name: self.adapters[name][1](add(sensed[self.adapters[name][0]])) for name in eyes}
        if self.config.eye_midline_deg < 90.0:  # a narrower binocular field: the far side of the midline blank
            for name, image in images.items():
                blank = across_midline(name[-1], image.shape[-1], self.config.eye_midline_deg, not self.adapters)
                images[name] = np.where(blank, 1.0, image)
        return images

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        eyes = EYES[self.mode]
        sensed = loop.backend.read(("heading", "position"))
        images = self.look(loop.backend, eyes)
        if not self.first_view:  # both eyes' first view, for the figure (the brain uses only its own)
            start = self.look(loop.backend, ("eye_L", "eye_R"), noise=False)
            self.first_view = {name: image[0].copy() for name, image in start.items()}
        shift = beacon_shift(images.get("eye_L"), images.get("eye_R"), threshold=self.config.dark_threshold)
        heading = sensed["heading"]
        self.circuit.step({"heading": heading, "shift": shift})
        command = steering_command(self.circuit.rates("CPU1")[0], self.config.k_vb)
        for key, value in (("time_s", loop.time_s), ("position_m", sensed["position"][0]),
                           ("heading_rad", heading[0, 0]), ("shift", shift[0, 0]), ("turn", command[0]),
                           ("stride_rad", command[1])):
            self.log[key].append(np.array(value, float))
        return self.motor_noise(*command)


def across_midline(side: str, width_px: int, limit_deg: float, planar: bool) -> np.ndarray:
    """Bool (width_px,): the columns of the ``side`` eye's image (``L``/``R``: 2 rad wide, centred 30° to its
    side) that look more than ``limit_deg`` across the midline, to the other side; ``planar``: the camera eye's
    pinhole image (columns even in the tangent of the angle), else the compound eye's layout on its grid
    (even in azimuth, :func:`neuronav.senses.compound_eye_vision.eye_grid`)."""
    u = 2.0 * (np.arange(width_px) + 0.5) / width_px - 1.0  # -1 .. 1, left to right
    half = CAMERA_EYE_FOV_RAD[0] / 2.0
    offset = np.arctan(np.tan(half) * u) if planar else half * u  # clockwise from the eye's axis
    azimuth = np.radians(CAMERA_EYE_AZIMUTH_DEG) * (-1.0 if side == "L" else 1.0) + offset  # the left negative
    across = azimuth if side == "L" else -azimuth  # how far each column looks to the other side
    return across > np.radians(limit_deg)


def beacon_video(config: VisualBeaconConfig, brain: BeaconBrain, start_m, goal_m) -> VideoContent:
    """What the video shows: the goal (within ``success_radius_m`` of the landmark), both eyes and the
    copy-and-shift circuit's CPU1 (its steering output); from above, the start and the goal in view."""
    return VideoContent(markers=(Marker("goal", tuple(goal_m), config.success_radius_m, (250, 200, 0)),),
                        insets=(EyeInset(("eye_L", "eye_R"), "eyes L R"),
                                PopulationInset("CPU1", lambda loop: brain.circuit.rates("CPU1")[0])),
                        keep_in_view=(tuple(start_m), tuple(goal_m)))


def beacon_trial(config: VisualBeaconConfig, backend_name: str, seed: int, video_path=None) -> tuple[dict, dict]:
    """One trial: the metrics row and the per-cycle log (with the first views)."""
    mode = eye_mode(config, seed)
    rng = np.random.default_rng([seed, 4])
    heading0 = float(rng.uniform(*START_HEADINGS_RAD[mode]))
    start = np.zeros(2)
    if is_on(config):  # the start moved; the start heading drawn as before, relative to the landmark's bearing
        start = jitter_start(trial_generators([seed], "start"), start[None], np.zeros(1), config.start_position_sd_m,
                             0.0)[0][0]
        heading0 += float(np.arctan2(-start[0], config.landmark_distance_m - start[1]))
    world = beacon_world(config, seed)
    compound = config.eyes == "compound"
    engine, body, gait, physics_dt = make_engine(backend_name, config.timestep_s, compound_eyes=compound)
    brain = BeaconBrain(config, mode, seed, body.compound_eyes if compound else ())
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
    goal = np.array([0.0, config.landmark_distance_m])

    def arrived(lp: AgentLoop) -> bool:
        position = lp.backend.read(("position",))["position"][0]
        return bool(np.hypot(*(position - goal)) <= config.success_radius_m)

    loop, final, wall_s = run_loop(engine, world, body, gait, clocks, brain, heading_rad=heading0, seed=seed,
                                   duration_s=config.timeout_s, until=arrived, video_path=video_path,
                                   position_m=tuple(start), video_content=beacon_video(config, brain, start, goal))
    log = {k: np.array(v, float) for k, v in brain.log.items()}
    log["position_m"] = np.vstack([log["position_m"], final[None]])
    log["end_time_s"] = np.array(loop.time_s)
    log["first_view"] = brain.first_view
    log["world"] = world_record(world, beacon_m=goal)
    return beacon_metrics(log, config, mode, heading0, loop.time_s, wall_s, start), log


def beacon_metrics(log: dict, config: VisualBeaconConfig, mode: str, heading0: float, trial_time_s: float,
                   wall_s: float, start_m=(0.0, 0.0)) -> dict:
    """Success, time to the landmark and the path's shape (signed lateral offset, length over distance)."""
    path = log["position_m"]
    goal = np.array([0.0, config.landmark_distance_m])
    distance = np.hypot(path[:, 0] - goal[0], path[:, 1] - goal[1])
    reached = bool(distance.min() <= config.success_radius_m)
    # Signed offset from the start-landmark line, + to the left looking at the landmark (−x from the origin).
    start = np.asarray(start_m, float)
    if start.any():
        along = (goal - start) / np.hypot(*(goal - start))
        lateral = along[1] * (start[0] - path[:, 0]) + along[0] * (path[:, 1] - start[1])
    else:
        lateral = -path[:, 0]
    extreme = int(np.argmax(np.abs(lateral)))
    length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
    travelled = float(np.hypot(*(path[-1] - path[0])))
    return {
        "success": reached, "status": "ok", "error": "",
        "eye_mode": float(EYE_MODES.index(mode)),
        "start_heading_deg": float(np.degrees(heading0)),
        "time_to_landmark_s": float(trial_time_s) if reached else float("nan"),
        "closest_distance_m": float(distance.min()),
        "lateral_offset_m": float(lateral[extreme]),
        "mean_lateral_offset_m": float(lateral.mean()),
        "path_ratio": length / travelled if travelled > 0 else float("nan"),
        "trial_time_s": float(trial_time_s),
        "real_time_factor": float(trial_time_s / wall_s) if wall_s > 0 else float("nan"),
    }


class VisualBeacon(Scenario):
    """Monocular and binocular visual beacons on every backend."""

    name = "visual-beacon"
    description = "walk to a dark landmark seen by the left, right or both eyes: copy-and-shift steering (paper §2.4.1)"
    config_type = VisualBeaconConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    timing_metrics = ("real_time_factor",)
    # NaN by definition: the time to arrive for an ant that never arrives (per trial, and the median of
    # a mode whose every trial timed out), the path ratio of an ant that did not move.
    optional_metrics = ("time_to_landmark_s", "path_ratio", *(f"median_time_{m}_s" for m in EYE_MODES))

    def smoke_config(self) -> dict:
        return {"timeout_s": 2.0, "trees": 5}

    def statistics(self, config: VisualBeaconConfig) -> Statistics:
        """Per eye mode (``eye_mode`` 0 left, 1 right, 2 both), each monocular mode against both eyes."""
        return Statistics(condition="eye_mode", reference=float(EYE_MODES.index("both")),
                          metrics=("time_to_landmark_s", "closest_distance_m", "lateral_offset_m",
                                   "mean_lateral_offset_m", "path_ratio"))

    def check(self, config: VisualBeaconConfig, backend: str) -> None:
        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def aggregate(self, trials: list[dict], config: VisualBeaconConfig) -> dict:
        """Per eye mode (among the finished trials): the median time to the landmark of those that
        reached it, the fraction that did, and ``lateral_offset_{mode}_m``: the mean of each trial's peak
        signed lateral offset (its ``lateral_offset_m``, the largest; + = left), not a mean over the path."""
        return per_condition(trials, "eye_mode", {
            "median_time_{}_s": finite_median_of("time_to_landmark_s"), "success_{}": success_rate,
            "lateral_offset_{}_m": mean_of("lateral_offset_m"),
        }, labels=dict(enumerate(EYE_MODES)))

    def run(self, config: VisualBeaconConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        rows, logs = trials_one_by_one(lambda s, video: beacon_trial(config, backend, s, video), trials, seed,
                                       video_path)
        return ScenarioResult(trials=rows, timeseries=pack_logs(logs), aggregates=self.aggregate(rows, config),
                              simulated_time_s=float(np.mean([r["trial_time_s"] for r in rows])))

    def figures(self, result: ScenarioResult, config: VisualBeaconConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.visual_beacon.figures import write_beacon_figures

        return write_beacon_figures(result, config, Path(out_dir))


def pack_logs(logs: list[dict]) -> dict[str, np.ndarray]:
    """Per-cycle logs of unequal length as NaN-padded arrays (trials, cycles, ...), the first views and
    the world (the landmark and the trees, :func:`~neuronav.scenarios.worlds.scenes.world_record`)."""
    packed = pack_cycle_logs(logs, ("time_s", "heading_rad", "shift", "turn", "stride_rad"))
    for name in ("eye_L", "eye_R"):
        shape = next((log["first_view"][name].shape for log in logs if name in log["first_view"]), None)
        if shape is None:
            continue
        packed[f"first_view_{name}"] = np.full((len(logs), *shape), np.nan)
        for i, log in enumerate(logs):
            if name in log["first_view"]:
                packed[f"first_view_{name}"][i] = log["first_view"][name]
    packed.update(pack_world([log["world"] for log in logs]))
    return packed
