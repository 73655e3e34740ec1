"""The sweep's metric figure: every numeric metric against the grid, as the finished trials' values (points),
their mean and its seeded 95 % bootstrap interval (error bar), with n per grid point in each panel's title."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

METRICS_FIGURE = "sweep_metrics.png"


def plotted_metrics(rows: list[dict], keys: list[str]) -> list[str]:
    """The numeric metrics of finished trial rows worth a panel, in first-seen order: not the grid
    keys or bookkeeping, and not a metric that is NaN in every trial (undefined for this setting)."""
    skip = {"trial", "seed", "status", "error", *keys}
    metrics: list[str] = []
    for row in rows:
        for key, value in row.items():
            if key not in skip and key not in metrics and isinstance(value, (int, float)):
                metrics.append(key)
    return [m for m in metrics if any(isinstance(r.get(m), (int, float)) and math.isfinite(r[m]) for r in rows)]


def _x_axis(rows: list[dict], x_key: str) -> tuple[list, list[float], bool]:
    """The x key's labels in grid order, their positions, and whether they are numbers."""
    x_labels = list(dict.fromkeys(r[x_key] for r in rows))
    try:
        x_values = [float(v) for v in x_labels]
        numeric = all(math.isfinite(v) for v in x_values)
    except (TypeError, ValueError):
        numeric = False
    return x_labels, (x_values if numeric else [float(i) for i in range(len(x_labels))]), numeric


def _values(ok: list[dict], metric: str, match) -> np.ndarray:
    values = np.array([float(r[metric]) for r in ok if match(r) and isinstance(r.get(metric), (int, float))], float)
    return values[np.isfinite(values)]


def _mean_interval(values: np.ndarray) -> tuple[float, float, float]:
    """The mean and its 95 % percentile-bootstrap interval (seeded: the figure is the same every time);
    the mean alone (no bar) for fewer than two values."""
    if values.size == 0:
        return np.nan, np.nan, np.nan
    mean = float(values.mean())
    if values.size < 2:
        return mean, mean, mean
    from neuronav.runs.stats import describe
    from neuronav.runs.summary_statistics import resamples_for

    block = describe(values, seed=0, n_resamples=resamples_for(values.size))
    low, high = block["mean_ci"]
    return mean, low, high


def build_metrics_figure(rows: list[dict], keys: list[str]) -> Any:
    """The sweep's metric figure as a matplotlib Figure (not saved): one panel per plotted metric.

    The first grid key is the x axis. Numeric values are joined by lines; categorical ones (a
    gait, a protocol) are separate points with their names as ticks, each series slightly offset
    so that their error bars do not hide each other. Every combination of the other keys is one
    series. Each panel's y label is its metric; there is one panel for every metric of
    :func:`plotted_metrics`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    metrics = plotted_metrics(ok, keys)
    x_key, others = keys[0], keys[1:]
    x_labels, positions, numeric = _x_axis(rows, x_key)
    series = list(dict.fromkeys(tuple(r[k] for k in others) for r in rows))
    columns = min(3, max(1, len(metrics)))
    lines = max(1, math.ceil(len(metrics) / columns))
    fig, axes = plt.subplots(lines, columns, figsize=(4.2 * columns, 3.0 * lines), squeeze=False)
    spread = 0.0 if numeric or len(series) < 2 else min(0.3, 0.6 / len(series))
    for ax, metric in zip(axes.flat, metrics):
        counts: set[int] = set()
        for s, combination in enumerate(series):
            samples = [_values(ok, metric, lambda r, x=x, c=combination: r[x_key] == x
                               and tuple(r[k] for k in others) == c) for x in x_labels]
            stats = [_mean_interval(v) for v in samples]
            means = np.array([m for m, _, _ in stats])
            below = np.nan_to_num(means - np.array([low for _, low, _ in stats]))
            above = np.nan_to_num(np.array([high for _, _, high in stats]) - means)
            offset = (s - (len(series) - 1) / 2) * spread
            name = ", ".join(f"{k}={v}" for k, v in zip(others, combination)) or None
            bars = ax.errorbar([p + offset for p in positions], means, yerr=[below, above], marker="o", ms=4,
                               capsize=2, lw=1, linestyle="-" if numeric else "none", label=name)
            colour = bars.lines[0].get_color()
            for position, values in zip(positions, samples):  # every trial, beside its mean
                ax.scatter(np.full(values.size, position + offset), values, s=6, alpha=0.35, color=colour,
                           linewidths=0)
            counts.update(v.size for v in samples)
        n_text = f"n = {min(counts)}" if len(counts) == 1 else f"n = {min(counts)}–{max(counts)}"
        ax.set_title(f"{metric} ({n_text}; mean, 95 % CI)", fontsize=8)
        ax.set_xlabel(x_key, fontsize=8)
        ax.set_ylabel(metric, fontsize=8)
        if not numeric:
            ax.set_xticks(positions, [str(v) for v in x_labels], fontsize=7)
            ax.set_xlim(min(positions) - 0.5, max(positions) + 0.5)
        ax.tick_params(labelsize=7)
        if others and metric == metrics[0]:
            ax.legend(fontsize=6)
    for ax in list(axes.flat)[len(metrics):]:
        ax.axis("off")
    if not metrics:
        axes.flat[0].text(0.5, 0.5, "no finished trials with numeric metrics", ha="center", va="center")
    fig.tight_layout()
    return fig


def metrics_figure(rows: list[dict], keys: list[str], path: Path) -> Path:
    """Draw :func:`build_metrics_figure` into ``path`` (a PNG, written atomically); return the path."""
    import matplotlib.pyplot as plt

    fig = build_metrics_figure(rows, keys)
    handle = Path(path)
    temporary = handle.with_name(f".{handle.name}.{os.getpid()}.tmp")
    try:
        fig.savefig(temporary, dpi=110, format="png")
        os.replace(temporary, handle)
    finally:
        plt.close(fig)
        if temporary.exists():
            temporary.unlink()
    return handle
