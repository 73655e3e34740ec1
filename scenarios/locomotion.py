"""``locomotion``: the desert ant walks with an FK or IK gait on flat, uneven or vertical ground.

The paper's §2.2 and Fig. 2: gaits (tripod, ripple, wave; IK tripod), turning with the Table 2
yaw control, uneven terrain, and wall climbing with adhesion. One body per physics engine, so
trials run one after another; trial i uses seed ``seed + i`` (it sets the terrain and a small
random initial yaw).

Clocks: physics every ``timestep_s`` (2 ms), the gait every ``control_dt_s`` (8 ms, the paper's
control step; one gait sample per control step).

Metrics per trial: ``forward_speed_m_s`` (displacement along the initial heading per second),
``lateral_drift_m`` (sideways displacement at the end), ``turn_rate_rad_s`` (counter-clockwise
positive, so turn > 0 gives a positive rate), body height mean and variance, roll and pitch
variance, ``mean_abs_torque_nm``, ``cost_of_transport`` (mechanical work Σ|τ·q̇|dt over
m·g·distance), ``climb_height_m`` (highest root height above its start), ``gait_us_per_step``
(time to compute one gait sample) and ``fell`` (the body rolled or pitched past 80° or its root
dropped below 0.1 m above the ground); ``success`` = not fell.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bodies.desert_ant import LEGS, desert_ant
from bodies.gaits import make_gait
from neuronav import registry
from neuronav.config import field
from neuronav.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.scenario import Scenario, ScenarioResult
from neuronav.world import Ground, World

TERRAINS = {
    "flat": dict(kind="flat"),
    "uneven-1": dict(kind="uneven", roughness_m=0.02),
    "uneven-2": dict(kind="uneven", roughness_m=0.05),
    "wall": dict(kind="wall", wall_distance_m=1.0),
}
GRAVITY_M_S2 = 9.81
MIDDLE_RIGHT = "MR"


@dataclass
class LocomotionConfig:
    """Settings of the locomotion scenario (defaults: the paper's tripod gait on flat ground)."""

    gait: str = field("tripod", "gait: FK tripod, ripple, wave, or the IK tripod",
                      choices=("tripod", "ripple", "wave", "ik"))
    terrain: str = field("flat", "ground: flat, uneven-1 (2 cm bumps), uneven-2 (5 cm), wall",
                         choices=tuple(TERRAINS))
    adhesion_n: float = field(0.0, "force pressing each touching claw into its surface (N)", min=0.0, max=1000.0)
    duration_s: float = field(4.0, "simulated time per trial (s)", min_exclusive=0.0, max=600.0)
    turn: float = field(0.0, "rotation configuration θ: 0 straight, ±1 on the spot (+ = left)", min=-1.0, max=1.0)
    stride_deg: float = field(15.0, "hip swing S_l (deg)", min=0.0, max=40.0)
    timestep_s: float = field(0.002, "physics step (s)", min_exclusive=0.0, max=0.01)
    control_dt_s: float = field(0.008, "gait step (s): an integer multiple of timestep_s",
                                min_exclusive=0.0, max=0.1)
    leg_scale: float = field(1.0, "all leg lengths times this factor", min_exclusive=0.0, max=3.0)
    initial_yaw_jitter_rad: float = field(0.05, "initial yaw uniform in ±this", min=0.0, max=np.pi)
    roughness_seed_offset: int = field(0, "added to the trial seed to pick the terrain", min=0)


class Locomotion(Scenario):
    """Gaits, terrains and wall climbing on a physics backend."""

    name = "locomotion"
    description = "the desert ant walks: FK/IK gaits, turning, uneven ground, wall climbing (paper §2.2)"
    config_type = LocomotionConfig
    backends = ("mujoco", "pybullet")
    default_backend = "mujoco"
    records_video = True
    timing_metrics = ("gait_us_per_step", "real_time_factor")

    def smoke_config(self) -> dict:
        return {"duration_s": 0.3}

    def run(self, config: LocomotionConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        integer_ratio(config.control_dt_s, config.timestep_s, "control_dt_s / timestep_s")
        rows, series = [], []
        for i in range(trials):
            row, recorded = run_trial(config, backend, seed + i, video_path if i == 0 else None)
            rows.append(dict(row, trial=i, seed=seed + i))
            series.append(recorded)
        timeseries = {key: np.stack([s[key] for s in series]) for key in series[0]}
        return ScenarioResult(trials=rows, timeseries=timeseries, simulated_time_s=config.duration_s)

    def figures(self, result: ScenarioResult, config: LocomotionConfig, out_dir: Path) -> list[Path]:
        from scenarios.locomotion_figures import write_figures

        return write_figures(result, config, Path(out_dir))


def build_world(config: LocomotionConfig, seed: int) -> World:
    """The world of one trial: the terrain preset (its bumps seeded) and the adhesion force."""
    ground = Ground(**TERRAINS[config.terrain], seed=seed + config.roughness_seed_offset)
    return World(ground=ground, adhesion_n=config.adhesion_n)


class LocomotionRecorder(Hook):
    """Records what the locomotion metrics and figures need, once per control step."""

    def __init__(self, body, steps: int, control_dt_s: float, video: bool) -> None:
        names = list(body.joint_names)
        self.middle_right = [names.index(f"{MIDDLE_RIGHT}_{j}") for j in ("ThCz", "CTr", "FTi")]
        contact_sites = [s.name for s in body.sites_of_kind("contact")]
        self.claws = [i for i, n in enumerate(contact_sites) if n.split("_")[0] in LEGS]
        self.control_dt_s, self.video = control_dt_s, video
        self.work_j = self.torque_sum = 0.0
        self.frames: list[np.ndarray] = []
        self.record = {
            "position_m": np.zeros((steps + 1, 3)), "heading_rad": np.zeros(steps + 1),
            "roll_rad": np.zeros(steps + 1), "pitch_rad": np.zeros(steps + 1),
            "mr_angles_rad": np.zeros((steps, 3)), "mr_torques_nm": np.zeros((steps, 3)),
            "claw_force_n": np.zeros((steps, len(self.claws))),
        }

    def initialize_episode(self, loop: AgentLoop) -> None:
        self._pose(loop, 0)

    def after_step(self, loop: AgentLoop) -> None:
        t = loop.control_steps - 1
        sensed = loop.backend.read(("joint_pos", "joint_vel", "joint_torque", "contact_force"))
        torque, velocity = sensed["joint_torque"][0], sensed["joint_vel"][0]
        self.work_j += float(np.abs(torque * velocity).sum()) * self.control_dt_s
        self.torque_sum += float(np.abs(torque).mean())
        self.record["mr_angles_rad"][t] = sensed["joint_pos"][0, self.middle_right]
        self.record["mr_torques_nm"][t] = torque[self.middle_right]
        self.record["claw_force_n"][t] = np.linalg.norm(sensed["contact_force"][0, self.claws], axis=1)
        self._pose(loop, t + 1)
        if self.video and t % 4 == 0:  # 31 frames per second of 8 ms steps
            self.frames.append(loop.backend.render("follow"))

    def _pose(self, loop: AgentLoop, index: int) -> None:
        sensed = loop.backend.read(("body_pos", "body_quat", "heading"))
        self.record["position_m"][index] = sensed["body_pos"][0]
        self.record["heading_rad"][index] = sensed["heading"][0, 0]
        self.record["roll_rad"][index], self.record["pitch_rad"][index] = roll_pitch_rad(sensed["body_quat"][0])


def run_trial(config: LocomotionConfig, backend_name: str, seed: int,
              video_path: Path | None = None) -> tuple[dict, dict[str, np.ndarray]]:
    """Walk one trial; return its metrics and recorded signals (one sample per control step)."""
    rng = np.random.default_rng(seed)
    body = desert_ant(leg_length_factors=config.leg_scale)
    steps = int(round(config.duration_s / config.control_dt_s))
    clocks = Clocks(physics_dt_s=config.timestep_s, control_dt_s=config.control_dt_s,
                    brain_dt_s=config.control_dt_s)
    recorder = LocomotionRecorder(body, steps, config.control_dt_s, video=video_path is not None)
    yaw0 = float(rng.uniform(-config.initial_yaw_jitter_rad, config.initial_yaw_jitter_rad))
    with registry.load("backend", backend_name)(timestep_s=config.timestep_s) as engine:
        engine.load(build_world(config, seed), [body])
        loop = AgentLoop(engine, make_gait(config.gait, body), clocks, hooks=[recorder],
                         turn=config.turn, stride_rad=np.radians(config.stride_deg))
        loop.reset(seed=seed, position_m=(0.0, 0.0), yaw_rad=yaw0)
        started = time.perf_counter()
        loop.run(config.duration_s)
        wall_s = time.perf_counter() - started
    if video_path is not None:
        write_video(video_path, recorder.frames, fps=1.0 / (4 * config.control_dt_s))
    metrics = trial_metrics(recorder.record, config, body.total_mass_kg, recorder.work_j,
                            recorder.torque_sum / max(steps, 1), loop.gait_time_s / max(steps, 1), wall_s)
    return metrics, recorder.record


def roll_pitch_rad(quat: np.ndarray) -> tuple[float, float]:
    """Roll (about the body's forward axis) and pitch of a (w, x, y, z) quaternion."""
    w, x, y, z = quat
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    return float(roll), float(pitch)


def trial_metrics(record: dict, config: LocomotionConfig, mass_kg: float, work_j: float,
                  mean_abs_torque_nm: float, gait_s_per_step: float, wall_s: float) -> dict:
    """Scalar metrics of one trial from its recorded signals."""
    position, heading = record["position_m"], record["heading_rad"]
    start, end = position[0, :2], position[-1, :2]
    forward = np.array([np.sin(heading[0]), np.cos(heading[0])])
    left = np.array([-forward[1], forward[0]])
    displacement = end - start
    yaw = np.unwrap(np.pi / 2 - heading)
    height = position[:, 2]
    distance_m = float(np.linalg.norm(np.diff(position[:, :2], axis=0), axis=1).sum())
    fell = bool(np.any(np.abs(record["roll_rad"]) > np.radians(80))
                or np.any(np.abs(record["pitch_rad"]) > np.radians(80)) or height.min() < 0.1)
    return {
        "success": not fell, "status": "ok", "error": "",
        "forward_speed_m_s": float(displacement @ forward / config.duration_s),
        "lateral_drift_m": float(displacement @ left),
        "turn_rate_rad_s": float((yaw[-1] - yaw[0]) / config.duration_s),
        "body_height_mean_m": float(height.mean()), "body_height_var_m2": float(height.var()),
        "roll_var_rad2": float(np.var(record["roll_rad"])), "pitch_var_rad2": float(np.var(record["pitch_rad"])),
        "mean_abs_torque_nm": mean_abs_torque_nm,
        "cost_of_transport": float(work_j / (mass_kg * GRAVITY_M_S2 * distance_m)) if distance_m > 1e-3 else np.nan,
        "climb_height_m": float(height.max() - height[0]),
        "gait_us_per_step": 1e6 * gait_s_per_step,
        "real_time_factor": float(config.duration_s / wall_s) if wall_s > 0 else np.nan,
        "fell": fell,
    }


def write_video(path: Path, frames: list[np.ndarray], fps: float) -> None:
    """Write RGB frames to an MP4 (imageio with its ffmpeg plugin)."""
    import imageio.v2 as imageio

    if not frames:
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".partial.mp4")
    with imageio.get_writer(temporary, fps=fps, codec="libx264", quality=7, macro_block_size=8) as writer:
        for frame in frames:
            writer.append_data(frame)
    temporary.replace(path)
