"""The trail-following controller against the paper's Table 3 (no body)."""

import math

import numpy as np
import pytest

from neuronav.brains.trail_following import K_D, SENSOR_SCALE, T_D, T_O, TrailFollowing
from neuronav.errors import ConfigError


def rng():
    return np.random.default_rng(0)


def test_table_3_values_and_the_documented_mapping():
    assert (T_D, T_O, K_D, SENSOR_SCALE) == (5.0, 900.0, 400.0, 1000.0)


def test_no_odour_on_either_antenna_searches_with_random_full_turns_and_a_3_degree_stride():
    controller = TrailFollowing()
    generator = rng()
    commands = [controller(0.0, 0.5, generator) for _ in range(200)]  # 500 < T_o = 900 on both
    turns = {turn for turn, _ in commands}
    assert turns == {-1.0, 1.0}
    assert all(stride == pytest.approx(math.radians(3.0)) for _, stride in commands)
    lefts = sum(turn > 0 for turn, _ in commands)
    assert 60 < lefts < 140  # both signs about equally often
    assert controller.state(0.899, 0.899) == "search"


def test_search_turns_repeat_under_a_seed():
    controller = TrailFollowing()
    first = [controller(0.0, 0.0, np.random.default_rng(4)) for _ in range(1)]
    again = [controller(0.0, 0.0, np.random.default_rng(4)) for _ in range(1)]
    assert first == again


def test_stronger_left_turns_left_and_stronger_right_turns_right_with_a_4_degree_stride():
    controller = TrailFollowing()
    turn, stride = controller(1.0, 0.0, rng())  # O_d = +1000: clipped to +1 (left)
    assert (turn, stride) == (1.0, pytest.approx(math.radians(4.0)))
    turn, stride = controller(0.0, 1.0, rng())
    assert (turn, stride) == (-1.0, pytest.approx(math.radians(4.0)))


def test_turn_is_the_difference_over_k_d_below_the_clip():
    controller = TrailFollowing()
    turn, _ = controller(1.0, 0.9, rng())  # O_d = 100 -> 100 / 400
    assert turn == pytest.approx(0.25)
    turn, _ = controller(0.92, 1.0, rng())  # O_d = -80 -> -0.2
    assert turn == pytest.approx(-0.2)
    turn, _ = controller(0.95, 0.0, rng())  # O_d = 950 -> 2.375, clipped
    assert turn == 1.0


def test_equal_odour_walks_straight_with_an_8_degree_stride_and_the_dead_band_is_t_d():
    controller = TrailFollowing()
    assert controller(1.0, 1.0, rng()) == (0.0, pytest.approx(math.radians(8.0)))
    assert controller(1.0, 0.995, rng())[0] == 0.0  # |O_d| = 5, not > T_d
    assert controller.state(1.0, 0.994) == "turn"  # |O_d| = 6 > T_d
    assert controller(0.95, 0.949, rng())[0] == 0.0


def test_thresholds_and_scale_are_parameters():
    controller = TrailFollowing(t_o=100.0, k_d=100.0, sensor_scale=100.0)
    assert controller.state(0.5, 0.5) == "search"  # 50 < 100
    assert controller(1.0, 0.5, rng())[0] == pytest.approx(0.5)
    assert TrailFollowing(t_d=0.0).state(1.0, 0.9999) == "turn"


@pytest.mark.parametrize("bad", [dict(t_d=-1.0), dict(t_o=0.0), dict(k_d=-3.0), dict(sensor_scale=float("nan")),
                                 dict(k_d="400")])
def test_bad_parameters_are_one_clear_config_error(bad):
    name = next(iter(bad))
    with pytest.raises(ConfigError, match=name):
        TrailFollowing(**bad)
