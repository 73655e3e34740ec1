"""The core's angle helpers: one turn's wrap and the signed difference of two directions."""

import numpy as np
import pytest

from neuronav.angles import angle_difference_rad, wrap_rad

PI = np.pi


@pytest.mark.parametrize(("angle", "wrapped"), [
    (0.0, 0.0), (PI / 2, PI / 2), (-PI / 2, -PI / 2), (3 * PI / 2, -PI / 2), (-3 * PI / 2, PI / 2),
    (2 * PI, 0.0), (5 * PI / 4, -3 * PI / 4), (-5 * PI / 4, 3 * PI / 4), (7 * PI / 3, PI / 3),
])
def test_wrap_rad_analytic_values(angle, wrapped):
    assert wrap_rad(angle) == pytest.approx(wrapped, abs=1e-12)


def test_wrap_rad_range_is_half_open_at_minus_pi():
    """[-π, π): π and -π both map to -π."""
    assert wrap_rad(PI) == -PI
    assert wrap_rad(-PI) == -PI
    angles = np.random.default_rng(0).uniform(-50.0, 50.0, 100_000)
    wrapped = wrap_rad(angles)
    assert wrapped.min() >= -PI and wrapped.max() < PI


def test_wrap_rad_is_periodic_and_keeps_one_turn():
    angles = np.random.default_rng(1).uniform(-PI, PI, 1000)
    for turns in (-3, -1, 1, 4):
        np.testing.assert_allclose(wrap_rad(angles + 2 * PI * turns), angles, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(wrap_rad(wrap_rad(angles)), wrap_rad(angles))


def test_wrap_rad_keeps_the_array_shape():
    angles = np.linspace(-10.0, 10.0, 24).reshape(2, 3, 4)
    wrapped = wrap_rad(angles)
    assert wrapped.shape == (2, 3, 4) and wrapped.dtype == np.float64
    np.testing.assert_allclose(np.cos(wrapped), np.cos(angles), atol=1e-12)
    np.testing.assert_allclose(np.sin(wrapped), np.sin(angles), atol=1e-12)
    assert wrap_rad([7.0]).shape == (1,) and wrap_rad(7.0).shape == ()


def test_wrap_rad_rounds_below_pis_last_bit():
    """The documented cost of the shift by π."""
    assert wrap_rad(1e-20) == 0.0


@pytest.mark.parametrize(("a", "b", "difference"), [
    (0.1, 0.0, 0.1), (0.0, 0.1, -0.1), (0.1, 2 * PI - 0.1, 0.2), (2 * PI - 0.1, 0.1, -0.2),
    (PI / 2, -PI / 2, PI), (-3 * PI / 4, 3 * PI / 4, PI / 2), (5.0, 5.0, 0.0),
])
def test_angle_difference_analytic_values(a, b, difference):
    assert angle_difference_rad(a, b) == pytest.approx(difference, abs=1e-12)


def test_angle_difference_range_sign_and_broadcasting():
    rng = np.random.default_rng(2)
    a, b = rng.uniform(-30.0, 30.0, (500, 1)), rng.uniform(-30.0, 30.0, 7)
    difference = angle_difference_rad(a, b)
    assert difference.shape == (500, 7)
    assert difference.min() >= -PI and difference.max() <= PI
    np.testing.assert_allclose(angle_difference_rad(b, a), -difference, atol=1e-12)
    np.testing.assert_allclose(difference, wrap_rad(a - b), atol=1e-12)
    assert angle_difference_rad(0.0, PI) == -PI and angle_difference_rad(PI, 0.0) == PI


def test_angle_difference_is_exact_for_small_differences():
    """Where it differs from wrap_rad: a tiny difference comes back to the bit."""
    assert angle_difference_rad(1e-20, 0.0) == 1e-20
    assert angle_difference_rad(0.0, 1e-12) == -1e-12
