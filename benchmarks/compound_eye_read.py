"""Benchmark: reading compound eyes: 1000 kinematic agents', and one ant's on MuJoCo and PyBullet (issue 24).

One read is ``backend.read(["compound_eye_L", "compound_eye_R"])`` on the kinematic backend: every agent's
two eyes (about 1290 ommatidia each at ``--scale`` 1, green and UV), 7 rays per ommatidium
(:class:`neuronav.senses.compound_eye_rays.CompoundEyeReader`), for ``--agents`` unicycle agents spread over
a 20 m square with random headings, in three scenes: ``open`` (no objects: the ground and sky come from a
table per eye height), ``beacon`` (the 6 m landmark 25 m away) and ``forest`` (40 trees 2 to 30 m
from the origin). Median over ``--reads`` reads, the agents stepped between reads (not timed).

Physics backends: one read is ``backend.read(["compound_eye_L", "compound_eye_R"])`` of the desert ant
(``desert_ant(compound_eyes=True, ommatidia_scale=--scale)``) standing at rest in the same three scenes, turned
0.1 rad between reads (not timed): each eye's cube faces rendered in the green-and-UV colouring (MuJoCo: one
scene update for the ground, the objects a face can show drawn in one GL call where they are several
(:mod:`neuronav.backends.mujoco.object_batch`), one buffer read for both eyes; then the forest's read with and
without that batch, in alternating rounds, for comparison; PyBullet: TinyRenderer
per face, of 12-sided copies of the objects it can show, a segmentation mask coloured per body, the flat floor
from rays) and one sparse product per eye
(:mod:`neuronav.senses.compound_eye_views`). Median over ``--physics-reads`` reads.

CPU time (``time.process_time``) next to wall time (``time.perf_counter``); the targets are judged on
CPU time (one thread: BLAS held to one; Mesa rasterises in the calling thread).

Targets (issue 24): 1000 kinematic agents' compound eyes at least 100 reads per second; a binocular read
(two eyes, about 1000 ommatidia each, two channels) at most 2 ms on MuJoCo and 4 ms on PyBullet.

Usage::

    python benchmarks/compound_eye_read.py [--reads 10] [--agents 1000] [--scale 1.0] [--physics-reads 20]
    python benchmarks/compound_eye_read.py --reads 2 --agents 20 --repeats 1   # quick look
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuronav import registry  # noqa: E402
from neuronav.backends.kinematic import KinematicBackend  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.bodies.desert_ant.body import point_agent_compound_eyes  # noqa: E402
from neuronav.scenarios.worlds.scenes import forest, landmark  # noqa: E402
from neuronav.spec.world import PointAgents, World  # noqa: E402

TARGET_READS_PER_S = 100.0
TARGET_PHYSICS_MS = {"mujoco": 2.0, "pybullet": 4.0}
EYES = ["compound_eye_L", "compound_eye_R"]


def scenes() -> dict[str, World]:
    return {"open": World(), "beacon": World(objects=(landmark(),)),
            "forest": World(objects=forest(40, seed=0, inner_radius_m=2.0, outer_radius_m=30.0))}


def measure(world: World, agents: int, reads: int, scale: float, repeats: int) -> tuple[float, float, int, int, int]:
    """Median CPU and wall ms of one read of both eyes of every agent, the ommatidia per eye, and the rays the
    last read intersected with objects and those that hit (both eyes)."""
    eyes = point_agent_compound_eyes(desert_ant(compound_eyes=True, ommatidia_scale=scale))
    backend = KinematicBackend(timestep_s=0.008)
    backend.load(world, [PointAgents(count=agents, mode="unicycle", compound_eyes=eyes)])
    rng = np.random.default_rng(0)
    backend.reset(heading_rad=rng.uniform(0, 2 * np.pi, agents), position_m=rng.uniform(-10, 10, (agents, 2)))
    backend.write({"turn": rng.uniform(-0.3, 0.3, (agents, 1)), "stride": np.full((agents, 1), 0.3)})
    backend.read(EYES)  # builds the readers and the ground-and-sky tables (not timed)
    cpu, wall = [], []
    for _ in range(repeats * reads):
        backend.step(5)
        c, w = time.process_time(), time.perf_counter()
        backend.read(EYES)
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    readers = backend._eye_readers.values()
    return (1e3 * float(np.median(cpu)), 1e3 * float(np.median(wall)), eyes[0].n_ommatidia,
            sum(r.rays_tested for r in readers), sum(r.rays_hit for r in readers))


def measure_physics(engine: str, world: World, reads: int, scale: float) -> tuple[float, float, int]:
    """Median CPU and wall ms of one binocular read of the ant standing in ``world`` on ``engine``."""
    body = desert_ant(compound_eyes=True, ommatidia_scale=scale)
    backend = registry.load("backend", engine)(timestep_s=0.002)
    cpu, wall = [], []
    with backend:
        backend.load(world, [body])
        backend.read(EYES)  # the eyes' sampling matrices, the render client or context (not timed)
        for k in range(reads):
            backend.reset(seed=0, yaw_rad=0.1 * k)
            c, w = time.process_time(), time.perf_counter()
            backend.read(EYES)
            cpu.append(time.process_time() - c)
            wall.append(time.perf_counter() - w)
    return 1e3 * float(np.median(cpu)), 1e3 * float(np.median(wall)), body.compound_eyes[0].n_ommatidia


PHYSICS_REASONS = {
    "mujoco": "Mesa's llvmpipe draws each tree in every face that shows it (the eyes' batch of a face's objects in"
              " one GL call, ~0.1 us a triangle at the eyes' 12 x 6 tessellation, after each face's cull by bounding"
              " sphere and box), besides ten faces of ground and the read's numpy steps",
    "pybullet": "TinyRenderer draws each tree in every face that shows it (one getCameraImage call per face, 10 per"
                " read; 12-sided copies of the objects, culled per face by bounding sphere; the flat floor from rays)",
}


def batch_comparison(world: World, reads: int, scale: float, rounds: int = 6) -> tuple[float, float, float]:
    """MuJoCo's binocular read in ``world`` with the eyes' own batch of objects (one GL call per face that shows
    several, :mod:`neuronav.backends.mujoco.object_batch`) and with every geom drawn by MuJoCo, as before it: two
    backends read in alternating rounds of ``reads`` (the machine's speed drifts by tens of percent over a
    minute). Returns the median CPU ms of each and the median of the rounds' ratios (batch / every geom)."""
    from neuronav.backends.mujoco.backend import _FlatRenderer

    backends, medians = {}, {True: [], False: []}
    try:
        for batched in (True, False):
            _FlatRenderer.batches_objects = batched
            backends[batched] = registry.load("backend", "mujoco")(timestep_s=0.002)
            backends[batched].load(world, [desert_ant(compound_eyes=True, ommatidia_scale=scale)])
            backends[batched].read(EYES)
        for round_ in range(rounds):
            for batched in ((True, False) if round_ % 2 == 0 else (False, True)):
                _FlatRenderer.batches_objects = batched
                cpu = []
                for k in range(reads):
                    backends[batched].reset(seed=0, yaw_rad=0.1 * k)
                    start = time.process_time()
                    backends[batched].read(EYES)
                    cpu.append(time.process_time() - start)
                medians[batched].append(1e3 * float(np.median(cpu)))
    finally:
        _FlatRenderer.batches_objects = True
        for backend in backends.values():
            backend.close()
    ratios = np.array(medians[True]) / np.array(medians[False])
    return float(np.median(medians[True])), float(np.median(medians[False])), float(np.median(ratios))


def physics_section(reads: int, scale: float) -> None:
    print(f"\nphysics backends, the ant's two compound eyes at rest, turned between reads; median of {reads} reads")
    print(f"{'backend':9s} {'scene':8s} {'ommatidia/eye':>13s} {'cpu ms/read':>12s} {'wall ms/read':>13s}")
    results = {}
    for engine in TARGET_PHYSICS_MS:
        for name, world in scenes().items():
            cpu_ms, wall_ms, per_eye = measure_physics(engine, world, reads, scale)
            results[engine, name] = cpu_ms
            print(f"{engine:9s} {name:8s} {per_eye:13d} {cpu_ms:12.2f} {wall_ms:13.2f}")
    batch_ms, each_ms, ratio = batch_comparison(scenes()["forest"], reads, scale)
    print(f"mujoco forest, the eyes' batch against every geom drawn by MuJoCo (as before it), alternating: "
          f"{batch_ms:.2f} against {each_ms:.2f} cpu ms/read, paired ratio {ratio:.2f}")
    for (engine, name), cpu_ms in results.items():
        target = TARGET_PHYSICS_MS[engine]
        verdict = "met" if cpu_ms <= target and scale >= 0.75 else "MISSED"
        reason = ""
        if scale < 0.75:
            reason = f" (ommatidia_scale {scale}: the target is for about 1000 ommatidia per eye)"
        elif verdict == "MISSED":
            extra = cpu_ms - results[engine, "open"]
            reason = (f" ({PHYSICS_REASONS[engine]}: {extra:.2f} ms on top of the open world's "
                      f"{results[engine, 'open']:.2f} ms)")
        print(f"target <= {target:.0f} ms per binocular read on {engine}, {name}: {verdict} on CPU "
              f"({cpu_ms:.2f} ms){reason}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reads", type=int, default=10)
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--scale", type=float, default=1.0, help="ommatidia_scale of each eye")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--physics-reads", type=int, default=20, help="binocular reads per scene on MuJoCo and "
                        "PyBullet (0: skip them)")
    args = parser.parse_args(argv)
    print(f"kinematic backend, {args.agents} agents, two compound eyes each, 7 rays per ommatidium; "
          f"median of {args.reads * args.repeats} reads")
    print(f"{'scene':8s} {'ommatidia/eye':>13s} {'cpu ms/read':>12s} {'wall ms/read':>13s} {'reads/s (cpu)':>14s}")
    results, rays = {}, {}
    for name, world in scenes().items():
        cpu_ms, wall_ms, per_eye, tested, hit = measure(world, args.agents, args.reads, args.scale, args.repeats)
        results[name], rays[name] = cpu_ms, (tested, hit)
        print(f"{name:8s} {per_eye:13d} {cpu_ms:12.2f} {wall_ms:13.2f} {1e3 / cpu_ms:14.1f}")
        print(f"         rays intersected with objects per read: {tested:,} of {2 * 7 * per_eye * args.agents:,}"
              f" ({hit:,} hits)")
    for name, cpu_ms in results.items():
        rate = 1e3 / cpu_ms
        verdict = "met" if rate >= TARGET_READS_PER_S and args.agents >= 1000 else "MISSED"
        reason = ""
        if args.agents < 1000:
            reason = f" (only {args.agents} agents: the target is for 1000)"
        elif verdict == "MISSED":
            extra = cpu_ms - results["open"]
            reason = (f" (the output alone, 41 MB of float64 for 1000 agents' two eyes written into fresh memory, is"
                      f" the open world's read: {results['open']:.2f} ms of the {1e3 / TARGET_READS_PER_S:.0f} ms;"
                      f" objects add {extra:.1f} ms of numpy steps on the rays inside each upright object's azimuth"
                      f" wedge and elevation band ({rays[name][0]:,}: intersection, then the nearest hit merged),"
                      f" {1e3 * extra / max(rays[name][0], 1):.2f} us per ray)")
        print(f"target >= {TARGET_READS_PER_S:.0f} reads/s for 1000 agents, {name}: {verdict} on CPU "
              f"({rate:.1f} reads/s){reason}")
    if args.physics_reads > 0:
        physics_section(args.physics_reads, args.scale)
    return 0


if __name__ == "__main__":
    sys.exit(main())
