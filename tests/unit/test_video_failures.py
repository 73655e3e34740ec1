"""A video that fails stops, not its trial (:class:`neuronav.engine.video.VideoFile`): the trial keeps its results,
what was filmed stays in ``*.partial.mp4``, why is written beside it (``*.video-error.txt``), in ``summary.json``'s
``video_error`` and on stderr, and ``neuronav run`` exits 1."""

from __future__ import annotations

import csv
import json
from types import SimpleNamespace

import numpy as np
import pytest

from neuronav.engine import video
from neuronav.engine.video import FrameWriter, VideoRecorder, join_filmed_parts, video_failure, video_failure_path
from neuronav.runs.cli import main

imageio = pytest.importorskip("imageio.v2")


class Camera:
    """A backend whose follow camera draws grey frames and, from ``broken_from`` on, fails as ``failure`` says."""

    def __init__(self, broken_from: int, failure: str) -> None:
        self.drawn, self.broken_from, self.failure = 0, broken_from, failure

    def render(self, camera: str) -> np.ndarray:
        self.drawn += 1
        if self.drawn >= self.broken_from and self.failure == "raise":
            raise RuntimeError("the camera broke")
        if self.drawn >= self.broken_from:  # a frame of another size: imageio refuses it on the writer's thread
            return np.full((24, 32, 3), 90, np.uint8)
        return np.full((48, 64, 3), 90, np.uint8)


def _film(path, camera: Camera, steps: int = 8) -> VideoRecorder:
    loop = SimpleNamespace(backend=camera, clocks=SimpleNamespace(control_dt_s=0.008), control_steps=0, time_s=0.0)
    recorder = VideoRecorder(path, every=1)
    recorder.initialize_episode(loop)
    for step in range(1, steps + 1):
        loop.control_steps, loop.time_s = step, 0.008 * step
        recorder.after_step(loop)  # never raises: the trial goes on
    recorder.close(finished=True)
    return recorder


@pytest.mark.parametrize("failure", ["raise", "encoder"])
def test_a_frame_that_fails_stops_the_video_and_not_the_trial(tmp_path, failure):
    path = tmp_path / "trial0.mp4"
    camera = Camera(broken_from=4, failure=failure)
    recorder = _film(path, camera)
    assert not path.exists()
    with imageio.get_reader(path.with_suffix(".partial.mp4")) as reader:
        assert len([frame for frame in reader]) == 3  # the frames before the failure
    reason = video_failure(path)
    assert reason == recorder.error and "trial0.partial.mp4" in reason
    assert ("RuntimeError: the camera broke" in reason) if failure == "raise" else ("ValueError" in reason)
    if failure == "raise":  # filming stopped at the failure (the encoder's surfaces later: its thread is behind)
        assert camera.drawn == 4


def test_a_new_recording_forgets_an_earlier_failure(tmp_path):
    path = tmp_path / "trial0.mp4"
    _film(path, Camera(broken_from=2, failure="raise"))
    assert video_failure(path)
    recorder = _film(path, Camera(broken_from=100, failure="raise"))
    assert recorder.error is None and video_failure(path) == "" and path.exists()


def test_parts_of_a_failed_leg_are_not_joined(tmp_path):
    parts = [tmp_path / "trial0.outbound.partial.mp4", tmp_path / "trial0.homeward.partial.mp4"]
    for part in parts:
        writer = FrameWriter(part, 10.0)
        writer.append(np.zeros((48, 64, 3), np.uint8))
        writer.close()
    video.note_video_failure(parts[0], "trial0.outbound.partial.mp4 stopped: OSError: disk full")
    join_filmed_parts(parts, tmp_path / "trial0.mp4")
    assert not (tmp_path / "trial0.mp4").exists()
    assert "disk full" in video_failure(tmp_path / "trial0.mp4")
    assert all(part.exists() and not video_failure_path(part).exists() for part in parts)
    # parts that were all filmed (the trip filmed again) are joined, the earlier failure's note goes with the parts
    join_filmed_parts(parts, tmp_path / "trial0.mp4")
    with imageio.get_reader(tmp_path / "trial0.mp4") as reader:
        assert len([frame for frame in reader]) == 2
    assert not any(part.exists() for part in parts) and video_failure(tmp_path / "trial0.mp4") == ""


def test_a_swarm_film_that_fails_stops_the_film_and_not_the_swarm(tmp_path, monkeypatch):
    from neuronav.scenarios.swarm_homing.film import SwarmFilm
    from neuronav.scenarios.swarm_homing.scenario import SWARM_WORLD, home_positions

    appended = []

    def append(self, frame):
        if len(appended) == 2:
            raise OSError(28, "No space left on device")
        appended.append(frame)

    monkeypatch.setattr(FrameWriter, "append", append)
    homes = home_positions(3, 1.0)
    film = SwarmFilm(tmp_path / "trial0.mp4", SWARM_WORLD, homes, 0.3, 0.008, 8)
    for k in range(5):
        film.film(homes + 0.1 * k, np.zeros(3), np.full(3, np.inf), False, 0.064 * k)
    film.close(finished=True)
    assert len(appended) == 2 and film.frames == 2
    assert "No space left on device" in video_failure(tmp_path / "trial0.mp4")
    assert not (tmp_path / "trial0.mp4").exists()


def test_a_run_whose_video_fails_keeps_its_trials_and_exits_1(tmp_path, monkeypatch, capsys):
    settings = ["plume-tracking", "--backend", "kinematic", "--trials", "2", "--set", "timeout_s=1.28"]
    assert main(["run", *settings, "--out", str(tmp_path / "plain")]) == 0
    appended = []

    def full_disk(self, make_frame):
        if len(appended) == 3:
            raise OSError(28, "No space left on device")
        appended.append(make_frame)
        self._queue.put(make_frame)

    monkeypatch.setattr(FrameWriter, "append_later", full_disk)
    monkeypatch.setattr(FrameWriter, "append", full_disk)
    out = tmp_path / "filmed"
    capsys.readouterr()
    assert main(["run", *settings, "--video", "--out", str(out)]) == 1
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and "video failed" in said[0] and "No space left on device" in said[0], said
    assert "after 3 frames" in json.loads((out / "summary.json").read_text())["video_error"]
    assert (out / "trial0.video-error.txt").exists() and (out / "trial0.partial.mp4").exists()
    assert not (out / "trial0.mp4").exists()

    def rows(folder):
        with open(folder / "trials.csv") as handle:
            timing = ("real_time_factor", "wall_s")
            return [{k: v for k, v in row.items() if not k.endswith(timing)} for row in csv.DictReader(handle)]

    assert rows(out) == rows(tmp_path / "plain")  # both trials ran, as without video


def test_video_asked_of_a_finished_run_says_why_none_is_made(tmp_path, capsys):
    settings = ["plume-tracking", "--backend", "kinematic", "--trials", "2", "--set", "timeout_s=0.64",
                "--out", str(tmp_path / "run")]
    assert main(["run", *settings]) == 0
    capsys.readouterr()
    assert main(["run", *settings, "--video"]) == 0  # nothing left to run: the results stand
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and "trial 0 already ran" in said[0] and "new folder" in said[0], said
    assert not (tmp_path / "run" / "trial0.mp4").exists()
    # a filmed run resumed with --video again says nothing: its video is there
    filmed = [*settings[:-1], str(tmp_path / "filmed"), "--video"]
    assert main(["run", *filmed]) == 0 and (tmp_path / "filmed" / "trial0.mp4").exists()
    capsys.readouterr()
    assert main(["run", *filmed]) == 0
    assert "warning" not in capsys.readouterr().err
