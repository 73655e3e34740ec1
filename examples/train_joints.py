"""Joint-level learning: a gait for ``neuronav/AntHoming-v0`` learnt in ``action_mode="joints"``.

The ant sets its 40 joint targets every 8 ms control step on a physics engine (MuJoCo by default) and
observes its proprioception (joint angles and velocities, contact forces, its up axis) with its heading,
body velocity and home vector; the reward is its progress toward the nest (m), and the episode ends at
the nest, when it falls (its up axis more than 60° from vertical) or at the time limit.

The policy is a central pattern generator with six learnt numbers: every leg's swing (ThCz), lift (CTr)
and reach (FTi) joints oscillate about their rest angles at the tripod's period (0.64 s), tripod B half a
cycle after tripod A; the parameters are the three amplitudes, the lift's and reach's phases relative
to the swing, and a steering gain that lengthens the swings of the legs on the side away from the nest
(from the home vector's direction). Trunk and antennae stay at rest. Trained with the cross-entropy
method (numpy only, as in ``train_homing.py``), starting from a standing ant (every amplitude 0).

Run (writes ``learning_curve.csv`` and ``learning_curve.png`` into ``--out``)::

    python examples/train_joints.py --out runs/train_joints                 # MuJoCo, a few minutes
    python examples/train_joints.py --quick --out runs/train_joints_quick   # a few thousand steps
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gymnasium
import numpy as np

import neuronav.scenarios.envs  # noqa: F401  (registers the neuronav ids)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from train_homing import write_curve  # noqa: E402

ENV_ID = "neuronav/AntHoming-v0"
CONTROL_S = 0.008
PERIOD_S = 0.64  # the tripod's gait cycle
TRIPOD_A = ("FL", "MR", "HL")
PARAMETERS = ("swing_rad", "lift_rad", "reach_rad", "lift_phase_rad", "reach_phase_rad", "steer_gain")


class PatternGenerator:
    """Joint targets (J,) of the six-number CPG (module docstring) for one control step."""

    def __init__(self, params: np.ndarray, joint_names: list[str], rest_rad: np.ndarray,
                 low: np.ndarray, high: np.ndarray) -> None:
        self.swing, self.lift, self.reach, self.lift_phase, self.reach_phase, self.steer = (float(p) for p in params)
        self.rest, self.low, self.high = rest_rad, low, high
        leg = [name.split("_")[0] for name in joint_names]
        kind = [name.split("_")[-1] for name in joint_names]
        self.phase = np.array([0.0 if part in TRIPOD_A else np.pi for part in leg])
        self.right = np.array([part in ("FR", "MR", "HR") for part in leg])
        self.is_swing = np.array([k == "ThCz" for k in kind])
        self.is_lift = np.array([k == "CTr" for k in kind])
        self.is_reach = np.array([k == "FTi" for k in kind])
        self.step = 0

    def __call__(self, observation: dict) -> np.ndarray:
        angle = 2.0 * np.pi * self.step * CONTROL_S / PERIOD_S + self.phase
        self.step += 1
        home = np.asarray(observation["home_vector"], float)
        left = float(home[1] / max(np.hypot(*home), 1e-6))  # +1: the nest is to the left
        # Turning left needs longer swings on the right: scale each side's swing by the steering term.
        side = np.where(self.right, 1.0 + self.steer * left, 1.0 - self.steer * left)
        targets = (self.rest + self.is_swing * self.swing * side * np.sin(angle)
                   + self.is_lift * self.lift * np.sin(angle + self.lift_phase)
                   + self.is_reach * self.reach * np.sin(angle + self.reach_phase))
        return np.clip(targets, self.low, self.high).astype(np.float32)


def make_env(backend: str, homing_timeout_s: float) -> gymnasium.Env:
    return gymnasium.make(ENV_ID, backend=backend, action_mode="joints", outbound_s=16.0,
                          homing_timeout_s=homing_timeout_s)


def episode(env: gymnasium.Env, params: np.ndarray, seed: int) -> tuple[float, bool, bool, int]:
    """(return m, reached the nest, fell, control steps) of one episode of the CPG ``params``."""
    from neuronav.bodies.desert_ant import desert_ant

    body = desert_ant()
    policy = PatternGenerator(params, body.joint_names, body.rest_pose_rad(), env.action_space.low,
                              env.action_space.high)
    observation, _ = env.reset(seed=seed)
    total, steps, terminated, truncated, info = 0.0, 0, False, False, {}
    while not (terminated or truncated):
        observation, reward, terminated, truncated, info = env.step(policy(observation))
        total += float(reward)
        steps += 1
    if not np.isfinite(total):
        raise RuntimeError(f"episode {seed}: a non-finite return")
    return total, bool(info.get("is_success")), bool(info.get("fell")), steps


def train(generations: int, population: int, elite: int, eval_episodes: int, seed: int, backend: str,
          homing_timeout_s: float) -> tuple[np.ndarray, list[dict], int]:
    """Cross-entropy method over the six CPG numbers; returns the mean, the curve and the steps taken."""
    env = make_env(backend, homing_timeout_s)
    rng = np.random.default_rng(seed)
    mean = np.zeros(len(PARAMETERS))  # a standing ant
    std = np.array([0.3, 0.3, 0.3, 1.5, 1.5, 0.5])
    eval_seeds = [10_000 + k for k in range(eval_episodes)]
    curve, steps = [], 0
    for generation in range(generations + 1):
        results = [episode(env, mean, s) for s in eval_seeds]
        steps += sum(r[3] for r in results)
        row = {"generation": generation, "episodes": generation * population,
               "policy_return": float(np.mean([r[0] for r in results])),
               "policy_success": float(np.mean([r[1] for r in results])),
               "policy_fell": float(np.mean([r[2] for r in results])), "population_return": float("nan"),
               "control_steps": steps}
        curve.append(row)
        if generation == generations:
            break
        candidates = mean + std * rng.standard_normal((population, len(PARAMETERS)))
        episode_seed = int(rng.integers(0, 2**31 - 1))  # common to the generation: a fair comparison
        outcomes = [episode(env, c, episode_seed) for c in candidates]
        steps += sum(o[3] for o in outcomes)
        returns = np.array([o[0] for o in outcomes])
        best = candidates[np.argsort(returns)[-elite:]]
        mean, std = best.mean(axis=0), best.std(axis=0) + 0.02
        row["population_return"] = float(returns.mean())
    env.close()
    return mean, curve, steps


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="mujoco", help="a physics backend: mujoco, pybullet or dm_control")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--generations", type=int, default=8)
    parser.add_argument("--population", type=int, default=10)
    parser.add_argument("--elite", type=int, default=3)
    parser.add_argument("--eval-episodes", type=int, default=2)
    parser.add_argument("--homing-timeout-s", type=float, default=6.4, help="episode length (s of 8 ms steps)")
    parser.add_argument("--quick", action="store_true", help="2 generations of 4 policies, 1.6 s episodes")
    parser.add_argument("--out", type=Path, default=Path("runs/train_joints"))
    args = parser.parse_args(argv)
    if args.quick:
        args.generations, args.population, args.elite, args.eval_episodes, args.homing_timeout_s = 2, 4, 1, 1, 1.6
    mean, curve, steps = train(args.generations, args.population, args.elite, args.eval_episodes, args.seed,
                               args.backend, args.homing_timeout_s)
    write_curve(curve, "cem", args.out)
    first, last = curve[0], curve[-1]
    print(f"{args.backend}, joints mode, {steps} control steps without divergence: mean policy return "
          f"{first['policy_return']:.3f} m before training, {last['policy_return']:.3f} m after {args.generations} "
          f"generations (fell {last['policy_fell']:.2f}); CPG "
          + ", ".join(f"{name} {value:.3f}" for name, value in zip(PARAMETERS, mean.tolist())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
