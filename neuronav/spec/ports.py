"""Sensor and motor ports: the named, shaped, unit-carrying interface between brains and bodies.

A brain declares the sensors it reads and the motors it writes; a body or backend declares the
sensors it provides and the motor commands it accepts. :func:`bind` checks the two sides agree
before the first step and raises one :class:`~neuronav.errors.PortError` naming both sides.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from neuronav.errors import PortError


@dataclass(frozen=True)
class _PortSpec:
    """What a sensor and a motor port share, checked once when one is made: a non-empty name, a shape
    of positive ints, units and a (low, high) range with low <= high (or None)."""

    name: str
    shape: tuple[int, ...]
    units: str = ""
    range: tuple[float, float] | None = None

    _KIND = "port"  # the word naming the port in an error: "sensor" or "motor" (a class constant, no field)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise PortError(f"port name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.shape, tuple) or not all(isinstance(n, int) and n > 0 for n in self.shape):
            raise PortError(f"port {self.name!r}: shape must be a tuple of positive ints, got {self.shape!r}")
        if self.range is not None and not self.range[0] <= self.range[1]:
            raise PortError(f"{self._KIND} port {self.name!r}: range {self.range} has low > high")


@dataclass(frozen=True)
class SensorSpec(_PortSpec):
    """A sensor port.

    Parameters
    ----------
    name : str
        Port name, e.g. ``"heading"``.
    shape : tuple of int
        Shape of one agent's value (the batch dimension is not included).
    units : str
        Physical units, e.g. ``"rad"`` or ``"m/s"``; ``""`` for dimensionless.
    range : tuple of float or None
        Allowed (low, high) values, checked on every step by a compiled circuit that reads the
        port (NaN is outside every range), or None when any finite or infinite value is accepted.
    """

    _KIND = "sensor"


@dataclass(frozen=True)
class MotorSpec(_PortSpec):
    """A motor port.

    Parameters
    ----------
    name : str
        Port name, e.g. ``"turn"``.
    shape : tuple of int
        Shape of one agent's command (no batch dimension).
    units : str
        Physical units of the command.
    range : tuple of float or None
        Allowed (low, high) range of the command, or None when unbounded.
    """

    _KIND = "motor"


def bind(
    required: Iterable[SensorSpec | MotorSpec],
    provided: Iterable[SensorSpec | MotorSpec],
    *,
    consumer: str,
    provider: str,
) -> None:
    """Check that every port ``consumer`` needs is provided by ``provider`` with the same shape and units.

    Raises
    ------
    PortError
        Naming the port, both sides and what each side declares.
    """
    offered = {spec.name: spec for spec in provided}
    for need in required:
        have = offered.get(need.name)
        if have is None:
            raise PortError(
                f"{consumer} needs port {need.name!r} {need.shape} [{need.units}] but {provider} "
                f"provides only: {', '.join(sorted(offered)) or 'nothing'}"
            )
        if tuple(have.shape) != tuple(need.shape) or have.units != need.units:
            raise PortError(
                f"port {need.name!r}: {consumer} expects shape {need.shape} [{need.units}] but "
                f"{provider} provides shape {have.shape} [{have.units}]"
            )
