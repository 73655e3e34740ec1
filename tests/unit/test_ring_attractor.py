"""Sun et al.'s ring attractor (brains.ring): optimal two-cue integration, tracking, stability."""

from __future__ import annotations

import numpy as np
import pytest

from brains import bump_heading_rad, ring_attractor
from brains.ring import CUE_AMPLITUDE, DT_S, N_CELLS, SETTLE_S, gaussian_cue, settle
from neuronav import CircuitError, ConfigError, PortError


def _wrap_deg(angle_rad: np.ndarray) -> np.ndarray:
    return np.rad2deg(np.angle(np.exp(1j * np.asarray(angle_rad))))


def _two_cues(n_cells: int = N_CELLS) -> np.ndarray:
    return (gaussian_cue(np.deg2rad(90.0), np.deg2rad(40.0), n_cells)
            + gaussian_cue(np.deg2rad(155.0), np.deg2rad(35.0), n_cells))


def test_two_cues_settle_at_the_inverse_variance_weighted_mean():
    sim = ring_attractor().compile(batch=1, dt_s=DT_S)
    bump_deg = _wrap_deg(settle(sim, _two_cues()))[0]
    weighted_mean_deg = (90.0 / 40.0**2 + 155.0 / 35.0**2) / (1 / 40.0**2 + 1 / 35.0**2)
    assert abs(weighted_mean_deg - 126.8) < 0.05
    assert abs(bump_deg - 127.0) < 5.0
    assert abs(bump_deg - weighted_mean_deg) < 5.0
    # the tuned defaults (N 32, sigma 125 deg, cue amplitude 3) land within 1 deg of it (126.98 deg)
    assert abs(bump_deg - weighted_mean_deg) < 1.0
    # a real bump, not the decode of a flat or silent ring
    rates = sim.rates("E")[0]
    assert rates.max() > 0.5 and rates.min() < 1e-6 * rates.max()


def test_recurrence_does_the_combining_not_the_cue():
    # The cue's own population vector (121°) and peak (132°) both miss by more than 4°.
    cue_deg = _wrap_deg(bump_heading_rad(_two_cues()))[0]
    assert abs(cue_deg - 126.8) > 4.0
    sim = ring_attractor().compile(batch=1, dt_s=DT_S)
    assert abs(_wrap_deg(settle(sim, _two_cues()))[0] - 126.8) < abs(cue_deg - 126.8)


@pytest.mark.parametrize("sigma_deg", [120.0, 130.0])
def test_two_cue_result_holds_across_the_papers_sigma_range(sigma_deg):
    sim = ring_attractor(sigma_rad=np.deg2rad(sigma_deg)).compile(batch=1, dt_s=DT_S)
    assert abs(_wrap_deg(settle(sim, _two_cues()))[0] - 127.0) < 5.0


def test_single_cue_is_tracked_at_any_angle():
    angles_rad = np.deg2rad(np.array([0.0, 17.0, 45.0, 90.0, 133.3, 180.0, 222.0, 271.0, 300.0, 359.0]))
    sim = ring_attractor().compile(batch=angles_rad.size, dt_s=DT_S)
    bump = settle(sim, gaussian_cue(angles_rad, np.deg2rad(40.0)))
    assert np.abs(_wrap_deg(bump - angles_rad)).max() < 2.0


def test_bump_persists_without_cue_and_follows_a_moved_cue():
    sim = ring_attractor().compile(batch=1, dt_s=DT_S)
    settle(sim, gaussian_cue(0.0, np.deg2rad(40.0)))
    after_cue_off = settle(sim, np.zeros(N_CELLS), duration_s=0.1)
    assert abs(_wrap_deg(after_cue_off)[0]) < 2.0
    assert sim.rates("E").max() > 0.3
    moved = settle(sim, gaussian_cue(np.deg2rad(90.0), np.deg2rad(40.0)))
    assert abs(_wrap_deg(moved)[0] - 90.0) < 2.0


def test_bump_stays_finite_and_bounded():
    sim = ring_attractor().compile(batch=3, dt_s=DT_S)
    cues = np.stack([_two_cues(), 10 * CUE_AMPLITUDE * np.ones(N_CELLS), np.zeros(N_CELLS)])
    for _ in range(int(0.3 / DT_S)):
        sim.step({"cues": cues})
        if sim.steps % 500 == 0:
            assert sim.all_finite()
            assert sim.rates("E").max() < 50.0 and sim.rates("I").max() < 50.0
    assert sim.all_finite()
    assert np.all(sim.rates("E") >= 0.0)
    assert sim.rates("E")[0].max() < 5.0
    assert np.all(sim.rates("E")[2] == 0.0) and sim.rates("I")[2, 0] == 0.0  # no cue: stays silent


def test_graph_integrates_the_equations_by_euler():
    """One compiled step per hand-written Euler step of Sun et al.'s equations, all from the state at t."""
    n = N_CELLS
    sim = ring_attractor().compile(batch=1, dt_s=DT_S)
    cues = _two_cues()
    theta = 2 * np.pi * np.arange(n) / n
    d = np.angle(np.exp(1j * (theta[:, None] - theta[None, :])))
    w_ee = 45.0 / n * np.exp(-(d**2) / (2 * np.deg2rad(125.0) ** 2))
    c, u = np.zeros(n), 0.0
    for _ in range(300):
        sim.step({"cues": cues[None, :]})
        dc = (-c + np.maximum(-1.5 + w_ee @ c - 6.0 * u + cues, 0.0)) / 5e-3
        du = (-u + max(-7.5 + 60.0 / n * c.sum() - u, 0.0)) / 2.5e-4
        c, u = c + DT_S * dc, u + DT_S * du
    np.testing.assert_allclose(sim.rates("E")[0], c, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(sim.rates("I")[0, 0], u, rtol=1e-10, atol=1e-12)
    assert c.max() > 0.1  # the comparison is not between two silent rings


def test_same_seed_same_numbers():
    runs = []
    for _ in range(2):
        sim = ring_attractor().compile(batch=2, seed=7, dt_s=DT_S)
        settle(sim, np.stack([_two_cues(), gaussian_cue(1.0, 0.6)]), duration_s=0.05)
        runs.append((sim.rates("E"), sim.rates("I")))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_readout_and_cue_helpers():
    cue = gaussian_cue(np.deg2rad(90.0), np.deg2rad(30.0), 8, amplitude=2.0)
    assert cue.shape == (8,) and cue[2] == pytest.approx(2.0) and cue.argmax() == 2
    assert gaussian_cue(np.array([0.0, 1.0]), 0.5).shape == (2, N_CELLS)
    assert bump_heading_rad(cue).shape == (1,)
    assert bump_heading_rad(cue)[0] == pytest.approx(np.pi / 2)
    assert bump_heading_rad(np.zeros((3, 8))).tolist() == [0.0, 0.0, 0.0]


def test_bad_arguments_and_ports_give_neuronav_errors():
    with pytest.raises(ConfigError):
        ring_attractor(n_cells=2)
    with pytest.raises(ConfigError):
        ring_attractor(sigma_rad=-1.0)
    with pytest.raises(ConfigError):
        gaussian_cue(0.0, 0.0)
    sim = ring_attractor(n_cells=16).compile(batch=1, dt_s=DT_S)
    with pytest.raises(PortError):
        sim.step({"cues": np.zeros((1, 32))})
    with pytest.raises(PortError):
        settle(sim, np.zeros(32), duration_s=SETTLE_S)


def test_compile_defaults_to_the_papers_step_and_refuses_unstable_steps():
    circuit = ring_attractor()
    assert circuit.compile(batch=1).dt_s == DT_S
    with pytest.raises(CircuitError, match="dt_s"):
        circuit.compile(batch=1, dt_s=5e-4)  # Euler diverges there (the I cell's tau is 0.25 ms)
