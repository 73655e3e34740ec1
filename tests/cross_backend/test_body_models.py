"""One body spec, two engines: MuJoCo's compiled model and PyBullet's generated URDF agree.

Total and per-segment masses, joint names, axes and limits, and where every sensor site sits,
read back from each engine after it built the desert ant — plus the physical check that the
standing ant presses on the floor with its weight on both.
"""

# Tolerances: PyBullet places each link through its principal inertia frame, which it derives
# with single-precision rounding; joint axes then agree to ~2e-4 rad (0.01°) and sites to a few
# micrometres, far below anything a gait could feel. MuJoCo matches the spec to 1e-12.
import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.spec.world import World

ENGINES = ["mujoco", "pybullet"]


def summary(engine_name, body):
    ok, reason = registry.availability("backend", engine_name)
    if not ok:
        pytest.skip(reason)
    with registry.load("backend", engine_name)() as engine:
        engine.load(World(), [body])
        engine.reset(0, position_m=(0.3, -0.2), yaw_rad=0.7)
        return engine.model_summary()


@pytest.fixture(scope="module")
def models():
    body = desert_ant()
    return body, {name: summary(name, body) for name in ENGINES}


def test_masses_match_the_spec_on_both_engines(models):
    body, built = models
    for name, model in built.items():
        masses = model["segment_mass_kg"]
        assert set(masses) == {s.name for s in body.segments}, name
        for segment in body.segments:
            assert masses[segment.name] == pytest.approx(segment.mass_kg, rel=1e-6), (name, segment.name)
        assert sum(masses.values()) == pytest.approx(body.total_mass_kg, rel=1e-9)


def test_joint_names_axes_and_limits_agree(models):
    body, built = models
    mujoco_model, pybullet_model = built["mujoco"], built["pybullet"]
    assert list(mujoco_model["joint_range_rad"]) == list(pybullet_model["joint_range_rad"]) == body.joint_names
    for joint in body.joints:
        for model in (mujoco_model, pybullet_model):
            np.testing.assert_allclose(model["joint_range_rad"][joint.name], joint.range_rad, atol=1e-9)
        np.testing.assert_allclose(mujoco_model["joint_axis_world"][joint.name],
                                   pybullet_model["joint_axis_world"][joint.name], atol=1e-3, err_msg=joint.name)


def test_sensor_sites_sit_at_the_same_places(models):
    body, built = models
    for site in body.sites:
        np.testing.assert_allclose(built["mujoco"]["site_pos_m"][site.name], built["pybullet"]["site_pos_m"][site.name],
                                   atol=1e-5, err_msg=site.name)


@pytest.mark.parametrize("engine_name", ENGINES)
def test_standing_ant_carries_its_weight_on_its_claws(engine_name):
    ok, reason = registry.availability("backend", engine_name)
    if not ok:
        pytest.skip(reason)
    body = desert_ant()
    with registry.load("backend", engine_name)() as engine:
        engine.load(World(), [body])
        engine.reset(0)
        engine.write({"joint_targets": body.rest_pose_rad()[None, :]})
        engine.step(500)  # 1 s to settle
        forces = engine.read(["contact_force"])["contact_force"][0]
        height = engine.read(["body_pos"])["body_pos"][0, 2]
    assert forces[:, 2].sum() == pytest.approx(body.total_mass_kg * 9.81, rel=0.03)
    assert np.all(forces[:6, 2] > 0.5), "every claw should carry some weight"
    assert height == pytest.approx(0.43, abs=0.03)


@pytest.mark.parametrize("engine_name", ENGINES)
def test_leg_scale_lengthens_and_weighs_the_legs_on_both_engines(engine_name):
    """The ``leg_scale`` body option, as each engine built it: longer, heavier legs; nothing else changes."""
    from neuronav.bodies.desert_ant import LEGS

    bodies = {scale: desert_ant(leg_length_factors=scale) for scale in (1.0, 1.25)}
    built = {scale: summary(engine_name, body) for scale, body in bodies.items()}
    for scale, body in bodies.items():  # the engine's masses are the spec's
        for segment in body.segments:
            assert built[scale]["segment_mass_kg"][segment.name] == pytest.approx(segment.mass_kg, rel=1e-4)
    for leg in LEGS:
        heavier = [s.name for s in bodies[1.0].segments if s.name.startswith(f"{leg}_") and s.name != f"{leg}_thc"]
        for name in heavier:
            assert built[1.25]["segment_mass_kg"][name] > built[1.0]["segment_mass_kg"][name], name
        # the claw sits farther from the thorax's centre site: the leg is longer (by about the factor)
        reach = {scale: np.linalg.norm(built[scale]["site_pos_m"][f"{leg}_claw"]
                                       - built[scale]["site_pos_m"]["thorax_centre"]) for scale in built}
        assert 1.1 < reach[1.25] / reach[1.0] < 1.3, (leg, reach)
    thorax = bodies[1.0].segments[0].name
    assert built[1.25]["segment_mass_kg"][thorax] == pytest.approx(built[1.0]["segment_mass_kg"][thorax])


@pytest.mark.parametrize("engine_name", ENGINES)
def test_longer_legs_stand_taller_and_walk_faster(engine_name):
    """Measured (2.5 s, seed 0): leg_scale 0.75 / 1.25 stand 0.29 / 0.49 m high (the factor's ratio, 1.67)
    and walk 0.34 / 0.50 m/s on MuJoCo, 0.33 / 0.51 m/s on PyBullet."""
    from dataclasses import replace

    from neuronav.scenarios.locomotion.scenario import LocomotionConfig, run_trial

    if not registry.availability("backend", engine_name)[0]:
        pytest.skip(f"{engine_name} is not installed")
    runs = {scale: run_trial(replace(LocomotionConfig(), leg_scale=scale, duration_s=2.5), engine_name, 0)[0]
            for scale in (0.75, 1.25)}
    assert not any(run["fell"] for run in runs.values()), runs
    height = runs[1.25]["body_height_mean_m"] / runs[0.75]["body_height_mean_m"]
    assert height == pytest.approx(1.25 / 0.75, rel=0.05), height
    assert runs[1.25]["forward_speed_m_s"] > 1.25 * runs[0.75]["forward_speed_m_s"] > 0.0, runs
