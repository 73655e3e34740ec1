"""One embodied trial, and trials one after another: what the closed-loop scenarios share.

A physics engine simulates one body, so the embodied scenarios (embodied homing, the visual beacon,
the visual compass) run their trials one after another, each on its own engine: load the world and
the body, start at the origin facing a heading, run the agent loop until done, film the first
trial if asked.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

from neuronav.engine.loop import AgentLoop, Clocks, Hook
from neuronav.engine.video import VideoRecorder
from neuronav.engine.video_overlay import VideoContent, VideoOverlay

# Video: one frame of the follow camera every this many control steps (0.064 s at 8 ms), played in
# real time (15.6 frames per second), streamed to the file.
VIDEO_EVERY = 8


def run_loop(engine, world, body, gait, clocks: Clocks, steering, *, heading_rad: float, seed: int,
             duration_s: float, until: Callable[[AgentLoop], bool] | None = None, hooks: Sequence[Hook] = (),
             video_path=None, position_m: tuple[float, float] = (0.0, 0.0),
             video_content: VideoContent | None = None) -> tuple[AgentLoop, np.ndarray, float]:
    """Load ``world`` and ``body`` into ``engine``, start at ``position_m`` (the origin by default)
    facing ``heading_rad`` (clockwise from +y) and run for ``duration_s`` or until ``until(loop)``.
    With ``video_path`` the follow camera films it, with ``video_content`` drawn over (and always the
    world's plume, the path and the objects out of view: :mod:`neuronav.engine.video_overlay`).

    Returns
    -------
    loop : AgentLoop
        The loop after the run (its time, the brain's state through ``steering``).
    final_position_m : ndarray, shape (2,)
    wall_s : float
        Wall time of loading and running.
    """
    started = time.perf_counter()
    with engine:
        engine.load(world, [body])
        video = (VideoRecorder(video_path, "follow", every=VIDEO_EVERY, compose=VideoOverlay(video_content))
                 if video_path is not None else None)
        loop = AgentLoop(engine, gait, clocks, steering=steering, hooks=[*hooks, *([video] if video else [])])
        loop.reset(seed=seed, position_m=tuple(position_m), yaw_rad=np.pi / 2 - heading_rad)
        finished = False
        try:
            loop.run(duration_s, until=until)
            finished = True
        finally:
            if video is not None:
                video.close(finished)  # a trial stopped or failed keeps its video under the temporary name
        final = engine.read(("position",))["position"][0]
    return loop, final, time.perf_counter() - started


def trials_one_by_one(trial: Callable, trials: int, seed: int, video_path=None) -> tuple[list[dict], list]:
    """Run ``trial(seed, video_path)`` for seeds ``seed`` .. ``seed + trials - 1`` (only the first filmed).

    Returns the metric rows (with ``trial`` and ``seed`` added) and the trials' logs.
    """
    rows, logs = [], []
    for i in range(trials):
        row, log = trial(seed + i, video_path if i == 0 else None)
        rows.append(dict(row, trial=i, seed=seed + i))
        logs.append(log)
    return rows, logs


def pack_cycle_logs(logs: list[dict], keys: Sequence[str]) -> dict[str, np.ndarray]:
    """Per-cycle logs of unequal length as NaN-padded arrays: each of ``keys`` (trials, cycles) and
    ``position_m`` (trials, cycles + 1, 2) (the final position after the last cycle)."""
    cycles = max(len(log["time_s"]) for log in logs)
    packed = {}
    for key in keys:
        packed[key] = np.full((len(logs), cycles), np.nan)
        for i, log in enumerate(logs):
            packed[key][i, : len(log[key])] = log[key]
    packed["position_m"] = np.full((len(logs), cycles + 1, 2), np.nan)
    for i, log in enumerate(logs):
        packed["position_m"][i, : len(log["position_m"])] = log["position_m"]
    return packed
