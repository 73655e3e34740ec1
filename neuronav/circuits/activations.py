"""Activation functions of rate populations, by name.

Each function takes the population's net input ``x`` of shape (batch, size), may overwrite it in
place (it is a scratch array), and returns the rates. Parameters are keyword arguments stored with
the population, so a circuit stays plain data.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from neuronav.errors import CircuitError


def logistic(x: np.ndarray, slope: float = 1.0, bias: float = 0.0) -> np.ndarray:
    """``1 / (1 + exp(-(slope * x - bias)))``: Stone et al. 2017's sigmoid with slope a and bias b.

    One arithmetic path for every array size, so that a value's result never depends on how many
    others are computed with it (scipy's ``expit`` rounds differently from ``exp`` here).
    """
    np.multiply(x, -slope, out=x)
    x += bias
    np.exp(x, out=x)
    x += 1.0
    return np.reciprocal(x, out=x)


def logistic_of_negated(x: np.ndarray) -> np.ndarray:
    """``1 / (1 + exp(x))``: the logistic of an input already mapped to ``-(slope * I - bias)``.

    The compiled circuit folds a logistic population's slope and bias into its weights, which
    saves two passes over the rates every step.
    """
    np.exp(x, out=x)
    x += 1.0
    return np.reciprocal(x, out=x)


def relu(x: np.ndarray) -> np.ndarray:
    """Rectified linear: ``max(x, 0)``."""
    return np.maximum(x, 0.0, out=x)


def identity(x: np.ndarray) -> np.ndarray:
    """The net input itself."""
    return x


def step(x: np.ndarray, threshold: float = 0.0) -> np.ndarray:
    """Binary: 1 where the net input exceeds ``threshold``, else 0 (the mushroom body's Kenyon cells)."""
    return np.greater(x, threshold, out=x)


ACTIVATIONS: dict[str, Callable[..., np.ndarray]] = {
    "logistic": logistic,
    "relu": relu,
    "identity": identity,
    "step": step,
}

_PARAMETERS = {"logistic": {"slope", "bias"}, "relu": set(), "identity": set(), "step": {"threshold"}}


def check_activation(population: str, name: str, params: dict) -> None:
    """Raise :class:`CircuitError` unless ``name`` is a known activation and ``params`` fit it."""
    if name not in ACTIVATIONS:
        raise CircuitError(
            f"population {population!r}: unknown activation {name!r}; allowed: {', '.join(ACTIVATIONS)}"
        )
    unknown = set(params) - _PARAMETERS[name]
    if unknown:
        allowed = ", ".join(sorted(_PARAMETERS[name])) or "none"
        raise CircuitError(
            f"population {population!r}: activation {name!r} has no parameter "
            f"{', '.join(sorted(unknown))}; allowed: {allowed}"
        )
    for key, value in params.items():
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not np.isfinite(value):
            raise CircuitError(
                f"population {population!r}: activation parameter {key!r} must be a finite number, got {value!r}"
            )
