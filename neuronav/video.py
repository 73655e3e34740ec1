"""Video: grab a backend camera from the agent loop and write the frames to an MP4."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.articulated import follow_axes  # noqa: F401 - the follow camera's axes, re-exported
from neuronav.loop import AgentLoop, Hook


class CameraRecorder(Hook):
    """Grabs ``camera`` (e.g. the backends' ``follow`` camera) every ``every`` control steps."""

    def __init__(self, camera: str = "follow", every: int = 4) -> None:
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
