"""Figures of the route-following scenario: the trained route and the test paths, the familiarity landscape."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import new_figure, save, trial_colour


def write_route_figures(result, config, out_dir: Path) -> list[Path]:
    """``route_paths.png`` (the route, the training walks, the test paths) and, when measured,
    ``familiarity_landscape.png`` (the first trial's novelty about the route)."""
    series = result.timeseries
    route = series["route_m"][0]
    fig, ax = new_figure((7.0, 4.5))
    ax.plot(route[:, 0], route[:, 1], color="k", lw=3, alpha=0.25, label="route")
    for i, train in enumerate(series["train_position_m"]):
        ax.plot(train[:, 0], train[:, 1], color="0.5", lw=0.8, ls=":", label="training walk" if i == 0 else None)
    for i, path in enumerate(series["position_m"]):
        ax.plot(path[:, 0], path[:, 1], color=trial_colour(i), lw=1.2,
                label=f"test ({config.strategy})" if i == 0 else None)
        finite = path[np.isfinite(path[:, 0])]
        if len(finite):
            ax.plot(*finite[0], "o", color=trial_colour(i), ms=4)
    ax.plot(*route[-1], "*", color="k", ms=12, label="route end")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    reached = np.mean([t.get("checkpoints_reached", np.nan) for t in result.trials])
    ax.set_title(f"route following by {config.strategy}: {100 * reached:.0f} % of checkpoints reached")
    ax.legend(fontsize=7, loc="best")
    paths = [save(fig, out_dir / "route_paths.png")]
    if "landscape_novelty" in series:
        fig, ax = new_figure((7.0, 4.5))
        mesh = ax.pcolormesh(series["landscape_x_m"][0], series["landscape_y_m"][0], series["landscape_novelty"][0],
                             shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label="novelty / active KCs, facing along the route")
        ax.plot(route[:, 0], route[:, 1], color="w", lw=1.5)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title("familiarity landscape about the trained route (first trial)")
        paths.append(save(fig, out_dir / "familiarity_landscape.png"))
    return paths
