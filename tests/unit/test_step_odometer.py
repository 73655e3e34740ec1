"""The step odometer (bodies/step_odometer.py) without a physics engine.

Synthetic walks: the body moves by a known amount each update, the stance feet stay put on the
ground, and the joint angles that put each claw where it is come from the IK of
:func:`neuronav.bodies.gaits.leg_ik` (exact where the foot is reachable): the odometer must read the
body's motion back from those angles and the loads alone.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from neuronav.bodies.desert_ant import LEGS, desert_ant, leg_geometry
from neuronav.bodies.desert_ant.unicycle import unicycle_calibration
from neuronav.bodies.gaits import TRIPOD_A, foot_position, leg_ik
from neuronav.bodies.step_odometer import (
    StepOdometer,
    UnicycleStrideOdometer,
    rigid_motion_2d,
    stride_odometer_distance,
)
from neuronav.errors import ConfigError

LOAD_N = 40.0


@pytest.fixture(scope="module")
def ant():
    return desert_ant()


def rest_feet(body) -> np.ndarray:
    geometry = leg_geometry(body)
    return np.array([foot_position(body, leg, geometry[leg]["rest_rad"]) for leg in LEGS])


def joints_for(body, feet_m: np.ndarray) -> np.ndarray:
    """The joint vector (J,) putting each claw at ``feet_m`` (6, 3), body frame (other joints at rest)."""
    geometry = leg_geometry(body)
    index = {name: i for i, name in enumerate(body.joint_names)}
    joints = body.rest_pose_rad()
    for leg, foot in zip(LEGS, feet_m):
        alpha, beta, gamma = leg_ik(geometry[leg], foot)
        names = geometry[leg]["joints"]
        joints[index[names[0]]], joints[index[names[2]]], joints[index[names[3]]] = alpha, beta, gamma
    return joints


def forces(stance) -> np.ndarray:
    """contact_force (8, 3): ``LOAD_N`` up on each claw in stance, nothing on the antenna tips."""
    out = np.zeros((8, 3))
    out[:6, 2] = np.where(stance, LOAD_N, 0.0)
    return out


def to_body(world_xy: np.ndarray, pose) -> np.ndarray:
    """World (x, y) points in the frame of a body at ``pose`` = (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    d = world_xy - (x, y)
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def planted_walk(body, poses, stance=(True,) * 6):
    """Joint vectors of a body moving through ``poses`` (x, y, yaw) with the stance feet planted
    where they stood at the first pose (world frame = the first body frame)."""
    feet = rest_feet(body)
    world = feet[:, :2].copy()
    vectors = []
    for pose in poses:
        now = feet.copy()
        now[:, :2] = to_body(world, pose)
        vectors.append(joints_for(body, now))
    return vectors, np.array(stance)


def test_feet_follow_the_bodys_forward_kinematics(ant):
    rng = np.random.default_rng(3)
    for body in (ant, desert_ant(leg_length_factors=1.3), desert_ant(leg_segment_factors={"tibia": 0.5})):
        odometer = StepOdometer(body)
        for _ in range(5):
            joints = body.rest_pose_rad() + rng.normal(0.0, 0.4, len(body.joint_names))
            expected = np.array([foot_position(body, leg, joints) for leg in LEGS])
            np.testing.assert_allclose(odometer.feet_m(joints), expected, atol=1e-12)


def test_rigid_motion_2d_recovers_a_turn_and_a_shift():
    rng = np.random.default_rng(0)
    after = rng.normal(0.0, 0.5, (3, 2))
    angle, shift = 0.3, np.array([0.05, -0.02])
    c, s = math.cos(angle), math.sin(angle)
    before = after @ np.array([[c, s], [-s, c]]) + shift  # R(angle) @ p + shift, row-wise
    (tx, ty), found = rigid_motion_2d(before.tolist(), after.tolist())
    assert found == pytest.approx(angle, abs=1e-12)
    assert (tx, ty) == pytest.approx(tuple(shift), abs=1e-12)
    assert rigid_motion_2d([[1.0, 2.0]], [[0.5, 2.5]]) == ((0.5, -0.5), 0.0)


def test_a_straight_step_reads_the_bodys_displacement(ant):
    vectors, stance = planted_walk(ant, [(0.0, 0.0, 0.0), (0.03, 0.01, 0.0)])
    odometer = StepOdometer(ant)
    assert odometer.update(vectors[0], forces(stance)) == pytest.approx([0.0, 0.0])  # nothing before
    np.testing.assert_allclose(odometer.update(vectors[1], forces(stance)), [0.03, 0.01], atol=1e-9)


def test_turning_in_stance_does_not_leak_into_the_translation(ant):
    # The tripod A feet (two left, one right) are not centred on the body origin: taking the mean foot
    # motion instead of the rigid motion reads the turn as a sideways and forward shift.
    tripod = [leg in TRIPOD_A for leg in LEGS]
    vectors, stance = planted_walk(ant, [(0.0, 0.0, 0.0), (0.02, 0.0, 0.05)], tripod)
    odometer = StepOdometer(ant)
    odometer.update(vectors[0], forces(stance))
    np.testing.assert_allclose(odometer.update(vectors[1], forces(stance)), [0.02, 0.0], atol=1e-9)
    assert odometer.yaw_rad == pytest.approx(0.05, abs=1e-9)


def test_only_legs_loaded_at_both_updates_count_and_none_reads_zero(ant):
    vectors, _ = planted_walk(ant, [(0.0, 0.0, 0.0), (0.03, 0.0, 0.0), (0.06, 0.0, 0.0)])
    odometer = StepOdometer(ant)
    odometer.update(vectors[0], forces([True, False] * 3))
    # No leg loaded at both updates: no displacement, whatever the joints did.
    assert odometer.update(vectors[1], forces([False, True] * 3)) == pytest.approx([0.0, 0.0])
    assert odometer.update(vectors[2], forces([False] * 6)) == pytest.approx([0.0, 0.0])
    assert odometer.distance_m == 0.0


def test_the_load_threshold_decides_stance(ant):
    vectors, stance = planted_walk(ant, [(0.0, 0.0, 0.0), (0.03, 0.0, 0.0)])
    light = forces(stance) * (0.5 / LOAD_N)  # 0.5 N on every claw
    for threshold, expected in ((0.1, 0.03), (1.0, 0.0)):
        odometer = StepOdometer(ant, contact_threshold_n=threshold)
        odometer.update(vectors[0], light)
        assert odometer.update(vectors[1], light)[0] == pytest.approx(expected, abs=1e-9)


def tripod_walk(body, speed_m_per_step: float, half_cycle: int, cycles: int):
    """A synthetic tripod: each tripod stands for ``half_cycle`` updates with its feet planted while
    the body moves straight ahead, then swings forward by a full stride while the other stands."""
    rest = rest_feet(body)
    stride_m = 2 * half_cycle * speed_m_per_step
    tripod_a = np.array([leg in TRIPOD_A for leg in LEGS])
    world = rest[:, :2] + np.where(tripod_a, 0.5, -0.5)[:, None] * [stride_m / 2, 0.0]
    body_x, steps = 0.0, []
    for k in range(2 * half_cycle * cycles):
        standing = tripod_a if (k // half_cycle) % 2 == 0 else ~tripod_a
        body_x += speed_m_per_step
        feet = rest.copy()
        feet[:, :2] = to_body(world, (body_x, 0.0, 0.0))
        # The swinging tripod moves forward through the air: a stride over its half cycle.
        progress = (k % half_cycle + 1) / half_cycle
        swing = ~standing
        world[swing, 0] += stride_m / half_cycle
        feet[swing, :2] = to_body(world[swing], (body_x, 0.0, 0.0))
        feet[swing, 2] += 0.05 * math.sin(math.pi * progress)
        steps.append((joints_for(body, feet), forces(standing)))
    return steps, stride_m


def test_a_synthetic_tripod_walk_reads_its_distance_and_strides(ant):
    speed, half, cycles = 0.004, 20, 5
    steps, stride_m = tripod_walk(ant, speed, half, cycles)
    odometer = StepOdometer(ant)
    for joints, force in steps:
        odometer.update(joints, force)
    walked = speed * (len(steps) - 1)
    # Each tripod's last standing update and the other's first share no loaded leg: those
    # updates (one per half cycle) read nothing.
    lost = speed * (2 * cycles - 1)
    assert odometer.distance_m == pytest.approx(walked - lost, rel=1e-6)
    # FL's swings end at updates 39, 79, ..., 199; each of the first four is seen a few updates later
    # (the hysteresis), and the strides between them are complete.
    assert len(odometer.stride_lengths_m) == 3
    np.testing.assert_allclose(odometer.stride_lengths_m, stride_m - 2 * speed, rtol=1e-6)


def test_longer_legs_read_through_the_normal_body_underestimate(ant):
    # The long-legged ant's feet stay planted while it moves 5 cm; the odometer believing the normal
    # legs turns the same joint angles into smaller foot motion: it reads less.
    long_legs = desert_ant(leg_length_factors=1.3)
    vectors, stance = planted_walk(long_legs, [(0.0, 0.0, 0.0), (0.05, 0.0, 0.0)])
    readings = {}
    for name, believed in (("long", long_legs), ("normal", ant)):
        odometer = StepOdometer(believed)
        odometer.update(vectors[0], forces(stance))
        readings[name] = odometer.update(vectors[1], forces(stance))[0]
    assert readings["long"] == pytest.approx(0.05, abs=1e-9)
    assert 0.6 * 0.05 < readings["normal"] < 0.9 * 0.05, readings


def test_reset_forgets_the_walk(ant):
    vectors, stance = planted_walk(ant, [(0.0, 0.0, 0.0), (0.03, 0.0, 0.0)])
    odometer = StepOdometer(ant)
    odometer.update(vectors[0], forces(stance))
    odometer.update(vectors[1], forces(stance))
    assert odometer.distance_m > 0.0
    odometer.reset()
    assert odometer.distance_m == 0.0 and odometer.stride_lengths_m == []
    assert odometer.update(vectors[1], forces(stance)) == pytest.approx([0.0, 0.0])


@pytest.mark.parametrize("kwargs, match", [
    ({"contact_threshold_n": -1.0}, "contact_threshold_n"),
    ({"contact_threshold_n": "x"}, "contact_threshold_n"),
    ({"reference_leg": "XX"}, "reference_leg"),
    ({"swing_hysteresis_rad": float("nan")}, "swing_hysteresis_rad"),
])
def test_bad_settings_are_config_errors(ant, kwargs, match):
    with pytest.raises(ConfigError, match=match):
        StepOdometer(ant, **kwargs)


def test_bad_shapes_are_config_errors(ant):
    odometer = StepOdometer(ant)
    with pytest.raises(ConfigError, match="joint_pos"):
        odometer.update(np.zeros(3), forces([True] * 6))
    with pytest.raises(ConfigError, match="contact_force"):
        odometer.update(ant.rest_pose_rad(), np.zeros((6, 3)))
    with pytest.raises(ConfigError, match="BodySpec"):
        StepOdometer("desert_ant")


def test_loads_and_forces_read_the_same(ant):
    steps, _ = tripod_walk(ant, 0.004, 20, 2)
    by_force, by_load = StepOdometer(ant), StepOdometer(ant)
    for joints, force in steps:
        np.testing.assert_array_equal(by_force.update(joints, force),
                                      by_load.update(joints, np.linalg.norm(force, axis=1)))
    assert by_force.distance_m == by_load.distance_m > 0.0


def test_update_many_is_update_one_sample_at_a_time(ant):
    # A walk that turns and shifts with the stance sets changing (one leg unloading mid stance too), split
    # into uneven batches: the same displacements, pose, strides and distance as one update per sample.
    steps, _ = tripod_walk(ant, 0.004, 20, 4)
    rng = np.random.default_rng(5)
    joints = np.array([j for j, _ in steps]) + rng.normal(0.0, 0.01, (len(steps), len(ant.joint_names)))
    loads = np.array([np.linalg.norm(f, axis=1) for _, f in steps])
    loads[rng.random(loads.shape) < 0.1] = 0.0
    one, many = StepOdometer(ant), StepOdometer(ant)
    expected = np.array([one.update(j, f) for j, f in zip(joints, loads)])
    cuts = [0, 1, 7, 40, 41, 90, len(steps)]
    got = np.concatenate([many.update_many(joints[a:b], loads[a:b]) for a, b in zip(cuts[:-1], cuts[1:])])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert many.yaw_rad == pytest.approx(one.yaw_rad, abs=1e-12) and one.yaw_rad != 0.0
    np.testing.assert_allclose(many.position_m, one.position_m, rtol=0, atol=1e-12)
    np.testing.assert_allclose(many.stride_lengths_m, one.stride_lengths_m, rtol=0, atol=1e-12)
    assert len(one.stride_lengths_m) >= 2
    np.testing.assert_array_equal(many.stance, one.stance)
    with pytest.raises(ConfigError, match="one row per joint_pos row"):
        many.update_many(joints[:3], loads[:2])
    with pytest.raises(ConfigError, match="joint_pos"):
        many.update_many(joints[0], loads[:1])


# -- the unicycle ---------------------------------------------------------------------------------------
def test_unicycle_stride_is_the_calibrated_speed_times_the_cycle():
    calibration = unicycle_calibration()
    speed, _ = calibration.rates(np.array([0.0, 0.5]), np.radians([15.0, 10.0]))
    np.testing.assert_allclose(stride_odometer_distance(np.radians([15.0, 10.0]), [0.0, 0.5], calibration, 0.64),
                               speed * 0.64)
    assert stride_odometer_distance(np.radians(15.0), 0.0, calibration, 0.64)[0] > 0.2  # ~0.3 m per tripod cycle
    with pytest.raises(ConfigError, match="cycle_s"):
        stride_odometer_distance(0.2, 0.0, calibration, 0.0)


def test_unicycle_odometer_counts_strides_of_the_commanded_stride_not_the_true_motion():
    calibration = unicycle_calibration()
    odometer = UnicycleStrideOdometer(calibration, agents=2, cycle_s=0.64)
    stride = np.radians([15.0, 15.0])
    believed = stride_odometer_distance(stride, [0.0, 0.0], calibration, 0.64)
    rng = np.random.default_rng(1)
    true_m = np.zeros(2)
    for _ in range(4 * 80):  # four cycles of 8 ms steps
        moved = odometer.update([0.0, 0.0], stride, 0.008)
        # The legs carry out the command with motor noise: the true step differs, the odometer's does not.
        true_m += moved * (1.0 + rng.normal(0.0, 0.1, 2))
    np.testing.assert_array_equal(odometer.strides, [4, 4])
    np.testing.assert_allclose(odometer.distance_m, 4 * believed)
    np.testing.assert_allclose(odometer.stride_lengths_m, [[believed[0]] * 4, [believed[1]] * 4])
    assert not np.allclose(true_m, odometer.distance_m, rtol=1e-3)


class _Replay:
    """A stand-in for the agent loop and its backend, replaying a synthetic walk's proprioception."""

    def __init__(self, steps) -> None:
        self.steps, self.control_steps, self.reads = steps, 0, []
        self.backend = self

    def read(self, names):
        self.reads.append(self.control_steps)
        joints, force = self.steps[self.control_steps]
        assert tuple(names) == ("joint_pos", "contact_load"), names
        return {"joint_pos": joints[None, :], "contact_load": np.linalg.norm(force, axis=1)[None]}


@pytest.mark.parametrize("every", [1, 4])
def test_leg_odometer_samples_every_k_control_steps_and_still_marks_strides(ant, every):
    from neuronav.scenarios.path_integration.inputs import LegOdometer

    speed, half, cycles = 0.004, 20, 5
    steps, stride_m = tripod_walk(ant, speed, half, cycles)
    loop, hook = _Replay(steps), LegOdometer(ant, sample_every=every)
    hook.initialize_episode(loop)
    for k in range(1, len(steps)):
        loop.control_steps = k
        hook.after_step(loop)
    assert loop.reads == list(range(0, len(steps), every))
    # Sampled every k steps, the interval across each tripod switch (no leg loaded at both ends) loses k steps.
    walked = speed * loop.reads[-1]  # up to the last sample
    assert hook.odometer.distance_m == pytest.approx(walked - every * speed * (2 * cycles - 1), rel=1e-6)
    # FL's protractions are still seen at the coarser sampling: the same strides, each missing two lost intervals.
    assert len(hook.odometer.stride_lengths_m) == 3
    np.testing.assert_allclose(hook.odometer.stride_lengths_m, stride_m - 2 * every * speed, rtol=1e-6)
    forward, left = hook.take()
    assert forward == pytest.approx(hook.odometer.position_m[0], rel=1e-9) and left == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("every", [0, -2, 1.5, True])
def test_leg_odometer_refuses_a_bad_sampling_period(ant, every):
    from neuronav.scenarios.path_integration.inputs import LegOdometer

    with pytest.raises(ConfigError, match="sample_every"):
        LegOdometer(ant, sample_every=every)
