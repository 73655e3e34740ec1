"""The PyBullet backend: URDF generation, the world, control, sensors, forces, rendering, errors."""

import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

pb = pytest.importorskip("pybullet")

from neuronav.backends.pybullet import PybulletBackend  # noqa: E402
from neuronav.backends.pybullet.urdf import body_to_urdf, subset_inertial  # noqa: E402
from neuronav.engine.backend import ARTICULATED_SENSORS, Backend  # noqa: E402
from neuronav.errors import ConfigError, PortError, SimulationError  # noqa: E402
from neuronav.spec.body import BodySpec, Camera, Geom, Joint, Segment, Site, axis_angle_quat, quat_to_matrix  # noqa: E402
from neuronav.spec.world import Ground, PointAgents, World, WorldObject  # noqa: E402

G = 9.81
# A camera looking along the body's +x (its -z axis forward) with +z up: columns x=-y, y=z, z=-x.
FORWARD_CAMERA_QUAT = (0.5, 0.5, -0.5, -0.5)


def small_body(kp=20.0, kd=0.1, claw_friction=1.0) -> BodySpec:
    """A 1 kg box on two 2-segment legs ending in sphere claws, and a tail strut: it stands on three points."""
    segments = [Segment("root", None, (Geom("box", (0.15, 0.08, 0.04), rgba=(0.8, 0.3, 0.1, 1.0)),
                                       Geom("capsule", (0.02, 0.045), (-0.14, 0.0, -0.1), name="tail")), 1.0)]
    sites = []
    for side, sign in (("l", 1.0), ("r", -1.0)):
        along_y = axis_angle_quat((1.0, 0.0, 0.0), -sign * np.pi / 2)  # capsule z -> ±y
        segments.append(Segment(
            f"{side}_upper", "root", (Geom("capsule", (0.012, 0.05), (0.0, sign * 0.05, 0.0), along_y),), 0.1,
            Joint(f"{side}_hip", axis=(1.0, 0.0, 0.0), range_rad=(-1.2, 1.2), kp=kp, kd=kd, max_torque_nm=10.0,
                  damping=0.01),
            pos_m=(0.1, sign * 0.08, 0.0)))
        segments.append(Segment(
            f"{side}_lower", f"{side}_upper",
            (Geom("capsule", (0.01, 0.06), (0.0, 0.0, -0.07)),
             Geom("sphere", (0.015,), (0.0, 0.0, -0.15), name=f"{side}_claw", rgba=(0.1, 0.1, 0.1, 1.0),
                  friction=claw_friction)),
            0.1, Joint(f"{side}_knee", axis=(2.0, 0.0, 0.0), range_rad=(-1.5, 1.4), kp=kp, kd=kd, max_torque_nm=10.0),
            pos_m=(0.0, sign * 0.1, 0.0)))
        sites.append(Site(f"{side}_claw", f"{side}_lower", (0.0, 0.0, -0.15), "contact", f"{side}_claw", adhesive=True))
    sites += [Site("tail", "root", (-0.14, 0.0, -0.145), "contact", "tail", adhesive=True),
              Site("nose", "root", (0.15, 0.0, 0.0), "odour"),
              Site("left_eye", "root", (0.12, 0.05, 0.04), "wind"),
              Site("centre", "root", (0.0, 0.0, 0.0), "marker")]
    cameras = (Camera("eye", "root", (0.16, 0.0, 0.0), FORWARD_CAMERA_QUAT, 32, 16, (1.5, 0.8)),
               Camera("pano", "root", (0.0, 0.0, 0.05), FORWARD_CAMERA_QUAT, 48, 24, (2 * np.pi, np.pi), "spherical"))
    return BodySpec("tester", tuple(segments), tuple(sites), cameras, spawn_height_m=0.175)


def arm_body(kp=20.0) -> BodySpec:
    """A box welded to the world with one horizontal arm (0.2 kg, 0.3 m along +x) on a hinge about +y."""
    along_x = axis_angle_quat((0.0, 1.0, 0.0), np.pi / 2)
    root = Segment("base", None, (Geom("box", (0.05, 0.05, 0.05)),), 1.0, Joint("weld", kind="fixed"))
    arm = Segment("arm", "base", (Geom("capsule", (0.01, 0.15), (0.15, 0.0, 0.0), along_x),), 0.2,
                  Joint("shoulder", axis=(0.0, 1.0, 0.0), range_rad=(-1.0, 1.0), kp=kp, kd=0.3, max_torque_nm=5.0),
                  pos_m=(0.06, 0.0, 0.0))
    return BodySpec("arm", (root, arm), spawn_height_m=0.5)


@pytest.fixture
def backend():
    with PybulletBackend() as instance:
        instance.load(World(), [small_body()])
        yield instance


def settle(backend, steps=400):
    backend.step(steps)
    return backend


def wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


# -- URDF ------------------------------------------------------------------------------------------
def test_urdf_parses_with_unique_links_and_a_link_per_contact_geom():
    body = small_body()
    urdf = body_to_urdf(body)
    root = ET.fromstring(urdf.text)
    links = [e.get("name") for e in root.findall("link")]
    assert len(links) == len(set(links)) == len(urdf.links)
    assert {"root__tail", "l_lower__l_claw", "r_lower__r_claw"} <= set(links)
    joints = {e.get("name"): e for e in root.findall("joint")}
    assert joints["l_knee"].get("type") == "revolute"
    assert joints["l_lower__l_claw"].get("type") == "fixed"
    assert root.find("link/collision/geometry/capsule") is not None


def test_split_links_add_up_to_the_segment():
    segment = small_body().segment("l_lower")
    com, inertia, _ = segment.inertial()
    parts = [subset_inertial(segment, [0]), subset_inertial(segment, [1])]
    assert sum(m for m, _, _ in parts) == pytest.approx(segment.mass_kg)
    combined_com = sum(m * c for m, c, _ in parts) / segment.mass_kg
    np.testing.assert_allclose(combined_com, com, atol=1e-12)
    combined = sum(i + m * ((c - com) @ (c - com) * np.eye(3) - np.outer(c - com, c - com)) for m, c, i in parts)
    np.testing.assert_allclose(combined, inertia, rtol=1e-10, atol=1e-15)


def test_loaded_masses_and_inertia_equal_the_spec(backend):
    body = small_body()
    cid, robot = backend.client_id, backend._robot
    per_segment = dict.fromkeys((s.name for s in body.segments), 0.0)
    for link in backend._urdf.links:
        index = backend._link_index[link.name]
        info = pb.getDynamicsInfo(robot, index, physicsClientId=cid)
        per_segment[link.segment] += info[0]
        # PyBullet diagonalises the tensor; turn it back and compare with the generated link.
        x, y, z, w = info[4]
        rotation = quat_to_matrix((w, x, y, z))
        np.testing.assert_allclose(rotation @ np.diag(info[2]) @ rotation.T, link.inertia, rtol=1e-5, atol=1e-10)
        np.testing.assert_allclose(info[3], link.com_m, atol=1e-9)
    for segment in body.segments:
        assert per_segment[segment.name] == pytest.approx(segment.mass_kg, rel=1e-9)
    assert sum(per_segment.values()) == pytest.approx(body.total_mass_kg, rel=1e-9)


def test_joint_names_axes_limits_and_effort_equal_the_spec(backend):
    body = small_body()
    cid, robot = backend.client_id, backend._robot
    infos = [pb.getJointInfo(robot, i, physicsClientId=cid) for i in range(pb.getNumJoints(robot, physicsClientId=cid))]
    revolute = {info[1].decode(): info for info in infos if info[2] == pb.JOINT_REVOLUTE}
    assert sorted(revolute) == sorted(body.joint_names)
    for joint in body.joints:
        info = revolute[joint.name]
        np.testing.assert_allclose(info[13], np.asarray(joint.axis) / np.linalg.norm(joint.axis), atol=1e-12)
        assert (info[8], info[9]) == pytest.approx(joint.range_rad)
        assert info[10] == pytest.approx(joint.max_torque_nm)
        assert info[6] == pytest.approx(joint.damping)


def test_capsules_load_as_capsules(backend):
    data = pb.getCollisionShapeData(backend._robot, backend._link_index["l_upper"], physicsClientId=backend.client_id)
    assert data[0][2] == pb.GEOM_CAPSULE
    assert data[0][3][:2] == pytest.approx((0.1, 0.012))  # (length of the cylinder part, radius)


# -- protocol basics -------------------------------------------------------------------------------
def test_capabilities_placeholders_then_real_shapes_and_reads_match():
    with PybulletBackend() as backend:
        assert isinstance(backend, Backend)
        # before load, every sensor of the shared table, with its body-sized dimensions (J, C, O, W) at 1
        placeholders = {s.name: s.shape for s in backend.capabilities.sensors}
        assert placeholders == {name: tuple(1 if isinstance(n, str) else n for n in shape)
                                for name, shape, _, _ in ARTICULATED_SENSORS}
        assert "joint_targets" in {m.name for m in backend.capabilities.motors}
        backend.load(World(), [small_body()])
        caps = backend.capabilities
        assert caps.name == "pybullet" and caps.can_render and not caps.batched
        shapes = {s.name: s.shape for s in caps.sensors}
        assert shapes["joint_pos"] == (4,) and shapes["contact_force"] == (3, 3)
        assert shapes["odour_sites"] == (1, 3) and shapes["wind_sites"] == (1, 3) and shapes["body_quat"] == (4,)
        assert shapes["eye"] == (16, 32) and shapes["pano"] == (24, 48)  # body cameras are grey-image sensors
        assert [(m.name, m.shape, m.units) for m in caps.motors] == [("joint_targets", (4,), "rad"),
                                                                    ("adhesion", (3,), "fraction of adhesion_n")]
        backend.step(3)
        values = backend.read(list(shapes))
        for name, shape in shapes.items():
            assert values[name].shape == (1, *shape), name
            assert np.isfinite(values[name]).all()
        assert backend.time == pytest.approx(3 * backend.timestep)
        with pytest.raises(PortError, match="no sensor"):
            backend.read(["speed"])


def test_read_is_lazy(backend, monkeypatch):
    calls = []
    for name in ("getContactPoints", "getJointStates", "getLinkStates"):
        original = getattr(pb, name)
        monkeypatch.setattr(pb, name, lambda *a, _o=original, _n=name, **k: calls.append(_n) or _o(*a, **k))
    backend.read(["heading", "position"])
    assert calls == []
    backend.read(["contact_force"])
    assert set(calls) == {"getContactPoints"}


def test_wrong_loads_raise_config_error():
    with PybulletBackend() as backend:
        with pytest.raises(SimulationError, match="load"):
            backend.step()
        with pytest.raises(ConfigError, match="exactly one BodySpec"):
            backend.load(World(), [small_body(), small_body()])
        with pytest.raises(ConfigError, match="exactly one BodySpec"):
            backend.load(World(), [PointAgents()])
        with pytest.raises(ConfigError, match="timestep"):
            PybulletBackend(timestep_s=0.0)


def test_write_shapes(backend):
    backend.write({"joint_targets": np.zeros(4)})
    backend.write({"joint_targets": np.zeros((1, 4))})
    for bad in (np.zeros(3), np.zeros((2, 4)), np.zeros((1, 5))):
        with pytest.raises(PortError, match="joint_targets"):
            backend.write({"joint_targets": bad})
    with pytest.raises(PortError, match="finite"):
        backend.write({"joint_targets": np.full(4, np.nan)})
    with pytest.raises(PortError, match="accepts no command"):
        backend.write({"turn": np.zeros(1)})


def test_close_disconnects_and_removes_the_urdf():
    backend = PybulletBackend()
    backend.load(World(), [small_body()])
    cid, path = backend.client_id, backend._urdf_path
    assert os.path.exists(path)
    backend.close()
    assert pb.getConnectionInfo(physicsClientId=cid)["isConnected"] == 0
    assert not os.path.exists(path)
    with pytest.raises(SimulationError):
        backend.read(["heading"])
    backend.close()  # twice is fine


# -- control and sensors ---------------------------------------------------------------------------
def test_position_control_holds_an_arm_against_gravity():
    kp = 20.0
    with PybulletBackend() as backend:
        backend.load(World(), [arm_body(kp)])
        backend.step(500)
        values = backend.read(["joint_pos", "joint_vel", "joint_torque"])
    gravity_torque = 0.2 * G * 0.15  # mass x g x lever (the arm's centre is 0.15 m from the hinge)
    # At rest kp (0 - q) balances gravity: the arm droops (positive about +y) by torque / kp.
    assert values["joint_pos"][0, 0] == pytest.approx(gravity_torque / kp, rel=0.02)
    assert abs(values["joint_vel"][0, 0]) < 1e-3
    assert values["joint_torque"][0, 0] == pytest.approx(-gravity_torque, rel=0.02)


def test_position_control_reaches_targets_and_reports_its_torque(backend):
    targets = np.array([0.15, 0.1, -0.15, -0.1])
    backend.write({"joint_targets": targets})
    settle(backend, 500)
    values = backend.read(["joint_pos", "joint_vel", "joint_torque"])
    q, qd, torque = values["joint_pos"][0], values["joint_vel"][0], values["joint_torque"][0]
    np.testing.assert_allclose(q, targets, atol=0.02)
    assert np.abs(qd).max() < 1e-2
    np.testing.assert_allclose(torque, 20.0 * (targets - q) - 0.1 * qd, atol=1e-3)
    assert np.abs(torque).max() > 0.05  # the legs carry load


def test_resting_contact_forces_carry_the_weight_and_point_up(backend):
    settle(backend)
    forces = backend.read(["contact_force"])["contact_force"][0]
    weight = small_body().total_mass_kg * G
    np.testing.assert_allclose(forces.sum(axis=0), [0.0, 0.0, weight], atol=0.01 * weight)
    assert (forces[:, 2] > 0.25 * weight).all()
    assert (forces[:, 2] > 0.9 * np.linalg.norm(forces, axis=1)).all()
    left, right, _ = forces
    np.testing.assert_allclose(left * [1, -1, 1], right, atol=0.02 * weight)  # mirror images


PLATFORM = WorldObject("box", (0.0, 0.0, -0.045), (1.0, 1.0, 0.05))  # top 5 mm above the floor


@pytest.mark.parametrize("world", [World(), World(ground=Ground("uneven", roughness_m=0.03, size_m=4.0, cells=65)),
                                   World(objects=(PLATFORM,))], ids=["flat", "uneven", "platform"])
def test_friction_forces_oppose_a_push(world):
    # PyBullet reports friction directions of a contact pair in its own order; a wrong sign shows here.
    with PybulletBackend() as backend:
        backend.load(world, [small_body()])
        settle(backend)
        for _ in range(100):
            backend.apply_force(0, "centre", [0.0, 3.0, 0.0])
            backend.step()
        total = backend.read(["contact_force"])["contact_force"][0].sum(axis=0)
        assert np.linalg.norm(backend.read(["body_linvel"])["body_linvel"]) < 1e-3  # it holds
    np.testing.assert_allclose(total, [0.0, -3.0, small_body().total_mass_kg * G], atol=0.1)


@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.0, np.pi])
def test_heading_is_clockwise_from_y(backend, yaw):
    backend.reset(position_m=(0.3, -0.2), yaw_rad=yaw)
    values = backend.read(["heading", "body_quat", "body_pos", "position"])
    assert wrap(values["heading"][0, 0] - (np.pi / 2 - yaw)) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(values["body_pos"][0], [0.3, -0.2, 0.175], atol=1e-9)
    np.testing.assert_allclose(values["position"][0], [0.3, -0.2], atol=1e-9)
    w, z = np.cos(yaw / 2), np.sin(yaw / 2)
    assert abs(values["body_quat"][0] @ [w, 0.0, 0.0, z]) == pytest.approx(1.0, abs=1e-9)


def test_body_velocity_and_site_positions_follow_the_root(backend):
    backend.reset(yaw_rad=np.pi / 2)  # facing +y: the nose is at (0, 0.15) from the root
    values = backend.read(["odour_sites", "wind_sites", "body_pos"])
    np.testing.assert_allclose(values["odour_sites"][0, 0] - values["body_pos"][0], [0.0, 0.15, 0.0], atol=1e-9)
    np.testing.assert_allclose(values["wind_sites"][0, 0] - values["body_pos"][0], [-0.05, 0.12, 0.04], atol=1e-9)
    backend.step(20)  # falling
    velocity = backend.read(["body_linvel", "velocity"])
    assert velocity["body_linvel"][0, 2] < -0.05


# -- world -----------------------------------------------------------------------------------------
def test_uneven_ground_matches_ground_height_at():
    ground = Ground("uneven", roughness_m=0.1, size_m=4.0, cells=33, seed=3)
    spacing = ground.size_m / (ground.cells - 1)
    with PybulletBackend() as backend:
        backend.load(World(ground=ground), [small_body()])
        # Grid points and cell-edge midpoints: there the spec's bilinear surface and PyBullet's
        # triangles agree exactly, so any offset or flip of the field would show.
        points = [(-2.0 + 5 * spacing, -2.0 + 9 * spacing), (1.0, -0.5), (0.25 + spacing / 2, 0.75),
                  (-1.5, 0.5 + spacing / 2), (1.875, 1.875)]
        for x, y in points:
            hit = pb.rayTest([x, y, 5.0], [x, y, -5.0], physicsClientId=backend.client_id)[0]
            assert hit[3][2] == pytest.approx(ground.height_at(x, y), abs=1e-6), (x, y)
        # The body spawns over the terrain and comes to rest on it.
        settle(backend, 500)
        forces = backend.read(["contact_force"])["contact_force"][0]
        assert forces.sum(axis=0)[2] == pytest.approx(small_body().total_mass_kg * G, rel=0.01)
        touches = pb.getContactPoints(bodyA=backend._robot, physicsClientId=backend.client_id)
        assert touches
        for point in touches:
            x, y, z = point[6]
            assert z == pytest.approx(ground.height_at(x, y), abs=2e-3)


def test_the_wall_stops_a_pushed_body():
    wall_m = 0.5
    with PybulletBackend() as backend:
        backend.load(World(ground=Ground("wall", wall_distance_m=wall_m, friction=0.05)), [small_body()])
        for _ in range(750):
            backend.apply_force(0, "centre", [5.0, 0.0, 0.0])
            backend.step()
        values = backend.read(["body_pos", "body_linvel", "heading"])
    front = values["body_pos"][0, 0] + 0.15  # the box's front face
    assert front == pytest.approx(wall_m, abs=3e-3)
    assert abs(values["body_linvel"][0, 0]) < 1e-2
    assert values["heading"][0, 0] == pytest.approx(np.pi / 2, abs=0.05)


def test_objects_are_solid_and_visible():
    objects = (WorldObject("box", (1.5, 0.0, 0.3), (0.2, 0.2, 0.3), (1.0, 0.0, 0.0, 1.0)),
               WorldObject("cone", (0.0, 1.5, 0.3), (0.2, 0.3), (0.0, 1.0, 0.0, 1.0)),
               WorldObject("cylinder", (-1.5, 0.0, 0.5), (0.2, 0.5), (0.0, 0.0, 1.0, 1.0)),
               WorldObject("sphere", (0.0, -1.5, 0.2), (0.2,), (1.0, 1.0, 0.0, 1.0)))
    with PybulletBackend() as backend:
        backend.load(World(objects=objects), [small_body()])
        cid = backend.client_id
        tops = {"box": 0.6, "cone": 0.6, "cylinder": 1.0, "sphere": 0.4}
        for obj in objects:
            x, y, _ = obj.position_m
            hit = pb.rayTest([x, y, 3.0], [x, y, -1.0], physicsClientId=cid)[0]
            assert hit[3][2] == pytest.approx(tops[obj.shape], abs=2e-3), obj.shape  # meshes have a 1 mm margin
        # The cone narrows: halfway up it is half as wide.
        hit = pb.rayTest([0.0, 1.5 + 0.15, 3.0], [0.0, 1.5 + 0.15, -1.0], physicsClientId=cid)[0]
        assert hit[3][2] == pytest.approx(0.15, abs=0.02)
        # The panorama sees the red box ahead (centre column) and the green cone on the left (a quarter in),
        # each in exactly its colour (flat shading).
        image = backend.render("pano").astype(int)
        red = (image == (255, 0, 0)).all(-1)
        green = (image == (0, 255, 0)).all(-1)
        width = image.shape[1]
        assert red.any() and green.any()
        assert np.mean(np.nonzero(red)[1]) == pytest.approx(width / 2, abs=2)
        assert np.mean(np.nonzero(green)[1]) == pytest.approx(width / 4, abs=2)
        assert np.nonzero(red)[0].max() < image.shape[0] / 2 + 2  # above the horizon (it is taller than the eye)
        eye = backend.render("eye").astype(int)
        red = (eye == (255, 0, 0)).all(-1)
        assert np.mean(np.nonzero(red)[1]) == pytest.approx(eye.shape[1] / 2, abs=1.5)


def test_adhesion_presses_touching_claws_into_the_surface():
    def rest_forces(adhesion_n):
        with PybulletBackend() as backend:
            backend.load(World(adhesion_n=adhesion_n), [small_body()])
            settle(backend)
            return backend.read(["contact_force"])["contact_force"][0]

    free, pressed = rest_forces(0.0), rest_forces(5.0)
    np.testing.assert_allclose(pressed[:, 2] - free[:, 2], 5.0, atol=0.25)
    assert pressed.sum(axis=0)[2] == pytest.approx(small_body().total_mass_kg * G + 3 * 5.0, rel=0.01)


# -- forces, determinism, divergence ---------------------------------------------------------------
@pytest.mark.parametrize("force", [(0.0, 30.0, 0.0), (-30.0, 0.0, 0.0)])
def test_apply_force_moves_the_body_that_way(backend, force):
    settle(backend, 200)
    start = backend.read(["position"])["position"][0]
    for _ in range(100):
        backend.apply_force(0, "centre", force)
        backend.step()
    moved = backend.read(["position"])["position"][0] - start
    direction = np.asarray(force[:2]) / np.linalg.norm(force[:2])
    assert moved @ direction > 0.02
    assert abs(moved @ [-direction[1], direction[0]]) < 0.3 * (moved @ direction)


def test_apply_force_lasts_one_step_call_and_checks_its_input(backend):
    settle(backend, 200)
    backend.apply_force(0, "centre", [0.0, 0.0, 200.0])
    backend.step(1)
    rising = backend.read(["body_linvel"])["body_linvel"][0, 2]
    backend.step(1)
    assert rising > 0.1 and backend.read(["body_linvel"])["body_linvel"][0, 2] < rising
    with pytest.raises(ConfigError, match="no site"):
        backend.apply_force(0, "tip", [1.0, 0.0, 0.0])
    with pytest.raises(ConfigError, match="one body"):
        backend.apply_force(1, "centre", [1.0, 0.0, 0.0])
    with pytest.raises(ConfigError, match="3 finite"):
        backend.apply_force(0, "centre", [1.0, 0.0])


def test_same_seed_same_trajectory_bit_identical_across_instances_and_resets():
    world = World(ground=Ground("uneven", roughness_m=0.03, size_m=4.0, cells=33))
    first, second = PybulletBackend(), PybulletBackend()
    try:
        first.load(world, [small_body()])
        second.load(world, [small_body()])
        assert first.client_id != second.client_id

        def episode(backends):
            rng = np.random.default_rng(11)
            for backend in backends:
                backend.reset(seed=5, position_m=(0.2, 0.1), yaw_rad=0.3)
            records = [[] for _ in backends]
            names = [s.name for s in first.capabilities.sensors]
            for _ in range(60):
                targets = rng.uniform(-0.4, 0.4, 4)
                for backend, record in zip(backends, records):  # interleaved: the clients must not interact
                    backend.write({"joint_targets": targets})
                    backend.apply_force(0, "nose", [1.0, 0.5, 0.0])
                    backend.step(4)
                    record.append(np.concatenate([v.ravel() for v in backend.read(names).values()]))
            return [np.array(r) for r in records]

        a, b = episode([first, second])
        assert np.abs(a[:, :4]).max() > 0.1  # the legs moved
        np.testing.assert_array_equal(a, b)
        (again,) = episode([first])
        np.testing.assert_array_equal(a, again)
    finally:
        first.close()
        second.close()


def test_divergence_raises_simulation_error(backend):
    backend.apply_force(0, "centre", [1e9, 0.0, 0.0])
    with pytest.raises(SimulationError, match="diverged"):
        backend.step()
    assert any("diverged" in w for w in backend.warnings)


def test_unstable_gains_get_substeps_and_stay_put():
    body = small_body(kp=200.0, kd=2.0)
    with PybulletBackend() as backend:
        backend.load(World(), [body])
        assert backend.substeps > 1
        assert any("PyBullet steps of" in w for w in backend.notes)
        settle(backend, 300)
        assert np.abs(backend.read(["joint_vel"])["joint_vel"]).max() < 1e-2
        assert backend.time == pytest.approx(300 * backend.timestep)
    with PybulletBackend(substeps=1) as forced:
        forced.load(World(), [body])
        assert forced.substeps == 1
        assert any("stability limit" in w for w in forced.warnings)


def test_raw_step_advances_without_control(backend):
    backend.raw_step(50)
    assert backend.time == pytest.approx(50 * backend.timestep / backend.substeps)
    assert np.isfinite(backend.read(["body_pos"])["body_pos"]).all()


# -- rendering -------------------------------------------------------------------------------------
@pytest.mark.parametrize("camera, shape", [("eye", (16, 32, 3)), ("pano", (24, 48, 3)), ("follow", (480, 640, 3))])
def test_render_returns_non_constant_rgb(backend, camera, shape):
    image = backend.render(camera)
    assert image.shape == shape and image.dtype == np.uint8
    assert image.reshape(-1, 3).std(axis=0).max() > 5


def test_render_unknown_camera_raises(backend):
    with pytest.raises(PortError, match="follow"):
        backend.render("nope")


# -- the desert ant (if its body is available) ------------------------------------------------------
def _ant():
    try:
        from neuronav.bodies.desert_ant import desert_ant
    except ImportError:
        pytest.skip("neuronav.bodies.desert_ant is not available")
    return desert_ant()


def test_desert_ant_loads_with_its_masses_and_joints():
    ant = _ant()
    with PybulletBackend() as backend:
        backend.load(World(), [ant])
        cid, robot = backend.client_id, backend._robot
        per_segment = dict.fromkeys((s.name for s in ant.segments), 0.0)
        for link in backend._urdf.links:
            per_segment[link.segment] += pb.getDynamicsInfo(robot, backend._link_index[link.name],
                                                            physicsClientId=cid)[0]
        for segment in ant.segments:
            assert per_segment[segment.name] == pytest.approx(segment.mass_kg, rel=1e-9), segment.name
        count = pb.getNumJoints(robot, physicsClientId=cid)
        infos = [pb.getJointInfo(robot, i, physicsClientId=cid) for i in range(count)]
        revolute = {i[1].decode(): i for i in infos if i[2] == pb.JOINT_REVOLUTE}
        assert sorted(revolute) == sorted(ant.joint_names)
        for joint in ant.joints:
            assert (revolute[joint.name][8], revolute[joint.name][9]) == pytest.approx(joint.range_rad)
        assert not any("inertia" in w.lower() and "bad" in w.lower() for w in backend.warnings)


def test_desert_ant_stands_on_its_claws():
    ant = _ant()
    with PybulletBackend() as backend:
        backend.load(World(), [ant])
        backend.step(400)
        values = backend.read(["contact_force", "body_pos", "joint_pos", "heading"])
        forces = values["contact_force"][0]
        assert forces.sum(axis=0)[2] == pytest.approx(ant.total_mass_kg * G, rel=0.02)
        assert forces[:, 2].min() >= 0.0
        assert values["body_pos"][0, 2] == pytest.approx(ant.spawn_height_m, abs=0.05)
        assert np.abs(values["joint_pos"][0] - ant.rest_pose_rad()).max() < 0.1
        assert values["heading"][0, 0] == pytest.approx(np.pi / 2, abs=0.05)
        for camera in ant.cameras:
            image = backend.render(camera.name)
            assert image.shape == (camera.height_px, camera.width_px, 3)
