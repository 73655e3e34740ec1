"""Stone et al. 2017's CX against the published numbers (docs/parameters.md §3)."""

import numpy as np
import pytest

from neuronav.brains.cx import CPU4_GAIN, decode_home_vector, stone2017

PUBLISHED_TB1_AT_0 = [0.0099, 0.0203, 0.6387, 0.8866, 0.9297, 0.8866, 0.6387, 0.0203]


def straight_run(sim, heading_rad, steps, speed=0.85):
    """Feed a constant heading and velocity; return CPU4 memory after every step, shape (steps, 16)."""
    heading = np.full((sim.batch, 1), heading_rad)
    velocity = speed * np.array([[np.sin(heading_rad), np.cos(heading_rad)]]).repeat(sim.batch, 0)
    memory = []
    for _ in range(steps):
        sim.step({"heading": heading, "velocity": velocity})
        memory.append(sim.memory("CPU4")[0])
    return np.array(memory)


def test_tb1_settles_to_published_bump():
    sim = stone2017(noise=0.0).compile(batch=1)
    for _ in range(50):
        sim.step({"heading": np.zeros((1, 1)), "velocity": np.zeros((1, 2))})
    np.testing.assert_allclose(sim.rates("TB1")[0], PUBLISHED_TB1_AT_0, atol=1e-3)


@pytest.mark.parametrize("heading_deg", [45, 90, 180, 270])
def test_tb1_bump_rotates_with_heading(heading_deg):
    sim = stone2017(noise=0.0).compile(batch=1)
    for _ in range(50):
        sim.step({"heading": np.full((1, 1), np.radians(heading_deg)), "velocity": np.zeros((1, 2))})
    np.testing.assert_allclose(sim.rates("TB1")[0], np.roll(PUBLISHED_TB1_AT_0, heading_deg // 45), atol=1e-3)


def test_cpu4_integrates_linearly_then_saturates_near_430_steps():
    sim = stone2017(noise=0.0).compile(batch=1)
    memory = straight_run(sim, 0.0, 600)
    top = memory.max(axis=1)
    # Linear growth while unsaturated: the increments are constant.
    increments = np.diff(top[50:350])  # after TB1 has settled
    assert increments.min() > 0
    np.testing.assert_allclose(increments, increments.mean(), rtol=1e-3)
    # Expected rate: h * (TN2 - TB1_min - k) with TN2 = 0.85 cos 45°.
    expected = CPU4_GAIN * (0.85 * np.cos(np.pi / 4) - PUBLISHED_TB1_AT_0[0] - 0.125)
    assert increments.mean() == pytest.approx(expected, rel=0.02)
    saturated_at = int(np.argmax(top >= 1.0))
    assert 400 <= saturated_at <= 460, saturated_at
    assert np.all(top[saturated_at:] == 1.0)


@pytest.mark.parametrize("alpha_deg", [0, 30, 75, 120, 200, 290, 345])
def test_decoded_home_vector_points_back(alpha_deg):
    alpha = np.radians(alpha_deg)
    sim = stone2017(noise=0.0).compile(batch=1)
    short = straight_run(sim, alpha, 100)[-1]
    long = straight_run(sim, alpha, 100)[-1]  # continues: 200 steps in all
    direction, distance_short = decode_home_vector(short[None])
    _, distance_long = decode_home_vector(long[None])
    error_deg = np.degrees(np.angle(np.exp(1j * (direction[0] - (alpha + np.pi)))))
    assert abs(error_deg) < 5.0
    assert distance_long[0] > 1.5 * distance_short[0] > 0


@pytest.mark.parametrize("offset_deg", [-90, -30, 30, 90])
def test_cx_turns_toward_home(offset_deg):
    """After an outbound run east, an agent facing off the home direction is turned back toward it."""
    alpha = np.pi / 2
    sim = stone2017(noise=0.0).compile(batch=1)
    straight_run(sim, alpha, 200)
    home = alpha + np.pi
    heading = home + np.radians(offset_deg)
    for _ in range(20):  # let the compass settle at the new heading, standing still
        motor = sim.step({"heading": np.full((1, 1), heading), "velocity": np.zeros((1, 2))})["motor"][0, 0]
    assert np.sign(motor) == -np.sign(offset_deg)
    # Closed loop: heading += motor brings the agent round to face home.
    for _ in range(300):
        heading += sim.step({"heading": np.full((1, 1), heading), "velocity": np.zeros((1, 2))})["motor"][0, 0]
    assert abs(np.degrees(np.angle(np.exp(1j * (heading - home))))) < 10.0


def test_motor_is_zero_when_memory_is_flat():
    sim = stone2017(noise=0.0).compile(batch=1)
    out = sim.step({"heading": np.full((1, 1), 1.0), "velocity": np.zeros((1, 2))})
    assert abs(out["motor"][0, 0]) < 1e-12
