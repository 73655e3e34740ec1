"""Benchmark: the locomotion loop (gait + body on a physics engine) against raw engine steps.

For each installed physics backend and each gait, on flat ground without rendering, on one core:

- loop throughput: physics steps per second of the full loop (gait sample every control step,
  write joint targets, step the engine with the control law, read the sensors the locomotion
  scenario reads), and its real-time factor (simulated seconds per wall second);
- raw throughput: the engine's own step on the same compiled model over the same simulated time,
  no Python in the loop, no reads: ``mj_step`` replaying the same walk's joint targets for MuJoCo
  (its actuators are the control law), dm_control's ``Physics.step`` replaying them for dm_control
  (the same model, stepped through dm_control), ``stepSimulation`` with no control for PyBullet (whose
  control law is Python), as many calls as the loop makes: ``substeps`` per physics step (the
  PyBullet backend runs 3 PyBullet steps per 2 ms for the desert ant, for stable explicit joint
  control; before this benchmark counted them, its raw side stepped a third of the simulated time
  and the ratio read about 0.25);
- the ratio loop / raw.

Times are this process's CPU time (``time.process_time``; the engines run on one thread), the best
of ``--repeats`` runs, so that other work on a shared machine skews them less than wall time would.

Targets (issue 3): MuJoCo real-time factor >= 20x, loop throughput >= 0.5x raw ``mj_step``.

Usage::

    python benchmarks/locomotion_speed.py [--seconds 2.0] [--repeats 3] [--backends mujoco,dm_control,pybullet]
        [--gaits tripod,ripple,wave,ik]
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

from bodies.desert_ant import desert_ant  # noqa: E402
from bodies.gaits import make_gait  # noqa: E402
from neuronav import registry  # noqa: E402
from neuronav.world import World  # noqa: E402

TIMESTEP_S = 0.002
PHYSICS_PER_CONTROL = 4
SENSORS = ("joint_pos", "joint_vel", "joint_torque", "contact_force", "body_pos", "body_quat", "heading")


def loop_rate(backend_name: str, gait_name: str, seconds: float, repeats: int = 1) -> tuple[float, float, float]:
    """(physics steps per CPU second of the loop, forward speed m/s, raw steps per CPU second), best of ``repeats``."""
    body = desert_ant()
    gait = make_gait(gait_name, body)
    controls = int(round(seconds / (TIMESTEP_S * PHYSICS_PER_CONTROL)))
    with registry.load("backend", backend_name)(timestep_s=TIMESTEP_S) as engine:
        engine.load(World(), [body])
        loop_s = np.inf
        for _ in range(repeats):
            engine.reset(0)
            gait.reset()
            start_x = engine.read(["body_pos"])["body_pos"][0, 0]
            walked = []
            started = time.process_time()
            for _ in range(controls):
                targets = gait.step(0.0, np.radians(15))
                engine.write({"joint_targets": targets[None, :]})
                engine.step(PHYSICS_PER_CONTROL)
                engine.read(SENSORS)
                walked.append(targets)
            loop_s = min(loop_s, time.process_time() - started)
        speed = (engine.read(["body_pos"])["body_pos"][0, 0] - start_x) / seconds
        # Raw: the same walk replayed through the engine's own step alone. MuJoCo's actuators take
        # the targets directly; PyBullet's control law lives in Python, so its raw steps run free.
        takes_targets = backend_name in ("mujoco", "dm_control")
        engine_steps = PHYSICS_PER_CONTROL * getattr(engine, "substeps", 1)  # engine calls per control step
        raw_s = np.inf
        for _ in range(repeats):
            engine.reset(0)
            started = time.process_time()
            for targets in walked:
                if takes_targets:
                    engine.raw_step(engine_steps, targets)
                else:
                    engine.raw_step(engine_steps)
            raw_s = min(raw_s, time.process_time() - started)
    return controls * PHYSICS_PER_CONTROL / loop_s, float(speed), controls * PHYSICS_PER_CONTROL / raw_s


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    parser.add_argument("--backends", default="mujoco,dm_control,pybullet")
    parser.add_argument("--gaits", default="tripod,ripple,wave,ik")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs")
    args = parser.parse_args(argv)
    print(f"locomotion loop on flat ground, {args.seconds:g} s simulated, physics {1000 * TIMESTEP_S:g} ms, "
          f"gait every {PHYSICS_PER_CONTROL} steps, one core")
    print(f"{'backend':<10} {'gait':<8} {'loop steps/s':>13} {'real-time x':>12} {'raw steps/s':>12} "
          f"{'loop/raw':>9} {'speed m/s':>10}")
    for backend in args.backends.split(","):
        ok, reason = registry.availability("backend", backend)
        if not ok:
            print(f"{backend:<10} not available: {reason}")
            continue
        for gait in args.gaits.split(","):
            rate, speed, raw = loop_rate(backend, gait, args.seconds, args.repeats)
            print(f"{backend:<10} {gait:<8} {rate:>13.0f} {rate * TIMESTEP_S:>11.1f}x {raw:>12.0f} "
                  f"{rate / raw:>9.2f} {speed:>10.3f}")
    print("targets: MuJoCo real-time factor >= 20x; loop throughput >= 0.5x raw mj_step")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
