"""Benchmark: what the filament plume costs, alone and inside a plume-tracking trial.

On one core (run it under ``taskset -c 0``; BLAS is held to one thread), it prints:

- the wall time of one plume step (0.01 s of plume time: move, grow and drop puffs, step the wind,
  release) with 1000 live puffs (a source releasing 400 puffs/s, the 1000-puff cap reached), and with
  the scenario's default plume (60 puffs/s at 2 m/s: about 225 puffs), median of ``--steps`` steps;
- the wall time of one concentration query at two antenna tips (``Plume.concentration_at`` on a
  (1, 2, 3) array) and of the two sensor reads a brain makes (``backend.read(("odour", "wind"))``
  at an unchanged time, so no plume step is included), at both puff counts;
- the share of a plume-tracking trial on MuJoCo that the plume takes: one trial of ``--seconds``
  simulated seconds (odour on, seed 0) with the chemistry's ``advance_to``, ``odour_at`` and
  ``wind_at`` timed; the plume's time over the rest of the trial's loop is what it adds to a step
  (target: < 20 %); the warm-up at reset is reported apart;
- the kinematic batch: one ``backend.read(("odour",))`` for 1 and for 100 unicycle agents with the
  ant's antennae (``PointAgents(count=..., mode="unicycle", antennae=...)``), median wall time, and
  how many calls to ``Plume.concentration_at`` one read makes (1: all agents' tips in one array
  operation).

Usage::

    taskset -c 0 python benchmarks/plume_speed.py [--steps 2000] [--reads 500] [--seconds 30]
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

from neuronav import registry  # noqa: E402
from neuronav.bodies.antennae import point_antennae  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.scenarios.plume_tracking.scenario import PlumeTrackingConfig, plume_config, plume_trial  # noqa: E402
from neuronav.senses.chemistry import Chemistry, OdourScene  # noqa: E402
from neuronav.senses.plume import OdourSource, Plume, PlumeConfig  # noqa: E402
from neuronav.spec.world import PointAgents, World  # noqa: E402

DT_S = 0.01
TIPS_M = np.array([[[6.6, -0.2, 0.15], [6.6, 0.2, 0.15]]])  # (1 agent, 2 tips, xyz)


def busy_plume() -> Plume:
    """A plume holding its cap of 1000 puffs: 400 puffs/s in a 2 m/s wind, warmed up 10 s."""
    config = PlumeConfig(sources=(OdourSource(release_rate_hz=400.0),), max_puffs=1000)
    plume = Plume(config, seed=0)
    plume.advance(DT_S, 1000)
    return plume


def default_plume() -> Plume:
    """The scenario's plume, warmed up 10 s."""
    plume = Plume(plume_config(PlumeTrackingConfig()), seed=0)
    plume.advance(DT_S, 1000)
    return plume


def median_us(function, repeats: int) -> float:
    """Median wall microseconds of ``function()`` over ``repeats`` calls (after 10 unmeasured ones)."""
    for _ in range(10):
        function()
    times = np.empty(repeats)
    for k in range(repeats):
        started = time.perf_counter()
        function()
        times[k] = time.perf_counter() - started
    return float(np.median(times) * 1e6)


def plume_costs(steps: int, reads: int) -> None:
    for label, make in (("1000 puffs", busy_plume), ("default plume", default_plume)):
        plume = make()
        puffs = plume.n_puffs
        step_us = median_us(lambda p=plume: p.advance(DT_S, 1), steps)
        query_us = median_us(lambda p=plume: p.concentration_at(TIPS_M), reads)
        print(f"{label:>14} ({puffs:4d} puffs): step {step_us:7.1f} us   "
              f"concentration at 2 tips {query_us:6.1f} us", flush=True)
    # The same through a backend's sensor port (the brain's read), at an unchanged time.
    for label, config in (("1000 puffs", PlumeConfig(sources=(OdourSource(release_rate_hz=400.0),))),
                          ("default plume", plume_config(PlumeTrackingConfig()))):
        engine = registry.load("backend", "kinematic")(timestep_s=0.008)
        body = PointAgents(count=1, mode="unicycle", antennae=point_antennae(desert_ant()))
        engine.load(World(odour=OdourScene(plume=config, warmup_s=10.0)), [body])
        engine.reset(seed=0, position_m=(7.0, 0.0), yaw_rad=np.pi)
        read_us = median_us(lambda e=engine: e.read(("odour", "wind")), reads)
        print(f"{label:>14} ({engine.chemistry.plume.n_puffs:4d} puffs): backend.read(('odour', 'wind')) "
              f"{read_us:6.1f} us", flush=True)
        engine.close()


class _Timed:
    """Wraps Chemistry methods with wall-time counters (restored by :meth:`restore`)."""

    NAMES = ("advance_to", "odour_at", "wind_at", "reset")

    def __init__(self) -> None:
        self.seconds = dict.fromkeys(self.NAMES, 0.0)
        self._originals = {name: getattr(Chemistry, name) for name in self.NAMES}
        for name, original in self._originals.items():
            setattr(Chemistry, name, self._wrap(name, original))

    def _wrap(self, name, original):
        def timed(chemistry, *args, **kwargs):
            started = time.perf_counter()
            try:
                return original(chemistry, *args, **kwargs)
            finally:
                self.seconds[name] += time.perf_counter() - started
        return timed

    def restore(self) -> None:
        for name, original in self._originals.items():
            setattr(Chemistry, name, original)


def trial_share(seconds: float) -> None:
    # A 1 cm success radius: the trial runs its whole --seconds.
    config = PlumeTrackingConfig(timeout_s=seconds, success_radius_m=0.01)
    plume_trial(config, "mujoco", seed=0)  # warm the caches (compiled model, imports)
    timer = _Timed()
    try:
        started = time.perf_counter()
        row, _ = plume_trial(config, "mujoco", seed=0)
        wall = time.perf_counter() - started
    finally:
        timer.restore()
    plume_loop = timer.seconds["advance_to"] + timer.seconds["odour_at"] + timer.seconds["wind_at"]
    warmup = timer.seconds["reset"]
    rest = wall - plume_loop - warmup
    print(f"MuJoCo plume-tracking trial, {row['trial_time_s']:.0f} s simulated in {wall:.2f} s wall "
          f"({row['trial_time_s'] / wall:.1f}x real time):", flush=True)
    print(f"  plume during the loop {plume_loop * 1e3:7.1f} ms (advance {timer.seconds['advance_to'] * 1e3:.1f}, "
          f"odour {timer.seconds['odour_at'] * 1e3:.1f}, wind {timer.seconds['wind_at'] * 1e3:.1f}); "
          f"everything else {rest * 1e3:.0f} ms", flush=True)
    print(f"  the plume adds {100 * plume_loop / rest:.1f} % to the trial's step time (target < 20 %); "
          f"warm-up at reset {warmup * 1e3:.0f} ms (10 s of plume, once per trial)", flush=True)


def batch_read(reads: int) -> None:
    calls = {"n": 0}
    original = Plume.concentration_at

    def counted(plume, points):
        calls["n"] += 1
        return original(plume, points)

    results = {}
    for agents in (1, 100):
        engine = registry.load("backend", "kinematic")(timestep_s=0.008)
        body = PointAgents(count=agents, mode="unicycle", antennae=point_antennae(desert_ant()))
        engine.load(World(odour=OdourScene(plume=plume_config(PlumeTrackingConfig()), warmup_s=10.0)), [body])
        rng = np.random.default_rng(0)
        engine.reset(seed=0, position_m=np.column_stack([rng.uniform(1, 7, agents), rng.uniform(-1, 1, agents)]),
                     yaw_rad=rng.uniform(-np.pi, np.pi, agents))
        read_us = median_us(lambda e=engine: e.read(("odour",)), reads)
        Plume.concentration_at = counted
        try:
            calls["n"] = 0
            shape = engine.read(("odour",))["odour"].shape
        finally:
            Plume.concentration_at = original
        results[agents] = read_us
        print(f"kinematic, {agents:3d} agents: one read of 'odour' {shape} {read_us:7.1f} us "
              f"({read_us / agents:6.2f} us per agent), {calls['n']} call to Plume.concentration_at", flush=True)
        engine.close()
    print(f"100 agents cost {results[100] / results[1]:.2f}x one agent's read", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="plume steps timed")
    parser.add_argument("--reads", type=int, default=500, help="queries / reads timed")
    parser.add_argument("--seconds", type=float, default=30.0, help="simulated seconds of the MuJoCo trial")
    args = parser.parse_args()
    plume_costs(args.steps, args.reads)
    trial_share(args.seconds)
    batch_read(args.reads)


if __name__ == "__main__":
    main()
