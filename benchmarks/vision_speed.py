"""Benchmark: how fast each backend's eyes see, and what vision costs a visual-beacon trial.

On one core (Mesa's software rasteriser limited to one thread with ``LP_NUM_THREADS=1``; run it
under ``taskset -c 0`` to pin the process too), in the visual compass scene (five objects, plain
ground, sky gradient), the ant standing at rest:

- per backend (kinematic unicycle, MuJoCo, PyBullet): milliseconds (and frames per second) per binocular pair
  (``eye_L`` + ``eye_R``, 74×19 each) and per panorama (72×72, the whole sphere, 4 × 4 rays per
  pixel), each frame read
  through the sensor port (render, compose, grey), median of ``--frames`` reads, the body turned a
  little between reads so nothing is cached;
- the kinematic backend's batch: panoramas and binocular pairs per second for 1000 agents read at once;
- the real-time factor (simulated seconds per wall second) of one visual-beacon trial of
  ``--seconds`` simulated seconds, binocular, 40 trees, per backend.

Targets (issue 11): the MuJoCo panorama <= 10 ms (45 ms before); visual-beacon real-time factor
>= 10x on MuJoCo and >= 3x on PyBullet.

Usage::

    taskset -c 0 python benchmarks/vision_speed.py [--frames 50] [--seconds 20] [--backends kinematic,mujoco,pybullet]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"
os.environ.setdefault("LP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bodies.desert_ant import desert_ant  # noqa: E402
from neuronav import registry  # noqa: E402
from neuronav.scenery import compass_scene  # noqa: E402
from neuronav.world import PointAgents  # noqa: E402
from scenarios.visual_beacon import VisualBeaconConfig, beacon_trial  # noqa: E402
from scenarios.visual_setup import point_agent_cameras  # noqa: E402


def _engine(name: str, agents: int = 1):
    engine = registry.load("backend", name)(timestep_s=0.008 if name == "kinematic" else 0.002)
    body = PointAgents(count=agents, mode="unicycle", cameras=point_agent_cameras(desert_ant())) \
        if name == "kinematic" else desert_ant()
    engine.load(compass_scene(), [body])
    return engine


def frame_ms(name: str, cameras: tuple[str, ...], frames: int) -> float:
    """Median wall milliseconds to read ``cameras`` once, the body turned by 1° between reads."""
    times = []
    with _engine(name) as engine:
        for k in range(frames):
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=np.radians(k))
            started = time.perf_counter()
            engine.read(cameras)
            times.append(time.perf_counter() - started)
    return 1e3 * float(np.median(times))


def batch_rate(cameras: tuple[str, ...], agents: int, repeats: int = 3) -> float:
    """Frames (of ``cameras`` together) per second for ``agents`` kinematic agents read at once; best of ``repeats``."""
    with _engine("kinematic", agents) as engine:
        engine.reset(seed=0, heading_rad=np.linspace(0.0, 2 * np.pi, agents, endpoint=False))
        best = np.inf
        for _ in range(repeats):
            started = time.perf_counter()
            engine.read(cameras)
            best = min(best, time.perf_counter() - started)
    return agents / best


def beacon_real_time_factor(name: str, seconds: float) -> float:
    config = VisualBeaconConfig(eye="both", timeout_s=seconds, trees=40)
    row, _ = beacon_trial(config, name, seed=2)
    return row["real_time_factor"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--backends", default="kinematic,mujoco,pybullet")
    args = parser.parse_args()
    names = [n for n in args.backends.split(",") if n]
    print(f"{'backend':<10} {'eye pair ms':>12} {'pairs/s':>8} {'panorama ms':>12} {'panoramas/s':>12} "
          f"{'beacon RTF':>11}")
    for name in names:
        try:
            registry.load("backend", name)
        except Exception as error:  # noqa: BLE001 -- a backend that is not installed is reported, not fatal
            print(f"{name:<10} not available: {error}")
            continue
        pair = frame_ms(name, ("eye_L", "eye_R"), args.frames)
        pano = frame_ms(name, ("panorama",), args.frames)
        rtf = beacon_real_time_factor(name, args.seconds)
        print(f"{name:<10} {pair:>12.2f} {1e3 / pair:>8.0f} {pano:>12.2f} {1e3 / pano:>12.0f} {rtf:>10.1f}x")
    if "kinematic" in names:
        print(f"kinematic batch of {args.agents}: {batch_rate(('panorama',), args.agents):,.0f} panoramas/s, "
              f"{batch_rate(('eye_L', 'eye_R'), args.agents):,.0f} binocular pairs/s")


if __name__ == "__main__":
    main()
