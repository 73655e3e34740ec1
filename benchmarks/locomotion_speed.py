"""Benchmark: the locomotion loop (gait + body on a physics engine) against the bare engine doing the same walk.

For each installed physics backend and each gait, on flat ground without rendering, on one core:

- loop: the full loop (gait sample every control step, write joint targets, step the engine with
  the control law, read the sensors the locomotion scenario reads): its seconds and its real-time
  factor (simulated seconds per CPU second);
- raw: the engine alone doing the same walk over the same simulated time, no reads:

  - MuJoCo: bare ``mujoco.mj_step`` (its actuators are the control law), ``ctrl`` set to the
    walk's joint targets before each control step's ``mj_step`` calls;
  - dm_control: ``Physics.step`` on the same model, the same targets in ``ctrl``;
  - PyBullet: as many ``stepSimulation`` calls as the loop makes (``substeps`` per physics
    step), each preceded by one ``setJointMotorControlArray`` with the torques the backend's
    control law applied at that PyBullet step, recorded in an untimed pass that runs the
    backend's law (``torque = kp (target - q) - kd q_dot``, clipped) at every PyBullet step. The
    engine integrates the same torques and so walks the same walk (bit for bit here), and the raw
    side pays for no Python control. PyBullet's own C-side controls were measured and rejected
    (1.5 s tripod, 2-core CI VM): ``POSITION_CONTROL`` (solver motors) walks another walk
    (0.78-0.85 m instead of 0.54 m, depending on the gains) in 2.3-3.5x the loop's CPU time, and
    ``PD_CONTROL`` through ``pdControlPlugin`` walks the same walk but costs 1.2x the loop (the
    plugin reads and commands each joint through the client API, one call per joint and step);
- the ratio loop / raw (raw CPU time over loop CPU time: the loop's throughput as a fraction of
  the engine's own).

SAME WALK: the raw side must do what the loop does, or the ratio measures nothing (before, the
PyBullet raw steps ran with no control: the ant collapsed, its contacts changed and the ratio read
0.98-1.12). For both sides the script prints how far the thorax travelled (horizontal distance
from its start) and its lowest height over the walk (the loop's from its timed runs, which read
the thorax anyway; the raw side's from one more, untimed, pass), and says
``same walk: yes`` when the distances agree within 5 % (or 5 mm) and the lowest heights within
10 %; ``SAME WALK: no`` makes the script exit 1.

Times: each side is run ``--repeats`` times and the best CPU time (``time.process_time``) and the
best wall time (``time.perf_counter``) are printed; targets are judged on CPU time, because the
engines step on one thread and CPU time does not grow with other work on a shared machine.

Targets (issue 3): MuJoCo real-time factor >= 20x, loop throughput >= 0.5x raw on every engine.

Usage::

    python benchmarks/locomotion_speed.py [--seconds 2.0] [--repeats 3] [--backends mujoco,dm_control,pybullet]
        [--gaits tripod,ripple,wave,ik]
    python benchmarks/locomotion_speed.py --seconds 0.8 --repeats 1 --gaits tripod   # quick look (~10 s)
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import functools  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav import registry  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.bodies.gaits import make_gait  # noqa: E402
from neuronav.spec.body import BodySpec  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

TIMESTEP_S = 0.002
PHYSICS_PER_CONTROL = 4
STRIDE_RAD = np.radians(15)
SENSORS = ("joint_pos", "joint_vel", "joint_torque", "contact_force", "body_pos", "body_quat", "heading")
SAME_DISTANCE_FRACTION, SAME_DISTANCE_FLOOR_M, SAME_HEIGHT_FRACTION = 0.05, 0.005, 0.10
TARGET_MUJOCO_RTF, TARGET_LOOP_OVER_RAW = 20.0, 0.5


@dataclass
class Side:
    """One side of the comparison: best CPU and wall seconds, and the walk an untimed pass did."""

    cpu_s: float
    wall_s: float
    walked_m: float  # the thorax's horizontal distance from its start at the end
    lowest_m: float  # the thorax's lowest height over the walk


def same_walk(loop: Side, raw: Side) -> bool:
    """Whether the raw side travelled as far as the loop and stayed as high (module docstring)."""
    distance_ok = abs(raw.walked_m - loop.walked_m) <= max(SAME_DISTANCE_FRACTION * abs(loop.walked_m),
                                                             SAME_DISTANCE_FLOOR_M)
    return distance_ok and abs(raw.lowest_m - loop.lowest_m) <= SAME_HEIGHT_FRACTION * loop.lowest_m


def best_times(run: Callable[[], object], repeats: int, prepare: Callable[[], object]) -> tuple[float, float]:
    """(best CPU s, best wall s) of ``repeats`` calls of ``run``, each after an untimed ``prepare()``."""
    cpu_s = wall_s = np.inf
    for _ in range(repeats):
        prepare()
        cpu, wall = time.process_time(), time.perf_counter()
        run()
        cpu_s, wall_s = min(cpu_s, time.process_time() - cpu), min(wall_s, time.perf_counter() - wall)
    return cpu_s, wall_s


def thorax_m(engine) -> np.ndarray:
    """The root segment's (thorax's) position (3,) m."""
    return engine.read(["body_pos"])["body_pos"][0].copy()


def walk_summary(start_m: np.ndarray, path_m: list[np.ndarray]) -> tuple[float, float]:
    """(horizontal distance from ``start_m`` at the end, lowest height) of a thorax path (T, 3)."""
    path = np.asarray(path_m)
    return float(np.hypot(*(path[-1, :2] - start_m[:2]))), float(path[:, 2].min())


def run_loop(engine, gait, controls: int, repeats: int) -> tuple[Side, list[np.ndarray]]:
    """Time the loop; return its side and the joint targets (J,) it wrote, one per control step."""
    walked: list[np.ndarray] = []
    path: list[np.ndarray] = []

    def restart() -> None:
        engine.reset(0)
        gait.reset()
        walked.clear()
        path.clear()

    def loop() -> None:
        for _ in range(controls):
            targets = gait.step(0.0, STRIDE_RAD)
            engine.write({"joint_targets": targets[None, :]})
            engine.step(PHYSICS_PER_CONTROL)
            path.append(engine.read(SENSORS)["body_pos"][0])  # read anyway: keeping it costs nothing
            walked.append(targets)

    engine.reset(0)
    start = thorax_m(engine)
    cpu_s, wall_s = best_times(loop, repeats, restart)
    return Side(cpu_s, wall_s, *walk_summary(start, path)), list(walked)


# -- raw replays: each advances the engine by one control step per iteration ---------------------------
def mujoco_replay(engine, targets: list[np.ndarray]) -> Iterator[None]:
    """Bare ``mj_step``: ``PHYSICS_PER_CONTROL`` per control step, the actuators holding its targets."""
    import mujoco

    model, data = engine.model, engine.data
    for step_targets in targets:
        data.ctrl[:] = step_targets
        for _ in range(PHYSICS_PER_CONTROL):
            mujoco.mj_step(model, data)
        yield


def dm_control_replay(engine, targets: list[np.ndarray]) -> Iterator[None]:
    """dm_control's ``Physics.step(PHYSICS_PER_CONTROL)`` per control step, the actuators holding its targets."""
    physics = engine.physics
    for step_targets in targets:
        physics.data.ctrl[:] = step_targets
        physics.step(PHYSICS_PER_CONTROL)
        yield


def _pybullet_handles(engine, body: BodySpec) -> tuple[object, int, int, list[int]]:
    """(pybullet module, client, body id, joint indices in the body's joint order) of a loaded backend."""
    import pybullet as pb

    client = engine.client_id
    robot = pb.getBodyUniqueId(0, physicsClientId=client)  # the backend creates the body first
    index = {pb.getJointInfo(robot, i, physicsClientId=client)[1].decode(): i
             for i in range(pb.getNumJoints(robot, physicsClientId=client))}
    return pb, client, robot, [index[joint.name] for joint in body.joints]


def pybullet_torques(engine, body: BodySpec, targets: list[np.ndarray]) -> list[list[list[float]]]:
    """The torques (per control step, per PyBullet step, (J,) N·m) the backend's control law applies
    along the walk, recorded by running that law here from the reset state (untimed)."""
    pb, client, robot, joints = _pybullet_handles(engine, body)
    kp = np.array([j.kp for j in body.joints])
    kd = np.array([j.kd for j in body.joints])
    limit = np.array([j.max_torque_nm for j in body.joints])
    engine.reset(0)
    recorded = []
    for step_targets in targets:
        block = []
        for _ in range(PHYSICS_PER_CONTROL * engine.substeps):
            q, qd, _, _ = zip(*pb.getJointStates(robot, joints, physicsClientId=client))
            torque = np.minimum(np.maximum(kp * (step_targets - np.array(q)) - kd * np.array(qd), -limit), limit)
            pb.setJointMotorControlArray(robot, joints, pb.TORQUE_CONTROL, forces=torque, physicsClientId=client)
            pb.stepSimulation(physicsClientId=client)
            block.append(torque.tolist())
        recorded.append(block)
    return recorded


def pybullet_replay(handles: tuple[object, int, int, list[int]], torques: list[list[list[float]]]) -> Iterator[None]:
    """``stepSimulation`` with the recorded torques: one torque command and one step per PyBullet step;
    ``handles`` from :func:`_pybullet_handles` (the ids survive a reset: the body is always created first)."""
    pb, client, robot, joints = handles
    command, step, mode = pb.setJointMotorControlArray, pb.stepSimulation, pb.TORQUE_CONTROL
    for block in torques:
        for forces in block:
            command(robot, joints, mode, forces=forces, physicsClientId=client)
            step(physicsClientId=client)
        yield


def run_raw(backend_name: str, engine, body: BodySpec, targets: list[np.ndarray], repeats: int) -> Side:
    """Time the engine alone replaying the loop's walk; trace the thorax in one more, untimed, pass."""
    if backend_name == "pybullet":
        replay = functools.partial(pybullet_replay, _pybullet_handles(engine, body),
                                   pybullet_torques(engine, body, targets))
    else:
        replay = functools.partial(dm_control_replay if backend_name == "dm_control" else mujoco_replay,
                                   engine, targets)
    if backend_name == "mujoco":
        import mujoco

        # After a bare mj_step the body poses lag one step behind the state: bring them up to it.
        def thorax_now_m() -> np.ndarray:
            mujoco.mj_kinematics(engine.model, engine.data)
            return thorax_m(engine)
    else:
        def thorax_now_m() -> np.ndarray:
            return thorax_m(engine)

    engine.reset(0)
    start = thorax_m(engine)
    path = [thorax_now_m() for _ in replay()]

    def timed() -> None:
        for _ in replay():
            pass

    return Side(*best_times(timed, repeats, lambda: engine.reset(0)), *walk_summary(start, path))


def compare(backend_name: str, gait_name: str, seconds: float, repeats: int) -> tuple[Side, Side, int]:
    """(loop side, raw side, physics steps simulated) of one backend and gait."""
    body = desert_ant()
    gait = make_gait(gait_name, body)
    controls = int(round(seconds / (TIMESTEP_S * PHYSICS_PER_CONTROL)))
    with registry.load("backend", backend_name)(timestep_s=TIMESTEP_S) as engine:
        engine.load(World(), [body])
        loop, targets = run_loop(engine, gait, controls, repeats)
        raw = run_raw(backend_name, engine, body, targets, repeats)
    return loop, raw, controls * PHYSICS_PER_CONTROL


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per measurement")
    parser.add_argument("--backends", default="mujoco,dm_control,pybullet")
    parser.add_argument("--gaits", default="tripod,ripple,wave,ik")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs")
    args = parser.parse_args(argv)
    if not (args.seconds >= 4 * TIMESTEP_S * PHYSICS_PER_CONTROL and args.repeats >= 1):
        parser.error(f"need --seconds >= {4 * TIMESTEP_S * PHYSICS_PER_CONTROL:g} and --repeats >= 1")
    print(f"locomotion loop on flat ground, {args.seconds:g} s simulated, physics {1000 * TIMESTEP_S:g} ms, "
          f"gait every {PHYSICS_PER_CONTROL} steps, one core; best of {args.repeats}: CPU (process_time) and wall s")
    print(f"{'backend':<10} {'gait':<7} {'loop cpu s':>10} {'wall s':>7} {'raw cpu s':>9} {'wall s':>7} "
          f"{'RTF cpu':>8} {'loop/raw cpu':>12} {'wall':>5}   {'walked m loop/raw':>17} {'lowest m loop/raw':>17}"
          f"  same walk")
    different, misses = [], []
    for backend in args.backends.split(","):
        ok, reason = registry.availability("backend", backend)
        if not ok:
            print(f"{backend:<10} not available: {reason}")
            continue
        for gait in args.gaits.split(","):
            loop, raw, steps = compare(backend, gait, args.seconds, args.repeats)
            real_time = steps * TIMESTEP_S / loop.cpu_s
            ratio = raw.cpu_s / loop.cpu_s
            same = same_walk(loop, raw)
            print(f"{backend:<10} {gait:<7} {loop.cpu_s:>10.3f} {loop.wall_s:>7.3f} {raw.cpu_s:>9.3f} "
                  f"{raw.wall_s:>7.3f} {real_time:>7.1f}x {ratio:>12.2f} {raw.wall_s / loop.wall_s:>5.2f}   "
                  f"{loop.walked_m:>8.3f}/{raw.walked_m:<8.3f} {loop.lowest_m:>8.3f}/{raw.lowest_m:<8.3f}  "
                  f"{'yes' if same else 'NO'}")
            if not same:
                different.append(f"{backend} {gait}")
            if ratio < TARGET_LOOP_OVER_RAW or (backend == "mujoco" and real_time < TARGET_MUJOCO_RTF):
                misses.append(f"{backend} {gait}")
    print(f"targets (on CPU time): MuJoCo real-time factor >= {TARGET_MUJOCO_RTF:g}x; loop >= "
          f"{TARGET_LOOP_OVER_RAW:g}x raw on every engine: {'MISSED by ' + ', '.join(misses) if misses else 'met'}")
    print(f"SAME WALK: {'no (' + ', '.join(different) + ')' if different else 'yes'}")
    return 1 if different else 0


if __name__ == "__main__":
    raise SystemExit(main())
