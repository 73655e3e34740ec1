"""Figures of swarm homing: every ant's trajectory in one top view, and the rows' homing times.

Each ``*_figure`` function draws one figure and returns it; :func:`write_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import new_figure, save

CYCLE_S = 0.64  # neuronav.scenarios.swarm_homing.scenario.CYCLE_S: the trajectories' sample period
HOMED_RGB, LOST_RGB = "tab:blue", "tab:red"


def write_figures(result, config, out_dir: Path) -> list[Path]:
    """swarm_trajectories.png and homing_times.png."""
    out_dir = Path(out_dir)
    return [save(trajectories_figure(result, config), out_dir / "swarm_trajectories.png"),
            save(homing_times_figure(result, config), out_dir / "homing_times.png")]


def trajectories_figure(result, config):
    """Top view of the first trial's whole swarm: foraging grey, homing blue (home) or red (not home)."""
    from matplotlib.collections import LineCollection

    ts = result.timeseries
    paths = ts["swarm_position_m"][0]  # (ants, samples, 2)
    homes = ts["swarm_home_m"][0]
    homed = np.isfinite(ts["swarm_home_at_s"][0])
    turnback = int(round(config.outbound_s / CYCLE_S))
    ants = len(paths)
    width = 0.8 if ants <= 50 else 0.3
    outbound, homing_ok, homing_lost = [], [], []
    for ant in range(ants):
        path = paths[ant][np.isfinite(paths[ant][:, 0])]
        outbound.append(path[:turnback + 1])
        (homing_ok if homed[ant] else homing_lost).append(path[turnback:])
    fig, ax = new_figure((8, 8))
    ax.add_collection(LineCollection(outbound, colors="0.6", linewidths=width, linestyles="--", label="foraging",
                                     gid="foraging"))
    ax.add_collection(LineCollection(homing_ok, colors=HOMED_RGB, linewidths=width, label="homing, home",
                                     gid="homing home"))
    if homing_lost:
        ax.add_collection(LineCollection(homing_lost, colors=LOST_RGB, linewidths=width, label="homing, not home",
                                         gid="homing lost"))
    ax.plot(homes[:, 0], homes[:, 1], "k.", ms=4 if ants <= 50 else 1, label="homes", gid="homes")
    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"{ants} ants in one world, each with its own CX: {homed.sum()} of {ants} home "
                 f"({100 * homed.mean():.0f}%)")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right")
    return fig


def homing_times_figure(result, config):
    """Histogram of the reported ants' homing times (s); the ants not home are counted in the title."""
    times = np.array([row.get("homing_time_s", np.nan) for row in result.trials], float)
    home = np.isfinite(times)
    fig, ax = new_figure((6, 4))
    ax.hist(times[home], bins=min(30, max(5, home.sum() // 5 or 1)), color=HOMED_RGB)
    ax.set_xlabel("homing time (s)")
    ax.set_ylabel("ants")
    ax.set_title(f"{home.sum()} of {len(times)} reported ants home within {config.homing_timeout_s:g} s")
    return fig
