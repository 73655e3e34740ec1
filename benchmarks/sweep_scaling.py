"""Benchmark: the same trials on 1 and 2 local workers and on a local Dask cluster of 2 workers.

The workload is path-integration with 2500 steps out and 2500 back (``--steps``; the rest at its
defaults) with one trial per task (``--chunk-size 1``), so each task takes about 0.3 s. Every
variant runs the same 64 trials through :func:`neuronav.sweep.execute` into a fresh run directory
(figures off, so the timings are the trials, the parts and the assembly of trials.csv and
timeseries.h5) and the per-trial results are compared.

Variants:

1. 1 worker: in this process, one task after another (no pool);
2. 2 workers: the local process pool (forked);
3. Dask: a ``distributed.LocalCluster`` of 2 single-threaded worker processes on 127.0.0.1,
   started (untimed) for each round and closed after it, so that it takes no CPU from the local
   variants; timed cold (its first run: the workers import numpy, scipy and neuronav on their first
   task) and then warm (the same cluster again). Dask overhead = (Dask - local pool) / local pool.

The machine is shared, so the variants run interleaved, ``--repeats`` rounds, and the best time of
each is compared (interference only ever adds time).

Context row: the same 64 trials batched into one task (what ``neuronav run --trials 64`` does).

Targets (issue 5): speed-up on 2 workers >= 1.7x; Dask overhead <= 10 % of the local pool's time.

Usage::

    python benchmarks/sweep_scaling.py [--trials 64] [--steps 2500] [--chunk-size 1] [--repeats 3] [--no-dask]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav.sweep import execute  # noqa: E402

TARGET_SPEEDUP = 1.7
TARGET_DASK_OVERHEAD = 0.10


def timed(root: Path, label: str, **options) -> tuple[float, str]:
    """Wall time of one run into a fresh directory, and its trials.csv text."""
    out = Path(tempfile.mkdtemp(prefix=label.replace(" ", "-") + "-", dir=root))
    started = time.perf_counter()
    execute("path-integration", out_dir=out, progress=False, figures=False, **options)
    wall_s = time.perf_counter() - started
    return wall_s, (out / "trials.csv").read_text()


def dask_round(root: Path, **options) -> tuple[float, float, str]:
    """(cold wall, warm wall, trials.csv) on a fresh LocalCluster of 2 worker processes (started untimed)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        cold_s, _ = timed(root, "dask cold", scheduler=cluster.scheduler_address, **options)
        warm_s, text = timed(root, "dask warm", scheduler=cluster.scheduler_address, **options)
    return cold_s, warm_s, text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=64)
    parser.add_argument("--steps", type=int, default=2500, help="outbound and inbound steps of a trial")
    parser.add_argument("--chunk-size", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=3,
                        help="rounds (each runs every variant once, interleaved); the best of each is shown")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-dask", action="store_true")
    args = parser.parse_args(argv)

    steps = {"outbound_steps": args.steps, "inbound_steps": args.steps}
    common = dict(trials=args.trials, seed=args.seed, chunk_size=args.chunk_size, overrides=steps)
    times: dict[str, list[float]] = {"batched": [], "one": [], "two": [], "dask": [], "cold": []}
    texts: set[str] = set()
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        for _ in range(args.repeats):
            times["batched"].append(timed(root, "batched", trials=args.trials, seed=args.seed, workers=1,
                                          overrides=steps)[0])
            for key, workers in (("one", 1), ("two", 2)):
                wall_s, text = timed(root, key, workers=workers, **common)
                times[key].append(wall_s)
                texts.add(text)
            if not args.no_dask:
                cold_s, warm_s, text = dask_round(root, **common)
                times["cold"].append(cold_s)
                times["dask"].append(warm_s)
                texts.add(text)
    one_s, two_s, batched_s = min(times["one"]), min(times["two"]), min(times["batched"])
    rows = [("1 worker (in process)", times["one"]), ("2 workers (local process pool)", times["two"])]
    if not args.no_dask:
        rows += [("Dask LocalCluster, 2 workers, warm", times["dask"]),
                 ("Dask LocalCluster, 2 workers, cold", times["cold"])]

    per_task_s = one_s / (args.trials / args.chunk_size)
    print(f"path-integration, {args.steps}+{args.steps} steps, {args.trials} trials, chunk size {args.chunk_size} "
          f"({args.trials // args.chunk_size} tasks of {per_task_s:.3f} s), {os.cpu_count()} CPUs, one BLAS thread, "
          f"best of {args.repeats} interleaved rounds")
    print(f"{'variant':<42} {'best s':>8} {'speed-up':>9}   all runs (s)")
    for label, walls in rows:
        print(f"{label:<42} {min(walls):>8.2f} {one_s / min(walls):>8.2f}x   "
              + " ".join(f"{w:.2f}" for w in walls))
    print(f"{'context: all trials in one batch (1 task)':<42} {batched_s:>8.2f} {one_s / batched_s:>8.2f}x")
    print()
    speedup = one_s / two_s
    print(f"speed-up, 2 workers vs 1:       {speedup:.2f}x   target >= {TARGET_SPEEDUP}x  "
          f"{'met' if speedup >= TARGET_SPEEDUP else 'MISSED'}")
    if not args.no_dask:
        for label, wall_s in (("warm", min(times["dask"])), ("cold", min(times["cold"]))):
            overhead = (wall_s - two_s) / two_s
            print(f"Dask overhead ({label}) vs local pool: {100 * overhead:+.1f} %   target <= "
                  f"{100 * TARGET_DASK_OVERHEAD:.0f} %  {'met' if overhead <= TARGET_DASK_OVERHEAD else 'MISSED'}")
    print(f"identical per-trial results (every variant, every round): {'yes' if len(texts) == 1 else 'NO'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
