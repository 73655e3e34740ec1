"""Figures of the route-following scenario: the trained route and the test paths, the familiarity landscape."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save, trial_colour


def write_route_figures(result, config, out_dir: Path) -> list[Path]:
    """``route_paths.png`` (the route, the training walks, the test paths; beside them the checkpoints
    reached and success per condition, :func:`summary_panels`) and, when measured,
    ``familiarity_landscape.png`` (the first trial's novelty about the route)."""
    series = result.timeseries
    route = series["route_m"][0]
    fig, (ax, reached_ax, success_ax) = new_figure((13.0, 4.5), 1, 3, gridspec_kw={"width_ratios": [2.2, 1, 1]})
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
    ax.set_title(f"route following by {config.strategy}: {len(result.trials)} test paths", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    summary_panels(reached_ax, success_ax, result, config)
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


def conditions(result, config) -> dict[str, list[dict]]:
    """The finished trials per condition the run compares: per strategy, or per release offset when one
    strategy ran at several (as the scenario's statistics group them)."""
    from neuronav.scenarios.route_following.scenario import release_offsets_m, strategies

    rows = [t for t in result.trials if t.get("status", "ok") == "ok"]
    if len(strategies(config)) == 1 and len(release_offsets_m(config)) > 1:
        names = {o: f"offset {o:g} m" for o in release_offsets_m(config)}
        return {name: [t for t in rows if t.get("release_offset_m") == o] for o, name in names.items()}
    return {s: [t for t in rows if t.get("strategy", s) == s] for s in strategies(config)}


def summary_panels(reached_ax, success_ax, result, config) -> None:
    """Per condition: each trial's fraction of checkpoints reached (the mean with its bootstrap 95 %
    interval) and reaching the route's end (1 or 0, the proportion with its Wilson 95 % interval)."""
    groups = {name: rows for name, rows in conditions(result, config).items() if rows}
    condition_strip(reached_ax, {name: [t["checkpoints_reached"] for t in rows] for name, rows in groups.items()},
                    gid="checkpoints")
    reached_ax.set_ylim(-0.05, 1.05)
    reached_ax.set_ylabel("checkpoints reached (fraction)")
    reached_ax.set_title("checkpoints reached", fontsize=10)
    reached_ax.legend(fontsize=7, loc="best")
    proportion_points(success_ax, {name: [bool(t["success"]) for t in rows] for name, rows in groups.items()},
                      gid="success")
    success_ax.set_ylabel("reached the route's end (1 yes, 0 no)")
    success_ax.set_title("reaching the end", fontsize=10)
    success_ax.legend(fontsize=7, loc="best")
