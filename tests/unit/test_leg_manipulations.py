"""Per-segment leg factors of the desert ant and Wittlinger et al. 2006's named manipulations
(bodies/desert_ant/body.py ``leg_segment_factors``, bodies/desert_ant/manipulations.py)."""

from __future__ import annotations

import pytest

from neuronav.bodies.desert_ant import LEG_SEGMENTS, LEGS, desert_ant, leg_geometry
from neuronav.bodies.desert_ant.manipulations import (
    MANIPULATIONS,
    STILTS_FACTOR,
    STUMPS_SEGMENT_FACTORS,
    leg_length_ratio,
    leg_manipulation,
    manipulated_ant,
)
from neuronav.errors import ConfigError


@pytest.fixture(scope="module")
def ant():
    return desert_ant()


def lengths(body) -> dict[str, dict[str, float]]:
    geometry = leg_geometry(body)
    return {leg: {segment: geometry[leg][f"{segment}_m"] for segment in LEG_SEGMENTS} for leg in LEGS}


@pytest.mark.parametrize("factors", [None, {}, {"tibia": 1.0}])
def test_no_segment_factor_leaves_the_ant_bit_identical(ant, factors):
    assert desert_ant(leg_segment_factors=factors) == ant


def test_a_segment_factor_scales_that_segment_on_every_leg_only(ant):
    before, after = lengths(ant), lengths(desert_ant(leg_segment_factors={"tibia": 0.5, "tarsus": 2.0}))
    for leg in LEGS:
        assert after[leg]["tibia"] == pytest.approx(0.5 * before[leg]["tibia"], rel=1e-12)
        assert after[leg]["tarsus"] == pytest.approx(2.0 * before[leg]["tarsus"], rel=1e-12)
        for segment in ("coxa", "femur"):
            assert after[leg][segment] == pytest.approx(before[leg][segment], rel=1e-12)


def test_segment_factors_multiply_the_leg_factor(ant):
    both = lengths(desert_ant(leg_length_factors=1.2, leg_segment_factors={"femur": 0.5}))
    for leg, segments in lengths(ant).items():
        assert both[leg]["femur"] == pytest.approx(0.6 * segments["femur"], rel=1e-12)
        assert both[leg]["tibia"] == pytest.approx(1.2 * segments["tibia"], rel=1e-12)


def test_shorter_distal_segments_lower_the_standing_ant(ant):
    shorter = desert_ant(leg_segment_factors={"tibia": 0.8})
    assert shorter.spawn_height_m < ant.spawn_height_m
    assert shorter.total_mass_kg < ant.total_mass_kg  # the legs' mass follows their volume


@pytest.mark.parametrize("factors, match", [
    ({"claw": 1.1}, "'claw'"),
    ({"tibia": 0.0}, "leg_segment_factors"),
    ({"tibia": float("inf")}, "leg_segment_factors"),
    (0.5, "mapping"),
])
def test_bad_segment_factors_are_config_errors(factors, match):
    with pytest.raises(ConfigError, match=match):
        desert_ant(leg_segment_factors=factors)


def test_normal_is_the_published_ant(ant):
    assert leg_manipulation("normal") == {}
    assert manipulated_ant("normal") == ant


def test_stumps_cut_the_tibia_in_half_and_lose_the_tarsus(ant):
    stumps = lengths(manipulated_ant("stumps"))
    for leg, segments in lengths(ant).items():
        assert stumps[leg]["tibia"] == pytest.approx(0.5 * segments["tibia"], rel=1e-12)
        assert stumps[leg]["tarsus"] < 0.1 * segments["tarsus"]
        assert stumps[leg]["femur"] == pytest.approx(segments["femur"], rel=1e-12)
    # The standing height keeps the posture's proportions: 0.43 m times the legs' length ratio (~0.55),
    # so the trunk stays off the ground (the gaster's radius is 0.093 m).
    height = manipulated_ant("stumps").spawn_height_m
    assert height == pytest.approx(0.43 * leg_length_ratio(STUMPS_SEGMENT_FACTORS), rel=1e-9)
    assert 0.2 < height < 0.25


def test_stilts_lengthen_every_leg(ant):
    stilts = lengths(manipulated_ant("stilts"))
    for leg, segments in lengths(ant).items():
        for segment, length in segments.items():
            assert stilts[leg][segment] == pytest.approx(STILTS_FACTOR * length, rel=1e-12)
    assert STILTS_FACTOR > 1.0


def test_manipulations_follow_the_scale():
    small = manipulated_ant("stumps", scale=0.5)
    assert small.spawn_height_m == pytest.approx(0.5 * manipulated_ant("stumps").spawn_height_m, rel=1e-9)


def test_unknown_or_clashing_manipulations_are_config_errors():
    assert MANIPULATIONS == ("normal", "stilts", "stumps")
    with pytest.raises(ConfigError, match="stilts"):
        leg_manipulation("tiptoes")
    with pytest.raises(ConfigError, match="standing_height_m"):
        manipulated_ant("stumps", standing_height_m=0.3)
