"""Every registered brain, backend and scenario builds, steps, stays finite and repeats under a seed."""

import dataclasses

import numpy as np
import pytest

from neuronav import registry
from neuronav.backend import Backend
from neuronav.config import apply_overrides
from neuronav.runner import load_scenario, run_trials
from neuronav.world import PointAgents, World


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


@pytest.mark.parametrize("name", registry.names("backend"))
def test_backend_builds_steps_stays_finite_and_repeats(name):
    ok, reason = registry.availability("backend", name)
    if not ok:
        pytest.skip(reason)
    cls = registry.load("backend", name)

    def run(seed):
        with cls() as backend:
            assert isinstance(backend, Backend)
            if backend.capabilities.batched:
                backend.load(World(), [PointAgents(count=4)])
            backend.reset(seed)
            rng = np.random.default_rng(seed)
            readings = []
            for _ in range(50):
                commands = {m.name: rng.uniform(*(m.range or (-0.1, 0.1)), (4, *m.shape))
                            for m in backend.capabilities.motors}
                backend.write(commands)
                backend.step()
                read = backend.read([s.name for s in backend.capabilities.sensors])
                readings.append(np.concatenate([v.reshape(4, -1) for v in read.values()], 1))
            return np.array(readings)

    first = run(3)
    assert np.all(np.isfinite(first))
    np.testing.assert_array_equal(first, run(3))


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
        assert a == b or all(a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]) for k in a)  # NaN == NaN
        numbers = [v for v in a.values() if isinstance(v, float)]
        assert numbers and any(np.isfinite(numbers))
    for key, array in first.timeseries.items():
        np.testing.assert_array_equal(array, second.timeseries[key], err_msg=key)
