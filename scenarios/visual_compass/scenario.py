"""Visual compass (the I2Bot paper's §2.4.2, Fig. 5): the ant keeps facing where it faced, by its panorama.

The ant stands in the compass scene (five coloured objects 13–17 m around,
:func:`neuronav.scenarios.worlds.scenes.compass_scene`).
Once per gait cycle (0.64 s) the brain reads its panorama, takes the phase Φ of the Zernike moment
Z_{7,1} (:mod:`neuronav.brains.vision`), stores it at the first cycle and steers by eq. 3.10:

    θ   = sign(Φ(t) − Φ(0))       (which way the phase says the ant has turned)
    S_l = |Φ(t) − Φ(0)| / 5       (degrees; nothing inside the 0.8° dead band)

Meanwhile the world turns about the vertical axis (``backend.set_scene_yaw``): ``rotation=incremental``
adds ``incremental_rad`` every gait cycle, ``rotation=jump`` jumps to a random angle in [−π, π]
every ``jump_every_s`` (the last jump a whole interval before the end, so each can be
recovered). Turning the scene counter-clockwise by α moves the stored direction from heading h₀ to
h₀ − α (headings clockwise from +y): the error is the ant's heading minus that.

Trials differ (``variability=on``): start jitter (the scene moves), eye pixel and motor noise, each a setting
(:mod:`neuronav.scenarios.eye_noise`, :mod:`neuronav.scenarios.motor_noise`); ``variability=off``: the paper's protocol.

Metrics per trial: ``mean_error_deg`` (after the first gait cycle), ``final_error_deg`` and the signed
``final_error_rad`` (+ = clockwise of the stored direction), ``jumps``, ``recovered_fraction``,
``mean_recovery_s`` and ``max_recovery_s`` (within ``recovered_deg``); ``success``: mean error within
``recovered_deg`` (incremental) or every jump recovered (jump); statistics: one group, ``final_error_rad`` circular.

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from neuronav.angles import wrap_rad
from neuronav.brains.vision import ZernikeBasis, compass_command
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.engine.video_overlay import EyeInset, VideoContent
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import EVERY_BACKEND, settings
from neuronav.scenarios.eye_noise import EyeNoise, eye_pixel_noise_field
from neuronav.scenarios.motor_noise import MotorNoise, stride_noise_field, turn_noise_field
from neuronav.scenarios.trial_loop import run_loop, trials_one_by_one
from neuronav.scenarios.variability import is_on, jitter_start, trial_generators, variability_field
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.scenarios.worlds.scenes import compass_scene, pack_world, world_record
from neuronav.senses.compound_eye_vision import compass_panorama
from neuronav.spec.world import World

EYE_KINDS = ("camera", "compound")


@dataclass
class VisualCompassConfig:
    rotation: str = field("incremental", "how the world turns: incremental (a little every gait cycle) or jump "
                          "(to a random angle every jump_every_s)", choices=("incremental", "jump"))
    # The first look stores the direction, the next (one gait cycle later) is the first to measure the error.
    duration_s: float = field(40.0, "simulated time per trial (s): at least two gait cycles", min=2 * CYCLE_S,
                              max=3600.0)
    incremental_rad: float = field(0.01, "incremental: the world turns this much every gait cycle (rad)",
                                   min=-0.5, max=0.5)
    jump_every_s: float = field(10.0, "jump: the world jumps to a new random angle this often (s)", min=1.28,
                                max=3600.0)
    eyes: str = field("camera", "what the eyes are: camera (the 72 x 72 panoramic camera) or compound (both "
                      "compound eyes' UV channel laid out on the panorama's grid)", choices=EYE_KINDS)
    dead_band_deg: float = field(0.8, "no turn while the phase differs from the stored one by less (deg)",
                                 min=0.0, max=45.0)
    recovered_deg: float = field(10.0, "a jump is recovered once the heading error is within this (deg)",
                                 min_exclusive=0.0, max=90.0)
    timestep_s: float = settings.timestep_field()
    variability: str = variability_field()
    start_position_sd_m: float = field(0.5, "start jitter: std of each start coordinate's Gaussian offset (m), with "
                                       "variability=on (0.5: half the ant's body length at x100)", min=0.0, max=5.0)
    eye_pixel_noise_sd: float = eye_pixel_noise_field()
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()


class SceneRotation(Hook):
    """Turns the world on its schedule, at the start of each gait cycle (before the brain looks again)."""

    def __init__(self, config: VisualCompassConfig, seed: int) -> None:
        self.config = config
        self.rng = np.random.default_rng([seed, 5])
        self.yaw_rad = 0.0
        self.cycles = integer_ratio(CYCLE_S, CONTROL_S, "gait cycle / control step")
        self.jump_steps = int(round(config.jump_every_s / CONTROL_S))
        self.jump_times_s: list[float] = []

    def initialize_episode(self, loop: AgentLoop) -> None:
        loop.backend.set_scene_yaw(0.0)

    def after_step(self, loop: AgentLoop) -> None:
        step = loop.control_steps
        if self.config.rotation == "incremental":
            if step % self.cycles == 0:
                self.yaw_rad += self.config.incremental_rad
                loop.backend.set_scene_yaw(self.yaw_rad)
        elif step % self.jump_steps == 0 and loop.time_s + self.config.jump_every_s <= self.config.duration_s + 1e-9:
            # A jump every jump_every_s, the last one a whole interval before the end (time to recover).
            self.yaw_rad = float(self.rng.uniform(-np.pi, np.pi))
            self.jump_times_s.append(loop.time_s)
            loop.backend.set_scene_yaw(self.yaw_rad)


class CompassBrain:
    """Panorama → Z_{7,1} phase → eq. 3.10, once per gait cycle; logs what the figure and metrics need."""

    def __init__(self, config: VisualCompassConfig, rotation: SceneRotation, seed: int = 0, compound_eyes=()) -> None:
        self.config, self.rotation = config, rotation
        # eyes=compound: both eyes' UV (the sky bright, the objects dark) on the panoramic camera's grid.
        self.adapter = compass_panorama(compound_eyes) if config.eyes == "compound" else None
        noisy = is_on(config)
        self.eye_noise = EyeNoise(seed, config.eye_pixel_noise_sd if noisy else 0.0)
        self.motor_noise = MotorNoise(seed, config.turn_noise_sd if noisy else 0.0,
                                      config.stride_noise_fraction if noisy else 0.0)
        self.basis: ZernikeBasis | None = None
        self.stored_phase_rad: float | None = None
        self.log: dict[str, list] = {k: [] for k in ("time_s", "heading_rad", "scene_yaw_rad", "phase_rad", "turn",
                                                     "stride_rad")}

    def __call__(self, loop: AgentLoop) -> tuple[float, float]:
        if self.adapter is None:
            sensed = loop.backend.read(("heading", "panorama"))
            panorama = self.eye_noise(sensed["panorama"])
        else:  # receptor noise on every ommatidium, then the panorama's grid
            names = tuple(eye.name for eye in self.adapter.eyes)
            sensed = loop.backend.read(("heading", *names))
            panorama = self.adapter(*(self.eye_noise(sensed[name]) for name in names))
        if self.basis is None:
            self.basis = ZernikeBasis(*panorama.shape[1:])
        phase = float(self.basis.compass_phase(panorama)[0])
        if self.stored_phase_rad is None:
            self.stored_phase_rad = phase
        turn, stride = compass_command(phase, self.stored_phase_rad, dead_band_deg=self.config.dead_band_deg)
        for key, value in (("time_s", loop.time_s), ("heading_rad", sensed["heading"][0, 0]),
                           ("scene_yaw_rad", self.rotation.yaw_rad), ("phase_rad", phase), ("turn", turn),
                           ("stride_rad", stride)):
            self.log[key].append(float(value))
        return self.motor_noise(float(turn), float(stride))


def compass_trial(config: VisualCompassConfig, backend_name: str, seed: int, video_path=None) -> tuple[dict, dict]:
    """One trial: the metrics row and the per-cycle log."""
    rng = np.random.default_rng([seed, 6])
    heading0 = float(rng.uniform(-np.pi, np.pi))
    world = compass_scene()
    if is_on(config):  # the ant stands off the scene's centre (the start heading is drawn over the circle either way)
        offset = jitter_start(trial_generators([seed], "start"), np.zeros((1, 2)), np.zeros(1),
                              config.start_position_sd_m, 0.0)[0][0]
        world = shifted(world, -offset)
    compound = config.eyes == "compound"
    engine, body, gait, physics_dt = make_engine(backend_name, config.timestep_s, compound_eyes=compound)
    rotation = SceneRotation(config, seed)
    brain = CompassBrain(config, rotation, seed, body.compound_eyes if compound else ())
    clocks = Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
    loop, _, wall_s = run_loop(engine, world, body, gait, clocks, brain, heading_rad=heading0, seed=seed,
                               duration_s=config.duration_s, hooks=[rotation], video_path=video_path,
                               video_content=VideoContent(insets=(EyeInset(("panorama",), "panorama", height_px=144),)))
    log = {k: np.array(v, float) for k, v in brain.log.items()}
    # The stored direction is the heading at the first look; the world's turn moves it (module doc).
    log["target_rad"] = wrap_rad(log["heading_rad"][0] - log["scene_yaw_rad"])
    log["error_rad"] = wrap_rad(log["heading_rad"] - log["target_rad"])
    return compass_metrics(log, config, rotation.jump_times_s, loop.time_s, wall_s), log


def shifted(world: World, offset_m: np.ndarray) -> World:
    """``world`` with every object moved by ``offset_m`` (x, y) m: the ant, starting at the origin, stands
    off the scene's centre by ``-offset_m`` while the world still turns about the ant's start."""
    dx, dy = (float(v) for v in offset_m)
    objects = tuple(replace(o, position_m=(o.position_m[0] + dx, o.position_m[1] + dy, o.position_m[2]))
                    for o in world.objects)
    return replace(world, objects=objects)


def compass_metrics(log: dict, config: VisualCompassConfig, jump_times_s: list[float], trial_time_s: float,
                    wall_s: float) -> dict:
    """Heading error after the first gait cycle, and the recovery after each jump."""
    time_s, error_deg = log["time_s"], np.degrees(np.abs(log["error_rad"]))
    after_first = time_s >= CYCLE_S
    recoveries = []
    for k, jumped in enumerate(jump_times_s):
        until = jump_times_s[k + 1] if k + 1 < len(jump_times_s) else np.inf
        window = (time_s > jumped) & (time_s < until)
        within = np.flatnonzero(window & (error_deg <= config.recovered_deg))
        recoveries.append(float(time_s[within[0]] - jumped) if within.size else float("nan"))
    recovered = np.isfinite(recoveries)
    mean_error = float(error_deg[after_first].mean()) if after_first.any() else float("nan")
    if config.rotation == "incremental":
        success = bool(mean_error <= config.recovered_deg)
    else:
        success = bool(len(recoveries) > 0 and recovered.all())
    return {
        "success": success, "status": "ok", "error": "",
        "mean_error_deg": mean_error,
        "final_error_deg": float(error_deg[-1]),
        "jumps": float(len(jump_times_s)),
        "recovered_fraction": float(recovered.mean()) if recoveries else float("nan"),
        "mean_recovery_s": float(np.nanmean(recoveries)) if recovered.any() else float("nan"),
        "max_recovery_s": float(np.nanmax(recoveries)) if recovered.any() else float("nan"),
        "final_error_rad": float(log["error_rad"][-1]),
        "trial_time_s": float(trial_time_s),
        "real_time_factor": float(trial_time_s / wall_s) if wall_s > 0 else float("nan"),
    }


class VisualCompass(Scenario):
    """The Zernike visual compass in a rotating world, on every backend."""

    name = "visual-compass"
    description = "keep facing the stored direction by the panorama's Zernike phase while the world turns (§2.4.2)"
    config_type = VisualCompassConfig
    backends = EVERY_BACKEND
    default_backend = "kinematic"
    records_video = True
    timing_metrics = ("real_time_factor",)
    optional_metrics = ("recovered_fraction", "mean_recovery_s", "max_recovery_s")

    def smoke_config(self) -> dict:
        return {"duration_s": 2.0}

    def statistics(self, config: VisualCompassConfig) -> Statistics:
        """One group (``rotation`` is a run's setting): the heading errors (and, with jumps, the recoveries);
        the signed final heading error as circular data."""
        jumps = ("recovered_fraction", "mean_recovery_s", "max_recovery_s") if config.rotation == "jump" else ()
        return Statistics(metrics=("mean_error_deg", "final_error_deg", *jumps), circular=("final_error_rad",))

    def check(self, config: VisualCompassConfig, backend: str) -> None:
        if backend != "kinematic":
            integer_ratio(CONTROL_S, config.timestep_s, "control step (8 ms) / timestep_s")

    def run(self, config: VisualCompassConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        rows, logs = trials_one_by_one(lambda s, video: compass_trial(config, backend, s, video), trials, seed,
                                       video_path)
        cycles = max(len(log["time_s"]) for log in logs)
        timeseries = {}
        for key in logs[0]:
            timeseries[key] = np.full((len(logs), cycles), np.nan)
            for i, log in enumerate(logs):
                timeseries[key][i, : len(log[key])] = log[key]
        timeseries.update(pack_world([world_record(compass_scene())] * len(logs)))  # its objects, unturned
        return ScenarioResult(trials=rows, timeseries=timeseries, simulated_time_s=config.duration_s)

    def figures(self, result: ScenarioResult, config: VisualCompassConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.visual_compass.figures import write_compass_figures

        return write_compass_figures(result, config, Path(out_dir))
