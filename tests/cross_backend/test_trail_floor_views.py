"""Odour trails drawn on the floor, the same on MuJoCo, PyBullet and the kinematic ray caster.

A camera looking straight down from 0.6 m shows the trails' floor image (:mod:`neuronav.senses.trail_floor`)
where its rays meet the floor, on every backend; the ant's own eyes, standing beside a trail, see
the same share of trail pixels in the same columns; the follow view (videos) shows the trail where
it lies; the drawing touches no physics, and a world without trails builds nothing for it.
"""

import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from neuronav import registry  # noqa: E402
from neuronav.scenarios.worlds.scenes import vision_appearance  # noqa: E402
from neuronav.senses.chemistry import OdourScene  # noqa: E402
from neuronav.senses.odour import PolylineTrail, straight_trail  # noqa: E402
from neuronav.senses.plume import PlumeConfig  # noqa: E402
from neuronav.senses.trail_floor import TRAIL_RGB, ground_rgb_at, trail_floor  # noqa: E402
from neuronav.senses.vision import pixel_directions, to_uint8  # noqa: E402
from neuronav.spec.body import BodySpec, Camera, Geom, Joint, Segment  # noqa: E402
from neuronav.spec.world import Appearance, PointAgents, World  # noqa: E402

BACKENDS = ("kinematic", "mujoco", "pybullet")
PHYSICS = ("mujoco", "pybullet")
EYE_Z_M = 0.6
# Looking straight down: the camera's frame is the body's (image x along +x, image up along +y).
DOWN = Camera("down", "base", (0.0, 0.0, 0.1), (1.0, 0.0, 0.0, 0.0), width_px=64, height_px=48, fov_rad=(2.0, 1.7))
BENT = PolylineTrail(np.array([[-1.3, -0.2], [0.4, -0.2], [0.4, 0.6]]), 0.15, 0.04)
TRAIL_UINT8 = to_uint8(TRAIL_RGB).astype(int)


def require(name: str) -> None:
    if name != "kinematic":
        pytest.importorskip(name, reason=f"{name} is not installed")


def post() -> BodySpec:
    """A small box welded to the world at 0.5 m carrying the downward camera (0.6 m above the floor)."""
    base = Segment("base", None, (Geom("box", (0.02, 0.02, 0.02), rgba=(1.0, 0.0, 1.0, 1.0)),), 1.0,
                   Joint("weld", kind="fixed"))
    return BodySpec("post", (base,), cameras=(DOWN,), spawn_height_m=0.5)


def engine_and_body(name: str, camera_body: str = "post"):
    require(name)
    engine = registry.load("backend", name)(timestep_s=0.008 if name == "kinematic" else 0.002)
    if camera_body == "post":
        if name == "kinematic":  # the same camera in the agent's frame: origin on the ground under it
            return engine, PointAgents(count=1, mode="unicycle", cameras=(Camera(
                "down", "base", (0.0, 0.0, EYE_Z_M), DOWN.quat, width_px=DOWN.width_px, height_px=DOWN.height_px,
                fov_rad=DOWN.fov_rad),))
        return engine, post()
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.visual_setup import point_agent_cameras

    if name == "kinematic":
        return engine, PointAgents(count=1, mode="unicycle", cameras=point_agent_cameras(desert_ant()))
    return engine, desert_ant()


def render(name: str, world: World, camera: str, camera_body: str = "post", yaw_rad: float = 0.0) -> np.ndarray:
    engine, body = engine_and_body(name, camera_body)
    with engine:
        engine.load(world, [body])
        engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=yaw_rad)
        return engine.render(camera).astype(int)


def expected_down(world: World) -> tuple[np.ndarray, np.ndarray]:
    """What the downward camera should show (uint8 (H, W, 3) as int) and where the floor image lies."""
    rays = pixel_directions(DOWN)
    points = (-EYE_Z_M / rays[..., 2])[..., None] * rays[..., :2]
    image = to_uint8(ground_rgb_at(world.appearance, points[..., 0], points[..., 1])).astype(int)
    rgb, inside = trail_floor(world).rgb_at(points)
    image[inside] = rgb[inside]
    return image, inside


def trail_pixels(image: np.ndarray) -> np.ndarray:
    return np.abs(image - TRAIL_UINT8).max(-1) <= 3


@pytest.mark.parametrize("appearance", [Appearance(ground_texture="plain", ground_rgb=(0.7, 0.6, 0.4)),
                                        Appearance(ground_texture="checker", checker_m=0.3)])
def test_a_downward_camera_sees_the_trail_where_it_lies_on_every_backend(appearance):
    world = World(appearance=appearance, odour=OdourScene(trails=(BENT,)))
    expected, inside = expected_down(world)
    assert 0.3 < inside.mean() < 0.95
    fractions = {}
    for name in BACKENDS:
        image = render(name, world, "down")
        # Pixel for pixel the floor image (or the ground around it); a pixel on a texel's edge may show its neighbour.
        matches = (np.abs(image - expected) <= 2).all(-1)
        assert matches.mean() > 0.99, (name, matches.mean())
        fractions[name] = trail_pixels(image).mean()
    assert fractions["kinematic"] > 0.05
    assert max(fractions.values()) - min(fractions.values()) <= 0.005, fractions


def test_the_ants_eyes_see_the_trail_beside_it_alike_on_every_backend():
    world = World(appearance=vision_appearance(), odour=OdourScene(trails=(straight_trail((-6.0, 0.5), (6.0, 0.5)),)))
    seen = {}
    for name in BACKENDS:
        seen[name] = {camera: trail_pixels(render(name, world, camera, "ant", yaw_rad=0.3))
                      for camera in ("eye_L", "eye_R", "panorama")}
    for camera in ("eye_L", "eye_R", "panorama"):
        share = {name: seen[name][camera].mean() for name in BACKENDS}
        columns = {name: np.flatnonzero(seen[name][camera].any(axis=0)).mean() for name in BACKENDS}
        assert share["kinematic"] > 0.01, (camera, share)
        assert max(share.values()) - min(share.values()) <= 0.1 * share["kinematic"], (camera, share)
        assert max(columns.values()) - min(columns.values()) <= 1.0, (camera, columns)


def follow_floor_concentration(view, trail) -> np.ndarray:
    """The trail's concentration where each follow-view pixel's ray meets the floor, (H, W)."""
    width, height = view.size_px
    forward = (view.target - view.eye) / view.distance_m
    up = np.asarray(view.up, float)
    rotation = np.column_stack([np.cross(forward, up), up, -forward])
    fov_v = np.radians(view.fov_deg)
    fov_h = 2.0 * np.arctan(np.tan(fov_v / 2.0) * width / height)
    camera = Camera("follow", "root", (0.0, 0.0, 0.0), width_px=width, height_px=height, fov_rad=(fov_h, fov_v))
    rays = pixel_directions(camera) @ rotation.T
    reach = -view.eye[2] / np.minimum(rays[..., 2], -1e-12)
    return trail.concentration_at(view.eye[:2] + reach[..., None] * rays[..., :2])


@pytest.mark.parametrize("name", PHYSICS)
def test_the_follow_view_shows_the_trail_beside_the_ant(name):
    trail = straight_trail((-6.0, 0.8), (6.0, 0.8))
    images = {}
    for label, world in (("trail", World(odour=OdourScene(trails=(trail,)))), ("none", World())):
        engine, body = engine_and_body(name, "ant")
        with engine:
            engine.load(world, [body])
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=0.0)
            images[label] = engine.render("follow").astype(int)
            view = engine.follow_view()
    concentration = follow_floor_concentration(view, trail)
    on, off = concentration > 0.99, concentration == 0.0
    assert on.sum() > 5000
    darker = images["trail"].sum(-1) < images["none"].sum(-1) - 30
    changed = np.abs(images["trail"] - images["none"]).sum(-1) > 30
    assert darker[on].mean() > 0.98
    assert changed[off].mean() < 0.02  # the checker floor goes on under the image's margin


@pytest.mark.parametrize("name", PHYSICS)
def test_the_drawn_trail_touches_no_physics(name):
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.bodies.gaits import make_gait

    # The trail runs under the ant: the walk is the same to the bit with and without it.
    trail = straight_trail((-3.0, 0.0), (3.0, 0.0), "wide")
    states = []
    for world in (World(odour=OdourScene(trails=(trail,))), World()):
        require(name)
        ant = desert_ant()
        gait = make_gait("tripod", ant)
        with registry.load("backend", name)(timestep_s=0.002) as engine:
            engine.load(world, [ant])
            engine.reset(seed=0)
            for k in range(25):
                engine.write({"joint_targets": gait.targets_at(k)})
                engine.step(4)
            states.append(engine.read(("position", "joint_pos")))
    for key in states[0]:
        np.testing.assert_array_equal(states[0][key], states[1][key])


def test_a_world_without_trails_builds_nothing_for_them():
    from neuronav.backends.mujoco.mjcf import TRAIL_GEOM, compile_model

    require("mujoco")
    mujoco = pytest.importorskip("mujoco")
    plume_only = World(odour=OdourScene(plume=PlumeConfig()))
    model, _ = compile_model(plume_only, post())
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, TRAIL_GEOM) == -1
    assert model.ntex == compile_model(World(), post())[0].ntex
    model, _ = compile_model(World(odour=OdourScene(trails=(BENT,))), post())
    geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, TRAIL_GEOM)
    assert geom >= 0 and model.geom_contype[geom] == 0 and model.geom_conaffinity[geom] == 0
    for name in BACKENDS:
        # Renders of a world with odour but no trail are those of the world without odour.
        require(name)
        np.testing.assert_array_equal(render(name, plume_only, "down"), render(name, World(), "down"))


@pytest.mark.parametrize("name", PHYSICS)
def test_the_videos_checker_floor_has_squares_of_checker_m_with_the_shared_parity(name):
    """Seen from 6 m straight above (lit), the floor's lighter squares are those of ``ground_rgb``
    (``floor(x/s) + floor(y/s)`` even), squares of ``checker_m``: as the trails' image draws them."""
    from neuronav.engine.articulated import FollowView

    look = Appearance(ground_texture="checker", checker_m=0.4)
    # Looking down, a little toward +y, image up along +y (MuJoCo's free camera takes its up from the look).
    view = FollowView(eye=np.array([0.3, 0.19, 6.0]), target=np.array([0.3, 0.2, 0.0]), up=np.array([0.0, 1.0, 0.0]),
                      distance_m=6.0)
    engine, body = engine_and_body(name)
    with engine:
        engine.load(World(appearance=look), [body])
        engine.reset(seed=0, position_m=(20.0, 20.0))  # the post out of sight
        image = engine._render_follow(view).astype(float).mean(-1)
    eye = view.eye
    forward = (view.target - eye) / np.linalg.norm(view.target - eye)
    camera_up = np.cross(np.cross(forward, view.up), forward)
    camera_up /= np.linalg.norm(camera_up)
    rotation = np.column_stack([np.cross(forward, camera_up), camera_up, -forward])
    width, height = view.size_px
    fov_v = np.radians(view.fov_deg)
    camera = Camera("top", "root", (0.0, 0.0, 0.0), width_px=width, height_px=height,
                    fov_rad=(2.0 * np.arctan(np.tan(fov_v / 2.0) * width / height), fov_v))
    rays = pixel_directions(camera) @ rotation.T
    points = eye[:2] + (-eye[2] / rays[..., 2])[..., None] * rays[..., :2]
    odd = (np.floor(points / look.checker_m).sum(-1) % 2) == 1
    assert (image[~odd].mean() - image[odd].mean()) > 25  # ground_rgb is the lighter colour
    lighter = image > 0.5 * (image[~odd].mean() + image[odd].mean())
    # PyBullet draws the follow view at half its size a side (backends/pybullet/camera.py, FOLLOW_SCALE): its
    # square edges land within a pixel or two (96 % of the pixels agree; a wrong parity or size gives <= 50 %).
    assert (lighter == ~odd).mean() > (0.95 if name == "pybullet" else 0.97)


def test_the_mjcf_text_of_a_world_with_trails_names_their_texture_file(tmp_path):
    mujoco = pytest.importorskip("mujoco")
    from neuronav.backends.mujoco.mjcf import compile_model, to_xml
    from neuronav.errors import ConfigError

    world = World(odour=OdourScene(trails=(BENT,)))
    with pytest.raises(ConfigError, match="asset_dir"):
        to_xml(world, post())
    loaded = mujoco.MjModel.from_xml_string(to_xml(world, post(), asset_dir=str(tmp_path)))
    built, _ = compile_model(world, post())
    texture = {model: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "trails") for model in (loaded, built)}
    data = [model.tex_data[model.tex_adr[t]:model.tex_adr[t] + model.tex_height[t] * model.tex_width[t] * 3]
            for model, t in texture.items()]
    np.testing.assert_array_equal(data[0], data[1])
    np.testing.assert_array_equal(data[1], trail_floor(world).image.ravel())
