"""Benchmark: the fixed cost of a command — a 1 s locomotion run from the command line, and ``neuronav list``.

Runs, each ``--repeats`` times in a fresh process, and prints the median wall time and the median
CPU time of the command (its process and the processes it waited for, the figure helper included:
the children's user + system time from ``os.times``):

- ``neuronav run locomotion --backend mujoco --set duration_s=1 --out DIR`` (the issue's measure: the
  simulation itself takes about 0.05 s of it, the rest is start-up, writing the run and figures);
- the same with its figures drawn in the command's own process (``NEURONAV_FIGURE_HELPER=0``: no
  helper importing matplotlib while the trial runs, :mod:`neuronav.runs.figure_process`);
- the same with ``--no-figures``;
- ``neuronav list``.

Before (commit d59cb8e, the 2-core CI machine): the 1 s run took 1.41–1.54 s and ``neuronav list``
1.2 s, measured while other jobs shared the machine; on the same machine idle, d59cb8e's
``python -m neuronav`` (then the same as the script) took 1.12 s (0.65 s with ``--no-figures``,
``neuronav list`` 0.89 s; median of 9). What went: scipy.sparse, scipy.signal/interpolate,
scipy.optimize and scipy.spatial (the default ant's tilts and quaternions are kept exactly as scipy
solves them: ``bodies/desert_ant/solved.py``) and networkx (circuits and the
circuit diagram import it when used) are no longer imported on this path; cube-face lookups are
built when a camera first renders; the young generation is collected less often and ``gc.freeze``
runs before exit (``python -m neuronav`` too); PNGs are compressed fast, at the figures' own 100
dpi, and drawn once (no second layout draw after ``tight_layout``).

Which time to read: the in-process and ``--no-figures`` runs and ``neuronav list`` are one
process on one thread, so their CPU time is their cost whatever else the machine runs, and it is
the figure to compare across runs on a shared machine (wall time grows with the load). The default
run forks a helper that imports matplotlib on the second core while the trial runs: what it buys is
that overlap, which only wall time shows (and only when a second core is free), while its CPU time
(the two processes summed) shows what the overlap costs.

Usage::

    python benchmarks/startup.py [--repeats 7]
    python benchmarks/startup.py --repeats 1   # quick look
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = Path(sys.executable).parent


def median_times_s(command: list[str], repeats: int, out: Path | None = None, **environ: str) -> tuple[float, float]:
    """Median (wall, CPU) seconds of ``command``; CPU is the children's user + system time it adds."""
    wall, cpu = [], []
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), MPLBACKEND="Agg", **environ)
    for _ in range(repeats):
        if out is not None:
            shutil.rmtree(out, ignore_errors=True)
        before = os.times()
        started = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        wall.append(time.perf_counter() - started)
        after = os.times()
        cpu.append(after.children_user + after.children_system - before.children_user - before.children_system)
    return statistics.median(wall), statistics.median(cpu)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    neuronav = str(BIN / "neuronav")
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "run"
        run = [neuronav, "run", "locomotion", "--backend", "mujoco", "--set", "duration_s=1", "--out", str(out)]
        rows = [("1 s locomotion run (figures)", median_times_s(run, args.repeats, out)),
                ("  the same, figures drawn in-process", median_times_s(run, args.repeats, out,
                                                                      NEURONAV_FIGURE_HELPER="0")),
                ("1 s locomotion run --no-figures", median_times_s([*run, "--no-figures"], args.repeats, out)),
                ("neuronav list", median_times_s([neuronav, "list"], args.repeats))]
    print(f"{'command':<38} {'wall s':>7} {'CPU s':>7}   (medians of {args.repeats}; CPU: the command and its helper)")
    for label, (wall_s, cpu_s) in rows:
        print(f"{label:<38} {wall_s:>7.2f} {cpu_s:>7.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
