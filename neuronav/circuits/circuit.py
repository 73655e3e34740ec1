"""Circuits: rate-neuron populations and their connections, declared as a networkx graph.

Declare a network, then build it (``compile``) and run it — the nengo way. A node of
``circuit.graph`` is a population; its data dict holds one :class:`Population` under
``"population"``. An edge is a connection; its data dict holds ``weights`` (target_size,
source_size), ``delay`` (read the source's value from the previous step), ``learning`` (a
:class:`~neuronav.circuits.plasticity.LearningRule`, or None for fixed weights) and, for reference, the
``rule`` and ``sign`` it was made from.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import networkx as nx
import numpy as np

from neuronav.circuits.activations import check_activation
from neuronav.circuits.connectivity import make_weights
from neuronav.circuits.encoders import get_encoder
from neuronav.circuits.plasticity import LearningRule, check_rule
from neuronav.errors import CircuitError
from neuronav.spec.ports import MotorSpec, SensorSpec

KINDS = ("input", "rate", "leaky", "integrator", "output")
# Keyword options of Circuit.compile besides batch, seed and dt_s (see CompiledCircuit).
COMPILE_OPTIONS = ("seeds", "dtype", "sparse", "noise_method", "check_inputs")


def _declaration(method):
    """Report a malformed argument to a declaration method as one :class:`CircuitError`.

    The methods check what they can by name; whatever else Python or numpy trips over (an
    unhashable name, a string where a number belongs) still surfaces as the project's error,
    naming the call.
    """

    @functools.wraps(method)
    def checked(*args, **kwargs):
        try:
            return method(*args, **kwargs)
        except CircuitError:
            raise
        except (TypeError, ValueError, AttributeError, KeyError, IndexError) as error:
            raise CircuitError(f"{method.__name__}: bad argument ({type(error).__name__}: {error})") from None

    return checked


@dataclass(frozen=True)
class Population:
    """One population of rate neurons.

    Parameters
    ----------
    name : str
    size : int
        Number of cells.
    kind : str
        ``input`` (driven by sensor ports through an encoder), ``rate`` (r = f(W x + b), at once),
        ``leaky`` (tau dr/dt = -r + f(W x + b), Euler), ``integrator`` (a clipped memory
        m += gain * clip(W x + b) - leak whose rates are f(m)), or ``output`` (a motor port:
        r = f(W x + b), identity by default).
    activation : str
        Name from :data:`neuronav.circuits.activations.ACTIVATIONS`.
    params : dict
        Activation parameters (e.g. ``slope``, ``bias`` for ``logistic``).
    bias : float
        Constant added to the net input.
    noise_std : float
        Standard deviation of additive Gaussian noise on the rates (per step).
    clip : tuple of float or None
        (low, high) the rates are clipped into after noise, or None.
    initial : float
        Rates (or, for an integrator, memory) at reset.
    tau_s : float or None
        Time constant of a ``leaky`` population, seconds.
    gain, leak : float
        Integrator: ``m += gain * drive - leak`` every step.
    drive_clip, memory_clip : tuple of float or None
        Integrator: bounds of the drive before integration and of the memory after.
    ports : tuple of SensorSpec or MotorSpec
        ``input``: the sensor ports read; ``output``: the one motor port written.
    encoder : str
        ``input``: name from :data:`neuronav.circuits.encoders.ENCODERS`.
    encoder_params : dict
        ``input``: keyword arguments of the encoder.
    """

    name: str
    size: int
    kind: str = "rate"
    activation: str = "identity"
    params: dict = field(default_factory=dict)
    bias: float = 0.0
    noise_std: float = 0.0
    clip: tuple[float, float] | None = None
    initial: float = 0.0
    tau_s: float | None = None
    gain: float = 1.0
    leak: float = 0.0
    drive_clip: tuple[float, float] | None = None
    memory_clip: tuple[float, float] | None = None
    ports: tuple = ()
    encoder: str = "identity"
    encoder_params: dict = field(default_factory=dict)

    def validate(self) -> None:
        """Raise :class:`CircuitError` when the population is inconsistent."""
        where = f"population {self.name!r}"
        if not isinstance(self.name, str) or not self.name:
            raise CircuitError(f"population name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.size, (int, np.integer)) or isinstance(self.size, bool) or self.size <= 0:
            raise CircuitError(f"{where}: size must be a positive int, got {self.size!r}")
        if self.kind not in KINDS:
            raise CircuitError(f"{where}: unknown kind {self.kind!r}; allowed: {', '.join(KINDS)}")
        if not isinstance(self.activation, str):
            raise CircuitError(f"{where}: activation must be a name (str), got {self.activation!r}")
        if not isinstance(self.params, dict):
            raise CircuitError(f"{where}: params must be a dict of activation parameters, got {self.params!r}")
        if not isinstance(self.encoder, str) or not isinstance(self.encoder_params, dict):
            raise CircuitError(f"{where}: encoder must be a name and encoder_params a dict, got "
                               f"{self.encoder!r}, {self.encoder_params!r}")
        check_activation(self.name, self.activation, self.params)
        numbers = (("bias", self.bias), ("noise_std", self.noise_std), ("initial", self.initial),
                   ("gain", self.gain), ("leak", self.leak))
        if self.tau_s is not None:
            numbers += (("tau_s", self.tau_s),)
        for label, value in numbers:
            if not isinstance(value, (int, float, np.number)) or isinstance(value, bool) or not np.isfinite(value):
                raise CircuitError(f"{where}: {label} must be a finite number, got {value!r}")
        if self.noise_std < 0:
            raise CircuitError(f"{where}: noise_std must be >= 0, got {self.noise_std}")
        for label, bounds in (("clip", self.clip), ("drive_clip", self.drive_clip), ("memory_clip", self.memory_clip)):
            if bounds is not None and (len(bounds) != 2 or not bounds[0] <= bounds[1]):
                raise CircuitError(f"{where}: {label} must be (low, high) with low <= high, got {bounds!r}")
        if self.kind == "leaky" and (self.tau_s is None or not self.tau_s > 0):
            raise CircuitError(f"{where}: a leaky population needs tau_s > 0, got {self.tau_s!r}")
        if self.kind == "input":
            if not self.ports or not all(isinstance(p, SensorSpec) for p in self.ports):
                raise CircuitError(f"{where}: an input population needs one or more SensorSpec ports")
            get_encoder(self.name, self.encoder)
        if self.kind == "output" and (len(self.ports) != 1 or not isinstance(self.ports[0], MotorSpec)):
            raise CircuitError(f"{where}: an output population needs exactly one MotorSpec port")
        if self.kind == "output" and self.ports[0].shape != (self.size,):
            raise CircuitError(
                f"{where}: motor port {self.ports[0].name!r} has shape {self.ports[0].shape}, "
                f"population size is {self.size}"
            )


class Circuit:
    """A rate-neuron circuit declared as a graph of populations and connections.

    Examples
    --------
    >>> c = Circuit("demo")
    >>> _ = c.add_input("x", 1, ports=[SensorSpec("x", (1,))])
    >>> _ = c.add_population("r", 1, activation="relu")
    >>> c.connect("x", "r", weights=[[2.0]])
    >>> sim = c.compile(batch=1)
    """

    def __init__(self, name: str = "circuit", dt_s: float | None = None) -> None:
        self.name = name
        self.graph = nx.DiGraph(name=name)
        # The step length compile() uses when none is given (needed by leaky populations).
        self.dt_s = dt_s

    # -- declaring --------------------------------------------------------------------------
    @_declaration
    def add(self, population: Population) -> Population:
        """Add a :class:`Population`; its name must be new."""
        population.validate()
        if population.name in self.graph:
            raise CircuitError(f"circuit {self.name!r} already has a population {population.name!r}")
        self.graph.add_node(population.name, population=population)
        return population

    @_declaration
    def add_population(self, name: str, size: int, kind: str = "rate", **options: Any) -> Population:
        """Add a ``rate``, ``leaky`` or ``integrator`` population; options as in :class:`Population`."""
        return self.add(_population(name, size, kind, options))

    @_declaration
    def add_input(
        self, name: str, size: int, ports: Iterable[SensorSpec], encoder: str = "identity",
        encoder_params: dict | None = None, **options: Any,
    ) -> Population:
        """Add an ``input`` population that reads ``ports`` through ``encoder``."""
        return self.add(_population(
            name, size, "input",
            dict(options, ports=tuple(ports), encoder=encoder, encoder_params=dict(encoder_params or {})),
        ))

    @_declaration
    def add_output(self, name: str, size: int, port: MotorSpec, **options: Any) -> Population:
        """Add an ``output`` population that writes the motor ``port``."""
        return self.add(_population(name, size, "output", dict(options, ports=(port,))))

    @_declaration
    def connect(
        self, source: str, target: str, weights: Any = None, *, rule: str | None = None,
        rule_params: dict | None = None, gain: float = 1.0, sign: int = 1, delay: bool | None = None,
        learning: LearningRule | None = None,
    ) -> None:
        """Connect ``source`` to ``target``: ``target_input += sign * gain * W @ source``.

        Parameters
        ----------
        weights : array-like, shape (target_size, source_size), optional
            Explicit weights; give either these or ``rule``.
        rule : str, optional
            A rule from :data:`neuronav.circuits.connectivity.RULES` that generates the weights.
        sign : {1, -1}
            Excitatory (1) or inhibitory (-1).
        delay : bool, optional
            Read the source's value from the previous step. Default: True for a self-connection,
            False otherwise. A cycle of undelayed connections is an error at compile time.
        learning : LearningRule, optional
            Make the connection plastic (:mod:`neuronav.circuits.plasticity`): each agent of a compiled
            circuit then holds its own copy of the weights, changed every step by the rule, gated by
            the rule's ``gate`` (an ``input`` population of one cell, declared before this call).
        """
        for name in (source, target):
            if name not in self.graph:
                raise CircuitError(
                    f"connection {source!r} -> {target!r}: circuit {self.name!r} has no population "
                    f"{name!r}; it has: {', '.join(sorted(self.graph)) or 'none'}"
                )
        if self.graph.has_edge(source, target):
            raise CircuitError(f"connection {source!r} -> {target!r} already exists")
        src, dst = self.population(source), self.population(target)
        if dst.kind == "input":
            raise CircuitError(f"connection {source!r} -> {target!r}: an input population takes no connections")
        if src.kind == "output":
            raise CircuitError(f"connection {source!r} -> {target!r}: an output population drives nothing")
        if sign not in (1, -1):
            raise CircuitError(f"connection {source!r} -> {target!r}: sign must be 1 or -1, got {sign!r}")
        if rule is not None and not isinstance(rule, str):
            raise CircuitError(f"connection {source!r} -> {target!r}: rule must be a name, got {rule!r}")
        if (weights is None) == (rule is None):
            raise CircuitError(f"connection {source!r} -> {target!r}: give exactly one of weights or rule")
        if rule is not None:
            matrix = make_weights(rule, dst.size, src.size, rule_params)
        else:
            try:
                matrix = np.array(weights, dtype=float)
            except (TypeError, ValueError):
                raise CircuitError(f"connection {source!r} -> {target!r}: weights are not numeric") from None
        if matrix.shape != (dst.size, src.size):
            raise CircuitError(
                f"connection {source!r} -> {target!r}: weights have shape {matrix.shape}, expected "
                f"(target_size, source_size) = ({dst.size}, {src.size})"
            )
        matrix = sign * float(gain) * matrix
        if not np.all(np.isfinite(matrix)):
            raise CircuitError(f"connection {source!r} -> {target!r}: weights (times gain {gain!r}) contain NaN or inf")
        if learning is not None:
            self._check_learning(source, target, learning, matrix)
        self.graph.add_edge(
            source, target, weights=matrix,
            delay=(source == target) if delay is None else bool(delay), rule=rule, sign=sign, learning=learning,
        )

    def _check_learning(self, source: str, target: str, learning, matrix: np.ndarray) -> None:
        """The rule valid, its gate an input population of one cell, the weights inside its bounds."""
        where = f"connection {source!r} -> {target!r}"
        check_rule(where, learning)
        check_gate(self, where, learning.gate)
        learning.check_weights(where, matrix)

    # -- inspecting -------------------------------------------------------------------------
    def population(self, name: str) -> Population:
        """The :class:`Population` called ``name``."""
        try:
            return self.graph.nodes[name]["population"]
        except KeyError:
            raise CircuitError(
                f"circuit {self.name!r} has no population {name!r}; it has: {', '.join(sorted(self.graph))}"
            ) from None

    @property
    def populations(self) -> list[Population]:
        """All populations, sorted by name."""
        return [self.graph.nodes[n]["population"] for n in sorted(self.graph)]

    @property
    def sensors(self) -> list[SensorSpec]:
        """The sensor ports the circuit reads (each once), sorted by name."""
        specs: dict[str, SensorSpec] = {}
        for pop in self.populations:
            if pop.kind == "input":
                for port in pop.ports:
                    if port.name in specs and specs[port.name] != port:
                        raise CircuitError(
                            f"port {port.name!r} is declared twice with different specs: "
                            f"{specs[port.name]} and {port}"
                        )
                    specs[port.name] = port
        return [specs[k] for k in sorted(specs)]

    @property
    def motors(self) -> list[MotorSpec]:
        """The motor ports the circuit writes, sorted by name."""
        return sorted((p.ports[0] for p in self.populations if p.kind == "output"), key=lambda s: s.name)

    def weight_matrix(self) -> tuple[np.ndarray, list[tuple[str, int, int]]]:
        """The whole circuit as one block matrix (targets x sources) and its (name, start, stop) blocks."""
        blocks, start = [], 0
        for pop in self.populations:
            blocks.append((pop.name, start, start + pop.size))
            start += pop.size
        index = {name: (a, b) for name, a, b in blocks}
        matrix = np.zeros((start, start))
        for source, target, data in self.graph.edges(data=True):
            (sa, sb), (ta, tb) = index[source], index[target]
            matrix[ta:tb, sa:sb] = data["weights"]
        return matrix, blocks

    # -- composing --------------------------------------------------------------------------
    @_declaration
    def renamed(self, prefix: str) -> Circuit:
        """A copy with every population renamed ``prefix + name`` (ports keep their names)."""
        out = Circuit(self.name, dt_s=self.dt_s)
        mapping = {n: prefix + n for n in self.graph}
        for node in self.graph:
            out.add(replace(self.population(node), name=mapping[node]))
        for source, target, data in self.graph.edges(data=True):
            learning = data.get("learning")
            if learning is not None:  # the gate is a population of this circuit: renamed with it
                data = dict(data, learning=replace(learning, gate=mapping.get(learning.gate, learning.gate)))
            out.graph.add_edge(mapping[source], mapping[target], **data)
        return out

    @classmethod
    @_declaration
    def merge(
        cls, *circuits: Circuit, prefixes: Iterable[str] | None = None,
        connections: Iterable[tuple] = (), name: str = "merged",
    ) -> Circuit:
        """Combine circuits into one, optionally prefixing each one's population names.

        Parameters
        ----------
        circuits : Circuit
        prefixes : iterable of str, optional
            One prefix per circuit (``""`` for none). Name clashes are an error.
        connections : iterable of tuple
            Extra connections ``(source, target, kwargs)`` between the merged populations, using
            the prefixed names; ``kwargs`` as in :meth:`connect`.
        """
        if prefixes is not None and (isinstance(prefixes, str) or not all(isinstance(p, str) for p in prefixes)):
            raise CircuitError(f"merge: prefixes must be a sequence of strings, one per circuit, got {prefixes!r}")
        prefixes = list(prefixes) if prefixes is not None else [""] * len(circuits)
        if len(prefixes) != len(circuits):
            raise CircuitError(f"merge: {len(circuits)} circuits but {len(prefixes)} prefixes")
        steps = {c.dt_s for c in circuits if c.dt_s is not None}
        if len(steps) > 1:
            raise CircuitError(f"merge: the circuits declare different dt_s {sorted(steps)}; compile with one")
        out = cls(name, dt_s=steps.pop() if steps else None)
        for circuit, prefix in zip(circuits, prefixes):
            part = circuit.renamed(prefix) if prefix else circuit
            for node in part.graph:
                out.add(part.population(node))
            for source, target, data in part.graph.edges(data=True):
                out.graph.add_edge(source, target, **data)
        for connection in connections:
            if not isinstance(connection, (tuple, list)) or len(connection) not in (2, 3):
                raise CircuitError(f"merge: a connection is (source, target[, options]), got {connection!r}")
            source, target, *rest = connection
            out.connect(source, target, **(rest[0] if rest else {}))
        return out

    def compile(self, batch: int = 1, seed: int | None = 0, dt_s: float | None = None, **options: Any):
        """Build the circuit into a :class:`~neuronav.circuits.compiled.CompiledCircuit`; options as there.

        ``dt_s`` defaults to the circuit's own ``dt_s`` (set by factories such as the ring attractor).
        Other options: :data:`COMPILE_OPTIONS`; any other name is a :class:`CircuitError`.
        """
        from neuronav.circuits.compiled import CompiledCircuit

        unknown = sorted(map(str, set(options) - set(COMPILE_OPTIONS)))
        if unknown:
            raise CircuitError(f"compile: unknown option {', '.join(unknown)}; allowed: batch, seed, dt_s, "
                               f"{', '.join(COMPILE_OPTIONS)}")
        return CompiledCircuit(self, batch=batch, seed=seed, dt_s=self.dt_s if dt_s is None else dt_s, **options)

    def __repr__(self) -> str:
        return (f"Circuit({self.name!r}, {self.graph.number_of_nodes()} populations, "
                f"{self.graph.number_of_edges()} connections)")


def check_gate(circuit: Circuit, where: str, gate: str) -> None:
    """Raise :class:`CircuitError` unless ``gate`` is an ``input`` population of one cell in ``circuit``."""
    if gate not in circuit.graph:
        inputs = sorted(p.name for p in circuit.populations if p.kind == "input")
        raise CircuitError(f"{where}: learning gate {gate!r} is not a population of circuit {circuit.name!r}; "
                           f"its input populations: {', '.join(inputs) or 'none'}")
    population = circuit.population(gate)
    if population.kind != "input" or population.size != 1:
        raise CircuitError(f"{where}: learning gate {gate!r} must be an input population of one cell, got a "
                           f"{population.kind} population of {population.size}")


def _population(name: str, size: int, kind: str, options: dict) -> Population:
    allowed = set(Population.__dataclass_fields__) - {"name", "size", "kind"}
    unknown = set(options) - allowed
    if unknown:
        raise CircuitError(
            f"population {name!r}: unknown option {', '.join(sorted(unknown))}; allowed: {', '.join(sorted(allowed))}"
        )
    for key in ("clip", "drive_clip", "memory_clip"):
        if options.get(key) is not None:
            options[key] = tuple(float(v) for v in options[key])
    return Population(name=name, size=size, kind=kind, **options)
