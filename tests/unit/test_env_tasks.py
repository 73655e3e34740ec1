"""The engine-free learning tasks (scenarios/envs/tasks.py): starts, observations, rewards, limits."""

import numpy as np
import pytest

from neuronav.backends.kinematic import KinematicBackend
from neuronav.errors import ConfigError
from neuronav.scenarios.envs.tasks import MIN_START_RADII, TASKS, foraging_walk, make_task, read_state
from neuronav.scenarios.plume_tracking.scenario import start_pose
from neuronav.spec.world import PointAgents


def test_foraging_walk_ends_where_the_kinematic_unicycle_ends():
    """The homing start is the end of the scenario's foraging walk on the kinematic unicycle (the reference)."""
    task = make_task("homing", outbound_s=6.4)
    cfg = task.config
    position, heading = foraging_walk(7, 6.4, cfg.foraging_turn_std, np.radians(cfg.foraging_stride_deg))
    engine = KinematicBackend(timestep_s=0.008)
    engine.load(task.world(), [PointAgents(count=1, mode="unicycle")])
    heading0 = np.random.default_rng([7, 3]).uniform(0.0, 2.0 * np.pi)
    engine.reset(heading_rad=heading0)
    rng, turn = np.random.default_rng([7, 2]), 0.0
    for _ in range(10):  # 6.4 s = 10 gait cycles of 80 control steps
        turn = float(np.clip(0.7 * turn + rng.normal(0.0, cfg.foraging_turn_std), -1.0, 1.0))
        engine.write({"turn": np.array([[turn]]), "stride": np.array([[np.radians(cfg.foraging_stride_deg)]])})
        engine.step(80)
    state = engine.read(("position", "heading"))
    np.testing.assert_allclose(position, state["position"][0], atol=1e-9)
    assert np.isclose(np.mod(state["heading"][0, 0], 2 * np.pi), heading, atol=1e-9)
    assert np.hypot(*position) > 0.5  # it did walk away from the nest


def test_homing_never_starts_at_home():
    task = make_task("homing")
    distances = np.array([np.hypot(*task.start(seed).position_m) for seed in range(40)])
    assert distances.min() >= MIN_START_RADII * task.config.nest_radius_m
    # Most starts are the scenario's own walk (attempt 0), unchanged.
    first = [np.hypot(*foraging_walk(seed, 32.0, 0.35, np.radians(15.0))[0]) for seed in range(40)]
    assert np.sum(np.isclose(distances, first)) >= 25
    with pytest.raises(ConfigError, match="lengthen outbound_s"):
        make_task("homing", outbound_s=0.64).start(0)


def test_starts_repeat_under_a_seed_and_differ_between_seeds():
    for name in TASKS:
        task = make_task(name)
        a, b, c = task.start(3), task.start(3), task.start(4)
        np.testing.assert_array_equal(a.position_m, b.position_m)
        assert a.heading_rad == b.heading_rad
        assert a.heading_rad != c.heading_rad


def test_starts_follow_their_scenarios():
    beacon = make_task("beacon")
    headings = np.array([beacon.start(s).heading_rad for s in range(50)])
    assert np.all(np.abs(headings) <= np.pi / 4)  # the landmark within ±45°, as the binocular trials
    plume = make_task("plume", start_heading_deg=10.0)
    position, heading = start_pose(plume.config, 5)
    np.testing.assert_array_equal(plume.start(5).position_m, position)
    assert plume.start(5).heading_rad == heading


def test_reward_is_the_progress_toward_the_goal():
    task = make_task("beacon", landmark_distance_m=20.0)  # goal at (0, 20)
    before = {"position": np.array([0.0, 0.0]), "heading": np.array([0.0])}
    nearer = {"position": np.array([0.0, 4.0]), "heading": np.array([0.0])}
    aside = {"position": np.array([3.0, 0.0]), "heading": np.array([0.0])}
    assert task.reward(before, nearer) == pytest.approx(4.0)
    assert task.reward(nearer, before) == pytest.approx(-4.0)
    assert task.reward(before, aside) == pytest.approx(20.0 - np.hypot(3.0, 20.0))


def test_terminated_within_the_success_radius():
    homing = make_task("homing", nest_radius_m=0.5)
    assert homing.terminated({"position": np.array([0.3, 0.3]), "heading": np.array([0.0])})
    assert not homing.terminated({"position": np.array([0.4, 0.4]), "heading": np.array([0.0])})
    plume = make_task("plume")  # the source at (0.5, 0); an antenna tip counts, as in the scenario
    far_root = {"position": np.array([1.5, 0.0]), "odour_sites": np.array([[0.9, 0.1, 0.2], [0.9, -0.1, 0.2]])}
    assert plume.terminated(far_root)
    far_root["odour_sites"] = far_root["odour_sites"] + np.array([0.2, 0.0, 0.0])
    assert not plume.terminated(far_root)


def test_home_vector_is_in_the_body_frame():
    task = make_task("homing")
    # At (3, 4) facing the nest (heading clockwise from +y: the direction (-3, -4)): all ahead.
    heading = np.arctan2(-3.0, -4.0)
    vector = task.observe({"position": np.array([3.0, 4.0]), "heading": np.array([heading])})["home_vector"]
    np.testing.assert_allclose(vector, [5.0, 0.0], atol=1e-12)
    # Facing +y from (1, 0): the nest lies 1 m to the left.
    vector = task.observe({"position": np.array([1.0, 0.0]), "heading": np.array([0.0])})["home_vector"]
    np.testing.assert_allclose(vector, [0.0, 1.0], atol=1e-12)


def test_step_limit_covers_the_time_limit():
    task = make_task("homing", homing_timeout_s=90.0)
    assert task.step_limit(0.64) == 141  # 140 steps are 89.6 s
    assert task.step_limit(0.008) == 11250
    with pytest.raises(ConfigError, match="step_s"):
        task.step_limit(0.0)


def test_bad_task_or_setting_is_one_clear_error():
    with pytest.raises(ConfigError, match="unknown task 'nest'; allowed: homing, beacon, plume"):
        make_task("nest")
    with pytest.raises(ConfigError, match="unknown key 'radius'"):
        make_task("homing", radius=1.0)
    with pytest.raises(ConfigError, match="timeout_s"):
        make_task("plume", timeout_s=-1.0)


def test_read_state_drops_the_batch_dimension():
    task = make_task("homing")
    engine = KinematicBackend(timestep_s=0.008)
    engine.load(task.world(), [PointAgents(count=1, mode="unicycle")])
    engine.reset(position_m=(1.0, 2.0), heading_rad=0.5)
    state = read_state(engine, task)
    assert set(state) == {"position", "heading", "velocity"}
    np.testing.assert_array_equal(state["position"], [1.0, 2.0])
    assert state["heading"].shape == (1,)


# Which of its scenario's settings each task's goal (x, y) m, success radius, time limit and physics step are
# (the module doc's table): a key, or a number.
TASK_SETTINGS = {
    "homing": ((0.0, 0.0), "nest_radius_m", "homing_timeout_s", "embodied_timestep_s"),
    "beacon": ((0.0, "landmark_distance_m"), "success_radius_m", "timeout_s", "timestep_s"),
    "plume": (("source_x_m", 0.0), "success_radius_m", "timeout_s", "timestep_s"),
}


@pytest.mark.parametrize("name", list(TASKS))
def test_goal_radius_limit_and_step_are_read_from_the_scenarios_settings(name):
    """Each task's numbers follow the setting they come from (set with --set keys), never a default of its own."""
    goal_keys, radius_key, limit_key, step_key = TASK_SETTINGS[name]
    keys = [k for k in (*goal_keys, radius_key, limit_key, step_key) if isinstance(k, str)]
    defaults = make_task(name).config
    # Distinct values (a swapped key would show), each in range: 1.1, 1.2, ... times its default.
    settings = {key: round(getattr(defaults, key) * (1.1 + 0.1 * i), 6) for i, key in enumerate(keys)}
    assert len(set(settings.values())) == len(settings)
    task = make_task(name, **settings)
    np.testing.assert_array_equal(task.goal_m, [settings[k] if isinstance(k, str) else k for k in goal_keys])
    assert task.success_radius_m == settings[radius_key]
    assert task.time_limit_s == settings[limit_key]
    assert task.physics_timestep_s == settings[step_key]
