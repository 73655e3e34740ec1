"""The circuit core: declaration errors, update order, analytic dynamics, batching, sparse, seeds."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neuronav import Circuit, CircuitError, MotorSpec, PortError, SensorSpec, bind
from neuronav.brains.cx import stone2017
from neuronav.runs.plotting import plot_circuit, plot_connectivity

X = SensorSpec("x", (1,), "")


def route_inputs(batch, steps, seed=0):
    """Varying heading/velocity inputs, shape per step (batch, 1) and (batch, 2)."""
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, 0.1, (steps, batch, 1)), axis=0)
    velocity = 0.5 * np.concatenate([np.sin(heading), np.cos(heading)], axis=2)
    return [{"heading": heading[t], "velocity": velocity[t]} for t in range(steps)]


def run(sim, inputs):
    return np.array([sim.step(i)["motor"] for i in inputs])


# -- declaration errors --------------------------------------------------------------------------
def test_connection_to_unknown_population_names_it():
    c = Circuit("c")
    c.add_population("a", 2)
    with pytest.raises(CircuitError, match="no population 'b'.*it has: a"):
        c.connect("a", "b", rule="one_to_one")


def test_weight_shape_mismatch_names_expected_shape():
    c = Circuit("c")
    c.add_population("a", 2)
    c.add_population("b", 3)
    with pytest.raises(CircuitError, match=r"shape \(2, 3\), expected .* \(3, 2\)"):
        c.connect("a", "b", weights=np.ones((2, 3)))


@pytest.mark.parametrize("options, message", [
    ({"kind": "spiking"}, "unknown kind 'spiking'"),
    ({"activation": "tanh"}, "unknown activation 'tanh'"),
    ({"activation": "logistic", "params": {"gain": 1}}, "no parameter gain"),
    ({"kind": "leaky"}, "needs tau_s > 0"),
    ({"clip": (1, 0)}, "low <= high"),
    ({"noise_std": -1.0}, "noise_std must be >= 0"),
    ({"colour": "red"}, "unknown option colour"),
])
def test_bad_population_options(options, message):
    with pytest.raises(CircuitError, match=message):
        Circuit("c").add_population("p", 2, **options)


def test_duplicate_population_and_bad_rule():
    c = Circuit("c")
    c.add_population("a", 2)
    with pytest.raises(CircuitError, match="already has a population 'a'"):
        c.add_population("a", 2)
    c.add_population("b", 3)
    with pytest.raises(CircuitError, match="unknown connectivity rule 'ring'"):
        c.connect("a", "b", rule="ring")
    with pytest.raises(CircuitError, match="needs equal sizes"):
        c.connect("a", "b", rule="one_to_one")


def test_undelayed_cycle_is_an_error_naming_it():
    c = Circuit("c")
    c.add_population("a", 1)
    c.add_population("b", 1)
    c.connect("a", "b", weights=[[1.0]])
    c.connect("b", "a", weights=[[1.0]])
    with pytest.raises(CircuitError, match="cycle .*(a -> b -> a|b -> a -> b).*delay=True"):
        c.compile()


def test_missing_or_misshaped_input_is_a_port_error():
    sim = stone2017(noise=0.0).compile(batch=2)
    with pytest.raises(PortError, match="reads port 'velocity'.*have only: heading"):
        sim.step({"heading": np.zeros((2, 1))})
    with pytest.raises(PortError, match=r"port 'heading' expects an array of shape \(2, 1\).*got \(2,\)"):
        sim.step({"heading": np.zeros(2), "velocity": np.zeros((2, 2))})


def test_bind_names_both_sides():
    brain = stone2017()
    with pytest.raises(PortError, match="stone2017 needs port 'velocity'.*body provides only: heading"):
        bind(brain.sensors, [SensorSpec("heading", (1,), "rad")], consumer="stone2017", provider="body")
    with pytest.raises(PortError, match=r"port 'heading': stone2017 expects shape \(1,\) \[rad\].*\(2,\) \[deg\]"):
        bind(brain.sensors, [SensorSpec("heading", (2,), "deg"), SensorSpec("velocity", (2,), "units/step")],
             consumer="stone2017", provider="body")


# -- analytic dynamics ---------------------------------------------------------------------------
def test_rate_relu_and_logistic_are_exact():
    c = Circuit("c")
    c.add_input("x", 1, ports=[X])
    c.add_population("r", 2, activation="relu", bias=-1.0)
    c.add_population("s", 1, activation="logistic", params={"slope": 2.0, "bias": 1.0})
    c.add_output("y", 1, port=MotorSpec("y", (1,)))
    c.connect("x", "r", weights=[[1.0], [-1.0]])
    c.connect("x", "s", weights=[[1.0]])
    c.connect("s", "y", weights=[[3.0]])
    sim = c.compile(batch=3)
    x = np.array([[-2.0], [0.5], [3.0]])
    out = sim.step({"x": x})
    np.testing.assert_allclose(sim.rates("r"), np.maximum(np.c_[x - 1, -x - 1], 0))
    np.testing.assert_allclose(out["y"], 3.0 / (1 + np.exp(-(2 * x - 1))))


@pytest.mark.parametrize("kind", ["rate", "leaky"])
def test_logistic_population_adds_its_bias_before_the_slope(kind):
    """A logistic population with a bias b and params slope a, bias c: r = 1 / (1 + exp(-(a (W x + b) - c)))
    (leaky: its Euler step towards that value, from 0)."""
    c = Circuit("c")
    c.add_input("x", 1, ports=[X])
    options = {"tau_s": 0.02} if kind == "leaky" else {}
    c.add_population("s", 1, kind=kind, activation="logistic", params={"slope": 2.0, "bias": 1.0}, bias=0.75,
                     **options)
    c.connect("x", "s", weights=[[1.5]])
    sim = c.compile(batch=3, dt_s=0.01)
    x = np.array([[-2.0], [0.5], [3.0]])
    sim.step({"x": x})
    target = 1.0 / (1.0 + np.exp(-(2.0 * (1.5 * x + 0.75) - 1.0)))
    np.testing.assert_allclose(sim.rates("s"), target * (0.5 if kind == "leaky" else 1.0), rtol=1e-12)


def test_leaky_population_follows_euler_solution():
    dt_s, tau_s = 1e-3, 0.02
    c = Circuit("c")
    c.add_input("x", 1, ports=[X])
    c.add_population("r", 1, kind="leaky", tau_s=tau_s)
    c.connect("x", "r", weights=[[1.0]])
    sim = c.compile(dt_s=dt_s)
    for _ in range(100):
        sim.step({"x": np.ones((1, 1))})
    assert sim.rates("r")[0, 0] == pytest.approx(1 - (1 - dt_s / tau_s) ** 100, rel=1e-12)
    # ... which approaches the continuous solution 1 - exp(-t/tau).
    assert sim.rates("r")[0, 0] == pytest.approx(1 - np.exp(-0.1 / tau_s), abs=0.01)


def test_integrator_accumulates_gain_minus_leak_and_clips():
    c = Circuit("c")
    c.add_input("x", 1, ports=[X])
    c.add_population("m", 1, kind="integrator", gain=0.1, leak=0.02, drive_clip=(0, 1),
                     memory_clip=(0, 1), initial=0.2)
    c.connect("x", "m", weights=[[1.0]])
    sim = c.compile()
    for _ in range(5):
        sim.step({"x": np.full((1, 1), 7.0)})  # drive clipped to 1
    assert sim.memory("m")[0, 0] == pytest.approx(0.2 + 5 * (0.1 - 0.02))
    for _ in range(20):
        sim.step({"x": np.ones((1, 1))})
    assert sim.memory("m")[0, 0] == 1.0
    for _ in range(100):
        sim.step({"x": -np.ones((1, 1))})
    assert sim.memory("m")[0, 0] == 0.0


def test_delayed_self_connection_reads_previous_step():
    """r(t) = 1 + 0.5 r(t-1), r(0) = 0: the self-connection sees the previous value: 2 - 0.5^(t-1)."""
    c = Circuit("c")
    c.add_population("r", 1, bias=1.0)
    c.connect("r", "r", weights=[[0.5]])
    sim = c.compile()
    for t in range(1, 8):
        sim.step({})
        assert sim.rates("r")[0, 0] == pytest.approx(2 - 0.5 ** (t - 1))


def test_delayed_connection_between_populations_reads_start_of_step():
    c = Circuit("c")
    c.add_population("a", 1, bias=1.0)
    c.add_population("b", 1)
    c.connect("a", "b", weights=[[1.0]], delay=True)
    sim = c.compile()
    sim.step({})
    assert sim.rates("b")[0, 0] == 0.0  # a was still 0 at the start of the first step
    sim.step({})
    assert sim.rates("b")[0, 0] == 1.0


# -- batching, sparse, order, seeds ----------------------------------------------------------------
def test_batch_equals_single_runs_with_noise():
    steps, batch, seed = 150, 4, 11
    inputs = route_inputs(batch, steps)
    batched = run(stone2017(noise=0.1).compile(batch=batch, seed=seed), inputs)
    for i in range(batch):
        single_inputs = [{k: v[i:i + 1] for k, v in step.items()} for step in inputs]
        single = run(stone2017(noise=0.1).compile(batch=1, seed=seed + i), single_inputs)
        # Same noise, same equations; BLAS may round differently for another batch shape.
        np.testing.assert_allclose(batched[:, i], single[:, 0], rtol=0, atol=1e-12)


def test_dense_equals_sparse():
    inputs = route_inputs(3, 100)
    dense = stone2017(noise=0.1).compile(batch=3, seed=5, sparse=False)
    sparse = stone2017(noise=0.1).compile(batch=3, seed=5, sparse=True)
    assert sparse.sparse and not dense.sparse
    np.testing.assert_allclose(run(dense, inputs), run(sparse, inputs), rtol=0, atol=1e-12)
    np.testing.assert_allclose(dense.memory("CPU4"), sparse.memory("CPU4"), atol=1e-12)


@pytest.mark.parametrize("shift", [1, -2])
def test_roll_moves_the_bump_by_shift_cells(shift):
    """Rule ``roll``: target cell j reads source cell (j - shift) mod n, so a bump at cell 0 lands on
    cell ``shift mod n``."""
    n = 6
    c = Circuit("c")
    c.add_input("x", n, ports=[SensorSpec("x", (n,))])
    c.add_population("r", n, activation="identity")
    c.connect("x", "r", rule="roll", rule_params={"shift": shift})
    sim = c.compile()
    bump = np.zeros((1, n))
    bump[0, 0] = 1.0
    sim.step({"x": bump})
    np.testing.assert_array_equal(sim.rates("r"), np.roll(bump, shift, axis=1))
    assert sim.rates("r")[0, shift % n] == 1.0


def test_one_hot_codes_the_rounded_index_plus_offset_clipped_into_range():
    """Encoder ``one_hot``: the cell round(index) + offset is on, clipped into [0, size - 1]."""
    c = Circuit("c")
    c.add_input("shift", 5, ports=[SensorSpec("shift", (1,))], encoder="one_hot",
                encoder_params={"size": 5, "offset": 2})
    sim = c.compile(batch=5)
    sim.step({"shift": np.array([[-0.4], [0.6], [1.4], [-7.0], [9.0]])})
    np.testing.assert_array_equal(sim.rates("shift"), np.eye(5)[[2, 3, 3, 0, 4]])


def test_large_sparse_circuit_is_stored_sparse_by_default():
    c = Circuit("big")
    c.add_input("x", 1, ports=[X])
    c.add_population("a", 3000, activation="relu")
    c.connect("x", "a", weights=np.ones((3000, 1)))
    c.connect("a", "a", rule="roll", rule_params={"shift": 1}, gain=0.5)
    sim = c.compile()
    assert sim.sparse
    sim.step({"x": np.ones((1, 1))})
    sim.step({"x": np.ones((1, 1))})
    np.testing.assert_allclose(sim.rates("a"), 1.5)


def test_same_seed_same_numbers_different_seed_different():
    inputs = route_inputs(2, 80)
    a = run(stone2017(noise=0.1).compile(batch=2, seed=3), inputs)
    b = run(stone2017(noise=0.1).compile(batch=2, seed=3), inputs)
    c = run(stone2017(noise=0.1).compile(batch=2, seed=4), inputs)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_reset_restarts_state_and_noise():
    inputs = route_inputs(1, 50)
    sim = stone2017(noise=0.1).compile(seed=2)
    first = run(sim, inputs)
    sim.reset()
    np.testing.assert_array_equal(run(sim, inputs), first)


def rebuilt_in_order(circuit, order):
    out = Circuit(circuit.name)
    for name in order:
        out.add(circuit.population(name))
    for source, target, data in circuit.graph.edges(data=True):
        out.graph.add_edge(source, target, **data)
    return out


@settings(max_examples=15, deadline=None)
@given(st.permutations(sorted(stone2017().graph.nodes)))
def test_results_do_not_depend_on_declaration_order(order):
    reference = stone2017(noise=0.1)
    inputs = route_inputs(2, 30, seed=1)
    expected = run(reference.compile(batch=2, seed=9), inputs)
    shuffled = rebuilt_in_order(reference, order)
    np.testing.assert_array_equal(run(shuffled.compile(batch=2, seed=9), inputs), expected)


# -- composition and introspection ----------------------------------------------------------------
def test_merge_with_prefixes_and_extra_connection():
    a, b = Circuit("a"), Circuit("b")
    for circuit in (a, b):
        circuit.add_input("in", 1, ports=[X])
        circuit.add_population("r", 1, activation="relu")
        circuit.connect("in", "r", weights=[[1.0]])
    merged = Circuit.merge(a, b, prefixes=["left.", "right."],
                           connections=[("left.r", "right.r", {"weights": [[2.0]]})])
    assert set(merged.graph) == {"left.in", "left.r", "right.in", "right.r"}
    assert [s.name for s in merged.sensors] == ["x"]  # ports keep their names and are shared
    sim = merged.compile()
    sim.step({"x": np.ones((1, 1))})
    assert sim.rates("right.r")[0, 0] == 3.0
    with pytest.raises(CircuitError, match="already has a population 'in'"):
        Circuit.merge(a, b)


def test_graph_is_networkx_and_plots_draw(tmp_path):
    circuit = stone2017()
    assert circuit.graph.has_edge("TB1", "TB1") and circuit.graph.edges["TB1", "TB1"]["delay"]
    matrix, blocks = circuit.weight_matrix()
    assert matrix.shape == (sum(p.size for p in circuit.populations),) * 2
    ax = plot_connectivity(circuit)
    ax.figure.savefig(tmp_path / "m.png")
    ax = plot_circuit(circuit)
    ax.figure.savefig(tmp_path / "d.png")
    assert (tmp_path / "m.png").stat().st_size > 1000 and (tmp_path / "d.png").stat().st_size > 1000


def test_table_noise_is_standard_normal_and_per_agent():
    from scipy import stats

    c = Circuit("noise")
    c.add_population("r", 50, noise_std=1.0)
    samples = []
    sim = c.compile(batch=3, seed=1, noise_method="table")
    for _ in range(400):
        sim.step({})
        samples.append(sim.rates("r"))
    samples = np.array(samples)  # (steps, agents, cells)
    values = samples.ravel()
    assert abs(values.mean()) < 0.01 and values.std() == pytest.approx(1.0, abs=0.01)
    assert stats.kstest(values, "norm").pvalue > 0.01
    assert np.abs(values).max() < 4.4  # the table's tails stop at 4.33 sigma
    # Agent i of the batch draws what a single run with seed 1 + i draws.
    single = c.compile(batch=1, seed=2, noise_method="table")
    first = [single.step({}) or single.rates("r")[0] for _ in range(5)]
    np.testing.assert_array_equal(np.array(first), samples[:5, 1])
    with pytest.raises(CircuitError, match="noise_method 'pink' is unknown"):
        c.compile(noise_method="pink")


@pytest.mark.parametrize("noise_method, batch", [("gaussian", 3), ("gaussian", 40), ("table", 3)])
@pytest.mark.parametrize("stds", [(0.3, 0.3), (0.5, 2.0)], ids=["one level", "two levels"])
def test_each_population_gets_noise_of_its_own_std(noise_method, batch, stds):
    """Rates with no input are the noise itself: each population's spread is its own noise_std, for one
    level shared by every population (scaled once per block) and for two (scaled population by
    population), in every noise layout (small and large gaussian batches, table)."""
    c = Circuit("levels")
    c.add_population("a", 8, activation="identity", noise_std=stds[0])
    c.add_population("b", 5, activation="identity", noise_std=stds[1])  # 5 cells: packed after whole words
    sim = c.compile(batch=batch, seed=2, noise_method=noise_method)
    steps = 6000 // batch
    rates = {"a": [], "b": []}
    for _ in range(steps):
        sim.step({})
        for name in rates:
            rates[name].append(sim.rates(name))
    for name, std in zip(rates, stds):
        values = np.ravel(rates[name])
        assert abs(values.mean()) < 4 * std / np.sqrt(values.size)
        assert values.std() == pytest.approx(std, rel=4 / np.sqrt(2 * values.size))


def test_leaky_step_longer_than_tau_is_refused():
    c = Circuit("c")
    c.add_population("r", 1, kind="leaky", tau_s=1e-3)
    with pytest.raises(CircuitError, match="longer than half its tau_s"):
        c.compile(dt_s=3e-3)


@pytest.mark.parametrize("noise_method", ["gaussian", "table"])
def test_large_batches_lay_noise_out_differently_but_draw_the_same(noise_method):
    """Gaussian noise for batches of 32+ is kept as (word, agent, sample), small batches and all table
    noise as (step, column, agent); every layout gives each agent the draws of its own stream."""
    steps, batch, seed = 40, 40, 3
    inputs = route_inputs(batch, steps, seed=2)
    big = stone2017(noise=0.1).compile(batch=batch, seed=seed, noise_method=noise_method)
    assert big._noise_by_cell == (noise_method == "table")
    batched = run(big, inputs)
    for agent in (0, 17, 39):
        single_inputs = [{k: v[agent:agent + 1] for k, v in step.items()} for step in inputs]
        small = stone2017(noise=0.1).compile(batch=1, seed=seed + agent, noise_method=noise_method)
        assert small._noise_by_cell
        np.testing.assert_allclose(batched[:, agent], run(small, single_inputs)[:, 0], rtol=0, atol=1e-12)


def test_plots_show_every_population_and_connection_of_a_merged_circuit():
    """What the two plots draw, read from the figure: every (prefixed) population, every connection, the weights."""
    from matplotlib.patches import Circle, FancyArrowPatch

    left = Circuit("left")
    left.add_input("in", 1, ports=[X])
    left.add_population("r", 2)
    left.connect("in", "r", weights=[[1.0], [-2.0]])
    right = Circuit("right")
    right.add_input("in", 1, ports=[X])
    right.add_population("r", 1, kind="leaky", tau_s=0.1)
    right.connect("in", "r", weights=[[-3.0]])
    circuit = Circuit.merge(left, right, prefixes=("left", "right"))
    ax = plot_circuit(circuit)
    discs = {p.get_gid()[5:] for p in ax.patches if isinstance(p, Circle)}
    arrows = {p.get_gid()[5:] for p in ax.patches if isinstance(p, FancyArrowPatch)}
    assert discs == set(circuit.graph)
    assert arrows == {f"{s}->{t}" for s, t in circuit.graph.edges if s != t}
    assert {t.get_text() for t in ax.get_legend().get_texts()} == {"input", "rate", "leaky", "mixed sign", "inhibitory"}
    ax = plot_connectivity(circuit)
    matrix, blocks = circuit.weight_matrix()
    np.testing.assert_array_equal(ax.images[0].get_array(), matrix)
    assert [t.get_text() for t in ax.get_xticklabels()] == [name for name, _, _ in blocks]
