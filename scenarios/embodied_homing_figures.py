"""Figures of embodied homing, after the paper's Fig. 3: trajectories, CPU4 memory, fed vs measured velocity."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from neuronav.plotting import save  # noqa: E402


def write_embodied_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectories.png, cpu4_activity.png, velocity.png."""
    ts = result.timeseries
    paths = []
    time_s = ts["time_s"]
    fig, ax = plt.subplots(figsize=(7, 7))
    for i in range(len(result.trials)):
        outbound = time_s[i] <= config.outbound_s
        path = ts["position_m"][i]
        ax.plot(path[outbound, 0], path[outbound, 1], color="tab:blue", lw=0.8, alpha=0.7)
        ax.plot(path[~outbound, 0], path[~outbound, 1], color="tab:red", lw=0.8, alpha=0.8)
    ax.add_patch(plt.Circle((0, 0), config.nest_radius_m, fill=False, color="k", ls="--"))
    ax.plot(0, 0, "k*", ms=12, label="nest")
    ax.plot([], [], color="tab:blue", label="foraging")
    ax.plot([], [], color="tab:red", label="homing (CX)")
    success = np.mean([t["success"] for t in result.trials])
    ax.set_title(f"{len(result.trials)} trials, success {100 * success:.0f}%")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right")
    paths.append(out_dir / "trajectories.png")
    save(fig, paths[-1])

    keep = np.isfinite(ts["cpu4"][0, :, 0])
    fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    axes[0].imshow(ts["cpu4"][0, keep].T, aspect="auto", origin="lower", cmap="viridis",
                   extent=(time_s[0, keep][0], time_s[0, keep][-1], -0.5, 15.5))
    axes[0].axvline(config.outbound_s, color="w", ls="--")
    axes[0].set_ylabel("CPU4 cell")
    axes[0].set_title("trial 0: CPU4 memory (dashed: start of homing)")
    axes[1].plot(time_s[0, keep], np.degrees(np.angle(np.exp(1j * ts["heading_rad"][0, keep]))), lw=0.8)
    axes[1].axvline(config.outbound_s, color="k", ls="--")
    axes[1].set_ylabel("heading (deg)")
    axes[1].set_xlabel("time (s)")
    paths.append(out_dir / "cpu4_activity.png")
    save(fig, paths[-1])

    fig, axes = plt.subplots(3, 1, figsize=(9, 6), sharex=True)
    fed, measured = ts["fed_velocity"][0, keep], ts["measured_velocity"][0, keep]
    for k, label in enumerate(("x", "y")):
        axes[k].plot(time_s[0, keep], measured[:, k], color="0.7", lw=0.8, label="measured (instant)")
        axes[k].plot(time_s[0, keep], fed[:, k], color="k", lw=1.2, label="fed to the CX")
        axes[k].set_ylabel(f"v{label} (m/s)")
    axes[2].plot(time_s[0, keep], np.linalg.norm(measured, axis=1), color="0.7", lw=0.8)
    axes[2].plot(time_s[0, keep], np.linalg.norm(fed, axis=1), color="k", lw=1.2)
    axes[2].set_ylabel("speed (m/s)")
    axes[2].set_xlabel("time (s)")
    axes[0].legend(fontsize=7)
    axes[0].set_title("trial 0: velocity fed to the path integrator vs the body's instantaneous velocity")
    paths.append(out_dir / "velocity.png")
    save(fig, paths[-1])
    return paths
