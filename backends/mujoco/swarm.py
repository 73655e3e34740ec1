"""Several ants in one MuJoCo world: one model, each ant's names prefixed, ants colliding with each other.

:class:`MujocoSwarm` loads a :class:`~neuronav.spec.world.World` with N :class:`~neuronav.spec.body.BodySpec`\\ s
(N copies of one, or different ones) into one MuJoCo model and reads and writes them with a leading
agent axis, as the kinematic backend batches its point agents: ``read`` gives (N, ...) arrays,
``write`` takes (N, ...) commands, ``reset`` takes one start pose per ant, so a brain compiled with
``batch=N`` binds the same way on both. Ant i's segments, joints, geoms, sites and actuators are
named ``ant{i}/<spec name>`` (:func:`prefixed_body`); the world's elements keep their names.

The world is built by :mod:`neuronav.backends.mujoco.mjcf` exactly as for one ant (same options, ground,
objects, trails); each ant is added by the same translation of its spec. The physics step is the
single-ant backend's (``mj_step2`` then ``mj_step1``, the warning counters checked after it).

Collisions
----------
An ant's geoms touch the world's and every other ant's geoms, never their own ant's (the single-ant
rule: the legs may cross). MuJoCo collides two geoms when ``contype`` of one shares a bit with
``conaffinity`` of the other: bit 0 is the world's; ant i owns bit i + 1, its ``contype`` is bit 0 |
bit i + 1, its ``conaffinity`` every ant bit but its own. 32-bit masks leave 31 ant bits: at most
:data:`MAX_ANTS` ants per model.

Sensors (per ant, with the agent axis first): ``heading`` (N, 1) rad, ``position`` (N, 2) m,
``velocity`` (N, 2) m/s, ``body_pos`` (N, 3), ``body_quat`` (N, 4), ``body_linvel`` (N, 3),
``body_angvel`` (N, 3), ``joint_pos`` / ``joint_vel`` (N, J): the meanings of
:data:`neuronav.engine.backend.ARTICULATED_SENSORS`. Commands: ``joint_targets`` (N, J) rad. All ants
must have the same J. Not offered here (the single-ant :class:`~neuronav.backends.mujoco.MujocoBackend` has
them): contact forces, adhesion, odour and wind, cameras and videos; a world with ``adhesion_n`` > 0
is refused. A reset stands each ant on the terrain under its start (``spawn_height_m`` above
:meth:`Ground.height_at`) without the single-ant backend's lift out of rough ground.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from collections.abc import Iterable, Sequence  # noqa: E402
from dataclasses import replace  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from neuronav.backends.mujoco.backend import _FATAL_INDEX, _FATAL_WARNINGS  # noqa: E402
from neuronav.backends.mujoco.mjcf import (  # noqa: E402
    WORLD_CONTYPE,
    ModelNames,
    _body,
    _options,
    _trails,
    _visual,
    _world,
)
from neuronav.engine.articulated import check_swarm_load, check_timestep, swarm_capabilities  # noqa: E402
from neuronav.engine.backend import BackendBase, Capabilities, check_seed, start_pose  # noqa: E402
from neuronav.errors import ConfigError, PortError, SimulationError  # noqa: E402
from neuronav.senses.trail_floor import trail_floor  # noqa: E402
from neuronav.spec.body import BodySpec  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

MAX_ANTS = 31  # one contype bit per ant besides the world's bit 0
ANT_PREFIX = "ant{index}/"



def prefixed_body(body: BodySpec, prefix: str) -> BodySpec:
    """A copy of ``body`` with ``prefix`` before every segment, joint, site, camera and compound-eye name.

    Geom names are built from segment names by the translation, so they carry the prefix too.
    """
    segments = tuple(replace(s, name=prefix + s.name, parent=None if s.parent is None else prefix + s.parent,
                             joint=None if s.joint is None else replace(s.joint, name=prefix + s.joint.name))
                     for s in body.segments)
    sites = tuple(replace(s, name=prefix + s.name, segment=prefix + s.segment) for s in body.sites)
    cameras = tuple(replace(c, name=prefix + c.name, segment=prefix + c.segment) for c in body.cameras)
    eyes = tuple(replace(e, name=prefix + e.name, segment=prefix + e.segment) for e in body.compound_eyes)
    return replace(body, name=prefix + body.name, segments=segments, sites=sites, cameras=cameras,
                   compound_eyes=eyes)


def ant_collision_masks(index: int) -> tuple[int, int]:
    """(contype, conaffinity) of ant ``index``'s geoms: touch the world and the other ants, not itself."""
    own = 1 << (index + 1)
    every_ant = sum(1 << (i + 1) for i in range(MAX_ANTS))
    # As signed 32-bit ints, as MuJoCo stores them.
    affinity = (every_ant & ~own) & 0xFFFFFFFF
    affinity = affinity - (1 << 32) if affinity >= 1 << 31 else affinity
    return WORLD_CONTYPE | own, affinity


def build_swarm_spec(world: World, bodies: Sequence[BodySpec],
                     timestep_s: float = 0.002) -> tuple[mujoco.MjSpec, list[ModelNames]]:
    """The world and every ant (named ``ant{i}/...``) in one uncompiled ``MjSpec``."""
    spec = mujoco.MjSpec()
    spec.modelname = f"swarm of {len(bodies)}"
    spec.compiler.degree = False
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = True
    _options(spec, timestep_s, sticky=world.adhesion_n > 0)
    floor = trail_floor(world)
    _visual(spec, bodies[0], world)
    _world(spec, world)
    if floor is not None:
        _trails(spec, floor)
    names = []
    for index, body in enumerate(bodies):
        ant = _body(spec, prefixed_body(body, ANT_PREFIX.format(index=index)))
        contype, conaffinity = ant_collision_masks(index)
        for geom_name in ant.geoms.values():
            geom = spec.geom(geom_name)
            geom.contype, geom.conaffinity = contype, conaffinity
        names.append(ant)
    # More bodies, more contacts: room for every ant's feet and their meetings.
    return spec, names


class MujocoSwarm(BackendBase):
    """N articulated ants in one MuJoCo model, read and written with a leading agent axis (see the module doc).

    Parameters
    ----------
    timestep_s : float
        Physics step (default 2 ms, as the single-ant backend).

    Attributes
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
    names : list of ModelNames
        Where each ant's spec elements went (prefixed names).
    warnings : list of str
        Non-fatal MuJoCo warnings seen so far.
    """

    engine = "mujoco"

    def __init__(self, timestep_s: float = 0.002) -> None:
        self._timestep_s = check_timestep("mujoco swarm", timestep_s)
        self.capabilities = Capabilities(name="mujoco", sensors=(), motors=(), batched=True)
        self.model: mujoco.MjModel | None = None
        self.data: mujoco.MjData | None = None
        self.names: list[ModelNames] = []
        self.bodies: list[BodySpec] = []
        self.world: World | None = None
        self.warnings: list[str] = []

    # -- building --------------------------------------------------------------------------------------
    def load(self, world: World, bodies: Sequence[BodySpec]) -> None:
        """Build ``world`` with every BodySpec of ``bodies`` (1 to :data:`MAX_ANTS`) in one model, then reset.

        Raises
        ------
        ConfigError
            Not a World, no bodies, too many, not BodySpecs, different joint counts, or adhesion.
        """
        bodies = check_swarm_load("mujoco", world, bodies, MAX_ANTS)
        spec, names = build_swarm_spec(world, bodies, self._timestep_s)
        try:
            model = spec.compile()
        except ValueError as error:
            raise ConfigError(f"mujoco could not compile the swarm of {len(bodies)}: {error}") from None
        self.model, self.data, self.names = model, mujoco.MjData(model), names
        self.bodies, self.world = bodies, world
        self._index()
        count, joints = len(bodies), len(bodies[0].joints)
        self.capabilities = swarm_capabilities("mujoco", joints)
        self._count = count
        self.reset()

    def _index(self) -> None:
        model = self.model

        def ids(kind, items):
            found = np.array([mujoco.mj_name2id(model, kind, n) for n in items], dtype=int)
            assert (found >= 0).all(), f"mujoco swarm: a {kind} of {items} is missing from the model"
            return found

        self._roots = np.array([ids(mujoco.mjtObj.mjOBJ_BODY, [n.root])[0] for n in self.names])
        self._free_qpos = np.array([model.jnt_qposadr[ids(mujoco.mjtObj.mjOBJ_JOINT, [n.free_joint])[0]]
                                    for n in self.names])
        self._qpos = np.stack([model.jnt_qposadr[ids(mujoco.mjtObj.mjOBJ_JOINT, n.joints)] for n in self.names])
        self._dof = np.stack([model.jnt_dofadr[ids(mujoco.mjtObj.mjOBJ_JOINT, n.joints)] for n in self.names])
        self._actuators = np.stack([ids(mujoco.mjtObj.mjOBJ_ACTUATOR, n.joints) for n in self.names])
        # Which ant each MuJoCo body belongs to (-1: the world's).
        self._ant_of_body = np.full(model.nbody, -1, dtype=int)
        for index, root in enumerate(self._roots):
            self._ant_of_body[self._subtree(root)] = index
        self._ant_of_geom = self._ant_of_body[model.geom_bodyid]

    def _subtree(self, root: int) -> np.ndarray:
        parents = self.model.body_parentid
        inside = np.zeros(self.model.nbody, dtype=bool)
        inside[root] = True
        for body in range(root + 1, self.model.nbody):  # MuJoCo numbers children after their parents
            inside[body] = inside[parents[body]]
        return np.flatnonzero(inside)

    # -- protocol ---------------------------------------------------------------------------------------
    @property
    def batch(self) -> int:
        """The number of ants."""
        self._require()
        return self._count

    @property
    def timestep(self) -> float:
        return self._timestep_s

    @property
    def time(self) -> float:
        return 0.0 if self.data is None else float(self.data.time)

    def reset(self, seed: int | None = None, position_m=None, yaw_rad=None, heading_rad=None) -> None:
        """Every ant at its rest pose, at rest, standing on the terrain at its start.

        Parameters
        ----------
        seed : None or int >= 0
            Accepted for the protocol (the engine is deterministic).
        position_m : array (N, 2) or (2,), optional
            Starts (x, y) m; default: ant i at (2 i, 0), in a row 2 m apart.
        yaw_rad, heading_rad : array (N,) or float, optional
            Facing: counter-clockwise from +x, or the kinematic backend's heading (clockwise from
            +y, heading = π/2 − yaw); at most one of them. Default yaw 0.
        """
        self._require()
        check_seed("mujoco swarm", seed)
        n = self._count
        if yaw_rad is not None and heading_rad is not None:
            raise ConfigError("mujoco swarm reset: give yaw_rad or heading_rad, not both")
        if heading_rad is not None:
            yaw_rad = np.pi / 2 - np.asarray(heading_rad, float)
        try:
            starts = np.broadcast_to(np.asarray(position_m if position_m is not None
                                                else np.column_stack([2.0 * np.arange(n), np.zeros(n)]),
                                                float), (n, 2))
            yaws = np.broadcast_to(np.asarray(0.0 if yaw_rad is None else yaw_rad, float), (n,))
        except ValueError:
            raise ConfigError(f"mujoco swarm reset: position_m must be (x, y) or ({n}, 2) m and yaw_rad / heading_rad "
                              f"one number or {n}, got {np.shape(position_m)} and {np.shape(yaw_rad)}") from None
        model, data = self.model, self.data
        mujoco.mj_resetData(model, data)
        for index, body in enumerate(self.bodies):
            position, _, quat = start_pose(starts[index], float(yaws[index]), 0.0, "mujoco swarm")
            position[2] = float(self.world.ground.height_at(position[0], position[1])) + body.spawn_height_m
            root_quat = np.zeros(4)
            mujoco.mju_mulQuat(root_quat, quat, np.asarray(body.root.quat, float))
            address = self._free_qpos[index]
            data.qpos[address:address + 3] = position
            data.qpos[address + 3:address + 7] = root_quat
            data.qpos[self._qpos[index]] = body.rest_pose_rad()
            data.ctrl[self._actuators[index]] = body.rest_pose_rad()
        mujoco.mj_forward(model, data)
        self._seen = np.zeros(len(data.warning.number), dtype=int)
        self._diverged = ""

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps (``mj_step2`` then ``mj_step1``, as the single-ant backend)."""
        model, data = self._require()
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
            raise ConfigError(f"mujoco swarm step: n must be a whole number of steps >= 0, got {n!r}")
        if self._diverged:
            raise SimulationError(f"{self._diverged} (earlier); call reset() to continue")
        fatal_seen = self._seen[_FATAL_INDEX]
        for _ in range(int(n)):
            mujoco.mj_step2(model, data)
            mujoco.mj_step1(model, data)
            if (data.warning.number[_FATAL_INDEX] > fatal_seen).any():
                break
        self._check(data)

    def _check(self, data: mujoco.MjData) -> None:
        counts = np.asarray(data.warning.number, dtype=int)
        fatal = []
        for index in np.flatnonzero(counts > self._seen):
            warning = mujoco.mjtWarning(int(index))
            message = f"mujoco {warning.name} at t={data.time:.4f} s (seen {counts[index]} times)"
            self.warnings.append(message)
            if warning in _FATAL_WARNINGS:
                fatal.append(f"{message}: {_FATAL_WARNINGS[warning]}")
        self._seen = counts.copy()
        if fatal:
            self._diverged = f"mujoco swarm diverged: {'; '.join(fatal)}"
        elif not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
            self._diverged = f"mujoco swarm diverged at t={data.time:.4f} s: the state is not finite"
        if self._diverged:
            raise SimulationError(f"{self._diverged}; call reset() to continue")

    def read(self, names: Iterable[str]) -> dict[str, np.ndarray]:
        """Each sensor with the agent axis first, (N, ...); only the names asked for are computed."""
        self._require()
        data, roots = self.data, self._roots
        out: dict[str, np.ndarray] = {}
        velocity = None
        for name in self._check_read(names):
            if name in ("body_pos", "position"):
                out[name] = data.xpos[roots, :3 if name == "body_pos" else 2].copy()
            elif name == "body_quat":
                quat = data.xquat[roots].copy()
                out[name] = np.where(quat[:, :1] < 0, -quat, quat)  # w >= 0, as every backend reports
            elif name == "heading":
                forward = data.xmat[roots].reshape(-1, 3, 3)[:, :, 0]
                out[name] = np.arctan2(forward[:, 0], forward[:, 1])[:, None]
            elif name in ("body_linvel", "body_angvel", "velocity"):
                if velocity is None:
                    velocity = self._root_velocities()
                linear, angular = velocity
                out[name] = {"body_linvel": linear, "body_angvel": angular, "velocity": linear[:, :2]}[name].copy()
            elif name == "joint_pos":
                out[name] = data.qpos[self._qpos].copy()
            else:  # joint_vel
                out[name] = data.qvel[self._dof].copy()
        return out

    def _root_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        linear, angular = np.zeros((self._count, 3)), np.zeros((self._count, 3))
        velocity = np.zeros(6)
        for index, root in enumerate(self._roots):
            mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, int(root), velocity, 0)
            linear[index], angular[index] = velocity[3:], velocity[:3]
        return linear, angular

    def write(self, commands: dict[str, np.ndarray]) -> None:
        """``joint_targets`` (N, J) rad, finite, held until overwritten."""
        self._require()
        checked = self._check_write(commands, self._count)
        if "joint_targets" in checked:
            targets = checked["joint_targets"]
            if not np.isfinite(targets).all():
                raise PortError("mujoco swarm: joint_targets must be finite (rad)")
            self.data.ctrl[self._actuators] = targets

    def ant_contacts(self) -> np.ndarray:
        """Bool (N,): which ants touch another ant now (a contact between geoms of two different ants)."""
        self._require()
        touching = np.zeros(self._count, dtype=bool)
        ncon = self.data.ncon
        if ncon:
            first = self._ant_of_geom[self.data.contact.geom1[:ncon]]
            second = self._ant_of_geom[self.data.contact.geom2[:ncon]]
            between = (first >= 0) & (second >= 0) & (first != second)
            touching[first[between]] = True
            touching[second[between]] = True
        return touching

    def ant_overlap_m(self) -> float:
        """How deep the deepest contact between two different ants is (0 when none overlap)."""
        self._require()
        ncon = self.data.ncon
        if not ncon:
            return 0.0
        contact = self.data.contact
        first, second = self._ant_of_geom[contact.geom1[:ncon]], self._ant_of_geom[contact.geom2[:ncon]]
        between = (first >= 0) & (second >= 0) & (first != second)
        return float(max(0.0, -contact.dist[:ncon][between].min())) if between.any() else 0.0

    def render(self, camera: str) -> np.ndarray:
        raise PortError("mujoco swarm: no cameras (render a single ant with the mujoco backend)")

    def apply_force(self, body: int, site: str, force_n) -> None:
        """Push ant ``body`` at the origin of its segment ``site`` with a world-frame force (3,) N, held
        in ``xfrc_applied`` until the next reset or the next call for that segment."""
        self._require()
        if isinstance(body, bool) or not isinstance(body, int | np.integer) or not 0 <= body < self._count:
            raise ConfigError(f"mujoco swarm apply_force: body {body!r} out of range 0..{self._count - 1}")
        force = np.asarray(force_n, dtype=float).reshape(-1)
        if force.shape != (3,) or not np.isfinite(force).all():
            raise ConfigError(f"mujoco swarm apply_force: force_n must be 3 finite numbers (N), got {force_n!r}")
        name = ANT_PREFIX.format(index=body) + site
        body_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if body_id < 0:
            raise ConfigError(f"mujoco swarm apply_force: ant {body} has no segment {site!r}; segments: "
                              f"{', '.join(s.name for s in self.bodies[body].segments)}")
        # xfrc_applied acts at the centre of mass: the torque of a force at the frame origin about it.
        offset = self.data.xpos[body_id] - self.data.xipos[body_id]
        self.data.xfrc_applied[body_id] = np.concatenate([force, np.cross(offset, force)])

    def _require(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        if self.model is None:
            raise SimulationError("mujoco swarm: call load(world, [body_spec, ...]) first")
        return self.model, self.data
