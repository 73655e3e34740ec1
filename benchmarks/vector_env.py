"""Benchmark: the native kinematic vector environment against the single Gymnasium environment.

What is counted: one *env-step* is one ``step`` of one env, i.e. one locomotion command held for one
gait cycle (0.64 s of simulated time = 80 control steps of 8 ms, as in
:class:`neuronav.scenarios.envs.gym_env.NeuronavEnv`); one *agent-control-step* is one of those 8 ms steps
of one agent (80 per env-step).

- vector: ``gymnasium.make_vec(ID, num_envs=N, vectorization_mode="vector_entry_point",
  backend="kinematic")`` (:mod:`neuronav.scenarios.envs.vector_env`), N envs stepped as one batch of N
  point agents, with random actions (a seeded generator, uniform in the action box), episodes ending
  and auto-resetting (Gymnasium's next-step mode) inside the timed steps;
- single: ``gymnasium.make(ID, backend="kinematic")``, one env, the same random actions, reset when an
  episode ends.

Time is this process's CPU time (``time.process_time``, one thread: BLAS threads are pinned to 1) and
wall time, the best of ``--repeats`` runs. The target (issue 25): at least 20,000 env-steps per
CPU-second at N = 1000 on ``neuronav/AntHoming-v0``.

Usage::

    python benchmarks/vector_env.py [--envs 1000] [--steps 150] [--single-steps 150] [--repeats 3]
                                    [--id neuronav/AntHoming-v0]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import gymnasium  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import neuronav.scenarios.envs  # noqa: E402,F401  (registers the ids)

TARGET_ENV_STEPS_PER_CPU_S = 20_000
TARGET_ENVS = 1000


def random_actions(space: gymnasium.spaces.Box, count: int, seed: int) -> np.ndarray:
    """``count`` actions drawn uniformly in ``space`` (a seeded generator: the same every run)."""
    rng = np.random.default_rng(seed)
    return rng.uniform(space.low, space.high, (count, *space.shape)).astype(space.dtype)


def time_vector(env_id: str, envs: int, steps: int) -> tuple[float, float, int]:
    """(CPU s, wall s) of ``steps`` steps of ``envs`` envs (autoresets included), and the episodes ended."""
    env = gymnasium.make_vec(env_id, num_envs=envs, vectorization_mode="vector_entry_point", backend="kinematic")
    env.reset(seed=0)
    actions = random_actions(env.action_space, steps, seed=1)
    ended = 0
    cpu, wall = time.process_time(), time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        ended += int(terminated.sum() + truncated.sum())
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    env.close()
    return cpu, wall, ended


def time_single(env_id: str, steps: int) -> tuple[float, float, int]:
    """(CPU s, wall s) of ``steps`` steps of one env (resets after an episode ends included), episodes ended."""
    env = gymnasium.make(env_id, backend="kinematic")
    env.reset(seed=0)
    actions = random_actions(env.action_space, steps, seed=1)
    ended = 0
    cpu, wall = time.process_time(), time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            ended += 1
            env.reset()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    env.close()
    return cpu, wall, ended


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=TARGET_ENVS, help="N, envs in the vector env")
    parser.add_argument("--steps", type=int, default=150,
                        help="vector steps timed per run (150: past the 141-step homing episode, so every env resets)")
    parser.add_argument("--single-steps", type=int, default=150, help="single-env steps timed per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs; the best is reported")
    parser.add_argument("--id", default="neuronav/AntHoming-v0", help="the Gymnasium id")
    args = parser.parse_args(argv)
    controls = 80  # control steps of 8 ms per env-step (one gait cycle of 0.64 s)

    vector = min((time_vector(args.id, args.envs, args.steps) for _ in range(args.repeats)), key=lambda r: r[0])
    single = min((time_single(args.id, args.single_steps) for _ in range(args.repeats)), key=lambda r: r[0])
    rows = [("vector", args.envs, args.steps, *vector), ("single", 1, args.single_steps, *single)]
    print(f"{args.id} on the kinematic backend; one env-step = one gait cycle (0.64 s, {controls} control steps "
          f"of 8 ms); best of {args.repeats}; cpu = time.process_time, wall = time.perf_counter")
    print(f"{'env':8s}{'N':>6s}{'steps':>7s}{'cpu s/step':>12s}{'wall s/step':>13s}{'env-steps/cpu-s':>17s}"
          f"{'control-steps/cpu-s':>21s}{'episodes ended':>16s}")
    rates = {}
    for name, n, steps, cpu, wall, ended in rows:
        rates[name] = n * steps / cpu
        print(f"{name:8s}{n:6d}{steps:7d}{cpu / steps:12.5f}{wall / steps:13.5f}{rates[name]:17,.0f}"
              f"{rates[name] * controls:21,.0f}{ended:16d}")
    print(f"vector / single: {rates['vector'] / rates['single']:.0f}x env-steps per CPU-second")
    if args.envs != TARGET_ENVS:
        print(f"target not judged: it is set at N = {TARGET_ENVS} (got N = {args.envs})")
    elif vector[2] < args.envs:
        print(f"target not judged: the timed steps must include every env's episode end and auto-reset "
              f"(homing: --steps 150); {vector[2]} of {args.envs} envs ended")
    else:
        verdict = "met" if rates["vector"] >= TARGET_ENV_STEPS_PER_CPU_S else "MISSED"
        print(f"target >= {TARGET_ENV_STEPS_PER_CPU_S:,} env-steps per CPU-second at N = {TARGET_ENVS} on CPU: "
              f"{verdict} ({rates['vector']:,.0f})")


if __name__ == "__main__":
    main()
