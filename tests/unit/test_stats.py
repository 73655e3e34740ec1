"""The statistics of a run's trials (issue 22): known values from scipy's documented examples, Zar's
Biostatistical Analysis, Newcombe 1998 and hand computation; seeded bootstraps; NaN handling; messages."""

import inspect
import json
import math

import numpy as np
import pytest
from scipy import stats

from neuronav.angles import angle_difference_rad
from neuronav.errors import ConfigError
from neuronav.runs.stats import (
    circular_summary,
    compare_conditions,
    compare_successes,
    compare_values,
    describe,
    success_rate,
    v_test,
)

NAN = float("nan")
# Recent scipy takes the bootstrap's generator as ``rng``, older releases as ``random_state``.
RNG_KEYWORD = "rng" if "rng" in inspect.signature(stats.bootstrap).parameters else "random_state"


# --- describe ---------------------------------------------------------------------------------------

def test_describe_drops_and_counts_missing_values():
    result = describe([1.0, 2.0, NAN, 3.0, 4.0, None, 5.0], seed=0, n_resamples=999)
    assert result["n"] == 5 and result["n_nan"] == 2
    assert result["mean"] == 3.0 and result["median"] == 3.0
    assert result["std"] == pytest.approx(math.sqrt(2.5))
    assert (result["min"], result["max"]) == (1.0, 5.0)
    assert result["mean_ci"][0] < 3.0 < result["mean_ci"][1]


def test_describe_interval_is_scipys_seeded_percentile_bootstrap():
    values = np.random.default_rng(5).exponential(2.0, 25)
    result = describe(values, seed=11, confidence=0.9, n_resamples=2000)
    for key, statistic in (("mean_ci", np.mean), ("median_ci", np.median)):
        expected = stats.bootstrap((values,), statistic, n_resamples=2000, confidence_level=0.9, method="percentile",
                                   **{RNG_KEYWORD: np.random.default_rng(11)}).confidence_interval
        assert result[key] == pytest.approx([expected.low, expected.high], rel=1e-12)
    assert result["ci_method"] == "percentile bootstrap" and result["confidence"] == 0.9


def test_describe_is_deterministic_for_a_seed():
    values = np.random.default_rng(1).normal(10.0, 2.0, 20)
    assert describe(values, seed=3, n_resamples=999) == describe(values, seed=3, n_resamples=999)
    assert describe(values, seed=3, n_resamples=999)["mean_ci"] != describe(values, seed=4, n_resamples=999)["mean_ci"]


def test_describe_mean_interval_covers_the_true_mean_at_about_its_confidence():
    """200 samples of 30 from N(5, 1): the 95 % interval covers 5 in 184 of them (0.92; the percentile
    bootstrap runs a little short at n = 30); 0.88-0.99 allows for the spread of 200 draws."""
    rng = np.random.default_rng(2024)
    covered = 0
    for i in range(200):
        low, high = describe(rng.normal(5.0, 1.0, 30), seed=i, n_resamples=999)["mean_ci"]
        covered += low <= 5.0 <= high
    assert 0.88 <= covered / 200 <= 0.99


def test_describe_small_samples_give_nan_intervals():
    empty = describe([NAN, None], seed=0)
    assert empty["n"] == 0 and empty["n_nan"] == 2
    assert all(math.isnan(empty[key]) for key in ("mean", "median", "std", "min", "max"))
    one = describe([4.0], seed=0)
    assert one["n"] == 1 and one["mean"] == 4.0 and one["median"] == 4.0
    assert all(math.isnan(x) for x in one["mean_ci"] + one["median_ci"]) and math.isnan(one["std"])


def test_describe_identical_trials_have_a_zero_width_interval():
    """The issue's symptom (every trial finishing at exactly 36.53 s): the interval is that value."""
    result = describe([36.53] * 10, seed=0, n_resamples=999)
    assert result["mean_ci"] == pytest.approx([36.53, 36.53]) and result["median_ci"] == pytest.approx([36.53, 36.53])


# --- success rates ----------------------------------------------------------------------------------

def test_success_rate_wilson_hand_computed():
    """8 of 10, z = 1.95996: centre (8 + z²/2) / (10 + z²) = 0.71673, half-width
    z / (10 + z²) · sqrt(8·2/10 + z²/4) = 0.22658, so 0.4902-0.9433."""
    result = success_rate(8, 10)
    assert result["rate"] == 0.8
    assert result["ci"] == pytest.approx([0.4902, 0.9433], abs=1e-4)


@pytest.mark.parametrize(("k", "n", "confidence"), [(8, 10, 0.95), (0, 5, 0.95), (5, 5, 0.95), (0, 1, 0.9),
                                                    (13, 40, 0.99), (1, 3, 0.5)])
def test_success_rate_matches_scipy_wilson(k, n, confidence):
    expected = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    assert success_rate(k, n, confidence)["ci"] == pytest.approx([expected.low, expected.high], abs=1e-12)


def test_success_rate_without_trials_is_nan():
    result = success_rate(0, 0)
    assert math.isnan(result["rate"]) and all(math.isnan(x) for x in result["ci"])


# --- two samples ------------------------------------------------------------------------------------

MALES = [19, 22, 16, 29, 24]  # scipy.stats.mannwhitneyu's documented example: U1 = 17, p = 0.1111
FEMALES = [20, 11, 17, 12]


def test_compare_values_scipy_documented_example():
    result = compare_values(MALES, FEMALES)
    assert result["u"] == 17.0 and result["p"] == pytest.approx(0.1111111111111111)
    assert result["rank_biserial"] == pytest.approx(2 * 17 / 20 - 1)  # 0.7: males tend to be older
    assert (result["median_a"], result["median_b"], result["median_difference"]) == (22.0, 14.5, 7.5)
    swapped = compare_values(FEMALES, MALES)
    assert swapped["u"] == 3.0 and swapped["rank_biserial"] == pytest.approx(-0.7)
    assert swapped["p"] == pytest.approx(result["p"])


def test_rank_biserial_is_cliffs_delta_with_ties():
    a = [1.0, 2.0, 2.0, 3.0, 5.0, 5.0]
    b = [2.0, 2.0, 4.0, 5.0]
    cliffs_delta = np.mean([np.sign(x - y) for x in a for y in b])
    assert compare_values(a, b)["rank_biserial"] == pytest.approx(cliffs_delta)


def test_compare_values_drops_nan_and_empty_samples_give_nan():
    result = compare_values([*MALES, NAN, None], [NAN, *FEMALES])
    assert (result["n_a"], result["n_b"], result["n_nan_a"], result["n_nan_b"]) == (5, 4, 2, 1)
    assert result["u"] == 17.0
    empty = compare_values([NAN], FEMALES)
    assert empty["n_a"] == 0 and math.isnan(empty["p"]) and math.isnan(empty["rank_biserial"])


def test_compare_successes_scipy_documented_example():
    result = compare_successes(8, 10, 1, 6)  # fisher_exact([[8, 2], [1, 5]]): 20.0, p = 0.034965034965034975
    assert result["odds_ratio"] == 20.0 and result["p"] == pytest.approx(0.034965034965034975)
    assert result["risk_difference"] == pytest.approx(0.8 - 1 / 6)


def test_risk_difference_interval_newcombe_example():
    """Newcombe (1998) Table II, example (a), 56/70 vs 48/80, method 10: 0.0524 to 0.3339."""
    result = compare_successes(56, 70, 48, 80)
    assert result["risk_difference"] == pytest.approx(0.2)
    assert result["risk_difference_ci"] == pytest.approx([0.0524, 0.3339], abs=1e-4)


def test_compare_successes_without_trials_is_nan():
    result = compare_successes(0, 0, 3, 4)
    assert math.isnan(result["p"]) and math.isnan(result["risk_difference"]) and result["rate_b"] == 0.75


# --- circular ---------------------------------------------------------------------------------------

def test_rayleigh_zar_example_27_1():
    """Zar (2010) Example 27.1, the eight trees of Example 26.2: r = 0.82522, mean 99°, z = 5.448,
    0.001 < P < 0.002."""
    result = circular_summary(np.deg2rad([45, 55, 81, 96, 110, 117, 132, 154]), seed=0, n_resamples=999)
    assert result["resultant_length"] == pytest.approx(0.82522, abs=1e-5)
    assert np.rad2deg(result["mean_rad"]) == pytest.approx(99.0, abs=0.05)
    assert result["rayleigh_z"] == pytest.approx(5.448, abs=1e-3)
    assert 0.001 < result["rayleigh_p"] < 0.002


def test_rayleigh_hand_computed():
    """0, 0, 0 and arccos(2/3): resultant (3 + 2/3, sqrt(5)/3), R_n² = 121/9 + 5/9 = 14, r = sqrt(14)/4,
    z = R_n²/n = 3.5; Zar's p = exp(sqrt(1 + 16 + 4 (16 - 14)) - 9) = exp(5 - 9) = e⁻⁴ = 0.0183, where
    the uncorrected exp(-z) would say 0.0302."""
    result = circular_summary([0.0, 0.0, 0.0, math.acos(2 / 3)], seed=0, n_resamples=999)
    assert result["mean_rad"] == pytest.approx(math.atan2(math.sqrt(5) / 3, 11 / 3))
    assert result["resultant_length"] == pytest.approx(math.sqrt(14) / 4)
    assert result["rayleigh_z"] == pytest.approx(3.5)
    assert result["rayleigh_p"] == pytest.approx(math.exp(-4.0))


def test_v_test_zar_example_27_2():
    """Zar (2010) Example 27.2, ten pigeons, expected 90°: V = 9.498, u = 4.248, P < 0.0005."""
    result = v_test(np.deg2rad([66, 75, 86, 88, 88, 93, 97, 101, 118, 130]), np.pi / 2)
    assert result["v"] == pytest.approx(9.498, abs=1e-3) and result["u"] == pytest.approx(4.248, abs=1e-3)
    assert result["p"] < 0.0005


def test_v_test_hand_computed_and_one_sided():
    """0, 0, π/2, π/2 against π/4: V = R_n = 2√2, u = 2√2 · sqrt(2/4) = 2, p = 1 - Φ(2) = 0.02275."""
    toward = v_test([0.0, 0.0, np.pi / 2, np.pi / 2], np.pi / 4)
    assert toward["u"] == pytest.approx(2.0) and toward["p"] == pytest.approx(0.0227501319481792)
    away = v_test([0.0, 0.0, np.pi / 2, np.pi / 2], np.pi / 4 + np.pi)
    assert away["u"] == pytest.approx(-2.0) and away["p"] == pytest.approx(1 - 0.0227501319481792)
    assert math.isnan(v_test([1.0], 0.0)["p"])


def test_circular_mean_interval_across_pi_stays_narrow():
    """Headings around ±π: the interval is a short arc through π, not the whole circle."""
    angles = np.pi + np.random.default_rng(3).normal(0.0, 0.1, 30)
    result = circular_summary(angles, seed=1, n_resamples=999)
    low, high = result["mean_ci_rad"]
    assert 0.0 < high - low < 0.2
    assert low <= result["mean_rad"] <= high
    assert abs(angle_difference_rad((low + high) / 2, np.pi)) < 0.05


def test_circular_summary_is_seeded_and_small_samples_are_nan():
    angles = np.random.default_rng(4).vonmises(1.0, 2.0, 15)
    assert circular_summary(angles, seed=2, n_resamples=999) == circular_summary(angles, seed=2, n_resamples=999)
    one = circular_summary([0.5, NAN], seed=0)
    assert one["n"] == 1 and one["n_nan"] == 1 and one["mean_rad"] == pytest.approx(0.5)
    assert math.isnan(one["rayleigh_p"]) and all(math.isnan(x) for x in one["mean_ci_rad"])


# --- conditions -------------------------------------------------------------------------------------

def _rows():
    rng = np.random.default_rng(7)
    rows = []
    for trial in range(30):
        antennae = ("fixed", "moving", "none")[trial % 3]
        finish_s = float(rng.normal({"fixed": 30.0, "moving": 25.0, "none": 31.0}[antennae], 2.0))
        rows.append({"trial": trial, "antennae": antennae, "finish_time_s": finish_s,
                     "success": bool(rng.random() < 0.8), "heading_rad": float(rng.vonmises(0.0, 4.0))})
    rows[4]["finish_time_s"] = NAN  # a moving ant that never finished
    del rows[7]["finish_time_s"]  # a moving trial without the metric at all
    return rows


def _column(rows, condition, key):
    return [row.get(key) for row in rows if row["antennae"] == condition]


def test_compare_conditions_gives_each_condition_and_each_comparison():
    rows = _rows()
    block = compare_conditions(rows, "antennae", ["finish_time_s"], success_key="success",
                               circular_keys=["heading_rad"], seed=5, n_resamples=999)
    assert list(block["conditions"]) == ["fixed", "moving", "none"] and block["reference"] == "fixed"
    moving = block["conditions"]["moving"]
    assert moving["n_trials"] == 10 and moving["metrics"]["finish_time_s"]["n_nan"] == 2
    assert moving["metrics"]["finish_time_s"] == describe(_column(rows, "moving", "finish_time_s"), seed=5,
                                                          n_resamples=999)
    k = sum(_column(rows, "moving", "success"))
    assert moving["success"] == success_rate(k, 10)
    assert moving["circular"]["heading_rad"] == circular_summary(_column(rows, "moving", "heading_rad"), seed=5,
                                                                  n_resamples=999)
    assert [(c["condition"], c["reference"]) for c in block["comparisons"]] == [("moving", "fixed"),
                                                                                ("none", "fixed")]
    first = block["comparisons"][0]
    assert first["metrics"]["finish_time_s"] == compare_values(_column(rows, "moving", "finish_time_s"),
                                                               _column(rows, "fixed", "finish_time_s"))
    assert first["metrics"]["finish_time_s"]["rank_biserial"] < -0.5  # moving antennae finish sooner
    k_fixed = sum(_column(rows, "fixed", "success"))
    assert first["success"] == compare_successes(k, 10, k_fixed, 10)


def test_compare_conditions_is_deterministic_and_serialises_to_plain_json():
    rows = _rows()
    kwargs = dict(success_key="success", circular_keys=["heading_rad"], seed=9, n_resamples=499)
    block = compare_conditions(rows, "antennae", ["finish_time_s"], **kwargs)
    assert json.dumps(block, sort_keys=True) == json.dumps(
        compare_conditions(rows, "antennae", ["finish_time_s"], **kwargs), sort_keys=True)

    def leaves(value):
        if isinstance(value, dict):
            assert all(type(key) is str for key in value)
            for item in value.values():
                yield from leaves(item)
        elif isinstance(value, list):
            for item in value:
                yield from leaves(item)
        else:
            yield value

    assert {type(leaf) for leaf in leaves(block)} <= {int, float, str}
    assert json.loads(json.dumps(block))["bootstrap"] == {"method": "percentile", "n_resamples": 499, "seed": 9}


def test_compare_conditions_reference_and_boolean_conditions():
    rows = [{"moving": flag, "t_s": float(t)} for flag, t in [(True, 1), (False, 5), (True, 2), (False, 6)]]
    block = compare_conditions(rows, "moving", ["t_s"], reference=False, seed=0, n_resamples=99)
    assert list(block["conditions"]) == ["true", "false"] and block["reference"] == "false"
    (comparison,) = block["comparisons"]
    assert comparison["condition"] == "true" and comparison["metrics"]["t_s"]["median_difference"] == -4.0
    single = compare_conditions(rows[:1], "moving", ["t_s"], seed=0)
    assert single["comparisons"] == [] and single["conditions"]["true"]["metrics"]["t_s"]["n"] == 1


# --- bad input --------------------------------------------------------------------------------------

ROWS = [{"c": "a", "t_s": 1.0, "success": True}, {"c": "b", "t_s": 2.0, "success": False}]


@pytest.mark.parametrize(("call", "message"), [
    (lambda: success_rate(11, 10), r"successes \(11\) must not exceed n \(10\)"),
    (lambda: success_rate(-1, 10), r"successes must be a non-negative integer count, got -1"),
    (lambda: success_rate(2.5, 10), r"successes must be a non-negative integer count, got 2.5"),
    (lambda: success_rate(1, 2, confidence=95), r"confidence must be a number between 0 and 1"),
    (lambda: compare_successes(3, 2, 1, 2), r"k1 \(3\) must not exceed n1 \(2\)"),
    (lambda: compare_successes(1, 2, 1, -2), r"n2 must be a non-negative integer count, got -2"),
    (lambda: describe("1,2,3", seed=0), r"values must be a 1-D sequence of numbers, got str"),
    (lambda: describe(np.ones((2, 3)), seed=0), r"values must be 1-D, got an array of shape \(2, 3\)"),
    (lambda: describe([1.0, "a"], seed=0), r"values\[1\] is 'a', not a number"),
    (lambda: describe([True, False], seed=0), r"values\[0\] is True, not a number"),
    (lambda: describe([1.0, math.inf], seed=0), r"values\[1\] is inf; values must be finite"),
    (lambda: describe([1.0, 2.0], seed=-1), r"seed must be a non-negative integer, got -1"),
    (lambda: describe([1.0, 2.0], seed=0, n_resamples=0), r"n_resamples must be a positive integer"),
    (lambda: compare_values([1.0], {"x": 1}), r"b must be a 1-D sequence of numbers, got dict"),
    (lambda: circular_summary([0.1, None, "n"], seed=0), r"angles_rad\[2\] is 'n', not a number"),
    (lambda: v_test([0.1, 0.2], "north"), r"expected_rad must be a finite number"),
    (lambda: compare_conditions([], "c", ["t_s"], seed=0), r"rows is empty"),
    (lambda: compare_conditions([*ROWS, {"t_s": 3.0}], "c", ["t_s"], seed=0),
     r"rows\[2\] has no condition column 'c'"),
    (lambda: compare_conditions(ROWS, "c", "t_s", seed=0), r"metric_keys must be a list of column names"),
    (lambda: compare_conditions(ROWS, "c", ["time_s"], seed=0), r"no row has the column 'time_s'"),
    (lambda: compare_conditions([*ROWS, {"c": "a", "t_s": "slow"}], "c", ["t_s"], seed=0),
     r"condition 'a', column 't_s': t_s\[1\] is 'slow', not a number"),
    (lambda: compare_conditions([{"c": "a", "success": "yes"}], "c", success_key="success", seed=0),
     r"rows\[0\]\['success'\] is 'yes'; success must be true/false"),
    (lambda: compare_conditions(ROWS, "c", ["t_s"], reference="z", seed=0),
     r"reference 'z' is not a condition of 'c'; conditions: a, b"),
])
def test_bad_input_names_the_argument(call, message):
    with pytest.raises(ConfigError, match=message):
        call()
