"""CompiledCircuit: a circuit built into block matrices and index slices, stepped for a batch.

All N agents advance together: every population's rates live in one state array of shape
(total_cells, N) — cells by agents, so that element-wise work runs over long contiguous rows —
and each population reads the span of that array its sources occupy through one sum of products
formed element-wise and summed in a fixed order (:class:`~neuronav.circuits.product.Product`), so
that an agent's numbers never depend on how many agents share the batch. The public methods speak
(N, size), the batch first. Populations update in a topological order of the undelayed connections
(ties broken by name, so the order — and the numbers — never depend on the order the populations
were declared in). A delayed connection reads its source as it was at the start of the step.

This module holds the compiled circuit's state and its step; the rest lives beside it, one concept
a module:

- :mod:`neuronav.circuits.build` — from the circuit graph to the update order, each population's
  rows of the state and its update (compile options and the memory bound checked there);
- :mod:`neuronav.circuits.product` — a population's net input, summed in a fixed order;
- :mod:`neuronav.circuits.updates` — one update per population kind (rate, leaky, integrator);
- :mod:`neuronav.circuits.noise` — the noise layout and every agent's seeded draws: agent i of a
  batch sees exactly the numbers a single run with that agent's seed sees;
- :mod:`neuronav.circuits.weights` — plastic connections, each agent with its own weights, and the
  methods that read, set, save and load them (a circuit without plastic connections steps exactly
  as before);
- :mod:`neuronav.circuits.inputs` — the checks of a step's inputs.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from neuronav.circuits.build import (
    Builder,
    check_batch_fits,
    check_compile_arguments,
    choose_sparse,
    lay_out_cells,
    update_order,
)
from neuronav.circuits.inputs import InputCheck
from neuronav.circuits.noise import RNG_BYTES, NoiseStream, lay_out_noise
from neuronav.circuits.weights import PlasticWeights
from neuronav.errors import CircuitError


class CompiledCircuit(PlasticWeights):
    """A circuit ready to run: ``step(inputs) -> outputs`` for a batch of agents.

    Parameters
    ----------
    circuit : Circuit
    batch : int
        Number of agents N stepped together. The state needs about :meth:`bytes_per_agent` bytes
        per agent; a batch that would need more than the machine's free memory (or
        :data:`~neuronav.circuits.build.DEFAULT_MEMORY_CAP_BYTES` where that is unknown) is refused
        before anything is allocated.
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
        table of normal quantiles (:func:`~neuronav.circuits.noise.normal_quantile_table`) — about
        3x cheaper, within 1/65536 of N(0, 1) in distribution, tails cut at ±4.33 σ.
    check_inputs : bool
        Check every step that each input is finite and inside its port's declared range (default).
        ``False`` skips these value checks (names, shapes and dtypes are still checked) for speed:
        a NaN or infinite input then propagates into the state and stays there.

    Reproducibility: agent i's numbers depend only on the circuit, dtype, noise method, its own
    seed and its own inputs — not on the batch width or its batch-mates — bit for bit on one
    machine and build of numpy/scipy (see :class:`~neuronav.circuits.product.Product`).
    """


    def __init__(
        self, circuit, batch: int = 1, seed: int | None = 0, seeds: Sequence[int] | None = None,
        dtype: Any = np.float64, dt_s: float | None = None, sparse: bool | None = None,
        noise_method: str = "gaussian", check_inputs: bool = True,
    ) -> None:
        check_compile_arguments(circuit, batch, seed, seeds, dtype, dt_s, noise_method, check_inputs)
        self.noise_method = noise_method
        self.check_inputs = bool(check_inputs)
        self.circuit = circuit
        self.batch = int(batch)
        self.dtype = np.dtype(dtype)
        self.dt_s = dt_s
        self.sensors = circuit.sensors
        self.motors = circuit.motors
        checks = InputCheck(circuit, self.sensors, self.batch)
        self._check_input_ports, self._check_input_values = checks.ports, checks.values

        self.order = update_order(circuit)
        self.cells, self.total_cells = lay_out_cells(circuit, self.order)
        self.sparse = choose_sparse(circuit, self.total_cells, sparse)
        self._noise_layout = lay_out_noise(circuit, self.order)
        self._noise_width = self._noise_layout.width
        builder = Builder(circuit, self.cells, self.dtype, dt_s, self.sparse, self._noise_layout.columns)
        builder.build(self.order)
        self._inputs, self._updates, self._needs_snapshot = builder.inputs, builder.updates, builder.needs_snapshot
        self._outputs = [(p.ports[0].name, self.cells[p.name]) for p in
                         (circuit.population(n) for n in self.order) if p.kind == "output"]
        self._memory_names = [u.name for u in self._updates if u.kind == "integrator"]
        self._plastic = dict(sorted(builder.plastic.items()))  # learning order: by name
        self._learning = list(self._plastic.values())
        check_batch_fits(circuit, self.batch, self.bytes_per_agent())
        for connection in self._learning:
            connection.allocate(self.batch)

        if seeds is None:
            if seed is None:
                seed = int(np.random.SeedSequence().entropy % (2**31))
            seeds = [int(seed) + i for i in range(self.batch)]
        self.seeds = [int(s) for s in seeds]
        self.reset()

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
        # Before binding: the updates read the noise layout.
        self._noise = NoiseStream(self._noise_layout, self.seeds, self.batch, self.dtype, self.noise_method)
        self._draw_noise = self._noise.draw
        for update in self._updates:
            update.bind(self._state, self._snapshot, self._memory, self._noise)
        for update in self._updates:
            if update.kind == "integrator":
                update.rates_of_memory()
        self.steps = 0

    @property
    def _noise_by_cell(self) -> bool:
        """Whether this step's noise comes as (column, agent) (see :mod:`neuronav.circuits.noise`)."""
        return self._noise.by_cell

    @property
    def _noise_block_steps(self) -> int:
        """Steps of noise drawn ahead at once."""
        return self._noise.block_steps

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


    def all_finite(self) -> bool:
        """True while every rate and memory is finite (a cheap divergence check)."""
        return bool(np.isfinite(self._state).all()) and all(np.isfinite(m).all() for m in self._memory.values())
