"""The MuJoCo backend: one articulated body (a :class:`~neuronav.body.BodySpec`) in a :class:`~neuronav.world.World`.

Physics step
------------
Each physics step runs ``mj_step2`` then ``mj_step1`` (together exactly ``mj_step``), so between
steps every derived quantity (body poses, site positions, contacts) belongs to the current state:
reads are consistent, and adhesion and external forces are computed from the contacts and poses
of the state they act on. Position control lives in the model's actuators (see
:mod:`backends.mujoco.mjcf`): ``ctrl`` holds the joint targets, and MuJoCo evaluates
``clip(kp * (target - q) - kd * qdot, ±max_torque)`` every step.

Stability
---------
After every step the MuJoCo warning counters are checked: a bad position, velocity, acceleration
or control (NaN, inf or beyond 1e10) raises :class:`~neuronav.errors.SimulationError`; other warnings
(e.g. a full contact buffer) are recorded in :attr:`MujocoBackend.warnings`.

Cameras
-------
Planar cameras render directly. A spherical camera renders up to six 90° cube faces and stitches
them into an equirectangular image by nearest-neighbour lookup (see :func:`mjcf.panorama_lookup`).
``"follow"`` is a 640x480 view from behind and above the root, turned with the body's yaw.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from collections.abc import Iterable, Sequence  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from backends.mujoco.mjcf import FOLLOW_SIZE_PX, ModelNames, compile_model  # noqa: E402
from neuronav.backend import BackendBase, Capabilities, adhesion_port, start_pose  # noqa: E402
from neuronav.body import BodySpec  # noqa: E402
from neuronav.errors import ConfigError, PortError, SimulationError  # noqa: E402
from neuronav.ports import MotorSpec, SensorSpec  # noqa: E402
from neuronav.video import follow_axes  # noqa: E402
from neuronav.world import World  # noqa: E402

# Sensor names, units and per-agent shapes; "J", "C", "O", "W" are filled in from the body at load.
_SENSORS = (
    ("joint_pos", ("J",), "rad"),
    ("joint_vel", ("J",), "rad/s"),
    ("joint_torque", ("J",), "N*m"),
    ("contact_force", ("C", 3), "N"),
    ("body_pos", (3,), "m"),
    ("body_quat", (4,), ""),
    ("body_linvel", (3,), "m/s"),
    ("body_angvel", (3,), "rad/s"),
    ("heading", (1,), "rad"),
    ("velocity", (2,), "m/s"),
    ("position", (2,), "m"),
    ("odour_sites", ("O", 3), "m"),
    ("wind_sites", ("W", 3), "m"),
)
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
# The follow camera looks 25° down at a body on the floor (the tangent: its tilt toward the body's up).
FOLLOW_TILT = float(np.tan(np.radians(25.0)))


def _placeholder_capabilities() -> Capabilities:
    """Before load: every sensor name, with (1,)-shaped placeholders for the body-sized dimensions."""
    sensors = tuple(SensorSpec(name, tuple(1 if isinstance(n, str) else n for n in shape), units)
                    for name, shape, units in _SENSORS)
    return Capabilities(name="mujoco", sensors=sensors, motors=(MotorSpec("joint_targets", (1,), "rad"),),
                        batched=False, can_render=True)


class MujocoBackend(BackendBase):
    """One articulated body simulated by MuJoCo; implements the backend protocol (see DESIGN.md).

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

    def __init__(self, timestep_s: float = 0.002) -> None:
        if not (np.isfinite(timestep_s) and timestep_s > 0):
            raise ConfigError(f"mujoco backend: timestep_s must be a positive number of seconds, got {timestep_s!r}")
        self._timestep_s = float(timestep_s)
        self.capabilities = _placeholder_capabilities()
        self.model: mujoco.MjModel | None = None
        self.data: mujoco.MjData | None = None
        self.names: ModelNames | None = None
        self.body: BodySpec | None = None
        self.world: World | None = None
        self.warnings: list[str] = []
        # What the backend did on its own (e.g. lifting the body on reset): information, not a problem.
        self.notes: list[str] = []
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._pending: list[tuple[tuple[str, int], np.ndarray]] = []

    # -- protocol ------------------------------------------------------------------------------
    def load(self, world: World, bodies: Sequence[BodySpec]) -> None:
        """Build the MuJoCo model of ``world`` with exactly one body, then :meth:`reset`.

        Raises
        ------
        ConfigError
            Not exactly one :class:`BodySpec`, not a :class:`World`, or a model MuJoCo rejects.
        """
        if not isinstance(world, World):
            raise ConfigError(f"mujoco backend: load needs a neuronav World, got {type(world).__name__}")
        bodies = list(bodies)
        if len(bodies) != 1 or not isinstance(bodies[0], BodySpec):
            kinds = ", ".join(type(b).__name__ for b in bodies) or "nothing"
            raise ConfigError(f"the mujoco backend simulates exactly one BodySpec, got {kinds}")
        body = bodies[0]
        self._close_renderers()
        model, names = compile_model(world, body, self._timestep_s)
        self.model, self.data, self.names = model, mujoco.MjData(model), names
        self.body, self.world = body, world
        self._index(model, names, body)
        self.capabilities = self._capabilities(body)
        self.reset()

    def reset(self, seed: int | None = None, position_m=(0.0, 0.0), yaw_rad: float = 0.0,
              pitch_rad: float = 0.0, spin_rad: float = 0.0) -> None:
        """Rest pose, at rest, root at ``spawn_height_m`` above the terrain under ``position_m``, facing ``yaw_rad``.

        ``yaw_rad`` turns the body counter-clockwise from +x (its heading is then pi/2 - yaw);
        ``position_m=(x, y, z)``, ``pitch_rad`` and ``spin_rad`` place it anywhere, e.g. on a wall
        (:func:`neuronav.backend.start_pose`). Every pad's adhesion is switched fully on.
        MuJoCo is deterministic, so ``seed`` changes nothing; it is accepted for the protocol.
        """
        model, data = self._require()
        position, z_given, pose_quat = start_pose(position_m, yaw_rad, pitch_rad, "mujoco", spin_rad)
        x_m, y_m = float(position[0]), float(position[1])
        self._seed = seed
        mujoco.mj_resetData(model, data)
        ground_z = self.world.ground.height_at(x_m, y_m) + self.body.spawn_height_m
        root_pos = np.array([x_m, y_m, position[2] if z_given else ground_z])
        root_quat = np.zeros(4)
        mujoco.mju_mulQuat(root_quat, pose_quat, np.asarray(self.body.root.quat, float))
        if self._free_qpos is not None:
            data.qpos[self._free_qpos:self._free_qpos + 3] = root_pos
            data.qpos[self._free_qpos + 3:self._free_qpos + 7] = root_quat
        else:  # a root welded to the world: move the weld itself
            model.body_pos[self._root] = root_pos
            model.body_quat[self._root] = root_quat
        rest = self.body.rest_pose_rad()
        data.qpos[self._qpos] = rest
        data.ctrl[:] = rest
        self._pending.clear()
        mujoco.mj_forward(model, data)
        self._adhesion_scale = np.ones(len(self._contact_sites))
        if self._free_qpos is not None and not z_given:
            # On rough ground a claw can start inside a bump and stay trapped there: lift the body
            # until nothing of it starts inside the world (as the PyBullet backend does).
            lifted = 0.0
            for _ in range(20):  # contact depths are local: lift until no overlap is left
                sink = self._deepest_penetration_m(model, data)
                if sink <= 1e-4:
                    break
                data.qpos[self._free_qpos + 2] += sink + 1e-3
                lifted += sink + 1e-3
                mujoco.mj_forward(model, data)
            if lifted:
                note = "reset lifted the body above spawn_height_m so that no part starts inside the terrain"
                if not any(n.startswith(note) for n in self.notes):
                    self.notes.append(f"{note} (first at {[x_m, y_m]}, by {lifted:.4f} m)")
        self._torque = data.actuator_force.copy()
        self._forces_current = True
        self._seen = np.zeros(len(data.warning.number), dtype=int)
        self._diverged = ""  # the reason, once a step has failed

    def _deepest_penetration_m(self, model: mujoco.MjModel, data: mujoco.MjData) -> float:
        """How far the deepest body geom reaches into a world geom (0 when nothing overlaps)."""
        deepest = 0.0
        for i in range(data.ncon):
            contact = data.contact[i]
            bodies = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
            if (bodies[0] == 0) != (bodies[1] == 0):  # exactly one side is the world
                deepest = max(deepest, -float(contact.dist))
        return deepest

    @property
    def timestep(self) -> float:
        return self._timestep_s

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
        model, data = self._require()
        if int(n) != n or n < 0:
            raise ConfigError(f"mujoco step: n must be a whole number of steps >= 0, got {n!r}")
        if self._diverged:
            raise SimulationError(f"{self._diverged} (earlier); call reset() to continue")
        fatal_seen = self._seen[_FATAL_INDEX]
        forces = bool(self._pending) or self._adhesion_n > 0
        try:
            for _ in range(int(n)):
                if forces:
                    self._external_forces(model, data)
                mujoco.mj_step2(model, data)
                mujoco.mj_step1(model, data)
                if (data.warning.number[_FATAL_INDEX] > fatal_seen).any():
                    break  # MuJoCo has already reset the state; stop and report
        finally:
            if forces:
                data.xfrc_applied[:] = 0.0
            self._pending.clear()
            # mj_step1 leaves actuator_force alone: it still holds the torques applied in the last step.
            self._torque = data.actuator_force.copy()
            self._forces_current = False
        self._check(data)

    def model_summary(self) -> dict:
        """What MuJoCo compiled, read back from the model: for comparing backends on one spec.

        Returns
        -------
        dict
            ``segment_mass_kg`` {segment: kg}, ``joint_range_rad`` {joint: (low, high)},
            ``joint_axis_world`` {joint: unit (3,) at the current pose}, ``site_pos_m``
            {site: (3,) world position}.
        """
        model, data = self._require()
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
        model, data = self._require()
        if targets is not None:
            data.ctrl[:] = targets
        for _ in range(int(n)):
            mujoco.mj_step(model, data)
        mujoco.mj_step1(model, data)  # bring poses and contacts up to the new state, as step() does
        self._torque = data.actuator_force.copy()
        self._forces_current = False

    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]:
        """Sensor values, each with a leading batch dimension of 1; only the names asked for are computed."""
        model, data = self._require()
        out = {}
        for name in self._check_read(names):
            out[name] = np.asarray(self._sensor(name, model, data), dtype=float)[None].copy()
        return out

    def write(self, commands: dict[str, np.ndarray]) -> None:
        """``joint_targets``: shape (1, J) or (J,), rad, in :attr:`BodySpec.joint_names` order;
        ``adhesion``: (1, C), each contact site's fraction of the world's ``adhesion_n``."""
        self._require()
        commands = dict(commands)
        for name, value in commands.items():
            array = np.asarray(value, dtype=float)
            if name == "joint_targets" and array.ndim == 1:
                commands[name] = array[None]
        checked = self._check_write(commands, batch=1)
        if "joint_targets" in checked:
            self.data.ctrl[:] = checked["joint_targets"][0]
        if "adhesion" in checked:
            self._adhesion_scale = self._adhesion_fractions(checked["adhesion"])

    def render(self, camera: str) -> np.ndarray:
        """A uint8 (H, W, 3) image from a body camera, or ``"follow"`` (640x480, behind and above the root)."""
        model, data = self._require()
        if camera == "follow":
            renderer = self._renderer(*FOLLOW_SIZE_PX)
            renderer.update_scene(data, camera=self._follow_camera(data))
            return renderer.render().copy()
        if camera in self.names.cameras:
            spec = next(c for c in self.body.cameras if c.name == camera)
            renderer = self._renderer(spec.width_px, spec.height_px)
            renderer.update_scene(data, camera=self.names.cameras[camera])
            return renderer.render().copy()
        if camera in self.names.panoramas:
            pano = self.names.panoramas[camera]
            renderer = self._renderer(pano.face_px, pano.face_px)
            faces = []
            for face in pano.faces:
                renderer.update_scene(data, camera=face)
                faces.append(renderer.render().copy())
            return np.stack(faces)[pano.face_index, pano.rows, pano.cols]
        known = ["follow", *self.names.cameras, *self.names.panoramas]
        raise PortError(f"mujoco backend has no camera {camera!r}; available: {', '.join(known)}")

    def apply_force(self, body: int, site: str, force_n) -> None:
        """Add a world-frame force (3,) N at ``site`` (any site or segment name) during the next :meth:`step` call."""
        model, _ = self._require()
        if int(body) != 0:
            raise ConfigError(f"mujoco apply_force: body {body} out of range; this backend simulates body 0 only")
        force = np.asarray(force_n, dtype=float).reshape(-1)
        if force.shape != (3,) or not np.isfinite(force).all():
            raise ConfigError(f"mujoco apply_force: force_n must be 3 finite numbers (N, world frame), got {force_n!r}")
        site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        if site_id >= 0:
            self._pending.append((("site", site_id), force))
            return
        body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, site)
        if body_id >= 0 and site in {s.name for s in self.body.segments}:
            self._pending.append((("body", body_id), force))
            return
        known = [s.name for s in self.body.sites] + [s.name for s in self.body.segments]
        raise ConfigError(f"mujoco apply_force: unknown site {site!r}; sites and segments: {', '.join(known)}")

    def close(self) -> None:
        """Free the renderers (their GL contexts); the model stays readable."""
        self._close_renderers()

    # -- load helpers --------------------------------------------------------------------------
    def _index(self, model: mujoco.MjModel, names: ModelNames, body: BodySpec) -> None:
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
        self._odour = ids(mujoco.mjtObj.mjOBJ_SITE, [s.name for s in body.sites_of_kind("odour")])
        self._wind = ids(mujoco.mjtObj.mjOBJ_SITE, [s.name for s in body.sites_of_kind("wind")])
        self._adhesion_n = float(self.world.adhesion_n)
        # Follow distance: a few body sizes, from the rest pose's geom bounds around the root.
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        body_geoms = np.flatnonzero(model.geom_bodyid > 0)
        offsets = np.linalg.norm(data.geom_xpos[body_geoms] - data.xpos[self._root], axis=1)
        reach = offsets + model.geom_rbound[body_geoms]
        self._follow_distance_m = float(max(3.0 * reach.max(), 0.3))

    def _capabilities(self, body: BodySpec) -> Capabilities:
        sizes = {"J": len(body.joints), "C": len(body.sites_of_kind("contact")),
                 "O": len(body.sites_of_kind("odour")), "W": len(body.sites_of_kind("wind"))}
        sensors = []
        for name, shape, units in _SENSORS:
            shape = tuple(sizes[n] if isinstance(n, str) else n for n in shape)
            if all(n > 0 for n in shape):  # a body without e.g. odour sites offers no odour_sites
                sensors.append(SensorSpec(name, shape, units))
        motors = (MotorSpec("joint_targets", (sizes["J"],), "rad"),) if sizes["J"] else ()
        if sizes["C"]:
            motors += (adhesion_port(sizes["C"]),)
        return Capabilities(name="mujoco", sensors=tuple(sensors), motors=motors, batched=False, can_render=True)

    # -- step helpers --------------------------------------------------------------------------
    def _external_forces(self, model: mujoco.MjModel, data: mujoco.MjData, pending: bool = True) -> None:
        """Fill ``xfrc_applied`` with adhesion (and the pending forces) for the state about to be stepped."""
        xfrc = data.xfrc_applied
        xfrc[:] = 0.0
        for (kind, index), force in self._pending if pending else ():
            if kind == "site":
                body_id, point = model.site_bodyid[index], data.site_xpos[index]
            else:
                body_id, point = index, data.xpos[index]
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

    # -- sensors -------------------------------------------------------------------------------
    def _sensor(self, name: str, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        root = self._root
        if name == "joint_pos":
            return data.qpos[self._qpos]
        if name == "joint_vel":
            return data.qvel[self._dof]
        if name == "joint_torque":
            return self._torque[self._actuators]
        if name == "contact_force":
            return self._contact_forces(model, data)
        if name == "body_pos":
            return data.xpos[root]
        if name == "body_quat":
            return data.xquat[root]
        if name in ("body_linvel", "body_angvel", "velocity"):
            velocity = np.zeros(6)  # (angular, linear) of the root frame, world axes
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, root, velocity, 0)
            return {"body_linvel": velocity[3:], "body_angvel": velocity[:3], "velocity": velocity[3:5]}[name]
        if name == "heading":
            forward = data.xmat[root].reshape(3, 3)[:, 0]  # body +x in the world
            return np.array([np.arctan2(forward[0], forward[1])])
        if name == "position":
            return data.xpos[root, :2]
        if name == "odour_sites":
            return data.site_xpos[self._odour]
        if name == "wind_sites":
            return data.site_xpos[self._wind]
        raise PortError(f"mujoco backend: sensor {name!r} is not implemented")  # unreachable after _check_read

    def _contact_forces(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """World-frame total force ON each contact site's geoms, summed over their contacts."""
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
    def _renderer(self, width: int, height: int) -> mujoco.Renderer:
        key = (int(width), int(height))
        if key not in self._renderers:
            self._renderers[key] = mujoco.Renderer(self.model, height=key[1], width=key[0])
        return self._renderers[key]

    def _follow_camera(self, data: mujoco.MjData) -> mujoco.MjvCamera:
        forward, up = follow_axes(data.xmat[self._root].reshape(3, 3))
        view = forward - FOLLOW_TILT * up  # from behind and above, looking at the root
        view /= np.linalg.norm(view)
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.lookat[:] = data.xpos[self._root]
        camera.distance = self._follow_distance_m
        camera.azimuth = float(np.degrees(np.arctan2(view[1], view[0])))
        camera.elevation = float(np.degrees(np.arcsin(np.clip(view[2], -1.0, 1.0))))
        return camera

    def _close_renderers(self) -> None:
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()

    def _require(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        if self.model is None:
            raise SimulationError("mujoco backend: call load(world, [body_spec]) first")
        return self.model, self.data

    def __del__(self) -> None:
        try:
            self._close_renderers()
        except Exception:  # noqa: BLE001 -- interpreter shutdown: GL may already be gone
            pass
