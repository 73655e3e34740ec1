"""Figures of the cue-integration scenario: the initial heading against the conflict angle, and the paths.

Each ``*_figure`` function draws one figure and returns it; :func:`write_cue_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, save


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


def cue_modes_of(result) -> list[str]:
    """The cue modes of the finished trials, in order of first appearance (``""`` for rows without one)."""
    return list(dict.fromkeys(t.get("cues", "") for t in result.trials if t.get("status", "ok") == "ok"))


def conflict_table(result, cues: str | None = None) -> dict[str, np.ndarray]:
    """Per conflict angle (sorted): n, the mean initial heading and its standard error, the mean prediction,
    the mean PI and visual cues at release (deg, relative to the nest direction), over the finished trials
    of cue mode ``cues`` (None: every trial, as when the run has one mode)."""
    trials = [t for t in result.trials if t.get("status", "ok") == "ok" and (cues is None or t.get("cues", "") == cues)]
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


MODE_COLOURS = {"both": "tab:red", "pi": "tab:blue", "vision": "tab:green"}


def initial_heading_figure(result, config):
    """Initial heading (relative to the nest) against the conflict angle, per cue mode (``cues`` a comma
    list: one series each, side by side, never pooled): every trial as a point, the circular mean per
    conflict with its bootstrap 95 % interval, n per conflict and mode; the two cues' lines and each
    mode's reliability-weighted prediction."""
    fig, ax = new_figure((7, 5))
    modes = cue_modes_of(result)
    all_conflicts = np.array(sorted({t["conflict_deg"] for t in result.trials if "conflict_deg" in t}), float)
    spacing = float(np.min(np.diff(all_conflicts))) if all_conflicts.size > 1 else 30.0
    band = 0.5 * spacing / max(len(modes), 1)  # each mode's share of the space between two conflicts
    x = all_conflicts
    ax.plot(x, np.zeros_like(x), "-", color="tab:green", lw=0.8, gid="vision line", label="visual cue (nest direction)")
    ax.plot(x, x, "-", color="tab:blue", lw=0.8, gid="pi line", label="PI cue (home vector)")
    counts = []
    for k, mode in enumerate(modes):
        table = conflict_table(result, mode if len(modes) > 1 else None)
        offset = (k - (len(modes) - 1) / 2) * band
        groups = {f"{c:g}": [t["initial_heading_deg"] for t in result.trials if t.get("status", "ok") == "ok"
                             and t["conflict_deg"] == c and (len(modes) == 1 or t.get("cues", "") == mode)]
                  for c in table["conflict_deg"]}
        drawn = condition_strip(ax, groups, positions=table["conflict_deg"] + offset - 0.2 * band,
                                colours=dict.fromkeys(groups, MODE_COLOURS.get(mode, f"C{k}")), centre="circular",
                                width=0.45 * band, gid=f"initial {mode}", tick_labels=False, marker_size=3,
                                legend=k == 0)
        counts += [d["n"] for d in drawn.values()]
        ax.plot([], [], "o", color=MODE_COLOURS.get(mode, f"C{k}"), ms=3, label=f"trials, {mode} cues")
        ax.plot(table["conflict_deg"], table["predicted_deg"], "--", color=MODE_COLOURS.get(mode, f"C{k}"),
                gid="prediction" if len(modes) == 1 else f"prediction {mode}",
                label=f"weighted prediction ({mode} cues)")
    ax.set_xticks(x, [f"{c:g}" for c in x])
    ax.set_xlabel("conflict: PI direction − nest direction (deg)")
    ax.set_ylabel(f"initial heading at {config.initial_distance_m:g} m (deg from the nest direction)")
    n_text = f"n = {min(counts)}" if counts and min(counts) == max(counts) else \
        f"n = {min(counts, default=0)}–{max(counts, default=0)}"
    ax.set_title(f"cue integration ({', '.join(modes)}): {n_text} per conflict and cue mode", fontsize=9)
    ax.legend(loc="best", fontsize=7)
    return fig


def paths_figure(result, config):
    """Top view of every path, the nest, the circle of stored views, coloured by conflict angle."""
    from matplotlib import colormaps
    from matplotlib.patches import Circle

    fig, ax = new_figure((6, 6))
    conflicts = np.array([t.get("conflict_deg", np.nan) for t in result.trials], float)  # a failed trial: none
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
