"""Benchmark: the fixed cost of a command — a 1 s locomotion run from the command line, and ``neuronav list``.

Runs, each ``--repeats`` times in a fresh process, and prints the median wall time:

- ``neuronav run locomotion --backend mujoco --set duration_s=1 --out DIR`` (the issue's measure: the
  simulation itself takes about 0.05 s of it, the rest is start-up, writing the run and figures);
- the same with its figures drawn in the command's own process (``NEURONAV_FIGURE_HELPER=0``: no
  helper importing matplotlib while the trial runs, :mod:`neuronav.figure_process`);
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

Usage::

    python benchmarks/startup.py [--repeats 7]
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


def median_wall_s(command: list[str], repeats: int, out: Path | None = None, **environ: str) -> float:
    times = []
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), MPLBACKEND="Agg", **environ)
    for _ in range(repeats):
        if out is not None:
            shutil.rmtree(out, ignore_errors=True)
        started = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    neuronav = str(BIN / "neuronav")
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "run"
        run = [neuronav, "run", "locomotion", "--backend", "mujoco", "--set", "duration_s=1", "--out", str(out)]
        rows = [("1 s locomotion run (figures)", median_wall_s(run, args.repeats, out)),
                ("  the same, figures drawn in-process", median_wall_s(run, args.repeats, out,
                                                                     NEURONAV_FIGURE_HELPER="0")),
                ("1 s locomotion run --no-figures", median_wall_s([*run, "--no-figures"], args.repeats, out)),
                ("neuronav list", median_wall_s([neuronav, "list"], args.repeats))]
    for label, seconds in rows:
        print(f"{label:<38} {seconds:6.2f} s (median of {args.repeats})")


if __name__ == "__main__":
    main()
