"""The MuJoCo backend: model built from the spec, control law, sensors, world, cameras, errors."""

import dataclasses
import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
mujoco = pytest.importorskip("mujoco")

from neuronav.backends.mujoco import MujocoBackend  # noqa: E402
from neuronav.backends.mujoco.mjcf import matrix_to_quat, to_xml  # noqa: E402
from neuronav.engine.articulated import rest_bounds  # noqa: E402
from neuronav.engine.backend import Backend  # noqa: E402
from neuronav.errors import ConfigError, PortError, SimulationError  # noqa: E402
from neuronav.spec.body import BodySpec, Camera, Geom, Joint, Segment, Site, axis_angle_quat, quat_to_matrix  # noqa: E402
from neuronav.spec.world import Ground, World, WorldObject  # noqa: E402

G = 9.81
# A camera looking along the body's +x with image-up +z: its (x, y, z) axes in the body frame as columns.
FORWARD_CAMERA = tuple(matrix_to_quat(np.column_stack([[0, -1, 0], [0, 0, 1], [-1, 0, 0]])))


def small_body(root_joint=None, kp=20.0, kd=0.5, max_torque_nm=5.0) -> BodySpec:
    """A box on a rear skid and two 2-segment side legs ending in sphere claws (a statically determinate tripod)."""
    segments = [Segment("root", None, (Geom("box", (0.1, 0.05, 0.03), name="torso"),
                                       Geom("sphere", (0.02,), pos_m=(-0.12, 0.0, -0.095), name="skid")),
                        1.0, joint=root_joint)]
    sites = []
    for side, sign in (("L", 1.0), ("R", -1.0)):
        gains = dict(kp=kp, kd=kd, max_torque_nm=max_torque_nm, damping=0.01, armature=0.001)
        femur = Geom("capsule", (0.01, 0.05), pos_m=(0.0, sign * 0.05, 0.0),
                     quat=axis_angle_quat((1, 0, 0), -sign * np.pi / 2))
        segments.append(Segment(f"{side}_femur", "root", (femur,), 0.1, pos_m=(0.05, sign * 0.05, 0.0),
                                joint=Joint(f"{side}_hip", axis=(1, 0, 0), range_rad=(-1.5, 1.4), **gains)))
        tibia = (Geom("capsule", (0.008, 0.05), pos_m=(0.0, 0.0, -0.05)),
                 Geom("sphere", (0.015,), pos_m=(0.0, 0.0, -0.1), name="claw"))
        segments.append(Segment(f"{side}_tibia", f"{side}_femur", tibia, 0.05, pos_m=(0.0, sign * 0.1, 0.0),
                                joint=Joint(f"{side}_knee", axis=(1, 0, 0), range_rad=(-1.2, 1.3), **gains)))
        sites.append(Site(f"{side}_claw", f"{side}_tibia", (0.0, 0.0, -0.1), kind="contact", geom="claw",
                          adhesive=True))
        sites.append(Site(f"{side}_smell", f"{side}_femur", (0.0, sign * 0.05, 0.01), kind="odour"))
    sites.append(Site("nose", "root", (0.1, 0.0, 0.0), kind="wind"))
    cameras = (Camera("eye", "root", (0.11, 0.0, 0.03), FORWARD_CAMERA, 64, 16, (1.6, 0.4)),
               Camera("pano", "root", (0.0, 0.0, 0.05), FORWARD_CAMERA, 48, 24, (2 * np.pi, np.pi / 2), "spherical"))
    # Claw and skid bottoms 0.115 m below the root at rest.
    return BodySpec("tripod_bot", tuple(segments), tuple(sites), cameras, spawn_height_m=0.116)


def loaded(world=None, body=None, **kwargs) -> MujocoBackend:
    backend = MujocoBackend(**kwargs)
    backend.load(world or World(), [body or small_body()])
    return backend


def ray(backend, start, direction):
    """(distance, geom name) of the first world geom hit from ``start`` along ``direction``."""
    geom = np.array([-1], dtype=np.int32)
    world_only = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)  # body geoms are in group 1
    distance = mujoco.mj_ray(backend.model, backend.data, np.asarray(start, float), np.asarray(direction, float),
                             world_only, 1, -1, geom)
    return distance, mujoco.mj_id2name(backend.model, mujoco.mjtObj.mjOBJ_GEOM, int(geom[0]))


def red_columns(image, channel=0):
    """Columns of the pixels that are clearly ``channel``-coloured (red, green or blue)."""
    image = image.astype(int)
    others = [c for c in range(3) if c != channel]
    mask = (image[..., channel] - image[..., others[0]] > 90) & (image[..., channel] - image[..., others[1]] > 90)
    return np.nonzero(mask)[1]


# -- load, read, write ----------------------------------------------------------------------------
def test_load_step_read_shapes_and_capabilities():
    backend = MujocoBackend()
    assert isinstance(backend, Backend)
    assert backend.capabilities.name == "mujoco" and not backend.capabilities.batched
    assert all(s.shape in ((1,), (1, 1), (1, 2), (1, 3)) or len(s.shape) <= 1 for s in backend.capabilities.sensors)
    with pytest.raises(SimulationError):
        backend.step()
    backend.load(World(), [small_body()])
    sensors = {s.name: s.shape for s in backend.capabilities.sensors}
    assert sensors == {"joint_pos": (4,), "joint_vel": (4,), "joint_torque": (4,), "contact_force": (2, 3),
                       "contact_load": (2,), "body_pos": (3,), "body_quat": (4,), "body_linvel": (3,),
                       "body_angvel": (3,),
                       "heading": (1,), "velocity": (2,), "position": (2,), "head_pos": (3,), "head_quat": (4,),
                       "odour_sites": (2, 3),
                       "wind_sites": (1, 3), "odour": (2, 1), "wind": (1, 2), "eye": (16, 64), "pano": (24, 48)}
    assert [(m.name, m.shape) for m in backend.capabilities.motors] == [("joint_targets", (4,)), ("adhesion", (2,))]
    backend.step(10)
    assert backend.time == pytest.approx(10 * 0.002)
    assert backend.timestep == 0.002
    values = backend.read(list(sensors))
    for name, shape in sensors.items():
        assert values[name].shape == (1, *shape), name
        assert np.all(np.isfinite(values[name])), name
    assert list(backend.read(["heading"])) == ["heading"]  # lazy: only what is asked
    np.testing.assert_allclose(values["odour_sites"][0], backend.data.site_xpos[backend._odour])
    backend.close()


def test_bad_inputs_raise_the_projects_errors():
    with pytest.raises(ConfigError):
        MujocoBackend(timestep_s=0.0)
    backend = MujocoBackend()
    with pytest.raises(ConfigError, match="exactly one BodySpec"):
        backend.load(World(), [small_body(), small_body()])
    with pytest.raises(ConfigError, match="exactly one BodySpec"):
        backend.load(World(), [])
    backend.load(World(), [small_body()])
    for bad in (np.zeros(3), np.zeros((2, 4)), np.zeros((1, 5))):
        with pytest.raises(PortError, match="joint_targets"):
            backend.write({"joint_targets": bad})
    backend.write({"joint_targets": np.zeros(4)})
    backend.write({"joint_targets": np.zeros((1, 4))})
    with pytest.raises(PortError):
        backend.write({"torques": np.zeros(4)})
    with pytest.raises(PortError):
        backend.read(["nonsense"])
    with pytest.raises(PortError, match="follow"):
        backend.render("no_such_camera")
    with pytest.raises(ConfigError):
        backend.apply_force(1, "nose", (0, 0, 1))
    with pytest.raises(ConfigError, match="unknown site"):
        backend.apply_force(0, "tail", (0, 0, 1))
    with pytest.raises(ConfigError):
        backend.apply_force(0, "nose", (0, 1))
    with pytest.raises(ConfigError, match="position_m"):
        backend.reset(position_m=(0.0, 1.0, 2.0, 3.0))
    with pytest.raises(ConfigError):
        backend.step(-1)


# -- the model matches the spec ---------------------------------------------------------------------
def test_masses_inertia_and_joints_match_the_spec():
    body = small_body()
    backend = loaded(body=body)
    model = backend.model
    assert model.body_mass.sum() == pytest.approx(body.total_mass_kg, abs=1e-12)
    for segment in body.segments:
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, segment.name)
        assert model.body_mass[index] == pytest.approx(segment.mass_kg, abs=1e-12)
        com, inertia, _ = segment.inertial()
        np.testing.assert_allclose(model.body_ipos[index], com, atol=1e-9)
        rotation = quat_to_matrix(model.body_iquat[index])
        np.testing.assert_allclose(rotation @ np.diag(model.body_inertia[index]) @ rotation.T, inertia, atol=1e-9)
    for joint in body.joints:
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        assert model.jnt_type[index] == mujoco.mjtJoint.mjJNT_HINGE
        np.testing.assert_allclose(model.jnt_axis[index], np.asarray(joint.axis) / np.linalg.norm(joint.axis))
        np.testing.assert_allclose(model.jnt_range[index], joint.range_rad)
        assert model.jnt_limited[index]
        assert model.dof_damping[model.jnt_dofadr[index]] == joint.damping
        assert model.dof_armature[model.jnt_dofadr[index]] == joint.armature
    # joint arrays follow BodySpec.joints order even though MuJoCo numbers the tree depth-first
    backend.load(World(), [dataclasses.replace(body, spawn_height_m=2.0)])  # in the air: nothing resists
    targets = np.array([0.0, 0.0, -0.6, 0.0])  # R_hip only
    backend.write({"joint_targets": targets})
    backend.step(100)
    assert np.argmax(np.abs(backend.read(["joint_pos"])["joint_pos"][0])) == 2
    assert "implicitfast" in to_xml(World(), body)


def test_actuators_apply_exactly_the_clipped_pd_law():
    body = small_body(kp=30.0, kd=0.7, max_torque_nm=0.5)
    backend = loaded(body=body)
    model, data = backend.model, backend.data
    rng = np.random.default_rng(0)
    for _ in range(5):
        data.qpos[backend._qpos] = rng.uniform(-1, 1, 4)
        data.qvel[backend._dof] = rng.uniform(-2, 2, 4)
        targets = rng.uniform(-1, 1, 4)
        backend.write({"joint_targets": targets})
        mujoco.mj_forward(model, data)
        q, qdot = data.qpos[backend._qpos], data.qvel[backend._dof]
        law = np.clip(30.0 * (targets - q) - 0.7 * qdot, -0.5, 0.5)
        np.testing.assert_allclose(data.actuator_force, law, atol=1e-12)
        # gear 1: the actuator torque is exactly the generalised force at the joint
        np.testing.assert_allclose(data.qfrc_actuator[backend._dof], law, atol=1e-12)
        # joint_torque reports the torque applied during the last physics step
        backend.step(1)
        np.testing.assert_allclose(backend.read(["joint_torque"])["joint_torque"][0], law, atol=1e-12)


def test_position_control_holds_a_target_against_gravity():
    body = dataclasses.replace(small_body(root_joint=Joint("base", kind="fixed")), spawn_height_m=1.0)  # hanging
    backend = loaded(body=body)
    assert "body_pos" in backend.read(["body_pos"])
    targets = np.array([0.4, -0.3, -0.4, 0.3])  # both legs raised (mirrored signs), shins bent down
    backend.write({"joint_targets": targets})
    backend.step(750)
    read = backend.read(["joint_pos", "joint_vel", "joint_torque"])
    q = read["joint_pos"][0]
    np.testing.assert_allclose(q, targets, atol=0.03)
    assert not np.allclose(q, targets, atol=1e-6)  # gravity leaves a small steady error ...
    np.testing.assert_allclose(read["joint_vel"][0], 0.0, atol=1e-3)
    torque = read["joint_torque"][0]
    np.testing.assert_allclose(torque, 20.0 * (targets - q) - 0.5 * read["joint_vel"][0], atol=1e-6)
    assert torque[0] > 0 > torque[2]  # ... held by hip torques that lift each leg against gravity


# -- sensors -----------------------------------------------------------------------------------------
def test_resting_claws_carry_their_share_of_the_weight():
    body = small_body()
    backend = loaded(body=body)
    backend.step(600)
    data = backend.data
    force = backend.read(["contact_force"])["contact_force"][0]
    weight = body.total_mass_kg * G
    # Tripod (two claws + skid): moment balance about y gives each claw W/2 (x_com - x_skid) / (x_claw - x_skid).
    x_com = data.subtree_com[backend._root, 0]
    claw = data.geom_xpos[backend._site_geoms[0][0], 0]
    skid = data.geom_xpos[mujoco.mj_name2id(backend.model, mujoco.mjtObj.mjOBJ_GEOM, "root/skid"), 0]
    share = weight / 2.0 * (x_com - skid) / (claw - skid)
    np.testing.assert_allclose(force[:, 2], share, rtol=0.03)
    assert np.all(np.abs(force[:, :2]) < 0.2 * share)
    assert abs(force[0, 1] + force[1, 1]) < 1e-3  # mirror-symmetric sideways friction
    # everything touching the floor carries the whole weight
    total = np.zeros(6)
    wrench = np.zeros(6)
    for i in range(data.ncon):
        mujoco.mj_contactForce(backend.model, data, i, wrench)
        total[:3] += data.contact.frame[i].reshape(3, 3).T @ wrench[:3]
    assert total[2] == pytest.approx(weight, rel=1e-3)


@pytest.mark.parametrize("yaw", [0.0, 0.7, 2.5, -1.2])
def test_heading_is_clockwise_from_y(yaw):
    backend = loaded()
    backend.reset(position_m=(0.3, -0.2), yaw_rad=yaw)
    read = backend.read(["heading", "position", "body_quat"])
    expected = np.angle(np.exp(1j * (np.pi / 2 - yaw)))
    assert np.angle(np.exp(1j * (read["heading"][0, 0] - expected))) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(read["position"][0], (0.3, -0.2))
    np.testing.assert_allclose(read["body_quat"][0], (np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)), atol=1e-12)


def test_body_velocities_are_world_frame():
    backend = loaded(body=dataclasses.replace(small_body(), spawn_height_m=3.0))
    backend.reset(yaw_rad=1.0)
    backend.step(50)  # free fall: 0.1 s
    read = backend.read(["body_linvel", "velocity", "body_angvel"])
    np.testing.assert_allclose(read["body_linvel"][0], (0.0, 0.0, -G * 0.1), atol=1e-6)
    np.testing.assert_allclose(read["velocity"][0], 0.0, atol=1e-9)
    np.testing.assert_allclose(read["body_angvel"][0], 0.0, atol=1e-6)


# -- world ---------------------------------------------------------------------------------------------
def test_uneven_ground_matches_the_heightfield():
    ground = Ground(kind="uneven", roughness_m=0.05, size_m=4.0, cells=33, seed=3)
    backend = loaded(World(ground=ground))
    heights = ground.heights_m()
    axis = np.linspace(-2.0, 2.0, 33)
    for i, j in [(3, 5), (5, 3), (10, 30), (30, 10), (20, 17)]:  # rows y, columns x; both orders differ
        distance, name = ray(backend, (axis[j], axis[i], 5.0), (0, 0, -1))
        assert name == "world/ground"
        assert 5.0 - distance == pytest.approx(heights[i, j], abs=1e-6)
    for x, y in np.random.default_rng(1).uniform(-1.9, 1.9, (10, 2)):
        distance, _ = ray(backend, (x, y, 5.0), (0, 0, -1))
        # MuJoCo interpolates on triangles, Ground.height_at bilinearly: equal at nodes, close between.
        assert 5.0 - distance == pytest.approx(ground.height_at(x, y), abs=0.003)
    backend.reset(position_m=(0.5, -0.3))
    z = backend.read(["body_pos"])["body_pos"][0, 2]
    # At least spawn height above the terrain under it; more only if a part would start inside a bump.
    lifted = z - (ground.height_at(0.5, -0.3) + backend.body.spawn_height_m)
    assert lifted > -1e-9
    assert (lifted < 1e-9) == (not backend.notes)


def test_wall_and_objects_are_where_the_world_says():
    objects = (WorldObject("box", (0.0, 3.0, 0.5), (0.2, 0.3, 0.5)),
               WorldObject("cylinder", (0.0, -3.0, 1.0), (0.25, 1.0)),
               WorldObject("sphere", (-3.0, 0.0, 0.4), (0.4,)),
               WorldObject("cone", (-3.0, 3.0, 0.5), (0.3, 0.5)))
    world = World(ground=Ground(kind="wall", wall_distance_m=1.5, wall_height_m=2.0), objects=objects)
    backend = loaded(world)
    distance, name = ray(backend, (0.0, 0.5, 1.0), (1, 0, 0))
    assert name == "world/wall" and distance == pytest.approx(1.5)
    distance, name = ray(backend, (1.55, 0.0, 10.0), (0, 0, -1))
    assert name == "world/wall" and 10.0 - distance == pytest.approx(2.0)
    for index, (start, top) in enumerate([((0.1, 3.1), 1.0), ((0.1, -3.1), 2.0), ((-3.0, 0.0), 0.8)]):
        distance, name = ray(backend, (*start, 10.0), (0, 0, -1))
        assert name == f"world/object{index}" and 10.0 - distance == pytest.approx(top)
    # the cone (a convex mesh): base radius 0.3 at z 0, apex at z 1; at radius 0.06 it stands 0.8 high
    distance, name = ray(backend, (-3.0 + 0.06 * np.cos(0.05), 3.0 + 0.06 * np.sin(0.05), 10.0), (0, 0, -1))
    assert name == "world/object3" and 10.0 - distance == pytest.approx(0.8, abs=0.005)


def test_adhesion_presses_claws_into_the_surface():
    def claw_force(adhesion_n):
        backend = loaded(World(adhesion_n=adhesion_n))
        backend.step(400)
        return backend.read(["contact_force"])["contact_force"][0, :, 2]

    without, with_adhesion = claw_force(0.0), claw_force(5.0)
    assert np.all(with_adhesion - without > 0.8 * 5.0)
    assert np.all(with_adhesion - without < 1.2 * 5.0 + 2.0)


# -- determinism, divergence, forces -------------------------------------------------------------------
def _trajectory(backend, seed, names=("joint_pos", "body_pos", "joint_torque", "contact_force")):
    backend.reset(seed=seed)
    rows = []
    for k in range(150):
        backend.write({"joint_targets": 0.3 * np.sin(0.05 * k + np.arange(4))})
        backend.step(2)
        rows.append(np.concatenate([v.ravel() for v in backend.read(names).values()]))
    return np.array(rows)


def test_same_seed_same_trajectory_bit_identical():
    backend = loaded(World(adhesion_n=2.0))
    first = _trajectory(backend, seed=4)
    np.testing.assert_array_equal(first, _trajectory(backend, seed=4))
    np.testing.assert_array_equal(first, _trajectory(loaded(World(adhesion_n=2.0)), seed=4))
    assert np.ptp(first[:, :4], axis=0).min() > 0.05  # it moved
    assert np.abs(first[:, -6:]).max() > 1.0  # and touched the ground
    # reading (which may solve the current contacts) never changes what happens next
    quiet = _trajectory(loaded(World(adhesion_n=2.0)), seed=4, names=("joint_pos", "body_pos"))
    np.testing.assert_array_equal(first[:, :7], quiet)


def test_step_equals_raw_mj_step_without_adhesion():
    a, b = loaded(), loaded()
    for backend in (a, b):
        backend.write({"joint_targets": [0.2, -0.1, 0.3, 0.0]})
    a.step(200)
    b.raw_step(200)
    np.testing.assert_array_equal(a.data.qpos, b.data.qpos)
    np.testing.assert_array_equal(a.read(["body_pos"])["body_pos"], b.read(["body_pos"])["body_pos"])


def test_divergence_raises_simulation_error_and_reset_recovers():
    backend = loaded()
    with pytest.raises(PortError, match="finite"):  # the shared write check refuses it up front ...
        backend.write({"joint_targets": [np.nan, 0.0, 0.0, 0.0]})
    backend.data.ctrl[0] = np.nan  # ... so put it in the engine directly: MuJoCo's own check reports it
    with pytest.raises(SimulationError, match="BADCTRL"):
        backend.step(5)
    assert any("BADCTRL" in w for w in backend.warnings)
    backend.write({"joint_targets": np.zeros(4)})
    with pytest.raises(SimulationError, match="reset"):
        backend.step(1)  # stays failed until reset
    backend.reset()
    backend.step(5)  # usable again
    absurd = loaded(body=small_body(kp=1e12, kd=0.0, max_torque_nm=1e12))
    absurd.write({"joint_targets": [1.0, -1.0, 1.0, -1.0]})
    with pytest.raises(SimulationError, match="diverged"):
        absurd.step(200)


def test_apply_force_pushes_the_body_the_right_way_for_one_step_call():
    backend = loaded()
    backend.step(300)
    start = backend.read(["body_pos"])["body_pos"][0]
    backend.apply_force(0, "nose", (0.0, 30.0, 0.0))
    backend.step(25)
    pushed = backend.read(["body_pos", "velocity"])
    assert pushed["body_pos"][0, 1] - start[1] > 0.005
    assert abs(pushed["body_pos"][0, 0] - start[0]) < 0.5 * (pushed["body_pos"][0, 1] - start[1])
    backend.step(25)  # the force is gone: friction slows the slide
    assert backend.read(["velocity"])["velocity"][0, 1] < pushed["velocity"][0, 1]
    # a lift at the nose, ahead of the centre of mass, pitches the nose up (rotation about -y)
    backend.reset()
    backend.step(300)
    backend.apply_force(0, "nose", (0.0, 0.0, 10.0))
    backend.step(10)
    assert backend.read(["body_angvel"])["body_angvel"][0, 1] < -0.05


# -- cameras -------------------------------------------------------------------------------------------
def test_body_camera_honours_both_fields_of_view():
    # Poles 4 m ahead of the eye, straight on and 0.6 rad to the left.
    backend = loaded()
    eye = backend.read(["body_pos"])["body_pos"][0] + (0.11, 0.0, 0.03)  # the camera's mount on the level root
    poles = tuple(WorldObject("cylinder", (eye[0] + 4 * np.cos(a), 4 * np.sin(a), 1.0), (0.12, 1.0), (1, 0, 0, 1))
                  for a in (0.0, 0.6))
    backend = loaded(World(objects=poles))
    image = backend.render("eye")
    assert image.shape == (16, 64, 3) and image.dtype == np.uint8
    assert image.std() > 5
    columns = red_columns(image) + 0.5
    left, centre = columns[columns < 20], columns[columns >= 20]
    assert centre.mean() == pytest.approx(32.0, abs=1.0)
    # the 1.6 rad horizontal FOV on a 64x16 image (non-square pixels): tan(0.6)/tan(0.8) of the half width
    assert left.mean() == pytest.approx(32.0 * (1 - np.tan(0.6) / np.tan(0.8)), abs=1.5)
    backend.close()


def test_panorama_and_follow_camera():
    objects = (WorldObject("sphere", (0.0, 2.5, 0.3), (0.3,), (1, 0, 0, 1)),    # left
               WorldObject("sphere", (0.0, -2.5, 0.3), (0.3,), (0, 1, 0, 1)),   # right
               WorldObject("box", (-2.5, 0.0, 0.3), (0.3, 0.3, 0.3), (0, 0, 1, 1)))  # behind
    with loaded(World(objects=objects)) as backend:
        pano = backend.render("pano")
        assert pano.shape == (24, 48, 3) and pano.dtype == np.uint8
        # equirectangular over 2 pi: left (+90°) at a quarter of the width, right at three quarters, back at the seam
        assert (red_columns(pano, 0) + 0.5).mean() == pytest.approx(12.0, abs=1.0)
        assert (red_columns(pano, 1) + 0.5).mean() == pytest.approx(36.0, abs=1.0)
        back = red_columns(pano, 2) + 0.5
        assert back.size and np.all((back < 4) | (back > 44))
        follow = backend.render("follow")
        assert follow.shape == (480, 640, 3) and follow.dtype == np.uint8
        assert follow.std() > 5
        # it tracks the body from behind: looks at the centre of its rest-pose bounding sphere, along its yaw,
        # 25° down, from where that sphere fills 1/1.25 of the 45° field of view (the shared rule)
        backend.reset(position_m=(1.0, 2.0), yaw_rad=1.0)
        centre, radius = rest_bounds(backend.body)
        pose = backend.read(["body_pos", "body_quat"])
        camera = backend._follow_camera(backend.follow_view())
        np.testing.assert_allclose(camera.lookat, pose["body_pos"][0] + quat_to_matrix(pose["body_quat"][0]) @ centre)
        assert camera.azimuth == pytest.approx(np.degrees(1.0)) and camera.elevation == pytest.approx(-25.0)
        assert camera.distance == pytest.approx(1.25 * radius / np.sin(np.radians(22.5)))
        assert backend.model.vis.global_.fovy == pytest.approx(45.0)
        assert not np.array_equal(backend.render("follow"), follow)


# -- the desert ant, when it is there ------------------------------------------------------------------
def test_desert_ant_loads_stands_and_sees():
    desert_ant = pytest.importorskip("neuronav.bodies.desert_ant").desert_ant
    body = desert_ant()
    with loaded(body=body) as backend:
        model = backend.model
        for segment in body.segments:
            index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, segment.name)
            assert model.body_mass[index] == pytest.approx(segment.mass_kg, abs=1e-12)
        assert model.body_mass.sum() == pytest.approx(body.total_mass_kg, abs=1e-9)
        assert model.nu == len(body.joints)
        backend.step(500)
        read = backend.read(["body_pos", "contact_force", "joint_pos"])
        assert read["body_pos"][0, 2] == pytest.approx(body.spawn_height_m, abs=0.03)
        assert read["contact_force"][0, :, 2].sum() == pytest.approx(body.total_mass_kg * G, rel=0.02)
        np.testing.assert_allclose(read["joint_pos"][0], body.rest_pose_rad(), atol=0.1)
        for camera in body.cameras:
            image = backend.render(camera.name)
            assert image.shape == (camera.height_px, camera.width_px, 3) and image.std() > 1
        assert backend.warnings == []
