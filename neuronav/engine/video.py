"""Video: film a backend camera from the agent loop into an MP4 that plays in real time.

:class:`VideoRecorder` grabs a camera (by default the backends' ``"follow"`` camera, framed by
:func:`neuronav.engine.articulated.follow_view`) every ``every`` control steps and streams each frame to the
file (memory stays flat however long the trial; :class:`FrameWriter` draws and encodes on a thread of its own,
beside the loop: see :class:`VideoRecorder`). The file's frame rate is ``1 / (every * control_dt_s)``: one
second of the video is one second of simulated time (31.25 frames per second for the 8 ms gait step and
``every=4``). A run of N control steps gives ``ceil(N / every)`` frames (``duration_s * fps`` when N is a
multiple of ``every``), the first taken after the first control step.
"""

from __future__ import annotations

import queue
import subprocess
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from functools import partial
from pathlib import Path

import numpy as np

from neuronav.engine.articulated import follow_axes  # noqa: F401 - the follow camera's axes, re-exported
from neuronav.engine.loop import AgentLoop, Hook
from neuronav.errors import ConfigError, SimulationError

# Frames per control step: every 4th 8 ms step, 31.25 frames per second of simulated time.
DEFAULT_EVERY = 4
# The MP4s' encoding (imageio's ffmpeg writer): H.264 at quality 7 of 10 (crf 15), x264's "ultrafast" preset on one
# thread: the encoder shares the machine's second core with the follow view's rasteriser (benchmarks/video_cost.py).
# Re-encoding one filmed trial's 125 frames of 640 x 480 took 0.54 s of the encoder's CPU at "veryfast" (386 kB),
# 0.41 s at "superfast" (802 kB) and 0.25 s at "ultrafast" on one thread (1143 kB): files 3x larger, still
# about 140 kB per second of video.
ENCODER = {"codec": "libx264", "quality": 7, "macro_block_size": 8,
           "ffmpeg_params": ["-preset", "ultrafast", "-threads", "1"]}
# Frames a FrameWriter holds for its thread before append waits (a 640 x 480 frame is 0.9 MB): room for the
# writer to fall behind the loop for a while and catch up later, rather than stall it (8 waited more).
QUEUED_FRAMES = 16
# Whether a VideoRecorder draws its frames beside the loop, on its writer's thread (see VideoRecorder).
DRAW_BESIDE_LOOP = True


def real_time_fps(control_dt_s: float, every: int) -> float:
    """The frame rate at which frames taken every ``every`` control steps of ``control_dt_s`` play in real time."""
    return 1.0 / (int(every) * float(control_dt_s))


class FrameWriter:
    """An MP4 at ``path`` (RGB uint8 frames, ``fps``) encoded while the caller goes on: :meth:`append` hands
    each frame to a thread of this writer, which converts it and pipes it to imageio's ffmpeg encoder (a
    process of its own: on a machine with two cores, the trial, the pipe and the encoder each get one).

    At most :data:`QUEUED_FRAMES` frames wait; :meth:`close` writes them all and ends the file. An error
    of the encoder is raised by the next :meth:`append` or by :meth:`close`.
    """

    def __init__(self, path: Path, fps: float) -> None:
        import imageio.v2 as imageio

        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = imageio.get_writer(self.path, fps=fps, **ENCODER)
        self._queue: queue.Queue = queue.Queue(maxsize=QUEUED_FRAMES)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._encode, name=f"video writer {self.path.name}", daemon=True)
        self._thread.start()

    def _encode(self) -> None:
        while (frame := self._queue.get()) is not None:
            if self._error is None:  # after an error, frames are only drained (append raises it)
                try:
                    self._writer.append_data(frame() if callable(frame) else frame)
                except BaseException as error:  # noqa: BLE001 -- handed to the caller's thread
                    self._error = error

    def append(self, frame: np.ndarray) -> None:
        """Queue one frame (kept as it is: a frame that is a view of a buffer the caller reuses is copied)."""
        if self._error is not None:
            raise self._error
        frame = np.asarray(frame)
        self._queue.put(frame if frame.flags.owndata else frame.copy())

    def append_later(self, make_frame: Callable[[], np.ndarray]) -> None:
        """Queue a frame that this writer's thread makes (``make_frame()``, called in the order queued) before it
        encodes it: the caller need not wait for its drawing."""
        if self._error is not None:
            raise self._error
        self._queue.put(make_frame)

    def close(self) -> None:
        """Write the queued frames and end the file (the encoder's error, if any, is raised here)."""
        if self._thread is None:
            return
        self._queue.put(None)
        self._thread.join()
        self._thread = None
        self._writer.close()
        if self._error is not None:
            raise self._error


class VideoFile:
    """An MP4 ``path`` written under the temporary ``*.partial.mp4`` (a :class:`FrameWriter` opened on the first
    frame) and given its name by :meth:`close` once the trial finished. A failure to take, draw or encode a frame
    stops the video, not the trial (:meth:`_give_up`): what was written stays in the partial file, :attr:`error`
    and :func:`video_failure_path` say why, and the trial keeps its results.

    Attributes
    ----------
    path : Path
    frames : int
        Frames written.
    error : str or None
        Why filming stopped, None while it goes well.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        video_failure_path(self.path).unlink(missing_ok=True)  # an earlier attempt's note is not this one's
        self.frames = 0
        self.error: str | None = None
        self._writer: FrameWriter | None = None

    @property
    def _partial(self) -> Path:
        return self.path.with_suffix(".partial.mp4")

    def close(self, finished: bool = True) -> None:
        """Finish the file and give it its name (nothing is written when no frame was taken); a trial that did not
        finish (``finished`` False: stopped or failed) leaves its video under the temporary ``*.partial.mp4``,
        which reports leave out. A video that failed (:attr:`error`) stays there too."""
        writer, self._writer = self._writer, None
        if writer is None:
            return
        try:
            writer.close()
            if finished:
                self._partial.replace(self.path)
        except Exception as error:  # noqa: BLE001 -- the trial's results stand without their video
            self._give_up(error, None)

    def _give_up(self, error: Exception, time_s: float | None) -> None:
        """Stop filming after ``error`` (the frames written so far stay in ``*.partial.mp4``) and say why in
        :func:`video_failure_path`: the trial goes on and keeps its results."""
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.close()
            except Exception:  # noqa: BLE001 -- the first error is the one to tell
                pass
        when = f" at {time_s:.2f} s of the trial" if time_s is not None else " while finishing the file"
        self.error = (f"{self.path.name} stopped{when} after {self.frames} frames "
                      f"(kept as {self._partial.name}): {type(error).__name__}: {error}")
        note_video_failure(self.path, self.error)


class VideoRecorder(Hook, VideoFile):
    """Streams ``camera`` every ``every`` control steps into the MP4 ``path``, at real-time speed.

    The file is written under a temporary name and moved to ``path`` by :meth:`close` (call it once
    the episode is over; a recorder is also a context manager). ``frames`` counts what was written; a video that
    fails stops, the trial goes on (:class:`VideoFile`).
    ``compose(frame, loop) -> frame``, when given, draws on each frame before it is written (what the
    experiment shows: :class:`neuronav.engine.video_overlay.VideoOverlay`).

    Beside the loop (``background``, by default :data:`DRAW_BESIDE_LOOP`): where ``compose`` can take what it
    draws now and draw it later (``compose.prepare(loop) -> (draw, again)``, ``draw(frame) -> frame``; ``again``:
    the camera moved, take the frame again), the loop only takes the frame and what is drawn on it, and the
    writer's thread draws; where the backend draws frames in the background too (``render_later(camera)``
    returning a ``concurrent.futures.Future``: MuJoCo's follow view, rasterised on a GL thread), the loop only
    starts the frame. The same frames as drawing them in the loop (``background=False``).
    """

    def __init__(self, path: Path, camera: str = "follow", every: int = DEFAULT_EVERY,
                 compose: Callable[[np.ndarray, AgentLoop], np.ndarray] | None = None,
                 background: bool | None = None) -> None:
        if not (isinstance(every, int) and every >= 1):
            raise ConfigError(f"video: every must be an int >= 1 control steps, got {every!r}")
        VideoFile.__init__(self, path)
        self.camera, self.every, self.compose = camera, every, compose
        self.background = DRAW_BESIDE_LOOP if background is None else bool(background)
        self.fps: float | None = None

    def initialize_episode(self, loop: AgentLoop) -> None:
        self.fps = real_time_fps(loop.clocks.control_dt_s, self.every)

    def after_step(self, loop: AgentLoop) -> None:
        if self.error is not None or (loop.control_steps - 1) % self.every:
            return
        try:
            self._film(loop)
        except Exception as error:  # noqa: BLE001 -- the trial goes on unfilmed; why is written beside the video
            self._give_up(error, getattr(loop, "time_s", None))

    def _film(self, loop: AgentLoop) -> None:
        """Take this step's frame (drawn and encoded beside the loop where it can be)."""
        if self._writer is None:
            self._writer = FrameWriter(self._partial, self.fps or real_time_fps(loop.clocks.control_dt_s, self.every))
        prepare = getattr(self.compose, "prepare", None)
        if self.background and (self.compose is None or prepare is not None):
            later = getattr(loop.backend, "render_later", None) or partial(_rendered, loop.backend)
            frame, draw = later(self.camera), None
            if prepare is not None:
                draw, again = prepare(loop)
                frame = later(self.camera) if again else frame
            self._writer.append_later(partial(_finish, frame, draw))
        else:
            frame = loop.backend.render(self.camera)
            frame = self.compose(frame, loop) if self.compose is not None else frame
            self._writer.append(frame)
        self.frames += 1

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, kind, *exc: object) -> None:
        self.close(finished=kind is None)


def join_filmed_parts(parts: Sequence[Path], path: Path) -> None:
    """The filmed parts (each a :class:`VideoRecorder`'s ``path``) joined into ``path`` (:func:`join_videos`);
    when a part's video failed, or the joining does, ``path`` is not written and :func:`video_failure_path` of it
    says why (the parts stay as they were written): the trial keeps its results."""
    video_failure_path(path).unlink(missing_ok=True)  # an earlier attempt's note is not this one's
    failed = [reason for reason in map(video_failure, parts) if reason]
    for part in parts:
        video_failure_path(part).unlink(missing_ok=True)
    if failed:
        note_video_failure(path, failed[0])
        return
    try:
        join_videos(parts, path)
    except Exception as error:  # noqa: BLE001 -- the trial's results stand without their video
        note_video_failure(path, f"{Path(path).name}: joining {len(parts)} parts failed: {error}")


def video_failure_path(path: Path) -> Path:
    """Where a video that failed says why: ``trial0.mp4`` -> ``trial0.video-error.txt`` (one line), read back by
    the run (:func:`video_failure`), which keeps the trial's results and exits 1."""
    return Path(path).with_suffix(".video-error.txt")


def note_video_failure(path: Path, reason: str) -> None:
    """Write ``reason`` (one line) to :func:`video_failure_path` of ``path`` (best effort: a full disk may be why)."""
    try:
        video_failure_path(path).write_text(" ".join(str(reason).split()) + "\n")
    except OSError:
        pass


def video_failure(path: Path) -> str:
    """Why the video ``path`` failed ("" when it did not, or was not asked for)."""
    try:
        return video_failure_path(path).read_text().strip()
    except OSError:
        return ""


def _rendered(backend, camera: str) -> Future:
    """``backend.render(camera)`` now, as a finished future (a backend that cannot draw in the background)."""
    future: Future = Future()
    future.set_result(backend.render(camera))
    return future


def _finish(frame: Future, draw: Callable[[np.ndarray], np.ndarray] | None) -> np.ndarray:
    """A frame started in the background, waited for and drawn on (on the writer's thread)."""
    image = frame.result()
    return draw(image) if draw is not None else image


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
    with imageio.get_writer(temporary, fps=fps, **ENCODER) as writer:
        for frame in frames:
            writer.append_data(frame)
    temporary.replace(path)


def join_videos(parts: Sequence[Path], path: Path) -> None:
    """The MP4s ``parts`` played one after the other in the MP4 ``path``, without encoding them again (ffmpeg's
    concat demuxer: the parts must share their size, frame rate and encoding, as this module's writers' do).
    Parts that were not written are skipped; the parts are removed.

    Raises
    ------
    SimulationError
        ffmpeg could not join them (its message).
    """
    import imageio_ffmpeg

    path = Path(path)
    written = [Path(part) for part in parts if Path(part).exists()]
    listing, temporary = path.with_suffix(".parts.txt"), path.with_suffix(".partial.mp4")
    try:
        if len(written) == 1:
            written[0].replace(path)
        elif written:
            # The concat demuxer's list: one quoted path a line (a quote inside a path closed, escaped, reopened).
            listing.write_text("".join("file '{}'\n".format(str(part.resolve()).replace("'", "'\\''"))
                                       for part in written))
            command = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "concat", "-safe", "0",
                       "-i", str(listing), "-c", "copy", str(temporary)]
            done = subprocess.run(command, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                said = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit {done.returncode}"
                raise SimulationError(f"video: ffmpeg could not join {len(written)} parts into {path.name}: {said}")
            temporary.replace(path)
    finally:
        for leftover in (listing, temporary, *written):
            leftover.unlink(missing_ok=True)
