"""The dorsal rim: its geometry in the head frame and its POL-neuron responses (Malus, opponent log ratio)."""

from dataclasses import dataclass, replace

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.dorsal_rim import (
    DorsalRim,
    acceptance_difference,
    head_rotations_from_headings,
    rotations_from_quaternions,
)
from neuronav.senses.sky import Sky


@dataclass(frozen=True)
class _Light:
    radiance: np.ndarray
    degree: np.ndarray
    evector: np.ndarray


@dataclass(frozen=True)
class UniformAngleSky:
    """A test sky: everywhere degree ``degree``, radiance 2, and the e-vector at ``angle_rad`` from the
    local meridian (the great circle through the zenith), turned about the view direction."""

    angle_rad: float
    degree: float = 0.6

    def light(self, directions):
        d = np.asarray(directions, float)
        horizontal = np.linalg.norm(d[..., :2], axis=-1, keepdims=True)
        # Meridian tangent toward the zenith: (-x z, -y z, x² + y²) / horizontal.
        meridian = np.concatenate([-d[..., :2] * d[..., 2:], horizontal ** 2], axis=-1) / horizontal
        across = np.cross(d, meridian)
        evector = np.cos(self.angle_rad) * meridian + np.sin(self.angle_rad) * across
        shape = d.shape[:-1]
        return _Light(np.full(shape, 2.0), np.full(shape, self.degree), evector)


def test_geometry_unit_directions_above_the_head_horizon_and_mirrored():
    rim = DorsalRim()
    assert rim.n_ommatidia == 160 and rim.directions.shape == (160, 3)
    np.testing.assert_allclose(np.linalg.norm(rim.directions, axis=1), 1.0)
    elevations = np.degrees(np.arcsin(rim.directions[:, 2]))
    assert elevations.min() == pytest.approx(40.0) and elevations.max() == pytest.approx(70.0)
    left, right = rim.directions[:80], rim.directions[80:]
    # Each eye looks contralaterally: the left eye's DRA sees the right half (y < 0), and the right
    # eye's is its mirror image about the sagittal (x-z) plane.
    assert np.all(left[:, 1] < 0) and np.all(right[:, 1] > 0)
    np.testing.assert_allclose(right, left * np.array([1.0, -1.0, 1.0]), atol=1e-15)
    # Together the eyes see a full ring: per row, 40 azimuths 9° apart.
    row = np.sort(np.degrees(rim.azimuths_rad[rim.elevations_rad == rim.elevations_rad[0]]) % 360)
    np.testing.assert_allclose(np.diff(row), 9.0)


def test_analyser_axes_are_unit_perpendicular_and_along_the_meridian():
    rim = DorsalRim()
    np.testing.assert_allclose(np.linalg.norm(rim.axes, axis=1), 1.0)
    np.testing.assert_allclose(np.einsum("mi,mi->m", rim.axes, rim.directions), 0.0, atol=1e-15)
    # Along the meridian: in the vertical plane through the view direction, tilted toward the zenith.
    np.testing.assert_allclose(np.cross(rim.directions, rim.axes)[:, 2], 0.0, atol=1e-15)
    assert np.all(rim.axes[:, 2] > 0)


def test_sky_directions_follow_heading_and_pitch():
    rim = DorsalRim()
    level = rim.sky_directions(head_rotations_from_headings(np.array([0.0, np.pi / 2])))
    # Heading north: head forward = +y, head left = -x; heading east: forward = +x, left = +y.
    d = rim.directions
    np.testing.assert_allclose(level[0], np.stack([-d[:, 1], d[:, 0], d[:, 2]], 1), atol=1e-15)
    np.testing.assert_allclose(level[1], np.stack([d[:, 0], d[:, 1], d[:, 2]], 1), atol=1e-15)
    pitched = rim.sky_directions(head_rotations_from_headings(0.0, pitch_rad=np.radians(20)))
    # Nose up: the forward-looking ommatidia rise, the backward-looking ones sink.
    forward = d[:, 0] > 0.5
    assert np.all(pitched[0, forward, 2] > level[0, forward, 2])
    assert np.all(pitched[0, d[:, 0] < -0.5, 2] < level[0, d[:, 0] < -0.5, 2])


def test_quaternions_give_the_same_rotation_as_headings():
    heading = np.array([0.3, -2.0])
    # A level head at heading h is the world rotated about +z by (pi/2 - h): forward (+x) goes to
    # (sin h, cos h, 0).
    angle = np.pi / 2 - heading
    quaternions = np.stack([np.cos(angle / 2), 0 * angle, 0 * angle, np.sin(angle / 2)], 1)
    np.testing.assert_allclose(rotations_from_quaternions(quaternions), head_rotations_from_headings(heading),
                               atol=1e-15)


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 45.0, 60.0, 90.0, 135.0])
def test_malus_opponent_log_ratio_at_known_evectors(angle_deg):
    rim = DorsalRim()
    sky = UniformAngleSky(np.radians(angle_deg), degree=0.6)
    response = rim.responses(sky, head_rotations_from_headings(0.7))
    k = (10.0 - 1.0) / (10.0 + 1.0)
    modulation = k * 0.6 * np.cos(2 * np.radians(angle_deg))
    np.testing.assert_allclose(response, np.log((1 + modulation) / (1 - modulation)), atol=1e-12)


def test_ideal_analyser_and_unpolarised_light():
    sky = UniformAngleSky(0.0, degree=0.5)
    ideal = DorsalRim(polarisation_sensitivity=np.inf).responses(sky, head_rotations_from_headings(0.0))
    np.testing.assert_allclose(ideal, np.log(3.0))  # (1 + 0.5) / (1 - 0.5)
    unpolarised = DorsalRim().responses(UniformAngleSky(0.0, degree=0.0), head_rotations_from_headings(0.0))
    np.testing.assert_array_equal(unpolarised, 0.0)


def test_occluded_ommatidia_read_zero():
    rim = DorsalRim()
    rotations = head_rotations_from_headings(np.array([0.0, 1.0, 2.0]))
    sky = Sky(sun_azimuth_rad=0.4, sun_elevation_rad=np.radians(30))
    free = rim.responses(sky, rotations)
    visible = np.ones((3, rim.n_ommatidia), bool)
    visible[1, :50] = False
    visible[2] = False
    blocked = rim.responses(sky, rotations, visible)
    assert np.abs(free).min() > 1e-3  # every ommatidium sees some polarisation in the open
    np.testing.assert_array_equal(blocked[1, :50], 0.0)
    np.testing.assert_array_equal(blocked[2], 0.0)
    np.testing.assert_array_equal(blocked[0], free[0])
    np.testing.assert_array_equal(blocked[1, 50:], free[1, 50:])
    np.testing.assert_array_equal(rim.responses(sky, rotations, np.ones_like(visible)), free)
    with pytest.raises(ConfigError, match="visible"):
        rim.responses(sky, rotations, visible[:, :10])


@pytest.mark.parametrize("samples", [1, 7])
def test_batch_equals_one_by_one(samples):
    rim = DorsalRim(acceptance_samples=samples)
    rng = np.random.default_rng(3)
    rotations = head_rotations_from_headings(rng.uniform(-np.pi, np.pi, 7), rng.normal(0, 0.2, 7),
                                             rng.normal(0, 0.2, 7))
    sky = Sky(sun_azimuth_rad=2.0, sun_elevation_rad=np.radians(50), cloud_cover=0.3)
    batch = rim.responses(sky, rotations)
    for n in range(7):
        np.testing.assert_allclose(batch[n], rim.responses(sky, rotations[n:n + 1])[0], rtol=0, atol=1e-14)


def test_responses_follow_the_real_sky_at_the_solar_meridian():
    # Sun due north at 30°; the head faces north. The ommatidium looking (almost) at the antisolar
    # meridian sees the e-vector across its meridian: the meridian channel reads less than the other.
    rim = DorsalRim()
    sky = Sky(sun_azimuth_rad=0.0, sun_elevation_rad=np.radians(30))
    response = rim.responses(sky, head_rotations_from_headings(0.0))[0]
    behind = np.argmin(np.abs(np.abs(rim.azimuths_rad) - np.pi) + rim.elevations_rad)
    assert response[behind] < -0.5
    assert response[behind] == pytest.approx(response[rim.n_ommatidia // 2 + behind], abs=1e-12)  # mirror eye


@pytest.mark.parametrize("elevation_deg", [10, 30, 60, 80])
def test_a_single_ray_stands_for_the_acceptance_field(elevation_deg):
    # The module docstring's claim: 7 rays over the 5.4° field change a response by under 0.01
    # (responses span about ±1.4).
    sky = Sky(sun_azimuth_rad=0.3, sun_elevation_rad=np.radians(elevation_deg))
    assert acceptance_difference(sky) < 0.01


def test_a_wide_acceptance_field_does_change_the_responses():
    # The check above can fail: with a 40° field the average differs clearly.
    sky = Sky(sun_azimuth_rad=0.3, sun_elevation_rad=np.radians(30))
    assert acceptance_difference(sky, DorsalRim(acceptance_angle_rad=np.radians(40))) > 0.05


@pytest.mark.parametrize("field, value", [
    ("rows", 0), ("columns", 1.5), ("rows", True), ("elevation_low_rad", 0.0), ("elevation_high_rad", 2.0),
    ("azimuth_span_rad", 4.0), ("acceptance_angle_rad", -0.1), ("acceptance_samples", 3),
    ("polarisation_sensitivity", 1.0), ("polarisation_sensitivity", float("nan")),
])
def test_bad_values_are_refused(field, value):
    with pytest.raises(ConfigError, match=field):
        replace(DorsalRim(), **{field: value})


def test_bad_rotations_are_refused():
    with pytest.raises(ConfigError, match="head_rotations"):
        DorsalRim().sky_directions(np.eye(3))
