"""Articulated bodies as data: segments, geoms, joints, sites and cameras.

A :class:`BodySpec` says everything a physics engine needs and nothing engine-specific; each
backend translates it (MuJoCo: MJCF, PyBullet: URDF) — neither format is converted from the other.
Inertia is computed here from the geoms (uniform density within a segment scaled to the segment's
mass), so every engine gets the same mass, centre of mass and inertia tensor.

Frames: a segment's frame sits at its joint, placed at ``pos_m`` / ``quat`` in its parent's frame;
geoms, sites and cameras are placed in their segment's frame. Quaternions are (w, x, y, z).
Capsules and cylinders lie along their local z axis; ``size_m`` is (radius, half_length) for them,
(radius,) for a sphere and the half-extents for a box.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from neuronav.errors import ConfigError

GEOM_SHAPES = ("capsule", "sphere", "box", "cylinder")
JOINT_KINDS = ("hinge", "free", "fixed")
SITE_KINDS = ("contact", "odour", "wind", "marker")
PROJECTIONS = ("planar", "spherical")
# Spectral receptor types of a compound eye's ommatidia (neuronav.senses.compound_eye).
OMMATIDIUM_CHANNELS = ("green", "uv")
IDENTITY_QUAT = (1.0, 0.0, 0.0, 0.0)


def _positive(where: str, values) -> None:
    if any(not np.isfinite(v) or v <= 0 for v in values):
        raise ConfigError(f"{where}: sizes must be positive and finite, got {tuple(values)}")


def _unit_quat(where: str, quat) -> None:
    if len(quat) != 4 or not np.isclose(np.linalg.norm(quat), 1.0, atol=1e-6):
        raise ConfigError(f"{where}: quat must be a unit quaternion (w, x, y, z), got {tuple(quat)}")


@dataclass(frozen=True)
class Geom:
    """A primitive collision and visual shape in its segment's frame."""

    shape: str
    size_m: tuple[float, ...]
    pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = IDENTITY_QUAT
    rgba: tuple[float, float, float, float] = (0.55, 0.35, 0.2, 1.0)
    name: str = ""
    friction: float = 1.0

    def validate(self, where: str) -> None:
        if self.shape not in GEOM_SHAPES:
            raise ConfigError(f"{where}: unknown geom shape {self.shape!r}; allowed: {', '.join(GEOM_SHAPES)}")
        expected = {"capsule": 2, "cylinder": 2, "sphere": 1, "box": 3}[self.shape]
        if len(self.size_m) != expected:
            raise ConfigError(f"{where}: a {self.shape} needs {expected} sizes, got {self.size_m}")
        _positive(where, self.size_m)
        _unit_quat(where, self.quat)

    def volume_m3(self) -> float:
        if self.shape == "sphere":
            return 4.0 / 3.0 * np.pi * self.size_m[0] ** 3
        if self.shape == "box":
            return 8.0 * float(np.prod(self.size_m))
        radius, half = self.size_m
        cylinder = np.pi * radius**2 * 2.0 * half
        return cylinder + (4.0 / 3.0 * np.pi * radius**3 if self.shape == "capsule" else 0.0)

    def local_inertia(self, mass_kg: float) -> np.ndarray:
        """Diagonal inertia (kg m²) about the geom's own centre, in the geom's frame."""
        if self.shape == "sphere":
            return np.full(3, 0.4 * mass_kg * self.size_m[0] ** 2)
        if self.shape == "box":
            a, b, c = (2.0 * s for s in self.size_m)
            return mass_kg / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
        radius, half = self.size_m
        length = 2.0 * half + (4.0 / 3.0 * radius if self.shape == "capsule" else 0.0)
        # A capsule is treated as a cylinder lengthened by its caps' volume: close, and the same
        # number for every engine (which is what matters for comparing them).
        axial = 0.5 * mass_kg * radius**2
        transverse = mass_kg * (3.0 * radius**2 + length**2) / 12.0
        return np.array([transverse, transverse, axial])


@dataclass(frozen=True)
class Joint:
    """How a segment moves relative to its parent, and its position-controlled actuator."""

    name: str
    kind: str = "hinge"
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    range_rad: tuple[float, float] = (-np.pi, np.pi)
    rest_rad: float = 0.0
    damping: float = 0.0
    armature: float = 0.0
    max_torque_nm: float = 50.0
    kp: float = 100.0
    kd: float = 1.0

    def validate(self, where: str) -> None:
        if self.kind not in JOINT_KINDS:
            raise ConfigError(f"{where}: unknown joint kind {self.kind!r}; allowed: {', '.join(JOINT_KINDS)}")
        if self.kind == "hinge":
            low, high = self.range_rad
            if not low < high:
                raise ConfigError(f"{where}: joint {self.name!r} range {self.range_rad} is reversed or empty")
            if not low <= self.rest_rad <= high:
                raise ConfigError(f"{where}: joint {self.name!r} rest {self.rest_rad} lies outside {self.range_rad}")
            if np.linalg.norm(self.axis) == 0:
                raise ConfigError(f"{where}: joint {self.name!r} has a zero axis")
        for label in ("damping", "armature", "max_torque_nm", "kp", "kd"):
            if getattr(self, label) < 0:
                raise ConfigError(f"{where}: joint {self.name!r} {label} must be >= 0")


@dataclass(frozen=True)
class Segment:
    """A rigid body: geoms, a mass, and the joint attaching it to its parent (None for the root)."""

    name: str
    parent: str | None
    geoms: tuple[Geom, ...]
    mass_kg: float
    joint: Joint | None = None
    pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = IDENTITY_QUAT

    def inertial(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(centre of mass (3,), inertia tensor (3, 3) about it, in the segment frame)."""
        volumes = np.array([g.volume_m3() for g in self.geoms])
        masses = self.mass_kg * volumes / volumes.sum()
        centres = np.array([g.pos_m for g in self.geoms], float)
        com = (masses[:, None] * centres).sum(axis=0) / self.mass_kg
        inertia = np.zeros((3, 3))
        for geom, mass, centre in zip(self.geoms, masses, centres):
            rotation = quat_to_matrix(geom.quat)
            local = rotation @ np.diag(geom.local_inertia(mass)) @ rotation.T
            offset = centre - com
            inertia += local + mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))
        return com, inertia, masses


@dataclass(frozen=True)
class Site:
    """A named point on a segment: a contact sensor, an odour or wind sensor, or a marker."""

    name: str
    segment: str
    pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    kind: str = "marker"
    geom: str = ""  # contact sites: the geom whose contact forces they report
    adhesive: bool = False  # contact sites: the world's adhesion presses this geom into what it touches


@dataclass(frozen=True)
class Camera:
    """A camera mount: where it is, where it looks (its -z axis, MuJoCo's convention) and its image.

    Pixel rays, projections and colours follow :mod:`neuronav.senses.vision` on every backend. A body
    camera does not see its own body unless ``sees_body`` (an ant's eye would otherwise see its
    antenna as a dark wedge). Each pixel is the mean of ``supersample`` × ``supersample`` rays
    spread evenly over it: its colour over its solid angle, as an ommatidium averages over its
    acceptance angle, so an edge moving across a pixel changes it smoothly (a coarse panorama's
    Zernike phase would otherwise jump by degrees as objects snap from one column to the next).
    """

    name: str
    segment: str
    pos_m: tuple[float, float, float]
    quat: tuple[float, float, float, float] = IDENTITY_QUAT
    width_px: int = 64
    height_px: int = 64
    fov_rad: tuple[float, float] = (1.0, 1.0)
    projection: str = "planar"
    sees_body: bool = False
    supersample: int = 1


@dataclass(frozen=True, eq=False)
class CompoundEye:
    """A compound-eye mount: where the eye sits, and its ommatidia as data.

    The eye's frame is placed at ``pos_m`` / ``quat`` in its segment's frame and follows the head
    convention of :mod:`neuronav.senses.dorsal_rim`: +x forward, +y left, +z up (not a camera's -z).
    Each ommatidium has a unit viewing direction in that frame (``directions``, (M, 3)), the full width
    at half maximum of its Gaussian angular sensitivity (``acceptance_rad``, (M,)), and reads every one
    of ``channels`` (spectral receptor types: ``green``, ``uv``). Generated from the literature by
    :func:`neuronav.senses.compound_eye.cataglyphis_eye`; read by :mod:`neuronav.senses.compound_eye`.
    Two eyes are equal when every field is (arrays compared by value).
    """

    name: str
    segment: str
    pos_m: tuple[float, float, float]
    quat: tuple[float, float, float, float] = IDENTITY_QUAT
    directions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    acceptance_rad: np.ndarray = field(default_factory=lambda: np.zeros(0))
    channels: tuple[str, ...] = OMMATIDIUM_CHANNELS

    def __post_init__(self) -> None:
        where = f"compound eye {self.name!r}"
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"compound eye name must be a non-empty string, got {self.name!r}")
        try:
            directions = np.array(self.directions, dtype=float)
            acceptance = np.array(self.acceptance_rad, dtype=float).reshape(-1)
            pos, quat = np.array(self.pos_m, dtype=float), np.array(self.quat, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"{where}: pos_m, quat, directions and acceptance_rad must be numbers") from None
        if directions.ndim != 2 or directions.shape[1] != 3 or directions.shape[0] < 1:
            raise ConfigError(f"{where}: directions must have shape (M, 3) with M >= 1, got {directions.shape}")
        if not (np.isfinite(directions).all() and np.allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-6)):
            raise ConfigError(f"{where}: directions must be finite unit vectors")
        if acceptance.shape != (directions.shape[0],) or not (
                np.isfinite(acceptance).all() and acceptance.min() > 0 and acceptance.max() <= np.pi / 4):
            raise ConfigError(f"{where}: acceptance_rad must be {directions.shape[0]} angles in (0, pi/4] "
                              f"(one per ommatidium), got shape {acceptance.shape}")
        if pos.shape != (3,) or not np.isfinite(pos).all():
            raise ConfigError(f"{where}: pos_m must be 3 finite numbers, got {self.pos_m!r}")
        _unit_quat(where, tuple(quat))
        channels = tuple(self.channels) if isinstance(self.channels, list | tuple) else ()
        if not channels or len(set(channels)) != len(channels) or not set(channels) <= set(OMMATIDIUM_CHANNELS):
            raise ConfigError(f"{where}: channels must be distinct names from {OMMATIDIUM_CHANNELS}, "
                              f"got {self.channels!r}")
        directions.setflags(write=False)
        acceptance.setflags(write=False)
        object.__setattr__(self, "directions", directions)
        object.__setattr__(self, "acceptance_rad", acceptance)
        object.__setattr__(self, "pos_m", tuple(float(v) for v in pos))
        object.__setattr__(self, "quat", tuple(float(v) for v in quat))
        object.__setattr__(self, "channels", channels)

    @property
    def n_ommatidia(self) -> int:
        """M, the number of ommatidia."""
        return int(self.directions.shape[0])

    def __eq__(self, other) -> bool:
        if not isinstance(other, CompoundEye):
            return NotImplemented
        return ((self.name, self.segment, self.pos_m, self.quat, self.channels)
                == (other.name, other.segment, other.pos_m, other.quat, other.channels)
                and np.array_equal(self.directions, other.directions)
                and np.array_equal(self.acceptance_rad, other.acceptance_rad))

    def __hash__(self) -> int:
        return hash((self.name, self.segment, self.pos_m, self.quat, self.channels, self.directions.tobytes(),
                     self.acceptance_rad.tobytes()))


@dataclass(frozen=True)
class BodySpec:
    """A whole articulated body. ``segments[0]`` is the root and has no parent."""

    name: str
    segments: tuple[Segment, ...]
    sites: tuple[Site, ...] = ()
    cameras: tuple[Camera, ...] = ()
    spawn_height_m: float = 0.5
    notes: dict = field(default_factory=dict)
    compound_eyes: tuple[CompoundEye, ...] = ()

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise :class:`ConfigError` naming the part and what is allowed."""
        if not self.segments:
            raise ConfigError(f"body {self.name!r} has no segments")
        names: set[str] = set()
        joints: set[str] = set()
        for index, segment in enumerate(self.segments):
            where = f"body {self.name!r}, segment {segment.name!r}"
            if segment.name in names:
                raise ConfigError(f"{where}: the name is used twice")
            if index == 0 and segment.parent is not None:
                raise ConfigError(f"{where}: the first segment is the root and has no parent")
            if index > 0 and segment.parent not in names:
                raise ConfigError(
                    f"{where}: unknown parent {segment.parent!r}; it must be declared before its children "
                    f"(known: {', '.join(sorted(names))})"
                )
            if not segment.geoms:
                raise ConfigError(f"{where}: no geoms")
            if not np.isfinite(segment.mass_kg) or segment.mass_kg <= 0:
                raise ConfigError(f"{where}: mass_kg must be positive, got {segment.mass_kg}")
            _unit_quat(where, segment.quat)
            for geom in segment.geoms:
                geom.validate(where)
            if segment.joint is not None:
                segment.joint.validate(where)
                if segment.joint.name in joints:
                    raise ConfigError(f"{where}: joint name {segment.joint.name!r} is used twice")
                joints.add(segment.joint.name)
            names.add(segment.name)
        site_names: set[str] = set()
        for site in self.sites:
            if site.segment not in names:
                raise ConfigError(f"body {self.name!r}, site {site.name!r}: unknown segment {site.segment!r}")
            if site.kind not in SITE_KINDS:
                raise ConfigError(f"body {self.name!r}, site {site.name!r}: unknown kind {site.kind!r}; "
                                  f"allowed: {', '.join(SITE_KINDS)}")
            if site.name in site_names:
                raise ConfigError(f"body {self.name!r}: site name {site.name!r} is used twice")
            site_names.add(site.name)
        for camera in self.cameras:
            if camera.segment not in names:
                raise ConfigError(f"body {self.name!r}, camera {camera.name!r}: unknown segment {camera.segment!r}")
            if camera.projection not in PROJECTIONS:
                raise ConfigError(f"body {self.name!r}, camera {camera.name!r}: unknown projection "
                                  f"{camera.projection!r}; allowed: {', '.join(PROJECTIONS)}")
            if camera.width_px < 1 or camera.height_px < 1:
                raise ConfigError(f"body {self.name!r}, camera {camera.name!r}: image size must be positive")
            if isinstance(camera.supersample, bool) or camera.supersample not in range(1, 9):
                raise ConfigError(f"body {self.name!r}, camera {camera.name!r}: supersample must be an int in "
                                  f"1..8 (rays per pixel side), got {camera.supersample!r}")
        eye_names = {camera.name for camera in self.cameras}
        for eye in self.compound_eyes:
            if not isinstance(eye, CompoundEye):
                raise ConfigError(f"body {self.name!r}: compound_eyes must be CompoundEye instances, "
                                  f"got {type(eye).__name__}")
            if eye.segment not in names:
                raise ConfigError(f"body {self.name!r}, compound eye {eye.name!r}: unknown segment {eye.segment!r}")
            if eye.name in eye_names:
                raise ConfigError(f"body {self.name!r}: compound eye name {eye.name!r} is used twice (cameras and "
                                  f"compound eyes share one name space)")
            eye_names.add(eye.name)

    # -- queries ----------------------------------------------------------------------------------
    @property
    def root(self) -> Segment:
        return self.segments[0]

    @property
    def joints(self) -> list[Joint]:
        """The actuated (hinge) joints in declaration order: the order of every joint array."""
        return [s.joint for s in self.segments if s.joint is not None and s.joint.kind == "hinge"]

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def total_mass_kg(self) -> float:
        return float(sum(s.mass_kg for s in self.segments))

    def segment(self, name: str) -> Segment:
        for segment in self.segments:
            if segment.name == name:
                return segment
        raise ConfigError(f"body {self.name!r} has no segment {name!r}")

    def sites_of_kind(self, kind: str) -> list[Site]:
        return [s for s in self.sites if s.kind == kind]

    def rest_pose_rad(self) -> np.ndarray:
        """Rest angle of every actuated joint, in :attr:`joints` order."""
        return np.array([j.rest_rad for j in self.joints])


class Gait(Protocol):
    """Turns the locomotion command into joint targets, one control step at a time.

    ``turn`` is the paper's rotation configuration θ in [-1, 1] (0 straight, ±1 on the spot);
    ``stride_rad`` the hip swing S_l.
    """

    joint_names: tuple[str, ...]

    def reset(self) -> None: ...

    def step(self, turn: float, stride_rad: float) -> np.ndarray:
        """Joint targets (rad) for the next control step, in ``joint_names`` order."""
        ...


def quat_to_matrix(quat) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = quat
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def axis_angle_quat(axis, angle_rad: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation by ``angle_rad`` about ``axis``."""
    axis = np.asarray(axis, float)
    axis = axis / np.linalg.norm(axis)
    half = angle_rad / 2.0
    return (float(np.cos(half)), *(float(v) for v in np.sin(half) * axis))
