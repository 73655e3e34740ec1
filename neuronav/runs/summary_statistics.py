"""The ``statistics`` block of a run's, a sweep's and a comparison's summary.

A run's trials are grouped by the condition its scenario compares (:class:`Statistics`: antennae
fixed or moving, the eye used, the cues, ...; one group ``all`` when it compares none). Per group:
n, the mean and median of every metric with seeded 95 % bootstrap intervals, the success rate with
its Wilson interval, headings summarised as circular data; then each condition against the reference
(Mann-Whitney U with the rank-biserial effect for metrics, Fisher's exact test with the risk
difference for success), all from :mod:`neuronav.runs.stats`. A sweep compares its grid points the
same way (each against the first); ``neuronav compare`` puts each backend's block side by side and says
whether the backends agree on the direction of every effect, with a test across backends.

Failed trials are left out (their count is given): a trial that failed measured nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from neuronav.errors import ConfigError
from neuronav.runs.stats import compare_conditions

# Columns every trial row has that are not measurements.
BOOKKEEPING = frozenset({"trial", "seed", "status", "error", "success"})
SINGLE = "_all"  # the column a run without conditions is grouped by (one group, "all")


@dataclass(frozen=True)
class Statistics:
    """What a scenario's summary compares.

    Attributes
    ----------
    condition : str or None
        The per-trial column naming each trial's condition (None: the run is one group).
    metrics : tuple of str
        Metrics described and compared; empty: every numeric per-trial metric of the rows (timing
        metrics, the condition and the circular columns excepted).
    circular : tuple of str
        Heading columns (rad), summarised as circular data.
    success : str or None
        The true/false column of success.
    reference : str or None
        The condition the others are compared against (default: the first met).
    """

    condition: str | None = None
    metrics: tuple[str, ...] = ()
    circular: tuple[str, ...] = ()
    success: str | None = "success"
    reference: str | None = None


def resamples_for(n: int) -> int:
    """Bootstrap resamples for n values: 1999 for small runs, fewer for large ones (the intervals of
    thousands of trials are narrow, and the bootstrap's cost grows with n times the resamples)."""
    return int(np.clip(2_000_000 // max(n, 1), 199, 1999))


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool | np.bool_)


def metric_columns(rows: list[dict], spec: Statistics, timing: tuple[str, ...] = ()) -> list[str]:
    """The numeric per-trial metrics of ``rows`` that ``spec`` describes (in first-seen order)."""
    if spec.metrics:
        return list(spec.metrics)
    skip = set(BOOKKEEPING) | set(timing) | set(spec.circular) | {spec.condition}
    seen: dict[str, bool] = {}
    for row in rows:
        for key, value in row.items():
            if key in skip:
                continue
            numeric = _is_number(value) or value is None
            seen[key] = seen.get(key, True) and numeric
    return [key for key, numeric in seen.items() if numeric and any(_is_number(r.get(key)) for r in rows)]


def run_statistics(rows: list[dict], spec: Statistics, *, seed: int, timing: tuple[str, ...] = ()) -> dict:
    """The statistics block of one run's ``rows`` (see the module docstring).

    Never raises for the data: a block that cannot be computed carries a ``note`` instead.
    """
    finished = [row for row in rows if row.get("status", "ok") == "ok"]
    block: dict[str, Any] = {"condition": spec.condition, "n_trials": len(rows),
                             "n_failed": len(rows) - len(finished)}
    if not finished:
        return block | {"note": "no trial finished"}
    key = spec.condition or SINGLE
    if spec.condition is None:
        finished = [dict(row, **{SINGLE: "all"}) for row in finished]
    success = spec.success if spec.success and all(spec.success in row for row in finished) else None
    circular = [c for c in spec.circular if any(_is_number(row.get(c)) for row in finished)]
    try:
        table = compare_conditions(finished, key, metric_columns(finished, spec, timing), success_key=success,
                                   circular_keys=circular, reference=spec.reference, seed=seed,
                                   n_resamples=resamples_for(len(finished)))
    except ConfigError as error:
        return block | {"note": f"statistics not computed: {error}"}
    table.pop("condition_key", None)
    return block | table


def agreement(blocks: dict[str, dict]) -> dict:
    """Whether the backends' runs agree: for each comparison (condition vs reference) and metric, the
    sign of the effect per backend and whether all signs are the same (ties at 0 agree with anything).

    ``blocks``: backend name -> its run's statistics block.
    """
    signs: dict[str, dict[str, dict[str, float]]] = {}
    for backend, block in blocks.items():
        for comparison in block.get("comparisons", []):
            label = f"{comparison['condition']} vs {comparison['reference']}"
            for metric, test in comparison.get("metrics", {}).items():
                effect = test.get("rank_biserial", float("nan"))
                signs.setdefault(label, {}).setdefault(metric, {})[backend] = effect
            if "success" in comparison:
                effect = comparison["success"].get("risk_difference", float("nan"))
                signs.setdefault(label, {}).setdefault("success", {})[backend] = effect
    out: dict[str, dict] = {}
    for label, metrics in signs.items():
        for metric, effects in metrics.items():
            directions = {np.sign(v) for v in effects.values() if not math.isnan(v) and v != 0}
            out.setdefault(label, {})[metric] = {"effect_by_backend": effects,
                                                 "same_direction": len(directions) <= 1}
    return out


def across_backends(rows_by_backend: dict[str, list[dict]], spec: Statistics, *, timing: tuple[str, ...] = ()) -> dict:
    """Per condition and metric, a Kruskal-Wallis H test of the backends' values (Mann-Whitney's
    generalisation: do the backends' distributions differ?). Needs two backends with values."""
    from scipy.stats import kruskal

    finished = {b: [r for r in rows if r.get("status", "ok") == "ok"] for b, rows in rows_by_backend.items()}
    every = [r for rows in finished.values() for r in rows]
    if not every:
        return {}
    key = spec.condition
    conditions = sorted({str(r.get(key)) for r in every}) if key else ["all"]
    result: dict[str, dict] = {}
    for condition in conditions:
        for metric in metric_columns(every, spec, timing):
            samples = {}
            for backend, rows in finished.items():
                values = [float(r[metric]) for r in rows if (not key or str(r.get(key)) == condition)
                          and _is_number(r.get(metric)) and math.isfinite(float(r[metric]))]
                if values:
                    samples[backend] = values
            if len(samples) < 2:
                continue
            try:
                statistic, p = kruskal(*samples.values())
            except ValueError:  # every value the same across backends
                continue
            result.setdefault(condition, {})[metric] = {
                "test": "Kruskal-Wallis H", "h": float(statistic), "p": float(p),
                "n_by_backend": {b: len(v) for b, v in samples.items()},
                "median_by_backend": {b: float(np.median(v)) for b, v in samples.items()}}
    return result
