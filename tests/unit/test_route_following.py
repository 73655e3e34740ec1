"""Route following by mushroom-body familiarity (scenarios/route_following/scenario.py) on the kinematic unicycle."""

import numpy as np
import pytest

from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.scenarios.route_following.scenario import (
    RouteFollowing,
    RouteFollowingConfig,
    release_point,
    route_metrics,
    route_trial,
)
from neuronav.scenarios.tools.mb_familiarity import route


def test_metrics_of_a_path_along_the_route_and_of_one_beside_it():
    points, headings = route(51)  # 5 m
    config = RouteFollowingConfig(route_m=5.0)
    on = route_metrics(points[::3].copy(), points, config, views=8, test_time_s=12.0)
    assert on["success"] and on["checkpoints_reached"] == 1.0
    assert on["mean_distance_m"] < 0.05 and on["max_distance_m"] < 0.06  # chords of the curve
    beside = points + np.array([0.0, 2.0])  # 2 m north of the route everywhere
    off = route_metrics(beside, points, config, views=8, test_time_s=12.0)
    assert not off["success"] and off["checkpoints_reached"] < 0.5
    assert 0.5 < off["mean_distance_m"] <= 2.0


def test_release_point_lies_to_the_right_of_the_first_heading():
    points, headings = route(11)
    right = release_point(points, headings, 1.0)
    forward = np.array([np.sin(headings[0]), np.cos(headings[0])])
    step = right - points[0]
    assert np.isclose(np.hypot(*step), 1.0) and abs(step @ forward) < 1e-12
    assert forward[0] * step[1] - forward[1] * step[0] < 0  # clockwise of forward: to the right


def test_scanning_follows_a_trained_route():
    """Measured (seed 1): all checkpoints of a 5 m route reached, within 0.5 m of it."""
    config = RouteFollowingConfig(strategy="scan", route_m=5.0, duration_s=30.0, n_kc=2000, landscape=False)
    row, log = route_trial(config, "kinematic", seed=1)
    assert row["views_stored"] >= 10
    assert row["success"] and row["checkpoints_reached"] == 1.0
    assert row["max_distance_m"] < 1.0
    assert np.all(np.isfinite(log["novelty"]))


def test_without_a_memory_the_scan_does_not_follow_the_route():
    """The control: a mushroom body that learnt nothing finds every heading equally novel and walks off."""
    config = RouteFollowingConfig(strategy="scan", route_m=5.0, duration_s=15.0, n_kc=2000, landscape=False)
    import neuronav.scenarios.route_following.scenario as rf

    class Forgetful(rf.RouteMemory):
        def learn(self, panorama):
            self.views += 1

    original = rf.RouteMemory
    rf.RouteMemory = Forgetful
    try:
        row, _ = route_trial(config, "kinematic", seed=1)
    finally:
        rf.RouteMemory = original
    assert not row["success"]


def test_bad_settings_are_refused():
    with pytest.raises(ConfigError):
        apply_overrides(RouteFollowingConfig, {"strategy": "run"})
    with pytest.raises(ConfigError):
        apply_overrides(RouteFollowingConfig, {"route_m": 0.5})
    RouteFollowing().check(RouteFollowingConfig(), "kinematic")


def test_run_and_figures(tmp_path):
    scenario = RouteFollowing()
    config = RouteFollowingConfig(route_m=3.0, duration_s=12.0, n_kc=1000, landscape=True)
    result = scenario.run(config, backend="kinematic", trials=1, seed=2)
    assert result.timeseries["landscape_novelty"].shape == (1, 9, 13)
    assert result.timeseries["route_m"].shape == (1, 31, 2)
    paths = scenario.figures(result, config, tmp_path)
    assert {p.name for p in paths} == {"route_paths.png", "familiarity_landscape.png"}
    # The landscape is most familiar along the route: its minimum lies within 1.5 m of it.
    grid = result.timeseries
    relative = grid["landscape_novelty"][0]
    assert np.nanmax(relative) <= 1.0 and np.nanmin(relative) >= 0.0
    row, column = np.unravel_index(np.nanargmin(relative), (9, 13))
    at = np.array([grid["landscape_x_m"][0][column], grid["landscape_y_m"][0][row]])
    assert np.hypot(*(grid["route_m"][0] - at).T).min() < 1.5


@pytest.mark.slow
def test_scanning_follows_the_10_m_route_in_most_forests():
    """Measured (seeds 1-10, defaults, variability off: the protocol): 9 of 10 trials reach the route's end, 99 %
    of checkpoints."""
    rows = [route_trial(RouteFollowingConfig(landscape=False, variability="off"), "kinematic", seed)[0]
            for seed in range(1, 11)]
    assert sum(r["success"] for r in rows) >= 8
    assert np.mean([r["checkpoints_reached"] for r in rows]) >= 0.9


@pytest.mark.slow
def test_klinokinesis_follows_most_of_the_route():
    """Measured (seeds 1-10, variability off, defaults: gain 8, widest turn 0.6): 87 % of checkpoints, 4 of 10
    reaching the end (gain 2 with turns up to ±1, which turn on the spot: 52 %, none)."""
    rows = [route_trial(RouteFollowingConfig(strategy="klinokinesis", landscape=False, variability="off"),
                        "kinematic", seed)[0] for seed in range(1, 11)]
    assert np.mean([r["checkpoints_reached"] for r in rows]) >= 0.75
    assert sum(r["success"] for r in rows) >= 2


def test_klinokinesis_follows_most_of_a_short_route():
    """The CI variant of the slow test above: a 5 m route, seeds 1-4, 30 s, the exact protocol (variability off;
    measured: 100, 80, 80 and 80 % of checkpoints, seed 1 reaching the end; a memory that learnt nothing: 40 % in
    each; with the default variability 20, 80, 80 and 60 %)."""
    rows = [route_trial(RouteFollowingConfig(strategy="klinokinesis", route_m=5.0, duration_s=30.0, n_kc=2000,
                                             landscape=False, variability="off"), "kinematic", seed)[0]
            for seed in range(1, 5)]
    assert np.mean([r["checkpoints_reached"] for r in rows]) >= 0.75
    assert sum(r["success"] for r in rows) >= 1


def test_a_kinematic_batch_gives_each_trial_the_numbers_it_has_alone():
    """Shared forest (forest_seed): trial k of a batch of 4 == trial k run alone == the one-at-a-time loop."""
    from neuronav.scenarios.route_following.scenario import run_kinematic_batch

    config = RouteFollowingConfig(route_m=3.0, duration_s=10.0, n_kc=500, landscape=False, forest_seed=1,
                                  release_jitter_m=0.2)
    rows4, logs4 = run_kinematic_batch(config, [5, 6, 7, 8])
    rows1, logs1 = run_kinematic_batch(config, [7])
    assert rows4[2] == rows1[0]
    assert np.array_equal(logs4[2]["position_m"], logs1[0]["position_m"])
    assert len({r["mean_distance_m"] for r in rows4}) == 4  # the seeded releases differ
    alone, log = route_trial(config, "kinematic", seed=7)
    assert np.array_equal(log["position_m"], logs1[0]["position_m"])
    assert alone["success"] == rows1[0]["success"] and np.isclose(alone["test_time_s"], rows1[0]["test_time_s"])


def test_run_batches_the_trials_on_kinematic_with_a_shared_forest():
    result = RouteFollowing().run(RouteFollowingConfig(route_m=2.0, duration_s=4.0, n_kc=500, landscape=False,
                                                       forest_seed=1, release_jitter_m=0.1),
                                  backend="kinematic", trials=3, seed=2)
    assert [r["seed"] for r in result.trials] == [2, 3, 4]
    assert result.timeseries["position_m"].shape[0] == 3


def test_judging_several_views_per_cycle_still_turns_once_per_cycle_and_follows_the_route():
    from neuronav.scenarios.visual_setup import CYCLE_S

    config = RouteFollowingConfig(route_m=3.0, duration_s=10.0, n_kc=500, landscape=False, test_views_per_cycle=2)
    row, log = route_trial(config, "kinematic", seed=1)
    assert np.allclose(np.diff(log["time_s"]), CYCLE_S)  # one logged decision per gait cycle
    assert row["success"] and row["checkpoints_reached"] == 1.0


def test_the_scan_turns_toward_the_least_novel_heading_in_proportion_to_its_offset():
    from neuronav.scenarios.route_following.scenario import familiarity_turn

    offsets = np.array([-20.0, -10.0, 0.0, 10.0, 20.0])  # deg, + right
    values = np.array([5.0, 4.0, 3.0, 1.0, 2.0])  # least novel 10° right
    assert familiarity_turn("scan", None, offsets, values, 0.1, 1.0, full_turn_deg=30.0) == -1.0 / 3.0
    assert familiarity_turn("scan", None, offsets, values, 0.1, 1.0, full_turn_deg=60.0) == -1.0 / 6.0
    assert familiarity_turn("scan", None, offsets, values[::-1], 0.1, 1.0, full_turn_deg=5.0) == 1.0  # clipped


def test_klinokinesis_turns_alternately_and_no_wider_than_its_widest_turn():
    from neuronav.scenarios.route_following.scenario import familiarity_turn

    class Memory:  # 100 KCs: the learner's KC rates are all that klinokinesis reads of the memory
        class learner:
            @staticmethod
            def rates(name):
                return np.zeros((1, 100))

    offsets = np.array([10.0, 0.0, -10.0])
    familiar, novel = np.array([9.0, 0.0, 9.0]), np.array([9.0, 5.0, 9.0])
    assert familiarity_turn("klinokinesis", Memory, offsets, familiar, 0.1, 1.0) == 0.0  # straight where familiar
    # 5 of the 10 active KCs novel: gain 2 gives θ = 1 * min(1, 2 * 0.5), gain 8 is capped at the widest turn
    assert familiarity_turn("klinokinesis", Memory, offsets, novel, 0.1, -1.0, klinokinesis_gain=2.0,
                            klinokinesis_max_turn=1.0) == -1.0
    assert familiarity_turn("klinokinesis", Memory, offsets, novel, 0.1, 1.0, klinokinesis_gain=8.0,
                            klinokinesis_max_turn=0.6) == 0.6
    assert familiarity_turn("klinokinesis", Memory, offsets, novel, 0.1, 1.0, klinokinesis_gain=0.5,
                            klinokinesis_max_turn=0.6) == pytest.approx(0.6 * 0.25)


def test_the_scan_judges_headings_scan_step_deg_apart():
    from neuronav.scenarios.route_following.scenario import RouteMemory

    for step_deg, columns in ((5.0, 1), (10.0, 2), (20.0, 4)):
        memory = RouteMemory(RouteFollowingConfig(n_kc=100, scan_deg=60.0, scan_step_deg=step_deg), seed=0)
        assert np.all(np.diff(memory.rolls) == columns) and memory.rolls[-1] * 5.0 == 60.0


def test_travel_aligned_views_face_the_way_the_ant_moved_over_its_last_cycle():
    """Headings clockwise from +y; the panorama rolled k columns faces -5k° (+ right), as in the scan."""
    from neuronav.scenarios.route_following.scenario import GuidedLearning

    guide = GuidedLearning(np.zeros((2, 2)), memory=None, calls_per_cycle=2, travel_aligned=True)
    assert guide.view_roll_columns(0.0) == 0  # no cycle walked yet
    guide.positions = [np.array([0.0, 0.0]), np.array([0.05, 0.05]), np.array([0.1, 0.1])]  # moving 45° right
    assert guide.view_roll_columns(0.0) == -9  # body facing north: the view turned 45° right
    assert guide.view_roll_columns(np.radians(45.0)) == 0  # body facing the way it moves
    assert guide.view_roll_columns(np.radians(60.0)) == 3  # body 15° right of its path: turned 15° left
    assert guide.crab_deg[-1] == pytest.approx(-15.0)
    body_aligned = GuidedLearning(np.zeros((2, 2)), memory=None, calls_per_cycle=2, travel_aligned=False)
    body_aligned.positions = guide.positions
    assert body_aligned.view_roll_columns(0.0) == 0


def test_travel_aligned_views_change_nothing_on_the_unicycle_that_walks_along_its_axis():
    """The kinematic unicycle does not crab: every stored view is rolled by 0 columns, so the test path is the same."""
    config = RouteFollowingConfig(route_m=3.0, duration_s=10.0, n_kc=500, landscape=False, travel_aligned_views=False)
    _, body = route_trial(config, "kinematic", seed=1)
    from dataclasses import replace

    _, travel = route_trial(replace(config, travel_aligned_views=True), "kinematic", seed=1)
    assert np.array_equal(body["position_m"], travel["position_m"])


def test_the_scan_gain_and_test_views_left_at_0_are_the_bodys_own():
    from neuronav.scenarios.route_following.scenario import body_steering

    unicycle = body_steering(RouteFollowingConfig(), "kinematic")
    assert (unicycle.scan_full_turn_deg, unicycle.test_views_per_cycle) == (30.0, 1)
    for backend in ("mujoco", "pybullet"):
        ant = body_steering(RouteFollowingConfig(), backend)
        assert (ant.scan_full_turn_deg, ant.test_views_per_cycle) == (45.0, 4)
    chosen = body_steering(RouteFollowingConfig(scan_full_turn_deg=60.0, test_views_per_cycle=2), "pybullet")
    assert (chosen.scan_full_turn_deg, chosen.test_views_per_cycle) == (60.0, 2)


class ScriptedMemory:
    """A memory whose scan returns the next of the given novelty rows (offsets -20 to 20° in 10° steps)."""

    offsets = np.array([-20.0, -10.0, 0.0, 10.0, 20.0])  # deg, + right

    def __init__(self, rows):
        self.rows = iter(rows)

    def scan(self, panorama):
        return self.offsets, np.asarray(next(self.rows), float), 0.1


class StandingAnt:
    """The loop and backend a steering call reads: position, heading, panorama and the time."""

    time_s = 0.0

    @property
    def backend(self):
        return self

    def read(self, names):
        return {"position": np.zeros((1, 2)), "heading": np.zeros((1, 1)), "panorama": np.zeros((1, 72, 72))}


def test_the_test_turns_on_the_novelty_averaged_over_the_cycles_views():
    """Four views per cycle (the physics ants' own): the turn of a cycle is the scan of the mean novelty of
    its last four views, not of the last view, and is held for the cycle's other views."""
    from neuronav.scenarios.route_following.scenario import FamiliaritySteering

    first = [5.0, 5.0, 0.0, 5.0, 5.0]  # straight ahead least novel
    swayed_left = [5.0, 1.0, 3.0, 4.0, 5.0]  # three views: least novel 10° left
    swayed_right = [5.0, 4.0, 3.0, 4.0, 0.5]  # the last view alone: least novel 20° right
    rows = [first, swayed_left, swayed_left, swayed_left, swayed_right]
    steering = FamiliaritySteering("scan", ScriptedMemory(rows), np.zeros((2, 2)), 0.5, views_per_cycle=4,
                                   full_turn_deg=30.0)
    turns = [steering(StandingAnt())[0] for _ in rows]
    # Mean of the last four: 1.75 at 10° left, 3.875 at 20° right: turn left by 10/30 (the last view: right by 20/30).
    assert turns == [0.0, 0.0, 0.0, 0.0, pytest.approx(1.0 / 3.0)]
    assert len(steering.log["turn"]) == 2  # one decision per cycle


def test_the_physics_ant_follows_a_short_route_with_its_own_steering():
    """The CI variant of the slow test below: MuJoCo, a 3 m route, one trial (seed 1: every checkpoint, mean
    distance 0.08 m, at most 0.13 m). A memory that learnt nothing strays up to 0.56 m from the same route."""
    pytest.importorskip("mujoco")
    config = RouteFollowingConfig(route_m=3.0, duration_s=15.0, n_kc=1000, landscape=False)
    row, log = route_trial(config, "mujoco", seed=1)
    assert row["success"] and row["checkpoints_reached"] == 1.0
    assert row["mean_distance_m"] < 0.15 and row["max_distance_m"] < 0.3


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_the_physics_ants_follow_the_route_with_their_own_steering(backend):
    """Measured (seed 1, defaults, variability off): MuJoCo and PyBullet reach the end, every checkpoint. What the
    body's own settings are for is following the route, asserted here; that PyBullet with the unicycle's settings
    falls short (60 % of checkpoints, README "route-following") is a measurement, not a requirement: a better gait
    may close it."""
    row, _ = route_trial(RouteFollowingConfig(landscape=False, variability="off"), backend, seed=1)
    assert row["success"] and row["checkpoints_reached"] == 1.0 and row["mean_distance_m"] < 0.3


# -- variability and statistics (issue 22) ----------------------------------------------------------------

SHARED = dict(route_m=3.0, duration_s=8.0, n_kc=500, landscape=False, forest_seed=1)
METRICS = ("checkpoints_reached", "mean_distance_m", "max_distance_m", "final_distance_to_goal_m", "test_time_s")


def metric_row(row):
    return tuple(row[k] for k in METRICS)


def test_with_the_defaults_no_two_trials_in_one_forest_are_the_same():
    """One shared forest and route: only the seeded variability (release jitter, eye and motor noise) tells
    the trials apart, and no two metric rows are equal; with variability off every trial repeats the first."""
    from neuronav.scenarios.route_following.scenario import run_kinematic_batch

    rows, _ = run_kinematic_batch(RouteFollowingConfig(**SHARED), [1, 2, 3, 4])
    assert len({metric_row(r) for r in rows}) == 4
    off, _ = run_kinematic_batch(RouteFollowingConfig(**SHARED, variability="off"), [1, 2, 3, 4])
    assert len({metric_row(r) for r in off}) == 1


def test_variability_off_is_every_noise_source_at_zero_and_each_source_acts():
    """``variability=off`` gives what the sizes at 0 give (the exact protocol); each source alone changes a trial."""
    from neuronav.scenarios.route_following.scenario import run_kinematic_batch

    zero = dict(release_jitter_m=0.0, release_heading_jitter_deg=0.0, eye_noise=0.0, turn_noise=0.0,
                stride_noise_deg=0.0)
    off = run_kinematic_batch(RouteFollowingConfig(**SHARED, variability="off"), [5])[1][0]["position_m"]
    sizes_zero = run_kinematic_batch(RouteFollowingConfig(**SHARED, **zero), [5])[1][0]["position_m"]
    np.testing.assert_array_equal(off, sizes_zero)
    for source in zero:
        alone = dict(zero, **{source: RouteFollowingConfig.__dataclass_fields__[source].default})
        path = run_kinematic_batch(RouteFollowingConfig(**SHARED, **alone), [5])[1][0]["position_m"]
        assert path.shape != off.shape or not np.array_equal(path, off), source


def test_the_release_jitter_is_the_trials_own_and_off_without_variability():
    from neuronav.scenarios.route_following.scenario import trial_start

    points, headings = route(31)
    config = RouteFollowingConfig(release_jitter_m=0.1, release_heading_jitter_deg=10.0)
    starts = [trial_start(config, points, headings, seed) for seed in range(200)]
    offsets = np.array([position - points[0] for position, _ in starts])
    turns = np.degrees([heading - headings[0] for _, heading in starts])
    assert 0.08 < offsets.std() < 0.12 and 8.0 < turns.std() < 12.0
    again = trial_start(config, points, headings, 7)
    assert np.array_equal(again[0], starts[7][0]) and again[1] == starts[7][1]
    position, heading = trial_start(RouteFollowingConfig(variability="off"), points, headings, 7)
    assert np.array_equal(position, points[0]) and heading == headings[0]


def test_a_strategy_list_is_cycled_over_trials_and_is_the_statistics_condition():
    config = apply_overrides(RouteFollowingConfig, ["strategy=scan,klinokinesis", "route_m=2", "duration_s=3",
                                                    "n_kc=500", "landscape=false", "forest_seed=1"])
    result = RouteFollowing().run(config, backend="kinematic", trials=4, seed=2)
    assert [r["strategy"] for r in result.trials] == ["scan", "klinokinesis", "scan", "klinokinesis"]
    spec = RouteFollowing().statistics(config)
    assert spec.condition == "strategy" and spec.reference == "scan"
    assert all(spec.condition in row and all(m in row for m in spec.metrics) for row in result.trials)
    assert [r["release_offset_m"] for r in result.trials] == [0.0] * 4
    with pytest.raises(ConfigError, match="strategy"):
        apply_overrides(RouteFollowingConfig, ["strategy=scan,run"])


def test_a_release_offset_list_is_cycled_after_the_strategies_and_compared_with_one_strategy():
    from neuronav.scenarios.route_following.scenario import trial_release_offset_m, trial_strategy

    both = apply_overrides(RouteFollowingConfig, ["strategy=scan,klinokinesis", "release_offset_m=0,1"])
    assert [(trial_strategy(both, s), trial_release_offset_m(both, s)) for s in range(2, 6)] == [
        ("scan", 1.0), ("klinokinesis", 1.0), ("scan", 0.0), ("klinokinesis", 0.0)]
    offsets = apply_overrides(RouteFollowingConfig, ["release_offset_m=0,1"])
    spec = RouteFollowing().statistics(offsets)
    assert (spec.condition, spec.reference) == ("release_offset_m", 0.0)
    assert RouteFollowing().statistics(both).condition == "strategy"
    points, headings = route(31)
    from neuronav.scenarios.route_following.scenario import trial_start

    off = apply_overrides(RouteFollowingConfig, ["release_offset_m=0,1", "variability=off"])
    assert np.allclose(trial_start(off, points, headings, 1)[0], release_point(points, headings, 1.0))
    with pytest.raises(ConfigError, match="release_offset_m"):
        apply_overrides(RouteFollowingConfig, ["release_offset_m=0,11"])


def test_the_physics_ants_trials_differ_with_the_defaults():
    """MuJoCo, one shared forest, two short trials: the seeded variability tells them apart."""
    pytest.importorskip("mujoco")
    config = RouteFollowingConfig(**dict(SHARED, route_m=2.0, duration_s=3.0))
    rows = [route_trial(config, "mujoco", seed)[0] for seed in (1, 2)]
    assert metric_row(rows[0]) != metric_row(rows[1])


# --- eyes=compound (issue 24): the mushroom body's view code from the compound eyes ------------------------------

def test_the_compound_eyes_laid_out_on_the_panorama_grid_see_what_the_camera_sees():
    """The UV ommatidia of both eyes on the panorama's grid against the camera's grey panorama at three route points
    of forest 1, upper half (where the trees stand against the sky): correlation 0.80-0.83 (measured); mirrored
    left-right 0.19-0.61, turned 20° 0.53-0.56, upside down below 0.15."""
    from neuronav import registry
    from neuronav.scenarios.route_following.compound_view import EYE_SENSORS, CompoundPanorama, ant_eyes
    from neuronav.scenarios.tools.mb_familiarity import forest_world, panoramas
    from neuronav.spec.world import PointAgents

    points, headings = route(101)
    world = forest_world(points, seed=1)
    eyes, camera = ant_eyes()
    backend = registry.load("backend", "kinematic")()
    backend.load(world, [PointAgents(count=3, mode="unicycle", compound_eyes=eyes)])
    backend.reset(position_m=points[[10, 50, 90]], heading_rad=headings[[10, 50, 90]])
    seen = CompoundPanorama(eyes, camera, "uv")(backend.read(EYE_SENSORS))
    grey = panoramas(world, points[[10, 50, 90]], headings[[10, 50, 90]])
    assert seen.shape == grey.shape == (3, 72, 72)
    for i in range(3):
        same = np.corrcoef(seen[i, :36].ravel(), grey[i, :36].ravel())[0, 1]
        turned = np.corrcoef(np.roll(seen[i], 4, axis=1)[:36].ravel(), grey[i, :36].ravel())[0, 1]
        assert same > 0.75 and same > turned + 0.15


def test_the_channels_and_the_uv_green_contrast_of_sky_and_vegetation():
    from neuronav.scenarios.route_following.compound_view import channel_values

    sky_and_tree = np.array([[0.15, 0.50], [0.12, 0.04], [0.0, 0.0]])  # green, UV (neuronav.spec.world defaults)
    assert np.allclose(channel_values(sky_and_tree, "green"), [0.15, 0.12, 0.0])
    assert np.allclose(channel_values(sky_and_tree, "uv"), [0.50, 0.04, 0.0])
    assert np.allclose(channel_values(sky_and_tree, "uv_green"), [0.35 / 0.65, -0.08 / 0.16, 0.0])
    with pytest.raises(ConfigError, match="green, uv, uv_green"):
        channel_values(sky_and_tree, "blue")


def test_bad_eyes_and_eye_channels_are_refused_naming_the_choices():
    with pytest.raises(ConfigError, match="camera, compound"):
        apply_overrides(RouteFollowingConfig, {"eyes": "fisheye"})
    with pytest.raises(ConfigError, match="green, uv, uv_green"):
        apply_overrides(RouteFollowingConfig, {"eye_channel": "red"})
    assert apply_overrides(RouteFollowingConfig, {}).eyes == "camera"  # nothing existing changes


def test_the_scan_follows_a_short_route_with_the_compound_eyes_uv_code():
    """Kinematic, a 3 m route, seed 1, the UV channel (measured: every checkpoint, mean distance 0.07 m). A code
    mirrored left-right (each turn the wrong way) does not follow it."""
    config = RouteFollowingConfig(route_m=3.0, duration_s=15.0, n_kc=1000, landscape=False, eyes="compound",
                                  eye_channel="uv")
    row, log = route_trial(config, "kinematic", seed=1)
    assert row["success"] and row["checkpoints_reached"] == 1.0 and row["mean_distance_m"] < 0.15
    assert np.all(np.isfinite(log["novelty"]))


def test_the_physics_ant_reads_its_compound_eyes_as_the_mushroom_bodys_view():
    """MuJoCo: the ant with compound eyes, one read through the scenario's view reader: a (1, 72, 72) UV panorama
    between the trees' 0.04 and the sky's 0.5, the upper half mostly sky, the ground below dark."""
    pytest.importorskip("mujoco")
    from neuronav.scenarios.route_following.scenario import RouteViews, make_route_engine
    from neuronav.scenarios.tools.mb_familiarity import forest_world

    points, headings = route(31)
    engine, body, _, _ = make_route_engine("mujoco", 0.002, "compound")
    with engine:
        engine.load(forest_world(points, seed=1), [body])
        engine.reset(seed=0)
        sensed, seen = RouteViews(RouteFollowingConfig(eyes="compound", eye_channel="uv")).read(engine)
    assert seen.shape == (1, 72, 72) and np.isfinite(seen).all()
    assert 0.04 - 1 / 255 <= seen.min() and seen.max() <= 0.5 + 1 / 255  # rendered in 8 bits
    assert np.median(seen[0, :30]) > 0.4 and np.median(seen[0, 45:]) < 0.2


def test_pixel_noise_blurs_the_green_code_of_a_view_but_not_the_uv_code():
    """Why green alone follows the route less well (README, the UV skyline comparison): the same view read twice
    with the scenario's pixel noise (0.02) gives mushroom-body codes that correlate 0.71-0.77 in green (sky and
    trees 0.03 apart) and 0.999 in UV and UV-green (measured, forest 1, three route points)."""
    from neuronav.brains.mushroom_body import panorama_code
    from neuronav.scenarios.route_following.uv_skyline import views_of
    from neuronav.scenarios.tools.mb_familiarity import forest_world

    points, headings = route(101)
    world = forest_world(points, seed=1)
    rng = np.random.default_rng(0)
    agreement = {}
    for code in ("green", "uv", "uv_green"):
        views = views_of(code).at(world, points[[10, 50, 90]], headings[[10, 50, 90]])
        first = panorama_code(views + 0.02 * rng.normal(size=views.shape))
        second = panorama_code(views + 0.02 * rng.normal(size=views.shape))
        agreement[code] = [np.corrcoef(a, b)[0, 1] for a, b in zip(first, second)]
    assert max(agreement["green"]) < 0.85 and min(agreement["uv"]) > 0.99 and min(agreement["uv_green"]) > 0.99


@pytest.mark.slow
def test_green_alone_finds_the_route_heading_less_often_than_uv():
    """The README's rotational familiarity, forest 1 (100 views, 50 midpoints, pixel noise 0.02): the least novel
    heading within ±15° of the route's at 70 % of the midpoints in green, 94 % in UV and 100 % in UV-green."""
    from neuronav.scenarios.route_following.uv_skyline import familiarity

    within = {code: familiarity(code, views=100, tests=50, seed=1)["within"] for code in ("green", "uv", "uv_green")}
    assert within["green"] < 0.8 and within["uv"] >= 0.9 and within["uv_green"] >= 0.9, within
