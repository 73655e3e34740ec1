"""The statistics block of summaries (neuronav/runs/summary_statistics.py): grouping by the scenario's
condition, the metrics it infers, failed trials left out, agreement of backends, the test across them."""

import json
import math

import pytest
from scipy import stats as scipy_stats

from neuronav.runs.summary_statistics import (
    Statistics,
    across_backends,
    agreement,
    metric_columns,
    resamples_for,
    run_statistics,
)


def rows(times_fixed, times_moving, *, failed=0):
    out = [{"trial": i, "seed": i, "status": "ok", "error": "", "success": t < 30, "antennae": "fixed",
            "time_s": t, "wall_s": 0.1} for i, t in enumerate(times_fixed)]
    out += [{"trial": 100 + i, "seed": 100 + i, "status": "ok", "error": "", "success": t < 30,
             "antennae": "moving", "time_s": t, "wall_s": 0.2} for i, t in enumerate(times_moving)]
    out += [{"trial": 200 + i, "seed": 200 + i, "status": "failed", "error": "boom", "success": False,
             "antennae": "moving", "time_s": float("nan"), "wall_s": 0.0} for i in range(failed)]
    return out


FIXED = [36.0, 35.0, 37.5, 34.0, 38.0, 36.5]
MOVING = [29.0, 28.5, 31.0, 27.0, 30.5, 29.5]


def test_conditions_are_compared_with_mann_whitney_and_fisher():
    block = run_statistics(rows(FIXED, MOVING, failed=2), Statistics(condition="antennae"), seed=3,
                           timing=("wall_s",))
    assert (block["n_trials"], block["n_failed"]) == (14, 2)
    assert set(block["conditions"]) == {"fixed", "moving"}
    assert block["conditions"]["moving"]["n_trials"] == 6  # the failed trials are left out
    assert "wall_s" not in block["conditions"]["fixed"]["metrics"]  # timing is not a measurement
    comparison = block["comparisons"][0]
    assert (comparison["condition"], comparison["reference"]) == ("moving", "fixed")
    expected = scipy_stats.mannwhitneyu(MOVING, FIXED, alternative="two-sided")
    assert comparison["metrics"]["time_s"]["p"] == pytest.approx(expected.pvalue)
    assert comparison["metrics"]["time_s"]["rank_biserial"] == pytest.approx(-1.0)  # every moving time shorter
    moving_successes = sum(t < 30 for t in MOVING)
    fisher = scipy_stats.fisher_exact([[moving_successes, 6 - moving_successes], [0, 6]])
    assert comparison["success"]["p"] == pytest.approx(fisher.pvalue)
    json.dumps(block)  # plain JSON


def test_a_run_without_conditions_is_one_group_and_the_seed_fixes_the_intervals():
    one = run_statistics(rows(FIXED, MOVING), Statistics(), seed=1)
    assert list(one["conditions"]) == ["all"] and one["comparisons"] == []
    assert one["conditions"]["all"]["metrics"]["time_s"]["n"] == 12
    again = run_statistics(rows(FIXED, MOVING), Statistics(), seed=1)
    other = run_statistics(rows(FIXED, MOVING), Statistics(), seed=2)
    ci = one["conditions"]["all"]["metrics"]["time_s"]["mean_ci"]
    assert ci == again["conditions"]["all"]["metrics"]["time_s"]["mean_ci"]
    assert ci != other["conditions"]["all"]["metrics"]["time_s"]["mean_ci"]
    assert ci[0] < sum(FIXED + MOVING) / 12 < ci[1]


def test_metric_columns_are_the_numeric_measurements():
    table = rows(FIXED, MOVING)
    assert metric_columns(table, Statistics(condition="antennae"), ("wall_s",)) == ["time_s"]
    assert metric_columns(table, Statistics(metrics=("wall_s",))) == ["wall_s"]


def test_no_finished_trial_or_a_bad_declaration_gives_a_note_not_an_error():
    assert run_statistics(rows([], [], failed=3), Statistics(), seed=0)["note"] == "no trial finished"
    block = run_statistics(rows(FIXED, MOVING), Statistics(condition="no_such_column"), seed=0)
    assert "no_such_column" in block["note"]


def test_backends_agree_when_their_effects_point_the_same_way():
    kinematic = run_statistics(rows(FIXED, MOVING), Statistics(condition="antennae"), seed=0)
    mujoco = run_statistics(rows(FIXED, [t - 2 for t in MOVING]), Statistics(condition="antennae"), seed=0)
    reversed_ = run_statistics(rows(MOVING, FIXED), Statistics(condition="antennae"), seed=0)
    same = agreement({"kinematic": kinematic, "mujoco": mujoco})["moving vs fixed"]["time_s"]
    assert same["same_direction"] and same["effect_by_backend"]["mujoco"] < 0
    assert not agreement({"kinematic": kinematic, "pybullet": reversed_})["moving vs fixed"]["time_s"]["same_direction"]


def test_the_test_across_backends_is_kruskal_wallis_per_condition():
    a, b = rows(FIXED, MOVING), rows([t + 5 for t in FIXED], MOVING)
    result = across_backends({"kinematic": a, "mujoco": b}, Statistics(condition="antennae"), timing=("wall_s",))
    expected = scipy_stats.kruskal(FIXED, [t + 5 for t in FIXED])
    assert result["fixed"]["time_s"]["p"] == pytest.approx(expected.pvalue)
    assert result["fixed"]["time_s"]["n_by_backend"] == {"kinematic": 6, "mujoco": 6}
    assert "wall_s" not in result["fixed"]


def test_resamples_shrink_with_n_within_bounds():
    assert resamples_for(5) == 1999 and resamples_for(10**6) == 199
    assert math.isclose(resamples_for(2000), 1000)
