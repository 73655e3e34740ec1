"""The world's odour and wind (neuronav.senses.chemistry): channels, the plume's own clock, seeds, checks."""

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.chemistry import PLUME_DT_S, Chemistry, OdourScene
from neuronav.senses.odour import ImageTrail, PolylineTrail, straight_trail
from neuronav.senses.plume import OdourSource, PlumeConfig
from neuronav.spec.world import World


def _plume(**options) -> PlumeConfig:
    return PlumeConfig(sources=(OdourSource(position_m=(0.5, 0.0, 0.0), release_rate_hz=60.0),), **options)


def test_trails_add_into_their_own_odour_channel():
    first = straight_trail((0.0, 0.0), (4.0, 0.0), "wide")
    second = PolylineTrail(np.array([[0.0, -1.0], [4.0, -1.0]]), 0.27, odour=2)
    scene = OdourScene(trails=(first, second))
    assert scene.n_odours == 3
    chemistry = Chemistry(scene)
    points = np.array([[[1.0, 0.0, 0.2], [1.0, -1.0, 0.2]], [[2.0, 3.0, 0.0], [3.0, -0.7, 0.0]]])
    reading = chemistry.odour_at(points)
    assert reading.shape == (2, 2, 3)
    np.testing.assert_allclose(reading[..., 0], first.concentration_at(points))
    np.testing.assert_allclose(reading[..., 2], second.concentration_at(points))
    assert not reading[..., 1].any()
    assert reading[0, 0, 0] == 1.0 and reading[0, 1, 2] == 1.0 and reading[1, 0].sum() == 0.0


def test_an_odourless_world_reads_one_zero_channel_and_still_air():
    chemistry = Chemistry(World().odour)
    assert World().odour.is_empty and chemistry.n_odours == 1
    points = np.zeros((3, 2, 3))
    assert chemistry.odour_at(points).shape == (3, 2, 1) and not chemistry.odour_at(points).any()
    assert chemistry.wind_at(points).shape == (3, 2, 2) and not chemistry.wind_at(points).any()
    chemistry.advance_to(100.0)  # nothing to step


def test_plume_and_trail_share_a_channel_and_the_plume_reads_as_its_own_model():
    trail = straight_trail((0.0, 1.0), (8.0, 1.0))
    scene = OdourScene(trails=(trail,), plume=_plume(), warmup_s=3.0)
    chemistry = Chemistry(scene)
    chemistry.reset(seed=4)
    points = np.array([[2.0, 0.0, 0.0], [3.0, 1.0, 0.0]])
    np.testing.assert_allclose(chemistry.odour_at(points)[..., 0],
                               chemistry.plume.concentration_at(points)[..., 0] + trail.concentration_at(points))
    np.testing.assert_array_equal(chemistry.wind_at(points), chemistry.plume.wind_at(points))


def test_the_plume_runs_on_its_own_clock_whatever_the_engine_timestep():
    """Read at the end of 1.004 s of 2 ms or of 8 ms engine steps, the plume has made the same 100
    steps of 10 ms and holds the same puffs."""
    states = []
    for engine_dt_s in (0.002, 0.008):
        chemistry = Chemistry(OdourScene(plume=_plume(), warmup_s=2.0))
        chemistry.reset(seed=7)
        assert chemistry.plume.time_s == pytest.approx(2.0)
        time_s = 0.0
        for _ in range(int(round(1.004 / engine_dt_s))):
            time_s += engine_dt_s  # as the engine keeps it: a sum of steps
            if round(time_s / engine_dt_s) % 25 == 0:
                chemistry.advance_to(time_s)  # read now and then, at different times per engine
        chemistry.advance_to(time_s)
        assert chemistry.plume.time_s == pytest.approx(2.0 + 100 * PLUME_DT_S)
        states.append(chemistry.plume.puffs)
    np.testing.assert_array_equal(states[0].position_m, states[1].position_m)
    np.testing.assert_array_equal(states[0].r2_m2, states[1].r2_m2)


def test_same_seed_same_plume_and_another_seed_another():
    def puffs(seed):
        chemistry = Chemistry(OdourScene(plume=_plume(), warmup_s=1.0))
        chemistry.reset(seed)
        chemistry.advance_to(0.5)
        return chemistry.plume.puffs.position_m

    np.testing.assert_array_equal(puffs(3), puffs(3))
    assert puffs(3).shape != puffs(4).shape or not np.array_equal(puffs(3), puffs(4))
    np.testing.assert_array_equal(puffs(None), puffs(0))


def test_reset_starts_the_plume_again():
    chemistry = Chemistry(OdourScene(plume=_plume(), warmup_s=0.5))
    chemistry.reset(seed=1)
    first = chemistry.plume.puffs.position_m
    chemistry.advance_to(2.0)
    chemistry.reset(seed=1)
    np.testing.assert_array_equal(chemistry.plume.puffs.position_m, first)


@pytest.mark.parametrize("scene, message", [
    (dict(trails=("trail",)), "odour trail 0: expected a PolylineTrail or ImageTrail"),
    (dict(plume="plume"), "odour plume: expected a PlumeConfig"),
    (dict(warmup_s=-1.0), "odour warmup_s"),
    (dict(warmup_s=float("nan")), "odour warmup_s"),
    (dict(plume_dt_s=0.0), "odour plume_dt_s"),
])
def test_bad_scenes_are_refused_with_one_message(scene, message):
    with pytest.raises(ConfigError, match=message):
        OdourScene(**scene)


def test_bad_odour_indices_and_query_shapes_are_refused():
    with pytest.raises(ConfigError, match="trail odour"):
        PolylineTrail(np.array([[0.0, 0.0], [1.0, 0.0]]), odour=-1)
    with pytest.raises(ConfigError, match="trail image odour"):
        ImageTrail(np.ones((2, 2)), (0.0, 1.0), (0.0, 1.0), odour=1.5)
    with pytest.raises(ConfigError, match="world odour"):
        World(odour=())
    chemistry = Chemistry(OdourScene())
    with pytest.raises(ConfigError, match="odour query points"):
        chemistry.odour_at(np.zeros((2, 4)))
    with pytest.raises(ConfigError, match="wind query points"):
        chemistry.wind_at(np.zeros(5))
