"""The sky compass's backend primitives on every backend: the head's pose (``head_pos``, ``head_quat``)
and ``cast_rays`` (first-hit distances against the world, the body's own geoms left out)."""

import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.errors import ConfigError
from neuronav.spec.body import BodySpec, Geom, Joint, Segment, Site, axis_angle_quat, quat_to_matrix
from neuronav.spec.world import Ground, PointAgents, World, WorldObject

PHYSICS = ["mujoco", "pybullet"]
HEAD_OFFSET_M = (0.12, 0.0, 0.03)  # the head segment's origin in the root frame
# Rays (origin, direction, distance) in WORLD: a box face, a cylinder's side, the open sky, the ground.
BOX = WorldObject("box", (2.0, 0.0, 1.0), (0.5, 0.5, 0.5))
CYLINDER = WorldObject("cylinder", (0.0, 3.0, 1.0), (0.5, 1.0))
# A roof, bottom face at z = 2.5, so wide that every ray under it is cast from inside the body.
OVERHEAD = WorldObject("box", (0.0, 0.0, 3.0), (3.0, 3.0, 0.5))
WORLD = World(objects=(BOX, CYLINDER))


def _cylinder_diagonal() -> float:
    """From (-1, 1.4) along (1, 1)/√2 onto the circle of radius 0.5 about (0, 3): the cylinder's side."""
    o, d = np.array([-1.0, 1.4 - 3.0]), np.array([1.0, 1.0]) / np.sqrt(2.0)
    b = o @ d
    return float(-b - np.sqrt(b * b - (o @ o - 0.25)))


RAYS = [((0.5, 0.0, 1.0), (1.0, 0.0, 0.0), 1.0),  # the box's -x face at x = 1.5
        ((0.0, 0.4, 1.2), (0.0, 2.0, 0.0), 2.1),  # the cylinder's side at y = 2.5; not a unit direction
        ((-3.0, -3.0, 1.0), (0.0, 0.0, 1.0), np.inf),  # the open sky
        ((-4.0, 2.0, 1.5), (0.0, 0.6, -0.8), 1.875),  # the ground
        ((-1.0, 1.4, 0.7), (1.0, 1.0, 0.0), _cylinder_diagonal()),
        ((0.5, 0.45, 1.45), (1.0, 0.0, 0.0), 1.0)]  # near the box face's corner


def require(name):
    pytest.importorskip(name, reason=f"{name} is not installed")


def head_body(head_quat=(1.0, 0.0, 0.0, 0.0), pitch_rad=0.0, head="head") -> BodySpec:
    """A box on two feet with a ``head`` segment on a pitch hinge (axis -y: positive is nose up, as the
    desert ant's) whose sphere holds the head's origin; ``head_quat`` turns the head's frame; ``head``
    names that segment."""
    root = Segment("root", None, (Geom("box", (0.1, 0.06, 0.03)),), 1.0)
    # The skull off the head's origin (which it holds): a centre of mass away from the segment's frame.
    head = Segment(head, "root", (Geom("sphere", (0.03,), pos_m=(0.015, 0.0, 0.01), name="skull"),), 0.1,
                   Joint("head_pitch", axis=(0.0, -1.0, 0.0), range_rad=(-1.0, 1.0), rest_rad=pitch_rad, kp=5.0,
                         kd=0.1), pos_m=HEAD_OFFSET_M, quat=tuple(head_quat))
    feet = tuple(Segment(f"foot_{side}", "root", (Geom("sphere", (0.02,), name=f"ball_{side}"),), 0.05,
                         Joint(f"fix_{side}", kind="fixed"), pos_m=(-0.05, sign * 0.05, -0.05))
                 for side, sign in (("l", 1.0), ("r", -1.0)))
    sites = (Site("foot_l", "foot_l", kind="contact", geom="ball_l"), Site("foot_r", "foot_r", kind="contact",
                                                                           geom="ball_r"))
    return BodySpec("header", (root, head, *feet), sites, spawn_height_m=0.1)


def physics(name, world=WORLD, body=None):
    require(name)
    backend = registry.load("backend", name)()
    backend.load(world, [body or head_body()])
    return backend


def kinematic(world=WORLD, count=1, **kwargs):
    backend = registry.load("backend", "kinematic")()
    backend.load(world, [PointAgents(count=count, **kwargs)])
    return backend


def forward_azimuth(quat) -> float:
    """The +x axis of a (w, x, y, z) rotation, clockwise from +y (the protocol's heading)."""
    x_axis = quat_to_matrix(quat)[:, 0]
    return float(np.arctan2(x_axis[0], x_axis[1]))


def wrapped(angle):
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


# -- the head's pose ------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", PHYSICS)
@pytest.mark.parametrize("yaw_rad", [0.0, 1.0, -2.5, 3.0])
def test_head_x_axis_points_along_the_heading_on_flat_ground(name, yaw_rad):
    backend = physics(name, body=head_body(pitch_rad=0.4))
    backend.reset(yaw_rad=yaw_rad)
    values = backend.read(["heading", "head_quat", "head_pos"])
    quat = values["head_quat"][0]
    assert quat.shape == (4,) and quat[0] >= 0 and abs(np.linalg.norm(quat) - 1.0) < 1e-6
    assert abs(wrapped(forward_azimuth(quat) - values["heading"][0, 0])) < 1e-6
    assert abs(wrapped(values["heading"][0, 0] - (np.pi / 2 - yaw_rad))) < 1e-6
    assert quat_to_matrix(quat)[2, 0] == pytest.approx(np.sin(0.4), abs=1e-6)  # nose up by the hinge's rest
    backend.close()


def test_kinematic_head_follows_each_agents_heading_at_its_head_height():
    headings = np.array([0.0, 0.5, -1.2, np.pi, -np.pi + 1e-3, 2.0 * np.pi + 0.3])
    backend = kinematic(count=headings.size, head_height_m=0.7)
    positions = np.arange(2 * headings.size, dtype=float).reshape(-1, 2)
    backend.reset(heading_rad=headings, position_m=positions)
    values = backend.read(["heading", "head_quat", "head_pos"])
    assert values["head_pos"].shape == (headings.size, 3) and values["head_quat"].shape == (headings.size, 4)
    np.testing.assert_allclose(values["head_pos"], np.column_stack([positions, np.full(headings.size, 0.7)]))
    assert (values["head_quat"][:, 0] >= 0).all()
    for quat, heading in zip(values["head_quat"], values["heading"][:, 0]):
        assert abs(np.linalg.norm(quat) - 1.0) < 1e-12
        assert abs(wrapped(forward_azimuth(quat) - heading)) < 1e-9
        np.testing.assert_allclose(quat_to_matrix(quat)[:, 2], [0.0, 0.0, 1.0], atol=1e-12)  # upright


@pytest.mark.parametrize("value", [-0.1, float("nan"), float("inf"), "0.5", True])
def test_point_agents_refuse_a_bad_head_height(value):
    with pytest.raises(ConfigError, match="head_height_m"):
        PointAgents(head_height_m=value)


@pytest.mark.parametrize("pitch_rad", [0.0, 0.6, -0.5])
def test_head_pose_is_the_segment_frame_with_its_joint_the_same_on_mujoco_and_pybullet(pitch_rad):
    """The head's frame (turned 0.7 rad about z and 0.3 about x against the root, so that an engine's
    link frame that is not the segment's would show) = root ∘ (offset, quat) ∘ hinge(pitch)."""
    head_quat = tuple(np.round(np.array(axis_angle_quat((0, 0, 1), 0.7)), 12))
    tilt = axis_angle_quat((1, 0, 0), 0.3)
    quat = tuple(np.array(_product(head_quat, tilt)))
    poses = {}
    for name in PHYSICS:
        backend = physics(name, body=head_body(head_quat=quat, pitch_rad=pitch_rad))
        backend.reset(yaw_rad=0.4)
        values = backend.read(["body_pos", "body_quat", "head_pos", "head_quat"])
        root = quat_to_matrix(values["body_quat"][0])
        expected = root @ quat_to_matrix(quat) @ quat_to_matrix(axis_angle_quat((0, -1, 0), pitch_rad))
        np.testing.assert_allclose(quat_to_matrix(values["head_quat"][0]), expected, atol=1e-6)
        np.testing.assert_allclose(values["head_pos"][0], values["body_pos"][0] + root @ HEAD_OFFSET_M, atol=1e-6)
        poses[name] = values["head_pos"][0], values["head_quat"][0]
        backend.close()
    np.testing.assert_allclose(poses["mujoco"][0], poses["pybullet"][0], atol=1e-6)
    np.testing.assert_allclose(poses["mujoco"][1], poses["pybullet"][1], atol=1e-6)


def _product(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


@pytest.mark.parametrize("name", PHYSICS)
def test_driving_the_head_joint_pitches_head_quat(name):
    backend = physics(name)
    backend.write({"joint_targets": np.array([0.5])})
    backend.step(400)
    values = backend.read(["joint_pos", "body_quat", "head_quat"])
    angle = values["joint_pos"][0, 0]
    assert angle > 0.3  # it moved toward the target
    relative = quat_to_matrix(values["body_quat"][0]).T @ quat_to_matrix(values["head_quat"][0])
    np.testing.assert_allclose(relative, quat_to_matrix(axis_angle_quat((0, -1, 0), angle)), atol=1e-5)
    backend.close()


@pytest.mark.parametrize("name", PHYSICS)
def test_a_body_without_a_head_segment_reports_the_roots_pose(name):
    backend = physics(name, body=head_body(pitch_rad=0.4, head="snout"))
    values = backend.read(["body_pos", "body_quat", "head_pos", "head_quat"])
    np.testing.assert_array_equal(values["head_pos"], values["body_pos"])
    np.testing.assert_array_equal(values["head_quat"], values["body_quat"])
    backend.close()


# -- rays ------------------------------------------------------------------------------------------------

def every_backend(world=WORLD):
    yield "kinematic", kinematic(world)
    for name in PHYSICS:
        yield name, physics(name, world)


def test_rays_hit_a_box_a_cylinder_and_the_ground_at_their_distances_and_miss_the_sky():
    origins = np.array([r[0] for r in RAYS])
    directions = np.array([r[1] for r in RAYS])
    expected = np.array([r[2] for r in RAYS])
    for name, backend in every_backend():
        distances = backend.cast_rays(origins, directions)
        assert distances.shape == (len(RAYS),), name
        assert np.isinf(distances[2]), name
        finite = np.isfinite(expected)
        np.testing.assert_allclose(distances[finite], expected[finite], atol=1e-3, err_msg=name)
        # One by one, the same numbers.
        single = np.concatenate([backend.cast_rays(origins[k:k + 1], directions[k]) for k in range(len(RAYS))])
        np.testing.assert_array_equal(single, distances, err_msg=name)
        # Beyond max_distance_m: no hit.
        assert np.isinf(backend.cast_rays(origins[:1], directions[:1], max_distance_m=0.9)).all(), name
        backend.close()


def test_rays_see_the_objects_where_the_scene_yaw_turned_them():
    for name, backend in every_backend():
        backend.set_scene_yaw(np.pi / 2)  # the box now stands at (0, 2, 1)
        distances = backend.cast_rays([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0]], [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
        assert distances[0] == pytest.approx(1.5, abs=1e-3), name
        assert np.isinf(distances[1]), name
        backend.close()


@pytest.mark.parametrize("name", PHYSICS)
def test_the_body_never_blocks_its_own_rays(name):
    backend = physics(name, World(objects=(OVERHEAD,)))
    values = backend.read(["head_pos", "body_pos"])
    head, root = values["head_pos"][0], values["body_pos"][0]
    origins = [head, root, root, root - [1.0, 0.0, 0.0]]
    directions = [[0, 0, 1], [0, 0, 1], [0, 0, -1], [1, 0, 0]]
    distances = backend.cast_rays(origins, directions, max_distance_m=5.0)
    # Up from inside the head's and the root's geoms to the roof; down through the body to the ground;
    # along the body from behind it: past it, into the open (under the roof).
    np.testing.assert_allclose(distances[:3], [2.5 - head[2], 2.5 - root[2], root[2]], atol=1e-3)
    assert np.isinf(distances[3])
    backend.close()


@pytest.mark.parametrize("name", PHYSICS)
def test_the_desert_ant_sees_the_roof_from_inside_its_head(name):
    backend = physics(name, World(objects=(OVERHEAD,)), desert_ant())
    values = backend.read(["head_pos", "head_quat"])
    head, up = values["head_pos"][0], quat_to_matrix(values["head_quat"][0])[:, 2]
    distances = backend.cast_rays(np.repeat(values["head_pos"], 3, axis=0), [[0, 0, 1], up, [0.3, -0.2, 1.0]])
    expected = (2.5 - head[2]) / (np.array([1.0, up[2], 1.0 / np.linalg.norm([0.3, -0.2, 1.0])]))
    np.testing.assert_allclose(distances, expected, atol=1e-3)
    backend.close()


def test_a_ray_leaving_near_an_objects_centre_still_hits_it():
    """From under the roof's edge, outward and up (away from the roof's centre): it meets the roof."""
    for name, backend in every_backend(World(objects=(OVERHEAD,))):
        distance = backend.cast_rays([[2.5, 0.0, 2.3]], [[1.0, 0.0, 1.0]])[0]
        assert distance == pytest.approx(0.2 * np.sqrt(2.0), abs=1e-3), name
        backend.close()


@pytest.mark.parametrize("name", PHYSICS)
def test_physics_rays_hit_the_wall(name):
    backend = physics(name, World(ground=Ground(kind="wall", wall_distance_m=1.5)))
    root = backend.read(["body_pos"])["body_pos"][0]
    # Above the body; away from the wall; from behind the body through it (a wall world casts every
    # ray from its origin: the engine itself must leave the body out).
    distances = backend.cast_rays([[0.0, 0.0, 0.5], [0.0, 0.0, 0.5], root - [0.5, 0.0, 0.0]],
                                  [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    np.testing.assert_allclose(distances[[0, 2]], [1.5, 2.0 - root[0]], atol=1e-3)
    assert np.isinf(distances[1])
    backend.close()


@pytest.mark.parametrize("name", PHYSICS)
def test_physics_rays_meet_uneven_ground_at_its_height_and_a_turned_object(name):
    """Rays cast down onto a heightfield meet it where the ground's surface is (between its samples the engines
    interpolate planar triangles: within a few mm of ``height_at``), and an object turned with the scene."""
    ground = Ground(kind="uneven", roughness_m=0.2, size_m=20.0, seed=3)
    backend = physics(name, World(ground=ground, objects=(BOX,)))
    xy = np.array([[3.0, -4.0], [-5.0, 2.5], [6.5, 6.0], [-2.0, -7.0]])
    origins = np.column_stack([xy, np.full(len(xy), 5.0)])
    distances = backend.cast_rays(origins, np.tile([0.0, 0.0, -1.0], (len(xy), 1)))
    np.testing.assert_allclose(5.0 - distances, ground.height_at(xy[:, 0], xy[:, 1]), atol=0.02)
    backend.set_scene_yaw(np.pi)  # the box now stands at (-2, 0, 1)
    assert backend.cast_rays([[-2.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]])[0] == pytest.approx(3.5, abs=1e-3)
    backend.close()


@pytest.mark.parametrize("scene_yaw_rad", [0.0, np.pi / 2])
def test_pybullet_rays_meet_the_surfaces_the_physics_collides_with(scene_yaw_rad):
    """PyBullet casts rays in a client of the world's surfaces alone (no body; boxes and cones as triangle meshes
    of the same surface): rays meet a cone's 32-sided hull at a vertex, its apex, a box and a sphere where
    geometry puts them and where the physics client's own ray test (the body masked out) meets them."""
    require("pybullet")
    from neuronav.backends.pybullet.engine import pb

    cone = WorldObject("cone", (1.0, -2.0, 1.0), (0.6, 1.0))  # radius 0.3 at its centre's height
    sphere = WorldObject("sphere", (-2.0, 1.0, 1.0), (0.7,))
    backend = physics("pybullet", World(objects=(BOX, cone, sphere)))
    backend.set_scene_yaw(scene_yaw_rad)
    turn = np.array([[np.cos(scene_yaw_rad), -np.sin(scene_yaw_rad), 0.0],
                     [np.sin(scene_yaw_rad), np.cos(scene_yaw_rad), 0.0], [0.0, 0.0, 1.0]])
    # (origin, direction) in the objects' declared frame, the distance geometry gives
    rays = [((3.0, -2.0, 1.0), (-1.0, 0.0, 0.0), 1.7),  # the cone's side at a vertex of its hull
            ((1.0, -2.0, 2.5), (0.0, 0.0, -1.0), 0.5),  # down onto its apex
            ((2.0, 0.3, 0.2), (0.0, 0.0, 1.0), 0.3),  # up into the box's bottom
            ((-2.0, 3.0, 1.0), (0.0, -1.0, 0.0), 1.3)]  # the sphere's side
    origins = np.array([r[0] for r in rays]) @ turn.T
    directions = np.array([r[1] for r in rays]) @ turn.T
    distances = backend.cast_rays(origins, directions, max_distance_m=5.0)
    np.testing.assert_allclose(distances, [r[2] for r in rays], atol=1e-3)
    found = pb.rayTestBatch(origins.tolist(), (origins + 5.0 * directions).tolist(), collisionFilterMask=~1,
                            physicsClientId=backend.client_id)
    np.testing.assert_allclose(distances, [5.0 * hit[2] for hit in found], atol=2e-3)
    backend.close()


def test_kinematic_rays_of_a_thousand_agents_are_one_call_and_each_agents_own():
    rng = np.random.default_rng(3)
    world = World(objects=(BOX, CYLINDER, OVERHEAD, WorldObject("sphere", (-2.0, -1.0, 1.0), (0.6,)),
                           WorldObject("cone", (1.0, -3.0, 1.0), (0.7, 1.0))))
    backend = kinematic(world, count=1000)
    backend.reset(position_m=rng.uniform(-4.0, 4.0, (1000, 2)), heading_rad=rng.uniform(-np.pi, np.pi, 1000))
    heads = backend.read(["head_pos"])["head_pos"]
    directions = rng.normal(size=(1000, 30, 3))
    origins = np.repeat(heads[:, None], 30, axis=1)
    distances = backend.cast_rays(origins.reshape(-1, 3), directions.reshape(-1, 3)).reshape(1000, 30)
    assert np.isfinite(distances).any() and np.isinf(distances).any()
    for agent in rng.choice(1000, 20, replace=False):
        np.testing.assert_array_equal(backend.cast_rays(origins[agent], directions[agent]), distances[agent])


@pytest.mark.parametrize("bad, match", [
    (dict(origins_m=np.zeros((2, 2))), "origins_m"),
    (dict(directions=np.zeros((2, 3, 1))), "directions"),
    (dict(origins_m=[[0.0, 0.0, np.nan]] * 2), "origins_m"),
    (dict(directions=[[0.0, np.inf, 1.0]] * 2), "directions"),
    (dict(directions=[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]), "directions"),
    (dict(origins_m=np.zeros((3, 3))), "origins_m"),
    (dict(origins_m="here"), "origins_m"),
    (dict(max_distance_m=0.0), "max_distance_m"),
    (dict(max_distance_m=float("nan")), "max_distance_m"),
])
def test_bad_rays_are_refused_naming_the_argument(bad, match):
    arguments = dict(origins_m=np.zeros((2, 3)), directions=[[0.0, 0.0, 1.0]] * 2, max_distance_m=10.0)
    arguments.update(bad)
    for _, backend in every_backend():
        with pytest.raises(ConfigError, match=match):
            backend.cast_rays(**arguments)
        backend.close()
