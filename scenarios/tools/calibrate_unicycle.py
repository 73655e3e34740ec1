"""Measure the desert ant's unicycle table from the physics gait.

Walks the desert ant with the FK tripod gait on flat ground for every (turn, stride) on a grid and
records its forward speed and turn rate; writes the table the kinematic backend's ``unicycle``
mode interpolates (body data: :mod:`neuronav.bodies.desert_ant.unicycle`).

By default the table goes to ``unicycle_<backend>.json`` in the current folder (or ``--out PATH``);
replacing the table shipped with the body (``bodies/desert_ant/unicycle_<backend>.json``; the ant walks
by the ``mujoco`` one) takes ``--write-package-table``. Where it will go is decided, and refused if
unusable, before the long calibration starts.

Usage::

    python -m neuronav.scenarios.tools.calibrate_unicycle [--backend mujoco] [--duration 3.0]
        [--out PATH | --write-package-table]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from neuronav.bodies.desert_ant.unicycle import DATA_DIR, table_path
from neuronav.config import apply_overrides
from neuronav.runs.rundir import write_atomic
from neuronav.scenarios.locomotion.scenario import LocomotionConfig, run_trial

TURNS = np.linspace(-1.0, 1.0, 9)
STRIDES_DEG = np.array([0.0, 5.0, 10.0, 15.0, 20.0, 25.0])


def measure(backend: str, duration_s: float, seed: int = 0) -> dict:
    """The calibration table as a JSON-ready dict."""
    # The commanded walk itself: no start jitter, no motor noise.
    base = apply_overrides(LocomotionConfig, {"duration_s": duration_s, "initial_yaw_jitter_rad": 0.0,
                                              "variability": "off"})
    speed = np.zeros((TURNS.size, STRIDES_DEG.size))
    rate = np.zeros_like(speed)
    for i, turn in enumerate(TURNS):
        for j, stride in enumerate(STRIDES_DEG):
            if stride == 0.0:
                continue  # no swing, no motion
            config = replace(base, turn=float(turn), stride_deg=float(stride))
            metrics, _ = run_trial(config, backend, seed)
            speed[i, j] = metrics["forward_speed_m_s"]
            # The kinematic backend's heading is clockwise: its turn rate is minus the yaw rate.
            rate[i, j] = -metrics["turn_rate_rad_s"]
            print(f"turn {turn:+.2f} stride {stride:4.1f} deg: {speed[i, j]:+.3f} m/s, {rate[i, j]:+.3f} rad/s")
    return {
        "source": f"measured on {backend}: FK tripod, flat ground, {duration_s:g} s per point "
                  "(python -m neuronav.scenarios.tools.calibrate_unicycle)",
        "turn": TURNS.tolist(), "stride_rad": np.radians(STRIDES_DEG).tolist(),
        "speed_m_s": speed.tolist(), "turn_rate_rad_s": rate.tolist(),
    }


def output_path(argv: list[str] | None = None) -> tuple[argparse.Namespace, Path]:
    """The parsed arguments and where the table will be written (argparse exits 2 on bad ones)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="mujoco")
    parser.add_argument("--duration", type=float, default=3.0)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--out", type=Path, help="where to write the table (default: ./unicycle_BACKEND.json)")
    where.add_argument("--write-package-table", action="store_true",
                       help="replace the table shipped with the body (bodies/desert_ant/unicycle_BACKEND.json)")
    args = parser.parse_args(argv)
    if not (args.duration > 0):
        parser.error(f"--duration must be positive, got {args.duration}")
    if args.write_package_table:
        return args, table_path(args.backend)
    out = args.out if args.out is not None else Path(f"unicycle_{args.backend}.json")
    if str(args.out) == "" or out.is_dir():
        parser.error(f"--out {str(out)!r} must be a file path")
    if out.resolve().parent == DATA_DIR.resolve():
        parser.error(f"--out {str(out)!r} is in the package; use --write-package-table to replace its table")
    if not out.resolve().parent.is_dir():
        parser.error(f"--out {str(out)!r}: the folder {str(out.parent)!r} does not exist")
    return args, out


def main(argv: list[str] | None = None) -> int:
    args, out = output_path(argv)
    table = measure(args.backend, args.duration)
    write_atomic(out, json.dumps(table, indent=1) + "\n")
    print(f"wrote {out}", file=sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
