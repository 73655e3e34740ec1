"""Building a compiled circuit: from the :class:`~neuronav.circuits.circuit.Circuit` graph to index
slices of one state array, connection blocks and one update per population.

In order: the compile options are checked (:func:`check_compile_arguments`); the populations are put
in a topological order of the undelayed connections (:func:`update_order`) and each is given its
rows of the state (:func:`lay_out_cells`); the weights are stored dense or sparse
(:func:`choose_sparse`); then :class:`Builder` makes, population by population in that order, an
input's encoder or a population's :class:`~neuronav.circuits.product.Product` and its kind's update
(:mod:`neuronav.circuits.updates`), and each plastic connection's
:class:`~neuronav.circuits.weights.PlasticConnection`. A batch that would not fit in memory is
refused before anything is allocated (:func:`check_batch_fits`).
"""

from __future__ import annotations

import os

import networkx as nx
import numpy as np

from neuronav.circuits.activations import ACTIVATIONS, logistic_of_negated
from neuronav.circuits.encoders import get_encoder
from neuronav.circuits.noise import NOISE_METHODS
from neuronav.circuits.product import Product, is_dense
from neuronav.circuits.updates import IntegratorStep, LeakyStep, PopulationStep, RateStep, check_leaky_step
from neuronav.circuits.weights import PlasticConnection
from neuronav.errors import CircuitError

# Above this many cells a circuit's weights are stored sparse when most of them are zero.
SPARSE_MIN_CELLS = 2000
SPARSE_MAX_DENSITY = 0.1
# compile() refuses a batch whose state would need more than the machine's free memory, or this
# many bytes where the free memory cannot be read.
DEFAULT_MEMORY_CAP_BYTES = 64 * 2**30


def check_compile_arguments(circuit, batch, seed, seeds, dtype, dt_s, noise_method, check_inputs) -> None:
    """Raise a :class:`CircuitError` naming the first compile option that is not allowed."""
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


def update_order(circuit) -> list[str]:
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


def lay_out_cells(circuit, order: list[str]) -> tuple[dict[str, slice], int]:
    """Each population's rows of the state, in update order, and the number of rows."""
    cells: dict[str, slice] = {}
    start = 0
    for name in order:
        size = circuit.population(name).size
        cells[name] = slice(start, start + size)
        start += size
    return cells, start


def choose_sparse(circuit, total_cells: int, sparse: bool | None) -> bool:
    """``sparse`` as given, or (None) sparse for large circuits whose weights are mostly zero."""
    if sparse is None:
        if total_cells < SPARSE_MIN_CELLS:
            return False
        edges = circuit.graph.edges(data=True)
        nonzero = sum(int(np.count_nonzero(data["weights"])) for _, _, data in edges)
        return nonzero / total_cells ** 2 <= SPARSE_MAX_DENSITY
    return bool(sparse)


class Builder:
    """Builds each population of a circuit in update order (:meth:`build`).

    Parameters
    ----------
    circuit : Circuit
    cells : dict of str to slice
        Each population's rows of the state (:func:`lay_out_cells`).
    dtype : numpy dtype
    dt_s : float or None
        Step length, seconds (needed by leaky populations).
    sparse : bool
        Store the weights as scipy.sparse matrices.
    noise_columns : dict of str to (int, int, float)
        Each noisy population's place in a step's noise (:class:`~neuronav.circuits.noise.NoiseLayout`).

    Attributes
    ----------
    inputs : list of tuple
        Per input population: (its rows, encoder, port names, encoder parameters, name).
    updates : list of PopulationStep
        Every other population's update, in update order.
    plastic : dict of str to PlasticConnection
        The plastic connections by name (``"SOURCE->TARGET"``), in the order built.
    needs_snapshot : bool
        Some connection reads its source as it was at the start of the step.
    """

    def __init__(self, circuit, cells: dict[str, slice], dtype: np.dtype, dt_s: float | None, sparse: bool,
                 noise_columns: dict[str, tuple[int, int, float]]) -> None:
        self.circuit, self.cells, self.dtype, self.dt_s = circuit, cells, dtype, dt_s
        self.sparse, self.noise_columns = sparse, noise_columns
        self.inputs: list[tuple] = []
        self.updates: list[PopulationStep] = []
        self.plastic: dict[str, PlasticConnection] = {}
        self.needs_snapshot = False

    def build(self, order: list[str]) -> None:
        """Build every population of ``order``, one after another (errors come in that order)."""
        position = {name: i for i, name in enumerate(order)}
        for name in order:
            pop = self.circuit.population(name)
            if pop.kind == "input":
                self.inputs.append(self.input(pop))
            else:
                self.updates.append(self.population(pop, position))

    def input(self, pop) -> tuple:
        """An input population: its encoder, checked to make ``pop.size`` values from its ports."""
        encoder = get_encoder(pop.name, pop.encoder)
        self._check_encoder(pop, encoder)
        return self.cells[pop.name], encoder, tuple(p.name for p in pop.ports), dict(pop.encoder_params), pop.name

    def population(self, pop, position: dict[str, int]) -> PopulationStep:
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
                plastic.append((from_snapshot, self.plastic_connection(source, name, edge)))
                continue
            (prev if from_snapshot else now).append((source, edge["weights"]))
        self.needs_snapshot |= bool(prev) or any(from_snapshot for from_snapshot, _ in plastic)
        activation, params, bias = ACTIVATIONS[pop.activation], dict(pop.params), float(pop.bias)
        scale = 1.0
        if pop.activation == "logistic" and pop.kind != "integrator":
            # σ(a(W x + b) − c) = 1 / (1 + exp(−a W x − a b + c)): scale the weights by −a once.
            slope, offset = params.get("slope", 1.0), params.get("bias", 0.0)
            scale = -slope
            activation, params, bias = logistic_of_negated, {}, -slope * bias + offset
        reads = self._reads(now, pop.size, False, scale) + self._reads(prev, pop.size, True, scale)
        plastic_terms = sorted(((snap, c.source.start, c, scale) for snap, c in plastic), key=lambda t: (t[1], t[0]))
        product = Product(reads, pop.size, self.dtype, self.sparse, bias, plastic_terms)
        common = (name, self.cells[name], product, bias, activation, params, self.noise_columns.get(name), pop.clip)
        if pop.kind == "leaky":
            return LeakyStep(*common, leak_fraction=self.dt_s / pop.tau_s)
        if pop.kind == "integrator":
            return IntegratorStep(*common, gain=float(pop.gain), leak=float(pop.leak), drive_clip=pop.drive_clip,
                                  memory_clip=pop.memory_clip)
        return RateStep(*common)

    def plastic_connection(self, source: str, target: str, edge: dict) -> PlasticConnection:
        """A plastic connection: its rule checked against this circuit, its weights allocated later."""
        from neuronav.circuits.circuit import check_gate

        name = f"{source}->{target}"
        rule = edge["learning"]
        check_gate(self.circuit, f"connection {source!r} -> {target!r}", rule.gate)
        connection = PlasticConnection(name, rule, edge["weights"], self.cells[source], self.cells[target],
                                       self.cells[rule.gate], self.dtype)
        self.plastic[name] = connection
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
                if filled >= 0.5 * (self.cells[source].stop - lo) and is_dense(matrix) == is_dense(groups[-1][-1][1]):
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


def available_memory_bytes() -> int:
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


def check_batch_fits(circuit, batch: int, bytes_per_agent: int) -> None:
    """Refuse a batch that would need more than the free memory (at most :data:`DEFAULT_MEMORY_CAP_BYTES`)."""
    needed = batch * bytes_per_agent
    available = min(available_memory_bytes(), DEFAULT_MEMORY_CAP_BYTES)
    if needed > available:
        raise CircuitError(
            f"batch={batch} needs about {needed / 2**30:.3g} GiB for circuit {circuit.name!r} "
            f"({bytes_per_agent} bytes per agent) but only {available / 2**30:.3g} GiB are available; "
            f"use a batch of at most {max(1, available // bytes_per_agent)}"
        )
