"""The ventral optic-flow odometer's image motion and ground geometry (neuronav.senses.optic_flow), on
synthetic images with known shifts."""

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.optic_flow import camera_displacement_m, image_shift_px, metres_per_pixel

ROWS, COLS = np.mgrid[0:32, 0:32].astype(float)


def texture(rows, cols):
    """A smooth grey texture with structure in every direction."""
    return (0.5 + 0.2 * np.sin(0.4 * rows + 0.3 * cols) + 0.15 * np.cos(0.25 * cols - 0.5 * rows + 1.0)
            + 0.1 * np.sin(0.7 * cols))


def checker(rows, cols, shift=(0.0, 0.0), square_px=20.0):
    """The default ground's checker as a hard-edged image, moved by ``shift`` (rows, columns) px."""
    odd = (np.floor((rows - shift[0] - 5.0) / square_px) + np.floor((cols - shift[1] - 9.0) / square_px)) % 2
    return np.where(odd == 1, 0.58, 0.77)


@pytest.mark.parametrize("shift", [(0.3, -0.2), (1.5, 0.7), (-2.5, 2.0), (0.0, -1.0)])
def test_a_shifted_texture_gives_its_shift(shift):
    measured = image_shift_px(texture(ROWS, COLS), texture(ROWS - shift[0], COLS - shift[1]))
    np.testing.assert_allclose(measured, shift, atol=0.06)


def test_a_checker_corner_moved_a_pixel_gives_the_pixel():
    np.testing.assert_allclose(image_shift_px(checker(ROWS, COLS), checker(ROWS, COLS, (1.0, -1.0))), (1.0, -1.0),
                               atol=0.05)


def test_a_plain_image_gives_no_estimate():
    plain = np.full((32, 32), 0.77)
    assert image_shift_px(plain, plain) is None
    assert image_shift_px(plain, plain + 0.1) is None  # a change of brightness is no motion


def test_a_single_edge_gives_only_the_motion_across_it():
    """The aperture problem: an edge along the columns shows the row motion, none along it."""
    edge = lambda rows: np.where(rows < 15.5, 0.58, 0.77) + 0.0 * COLS  # noqa: E731
    measured = image_shift_px(edge(ROWS), edge(ROWS - 1.0))
    np.testing.assert_allclose(measured, (1.0, 0.0), atol=0.05)


def test_pinhole_ground_scale():
    """A 90° camera 0.4 m up sees 0.8 m of ground across its 32 pixels: 2.5 cm per pixel."""
    np.testing.assert_allclose(metres_per_pixel(0.4, (np.pi / 2, np.pi / 2), (32, 32)), (0.025, 0.025))
    np.testing.assert_allclose(metres_per_pixel(0.4, (np.pi / 2, np.pi / 3), (16, 32)),
                               (2 * 0.4 * np.tan(np.pi / 6) / 16, 0.025))


def test_a_known_shift_gives_a_known_speed():
    """The ground's image moves 2 px down and 1 px left in 16 ms: the camera moved 5 cm toward its image top
    and 2.5 cm toward its right (the ground moves opposite): 3.125 m/s and 1.5625 m/s."""
    shift = image_shift_px(texture(ROWS, COLS), texture(ROWS - 2.0, COLS + 1.0))
    moved = camera_displacement_m(shift, 0.4, (np.pi / 2, np.pi / 2), (32, 32))
    np.testing.assert_allclose(moved / 0.016, (1.5625, 3.125), rtol=0.03)


def test_images_of_different_shapes_are_refused():
    with pytest.raises(ConfigError, match="one shape"):
        image_shift_px(np.zeros((8, 8)), np.zeros((8, 9)))
