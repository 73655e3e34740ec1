"""Several ants in one world (backends/mujoco/swarm.py, backends/pybullet/swarm.py): prefixed names, ants
that collide with each other, and per-ant reads that match a single-ant run when the ants are far apart."""

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("pybullet")

import neuronav.backends.mujoco.swarm as swarm  # noqa: E402
from neuronav.backends.mujoco import MujocoBackend  # noqa: E402
from neuronav.backends.pybullet import PybulletBackend  # noqa: E402
from neuronav.backends.pybullet.swarm import PybulletSwarm  # noqa: E402
from neuronav.bodies.desert_ant import desert_ant  # noqa: E402
from neuronav.bodies.gaits import make_gait  # noqa: E402
from neuronav.errors import ConfigError  # noqa: E402
from neuronav.spec.world import Ground, World  # noqa: E402

WORLD = World(ground=Ground(size_m=80.0))
PUSH_N = 250.0
THORAX_RADIUS_M = 0.0664  # the desert ant's thorax capsule (bodies/desert_ant)


@pytest.fixture(scope="module")
def ant():
    return desert_ant()


def test_every_ant_element_is_prefixed_and_the_world_is_not(ant):
    backend = swarm.MujocoSwarm()
    backend.load(WORLD, [ant] * 3)
    import mujoco

    model = backend.model
    bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(1, model.nbody)]
    assert len(bodies) == 3 * len(ant.segments)
    for index in range(3):
        prefix = f"ant{index}/"
        assert sorted(b[len(prefix):] for b in bodies if b.startswith(prefix)) == sorted(s.name for s in ant.segments)
        joints = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in backend._actuators[index]]
        assert joints == [prefix + name for name in ant.joint_names]
    geoms = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) for i in range(model.ngeom)]
    assert "world/ground" in geoms
    assert all(g.startswith(("ant0/", "ant1/", "ant2/", "world/")) for g in geoms)
    assert backend.capabilities.batched
    assert backend.read(["joint_pos"])["joint_pos"].shape == (3, len(ant.joints))


SWARMS = {"mujoco": (swarm.MujocoSwarm, MujocoBackend), "pybullet": (PybulletSwarm, PybulletBackend)}


def _push_together(ant, masks=None, steps=400, engine="mujoco"):
    """Two ants side by side 1.6 m apart, their thoraces pushed toward each other with PUSH_N for 1.6 s:
    the distances between their root frames, the deepest overlap between them, whether both touched."""
    backend = SWARMS[engine][0]()
    if masks is not None:
        original, swarm.ant_collision_masks = swarm.ant_collision_masks, masks
    try:
        backend.load(WORLD, [ant, ant])
    finally:
        if masks is not None:
            swarm.ant_collision_masks = original
    backend.reset(position_m=[(0.0, -0.8), (0.0, 0.8)], yaw_rad=[0.0, 0.0])
    gaps, overlap, touched = [], 0.0, False
    for _ in range(steps):
        backend.apply_force(0, "thorax", (0.0, PUSH_N, 0.0))
        backend.apply_force(1, "thorax", (0.0, -PUSH_N, 0.0))
        backend.step(2)
        root = backend.read(["body_pos"])["body_pos"]
        gaps.append(np.linalg.norm(root[1] - root[0]) * np.sign(root[1, 1] - root[0, 1]))
        overlap = max(overlap, backend.ant_overlap_m())
        touched |= bool(backend.ant_contacts().all())
    return np.array(gaps), overlap, touched


@pytest.mark.parametrize("engine", sorted(SWARMS))
def test_two_ants_pushed_into_each_other_do_not_interpenetrate(ant, engine):
    gaps, overlap, touched = _push_together(ant, engine=engine)
    assert touched, "the pushed ants never touched"
    # The thoraces stay at least two thorax radii apart (MuJoCo 0.19 m, PyBullet 0.15 m: one rides a little
    # higher); MuJoCo's soft contacts give under 3 cm at 250 N, PyBullet's rigid ones under 1 mm.
    assert gaps.min() > 2 * THORAX_RADIUS_M
    assert overlap < 0.04


def test_without_the_ant_bits_the_same_push_passes_one_ant_through_the_other(ant):
    """The single-ant rule (body geoms touch only the world) lets them cross: what the masks prevent."""
    gaps, overlap, touched = _push_together(ant, masks=lambda index: (1, 0))
    assert not touched and overlap == 0.0
    assert gaps.min() < 0.0


def test_ant_masks_touch_the_world_and_other_ants_but_not_themselves():
    masks = [swarm.ant_collision_masks(i) for i in range(swarm.MAX_ANTS)]
    world = (1, 1)
    for i, (contype_i, affinity_i) in enumerate(masks):
        assert contype_i & world[1] or world[0] & affinity_i
        assert not (contype_i & affinity_i)
        for j, (contype_j, affinity_j) in enumerate(masks):
            if i != j:
                assert (contype_i & affinity_j) or (contype_j & affinity_i)


@pytest.mark.parametrize("engine", sorted(SWARMS))
def test_far_apart_ants_read_what_single_ant_runs_read(ant, engine):
    starts, yaws = [(0.0, 0.0), (20.0, 5.0)], [0.3, -2.0]
    turns = [0.0, 0.6]
    swarm_class, single_class = SWARMS[engine]
    backend = swarm_class()
    backend.load(WORLD, [ant, ant])
    backend.reset(position_m=starts, yaw_rad=yaws)
    gaits = [make_gait("tripod", ant) for _ in starts]
    for _ in range(125):  # 1 s: 125 control steps of 4 physics steps
        backend.write({"joint_targets": np.stack([g.step(t, np.radians(15)) for g, t in zip(gaits, turns)])})
        backend.step(4)
    names = ("position", "heading", "body_quat", "velocity", "joint_pos", "joint_vel")
    together = backend.read(names)
    for index, (start, yaw, turn) in enumerate(zip(starts, yaws, turns)):
        single, gait = single_class(), make_gait("tripod", ant)
        single.load(WORLD, [ant])
        single.reset(position_m=start, yaw_rad=yaw)
        for _ in range(125):
            single.write({"joint_targets": gait.step(turn, np.radians(15))})
            single.step(4)
        alone = single.read(names)
        assert np.linalg.norm(alone["position"][0] - start) > 0.2  # it walked
        # MuJoCo solves both ants' contacts as one problem (differences ~1e-8 m); PyBullet gives the same bits.
        for name in names:
            np.testing.assert_allclose(together[name][index], alone[name][0], atol=1e-6, err_msg=name)


def test_bad_swarms_and_starts_are_refused_with_what_is_allowed(ant):
    with pytest.raises(ConfigError, match="1 to 31 BodySpecs"):
        swarm.MujocoSwarm().load(WORLD, [ant] * 32)
    backend = swarm.MujocoSwarm()
    backend.load(WORLD, [ant] * 2)
    with pytest.raises(ConfigError, match=r"position_m must be"):
        backend.reset(position_m=[(0.0, 0.0)] * 3)
    with pytest.raises(ConfigError, match="adhesion"):
        swarm.MujocoSwarm().load(World(adhesion_n=10.0), [ant] * 2)
    with pytest.raises(ConfigError, match="adhesion"):
        PybulletSwarm().load(World(adhesion_n=10.0), [ant] * 2)
    pybullet = PybulletSwarm()
    pybullet.load(WORLD, [ant] * 2)
    with pytest.raises(ConfigError, match=r"position_m must be"):
        pybullet.reset(position_m=[(0.0, 0.0)] * 3)
    with pytest.raises(ConfigError, match="no segment 'wing'"):
        pybullet.apply_force(1, "wing", (0.0, 0.0, 1.0))


@pytest.mark.parametrize("engine", sorted(SWARMS))
def test_reads_have_the_agent_axis_first_like_the_kinematic_backend(ant, engine):
    from neuronav.backends.kinematic import KinematicBackend

    backend = SWARMS[engine][0]()
    backend.load(WORLD, [ant] * 3)
    assert backend.capabilities.batched and backend.batch == 3
    specs = {spec.name: spec for spec in backend.capabilities.sensors}
    readings = backend.read(list(specs))
    for name, spec in specs.items():
        assert readings[name].shape == (3, *spec.shape), name
    # The point agents' ports the CX reads have the same per-agent shapes: batch=N binds alike.
    for spec in KinematicBackend.capabilities.sensors:
        if spec.name in ("heading", "position", "velocity"):
            assert specs[spec.name].shape == spec.shape
    # The default starts: a row 2 m apart along +x, facing +x (heading pi/2 clockwise from +y).
    np.testing.assert_allclose(readings["position"], [[0.0, 0.0], [2.0, 0.0], [4.0, 0.0]], atol=1e-9)
    np.testing.assert_allclose(readings["heading"], np.pi / 2, atol=1e-9)
