"""Observations and conventions of the Gymnasium environment (scenarios/envs/observations.py, gym_env.py):
heading as (sin, cos) on every backend, body-frame vectors in m and m/s, uint8 channel-last eyes, proprioception
with bounds, the fall rule, is_success, reset options, the action rule, ended episodes, goals in physics frames."""

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import neuronav.scenarios.envs  # noqa: F401  (registers the ids)
from neuronav import registry
from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs import GYM_IDS, MAX_EPISODE_STEPS
from neuronav.scenarios.envs.gym_env import NeuronavEnv
from neuronav.scenarios.envs.observations import (
    body_frame,
    check_actions,
    fallen,
    observation_space,
    observe,
    state_ports,
    up_vector,
)
from neuronav.scenarios.envs.tasks import make_task
from neuronav.scenarios.envs.top_view import GOAL
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S
from neuronav.spec.ports import SensorSpec

INSTALLED = [name for name in registry.names("backend") if registry.availability("backend", name)[0]]
needs_mujoco = pytest.mark.skipif("mujoco" not in INSTALLED, reason="mujoco is not installed")
TURN = np.array([1.0, np.radians(20.0)], dtype=np.float32)  # the sharpest turn at a long stride


def test_kinematic_heading_is_sin_cos_and_stays_bounded_while_the_raw_heading_winds_up():
    env = NeuronavEnv("homing", backend="kinematic", homing_timeout_s=200.0)
    env.reset(seed=0)
    for _ in range(60):  # about 10 turns of the unicycle: the raw heading passes 60 rad
        observation = env.step(TURN)[0]
    raw = float(env._state["heading"][0])
    assert abs(raw) > 4 * np.pi
    np.testing.assert_allclose(observation["heading"], [np.sin(raw), np.cos(raw)], atol=1e-6)
    assert env.observation_space["heading"].contains(observation["heading"])


@pytest.mark.parametrize("backend", [b for b in ("kinematic", "mujoco", "pybullet") if b in INSTALLED])
def test_heading_and_home_vector_are_the_same_on_every_backend_for_the_same_pose(backend):
    """A start heading of 7 rad (past 2π) reads as (sin 7, cos 7); the nest, in the body frame, the same everywhere."""
    env = NeuronavEnv("homing", backend=backend)
    try:
        observation, _ = env.reset(seed=0, options={"position_m": (1.0, -2.0), "heading_rad": 7.0})
        np.testing.assert_allclose(observation["heading"], [np.sin(7.0), np.cos(7.0)], atol=0.02)
        forward, left = np.array([np.sin(7.0), np.cos(7.0)]), np.array([-np.cos(7.0), np.sin(7.0)])
        home = -np.array([1.0, -2.0])
        np.testing.assert_allclose(observation["home_vector"], [home @ forward, home @ left], atol=0.05)
    finally:
        env.close()


def test_velocity_is_in_the_body_frame_in_metres_per_second():
    env = NeuronavEnv("homing", backend="kinematic")
    env.reset(seed=3, options={"heading_rad": 2.0})
    start = env._state["position"].copy()
    observation = env.step(np.array([0.0, np.radians(15.0)], dtype=np.float32))[0]
    speed_m_s = np.hypot(*(env._state["position"] - start)) / CYCLE_S
    np.testing.assert_allclose(observation["velocity_body"], [speed_m_s, 0.0], rtol=1e-4, atol=1e-6)
    assert speed_m_s > 0.1  # walking straight ahead: all forward, nothing to the left, whatever the heading
    units = {s.name: s.units for s in env.engine.capabilities.sensors}
    assert units["velocity"] == "m/s" and units["position"] == "m"


def test_body_frame_turns_world_vectors_into_forward_and_left():
    headings = np.array([[0.0], [np.pi / 2], [np.pi]])  # facing +y, +x, -y
    np.testing.assert_allclose(body_frame(np.array([[0.0, 2.0], [0.0, 2.0], [1.0, 0.0]]), headings),
                               [[2.0, 0.0], [0.0, 2.0], [0.0, 1.0]], atol=1e-12)  # +x is left when facing -y
    quats = np.array([[1.0, 0, 0, 0], [np.cos(np.pi / 2), np.sin(np.pi / 2), 0, 0]])  # upright; upside down (x)
    np.testing.assert_allclose(up_vector(quats), [[0, 0, 1], [0, 0, -1]], atol=1e-12)
    tilted = np.array([[np.cos(np.radians(31)), np.sin(np.radians(31)), 0, 0]])  # 62° about x
    assert fallen({"body_quat": tilted}).tolist() == [True]
    assert fallen({"body_quat": tilted}, max_tilt_deg=70.0).tolist() == [False]
    assert fallen({"position": np.zeros((2, 2))}).tolist() == [False, False]  # no body_quat: the kinematic unicycle


@pytest.mark.parametrize("name", ["beacon", "homing", "plume"])
def test_observe_is_batched_agent_by_agent(name):
    """A batch of N states gives each agent's single observation (what the vector env relies on)."""
    task = make_task(name, trees=3) if name == "beacon" else make_task(name)
    env = NeuronavEnv(task, backend="kinematic", panorama=name == "beacon")
    space = env.observation_space
    rng = np.random.default_rng(0)
    states = []
    for seed in range(3):
        env.reset(seed=seed)
        env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
        states.append({name: value[None] for name, value in env._state.items()})
    batch = {name: np.concatenate([s[name] for s in states]) for name in states[0]}
    together = observe(task, batch, space)
    for k, state in enumerate(states):
        alone = observe(task, state, space)
        for name in space:
            assert together[name].shape == (3, *space[name].shape) and together[name].dtype == space[name].dtype
            np.testing.assert_array_equal(together[name][k], alone[name][0], err_msg=name)
    assert set(state_ports(task, space)) >= {"position", "heading", *task.observation_ports}


def test_eyes_are_uint8_channel_last_images_and_the_panorama_is_an_option():
    env = NeuronavEnv("beacon", backend="kinematic", panorama=True, trees=0)
    observation, _ = env.reset(seed=1)
    for name, shape in (("eye_L", (19, 74, 1)), ("eye_R", (19, 74, 1)), ("panorama", (72, 72, 1))):
        image = observation[name]
        assert image.dtype == np.uint8 and image.shape == shape and env.observation_space[name].contains(image)
        assert image.min() < image.max()  # sky, ground and the landmark: not a blank image
    grey = env.engine.read(["eye_L"])["eye_L"][0]
    np.testing.assert_array_equal(observation["eye_L"][..., 0], np.rint(grey * 255).astype(np.uint8))
    assert "panorama" not in NeuronavEnv("beacon", backend="kinematic", trees=0).observation_space


@pytest.mark.parametrize(("task", "backend", "options"), [("beacon", "kinematic", {"panorama": True, "trees": 2}),
                                                           ("homing", "mujoco", {"proprioception": True})])
def test_gymnasium_checker_passes_with_the_optional_observations(task, backend, options):
    if backend not in INSTALLED:
        pytest.skip(f"{backend} is not installed")
    env = gymnasium.make({"beacon": "neuronav/AntBeacon-v0", "homing": "neuronav/AntHoming-v0"}[task],
                         backend=backend, render_mode="rgb_array", **options)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env.unwrapped)
        allowed = ("infinity", "symmetric and normalized")  # as in test_gym_envs.py
        assert not [str(w.message) for w in caught if not any(text in str(w.message) for text in allowed)]
    finally:
        env.close()


def test_compound_eyes_are_an_option_when_the_body_has_them():
    task = make_task("beacon")
    env = NeuronavEnv("beacon", backend="kinematic", trees=0)
    sensors = {s.name: s for s in env.engine.capabilities.sensors}
    with pytest.raises(ConfigError, match="compound_eyes=True: this backend's body carries no compound eyes"):
        observation_space(task, sensors, compound_eyes=True)  # a body without them
    # With compound_eyes=True the env's ant (here the unicycle) carries its two eyes, observed as (M, 2) in [0, 1].
    seeing = NeuronavEnv("beacon", backend="kinematic", trees=0, compound_eyes=True)
    observation, _ = seeing.reset(seed=1)
    for side in ("L", "R"):
        eye = observation[f"compound_eye_{side}"]
        assert eye.shape == (1287, 2) and seeing.observation_space[f"compound_eye_{side}"].contains(eye)
    assert observation["compound_eye_L"][:, 1].max() > 0.4  # UV: the bright sky is seen
    seeing.close()
    sensors["compound_eye_L"] = SensorSpec("compound_eye_L", (5, 2), "green, UV [0, 1]")
    space = observation_space(task, sensors, compound_eyes=True)
    box = space["compound_eye_L"]
    assert box.shape == (5, 2) and box.low.min() == 0.0 and box.high.max() == 1.0
    values = np.linspace(0.0, 1.0, 10).reshape(1, 5, 2)
    state = {"heading": np.zeros((1, 1)), "eye_L": np.zeros((1, 19, 74)), "eye_R": np.zeros((1, 19, 74)),
             "compound_eye_L": values}
    np.testing.assert_allclose(observe(task, state, space)["compound_eye_L"], values.astype(np.float32))
    assert "compound_eye_L" not in observation_space(task, sensors)


def test_proprioception_needs_joints():
    with pytest.raises(ConfigError, match="proprioception needs a physics backend"):
        NeuronavEnv("homing", backend="kinematic", proprioception=True)
    with pytest.raises(ConfigError, match="panorama must be True or False"):
        NeuronavEnv("homing", backend="kinematic", panorama="yes")
    with pytest.raises(ConfigError, match="proprioception needs joint_ranges_rad"):
        env = NeuronavEnv("homing", backend="mujoco" if "mujoco" in INSTALLED else "kinematic")
        observation_space(env.task, {s.name: s for s in env.engine.capabilities.sensors}, proprioception=True)


@needs_mujoco
def test_joints_mode_observes_proprioception_within_its_bounds():
    env = NeuronavEnv("homing", backend="mujoco", action_mode="joints")
    try:
        space = env.observation_space
        assert {"joint_pos", "joint_vel", "contact_force", "body_up"} <= set(space)
        np.testing.assert_array_equal(space["joint_pos"].low, env.action_space.low)  # the joints' ranges
        observation, _ = env.reset(seed=0)
        target = np.clip(np.full(40, 0.3), env.action_space.low, env.action_space.high).astype(np.float32)
        for _ in range(10):
            observation = env.step(target)[0]
        assert space.contains(observation)
        raw = env.engine.read(["joint_pos", "joint_vel"])
        np.testing.assert_allclose(observation["joint_pos"], np.clip(raw["joint_pos"][0], space["joint_pos"].low,
                                                                     space["joint_pos"].high), atol=1e-6)
        np.testing.assert_allclose(observation["joint_vel"], raw["joint_vel"][0], rtol=1e-6, atol=1e-5)
        assert observation["body_up"][2] > 0.9  # standing
        assert np.abs(observation["contact_force"][:6]).sum() > 1.0  # the feet carry the body
        locomotion = NeuronavEnv("homing", backend="mujoco", proprioception=True)
        assert {"joint_pos", "body_up"} <= set(locomotion.observation_space)
        locomotion.close()
        assert "joint_pos" not in NeuronavEnv("homing", backend="mujoco").observation_space
    finally:
        env.close()


@needs_mujoco
def test_the_ant_falls_under_bang_bang_joint_actions_and_the_episode_ends():
    """Measured: all joints flipped between their limits every 80 ms tip the MuJoCo ant over 60° in 0.21 s."""
    env = NeuronavEnv("homing", backend="mujoco", action_mode="joints")
    try:
        env.reset(seed=0)
        low, high = env.action_space.low, env.action_space.high
        for k in range(100):  # 0.8 s
            _, _, terminated, truncated, info = env.step(high if (k // 10) % 2 == 0 else low)
            if terminated or truncated:
                break
        assert terminated and not truncated and info["fell"] and not info["is_success"]
        assert info["time_s"] == pytest.approx(0.21, abs=0.05)  # the README's figure
        assert env._state["body_quat"] is not None and up_vector(env._state["body_quat"][None])[0, 2] < 0.5
        with pytest.raises(gymnasium.error.ResetNeeded, match="episode ended"):
            env.step(high)
        env.reset(seed=0)
        env.unwrapped.fall_tilt_deg = None  # no fall rule: the same actions go on
        for k in range(40):
            _, _, terminated, _, info = env.step(high if (k // 10) % 2 == 0 else low)
        assert not terminated and not info["fell"]
    finally:
        env.close()


def test_success_is_reported_and_an_ended_episode_needs_a_reset():
    env = gymnasium.make("neuronav/AntHoming-v0", backend="kinematic")
    # 2.5 m north of the nest, facing south (heading π): walking straight ahead reaches it
    observation, info = env.reset(seed=0, options={"position_m": (0.0, 2.5), "heading_rad": np.pi})
    assert info["is_success"] is False and info["fell"] is False
    for _ in range(20):
        _, _, terminated, truncated, info = env.step(np.array([0.0, np.radians(20.0)], dtype=np.float32))
        if terminated or truncated:
            break
    assert terminated and info["is_success"] and info["distance_m"] <= env.unwrapped.task.success_radius_m
    with pytest.raises(gymnasium.error.ResetNeeded, match="episode ended"):
        env.unwrapped.step(np.zeros(2, dtype=np.float32))
    short = gymnasium.make("neuronav/AntHoming-v0", backend="kinematic", homing_timeout_s=0.64)
    short.reset(seed=0)
    assert short.step(np.zeros(2, dtype=np.float32))[3]  # truncated
    with pytest.raises(gymnasium.error.ResetNeeded):
        short.unwrapped.step(np.zeros(2, dtype=np.float32))
    short.reset(seed=0)
    short.step(np.zeros(2, dtype=np.float32))  # a reset starts a new episode


@pytest.mark.parametrize("env_id", sorted(GYM_IDS))
def test_the_spec_has_max_episode_steps_covering_both_action_modes(env_id):
    task = make_task(GYM_IDS[env_id])
    assert gymnasium.spec(env_id).max_episode_steps == MAX_EPISODE_STEPS[env_id] == task.step_limit(CONTROL_S)
    assert task.step_limit(CYCLE_S) < MAX_EPISODE_STEPS[env_id]  # locomotion episodes end first, on their own


def test_reset_options_set_start_goal_and_world():
    env = NeuronavEnv("homing", backend="kinematic")
    observation, info = env.reset(seed=0, options={"position_m": [3.0, 4.0], "heading_rad": 0.0,
                                                   "goal_m": (3.0, 10.0)})
    np.testing.assert_allclose(env._state["position"], [3.0, 4.0])
    np.testing.assert_allclose(observation["home_vector"], [6.0, 0.0], atol=1e-6)  # the goal straight ahead
    assert info["distance_m"] == pytest.approx(6.0)
    observation, info = env.reset(seed=0)  # options hold for one episode
    assert info["distance_m"] == pytest.approx(np.hypot(*env._state["position"]))
    for options, match in (({"start": (0, 0)}, "unknown reset option.*'start'.*allowed: position_m"),
                           ({"position_m": "x"}, "'position_m' must be \\(x, y\\)"),
                           ({"position_m": (1.0, np.nan)}, "'position_m' must be"),
                           ({"heading_rad": "north"}, "'heading_rad' must be a finite number"),
                           ({"world_seed": None}, "world_seed must be an int >= 0"),
                           ("world_seed", "reset options must be a dict")):
        with pytest.raises(ConfigError, match=match):
            env.reset(options=options)
    beacon = NeuronavEnv("beacon", backend="kinematic", trees=5)
    with pytest.raises(ConfigError, match="task 'beacon' cannot move its goal"):
        beacon.reset(options={"goal_m": (1.0, 1.0)})
    objects = beacon.engine.world.objects
    beacon.reset(seed=0, options={"world_seed": 7})
    assert beacon.world_seed == 7 and beacon.engine.world.objects != objects  # another forest
    assert beacon.engine.world.objects == beacon.task.world(7).objects


@pytest.mark.parametrize("seed", [None, "x", -5, 1.5, True])
def test_world_seed_must_be_a_non_negative_int(seed):
    with pytest.raises(ConfigError, match="world_seed must be an int >= 0"):
        NeuronavEnv("homing", backend="kinematic", world_seed=seed)
    if seed is not None:  # an episode's seed may be None (fresh entropy), else the same rule
        with pytest.raises(ConfigError, match="seed must be an int >= 0 \\(or None\\)"):
            NeuronavEnv("homing", backend="kinematic").reset(seed=seed)


@pytest.mark.parametrize("action", ["fast", {"turn": 0.0, "stride": 0.2}, np.array([1j, 0.2]), [0.0, 0.1, 0.2],
                                    [[0.0, 0.1], [0.0, 0.1]], [np.inf, 0.1], None])
def test_bad_actions_are_port_errors(action):
    env = NeuronavEnv("homing", backend="kinematic")
    env.reset(seed=0)
    with pytest.raises(PortError, match="action must be 2 finite real numbers"):
        env.step(action)


def test_out_of_bounds_actions_are_clipped_to_the_box():
    runs = []
    for action in ([5.0, 5.0], [-5.0, -1.0]), (NeuronavEnv("homing").action_space.high, [-1.0, 0.0]):
        env = NeuronavEnv("homing", backend="kinematic")
        env.reset(seed=4)
        runs.append([env.step(np.asarray(a, dtype=np.float32))[0]["home_vector"] for a in action])
    np.testing.assert_array_equal(runs[0], runs[1])
    np.testing.assert_array_equal(check_actions([[2.0, -1.0]], [-1.0, 0.0], [1.0, 0.4]), [[1.0, 0.0]])


def test_human_rendering_is_refused_with_the_envs_own_message():
    with pytest.raises(ConfigError, match="render_mode='human' is not supported: neuronav renders headless"):
        NeuronavEnv("homing", backend="kinematic", render_mode="human")


@needs_mujoco
def test_physics_frames_draw_the_goal():
    env = NeuronavEnv("homing", backend="mujoco", render_mode="rgb_array")
    try:
        env.reset(seed=0)
        position = env._state["position"]
        heading = float(env._state["heading"][0])
        ahead = position + 1.0 * np.array([np.sin(heading), np.cos(heading)])  # 1 m in front: in view
        env.reset(seed=0, options={"goal_m": ahead})
        frame = env.render()
        plain = env.engine.render("follow")
        drawn = np.all(frame == np.array(GOAL, np.uint8), axis=-1)
        assert drawn.sum() > 200 and not np.all(plain == np.array(GOAL, np.uint8), axis=-1).any()
        rows, cols = np.nonzero(drawn)
        assert 0.2 * frame.shape[1] < cols.mean() < 0.8 * frame.shape[1]  # the circle ahead, near the middle
        assert (frame != plain).any(axis=-1).sum() == drawn.sum()  # nothing else changed
    finally:
        env.close()


def test_stable_baselines3_checker_passes_with_documented_warnings_only():
    env_checker = pytest.importorskip("stable_baselines3.common.env_checker",
                                      reason="stable-baselines3 (the rl extra) is not installed")
    allowed = ("minimal resolution for an image is 36x36",  # the 19 x 74 eyes: a custom features extractor
               "symmetric and normalized Box action space",  # (turn, stride_rad) and joint targets in rad
               "infinity",  # unbounded observations: velocity_body, home_vector, wind
               "unconventional shape")  # the plume's odour (2, 1) and wind (2, 2): one row per antenna tip
    for task in ("homing", "beacon", "plume"):
        env = NeuronavEnv(task, backend="kinematic", panorama=task == "beacon")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            env_checker.check_env(env, warn=True, skip_render_check=True)
        unexpected = [str(w.message) for w in caught if not any(text in str(w.message) for text in allowed)]
        assert not unexpected, (task, unexpected)
