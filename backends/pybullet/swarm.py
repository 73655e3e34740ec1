"""Several ants in one PyBullet world: one physics client, one multibody per ant, ants colliding.

:class:`PybulletSwarm` is the PyBullet twin of :class:`neuronav.backends.mujoco.swarm.MujocoSwarm`: a
:class:`~neuronav.spec.world.World` with N :class:`~neuronav.spec.body.BodySpec`\\ s, read and written with a
leading agent axis (``read`` (N, ...), ``write`` (N, ...), ``reset`` one start per ant), so a brain
compiled with ``batch=N`` binds the same way as on the kinematic backend. Ant i is the multibody
:attr:`PybulletSwarm.ants` [i], loaded from the URDF of its spec (:mod:`neuronav.backends.pybullet.urdf`);
its parts go by the spec's names, prefixed ``ant{i}/`` where the swarm names them.

As in the single-ant :class:`~neuronav.backends.pybullet.PybulletBackend`: every reset rebuilds the
simulation (bodies first, then the ground; the same calls give the same trajectory), position
control is ``clip(kp (target - q) - kd q', ±max_torque)`` applied through ``TORQUE_CONTROL`` at
every PyBullet step, and each ``timestep`` runs as many PyBullet steps as the single-ant backend
chooses for stable explicit joint control (``substeps``). PyBullet collides different multibodies
by default and a multibody's own links not at all (URDF self-collision off): ants touch the world
and each other, never themselves.

Sensors per ant: ``heading`` (N, 1), ``position`` (N, 2), ``velocity`` (N, 2), ``body_pos``
(N, 3), ``body_quat`` (N, 4), ``body_linvel`` (N, 3), ``body_angvel`` (N, 3), ``joint_pos`` /
``joint_vel`` (N, J); commands: ``joint_targets`` (N, J) rad. Not offered (the single-ant backend
has them): contact forces, adhesion, odour and wind, cameras; a world with ``adhesion_n`` > 0 is
refused. A reset stands each ant ``spawn_height_m`` above :meth:`Ground.height_at` under its start.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Sequence

import numpy as np

from neuronav.backends.pybullet.backend import DIVERGED_VELOCITY, GRAVITY_M_S2, VELOCITY_CLAMP, PybulletBackend
from neuronav.backends.pybullet.engine import EngineOutput, configure_client, pb
from neuronav.backends.pybullet.scene import build_ground, build_object
from neuronav.backends.pybullet.urdf import body_to_urdf
from neuronav.engine.articulated import check_swarm_load, check_timestep, swarm_capabilities
from neuronav.engine.backend import BackendBase, Capabilities, check_seed, quat_product, start_pose
from neuronav.errors import ConfigError, PortError, SimulationError
from neuronav.spec.body import BodySpec, quat_to_matrix
from neuronav.spec.world import World


class _Ant:
    """One ant's multibody and what reading and driving it needs."""

    def __init__(self, cid: int, body: BodySpec, urdf_path: str, fixed_base: bool, warnings: list) -> None:
        flags = pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_MAINTAIN_LINK_ORDER
        with EngineOutput(warnings):
            self.id = pb.loadURDF(urdf_path, useFixedBase=fixed_base, flags=flags, physicsClientId=cid)
        # The single-ant backend's velocity clamp (see VELOCITY_CLAMP there), which its divergence check assumes.
        pb.changeDynamics(self.id, -1, maxJointVelocity=VELOCITY_CLAMP, physicsClientId=cid)
        joint_index, movable = {}, []
        self.link_index = {}  # URDF link name -> PyBullet link index (the base: -1)
        for i in range(pb.getNumJoints(self.id, physicsClientId=cid)):
            info = pb.getJointInfo(self.id, i, physicsClientId=cid)
            joint_index[info[1].decode()] = i
            self.link_index[info[12].decode()] = i
            if info[2] != pb.JOINT_FIXED:
                movable.append(i)
        if movable:  # PyBullet's velocity motors off: torques come from the control law
            pb.setJointMotorControlArray(self.id, movable, pb.VELOCITY_CONTROL, forces=[0.0] * len(movable),
                                         physicsClientId=cid)
        self.joints = [joint_index[j.name] for j in body.joints]
        self.kp = np.array([j.kp for j in body.joints])
        self.kd = np.array([j.kd for j in body.joints])
        self.limit = np.array([j.max_torque_nm for j in body.joints])
        self.targets = body.rest_pose_rad().astype(float)
        dynamics = pb.getDynamicsInfo(self.id, -1, physicsClientId=cid)
        self.inertial_pos = np.array(dynamics[3], float)
        self.inertial_rot = quat_to_matrix((dynamics[4][3], *dynamics[4][:3]))
        x, y, z, w = dynamics[4]
        self.inertial_conj = np.array([w, -x, -y, -z]) / np.linalg.norm(dynamics[4])

    def place(self, cid: int, frame_pos: np.ndarray, frame_rot: np.ndarray, rest_rad: np.ndarray) -> None:
        """The root frame at a pose, the joints at rest, everything still."""
        from scipy.spatial.transform import Rotation

        com_pos = frame_pos + frame_rot @ self.inertial_pos
        com_quat = Rotation.from_matrix(frame_rot @ self.inertial_rot).as_quat()
        pb.resetBasePositionAndOrientation(self.id, com_pos.tolist(), com_quat.tolist(), physicsClientId=cid)
        pb.resetBaseVelocity(self.id, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
        for index, angle in zip(self.joints, rest_rad):
            pb.resetJointState(self.id, index, float(angle), 0.0, physicsClientId=cid)

    def control(self, cid: int) -> float:
        """Apply this step's control torques; returns the fastest joint speed (NaN when not finite)."""
        q, qd, _, _ = zip(*pb.getJointStates(self.id, self.joints, physicsClientId=cid))
        q, qd = np.array(q), np.array(qd)
        torque = np.minimum(np.maximum(self.kp * (self.targets - q) - self.kd * qd, -self.limit), self.limit)
        pb.setJointMotorControlArray(self.id, self.joints, pb.TORQUE_CONTROL, forces=torque, physicsClientId=cid)
        fastest = float(np.abs(qd).max())
        return fastest if np.isfinite(q).all() else float("nan")

    def root(self, cid: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The root frame's position (3,), quaternion (w, x, y, z) and rotation (3, 3)."""
        com_pos, (x, y, z, w) = pb.getBasePositionAndOrientation(self.id, physicsClientId=cid)
        quat = quat_product(np.array([w, x, y, z]), self.inertial_conj)
        rotation = quat_to_matrix(quat)
        return np.asarray(com_pos) - rotation @ self.inertial_pos, quat, rotation

    def root_velocity(self, cid: int) -> tuple[np.ndarray, np.ndarray]:
        """The root frame origin's linear and angular velocity (3,) each, world axes."""
        _, rotation = self.root(cid)[1:]
        linear, angular = (np.asarray(v, float) for v in pb.getBaseVelocity(self.id, physicsClientId=cid))
        offset = rotation @ self.inertial_pos
        return linear + np.cross(angular, -offset), angular


class PybulletSwarm(BackendBase):
    """N articulated ants in one PyBullet client, read and written with a leading agent axis (see the module doc).

    Parameters
    ----------
    timestep_s : float
        Physics step (default 2 ms).
    solver_iterations : int
        Constraint-solver iterations per PyBullet step (the single-ant backend's default, 50).
    """

    engine = "pybullet"

    def __init__(self, timestep_s: float = 0.002, solver_iterations: int = 50) -> None:
        self._timestep_s = check_timestep("pybullet swarm", timestep_s)
        self._iterations = int(solver_iterations)
        self.capabilities = Capabilities(name="pybullet", sensors=(), motors=(), batched=True)
        self.bodies: list[BodySpec] = []
        self.world: World | None = None
        self.warnings: list[str] = []
        self.substeps = 1
        self.ants: list[int] = []
        self._client: int | None = None
        self._tmpdir: tempfile.TemporaryDirectory | None = None
        self._inner_steps = 0

    # -- building -----------------------------------------------------------------------------------
    def load(self, world: World, bodies: Sequence[BodySpec]) -> None:
        """Build ``world`` with every BodySpec of ``bodies`` in one client, then reset.

        Raises
        ------
        ConfigError
            Not a World, no bodies, not BodySpecs, different joint counts, adhesion, or a bad object.
        """
        bodies = check_swarm_load("pybullet", world, bodies)
        self.close()
        self._tmpdir = tempfile.TemporaryDirectory(prefix="neuronav_pybullet_swarm_")
        self._urdfs = []
        substeps = 1
        for index, body in enumerate(bodies):
            if body in bodies[:index]:  # the same spec again: its URDF and substeps are known
                self._urdfs.append(self._urdfs[bodies.index(body)])
                continue
            urdf = body_to_urdf(body)
            path = os.path.join(self._tmpdir.name, f"ant{index}.urdf")
            with open(path, "w") as handle:
                handle.write(urdf.text)
            self._urdfs.append((path, urdf.fixed_base, urdf))
            with PybulletBackend(timestep_s=self._timestep_s, solver_iterations=self._iterations) as single:
                single.load(World(ground=world.ground), [body])  # the substeps it needs alone
                substeps = max(substeps, single.substeps)
        self.substeps = substeps
        self._client = pb.connect(pb.DIRECT)
        if self._client < 0:
            raise SimulationError("pybullet swarm: could not start a DIRECT physics client")
        self.bodies, self.world = bodies, world
        self.capabilities = swarm_capabilities("pybullet", len(bodies[0].joints))
        self.reset()

    def _build(self) -> None:
        cid = self._client
        configure_client(cid, self._timestep_s, self.substeps, self._iterations, GRAVITY_M_S2)
        self._ants = [_Ant(cid, body, path, fixed, self.warnings)
                      for body, (path, fixed, _) in zip(self.bodies, self._urdfs)]
        self.ants = [ant.id for ant in self._ants]
        for ant, (_, _, urdf) in zip(self._ants, self._urdfs):
            ant.link_index[urdf.links[0].name] = -1
        self._pushes: dict[tuple[int, int], np.ndarray] = {}
        build_ground(cid, self.world, self._tmpdir.name)
        for obj in self.world.objects:
            build_object(cid, self.world, obj)

    # -- protocol -----------------------------------------------------------------------------------
    @property
    def batch(self) -> int:
        self._require()
        return len(self.bodies)

    @property
    def timestep(self) -> float:
        return self._timestep_s

    @property
    def time(self) -> float:
        return self._inner_steps / self.substeps * self._timestep_s

    def reset(self, seed: int | None = None, position_m=None, yaw_rad=None, heading_rad=None) -> None:
        """Rebuild the simulation and stand every ant at rest at its start (the MuJoCo swarm's arguments:
        ``position_m`` (N, 2) or (2,), default a row 2 m apart; ``yaw_rad`` or ``heading_rad``, (N,) or one)."""
        self._require()
        check_seed("pybullet swarm", seed)
        n = len(self.bodies)
        if yaw_rad is not None and heading_rad is not None:
            raise ConfigError("pybullet swarm reset: give yaw_rad or heading_rad, not both")
        if heading_rad is not None:
            yaw_rad = np.pi / 2 - np.asarray(heading_rad, float)
        default = np.column_stack([2.0 * np.arange(n), np.zeros(n)])
        try:
            starts = np.broadcast_to(np.asarray(default if position_m is None else position_m, float), (n, 2))
            yaws = np.broadcast_to(np.asarray(0.0 if yaw_rad is None else yaw_rad, float), (n,))
        except ValueError:
            raise ConfigError(f"pybullet swarm reset: position_m must be (x, y) or ({n}, 2) m and yaw_rad / "
                              f"heading_rad one number or {n}, got {np.shape(position_m)} and "
                              f"{np.shape(yaw_rad)}") from None
        self._build()
        for ant, body, start, yaw in zip(self._ants, self.bodies, starts, yaws):
            position, _, quat = start_pose(start, float(yaw), 0.0, "pybullet swarm")
            position[2] = float(self.world.ground.height_at(position[0], position[1])) + body.spawn_height_m
            rotation = quat_to_matrix(quat)  # the root frame's turn, as the single-ant backend places it
            ant.place(self._client, position, rotation, body.rest_pose_rad())
            ant.targets = body.rest_pose_rad().astype(float)
        self._inner_steps = 0

    def step(self, n: int = 1) -> None:
        """Advance ``n`` timesteps (``n * substeps`` PyBullet steps), the control law at every one.

        Raises
        ------
        SimulationError
            When a joint's state stops being finite or reaches PyBullet's velocity clamp.
        """
        self._require()
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
            raise ConfigError(f"pybullet swarm step: n must be a whole number of steps >= 0, got {n!r}")
        cid = self._client
        for _ in range(int(n) * self.substeps):
            for index, ant in enumerate(self._ants):
                fastest = ant.control(cid)
                if not fastest < DIVERGED_VELOCITY:  # NaN fails too
                    raise SimulationError(f"pybullet swarm diverged at t = {self.time:.4f} s: ant {index}'s joints "
                                          f"are not finite or reached PyBullet's velocity clamp")
            for (ant, link), force in self._pushes.items():  # PyBullet forgets external forces after a step
                position = (pb.getBasePositionAndOrientation(ant, physicsClientId=cid)[0] if link < 0 else
                            pb.getLinkState(ant, link, computeForwardKinematics=1, physicsClientId=cid)[4])
                pb.applyExternalForce(ant, link, force.tolist(), list(position), pb.WORLD_FRAME, physicsClientId=cid)
            pb.stepSimulation(physicsClientId=cid)
            self._inner_steps += 1

    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]:
        """Each sensor with the agent axis first, (N, ...)."""
        self._require()
        cid = self._client
        names = self._check_read(names)
        roots = [ant.root(cid) for ant in self._ants] if set(names) - {"joint_pos", "joint_vel"} else []
        out: dict[str, np.ndarray] = {}
        velocities = None
        for name in names:
            if name in ("body_pos", "position"):
                out[name] = np.array([pos[:3 if name == "body_pos" else 2] for pos, _, _ in roots])
            elif name == "body_quat":
                out[name] = np.array([quat if quat[0] >= 0 else -quat for _, quat, _ in roots])
            elif name == "heading":
                out[name] = np.array([[np.arctan2(rot[0, 0], rot[1, 0])] for _, _, rot in roots])
            elif name in ("body_linvel", "body_angvel", "velocity"):
                if velocities is None:
                    velocities = [ant.root_velocity(cid) for ant in self._ants]
                which = 1 if name == "body_angvel" else 0
                out[name] = np.array([v[which][:2 if name == "velocity" else 3] for v in velocities])
            else:
                column = 0 if name == "joint_pos" else 1
                out[name] = np.array([[state[column] for state in pb.getJointStates(ant.id, ant.joints,
                                                                                   physicsClientId=cid)]
                                      for ant in self._ants])
        return out

    def write(self, commands: dict[str, np.ndarray]) -> None:
        """``joint_targets`` (N, J) rad, finite, held until overwritten."""
        self._require()
        checked = self._check_write(commands, len(self.bodies))
        if "joint_targets" in checked:
            targets = checked["joint_targets"]
            if not np.isfinite(targets).all():
                raise PortError("pybullet swarm: joint_targets must be finite (rad)")
            for ant, row in zip(self._ants, targets):
                ant.targets = row.copy()

    def ant_contacts(self) -> np.ndarray:
        """Bool (N,): which ants touch another ant now."""
        self._require()
        touching = np.zeros(len(self._ants), dtype=bool)
        index = {ant.id: i for i, ant in enumerate(self._ants)}
        for i, ant in enumerate(self._ants):
            for point in pb.getContactPoints(bodyA=ant.id, physicsClientId=self._client):
                other = index.get(point[2])
                if other is not None and other != i:
                    touching[i] = touching[other] = True
        return touching

    def ant_overlap_m(self) -> float:
        """How deep the deepest contact between two different ants is (0 when none overlap)."""
        self._require()
        ids, deepest = set(self.ants), 0.0
        for ant in self.ants:
            for point in pb.getContactPoints(bodyA=ant, physicsClientId=self._client):
                if point[2] in ids and point[2] != ant:
                    deepest = max(deepest, -float(point[8]))
        return deepest

    def apply_force(self, body: int, site: str, force_n) -> None:
        """Push ant ``body``'s segment ``site`` with a world-frame force (3,) N at every PyBullet step until
        the next reset or the next call for that segment (the MuJoCo swarm's rule). On the root segment
        the force acts at its centre of mass, on the others at their link frame's origin."""
        self._require()
        if isinstance(body, bool) or not isinstance(body, int | np.integer) or not 0 <= body < len(self.bodies):
            raise ConfigError(f"pybullet swarm apply_force: body {body!r} out of range 0..{len(self.bodies) - 1}")
        force = np.asarray(force_n, dtype=float).reshape(-1)
        if force.shape != (3,) or not np.isfinite(force).all():
            raise ConfigError(f"pybullet swarm apply_force: force_n must be 3 finite numbers (N), got {force_n!r}")
        urdf = self._urdfs[body][2]
        if site not in urdf.segment_link:
            raise ConfigError(f"pybullet swarm apply_force: ant {body} has no segment {site!r}; segments: "
                              f"{', '.join(s.name for s in self.bodies[body].segments)}")
        ant = self._ants[body]
        self._pushes[(ant.id, ant.link_index[urdf.segment_link[site]])] = force

    def render(self, camera: str) -> np.ndarray:
        raise PortError("pybullet swarm: no cameras (render a single ant with the pybullet backend)")

    def close(self) -> None:
        """Disconnect the client and delete the URDFs."""
        if self._client is not None:
            try:
                pb.disconnect(physicsClientId=self._client)
            except pb.error:
                pass
            self._client = None
        if self._tmpdir is not None:
            self._tmpdir.cleanup()
            self._tmpdir = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - never raise from a finaliser
            pass

    def _require(self) -> None:
        if self._client is None or not self.bodies:
            raise SimulationError("pybullet swarm: call load(world, [body_spec, ...]) first (or it was closed)")
