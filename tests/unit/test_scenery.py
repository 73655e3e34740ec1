"""The visual worlds: the landmark's size and colour, a seeded forest that keeps out of clear zones and
stays light, the compass scene's objects 13–17 m away, and a sky lighter than the ground."""

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.scenarios.worlds.scenes import TREE_GREY_MIN, compass_scene, forest, landmark, vision_appearance
from neuronav.senses.vision import grey


def footprint_m(obj):
    """Horizontal radius of an object about its position."""
    return float(np.hypot(*obj.size_m[:2])) if obj.shape == "box" else float(obj.size_m[0])


def bottom_m(obj):
    return obj.position_m[2] - (obj.size_m[0] if obj.shape == "sphere" else obj.size_m[-1])


def test_the_landmark_is_a_black_cylinder_standing_on_the_ground():
    mark = landmark()
    assert mark.shape == "cylinder" and mark.rgba[:3] == (0.0, 0.0, 0.0)
    assert mark.position_m[:2] == (0.0, 25.0) and bottom_m(mark) == 0.0
    assert mark.size_m == (1.0, 3.0)  # radius 1 m, 6 m tall (I2Bot §3.3.4; docs/parameters.md §7)
    other = landmark((3.0, -4.0), radius_m=0.5, height_m=2.0)
    assert other.position_m == (3.0, -4.0, 1.0) and other.size_m == (0.5, 1.0)


def test_the_same_seed_grows_the_same_forest():
    assert forest(20, seed=4) == forest(20, seed=4)
    assert forest(20, seed=4) != forest(20, seed=5)
    assert forest(0, seed=4) == ()


def test_trees_stand_in_their_ring_and_keep_out_of_clear_zones():
    clear = [(0.0, y, 8.0) for y in np.linspace(0.0, 25.0, 6)]
    centre = (0.0, 12.5)
    trees = forest(60, seed=1, inner_radius_m=5.0, outer_radius_m=55.0, clear=clear, centre_m=centre)
    assert len(trees) == 120
    trunks, crowns = trees[0::2], trees[1::2]
    assert all(t.shape == "cylinder" for t in trunks) and {c.shape for c in crowns} == {"cone", "sphere"}
    for trunk, crown in zip(trunks, crowns):
        assert bottom_m(trunk) == pytest.approx(0.0) and crown.position_m[:2] == trunk.position_m[:2]
        assert 5.0 <= np.hypot(trunk.position_m[0] - centre[0], trunk.position_m[1] - centre[1]) <= 55.0
        assert 4.0 <= crown.position_m[2] + crown.size_m[-1] <= 9.0 + 1e-9  # the tree's height
    for obj in trees:
        for x, y, radius in clear:
            assert np.hypot(obj.position_m[0] - x, obj.position_m[1] - y) >= radius + footprint_m(obj)


def test_every_part_of_a_tree_is_lighter_than_a_dark_landmark_threshold():
    for obj in forest(100, seed=7):
        assert grey(np.array(obj.rgba[:3])) >= TREE_GREY_MIN >= 0.25


def test_trunks_do_not_overlap():
    trunks = forest(80, seed=2, outer_radius_m=20.0)[0::2]
    xy = np.array([t.position_m[:2] for t in trunks])
    radius = np.array([t.size_m[0] for t in trunks])
    gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1)) - radius[:, None] - radius[None]
    assert gaps[~np.eye(len(trunks), dtype=bool)].min() >= 0.0


def test_impossible_or_bad_forests_are_clear_errors():
    with pytest.raises(ConfigError, match="cannot place 10 trees"):
        forest(10, seed=0, outer_radius_m=5.0, clear=[(0.0, 0.0, 30.0)])
    with pytest.raises(ConfigError, match="inner_radius_m < outer_radius_m"):
        forest(3, seed=0, inner_radius_m=10.0, outer_radius_m=5.0)
    with pytest.raises(ConfigError, match="height_m must be a range"):
        forest(3, seed=0, height_m=(5.0, 2.0))
    with pytest.raises(ConfigError, match="clear must be a list of"):
        forest(3, seed=0, clear=[(0.0, 1.0)])
    with pytest.raises(ConfigError, match="count must be a whole number"):
        forest(-1, seed=0)


def test_the_compass_scene_has_five_objects_13_to_17_m_away_at_distinct_bearings():
    world = compass_scene()
    shapes = sorted(o.shape for o in world.objects)
    assert shapes == ["box", "box", "cone", "cylinder", "sphere"]
    distances = [np.hypot(*o.position_m[:2]) for o in world.objects]
    assert all(13.0 <= d <= 17.0 for d in distances)
    bearings = np.sort([np.degrees(np.arctan2(o.position_m[0], o.position_m[1])) % 360 for o in world.objects])
    assert np.diff(np.append(bearings, bearings[0] + 360)).min() >= 30.0
    ball = next(o for o in world.objects if o.shape == "sphere")
    assert ball.rgba[0] > 0.8 and max(ball.rgba[1:3]) < 0.2  # the red ball
    assert all(bottom_m(o) == pytest.approx(0.0) for o in world.objects)
    assert world.ground.size_m == 12.0 and world.ground.is_flat
    assert world.appearance.ground_texture == "plain"


def test_the_vision_sky_is_lighter_than_the_plain_ground():
    look = vision_appearance()
    assert look.ground_texture == "plain" and look.horizon_rgb is not None
    ground = grey(np.array(look.ground_rgb))
    assert grey(np.array(look.sky_rgb)) > ground and grey(np.array(look.horizon_rgb)) > ground
    assert ground > 0.25  # and the ground is no dark landmark either
