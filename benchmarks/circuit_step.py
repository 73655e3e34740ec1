"""Benchmark: one step of the compiled Stone 2017 CX circuit, against the hand-written numpy model.

Measures, in one run and on one core:

(a) batch 1: ``CompiledCircuit.step`` of ``neuronav.brains.cx.stone2017`` against
    ``neuronav.brains.cx_reference.StoneNumpy.step`` at the same noise level; target compiled/hand-written <= 1.0;
(b) batch N (default 1000): the compiled circuit's cost per agent-step (time per step / N) and the
    per-agent speed-up batch 1 -> batch N; target >= 50x. For context it also times (b) with the noise
    off, and the floor set by the random numbers alone: every agent-step needs one N(0, 1) draw per
    noisy cell (92 for this circuit), from the agent's own generator (SFC64 seeded with seed + i).

Inputs (heading (batch, 1), velocity (batch, 2), varying every step along smooth random routes) are
generated before timing. Each repeat times a loop of ``--steps`` steps after ``--warmup`` untimed
steps; the table gives the best and the median over ``--repeats`` repeats, and the ratios use the
best (least disturbed) times.

Usage::

    python benchmarks/circuit_step.py [--steps 2048] [--repeats 7] [--batch 1000] [--noise 0.1] [--no-noise-free]
"""

from __future__ import annotations

import os

# One core: set before numpy is imported, so BLAS starts with a single thread.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without installing

from neuronav.brains.cx import stone2017  # noqa: E402
from neuronav.brains.cx_reference import StoneNumpy  # noqa: E402

TARGET_BATCH1_RATIO = 1.0  # compiled / hand-written, at most
TARGET_PER_AGENT_SPEEDUP = 50.0  # per-agent cost batch 1 / batch N, at least


def routes(batch: int, steps: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Smooth random routes: headings (steps, batch, 1) rad and world velocities (steps, batch, 2)."""
    rng = np.random.default_rng(seed)
    turns = rng.vonmises(0.0, 20.0, size=(steps, batch))
    for t in range(1, steps):
        turns[t] += 0.4 * turns[t - 1]
    headings = np.cumsum(turns, axis=0) + rng.uniform(-np.pi, np.pi, size=batch)
    speeds = 0.2 + 0.8 * np.abs(np.sin(np.linspace(0.0, 3.0 * np.pi, steps)))[:, None] * rng.uniform(0.5, 1.0, batch)
    velocities = np.stack([speeds * np.sin(headings), speeds * np.cos(headings)], axis=-1)
    return headings[..., None], velocities


def time_loop(step, arguments: list, warmup: int, repeats: int) -> list[float]:
    """Seconds per call of ``step(*arguments[i])`` for each repeat (a loop over all of ``arguments``)."""
    for args in arguments[:warmup]:
        step(*args)
    per_step = []
    for _ in range(repeats):
        start = time.perf_counter()
        for args in arguments:
            step(*args)
        per_step.append((time.perf_counter() - start) / len(arguments))
    return per_step


def bench_compiled(batch: int, steps: int, warmup: int, repeats: int, noise: float, seed: int,
                   dtype: str = "float64", noise_method: str = "gaussian") -> list[float]:
    compiled = stone2017(noise=noise).compile(batch=batch, seed=seed, dtype=dtype, noise_method=noise_method)
    headings, velocities = routes(batch, steps, seed)
    inputs = [({"heading": headings[t], "velocity": velocities[t]},) for t in range(steps)]
    times = time_loop(compiled.step, inputs, warmup, repeats)
    assert compiled.all_finite()
    return times


def bench_normal_draws(cells: int, batch: int, repeats: int) -> list[float]:
    """Seconds per agent-step spent drawing ``cells`` exact standard normals (numpy's sampler, SFC64),
    in blocks of 64 steps per agent: the floor of the compiled circuit's ``gaussian`` noise."""
    rng = np.random.Generator(np.random.SFC64(0))
    block = np.empty((64, cells))
    per_step = []
    for _ in range(repeats + 1):  # the first one warms up
        start = time.perf_counter()
        for _ in range(batch):
            rng.standard_normal(out=block)
        per_step.append((time.perf_counter() - start) / (batch * block.shape[0]))
    return per_step[1:]


def bench_hand_written(steps: int, warmup: int, repeats: int, noise: float, seed: int) -> list[float]:
    model = StoneNumpy(noise=noise, seed=seed)
    headings, velocities = routes(1, steps, seed)
    inputs = [(float(headings[t, 0, 0]), velocities[t, 0].copy()) for t in range(steps)]
    return time_loop(model.step, inputs, warmup, repeats)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2048, help="timed steps per repeat (default 2048)")
    parser.add_argument("--repeats", type=int, default=7, help="timed repeats; best and median reported (default 7)")
    parser.add_argument("--warmup", type=int, default=200, help="untimed steps before timing (default 200)")
    parser.add_argument("--batch", type=int, default=1000, help="large batch for (b) (default 1000)")
    parser.add_argument("--noise", type=float, default=0.1, help="noise std of every population (default 0.1)")
    parser.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                        help="arithmetic of the compiled circuit (default float64)")
    parser.add_argument("--noise-method", choices=("gaussian", "table"), default="gaussian",
                        help="noise sampler of the compiled circuit (default gaussian: numpy's exact sampler)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise-free", action=argparse.BooleanOptionalAction, default=True,
                        help="also time (b) with the noise off, to show what the random numbers cost (default on)")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.repeats < 1 or args.warmup < 0 or args.batch < 1:
        parser.error("--steps, --repeats and --batch must be >= 1, --warmup >= 0")

    common = dict(steps=args.steps, warmup=min(args.warmup, args.steps), repeats=args.repeats,
                  noise=args.noise, seed=args.seed)
    arithmetic = dict(dtype=args.dtype, noise_method=args.noise_method)
    hand = bench_hand_written(**common)
    one = bench_compiled(batch=1, **common, **arithmetic)
    many = bench_compiled(batch=args.batch, **common, **arithmetic)
    noisy_cells = sum(p.size for p in stone2017(noise=args.noise).populations if p.noise_std > 0)
    if noisy_cells:
        floor = bench_normal_draws(noisy_cells, args.batch, args.repeats)
    if args.noise_free:
        quiet = dict(common, noise=0.0)
        one_quiet = bench_compiled(batch=1, **quiet, **arithmetic)
        many_quiet = bench_compiled(batch=args.batch, **quiet, **arithmetic)

    us = 1e6
    print(f"Stone 2017 CX step ({args.dtype}, {args.noise_method} noise), noise {args.noise}, "
          f"{args.steps} steps x {args.repeats} repeats "
          f"(+{common['warmup']} warm-up); numpy {np.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}")
    print()
    header = f"{'measurement':<40} {'best':>12} {'median':>12}"
    print(header)
    print("-" * len(header))
    rows = [
        ("hand-written StoneNumpy.step [us]", hand),
        ("compiled step, batch 1 [us]", one),
        (f"compiled step, batch {args.batch} [us]", many),
        (f"compiled per agent, batch {args.batch} [us]", [t / args.batch for t in many]),
    ]
    if noisy_cells:
        rows.append((f"  per agent: {noisy_cells} exact N(0,1) draws [us]", floor))
    if args.noise_free:
        rows += [
            ("compiled step, batch 1, noise 0 [us]", one_quiet),
            (f"compiled per agent, batch {args.batch}, noise 0 [us]", [t / args.batch for t in many_quiet]),
        ]
    for label, times in rows:
        print(f"{label:<40} {min(times) * us:>12.3f} {statistics.median(times) * us:>12.3f}")
    print()
    ratio = min(one) / min(hand)
    speedup = min(one) / (min(many) / args.batch)
    median_ratio = statistics.median(one) / statistics.median(hand)
    median_speedup = statistics.median(one) / (statistics.median(many) / args.batch)
    print(f"{'ratio':<40} {'best':>12} {'median':>12}  target")
    print(f"{'(a) compiled / hand-written, batch 1':<40} {ratio:>12.3f} {median_ratio:>12.3f}  "
          f"<= {TARGET_BATCH1_RATIO:.1f}  {'ok' if ratio <= TARGET_BATCH1_RATIO else 'MISSED'}")
    print(f"{f'(b) per-agent cost batch 1 / batch {args.batch}':<40} {speedup:>11.1f}x {median_speedup:>11.1f}x  "
          f">= {TARGET_PER_AGENT_SPEEDUP:.0f}x  {'ok' if speedup >= TARGET_PER_AGENT_SPEEDUP else 'MISSED'}")
    if args.noise_free:
        quiet_speedup = min(one_quiet) / (min(many_quiet) / args.batch)
        quiet_median = statistics.median(one_quiet) / (statistics.median(many_quiet) / args.batch)
        print(f"{'    the same with noise 0':<40} {quiet_speedup:>11.1f}x {quiet_median:>11.1f}x")
    if noisy_cells and args.noise_method == "gaussian":
        print(f"{'    ceiling set by the N(0,1) draws':<40} {min(one) / min(floor):>11.1f}x {'':>12}  "
              "(batch-1 step / draws per agent-step)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
