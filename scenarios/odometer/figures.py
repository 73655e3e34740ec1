"""Figures of the odometer experiment, after Wittlinger et al. 2006's Fig. 2: where each ant started to
search, per leg condition, and the homeward stride per leg condition.

Each ``*_figure`` function draws one figure and returns it; :func:`write_odometer_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

from neuronav.runs.plotting import condition_strip, new_figure, save

LEG_COLOURS = {"normal": "tab:blue", "stilts": "tab:red", "stumps": "tab:green"}
LEG_ORDER = ("stumps", "normal", "stilts")  # the paper's order: shortest strides first


def write_odometer_figures(result, config, out_dir: Path) -> list[Path]:
    """search_start.png, stride_length.png."""
    out_dir = Path(out_dir)
    return [save(search_start_figure(result, config), out_dir / "search_start.png"),
            save(stride_length_figure(result), out_dir / "stride_length.png")]


def by_legs(result, key: str) -> dict[str, list[float]]:
    """Each present leg condition's values of column ``key`` over the trials that ran (a failed trial's row has
    no metrics), in :data:`LEG_ORDER`."""
    ran = [t for t in result.trials if t.get("status", "ok") == "ok" and "legs" in t]
    present = {t["legs"] for t in ran}
    return {legs: [float(t[key]) for t in ran if t["legs"] == legs] for legs in LEG_ORDER if legs in present}


def search_start_figure(result, config):
    """The distance walked home before searching, per leg condition: box plot, every ant, the mean with its
    seeded bootstrap 95 % interval, and a line at the channel's length (where the nest would be)."""
    fig, ax = new_figure((5.5, 4.5))
    condition_strip(ax, by_legs(result, "search_start_m"), colours=LEG_COLOURS, box=True, gid="search start")
    ax.axhline(config.channel_m, color="k", ls="--", lw=1, gid="nest", label=f"nest ({config.channel_m:g} m)")
    ax.set_ylabel("distance walked home before searching (m)")
    ax.set_title(f"search start by legs (odometry: {config.odometry})")
    ax.legend(loc="best", fontsize=8)
    return fig


def stride_length_figure(result):
    """The homeward stride per leg condition: the true one (distance per gait cycle) and the one the
    odometer believed, side by side, every ant and the mean with its bootstrap 95 % interval."""
    fig, (true_ax, believed_ax) = new_figure((9, 4), 1, 2, sharey=True)
    condition_strip(true_ax, by_legs(result, "stride_length_m"), colours=LEG_COLOURS, gid="true stride")
    true_ax.set_ylabel("homeward stride (m per gait cycle)")
    true_ax.set_title("true stride")
    condition_strip(believed_ax, by_legs(result, "stride_length_believed_m"), colours=LEG_COLOURS,
                    gid="believed stride", legend=False)
    believed_ax.set_title("stride the odometer measured")
    true_ax.legend(loc="best", fontsize=8)
    return fig
