"""The mushroom body: wiring, view codes, sparsity of the KC code, familiar against novel views,
and the familiarity measurements on ray-cast forest views (scenarios/tools/mb_familiarity.py)."""

import numpy as np
import pytest

from neuronav import registry
from neuronav.brains.mushroom_body import (
    KC_THRESHOLD,
    PANORAMA_COLUMNS,
    PANORAMA_ROWS,
    kc_sparsity,
    kc_wiring,
    learn_views,
    mushroom_body,
    novelty,
    panorama_code,
    pn_code,
    zernike_code,
)
from neuronav.brains.vision import ZernikeBasis
from neuronav.errors import ConfigError
from neuronav.scenarios.tools import mb_familiarity as mbf

N_PN = PANORAMA_ROWS * PANORAMA_COLUMNS


@pytest.fixture(scope="module")
def forest_views():
    """40 panoramas at random points and headings in a forest about a 2 m route (ray cast); points
    inside a tree crown (an almost uniform image) left out."""
    points, _ = mbf.route(20)
    world = mbf.forest_world(points, seed=3)
    rng = np.random.default_rng(0)
    where = rng.uniform(points.min(axis=0) - 10, points.max(axis=0) + 10, (50, 2))
    images = mbf.panoramas(world, where, rng.uniform(0, 2 * np.pi, 50))
    return images[images.std(axis=(1, 2)) > 0.06][:40]


def test_registered_factory_builds_the_published_sizes():
    circuit = registry.load("brain", "mushroom_body")()
    assert [(p.name, p.size) for p in circuit.populations] == [("KC", 4000), ("MBON", 1), ("PN", 81),
                                                               ("learning", 1)]
    assert {s.name for s in circuit.sensors} == {"pn", "learning"}
    assert [m.name for m in circuit.motors] == ["novelty"]


def test_each_kc_reads_ten_distinct_pns_and_the_seed_fixes_the_wiring():
    weights = kc_wiring(4000, 81, 10, seed=0)
    np.testing.assert_array_equal((weights != 0).sum(axis=1), np.full(4000, 10))
    assert set(np.unique(weights)) == {0.0, 1.0}
    np.testing.assert_array_equal(weights, kc_wiring(4000, 81, 10, seed=0))
    assert not np.array_equal(weights, kc_wiring(4000, 81, 10, seed=1))
    # Every PN is read by about 4000 * 10 / 81 ≈ 494 KCs.
    assert 380 < (weights != 0).sum(axis=0).min() and (weights != 0).sum(axis=0).max() < 620


def test_pn_code_is_z_scored_and_the_panorama_code_turns_with_the_view():
    rng = np.random.default_rng(0)
    code = pn_code(rng.uniform(0, 1, (3, 50)))
    np.testing.assert_allclose(code.mean(axis=1), 0.0, atol=1e-12)
    np.testing.assert_allclose(code.std(axis=1), 1.0)
    np.testing.assert_array_equal(pn_code(np.full((1, 5), 0.3)), np.zeros((1, 5)))
    image = rng.uniform(0, 1, (72, 72))
    codes = panorama_code(np.stack([image, np.roll(image, 2, axis=1)]))  # 2 columns = one 10° block
    assert codes.shape == (2, N_PN)
    np.testing.assert_allclose(np.roll(codes[0].reshape(PANORAMA_ROWS, PANORAMA_COLUMNS), 1, axis=1).ravel(),
                               codes[1])
    with pytest.raises(ConfigError, match="divide"):
        panorama_code(np.zeros((1, 70, 70)))


def test_kc_code_is_sparse_on_forest_views(forest_views):
    """A few per cent of the KCs fire (Sun et al. 2020): measured 2.8 % on average for the panorama
    code and 2.6 % for the log-Zernike code at the default threshold."""
    for codes, n_pn in ((panorama_code(forest_views), N_PN),
                        (zernike_code(forest_views, ZernikeBasis(72, 72, n_max=16)), 81)):
        sim = mushroom_body(n_pn=n_pn).compile(batch=len(codes))
        sim.step({"pn": codes, "learning": np.zeros((len(codes), 1))})
        sparsity = kc_sparsity(sim)
        assert 0.01 <= sparsity.mean() <= 0.05, sparsity.mean()
        assert sparsity.min() > 0.002 and sparsity.max() < 0.10


def test_a_stored_view_is_familiar_and_other_views_stay_novel(forest_views):
    codes = panorama_code(forest_views)
    sim = mushroom_body(n_pn=N_PN).compile(batch=20)
    before = novelty(sim, codes)
    kc = (codes @ kc_wiring(4000, N_PN, 10, 0).T > KC_THRESHOLD).sum(axis=1)
    np.testing.assert_array_equal(before, kc)  # nothing learnt: every active KC counts
    learner = mushroom_body(n_pn=N_PN).compile(batch=1)
    learn_views(learner, codes[:5])
    sim.set_weights("KC->MBON", learner.weights("KC->MBON"))
    after = novelty(sim, codes)
    np.testing.assert_array_equal(after[:5], 0.0)  # stored: familiar
    # Views elsewhere in the forest keep most of their novelty (5 views silence about 5 x 3 % of the KCs).
    assert np.median(after[5:] / before[5:]) > 0.7
    weights = sim.weights("KC->MBON")
    assert np.all(weights == weights[:1])  # every agent of the judging batch holds the learnt memory


def test_novelty_reads_agent_zero_and_leaves_the_weights_as_they_were():
    sim = mushroom_body(n_pn=12, n_kc=50, inputs_per_kc=3, kc_threshold=0.5).compile(batch=2)
    rng = np.random.default_rng(1)
    learn = pn_code(rng.normal(size=(1, 12)))
    sim.step({"pn": np.repeat(learn, 2, axis=0), "learning": np.array([[1.0], [0.0]])})
    weights = sim.weights("KC->MBON")
    views = pn_code(rng.normal(size=(5, 12)))
    kc = (views @ kc_wiring(50, 12, 3, 0).T > 0.5).astype(float)
    np.testing.assert_array_equal(novelty(sim, views), kc @ weights[0, 0])
    np.testing.assert_array_equal(sim.weights("KC->MBON"), weights)


def test_the_learning_port_learns_only_above_one_half():
    """The port reads "> 0.5: learn": at exactly 0.5 a view stays novel, just above it is stored."""
    sim = mushroom_body(n_pn=12, n_kc=50, inputs_per_kc=3, kc_threshold=0.5).compile(batch=3)
    view = pn_code(np.random.default_rng(2).normal(size=(1, 12)))
    before = novelty(sim, view)[0]
    assert before > 0
    gates = np.array([[0.5], [np.nextafter(0.5, 1.0)], [1.0]])
    sim.step({"pn": np.repeat(view, 3, axis=0), "learning": gates})
    weights = sim.weights("KC->MBON")
    np.testing.assert_array_equal(weights[0], 1.0)  # at 0.5: nothing learnt
    np.testing.assert_array_equal(weights[1], weights[2])  # just above: as learnt as with the gate at 1
    assert novelty(sim, view)[0] == before and np.count_nonzero(weights[1] == 0.0) == before


@pytest.mark.parametrize("options, message", [
    (dict(n_kc=0), "n_kc must be an int >= 1"),
    (dict(inputs_per_kc=100), "cannot exceed n_pn"),
    (dict(learning_rate=0.0), "learning_rate must be > 0"),
    (dict(kc_threshold=float("nan")), "kc_threshold must be a finite number"),
])
def test_bad_options_are_refused(options, message):
    with pytest.raises(ConfigError, match=message):
        mushroom_body(**options)


def test_route_points_are_evenly_spaced_and_headed_along_the_route():
    points, headings = mbf.route(50)
    steps = np.diff(points, axis=0)
    np.testing.assert_allclose(np.hypot(*steps.T), mbf.SPACING_M, rtol=0.02)
    # The heading (clockwise from +y) points to the next point.
    np.testing.assert_allclose(np.arctan2(steps[:, 0], steps[:, 1]), headings[:-1], atol=0.02)


def test_rotational_familiarity_short():
    """20 views stored (2 m of route): the least novel heading at the midpoints lies within ±15°."""
    result = mbf.rotational_familiarity(views=20, tests=10)
    assert result["novelty"].shape == (10, 72)
    assert result["within"] >= 0.9


@pytest.mark.slow
def test_rotational_familiarity_of_a_100_view_route():
    """The issue's criterion: minimum within ±15° of the learnt heading at >= 90 % of route positions."""
    result = mbf.rotational_familiarity(views=100, tests=100)
    assert result["within"] >= 0.9


def test_capacity_short():
    """10 and 50 views stored: off-route views are more novel than on-route ones."""
    results = mbf.capacity(stored=(10, 50), tests=20)
    for n in (10, 50):
        assert results[n]["auc"] > 0.9
        assert np.median(results[n]["on"]) < np.median(results[n]["off"])
    assert results[10]["depressed"] < results[50]["depressed"]


@pytest.mark.slow
def test_capacity_of_10_100_and_1000_views():
    """Measured (seed 1, 100 test points): AUC 1.000, 1.000, 0.980; KC weights at 0: 4.5, 20.8, 58.5 %."""
    results = mbf.capacity(stored=(10, 100, 1000), tests=100)
    assert results[10]["auc"] >= 0.99 and results[100]["auc"] >= 0.99
    assert 0.9 <= results[1000]["auc"] <= results[100]["auc"]
    depressed = [results[n]["depressed"] for n in (10, 100, 1000)]
    assert depressed == sorted(depressed) and depressed[-1] < 0.9
    # Off-route novelty falls as the memory fills; on-route views stay familiar.
    assert np.median(results[1000]["off"]) < np.median(results[10]["off"])
    assert max(np.median(results[n]["on"]) for n in (10, 100, 1000)) <= 2.0


def test_turning_right_by_10_degrees_rolls_the_panorama_two_columns_left():
    """The sign behind ``offset_deg``: a turn on the spot is a roll of the panorama (module doc)."""
    points, _ = mbf.route(20)
    world = mbf.forest_world(points, seed=3)
    images = mbf.panoramas(world, np.zeros((2, 2)), np.array([0.3, 0.3 + np.radians(10.0)]))
    assert np.abs(np.roll(images[0], -2, axis=1) - images[1]).mean() < 1e-3
    assert np.abs(np.roll(images[0], 2, axis=1) - images[1]).mean() > 0.01
