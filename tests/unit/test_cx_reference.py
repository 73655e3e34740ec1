"""The compiled graph of Stone et al. 2017 (brains/cx.py) against the hand-written numpy model.

The two share no code: brains/cx_reference.py copies its numbers from docs/parameters.md §3. With noise
off they must agree to 1e-12 on every population over a varying route, so a change to either
implementation's equations (or to the compiler) fails here.
"""

from __future__ import annotations

import numpy as np
import pytest

from neuronav.brains.cx import stone2017
from neuronav.brains.cx_reference import StoneNumpy

STEPS = 400
TOLERANCE = 1e-12
# docs/parameters.md §3: noise-free TB1 at heading 0 after settling (an inverted bump).
TB1_SETTLED_AT_0 = [0.0099, 0.0203, 0.6387, 0.8866, 0.9297, 0.8866, 0.6387, 0.0203]


def random_route(steps: int = STEPS, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A smooth random outbound route: headings (steps,) rad and world velocities (steps, 2)."""
    rng = np.random.default_rng(seed)
    turns = np.zeros(steps)
    for t in range(1, steps):  # smoothed von Mises turns, as in Stone's outbound routes
        turns[t] = rng.vonmises(0.0, 20.0) + 0.4 * turns[t - 1]
    headings = np.cumsum(turns) + rng.uniform(-np.pi, np.pi)
    speeds = 0.2 + 0.8 * np.abs(np.sin(np.linspace(0.0, 3.0 * np.pi, steps)))
    velocities = speeds[:, None] * np.column_stack([np.sin(headings), np.cos(headings)])
    return headings, velocities


def run_both(noise: float, headings: np.ndarray, velocities: np.ndarray):
    """Step both implementations along the route; yield (compiled, reference, compiled motor)."""
    compiled = stone2017(noise=noise).compile(batch=1, seed=0)
    reference = StoneNumpy(noise=noise, seed=0)
    for heading, velocity in zip(headings, velocities, strict=True):
        out = compiled.step({"heading": np.array([[heading]]), "velocity": velocity[None, :]})
        reference.step(float(heading), velocity)
        yield compiled, reference, out["motor"]


def test_noise_free_compiled_matches_hand_written():
    headings, velocities = random_route()
    pairs = {"TL2": "tl2", "CL1": "cl1", "TB1": "tb1", "TN1": "tn1", "TN2": "tn2", "CPU4": "cpu4",
             "Pontine": "pontine", "CPU1": "cpu1"}
    motors, memories = [], []
    for compiled, reference, motor in run_both(0.0, headings, velocities):
        assert motor.shape == (1, 1)
        np.testing.assert_allclose(motor[0, 0], reference.motor, rtol=0, atol=TOLERANCE)
        np.testing.assert_allclose(compiled.memory("CPU4")[0], reference.cpu4_memory, rtol=0, atol=TOLERANCE)
        for population, attribute in pairs.items():
            np.testing.assert_allclose(compiled.rates(population)[0], getattr(reference, attribute),
                                       rtol=0, atol=TOLERANCE, err_msg=population)
        motors.append(reference.motor)
        memories.append(reference.cpu4_memory.copy())
    # The route must exercise the model, or the comparison above proves little.
    motors, memories = np.array(motors), np.array(memories)
    assert np.ptp(motors) > 0.1
    assert np.ptp(memories[-1]) > 0.05  # the memory holds a home vector
    assert 0.0 < memories.min() and memories.max() < 1.0  # and is not saturated


def test_tb1_settles_to_published_bump_at_heading_zero():
    compiled = stone2017(noise=0.0).compile(batch=1)
    reference = StoneNumpy(noise=0.0)
    for _ in range(100):
        compiled.step({"heading": np.zeros((1, 1)), "velocity": np.zeros((1, 2))})
        reference.step(0.0, np.zeros(2))
    np.testing.assert_allclose(reference.tb1, TB1_SETTLED_AT_0, atol=5e-5)
    np.testing.assert_allclose(compiled.rates("TB1")[0], TB1_SETTLED_AT_0, atol=5e-5)


def test_reference_reset_restores_initial_state():
    headings, velocities = random_route(50)
    reference = StoneNumpy(noise=0.1, seed=7)
    first = [reference.step(float(h), v) for h, v in zip(headings, velocities, strict=True)]
    reference.reset()
    np.testing.assert_array_equal(reference.cpu4_memory, np.full(16, 0.5))
    np.testing.assert_array_equal(reference.tb1, np.zeros(8))
    second = [reference.step(float(h), v) for h, v in zip(headings, velocities, strict=True)]
    assert first == second


@pytest.mark.parametrize("noise", [0.1, 0.5])
def test_noisy_rates_stay_finite_and_in_unit_interval(noise):
    headings, velocities = random_route()
    noise_free = StoneNumpy(noise=0.0)
    differs = False
    steps = zip(run_both(noise, headings, velocities), headings, velocities, strict=True)
    for (compiled, reference, motor), heading, velocity in steps:
        noise_free.step(float(heading), velocity)
        differs |= not np.allclose(reference.tb1, noise_free.tb1) and not np.allclose(
            compiled.rates("TB1")[0], noise_free.tb1)
        assert np.isfinite(motor).all() and np.isfinite(reference.motor)
        assert compiled.all_finite()
        for rates in [compiled.rates(p)[0] for p in ("TL2", "CL1", "TB1", "TN1", "TN2", "CPU4", "Pontine", "CPU1")]:
            assert np.isfinite(rates).all() and rates.min() >= 0.0 and rates.max() <= 1.0
        for rates in (reference.tl2, reference.cl1, reference.tb1, reference.tn1, reference.tn2,
                      reference.cpu4_memory, reference.cpu4, reference.pontine, reference.cpu1):
            assert np.isfinite(rates).all() and rates.min() >= 0.0 and rates.max() <= 1.0
        memory = compiled.memory("CPU4")
        assert memory.min() >= 0.0 and memory.max() <= 1.0
    assert differs  # the noise is really applied, in both
