"""Copy-and-shift steering (brains.steering): motor sign vs shift, closed-loop convergence, port errors."""

from __future__ import annotations

import numpy as np
import pytest

from brains import copy_and_shift, stone2017
from brains.steering import MAX_SHIFT, shift_toward, shift_weights
from neuronav import ConfigError, NeuronavError, PortError

HEADINGS_RAD = np.deg2rad(np.arange(0.0, 360.0, 15.0))
TARGETS_RAD = [0.0, 1.0, -2.5, np.pi]
WARM_UP_STEPS = 3


def _wrap(angle_rad):
    return np.angle(np.exp(1j * np.asarray(angle_rad)))


def _motor(shift: int, noise: float = 0.0, steps: int = 5) -> np.ndarray:
    """Motor after a few steps at fixed headings (HEADINGS_RAD) and a constant shift, shape (batch,)."""
    sim = copy_and_shift(noise=noise).compile(batch=HEADINGS_RAD.size, seed=1)
    shifts = np.full((HEADINGS_RAD.size, 1), float(shift))
    for _ in range(steps):
        out = sim.step({"heading": HEADINGS_RAD[:, None], "shift": shifts})
    return out["motor"][:, 0]


def _closed_loop(target_rad: float, noise: float = 0.0, steps: int = 40, **options) -> np.ndarray:
    """Heading error (rad, wrapped) every step, shape (steps, batch), starting from HEADINGS_RAD."""
    sim = copy_and_shift(noise=noise, **options).compile(batch=HEADINGS_RAD.size, seed=2)
    heading = HEADINGS_RAD.copy()
    errors = []
    for _ in range(steps):
        motor = sim.step({"heading": heading[:, None], "shift": shift_toward(heading, target_rad)})["motor"][:, 0]
        heading = _wrap(heading + motor)
        errors.append(_wrap(heading - target_rad))
    return np.array(errors)


def test_motor_sign_follows_shift_and_grows_up_to_two_columns():
    motors = {s: _motor(s) for s in range(-MAX_SHIFT, MAX_SHIFT + 1)}
    for s in range(1, MAX_SHIFT + 1):
        assert np.all(motors[s] > 0.05), s
        assert np.all(motors[-s] < -0.05), -s
    # monotonic over -2..2 at every heading
    for s in range(-2, 2):
        assert np.all(motors[s + 1] > motors[s])
    # shift 0: small next to shift +-2
    assert np.abs(motors[0]).max() < 0.2 * min(np.abs(motors[2]).min(), np.abs(motors[-2]).min())


def test_constant_shift_keeps_turning_in_its_direction():
    for shift in (1, -2):
        sim = copy_and_shift().compile(batch=HEADINGS_RAD.size)
        heading = HEADINGS_RAD.copy()
        turned = np.zeros_like(heading)
        for step in range(30):
            motor = sim.step({"heading": heading[:, None], "shift": np.full((heading.size, 1), float(shift))})
            motor = motor["motor"][:, 0]
            # TB1 starts silent and its delayed self-inhibition rings for the first two steps
            if step >= WARM_UP_STEPS:
                assert np.all(np.sign(motor) == np.sign(shift)), step
            heading = _wrap(heading + motor)
            turned += motor
        assert np.all(np.sign(shift) * turned > 2 * np.pi)  # more than a full turn


@pytest.mark.parametrize("target_rad", TARGETS_RAD)
def test_closed_loop_converges_to_target_within_one_column(target_rad):
    errors = np.abs(_closed_loop(target_rad))
    assert errors[0].max() > np.deg2rad(150)  # some starts are far away
    assert errors[-10:].max() < np.deg2rad(45.0)
    # it stops in the dead band, where the shift is 0, and stays there
    assert errors[-10:].max() <= np.deg2rad(22.5) + 1e-9


def test_closed_loop_converges_with_noise():
    errors = np.abs(_closed_loop(1.0, noise=0.1, steps=60))
    assert errors[-20:].max() < np.deg2rad(45.0)


def test_inverted_goal_is_the_wrong_mapping():
    errors = np.abs(_closed_loop(1.0, invert_goal=True))
    # it heads the opposite way from nearly every start (only starts at the target stay there)
    assert np.mean(errors[-1] > np.deg2rad(120.0)) > 0.75


def test_same_sign_convention_as_stone_path_integration():
    # Stone: go north (heading 0) for a while; home is south (pi). Facing east (+pi/2) the agent must
    # turn clockwise (heading increases toward pi) and facing west the other way.
    sim = stone2017(noise=0.0).compile(batch=1)
    for _ in range(300):
        sim.step({"heading": np.zeros((1, 1)), "velocity": np.array([[0.0, 1.0]])})
    east = west = None
    for _ in range(3):
        east = sim.step({"heading": np.full((1, 1), np.pi / 2), "velocity": np.zeros((1, 2))})["motor"][0, 0]
    for _ in range(3):
        west = sim.step({"heading": np.full((1, 1), -np.pi / 2), "velocity": np.zeros((1, 2))})["motor"][0, 0]
    assert east > 0 > west
    # copy-and-shift facing east, desired heading south (+2 columns): the same clockwise turn
    cas = copy_and_shift().compile(batch=1)
    for _ in range(3):
        motor = cas.step({"heading": np.full((1, 1), np.pi / 2), "shift": np.full((1, 1), 2.0)})["motor"][0, 0]
    assert motor > 0


def test_shift_toward():
    heading = np.deg2rad(np.array([0.0, 0.0, 0.0, 350.0, 100.0]))
    target = np.deg2rad(np.array([90.0, -50.0, 180.0, 10.0, 100.0]))
    np.testing.assert_array_equal(shift_toward(heading, target), [[2.0], [-1.0], [3.0], [0.0], [0.0]])
    assert shift_toward(heading, 0.0, max_shift=1).shape == (5, 1)


def test_shifter_wiring_is_a_gated_roll():
    from_tb1, from_gate, to_goal = shift_weights(2)
    assert from_tb1.shape == (40, 8) and from_gate.shape == (40, 5) and to_goal.shape == (16, 40)
    tb1 = np.linspace(0.1, 0.8, 8)
    for k, shift in enumerate(range(-2, 3)):
        gate = np.eye(5)[k]
        shifter = np.maximum(from_tb1 @ tb1 + from_gate @ gate - 1.0, 0.0)
        np.testing.assert_allclose(to_goal @ shifter, np.tile(np.roll(tb1, shift), 2))


def test_same_seed_same_numbers_with_noise():
    runs = [_motor(1, noise=0.1, steps=20) for _ in range(2)]
    np.testing.assert_array_equal(runs[0], runs[1])


@pytest.mark.parametrize("shift", [MAX_SHIFT + 1, -(MAX_SHIFT + 1), 10.0, np.nan, np.inf])
def test_shift_out_of_range_is_a_port_error(shift):
    sim = copy_and_shift().compile(batch=2)
    with pytest.raises(PortError, match="shift"):
        sim.step({"heading": np.zeros((2, 1)), "shift": np.array([[0.0], [shift]])})


@pytest.mark.parametrize("value", [np.zeros(2), np.zeros((2, 2)), np.zeros((3, 1)), [[0.0], [1.0]]])
def test_shift_of_wrong_shape_is_a_port_error(value):
    sim = copy_and_shift().compile(batch=2)
    with pytest.raises(PortError, match="shift"):
        sim.step({"heading": np.zeros((2, 1)), "shift": value})


def test_missing_port_and_bad_arguments():
    sim = copy_and_shift().compile(batch=1)
    with pytest.raises(PortError, match="shift"):
        sim.step({"heading": np.zeros((1, 1))})
    for bad in (0, 5, 2.5, True):
        with pytest.raises(ConfigError):
            copy_and_shift(max_shift=bad)
    with pytest.raises(NeuronavError):
        copy_and_shift(noise=-1.0)
    # a larger range accepts what the default rejects
    wide = copy_and_shift(max_shift=4).compile(batch=1)
    assert wide.step({"heading": np.zeros((1, 1)), "shift": np.full((1, 1), 4.0)})["motor"].shape == (1, 1)
