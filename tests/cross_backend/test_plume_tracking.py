"""Plume tracking (paper §2.5.2): an ant in the plume turns upwind and walks up it; from the protocol's
downwind starts, in the intermittent plume, ants with odour reach the source clearly more often than
the controls without, on every backend.

The short tests run the kinematic ant for seconds, and the MuJoCo ant from a start 3 m downwind; the
full protocol (20 trials with odour, 20 without, 60 s each, compared by the run's statistics) on every
backend is ``slow``.
"""

import numpy as np
import pytest

from neuronav.brains.plume_tracking import ORIENT, SEARCH
from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.runs.summary_statistics import run_statistics
from neuronav.scenarios.plume_tracking.scenario import (
    PlumeTracking,
    PlumeTrackingConfig,
    plume_trial,
    plume_world,
    start_pose,
)
from neuronav.senses.chemistry import Chemistry

UPWIND_RAD = -np.pi / 2  # against the wind along +x, clockwise from +y
# The plume before issue 22 (pompy's 60 puffs/s of 1 unit, Farrell's wind gain 0.2): odour on the axis
# nearly all the time, so that an ant placed on it smells it at once; and no sensor or motor noise. The
# controller's steps are then exact.
DENSE_EXACT = {"release_rate_hz": 60.0, "puff_amount": 1.0, "wind_gain": 0.2, "variability": "off"}


def across_the_plume(odour: str, seconds: float = 8.0, seed: int = 3, stride_rule: str = "mod"):
    """The kinematic ant at x = 5 m on the axis of the dense plume (the median y of the puffs there at
    the start), facing +y: upwind is 90° to its left."""
    config = PlumeTrackingConfig(odour=odour, timeout_s=seconds, warmup_s=5.0, stride_rule=stride_rule,
                                 **DENSE_EXACT)
    chemistry = Chemistry(plume_world(config).odour)
    chemistry.reset(seed)
    puffs = chemistry.plume.puffs.position_m
    axis_y = float(np.median(puffs[np.abs(puffs[:, 0] - 5.0) < 0.5, 1]))
    return plume_trial(config, "kinematic", seed=seed, start=((5.0, axis_y), 0.0))


def test_an_ant_started_across_the_plume_turns_upwind_and_walks_up_it():
    row, log = across_the_plume("on")
    assert log["odour"][0].max() > 1e-6  # it starts in odour
    assert log["branch"][0] == ORIENT and log["turn"][0] == 1.0  # a left turn, toward upwind
    heading_error = abs((log["heading_rad"][-1] - UPWIND_RAD + np.pi) % (2 * np.pi) - np.pi)
    assert heading_error < np.radians(30)  # from 90° off in 8 s (four orienting cycles)
    assert log["position_m"][-1, 0] < 5.0 - 1.0  # and walked upwind
    assert row["odour_fraction"] > 0.5


def test_the_divide_stride_rule_turns_the_ant_upwind_in_fewer_cycles():
    _, printed = across_the_plume("on", seconds=2.0)
    _, divide = across_the_plume("on", seconds=2.0, stride_rule="divide")
    assert 5.0 <= np.degrees(printed["stride_rad"][0]) < 10.0  # 5° + (about 90°) mod 5°
    assert np.degrees(divide["stride_rad"][0]) == pytest.approx(15.0)  # min(5° + about 90° / 5, 15°)
    turned = [abs(log["heading_rad"][-1]) for log in (printed, divide)]  # from 0 toward −90°
    assert turned[1] > turned[0] + np.radians(10)


def test_without_odour_the_same_ant_only_turns_on_the_spot():
    row, log = across_the_plume("off")
    assert np.all(log["branch"] == SEARCH)
    assert np.all(np.abs(log["turn"]) == 1.0)
    assert np.hypot(*(log["position_m"][-1] - log["position_m"][0])) < 0.3
    assert row["odour_fraction"] > 0.5  # the odour was there; the brain was not given it


def test_same_seed_same_trial_and_starts_vary_with_the_seed():
    config = PlumeTrackingConfig(timeout_s=3.0, warmup_s=2.0)
    first, log1 = plume_trial(config, "kinematic", seed=5)
    again, log2 = plume_trial(config, "kinematic", seed=5)
    np.testing.assert_array_equal(log1["position_m"], log2["position_m"])
    np.testing.assert_array_equal(log1["odour"], log2["odour"])
    np.testing.assert_equal({k: v for k, v in first.items() if k != "real_time_factor"},
                            {k: v for k, v in again.items() if k != "real_time_factor"})
    starts = [start_pose(config, seed) for seed in range(20)]
    ys = np.array([xy[1] for xy, _ in starts])
    headings = np.array([h for _, h in starts])
    assert np.all(np.abs(ys) <= config.start_lateral_m) and np.ptp(ys) > 0.5
    assert np.all(np.abs(headings - UPWIND_RAD) <= np.radians(config.start_heading_deg) + 1e-12)


def test_a_start_at_the_source_is_refused():
    with pytest.raises(ConfigError, match="start_x_m"):
        apply_overrides(PlumeTrackingConfig, {"start_x_m": 1.5})


def test_figures_are_drawn_from_a_short_run(tmp_path):
    scenario = PlumeTracking()
    config = PlumeTrackingConfig(timeout_s=2.0, warmup_s=2.0)
    result = scenario.run(config, backend="kinematic", trials=2, seed=0)
    assert result.timeseries["plume_raster"].shape == (2, 80, 160)
    assert np.nanmax(result.timeseries["plume_raster"][0]) > 100 * config.threshold  # the warmed-up plume is in it
    paths = scenario.figures(result, config, tmp_path)
    assert [p.name for p in paths] == ["plume_paths.png", "trial0_senses.png", "time_to_source.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_on_mujoco_ants_reach_the_source_with_odour_and_none_without_from_a_short_start():
    """The CI variant of the slow protocol below on the physics ant: 3 trials each way, 3 m downwind, 20 s
    (seed 0, the intermittent plume and variability of the defaults: with odour 2 of 3 reach the source in
    13.0 and 11.0 s and the third gets within 1.04 m; without odour none, all 2.58 m or more away at their
    closest, turning on the spot)."""
    pytest.importorskip("mujoco")
    scenario = PlumeTracking()
    short = {"start_x_m": 3.5, "timeout_s": 20.0}
    with_odour = scenario.run(PlumeTrackingConfig(odour="on", **short), backend="mujoco", trials=3, seed=0)
    without = scenario.run(PlumeTrackingConfig(odour="off", **short), backend="mujoco", trials=3, seed=0)
    assert all(row["status"] == "ok" for row in with_odour.trials + without.trials)
    assert with_odour.aggregates["success_rate"] >= 0.6 and with_odour.aggregates["median_time_to_source_s"] < 15.0
    assert without.aggregates["success_rate"] == 0.0
    closest = {name: [row["closest_distance_m"] for row in result.trials]
               for name, result in (("on", with_odour), ("off", without))}
    assert max(closest["on"]) < min(closest["off"]), closest


@pytest.mark.slow
@pytest.mark.parametrize("backend, arrivals_significant", [("kinematic", True), ("mujoco", True),
                                                          ("pybullet", False)])
def test_with_odour_ants_get_clearly_closer_to_the_source_than_without(backend, arrivals_significant):
    """The protocol's statistics (20 trials with odour, 20 without, seeds 0-39, the intermittent plume and
    variability of the defaults): with odour the ants get closer (Mann-Whitney U) and more reach the
    source (Fisher's exact test: significant on the kinematic body and MuJoCo, p = 0.001 and 0.0004; on
    PyBullet 4 / 20 against 0 / 20, p = 0.11), and the controls are in odour only a minority of the time
    (numbers per backend in the scenario's README)."""
    if backend != "kinematic":
        pytest.importorskip(backend)
    scenario = PlumeTracking()
    config = PlumeTrackingConfig(odour="both")
    result = scenario.run(config, backend=backend, trials=40, seed=0)
    block = run_statistics(result.trials, scenario.statistics(config), seed=0)
    (comparison,) = block["comparisons"]
    assert comparison["success"]["risk_difference"] > 0.1, comparison
    if arrivals_significant:
        assert comparison["success"]["p"] < 0.05 and comparison["success"]["risk_difference"] > 0.3, comparison
    closest = comparison["metrics"]["closest_distance_m"]
    assert closest["p"] < 0.001 and closest["rank_biserial"] < -0.5, closest
    assert block["conditions"]["false"]["metrics"]["odour_fraction"]["mean"] < 0.5
