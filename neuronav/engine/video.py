"""Video: film a backend camera from the agent loop into an MP4 that plays in real time.

:class:`VideoRecorder` grabs a camera (by default the backends' ``"follow"`` camera, framed by
:func:`neuronav.engine.articulated.follow_view`) every ``every`` control steps and streams each frame to the
file (memory stays flat however long the trial). The file's frame rate is ``1 / (every *
control_dt_s)``: one second of the video is one second of simulated time (31.25 frames per second
for the 8 ms gait step and ``every=4``). A run of N control steps gives ``ceil(N / every)`` frames
(``duration_s * fps`` when N is a multiple of ``every``), the first taken after the first control step.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.engine.articulated import follow_axes  # noqa: F401 - the follow camera's axes, re-exported
from neuronav.engine.loop import AgentLoop, Hook
from neuronav.errors import ConfigError

# Frames per control step: every 4th 8 ms step, 31.25 frames per second of simulated time.
DEFAULT_EVERY = 4


def real_time_fps(control_dt_s: float, every: int) -> float:
    """The frame rate at which frames taken every ``every`` control steps of ``control_dt_s`` play in real time."""
    return 1.0 / (int(every) * float(control_dt_s))


class VideoRecorder(Hook):
    """Streams ``camera`` every ``every`` control steps into the MP4 ``path``, at real-time speed.

    The file is written under a temporary name and moved to ``path`` by :meth:`close` (call it once
    the episode is over; a recorder is also a context manager). ``frames`` counts what was written.
    """

    def __init__(self, path: Path, camera: str = "follow", every: int = DEFAULT_EVERY) -> None:
        if not (isinstance(every, int) and every >= 1):
            raise ConfigError(f"video: every must be an int >= 1 control steps, got {every!r}")
        self.path, self.camera, self.every = Path(path), camera, every
        self.frames = 0
        self.fps: float | None = None
        self._writer = None

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.fps = real_time_fps(loop.clocks.control_dt_s, self.every)

    def after_step(self, loop: AgentLoop) -> None:
        if (loop.control_steps - 1) % self.every:
            return
        frame = loop.backend.render(self.camera)
        if self._writer is None:
            import imageio.v2 as imageio

            self.path.parent.mkdir(parents=True, exist_ok=True)
            fps = self.fps or real_time_fps(loop.clocks.control_dt_s, self.every)
            self._writer = imageio.get_writer(self._partial, fps=fps, codec="libx264", quality=7,
                                              macro_block_size=8)
        self._writer.append_data(frame)
        self.frames += 1

    @property
    def _partial(self) -> Path:
        return self.path.with_suffix(".partial.mp4")

    def close(self) -> None:
        """Finish the file and give it its name (nothing is written when no frame was taken)."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
            self._partial.replace(self.path)

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class CameraRecorder(Hook):
    """Grabs ``camera`` every ``every`` control steps into :attr:`frames` (in memory; see :class:`VideoRecorder`)."""

    def __init__(self, camera: str = "follow", every: int = DEFAULT_EVERY) -> None:
        self.camera, self.every = camera, int(every)
        self.frames: list[np.ndarray] = []

    def after_step(self, loop: AgentLoop) -> None:
        if (loop.control_steps - 1) % self.every == 0:
            self.frames.append(loop.backend.render(self.camera))


def write_video(path: Path, frames: list[np.ndarray], fps: float) -> None:
    """Write RGB frames (H, W, 3) uint8 to an MP4 with imageio's ffmpeg plugin (through a temporary name)."""
    import imageio.v2 as imageio

    if not frames:
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".partial.mp4")
    with imageio.get_writer(temporary, fps=fps, codec="libx264", quality=7, macro_block_size=8) as writer:
        for frame in frames:
            writer.append_data(frame)
    temporary.replace(path)
