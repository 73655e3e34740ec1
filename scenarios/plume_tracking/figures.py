"""Figures of plume tracking, after the paper's Fig. 6e–g: the plume with the paths, trial 0's senses and speed.

Each ``*_figure`` function draws one figure and returns it; :func:`write_plume_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save

ARENA_X_M, ARENA_Y_M = (0.0, 8.0), (-2.0, 2.0)
ODOUR_COLOURS = {"on": "tab:green", "off": "tab:grey"}
MAX_PLUME_PANELS = 4  # trials drawn over their own plume in plume_paths.png


def _odour(trial: dict, config) -> str:
    """A trial's odour input, on or off (rows written before issue 22 have no ``odour_on`` column: the run's)."""
    return ("on" if trial["odour_on"] else "off") if "odour_on" in trial else str(config.odour)


def _outcome(trial: dict) -> str:
    """How a trial ended, for a title."""
    if trial.get("status", "ok") != "ok":
        return "the trial failed"
    return f"reached the source at {trial['time_to_source_s']:.1f} s" if trial["success"] else "did not arrive"


def write_plume_figures(result, config, out_dir: Path) -> list[Path]:
    """plume_paths.png (Fig. 6e–f: the first trials, each over its own plume), trial0_senses.png (Fig. 6g),
    time_to_source.png."""
    out_dir = Path(out_dir)
    return [save(plume_paths_figure(result, config), out_dir / "plume_paths.png", tight=False),
            save(senses_figure(result, config), out_dir / "trial0_senses.png"),
            save(times_figure(result, config), out_dir / "time_to_source.png")]


def plume_paths_figure(result, config, max_panels: int = MAX_PLUME_PANELS):
    """Each of the first recorded trials (up to ``max_panels``) in its own panel, its path over its own plume
    at its end (log concentration, the live puffs as dots), since every trial meets a plume of its own; when
    the run has more trials, a last panel with every trial's path and no plume (green: reached the source,
    grey: not; dashed: odour off)."""
    from matplotlib.colors import LogNorm

    ts = result.timeseries
    recorded = min(len(result.trials), len(ts["plume_raster"]), len(ts["puffs_m"]), max(int(max_panels), 1))
    overview = len(result.trials) > recorded
    panels = recorded + overview
    ncols = 1 if panels == 1 else 2
    nrows = -(-panels // ncols)
    fig, axes = new_figure((6.5 * ncols + 1.2, 3.3 * nrows + 0.6), nrows, ncols, squeeze=False)
    fig.set_layout_engine("constrained")
    axes = list(axes.ravel())
    for ax in axes[panels:]:
        ax.set_visible(False)
    rasters = [np.asarray(ts["plume_raster"][i], float) for i in range(recorded)]
    positive = np.concatenate([r[r > config.threshold] for r in rasters] + [np.empty(0)])
    norm = LogNorm(vmin=config.threshold, vmax=max(float(positive.max()), config.threshold * 10)) \
        if positive.size else None
    image = None
    for i in range(recorded):
        ax = axes[i]
        raster = rasters[i]
        if norm is not None and np.any(raster > config.threshold):
            image = ax.imshow(np.where(raster > config.threshold, raster, np.nan), extent=(*ARENA_X_M, *ARENA_Y_M),
                              origin="upper", cmap="magma_r", norm=norm, gid=f"plume {i}", interpolation="nearest")
        puffs = np.asarray(ts["puffs_m"][i], float)
        puffs = puffs[np.isfinite(puffs[:, 0])]
        ax.plot(puffs[:, 0], puffs[:, 1], ".", color="tab:purple", ms=1.5, alpha=0.5, gid=f"puffs {i}")
        _trial_path(ax, result, config, i, lw=1.6)
        trial = result.trials[i]
        ax.set_title(f"trial {i} (odour {_odour(trial, config)}) over its own plume: {_outcome(trial)}", fontsize=9)
    if overview:
        ax = axes[recorded]
        for i in range(len(result.trials)):
            _trial_path(ax, result, config, i, lw=0.9)
        reached = sum(bool(t["success"]) for t in result.trials)
        ax.set_title(f"all {len(result.trials)} trials' paths, {reached} reached the source (green); "
                     "no plume: each trial had its own", fontsize=9)
    positions = np.asarray(ts["position_m"], float)
    for ax in axes[:panels]:
        _arena(ax, config, positions)
    if image is not None:
        fig.colorbar(image, ax=axes[:panels], label="odour (amount/m³), each trial at its end", shrink=0.8)
    fig.suptitle(f"plume tracking (odour {config.odour}): "
                 f"{sum(bool(t['success']) for t in result.trials)}/{len(result.trials)} reached the source")
    return fig


def _trial_path(ax, result, config, i: int, lw: float) -> None:
    """Trial ``i``'s path (green: reached the source, grey: not; dashed: odour off) and its start (triangle)."""
    trial = result.trials[i]
    path = np.asarray(result.timeseries["position_m"][i], float)
    path = path[np.isfinite(path[:, 0])]
    colour = "tab:green" if trial["success"] else "tab:grey"
    ax.plot(path[:, 0], path[:, 1], color=colour, lw=lw, ls="--" if _odour(trial, config) == "off" else "-",
            gid=f"trial {i}")
    ax.plot(path[:1, 0], path[:1, 1], "^", color=colour, ms=5, gid=f"start {i}")


def _arena(ax, config, positions: np.ndarray) -> None:
    """The source with its success radius, the wind's arrow, limits holding the arena and every path, labels."""
    from matplotlib.patches import Circle

    ax.add_patch(Circle((config.source_x_m, 0.0), config.success_radius_m, fill=False, ls="--", color="k",
                        gid="source radius"))
    ax.plot(config.source_x_m, 0.0, "k*", ms=12, label="source")
    direction = np.radians(getattr(config, "wind_direction_deg", 0.0))
    tail = np.array([7.1, 1.7]) - 0.5 * np.array([np.cos(direction), np.sin(direction)])
    ax.annotate("", xy=tuple(tail + np.array([np.cos(direction), np.sin(direction)])), xytext=tuple(tail),
                arrowprops=dict(arrowstyle="->", lw=1.5))
    ax.text(7.1, 1.85, f"wind {config.wind_mps:g} m/s", ha="center", fontsize=8)
    ax.set_xlim(min(ARENA_X_M[0], np.nanmin(positions[..., 0]) - 0.3),
                max(ARENA_X_M[1], np.nanmax(positions[..., 0]) + 0.3))
    ax.set_ylim(min(ARENA_Y_M[0], np.nanmin(positions[..., 1]) - 0.3),
                max(ARENA_Y_M[1], np.nanmax(positions[..., 1]) + 0.3))
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def senses_figure(result, config):
    """Trial 0 over time: odour at both tips (log), the ant's speed, the wind at the tips (Fig. 6g)."""
    fig, axes = new_figure((8, 6), nrows=3, sharex=True)
    ts = result.timeseries
    t = ts["time_s"][0]
    keep = np.isfinite(t)
    t = t[keep]
    odour = ts["odour"][0][keep]
    for k, (side, colour) in enumerate((("left", "tab:blue"), ("right", "tab:red"))):
        axes[0].semilogy(t, np.maximum(odour[:, k], config.threshold / 100), color=colour, lw=0.9,
                         label=f"{side} antenna", gid=f"odour {side}")
    axes[0].axhline(config.threshold, color="k", ls=":", lw=1, label="threshold")
    axes[0].set_ylabel("odour (amount/m³)")
    axes[0].legend(loc="upper left", fontsize=8)
    path = ts["position_m"][0][keep]
    speed = np.hypot(*np.diff(path, axis=0).T) / np.maximum(np.diff(t), 1e-12)
    axes[1].plot(t[1:], speed, color="k", lw=0.9, gid="speed")
    axes[1].set_ylabel("speed (m/s)")
    wind = ts["wind_mps"][0][keep]
    for k, (label, colour) in enumerate((("w_x", "tab:orange"), ("w_y", "tab:cyan"))):
        axes[2].plot(t, wind[:, 0, k], color=colour, lw=1.0, label=f"{label} (left tip)", gid=f"wind {label}")
    axes[2].set_ylabel("wind (m/s)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(loc="upper left", fontsize=8)
    axes[0].set_title(f"trial 0 (odour {config.odour}): {_outcome(result.trials[0])}")
    return fig


def times_figure(result, config):
    """Per odour input, left: each arriving trial's time to the source (box plot, every trial, the median
    with its bootstrap 95 % interval; n counts the arrivals of all trials); right: reaching the source (each
    trial at 1 or 0, the proportion with its Wilson 95 % interval)."""
    fig, (ax, rate_ax) = new_figure((8, 4), 1, 2, gridspec_kw={"width_ratios": [1.4, 1]})
    modes = [_odour(t, config) if t.get("status", "ok") == "ok" else None for t in result.trials]  # failed: none
    present = [m for m in ("on", "off") if m in modes] or sorted(set(modes) - {None})
    colours = {f"odour {m}": ODOUR_COLOURS.get(m, "tab:blue") for m in present}
    condition_strip(ax, {f"odour {mode}": [t["time_to_source_s"] for t, m in zip(result.trials, modes) if m == mode]
                         for mode in present}, colours=colours, centre="median", box=True, gid="reached")
    ax.set_ylabel("time to the source (s)")
    ax.set_ylim(0, config.timeout_s * 1.05)
    ax.set_title(f"time to the source (limit {config.timeout_s:g} s)", fontsize=9)
    ax.legend(loc="best", fontsize=7)
    proportion_points(rate_ax, {f"odour {mode}": [bool(t["success"]) for t, m in zip(result.trials, modes) if m == mode]
                                for mode in present}, colours=colours, gid="success")
    rate_ax.set_ylabel("reached the source (1 yes, 0 no)")
    rate_ax.set_title("reaching the source", fontsize=9)
    rate_ax.legend(loc="best", fontsize=7)
    return fig
