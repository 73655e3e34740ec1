"""Figures of the locomotion scenario, after the paper's Fig. 2: paths, middle-right leg traces, gait diagram, climb.

Positions are those of the body centre (see :mod:`neuronav.scenarios.locomotion.scenario`); the climb figure
also shows the root (the front of the thorax), which rises more when the body rears up against the wall.

Each ``*_figure`` function draws one figure and returns it; :func:`write_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.bodies.desert_ant import LEGS
from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save, trial_colour

# A claw pressing on the ground with more than this counts as touching in the gait diagram.
STANCE_FORCE_N = 1.0
MAX_LABELLED_TRIALS = 8


def write_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectory.png (with the per-gait summary), leg_traces.png, gait_diagram.png (and climb.png on the wall)."""
    ts = result.timeseries
    out_dir = Path(out_dir)
    time_s = np.arange(ts["mr_angles_rad"].shape[1]) * config.control_dt_s
    paths = [save(trajectory_figure(result, config), out_dir / "trajectory.png"),
             save(leg_traces_figure(ts, config, time_s), out_dir / "leg_traces.png"),
             save(gait_diagram_figure(ts, config, time_s), out_dir / "gait_diagram.png")]
    if config.terrain == "wall":
        paths.append(save(climb_figure(result, config), out_dir / "climb.png"))
    return paths


def _title(config) -> str:
    extra = f", adhesion {config.adhesion_n:g} N" if config.adhesion_n > 0 else ""
    return f"{config.gait} gait, {config.terrain}, turn {config.turn:+.2f}, stride {config.stride_deg:g}°{extra}"


def trajectory_figure(result, config):
    """Top view of the body centre's path per trial (start: black dot, end: cross); beside it, per gait,
    each trial's forward speed (on the wall: climb height) and not falling (:func:`gait_panels`)."""
    ts = result.timeseries
    fig, (ax, metric_ax, upright_ax) = new_figure((13, 5.5), 1, 3, gridspec_kw={"width_ratios": [1.6, 1, 1]})
    for i, trial in enumerate(result.trials):
        xy = ts["position_m"][i][:, :2]
        ax.plot(xy[:, 0], xy[:, 1], lw=1, color=trial_colour(i),
                label=f"trial {trial['trial']}" if i < MAX_LABELLED_TRIALS else None)
        ax.plot(*xy[0], "ko", ms=3)
        ax.plot(*xy[-1], "kx", ms=5)
    if config.terrain == "wall":
        ax.axvline(1.0, color="0.3", lw=3, label="wall")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(_title(config), fontsize=10)
    ax.legend(fontsize=7)
    gait_panels(metric_ax, upright_ax, result, config)
    return fig


def gait_panels(metric_ax, upright_ax, result, config) -> None:
    """Per gait (the rows' ``gait`` column, as the scenario's statistics group them): every trial's forward
    speed (on the wall: the climb height) with the mean's bootstrap 95 % interval, and staying upright
    (1 or 0, the proportion with its Wilson 95 % interval)."""
    rows = [t for t in result.trials if t.get("status", "ok") == "ok"]
    names = list(dict.fromkeys(str(t.get("gait", config.gait)) for t in rows))
    key, label = (("climb_height_m", "climb height (m)") if config.terrain == "wall"
                  else ("forward_speed_m_s", "forward speed (m/s)"))
    condition_strip(metric_ax, {g: [t.get(key, np.nan) for t in rows if str(t.get("gait", config.gait)) == g]
                                for g in names}, gid=key)
    metric_ax.set_ylabel(label)
    metric_ax.set_title(f"{label.split(' (')[0]} by gait", fontsize=10)
    metric_ax.legend(fontsize=7, loc="best")
    proportion_points(upright_ax, {g: [bool(t["success"]) for t in rows if str(t.get("gait", config.gait)) == g]
                                   for g in names}, gid="upright")
    upright_ax.set_ylabel("did not fall (1 yes, 0 no)")
    upright_ax.set_title("staying upright by gait", fontsize=10)
    upright_ax.legend(fontsize=7, loc="best")


def leg_traces_figure(ts, config, time_s):
    """Joint angles and torques of the middle-right leg (the paper's Fig. 2a,b, right), trial 0."""
    fig, axes = new_figure((8, 5), 2, 1, sharex=True)
    for j, joint in enumerate(("ThCz", "CTr", "FTi")):
        axes[0].plot(time_s, np.degrees(ts["mr_angles_rad"][0, :, j]), label=joint)
        axes[1].plot(time_s, ts["mr_torques_nm"][0, :, j], label=joint)
    axes[0].set_ylabel("angle (deg)")
    axes[1].set_ylabel("torque (N·m)")
    axes[1].set_xlabel("time (s)")
    axes[0].set_title(f"middle-right leg, trial 0 — {_title(config)}", fontsize=10)
    axes[0].legend(fontsize=7, ncol=3)
    return fig


def _bars(ax, on: np.ndarray, time_s: np.ndarray, dt_s: float, row: float, height: float, **style) -> None:
    edges = np.flatnonzero(np.diff(np.r_[0, on.astype(int), 0]))
    spans = [(time_s[start], (stop - start) * dt_s) for start, stop in zip(edges[::2], edges[1::2])]
    if spans:
        ax.broken_barh(spans, (row - height / 2, height), **style)


def gait_diagram_figure(ts, config, time_s):
    """Per leg (FL at the top): commanded stance (grey) and measured claw contact (black), trial 0."""
    fig, ax = new_figure((8, 3))
    touching = ts["claw_force_n"][0] > STANCE_FORCE_N  # (steps, legs)
    stance = ~ts["swing"][0] if "swing" in ts else None
    for leg in range(len(LEGS)):
        row = len(LEGS) - 1 - leg
        if stance is not None:
            _bars(ax, stance[:, leg], time_s, config.control_dt_s, row, 0.8, color="0.8")
        _bars(ax, touching[:, leg], time_s, config.control_dt_s, row, 0.4, color="k")
    ax.set_yticks(range(len(LEGS)), LEGS[::-1])
    ax.set_ylim(-0.6, len(LEGS) - 0.4)
    ax.set_xlabel("time (s)")
    ax.set_title(f"gait diagram, trial 0 (grey: commanded stance; black: claw touching) — {config.gait}",
                 fontsize=10)
    return fig


def climb_figure(result, config):
    """Side view (x, z) of the centre and the root, and their heights above the start over time.

    Colour: trial; solid: body centre; dashed: root (front of the thorax). One legend, on the
    height panel, names each trial's colour by the trial's own centre line.
    """
    ts = result.timeseries
    fig, (side, height) = new_figure((11, 4), 1, 2, gridspec_kw={"width_ratios": [1, 1.6]})
    full_time = np.arange(ts["position_m"].shape[1]) * config.control_dt_s
    for i in range(len(result.trials)):
        centre, root = ts["position_m"][i], ts["root_m"][i]
        colour = trial_colour(i)
        side.plot(centre[:, 0], centre[:, 2], color=colour, lw=1, gid=f"trial {i} centre")
        side.plot(root[:, 0], root[:, 2], color=colour, lw=1, ls="--", gid=f"trial {i} root")
        height.plot(full_time, centre[:, 2] - centre[0, 2], color=colour, lw=1,
                    label=f"trial {i}" if i < MAX_LABELLED_TRIALS else None, gid=f"trial {i} centre")
        height.plot(full_time, root[:, 2] - root[0, 2], color=colour, lw=0.8, ls="--", gid=f"trial {i} root")
    side.axvline(1.0, color="0.3", lw=3)
    side.axhline(0.0, color="0.6", lw=1)
    side.set_xlabel("x (m)")
    side.set_ylabel("z (m)")
    side.set_title("side view (wall at x = 1 m; solid: centre, dashed: root)", fontsize=10)
    height.axhline(0.0, color="0.6", lw=1)
    height.set_xlabel("time (s)")
    height.set_ylabel("height above start (m)")
    height.set_title(f"climb, adhesion {config.adhesion_n:g} N (solid: centre, dashed: root)", fontsize=10)
    height.legend(fontsize=7)
    return fig
