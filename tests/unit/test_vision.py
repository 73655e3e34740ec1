"""The one camera model (neuronav.senses.vision): pixel rays, cube faces, supersampling, the sky, grey."""

import numpy as np
import pytest

from neuronav import ConfigError
from neuronav.senses.vision import (
    CUBE_FACE_ROTATIONS,
    average_samples,
    camera_views,
    compose_image,
    cube_lookup,
    grey,
    pixel_directions,
    sampling_camera,
    sky_rgb,
)
from neuronav.spec.body import Camera
from neuronav.spec.world import Appearance

PANORAMA = Camera("pano", "head", (0.0, 0.0, 0.0), width_px=72, height_px=72, fov_rad=(2 * np.pi, np.pi),
                  projection="spherical")
EYE = Camera("eye", "head", (0.0, 0.0, 0.0), width_px=74, height_px=19, fov_rad=(2.0, 0.5))


def test_planar_rays_span_the_declared_fields_of_view_with_non_square_pixels():
    rays = pixel_directions(EYE)
    assert rays.shape == (19, 74, 3)
    assert np.allclose(np.linalg.norm(rays, axis=-1), 1.0)
    # The image's edges (not its edge pixels' centres) are at ±fov/2: extrapolate half a pixel.
    left_edge = np.tan(1.0) * (2 * 0.0 / 74 - 1)
    centre_col = rays[9, :, 0] / -rays[9, :, 2]
    assert centre_col[0] == pytest.approx(np.tan(1.0) * (2 * 0.5 / 74 - 1)) and left_edge == pytest.approx(-np.tan(1.0))
    assert rays[0, 37, 1] / -rays[0, 37, 2] == pytest.approx(np.tan(0.25) * (1 - 1 / 19))


def test_spherical_columns_are_azimuths_rows_are_elevations():
    rays = pixel_directions(PANORAMA)
    azimuth = np.degrees(np.arctan2(rays[36, :, 0], -rays[36, :, 2]))
    assert azimuth[36] == pytest.approx(2.5) and azimuth[35] == pytest.approx(-2.5)  # forward between 35 and 36
    assert np.allclose(np.diff(azimuth[1:-1]), 5.0)
    elevation = np.degrees(np.arcsin(rays[:, 10, 1]))
    assert elevation[0] == pytest.approx(90 - 1.25) and elevation[-1] == pytest.approx(-90 + 1.25)


def test_cube_faces_are_rotations_and_cover_the_sphere():
    for rotation in CUBE_FACE_ROTATIONS:
        assert np.allclose(rotation.T @ rotation, np.eye(3)) and np.linalg.det(rotation) == pytest.approx(1.0)
    lookup = cube_lookup(PANORAMA)
    assert lookup.faces == (0, 1, 2, 3, 4, 5) and lookup.face_px == 36
    # The pixel looking straight ahead samples the front face's centre.
    assert lookup.face[36, 36] == 0 and abs(lookup.col[36, 36] - 18) <= 1 and abs(lookup.row[36, 36] - 18) <= 1


def test_supersampling_renders_k_by_k_samples_and_averages_them():
    camera = Camera("pano", "head", (0.0, 0.0, 0.0), width_px=72, height_px=72, fov_rad=(2 * np.pi, np.pi),
                    projection="spherical", supersample=4)
    assert (sampling_camera(camera).width_px, sampling_camera(camera).height_px) == (288, 288)
    assert cube_lookup(camera).face.shape == (288, 288) and cube_lookup(camera).face_px == 144
    samples = np.zeros((8, 8, 3), np.uint8)
    samples[:, :3] = 255  # 3 of each 4 sample columns of the first pixel column are white
    averaged = average_samples(samples, 4)
    assert averaged.shape == (2, 2, 3)
    assert averaged[0, 0, 0] == round(255 * 3 / 4) and averaged[0, 1, 0] == 0
    planar = Camera("eye", "head", (0.0, 0.0, 0.0), width_px=74, height_px=19, fov_rad=(2.0, 0.5), supersample=2)
    (view,) = camera_views(planar, np.zeros(3), np.eye(3))
    assert (view.width_px, view.height_px) == (148, 38)


@pytest.mark.parametrize("bad", [0, 9, 2.5, True])
def test_supersample_out_of_range_is_refused(bad):
    from neuronav.senses.vision import check_camera

    with pytest.raises(ConfigError, match="supersample"):
        check_camera(Camera("eye", "head", (0.0, 0.0, 0.0), supersample=bad))


def test_compose_paints_the_sky_from_each_samples_direction():
    look = Appearance(sky_rgb=(0.2, 0.4, 0.8), horizon_rgb=(1.0, 1.0, 1.0))
    camera = Camera("up", "head", (0.0, 0.0, 0.0), width_px=4, height_px=4, fov_rad=(0.2, 0.2))
    rotation = np.array([[-1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]])  # looks up: the camera's -z is world +z
    image = compose_image(camera, rotation, [(np.zeros((4, 4, 3), np.uint8), np.ones((4, 4), bool))], look)
    expected = np.rint(255 * sky_rgb(look, pixel_directions(camera) @ rotation.T)).astype(np.uint8)
    assert np.array_equal(image, expected)
    assert (image[..., 0] < 60).all() and (image[..., 2] > 200).all()  # near the zenith: the top colour


def test_grey_is_bt601_luma_in_unit_range():
    rgb = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]], np.uint8)
    assert np.allclose(grey(rgb)[0], [0.299, 0.587, 0.114, 1.0])
