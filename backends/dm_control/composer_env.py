"""The ant, a world and a navigation task as dm_control ``composer`` pieces: a ``dm_env`` environment.

- :class:`AntEntity` — the ant as a ``composer.Entity``; :class:`WorldArena` — a
  :class:`~neuronav.spec.world.World` as a ``composer.Arena``. Both come from one MJCF: the text that
  :func:`neuronav.backends.mujoco.mjcf.to_xml` writes for the world and the body spec (the MuJoCo backend's
  own translation), split into the body's subtree with its actuators (the entity) and the rest (the
  arena: options, sky, ground, objects, lights). PyMJCF keeps ``/`` for its scopes, so every ``/`` in
  a name becomes ``_`` (``thorax/free`` -> ``thorax_free``); attached, the ant's names are prefixed
  ``ant/``. MJCF text holds 6 significant digits: masses and inertias agree with the compiled model
  of the MuJoCo backend to about 1e-6 relative (the dm_control *backend* uses that model itself).
- :class:`PortTask` — a generic ``composer.Task`` over an engine-free task object (duck-typed: the
  interface of ``neuronav.scenarios.envs.tasks.NavigationTask``: ``world``, ``start``, ``observation_ports``,
  ``task_sensors``, ``state_ports``, ``observe``, ``reward``, ``terminated``, ``time_limit_s``).
  Its observables are named after the ports the task observes (``heading``, ``eye_L``, ``odour``, ...)
  and the observations the task computes (``home_vector``); they are read through the sensors of
  :class:`~neuronav.backends.dm_control.DmControlBackend`, bound to the composer physics, so an observation is
  exactly what a backend reports (odour and wind from the world's fields, eyes rendered by the rules
  of :mod:`neuronav.senses.vision`). Reward, termination and the start pose are the task object's.
- :func:`environment` — a ``composer.Environment`` of a task.

The action is the locomotion command (``turn`` θ in [-1, 1], ``stride`` S_l in rad; outside its
bounds it is clipped to them, as the Gymnasium environment does; not finite, not real numbers or of
another shape: a :class:`~neuronav.errors.PortError`), held for one
control period (``cycle_s``, the scenarios' brain period) and walked by the gait given (its targets
written every ``control_s``). The episode ends at the task's goal (``discount`` 0) or at its time
limit (``discount`` 1: truncated, dm_env's convention).
"""

from __future__ import annotations

import copy
import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import replace

os.environ.setdefault("MUJOCO_GL", "egl")
# Before dm_control starts EGL: Mesa then rasterises in the calling thread, safe after fork
# (neuronav.backends.mujoco.gl_contexts).
os.environ.setdefault("LP_NUM_THREADS", "0")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from dm_control import composer, mjcf  # noqa: E402
from dm_control.composer.observation import observable  # noqa: E402
from dm_env import specs  # noqa: E402

from neuronav.backends.dm_control.backend import DmControlBackend  # noqa: E402
from neuronav.backends.mujoco.mjcf import SCENE_BODY, ModelNames, build_spec, to_xml  # noqa: E402
from neuronav.backends.mujoco.swarm import prefixed_body  # noqa: E402
from neuronav.errors import ConfigError, PortError  # noqa: E402
from neuronav.spec.body import BodySpec  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

ENTITY_NAME = "ant"
PREFIX = ENTITY_NAME + "/"  # PyMJCF's scope of the attached ant
FREE_JOINT = "free"  # the free joint of the ant's attachment frame
# MJCF sections the split knows: the body's subtree and its actuators go to the entity, the rest to the arena.
_ARENA_SECTIONS = ("compiler", "option", "visual", "asset", "worldbody")
_ENTITY_SECTIONS = ("actuator", "sensor")


def pymjcf_name(name: str) -> str:
    """A model name as PyMJCF allows it (``/`` is its scope separator): each ``/`` becomes ``_``."""
    return name.replace("/", "_")


def split_mjcf(world: World, body: BodySpec, timestep_s: float) -> tuple[mjcf.RootElement, mjcf.RootElement]:
    """(arena MJCF, ant MJCF) as PyMJCF models, from the MuJoCo backend's MJCF of ``world`` and ``body``.

    A free root loses its free joint and its pose in the ant's MJCF: :meth:`WorldArena.add_ant` gives
    them to the attachment frame (MuJoCo allows a free joint only in a top-level body).

    Raises
    ------
    ConfigError
        The MJCF has a section the split does not know, or renaming ``/`` makes two names equal.
    """
    with tempfile.TemporaryDirectory() as assets:  # a world with odour trails writes its floor image here
        root = ET.fromstring(to_xml(world, body, timestep_s, asset_dir=assets))
        unknown = [s.tag for s in root if s.tag not in _ARENA_SECTIONS + _ENTITY_SECTIONS]
        if unknown:
            raise ConfigError(f"dm_control composer: the MJCF of {body.name!r} has sections {unknown} that the "
                              f"entity/arena split does not handle")
        _rename(root)
        worldbody = root.find("worldbody")
        ant_body = next(b for b in worldbody.findall("body") if b.get("name") == pymjcf_name(body.root.name))
        worldbody.remove(ant_body)
        free = [j for j in ant_body if j.tag == "freejoint" or (j.tag == "joint" and j.get("type") == "free")]
        if free:  # the arena gives the attachment frame the free joint (MuJoCo allows one only at the top level)
            ant_body.remove(free[0])
            for key in ("pos", "quat"):  # the frame carries the root's pose: the root sits at its origin
                ant_body.attrib.pop(key, None)
        ant = ET.Element("mujoco", model=ENTITY_NAME)
        ant.append(copy.deepcopy(root.find("compiler")))
        materials = {e.get("material") for e in ant_body.iter() if e.get("material")}
        if materials:
            ant_assets = ET.SubElement(ant, "asset")
            for element in root.find("asset"):
                if element.get("name") in materials or element.get("name") in _textures(root, materials):
                    ant_assets.append(copy.deepcopy(element))
        ET.SubElement(ant, "worldbody").append(ant_body)
        for tag in _ENTITY_SECTIONS:
            for section in root.findall(tag):
                root.remove(section)
                ant.append(section)
        arena_root = mjcf.from_xml_string(ET.tostring(root, encoding="unicode"), model_dir=assets)
        ant_root = mjcf.from_xml_string(ET.tostring(ant, encoding="unicode"), model_dir=assets)
    return arena_root, ant_root


def _textures(root: ET.Element, materials: set[str]) -> set[str]:
    return {m.get("texture") for m in root.iter("material") if m.get("name") in materials and m.get("texture")}


def _rename(root: ET.Element) -> None:
    """Replace ``/`` in every name (and every reference to it) in place."""
    renamed = {e.get("name"): pymjcf_name(e.get("name")) for e in root.iter() if "/" in (e.get("name") or "")}
    names = [e.get("name") for e in root.iter() if e.get("name")]
    new = [renamed.get(n, n) for n in names]
    if len(set(new)) != len(set(names)):
        raise ConfigError("dm_control composer: replacing '/' by '_' makes two MJCF names equal; rename the body's "
                          "segments or geoms")
    for element in root.iter():
        for key, value in element.attrib.items():
            if value in renamed:
                element.set(key, renamed[value])


def composer_names(names: ModelNames, free_joint: str | None) -> ModelNames:
    """Where each spec element of the ant went in the composer model (renamed, then prefixed ``ant/``);
    ``free_joint``: the attachment frame's."""
    def full(name: str) -> str:
        return PREFIX + pymjcf_name(name)

    return ModelNames(root=full(names.root), free_joint=free_joint,
                      joints=tuple(full(j) for j in names.joints),
                      geoms={key: full(geom) for key, geom in names.geoms.items()},
                      contact_geoms=tuple(tuple(full(g) for g in geoms) for geoms in names.contact_geoms))


def composer_body(body: BodySpec) -> BodySpec:
    """``body`` with its segments, joints and sites named as in the composer model; cameras and compound eyes
    keep their (port) names, mounted on the prefixed segments."""
    if any("/" in n for n in [s.name for s in body.segments] + body.joint_names + [s.name for s in body.sites]):
        raise ConfigError(f"dm_control composer: body {body.name!r} has a segment, joint or site name with '/'")
    cameras = tuple(replace(c, segment=PREFIX + c.segment) for c in body.cameras)
    eyes = tuple(replace(e, segment=PREFIX + e.segment) for e in body.compound_eyes)
    return replace(prefixed_body(body, PREFIX), cameras=cameras, compound_eyes=eyes)


class AntEntity(composer.Entity):
    """The ant as a composer entity: the body's MJCF subtree and actuators (see the module doc)."""

    def _build(self, mjcf_root: mjcf.RootElement) -> None:
        self._mjcf_root = mjcf_root

    @property
    def mjcf_model(self) -> mjcf.RootElement:
        return self._mjcf_root

    @property
    def actuators(self) -> tuple:
        return tuple(self._mjcf_root.find_all("actuator"))


class WorldArena(composer.Arena):
    """A :class:`~neuronav.spec.world.World` as a composer arena: options, sky, ground, objects, lights."""

    def _build(self, mjcf_root: mjcf.RootElement, name: str = "world") -> None:
        self._mjcf_root = mjcf_root
        self._mjcf_root.model = name

    def add_ant(self, ant: AntEntity, free: bool) -> str | None:
        """Attach ``ant``; a ``free`` one on a frame with the free joint :data:`FREE_JOINT`.

        Returns the free joint's name in the compiled model (None when not free).
        """
        frame = self.attach(ant)
        return frame.add("freejoint", name=FREE_JOINT).full_identifier if free else None


class _ComposerPorts(DmControlBackend):
    """The dm_control backend's sensors and joint targets on a composer environment's physics.

    Composer steps the physics itself; :meth:`after_engine_steps` tells the sensors so.
    """

    def __init__(self, physics, names: ModelNames, timestep_s: float) -> None:
        super().__init__(timestep_s)
        self._given = physics, names

    def _load_engine(self, world: World, body: BodySpec) -> None:
        physics, names = self._given
        self._close_renderers()
        self.physics = physics
        self.model, self.data, self.names = physics.model.ptr, physics.data.ptr, names
        self._index(self.model, names, body, world)
        # The objects' mocap body is renamed in PyMJCF (no '/'): reset's overlap check and the scene yaw need it.
        self._scene_body = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, pymjcf_name(SCENE_BODY))
        self._scenery = np.isin(np.arange(self.model.nbody), [0, self._scene_body])

    def after_engine_steps(self) -> None:
        """The physics was stepped outside :meth:`step`: torques and contact forces belong to the new state."""
        self._torque = self.data.actuator_force.copy()
        self._forces_current = False


class PortTask(composer.Task):
    """A composer task over an engine-free navigation task (see the module doc).

    Parameters
    ----------
    task : NavigationTask-like
        What an episode is: world, start, observed ports, reward, termination, time limit.
    body : BodySpec
        The ant (its MJCF from :func:`split_mjcf`).
    gait : Gait
        Turns the locomotion command into joint targets (``reset()``, ``step(turn, stride_rad)``).
    physics_timestep_s, control_s, cycle_s : float
        Physics step, gait step and the action's period (whole multiples of each other).
    action_low, action_high : (2,) float
        Bounds of (turn, stride_rad).
    world_seed : int
        Seed of the task's world (the beacon's forest).
    """

    def __init__(self, task, body: BodySpec, gait, *, physics_timestep_s: float, control_s: float, cycle_s: float,
                 action_low, action_high, world_seed: int = 0) -> None:
        self._task, self._gait = task, gait
        self._world = task.world(world_seed)
        arena_root, ant_root = split_mjcf(self._world, body, physics_timestep_s)
        self._arena, self._ant = WorldArena(arena_root), AntEntity(ant_root)
        _, names = build_spec(self._world, body, physics_timestep_s)
        free_joint = self._arena.add_ant(self._ant, free=names.free_joint is not None)
        self._names, self._body = composer_names(names, free_joint), composer_body(body)
        self._physics_per_control = _ratio(control_s, physics_timestep_s, "control_s / physics_timestep_s")
        _ratio(cycle_s, control_s, "cycle_s / control_s")
        self.set_timesteps(control_timestep=cycle_s, physics_timestep=physics_timestep_s)
        self._action_spec = specs.BoundedArray((2,), np.float64, np.asarray(action_low, float),
                                               np.asarray(action_high, float), name="turn,stride_rad")
        self._ports: _ComposerPorts | None = None
        self.episode_seed: int | None = None  # the seed of the start pose and the plume, drawn at each reset
        self._state: dict | None = None
        self._previous: dict | None = None
        self._command = np.zeros(2)
        self._substeps = 0
        names_out = [*task.observation_ports, *(spec.name for spec in task.task_sensors)]
        self._observables = {}
        for name in names_out:
            item = observable.Generic(lambda physics, name=name: self._observation(physics, name))
            item.enabled = True
            self._observables[name] = item

    # -- composer's Task API ------------------------------------------------------------------------
    @property
    def root_entity(self) -> WorldArena:
        return self._arena

    @property
    def ant(self) -> AntEntity:
        return self._ant

    @property
    def task_observables(self) -> dict:
        return self._observables

    def action_spec(self, physics) -> specs.BoundedArray:
        return self._action_spec

    def initialize_episode(self, physics, random_state: np.random.RandomState) -> None:
        ports = self.ports(physics)
        seed = self.episode_seed = int(random_state.randint(2**31 - 1))
        start = self._task.start(seed)
        ports.reset(seed=seed, position_m=tuple(float(v) for v in start.position_m),
                    yaw_rad=float(np.pi / 2 - start.heading_rad))
        self._gait.reset()
        self._substeps = 0
        self._state = self._previous = self._read()

    def before_step(self, physics, action, random_state) -> None:
        spec = self._action_spec
        try:
            array = np.asarray(action)
        except (TypeError, ValueError):
            array = np.asarray(None)
        command = array.astype(float).reshape(-1) if array.dtype.kind in "biuf" else np.full(0, np.nan)
        if command.shape != spec.shape or not np.isfinite(command).all():
            raise PortError(f"action must be (turn in [{spec.minimum[0]:g}, {spec.maximum[0]:g}], stride_rad in "
                            f"[{spec.minimum[1]:g}, {spec.maximum[1]:.4g}]), finite real numbers (outside the bounds: "
                            f"clipped); got {action!r}")
        self._command = np.clip(command, spec.minimum, spec.maximum)  # the Gymnasium environment's rule too
        self._previous = self._state

    def before_substep(self, physics, action, random_state) -> None:
        if self._substeps % self._physics_per_control == 0:
            targets = self._gait.step(float(self._command[0]), float(self._command[1]))
            self._ports.write({"joint_targets": targets[None, :]})
        self._substeps += 1

    def after_substep(self, physics, random_state) -> None:
        self._ports.after_engine_steps()

    def after_step(self, physics, random_state) -> None:
        self._state = self._read()

    def get_reward(self, physics) -> float:
        return float(self._task.reward(self._previous, self._state))

    def should_terminate_episode(self, physics) -> bool:
        return bool(self._task.terminated(self._state))

    def get_discount(self, physics) -> float:
        return 0.0 if self.should_terminate_episode(physics) else 1.0

    # -- ports --------------------------------------------------------------------------------------
    def ports(self, physics) -> _ComposerPorts:
        """The sensors bound to ``physics`` (bound again when composer has built a new physics)."""
        if self._ports is None or self._ports.data is not physics.data.ptr:
            self._ports = _ComposerPorts(physics, self._names, float(physics.model.opt.timestep))
            self._ports.load(self._world, [self._body])
            self._state = None
        return self._ports

    def close(self) -> None:
        """Free the body cameras' renderer (its GL context)."""
        if self._ports is not None:
            self._ports.close()

    def _read(self) -> dict[str, np.ndarray]:
        readings = self._ports.read(self._task.state_ports)
        return {name: np.asarray(value)[0] for name, value in readings.items()}

    def _observation(self, physics, name: str) -> np.ndarray:
        if self._state is None:  # composer asks for the observations' specs before the first episode
            self.ports(physics)
            self._state = self._read()
        value = self._state[name] if name in self._state else self._task.observe(self._state)[name]
        return np.asarray(value, dtype=np.float64)


def _ratio(long_s: float, short_s: float, what: str) -> int:
    ratio = long_s / short_s
    if not (np.isfinite(ratio) and ratio >= 1 and abs(ratio - round(ratio)) < 1e-9):
        raise ConfigError(f"dm_control composer: {what} must be a whole number >= 1, got {ratio:g}")
    return int(round(ratio))


class _Environment(composer.Environment):
    """A composer environment that also frees its task's renderer when closed."""

    def close(self) -> None:
        self.task.close()
        super().close()


def environment(task, body: BodySpec, gait, *, random_state=None, time_limit_s: float | None = None,
                **settings) -> composer.Environment:
    """A ``composer.Environment`` of ``task`` (``settings``: :class:`PortTask`'s keywords).

    An episode lasts at most ``time_limit_s`` of simulated time (default: the task's ``time_limit_s``).
    """
    limit = float(task.time_limit_s if time_limit_s is None else time_limit_s)
    if not (np.isfinite(limit) and limit > 0):
        raise ConfigError(f"dm_control composer: time_limit_s must be a positive number of seconds, got {limit!r}")
    return _Environment(PortTask(task, body, gait, **settings), time_limit=limit, random_state=random_state,
                        strip_singleton_obs_buffer_dim=True)
