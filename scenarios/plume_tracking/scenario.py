"""Odour plume tracking (I2Bot §2.5.2, Fig. 6e–g): the ant walks up a turbulent plume to its source.

An 8 × 4 m arena (x in [0, 8] m, y in [−2, 2] m) with a Farrell filament plume (:mod:`neuronav.senses.plume`):
a source at ``(source_x_m, 0)`` releasing ``release_rate_hz`` puffs of ``puff_amount`` into a wind of
``wind_mps`` toward ``wind_direction_deg`` meandering with gain ``wind_gain``, warmed up for ``warmup_s``
(the defaults make it intermittent). The ant starts at ``x = start_x_m``, within ``±start_lateral_m`` of the
plume's axis and ``±start_heading_deg`` of upwind; once per gait cycle the brain steers by eq. 3.11
(:class:`neuronav.brains.plume_tracking.PlumeController`) from ``odour``, ``wind`` and ``heading`` (with
``variability=on`` each read with seeded noise and the command given motor noise: :class:`PlumeNoise`);
``odour=off`` zeroes its odour input (the control), ``both`` alternates it by seed (even: on). Each
trial's seed seeds the plume, the start and the search turns.

Metrics per trial: ``odour_on`` (the condition: true with odour, false for the control), ``success`` (the
root or an antenna tip came within ``success_radius_m`` of the source), ``time_to_source_s`` (NaN when it
did not), ``odour_fraction`` (the share of samples, every 0.064 s, with odour above the threshold at either
tip), ``closest_distance_m``, ``final_x_m``, ``orient_fraction`` (the share of gait cycles spent
orienting), the start's ``start_y_m`` and ``start_heading_deg``, ``trial_time_s``, ``real_time_factor``.

Logs (``timeseries.h5``): every 0.064 s the time, position, heading, odour and wind at both tips; every
gait cycle the brain's branch, turn and stride; at each trial's end the plume (a raster, with the x of its
columns and the y of its rows ``plume_raster_x_m`` / ``plume_raster_y_m``, and the puffs).

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav.angles import wrap_rad
from neuronav.brains.plume_tracking import ORIENT, PlumeController
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.engine.video import VideoRecorder
from neuronav.engine.video_overlay import OdourInset, VideoContent, VideoOverlay
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.runs.trials import stack_padded
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.aggregation import (
    finished_trials,
    finite_median_of,
    mean_of,
    per_condition,
    success_rate,
    summarise,
)
from neuronav.scenarios.motor_noise import MotorNoise, stride_noise_field, turn_noise_field
from neuronav.scenarios.trial_loop import VIDEO_EVERY, trials_one_by_one
from neuronav.scenarios.variability import is_on, normal_per_trial, trial_generators, variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.senses.chemistry import OdourScene
from neuronav.senses.plume import OdourSource, PlumeConfig, WindConfig
from neuronav.spec.world import World

# Sensor samples for the metrics and figures: every this many control steps (0.064 s).
SAMPLE_EVERY = 8
# The plume raster stored at each trial's end: (rows, columns) over the 8 × 4 m arena (5 cm pixels).
RASTER_PX = (80, 160)
# The arena's half-width (m): the start must lie inside it.
ARENA_HALF_WIDTH_M = 2.0
ODOUR_MODES = ("on", "off")


@dataclass
class PlumeTrackingConfig:
    odour: str = field("on", "the brain's odour input: on, off (the control: it always searches), or both "
                       "(trial seed even: on, odd: off)", choices=("on", "off", "both"))
    wind_mps: float = field(2.0, "mean wind speed (m/s; the paper: 1.5-2)", min=0.5, max=5.0)
    wind_direction_deg: float = field(0.0, "direction the mean wind blows to, counter-clockwise from +x (deg); "
                                      "the start follows the plume's axis", min=-10.0, max=10.0)
    wind_gain: float = field(0.4, "G, the gain of the wind's coloured noise: the plume's meander (m/s per "
                             "sqrt(rad/s); Farrell et al. 2002: 0.2)", min=0.0, max=10.0)
    release_rate_hz: float = field(10.0, "puffs released per second at the source (the paper's pompy: 60)",
                                   min_exclusive=0.0, max=1e4)
    # At most the plume model's MAX_PUFF_AMOUNT, as an integer so that neuronav list writes it in full.
    puff_amount: float = field(3e-7, "odour carried by one puff (amount; the paper's pompy: 1)",
                               min_exclusive=0.0, max=10**9)
    source_x_m: float = field(0.5, "the source's x at the upwind end of the 8 x 4 m arena (m)", min=0.1, max=4.0)
    warmup_s: float = field(10.0, "the plume runs this long before the ant starts (s)", min=0.0, max=120.0)
    start_x_m: float = field(7.0, "the ant starts at this x, downwind (m)", min=1.0, max=7.9)
    start_lateral_m: float = field(0.5, "the start's y is drawn uniformly within +-this of the plume axis (m)",
                                   min=0.0, max=1.9)
    start_heading_deg: float = field(45.0, "the start heading is drawn uniformly within +-this of upwind (deg; "
                                     "180: any heading)", min=0.0, max=180.0)
    stride_rule: str = field("mod", "eq. 3.11's orienting stride: mod (5 deg + (m - h) mod 5 deg, as printed) "
                             "or divide (5 deg + |m - h| / 5, at most 15 deg)", choices=("mod", "divide"))
    sensing: str = field("instant", "the odour eq. 3.11 reads once per gait cycle: each antenna's odour now "
                         "(instant, the paper) or its highest since the last cycle, sampled every 8 ms (cycle_peak)",
                         choices=("instant", "cycle_peak"))
    threshold: float = field(1e-6, "odour detection threshold T_o (amount/m^3; the paper: 1e-6)",
                             min_exclusive=0.0, max=1e3)
    success_radius_m: float = field(0.5, "success: the root or an antenna tip comes this close to the source (m)",
                                    min_exclusive=0.0, max=3.0)
    timeout_s: float = field(60.0, "a trial gives up after this long (s)", min_exclusive=0.0, max=3600.0)
    timestep_s: float = settings.timestep_field()
    variability: str = variability_field()
    odour_noise_sd: float = field(1e-7, "std of the error on each antenna's odour reading, per gait cycle "
                                  "(amount/m^3; variability=on)", min=0.0, max=1e3)
    wind_noise_deg: float = field(5.0, "std of the error on the direction of each antenna's wind reading, per "
                                  "gait cycle (deg; variability=on)", min=0.0, max=180.0)
    compass_noise_deg: float = field(3.0, "std of the error on the heading the brain reads, per gait cycle (deg; "
                                     "variability=on)", min=0.0, max=180.0)
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()

    def cross_check(self) -> None:
        if self.start_x_m - self.success_radius_m - 1.0 <= self.source_x_m:
            raise ConfigError(f"start_x_m ({self.start_x_m:g}) must be more than success_radius_m + 1 m "
                              f"({self.success_radius_m:g} + 1) downwind of source_x_m ({self.source_x_m:g}): "
                              "the ant (about 1 m long) would start at the source")
        reach_m = abs(axis_y_m(self, self.start_x_m)) + self.start_lateral_m
        if reach_m >= ARENA_HALF_WIDTH_M:
            raise ConfigError(f"the start may lie {reach_m:.2f} m from the arena's centre line (the plume's axis "
                              f"at start_x_m, wind_direction_deg {self.wind_direction_deg:g}, plus start_lateral_m "
                              f"{self.start_lateral_m:g}): it must stay inside the arena's +-{ARENA_HALF_WIDTH_M:g} m")


def axis_y_m(config: PlumeTrackingConfig, x_m: float) -> float:
    """The y of the plume's axis (the mean wind's line through the source) at ``x_m`` (m)."""
    if config.wind_direction_deg == 0.0:
        return 0.0
    return float(np.tan(np.radians(config.wind_direction_deg)) * (x_m - config.source_x_m))


def mean_wind_mps(config: PlumeTrackingConfig) -> tuple[float, float]:
    """The mean wind (x, y), m/s."""
    if config.wind_direction_deg == 0.0:
        return (config.wind_mps, 0.0)
    direction = np.radians(config.wind_direction_deg)
    return (float(config.wind_mps * np.cos(direction)), float(config.wind_mps * np.sin(direction)))


def odour_mode(config: PlumeTrackingConfig, seed: int) -> str:
    """The odour input trial ``seed`` uses (``both``: even seeds on, odd seeds off)."""
    return ODOUR_MODES[seed % 2] if config.odour == "both" else config.odour


def plume_config(config: PlumeTrackingConfig) -> PlumeConfig:
    """The filament plume of the arena: one source at (source_x_m, 0) releasing ``release_rate_hz``
    puffs of ``puff_amount``, the wind :func:`mean_wind_mps` with the meander ``wind_gain``."""
    source = OdourSource(position_m=(config.source_x_m, 0.0, 0.0), release_rate_hz=config.release_rate_hz,
                         puff_amount=config.puff_amount)
    return PlumeConfig(sources=(source,), wind=WindConfig(mean_mps=mean_wind_mps(config), gain=config.wind_gain))


def plume_world(config: PlumeTrackingConfig) -> World:
    """A flat floor with the plume, warmed up for ``warmup_s`` before the trial starts."""
    return World(odour=OdourScene(plume=plume_config(config), warmup_s=config.warmup_s))


def start_pose(config: PlumeTrackingConfig, seed: int) -> tuple[np.ndarray, float]:
    """Trial ``seed``'s start: position (x, y) m and heading (clockwise from +y) rad."""
    rng = np.random.default_rng([seed, 12])
    lateral = float(rng.uniform(-config.start_lateral_m, config.start_lateral_m))
    # Upwind (against the wind along +x) is the heading −π/2, clockwise from +y; a wind turned
    # counter-clockwise turns it the other way.
    spread = np.radians(config.start_heading_deg)
    upwind = -np.pi / 2 - np.radians(config.wind_direction_deg)
    heading = float(wrap_rad(upwind + rng.uniform(-spread, spread)))
    return np.array([config.start_x_m, axis_y_m(config, config.start_x_m) + lateral]), heading


class PlumeNoise:
    """Trial ``seed``'s sensor and motor noise, drawn once per gait cycle from its own streams (none
    with ``variability=off``): what the brain reads (:meth:`senses`: odour, wind, heading), then its
    command (:class:`neuronav.scenarios.motor_noise.MotorNoise`, :attr:`command`)."""

    def __init__(self, config: PlumeTrackingConfig, seed: int) -> None:
        on = is_on(config)
        self.sd = {"odour": config.odour_noise_sd, "wind": np.radians(config.wind_noise_deg),
                   "compass": np.radians(config.compass_noise_deg)}
        self.sd = {k: float(v) if on else 0.0 for k, v in self.sd.items()}
        self.rng = {k: trial_generators([seed], k) for k in self.sd}
        self.command = MotorNoise(seed, config.turn_noise_sd if on else 0.0,
                                  config.stride_noise_fraction if on else 0.0)

    def _draw(self, source: str, shape=()) -> np.ndarray:
        return normal_per_trial(self.rng[source], shape, self.sd[source])[0]

    def senses(self, odour: np.ndarray, wind_mps: np.ndarray, heading_rad: np.ndarray):
        """``odour`` (1, tips, K), ``wind_mps`` (1, tips, 2) and ``heading_rad`` (1, 1) with this cycle's
        errors: the odour's added, each tip's wind turned by its angle, the heading's added."""
        if self.sd["odour"]:
            odour = odour + self._draw("odour", odour.shape[1:])[None]
        if self.sd["wind"]:
            angle = self._draw("wind", wind_mps.shape[1:2])
            cos, sin = np.cos(angle), np.sin(angle)
            x, y = wind_mps[0, :, 0], wind_mps[0, :, 1]
            wind_mps = np.stack([cos * x - sin * y, sin * x + cos * y], axis=-1)[None]
        if self.sd["compass"]:
            heading_rad = heading_rad + self._draw("compass")
        return odour, wind_mps, heading_rad


class OdourPeak(Hook):
    """Each antenna tip's highest odour (summed over odours) since it was last taken, read after every
    control step (8 ms): what the antennae met during a gait cycle (``sensing=cycle_peak``)."""

    def __init__(self) -> None:
        self.peak: np.ndarray | None = None

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.peak = None

    def after_step(self, loop: AgentLoop) -> None:
        now = loop.backend.read(("odour",))["odour"]
        self.peak = now.copy() if self.peak is None else np.maximum(self.peak, now)

    def take(self) -> np.ndarray | None:
        """The peaks (1, tips, K) since the last take (None before the first step), and start again."""
        peak, self.peak = self.peak, None
        return peak


class PlumeBrain:
    """Antennae → eq. 3.11 (:class:`PlumeController`) → (θ, S_l), once per gait cycle; with ``peaks`` (an
    :class:`OdourPeak` in the loop) it reads each tip's highest odour since the last cycle."""

    def __init__(self, config: PlumeTrackingConfig, seed: int, peaks: OdourPeak | None = None) -> None:
        self.config, self.odour, self.peaks = config, odour_mode(config, seed), peaks
        self.controller = PlumeController(agents=1, seed=np.random.default_rng([seed, 13]),
                                          threshold=config.threshold, stride_rule=config.stride_rule)
        self.noise = PlumeNoise(config, seed)
        self.log: dict[str, list] = {k: [] for k in ("cycle_time_s", "branch", "turn", "stride_rad")}

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        sensed = loop.backend.read(("odour", "wind", "heading"))
        peak = self.peaks.take() if self.peaks is not None else None
        now = sensed["odour"] if peak is None else np.maximum(peak, sensed["odour"])
        odour, wind, heading = self.noise.senses(now, sensed["wind"], sensed["heading"])
        if self.odour == "off":
            odour = np.zeros_like(odour)
        turn, stride, branch = self.controller.step(odour, wind, heading)
        turn, stride = self.noise.command(float(turn[0]), float(stride[0]))
        for key, value in (("cycle_time_s", loop.time_s), ("branch", branch[0]), ("turn", turn),
                           ("stride_rad", stride)):
            self.log[key].append(float(value))
        return turn, stride


class SensorLog(Hook):
    """Position, heading, odour and wind at both antenna tips every ``every`` control steps."""

    def __init__(self, every: int = SAMPLE_EVERY) -> None:
        self.every = every
        self.log: dict[str, list] = {k: [] for k in ("time_s", "position_m", "heading_rad", "odour", "wind_mps")}

    def initialize_episode(self, loop: AgentLoop) -> None:
        self._sample(loop)

    def after_step(self, loop: AgentLoop) -> None:
        if loop.control_steps % self.every == 0:
            self._sample(loop)

    def _sample(self, loop: AgentLoop) -> None:
        sensed = loop.backend.read(("position", "heading", "odour", "wind"))
        for key, value in (("time_s", loop.time_s), ("position_m", sensed["position"][0]),
                           ("heading_rad", sensed["heading"][0, 0]), ("odour", sensed["odour"][0].sum(axis=-1)),
                           ("wind_mps", sensed["wind"][0])):
            self.log[key].append(np.array(value, float))


def plume_video(config: PlumeTrackingConfig) -> VideoContent:
    """What the video shows: the plume, its source and wind (drawn for every world with a plume) and the
    antennae's odour on a log scale, each tip's bar from the brain's threshold (empty) to 10 ** 4 times it (full)."""
    return VideoContent(insets=(OdourInset(full_scale=config.threshold * 1e4, decades=4.0),))


def plume_trial(config: PlumeTrackingConfig, backend_name: str, seed: int, video_path=None,
                start: tuple[tuple[float, float], float] | None = None) -> tuple[dict, dict]:
    """One trial: the metrics row and its log. ``start`` ((x, y) m, heading rad) replaces the drawn start."""
    start_xy, heading0 = start_pose(config, seed) if start is None else (np.asarray(start[0], float), float(start[1]))
    world = plume_world(config)
    engine, body, gait, physics_dt = make_engine(backend_name, config.timestep_s)
    peaks = OdourPeak() if config.sensing == "cycle_peak" else None
    brain, sensors = PlumeBrain(config, seed, peaks), SensorLog()
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
    source = np.array([config.source_x_m, 0.0])

    def arrived(lp: AgentLoop) -> bool:
        sensed = lp.backend.read(("position", "odour_sites"))
        points = np.vstack([sensed["position"][0], sensed["odour_sites"][0, :, :2]])
        return bool(np.hypot(*(points - source).T).min() <= config.success_radius_m)

    started = time.perf_counter()
    with engine:
        engine.load(world, [body])
        video = (VideoRecorder(video_path, "follow", every=VIDEO_EVERY, compose=VideoOverlay(plume_video(config)))
                 if video_path is not None else None)
        hooks = [sensors, *([peaks] if peaks is not None else []), *([video] if video else [])]
        loop = AgentLoop(engine, gait, clocks, steering=brain, hooks=hooks)
        loop.reset(seed=seed, position_m=tuple(start_xy), yaw_rad=np.pi / 2 - heading0)
        try:
            loop.run(config.timeout_s, until=arrived)
        finally:
            if video is not None:
                video.close()
        reached = arrived(loop)
        final = engine.read(("position", "heading", "odour", "wind"))
        plume = engine.chemistry.plume
        raster = plume.rasterise(shape_px=RASTER_PX)
        raster_axes = raster_axes_m(plume.config.arena_x_m, plume.config.arena_y_m, RASTER_PX)
        puffs = plume.puffs.position_m[:, :2]
    wall_s = time.perf_counter() - started
    log = {k: np.array(v, float) for k, v in {**sensors.log, **brain.log}.items()}
    if not log["time_s"].size or log["time_s"][-1] < loop.time_s:  # the last instant, for the path's end
        for key, value in (("time_s", loop.time_s), ("position_m", final["position"][0]),
                           ("heading_rad", final["heading"][0, 0]), ("odour", final["odour"][0].sum(axis=-1)),
                           ("wind_mps", final["wind"][0])):
            log[key] = np.concatenate([log[key], np.array(value, float)[None]])
    log.update(plume_raster=raster, puffs_m=puffs, start_heading_rad=np.array(heading0))
    log.update(zip(("plume_raster_x_m", "plume_raster_y_m"), raster_axes))
    row = {"odour_on": brain.odour == "on", **plume_metrics(log, config, reached, loop.time_s, wall_s)}
    return row, log


def plume_metrics(log: dict, config: PlumeTrackingConfig, reached: bool, trial_time_s: float,
                  wall_s: float) -> dict:
    """Success, time to the source, the share of time in odour and the path's closest approach."""
    path = log["position_m"]
    distance = np.hypot(path[:, 0] - config.source_x_m, path[:, 1])
    in_odour = log["odour"].max(axis=1) > config.threshold
    branch = log["branch"]
    return {
        "success": bool(reached), "status": "ok", "error": "",
        "time_to_source_s": float(trial_time_s) if reached else float("nan"),
        "odour_fraction": float(in_odour.mean()),
        "orient_fraction": float(np.mean(branch == ORIENT)) if branch.size else 0.0,
        "closest_distance_m": float(distance.min()),
        "final_x_m": float(path[-1, 0]),
        "start_y_m": float(path[0, 1]),
        "start_heading_deg": float(np.degrees(log["start_heading_rad"])),
        "trial_time_s": float(trial_time_s),
        "real_time_factor": float(trial_time_s / wall_s) if wall_s > 0 else float("nan"),
    }


class PlumeTracking(Scenario):
    """Eq. 3.11 plume tracking on every backend, with odour or without (the control)."""

    name = "plume-tracking"
    description = ("walk up a turbulent filament plume to its source: eq. 3.11 upwind turns when odour is "
                   "sensed, random turns on the spot when not (paper §2.5.2)")
    config_type = PlumeTrackingConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    timing_metrics = ("real_time_factor",)
    # NaN by definition: the time to the source of an ant that never got there (and its median when none did).
    optional_metrics = ("time_to_source_s", "median_time_to_source_s",
                        *(f"median_time_to_source_{m}_s" for m in ODOUR_MODES))

    def smoke_config(self) -> dict:
        return {"timeout_s": 1.5, "warmup_s": 2.0}

    def check(self, config: PlumeTrackingConfig, backend: str) -> None:
        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def aggregate(self, trials: list[dict], config: PlumeTrackingConfig) -> dict:
        """Over the finished trials: the fraction that reached the source, the median time of those
        that did, and the mean share of time in odour; with ``odour=both`` also per odour input
        (``success_rate_on``, ...)."""
        rows = finished_trials(trials)
        statistics = {"success_rate{}": success_rate, "median_time_to_source{}_s": finite_median_of("time_to_source_s"),
                      "mean_odour_fraction{}": mean_of("odour_fraction")}
        overall = summarise(rows, {k.format(""): v for k, v in statistics.items()}) if rows else {}
        if config.odour != "both":
            return overall
        return overall | per_condition(trials, "odour_on", {k.format("_{}"): v for k, v in statistics.items()},
                                       labels={True: "on", False: "off"})

    def statistics(self, config: PlumeTrackingConfig) -> Statistics:
        """Odour on (``odour_on`` true) against off (false, the control): reaching the source (Fisher's
        exact test), the closest approach, the time to the source, the share of time in odour and the
        final x (Mann-Whitney U)."""
        return Statistics(condition="odour_on", metrics=("closest_distance_m", "time_to_source_s",
                                                         "odour_fraction", "final_x_m"), reference=False)

    def run(self, config: PlumeTrackingConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        rows, logs = trials_one_by_one(lambda s, video: plume_trial(config, backend, s, video), trials, seed,
                                       video_path)
        return ScenarioResult(trials=rows, timeseries=pack_logs(logs), aggregates=self.aggregate(rows, config),
                              simulated_time_s=float(np.mean([r["trial_time_s"] for r in rows])))

    def figures(self, result: ScenarioResult, config: PlumeTrackingConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.plume_tracking.figures import write_plume_figures

        return write_plume_figures(result, config, Path(out_dir))


def raster_axes_m(x_range_m, y_range_m, shape_px) -> tuple[np.ndarray, np.ndarray]:
    """The x of each column (W,) and the y of each row (H,, decreasing: row 0 at the largest y) of a
    :meth:`~neuronav.senses.plume.Plume.rasterise` image of ``shape_px`` over the rectangle."""
    (x0, x1), (y0, y1), (height, width) = x_range_m, y_range_m, shape_px
    return x0 + (np.arange(width) + 0.5) * (x1 - x0) / width, y1 - (np.arange(height) + 0.5) * (y1 - y0) / height


def pack_logs(logs: list[dict]) -> dict[str, np.ndarray]:
    """Per-trial logs as arrays with the trial first: samples and gait cycles NaN-padded, the plume
    rasters stacked, the puffs NaN-padded (:func:`neuronav.runs.trials.stack_padded`, as chunks are joined);
    ``branch`` codes index :data:`neuronav.brains.plume_tracking.BRANCHES`."""
    packed = {key: stack_padded([log[key] for log in logs], float)
              for key in ("time_s", "position_m", "heading_rad", "odour", "wind_mps", "cycle_time_s", "branch",
                          "turn", "stride_rad")}
    packed["plume_raster"] = np.stack([log["plume_raster"] for log in logs])
    for axis in ("plume_raster_x_m", "plume_raster_y_m"):  # where the raster lies (a report draws it there)
        packed[axis] = np.stack([log[axis] for log in logs])
    packed["puffs_m"] = stack_padded([log["puffs_m"] if len(log["puffs_m"]) else np.full((1, 2), np.nan)
                                      for log in logs], float)
    return packed

