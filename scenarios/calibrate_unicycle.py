"""Measure the kinematic backend's unicycle table from the physics gait.

Walks the desert ant with the FK tripod gait on flat ground for every (turn, stride) on a grid and
records its forward speed and turn rate; writes the table the kinematic backend's ``unicycle``
mode interpolates (``backends/data/unicycle_<backend>.json``).

Usage::

    python -m scenarios.calibrate_unicycle [--backend mujoco] [--duration 3.0] [--out PATH]
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from neuronav.config import apply_overrides
from neuronav.rundir import write_atomic
from scenarios.locomotion import LocomotionConfig, run_trial

TURNS = np.linspace(-1.0, 1.0, 9)
STRIDES_DEG = np.array([0.0, 5.0, 10.0, 15.0, 20.0, 25.0])
DATA_DIR = Path(__file__).resolve().parents[1] / "backends" / "data"


def measure(backend: str, duration_s: float, seed: int = 0) -> dict:
    """The calibration table as a JSON-ready dict."""
    base = apply_overrides(LocomotionConfig, {"duration_s": duration_s, "initial_yaw_jitter_rad": 0.0})
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
                  "(python -m scenarios.calibrate_unicycle)",
        "turn": TURNS.tolist(), "stride_rad": np.radians(STRIDES_DEG).tolist(),
        "speed_m_s": speed.tolist(), "turn_rate_rad_s": rate.tolist(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="mujoco")
    parser.add_argument("--duration", type=float, default=3.0)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    table = measure(args.backend, args.duration)
    out = args.out or DATA_DIR / f"unicycle_{args.backend}.json"
    write_atomic(out, json.dumps(table, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
