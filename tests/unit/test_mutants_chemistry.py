"""What neuronav.senses.chemistry's docstrings claim and no other test pinned: the warm-up is the nearest whole
number of plume steps, and the trails of one odour add up in its channel."""

import numpy as np
import pytest

from neuronav.senses.chemistry import Chemistry, OdourScene
from neuronav.senses.odour import PolylineTrail
from neuronav.senses.plume import OdourSource, Plume, PlumeConfig


@pytest.mark.parametrize("warmup_s", [0.3, 0.29, 0.57])
def test_the_warm_up_runs_the_nearest_whole_number_of_plume_steps(warmup_s):
    """0.3 / 0.01 is 29.999999999999996 in floating point: the warm-up still runs 30 steps."""
    config = PlumeConfig(sources=(OdourSource((0.5, 0.0, 0.0), 200.0),))
    chemistry = Chemistry(OdourScene(plume=config, warmup_s=warmup_s, plume_dt_s=0.01))
    chemistry.reset(seed=4)
    steps = round(warmup_s * 100)
    assert chemistry.plume.time_s == pytest.approx(steps * 0.01, abs=1e-12)
    reference = Plume(config, seed=4)
    reference.advance(0.01, steps)
    np.testing.assert_array_equal(chemistry.plume.puffs.position_m, reference.puffs.position_m)


def test_trails_of_one_odour_add_up_in_its_channel():
    """Channel k sums every trail with odour k: where two such trails cross it reads 1 + 1."""
    along_x = PolylineTrail(np.array([[0.0, 0.0], [4.0, 0.0]]), 0.2, odour=1)
    along_y = PolylineTrail(np.array([[2.0, -2.0], [2.0, 2.0]]), 0.2, odour=1)
    chemistry = Chemistry(OdourScene(trails=(along_x, along_y)))
    reading = chemistry.odour_at(np.array([[2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 1.0, 0.0]]))
    np.testing.assert_array_equal(reading, [[0.0, 2.0], [0.0, 1.0], [0.0, 1.0]])
