"""A scenario's aggregates: statistics over its finished trials, per condition (antenna mode, eye, conflict).

A scenario's ``aggregate(trials, config)`` names its statistics once, each a function of a group's rows
under a key template whose ``{}`` takes the condition's label, and :func:`per_condition` fills them in,
a group per condition, leaving out conditions no finished trial ran under:

    per_condition(trials, "eye_mode", {"success_{}": success_rate,
                                       "median_time_{}_s": finite_median_of("time_to_landmark_s")},
                  labels=dict(enumerate(EYE_MODES)))

gives ``{"success_left": ..., "median_time_left_s": ..., "success_right": ...}``. Failed trials (a
``status`` other than ``"ok"``) count in no statistic.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

Statistic = Callable[[list[dict]], "float | None"]
"""A group's rows -> a number, or None to leave the key out for that group."""


def finished_trials(trials: list[dict]) -> list[dict]:
    """The trials whose ``status`` is ``"ok"`` (a row without one counts as finished)."""
    return [t for t in trials if t.get("status", "ok") == "ok"]


def success_rate(rows: list[dict]) -> float:
    """The fraction of ``rows`` whose ``success`` is true."""
    return float(np.mean([bool(t["success"]) for t in rows]))


def mean_of(key: str) -> Statistic:
    """The statistic: the mean of column ``key``."""
    return lambda rows: float(np.mean([t[key] for t in rows]))


def finite_median_of(key: str) -> Statistic:
    """The statistic: the median of the finite values of column ``key`` (NaN when there are none, e.g.
    a time to the goal when no trial reached it)."""
    def median(rows: list[dict]) -> float:
        values = [t[key] for t in rows if np.isfinite(t[key])]
        return float(np.median(values)) if values else float("nan")

    return median


def summarise(rows: list[dict], statistics: Mapping[str, Statistic], label: str = "") -> dict[str, float]:
    """Every statistic of one group of rows, under its key template filled with ``label``; a statistic
    that returns None is left out."""
    result = {}
    for template, statistic in statistics.items():
        value = statistic(rows)
        if value is not None:
            result[template.format(label)] = value
    return result


def per_condition(trials: list[dict], key: str, statistics: Mapping[str, Statistic],
                  labels: Mapping | None = None) -> dict[str, float]:
    """The statistics of the finished trials, a group per value of column ``key``.

    Parameters
    ----------
    trials : list of dict
        The trial rows (failed ones are skipped).
    key : str
        The column naming a trial's condition.
    statistics : mapping of str to callable
        Key template (``"{}"`` stands for the condition's label) -> statistic of a group's rows.
    labels : mapping or None
        Condition value -> its label, in the order of the result; None: every value the finished
        trials hold, in increasing order, each labelled ``f"{value:g}"``.

    Returns
    -------
    dict of str to float
        Condition after condition, each statistic in the order given; conditions without a finished
        trial are left out.
    """
    rows = finished_trials(trials)
    if labels is None:
        labels = {value: f"{value:g}" for value in sorted({t[key] for t in rows})}
    result = {}
    for value, label in labels.items():
        group = [t for t in rows if t.get(key) == value]
        if group:
            result.update(summarise(group, statistics, label))
    return result
