"""The swarm as a PettingZoo parallel environment: PettingZoo's API test, seeds, rewards, termination."""

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

from neuronav.errors import ConfigError, PortError  # noqa: E402
from neuronav.scenarios.envs.pettingzoo_swarm import SwarmHomingEnv  # noqa: E402


@pytest.mark.parametrize("backend", ["kinematic", "mujoco", "pybullet"])
def test_pettingzoo_parallel_api_test_passes(backend):
    if backend != "kinematic":
        pytest.importorskip(backend)
    env = SwarmHomingEnv(backend=backend, ants=3 if backend == "kinematic" else 2,
                         max_cycles=2 if backend == "pybullet" else 4)  # PyBullet: 1.5 ant-s per s
    parallel_api_test(env, num_cycles=3 if backend == "pybullet" else 6)
    assert env.possible_agents == [f"ant_{i}" for i in range(env.config.ants)]


def test_the_same_seed_gives_the_same_episode():
    parallel_seed_test(lambda: SwarmHomingEnv(ants=3, max_cycles=5))
    env = SwarmHomingEnv(ants=3, max_cycles=5)
    first, _ = env.reset(seed=4)
    again, _ = env.reset(seed=4)
    other, _ = env.reset(seed=5)
    assert all(np.array_equal(first[a]["goal_vector"], again[a]["goal_vector"]) for a in env.possible_agents)
    assert not np.array_equal(first["ant_0"]["goal_vector"], other["ant_0"]["goal_vector"])


def steer(observation, toward: bool) -> np.ndarray:
    """Turn toward (or away from) the goal: θ > 0 turns left; heading is clockwise from +y."""
    goal = observation["goal_vector"]
    bearing = np.arctan2(goal[0], goal[1])
    error = np.angle(np.exp(1j * (bearing - observation["heading"][0])))
    if not toward:
        error = np.angle(np.exp(1j * (error + np.pi)))
    return np.array([np.clip(-2.0 * error, -1.0, 1.0), np.radians(20.0)], np.float32)


def test_reward_is_progress_toward_the_goal_and_arrival_terminates():
    env = SwarmHomingEnv(ants=2, max_cycles=60)
    observations, infos = env.reset(seed=0)
    returns, start = {a: 0.0 for a in env.agents}, {a: infos[a]["distance_m"] for a in env.agents}
    finished = {}
    while env.agents:
        actions = {a: steer(observations[a], toward=True) for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        for agent, reward in rewards.items():
            returns[agent] += reward
            if terminations[agent]:
                finished[agent] = infos[agent]["distance_m"]
    assert set(finished) == {"ant_0", "ant_1"}, "both ants reach their goals by steering at them"
    for agent, distance in finished.items():
        assert distance <= env.config.nest_radius_m
        # The return is the distance covered toward the goal.
        assert returns[agent] == pytest.approx(start[agent] - distance, abs=1e-9)


def test_walking_away_earns_negative_reward_and_is_truncated():
    env = SwarmHomingEnv(ants=2, max_cycles=8)
    observations, _ = env.reset(seed=1)
    total = {a: 0.0 for a in env.agents}
    while env.agents:
        observations, rewards, terminations, truncations, _ = env.step(
            {a: steer(observations[a], toward=False) for a in env.agents})
        for agent, reward in rewards.items():
            total[agent] += reward
    assert all(value < -1.0 for value in total.values())
    assert all(truncations.values()) and not any(terminations.values())


def test_bad_settings_and_actions_are_refused():
    with pytest.raises(ConfigError, match="backend must be one of"):
        SwarmHomingEnv(backend="dm_control")
    with pytest.raises(ConfigError, match="at most 31"):
        SwarmHomingEnv(backend="mujoco", ants=40)
    env = SwarmHomingEnv(ants=2)
    env.reset(seed=0)
    with pytest.raises(PortError, match="ant_0's action must be 2 finite numbers"):
        env.step({"ant_0": [0.0, np.nan], "ant_1": [0.0, 0.1]})
