"""The odour trails' floor image against the trail field: where it lies, its colours, its blend, its cache,
and the kinematic ray caster painting it where its rays meet the floor."""

import dataclasses

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.scenarios.worlds.scenes import vision_appearance
from neuronav.senses.chemistry import OdourScene
from neuronav.senses.odour import ImageTrail, PolylineTrail, loop_trail, rasterise, straight_trail
from neuronav.senses.plume import PlumeConfig
from neuronav.senses.raycast import RayCaster
from neuronav.senses.trail_floor import (
    MARGIN_M,
    PIXEL_M,
    TRAIL_RGB,
    blend_rgb,
    build_trail_floor,
    ground_rgb_at,
    trail_floor,
)
from neuronav.senses.vision import LUMA_WEIGHTS, pixel_directions, to_uint8
from neuronav.spec.body import Camera
from neuronav.spec.world import Appearance, Ground, World

PLAIN = Appearance(ground_texture="plain", ground_rgb=(0.7, 0.6, 0.4))
BENT = PolylineTrail(np.array([[-1.3, -0.2], [0.4, -0.2], [0.4, 0.6]]), 0.15, 0.04)


def world_with(*trails, appearance=PLAIN, **kwargs) -> World:
    return World(appearance=appearance, odour=OdourScene(trails=trails), **kwargs)


def centres(floor):
    """The floor image's pixel centres, (H, W, 2)."""
    height, width = floor.shape_px
    xs = floor.x_range_m[0] + (np.arange(width) + 0.5) * floor.pixel_m
    ys = floor.y_range_m[1] - (np.arange(height) + 0.5) * floor.pixel_m
    return np.stack(np.meshgrid(xs, ys), axis=-1)


def test_a_straight_trail_is_trail_coloured_on_its_centre_line_and_ground_coloured_far_from_it():
    trail = straight_trail((0.0, 0.0), (12.0, 0.0))  # normal width 0.27 m
    floor = trail_floor(world_with(trail))
    assert floor.pixel_m == pytest.approx(PIXEL_M)
    # The rectangle holds the trail's reach plus the margin, corners on the pixel grid.
    reach = 0.5 * (trail.width_m + trail.edge_m) + MARGIN_M
    (x0, x1), (y0, y1) = floor.x_range_m, floor.y_range_m
    assert x0 <= -reach and x1 >= 12.0 + reach and y0 <= -reach and y1 >= reach
    assert x1 - x0 < 12.0 + 2 * reach + 2 * PIXEL_M and y1 - y0 < 2 * reach + 2 * PIXEL_M
    for corner in (x0, x1, y0, y1):
        assert corner / PIXEL_M == pytest.approx(round(corner / PIXEL_M), abs=1e-9)
    points = centres(floor)
    distance = np.abs(points[..., 1])
    on_line = (distance < 0.05) & (points[..., 0] > 0.0) & (points[..., 0] < 12.0)
    far = distance > reach - MARGIN_M
    assert on_line.sum() > 1000 and far.sum() > 1000
    assert (floor.image[on_line] == to_uint8(TRAIL_RGB)).all()
    assert (floor.image[far] == to_uint8(PLAIN.ground_rgb)).all()


@pytest.mark.parametrize("trails", [
    (BENT,),
    (loop_trail((1.0, -2.0), 1.5, "narrow"),),
    (straight_trail((-2.0, 1.0), (3.0, -1.5), "wide"),),
    # Two trails that cross: their concentrations add up, clipped to 1.
    (straight_trail((0.0, -1.0), (0.0, 1.0)), straight_trail((-1.0, 0.0), (1.0, 0.0), edge_m=0.2)),
    (ImageTrail(np.linspace(0.0, 1.0, 12).reshape(3, 4), (-0.5, 0.3), (0.2, 0.8)),),
])
def test_the_image_is_the_trail_field_at_the_pixel_centres(trails):
    floor = trail_floor(world_with(*trails))
    field = sum(rasterise(trail, floor.x_range_m, floor.y_range_m, floor.shape_px) for trail in trails)
    np.testing.assert_allclose(floor.concentration, np.clip(field, 0.0, 1.0), atol=1e-9)
    expected = to_uint8((1 - floor.concentration[..., None]) * np.array(PLAIN.ground_rgb)
                        + floor.concentration[..., None] * np.array(TRAIL_RGB))
    np.testing.assert_array_equal(floor.image, expected)
    # Every trail lies inside the rectangle: its field is 0 on the rectangle's outer pixels.
    assert floor.concentration[[0, -1]].max() == 0 and floor.concentration[:, [0, -1]].max() == 0


def test_the_blend_darkens_monotonically_from_the_ground_to_the_trail_colour():
    floor = trail_floor(world_with(BENT))
    order = np.argsort(floor.concentration, axis=None, kind="stable")
    # Every channel of this ground is lighter than the trail's: each falls (or stays) as c rises.
    channels = floor.image.reshape(-1, 3)[order].astype(int)
    assert np.all(np.diff(channels, axis=0) <= 0)
    np.testing.assert_array_equal(channels[[0, -1]], [to_uint8(PLAIN.ground_rgb), to_uint8(TRAIL_RGB)])
    # Intermediate concentrations exist (the raised-cosine edge) and give intermediate colours.
    edge = (floor.concentration > 0.2) & (floor.concentration < 0.8)
    assert edge.sum() > 20
    c = np.linspace(0.0, 1.0, 11)
    blended = blend_rgb(PLAIN.ground_rgb, c)
    assert np.all(np.diff(blended @ LUMA_WEIGHTS) < 0)
    np.testing.assert_allclose(blended[[0, -1]], [PLAIN.ground_rgb, TRAIL_RGB])
    np.testing.assert_allclose(blend_rgb(PLAIN.ground_rgb, [-0.5, 2.0]), [PLAIN.ground_rgb, TRAIL_RGB])


def test_the_trail_colour_is_darker_than_every_ground_and_lighter_than_a_dark_landmark():
    trail_grey = float(np.array(TRAIL_RGB) @ LUMA_WEIGHTS)
    assert trail_grey == pytest.approx(0.25, abs=0.01)
    grounds = [Appearance().ground_rgb, Appearance().checker_rgb, vision_appearance().ground_rgb]
    assert all(float(np.array(rgb) @ LUMA_WEIGHTS) > trail_grey + 0.2 for rgb in grounds)
    assert trail_grey > 25 / 255 + 0.1


def test_a_checker_ground_is_drawn_under_and_around_the_trail():
    look = Appearance(ground_texture="checker", checker_m=0.5)
    floor = trail_floor(world_with(BENT, appearance=look))
    points = centres(floor)
    expected = to_uint8(blend_rgb(ground_rgb_at(look, points[..., 0], points[..., 1]), floor.concentration))
    np.testing.assert_array_equal(floor.image, expected)
    off = floor.concentration == 0
    colours = {tuple(c) for c in floor.image[off]}
    assert colours == {tuple(to_uint8(look.ground_rgb)), tuple(to_uint8(look.checker_rgb))}
    # ground_rgb where floor(x/s) + floor(y/s) is even, as every backend draws its checker.
    np.testing.assert_array_equal(ground_rgb_at(look, [0.25, 0.75, -0.25], [0.25, 0.25, -0.25]),
                                  [look.ground_rgb, look.checker_rgb, look.ground_rgb])


@pytest.mark.parametrize("checker_m", [0.5, 0.3, 0.315])
def test_on_a_checker_ground_the_image_tiles_the_checker(checker_m):
    look = Appearance(ground_texture="checker", checker_m=checker_m)
    floor = trail_floor(world_with(BENT, appearance=look))
    period = 2 * checker_m
    # Corners on whole periods, a period a whole number of pixels, pixels no finer than asked.
    for corner in (*floor.x_range_m, *floor.y_range_m):
        assert corner / period == pytest.approx(round(corner / period), abs=1e-9)
    assert period / floor.pixel_m == pytest.approx(round(period / floor.pixel_m), abs=1e-9)
    assert PIXEL_M <= floor.pixel_m < PIXEL_M * 1.05
    # So the image continues periodically past its edges (what wrapping texture filters read there):
    # the row beyond the bottom edge is the top row, the column beyond the right edge the first.
    x1, y0 = floor.x_range_m[1], floor.y_range_m[0]
    points = centres(floor)
    below = to_uint8(ground_rgb_at(look, points[0, :, 0], y0 - floor.pixel_m / 2))
    right = to_uint8(ground_rgb_at(look, x1 + floor.pixel_m / 2, points[:, 0, 1]))
    np.testing.assert_array_equal(floor.image[0], below)
    np.testing.assert_array_equal(floor.image[:, 0], right)


def test_a_large_rectangle_on_a_checker_ground_keeps_to_the_side_limit():
    look = Appearance(ground_texture="checker", checker_m=0.5)
    for side_px in (64, 5):  # 2 or more pixels per period, then whole periods per pixel
        floor = build_trail_floor((loop_trail((0.0, 0.0), 3.0),), look, max_side_px=side_px)
        assert max(floor.shape_px) <= side_px
        assert floor.image.shape[:2] == floor.concentration.shape == floor.shape_px
        ratio = 1.0 / floor.pixel_m if floor.pixel_m < 1.0 else floor.pixel_m
        assert ratio == pytest.approx(round(ratio), abs=1e-9)


def test_rgb_at_is_the_nearest_texel_and_says_where_the_image_lies():
    floor = trail_floor(world_with(BENT))
    points = centres(floor)
    jitter = np.random.default_rng(0).uniform(-0.49, 0.49, points.shape) * floor.pixel_m
    rgb, inside = floor.rgb_at(points + jitter)
    assert inside.all()
    np.testing.assert_array_equal(rgb, floor.image)
    (x0, x1), (y0, y1) = floor.x_range_m, floor.y_range_m
    outside = np.array([[x0 - 1e-6, 0.0], [x1 + 1e-6, 0.0], [0.0, y0 - 1e-6], [0.0, y1 + 1e-6], [50.0, 50.0]])
    _, inside = floor.rgb_at(outside)
    assert not inside.any()
    # Height is ignored; any leading shape works.
    rgb3, inside3 = floor.rgb_at(np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)[None])
    np.testing.assert_array_equal(rgb3[0], floor.image)
    assert inside3.shape == (1, *floor.shape_px)
    with pytest.raises(ConfigError, match="shape"):
        floor.rgb_at(np.zeros((3, 4)))


def test_no_trail_or_an_uneven_ground_draws_nothing():
    assert trail_floor(World()) is None
    assert trail_floor(World(odour=OdourScene(plume=PlumeConfig()))) is None
    assert trail_floor(world_with(BENT, ground=Ground(kind="uneven", roughness_m=0.02))) is None
    # A wall's floor and an uneven ground without roughness are flat: the trail is drawn.
    assert trail_floor(world_with(BENT, ground=Ground(kind="wall"))) is not None
    assert trail_floor(world_with(BENT, ground=Ground(kind="uneven"))) is not None


def test_the_image_is_kept_per_trails_and_appearance():
    world = world_with(BENT)
    first = trail_floor(world)
    assert trail_floor(world_with(BENT)) is first  # the same trail objects and look: the same image
    assert trail_floor(world_with(BENT, appearance=vision_appearance())) is not first
    assert not first.image.flags.writeable and not first.concentration.flags.writeable


def test_a_large_rectangle_keeps_to_the_side_limit_with_square_pixels():
    trail = loop_trail((0.0, 0.0), 3.0)
    floor = build_trail_floor((trail,), PLAIN, max_side_px=64)
    assert max(floor.shape_px) <= 64
    assert floor.pixel_m > PIXEL_M
    assert floor.y_range_m[1] - floor.y_range_m[0] == pytest.approx(floor.shape_px[0] * floor.pixel_m)
    assert floor.concentration.max() == 1.0


def test_a_trail_of_unknown_extent_is_refused_by_name():
    class Cloud:
        odour = 0

        def concentration_at(self, points_m):
            return np.zeros(np.shape(points_m)[:-1])

    with pytest.raises(ConfigError, match="odour trail 1 \\(Cloud\\).*extent"):
        trail_floor(world_with(BENT, Cloud()))
    with pytest.raises(ConfigError, match="max_side_px"):
        build_trail_floor((BENT,), PLAIN, max_side_px=1)


# -- the kinematic ray caster ----------------------------------------------------------------------------
DOWN = Camera("down", "base", (0.0, 0.0, 0.0), width_px=64, height_px=48, fov_rad=(2.0, 1.7))
DOWN_FRAME = np.column_stack([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # looks along -z


def floor_points(eye_m):
    rays = pixel_directions(DOWN) @ DOWN_FRAME.T
    return np.asarray(eye_m[:2]) + (-eye_m[2] / rays[..., 2])[..., None] * rays[..., :2]


@pytest.mark.parametrize("appearance", [PLAIN, Appearance(ground_texture="checker", checker_m=0.3)])
def test_the_ray_caster_paints_the_floor_image_where_its_rays_meet_the_floor(appearance):
    world = world_with(BENT, appearance=appearance)
    eye = np.array([-0.2, 0.1, 0.8])
    image = RayCaster(world, pixel_directions(DOWN)).render(eye[None], DOWN_FRAME[None])[0]
    points = floor_points(eye)
    floor = trail_floor(world)
    rgb, inside = floor.rgb_at(points)
    assert 0.3 < inside.mean() < 0.95  # the rectangle and the ground around it are in view
    np.testing.assert_array_equal(image[inside], rgb[inside])
    trail = (image == to_uint8(TRAIL_RGB)).all(-1)
    assert trail.mean() > 0.05
    # Off the rectangle: the ground exactly as without trails.
    plain = RayCaster(dataclasses.replace(world, odour=OdourScene()), pixel_directions(DOWN))
    before = plain.render(eye[None], DOWN_FRAME[None])[0]
    np.testing.assert_array_equal(image[~inside], before[~inside])
    assert (image[inside] != before[inside]).any(-1).sum() >= trail.sum()


def test_the_ray_caster_is_unchanged_by_a_world_without_trails():
    eye = np.array([[0.3, -0.4, 0.7], [5.0, 2.0, 0.2]])
    frames = np.repeat(DOWN_FRAME[None], 2, axis=0)
    plume_only = World(appearance=PLAIN, odour=OdourScene(plume=PlumeConfig()))
    caster = RayCaster(plume_only, pixel_directions(DOWN))
    assert caster._trails is None
    np.testing.assert_array_equal(caster.render(eye, frames),
                                  RayCaster(World(appearance=PLAIN), pixel_directions(DOWN)).render(eye, frames))
