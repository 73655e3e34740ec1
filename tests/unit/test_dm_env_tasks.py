"""dm_control environments of the navigation tasks: dm_env's own conformance tests on every task, and
what the environments promise beyond them (observables named after the ports, the task object's reward,
termination vs truncation, seeded episodes, the composer ant walking like the dm_control backend's).

The conformance classes are made from the task registry (:data:`neuronav.scenarios.envs.tasks.TASKS`), so a
new task is tested without being listed here. Episodes are cut to 1.5 gait cycles (2 actions) so that
dm_env's longer action sequence also crosses an episode's end.
"""

import unittest

import numpy as np
import pytest

pytest.importorskip("dm_control", reason="dm_control is not installed")
import dm_env  # noqa: E402
from dm_env import test_utils  # noqa: E402

from neuronav.backends.dm_control import DmControlBackend  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.bodies.gaits import make_gait  # noqa: E402
from neuronav.engine.loop import AgentLoop, Clocks  # noqa: E402
from neuronav.errors import ConfigError, PortError  # noqa: E402
from neuronav.scenarios.envs.dm_env_tasks import action_bounds, load, task_names  # noqa: E402
from neuronav.scenarios.envs.tasks import TASKS, make_task  # noqa: E402
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S  # noqa: E402

SHORT_S = 1.5 * CYCLE_S  # an episode of two actions
ACTIONS = 3  # per sequence: two in the first episode, then a new one starts


def _conformance_case(name: str) -> type:
    class Case(test_utils.EnvironmentTestMixin, unittest.TestCase):
        def make_object_under_test(self):
            return load(name, random_state=0, time_limit_s=SHORT_S, trees=0) if name == "beacon" else \
                load(name, random_state=0, time_limit_s=SHORT_S)

        def make_action_sequence(self):
            for _ in range(ACTIONS):
                yield self.make_action()

    Case.__name__ = Case.__qualname__ = f"TestDmEnvConformance_{name}"
    return Case


for _name in TASKS:
    globals()[f"TestDmEnvConformance_{_name}"] = _conformance_case(_name)


def test_every_task_has_an_environment():
    assert task_names() == tuple(TASKS) and len(TASKS) >= 3


@pytest.mark.parametrize("name", list(TASKS))
def test_observables_are_the_task_ports_and_reward_is_the_task_progress(name):
    task = make_task(name)
    env = load(name, random_state=1, time_limit_s=SHORT_S)
    try:
        expected = {*task.observation_ports, *(spec.name for spec in task.task_sensors)}
        assert set(env.observation_spec()) == expected
        low, high = action_bounds()
        assert np.array_equal(env.action_spec().minimum, low) and np.array_equal(env.action_spec().maximum, high)
        env.reset()
        ports = env.task.ports(env.physics)
        before = {k: v[0] for k, v in ports.read(task.state_ports).items()}
        timestep = env.step(np.array([0.0, 0.26]))
        after = {k: v[0] for k, v in ports.read(task.state_ports).items()}
        assert timestep.reward == pytest.approx(task.reward(before, after), abs=1e-12)
        assert abs(timestep.reward) > 0.05  # the ant walked (the tripod covers ~0.27 m per cycle)
        for port in task.observation_ports:
            np.testing.assert_array_equal(timestep.observation[port], after[port], err_msg=port)
    finally:
        env.close()


def test_home_vector_observation_and_reward_agree():
    env = load("homing", random_state=2)
    try:
        first = env.reset().observation["home_vector"]
        second = env.step(np.array([0.0, 0.3]))
        # reward = distance to the nest before minus after = |home vector| before minus after
        assert second.reward == pytest.approx(np.hypot(*first) - np.hypot(*second.observation["home_vector"]),
                                              abs=1e-12)
    finally:
        env.close()


def test_time_limit_truncates_with_discount_one():
    env = load("homing", random_state=0, time_limit_s=SHORT_S)
    try:
        env.reset()
        steps = [env.step(np.array([0.0, 0.2])) for _ in range(2)]
        assert [s.step_type for s in steps] == [dm_env.StepType.MID, dm_env.StepType.LAST]
        assert steps[-1].discount == 1.0  # truncated: not the task's end
    finally:
        env.close()


def test_reaching_the_goal_terminates_with_discount_zero():
    env = load("beacon", random_state=0, landmark_distance_m=5.0, success_radius_m=4.95, trees=0)
    try:
        env.reset()
        for _ in range(8):
            timestep = env.step(np.array([0.0, 0.4]))
            if timestep.last():
                break
        assert timestep.last() and timestep.discount == 0.0
        assert env.task._task.terminated(env.task._state)
    finally:
        env.close()


def test_same_random_state_same_episode():
    runs = []
    for _ in range(2):
        env = load("plume", random_state=7)
        try:
            observations = [env.reset().observation]
            observations += [env.step(np.array([0.3, 0.2])).observation for _ in range(2)]
        finally:
            env.close()
        runs.append(observations)
    for a, b in zip(*runs):
        for port in a:
            np.testing.assert_array_equal(a[port], b[port])
    assert not np.array_equal(runs[0][0]["heading"], runs[0][-1]["heading"])  # it turned


def test_composer_ant_walks_like_the_dm_control_backend():
    """Same start, same commands: the composer model (MJCF text, 6 digits) walks the backend's walk
    (measured: 2e-5 m and 2e-5 rad apart after two gait cycles)."""
    env = load("homing", random_state=3)
    try:
        env.reset()
        task, seed = make_task("homing"), env.task.episode_seed
        commands = [np.array([0.0, 0.3]), np.array([0.5, 0.2])]
        for command in commands:
            composer_state = env.step(command)
        composer_position = env.task.ports(env.physics).read(["position"])["position"][0]
    finally:
        env.close()
    body = desert_ant()
    start = task.start(seed)
    with DmControlBackend(timestep_s=task.physics_timestep_s) as backend:
        backend.load(task.world(0), [body])
        loop = AgentLoop(backend, make_gait("tripod", body),
                         Clocks(physics_dt_s=task.physics_timestep_s, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S))
        loop.reset(seed=seed, position_m=tuple(start.position_m), yaw_rad=float(np.pi / 2 - start.heading_rad))
        for command in commands:
            loop.turn, loop.stride_rad = float(command[0]), float(command[1])
            for _ in range(int(round(CYCLE_S / CONTROL_S))):
                loop.step()
        position = backend.read(["position"])["position"][0]
        heading = backend.read(["heading"])["heading"][0]
    assert np.hypot(*(position - start.position_m)) > 0.3  # it walked
    np.testing.assert_allclose(composer_position, position, atol=2e-4)
    np.testing.assert_allclose(composer_state.observation["heading"], heading, atol=2e-4)


@pytest.mark.parametrize("action", [[0.0], [np.nan, 0.1], "fast", {"turn": 0.0}, [1j, 0.1]])
def test_bad_action_is_a_port_error_naming_the_bounds(action):
    env = load("homing", random_state=0)
    try:
        env.reset()
        with pytest.raises(PortError, match=r"action must be \(turn in \[-1, 1\], stride_rad in \[0, 0.4363\]\)"):
            env.step(action)
    finally:
        env.close()


def test_bad_time_limit_is_a_config_error():
    with pytest.raises(ConfigError, match="time_limit_s must be a positive number"):
        load("homing", time_limit_s=-1.0)


def test_out_of_bounds_actions_are_clipped_as_in_gymnasium():
    """One action rule for dm_env and Gymnasium: a finite action outside the bounds acts as the bound."""
    low, high = action_bounds()
    observations = []
    for action in (np.array([2.0, 1.0]), high):
        env = load("homing", random_state=4)
        try:
            env.reset()
            observations.append(env.step(action).observation["home_vector"])
        finally:
            env.close()
    np.testing.assert_array_equal(observations[0], observations[1])


@pytest.mark.parametrize("seed", [None, "x", -5, 1.5])
def test_world_seed_must_be_a_non_negative_int_as_in_gymnasium(seed):
    with pytest.raises(ConfigError, match="world_seed must be an int >= 0"):
        load("beacon", world_seed=seed)
