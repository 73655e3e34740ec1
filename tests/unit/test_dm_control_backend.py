"""The dm_control backend: the MuJoCo backend's model in a dm_control ``Physics``, stepped by ``Physics.step``."""

import numpy as np
import pytest

from neuronav import registry
from neuronav.errors import ConfigError, SimulationError
from neuronav.runs.trials import run_trials
from neuronav.spec.world import World

pytest.importorskip("dm_control", reason="dm_control is not installed")
from dm_control import mujoco as dm_mujoco  # noqa: E402

from neuronav.backends.dm_control import DmControlBackend  # noqa: E402
from neuronav.backends.mujoco import MujocoBackend  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402


@pytest.fixture(scope="module")
def ant():
    return desert_ant()


def loaded(cls, ant):
    backend = cls()
    backend.load(World(), [ant])
    backend.reset(seed=0)
    return backend


# Scenarios that run on "mujoco" without the single-ant backend, so dm_control cannot stand in: why.
NOT_ON_DM_CONTROL = {"swarm-homing": "many ants in one MuJoCo model (neuronav.backends.mujoco.swarm), not the backend"}


def test_registered_under_its_name_and_accepted_where_mujoco_is():
    assert registry.load("backend", "dm_control") is DmControlBackend
    for name in registry.names("scenario"):
        scenario = registry.load("scenario", name)
        if "mujoco" in scenario.backends and name not in NOT_ON_DM_CONTROL:
            assert "dm_control" in scenario.backends, name


def test_physics_wraps_the_same_model_as_the_mujoco_backend(ant):
    dm, mj = loaded(DmControlBackend, ant), loaded(MujocoBackend, ant)
    assert isinstance(dm.physics, dm_mujoco.Physics)
    assert dm.physics.model.ptr is dm.model and dm.physics.data.ptr is dm.data
    for field in ("body_mass", "body_inertia", "body_pos", "body_quat", "geom_size", "jnt_range",
                  "dof_damping", "actuator_gainprm", "actuator_biasprm"):
        np.testing.assert_array_equal(getattr(dm.model, field), getattr(mj.model, field), err_msg=field)
    assert dm.physics.timestep() == mj.model.opt.timestep == 0.002
    # dm_control's named views see the backend's state: the joints it reports.
    joints = dm.read(["joint_pos"])["joint_pos"][0]
    named = [dm.physics.named.data.qpos[name] for name in dm.names.joints]
    np.testing.assert_array_equal(np.concatenate(named), joints)


def test_steps_go_through_physics_step_and_match_mujoco(ant, monkeypatch):
    dm, mj = loaded(DmControlBackend, ant), loaded(MujocoBackend, ant)
    calls = []
    original = dm.physics.step
    monkeypatch.setattr(dm.physics, "step", lambda n=1: (calls.append(n), original(n)))
    targets = ant.rest_pose_rad() + 0.2
    for backend in (dm, mj):
        backend.write({"joint_targets": targets[None, :]})
        backend.step(25)
    assert calls == [25]  # no external force: all steps in one Physics.step
    dm.step(0)
    assert dm.time == pytest.approx(25 * 0.002)  # zero steps are none (dm_control's step(0) takes one)
    assert dm.time == pytest.approx(25 * 0.002)
    names = ["joint_pos", "joint_torque", "position", "heading", "contact_force"]
    got, want = dm.read(names), mj.read(names)
    for name in names:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    dm.apply_force(0, dm.body.root.name, [0.0, 0.0, 5.0])
    dm.step(3)
    assert calls == [25, 1, 1, 1]  # a pending force: one Physics.step per physics step, the force each time


def test_a_diverged_state_is_a_simulation_error_as_on_mujoco(ant):
    dm = loaded(DmControlBackend, ant)
    dm.data.qvel[:] = np.nan
    with pytest.raises(SimulationError, match="diverged"):
        dm.step(1)
    with pytest.raises(SimulationError, match="call reset"):
        dm.step(1)
    dm.reset(seed=0)
    dm.step(1)  # a reset recovers
    assert np.isfinite(dm.data.qpos).all()


def test_bad_input_names_the_backend():
    with pytest.raises(ConfigError, match="dm_control backend: timestep_s"):
        DmControlBackend(timestep_s=-1.0)
    with pytest.raises(SimulationError, match="dm_control backend: call load"):
        DmControlBackend().step(1)


def test_locomotion_runs_on_dm_control_and_repeats_under_its_seed():
    scenario = registry.load("scenario", "locomotion")
    config = scenario.config_type(duration_s=0.1)
    first = run_trials(scenario(), config, "dm_control", trials=1, seed=2)
    second = run_trials(scenario(), config, "dm_control", trials=1, seed=2)
    assert first.trials[0]["status"] == "ok", first.trials[0]["error"]
    assert first.trials[0]["forward_speed_m_s"] == second.trials[0]["forward_speed_m_s"]


def test_composer_entity_and_arena_come_from_the_backend_mjcf(ant):
    from dm_control import mjcf

    from neuronav.backends.dm_control.composer_env import AntEntity, WorldArena, split_mjcf
    from neuronav.scenarios.odour_trail.scenario import trail_world
    from neuronav.senses.odour import PolylineTrail

    world = trail_world(PolylineTrail(vertices_m=np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]]), width_m=0.3))
    arena_root, ant_root = split_mjcf(world, ant, 0.002)
    arena, entity = WorldArena(arena_root), AntEntity(ant_root)
    assert [a.name for a in entity.actuators] == ant.joint_names
    free_joint = arena.add_ant(entity, free=True)
    physics = mjcf.Physics.from_mjcf_model(arena.mjcf_model)
    model = physics.model
    assert [model.id2name(i, "actuator") for i in range(model.nu)] == ["ant/" + j for j in ant.joint_names]
    assert model.jnt_type[model.name2id(free_joint, "joint")] == 0  # mjJNT_FREE, on the attachment frame
    # The ant's bodies weigh what the spec says (MJCF text: 6 significant digits), the world is the world's.
    ant_bodies = [i for i in range(model.nbody) if model.id2name(i, "body").startswith("ant/")]
    assert model.body_mass[ant_bodies].sum() == pytest.approx(ant.total_mass_kg, rel=1e-5)
    assert "trails" in [model.id2name(i, "texture") for i in range(model.ntex)]
    assert model.opt.timestep == 0.002
