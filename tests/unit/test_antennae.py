"""Antennae that stay fixed or sweep (neuronav.bodies.antennae), and the kinematic body's antenna tips."""

import sys

import numpy as np
import pytest

import neuronav.bodies  # noqa: F401  (registers the desert ant's modules)
from neuronav.backends.kinematic import KinematicBackend
from neuronav.bodies.antennae import AntennaSweep, AntennaYawHook, SweptAntennaeGait, point_antennae
from neuronav.bodies.gaits import make_gait
from neuronav.engine.loop import AgentLoop, Clocks
from neuronav.errors import ConfigError
from neuronav.spec.world import PointAgents, PointAntenna, World

desert_ant = sys.modules["neuronav.bodies.desert_ant.body"].desert_ant


def _offsets(sweep: AntennaSweep, seconds: float, dt_s: float = 0.008) -> np.ndarray:
    return np.array([sweep.step(dt_s) for _ in range(int(round(seconds / dt_s)))])


def test_fixed_antennae_stay_at_rest():
    assert not _offsets(AntennaSweep("fixed", seed=3), 5.0).any()


def test_a_sweep_pans_both_antennae_through_its_amplitude_at_its_period():
    offsets = _offsets(AntennaSweep("moving", amplitude_rad=0.7, period_s=0.64, seed=1), 32.0)
    np.testing.assert_array_equal(offsets[:, 0], offsets[:, 1])  # the pair pans together
    assert np.abs(offsets).max() <= 0.7 + 1e-12
    assert np.quantile(offsets[:, 0], 0.02) < -0.68 and np.quantile(offsets[:, 0], 0.98) > 0.68
    # 32 s at a 0.64 s period: 50 sweeps, two zero crossings each; the phase noise only blurs the rhythm.
    crossings = np.count_nonzero(np.diff(np.sign(offsets[:, 0])) != 0)
    assert 80 <= crossings <= 120


def test_without_phase_noise_the_sweep_is_a_sinusoid():
    sweep = AntennaSweep("moving", amplitude_rad=0.5, period_s=1.0, phase_noise_rad_per_sqrt_s=0.0, seed=2)
    start = sweep.phase_rad
    offsets = _offsets(sweep, 1.0, dt_s=0.01)[:, 0]
    expected = 0.5 * np.sin(start + 2 * np.pi * 0.01 * np.arange(1, 101))
    np.testing.assert_allclose(offsets, expected, atol=1e-12)


@pytest.mark.parametrize("dt_s, steps", [(0.01, 100), (0.05, 40)])
def test_the_phase_diffuses_with_variance_sigma_squared_times_time(dt_s, steps):
    """After n steps of dt the phase's deviation from its mean advance 2π n dt / period is a sum of n
    normal kicks of std σ √dt: its variance is σ² n dt whatever dt (1.0 at dt 0.01 s, 2.0 at 0.05 s;
    a kick scaled by dt instead of √dt would give σ² n dt² = 0.01 and 0.1)."""
    sigma, period_s, samples = 1.0, 0.64, 2000
    sweep = AntennaSweep("moving", period_s=period_s, phase_noise_rad_per_sqrt_s=sigma)
    drift = np.empty(samples)
    for seed in range(samples):
        sweep.reset(seed)
        start = sweep.phase_rad
        for _ in range(steps):
            sweep.step(dt_s)
        drift[seed] = sweep.phase_rad - start - 2 * np.pi * steps * dt_s / period_s
    expected = sigma ** 2 * steps * dt_s
    assert np.mean(drift) == pytest.approx(0.0, abs=4 * np.sqrt(expected / samples))
    assert np.var(drift) == pytest.approx(expected, rel=4 * np.sqrt(2 / samples))  # chi² tolerance: ±13 %


def test_same_seed_same_sweep():
    np.testing.assert_array_equal(_offsets(AntennaSweep("moving", seed=5), 3.0),
                                  _offsets(AntennaSweep("moving", seed=5), 3.0))
    assert not np.array_equal(_offsets(AntennaSweep("moving", seed=5), 3.0),
                              _offsets(AntennaSweep("moving", seed=6), 3.0))


@pytest.mark.parametrize("options, message", [
    (dict(mode="wiggle"), "antennae 'wiggle' is unknown; allowed: fixed, moving"),
    (dict(amplitude_rad=-0.1), "amplitude_rad"),
    (dict(period_s=0.0), "period_s must be > 0"),
    (dict(phase_noise_rad_per_sqrt_s=float("nan")), "phase_noise"),
])
def test_bad_sweeps_are_refused(options, message):
    with pytest.raises(ConfigError, match=message):
        AntennaSweep(**options)


def test_the_swept_gait_moves_only_the_antenna_yaw_joints():
    ant = desert_ant()
    plain, swept = make_gait("tripod", ant), SweptAntennaeGait(make_gait("tripod", ant), AntennaSweep("moving", seed=1),
                                                                ant, control_dt_s=0.008, seed=1)
    swept.reset()
    plain.reset()
    names = ant.joint_names
    yaw = [names.index("antenna_L_yaw"), names.index("antenna_R_yaw")]
    differences = np.array([swept.step(0.2, 0.2) - plain.step(0.2, 0.2) for _ in range(80)])
    others = np.delete(differences, yaw, axis=1)
    assert not others.any()
    assert np.abs(differences[:, yaw]).max() > 0.5
    np.testing.assert_allclose(differences[:, yaw[0]], differences[:, yaw[1]], atol=1e-12)
    assert swept.cycle_s == plain.cycle_s  # the rest is the wrapped gait's


def test_point_antennae_sit_at_the_ants_odour_sites_and_scale_with_its_antennae():
    short, long = point_antennae(desert_ant(antenna_length_m=0.3)), point_antennae(desert_ant(antenna_length_m=0.8))
    for antennae in (short, long):
        left, right = antennae
        assert (left.name, right.name) == ("L", "R")
        assert left.tip_m[1] > 0 > right.tip_m[1]  # y is left
        assert left.tip_m[1] == pytest.approx(-right.tip_m[1]) and left.tip_m[0] == pytest.approx(right.tip_m[0])
    reach = [np.linalg.norm(np.subtract(a[0].tip_m, a[0].base_m)) for a in (short, long)]
    assert reach[1] > reach[0] * 2


def _kinematic(antennae, count=3):
    backend = KinematicBackend()
    backend.load(World(), [PointAgents(count=count, mode="unicycle", antennae=antennae)])
    return backend


def test_kinematic_tips_follow_the_agent_and_swing_about_their_bases():
    antennae = (PointAntenna("L", (0.1, 0.05, 0.4), (0.4, 0.2, 0.15)), PointAntenna("R", (0.1, -0.05, 0.4),
                                                                                      (0.4, -0.2, 0.15)))
    backend = _kinematic(antennae)
    backend.reset(heading_rad=np.array([0.0, np.pi / 2, np.pi]), position_m=(1.0, 2.0))
    tips = backend.read(["odour_sites"])["odour_sites"]
    # Heading 0 faces +y (left is -x); pi/2 faces +x (left is +y); pi faces -y.
    np.testing.assert_allclose(tips[0, 0], [1.0 - 0.2, 2.0 + 0.4, 0.15], atol=1e-12)
    np.testing.assert_allclose(tips[1, 0], [1.0 + 0.4, 2.0 + 0.2, 0.15], atol=1e-12)
    np.testing.assert_allclose(tips[2, 1], [1.0 - 0.2, 2.0 - 0.4, 0.15], atol=1e-12)
    backend.write({"antenna_yaw": np.array([[0.5, 0.0], [0.0, 0.0], [-0.5, -0.5]])})
    turned = backend.read(["wind_sites"])["wind_sites"]
    base = np.array([1.0 - 0.05, 2.0 + 0.1])  # agent 0's left base, heading 0
    assert np.linalg.norm(turned[0, 0, :2] - base) == pytest.approx(np.linalg.norm(tips[0, 0, :2] - base))
    assert turned[0, 0, 0] < tips[0, 0, 0]  # turned left: further toward -x
    np.testing.assert_array_equal(turned[0, 1], tips[0, 1])
    np.testing.assert_array_equal(turned[1], tips[1])


def test_the_yaw_hook_sweeps_the_kinematic_antennae():
    ant = desert_ant()
    backend = _kinematic(point_antennae(ant), count=1)
    loop = AgentLoop(backend, None, Clocks(physics_dt_s=0.008, control_dt_s=0.008, brain_dt_s=0.64),
                     hooks=[AntennaYawHook(AntennaSweep("moving", seed=2), seed=2)])
    loop.reset(seed=0)
    lateral = []
    for _ in range(100):
        loop.step()
        tips = backend.read(["odour_sites"])["odour_sites"]
        position = backend.read(["position"])["position"]
        lateral.append(-(tips[:, 0, 0] - position[:, 0]))  # heading 0: left is -x
    lateral = np.array(lateral)
    assert np.ptp(lateral[:, 0]) > 0.2
