"""Sensor and motor ports check themselves when made, with one rule for both kinds."""

import dataclasses

import pytest

from neuronav import MotorSpec, PortError, SensorSpec

KINDS = [(SensorSpec, "sensor"), (MotorSpec, "motor")]


@pytest.mark.parametrize(("spec", "word"), KINDS)
@pytest.mark.parametrize(("name", "shape", "message"), [
    ("", (1,), "port name must be a non-empty string, got ''"),
    (None, (1,), "port name must be a non-empty string, got None"),
    ("heading", (0,), "port 'heading': shape must be a tuple of positive ints, got (0,)"),
    ("heading", [1], "port 'heading': shape must be a tuple of positive ints, got [1]"),
    ("heading", (2.0,), "port 'heading': shape must be a tuple of positive ints, got (2.0,)"),
])
def test_a_bad_name_or_shape_is_refused(spec, word, name, shape, message):
    with pytest.raises(PortError) as error:
        spec(name, shape)
    assert str(error.value) == message


@pytest.mark.parametrize(("spec", "word"), KINDS)
def test_a_reversed_range_names_the_kind_of_port(spec, word):
    with pytest.raises(PortError, match=rf"^{word} port 'turn': range \(1\.0, -1\.0\) has low > high$"):
        spec("turn", (1,), "", (1.0, -1.0))
    assert spec("turn", (1,), "", (-1.0, 1.0)).range == (-1.0, 1.0)
    assert spec("turn", (1,), "", (0.5, 0.5)).range == (0.5, 0.5)


@pytest.mark.parametrize(("spec", "word"), KINDS)
def test_a_port_is_a_frozen_value(spec, word):
    port = spec("velocity", (2,), "m/s")
    assert [f.name for f in dataclasses.fields(port)] == ["name", "shape", "units", "range"]
    assert port == spec("velocity", (2,), "m/s") and hash(port) == hash(spec("velocity", (2,), "m/s"))
    assert repr(port) == f"{spec.__name__}(name='velocity', shape=(2,), units='m/s', range=None)"
    with pytest.raises(dataclasses.FrozenInstanceError):
        port.units = "deg"


def test_a_sensor_is_never_equal_to_a_motor():
    assert SensorSpec("turn", (1,), "") != MotorSpec("turn", (1,), "")
