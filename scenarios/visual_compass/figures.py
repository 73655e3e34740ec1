"""Figures of the visual compass, after the paper's Fig. 5c: heading, scene angle and Zernike phase over time.

Each ``*_figure`` function draws one figure and returns it; :func:`write_compass_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import break_at_wraps, condition_strip, new_figure, proportion_points, save, trial_colour


def write_compass_figures(result, config, out_dir: Path) -> list[Path]:
    """compass.png (trial 0, like Fig. 5c, with the run's mean error), heading_error.png (every trial) and
    error_summary.png (every trial's errors and success as points, with intervals)."""
    out_dir = Path(out_dir)
    return [save(compass_figure(result, config), out_dir / "compass.png"),
            save(error_figure(result, config), out_dir / "heading_error.png"),
            save(error_summary_figure(result, config), out_dir / "error_summary.png")]


def run_mean(result, key: str) -> tuple[float, int]:
    """The mean of metric ``key`` over the trials that finished with a finite value, and how many (as summary.json)."""
    values = np.array([float(t[key]) for t in result.trials if t.get("status", "ok") == "ok"
                       and np.isfinite(float(t.get(key, np.nan)))])
    return (float(values.mean()) if values.size else float("nan")), int(values.size)


def compass_figure(result, config, trial: int = 0):
    """One trial (0 by default): the ant's heading and its stored direction (top), the scene's angle and the
    Z_{7,1} phase (bottom); the title gives that trial's mean error and the run's (the mean over its n trials)."""
    ts = result.timeseries
    keep = np.isfinite(ts["time_s"][trial])
    time_s = ts["time_s"][trial, keep]
    fig, (top, bottom) = new_figure((8, 5.5), nrows=2, sharex=True)
    for ax, series in ((top, (("heading_rad", "ant heading", "tab:blue", "-"),
                              ("target_rad", "stored direction (moves with the scene)", "k", "--"))),
                       (bottom, (("scene_yaw_rad", "scene angle", "tab:orange", "-"),
                                 ("phase_rad", "Zernike Z7,1 phase", "tab:green", "-")))):
        for key, label, colour, style in series:
            t, angle = break_at_wraps(time_s, ts[key][trial, keep])
            ax.plot(t, np.degrees(angle), color=colour, ls=style, lw=1.0, label=label, gid=key)
        ax.set_ylim(-180, 180)
        ax.set_ylabel("angle (deg)")
        ax.legend(loc="upper right", fontsize=8)
    bottom.set_xlabel("time (s)")
    row = result.trials[trial]
    jump = config.rotation == "jump"
    run_error, n = run_mean(result, "mean_error_deg")
    line = (f"trial {trial}: mean error {row['mean_error_deg']:.1f}°"
            + (f", jumps recovered {row['recovered_fraction'] * 100:.0f}%" if jump else ""))
    line += f"\nmean over {n} trials: mean error {run_error:.1f}°"
    if jump:
        line += f", jumps recovered {run_mean(result, 'recovered_fraction')[0] * 100:.0f}%"
    top.set_title(f"visual compass, {config.rotation} rotation, trial {trial} shown (of {len(result.trials)})\n{line}",
                  fontsize=9)
    return fig


def error_figure(result, config):
    """Every trial's heading error (ant heading minus the stored direction) against time."""
    ts = result.timeseries
    fig, ax = new_figure((8, 3.5))
    for i in range(len(result.trials)):
        keep = np.isfinite(ts["time_s"][i])
        ax.plot(ts["time_s"][i, keep], np.degrees(ts["error_rad"][i, keep]), color=trial_colour(i), lw=0.8,
                gid=f"trial {i}", label=f"trial {i}" if i < 10 else None)
    ax.axhspan(-config.recovered_deg, config.recovered_deg, color="0.9", zorder=0, gid="recovered band")
    ax.set_ylim(-180, 180)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("heading error (deg)")
    ax.set_title(f"heading error, {len(result.trials)} trials (grey: ±{config.recovered_deg:g}°)")
    if len(result.trials) <= 10:
        ax.legend(loc="upper right", fontsize=7)
    return fig


def error_summary_figure(result, config):
    """Left: each trial's mean and final absolute heading error (points, the median with its bootstrap
    95 % interval); right: success (incremental: mean error within ``recovered_deg``; jump: every jump
    recovered) as 1 or 0 per trial, the proportion with its Wilson 95 % interval."""
    rows = [t for t in result.trials if t.get("status", "ok") == "ok"]
    fig, (ax, rate_ax) = new_figure((8, 4), 1, 2, gridspec_kw={"width_ratios": [1.4, 1]})
    condition_strip(ax, {"mean |error|": [t["mean_error_deg"] for t in rows],
                         "final |error|": [t["final_error_deg"] for t in rows]}, centre="median", box=True,
                    gid="error")
    ax.axhspan(0.0, config.recovered_deg, color="0.9", zorder=0, gid="recovered band")
    ax.set_ylabel("heading error (deg)")
    ax.set_title(f"heading error, {config.rotation} rotation (grey: within {config.recovered_deg:g}°)", fontsize=9)
    ax.legend(loc="best", fontsize=7)
    proportion_points(rate_ax, {"trials": [bool(t["success"]) for t in rows]}, gid="success")
    rate_ax.set_ylabel("success (1 yes, 0 no)")
    rate_ax.set_title("every jump recovered" if config.rotation == "jump" else
                      f"mean error within {config.recovered_deg:g}°", fontsize=9)
    rate_ax.legend(loc="best", fontsize=7)
    return fig
