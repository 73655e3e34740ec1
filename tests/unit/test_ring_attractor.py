"""Sun et al.'s ring attractor (neuronav.brains.ring): optimal two-cue integration, tracking, stability."""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import Circuit, CircuitError, ConfigError, PortError, SensorSpec
from neuronav.brains import bump_heading_rad, ring_attractor
from neuronav.brains.ring import CUE_AMPLITUDE, DT_S, N_CELLS, SETTLE_S, gaussian_cue, settle


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


def test_graph_integrates_the_equations_by_semi_implicit_euler():
    """One compiled step per hand-written step of Sun et al.'s equations: E by Euler from the state at t,
    then u by Euler from the new E and the old u."""
    n = N_CELLS
    sim = ring_attractor().compile(batch=1, dt_s=DT_S)
    cues = _two_cues()
    theta = 2 * np.pi * np.arange(n) / n
    d = np.angle(np.exp(1j * (theta[:, None] - theta[None, :])))
    w_ee = 45.0 / n * np.exp(-(d**2) / (2 * np.deg2rad(125.0) ** 2))
    c, u = np.zeros(n), 0.0
    for _ in range(300):
        sim.step({"cues": cues[None, :]})
        c = c + DT_S / 5e-3 * (-c + np.maximum(-1.5 + w_ee @ c - 6.0 * u + cues, 0.0))
        u = u + DT_S / 2.5e-4 * (-u + max(-7.5 + 60.0 / n * c.sum() - u, 0.0))
    np.testing.assert_allclose(sim.rates("E")[0], c, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(sim.rates("I")[0, 0], u, rtol=1e-10, atol=1e-12)
    assert c.max() > 0.1  # the comparison is not between two silent rings


def _explicit_euler_ring():
    """The same ring with E -> I delayed too: plain explicit Euler, the old integration."""
    circuit = ring_attractor()
    circuit.graph.edges["E", "I"]["delay"] = True
    return circuit


def _cue_off_trace(circuit, dt_s: float, cue_deg: float, off_s: float = 0.5, last_s: float = 0.02):
    """Cue for SETTLE_S, then ``off_s`` without; the I rate and bump (deg) over the last ``last_s``."""
    sim = circuit.compile(batch=1, dt_s=dt_s)
    settle(sim, gaussian_cue(np.deg2rad(cue_deg), np.deg2rad(40.0)))
    n_off, n_last = int(round(off_s / dt_s)), int(round(last_s / dt_s))
    inhibition, bump = [], []
    for k in range(n_off):
        sim.step({"cues": np.zeros((1, N_CELLS))})
        if k >= n_off - n_last:
            inhibition.append(sim.rates("I")[0, 0])
            bump.append(_wrap_deg(bump_heading_rad(sim.rates("E")))[0])
    return sim, np.array(inhibition), np.array(bump)


@pytest.mark.parametrize("dt_s", [DT_S, 1.25e-4])
def test_cue_off_state_is_steady_at_every_step_compile_accepts(dt_s):
    # 5.625 deg: a midpoint between two cells, where the cue-less bump rests (see the drift test)
    sim, inhibition, bump = _cue_off_trace(ring_attractor(), dt_s, 5.625)
    assert np.ptp(inhibition) < 1e-9  # the I cell does not swing (plain Euler at 0.1 ms: 0.36)
    assert abs(inhibition[-1] - 0.73225) < 1e-5  # (0.73211 for a bump centred on a cell)
    assert np.ptp(bump) < 1e-9 and abs(bump[-1] - 5.625) < 1e-6  # the bump stays put
    # ... and it rests at a fixed point of the equations, not merely a slow part of a cycle
    n = N_CELLS
    theta = 2 * np.pi * np.arange(n) / n
    d = np.angle(np.exp(1j * (theta[:, None] - theta[None, :])))
    w_ee = 45.0 / n * np.exp(-(d**2) / (2 * np.deg2rad(125.0) ** 2))
    c, u = sim.rates("E")[0], sim.rates("I")[0, 0]
    np.testing.assert_allclose(c, np.maximum(-1.5 + w_ee @ c - 6.0 * u, 0.0), atol=1e-9)
    assert abs(u - max(-7.5 + 60.0 / n * c.sum() - u, 0.0)) < 1e-9
    assert c.max() > 0.3


def test_plain_euler_swings_at_the_default_step_and_not_at_50_us():
    """Why E -> I is undelayed: plain explicit Euler's E-I loop swings at 0.1 ms (0.59 to 0.94)."""
    _, swinging, _ = _cue_off_trace(_explicit_euler_ring(), DT_S, 5.625)
    assert 0.3 < np.ptp(swinging) < 0.4
    assert swinging.min() < 0.6 and swinging.max() > 0.9
    _, steady, _ = _cue_off_trace(_explicit_euler_ring(), 5e-5, 5.625)
    assert np.ptp(steady) < 1e-9


def test_cue_between_cells_drifts_to_the_nearest_midpoint_between_cells():
    """Documented in brains/ring.py: without a cue the bump rests between two cells (16.875 deg here)."""
    cues_deg = np.array([12.0, 14.0, 16.0, 17.0, 19.0, 21.0])
    sim = ring_attractor().compile(batch=cues_deg.size, dt_s=DT_S)
    on = _wrap_deg(settle(sim, gaussian_cue(np.deg2rad(cues_deg), np.deg2rad(40.0))))
    assert np.abs(on - cues_deg).max() < 1.0  # with the cue on the bump follows it
    assert abs(on[3] - 16.97) < 0.01
    after_1_s = _wrap_deg(settle(sim, np.zeros(N_CELLS), duration_s=1.0))
    np.testing.assert_allclose(after_1_s, 16.875, atol=1e-3)
    after_3_s = _wrap_deg(settle(sim, np.zeros(N_CELLS), duration_s=2.0))
    np.testing.assert_allclose(after_3_s, 16.875, atol=1e-6)
    assert abs(after_3_s[3] - 17.0) == pytest.approx(0.125, abs=1e-6)


def test_drift_to_the_midpoint_is_the_equations_not_the_step():
    """A 25 us step, by plain explicit Euler (stable there), ends at the same midpoint for a 17 deg cue."""
    sim = _explicit_euler_ring().compile(batch=1, dt_s=2.5e-5)
    settle(sim, gaussian_cue(np.deg2rad(17.0), np.deg2rad(40.0)))
    assert abs(_wrap_deg(settle(sim, np.zeros(N_CELLS), duration_s=1.0))[0] - 16.875) < 1e-3


def test_the_compile_rule_is_the_no_overshoot_bound_of_a_self_inhibited_cell():
    """check_leaky_step's claim: a cell with self-weight -1 and its leak (Sun's I cell) overshoots only past tau/2."""
    tau_s = 1e-3
    circuit = Circuit("one_cell")
    circuit.add_input("x", 1, ports=[SensorSpec("x", (1,), "")])
    circuit.add_population("r", 1, kind="leaky", activation="relu", tau_s=tau_s)
    circuit.connect("x", "r", weights=[[1.0]])
    circuit.connect("r", "r", weights=[[-1.0]])  # delayed: reads the state at the start of the step
    target = 0.5  # r = relu(1 - r)
    for dt_s in (0.3 * tau_s, 0.5 * tau_s):
        sim = circuit.compile(batch=1, dt_s=dt_s)
        trace = []
        for _ in range(40):
            sim.step({"x": np.ones((1, 1))})
            trace.append(sim.rates("r")[0, 0])
        assert np.all(np.diff(trace) >= 0) and np.all(np.array(trace) <= target + 1e-12)  # no overshoot
        assert trace[-1] == pytest.approx(target, abs=1e-6)
    # just past tau/2 the same step would overshoot: 1 - 2 dt/tau < 0; compile refuses it
    with pytest.raises(CircuitError, match="longer than half its tau_s"):
        circuit.compile(batch=1, dt_s=0.51 * tau_s)
    r, dt_s = 0.0, 0.51 * tau_s
    r = r + dt_s / tau_s * (max(1.0 - r, 0.0) - r)
    assert r > target  # the hand-written step at 0.51 tau already overshoots


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
