"""Figures of the visual beacon, after the paper's Fig. 4: paths per eye mode, times, first views.

Each ``*_figure`` function draws one figure and returns it; :func:`write_beacon_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import new_figure, save

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
    """Top view: every trial's path coloured by its eye mode, the landmark as a black disc."""
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
    ax.plot(0.0, 0.0, "k^", ms=9, label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("visual beacon: paths by eye mode")
    ax.legend(loc="lower right")
    return fig


def times_figure(result):
    """Box plot of the time to the landmark per eye mode (successful trials), with the points."""
    fig, ax = new_figure((5, 4))
    modes = _modes(result)
    present = [m for m in MODES if m in modes]
    data = [[t["time_to_landmark_s"] for t, m in zip(result.trials, modes)
             if m == mode and np.isfinite(t["time_to_landmark_s"])] for mode in present]
    positions = np.arange(1, len(present) + 1)
    filled = [k for k, d in enumerate(data) if d]
    if filled:
        ax.boxplot([data[k] for k in filled], positions=positions[filled], widths=0.5)
    for k, (mode, values) in enumerate(zip(present, data)):
        ax.plot(np.full(len(values), positions[k]), values, "o", color=MODE_COLOURS[mode], alpha=0.7,
                gid=f"times {mode}")
    ax.set_xticks(positions, [f"{m}\n(n={sum(1 for x in modes if x == m)}, reached {len(d)})"
                              for m, d in zip(present, data)])
    ax.set_ylabel("time to the landmark (s)")
    ax.set_title("finish time by eye mode")
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
