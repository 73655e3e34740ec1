"""Brains in the loop: Gymnasium wrappers that run the central complex inside the homing environment.

Researchers learn on top of the insect circuits, or against them. The CX is
:class:`neuronav.scenarios.envs.path_integrator.CXPathIntegrator` (Stone et al. 2017's circuit fed as
embodied homing feeds it, once per gait cycle, from the environment's raw state, after integrating the
foraging walk that brought the ant to its start). Three ways in:

- ``homing`` with ``home_vector="cx"`` (a setting of :class:`neuronav.scenarios.envs.tasks.HomingTask`,
  so ``gymnasium.make("neuronav/AntHoming-v0", home_vector="cx")``): the observation ``home_vector`` is
  the CX's own estimate, decoded from CPU4's memory as the path-integration scenario decodes it
  (:func:`neuronav.brains.cx.decode_home_vector`) and put in the oracle's frame, so path integration,
  with its errors, is part of the learning problem; ``home_vector="oracle"`` (the default) is the true
  vector.
- :class:`CXObservation` adds the CX's populations to the observation ``Dict``: ``TB1`` (8 rates),
  ``CPU4`` (16, the memory), ``CPU1`` (16 rates), each a ``Box`` in [0, 1].
- :class:`CXResidualControl` makes the action a residual on the CX's steering: the action is in
  [-1, 1]² (symmetric and normalised, as RL libraries prefer) and the command walked is
  ``clip(brain + action * (high - low), low, high)``, ``brain`` the CX's (turn θ, stride S_l) of eqs.
  3.6-3.7 (:func:`neuronav.scenarios.path_integration.embodied.steering_command`) and (low, high) the
  environment's action box (so a residual of ±1 spans the whole box). A zero residual walks the ant
  home as the embodied scenario's CX does.

The wrappers share the task's integrator when ``home_vector="cx"`` (the observation, the populations
and the steering then come from one CX); with the oracle vector they attach one to the task, which its
``start`` then primes. They need the homing task in the locomotion action mode (one action per gait
cycle, the CX's period): the joints mode would feed the CX 80 times per cycle, and is refused.
:func:`brain_homing_env` builds the environment with both wrappers.

The mushroom body's novelty is not offered: the homing floor is bare, with no view to learn.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs.path_integrator import HOME_VECTORS, POPULATIONS, CXPathIntegrator
from neuronav.scenarios.envs.tasks import read_state


def homing_integrator(env: gymnasium.Env) -> CXPathIntegrator:
    """The homing task's path integrator under ``env`` (attached when the task has none), or one clear error."""
    base = env.unwrapped
    task = getattr(base, "task", None)
    if getattr(task, "name", None) != "homing":
        raise ConfigError(f"brain-in-the-loop wrappers run the CX on the homing task; got task "
                          f"{getattr(task, 'name', None)!r}")
    if getattr(base, "action_mode", "locomotion") != "locomotion":
        raise ConfigError("brain-in-the-loop wrappers need action_mode='locomotion' (one action per gait cycle, "
                          f"the CX's period); got {base.action_mode!r}")
    if task.path_integrator is None:
        task.path_integrator = CXPathIntegrator(task.config)
    return task.path_integrator


def raw_state(env: gymnasium.Env) -> dict[str, np.ndarray]:
    """The environment's raw state now: the task's ports read from its backend (agent 0)."""
    base = env.unwrapped
    return read_state(base.engine, base.task)


class CXObservation(gymnasium.ObservationWrapper, gymnasium.utils.RecordConstructorArgs):
    """The homing environment with the CX's ``TB1``, ``CPU4`` and ``CPU1`` added to its observation ``Dict``."""

    def __init__(self, env: gymnasium.Env) -> None:
        gymnasium.utils.RecordConstructorArgs.__init__(self)
        super().__init__(env)
        self.integrator = homing_integrator(env)
        if not isinstance(env.observation_space, spaces.Dict):
            raise ConfigError(f"CXObservation wraps a Dict observation space; got {env.observation_space}")
        clash = sorted(set(POPULATIONS) & set(env.observation_space.spaces))
        if clash:
            raise ConfigError(f"CXObservation: the observation already has {', '.join(clash)}")
        boxes = dict(env.observation_space.spaces)
        boxes.update({name: spaces.Box(0.0, 1.0, (size,), np.float32) for name, size in POPULATIONS.items()})
        self.observation_space = spaces.Dict(boxes)

    def observation(self, observation: dict) -> dict:
        self.integrator.update(raw_state(self.env))
        return {**observation, **self.integrator.populations()}


class CXResidualControl(gymnasium.ActionWrapper, gymnasium.utils.RecordConstructorArgs):
    """The action, in [-1, 1]², is a residual on the CX's steering: ``clip(brain + action * (high - low), low,
    high)`` (module docstring)."""

    def __init__(self, env: gymnasium.Env) -> None:
        gymnasium.utils.RecordConstructorArgs.__init__(self)
        super().__init__(env)
        self.integrator = homing_integrator(env)
        self.low = np.asarray(env.action_space.low, float)
        self.high = np.asarray(env.action_space.high, float)
        self.span = self.high - self.low
        self.action_space = spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        self._started = False

    def reset(self, **kwargs: Any):
        observation, info = self.env.reset(**kwargs)
        self._started = True
        self.integrator.update(raw_state(self.env))
        return observation, info

    def action(self, action) -> np.ndarray:
        try:
            residual = np.asarray(action)
        except (TypeError, ValueError):  # e.g. rows of unequal length
            residual = np.zeros(0, dtype=object)
        # Real numbers only: a string, a dict or a complex number is refused, not cast.
        residual = residual.astype(float).reshape(-1) if residual.dtype.kind in "iuf" else np.full(0, np.nan)
        if residual.shape != self.action_space.shape or not np.isfinite(residual).all():
            raise PortError(f"residual action must be {self.action_space.shape[0]} finite numbers (turn, stride in "
                            f"[-1, 1], times the action box's width added to the CX's command), got {action!r}")
        if not self._started:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        self.integrator.update(raw_state(self.env))
        brain = np.array(self.integrator.steering())
        return np.clip(brain + residual * self.span, self.low, self.high).astype(np.float32)


def brain_homing_env(home_vector: str = "cx", populations: bool = True, residual: bool = True,
                     backend: str = "kinematic", **settings: Any) -> gymnasium.Env:
    """``neuronav/AntHoming-v0`` with ``home_vector`` and the brain wrappers asked for (locomotion mode)."""
    import neuronav.scenarios.envs  # noqa: F401  (registers the ids)

    if home_vector not in HOME_VECTORS:
        raise ConfigError(f"home_vector must be one of {', '.join(HOME_VECTORS)}; got {home_vector!r}")
    env = gymnasium.make("neuronav/AntHoming-v0", backend=backend, action_mode="locomotion",
                         home_vector=home_vector, **settings)
    if populations:
        env = CXObservation(env)
    if residual:
        env = CXResidualControl(env)
    return env
