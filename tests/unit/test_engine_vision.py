"""Body cameras of both physics engines against geometry: flat colours, the sky, the ground, columns, the
body, scene yaw. One test per claim, run on MuJoCo and on PyBullet (each within its renderer's tolerance)."""

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from neuronav.engine.backend import quat_product
from neuronav.senses.vision import GROUND_REACH_M, pixel_directions, sky_rgb, to_uint8
from neuronav.spec.body import BodySpec, Camera, Geom, Joint, Segment, axis_angle_quat, quat_to_matrix
from neuronav.spec.world import Appearance, World, WorldObject

PLAIN = Appearance(ground_texture="plain", sky_rgb=(0.5, 0.7, 0.9), ground_rgb=(0.7, 0.6, 0.4))
EYE_Z_M = 0.6  # the cameras' height: the fixed base's centre at 0.5 m, the cameras 0.1 m above it
LEVEL_QUAT = np.array([0.5, 0.5, -0.5, -0.5])  # camera frame: x = -y (right), y = z (up), looks along -z = +x


@dataclasses.dataclass(frozen=True)
class Engine:
    """What differs between the engines' tests: the backend, its renderer's tolerances, its own calls."""

    name: str
    backend: type
    colour_atol: int  # flat colours of objects and the sky (0-255)
    pixel_atol: int  # ground, checker and scenery pixels (0-255)
    checker_fraction: float  # ground pixels of the expected checker colour (square edges may show the neighbour)
    ray_down: Callable[[Any, float, float], float]  # height of the first world geom under (x, y), rays from 3 m
    ray_atol_m: float
    render_call: tuple[Any, str]  # (module, function) every eye render goes through
    eyes_attribute: str  # the backend's rendering state, None until an eye is read

    def follow_view_colours(self, backend, image: np.ndarray, appearance: Appearance) -> None:
        """The follow view's sky and floor are the appearance's (the sky seen by the camera turned level:
        the floor reaches the horizon, so the follow view's own pose, 25° down, shows none)."""
        from neuronav.engine.articulated import FollowView

        level = FollowView(np.array([0.0, -3.0, 0.5]), np.array([0.0, 0.0, 0.5]), np.array([0.0, 0.0, 1.0]), 3.0)
        np.testing.assert_allclose(backend._render_follow(level)[0, 0], to_uint8(appearance.sky_rgb), atol=1)
        if self.name == "pybullet":
            return
        import mujoco

        model = backend.model
        sand = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "sand")  # the plain ground's texture
        ground = model.tex_data[model.tex_adr[sand]:model.tex_adr[sand] + 3]
        np.testing.assert_array_equal(ground, to_uint8(appearance.ground_rgb))


def _mujoco() -> Engine:
    mujoco = pytest.importorskip("mujoco")
    from neuronav.backends.mujoco import MujocoBackend

    def ray_down(backend, x: float, y: float) -> float:
        geom = np.array([-1], dtype=np.int32)
        groups = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)  # world geoms only
        return 3.0 - mujoco.mj_ray(backend.model, backend.data, np.array([x, y, 3.0]), np.array([0.0, 0.0, -1.0]),
                                   groups, 1, -1, geom)

    return Engine("mujoco", MujocoBackend, colour_atol=2, pixel_atol=2, checker_fraction=0.97, ray_down=ray_down,
                  ray_atol_m=1e-6, render_call=(mujoco, "mjr_render"), eyes_attribute="_eyes")


def _pybullet() -> Engine:
    pb = pytest.importorskip("pybullet")
    from neuronav.backends.pybullet import PybulletBackend

    def ray_down(backend, x: float, y: float) -> float:
        return pb.rayTest([x, y, 3.0], [x, y, -1.0], physicsClientId=backend.client_id)[0][3][2]

    return Engine("pybullet", PybulletBackend, colour_atol=3, pixel_atol=0, checker_fraction=0.99, ray_down=ray_down,
                  ray_atol_m=2e-3, render_call=(pb, "getCameraImage"), eyes_attribute="_vision")


@pytest.fixture(params=["mujoco", "pybullet"])
def engine(request) -> Engine:
    return {"mujoco": _mujoco, "pybullet": _pybullet}[request.param]()


def camera_quat(yaw_rad: float = 0.0, pitch_rad: float = 0.0) -> tuple:
    """A camera looking along +x turned by yaw (counter-clockwise from above), pitched up by pitch."""
    turn = quat_product(np.array(axis_angle_quat((0, 0, 1), yaw_rad)), np.array(axis_angle_quat((0, -1, 0), pitch_rad)))
    return tuple(quat_product(turn, LEVEL_QUAT))


def fixed_body(*cameras: Camera) -> BodySpec:
    """A small box welded to the world at (0, 0, 0.5) with the given cameras (on its segment ``base``)."""
    base = Segment("base", None, (Geom("box", (0.02, 0.02, 0.02), rgba=(1.0, 0.0, 1.0, 1.0)),), 1.0,
                   Joint("weld", kind="fixed"))
    return BodySpec("post", (base,), cameras=cameras, spawn_height_m=0.5)


def eye(yaw_rad=0.0, pitch_rad=0.0, **kwargs) -> Camera:
    """The ant's eye's image: 74 x 19, fov (2.0, 0.5), 0.1 m above the box's centre."""
    settings = {"width_px": 74, "height_px": 19, "fov_rad": (2.0, 0.5)} | kwargs
    return Camera("eye", "base", (0.0, 0.0, 0.1), camera_quat(yaw_rad, pitch_rad), **settings)


def panorama() -> Camera:
    return Camera("pano", "base", (0.0, 0.0, 0.1), camera_quat(), 72, 72, (2 * np.pi, np.pi), "spherical")


def world_rays(camera: Camera) -> np.ndarray:
    """Each pixel's world ray (H, W, 3) for a camera of :func:`fixed_body` (the base does not turn)."""
    return pixel_directions(camera) @ quat_to_matrix(camera.quat).T


def loaded(engine: Engine, world: World, *cameras: Camera):
    backend = engine.backend()
    backend.load(world, [fixed_body(*cameras)])
    return backend


def dark_pixels(image: np.ndarray) -> np.ndarray:
    return image.astype(int).sum(-1) < 60


def scenery(image: np.ndarray, atol: int) -> np.ndarray:
    """Pixels within ``atol`` of the plain sky or the plain ground."""
    image = image.astype(int)
    return ((np.abs(image - to_uint8(PLAIN.sky_rgb)) <= atol).all(-1)
            | (np.abs(image - to_uint8(PLAIN.ground_rgb)) <= atol).all(-1))


def test_a_box_shows_exactly_its_colour_and_the_ground_its_own(engine):
    rgba = (0.3, 0.55, 0.15, 1.0)
    # A box in the air, 0.7 to 1.9 m high, 2.5 m ahead: it spans ±31° and the rows from 2.3° up.
    world = World(objects=(WorldObject("box", (3.0, 0.0, 1.3), (0.5, 1.5, 0.6), rgba),), appearance=PLAIN)
    with loaded(engine, world, eye()) as backend:
        image = backend.render("eye").astype(int)
    atol = engine.colour_atol
    np.testing.assert_allclose(image[0:7, 30:44], np.broadcast_to(to_uint8(rgba[:3]), (7, 14, 3)), atol=atol)
    np.testing.assert_allclose(image[10:, :], np.broadcast_to(to_uint8(PLAIN.ground_rgb), (9, 74, 3)), atol=atol)


@pytest.mark.parametrize("appearance", [PLAIN, dataclasses.replace(PLAIN, horizon_rgb=(0.95, 0.9, 0.8))])
def test_sky_pixels_are_the_appearance_sky(engine, appearance):
    camera = eye(pitch_rad=0.6, width_px=40, height_px=30, fov_rad=(1.5, 1.4))
    with loaded(engine, World(appearance=appearance), camera) as backend:
        image = backend.render("eye").astype(int)
    rays = world_rays(camera)
    up = rays[..., 2] > 0.0
    assert up.sum() > 200
    np.testing.assert_allclose(image[up], to_uint8(sky_rgb(appearance, rays[up])).astype(int),
                               atol=engine.colour_atol)


def test_the_checker_ground_is_where_the_rays_meet_it(engine):
    appearance = Appearance(ground_texture="checker", checker_m=0.3, ground_rgb=(0.9, 0.8, 0.6),
                            checker_rgb=(0.3, 0.2, 0.1))
    camera = eye(yaw_rad=0.7, pitch_rad=-0.5, width_px=64, height_px=48, fov_rad=(1.6, 1.2))
    with loaded(engine, World(appearance=appearance), camera) as backend:
        image = backend.render("eye").astype(int)
    rays = world_rays(camera)
    reach = -EYE_Z_M / np.minimum(rays[..., 2], -1e-12)
    points = reach[..., None] * rays[..., :2]
    odd = (np.floor(points / appearance.checker_m).sum(-1) % 2 == 1)[..., None]
    expected = to_uint8(np.where(odd, appearance.checker_rgb, appearance.ground_rgb)).astype(int)
    ground = rays[..., 2] < -0.01
    assert ground.sum() > 1000
    # Every ground pixel is one of the two colours; pixels on a square's edge may show its neighbour.
    matching = (np.abs(image[ground] - expected[ground]) <= engine.pixel_atol).all(-1)
    assert matching.mean() > engine.checker_fraction


def test_the_ground_reaches_far_just_below_the_horizon(engine):
    # A row looking 0.1° down meets the ground 344 m away: ground, not sky (GROUND_REACH_M = 500 m).
    camera = eye(pitch_rad=np.radians(-0.1) + 0.25 * (1 - 1 / 19), width_px=8, height_px=19, fov_rad=(0.5, 0.5))
    assert EYE_Z_M / np.tan(np.radians(0.1)) < GROUND_REACH_M
    with loaded(engine, World(appearance=PLAIN), camera) as backend:
        image = backend.render("eye").astype(int)
    atol = engine.pixel_atol
    np.testing.assert_allclose(image[-1], np.broadcast_to(to_uint8(PLAIN.ground_rgb), (8, 3)), atol=atol)
    np.testing.assert_allclose(image[0], np.broadcast_to(to_uint8(PLAIN.sky_rgb), (8, 3)), atol=atol)


def _ant():
    from neuronav.bodies.desert_ant import desert_ant

    return desert_ant()


@pytest.mark.parametrize("sees_body", [False, True])
def test_an_ants_eye_sees_its_body_only_when_asked(engine, sees_body):
    ant = _ant()
    ant = dataclasses.replace(ant, cameras=tuple(dataclasses.replace(c, sees_body=sees_body) for c in ant.cameras))
    with engine.backend() as backend:
        backend.load(World(appearance=PLAIN), [ant])
        image = backend.render("eye_L")
    assert image.shape == (19, 74, 3)
    assert scenery(image, engine.pixel_atol).all() != sees_body


def test_a_camera_that_sees_the_body_does_not_show_it_to_one_that_does_not(engine):
    ant = _ant()
    ant = dataclasses.replace(ant, cameras=tuple(dataclasses.replace(c, sees_body=c.name == "panorama")
                                                 for c in ant.cameras))
    with engine.backend() as backend:
        backend.load(World(appearance=PLAIN), [ant])
        backend.step(20)
        images = {name: backend.render(name) for name in ("eye_L", "panorama", "eye_R")}
    for name, image in images.items():
        assert scenery(image, engine.pixel_atol).all() == (name != "panorama"), name


@pytest.mark.parametrize("bearing_deg", [-130.0, -20.0, 35.0, 160.0])
def test_a_cylinder_lands_in_the_panorama_column_of_its_bearing(engine, bearing_deg):
    bearing = np.radians(bearing_deg)  # counter-clockwise from +x, seen from the camera
    position = (4.0 * np.cos(bearing), 4.0 * np.sin(bearing), 1.0)
    world = World(objects=(WorldObject("cylinder", position, (0.4, 1.0), (0.05, 0.05, 0.05, 1.0)),), appearance=PLAIN)
    with loaded(engine, world, panorama()) as backend:
        image = backend.render("pano")
    # Azimuth is positive to the right (clockwise): column c looks at ((c + 0.5) / 72 - 0.5) 2π.
    expected = (-bearing / (2 * np.pi) + 0.5) * 72 - 0.5
    columns = np.nonzero(dark_pixels(image)[36])[0]
    assert columns.size >= 2
    assert np.mean(columns) == pytest.approx(expected, abs=1.0)


@pytest.mark.parametrize("bearing_deg", [-45.0, 10.0, 50.0])
def test_a_cylinder_lands_in_the_eye_column_of_the_planar_model(engine, bearing_deg):
    bearing = np.radians(bearing_deg)
    position = (3.0 * np.cos(bearing), 3.0 * np.sin(bearing), 1.0)
    world = World(objects=(WorldObject("cylinder", position, (0.06, 1.0), (0.05, 0.05, 0.05, 1.0)),), appearance=PLAIN)
    with loaded(engine, world, eye()) as backend:
        image = backend.render("eye")
    # Planar: column centre c + 0.5 at (tan(-bearing) / tan(fov_h / 2) + 1) / 2 * W.
    expected = (np.tan(-bearing) / np.tan(1.0) + 1.0) / 2.0 * 74 - 0.5
    columns = np.nonzero(dark_pixels(image)[9])[0]
    assert columns.size >= 1
    assert np.mean(columns) == pytest.approx(expected, abs=1.0)


def test_scene_yaw_of_five_degrees_rolls_the_panorama_by_one_column_and_keeps_collisions(engine):
    objects = (WorldObject("cylinder", (3.0, 1.0, 1.0), (0.2, 1.0), (0.05, 0.05, 0.05, 1.0)),
               WorldObject("box", (-2.0, -2.5, 0.5), (0.3, 0.6, 0.5), (0.8, 0.1, 0.1, 1.0)))
    c, s = np.cos(np.radians(5.0)), np.sin(np.radians(5.0))
    x, y = c * 3.0 - s * 1.0, s * 3.0 + c * 1.0  # the cylinder's centre turned by 5° about the origin
    with loaded(engine, World(objects=objects, appearance=PLAIN), panorama()) as backend:
        before = backend.render("pano")
        backend.set_scene_yaw(np.radians(5.0))
        after = backend.render("pano")
        turned = backend.read(["pano"])["pano"][0]
        # The physics world's cylinder moved too: a ray down through its new centre hits its top.
        assert engine.ray_down(backend, x, y) == pytest.approx(2.0, abs=engine.ray_atol_m)
        backend.reset()  # the turn holds across resets
        assert engine.ray_down(backend, x, y) == pytest.approx(2.0, abs=engine.ray_atol_m)
        # ... and the box's new corner region collides: its centre moved from (-2, -2.5) by 5°.
        corner = engine.ray_down(backend, c * -2.0 + s * 2.5, s * -2.0 - c * 2.5)
        assert corner == pytest.approx(1.0, abs=engine.ray_atol_m)
    with loaded(engine, World(objects=objects, appearance=PLAIN), panorama()) as backend:
        backend.set_scene_yaw(np.radians(5.0))  # before the first render: the cameras' world starts turned
        np.testing.assert_array_equal(backend.render("pano"), after)
    # Counter-clockwise is to the left: one column (5°) toward column 0.
    rolled = np.roll(before, -1, axis=1)
    assert (rolled == after).all(-1).mean() > 0.97
    dark_before, dark_after = np.nonzero(dark_pixels(before)[36])[0], np.nonzero(dark_pixels(after)[36])[0]
    assert np.mean(dark_after) - np.mean(dark_before) == pytest.approx(-1.0, abs=0.3)
    np.testing.assert_allclose(turned, (after.astype(float) @ [0.299, 0.587, 0.114]) / 255.0, atol=1e-9)


def test_a_turned_object_still_stops_a_falling_body(engine):
    # A 10 cm box falls onto a plank that exists only after the scene turns by 90°: the plank's (x, y)
    # extent (0.6 m by 0.1 m along x) turned about the origin lies along y, under the box.
    plank = WorldObject("box", (0.0, 0.0, 0.3), (0.6, 0.05, 0.05), (0.5, 0.5, 0.5, 1.0))
    body = BodySpec("cube", (Segment("cube", None, (Geom("box", (0.05, 0.05, 0.05)),), 0.1),), spawn_height_m=0.6)
    with engine.backend() as backend:
        backend.load(World(objects=(plank,)), [body])
        backend.set_scene_yaw(np.pi / 2)
        backend.reset(position_m=(0.0, 0.4, 0.6))
        backend.step(400)
        pos = backend.read(["body_pos"])["body_pos"][0]
    assert pos[2] == pytest.approx(0.35 + 0.05, abs=0.01)  # resting on the plank's top at 0.35 m


def test_camera_sensors_are_grey_images_read_lazily(engine, monkeypatch):
    world = World(objects=(WorldObject("box", (3.0, 0.0, 1.0), (0.5, 1.5, 1.0)),))
    with loaded(engine, world, eye(), panorama()) as backend:
        shapes = {s.name: s.shape for s in backend.capabilities.sensors}
        assert shapes["eye"] == (19, 74) and shapes["pano"] == (72, 72)
        calls = []
        module, function = engine.render_call
        original = getattr(module, function)
        monkeypatch.setattr(module, function, lambda *a, **k: calls.append(1) or original(*a, **k))
        backend.read(["heading", "position", "body_pos"])
        assert calls == [] and getattr(backend, engine.eyes_attribute) is None  # no render, no eye context
        values = backend.read(["eye"])
        assert list(values) == ["eye"] and len(calls) == 1
        assert values["eye"].shape == (1, 19, 74) and values["eye"].dtype == float
        assert 0.0 <= values["eye"].min() and values["eye"].max() <= 1.0
        pano = backend.read(["pano"])["pano"]
        assert pano.shape == (1, 72, 72) and 0.0 <= pano.min() <= pano.max() <= 1.0


def test_the_follow_view_floor_and_sky_come_from_the_appearance(engine):
    appearance = dataclasses.replace(PLAIN, sky_rgb=(0.1, 0.2, 0.9))
    with loaded(engine, World(appearance=appearance), eye()) as backend:
        image = backend.render("follow")
        assert image.shape == (480, 640, 3)
        engine.follow_view_colours(backend, image, appearance)
