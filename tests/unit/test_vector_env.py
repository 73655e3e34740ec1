"""The native kinematic vector environment (scenarios/envs/vector_env.py): made by ``gymnasium.make_vec``, it
steps N envs as one batch yet gives each env the episodes of a single ``NeuronavEnv`` with the same seed,
auto-resets per env in Gymnasium's modes, passes the vector checks written here, and refuses bad input.

Gymnasium 1.x ships no checker for vector environments (``gymnasium.utils.env_checker`` checks single
envs only), so :func:`check_vector_env` writes the checks: batched spaces, reset/step shapes and dtypes,
observations inside the space, info masks, seeded determinism, arrays not reused between steps.
"""

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.vector.utils import batch_space

import neuronav.scenarios.envs  # noqa: F401  (registers the ids)
from neuronav import registry
from neuronav.errors import ConfigError, PortError
from neuronav.scenarios.envs.gym_env import NeuronavEnv
from neuronav.scenarios.envs.tasks import foraging_walk, make_task
from neuronav.scenarios.envs.vector_env import NeuronavVectorEnv, foraging_walks, homing_starts

N = 4
# Short episodes, so a few steps see successes, truncations and auto-resets (homing: 15 steps at most).
SETTINGS = {"homing": {"outbound_s": 10.0, "homing_timeout_s": 9.0}, "beacon": {"timeout_s": 4.0}}


def homeward(observations: dict, rng: np.random.Generator) -> np.ndarray:
    """Actions (N, 2) that mostly steer toward the goal (homing: the home vector), with noise, float32."""
    if "home_vector" in observations:
        forward, left = observations["home_vector"][:, 0], observations["home_vector"][:, 1]
        turn = 2.0 * np.arctan2(left, forward) / np.pi
    else:
        turn = np.zeros(len(observations["heading"]))
    turn = np.clip(turn + rng.normal(0.0, 0.3, turn.shape), -1.0, 1.0)
    return np.stack([turn, rng.uniform(0.2, 0.5, turn.shape)], axis=1).astype(np.float32)


def assert_same(a, b, where: str = "") -> None:
    """Bit for bit: the same keys, dtypes, shapes and values (object arrays and dicts recursively)."""
    if isinstance(a, dict):
        assert set(a) == set(b), (where, sorted(a), sorted(b))
        for key in a:
            assert_same(a[key], b[key], f"{where}/{key}")
    elif isinstance(a, np.ndarray) and a.dtype == object:
        assert isinstance(b, np.ndarray) and b.dtype == object and a.shape == b.shape, where
        for x, y in zip(a, b):
            assert_same(x, y, where)
    elif a is None:
        assert b is None, where
    else:
        a, b = np.asarray(a), np.asarray(b)
        assert a.dtype == b.dtype and a.shape == b.shape, (where, a.dtype, b.dtype, a.shape, b.shape)
        assert np.array_equal(a, b), (where, a, b)


def check_vector_env(env, seed: int = 5, steps: int = 6) -> None:
    """The vector checks Gymnasium does not ship (see the module docstring)."""
    n = env.num_envs
    assert env.observation_space == batch_space(env.single_observation_space, n)
    assert env.action_space == batch_space(env.single_action_space, n)
    assert env.metadata["autoreset_mode"] in tuple(AutoresetMode)
    first, info = env.reset(seed=seed)
    again, _ = env.reset(seed=seed)
    assert_same(first, again, "seeded reset")
    assert first in env.observation_space
    assert all(info[f"_{key}"].all() for key in ("distance_m", "time_s", "is_success", "fell"))
    kept = {name: value.copy() for name, value in first.items()}
    env.action_space.seed(seed)
    for _ in range(steps):
        observations, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert observations in env.observation_space, observations
        for name, box in env.single_observation_space.spaces.items():
            assert observations[name].dtype == box.dtype and observations[name].shape == (n, *box.shape)
        assert reward.dtype == np.float64 and reward.shape == (n,)
        assert terminated.dtype == np.bool_ and terminated.shape == (n,)
        assert truncated.dtype == np.bool_ and truncated.shape == (n,)
        for key in [k for k in info if not k.startswith("_")]:
            assert info[f"_{key}"].dtype == np.bool_ and info[f"_{key}"].shape == (n,), key
            assert len(info[key]) == n, key
        assert {"distance_m", "time_s", "is_success", "fell"} <= set(info)
    assert_same(first, kept, "the first observations after stepping")  # not reused or overwritten


def test_make_vec_gives_the_native_vector_env_for_homing_and_beacon():
    for env_id in ("neuronav/AntHoming-v0", "neuronav/AntBeacon-v0"):
        env = gymnasium.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", backend="kinematic")
        try:
            assert isinstance(env.unwrapped, NeuronavVectorEnv) and env.num_envs == 3
            assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
            single = gymnasium.make(env_id, backend="kinematic")
            assert env.single_observation_space == single.observation_space
            assert env.single_action_space == single.action_space
            single.close()
        finally:
            env.close()
    # The plume has no vector entry point: make_vec's default there is Gymnasium's own.
    assert gymnasium.spec("neuronav/AntPlume-v0").vector_entry_point is None


@pytest.mark.parametrize("task", ["homing", "beacon"])
def test_vector_checks_pass(task):
    env = NeuronavVectorEnv(num_envs=N, task=task, **SETTINGS[task])
    try:
        check_vector_env(env)
    finally:
        env.close()


def test_gymnasium_vector_wrappers_see_the_episodes():
    """RecordEpisodeStatistics (which reads the autoreset mode) reports each env's ended episodes."""
    from gymnasium.wrappers.vector import RecordEpisodeStatistics

    env = RecordEpisodeStatistics(NeuronavVectorEnv(num_envs=3, task="homing", outbound_s=10.0,
                                                    homing_timeout_s=1.92))  # three steps
    try:
        env.reset(seed=0)
        returns = np.zeros(3)
        for _ in range(3):
            _, reward, _, truncated, info = env.step(np.tile(np.float32([0.0, 0.3]), (3, 1)))
            returns += reward
        assert truncated.all() and info["_episode"].all()
        assert info["episode"]["l"].tolist() == [3, 3, 3]
        assert np.allclose(info["episode"]["r"], returns, atol=1e-5)
    finally:
        env.close()


@pytest.mark.parametrize(("task", "mode", "steps"), [
    ("homing", AutoresetMode.NEXT_STEP, 30),
    ("homing", AutoresetMode.SAME_STEP, 30),
    ("beacon", AutoresetMode.NEXT_STEP, 8),
])
def test_each_env_runs_the_single_envs_episodes_bit_for_bit(task, mode, steps):
    """The same observations, rewards, ends and infos as Gymnasium's SyncVectorEnv of N single kinematic
    envs (which seeds env i with seed + i), over several auto-reset episodes per env."""
    vector = NeuronavVectorEnv(num_envs=N, task=task, autoreset_mode=mode, **SETTINGS[task])
    sync = SyncVectorEnv([lambda: NeuronavEnv(task=task, backend="kinematic", **SETTINGS[task])] * N,
                         autoreset_mode=mode)
    try:
        ours, theirs = vector.reset(seed=11), sync.reset(seed=11)
        assert_same(ours[0], theirs[0], "reset obs")
        assert_same(ours[1], theirs[1], "reset info")
        rng = np.random.default_rng(0)
        successes = truncations = 0
        for step in range(steps):
            actions = homeward(ours[0], rng)
            ours, theirs = vector.step(actions), sync.step(actions)
            for name, a, b in zip(("obs", "reward", "terminated", "truncated", "info"), ours, theirs):
                assert_same(a, b, f"step {step} {name}")
            successes, truncations = successes + ours[2].sum(), truncations + ours[3].sum()
        if task == "homing":  # the comparison saw both ways an episode ends
            assert successes >= 2 and truncations >= 2, (successes, truncations)
    finally:
        vector.close()
        sync.close()


def test_env_i_is_a_single_env_reset_with_seed_plus_i():
    """The seed mapping stated in the module docstring, against a bare NeuronavEnv: env 2 of reset(seed=40)
    is NeuronavEnv reset(seed=42), then reset() (no seed) at each episode's end."""
    vector = NeuronavVectorEnv(num_envs=3, task="homing", **SETTINGS["homing"])
    single = NeuronavEnv(task="homing", backend="kinematic", **SETTINGS["homing"])
    try:
        ours, _ = vector.reset(seed=40)
        theirs, _ = single.reset(seed=42)
        rng, episodes = np.random.default_rng(1), 0
        for _ in range(30):
            assert_same({k: v[2] for k, v in ours.items()}, theirs)
            actions = homeward(ours, rng)
            ours, reward, terminated, truncated, _ = vector.step(actions)
            theirs, single_reward, single_terminated, single_truncated, _ = single.step(actions[2])
            assert (reward[2], terminated[2], truncated[2]) == (single_reward, single_terminated, single_truncated)
            if terminated[2] or truncated[2]:  # next step: the vector env resets env 2 (next-step mode)
                assert_same({k: v[2] for k, v in ours.items()}, theirs)
                ours, reward, *_ = vector.step(homeward(ours, rng))
                theirs, _ = single.reset()
                assert reward[2] == 0.0
                episodes += 1
        assert episodes >= 2
    finally:
        vector.close()
        single.close()


def test_disabled_autoreset_needs_a_masked_reset():
    env = NeuronavVectorEnv(num_envs=2, task="homing", autoreset_mode="Disabled", outbound_s=10.0,
                            homing_timeout_s=1.28)  # two steps
    try:
        env.reset(seed=0)
        actions = np.zeros((2, 2), np.float32)
        env.step(actions)
        _, _, _, truncated, _ = env.step(actions)
        assert truncated.all()
        with pytest.raises(gymnasium.error.ResetNeeded, match="reset_mask"):
            env.step(actions)
        observations, info = env.reset(options={"reset_mask": np.array([True, False])})
        assert info["_time_s"].tolist() == [True, False]
        with pytest.raises(gymnasium.error.ResetNeeded, match=r"\[1\]"):  # env 1 still ended
            env.step(actions)
        env.reset(options={"reset_mask": np.array([False, True])})
        env.step(actions)
    finally:
        env.close()


def test_one_batch_steps_a_thousand_envs():
    """1000 envs in one kinematic backend of 1000 agents; each env's start is its own seeded one."""
    env = NeuronavVectorEnv(num_envs=1000, task="homing")
    try:
        observations, info = env.reset(seed=0)
        assert env.engine.batch == 1000
        assert len(np.unique(info["distance_m"])) == 1000  # 1000 different starts
        observations, reward, *_ = env.step(np.tile(np.float32([0.0, 0.3]), (1000, 1)))
        assert observations["home_vector"].shape == (1000, 2) and np.all(reward != 0.0)
    finally:
        env.close()


def test_batched_foraging_walks_end_where_the_single_walks_end():
    seeds = list(range(40))
    for attempt in (0, 1):
        positions, headings = foraging_walks(seeds, 32.0, 0.35, np.radians(15.0), attempt)
        for k, seed in enumerate(seeds):
            position, heading = foraging_walk(seed, 32.0, 0.35, np.radians(15.0), attempt)
            assert np.array_equal(positions[k], position) and headings[k] == heading
    task = make_task("homing")
    # Seeds 0-39 include first walks that end too near the nest (the task's docstring: 30 of 0-199).
    positions, headings = homing_starts(task, seeds)
    for k, seed in enumerate(seeds):
        start = task.start(seed)
        assert np.array_equal(positions[k], start.position_m) and headings[k] == start.heading_rad


def test_reset_agents_resets_only_those_agents():
    from neuronav.spec.world import Ground, PointAgents, World

    engine = registry.load("backend", "kinematic")(timestep_s=0.008)
    engine.load(World(ground=Ground(size_m=80.0)), [PointAgents(count=3, mode="unicycle")])
    engine.write({"turn": np.full((3, 1), 0.2), "stride": np.full((3, 1), 0.3)})
    engine.step(10)
    before = engine.read(("position", "heading", "velocity"))
    engine.reset_agents([1], [(1.0, 2.0)], yaw_rad=[0.5])
    after = engine.read(("position", "heading", "velocity"))
    for name in before:
        assert np.array_equal(after[name][[0, 2]], before[name][[0, 2]])
    assert after["position"][1].tolist() == [1.0, 2.0] and after["heading"][1, 0] == np.pi / 2 - 0.5
    assert not after["velocity"][1].any()
    engine.step(1)
    assert engine.read(("position",))["position"][1].tolist() == [1.0, 2.0]  # its command is zero: it stands
    for bad in ([3], [0.5], np.array([True, False])):
        with pytest.raises(ConfigError, match="agents must be"):
            engine.reset_agents(bad, (0.0, 0.0))
    with pytest.raises(ConfigError, match="position_m"):
        engine.reset_agents([0, 1], [(0.0, 0.0, 0.0)] * 2)


@pytest.mark.parametrize("num_envs", [0, -1, "x", 2.0, True, None])
def test_bad_num_envs_is_a_config_error(num_envs):
    with pytest.raises(ConfigError, match="num_envs must be an int >= 1"):
        gymnasium.make_vec("neuronav/AntHoming-v0", num_envs=num_envs, vectorization_mode="vector_entry_point")


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"backend": "mujoco"}, "vectorization_mode='sync'"),
    ({"backend": "nope"}, "vectorization_mode='sync'"),
    ({"task": "plume"}, "runs the tasks homing, beacon"),
    ({"home_vector": "cx"}, "home_vector='oracle' only"),
    ({"render_mode": "rgb_array"}, "render_mode must be None"),
    ({"autoreset_mode": "x"}, "autoreset_mode must be one of"),
    ({"max_episode_steps": 0}, "max_episode_steps"),
    ({"max_episode_steps": 2.5}, "max_episode_steps"),
    ({"world_seed": None}, "world_seed"),
    ({"nest_radius_m": "x"}, "nest_radius_m"),
])
def test_bad_arguments_are_config_errors(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        NeuronavVectorEnv(num_envs=2, **kwargs)


def test_bad_seeds_options_and_actions_are_refused():
    env = NeuronavVectorEnv(num_envs=2, task="homing")
    try:
        with pytest.raises(gymnasium.error.ResetNeeded):
            env.step(np.zeros((2, 2)))
        for seed in ("x", -5, 1.5, [1], [0, "x"], [0, -1]):
            with pytest.raises(ConfigError, match="seed"):
                env.reset(seed=seed)
        for options in ({"goal_m": (1, 1)}, {"reset_mask": [True, False]}, {"reset_mask": np.zeros(2, bool)}, "x"):
            with pytest.raises(ConfigError, match="reset_mask"):
                env.reset(options=options)
        env.reset(seed=[3, None])
        for actions in (np.zeros(2), np.zeros((3, 2)), np.full((2, 2), np.nan), "ab", {"a": 1},
                        np.zeros((2, 2), complex), [[0, 0], [0]]):
            with pytest.raises(PortError, match="action"):
                env.step(actions)
        clipped = env.step(np.array([[5.0, 5.0], [-5.0, -5.0]]))  # outside the box: clipped, as the single env
        assert clipped[0]["home_vector"].shape == (2, 2)
    finally:
        env.close()


def test_the_max_episode_steps_of_make_vec_truncates():
    env = gymnasium.make_vec("neuronav/AntHoming-v0", num_envs=2, vectorization_mode="vector_entry_point",
                             max_episode_steps=2)
    try:
        env.reset(seed=0)
        assert not env.step(np.zeros((2, 2), np.float32))[3].any()
        assert env.step(np.zeros((2, 2), np.float32))[3].all()
    finally:
        env.close()
    env = gymnasium.make_vec("neuronav/AntHoming-v0", num_envs=2, vectorization_mode="vector_entry_point",
                             max_episode_steps=-1)  # -1: no limit but the task's, as in gymnasium.make
    assert env.unwrapped.max_steps == env.unwrapped.single_env.max_steps == 141
    env.close()


@pytest.mark.slow
def test_a_thousand_envs_run_the_single_envs_episodes_bit_for_bit():
    """The non-slow comparison at N = 1000 over 300 steps (two episodes per env and more): envs 0, 517 and 999."""
    vector = NeuronavVectorEnv(num_envs=1000, task="homing")
    picked = {i: NeuronavEnv(task="homing", backend="kinematic") for i in (0, 517, 999)}
    try:
        ours, _ = vector.reset(seed=100)
        theirs = {i: env.reset(seed=100 + i)[0] for i, env in picked.items()}
        rng, ended_before = np.random.default_rng(2), np.zeros(1000, dtype=bool)
        for _ in range(300):
            actions = homeward(ours, rng)
            ours, reward, terminated, truncated, _ = vector.step(actions)
            for i, env in picked.items():
                if ended_before[i]:
                    theirs[i], _ = env.reset()
                else:
                    theirs[i], single_reward, *_ = env.step(actions[i])
                    assert reward[i] == single_reward
                assert_same({k: v[i] for k, v in ours.items()}, theirs[i])
            ended_before = terminated | truncated
    finally:
        vector.close()
        for env in picked.values():
            env.close()
