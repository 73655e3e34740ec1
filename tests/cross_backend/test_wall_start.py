"""Starting on a wall and switching pads: the reset pose and the ``adhesion`` command on both engines.

The desert ant is put on the wall head up (the start of I2Bot's climbing world) and held at its rest
pose: with its pads on it stays there, with them off it falls, on MuJoCo and PyBullet alike.
"""

import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.engine.backend import start_pose
from neuronav.errors import ConfigError, PortError
from neuronav.spec.body import quat_to_matrix
from neuronav.spec.world import Ground, World

ENGINES = ["mujoco", "pybullet"]
WALL_X_M = 1.0


def engine(name, adhesion_n):
    ok, reason = registry.availability("backend", name)
    if not ok:
        pytest.skip(reason)
    body = desert_ant()
    backend = registry.load("backend", name)()
    backend.load(World(ground=Ground(kind="wall", wall_distance_m=WALL_X_M), adhesion_n=adhesion_n), [body])
    # Belly to the wall: the root its standing height off the wall face, pressed in 2 mm.
    root = (WALL_X_M - body.spawn_height_m + 0.002, 0.0, 1.5)
    backend.reset(0, position_m=root, pitch_rad=np.pi / 2)
    return backend, body, np.array(root)


def test_start_pose_pitch_then_yaw():
    _, _, quat = start_pose((0, 0), 0.0, np.pi / 2, "test")
    rotation = quat_to_matrix(quat)
    np.testing.assert_allclose(rotation[:, 0], [0, 0, 1], atol=1e-12)  # nose up
    np.testing.assert_allclose(rotation[:, 2], [-1, 0, 0], atol=1e-12)  # back away from a wall at +x
    position, z_given, quat = start_pose((1, 2), np.pi / 2, 0.0, "test")
    assert not z_given and position.tolist() == [1, 2, 0]
    np.testing.assert_allclose(quat_to_matrix(quat)[:, 0], [0, 1, 0], atol=1e-12)  # yaw alone turns x to y
    _, _, quat = start_pose((0, 0, 1), np.pi / 2, np.pi / 2, "test")
    np.testing.assert_allclose(quat_to_matrix(quat)[:, 2], [0, -1, 0], atol=1e-12)  # pitched, then turned
    # Spun first: on the wall, a spin to the left turns the nose from straight up toward -y.
    _, _, quat = start_pose((0, 0, 1), 0.0, np.pi / 2, "test", spin_rad=np.pi / 2)
    np.testing.assert_allclose(quat_to_matrix(quat)[:, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(quat)[:, 2], [-1, 0, 0], atol=1e-12)  # still belly to the wall
    _, _, spun = start_pose((0, 0), 0.0, 0.0, "test", spin_rad=0.4)
    _, _, turned = start_pose((0, 0), 0.4, 0.0, "test")
    np.testing.assert_allclose(spun, turned, atol=1e-12)  # on the floor spin and yaw are one turn
    for bad in [dict(position_m=(1, 2, 3, 4)), dict(position_m=(0, np.nan)), dict(pitch_rad=np.inf)]:
        arguments = dict(position_m=(0, 0), yaw_rad=0.0, pitch_rad=0.0) | bad
        with pytest.raises(ConfigError, match="position_m"):
            start_pose(arguments["position_m"], arguments["yaw_rad"], arguments["pitch_rad"], "test")


@pytest.mark.parametrize("name", ENGINES)
def test_reset_puts_the_root_where_asked_nose_up(name):
    backend, _, root = engine(name, adhesion_n=0.0)
    with backend:
        pose = backend.read(["body_pos", "body_quat"])
        np.testing.assert_allclose(pose["body_pos"][0], root, atol=1e-6)
        rotation = quat_to_matrix(pose["body_quat"][0])
        np.testing.assert_allclose(rotation[:, 0], [0, 0, 1], atol=1e-6)
        np.testing.assert_allclose(rotation[:, 2], [-1, 0, 0], atol=1e-6)


@pytest.mark.parametrize("name", ENGINES)
def test_pads_hold_the_body_on_the_wall_and_letting_go_drops_it(name):
    """Held at rest pose for 0.5 s at 200 N per claw: pads on, the centre stays within 5 cm; off, it falls."""
    drops = {}
    for fraction in (1.0, 0.0):
        backend, body, _ = engine(name, adhesion_n=200.0)
        with backend:
            pads = np.full((1, len(body.sites_of_kind("contact"))), fraction)
            start_z = backend.read(["body_pos"])["body_pos"][0, 2]
            for _ in range(125):
                backend.write({"joint_targets": body.rest_pose_rad()[None, :], "adhesion": pads})
                backend.step(2)
            drops[fraction] = start_z - backend.read(["body_pos"])["body_pos"][0, 2]
    assert drops[1.0] < 0.05, drops
    assert drops[0.0] > 0.5, drops  # free fall for 0.5 s: 1.2 m, less what the wall's friction holds back


@pytest.mark.parametrize("name", ENGINES)
def test_adhesion_command_is_checked(name):
    backend, body, _ = engine(name, adhesion_n=100.0)
    sites = len(body.sites_of_kind("contact"))
    with backend:
        spec = next(m for m in backend.capabilities.motors if m.name == "adhesion")
        assert spec.shape == (sites,) and spec.range == (0.0, 1.0)
        for bad in (np.full((1, sites), 1.5), np.full((1, sites), np.nan), np.full((1, sites), -0.1)):
            with pytest.raises(PortError, match="adhesion"):
                backend.write({"adhesion": bad})
        with pytest.raises(PortError, match="shape"):
            backend.write({"adhesion": np.ones((1, sites + 1))})


def test_pads_are_compliant_only_in_worlds_with_adhesion():
    """MuJoCo stiffens friction (impratio) and PyBullet softens the claws' contacts only when there is
    adhesion, so walking on plain ground is the same with or without this code."""
    for adhesion_n, impratio in ((0.0, 1.0), (50.0, 10.0)):
        backend, _, _ = engine("mujoco", adhesion_n)
        with backend:
            assert backend.model.opt.impratio == impratio
    pybullet = pytest.importorskip("pybullet")
    from neuronav.backends.pybullet.backend import PAD_DAMPING_N_S_M, PAD_STIFFNESS_N_M

    for adhesion_n in (0.0, 50.0):
        backend, _, _ = engine("pybullet", adhesion_n)
        with backend:
            pads = {link for site, (link, _) in zip(backend._contact_sites, backend._contact_links) if site.adhesive}
            info = [pybullet.getDynamicsInfo(backend._robot, link, physicsClientId=backend._client) for link in pads]
            damping, stiffness = zip(*[(i[8], i[9]) for i in info])
            if adhesion_n:
                assert set(stiffness) == {PAD_STIFFNESS_N_M} and set(damping) == {PAD_DAMPING_N_S_M}
            else:
                assert PAD_STIFFNESS_N_M not in stiffness
