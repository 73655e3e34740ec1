"""Benchmark: the same trials on 1 and 2 local workers and on a local Dask cluster of 2 workers.

The workload is path-integration with 2500 steps out and 2500 back (``--steps``; the rest at its
defaults) with one trial per task (``--chunk-size 1``), so each task takes about 0.3 s. Every
variant runs the same 64 trials through :func:`neuronav.runs.sweep.execute` into a fresh run directory
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

Times: wall time (``time.perf_counter``) and CPU time summed over this process and its worker
processes (this process's ``time.process_time``, finished children from ``os.times``, live
children such as Dask's workers from psutil when it is installed). The targets are judged on wall
time: they are claims about elapsed time with two cores working at once, which CPU time cannot
show (two workers spend at least the CPU time of one). Wall time grows when other jobs share the
machine, so the script prints beside it the summed CPU time of every variant (how much work each
really did: a variant whose CPU time is close to the 1-worker run's lost its wall time waiting, not
working) and the load average before and after; read a MISSED next to a load average above 0.5 as
a measurement on a busy machine.

Targets (issue 5): speed-up on 2 workers >= 1.7x; Dask overhead <= 10 % of the local pool's time.

Usage::

    python benchmarks/sweep_scaling.py [--trials 64] [--steps 2500] [--chunk-size 1] [--repeats 3] [--no-dask]
    python benchmarks/sweep_scaling.py --trials 4 --steps 100 --repeats 1 --no-dask   # quick look
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

from neuronav.runs.sweep import execute  # noqa: E402

TARGET_SPEEDUP = 1.7
TARGET_DASK_OVERHEAD = 0.10


def cpu_s() -> float:
    """CPU seconds so far of this process and its children: finished ones (``os.times``) and, with
    psutil, live ones (Dask's workers live across runs, so ``os.times`` alone never sees them)."""
    times = os.times()
    total = time.process_time() + times.children_user + times.children_system
    try:
        import psutil
    except ImportError:  # only the local variants run without distributed, and their workers finish
        return total
    for child in psutil.Process().children(recursive=True):
        try:
            used = child.cpu_times()
        except psutil.NoSuchProcess:  # finished meanwhile: counted by os.times once reaped
            continue
        total += used.user + used.system
    return total


def timed(root: Path, label: str, **options) -> tuple[float, float, str]:
    """(wall s, summed CPU s) of one run into a fresh directory, and its trials.csv text."""
    out = Path(tempfile.mkdtemp(prefix=label.replace(" ", "-") + "-", dir=root))
    started_cpu, started = cpu_s(), time.perf_counter()
    execute("path-integration", out_dir=out, progress=False, figures=False, **options)
    wall_s = time.perf_counter() - started
    return wall_s, cpu_s() - started_cpu, (out / "trials.csv").read_text()


def dask_round(root: Path, **options) -> tuple[tuple[float, float], tuple[float, float], str]:
    """((wall, CPU) cold, (wall, CPU) warm, trials.csv) on a fresh LocalCluster of 2 worker
    processes (started untimed)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        cold_wall, cold_cpu, _ = timed(root, "dask cold", scheduler=cluster.scheduler_address, **options)
        warm_wall, warm_cpu, text = timed(root, "dask warm", scheduler=cluster.scheduler_address, **options)
    return (cold_wall, cold_cpu), (warm_wall, warm_cpu), text


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
    cpus: dict[str, list[float]] = {key: [] for key in times}
    texts: set[str] = set()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        for _ in range(args.repeats):
            wall_s, used_s, _ = timed(root, "batched", trials=args.trials, seed=args.seed, workers=1, overrides=steps)
            times["batched"].append(wall_s)
            cpus["batched"].append(used_s)
            for key, workers in (("one", 1), ("two", 2)):
                wall_s, used_s, text = timed(root, key, workers=workers, **common)
                times[key].append(wall_s)
                cpus[key].append(used_s)
                texts.add(text)
            if not args.no_dask:
                cold, warm, text = dask_round(root, **common)
                for key, (wall_s, used_s) in (("cold", cold), ("dask", warm)):
                    times[key].append(wall_s)
                    cpus[key].append(used_s)
                texts.add(text)
    load_after = os.getloadavg()[0]
    one_s, two_s, batched_s = min(times["one"]), min(times["two"]), min(times["batched"])
    one_cpu = min(cpus["one"])
    rows = [("1 worker (in process)", "one"), ("2 workers (local process pool)", "two")]
    if not args.no_dask:
        rows += [("Dask LocalCluster, 2 workers, warm", "dask"), ("Dask LocalCluster, 2 workers, cold", "cold")]

    per_task_s = one_s / (args.trials / args.chunk_size)
    print(f"path-integration, {args.steps}+{args.steps} steps, {args.trials} trials, chunk size {args.chunk_size} "
          f"({args.trials // args.chunk_size} tasks of {per_task_s:.3f} s), {os.cpu_count()} CPUs, one BLAS thread, "
          f"best of {args.repeats} interleaved rounds; load average {load_before:.2f} before, {load_after:.2f} after")
    print(f"{'variant':<42} {'best wall s':>11} {'speed-up':>9} {'best CPU s':>10} {'CPU vs 1':>8}   "
          f"all runs, wall/CPU s")
    for label, key in rows:
        walls, used = times[key], cpus[key]
        print(f"{label:<42} {min(walls):>11.2f} {one_s / min(walls):>8.2f}x {min(used):>10.2f} "
              f"{min(used) / one_cpu:>7.2f}x   " + " ".join(f"{w:.2f}/{c:.2f}" for w, c in zip(walls, used)))
    print(f"{'context: all trials in one batch (1 task)':<42} {batched_s:>11.2f} {one_s / batched_s:>8.2f}x "
          f"{min(cpus['batched']):>10.2f} {min(cpus['batched']) / one_cpu:>7.2f}x")
    print()
    speedup = one_s / two_s
    print(f"speed-up, 2 workers vs 1 (wall):       {speedup:.2f}x   target >= {TARGET_SPEEDUP}x  "
          f"{'met' if speedup >= TARGET_SPEEDUP else 'MISSED'}")
    if not args.no_dask:
        for label, key in (("warm", "dask"), ("cold", "cold")):
            overhead = (min(times[key]) - two_s) / two_s
            print(f"Dask overhead ({label}) vs local pool (wall): {100 * overhead:+.1f} %   target <= "
                  f"{100 * TARGET_DASK_OVERHEAD:.0f} %  {'met' if overhead <= TARGET_DASK_OVERHEAD else 'MISSED'}"
                  f"   (CPU: {100 * (min(cpus[key]) - min(cpus['two'])) / min(cpus['two']):+.1f} %)")
    print(f"identical per-trial results (every variant, every round): {'yes' if len(texts) == 1 else 'NO'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
