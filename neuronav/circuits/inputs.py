"""What a compiled circuit's ``step`` accepts: one array per sensor port, named, shaped and typed as the
port (always checked, :meth:`InputCheck.ports`), finite and inside the port's range (unless compiled
with ``check_inputs=False``, :meth:`InputCheck.values`). Every failure is a :class:`PortError` naming
the port.
"""

from __future__ import annotations

import math

import numpy as np

from neuronav.errors import PortError

_add_reduce = np.add.reduce


class InputCheck:
    """The checks of one compiled circuit's inputs.

    Parameters
    ----------
    circuit : Circuit
        Named in the messages.
    sensors : list of SensorSpec
        The circuit's sensor ports.
    batch : int
        The first axis every input must have.
    """

    def __init__(self, circuit, sensors: list, batch: int) -> None:
        self.circuit = circuit
        self.sensors = sensors
        self.shapes = {s.name: (batch, *s.shape) for s in self.sensors}
        # Every port is checked for finite values, and for its range where one is declared.
        self.ranges = [(s.name, *(s.range or (-np.inf, np.inf))) for s in self.sensors]

    def ports(self, inputs: dict) -> None:
        """Names, shapes and dtypes of the inputs (always checked)."""
        if not isinstance(inputs, dict):
            raise PortError(f"circuit {self.circuit.name!r}: inputs must be a dict of port -> array, "
                            f"got {type(inputs).__name__}")
        shapes = self.shapes
        for port, shape in shapes.items():
            value = inputs.get(port)
            if value is None or getattr(value, "shape", None) != shape:
                self._raise_misshaped(inputs)
            if value.dtype.kind not in "fiu":
                raise PortError(f"circuit {self.circuit.name!r}: port {port!r} needs numbers, got an array of "
                                f"{value.dtype}")
        if len(inputs) != len(shapes):
            unknown = sorted(map(str, set(inputs) - set(shapes)))
            raise PortError(f"circuit {self.circuit.name!r} has no input port {', '.join(map(repr, unknown))}; "
                            f"its ports: {', '.join(shapes) or 'none'}")

    def values(self, inputs: dict) -> None:
        """Every input finite, and inside its port's range where one is declared."""
        for port, low, high in self.ranges:
            value = inputs[port]
            if value.dtype.kind != "f":
                lowest, highest = value.min(), value.max()
                if lowest >= low and highest <= high:
                    continue
            elif low == -np.inf and high == np.inf:
                # The sum is finite when every value is (the second test: a sum of finite values overflowed).
                if math.isfinite(_add_reduce(value, None)) or np.isfinite(value).all():
                    continue
            else:
                lowest, highest = value.min(), value.max()  # NaN when any value is NaN
                if lowest >= low and highest <= high and np.isfinite(lowest) and np.isfinite(highest):
                    continue
            bad = float(value[~(np.isfinite(value) & (value >= low) & (value <= high))].ravel()[0])
            if not np.isfinite(bad):
                raise PortError(f"circuit {self.circuit.name!r}: port {port!r} needs finite values, got {bad!r} "
                                "(compile with check_inputs=False to skip this check)")
            raise PortError(
                f"circuit {self.circuit.name!r}: port {port!r} accepts values in [{low:g}, {high:g}], got {bad:g}"
            )

    def _raise_misshaped(self, inputs: dict) -> None:
        """Raise the PortError naming the first port missing or misshaped."""
        if not isinstance(inputs, dict):
            raise PortError(f"circuit {self.circuit.name!r}: inputs must be a dict of port -> array")
        for spec in self.sensors:
            expected = self.shapes[spec.name]
            if spec.name not in inputs:
                raise PortError(
                    f"circuit {self.circuit.name!r} reads port {spec.name!r} {expected} but the inputs "
                    f"have only: {', '.join(sorted(inputs)) or 'nothing'}"
                )
            shape = getattr(inputs[spec.name], "shape", None)
            if shape != expected:
                raise PortError(
                    f"circuit {self.circuit.name!r}: port {spec.name!r} expects an array of shape "
                    f"{expected} (batch, *port_shape) [{spec.units}], got {shape}"
                )

