"""Benchmark: the 1000-trial path-integration validation run, batched vs one trial at a time.

Measures on one core (BLAS pinned to one thread before numpy is imported):

1. the batched run as ``neuronav run path-integration --trials 1000`` does it — all 1000 trials in
   one compiled circuit and one kinematic backend — with the scenario's defaults (float32, table
   noise) and with exact arithmetic (float64, numpy's Gaussian sampler);
2. the same trials run one by one with the hand-written numpy model
   (``neuronav.brains.cx_reference.StoneNumpy``) and the agent equations written out per step: the same
   routes (``outbound_routes``), 1500 steps out and 1500 back. Running all 1000 that way takes
   minutes, so ``--baseline-trials`` of them are timed and the per-trial time is multiplied by the
   trial count (printed as an extrapolation).

Targets (issue 2): batched at least 100x faster than one by one, and under 3 s. The headline
speed-up (scenario default: float32 and table noise) is printed next to the like-for-like one
(float64 and numpy's Gaussian sampler batched, against the float64 Gaussian hand-written model).

Every run is timed in CPU time (``time.process_time``) and wall time (``time.perf_counter``), both
printed; the targets are judged on CPU time, because the work runs on one thread (BLAS pinned) and
CPU time, unlike wall time, does not grow when other jobs share the machine.

The batched runs are timed ``--repeats`` times (default 3) and the best counts, as ``timeit`` does:
the first run in a process also pays one-time costs (first allocations, lazy imports) that a
steady-state comparison leaves out; every time is printed. The one-by-one baseline is already a
steady-state average over ``--baseline-trials`` trials.

Usage::

    python benchmarks/path_integration_1000.py [--trials 1000] [--baseline-trials 20] [--seed 0] [--repeats 3]
    python benchmarks/path_integration_1000.py --trials 20 --baseline-trials 1 --repeats 1   # quick look
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav.brains.cx_reference import StoneNumpy  # noqa: E402
from neuronav.config import apply_overrides  # noqa: E402
from neuronav.runs.runner import load_scenario, run_trials  # noqa: E402
from neuronav.scenarios.path_integration.scenario import PathIntegrationConfig, outbound_routes  # noqa: E402

TARGET_SPEEDUP = 100.0
TARGET_S = 3.0


def batched(trials: int, seed: int, overrides: dict, repeats: int) -> tuple[list[float], list[float], float, float]:
    """CPU and wall times of ``repeats`` identical batched scenario runs, and their success rate and tortuosity."""
    scenario = load_scenario("path-integration")
    config = apply_overrides(PathIntegrationConfig, overrides)
    cpu, wall = [], []
    for _ in range(repeats):
        started_cpu, started_wall = time.process_time(), time.perf_counter()
        result = run_trials(scenario, config, "kinematic", trials, seed)
        cpu.append(time.process_time() - started_cpu)
        wall.append(time.perf_counter() - started_wall)
    success = np.mean([t["success"] for t in result.trials])
    return cpu, wall, float(success), result.aggregates["tortuosity"]


def one_trial(seed: int, config: PathIntegrationConfig) -> float:
    """One trial with the hand-written model; returns the closest approach to the nest."""
    rotation, acceleration = outbound_routes(config, [seed])
    model = StoneNumpy(noise=config.noise, seed=seed)
    heading, velocity, position = 0.0, np.zeros(2), np.zeros(2)
    closest = np.inf
    for t in range(config.outbound_steps + config.inbound_steps):
        motor = model.step(heading, velocity)
        if t < config.outbound_steps:
            heading += rotation[0, t]
            thrust = acceleration[0, t]
        else:
            heading += motor
            thrust = config.inbound_acceleration
        velocity = (velocity + thrust * np.array([np.sin(heading), np.cos(heading)])) * (1.0 - config.drag)
        position = position + velocity
        if t >= config.outbound_steps:
            closest = min(closest, float(np.hypot(*position)))
    return closest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=1000)
    parser.add_argument("--baseline-trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=3,
                        help="batched runs timed; the best counts (the first also pays one-time start-up costs)")
    args = parser.parse_args(argv)
    if args.trials < 1 or not 1 <= args.baseline_trials <= args.trials or args.repeats < 1:
        parser.error("need --trials >= 1, 1 <= --baseline-trials <= --trials and --repeats >= 1")

    fast_cpu, fast_wall, fast_success, fast_tortuosity = batched(args.trials, args.seed, {}, args.repeats)
    exact_cpu, exact_wall, exact_success, exact_tortuosity = batched(
        args.trials, args.seed, {"dtype": "float64", "noise_method": "gaussian"}, args.repeats)
    fast_s, exact_s = min(fast_cpu), min(exact_cpu)
    config = PathIntegrationConfig()
    started_cpu, started_wall = time.process_time(), time.perf_counter()
    closest = [one_trial(args.seed + i, config) for i in range(args.baseline_trials)]
    scale = args.trials / args.baseline_trials
    one_by_one_s = (time.process_time() - started_cpu) * scale
    one_by_one_wall_s = (time.perf_counter() - started_wall) * scale

    print(f"path-integration, {args.trials} trials x {config.outbound_steps}+{config.inbound_steps} steps, "
          f"noise {config.noise}, one core; CPU time (process_time) and wall time")
    listed = {name: ", ".join(f"{c:.2f}/{w:.2f}" for c, w in zip(cpu, wall))
              for name, cpu, wall in (("default", fast_cpu, fast_wall), ("exact", exact_cpu, exact_wall))}
    print(f"batched runs, CPU/wall s: best of {args.repeats} (default: {listed['default']}; exact: {listed['exact']})")
    print(f"{'run':<58} {'CPU s':>9} {'wall s':>9} {'success':>8} {'tortuosity':>10}")
    print(f"{'batched, float32 + table noise (scenario default)':<58} {fast_s:>9.2f} {min(fast_wall):>9.2f} "
          f"{100 * fast_success:>7.1f}% {fast_tortuosity:>10.3f}")
    print(f"{'batched, float64 + Gaussian noise (exact)':<58} {exact_s:>9.2f} {min(exact_wall):>9.2f} "
          f"{100 * exact_success:>7.1f}% {exact_tortuosity:>10.3f}")
    print(f"{'one by one, hand-written numpy (extrapolated from ' + str(args.baseline_trials) + ')':<58} "
          f"{one_by_one_s:>9.1f} {one_by_one_wall_s:>9.1f} {100 * np.mean(np.array(closest) <= 20):>7.1f}%")
    print()
    # The headline compares the scenario's default arithmetic (float32, table noise) with the
    # float64 Gaussian hand-written model; the like-for-like figure uses float64 Gaussian on both sides.
    speedup = one_by_one_s / fast_s
    print(f"{'speed-up, default (float32, table noise) vs one by one':<58} {speedup:>8.1f}x CPU "
          f"({one_by_one_wall_s / min(fast_wall):.1f}x wall)   target >= {TARGET_SPEEDUP:.0f}x on CPU  "
          f"{'met' if speedup >= TARGET_SPEEDUP else 'MISSED'}")
    print(f"{'speed-up, like for like (float64 Gaussian on both sides)':<58} {one_by_one_s / exact_s:>8.1f}x CPU "
          f"({one_by_one_wall_s / min(exact_wall):.1f}x wall)")
    print(f"{'time, default':<58} {fast_s:>8.2f} s CPU ({min(fast_wall):.2f} s wall)   target < {TARGET_S:.0f} s "
          f"on CPU  {'met' if fast_s < TARGET_S else 'MISSED'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
