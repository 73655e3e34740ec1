"""Property-based tests: random circuits, configs and command lines never escape as a bare exception.

Every failure a user can cause must be a :class:`neuronav.errors.NeuronavError` with a message, and
the CLI must exit 0 or 2 (one line on stderr), never with a traceback.

The circuit strategies below draw values of the right *types* (wrong values, shapes, names, kinds,
NaN and infinities included). Inputs of the wrong *type* (a string gain, a list as an activation
name, a negative seed, ...) once escaped as bare TypeError/ValueError; each such call is listed in
``REPORTED`` and ``test_malformed_circuit_input_is_a_neuronav_error`` requires a NeuronavError from it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from neuronav import Circuit, MotorSpec, NeuronavError, SensorSpec
from neuronav.circuits.connectivity import RULES
from neuronav.config import apply_overrides, build_config, field, load_config_file
from neuronav.errors import ConfigError
from neuronav.runs.cli import main
from neuronav.runs.runner import run_trials
from neuronav.scenarios.path_integration.embodied import CYCLE_S as GAIT_CYCLE_S
from neuronav.scenarios.path_integration.scenario import PathIntegration, PathIntegrationConfig

PROPERTY = settings(deadline=None, database=None, derandomize=bool(os.environ.get("CI")),
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


# NEURONAV_PROPERTY_SCALE=10 searches ten times longer (the defaults keep the suite quick on 2 cores).
SCALE = float(os.environ.get("NEURONAV_PROPERTY_SCALE", "1"))
# Random circuits and configs overflow and divide by zero on purpose.
pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


def examples(count: int) -> settings:
    """The shared settings with ``count`` examples (times ``NEURONAV_PROPERTY_SCALE``)."""
    return settings(PROPERTY, max_examples=max(1, int(count * SCALE)))
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True, width=64)
SOME_FLOAT = st.one_of(st.floats(-3, 3), st.sampled_from([0.0, float("nan"), float("inf"), -float("inf"), 1e300]))
TEXT = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=6)


def assert_own_error(error: BaseException) -> None:
    assert isinstance(error, NeuronavError), f"{type(error).__name__}: {error}"
    assert str(error).strip(), f"{type(error).__name__} without a message"


# -- circuits ------------------------------------------------------------------------------------------

NAMES = ["a", "b", "c", "d", ""]
KINDS = ["rate", "leaky", "integrator", "input", "output", "spiking"]
ACTIVATIONS = ["identity", "relu", "logistic", "tanh"]


@st.composite
def population_options(draw, kind):
    options = {}
    if draw(st.booleans()):
        activation = draw(st.sampled_from(ACTIVATIONS))
        options["activation"] = activation
        if draw(st.booleans()):
            keys = st.sampled_from(["slope", "bias", "gain"])
            options["params"] = draw(st.dictionaries(keys, SOME_FLOAT, max_size=2))
    for key in ("bias", "noise_std", "initial", "gain", "leak"):
        if draw(st.integers(0, 3)) == 0:
            options[key] = draw(SOME_FLOAT)
    for key in ("clip", "drive_clip", "memory_clip"):
        if draw(st.integers(0, 3)) == 0:
            options[key] = draw(st.tuples(SOME_FLOAT, SOME_FLOAT))
    if kind == "leaky" or draw(st.integers(0, 5)) == 0:
        options["tau_s"] = draw(st.one_of(st.none(), SOME_FLOAT))
    return options


@st.composite
def circuits(draw):
    """A Circuit built step by step from random declarations; invalid ones raise and are skipped."""
    dt_s = draw(st.one_of(st.none(), st.sampled_from([0.01, 1.0])))
    circuit = Circuit(draw(st.sampled_from(["net", "x"])), dt_s=dt_s)
    declared = []
    for _ in range(draw(st.integers(1, 5))):
        name, size = draw(st.sampled_from(NAMES)), draw(st.integers(-1, 5))
        kind = draw(st.sampled_from(KINDS))
        try:
            if kind == "input":
                # The encoder's output must match the population's size: a mismatch is reported
                # ("input size", REPORTED), so the shapes drawn here fit or are invalid outright.
                encoder, shape = draw(st.sampled_from([("identity", (size,)), ("heading_vector", (1,)),
                                                       ("nope", (1,)), ("identity", (0,))]))
                size = 2 if encoder == "heading_vector" else size
                ports = [SensorSpec(draw(st.sampled_from(["p", "q"])), shape,
                                    range=draw(st.one_of(st.none(), st.tuples(SOME_FLOAT, SOME_FLOAT))))]
                circuit.add_input(name, size, ports=ports, encoder=encoder, **draw(population_options("input")))
            elif kind == "output":
                circuit.add_output(name, size, MotorSpec("m" + name, (draw(st.sampled_from([size, 1, 2])),)),
                                   **draw(population_options("output")))
            else:
                circuit.add_population(name, size, kind, **draw(population_options(kind)))
            declared.append(name)
        except NeuronavError as error:
            assert_own_error(error)
    for _ in range(draw(st.integers(0, 6))):
        source, target = draw(st.sampled_from(NAMES)), draw(st.sampled_from(NAMES))
        options = {"gain": draw(SOME_FLOAT), "sign": draw(st.sampled_from([1, -1, 0, 2])),
                   "delay": draw(st.one_of(st.none(), st.booleans()))}
        if draw(st.booleans()):
            shape = draw(st.tuples(st.integers(0, 5), st.integers(0, 5)))
            options["weights"] = draw(st.sampled_from([np.ones, np.zeros]))(shape) * draw(SOME_FLOAT)
        else:
            options["rule"] = draw(st.sampled_from([*RULES, "random"]))
            if draw(st.booleans()):
                options["rule_params"] = draw(st.dictionaries(st.sampled_from(["shift", "sigma_rad", "width"]),
                                                              st.one_of(st.integers(-3, 3), SOME_FLOAT), max_size=2))
        try:
            circuit.connect(source, target, **options)
        except NeuronavError as error:
            assert_own_error(error)
    return circuit


@examples(150)
@given(circuits(), st.data())
def test_random_circuits_fail_only_with_neuronav_errors(circuit, data):
    options = {"batch": data.draw(st.integers(-1, 3)), "seed": data.draw(st.one_of(st.none(), st.integers(0, 2**40))),
               "dtype": data.draw(st.sampled_from(["float64", "float32", "float16", "int8", np.float32])),
               "noise_method": data.draw(st.sampled_from(["gaussian", "table", "fast"])),
               "sparse": data.draw(st.one_of(st.none(), st.booleans()))}
    if data.draw(st.booleans()):
        options["dt_s"] = data.draw(st.one_of(st.none(), SOME_FLOAT))
    try:
        simulation = circuit.compile(**options)
    except NeuronavError as error:
        assert_own_error(error)
        return
    for _ in range(data.draw(st.integers(1, 4))):
        inputs = {}
        for spec in simulation.sensors:
            if data.draw(st.integers(0, 6)):
                shape = (simulation.batch, *spec.shape) if data.draw(st.integers(0, 5)) else (spec.shape[0] + 1,)
                inputs[spec.name] = np.full(shape, data.draw(SOME_FLOAT))
        try:
            outputs = simulation.step(inputs)
        except NeuronavError as error:
            assert_own_error(error)
            continue
        assert set(outputs) == {m.name for m in simulation.motors}
        for spec in simulation.motors:
            assert outputs[spec.name].shape == (simulation.batch, *spec.shape)
    for name in (*declared_names(circuit), "nobody"):
        for read in (simulation.rates, simulation.memory):
            try:
                assert read(name).shape[0] == simulation.batch
            except NeuronavError as error:
                assert_own_error(error)


def declared_names(circuit):
    return [p.name for p in circuit.populations]


@examples(40)
@given(st.lists(st.sampled_from(["a_", "b_", "", "a_"]), min_size=1, max_size=3), st.data())
def test_merging_random_circuits_fails_only_with_neuronav_errors(prefixes, data):
    parts = []
    for _ in prefixes:
        circuit = Circuit("part")
        # (2,) only: a port wider than its input population is reported ("input size", REPORTED).
        circuit.add_input("in", 2, ports=[SensorSpec(data.draw(st.sampled_from(["p", "q"])), (2,),
                                                     data.draw(st.sampled_from(["", "rad"])))])
        circuit.add_population("r", 2, activation="relu")
        circuit.connect("in", "r", rule="one_to_one")
        parts.append(circuit)
    connections = [(data.draw(st.sampled_from(["a_r", "b_r", "r", "zz"])), data.draw(st.sampled_from(["a_r", "b_r"])),
                    {"rule": "all_to_all"}) for _ in range(data.draw(st.integers(0, 2)))]
    try:
        merged = Circuit.merge(*parts, prefixes=prefixes if data.draw(st.booleans()) else None,
                               connections=connections)
        merged.compile(batch=2).step({s.name: np.zeros((2, *s.shape)) for s in merged.sensors})
    except NeuronavError as error:
        assert_own_error(error)


# Inputs of the wrong type or size that once escaped as bare Python/numpy exceptions from the
# circuit core (circuit.py, activations.py, encoders.py, connectivity.py, compiled.py). Each is one call.
def _base():
    circuit = Circuit("c")
    circuit.add_input("x", 2, ports=[SensorSpec("a", (2,))])
    circuit.add_population("m", 2, "integrator")
    circuit.connect("x", "m", rule="one_to_one")
    return circuit


def _leaky():
    circuit = Circuit("l")
    circuit.add_input("x", 1, ports=[SensorSpec("a", (1,))])
    circuit.add_population("k", 1, "leaky", tau_s=1.0)
    return circuit


REPORTED = {
    "params=None": lambda: Circuit().add_population("p", 2, params=None),  # activations.py: set(None)
    "params=(0.5,)": lambda: Circuit().add_population("p", 2, params=(0.5,)),  # activations.py: join floats
    "activation=['relu']": lambda: Circuit().add_population("p", 2, activation=["relu"]),  # unhashable
    "clip=0": lambda: Circuit().add_population("p", 2, clip=0),  # circuit.py _population: tuple(0)
    "clip=('a', 'b')": lambda: Circuit().add_population("p", 2, clip=("a", "b")),  # float('a')
    "tau_s='1'": lambda: Circuit().add_population("p", 2, "leaky", tau_s="1"),  # '>' str and int
    "encoder_params=1.0": lambda: Circuit().add_input("i", 2, ports=[SensorSpec("a", (2,))], encoder_params=1.0),
    "encoder=['x']": lambda: Circuit().add_input("i", 2, ports=[SensorSpec("a", (2,))], encoder=["x"]),
    "gain='x' (compile)": lambda: (lambda c: (c.add_population("g", 2, "integrator", gain="x"), c.compile()))(_base()),
    "connect rule=['x']": lambda: _base().connect("m", "m", rule=["x"]),  # connectivity.py: unhashable
    "connect gain='x'": lambda: _base().connect("m", "m", rule="one_to_one", gain="x"),  # float('x')
    "connect gain=inf": lambda: _base().connect("m", "m", rule="one_to_one", gain=math.inf),  # inf/NaN weights kept
    "merge prefixes=5": lambda: Circuit.merge(_base(), prefixes=5),
    "merge connections=[('x',)]": lambda: Circuit.merge(_base(), connections=[("x",)]),  # unpacking
    "compile dtype='1:A'": lambda: _base().compile(dtype="1:A"),  # np.dtype's ValueError
    "compile seed=-1": lambda: _base().compile(seed=-1),  # SFC64: expected non-negative integer
    "compile seeds=['x']": lambda: _base().compile(batch=1, seeds=["x"]),
    "compile dt_s='x' (leaky)": lambda: _leaky().compile(dt_s="x"),
    "rates(['m'])": lambda: _base().compile().rates(["m"]),  # unhashable
    "set_memory('m', 'x')": lambda: _base().compile().set_memory("m", "x"),
    "step(['a'])": lambda: _base().compile().step(["a"]),  # AttributeError: list has no get
    "step string array": lambda: _base().compile().step({"a": np.array([["a", "b"]])}),
    # Right types, wrong sizes: an input population of 2 cells reading a port of 3 values passes
    # declaration and compile, then step() raises numpy's broadcast ValueError.
    "input size": lambda: (lambda c: (c.add_input("in", 2, ports=[SensorSpec("p", (3,))]),
                                      c.compile().step({"p": np.zeros((1, 3))})))(Circuit("c")),
}


@pytest.mark.parametrize("case", sorted(REPORTED))
def test_malformed_circuit_input_is_a_neuronav_error(case):
    with pytest.raises(NeuronavError):  # a CircuitError/PortError naming the argument is what is wanted
        REPORTED[case]()


# -- configs -------------------------------------------------------------------------------------------

VALUES = st.one_of(st.none(), st.booleans(), st.integers(-(10**30), 10**30), ANY_FLOAT, TEXT,
                   st.lists(st.integers(), max_size=2), st.dictionaries(TEXT, st.integers(), max_size=1))
KEYS = st.one_of(st.sampled_from([f.name for f in dataclasses.fields(PathIntegrationConfig)]), TEXT)


@examples(150)
@given(st.dictionaries(KEYS, VALUES, max_size=4))
def test_random_config_dicts_are_valid_or_a_config_error(values):
    try:
        config = build_config(PathIntegrationConfig, values)
    except ConfigError as error:
        assert_own_error(error)
        return
    assert build_config(PathIntegrationConfig, dataclasses.asdict(config)) == config


@examples(150)
@given(st.lists(st.one_of(st.builds(lambda k, v: f"{k}={v}", KEYS, TEXT),
                          st.builds(lambda k, v: f"{k}={v!r}", KEYS, VALUES), TEXT), max_size=4))
def test_random_set_strings_are_valid_or_a_config_error(assignments):
    try:
        apply_overrides(PathIntegrationConfig, assignments)
    except ConfigError as error:
        assert_own_error(error)


@st.composite
def config_types(draw):
    """A random scenario config dataclass: fields of each type with random limits and choices."""
    fields = []
    for i in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from([int, float, bool, str]))
        default = {int: draw(st.integers(-5, 5)), float: draw(st.floats(-5, 5)), bool: draw(st.booleans()),
                   str: draw(st.sampled_from(["a", "b"]))}[kind]
        limits = {}
        if kind in (int, float):
            for limit in ("min", "max", "min_exclusive", "max_exclusive"):
                if draw(st.integers(0, 3)) == 0:
                    limits[limit] = draw(st.integers(-5, 5))
        if kind is str and draw(st.booleans()):
            limits["choices"] = ("a", "b")
        fields.append((f"f{i}", kind, field(default, "a field", **limits)))
    return dataclasses.make_dataclass("RandomConfig", fields)


@examples(100)
@given(config_types(), st.dictionaries(st.sampled_from(["f0", "f1", "f2", "f3", "g"]), VALUES, max_size=3),
       st.lists(st.builds(lambda k, v: f"{k}={v}", st.sampled_from(["f0", "f1", "g"]), TEXT), max_size=2))
def test_random_config_types_and_overrides(config_type, values, assignments):
    try:
        build_config(config_type, values, assignments)
    except ConfigError as error:
        assert_own_error(error)


@examples(100)
@given(st.one_of(st.dictionaries(KEYS, VALUES, max_size=3).map(lambda d: "".join(
    f"{k!r} = {v!r}\n".replace("'", '"') for k, v in d.items())), TEXT, st.binary(max_size=20)))
def test_random_config_files_are_valid_or_a_config_error(text):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "config.toml"
        path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
        try:
            load_config_file(PathIntegrationConfig, path)
        except ConfigError as error:
            assert_own_error(error)
            assert str(path) in str(error)


PROTOCOLS = next(f for f in dataclasses.fields(PathIntegrationConfig) if f.name == "protocol").metadata["choices"]


@st.composite
def small_path_integration_configs(draw):
    """Valid configs over each field's whole range (extremes included), with short runs: a few steps of the
    stone2017 protocol, a few seconds of the i2bot protocol (its defaults walk 32 s out and up to 90 s home;
    out and home together at least one gait cycle, the cross-field rule)."""
    homing_s = draw(st.floats(0.01, 3.0))
    outbound_s = draw(st.floats(max(0.01, GAIT_CYCLE_S + 1e-9 - homing_s), 3.0))
    values = {"outbound_steps": draw(st.integers(1, 25)), "inbound_steps": draw(st.integers(1, 25)),
              "record_every": draw(st.integers(1, 60)), "record_trials": draw(st.integers(0, 3)),
              "homing_timeout_s": homing_s, "outbound_s": outbound_s,
              "protocol": draw(st.sampled_from(PROTOCOLS))}  # each protocol in about a third of the examples
    for f in dataclasses.fields(PathIntegrationConfig):
        if f.name in values or draw(st.integers(0, 2)):
            continue
        meta = f.metadata
        if "choices" in meta:
            values[f.name] = draw(st.sampled_from(meta["choices"]))
        elif isinstance(f.default, float):
            low = meta.get("min", meta.get("min_exclusive", -1e300))
            high = meta.get("max", meta.get("max_exclusive", 1e300))
            values[f.name] = draw(st.floats(low, high, exclude_min="min_exclusive" in meta,
                                            exclude_max="max_exclusive" in meta))
    low, high = (values.get(key, getattr(PathIntegrationConfig, key)) for key in ("min_acceleration",
                                                                                   "max_acceleration"))
    if low > high:  # a cross-field rule: min_acceleration <= max_acceleration
        values["min_acceleration"], values["max_acceleration"] = high, low
    return build_config(PathIntegrationConfig, values)


@examples(30)
@given(small_path_integration_configs(), st.integers(1, 3), st.integers(0, 2**32))
def test_random_valid_configs_run_to_ok_or_failed_trials(config, trials, seed):
    result = run_trials(PathIntegration(), config, "kinematic", trials, seed)
    assert [row["trial"] for row in result.trials] == list(range(trials))
    for row in result.trials:
        assert row["status"] in ("ok", "failed")
        assert row["seed"] == seed + row["trial"]
        assert (row["status"] == "ok") == (row.get("error", "") == ""), row


# -- the command line ----------------------------------------------------------------------------------

NUMBER_TEXT = st.one_of(st.integers(-2, 3).map(str), st.sampled_from(["", "x", "1.5", "1e3", "99999999999999999999"]))
SET_KEYS = st.sampled_from(["noise", "kappa", "drag", "dtype", "record_every", "nois", "", "outbound_steps"])
SET_VALUES = st.one_of(st.sampled_from(["0.1", "0", "-1", "2", "nan", "inf", "float64", "float16", "", "1e999",
                                        "3", "true"]), TEXT)


@st.composite
def command_lines(draw, folder):
    command = draw(st.sampled_from(["run", "sweep", "compare", "list", "bogus", "run", "sweep"]))
    argv = [command]
    if command in ("run", "sweep", "compare") or draw(st.booleans()):
        argv.append(draw(st.sampled_from(["path-integration", "path-integration", "locomotion", "nope", ""])))
    # Keep valid runs tiny: every run starts from short routes.
    argv += ["--set", "outbound_steps=12", "--set", "inbound_steps=12", "--no-figures"] if command != "compare" else [
        "--set", "outbound_steps=12", "--set", "inbound_steps=12"]
    options = [
        ("--trials", NUMBER_TEXT), ("--seed", NUMBER_TEXT), ("--set", st.builds("{}={}".format, SET_KEYS, SET_VALUES)),
        ("--grid", st.builds("{}={}".format, SET_KEYS, st.lists(SET_VALUES, max_size=2).map(",".join))),
        ("--workers", st.sampled_from(["1", "2", "0", "-1", "x"])), ("--chunk-size", NUMBER_TEXT),
        ("--backend", st.sampled_from(["kinematic", "mujoco", "warp", ""])),
        ("--scheduler", st.sampled_from(["", "localhost", "tcp//x", "tcp://"])),
        ("--config", st.sampled_from(["missing.toml", "good.toml", "bad.toml", "", "."])),
        ("--out", st.sampled_from(["out", "out", "file.txt", "a\x00b", "new/deeper"])),
        ("--backends", st.sampled_from(["kinematic", "", "kinematic,warp"])),
        ("--video", st.none()), ("--no-progress", st.none()), ("--frobnicate", st.none()),
    ]
    for option, values in draw(st.lists(st.sampled_from(options), max_size=4)):
        value = draw(values)
        argv += [option] if value is None else [option, value]
    for i, arg in enumerate(argv):  # paths live in the example's folder
        if i and argv[i - 1] in ("--out", "--config"):
            argv[i] = str(folder / arg) if arg else arg
    return argv


@examples(50)
@given(st.data())
def test_random_command_lines_exit_0_or_2_with_one_line(tmp_path, data):
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    (folder / "good.toml").write_text("noise = 0.05\n")
    (folder / "bad.toml").write_text("noise = [\n")
    (folder / "file.txt").write_text("not a directory\n")
    argv = data.draw(command_lines(folder))
    stdout, stderr = io.StringIO(), io.StringIO()
    # In the example's folder: a run without --out writes its default runs/... there.
    with contextlib.chdir(folder), contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        try:
            code = main(argv)
        except SystemExit as exit:  # argparse: usage errors (2) and --help (0)
            code = exit.code
    errors = stderr.getvalue()
    assert code in (0, 2), (argv, code, errors)
    assert "Traceback" not in errors
    if code == 2:
        lines = errors.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("neuronav: error: "), (argv, errors)
