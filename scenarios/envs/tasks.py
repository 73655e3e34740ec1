"""Engine-free navigation tasks: what the learning environments (Gymnasium, dm_control) share.

A task says what an episode is; an adapter (:mod:`neuronav.scenarios.envs.gym_env`, the dm_control tasks)
only runs it on a backend, so a reward is written once. Each task wraps one scenario's settings
(its config dataclass, validated by :func:`neuronav.config.build_config`: the same keys as
``neuronav run ... --set``) and reuses that scenario's world:

==========  ==========================================  ==========================  ==================
task        world and start                             goal (reward: progress)     success radius
==========  ==========================================  ==========================  ==================
``homing``  the embodied homing floor; the ant starts   the nest at (0, 0)          ``nest_radius_m``
            where a seeded foraging walk ended (at
            least 3 nest radii from the nest)
``beacon``  the visual beacon's landmark and forest     the landmark (0, d)         ``success_radius_m``
            (:func:`neuronav.scenarios.visual_beacon.scenario.beacon_world`)
``plume``   the plume-tracking arena and plume          the odour source            ``success_radius_m``
            (:func:`neuronav.scenarios.plume_tracking.scenario.plume_world`)
==========  ==========================================  ==========================  ==================

The API, all a task offers:

- ``task.world(seed=0)`` -> :class:`~neuronav.spec.world.World` (only the beacon's forest depends on the seed);
- ``task.start(seed)`` -> :class:`Start` (position (2,) m, heading rad clockwise from +y), the same
  for the same seed;
- ``task.goal_m`` (2,) m; ``task.success_radius_m``; ``task.time_limit_s`` (the scenario's timeout);
- ``task.backends``: the backends its scenario runs on; ``task.physics_timestep_s``: the scenario's
  physics step of the ant on a physics backend;
- ``task.observation_ports``: the backend sensors an agent observes (made into the environments'
  observations by :mod:`neuronav.scenarios.envs.observations`); ``task.task_sensors``: the
  :class:`~neuronav.spec.ports.SensorSpec` of observations the task computes itself (``observe``);
- ``task.state_ports``: every sensor the task reads (``position`` and ``heading`` first);
- ``read_state(backend, task)`` -> the state: ``{port: reading}`` of agent 0, batch dimension removed;
- ``task.observe(state)`` -> the task's own observations (e.g. the homing vector);
- ``task.reward(prev_state, state)``: progress toward the goal in m (distance before minus after);
- ``task.terminated(state)``: the goal is reached (the body, or for the plume an antenna tip,
  within ``success_radius_m``);
- ``observe``, ``distance_m``, ``reward`` and ``terminated`` also take a batched state (every reading
  with a leading axis of N agents, as a backend reads it) and then give (N,) arrays (``observe``:
  (N, ...)); ``task.goal_of(state)``: the goal, the state's ``goal_m`` (N, 2) where an environment
  moved it (``reset(options={"goal_m": ...})``, only where ``task.movable_goal``), else ``goal_m``;
- ``task.seeded_world``: whether ``world(seed)`` depends on the seed (the beacon's forest);
- ``task.step_limit(step_s)``: how many steps of ``step_s`` fit in ``time_limit_s`` (an episode
  that reaches it is truncated, not terminated).

``make_task(name, **settings)`` builds a task by name (:data:`TASKS`) with its scenario's settings;
``check_world_seed(seed)``: a world seed every adapter accepts (an int >= 0; None is refused).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral
from typing import Any, ClassVar

import numpy as np

from neuronav.bodies.desert_ant.unicycle import unicycle_calibration
from neuronav.config import build_config
from neuronav.errors import ConfigError
from neuronav.scenarios.path_integration.embodied import CONTROL_S, CYCLE_S
from neuronav.scenarios.path_integration.scenario import PathIntegration, PathIntegrationConfig
from neuronav.scenarios.plume_tracking.scenario import PlumeTracking, PlumeTrackingConfig, plume_world, start_pose
from neuronav.scenarios.visual_beacon.scenario import START_HEADINGS_RAD, VisualBeacon, VisualBeaconConfig, beacon_world
from neuronav.spec.ports import SensorSpec
from neuronav.spec.world import Ground, World

# The embodied homing scenario's floor (neuronav.scenarios.path_integration.embodied.embodied_trial).
HOMING_FLOOR_M = 80.0
# A homing episode starts at least this many nest radii from the nest (else it would start home).
MIN_START_RADII = 3.0
# Foraging walks drawn at the most to find such a start.
MAX_WALKS = 100


@dataclass(frozen=True)
class Start:
    """Where an episode starts: ``position_m`` (2,) and ``heading_rad`` (clockwise from +y)."""

    position_m: np.ndarray
    heading_rad: float


def forward_left(heading_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """The body's forward (sin h, cos h) and left (-cos h, sin h) unit vectors in the world's xy plane."""
    return np.array([np.sin(heading_rad), np.cos(heading_rad)]), np.array([-np.cos(heading_rad), np.sin(heading_rad)])


class NavigationTask:
    """Walk to a goal: the reward is the progress toward it, success within ``success_radius_m``.

    Subclasses set ``name``, ``scenario`` (the scenario class whose settings and backends the task
    takes), ``config_type``, ``observation_ports``, where their goal, success radius, time limit and
    physics step are read in the scenario's settings (``goal_keys``, ``success_radius_key``,
    ``time_limit_key``, ``physics_timestep_key``), and implement ``world`` and ``start``.
    """

    name: ClassVar[str]
    scenario: ClassVar[type]
    config_type: ClassVar[type]  # the scenario's config dataclass
    observation_ports: ClassVar[tuple[str, ...]]
    task_sensors: ClassVar[tuple[SensorSpec, ...]] = ()
    # Where the task's numbers come from: a key of the scenario's config, or (for goal_keys) a number.
    goal_keys: ClassVar[tuple[str | float, str | float]]  # the goal's (x, y) in m
    success_radius_key: ClassVar[str]  # m
    time_limit_key: ClassVar[str]  # s
    physics_timestep_key: ClassVar[str] = "timestep_s"  # s, the ant's physics step on a physics backend
    # Whether an episode may move the goal (a goal with nothing built at it), and whether the world depends on its seed.
    movable_goal: ClassVar[bool] = False
    seeded_world: ClassVar[bool] = False

    def __init__(self, **settings: Any) -> None:
        self.config = build_config(self.config_type, settings)

    def setting(self, key: str | float) -> float:
        """The scenario's setting ``key`` as a float (a number given instead of a key is itself)."""
        return float(getattr(self.config, key)) if isinstance(key, str) else float(key)

    @property
    def backends(self) -> tuple[str, ...]:
        """The backends the task's scenario runs on."""
        return tuple(self.scenario.backends)

    @property
    def physics_timestep_s(self) -> float:
        """The scenario's physics step of the ant (s) on a physics backend."""
        return self.setting(self.physics_timestep_key)

    @property
    def goal_m(self) -> np.ndarray:
        """The goal (2,) m."""
        return np.array([self.setting(key) for key in self.goal_keys])

    @property
    def success_radius_m(self) -> float:
        """Success within this distance of the goal (m)."""
        return self.setting(self.success_radius_key)

    @property
    def time_limit_s(self) -> float:
        """The scenario's timeout (s): an episode that reaches it is truncated."""
        return self.setting(self.time_limit_key)

    # -- what subclasses define -----------------------------------------------------------------
    def world(self, seed: int = 0) -> World:
        raise NotImplementedError

    def start(self, seed: int) -> Start:
        raise NotImplementedError

    # -- shared ---------------------------------------------------------------------------------
    @property
    def state_ports(self) -> tuple[str, ...]:
        """Every backend sensor the task reads: position and heading, then the observed ports."""
        extra = tuple(p for p in self.observation_ports if p not in ("position", "heading"))
        return ("position", "heading", *extra)

    def observe(self, state: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The task's own observations (named as in ``task_sensors``); none by default."""
        return {}

    def goal_of(self, state: dict[str, np.ndarray]) -> np.ndarray:
        """The episode's goal (..., 2) m: the state's ``goal_m`` where an environment moved it, else :attr:`goal_m`."""
        return np.asarray(state["goal_m"], float) if "goal_m" in state else self.goal_m

    def distance_m(self, state: dict[str, np.ndarray]) -> float | np.ndarray:
        """The body's (root's) distance to the goal in the ground plane (m; (N,) for a batched state)."""
        offset = np.asarray(state["position"], float)[..., :2] - self.goal_of(state)
        return _scalar(np.hypot(offset[..., 0], offset[..., 1]))

    def reach_distance_m(self, state: dict[str, np.ndarray]) -> float | np.ndarray:
        """The distance that decides success (the root's, unless a task says otherwise)."""
        return self.distance_m(state)

    def reward(self, prev_state: dict[str, np.ndarray], state: dict[str, np.ndarray]) -> float | np.ndarray:
        """Progress toward the goal (m): the distance before the step minus the distance after."""
        return self.distance_m(prev_state) - self.distance_m(state)

    def terminated(self, state: dict[str, np.ndarray]) -> bool | np.ndarray:
        """Whether the goal is reached (a bool; (N,) bools for a batched state)."""
        reached = np.asarray(self.reach_distance_m(state)) <= self.success_radius_m
        return bool(reached) if reached.ndim == 0 else reached

    def step_limit(self, step_s: float) -> int:
        """Steps of ``step_s`` in ``time_limit_s`` (rounded up): the episode's length before truncation."""
        if not (np.isfinite(step_s) and step_s > 0):
            raise ConfigError(f"task {self.name!r}: step_s must be positive and finite, got {step_s!r}")
        return max(1, math.ceil(self.time_limit_s / step_s - 1e-9))


def foraging_walk(seed: int, outbound_s: float, turn_std: float, stride_rad: float,
                  attempt: int = 0, poses: list | None = None) -> tuple[np.ndarray, float]:
    """The end of embodied homing's foraging walk, engine-free: (position (2,) m, heading rad).

    The same walk as :class:`neuronav.scenarios.path_integration.embodied.HomingBrain` commands (from the nest, heading
    uniform in [0, 2π), a turn command ``0.7 turn + N(0, turn_std)`` per gait cycle at a fixed
    stride), moved as the kinematic unicycle moves: the desert ant's calibration (the body data the kinematic
    backend walks by) read through :meth:`~neuronav.spec.unicycle.UnicycleCalibration.rates`, the
    interpolation the backend's step calls, in 8 ms steps. Each gait cycle's constant command is summed in
    closed form, which ends within 1e-9 m of the backend's step-by-step walk (``tests/unit/test_env_tasks.py``).
    ``attempt`` 0 draws trial ``seed``'s walk as the scenario does; other attempts draw other walks.
    ``poses``, a list, receives (position, heading) at the start and at the end of every gait cycle.
    """
    calibration = unicycle_calibration()
    streams = [] if attempt == 0 else [attempt]
    rng = np.random.default_rng([seed, 3, *streams])
    heading = float(rng.uniform(0.0, 2.0 * np.pi))
    position, turn = np.zeros(2), 0.0
    steps_per_cycle = int(round(CYCLE_S / CONTROL_S))
    cycles = int(math.ceil(outbound_s / CYCLE_S - 1e-9))
    walk_rng = np.random.default_rng([seed, 2, *streams])
    if poses is not None:
        poses.append((position, heading))
    for _ in range(cycles):
        turn = float(np.clip(0.7 * turn + walk_rng.normal(0.0, turn_std), -1.0, 1.0))
        speed_m_s, turn_rate_rad_s = calibration.rates(turn, stride_rad)
        v_m_s, w_rad_s = float(speed_m_s[0]), float(turn_rate_rad_s[0])
        # Each control step turns, then moves along the new heading (the kinematic backend's order).
        headings = heading + w_rad_s * CONTROL_S * np.arange(1, steps_per_cycle + 1)
        position = position + v_m_s * CONTROL_S * np.array([np.sin(headings).sum(), np.cos(headings).sum()])
        heading = float(headings[-1])
        if poses is not None:
            poses.append((position, heading))
    return position, float(np.mod(heading, 2.0 * np.pi))


class HomingTask(NavigationTask):
    """Walk home from where a foraging walk ended, knowing the home vector (a perfect path integrator).

    Settings: the path-integration scenario's embodied (``i2bot``) keys: ``outbound_s``,
    ``foraging_turn_std``, ``foraging_stride_deg``, ``nest_radius_m``, ``homing_timeout_s``.
    Observation ``home_vector`` (2,) m: the nest from the body, in the body's frame (forward, left).
    """

    name = "homing"
    scenario = PathIntegration
    config_type = PathIntegrationConfig
    observation_ports = ("heading", "velocity")
    task_sensors = (SensorSpec("home_vector", (2,), "m"),)
    goal_keys = (0.0, 0.0)
    success_radius_key = "nest_radius_m"
    time_limit_key = "homing_timeout_s"
    physics_timestep_key = "embodied_timestep_s"
    movable_goal = True  # the nest is a point on a bare floor

    def __init__(self, home_vector: str = "oracle", **settings: Any) -> None:
        """``home_vector``: ``oracle`` (the true vector) or ``cx`` (the CX's estimate after integrating the
        foraging walk: :mod:`neuronav.scenarios.envs.path_integrator`); ``path_integrator``: the CX that ``start``
        primes with the walk (None with ``oracle`` unless a brain wrapper attaches one)."""
        from neuronav.scenarios.envs.path_integrator import HOME_VECTORS, CXPathIntegrator

        if home_vector not in HOME_VECTORS:
            raise ConfigError(f"homing: home_vector must be one of {', '.join(HOME_VECTORS)}; got {home_vector!r}")
        super().__init__(**settings)
        self.home_vector = home_vector
        self.path_integrator = CXPathIntegrator(self.config) if home_vector == "cx" else None

    def world(self, seed: int = 0) -> World:
        return World(ground=Ground(size_m=HOMING_FLOOR_M))

    def start(self, seed: int) -> Start:
        """The end of trial ``seed``'s foraging walk; a walk that ends within ``MIN_START_RADII`` nest
        radii of the nest is replaced by the next attempt's (at the defaults, 30 of seeds 0-199's first
        walks: ``sum(hypot(*foraging_walk(s, 32.0, 0.35, radians(15))[0]) < 2.01 for s in range(200))``)."""
        for attempt in range(MAX_WALKS):
            position, heading = foraging_walk(seed, self.config.outbound_s, self.config.foraging_turn_std,
                                              np.radians(self.config.foraging_stride_deg), attempt)
            if np.hypot(*position) >= MIN_START_RADII * self.config.nest_radius_m:
                break
        else:
            raise ConfigError(f"homing: no foraging walk of {MAX_WALKS} ended {MIN_START_RADII} nest radii "
                              f"({MIN_START_RADII * self.config.nest_radius_m:g} m) from the nest; lengthen "
                              f"outbound_s ({self.config.outbound_s:g} s) or shrink nest_radius_m")
        if self.path_integrator is not None:  # the CX integrates this walk (path_integrator.episode_integrator)
            from neuronav.scenarios.envs.path_integrator import episode_integrator

            episode_integrator(self, seed, attempt)
        return Start(position, heading)

    def observe(self, state: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if self.home_vector == "cx":  # the CX's vector, in the oracle's frame: the body where the CX believes it
            self.path_integrator.update(state)
            state = dict(state, position=self.goal_of(state) - self.path_integrator.home_vector_world_m())
        heading = np.asarray(state["heading"], float)[..., 0]  # a batched state (N, 1) gives (N, 2)
        home = self.goal_of(state) - np.asarray(state["position"], float)[..., :2]
        forward = home[..., 0] * np.sin(heading) + home[..., 1] * np.cos(heading)
        left = -home[..., 0] * np.cos(heading) + home[..., 1] * np.sin(heading)
        return {"home_vector": np.stack(np.broadcast_arrays(forward, left), axis=-1)}


class BeaconTask(NavigationTask):
    """Walk to the visual beacon's dark landmark, seen with both eyes.

    Settings: the visual-beacon scenario's keys (``landmark_distance_m``, ``trees``,
    ``success_radius_m``, ``timeout_s``, ...). The start: the origin, heading within ±45° of the
    landmark (the scenario's binocular range), drawn as the scenario draws it.
    """

    name = "beacon"
    scenario = VisualBeacon
    config_type = VisualBeaconConfig
    observation_ports = ("heading", "eye_L", "eye_R")
    goal_keys = (0.0, "landmark_distance_m")
    success_radius_key = "success_radius_m"
    time_limit_key = "timeout_s"
    seeded_world = True  # the forest

    def world(self, seed: int = 0) -> World:
        return beacon_world(self.config, seed)

    def start(self, seed: int) -> Start:
        rng = np.random.default_rng([seed, 4])  # as neuronav.scenarios.visual_beacon.scenario.beacon_trial draws it
        return Start(np.zeros(2), float(rng.uniform(*START_HEADINGS_RAD["both"])))


class PlumeTask(NavigationTask):
    """Walk up the plume to its source, smelling with the antennae and feeling the wind.

    Settings: the plume-tracking scenario's keys (``wind_mps``, ``source_x_m``, ``warmup_s``,
    ``start_x_m``, ``start_lateral_m``, ``start_heading_deg``, ``success_radius_m``, ``timeout_s``,
    ...). Success as in the scenario: the root or an antenna tip within ``success_radius_m``.
    """

    name = "plume"
    scenario = PlumeTracking
    config_type = PlumeTrackingConfig
    observation_ports = ("heading", "odour", "wind")
    goal_keys = ("source_x_m", 0.0)
    success_radius_key = "success_radius_m"
    time_limit_key = "timeout_s"

    @property
    def state_ports(self) -> tuple[str, ...]:
        return (*super().state_ports, "odour_sites")

    def world(self, seed: int = 0) -> World:
        return plume_world(self.config)

    def start(self, seed: int) -> Start:
        position, heading = start_pose(self.config, seed)
        return Start(position, heading)

    def reach_distance_m(self, state: dict[str, np.ndarray]) -> float | np.ndarray:
        points = np.concatenate([np.asarray(state["position"], float)[..., None, :2],
                                 np.asarray(state["odour_sites"], float)[..., :, :2]], axis=-2)
        offset = points - self.goal_of(state)[..., None, :]
        return _scalar(np.hypot(offset[..., 0], offset[..., 1]).min(axis=-1))


TASKS: dict[str, type[NavigationTask]] = {task.name: task for task in (HomingTask, BeaconTask, PlumeTask)}


def make_task(name: str, **settings: Any) -> NavigationTask:
    """The task ``name`` (one of :data:`TASKS`) with its scenario's settings overridden by ``settings``.

    Raises
    ------
    ConfigError
        An unknown task, or a setting its scenario does not have or does not allow.
    """
    if name not in TASKS:
        raise ConfigError(f"unknown task {name!r}; allowed: {', '.join(TASKS)}")
    return TASKS[name](**settings)


def check_world_seed(world_seed: Any, name: str = "world_seed") -> int:
    """``world_seed`` as an int >= 0, or a ConfigError (None too: the world would not be reproducible);
    ``name``: what the message calls it (an episode's ``seed`` is checked the same way where it is given)."""
    if isinstance(world_seed, bool) or not isinstance(world_seed, Integral) or world_seed < 0:
        what = ("the seed of the task's world, e.g. the beacon's forest; None is refused: the world would not be "
                "reproducible") if name == "world_seed" else "or None"
        raise ConfigError(f"{name} must be an int >= 0 ({what}); got {world_seed!r}")
    return int(world_seed)


def _scalar(value: np.ndarray) -> float | np.ndarray:
    """A 0-d result as a float (an unbatched state), else the array (a batched one)."""
    return float(value) if np.ndim(value) == 0 else value


def read_state(backend, task: NavigationTask) -> dict[str, np.ndarray]:
    """Agent 0's readings of ``task.state_ports`` from a loaded backend, without the batch dimension."""
    return {name: np.asarray(value)[0] for name, value in backend.read(task.state_ports).items()}
