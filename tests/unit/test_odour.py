"""Odour trails: the documented profile (flat top, raised-cosine edge), the loop, image trails, bad inputs."""

from __future__ import annotations

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.odour import (
    DEFAULT_EDGE_M,
    TRAIL_WIDTHS_M,
    ImageTrail,
    PolylineTrail,
    loop_trail,
    rasterise,
    straight_trail,
)


def _across(trail, offsets_m):
    """Concentration at lateral offsets from the middle of a trail along x from (0, 0) to (10, 0)."""
    points = np.stack([np.full_like(offsets_m, 5.0), offsets_m], axis=-1)
    return trail.concentration_at(points)


@pytest.mark.parametrize("name", sorted(TRAIL_WIDTHS_M))
def test_trail_profile_inside_edge_outside(name):
    trail = straight_trail((0.0, 0.0), (10.0, 0.0), width=name)
    half, edge = 0.5 * TRAIL_WIDTHS_M[name], DEFAULT_EDGE_M
    inside = np.linspace(-(half - edge / 2), half - edge / 2, 41)
    assert np.all(_across(trail, inside) == 1.0)
    assert np.allclose(_across(trail, np.array([-half, half])), 0.5)
    outside = np.concatenate([np.linspace(half + edge / 2, half + 3, 30), -np.linspace(half + edge / 2, 5, 30)])
    assert np.all(_across(trail, outside) == 0.0)
    ramp = _across(trail, np.linspace(half - edge / 2, half + edge / 2, 51))
    assert np.all(np.diff(ramp) < 0)  # strictly falling across the edge


@pytest.mark.parametrize("name", sorted(TRAIL_WIDTHS_M))
def test_trail_full_width_at_half_maximum_is_its_width(name):
    trail = straight_trail((0.0, 0.0), (10.0, 0.0), width=name)
    step_m = 1e-4
    offsets = np.arange(-1.0, 1.0, step_m) + step_m / 2
    measured = (_across(trail, offsets) >= 0.5).sum() * step_m
    assert measured == pytest.approx(TRAIL_WIDTHS_M[name], abs=2 * step_m)


def test_trail_edge_is_smooth_and_beyond_ends_falls_off():
    trail = straight_trail((0.0, 0.0), (10.0, 0.0), width=0.27, edge_m=0.04)
    # continuous slope: the steepest drop between samples 1 mm apart is the raised cosine's π/(2e)
    offsets = np.arange(0.0, 0.3, 1e-3)
    slope = np.abs(np.diff(_across(trail, offsets))) / 1e-3
    assert slope.max() == pytest.approx(np.pi / (2 * 0.04), rel=3e-3)
    assert slope[0] == 0.0 and slope[-1] == 0.0 and np.all(slope < 1.01 * np.pi / (2 * 0.04))
    # past the end the distance is to the end point: same profile in the x direction
    beyond = trail.concentration_at(np.array([[10.0 + 0.135, 0.0], [10.5, 0.0], [-0.5, 0.0]]))
    assert beyond == pytest.approx([0.5, 0.0, 0.0])


def test_query_is_vectorised_over_any_leading_shape_and_ignores_height():
    trail = straight_trail((0.0, 0.0), (10.0, 0.0), width="normal")
    rng = np.random.default_rng(0)
    tips = rng.uniform([0, -0.5, 0], [10, 0.5, 0.3], size=(100, 2, 3))
    out = trail.concentration_at(tips)
    assert out.shape == (100, 2)
    one_by_one = np.array([[trail.concentration_at(tip[:2]) for tip in agent] for agent in tips])
    assert np.array_equal(out, one_by_one)
    assert np.array_equal(out, trail.concentration_at(tips[..., :2]))


def test_loop_trail_is_closed_everywhere_along_its_circle():
    trail = loop_trail((1.0, -2.0), radius_m=2.0, width="narrow")
    assert trail.closed
    angles = np.linspace(0, 2 * np.pi, 3601)
    on_circle = np.stack([1.0 + 2.0 * np.cos(angles), -2.0 + 2.0 * np.sin(angles)], axis=-1)
    assert np.all(trail.concentration_at(on_circle) == 1.0)
    # the closing segment (last vertex -> first) counts: half-way along it is on the trail
    last, first = trail.vertices_m[-1], trail.vertices_m[0]
    assert trail.concentration_at((last + first) / 2) == 1.0
    assert trail.length_m == pytest.approx(2 * np.pi * 2.0, rel=1e-3)
    assert trail.concentration_at(np.array([1.0, -2.0])) == 0.0  # the centre is off the trail
    open_trail = PolylineTrail(trail.vertices_m, "narrow")
    assert open_trail.concentration_at((last + first) / 2) < 1.0


def test_image_trail_matches_its_image_at_pixel_centres_and_is_bilinear_between():
    rng = np.random.default_rng(3)
    image = rng.uniform(0, 1, size=(7, 11))
    trail = ImageTrail(image, (-1.0, 1.2), (2.0, 3.4))
    h, w = image.shape
    dx, dy = 2.2 / w, 1.4 / h
    cols, rows = np.meshgrid(np.arange(w), np.arange(h))
    centres = np.stack([-1.0 + (cols + 0.5) * dx, 3.4 - (rows + 0.5) * dy], axis=-1)
    assert np.allclose(trail.concentration_at(centres), image)
    assert np.allclose(trail.rasterise((-1.0, 1.2), (2.0, 3.4), (h, w)), image)
    between = (centres[2, 3] + centres[3, 4]) / 2
    expected = image[2:4, 3:5].mean()
    assert trail.concentration_at(between) == pytest.approx(expected)
    outside = np.array([[-1.01, 3.0], [1.21, 3.0], [0.0, 1.99], [0.0, 3.41]])
    assert np.all(trail.concentration_at(outside) == 0.0)


def test_image_trail_reads_uint8_as_fraction_of_255():
    image = np.array([[0, 255], [51, 102]], dtype=np.uint8)
    trail = ImageTrail(image, (0.0, 2.0), (0.0, 2.0))
    assert trail.rasterise((0.0, 2.0), (0.0, 2.0), (2, 2)) == pytest.approx(image / 255.0)


def test_rasterise_orientation_row_zero_is_the_largest_y():
    trail = straight_trail((0.0, 0.9), (1.0, 0.9), width=0.1, edge_m=0.0)
    image = rasterise(trail, (0.0, 1.0), (0.0, 1.0), (10, 5))
    assert image.shape == (10, 5)
    assert np.all(image[0] == 1.0) and np.all(image[1:] == 0.0)


@pytest.mark.parametrize("make, match", [
    (lambda: straight_trail((0, 0), (1, 0), width="medium"), "trail width"),
    (lambda: straight_trail((0, 0), (1, 0), width=-0.1), "trail width"),
    (lambda: straight_trail((0, 0), (1, 0), width=0.1, edge_m=0.2), "edge_m"),
    (lambda: PolylineTrail(np.array([[0.0, 0.0]])), "vertices_m"),
    (lambda: PolylineTrail(np.array([[0.0, 0.0], [0.0, 0.0]])), "zero length"),
    (lambda: PolylineTrail(np.array([[0.0, 0.0], [np.nan, 1.0]])), "finite"),
    (lambda: loop_trail(n_vertices=2), "n_vertices"),
    (lambda: loop_trail(radius_m=0), "radius_m"),
    (lambda: ImageTrail(np.zeros((2, 2, 3)), (0, 1), (0, 1)), "greyscale"),
    (lambda: ImageTrail(np.full((2, 2), 1.5), (0, 1), (0, 1)), r"\[0, 1\]"),
    (lambda: ImageTrail(np.zeros((2, 2)), (1, 0), (0, 1)), "x_range_m"),
    (lambda: straight_trail((0, 0), (1, 0)).concentration_at(np.zeros((3, 4))), "query points"),
    (lambda: rasterise(straight_trail((0, 0), (1, 0)), (0, 1), (0, 1), (0, 4)), "shape_px"),
])
def test_bad_trail_inputs_are_refused(make, match):
    with pytest.raises(ConfigError, match=match):
        make()
