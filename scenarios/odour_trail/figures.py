"""Figures of odour trail following, after the paper's Fig. 6b–d: paths over the trail, completion,
finish times, per antenna mode.

Each ``*_figure`` function draws one figure and returns it; :func:`write_trail_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import new_figure, save
from neuronav.runs.stats import describe
from neuronav.senses.odour import rasterise

MODE_COLOURS = {"fixed": "tab:blue", "moving": "tab:orange"}
MODES = ("fixed", "moving")


def write_trail_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectories.png, completion.png, finish_time.png."""
    out_dir = Path(out_dir)
    return [save(trajectories_figure(result, config), out_dir / "trajectories.png"),
            save(completion_figure(result), out_dir / "completion.png"),
            save(finish_time_figure(result), out_dir / "finish_time.png")]


def _modes(result) -> list[str]:
    return [MODES[int(t["antennae_moving"])] for t in result.trials]


def trajectories_figure(result, config):
    """Top view: the trail (rasterised concentration) and every trial's path coloured by its antennae."""
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
        ax.plot(path[:, 0], path[:, 1], color=MODE_COLOURS[mode], lw=1.0, alpha=0.8, gid=f"trial {i} {mode}",
                label=f"{mode} antennae" if mode not in labelled else None)
        labelled.add(mode)
    finish = end_line_m(trail, config)
    ax.plot(finish[:, 0], finish[:, 1], ls="--", color="k", gid="end", label="finish line")
    ax.plot(0.0, 0.0, "k^", ms=9, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"odour trail ({config.width}, {trail.width_m:g} m): paths by antennae")
    ax.legend(loc="lower right")
    return fig


def completion_figure(result):
    """Completion (fraction of the trail covered) per antenna mode: every trial, and the mean with its
    seeded bootstrap 95 % interval."""
    fig, ax = new_figure((5, 4))
    modes = _modes(result)
    present = [m for m in MODES if m in modes]
    for k, mode in enumerate(present):
        values = np.array([t["completion"] for t, m in zip(result.trials, modes) if m == mode])
        jitter = np.linspace(-0.12, 0.12, len(values)) if len(values) > 1 else np.zeros(1)
        ax.plot(k + jitter, values, "o", color=MODE_COLOURS[mode], alpha=0.6, gid=f"completion {mode}")
        mean = describe(values, seed=0)
        low, high = mean["mean_ci"]  # NaN for one trial: no interval drawn
        error = np.nan_to_num([[mean["mean"] - low], [high - mean["mean"]]])
        ax.errorbar(k + 0.3, mean["mean"], yerr=error, fmt="D",
                    color="k", capsize=4, gid=f"mean {mode}", label="mean, 95 % CI" if k == 0 else None)
    ax.set_xticks(range(len(present)), [f"{m}\n(n={modes.count(m)})" for m in present])
    ax.set_ylim(0.0, 1.05)
    ax.set_xlim(-0.5, len(present) - 0.2)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_ylabel("completion (fraction of the trail)")
    ax.set_title("completion by antennae")
    return fig


def finish_time_figure(result):
    """Box plot of the finish time per antenna mode (trials that reached the end), with the points."""
    fig, ax = new_figure((5, 4))
    modes = _modes(result)
    present = [m for m in MODES if m in modes]
    data = [[t["finish_time_s"] for t, m in zip(result.trials, modes) if m == mode and np.isfinite(t["finish_time_s"])]
            for mode in present]
    positions = np.arange(1, len(present) + 1)
    filled = [k for k, d in enumerate(data) if d]
    if filled:
        ax.boxplot([data[k] for k in filled], positions=positions[filled], widths=0.5)
    for k, (mode, values) in enumerate(zip(present, data)):
        ax.plot(np.full(len(values), positions[k]), values, "o", color=MODE_COLOURS[mode], alpha=0.7,
                gid=f"finish {mode}")
    ax.set_xticks(positions, [f"{m}\n(n={modes.count(m)}, reached {len(d)})" for m, d in zip(present, data)])
    ax.set_xlim(0.4, len(present) + 0.6)
    ax.set_ylabel("finish time (s)")
    ax.set_title("finish time by antennae")
    return fig
