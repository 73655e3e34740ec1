"""Train a small policy for ``neuronav/AntHoming-v0`` and draw its learning curve.

The ant starts where a foraging walk ended and must walk home; it observes its home vector (the nest
in its own frame, as a path integrator holds it) and sends the locomotion command (turn θ, stride
S_l) once per gait cycle; the reward is its progress toward the nest (m). The environment runs on
the kinematic backend by default (fast); ``--backend mujoco`` trains the physics ant the same way.

Two trainers:

- ``--algo cem`` (default, numpy only): the cross-entropy method over a linear policy of the home
  vector's direction, squashed into the action box: ``tanh(W @ [ahead / d, left / d, 1])`` (6 numbers).
  Every generation draws ``--population`` policies from a Gaussian, runs each for ``--episodes``
  episodes (the same seeds for all of a generation), and refits the Gaussian to the best
  ``--elite``. The curve: the population's mean return, and the return of the Gaussian's mean
  policy on ``--eval-episodes`` fixed evaluation episodes, per generation.
- ``--algo ppo``: stable-baselines3's PPO with its ``MultiInputPolicy`` on the observation dict
  (``pip install 'neuronav[rl]'``). The curve: each training episode's return.

Run (writes ``learning_curve.png`` and ``learning_curve.csv`` into ``--out``)::

    python examples/train_homing.py --out runs/train_homing
    python examples/train_homing.py --algo ppo --timesteps 30000 --out runs/train_homing_ppo
"""

from __future__ import annotations

import argparse
import csv
import sys
from dataclasses import dataclass
from pathlib import Path

import gymnasium
import numpy as np

import neuronav.scenarios.envs  # noqa: F401  (registers the neuronav ids)

ENV_ID = "neuronav/AntHoming-v0"
# Shorter trips than the scenario's (32 s out, 90 s home) so that an episode takes a fraction of a second.
DEFAULT_SETTINGS = {"outbound_s": 16.0, "homing_timeout_s": 19.2}


def make_env(backend: str = "kinematic", settings: dict | None = None) -> gymnasium.Env:
    """The homing environment in locomotion mode."""
    return gymnasium.make(ENV_ID, backend=backend, action_mode="locomotion", **(settings or DEFAULT_SETTINGS))


def features(observation: dict) -> np.ndarray:
    """(ahead / d, left / d, 1): the nest's direction in the ant's frame, and a bias."""
    home = np.asarray(observation["home_vector"], float)
    return np.append(home / max(float(np.hypot(*home)), 1e-6), 1.0)


@dataclass
class LinearPolicy:
    """A linear map squashed into the action box: ``low + (high - low) (1 + tanh(weights @ features)) / 2``.

    ``weights`` (2, 3): the turn row and the stride row. All zeros walks straight at half the
    largest stride.
    """

    weights: np.ndarray
    low: np.ndarray
    high: np.ndarray

    def __call__(self, observation: dict) -> np.ndarray:
        squashed = (1.0 + np.tanh(self.weights @ features(observation))) / 2.0
        return (self.low + (self.high - self.low) * squashed).astype(np.float32)


def episode_return(env: gymnasium.Env, policy, seed: int) -> tuple[float, bool]:
    """The return of one episode of ``policy`` from ``reset(seed=seed)``, and whether it reached the nest."""
    observation, _ = env.reset(seed=seed)
    total, terminated, truncated = 0.0, False, False
    while not (terminated or truncated):
        observation, reward, terminated, truncated, _ = env.step(policy(observation))
        total += float(reward)
    return total, bool(terminated)


def train_cem(generations: int = 12, population: int = 16, elite: int = 4, episodes: int = 2,
              eval_episodes: int = 8, seed: int = 0, backend: str = "kinematic",
              settings: dict | None = None, make=None) -> tuple[LinearPolicy, list[dict]]:
    """Cross-entropy method over :class:`LinearPolicy`; returns the mean policy and the curve.

    ``make``: a function that returns the environment to train on (default: :func:`make_env` with
    ``backend`` and ``settings``); its observation must have ``home_vector``.

    The curve has one row per generation: ``generation``, ``episodes`` (training episodes before
    it), ``policy_return`` and ``policy_success`` (the Gaussian's mean policy before this
    generation's update, on the fixed evaluation seeds 10_000 ...: mean return, fraction that
    reached the nest) and ``population_return`` (mean over the generation's episodes); a last row
    evaluates the trained policy.
    """
    if not (generations >= 1 and population >= 2 and 1 <= elite <= population and episodes >= 1):
        raise ValueError("need generations >= 1, population >= 2, 1 <= elite <= population, episodes >= 1")
    env = make_env(backend, settings) if make is None else make()
    low, high = env.action_space.low, env.action_space.high
    rng = np.random.default_rng(seed)
    mean, std = np.zeros(6), np.full(6, 1.0)
    eval_seeds = [10_000 + k for k in range(eval_episodes)]

    def evaluate(params: np.ndarray, seeds) -> tuple[float, float]:
        """Mean return and fraction of episodes that reached the nest."""
        policy = LinearPolicy(params.reshape(2, 3), low, high)
        results = np.array([episode_return(env, policy, int(s)) for s in seeds], dtype=float)
        return float(results[:, 0].mean()), float(results[:, 1].mean())

    curve = []
    for generation in range(generations + 1):
        policy_return, policy_success = evaluate(mean, eval_seeds)
        row = {"generation": generation, "episodes": generation * population * episodes,
               "policy_return": policy_return, "policy_success": policy_success, "population_return": float("nan")}
        curve.append(row)
        if generation == generations:  # the last row evaluates the trained policy
            break
        candidates = mean + std * rng.standard_normal((population, 6))
        seeds = rng.integers(0, 2**31 - 1, size=episodes)  # common to the generation: fair comparison
        returns = np.array([evaluate(c, seeds)[0] for c in candidates])
        best = candidates[np.argsort(returns)[-elite:]]
        mean, std = best.mean(axis=0), best.std(axis=0) + 0.05
        row["population_return"] = float(returns.mean())
    env.close()
    return LinearPolicy(mean.reshape(2, 3), low, high), curve


def train_ppo(timesteps: int = 30_000, seed: int = 0, backend: str = "kinematic",
              settings: dict | None = None, n_steps: int = 1024):
    """stable-baselines3 PPO; returns (policy: observation -> action, curve of per-episode returns)."""
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.monitor import Monitor
    except ImportError:
        raise SystemExit("--algo ppo needs stable-baselines3: pip install 'neuronav[rl]'") from None
    env = Monitor(make_env(backend, settings))
    model = PPO("MultiInputPolicy", env, n_steps=n_steps, batch_size=min(64, n_steps), seed=seed, verbose=0)
    model.learn(total_timesteps=timesteps)
    lengths = np.cumsum(env.get_episode_lengths())
    curve = [{"episode": k, "timesteps": int(t), "return": float(r)}
             for k, (t, r) in enumerate(zip(lengths, env.get_episode_rewards()))]
    env.close()
    return (lambda observation: model.predict(observation, deterministic=True)[0]), curve


def learning_curve_figure(curve: list[dict], algo: str):
    """The return per generation (CEM) or per episode with its running mean (PPO)."""
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6, 4))
    if algo == "cem":
        x = [row["episodes"] for row in curve]
        axes.plot(x, [row["policy_return"] for row in curve], "o-", label="mean policy (evaluation episodes)")
        axes.plot(x, [row["population_return"] for row in curve], "s--", alpha=0.7, label="population mean")
        axes.set_xlabel("training episodes")
    else:
        returns = np.array([row["return"] for row in curve])
        window = max(1, len(returns) // 20)
        axes.plot([row["timesteps"] for row in curve], returns, ".", alpha=0.3, label="episode")
        running = np.convolve(returns, np.ones(window) / window, mode="valid")
        axes.plot([row["timesteps"] for row in curve][window - 1:], running, "-", label=f"running mean ({window})")
        axes.set_xlabel("training steps (gait cycles)")
    axes.set_ylabel("return: progress toward the nest (m)")
    axes.set_title(f"{ENV_ID}, {algo}")
    axes.legend()
    figure.tight_layout()
    return figure


def write_curve(curve: list[dict], algo: str, out_dir: Path) -> list[Path]:
    """``learning_curve.csv`` and ``learning_curve.png`` in ``out_dir``."""
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    table = out_dir / "learning_curve.csv"
    with table.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(curve[0]))
        writer.writeheader()
        writer.writerows(curve)
    figure = learning_curve_figure(curve, algo)
    image = out_dir / "learning_curve.png"
    figure.savefig(image, dpi=120)
    plt.close(figure)
    return [table, image]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", choices=("cem", "ppo"), default="cem")
    parser.add_argument("--backend", default="kinematic")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--generations", type=int, default=12, help="cem: generations")
    parser.add_argument("--population", type=int, default=16, help="cem: policies per generation")
    parser.add_argument("--elite", type=int, default=4, help="cem: policies kept per generation")
    parser.add_argument("--episodes", type=int, default=2, help="cem: episodes per policy")
    parser.add_argument("--eval-episodes", type=int, default=8, help="cem: evaluation episodes of the mean policy")
    parser.add_argument("--timesteps", type=int, default=30_000, help="ppo: training steps (gait cycles)")
    parser.add_argument("--out", type=Path, default=Path("runs/train_homing"))
    args = parser.parse_args(argv)
    if args.algo == "cem":
        _, curve = train_cem(args.generations, args.population, args.elite, args.episodes, args.eval_episodes,
                             args.seed, args.backend)
        first, last = curve[0], curve[-1]
        print(f"mean policy on {args.eval_episodes} evaluation episodes: return {first['policy_return']:.3f} m, "
              f"success {first['policy_success']:.2f} before training; {last['policy_return']:.3f} m, "
              f"{last['policy_success']:.2f} after {args.generations} generations ({last['episodes']} episodes)")
    else:
        _, curve = train_ppo(args.timesteps, args.seed, args.backend)
        returns = [row["return"] for row in curve]
        tenth = max(1, len(returns) // 10)
        print(f"PPO episode return: first {tenth} episodes {np.mean(returns[:tenth]):.3f} m, last {tenth} "
              f"{np.mean(returns[-tenth:]):.3f} m ({len(returns)} episodes, {args.timesteps} steps)")
    for path in write_curve(curve, args.algo, args.out):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
