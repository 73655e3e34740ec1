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

The mushroom body's novelty (:class:`MBNoveltyObservation`) needs views to learn: it wraps a task the agent
sees in, made with ``panorama=True`` (the beacon's forest; the homing floor is bare, every view alike). It
adds ``mb_novelty`` (1,) in [0, 1], the MBON's output over the active KCs (1: no active KC silenced, the view
never seen), for a mushroom body (:func:`neuronav.brains.mushroom_body.mushroom_body`, Ardin's 324-PN panorama
code) that learns the views of each episode's first ``learn_steps`` observations, a learning walk.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from neuronav.brains.mushroom_body import N_KC, PANORAMA_COLUMNS, PANORAMA_ROWS, mushroom_body, panorama_code
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


def _count(where: str, label: str, value: Any, lowest: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lowest:
        raise ConfigError(f"{where}: {label} must be an int >= {lowest}, got {value!r}")
    return int(value)


class MBNoveltyObservation(gymnasium.ObservationWrapper, gymnasium.utils.RecordConstructorArgs):
    """A seeing environment (``panorama=True``) with the mushroom body's novelty of the current view added to its
    observation ``Dict`` as ``mb_novelty`` (1,) float32 in [0, 1].

    The protocol, a learning walk: at every ``reset`` the mushroom body forgets (every KC->MBON weight back
    to 1); the views of the episode's first ``learn_steps`` observations (the reset's included) are learnt,
    after that it only reports. Each observation's novelty is judged *before* its view is learnt: the
    MBON's output (active KCs whose weights are intact, :mod:`neuronav.brains.mushroom_body`) divided by
    the number of active KCs, so 1 is a view no part of which was learnt and 0 a view seen before; a view
    that drives no KC (a uniform panorama) reports 1. With ``learning_rate`` 1 one presentation silences
    a view's KCs: along the walk novelty falls where views repeat, and afterwards a view off the walk
    (another place, or the same place facing another way: the panorama code turns with the ant) is novel.

    The view is the environment's raw grey panorama (float, 72 x 72, the reading its observation's uint8
    ``panorama`` is rounded from), coded by :func:`~neuronav.brains.mushroom_body.panorama_code` (9 x 36
    blocks of 10 deg, z-scored: 324 PNs).

    Parameters
    ----------
    env : gymnasium.Env
        A neuronav environment whose observation ``Dict`` has ``panorama`` (``gymnasium.make(...,
        panorama=True)``), e.g. ``neuronav/AntBeacon-v0``.
    learn_steps : int
        Observations learnt at the start of each episode (>= 0; 0: the memory stays empty, novelty 1 when
        any KC fires).
    n_kc : int
        Kenyon cells (Sun et al. 2020's 4000 by default).
    seed : int
        Seeds the KC wiring (the same seed, the same mushroom body).

    Raises
    ------
    ConfigError
        An environment without the panorama observation, one that already observes ``mb_novelty``, or a
        setting out of range.
    """

    name = "mb_novelty"

    def __init__(self, env: gymnasium.Env, learn_steps: int = 10, n_kc: int = N_KC, seed: int = 0) -> None:
        gymnasium.utils.RecordConstructorArgs.__init__(self, learn_steps=learn_steps, n_kc=n_kc, seed=seed)
        super().__init__(env)
        where = "MBNoveltyObservation"
        space = env.observation_space
        if not isinstance(space, spaces.Dict) or "panorama" not in space.spaces:
            raise ConfigError(f"{where} needs the panorama observation: make the environment with panorama=True "
                              f"(e.g. gymnasium.make('neuronav/AntBeacon-v0', panorama=True)); got {space}")
        if self.name in space.spaces:
            raise ConfigError(f"{where}: the observation already has {self.name}")
        self.learn_steps = _count(where, "learn_steps", learn_steps, 0)
        self.circuit = mushroom_body(n_pn=PANORAMA_ROWS * PANORAMA_COLUMNS, n_kc=_count(where, "n_kc", n_kc, 1),
                                     seed=_count(where, "seed", seed, 0))
        self.mb = self.circuit.compile(batch=1)
        self.views_seen = 0
        self.observation_space = spaces.Dict({**space.spaces, self.name: spaces.Box(0.0, 1.0, (1,), np.float32)})

    def reset(self, **kwargs: Any):
        self.forget()
        return super().reset(**kwargs)

    def forget(self) -> None:
        """Empty the memory (every KC->MBON weight 1) and start the learning walk again."""
        self.mb.set_weights("KC->MBON", np.ones_like(self.mb.weights("KC->MBON")))
        self.views_seen = 0

    def panorama(self) -> np.ndarray:
        """The raw grey panorama (H, W) in [0, 1] the environment read at its last reset or step."""
        state = getattr(self.env.unwrapped, "_state", None)
        if state is None or "panorama" not in state:
            raise gymnasium.error.ResetNeeded("call reset() before reading the panorama")
        return np.asarray(state["panorama"], float)

    def _judge(self, panorama: np.ndarray, learn: bool) -> float:
        out = self.mb.step({"pn": panorama_code(panorama), "learning": np.full((1, 1), float(learn))})
        active = float(self.mb.rates("KC")[0].sum())
        return float(np.clip(out["novelty"][0, 0] / active, 0.0, 1.0)) if active > 0 else 1.0

    def novelty(self, panorama) -> float:
        """The novelty in [0, 1] of a raw grey panorama (H, W) for the memory as it is now (nothing learnt)."""
        return self._judge(np.asarray(panorama, float), learn=False)

    def observation(self, observation: dict) -> dict:
        learn = self.views_seen < self.learn_steps
        value = self._judge(self.panorama(), learn)
        self.views_seen += 1
        return {**observation, self.name: np.array([value], np.float32)}
