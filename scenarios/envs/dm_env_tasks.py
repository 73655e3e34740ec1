"""dm_control environments (``dm_env`` API) of the navigation tasks: one per task of
:data:`neuronav.scenarios.envs.tasks.TASKS`.

``load(name, world_seed=0, random_state=None, time_limit_s=None, **settings)`` builds the task ``name`` (``homing``,
``beacon``, ``plume``) with its scenario's settings (the keys of ``neuronav run ... --set``) and
returns a ``dm_control.composer.Environment``: the desert ant (a composer entity) walked by the FK
tripod gait in the task's world (a composer arena), the task's observed ports and computed
observations as observables, its reward and termination, built by the registered ``dm_control`` backend
(``registry.load("backend", "dm_control").composer_environment``: see
:mod:`neuronav.backends.dm_control.composer_env`)::

    from neuronav.scenarios.envs.dm_env_tasks import load
    env = load("homing")
    timestep = env.reset()                       # timestep.observation["home_vector"]: (2,) m, body frame
    while not timestep.last():
        timestep = env.step([0.0, 0.26])         # (turn θ, stride S_l rad), held one gait cycle (0.64 s)

The action and its bounds, the clocks (2 ms physics or the scenario's, 8 ms gait, 0.64 s per action)
and the start pose follow the Gymnasium environment's locomotion mode
(:mod:`neuronav.scenarios.envs.gym_env`); the episode seed comes from the environment's ``random_state``.
The action rule is the Gymnasium environment's (:data:`neuronav.scenarios.envs.observations.ACTION_RULE`):
finite actions outside the bounds are clipped to them; another shape, not finite, or not real numbers
(a string, a dict, complex): a :class:`~neuronav.errors.PortError`.

The observables are the task's backend ports as the backend reports them (``heading`` in rad
clockwise from +y, ``velocity`` m/s in world (x, y), eyes as grey floats in [0, 1]) and its computed
observations (``home_vector``, body frame); the Gymnasium environment's conventions (heading as
(sin, cos), body-frame velocity, uint8 eyes) are made from the same readings by
:func:`neuronav.scenarios.envs.observations.observe`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.gaits import make_gait
from neuronav.scenarios.envs.tasks import TASKS, check_world_seed, make_task
from neuronav.scenarios.path_integration.embodied import EXTRA_STRIDE_RAD, MIN_STRIDE_RAD
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S

# Eq. 3.7's largest stride (5° + 20°): the action's upper stride, as in the Gymnasium environment.
MAX_STRIDE_RAD = float(MIN_STRIDE_RAD + EXTRA_STRIDE_RAD)


def action_bounds() -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of (turn, stride_rad): the locomotion command ports' ranges, the stride capped at eq. 3.7's."""
    motors = {spec.name: spec for spec in registry.load("backend", "kinematic").capabilities.motors}
    turn, stride = motors["turn"].range, motors["stride"].range
    return np.array([turn[0], stride[0]]), np.array([turn[1], min(stride[1], MAX_STRIDE_RAD)])


def task_names() -> tuple[str, ...]:
    """The tasks that have a dm_env environment: every registered task."""
    return tuple(TASKS)


def load(name: str, *, world_seed: int = 0, random_state: int | np.random.RandomState | None = None,
         time_limit_s: float | None = None, **settings: Any):
    """The ``dm_env`` environment of task ``name`` (see the module doc).

    ``random_state`` seeds the episodes; ``time_limit_s`` shortens (or lengthens) the task's time limit.

    Raises
    ------
    ConfigError
        An unknown task, a setting its scenario does not have or does not allow, or a ``world_seed`` that
        is not an int >= 0 (None is refused: the beacon's forest would not be reproducible).
    RegistryError
        The dm_control backend is not installed (dm-control installs on Python < 3.13 only).
    """
    task = make_task(name, **settings)
    world_seed = check_world_seed(world_seed)
    backend = registry.load("backend", "dm_control")  # the class: reached by name, never imported
    body = desert_ant()
    low, high = action_bounds()
    return backend.composer_environment(
        task, body, make_gait("tripod", body), random_state=random_state, time_limit_s=time_limit_s,
        physics_timestep_s=task.physics_timestep_s, control_s=CONTROL_S, cycle_s=CYCLE_S, action_low=low,
        action_high=high, world_seed=world_seed)
