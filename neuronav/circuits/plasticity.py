"""Learning rules: connections whose weights change while the circuit runs, gated by an input port.

A connection carries a rule when it is declared
(``circuit.connect("KC", "MBON", weights=..., learning=OneShotDepression(rate=1.0, gate="reward"))``);
``gate`` names an ``input`` population of one cell (a sensor port, e.g. a reward or "learn now"
signal) read by every agent each step. The compiled circuit
(:class:`~neuronav.circuits.compiled.CompiledCircuit`) keeps each agent its own copy of a plastic
connection's weights, shape (batch, post, pre), and applies the rule after every step to the
rates of that step: the presynaptic (source) cells, the postsynaptic (target) cells and the gate.
Fixed connections stay one matrix shared by all agents.

The rules act on the connection's effective weights (``sign * gain * weights`` as declared), the
numbers that multiply the presynaptic rates and that ``compiled.weights(name)`` returns.

Rules
-----
:class:`OneShotDepression`
    The mushroom body's Kenyon-cell-to-output learning (Ardin et al. 2016; Sun et al. 2020,
    ``docs/parameters.md`` §7): where the gate is on (its rate above ``gate_threshold``), the
    weight from every active presynaptic cell (rate above ``active_threshold``) drops by ``rate``,
    floored at 0. One presentation of a view with ``rate`` >= the initial weight silences its
    active cells' weights: the view is then familiar.
:class:`ThreeFactorHebbian`
    ``Δw_ij = rate · g · post_i · pre_j``, the gate's rate ``g`` as the third (modulatory) factor
    (a reward, a dopamine signal; negative ``g`` depresses), then clipped into ``[w_min, w_max]``.

Each agent's update uses only its own rates and weights: an agent's numbers never depend on its
batch-mates.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from neuronav.errors import CircuitError


def _finite_number(where: str, label: str, value) -> float:
    if not isinstance(value, (int, float, np.number)) or isinstance(value, bool) or not np.isfinite(value):
        raise CircuitError(f"{where}: {label} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class LearningRule:
    """What every rule has: the name of the gating input population (one cell)."""

    gate: str

    name = "rule"

    def validate(self, where: str) -> None:
        """Raise :class:`CircuitError` naming ``where`` when a parameter is not allowed."""
        if not isinstance(self.gate, str) or not self.gate:
            raise CircuitError(f"{where}: the learning rule's gate must name an input population, got {self.gate!r}")

    def check_weights(self, where: str, weights: np.ndarray) -> None:
        """Raise :class:`CircuitError` when ``weights`` lie outside what the rule keeps them in."""

    def update(self, weights: np.ndarray, pre: np.ndarray, post: np.ndarray, gate: np.ndarray) -> None:
        """Apply one step's change in place.

        Parameters
        ----------
        weights : ndarray, shape (post, pre, batch)
            Each agent's weights (agents last, as the compiled circuit keeps them: cells by agents),
            changed in place.
        pre, post : ndarray, shape (pre, batch) and (post, batch)
            This step's rates of the source and target populations (cells by agents).
        gate : ndarray, shape (batch,)
            This step's rate of the gate population.
        """
        raise NotImplementedError

    def describe(self) -> str:
        """One line naming the rule and its parameters (for diagrams and reports)."""
        values = ", ".join(f"{f.name}={getattr(self, f.name)!r}" for f in fields(self))
        return f"{type(self).__name__}({values})"


@dataclass(frozen=True)
class OneShotDepression(LearningRule):
    """Gate on: every active presynaptic cell's weights drop by ``rate``, floored at 0.

    Parameters
    ----------
    gate : str
        The gating input population (one cell).
    rate : float
        Weight lost per gated step by an active cell's connections (> 0).
    active_threshold : float
        A presynaptic cell is active where its rate exceeds this.
    gate_threshold : float
        The gate is on where its rate exceeds this.
    """

    rate: float = 1.0
    active_threshold: float = 0.0
    gate_threshold: float = 0.5

    name = "one-shot depression"

    def validate(self, where: str) -> None:
        super().validate(where)
        for label in ("rate", "active_threshold", "gate_threshold"):
            _finite_number(where, f"OneShotDepression {label}", getattr(self, label))
        if not self.rate > 0:
            raise CircuitError(f"{where}: OneShotDepression rate must be > 0, got {self.rate!r}")

    def check_weights(self, where: str, weights: np.ndarray) -> None:
        if np.any(weights < 0):
            raise CircuitError(f"{where}: OneShotDepression keeps weights >= 0 (floored at 0), got "
                               f"{float(weights.min()):g}; declare the connection with non-negative weights "
                               "and sign 1")

    def update(self, weights: np.ndarray, pre: np.ndarray, post: np.ndarray, gate: np.ndarray) -> None:
        on = gate > self.gate_threshold
        if not on.any():
            return
        # Agents not learning (and inactive cells) subtract exactly 0: their weights keep every bit.
        depressed = (pre > self.active_threshold) & on  # (pre, batch)
        changed = weights - self.rate * depressed
        np.maximum(changed, 0.0, out=weights)


@dataclass(frozen=True)
class ThreeFactorHebbian(LearningRule):
    """``Δw_ij = rate · g · post_i · pre_j`` each step, then clipped into ``[w_min, w_max]``.

    Parameters
    ----------
    gate : str
        The modulatory input population (one cell); its rate ``g`` scales the change (0: none).
    rate : float
        Learning rate (> 0).
    w_min, w_max : float
        Bounds the weights are kept in (w_min < w_max; either may be infinite).
    """

    rate: float = 0.01
    w_min: float = 0.0
    w_max: float = 1.0

    name = "three-factor Hebbian"

    def validate(self, where: str) -> None:
        super().validate(where)
        _finite_number(where, "ThreeFactorHebbian rate", self.rate)
        if not self.rate > 0:
            raise CircuitError(f"{where}: ThreeFactorHebbian rate must be > 0, got {self.rate!r}")
        for label in ("w_min", "w_max"):
            value = getattr(self, label)
            if not isinstance(value, (int, float, np.number)) or isinstance(value, bool) or np.isnan(value):
                raise CircuitError(f"{where}: ThreeFactorHebbian {label} must be a number, got {value!r}")
        if not self.w_min < self.w_max:
            raise CircuitError(f"{where}: ThreeFactorHebbian needs w_min < w_max, got {self.w_min!r} and "
                               f"{self.w_max!r}")

    def check_weights(self, where: str, weights: np.ndarray) -> None:
        if np.any(weights < self.w_min) or np.any(weights > self.w_max):
            raise CircuitError(f"{where}: ThreeFactorHebbian keeps weights in [{self.w_min:g}, {self.w_max:g}], "
                               f"got values in [{float(weights.min()):g}, {float(weights.max()):g}]")

    def update(self, weights: np.ndarray, pre: np.ndarray, post: np.ndarray, gate: np.ndarray) -> None:
        learning = np.flatnonzero(gate != 0)
        if learning.size == 0:
            return
        if learning.size < gate.size:  # only the learning agents' columns
            part = weights[:, :, learning]
            self.update(part, pre[:, learning], post[:, learning], gate[learning])
            weights[:, :, learning] = part
            return
        factor = (self.rate * gate) * post  # (post, batch)
        change = factor[:, None, :] * pre[None, :, :]
        np.clip(weights + change, self.w_min, self.w_max, out=weights)


RULES = (OneShotDepression, ThreeFactorHebbian)


def check_rule(where: str, rule) -> LearningRule:
    """``rule`` validated, or a :class:`CircuitError` naming ``where`` and the rules allowed."""
    if not isinstance(rule, LearningRule) or type(rule) is LearningRule:
        allowed = ", ".join(r.__name__ for r in RULES)
        raise CircuitError(f"{where}: learning must be a learning rule ({allowed}), got {rule!r}")
    rule.validate(where)
    return rule
