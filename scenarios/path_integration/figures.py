"""Figures of the path-integration scenario: trajectories, CPU4 memory over time, TB1 vs heading.

Each ``*_figure`` function draws one figure and returns it (a :class:`matplotlib.figure.Figure`);
:func:`write_figures` saves them. matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.brains.cx import stone2017
from neuronav.brains.sky_compass import sky_stone2017
from neuronav.runs.plotting import (
    heading_panel,
    new_figure,
    plot_circuit,
    plot_connectivity,
    save,
    success_text,
    trial_colour,
)

MAX_TRAJECTORIES = 200


def write_figures(result, config, out_dir: Path) -> list[Path]:
    """Write trajectories.png, cpu4_activity.png, tb1_heading.png and the circuit plots."""
    out_dir = Path(out_dir)
    paths = [save(trajectories_figure(result, config), out_dir / "trajectories.png")]
    if result.timeseries["cpu4_memory"].shape[0]:
        paths.append(save(cpu4_figure(result, config), out_dir / "cpu4_activity.png", tight=False))
        paths.append(save(tb1_figure(result, config), out_dir / "tb1_heading.png"))
    circuit = sky_stone2017(noise=config.noise) if _sky(config) else stone2017(noise=config.noise)
    fig, ax = new_figure((8, 7))
    plot_connectivity(circuit, ax)
    paths.append(save(fig, out_dir / "circuit_connectivity.png"))
    fig, ax = new_figure((9, 5))
    plot_circuit(circuit, ax)
    paths.append(save(fig, out_dir / "circuit_diagram.png"))
    return paths


def trajectories_figure(result, config):
    """Top view: each recorded trial in its own colour, outbound dashed and homing solid."""
    from matplotlib.patches import Circle

    ts = result.timeseries
    turn = config.outbound_steps // config.record_every
    fig, ax = new_figure((7, 7))
    ok = [t["trial"] for t in result.trials if t.get("status") == "ok"]
    for n, i in enumerate(ok[:MAX_TRAJECTORIES]):
        path = ts["position"][i]
        colour = trial_colour(n)
        ax.plot(path[: turn + 1, 0], path[: turn + 1, 1], color=colour, lw=0.6, ls="--", alpha=0.7,
                label="outbound (dashed)" if n == 0 else None, gid=f"trial {i} outbound")
        ax.plot(path[turn:, 0], path[turn:, 1], color=colour, lw=0.8, alpha=0.8,
                label="homing, CX (solid)" if n == 0 else None, gid=f"trial {i} homing")
    ax.add_patch(Circle((0, 0), config.success_radius, fill=False, color="k", ls="--"))
    ax.plot(0, 0, "k*", ms=12, label="nest")
    ax.set_title(f"{len(result.trials)} trials (colour: trial), {success_text([t['success'] for t in result.trials])},"
                 f"\ntortuosity {result.aggregates.get('tortuosity', float('nan')):.3f}", fontsize=10)
    ax.set_aspect("equal")
    ax.set_xlabel("x (steps)")
    ax.set_ylabel("y (steps)")
    ax.legend(loc="upper right")
    return fig


def _record_extent(time, record_every, rows):
    """An image's extent with each column centred on its record's step, half a record either side.

    A run with a single record still gets a column one record wide (an extent from time[0] to
    time[-1] would have zero width, and matplotlib's resampling never finishes on it).
    """
    half = 0.5 * record_every
    return (time[0] - half, time[-1] + half, *rows)


def cpu4_figure(result, config):
    """Trial 0: CPU4 memory (cells x steps) above the heading (degrees, broken at ±180°)."""
    ts = result.timeseries
    time = np.arange(1, ts["cpu4_memory"].shape[1] + 1) * config.record_every
    fig, axes = new_figure((9, 5), 2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    image = axes[0].imshow(ts["cpu4_memory"][0].T, aspect="auto", origin="lower", cmap="viridis",
                           extent=_record_extent(time, config.record_every, (-0.5, 15.5)))
    axes[0].axvline(config.outbound_steps, color="w", ls="--")
    axes[0].set_ylabel("CPU4 cell")
    axes[0].set_title("trial 0: CPU4 memory (dashed: turn back)")
    fig.colorbar(image, ax=axes, shrink=0.6, label="memory")
    heading_panel(axes[1], time, ts["heading_rad"][0], config.outbound_steps, "step")
    return fig


def _sky(config) -> bool:
    """Whether the run's CX read the sky compass (stone2017 runs one compass per run)."""
    return str(config.compass).strip() == "sky"


def tb1_figure(result, config):
    """Trial 0: TB1 rates (columns x steps) with the heading in column units as dots."""
    ts = result.timeseries
    time = np.arange(1, ts["tb1_rates"].shape[1] + 1) * config.record_every
    fig, ax = new_figure((9, 3.5))
    ax.imshow(ts["tb1_rates"][0].T, aspect="auto", origin="lower", cmap="magma",
              extent=_record_extent(time, config.record_every, (-0.5, 7.5)))
    # The sky compass's TB1 stands for the heading relative to the sun's azimuth.
    frame_rad = np.radians(config.sun_azimuth_deg) if _sky(config) else 0.0
    column = np.mod(ts["heading_rad"][0] - frame_rad, 2 * np.pi) / (np.pi / 4)
    column = np.where(column > 7.5, column - 8, column)
    ax.plot(time, column, "c.", ms=1.5,
            label="heading - sun azimuth (column units)" if _sky(config) else "heading (column units)")
    ax.set_ylabel("TB1 column")
    ax.set_xlabel("step")
    ax.set_title("trial 0: TB1 (inverted bump: the dark column follows the heading)")
    ax.legend(loc="upper right", fontsize=7)
    return fig
