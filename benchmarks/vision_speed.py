"""Benchmark: how fast each backend's eyes see, and what vision costs a visual-beacon trial.

On one core (Mesa's software rasteriser rasterising in the calling thread with ``LP_NUM_THREADS=0``,
the MuJoCo backend's default, see :mod:`neuronav.backends.mujoco.gl_contexts`; run it under
``taskset -c 0`` to pin the process too), in the visual compass scene (five objects, plain
ground, sky gradient), the ant standing at rest:

- per backend (kinematic unicycle, MuJoCo, PyBullet): milliseconds (and frames per second) per binocular pair
  (``eye_L`` + ``eye_R``, 74×19 each) and per panorama (72×72, the whole sphere, 4 × 4 rays per
  pixel), each frame read
  through the sensor port (render, compose, grey), median of ``--frames`` reads, the body turned a
  little between reads so nothing is cached;
- the kinematic backend's batch: panoramas and binocular pairs per second for 1000 agents read at once;
- the real-time factor (simulated seconds per wall second) of one visual-beacon trial of
  ``--seconds`` simulated seconds, binocular, 40 trees, per backend;
- rendering that does not grow with the world (issue 24), MuJoCo and PyBullet: the binocular read in the
  empty world (the visual-beacon ground, no object) and in the 40-tree beacon forest (``trees=40``, seed 2),
  median of ``--frames`` reads with the ant turned 6° between reads, and their ratio;
- MuJoCo's per-trial GL cost: the first binocular read of a new backend (its eyes' GL context and
  ``MjrContext`` made) in a process that has rendered before, median of ``--trials`` backends, as it was
  (a new context per backend, MuJoCo's default 4096 px shadow map) and as it is (the process's kept
  context, no shadow map: :mod:`neuronav.backends.mujoco.gl_contexts`).

Every figure is given in CPU time (``time.process_time``: this process, all its threads) next to
wall time (``time.perf_counter``); the targets are judged on CPU time, because the work runs on one
thread (BLAS and Mesa held to one) and CPU time, unlike wall time, does not grow when other jobs
share the machine. The beacon trial's real-time factors are simulated seconds over the seconds
of the whole ``beacon_trial`` call (building the world and loading it included, as the scenario's
own ``real_time_factor`` includes loading).

Targets (issue 11): the MuJoCo panorama <= 10 ms (45 ms before); visual-beacon real-time factor
>= 10x on MuJoCo and >= 3x on PyBullet. Issue 24: a binocular read in the 40-tree forest <= 1.5x the
empty world, on MuJoCo and PyBullet. The compound-eye read targets of issue 24 (2 ms MuJoCo, 4 ms
PyBullet, 100 reads/s for 1000 kinematic agents) are judged by ``benchmarks/compound_eye_read.py``.

Usage::

    taskset -c 0 python benchmarks/vision_speed.py [--frames 50] [--seconds 20] [--backends kinematic,mujoco,pybullet]
    python benchmarks/vision_speed.py --frames 3 --seconds 0.5 --agents 20 --backends kinematic   # quick look
    taskset -c 0 python benchmarks/vision_speed.py --backends mujoco,pybullet --no-cull   # every object drawn
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"
os.environ.setdefault("LP_NUM_THREADS", "0")
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav import registry  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig, beacon_trial, beacon_world  # noqa: E402
from neuronav.scenarios.visual_setup import point_agent_cameras  # noqa: E402
from neuronav.scenarios.worlds.scenes import compass_scene  # noqa: E402
from neuronav.spec.world import PointAgents  # noqa: E402


def _engine(name: str, agents: int = 1):
    engine = registry.load("backend", name)(timestep_s=0.008 if name == "kinematic" else 0.002)
    body = PointAgents(count=agents, mode="unicycle", cameras=point_agent_cameras(desert_ant())) \
        if name == "kinematic" else desert_ant()
    engine.load(compass_scene(), [body])
    return engine


def frame_ms(name: str, cameras: tuple[str, ...], frames: int) -> tuple[float, float]:
    """Median (wall, CPU) milliseconds to read ``cameras`` once, the body turned by 1° between reads."""
    wall, cpu = [], []
    with _engine(name) as engine:
        for k in range(frames):
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=np.radians(k))
            started_wall, started_cpu = time.perf_counter(), time.process_time()
            engine.read(cameras)
            wall.append(time.perf_counter() - started_wall)
            cpu.append(time.process_time() - started_cpu)
    return 1e3 * float(np.median(wall)), 1e3 * float(np.median(cpu))


def batch_rate(cameras: tuple[str, ...], agents: int, repeats: int = 3) -> tuple[float, float]:
    """Frames (of ``cameras`` together) per (wall, CPU) second for ``agents`` kinematic agents read at
    once; best of ``repeats``."""
    with _engine("kinematic", agents) as engine:
        engine.reset(seed=0, heading_rad=np.linspace(0.0, 2 * np.pi, agents, endpoint=False))
        wall_s = cpu_s = np.inf
        for _ in range(repeats):
            started_wall, started_cpu = time.perf_counter(), time.process_time()
            engine.read(cameras)
            wall_s = min(wall_s, time.perf_counter() - started_wall)
            cpu_s = min(cpu_s, time.process_time() - started_cpu)
    return agents / wall_s, agents / cpu_s


def beacon_real_time_factor(name: str, seconds: float) -> tuple[float, float]:
    """Simulated seconds per (wall, CPU) second of one visual-beacon trial, set-up included."""
    config = VisualBeaconConfig(eye="both", timeout_s=seconds, trees=40)
    started_wall, started_cpu = time.perf_counter(), time.process_time()
    row, _ = beacon_trial(config, name, seed=2)
    wall_s, cpu_s = time.perf_counter() - started_wall, time.process_time() - started_cpu
    return row["trial_time_s"] / wall_s, row["trial_time_s"] / cpu_s


# The forest of issue 24's target: the visual-beacon world of 40 trees (seed 2), and the same world emptied.
FOREST_TREES, FOREST_SEED = 40, 2
# Issue 24: a binocular read in the forest costs at most this many times the empty world's.
FOREST_RATIO_TARGET = 1.5
# Why the forest's read still costs more than the target: the eyes already leave out every object outside their
# frustum (bounding sphere and box), images unchanged; what remains is drawing the trees they face.
WHY_THE_FOREST_COSTS = {
    "mujoco": "Mesa's software rasteriser draws each tree an eye faces at MuJoCo's full tessellation (28 slices x"
              " 16 stacks per sphere and cylinder), which the cameras keep: the compound eyes' 12 x 6 made this"
              " ratio about 3x, but changed the scenarios' camera images and what the ants do",
    "pybullet": "TinyRenderer transforms and rasterises every triangle of the trees an eye faces",
}


def forest_and_empty():
    """The 40-tree beacon forest and the same world without any object (ground, sky and look kept)."""
    forest = beacon_world(VisualBeaconConfig(eye="both", trees=FOREST_TREES), FOREST_SEED)
    return forest, dataclasses.replace(forest, objects=())


def binocular_ms(name: str, world, frames: int) -> tuple[float, float]:
    """Median (wall, CPU) milliseconds of a binocular read in ``world``, the ant turned 6° between reads."""
    wall, cpu = [], []
    with registry.load("backend", name)(timestep_s=0.002) as engine:
        engine.load(world, [desert_ant()])
        engine.reset(seed=0)
        engine.read(("eye_L", "eye_R"))  # renderers made before timing
        for k in range(frames):
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=np.radians(6.0 * k))
            started_wall, started_cpu = time.perf_counter(), time.process_time()
            engine.read(("eye_L", "eye_R"))
            wall.append(time.perf_counter() - started_wall)
            cpu.append(time.process_time() - started_cpu)
    return 1e3 * float(np.median(wall)), 1e3 * float(np.median(cpu))


def first_read_ms(world, trials: int, kept: bool) -> tuple[float, float]:
    """Median (wall, CPU) milliseconds of a new MuJoCo backend's first binocular read over ``trials``
    backends (one per trial), with the process's GL context kept across them and no shadow map
    (``kept``), or as before: a context made per backend with MuJoCo's default shadow map."""
    from neuronav.backends.mujoco import backend as mujoco_backend
    from neuronav.backends.mujoco import gl_contexts

    saved = gl_contexts.KEPT_PER_SIZE, mujoco_backend.EYE_SHADOW_PX
    if not kept:
        gl_contexts.KEPT_PER_SIZE, mujoco_backend.EYE_SHADOW_PX = 0, 4096  # MuJoCo's default shadowsize
        gl_contexts.free_kept()  # none kept: every backend makes its own
    wall, cpu = [], []
    try:
        for _ in range(trials):
            with registry.load("backend", "mujoco")(timestep_s=0.002) as engine:
                engine.load(world, [desert_ant()])
                engine.reset(seed=0)
                started_wall, started_cpu = time.perf_counter(), time.process_time()
                engine.read(("eye_L", "eye_R"))
                wall.append(time.perf_counter() - started_wall)
                cpu.append(time.process_time() - started_cpu)
    finally:
        gl_contexts.KEPT_PER_SIZE, mujoco_backend.EYE_SHADOW_PX = saved
    return 1e3 * float(np.median(wall)), 1e3 * float(np.median(cpu))


def draw_everything(names: list[str]) -> None:
    """Turn off the eyes' frustum culling on MuJoCo and PyBullet (every object drawn in every view)."""
    if "mujoco" in names:
        from neuronav.backends.mujoco import backend as mujoco_backend

        mujoco_backend._FlatRenderer._visible = lambda self, model, data, views: np.ones(
            (len(views), self._cullable.size), dtype=bool)
    if "pybullet" in names:
        from neuronav.backends.pybullet import camera as pybullet_camera

        pybullet_camera.ObjectCulling.only_for = lambda self, view: None
    print("culling off: every world object drawn in every view")


def rendering_growth(names: list[str], frames: int, trials: int) -> list[tuple[str, bool]]:
    """Print the empty-world and forest binocular reads per backend and MuJoCo's per-trial GL cost;
    return the issue-24 verdicts."""
    forest, empty = forest_and_empty()
    verdicts = []
    print(f"\nbinocular read, empty world vs {FOREST_TREES}-tree forest (median ms, CPU time and wall)")
    print(f"{'backend':<10} {'empty cpu':>9} {'wall':>6} {'forest cpu':>10} {'wall':>6} {'ratio cpu':>9}")
    for name in names:
        if name not in ("mujoco", "pybullet"):
            continue
        empty_wall, empty_cpu = binocular_ms(name, empty, frames)
        forest_wall, forest_cpu = binocular_ms(name, forest, frames)
        ratio = forest_cpu / empty_cpu
        print(f"{name:<10} {empty_cpu:>9.2f} {empty_wall:>6.2f} {forest_cpu:>10.2f} {forest_wall:>6.2f} {ratio:>8.2f}x")
        met = ratio <= FOREST_RATIO_TARGET
        verdicts.append((f"{'MuJoCo' if name == 'mujoco' else 'PyBullet'} forest <= {FOREST_RATIO_TARGET:g}x "
                         f"empty ({ratio:.2f}x)" + ("" if met else f" [{WHY_THE_FOREST_COSTS[name]}]"), met))
    if "mujoco" in names:
        before_wall, before_cpu = first_read_ms(forest, trials, kept=False)
        after_wall, after_cpu = first_read_ms(forest, trials, kept=True)
        print(f"MuJoCo per-trial GL cost (first binocular read of a new backend, median of {trials}): "
              f"before {before_cpu:.1f} ms CPU ({before_wall:.1f} wall), now {after_cpu:.1f} ms CPU "
              f"({after_wall:.1f} wall): {before_cpu - after_cpu:.1f} ms CPU saved per trial")
    return verdicts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--backends", default="kinematic,mujoco,pybullet")
    parser.add_argument("--trials", type=int, default=5, help="new backends timed for the per-trial GL cost")
    parser.add_argument("--no-cull", action="store_true",
                        help="draw every world object in every view (the eyes before issue 24), for comparison")
    args = parser.parse_args(argv)
    names = [n for n in args.backends.split(",") if n]
    if args.no_cull:
        draw_everything(names)
    print("median per read (ms) and real-time factor, CPU time (process_time) and wall time")
    print(f"{'backend':<10} {'eye pair ms cpu':>15} {'wall':>6} {'pairs/s cpu':>11} {'panorama ms cpu':>15} "
          f"{'wall':>6} {'panoramas/s cpu':>15} {'beacon RTF cpu':>14} {'wall':>6}")
    verdicts, available = [], []
    for name in names:
        try:
            registry.load("backend", name)
        except Exception as error:  # noqa: BLE001 -- a backend that is not installed is reported, not fatal
            print(f"{name:<10} not available: {error}")
            continue
        available.append(name)
        pair_wall, pair_cpu = frame_ms(name, ("eye_L", "eye_R"), args.frames)
        pano_wall, pano_cpu = frame_ms(name, ("panorama",), args.frames)
        rtf_wall, rtf_cpu = beacon_real_time_factor(name, args.seconds)
        print(f"{name:<10} {pair_cpu:>15.2f} {pair_wall:>6.2f} {1e3 / pair_cpu:>11.0f} {pano_cpu:>15.2f} "
              f"{pano_wall:>6.2f} {1e3 / pano_cpu:>15.0f} {rtf_cpu:>13.1f}x {rtf_wall:>5.1f}x")
        if name == "mujoco":
            verdicts += [("MuJoCo panorama <= 10 ms", pano_cpu <= 10.0), ("MuJoCo beacon >= 10x", rtf_cpu >= 10.0)]
        if name == "pybullet":
            verdicts.append(("PyBullet beacon >= 3x", rtf_cpu >= 3.0))
    if "kinematic" in names:
        pano_wall, pano_cpu = batch_rate(("panorama",), args.agents)
        pair_wall, pair_cpu = batch_rate(("eye_L", "eye_R"), args.agents)
        print(f"kinematic batch of {args.agents}: {pano_cpu:,.0f} panoramas per CPU s ({pano_wall:,.0f} per wall s), "
              f"{pair_cpu:,.0f} binocular pairs per CPU s ({pair_wall:,.0f} per wall s)")
    verdicts += rendering_growth([n for n in names if n in available], args.frames, args.trials)
    for label, met in verdicts:
        print(f"target (on CPU time) {label}: {'met' if met else 'MISSED'}")
    return 0

if __name__ == "__main__":
    raise SystemExit(main())
