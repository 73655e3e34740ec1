"""The compiled circuit's noise: where each noisy population's samples lie, and their seeded draws.

Each step an agent draws one normal sample per noisy cell (:class:`NoiseLayout`), from its own
:class:`numpy.random.Generator` (SFC64, seeded with the agent's seed), drawn ahead in blocks of
steps (:class:`NoiseStream`), so agent i of a batch sees exactly the numbers a single run with that
agent's seed sees. Two samplers (``noise_method``): ``gaussian``, numpy's exact normal sampler, and
``table``, 16 random bits per sample indexing a table of normal quantiles
(:func:`normal_quantile_table`).

A block is held in one of two layouts, whichever makes a population's share cheapest to add:
(step, column, agent) for table noise and batches under :data:`SMALL_BATCH` agents (each population
adds plain row slices), else (word, agent, sample-in-word) (no re-laying copy at large batches).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

# Bytes of pre-drawn noise held per circuit at most.
NOISE_BUFFER_BYTES = 1 << 25
NOISE_METHODS = ("gaussian", "table")
# About what one agent's noise generator (an SFC64 Generator object) costs.
RNG_BYTES = 1024
# Gaussian noise below this many agents is re-laid per block as (step, column, agent): row slices
# then cost the least per step; above it the (word, agent, sample) layout avoids that copy. Table
# noise is always gathered straight into (step, column, agent).
SMALL_BATCH = 32
# The "table" noise: N(0, 1) quantiles at this many equiprobable levels, indexed by 16 random bits.
TABLE_LEVELS = 1 << 16
# Samples gathered from the table per call (see NoiseStream.draw).
TABLE_GATHER_CHUNK = 1 << 16


def normal_quantile_table(dtype: Any = np.float64) -> np.ndarray:
    """``Φ⁻¹((k + 0.5) / 65536)`` for k = 0..65535: a 16-bit inverse-CDF table of N(0, 1).

    Sampling it with uniform 16-bit indices gives a distribution within 1/65536 (Kolmogorov
    distance) of the standard normal, with tails cut at ±4.33 σ.
    """
    from scipy.special import ndtri

    return ndtri((np.arange(TABLE_LEVELS) + 0.5) / TABLE_LEVELS).astype(dtype)


@dataclass(frozen=True)
class NoiseLayout:
    """Where each noisy population's samples lie in a step's draw.

    Attributes
    ----------
    columns : dict of str to (int, int, float)
        Per noisy population: its first column, its number of cells and its noise std.
    width : int
        Samples per agent-step, padded to whole words of four.
    std : float or None
        The noise std when every noisy population has the same one (then scaled once per block).
    """

    columns: dict[str, tuple[int, int, float]]
    width: int
    std: float | None


def lay_out_noise(circuit, order: list[str]) -> NoiseLayout:
    """Each step an agent draws one normal sample per noisy cell, population by population in
    update order (those of 4k cells first, each then owning whole 64-bit words of four 16-bit
    samples; the others packed after), padded to whole words (see NoiseStream.draw and .add)."""
    noisy = [n for n in order if circuit.population(n).noise_std > 0]
    noisy.sort(key=lambda n: circuit.population(n).size % 4 != 0)
    columns: dict[str, tuple[int, int, float]] = {}
    column = 0
    for name in noisy:
        size = circuit.population(name).size
        columns[name] = (column, size, float(circuit.population(name).noise_std))
        column += size
    stds = {std for _, _, std in columns.values()}
    # One level for all: scale once.
    return NoiseLayout(columns, -(-column // 4) * 4, stds.pop() if len(stds) == 1 else None)


class NoiseStream:
    """Every agent's noise generator from its first step: this step's noise (:meth:`draw`) and how a
    population adds its share to its rates (:meth:`add`).

    Parameters
    ----------
    layout : NoiseLayout
    seeds : sequence of int
        One per agent.
    batch : int
    dtype : numpy dtype
    method : {"gaussian", "table"}
    """

    def __init__(self, layout: NoiseLayout, seeds, batch: int, dtype: np.dtype, method: str) -> None:
        self.layout, self.batch, self.dtype, self.method = layout, batch, dtype, method
        # SFC64: as good for simulation noise as numpy's default PCG64, and faster here.
        self.rngs = [np.random.Generator(np.random.SFC64(s)) for s in seeds] if layout.width else []
        columns = layout.width
        self.words_per_step = columns // 4
        bytes_per_step = max(1, batch * columns * dtype.itemsize)
        self.block_steps = max(1, min(256, NOISE_BUFFER_BYTES // bytes_per_step))
        if method == "table":
            self.table = normal_quantile_table(dtype)
            if layout.std is not None:  # one noise level for every population: fold it in
                self.table = self.table * layout.std
        # One noise level for every population: each block of noise is scaled once when drawn.
        self.scaled = layout.std is not None
        self.by_cell = batch < SMALL_BATCH or method == "table"
        if method == "table":  # (step, column, agent), filled in place block after block
            self.buffer = np.zeros((self.block_steps, columns, batch), dtype)
        # Gaussian: (word, agent, sample-in-word), word w of a step holding its columns 4w .. 4w + 3.
        self.block = np.zeros((0, batch, 4), dtype)  # drawn at the first step
        self.next_step = self.block_steps  # empty: draw on the first step

    def draw(self) -> np.ndarray:
        """This step's noise: (columns, agents) for table noise and small batches; otherwise
        (words, agents, 4), column c at [c // 4, :, c % 4]."""
        words_per_step = self.words_per_step
        if self.next_step == self.block_steps:
            words = self.block_steps * words_per_step
            batch = self.batch
            # Each agent draws its (step, column) samples in order from its own stream.
            if self.method == "table":
                # 64 random bits give four 16-bit table indices. The words are transposed to
                # (word, agent) whole (cheaper than moving 16-bit pieces), and the gather reads
                # them through a (word, sample-in-word, agent) view, so the gathered noise comes
                # out as (step, column, agent): each step then adds contiguous row slices.
                drawn = np.empty((batch, words), np.uint64)
                for agent, rng in enumerate(self.rngs):
                    drawn[agent] = rng.bit_generator.random_raw(words)
                indices = np.ascontiguousarray(drawn.T).view(np.uint16).reshape(words, batch, 4).transpose(0, 2, 1)
                gathered = self.buffer.reshape(words, 4, batch)
                # In chunks of about 64k samples: numpy widens the indices to a temporary intp array,
                # which then stays in cache (a third faster than one gather over the whole block).
                rows = max(1, TABLE_GATHER_CHUNK // (4 * batch))
                for row in range(0, words, rows):
                    np.take(self.table, indices[row:row + rows], out=gathered[row:row + rows], mode="wrap")
                self.block = self.buffer
            else:
                draws = np.empty((batch, words * 4), self.dtype)
                for agent, rng in enumerate(self.rngs):
                    rng.standard_normal(out=draws[agent], dtype=self.dtype)
                self.block = np.ascontiguousarray(draws.reshape(batch, words, 4).transpose(1, 0, 2))
                if self.by_cell:
                    # Few agents: re-lay the block as (step, column, agent) once, so that each step
                    # adds plain row slices (cheapest when the arrays are tiny).
                    steps = self.block_steps
                    self.block = np.ascontiguousarray(
                        self.block.reshape(steps, words_per_step, batch, 4).transpose(0, 1, 3, 2)
                    ).reshape(steps, self.layout.width, batch)
                if self.scaled:  # std * sample, the same product as population by population
                    self.block *= self.layout.std
            self.next_step = 0
        step = self.next_step
        self.next_step += 1
        if self.by_cell:
            return self.block[step]
        return self.block[step * words_per_step:(step + 1) * words_per_step]

    def add(self, rates: np.ndarray, noise: np.ndarray, columns: tuple[int, int, float]) -> None:
        """Add this step's noise for one population (its ``columns`` in the layout) to its rates, in place."""
        start, size, std = columns
        if self.by_cell:
            rates += noise[start:start + size] if self.scaled else std * noise[start:start + size]
            return
        block = noise[start >> 2:(start + size + 3) >> 2].transpose(0, 2, 1)  # (words, 4, agents)
        if not self.scaled:
            block = std * block
        if size & 3 or start & 3:
            offset = start & 3
            rates += block.reshape(-1, rates.shape[1])[offset:offset + size]
        else:
            by_word = rates.reshape(size >> 2, 4, -1)  # a view: adding to it adds to rates
            by_word += block
