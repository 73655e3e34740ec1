"""The swarm as a PettingZoo parallel environment: several ants in one world, each steered by its own policy.

``SwarmHomingEnv(backend="kinematic", ants=4, max_cycles=150, render_mode=None, **settings)`` runs the
bodies of :mod:`neuronav.scenarios.swarm_homing.scenario`
(:class:`~neuronav.scenarios.swarm_homing.scenario.SwarmBodies`: kinematic unicycles,
or desert ants walked by their own FK tripod gaits in one MuJoCo or PyBullet world, colliding with
each other);
``settings`` are swarm-homing's (``spacing_m``, ``nest_radius_m``, ``timestep_s``, ...: the keys of
``neuronav run swarm-homing --set``). Agents are ``"ant_0"`` .. ``"ant_{N-1}"``.

Episode: ant i starts at its home of the swarm's sunflower spiral
(:func:`~neuronav.scenarios.swarm_homing.scenario.home_positions`, ``spacing_m`` apart) facing a seeded heading; its
goal (its nest) lies a seeded distance of 3 nest radii to ``MAX_GOAL_M`` away in a seeded direction (goals may
lie where other ants stand: they meet on the way). ``reset(seed)`` seeds the episode (None or an int >= 0):
the same seed gives the same episode. ``reset`` takes no options; ``options`` is accepted and ignored
(PettingZoo's ``parallel_api_test`` passes one).

Observation per agent, a ``Dict`` of float32 ``Box`` es with the single-ant Gymnasium environment's
names, frames and units (:mod:`neuronav.scenarios.envs.observations`): heading h clockwise from world +y;
the body frame's axes are (forward, left) in the ground plane, forward being (sin h, cos h) in world (x, y).

=================  =====  ===============  ============================================================
key                shape  units, bounds    what, frame
=================  =====  ===============  ============================================================
``heading``        (2,)   [-1, 1]          (sin h, cos h): the forward axis in world (x, y); the same on
                                           every backend, however the backend wraps h
``velocity_body``  (2,)   m/s, unbounded   the root's ground velocity, body frame (forward, left)
``goal_vector``    (2,)   m, unbounded     the goal (this ant's nest) from the root, body frame
                                           (forward, left)
=================  =====  ===============  ============================================================

Action per agent: ``Box`` (2,), the locomotion command (``turn`` θ in [-1, 1], θ > 0 turns left;
``stride`` S_l in [0, 25°] rad), held for one gait cycle (0.64 s) and walked by the ant's gait (or the
unicycle). One rule with the single environment (:data:`~neuronav.scenarios.envs.observations.ACTION_RULE`):
finite actions outside the box are clipped to it; anything but 2 finite real numbers (a string, a dict,
complex numbers, another shape) is a :class:`~neuronav.errors.PortError` naming the ant.
``step(actions)`` takes exactly one action for each ant of ``env.agents``: a missing ant (it does not
stand still by default), a name that is not an agent, or an ant already done (terminated or truncated)
is refused with a PortError naming them. Reward: progress toward the goal over the step (m). An ant
within ``nest_radius_m`` of its goal is terminated (a success) and stands from then on (turn 0, stride
0); on a physics backend so is an ant that fell, by the single environment's rule
(:data:`~neuronav.scenarios.envs.observations.FALL_RULE`: its up axis more than 60° from vertical; not
a success); all are truncated after ``max_cycles`` steps. Stepping before ``reset()``, or after every
ant is done, raises ``gymnasium.error.ResetNeeded``. ``info`` per agent: ``distance_m`` to its goal,
``time_s`` of the episode, ``is_success`` (within ``nest_radius_m`` of its goal, not fallen), ``fell``
(always False on the kinematic backend).

``render_mode="rgb_array"``: ``render()`` returns a (256, 256, 3) uint8 top view of the whole swarm,
+y up, on every backend (:func:`swarm_top_view`: each ant's goal as a disc of ``nest_radius_m``, its
path so far and the ant with a heading tick, one colour per ant). The swarm backends carry no cameras,
so the physics backends are drawn the same way from their bodies' positions. ``render_mode="human"``
is refused (draw the rgb_array frames, e.g. with matplotlib).
"""

from __future__ import annotations

from collections.abc import Mapping

import gymnasium
import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from neuronav.config import build_config
from neuronav.engine.backend import check_seed
from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs.gym_env import MAX_STRIDE_RAD
from neuronav.scenarios.envs.observations import FALL_TILT_DEG, body_frame, check_actions, fallen, heading_sin_cos
from neuronav.scenarios.swarm_homing.scenario import (
    CONTROL_S,
    CYCLE_S,
    SwarmBodies,
    SwarmHoming,
    SwarmHomingConfig,
    home_positions,
)

MAX_GOAL_M = 6.0
RENDER_PX = 256
BACKGROUND = (235, 225, 200)
# One colour per ant, cycled: the ant, its heading tick and (lighter) its goal and (darker) its path.
PALETTE = np.array([(200, 30, 30), (30, 90, 200), (30, 140, 60), (200, 120, 0), (140, 50, 170),
                    (0, 150, 150), (170, 90, 40), (90, 90, 90)], dtype=float)


def swarm_top_view(paths_m: np.ndarray, headings_rad: np.ndarray, goals_m: np.ndarray, radius_m: float,
                   size_px: int = RENDER_PX) -> np.ndarray:
    """A (size_px, size_px, 3) uint8 top view, +y up, of a swarm: paths (P, N, 2) m (the last row is now),
    headings (N,) rad clockwise from +y, goals (N, 2) m drawn as discs of ``radius_m`` (at least a pixel).

    The square frames every path point and goal disc with a 5 % margin, at least 2 m wide. Ant i is
    drawn in ``PALETTE[i % 8]``: its goal lighter, its path darker, its body a 3 × 3 px square with a
    4 px heading tick.
    """
    paths = np.asarray(paths_m, float).reshape(-1, len(goals_m), 2)
    goals = np.asarray(goals_m, float).reshape(-1, 2)
    points = np.vstack([paths.reshape(-1, 2), goals - radius_m, goals + radius_m])
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    half_m = max(float(np.ptp(points, axis=0).max()) / 2 * 1.05, 1.0)
    to_m = 2 * half_m / size_px
    colours = PALETTE[np.arange(len(goals)) % len(PALETTE)]
    image = np.empty((size_px, size_px, 3), np.uint8)
    image[:] = BACKGROUND

    def pixels(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cols = np.clip(((xy[..., 0] - centre[0] + half_m) / to_m).astype(int), 0, size_px - 1)
        rows = np.clip(((centre[1] + half_m - xy[..., 1]) / to_m).astype(int), 0, size_px - 1)
        return rows, cols

    disc_m = max(radius_m, to_m)
    reach = int(np.ceil(disc_m / to_m)) + 1
    for goal, colour in zip(goals, colours):  # each disc over its own bounding box
        row, col = pixels(goal)
        r0, r1 = max(row - reach, 0), min(row + reach, size_px - 1)
        c0, c1 = max(col - reach, 0), min(col + reach, size_px - 1)
        x_m = centre[0] - half_m + (np.arange(c0, c1 + 1) + 0.5) * to_m
        y_m = centre[1] + half_m - (np.arange(r0, r1 + 1) + 0.5) * to_m
        inside = np.hypot(x_m[None, :] - goal[0], y_m[:, None] - goal[1]) <= disc_m
        image[r0:r1 + 1, c0:c1 + 1][inside] = (255 - (255 - colour) * 0.35).astype(np.uint8)
    for first in range(0, len(paths) - 1, 16):  # 16 cycles at a time; each segment at half-pixel spacing
        start, end = paths[first:first + 16], paths[first + 1:first + 17]
        start = start[:len(end)]
        step_px = np.hypot(*(end - start).transpose(2, 0, 1)) / to_m
        t = np.linspace(0.0, 1.0, int(np.ceil(step_px.max() * 2)) + 2)
        rows, cols = pixels(start[:, :, None] + t[:, None] * (end - start)[:, :, None])  # (S, N, T)
        image[rows, cols] = (colours * 0.6).astype(np.uint8)[None, :, None]
    now = paths[-1]
    ticks = now[:, None] + np.linspace(0.0, 4 * to_m, 9)[:, None] * np.column_stack(
        [np.sin(headings_rad), np.cos(headings_rad)])[:, None]
    rows, cols = pixels(ticks)
    image[rows, cols] = colours.astype(np.uint8)[:, None]
    rows, cols = pixels(now)
    for d_row in (-1, 0, 1):
        for d_col in (-1, 0, 1):
            image[np.clip(rows + d_row, 0, size_px - 1), np.clip(cols + d_col, 0, size_px - 1)] = colours
    return image


class SwarmHomingEnv(ParallelEnv):
    """Several ants in one world as a PettingZoo ``ParallelEnv`` (see the module docstring)."""

    metadata = {"name": "neuronav_swarm_homing_v0", "render_modes": ["rgb_array"], "render_fps": 1.0 / CYCLE_S}

    def __init__(self, backend: str = "kinematic", ants: int = 4, max_cycles: int = 150,
                 render_mode: str | None = None, **settings) -> None:
        if isinstance(max_cycles, bool) or not isinstance(max_cycles, int) or max_cycles < 1:
            raise ConfigError(f"SwarmHomingEnv: max_cycles must be an int >= 1 (gait cycles of 0.64 s), "
                              f"got {max_cycles!r}")
        if backend not in SwarmHoming.backends:
            raise ConfigError(f"SwarmHomingEnv: backend must be one of {', '.join(SwarmHoming.backends)}, "
                              f"got {backend!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"SwarmHomingEnv: render_mode must be None or 'rgb_array' (a top view of the swarm; "
                              f"show its frames yourself, e.g. with matplotlib), got {render_mode!r}")
        self.config = build_config(SwarmHomingConfig, {**settings, "ants": ants})
        SwarmHoming().check(self.config, backend)
        self.backend_name, self.max_cycles, self.render_mode = backend, max_cycles, render_mode
        self.bodies = SwarmBodies(backend, self.config)
        self.possible_agents = [f"ant_{i}" for i in range(self.config.ants)]
        self.agents: list[str] = []
        self._index = {agent: i for i, agent in enumerate(self.possible_agents)}
        self._controls = int(round(CYCLE_S / CONTROL_S))
        unbounded = spaces.Box(-np.inf, np.inf, (2,), np.float32)
        self._observation_space = spaces.Dict({"heading": spaces.Box(-1.0, 1.0, (2,), np.float32),
                                               "velocity_body": unbounded, "goal_vector": unbounded})
        self._action_space = spaces.Box(np.array([-1.0, 0.0], np.float32),
                                        np.array([1.0, MAX_STRIDE_RAD], np.float32), dtype=np.float32)
        self._rng = np.random.default_rng()
        self._done: np.ndarray | None = None  # None until the first reset()
        self._path: list[np.ndarray] = []

    def observation_space(self, agent: str) -> spaces.Dict:
        """Every ant's observation space (one object: the same for all)."""
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Box:
        """Every ant's action space: the locomotion command (turn, stride_rad)."""
        return self._action_space

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode (see the module docstring); ``options`` are ignored. Returns (observations, infos)."""
        seed = check_seed("SwarmHomingEnv", seed)
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
        self._path = [self._state["position"].copy()] if self.render_mode else []
        return self._observations(self.agents), {agent: self._info(i) for i, agent in enumerate(self.agents)}

    def step(self, actions: dict):
        """Walk every live ant one gait cycle; ``actions`` holds one (turn, stride_rad) per ant of ``env.agents``."""
        if self._done is None:
            raise gymnasium.error.ResetNeeded("SwarmHomingEnv: call reset() before step()")
        if not self.agents:
            raise gymnasium.error.ResetNeeded("SwarmHomingEnv: every ant is done (terminated or truncated); "
                                              "call reset()")
        command = self._commands(actions)
        before = self._distance.copy()
        for _ in range(self._controls):
            self.bodies.control_step(command[:, 0], command[:, 1])
        self._cycles += 1
        self._sense()
        if self.render_mode:
            self._path.append(self._state["position"].copy())
        ended = self._success | self._fell
        truncate = self._cycles >= self.max_cycles
        live = list(self.agents)
        index = {agent: self._index[agent] for agent in live}
        rewards = {a: float(before[i] - self._distance[i]) for a, i in index.items()}
        terminations = {a: bool(ended[i]) for a, i in index.items()}
        truncations = {a: bool(truncate and not ended[i]) for a, i in index.items()}
        observations = self._observations(live)
        infos = {a: self._info(i) for a, i in index.items()}
        self._done |= ended
        self.agents = [a for a in live if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    def render(self) -> np.ndarray | None:
        """The swarm's top view (RENDER_PX, RENDER_PX, 3) uint8 with ``render_mode="rgb_array"``; else None
        (also before the first ``reset()``)."""
        if self.render_mode != "rgb_array" or self._done is None:
            return None
        return swarm_top_view(np.array(self._path), self._state["heading"][:, 0], self.goals_m,
                              self.config.nest_radius_m)

    def close(self) -> None:
        self.bodies.engine.close()

    # -- helpers ------------------------------------------------------------------------------------
    def _commands(self, actions) -> np.ndarray:
        """The (N, 2) command from one action per live ant, each checked and clipped; done ants stand."""
        if not isinstance(actions, Mapping):
            raise PortError(f"SwarmHomingEnv: actions must be a dict {{agent: (turn, stride_rad)}} with one entry "
                            f"for each of env.agents, got {type(actions).__name__}")
        unknown = [a for a in actions if a not in self._index]
        if unknown:
            raise PortError(f"SwarmHomingEnv: actions for unknown agents {_names(unknown)}; the agents are "
                            f"{_names(self.possible_agents)}")
        live = set(self.agents)
        finished = [a for a in actions if a not in live]
        if finished:
            raise PortError(f"SwarmHomingEnv: actions for {_names(finished)}, which are done (terminated or "
                            f"truncated) and take none: send one for each of env.agents")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise PortError(f"SwarmHomingEnv: no action for {_names(missing)}: every ant of env.agents needs one "
                            f"(turn, stride_rad); a missing ant does not stand still by default")
        command = np.zeros((self.config.ants, 2))
        for agent, action in actions.items():
            command[self._index[agent]] = _action(agent, action, self._action_space)
        command[self._done] = 0.0  # an ant at its goal (or fallen) stands
        return command

    def _sense(self) -> None:
        physics = ("body_quat",) if self.backend_name != "kinematic" else ()
        self._state = self.bodies.engine.read(("heading", "velocity", "position", *physics))
        self._distance = np.hypot(*(self.goals_m - self._state["position"]).T)
        self._fell = fallen(self._state, FALL_TILT_DEG)
        self._success = (self._distance <= self.config.nest_radius_m) & ~self._fell  # at the goal and standing

    def _observations(self, agents: list[str]) -> dict:
        state = self._state
        heading = state["heading"][:, 0]
        values = {"heading": heading_sin_cos(heading), "velocity_body": body_frame(state["velocity"], heading),
                  "goal_vector": body_frame(self.goals_m - state["position"], heading)}
        values = {key: value.astype(np.float32) for key, value in values.items()}
        return {agent: {key: value[self._index[agent]] for key, value in values.items()} for agent in agents}

    def _info(self, index: int) -> dict:
        return {"distance_m": float(self._distance[index]), "time_s": self._cycles * CYCLE_S,
                "is_success": bool(self._success[index]), "fell": bool(self._fell[index])}


def _action(agent: str, action, space: spaces.Box) -> np.ndarray:
    """One ant's action clipped to ``space`` (the single environment's rule,
    :func:`~neuronav.scenarios.envs.observations.check_actions`), or a PortError naming the ant."""
    try:
        command = check_actions(action, space.low, space.high, "turn, stride_rad", count=1)
    except PortError as error:
        raise PortError(f"SwarmHomingEnv: {agent}'s {error}") from None
    return command[0]


def _names(agents: list, shown: int = 5) -> str:
    """Agent names for a message: the first ``shown``, then how many more."""
    names = ", ".join(repr(a) for a in agents[:shown])
    return names + (f" and {len(agents) - shown} more" if len(agents) > shown else "")
