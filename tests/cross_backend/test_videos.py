"""Videos from ``--video`` on both physics engines: they play in real time and show a moving scene.

For each video: the MP4 read back with imageio has ``duration × fps`` frames (one second of video is
one second of simulated time), every frame shows something (pixel standard deviation above a
floor, the checker floor and the ant), and the frames change over time (the ant walks, the follow
camera moves over the checker floor).
"""

import numpy as np
import pytest

from neuronav.runs.cli import main

imageio = pytest.importorskip("imageio.v2")

MIN_PIXEL_STD = 10.0  # a blank or one-colour frame has about 0
MIN_CHANGE = 2.0  # mean absolute difference (0-255) between the first and the last frame


def require(name):
    pytest.importorskip(name, reason=f"{name} is not installed")


def read_video(out):
    videos = list(out.rglob("*.mp4"))
    assert len(videos) == 1, videos
    with imageio.get_reader(videos[0]) as reader:
        fps = reader.get_meta_data()["fps"]
        frames = [np.asarray(frame) for frame in reader]
    return fps, frames


def check_video(out, simulated_s: float, expected_fps: float) -> None:
    fps, frames = read_video(out)
    assert fps == pytest.approx(expected_fps, rel=0.01)
    assert len(frames) == round(simulated_s * fps), (len(frames), simulated_s, fps)  # real time
    assert frames[0].shape == (480, 640, 3)
    stds = [frame.std() for frame in frames]
    assert min(stds) > MIN_PIXEL_STD, stds
    change = np.abs(frames[-1].astype(float) - frames[0].astype(float)).mean()
    assert change > MIN_CHANGE, change


@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_locomotion_video_plays_in_real_time_and_shows_the_walk(tmp_path, backend):
    require(backend)
    out = tmp_path / "run"
    # 0.512 s = 64 gait steps of 8 ms; a frame every 4 of them: 16 frames at 31.25 fps.
    assert main(["run", "locomotion", "--backend", backend, "--set", "duration_s=0.512", "--video",
                 "--out", str(out)]) == 0
    check_video(out, 0.512, 31.25)


def test_embodied_homing_video_plays_in_real_time(tmp_path):
    require("mujoco")
    out = tmp_path / "run"
    # 1.28 s out and 1.28 s homing (a 1 cm nest: the trial runs to the timeout) = 320 control steps;
    # a frame every 8 of them: 40 frames at 15.625 fps.
    settings = ["protocol=i2bot", "outbound_s=1.28", "homing_timeout_s=1.28", "nest_radius_m=0.01"]
    command = ["run", "path-integration", "--backend", "mujoco", "--trials", "1", "--video", "--out", str(out)]
    for setting in settings:
        command += ["--set", setting]
    # A 1 cm nest is rarely reached, but a trial that does not reach it still ran: exit 0 (1 is a trial that raised).
    assert main(command) == 0
    check_video(out, 2.56, 15.625)


@pytest.mark.parametrize("backend", ["kinematic", "mujoco", "pybullet"])
def test_swarm_video_plays_in_real_time_on_every_backend(tmp_path, backend):
    """The swarm's video (drawn from above: the swarm backends have no cameras): 6.4 s = 800 control steps, a frame
    every 8 of them: 100 frames at 15.625 fps, the ants moving."""
    if backend != "kinematic":
        require(backend)
    out = tmp_path / "run"
    assert main(["run", "swarm-homing", "--backend", backend, "--trials", "3", "--set", "ants=3", "--set",
                 "outbound_s=3.2", "--set", "homing_timeout_s=3.2", "--video", "--no-figures", "--out", str(out)]) == 0
    check_video(out, 6.4, 15.625)


@pytest.mark.parametrize("backend", ["kinematic", "mujoco"])
def test_odometer_video_films_both_legs(tmp_path, backend):
    """The odometer's trial is two legs on two engines (normal legs out, manipulated legs home): its video holds both,
    one after the other (as long as the trial, within a frame per leg)."""
    import csv

    if backend != "kinematic":
        require(backend)
    out = tmp_path / "run"
    assert main(["run", "odometer", "--backend", backend, "--trials", "1", "--set", "channel_m=1",
                 "--set", "legs=stilts", "--video", "--no-figures", "--out", str(out)]) == 0
    fps, frames = read_video(out)
    trial_s = float(next(csv.DictReader((out / "trials.csv").open()))["trial_time_s"])
    assert abs(len(frames) / fps - trial_s) <= 2.0 / fps, (len(frames), fps, trial_s)
    assert sorted(p.name for p in out.glob("*.mp4")) == ["trial0.mp4"]  # the legs' parts joined and gone
