"""The step odometer on the physics engines: the ant walks the FK tripod straight (stride 15°), one
cycle of start-up and then ``CYCLES`` gait cycles (0.64 s each), while
:class:`neuronav.bodies.step_odometer.StepOdometer` reads its joint angles and claw loads through
the leg kinematics of the body it *believes* it has.

- Normal legs, believed normal: the odometer reads close to the true distance (the root's horizontal
  displacement), within ``BAND`` of what each engine measured; it is not exact, because the FK tripod's
  feet slip and its stance legs unload now and then (README: bodies/desert_ant/README.md, "Step odometer").
- Longer legs (``leg_length_factors=1.3``) read through the believed normal legs: the odometer
  underestimates, relative to the normal legs' reading.
- The named manipulations (:mod:`neuronav.bodies.desert_ant.manipulations`) change the true stride:
  stilts longer, stumps shorter.

Measured (this test's walk) with ``python benchmarks/step_odometer.py --manipulations --cycles 3``
(odometer / true): MuJoCo normal 0.905, stilts 0.810; PyBullet normal 1.187, stilts 0.984.
"""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.desert_ant.manipulations import manipulated_ant
from neuronav.bodies.gaits import make_gait
from neuronav.bodies.step_odometer import StepOdometer
from neuronav.spec.world import World

BACKENDS = ["mujoco", "pybullet"]
CYCLES = 3
CYCLE_STEPS = 80
MEASURED_RATIO = {"mujoco": 0.905, "pybullet": 1.187}  # odometer / true, normal legs
BAND = 0.1


def walk(backend: str, body, believed) -> tuple[float, StepOdometer]:
    """(true distance m, the odometer) of the straight walk."""
    pytest.importorskip(backend, reason=f"{backend} is not installed")
    with registry.load("backend", backend)(timestep_s=0.002) as engine:
        engine.load(World(), [body])
        gait = make_gait("tripod", body)
        engine.reset(0)
        odometer = StepOdometer(believed)
        for k in range((CYCLES + 1) * CYCLE_STEPS):
            engine.write({"joint_targets": gait.step(0.0, np.radians(15.0))[None, :]})
            engine.step(4)
            sensed = engine.read(("joint_pos", "contact_force", "body_pos"))
            if k == CYCLE_STEPS - 1:
                start = sensed["body_pos"][0, :2].copy()
            if k >= CYCLE_STEPS - 1:
                odometer.update(sensed["joint_pos"][0], sensed["contact_force"][0])
        return float(np.hypot(*(sensed["body_pos"][0, :2] - start))), odometer


@pytest.fixture(scope="module")
def normal():
    return desert_ant()


@pytest.mark.parametrize("backend", BACKENDS)
def test_normal_legs_read_close_to_the_true_distance(backend, normal):
    true_m, odometer = walk(backend, normal, normal)
    assert true_m > 0.8, true_m  # it walked (~0.33 m per cycle)
    ratio = odometer.distance_m / true_m
    assert ratio == pytest.approx(MEASURED_RATIO[backend], rel=BAND), ratio
    assert len(odometer.stride_lengths_m) == CYCLES - 1, odometer.stride_lengths_m
    np.testing.assert_allclose(odometer.stride_lengths_m, odometer.distance_m / CYCLES, rtol=0.2)


@pytest.mark.parametrize("backend", BACKENDS)
def test_longer_legs_read_through_the_believed_normal_legs_underestimate(backend, normal):
    true_normal, normal_reading = walk(backend, normal, normal)
    true_long, long_reading = walk(backend, desert_ant(leg_length_factors=1.3), normal)
    assert true_long > 1.1 * true_normal  # the longer legs walk farther ...
    ratio_normal = normal_reading.distance_m / true_normal
    ratio_long = long_reading.distance_m / true_long
    assert ratio_long < 0.93 * ratio_normal, (ratio_long, ratio_normal)  # ... than the odometer believes


@pytest.mark.parametrize("backend", BACKENDS)
def test_stilts_lengthen_and_stumps_shorten_the_stride(backend, normal):
    true_m = {name: walk(backend, manipulated_ant(name), normal)[0] for name in ("normal", "stilts", "stumps")}
    assert true_m["stilts"] > 1.1 * true_m["normal"], true_m
    assert true_m["stumps"] < 0.8 * true_m["normal"], true_m
