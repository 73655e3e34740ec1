"""Figures of swarm homing: every ant's trajectory in one top view, and the rows' homing times.

Each ``*_figure`` function draws one figure and returns it; :func:`write_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save

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
    """The reported ants, left: each homing time as a point (box plot, the median with its bootstrap 95 %
    interval; n counts the ants home of all reported); right: getting home (each ant at 1 or 0, the
    proportion with its Wilson 95 % interval)."""
    times = [row.get("homing_time_s", np.nan) for row in result.trials]
    home = [bool(row["success"]) if "success" in row else bool(np.isfinite(t)) for row, t in zip(result.trials, times)]
    fig, (ax, rate_ax) = new_figure((7, 4), 1, 2, gridspec_kw={"width_ratios": [1.3, 1]})
    small = len(times) > 200  # thousands of ants: smaller points
    condition_strip(ax, {"ants": times}, colours={"ants": HOMED_RGB}, centre="median", box=True, gid="homing time",
                    width=0.5, marker_size=2.0 if small else 5.0)
    ax.set_ylabel("homing time (s)")
    ax.set_title(f"homing time (limit {config.homing_timeout_s:g} s)", fontsize=9)
    ax.legend(loc="best", fontsize=7)
    drawn = proportion_points(rate_ax, {"ants": home}, colours={"ants": HOMED_RGB}, gid="home", width=0.5)
    rate_ax.set_ylabel("home (1 yes, 0 no)")
    low, high = drawn["ants"]["ci"]
    rate_ax.set_title(f"home: {100 * drawn['ants']['rate']:.0f} % ({100 * low:.0f}–{100 * high:.0f} %)", fontsize=9)
    rate_ax.legend(loc="best", fontsize=7)
    return fig
