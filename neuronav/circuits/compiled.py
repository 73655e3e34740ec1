"""CompiledCircuit: a circuit built into block matrices and index slices, stepped for a batch.

All N agents advance together: every population's rates live in one state array of shape
(total_cells, N) — cells by agents, so that element-wise work runs over long contiguous rows —
and each population reads the span of that array its sources occupy through one
sum of products formed element-wise and summed in a fixed order (:class:`_Product`), so that an
agent's numbers never depend on how many agents share the batch. The public methods speak
(N, size), the batch first. Populations update in a
topological order of the undelayed connections (ties broken by name, so the order — and the
numbers — never depend on the order the populations were declared in). A delayed connection reads
its source as it was at the start of the step.

Noise comes from one seeded :class:`numpy.random.Generator` (SFC64) per agent, drawn ahead in blocks, so
agent i of a batch sees exactly the numbers a single run with that agent's seed sees.

Plastic connections (those declared with ``learning=``, :mod:`neuronav.circuits.plasticity`) are the one
exception to shared weights: each agent holds its own copy (kept as (post, pre, batch), agents last
like the state; read and written as (batch, post, pre)), read by one more
term of the target's product (:func:`_plastic_term`) and changed by the rule after every step
(:class:`_PlasticConnection`). Fixed connections keep one matrix for all agents, and a circuit
without plastic connections steps exactly as before.
"""

from __future__ import annotations

import functools
import math
import os
import zipfile
from collections.abc import Callable, Sequence
from typing import Any

import networkx as nx
import numpy as np

from neuronav.circuits.activations import ACTIVATIONS, identity, logistic, logistic_of_negated
from neuronav.circuits.encoders import get_encoder
from neuronav.errors import CircuitError, PortError

# Above this many cells a circuit's weights are stored sparse when most of them are zero.
SPARSE_MIN_CELLS = 2000
SPARSE_MAX_DENSITY = 0.1
# Bytes of pre-drawn noise held per circuit at most.
NOISE_BUFFER_BYTES = 1 << 25
NOISE_METHODS = ("gaussian", "table")
# compile() refuses a batch whose state would need more than the machine's free memory, or this
# many bytes where the free memory cannot be read.
DEFAULT_MEMORY_CAP_BYTES = 64 * 2**30
# About what one agent's noise generator (an SFC64 Generator object) costs.
RNG_BYTES = 1024


def _clip_ufunc():
    """numpy's ``clip`` ufunc itself: ``ndarray.clip`` adds about a microsecond of Python per call,
    which shows at small batches. Falls back to the method where the ufunc is not exposed."""
    for module in ("_core", "core"):
        ufunc = getattr(getattr(np, module, None), "umath", None)
        ufunc = getattr(ufunc, "clip", None)
        if isinstance(ufunc, np.ufunc):
            return ufunc
    return lambda x, low, high, out: x.clip(low, high, out=out)


_clip = _clip_ufunc()
_add_reduce = np.add.reduce
# Gaussian noise below this many agents is re-laid per block as (step, column, agent): row slices
# then cost the least per step; above it the (word, agent, sample) layout avoids that copy. Table
# noise is always gathered straight into (step, column, agent).
SMALL_BATCH = 32
# The "table" noise: N(0, 1) quantiles at this many equiprobable levels, indexed by 16 random bits.
TABLE_LEVELS = 1 << 16
# Samples gathered from the table per call (see _draw_noise).
TABLE_GATHER_CHUNK = 1 << 16


def normal_quantile_table(dtype: Any = np.float64) -> np.ndarray:
    """``Φ⁻¹((k + 0.5) / 65536)`` for k = 0..65535: a 16-bit inverse-CDF table of N(0, 1).

    Sampling it with uniform 16-bit indices gives a distribution within 1/65536 (Kolmogorov
    distance) of the standard normal, with tails cut at ±4.33 σ.
    """
    from scipy.special import ndtri

    return ndtri((np.arange(TABLE_LEVELS) + 0.5) / TABLE_LEVELS).astype(dtype)


def _is_dense(weights: np.ndarray) -> bool:
    """Most of the row's weights non-zero: summed by broadcasting every source cell (see _Product)."""
    weights = np.asarray(weights)
    return weights.shape[1] <= 2 * int((weights != 0).sum(axis=1).max(initial=0))


def _overlaps(a: slice, b: slice) -> bool:
    return a.start < b.stop and b.start < a.stop


def _available_memory_bytes() -> int:
    """Memory available to a new allocation: Linux's MemAvailable (free plus reclaimable cache), else
    the free physical pages, else :data:`DEFAULT_MEMORY_CAP_BYTES` where neither can be read."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return DEFAULT_MEMORY_CAP_BYTES


# -- the net input: W·x summed in a fixed order per cell ------------------------------------------
class _Product:
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
        # first state row, _PlasticConnection, scale), one term each (see _plastic_term).
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
            elif _is_dense(weights):
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
                calls.append(functools.partial(_plastic_term, connection.values, source[rows], target[0], scratch,
                                               lanes, lanes_by_agent, scale))
            elif kind == "gather":
                index, values = data
                # mode "clip" (the indices are always in range): with "raise" numpy buffers ``out``.
                calls.append(functools.partial(np.take, source, index, 0, target, "clip"))
                calls.append(functools.partial(np.multiply, target, values, out=target))
            else:
                calls.append(functools.partial(_sparse_term, data, source[rows], target[0]))
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


def _sparse_term(matrix, source: np.ndarray, out: np.ndarray) -> None:
    np.copyto(out, matrix @ source)


# A plastic term's presynaptic sum runs in this many interleaved lanes (see _plastic_term).
PLASTIC_LANES = 32


def _plastic_term(values: np.ndarray, source: np.ndarray, out: np.ndarray, scratch: np.ndarray,
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


class _PlasticConnection:
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


# -- one small step per population kind (nengo's builder style) -----------------------------------
class _PopulationStep:
    """What every non-input population does each step: net input, bias, activation, noise, clip.

    Subclasses differ in where the net input goes (:class:`_RateStep`, :class:`_LeakyStep`,
    :class:`_IntegratorStep`).
    """

    kind = "rate"

    def __init__(self, name: str, cells: slice, product: _Product, bias: float, activation: Callable,
                 params: dict, noise_columns: tuple[int, int, float] | None, clip: tuple[float, float] | None,
                 ) -> None:
        self.name, self.cells, self.product = name, cells, product
        self.bias, self.activation, self.params = bias, activation, params
        self.noise_columns, self.clip = noise_columns, clip

    def bind(self, compiled: CompiledCircuit) -> None:
        """Point the step's calls at the compiled circuit's (new) state arrays."""
        self.rates_view = compiled._state[self.cells]
        self.add_noise = compiled._add_noise
        # Pre-scaled noise laid out (column, agent): this population adds a plain row slice.
        self.noise_rows = None
        if self.noise_columns is not None and compiled._noise_by_cell and compiled._noise_scaled:
            start, size, _ = self.noise_columns
            self.noise_rows = slice(start, start + size)
        self.net = self._net_target(compiled)
        self.product.bind(compiled._state, compiled._snapshot, self.net,
                          self.cells if self.net is self.rates_view else None)
        # The net input's calls, then the bias unless the product already added it.
        self.calls = list(self.product.calls)
        if self.bias and not self.product.includes_bias:
            self.calls.append(functools.partial(np.add, self.net, self.bias, out=self.net))

    def _net_target(self, compiled: CompiledCircuit) -> np.ndarray:
        return self.rates_view  # rate and output populations are computed in place in the state

    def finish(self, rates: np.ndarray, noise: np.ndarray | None) -> None:
        """Noise and clip, in place."""
        if self.noise_rows is not None:
            rates += noise[self.noise_rows]
        elif self.noise_columns is not None:
            self.add_noise(rates, noise, self.noise_columns)
        if self.clip is not None:
            _clip(rates, *self.clip, out=rates)

    def __call__(self, noise: np.ndarray | None) -> None:
        for call in self.calls:  # net input, bias and activation, all in the population's state rows
            call()
        if self.noise_rows is not None:
            self.rates_view += noise[self.noise_rows]
        elif self.noise_columns is not None:
            self.add_noise(self.rates_view, noise, self.noise_columns)
        if self.clip is not None:
            _clip(self.rates_view, *self.clip, out=self.rates_view)


class _RateStep(_PopulationStep):
    """``rate`` and ``output``: r = f(W x + b), written straight into the population's state rows."""

    def bind(self, compiled: CompiledCircuit) -> None:
        super().bind(compiled)
        if self.activation is not identity:
            self.calls.append(functools.partial(self.activation, self.net, **self.params))  # in place


def check_leaky_step(name: str, tau_s: float, dt_s: float | None) -> None:
    """Compile-time check of a leaky population's Euler step, one cell at a time: ``0 < dt_s <= tau_s / 2``.

    For one cell, input held fixed, Euler multiplies the distance to the target by ``1 - dt/tau``; with
    self-inhibition of weight ``-g`` (at activation slope 1) by ``1 - (1 + g) dt/tau``. At ``g = 1`` (a
    self-inhibition as strong as the leak, as Sun et al.'s I cell) the step overshoots and alternates
    exactly when ``dt > tau/2`` and diverges when ``dt > tau``. It does not check the coupling between
    cells: a recurrent loop can need a shorter step (Sun et al.'s E-I loop by plain Euler swings from
    about 70 µs with tau_I = 250 µs; see ``brains/ring.py``).
    """
    if dt_s is None or not dt_s > 0:
        raise CircuitError(f"population {name!r} is leaky: compile with dt_s > 0 (got {dt_s!r})")
    if dt_s > 0.5 * tau_s:
        raise CircuitError(
            f"population {name!r}: dt_s = {dt_s:g} s is longer than half its tau_s = {tau_s:g} s; "
            "the Euler step of a cell with self-inhibition as strong as its leak would overshoot and "
            "alternate (and diverge past tau_s) — use dt_s <= tau_s / 2 (this checks each cell alone, "
            "not the coupling between cells)"
        )


def leaky_euler_update(previous: np.ndarray, target: np.ndarray, leak_fraction: float) -> np.ndarray:
    """One Euler step of ``tau dr/dt = -r + f(W x + b)``: ``r + (dt / tau) (f - r)``."""
    return previous + leak_fraction * (target - previous)


class _SeparateNetStep(_PopulationStep):
    """A population whose net input goes into a buffer of its own (its state is updated from it)."""

    def _net_target(self, compiled: CompiledCircuit) -> np.ndarray:
        self.net = np.zeros((self.cells.stop - self.cells.start, compiled.batch), compiled.dtype)
        return self.net


class _LeakyStep(_SeparateNetStep):
    """``leaky``: tau dr/dt = -r + f(W x + b), one Euler step (:func:`leaky_euler_update`)."""

    kind = "leaky"

    def __init__(self, *args: Any, leak_fraction: float) -> None:
        super().__init__(*args)
        self.leak_fraction = leak_fraction

    def __call__(self, noise: np.ndarray | None) -> None:
        for call in self.calls:
            call()
        net = self.net
        rates = leaky_euler_update(self.rates_view, self.activation(net, **self.params), self.leak_fraction)
        self.finish(rates, noise)
        self.rates_view[...] = rates


class _IntegratorStep(_SeparateNetStep):
    """``integrator``: m += gain * clip(W x + b) - leak, m clipped; rates f(m)."""

    kind = "integrator"

    def __init__(self, *args: Any, gain: float, leak: float, drive_clip, memory_clip) -> None:
        super().__init__(*args)
        self.gain, self.leak, self.drive_clip, self.memory_clip = gain, leak, drive_clip, memory_clip

    def bind(self, compiled: CompiledCircuit) -> None:
        self.memory = compiled._memory[self.name]
        super().bind(compiled)

    def __call__(self, noise: np.ndarray | None) -> None:
        for call in self.calls:
            call()
        net, memory = self.net, self.memory
        if self.drive_clip is not None:
            _clip(net, *self.drive_clip, out=net)
        net *= self.gain
        memory += net
        if self.leak:
            memory -= self.leak
        if self.memory_clip is not None:
            _clip(memory, *self.memory_clip, out=memory)
        self._activate()
        self.finish(self.rates_view, noise)

    def _activate(self) -> None:
        """f(m) into the population's state rows."""
        rates = self.rates_view
        if self.activation is logistic:  # logistic's own steps, its first product written into the rates
            np.multiply(self.memory, -self.params.get("slope", 1.0), out=rates)
            rates += self.params.get("bias", 0.0)
            logistic_of_negated(rates)
        else:
            np.copyto(rates, self.memory)
            self.activation(rates, **self.params)

    def rates_of_memory(self) -> None:
        """The rates f(m), clipped, into the population's state rows (no noise): at reset and set_memory."""
        self._activate()
        if self.clip is not None:
            _clip(self.rates_view, *self.clip, out=self.rates_view)


class CompiledCircuit:
    """A circuit ready to run: ``step(inputs) -> outputs`` for a batch of agents.

    Parameters
    ----------
    circuit : Circuit
    batch : int
        Number of agents N stepped together. The state needs about :meth:`bytes_per_agent` bytes
        per agent; a batch that would need more than the machine's free memory (or
        :data:`DEFAULT_MEMORY_CAP_BYTES` where that is unknown) is refused before anything is allocated.
    seed : int or None
        Agent i's noise generator is seeded with ``seed + i`` (unless ``seeds`` is given).
    seeds : sequence of int, optional
        One seed per agent; overrides ``seed``.
    dtype : numpy dtype
        float64 (default) or float32.
    dt_s : float, optional
        Step length in seconds; required when the circuit has ``leaky`` populations.
    sparse : bool, optional
        Store weights as scipy.sparse matrices. Default: only for large, mostly empty circuits.
    noise_method : {"gaussian", "table"}
        ``gaussian``: numpy's exact normal sampler. ``table``: 16 random bits per sample index a
        table of normal quantiles (:func:`normal_quantile_table`) — about 3x cheaper, within
        1/65536 of N(0, 1) in distribution, tails cut at ±4.33 σ.
    check_inputs : bool
        Check every step that each input is finite and inside its port's declared range (default).
        ``False`` skips these value checks (names, shapes and dtypes are still checked) for speed:
        a NaN or infinite input then propagates into the state and stays there.

    Reproducibility: agent i's numbers depend only on the circuit, dtype, noise method, its own
    seed and its own inputs — not on the batch width or its batch-mates — bit for bit on one
    machine and build of numpy/scipy (see :class:`_Product`).
    """

    def __init__(
        self, circuit, batch: int = 1, seed: int | None = 0, seeds: Sequence[int] | None = None,
        dtype: Any = np.float64, dt_s: float | None = None, sparse: bool | None = None,
        noise_method: str = "gaussian", check_inputs: bool = True,
    ) -> None:
        self._check_arguments(circuit, batch, seed, seeds, dtype, dt_s, noise_method, check_inputs)
        self.noise_method = noise_method
        self.check_inputs = bool(check_inputs)
        self.circuit = circuit
        self.batch = int(batch)
        self.dtype = np.dtype(dtype)
        self.dt_s = dt_s
        self.sensors = circuit.sensors
        self.motors = circuit.motors
        self._sensor_shapes = {s.name: (self.batch, *s.shape) for s in self.sensors}
        # Every port is checked for finite values, and for its range where one is declared.
        self._sensor_ranges = [(s.name, *(s.range or (-np.inf, np.inf))) for s in self.sensors]

        self.order = _update_order(circuit)
        self._lay_out_cells()
        self.sparse = self._choose_sparse(sparse)
        self._lay_out_noise()
        self._inputs: list[tuple] = []
        self._updates: list[_PopulationStep] = []
        self._needs_snapshot = False
        self._plastic: dict[str, _PlasticConnection] = {}
        position = {name: i for i, name in enumerate(self.order)}
        for name in self.order:
            pop = circuit.population(name)
            if pop.kind == "input":
                self._inputs.append(self._build_input(pop))
            else:
                self._updates.append(self._build_population(pop, position))
        self._outputs = [(p.ports[0].name, self.cells[p.name]) for p in
                         (circuit.population(n) for n in self.order) if p.kind == "output"]
        self._memory_names = [u.name for u in self._updates if u.kind == "integrator"]
        self._plastic = dict(sorted(self._plastic.items()))  # learning order: by name
        self._learning = list(self._plastic.values())
        self._check_size()
        for connection in self._learning:
            connection.allocate(self.batch)

        if seeds is None:
            if seed is None:
                seed = int(np.random.SeedSequence().entropy % (2**31))
            seeds = [int(seed) + i for i in range(self.batch)]
        self.seeds = [int(s) for s in seeds]
        self.reset()

    # -- building -------------------------------------------------------------------------------
    @staticmethod
    def _check_arguments(circuit, batch, seed, seeds, dtype, dt_s, noise_method, check_inputs) -> None:
        if noise_method not in NOISE_METHODS:
            raise CircuitError(f"noise_method {noise_method!r} is unknown; allowed: {', '.join(NOISE_METHODS)}")
        if not isinstance(batch, (int, np.integer)) or isinstance(batch, bool) or batch < 1:
            raise CircuitError(f"batch must be a positive int, got {batch!r}")
        if not isinstance(check_inputs, (bool, np.bool_)):
            raise CircuitError(f"check_inputs must be True or False, got {check_inputs!r}")
        try:
            dtype = np.dtype(dtype)
        except (TypeError, ValueError):
            raise CircuitError(f"dtype must be float64 or float32, got {dtype!r}") from None
        if dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
            raise CircuitError(f"dtype must be float64 or float32, got {dtype}")
        if seeds is not None:
            try:
                seeds = list(seeds)
            except TypeError:
                raise CircuitError(f"seeds must be a sequence of non-negative ints, got {seeds!r}") from None
            if len(seeds) != batch:
                raise CircuitError(f"{len(seeds)} seeds given for a batch of {batch}")
        for value in [seed] if seeds is None else seeds:
            if value is not None and (not isinstance(value, (int, np.integer)) or isinstance(value, bool)
                                      or value < 0):
                raise CircuitError(f"seeds must be non-negative ints, got {value!r}")
        if dt_s is not None and (not isinstance(dt_s, (int, float, np.number)) or not np.isfinite(dt_s)):
            raise CircuitError(f"dt_s must be a finite number of seconds, got {dt_s!r}")
        if circuit.graph.number_of_nodes() == 0:
            raise CircuitError(f"circuit {circuit.name!r} has no populations")

    def _lay_out_cells(self) -> None:
        """Each population's rows of the state, in update order."""
        self.cells: dict[str, slice] = {}
        start = 0
        for name in self.order:
            size = self.circuit.population(name).size
            self.cells[name] = slice(start, start + size)
            start += size
        self.total_cells = start

    def _choose_sparse(self, sparse: bool | None) -> bool:
        if sparse is None:
            if self.total_cells < SPARSE_MIN_CELLS:
                return False
            edges = self.circuit.graph.edges(data=True)
            nonzero = sum(int(np.count_nonzero(data["weights"])) for _, _, data in edges)
            return nonzero / self.total_cells ** 2 <= SPARSE_MAX_DENSITY
        return bool(sparse)

    def _lay_out_noise(self) -> None:
        """Each step an agent draws one normal sample per noisy cell, population by population in
        update order (those of 4k cells first, each then owning whole 64-bit words of four 16-bit
        samples; the others packed after), padded to whole words (see _draw_noise and _add_noise)."""
        circuit = self.circuit
        noisy = [n for n in self.order if circuit.population(n).noise_std > 0]
        noisy.sort(key=lambda n: circuit.population(n).size % 4 != 0)
        self._noise_columns: dict[str, tuple[int, int, float]] = {}
        column = 0
        for name in noisy:
            size = circuit.population(name).size
            self._noise_columns[name] = (column, size, float(circuit.population(name).noise_std))
            column += size
        self._noise_width = -(-column // 4) * 4  # whole words per step
        stds = {std for _, _, std in self._noise_columns.values()}
        self._noise_std = stds.pop() if len(stds) == 1 else None  # one level for all: scale once

    def _build_input(self, pop) -> tuple:
        """An input population: its encoder, checked to make ``pop.size`` values from its ports."""
        encoder = get_encoder(pop.name, pop.encoder)
        self._check_encoder(pop, encoder)
        return self.cells[pop.name], encoder, tuple(p.name for p in pop.ports), dict(pop.encoder_params), pop.name

    def _build_population(self, pop, position: dict[str, int]) -> _PopulationStep:
        """A rate, output, leaky or integrator population: its product, activation and kind's update."""
        name = pop.name
        if pop.kind == "leaky":
            check_leaky_step(name, pop.tau_s, self.dt_s)
        now, prev, plastic = [], [], []
        for source in self.circuit.graph.predecessors(name):
            edge = self.circuit.graph.edges[source, name]
            # A delayed connection from a population already updated this step reads the snapshot.
            from_snapshot = bool(edge["delay"] and position[source] < position[name])
            if edge.get("learning") is not None:
                plastic.append((from_snapshot, self._build_plastic(source, name, edge)))
                continue
            (prev if from_snapshot else now).append((source, edge["weights"]))
        self._needs_snapshot |= bool(prev) or any(from_snapshot for from_snapshot, _ in plastic)
        activation, params, bias = ACTIVATIONS[pop.activation], dict(pop.params), float(pop.bias)
        scale = 1.0
        if pop.activation == "logistic" and pop.kind != "integrator":
            # σ(a(W x + b) − c) = 1 / (1 + exp(−a W x − a b + c)): scale the weights by −a once.
            slope, offset = params.get("slope", 1.0), params.get("bias", 0.0)
            scale = -slope
            activation, params, bias = logistic_of_negated, {}, -slope * bias + offset
        reads = self._reads(now, pop.size, False, scale) + self._reads(prev, pop.size, True, scale)
        plastic_terms = sorted(((snap, c.source.start, c, scale) for snap, c in plastic), key=lambda t: (t[1], t[0]))
        product = _Product(reads, pop.size, self.dtype, self.sparse, bias, plastic_terms)
        common = (name, self.cells[name], product, bias, activation, params, self._noise_columns.get(name), pop.clip)
        if pop.kind == "leaky":
            return _LeakyStep(*common, leak_fraction=self.dt_s / pop.tau_s)
        if pop.kind == "integrator":
            return _IntegratorStep(*common, gain=float(pop.gain), leak=float(pop.leak), drive_clip=pop.drive_clip,
                                   memory_clip=pop.memory_clip)
        return _RateStep(*common)

    def _build_plastic(self, source: str, target: str, edge: dict) -> _PlasticConnection:
        """A plastic connection: its rule checked against this circuit, its weights allocated later."""
        from neuronav.circuits.circuit import check_gate

        name = f"{source}->{target}"
        rule = edge["learning"]
        check_gate(self.circuit, f"connection {source!r} -> {target!r}", rule.gate)
        connection = _PlasticConnection(name, rule, edge["weights"], self.cells[source], self.cells[target],
                                        self.cells[rule.gate], self.dtype)
        self._plastic[name] = connection
        return connection

    @staticmethod
    def _check_encoder(pop, encoder) -> None:
        """The encoder must turn its ports into exactly ``pop.size`` values per agent."""
        probe = [np.zeros((1, *port.shape)) for port in pop.ports]
        try:
            shape = np.shape(encoder(*probe, **pop.encoder_params))
        except (TypeError, ValueError, IndexError) as error:
            ports = [p.name for p in pop.ports]
            raise CircuitError(f"input population {pop.name!r}: encoder {pop.encoder!r} cannot read ports "
                               f"{ports} with parameters {pop.encoder_params} ({error})") from None
        if shape != (1, pop.size):
            raise CircuitError(
                f"input population {pop.name!r} has {pop.size} cells but encoder {pop.encoder!r} makes "
                f"{shape[1:] if len(shape) > 1 else shape} values per agent from ports "
                f"{', '.join(f'{p.name} {p.shape}' for p in pop.ports)}"
            )

    def _reads(self, sources: list[tuple[str, np.ndarray]], size: int, from_snapshot: bool,
               scale: float) -> list[tuple[bool, int, np.ndarray]]:
        """Group sources lying close together in the state into one term each.

        Sources are merged while at least half of the merged span is real source cells. Returns
        (from_snapshot, first state row, weights (size, span)) per group.
        """
        groups: list[list[tuple[str, np.ndarray]]] = []
        for source, matrix in sorted(sources, key=lambda item: self.cells[item[0]].start):
            if groups:
                members = groups[-1] + [(source, matrix)]
                lo = self.cells[members[0][0]].start
                filled = sum(self.cells[s].stop - self.cells[s].start for s, _ in members)
                # A dense block beside a sparse one stays apart: broadcasting it needs no gather.
                if filled >= 0.5 * (self.cells[source].stop - lo) and _is_dense(matrix) == _is_dense(groups[-1][-1][1]):
                    groups[-1] = members
                    continue
            groups.append([(source, matrix)])
        reads = []
        for members in groups:
            lo = self.cells[members[0][0]].start
            hi = max(self.cells[s].stop for s, _ in members)
            weights = np.zeros((size, hi - lo))
            for source, matrix in members:
                cells = self.cells[source]
                weights[:, cells.start - lo:cells.stop - lo] += matrix
            reads.append((from_snapshot, lo, weights * scale))
        return reads

    def bytes_per_agent(self) -> int:
        """About how many bytes of memory one agent needs (state, memory, buffers, noise, generator)."""
        itemsize = self.dtype.itemsize
        cells = self.total_cells * (2 if self._needs_snapshot else 1)
        cells += sum(self.circuit.population(n).size * 2 for n in self._memory_names)
        buffers = sum(u.product.buffer_bytes(1, itemsize) for u in self._updates)
        noise = self._noise_width * itemsize * 2 + (RNG_BYTES if self._noise_width else 0)
        # Each plastic connection: the agent's weights and the product's scratch of the same size.
        noise += sum(2 * c.initial.size * itemsize for c in self._plastic.values())
        return cells * itemsize + buffers + noise

    def _check_size(self) -> None:
        needed = self.batch * self.bytes_per_agent()
        available = min(_available_memory_bytes(), DEFAULT_MEMORY_CAP_BYTES)
        if needed > available:
            raise CircuitError(
                f"batch={self.batch} needs about {needed / 2**30:.3g} GiB for circuit {self.circuit.name!r} "
                f"({self.bytes_per_agent()} bytes per agent) but only {available / 2**30:.3g} GiB are available; "
                f"use a batch of at most {max(1, available // self.bytes_per_agent())}"
            )

    # -- running --------------------------------------------------------------------------------
    def reset(self) -> None:
        """Return every population to its initial rates and memory, and restart the noise streams.

        Plastic weights keep what they learnt (:meth:`reset_weights` returns them to the declared ones).
        """
        self._state = np.zeros((self.total_cells, self.batch), self.dtype)
        for name in self.order:
            self._state[self.cells[name]] = self.circuit.population(name).initial
        self._snapshot = np.zeros_like(self._state) if self._needs_snapshot else None
        self._memory = {
            name: np.full((self.circuit.population(name).size, self.batch),
                          self.circuit.population(name).initial, self.dtype)
            for name in self._memory_names
        }
        self._reset_noise()  # before binding: the steps read the noise layout
        for update in self._updates:
            update.bind(self)
        for update in self._updates:
            if update.kind == "integrator":
                update.rates_of_memory()
        self.steps = 0

    def _reset_noise(self) -> None:
        # SFC64: as good for simulation noise as numpy's default PCG64, and faster here.
        self._rngs = [np.random.Generator(np.random.SFC64(s)) for s in self.seeds] if self._noise_width else []
        columns = self._noise_width
        bytes_per_step = max(1, self.batch * columns * self.dtype.itemsize)
        self._noise_block_steps = max(1, min(256, NOISE_BUFFER_BYTES // bytes_per_step))
        if self.noise_method == "table":
            self._table = normal_quantile_table(self.dtype)
            if self._noise_std is not None:  # one noise level for every population: fold it in
                self._table = self._table * self._noise_std
        # One noise level for every population: each block of noise is scaled once when drawn.
        self._noise_scaled = self._noise_std is not None
        self._noise_by_cell = self.batch < SMALL_BATCH or self.noise_method == "table"
        if self.noise_method == "table":  # (step, column, agent), filled in place block after block
            self._noise_buffer = np.zeros((self._noise_block_steps, columns, self.batch), self.dtype)
        # Gaussian: (word, agent, sample-in-word), word w of a step holding its columns 4w .. 4w + 3.
        self._noise = np.zeros((0, self.batch, 4), self.dtype)  # drawn at the first step
        self._noise_step = self._noise_block_steps  # empty: draw on the first step

    def _draw_noise(self) -> np.ndarray:
        """This step's noise: (columns, agents) for table noise and small batches; otherwise
        (words, agents, 4), column c at [c // 4, :, c % 4]."""
        words_per_step = self._noise_width // 4
        if self._noise_step == self._noise_block_steps:
            words = self._noise_block_steps * words_per_step
            batch = self.batch
            # Each agent draws its (step, column) samples in order from its own stream.
            if self.noise_method == "table":
                # 64 random bits give four 16-bit table indices. The words are transposed to
                # (word, agent) whole (cheaper than moving 16-bit pieces), and the gather reads
                # them through a (word, sample-in-word, agent) view, so the gathered noise comes
                # out as (step, column, agent): each step then adds contiguous row slices.
                drawn = np.empty((batch, words), np.uint64)
                for agent, rng in enumerate(self._rngs):
                    drawn[agent] = rng.bit_generator.random_raw(words)
                indices = np.ascontiguousarray(drawn.T).view(np.uint16).reshape(words, batch, 4).transpose(0, 2, 1)
                gathered = self._noise_buffer.reshape(words, 4, batch)
                # In chunks of about 64k samples: numpy widens the indices to a temporary intp array,
                # which then stays in cache (a third faster than one gather over the whole block).
                rows = max(1, TABLE_GATHER_CHUNK // (4 * batch))
                for row in range(0, words, rows):
                    np.take(self._table, indices[row:row + rows], out=gathered[row:row + rows], mode="wrap")
                self._noise = self._noise_buffer
            else:
                draws = np.empty((batch, words * 4), self.dtype)
                for agent, rng in enumerate(self._rngs):
                    rng.standard_normal(out=draws[agent], dtype=self.dtype)
                self._noise = np.ascontiguousarray(draws.reshape(batch, words, 4).transpose(1, 0, 2))
                if self._noise_by_cell:
                    # Few agents: re-lay the block as (step, column, agent) once, so that each step
                    # adds plain row slices (cheapest when the arrays are tiny).
                    steps = self._noise_block_steps
                    self._noise = np.ascontiguousarray(
                        self._noise.reshape(steps, words_per_step, batch, 4).transpose(0, 1, 3, 2)
                    ).reshape(steps, self._noise_width, batch)
                if self._noise_scaled:  # std * sample, the same product as population by population
                    self._noise *= self._noise_std
            self._noise_step = 0
        step = self._noise_step
        self._noise_step += 1
        if self._noise_by_cell:
            return self._noise[step]
        return self._noise[step * words_per_step:(step + 1) * words_per_step]

    def step(self, inputs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Advance every agent one step.

        Parameters
        ----------
        inputs : dict of str to ndarray
            One array per sensor port, shape (batch, *port_shape), and nothing else. Unless
            compiled with ``check_inputs=False``, every value must be finite and inside its port's
            range (when one is declared).

        Returns
        -------
        dict of str to ndarray
            One array per motor port, shape (batch, *port_shape).

        Raises
        ------
        PortError
            Naming the port: missing, unknown, misshaped, not numbers, not finite or out of range.
        """
        self._check_input_ports(inputs)
        if self.check_inputs:
            self._check_input_values(inputs)
        state = self._state
        dtype = self.dtype
        for cells, encoder, ports, params, _ in self._inputs:
            # Encoders compute in the circuit's arithmetic (float32 trig is several times faster).
            values = [inputs[p] if inputs[p].dtype == dtype else inputs[p].astype(dtype) for p in ports]
            state[cells] = encoder(*values, **params).T
        if self._snapshot is not None:
            np.copyto(self._snapshot, state)
        noise = self._draw_noise() if self._noise_width else None
        for update in self._updates:
            update(noise)
        for connection in self._learning:
            connection.learn(state)
        self.steps += 1
        return {port: state[cells].T.copy() for port, cells in self._outputs}

    def _check_input_ports(self, inputs: dict) -> None:
        """Names, shapes and dtypes of the inputs (always checked)."""
        if not isinstance(inputs, dict):
            raise PortError(f"circuit {self.circuit.name!r}: inputs must be a dict of port -> array, "
                            f"got {type(inputs).__name__}")
        shapes = self._sensor_shapes
        for port, shape in shapes.items():
            value = inputs.get(port)
            if value is None or getattr(value, "shape", None) != shape:
                self._raise_input_error(inputs)
            if value.dtype.kind not in "fiu":
                raise PortError(f"circuit {self.circuit.name!r}: port {port!r} needs numbers, got an array of "
                                f"{value.dtype}")
        if len(inputs) != len(shapes):
            unknown = sorted(map(str, set(inputs) - set(shapes)))
            raise PortError(f"circuit {self.circuit.name!r} has no input port {', '.join(map(repr, unknown))}; "
                            f"its ports: {', '.join(shapes) or 'none'}")

    def _check_input_values(self, inputs: dict) -> None:
        """Every input finite, and inside its port's range where one is declared."""
        for port, low, high in self._sensor_ranges:
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

    def _add_noise(self, rates: np.ndarray, noise: np.ndarray, columns: tuple[int, int, float]) -> None:
        """Add this step's noise for one population (its ``noise_columns``) to its rates, in place."""
        start, size, std = columns
        if self._noise_by_cell:
            rates += noise[start:start + size] if self._noise_scaled else std * noise[start:start + size]
            return
        block = noise[start >> 2:(start + size + 3) >> 2].transpose(0, 2, 1)  # (words, 4, agents)
        if not self._noise_scaled:
            block = std * block
        if size & 3 or start & 3:
            offset = start & 3
            rates += block.reshape(-1, rates.shape[1])[offset:offset + size]
        else:
            by_word = rates.reshape(size >> 2, 4, -1)  # a view: adding to it adds to rates
            by_word += block

    def _raise_input_error(self, inputs: dict) -> None:
        if not isinstance(inputs, dict):
            raise PortError(f"circuit {self.circuit.name!r}: inputs must be a dict of port -> array")
        for spec in self.sensors:
            expected = self._sensor_shapes[spec.name]
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

    # -- reading --------------------------------------------------------------------------------
    def rates(self, name: str) -> np.ndarray:
        """A copy of population ``name``'s current rates, shape (batch, size)."""
        if not isinstance(name, str) or name not in self.cells:
            raise CircuitError(
                f"circuit {self.circuit.name!r} has no population {name!r}; it has: {', '.join(sorted(self.cells))}"
            )
        return self._state[self.cells[name]].T.copy()

    def memory(self, name: str) -> np.ndarray:
        """A copy of integrator ``name``'s memory, shape (batch, size)."""
        if not isinstance(name, str) or name not in self._memory:
            raise CircuitError(
                f"circuit {self.circuit.name!r}: {name!r} is not an integrator; integrators: "
                f"{', '.join(self._memory) or 'none'}"
            )
        return self._memory[name].T.copy()

    def set_memory(self, name: str, values: np.ndarray) -> None:
        """Overwrite integrator ``name``'s memory (broadcast to (batch, size)) and its rates."""
        self.memory(name)  # checks the name
        try:
            values = np.broadcast_to(np.asarray(values, dtype=self.dtype), self._memory[name].T.shape)
        except (TypeError, ValueError):
            raise CircuitError(f"set_memory({name!r}): values must be numbers broadcastable to "
                               f"{self._memory[name].T.shape}, got {values!r}") from None
        if not np.isfinite(values).all():
            raise CircuitError(f"set_memory({name!r}): values must be finite, got "
                               f"{values[~np.isfinite(values)].ravel()[0]!r}")
        update = next(u for u in self._updates if u.name == name)
        if update.memory_clip is not None:
            low, high = update.memory_clip
            if not (values.min() >= low and values.max() <= high):
                bad = values[(values < low) | (values > high)].ravel()[0]
                raise CircuitError(f"set_memory({name!r}): memory is kept in [{low:g}, {high:g}] "
                                   f"(memory_clip), got {bad!r}")
        self._memory[name][...] = values.T
        update.rates_of_memory()

    # -- plastic weights ------------------------------------------------------------------------
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

    def all_finite(self) -> bool:
        """True while every rate and memory is finite (a cheap divergence check)."""
        return bool(np.isfinite(self._state).all()) and all(np.isfinite(m).all() for m in self._memory.values())


def _update_order(circuit) -> list[str]:
    """Topological order of the undelayed connections, ties broken by population name."""
    undelayed = nx.DiGraph()
    undelayed.add_nodes_from(circuit.graph)
    undelayed.add_edges_from((s, t) for s, t, d in circuit.graph.edges(data=True) if not d["delay"])
    try:
        return list(nx.lexicographical_topological_sort(undelayed))
    except nx.NetworkXUnfeasible:
        cycle = nx.find_cycle(undelayed)
        path = " -> ".join([s for s, _ in cycle] + [cycle[0][0]])
        raise CircuitError(
            f"circuit {circuit.name!r} has a cycle of undelayed connections ({path}); "
            "mark one of them delay=True"
        ) from None
