"""Eq. 3.11 plume tracking controller: its branches, signs, the two straight cycles and the stride formula."""

import numpy as np
import pytest

from neuronav.brains.plume_tracking import (
    ODOUR_THRESHOLD,
    ORIENT,
    SEARCH,
    SEARCH_STRIDE_RAD,
    STRAIGHT,
    STRAIGHT_STRIDE_RAD,
    PlumeController,
    eq_3_11,
    upwind_heading_rad,
)
from neuronav.errors import ConfigError

WIND_PLUS_X = np.array([[[2.0, 0.0], [2.0, 0.0]]])  # (1 agent, 2 tips, xy)
SMELL = np.array([[1e-3, 1e-4]])


def test_upwind_heading_points_against_the_wind_clockwise_from_plus_y():
    # Wind toward +x: upwind is −x, the heading −90° (clockwise from +y); toward +y: upwind −y, 180°.
    np.testing.assert_allclose(upwind_heading_rad([2.0, 0.0]), -np.pi / 2)
    np.testing.assert_allclose(upwind_heading_rad([-1.5, 0.0]), np.pi / 2)
    np.testing.assert_allclose(abs(upwind_heading_rad([0.0, 2.0])), np.pi)
    np.testing.assert_allclose(upwind_heading_rad([0.0, -2.0]), 0.0, atol=1e-12)


@pytest.mark.parametrize(("heading_deg", "desired_deg", "turn"), [
    (0.0, -90.0, 1.0),     # facing +y, upwind −x is on the left: turn left (θ > 0)
    (0.0, 90.0, -1.0),     # the desired heading clockwise of the current one: turn right
    (170.0, -170.0, -1.0),  # 20° clockwise across the ±180° seam (unwrapped it would read 340° the other way)
    (-170.0, 170.0, 1.0),
    (-90.0, -90.0, 0.0),   # aligned: no turn
])
def test_turn_sign_is_left_toward_a_desired_heading_on_the_left(heading_deg, desired_deg, turn):
    got, _ = eq_3_11(np.radians(desired_deg), np.radians(heading_deg))
    assert got == turn


@pytest.mark.parametrize(("heading_deg", "desired_deg", "stride_deg"), [
    (0.0, -7.0, 7.0),     # the paper's m − h = +7°: 5 + (7 mod 5) = 7
    (0.0, 7.0, 8.0),      # m − h = −7°: floor modulo gives 3, so 8
    (0.0, -90.0, 5.0),    # 90 mod 5 = 0
    (0.0, -93.5, 8.5),
    (0.0, 0.0, 5.0),
])
def test_stride_is_five_degrees_plus_the_difference_modulo_five(heading_deg, desired_deg, stride_deg):
    _, stride = eq_3_11(np.radians(desired_deg), np.radians(heading_deg))
    np.testing.assert_allclose(np.degrees(stride), stride_deg, atol=1e-9)


def test_stride_stays_within_five_and_ten_degrees_for_any_difference():
    rng = np.random.default_rng(0)
    _, stride = eq_3_11(rng.uniform(-np.pi, np.pi, 5000), rng.uniform(-np.pi, np.pi, 5000))
    assert np.degrees(stride).min() >= 5.0 and np.degrees(stride).max() < 10.0


@pytest.mark.parametrize(("desired_deg", "stride_deg"), [(-7.0, 6.4), (20.0, 9.0), (-50.0, 15.0), (-90.0, 15.0)])
def test_divide_rule_adds_a_fifth_of_the_difference_capped_at_fifteen_degrees(desired_deg, stride_deg):
    turn, stride = eq_3_11(np.radians(desired_deg), 0.0, stride_rule="divide")
    np.testing.assert_allclose(np.degrees(stride), stride_deg, atol=1e-9)
    assert turn == -np.sign(desired_deg)  # the same turn as the printed rule
    brain = PlumeController(seed=0, stride_rule="divide")
    np.testing.assert_allclose(np.degrees(brain.step(SMELL, WIND_PLUS_X, [0.0])[1][0]), 15.0)  # 90° off


def test_odour_orients_upwind_then_walks_straight_two_cycles_then_decides_again():
    brain = PlumeController(agents=1, seed=0)
    heading = np.array([0.0])  # facing +y; upwind (−x) is on the left
    turn, stride, branch = brain.step(SMELL, WIND_PLUS_X, heading)
    assert (branch[0], turn[0]) == (ORIENT, 1.0)
    np.testing.assert_allclose(np.degrees(stride[0]), 5.0)  # |−(−90°)| mod 5 = 0
    for _ in range(2):  # straight, whatever is smelled now (here nothing)
        turn, stride, branch = brain.step(np.zeros((1, 2)), WIND_PLUS_X, heading)
        assert (branch[0], turn[0], stride[0]) == (STRAIGHT, 0.0, STRAIGHT_STRIDE_RAD)
    turn, stride, branch = brain.step(np.zeros((1, 2)), WIND_PLUS_X, heading)
    assert branch[0] == SEARCH and abs(turn[0]) == 1.0 and stride[0] == SEARCH_STRIDE_RAD


def test_the_antenna_with_more_odour_gives_the_wind_to_follow():
    # Left tip: wind toward +x (upwind on the left of a +y-facing ant); right tip: toward −x (upwind right).
    wind = np.array([[[2.0, 0.0], [-2.0, 0.0]]])
    left_stronger = PlumeController(seed=0).step(np.array([[1e-3, 1e-5]]), wind, [0.0])
    right_stronger = PlumeController(seed=0).step(np.array([[1e-5, 1e-3]]), wind, [0.0])
    assert left_stronger[0][0] == 1.0 and right_stronger[0][0] == -1.0


def test_threshold_is_strict_and_several_odours_are_summed():
    at_threshold = np.full((1, 2), ODOUR_THRESHOLD)
    assert PlumeController(seed=0).step(at_threshold, WIND_PLUS_X, [0.0])[2][0] == SEARCH
    # Two odours each at 0.6 T: their sum is above the threshold.
    two_odours = np.full((1, 2, 2), 0.6 * ODOUR_THRESHOLD)
    assert PlumeController(seed=0).step(two_odours, WIND_PLUS_X, [0.0])[2][0] == ORIENT


def test_search_turns_on_the_spot_left_or_right_at_random_and_repeats_under_a_seed():
    def turns(seed):
        brain = PlumeController(agents=1, seed=seed)
        out = [brain.step(np.zeros((1, 2)), WIND_PLUS_X, [0.0]) for _ in range(400)]
        assert all(b[0] == SEARCH and s[0] == SEARCH_STRIDE_RAD for _, s, b in out)  # never a straight run
        return np.array([t[0] for t, _, _ in out])

    first = turns(3)
    assert set(np.unique(first)) == {-1.0, 1.0}
    assert 0.4 < np.mean(first > 0) < 0.6
    np.testing.assert_array_equal(first, turns(3))
    assert not np.array_equal(first, turns(4))


def test_agents_in_a_batch_follow_their_own_branch():
    brain = PlumeController(agents=3, seed=0)
    odour = np.array([[1e-3, 0.0], [0.0, 0.0], [0.0, 2e-6]])
    wind = np.repeat(WIND_PLUS_X, 3, axis=0)
    heading = np.radians([0.0, 0.0, -180.0])  # the third faces −y: upwind −x is on its right
    turn, _, branch = brain.step(odour, wind, heading)
    np.testing.assert_array_equal(branch, [ORIENT, SEARCH, ORIENT])
    assert turn[0] == 1.0 and turn[2] == -1.0
    _, _, branch = brain.step(np.zeros((3, 2)), wind, heading)
    np.testing.assert_array_equal(branch, [STRAIGHT, SEARCH, STRAIGHT])


@pytest.mark.parametrize("kwargs", [dict(agents=0), dict(threshold=-1.0), dict(threshold=float("nan")),
                                    dict(straight_cycles=-1), dict(stride_rule="round")])
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(ConfigError):
        PlumeController(**kwargs)


def test_bad_shapes_are_refused_with_the_expected_shapes_named():
    with pytest.raises(ConfigError, match=r"odour \(1, 2"):
        PlumeController().step(np.zeros((1, 3)), WIND_PLUS_X, [0.0])
