"""Figures that compare conditions or summarise trials show every trial as a point, the condition's centre
with its 95 % interval and n (issue 22): the shared helpers, then each scenario's figure on a tiny run."""

import numpy as np
import pytest

from neuronav import registry
from neuronav.config import apply_overrides
from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, strip_offsets, success_text
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.runs.stats import circular_summary, describe, success_rate
from neuronav.runs.summary_statistics import resamples_for


def line(ax, gid):
    (found,) = [drawn for drawn in ax.lines if drawn.get_gid() == gid]
    return found


def interval(ax, gid):
    """The (low, high) of the error bar whose data line has ``gid``."""
    (container,) = [c for c in ax.containers if c.lines[0].get_gid() == gid]
    (segment,) = container.lines[2][0].get_segments()
    return tuple(sorted(segment[:, 1]))


def points_under(fig, prefix):
    """Every value drawn as a trial's point (marker "o") by a helper line whose gid starts with ``prefix``."""
    return sorted(float(y) for ax in fig.axes for drawn in ax.lines
                  if (drawn.get_gid() or "").startswith(prefix + " ") and drawn.get_marker() == "o"
                  for y in drawn.get_ydata())


# -- the helpers ---------------------------------------------------------------------------------------
def test_condition_strip_draws_each_trial_and_the_mean_with_its_bootstrap_interval():
    _, ax = new_figure()
    groups = {"left": [3.0, 1.0, np.nan, 2.0, 10.0], "both": [5.0, 6.0]}
    drawn = condition_strip(ax, groups, gid="time", box=True, width=0.3)
    points = line(ax, "time left")
    assert sorted(points.get_ydata()) == [1.0, 2.0, 3.0, 10.0]  # the NaN left out
    assert np.all(np.abs(points.get_xdata() - 0.0) <= 0.15) and len(set(points.get_xdata())) == 4
    assert sorted(line(ax, "time both").get_ydata()) == [5.0, 6.0]
    expected = describe([1.0, 2.0, 3.0, 10.0], seed=0, n_resamples=resamples_for(4))
    assert line(ax, "time left mean").get_ydata()[0] == pytest.approx(4.0)
    low, high = interval(ax, "time left mean")
    assert low < 4.0 < high
    assert (low, high) == pytest.approx(tuple(expected["mean_ci"]))
    assert drawn["left"]["n"] == 4 and drawn["left"]["n_missing"] == 1
    assert [t.get_text() for t in ax.get_xticklabels()] == ["left\n(n = 4 of 5)", "both\n(n = 2)"]
    assert len(ax.lines) > 4  # the box plots' lines under the points
    _, again = new_figure()
    condition_strip(again, groups, gid="time")
    np.testing.assert_array_equal(line(again, "time left").get_xdata(), points.get_xdata())  # seeded offsets


def test_condition_strip_median_and_circular_centres():
    _, ax = new_figure()
    condition_strip(ax, {"a": [1.0, 2.0, 30.0]}, centre="median", gid="m")
    assert line(ax, "m a median").get_ydata()[0] == 2.0
    _, ax = new_figure()
    condition_strip(ax, {"a": [170.0, -170.0, 180.0]}, centre="circular", gid="h")
    centre = line(ax, "h a circular").get_ydata()[0]
    assert abs(centre) == pytest.approx(180.0)  # not the arithmetic mean, 60
    block = circular_summary(np.radians([170.0, -170.0, 180.0]), seed=0, n_resamples=resamples_for(3))
    assert interval(ax, "h a circular") == pytest.approx(tuple(np.degrees(block["mean_ci_rad"])))


def test_proportion_points_draw_each_outcome_and_the_wilson_interval():
    _, ax = new_figure()
    drawn = proportion_points(ax, {"on": [True, False, True, None], "off": [False, False]}, gid="reached")
    assert sorted(line(ax, "reached on").get_ydata()) == [0.0, 1.0, 1.0]
    assert line(ax, "reached on rate").get_ydata()[0] == pytest.approx(2 / 3)
    assert interval(ax, "reached on rate") == pytest.approx(tuple(success_rate(2, 3)["ci"]))
    assert drawn["off"]["rate"] == 0.0 and interval(ax, "reached off rate")[1] > 0.0
    assert [t.get_text() for t in ax.get_xticklabels()] == ["on\n(2 of 3)", "off\n(0 of 2)"]
    assert success_text([True, True, False]) == "success 2 of 3 = 67 % (Wilson 95 % CI 21–94 %)"


@pytest.mark.parametrize("outcomes", [[False] * 3, [False] * 6, [True] * 3, [True] * 6])
def test_proportion_points_draw_all_or_none_outcomes(outcomes):
    # Wilson's bounds at 0 of n and n of n can fall a rounding error past the rate (0 of 3: 5.6e-17):
    # the bar must still be drawn, not refused by matplotlib as a negative error.
    _, ax = new_figure()
    drawn = proportion_points(ax, {"c": outcomes}, gid="reached")
    assert drawn["c"]["rate"] == float(outcomes[0])
    low, high = interval(ax, "reached c rate")
    assert low <= drawn["c"]["rate"] <= high and high - low > 0.2


def test_strip_offsets_spread_evenly_within_the_width():
    offsets = strip_offsets(5, width=0.4)
    np.testing.assert_allclose(sorted(offsets), np.linspace(-0.2, 0.2, 5))
    assert strip_offsets(1).tolist() == [0.0]


# -- each scenario's figure on a tiny run --------------------------------------------------------------
def tiny_run(name, trials, **overrides):
    scenario = load_scenario(name)
    config = apply_overrides(scenario.config_type, dict(scenario.smoke_config(), **overrides))
    backend = "kinematic" if "kinematic" in scenario.backends else scenario.default_backend
    ok, reason = registry.availability("backend", backend)
    if not ok:
        pytest.skip(reason)
    return run_trials(scenario, config, backend, trials=trials, seed=0), config


def finite(rows, key):
    return sorted(float(t[key]) for t in rows if np.isfinite(float(t[key])))


def outcomes(rows, key="success"):
    return sorted(float(bool(t[key])) for t in rows)


def assert_centres(fig, prefix):
    """A centre (mean, median, circular mean or rate) with its error bar beside the points."""
    centres = [drawn for ax in fig.axes for drawn in ax.lines
               if (drawn.get_gid() or "").startswith(prefix + " ") and drawn.get_marker() in ("D", "s")]
    assert centres, f"no centre drawn for {prefix!r}"


def test_odour_trail_figures_show_every_trial():
    from neuronav.scenarios.odour_trail.figures import completion_figure, finish_time_figure

    result, _ = tiny_run("odour-trail", 4)
    fig = completion_figure(result)
    assert points_under(fig, "completion") == finite(result.trials, "completion")
    assert_centres(fig, "completion")
    fig = finish_time_figure(result)
    assert points_under(fig, "finish") == finite(result.trials, "finish_time_s")
    assert points_under(fig, "reached") == outcomes(result.trials)
    assert_centres(fig, "reached")
    assert any("n = " in t.get_text() for t in fig.axes[0].get_xticklabels())


def test_visual_beacon_times_and_own_starts():
    from neuronav.scenarios.visual_beacon.figures import times_figure, trajectories_figure

    result, config = tiny_run("visual-beacon", 3, timeout_s=1.0)
    fig = times_figure(result)
    assert points_under(fig, "times") == finite(result.trials, "time_to_landmark_s")
    assert points_under(fig, "reached") == outcomes(result.trials)
    assert_centres(fig, "reached")
    (starts,) = [drawn for drawn in trajectories_figure(result, config).axes[0].lines if drawn.get_label() == "start"]
    first = np.array([path[0] for path in result.timeseries["position_m"]])
    np.testing.assert_allclose(starts.get_xydata(), first)
    assert np.abs(first).max() > 0.01, "starts are jittered: not all at the origin"


def test_plume_tracking_times_and_arrivals():
    from neuronav.scenarios.plume_tracking.figures import times_figure

    result, config = tiny_run("plume-tracking", 2, odour="both")
    fig = times_figure(result, config)
    assert points_under(fig, "reached") == finite(result.trials, "time_to_source_s")
    assert points_under(fig, "success") == outcomes(result.trials)
    assert_centres(fig, "success")
    assert [t.get_text().split("\n")[0] for t in fig.axes[1].get_xticklabels()] == ["odour on", "odour off"]


def test_plume_paths_draw_each_trial_over_its_own_plume():
    from neuronav.scenarios.plume_tracking.figures import plume_paths_figure

    result, config = tiny_run("plume-tracking", 3)
    fig = plume_paths_figure(result, config, max_panels=2)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_xlabel() == "x (m)"]
    assert len(panels) == 3, "trials 0 and 1 over their own plumes, then every path without a plume"
    for i, ax in enumerate(panels[:2]):
        assert [drawn.get_gid() for drawn in ax.lines if (drawn.get_gid() or "").startswith("trial ")] == [
            f"trial {i}"]
        (image,) = ax.images
        raster = np.asarray(result.timeseries["plume_raster"][i], float)
        np.testing.assert_array_equal(np.ma.filled(image.get_array(), np.nan),
                                      np.where(raster > config.threshold, raster, np.nan))
        assert f"trial {i}" in ax.get_title()
    assert not np.array_equal(result.timeseries["plume_raster"][0], result.timeseries["plume_raster"][1])
    assert not panels[2].images and "no plume" in panels[2].get_title()
    assert sorted(d.get_gid() for d in panels[2].lines if (d.get_gid() or "").startswith("trial ")) == [
        "trial 0", "trial 1", "trial 2"]


def test_cue_integration_groups_by_cue_mode_in_the_aggregate_and_the_figure():
    from neuronav.scenarios.cue_integration.figures import initial_heading_figure

    result, config = tiny_run("cue-integration", 4, cues="both,pi", conflict_deg="90", timeout_s=2.0,
                              initial_distance_m=0.4)
    by_mode = {m: [t for t in result.trials if t["cues"] == m] for m in ("both", "pi")}
    ax = initial_heading_figure(result, config).axes[0]
    for mode, rows in by_mode.items():
        assert sorted(line(ax, f"initial {mode} 90").get_ydata()) == finite(rows, "initial_heading_deg")
        assert line(ax, f"initial {mode} 90 circular")
        assert line(ax, f"prediction {mode}")
    assert set(result.aggregates) >= {"initial_heading_both_90_deg", "initial_heading_pi_90_deg", "success_pi_90"}
    assert "initial_heading_90_deg" not in result.aggregates


def test_cue_integration_aggregate_never_pools_cue_modes():
    from neuronav.scenarios.cue_integration.scenario import CueIntegration, CueIntegrationConfig

    rows = [{"cues": cues, "conflict_deg": 90.0, "initial_heading_deg": heading, "predicted_heading_deg": heading,
             "success": True, "status": "ok"} for cues, heading in (("both", 20.0), ("pi", 80.0), ("both", 30.0),
                                                                     ("pi", 90.0))]
    mixed = CueIntegration().aggregate(rows, apply_overrides(CueIntegrationConfig, ["cues=both,pi"]))
    assert mixed["initial_heading_both_90_deg"] == pytest.approx(25.0, abs=0.1)
    assert mixed["initial_heading_pi_90_deg"] == pytest.approx(85.0, abs=0.1)
    single = CueIntegration().aggregate(rows[::2], apply_overrides(CueIntegrationConfig, ["cues=both"]))
    assert set(single) == {"initial_heading_90_deg", "predicted_heading_90_deg", "success_90"}


def test_route_following_summary_panels():
    from neuronav.scenarios.route_following.figures import summary_panels

    result, config = tiny_run("route-following", 2, strategy="scan,klinokinesis")
    fig, (reached, success) = new_figure((8, 4), 1, 2)
    summary_panels(reached, success, result, config)
    assert points_under(fig, "checkpoints") == finite(result.trials, "checkpoints_reached")
    assert points_under(fig, "success") == outcomes(result.trials)
    assert [t.get_text().split("\n")[0] for t in success.get_xticklabels()] == ["scan", "klinokinesis"]


def test_swarm_homing_times_and_ants_home():
    from neuronav.scenarios.swarm_homing.figures import homing_times_figure

    result, config = tiny_run("swarm-homing", 4)
    fig = homing_times_figure(result, config)
    assert points_under(fig, "homing time") == finite(result.trials, "homing_time_s")
    assert points_under(fig, "home") == outcomes(result.trials)
    assert_centres(fig, "home")


def test_visual_compass_error_summary():
    from neuronav.scenarios.visual_compass.figures import error_summary_figure

    result, config = tiny_run("visual-compass", 2)
    fig = error_summary_figure(result, config)
    assert points_under(fig, "error") == sorted(finite(result.trials, "mean_error_deg")
                                                + finite(result.trials, "final_error_deg"))
    assert points_under(fig, "success") == outcomes(result.trials)


def test_locomotion_gait_panels():
    from neuronav.scenarios.locomotion.figures import trajectory_figure

    result, config = tiny_run("locomotion", 2, gait="tripod,wave")
    fig = trajectory_figure(result, config)
    assert points_under(fig, "forward_speed_m_s") == finite(result.trials, "forward_speed_m_s")
    assert points_under(fig, "upright") == outcomes(result.trials)
    assert [t.get_text().split("\n")[0] for t in fig.axes[2].get_xticklabels()] == ["tripod", "wave"]


def test_path_integration_title_gives_n_and_the_wilson_interval():
    from neuronav.scenarios.path_integration.figures import trajectories_figure

    result, config = tiny_run("path-integration", 2)
    title = trajectories_figure(result, config).axes[0].get_title()
    assert success_text([t["success"] for t in result.trials]) in title and " of 2 " in title
