"""Filament plume and wind, tested against the model's own statistics (Farrell et al. 2002)."""

from __future__ import annotations

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.plume import ColouredNoise, OdourSource, Plume, PlumeConfig, WindConfig

STEADY = WindConfig(mean_mps=(1.0, 0.0), gain=0.0)
STILL = WindConfig(mean_mps=(0.0, 0.0), gain=0.0)
BIG_ARENA = {"arena_x_m": (-100.0, 100.0), "arena_y_m": (-100.0, 100.0), "max_puffs": 100_000}


def test_mean_release_rate_is_the_poisson_rate():
    rate_hz, dt_s, steps = 60.0, 0.01, 3000
    config = PlumeConfig(sources=(OdourSource((0.0, 0.0, 0.0), rate_hz),), wind=STEADY, **BIG_ARENA)
    plume = Plume(config, seed=4)
    plume.advance(dt_s, steps)
    expected = rate_hz * dt_s * steps  # 1800; Poisson std ≈ 42
    assert plume.suppressed_releases == 0
    assert abs(plume.released - expected) < 4 * np.sqrt(expected)
    assert plume.n_puffs == plume.released  # nothing left this arena


def test_each_source_releases_at_its_own_rate_and_odour():
    sources = (OdourSource((0.0, 0.0, 0.0), 20.0, odour=0), OdourSource((0.0, 1.0, 0.0), 80.0, odour=2))
    plume = Plume(PlumeConfig(sources=sources, wind=STEADY, **BIG_ARENA), seed=5)
    plume.advance(0.01, 2000)
    counts = np.bincount(plume.puffs.odour, minlength=3)
    for count, expected in ((counts[0], 400), (counts[2], 1600)):
        assert abs(count - expected) < 4 * np.sqrt(expected)
    assert counts[1] == 0
    # each odour is read where its own puffs are
    near_a = plume.concentration_at(np.array([0.5, 0.0, 0.0]))
    near_b = plume.concentration_at(np.array([0.5, 1.0, 0.0]))
    assert near_a.shape == (3,) and near_a[0] > 1e3 * near_a[2] and near_b[2] > 1e3 * near_b[0]
    assert near_a[1] == 0.0 and near_b[1] == 0.0


def test_r2_grows_linearly_in_age_with_slope_gamma():
    gamma, r0 = 0.003, 0.05
    config = PlumeConfig(wind=STEADY, growth_m2_per_s=gamma, initial_radius_m=r0, **BIG_ARENA)
    plume = Plume(config, seed=1)
    plume.advance(0.01, 500)
    puffs = plume.puffs
    slope, intercept = np.polyfit(puffs.age_s, puffs.r2_m2, 1)
    assert slope == pytest.approx(gamma, rel=1e-6)
    assert intercept == pytest.approx(r0 ** 2, rel=1e-6)
    assert np.allclose(puffs.r2_m2, r0 ** 2 + gamma * puffs.age_s, rtol=1e-9, atol=1e-12)


def test_puff_centres_drift_with_the_wind_and_spread_as_sigma_squared_age():
    sigma = 0.3
    config = PlumeConfig(sources=(OdourSource((0.0, 0.0, 0.0), 400.0),), wind=STEADY,
                         puff_spread_m_per_sqrt_s=sigma, **BIG_ARENA)
    plume = Plume(config, seed=2)
    plume.advance(0.01, 300)
    puffs = plume.puffs
    old = puffs.age_s > 2.0  # ~400 puffs aged 2-3 s
    age = puffs.age_s[old]
    assert np.mean(puffs.position_m[old, 0] - 1.0 * age) == pytest.approx(0.0, abs=0.1)
    # y / sqrt(age) is standard normal times sigma: its variance is sigma² within a chi² tolerance
    scaled = puffs.position_m[old, 1] / np.sqrt(age)
    assert np.var(scaled) == pytest.approx(sigma ** 2, rel=4 * np.sqrt(2 / old.sum()))


def test_puffs_drift_along_a_crosswind_by_its_velocity_times_their_age():
    """Wind (u, v) with both components non-zero: every puff sits at source + (u, v) · age, exactly
    without spread; the puffs' own noise spreads both axes by sigma² · age about that drift."""
    u, v = 0.6, -0.8
    crosswind = WindConfig(mean_mps=(u, v), gain=0.0)
    source = OdourSource((0.0, 0.0, 0.1), 400.0)
    plume = Plume(PlumeConfig(sources=(source,), wind=crosswind, puff_spread_m_per_sqrt_s=0.0, **BIG_ARENA), seed=3)
    plume.advance(0.01, 300)
    puffs = plume.puffs
    assert puffs.age_s.max() > 2.5
    np.testing.assert_allclose(puffs.position_m[:, 0], u * puffs.age_s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(puffs.position_m[:, 1], v * puffs.age_s, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(puffs.position_m[:, 2], 0.1)
    sigma = 0.3
    plume = Plume(PlumeConfig(sources=(source,), wind=crosswind, puff_spread_m_per_sqrt_s=sigma, **BIG_ARENA), seed=4)
    plume.advance(0.01, 300)
    puffs = plume.puffs
    old = puffs.age_s > 2.0  # ~400 puffs aged 2-3 s
    age = puffs.age_s[old]
    for axis, speed in ((0, u), (1, v)):
        scaled = (puffs.position_m[old, axis] - speed * age) / np.sqrt(age)  # sigma times a standard normal
        assert np.mean(scaled) == pytest.approx(0.0, abs=4 * sigma / np.sqrt(old.sum()))
        assert np.var(scaled) == pytest.approx(sigma ** 2, rel=4 * np.sqrt(2 / old.sum()))


def test_coloured_noise_reaches_its_stationary_variance():
    zeta, omega, gain = 0.1, 0.2, 2.0
    target = gain ** 2 * omega / (4 * zeta)  # 2 (m/s)²
    noise = ColouredNoise(zeta, omega, gain, size=4000, rng=np.random.default_rng(7), start_stationary=False)
    assert noise.stationary_variance == pytest.approx(target)
    dt_s = 0.05
    for _ in range(4000):  # 200 s burn-in: the variance's transient decays as exp(-2ζω t) = e^-8
        noise.step(dt_s)
    values, rates = [], []
    for _ in range(5):  # five snapshots 60 s apart (about one correlation time 1/(ζω) = 50 s)
        for _ in range(1200):
            noise.step(dt_s)
        values.append(noise.value.var())
        rates.append(noise.rate.var())
    # each snapshot: 4000 samples, relative std sqrt(2/4000) = 2.2 %; the mean of five: ~1 %;
    # Euler–Maruyama at ω dt = 0.01 adds ~1 %; tolerance 5 %
    assert np.mean(values) == pytest.approx(target, rel=0.05)
    assert np.mean(rates) == pytest.approx(omega ** 2 * target, rel=0.05)


def test_stationary_start_draws_the_stationary_variance():
    noise = ColouredNoise(0.1, 0.2, 2.0, size=20000, rng=np.random.default_rng(8), start_stationary=True)
    assert noise.value.var() == pytest.approx(2.0, rel=0.05)


def test_stationary_start_draws_the_rate_with_omega_squared_times_the_variance():
    """(n, n') start uncorrelated, var n = G² ω / (4 ζ) and var n' = ω² var n (the stationary state)."""
    zeta, omega, gain, size = 0.1, 0.5, 2.0, 20000
    noise = ColouredNoise(zeta, omega, gain, size, np.random.default_rng(6), start_stationary=True)
    variance = gain ** 2 * omega / (4 * zeta)
    tolerance = 4 * np.sqrt(2 / size)
    assert np.var(noise.value) == pytest.approx(variance, rel=tolerance)
    assert np.var(noise.rate) == pytest.approx(omega ** 2 * variance, rel=tolerance)
    assert abs(np.corrcoef(noise.value, noise.rate)[0, 1]) < 4 / np.sqrt(size)


def test_one_puff_integrates_to_its_amount():
    q, r0 = 2.5, 0.05
    config = PlumeConfig(sources=(OdourSource((1.0, 0.5, 0.3), 1e6, puff_amount=q),), wind=STILL,
                         puff_spread_m_per_sqrt_s=0.0, initial_radius_m=r0, max_puffs=1, planar=False)
    plume = Plume(config, seed=0)
    plume.advance(0.01, 1)
    assert plume.n_puffs == 1
    h = r0 / 4
    axis = np.arange(-6 * r0, 6 * r0 + h / 2, h)
    grid = np.stack(np.meshgrid(axis + 1.0, axis + 0.5, axis + 0.3, indexing="ij"), axis=-1)
    total = plume.concentration_at(grid)[..., 0].sum() * h ** 3
    assert total == pytest.approx(q, rel=1e-3)


def test_same_seed_same_plume_different_seed_different():
    def run(seed):
        plume = Plume(PlumeConfig(), seed=seed)
        plume.advance(0.01, 300)
        return plume
    a, b, c = run(11), run(11), run(12)
    assert np.array_equal(a.puffs.position_m, b.puffs.position_m)
    assert np.array_equal(a.wind_at(np.zeros(2)), b.wind_at(np.zeros(2)))
    tips = np.array([[1.0, 0.0, 0.0], [2.0, 0.1, 0.0]])
    assert np.array_equal(a.concentration_at(tips), b.concentration_at(tips))
    assert a.n_puffs != c.n_puffs or not np.array_equal(a.puffs.position_m, c.puffs.position_m)
    assert not np.array_equal(a.wind_at(np.zeros(2)), c.wind_at(np.zeros(2)))


def test_puffs_leaving_the_arena_are_dropped_and_the_count_stays_bounded():
    config = PlumeConfig(sources=(OdourSource((0.2, 0.0, 0.0), 60.0),), wind=WindConfig(mean_mps=(2.0, 0.0)),
                         arena_x_m=(0.0, 2.0), arena_y_m=(-1.0, 1.0))
    plume = Plume(config, seed=3)
    counts = []
    for _ in range(30):  # 30 s
        plume.advance(0.01, 100)
        counts.append(plume.n_puffs)
        pos = plume.puffs.position_m
        assert np.all((pos[:, 0] >= 0.0) & (pos[:, 0] <= 2.0) & (np.abs(pos[:, 1]) <= 1.0))
    assert plume.dropped > 0 and plume.released == plume.dropped + plume.n_puffs
    # steady state: about 60/s × 0.9 s of travel ≈ 54 puffs alive, never growing with time
    assert max(counts[5:]) < 120 and abs(np.mean(counts[5:15]) - np.mean(counts[20:])) < 15


@pytest.mark.parametrize("wind_mps", [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)])
def test_puffs_are_dropped_at_whichever_edge_they_leave_by(wind_mps):
    """A source in the middle of a 2 × 2 m arena, a steady 1 m/s wind toward one edge: after 3 s puffs
    have left through that edge, and every live puff is inside the arena (so younger than 1 s + a step)."""
    config = PlumeConfig(sources=(OdourSource((1.0, 0.0, 0.0), 60.0),), wind=WindConfig(mean_mps=wind_mps, gain=0.0),
                         puff_spread_m_per_sqrt_s=0.0, arena_x_m=(0.0, 2.0), arena_y_m=(-1.0, 1.0))
    plume = Plume(config, seed=1)
    plume.advance(0.01, 300)
    pos = plume.puffs.position_m
    assert plume.dropped > 100 and plume.released == plume.dropped + plume.n_puffs
    assert np.all((pos[:, 0] >= 0.0) & (pos[:, 0] <= 2.0) & (pos[:, 1] >= -1.0) & (pos[:, 1] <= 1.0))
    assert plume.puffs.age_s.max() <= 1.0 + 0.01 + 1e-9


def test_a_planar_plume_reads_the_same_at_every_height():
    """planar=True (the default): a query's height is ignored, a 3-D point reads as its (x, y); not planar,
    a puff seen from above reads less."""
    sources = (OdourSource((1.0, 0.0, 0.0), 60.0),)
    planar = Plume(PlumeConfig(sources=sources, wind=STEADY), seed=2)
    solid = Plume(PlumeConfig(sources=sources, wind=STEADY, planar=False), seed=2)
    for plume in (planar, solid):
        plume.advance(0.01, 200)
    xy = np.array([[1.5, 0.0], [2.0, 0.05], [2.5, -0.1]])
    ground, raised = np.c_[xy, np.zeros(3)], np.c_[xy, np.full(3, 0.05)]
    reading = planar.concentration_at(xy)
    assert np.all(reading > 0)
    np.testing.assert_array_equal(planar.concentration_at(ground), reading)
    np.testing.assert_array_equal(planar.concentration_at(raised), reading)
    assert np.all(solid.concentration_at(raised) < solid.concentration_at(ground))


def test_max_puffs_bounds_the_count_and_suppresses_releases():
    config = PlumeConfig(wind=STEADY, max_puffs=50, **{k: v for k, v in BIG_ARENA.items() if k != "max_puffs"})
    plume = Plume(config, seed=0)
    plume.advance(0.01, 200)
    assert plume.n_puffs == 50 and plume.suppressed_releases > 0 and plume.released == 50


def test_wind_reads_the_same_at_every_point_and_is_the_mean_without_noise():
    plume = Plume(PlumeConfig(wind=WindConfig(mean_mps=(1.5, -0.5), gain=0.0)), seed=0)
    plume.advance(0.01, 10)
    wind = plume.wind_at(np.random.default_rng(0).uniform(0, 4, size=(100, 2, 3)))
    assert wind.shape == (100, 2, 2) and np.all(wind == np.array([1.5, -0.5]))
    noisy = Plume(PlumeConfig(), seed=0)
    noisy.advance(0.01, 10)
    w = noisy.wind_at(np.zeros((3, 2)))
    assert np.all(w == w[0]) and not np.array_equal(w[0], [2.0, 0.0])


def test_query_over_agents_and_antennae_matches_point_by_point():
    plume = Plume(PlumeConfig(), seed=9)
    plume.advance(0.01, 200)
    tips = np.random.default_rng(1).uniform([0.5, -0.3, 0.0], [4.0, 0.3, 0.1], size=(100, 2, 3))
    out = plume.concentration_at(tips)
    assert out.shape == (100, 2, 1)
    single = np.array([[plume.concentration_at(tip) for tip in agent] for agent in tips])
    assert np.allclose(out, single, rtol=1e-9, atol=0)
    assert plume.rasterise(shape_px=(20, 40)).shape == (20, 40)


@pytest.mark.parametrize("make, match", [
    (lambda: OdourSource(release_rate_hz=-1.0), "release_rate_hz"),
    (lambda: OdourSource(position_m=(0.0, 0.0)), "position_m"),
    (lambda: OdourSource(odour=-1), "odour"),
    (lambda: WindConfig(damping=0.0), "damping"),
    (lambda: WindConfig(gain=-1.0), "gain"),
    (lambda: PlumeConfig(sources=()), "sources"),
    (lambda: PlumeConfig(sources=(OdourSource((9.0, 0.0, 0.0)),)), "outside the arena"),
    (lambda: PlumeConfig(arena_x_m=(1.0, 0.0)), "arena_x_m"),
    (lambda: PlumeConfig(max_puffs=0), "max_puffs"),
    (lambda: PlumeConfig(initial_radius_m=0.0), "initial_radius_m"),
    (lambda: Plume(PlumeConfig()).advance(0.0), "dt_s"),
    (lambda: Plume(PlumeConfig()).advance(0.01, -1), "steps"),
    (lambda: Plume(PlumeConfig()).concentration_at(np.zeros((2, 4))), "query points"),
    (lambda: Plume(PlumeConfig()).rasterise(odour=1), "odour"),
])
def test_bad_plume_inputs_are_refused(make, match):
    with pytest.raises(ConfigError, match=match):
        make()
