"""Figures of the path-integration scenario: trajectories, CPU4 memory over time, TB1 vs heading."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from brains.cx import stone2017  # noqa: E402
from neuronav.plotting import plot_circuit, plot_connectivity, save  # noqa: E402

MAX_TRAJECTORIES = 200


def write_figures(result, config, out_dir: Path) -> list[Path]:
    """Write trajectories.png, cpu4_activity.png, tb1_heading.png and the circuit plots."""
    paths = []
    ts = result.timeseries
    k = config.record_every
    turn = config.outbound_steps // k

    fig, ax = plt.subplots(figsize=(7, 7))
    ok = [t["trial"] for t in result.trials if t.get("status") == "ok"]
    for i in ok[:MAX_TRAJECTORIES]:
        path = ts["position"][i]
        ax.plot(path[: turn + 1, 0], path[: turn + 1, 1], color="tab:blue", lw=0.5, alpha=0.5)
        ax.plot(path[turn:, 0], path[turn:, 1], color="tab:red", lw=0.5, alpha=0.5)
    ax.add_patch(plt.Circle((0, 0), config.success_radius, fill=False, color="k", ls="--"))
    ax.plot(0, 0, "k*", ms=12, label="nest")
    ax.plot([], [], color="tab:blue", label="outbound")
    ax.plot([], [], color="tab:red", label="homing (CX)")
    success = np.mean([t["success"] for t in result.trials])
    ax.set_title(f"{len(result.trials)} trials, success {100 * success:.1f}%, "
                 f"tortuosity {result.aggregates.get('tortuosity', float('nan')):.3f}")
    ax.set_aspect("equal")
    ax.set_xlabel("x (steps)")
    ax.set_ylabel("y (steps)")
    ax.legend(loc="upper right")
    paths.append(out_dir / "trajectories.png")
    save(fig, paths[-1])

    if ts["cpu4_memory"].shape[0]:
        time = np.arange(1, ts["cpu4_memory"].shape[1] + 1) * k
        fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
        image = axes[0].imshow(ts["cpu4_memory"][0].T, aspect="auto", origin="lower", cmap="viridis",
                               extent=(time[0], time[-1], -0.5, 15.5))
        axes[0].axvline(config.outbound_steps, color="w", ls="--")
        axes[0].set_ylabel("CPU4 cell")
        axes[0].set_title("trial 0: CPU4 memory (dashed: turn back)")
        fig.colorbar(image, ax=axes, shrink=0.6, label="memory")
        axes[1].plot(time, np.degrees(np.angle(np.exp(1j * ts["heading_rad"][0]))), lw=0.8)
        axes[1].axvline(config.outbound_steps, color="k", ls="--")
        axes[1].set_ylabel("heading (deg)")
        axes[1].set_xlabel("step")
        paths.append(out_dir / "cpu4_activity.png")
        fig.savefig(paths[-1], dpi=120)
        plt.close(fig)

        fig, ax = plt.subplots(figsize=(9, 3.5))
        ax.imshow(ts["tb1_rates"][0].T, aspect="auto", origin="lower", cmap="magma",
                  extent=(time[0], time[-1], -0.5, 7.5))
        column = (np.mod(ts["heading_rad"][0], 2 * np.pi) / (np.pi / 4))
        column = np.where(column > 7.5, column - 8, column)
        ax.plot(time, column, "c.", ms=1.5, label="heading (column units)")
        ax.set_ylabel("TB1 column")
        ax.set_xlabel("step")
        ax.set_title("trial 0: TB1 (inverted bump: the dark column follows the heading)")
        ax.legend(loc="upper right", fontsize=7)
        paths.append(out_dir / "tb1_heading.png")
        save(fig, paths[-1])

    circuit = stone2017(noise=config.noise)
    fig, ax = plt.subplots(figsize=(8, 7))
    plot_connectivity(circuit, ax)
    paths.append(out_dir / "circuit_connectivity.png")
    save(fig, paths[-1])
    fig, ax = plt.subplots(figsize=(9, 5))
    plot_circuit(circuit, ax)
    paths.append(out_dir / "circuit_diagram.png")
    save(fig, paths[-1])
    return paths
