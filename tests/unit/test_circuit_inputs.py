"""The Python API refuses what would silently go wrong: NaN/inf inputs, unknown ports, bad memory,
unknown compile options, batches too large for memory, negative reset seeds, pushes that do nothing."""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import Circuit, SensorSpec
from neuronav.backends.kinematic import KinematicBackend
from neuronav.brains.cx import stone2017
from neuronav.errors import CircuitError, ConfigError, NeuronavError, PortError
from neuronav.spec.world import PointAgents, World

GOOD = {"heading": np.zeros((1, 1)), "velocity": np.zeros((1, 2))}


@pytest.mark.parametrize("port,bad", [("heading", np.nan), ("velocity", np.inf), ("velocity", -np.inf)])
def test_non_finite_input_is_refused_naming_the_port(port, bad):
    sim = stone2017().compile(batch=3)
    inputs = {"heading": np.zeros((3, 1)), "velocity": np.zeros((3, 2))}
    inputs[port] = inputs[port].copy()
    inputs[port][1, -1] = bad
    with pytest.raises(PortError, match=f"port '{port}' needs finite values"):
        sim.step(inputs)
    assert sim.all_finite() and sim.steps == 0  # nothing was stepped


def test_input_check_can_be_switched_off_explicitly():
    sim = stone2017().compile(batch=1, check_inputs=False)
    sim.step({"heading": np.full((1, 1), np.nan), "velocity": np.zeros((1, 2))})
    assert not sim.all_finite()  # the documented consequence: NaN stays in the state
    with pytest.raises(CircuitError, match="check_inputs must be True or False"):
        stone2017().compile(check_inputs="no")


def test_huge_finite_inputs_pass_the_finite_check():
    sim = stone2017().compile(batch=2)
    huge = np.full((2, 2), 1e308)  # finite, but their sum overflows to inf
    out = sim.step({"heading": np.zeros((2, 1)), "velocity": huge})
    assert sim.steps == 1 and out["motor"].shape == (2, 1) and np.isfinite(out["motor"]).all() and sim.all_finite()
    huge[1, 0] = np.inf  # the same overflowing sum, now with a value that is not finite
    with pytest.raises(PortError, match="port 'velocity' needs finite values, got inf"):
        sim.step({"heading": np.zeros((2, 1)), "velocity": huge})
    assert sim.steps == 1


def test_ranged_port_refuses_values_outside_and_nan():
    circuit = Circuit("r")
    circuit.add_input("x", 1, ports=[SensorSpec("x", (1,), range=(0.0, 1.0))])
    sim = circuit.compile(batch=2)
    sim.step({"x": np.array([[0.0], [1.0]])})
    with pytest.raises(PortError, match=r"port 'x' accepts values in \[0, 1\], got 2"):
        sim.step({"x": np.array([[0.5], [2.0]])})
    with pytest.raises(PortError, match="port 'x' needs finite values"):
        sim.step({"x": np.array([[np.nan], [0.5]])})


def test_unknown_input_port_is_refused_naming_the_known_ones():
    sim = stone2017().compile(batch=1)
    with pytest.raises(PortError, match=r"no input port 'headng'; its ports: heading, velocity"):
        sim.step({**GOOD, "headng": np.zeros((1, 1))})


@pytest.mark.parametrize("value,message", [(np.nan, "must be finite"), (np.inf, "must be finite"),
                                           (1.5, r"kept in \[0, 1\]"), (-0.1, r"kept in \[0, 1\]")])
def test_set_memory_refuses_non_finite_and_out_of_clip_values(value, message):
    sim = stone2017().compile(batch=2)
    before = sim.memory("CPU4")
    with pytest.raises(CircuitError, match=message):
        sim.set_memory("CPU4", value)
    assert np.array_equal(sim.memory("CPU4"), before)
    sim.set_memory("CPU4", 0.25)
    assert np.all(sim.memory("CPU4") == 0.25)


def test_unknown_compile_option_is_a_circuit_error_naming_the_allowed_ones():
    with pytest.raises(CircuitError, match="unknown option frobnicate; allowed: batch, seed, dt_s, seeds, dtype"):
        stone2017().compile(frobnicate=True)


def test_batch_too_large_for_memory_fails_before_allocating():
    with pytest.raises(CircuitError, match=r"batch=1000000000000 needs about .* GiB .* use a batch of at most"):
        stone2017().compile(batch=10**12)
    assert stone2017().compile(batch=1).bytes_per_agent() > 0


def _kinematic(mode, count=2):
    backend = KinematicBackend()
    backend.load(World(), [PointAgents(count=count, mode=mode, drag=0.0)])
    return backend


@pytest.mark.parametrize("seed", [-1, 1.5, "0", True])
def test_kinematic_reset_refuses_a_bad_seed(seed):
    backend = _kinematic("stone")
    with pytest.raises(ConfigError, match="seed must be None or an int >= 0"):
        backend.reset(seed=seed)
    backend.reset(seed=0)
    backend.reset(seed=None)


def test_apply_force_moves_a_unicycle_agent():
    backend = _kinematic("unicycle")  # both agents stand still (stride 0)
    dt = backend.timestep
    backend.apply_force(1, "thorax", [2.0, -1.0, 5.0])
    backend.step(3)  # the push acts during every step of this call ...
    position = backend.read(["position"])["position"]
    np.testing.assert_allclose(position, [[0.0, 0.0], [3 * 2.0 * dt * dt, -3 * 1.0 * dt * dt]], rtol=1e-12)
    backend.step(2)  # ... and not after it: the gait holds the agent again
    np.testing.assert_allclose(backend.read(["position"])["position"], position, rtol=0, atol=0)


def test_apply_force_in_stone_mode_changes_the_velocity_once_per_step():
    backend = _kinematic("stone", count=1)
    backend.apply_force(0, "", [1.0, 0.0])
    backend.step(2)  # dt = 1 step, mass 1: v = 1 after the first step, 2 after the second
    np.testing.assert_allclose(backend.read(["velocity"])["velocity"], [[2.0, 0.0]])
    backend.step()
    np.testing.assert_allclose(backend.read(["velocity"])["velocity"], [[2.0, 0.0]])  # no drag, no push
    np.testing.assert_allclose(backend.read(["position"])["position"], [[5.0, 0.0]])


@pytest.mark.parametrize("body,force", [(2, [1.0, 0.0]), (True, [1.0, 0.0]), (0, [np.nan, 0.0]),
                                        (0, [1.0]), (0, "x")])
def test_apply_force_refuses_bad_arguments(body, force):
    with pytest.raises(NeuronavError):
        _kinematic("stone").apply_force(body, "thorax", force)
