"""Figures of the cue-integration scenario: the initial heading against the conflict angle, and the paths.

Each ``*_figure`` function draws one figure and returns it; :func:`write_cue_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import new_figure, save


def write_cue_figures(result, config, out_dir: Path) -> list[Path]:
    """initial_heading.png and paths.png."""
    out_dir = Path(out_dir)
    return [save(initial_heading_figure(result, config), out_dir / "initial_heading.png"),
            save(paths_figure(result, config), out_dir / "paths.png")]


def _circular_mean_deg(values: np.ndarray) -> tuple[float, float]:
    """(circular mean, its standard error) of the finite angles in degrees; NaNs when none."""
    values = np.radians(values[np.isfinite(values)])
    if values.size == 0:
        return float("nan"), float("nan")
    resultant = np.exp(1j * values).mean()
    spread = np.sqrt(max(-2.0 * np.log(max(abs(resultant), 1e-12)), 0.0))
    return float(np.degrees(np.angle(resultant))), float(np.degrees(spread) / np.sqrt(values.size))


def conflict_table(result) -> dict[str, np.ndarray]:
    """Per conflict angle (sorted): n, the mean initial heading and its standard error, the mean prediction,
    the mean PI and visual cues at release (deg, relative to the nest direction)."""
    trials = [t for t in result.trials if t.get("status", "ok") == "ok"]
    conflicts = np.array(sorted({t["conflict_deg"] for t in trials}), float)
    columns = {k: [] for k in ("n", "initial_deg", "initial_se_deg", "predicted_deg", "pi_deg", "vision_deg")}
    for conflict in conflicts:
        group = [t for t in trials if t["conflict_deg"] == conflict]
        mean, error = _circular_mean_deg(np.array([t["initial_heading_deg"] for t in group], float))
        columns["n"].append(len(group))
        columns["initial_deg"].append(mean)
        columns["initial_se_deg"].append(error)
        for key, metric in (("predicted_deg", "predicted_heading_deg"), ("pi_deg", "pi_cue_deg"),
                            ("vision_deg", "vision_cue_deg")):
            columns[key].append(_circular_mean_deg(np.array([t[metric] for t in group], float))[0])
    return {"conflict_deg": conflicts, **{k: np.array(v, float) for k, v in columns.items()}}


def initial_heading_figure(result, config):
    """Initial heading (relative to the nest) against the conflict angle: each trial, the mean per conflict,
    the two cues' lines and the reliability-weighted prediction."""
    table = conflict_table(result)
    fig, ax = new_figure((6, 5))
    conflicts = np.array([t["conflict_deg"] for t in result.trials], float)
    initial = np.array([t["initial_heading_deg"] for t in result.trials], float)
    jitter = np.random.default_rng(0).uniform(-3.0, 3.0, conflicts.size)
    ax.plot(conflicts + jitter, initial, ".", color="0.6", ms=3, alpha=0.5, gid="trials", label="trials")
    x = table["conflict_deg"]
    ax.plot(x, np.zeros_like(x), "-", color="tab:green", gid="vision line", label="visual cue (nest direction)")
    ax.plot(x, x, "-", color="tab:blue", gid="pi line", label="PI cue (home vector)")
    ax.plot(x, table["predicted_deg"], "--", color="k", gid="prediction", label="weighted prediction")
    ax.errorbar(x, table["initial_deg"], yerr=table["initial_se_deg"], fmt="o", color="tab:red", capsize=3,
                gid="mean initial heading", label=f"mean initial heading ({config.cues})")
    ax.set_xlabel("conflict: PI direction − nest direction (deg)")
    ax.set_ylabel(f"initial heading at {config.initial_distance_m:g} m (deg from the nest direction)")
    ax.set_title(f"cue integration, n = {len(result.trials)} trials")
    ax.legend(loc="upper left", fontsize=8)
    return fig


def paths_figure(result, config):
    """Top view of every path, the nest, the circle of stored views, coloured by conflict angle."""
    from matplotlib import colormaps
    from matplotlib.patches import Circle

    fig, ax = new_figure((6, 6))
    conflicts = np.array([t["conflict_deg"] for t in result.trials], float)
    colour = colormaps["viridis"]
    shown = min(len(result.trials), 200)
    for i in range(shown):
        path = result.timeseries["position_m"][i]
        path = path[np.isfinite(path[:, 0])]
        ax.plot(path[:, 0], path[:, 1], lw=0.8, color=colour(conflicts[i] / 180.0), gid=f"trial {i}")
        if len(path):
            ax.plot(path[0, 0], path[0, 1], "^", ms=4, color=colour(conflicts[i] / 180.0))
    ax.add_patch(Circle((0.0, 0.0), config.nest_radius_m, color="k", alpha=0.4, gid="nest"))
    ax.add_patch(Circle((0.0, 0.0), config.snapshot_radius_m, fill=False, ls=":", color="tab:green",
                        gid="snapshots"))
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"paths ({shown} of {len(result.trials)}), colour: conflict 0–180°; dotted: stored views")
    return fig
