"""Figures of the visual beacon, after the paper's Fig. 4: paths per eye mode, times, first views.

Each ``*_figure`` function draws one figure and returns it; :func:`write_beacon_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save

MODE_COLOURS = {"left": "tab:blue", "right": "tab:red", "both": "tab:green"}
MODES = ("left", "right", "both")


def write_beacon_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectories.png, time_to_landmark.png, first_views.png."""
    out_dir = Path(out_dir)
    return [save(trajectories_figure(result, config), out_dir / "trajectories.png"),
            save(times_figure(result), out_dir / "time_to_landmark.png"),
            save(first_views_figure(result, config), out_dir / "first_views.png")]


def _modes(result) -> list[str]:
    return [MODES[int(t["eye_mode"])] if np.isfinite(t.get("eye_mode", np.nan)) else "both" for t in result.trials]


def trajectories_figure(result, config):
    """Top view: every trial's path coloured by its eye mode, each trial's start (its first recorded
    position: starts are jittered) as an open triangle, the landmark as a black disc."""
    from matplotlib.patches import Circle

    fig, ax = new_figure((6, 7))
    modes = _modes(result)
    labelled = set()
    for i, mode in enumerate(modes):
        path = result.timeseries["position_m"][i]
        path = path[np.isfinite(path[:, 0])]
        ax.plot(path[:, 0], path[:, 1], color=MODE_COLOURS[mode], lw=1.2, gid=f"trial {i} {mode}",
                label=f"{mode} eye{'s' if mode == 'both' else ''}" if mode not in labelled else None)
        labelled.add(mode)
    ax.add_patch(Circle((0.0, config.landmark_distance_m), 1.0, color="k", gid="landmark"))
    ax.add_patch(Circle((0.0, config.landmark_distance_m), config.success_radius_m, fill=False, ls="--", color="k"))
    starts = np.array([path[np.isfinite(path[:, 0])][0] for path in result.timeseries["position_m"]
                       if np.isfinite(path[:, 0]).any()]).reshape(-1, 2)  # each trial's own (jittered) start
    ax.plot(starts[:, 0], starts[:, 1], "k^", ms=6, mfc="none", label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("visual beacon: paths by eye mode")
    ax.legend(loc="lower right")
    return fig


def times_figure(result):
    """Per eye mode: reaching the landmark (each trial at 1 or 0, the proportion with its Wilson 95 %
    interval) and the time to the landmark of the trials that reached it (box plot, every trial, the
    median with its bootstrap 95 % interval)."""
    fig, (ax, rate_ax) = new_figure((9, 4), 1, 2, gridspec_kw={"width_ratios": [1.4, 1]})
    modes = _modes(result)
    present = [m for m in MODES if m in modes]
    proportion_points(rate_ax, {mode: [bool(t["success"]) for t, m in zip(result.trials, modes) if m == mode]
                                for mode in present}, colours=MODE_COLOURS, gid="reached")
    rate_ax.set_ylabel("reached the landmark (1 yes, 0 no)")
    rate_ax.set_title("reaching the landmark")
    rate_ax.legend(loc="best", fontsize=7)
    condition_strip(ax, {mode: [t["time_to_landmark_s"] for t, m in zip(result.trials, modes) if m == mode]
                         for mode in present}, colours=MODE_COLOURS, centre="median", box=True, gid="times")
    ax.set_ylabel("time to the landmark (s)")
    ax.set_title("time to the landmark by eye mode")
    ax.legend(loc="best", fontsize=7)
    return fig


def first_views_figure(result, config):
    """What the eyes see at the start of the first trial of each mode, dark pixels outlined."""
    modes = _modes(result)
    shown = [m for m in MODES if m in modes]
    fig, axes = new_figure((8, 1.6 * max(len(shown), 1) + 0.6), nrows=max(len(shown), 1), ncols=2)
    axes = np.atleast_2d(axes)
    for row, mode in enumerate(shown):
        trial = modes.index(mode)
        for col, name in enumerate(("eye_L", "eye_R")):
            ax = axes[row, col]
            key = f"first_view_{name}"
            if key in result.timeseries and np.isfinite(result.timeseries[key][trial]).all():
                image = result.timeseries[key][trial]
                ax.imshow(image, cmap="gray", vmin=0.0, vmax=1.0, aspect="auto", gid=f"{mode} {name}")
                dark = image <= config.dark_threshold
                if dark.any():
                    ax.contour(dark.astype(float), levels=[0.5], colors="r", linewidths=0.8)
            ax.set_xticks([])
            ax.set_yticks([])
            used = name in {"left": ("eye_L",), "right": ("eye_R",), "both": ("eye_L", "eye_R")}[mode]
            ax.set_title(f"{mode} mode, trial {trial}: {name}{'' if used else ' (not used)'}", fontsize=8)
    return fig
