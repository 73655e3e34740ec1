"""The swarm as a PettingZoo parallel environment: several ants in one world, each steered by its own policy.

``SwarmHomingEnv(backend="kinematic", ants=4, max_cycles=150, **settings)`` runs the bodies of
:mod:`neuronav.scenarios.swarm_homing.scenario`
(:class:`~neuronav.scenarios.swarm_homing.scenario.SwarmBodies`: kinematic unicycles,
or desert ants walked by their own FK tripod gaits in one MuJoCo or PyBullet world, colliding with
each other);
``settings`` are swarm-homing's (``spacing_m``, ``nest_radius_m``, ``timestep_s``, ...: the keys of
``neuronav run swarm-homing --set``). Agents are ``"ant_0"`` .. ``"ant_{N-1}"``.

Episode: ant i starts at its home of the swarm's sunflower spiral
(:func:`~neuronav.scenarios.swarm_homing.scenario.home_positions`, ``spacing_m`` apart) facing a seeded heading; its
goal lies a seeded distance of 3 nest radii to ``MAX_GOAL_M`` away in a seeded direction (goals may
lie where other ants stand: they meet on the way).

Spaces per agent, from the ports: observation ``Dict`` of ``heading`` (1,) rad in [-π, π] and
``velocity`` (2,) (the backend's ``heading`` and ``velocity`` sensors, their shapes and units) and
``goal_vector`` (2,) m, the goal minus the body's position in world axes; float32. Action ``Box``
(2,): the locomotion command (``turn`` θ in [-1, 1], ``stride`` S_l in [0, 25°]), held for one gait
cycle (0.64 s) and walked by the ant's gait (or the unicycle); clipped to the box. Reward: progress
toward the goal over the step (m). An ant within ``nest_radius_m`` of its goal is terminated and
stands from then on (turn 0, stride 0); all are truncated after ``max_cycles`` steps. ``reset(seed)``
seeds the episode: the same seed gives the same episode.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from neuronav.angles import angle_difference_rad
from neuronav.config import build_config
from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs.gym_env import MAX_STRIDE_RAD, port_box
from neuronav.scenarios.swarm_homing.scenario import (
    CONTROL_S,
    CYCLE_S,
    SwarmBodies,
    SwarmHoming,
    SwarmHomingConfig,
    home_positions,
)

MAX_GOAL_M = 6.0


class SwarmHomingEnv(ParallelEnv):
    """Several ants in one world as a PettingZoo ``ParallelEnv`` (see the module docstring)."""

    metadata = {"name": "neuronav_swarm_homing_v0", "render_modes": []}

    def __init__(self, backend: str = "kinematic", ants: int = 4, max_cycles: int = 150, **settings) -> None:
        if isinstance(max_cycles, bool) or not isinstance(max_cycles, int) or max_cycles < 1:
            raise ConfigError(f"SwarmHomingEnv: max_cycles must be an int >= 1 (gait cycles of 0.64 s), "
                              f"got {max_cycles!r}")
        if backend not in SwarmHoming.backends:
            raise ConfigError(f"SwarmHomingEnv: backend must be one of {', '.join(SwarmHoming.backends)}, "
                              f"got {backend!r}")
        self.config = build_config(SwarmHomingConfig, {**settings, "ants": ants})
        SwarmHoming().check(self.config, backend)
        self.backend_name, self.max_cycles = backend, max_cycles
        self.bodies = SwarmBodies(backend, self.config)
        self.possible_agents = [f"ant_{i}" for i in range(self.config.ants)]
        self.agents: list[str] = []
        self._controls = int(round(CYCLE_S / CONTROL_S))
        sensors = {spec.name: spec for spec in self.bodies.engine.capabilities.sensors}
        heading = spaces.Box(np.float32(-np.pi), np.float32(np.pi), (1,), np.float32)
        self._observation_space = spaces.Dict({"heading": heading, "velocity": port_box(sensors["velocity"]),
                                               "goal_vector": spaces.Box(-np.inf, np.inf, (2,), np.float32)})
        self._action_space = spaces.Box(np.array([-1.0, 0.0], np.float32),
                                        np.array([1.0, MAX_STRIDE_RAD], np.float32), dtype=np.float32)
        self._rng = np.random.default_rng()

    def observation_space(self, agent: str) -> spaces.Dict:
        """Every ant's observation space (one object: the same for all)."""
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Box:
        """Every ant's action space: the locomotion command (turn, stride_rad)."""
        return self._action_space

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        n = self.config.ants
        starts = home_positions(n, self.config.spacing_m)
        headings = self._rng.uniform(0.0, 2.0 * np.pi, n)
        distance = self._rng.uniform(3.0 * self.config.nest_radius_m, MAX_GOAL_M, n)
        direction = self._rng.uniform(0.0, 2.0 * np.pi, n)
        self.goals_m = starts + distance[:, None] * np.column_stack([np.sin(direction), np.cos(direction)])
        self.bodies.reset(starts, headings)
        self.agents = list(self.possible_agents)
        self._done = np.zeros(n, dtype=bool)
        self._cycles = 0
        self._sense()
        return self._observations(), {agent: self._info(i) for i, agent in enumerate(self.possible_agents)}

    def step(self, actions: dict):
        if not self.agents:
            raise PortError("SwarmHomingEnv: every ant is done; call reset()")
        n = self.config.ants
        command = np.zeros((n, 2))
        for agent in self.agents:
            action = np.asarray(actions.get(agent, (0.0, 0.0)), float).reshape(-1)
            if action.shape != (2,) or not np.isfinite(action).all():
                raise PortError(f"SwarmHomingEnv: {agent}'s action must be 2 finite numbers (turn, stride_rad), "
                                f"got {actions.get(agent)!r}")
            command[int(agent.split("_")[1])] = np.clip(action, self._action_space.low, self._action_space.high)
        command[self._done] = 0.0  # an ant at its goal stands
        before = self._distance.copy()
        for _ in range(self._controls):
            self.bodies.control_step(command[:, 0], command[:, 1])
        self._cycles += 1
        self._sense()
        arrived = self._distance <= self.config.nest_radius_m
        truncate = self._cycles >= self.max_cycles
        live = list(self.agents)
        index = {agent: int(agent.split("_")[1]) for agent in live}
        rewards = {a: float(before[i] - self._distance[i]) for a, i in index.items()}
        terminations = {a: bool(arrived[i]) for a, i in index.items()}
        truncations = {a: bool(truncate and not arrived[i]) for a, i in index.items()}
        observations = self._observations(live)
        infos = {a: self._info(i) for a, i in index.items()}
        self._done |= arrived
        self.agents = [a for a in live if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    # -- helpers ------------------------------------------------------------------------------------
    def _sense(self) -> None:
        self._state = self.bodies.engine.read(("heading", "velocity", "position"))
        self._distance = np.hypot(*(self.goals_m - self._state["position"]).T)

    def _observations(self, agents=None) -> dict:
        state = self._state
        goal = self.goals_m - state["position"]
        heading = angle_difference_rad(state["heading"], 0.0)  # wrapped to [-π, π]
        return {agent: {"heading": heading[i].astype(np.float32), "velocity": state["velocity"][i].astype(np.float32),
                        "goal_vector": goal[i].astype(np.float32)}
                for i, agent in enumerate(self.possible_agents) if agents is None or agent in agents}

    def _info(self, index: int) -> dict:
        return {"distance_m": float(self._distance[index]), "time_s": self._cycles * CYCLE_S}

    def close(self) -> None:
        self.bodies.engine.close()
