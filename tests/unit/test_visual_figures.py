"""The visual scenarios' figures draw what they claim: read back from the matplotlib objects."""

from types import SimpleNamespace

import numpy as np
import pytest

from neuronav.bodies.desert_ant import desert_ant
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


def test_first_views_keep_the_aspect_with_angle_axes_from_the_field_of_view(beacon):
    result, config = beacon
    fig = first_views_figure(result, config)
    camera = next(c for c in desert_ant().cameras if c.name == "eye_L")  # the ant the scenario carries
    half_h, half_v = np.tan(np.array(camera.fov_rad) / 2)
    for ax in fig.axes:
        (image,) = ax.images
        height_px, width_px = image.get_array().shape
        assert (width_px, height_px) == (camera.width_px, camera.height_px)
        # On the image plane: one unit is the same angle across and up the centre, drawn at equal aspect.
        assert np.allclose(image.get_extent(), [-half_h, half_h, -half_v, half_v])
        assert ax.get_aspect() == 1.0
        x0, y0, w, h = ax.get_position().bounds
        fig_w, fig_h = fig.get_size_inches()
        assert np.isclose((w * fig_w) / (h * fig_h), half_h / half_v, rtol=0.02)
        # Angle ticks in degrees, at tan(angle): 0 in the middle, ±45° at tan(45°) = 1 (not at 45/57 of the edge).
        ticks = dict(zip([t.get_text() for t in ax.get_xticklabels()], ax.get_xticks()))
        assert np.isclose(ticks["0"], 0.0) and np.isclose(ticks["45"], 1.0) and np.isclose(ticks["-45"], -1.0)
        yticks = dict(zip([t.get_text() for t in ax.get_yticklabels()], ax.get_yticks()))
        assert set(yticks) == {"-10", "0", "10"} and np.isclose(yticks["10"], np.tan(np.radians(10)))
    assert fig.axes[-1].get_xlabel() == "angle right of the eye's axis (deg)"
    assert fig.axes[0].get_ylabel() == "up (deg)"
    assert "115° × 29° over 74 × 19 px" in fig._suptitle.get_text()


def test_compass_figure_draws_heading_target_scene_and_phase(compass):
    result, config = compass
    fig = compass_figure(result, config)
    lines = by_gid(fig, "lines")
    assert set(lines) == {"heading_rad", "target_rad", "scene_yaw_rad", "phase_rad"}
    drawn_s, heading = lines["heading_rad"].get_xdata(), lines["heading_rad"].get_ydata()
    time_s = result.timeseries["time_s"][0]
    expected = np.degrees((result.timeseries["heading_rad"][0] + np.pi) % (2 * np.pi) - np.pi)
    samples = np.isin(drawn_s, time_s) & np.isfinite(heading)  # the samples, without points added at a wrap
    assert np.allclose(heading[samples], expected[np.isfinite(expected)])
    assert "jumps recovered" in fig.axes[0].get_title()
    errors = error_figure(result, config)
    assert set(by_gid(errors, "lines")) == {"trial 0", "trial 1"}
    assert errors.axes[0].get_ylabel() == "heading error (deg)"


def test_compass_title_says_whose_mean_error_it_is(compass):
    result, config = compass
    title = compass_figure(result, config).axes[0].get_title()
    own = result.trials[0]["mean_error_deg"]
    run = np.mean([t["mean_error_deg"] for t in result.trials])
    assert not np.isclose(round(own, 1), round(run, 1))  # the two can be told apart in this run
    assert "trial 0 shown (of 2)" in title
    assert f"trial 0: mean error {own:.1f}°" in title
    assert f"mean over 2 trials: mean error {run:.1f}°" in title


def wrapping_compass():
    """Two synthetic trials whose angles wrap at ±180°, one sample a second (a gait cycle in the scenario)."""
    time_s = np.arange(12.0)
    turning = np.radians(150.0 + 20.0 * time_s)  # crosses +180° between 1 s and 2 s (at 1.5 s), and again
    series = {"time_s": time_s, "heading_rad": turning, "target_rad": -turning, "scene_yaw_rad": turning / 2,
              "phase_rad": turning + np.radians(5.0)}
    timeseries = {k: np.vstack([v, v]) for k, v in series.items()}
    trials = [{"mean_error_deg": 5.0, "recovered_fraction": 1.0}, {"mean_error_deg": 7.0, "recovered_fraction": 0.5}]
    config = SimpleNamespace(rotation="incremental", recovered_deg=10.0)
    return SimpleNamespace(trials=trials, timeseries=timeseries), config


def test_compass_traces_reach_the_edge_at_a_wrap_without_a_gap_or_a_vertical_jump():
    result, config = wrapping_compass()
    lines = by_gid(compass_figure(result, config), "lines")
    phase = lines["phase_rad"]
    t, angle = phase.get_xdata(), phase.get_ydata()
    # The Zernike phase goes 155, 175, 195 (wrapped: -165) ...: the line runs up to +180° and on from -180°.
    breaks = np.flatnonzero(np.isnan(angle))
    assert len(breaks) == 1  # 155° to 375°: one wrap
    for b in breaks:
        assert t[b - 1] == t[b + 1]  # no gap in time: the next piece starts where the last ended
        assert abs(angle[b - 1]) == 180.0 and angle[b + 1] == -angle[b - 1]
    assert np.isclose(t[breaks[0] - 1], 1.25)  # 155 + 20 t = 180 at t = 1.25 s
    finite = np.isfinite(angle)
    pieces = np.split(angle, breaks)
    assert all(np.all(np.abs(np.diff(p[np.isfinite(p)])) <= 20.0 + 1e-9) for p in pieces)  # no vertical stroke
    assert np.allclose(angle[finite & np.isin(t, result.timeseries["time_s"][0])],
                       np.degrees(np.mod(result.timeseries["phase_rad"][0] + np.pi, 2 * np.pi) - np.pi))
    target = lines["target_rad"]  # turning the other way: down to -180° and on from +180°
    first = np.flatnonzero(np.isnan(target.get_ydata()))[0]
    assert target.get_ydata()[first - 1] == -180.0 and target.get_ydata()[first + 1] == 180.0
