"""The dm_control backend: the MuJoCo backend's model, stepped through dm_control's ``Physics``.

dm_control is DeepMind's Python layer over MuJoCo. This backend builds exactly the model that
:mod:`neuronav.backends.mujoco.mjcf` compiles from the :class:`~neuronav.spec.body.BodySpec` and the
:class:`~neuronav.spec.world.World` (one MJCF, one ``MjSpec``, compiled once), wraps it in a
:class:`dm_control.mujoco.Physics` and advances it with :meth:`Physics.step`. dm_control's
step (its default "legacy" step) is ``mj_step2`` then ``mj_step1``, the very order the MuJoCo
backend uses, so both backends walk the same walk to the last bit (a cross-backend test checks it).

Everything else (sensors, reset, adhesion, external forces, cameras, the follow view, the stability
checks) is inherited from :class:`~neuronav.backends.mujoco.MujocoBackend`, which reads and writes the
``MjModel``/``MjData`` that the ``Physics`` wraps (``physics.model.ptr``, ``physics.data.ptr``).
``physics`` is public: dm_control users can read ``physics.named.data.qpos`` and the like.

dm_control raises its ``PhysicsError`` on any new MuJoCo warning; here the MuJoCo backend's own
check sorts the warnings instead (a diverged state is a :class:`~neuronav.errors.SimulationError`,
a full contact buffer only a recorded warning), so both backends fail the same way.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")
# Before dm_control starts EGL: Mesa then rasterises in the calling thread, safe after fork
# (neuronav.backends.mujoco.gl_contexts).
os.environ.setdefault("LP_NUM_THREADS", "0")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from dm_control import mujoco as dm_mujoco  # noqa: E402
from dm_control.mujoco.wrapper import MjModel  # noqa: E402
from dm_control.rl.control import PhysicsError  # noqa: E402

from neuronav.backends.mujoco.backend import _FATAL_INDEX, MujocoBackend  # noqa: E402
from neuronav.backends.mujoco.mjcf import compile_model  # noqa: E402
from neuronav.spec.body import BodySpec  # noqa: E402
from neuronav.spec.world import World  # noqa: E402


class DmControlBackend(MujocoBackend):
    """One articulated body simulated by MuJoCo through dm_control's ``Physics`` (see the module doc).

    Parameters
    ----------
    timestep_s : float
        Physics step (default 2 ms).

    Attributes
    ----------
    physics : dm_control.mujoco.Physics
        The dm_control physics of the loaded model (after :meth:`load`); ``model`` and ``data`` are
        its MuJoCo structures.
    """

    engine = "dm_control"

    def __init__(self, timestep_s: float = 0.002) -> None:
        super().__init__(timestep_s)
        self.physics: dm_mujoco.Physics | None = None

    def _load_engine(self, world: World, body: BodySpec) -> None:
        """Compile the MuJoCo backend's MJCF of ``world`` and ``body`` and wrap it in a dm_control ``Physics``."""
        self._close_renderers()
        model, names = compile_model(world, body, self._timestep_s)
        self.physics = dm_mujoco.Physics.from_model(MjModel(model))
        self.model, self.data, self.names = self.physics.model.ptr, self.physics.data.ptr, names
        self._index(self.model, names, body, world)

    def _advance(self, model: mujoco.MjModel, data: mujoco.MjData, n: int, forces: bool,
                 fatal_seen: np.ndarray) -> None:
        """``Physics.step``: all ``n`` steps at once, or one at a time when adhesion or pushes act.

        One at a time, a fatal warning stops the steps as in the MuJoCo backend; all at once, dm_control
        finishes the ``n`` steps first. Either way :meth:`step`'s check then raises.
        """
        if not forces:
            self._physics_step(n)
            return
        for _ in range(n):
            self._external_forces(model, data)
            self._physics_step(1)
            if (data.warning.number[_FATAL_INDEX] > fatal_seen).any():
                break  # MuJoCo has already reset the state; stop and report

    def _physics_step(self, n: int) -> None:
        if n <= 0:
            return  # (dm_control's step(0) would still take one step)
        try:
            self.physics.step(n)
        except PhysicsError:
            pass  # the MuJoCo backend's check (in step) sorts the warnings: fatal or only recorded

    @staticmethod
    def composer_environment(task, body: BodySpec, gait, **options):
        """A ``dm_control.composer.Environment`` (``dm_env`` API) of an engine-free navigation ``task``.

        What scenarios call, by name through the registry
        (``registry.load("backend", "dm_control").composer_environment(...)``), so that none imports this
        package: :func:`neuronav.backends.dm_control.composer_env.environment` with the same arguments
        (``random_state``, ``time_limit_s`` and :class:`~neuronav.backends.dm_control.composer_env.PortTask`'s
        keywords).
        """
        from neuronav.backends.dm_control.composer_env import environment  # it subclasses this backend

        return environment(task, body, gait, **options)

    def raw_step(self, n: int = 1, targets: np.ndarray | None = None) -> None:
        """``Physics.step(n)`` and nothing else (no adhesion, no checks): for benchmarks.

        The actuators hold ``targets`` (J,) when given, else the last targets, as in
        :meth:`MujocoBackend.raw_step`; dm_control's step leaves poses and contacts up to date.
        """
        model, data = self._require_model()
        if targets is not None:
            data.ctrl[:] = targets
        self._physics_step(int(n))
        self._torque = data.actuator_force.copy()
        self._forces_current = False
