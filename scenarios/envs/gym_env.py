"""A Gymnasium environment over any backend: one task (:mod:`neuronav.scenarios.envs.tasks`), one ant.

``NeuronavEnv(task="homing", backend="kinematic", action_mode="locomotion", render_mode=None,
world_seed=0, **settings)`` runs a task on a registered backend with the body the scenarios use
(:func:`neuronav.scenarios.visual_setup.make_engine`): the desert ant walked by the FK tripod gait on a
physics backend, the kinematic unicycle (carrying the ant's cameras and antennae) on ``kinematic``.
``settings`` are the task's scenario settings (the keys of ``neuronav run ... --set``).

Spaces come from the ports. Observations: a ``Dict`` of ``Box`` es, one per observed port of the
task (its shape from the backend's :class:`~neuronav.spec.ports.SensorSpec`, its bounds from the spec's
``range``, else from its units: grey images in [0, 1], odour concentrations >= 0, else unbounded)
and one per observation the task computes (``home_vector``), float32. Actions:

- ``action_mode="locomotion"``: ``Box`` (2,) = (``turn`` θ in [-1, 1], ``stride`` S_l in rad), the
  locomotion command, held for one gait cycle (0.64 s, the brain period of the scenarios) and
  walked by the gait (or the unicycle). The stride is bounded by the ``stride`` port's range and by
  eq. 3.7's largest stride, 25°.
- ``action_mode="joints"``: ``Box`` (J,) joint targets in rad within each joint's range (the
  desert ant: J = 40), held for one control step (8 ms); physics backends only.

Actions outside the box are clipped to it. The reward is the task's (progress toward its goal, m per
step); ``terminated`` when the goal is reached (checked at the end of each step), ``truncated`` when
the task's time limit is reached first (``task.step_limit``). ``reset(seed=...)`` seeds
``np_random``, which draws the episode's seed: the start pose, the plume and the backend's reset
all follow from it, so the same seed gives the same episode bit for bit. ``info``: ``distance_m``
to the goal, ``time_s`` of the episode.

``render_mode="rgb_array"``: the follow camera on a physics backend (640 × 480), a top view of the
agent, its goal and its path on the kinematic backend (:func:`neuronav.scenarios.envs.top_view.top_view`).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from neuronav import registry
from neuronav.engine.loop import AgentLoop, Clocks
from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs.tasks import NavigationTask, make_task, read_state
from neuronav.scenarios.envs.top_view import top_view
from neuronav.scenarios.path_integration.embodied import EXTRA_STRIDE_RAD, MIN_STRIDE_RAD
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.spec.ports import SensorSpec

ACTION_MODES = ("locomotion", "joints")
# Bounds of sensors whose spec has no range, by their units.
UNIT_BOUNDS = {"grey [0, 1]": (0.0, 1.0), "amount/m^3": (0.0, np.inf)}
# Eq. 3.7's largest stride (5° + 20°): the locomotion action's upper stride.
MAX_STRIDE_RAD = MIN_STRIDE_RAD + EXTRA_STRIDE_RAD


def port_box(spec: SensorSpec) -> spaces.Box:
    """The observation space of one sensor port: its shape, its range (or its units' bounds), float32."""
    low, high = spec.range if spec.range is not None else UNIT_BOUNDS.get(spec.units, (-np.inf, np.inf))
    return spaces.Box(low=np.float32(low), high=np.float32(high), shape=spec.shape, dtype=np.float32)


def check_backend(task: NavigationTask, backend: str) -> None:
    """A backend that is registered and installed, and that the task's scenario runs on, or one clear error."""
    registry.load("backend", backend)  # a RegistryError: unknown, or not installed (naming the extra)
    if backend not in task.backends:
        raise ConfigError(f"task {task.name!r} runs on the backends {', '.join(task.backends)}; got {backend!r}")


class NeuronavEnv(gymnasium.Env):
    """A neuronav task as a Gymnasium environment (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1.0 / CYCLE_S}

    def __init__(self, task: str | NavigationTask = "homing", backend: str = "kinematic",
                 action_mode: str = "locomotion", render_mode: str | None = None, world_seed: int = 0,
                 **settings: Any) -> None:
        self.task = task if isinstance(task, NavigationTask) else make_task(task, **settings)
        if isinstance(task, NavigationTask) and settings:
            raise ConfigError(f"settings {sorted(settings)} go with a task name, not a task instance")
        check_backend(self.task, backend)
        if action_mode not in ACTION_MODES:
            raise ConfigError(f"action_mode must be one of {', '.join(ACTION_MODES)}; got {action_mode!r}")
        if action_mode == "joints" and backend == "kinematic":
            raise ConfigError("action_mode='joints' needs a physics backend (the ant's joints); the kinematic "
                              "backend's unicycle takes only the locomotion command: use action_mode='locomotion'")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode must be None or one of {', '.join(self.metadata['render_modes'])}; "
                              f"got {render_mode!r}")
        self.backend_name, self.action_mode, self.render_mode = backend, action_mode, render_mode
        self.engine, body, self.gait, physics_dt_s = make_engine(backend, self.task.physics_timestep_s)
        self.engine.load(self.task.world(world_seed), [body])
        self.clocks = Clocks(physics_dt_s=physics_dt_s, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
        self.loop = AgentLoop(self.engine, self.gait, self.clocks)
        self.step_s = CYCLE_S if action_mode == "locomotion" else CONTROL_S
        self.max_steps = self.task.step_limit(self.step_s)
        self.metadata = dict(self.metadata, render_fps=1.0 / self.step_s)
        self.observation_space = self._observation_space()
        self.action_space = self._action_space(body)
        self._state: dict[str, np.ndarray] | None = None
        self._steps = 0
        self._path: list[np.ndarray] = []

    # -- spaces ---------------------------------------------------------------------------------
    def _observation_space(self) -> spaces.Dict:
        sensors = {spec.name: spec for spec in self.engine.capabilities.sensors}
        boxes = {name: port_box(sensors[name]) for name in self.task.observation_ports}
        boxes.update({spec.name: port_box(spec) for spec in self.task.task_sensors})
        return spaces.Dict(boxes)

    def _action_space(self, body) -> spaces.Box:
        if self.action_mode == "joints":
            ranges = np.array([joint.range_rad for joint in body.joints], dtype=np.float32)
            return spaces.Box(low=ranges[:, 0], high=ranges[:, 1], dtype=np.float32)
        motors = {spec.name: spec for spec in registry.load("backend", "kinematic").capabilities.motors}
        turn, stride = motors["turn"].range, motors["stride"].range
        return spaces.Box(low=np.array([turn[0], stride[0]], dtype=np.float32),
                          high=np.array([turn[1], min(stride[1], MAX_STRIDE_RAD)], dtype=np.float32),
                          dtype=np.float32)

    # -- the Gymnasium API ----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        episode_seed = int(self.np_random.integers(0, 2**31 - 1))
        start = self.task.start(episode_seed)
        self.loop.reset(seed=episode_seed, position_m=tuple(float(v) for v in start.position_m),
                        yaw_rad=float(np.pi / 2 - start.heading_rad))
        self._state = read_state(self.engine, self.task)
        self._steps = 0
        self._path = [self._state["position"].copy()]
        return self._observation(), self._info()

    def step(self, action):
        if self._state is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        command = np.asarray(action, dtype=float).reshape(-1)
        if command.shape != self.action_space.shape or not np.isfinite(command).all():
            raise PortError(f"action must be {self.action_space.shape[0]} finite numbers ({self.action_mode} mode: "
                            f"{self._action_names()}), got {action!r}")
        command = np.clip(command, self.action_space.low, self.action_space.high)
        if self.action_mode == "locomotion":
            self.loop.turn, self.loop.stride_rad = float(command[0]), float(command[1])
            for _ in range(self.clocks.controls_per_brain):
                self.loop.step()
        else:
            self.engine.write({"joint_targets": command[None, :]})
            self.engine.step(self.clocks.physics_per_control)
            self.loop.control_steps += 1
        previous, self._state = self._state, read_state(self.engine, self.task)
        self._steps += 1
        self._path.append(self._state["position"].copy())
        reward = float(self.task.reward(previous, self._state))
        terminated = self.task.terminated(self._state)
        truncated = not terminated and self._steps >= self.max_steps
        return self._observation(), reward, terminated, truncated, self._info()

    def render(self):
        if self.render_mode != "rgb_array" or self._state is None:
            return None
        if self.backend_name == "kinematic":
            return top_view(np.array(self._path), float(self._state["heading"][0]), self.task.goal_m,
                            self.task.success_radius_m)
        return self.engine.render("follow")

    def close(self) -> None:
        self.engine.close()
        super().close()

    # -- helpers --------------------------------------------------------------------------------
    def _observation(self) -> dict[str, np.ndarray]:
        values = {name: self._state[name] for name in self.task.observation_ports}
        values.update(self.task.observe(self._state))
        return {name: np.asarray(values[name], dtype=np.float32).reshape(box.shape)
                for name, box in self.observation_space.spaces.items()}

    def _info(self) -> dict[str, float]:
        return {"distance_m": self.task.distance_m(self._state), "time_s": self.loop.time_s}

    def _action_names(self) -> str:
        return "turn, stride_rad" if self.action_mode == "locomotion" else "joint targets in rad"
