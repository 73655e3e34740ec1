"""The paper's locomotion findings on every physics backend (short runs; trial seed 0).

- gait ranking: the FK tripod walks faster than the ripple, the ripple faster than the wave;
- turning: the turning rate grows with ``turn`` (Table 2), turn = 0 walks nearly straight and
  turn = ±1 turns on the spot;
- IK vs FK: at about the same speed the IK tripod keeps the body steadier (less variance of body
  height, roll and pitch) than the FK tripod.

Besides the orderings, the speeds and turning rates must stay within ±25% of what each engine
measured (2.5 s, trial seed 0, default settings otherwise), so that a change that slows every gait
alike fails. Measured on 2026-11-23 with::

    python -c "from dataclasses import replace; \
        from neuronav.scenarios.locomotion.scenario import LocomotionConfig, run_trial; \
        print(run_trial(replace(LocomotionConfig(), gait='tripod', duration_s=2.5), 'mujoco', 0)[0])"

(and likewise for each gait, ``turn`` and engine): forward speed (m/s) and turning rate (rad/s)
below. Both engines run the same body, gaits and control law; they differ by at most 20%.
"""

from dataclasses import replace

import pytest

from neuronav.scenarios.locomotion.scenario import LocomotionConfig, run_trial

BACKENDS = ["mujoco", "pybullet"]
BAND = 0.25  # relative band around each measured value
MEASURED_SPEED_M_S = {
    "mujoco": {"tripod": 0.433, "ripple": 0.229, "wave": 0.065},
    "pybullet": {"tripod": 0.423, "ripple": 0.211, "wave": 0.053},
}
MEASURED_TURN_RATE_RAD_S = {  # at turn = -1, -0.5, 0.5, 1 (+ = left)
    "mujoco": {-1.0: -0.934, -0.5: -0.446, 0.5: 0.450, 1.0: 0.935},
    "pybullet": {-1.0: -1.052, -0.5: -0.463, 0.5: 0.485, 1.0: 1.042},
}


def require(backend):
    pytest.importorskip(backend, reason=f"{backend} is not installed")


def walk(backend, **settings):
    config = replace(LocomotionConfig(), **settings)
    metrics, _ = run_trial(config, backend, 0)
    assert not metrics["fell"], (backend, settings, metrics)
    return metrics


@pytest.mark.parametrize("backend", BACKENDS)
def test_tripod_is_faster_than_ripple_faster_than_wave(backend):
    require(backend)
    speed = {gait: walk(backend, gait=gait, duration_s=2.5)["forward_speed_m_s"]
             for gait in ("tripod", "ripple", "wave")}
    assert speed["tripod"] > 1.3 * speed["ripple"] > 1.3 * 1.3 * speed["wave"] > 0.0, speed
    for gait, measured in MEASURED_SPEED_M_S[backend].items():
        assert speed[gait] == pytest.approx(measured, rel=BAND), (gait, speed[gait], measured)


@pytest.mark.parametrize("backend", BACKENDS)
def test_turning_rate_grows_with_turn_straight_at_zero_on_the_spot_at_one(backend):
    require(backend)
    turns = (-1.0, -0.5, 0.0, 0.5, 1.0)
    runs = {turn: walk(backend, turn=turn, duration_s=2.5) for turn in turns}
    rates = [runs[turn]["turn_rate_rad_s"] for turn in turns]
    assert all(a < b for a, b in zip(rates, rates[1:])), rates  # monotone in turn
    assert rates[0] < -0.5 and rates[-1] > 0.5, rates  # ±1: turns left (+) and right (−)
    for turn, measured in MEASURED_TURN_RATE_RAD_S[backend].items():
        assert runs[turn]["turn_rate_rad_s"] == pytest.approx(measured, rel=BAND), (turn, rates, measured)
    spin = min(abs(rates[0]), abs(rates[-1]))
    straight = runs[0.0]
    assert abs(straight["turn_rate_rad_s"]) < 0.15 * spin, rates
    assert abs(straight["lateral_drift_m"]) < 0.1 * straight["forward_speed_m_s"] * 2.5, straight
    for turn in (-1.0, 1.0):  # on the spot: the body centre hardly moves
        assert abs(runs[turn]["forward_speed_m_s"]) < 0.15 * straight["forward_speed_m_s"], runs[turn]


@pytest.mark.parametrize("backend", BACKENDS)
def test_ik_tripod_rides_steadier_than_fk_tripod_at_the_same_speed(backend):
    require(backend)
    fk = walk(backend, gait="tripod", duration_s=3.0)
    ik = walk(backend, gait="ik", duration_s=3.0)
    assert ik["forward_speed_m_s"] == pytest.approx(fk["forward_speed_m_s"], rel=0.25), (fk, ik)
    for key in ("body_height_var_m2", "roll_var_rad2", "pitch_var_rad2"):
        assert ik[key] < 0.7 * fk[key], (key, fk[key], ik[key])
