"""The net input ``W·x`` of one population, for every agent, summed in a fixed order (:class:`Product`).

A compiled circuit's state is one array of shape (total_cells, agents); each non-input population
reads the span of that array its sources occupy through one :class:`Product`, built once from its
connection blocks and bound to the state arrays at every reset. The order of the additions never
depends on the number of agents, so an agent's numbers are the same bit for bit whatever its
batch-mates. A plastic connection (each agent its own weights) is one more term of the product
(:func:`plastic_term`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

# A plastic term's presynaptic sum runs in this many interleaved lanes (see plastic_term).
PLASTIC_LANES = 32


def is_dense(weights: np.ndarray) -> bool:
    """Most of the row's weights non-zero: summed by broadcasting every source cell (see Product)."""
    weights = np.asarray(weights)
    return weights.shape[1] <= 2 * int((weights != 0).sum(axis=1).max(initial=0))


def _overlaps(a: slice, b: slice) -> bool:
    return a.start < b.stop and b.start < a.stop


class Product:
    """The net input ``W·x`` of one population, for every agent, summed in a fixed order.

    A BLAS matrix product rounds each agent's column differently depending on the batch width
    (gemv for one agent, gemm kernels and blockings for many), so instead each cell's terms
    ``w_k * x_k`` are formed element-wise into a buffer of shape (terms, cells, agents) and summed
    over the first axis — always left to right, in the order of the source cells. Every agent's
    numbers are then independent of the batch width and of its batch-mates, bit for bit.

    A connection block becomes one of four terms:

    - ``diagonal`` (one-to-one onto a block the size of the target): one product, one term;
    - ``dense`` (most weights non-zero): one term per source cell, by broadcasting;
    - ``gather`` (few non-zeros per row): the source cells each row reads are gathered
      (``np.take``), one term per non-zero of the fullest row (shorter rows padded with weight 0);
    - ``sparse`` (``sparse=True``): a scipy CSR product, which sums each row's non-zeros in column
      order from 0 whatever the number of agents.
    """

    def __init__(self, reads: list[tuple[bool, int, np.ndarray]], size: int, dtype: np.dtype,
                 sparse: bool, bias: float = 0.0, plastic: Sequence[tuple] = ()) -> None:
        # reads: (from_snapshot, first state row, weights (size, span)); plastic: (from_snapshot,
        # first state row, PlasticConnection, scale), one term each (see plastic_term).
        self.size = size
        self.dtype = dtype
        self.terms: list[tuple] = []  # (kind, from_snapshot, rows, weights, first slot, slots)
        slot = 0
        for from_snapshot, lo, weights in reads:
            span = weights.shape[1]
            nonzero = weights != 0
            per_row = int(nonzero.sum(axis=1).max())
            if per_row == 0:
                continue  # all weights zero: nothing to add
            if span == size and not np.any(nonzero & ~np.eye(size, dtype=bool)):
                term = ("diagonal", np.diag(weights).astype(dtype)[:, None], 1)
            elif sparse:
                import scipy.sparse  # only sparse circuits pay for the import (0.1 s at start-up)

                term = ("sparse", scipy.sparse.csr_matrix(weights.astype(dtype)), 1)
            elif is_dense(weights):
                term = ("dense", np.ascontiguousarray(weights.T.astype(dtype))[:, :, None], span)
            else:
                index = np.zeros((per_row, size), np.intp)
                values = np.zeros((per_row, size), dtype)
                for row in range(size):
                    columns = np.flatnonzero(nonzero[row])
                    index[:columns.size, row] = lo + columns
                    index[columns.size:, row] = lo + (columns[0] if columns.size else 0)
                    values[:columns.size, row] = weights[row, columns]
                term = ("gather", (index, values[:, :, None]), per_row)
            kind, data, slots = term
            self.terms.append((kind, from_snapshot, slice(lo, lo + span), data, slot, slots))
            slot += slots
        for from_snapshot, lo, connection, scale in plastic:
            rows = slice(lo, lo + connection.initial.shape[1])
            self.terms.append(("plastic", from_snapshot, rows, (connection, float(scale)), slot, 1))
            slot += 1
        # The bias is the last term when the terms are summed anyway (or alone): ((t0 + t1) + ...) + b,
        # the same numbers as adding it afterwards, one call fewer.
        self.bias = float(bias)
        self.includes_bias = bool(self.bias) and slot != 1
        if self.includes_bias and slot:
            self.terms.append(("constant", False, slice(0, 0), self.bias, slot, 1))
            slot += 1
        self.slots = slot
        # Summing three or more terms over axis 0 is a left-to-right loop only while each term has
        # two or more elements (numpy sums a lone vector pairwise): pad a one-cell population to two.
        self.padded = max(size, 2) if slot >= 3 else size

    def buffer_bytes(self, batch: int, itemsize: int) -> int:
        return self.slots * self.padded * batch * itemsize if self.slots > 1 else 0

    def bind(self, state: np.ndarray, snapshot: np.ndarray | None, out: np.ndarray,
             out_rows: slice | None) -> None:
        """Prepare the step's calls against the state arrays; the sum lands in ``out`` (size, agents),
        which is the state's rows ``out_rows`` when given (None: a separate array)."""
        batch = state.shape[1]
        size = self.size
        # One term is computed straight into ``out`` unless it reads out's own rows.
        direct = self.slots == 1 and not (out_rows is not None and any(
            not from_snapshot and _overlaps(rows, out_rows) for _, from_snapshot, rows, *_ in self.terms))
        if direct:
            buffer = out[None]
        else:
            buffer = np.zeros((self.slots, self.padded, batch), state.dtype)
        calls = []
        for kind, from_snapshot, rows, data, first, slots in self.terms:
            source = snapshot if from_snapshot else state
            target = buffer[first:first + slots, :size]
            if kind == "diagonal":
                calls.append(functools.partial(np.multiply, data, source[rows], out=target[0]))
            elif kind == "dense":
                calls.append(functools.partial(np.multiply, data, source[rows][:, None, :], out=target))
            elif kind == "constant":
                target[...] = data  # filled once: never written again
            elif kind == "plastic":
                connection, scale = data
                post, pre, _ = connection.values.shape
                scratch = np.zeros((post, -(-pre // PLASTIC_LANES), PLASTIC_LANES, batch), state.dtype)
                lanes = np.zeros((post, PLASTIC_LANES, batch), state.dtype)
                lanes_by_agent = np.zeros((post, batch, PLASTIC_LANES), state.dtype)
                calls.append(functools.partial(plastic_term, connection.values, source[rows], target[0], scratch,
                                               lanes, lanes_by_agent, scale))
            elif kind == "gather":
                index, values = data
                # mode "clip" (the indices are always in range): with "raise" numpy buffers ``out``.
                calls.append(functools.partial(np.take, source, index, 0, target, "clip"))
                calls.append(functools.partial(np.multiply, target, values, out=target))
            else:
                calls.append(functools.partial(sparse_term, data, source[rows], target[0]))
        self.calls = calls
        if not self.terms:
            calls.append(functools.partial(out.fill, self.bias))
        elif self.slots == 2:
            calls.append(functools.partial(np.add, buffer[0, :size], buffer[1, :size], out=out))
        elif self.slots >= 3 and self.padded == size:
            calls.append(functools.partial(np.add.reduce, buffer, 0, None, out))
        elif self.slots >= 3:
            total = np.zeros((self.padded, batch), state.dtype)
            calls.append(functools.partial(np.add.reduce, buffer, 0, None, total))
            calls.append(functools.partial(np.copyto, out, total[:size]))
        elif not direct:
            calls.append(functools.partial(np.copyto, out, buffer[0, :size]))

    def __call__(self) -> None:
        for call in self.calls:
            call()


def sparse_term(matrix, source: np.ndarray, out: np.ndarray) -> None:
    """A scipy CSR matrix times the rates (cells, agents), into ``out``."""
    np.copyto(out, matrix @ source)


def plastic_term(values: np.ndarray, source: np.ndarray, out: np.ndarray, scratch: np.ndarray,
                 lanes: np.ndarray, lanes_by_agent: np.ndarray, scale: float) -> None:
    """Each agent's own weights times its rates: ``out[i, b] = scale * Σ_j values[i, j, b] source[j, b]``.

    The same order of additions for every agent at every batch width, in two stages, each a numpy
    reduction whose order does not depend on the number of agents (never BLAS):

    1. the products, formed element-wise into ``scratch`` (post, m, L, agents) (the presynaptic
       cells padded with zeros to m x L, L = :data:`PLASTIC_LANES`), are summed over m, the outer
       loop: lane l holds ``((p_l + p_{L+l}) + p_{2L+l}) + ...``;
    2. each agent's L lane sums, laid out contiguous (post, agents, L), are summed as one row.

    Both stages vectorise over lanes (and agents), so one agent costs a few microseconds for
    thousands of presynaptic cells.
    """
    post, pre, _ = values.shape
    np.multiply(values, source[None], out=scratch.reshape(post, -1, values.shape[2])[:, :pre])
    np.add.reduce(scratch, axis=1, out=lanes)  # (post, L, agents)
    np.copyto(lanes_by_agent, lanes.transpose(0, 2, 1))
    np.add.reduce(lanes_by_agent, axis=2, out=out)  # (post, agents)
    if scale != 1.0:
        out *= scale
