"""The CX as the homing task's path integrator: engine-free, fed one gait cycle at a time.

:class:`CXPathIntegrator` runs Stone et al. 2017's central complex (:func:`neuronav.brains.cx.stone2017`)
as the embodied homing scenario runs it (:class:`neuronav.scenarios.path_integration.embodied.HomingBrain`:
once per gait cycle, the heading and the body's displacement over the last cycle, the scenario's
embodied gain, leak and noise, its compass and odometer noise under ``variability=on``), fed from the
environment's raw state (the backend's ``position`` and ``heading`` ports as
:func:`neuronav.scenarios.envs.tasks.read_state` returns them, never an observation's layout). At the start
of an episode it integrates the foraging walk that brought the ant to its start pose
(:func:`outbound_poses`, the walk of :func:`neuronav.scenarios.envs.tasks.foraging_walk` cycle by cycle),
so its memory holds the way home as the scenario's CX holds it at the turn-back.

The homing task with ``home_vector="cx"`` (:class:`neuronav.scenarios.envs.tasks.HomingTask`) observes
its estimate; :mod:`neuronav.scenarios.envs.brain_loop` wraps the Gymnasium environment around it.

One update per new state: the integrator steps when it sees a pose (position, heading) other than the
last one it integrated; the environment observes once per gait cycle in the locomotion action mode. A
state observed again, or a cycle in which the body neither moved nor turned, is not integrated twice.
So ``home_vector="cx"`` is for one action per gait cycle (the Gymnasium locomotion mode, the dm_control
tasks): the joints mode observes every 8 ms and would feed the CX 80 times per cycle (the wrappers of
:mod:`~neuronav.scenarios.envs.brain_loop` refuse it). One integrator is one ant: a batched state is refused.
No Gymnasium here: the tasks (dm_control's too) import this module.
"""

from __future__ import annotations

import numpy as np

from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.errors import ConfigError
from neuronav.scenarios.path_integration.embodied import homing_noise, noise_cycles, steering_command

HOME_VECTORS = ("oracle", "cx")
# The CX populations the observation wrapper exposes, with their sizes (stone2017's).
POPULATIONS = {"TB1": 8, "CPU4": 16, "CPU1": 16}
# Metres per unit of decode_home_vector's distance at the embodied gain (0.04 per gait cycle): the median of
# true / decoded distance at the start of homing over seeds 0-199, measured by distance_scale()
# (python -c "from neuronav.scenarios.envs.path_integrator import distance_scale; print(distance_scale())").
CX_METRES_PER_UNIT = 0.518


def outbound_poses(seed: int, attempt: int, outbound_s: float, turn_std: float,
                   stride_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """The foraging walk of :func:`~neuronav.scenarios.envs.tasks.foraging_walk`, at every gait cycle.

    Returns
    -------
    positions_m : ndarray, shape (cycles + 1, 2)
        The body at the start of each cycle, the nest (0, 0) first and the walk's end last.
    headings_rad : ndarray, shape (cycles + 1,)
        The heading (clockwise from +y) at the same times.

    """
    from neuronav.scenarios.envs.tasks import foraging_walk

    poses: list = []
    foraging_walk(seed, outbound_s, turn_std, stride_rad, attempt, poses)
    return np.array([p for p, _ in poses]), np.array([h for _, h in poses])


def state_pose(state: dict[str, np.ndarray]) -> tuple[np.ndarray, float]:
    """(position (2,) m, heading rad clockwise from +y) from one agent's raw state (backend ports).

    Raises
    ------
    ConfigError
        A batched state of several agents: one integrator is one CX, for one agent.
    """
    position = np.asarray(state["position"], float)
    heading = np.asarray(state["heading"], float)
    if position.size not in (2, 3) or heading.size != 1:
        raise ConfigError(f"the CX path integrator runs one ant; got a state of position shape {position.shape} "
                          f"and heading shape {heading.shape} (home_vector='cx' needs one agent per environment)")
    return position.reshape(-1)[:2], float(heading.reshape(-1)[0])


class CXPathIntegrator:
    """Stone et al. 2017's CX fed once per gait cycle, as embodied homing feeds it (module docstring).

    Parameters
    ----------
    config : PathIntegrationConfig
        The homing task's settings: ``embodied_noise``, ``embodied_memory_gain``, ``memory_leak``,
        ``k_pi``, the variability settings (``compass_noise_deg``, ``odometry_noise_fraction``), the
        trip (``outbound_s``, ``homing_timeout_s``).
    """

    def __init__(self, config) -> None:
        self.config = config
        self.cx = stone2017(noise=config.embodied_noise, memory_gain=config.embodied_memory_gain,
                            memory_leak=config.memory_leak).compile(batch=1, seeds=[0])
        self.noise: dict[str, np.ndarray] | None = None
        self.cycle = 0
        self._last_position: np.ndarray | None = None
        self._last_pose: tuple[bytes, bytes] | None = None
        self._started = False

    # -- an episode -----------------------------------------------------------------------------
    def start_episode(self, seed: int, positions_m: np.ndarray, headings_rad: np.ndarray) -> None:
        """Reset the CX (its noise seeded by ``seed``) and integrate the outbound walk's poses, but the last.

        The last pose is the episode's start: the first state observed there is the turn-back's update.
        """
        self.cx.seeds = [int(seed)]
        self.cx.reset()
        trip_s = self.config.outbound_s + self.config.homing_timeout_s
        self.noise = homing_noise(self.config, [int(seed)], noise_cycles(trip_s))
        self.cycle = 0
        self._last_position, self._last_pose, self._started = None, None, True
        for position, heading in zip(positions_m[:-1], headings_rad[:-1], strict=True):
            self._integrate(np.asarray(position, float), float(heading))

    def update(self, state: dict[str, np.ndarray]) -> bool:
        """Integrate one gait cycle ending at ``state`` unless this pose was the last one integrated, or no
        episode has started (:meth:`start_episode`; the memory then reads a zero home vector); whether it did."""
        position, heading = state_pose(state)
        if not self._started:  # no episode yet (an adapter reading its spaces): nothing integrated, no vector
            return False
        pose = (position.tobytes(), np.float64(heading).tobytes())
        if pose == self._last_pose:
            return False
        self._integrate(position, heading)
        self._last_pose = pose
        return True

    def _integrate(self, position: np.ndarray, heading: float) -> None:
        """One brain call of :class:`~neuronav.scenarios.path_integration.embodied.HomingBrain` (``velocity_input``
        pose, true compass and odometer): the heading read now, the displacement since the last call."""
        moved = np.zeros(2) if self._last_position is None else position - self._last_position
        self._last_position = position
        read = heading
        if self.noise is not None:
            cycle = min(self.cycle, self.noise["compass"].shape[1] - 1)
            moved = moved * (1.0 + self.noise["odometry"][0, cycle])
            read = heading + self.noise["compass"][0, cycle]
        self.cx.step({"heading": np.array([[read]]), "velocity": moved[None, :]})
        self.cycle += 1

    # -- what it holds --------------------------------------------------------------------------
    def home_vector_world_m(self) -> np.ndarray:
        """The CX's estimate of the nest from the body, world frame (x, y) m, decoded from CPU4's memory."""
        direction, distance = decode_home_vector(self.cx.memory("CPU4"), self.config.embodied_memory_gain)
        length_m = float(distance[0]) * CX_METRES_PER_UNIT
        return length_m * np.array([np.sin(direction[0]), np.cos(direction[0])])

    def populations(self) -> dict[str, np.ndarray]:
        """``TB1`` (8), ``CPU4`` (16, the memory) and ``CPU1`` (16) now, float32 in [0, 1]."""
        values = {"TB1": self.cx.rates("TB1")[0], "CPU4": self.cx.memory("CPU4")[0], "CPU1": self.cx.rates("CPU1")[0]}
        return {name: np.clip(value, 0.0, 1.0).astype(np.float32) for name, value in values.items()}

    def steering(self) -> tuple[float, float]:
        """The CX's locomotion command now: (turn θ, stride S_l rad), eqs. 3.6-3.7 with the task's ``k_pi``."""
        return steering_command(self.cx.rates("CPU1")[0], self.config.k_pi)


def episode_integrator(task, seed: int, attempt: int) -> None:
    """Start ``task.path_integrator``'s episode on the foraging walk (``seed``, ``attempt``) of ``task.start``."""
    config = task.config
    positions, headings = outbound_poses(seed, attempt, config.outbound_s, config.foraging_turn_std,
                                         np.radians(config.foraging_stride_deg))
    task.path_integrator.start_episode(seed, positions, headings)


def start_estimates(seeds: range = range(200), **settings) -> dict[str, float]:
    """How the CX's home vector at the start of homing compares with the true one over ``seeds``.

    ``settings``: the homing task's (default: the scenario's, ``variability=on``). Returns
    ``metres_per_unit`` (the median of true / decoded distance, decode_home_vector's units),
    ``direction_error_deg_median`` and ``direction_error_deg_95`` (95th percentile): the decoded
    direction against the true one. :data:`CX_METRES_PER_UNIT` is the first with ``variability=off``.
    """
    from neuronav.scenarios.envs.tasks import make_task

    task = make_task("homing", home_vector="cx", **settings)
    ratios, errors = [], []
    for seed in seeds:
        start = task.start(seed)
        task.path_integrator.update({"position": start.position_m, "heading": np.array([start.heading_rad])})
        direction, distance = decode_home_vector(task.path_integrator.cx.memory("CPU4"),
                                                 task.config.embodied_memory_gain)
        true_direction = np.arctan2(-start.position_m[0], -start.position_m[1])
        ratios.append(np.hypot(*start.position_m) / float(distance[0]))
        errors.append(abs(np.degrees(np.angle(np.exp(1j * (direction[0] - true_direction))))))
    return {"metres_per_unit": float(np.median(ratios)), "direction_error_deg_median": float(np.median(errors)),
            "direction_error_deg_95": float(np.percentile(errors, 95))}


def distance_scale(seeds: range = range(200)) -> float:
    """The median ratio of the true home distance to decode_home_vector's distance at the start of
    homing over ``seeds``, ``variability=off``: how :data:`CX_METRES_PER_UNIT` is measured."""
    return start_estimates(seeds, variability="off")["metres_per_unit"]
