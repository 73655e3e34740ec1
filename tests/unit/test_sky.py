"""The sky against the single-scattering Rayleigh formulas at known points, the sun's position against
the solar-position formulas, and the sky as a World field (neuronav/senses/sky.py, docs/parameters.md §11)."""

import math

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.sky import MAX_DEGREE, Sky, SkyLight, direction, solar_declination_rad
from neuronav.spec.world import World

RNG = np.random.default_rng(23)


def random_sky_directions(count):
    """Unit directions spread over the upper hemisphere, shape (count, 3)."""
    views = RNG.normal(size=(count, 3))
    views[:, 2] = np.abs(views[:, 2])
    return views / np.linalg.norm(views, axis=1, keepdims=True)


def rayleigh_degree(gamma_rad, max_degree=MAX_DEGREE):
    return max_degree * np.sin(gamma_rad) ** 2 / (1 + np.cos(gamma_rad) ** 2)


@pytest.mark.parametrize("azimuth_rad, elevation_rad", [(0.0, 0.0), (1.0, 0.3), (4.0, 1.2), (2.5, math.pi / 2)])
def test_degree_is_maximal_90_degrees_from_the_sun(azimuth_rad, elevation_rad):
    """Every point of the great circle 90° from the sun carries max_degree; here those above the horizon."""
    sky = Sky(sun_azimuth_rad=azimuth_rad, sun_elevation_rad=elevation_rad)
    sun = sky.sun_direction
    helper = np.array([0.0, 0.0, 1.0]) if abs(sun[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    first = np.cross(sun, helper)
    first /= np.linalg.norm(first)
    second = np.cross(sun, first)
    angles = np.linspace(0, 2 * np.pi, 73)
    circle = np.cos(angles)[:, None] * first + np.sin(angles)[:, None] * second
    circle = circle[circle[:, 2] >= 0]
    light = sky.light(circle)
    np.testing.assert_allclose(light.degree, MAX_DEGREE, atol=1e-12)
    assert light.degree.max() == pytest.approx(sky.light(random_sky_directions(2000)).degree.max(), abs=1e-2)


def test_degree_follows_the_rayleigh_formula():
    sky = Sky(sun_azimuth_rad=2.0, sun_elevation_rad=0.4, max_degree=0.7)
    views = random_sky_directions(500)
    gamma = np.arccos(np.clip(views @ sky.sun_direction, -1, 1))
    np.testing.assert_allclose(sky.light(views).degree, rayleigh_degree(gamma, 0.7), atol=1e-12)


def test_sun_and_antisun_are_unpolarised_with_a_valid_evector():
    sky = Sky(sun_azimuth_rad=0.7, sun_elevation_rad=0.0)  # antisun on the horizon: in view
    light = sky.light(np.stack([sky.sun_direction, -sky.sun_direction]))
    np.testing.assert_array_equal(light.degree, 0.0)
    np.testing.assert_allclose(np.linalg.norm(light.evector, axis=-1), 1.0)
    np.testing.assert_allclose(np.sum(light.evector * np.stack([sky.sun_direction, -sky.sun_direction]), axis=-1),
                               0.0, atol=1e-12)
    overhead = Sky(sun_azimuth_rad=0.0, sun_elevation_rad=math.pi / 2).light(np.array([0.0, 0.0, 1.0]))
    assert overhead.degree == 0.0
    assert np.linalg.norm(overhead.evector) == pytest.approx(1.0)
    assert overhead.evector[2] == pytest.approx(0.0)


@pytest.mark.parametrize("azimuth_rad", [0.0, 0.5, math.pi / 2, 2.0, math.pi, 4.5])
def test_zenith_evector_is_perpendicular_to_the_solar_meridian(azimuth_rad):
    """For sun azimuth a the zenith e-vector is horizontal, along (cos a, −sin a, 0) up to sign."""
    light = Sky(sun_azimuth_rad=azimuth_rad, sun_elevation_rad=0.5).light(np.array([0.0, 0.0, 1.0]))
    expected = np.array([math.cos(azimuth_rad), -math.sin(azimuth_rad), 0.0])
    assert abs(light.evector @ expected) == pytest.approx(1.0, abs=1e-12)
    assert light.degree == pytest.approx(rayleigh_degree(math.pi / 2 - 0.5))


def test_evector_is_a_unit_vector_perpendicular_to_view_and_sun():
    sky = Sky(sun_azimuth_rad=5.0, sun_elevation_rad=0.9)
    views = random_sky_directions(1000)
    evector = sky.light(views).evector
    np.testing.assert_allclose(np.linalg.norm(evector, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.sum(evector * views, axis=-1), 0.0, atol=1e-12)
    np.testing.assert_allclose(evector @ sky.sun_direction, 0.0, atol=1e-12)


def test_the_sky_is_symmetric_about_the_solar_meridian():
    """Mirroring a direction across the vertical plane through the sun keeps radiance and degree, and
    mirrors the e-vector axis."""
    azimuth_rad = 1.1
    sky = Sky(sun_azimuth_rad=azimuth_rad, sun_elevation_rad=0.6)
    view_azimuth = RNG.uniform(0, 2 * np.pi, 300)
    view_elevation = RNG.uniform(0, np.pi / 2, 300)
    views = direction(view_azimuth, view_elevation)
    mirrored = direction(2 * azimuth_rad - view_azimuth, view_elevation)
    light, light_mirrored = sky.light(views), sky.light(mirrored)
    np.testing.assert_allclose(light.degree, light_mirrored.degree, atol=1e-12)
    np.testing.assert_allclose(light.radiance, light_mirrored.radiance, rtol=1e-12)
    normal = np.array([math.cos(azimuth_rad), -math.sin(azimuth_rad), 0.0])  # the meridian plane's normal
    reflected = light.evector - 2 * (light.evector @ normal)[:, None] * normal
    np.testing.assert_allclose(np.abs(np.sum(reflected * light_mirrored.evector, axis=-1)), 1.0, atol=1e-9)


def test_below_the_horizon_is_dark_and_unpolarised():
    sky = Sky(sun_azimuth_rad=1.0, sun_elevation_rad=0.3)
    views = -random_sky_directions(200)
    views[:, 2] = np.minimum(views[:, 2], -1e-6)
    light = sky.light(views)
    np.testing.assert_array_equal(light.radiance, 0.0)
    np.testing.assert_array_equal(light.degree, 0.0)
    horizon = sky.light(np.array([[1.0, 0.0, 0.0], [1.0, 0.0, -0.0]]))  # on the horizon, either sign of zero
    np.testing.assert_allclose(horizon.radiance, horizon.radiance[0])
    assert np.isfinite(horizon.radiance).all() and (horizon.radiance > 0).all()


def test_radiance_follows_rayleigh_phase_and_brightens_towards_the_horizon():
    sky = Sky(sun_azimuth_rad=0.0, sun_elevation_rad=math.pi / 2)
    assert sky.light(np.array([0.0, 0.0, 1.0])).radiance == pytest.approx(1.0)
    # Sun overhead: along one vertical, phase (1 + sin² e)/2 falls, the CIE gradation rises, to the horizon.
    elevations = np.linspace(0, math.pi / 2, 10)
    radiance = sky.light(direction(0.3, elevations)).radiance
    phase = (1 + np.sin(elevations) ** 2) / 2
    gradation = (1 - np.exp(-0.32 / np.maximum(np.sin(elevations), 1e-300))) / (1 - math.exp(-0.32))
    np.testing.assert_allclose(radiance, phase * gradation, rtol=1e-12)
    assert radiance[0] > radiance[-1]


def test_cloud_cover_lowers_the_degree_monotonically_and_keeps_the_evector():
    views = random_sky_directions(300)
    lights = [Sky(sun_azimuth_rad=2.0, sun_elevation_rad=0.5, cloud_cover=c).light(views)
              for c in np.linspace(0, 1, 6)]
    degrees = np.stack([light.degree for light in lights])
    assert (np.diff(degrees, axis=0) < 0).all()
    np.testing.assert_array_equal(degrees[-1], 0.0)
    for light in lights:
        np.testing.assert_allclose(np.abs(np.sum(light.evector * lights[0].evector, axis=-1)), 1.0, atol=1e-12)
    ring = direction(np.linspace(0, 2 * np.pi, 37), 0.4)  # the radiance loses its sun-ward bias
    spread = [np.ptp(Sky(sun_azimuth_rad=2.0, sun_elevation_rad=0.5, cloud_cover=c).light(ring).radiance)
              for c in np.linspace(0, 1, 6)]
    assert (np.diff(spread) < 0).all()
    assert spread[-1] == pytest.approx(0.0, abs=1e-12)


def test_light_is_vectorised_over_any_leading_shape():
    sky = Sky(sun_azimuth_rad=3.0, sun_elevation_rad=0.2)
    views = random_sky_directions(24).reshape(2, 3, 4, 3)
    light = sky.light(views * 5.0)  # not unit: normalised
    assert light.radiance.shape == light.degree.shape == (2, 3, 4)
    assert light.evector.shape == (2, 3, 4, 3)
    flat = sky.light(views.reshape(-1, 3))
    np.testing.assert_allclose(light.degree.reshape(-1), flat.degree)
    np.testing.assert_allclose(light.evector.reshape(-1, 3), flat.evector)


def test_occluded_blanks_the_masked_directions():
    light = Sky().light(random_sky_directions(6))
    mask = np.array([True, False, True, False, False, False])
    blocked = light.occluded(mask)
    assert isinstance(blocked, SkyLight)
    np.testing.assert_array_equal(blocked.radiance[mask], 0.0)
    np.testing.assert_array_equal(blocked.degree[mask], 0.0)
    np.testing.assert_array_equal(blocked.radiance[~mask], light.radiance[~mask])
    np.testing.assert_array_equal(blocked.evector, light.evector)
    with pytest.raises(ConfigError, match="broadcast"):
        light.occluded(np.zeros(4, dtype=bool))
    with pytest.raises(ConfigError, match="booleans"):
        light.occluded(np.zeros(6))


def test_solar_noon_puts_the_sun_due_south_at_90_minus_latitude_minus_declination():
    for latitude_deg, day in ((35.5, 172), (50.0, 1), (23.0, 80), (10.0, 300)):
        sky = Sky.from_place(latitude_deg, day, 12.0)
        declination_deg = math.degrees(solar_declination_rad(day))
        assert sky.sun_azimuth_rad == pytest.approx(math.pi, abs=1e-9)
        assert math.degrees(sky.sun_elevation_rad) == pytest.approx(90 - abs(latitude_deg - declination_deg), abs=1e-9)


def test_spencer_declination_at_the_solstices_and_equinox():
    assert math.degrees(solar_declination_rad(172)) == pytest.approx(23.45, abs=0.1)  # 21 June
    assert math.degrees(solar_declination_rad(355)) == pytest.approx(-23.45, abs=0.1)  # 21 December
    assert abs(math.degrees(solar_declination_rad(80))) < 0.5  # 21 March


def test_equinox_morning_sun_is_near_the_east_horizon():
    for latitude_deg in (0.0, 35.0):
        sky = Sky.from_place(latitude_deg, 81, 6.0)
        assert sky.sun_azimuth_rad == pytest.approx(math.pi / 2, abs=math.radians(1.0))
        assert 0 <= math.degrees(sky.sun_elevation_rad) < 0.5
    afternoon = Sky.from_place(35.0, 81, 16.0)
    assert math.pi < afternoon.sun_azimuth_rad < 2 * math.pi  # west of the meridian


def test_from_place_passes_the_other_fields_and_refuses_the_night():
    sky = Sky.from_place(30.0, 172, 9.0, cloud_cover=0.4, max_degree=0.6)
    assert (sky.cloud_cover, sky.max_degree) == (0.4, 0.6)
    with pytest.raises(ConfigError, match="below the horizon"):
        Sky.from_place(30.0, 172, 0.0)


@pytest.mark.parametrize("kwargs, field", [
    ({"sun_azimuth_rad": float("nan")}, "sun_azimuth_rad"),
    ({"sun_azimuth_rad": "north"}, "sun_azimuth_rad"),
    ({"sun_elevation_rad": -0.1}, "sun_elevation_rad"),
    ({"sun_elevation_rad": 1.6}, "sun_elevation_rad"),
    ({"cloud_cover": 1.5}, "cloud_cover"),
    ({"cloud_cover": -0.1}, "cloud_cover"),
    ({"max_degree": 0.0}, "max_degree"),
    ({"max_degree": 1.2}, "max_degree"),
    ({"max_degree": True}, "max_degree"),
])
def test_bad_values_raise_config_error_naming_the_field(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        Sky(**kwargs)


@pytest.mark.parametrize("args, field", [((91, 100, 12), "latitude_deg"), ((0, 0, 12), "day_of_year"),
                                         ((0, 100, 25), "solar_hour"), ((0, 100, float("nan")), "solar_hour")])
def test_from_place_refuses_values_out_of_range(args, field):
    with pytest.raises(ConfigError, match=field):
        Sky.from_place(*args)


def test_azimuth_is_wrapped_to_one_turn():
    assert Sky(sun_azimuth_rad=-math.pi / 2).sun_azimuth_rad == pytest.approx(3 * math.pi / 2)
    assert Sky(sun_azimuth_rad=5 * math.pi).sun_azimuth_rad == pytest.approx(math.pi)
    np.testing.assert_allclose(Sky(sun_azimuth_rad=math.pi / 2, sun_elevation_rad=0.0).sun_direction, [1, 0, 0],
                               atol=1e-15)  # east


def test_bad_directions_raise_config_error():
    sky = Sky()
    for bad in (np.zeros((2, 3)), np.ones((4, 2)), np.array([np.nan, 0, 1]), 1.0):
        with pytest.raises(ConfigError, match="directions|direction"):
            sky.light(bad)


def test_world_holds_a_sky_or_none():
    assert World().sky is None
    sky = Sky.from_place(35.5, 172, 10.0)
    assert World(sky=sky).sky is sky
    with pytest.raises(ConfigError, match="world sky"):
        World(sky="clear")
