"""The MuJoCo backend: one articulated body (a :class:`~neuronav.spec.body.BodySpec`) in a
:class:`~neuronav.spec.world.World`.

Physics step
------------
Each physics step runs ``mj_step2`` then ``mj_step1`` (together exactly ``mj_step``), so between
steps every derived quantity (body poses, site positions, contacts) belongs to the current state:
reads are consistent, and adhesion and external forces are computed from the contacts and poses
of the state they act on. Position control lives in the model's actuators (see
:mod:`neuronav.backends.mujoco.mjcf`): ``ctrl`` holds the joint targets, and MuJoCo evaluates
``clip(kp * (target - q) - kd * qdot, ±max_torque)`` every step.

Stability
---------
After every step the MuJoCo warning counters are checked: a bad position, velocity, acceleration
or control (NaN, inf or beyond 1e10) raises :class:`~neuronav.errors.SimulationError`; other warnings
(e.g. a full contact buffer) are recorded in :attr:`MujocoBackend.warnings`.

Cameras
-------
Body cameras follow :mod:`neuronav.senses.vision` (the shared base composes their images): this module
renders the planar views it asks for, flat-shaded, in one GL context of its own. Per camera frame
the scene is updated once; every view (a planar eye, or a panorama's cube faces) is drawn into its
own viewport of one offscreen buffer (side by side, in rows when they overflow its width) with its own
frustum (independent horizontal and vertical fields of view, clipped at ``NEAR_M``..``FAR_M``), and the
buffer is read once, colour and depth. Compound eyes' cube faces (all the eyes of one read together,
:mod:`neuronav.senses.compound_eye_views`) are drawn in the spectral colouring: the world's geoms take their
green-and-UV colours, untextured, for the scene updates (one per face, with only the objects that face can
show: a compound eye's faces look all around), and get their own back at once; where a face shows several
objects, the eyes draw them themselves in one GL call over the ground MuJoCo drew
(:mod:`neuronav.backends.mujoco.object_batch`: MuJoCo's pixels but for rare edge ones, one call instead of one
per geom).
Flat shading: the scene's only light is an ambient headlight of 1 (no diffuse, specular, shadows,
reflections, fog, haze or skybox), so each surface shows exactly its rgba; 2D textures are sampled
nearest: the checker (one texel per square) and the odour trails' floor image
(:mod:`neuronav.senses.trail_floor`, on a plane just above the ground: each pixel shows one of its texels,
as the kinematic ray caster paints it). Pixels left at the far plane are the sky mask. The body
(geom group ``BODY_GROUP``) is drawn only for a camera that ``sees_body``. A world object whose bounding
sphere or turned bounding box lies outside every view of a read is left out of that read's scene (exact: it
could not cover a pixel; the eyes of the 40-tree forest draw a third of its trees, the ten faces of a
compound-eye read together about a fifth of what they would draw uncut). The GL context is the process's
(:mod:`neuronav.backends.mujoco.gl_contexts`: kept across backends, safe after ``fork``); the eyes'
``MjrContext`` has no shadow map; the compound eyes' own one draws spheres and cylinders with 12 slices and 6
stacks (:data:`EYE_SLICES`; MuJoCo's default 28 and 16, which the cameras keep, cost the forest's compound-eye
reads twice the time, for silhouettes a tenth of a face pixel truer).
``"follow"`` is the shared follow view (:func:`neuronav.engine.articulated.follow_view`): the free camera
looks at its target from its distance, with the model's free-camera field of view set to it; it is
lit (headlight and sun) with the World's sky and floor, in one pass per frame without multisampling, in a
GL context kept across backends (:mod:`neuronav.backends.mujoco.follow_renderer`).

Scene yaw turns the mocap body that carries the world's objects (:data:`mjcf.SCENE_BODY`) about
the world z axis: their collisions follow them, and the turn holds across resets.

Everything engine-free (sensor table, checks, reset lifting, ``apply_force``'s rule, the follow
framing) is in :class:`neuronav.engine.articulated.ArticulatedBackend`; this module only talks to MuJoCo.
"""

from __future__ import annotations

import os
from concurrent.futures import Future
from functools import lru_cache

os.environ.setdefault("MUJOCO_GL", "egl")


import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from neuronav.backends.mujoco import gl_contexts  # noqa: E402 -- sets LP_NUM_THREADS=0 (fork-safe rendering)
from neuronav.backends.mujoco.follow_renderer import FollowRenderer  # noqa: E402
from neuronav.backends.mujoco.mjcf import (  # noqa: E402
    BODY_GROUP,
    HORIZON_GROUP,
    LOAD_SENSOR_PREFIX,
    SCENE_BODY,
    ModelNames,
    compile_model,
)
from neuronav.backends.mujoco.object_batch import ObjectBatch  # noqa: E402
from neuronav.engine.articulated import ArticulatedBackend, FollowView  # noqa: E402
from neuronav.engine.sampling import RawRowSampler, Sampler  # noqa: E402
from neuronav.errors import SimulationError  # noqa: E402
from neuronav.senses.vision import FAR_M, NEAR_M, View  # noqa: E402
from neuronav.spec.body import BodySpec, Camera, quat_to_matrix  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

# Rays see the world's geoms (group 0) only: not the body (BODY_GROUP) nor the drawn-only planes (HORIZON_GROUP).
_WORLD_GEOMS = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)

_FATAL_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "bad joint position (NaN, inf or huge)",
    mujoco.mjtWarning.mjWARN_BADQVEL: "bad velocity (NaN, inf or huge)",
    mujoco.mjtWarning.mjWARN_BADQACC: "bad acceleration (NaN, inf or huge)",
    mujoco.mjtWarning.mjWARN_BADCTRL: "bad control (NaN, inf or huge joint target)",
}
_OTHER_WARNINGS = {
    mujoco.mjtWarning.mjWARN_INERTIA: "inertia matrix too close to singular",
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "contact buffer full: contacts were dropped",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "constraint buffer full: constraints were dropped",
}
_FATAL_INDEX = np.array([int(w) for w in _FATAL_WARNINGS])


class MujocoBackend(ArticulatedBackend):
    """One articulated body simulated by MuJoCo; implements the backend protocol (see docs/architecture.md).

    Parameters
    ----------
    timestep_s : float
        Physics step (default 2 ms).

    Attributes
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The compiled model and its state (after :meth:`load`), for benchmarks and inspection.
    names : ModelNames
        Where each spec element went in the model.
    warnings : list of str
        MuJoCo warnings seen so far (kept across resets).
    """

    engine = "mujoco"

    cull_rays = False  # mj_multiRay culls by bounding spheres itself (see _cast_rays)

    def __init__(self, timestep_s: float = 0.002) -> None:
        super().__init__(timestep_s)
        self.model: mujoco.MjModel | None = None
        self.data: mujoco.MjData | None = None
        self.names: ModelNames | None = None
        self._renderers: dict[tuple[int, int], FollowRenderer] = {}
        self._renderers_pid = os.getpid()  # the process that made the follow view's renderers
        self._eyes: _FlatRenderer | None = None
        self._pending: list[tuple[int, np.ndarray, np.ndarray]] = []

    # -- engine hooks: building and resetting --------------------------------------------------------
    def _load_engine(self, world: World, body: BodySpec) -> None:
        """Compile the MJCF of ``world`` and ``body`` (a model MuJoCo rejects is a ConfigError)."""
        self._close_renderers()
        model, names = compile_model(world, body, self._timestep_s)
        self.model, self.data, self.names = model, mujoco.MjData(model), names
        self._index(model, names, body, world)

    def _reset_engine(self, position: np.ndarray, pose_quat: np.ndarray) -> None:
        model, data = self.model, self.data
        mujoco.mj_resetData(model, data)
        root_quat = np.zeros(4)
        mujoco.mju_mulQuat(root_quat, pose_quat, np.asarray(self.body.root.quat, float))
        if self._free_qpos is not None:
            data.qpos[self._free_qpos:self._free_qpos + 3] = position
            data.qpos[self._free_qpos + 3:self._free_qpos + 7] = root_quat
        else:  # a root welded to the world: move the weld itself
            model.body_pos[self._root] = position
            model.body_quat[self._root] = root_quat
        rest = self.body.rest_pose_rad()
        data.qpos[self._qpos] = rest
        data.ctrl[:] = rest
        self._pending.clear()
        mujoco.mj_forward(model, data)
        self._torque = data.actuator_force.copy()
        self._forces_current = True
        self._seen = np.zeros(len(data.warning.number), dtype=int)
        self._diverged = ""  # the reason, once a step has failed

    def _raise_root(self, dz_m: float) -> None:
        if self._free_qpos is not None:
            self.data.qpos[self._free_qpos + 2] += dz_m
        else:
            self.model.body_pos[self._root, 2] += dz_m
        mujoco.mj_forward(self.model, self.data)

    def _penetration_m(self) -> float:
        """How far the deepest body geom reaches into a world geom (0 when nothing overlaps)."""
        model, data = self.model, self.data
        deepest = 0.0
        for i in range(data.ncon):
            contact = data.contact[i]
            bodies = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
            if self._scenery[bodies[0]] != self._scenery[bodies[1]]:  # exactly one side is the world
                deepest = max(deepest, -float(contact.dist))
        return deepest

    @property
    def time(self) -> float:
        return 0.0 if self.data is None else float(self.data.time)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps, applying adhesion and any pending :meth:`apply_force` each step.

        Raises
        ------
        SimulationError
            When the state becomes non-finite or MuJoCo reports an unstable step.
        """
        model, data = self._require_model()
        n = self._check_steps(n)
        if self._diverged:
            raise SimulationError(f"{self._diverged} (earlier); call reset() to continue")
        fatal_seen = self._seen[_FATAL_INDEX]
        forces = bool(self._pending) or self._adhesion_n > 0
        try:
            self._advance(model, data, n, forces, fatal_seen)
        finally:
            if forces:
                data.xfrc_applied[:] = 0.0
            self._pending.clear()
            # mj_step1 leaves actuator_force alone: it still holds the torques applied in the last step.
            self._torque = data.actuator_force.copy()
            self._forces_current = False
        self._check(data)

    def _advance(self, model: mujoco.MjModel, data: mujoco.MjData, n: int, forces: bool,
                 fatal_seen: np.ndarray) -> None:
        """:meth:`step`'s physics steps: each ``mj_step2`` then ``mj_step1``, adhesion and pending forces first.

        A subclass may advance the same model another way (the dm_control backend steps its ``Physics``).
        """
        for _ in range(n):
            if forces:
                self._external_forces(model, data)
            mujoco.mj_step2(model, data)
            mujoco.mj_step1(model, data)
            if (data.warning.number[_FATAL_INDEX] > fatal_seen).any():
                break  # MuJoCo has already reset the state; stop and report

    def model_summary(self) -> dict:
        """What MuJoCo compiled, read back from the model: for comparing backends on one spec.

        Returns
        -------
        dict
            ``segment_mass_kg`` {segment: kg}, ``joint_range_rad`` {joint: (low, high)},
            ``joint_axis_world`` {joint: unit (3,) at the current pose}, ``site_pos_m``
            {site: (3,) world position}.
        """
        model, data = self._require_model()
        mujoco.mj_kinematics(model, data)
        body = self.body
        masses = {s.name: float(model.body_mass[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, s.name)])
                  for s in body.segments}
        ranges, axes = {}, {}
        for joint in body.joints:
            index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
            ranges[joint.name] = tuple(float(v) for v in model.jnt_range[index])
            axes[joint.name] = data.xaxis[index].copy()
        sites = {s.name: data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, s.name)].copy()
                 for s in body.sites}
        return {"segment_mass_kg": masses, "joint_range_rad": ranges, "joint_axis_world": axes, "site_pos_m": sites}

    def raw_step(self, n: int = 1, targets: np.ndarray | None = None) -> None:
        """``mujoco.mj_step`` n times and nothing else (no adhesion, no checks): for benchmarks.

        The actuators hold ``targets`` (J,) when given, else the last targets (the control law is
        part of the model), so replaying a walk's targets costs exactly MuJoCo's own steps.
        """
        model, data = self._require_model()
        if targets is not None:
            data.ctrl[:] = targets
        for _ in range(int(n)):
            mujoco.mj_step(model, data)
        mujoco.mj_step1(model, data)  # bring poses and contacts up to the new state, as step() does
        self._torque = data.actuator_force.copy()
        self._forces_current = False

    def _render_follow(self, view: FollowView) -> np.ndarray:
        return np.ascontiguousarray(self._render_follow_later(view).result())

    def _render_follow_later(self, view: FollowView) -> Future:
        self.model.vis.global_.fovy = view.fov_deg
        renderer = self._renderer(*view.size_px)
        return renderer.render_later(self.model, self.data, self._follow_camera(view), self._follow_option)

    def render_later(self, camera: str) -> Future:
        """``render(camera)`` as a ``concurrent.futures.Future``: the follow view's scene is taken now and drawn on
        the GL thread (:mod:`~neuronav.backends.mujoco.follow_renderer`) while the caller goes on; any other camera
        is rendered now."""
        if camera != "follow":
            done: Future = Future()
            done.set_result(self.render(camera))
            return done
        return self._render_follow_later(self.follow_view())

    # -- engine hooks: body cameras --------------------------------------------------------------------
    def _camera_frame(self, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
        segment = self._camera_segments[camera.name]
        position, rotation = self.data.xpos[segment], self.data.xmat[segment].reshape(3, 3)
        return position + rotation @ np.asarray(camera.pos_m, float), rotation @ quat_to_matrix(camera.quat)

    def _views_fit(self, view_lists: list[list[View]]) -> bool:
        """Several cameras' views fit the offscreen buffer together: one scene update and one read for all."""
        width, height = int(self.model.vis.global_.offwidth), int(self.model.vis.global_.offheight)
        _, total, tallest = _place_views([view for views in view_lists for view in views], width)
        return total <= width and tallest <= height

    def _render_views(self, views: list[View], sees_body: bool,
                      spectral: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
        if self._eyes is not None and self._eyes.pid != os.getpid():  # forked: the parent's, never touched
            self._eyes.close()
            self._eyes = None
        if self._eyes is None:
            self._eyes = _FlatRenderer(self.model)
        return self._eyes.render(self.model, self.data, views, sees_body,
                                 self._spectral_colours() if spectral else None)

    def _spectral_colours(self) -> tuple[np.ndarray, np.ndarray]:
        """The world's geoms (ids) and their rgba in the spectral colouring (``spectral_world``): the
        objects' geoms (the scene body's, in the World's order) in their ``spectral``, every other geom of
        the world body (ground, horizon, wall, trail plane) in ``ground_green_uv``; built once per model."""
        if getattr(self, "_spectral", None) is None or self._spectral[0] is not self.model:
            model, world = self.model, self.world
            objects = np.flatnonzero(model.geom_bodyid == self._scene_body) if self._scene_body >= 0 else []
            ground = np.flatnonzero((model.geom_bodyid == 0) & np.isin(model.geom_group, (0, HORIZON_GROUP)))
            rgba = [(0.0, *world.appearance.ground_green_uv, 1.0)] * len(ground)
            rgba += [(0.0, *obj.spectral, 1.0) for obj in world.objects][:len(objects)]
            self._spectral = (model, np.concatenate([ground, objects]).astype(int), np.array(rgba, np.float32))
        return self._spectral[1], self._spectral[2]

    def _turn_scene(self, yaw_rad: float) -> None:
        if self._scene_body < 0:
            return  # no objects to turn
        quat = np.array([np.cos(yaw_rad / 2.0), 0.0, 0.0, np.sin(yaw_rad / 2.0)])
        # The mocap pose now, and the model's (which a reset copies into the mocap pose): the turn holds.
        self.data.mocap_quat[self.model.body_mocapid[self._scene_body]] = quat
        self.model.body_quat[self._scene_body] = quat
        # Poses and contacts of the turned scene; the solved forces are recomputed when read.
        mujoco.mj_forward(self.model, self.data)
        self._forces_current = False

    def _queue_force(self, segment: str, point_m: np.ndarray, force_n: np.ndarray) -> None:
        body_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, segment)
        self._pending.append((body_id, point_m, force_n))

    def close(self) -> None:
        """Free the renderers (their GL contexts); the model stays readable."""
        self._close_renderers()

    # -- load helpers --------------------------------------------------------------------------
    def _index(self, model: mujoco.MjModel, names: ModelNames, body: BodySpec, world: World) -> None:
        def ids(kind, items):
            found = np.array([mujoco.mj_name2id(model, kind, n) for n in items], dtype=int)
            assert (found >= 0).all(), f"mujoco backend: a {kind} of {items} is missing from the model"
            return found

        joints = ids(mujoco.mjtObj.mjOBJ_JOINT, names.joints)
        self._qpos = model.jnt_qposadr[joints].copy()
        self._dof = model.jnt_dofadr[joints].copy()
        self._actuators = ids(mujoco.mjtObj.mjOBJ_ACTUATOR, names.joints)
        assert (self._actuators == np.arange(len(names.joints))).all(), "actuators must follow BodySpec.joints order"
        self._root = int(ids(mujoco.mjtObj.mjOBJ_BODY, [names.root])[0])
        self._free_qpos = None
        if names.free_joint is not None:
            self._free_qpos = int(model.jnt_qposadr[ids(mujoco.mjtObj.mjOBJ_JOINT, [names.free_joint])[0]])
        # geom id -> contact-site index (-1: not a contact geom)
        self._contact_sites = body.sites_of_kind("contact")
        self._adhesive = np.array([site.adhesive for site in self._contact_sites], dtype=bool)
        self._site_of_geom = np.full(model.ngeom, -1, dtype=int)
        self._site_geoms = []
        for index, geoms in enumerate(names.contact_geoms):
            geom_ids = ids(mujoco.mjtObj.mjOBJ_GEOM, geoms)
            self._site_of_geom[geom_ids] = index
            self._site_geoms.append(geom_ids)
        # contact_load: each contact site's rows of sensordata (its geoms' net-force contact sensors, 3 each).
        # Found by the geom each sensor watches (a composer entity renames the sensors with the geoms).
        sensor_of_geom = {int(model.sensor_objid[s]): s for s in range(model.nsensor)
                          if model.sensor_type[s] == mujoco.mjtSensor.mjSENS_CONTACT
                          and model.sensor_objtype[s] == mujoco.mjtObj.mjOBJ_GEOM}
        self._load_rows = []
        for geom_ids in self._site_geoms:
            missing = [int(g) for g in geom_ids if int(g) not in sensor_of_geom]
            assert not missing, f"contact geoms {missing} have no load sensor ({LOAD_SENSOR_PREFIX}...): see mjcf.py"
            self._load_rows.append(np.concatenate([model.sensor_adr[sensor_of_geom[int(g)]] + np.arange(3)
                                                   for g in geom_ids]))
        self._load_sites = np.repeat(np.arange(len(self._load_rows)), [len(rows) // 3 for rows in self._load_rows])
        self._load_rows = np.concatenate(self._load_rows) if self._load_rows else np.zeros(0, int)
        if len(self._load_rows) and (np.diff(self._load_rows) == 1).all():  # consecutive: a view, not a copy
            self._load_rows = slice(int(self._load_rows[0]), int(self._load_rows[-1]) + 1)
        self._camera_segments = {c.name: int(ids(mujoco.mjtObj.mjOBJ_BODY, [c.segment])[0]) for c in body.cameras}
        self._segment_ids: dict[str, int] = {}
        self._scene_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, SCENE_BODY)
        # The scenery: the world body and the objects' mocap body (reset's overlap check is between it and the body).
        self._scenery = np.isin(np.arange(model.nbody), [0, self._scene_body])
        self._follow_option = mujoco.MjvOption()
        self._follow_option.geomgroup[HORIZON_GROUP] = 1
        self._odour = ids(mujoco.mjtObj.mjOBJ_SITE, [s.name for s in body.sites_of_kind("odour")])
        self._wind = ids(mujoco.mjtObj.mjOBJ_SITE, [s.name for s in body.sites_of_kind("wind")])
        self._adhesion_n = float(world.adhesion_n)

    # -- step helpers --------------------------------------------------------------------------
    def _external_forces(self, model: mujoco.MjModel, data: mujoco.MjData, pending: bool = True) -> None:
        """Fill ``xfrc_applied`` with adhesion (and the pending forces) for the state about to be stepped."""
        xfrc = data.xfrc_applied
        xfrc[:] = 0.0
        for body_id, local, force in self._pending if pending else ():
            point = data.xpos[body_id] + data.xmat[body_id].reshape(3, 3) @ local
            self._push(xfrc, data, body_id, point, force)
        if self._adhesion_n > 0 and data.ncon:
            self._adhesion(model, data, xfrc)

    def _adhesion(self, model: mujoco.MjModel, data: mujoco.MjData, xfrc: np.ndarray) -> None:
        """Press each touching adhesive geom into what it touches with its fraction of ``adhesion_n`` newtons."""
        contact = data.contact
        active = contact.exclude == 0
        normal = contact.frame[:, :3]  # points from geom1 to geom2
        site1, site2 = self._site_of_geom[contact.geom1], self._site_of_geom[contact.geom2]
        # The surface's outward normal, pointing toward the site geom: +normal when that geom is geom2.
        on2, on1 = active & (site2 >= 0), active & (site1 >= 0)
        if not (on2.any() or on1.any()):
            return
        sites = len(self._contact_sites)
        outward = np.zeros((sites, 3))
        np.add.at(outward, site2[on2], normal[on2])
        np.add.at(outward, site1[on1], -normal[on1])
        touching = np.full(sites, -1)
        touching[site2[on2]] = contact.geom2[on2]
        touching[site1[on1]] = contact.geom1[on1]
        norm = np.linalg.norm(outward, axis=1)
        pressed = np.flatnonzero((touching >= 0) & (norm > 0) & self._adhesive & (self._adhesion_scale > 0))
        geoms = touching[pressed]
        force = -(self._adhesion_n * self._adhesion_scale[pressed] / norm[pressed])[:, None] * outward[pressed]
        self._push(xfrc, data, model.geom_bodyid[geoms], data.geom_xpos[geoms], force)

    @staticmethod
    def _push(xfrc: np.ndarray, data: mujoco.MjData, body_id, point: np.ndarray, force: np.ndarray) -> None:
        """Add forces at world points; xfrc_applied acts at each body's centre of mass, hence the torques.

        ``body_id`` is an int or an (n,) array, ``point`` and ``force`` (3,) or (n, 3).
        """
        body_id = np.atleast_1d(body_id)
        point, force = np.atleast_2d(point), np.atleast_2d(force)
        r = point - data.xipos[body_id]
        torque = np.stack([r[:, 1] * force[:, 2] - r[:, 2] * force[:, 1],
                           r[:, 2] * force[:, 0] - r[:, 0] * force[:, 2],
                           r[:, 0] * force[:, 1] - r[:, 1] * force[:, 0]], axis=1)
        np.add.at(xfrc, body_id, np.hstack([force, torque]))

    def _check(self, data: mujoco.MjData) -> None:
        counts = np.asarray(data.warning.number, dtype=int)
        fatal = []
        for index in np.flatnonzero(counts > self._seen):
            warning = mujoco.mjtWarning(int(index))
            reason = _FATAL_WARNINGS.get(warning) or _OTHER_WARNINGS.get(warning, "engine warning")
            message = (f"mujoco {warning.name} at t={data.time:.4f} s: {reason} "
                       f"(seen {counts[index]} times, last at index {data.warning.lastinfo[index]})")
            self.warnings.append(message)
            if warning in _FATAL_WARNINGS:
                fatal.append(message)
        self._seen = counts.copy()
        if fatal:
            self._diverged = f"mujoco simulation diverged: {'; '.join(fatal)}"
        elif not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
            self._diverged = f"mujoco simulation diverged at t={data.time:.4f} s: the state is not finite"
        if self._diverged:
            raise SimulationError(f"{self._diverged}; call reset() to continue")

    # -- engine hooks: sensors -------------------------------------------------------------------------
    def _root_pose(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        data, root = self.data, self._root
        return data.xpos[root], data.xquat[root], data.xmat[root].reshape(3, 3)

    def _segment_pose(self, segment: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        body_id = self._segment_ids.get(segment)
        if body_id is None:
            body_id = self._segment_ids[segment] = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, segment)
        data = self.data
        return data.xpos[body_id].copy(), data.xquat[body_id].copy(), data.xmat[body_id].reshape(3, 3).copy()

    def _cast_rays(self, origins: np.ndarray, directions: np.ndarray, max_distance_m: float,
                   start_m: np.ndarray, stop_m: np.ndarray) -> np.ndarray:
        """``mj_multiRay`` once per distinct origin (from the origins, to ``max_distance_m``: ``start_m`` and
        ``stop_m`` are not needed), against the world's geoms only (geom group 0: the body's geoms are in
        ``BODY_GROUP``, the drawn-only horizon and trail planes in ``HORIZON_GROUP``). MuJoCo culls by
        bounding spheres itself, faster than the shared test (``cull_rays`` is off): 160 rays among 80
        objects cost about 0.1 ms."""
        if (origins == origins[0]).all():  # one origin (an agent's rays): one call
            return self._multi_ray(origins[0], directions, max_distance_m)
        distances = np.full(origins.shape[0], np.inf)
        # One call per run of rays sharing an origin (an eye's rays come together; a run met again only costs
        # one call more). Cheaper than grouping all equal origins with np.unique(axis=0).
        starts = np.flatnonzero((origins[1:] != origins[:-1]).any(axis=1)) + 1
        for rows in np.split(np.arange(origins.shape[0]), starts):
            distances[rows] = self._multi_ray(origins[rows[0]], directions[rows], max_distance_m)
        return distances

    def _multi_ray(self, origin: np.ndarray, directions: np.ndarray, max_distance_m: float) -> np.ndarray:
        """``mj_multiRay`` of the rays (K, 3) from one origin: hit distances (K,), ``np.inf`` for none."""
        count = directions.shape[0]
        found = np.empty(count)
        geom_ids = np.empty(count, dtype=np.int32)
        if self.scene_yaw_rad % (2 * np.pi) != 0.0:
            # mj_multiRay (MuJoCo 3.17) misses geoms of the turned scene body in this model (a tower 20 m off
            # turned 1 rad: 0 of 28 rays hit; mj_ray hits them all): ray by ray while the scene is turned.
            geom_id = np.empty(1, dtype=np.int32)
            for k in range(count):
                found[k] = mujoco.mj_ray(self.model, self.data, origin, directions[k], _WORLD_GEOMS, 1, -1, geom_id)
                geom_ids[k] = geom_id[0]
        else:
            mujoco.mj_multiRay(self.model, self.data, origin, np.ascontiguousarray(directions).reshape(-1),
                               _WORLD_GEOMS, 1, -1, geom_ids, found, None, count, max_distance_m)
        return np.where((geom_ids >= 0) & (found >= 0) & (found <= max_distance_m), found, np.inf)

    def _root_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        velocity = np.zeros(6)  # (angular, linear) of the root frame, world axes
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, self._root, velocity, 0)
        return velocity[3:], velocity[:3]

    def _joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.data.qpos[self._qpos], self.data.qvel[self._dof]

    def _joint_torque(self) -> np.ndarray:
        return self._torque[self._actuators]

    def _site_positions(self, kind: str) -> np.ndarray:
        return self.data.site_xpos[self._odour if kind == "odour" else self._wind]

    def _set_joint_targets(self, targets: np.ndarray) -> None:
        self.data.ctrl[:] = targets

    def _sampler(self, names: tuple[str, ...]) -> Sampler:
        """Joint angles and contact loads straight from the model's arrays; other sensors as :meth:`read`
        reads them. A record copies two stretches, of ``qpos`` (the joints' span) and of ``sensordata``
        (the legs' net contact forces), as they are: the joints' order and the forces' norms are done
        for all recorded rows at the drain."""
        if (names != ("joint_pos", "contact_load") or len(self._load_sites) != len(self._contact_sites)
                or not len(self._contact_sites) or not len(self._qpos)):
            return super()._sampler(names)
        data, joints, rows = self.data, self._qpos, self._load_rows
        qpos, sensordata = data.qpos, data.sensordata  # views of the loaded model's arrays
        out = np.empty(len(joints) + len(self._contact_sites))
        loads = out[len(joints):]

        def sample() -> np.ndarray:
            np.take(qpos, joints, out=out[:len(joints)])
            net = sensordata[rows].reshape(-1, 3)
            np.sqrt(np.einsum("ij,ij->i", net, net), out=loads)
            return out.copy()

        force_rows = np.arange(sensordata.shape[0])[rows]  # the load rows as indices (a slice on the ant)
        q0, q1 = int(joints.min()), int(joints.max()) + 1
        s0, s1 = int(force_rows.min()), int(force_rows.max()) + 1
        columns = np.concatenate([joints - q0, (q1 - q0) + force_rows - s0])

        def finish(raw: np.ndarray) -> np.ndarray:
            picked = raw[:, columns]
            net = picked[:, len(joints):].reshape(len(raw), len(loads), 3)
            return np.concatenate([picked[:, :len(joints)], np.sqrt(np.einsum("tij,tij->ti", net, net))], axis=1)
        return RawRowSampler(sample, [(qpos, q0, q1), (sensordata, s0, s1)], finish)

    def _contact_loads(self) -> np.ndarray:
        """(C,) N: each contact site's net contact force in the last physics step, from the model's contact
        sensors (MuJoCo computes them in every step's acceleration stage: reading them solves nothing)."""
        net = self.data.sensordata[self._load_rows].reshape(-1, 3)
        if len(net) == len(self._contact_sites):  # one geom per site (the desert ant)
            return np.sqrt(np.einsum("ij,ij->i", net, net))
        summed = np.zeros((len(self._contact_sites), 3))
        np.add.at(summed, self._load_sites, net)
        return np.linalg.norm(summed, axis=1)

    def _contact_forces(self) -> np.ndarray:
        """World-frame total force ON each contact site's geoms, summed over their contacts."""
        model, data = self.model, self.data
        forces = np.zeros((len(self._contact_sites), 3))
        if not data.ncon:
            return forces
        if not self._forces_current:
            # After mj_step1 the contact list is the current state's but the solved forces are the last
            # step's: solve the current state's constraints (this leaves the trajectory unchanged -- the
            # next mj_step2 solves the same problem from the same warm start).
            if self._adhesion_n > 0:
                self._external_forces(model, data, pending=False)  # adhesion acts in this state too
            mujoco.mj_forwardSkip(model, data, mujoco.mjtStage.mjSTAGE_VEL, 1)
            data.xfrc_applied[:] = 0.0
            self._forces_current = True
        contact = data.contact
        wrench = np.zeros(6)
        for i in range(data.ncon):
            s1, s2 = self._site_of_geom[contact.geom1[i]], self._site_of_geom[contact.geom2[i]]
            if (s1 < 0 and s2 < 0) or contact.efc_address[i] < 0:
                continue
            mujoco.mj_contactForce(model, data, i, wrench)
            # The contact-frame force acts on geom2 (normal from geom1 to geom2); geom1 feels the opposite.
            world = contact.frame[i].reshape(3, 3).T @ wrench[:3]
            if s2 >= 0:
                forces[s2] += world
            if s1 >= 0:
                forces[s1] -= world
        return forces

    # -- rendering -----------------------------------------------------------------------------
    def _renderer(self, width: int, height: int) -> FollowRenderer:
        key = (int(width), int(height))
        if self._renderers_pid != os.getpid():  # forked: the parent's renderers are never touched
            self._close_renderers(eyes=False)
            self._renderers_pid = os.getpid()
        if key not in self._renderers:
            self._renderers[key] = FollowRenderer(self.model, *key)
        return self._renderers[key]

    @staticmethod
    def _follow_camera(view: FollowView) -> mujoco.MjvCamera:
        """A free camera at ``view`` (its up is always world z: MuJoCo's free camera does not roll)."""
        look = (view.target - view.eye) / view.distance_m
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.lookat[:] = view.target
        camera.distance = view.distance_m
        camera.azimuth = float(np.degrees(np.arctan2(look[1], look[0])))
        camera.elevation = float(np.degrees(np.arcsin(np.clip(look[2], -1.0, 1.0))))
        return camera

    def _close_renderers(self, eyes: bool = True) -> None:
        """Free the follow view's renderers (and the eyes' with ``eyes``); a forked child only drops its
        parent's (:mod:`~neuronav.backends.mujoco.gl_contexts`)."""
        for renderer in self._renderers.values():
            if self._renderers_pid == os.getpid():
                renderer.close()
            else:
                gl_contexts.abandon(renderer)
        self._renderers.clear()
        if eyes and self._eyes is not None:
            self._eyes.close()
            self._eyes = None

    def _require(self) -> BodySpec:
        if self.model is None:
            raise SimulationError(f"{self.engine} backend: call load(world, [body_spec]) first")
        return self.body

    def _require_model(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        self._require()
        return self.model, self.data

    def __del__(self) -> None:
        try:
            self._close_renderers()
        except Exception:  # noqa: BLE001 -- interpreter shutdown: GL may already be gone
            pass


# The eyes' shadow map size (px): the smallest, as the eyes draw no shadows.
EYE_SHADOW_PX = 1
# The compound eyes' tessellation of spheres, cylinders and capsules (their own MjrContext; the cameras keep
# MuJoCo's default 28 slices and 16 stacks, which the scenarios' measured behaviour was made with): a 12-gon's
# silhouette is within 3.4 % of the radius (a tenth of a 1.9° face pixel for a 1 m trunk 5 m off); the
# compound eyes' read in the 40-tree forest took 7.8 ms at 28 x 16, 4.3 ms at 16 x 8, 3.4 ms at 12 x 6,
# 3.3 ms at 8 x 4 (CPU time, one run), and their agreement with the rays did not change
# (tests/cross_backend/test_compound_eye_agreement.py).
EYE_SLICES, EYE_STACKS = 12, 6
_EYE_QUALITY = ("offsamples", "shadowsize", "numslices", "numstacks")  # set for the eyes' MjrContext
# A compound-eye view whose objects MuJoCo leaves to the eyes' batch (one GL call) shows at least this many.
BATCH_MIN_GEOMS = 4
# The geom group a world geom outside every view of a read is moved to for that read's scene update (not drawn).
CULLED_GROUP = 5


@lru_cache(maxsize=64)
def _frustum_planes(fovs_rad: tuple[tuple[float, float], ...]) -> tuple[np.ndarray, np.ndarray]:
    """The six planes of views with fields of view ``fovs_rad`` ((horizontal, vertical) each), in each view's axes
    (x right, y up, z backwards): outward normals (V, 6, 3) and offsets (V, 6), a point p inside when
    n . p + offset <= 0 for all six; a side of a field of 180° or more is left out (offset -inf)."""
    half = np.array(fovs_rad, float).reshape(-1, 2) / 2.0
    cos, sin, zero = np.cos(half), np.sin(half), np.zeros(len(half))
    normals = np.stack([np.stack([cos[:, 0], zero, sin[:, 0]], 1), np.stack([-cos[:, 0], zero, sin[:, 0]], 1),
                        np.stack([zero, cos[:, 1], sin[:, 1]], 1), np.stack([zero, -cos[:, 1], sin[:, 1]], 1),
                        np.tile([0.0, 0.0, 1.0], (len(half), 1)), np.tile([0.0, 0.0, -1.0], (len(half), 1))], 1)
    wide = np.repeat(half >= np.pi / 2.0, 2, axis=1)  # (V, 4): the side planes to leave out
    offsets = np.concatenate([np.where(wide, -np.inf, 0.0), np.tile([NEAR_M, -FAR_M], (len(half), 1))], 1)
    normals.setflags(write=False)
    offsets.setflags(write=False)
    return normals, offsets


def _place_views(views: list[View], width_px: int) -> tuple[list[tuple[int, int]], int, int]:
    """Where each view goes in an offscreen buffer ``width_px`` wide (left, bottom): side by side, in rows of
    the buffer's width stacked upwards; and the width and height of the block used."""
    places, left, bottom, row_height, total = [], 0, 0, 0, 0
    for view in views:
        if left + view.width_px > width_px and left > 0:  # a new row above
            left, bottom, row_height = 0, bottom + row_height, 0
        places.append((left, bottom))
        left += view.width_px
        row_height = max(row_height, view.height_px)
        total = max(total, left)
    return places, total, bottom + row_height


class _FlatRenderer:
    """Body-camera views, flat-shaded, in one GL context: one scene update and one read per camera frame."""

    # Compound-eye reads draw the world's objects themselves, one GL call per view (:class:`ObjectBatch`);
    # False leaves every geom to MuJoCo (the same pixels but for rare edge ones, tests compare; slower in a forest).
    batches_objects = True

    def __init__(self, model: mujoco.MjModel) -> None:
        self.width, self.height = int(model.vis.global_.offwidth), int(model.vis.global_.offheight)
        self.pid = os.getpid()
        self._gl = gl_contexts.acquire(self.width, self.height)  # kept across the backends of the process
        self._context = self._make_context(model)  # the cameras'
        self._spectral_context: mujoco.MjrContext | None = None  # the compound eyes', made on their first read
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION, mujoco.mjtRndFlag.mjRND_SKYBOX,
                     mujoco.mjtRndFlag.mjRND_FOG, mujoco.mjtRndFlag.mjRND_HAZE):
            self._scene.flags[flag] = 0
        self._option = mujoco.MjvOption()
        self._option.geomgroup[:] = 0
        self._option.geomgroup[0] = self._option.geomgroup[HORIZON_GROUP] = 1
        self._perturb, self._camera = mujoco.MjvPerturb(), mujoco.MjvCamera()
        self._buffers: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        # The world's bounded geoms (objects: trees, landmarks), which a read may cull; planes (rbound 0) never.
        self._cullable = np.flatnonzero((model.geom_group == 0) & (model.geom_rbound > 0))
        self._batch: ObjectBatch | None = None  # the compound eyes' objects, drawn in one call per view

    def _make_context(self, model: mujoco.MjModel, tessellation: tuple[int, int] | None = None) -> mujoco.MjrContext:
        """An ``MjrContext`` for the eyes in the GL context: no multisampling (an edge pixel shows one surface's
        colour, never a blend; the follow view keeps it), no shadow map (the eyes draw no shadows: MuJoCo's
        default 4096 x 4096 one cost ~35 ms per context), and spheres and cylinders drawn with ``tessellation``
        (slices, stacks) if given, else the model's."""
        quality = model.vis.quality
        kept = [int(getattr(quality, name)) for name in _EYE_QUALITY]
        wanted = (0, EYE_SHADOW_PX, *(tessellation or kept[2:]))
        for name, value in zip(_EYE_QUALITY, wanted):
            setattr(quality, name, value)
        try:
            context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        finally:
            for name, value in zip(_EYE_QUALITY, kept):
                setattr(quality, name, value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, context)
        self._nearest_textures(model, context)
        return context

    @staticmethod
    def _nearest_textures(model: mujoco.MjModel, context: mujoco.MjrContext) -> None:
        """Sample 2D textures nearest, without mipmaps: a checker square is exactly its colour at any distance."""
        from OpenGL import GL  # mujoco's EGL context comes with PyOpenGL

        for texture in range(model.ntex):
            if model.tex_type[texture] != mujoco.mjtTexture.mjTEXTURE_2D:
                continue
            GL.glBindTexture(GL.GL_TEXTURE_2D, int(context.texture[texture]))
            GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MIN_FILTER, GL.GL_NEAREST)
            GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MAG_FILTER, GL.GL_NEAREST)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)

    def render(self, model: mujoco.MjModel, data: mujoco.MjData, views: list[View], sees_body: bool,
               spectral: tuple[np.ndarray, np.ndarray] | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each view's uint8 image and sky mask. ``spectral``: geom ids and the rgba they are drawn in for
        this read (untextured; the model's own colours are back right after the scene update)."""
        places, total, tallest = self._layout(views)
        self._gl.make_current()
        if spectral is not None and self._spectral_context is None:
            self._spectral_context = self._make_context(model, (EYE_SLICES, EYE_STACKS))
        context = self._context if spectral is None else self._spectral_context
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, context)
        self._option.geomgroup[BODY_GROUP] = int(sees_body)
        # Views that can show the same world objects share one scene update (both eyes of a binocular read in
        # an open world); views that face different objects (the eyes in a forest, a compound eye's cube
        # faces) each get the scene of what they face, cheaper to draw than the union of all.
        visible = self._visible(model, data, views)
        # The views where the eyes' own batch draws the objects (those showing at least BATCH_MIN_GEOMS of them:
        # one GL call's fixed cost is two or three of MuJoCo's geoms'); MuJoCo draws the rest of each view.
        batched, by_batch = np.zeros(len(self._cullable), dtype=bool), np.zeros(len(views), dtype=bool)
        # The batch draws after MuJoCo has drawn every view, in the projection it left: views of one field only.
        if (spectral is not None and self.batches_objects and self._cullable.size >= BATCH_MIN_GEOMS
                and len({tuple(view.fov_rad) for view in views}) == 1):
            batch, batched, batch_rgba = self._object_batch(model, spectral)
            by_batch = visible[:, batched].sum(axis=1) >= BATCH_MIN_GEOMS
            if by_batch.any():
                batch.update(data, batch_rgba)
        by_mujoco = visible & ~(by_batch[:, None] & batched)
        scenes: dict[bytes, list[int]] = {}  # the views of each pattern of geoms (np.unique(axis=0) cost 0.4 ms)
        for v, pattern in enumerate(by_mujoco):
            scenes.setdefault(pattern.tobytes(), []).append(v)
        if spectral is not None:  # the world in its spectral colours, set once for the read
            ids, rgba = spectral
            kept_rgba, kept_matid = model.geom_rgba[ids].copy(), model.geom_matid[ids].copy()
            model.geom_rgba[ids], model.geom_matid[ids] = rgba, -1
        try:
            for members in scenes.values():
                culled = self._cullable[~by_mujoco[members[0]]]
                model.geom_group[culled] = CULLED_GROUP
                self._update_scene(model, data, culled)
                for v in members:
                    self._draw(views[v], places[v], context)
            if by_batch.any():  # the objects, over what MuJoCo drew, in the projection it left set
                batch.draw([(views[v], places[v], batch.indices(visible[v, batched]))
                            for v in np.flatnonzero(by_batch)])
        finally:
            if spectral is not None:
                model.geom_rgba[ids], model.geom_matid[ids] = kept_rgba, kept_matid
        whole = mujoco.MjrRect(0, 0, total, tallest)
        if (tallest, total) not in self._buffers:  # readPixels fills contiguous arrays of the read's size
            self._buffers[tallest, total] = (np.zeros((tallest, total, 3), dtype=np.uint8),
                                             np.zeros((tallest, total), dtype=np.float32))
        rgb, depth = self._buffers[tallest, total]
        mujoco.mjr_readPixels(rgb, depth, whole, context)
        # GL rows run bottom-up: each view is its block of the buffer, flipped.
        rendered = []
        for view, (left, bottom) in zip(views, places):
            rows = slice(bottom + view.height_px - 1, bottom - 1 if bottom else None, -1)
            block = slice(left, left + view.width_px)
            rendered.append((rgb[rows, block].copy(), depth[rows, block] >= 1.0))
        return rendered

    def _object_batch(self, model: mujoco.MjModel, spectral: tuple[np.ndarray, np.ndarray]
                      ) -> tuple[ObjectBatch, np.ndarray, np.ndarray]:
        """The world's objects as a compound-eye read draws them itself (:class:`ObjectBatch`: the bounded geoms
        with a spectral colour, at the eyes' tessellation; built on the first spectral read), which of
        :attr:`_cullable` it draws, and their rgba in the spectral colouring ``spectral`` (ids, rgba)."""
        ids, rgba = spectral
        if self._batch is None:
            coloured = np.isin(self._cullable, ids)
            self._batch = ObjectBatch(model, self._cullable[coloured], EYE_SLICES, EYE_STACKS)
            self._batched = np.zeros(len(self._cullable), dtype=bool)
            self._batched[np.flatnonzero(coloured)[self._batch.drawn]] = True
            row_of = {int(geom): row for row, geom in enumerate(ids)}
            self._batch_rows = np.array([row_of[int(geom)] for geom in self._batch.geoms], dtype=int)
        return self._batch, self._batched, rgba[self._batch_rows]

    def _draw(self, view: View, place: tuple[int, int], context: mujoco.MjrContext) -> None:
        """Render the scene as ``view`` sees it into its block of ``context``'s offscreen buffer."""
        self._frame(view)
        mujoco.mjr_render(mujoco.MjrRect(place[0], place[1], view.width_px, view.height_px), self._scene, context)

    def _update_scene(self, model: mujoco.MjModel, data: mujoco.MjData, culled: np.ndarray) -> None:
        """The scene of the world but the geoms ``culled`` (moved to :data:`CULLED_GROUP` by the caller, moved
        back here), flat-lit."""
        scene = self._scene
        try:
            mujoco.mjv_updateScene(model, data, self._option, self._perturb, self._camera,
                                   int(mujoco.mjtCatBit.mjCAT_STATIC) | int(mujoco.mjtCatBit.mjCAT_DYNAMIC), scene)
        finally:
            model.geom_group[culled] = 0
        # Flat shading: one ambient light of 1, nothing else, so colour = rgba (times the texture).
        light = scene.lights[0]
        light.headlight, light.castshadow = 1, 0
        light.ambient[:], light.diffuse[:], light.specular[:] = 1.0, 0.0, 0.0
        scene.nlight = 1

    def _layout(self, views: list[View]) -> tuple[list[tuple[int, int]], int, int]:
        """Where each view goes in the offscreen buffer (:func:`_place_views`), refused when they do not fit."""
        places, total, tallest = _place_views(views, self.width)
        if total > self.width or tallest > self.height:
            size = f"{sum(v.width_px for v in views)}x{max(v.height_px for v in views)}"
            raise SimulationError(f"mujoco backend: body-camera views of {size} px do not fit the "
                                  f"{self.width}x{self.height} offscreen buffer")
        return places, total, tallest

    def _visible(self, model: mujoco.MjModel, data: mujoco.MjData, views: list[View]) -> np.ndarray:
        """Whether each of the world's bounded geoms may show in each view, bool (views, geoms): both its
        bounding sphere and its bounding box (``geom_aabb``, turned with the geom: a trunk's is far tighter than
        its sphere) meet the view's frustum.

        Exact: a geom left out could not have covered a pixel (it lies beyond a side, the near or the far plane
        of the view), so the images are the same, and the GL draws only what the eyes face.
        """
        cullable = self._cullable
        if cullable.size == 0:
            return np.zeros((len(views), 0), dtype=bool)
        radii, aabb = model.geom_rbound[cullable], model.geom_aabb[cullable]
        centres, frames = data.geom_xpos[cullable], data.geom_xmat[cullable].reshape(-1, 3, 3)
        box_centres = centres + (frames @ aabb[:, :3, None])[..., 0]
        normals, offsets = _frustum_planes(tuple(tuple(view.fov_rad) for view in views))
        rotations = np.array([view.rotation for view in views])  # (V, 3, 3), columns: the view's axes
        normals = normals @ rotations.transpose(0, 2, 1)  # (V, 6, 3), world frame
        eyes = np.array([view.eye_m for view in views])
        shift = (offsets - (normals @ eyes[:, :, None])[..., 0]).reshape(-1, 1)
        normals = normals.reshape(-1, 3)
        # The sphere's centre at most its radius outside each plane, and the box's at most its reach along the
        # plane's normal (the half extents times the normal's part along each of the box's axes).
        reach = (np.abs(normals @ frames.transpose(1, 0, 2).reshape(3, -1)).reshape(len(normals), -1, 3)
                 * aabb[:, 3:]).sum(axis=2)
        inside = (normals @ centres.T + shift <= radii) & (normals @ box_centres.T + shift <= reach)
        return inside.reshape(len(views), 6, -1).all(axis=1)

    def _frame(self, view: View) -> None:
        """Both GL cameras at the view: pose, and a frustum with its own horizontal and vertical fields of view."""
        half_w = NEAR_M * np.tan(view.fov_rad[0] / 2.0)
        half_h = NEAR_M * np.tan(view.fov_rad[1] / 2.0)
        for camera in self._scene.camera:
            camera.pos[:] = view.eye_m
            camera.forward[:] = -view.rotation[:, 2]
            camera.up[:] = view.rotation[:, 1]
            camera.frustum_center, camera.frustum_width = 0.0, half_w
            camera.frustum_bottom, camera.frustum_top = -half_h, half_h
            camera.frustum_near, camera.frustum_far = NEAR_M, FAR_M
            camera.orthographic = 0

    def close(self) -> None:
        """Free what this model put in the GL context and give the context back for the next backend
        (:func:`gl_contexts.release`); in a forked child, touch nothing of the parent's."""
        if self._gl is None:
            return
        contexts = [context for context in (self._context, self._spectral_context) if context is not None]
        if self.pid == os.getpid():
            self._gl.make_current()
            for context in contexts:
                context.free()
        else:
            for context in contexts:
                gl_contexts.abandon(context)
        gl_contexts.release(self._gl, self.width, self.height, self.pid)
        self._gl = None
