"""The ``locomotion`` scenario: metrics and their conventions, uneven ground, the wall, video, bad input.

Physics runs use MuJoCo (fast) unless a finding belongs to one engine: on the wall, the ant climbs
with I2Bot's touch rule on PyBullet and with pads released in swing on MuJoCo (see
bodies/desert_ant/README.md, "Wall climbing"). Long sweeps are marked slow.
"""

from dataclasses import replace

import numpy as np
import pytest

from neuronav.bodies.desert_ant import LEGS, desert_ant
from neuronav.bodies.gaits import foot_position, segment_pose
from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.runs.cli import main
from neuronav.scenarios.locomotion.scenario import (
    Locomotion,
    LocomotionConfig,
    StanceAdhesion,
    body_centre_m,
    build_gait,
    fell_over,
    gaits,
    ground_height_m,
    run_trial,
    start_pose_kwargs,
    start_position_m,
    trial_gait,
    trial_metrics,
)
from neuronav.spec.world import Ground


def walk(backend, seed=0, **settings):
    pytest.importorskip(backend, reason=f"{backend} is not installed")
    metrics, record = run_trial(replace(LocomotionConfig(), **settings), backend, seed)
    return metrics, record


# -- conventions, no physics --------------------------------------------------------------------------
def synthetic_record(steps, position, heading, up=(0.0, 0.0, 1.0)):
    n = steps + 1
    return {
        "position_m": np.asarray(position, float), "root_m": np.asarray(position, float),
        "heading_rad": np.asarray(heading, float), "up_axis": np.tile(up, (n, 1)), "ground_m": np.zeros(n),
        "roll_rad": np.zeros(n), "pitch_rad": np.zeros(n),
    }


def test_metrics_follow_the_sign_conventions():
    config = LocomotionConfig(duration_s=2.0)
    t = np.linspace(0.0, 1.0, 251)
    yaw = 0.4 * t  # counter-clockwise, so the heading (clockwise from +y) falls
    # Starts heading +x (heading π/2), moves 1 m forward and 0.2 m to the left, turns 0.4 rad left.
    position = np.column_stack([t, 0.2 * t, np.full_like(t, 0.4)])
    metrics = trial_metrics(synthetic_record(250, position, np.pi / 2 - yaw), config, 12.0, 1.0, 1.0, 1e-5, 1.0)
    assert metrics["forward_speed_m_s"] == pytest.approx(0.5)
    assert metrics["lateral_drift_m"] == pytest.approx(0.2)
    assert metrics["turn_rate_rad_s"] == pytest.approx(0.2)
    assert metrics["climb_height_m"] == pytest.approx(0.0) and not metrics["fell"]


def test_fell_over_tells_a_body_on_its_back_from_one_rearing_up_a_wall():
    steps = 10
    at_wall = np.tile([0.6, 0.0, 0.4], (steps + 1, 1))  # centre 0.4 m from the wall at x = 1
    far = np.tile([-0.5, 0.0, 0.4], (steps + 1, 1))

    def record(position, up):
        return synthetic_record(steps, position, np.zeros(steps + 1), up=up)

    assert not fell_over(record(at_wall, (0.0, 0.0, 1.0)))
    assert fell_over(record(at_wall, (0.0, 0.0, -1.0)))  # on its back
    belly_to_wall = record(at_wall, (-1.0, 0.0, 0.0))
    assert fell_over(belly_to_wall) and not fell_over(belly_to_wall, wall_x_m=1.0)
    assert not fell_over(record(at_wall, (-0.7, 0.0, 0.7)), wall_x_m=1.0)  # rearing up against the wall
    assert fell_over(record(at_wall, (-0.7, 0.0, -0.7)), wall_x_m=1.0)  # on its back at the foot of the wall
    assert fell_over(record(far, (-1.0, 0.0, 0.0)), wall_x_m=1.0)  # on its side, away from the wall
    assert fell_over(record(np.tile([0.0, 0.0, 0.05], (steps + 1, 1)), (0.0, 0.0, 1.0)))  # centre on the ground


def test_body_centre_is_the_rest_centre_of_mass_between_the_middle_legs():
    body = desert_ant()
    centre = body_centre_m(body)
    moment = sum(s.mass_kg * (segment_pose(body, s.name, {})[1] + segment_pose(body, s.name, {})[0] @ s.inertial()[0])
                 for s in body.segments)
    np.testing.assert_allclose(centre, moment / body.total_mass_kg)
    assert centre[0] == pytest.approx(foot_position(body, "ML", body.rest_pose_rad())[0], abs=0.01)
    assert abs(centre[1]) < 1e-9


def test_ground_height_is_the_grounds_own_interpolation():
    ground = Ground(kind="uneven", roughness_m=0.05, seed=3)
    points = np.random.default_rng(1).uniform(-12.0, 12.0, size=(50, 2))  # some beyond the edge
    expected = [ground.height_at(x, y) for x, y in points]
    np.testing.assert_allclose(ground_height_m(ground, points), expected, atol=1e-12)
    assert np.all(ground_height_m(Ground(kind="wall"), points) == 0.0)


@pytest.mark.parametrize("roughness_m", [0.02, 0.05])
def test_start_on_rough_ground_keeps_every_claw_out_of_the_ground(roughness_m):
    body = desert_ant()
    feet = np.array([foot_position(body, leg, body.rest_pose_rad())[:2] for leg in LEGS])
    for seed in range(4):
        ground = Ground(kind="uneven", roughness_m=roughness_m, seed=seed)
        x, y = start_position_m(ground, body, 0.0, np.random.default_rng(seed))
        root = ground.height_at(x, y)
        assert all(ground.height_at(x + fx, y + fy) <= root + 1e-3 for fx, fy in feet), seed
    assert start_position_m(Ground(kind="flat"), body, 0.3, np.random.default_rng(0)) == (0.0, 0.0)


def test_wall_posture_only_when_walking_at_the_wall():
    body = desert_ant()
    rest = body.rest_pose_rad()
    head = list(body.joint_names).index("head_pitch")
    flat = build_gait(LocomotionConfig(), body)
    approach = build_gait(LocomotionConfig(terrain="wall", wall_start="floor"), body)
    plain_approach = build_gait(LocomotionConfig(terrain="wall", wall_start="floor", wall_posture=False), body)
    on_wall = build_gait(LocomotionConfig(terrain="wall"), body)
    for _ in range(2 * approach.cycle_steps):
        a, b, c, d = (g.step(0.0, 0.26) for g in (flat, approach, plain_approach, on_wall))
    assert a[head] == rest[head] == c[head] == d[head] and b[head] > rest[head] + 0.5  # raised for the approach only


def test_on_wall_start_pose_puts_the_centre_at_the_asked_height():
    body = desert_ant()
    config = LocomotionConfig(terrain="wall", wall_start_height_m=2.0)
    pose = start_pose_kwargs(config, body, Ground(kind="wall"), 0.3, np.random.default_rng(0))
    assert pose["pitch_rad"] == pytest.approx(np.pi / 2) and pose["yaw_rad"] == 0.0 and pose["spin_rad"] == 0.3
    root = np.array(pose["position_m"])
    centre = root + np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]]) @ body_centre_m(body)  # body x up, z to -x
    assert centre[2] == pytest.approx(2.0)
    assert root[0] == pytest.approx(1.0 - body.spawn_height_m + 0.002)  # standing height off the wall face
    floor = start_pose_kwargs(replace(config, wall_start="floor"), body, Ground(kind="wall"), 0.3,
                              np.random.default_rng(0))
    assert floor == {"position_m": (0.0, 0.0), "yaw_rad": 0.3}


# -- physics --------------------------------------------------------------------------------------------
def test_walking_goes_on_over_uneven_ground_with_larger_height_changes():
    flat, _ = walk("mujoco", gait="tripod", duration_s=3.0)
    flat_ik, _ = walk("mujoco", gait="ik", duration_s=3.0)
    for seed in (0, 1):
        rough, _ = walk("mujoco", seed=seed, gait="tripod", terrain="uneven-2", duration_s=3.0)
        assert not rough["fell"] and rough["forward_speed_m_s"] > 0.05, rough
        assert rough["body_height_var_m2"] > 2.0 * flat["body_height_var_m2"], (flat, rough)
        bumpy_ik, _ = walk("mujoco", seed=seed, gait="ik", terrain="uneven-1", duration_s=3.0)
        assert not bumpy_ik["fell"] and bumpy_ik["forward_speed_m_s"] > 0.2, bumpy_ik
        assert bumpy_ik["body_height_var_m2"] > 4.0 * flat_ik["body_height_var_m2"], (flat_ik, bumpy_ik)


def test_pybullets_ant_walks_on_over_uneven_ground_with_larger_height_changes():
    """The slow test_uneven_ground_on_every_backend's claim for PyBullet, on one seed and 2 s."""
    flat, _ = walk("pybullet", gait="tripod", duration_s=2.0)
    rough, _ = walk("pybullet", seed=1, gait="tripod", terrain="uneven-2", duration_s=2.0)
    assert not rough["fell"] and rough["forward_speed_m_s"] > 0.05, rough
    assert rough["body_height_var_m2"] > 2.0 * flat["body_height_var_m2"], (flat, rough)  # measured: 9x


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
@pytest.mark.parametrize("gait", ["tripod", "ik"])
def test_uneven_ground_on_every_backend(backend, gait):
    flat, _ = walk(backend, gait=gait, duration_s=4.0)
    for terrain in ("uneven-1", "uneven-2"):
        variances = []
        for seed in range(3):
            rough, _ = walk(backend, seed=seed, gait=gait, terrain=terrain, duration_s=4.0)
            assert not rough["fell"] and rough["forward_speed_m_s"] > 0.05, (terrain, seed, rough)
            variances.append(rough["body_height_var_m2"])
        assert np.mean(variances) > flat["body_height_var_m2"], (terrain, variances, flat)


def test_adhesion_raises_the_ant_walking_at_the_wall():
    without, _ = walk("pybullet", terrain="wall", wall_start="floor", adhesion_n=0.0, duration_s=10.0)
    with_adhesion, _ = walk("pybullet", terrain="wall", wall_start="floor", adhesion_n=120.0, duration_s=10.0)
    assert not without["fell"] and not with_adhesion["fell"]
    assert without["climb_height_m"] < 0.1  # pushing against the wall lifts the body a little at most
    assert with_adhesion["climb_height_m"] > without["climb_height_m"] + 0.04, (without, with_adhesion)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_walking_at_the_wall_against_adhesion_sweep(backend):
    """Walking from the floor at the wall, 0–200 N: the ant rears up but does not get onto it (README);
    the climbs themselves start on the wall (tests/cross_backend/test_wall_climbing.py)."""
    climbs = {}
    for adhesion in (0.0, 60.0, 120.0, 150.0, 200.0):
        metrics, record = walk(backend, terrain="wall", wall_start="floor", adhesion_n=adhesion, duration_s=12.0)
        assert np.isfinite(metrics["climb_height_m"]), (adhesion, metrics)  # it may rear up and tip over backwards
        assert metrics["climb_height_m"] == pytest.approx(record["position_m"][:, 2].max()
                                                          - record["position_m"][0, 2])
        climbs[adhesion] = metrics["climb_height_m"]
    assert climbs[0.0] < 0.1, climbs  # without adhesion the ant cannot get onto the wall
    # With adhesion it gets its front legs onto the wall on PyBullet (0.13-0.3 m); on MuJoCo they stay
    # glued at the foot of the wall (README, "Wall climbing"): no effect to assert there.
    if backend == "pybullet":
        assert min(climbs[a] for a in (60.0, 120.0, 150.0, 200.0)) > climbs[0.0] + 0.04, climbs


# -- video and bad input --------------------------------------------------------------------------------
def test_video_is_an_mp4(tmp_path):
    pytest.importorskip("mujoco")
    pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "run"
    command = ["run", "locomotion", "--backend", "mujoco", "--set", "duration_s=0.5", "--video", "--out", str(out)]
    assert main(command) == 0
    videos = list(out.rglob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
    assert videos[0].read_bytes()[4:8] == b"ftyp"  # an MP4 container


@pytest.mark.parametrize("setting, fragment", [
    ("gait=gallop", "gait"), ("terrain=ice", "terrain"), ("adhesion_n=-5", "adhesion_n"),
    ("turn=2", "turn"), ("duration_s=0", "duration_s"), ("gait=tripod,gallop", "gallop"),
    ("gait=tripod,tripod", "without repeats"), ("turn_noise_sd=-1", "turn_noise_sd"),
    ("variability=maybe", "variability"),
])
def test_bad_settings_are_config_errors(setting, fragment):
    with pytest.raises(ConfigError, match=fragment):
        apply_overrides(LocomotionConfig, [setting])


def test_control_step_must_be_a_multiple_of_the_physics_step():
    with pytest.raises(ConfigError, match="not an integer multiple"):
        apply_overrides(LocomotionConfig, ["timestep_s=0.003", "control_dt_s=0.008"])
    assert apply_overrides(LocomotionConfig, ["timestep_s=0.001", "control_dt_s=0.008"]).control_dt_s == 0.008


@pytest.mark.parametrize("settings, fragment", [
    (["timestep_s=1e-300"], "timestep_s"),  # used to hang: 8e297 physics steps per control step
    (["control_dt_s=1e-300"], "control_dt_s"),
    (["timestep_s=0.0001", "control_dt_s=0.05"], "at most 100 physics steps per control step"),
    (["timestep_s=0.0001", "duration_s=600"], "at most 1,000,000"),
    (["duration_s=0.004"], "shorter than one control step"),
    (["leg_scale=1e-300"], "leg_scale"), (["leg_scale=3"], "leg_scale"),
    (["roughness_seed_offset=99999999999999"], "roughness_seed_offset"),
])
def test_settings_that_would_hang_or_overflow_are_config_errors(settings, fragment):
    with pytest.raises(ConfigError, match=fragment):
        apply_overrides(LocomotionConfig, settings)


def test_every_setting_has_a_documented_range_or_choices():
    import dataclasses

    for f in dataclasses.fields(LocomotionConfig):
        meta = f.metadata
        assert meta.get("help"), f.name
        if isinstance(f.default, bool) or f.name == "gait":  # gait: one or a comma list, checked by gaits()
            continue
        if isinstance(f.default, str):
            assert meta.get("choices"), f.name
        else:
            assert ("min" in meta or "min_exclusive" in meta) and "max" in meta, f.name
    # the extremes of the ranges still run (the longest trial is bounded by MAX_PHYSICS_STEPS)
    longest = apply_overrides(LocomotionConfig, ["timestep_s=0.0006", "control_dt_s=0.0594", "duration_s=600"])
    assert round(longest.duration_s / longest.timestep_s) == 1_000_000


@pytest.mark.parametrize("setting", ["gait=gallop", "terrain=ice", "adhesion_n=-5", "control_dt_s=0.007",
                                     "timestep_s=1e-300"])
def test_cli_bad_settings_exit_2_with_one_line(tmp_path, capsys, setting):
    pytest.importorskip("mujoco")
    code = main(["run", "locomotion", "--backend", "mujoco", "--set", setting, "--set", "duration_s=0.1",
                 "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err and len(err.splitlines()) == 1, err


def test_stance_adhesion_switches_off_the_pads_of_swinging_legs_only():
    body = desert_ant()
    gait = build_gait(LocomotionConfig(gait="ik"), body)
    written = []

    class Recorder:
        def write(self, commands):
            written.append(commands["adhesion"].copy())

    class Loop:
        backend = Recorder()

    Loop.gait = gait
    hook = StanceAdhesion(body)
    sites = [s.name for s in body.sites_of_kind("contact")]
    for _ in range(gait.cycle_steps):
        hook.before_step(Loop)
        swing = gait.in_swing(gait.step_index)
        pads = dict(zip(sites, written[-1][0]))
        for i, leg in enumerate(LEGS):
            assert pads[f"{leg}_claw"] == (0.0 if swing[i] else 1.0)
        assert pads["antenna_L_tip"] == pads["antenna_R_tip"] == 1.0
        gait.step(0.0, 0.26)
    assert min(p.sum() for p in written) < len(sites)  # some pads were off some of the time


# -- conditions and variability (issue 22) ------------------------------------------------------------
def test_a_gait_list_is_walked_by_seed_and_named_in_each_row():
    config = apply_overrides(LocomotionConfig, ["gait=ik,wave"])
    assert gaits(config) == ("ik", "wave")
    assert [trial_gait(config, seed) for seed in range(5)] == ["ik", "wave", "ik", "wave", "ik"]
    spec = Locomotion().statistics(config)
    assert (spec.condition, spec.reference) == ("gait", "ik")
    pytest.importorskip("mujoco")
    rows = Locomotion().run(replace(config, duration_s=0.16), backend="mujoco", trials=2, seed=3).trials
    assert [row["gait"] for row in rows] == ["wave", "ik"]


@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_motor_noise_is_what_makes_walks_of_one_start_differ(backend):
    """Without the yaw jitter two seeds start alike on flat ground: the exact command walks them alike,
    the default motor noise (per gait cycle) apart."""
    still = {"initial_yaw_jitter_rad": 0.0, "duration_s": 1.28}
    off = [walk(backend, seed, variability="off", **still)[0] for seed in (1, 3)]
    on = [walk(backend, seed, **still)[0] for seed in (1, 3)]
    key = ("forward_speed_m_s", "lateral_drift_m", "turn_rate_rad_s", "body_height_var_m2")
    assert [off[0][k] for k in key] == [off[1][k] for k in key]
    assert [on[0][k] for k in key] != [on[1][k] for k in key]
    assert all(abs(on[i][k] - off[i][k]) > 0 for i in range(2) for k in key[:2])
