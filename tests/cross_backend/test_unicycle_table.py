"""The desert ant's unicycle table (its body data, walked by the kinematic backend) is what
``neuronav.scenarios.tools.calibrate_unicycle`` measures on MuJoCo today: the whole table is walked again
(45 points of 3 s, about 10 s here) and must match to 1e-9 (it regenerated bit for bit when this test was
written)."""

import json

import numpy as np

import neuronav.scenarios.tools.calibrate_unicycle as calibrate
from neuronav.bodies.desert_ant.unicycle import table_path

SHIPPED = json.loads(table_path("mujoco").read_text())


def test_shipped_table_has_the_calibration_grid():
    assert SHIPPED["turn"] == calibrate.TURNS.tolist()
    assert SHIPPED["stride_rad"] == np.radians(calibrate.STRIDES_DEG).tolist()


def test_whole_shipped_table_regenerates():
    table = calibrate.measure("mujoco", 3.0)
    np.testing.assert_allclose(table["speed_m_s"], SHIPPED["speed_m_s"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(table["turn_rate_rad_s"], SHIPPED["turn_rate_rad_s"], rtol=0, atol=1e-9)
