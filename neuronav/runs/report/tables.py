"""The report's tables as HTML: settings, versions, summary statistics, comparison statistics.

Every function returns an HTML fragment (a ``<table>`` or a short note); every value is escaped.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Mapping, Sequence

from neuronav.runs.report.loader import RunFolder


def cell(value) -> str:
    """A value as table text: floats to 4 significant digits, lists joined, None empty."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(cell(v) for v in value) + "]"
    return str(value)


def table(header: Sequence[str], rows: Iterable[Sequence], css_class: str = "") -> str:
    """An HTML table with ``header`` and ``rows`` (values through :func:`cell`, escaped)."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(cell(v))}</td>" for v in row) + "</tr>" for row in rows)
    klass = f' class="{html.escape(css_class)}"' if css_class else ""
    return f"<table{klass}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def key_values(mapping: Mapping, header: tuple[str, str] = ("setting", "value")) -> str:
    """A two-column table of a mapping (nested mappings flattened as ``a.b``)."""
    return table(header, _flatten(mapping))


def run_facts(run: RunFolder) -> str:
    """Scenario, backend, trials, seed, wall time, command and git revision of a run, compare or sweep; the first
    error and why the video failed, where they did."""
    s = run.summary
    facts = {"scenario": s.get("scenario") or run.settings.get("scenario"),
             "backend": s.get("backend") or ", ".join(map(str, s.get("backends", []))) or None,
             "trials": s.get("total_trials", s.get("trials")), "failed trials": s.get("failed_trials"),
             "seed": s.get("seed"), "wall time (s)": s.get("wall_time_s"),
             "simulated time per trial (s)": s.get("simulated_time_s"),
             "command": " ".join(map(str, s["command"])) if isinstance(s.get("command"), list) else None,
             "git revision": s.get("git_revision"), "first error": s.get("first_error") or None,
             "video error": s.get("video_error") or None}
    return key_values({k: v for k, v in facts.items() if v not in (None, "")}, ("run", ""))


def settings(run: RunFolder) -> str:
    """The scenario settings the run used (``config`` of its summary)."""
    config = run.summary.get("config") or run.settings.get("config") or {}
    return key_values(config) if config else "<p>no settings recorded</p>"


def versions(run: RunFolder) -> str:
    """Python and package versions the run recorded."""
    found = run.summary.get("versions") or {}
    return key_values(found, ("package", "version")) if found else "<p>no versions recorded</p>"


def metrics(run: RunFolder) -> str:
    """The run's metrics over its trials: mean and standard deviation (``summary.json``)."""
    found, spread = run.summary.get("metrics") or {}, run.summary.get("metrics_std") or {}
    return table(("metric", "mean", "std"), ((k, v, spread.get(k)) for k, v in found.items()))


def summary_statistics(run: RunFolder) -> str:
    """Per condition and metric: n, mean with its confidence interval, median, std, min, max; and the
    success rate with its interval. Falls back to the metrics' mean and std when no statistics block."""
    block = run.summary.get("statistics") or {}
    conditions = block.get("conditions") or {}
    if not conditions:
        note = f"<p class='note'>{html.escape(str(block['note']))}</p>" if block.get("note") else ""
        return note + metrics(run)
    rows = []
    for condition, entry in conditions.items():
        for metric, m in (entry.get("metrics") or {}).items():
            rows.append((condition, metric, m.get("n"), m.get("mean"), m.get("mean_ci"), m.get("median"),
                         m.get("std"), m.get("min"), m.get("max")))
        success = entry.get("success") or {}
        if success:
            rows.append((condition, "success rate", success.get("n"), success.get("rate"), success.get("ci"),
                         None, None, None, None))
    confidence = block.get("confidence", 0.95)
    return table(("condition", "metric", "n", "mean", f"{confidence:.0%} CI", "median", "std", "min", "max"), rows)


def comparisons(run: RunFolder) -> str:
    """The tests between conditions (a sweep's grid points, a scenario's conditions), or ``""``."""
    found = (run.summary.get("statistics") or {}).get("comparisons") or []
    rows = []
    for comparison in found:
        for metric, m in (comparison.get("metrics") or {}).items():
            rows.append((comparison.get("condition"), comparison.get("reference"), metric, m.get("median_a"),
                         m.get("median_b"), m.get("median_difference"), m.get("p"), m.get("test")))
    if not rows:
        return ""
    return table(("condition", "reference", "metric", "median", "reference median", "difference", "p", "test"), rows)


def across_backends(run: RunFolder) -> str:
    """A compare's Kruskal-Wallis tests between backends, per condition and metric."""
    between = run.summary.get("across_backends") or {}
    if "note" in between:
        return f"<p class='note'>{html.escape(str(between['note']))}</p>"
    backends = [str(b) for b in run.summary.get("backends", [])]
    rows = []
    for condition, metrics in between.items():
        for metric, m in (metrics if isinstance(metrics, dict) else {}).items():
            medians = m.get("median_by_backend") or {}
            rows.append((condition, metric, *(medians.get(b) for b in backends), m.get("h"), m.get("p"), m.get("test")))
    if not rows:
        return ""
    return table(("condition", "metric", *(f"median {b}" for b in backends), "H", "p", "test"), rows)


def metrics_side_by_side(runs: Sequence[RunFolder]) -> str:
    """Each run's metrics (mean ± std) in one table, a column per run: the comparison of several folders."""
    names = [m for r in runs for m in (r.summary.get("metrics") or {})]
    metrics = list(dict.fromkeys(names))
    rows = []
    for metric in metrics:
        row = [metric]
        for run in runs:
            mean = (run.summary.get("metrics") or {}).get(metric)
            std = (run.summary.get("metrics_std") or {}).get(metric)
            row.append(f"{cell(mean)} ± {cell(std)}" if isinstance(std, (int, float)) else cell(mean))
        rows.append(row)
    header = ["metric (mean ± std)", *(f"{r.label} ({r.summary.get('backend', '')})" for r in runs)]
    return table(header, rows, "compare")


def _flatten(mapping: Mapping, prefix: str = "") -> list[tuple[str, object]]:
    out: list[tuple[str, object]] = []
    for key, value in mapping.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out += _flatten(value, name + ".")
        else:
            out.append((name, value))
    return out
