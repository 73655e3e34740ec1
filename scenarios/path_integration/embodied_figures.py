"""Figures of embodied homing, after the paper's Fig. 3: trajectories, CPU4 memory, fed vs measured velocity.

Each ``*_figure`` function draws one figure and returns it; :func:`write_embodied_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import heading_panel, new_figure, save, success_text, trial_colour


def write_embodied_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectories.png, cpu4_activity.png, velocity.png."""
    out_dir = Path(out_dir)
    return [save(trajectories_figure(result, config), out_dir / "trajectories.png"),
            save(cpu4_figure(result, config), out_dir / "cpu4_activity.png"),
            save(velocity_figure(result, config), out_dir / "velocity.png")]


def trajectories_figure(result, config):
    """Top view: each trial in its own colour, foraging dashed and homing solid (joined at the turn)."""
    from matplotlib.patches import Circle

    ts = result.timeseries
    time_s = ts["time_s"]
    fig, ax = new_figure((7, 7))
    labelled = {"outbound": False, "homing": False}  # the legend names the first line of each drawn
    for i in range(len(result.trials)):
        recorded = np.isfinite(time_s[i])
        outbound = recorded & (time_s[i] <= config.outbound_s)
        homing = recorded & ~outbound
        if outbound.any() and homing.any():  # start the homing line where foraging ended
            homing[np.flatnonzero(outbound)[-1]] = True
        path = ts["position_m"][i]
        colour = trial_colour(i)
        for part, keep, style, label in (("outbound", outbound, dict(lw=0.8, ls="--", alpha=0.8), "foraging (dashed)"),
                                         ("homing", homing, dict(lw=1.0), "homing, CX (solid)")):
            visible = keep.sum() >= 2  # a line needs two points
            ax.plot(path[keep, 0], path[keep, 1], color=colour, **style, gid=f"trial {i} {part}",
                    label=label if visible and not labelled[part] else None)
            labelled[part] |= bool(visible)
    ax.add_patch(Circle((0, 0), config.nest_radius_m, fill=False, color="k", ls="--"))
    ax.plot(0, 0, "k*", ms=12, label="nest")
    ax.set_title(f"{len(result.trials)} trials (colour: trial), {success_text([t['success'] for t in result.trials])}",
                 fontsize=10)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right")
    return fig


def cpu4_figure(result, config, trial: int = 0):
    """One trial (default 0): CPU4 memory (cells x time) above the heading (degrees, broken at ±180°)."""
    ts = result.timeseries
    time_s = ts["time_s"]
    keep = np.isfinite(ts["cpu4"][trial, :, 0])
    fig, axes = new_figure((9, 5), 2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    axes[0].imshow(ts["cpu4"][trial, keep].T, aspect="auto", origin="lower", cmap="viridis",
                   extent=(time_s[trial, keep][0], time_s[trial, keep][-1], -0.5, 15.5))
    axes[0].axvline(config.outbound_s, color="w", ls="--")
    axes[0].set_ylabel("CPU4 cell")
    axes[0].set_title(f"trial {trial}: CPU4 memory (dashed: start of homing)")
    heading_panel(axes[1], time_s[trial, keep], ts["heading_rad"][trial, keep], config.outbound_s, "time (s)")
    return fig


def velocity_figure(result, config, trial: int = 0):
    """One trial (default 0): the velocity fed to the CX (black) and the body's instantaneous velocity (grey)."""
    ts = result.timeseries
    keep = np.isfinite(ts["cpu4"][trial, :, 0])
    time_s = ts["time_s"][trial, keep]
    fig, axes = new_figure((9, 6), 3, 1, sharex=True)
    fed, measured = ts["fed_velocity"][trial, keep], ts["measured_velocity"][trial, keep]
    for k, label in enumerate(("x", "y")):
        axes[k].plot(time_s, measured[:, k], color="0.7", lw=0.8, label="measured (instant)")
        axes[k].plot(time_s, fed[:, k], color="k", lw=1.2, label="fed to the CX")
        axes[k].set_ylabel(f"v{label} (m/s)")
    axes[2].plot(time_s, np.linalg.norm(measured, axis=1), color="0.7", lw=0.8)
    axes[2].plot(time_s, np.linalg.norm(fed, axis=1), color="k", lw=1.2)
    axes[2].set_ylabel("speed (m/s)")
    axes[2].set_xlabel("time (s)")
    axes[0].legend(fontsize=7)
    axes[0].set_title(f"trial {trial}: velocity fed to the path integrator vs the body's instantaneous velocity")
    return fig
