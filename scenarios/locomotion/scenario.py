"""``locomotion``: the desert ant walks with an FK or IK gait on flat, uneven or vertical ground.

Runs the body on a physics backend with the configured gait (tripod, ripple, wave; IK tripod), turn θ
(Table 2 yaw control) and terrain, trials one after another; trial i uses seed ``seed + i`` (terrain,
start spot on rough ground, a small random initial yaw). Physics every ``timestep_s`` (2 ms), the gait
every ``control_dt_s`` (8 ms), ramping up to the full stride over its first cycle.

``gait`` may be a comma list: trial seed s walks gait s mod their count (its row's ``gait``, the
condition the statistics compare). ``variability=on``: motor noise each gait cycle (:class:`CycleMotorNoise`).

Positions, speeds and heights are those of the body centre (the centre of mass at the rest pose, fixed
in the thorax frame 0.34 m behind the root). Metrics per trial: ``forward_speed_m_s``,
``lateral_drift_m`` (+ = left), ``turn_rate_rad_s`` (counter-clockwise positive), body height mean and
variance, roll and pitch variance (these five NaN for a start on the wall), ``mean_abs_torque_nm``,
``cost_of_transport`` (Σ|τ·q̇|dt over m·g·distance), ``climb_height_m`` (highest centre height above
the start) and ``climb_final_m`` (at the end), ``gait_us_per_step``, ``real_time_factor``, ``fell``
(:func:`fell_over`; ``success`` = not fell) and ``gait``.

Wall (``terrain=wall``): a vertical wall faces -x at x = 1 m. ``wall_start=wall`` starts the ant on it,
head up, its centre ``wall_start_height_m`` up; ``wall_start=floor`` walks it at the wall from the
origin, with ``wall_posture`` holding the climbing posture. With ``adhesion_n`` > 0 the backend presses
claws into the surface they touch: every touching claw (``adhesion_rule=touch``) or only those of legs
in stance (``adhesion_rule=stance``, the :class:`StanceAdhesion` hook).

Results, sources and model choices: README.md in this folder.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuronav import registry
from neuronav.bodies.desert_ant import LEGS, desert_ant
from neuronav.bodies.gaits import PostureGait, foot_position, make_gait, segment_pose
from neuronav.config import field
from neuronav.engine.loop import AgentLoop, Clocks, Hook, integer_ratio
from neuronav.engine.video import VideoRecorder
from neuronav.errors import ConfigError
from neuronav.runs.scenario import Scenario, ScenarioResult
from neuronav.runs.summary_statistics import Statistics
from neuronav.scenarios import PHYSICS_BACKENDS
from neuronav.scenarios.motor_noise import MotorNoise, stride_noise_field, turn_noise_field
from neuronav.scenarios.settings import choice_list
from neuronav.scenarios.variability import is_on, variability_field
from neuronav.spec.body import BodySpec, quat_to_matrix
from neuronav.spec.world import Ground, World

TERRAINS = {
    "flat": dict(kind="flat"),
    "uneven-1": dict(kind="uneven", roughness_m=0.02),
    "uneven-2": dict(kind="uneven", roughness_m=0.05),
    "wall": dict(kind="wall", wall_distance_m=1.0),
}
GRAVITY_M_S2 = 9.81
MIDDLE_RIGHT = "MR"
FALL_ANGLE_RAD = np.radians(80.0)
# Climbing posture (rad): head raised to its limit, antennae raised straight and swept back over the
# thorax (tips 0.2 m behind the root, 0.6 m up, ±0.2 m to the sides: never the first thing at the wall),
# gaster raised 17° above the thorax axis (rest: 29° below) ...
WALL_POSTURE_RAD = {
    "head_pitch": 0.8, "abdomen_pitch": -0.3,
    "antenna_L_pitch": 1.2, "antenna_L_yaw": 0.3, "antenna_L_elbow": 0.0,
    "antenna_R_pitch": 1.2, "antenna_R_yaw": -0.3, "antenna_R_elbow": 0.0,
}
# ... and the front legs' hip swing centred 0.3 rad (17°) further forward, so their claws reach the wall
# ahead of the raised head (at rest they end level with the root, 0.07 m behind the raised head's front).
WALL_OFFSETS_RAD = {"FL_ThCz": 0.3, "FR_ThCz": 0.3}
WALL_STARTS = ("wall", "floor")
ADHESION_RULES = ("touch", "stance")
# Settings' bounds: every trial ends in bounded time. A trial needs duration_s / timestep_s physics steps
# (2000 by default); more than MAX_PHYSICS_STEPS (10 minutes of simulated time at 0.6 ms, about 2 minutes
# of wall time on MuJoCo and 6 on PyBullet at the speeds of benchmarks/locomotion_speed.py) is refused.
MAX_PHYSICS_STEPS = 1_000_000
MIN_TIMESTEP_S = 1e-4
MAX_PHYSICS_PER_CONTROL = 100
# Starting on the wall: the standing body pressed this far toward the wall, so that every claw
# touches it at the first step (at exactly the standing height they hang 0.5 mm off it).
WALL_PRESS_M = 0.002


@dataclass
class LocomotionConfig:
    """Settings of the locomotion scenario (defaults: the paper's tripod gait on flat ground)."""

    gait: str = field("tripod", "gait: FK tripod, ripple, wave, or the IK tripod (ik); or a comma list of them, "
                      "walked by trial seed s mod their count (the condition the statistics compare)")
    terrain: str = field("flat", "ground: flat, uneven-1 (2 cm bumps), uneven-2 (5 cm), wall",
                         choices=tuple(TERRAINS))
    adhesion_n: float = field(0.0, "force pressing each touching claw into its surface (N)", min=0.0, max=1000.0)
    duration_s: float = field(4.0, "simulated time per trial (s): at least one control step, at most "
                              f"{MAX_PHYSICS_STEPS:,} physics steps", min_exclusive=0.0, max=600.0)
    turn: float = field(0.0, "rotation configuration θ: 0 straight, ±1 on the spot (+ = left)", min=-1.0, max=1.0)
    stride_deg: float = field(15.0, "hip swing S_l (deg)", min=0.0, max=40.0)
    timestep_s: float = field(0.002, "physics step (s)", min=MIN_TIMESTEP_S, max=0.01)
    control_dt_s: float = field(0.008, "gait step (s): an integer multiple of timestep_s, at most "
                                f"{MAX_PHYSICS_PER_CONTROL} of them", min=MIN_TIMESTEP_S, max=0.1)
    leg_scale: float = field(1.0, "all leg lengths times this factor (their masses follow the volume)",
                             min=0.5, max=1.5)
    initial_yaw_jitter_rad: float = field(0.05, "initial yaw uniform in ±this", min=0.0, max=np.pi)
    roughness_seed_offset: int = field(0, "added to the trial seed to pick the terrain", min=0, max=2**31)
    wall_start: str = field("wall", "terrain=wall: start on the wall, head up (as in I2Bot's climbing world), "
                            "or on the floor walking at it", choices=WALL_STARTS)
    wall_start_height_m: float = field(1.5, "wall_start=wall: the body centre's start height (m)", min=0.8, max=6.0)
    adhesion_rule: str = field("touch", "which claws adhesion presses: touch = every touching claw (I2Bot), "
                               "stance = only those of legs in stance (pads released at lift-off)",
                               choices=ADHESION_RULES)
    wall_posture: bool = field(True, "wall_start=floor: head and gaster up, antennae folded, front legs reach further")
    variability: str = variability_field()
    turn_noise_sd: float = turn_noise_field()
    stride_noise_fraction: float = stride_noise_field()

    def __post_init__(self) -> None:
        gaits(self)
        # Checked here, not only when running, so that a bad pair is a ConfigError (CLI exit 2) up front.
        # (Values outside their own ranges are left to the per-field checks, which name the field.)
        numbers = (self.control_dt_s, self.timestep_s, self.duration_s)
        if (all(isinstance(v, (int, float)) and np.isfinite(v) and v > 0 for v in numbers)
                and min(self.control_dt_s, self.timestep_s) >= MIN_TIMESTEP_S):
            check_clocks(self)


GAITS = ("tripod", "ripple", "wave", "ik")


def gaits(config: LocomotionConfig) -> tuple[str, ...]:
    """The gaits of ``config.gait`` (one, or a comma list of distinct ones).

    Raises
    ------
    ConfigError
        An unknown or repeated gait.
    """
    return choice_list("gait", config.gait, tuple(GAITS), repeats=False)


def trial_gait(config: LocomotionConfig, seed: int) -> str:
    """The gait trial seed ``seed`` walks: number ``seed`` mod the count of :func:`gaits`."""
    names = gaits(config)
    return names[seed % len(names)]


def check_clocks(config: LocomotionConfig) -> None:
    """The cross-field rules of the three times: they keep every trial finite and bounded.

    Raises
    ------
    ConfigError
        ``control_dt_s`` not a whole multiple of ``timestep_s`` or more than ``MAX_PHYSICS_PER_CONTROL``
        of them; ``duration_s`` shorter than one control step; a trial of more than ``MAX_PHYSICS_STEPS``
        physics steps.
    """
    ratio = integer_ratio(config.control_dt_s, config.timestep_s, "control_dt_s / timestep_s")
    if ratio > MAX_PHYSICS_PER_CONTROL:
        raise ConfigError(f"control_dt_s / timestep_s = {ratio}: at most {MAX_PHYSICS_PER_CONTROL} physics steps "
                          f"per control step (raise timestep_s or lower control_dt_s)")
    if config.duration_s < config.control_dt_s:
        raise ConfigError(f"duration_s = {config.duration_s} s is shorter than one control step "
                          f"(control_dt_s = {config.control_dt_s} s)")
    steps = config.duration_s / config.timestep_s
    if steps > MAX_PHYSICS_STEPS * (1 + 1e-9):  # (a float quotient may land a hair above a round count)
        raise ConfigError(f"duration_s / timestep_s = {steps:.3g} physics steps per trial; at most "
                          f"{MAX_PHYSICS_STEPS:,} (shorten duration_s or raise timestep_s)")


class Locomotion(Scenario):
    """Gaits, terrains and wall climbing on a physics backend."""

    name = "locomotion"
    description = "the desert ant walks: FK/IK gaits, turning, uneven ground, wall climbing (paper §2.2)"
    config_type = LocomotionConfig
    backends = PHYSICS_BACKENDS
    default_backend = "mujoco"
    records_video = True
    timing_metrics = ("gait_us_per_step", "real_time_factor")
    condition_columns = ("gait",)
    # NaN by definition for a body started on the wall (heading, roll and pitch are taken against
    # the floor) and, for cost_of_transport, below 1 mm travelled.
    optional_metrics = ("forward_speed_m_s", "lateral_drift_m", "turn_rate_rad_s", "roll_var_rad2", "pitch_var_rad2",
                        "cost_of_transport")
    chunk_trials = 1  # one body per engine: trials run one after another anyway

    def smoke_config(self) -> dict:
        return {"duration_s": 0.3}

    def statistics(self, config: LocomotionConfig) -> Statistics:
        """The gaits compared (the rows' ``gait`` column, against the first gait listed): speed, drift,
        turning, body height and its variance, roll and pitch variance, torque, cost of transport, climb;
        success is not falling."""
        return Statistics(condition="gait", reference=gaits(config)[0])

    def run(self, config: LocomotionConfig, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        check_clocks(config)
        rows, series = [], []
        for i in range(trials):
            row, recorded = run_trial(config, backend, seed + i, video_path if i == 0 else None)
            rows.append(dict(row, trial=i, seed=seed + i))
            series.append(recorded)
        timeseries = {key: np.stack([s[key] for s in series]) for key in series[0]}
        if config.terrain == "wall":  # the wall's foot, 1 m either side of the ant's line (a report draws it)
            distance_m = TERRAINS["wall"]["wall_distance_m"]
            timeseries["wall_line_m"] = np.tile([[distance_m, -1.0], [distance_m, 1.0]], (trials, 1, 1))
        return ScenarioResult(trials=rows, timeseries=timeseries, simulated_time_s=config.duration_s)

    def figures(self, result: ScenarioResult, config: LocomotionConfig, out_dir: Path) -> list[Path]:
        from neuronav.scenarios.locomotion.figures import write_figures

        return write_figures(result, config, Path(out_dir))


def build_gait(config: LocomotionConfig, body: BodySpec, name: str | None = None):
    """The gait ``name`` (default: the first of ``config.gait``); on the wall (with ``wall_posture``)
    holding the climbing posture."""
    gait = make_gait(name or gaits(config)[0], body)
    if config.terrain == "wall" and config.wall_start == "floor" and config.wall_posture:
        gait = PostureGait(gait, WALL_POSTURE_RAD, WALL_OFFSETS_RAD)
    return gait


def start_pose_kwargs(config: LocomotionConfig, body: BodySpec, ground: Ground, yaw_rad: float,
                      rng: np.random.Generator) -> dict:
    """The backend reset pose of one trial.

    On the floor (and walking at the wall): the root on the ground near the origin, turned by
    ``yaw_rad`` (:func:`start_position_m`). Starting on the wall: head up, belly to the wall (the body
    pitched 90° nose-up), the root its standing height off the wall face (less ``WALL_PRESS_M``) and
    high enough that the body centre is ``wall_start_height_m`` up, turned by ``yaw_rad`` on the wall
    (+ turns the nose toward +y: to the ant's left).
    """
    if config.terrain != "wall" or config.wall_start == "floor":
        return {"position_m": start_position_m(ground, body, yaw_rad, rng), "yaw_rad": yaw_rad}
    centre = body_centre_m(body)
    # Pitched nose-up by 90°, body x points up (+z) and body z toward -x: a root-frame point (a, b, c)
    # sits at root + (-c, b, a).
    root_x = ground.wall_distance_m - body.spawn_height_m + WALL_PRESS_M
    root_z = config.wall_start_height_m - centre[0]
    return {"position_m": (root_x, 0.0, root_z), "yaw_rad": 0.0, "pitch_rad": np.pi / 2, "spin_rad": yaw_rad}


class StanceAdhesion(Hook):
    """``adhesion_rule=stance``: before each control step, switch each claw's pad on while its leg is
    in stance and off while it swings (insects detach their pads at lift-off); other contact sites
    stay on (they are not adhesive anyway)."""

    def __init__(self, body: BodySpec) -> None:
        legs = [s.name.split("_")[0] for s in body.sites_of_kind("contact")]
        self.claw_sites = np.array([i for i, leg in enumerate(legs) if leg in LEGS], dtype=int)
        self.claw_legs = np.array([LEGS.index(leg) for leg in legs if leg in LEGS], dtype=int)
        self.pads = np.ones((1, len(legs)))

    def before_step(self, loop: AgentLoop) -> None:
        swing = loop.gait.in_swing(loop.gait.step_index)
        self.pads[0, self.claw_sites] = ~swing[self.claw_legs]
        loop.backend.write({"adhesion": self.pads})


def build_world(config: LocomotionConfig, seed: int) -> World:
    """The world of one trial: the terrain preset (its bumps seeded) and the adhesion force."""
    ground = Ground(**TERRAINS[config.terrain], seed=seed + config.roughness_seed_offset)
    return World(ground=ground, adhesion_n=config.adhesion_n)


def ground_height_m(ground: Ground, xy_m) -> np.ndarray:
    """Terrain height under each point of ``xy_m`` (..., 2): :meth:`Ground.height_at` (the one lookup)."""
    xy_m = np.asarray(xy_m, float)
    return np.asarray(ground.height_at(xy_m[..., 0], xy_m[..., 1]), float)


def start_position_m(ground: Ground, body: BodySpec, yaw_rad: float, rng: np.random.Generator,
                     radius_m: float = 3.0, tries: int = 200) -> tuple[float, float]:
    """Where the root starts: the origin, or on rough ground a nearby spot where no claw starts in the ground.

    Backends put the root ``spawn_height_m`` above the terrain under the root; where the ground under
    a foot is higher, that claw would start inside the terrain (by up to 0.1 m on ``uneven-2``).
    MuJoCo cannot push a claw out of a heightfield from that deep (it stays trapped and the ant
    cannot walk), so on uneven ground the start is drawn (seeded) within ``radius_m`` of the origin
    among spots where the ground under every claw is no higher than under the root.
    """
    if ground.kind != "uneven" or ground.roughness_m == 0:
        return (0.0, 0.0)
    rotation = np.array([[np.cos(yaw_rad), -np.sin(yaw_rad)], [np.sin(yaw_rad), np.cos(yaw_rad)]])
    feet = np.array([foot_position(body, leg, body.rest_pose_rad())[:2] for leg in LEGS]) @ rotation.T
    candidates = np.vstack([[0.0, 0.0], rng.uniform(-radius_m, radius_m, size=(tries, 2))])
    under_root = ground_height_m(ground, candidates)
    under_feet = ground_height_m(ground, candidates[:, None, :] + feet[None, :, :])  # (tries + 1, 6)
    excess = under_feet.max(axis=1) - under_root
    clear = np.flatnonzero(excess <= 1e-3)
    best = clear[0] if clear.size else int(np.argmin(excess))  # the first clear spot, else the least buried
    return (float(candidates[best, 0]), float(candidates[best, 1]))


def body_centre_m(body: BodySpec) -> np.ndarray:
    """The body's centre of mass at its rest pose, in the root frame (3,) m.

    The root (the thorax frame) sits at the front of the thorax, 0.34 m ahead of the centre of mass
    and of the middle legs: a body turning on the spot swings it round a 0.34 m circle. Positions,
    speeds and heights are measured at this point instead, fixed in the root frame.
    """
    total, moment = 0.0, np.zeros(3)
    for segment in body.segments:
        rotation, position = segment_pose(body, segment.name, {})
        com, _, _ = segment.inertial()
        moment += segment.mass_kg * (position + rotation @ com)
        total += segment.mass_kg
    return moment / total


class CycleMotorNoise(Hook):
    """``variability=on``: at the start of every gait cycle (``cycle_steps`` control steps) the legs take
    the configured turn θ and hip swing as the trial's :class:`~neuronav.scenarios.motor_noise.MotorNoise`
    executes them (``turn_noise_sd``, ``stride_noise_fraction``), for the whole cycle."""

    def __init__(self, config: LocomotionConfig, seed: int, cycle_steps: int) -> None:
        self.cycle_steps = int(cycle_steps)
        self.turn, self.stride_rad = float(config.turn), float(np.radians(config.stride_deg))
        self.motor = MotorNoise(seed, config.turn_noise_sd, config.stride_noise_fraction)

    def before_step(self, loop: AgentLoop) -> None:
        if loop.control_steps % self.cycle_steps == 0:
            loop.turn, loop.stride_rad = self.motor(self.turn, self.stride_rad)


class LocomotionRecorder(Hook):
    """Records what the locomotion metrics and figures need, once per control step.

    ``position_m`` is the world position of the body centre (:func:`body_centre_m`), ``root_m``
    that of the root, ``up_axis`` the body's z axis in the world; :func:`run_trial` adds ``ground_m``,
    the terrain height under the centre.
    """

    def __init__(self, body, steps: int, control_dt_s: float) -> None:
        names = list(body.joint_names)
        self.centre_m = body_centre_m(body)
        self.middle_right = [names.index(f"{MIDDLE_RIGHT}_{j}") for j in ("ThCz", "CTr", "FTi")]
        contact_sites = [s.name for s in body.sites_of_kind("contact")]
        self.claws = [i for i, n in enumerate(contact_sites) if n.split("_")[0] in LEGS]
        self.control_dt_s = control_dt_s
        self.work_j = self.torque_sum = 0.0
        self.record = {
            "position_m": np.zeros((steps + 1, 3)), "root_m": np.zeros((steps + 1, 3)),
            "up_axis": np.zeros((steps + 1, 3)), "ground_m": np.zeros(steps + 1), "heading_rad": np.zeros(steps + 1),
            "roll_rad": np.zeros(steps + 1), "pitch_rad": np.zeros(steps + 1),
            "mr_angles_rad": np.zeros((steps, 3)), "mr_torques_nm": np.zeros((steps, 3)),
            "claw_force_n": np.zeros((steps, len(self.claws))),
            "swing": np.zeros((steps, len(LEGS)), dtype=bool),
        }

    def initialize_episode(self, loop: AgentLoop) -> None:
        self._pose(loop, 0)

    def before_step(self, loop: AgentLoop) -> None:
        gait = loop.gait
        if hasattr(gait, "in_swing") and hasattr(gait, "step_index"):  # the commanded phases, for the gait diagram
            self.record["swing"][loop.control_steps] = gait.in_swing(gait.step_index)

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

    def _pose(self, loop: AgentLoop, index: int) -> None:
        sensed = loop.backend.read(("body_pos", "body_quat", "heading"))
        root, quat = sensed["body_pos"][0], sensed["body_quat"][0]
        rotation = quat_to_matrix(quat)
        centre = root + rotation @ self.centre_m
        self.record["root_m"][index] = root
        self.record["position_m"][index] = centre
        self.record["up_axis"][index] = rotation[:, 2]
        self.record["heading_rad"][index] = sensed["heading"][0, 0]
        self.record["roll_rad"][index], self.record["pitch_rad"][index] = roll_pitch_rad(quat)


def run_trial(config: LocomotionConfig, backend_name: str, seed: int,
              video_path: Path | None = None) -> tuple[dict, dict[str, np.ndarray]]:
    """Walk one trial; return its metrics and recorded signals (one sample per control step)."""
    rng = np.random.default_rng(seed)
    body = desert_ant(leg_length_factors=config.leg_scale)
    steps = int(round(config.duration_s / config.control_dt_s))
    clocks = Clocks(physics_dt_s=config.timestep_s, control_dt_s=config.control_dt_s,
                    brain_dt_s=config.control_dt_s)
    yaw0 = float(rng.uniform(-config.initial_yaw_jitter_rad, config.initial_yaw_jitter_rad))
    world = build_world(config, seed)
    recorder = LocomotionRecorder(body, steps, config.control_dt_s)
    # A frame every 4 gait steps (31.25 per second at 8 ms), played in real time.
    camera = VideoRecorder(video_path, "follow", every=4) if video_path is not None else None
    pose = start_pose_kwargs(config, body, world.ground, yaw0, rng)
    gait_name = trial_gait(config, seed)
    gait = build_gait(config, body, gait_name)
    hooks = [recorder] + ([StanceAdhesion(body)] if config.adhesion_rule == "stance" else [])
    if is_on(config):
        hooks.append(CycleMotorNoise(config, seed, getattr(gait, "gait", gait).cycle_steps))
    with registry.load("backend", backend_name)(timestep_s=config.timestep_s) as engine:
        engine.load(world, [body])
        loop = AgentLoop(engine, gait, clocks, hooks=hooks + ([camera] if camera else []),
                         turn=config.turn, stride_rad=np.radians(config.stride_deg))
        loop.reset(seed=seed, **pose)
        started = time.perf_counter()
        try:
            loop.run(config.duration_s)
        finally:
            wall_s = time.perf_counter() - started
            if camera is not None:
                camera.close()
    recorder.record["ground_m"] = ground_height_m(world.ground, recorder.record["position_m"][:, :2])
    metrics = trial_metrics(recorder.record, config, body.total_mass_kg, recorder.work_j,
                            recorder.torque_sum / max(steps, 1), loop.gait_time_s / max(steps, 1), wall_s)
    metrics["gait"] = gait_name
    return metrics, recorder.record


def roll_pitch_rad(quat: np.ndarray) -> tuple[float, float]:
    """Roll (about the body's forward axis) and pitch of a (w, x, y, z) quaternion."""
    w, x, y, z = quat
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    return float(roll), float(pitch)


def fell_over(record: dict, wall_x_m: float | None = None) -> bool:
    """Whether the body tipped over, from its up axis and its centre's height.

    Upright: the up axis within 80° of the floor's normal (+z); or, within a body length (1 m) of a
    wall at ``wall_x_m`` (facing −x), within 80° of the wall's normal (−x) and not pointing more than
    10° below the horizon (rearing up against the wall or standing on it is not a fall, lying on the
    back at its foot is). Also fallen: the centre less than 0.1 m above the ground under it.
    """
    up, centre = record["up_axis"], record["position_m"]
    cos_limit = np.cos(FALL_ANGLE_RAD)
    upright = up[:, 2] >= cos_limit
    if wall_x_m is not None:
        near = centre[:, 0] > wall_x_m - 1.0
        upright |= near & (-up[:, 0] >= cos_limit) & (up[:, 2] >= -cos_limit)
    low = centre[:, 2] - record["ground_m"] < 0.1
    return bool(np.any(~upright) or np.any(low))


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
    wall_x_m = TERRAINS["wall"]["wall_distance_m"] if config.terrain == "wall" else None
    fell = fell_over(record, wall_x_m)
    # Heading, roll and pitch are taken against the floor: meaningless for a body standing on the wall.
    on_floor = 1.0 if config.terrain != "wall" or config.wall_start == "floor" else np.nan
    travelled = position[:, :2] if on_floor == 1.0 else position  # on the wall the way is mostly up
    distance_m = float(np.linalg.norm(np.diff(travelled, axis=0), axis=1).sum())
    return {
        "success": not fell, "status": "ok", "error": "",
        "forward_speed_m_s": on_floor * float(displacement @ forward / config.duration_s),
        "lateral_drift_m": on_floor * float(displacement @ left),
        "turn_rate_rad_s": on_floor * float((yaw[-1] - yaw[0]) / config.duration_s),
        "body_height_mean_m": float(height.mean()), "body_height_var_m2": float(height.var()),
        "roll_var_rad2": on_floor * float(np.var(record["roll_rad"])),
        "pitch_var_rad2": on_floor * float(np.var(record["pitch_rad"])),
        "mean_abs_torque_nm": mean_abs_torque_nm,
        "cost_of_transport": float(work_j / (mass_kg * GRAVITY_M_S2 * distance_m)) if distance_m > 1e-3 else np.nan,
        "climb_height_m": float(height.max() - height[0]),
        "climb_final_m": float(height[-1] - height[0]),
        "gait_us_per_step": 1e6 * gait_s_per_step,
        "real_time_factor": float(config.duration_s / wall_s) if wall_s > 0 else np.nan,
        "fell": fell,
    }
