"""The PyBullet backend: one articulated body (a :class:`~neuronav.spec.body.BodySpec`) in a :class:`World`.

Design
------
- One DIRECT-mode physics client per instance; every call passes ``physicsClientId`` (no global
  state), so several instances live side by side in one process. ``close()`` disconnects.
- The body is a URDF generated from the spec (:mod:`neuronav.backends.pybullet.urdf`), written to a
  temporary directory that ``close()`` removes. Inertia comes from the file
  (``URDF_USE_INERTIA_FROM_FILE``), i.e. from :meth:`Segment.inertial`, as in every backend.
- ``reset()`` rebuilds the whole simulation (``resetSimulation``, then body, ground, objects): a
  reset leaves no contact caches behind, so the same seed gives bit-identical trajectories, also
  after earlier episodes. The body is created before the world so that PyBullet's contact manifolds
  list the body first; PyBullet flips the contact normal but not the friction directions when it
  reports a pair the other way round, so this order keeps the friction forces' signs right.
- Position control is done here, not by PyBullet's motors: the default velocity motors are
  switched off (``VELOCITY_CONTROL`` with force 0) and every physics step applies, through
  ``TORQUE_CONTROL``, ``torque = kp (target - q) - kd q_dot`` clipped to ``±max_torque_nm`` — the
  same law as the MuJoCo backend. PyBullet integrates these torques (and joint damping)
  explicitly, which is unstable once ``h λ`` passes 2 (λ: the largest eigenvalue of
  ``M⁻¹ (kd + damping)``; MuJoCo's implicit integrators do not have this limit). ``load``
  estimates that margin at the rest pose and, unless ``substeps`` is given, runs as many PyBullet
  steps of ``timestep / substeps`` per ``timestep`` as keep it below 0.7 (said in
  :attr:`warnings`). ``step(n)`` always advances ``n * timestep``; control, adhesion and applied
  forces act at every PyBullet step.
- PyBullet clamps every velocity coordinate (m/s, rad/s) at the body's ``maxJointVelocity``, 100 by
  default; here it is 500, above anything valid joint targets do (the head and the antennae it whips
  pass 100 rad/s under bang-bang targets on MuJoCo too). A state that is not finite, or a velocity at
  that clamp, is taken as divergence and raises :class:`SimulationError`.
- Ground: ``flat`` is a plane; ``uneven`` a ``GEOM_HEIGHTFIELD`` from :meth:`Ground.heights_m`
  (PyBullet centres a heightfield at the midpoint of its lowest and highest sample, so the field is
  lifted by that midpoint to make its heights equal :meth:`Ground.height_at` at the samples; between
  samples PyBullet uses two triangles per cell, the spec bilinear interpolation) over a plane at
  z = 0 for outside it; ``wall`` a plane and a static box whose face is at x = ``wall_distance_m``.
  Objects are static primitives; a cone is the convex hull of a 32-sided pyramid (collision and
  looks), since PyBullet has no cone.
- Friction: PyBullet multiplies the two frictions of a contact (MuJoCo takes the larger); with the
  usual ground friction 1 the result is the same.
- PyBullet has no joint armature (rotor inertia); by default it is added to the segment's link
  inertia as a thin rotor disc on the joint axis, which the joint then feels as in MuJoCo (parent
  joints and the whole body feel the disc too). Light segments with stiff gains need it to stay
  stable. Self-collisions are off (PyBullet's default for URDFs).
- Contact sites: PyBullet reports contacts per link, so each contact geom has a link of its own
  (:mod:`neuronav.backends.pybullet.urdf`); ``contact_force`` sums normal and both friction forces of that
  link's contact points: the force on the geom, world frame. Adhesion presses each touching
  contact geom (a contact point within 1 mm) into the surface along minus the mean contact normal,
  at the geom's centre, every PyBullet step.
- ``reset`` puts the root ``spawn_height_m`` above the terrain under it; if a geom would then start
  inside the terrain (rough ground), the body is lifted just clear of it (the shared rule of
  :class:`~neuronav.engine.articulated.ArticulatedBackend`; said once in :attr:`notes`), because a PyBullet
  heightfield is a surface that pushes a sunken geom down. Here the overlap is measured from the
  geoms' extents against :meth:`Ground.height_at`.
- Speed: the control law runs in Python at every PyBullet step, so that step does one batched joint
  read (``getJointStates``), one batched torque command (``setJointMotorControlArray``) and a few
  numpy operations on (J,) arrays; the root's pose is read without scipy; contact points are only
  queried when ``contact_force`` is read or adhesion is on.
- The floor in the physics client looks as ``World.appearance`` says (plain ``ground_rgb``, or its
  checker as one texture over ``Ground.size_m``, squares aligned with the world axes) so that motion
  shows in videos, as on MuJoCo; a world's odour trails are drawn over it (:mod:`neuronav.senses.trail_floor`;
  :mod:`neuronav.backends.pybullet.scene`), and body cameras paint them on their floor pixels.
- What PyBullet's C code prints while loading the URDF (``b3Warning``) is collected in
  :attr:`warnings`, as are the notes above and the reason of a divergence.
- Body cameras follow :mod:`neuronav.senses.vision` (planar views, spherical ones from cube faces, the sky,
  the grey sensor: :class:`~neuronav.engine.articulated.ArticulatedBackend`); this backend renders each
  view flat-shaded with TinyRenderer (:mod:`neuronav.backends.pybullet.camera`) in a second DIRECT client
  that holds only the world's looks (:func:`neuronav.backends.pybullet.scene.build_vision_world`: the ground
  reaching ``vision.GROUND_REACH_M``), built on the first body-camera render: the body is not in
  the picture, and a render does not pay for its triangles. A camera with ``sees_body`` renders
  there too, with a copy of the body (loaded on first use) put in the physics body's pose; it is
  parked 10 km under the ground otherwise. Compound eyes draw their own copies of the objects there, coarser
  (:func:`neuronav.backends.pybullet.scene.build_eye_objects`, as MuJoCo's compound eyes draw them), hidden
  from the cameras, and the cameras' hidden from them. ``set_scene_yaw`` moves the objects in both clients
  (:func:`neuronav.backends.pybullet.scene.place_objects`; in the physics client they keep colliding), and a
  reset, which rebuilds the physics client, puts them back at the current scene yaw.
- ``"follow"`` renders :func:`neuronav.engine.articulated.follow_view` in the physics client, lit as
  TinyRenderer lights it, with the World's sky where nothing was drawn.

Everything engine-free (sensor table, checks, reset lifting, ``apply_force``'s rule, the follow
framing) is in :class:`neuronav.engine.articulated.ArticulatedBackend`; this module only talks to PyBullet,
with :mod:`neuronav.backends.pybullet.scene` (ground, objects), :mod:`neuronav.backends.pybullet.camera` (rendering),
:mod:`neuronav.backends.pybullet.urdf` (the body) and :mod:`neuronav.backends.pybullet.engine` (the import, C output).
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Sequence

import numpy as np

from neuronav.backends.pybullet.camera import ObjectCulling, render_flat, render_follow, render_spectral, spectral_lut
from neuronav.backends.pybullet.engine import EngineOutput, configure_client, pb
from neuronav.backends.pybullet.scene import (
    build_eye_objects,
    build_ground,
    build_object,
    build_ray_world,
    build_vision_world,
    exact_rgba,
    place_objects,
)
from neuronav.backends.pybullet.urdf import body_to_urdf, find_geom
from neuronav.engine.articulated import ArticulatedBackend, FollowView
from neuronav.engine.backend import quat_product
from neuronav.errors import ConfigError, SimulationError
from neuronav.senses.vision import View, check_camera
from neuronav.spec.body import BodySpec, Camera, quat_to_matrix
from neuronav.spec.world import World

GRAVITY_M_S2 = -9.81
SAFE_MARGIN = 0.7  # keep explicit joint control this far inside its stability limit (1)
MAX_SUBSTEPS = 64
# PyBullet's btMultiBody clamps every velocity coordinate (m/s, rad/s) at its maxJointVelocity, 100 unless
# set. Valid in-bounds joint targets move the ant faster than that: under bang-bang targets held 80 ms the
# head swings at about 67 rad/s and its 10 N·m antenna motors alone drive the antennae past 100 rad/s (105 on
# MuJoCo, which has no clamp). The clamp is set above any such motion (10,000 control steps of such targets
# never reach it), so that it only ever stops an explosion (tests/cross_backend/test_joint_actions_stay_finite.py).
VELOCITY_CLAMP = 500.0
DIVERGED_VELOCITY = 0.99 * VELOCITY_CLAMP
TOUCH_DISTANCE_M = 1e-3  # a contact point this close (or penetrating) counts as touching, for adhesion
# Adhesive pads in worlds with adhesion: PyBullet's contacts are otherwise rigid (under a millimetre of
# give), MuJoCo's default soft contacts let a claw sink 8-12 mm under 120 N (about 1.2e4 N/m). Giving
# the pads' links that compliance keeps a loaded claw in contact while the body shifts a few
# millimetres, as on MuJoCo; without it every pad lets go at once when the legs change over.
PAD_STIFFNESS_N_M = 1.2e4
PAD_DAMPING_N_S_M = 500.0
# Where the vision client's copy of the body waits while cameras must not see it: under the ground
# and past the far plane.
PARKED_POS_M = (0.0, 0.0, -1e4)
# cast_rays: rays per rayTestBatch call (PyBullet's batch limit is larger).
RAY_BATCH = 8192

def _xyzw(quat_wxyz) -> list[float]:
    w, x, y, z = quat_wxyz
    return [float(x), float(y), float(z), float(w)]


def _rot(quat_xyzw) -> np.ndarray:
    x, y, z, w = quat_xyzw
    return quat_to_matrix((w, x, y, z))


def _matrix_to_xyzw(r: np.ndarray) -> list[float]:
    from scipy.spatial.transform import Rotation

    return [float(v) for v in Rotation.from_matrix(r).as_quat()]


class PybulletBackend(ArticulatedBackend):
    """One articulated body in PyBullet; implements the backend protocol (see docs/architecture.md).

    Parameters
    ----------
    timestep_s : float
        Physics step (s).
    solver_iterations : int
        Constraint-solver iterations per step.
    armature_as_inertia : bool
        PyBullet has no joint armature: add it to the link inertia as a rotor disc on the joint axis
        (default), or ignore it (see :func:`neuronav.backends.pybullet.urdf.body_to_urdf`).
    substeps : int or None
        PyBullet steps per ``timestep_s``; None (default) picks the fewest that keep explicit joint
        control stable for the loaded body (see the module docstring).

    Attributes
    ----------
    warnings : list of str
        Engine output and notes seen since ``load``: armature handling, substeps, a lifted spawn,
        PyBullet's own warnings, the reason of a divergence.
    """

    engine = "pybullet"
    # Rays are cast in a client of the world's surfaces alone (_ray_client), where Bullet's own broadphase costs
    # less than the shared bounds test: 160 sky rays among 40 trees, a read 0.29-0.35 ms uncut against 0.34-0.35.
    cull_rays = False

    def __init__(self, timestep_s: float = 0.002, solver_iterations: int = 50, armature_as_inertia: bool = True,
                 substeps: int | None = None) -> None:
        super().__init__(timestep_s)
        if not (isinstance(solver_iterations, int) and solver_iterations > 0):
            raise ConfigError(f"pybullet backend: solver_iterations must be a positive int, got {solver_iterations!r}")
        if substeps is not None and not (isinstance(substeps, int) and 1 <= substeps <= MAX_SUBSTEPS):
            raise ConfigError(f"pybullet backend: substeps must be None (automatic) or an int in 1..{MAX_SUBSTEPS}, "
                              f"got {substeps!r}")
        self._requested_substeps = substeps
        self._substeps = substeps or 1
        self._iterations = solver_iterations
        self._armature_as_inertia = bool(armature_as_inertia)
        self._client: int | None = None
        self._tmpdir: tempfile.TemporaryDirectory | None = None
        self._inner_steps = 0
        self._pending: list[tuple[int, np.ndarray, np.ndarray]] = []
        self._objects: list[int] = []
        self._vision: int | None = None  # the render-only client (see the module doc)
        self._eye_objects: list[int] = []  # the compound eyes' copies of the objects there
        self._eye_culling: ObjectCulling | None = None
        self._rays: int | None = None  # the client rays are cast in (_ray_client)
        self._ray_objects: list[int] = []

    # -- protocol: set-up --------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return self._inner_steps / self._substeps * self._timestep_s

    @property
    def substeps(self) -> int:
        """PyBullet steps per ``timestep`` (chosen at ``load`` for stability unless given)."""
        return self._substeps

    @property
    def client_id(self) -> int | None:
        """The PyBullet physics client of this instance (None before ``load`` and after ``close``)."""
        return self._client

    def load(self, world: World, bodies: Sequence[BodySpec]) -> None:
        """Build ``world`` with exactly one :class:`BodySpec`, ``reset()``, then choose the substeps.

        Raises
        ------
        ConfigError
            When ``bodies`` is not exactly one BodySpec, or the spec cannot be expressed.
        """
        super().load(world, bodies)
        self._choose_substeps()

    def _load_engine(self, world: World, body: BodySpec) -> None:
        # Everything that can reject the input comes before any state changes (the World checked its objects).
        urdf = body_to_urdf(body, armature_as_inertia=self._armature_as_inertia)
        for site in body.sites:
            if site.kind == "contact" and site.geom:
                find_geom(body, site.segment, site.geom)
        for camera in body.cameras:
            check_camera(camera)
        self._close_vision()  # a new world: the render-only and ray clients are rebuilt when next needed
        self.body, self.world, self._urdf = body, world, urdf
        if self._tmpdir is None:
            self._tmpdir = tempfile.TemporaryDirectory(prefix="neuronav_pybullet_")
        self._urdf_path = os.path.join(self._tmpdir.name, "body.urdf")
        with open(self._urdf_path, "w") as handle:
            handle.write(self._urdf.text)
        if self._client is None:
            self._client = pb.connect(pb.DIRECT)
            if self._client < 0:
                raise SimulationError("pybullet backend: could not start a DIRECT physics client")
        self.warnings = []
        self.notes = []
        armature = [j.name for j in body.joints if j.armature > 0]
        if armature:
            how = ("added to the link inertia as a rotor disc on the joint axis (felt by the parents too)"
                   if self._armature_as_inertia else "ignored")
            self.notes.append(f"pybullet has no joint armature; {how} for {len(armature)} joints "
                                 f"({', '.join(armature[:4])}{', ...' if len(armature) > 4 else ''})")
        self._joints = body.joints
        self._kp = np.array([j.kp for j in self._joints])
        self._kd = np.array([j.kd for j in self._joints])
        self._max_torque = np.array([j.max_torque_nm for j in self._joints])
        self._contact_sites = body.sites_of_kind("contact")
        self._adhesive = [site.adhesive for site in self._contact_sites]
        self._substeps = self._requested_substeps or 1

    def _reset_engine(self, position: np.ndarray, pose_quat: np.ndarray) -> None:
        """Rebuild the simulation (no contact caches survive: same calls, same trajectory) and place the body."""
        body = self.body
        self._build()
        cid = self._client
        for index, joint in zip(self._joint_index, self._joints):
            pb.resetJointState(self._robot, index, joint.rest_rad, 0.0, physicsClientId=cid)
        self._frame_pos, self._frame_rot = np.array(position, float), quat_to_matrix(pose_quat)
        self._place_base(self._frame_pos, self._frame_rot)
        pb.resetBaseVelocity(self._robot, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
        self._targets = body.rest_pose_rad().astype(float)
        self._torque = np.zeros(len(self._joints))
        self._pending = []
        self._inner_steps = 0

    def _raise_root(self, dz_m: float) -> None:
        self._frame_pos[2] += dz_m
        self._place_base(self._frame_pos, self._frame_rot)

    def _set_joint_targets(self, targets: np.ndarray) -> None:
        self._targets = targets

    # -- protocol: running -------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` timesteps (``n * substeps`` PyBullet steps) with position control, adhesion and
        the forces given to :meth:`apply_force` since the last call, all applied at every PyBullet step.

        Raises
        ------
        SimulationError
            When the state stops being finite or a velocity reaches PyBullet's clamp.
        """
        self._require()
        n = self._check_steps(n)
        cid, robot, joints = self._client, self._robot, self._joint_index
        control = bool(self._joints)
        adhesion = self.world.adhesion_n
        kp, kd, limit, targets = self._kp, self._kd, self._max_torque, self._targets
        torque, TORQUE_CONTROL = self._torque, pb.TORQUE_CONTROL  # noqa: N806 - a local alias of the constant
        for _ in range(n * self._substeps):
            if control:
                q, qd, _, _ = zip(*pb.getJointStates(robot, joints, physicsClientId=cid))
                q, qd = np.array(q), np.array(qd)
                fastest = np.abs(qd).max()
                if not (fastest < DIVERGED_VELOCITY and np.isfinite(q).all()):  # NaN fails the comparison too
                    self._joint_diverged(q, qd)
                torque = np.minimum(np.maximum(kp * (targets - q) - kd * qd, -limit), limit)
                pb.setJointMotorControlArray(robot, joints, TORQUE_CONTROL, forces=torque, physicsClientId=cid)
            if self._pending:
                frames = self._frames(sorted({link for link, _, _ in self._pending}))
                for link, local, force in self._pending:
                    pos, rot = frames[link]
                    pb.applyExternalForce(robot, link, force.tolist(), (pos + rot @ local).tolist(),
                                          pb.WORLD_FRAME, physicsClientId=cid)
            if adhesion > 0:
                self._apply_adhesion(adhesion)
            pb.stepSimulation(physicsClientId=cid)
            self._inner_steps += 1
        if control and n:
            self._torque = torque
        self._pending = []
        self._check_base()

    def _joint_diverged(self, q: np.ndarray, qd: np.ndarray) -> None:
        if not (np.isfinite(q).all() and np.isfinite(qd).all()):
            self._diverged("a joint angle or velocity is not finite")
        worst = int(np.argmax(np.abs(qd)))
        self._diverged(f"joint {self._joints[worst].name!r} reached PyBullet's velocity clamp ({qd[worst]:.1f} rad/s)")

    def _queue_force(self, segment: str, point_m: np.ndarray, force_n: np.ndarray) -> None:
        self._pending.append((self._link_index[self._urdf.segment_link[segment]], point_m, force_n))

    # -- cameras ------------------------------------------------------------------------------------
    def _camera_frame(self, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
        link = self._link_index[self._urdf.segment_link[camera.segment]]
        pos, rot = self._frames([link])[link]
        return pos + rot @ np.asarray(camera.pos_m, float), rot @ quat_to_matrix(camera.quat)

    def _render_views(self, views: list[View], sees_body: bool,
                      spectral: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
        cid = self._vision_client()
        self._show_body(sees_body)
        if spectral:
            # The compound eyes draw the objects' coarse copies (scene.build_eye_objects), the cameras' hidden.
            if self._eye_culling is None:
                self._eye_objects = build_eye_objects(cid, self.world)
                place_objects(cid, self._eye_objects, self.world.objects, self._scene_yaw_rad)
                self._eye_culling = ObjectCulling(cid, self._eye_objects, self.world.objects, hidden=True)
                self._vision_spectral = spectral_lut(self.world, self._vision_ground, self._eye_objects)
            self._vision_culling.hide_all()
            culling = self._eye_culling
            culling.yaw_rad = self._scene_yaw_rad
            if len(self._vision_ground) > 1:  # a heightfield: TinyRenderer draws the ground
                return render_spectral(cid, views, self._vision_spectral, culling)
            # A flat floor: hidden while the faces are drawn, its pixels drawn from their rays (render_spectral).
            floor = self._vision_ground[0]
            pb.changeVisualShape(floor, -1, rgbaColor=[0.0, 0.0, 0.0, 0.0], physicsClientId=cid)
            try:
                return render_spectral(cid, views, self._vision_spectral, culling, (floor, self._vision_floor_z_m),
                                       only_objects=not sees_body and self.world.ground.kind != "wall")
            finally:
                pb.changeVisualShape(floor, -1, rgbaColor=exact_rgba(self.world.appearance.ground_rgb),
                                     physicsClientId=cid)
        if self._eye_culling is not None:
            self._eye_culling.hide_all()
        self._vision_culling.yaw_rad = self._scene_yaw_rad
        return [render_flat(cid, view, self.world, self._vision_ground, self._vision_floor_z_m, self._vision_culling)
                for view in views]

    def _turn_scene(self, yaw_rad: float) -> None:
        place_objects(self._client, self._objects, self.world.objects, yaw_rad)
        if self._rays is not None:
            place_objects(self._rays, self._ray_objects, self.world.objects, yaw_rad)
        if self._vision is not None:
            place_objects(self._vision, self._vision_objects, self.world.objects, yaw_rad)
            if self._eye_objects:
                place_objects(self._vision, self._eye_objects, self.world.objects, yaw_rad)

    def _vision_client(self) -> int:
        """The render-only client with the world's looks (built on first use, at the current scene yaw)."""
        if self._vision is None:
            cid = pb.connect(pb.DIRECT)
            if cid < 0:
                raise SimulationError("pybullet backend: could not start a DIRECT client for the cameras")
            self._vision, self._vision_body = cid, None
            self._vision_ground, self._vision_floor_z_m, self._vision_objects = build_vision_world(cid, self.world)
            place_objects(cid, self._vision_objects, self.world.objects, self._scene_yaw_rad)
            self._vision_culling = ObjectCulling(cid, self._vision_objects, self.world.objects)
            # The compound eyes' coarse copies of the objects, their culling and their colours by body
            # (spectral_lut), made on their first read.
            self._eye_objects, self._eye_culling, self._vision_spectral = [], None, None
        return self._vision

    def _show_body(self, shown: bool) -> None:
        """Put the vision client's copy of the body where the body is (loading it once), or park it."""
        cid = self._vision
        if not shown:
            if self._vision_body is not None and self._vision_body_shown:
                pb.resetBasePositionAndOrientation(self._vision_body, PARKED_POS_M, [0.0, 0.0, 0.0, 1.0],
                                                   physicsClientId=cid)
                self._vision_body_shown = False
            return
        if self._vision_body is None:
            flags = pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_MAINTAIN_LINK_ORDER
            with EngineOutput([]):
                self._vision_body = pb.loadURDF(self._urdf_path, useFixedBase=self._urdf.fixed_base, flags=flags,
                                                physicsClientId=cid)
        copy, robot = self._vision_body, self._robot
        pos, orn = pb.getBasePositionAndOrientation(robot, physicsClientId=self._client)
        pb.resetBasePositionAndOrientation(copy, pos, orn, physicsClientId=cid)
        if self._joint_index:
            angles = [state[0] for state in pb.getJointStates(robot, self._joint_index, physicsClientId=self._client)]
            for index, angle in zip(self._joint_index, angles):
                pb.resetJointState(copy, index, angle, 0.0, physicsClientId=cid)
        self._vision_body_shown = True

    def _close_vision(self) -> None:
        """Disconnect the render-only and the ray clients (rebuilt for the next world when needed)."""
        for client in (self._vision, self._rays):
            if client is not None:
                try:
                    pb.disconnect(physicsClientId=client)
                except pb.error:  # already gone
                    pass
        self._vision = self._rays = None

    def model_summary(self) -> dict:
        """What PyBullet built, read back from the engine: for comparing backends on one spec.

        Returns
        -------
        dict
            ``segment_mass_kg`` {segment: kg} (links split off for contact geoms are added back to
            their segment), ``joint_range_rad`` {joint: (low, high)}, ``joint_axis_world``
            {joint: unit (3,) at the current pose}, ``site_pos_m`` {site: (3,) world position}.
        """
        body = self._require()
        cid, robot = self._client, self._robot
        owner = {link: segment for (segment, _), link in self._urdf.geom_link.items()}
        owner.update({link: segment for segment, link in self._urdf.segment_link.items()})
        masses = {segment.name: 0.0 for segment in body.segments}
        for link, index in self._link_index.items():
            masses[owner[link]] += pb.getDynamicsInfo(robot, index, physicsClientId=cid)[0]
        frames = self._frames(sorted(set(self._link_index.values())))
        ranges, axes = {}, {}
        for joint, index in zip(self._joints, self._joint_index):
            info = pb.getJointInfo(robot, index, physicsClientId=cid)
            ranges[joint.name] = (float(info[8]), float(info[9]))
            # The joint axis is given in the child link's frame, which is the joint frame here.
            axis = frames[index][1] @ np.asarray(info[13], float)
            axes[joint.name] = axis / np.linalg.norm(axis)
        sites = list(body.sites)
        positions = self._positions_of(sites)
        return {"segment_mass_kg": masses, "joint_range_rad": ranges, "joint_axis_world": axes,
                "site_pos_m": {site.name: positions[i] for i, site in enumerate(sites)}}

    def raw_step(self, n: int = 1) -> None:
        """Call ``stepSimulation`` ``n`` times (each ``timestep / substeps``) with no control, adhesion or
        checks (for benchmarks)."""
        self._require()
        cid = self._client
        for _ in range(int(n)):
            pb.stepSimulation(physicsClientId=cid)
        self._inner_steps += int(n)

    def close(self) -> None:
        """Disconnect the physics, camera and ray clients and delete the temporary URDF."""
        self._close_vision()
        if self._client is not None:
            try:
                pb.disconnect(physicsClientId=self._client)
            except pb.error:  # already gone
                pass
            self._client = None
        if self._tmpdir is not None:
            self._tmpdir.cleanup()
            self._tmpdir = None
        self.body = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - never raise from a finaliser
            pass

    # -- building ----------------------------------------------------------------------------------
    def _build(self) -> None:
        """(Re)create the simulation: parameters, body first, then ground and objects."""
        cid = self._client
        configure_client(cid, self._timestep_s, self._substeps, self._iterations, GRAVITY_M_S2)
        flags = pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_MAINTAIN_LINK_ORDER
        with EngineOutput(self.warnings):
            self._robot = pb.loadURDF(self._urdf_path, useFixedBase=self._urdf.fixed_base, flags=flags,
                                      physicsClientId=cid)
        self._index_links()
        pb.changeDynamics(self._robot, -1, maxJointVelocity=VELOCITY_CLAMP, physicsClientId=cid)  # the whole body
        if self.world.adhesion_n > 0:
            pads = {link for site, (link, _) in zip(self._contact_sites, self._contact_links) if site.adhesive}
            for link in sorted(pads):
                pb.changeDynamics(self._robot, link, contactStiffness=PAD_STIFFNESS_N_M,
                                  contactDamping=PAD_DAMPING_N_S_M, physicsClientId=cid)
        # Switch PyBullet's default velocity motors off: torques are applied by step().
        movable = [i for i in range(pb.getNumJoints(self._robot, physicsClientId=cid))
                   if pb.getJointInfo(self._robot, i, physicsClientId=cid)[2] != pb.JOINT_FIXED]
        if movable:
            pb.setJointMotorControlArray(self._robot, movable, pb.VELOCITY_CONTROL, forces=[0.0] * len(movable),
                                         physicsClientId=cid)
        build_ground(cid, self.world, self._tmpdir.name)
        self._objects = [build_object(cid, self.world, obj) for obj in self.world.objects]
        yaw_rad = getattr(self, "_scene_yaw_rad", 0.0)  # the scene's turn survives a reset
        if yaw_rad:
            place_objects(cid, self._objects, self.world.objects, yaw_rad)

    def _index_links(self) -> None:
        cid, robot = self._client, self._robot
        self._link_index = {self._urdf.links[0].name: -1}
        joint_index = {}
        for i in range(pb.getNumJoints(robot, physicsClientId=cid)):
            info = pb.getJointInfo(robot, i, physicsClientId=cid)
            joint_index[info[1].decode()] = i
            self._link_index[info[12].decode()] = i
        self._joint_index = [joint_index[j.name] for j in self._joints]
        dynamics = pb.getDynamicsInfo(robot, -1, physicsClientId=cid)
        self._base_inertial_pos = np.array(dynamics[3], float)
        self._base_inertial_rot = _rot(dynamics[4])
        x, y, z, w = dynamics[4]
        self._base_inertial_conj = np.array([w, -x, -y, -z]) / np.linalg.norm(dynamics[4])
        # Contact sites: (link, point in the link frame) of the geom each one reports.
        self._contact_links = []
        for site in self._contact_sites:
            if site.geom:
                segment, index = find_geom(self.body, site.segment, site.geom)
                link = self._urdf.link(self._urdf.geom_link[(segment, index)])
                geom = self.body.segment(segment).geoms[index]
                point = quat_to_matrix(link.quat).T @ (np.asarray(geom.pos_m) - np.asarray(link.pos_m))
            else:
                link = self._urdf.link(self._urdf.segment_link[site.segment])
                point = np.asarray(site.pos_m, float)
            self._contact_links.append((self._link_index[link.name], point))

    def _stability_margin(self, step_s: float) -> tuple[float, list[str]]:
        """Stability margin of explicit joint control at ``step_s`` (>= 1: unstable) and the joints involved.

        Semi-implicit Euler on ``M q'' = -K q - D q'`` is stable while ``h λ_D < 2`` and
        ``2 h λ_D + h² λ_K < 4``, with λ the largest eigenvalues of ``M⁻¹D`` and ``M⁻¹K`` (D: kd plus
        joint damping, K: kp; M: the joint-space inertia at the current pose, free base included).
        The margin is the larger of ``h λ_D / 2`` and ``(2 h λ_D + h² λ_K) / 4``.
        """
        cid, robot = self._client, self._robot
        count = pb.getNumJoints(robot, physicsClientId=cid)
        movable = [i for i in range(count) if pb.getJointInfo(robot, i, physicsClientId=cid)[2] != pb.JOINT_FIXED]
        angles = [pb.getJointState(robot, i, physicsClientId=cid)[0] for i in movable]
        mass = np.array(pb.calculateMassMatrix(robot, angles, physicsClientId=cid))
        offset = mass.shape[0] - len(movable)  # the 6 base coordinates come first for a floating base
        damping = np.zeros(mass.shape[0])
        stiffness = np.zeros(mass.shape[0])
        for joint, index in zip(self._joints, self._joint_index):
            k = offset + movable.index(index)
            damping[k], stiffness[k] = joint.kd + joint.damping, joint.kp
        inverse = np.linalg.inv(mass)
        inverse = (inverse + inverse.T) / 2.0

        def largest(gains):  # eigen of M⁻¹G via the symmetric G^½ M⁻¹ G^½
            root = np.sqrt(gains)
            values, vectors = np.linalg.eigh(root[:, None] * inverse * root[None, :])
            return values[-1], np.abs(vectors[:, -1])

        lambda_d, mode = largest(damping)
        lambda_k, _ = largest(stiffness)
        margin = max(step_s * lambda_d / 2.0, (2.0 * step_s * lambda_d + step_s**2 * lambda_k) / 4.0)
        names = {offset + movable.index(index): joint.name for joint, index in zip(self._joints, self._joint_index)}
        involved = [names[k] for k in np.argsort(mode)[::-1][:3] if k in names and mode[k] > 0.1]
        return float(margin), involved

    def _choose_substeps(self) -> None:
        """Pick PyBullet steps per timestep so that explicit joint control stays stable (see the module doc)."""
        if not self._joints:
            return
        dt = self._timestep_s
        margin, involved = self._stability_margin(dt)
        wanted = max(1, math.ceil(margin / SAFE_MARGIN))
        if self._requested_substeps is not None:
            inner_margin = margin / self._requested_substeps  # margin scales about linearly with the step
            if inner_margin > SAFE_MARGIN:
                self.warnings.append(
                    f"explicit joint control is near or past its stability limit ({inner_margin:.2f}, 1 = unstable) "
                    f"with {self._requested_substeps} substep(s) of {dt / self._requested_substeps:g} s, in the "
                    f"mode of {', '.join(involved)}; automatic substeps would use {min(wanted, MAX_SUBSTEPS)}")
            return
        if wanted > MAX_SUBSTEPS:
            self.warnings.append(
                f"explicit joint control would need {wanted} substeps per {dt:g} s step to be stable "
                f"(margin {margin:.1f} in the mode of {', '.join(involved)}); using {MAX_SUBSTEPS}: lower kd/kp, "
                "add armature, or lower timestep_s")
            wanted = MAX_SUBSTEPS
        elif wanted > 1:
            self.notes.append(
                f"running {wanted} PyBullet steps of {dt / wanted:g} s per {dt:g} s step: explicit joint "
                f"control would be unstable at {dt:g} s (margin {margin:.2f}, 1 = unstable; mode of "
                f"{', '.join(involved)})")
        if wanted > 1:
            self._substeps = wanted
            self.reset()

    def _place_base(self, frame_pos: np.ndarray, frame_rot: np.ndarray) -> None:
        """Put the root's frame (not its centre of mass, which is what PyBullet places) at a pose."""
        com_pos = frame_pos + frame_rot @ self._base_inertial_pos
        com_rot = frame_rot @ self._base_inertial_rot
        pb.resetBasePositionAndOrientation(self._robot, com_pos.tolist(), _matrix_to_xyzw(com_rot),
                                           physicsClientId=self._client)

    def _penetration_m(self) -> float:
        """How far the lowest geom dips below the terrain under its footprint (<= 0: clear)."""
        link_of = {name: index for name, index in self._link_index.items()}
        frames = self._frames(sorted(set(link_of.values())))
        worst = -np.inf
        for link in self._urdf.links:
            pos, rot = frames[link_of[link.name]]
            to_link = quat_to_matrix(link.quat).T
            segment = self.body.segment(link.segment)
            for index in link.geoms:
                geom = segment.geoms[index]
                centre = pos + rot @ (to_link @ (np.asarray(geom.pos_m) - np.asarray(link.pos_m)))
                axes = rot @ to_link @ quat_to_matrix(geom.quat)
                reach = _geom_reach(geom, axes)  # half-extent of the geom along world x, y, z
                xs = np.linspace(centre[0] - reach[0], centre[0] + reach[0], 3)
                ys = np.linspace(centre[1] - reach[1], centre[1] + reach[1], 3)
                terrain = self.world.ground.height_at(*np.meshgrid(xs, ys)).max()
                worst = max(worst, terrain - (centre[2] - reach[2]))
        return float(worst)

    # -- reading -----------------------------------------------------------------------------------
    def _frames(self, links) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """World pose (position, rotation matrix) of the URDF frame of each link index (-1: base)."""
        cid, robot = self._client, self._robot
        frames = {}
        others = [k for k in links if k >= 0]
        if -1 in links:
            com_pos, com_orn = pb.getBasePositionAndOrientation(robot, physicsClientId=cid)
            rot = _rot(com_orn) @ self._base_inertial_rot.T
            frames[-1] = (np.asarray(com_pos) - rot @ self._base_inertial_pos, rot)
        if others:
            states = pb.getLinkStates(robot, others, computeForwardKinematics=1, physicsClientId=cid)
            for k, state in zip(others, states):
                frames[k] = (np.asarray(state[4], float), _rot(state[5]))
        return frames

    def _root_pose(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        com_pos, com_orn = pb.getBasePositionAndOrientation(self._robot, physicsClientId=self._client)
        x, y, z, w = com_orn
        quat = quat_product(np.array([w, x, y, z]), self._base_inertial_conj)
        rot = quat_to_matrix(quat)
        return np.asarray(com_pos) - rot @ self._base_inertial_pos, quat, rot

    def _segment_pose(self, segment: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The segment's frame: its URDF link's frame (the one cameras sit in, :meth:`_frames`)."""
        link = self._link_index[self._urdf.segment_link[segment]]
        if link == -1:
            return self._root_pose()
        state = pb.getLinkState(self._robot, link, computeForwardKinematics=1, physicsClientId=self._client)
        x, y, z, w = state[5]
        return np.asarray(state[4], float), np.array([w, x, y, z], float), _rot(state[5])

    def _cast_rays(self, origins: np.ndarray, directions: np.ndarray, max_distance_m: float,
                   start_m: np.ndarray, stop_m: np.ndarray) -> np.ndarray:
        """``rayTestBatch`` in the ray client (:meth:`_ray_client`: the world's collision shapes, no body, so the
        body never blocks a ray), each ray from its ``start_m`` to its ``stop_m`` only: a long ray is tested
        against every object whose box it crosses, even past its first hit. In the physics client the same rays
        cost 3 to 4 times as much (they start among the body's links, which Bullet visits even masked out: 160
        sky rays from the ant's head among 40 trees, 0.86 against 0.21 ms)."""
        cid = self._ray_client()
        distances = np.full(origins.shape[0], np.inf)
        for first in range(0, origins.shape[0], RAY_BATCH):
            rows = slice(first, first + RAY_BATCH)
            begin = origins[rows] + start_m[rows, None] * directions[rows]
            end = origins[rows] + stop_m[rows, None] * directions[rows]
            results = pb.rayTestBatch(begin.tolist(), end.tolist(), physicsClientId=cid)
            hit = np.array([result[0] >= 0 for result in results], dtype=bool)
            along = start_m[rows] + np.array([result[2] for result in results]) * (stop_m[rows] - start_m[rows])
            distances[rows] = np.where(hit, along, np.inf)
        return distances

    def _ray_client(self) -> int:
        """The client rays are cast in: the world's collision shapes alone (built on the first cast, at the
        current scene yaw; :func:`neuronav.backends.pybullet.scene.build_ray_world`)."""
        if self._rays is None:
            cid = pb.connect(pb.DIRECT)
            if cid < 0:
                raise SimulationError("pybullet backend: could not start a DIRECT client for ray tests")
            self._rays, self._ray_objects = cid, build_ray_world(cid, self.world)
            place_objects(cid, self._ray_objects, self.world.objects, self._scene_yaw_rad)
        return self._rays

    def _root_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        cid, robot = self._client, self._robot
        _, com_orn = pb.getBasePositionAndOrientation(robot, physicsClientId=cid)
        linvel, angvel = pb.getBaseVelocity(robot, physicsClientId=cid)
        offset = _rot(com_orn) @ self._base_inertial_rot.T @ self._base_inertial_pos
        angvel = np.asarray(angvel, float)
        # The COM moves at linvel; the root frame's origin sits at -offset from it.
        return np.asarray(linvel, float) + np.cross(angvel, -offset), angvel

    def _joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        q, qd, _, _ = zip(*pb.getJointStates(self._robot, self._joint_index, physicsClientId=self._client))
        return np.array(q), np.array(qd)

    def _joint_torque(self) -> np.ndarray:
        return self._torque

    def _contact_points(self) -> dict[int, list]:
        """The body's contact points (one PyBullet call), by the body's link (the body is always side A)."""
        by_link: dict[int, list] = {}
        for point in pb.getContactPoints(bodyA=self._robot, physicsClientId=self._client):
            by_link.setdefault(point[3], []).append(point)
        return by_link

    def _contact_forces(self) -> np.ndarray:
        """(C, 3) total contact force on each contact site's geom, world frame (N)."""
        forces = np.zeros((len(self._contact_links), 3))
        by_link = self._contact_points()
        for row, (link, _) in enumerate(self._contact_links):
            for point in by_link.get(link, ()):
                forces[row] += (point[9] * np.asarray(point[7]) + point[10] * np.asarray(point[11])
                                + point[12] * np.asarray(point[13]))
        return forces

    def _site_positions(self, kind: str) -> np.ndarray:
        return self._positions_of(self.body.sites_of_kind(kind))

    def _positions_of(self, sites) -> np.ndarray:
        if not sites:
            return np.zeros((0, 3))
        links = [self._link_index[self._urdf.segment_link[s.segment]] for s in sites]
        frames = self._frames(sorted(set(links)))
        return np.array([frames[k][0] + frames[k][1] @ np.asarray(s.pos_m, float) for k, s in zip(links, sites)])

    # -- stepping helpers --------------------------------------------------------------------------
    def _apply_adhesion(self, adhesion_n: float) -> None:
        """Press every touching adhesive geom into the surface it touches (along minus the contact normal)
        with its fraction of ``adhesion_n``."""
        cid, robot = self._client, self._robot
        if not any(a and f > 0 for a, f in zip(self._adhesive, self._adhesion_scale)):
            return
        pushes = []
        by_link = self._contact_points()
        for site, (link, point), fraction in zip(self._contact_sites, self._contact_links, self._adhesion_scale):
            if not site.adhesive or fraction <= 0:
                continue
            normal = np.zeros(3)
            for contact in by_link.get(link, ()):
                if contact[8] <= TOUCH_DISTANCE_M:
                    normal += contact[7]  # contactNormalOnB points from the surface to the body (A)
            size = np.linalg.norm(normal)
            if size > 0:
                pushes.append((link, point, -adhesion_n * fraction * normal / size))
        if pushes:
            frames = self._frames(sorted({link for link, _, _ in pushes}))
            for link, point, force in pushes:
                pos, rot = frames[link]
                pb.applyExternalForce(robot, link, force.tolist(), (pos + rot @ point).tolist(), pb.WORLD_FRAME,
                                      physicsClientId=cid)

    def _check_base(self) -> None:
        cid, robot = self._client, self._robot
        pos, _ = pb.getBasePositionAndOrientation(robot, physicsClientId=cid)
        linvel, angvel = pb.getBaseVelocity(robot, physicsClientId=cid)
        state = np.concatenate([pos, linvel, angvel])
        if not np.isfinite(state).all():
            self._diverged("the root's position or velocity is not finite")
        if np.abs(np.concatenate([linvel, angvel])).max() >= DIVERGED_VELOCITY:
            self._diverged(f"the root's velocity reached PyBullet's clamp (linear {np.round(linvel, 1).tolist()} "
                           f"m/s, angular {np.round(angvel, 1).tolist()} rad/s)")

    def _diverged(self, reason: str) -> None:
        message = f"pybullet simulation diverged at t = {self.time:.4f} s: {reason}"
        self.warnings.append(message)
        raise SimulationError(message)

    def _render_follow(self, view: FollowView) -> np.ndarray:
        return render_follow(self._client, view, self.world)

    def _require(self) -> BodySpec:
        if self.body is None or self._client is None:
            raise SimulationError("pybullet backend: call load(world, [body_spec]) first (or it was closed)")
        return self.body


def _geom_reach(geom, axes: np.ndarray) -> np.ndarray:
    """Half-extent (3,) along the world axes of a geom whose local axes are the columns of ``axes``."""
    if geom.shape == "sphere":
        return np.full(3, geom.size_m[0])
    if geom.shape == "box":
        return np.abs(axes) @ np.asarray(geom.size_m)
    radius, half = geom.size_m
    along = np.abs(axes[:, 2]) * half
    if geom.shape == "capsule":
        return along + radius
    return along + radius * np.sqrt(np.clip(1.0 - axes[:, 2] ** 2, 0.0, 1.0))


