"""Figures of odour trail following, after the paper's Fig. 6b–d: paths over the trail, completion,
finish times, per antenna mode.

Each ``*_figure`` function draws one figure and returns it; :func:`write_trail_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save
from neuronav.senses.odour import rasterise

MODE_COLOURS = {"fixed": "tab:blue", "moving": "tab:orange"}
MODES = ("fixed", "moving")


def write_trail_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectories.png, completion.png, finish_time.png."""
    out_dir = Path(out_dir)
    return [save(trajectories_figure(result, config), out_dir / "trajectories.png"),
            save(completion_figure(result), out_dir / "completion.png"),
            save(finish_time_figure(result), out_dir / "finish_time.png")]


def _modes(result) -> list[str | None]:
    """Each trial's antenna mode; None for a trial that failed (its row has no metrics: in no group)."""
    return [MODES[int(t["antennae_moving"])] if "antennae_moving" in t else None for t in result.trials]


def trajectories_figure(result, config):
    """Top view: the trail (rasterised concentration) and every trial's path coloured by its antennae, each
    trial's start (its first recorded position: starts are jittered) as an open triangle; the legend
    outside the axes, so that it covers none of them."""
    from neuronav.scenarios.odour_trail.scenario import end_line_m, make_trail

    trail = make_trail(config.width, config.edge_m)
    paths = [p[np.isfinite(p[:, 0])] for p in result.timeseries["position_m"]]
    points = np.vstack([np.asarray(trail.vertices_m), *paths])
    margin = 1.0 + trail.width_m / 2
    x_range = (float(points[:, 0].min() - margin), float(points[:, 0].max() + margin))
    y_range = (float(points[:, 1].min() - margin), float(points[:, 1].max() + margin))
    shape = tuple(int(np.clip((high - low) * 60, 50, 900)) for low, high in (y_range, x_range))  # 60 px per m
    image = rasterise(trail, x_range, y_range, shape)
    fig, ax = new_figure((6, 7))
    ax.imshow(image, extent=(*x_range, *y_range), origin="upper", cmap="Greens", vmin=0.0, vmax=1.6, gid="trail")
    labelled = set()
    for i, (mode, path) in enumerate(zip(_modes(result), paths)):
        if mode is None:  # a failed trial: no path to draw
            continue
        ax.plot(path[:, 0], path[:, 1], color=MODE_COLOURS[mode], lw=1.0, alpha=0.8, gid=f"trial {i} {mode}",
                label=f"{mode} antennae" if mode not in labelled else None)
        labelled.add(mode)
    finish = end_line_m(trail, config)
    ax.plot(finish[:, 0], finish[:, 1], ls="--", color="k", gid="end", label="finish line")
    starts = np.array([path[0] for path in paths if len(path)]).reshape(-1, 2)  # each trial's own (jittered) start
    ax.plot(starts[:, 0], starts[:, 1], "k^", ms=6, mfc="none", label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"odour trail ({config.width}, {trail.width_m:g} m): paths by antennae")
    # Outside the axes, to the right: inside, it covered the trail's start (issue 26).
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=8)
    return fig


def _by_mode(result, key: str) -> dict[str, list[float]]:
    """Each present antenna mode's values of column ``key`` (NaN kept: counted as missing)."""
    modes = _modes(result)
    return {mode: [float(t[key]) for t, m in zip(result.trials, modes) if m == mode] for mode in MODES if mode in modes}


def completion_figure(result):
    """Completion (fraction of the trail covered) per antenna mode: every trial, and the mean with its
    seeded bootstrap 95 % interval."""
    fig, ax = new_figure((5, 4))
    condition_strip(ax, _by_mode(result, "completion"), colours=MODE_COLOURS, gid="completion")
    ax.set_ylim(-0.02, 1.05)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_ylabel("completion (fraction of the trail)")
    ax.set_title("completion by antennae")
    return fig


def finish_time_figure(result):
    """Per antenna mode: reaching the end (each trial at 1 or 0, the proportion with its Wilson 95 %
    interval) and the finish time of the trials that reached it (box plot, every trial, the median with
    its bootstrap 95 % interval)."""
    fig, (ax, rate_ax) = new_figure((8, 4), 1, 2, gridspec_kw={"width_ratios": [1.4, 1]})
    modes = _modes(result)
    proportion_points(rate_ax, {mode: [bool(t["success"]) for t, m in zip(result.trials, modes) if m == mode]
                                for mode in MODES if mode in modes}, colours=MODE_COLOURS, gid="reached")
    rate_ax.set_ylabel("reached the end (1 yes, 0 no)")
    rate_ax.set_title("reaching the end")
    rate_ax.legend(loc="best", fontsize=7)
    condition_strip(ax, _by_mode(result, "finish_time_s"), colours=MODE_COLOURS, centre="median", box=True,
                    gid="finish")
    ax.set_ylabel("finish time (s)")
    ax.set_title("finish time (trials that reached the end)")
    ax.legend(loc="best", fontsize=7)
    return fig
