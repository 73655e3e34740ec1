"""A trial's numbers do not depend on its batch-mates, the batch width, the chunking or the workers.

Bit for bit (``np.array_equal``), on one machine and one build of numpy/scipy: the compiled circuit
sums every net input element-wise in a fixed order (no BLAS product, whose rounding depends on the
batch shape), every agent draws its noise from its own stream, and the path-integration scenario
builds each trial's route and metrics row by row.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.brains.ring import ring_attractor
from neuronav.config import apply_overrides
from neuronav.runs.cli import main
from neuronav.scenarios.path_integration.scenario import PathIntegration, PathIntegrationConfig, outbound_routes

TRIALS = 50
SHORT = {"outbound_steps": 150, "inbound_steps": 150, "record_every": 5, "record_trials": TRIALS}
METRICS = ("success", "closest_distance", "tortuosity_mu", "tortuosity", "decode_error_deg", "home_distance",
           "decoded_distance", "homing_steps")


def _inputs(batch, steps, seed=3):
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0.0, 0.3, (steps, batch, 1)), axis=0)
    speed = rng.uniform(0.0, 1.0, (steps, batch, 1))
    velocity = speed * np.concatenate([np.sin(heading), np.cos(heading)], axis=2)
    return heading, velocity


def _run_circuit(batch_slice, heading, velocity, **options):
    lo, hi = batch_slice.start, batch_slice.stop
    sim = stone2017(noise=0.1).compile(batch=hi - lo, seeds=list(range(100 + lo, 100 + hi)), **options)
    out = []
    for t in range(len(heading)):
        motor = sim.step({"heading": heading[t, lo:hi], "velocity": velocity[t, lo:hi]})["motor"]
        out.append(np.concatenate([motor, sim.memory("CPU4"), *(sim.rates(n) for n in sim.order)], axis=1))
    return np.array(out)  # (steps, agents, values)


@pytest.mark.parametrize("options", [
    {"dtype": "float32", "noise_method": "table"},
    {"dtype": "float64", "noise_method": "gaussian"},
    {"dtype": "float64", "noise_method": "table", "sparse": True},
], ids=["float32-table", "float64-gaussian", "float64-table-sparse"])
def test_compiled_circuit_agent_is_independent_of_its_batch(options):
    heading, velocity = _inputs(TRIALS, 120)
    whole = _run_circuit(slice(0, TRIALS), heading, velocity, **options)
    split = np.concatenate([_run_circuit(slice(0, 7), heading, velocity, **options),
                            _run_circuit(slice(7, TRIALS), heading, velocity, **options)], axis=1)
    assert np.array_equal(whole, split)
    for agent in (0, 6, 7, 33, TRIALS - 1):
        alone = _run_circuit(slice(agent, agent + 1), heading, velocity, **options)
        assert np.array_equal(whole[:, agent:agent + 1], alone), f"agent {agent} alone differs"


WIDE = 1000  # stone2017's noise blocks shrink below 256 steps above 178 agents (float64), 356 (float32)


@pytest.mark.parametrize("options", [
    {"dtype": "float64", "noise_method": "gaussian"},
    {"dtype": "float32", "noise_method": "table"},
], ids=["float64-gaussian", "float32-table"])
def test_agent_alone_equals_the_same_agent_in_a_batch_of_1000(options):
    """At 1000 agents each noise block holds fewer steps (45 or 91) than an agent alone draws (256):
    over 300 steps (several blocks either way) the agent's noise, and so its numbers, stay the same."""
    steps, agents = 300, (0, 517, WIDE - 1)
    heading, velocity = _inputs(WIDE, steps)
    wide = stone2017(noise=0.1).compile(batch=WIDE, seeds=list(range(100, 100 + WIDE)), **options)
    assert wide._noise_block_steps < 256  # the case the 50-agent tests above never reach
    picked = []
    for t in range(steps):
        motor = wide.step({"heading": heading[t], "velocity": velocity[t]})["motor"]
        values = np.concatenate([motor, wide.memory("CPU4"), *(wide.rates(n) for n in wide.order)], axis=1)
        picked.append(values[list(agents)])
    picked = np.array(picked)  # (steps, agents, values)
    for i, agent in enumerate(agents):
        alone = _run_circuit(slice(agent, agent + 1), heading, velocity, **options)
        assert np.array_equal(picked[:, i:i + 1], alone), f"agent {agent} alone differs from agent {agent} of {WIDE}"


@pytest.mark.parametrize("batch", [2, 5, 40])
def test_leaky_ring_attractor_agent_is_independent_of_its_batch(batch):
    n = ring_attractor().population("E").size
    cues = np.random.default_rng(1).uniform(0.0, 1.0, (30, batch, n))
    sims = [ring_attractor().compile(batch=batch, seed=4)] + [
        ring_attractor().compile(batch=1, seed=4 + i) for i in range(batch)]
    for t in range(len(cues)):
        sims[0].step({"cues": cues[t]})
        for i, single in enumerate(sims[1:]):
            single.step({"cues": cues[t, i:i + 1]})
    batched = sims[0].rates("E")
    for i, single in enumerate(sims[1:]):
        assert np.array_equal(batched[i:i + 1], single.rates("E"))


def test_home_vector_decode_is_row_by_row():
    cpu4 = np.random.default_rng(2).uniform(0.0, 1.0, (TRIALS, 16))
    direction, distance = decode_home_vector(cpu4)
    for i in (0, 13, TRIALS - 1):
        one_direction, one_distance = decode_home_vector(cpu4[i:i + 1])
        assert direction[i] == one_direction[0] and distance[i] == one_distance[0]


def test_outbound_routes_do_not_depend_on_the_other_trials():
    config = apply_overrides(PathIntegrationConfig, SHORT)
    rotation, acceleration = outbound_routes(config, list(range(TRIALS)))
    one_rotation, one_acceleration = outbound_routes(config, [17])
    assert np.array_equal(rotation[17:18], one_rotation) and np.array_equal(acceleration[17:18], one_acceleration)


def _scenario_runs(dtype, noise_method):
    config = apply_overrides(PathIntegrationConfig, dict(SHORT, dtype=dtype, noise_method=noise_method))
    scenario = PathIntegration()

    def run(seed, trials):
        return scenario.run(config, backend="kinematic", trials=trials, seed=seed)

    return run


def _table(results, key):
    return np.concatenate([np.asarray([row[key] for row in r.trials], float) for r in results])


def _series(results, key):
    return np.concatenate([r.timeseries[key] for r in results])


@pytest.mark.parametrize("dtype,noise_method", [("float32", "table"), ("float64", "gaussian")])
def test_path_integration_trials_are_identical_batched_as_1_as_7_43_and_as_50(dtype, noise_method):
    run = _scenario_runs(dtype, noise_method)
    layouts = {
        "50": [run(0, TRIALS)],
        "7+43": [run(0, 7), run(7, TRIALS - 7)],
        "1 by 1": [run(i, 1) for i in range(TRIALS)],
    }
    reference = layouts.pop("50")
    for name, results in layouts.items():
        for key in METRICS:
            assert np.array_equal(_table(reference, key), _table(results, key), equal_nan=True), (name, key)
        for key in ("position", "cpu4_memory", "tb1_rates", "heading_rad"):
            assert np.array_equal(_series(reference, key), _series(results, key)), (name, key)


def _trials_csv(out: Path) -> list[dict]:
    with open(out / "trials.csv", newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_cli_workers_1_and_2_and_chunks_of_5_write_identical_trials(tmp_path, dtype, capsys):
    settings = ["--set", "outbound_steps=120", "--set", "inbound_steps=120", "--set", "record_trials=2",
                "--set", f"dtype={dtype}"]
    tables = []
    for workers, chunk in ((1, []), (2, []), (2, ["--chunk-size", "5"])):
        out = tmp_path / f"workers{workers}{'-'.join(chunk)}"
        code = main(["run", "path-integration", "--trials", "12", "--seed", "5", "--out", str(out), "--no-figures",
                     "--no-progress", "--workers", str(workers), *chunk, *settings])
        assert code == 0, capsys.readouterr().err
        tables.append((out / "trials.csv").read_bytes())
        assert len(_trials_csv(out)) == 12
    assert tables[0] == tables[1] == tables[2]


@pytest.mark.parametrize("mode", ["stone", "unicycle"])
def test_kinematic_agent_is_independent_of_its_batch(mode):
    from neuronav.backends.kinematic import KinematicBackend
    from neuronav.spec.world import PointAgents, World

    rng = np.random.default_rng(4)
    batch, steps = 9, 60
    shape = (steps, batch, 1)
    commands = {"rotation": rng.normal(0, 0.2, shape), "acceleration": rng.uniform(0, 0.2, shape),
                "turn": rng.uniform(-1, 1, shape), "stride": rng.uniform(0, 0.5, shape)}

    def run(agents):
        backend = KinematicBackend()
        backend.load(World(), [PointAgents(count=len(agents), mode=mode)])
        for t in range(steps):
            backend.write({k: v[t, agents] for k, v in commands.items()})
            backend.step()
        return np.concatenate([backend.read(["position", "velocity", "heading"])[k] for k in
                               ("position", "velocity", "heading")], axis=1)

    whole = run(list(range(batch)))
    for agent in (0, 4, batch - 1):
        assert np.array_equal(whole[agent:agent + 1], run([agent]))
