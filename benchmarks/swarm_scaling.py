"""Benchmark: many ants in one MuJoCo model against as many single-ant models, in ant-seconds per second.

For N = 1, 4, 16 (``--ants``) desert ants, each walked by its own FK tripod gait (a gait sample every
8 ms control step, joint targets written, the 2 ms physics stepped, positions read once per control
step), on flat ground, without rendering:

- one model: the N ants in one MuJoCo model (:class:`neuronav.backends.mujoco.swarm.MujocoSwarm`), 5 m apart
  on a sunflower spiral, each walking a gentle curve of its own (they do not meet in the run);
- separate: N single-ant models (:class:`neuronav.backends.mujoco.MujocoBackend`), each stepped through the
  same walk in turn, as N separate runs would be.

The figure is ants x simulated seconds per CPU second of this process (``time.process_time``, one
thread, the best of ``--repeats`` runs, so other work on a shared machine skews it less than wall
time would); the ratio one model / separate > 1 means the shared model is the faster way.

Usage::

    python benchmarks/swarm_scaling.py [--seconds 2.0] [--repeats 3] [--ants 1,4,16]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav.backends.mujoco import MujocoBackend  # noqa: E402
from neuronav.backends.mujoco.swarm import MujocoSwarm  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.bodies.gaits import make_gait  # noqa: E402
from neuronav.scenarios.swarm_homing.scenario import home_positions  # noqa: E402
from neuronav.spec.world import Ground, World  # noqa: E402

CONTROL_S, PHYSICS_S = 0.008, 0.002
STRIDE_RAD = np.radians(15.0)


def one_model(ants: int, seconds: float) -> tuple[float, np.ndarray]:
    """CPU seconds to walk ``ants`` ants in one model for ``seconds``, and their final positions."""
    ant, world = desert_ant(), World(ground=Ground(size_m=80.0))
    engine = MujocoSwarm(timestep_s=PHYSICS_S)
    engine.load(world, [ant] * ants)
    engine.reset(position_m=home_positions(ants, 5.0), heading_rad=np.linspace(0.0, 2.0 * np.pi, ants, endpoint=False))
    gaits = [make_gait("tripod", ant) for _ in range(ants)]
    turns = np.linspace(-0.2, 0.2, ants)
    steps = int(round(seconds / CONTROL_S))
    started = time.process_time()
    for _ in range(steps):
        engine.write({"joint_targets": np.stack([g.step(t, STRIDE_RAD) for g, t in zip(gaits, turns)])})
        engine.step(int(round(CONTROL_S / PHYSICS_S)))
        engine.read(("position",))
    return time.process_time() - started, engine.read(("position",))["position"]


def separate_models(ants: int, seconds: float) -> tuple[float, np.ndarray]:
    """CPU seconds to walk the same ants as ``ants`` single-ant models, and their final positions."""
    ant, world = desert_ant(), World(ground=Ground(size_m=80.0))
    starts = home_positions(ants, 5.0)
    headings = np.linspace(0.0, 2.0 * np.pi, ants, endpoint=False)
    engines = []
    for start, heading in zip(starts, headings):
        engine = MujocoBackend(timestep_s=PHYSICS_S)
        engine.load(world, [ant])
        engine.reset(position_m=tuple(start), yaw_rad=float(np.pi / 2 - heading))
        engines.append(engine)
    gaits = [make_gait("tripod", ant) for _ in range(ants)]
    turns = np.linspace(-0.2, 0.2, ants)
    steps = int(round(seconds / CONTROL_S))
    started = time.process_time()
    for engine, gait, turn in zip(engines, gaits, turns):
        for _ in range(steps):
            engine.write({"joint_targets": gait.step(turn, STRIDE_RAD)})
            engine.step(int(round(CONTROL_S / PHYSICS_S)))
            engine.read(("position",))
    return time.process_time() - started, np.array([e.read(("position",))["position"][0] for e in engines])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per ant (default 2)")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs (default 3)")
    parser.add_argument("--ants", default="1,4,16", help="comma-separated swarm sizes (default 1,4,16)")
    args = parser.parse_args(argv)
    sizes = [int(n) for n in args.ants.split(",")]
    print(f"MuJoCo {args.seconds:g} s per ant, tripod gait, best of {args.repeats} (CPU time, one thread)")
    print("| ants | one model (ant-s per s) | separate models (ant-s per s) | one model / separate | "
          "largest position difference (m) |")
    print("|---|---|---|---|---|")
    for ants in sizes:
        together = [one_model(ants, args.seconds) for _ in range(args.repeats)]
        apart = [separate_models(ants, args.seconds) for _ in range(args.repeats)]
        shared_rate = ants * args.seconds / min(t for t, _ in together)
        separate_rate = ants * args.seconds / min(t for t, _ in apart)
        difference = float(np.abs(together[0][1] - apart[0][1]).max())
        print(f"| {ants} | {shared_rate:.1f} | {separate_rate:.1f} | {shared_rate / separate_rate:.2f} | "
              f"{difference:.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
