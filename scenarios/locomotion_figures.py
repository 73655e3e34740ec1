"""Figures of the locomotion scenario, after the paper's Fig. 2: paths, middle-right leg traces, gait diagram."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bodies.desert_ant import LEGS  # noqa: E402
from neuronav.plotting import save  # noqa: E402

# A claw pressing on the ground with more than this counts as stance in the gait diagram.
STANCE_FORCE_N = 1.0


def write_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectory.png, leg_traces.png, gait_diagram.png (and climb.png on the wall)."""
    ts = result.timeseries
    paths = []
    time_s = np.arange(ts["mr_angles_rad"].shape[1]) * config.control_dt_s

    fig, ax = plt.subplots(figsize=(6, 6))
    for i, trial in enumerate(result.trials):
        path = ts["position_m"][i]
        ax.plot(path[:, 0], path[:, 1], lw=1, label=f"trial {trial['trial']}" if i < 8 else None)
        ax.plot(path[0, 0], path[0, 1], "ko", ms=3)
    if config.terrain == "wall":
        ax.axvline(1.0, color="0.3", lw=3, label="wall")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{config.gait} gait, {config.terrain}, turn {config.turn:+.2f}, stride {config.stride_deg:g}°")
    ax.legend(fontsize=7)
    paths.append(out_dir / "trajectory.png")
    save(fig, paths[-1])

    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for j, joint in enumerate(("ThCz", "CTr", "FTi")):
        axes[0].plot(time_s, np.degrees(ts["mr_angles_rad"][0, :, j]), label=joint)
        axes[1].plot(time_s, ts["mr_torques_nm"][0, :, j], label=joint)
    axes[0].set_ylabel("angle (deg)")
    axes[1].set_ylabel("torque (N·m)")
    axes[1].set_xlabel("time (s)")
    axes[0].set_title("middle-right leg, trial 0")
    axes[0].legend(fontsize=7, ncol=3)
    paths.append(out_dir / "leg_traces.png")
    save(fig, paths[-1])

    fig, ax = plt.subplots(figsize=(8, 3))
    stance = ts["claw_force_n"][0] > STANCE_FORCE_N  # (steps, legs)
    for leg in range(stance.shape[1]):
        on = stance[:, leg]
        edges = np.flatnonzero(np.diff(np.r_[0, on.astype(int), 0]))
        for start, stop in zip(edges[::2], edges[1::2]):
            ax.broken_barh([(time_s[start], (stop - start) * config.control_dt_s)], (leg - 0.4, 0.8), color="k")
    ax.set_yticks(range(len(LEGS)), LEGS)
    ax.set_xlabel("time (s)")
    ax.set_title("gait diagram (black: claw on the ground), trial 0")
    paths.append(out_dir / "gait_diagram.png")
    save(fig, paths[-1])

    if config.terrain == "wall":
        fig, ax = plt.subplots(figsize=(7, 3))
        full_time = np.arange(ts["position_m"].shape[1]) * config.control_dt_s
        for i in range(len(result.trials)):
            height = ts["position_m"][i, :, 2]
            ax.plot(full_time, height - height[0])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("climb height (m)")
        ax.set_title(f"wall climbing, adhesion {config.adhesion_n:g} N")
        paths.append(out_dir / "climb.png")
        save(fig, paths[-1])
    return paths
