"""A native Gymnasium vector environment on the kinematic backend: N episodes, one batch of N agents.

``gymnasium.make_vec("neuronav/AntHoming-v0", num_envs=N, vectorization_mode="vector_entry_point",
backend="kinematic")`` (or ``NeuronavVectorEnv(num_envs=N, task="homing", **kwargs)``) runs N copies of
:class:`~neuronav.scenarios.envs.gym_env.NeuronavEnv` (``backend="kinematic"``, ``action_mode="locomotion"``)
as N point agents of ONE :class:`~neuronav.backends.kinematic.KinematicBackend`: a step writes the N
locomotion commands and advances the batch one gait cycle (80 control steps of 8 ms) in one array
operation per control step. The agents are points that neither touch nor hide each other, so each env
is its own episode, in the same world.

Tasks: ``homing`` (``neuronav/AntHoming-v0``) and ``beacon`` (``neuronav/AntBeacon-v0``: the eyes are
ray-cast for every agent at once), with the single env's settings and options (``panorama=True``, ...).
Refused: ``plume`` (its plume is one world state, seeded by each episode and moving with the episode's
time, which N episodes cannot share) and homing's ``home_vector="cx"`` (one CX estimate per episode).
Homing's starts (a foraging walk per episode) are drawn for all resetting envs at once
(:func:`homing_starts`, the same starts as ``task.start``).

What is the same as the single env, bit for bit (``tests/unit/test_vector_env.py`` compares both with
Gymnasium's ``SyncVectorEnv`` of single envs): spaces (``single_observation_space``,
``single_action_space``; the batched spaces are :func:`gymnasium.vector.utils.batch_space` of them),
observations (made by :func:`neuronav.scenarios.envs.observations.observe`, as in the single env),
rewards, ``terminated``, ``truncated`` and ``info`` (``distance_m``, ``time_s``, ``is_success``, ``fell``,
each with its ``_key`` mask). Seeds map as in ``SyncVectorEnv``: ``reset(seed=s)`` seeds
env i with ``s + i`` (a list seeds env i with its item i), so env i's episodes are those of a
``NeuronavEnv`` reset with ``seed=s + i`` and then reset without a seed after each episode; ``seed=None``
keeps each env's generator (a fresh random one the first time).

Autoreset (``metadata["autoreset_mode"]``, set by the ``autoreset_mode`` argument): ``NEXT_STEP`` (the
default, Gymnasium's): the step after an env's episode ends ignores its action, resets it and returns
its first observation with reward 0, ``terminated = truncated = False`` and the reset's info.
``SAME_STEP``: an env is reset in the step that ends its episode; ``info["final_obs"]`` and
``info["final_info"]`` hold what the ended episode returned. ``DISABLED``: stepping an ended env
raises :class:`gymnasium.error.ResetNeeded`; reset it with ``reset(options={"reset_mask": mask})``
(``reset_mask``, a bool array (N,), is the only reset option: it resets just those envs).

Bad input is a :class:`~neuronav.errors.ConfigError` (``num_envs`` not an int >= 1, a backend other than
``kinematic``, a task the vector env cannot share, seeds, options) or a
:class:`~neuronav.errors.PortError` (actions not (N, 2) finite numbers). Actions outside the box are
clipped, as in the single env. One env-step is one gait cycle (0.64 s of simulated time, 80
control steps): ``python benchmarks/vector_env.py`` measures env-steps per CPU-second (58,182 at
N = 1000, auto-resets included, against 149 for one single env, on one core of the 2-core machine).
"""

from __future__ import annotations

import math
from dataclasses import replace
from numbers import Integral
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from neuronav.bodies.desert_ant.unicycle import unicycle_calibration
from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs.gym_env import NeuronavEnv
from neuronav.scenarios.envs.observations import check_actions, observe, state_ports
from neuronav.scenarios.envs.tasks import MAX_WALKS, MIN_START_RADII, HomingTask, NavigationTask
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine

# The tasks whose N episodes can share one world (see the module docstring for plume's reason).
VECTOR_TASKS = ("homing", "beacon")
VECTOR_BACKENDS = ("kinematic",)
# The largest episode seed a single env draws (NeuronavEnv.reset: np_random.integers(0, 2**31 - 1)).
EPISODE_SEED_END = 2**31 - 1


def foraging_walks(seeds, outbound_s: float, turn_std: float, stride_rad: float,
                   attempt: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """:func:`neuronav.scenarios.envs.tasks.foraging_walk` for many seeds at once: positions (K, 2) m, headings (K,).

    The same draws, the same arithmetic in the same order, element by element (the calibration's
    rates depend on each command alone, whatever the batch), so walk k ends where
    ``foraging_walk(seeds[k], ...)`` ends, bit for bit (``tests/unit/test_vector_env.py``); one call of
    the calibration per gait cycle for all seeds instead of one per seed.
    """
    seeds = [int(seed) for seed in seeds]
    calibration = unicycle_calibration()
    streams = [] if attempt == 0 else [attempt]
    steps_per_cycle = int(round(CYCLE_S / CONTROL_S))
    cycles = int(math.ceil(outbound_s / CYCLE_S - 1e-9))
    heading = np.array([np.random.default_rng([seed, 3, *streams]).uniform(0.0, 2.0 * np.pi) for seed in seeds])
    noise = np.array([np.random.default_rng([seed, 2, *streams]).normal(0.0, turn_std, cycles) for seed in seeds])
    noise = noise.reshape(len(seeds), cycles)
    position, turn = np.zeros((len(seeds), 2)), np.zeros(len(seeds))
    stride = np.full(len(seeds), stride_rad)
    ramp = np.arange(1, steps_per_cycle + 1)
    for cycle in range(cycles):
        turn = np.clip(0.7 * turn + noise[:, cycle], -1.0, 1.0)
        speed_m_s, turn_rate_rad_s = calibration.rates(turn, stride)
        headings = heading[:, None] + (turn_rate_rad_s * CONTROL_S)[:, None] * ramp
        sums = np.stack([np.sin(headings).sum(axis=1), np.cos(headings).sum(axis=1)], axis=1)
        position = position + (speed_m_s * CONTROL_S)[:, None] * sums
        heading = headings[:, -1]
    return position, np.mod(heading, 2.0 * np.pi)


def homing_starts(task: HomingTask, seeds) -> tuple[np.ndarray, np.ndarray]:
    """``task.start(seed)`` for many seeds at once (:func:`foraging_walks`): positions (K, 2) m, headings (K,) rad."""
    config = task.config
    seeds = np.asarray(seeds, dtype=np.int64)
    positions, headings = np.zeros((seeds.size, 2)), np.zeros(seeds.size)
    pending = np.arange(seeds.size)
    for attempt in range(MAX_WALKS):
        if pending.size == 0:
            break
        position, heading = foraging_walks(seeds[pending], config.outbound_s, config.foraging_turn_std,
                                           np.radians(config.foraging_stride_deg), attempt)
        positions[pending], headings[pending] = position, heading
        pending = pending[np.hypot(position[:, 0], position[:, 1]) < MIN_START_RADII * config.nest_radius_m]
    if pending.size:
        task.start(int(seeds[pending[0]]))  # raises the task's own ConfigError
    return positions, headings


def task_starts(task: NavigationTask, seeds) -> tuple[np.ndarray, np.ndarray]:
    """Every seed's start (positions (K, 2) m, headings (K,) rad), batched where the task allows it."""
    if isinstance(task, HomingTask):
        return homing_starts(task, seeds)
    starts = [task.start(int(seed)) for seed in seeds]
    return (np.array([start.position_m for start in starts], float).reshape(-1, 2),
            np.array([start.heading_rad for start in starts], float))


def masked(infos: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, np.ndarray]:
    """``infos`` (every key with its ``_key`` mask) for the envs of ``mask`` only: the others' values zero, their
    masks False, as Gymnasium's ``VectorEnv._add_info`` gathers the infos of some envs."""
    if mask.all():
        return infos
    return {key: mask.copy() if key.startswith("_") else np.where(mask.reshape((-1,) + (1,) * (value.ndim - 1)),
                                                                   value, np.zeros_like(value))
            for key, value in infos.items()}


def check_num_envs(num_envs) -> int:
    """``num_envs`` as an int >= 1, or a ConfigError."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, Integral) or num_envs < 1:
        raise ConfigError(f"NeuronavVectorEnv: num_envs must be an int >= 1, got {num_envs!r}")
    return int(num_envs)


class NeuronavVectorEnv(VectorEnv):
    """N kinematic episodes of a neuronav task stepped as one batch (see the module docstring).

    Parameters
    ----------
    num_envs : int
        N, at least 1.
    task, world_seed, settings
        As :class:`~neuronav.scenarios.envs.gym_env.NeuronavEnv` (``task`` one of :data:`VECTOR_TASKS`).
    backend : str
        ``kinematic`` only (other backends: ``vectorization_mode="sync"`` or ``"async"``).
    action_mode : str
        ``locomotion`` only (the kinematic unicycle's command).
    max_episode_steps : int, optional
        Truncate after this many steps if that comes before the task's time limit (``gymnasium.make_vec``
        passes the registered spec's value, as ``gymnasium.make`` adds a ``TimeLimit``); None or -1: the
        task's limit alone.
    autoreset_mode : AutoresetMode or str
        ``NEXT_STEP`` (default), ``SAME_STEP`` or ``DISABLED``.
    """

    def __init__(self, num_envs: int = 1, task: str = "homing", backend: str = "kinematic",
                 action_mode: str = "locomotion", render_mode: str | None = None, world_seed: int = 0,
                 max_episode_steps: int | None = None, autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 **settings: Any) -> None:
        self.num_envs = check_num_envs(num_envs)
        if backend not in VECTOR_BACKENDS:
            raise ConfigError(f"NeuronavVectorEnv steps one batch of the kinematic backend; got backend {backend!r}: "
                              f"for other backends use gymnasium.make_vec(..., vectorization_mode='sync' or 'async')")
        if task not in VECTOR_TASKS:
            raise ConfigError(f"NeuronavVectorEnv runs the tasks {', '.join(VECTOR_TASKS)}; got {task!r} (the plume "
                              f"is one world state per episode: use vectorization_mode='sync' or 'async')")
        if settings.get("home_vector", "oracle") != "oracle":
            raise ConfigError(f"NeuronavVectorEnv observes home_vector='oracle' only; got "
                              f"{settings['home_vector']!r} (the CX keeps one estimate per episode: use "
                              f"vectorization_mode='sync' or 'async')")
        if action_mode != "locomotion":
            raise ConfigError(f"NeuronavVectorEnv takes action_mode='locomotion' (the kinematic unicycle's "
                              f"command); got {action_mode!r}")
        if render_mode is not None:
            raise ConfigError(f"NeuronavVectorEnv renders nothing: render_mode must be None, got {render_mode!r} "
                              f"(render one NeuronavEnv instead)")
        self.autoreset_mode = self._check_autoreset_mode(autoreset_mode)
        # One single env checks the task, the settings and the world seed, and gives the spaces and limits.
        self.single_env = NeuronavEnv(task=task, backend=backend, action_mode=action_mode, world_seed=world_seed,
                                      **settings)
        self.task = self.single_env.task
        self.max_steps = self.single_env.max_steps
        if max_episode_steps is not None and max_episode_steps != -1:
            if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, Integral) \
                    or max_episode_steps < 1:
                raise ConfigError(f"NeuronavVectorEnv: max_episode_steps must be None or -1 (no limit but the "
                                  f"task's, as in gymnasium.make) or an int >= 1, got {max_episode_steps!r}")
            self.max_steps = min(self.max_steps, int(max_episode_steps))
        self.single_observation_space = self.single_env.observation_space
        self.single_action_space = self.single_env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {"autoreset_mode": self.autoreset_mode, "render_modes": []}
        self.render_mode = None
        self.engine, body, _, _ = make_engine(backend, self.task.physics_timestep_s)
        self.engine.load(self.task.world(world_seed), [replace(body, count=self.num_envs)])
        self.controls_per_step = self.single_env.clocks.controls_per_brain
        self.state_ports = state_ports(self.task, self.single_observation_space)
        self._np_randoms: list[np.random.Generator | None] = [None] * self.num_envs
        self._state: dict[str, np.ndarray] | None = None
        self._distance = np.zeros(self.num_envs)
        self._steps = np.zeros(self.num_envs, dtype=np.int64)
        self._ended = np.zeros(self.num_envs, dtype=bool)

    @staticmethod
    def _check_autoreset_mode(mode) -> AutoresetMode:
        try:
            return mode if isinstance(mode, AutoresetMode) else AutoresetMode(mode)
        except ValueError:
            raise ConfigError(f"NeuronavVectorEnv: autoreset_mode must be one of "
                              f"{', '.join(m.value for m in AutoresetMode)}, got {mode!r}") from None

    # -- the Gymnasium vector API ----------------------------------------------------------------
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        seeds = self._check_seeds(seed)
        mask = self._check_options(options)
        index = np.flatnonzero(mask)
        for i in index:
            if seeds[i] is not None or self._np_randoms[i] is None:
                self._np_randoms[i], _ = seeding.np_random(seeds[i])
        if self._state is None and not mask.all():
            raise gymnasium.error.ResetNeeded("reset every env (no reset_mask) before resetting some")
        self._reset_envs(index)
        self._state = self._read()
        self._distance = self.task.distance_m(self._state)
        self._ended[index] = False
        infos = self._infos(self._state, self._distance, np.zeros(self.num_envs, dtype=bool))
        return self._observations(self._state), masked(infos, mask)

    def step(self, actions):
        if self._state is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        command = self._check_actions(actions)
        restart = self._ended.copy()
        if self.autoreset_mode == AutoresetMode.DISABLED and restart.any():
            raise gymnasium.error.ResetNeeded(f"envs {np.flatnonzero(restart).tolist()} ended their episodes; "
                                              f"reset them (reset(options={{'reset_mask': mask}})) before step()")
        self.engine.write({"turn": command[:, :1], "stride": command[:, 1:]})
        self.engine.step(self.controls_per_step)
        self._steps += 1
        if self.autoreset_mode == AutoresetMode.NEXT_STEP and restart.any():
            self._reset_envs(np.flatnonzero(restart))
        state = self._read()
        distance = self.task.distance_m(state)
        reward = self._distance - distance
        terminated = np.asarray(self.task.terminated(state), dtype=bool)
        truncated = ~terminated & (self._steps >= self.max_steps)
        reward[restart], terminated[restart], truncated[restart] = 0.0, False, False
        self._ended = terminated | truncated
        observations, infos = self._observations(state), self._infos(state, distance, terminated)
        if self.autoreset_mode == AutoresetMode.SAME_STEP and self._ended.any():
            ended = np.flatnonzero(self._ended)
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in ended:
                final_obs[i] = {name: value[i] for name, value in observations.items()}
            final = {"final_obs": final_obs, "_final_obs": self._ended.copy(),
                     "final_info": masked(infos, self._ended), "_final_info": self._ended.copy()}
            self._reset_envs(ended)
            self._ended[:] = False
            state = self._read()
            distance = self.task.distance_m(state)
            infos = {**self._infos(state, distance, np.zeros(self.num_envs, dtype=bool)), **final}
            observations = self._observations(state)
        self._state, self._distance = state, distance
        return observations, reward, terminated, truncated, infos

    def close(self, **kwargs: Any) -> None:
        self.engine.close()
        self.single_env.close()
        super().close(**kwargs)

    # -- helpers ----------------------------------------------------------------------------------
    def _reset_envs(self, index: np.ndarray) -> None:
        """Draw each env's episode seed from its generator and put its agent at its start."""
        if index.size == 0:
            return
        episode_seeds = [int(self._np_randoms[i].integers(0, EPISODE_SEED_END)) for i in index]
        positions, headings = task_starts(self.task, episode_seeds)
        self.engine.reset_agents(index, positions, yaw_rad=np.pi / 2 - headings)
        self._steps[index] = 0

    def _read(self) -> dict[str, np.ndarray]:
        """Every agent's readings of the ports the observations, reward and success need (N, ...)."""
        return self.engine.read(self.state_ports)

    def _observations(self, state: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return observe(self.task, state, self.single_observation_space)

    def _infos(self, state: dict[str, np.ndarray], distance: np.ndarray, success: np.ndarray) -> dict[str, np.ndarray]:
        """The single env's info, batched: ``distance_m``, ``time_s``, ``is_success`` (False at a reset),
        ``fell`` (a point agent never falls), each with its ``_key`` mask."""
        time_s = self._steps * self.controls_per_step * self.single_env.clocks.control_dt_s
        values = {"distance_m": distance, "time_s": time_s, "is_success": success.copy(),
                  "fell": np.zeros(self.num_envs, dtype=bool)}
        return {**values, **{f"_{key}": np.ones(self.num_envs, dtype=bool) for key in values}}

    def _check_seeds(self, seed) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, Integral) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        elif isinstance(seed, (list, tuple)) and len(seed) == self.num_envs:
            seeds = list(seed)
        else:
            raise ConfigError(f"NeuronavVectorEnv reset: seed must be None, an int >= 0 or a list of "
                              f"{self.num_envs} (int >= 0 or None), got {seed!r}")
        for value in seeds:
            if value is not None and (isinstance(value, bool) or not isinstance(value, Integral) or value < 0):
                raise ConfigError(f"NeuronavVectorEnv reset: seeds must be ints >= 0 or None, got {value!r} "
                                  f"in {seed!r}")
        return [None if value is None else int(value) for value in seeds]

    def _check_options(self, options) -> np.ndarray:
        if options is None:
            return np.ones(self.num_envs, dtype=bool)
        if not isinstance(options, dict) or set(options) - {"reset_mask"}:
            raise ConfigError(f"NeuronavVectorEnv reset: the only option is 'reset_mask' (a bool array of "
                              f"{self.num_envs}), got {options!r}")
        mask = options["reset_mask"]
        if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (self.num_envs,) \
                or not mask.any():
            raise ConfigError(f"NeuronavVectorEnv reset: reset_mask must be a bool array of shape ({self.num_envs},) "
                              f"with at least one True, got {mask!r}")
        return mask

    def _check_actions(self, actions) -> np.ndarray:
        """The single env's action rule (:func:`~neuronav.scenarios.envs.observations.check_actions`: clipped to
        the box; not real, not finite or another shape: a PortError), for (N, 2) actions."""
        try:
            rows = np.shape(actions)[:1]
        except ValueError:  # a ragged sequence
            rows = None
        if rows != (self.num_envs,):
            raise PortError(f"actions must be ({self.num_envs}, 2) finite real numbers: each env's (turn, stride_rad); "
                            f"got {type(actions).__name__} {actions!r:.200}")
        command = check_actions(actions, self.single_action_space.low, self.single_action_space.high,
                                "turn, stride_rad")
        if command.shape != self.action_space.shape:  # N numbers, not N actions
            raise PortError(f"actions must be ({self.num_envs}, 2): each env's (turn, stride_rad); "
                            f"got {actions!r:.200}")
        return command
