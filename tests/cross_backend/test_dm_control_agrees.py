"""dm_control and MuJoCo walk the same walk: the locomotion scenario's desert ant, one trial, both backends.

The dm_control backend steps the MuJoCo backend's compiled model through dm_control's ``Physics``
(``mj_step2`` then ``mj_step1``, the MuJoCo backend's own order), so every recorded signal must agree
to float tolerance: on flat ground (the tripod gait, no external forces: ``Physics.step(n)`` at once)
and on the wall with adhesion (one ``Physics.step`` per physics step, the claws pressed each step).
"""

from dataclasses import replace

import numpy as np
import pytest

from neuronav.scenarios.locomotion.scenario import Locomotion, LocomotionConfig, run_trial

pytest.importorskip("dm_control", reason="dm_control is not installed")
pytest.importorskip("mujoco", reason="mujoco is not installed")

ATOL = 1e-9  # metres, radians, newtons, newton-metres


def both(**settings):
    config = replace(LocomotionConfig(), **settings)
    return {backend: run_trial(config, backend, 3) for backend in ("mujoco", "dm_control")}


def assert_same_walk(runs):
    (metrics_mj, record_mj), (metrics_dm, record_dm) = runs["mujoco"], runs["dm_control"]
    assert record_mj.keys() == record_dm.keys()
    for name, signal in record_mj.items():
        np.testing.assert_allclose(record_dm[name], signal, rtol=0.0, atol=ATOL, err_msg=name)
    for name, value in metrics_mj.items():
        if name not in Locomotion.timing_metrics and isinstance(value, float):
            np.testing.assert_allclose(metrics_dm[name], value, rtol=1e-9, atol=ATOL, err_msg=name)


def test_tripod_walk_on_flat_ground_agrees():
    runs = both(duration_s=1.0)
    assert_same_walk(runs)
    metrics, record = runs["dm_control"]
    assert not metrics["fell"]
    assert metrics["forward_speed_m_s"] > 0.2  # it walked: the paper's tripod covers ~0.4 m/s
    assert np.ptp(record["claw_force_n"]) > 1.0  # the claws touched and left the ground


def test_wall_climb_with_adhesion_agrees():
    runs = both(duration_s=0.5, terrain="wall", adhesion_n=60.0)
    assert_same_walk(runs)
    record = runs["dm_control"][1]
    assert record["position_m"][-1, 2] > 1.0  # still on the wall, held by the adhesion
