"""A Gymnasium environment over any backend: one task (:mod:`neuronav.scenarios.envs.tasks`), one ant.

``NeuronavEnv(task="homing", backend="kinematic", action_mode="locomotion", render_mode=None,
world_seed=0, proprioception=None, panorama=False, compound_eyes=False, fall_tilt_deg=60.0, **settings)``
runs a task on a registered backend with the body the scenarios use
(:func:`neuronav.scenarios.visual_setup.make_engine`): the desert ant walked by the FK tripod gait on a
physics backend, the kinematic unicycle (carrying the ant's cameras and antennae) on ``kinematic``.
``settings`` are the task's scenario settings (the keys of ``neuronav run ... --set``). ``world_seed``:
the seed of the task's world (the beacon's forest), an int >= 0 (None is refused: the forest would
not be reproducible).

Observations: a ``Dict`` made by :mod:`neuronav.scenarios.envs.observations` (the table of names,
frames, units and bounds is there and in the README): ``heading`` as (sin, cos), ``velocity_body`` and
``home_vector`` in the body frame (forward, left), eyes as uint8 (H, W, 1) images (``panorama=True``
adds the head's panoramic camera, ``compound_eyes=True`` the body's compound eyes), odour and wind;
proprioception (``joint_pos``, ``joint_vel``, ``contact_force``, ``body_up``) by default in joints
mode, with ``proprioception=True`` in locomotion mode (physics backends). Actions:

- ``action_mode="locomotion"``: ``Box`` (2,) = (``turn`` θ in [-1, 1], ``stride`` S_l in rad), the
  locomotion command, held for one gait cycle (0.64 s, the brain period of the scenarios) and
  walked by the gait (or the unicycle). The stride is bounded by the ``stride`` port's range and by
  eq. 3.7's largest stride, 25°.
- ``action_mode="joints"``: ``Box`` (J,) joint targets in rad within each joint's range (the
  desert ant: J = 40), held for one control step (8 ms); physics backends only.

The action rule (the same in the dm_env tasks): finite actions outside the box are clipped to it; an
action of another shape, not finite, or not real numbers (a string, a dict, complex) is a
:class:`~neuronav.errors.PortError`.

The reward is the task's (progress toward its goal, m per step). ``terminated`` when the goal is
reached (checked at the end of each step) or, on a physics backend, when the ant fell: its root's up
axis tilts more than ``fall_tilt_deg`` (60°) from vertical (``fall_tilt_deg=None``: no fall rule).
``truncated`` when the task's time limit is reached first (``max_steps`` = ``task.step_limit``).
Stepping an ended episode without ``reset()`` raises ``gymnasium.error.ResetNeeded``. ``info``:
``distance_m`` to the goal, ``time_s`` of the episode, ``is_success`` (the goal reached), ``fell``.

``reset(seed=..., options=...)``: ``seed`` seeds ``np_random``, which draws the episode's seed: the
start pose, the plume and the backend's reset all follow from it, so the same seed gives the same
episode bit for bit. ``options`` (:data:`RESET_OPTIONS`; any other key is a ConfigError):
``position_m`` (x, y) and ``heading_rad`` (clockwise from +y) replace the drawn start for this
episode; ``goal_m`` (x, y) moves the goal for this episode (only tasks whose goal is a bare point:
homing's nest); ``world_seed`` rebuilds the world from that seed from this episode on.

``render_mode="rgb_array"``: the follow camera on a physics backend (640 × 480) with the goal drawn in
(its success circle on the ground and a pole, :func:`neuronav.scenarios.envs.top_view.draw_goal`), a
top view of the agent, its goal and its path on the kinematic backend
(:func:`neuronav.scenarios.envs.top_view.top_view`). ``render_mode="human"`` is refused (neuronav
renders headless): use ``rgb_array`` (with ``gymnasium.make``, ``render_mode="human"`` applies
Gymnasium's ``HumanRendering`` wrapper over it, which needs pygame).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from neuronav import registry
from neuronav.engine.loop import AgentLoop, Clocks
from neuronav.errors import ConfigError
from neuronav.scenarios.envs.observations import FALL_TILT_DEG, check_actions, fallen, observation_space, observe
from neuronav.scenarios.envs.observations import state_ports as observed_ports
from neuronav.scenarios.envs.tasks import NavigationTask, check_world_seed, make_task
from neuronav.scenarios.envs.top_view import draw_goal, top_view
from neuronav.scenarios.path_integration.embodied import EXTRA_STRIDE_RAD, MIN_STRIDE_RAD
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine

ACTION_MODES = ("locomotion", "joints")
# Eq. 3.7's largest stride (5° + 20°): the locomotion action's upper stride.
MAX_STRIDE_RAD = MIN_STRIDE_RAD + EXTRA_STRIDE_RAD
RESET_OPTIONS = {
    "position_m": "(x, y) m: the start position of this episode",
    "heading_rad": "rad clockwise from +y: the start heading of this episode",
    "goal_m": "(x, y) m: the goal of this episode (tasks with a movable goal: homing)",
    "world_seed": "int >= 0: rebuild the world from this seed (the beacon's forest) from this episode on",
}


def check_backend(task: NavigationTask, backend: str) -> None:
    """A backend that is registered and installed, and that the task's scenario runs on, or one clear error."""
    registry.load("backend", backend)  # a RegistryError: unknown, or not installed (naming the extra)
    if backend not in task.backends:
        raise ConfigError(f"task {task.name!r} runs on the backends {', '.join(task.backends)}; got {backend!r}")


def _point(name: str, value: Any) -> np.ndarray:
    try:
        point = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        point = np.full(0, np.nan)
    if isinstance(value, (str, bytes)) or point.shape != (2,) or not np.isfinite(point).all():
        raise ConfigError(f"reset option {name!r} must be (x, y): 2 finite numbers in m; got {value!r}")
    return point


class NeuronavEnv(gymnasium.Env):
    """A neuronav task as a Gymnasium environment (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1.0 / CYCLE_S}

    def __init__(self, task: str | NavigationTask = "homing", backend: str = "kinematic",
                 action_mode: str = "locomotion", render_mode: str | None = None, world_seed: int = 0,
                 proprioception: bool | None = None, panorama: bool = False, compound_eyes: bool = False,
                 fall_tilt_deg: float | None = FALL_TILT_DEG, **settings: Any) -> None:
        self.task = task if isinstance(task, NavigationTask) else make_task(task, **settings)
        if isinstance(task, NavigationTask) and settings:
            raise ConfigError(f"settings {sorted(settings)} go with a task name, not a task instance")
        check_backend(self.task, backend)
        if action_mode not in ACTION_MODES:
            raise ConfigError(f"action_mode must be one of {', '.join(ACTION_MODES)}; got {action_mode!r}")
        if action_mode == "joints" and backend == "kinematic":
            raise ConfigError("action_mode='joints' needs a physics backend (the ant's joints); the kinematic "
                              "backend's unicycle takes only the locomotion command: use action_mode='locomotion'")
        if action_mode == "joints" and getattr(self.task, "home_vector", "oracle") == "cx":
            raise ConfigError("home_vector='cx' feeds the CX once per gait cycle (0.64 s), as the path-integration "
                              "scenario does: it needs action_mode='locomotion', not 'joints' (8 ms steps)")
        if render_mode == "human":
            raise ConfigError("render_mode='human' is not supported: neuronav renders headless; use "
                              "render_mode='rgb_array' and show the frames (gymnasium.make applies Gymnasium's "
                              "HumanRendering wrapper for 'human', which needs pygame)")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode must be None or one of {', '.join(self.metadata['render_modes'])}; "
                              f"got {render_mode!r}")
        flags = (("proprioception", proprioception), ("panorama", panorama), ("compound_eyes", compound_eyes))
        for name, flag in flags:
            if flag is not None and not isinstance(flag, (bool, np.bool_)):
                raise ConfigError(f"{name} must be True or False; got {flag!r}")
        if fall_tilt_deg is not None and not (isinstance(fall_tilt_deg, (int, float)) and not isinstance(
                fall_tilt_deg, bool) and 0.0 < fall_tilt_deg <= 180.0):
            raise ConfigError(f"fall_tilt_deg must be None (no fall rule) or a number in (0, 180] deg; "
                              f"got {fall_tilt_deg!r}")
        self.world_seed = check_world_seed(world_seed)
        self.backend_name, self.action_mode, self.render_mode = backend, action_mode, render_mode
        self.fall_tilt_deg = fall_tilt_deg
        # compound_eyes=True: the ant (or the unicycle) carries its two compound eyes (1287 ommatidia each).
        self.engine, self.body, self.gait, physics_dt_s = make_engine(backend, self.task.physics_timestep_s,
                                                                      compound_eyes=bool(compound_eyes))
        self.engine.load(self.task.world(self.world_seed), [self.body])
        self.physics = backend != "kinematic"
        self.clocks = Clocks(physics_dt_s=physics_dt_s, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S)
        self.loop = AgentLoop(self.engine, self.gait, self.clocks)
        self.step_s = CYCLE_S if action_mode == "locomotion" else CONTROL_S
        self.max_steps = self.task.step_limit(self.step_s)
        self.metadata = dict(self.metadata, render_fps=1.0 / self.step_s)
        joints = getattr(self.body, "joints", ())
        ranges = np.array([joint.range_rad for joint in joints], dtype=float).reshape(-1, 2)
        self.observation_space = observation_space(
            self.task, {spec.name: spec for spec in self.engine.capabilities.sensors}, action_mode=action_mode,
            proprioception=proprioception, panorama=bool(panorama), compound_eyes=bool(compound_eyes),
            joint_ranges_rad=ranges)
        self.state_ports = observed_ports(self.task, self.observation_space, physics=self.physics)
        self.action_space = self._action_space(ranges)
        self._state: dict[str, np.ndarray] | None = None
        self._goal: np.ndarray | None = None
        self._ended = False
        self._steps = 0
        self._path: list[np.ndarray] = []

    def _action_space(self, ranges: np.ndarray) -> spaces.Box:
        if self.action_mode == "joints":
            return spaces.Box(low=ranges[:, 0].astype(np.float32), high=ranges[:, 1].astype(np.float32),
                              dtype=np.float32)
        motors = {spec.name: spec for spec in registry.load("backend", "kinematic").capabilities.motors}
        turn, stride = motors["turn"].range, motors["stride"].range
        return spaces.Box(low=np.array([turn[0], stride[0]], dtype=np.float32),
                          high=np.array([turn[1], min(stride[1], MAX_STRIDE_RAD)], dtype=np.float32),
                          dtype=np.float32)

    # -- the Gymnasium API ----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            check_world_seed(seed, "seed")
        options = self._check_options(options)
        super().reset(seed=seed)
        episode_seed = int(self.np_random.integers(0, 2**31 - 1))
        if "world_seed" in options and options["world_seed"] != self.world_seed:
            self.world_seed = options["world_seed"]
            if self.task.seeded_world:
                self.engine.load(self.task.world(self.world_seed), [self.body])
        start = self.task.start(episode_seed)
        position = options.get("position_m", start.position_m)
        heading = options.get("heading_rad", start.heading_rad)
        self._goal = options.get("goal_m")
        self.loop.reset(seed=episode_seed, position_m=tuple(float(v) for v in position),
                        yaw_rad=float(np.pi / 2 - heading))
        self._state = self._read()
        self._ended = False
        self._steps = 0
        self._path = [self._state["position"].copy()]
        return self._observation(), self._info(False, False)

    def step(self, action):
        if self._state is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        if self._ended:
            raise gymnasium.error.ResetNeeded("the episode ended (terminated or truncated): call reset() before step()")
        names = "turn, stride_rad" if self.action_mode == "locomotion" else "joint targets in rad"
        command = check_actions(action, self.action_space.low, self.action_space.high, names, count=1)[0]
        if self.action_mode == "locomotion":
            self.loop.turn, self.loop.stride_rad = float(command[0]), float(command[1])
            for _ in range(self.clocks.controls_per_brain):
                self.loop.step()
        else:
            self.engine.write({"joint_targets": command[None, :]})
            self.engine.step(self.clocks.physics_per_control)
            self.loop.control_steps += 1
        previous, self._state = self._state, self._read()
        self._steps += 1
        self._path.append(self._state["position"].copy())
        reward = float(self.task.reward(previous, self._state))
        success = bool(self.task.terminated(self._state))
        fell = bool(fallen(self._batch(), self.fall_tilt_deg)[0]) and not success
        terminated = success or fell
        truncated = not terminated and self._steps >= self.max_steps
        self._ended = terminated or truncated
        return self._observation(), reward, terminated, truncated, self._info(success, fell)

    def render(self):
        if self.render_mode != "rgb_array" or self._state is None:
            return None
        goal = self.task.goal_of(self._state)
        if self.backend_name == "kinematic":
            return top_view(np.array(self._path), float(self._state["heading"][0]), goal,
                            self.task.success_radius_m)
        frame = self.engine.render("follow")
        view = getattr(self.engine, "follow_view", None)
        return draw_goal(frame, view(), goal, self.task.success_radius_m) if view is not None else frame

    def close(self) -> None:
        self.engine.close()
        super().close()

    # -- helpers --------------------------------------------------------------------------------
    def _check_options(self, options: dict | None) -> dict:
        if options is None:
            return {}
        if not isinstance(options, dict):
            raise ConfigError(f"reset options must be a dict with keys {', '.join(RESET_OPTIONS)}; got {options!r}")
        unknown = sorted(set(options) - set(RESET_OPTIONS), key=str)
        if unknown:
            raise ConfigError(f"unknown reset option(s) {', '.join(map(repr, unknown))}; allowed: "
                              + "; ".join(f"{k}: {v}" for k, v in RESET_OPTIONS.items()))
        checked = {}
        if "position_m" in options:
            checked["position_m"] = _point("position_m", options["position_m"])
        if "heading_rad" in options:
            heading = options["heading_rad"]
            if isinstance(heading, bool) or not isinstance(heading, (int, float, np.number)) or not np.isfinite(
                    float(heading)):
                raise ConfigError(f"reset option 'heading_rad' must be a finite number (rad clockwise from +y); "
                                  f"got {heading!r}")
            checked["heading_rad"] = float(heading)
        if "goal_m" in options:
            if not self.task.movable_goal:
                raise ConfigError(f"task {self.task.name!r} cannot move its goal per episode (the goal is part of "
                                  f"its world); change the task's settings instead (its goal: {self.task.goal_keys})")
            checked["goal_m"] = _point("goal_m", options["goal_m"])
        if "world_seed" in options:
            checked["world_seed"] = check_world_seed(options["world_seed"])
        return checked

    def _read(self) -> dict[str, np.ndarray]:
        """Agent 0's readings of the ports the observation, reward and fall rule need (no batch axis)."""
        state = {name: np.asarray(value)[0] for name, value in self.engine.read(self.state_ports).items()}
        if self._goal is not None:
            state["goal_m"] = self._goal
        return state

    def _batch(self) -> dict[str, np.ndarray]:
        return {name: np.asarray(value)[None] for name, value in self._state.items()}

    def _observation(self) -> dict[str, np.ndarray]:
        return {name: value[0] for name, value in observe(self.task, self._batch(), self.observation_space).items()}

    def _info(self, success: bool, fell: bool) -> dict[str, Any]:
        return {"distance_m": float(self.task.distance_m(self._state)), "time_s": self.loop.time_s,
                "is_success": success, "fell": fell}
