"""Scenario aggregates per condition: groups of finished trials, statistics under their key templates."""

import math

import pytest

from neuronav.scenarios.aggregation import (
    finished_trials,
    finite_median_of,
    mean_of,
    per_condition,
    success_rate,
    summarise,
)

TRIALS = [
    {"mode": 0, "success": True, "time_s": 10.0, "offset_m": 1.0},
    {"mode": 0, "success": False, "time_s": math.nan, "offset_m": 3.0},
    {"mode": 0, "success": True, "time_s": 30.0, "offset_m": 2.0, "status": "ok"},
    {"mode": 1, "success": False, "time_s": math.nan, "offset_m": -1.0},
    {"mode": 1, "success": True, "time_s": 5.0, "offset_m": 100.0, "status": "failed"},  # counts nowhere
    {"mode": 2, "success": True, "time_s": 7.0, "offset_m": 0.0, "status": "failed"},
]
STATISTICS = {"success_{}": success_rate, "time_{}_s": finite_median_of("time_s"), "offset_{}_m": mean_of("offset_m")}


def test_failed_trials_count_nowhere():
    assert len(finished_trials(TRIALS)) == 4


def test_per_condition_groups_by_label_in_order_and_skips_empty_groups():
    result = per_condition(TRIALS, "mode", STATISTICS, labels={1: "right", 0: "left", 2: "both"})
    assert list(result) == ["success_right", "time_right_s", "offset_right_m",
                            "success_left", "time_left_s", "offset_left_m"]
    assert result["success_left"] == pytest.approx(2 / 3)
    assert result["time_left_s"] == 20.0  # the median of the finite times only
    assert result["offset_left_m"] == 2.0
    assert result["success_right"] == 0.0 and math.isnan(result["time_right_s"])
    assert result["offset_right_m"] == -1.0


def test_without_labels_every_value_of_the_finished_trials_in_increasing_order():
    trials = [{"conflict": c, "success": c < 60} for c in (90.0, 0.0, 30.0, 0.0, 60.0)]
    result = per_condition(trials, "conflict", {"success_{}": success_rate})
    assert result == {"success_0": 1.0, "success_30": 1.0, "success_60": 0.0, "success_90": 0.0}
    assert list(result) == ["success_0", "success_30", "success_60", "success_90"]


def test_a_statistic_returning_none_is_left_out():
    result = summarise(TRIALS[:2], {"kept": success_rate, "dropped_{}": lambda rows: None}, label="x")
    assert result == {"kept": 0.5}
