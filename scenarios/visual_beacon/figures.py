"""Figures of the visual beacon, after the paper's Fig. 4: paths per eye mode, times, first views.

Each ``*_figure`` function draws one figure and returns it; :func:`write_beacon_figures` saves them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.runs.plotting import condition_strip, new_figure, proportion_points, save

MODE_COLOURS = {"left": "tab:blue", "right": "tab:red", "both": "tab:green"}
MODES = ("left", "right", "both")


def write_beacon_figures(result, config, out_dir: Path) -> list[Path]:
    """trajectories.png, time_to_landmark.png, first_views.png."""
    out_dir = Path(out_dir)
    return [save(trajectories_figure(result, config), out_dir / "trajectories.png"),
            save(times_figure(result), out_dir / "time_to_landmark.png"),
            save(first_views_figure(result, config), out_dir / "first_views.png")]


def _modes(result) -> list[str | None]:
    """Each trial's eye mode; None for a trial that failed (its row has no metrics: in no group)."""
    return [None if "eye_mode" not in t else MODES[int(t["eye_mode"])] if np.isfinite(t["eye_mode"]) else "both"
            for t in result.trials]


def trajectories_figure(result, config):
    """Top view: every trial's path coloured by its eye mode, each trial's start (its first recorded
    position: starts are jittered) as an open triangle, the landmark as a black disc."""
    from matplotlib.patches import Circle

    fig, ax = new_figure((6, 7))
    modes = _modes(result)
    labelled = set()
    for i, mode in enumerate(modes):
        if mode is None:  # a failed trial: no path to draw
            continue
        path = result.timeseries["position_m"][i]
        path = path[np.isfinite(path[:, 0])]
        ax.plot(path[:, 0], path[:, 1], color=MODE_COLOURS[mode], lw=1.2, gid=f"trial {i} {mode}",
                label=f"{mode} eye{'s' if mode == 'both' else ''}" if mode not in labelled else None)
        labelled.add(mode)
    ax.add_patch(Circle((0.0, config.landmark_distance_m), 1.0, color="k", gid="landmark"))
    ax.add_patch(Circle((0.0, config.landmark_distance_m), config.success_radius_m, fill=False, ls="--", color="k"))
    starts = np.array([path[np.isfinite(path[:, 0])][0] for path in result.timeseries["position_m"]
                       if np.isfinite(path[:, 0]).any()]).reshape(-1, 2)  # each trial's own (jittered) start
    ax.plot(starts[:, 0], starts[:, 1], "k^", ms=6, mfc="none", label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("visual beacon: paths by eye mode")
    ax.legend(loc="lower right")
    return fig


def times_figure(result):
    """Per eye mode: reaching the landmark (each trial at 1 or 0, the proportion with its Wilson 95 %
    interval) and the time to the landmark of the trials that reached it (box plot, every trial, the
    median with its bootstrap 95 % interval)."""
    fig, (ax, rate_ax) = new_figure((9, 4), 1, 2, gridspec_kw={"width_ratios": [1.4, 1]})
    modes = _modes(result)
    present = [m for m in MODES if m in modes]
    proportion_points(rate_ax, {mode: [bool(t["success"]) for t, m in zip(result.trials, modes) if m == mode]
                                for mode in present}, colours=MODE_COLOURS, gid="reached")
    rate_ax.set_ylabel("reached the landmark (1 yes, 0 no)")
    rate_ax.set_title("reaching the landmark")
    rate_ax.legend(loc="best", fontsize=7)
    condition_strip(ax, {mode: [t["time_to_landmark_s"] for t, m in zip(result.trials, modes) if m == mode]
                         for mode in present}, colours=MODE_COLOURS, centre="median", box=True, gid="times")
    ax.set_ylabel("time to the landmark (s)")
    ax.set_title("time to the landmark by eye mode")
    ax.legend(loc="best", fontsize=7)
    return fig


def eye_cameras() -> dict:
    """The ant's binocular cameras (``eye_L``, ``eye_R``) by name, as the scenario's ant carries them."""
    from neuronav.bodies.desert_ant import desert_ant

    return {camera.name: camera for camera in desert_ant().cameras if camera.name in ("eye_L", "eye_R")}


def camera_angle_ticks(camera, steps_deg: tuple[float, float] = (15.0, 10.0)) -> tuple[tuple, dict]:
    """Where a planar camera's image goes and where its angle ticks fall, on its image plane at distance 1.

    Returns the image's extent (left, right, bottom, top: ±tan(fov / 2)), so that with equal aspect one
    unit is the same angle across and up the image's centre, and per axis (``"x"``, ``"y"``) the tick
    positions (tan of the angle) and their labels (the angle from the camera's axis, degrees, every
    ``steps_deg`` across and up).
    """
    half_h, half_v = camera.fov_rad[0] / 2.0, camera.fov_rad[1] / 2.0
    ticks = {}
    for axis, half, step_deg in (("x", half_h, steps_deg[0]), ("y", half_v, steps_deg[1])):
        top_deg = np.floor(np.degrees(half) / step_deg) * step_deg
        angles_deg = np.arange(-top_deg, top_deg + step_deg / 2, step_deg)
        ticks[axis] = (np.tan(np.radians(angles_deg)), [f"{a + 0.0:g}" for a in angles_deg])  # + 0.0: no "-0"
    return (-np.tan(half_h), np.tan(half_h), -np.tan(half_v), np.tan(half_v)), ticks


def first_views_figure(result, config):
    """What the eyes see at the start of the first trial of each mode, dark pixels outlined.

    Each image is drawn undistorted (pixels placed on the camera's image plane, equal aspect), with the
    angle from the eye's axis in degrees on both axes, from the camera's field of view.
    """
    modes = _modes(result)
    shown = [m for m in MODES if m in modes]
    cameras = eye_cameras()
    fig, axes = new_figure((9, 1.2 * max(len(shown), 1) + 0.6), nrows=max(len(shown), 1), ncols=2)
    axes = np.atleast_2d(axes)
    for row, mode in enumerate(shown):
        trial = modes.index(mode)
        for col, name in enumerate(("eye_L", "eye_R")):
            ax, camera = axes[row, col], cameras[name]
            extent, ticks = camera_angle_ticks(camera)
            key = f"first_view_{name}"
            if key in result.timeseries and np.isfinite(result.timeseries[key][trial]).all():
                image = result.timeseries[key][trial]
                ax.imshow(image, cmap="gray", vmin=0.0, vmax=1.0, extent=extent, aspect="equal",
                          interpolation="nearest", gid=f"{mode} {name}")
                dark = image <= config.dark_threshold
                if dark.any():
                    ax.contour(dark.astype(float), levels=[0.5], colors="r", linewidths=0.8, extent=extent,
                               origin="upper")
            ax.set_xlim(extent[0], extent[1])
            ax.set_ylim(extent[2], extent[3])
            ax.set_aspect("equal")
            ax.set_xticks(*ticks["x"], fontsize=7)
            ax.set_yticks(*ticks["y"], fontsize=7)
            if row == len(shown) - 1:
                ax.set_xlabel("angle right of the eye's axis (deg)", fontsize=8)
            if col == 0:
                ax.set_ylabel("up (deg)", fontsize=8)
            used = name in {"left": ("eye_L",), "right": ("eye_R",), "both": ("eye_L", "eye_R")}[mode]
            ax.set_title(f"{mode} mode, trial {trial}: {name}{'' if used else ' (not used)'}", fontsize=8)
    left = cameras["eye_L"]
    fov_deg = np.degrees(left.fov_rad)
    fig.suptitle(f"first views, angles from each eye's axis: planar cameras, {fov_deg[0]:.0f}° × {fov_deg[1]:.0f}° "
                 f"over {left.width_px} × {left.height_px} px; eye_L looks {_axis_text(left)}, eye_R "
                 f"{_axis_text(cameras['eye_R'])} (head frame)", fontsize=8)
    return fig


def _axis_text(camera) -> str:
    """Where a camera looks in its segment's frame (x forward, y left, z up): e.g. ``30° left, 9° up``."""
    from neuronav.spec.body import quat_to_matrix

    look = -quat_to_matrix(camera.quat)[:, 2]
    azimuth_deg = np.degrees(np.arctan2(look[1], look[0]))
    elevation_deg = np.degrees(np.arcsin(np.clip(look[2], -1.0, 1.0)))
    return (f"{abs(azimuth_deg):.0f}° {'left' if azimuth_deg >= 0 else 'right'}, "
            f"{abs(elevation_deg):.1f}° {'up' if elevation_deg >= 0 else 'down'}")
