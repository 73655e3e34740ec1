"""The sky compass without a body: TB1 follows the heading relative to the sun, read from the dorsal rim;
sky_stone2017 integrates a path from the sky and a body-frame odometer alone."""

import numpy as np
import pytest
from scipy import stats

from neuronav.angles import angle_difference_rad
from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.brains.sky_compass import (
    compass_errors_rad,
    decode_heading,
    reference_amplitude,
    sky_compass,
    sky_stone2017,
)
from neuronav.errors import ConfigError
from neuronav.senses.dorsal_rim import DorsalRim, head_rotations_from_headings
from neuronav.senses.sky import Sky

PUBLISHED_TB1_AT_0 = [0.0099, 0.0203, 0.6387, 0.8866, 0.9297, 0.8866, 0.6387, 0.0203]
SUN_AZIMUTHS = np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)
HEADINGS = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False) + 0.1


def errors_deg(elevation_deg, noise=0.1, pol_noise=0.1, cloud_cover=0.0, headings=HEADINGS):
    """|decoded - (heading - sun azimuth)| for every sun azimuth x heading, in degrees."""
    errors = [compass_errors_rad(Sky(sun_azimuth_rad=sun, sun_elevation_rad=np.radians(elevation_deg),
                                     cloud_cover=cloud_cover), headings, noise=noise, pol_noise=pol_noise, seed=k)
              for k, sun in enumerate(SUN_AZIMUTHS)]
    return np.degrees(np.abs(np.concatenate(errors)))


@pytest.mark.parametrize("column", range(8))
def test_decode_heading_reads_the_inverted_bump(column):
    assert decode_heading(np.roll(PUBLISHED_TB1_AT_0, column))[0] == pytest.approx(
        angle_difference_rad(column * np.pi / 4, 0.0), abs=1e-9)


def test_decode_heading_refuses_bad_shapes():
    with pytest.raises(ConfigError, match="tb1"):
        decode_heading(np.zeros((2, 7)))


def test_ports_no_true_heading_anywhere():
    assert [p.name for p in sky_compass().sensors] == ["pol"]
    assert sky_compass().sensors[0].shape == (DorsalRim().n_ommatidia,)
    brain = sky_stone2017()
    assert [p.name for p in brain.sensors] == ["body_velocity", "pol"]
    assert [p.name for p in brain.motors] == ["motor"]


@pytest.mark.parametrize("elevation_deg", [15, 30, 60])
def test_tb1_follows_the_heading_relative_to_the_sun_without_noise(elevation_deg):
    # Systematic error only (SOL saturation quantises toward the 45° columns): at most 5.0° measured.
    assert errors_deg(elevation_deg, noise=0.0, pol_noise=0.0).max() < 6.0


@pytest.mark.parametrize("elevation_deg, mean_deg, max_deg", [(15, 7.0, 25.0), (30, 7.0, 20.0), (60, 7.0, 20.0)])
def test_compass_error_with_noise_is_small(elevation_deg, mean_deg, max_deg):
    # 8 sun azimuths x 16 headings, the default noise (0.1 on SOL, CL1, TB1 and on each POL cell);
    # measured mean / max: 4.1 / 18.6° at 15°, 4.5 / 11.4° at 30°, 4.2 / 11.9° at 60°.
    errors = errors_deg(elevation_deg)
    assert errors.mean() < mean_deg and errors.max() < max_deg


def test_the_compass_mirrors_when_the_sun_moves_the_other_way():
    # Not a symmetric artefact: turning the sun clockwise moves the bump anticlockwise by as much.
    headings = np.zeros(1)
    decoded = []
    for sun in (0.5, 1.5):
        error = compass_errors_rad(Sky(sun_azimuth_rad=sun, sun_elevation_rad=np.radians(30)), headings,
                                   noise=0.0, pol_noise=0.0)
        decoded.append(error[0] + (0.0 - sun))
    assert angle_difference_rad(decoded[1], decoded[0]) == pytest.approx(-1.0, abs=np.radians(6))


def test_the_bump_is_steady_under_noise():
    # One agent holding its heading for 200 steps: the single-step decoded heading stays near the truth.
    rim = DorsalRim()
    sky = Sky(sun_azimuth_rad=2.0, sun_elevation_rad=np.radians(30))
    heading = 0.8
    pol = rim.responses(sky, head_rotations_from_headings(heading))
    brain = sky_compass().compile(batch=1, seed=5)
    decoded = []
    for _ in range(200):
        brain.step({"pol": pol})
        decoded.append(decode_heading(brain.rates("TB1"))[0])
    error = np.degrees(angle_difference_rad(np.array(decoded[20:]), heading - 2.0))
    assert abs(np.mean(error)) < 5.0 and np.percentile(np.abs(error), 95) < 25.0


def test_the_error_grows_with_cloud_cover():
    rng = np.random.default_rng(0)
    headings = rng.uniform(0.0, 2.0 * np.pi, 200)
    covers = [0.0, 0.5, 0.75, 0.9]
    errors = [np.degrees(np.abs(compass_errors_rad(Sky(sun_azimuth_rad=1.0, sun_elevation_rad=np.radians(30),
                                                       cloud_cover=c), headings))) for c in covers]
    means = [e.mean() for e in errors]
    # Measured: 4.2, 5.1, 9.8, 51° mean.
    assert means[0] < means[1] < means[2] < means[3]
    assert means[2] > 1.5 * means[0] and means[3] > 30.0
    rho, p = stats.spearmanr(np.repeat(covers, 200), np.concatenate(errors))
    assert rho > 0.2 and p < 1e-6


def test_no_direction_with_the_sun_on_the_horizon_or_the_zenith():
    # The degree pattern is symmetric about the zenith there: no first harmonic, no compass.
    rim = DorsalRim()
    assert reference_amplitude(rim, 0.0) < 1e-9 and reference_amplitude(rim, np.pi / 2) < 1e-9
    assert reference_amplitude(rim) == pytest.approx(0.4608, abs=1e-4)


@pytest.mark.parametrize("elevation_deg, ratio", [(5, 0.20), (15, 0.58), (30, 1.00), (45, 1.11), (60, 0.89),
                                                  (80, 0.32)])
def test_first_harmonic_amplitude_against_sun_elevation(elevation_deg, ratio):
    # The numbers of the module docstring (A / A_ref).
    amplitude = reference_amplitude(None, np.radians(elevation_deg))
    assert amplitude / reference_amplitude() == pytest.approx(ratio, abs=0.005)


def walk(brain, legs, sun, rim, true_heading=False):
    """Walk ``legs`` [(heading_rad, steps)] at 0.85 per step; return the final CPU4 memory (1, 16)."""
    sim = brain.compile(batch=1, seed=2)
    for heading, steps in legs:
        if true_heading:
            inputs = {"heading": np.full((1, 1), heading),
                      "velocity": 0.85 * np.array([[np.sin(heading), np.cos(heading)]])}
        else:
            inputs = {"pol": rim.responses(sun, head_rotations_from_headings(heading)),
                      "body_velocity": np.array([[0.85, 0.0]])}
        for _ in range(steps):
            sim.step(inputs)
    return sim.memory("CPU4")


def test_sky_stone2017_integrates_a_square_path_and_points_home():
    # North 200 steps, east 100, south 100, west 50: the nest lies at 180 + 63.4° from the end point.
    legs = [(0.0, 200), (np.pi / 2, 100), (np.pi, 100), (-np.pi / 2, 50)]
    end = 0.85 * np.array([50.0, 100.0])
    home_world = np.arctan2(-end[0], -end[1])
    rim = DorsalRim()
    for sun_azimuth in (0.0, 2.5):
        sky = Sky(sun_azimuth_rad=sun_azimuth, sun_elevation_rad=np.radians(40))
        direction, distance = decode_home_vector(walk(sky_stone2017(), legs, sky, rim))
        # The memory is in the sun's frame: add the sun's azimuth for the world direction.
        error = np.degrees(angle_difference_rad(direction[0] + sun_azimuth, home_world))
        assert abs(error) < 12.0, (sun_azimuth, error)
    true_direction, true_distance = decode_home_vector(walk(stone2017(), legs, None, rim, true_heading=True))
    assert abs(np.degrees(angle_difference_rad(true_direction[0], home_world))) < 12.0
    assert distance[0] == pytest.approx(true_distance[0], rel=0.3)


def test_sky_stone2017_reads_the_left_component_of_body_velocity():
    # Facing north while stepping forward-left (a crab walk, as a turning legged ant does): the ant
    # moves north-west, so the nest lies south-east (135°).
    rim = DorsalRim()
    sky = Sky(sun_azimuth_rad=1.0, sun_elevation_rad=np.radians(40))
    sim = sky_stone2017().compile(batch=1, seed=4)
    inputs = {"pol": rim.responses(sky, head_rotations_from_headings(0.0)), "body_velocity": np.array([[0.6, 0.6]])}
    for _ in range(250):
        sim.step(inputs)
    direction, _ = decode_home_vector(sim.memory("CPU4"))
    assert abs(np.degrees(angle_difference_rad(direction[0] + 1.0, np.radians(135)))) < 15.0


def test_bad_settings_are_refused():
    with pytest.raises(ConfigError, match="compass_gain"):
        sky_compass(compass_gain=0.0)
    with pytest.raises(ConfigError, match="pol_noise"):
        sky_compass(pol_noise=-1.0)
    with pytest.raises(ConfigError, match="rim"):
        sky_compass(rim="dorsal")


def test_the_error_tool_prints_its_table_and_trend(capsys):
    from neuronav.scenarios.tools import sky_compass_error

    assert sky_compass_error.main(["--elevations", "30", "--covers", "0,0.9", "--headings", "20"]) == 0
    out = capsys.readouterr().out
    assert "| 30° |" in out and "Spearman |error| vs cloud cover" in out
    errors = sky_compass_error.measure((30.0,), (0.0, 0.9), headings=20)
    assert errors.shape == (1, 2, 20) and errors[0, 1].mean() > errors[0, 0].mean()
