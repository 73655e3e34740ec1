"""FK and IK gaits on the desert ant: phase tables, symmetry, turning, IK accuracy, bad input."""

import math

import numpy as np
import pytest

from neuronav.bodies.desert_ant import LEGS, desert_ant, leg_geometry
from neuronav.bodies.gaits import IK_REACH_FACTOR, FKGait, IKGait, foot_position, leg_ik, make_gait, side_factors
from neuronav.errors import ConfigError

N = 20  # S_n, steps per half swing (I2Bot default)
PUBLISHED = {  # pattern: (cycle, swing, swing-start offsets in steps), docs/parameters.md §2
    "tripod": (4 * N, 2 * N, {"FL": 0, "MR": 0, "HL": 0, "FR": 2 * N, "ML": 2 * N, "HR": 2 * N}),
    "ripple": (6 * N, 2 * N, {"HL": 0, "FR": N, "ML": 2 * N, "HR": 3 * N, "FL": 4 * N, "MR": 5 * N}),
    "wave": (12 * N, 2 * N, {"FL": 0, "HR": 2 * N, "MR": 4 * N, "FR": 6 * N, "HL": 8 * N, "ML": 10 * N}),
}
MIRROR = {"FL": "FR", "ML": "MR", "HL": "HR"}


@pytest.fixture(scope="module")
def ant():
    return desert_ant()


def leg_angles(gait, targets, leg):
    return targets[gait.leg_index[leg]]


@pytest.mark.parametrize("pattern", sorted(PUBLISHED))
def test_phase_table_cycle_and_duty_factor(ant, pattern):
    gait = FKGait(ant, pattern=pattern)
    cycle, swing, offsets = PUBLISHED[pattern]
    assert (gait.cycle_steps, gait.swing_steps) == (cycle, swing)
    assert gait.duty_factor == pytest.approx(1 - swing / cycle)
    rest = ant.rest_pose_rad()
    for k in range(cycle):
        expected = {leg for leg in LEGS if (k - offsets[leg]) % cycle < swing}
        assert gait.swing_legs(k) == expected, f"{pattern} step {k}"
        targets = gait.targets_at(k)
        for leg in LEGS:
            index = gait.leg_index[leg]
            phase = (k - offsets[leg]) % cycle
            lifted = targets[index[2]] < rest[index[2]] - 1e-9  # CTr raised
            assert lifted == (0 < phase < swing), f"{pattern} {leg} step {k}"
    counts = {"tripod": 3, "ripple": 2, "wave": 1}[pattern]
    assert all(len(gait.swing_legs(k)) == counts for k in range(cycle))
    if pattern == "tripod":
        assert gait.swing_legs(0) == {"FL", "MR", "HL"} and gait.swing_legs(2 * N) == {"FR", "ML", "HR"}


@pytest.mark.parametrize("pattern", sorted(PUBLISHED))
def test_fk_swing_and_stance_shapes(ant, pattern):
    gait = FKGait(ant, pattern=pattern)
    stride, lift = math.radians(15), math.radians(20)
    rest = ant.rest_pose_rad()
    cycle, swing, offsets = PUBLISHED[pattern]
    leg = "ML"
    index = gait.leg_index[leg]
    series = np.array([gait.targets_at(offsets[leg] + p)[index] for p in range(cycle)])
    alpha = series[:, 0]
    # ThCz sweeps forward from α0 − Δ to α0 + Δ during swing, back during stance, continuously.
    assert alpha[0] == pytest.approx(rest[index[0]] - stride)
    assert alpha[swing] == pytest.approx(rest[index[0]] + stride)
    assert np.all(np.diff(alpha[:swing + 1]) > 0) and np.all(np.diff(alpha[swing:]) < 0)
    # Lift peaks mid-swing at the full lift swing; ThCx and TiTa never move.
    assert series[swing // 2, 2] == pytest.approx(rest[index[2]] - lift)
    assert series[swing // 2, 3] == pytest.approx(rest[index[3]] + lift)
    assert np.all(series[:, [1, 4]] == rest[index[[1, 4]]])
    # The lifted foot is higher than the standing one.
    feet = np.array([foot_position(ant, leg, q) for q in series])
    assert feet[swing // 2, 2] > feet[swing + 1, 2] + 0.05


@pytest.mark.parametrize("name", ["tripod", "ripple", "wave", "ik"])
def test_gait_protocol_and_non_leg_joints(ant, name):
    gait = make_gait(name, ant)
    assert gait.joint_names == tuple(ant.joint_names) and len(gait.joint_names) == 40
    rest = ant.rest_pose_rad()
    leg_joints = np.concatenate([gait.leg_index[leg] for leg in LEGS])
    others = np.setdiff1d(np.arange(40), leg_joints)
    low = np.array([j.range_rad[0] for j in ant.joints])
    high = np.array([j.range_rad[1] for j in ant.joints])
    first = [gait.step(0.3, math.radians(12)) for _ in range(gait.cycle_steps)]
    for targets in first:
        assert targets.shape == (40,) and np.all(np.isfinite(targets))
        assert np.all(targets[others] == rest[others])
        assert np.all((low <= targets) & (targets <= high))
        for leg in LEGS:  # ThCx and TiTa hold rest
            index = gait.leg_index[leg]
            assert targets[index[1]] == rest[index[1]] and targets[index[4]] == rest[index[4]]
    gait.reset()
    np.testing.assert_array_equal(gait.step(0.3, math.radians(12)), first[0])


@pytest.mark.parametrize("name", ["tripod", "ripple", "wave", "ik"])
def test_straight_walking_is_mirror_symmetric(ant, name):
    gait = make_gait(name, ant)
    half = gait.cycle_steps // 2
    for k in range(gait.cycle_steps):
        now, later = gait.targets_at(k, 0.0), gait.targets_at(k + half, 0.0)
        for left, right in MIRROR.items():
            # Contralateral legs are half a cycle apart and carry the same angles (axes are mirrored) ...
            np.testing.assert_allclose(leg_angles(gait, now, left), leg_angles(gait, later, right), atol=1e-12)
            # ... so their feet are mirror images across the body's midline.
            np.testing.assert_allclose(foot_position(ant, left, now) * (1, -1, 1), foot_position(ant, right, later),
                                       atol=1e-9)


def stance_foot_motion(ant, gait, turn):
    """(p × dp)_z and dp_x of every stance foot between consecutive control steps, per leg."""
    motion = {leg: [] for leg in LEGS}
    for k in range(gait.cycle_steps):
        a, b = gait.targets_at(k, turn), gait.targets_at(k + 1, turn)
        both = ~gait.in_swing(k) & ~gait.in_swing(k + 1)
        for i, leg in enumerate(LEGS):
            if both[i]:
                p0, p1 = foot_position(ant, leg, a), foot_position(ant, leg, b)
                d = p1 - p0
                motion[leg].append((p0[0] * d[1] - p0[1] * d[0], d[0]))
    return {leg: np.array(v) for leg, v in motion.items()}


@pytest.mark.parametrize("name", ["tripod", "ripple", "wave", "ik"])
def test_turning_on_the_spot(ant, name):
    gait = make_gait(name, ant)
    straight = stance_foot_motion(ant, gait, 0.0)
    assert all(np.all(v[:, 1] < 0) for v in straight.values())  # every stance foot pushes back: forward walk
    left = stance_foot_motion(ant, gait, 1.0)
    right = stance_foot_motion(ant, gait, -1.0)
    # θ = +1: stance feet sweep clockwise under the body, so the body turns counter-clockwise (left);
    # θ = −1 the other way. Both sides push the same rotational way.
    for leg in LEGS:
        assert np.all(left[leg][:, 0] < 0), leg
        assert np.all(right[leg][:, 0] > 0), leg
        assert np.sign(left[leg][0, 1]) == (1 if leg[1] == "L" else -1)


def test_side_factors_follow_table_2():
    assert side_factors(0.0) == (1.0, 1.0)
    assert side_factors(1.0) == (-1.0, 1.0)
    assert side_factors(-1.0) == (1.0, -1.0)
    assert side_factors(0.25) == (0.5, 1.0)
    assert side_factors(-0.25) == (1.0, 0.5)
    assert side_factors(3.0) == side_factors(1.0)  # clipped


def test_stride_is_the_hip_swing_amplitude(ant):
    gait = FKGait(ant, hip_swing_rad=math.radians(15))
    index = gait.leg_index["FL"]
    for stride in (math.radians(5), math.radians(25)):
        alphas = [gait.targets_at(k, 0.0, stride)[index[0]] for k in range(gait.cycle_steps)]
        assert max(alphas) - min(alphas) == pytest.approx(2 * stride, rel=0.06)
    default = [gait.targets_at(k)[index[0]] for k in range(gait.cycle_steps)]
    assert max(default) == pytest.approx(math.radians(15))
    backward = FKGait(ant, direction=-1)
    assert backward.targets_at(0)[index[0]] == pytest.approx(math.radians(15))  # swing starts in front


@pytest.mark.parametrize("turn", [-1.0, -0.4, 0.0, 0.7, 1.0])
def test_ik_reproduces_the_commanded_foot_trajectory(ant, turn):
    gait = IKGait(ant)
    stride = math.radians(20)
    for _ in range(gait.cycle_steps):
        targets = gait.step(turn, stride)
        for i, leg in enumerate(LEGS):
            np.testing.assert_allclose(foot_position(ant, leg, targets), gait.last_feet_m[i], atol=1e-6)


def test_ik_trajectory_shape(ant):
    gait = IKGait(ant, step_length_m=0.2, step_height_m=0.07)
    feet = np.array([gait.foot_targets(k) for k in range(gait.cycle_steps)])
    rest = gait.rest_feet_m
    for i, leg in enumerate(LEGS):
        swinging = np.array([gait.leg_phase(leg, k)[0] for k in range(gait.cycle_steps)])
        # Stance on the ground, straight back; swing an arc up to H, forward over L.
        assert np.allclose(feet[~swinging, i, 2], rest[i, 2]) and np.allclose(feet[:, i, 1], rest[i, 1])
        assert np.all(np.diff(feet[~swinging, i, 0]) < 0)
        assert feet[swinging, i, 2].max() == pytest.approx(rest[i, 2] + 0.07)
        assert np.ptp(feet[:, i, 0]) == pytest.approx(0.2, rel=0.01)
    horizontal = [np.linalg.norm((rest[i] - leg_geometry(ant)[leg]["anchor_m"])[:2]) for i, leg in enumerate(LEGS)]
    assert gait.reach_m == pytest.approx(IK_REACH_FACTOR * np.mean(horizontal))


def test_ik_stays_finite_and_in_range_for_unreachable_commands(ant):
    low = np.array([j.range_rad[0] for j in ant.joints])
    high = np.array([j.range_rad[1] for j in ant.joints])
    gait = IKGait(ant, step_height_m=2.0)
    for turn, stride in ((0.0, 5.0), (1.0, 40.0), (-0.5, -7.0)):
        for k in range(gait.cycle_steps):
            targets = gait.targets_at(k, turn, stride)
            assert np.all(np.isfinite(targets)) and np.all((low <= targets) & (targets <= high))
    geometry = leg_geometry(ant)["HL"]
    for point in ((50.0, 50.0, -50.0), tuple(geometry["anchor_m"]), (0.0, 0.0, 0.0)):
        assert np.all(np.isfinite(leg_ik(geometry, point)))


def test_bad_gait_names_and_parameters(ant):
    with pytest.raises(ConfigError, match="allowed: tripod, ripple, wave, ik"):
        make_gait("gallop", ant)
    with pytest.raises(ConfigError, match="unknown option 'speed'"):
        make_gait("tripod", ant, speed=3)
    with pytest.raises(ConfigError, match="pattern"):
        FKGait(ant, pattern="canter")
    for kwargs, fragment in (({"steps_per_half_swing": 0}, "steps_per_half_swing"),
                             ({"steps_per_half_swing": 2.5}, "steps_per_half_swing"),
                             ({"direction": 2}, "direction"),
                             ({"hip_swing_rad": -0.1}, "hip_swing_rad"),
                             ({"lift_rad": float("nan")}, "lift_rad")):
        with pytest.raises(ConfigError, match=fragment):
            make_gait("ripple", ant, **kwargs)
    with pytest.raises(ConfigError, match="step_height_m"):
        make_gait("ik", ant, step_height_m=-0.1)
    gait = make_gait("tripod", ant)
    with pytest.raises(ConfigError, match="turn"):
        gait.step(float("nan"), 0.2)
    with pytest.raises(ConfigError, match="stride_rad"):
        gait.step(0.0, float("inf"))
    with pytest.raises(ConfigError, match="BodySpec"):
        FKGait("not a body")
    with pytest.raises(ConfigError, match="unknown leg"):
        foot_position(ant, "XL", np.zeros(5))
    with pytest.raises(ConfigError, match="angles must have"):
        foot_position(ant, "FL", np.zeros(7))


@pytest.mark.parametrize("name", ["tripod", "ripple", "wave", "ik"])
def test_start_is_ramped_in_from_the_rest_pose(ant, name):
    gait = make_gait(name, ant)
    rest = ant.rest_pose_rad()
    first = gait.step(0.0, math.radians(15))
    np.testing.assert_allclose(first, rest, atol=1e-12)  # no jump of ±stride on the first sample
    samples = [first] + [gait.step(0.0, math.radians(15)) for _ in range(2 * gait.cycle_steps)]
    hips = np.concatenate([gait.leg_index[leg][:1] for leg in LEGS])
    jumps = np.abs(np.diff(np.array(samples)[:, hips], axis=0)).max(axis=1)
    stride = math.radians(15)
    steady = max(np.abs(gait.targets_at(k + 1, 0.0, stride) - gait.targets_at(k, 0.0, stride))[hips].max()
                 for k in range(gait.cycle_steps))
    assert jumps.max() <= steady * 1.2  # the start-up never moves a hip much faster than steady walking does
    # After the ramp (one cycle) the steady pattern of targets_at is back.
    k = 2 * gait.cycle_steps
    np.testing.assert_allclose(samples[k], gait.targets_at(k, 0.0, math.radians(15)), atol=1e-12)
    assert [gait.envelope(k) for k in (0, gait.cycle_steps // 2, gait.cycle_steps)] == pytest.approx([0.0, 0.5, 1.0])
    unramped = make_gait(name, ant, ramp_steps=0)
    np.testing.assert_allclose(unramped.step(0.0, math.radians(15)), unramped.targets_at(0, 0.0, math.radians(15)))
    with pytest.raises(ConfigError, match="ramp_steps"):
        make_gait(name, ant, ramp_steps=-1)


def test_posture_gait_holds_and_offsets_joints_after_a_smooth_start(ant):
    from neuronav.bodies.gaits import PostureGait

    base = make_gait("tripod", ant)
    gait = PostureGait(make_gait("tripod", ant), {"head_pitch": 0.6, "FL_FTi": 9.0}, {"FL_ThCz": 0.2})
    names = list(ant.joint_names)
    head, fti, thcz = names.index("head_pitch"), names.index("FL_FTi"), names.index("FL_ThCz")
    rest = ant.rest_pose_rad()
    first, plain = gait.step(0.0, 0.2), base.step(0.0, 0.2)
    np.testing.assert_allclose(first, rest, atol=1e-12)  # starts from the rest pose like the gait itself
    for _ in range(gait.cycle_steps):
        targets, plain = gait.step(0.0, 0.2), base.step(0.0, 0.2)
    assert targets[head] == pytest.approx(0.6)
    assert targets[fti] == pytest.approx(ant.joints[fti].range_rad[1])  # clipped to the joint range
    assert targets[thcz] == pytest.approx(plain[thcz] + 0.2)
    others = np.setdiff1d(np.arange(len(names)), [head, fti, thcz])
    np.testing.assert_array_equal(targets[others], plain[others])
    assert gait.cycle_steps == base.cycle_steps and gait.joint_names == base.joint_names
    with pytest.raises(ConfigError, match="unknown joint 'tail'"):
        PostureGait(base, {"tail": 0.1})
