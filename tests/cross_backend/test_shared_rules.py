"""The rules both physics backends share (neuronav.engine.articulated): the same answers on MuJoCo and PyBullet.

Reset seeds, write shapes, ``apply_force`` at a site or a segment, the sensor table, the terrain
lookup, the follow camera's framing (the whole body in view) and the floor's texture.
"""

import numpy as np
import pytest

from neuronav import registry
from neuronav.engine.articulated import FOLLOW_FOV_DEG, rest_bounds
from neuronav.engine.backend import ARTICULATED_SENSORS
from neuronav.errors import ConfigError, PortError
from neuronav.spec.body import BodySpec, Geom, Joint, Segment, Site
from neuronav.spec.world import Ground, World

BACKENDS = ["mujoco", "pybullet"]


def require(name):
    pytest.importorskip(name, reason=f"{name} is not installed")


def box_body() -> BodySpec:
    """A box with one swinging flap and two contact feet: small and quick to simulate."""
    root = Segment("root", None, (Geom("box", (0.1, 0.06, 0.03)),), 1.0)
    flap = Segment("flap", "root", (Geom("capsule", (0.01, 0.05), (0.0, 0.0, -0.05)),), 0.1,
                   Joint("hinge", axis=(0.0, 1.0, 0.0), range_rad=(-1.0, 1.0), kp=5.0, kd=0.1), pos_m=(0.1, 0.0, 0.0))
    feet = (Segment("foot_l", "root", (Geom("sphere", (0.02,), name="ball_l"),), 0.05, Joint("fix_l", kind="fixed"),
                    pos_m=(-0.05, 0.05, -0.05)),
            Segment("foot_r", "root", (Geom("sphere", (0.02,), name="ball_r"),), 0.05, Joint("fix_r", kind="fixed"),
                    pos_m=(-0.05, -0.05, -0.05)))
    sites = (Site("foot_l", "foot_l", kind="contact", geom="ball_l"), Site("foot_r", "foot_r", kind="contact",
                                                                           geom="ball_r"),
             Site("nose", "root", (0.1, 0.0, 0.0), "odour"), Site("centre", "root"))
    return BodySpec("box", (root, flap, *feet), sites, spawn_height_m=0.1)


@pytest.fixture(params=BACKENDS)
def engine(request):
    require(request.param)
    backend = registry.load("backend", request.param)()
    backend.load(World(), [box_body()])
    yield backend
    backend.close()


@pytest.mark.parametrize("seed", [-1, 1.5, "3", True])
def test_reset_refuses_a_seed_that_is_not_a_non_negative_int(engine, seed):
    with pytest.raises(ConfigError, match="seed"):
        engine.reset(seed=seed)
    engine.reset(seed=0)
    engine.reset(seed=np.int64(7))
    engine.reset(seed=None)


@pytest.mark.parametrize("name", BACKENDS)
@pytest.mark.parametrize("timestep_s", [0.0, -0.002, 1e-300, float("nan"), 2.0, "0.002"])
def test_a_physics_step_out_of_range_is_refused(name, timestep_s):
    require(name)
    with pytest.raises(ConfigError, match="timestep_s"):
        registry.load("backend", name)(timestep_s=timestep_s)


@pytest.mark.parametrize("n", [-1, 2.5, float("inf"), float("nan"), True, "3"])
def test_step_takes_a_whole_number_of_steps(engine, n):
    with pytest.raises(ConfigError, match="whole number"):
        engine.step(n)
    engine.step(np.int64(2))
    engine.step(2.0)
    assert engine.time == pytest.approx(4 * engine.timestep)


def test_sensors_are_the_shared_table_sized_from_the_body(engine):
    shapes = {s.name: s.shape for s in engine.capabilities.sensors}
    sizes = {"J": 1, "C": 2, "O": 1, "K": 1}  # K: a world without odours still reads one channel
    expected = {name: tuple(sizes.get(n, n) if isinstance(n, str) else n for n in shape)
                for name, shape, _, _ in ARTICULATED_SENSORS
                if name not in ("wind_sites", "wind")}  # no wind site: no sensor
    assert shapes == expected
    values = engine.read(list(shapes))
    assert {name: v.shape[1:] for name, v in values.items()} == shapes
    assert values["body_quat"][0, 0] >= 0  # the one sign of the quaternion


def test_writes_take_a_body_command_with_or_without_its_batch_dimension(engine):
    engine.write({"joint_targets": np.array([0.3]), "adhesion": np.array([1.0, 0.0])})
    engine.write({"joint_targets": np.array([[0.3]]), "adhesion": np.array([[1.0, 0.5]])})
    for bad in ({"joint_targets": np.array([np.nan])}, {"joint_targets": np.zeros(2)},
                {"adhesion": np.array([2.0, 0.0])}, {"flap": np.zeros(1)}):
        with pytest.raises(PortError):
            engine.write(bad)


@pytest.mark.parametrize("target", ["centre", "root", "flap", "nose"])
def test_apply_force_takes_a_site_or_a_segment_on_both_engines(engine, target):
    engine.step(100)
    start = engine.read(["body_pos"])["body_pos"][0]
    for _ in range(50):
        engine.apply_force(0, target, [0.0, 0.0, 40.0])  # four times the weight: up it goes
        engine.step()
    assert engine.read(["body_pos"])["body_pos"][0, 2] > start[2] + 0.02, target


def test_apply_force_refuses_other_names_bodies_and_forces_with_one_message(engine):
    with pytest.raises(ConfigError, match="no site or segment") as error:
        engine.apply_force(0, "tail", [1.0, 0.0, 0.0])
    assert "centre" in str(error.value) and "flap" in str(error.value)  # both kinds are listed
    with pytest.raises(ConfigError, match="one body"):
        engine.apply_force(1, "centre", [1.0, 0.0, 0.0])
    with pytest.raises(ConfigError, match="3 finite"):
        engine.apply_force(0, "centre", [1.0, np.inf, 0.0])


def test_reset_stands_the_body_on_the_terrain_both_engines_alike():
    ground = Ground("uneven", roughness_m=0.05, size_m=4.0, cells=33, seed=2)
    heights = {}
    for name in BACKENDS:
        require(name)
        with registry.load("backend", name)() as backend:
            backend.load(World(ground=ground), [box_body()])
            backend.reset(position_m=(0.4, -0.3))
            heights[name] = backend.read(["body_pos"])["body_pos"][0, 2]
    # the root spawn_height_m above Ground.height_at, or lifted a few mm clear of a bump: never below
    floor = ground.height_at(0.4, -0.3) + box_body().spawn_height_m
    assert all(floor - 1e-9 <= z < floor + 0.05 for z in heights.values()), (floor, heights)


def test_ground_height_is_one_cached_vectorised_lookup():
    ground = Ground("uneven", roughness_m=0.05, size_m=4.0, cells=33, seed=2)
    xs, ys = np.meshgrid(np.linspace(-2.5, 2.5, 7), np.linspace(-1.0, 1.0, 5))
    grid = ground.height_at(xs, ys)
    assert grid.shape == xs.shape
    assert all(grid[i, j] == ground.height_at(float(xs[i, j]), float(ys[i, j]))
               for i in range(5) for j in range(7))
    assert ground._heights is ground._heights  # computed once per ground
    copy = ground.heights_m()
    copy[:] = 9.0  # a caller's copy cannot change the terrain
    assert ground.height_at(0.0, 0.0) < 1.0
    nodes = np.linspace(-2.0, 2.0, 33)
    # at the samples it is the heightfield (to the 1e-6 cell of clipping at the far edge)
    np.testing.assert_allclose(ground.height_at(nodes[None, :], nodes[:, None]), ground.heights_m(), atol=1e-7)


@pytest.mark.parametrize("name", BACKENDS)
@pytest.mark.parametrize("where", ["floor", "wall"])
def test_follow_camera_keeps_the_whole_ant_in_view(name, where):
    require(name)
    from neuronav.bodies.desert_ant import desert_ant

    body = desert_ant()
    wall = Ground("wall", wall_distance_m=1.0)
    with registry.load("backend", name)() as backend:
        if where == "floor":
            backend.load(World(), [body])
            backend.reset(yaw_rad=0.7)
        else:  # head up on the wall, belly to it (as the locomotion scenario starts it)
            backend.load(World(ground=wall, adhesion_n=200.0), [body])
            backend.reset(position_m=(1.0 - body.spawn_height_m, 0.0, 1.8), pitch_rad=np.pi / 2)
        view = backend.follow_view()
        sites = np.array(list(backend.model_summary()["site_pos_m"].values()))  # claws, antenna tips, eyes ...
        look = (view.target - view.eye) / view.distance_m
        rays = sites - view.eye
        angles = np.arccos(np.clip(rays @ look / np.linalg.norm(rays, axis=1), -1.0, 1.0))
        # every site within the vertical half field of view of the look direction (the image is wider than tall)
        assert angles.max() < np.radians(FOLLOW_FOV_DEG) / 2, np.degrees(angles.max())
        assert view.eye[2] > 0.0 and (where == "floor" or view.eye[0] < 1.0)  # above the floor, before the wall
        centre, radius = rest_bounds(body)
        pose = backend.read(["body_pos"])["body_pos"][0]
        assert np.linalg.norm(view.target - pose) == pytest.approx(np.linalg.norm(centre), abs=1e-9)
        image = backend.render("follow")
        assert image.shape == (480, 640, 3)


def test_follow_view_is_the_same_on_both_engines():
    from neuronav.bodies.desert_ant import desert_ant

    views = {}
    for name in BACKENDS:
        require(name)
        with registry.load("backend", name)() as backend:
            backend.load(World(), [desert_ant()])
            backend.reset(position_m=(0.5, -1.0), yaw_rad=-0.4)
            views[name] = backend.follow_view()
    a, b = views.values()
    for key in ("eye", "target", "up"):
        np.testing.assert_allclose(getattr(a, key), getattr(b, key), atol=1e-6)


def test_the_floor_is_a_checker_on_both_engines():
    """Looking straight down at empty ground, the image has two clearly different floor colours."""
    from neuronav.engine.articulated import FollowView

    for name in BACKENDS:
        require(name)
        with registry.load("backend", name)() as backend:
            backend.load(World(), [box_body()])
            backend.reset(position_m=(5.0, 5.0))
            view = FollowView(eye=np.array([0.0, 0.01, 6.0]), target=np.zeros(3), up=np.array([0.0, 1.0, 0.0]),
                              distance_m=6.0)
            image = backend._render_follow(view).astype(float)
            brightness = image.mean(axis=2)
            low, high = np.percentile(brightness, [10, 90])
            assert high - low > 25, (name, low, high)
