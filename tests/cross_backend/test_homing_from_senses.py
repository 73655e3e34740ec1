"""Path integration from the ant's own senses (issue 23): the sky compass and the step odometer feed the CX,
on the kinematic point agents and unicycle, MuJoCo and PyBullet, through the Python API and the CLI."""

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from neuronav import registry
from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.scenarios.path_integration.inputs import SkyView, run_sky, trial_inputs
from neuronav.scenarios.path_integration.scenario import PathIntegrationConfig
from neuronav.spec.world import PointAgents, World, WorldObject

SHORT_I2BOT = {"protocol": "i2bot", "outbound_s": 8.0, "homing_timeout_s": 30.0}
SHORT_STONE = {"outbound_steps": 500, "inbound_steps": 700, "record_trials": 1}


def available(name):
    ok, reason = registry.availability("backend", name)
    if not ok:
        pytest.skip(reason)


def run(settings, backend="kinematic", trials=4, seed=11):
    scenario = load_scenario("path-integration")
    config = apply_overrides(PathIntegrationConfig, settings)
    scenario.check(config, backend)
    return run_trials(scenario, config, backend, trials=trials, seed=seed).trials


@pytest.mark.parametrize("sun_azimuth_deg", [120.0, -100.0])
def test_point_agents_home_by_the_sky_compass_and_decode_in_the_world_frame(sun_azimuth_deg):
    """stone2017 agents with the sky compass: the memory is in the sun's frame, decoded + sun azimuth = home."""
    rows = run({**SHORT_STONE, "compass": "sky", "sun_azimuth_deg": sun_azimuth_deg}, trials=10)
    assert all(r["inputs"] == "sky/true" for r in rows)
    assert sum(r["success"] for r in rows) >= 9
    assert np.median([r["decode_error_deg"] for r in rows]) < 10.0


def test_unicycle_homes_from_the_sky_and_its_stride_counter():
    rows = run({**SHORT_I2BOT, "compass": "sky", "odometry": "steps"}, trials=4)
    assert all(r["status"] == "ok" and r["inputs"] == "sky/steps" for r in rows)
    assert sum(r["success"] for r in rows) >= 3, [(r["home_distance_m"], r["closest_distance_m"]) for r in rows]
    # The stride counter reads the commanded strides: near the truth, not it (motor noise).
    ratios = np.array([r["odometer_ratio"] for r in rows])
    assert np.all(np.abs(ratios - 1.0) < 0.1) and np.all(ratios != 1.0), ratios
    assert all(2.0 < r["compass_error_deg"] < 20.0 for r in rows)


def test_compass_and_odometry_lists_are_cycled_and_compared():
    config = apply_overrides(PathIntegrationConfig, {"compass": "true,sky", "odometry": "true,steps"})
    assert [trial_inputs(config, s) for s in range(5)] == [("true", "true"), ("sky", "true"), ("true", "steps"),
                                                           ("sky", "steps"), ("true", "true")]
    statistics = load_scenario("path-integration").statistics(config)
    assert statistics.condition == "inputs" and statistics.reference == "true/true"


@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_physics_ant_homes_from_its_senses(backend):
    """The walking ant with the sky compass (its head's real pose) and the step odometer (its joints and
    leg loads through the believed legs)."""
    available(backend)
    rows = run({**SHORT_I2BOT, "compass": "sky", "odometry": "steps"}, backend, trials=1)
    for r in rows:
        assert r["status"] == "ok" and r["inputs"] == "sky/steps"
        assert r["closest_distance_m"] < 0.5 * r["home_distance_m"], r
        assert 0.85 < r["odometer_ratio"] < 1.2, r
        assert r["compass_error_deg"] < 20.0, r


def loaded(backend, world):
    """``backend`` with ``world`` loaded and reset (seed 0): two unicycle point agents on kinematic, else the ant."""
    engine = registry.load("backend", backend)()
    if backend == "kinematic":
        body = PointAgents(count=2, mode="unicycle")
    else:
        from neuronav.bodies.desert_ant import desert_ant

        body = desert_ant()
    engine.load(world, [body])
    engine.reset(seed=0)
    return engine


@pytest.mark.parametrize("backend", ["kinematic", "mujoco"])
def test_objects_overhead_block_the_sky(backend):
    """A roof over the ant: the dorsal rim's rays hit it on the backend, so no POL-neuron responds."""
    available(backend)
    sky = run_sky(apply_overrides(PathIntegrationConfig, {}))
    roof = WorldObject("box", (0.0, 0.0, 4.0), (6.0, 6.0, 0.5))
    responses = {}
    for name, world in (("open", World(sky=sky)), ("roofed", World(objects=(roof,), sky=sky))):
        with loaded(backend, world) as engine:
            responses[name] = SkyView(sky, world)(engine)
    assert np.abs(responses["open"]).max() > 0.1
    assert np.all(responses["roofed"] == 0.0)


@pytest.mark.parametrize("backend", ["kinematic", "mujoco", "pybullet"])
def test_the_rays_cast_as_far_as_the_scene_is_high_see_what_50_m_rays_see(backend):
    """SkyView casts the rims' rays only until they rise above the scene's top: a tower 20 m off, 20 m high,
    still hides the low ommatidia that face it (their rays meet its near face 16 m off about 14 m up, ~21 m
    along), as rays cast the full 50 m do, also with the scene turned 2 rad (set_scene_yaw); a low slab that
    no rising ray can meet hides none (none is cast)."""
    available(backend)
    sky = run_sky(apply_overrides(PathIntegrationConfig, {}))
    tower = WorldObject("box", (20.0, 0.0, 10.0), (4.0, 4.0, 10.0))
    slab = WorldObject("box", (3.0, 0.0, 0.1), (0.5, 0.5, 0.1))
    cases = [("tower", (tower,), 0.0), ("turned", (tower,), 2.0), ("slab", (slab,), 0.0)]
    blocked = {}
    for name, objects, yaw_rad in cases:
        world = World(objects=objects, sky=sky)
        with loaded(backend, world) as engine:
            engine.set_scene_yaw(yaw_rad)
            engine.step(1)  # (MuJoCo moves the scene's geoms in the step's kinematics)
            view, full = SkyView(sky, world), SkyView(sky, world)
            full._occlusion.top_m = None  # every ray cast the full 50 m
            cut = view(engine)
            np.testing.assert_array_equal(cut, full(engine))
            blocked[name] = int((cut == 0.0).sum())
    assert blocked["tower"] > 0 and blocked.get("turned", 1) > 0 and blocked["slab"] == 0, blocked


def test_settings_that_cannot_run_are_refused_before_any_trial():
    scenario = load_scenario("path-integration")
    with pytest.raises(ConfigError, match="odometry=steps needs protocol=i2bot"):
        scenario.check(apply_overrides(PathIntegrationConfig, {"odometry": "steps"}), "kinematic")
    with pytest.raises(ConfigError, match="one compass per run"):
        scenario.check(apply_overrides(PathIntegrationConfig, {"compass": "true,sky"}), "kinematic")
    with pytest.raises(ConfigError, match="compass: expected true or sky"):
        apply_overrides(PathIntegrationConfig, {"compass": "moon"})
    with pytest.raises(ConfigError, match="odometry: expected true, steps or optic_flow, .* without repeats"):
        apply_overrides(PathIntegrationConfig, {"odometry": "steps,steps"})


def test_cli_runs_the_senses_and_refuses_bad_ones(tmp_path):
    out = tmp_path / "run"
    command = [sys.executable, "-m", "neuronav", "run", "path-integration", "--backend", "kinematic", "--trials", "2",
               "--set", "protocol=i2bot", "--set", "outbound_s=4", "--set", "homing_timeout_s=10",
               "--set", "compass=sky", "--set", "odometry=steps", "--out", str(out), "--no-figures"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["compass"] == "sky" and np.isfinite(summary["metrics"]["compass_error_deg"])
    bad = subprocess.run(command[:-3] + ["--set", "compass=moon", "--out", str(tmp_path / "bad")],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "compass" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["kinematic", "mujoco", "pybullet"])
def test_homing_from_the_senses_is_as_good_as_from_the_truth(backend):
    """20 trials per input combination, paper protocol: every combination homes in most trials, and the
    sky compass with the step odometer is not significantly worse than the true inputs (Fisher's test)."""
    available(backend)
    rows = run({"protocol": "i2bot", "compass": "true,sky", "odometry": "true,steps"}, backend, trials=80, seed=0)
    by = {label: [r for r in rows if r["inputs"] == label] for label in ("true/true", "sky/true", "true/steps",
                                                                          "sky/steps")}
    assert all(len(group) == 20 for group in by.values())
    for label, group in by.items():
        assert sum(r["success"] for r in group) >= 16, label
    true_ok, sky_ok = (sum(r["success"] for r in by[k]) for k in ("true/true", "sky/steps"))
    assert stats.fisher_exact([[true_ok, 20 - true_ok], [sky_ok, 20 - sky_ok]]).pvalue > 0.05


@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_the_rims_are_mounted_level_on_the_ants_nose_down_head(backend):
    """The desert ant holds its head 0.2 rad nose-down: unmounted, the rims' zenith tilts forward by that much
    (a compass error that swings with the heading); mounted (level_rim_mount), it points up."""
    available(backend)
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.path_integration.inputs import level_rim_mount

    body = desert_ant()
    sky = run_sky(apply_overrides(PathIntegrationConfig, {}))
    engine = registry.load("backend", backend)()
    with engine:
        engine.load(World(sky=sky), [body])
        engine.reset(seed=0, yaw_rad=0.7)
        tilt = {}
        for name, mount in (("bare", None), ("mounted", level_rim_mount(body))):
            up = SkyView(sky, World(sky=sky), mount=mount).head_rotations(engine)[0][:, 2]
            tilt[name] = np.arccos(np.clip(up[2], -1.0, 1.0))
    assert tilt["bare"] == pytest.approx(0.2, abs=0.05)
    assert tilt["mounted"] < 0.05


def test_physics_ant_reads_its_path_from_ventral_optic_flow_on_textured_ground_only():
    """odometry=optic_flow: the ventral eye's image motion measures the outbound path within 20 % on the checker
    ground; on a plain ground it sees no motion and the odometer reads nothing. Point agents refuse it."""
    available("mujoco")
    short = {"protocol": "i2bot", "outbound_s": 6.0, "homing_timeout_s": 0.64, "odometry": "optic_flow"}
    textured = run({**short, "ground_texture": "checker"}, "mujoco", trials=1)[0]
    plain = run({**short, "ground_texture": "plain"}, "mujoco", trials=1)[0]
    assert textured["inputs"] == plain["inputs"] == "true/optic_flow"
    assert 0.8 < textured["odometer_ratio"] < 1.2, textured
    assert plain["odometer_ratio"] < 0.05, plain
    with pytest.raises(ConfigError, match="odometry=optic_flow needs protocol=i2bot"):
        load_scenario("path-integration").check(apply_overrides(PathIntegrationConfig, {"odometry": "optic_flow"}),
                                                "kinematic")
