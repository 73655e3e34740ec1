"""examples/train_homing.py: a short training run starts, returns a policy, and its return is measured."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
# A short trip: 6 gait cycles per episode.
SHORT = {"outbound_s": 9.6, "homing_timeout_s": 3.84}


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("train_homing", ROOT / "examples" / "train_homing.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def short_run(example):
    return example.train_cem(generations=3, population=8, elite=2, episodes=2, eval_episodes=4, seed=0,
                             settings=SHORT)


def test_cem_returns_a_policy_whose_actions_fit_the_action_space(example, short_run):
    policy, _ = short_run
    env = example.make_env(settings=SHORT)
    observation, _ = env.reset(seed=1)
    action = policy(observation)
    assert env.action_space.contains(action)
    env.close()


def test_the_short_run_learns_to_walk_toward_the_nest(short_run):
    _, curve = short_run
    assert [row["generation"] for row in curve] == [0, 1, 2, 3]
    returns = [row["policy_return"] for row in curve]
    assert np.isfinite(returns).all()
    # The untrained mean policy (all weights 0) walks straight on: as often away from the nest as toward it.
    assert returns[0] < 0.0
    # Three generations later it turns toward the nest and walks there (at most ~0.3 m per gait cycle, 6 cycles).
    assert returns[-1] > 0.5
    assert returns[-1] - returns[0] > 1.0


def test_the_curve_is_written_as_a_table_and_a_figure(example, short_run, tmp_path):
    _, curve = short_run
    table, image = example.write_curve(curve, "cem", tmp_path)
    lines = table.read_text().splitlines()
    assert lines[0].split(",") == list(curve[0]) and len(lines) == len(curve) + 1
    assert image.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    figure = example.learning_curve_figure(curve, "cem")
    line = figure.axes[0].lines[0]
    np.testing.assert_allclose(line.get_ydata(), [row["policy_return"] for row in curve])


def test_ppo_trains_when_stable_baselines3_is_installed(example):
    pytest.importorskip("stable_baselines3", reason="the rl extra (stable-baselines3) is not installed")
    policy, curve = example.train_ppo(timesteps=128, settings=SHORT, n_steps=64)
    env = example.make_env(settings=SHORT)
    observation, _ = env.reset(seed=0)
    assert env.action_space.contains(np.asarray(policy(observation), dtype=np.float32))
    assert curve and all(np.isfinite(row["return"]) for row in curve)
    env.close()
