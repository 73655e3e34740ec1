"""Plastic weights: each agent's own copy of a plastic connection (:class:`PlasticConnection`), and the
compiled circuit's methods that read, set, save and load them (:class:`PlasticWeights`).

Plastic connections (those declared with ``learning=``, :mod:`neuronav.circuits.plasticity`) are the one
exception to shared weights: each agent holds its own copy, kept as (post, pre, batch) — agents last,
like the state — and read and written as (batch, post, pre). The compiled circuit reads them through
one more term of the target's product (:func:`~neuronav.circuits.product.plastic_term`) and changes
them by the rule after every step (:meth:`PlasticConnection.learn`). Fixed connections keep one
matrix for all agents.
"""

from __future__ import annotations

import zipfile
from typing import Any

import numpy as np

from neuronav.errors import CircuitError


class PlasticConnection:
    """A plastic connection of a compiled circuit: its rule, its rows of the state and every agent's weights.

    ``values`` (post, pre, batch) is allocated once and only ever written in place, so the product
    terms bound to it see every change (learning, :meth:`CompiledCircuit.set_weights`, loading).
    """

    def __init__(self, name: str, rule, initial: np.ndarray, source: slice, target: slice, gate: slice,
                 dtype: np.dtype) -> None:
        self.name, self.rule = name, rule
        self.initial = np.asarray(initial, dtype)
        self.source, self.target, self.gate = source, target, gate
        self.values = np.empty((*self.initial.shape, 0), dtype)

    def allocate(self, batch: int) -> None:
        self.values = np.empty((*self.initial.shape, batch), self.initial.dtype)
        self.values[...] = self.initial[:, :, None]

    def by_agent(self) -> np.ndarray:
        """A copy of the weights as (batch, post, pre)."""
        return np.ascontiguousarray(self.values.transpose(2, 0, 1))

    def learn(self, state: np.ndarray) -> None:
        """One step of the rule on this step's rates (source, target, gate) of every agent."""
        self.rule.update(self.values, state[self.source], state[self.target], state[self.gate.start])



class PlasticWeights:
    """The weight methods of :class:`~neuronav.circuits.compiled.CompiledCircuit` (a base class of it).

    They read the compiled circuit's ``circuit``, ``batch``, ``dtype``, ``_plastic`` (its plastic
    connections by name, sorted) and ``_learning`` (the same connections, in learning order).
    """

    circuit: Any
    batch: int
    dtype: np.dtype
    _plastic: dict[str, PlasticConnection]
    _learning: list[PlasticConnection]

    @property
    def plastic(self) -> list[str]:
        """Names (``"SOURCE->TARGET"``) of the plastic connections, sorted."""
        return list(self._plastic)

    def _connection(self, name: str) -> tuple[str, str, dict]:
        """The edge called ``"SOURCE->TARGET"``, or a CircuitError listing the connections."""
        source, _, target = name.partition("->") if isinstance(name, str) else ("", "", "")
        if not self.circuit.graph.has_edge(source, target):
            names = sorted(f"{s}->{t}" for s, t in self.circuit.graph.edges)
            raise CircuitError(f"circuit {self.circuit.name!r} has no connection {name!r} (named 'SOURCE->TARGET'); "
                               f"it has: {', '.join(names) or 'none'}")
        return source, target, self.circuit.graph.edges[source, target]

    def weights(self, name: str) -> np.ndarray:
        """A copy of connection ``name``'s (``"SOURCE->TARGET"``) weights, shape (batch, post, pre).

        A plastic connection gives each agent's own weights; a fixed one its shared matrix, repeated.
        """
        _, _, edge = self._connection(name)
        if name in self._plastic:
            return self._plastic[name].by_agent()
        return np.repeat(np.asarray(edge["weights"], self.dtype)[None], self.batch, axis=0)

    def set_weights(self, name: str, values: Any) -> None:
        """Overwrite plastic connection ``name``'s weights with ``values`` broadcast to (batch, post, pre)."""
        self._connection(name)
        if name not in self._plastic:
            raise CircuitError(f"set_weights({name!r}): the connection is fixed (one matrix shared by every agent); "
                               f"plastic connections: {', '.join(self._plastic) or 'none'}")
        connection = self._plastic[name]
        shape = (self.batch, *connection.initial.shape)
        try:
            values = np.broadcast_to(np.asarray(values, dtype=self.dtype), shape)
        except (TypeError, ValueError):
            raise CircuitError(f"set_weights({name!r}): values must be numbers broadcastable to "
                               f"{shape} (batch, post, pre), got shape {np.shape(values)}") from None
        if not np.isfinite(values).all():
            raise CircuitError(f"set_weights({name!r}): values must be finite")
        connection.rule.check_weights(f"set_weights({name!r})", values)
        connection.values[...] = values.transpose(1, 2, 0)

    def reset_weights(self) -> None:
        """Return every plastic connection to its declared weights (:meth:`reset` keeps what was learnt)."""
        for connection in self._learning:
            connection.values[...] = connection.initial[:, :, None]

    def save_weights(self, path) -> None:
        """Write every plastic connection's weights to an ``.npz`` file, one array per connection."""
        arrays = {name: c.by_agent() for name, c in self._plastic.items()}
        np.savez(path, **arrays)

    def load_weights(self, path) -> None:
        """Read plastic weights written by :meth:`save_weights`.

        The file must hold exactly this circuit's plastic connections; an array saved from one agent
        (first axis 1) is given to every agent, else its batch must match.
        """
        try:
            data = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError, TypeError, zipfile.BadZipFile) as error:
            raise CircuitError(f"load_weights: cannot read {str(path)!r} as an .npz of weights "
                               f"({' '.join(str(error).split())})") from None
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise CircuitError(f"load_weights: {str(path)!r} holds one array (an .npy), not an .npz of weights "
                               f"written by save_weights")
        try:
            with data:
                arrays = {key: data[key] for key in data.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
            raise CircuitError(f"load_weights: cannot read {str(path)!r} as an .npz of weights "
                               f"({' '.join(str(error).split())})") from None
        if set(arrays) != set(self._plastic):
            raise CircuitError(f"load_weights: {str(path)!r} holds {', '.join(sorted(arrays)) or 'nothing'}; circuit "
                               f"{self.circuit.name!r} has plastic connections {', '.join(self._plastic) or 'none'}")
        for name, values in arrays.items():
            expected = (self.batch, *self._plastic[name].initial.shape)
            if values.shape not in (expected, (1, *expected[1:])):
                raise CircuitError(f"load_weights: {name!r} in {str(path)!r} has shape {values.shape}, expected "
                                   f"{expected} or {(1, *expected[1:])}")
        for name, values in arrays.items():
            self.set_weights(name, values)
