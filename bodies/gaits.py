"""Gaits: the locomotion command (turn θ, stride S_l) to joint targets, one control step at a time.

Every gait here implements :class:`neuronav.spec.body.Gait` for the desert-ant body
(:func:`neuronav.bodies.desert_ant.desert_ant`, or any body with the same leg naming): ``joint_names`` is all
of the body's hinge joints in its order, ``reset()`` restarts the cycle, and ``step(turn, stride_rad)``
returns the targets (rad, shape (J,)) for the next control step (8 ms in I2Bot; one gait sample per
step, whatever the physics timestep).

Conventions (see ``bodies/desert_ant/README.md``):

- The body walks toward +x (its head). Positive ThCz swings a leg forward on both sides, negative
  CTr raises the femur, positive FTi bends the tibia down.
- ``turn`` = θ in [−1, 1] (clipped): 0 walks straight forward, +1 turns on the spot to the LEFT
  (counter-clockwise seen from above), −1 to the right — as ``backends/kinematic.py``.
- ``stride_rad`` = S_l, the hip swing amplitude Δ (rad): ThCz sweeps α0 ± Δ. ``None`` uses the
  gait's default. Negative strides walk backward.
- Table 2 yaw control, in this module's sign convention (the paper's mirrored left legs carry −Δ
  when walking straight; here both sides carry +Δ): per-side amplitude factors
  θ ≥ 0: left (1 − 2θ), right 1; θ < 0: left 1, right (1 + 2θ). A negative factor reverses that
  side's sweep, so at θ = ±1 the two sides push opposite ways and the body turns on the spot.

The phase tables are docs/parameters.md §2 (I2Bot paper §3.3.1). A leg's phase at control step k is
``(k − offset) mod cycle``; it swings for the first ``swing_steps`` of its cycle, then stands.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from neuronav.bodies.desert_ant.body import LEGS, leg_geometry
from neuronav.errors import ConfigError
from neuronav.spec.body import BodySpec, quat_to_matrix

CONTROL_STEP_S = 0.008
PATTERNS = ("tripod", "ripple", "wave")
GAIT_NAMES = ("tripod", "ripple", "wave", "ik")
TRIPOD_A = ("FL", "MR", "HL")
TRIPOD_B = ("FR", "ML", "HR")
# Phase offsets in units of S_n (ripple) and 2·S_n (wave), docs/parameters.md §2.
RIPPLE_OFFSETS = {"HL": 0, "FR": 1, "ML": 2, "HR": 3, "FL": 4, "MR": 5}
WAVE_OFFSETS = {"FL": 0, "HR": 1, "MR": 2, "FR": 3, "HL": 4, "ML": 5}
# IK step length per rad of stride, in mean horizontal ThC-to-claw distances: calibrated so that the IK
# tripod walks about as fast as the FK tripod at the same stride (0.47 vs 0.47 m/s at 15°, both engines).
IK_REACH_FACTOR = 1.25


# -- forward kinematics from the spec ---------------------------------------------------------------
def _rotation(axis, angle_rad: float) -> np.ndarray:
    axis = np.asarray(axis, float)
    x, y, z = axis / np.linalg.norm(axis)
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    t = 1.0 - c
    return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])


def segment_pose(body: BodySpec, segment: str, angles: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(rotation (3, 3), position (3,)) of a segment's frame in the body (root) frame.

    Each segment sits at ``pos_m`` / ``quat`` in its parent's frame and then turns about its joint's
    axis (given in its own frame) by the joint angle — the rule every backend follows.
    ``angles`` maps joint names to angles; joints it does not name are at rest.
    """
    chain = []
    current = body.segment(segment)
    while current.parent is not None:
        chain.append(current)
        current = body.segment(current.parent)
    rotation, position = np.eye(3), np.zeros(3)
    for seg in reversed(chain):
        position = position + rotation @ np.asarray(seg.pos_m, float)
        rotation = rotation @ quat_to_matrix(seg.quat)
        if seg.joint is not None and seg.joint.kind == "hinge":
            rotation = rotation @ _rotation(seg.joint.axis, angles.get(seg.joint.name, seg.joint.rest_rad))
    return rotation, position


def _angle_map(body: BodySpec, leg: str, angles) -> dict[str, float]:
    angles = np.asarray(angles, float).ravel()
    names = body.joint_names
    if angles.size == len(names):
        return dict(zip(names, angles))
    leg_names = [f"{leg}_{j}" for j in ("ThCz", "ThCx", "CTr", "FTi", "TiTa")]
    if angles.size == len(leg_names):
        return dict(zip(leg_names, angles))
    raise ConfigError(f"foot_position: angles must have {len(leg_names)} values (the leg's joints) or "
                      f"{len(names)} (every joint of body {body.name!r}), got {angles.size}")


def foot_position(body: BodySpec, leg: str, angles) -> np.ndarray:
    """Centre of a leg's claw in the body frame, by forward kinematics of the spec itself.

    Parameters
    ----------
    body : BodySpec
    leg : str
        One of ``LEGS``.
    angles : array_like
        The leg's five angles (ThCz, ThCx, CTr, FTi, TiTa) in rad, or the whole (J,) joint vector.

    Returns
    -------
    ndarray, shape (3,)
    """
    if leg not in LEGS:
        raise ConfigError(f"foot_position: unknown leg {leg!r}; allowed: {', '.join(LEGS)}")
    site = next((s for s in body.sites if s.name == f"{leg}_claw"), None)
    if site is None:
        raise ConfigError(f"body {body.name!r} has no contact site {leg}_claw")
    segment = body.segment(site.segment)
    geom = next((g for g in segment.geoms if g.name == site.geom), None)
    local = np.asarray(geom.pos_m if geom is not None else site.pos_m, float)
    rotation, position = segment_pose(body, site.segment, _angle_map(body, leg, angles))
    return position + rotation @ local


# -- shared gait plumbing ----------------------------------------------------------------------------
def side_factors(turn: float) -> tuple[float, float]:
    """Table 2 per-side amplitude factors (left, right) for θ = ``turn`` (clipped to [−1, 1])."""
    theta = float(np.clip(turn, -1.0, 1.0))
    if theta >= 0:
        return 1.0 - 2.0 * theta, 1.0
    return 1.0, 1.0 + 2.0 * theta


def phase_table(pattern: str, steps_per_half_swing: int) -> tuple[int, int, dict[str, int]]:
    """(cycle steps, swing steps, {leg: swing-start offset in steps}) of an FK pattern."""
    n = steps_per_half_swing
    if pattern == "tripod":
        return 4 * n, 2 * n, {leg: (0 if leg in TRIPOD_A else 2 * n) for leg in LEGS}
    if pattern == "ripple":
        return 6 * n, 2 * n, {leg: RIPPLE_OFFSETS[leg] * n for leg in LEGS}
    if pattern == "wave":
        return 12 * n, 2 * n, {leg: WAVE_OFFSETS[leg] * 2 * n for leg in LEGS}
    raise ConfigError(f"unknown gait pattern {pattern!r}; allowed: {', '.join(PATTERNS)}")


def _finite(where: str, label: str, value, positive: bool = False, nonnegative: bool = False) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {label} must be a number, got {value!r}") from None
    if not math.isfinite(value) or (positive and value <= 0) or (nonnegative and value < 0):
        need = "positive" if positive else "non-negative" if nonnegative else "finite"
        raise ConfigError(f"{where}: {label} must be {need} and finite, got {value!r}")
    return value


class _PhasedGait:
    """Phase bookkeeping, joint bookkeeping and target clipping shared by the FK and IK gaits."""

    def __init__(self, body: BodySpec, pattern: str, steps_per_half_swing, direction, ramp_steps=None) -> None:
        where = type(self).__name__
        if not isinstance(body, BodySpec):
            raise ConfigError(f"{where}: body must be a BodySpec, got {type(body).__name__}")
        if isinstance(steps_per_half_swing, bool) or not isinstance(steps_per_half_swing, (int, np.integer)) \
                or steps_per_half_swing < 1:
            raise ConfigError(f"{where}: steps_per_half_swing must be an int >= 1, got {steps_per_half_swing!r}")
        if direction not in (1, -1):
            raise ConfigError(f"{where}: direction must be +1 (forward) or -1 (backward), got {direction!r}")
        self.body = body
        self.geometry = leg_geometry(body)
        self.joint_names = tuple(body.joint_names)
        self.pattern = pattern
        self.steps_per_half_swing = int(steps_per_half_swing)
        self.direction = int(direction)
        self.cycle_steps, self.swing_steps, self.offsets_steps = phase_table(pattern, self.steps_per_half_swing)
        if ramp_steps is None:
            ramp_steps = self.cycle_steps
        if isinstance(ramp_steps, bool) or not isinstance(ramp_steps, (int, np.integer)) or ramp_steps < 0:
            raise ConfigError(f"{where}: ramp_steps must be an int >= 0 (or None: one cycle), got {ramp_steps!r}")
        self.ramp_steps = int(ramp_steps)
        self.rest_rad = body.rest_pose_rad()
        self.low_rad = np.array([j.range_rad[0] for j in body.joints])
        self.high_rad = np.array([j.range_rad[1] for j in body.joints])
        index = {name: i for i, name in enumerate(self.joint_names)}
        self.leg_index = {leg: np.array([index[n] for n in self.geometry[leg]["joints"]]) for leg in LEGS}
        self.reset()

    @property
    def duty_factor(self) -> float:
        """Fraction of the cycle each leg spends on the ground."""
        return 1.0 - self.swing_steps / self.cycle_steps

    @property
    def cycle_s(self) -> float:
        return self.cycle_steps * CONTROL_STEP_S

    def reset(self) -> None:
        """Restart at phase 0 (the first swing group starts its swing)."""
        self.step_index = 0

    def envelope(self, step: int) -> float:
        """Start-up factor at control step ``step``: 0 → 1 along a half cosine over ``ramp_steps``.

        :meth:`step` multiplies the stride and the lift (IK: step length and height) by it, so a walk
        starts from the rest pose instead of jumping every hip by ±stride on its first sample (that
        jump kicks the body into a yaw that it then keeps: the IK tripod started 20° off its heading).
        :meth:`targets_at` gives the steady pattern, without it.
        """
        if step >= self.ramp_steps:
            return 1.0
        return 0.5 * (1.0 - math.cos(math.pi * max(step, 0) / self.ramp_steps))

    def leg_phase(self, leg: str, step: int) -> tuple[bool, float]:
        """(in swing?, progress in [0, 1) through that swing or stance) of a leg at control step ``step``."""
        phase = (step - self.offsets_steps[leg]) % self.cycle_steps
        if phase < self.swing_steps:
            return True, phase / self.swing_steps
        return False, (phase - self.swing_steps) / (self.cycle_steps - self.swing_steps)

    def in_swing(self, step: int) -> np.ndarray:
        """Bool (6,) in ``LEGS`` order: which legs swing at control step ``step``."""
        return np.array([self.leg_phase(leg, step)[0] for leg in LEGS])

    def swing_legs(self, step: int) -> frozenset[str]:
        return frozenset(leg for leg in LEGS if self.leg_phase(leg, step)[0])

    def _command(self, turn, stride_rad, default: float) -> tuple[float, float, float]:
        where = type(self).__name__
        turn = _finite(where, "turn", turn)
        stride = default if stride_rad is None else _finite(where, "stride_rad", stride_rad)
        left, right = side_factors(turn)
        return stride * self.direction, left, right

    def _clip(self, targets: np.ndarray) -> np.ndarray:
        return np.clip(targets, self.low_rad, self.high_rad)


# -- forward-kinematics gaits --------------------------------------------------------------------------
class FKGait(_PhasedGait):
    """Tripod, ripple or wave gait by forward kinematics (I2Bot eqs 3.1–3.3 and Table 2).

    Swing (``swing_steps`` = 2·S_n): ThCz moves linearly from α0 − R to α0 + R while the leg lifts
    smoothly and sets down again — CTr β0 → β0 − lift → β0, FTi γ0 → γ0 + lift → γ0 along
    ``lift·sin²(πu)`` (zero lift speed at lift-off and touch-down). Stance: ThCz moves linearly back
    from α0 + R to α0 − R with CTr, FTi at rest. R = direction·Δ·(side factor), Δ = ``stride_rad``.
    ThCx, TiTa and every non-leg joint hold their rest angles; targets are clipped to joint ranges.

    Parameters
    ----------
    body : BodySpec
    pattern : {"tripod", "ripple", "wave"}
    hip_swing_rad : float
        Default Δ when ``step`` gets ``stride_rad=None`` (I2Bot: 15°).
    lift_rad : float
        Lift swing S_h (I2Bot: 20°).
    steps_per_half_swing : int
        S_n (I2Bot: 20 steps of 8 ms; a tripod cycle is then 80 steps = 0.64 s).
    direction : {+1, -1}
        +1 walks forward (+x), −1 backward.
    ramp_steps : int, optional
        Start-up: :meth:`step` scales hip swing and lift by :meth:`envelope` over this many control
        steps after ``reset()`` (default: one cycle; 0: start at full stride, as I2Bot does).
    """

    def __init__(self, body: BodySpec, pattern: str = "tripod", hip_swing_rad: float = math.radians(15.0),
                 lift_rad: float = math.radians(20.0), steps_per_half_swing: int = 20, direction: int = 1,
                 ramp_steps: int | None = None) -> None:
        if pattern not in PATTERNS:
            raise ConfigError(f"FKGait: unknown pattern {pattern!r}; allowed: {', '.join(PATTERNS)}")
        self.hip_swing_rad = _finite("FKGait", "hip_swing_rad", hip_swing_rad, nonnegative=True)
        self.lift_rad = _finite("FKGait", "lift_rad", lift_rad, nonnegative=True)
        super().__init__(body, pattern, steps_per_half_swing, direction, ramp_steps)

    def targets_at(self, step: int, turn: float = 0.0, stride_rad: float | None = None,
                   amplitude_scale: float = 1.0) -> np.ndarray:
        """Joint targets (J,) at control step ``step`` (no state change); swing and lift times ``amplitude_scale``."""
        amplitude, left, right = self._command(turn, stride_rad, self.hip_swing_rad)
        amplitude *= amplitude_scale
        lift_rad = self.lift_rad * amplitude_scale
        targets = self.rest_rad.copy()
        for leg in LEGS:
            index = self.leg_index[leg]
            alpha0, _, beta0, gamma0, _ = self.rest_rad[index]
            r = amplitude * (left if leg[1] == "L" else right)
            swinging, progress = self.leg_phase(leg, step)
            if swinging:
                lift = lift_rad * math.sin(math.pi * progress) ** 2
                targets[index[0]] = alpha0 - r + 2.0 * r * progress
                targets[index[2]] = beta0 - lift
                targets[index[3]] = gamma0 + lift
            else:
                targets[index[0]] = alpha0 + r - 2.0 * r * progress
        return self._clip(targets)

    def step(self, turn: float = 0.0, stride_rad: float | None = None) -> np.ndarray:
        """Targets (J,) for the next control step (ramped in after ``reset()``); advances the gait by one step."""
        targets = self.targets_at(self.step_index, turn, stride_rad, self.envelope(self.step_index))
        self.step_index += 1
        return targets


# -- inverse-kinematics gait -------------------------------------------------------------------------
class IKGait(_PhasedGait):
    """Tripod gait from foot trajectories solved analytically to ThCz, CTr, FTi (I2Bot eqs 3.4–3.5).

    Each foot (claw centre) moves in the vertical plane through its rest position parallel to the
    body's x axis. Stance: a straight line on the ground from +L/2 to −L/2 (body frame, relative
    to the rest foot). Swing: the arc ``x = −(L/2)·cos(πu)``, ``z = H·sin(πu)``, u ∈ [0, 1).
    The step length per side is L times the Table 2 side factor (see the module docstring), and
    ``stride_rad`` sets ``L = stride_rad · reach_m``, where ``reach_m`` is ``IK_REACH_FACTOR`` (1.25)
    times the mean horizontal distance from the ThC joint to the claw at rest — so that at the same
    stride the IK tripod walks about as fast as the FK tripod (measured on MuJoCo and PyBullet; the FK
    gait's feet slip and its front feet travel less, so equal foot travel would make IK ~25 % faster),
    and the steadiness of the two is compared at matched speed. ThCx and TiTa hold their rest
    angles (the solution needs ThCx rest = 0). Targets outside the reachable workspace are pulled
    onto its edge along the line from the CTr joint, and every angle is clipped to its joint range:
    never NaN.

    Parameters
    ----------
    body : BodySpec
    step_length_m : float, optional
        L used when ``step`` gets ``stride_rad=None`` (default: 15° · reach_m).
    step_height_m : float, optional
        H (default: a quarter of the mean femur length, 0.076 m at scale 1).
    steps_per_half_swing : int
        S_n; the cycle is 4·S_n steps, half swing, half stance.
    direction : {+1, -1}
    reach_m : float, optional
        Override the stride-to-step-length factor.
    ramp_steps : int, optional
        Start-up: :meth:`step` scales step length and height by :meth:`envelope` over this many
        control steps after ``reset()`` (default: one cycle; 0: none).
    """

    def __init__(self, body: BodySpec, step_length_m: float | None = None, step_height_m: float | None = None,
                 steps_per_half_swing: int = 20, direction: int = 1, reach_m: float | None = None,
                 ramp_steps: int | None = None) -> None:
        super().__init__(body, "tripod", steps_per_half_swing, direction, ramp_steps)
        for leg in LEGS:
            if abs(self.geometry[leg]["rest_rad"][1]) > 1e-12:
                raise ConfigError(f"IKGait: leg {leg} has ThCx rest {self.geometry[leg]['rest_rad'][1]}; "
                                  "the analytic solution needs ThCx rest = 0")
        self.rest_feet_m = np.array([foot_position(body, leg, self.geometry[leg]["rest_rad"]) for leg in LEGS])
        horizontal = [np.linalg.norm((self.rest_feet_m[i] - self.geometry[leg]["anchor_m"])[:2])
                      for i, leg in enumerate(LEGS)]
        self.reach_m = (IK_REACH_FACTOR * float(np.mean(horizontal)) if reach_m is None
                        else _finite("IKGait", "reach_m", reach_m, positive=True))
        self.step_length_m = (math.radians(15.0) * self.reach_m if step_length_m is None
                              else _finite("IKGait", "step_length_m", step_length_m, nonnegative=True))
        mean_femur = float(np.mean([self.geometry[leg]["femur_m"] for leg in LEGS]))
        self.step_height_m = (0.25 * mean_femur if step_height_m is None
                              else _finite("IKGait", "step_height_m", step_height_m, nonnegative=True))
        self.last_feet_m = self.rest_feet_m.copy()

    def foot_targets(self, step: int, turn: float = 0.0, stride_rad: float | None = None,
                     amplitude_scale: float = 1.0) -> np.ndarray:
        """Commanded claw centres (6, 3) in the body frame, ``LEGS`` order, at control step ``step``.

        Step length and height are times ``amplitude_scale`` (:meth:`step` passes the start-up envelope).
        """
        where = "IKGait"
        turn = _finite(where, "turn", turn)
        if stride_rad is None:
            length = self.step_length_m * self.direction
        else:
            length = _finite(where, "stride_rad", stride_rad) * self.reach_m * self.direction
        length *= amplitude_scale
        left, right = side_factors(turn)
        feet = self.rest_feet_m.copy()
        for i, leg in enumerate(LEGS):
            side_length = length * (left if leg[1] == "L" else right)
            swinging, progress = self.leg_phase(leg, step)
            if swinging:
                feet[i, 0] += -0.5 * side_length * math.cos(math.pi * progress)
                feet[i, 2] += self.step_height_m * amplitude_scale * math.sin(math.pi * progress)
            else:
                feet[i, 0] += 0.5 * side_length - side_length * progress
        return feet

    def solve(self, feet_m: np.ndarray) -> np.ndarray:
        """Joint targets (J,) putting each claw at ``feet_m`` (6, 3) as nearly as the legs allow."""
        targets = self.rest_rad.copy()
        for i, leg in enumerate(LEGS):
            index = self.leg_index[leg]
            alpha, beta, gamma = leg_ik(self.geometry[leg], feet_m[i])
            targets[index[0]], targets[index[2]], targets[index[3]] = alpha, beta, gamma
        return self._clip(targets)

    def targets_at(self, step: int, turn: float = 0.0, stride_rad: float | None = None,
                   amplitude_scale: float = 1.0) -> np.ndarray:
        """Joint targets (J,) at control step ``step`` (no state change, no start-up envelope)."""
        return self.solve(self.foot_targets(step, turn, stride_rad, amplitude_scale))

    def step(self, turn: float = 0.0, stride_rad: float | None = None) -> np.ndarray:
        """Targets (J,) for the next control step (ramped in after ``reset()``); ``last_feet_m`` holds the feet."""
        self.last_feet_m = self.foot_targets(self.step_index, turn, stride_rad, self.envelope(self.step_index))
        self.step_index += 1
        return self.solve(self.last_feet_m)


def leg_ik(geometry: dict, foot_m) -> tuple[float, float, float]:
    """(ThCz, CTr, FTi) putting the claw at ``foot_m`` (body frame), ThCx = 0 and TiTa at rest.

    The leg lies in the vertical plane through its ThC joint at azimuth ``azimuth + thcz_axis_z·ThCz``;
    the coxa is horizontal, the femur is tilted down by ``tilt`` at CTr = 0, and tibia + tarsus
    (at the fixed TiTa angle) act as one rigid link: a planar two-link problem, solved in closed form
    with the knee bent the way the rest pose bends it. Unreachable points are pulled onto the
    workspace edge; angles are not clipped here.
    """
    anchor = geometry["anchor_m"]
    coxa, femur = geometry["coxa_m"], geometry["femur_m"]
    tibia, tarsus = geometry["tibia_m"], geometry["tarsus_m"]
    tilt, azimuth, axis_z = geometry["tilt_rad"], geometry["azimuth_rad"], geometry["thcz_axis_z"]
    _, _, beta_rest, gamma_rest, tita = geometry["rest_rad"]

    v = np.asarray(foot_m, float) - anchor
    horizontal = math.hypot(v[0], v[1])
    heading = math.atan2(v[1], v[0]) if horizontal > 1e-12 else azimuth
    alpha = axis_z * math.remainder(heading - azimuth, 2.0 * math.pi)
    # In the leg plane: h outward from the CTr joint, z up; rotate by the tilt into the femur's zero frame,
    # then write points as complex numbers x + i·(down).
    h, z = horizontal - coxa, v[2]
    px = h * math.cos(tilt) - z * math.sin(tilt)
    pz = h * math.sin(tilt) + z * math.cos(tilt)
    target = complex(px, -pz)
    link = tibia + tarsus * complex(math.cos(tita), math.sin(tita))  # tibia + tarsus, in the tibia's frame
    link_len, link_arg = abs(link), math.atan2(link.imag, link.real)
    knee = 1.0 if gamma_rest + link_arg >= 0 else -1.0
    low = max(abs(femur - link_len), 1e-9) * (1.0 + 1e-12)
    high = (femur + link_len) * (1.0 - 1e-12)
    distance = abs(target)
    if distance < 1e-12:  # degenerate: aim along the rest direction
        target = complex(math.cos(beta_rest), math.sin(beta_rest)) * low
        distance = low
    distance_c = min(max(distance, low), high)
    cos_knee = (distance_c**2 - femur**2 - link_len**2) / (2.0 * femur * link_len)
    g = knee * math.acos(min(max(cos_knee, -1.0), 1.0))
    beta = math.atan2(target.imag, target.real) - math.atan2(link_len * math.sin(g), femur + link_len * math.cos(g))
    gamma = g - link_arg
    return alpha, math.remainder(beta, 2.0 * math.pi), gamma


class PostureGait:
    """A gait with some joints held at other angles (e.g. the head raised for climbing) or offset.

    Wraps an :class:`FKGait` or :class:`IKGait`: every target comes from it, except that the joints
    in ``posture`` are held at the given angle and the joints in ``offsets`` get the given angle
    added to the wrapped gait's target (a leg keeps its motion around a shifted centre). Both fade in
    from the rest pose along the wrapped gait's start-up :meth:`~_PhasedGait.envelope` (no jump on
    the first sample). Targets are clipped to the joints' ranges.

    Parameters
    ----------
    gait : FKGait or IKGait
    posture : dict
        ``{joint name: angle (rad)}`` held.
    offsets : dict, optional
        ``{joint name: angle (rad)}`` added.
    """

    def __init__(self, gait: _PhasedGait, posture: dict[str, float], offsets: dict[str, float] | None = None) -> None:
        if not isinstance(gait, _PhasedGait):
            raise ConfigError(f"PostureGait: gait must be an FKGait or IKGait, got {type(gait).__name__}")
        offsets = {} if offsets is None else offsets
        index = {name: i for i, name in enumerate(gait.joint_names)}
        unknown = sorted((set(posture) | set(offsets)) - set(index))
        if unknown:
            raise ConfigError(f"PostureGait: unknown joint {unknown[0]!r}; joints: {', '.join(gait.joint_names)}")
        self.gait = gait
        self.joint_names = gait.joint_names
        self.held = np.array([index[name] for name in posture], dtype=int)
        angles = np.array([_finite("PostureGait", f"posture[{name!r}]", v) for name, v in posture.items()])
        self.posture_rad = np.clip(angles, gait.low_rad[self.held], gait.high_rad[self.held])
        self.shifted = np.array([index[name] for name in offsets], dtype=int)
        self.offsets_rad = np.array([_finite("PostureGait", f"offsets[{name!r}]", v) for name, v in offsets.items()])

    def __getattr__(self, name):  # phases, cycle, envelope, ... of the wrapped gait
        if name == "gait":
            raise AttributeError(name)
        return getattr(self.gait, name)

    def reset(self) -> None:
        self.gait.reset()

    def step(self, turn: float = 0.0, stride_rad: float | None = None) -> np.ndarray:
        """The wrapped gait's targets (J,) with the posture held and the offsets added; advances one step."""
        blend = self.gait.envelope(self.gait.step_index)
        targets = self.gait.step(turn, stride_rad)
        rest = self.gait.rest_rad[self.held]
        targets[self.held] = rest + blend * (self.posture_rad - rest)
        targets[self.shifted] += blend * self.offsets_rad
        return self.gait._clip(targets)


def make_gait(name: str, body: BodySpec, **options):
    """A gait by name: ``tripod``, ``ripple``, ``wave`` (:class:`FKGait`) or ``ik`` (:class:`IKGait`)."""
    if name not in GAIT_NAMES:
        raise ConfigError(f"unknown gait {name!r}; allowed: {', '.join(GAIT_NAMES)}")
    cls = IKGait if name == "ik" else FKGait
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p not in ("self", "body", "pattern")]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ConfigError(f"gait {name!r}: unknown option {unknown[0]!r}; allowed: {', '.join(accepted)}")
    if cls is IKGait:
        return IKGait(body, **options)
    return FKGait(body, pattern=name, **options)
