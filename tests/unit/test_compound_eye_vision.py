"""Early vision from compound eyes: the ommatidia laid out as the compass's panorama and the beacon's eye
images (neuronav.senses.compound_eye_vision), and eyes=compound on visual-beacon and visual-compass."""

import numpy as np
import pytest

from neuronav.bodies.desert_ant import desert_ant
from neuronav.brains.vision import ZernikeBasis, landmark_offset_px
from neuronav.config import apply_overrides
from neuronav.errors import ConfigError, PortError
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig
from neuronav.scenarios.visual_compass.scenario import VisualCompassConfig
from neuronav.senses.compound_eye_vision import (
    CAMERA_EYE_SHAPE_PX,
    PANORAMA_SHAPE_PX,
    OmmatidiaImage,
    beacon_eye_image,
    compass_panorama,
    eye_grid,
    panorama_grid,
)


@pytest.fixture(scope="module")
def eyes():
    return desert_ant(compound_eyes=True, ommatidia_scale=0.5).compound_eyes


def azimuth_cw(directions):
    return np.arctan2(-directions[..., 1], directions[..., 0])


def reads(eyes, scene):
    """Each eye's (M, 2) read of ``scene(directions) -> values`` (both channels the same)."""
    return [np.repeat(scene(eye.directions)[:, None], 2, axis=1) for eye in eyes]


def skyline(turn_rad=0.0):
    """An uneven skyline: dark objects up to an elevation that varies with the azimuth, the sky bright."""
    def scene(directions):
        azimuth = azimuth_cw(directions) - turn_rad
        elevation = np.arcsin(np.clip(directions[..., 2], -1, 1))
        height = 0.15 + 0.1 * np.sin(azimuth) + 0.08 * np.cos(3 * azimuth + 0.4)
        return np.where(elevation > height, 0.5, 0.04)
    return scene


def test_the_panorama_is_laid_out_as_the_panoramic_camera(eyes):
    grid = panorama_grid()
    assert grid.shape == (*PANORAMA_SHAPE_PX, 3)
    # The middle column looks forward, the first straight back, the top row at the zenith.
    assert azimuth_cw(grid[36, 36]) == pytest.approx(np.radians(2.5))
    assert abs(azimuth_cw(grid[36, 0])) == pytest.approx(np.radians(177.5))
    assert grid[0, 0, 2] == pytest.approx(np.cos(np.radians(1.25)))
    scene = skyline()
    image = compass_panorama(eyes)(*reads(eyes, scene))[0]
    truth = scene(grid)
    inside = ~compass_panorama(eyes).outside_cells.reshape(PANORAMA_SHAPE_PX)
    # Within the eyes' field, all but the cells straddling the skyline hold the scene's value.
    assert np.mean(np.abs(image - truth)[inside] < 0.05) > 0.9


@pytest.mark.parametrize("turn_deg", [10.0, 45.0, -120.0])
def test_the_compass_phase_from_compound_eyes_follows_a_turn_of_the_world(eyes, turn_deg):
    panorama, basis = compass_panorama(eyes), ZernikeBasis(*PANORAMA_SHAPE_PX)
    before = basis.compass_phase(panorama(*reads(eyes, skyline())))[0]
    after = basis.compass_phase(panorama(*reads(eyes, skyline(np.radians(turn_deg)))))[0]
    # The world turning clockwise by α looks like the ant turning left by α: the phase falls by α.
    change = np.degrees(np.angle(np.exp(1j * (after - before))))
    assert change == pytest.approx(-turn_deg, abs=3.0)


@pytest.mark.parametrize("side, landmark_deg", [("L", -50.0), ("L", 0.0), ("R", 45.0), ("R", 10.0)])
def test_the_beacon_eye_image_puts_a_dark_landmark_where_the_camera_eye_would(eyes, side, landmark_deg):
    eye = eyes[0] if side == "L" else eyes[1]
    assert eye.name.endswith(side)

    def scene(directions):  # a dark post 8° wide at landmark_deg (clockwise), standing on the horizon
        off = np.abs(np.angle(np.exp(1j * (azimuth_cw(directions) - np.radians(landmark_deg)))))
        return np.where((off < np.radians(4.0)) & (directions[..., 2] < 0.3), 0.02, 0.15)

    image = beacon_eye_image(eye, side)(*reads([eye], scene))
    assert image.shape == (1, *CAMERA_EYE_SHAPE_PX)
    centre_deg = -30.0 if side == "L" else 30.0
    expected_px = (centre_deg - landmark_deg) / np.degrees(2.0) * CAMERA_EYE_SHAPE_PX[1]
    assert landmark_offset_px(image, 0.08)[0] == pytest.approx(expected_px, abs=1.5)


def test_cells_beyond_an_eye_are_bright_and_the_rest_is_read(eyes):
    left = beacon_eye_image(eyes[0], "L")
    image = left(np.zeros((eyes[0].n_ommatidia, 2)))[0]  # an eye that sees only black
    azimuth = np.degrees(azimuth_cw(eye_grid("L")))
    # The left eye reaches 10° across the midline; a cell more than two acceptance widths beyond is outside.
    edge_deg = 10.0 + 2.0 * np.degrees(eyes[0].acceptance_rad.max())
    assert (image[azimuth > edge_deg + 0.5] == 1.0).all() and (azimuth > edge_deg + 0.5).any()
    assert (image[azimuth < 5.0] == 0.0).all()


def test_bad_inputs_are_refused_by_name(eyes):
    with pytest.raises(ConfigError, match="channel must be one of green, uv"):
        OmmatidiaImage(eyes, panorama_grid(), "red")
    with pytest.raises(ConfigError, match="CompoundEye"):
        OmmatidiaImage(["eye"], panorama_grid())
    with pytest.raises(ConfigError, match="grid"):
        OmmatidiaImage(eyes, np.zeros((4, 3)))
    with pytest.raises(PortError, match="compound_eye_L read must be"):
        compass_panorama(eyes)(np.zeros((3, 2)), np.zeros((eyes[1].n_ommatidia, 2)))
    with pytest.raises(PortError, match="needs 2 reads"):
        compass_panorama(eyes)(np.zeros((eyes[0].n_ommatidia, 2)))
    for config_type in (VisualBeaconConfig, VisualCompassConfig):
        with pytest.raises(ConfigError, match="'eyes' must be one of camera, compound"):
            apply_overrides(config_type, ["eyes=ommatidia"])


def test_compound_eyes_steer_the_beacon_ant_to_the_landmark():
    config = apply_overrides(VisualBeaconConfig, ["eyes=compound", "eye=both", "landmark_distance_m=8", "trees=5",
                                                  "timeout_s=25"])
    rows = run_trials(load_scenario("visual-beacon"), config, "kinematic", trials=1, seed=0).trials
    assert rows[0]["success"] and rows[0]["closest_distance_m"] <= 3.0


def test_compound_eyes_hold_the_compass_heading_while_the_world_turns():
    config = apply_overrides(VisualCompassConfig, ["eyes=compound", "duration_s=6", "incremental_rad=0.05"])
    rows = run_trials(load_scenario("visual-compass"), config, "kinematic", trials=1, seed=0).trials
    # The world turns 0.05 rad (2.9°) every cycle, 26° in all: the ant follows it within a few degrees.
    assert rows[0]["mean_error_deg"] < 6.0


def test_the_channel_picks_green_or_uv(eyes):
    read = [np.stack([np.full(e.n_ommatidia, 0.2), np.full(e.n_ommatidia, 0.7)], axis=1) for e in eyes]
    assert np.allclose(compass_panorama(eyes, "green")(*read), 0.2)
    assert np.allclose(compass_panorama(eyes, "uv")(*read), 0.7)


def test_eyes_compound_is_what_the_brains_read():
    """The beacon's first views are the compound eyes' green (at most the sand's 0.27, or 1 beyond an eye's field,
    where the cameras see a sky of about 0.9); the compass's phase is the compound panorama's, not the camera's."""
    beacon_config = apply_overrides(VisualBeaconConfig, ["eyes=compound", "trees=0", "timeout_s=1"])
    result = run_trials(load_scenario("visual-beacon"), beacon_config, "kinematic", trials=1, seed=0)
    view = result.timeseries["first_view_eye_L"][0]
    assert view.shape == CAMERA_EYE_SHAPE_PX and view.min() < 0.08
    assert not ((view > 0.3) & (view < 0.99)).any()
    phases = {}
    for kind in ("camera", "compound"):
        config = apply_overrides(VisualCompassConfig, [f"eyes={kind}", "duration_s=1.3", "variability=off"])
        phases[kind] = run_trials(load_scenario("visual-compass"), config, "kinematic", trials=1,
                                  seed=0).timeseries["phase_rad"][0, 0]
    assert abs(np.angle(np.exp(1j * (phases["compound"] - phases["camera"])))) > 0.02


@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_eyes_compound_runs_on_the_physics_ants(backend):
    """A short compass trial and the beacon's first views from the physics ant's compound eyes."""
    pytest.importorskip(backend)
    config = apply_overrides(VisualCompassConfig, ["eyes=compound", "duration_s=1.3", "variability=off"])
    result = run_trials(load_scenario("visual-compass"), config, backend, trials=1, seed=0)
    assert np.isfinite(result.timeseries["phase_rad"][0, :2]).all()
    beacon_config = apply_overrides(VisualBeaconConfig, ["eyes=compound", "eye=both", "trees=0", "timeout_s=0.7"])
    views = run_trials(load_scenario("visual-beacon"), beacon_config, backend, trials=1, seed=2).timeseries
    for side in ("L", "R"):  # the landmark ahead, dark in both eyes' green; no sky-bright camera pixel
        view = views[f"first_view_eye_{side}"][0]
        assert view.min() < 0.08 and not ((view > 0.3) & (view < 0.99)).any()
