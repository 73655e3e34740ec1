"""Benchmark: both eyes read together against one eye at a time, on MuJoCo (issue 24: "Render both eyes ...
in one scene update").

``backend.read(["eye_L", "eye_R"])`` renders both eyes' views in one call: one read of the offscreen buffer,
and one scene update for the views that face the same objects (both eyes in the open world; in a forest
each eye gets the scene of the trees it faces, cheaper to draw than all of them in both). Two reads of one
eye each (``read(["eye_L"])``, then ``read(["eye_R"])``) are what a binocular read cost before. The images
are the same (``tests/unit/test_binocular_one_pass.py``).

The desert ant in two worlds: ``open`` (no objects) and ``forest`` (the visual-beacon world with 40 trees);
``--reads`` reads per repeat with one physics step between reads (the step's cost is measured alone and
taken off), best of ``--repeats``. CPU time (``time.process_time``) next to wall time.

Usage::

    taskset -c 0 python benchmarks/binocular_read.py [--reads 100] [--repeats 5]
    python benchmarks/binocular_read.py --reads 3 --repeats 1   # quick look
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

from neuronav import registry  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig, beacon_world  # noqa: E402
from neuronav.scenarios.worlds.scenes import vision_appearance  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

EYES = ("eye_L", "eye_R")


def timed(step, reads: int, repeats: int) -> tuple[float, float]:
    """Best (CPU, wall) ms per call of ``step`` over ``repeats`` runs of ``reads`` calls."""
    best_cpu, best_wall = float("inf"), float("inf")
    for _ in range(repeats):
        cpu, wall = time.process_time(), time.perf_counter()
        for _ in range(reads):
            step()
        best_cpu = min(best_cpu, (time.process_time() - cpu) / reads * 1e3)
        best_wall = min(best_wall, (time.perf_counter() - wall) / reads * 1e3)
    return best_cpu, best_wall


def measure(world: World, reads: int, repeats: int) -> dict[str, tuple[float, float]]:
    """CPU and wall ms of a binocular read, together and one eye at a time, in ``world`` (the step's cost off)."""
    engine = registry.load("backend", "mujoco")()
    with engine:
        engine.load(world, [desert_ant()])
        engine.reset(seed=0)
        engine.read(list(EYES))  # the renderer made, not timed
        step = timed(lambda: engine.step(1), reads, repeats)
        together = timed(lambda: (engine.step(1), engine.read(list(EYES))), reads, repeats)
        alone = timed(lambda: (engine.step(1), [engine.read([eye]) for eye in EYES]), reads, repeats)
    return {"together": tuple(t - s for t, s in zip(together, step)),
            "one eye at a time": tuple(a - s for a, s in zip(alone, step))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reads", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    worlds = {"open": World(appearance=vision_appearance()),
              "forest": beacon_world(VisualBeaconConfig(eye="both", trees=40), 2)}
    print(f"MuJoCo binocular read (ms per read, best of {args.repeats} x {args.reads} reads, a physics step's "
          "cost taken off)")
    print(f"{'world':8} {'how':18} {'cpu':>7} {'wall':>7}")
    for name, world in worlds.items():
        rows = measure(world, args.reads, args.repeats)
        for how, (cpu, wall) in rows.items():
            print(f"{name:8} {how:18} {cpu:7.3f} {wall:7.3f}")
        saved = 1.0 - rows["together"][0] / rows["one eye at a time"][0]
        print(f"{name:8} together saves {saved:.0%} of the CPU time of one eye at a time")


if __name__ == "__main__":
    main()
