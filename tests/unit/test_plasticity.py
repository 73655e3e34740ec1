"""Plastic connections in the circuit core: the rules, their gate, per-agent weights, save and load."""

import numpy as np
import pytest

from neuronav import Circuit
from neuronav.circuits.plasticity import OneShotDepression, ThreeFactorHebbian
from neuronav.errors import CircuitError
from neuronav.spec.ports import MotorSpec, SensorSpec

N_PN, N_KC = 6, 12


def kc_weights(seed=3):
    """Each KC reads two random PNs with weight 1."""
    rng = np.random.default_rng(seed)
    weights = np.zeros((N_KC, N_PN))
    for row in range(N_KC):
        weights[row, rng.choice(N_PN, 2, replace=False)] = 1.0
    return weights


def mb_circuit(rule=None):
    """PN -> KC (binary, fixed) -> MBON (identity, plastic, all weights 1), gated by ``learn``."""
    c = Circuit("mini-mb")
    c.add_input("PN", N_PN, ports=[SensorSpec("view", (N_PN,))])
    c.add_input("reward", 1, ports=[SensorSpec("learn", (1,))])
    c.add_population("KC", N_KC, activation="step", params={"threshold": 1.5})
    c.connect("PN", "KC", weights=kc_weights())
    c.add_output("MBON", 1, MotorSpec("novelty", (1,)))
    c.connect("KC", "MBON", weights=np.ones((1, N_KC)),
              learning=rule or OneShotDepression(rate=1.0, gate="reward"))
    return c


def hebbian_circuit(rule=None):
    """PN -> OUT (relu, plastic, Hebbian, random initial weights in [0, 1]), gated by ``reward``."""
    c = Circuit("hebb")
    c.add_input("PN", N_PN, ports=[SensorSpec("x", (N_PN,))])
    c.add_input("reward", 1, ports=[SensorSpec("reward", (1,))])
    c.add_output("OUT", 3, MotorSpec("y", (3,)), activation="relu")
    initial = np.random.default_rng(5).uniform(0.2, 0.8, (3, N_PN))
    c.connect("PN", "OUT", weights=initial, learning=rule or ThreeFactorHebbian(rate=0.05, w_min=0.0, w_max=1.0,
                                                                                  gate="reward"))
    return c, initial


def view(*on):
    x = np.zeros((1, N_PN))
    x[0, list(on)] = 1.0
    return x


def step(sim, x, learn):
    return sim.step({"view": x, "learn": np.full((x.shape[0], 1), float(learn))})["novelty"]


def test_one_shot_learning_makes_the_stored_view_familiar_and_leaves_an_unrelated_one_novel():
    sim = mb_circuit().compile(batch=1)
    stored, unrelated = view(0, 1, 2), view(3, 4, 5)
    kc = kc_weights()
    active_stored = int(((kc @ stored[0]) > 1.5).sum())
    active_unrelated = int(((kc @ unrelated[0]) > 1.5).sum())
    assert active_stored > 0 and active_unrelated > 0
    # Disjoint PN sets: no KC reads two PNs of both views, so the codes share no KC.
    assert not np.any(((kc @ stored[0]) > 1.5) & ((kc @ unrelated[0]) > 1.5))
    assert step(sim, stored, 0)[0, 0] == active_stored  # novel before learning: every active KC counts
    step(sim, stored, 1)  # one presentation with the gate on
    assert step(sim, stored, 0)[0, 0] == 0.0  # familiar
    assert step(sim, unrelated, 0)[0, 0] == active_unrelated  # still fully novel


def test_the_gate_off_changes_nothing():
    sim = mb_circuit().compile(batch=2)
    rng = np.random.default_rng(0)
    before = sim.weights("KC->MBON")
    for _ in range(20):
        sim.step({"view": rng.uniform(0, 1, (2, N_PN)), "learn": rng.uniform(-1.0, 0.5, (2, 1))})
    np.testing.assert_array_equal(sim.weights("KC->MBON"), before)
    hebb, initial = hebbian_circuit()
    sim = hebb.compile(batch=2)
    for _ in range(20):
        sim.step({"x": rng.uniform(0, 1, (2, N_PN)), "reward": np.zeros((2, 1))})
    np.testing.assert_array_equal(sim.weights("PN->OUT"), np.repeat(initial[None], 2, axis=0))


def test_depression_needs_gate_and_rate_strictly_above_their_thresholds():
    """OneShotDepression learns where gate > gate_threshold, from cells with rate > active_threshold:
    a value exactly at either threshold leaves the weight as it was."""
    c = Circuit("thresholds")
    c.add_input("X", 3, ports=[SensorSpec("x", (3,))])
    c.add_input("g", 1, ports=[SensorSpec("gate", (1,))])
    c.add_output("Y", 1, MotorSpec("y", (1,)))
    c.connect("X", "Y", weights=np.ones((1, 3)),
              learning=OneShotDepression(rate=0.25, active_threshold=0.3, gate_threshold=0.2, gate="g"))
    sim = c.compile(batch=3)
    x = np.repeat([[0.3, np.nextafter(0.3, 1.0), 0.0]], 3, axis=0)
    gates = np.array([[0.2], [np.nextafter(0.2, 1.0)], [np.nextafter(0.2, 0.0)]])
    sim.step({"x": x, "gate": gates})
    np.testing.assert_array_equal(sim.weights("X->Y")[:, 0], [[1.0, 1.0, 1.0], [1.0, 0.75, 1.0], [1.0, 1.0, 1.0]])


def test_batched_agents_learn_independently():
    sim = mb_circuit().compile(batch=2)
    x = np.repeat(view(0, 1, 2), 2, axis=0)
    sim.step({"view": x, "learn": np.array([[1.0], [0.0]])})  # only agent 0 learns
    weights = sim.weights("KC->MBON")
    assert np.any(weights[0] != 1.0)
    np.testing.assert_array_equal(weights[1], np.ones((1, N_KC)))
    out = sim.step({"view": x, "learn": np.zeros((2, 1))})["novelty"]
    assert out[0, 0] == 0.0 and out[1, 0] > 0.0


@pytest.mark.parametrize("make, batch", [("mb", 2), ("hebbian", 2), ("mb", 5), ("hebbian", 3)])
def test_a_batch_gives_the_numbers_of_single_runs(make, batch):
    rng = np.random.default_rng(11)
    steps = 30
    if make == "mb":
        circuit, port, gate, out, name = mb_circuit(), "view", "learn", "novelty", "KC->MBON"
    else:
        circuit, port, gate, out, name = hebbian_circuit()[0], "x", "reward", "y", "PN->OUT"
    # Gates: on (1) at about a third of the steps for the MB; a reward in [-1, 1] for the Hebbian rule.
    scale = 1.0 if make == "mb" else rng.uniform(-1, 1, (steps, batch, 1))
    gates = (rng.uniform(0, 1, (steps, batch, 1)) > 0.7) * scale
    inputs = [(rng.uniform(0.3, 1, (batch, N_PN)), g) for g in gates]
    both = circuit.compile(batch=batch)
    singles = [circuit.compile(batch=1) for _ in range(batch)]
    for x, g in inputs:
        joint = both.step({port: x, gate: g})[out]
        for agent, sim in enumerate(singles):
            alone = sim.step({port: x[agent:agent + 1], gate: g[agent:agent + 1]})[out]
            np.testing.assert_array_equal(joint[agent:agent + 1], alone)
    for agent, sim in enumerate(singles):
        np.testing.assert_array_equal(both.weights(name)[agent], sim.weights(name)[0])
    assert not np.array_equal(both.weights(name)[0], both.weights(name)[1])


def numpy_mb(inputs, learn, rate=1.0):
    """Hand-written reference of the mini MB: KC = [W x > 1.5], MBON = w · KC, then one-shot depression."""
    kc_w = kc_weights()
    w = np.ones((inputs.shape[1], N_KC))  # (agents, KC)
    outputs = []
    for x, g in zip(inputs, learn):
        kc = (x @ kc_w.T > 1.5).astype(float)  # (agents, KC)
        outputs.append((w * kc).sum(axis=1, keepdims=True))
        on = g[:, 0] > 0.5
        w[on] = np.maximum(w[on] - rate * (kc[on] > 0), 0.0)
    return np.array(outputs), w


def numpy_hebbian(inputs, rewards, initial, rate=0.05):
    """Hand-written reference: y = relu(W x), then W += rate · g · y xᵀ, clipped into [0, 1]."""
    w = np.repeat(initial[None], inputs.shape[1], axis=0)  # (agents, out, in)
    outputs = []
    for x, g in zip(inputs, rewards):
        y = np.maximum(np.einsum("bij,bj->bi", w, x), 0.0)
        outputs.append(y)
        w = np.clip(w + rate * g[:, :, None] * y[:, :, None] * x[:, None, :], 0.0, 1.0)
    return np.array(outputs), w


def test_one_shot_depression_equals_a_numpy_reference():
    rng = np.random.default_rng(2)
    inputs = rng.uniform(0, 1, (25, 4, N_PN))
    learn = (rng.uniform(0, 1, (25, 4, 1)) > 0.6).astype(float)
    sim = mb_circuit(OneShotDepression(rate=0.4, gate="reward")).compile(batch=4)
    got = np.array([sim.step({"view": x, "learn": g})["novelty"] for x, g in zip(inputs, learn)])
    expected, w = numpy_mb(inputs, learn, rate=0.4)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sim.weights("KC->MBON")[:, 0], w, rtol=0, atol=1e-12)
    assert np.any((w > 0.0) & (w < 1.0))  # partly depressed weights stay above the floor ...
    assert np.any(w == 0.0)  # ... and repeated learning reaches it


def test_three_factor_hebbian_equals_a_numpy_reference():
    rng = np.random.default_rng(4)
    circuit, initial = hebbian_circuit()
    inputs = rng.uniform(0, 1, (40, 3, N_PN))
    rewards = rng.uniform(-1, 1, (40, 3, 1)) * (rng.uniform(0, 1, (40, 3, 1)) > 0.5)
    sim = circuit.compile(batch=3)
    got = np.array([sim.step({"x": x, "reward": g})["y"] for x, g in zip(inputs, rewards)])
    expected, w = numpy_hebbian(inputs, rewards, initial)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sim.weights("PN->OUT"), w, rtol=1e-12, atol=1e-12)
    assert not np.allclose(w, initial)


def test_weights_survive_reset_and_reset_weights_restores_them():
    sim = mb_circuit().compile(batch=1)
    step(sim, view(0, 1, 2), 1)
    learnt = sim.weights("KC->MBON")
    sim.reset()
    np.testing.assert_array_equal(sim.weights("KC->MBON"), learnt)
    sim.reset_weights()
    np.testing.assert_array_equal(sim.weights("KC->MBON"), np.ones((1, 1, N_KC)))


def test_save_and_load_round_trip(tmp_path):
    sim = mb_circuit().compile(batch=3)
    rng = np.random.default_rng(1)
    for _ in range(5):
        sim.step({"view": rng.uniform(0, 1, (3, N_PN)), "learn": rng.uniform(0, 1, (3, 1))})
    path = tmp_path / "mb.npz"
    sim.save_weights(path)
    fresh = mb_circuit().compile(batch=3)
    fresh.load_weights(path)
    np.testing.assert_array_equal(fresh.weights("KC->MBON"), sim.weights("KC->MBON"))
    x = rng.uniform(0, 1, (3, N_PN))
    np.testing.assert_array_equal(step(fresh, x, 0), step(sim, x, 0))
    # One agent's memory given to a whole batch.
    single = mb_circuit().compile(batch=1)
    step(single, view(0, 1, 2), 1)
    single.save_weights(tmp_path / "one.npz")
    many = mb_circuit().compile(batch=4)
    many.load_weights(tmp_path / "one.npz")
    np.testing.assert_array_equal(many.weights("KC->MBON"), np.repeat(single.weights("KC->MBON"), 4, axis=0))
    with pytest.raises(CircuitError, match="shape"):
        mb_circuit().compile(batch=2).load_weights(path)
    np.savez(tmp_path / "other.npz", other=np.ones(3))
    with pytest.raises(CircuitError, match="plastic connections KC->MBON"):
        many.load_weights(tmp_path / "other.npz")
    with pytest.raises(CircuitError, match="cannot read"):
        many.load_weights(tmp_path / "missing.npz")


def test_set_weights_and_weights_check_their_arguments():
    sim = mb_circuit().compile(batch=2)
    sim.set_weights("KC->MBON", np.full((1, N_KC), 0.5))
    np.testing.assert_array_equal(sim.weights("KC->MBON"), np.full((2, 1, N_KC), 0.5))
    assert sim.plastic == ["KC->MBON"]
    assert sim.weights("PN->KC").shape == (2, N_KC, N_PN)
    with pytest.raises(CircuitError, match="fixed"):
        sim.set_weights("PN->KC", np.zeros((N_KC, N_PN)))
    with pytest.raises(CircuitError, match="no connection 'KC->PN'.*KC->MBON"):
        sim.weights("KC->PN")
    with pytest.raises(CircuitError, match="broadcastable"):
        sim.set_weights("KC->MBON", np.ones(3))
    with pytest.raises(CircuitError, match=">= 0"):
        sim.set_weights("KC->MBON", -np.ones((1, N_KC)))


@pytest.mark.parametrize("rule, message", [
    (OneShotDepression(rate=0.0, gate="reward"), "rate must be > 0"),
    (OneShotDepression(rate=float("nan"), gate="reward"), "rate must be a finite number"),
    (OneShotDepression(rate=1.0, gate="nowhere"), "gate 'nowhere' is not a population.*reward"),
    (OneShotDepression(rate=1.0, gate="PN"), "one cell"),
    (OneShotDepression(rate=1.0, gate="KC"), "must be an input population"),
    (ThreeFactorHebbian(rate=0.1, w_min=1.0, w_max=0.0, gate="reward"), "w_min < w_max"),
    (ThreeFactorHebbian(rate=-0.1, gate="reward"), "rate must be > 0"),
    ("hebbian", "learning must be a learning rule"),
])
def test_bad_rules_are_refused_with_a_clear_message(rule, message):
    c = Circuit("bad")
    c.add_input("PN", 2, ports=[SensorSpec("view", (2,))])
    c.add_input("reward", 1, ports=[SensorSpec("learn", (1,))])
    c.add_population("KC", 2)
    c.add_output("MBON", 1, MotorSpec("novelty", (1,)))
    c.connect("PN", "KC", weights=np.eye(2))
    with pytest.raises(CircuitError, match=message):
        c.connect("KC", "MBON", weights=np.ones((1, 2)), learning=rule)


def test_depression_refuses_negative_weights():
    c = mb_circuit()
    c.graph.remove_edge("KC", "MBON")
    with pytest.raises(CircuitError, match="non-negative"):
        c.connect("KC", "MBON", weights=np.ones((1, N_KC)), sign=-1,
                  learning=OneShotDepression(rate=1.0, gate="reward"))


def test_a_prefixed_copy_keeps_its_gate():
    merged = Circuit.merge(mb_circuit(), mb_circuit(), prefixes=["a_", "b_"])
    rule = merged.graph.edges["a_KC", "a_MBON"]["learning"]
    assert rule.gate == "a_reward"
    assert merged.graph.edges["b_KC", "b_MBON"]["learning"].gate == "b_reward"
    sim = merged.compile(batch=1)
    assert sim.plastic == ["a_KC->a_MBON", "b_KC->b_MBON"]


def test_the_circuit_diagram_dashes_a_plastic_connection_and_names_its_rule():
    from neuronav.runs.plotting import plot_circuit

    ax = plot_circuit(mb_circuit())
    edges = {p.get_gid(): p for p in ax.patches if (p.get_gid() or "").startswith("edge:")}
    assert edges["edge:KC->MBON"].get_linestyle() == "--"
    assert edges["edge:PN->KC"].get_linestyle() == "-"
    labels = [text.get_text() for text in ax.get_legend().get_texts()]
    assert "plastic: one-shot depression" in labels


def test_the_step_activation_is_binary_at_its_threshold():
    from neuronav.circuits.activations import step

    x = np.array([[-1.0, 0.5, 0.5000001, 2.0]])
    np.testing.assert_array_equal(step(x.copy(), threshold=0.5), [[0.0, 0.0, 1.0, 1.0]])
    with pytest.raises(CircuitError, match="no parameter slope; allowed: threshold"):
        Circuit("s").add_population("KC", 2, activation="step", params={"slope": 1.0})


def test_a_delayed_plastic_connection_reads_the_previous_step():
    """A -> OUT delayed and plastic: OUT_t = W_t · A_{t-1}; the rule sees this step's A_t and OUT_t."""
    c = Circuit("delayed")
    c.add_input("X", 2, ports=[SensorSpec("x", (2,))])
    c.add_input("reward", 1, ports=[SensorSpec("reward", (1,))])
    c.add_population("A", 2)
    c.connect("X", "A", weights=np.eye(2))
    c.add_output("OUT", 1, MotorSpec("y", (1,)))
    c.connect("A", "OUT", weights=[[0.5, 0.5]], delay=True,
              learning=ThreeFactorHebbian(rate=0.1, w_min=0.0, w_max=2.0, gate="reward"))
    sim = c.compile(batch=1)
    rng = np.random.default_rng(0)
    w, previous = np.array([0.5, 0.5]), np.zeros(2)
    for _ in range(10):
        x, g = rng.uniform(0, 1, 2), rng.uniform(-1, 1)
        y = sim.step({"x": x[None], "reward": np.array([[g]])})["y"][0, 0]
        expected = w @ previous
        assert y == pytest.approx(expected, abs=1e-12)
        w = np.clip(w + 0.1 * g * expected * x, 0.0, 2.0)
        previous = x
    np.testing.assert_allclose(sim.weights("A->OUT")[0, 0], w, atol=1e-12)
