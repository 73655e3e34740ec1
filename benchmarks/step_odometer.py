"""Benchmark: what the step odometer adds to a MuJoCo homing step, and what its sampling and changed legs do.

(a) Overhead, in the configuration path integration uses (``odometry=steps`` on MuJoCo,
``scenarios/path_integration/embodied.py``): the desert ant in an
:class:`neuronav.engine.loop.AgentLoop` (physics 2 ms, control 8 ms, brain 0.64 s) walking the FK tripod
on flat ground, reading its ``position`` every control step as the homing loop's arrival check does,
with and without the :class:`neuronav.scenarios.path_integration.inputs.LegOdometer` hook (which reads
``joint_pos`` and ``contact_load`` every ``sample_every`` control steps into a buffer, which each take
runs through a :class:`neuronav.bodies.step_odometer.StepOdometer` at once). The brain is left out (the
denominator is the smaller one and every ratio an upper bound) but its take, once per 80 control steps,
is made. The loops walk the same walk, interleaved (``--repeats`` times each, the order rotated);
the best CPU (``time.process_time``) and wall time per control step of each is printed, and the
overhead in % for each ``sample_every`` of ``--every``; beside it, the CPU time of the hook's two parts
(the reads, the updates) clocked around each call in walks of their own (on a shared machine the
difference of two loops carries the noise of both; the clocked time does not see what the hook costs
the loop around it, cache misses for one). ``contact_load`` is the legs' load in the last physics step,
which MuJoCo's contact sensors compute within the step; ``contact_force`` (the current state's forces)
would solve the constraints once more on MuJoCo (``mj_forwardSkip``, see ``backends/mujoco/backend.py``)
and cost more than the odometer's own work. Target (issue 23): the odometer adds under
5 % to a MuJoCo homing step, judged on the loops' CPU time at the hook's default ``sample_every``
(``LEG_ODOMETER_SAMPLE_EVERY``): the verdict line says "met" or "MISSED".

(c) ``--sampling``: what the sampling period does to the reading. On each backend, for each turn command
of ``--turns``, one cycle of start-up and then ``--cycles`` gait cycles, one walk with a ``LegOdometer``
hook for each ``sample_every`` of ``--every`` (the hooks only read, so all see the same walk). Printed per
``sample_every``: the odometer ratio as path integration computes it (the length of the displacements
the CX takes each gait cycle over the true displacement per cycle, summed), its change from
``sample_every`` = 1 in % of the true distance, the end-point error of the odometer's path (each cycle's
displacement turned into the world by the true heading) in % of the distance, the integrated turn, and
the strides the reference leg marked (count and mean). A ``sample_every`` keeps the reading when the
ratio changes by < 1 % of the distance on every row.

(b) ``--manipulations``: for each backend and each leg manipulation of
:mod:`neuronav.bodies.desert_ant.manipulations` (normal, stilts, stumps), one cycle of start-up,
then ``--cycles`` gait cycles walked straight (stride 15°); prints the true distance per cycle
(the root's horizontal displacement), what the odometer believing the normal body reads per cycle,
their ratio, and the mean of its recorded strides. ``--distal-stilts`` adds a row ``distal``: stilts
made by lengthening the distal segment only (tarsus × 2, the standing height scaled with the leg length).

Usage::

    python benchmarks/step_odometer.py [--seconds 4] [--repeats 5] [--every 1,2,4,8]
    python benchmarks/step_odometer.py --sampling [--cycles 6] [--turns 0,0.3] [--backends mujoco,pybullet]
    python benchmarks/step_odometer.py --manipulations [--cycles 6] [--backends mujoco,pybullet] [--distal-stilts]
    python benchmarks/step_odometer.py --seconds 0.5 --repeats 1 --every 1   # quick look (~5 s)
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
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.bodies.desert_ant.body import STANDING_HEIGHT_M  # noqa: E402
from neuronav.bodies.desert_ant.manipulations import MANIPULATIONS, leg_length_ratio, manipulated_ant  # noqa: E402
from neuronav.bodies.gaits import make_gait  # noqa: E402
from neuronav.bodies.step_odometer import StepOdometer  # noqa: E402
from neuronav.config import build_config  # noqa: E402
from neuronav.engine.loop import AgentLoop, Clocks, Hook  # noqa: E402
from neuronav.scenarios.path_integration.embodied import CONTROL_S, embodied_trial  # noqa: E402
from neuronav.scenarios.path_integration.inputs import LEG_ODOMETER_SAMPLE_EVERY, LegOdometer  # noqa: E402
from neuronav.scenarios.path_integration.scenario import PathIntegrationConfig  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

TIMESTEP_S = 0.002
PHYSICS_PER_CONTROL = 4
CYCLE_STEPS = 80  # the FK tripod's cycle: 80 control steps of 8 ms
STRIDE_RAD = np.radians(15.0)
# What the embodied homing loop reads each control step without an odometer (scenarios/path_integration:
# its brain's heading, position and velocity), and what the step odometer adds.
HOMING_SENSORS = ("heading", "position", "velocity")
ODOMETER_SENSORS = LegOdometer.SENSORS  # joint_pos, contact_load
TARGET_OVERHEAD = 0.05


def walk(engine, gait, odometer: StepOdometer | None, controls: int, odometer_reads: bool = True,
         every: int = 1) -> None:
    """``controls`` control steps of the homing-like loop: gait, physics, the homing reads; then, every
    ``every`` control steps, the odometer's reads (``odometer_reads``) and its update (``odometer`` not None)."""
    for step in range(controls):
        engine.write({"joint_targets": gait.step(0.0, STRIDE_RAD)[None, :]})
        engine.step(PHYSICS_PER_CONTROL)
        engine.read(HOMING_SENSORS)
        if odometer_reads and step % every == 0:
            sensed = engine.read(ODOMETER_SENSORS)
            if odometer is not None:
                odometer.update(sensed["joint_pos"][0], sensed["contact_load"][0])


class ClockedLegOdometer(LegOdometer):
    """The hook, with the CPU time of its reads (and buffering) and of its updates (the flush of each
    take) clocked around each call."""

    def __init__(self, believed_body, sample_every: int = 1) -> None:
        super().__init__(believed_body, sample_every)
        self.reads_s = self.update_s = 0.0

    def after_step(self, loop: AgentLoop) -> None:
        started = time.process_time()
        super().after_step(loop)
        self.reads_s += time.process_time() - started

    def flush(self) -> None:
        started = time.process_time()
        super().flush()
        self.update_s += time.process_time() - started


def homing_walk(loop: AgentLoop, controls: int, hook: LegOdometer | None = None) -> None:
    """``controls`` control steps of the homing loop: the loop's step (gait, physics, hooks) and the
    arrival check's ``position`` read; every gait cycle (the brain's period) the CX takes the odometer's
    displacement (``hook.take()``), as the homing brain does."""
    for step in range(1, controls + 1):
        loop.step()
        loop.backend.read(("position",))
        if hook is not None and step % CYCLE_STEPS == 0:
            hook.take()


def overhead(seconds: float, repeats: int, everies: list[int]) -> bool:
    """Time part (a); True when the target is met at the hook's default ``sample_every``."""
    body = desert_ant()
    controls = int(round(seconds / (TIMESTEP_S * PHYSICS_PER_CONTROL)))
    clocks = Clocks(physics_dt_s=TIMESTEP_S, control_dt_s=TIMESTEP_S * PHYSICS_PER_CONTROL,
                    brain_dt_s=TIMESTEP_S * PHYSICS_PER_CONTROL * CYCLE_STEPS)
    default = LEG_ODOMETER_SAMPLE_EVERY
    everies = sorted(set(everies) | {default})
    sides = [None, *everies]  # None: the homing step without the odometer
    best = {side: [np.inf, np.inf] for side in sides}
    clocked = {side: [np.inf, np.inf] for side in everies}  # the hook's reads and update, clocked in it
    with registry.load("backend", "mujoco")(timestep_s=TIMESTEP_S) as engine:
        engine.load(World(), [body])
        gait = make_gait("tripod", body)
        for repeat in range(repeats):
            shift = repeat % len(sides)
            for side in sides[shift:] + sides[:shift]:  # rotate the order
                hook = None if side is None else LegOdometer(body, sample_every=side)
                loop = AgentLoop(engine, gait, clocks, hooks=[] if hook is None else [hook], stride_rad=STRIDE_RAD)
                loop.reset(seed=0)
                cpu, wall = time.process_time(), time.perf_counter()
                homing_walk(loop, controls, hook)
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
                best[side] = [min(best[side][0], cpu), min(best[side][1], wall)]
            for side in everies:  # the breakdown, in walks of their own (clocking costs time itself)
                hook = ClockedLegOdometer(body, sample_every=side)
                loop = AgentLoop(engine, gait, clocks, hooks=[hook], stride_rad=STRIDE_RAD)
                loop.reset(seed=0)
                hook.reads_s = hook.update_s = 0.0
                homing_walk(loop, controls, hook)
                clocked[side] = [min(clocked[side][0], hook.reads_s), min(clocked[side][1], hook.update_s)]
    per = {side: [1e3 * t / controls for t in times] for side, times in best.items()}
    base_cpu, base_wall = per[None]
    print(f"MuJoCo tripod in the AgentLoop, {controls} control steps of 8 ms (physics 2 ms), one core; best of "
          f"{repeats}, per control step; LegOdometer hook as path integration uses it (odometry=steps)")
    print(f"{'':<44} {'cpu ms':>7} {'wall ms':>7} {'cpu +%':>7} {'wall +%':>7}   clocked in the hook, cpu ms (+%)")
    print(f"{'homing step (loop step + position read)':<44} {base_cpu:>7.4f} {base_wall:>7.4f}")
    for side in everies:
        cpu, wall = per[side]
        reads, update = (1e3 * t / controls for t in clocked[side])
        label = f"+ LegOdometer, sample_every={side}" + (" (default)" if side == default else "")
        print(f"{label:<44} {cpu:>7.4f} {wall:>7.4f} {100 * (cpu - base_cpu) / base_cpu:>7.1f} "
              f"{100 * (wall - base_wall) / base_wall:>7.1f}   reads {reads:.4f} + update {update:.4f} "
              f"({100 * (reads + update) / base_cpu:.1f} %)")
    total = (per[default][0] - base_cpu) / base_cpu
    met = total < TARGET_OVERHEAD
    print(f"target (on CPU time): the odometer at its default sample_every={default} adds "
          f"{100 * total:.1f} % < {100 * TARGET_OVERHEAD:g} % to a MuJoCo homing step: {'met' if met else 'MISSED'}")
    return met


class TrueTrack(Hook):
    """The body's true position and heading at every control step."""

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.positions, self.headings = [], []
        self.after_step(loop)

    def after_step(self, loop: AgentLoop) -> None:
        sensed = loop.backend.read(("position", "heading"))
        self.positions.append(sensed["position"][0, :2].copy())
        self.headings.append(float(np.ravel(sensed["heading"])[0]))


def sampling(backends: list[str], cycles: int, turns: list[float], everies: list[int]) -> None:
    """Print part (c)."""
    body = desert_ant()
    clocks = Clocks(physics_dt_s=TIMESTEP_S, control_dt_s=TIMESTEP_S * PHYSICS_PER_CONTROL,
                    brain_dt_s=TIMESTEP_S * PHYSICS_PER_CONTROL * CYCLE_STEPS)
    everies = sorted(set(everies) | {1})
    print(f"tripod, stride 15°, {cycles} gait cycles after one of start-up; ratio = displacements taken per "
          f"cycle / true (as odometer_ratio in path integration); change and end error in % of the true distance")
    print(f"{'backend':<9} {'turn':>5} {'every':>5} {'ratio':>7} {'change %':>8} {'end err %':>9} {'turn deg':>8} "
          f"{'true deg':>8} {'strides':>7} {'mean m':>7}")
    keeps = {k: True for k in everies}
    for backend in backends:
        ok, reason = registry.availability("backend", backend)
        if not ok:
            print(f"{backend:<9} not available: {reason}")
            continue
        for turn in turns:
            hooks = {k: LegOdometer(body, sample_every=k) for k in everies}
            truth = TrueTrack()
            with registry.load("backend", backend)(timestep_s=TIMESTEP_S) as engine:
                engine.load(World(), [body])
                loop = AgentLoop(engine, make_gait("tripod", body), clocks, hooks=[truth, *hooks.values()],
                                 turn=turn, stride_rad=STRIDE_RAD)
                loop.reset(seed=0)
                homing_walk(loop, CYCLE_STEPS)
                for hook in hooks.values():  # the odometers start after the start-up cycle
                    hook.initialize_episode(loop)
                taken = {k: [] for k in everies}
                for _ in range(cycles):
                    homing_walk(loop, CYCLE_STEPS)
                    for k, hook in hooks.items():
                        taken[k].append(hook.take())
            positions = np.array(truth.positions[CYCLE_STEPS::CYCLE_STEPS])
            headings = np.array(truth.headings[CYCLE_STEPS::CYCLE_STEPS])
            steps_m = np.linalg.norm(np.diff(positions, axis=0), axis=1)
            true_m = steps_m.sum()
            # Counter-clockwise, unwrapped: the control steps' heading changes (clockwise) summed.
            every_heading = np.array(truth.headings[CYCLE_STEPS:])
            true_turn = -np.degrees(np.angle(np.exp(1j * np.diff(every_heading))).sum())
            base = None
            for k in everies:
                moved = np.array(taken[k])
                ratio = np.linalg.norm(moved, axis=1).sum() / true_m
                base = ratio if base is None else base
                # Each cycle's displacement (body frame at the cycle's end) into the world by the true heading.
                s, c = np.sin(headings[1:]), np.cos(headings[1:])
                world = np.stack([moved[:, 0] * s - moved[:, 1] * c, moved[:, 0] * c + moved[:, 1] * s], axis=1)
                end_error = np.hypot(*(world.sum(axis=0) - (positions[-1] - positions[0]))) / true_m
                odometer = hooks[k].odometer
                strides = odometer.stride_lengths_m
                keeps[k] &= abs(ratio - base) < 0.01
                print(f"{backend:<9} {turn:>5.2f} {k:>5d} {ratio:>7.3f} {100 * (ratio - base):>+8.2f} "
                      f"{100 * end_error:>9.1f} {np.degrees(odometer.yaw_rad):>8.1f} {true_turn:>8.1f} "
                      f"{len(strides):>7d} {np.mean(strides) if strides else float('nan'):>7.3f}")
    kept = [k for k in everies if keeps[k]]
    print(f"sample_every keeping the ratio within 1 % of the distance on every row: {', '.join(map(str, kept))}")


def manipulations(backends: list[str], cycles: int, distal_stilts: bool = False) -> None:
    """Print part (b)."""
    believed = desert_ant()
    print(f"straight tripod walk, stride 15°, {cycles} cycles after one of start-up; odometer believes the normal legs")
    print(f"{'backend':<9} {'legs':<7} {'true m/cycle':>12} {'odometer m/cycle':>16} {'odometer/true':>13} "
          f"{'strides':>7} {'mean stride m':>13}")
    for backend in backends:
        ok, reason = registry.availability("backend", backend)
        if not ok:
            print(f"{backend:<9} not available: {reason}")
            continue
        for name, body in bodies(distal_stilts).items():
            with registry.load("backend", backend)(timestep_s=TIMESTEP_S) as engine:
                engine.load(World(), [body])
                gait = make_gait("tripod", body)
                engine.reset(0)
                walk(engine, gait, None, CYCLE_STEPS, odometer_reads=False)
                sensed = engine.read(("body_pos", *ODOMETER_SENSORS))
                start = sensed["body_pos"][0, :2].copy()
                odometer = StepOdometer(believed)
                odometer.update(sensed["joint_pos"][0], sensed["contact_load"][0])
                walk(engine, gait, odometer, cycles * CYCLE_STEPS)
                end = engine.read(["body_pos"])["body_pos"][0, :2]
            true_m = float(np.hypot(*(end - start))) / cycles
            read_m = odometer.distance_m / cycles
            strides = odometer.stride_lengths_m
            mean = f"{np.mean(strides):.3f}" if strides else "-"
            print(f"{backend:<9} {name:<7} {true_m:>12.3f} {read_m:>16.3f} {read_m / true_m:>13.3f} "
                  f"{len(strides):>7d} {mean:>13}")


DISTAL_STILTS = {"tarsus": 2.0}  # --distal-stilts: a bristle as long as the tarsus, added to it


def bodies(distal_stilts: bool) -> dict:
    """The bodies part (b) walks, by name."""
    named = {name: manipulated_ant(name) for name in MANIPULATIONS}
    if distal_stilts:
        height_m = STANDING_HEIGHT_M * leg_length_ratio(DISTAL_STILTS)
        named["distal"] = desert_ant(leg_segment_factors=DISTAL_STILTS, standing_height_m=height_m)
    return named


class RidingLegOdometer(LegOdometer):
    """A LegOdometer that rides along in a trial without feeding its brain: sampled as in odometry=steps,
    taken once per gait cycle as the homing brain takes it."""

    def after_step(self, loop: AgentLoop) -> None:
        super().after_step(loop)
        if loop.control_steps % CYCLE_STEPS == 0:
            self.take()


def homing_trials(trials: int, repeats: int) -> bool:
    """Part (a'): whole path-integration trials on MuJoCo (protocol i2bot, compass and odometry true),
    seeds 0 .. trials-1, each without and with a step odometer riding along (the same walk: the odometer
    does not steer), interleaved; CPU and wall time per control step of the whole trials (the engine's
    build included on both sides); True when the odometer adds under the target."""
    config = build_config(PathIntegrationConfig, {"protocol": "i2bot", "compass": "true", "odometry": "true"})
    sides = ("without", "with")
    best = {side: [[np.inf, np.inf] for _ in range(trials)] for side in sides}
    steps = {}
    for repeat in range(repeats):
        for seed in range(trials):
            for side in (sides if (repeat + seed) % 2 == 0 else sides[::-1]):
                probe = (RidingLegOdometer(desert_ant()),) if side == "with" else ()
                cpu, wall = time.process_time(), time.perf_counter()
                _, log = embodied_trial(config, "mujoco", seed, extra_hooks=probe)
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
                steps[side, seed] = float(np.asarray(log["time_s"][-1])) / CONTROL_S
                best[side][seed] = [min(best[side][seed][0], cpu), min(best[side][seed][1], wall)]
    per = {side: [1e3 * sum(best[side][s][k] for s in range(trials)) / sum(steps[side, s] for s in range(trials))
                  for k in (0, 1)] for side in sides}
    print(f"MuJoCo path-integration trials (protocol i2bot, compass and odometry true), seeds 0-{trials - 1}, "
          f"best of {repeats}; CPU and wall time per control step of the whole trials")
    print(f"{'':<44} {'cpu ms':>7} {'wall ms':>7} {'cpu +%':>7} {'wall +%':>7}")
    base_cpu, base_wall = per["without"]
    print(f"{'homing trial':<44} {base_cpu:>7.4f} {base_wall:>7.4f}")
    cpu, wall = per["with"]
    print(f"{'+ the step odometer riding along':<44} {cpu:>7.4f} {wall:>7.4f} "
          f"{100 * (cpu - base_cpu) / base_cpu:>7.1f} {100 * (wall - base_wall) / base_wall:>7.1f}")
    total = (cpu - base_cpu) / base_cpu
    met = total < TARGET_OVERHEAD
    print(f"target (on CPU time): the step odometer adds {100 * total:.1f} % < {100 * TARGET_OVERHEAD:g} % to a "
          f"MuJoCo homing trial's step: {'met' if met else 'MISSED'}")
    return met


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per timed walk")
    parser.add_argument("--repeats", type=int, default=5, help="best of this many walks")
    parser.add_argument("--every", default="1,2,4,8", help="(a), (c): the hook's sample_every values, comma list "
                        "(control steps; (a) adds the default, (c) adds 1)")
    parser.add_argument("--sampling", action="store_true", help="part (c) instead of the timing")
    parser.add_argument("--homing-trials", type=int, default=3,
                        help="(a'): whole MuJoCo homing trials per odometry (seeds 0..N-1); 0 leaves them out")
    parser.add_argument("--turns", default="0,0.3", help="(c): turn commands, comma list")
    parser.add_argument("--manipulations", action="store_true", help="part (b) instead of the timing")
    parser.add_argument("--cycles", type=int, default=6, help="(b), (c): gait cycles walked after start-up")
    parser.add_argument("--backends", default="mujoco,pybullet", help="(b), (c): backends")
    parser.add_argument("--distal-stilts", action="store_true",
                        help="(b): also walk stilts made of the distal segment only (tarsus x 2, standing height "
                             "scaled with the leg length), row 'distal'")
    args = parser.parse_args(argv)
    if args.manipulations:
        manipulations(args.backends.split(","), args.cycles, args.distal_stilts)
        return 0
    try:
        everies = [int(k) for k in args.every.split(",")]
    except ValueError:
        parser.error(f"--every: a comma list of ints, got {args.every!r}")
    if min(everies) < 1:
        parser.error("--every: values >= 1")
    if args.sampling:
        sampling(args.backends.split(","), args.cycles, [float(t) for t in args.turns.split(",")], everies)
        return 0
    if not (args.seconds >= 0.1 and args.repeats >= 1):
        parser.error("need --seconds >= 0.1 and --repeats >= 1")
    if args.homing_trials < 0:
        parser.error("--homing-trials: an int >= 0")
    overhead(args.seconds, args.repeats, everies)
    if args.homing_trials:
        homing_trials(args.homing_trials, min(args.repeats, 2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
