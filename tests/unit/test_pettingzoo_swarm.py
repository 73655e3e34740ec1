"""The swarm as a PettingZoo parallel environment: PettingZoo's API tests, seeds, rewards, termination,
the observations' frames, the action dict's rule, stepping before reset, and the rendered top view."""

import gymnasium
import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test  # noqa: E402
from pettingzoo.utils.conversions import parallel_to_aec  # noqa: E402

from neuronav.errors import ConfigError, PortError  # noqa: E402
from neuronav.scenarios.envs.pettingzoo_swarm import PALETTE, RENDER_PX, SwarmHomingEnv  # noqa: E402

STRIDE_RAD = np.radians(20.0)


@pytest.mark.parametrize("backend", ["kinematic", "mujoco", "pybullet"])
def test_pettingzoo_parallel_api_test_passes(backend):
    if backend != "kinematic":
        pytest.importorskip(backend)
    env = SwarmHomingEnv(backend=backend, ants=3 if backend == "kinematic" else 2,
                         max_cycles=2 if backend == "pybullet" else 4)  # PyBullet: 1.5 ant-s per s
    parallel_api_test(env, num_cycles=3 if backend == "pybullet" else 6)
    assert env.possible_agents == [f"ant_{i}" for i in range(env.config.ants)]


# Its two warnings are about the Dict observation, which is by design (named observations as in the single env).
@pytest.mark.filterwarnings("ignore:Observation is not a NumPy array", "ignore:Observation space for each agent")
def test_pettingzoo_aec_api_test_passes_through_parallel_to_aec():
    api_test(parallel_to_aec(SwarmHomingEnv(ants=3, max_cycles=6)), num_cycles=20)


def test_the_same_seed_gives_the_same_episode():
    parallel_seed_test(lambda: SwarmHomingEnv(ants=3, max_cycles=5))
    env = SwarmHomingEnv(ants=3, max_cycles=5)
    first, _ = env.reset(seed=4)
    again, _ = env.reset(seed=4)
    other, _ = env.reset(seed=5)
    assert all(np.array_equal(first[a]["goal_vector"], again[a]["goal_vector"]) for a in env.possible_agents)
    assert not np.array_equal(first["ant_0"]["goal_vector"], other["ant_0"]["goal_vector"])


def steer(observation, toward: bool) -> np.ndarray:
    """Turn toward (or away from) the goal: its bearing in the body frame (forward, left); θ > 0 turns left."""
    forward, left = observation["goal_vector"]
    error = np.arctan2(left, forward)
    if not toward:
        error = np.angle(np.exp(1j * (error + np.pi)))
    return np.array([np.clip(2.0 * error, -1.0, 1.0), STRIDE_RAD], np.float32)


def test_reward_is_progress_toward_the_goal_and_arrival_terminates():
    env = SwarmHomingEnv(ants=2, max_cycles=60)
    observations, infos = env.reset(seed=0)
    assert not any(info["is_success"] for info in infos.values())
    returns, start = {a: 0.0 for a in env.agents}, {a: infos[a]["distance_m"] for a in env.agents}
    finished = {}
    while env.agents:
        actions = {a: steer(observations[a], toward=True) for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        for agent, reward in rewards.items():
            returns[agent] += reward
            assert infos[agent]["is_success"] == terminations[agent] and not infos[agent]["fell"]
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
        observations, rewards, terminations, truncations, infos = env.step(
            {a: steer(observations[a], toward=False) for a in env.agents})
        for agent, reward in rewards.items():
            total[agent] += reward
    assert all(value < -1.0 for value in total.values())
    assert all(truncations.values()) and not any(terminations.values())
    assert not any(info["is_success"] for info in infos.values())


def test_an_ant_that_falls_is_terminated_without_success_and_the_others_walk_on():
    pytest.importorskip("pybullet")
    env = SwarmHomingEnv(backend="pybullet", ants=2, max_cycles=5)
    env.reset(seed=0)
    env.bodies.engine.apply_force(0, "FL_coxa", [0.0, 0.0, 300.0])  # lifts its front left side: it rolls over
    _, _, terminations, truncations, infos = env.step({a: [0.0, 0.0] for a in env.agents})
    assert terminations == {"ant_0": True, "ant_1": False} and not any(truncations.values())
    assert infos["ant_0"]["fell"] and not infos["ant_0"]["is_success"] and not infos["ant_1"]["fell"]
    assert env.agents == ["ant_1"]


@pytest.mark.parametrize("backend", ["kinematic", "mujoco"])
def test_observations_are_bounded_heading_and_body_frame_vectors(backend):
    """heading is (sin, cos), the same however far the ant has turned; velocity_body and goal_vector are
    in the body frame (forward, left): walking straight is all forward, and the goal turned back into
    world axes is the goal minus the position (m)."""
    if backend != "kinematic":
        pytest.importorskip(backend)
    env = SwarmHomingEnv(backend=backend, ants=2, max_cycles=40)
    observations, _ = env.reset(seed=3)
    space = env.observation_space("ant_0")
    cycles = 12 if backend == "kinematic" else 3
    for _ in range(cycles):  # ant_0 walks a tight circle, ant_1 straight on
        observations, *_ = env.step({"ant_0": [1.0, STRIDE_RAD], "ant_1": [0.0, STRIDE_RAD]})
        heading = env.bodies.engine.read(("heading",))["heading"][:, 0]
        for i, agent in enumerate(env.possible_agents):
            observation = observations[agent]
            assert space.contains(observation)
            np.testing.assert_allclose(observation["heading"], [np.sin(heading[i]), np.cos(heading[i])], atol=1e-6)
            forward = observation["heading"]
            left = np.array([-forward[1], forward[0]])
            goal_world = observation["goal_vector"][0] * forward + observation["goal_vector"][1] * left
            np.testing.assert_allclose(goal_world, env.goals_m[i] - env._state["position"][i], atol=1e-4)
    if backend == "kinematic":
        assert abs(heading[0]) > 2 * np.pi, "the kinematic backend's heading is unwrapped; the observation is not"
    forward_m_s, left_m_s = observations["ant_1"]["velocity_body"]
    assert forward_m_s > 0.02 and abs(left_m_s) < 0.5 * forward_m_s, "walking straight: the velocity is forward"
    speed = np.hypot(*env.bodies.engine.read(("velocity",))["velocity"][1])
    assert np.hypot(forward_m_s, left_m_s) == pytest.approx(speed, rel=1e-4), "turned, not rescaled"


def test_the_action_dict_must_name_exactly_the_live_agents():
    env = SwarmHomingEnv(ants=3, max_cycles=30)
    env.reset(seed=0)
    go = [0.0, STRIDE_RAD]
    with pytest.raises(PortError, match=r"no action for 'ant_2'.*does not stand still"):
        env.step({"ant_0": go, "ant_1": go})
    with pytest.raises(PortError, match=r"unknown agents 'ant_7', 'bee'.*'ant_0', 'ant_1', 'ant_2'"):
        env.step({"ant_0": go, "ant_1": go, "ant_2": go, "ant_7": go, "bee": go})
    with pytest.raises(PortError, match="must be a dict"):
        env.step([go, go, go])
    # A refused step leaves the episode where it was.
    assert env._cycles == 0 and env.agents == env.possible_agents
    # Walk ant_0 home alone: then it is done and takes no action.
    observations, _ = env.reset(seed=0)
    while "ant_0" in env.agents:
        observations, *_ = env.step({a: steer(observations[a], True) if a == "ant_0" else [0.0, 0.0]
                                     for a in env.agents})
    with pytest.raises(PortError, match=r"actions for 'ant_0', which are done"):
        env.step({a: go for a in env.possible_agents})
    env.step({a: go for a in env.agents})


@pytest.mark.parametrize("action", ["ab", {"turn": 0.0}, [0.5 + 1j, 0.1], [0.0, np.nan], [0.0], [[0, 0], [0, 0]]],
                         ids=["string", "dict", "complex", "nan", "short", "two-actions"])
def test_actions_that_are_not_two_real_numbers_are_refused_naming_the_ant(action):
    env = SwarmHomingEnv(ants=2)
    env.reset(seed=0)
    with pytest.raises(PortError, match="ant_1's action must be 2 finite real numbers"):
        env.step({"ant_0": [0.0, 0.1], "ant_1": action})


def test_out_of_bounds_actions_are_clipped_to_the_box():
    clipped, wild = SwarmHomingEnv(ants=1), SwarmHomingEnv(ants=1)
    clipped.reset(seed=2)
    wild.reset(seed=2)
    for _ in range(3):
        a, *_ = clipped.step({"ant_0": [1.0, clipped.action_space("ant_0").high[1]]})
        b, *_ = wild.step({"ant_0": [7.0, 3.0]})
    np.testing.assert_array_equal(a["ant_0"]["goal_vector"], b["ant_0"]["goal_vector"])


def test_stepping_before_reset_or_after_the_end_raises():
    env = SwarmHomingEnv(ants=2, max_cycles=1)
    with pytest.raises(gymnasium.error.ResetNeeded, match=r"call reset\(\) before step\(\)"):
        env.step({"ant_0": [0.0, 0.1], "ant_1": [0.0, 0.1]})
    assert env.render() is None
    env.reset(seed=0)
    env.step({"ant_0": [0.0, 0.1], "ant_1": [0.0, 0.1]})
    assert env.agents == []
    with pytest.raises(gymnasium.error.ResetNeeded, match="every ant is done"):
        env.step({})


def test_bad_settings_are_refused():
    with pytest.raises(ConfigError, match="backend must be one of"):
        SwarmHomingEnv(backend="dm_control")
    with pytest.raises(ConfigError, match="at most 31"):
        SwarmHomingEnv(backend="mujoco", ants=40)
    with pytest.raises(ConfigError, match=r"render_mode must be None or 'rgb_array'.*got 'human'"):
        SwarmHomingEnv(render_mode="human")
    env = SwarmHomingEnv(ants=2)
    for seed in ("x", -5, 1.5):
        with pytest.raises(ConfigError, match="seed must be None or an int >= 0"):
            env.reset(seed=seed)
    assert "rgb_array" in env.metadata["render_modes"] and env.metadata["render_fps"] == pytest.approx(1 / 0.64)


def pixel(env, point_m, image) -> tuple[int, int]:
    """The (row, col) where ``swarm_top_view`` puts ``point_m``: found from the frame it draws (see its doc)."""
    paths = np.array(env._path).reshape(-1, 2)
    radius = env.config.nest_radius_m
    points = np.vstack([paths, env.goals_m - radius, env.goals_m + radius])
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    half_m = max(float(np.ptp(points, axis=0).max()) / 2 * 1.05, 1.0)
    to_m = 2 * half_m / image.shape[0]
    return int((centre[1] + half_m - point_m[1]) / to_m), int((point_m[0] - centre[0] + half_m) / to_m)


@pytest.mark.parametrize("backend", ["kinematic", "mujoco"])
def test_render_draws_every_ant_and_its_goal_from_above(backend):
    if backend != "kinematic":
        pytest.importorskip(backend)
    env = SwarmHomingEnv(backend=backend, ants=3, max_cycles=20, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    for _ in range(2):
        env.step({a: [0.3, STRIDE_RAD] for a in env.agents})
    image = env.render()
    assert image.shape == (RENDER_PX, RENDER_PX, 3) and image.dtype == np.uint8
    assert not np.array_equal(first, image), "the ants moved"
    for i in range(3):
        colour = PALETTE[i]
        row, col = pixel(env, env.goals_m[i], image)
        np.testing.assert_allclose(image[row, col], 255 - (255 - colour) * 0.35, atol=1.0)  # the goal's disc
        row, col = pixel(env, env._state["position"][i], image)
        body = image[row - 1:row + 2, col - 1:col + 2].astype(float)  # a 3 x 3 px square
        assert (np.abs(body - colour) <= 1.0).all(), f"ant_{i} is drawn where it stands"
    assert SwarmHomingEnv(ants=2).render() is None  # no render_mode: nothing drawn
