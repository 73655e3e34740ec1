"""Copy-and-shift steering (neuronav.brains.steering): motor sign vs shift, closed-loop convergence, port errors."""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import ConfigError, NeuronavError, PortError
from neuronav.brains import copy_and_shift, steering, stone2017
from neuronav.brains.steering import MAX_SHIFT, shift_toward, shift_weights

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


SETTLE_TOLERANCE = 1e-13  # rad: the motor has settled once a step changes it by less
MAX_SETTLE_STEPS = 200
SHIFTS = range(-MAX_SHIFT, MAX_SHIFT + 1)


def _settled_motor(shift: int) -> tuple[np.ndarray, int]:
    """Motor at HEADINGS_RAD and a constant shift, stepped until it stops changing; and the steps taken."""
    sim = copy_and_shift(noise=0.0).compile(batch=HEADINGS_RAD.size)
    shifts = np.full((HEADINGS_RAD.size, 1), float(shift))
    previous = None
    for step in range(1, MAX_SETTLE_STEPS + 1):
        motor = sim.step({"heading": HEADINGS_RAD[:, None], "shift": shifts})["motor"][:, 0].copy()
        if previous is not None and np.abs(motor - previous).max() < SETTLE_TOLERANCE:
            return motor, step
        previous = motor
    raise AssertionError(f"shift {shift}: the motor has not settled after {MAX_SETTLE_STEPS} steps")


@pytest.fixture(scope="module")
def settled():
    """{shift: (settled motor per heading, steps it took)} for every allowed shift."""
    return {s: _settled_motor(s) for s in SHIFTS}


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-x))


def _reference_motor(heading_rad: float, shift: int) -> float:
    """The settled motor, by hand from the model's equations (Stone et al. 2017's compass and steering,
    with the TB1 bump rolled by ``shift`` columns as the goal), iterating TB1 to its fixed point."""
    preferred = (np.arange(16) % 8) * np.pi / 4
    tl2 = _sigmoid(6.8 * np.cos(heading_rad - preferred) - 3.0)
    cl1 = _sigmoid(0.5 - 3.0 * tl2)
    column = np.arange(8)
    inhibition = (1.0 - np.cos(np.pi / 4 * (column[:, None] - column[None, :]))) / 2.0
    tb1 = np.zeros(8)
    for _ in range(1000):
        new_tb1 = _sigmoid(5.0 * (0.667 * (cl1[:8] + cl1[8:]) - 0.333 * inhibition @ tb1))
        converged = np.abs(new_tb1 - tb1).max() < 1e-15
        tb1 = new_tb1
        if converged:
            break
    else:
        raise AssertionError("reference TB1 did not converge")
    goal = np.tile(np.roll(tb1, shift), 2)  # goal cell j holds TB1 column (j - shift) mod 8
    pontine = _sigmoid(5.0 * goal - 2.5)
    # CPU1 cell j reads the other hemisphere's goal and Pontine cells, offset by one and three columns
    cell = np.arange(16)
    goal_cell = np.where(cell < 8, 8 + (cell - 1) % 8, (cell - 7) % 8)
    pontine_cell = np.where(cell < 8, 8 + (cell + 3) % 8, (cell - 3) % 8)
    cpu1 = _sigmoid(7.5 * (0.5 * goal[goal_cell] - 0.5 * pontine[pontine_cell] - tb1[cell % 8]) + 1.0)
    return 0.25 * (cpu1[:8].sum() - cpu1[8:].sum())


def test_settled_motor_matches_a_hand_written_reference_at_every_heading_and_shift(settled):
    for shift in SHIFTS:
        motor, steps = settled[shift]
        assert steps > 10, shift  # it really had to settle (TB1's delayed self-inhibition)
        reference = np.array([_reference_motor(h, shift) for h in HEADINGS_RAD])
        np.testing.assert_allclose(motor, reference, rtol=0, atol=1e-12, err_msg=f"shift {shift}")


def test_steering_curve_peaks_at_one_column(settled):
    motor = {s: settled[s][0] for s in SHIFTS}
    for s in range(1, MAX_SHIFT + 1):
        assert np.all(motor[s] > 0.15), s
        # mirror image: motor(-s, theta) = -motor(s, -theta)
        mirrored = -motor[s][(-np.arange(HEADINGS_RAD.size)) % HEADINGS_RAD.size]
        np.testing.assert_allclose(motor[-s], mirrored, rtol=0, atol=1e-12)
    # the turn is fastest for one column, at every heading, and slows for two and three
    assert np.all(motor[1] > motor[2]) and np.all(motor[2] > motor[3])
    # shift 0: a small heading-dependent bias next to any turn
    assert np.abs(motor[0]).max() < 0.05 * motor[3].min()
    # the response repeats every 45 deg of heading (HEADINGS_RAD are 15 deg apart)
    for s in SHIFTS:
        rows = motor[s].reshape(8, 3)
        np.testing.assert_allclose(rows, np.broadcast_to(rows[0], rows.shape), rtol=0, atol=1e-12)


def test_docstring_numbers_are_the_settled_curve(settled):
    doc = steering.__doc__
    for s in (1, 2, 3, 0):
        motor = settled[s][0]
        line = f"    shift {s:2d}: {motor.min():+.3f} to {motor.max():+.3f}"
        assert line in doc, line
    steps = [settled[s][1] for s in SHIFTS]
    assert f"which takes {min(steps)} to {max(steps)} steps" in doc
    early = {s: _motor(s) for s in (1, 2, 3)}
    assert "(1: {:.2f}–{:.2f}, 2: {:.2f}–{:.2f}, 3: {:.2f}–{:.2f})".format(
        *[v for s in (1, 2, 3) for v in (early[s].min(), early[s].max())]) in doc
    assert early[2].max() > early[1].max()  # after 5 steps it only looks like two columns turn fastest
    assert f"(at most {np.rad2deg(np.abs(settled[0][0]).max()):.2f}° per step)" in doc


def test_closed_loop_docstring_numbers():
    band_deg = 22.5
    entered, after = [], []
    for target_rad in TARGETS_RAD:
        errors = np.rad2deg(np.abs(_closed_loop(target_rad, steps=200)))
        for agent in range(errors.shape[1]):
            first = int(np.argmax(errors[:, agent] <= band_deg))
            assert errors[first, agent] <= band_deg
            entered.append(first + 1)
            after.append(errors[first:, agent].max())
    assert max(entered) == 12 and "within 12 steps from every start" in steering.__doc__
    assert f"stays within {max(after):.2f}° of the target" in steering.__doc__
    shift0_bias_deg = np.rad2deg(np.abs(_motor(0, steps=100)).max())
    assert max(after) <= band_deg + shift0_bias_deg + 1e-9  # past the edge by at most one step of bias
    noisy = np.rad2deg(np.abs(_closed_loop(1.0, noise=0.1, steps=200)))
    assert noisy[19:].max() < 35.0 and "within 35° of the target from step 20 to 200" in steering.__doc__
    inverted = np.rad2deg(np.abs(_closed_loop(1.0, invert_goal=True, steps=40)))[-1]
    assert np.sum(inverted > 180.0 - 26.0) == 22 and "22 of 24 starts end within 26° of it" in steering.__doc__


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
