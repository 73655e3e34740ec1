"""The Gymnasium environments (scenarios/envs/gym_env.py): every registered id passes Gymnasium's checker
on every installed backend that carries it, seeded resets repeat, rewards follow the goal, vector envs run."""

import subprocess
import sys
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import neuronav.scenarios.envs  # noqa: F401  (registers the ids)
from neuronav import registry
from neuronav.errors import ConfigError, PortError, RegistryError
from neuronav.scenarios.envs.gym_env import NeuronavEnv
from neuronav.scenarios.envs.tasks import make_task

IDS = sorted(env_id for env_id in gymnasium.registry if env_id.startswith("neuronav/"))
INSTALLED = [name for name in registry.names("backend") if registry.availability("backend", name)[0]]
# What the checker may warn about: observations with no bound (velocity_body, wind, home vector), and
# joint targets in rad within each joint's range rather than normalised to [-1, 1].
ALLOWED_WARNINGS = ("minimum value is -infinity", "maximum value is infinity",
                    "we recommend using a symmetric and normalized space")


def task_of(env_id: str):
    return make_task(gymnasium.spec(env_id).kwargs["task"])


def cases():
    """(id, backend, action mode) for every id, every installed backend its task runs on, every mode allowed."""
    for env_id in IDS:
        for backend in INSTALLED:
            if backend not in task_of(env_id).backends:
                continue
            yield env_id, backend, "locomotion"
            if backend != "kinematic":
                yield env_id, backend, "joints"


def test_the_three_tasks_are_registered():
    assert {"neuronav/AntHoming-v0", "neuronav/AntBeacon-v0", "neuronav/AntPlume-v0"} <= set(IDS)
    assert "kinematic" in INSTALLED


def test_make_with_the_module_prefix_needs_no_import():
    """Gymnasium 1.x loads no plugin entry points; ``"neuronav.scenarios.envs:ID"`` imports the package itself."""
    code = ("import gymnasium; env = gymnasium.make('neuronav.scenarios.envs:neuronav/AntHoming-v0'); "
            "print(sorted(env.reset(seed=0)[0]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "['heading', 'home_vector', 'velocity_body']"


@pytest.mark.parametrize(("env_id", "backend", "mode"), list(cases()))
def test_gymnasium_checker_passes(env_id, backend, mode):
    env = gymnasium.make(env_id, backend=backend, action_mode=mode, render_mode="rgb_array")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env.unwrapped)
        unexpected = [str(w.message) for w in caught if not any(text in str(w.message) for text in ALLOWED_WARNINGS)]
        assert not unexpected, unexpected
        env.reset(seed=0)
        frame = env.render()
        assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    finally:
        env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_backends_the_task_cannot_run_on_are_refused(env_id):
    task = task_of(env_id)
    for backend in INSTALLED:
        if backend not in task.backends:
            with pytest.raises(ConfigError, match=f"runs on the backends {', '.join(task.backends)}"):
                gymnasium.make(env_id, backend=backend)


def rollout(env, seed: int, steps: int = 3) -> list:
    """Observations, rewards and flags of ``steps`` fixed actions after ``reset(seed)``."""
    obs, info = env.reset(seed=seed)
    out = [obs, info["distance_m"]]
    for k in range(steps):
        action = env.action_space.low + (env.action_space.high - env.action_space.low) * (0.3 + 0.2 * k)
        obs, reward, terminated, truncated, info = env.step(action.astype(np.float32))
        out += [obs, reward, terminated, truncated]
    return out


def assert_same(a: list, b: list) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        if isinstance(x, dict):
            assert x.keys() == y.keys()
            for key in x:
                np.testing.assert_array_equal(x[key], y[key])
        else:
            assert x == y


@pytest.mark.parametrize("backend", [b for b in INSTALLED if b in ("kinematic", "mujoco", "pybullet")])
def test_seeded_resets_reproduce_bit_for_bit(backend):
    env_id = "neuronav/AntPlume-v0"  # the plume: the seed also drives the world's random state
    first, second = gymnasium.make(env_id, backend=backend), gymnasium.make(env_id, backend=backend)
    try:
        a = rollout(first, 11)
        assert_same(a, rollout(second, 11))  # another instance
        assert_same(a, rollout(first, 11))  # the same instance again, after other steps
        assert rollout(first, 12)[1] != a[1]  # another seed, another start
    finally:
        first.close()
        second.close()


def toward(env, sign: float) -> np.ndarray:
    """A locomotion command that turns toward the goal (sign +1) or away from it (-1), at a 15° stride."""
    state = env.unwrapped._state
    heading = float(state["heading"][0])
    to_goal = env.unwrapped.task.goal_m - state["position"]
    forward = np.array([np.sin(heading), np.cos(heading)])
    left = np.array([-np.cos(heading), np.sin(heading)])
    bearing = np.arctan2(to_goal @ left, to_goal @ forward)  # > 0: the goal lies to the left
    if sign < 0:
        bearing = np.angle(np.exp(1j * (bearing + np.pi)))
    return np.array([np.clip(2.0 * bearing, -1.0, 1.0), np.radians(15.0)], dtype=np.float32)


@pytest.mark.parametrize(("env_id", "backend"), [(i, "kinematic") for i in IDS] + [("neuronav/AntHoming-v0", "mujoco")])
def test_walking_toward_the_goal_earns_more_than_walking_away(env_id, backend):
    if backend not in INSTALLED:
        pytest.skip(f"{backend} is not installed")
    env = gymnasium.make(env_id, backend=backend)
    try:
        returns = {}
        for sign in (1.0, -1.0):
            env.reset(seed=5)
            returns[sign] = sum(env.step(toward(env, sign))[1] for _ in range(6))
        assert returns[1.0] > 0.5  # about 0.3 m of progress per gait cycle at a 15° stride, once turned
        assert returns[-1.0] < 0.0
    finally:
        env.close()


def test_an_episode_walked_home_terminates_at_the_nest():
    env = gymnasium.make("neuronav/AntHoming-v0", backend="kinematic")
    env.reset(seed=2)
    terminated = truncated = False
    steps = 0
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(toward(env, 1.0))
        steps += 1
    assert terminated and not truncated
    assert info["distance_m"] <= env.unwrapped.task.success_radius_m
    assert steps < env.unwrapped.max_steps


def test_the_time_limit_truncates():
    env = gymnasium.make("neuronav/AntHoming-v0", backend="kinematic", homing_timeout_s=1.28)  # two gait cycles
    env.reset(seed=0)
    standing = np.array([0.0, 0.0], dtype=np.float32)
    assert env.step(standing)[2:4] == (False, False)
    _, reward, terminated, truncated, info = env.step(standing)
    assert (terminated, truncated) == (False, True)
    assert reward == 0.0 and info["time_s"] == pytest.approx(1.28)


def test_spaces_come_from_the_ports():
    env = NeuronavEnv("beacon", backend="kinematic")
    eye = env.observation_space["eye_L"]
    assert eye.shape == (19, 74, 1) and eye.dtype == np.uint8 and eye.low.min() == 0 and eye.high.max() == 255
    assert env.action_space.low.tolist() == [-1.0, 0.0]
    assert env.action_space.high[1] == pytest.approx(np.radians(25.0))
    plume = NeuronavEnv("plume", backend="kinematic")
    assert plume.observation_space["odour"].shape == (2, 1) and plume.observation_space["odour"].low.min() == 0.0
    assert plume.observation_space["wind"].shape == (2, 2)
    homing = NeuronavEnv("homing", backend="kinematic")
    assert set(homing.observation_space) == {"heading", "velocity_body", "home_vector"}


@pytest.mark.skipif("mujoco" not in INSTALLED, reason="mujoco is not installed")
def test_joint_mode_acts_on_the_forty_joints():
    env = NeuronavEnv("homing", backend="mujoco", action_mode="joints")
    try:
        assert env.action_space.shape == (40,)
        low, high = env.action_space.low, env.action_space.high
        assert np.all(low < 0) and np.all(high > 0)
        env.reset(seed=0)
        target = np.clip(np.full(40, 0.3), low, high).astype(np.float32)
        for _ in range(50):  # 0.4 s of holding the targets
            env.step(target)
        joints = env.engine.read(("joint_pos",))["joint_pos"][0]
        assert np.median(np.abs(joints - target)) < 0.1  # the joints went where they were sent
        assert env.max_steps == env.task.step_limit(0.008)
    finally:
        env.close()


def test_bad_arguments_are_one_clear_error():
    with pytest.raises(ConfigError, match="action_mode='joints' needs a physics backend"):
        NeuronavEnv("homing", backend="kinematic", action_mode="joints")
    with pytest.raises(ConfigError, match="action_mode must be one of locomotion, joints"):
        NeuronavEnv("homing", action_mode="torques")
    with pytest.raises(ConfigError, match="home_vector='cx' .* needs action_mode='locomotion'"):
        NeuronavEnv("homing", backend="mujoco", action_mode="joints", home_vector="cx")
    with pytest.raises(RegistryError, match="unknown backend 'bullet'"):
        NeuronavEnv("homing", backend="bullet")
    with pytest.raises(ConfigError, match="unknown key 'radius'"):
        gymnasium.make("neuronav/AntHoming-v0", radius=1.0)
    with pytest.raises(ConfigError, match="render_mode"):
        NeuronavEnv("homing", render_mode="human")
    env = NeuronavEnv("homing")
    with pytest.raises(gymnasium.error.ResetNeeded):
        env.step(np.zeros(2, dtype=np.float32))
    env.reset(seed=0)
    with pytest.raises(PortError, match="action must be 2 finite real numbers"):
        env.step(np.array([np.nan, 0.1]))


def test_kinematic_top_view_shows_the_agent_and_the_goal():
    env = NeuronavEnv("homing", backend="kinematic", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.array([0.0, 0.3], dtype=np.float32))
    frame = env.render()
    colours = {tuple(c) for c in frame.reshape(-1, 3)}
    assert (200, 30, 30) in colours and (30, 120, 30) in colours  # the agent and the nest


@pytest.mark.parametrize("vector", [gymnasium.vector.SyncVectorEnv, gymnasium.vector.AsyncVectorEnv])
def test_vector_envs_run_copies_like_single_envs(vector):
    envs = vector([lambda: gymnasium.make("neuronav/AntHoming-v0", backend="kinematic") for _ in range(2)])
    try:
        obs, _ = envs.reset(seed=[3, 4])
        assert obs["home_vector"].shape == (2, 2)
        actions = np.array([[0.5, 0.3], [-0.5, 0.2]], dtype=np.float32)
        for _ in range(3):
            obs, rewards, terminated, truncated, _ = envs.step(actions)
        assert rewards.shape == (2,)
    finally:
        envs.close()
    single = gymnasium.make("neuronav/AntHoming-v0", backend="kinematic")
    single.reset(seed=4)
    for _ in range(3):
        expected = single.step(actions[1])[0]
    np.testing.assert_array_equal(obs["home_vector"][1], expected["home_vector"])
