"""The unicycle table shipped with the kinematic backend is what ``scenarios.calibrate_unicycle``
measures on MuJoCo today: a short variant re-measures a few grid points in CI, the slow test the
whole table (it regenerated bit for bit when this test was written)."""

import json

import numpy as np
import pytest

import scenarios.calibrate_unicycle as calibrate
from neuronav.config import apply_overrides
from scenarios.locomotion import LocomotionConfig, run_trial

SHIPPED = json.loads((calibrate.DATA_DIR / "unicycle_mujoco.json").read_text())


def test_shipped_table_has_the_calibration_grid():
    assert SHIPPED["turn"] == calibrate.TURNS.tolist()
    assert SHIPPED["stride_rad"] == np.radians(calibrate.STRIDES_DEG).tolist()


@pytest.mark.parametrize("turn_index, stride_index", [(4, 3), (0, 3), (8, 5), (6, 1)])
def test_shipped_points_re_measure_exactly(turn_index, stride_index):
    """A point of the table, walked again exactly as the calibration walks it (3 s, seed 0)."""
    config = apply_overrides(LocomotionConfig, {
        "duration_s": 3.0, "initial_yaw_jitter_rad": 0.0, "turn": float(calibrate.TURNS[turn_index]),
        "stride_deg": float(calibrate.STRIDES_DEG[stride_index])})
    metrics, _ = run_trial(config, "mujoco", 0)
    assert metrics["forward_speed_m_s"] == pytest.approx(SHIPPED["speed_m_s"][turn_index][stride_index], abs=1e-9)
    assert -metrics["turn_rate_rad_s"] == pytest.approx(SHIPPED["turn_rate_rad_s"][turn_index][stride_index],
                                                        abs=1e-9)


@pytest.mark.slow
def test_whole_shipped_table_regenerates():
    table = calibrate.measure("mujoco", 3.0)
    np.testing.assert_allclose(table["speed_m_s"], SHIPPED["speed_m_s"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(table["turn_rate_rad_s"], SHIPPED["turn_rate_rad_s"], rtol=0, atol=1e-9)
