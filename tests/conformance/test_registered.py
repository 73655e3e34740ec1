"""Every registered brain, backend and scenario builds, steps, stays finite and repeats under a seed."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from neuronav import registry
from neuronav.config import apply_overrides
from neuronav.engine.backend import Backend, Capabilities
from neuronav.errors import RegistryError
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.senses.chemistry import OdourScene
from neuronav.senses.odour import straight_trail
from neuronav.senses.plume import PlumeConfig
from neuronav.spec.body import BodySpec, Geom, Joint, Segment, Site
from neuronav.spec.world import PointAgents, PointAntenna, World

# Every backend's world smells: a trail under the bodies and a live plume upwind of them, so the odour
# and wind sensors are read (and must repeat under the seed) like the rest.
ODOUR_WORLD = World(odour=OdourScene(trails=(straight_trail((-2.0, 0.0), (2.0, 0.0), "wide"),),
                                     plume=PlumeConfig(arena_x_m=(-1.0, 7.0)), warmup_s=1.0))
ANTENNAE = (PointAntenna("L", (0.1, 0.05, 0.3), (0.4, 0.2, 0.2)),
            PointAntenna("R", (0.1, -0.05, 0.3), (0.4, -0.2, 0.2)))


def random_inputs(sensors, batch, steps, seed):
    rng = np.random.default_rng(seed)
    return [{s.name: rng.uniform(-1, 1, (batch, *s.shape)) for s in sensors} for _ in range(steps)]


@pytest.mark.parametrize("name", registry.names("brain"))
def test_brain_builds_steps_stays_finite_and_repeats(name):
    factory = registry.load("brain", name)
    circuit = factory()
    assert circuit.graph.number_of_nodes() > 0
    assert circuit.sensors, f"brain {name} reads no sensor port"

    def run(seed):
        sim = circuit.compile(batch=3, seed=seed)
        rates = []
        for inputs in random_inputs(circuit.sensors, 3, 40, seed=0):
            outputs = sim.step(inputs)
            assert set(outputs) == {m.name for m in circuit.motors}
            rates.append(np.concatenate([sim.rates(p.name) for p in circuit.populations], 1))
        assert sim.all_finite()
        return np.array(rates)

    first = run(seed=7)
    assert np.all(np.isfinite(first))
    np.testing.assert_array_equal(first, run(seed=7))


def small_body() -> BodySpec:
    """A two-legged box with an odour and a wind site: enough to exercise an articulated backend in a
    fraction of a second."""
    leg = dict(mass_kg=0.1, geoms=(Geom("capsule", (0.02, 0.1), pos_m=(0.0, 0.0, -0.1)),))
    joint = dict(kind="hinge", axis=(0.0, 1.0, 0.0), range_rad=(-1.0, 1.0), kp=50.0, kd=1.0, max_torque_nm=20.0)
    return BodySpec(
        name="biped-box",
        segments=(
            Segment("trunk", None, geoms=(Geom("box", (0.2, 0.1, 0.05)),), mass_kg=2.0),
            Segment("left", "trunk", joint=Joint("left_hip", **joint), pos_m=(0.0, 0.12, -0.05), **leg),
            Segment("right", "trunk", joint=Joint("right_hip", **joint), pos_m=(0.0, -0.12, -0.05), **leg),
        ),
        sites=(Site("nose", "trunk", (0.2, 0.0, 0.0), "odour"), Site("vane", "trunk", (0.0, 0.0, 0.05), "wind")),
        spawn_height_m=0.3,
    )


def drive(backend_class, body, seed, steps, batch):
    """Seeded random commands for ``steps`` steps; every sensor reading, shape (steps, ...)."""
    rng = np.random.default_rng(seed)
    with backend_class() as backend:
        assert isinstance(backend, Backend)
        backend.load(ODOUR_WORLD, [body])
        backend.reset(seed)
        readings = []
        for _ in range(steps):
            commands = {}
            for motor in backend.capabilities.motors:
                if motor.name == "joint_targets":
                    low, high = np.array([j.range_rad for j in body.joints]).T
                    commands[motor.name] = rng.uniform(low, high)[None, :]
                else:
                    commands[motor.name] = rng.uniform(*(motor.range or (-0.1, 0.1)), (batch, *motor.shape))
            backend.write(commands)
            backend.step()
            read = backend.read([s.name for s in backend.capabilities.sensors])
            readings.append(np.concatenate([v.reshape(batch, -1) for v in read.values()], 1))
        assert not getattr(backend, "warnings", []), backend.warnings
        return np.array(readings)


@pytest.mark.parametrize("name", registry.names("backend"))
def test_backend_builds_steps_stays_finite_and_repeats(name):
    ok, reason = registry.availability("backend", name)
    if not ok:
        pytest.skip(reason)
    cls = registry.load("backend", name)
    if isinstance(getattr(cls, "capabilities", None), Capabilities) and cls.capabilities.batched:
        body, batch, steps = PointAgents(count=4, antennae=ANTENNAE), 4, 50
    else:
        body, batch, steps = small_body(), 1, 250
    first = drive(cls, body, 3, steps, batch)
    with cls() as backend:
        backend.load(ODOUR_WORLD, [body])
        assert {"odour", "wind"} <= {s.name for s in backend.capabilities.sensors}
    assert np.all(np.isfinite(first))
    np.testing.assert_array_equal(first, drive(cls, body, 3, steps, batch))


PHYSICS = [b for b in registry.names("backend") if b != "kinematic"]


@pytest.mark.parametrize("backend", PHYSICS)
@pytest.mark.parametrize("name", registry.names("body"))
def test_body_on_every_backend_one_second_of_random_targets(name, backend):
    """1 s under seeded random joint targets: no engine warning, no NaN, nothing below the floor, repeatable."""
    ok, reason = registry.availability("backend", backend)
    if not ok:
        pytest.skip(reason)
    body = registry.load("body", name)()
    assert isinstance(body, BodySpec) and body.joints
    cls = registry.load("backend", backend)

    def run(seed):
        rng = np.random.default_rng(seed)
        low, high = np.array([j.range_rad for j in body.joints]).T
        rest = body.rest_pose_rad()
        with cls() as engine:
            engine.load(World(), [body])
            engine.reset(seed)
            heights = []
            for _ in range(125):  # 8 ms control steps
                # Random targets within a quarter of each joint's range around its rest angle.
                targets = np.clip(rest + 0.25 * (high - low) * rng.uniform(-0.5, 0.5, rest.size), low, high)
                engine.write({"joint_targets": targets[None, :]})
                engine.step(4)
                heights.append(engine.read(["body_pos"])["body_pos"][0, 2])
            assert not engine.warnings, engine.warnings
            return np.array(heights), engine.read(["joint_pos"])["joint_pos"]

    heights, joints = run(1)
    assert np.all(np.isfinite(heights)) and np.all(np.isfinite(joints))
    assert heights.min() > 0.05, "the body fell through or onto the floor"
    again_heights, again_joints = run(1)
    np.testing.assert_array_equal(heights, again_heights)
    np.testing.assert_array_equal(joints, again_joints)


# Per-trial bookkeeping, not metrics.
BOOKKEEPING = {"trial", "seed", "status", "error"}


def assert_metrics_finite(scenario, result, condition=None):
    """Every metric of every trial (and every aggregate) is a finite number.

    The only exceptions are the metrics the scenario lists in ``optional_metrics``: those it documents
    as legitimately undefined in some trials (NaN), e.g. a time-to-arrive for an agent that never
    arrives. (A name may belong to another protocol of the same scenario, so it need not appear here.)
    """
    declared = getattr(scenario, "optional_metrics", ())
    assert isinstance(declared, tuple) and all(isinstance(n, str) for n in declared), declared
    optional = set(declared)
    # The condition columns name a trial's condition; they measure nothing.
    not_measured = BOOKKEEPING | {condition} | set(getattr(scenario, "condition_columns", ()))
    names = {k for trial in result.trials for k in trial} - not_measured
    assert names, f"scenario {scenario.name} reports no metric"
    for trial in result.trials:
        assert set(trial) - not_measured == names, f"trial {trial['trial']} reports other metrics than the rest"
        for key in sorted(names - optional):
            value = trial[key]
            assert isinstance(value, (bool, int, float, np.number)), f"{key} = {value!r} is not a number"
            assert np.isfinite(value), (f"scenario {scenario.name}, trial {trial['trial']}: metric {key} = {value}; "
                                        f"list it in the scenario's optional_metrics if it may be undefined")
    for key, value in result.aggregates.items():
        if key not in optional:
            assert np.isfinite(value), f"scenario {scenario.name}: aggregate {key} = {value}"


@pytest.mark.parametrize("name", registry.names("scenario"))
def test_scenario_runs_short_finite_and_repeats(name):
    scenario = load_scenario(name)
    assert scenario.backends and scenario.default_backend in scenario.backends
    config = apply_overrides(scenario.config_type, scenario.smoke_config())
    assert dataclasses.is_dataclass(config)
    first = run_trials(scenario, config, scenario.default_backend, trials=2, seed=5)
    second = run_trials(scenario, config, scenario.default_backend, trials=2, seed=5)
    assert [t["status"] for t in first.trials] == ["ok", "ok"]
    for a, b in zip(first.trials, second.trials):
        for key in set(a) - set(scenario.timing_metrics):
            assert a[key] == b[key] or (a[key] != a[key] and b[key] != b[key]), key  # NaN == NaN
    assert_metrics_finite(scenario, first, scenario.statistics(config).condition)
    for key, array in first.timeseries.items():
        np.testing.assert_array_equal(array, second.timeseries[key], err_msg=key)


@pytest.mark.parametrize("name", registry.names("scenario"))
def test_scenario_figures_draw_the_trials_that_ran_beside_a_failed_one(name, tmp_path):
    """A failed trial never loses the others (their figures included): its row is only the bookkeeping (trial,
    seed, success, status, error) and its time series rows NaN, as a run writes them."""
    from neuronav.runs.scenario import ScenarioResult

    scenario = load_scenario(name)
    config = apply_overrides(scenario.config_type, scenario.smoke_config())
    result = run_trials(scenario, config, scenario.default_backend, trials=3, seed=5)
    rows = list(result.trials)
    rows[1] = {"trial": 1, "seed": 6, "success": False, "status": "failed", "error": "SimulationError: diverged"}
    series = {}
    for key, array in result.timeseries.items():
        array = np.array(array)
        if array.ndim and len(array) == 3 and np.issubdtype(array.dtype, np.floating):
            array[1] = np.nan
        series[key] = array
    failed = ScenarioResult(trials=rows, timeseries=series, aggregates=result.aggregates,
                            simulated_time_s=result.simulated_time_s)
    paths = scenario.figures(failed, config, tmp_path)
    assert paths and all(Path(path).exists() for path in paths)


@pytest.mark.parametrize("name", registry.names("scenario"))
def test_scenario_trials_differ_and_declare_what_they_compare(name):
    """Issue 22: with the default settings (``variability=on``) no two trials give the same metric row,
    and the condition a scenario's statistics compare is a column of its rows."""
    scenario = load_scenario(name)
    config = apply_overrides(scenario.config_type, scenario.smoke_config())
    assert getattr(config, "variability", None) == "on", f"{name}: variability must be a setting, on by default"
    result = run_trials(scenario, config, scenario.default_backend, trials=3, seed=11)
    spec = scenario.statistics(config)
    skip = BOOKKEEPING | set(scenario.timing_metrics) | {"success"}
    if spec.condition:
        assert all(spec.condition in trial for trial in result.trials), f"{name}: no column {spec.condition!r}"
        skip.add(spec.condition)
    measured = [tuple(sorted((k, repr(v)) for k, v in trial.items() if k not in skip)) for trial in result.trials]
    assert len(set(measured)) == len(measured), f"{name}: two trials gave identical metric rows"


def test_the_metric_check_refuses_an_undeclared_nan_and_accepts_a_declared_one():
    from neuronav.runs.scenario import ScenarioResult

    class Fake:
        name = "fake"
        optional_metrics = ()

    trials = [{"trial": 0, "seed": 0, "status": "ok", "error": "", "success": True, "d": 1.0, "t": float("nan")}]
    with pytest.raises(AssertionError, match="metric t = nan"):
        assert_metrics_finite(Fake(), ScenarioResult(trials=trials))
    Fake.optional_metrics = ("t",)
    assert_metrics_finite(Fake(), ScenarioResult(trials=trials))
    with pytest.raises(AssertionError, match="aggregate"):
        assert_metrics_finite(Fake(), ScenarioResult(trials=trials, aggregates={"tau": float("inf")}))


def drive_swarm(swarm_class, body, ants, seed, steps):
    """Seeded random joint targets for ``ants`` copies of ``body`` in one world; every reading (steps, ants, ...)."""
    rng = np.random.default_rng(seed)
    low, high = np.array([j.range_rad for j in body.joints]).T
    with swarm_class() as swarm:
        swarm.load(World(), [body] * ants)
        swarm.reset(seed)
        readings = []
        for _ in range(steps):
            swarm.write({"joint_targets": rng.uniform(low, high, (ants, len(low)))})
            swarm.step()
            read = swarm.read([s.name for s in swarm.capabilities.sensors])
            readings.append(np.concatenate([v.reshape(ants, -1) for v in read.values()], 1))
        return np.array(readings)


@pytest.mark.parametrize("name", registry.names("swarm_backend"))
def test_swarm_backend_builds_steps_stays_finite_and_repeats(name):
    """Every registered swarm backend (swarm-homing finds them by name) carries several bodies."""
    ok, reason = registry.availability("swarm_backend", name)
    if not ok:
        pytest.skip(reason)
    cls = registry.load("swarm_backend", name)
    first = drive_swarm(cls, small_body(), 3, 3, 100)
    assert first.shape[:2] == (100, 3) and np.all(np.isfinite(first))
    np.testing.assert_array_equal(first, drive_swarm(cls, small_body(), 3, 3, 100))


def test_an_unknown_swarm_backend_is_named_with_those_registered():
    with pytest.raises(RegistryError, match="unknown swarm_backend 'nope'; available: mujoco, pybullet"):
        registry.load("swarm_backend", "nope")
