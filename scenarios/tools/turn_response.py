"""Measure how the walking ant turns: heading change per gait cycle and crab angle per turn command.

The tripod gait turns by differential stride (I2Bot Table 2): one side's sweep shrinks. A legged body
turning that way does not walk along its own axis: over a gait cycle its path (the chord from the
cycle's start to its end) points several degrees off its mean heading — it walks crabwise, toward the
inside of the turn. Route following by stored views is sensitive to that
(:mod:`neuronav.scenarios.route_following.scenario`). :mod:`neuronav.scenarios.tools.calibrate_unicycle`
measures turn rate and speed only; this module adds the crab angle, on the bodies route following
drives (:func:`neuronav.scenarios.visual_setup.make_engine`, the unicycle included).

For each backend and each turn command θ (stride 20°, flat ground, 8 gait cycles; the first 3 left
out), prints the heading change per cycle (deg, + clockwise, i.e. to the right) and the crab angle
(deg; mean heading minus the chord's direction, + the body points right of its path).

Usage::

    python -m neuronav.scenarios.tools.turn_response [--backends mujoco,pybullet,kinematic]
        [--turns=-0.3,-0.2,-0.1,0,0.1,0.2,0.3]

Results: README.md in this folder.
"""

from __future__ import annotations

import argparse

import numpy as np

from neuronav import registry
from neuronav.angles import angle_difference_rad
from neuronav.engine.loop import AgentLoop, Clocks, Hook
from neuronav.errors import NeuronavError
from neuronav.scenarios.visual_setup import CONTROL_S, CYCLE_S, make_engine
from neuronav.spec.world import Ground, World

STRIDE_RAD = np.radians(20.0)
CYCLES, SETTLE_CYCLES = 8, 3


class PoseRecorder(Hook):
    """Heading (rad) and position (m) after every control step."""

    def __init__(self) -> None:
        self.heading_rad: list[float] = []
        self.position_m: list[np.ndarray] = []

    def after_step(self, loop: AgentLoop) -> None:
        sensed = loop.backend.read(("heading", "position"))
        self.heading_rad.append(float(sensed["heading"][0, 0]))
        self.position_m.append(sensed["position"][0].copy())


def turn_response(backend: str, turn: float, timestep_s: float = 0.002) -> tuple[float, float]:
    """(heading change per cycle, crab angle), both in degrees, for a constant ``turn`` on ``backend``."""
    engine, body, gait, physics_dt = make_engine(backend, timestep_s)
    recorder = PoseRecorder()
    with engine:
        engine.load(World(ground=Ground()), [body])
        loop = AgentLoop(engine, gait, Clocks(physics_dt_s=physics_dt, control_dt_s=CONTROL_S, brain_dt_s=CYCLE_S),
                         steering=lambda _: (turn, STRIDE_RAD), hooks=[recorder])
        loop.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=0.0)
        loop.run(CYCLE_S * CYCLES + 1e-9)
    heading = np.unwrap(recorder.heading_rad)
    position = np.array(recorder.position_m)
    per_cycle = int(round(CYCLE_S / CONTROL_S))
    crabs = []
    for cycle in range(SETTLE_CYCLES, CYCLES):
        start, end = cycle * per_cycle - 1, (cycle + 1) * per_cycle - 1
        chord = position[end] - position[start]
        chord_rad = np.arctan2(chord[0], chord[1])  # clockwise from +y, as the heading
        crabs.append(angle_difference_rad(heading[start:end].mean(), chord_rad))
    rate = (heading[-1] - heading[SETTLE_CYCLES * per_cycle - 1]) / (CYCLES - SETTLE_CYCLES)
    return float(np.degrees(rate)), float(np.degrees(np.mean(crabs)))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backends", default="mujoco,pybullet,kinematic")
    parser.add_argument("--turns", default="-0.3,-0.2,-0.1,0,0.1,0.2,0.3")
    args = parser.parse_args(argv)
    try:
        turns = [float(t) for t in args.turns.split(",")]
    except ValueError:
        parser.error(f"--turns: comma-separated numbers in [-1, 1], got {args.turns!r}")
    if not all(-1.0 <= t <= 1.0 for t in turns):
        parser.error(f"--turns: each in [-1, 1], got {args.turns!r}")
    backends = args.backends.split(",")
    for backend in backends:
        try:
            registry.load("backend", backend)
        except NeuronavError as error:  # unknown or not installed
            parser.error(str(error))
    print(f"stride 20 deg, flat ground, cycles {SETTLE_CYCLES + 1}-{CYCLES} of {CYCLE_S} s; turn > 0 is left")
    for backend in backends:
        cells = []
        for turn in turns:
            rate_deg, crab_deg = turn_response(backend, turn)
            cells.append(f"{turn:+.2f}: {rate_deg:+5.1f} deg/cycle, crab {crab_deg:+5.1f}")
        print(f"{backend:>9}  " + " | ".join(cells))


if __name__ == "__main__":
    main()
