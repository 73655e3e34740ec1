"""Videos (issue 26): the same scene on MuJoCo and PyBullet, and what keeps recording cheap.

- The odour trails' floor image shows no rectangle: on MuJoCo's lit follow view the plain floor just
  inside the image's rectangle (no trail there) is as bright as the floor outside it, as on PyBullet
  (MuJoCo clipped a textured surface's light to 1 but not an untextured one's: 10 % darker before).
- With the same camera pose both backends show the horizon on the same row, the World's sky above it
  (the same colours) and the floor below it (PyBullet's video floor ended at ``Ground.size_m``, MuJoCo's
  sky was its own gradient).
- MuJoCo's sky box is the World's sky in every direction.
- The follow view is drawn without multisampling in a GL context the next backend reuses, and without
  the sky box only where no pixel could show the sky; the video's frames are encoded on a thread of their
  own, whose errors reach the caller.
- MuJoCo's follow view is rasterised on a GL thread and each frame drawn on beside the loop: the same frames
  as drawn in the loop, however late they are finished; a frame's error reaches the caller at close.
"""

import contextlib
import dataclasses
import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from neuronav import registry  # noqa: E402
from neuronav.engine.articulated import FollowView  # noqa: E402
from neuronav.scenarios.worlds.scenes import vision_appearance  # noqa: E402
from neuronav.senses.chemistry import OdourScene  # noqa: E402
from neuronav.senses.odour import PolylineTrail  # noqa: E402
from neuronav.senses.trail_floor import trail_floor  # noqa: E402
from neuronav.senses.vision import pixel_directions, sky_rgb, to_uint8  # noqa: E402
from neuronav.spec.body import BodySpec, Camera, Geom, Joint, Segment  # noqa: E402
from neuronav.spec.world import Ground, World  # noqa: E402

PHYSICS = ("mujoco", "pybullet")
TRAIL = PolylineTrail(np.array([[0.0, -0.4], [0.0, 1.0], [0.8, 2.0], [0.8, 3.0], [0.0, 4.0], [0.0, 5.0]]), 0.27, 0.02)
WORLD = World(ground=Ground(size_m=16.0), appearance=vision_appearance(), odour=OdourScene(trails=(TRAIL,)))
UP = np.array([0.0, 0.0, 1.0])


def post() -> BodySpec:
    """A small box welded to the world at 0.5 m (out of every view below)."""
    base = Segment("base", None, (Geom("box", (0.02, 0.02, 0.02)),), 1.0, Joint("weld", kind="fixed"))
    return BodySpec("post", (base,), spawn_height_m=0.5)


def look(eye, target) -> FollowView:
    """The follow camera (640 x 480, 45° vertical field of view) at ``eye`` looking at ``target``, not rolled."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    distance = float(np.linalg.norm(target - eye))
    forward = (target - eye) / distance
    up = np.cross(np.cross(forward, UP), forward)
    return FollowView(eye, target, up / np.linalg.norm(up), distance)


def render(name: str, views: list[FollowView], world: World = WORLD) -> list[np.ndarray]:
    pytest.importorskip(name, reason=f"{name} is not installed")
    with registry.load("backend", name)(timestep_s=0.002) as engine:
        engine.load(world, [post()])
        engine.reset(seed=0)
        return [engine._render_follow(view).astype(int) for view in views]


def floor_points(view: FollowView) -> tuple[np.ndarray, np.ndarray]:
    """Where each pixel's ray meets the floor z = 0 (H, W, 2), and whether it does (H, W)."""
    width, height = view.size_px
    fov_v = np.radians(view.fov_deg)
    fov_h = 2.0 * np.arctan(np.tan(fov_v / 2.0) * width / height)
    camera = Camera("follow", "root", (0.0, 0.0, 0.0), width_px=width, height_px=height, fov_rad=(fov_h, fov_v))
    forward = (view.target - view.eye) / view.distance_m
    rotation = np.column_stack([np.cross(forward, view.up), view.up, -forward])
    rays = pixel_directions(camera) @ rotation.T
    down = rays[..., 2] < -1e-6
    reach = -view.eye[2] / np.where(down, rays[..., 2], -1.0)
    return view.eye[:2] + reach[..., None] * rays[..., :2], down


# Looking down at the trail's middle bend from its right: the floor image's right edge (x = 1.3 m) crosses the view.
TRAIL_EDGE_VIEW = look((2.6, 1.0, 1.6), (1.2, 2.5, 0.0))


def ring_and_outside(view: FollowView) -> tuple[np.ndarray, np.ndarray]:
    """Pixels of plain floor inside the floor image's rectangle (0.3 m or more from the trail's edge, 0.05 m
    from the rectangle's) and outside it (within 1 m of it), (H, W) each."""
    floor = trail_floor(WORLD)
    points, on_floor = floor_points(view)
    (x0, x1), (y0, y1) = floor.x_range_m, floor.y_range_m
    x, y = points[..., 0], points[..., 1]
    inside = (x > x0 + 0.05) & (x < x1 - 0.05) & (y > y0 + 0.05) & (y < y1 - 0.05)
    outside = ((x < x0 - 0.05) | (x > x1 + 0.05) | (y < y0 - 0.05) | (y > y1 + 0.05)) \
        & (x > x0 - 1.0) & (x < x1 + 1.0) & (y > y0 - 1.0) & (y < y1 + 1.0)
    clear = TRAIL.distance_m(points) > TRAIL.width_m / 2 + TRAIL.edge_m + 0.3
    return on_floor & inside & clear, on_floor & outside


def test_the_trails_floor_image_shows_no_darker_rectangle_on_either_backend():
    ring, outside = ring_and_outside(TRAIL_EDGE_VIEW)
    assert ring.sum() > 5000 and outside.sum() > 5000  # the view holds both sides of the rectangle's edge
    contrast = {}
    for name, (image,) in ((name, render(name, [TRAIL_EDGE_VIEW])) for name in PHYSICS):
        grey = image.mean(axis=-1)
        contrast[name] = float(grey[ring].mean() - grey[outside].mean())
    # Before: MuJoCo's rectangle was 15 grey levels darker (153 against 169 in red), PyBullet's 0.
    assert abs(contrast["mujoco"]) < 1.5, contrast
    assert abs(contrast["mujoco"] - contrast["pybullet"]) < 1.5, contrast


# Level, 0.6 m up, looking away from the trail: the horizon (the floor's edge, 500 m away) near the middle row.
LEVEL_VIEW = look((0.0, -2.0, 0.6), (0.0, -6.0, 0.6))


def horizon_rows(image: np.ndarray) -> np.ndarray:
    """Each column's first row from the top whose pixel is floor (bluer than red: sky; the floor is not)."""
    floor = image[..., 2] < image[..., 0]
    return np.argmax(floor, axis=0)


# A checker floor: PyBullet's video floor is its texture over Ground.size_m and a ring of its mean colour beyond.
CHECKER = World(ground=Ground(size_m=16.0),
                appearance=dataclasses.replace(vision_appearance(), ground_texture="checker"))


@pytest.mark.parametrize("world", [WORLD, CHECKER], ids=["plain", "checker"])
def test_the_same_pose_shows_the_same_horizon_sky_and_floor_on_both_backends(world):
    images = {name: render(name, [LEVEL_VIEW], world)[0] for name in PHYSICS}
    # The floor's edge 500 m away from 0.6 m up: 0.07° under the middle row (row 239.5 of 480 at 45°).
    expected_row = 239.5 + np.degrees(np.arctan(0.6 / 500.0)) / 45.0 * 480.0
    for name, image in images.items():
        rows = horizon_rows(image)
        assert np.all(np.abs(rows - expected_row) <= 2.0), (name, rows.min(), rows.max(), expected_row)
        assert (image[rows.max() + 2:, :, 2] < image[rows.max() + 2:, :, 0]).all(), name  # floor all the way down
    mujoco_sky, pybullet_sky = images["mujoco"][:230], images["pybullet"][:230]
    assert np.abs(mujoco_sky - pybullet_sky).max() <= 3  # the World's sky (PyBullet paints sky_rgb itself)
    # the sky is the World's gradient: its pale horizon at the bottom of the sky, bluer above
    assert np.abs(pybullet_sky[-1, 320] - to_uint8(vision_appearance().horizon_rgb)).max() <= 3
    assert pybullet_sky[0, 320, 0] < pybullet_sky[-1, 320, 0] - 10


def test_mujocos_sky_box_is_the_worlds_sky_in_every_direction():
    mujoco = pytest.importorskip("mujoco")
    from neuronav.backends.mujoco.follow_renderer import FollowRenderer

    with registry.load("backend", "mujoco")(timestep_s=0.002) as engine:
        engine.load(WORLD, [post()])
        model, data = engine.model, engine.data
        renderer = FollowRenderer(model, 32, 32)
        option = mujoco.MjvOption()
        option.geomgroup[:] = 0  # nothing but the sky
        model.vis.global_.fovy = 5.0
        worst = 0
        try:
            for azimuth in (0.0, 60.0, 90.0, 180.0, 270.0):
                for elevation in (-30.0, 3.0, 20.0, 50.0, 85.0):
                    camera = mujoco.MjvCamera()
                    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
                    # under the floor (not drawn here): the renderer draws the sky box for every direction
                    camera.lookat[:], camera.distance = (0.0, 0.0, -50.0), 1.0
                    camera.azimuth, camera.elevation = azimuth, elevation
                    got = renderer.render(model, data, camera, option)[16, 16].astype(int)
                    a, e = np.radians(azimuth), np.radians(elevation)
                    direction = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
                    worst = max(worst, int(np.abs(got - to_uint8(sky_rgb(WORLD.appearance, direction))).max()))
        finally:
            renderer.close()
    assert worst <= 2


def test_the_follow_view_has_no_multisampling_and_the_next_backend_reuses_its_gl_context():
    pytest.importorskip("mujoco")
    contexts = []
    for _ in range(2):
        with registry.load("backend", "mujoco")(timestep_s=0.002) as engine:
            engine.load(WORLD, [post()])
            engine.reset(seed=0)
            assert engine.render("follow").shape == (480, 640, 3)
            (renderer,) = engine._renderers.values()
            assert renderer._context.offSamples == 0
            assert engine.model.vis.quality.offsamples == 4  # the model's own setting is left as it was
            contexts.append(renderer._gl)
    assert contexts[0] is contexts[1]


def test_the_follow_views_offscreen_buffer_is_the_views_size_whatever_the_models():
    """The model's offscreen buffer is sized for its widest view (the ant's eyes: 864 px); the follow view draws
    into one of its own 640 x 480 px (the wider one cost 0.6 ms a frame), and shows the same picture."""
    pytest.importorskip("mujoco")
    images = []
    for width_px in (None, 1000):
        with registry.load("backend", "mujoco")(timestep_s=0.002) as engine:
            engine.load(WORLD, [post()])
            engine.reset(seed=0)
            if width_px is not None:
                engine.model.vis.global_.offwidth = width_px
            images.append(engine.render("follow"))
            (renderer,) = engine._renderers.values()
            assert (renderer._context.offWidth, renderer._context.offHeight) == (640, 480)
            assert engine.model.vis.global_.offwidth == (width_px or renderer.buffer_px[0])  # left as it was
            assert images[-1].flags.c_contiguous
    assert images[0].std() > 1.0  # a picture, not a blank
    np.testing.assert_array_equal(images[0], images[1])


def test_frames_are_encoded_on_a_thread_and_its_errors_reach_the_caller(tmp_path):
    import imageio.v2 as imageio

    from neuronav.engine.video import FrameWriter

    writer = FrameWriter(tmp_path / "ok.mp4", fps=10.0)
    buffer = np.zeros((48, 64, 3), np.uint8)
    for k in range(5):
        buffer[:] = 40 * k
        writer.append(buffer[:])  # a view of a buffer the caller reuses: the writer keeps a copy
    writer.close()
    with imageio.get_reader(tmp_path / "ok.mp4") as reader:
        frames = [frame.astype(int) for frame in reader]
    assert len(frames) == 5
    assert [int(np.rint(frame.mean())) for frame in frames] == pytest.approx([0, 40, 80, 120, 160], abs=3)

    broken = FrameWriter(tmp_path / "broken.mp4", fps=10.0)
    broken.append(np.zeros((48, 64, 3), np.uint8))
    broken.append(np.zeros((24, 32, 3), np.uint8))  # imageio refuses a frame of another size (on the thread)
    with pytest.raises(ValueError):
        broken.close()


def test_the_sky_box_is_left_out_only_where_no_pixel_could_show_it(monkeypatch):
    pytest.importorskip("mujoco")
    from neuronav.backends.mujoco.follow_renderer import FollowRenderer

    # From 1.5 m up looking ever closer to level: the follow view's own pitch (25° down), then the sky's edge.
    views = [look((0.0, -3.0, 1.5), (0.0, -3.0 + np.cos(np.radians(pitch)), 1.5 - np.sin(np.radians(pitch))))
             for pitch in (60.0, 25.0, 23.0, 22.8, 22.6, 20.0, 5.0)]
    decided = []
    sees_sky = FollowRenderer.sees_sky

    def recorded(camera, *args):
        decided.append(sees_sky(camera, *args))
        return decided[-1]

    monkeypatch.setattr(FollowRenderer, "sees_sky", staticmethod(recorded))
    chosen = render("mujoco", views)
    monkeypatch.setattr(FollowRenderer, "sees_sky", staticmethod(lambda camera, *args: True))
    always = render("mujoco", views)
    # 22.5° down puts the top edge's middle level; the floor's edge, 500 m away, lies 0.17° under it (corners: less)
    assert decided == [False, False, False, False, True, True, True], decided
    for image, reference in zip(chosen, always):
        np.testing.assert_array_equal(image, reference)


def test_pybullets_half_size_follow_view_is_scaled_up_bilinearly_on_pixel_centres():
    pytest.importorskip("pybullet")
    from neuronav.backends.pybullet.camera import upsample2

    image = np.zeros((3, 4, 3), np.uint8)
    image[:, 2:] = 200  # a vertical edge between columns 1 and 2
    image[2, :, 1] = 40
    big = upsample2(image).astype(int)
    assert big.shape == (6, 8, 3)
    # across the edge: 3/4 of the own pixel and 1/4 of the next, the far pixels and the border unchanged
    assert big[0, :, 0].tolist() == [0, 0, 0, 50, 150, 200, 200, 200]
    assert big[:, 0, 1].tolist() == [0, 0, 0, 10, 30, 40]
    np.testing.assert_array_equal(upsample2(np.full((5, 7, 3), 77, np.uint8)), 77)


def test_pybullets_scaling_up_weighs_each_new_pixel_9_3_3_1_from_its_four_nearest_old_ones():
    pytest.importorskip("pybullet")
    from neuronav.backends.pybullet.camera import upsample2

    image = np.random.default_rng(3).integers(0, 256, (9, 13, 3), dtype=np.uint8)
    image[0, 0] = 255
    old = np.pad(image.astype(int), ((1, 1), (1, 1), (0, 0)), mode="edge")
    expected = np.zeros((18, 26, 3), int)
    for row in range(18):
        for col in range(26):
            i, j = row // 2 + 1, col // 2 + 1
            k, m = i + (1 if row % 2 else -1), j + (1 if col % 2 else -1)  # the nearer neighbours' row, column
            expected[row, col] = (9 * old[i, j] + 3 * old[k, j] + 3 * old[i, m] + old[k, m] + 8) // 16
    np.testing.assert_array_equal(upsample2(image), expected)


class DeferredWriter:
    """A stand-in for :class:`~neuronav.engine.video.FrameWriter` that finishes every frame only at close: what a
    frame drawn in the background shows must not depend on when it is drawn."""

    made: list = []

    def __init__(self, path, fps) -> None:
        self.path, self.items, self.frames = path, [], None
        DeferredWriter.made.append(self)

    def append(self, frame) -> None:
        self.items.append(np.array(frame))

    def append_later(self, make_frame) -> None:
        self.items.append(make_frame)

    def close(self) -> None:
        self.frames = [item() if callable(item) else item for item in self.items]
        self.path.write_bytes(b"")


@pytest.mark.parametrize("engine", ["mujoco", "kinematic"])
def test_frames_drawn_beside_the_loop_are_the_frames_drawn_in_it(tmp_path, monkeypatch, engine):
    if engine != "kinematic":
        pytest.importorskip(engine)
    from neuronav.engine import video
    from neuronav.runs.cli import main

    monkeypatch.setattr(video, "FrameWriter", DeferredWriter)

    def run(name: str) -> None:  # the plume's puffs move and the path grows from frame to frame
        assert main(["run", "plume-tracking", "--backend", engine, "--set", "timeout_s=0.512", "--video",
                     "--out", str(tmp_path / name)]) == 0

    run("beside")
    monkeypatch.setattr(video, "DRAW_BESIDE_LOOP", False)  # the loop draws each frame
    run("in_loop")
    beside, in_loop = DeferredWriter.made[-2:]
    assert all(callable(item) for item in beside.items) and not any(callable(item) for item in in_loop.items)
    assert len(beside.frames) == len(in_loop.frames) == 8
    for k, (a, b) in enumerate(zip(beside.frames, in_loop.frames)):
        np.testing.assert_array_equal(a, b, err_msg=f"frame {k}")


def test_a_frame_that_fails_beside_the_loop_fails_the_close_and_a_closed_view_refuses_to_draw(tmp_path):
    pytest.importorskip("mujoco")
    from neuronav.engine.video import FrameWriter
    from neuronav.errors import ConfigError

    def broken():
        raise RuntimeError("drawing failed")

    writer = FrameWriter(tmp_path / "broken.mp4", fps=10.0)
    writer.append(np.zeros((48, 64, 3), np.uint8))
    writer.append_later(broken)
    with pytest.raises(RuntimeError, match="drawing failed"):
        writer.close()

    with registry.load("backend", "mujoco")(timestep_s=0.002) as engine:
        engine.load(WORLD, [post()])
        engine.reset(seed=0)
        later = engine.render_later("follow")
        (renderer,) = engine._renderers.values()
        renderer.close()  # waits for the frame being drawn
        assert later.done() and later.result().shape == (480, 640, 3)
        with pytest.raises(ConfigError, match="after close"):
            renderer.render_later(engine.model, engine.data, engine._follow_camera(engine.follow_view()),
                                  engine._follow_option)


FOLLOW_FORK = """
import os
import numpy as np
from neuronav import registry
from neuronav.scenarios.worlds.scenes import compass_scene
from neuronav.bodies.desert_ant import desert_ant

engine = registry.load("backend", "mujoco")()
engine.load(compass_scene(), [desert_ant()])
engine.reset(seed=0)
parent = engine.render("follow")
pid = os.fork()
if pid == 0:  # the parent's GL thread is not in the child: it draws on a thread and in a context of its own
    try:
        child = engine.render_later("follow").result(timeout=20)
        engine.close()
        print("child", "same" if np.array_equal(parent, child) else "different", flush=True)
    except Exception as error:
        print("child", type(error).__name__, error, flush=True)
    os._exit(0)
os.waitpid(pid, 0)
print("parent", "same" if np.array_equal(parent, engine.render("follow")) else "different", flush=True)
engine.close()
"""


def test_a_forked_child_draws_the_follow_view_on_a_gl_thread_of_its_own():
    pytest.importorskip("mujoco")
    import subprocess
    import sys

    environment = dict(os.environ, MUJOCO_GL="egl")
    environment.pop("LP_NUM_THREADS", None)
    try:
        done = subprocess.run([sys.executable, "-c", FOLLOW_FORK], capture_output=True, text=True, timeout=120,
                              env=environment)
    except subprocess.TimeoutExpired:
        pytest.fail("a child forked after the follow view was drawn hung")
    assert "child same" in done.stdout and "parent same" in done.stdout, done.stdout + done.stderr


def test_join_videos_plays_the_parts_one_after_the_other_and_removes_them(tmp_path):
    from neuronav.engine.video import FrameWriter, join_videos

    imageio = pytest.importorskip("imageio.v2")
    parts = [tmp_path / "a.partial.mp4", tmp_path / "missing.partial.mp4", tmp_path / "b.partial.mp4"]
    for part, (count, level) in zip(parts[::2], ((3, 40), (5, 200))):
        writer = FrameWriter(part, 10.0)
        for _ in range(count):
            writer.append(np.full((48, 64, 3), level, np.uint8))
        writer.close()
    joined = tmp_path / "trial0.mp4"
    join_videos(parts, joined)
    with imageio.get_reader(joined) as reader:
        levels = [int(np.asarray(frame).mean()) for frame in reader]
    assert len(levels) == 8 and max(levels[:3]) < 60 and min(levels[3:]) > 180  # a's 3 frames, then b's 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trial0.mp4"]
    join_videos([tmp_path / "none.mp4"], tmp_path / "nothing.mp4")  # nothing written: nothing made
    assert not (tmp_path / "nothing.mp4").exists()


def test_a_trial_that_did_not_finish_leaves_its_video_under_the_temporary_name(tmp_path):
    """Only a finished trial's video gets its name (reports leave ``*.partial.mp4`` out): stopped or failed, the
    frames taken so far stay in the partial file."""
    from types import SimpleNamespace

    from neuronav.engine.video import VideoRecorder

    class Camera:
        def render(self, camera):
            return np.full((48, 64, 3), 90, np.uint8)

    loop = SimpleNamespace(backend=Camera(), clocks=SimpleNamespace(control_dt_s=0.008), control_steps=0)
    for finishes in (True, False):
        path = tmp_path / f"trial{int(finishes)}.mp4"
        with pytest.raises(RuntimeError) if not finishes else contextlib.nullcontext():
            with VideoRecorder(path, every=1) as recorder:
                recorder.initialize_episode(loop)
                for step in range(1, 6):
                    loop.control_steps = step
                    recorder.after_step(loop)
                if not finishes:
                    raise RuntimeError("the trial broke")
        assert path.exists() == finishes
        assert path.with_suffix(".partial.mp4").exists() != finishes
