"""The kinematic backend's cameras: sensors in the capabilities, grey reads for every agent, images where
the agent's pose and the scene's turn put the objects, rendered only when read, and clear refusals."""

import numpy as np
import pytest

from neuronav.backends.kinematic import KinematicBackend
from neuronav.errors import ConfigError, PortError
from neuronav.senses.vision import to_uint8
from neuronav.spec.body import Camera, quat_to_matrix
from neuronav.spec.ports import SensorSpec
from neuronav.spec.world import Appearance, Ground, PointAgents, World, WorldObject

# A camera looking along the agent's forward axis, level: in the agent's frame (x forward, y left,
# z up) its x (right) is -y, its y (up) is z, its z (it looks along -z) is -x.
FORWARD_FRAME = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
FORWARD_QUAT = (0.5, 0.5, -0.5, -0.5)
PANORAMA = Camera("panorama", "agent", (0.0, 0.0, 0.5), FORWARD_QUAT, 72, 72, (2 * np.pi, np.pi), "spherical")
EYE = Camera("eye", "agent", (0.1, 0.2, 0.5), FORWARD_QUAT, 74, 19, (2.0, 0.5))
DARK = (0.0, 0.0, 0.0, 1.0)
LOOK = Appearance(ground_texture="plain")


def pillar(x, y, radius=1.0):
    return WorldObject("cylinder", (x, y, 3.0), (radius, 3.0), DARK)


def engine(objects=(), count=1, cameras=(PANORAMA, EYE), ground=None, appearance=LOOK):
    backend = KinematicBackend()
    backend.load(World(ground=ground or Ground(), objects=tuple(objects), appearance=appearance),
                 [PointAgents(count=count, mode="unicycle", cameras=cameras)])
    return backend


def dark_columns(image_rgb, row):
    return np.flatnonzero((image_rgb[row] == 0).all(-1))


def test_the_forward_quaternion_is_the_frame_the_tests_assume():
    np.testing.assert_allclose(quat_to_matrix(FORWARD_QUAT), FORWARD_FRAME, atol=1e-12)


def test_cameras_are_sensors_of_the_loaded_backend_only():
    backend = engine(count=3)
    sensors = {s.name: s for s in backend.capabilities.sensors}
    assert sensors["panorama"] == SensorSpec("panorama", (72, 72), "grey [0, 1]")
    assert sensors["eye"] == SensorSpec("eye", (19, 74), "grey [0, 1]")
    assert backend.capabilities.can_render
    assert "panorama" not in {s.name for s in KinematicBackend.capabilities.sensors}
    assert not engine(cameras=()).capabilities.can_render


def test_read_returns_grey_images_for_every_agent():
    backend = engine([pillar(0.0, 10.0)], count=3)
    frames = backend.read(["panorama", "eye", "heading"])
    assert frames["panorama"].shape == (3, 72, 72) and frames["eye"].shape == (3, 19, 74)
    for name in ("panorama", "eye"):
        assert frames[name].dtype == float and 0.0 <= frames[name].min() and frames[name].max() <= 1.0
    assert frames["panorama"].min() == 0.0  # the black pillar
    # BT.601 grey of the plain ground, straight below.
    assert frames["panorama"][0, -1, 0] == pytest.approx(float(to_uint8(LOOK.ground_rgb) @ [0.299, 0.587, 0.114])
                                                         / 255.0)


@pytest.mark.parametrize("heading_deg, pillar_bearing_deg", [(0.0, 0.0), (90.0, 90.0), (90.0, 60.0),
                                                             (-135.0, 160.0)])
def test_the_pillar_appears_where_the_agents_pose_puts_it(heading_deg, pillar_bearing_deg):
    # Agent at (2, -3) facing heading h; pillar 12 m away at a world bearing b (clockwise from +y):
    # in the panorama it sits (b - h) to the right of forward, 5° a column, forward at 36.
    backend = engine([pillar(2.0 + 12.0 * np.sin(np.radians(pillar_bearing_deg)),
                             -3.0 + 12.0 * np.cos(np.radians(pillar_bearing_deg)))])
    backend.reset(position_m=(2.0, -3.0), heading_rad=np.radians(heading_deg))
    relative = np.angle(np.exp(1j * np.radians(pillar_bearing_deg - heading_deg)))
    half = np.arcsin(1.0 / 12.0)
    azimuths = ((np.arange(72) + 0.5) / 72 - 0.5) * 2 * np.pi
    expected = np.flatnonzero(np.abs(np.angle(np.exp(1j * (azimuths - relative)))) < half)
    np.testing.assert_array_equal(dark_columns(backend.render("panorama"), 35), expected)


def test_the_eye_sits_forward_and_left_of_the_agent():
    # The eye is 0.1 m forward and 0.2 m left: a thin pillar 5 m straight ahead of the eye spans ±1.7°,
    # the middle columns 36 and 37 of the 74-column eye (±1.2°); seen from the agent's centre it
    # would sit 2.2° to the left, in columns 35 and 36.
    backend = engine([pillar(-0.2, 5.1, radius=0.15)])
    assert list(dark_columns(backend.render("eye"), 0)) == [36, 37]


def test_the_scene_turns_counter_clockwise_about_the_origin():
    backend = engine([pillar(0.0, 12.0)])
    before = dark_columns(backend.render("panorama"), 35)
    backend.set_scene_yaw(np.pi / 2)  # the pillar goes to (-12, 0): 90° to the left, 18 columns
    assert backend.scene_yaw_rad == pytest.approx(np.pi / 2)
    np.testing.assert_array_equal(dark_columns(backend.render("panorama"), 35), before - 18)


def test_a_batch_renders_each_agent_as_if_alone():
    objects = [pillar(0.0, 12.0), WorldObject("sphere", (8.0, -3.0, 1.0), (1.0,), (0.9, 0.1, 0.1, 1.0))]
    headings = np.array([0.0, 1.0, -2.0, 2.5])
    positions = np.array([[0.0, 0.0], [1.0, 2.0], [-3.0, 0.5], [2.0, -1.0]])
    together = engine(objects, count=4)
    together.reset(heading_rad=headings)
    together.position[:] = positions
    images = together.render_batch("panorama")
    assert images.shape == (4, 72, 72, 3) and images.dtype == np.uint8
    for k in range(4):
        alone = engine(objects)
        alone.reset(heading_rad=headings[k], position_m=positions[k])
        np.testing.assert_array_equal(alone.render("panorama"), images[k])


def test_cameras_render_only_when_read(monkeypatch):
    import neuronav.senses.raycast as raycast

    calls = []
    original = raycast.RayCaster.render
    monkeypatch.setattr(raycast.RayCaster, "render", lambda self, *a, **k: calls.append(1) or original(self, *a, **k))
    backend = engine([pillar(0.0, 12.0)], count=2)
    backend.write({"turn": np.zeros(2), "stride": np.full(2, 0.3)})
    backend.step(5)
    backend.read(["position", "heading", "speed"])
    assert calls == []
    backend.read(["eye"])
    assert len(calls) == 1


def test_bad_cameras_worlds_and_yaws_are_clear_errors():
    backend = engine()
    with pytest.raises(PortError, match="no sensor 'eye_L'.*available:.*eye, head_pos, head_quat, heading, panorama"):
        backend.read(["eye_L"])
    with pytest.raises(PortError, match="no camera 'eye_L'; available: panorama, eye"):
        backend.render("eye_L")
    with pytest.raises(ConfigError, match="finite"):
        backend.set_scene_yaw(float("nan"))
    with pytest.raises(ConfigError, match="finite"):
        backend.set_scene_yaw("north")
    with pytest.raises(ConfigError, match="cameras need a flat ground.*'uneven' ground with roughness_m 0.1"):
        engine(ground=Ground(kind="uneven", roughness_m=0.1))
    with pytest.raises(ConfigError, match="cameras need a flat ground without a wall.*'wall'"):
        engine(ground=Ground(kind="wall"))
    engine(cameras=(), ground=Ground(kind="uneven", roughness_m=0.1))  # no cameras: any ground, as before
    with pytest.raises(ConfigError, match="a name is used twice"):
        engine(cameras=(EYE, EYE))
    with pytest.raises(ConfigError, match="would hide the sensor"):
        engine(cameras=(Camera("heading", "agent", (0.0, 0.0, 0.5)),))
    with pytest.raises(ConfigError, match="planar camera needs 0 < fov < π"):
        engine(cameras=(Camera("wide", "agent", (0.0, 0.0, 0.5), fov_rad=(3.5, 1.0)),))
    with pytest.raises(ConfigError, match=r"object 0 \(sphere\): size_m needs 1 positive values"):
        engine([WorldObject("sphere", (0.0, 5.0, 1.0), (-1.0,))])
