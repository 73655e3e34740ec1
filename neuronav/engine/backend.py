"""The backend protocol: what every physics (or kinematic) engine offers the agent loop.

Backends register under the entry-point group ``neuronav.backends`` and are found by name
(:mod:`neuronav.registry`). ``read`` is lazy: only the names asked for are computed.

Articulated (physics) backends simulate one body and share the sensors of
:data:`ARTICULATED_SENSORS` (the one list of them: a new sensor is declared there, read by
:class:`neuronav.engine.articulated.ArticulatedBackend` from each engine's reports), each read with a
leading batch dimension of 1 (J hinge joints, C contact sites, O/W odour/wind sites, K the world's
odour channels):

{sensor_table}

Each body camera (``BodySpec.cameras``; on the kinematic backend ``PointAgents.cameras``) is a
sensor too, named after the camera: its image in grey, shape (H, W), float in [0, 1], rendered only
when read, by the rules of :mod:`neuronav.senses.vision`; ``render(camera)`` gives the colour image
(H, W, 3) uint8. A compound eye (``BodySpec.compound_eyes``, :mod:`neuronav.senses.compound_eye`; on the
kinematic backend ``PointAgents.compound_eyes``, read by rays; on MuJoCo, dm_control and PyBullet from rendered
cube faces, :mod:`neuronav.senses.compound_eye_views`) is a sensor named after it: (M, 2), each
ommatidium's green and UV in [0, 1]. Odour and wind come from the world's
:class:`~neuronav.senses.chemistry.Chemistry` (``backend.chemistry``), built at ``load``, seeded at
``reset`` (the plume), advanced to the
backend's time when read. Every backend can turn the world's objects about the vertical axis:
``set_scene_yaw(yaw_rad)`` (``scene_yaw_rad`` reads it back).

Articulated backends accept ``joint_targets`` (J,) rad for position-controlled joints (torque = kp (target - q) -
kd q', clipped to each joint's max torque), and ``adhesion`` (C,) in [0, 1], the fraction of the
world's ``adhesion_n`` each touching adhesive contact site gets (all 1 after a reset: I2Bot's rule,
force while touching; a controller can switch pads off in swing); both with or without the batch
dimension. ``reset(seed, position_m=(x, y), yaw_rad=...)`` puts the body at its rest pose above the
terrain (``seed``: None or an int >= 0); ``position_m=(x, y, z)`` puts the root at that height
instead, ``pitch_rad`` tilts the body nose-up about its lateral axis (π/2: head up, belly toward
+x), e.g. to start it on a wall, and ``spin_rad`` turns it about its own up axis first
(:func:`start_pose`). ``apply_force(0, name, force_n)`` pushes at a site or at a segment's origin.

Every backend casts rays against its scene: ``cast_rays(origins_m (N, 3), directions (N, 3),
max_distance_m=50.0)`` gives the distance (m) along each ray to the first surface (the world's objects
at the current scene yaw, the ground, a wall), ``np.inf`` where none lies within ``max_distance_m``;
directions need not be unit vectors (they are normalised); the physics backends ignore their own body,
so a ray may start inside it (e.g. at the head, looking at the sky). Its arguments are checked by
:meth:`BackendBase._check_rays` (shapes, finite, non-zero directions, a distance > 0: else a
:class:`ConfigError` naming the argument). On the kinematic backend ``head_pos`` / ``head_quat`` are
the agents' positions at ``PointAgents.head_height_m`` and their heading's yaw, and the rays of many
agents are stacked into one call.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from numbers import Integral
from typing import Any, Protocol, runtime_checkable

import numpy as np

from neuronav.errors import ConfigError, PortError, real_or_nan
from neuronav.senses.chemistry import Chemistry
from neuronav.spec.ports import MotorSpec, SensorSpec
from neuronav.spec.world import World

# Sensors of articulated backends: (name, shape with J/C/O/W for the body's sizes, units, what);
# the table in the module docstring says the same in words.
ARTICULATED_SENSORS: tuple[tuple[str, tuple, str, str], ...] = (
    ("joint_pos", ("J",), "rad", "joint angles"),
    ("joint_vel", ("J",), "rad/s", "joint velocities"),
    ("joint_torque", ("J",), "N*m", "control torque of the last physics step"),
    ("contact_force", ("C", 3), "N", "total force on each contact site's geom, world frame"),
    ("contact_load", ("C",), "N", "magnitude of the total force on each contact site's geom in the last physics step "
     "(a load sensor: no extra constraint solve)"),
    ("body_pos", (3,), "m", "root frame origin"),
    ("body_quat", (4,), "", "root rotation (w, x, y, z), w >= 0"),
    ("body_linvel", (3,), "m/s", "root origin velocity, world axes"),
    ("body_angvel", (3,), "rad/s", "root angular velocity, world axes"),
    ("heading", (1,), "rad", "body +x axis clockwise from world +y"),
    ("velocity", (2,), "m/s", "body_linvel in the xy plane"),
    ("position", (2,), "m", "body_pos in the xy plane"),
    ("head_pos", (3,), "m", "head segment's frame origin (a body without a 'head' segment: the root's)"),
    ("head_quat", (4,), "", "head segment's rotation (w, x, y, z), w >= 0 (no 'head': the root's)"),
    ("odour_sites", ("O", 3), "m", "odour sites, world frame"),
    ("wind_sites", ("W", 3), "m", "wind sites, world frame"),
    ("odour", ("O", "K"), "amount/m^3", "concentration of each odour at each odour site (trails: 0-1)"),
    ("wind", ("W", 2), "m/s", "wind (x, y) at each wind site"),
)


def _sensor_table() -> str:
    """The module docstring's table of :data:`ARTICULATED_SENSORS` (written from it: one source)."""
    rows = [(f"``{name}``", "(" + ", ".join(map(str, shape)) + ("," if len(shape) == 1 else "") + ")", units, what)
            for name, shape, units, what in ARTICULATED_SENSORS]
    widths = [max(len(row[k]) for row in rows + [("sensor", "shape", "units", "what")]) for k in range(4)]
    rule = "  ".join("=" * w for w in widths)
    header = "  ".join(h.ljust(w) for h, w in zip(("sensor", "shape", "units", "what"), widths)).rstrip()
    lines = [rule, header, rule]
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    return "\n".join([*lines, rule])


__doc__ = __doc__.replace("{sensor_table}", _sensor_table())


def adhesion_port(contact_sites: int) -> MotorSpec:
    """The ``adhesion`` command of a physics backend whose body has ``contact_sites`` contact sites."""
    return MotorSpec("adhesion", (contact_sites,), "fraction of adhesion_n", range=(0.0, 1.0))


def quat_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation b, then a, as (w, x, y, z) quaternions."""
    return np.array([a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                     a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                     a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                     a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]])


def start_pose(position_m, yaw_rad: float, pitch_rad: float, where: str,
               spin_rad: float = 0.0) -> tuple[np.ndarray, bool, np.ndarray]:
    """A physics backend's reset pose from the protocol's arguments.

    Parameters
    ----------
    position_m : (x, y) or (x, y, z)
        Where the root starts; without z the backend stands the body on the terrain.
    yaw_rad, pitch_rad, spin_rad : float
        The body first turns by ``spin_rad`` about its own up axis (counter-clockwise seen from
        above it), then tilts nose-up by ``pitch_rad`` about its lateral axis, then turns by
        ``yaw_rad`` about world z. On the floor (no pitch) spin and yaw are the same turn; for a
        body pitched onto a wall, spin turns it on the wall.
    where : str
        The backend's name, for error messages.

    Returns
    -------
    position : ndarray, shape (3,)
        x, y and z (0 when not given).
    z_given : bool
    quat : ndarray, shape (4,)
        (w, x, y, z) rotation: the spin, the pitch, then the yaw.

    Raises
    ------
    ConfigError
        A position of another size, or anything not finite.
    """
    position = np.asarray(position_m, dtype=float).reshape(-1)
    angles = [yaw_rad, pitch_rad, spin_rad]
    if position.size not in (2, 3) or not np.isfinite(position).all() or not np.isfinite(angles).all():
        raise ConfigError(f"{where} reset: position_m must be finite (x, y) or (x, y, z) in m, yaw_rad, "
                          f"pitch_rad and spin_rad finite, got {position_m!r}, {yaw_rad!r}, {pitch_rad!r}, "
                          f"{spin_rad!r}")
    yaw = np.array([np.cos(yaw_rad / 2.0), 0.0, 0.0, np.sin(yaw_rad / 2.0)])
    # Nose-up is a negative turn about the body's +y (left) axis.
    pitch = np.array([np.cos(pitch_rad / 2.0), 0.0, -np.sin(pitch_rad / 2.0), 0.0])
    spin = np.array([np.cos(spin_rad / 2.0), 0.0, 0.0, np.sin(spin_rad / 2.0)])
    quat = quat_product(yaw, quat_product(pitch, spin))
    return np.append(position, 0.0)[:3], position.size == 3, quat


def check_seed(where: str, seed) -> int | None:
    """A reset seed: None or an int >= 0 (a seed NumPy's generators accept); every backend's rule."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, Integral) or seed < 0:
        raise ConfigError(f"{where} reset: seed must be None or an int >= 0, got {seed!r}")
    return int(seed)


@dataclass(frozen=True)
class Capabilities:
    """What a backend can do.

    Attributes
    ----------
    name : str
    sensors : tuple of SensorSpec
        What ``read`` can return (shapes per agent, without the batch dimension).
    motors : tuple of MotorSpec
        What ``write`` accepts.
    batched : bool
        Whether one instance simulates many agents at once.
    can_render : bool
        Whether ``render`` produces camera images.
    """

    name: str
    sensors: tuple[SensorSpec, ...]
    motors: tuple[MotorSpec, ...]
    batched: bool = False
    can_render: bool = False


@runtime_checkable
class Backend(Protocol):
    """The interface the agent loop uses; see docs/architecture.md."""

    capabilities: Capabilities

    def load(self, world: World, bodies: Sequence[Any]) -> None: ...
    def reset(self, seed: int | None = None, **pose) -> None: ...
    def step(self, n: int = 1) -> None: ...
    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]: ...
    def write(self, commands: dict[str, np.ndarray]) -> None: ...
    def render(self, camera: str) -> np.ndarray: ...
    def apply_force(self, body: int | str, site: str, force_n: np.ndarray) -> None: ...
    def set_scene_yaw(self, yaw_rad: float) -> None: ...
    def cast_rays(self, origins_m: np.ndarray, directions: np.ndarray,
                  max_distance_m: float = 50.0) -> np.ndarray: ...
    @property
    def scene_yaw_rad(self) -> float: ...
    @property
    def time(self) -> float: ...
    @property
    def timestep(self) -> float: ...
    def close(self) -> None: ...
    def __enter__(self) -> Backend: ...
    def __exit__(self, *exc: object) -> None: ...


class BackendBase:
    """Shared plumbing: name checks for ``read``/``write``, odour and wind, the context-manager methods."""

    capabilities: Capabilities
    chemistry: Chemistry | None = None

    def _odour_at(self, points_m: np.ndarray) -> np.ndarray:
        """Every odour at points (..., 3), the world's chemistry caught up with this backend's time."""
        self.chemistry.advance_to(self.time)
        return self.chemistry.odour_at(points_m)

    def _wind_at(self, points_m: np.ndarray) -> np.ndarray:
        """Wind (x, y) at points (..., 3), the world's chemistry caught up with this backend's time."""
        self.chemistry.advance_to(self.time)
        return self.chemistry.wind_at(points_m)

    def _check_rays(self, origins_m, directions, max_distance_m) -> tuple[np.ndarray, np.ndarray, float]:
        """``cast_rays``' arguments checked: origins (N, 3) m and unit directions (N, 3) as float arrays
        (the directions normalised) and the distance, or a ConfigError naming the argument at fault.

        Shapes: (N, 3) each with the same N >= 0 (one ray (3,) is taken as (1, 3)); every value finite;
        no direction of length 0; ``max_distance_m`` a finite number > 0.
        """
        where = f"{self.capabilities.name} cast_rays"
        arrays = []
        for label, values in (("origins_m", origins_m), ("directions", directions)):
            try:
                array = np.array(values, dtype=float)
            except (TypeError, ValueError):
                raise ConfigError(f"{where}: {label} must be numbers of shape (N, 3), "
                                  f"got {type(values).__name__}") from None
            if array.shape == (3,):
                array = array[None]
            if array.ndim != 2 or array.shape[1] != 3:
                raise ConfigError(f"{where}: {label} must have shape (N, 3), got {array.shape}")
            if not np.isfinite(array).all():
                raise ConfigError(f"{where}: {label} must be finite, got a non-finite value")
            arrays.append(array)
        origins, vectors = arrays
        if origins.shape != vectors.shape:
            raise ConfigError(f"{where}: origins_m {origins.shape} and directions {vectors.shape} must have the "
                              "same shape (N, 3)")
        length = np.linalg.norm(vectors, axis=1)
        if (length == 0).any():
            raise ConfigError(f"{where}: directions must not be zero vectors (ray {int(np.argmin(length))})")
        distance = real_or_nan(max_distance_m)
        if not 0 < distance < np.inf:
            raise ConfigError(f"{where}: max_distance_m must be a finite number > 0 (m), got {max_distance_m!r}")
        return origins, vectors / length[:, None], distance

    def _check_read(self, names: Iterable[str]) -> list[str]:
        names = list(names)
        capabilities = self.capabilities
        if getattr(self, "_sensor_names_of", None) is not capabilities:  # built once per capabilities
            self._sensor_names = frozenset(s.name for s in capabilities.sensors)
            self._sensor_names_of = capabilities
        known = self._sensor_names
        for name in names:
            if name not in known:
                raise PortError(
                    f"backend {self.capabilities.name!r} has no sensor {name!r}; "
                    f"available: {', '.join(sorted(known))}"
                )
        return names

    def _adhesion_fractions(self, command: np.ndarray) -> np.ndarray:
        """A checked ``adhesion`` command of one body: its (C,) fractions, each in [0, 1]."""
        fractions = np.asarray(command, dtype=float)[0]
        if not (np.isfinite(fractions).all() and fractions.min() >= 0.0 and fractions.max() <= 1.0):
            raise PortError(f"backend {self.capabilities.name!r}: adhesion takes fractions in [0, 1] "
                            f"(of the world's adhesion_n), got {fractions.tolist()}")
        return fractions.copy()

    def _check_write(self, commands: dict[str, np.ndarray], batch: int) -> dict[str, np.ndarray]:
        specs = {m.name: m for m in self.capabilities.motors}
        checked = {}
        for name, value in commands.items():
            spec = specs.get(name)
            if spec is None:
                raise PortError(
                    f"backend {self.capabilities.name!r} accepts no command {name!r}; "
                    f"accepted: {', '.join(sorted(specs))}"
                )
            array = np.asarray(value, dtype=float)
            expected = (batch, *spec.shape)
            if array.shape != expected:
                if array.shape == (batch,) and spec.shape == (1,):
                    array = array[:, None]
                else:
                    raise PortError(
                        f"backend {self.capabilities.name!r}: command {name!r} must have shape {expected} "
                        f"(batch, *shape) [{spec.units}], got {array.shape}"
                    )
            checked[name] = array
        return checked

    # -- scene rotation (every backend) ---------------------------------------------------------------
    _scene_yaw_rad = 0.0

    @property
    def scene_yaw_rad(self) -> float:
        """How far the world's objects are turned about the vertical axis (see :class:`World`)."""
        return self._scene_yaw_rad

    def set_scene_yaw(self, yaw_rad: float) -> None:
        """Turn all of the world's objects to ``yaw_rad`` (counter-clockwise seen from above) about the
        world's z axis through the origin; the ground and the bodies stay where they are."""
        self._require()
        try:
            value = float(yaw_rad)
        except (TypeError, ValueError):
            value = float("nan")
        if isinstance(yaw_rad, bool) or not np.isfinite(value):
            raise ConfigError(f"{self.capabilities.name} set_scene_yaw: yaw_rad must be a finite number (rad), "
                              f"got {yaw_rad!r}")
        self._scene_yaw_rad = value
        self._turn_scene(value)

    def _turn_scene(self, yaw_rad: float) -> None:
        """Put the world's objects at their declared poses turned by ``yaw_rad`` (an engine's hook; a
        backend that turns its rays instead, like the kinematic ray caster, has nothing to move)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the engine's resources (nothing to do by default)."""
