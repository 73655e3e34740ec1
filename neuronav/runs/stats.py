"""Statistics of a run's trials: descriptions with intervals, comparisons as tests with effect sizes.

Engine-free functions over the per-trial numbers a scenario already produces; each returns a plain
dict of ``int``, ``float``, ``str`` and lists of floats that ``json.dumps`` writes as it is (NaN where
a number is undefined: too few trials, an empty condition).

- :func:`describe` — n, mean and median of a metric, each with a seeded **percentile** bootstrap
  confidence interval (``scipy.stats.bootstrap``); NaN and ``None`` values are dropped and counted.
- :func:`success_rate` — a rate with its **Wilson score** interval (Wilson 1927).
- :func:`compare_values` — **Mann-Whitney U** (two-sided) with the **rank-biserial correlation** as the
  effect size and the difference of medians.
- :func:`compare_successes` — **Fisher's exact test** (two-sided), the sample odds ratio, and the risk
  difference with **Newcombe's hybrid score** interval (Newcombe 1998, method 10).
- :func:`circular_summary` and :func:`v_test` — headings: circular mean with a bootstrap interval,
  resultant length, **Rayleigh** test; the **V-test** against an expected direction (Zar 2010, ch. 27).
- :func:`compare_conditions` — all of the above over a run's trial rows grouped by condition: the block
  a ``summary.json`` carries.

Sign conventions: every comparison is *first argument minus second* (``a`` vs ``b``; in
:func:`compare_conditions`, each condition vs the reference), so a positive effect means the first
sample's values (or success rate) are the larger.

Bad input (a wrong type, a string of numbers, an infinite value, a negative count, more successes than
trials, a confidence outside (0, 1)) raises :class:`neuronav.errors.ConfigError` naming the argument.

References
----------
Durand, D. & Greenwood, J. A. (1958). Modifications of the Rayleigh test for uniformity in analysis of
two-dimensional orientation data. *Journal of Geology* 66, 229-238.
Fisher, N. I. (1993). *Statistical Analysis of Circular Data*. Cambridge University Press.
Newcombe, R. G. (1998). Interval estimation for the difference between independent proportions:
comparison of eleven methods. *Statistics in Medicine* 17, 873-890.
Wilson, E. B. (1927). Probable inference, the law of succession, and statistical inference. *JASA* 22, 209-212.
Zar, J. H. (2010). *Biostatistical Analysis*, 5th ed. Pearson. Chapter 27 (Rayleigh test, V-test).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from numbers import Integral, Real
from typing import Any

import numpy as np
from scipy import special, stats

from neuronav.angles import angle_difference_rad, wrap_rad
from neuronav.errors import ConfigError

BOOTSTRAP_METHOD = "percentile"
"""The bootstrap interval of every ``*_ci`` here: the percentiles of the resampled statistic."""

DEFAULT_RESAMPLES = 9999
"""Bootstrap resamples by default (scipy's default)."""

# Recent scipy names the generator ``rng``, older releases (the project allows >= 1.11) ``random_state``.
_RNG_KEYWORD = "rng" if "rng" in inspect.signature(stats.bootstrap).parameters else "random_state"

_NAN = float("nan")


# --- checks -----------------------------------------------------------------------------------------

def _check_seed(seed: Any) -> int:
    if not isinstance(seed, Integral) or isinstance(seed, bool) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _check_confidence(confidence: Any) -> float:
    value = _real(confidence)
    if not 0.0 < value < 1.0:
        raise ConfigError(f"confidence must be a number between 0 and 1 (exclusive), got {confidence!r}")
    return value


def _check_resamples(n_resamples: Any) -> int:
    if not isinstance(n_resamples, Integral) or isinstance(n_resamples, bool) or n_resamples < 1:
        raise ConfigError(f"n_resamples must be a positive integer, got {n_resamples!r}")
    return int(n_resamples)


def _check_count(name: str, value: Any) -> int:
    if not isinstance(value, Integral) or isinstance(value, bool) or value < 0:
        raise ConfigError(f"{name} must be a non-negative integer count, got {value!r}")
    return int(value)


def _check_counts(k_name: str, k: Any, n_name: str, n: Any) -> tuple[int, int]:
    k, n = _check_count(k_name, k), _check_count(n_name, n)
    if k > n:
        raise ConfigError(f"{k_name} ({k}) must not exceed {n_name} ({n})")
    return k, n


def _is_number(value: Any) -> bool:
    """Whether ``value`` is a real number (a bool is not)."""
    return isinstance(value, Real) and not isinstance(value, bool | np.bool_)


def _real(value: Any) -> float:
    """``value`` as a float when it is a real number, else NaN."""
    return float(value) if _is_number(value) else _NAN


def _sample(name: str, values: Any) -> tuple[np.ndarray, int]:
    """The finite values of a 1-D sample and how many were missing (NaN or None)."""
    if isinstance(values, str | bytes | Mapping) or not isinstance(values, Iterable):
        raise ConfigError(f"{name} must be a 1-D sequence of numbers, got {type(values).__name__}")
    if isinstance(values, np.ndarray) and values.ndim != 1:
        raise ConfigError(f"{name} must be 1-D, got an array of shape {values.shape}")
    floats = []
    for i, value in enumerate(values):
        if value is not None and not _is_number(value):
            raise ConfigError(f"{name}[{i}] is {value!r}, not a number")
        number = _NAN if value is None else float(value)
        if math.isinf(number):
            raise ConfigError(f"{name}[{i}] is {value!r}; values must be finite (NaN or None for missing)")
        floats.append(number)
    array = np.asarray(floats, dtype=float)
    missing = np.isnan(array)
    return array[~missing], int(missing.sum())


def _pair(values: Sequence[float]) -> list[float]:
    return [float(values[0]), float(values[1])]


# --- one sample -------------------------------------------------------------------------------------

def _bootstrap_ci(sample: np.ndarray, statistic: Callable, seed: int, confidence: float,
                  n_resamples: int) -> list[float]:
    """The percentile bootstrap interval of ``statistic(sample, axis)``; NaNs when fewer than 2 values."""
    if sample.size < 2:
        return [_NAN, _NAN]
    result = stats.bootstrap((sample,), statistic, n_resamples=n_resamples, vectorized=True,
                             confidence_level=confidence, method=BOOTSTRAP_METHOD,
                             **{_RNG_KEYWORD: np.random.default_rng(seed)})
    return _pair((result.confidence_interval.low, result.confidence_interval.high))


def describe(values: Iterable[float], *, seed: int, confidence: float = 0.95,
             n_resamples: int = DEFAULT_RESAMPLES) -> dict[str, Any]:
    """n, mean and median of a sample, each with a seeded percentile bootstrap confidence interval.

    Parameters
    ----------
    values : sequence of float, shape (N,)
        One number per trial (any unit: the results carry it). NaN and ``None`` mark missing values
        (e.g. the finish time of an ant that never finished): they are dropped and counted.
    seed : int
        Seed of the bootstrap's ``np.random.Generator``; the mean's and the median's intervals each
        start a generator from it, so the result does not depend on which other statistics are asked.
    confidence : float, optional
        Coverage of the intervals, in (0, 1).
    n_resamples : int, optional
        Bootstrap resamples.

    Returns
    -------
    dict
        ``n`` (values used), ``n_nan`` (dropped), ``mean``, ``mean_ci`` ([low, high]), ``median``,
        ``median_ci``, ``std`` (sample standard deviation, ddof 1), ``min``, ``max``, ``confidence``,
        ``ci_method`` (``"percentile bootstrap"``). With no values every number is NaN; with one, the
        intervals and ``std`` are NaN. Never raises for a small sample.
    """
    sample, n_nan = _sample("values", values)
    seed, confidence = _check_seed(seed), _check_confidence(confidence)
    n_resamples = _check_resamples(n_resamples)
    n = int(sample.size)
    return {
        "n": n,
        "n_nan": n_nan,
        "mean": float(np.mean(sample)) if n else _NAN,
        "mean_ci": _bootstrap_ci(sample, np.mean, seed, confidence, n_resamples),
        "median": float(np.median(sample)) if n else _NAN,
        "median_ci": _bootstrap_ci(sample, np.median, seed, confidence, n_resamples),
        "std": float(np.std(sample, ddof=1)) if n >= 2 else _NAN,
        "min": float(np.min(sample)) if n else _NAN,
        "max": float(np.max(sample)) if n else _NAN,
        "confidence": confidence,
        "ci_method": f"{BOOTSTRAP_METHOD} bootstrap",
    }


def _wilson(k: int, n: int, confidence: float) -> list[float]:
    """Wilson's score interval of the proportion ``k / n`` (NaNs for ``n == 0``)."""
    if n == 0:
        return [_NAN, _NAN]
    z = float(special.ndtri(0.5 + confidence / 2.0))
    centre = (k + z * z / 2.0) / (n + z * z)
    half = z / (n + z * z) * math.sqrt(k * (n - k) / n + z * z / 4.0)
    return [max(0.0, centre - half), min(1.0, centre + half)]


def success_rate(successes: int, n: int, confidence: float = 0.95) -> dict[str, Any]:
    """A success rate with its Wilson score interval.

    Parameters
    ----------
    successes : int
        Trials that succeeded, 0 <= successes <= n.
    n : int
        Trials.
    confidence : float, optional
        Coverage of the interval, in (0, 1).

    Returns
    -------
    dict
        ``successes``, ``n``, ``rate`` (successes / n), ``ci`` ([low, high], Wilson 1927, without
        continuity correction: the same as ``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``),
        ``confidence``, ``ci_method``. For ``n == 0`` the rate and interval are NaN.
    """
    k, n = _check_counts("successes", successes, "n", n)
    confidence = _check_confidence(confidence)
    return {
        "successes": k,
        "n": n,
        "rate": k / n if n else _NAN,
        "ci": _wilson(k, n, confidence),
        "confidence": confidence,
        "ci_method": "Wilson score",
    }


# --- two samples ------------------------------------------------------------------------------------

def compare_values(a: Iterable[float], b: Iterable[float]) -> dict[str, Any]:
    """Mann-Whitney U test (two-sided) of two samples, its effect size and the difference of medians.

    Parameters
    ----------
    a, b : sequence of float
        The two samples (same unit); NaN and ``None`` are dropped and counted.

    Returns
    -------
    dict
        ``n_a``, ``n_b``, ``n_nan_a``, ``n_nan_b``; ``median_a``, ``median_b`` and ``median_difference``
        (``median_a - median_b``); ``u`` (the U statistic of ``a``, as ``scipy.stats.mannwhitneyu``
        reports it), ``p`` (two-sided; scipy's ``method="auto"``: exact for small samples without
        ties, else the normal approximation with continuity correction); ``rank_biserial``
        (``2 u / (n_a n_b) - 1`` in [-1, 1]: the probability that a value of ``a`` exceeds one of
        ``b`` minus the reverse, ties counting half — the same number as Cliff's delta; positive when
        ``a`` tends to be larger); ``test``. With an empty sample the test fields are NaN.
    """
    sample_a, nan_a = _sample("a", a)
    sample_b, nan_b = _sample("b", b)
    n_a, n_b = int(sample_a.size), int(sample_b.size)
    median_a = float(np.median(sample_a)) if n_a else _NAN
    median_b = float(np.median(sample_b)) if n_b else _NAN
    u = p = effect = _NAN
    if n_a and n_b:
        result = stats.mannwhitneyu(sample_a, sample_b, alternative="two-sided")
        u, p = float(result.statistic), float(result.pvalue)
        effect = 2.0 * u / (n_a * n_b) - 1.0
    return {
        "n_a": n_a, "n_b": n_b, "n_nan_a": nan_a, "n_nan_b": nan_b,
        "median_a": median_a, "median_b": median_b, "median_difference": median_a - median_b,
        "u": u, "p": p, "rank_biserial": effect,
        "test": "Mann-Whitney U, two-sided",
    }


def compare_successes(k1: int, n1: int, k2: int, n2: int, confidence: float = 0.95) -> dict[str, Any]:
    """Fisher's exact test (two-sided) of two success counts, odds ratio and risk difference.

    Parameters
    ----------
    k1, n1 : int
        Successes and trials of the first group (``a``).
    k2, n2 : int
        Successes and trials of the second group (``b``).
    confidence : float, optional
        Coverage of the risk difference's interval, in (0, 1).

    Returns
    -------
    dict
        ``successes_a``, ``n_a``, ``successes_b``, ``n_b``, ``rate_a``, ``rate_b``; ``risk_difference``
        (``rate_a - rate_b``) and ``risk_difference_ci`` (Newcombe's hybrid score interval, method 10,
        built from the two Wilson intervals); ``odds_ratio`` (the sample odds ratio
        ``k1 (n2 - k2) / ((n1 - k1) k2)``, as ``scipy.stats.fisher_exact`` gives it: ``inf`` or NaN
        when a cell is zero), ``p`` (two-sided), ``confidence``, ``test``. When a group has no trials
        the rates, difference, odds ratio and p are NaN.
    """
    k1, n1 = _check_counts("k1", k1, "n1", n1)
    k2, n2 = _check_counts("k2", k2, "n2", n2)
    confidence = _check_confidence(confidence)
    rate_a = k1 / n1 if n1 else _NAN
    rate_b = k2 / n2 if n2 else _NAN
    difference, interval, odds, p = _NAN, [_NAN, _NAN], _NAN, _NAN
    if n1 and n2:
        low_a, high_a = _wilson(k1, n1, confidence)
        low_b, high_b = _wilson(k2, n2, confidence)
        difference = rate_a - rate_b
        interval = [difference - math.hypot(rate_a - low_a, high_b - rate_b),
                    difference + math.hypot(high_a - rate_a, rate_b - low_b)]
        result = stats.fisher_exact([[k1, n1 - k1], [k2, n2 - k2]], alternative="two-sided")
        odds, p = float(result.statistic), float(result.pvalue)
    return {
        "successes_a": k1, "n_a": n1, "successes_b": k2, "n_b": n2,
        "rate_a": rate_a, "rate_b": rate_b,
        "risk_difference": difference, "risk_difference_ci": interval,
        "odds_ratio": odds, "p": p, "confidence": confidence,
        "test": "Fisher's exact, two-sided",
    }


# --- circular ---------------------------------------------------------------------------------------

def _resultant(angles_rad: np.ndarray) -> tuple[float, float]:
    """The mean direction (rad, in [-pi, pi)) and mean resultant length of a non-empty sample."""
    c, s = float(np.mean(np.cos(angles_rad))), float(np.mean(np.sin(angles_rad)))
    return float(wrap_rad(math.atan2(s, c))), math.hypot(c, s)


def _rayleigh_p(n: int, resultant_length: float) -> float:
    """p-value of the Rayleigh test of uniformity, with Zar's small-sample approximation.

    ``p = exp(sqrt(1 + 4 n + 4 (n^2 - R_n^2)) - (1 + 2 n))`` with ``R_n = n r`` (Zar 2010, sect. 27.1),
    instead of the large-sample ``exp(-z)``, ``z = R_n^2 / n``, which overstates significance in
    small samples (Fisher 1993, p. 70, corrects ``exp(-z)`` by a series in 1/n to the same end).

    Parameters
    ----------
    n : int
        Sample size (>= 2; NaN is returned below).
    resultant_length : float
        Mean resultant length r, in [0, 1].
    """
    if n < 2:
        return _NAN
    big_r = n * resultant_length
    return float(min(1.0, math.exp(math.sqrt(1.0 + 4.0 * n + 4.0 * (n * n - big_r * big_r)) - (1.0 + 2.0 * n))))


def circular_summary(angles_rad: Iterable[float], *, seed: int, confidence: float = 0.95,
                     n_resamples: int = DEFAULT_RESAMPLES) -> dict[str, Any]:
    """Circular mean with a bootstrap interval, resultant length and Rayleigh test of a set of headings.

    Parameters
    ----------
    angles_rad : sequence of float, shape (N,)
        Directions (rad), any turn; NaN and ``None`` are dropped and counted.
    seed : int
        Seed of the bootstrap's ``np.random.Generator``.
    confidence : float, optional
        Coverage of the interval, in (0, 1).
    n_resamples : int, optional
        Bootstrap resamples.

    Returns
    -------
    dict
        ``n``, ``n_nan``; ``mean_rad`` (``scipy.stats.circmean``, in [-pi, pi)); ``mean_ci_rad``: the
        percentile bootstrap interval of the circular mean, [low, high] with low <= high, not wrapped
        (it may pass ±pi): the percentiles of each resample's mean minus the sample's mean, each
        difference taken the short way round, added to ``mean_rad``; ``resultant_length`` (r in [0, 1]);
        ``circular_std_rad`` (``scipy.stats.circstd``, sqrt(-2 ln r)); ``rayleigh_z`` (``n r^2``) and
        ``rayleigh_p`` (Zar's small-sample approximation, see ``_rayleigh_p``; H0: uniform, against one
        preferred direction); ``confidence``, ``ci_method``. With no angles every number is NaN; with
        one, the interval and the test are NaN.
        When r is near 0 the mean is ill-defined and its interval spans most of the circle.
    """
    sample, n_nan = _sample("angles_rad", angles_rad)
    seed, confidence = _check_seed(seed), _check_confidence(confidence)
    n_resamples = _check_resamples(n_resamples)
    n = int(sample.size)
    mean_rad = r = _NAN
    interval = [_NAN, _NAN]
    if n:
        mean_rad = float(wrap_rad(stats.circmean(sample, high=np.pi, low=-np.pi)))
        r = _resultant(sample)[1]

        def deviation_rad(x, axis):
            return angle_difference_rad(stats.circmean(x, high=np.pi, low=-np.pi, axis=axis), mean_rad)

        offsets = _bootstrap_ci(sample, deviation_rad, seed, confidence, n_resamples)
        interval = [mean_rad + offsets[0], mean_rad + offsets[1]]
    return {
        "n": n,
        "n_nan": n_nan,
        "mean_rad": mean_rad,
        "mean_ci_rad": interval,
        "resultant_length": r,
        "circular_std_rad": float(stats.circstd(sample, high=np.pi, low=-np.pi)) if n else _NAN,
        "rayleigh_z": n * r * r if n >= 2 else _NAN,
        "rayleigh_p": _rayleigh_p(n, r),
        "confidence": confidence,
        "ci_method": f"{BOOTSTRAP_METHOD} bootstrap",
    }


def v_test(angles_rad: Iterable[float], expected_rad: float) -> dict[str, Any]:
    """The V-test: are the headings clustered around an expected direction? (Zar 2010, ch. 27)

    ``V = R_n cos(mean - expected)`` with ``R_n = n r`` the resultant length, ``u = V sqrt(2 / n)``;
    the one-sided p is ``1 - Phi(u)``, the normal approximation of u's distribution under uniformity
    (Durand & Greenwood 1958); for small n Zar tabulates exact critical values of u, which this
    approximation does not reproduce exactly.

    Parameters
    ----------
    angles_rad : sequence of float, shape (N,)
        Directions (rad); NaN and ``None`` are dropped and counted.
    expected_rad : float
        The direction of the alternative hypothesis (rad).

    Returns
    -------
    dict
        ``n``, ``n_nan``, ``expected_rad``, ``v``, ``u``, ``p`` (one-sided; NaN for n < 2), ``test``.
    """
    sample, n_nan = _sample("angles_rad", angles_rad)
    expected = _real(expected_rad)
    if not math.isfinite(expected):
        raise ConfigError(f"expected_rad must be a finite number (rad), got {expected_rad!r}")
    n = int(sample.size)
    v = u = p = _NAN
    if n >= 2:
        mean_rad, r = _resultant(sample)
        v = n * r * math.cos(mean_rad - expected)
        u = v * math.sqrt(2.0 / n)
        p = float(special.ndtr(-u))
    return {"n": n, "n_nan": n_nan, "expected_rad": expected, "v": v, "u": u, "p": p,
            "test": "V-test, one-sided"}


# --- conditions of a run ----------------------------------------------------------------------------

def _label(value: Any) -> str:
    """A condition's name: the text of its value, ``true``/``false`` for booleans (as grid labels)."""
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    return str(value)


def _keys(name: str, keys: Any) -> list[str]:
    if isinstance(keys, str) or not isinstance(keys, Iterable):
        raise ConfigError(f"{name} must be a list of column names, got {keys!r}")
    keys = list(keys)
    for key in keys:
        if not isinstance(key, str) or not key:
            raise ConfigError(f"{name} must hold column names (non-empty strings), got {key!r}")
    return keys


def _success(value: Any, index: int, key: str) -> bool | None:
    """A row's success as a bool, or None when it is missing (None or NaN)."""
    if value is None or (isinstance(value, float | np.floating) and math.isnan(value)):
        return None
    if isinstance(value, bool | np.bool_) or (isinstance(value, Integral) and value in (0, 1)):
        return bool(value)
    if isinstance(value, Real) and value in (0.0, 1.0):
        return bool(value)
    raise ConfigError(f"rows[{index}][{key!r}] is {value!r}; success must be true/false (or 1/0)")


def compare_conditions(rows: Sequence[Mapping[str, Any]], condition_key: str,
                       metric_keys: Sequence[str] = (), *, success_key: str | None = None,
                       circular_keys: Sequence[str] = (), reference: Any = None, seed: int,
                       confidence: float = 0.95, n_resamples: int = DEFAULT_RESAMPLES) -> dict[str, Any]:
    """Per-condition statistics of a run's trials and each condition's comparison with a reference.

    Parameters
    ----------
    rows : sequence of dict
        One dict per trial (the rows of ``trials.csv`` / ``ScenarioResult.trials``).
    condition_key : str
        The column naming each trial's condition (e.g. ``antennae``); conditions are named by the
        text of the value (``true``/``false`` for booleans) and kept in order of first appearance.
    metric_keys : sequence of str
        Numeric columns to describe (:func:`describe`) and compare (:func:`compare_values`). A row
        without the column, or with NaN/None, counts as missing; a column absent from every row is an
        error.
    success_key : str, optional
        A true/false column: per condition :func:`success_rate`, compared by :func:`compare_successes`.
        Rows where it is None or NaN are left out of the counts.
    circular_keys : sequence of str, optional
        Heading columns (rad) summarised per condition by :func:`circular_summary` (not compared).
    reference : optional
        The condition the others are compared against (its value or its name); the first by default.
    seed : int
        Seed of every bootstrap (each interval starts its own generator from it): the block is the
        same for the same rows and seed.
    confidence, n_resamples : optional
        As in :func:`describe`.

    Returns
    -------
    dict
        ``condition_key``, ``reference`` (name), ``confidence``, ``bootstrap`` (``method``,
        ``n_resamples``, ``seed``), ``conditions`` (name -> ``n_trials``, ``metrics`` {key: describe},
        ``success`` (if ``success_key``), ``circular`` {key: circular_summary}), and ``comparisons``:
        one entry per condition other than the reference, ``{"condition", "reference", "metrics":
        {key: compare_values(condition, reference)}, "success": compare_successes(condition,
        reference)}`` — effects are *condition minus reference*. Empty with a single condition.
    """
    if isinstance(rows, str | bytes | Mapping) or not isinstance(rows, Iterable):
        raise ConfigError(f"rows must be a list of per-trial dicts, got {type(rows).__name__}")
    rows = list(rows)
    if not rows:
        raise ConfigError("rows is empty: no trials to compare")
    if not isinstance(condition_key, str) or not condition_key:
        raise ConfigError(f"condition_key must be a column name, got {condition_key!r}")
    metric_keys, circular_keys = _keys("metric_keys", metric_keys), _keys("circular_keys", circular_keys)
    if success_key is not None and (not isinstance(success_key, str) or not success_key):
        raise ConfigError(f"success_key must be a column name or None, got {success_key!r}")
    seed, confidence = _check_seed(seed), _check_confidence(confidence)
    n_resamples = _check_resamples(n_resamples)

    groups: dict[str, list[int]] = {}  # condition name -> indices of its rows
    for i, row in enumerate(rows):
        if not isinstance(row, Mapping):
            raise ConfigError(f"rows[{i}] must be a dict, got {type(row).__name__}")
        if condition_key not in row:
            raise ConfigError(f"rows[{i}] has no condition column {condition_key!r}")
        groups.setdefault(_label(row[condition_key]), []).append(i)
    for key in [*metric_keys, *circular_keys, *([success_key] if success_key else [])]:
        if not any(key in row for row in rows):
            raise ConfigError(f"no row has the column {key!r}; columns: {', '.join(sorted(rows[0]))}")

    names = list(groups)
    reference_name = names[0] if reference is None else _label(reference)
    if reference_name not in groups:
        raise ConfigError(f"reference {reference!r} is not a condition of {condition_key!r}; "
                          f"conditions: {', '.join(names)}")

    def column(name: str, key: str) -> list:
        return [rows[i].get(key) for i in groups[name]]

    def column_checked(name: str, key: str) -> list:
        values = column(name, key)
        try:
            _sample(key, values)
        except ConfigError as error:
            raise ConfigError(f"condition {name!r}, column {key!r}: {error}") from None
        return values

    def successes(name: str) -> tuple[int, int]:
        flags = [_success(rows[i].get(success_key), i, success_key) for i in groups[name]]
        known = [flag for flag in flags if flag is not None]
        return sum(known), len(known)

    conditions: dict[str, dict[str, Any]] = {}
    for name in names:
        entry: dict[str, Any] = {
            "n_trials": len(groups[name]),
            "metrics": {key: describe(column_checked(name, key), seed=seed, confidence=confidence,
                                      n_resamples=n_resamples) for key in metric_keys},
        }
        if success_key:
            entry["success"] = success_rate(*successes(name), confidence=confidence)
        entry["circular"] = {key: circular_summary(column_checked(name, key), seed=seed, confidence=confidence,
                                                   n_resamples=n_resamples) for key in circular_keys}
        conditions[name] = entry

    comparisons = []
    for name in names:
        if name == reference_name:
            continue
        comparison: dict[str, Any] = {
            "condition": name,
            "reference": reference_name,
            "metrics": {key: compare_values(column(name, key), column(reference_name, key)) for key in metric_keys},
        }
        if success_key:
            comparison["success"] = compare_successes(*successes(name), *successes(reference_name),
                                                      confidence=confidence)
        comparisons.append(comparison)

    return {
        "condition_key": condition_key,
        "reference": reference_name,
        "confidence": confidence,
        "bootstrap": {"method": BOOTSTRAP_METHOD, "n_resamples": n_resamples, "seed": seed},
        "conditions": conditions,
        "comparisons": comparisons,
    }
