"""A step-integrating odometer: the distance an ant walked, from its own joint angles and leg loads.

Desert ants gauge distance by their strides: on stilts they overshoot the nest, on stumps they fall
short (Wittlinger et al. 2006, Science 312:1965). The odometer here reads only what the ant's own
proprioceptors would: the joint angles (chordotonal organs, hair plates) and the load on each leg
(campaniform sensilla), and turns them into body displacement through the leg kinematics of the
body the brain *believes* it has — fixed when the odometer is built, like the ant's calibration
before its legs were changed.

:class:`StepOdometer` (articulated bodies, MuJoCo and PyBullet):

- feet: each claw's centre in the body frame by forward kinematics of the believed body (the same
  rule as :func:`neuronav.bodies.gaits.foot_position`, vectorised over the six legs);
- stance: a leg whose claw's contact force exceeds ``contact_threshold_n`` (load sensing);
- displacement between two updates: the stance feet (those in stance at both updates) are fixed on
  the ground, so in the body frame they move by the body's motion reversed. The 2-D rigid motion
  (rotation and translation in the body's horizontal plane) that best carries their new positions
  onto their old ones is solved in closed form (Kabsch in the plane); its translation is the body's
  displacement, expressed in the body frame of the previous update (x forward, y left). With one
  stance foot it is minus that foot's motion; with none, zero. Solving the rigid motion (rather than
  taking the mean foot motion) keeps a turn during stance from leaking into the translation: when
  the body turns by φ about its centre, feet to the side of it move forward and back in the body
  frame, and their mean is the displacement only if they surround the centre symmetrically;
- strides: each end of a protraction of the reference leg (default ``FL``: its ThCz angle stops rising
  and the leg is set down, the anterior extreme position) closes one stride; its length is the
  straight-line distance between the odometer's position estimates (the pose integrated in the
  frame of the first update) at two successive ends, recorded in ``stride_lengths_m``;
  ``distance_m`` sums the closed strides and the straight stretches before the first and after
  the last.

:func:`stride_odometer_distance` and :class:`UnicycleStrideOdometer` do the same for the kinematic
unicycle, which has no legs: stride count × the stride length the body's unicycle calibration gives
for the commanded stride (speed × gait cycle), whatever the agent's true (noisy) motion.
"""

from __future__ import annotations

import math

import numpy as np

from neuronav.bodies.desert_ant.body import LEGS, leg_geometry
from neuronav.errors import ConfigError
from neuronav.spec.body import BodySpec, quat_to_matrix
from neuronav.spec.unicycle import UnicycleCalibration

# Default stance threshold: a claw carries weight above this force. The desert ant's stance claws carry
# tens of N (its weight, ~120 N at scale 1, shared by three legs in tripod; more with adhesion) and a swing
# claw none; 1 N keeps a grazing touch out.
DEFAULT_CONTACT_THRESHOLD_N = 1.0
# The tripod cycle of bodies.gaits.FKGait at its defaults: 80 control steps of 8 ms.
DEFAULT_CYCLE_S = 0.64
# The FK tripod sweeps ThCz through 2 × 15° = 0.52 rad per swing; 0.05 rad is a tenth of that, above the
# joint's tracking jitter.
DEFAULT_SWING_HYSTERESIS_RAD = 0.05


def _cross_matrix(axis: np.ndarray) -> np.ndarray:
    """The matrix K with K @ v = axis × v."""
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


class _LegChains:
    """The legs' kinematic chains of one body, as arrays, for forward kinematics of all feet at once.

    Each leg is the chain of segments from the root to the segment carrying its claw; every link sits
    at a fixed offset o and rotation F in its parent's frame and then turns about its hinge axis by
    its angle θ (Rodrigues: R = I + sin θ K + (1 − cos θ) K², K the axis's cross-product matrix). Its
    homogeneous transform [[F R, o], [0, 1]] is therefore A + sin θ·B + cos θ·C with constant
    A = [[F + F K², o], [0, 1]], B = [[F K, 0], [0, 0]], C = [[−F K², 0], [0, 0]]: one batched
    product of the stacked (A, B, C) with (1, sin θ, cos θ) gives every link's transform. Links
    without a hinge, and the identity links that pad shorter chains at their root end, have K = 0.
    The transforms are then composed from the root to the claw — the rule of
    :func:`neuronav.bodies.gaits.segment_pose`, batched over legs — pairwise, as a tree (4 batched
    products for 5 links instead of one per link: at this size NumPy's per-call cost is most of the time).
    """

    def __init__(self, body: BodySpec, legs: tuple[str, ...]) -> None:
        index = {name: i for i, name in enumerate(body.joint_names)}
        chains, claws = [], []
        for leg in legs:
            site = next((s for s in body.sites if s.name == f"{leg}_claw"), None)
            if site is None:
                raise ConfigError(f"StepOdometer: body {body.name!r} has no contact site {leg}_claw")
            segment = body.segment(site.segment)
            geom = next((g for g in segment.geoms if g.name == site.geom), None)
            claws.append(np.asarray(geom.pos_m if geom is not None else site.pos_m, float))
            chain = []
            while segment.parent is not None:
                chain.append(segment)
                segment = body.segment(segment.parent)
            chains.append(chain[::-1])
        links = max(len(chain) for chain in chains)
        n = len(legs)
        basis = np.zeros((links, n, 3, 4, 4))  # (A, B, C) of each link
        basis[:, :, 0] = np.eye(4)
        joint_index = np.zeros((links, n), int)
        for i, chain in enumerate(chains):
            pad = links - len(chain)
            for k, seg in enumerate(chain, start=pad):
                fixed = quat_to_matrix(seg.quat)
                cross = np.zeros((3, 3))
                if seg.joint is not None and seg.joint.kind == "hinge":
                    axis = np.asarray(seg.joint.axis, float)
                    cross = _cross_matrix(axis / np.linalg.norm(axis))
                    joint_index[k, i] = index[seg.joint.name]
                basis[k, i, 0, :3, :3] = fixed + fixed @ cross @ cross
                basis[k, i, 0, :3, 3] = seg.pos_m
                basis[k, i, 1, :3, :3] = fixed @ cross
                basis[k, i, 2, :3, :3] = -(fixed @ cross @ cross)
        # feet_many carries the claw point from the claw's link to the root, one link at a time: the rotation
        # parts (A, B, C) of each link stacked as (links, n, 9, 3), and each link's offset (links, n, 3).
        self._rotations = np.ascontiguousarray(basis[:, :, :, :3, :3].reshape(links, n, 9, 3))
        self._offsets = np.ascontiguousarray(basis[:, :, 0, :3, 3])
        # (links·n, 16, 3) @ (links·n, 3, 1) -> every link's flattened transform.
        self._basis = np.ascontiguousarray(np.moveaxis(basis.reshape(links * n, 3, 16), 1, 2))
        self._coefficients = np.ones((links * n, 3, 1))
        self._joint_index = joint_index.reshape(-1)
        self._shape = (links, n, 4, 4)
        self._claws = np.concatenate([np.array(claws), np.ones((n, 1))], axis=1)[:, :, None]

    def feet(self, joint_pos: np.ndarray) -> np.ndarray:
        """Claw centres (L, 3) in the body frame for the whole joint vector ``joint_pos`` (J,)."""
        angles = joint_pos[self._joint_index]
        coefficients = self._coefficients
        np.sin(angles, out=coefficients[:, 1, 0])
        np.cos(angles, out=coefficients[:, 2, 0])
        transforms = (self._basis @ coefficients).reshape(self._shape)
        point = self._claws
        while len(transforms) > 1:
            if len(transforms) % 2:  # the odd link nearest the claw goes into the point
                point = transforms[-1] @ point
                transforms = transforms[:-1]
            transforms = transforms[0::2] @ transforms[1::2]
        return (transforms[0] @ point)[:, :3, 0]

    def feet_many(self, joint_pos: np.ndarray) -> np.ndarray:
        """Claw centres (T, L, 3) in the body frame for T joint vectors ``joint_pos`` (T, J).

        The same transforms as :meth:`feet`, applied to the claw point from its own link toward the root
        (p ← o + A p + sin θ · B p + cos θ · C p per link) rather than composed as 4 × 4 matrices: for
        many samples, vectors through each link cost less than products of matrices.
        """
        links, n = self._shape[:2]
        # Samples last: each link's rotation parts multiply every sample's point in one (9, 3) @ (3, T) per leg.
        angles = joint_pos[:, self._joint_index].T.reshape(links, n, 1, len(joint_pos))
        sines, cosines = np.sin(angles), np.cos(angles)
        point = np.repeat(self._claws[:, :3], len(joint_pos), axis=2)  # (n, 3, T)
        for k in range(links - 1, -1, -1):
            parts = self._rotations[k] @ point  # (n, 9, T): A p, B p, C p
            point = self._offsets[k][:, :, None] + parts[:, :3] + sines[k] * parts[:, 3:6] + cosines[k] * parts[:, 6:]
        return point.transpose(2, 0, 1)


def rigid_motions_2d(before: np.ndarray, after: np.ndarray, used: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`rigid_motion_2d` for T point sets at once, each over the points ``used`` marks.

    Parameters
    ----------
    before, after : ndarray, shape (T, L, 2)
    used : ndarray of bool, shape (T, L)

    Returns
    -------
    translation : ndarray, shape (T, 2)
        Zero where no point is used.
    angle_rad : ndarray, shape (T,)
        Zero where fewer than two points are used (one point: a pure translation, as in the
        one-set rule).
    """
    weight = used.astype(float)
    n = weight.sum(axis=1)
    safe_n = np.maximum(n, 1.0)
    a = (weight[..., None] * after).sum(axis=1) / safe_n[:, None]  # centroids
    b = (weight[..., None] * before).sum(axis=1) / safe_n[:, None]
    cross = (weight * (after[..., 0] * before[..., 1] - after[..., 1] * before[..., 0])).sum(axis=1)
    dot = (weight * (after[..., 0] * before[..., 0] + after[..., 1] * before[..., 1])).sum(axis=1)
    angle = np.arctan2(cross - n * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]),
                       dot - n * (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
    angle = np.where(n >= 2, angle, 0.0)
    c, s = np.cos(angle), np.sin(angle)
    translation = np.stack([b[:, 0] - (c * a[:, 0] - s * a[:, 1]), b[:, 1] - (s * a[:, 0] + c * a[:, 1])], axis=1)
    return np.where((n >= 1)[:, None], translation, 0.0), angle


def rigid_motion_2d(before, after) -> tuple[tuple[float, float], float]:
    """The 2-D rigid motion carrying points ``after`` onto ``before`` (each N (x, y) pairs), least squares.

    Returns ``((tx, ty), angle_rad)`` with ``before ≈ R(angle) @ after + t`` (Kabsch in the plane,
    closed form: the angle from the summed cross and dot products of the centred points). One point:
    angle 0, ``t = before − after``. Plain Python floats: for the six legs it is several times faster
    than NumPy's per-call overhead.
    """
    n = len(before)
    if n == 1:
        return (before[0][0] - after[0][0], before[0][1] - after[0][1]), 0.0
    # One pass over raw sums; the centred sums follow: Σ(a − ā)×(b − b̄) = Σ a×b − n ā×b̄ (likewise ·).
    ax = ay = bx = by = cross = dot = 0.0
    for (px, py), (qx, qy) in zip(after, before):
        ax += px
        ay += py
        bx += qx
        by += qy
        cross += px * qy - py * qx
        dot += px * qx + py * qy
    ax, ay, bx, by = ax / n, ay / n, bx / n, by / n
    angle = math.atan2(cross - n * (ax * by - ay * bx), dot - n * (ax * bx + ay * by))
    c, s = math.cos(angle), math.sin(angle)
    return (bx - (c * ax - s * ay), by - (s * ax + c * ay)), angle


class StepOdometer:
    """A stride integrator from proprioception: joint angles and leg loads to body displacement.

    Parameters
    ----------
    believed_body : BodySpec
        The body whose leg kinematics the odometer assumes (the brain's belief, fixed for the trial);
        it must have the desert ant's legs (``LEGS``, segments ``{leg}_thc`` … ``{leg}_tarsus``,
        contact sites ``{leg}_claw``) and the same joints, in the same order, as the walking body.
    contact_threshold_n : float
        A leg is in stance while the norm of its claw's contact force exceeds this (N).
    reference_leg : str
        The leg whose swings mark strides.
    swing_hysteresis_rad : float
        How far the reference leg's ThCz angle must turn back from an extreme before the odometer
        takes the extreme as a turning point of its swing (keeps joint jitter from closing strides).

    Attributes
    ----------
    stride_lengths_m : list of float
        Straight-line distance between the odometer's position estimates at successive ends of a
        protraction (anterior extreme positions) of the reference leg: one per complete gait cycle.
    yaw_rad : float
        The integrated turn since the first update (counter-clockwise positive).

    Notes
    -----
    Strides are marked by the reference leg's own joint angle, not its load: at the end of each swing
    its ThCz angle (positive = protraction on both sides) stops rising and the leg is set down, the
    anterior extreme position. Marking strides by loss and return of load alone miscounts on the
    physics engines: on MuJoCo and PyBullet the tripod's stance legs often unload for a while in mid
    stance, as the body rolls, and with changed legs a swing foot may scuff the ground.
    """

    def __init__(self, believed_body: BodySpec, contact_threshold_n: float = DEFAULT_CONTACT_THRESHOLD_N,
                 reference_leg: str = LEGS[0], swing_hysteresis_rad: float = DEFAULT_SWING_HYSTERESIS_RAD) -> None:
        if not isinstance(believed_body, BodySpec):
            raise ConfigError(f"StepOdometer: believed_body must be a BodySpec, got {type(believed_body).__name__}")
        self.contact_threshold_n = _nonnegative("contact_threshold_n", contact_threshold_n)
        self.swing_hysteresis_rad = _nonnegative("swing_hysteresis_rad", swing_hysteresis_rad)
        if reference_leg not in LEGS:
            raise ConfigError(f"StepOdometer: unknown reference_leg {reference_leg!r}; allowed: {', '.join(LEGS)}")
        geometry = leg_geometry(believed_body)  # a clear error for a body without the ant's legs
        self.believed_body = believed_body
        self.reference_leg = reference_leg
        self.joint_count = len(believed_body.joint_names)
        contact = [site.name for site in believed_body.sites_of_kind("contact")]
        self.contact_count = len(contact)
        # Which rows of contact_force are the claws, in LEGS order.
        self.claw_rows = [contact.index(f"{leg}_claw") for leg in LEGS]
        self._swing_joint = believed_body.joint_names.index(geometry[reference_leg]["joints"][0])
        self._chains = _LegChains(believed_body, LEGS)
        self.reset()

    def reset(self) -> None:
        """Forget everything: no previous feet, zero distance, no strides."""
        self.stride_lengths_m: list[float] = []
        self._x_m = self._y_m = 0.0  # the integrated position
        self.yaw_rad = 0.0
        self._stance: list[bool] = [False] * len(LEGS)
        self._feet_xy: list[list[float]] | None = None
        self._mark_m = (0.0, 0.0)  # where the current (partial) stride began
        self._closed_m = 0.0  # the distance up to the mark
        self._marks = 0  # anterior extreme positions so far
        self._protracting = False  # the reference leg's ThCz is rising (a swing) since its last extreme
        self._extreme_rad: float | None = None

    @property
    def distance_m(self) -> float:
        """Distance walked since ``reset()``: the closed strides (and the stretch before the first one)
        plus the straight line from the last stride's end to the current position."""
        return self._closed_m + math.hypot(self._x_m - self._mark_m[0], self._y_m - self._mark_m[1])

    @property
    def position_m(self) -> np.ndarray:
        """The integrated position (2,) in the body frame of the first update (x forward, y left)."""
        return np.array([self._x_m, self._y_m])

    @property
    def stance(self) -> np.ndarray:
        """Which legs (bool (6,), ``LEGS`` order) were in stance at the last update."""
        return np.array(self._stance, bool)

    def feet_m(self, joint_pos) -> np.ndarray:
        """Claw centres (6, 3) in the body frame, ``LEGS`` order, through the believed body's kinematics."""
        return self._chains.feet(self._joints(joint_pos))

    def _joints(self, joint_pos) -> np.ndarray:
        joints = np.asarray(joint_pos, float).reshape(-1)
        if joints.size != self.joint_count:
            raise ConfigError(f"StepOdometer.update: joint_pos must have {self.joint_count} values (the joints of "
                              f"{self.believed_body.name!r}), got {joints.size}")
        return joints

    def _loads(self, contact, label: str) -> np.ndarray:
        """Each contact site's load (..., C) N from its forces (..., C, 3) or its loads (..., C)."""
        contact = np.asarray(contact, float)
        count = self.contact_count
        if contact.ndim >= 2 and contact.shape[-2:] == (count, 3):
            return np.linalg.norm(contact, axis=-1)
        if contact.ndim >= 1 and contact.shape[-1] == count:
            return contact
        raise ConfigError(f"StepOdometer.{label}: the contact reading must have shape ({count},) (contact_load) "
                          f"or ({count}, 3) (contact_force), got {contact.shape}")

    def update(self, joint_pos, contact) -> np.ndarray:
        """Body displacement (2,) m (forward, left) since the last update, from this update's proprioception.

        Parameters
        ----------
        joint_pos : array_like, shape (J,) (or (1, J))
            Joint angles (rad) in the believed body's joint order.
        contact : array_like, shape (C,) or (C, 3) (or with a leading 1)
            Each contact site's load (N, the backend's ``contact_load``) or its force (N, ``contact_force``,
            whose norm is the load), in the backend's contact-site order.

        Returns
        -------
        ndarray, shape (2,)
            In the body frame of the previous update; zero at the first update and with no leg in
            stance at both updates.
        """
        loads = self._loads(np.asarray(contact, float).reshape(-1, *np.shape(contact)[-1:]), "update").reshape(-1)
        joints = self._joints(joint_pos)
        feet = self._chains.feet(joints)
        threshold = self.contact_threshold_n
        stance = [bool(load > threshold) for load in loads[self.claw_rows]]
        feet_xy = feet[:, :2].tolist()
        dx = dy = 0.0
        previous, was = self._feet_xy, self._stance
        if previous is not None:
            both = [i for i in range(len(stance)) if stance[i] and was[i]]
            if both:
                (dx, dy), turn = rigid_motion_2d([previous[i] for i in both], [feet_xy[i] for i in both])
                c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
                self._x_m += c * dx - s * dy
                self._y_m += s * dx + c * dy
                self.yaw_rad += turn
        self._follow_swing(float(joints[self._swing_joint]))
        self._feet_xy, self._stance = feet_xy, stance
        return np.array([dx, dy])

    def update_many(self, joint_pos, contact) -> np.ndarray:
        """:meth:`update` for T successive samples at once (the same rules, in array operations).

        Parameters
        ----------
        joint_pos : array_like, shape (T, J)
        contact : array_like, shape (T, C) loads or (T, C, 3) forces

        Returns
        -------
        ndarray, shape (T, 2)
            Each sample's displacement (forward, left) in the body frame of the sample before it, as
            :meth:`update` returns them one by one (equal to rounding).
        """
        joints = np.asarray(joint_pos, float)
        if joints.ndim != 2 or joints.shape[1] != self.joint_count:
            raise ConfigError(f"StepOdometer.update_many: joint_pos must have shape (T, {self.joint_count}), "
                              f"got {joints.shape}")
        loads = self._loads(contact, "update_many")
        if loads.ndim != 2 or len(loads) != len(joints):
            raise ConfigError(f"StepOdometer.update_many: the contact reading must have one row per joint_pos row "
                              f"({len(joints)}), got shape {np.shape(contact)}")
        if not len(joints):
            return np.zeros((0, 2))
        feet = self._chains.feet_many(joints)[:, :, :2]
        stance = loads[:, self.claw_rows] > self.contact_threshold_n
        first = self._feet_xy is None
        previous_feet = np.concatenate([feet[:1] if first else np.array(self._feet_xy)[None], feet[:-1]])
        previous_stance = np.concatenate([np.zeros((1, len(LEGS)), bool) if first else np.array([self._stance]),
                                          stance[:-1]])
        moved, turns = rigid_motions_2d(previous_feet, feet, stance & previous_stance)
        # Each displacement into the odometer's frame by the yaw before its own turn.
        yaw_before = self.yaw_rad + np.concatenate([[0.0], np.cumsum(turns)[:-1]])
        c, s = np.cos(yaw_before), np.sin(yaw_before)
        xs = self._x_m + np.cumsum(c * moved[:, 0] - s * moved[:, 1])
        ys = self._y_m + np.cumsum(s * moved[:, 0] + c * moved[:, 1])
        swing = joints[:, self._swing_joint].tolist()
        for x_m, y_m, angle_rad in zip(xs.tolist(), ys.tolist(), swing):
            self._x_m, self._y_m = x_m, y_m
            self._follow_swing(angle_rad)
        self.yaw_rad = float(yaw_before[-1] + turns[-1])
        self._feet_xy, self._stance = feet[-1].tolist(), stance[-1].tolist()
        return moved

    def _follow_swing(self, angle_rad: float) -> None:
        """Track the reference leg's ThCz turning points; the end of each protraction closes a stride."""
        extreme = self._extreme_rad
        if extreme is None:
            self._extreme_rad = angle_rad
        elif self._protracting:
            if angle_rad > extreme:
                self._extreme_rad = angle_rad
            elif angle_rad < extreme - self.swing_hysteresis_rad:  # past the anterior extreme position
                self._protracting, self._extreme_rad = False, angle_rad
                self._close_stride()
        elif angle_rad < extreme:
            self._extreme_rad = angle_rad
        elif angle_rad > extreme + self.swing_hysteresis_rad:  # past the posterior extreme: a swing began
            self._protracting, self._extreme_rad = True, angle_rad

    def _close_stride(self) -> None:
        length = math.hypot(self._x_m - self._mark_m[0], self._y_m - self._mark_m[1])
        if self._marks:  # the stretch before the first mark is no complete stride
            self.stride_lengths_m.append(length)
        self._closed_m += length
        self._mark_m = (self._x_m, self._y_m)
        self._marks += 1


def _nonnegative(label: str, value) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"StepOdometer: {label} must be a number, got {value!r}") from None
    if not math.isfinite(number) or number < 0:
        raise ConfigError(f"StepOdometer: {label} must be finite and >= 0, got {value!r}")
    return number


# -- the kinematic unicycle ----------------------------------------------------------------------------
def stride_odometer_distance(stride_rad, turn, calibration: UnicycleCalibration,
                             cycle_s: float = DEFAULT_CYCLE_S) -> np.ndarray:
    """The believed length (m) of one stride (gait cycle) of the commanded ``(turn, stride_rad)``.

    The unicycle has no legs: its odometer believes each gait cycle carries it the distance the
    body's calibration says that command walks in one cycle, ``speed(turn, stride) · cycle_s``.

    Parameters
    ----------
    stride_rad, turn : float or array_like (N,)
    calibration : UnicycleCalibration
    cycle_s : float
        Duration of one gait cycle (the tripod's 0.64 s by default).

    Returns
    -------
    ndarray, shape (N,)
    """
    cycle = float(cycle_s)
    if not math.isfinite(cycle) or cycle <= 0:
        raise ConfigError(f"stride_odometer_distance: cycle_s must be positive and finite, got {cycle_s!r}")
    stride, theta = np.broadcast_arrays(np.asarray(stride_rad, float).reshape(-1), np.asarray(turn, float).reshape(-1))
    speed, _ = calibration.rates(theta, stride)
    return np.asarray(speed, float) * cycle


class UnicycleStrideOdometer:
    """Stride counting for kinematic unicycle agents: cycles walked × the believed stride length.

    Each update advances every agent's gait phase by ``dt_s / cycle_s`` and credits the believed
    displacement at the believed speed of the commanded stride (:func:`stride_odometer_distance` per
    cycle); each completed cycle appends one stride (its believed length) to ``stride_lengths_m``.
    The agent's true motion (with motor noise) never enters: the odometer reads the command.

    Parameters
    ----------
    calibration : UnicycleCalibration
    agents : int
    cycle_s : float
    """

    def __init__(self, calibration: UnicycleCalibration, agents: int = 1, cycle_s: float = DEFAULT_CYCLE_S) -> None:
        if isinstance(agents, bool) or not isinstance(agents, int | np.integer) or agents < 1:
            raise ConfigError(f"UnicycleStrideOdometer: agents must be an int >= 1, got {agents!r}")
        stride_odometer_distance(0.0, 0.0, calibration, cycle_s)  # validates cycle_s
        self.calibration = calibration
        self.agents = int(agents)
        self.cycle_s = float(cycle_s)
        self.reset()

    def reset(self) -> None:
        self.distance_m = np.zeros(self.agents)
        self.phase = np.zeros(self.agents)
        self.strides = np.zeros(self.agents, int)
        self.stride_lengths_m: list[list[float]] = [[] for _ in range(self.agents)]
        self._stride_so_far_m = np.zeros(self.agents)

    def update(self, turn, stride_rad, dt_s: float) -> np.ndarray:
        """Believed forward displacement (N,) m over ``dt_s`` for commands ``turn``, ``stride_rad`` (N,)."""
        stride_m = stride_odometer_distance(stride_rad, turn, self.calibration, self.cycle_s)
        stride_m = np.broadcast_to(stride_m, (self.agents,)) if stride_m.size == 1 else stride_m
        if stride_m.shape != (self.agents,):
            raise ConfigError(f"UnicycleStrideOdometer.update: commands must have {self.agents} values")
        fraction = float(dt_s) / self.cycle_s
        forward = stride_m * fraction
        self.distance_m += forward
        self._stride_so_far_m += forward
        self.phase += fraction
        done = self.phase >= 1.0 - 1e-9
        for i in np.flatnonzero(done):
            self.stride_lengths_m[i].append(float(self._stride_so_far_m[i]))
            self._stride_so_far_m[i] = 0.0
            self.phase[i] -= 1.0
            self.strides[i] += 1
        return forward
