"""The visual scenarios' figures draw what they claim: read back from the matplotlib objects."""

import numpy as np
import pytest

from neuronav.config import apply_overrides
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.scenarios.visual_beacon.figures import first_views_figure, times_figure, trajectories_figure
from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig
from neuronav.scenarios.visual_compass.figures import compass_figure, error_figure
from neuronav.scenarios.visual_compass.scenario import VisualCompassConfig


@pytest.fixture(scope="module")
def beacon():
    config = apply_overrides(VisualBeaconConfig, ["landmark_distance_m=10", "trees=5"])
    return run_trials(load_scenario("visual-beacon"), config, "kinematic", trials=3, seed=0), config


@pytest.fixture(scope="module")
def compass():
    config = apply_overrides(VisualCompassConfig, ["rotation=jump", "duration_s=12", "jump_every_s=5"])
    return run_trials(load_scenario("visual-compass"), config, "kinematic", trials=2, seed=0), config


def by_gid(fig, kind):
    return {a.get_gid(): a for ax in fig.axes for a in getattr(ax, kind) if a.get_gid()}


def test_beacon_trajectories_one_line_per_trial_coloured_by_eye_mode(beacon):
    result, config = beacon
    fig = trajectories_figure(result, config)
    lines = by_gid(fig, "lines")
    assert set(lines) == {"trial 0 left", "trial 1 right", "trial 2 both"}
    for i in range(3):
        drawn = next(v for k, v in lines.items() if k.startswith(f"trial {i} "))
        path = result.timeseries["position_m"][i]
        path = path[np.isfinite(path[:, 0])]
        assert np.allclose(drawn.get_xydata(), path)
    assert {lines["trial 0 left"].get_color(), lines["trial 1 right"].get_color(),
            lines["trial 2 both"].get_color()} == {"tab:blue", "tab:red", "tab:green"}
    landmark = by_gid(fig, "patches")["landmark"]
    assert tuple(landmark.center) == (0.0, config.landmark_distance_m)
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["left eye", "right eye", "both eyes",
                                                                            "start"]


def test_beacon_times_show_every_arrival_per_mode(beacon):
    result, _ = beacon
    fig = times_figure(result)
    points = by_gid(fig, "lines")
    for mode, trial in (("left", 0), ("right", 1), ("both", 2)):
        assert points[f"times {mode}"].get_ydata().tolist() == [result.trials[trial]["time_to_landmark_s"]]
    assert fig.axes[0].get_ylabel() == "time to the landmark (s)"


def test_first_views_show_both_eyes_of_each_mode(beacon):
    result, config = beacon
    fig = first_views_figure(result, config)
    images = {im.get_gid(): im for ax in fig.axes for im in ax.images}
    assert len(images) == 6
    assert np.array_equal(images["both eye_L"].get_array(), result.timeseries["first_view_eye_L"][2])
    titles = [ax.get_title() for ax in fig.axes]
    assert "left mode, trial 0: eye_R (not used)" in titles and "both mode, trial 2: eye_L" in titles


def test_compass_figure_draws_heading_target_scene_and_phase(compass):
    result, config = compass
    fig = compass_figure(result, config)
    lines = by_gid(fig, "lines")
    assert set(lines) == {"heading_rad", "target_rad", "scene_yaw_rad", "phase_rad"}
    heading = lines["heading_rad"].get_ydata()
    expected = np.degrees((result.timeseries["heading_rad"][0] + np.pi) % (2 * np.pi) - np.pi)
    assert np.allclose(heading[np.isfinite(heading)], expected[np.isfinite(expected)])
    assert "jumps recovered" in fig.axes[0].get_title()
    errors = error_figure(result, config)
    assert set(by_gid(errors, "lines")) == {"trial 0", "trial 1"}
    assert errors.axes[0].get_ylabel() == "heading error (deg)"
