"""One small update per population kind (nengo's builder style): what a compiled circuit does to each
non-input population every step.

:class:`RateStep` (``rate`` and ``output``), :class:`LeakyStep` and :class:`IntegratorStep` share
:class:`PopulationStep`: the net input (a :class:`~neuronav.circuits.product.Product`), bias,
activation, noise (from the circuit's :class:`~neuronav.circuits.noise.NoiseStream`) and clip. Each is
built once by :mod:`neuronav.circuits.build` and bound to the state arrays at every reset.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from neuronav.circuits.activations import identity, logistic, logistic_of_negated
from neuronav.errors import CircuitError

if TYPE_CHECKING:
    from neuronav.circuits.noise import NoiseStream
    from neuronav.circuits.product import Product


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


class PopulationStep:
    """What every non-input population does each step: net input, bias, activation, noise, clip.

    Subclasses differ in where the net input goes (:class:`RateStep`, :class:`LeakyStep`,
    :class:`IntegratorStep`).
    """

    kind = "rate"

    def __init__(self, name: str, cells: slice, product: Product, bias: float, activation: Callable,
                 params: dict, noise_columns: tuple[int, int, float] | None, clip: tuple[float, float] | None,
                 ) -> None:
        self.name, self.cells, self.product = name, cells, product
        self.bias, self.activation, self.params = bias, activation, params
        self.noise_columns, self.clip = noise_columns, clip

    def bind(self, state: np.ndarray, snapshot: np.ndarray | None, memory: dict[str, np.ndarray],
             noise: NoiseStream) -> None:
        """Point the step's calls at the compiled circuit's (new) arrays.

        Parameters
        ----------
        state : ndarray, shape (total_cells, batch)
            Every population's rates.
        snapshot : ndarray or None
            The state as it was at the start of the step (read by delayed connections).
        memory : dict of str to ndarray
            Each integrator's memory, shape (size, batch).
        noise : NoiseStream
        """
        self.rates_view = state[self.cells]
        self.add_noise = noise.add
        # Pre-scaled noise laid out (column, agent): this population adds a plain row slice.
        self.noise_rows = None
        if self.noise_columns is not None and noise.by_cell and noise.scaled:
            start, size, _ = self.noise_columns
            self.noise_rows = slice(start, start + size)
        self.net = self._net_target(state)
        self.product.bind(state, snapshot, self.net, self.cells if self.net is self.rates_view else None)
        # The net input's calls, then the bias unless the product already added it.
        self.calls = list(self.product.calls)
        if self.bias and not self.product.includes_bias:
            self.calls.append(functools.partial(np.add, self.net, self.bias, out=self.net))

    def _net_target(self, state: np.ndarray) -> np.ndarray:
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


class RateStep(PopulationStep):
    """``rate`` and ``output``: r = f(W x + b), written straight into the population's state rows."""

    def bind(self, *args: Any) -> None:
        super().bind(*args)
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


class SeparateNetStep(PopulationStep):
    """A population whose net input goes into a buffer of its own (its state is updated from it)."""

    def _net_target(self, state: np.ndarray) -> np.ndarray:
        self.net = np.zeros((self.cells.stop - self.cells.start, state.shape[1]), state.dtype)
        return self.net


class LeakyStep(SeparateNetStep):
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


class IntegratorStep(SeparateNetStep):
    """``integrator``: m += gain * clip(W x + b) - leak, m clipped; rates f(m)."""

    kind = "integrator"

    def __init__(self, *args: Any, gain: float, leak: float, drive_clip, memory_clip) -> None:
        super().__init__(*args)
        self.gain, self.leak, self.drive_clip, self.memory_clip = gain, leak, drive_clip, memory_clip

    def bind(self, state: np.ndarray, snapshot: np.ndarray | None, memory: dict[str, np.ndarray],
             noise: NoiseStream) -> None:
        self.memory = memory[self.name]
        super().bind(state, snapshot, memory, noise)

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
