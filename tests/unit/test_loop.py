"""The agent loop's clocks and hooks, on a stub backend and gait that count what happens."""

import numpy as np
import pytest

from neuronav.engine.loop import AgentLoop, Clocks, Hook
from neuronav.errors import ConfigError


class CountingBackend:
    def __init__(self):
        self.physics_steps, self.writes, self.resets = 0, [], []

    def reset(self, **kwargs):
        self.resets.append(kwargs)

    def write(self, commands):
        self.writes.append(commands["joint_targets"].copy())

    def step(self, n=1):
        self.physics_steps += n


class EchoGait:
    """Targets = (turn, stride), so the test sees which command reached the gait."""

    joint_names = ("a", "b")

    def reset(self):
        self.samples = 0

    def step(self, turn, stride_rad):
        self.samples += 1
        return np.array([turn, stride_rad])


class Log(Hook):
    def __init__(self):
        self.events = []

    def initialize_episode(self, loop):
        self.events.append(("init", loop.control_steps))

    def before_step(self, loop):
        self.events.append(("before", loop.control_steps))

    def after_step(self, loop):
        self.events.append(("after", loop.control_steps))


def test_clocks_run_at_integer_ratios_and_the_brain_sets_the_command():
    backend, gait, log = CountingBackend(), EchoGait(), Log()
    brain_calls = []

    def steering(loop):
        brain_calls.append(loop.control_steps)
        return 0.5 * len(brain_calls), 0.1  # turn clipped to 1 from the second call on

    clocks = Clocks(physics_dt_s=0.002, control_dt_s=0.008, brain_dt_s=0.032)
    loop = AgentLoop(backend, gait, clocks, steering=steering, hooks=[log])
    loop.reset(seed=3)
    loop.run(0.08)  # 10 control steps
    assert backend.resets == [{"seed": 3}]
    assert loop.control_steps == 10 and gait.samples == 10 and backend.physics_steps == 40
    assert brain_calls == [0, 4, 8]
    assert [w[0, 0] for w in backend.writes] == [0.5] * 4 + [1.0] * 6
    assert log.events[:3] == [("init", 0), ("before", 0), ("after", 1)]
    assert loop.time_s == pytest.approx(0.08)


def test_run_stops_early_when_asked():
    loop = AgentLoop(CountingBackend(), EchoGait(), Clocks())
    loop.reset()
    loop.run(1.0, until=lambda lp: lp.control_steps == 3)
    assert loop.control_steps == 3


@pytest.mark.parametrize("periods", [(0.002, 0.007, 0.64), (0.002, 0.008, 0.1), (0.0, 0.008, 0.64)])
def test_non_integer_clock_ratios_are_refused(periods):
    with pytest.raises(ConfigError, match="multiple|positive"):
        Clocks(*periods)


@pytest.mark.parametrize("periods", [(1e-300, 0.008, 0.64), (0.002, 0.008, 1e10), (float("nan"), 0.008, 0.64),
                                     (0.002, float("inf"), 0.64)])
def test_clocks_that_would_hang_the_loop_are_refused(periods):
    with pytest.raises(ConfigError, match="at most|finite"):
        Clocks(*periods)


def test_video_plays_in_real_time_whatever_the_control_step():
    from neuronav.engine.video import real_time_fps

    assert real_time_fps(0.008, 4) == pytest.approx(31.25)
    assert real_time_fps(0.008, 8) * 8 * 0.008 == pytest.approx(1.0)  # one frame per its share of a second
    assert real_time_fps(0.02, 1) == pytest.approx(50.0)


def test_follow_camera_axes_on_the_floor_and_on_a_wall():
    from neuronav.engine.video import follow_axes
    from neuronav.spec.body import quat_to_matrix

    # On the floor, pitched 10° nose-up and turned 90° left: follow the heading, keep the world's up.
    pitched = quat_to_matrix((np.cos(0.5 * np.radians(10)), 0.0, -np.sin(0.5 * np.radians(10)), 0.0))
    turned = quat_to_matrix((np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4))) @ pitched
    forward, up = follow_axes(turned)
    np.testing.assert_allclose(forward, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(up, [0, 0, 1])
    # Head up on a wall at +x: follow in the body's frame (forward up the wall, up away from it).
    on_wall = quat_to_matrix((np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0))
    forward, up = follow_axes(on_wall)
    np.testing.assert_allclose(forward, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(up, [-1, 0, 0], atol=1e-12)
