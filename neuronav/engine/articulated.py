"""What every articulated (physics) backend does the same way, written once.

:class:`ArticulatedBackend` is the base of the MuJoCo and PyBullet backends. It owns the protocol's
rules and checks, so that an engine module only translates them into its engine's calls:

- the sensors and motors (:data:`neuronav.engine.backend.ARTICULATED_SENSORS`, sized from the body by
  :func:`articulated_capabilities`) and the sensors derived from the root's state (``heading``,
  ``position``, ``velocity``): an engine reports the root's pose and velocity, the joints, the
  contact forces and site positions, nothing more;
- the load checks (a :class:`World` and exactly one :class:`BodySpec`), the physics step's and
  ``step(n)``'s checks, the reset's arguments (``seed`` None or an int >= 0, the pose through
  :func:`neuronav.engine.backend.start_pose`) and lifting the body clear of the terrain after a reset;
- ``write``: a body's command with or without its batch dimension of 1, names, shapes, finite
  joint targets, adhesion fractions in [0, 1];
- ``apply_force``: body 0 only, a finite world-frame force (3,) N, at a *site* (at the site) or a
  *segment* (at the segment frame's origin); anything else is a :class:`ConfigError` listing both;
- the follow camera's framing (:func:`follow_view`): the same view on every engine;
- body cameras (:mod:`neuronav.senses.vision`): each is a sensor (its image in grey), composed here from
  the flat-shaded planar views an engine renders (a spherical camera from cube faces), with the
  World's sky painted where nothing was hit; ``set_scene_yaw`` turns the world's objects;
- ``head_pos`` / ``head_quat``: the pose of the segment named ``head`` (:data:`HEAD_SEGMENT`), or the
  root's for a body without one; ``cast_rays``' checks (the engine casts checked rays past the body);
- compound eyes (``BodySpec.compound_eyes``): each a sensor (M, 2), green and UV in [0, 1], read from the
  cube faces about the eye that its ommatidia reach (:mod:`neuronav.senses.compound_eye_views`), rendered
  in the world's spectral colouring (``_render_views(..., spectral=True)``), every eye of one read in one
  render call, then one sparse product per eye.

Engine hooks (each backend implements them): ``_load_engine``, ``_reset_engine``, ``_raise_root``,
``_penetration_m``, ``_root_pose``, ``_segment_pose``, ``_root_velocity``, ``_joint_state``,
``_joint_torque``, ``_contact_forces`` (and ``_contact_loads``), ``_site_positions``, ``_set_joint_targets``,
``_queue_force``, ``_render_follow``, ``_camera_frame``, ``_render_views``, ``_turn_scene``, ``_cast_rays`` and
``_require``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from numbers import Integral

import numpy as np

from neuronav.engine.backend import (
    ARTICULATED_SENSORS,
    BackendBase,
    Capabilities,
    adhesion_port,
    check_seed,
    start_pose,
)
from neuronav.engine.sampling import Sampler
from neuronav.errors import ConfigError, PortError
from neuronav.senses.chemistry import Chemistry
from neuronav.senses.compound_eye_views import eye_views
from neuronav.senses.raycast import bounds_span_m, object_bounds
from neuronav.senses.vision import View, camera_views, compose_image, cube_lookup, grey
from neuronav.spec.body import BodySpec, Camera, Geom, quat_to_matrix
from neuronav.spec.ports import MotorSpec, SensorSpec
from neuronav.spec.world import World

MIN_TIMESTEP_S = 1e-6
# Reset: overlaps up to this deep are touching, not inside; a lift clears the overlap by LIFT_CLEARANCE_M.
LIFT_TOLERANCE_M = 1e-4
LIFT_CLEARANCE_M = 1e-3
LIFT_NOTE = "reset lifted the body above spawn_height_m so that no part starts inside the terrain"
# The follow camera: 640x480, 45° vertical field of view, looking 25° down at the body's centre from
# behind, far enough that the body's rest-pose bounding sphere (legs, gaster, antennae) fills at most
# 1/FOLLOW_MARGIN of the image height.
FOLLOW_SIZE_PX = (640, 480)
FOLLOW_FOV_DEG = 45.0
FOLLOW_DOWN_DEG = 25.0
FOLLOW_MARGIN = 1.25
# A body on a wall is seen from over its back (70° from its forward axis toward its back), and the
# camera never goes below FOLLOW_MIN_EYE_Z_M (it would look through the floor from underneath).
FOLLOW_WALL_DEG = 70.0
FOLLOW_MIN_EYE_Z_M = 0.05
# The segment whose pose ``head_pos`` / ``head_quat`` report (a body without it: the root's).
HEAD_SEGMENT = "head"
# cast_rays: the ground is never hit above its highest point plus this (m) nor below its lowest less this.
RAY_GROUND_MARGIN_M = 0.01


# What a physics backend holding several ants reads for each (the agent axis first, (N, ...)).
SWARM_SENSORS: tuple[tuple[str, tuple, str], ...] = (
    ("heading", (1,), "rad"),
    ("position", (2,), "m"),
    ("velocity", (2,), "m/s"),
    ("body_pos", (3,), "m"),
    ("body_quat", (4,), ""),
    ("body_linvel", (3,), "m/s"),
    ("body_angvel", (3,), "rad/s"),
    ("joint_pos", ("J",), "rad"),
    ("joint_vel", ("J",), "rad/s"),
)


def swarm_capabilities(name: str, joints: int) -> Capabilities:
    """The sensors (:data:`SWARM_SENSORS`) and motors of a physics backend holding several ants of
    ``joints`` hinge joints each, batched over ants."""
    return Capabilities(
        name=name,
        sensors=tuple(SensorSpec(n, tuple(joints if d == "J" else d for d in shape), units)
                      for n, shape, units in SWARM_SENSORS),
        motors=(MotorSpec("joint_targets", (joints,), "rad"),), batched=True)


def check_swarm_load(engine: str, world, bodies, max_ants: int | None = None) -> list[BodySpec]:
    """What a physics backend holding several ants accepts in ``load``: a World without adhesion and 1
    to ``max_ants`` BodySpecs with the same number of joints; the bodies as a list, or a
    :class:`ConfigError` naming ``engine`` and what is allowed."""
    bodies = list(bodies)
    if not isinstance(world, World):
        raise ConfigError(f"{engine} swarm: load needs a neuronav World, got {type(world).__name__}")
    too_many = max_ants is not None and len(bodies) > max_ants
    if not bodies or too_many or not all(isinstance(b, BodySpec) for b in bodies):
        kinds = ", ".join(type(b).__name__ for b in bodies[:3]) or "nothing"
        allowed = ("one or more BodySpecs" if max_ants is None
                   else f"1 to {max_ants} BodySpecs (one contact bit each)")
        raise ConfigError(f"{engine} swarm: load takes {allowed}, got {len(bodies)} "
                          f"({kinds}{', ...' if len(bodies) > 3 else ''})")
    joints = {len(b.joints) for b in bodies}
    if len(joints) != 1:
        raise ConfigError(f"{engine} swarm: every ant needs the same number of joints, got {sorted(joints)}")
    if world.adhesion_n > 0:
        raise ConfigError(f"{engine} swarm: adhesion is not simulated for several ants; world adhesion_n must be "
                          f"0, got {world.adhesion_n}")
    return bodies


def articulated_capabilities(name: str, body: BodySpec | None = None, n_odours: int = 1) -> Capabilities:
    """The sensors and motors of an articulated backend carrying ``body`` in a world of ``n_odours``.

    Sizes J (hinge joints), C (contact sites), O (odour sites) and W (wind sites) come from the
    body, K from the world's odours; a sensor with a zero size is left out (a body without odour
    sites has no ``odour_sites`` and no ``odour``).
    Without a body (before ``load``) every sensor is listed with (1,)-sized placeholders.
    """
    if body is None:
        sensors = tuple(SensorSpec(s, tuple(1 if isinstance(n, str) else n for n in shape), units)
                        for s, shape, units, _ in ARTICULATED_SENSORS)
        return Capabilities(name=name, sensors=sensors, motors=(MotorSpec("joint_targets", (1,), "rad"),),
                            batched=False, can_render=True)
    sizes = {"J": len(body.joints), "C": len(body.sites_of_kind("contact")),
             "O": len(body.sites_of_kind("odour")), "W": len(body.sites_of_kind("wind")), "K": int(n_odours)}
    sensors = []
    for sensor, shape, units, _ in ARTICULATED_SENSORS:
        shape = tuple(sizes[n] if isinstance(n, str) else n for n in shape)
        if min(shape) > 0:
            sensors.append(SensorSpec(sensor, shape, units))
    # Each body camera is a sensor too: its image in grey, float in [0, 1] (neuronav.senses.vision).
    sensors += [SensorSpec(camera.name, (camera.height_px, camera.width_px), "grey [0, 1]") for camera in body.cameras]
    # Each compound eye too: green and UV per ommatidium (neuronav.senses.compound_eye_views).
    sensors += [SensorSpec(eye.name, (eye.n_ommatidia, 2), "green, UV [0, 1]") for eye in body.compound_eyes]
    motors = (MotorSpec("joint_targets", (sizes["J"],), "rad"),) if sizes["J"] else ()
    if sizes["C"]:
        motors += (adhesion_port(sizes["C"]),)
    return Capabilities(name=name, sensors=tuple(sensors), motors=motors, batched=False, can_render=True)


def heading_rad(rotation: np.ndarray) -> float:
    """The protocol's heading of a body with this rotation (3, 3): its +x axis, clockwise from world +y."""
    forward = rotation[:, 0]
    return float(np.arctan2(forward[0], forward[1]))


def canonical_quat(quat) -> np.ndarray:
    """A (w, x, y, z) quaternion with w >= 0 (q and -q are the same rotation; every engine reports this one)."""
    quat = np.asarray(quat, dtype=float)
    return quat if quat[0] >= 0 else -quat


def check_timestep(where: str, timestep_s) -> float:
    """A physics step in seconds: a number from ``MIN_TIMESTEP_S`` (1 µs) to 1 s."""
    if not (isinstance(timestep_s, int | float | np.floating) and not isinstance(timestep_s, bool)
            and np.isfinite(timestep_s) and MIN_TIMESTEP_S <= timestep_s <= 1.0):
        raise ConfigError(f"{where} backend: timestep_s must be a number of seconds from {MIN_TIMESTEP_S:g} to 1, "
                          f"got {timestep_s!r}")
    return float(timestep_s)


# -- the body's extent and the follow camera ---------------------------------------------------------
def _geom_radius_m(geom: Geom) -> float:
    """Radius of a sphere around the geom's centre that holds the whole geom."""
    size = np.asarray(geom.size_m, dtype=float)
    if geom.shape == "sphere":
        return float(size[0])
    if geom.shape == "box":
        return float(np.linalg.norm(size))
    if geom.shape == "capsule":
        return float(size[0] + size[1])
    return float(np.hypot(size[0], size[1]))  # cylinder


def _axis_rotation(axis, angle_rad: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle_rad) * k + (1.0 - np.cos(angle_rad)) * k @ k


def rest_bounds(body: BodySpec) -> tuple[np.ndarray, float]:
    """A sphere holding the whole body at its rest pose: centre (3,) in the root frame, radius (m).

    Segment frames follow the rule every backend builds: ``pos_m``/``quat`` in the parent's frame,
    then the joint's turn by its rest angle about its axis.
    """
    frames: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    points, radii = [], []
    for segment in body.segments:
        if segment.parent is None:
            rotation, position = np.eye(3), np.zeros(3)
        else:
            parent_rot, parent_pos = frames[segment.parent]
            position = parent_pos + parent_rot @ np.asarray(segment.pos_m, float)
            rotation = parent_rot @ quat_to_matrix(segment.quat)
            if segment.joint is not None and segment.joint.kind == "hinge":
                rotation = rotation @ _axis_rotation(segment.joint.axis, segment.joint.rest_rad)
        frames[segment.name] = (rotation, position)
        for geom in segment.geoms:
            points.append(position + rotation @ np.asarray(geom.pos_m, float))
            radii.append(_geom_radius_m(geom))
    points, radii = np.array(points), np.array(radii)
    centre = ((points - radii[:, None]).min(axis=0) + (points + radii[:, None]).max(axis=0)) / 2.0
    return centre, float((np.linalg.norm(points - centre, axis=1) + radii).max())


def follow_axes(rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward and up directions for a camera that follows a body, from its rotation matrix (3, 3).

    A body on the floor (its up axis within 60° of vertical) is followed along its heading, with
    the world's up: the view does not rock with the gait. A body on a wall or a ceiling is followed
    in its own frame: behind it along its forward axis, above it along its up axis.
    """
    rotation = np.asarray(rotation, dtype=float)
    forward, up = rotation[:, 0].copy(), rotation[:, 2].copy()
    if up[2] >= 0.5:
        forward[2], up = 0.0, np.array([0.0, 0.0, 1.0])
        norm = np.linalg.norm(forward)
        forward = forward / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
    return forward, up


@dataclass(frozen=True)
class FollowView:
    """Where the follow camera is: ``eye`` and ``target`` (3,) m in the world, ``up`` (3,) unit,
    ``distance_m`` between them, the vertical field of view and the image size."""

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    distance_m: float
    fov_deg: float = FOLLOW_FOV_DEG
    size_px: tuple[int, int] = FOLLOW_SIZE_PX


def follow_view(root_pos: np.ndarray, rotation: np.ndarray, bounds: tuple[np.ndarray, float]) -> FollowView:
    """The follow camera's view of a body whose root is at ``root_pos`` with ``rotation`` (3, 3).

    It looks at the centre of the body's rest-pose bounding sphere (``bounds``, from
    :func:`rest_bounds`) from the distance at which that sphere spans 1/``FOLLOW_MARGIN`` of the
    image height: the whole body is in the frame, whatever its proportions. On the floor it looks
    from behind, ``FOLLOW_DOWN_DEG`` down (along :func:`follow_axes`); on a wall or a ceiling from
    over the body's back, ``FOLLOW_WALL_DEG`` from its forward axis. The eye stays at least
    ``FOLLOW_MIN_EYE_Z_M`` above z = 0 (it is raised there, still looking at the body).
    """
    centre_root, radius = bounds
    forward, up = follow_axes(rotation)
    target = np.asarray(root_pos, float) + np.asarray(rotation, float) @ centre_root
    angle = np.radians(FOLLOW_DOWN_DEG if up[2] == 1.0 else FOLLOW_WALL_DEG)  # follow_axes: world up on the floor
    view = np.cos(angle) * forward - np.sin(angle) * up
    distance = FOLLOW_MARGIN * radius / np.sin(np.radians(FOLLOW_FOV_DEG) / 2.0)
    eye = target - distance * view
    if eye[2] < FOLLOW_MIN_EYE_Z_M:
        eye[2] = FOLLOW_MIN_EYE_Z_M
        distance = float(np.linalg.norm(target - eye))
        view = (target - eye) / distance
    camera_up = np.cross(np.cross(view, up), view)
    return FollowView(eye=eye, target=target, up=camera_up / np.linalg.norm(camera_up), distance_m=float(distance))


# -- the base class --------------------------------------------------------------------------------------
class ArticulatedBackend(BackendBase):
    """The protocol's shared half for engines that simulate one articulated body (see the module doc).

    Subclasses set :attr:`engine` (their registered name), call ``super().__init__`` and implement
    the engine hooks. ``body`` and ``world`` are what :meth:`load` was given.
    """

    engine = "articulated"
    # Whether cast_rays tests the rays against the objects' bounding spheres before the engine casts them
    # (worth it where the engine's own ray test costs more than that test, e.g. from inside the body).
    cull_rays = True

    def __init__(self, timestep_s: float) -> None:
        self._timestep_s = check_timestep(self.engine, timestep_s)
        self.capabilities = articulated_capabilities(self.engine)
        self.body: BodySpec | None = None
        self.world: World | None = None
        self.warnings: list[str] = []
        # What the backend did on its own (e.g. lifting the body on reset): information, not a problem.
        self.notes: list[str] = []
        self._adhesion_scale = np.ones(0)
        self._bounds: tuple[np.ndarray, float] | None = None
        self._scene_yaw_rad = 0.0

    @property
    def timestep(self) -> float:
        return self._timestep_s

    # -- protocol ------------------------------------------------------------------------------------
    def load(self, world: World, bodies: Sequence[BodySpec]) -> None:
        """Build ``world`` with exactly one :class:`BodySpec` in the engine, then :meth:`reset`.

        Raises
        ------
        ConfigError
            Not a :class:`World`, not exactly one BodySpec, or a spec the engine cannot express.
        """
        if not isinstance(world, World):
            raise ConfigError(f"{self.engine} backend: load needs a neuronav World, got {type(world).__name__}")
        bodies = list(bodies)
        if len(bodies) != 1 or not isinstance(bodies[0], BodySpec):
            kinds = ", ".join(type(b).__name__ for b in bodies) or "nothing"
            raise ConfigError(f"the {self.engine} backend simulates exactly one BodySpec, got {kinds}")
        body = bodies[0]
        self._load_engine(world, body)
        self.body, self.world = body, world
        self.capabilities = articulated_capabilities(self.engine, body, world.odour.n_odours)
        self.chemistry = Chemistry(world.odour)
        self._bounds = rest_bounds(body)
        self._sites = {s.name: s for s in body.sites}
        self._segments = {s.name for s in body.segments}
        self._cameras = {c.name: c for c in body.cameras}
        self._compound_eyes = {e.name: e for e in body.compound_eyes}
        self._scene_yaw_rad = 0.0
        self._ground_heights_m = None
        self._ray_bounds = None
        self.reset()

    def reset(self, seed: int | None = None, position_m=(0.0, 0.0), yaw_rad: float = 0.0,
              pitch_rad: float = 0.0, spin_rad: float = 0.0) -> None:
        """Rest pose, at rest, root ``spawn_height_m`` above the terrain under ``position_m``.

        ``yaw_rad`` turns the body counter-clockwise from +x (its heading is then pi/2 - yaw);
        ``position_m=(x, y, z)``, ``pitch_rad`` and ``spin_rad`` place it anywhere, e.g. on a wall
        (:func:`neuronav.engine.backend.start_pose`). Standing on the terrain (no z), a body that would
        start inside it (rough ground) is lifted just clear (noted once in :attr:`notes`). Every
        pad's adhesion is switched fully on. ``seed`` seeds the world's plume (:attr:`chemistry`);
        the engines themselves are deterministic: for them ``seed`` (None or an
        int >= 0) changes nothing and is accepted for the protocol.
        """
        self._require()
        self._seed = check_seed(self.engine, seed)
        self.chemistry.reset(self._seed)
        position, z_given, pose_quat = start_pose(position_m, yaw_rad, pitch_rad, self.engine, spin_rad)
        if not z_given:
            position[2] = float(self.world.ground.height_at(position[0], position[1])) + self.body.spawn_height_m
        self._adhesion_scale = np.ones(len(self.body.sites_of_kind("contact")))
        self._reset_engine(position, pose_quat)
        if not z_given:
            self._lift_clear(position)

    def _lift_clear(self, position: np.ndarray) -> None:
        lifted = 0.0
        for _ in range(20):  # contact depths are local: lift until no overlap is left
            sink = self._penetration_m()
            if sink <= LIFT_TOLERANCE_M:
                break
            self._raise_root(sink + LIFT_CLEARANCE_M)
            lifted += sink + LIFT_CLEARANCE_M
        if lifted and not any(n.startswith(LIFT_NOTE) for n in self.notes):  # once, not at every reset
            self.notes.append(f"{LIFT_NOTE} (first at {[float(position[0]), float(position[1])]}, by {lifted:.4f} m)")

    def _check_steps(self, n) -> int:
        whole = isinstance(n, Integral) or (isinstance(n, float) and np.isfinite(n) and int(n) == n)
        if isinstance(n, bool) or not whole or n < 0:
            raise ConfigError(f"{self.engine} step: n must be a whole number of steps >= 0, got {n!r}")
        return int(n)

    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]:
        """Sensor values, each with a leading batch dimension of 1; only the names asked for are computed."""
        self._require()
        names = list(self._check_read(names))
        # The compound eyes asked for are rendered together, at the first of them; so are the cameras.
        cache: dict[str, object] = {"compound_eyes": [n for n in names if n in self._compound_eyes],
                                    "camera_names": [n for n in names if n in self._cameras]}
        return {name: np.array(self._sensor(name, cache), dtype=float)[None] for name in names}

    def sampler(self, names: Iterable[str]) -> Sampler:
        """A reader of ``names`` for every control step (:class:`neuronav.engine.sampling.Sampler`): checked
        once here, then each call returns their values (without the batch dimension) flattened and
        concatenated into one float array (J + C values for ``("joint_pos", "contact_load")``), read as
        :meth:`read` reads them; ``record()`` keeps the current values and ``drain()`` gives those kept as
        rows (T, J + C). For hooks that sample the same sensors at every step (an odometer, a logger), where
        ``read``'s checks and dict cost more than the values. It belongs to this loaded model: make a new
        one after ``load``.
        """
        self._require()
        names = tuple(self._check_read(names))
        return self._sampler(names)

    def _sampler(self, names: tuple[str, ...]) -> Sampler:
        """The engine's :class:`Sampler` of :meth:`sampler` (an engine may give a faster one)."""
        def sample() -> np.ndarray:
            cache: dict[str, object] = {}
            return np.concatenate([np.ravel(self._sensor(name, cache)) for name in names]).astype(float, copy=False)
        return Sampler(sample)

    def _sensor(self, name: str, cache: dict) -> np.ndarray:
        """One sensor, from the engine's reports (``cache`` holds the root's state within one read)."""
        if name in ("body_pos", "body_quat", "heading", "position"):
            if "pose" not in cache:
                cache["pose"] = self._root_pose()
            pos, quat, rotation = cache["pose"]
            if name == "heading":
                return np.array([heading_rad(rotation)])
            return {"body_pos": pos, "body_quat": canonical_quat(quat), "position": pos[:2]}[name]
        if name in ("head_pos", "head_quat"):
            if "head" not in cache:
                cache["head"] = (self._segment_pose(HEAD_SEGMENT) if HEAD_SEGMENT in self._segments
                                 else self._root_pose())
            pos, quat, _ = cache["head"]
            return pos if name == "head_pos" else canonical_quat(quat)
        if name in ("body_linvel", "body_angvel", "velocity"):
            if "velocity" not in cache:
                cache["velocity"] = self._root_velocity()
            linvel, angvel = cache["velocity"]
            return {"body_linvel": linvel, "body_angvel": angvel, "velocity": linvel[:2]}[name]
        if name in ("joint_pos", "joint_vel"):
            if "joints" not in cache:
                cache["joints"] = self._joint_state()
            return cache["joints"][0 if name == "joint_pos" else 1]
        if name == "joint_torque":
            return self._joint_torque()
        if name == "contact_force":
            return self._contact_forces()
        if name == "contact_load":
            return self._contact_loads()
        if name in ("odour_sites", "wind_sites"):
            return self._site_positions(name.split("_")[0])
        if name == "odour":
            return self._odour_at(self._site_positions("odour"))
        if name == "wind":
            return self._wind_at(self._site_positions("wind"))
        if name in self._cameras:
            if name not in cache.get("cameras", {}):
                cache["cameras"] = self._render_cameras(cache.get("camera_names") or [name])
            return grey(cache["cameras"][name])
        if name in self._compound_eyes:
            if name not in cache.get("compound", {}):
                cache["compound"] = self._read_compound_eyes(cache.get("compound_eyes") or [name])
            return cache["compound"][name]
        raise PortError(f"{self.engine} backend: sensor {name!r} is not implemented")  # unreachable after _check_read

    def write(self, commands: dict[str, np.ndarray]) -> None:
        """``joint_targets`` (1, J) or (J,) rad, in :attr:`BodySpec.joint_names` order, finite, held
        until overwritten; ``adhesion`` (1, C) or (C,): each contact site's fraction of the world's
        ``adhesion_n``, in [0, 1]."""
        self._require()
        specs = {m.name: m for m in self.capabilities.motors}
        batched = {}
        for name, value in commands.items():
            array = np.asarray(value, dtype=float)
            spec = specs.get(name)
            batched[name] = array[None] if spec is not None and array.shape == spec.shape else array
        checked = self._check_write(batched, batch=1)
        if "joint_targets" in checked:
            targets = checked["joint_targets"][0]
            if not np.isfinite(targets).all():
                raise PortError(f"{self.engine} backend: joint_targets must be finite (rad), got {targets.tolist()}")
            self._set_joint_targets(targets.copy())
        if "adhesion" in checked:
            self._adhesion_scale = self._adhesion_fractions(checked["adhesion"])

    def apply_force(self, body: int, site: str, force_n) -> None:
        """Add a world-frame force (3,) N during every physics step of the next :meth:`step` call.

        ``site`` names a site (the force acts at the site) or a segment (at its frame's origin).
        """
        spec = self._require()
        if isinstance(body, bool) or not isinstance(body, Integral) or body != 0:
            raise ConfigError(f"{self.engine} apply_force: body {body!r} out of range; this backend has one body (0)")
        force = np.asarray(force_n, dtype=float).reshape(-1)
        if force.shape != (3,) or not np.isfinite(force).all():
            raise ConfigError(f"{self.engine} apply_force: force_n must be 3 finite numbers (N, world frame), "
                              f"got {force_n!r}")
        if site in self._sites:
            target = self._sites[site]
            self._queue_force(target.segment, np.asarray(target.pos_m, float), force)
        elif site in self._segments:
            self._queue_force(site, np.zeros(3), force)
        else:
            raise ConfigError(f"{self.engine} apply_force: unknown site {site!r}: body {spec.name!r} has no site or "
                              f"segment of that name; sites: {', '.join(sorted(self._sites)) or 'none'}; "
                              f"segments: {', '.join(s.name for s in spec.segments)}")

    def cast_rays(self, origins_m, directions, max_distance_m: float = 50.0) -> np.ndarray:
        """Distance (m) along each ray to the first surface of the world, ``np.inf`` for none within
        ``max_distance_m``; the body's own geoms never block a ray (see :mod:`neuronav.engine.backend`).

        Parameters
        ----------
        origins_m, directions : array_like, shape (N, 3)
            World frame; directions are normalised here.
        max_distance_m : float

        Returns
        -------
        ndarray, shape (N,)

        Raises
        ------
        ConfigError
            Shapes other than (N, 3), non-finite values, a zero direction or a distance not > 0.
        """
        self._require()
        origins, unit, far = self._check_rays(origins_m, directions, max_distance_m)
        distances = np.full(origins.shape[0], np.inf)
        # Only rays that can reach the world are cast, each over the stretch where it may hit something
        # (start, stop): the ground's heights and, where the engine wants it (cull_rays), the objects' bounds.
        if self.world.objects and not self.cull_rays:
            start, stop = np.zeros(origins.shape[0]), np.full(origins.shape[0], far)
        else:
            start, stop = self._ground_span_m(origins, unit, far)
        if self.world.objects and self.cull_rays:
            if self._ray_bounds is None:
                self._ray_bounds = object_bounds(self.world.objects)
            enter, leave = bounds_span_m(self._ray_bounds, origins, unit, far, self._scene_yaw_rad)
            start, stop = np.minimum(start, enter), np.maximum(stop, leave)
        stop = np.minimum(stop, far)
        rows = np.flatnonzero(start <= far)
        if rows.size == origins.shape[0]:
            return self._cast_rays(origins, unit, far, start, stop)
        if rows.size:
            distances[rows] = self._cast_rays(origins[rows], unit[rows], far, start[rows], stop[rows])
        return distances

    def _ground_span_m(self, origins: np.ndarray, unit: np.ndarray, far: float) -> tuple[np.ndarray, np.ndarray]:
        """The stretch of each ray where the ground may be hit: between the terrain's highest and lowest
        points (widened by ``RAY_GROUND_MARGIN_M``) going down, from 0 from below the highest; (inf, -inf)
        going up from above it; (0, far) on a wall world."""
        count = origins.shape[0]
        if self.world.ground.kind == "wall":
            return np.zeros(count), np.full(count, far)
        if self._ground_heights_m is None:
            heights = self.world.ground.heights_m()
            self._ground_heights_m = (float(heights.max()) + RAY_GROUND_MARGIN_M,
                                      float(heights.min()) - RAY_GROUND_MARGIN_M)
        top, bottom = self._ground_heights_m
        above, down = origins[:, 2] - top, unit[:, 2] < 0
        with np.errstate(divide="ignore", invalid="ignore"):
            start = np.where(above <= 0, 0.0, np.where(down, above / -unit[:, 2], np.inf))
            stop = np.where(down, (origins[:, 2] - bottom) / -unit[:, 2], np.where(above <= 0, far, -np.inf))
        return start, stop

    def render(self, camera: str) -> np.ndarray:
        """A uint8 (H, W, 3) image from a body camera, or ``"follow"`` (:func:`follow_view`)."""
        self._require()
        if camera == "follow":
            pos, _, rotation = self._root_pose()
            return self._render_follow(follow_view(pos, rotation, self._bounds))
        return self._render_camera(camera)

    def _render_camera(self, camera: str) -> np.ndarray:
        """A body camera's uint8 RGB image by the rules of :mod:`neuronav.senses.vision` (engines render the views)."""
        spec = self._cameras.get(camera)
        if spec is None:
            raise PortError(f"{self.engine} backend has no camera {camera!r}; available: "
                            f"{', '.join(['follow', *self._cameras])}")
        return self._render_cameras([camera])[camera]

    def _render_cameras(self, names: list[str]) -> dict[str, np.ndarray]:
        """Body cameras ``names`` read together: the views of those that see the body alike rendered in one
        call (one scene update and one read of the buffer on MuJoCo: both eyes of a binocular read), each
        camera's image composed from its own views. The same images as one camera at a time (culling is
        exact); where the views do not fit the engine's buffer together, one camera at a time."""
        images: dict[str, np.ndarray] = {}
        for sees_body in (False, True):
            group = [name for name in names if self._cameras[name].sees_body == sees_body]
            layouts = [self._camera_layout(name) for name in group]
            together = len(group) > 1 and self._views_fit([views for _, _, views, _ in layouts])
            for batch in ([list(zip(group, layouts))] if together else [[item] for item in zip(group, layouts)]):
                rendered = self._render_views([view for _, (_, _, views, _) in batch for view in views], sees_body)
                start = 0
                for name, (spec, rotation, views, lookup) in batch:
                    images[name] = compose_image(spec, rotation, rendered[start:start + len(views)],
                                                 self.world.appearance, lookup)
                    start += len(views)
        return images

    def _camera_layout(self, camera: str):
        """A body camera's spec, frame rotation, views at its pose now, and cube lookup (spherical cameras)."""
        spec = self._cameras[camera]
        eye, rotation = self._camera_frame(spec)
        lookup = cube_lookup(spec) if spec.projection == "spherical" else None  # built once per camera, kept
        return spec, rotation, camera_views(spec, eye, rotation, lookup), lookup

    def _views_fit(self, view_lists: list[list]) -> bool:
        """Whether the views of several cameras can be rendered in one call (the engine's buffer); an engine
        that renders view by view need not batch them (False)."""
        return False

    def _read_compound_eyes(self, names: list[str]) -> dict[str, np.ndarray]:
        """Compound eyes ``names`` (M, 2) each: their cube faces rendered in one call in the spectral colouring,
        then each eye's sampling matrix (:mod:`neuronav.senses.compound_eye_views`)."""
        readers, views = [], []
        for name in names:
            eye = self._compound_eyes[name]
            reader = eye_views(eye)
            pos, _, rotation = self._segment_pose(eye.segment)
            frame = rotation @ quat_to_matrix(eye.quat)
            views += reader.views(pos + rotation @ np.asarray(eye.pos_m, float), frame)
            readers.append(reader)
        rendered = self._render_views(views, False, spectral=True)
        sky, out, start = self.world.appearance.sky_green_uv, {}, 0
        for name, reader in zip(names, readers):
            out[name] = reader.values(rendered[start:start + len(reader.faces)], sky)
            start += len(reader.faces)
        return out

    def follow_view(self) -> FollowView:
        """Where the follow camera is now."""
        self._require()
        pos, _, rotation = self._root_pose()
        return follow_view(pos, rotation, self._bounds)

    # -- engine hooks ----------------------------------------------------------------------------------
    def _require(self) -> BodySpec:  # pragma: no cover - every engine implements it
        raise NotImplementedError

    def _load_engine(self, world: World, body: BodySpec) -> None:  # pragma: no cover
        """Build the engine's model of ``world`` and ``body`` (all checks that can refuse them come first)."""
        raise NotImplementedError

    def _reset_engine(self, position: np.ndarray, pose_quat: np.ndarray) -> None:  # pragma: no cover
        """Rest pose, at rest, the root frame at ``position`` (3,) turned by ``pose_quat`` (w, x, y, z)."""
        raise NotImplementedError

    def _raise_root(self, dz_m: float) -> None:  # pragma: no cover
        """Move the root up by ``dz_m``."""
        raise NotImplementedError

    def _penetration_m(self) -> float:  # pragma: no cover
        """How deep the body's deepest geom starts inside the world (<= 0: clear)."""
        raise NotImplementedError

    def _root_pose(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        """The root frame's position (3,), quaternion (4,) (w, x, y, z) and rotation (3, 3)."""
        raise NotImplementedError

    def _segment_pose(self, segment: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        """Segment ``segment``'s frame (as :class:`BodySpec` declares it, joints applied): its position (3,),
        quaternion (4,) (w, x, y, z) and rotation (3, 3), world frame."""
        raise NotImplementedError

    def _root_velocity(self) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
        """The root frame origin's linear (3,) and angular (3,) velocity, world axes."""
        raise NotImplementedError

    def _joint_state(self) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
        raise NotImplementedError

    def _joint_torque(self) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _contact_forces(self) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _contact_loads(self) -> np.ndarray:
        """(C,) N: the magnitude of each contact site's total force in the last physics step. This default
        is the norm of :meth:`_contact_forces`, right for an engine whose contact forces are the last step's
        (PyBullet); an engine that solves them for the current state on demand (MuJoCo) overrides it."""
        return np.linalg.norm(self._contact_forces(), axis=1)

    def _site_positions(self, kind: str) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _set_joint_targets(self, targets: np.ndarray) -> None:  # pragma: no cover
        raise NotImplementedError

    def _queue_force(self, segment: str, point_m: np.ndarray, force_n: np.ndarray) -> None:  # pragma: no cover
        """Push at ``point_m`` (3,) in ``segment``'s frame during the next step call."""
        raise NotImplementedError

    def _render_follow(self, view: FollowView) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _cast_rays(self, origins: np.ndarray, directions: np.ndarray,  # pragma: no cover
                   max_distance_m: float, start_m: np.ndarray, stop_m: np.ndarray) -> np.ndarray:
        """Checked rays (N >= 1, unit directions): first-hit distances (N,) from the origins, inf for none
        within ``max_distance_m``, the body left out; nothing of the world lies on a ray before its
        ``start_m`` (N,) nor after its ``stop_m`` (N,) (an engine may cast over that stretch only)."""
        raise NotImplementedError

    def _camera_frame(self, camera: Camera) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
        """Where a body camera is now: its position (3,) and frame axes as columns (3, 3), world coordinates."""
        raise NotImplementedError

    def _render_views(self, views: list[View],  # pragma: no cover
                      sees_body: bool, spectral: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each view rendered flat-shaded (every surface in its rgba, no lights): a uint8 image (h, w, 3)
        and a bool mask (h, w) of the pixels where nothing was hit (the caller paints the sky there);
        the body is left out unless ``sees_body``. With ``spectral`` the world is drawn as
        :func:`neuronav.senses.compound_eye.spectral_world` draws it (every colour (0, green, UV): the ground,
        its wall and any floor image in ``ground_green_uv``, each object in its ``spectral``)."""
        raise NotImplementedError

    def _turn_scene(self, yaw_rad: float) -> None:  # pragma: no cover
        """Put every world object at its declared pose turned by ``yaw_rad`` about the world z axis."""
        raise NotImplementedError
