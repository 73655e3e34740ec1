"""The sweep's metric figure: every numeric metric (mean ± std over finished trials) against the grid."""

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


def _mean_std(ok: list[dict], metric: str, match) -> tuple[float, float]:
    values = np.array([float(r[metric]) for r in ok if match(r) and isinstance(r.get(metric), (int, float))], float)
    values = values[np.isfinite(values)]
    return (float(values.mean()), float(values.std())) if values.size else (np.nan, np.nan)


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
        for s, combination in enumerate(series):
            stats = [_mean_std(ok, metric, lambda r, x=x, c=combination: r[x_key] == x
                               and tuple(r[k] for k in others) == c) for x in x_labels]
            means, stds = [m for m, _ in stats], [d for _, d in stats]
            offset = (s - (len(series) - 1) / 2) * spread
            name = ", ".join(f"{k}={v}" for k, v in zip(others, combination)) or None
            ax.errorbar([p + offset for p in positions], means, yerr=stds, marker="o", ms=4, capsize=2,
                        lw=1, linestyle="-" if numeric else "none", label=name)
        ax.set_title(metric, fontsize=9)
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
