"""What the videos show (issue 26): the overlay's camera math, the kinematic backend's view from above,
the plume's puffs on every backend, the objects of the compass world and the brain's inset."""

import numpy as np
import pytest

from neuronav import registry
from neuronav.engine.articulated import FollowView
from neuronav.engine.loop import AgentLoop, Clocks
from neuronav.engine.video_overlay import (
    PUFF_RGB,
    PerspectiveCamera,
    PopulationInset,
    VideoContent,
    VideoOverlay,
    camera_of,
)
from neuronav.engine.video_topview import TopView
from neuronav.runs.cli import main
from neuronav.spec.world import PointAgents, World, WorldObject

imageio = pytest.importorskip("imageio.v2")


def read_frames(out):
    videos = list(out.rglob("*.mp4"))
    assert len(videos) == 1, videos
    with imageio.get_reader(videos[0]) as reader:
        return [np.asarray(frame).astype(int) for frame in reader]


def puff_pixels(frame: np.ndarray) -> int:
    """Pixels of the puffs' magenta (after the video's compression), which no ground, sky or object has."""
    r, g, b = frame[..., 0], frame[..., 1], frame[..., 2]
    return int(((r > 200) & (g < 100) & (b > 150)).sum())


def near_colour(frame: np.ndarray, rgb, tolerance: int = 40) -> int:
    return int((np.abs(frame - np.asarray(rgb, int)).max(axis=-1) <= tolerance).sum())


# -- the camera math -------------------------------------------------------------------------------------
def test_perspective_camera_puts_a_world_point_where_the_pinhole_model_says():
    view = FollowView(eye=np.array([0.0, -5.0, 0.0]), target=np.zeros(3), up=np.array([0.0, 0.0, 1.0]),
                      distance_m=5.0, fov_deg=45.0, size_px=(640, 480))
    camera = PerspectiveCamera(view)
    focal = 240.0 / np.tan(np.radians(22.5))
    uv, scale, front = camera.project(np.array([[1.0, 0.0, 0.5], [0.0, 0.0, 0.0], [0.0, -6.0, 0.0]]))
    # 1 m right and 0.5 m up at 5 m depth: right of and above the centre ((W - 1) / 2, (H - 1) / 2).
    assert uv[0] == pytest.approx([319.5 + focal / 5.0, 239.5 - focal * 0.5 / 5.0])
    assert uv[1] == pytest.approx([319.5, 239.5])
    assert scale[0] == pytest.approx(focal / 5.0)
    assert front.tolist() == [True, True, False]  # the last point is behind the eye


def test_top_view_maps_metres_to_pixels_with_y_up():
    view = TopView(centre_m=(1.0, 2.0), m_per_px=0.1, size_px=(640, 480))
    uv = view.project(np.array([[1.0, 2.0, 0.0], [2.0, 2.0, 0.0], [1.0, 3.0, 0.0]]))[0]
    np.testing.assert_allclose(uv, [[319.5, 239.5], [329.5, 239.5], [319.5, 229.5]])


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_overlay_projection_lands_on_the_engines_own_picture_of_a_ball(engine):
    """A red ball rendered by the engine's follow camera sits where the overlay projects its centre."""
    pytest.importorskip(engine)
    from neuronav.bodies.desert_ant import desert_ant

    world = World(objects=(WorldObject("sphere", (0.8, 1.6, 0.1), (0.1,), (1.0, 0.0, 0.0, 1.0)),))
    with registry.load("backend", engine)(timestep_s=0.002) as backend:
        backend.load(world, [desert_ant()])
        backend.reset(seed=0, yaw_rad=np.pi / 2)
        image = backend.render("follow").astype(int)
        uv = camera_of(backend).project(np.array([0.8, 1.6, 0.1]))[0]
    rows, cols = np.nonzero((image[..., 0] > 150) & (image[..., 1] < 60) & (image[..., 2] < 60))
    assert rows.size > 100
    assert np.hypot(cols.mean() - uv[0], rows.mean() - uv[1]) < 3.0, (cols.mean(), rows.mean(), uv)


# -- videos ---------------------------------------------------------------------------------------------------
def test_kinematic_plume_video_films_from_above_and_shows_the_puffs(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "plume-tracking", "--backend", "kinematic", "--set", "timeout_s=1.28", "--video",
                 "--out", str(out)]) == 0
    frames = read_frames(out)
    assert frames[0].shape == (480, 640, 3)
    assert min(puff_pixels(f) for f in frames) > 50
    assert near_colour(frames[-1], (200, 0, 0)) > 20  # the source


def test_kinematic_compass_video_shows_the_five_objects(tmp_path):
    from neuronav.scenarios.worlds.scenes import compass_scene

    out = tmp_path / "run"
    assert main(["run", "visual-compass", "--backend", "kinematic", "--set", "duration_s=1.28", "--video",
                 "--out", str(out)]) == 0
    frame = read_frames(out)[-1]
    for obj in compass_scene().objects:
        assert near_colour(frame, np.asarray(obj.rgba[:3]) * 255, 30) > 200, obj


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_physics_plume_video_shows_the_puffs(tmp_path, engine):
    pytest.importorskip(engine)
    out = tmp_path / "run"
    assert main(["run", "plume-tracking", "--backend", engine, "--set", "timeout_s=0.512", "--video",
                 "--out", str(out)]) == 0
    frames = read_frames(out)
    assert len(frames) == 8
    assert min(puff_pixels(f) for f in frames) > 50


def test_puff_colour_is_what_the_tests_look_for():
    assert puff_pixels(np.array([[PUFF_RGB]])) == 1


# -- insets ----------------------------------------------------------------------------------------------------
def test_population_inset_moves_with_the_bump():
    backend = registry.load("backend", "kinematic")()
    backend.load(World(), [PointAgents(count=1, mode="unicycle")])
    loop = AgentLoop(backend, None, Clocks(physics_dt_s=0.008, control_dt_s=0.008, brain_dt_s=0.64))
    loop.reset(seed=0)
    rates = np.zeros(8)
    overlay = VideoOverlay(VideoContent(insets=(PopulationInset("TB1", lambda _: rates),)))
    frames = []
    for peak in (1, 5):
        rates[:] = np.exp(-0.5 * (np.arange(8) - peak) ** 2)
        loop.step()
        frames.append(overlay(backend.render("follow"), loop).astype(int))
    corner = np.s_[-100:, :220]  # the insets' corner
    difference = np.abs(frames[1][corner] - frames[0][corner]).sum(axis=-1)
    assert (difference > 100).sum() > 200
    # The two bumps sit apart: the first frame's brightest bar is left of the second's.
    bright = [np.nonzero(f[corner][..., 0] > 200)[1].mean() for f in frames]
    assert bright[0] < bright[1]


@pytest.mark.parametrize("args, message", [
    (["path-integration"], "the stone2017 protocol has none"),
    (["cue-integration"], "on kinematic its trials run as one batch"),
    (["route-following", "--set", "forest_seed=3"], "the trials run as one batch"),
])
def test_video_of_a_batch_without_an_agent_loop_is_refused_before_any_trial(tmp_path, capsys, args, message):
    out = tmp_path / "run"
    assert main(["run", *args, "--backend", "kinematic", "--video", "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_boxs_blend_is_the_blend_of_the_same_rectangle_as_a_mask():
    from neuronav.engine.video_draw import blend, blend_box

    image = np.random.default_rng(5).integers(0, 256, (40, 60, 3), dtype=np.uint8)
    mask = np.zeros(image.shape[:2], bool)
    mask[7:31, 12:50] = True
    expected = image.copy()
    blend(expected, mask, (25, 25, 25), 0.75)
    blend_box(image, slice(7, 31), slice(12, 50), (25, 25, 25), 0.75)
    np.testing.assert_array_equal(image, expected)
    assert (expected[7:31, 12:50] < 90).all() and not (expected[:7] < 90).all()  # the box darkened, not the rest


def test_a_polyline_is_each_segment_3_px_wide_from_end_to_end_and_no_more():
    """Each segment sampled at most 0.7 px apart, both ends included (all segments at once), a 3 px disc at each
    sample: an L along the pixel grid covers exactly the pixels within 1 px of it; a diagonal every pixel within
    0.8 px of it and none farther than 2 px; a NaN point breaks the line."""
    from neuronav.engine.video_draw import polyline_mask

    points = np.array([[10.0, 20.0], [50.0, 20.0], [50.0, 35.0], [57.3, 41.9]])
    mask = polyline_mask((60, 80), points, 3.0)
    rows, columns = np.mgrid[0:60, 0:80]
    a, b = points[2], points[3]
    t = np.clip(((columns - a[0]) * (b[0] - a[0]) + (rows - a[1]) * (b[1] - a[1])) / np.sum((b - a) ** 2), 0, 1)
    diagonal_px = np.hypot(columns - (a[0] + t * (b[0] - a[0])), rows - (a[1] + t * (b[1] - a[1])))
    grid = np.zeros((60, 80), bool)
    grid[19:22, 9:52] = True  # along row 20 from column 10 to 50, one pixel each side
    grid[19:37, 49:52] = True  # down column 50 from row 20 to 35
    assert (mask[grid]).all() and (mask[~grid] == (mask & (diagonal_px <= 2.0))[~grid]).all()
    assert mask[diagonal_px <= 0.8].all()
    assert mask[36:43, 50:59].sum() > 20  # the diagonal drawn, end to end
    assert mask[42, 57] and not mask[45, 60]
    broken = polyline_mask((60, 80), np.array([[10.0, 5.0], [30.0, 5.0], [np.nan, np.nan], [40.0, 5.0],
                                               [45.0, 5.0]]), 3.0)
    assert broken[5, 10:31].all() and not broken[5, 32:39].any() and broken[5, 40:46].all()  # a gap at the NaN


# -- the swarm --------------------------------------------------------------------------------------------------
def test_swarm_film_draws_each_ant_where_it_is_in_its_phase_colour_and_each_home(tmp_path):
    from neuronav.scenarios.swarm_homing import film as swarm_film
    from neuronav.scenarios.swarm_homing.scenario import SWARM_WORLD

    homes = np.array([[-2.0, 0.0], [2.0, 0.0]])
    path = tmp_path / "swarm.mp4"
    recorder = swarm_film.SwarmFilm(path, SWARM_WORLD, homes, nest_radius_m=0.5, control_dt_s=0.008, every=8)
    views, ants = [], np.array([[-2.0, 1.5], [2.5, -1.0]])
    phases = [(False, [np.nan, np.nan]), (True, [np.nan, np.nan]), (True, [np.nan, 3.0])]  # foraging, homing, one home
    for k, (homing, home_at) in enumerate(phases):
        moved = ants + [0.1 * k, 0.0]
        recorder.film(moved, np.zeros(2), np.array(home_at), homing, time_s=k, cpu4=np.arange(16.0))
        views.append((recorder.camera.view, moved))
    recorder.close()
    assert path.exists() and not path.with_suffix(".partial.mp4").exists()
    with imageio.get_reader(path) as reader:
        frames = [np.asarray(frame).astype(int) for frame in reader]
    assert len(frames) == 3
    expected = [(swarm_film.FORAGING_RGB,) * 2, (swarm_film.HOMING_RGB,) * 2,
                (swarm_film.HOMING_RGB, swarm_film.HOME_RGB)]
    for frame, (view, moved), colours in zip(frames, views, expected):
        for (column, row), rgb in zip(np.rint(view.project(moved)[0]).astype(int), colours):
            centre = frame[row - 1: row + 2, column - 1: column + 2].reshape(-1, 3)
            assert np.abs(centre - np.asarray(rgb)).max(axis=1).min() <= 40, (rgb, centre)
        # Each home's ring: pixels of the home colour at the nest radius from it, none at its centre.
        for column, row in np.rint(view.project(homes)[0]).astype(int):
            radius_px = int(round(0.5 / view.m_per_px))
            ring = frame[row, column + radius_px - 3: column + radius_px + 2]
            assert np.abs(ring - np.asarray(swarm_film.HOME_RGB)).max(axis=1).min() <= 40
            assert np.abs(frame[row, column] - np.asarray(swarm_film.HOME_RGB)).max() > 60
    # The path walked between the frames: path colour between the first and the last position of ant 0.
    view = views[-1][0]
    (c0, r0), (c1, r1) = np.rint(view.project([views[0][1][0], views[-1][1][0]])[0]).astype(int)
    assert c1 > c0 + 3
    walked = frames[-1][r0, c0 - 3: c0 + 2]
    assert (np.abs(walked - frames[-1][r0 + 40, c0 - 3: c0 + 2]).sum(axis=1) > 30).any()  # not bare ground


def test_a_swarm_stopped_while_filmed_leaves_its_video_under_the_temporary_name(tmp_path, monkeypatch):
    from neuronav.scenarios.swarm_homing import scenario as swarm

    step = swarm.SwarmBodies.control_step
    calls = []

    def breaking(self, turn, stride):
        calls.append(1)
        if len(calls) > 40:
            raise KeyboardInterrupt
        step(self, turn, stride)

    monkeypatch.setattr(swarm.SwarmBodies, "control_step", breaking)
    path = tmp_path / "trial0.mp4"
    config = swarm.SwarmHomingConfig(ants=2, outbound_s=3.2, homing_timeout_s=3.2)
    with pytest.raises(KeyboardInterrupt):
        swarm.run_swarm(config, "kinematic", 0, path)
    assert not path.exists() and path.with_suffix(".partial.mp4").exists()
