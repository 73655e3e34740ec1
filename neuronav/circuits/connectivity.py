"""Named connectivity rules that generate weight matrices.

Every rule returns a matrix of shape (target_size, source_size), so that
``target_input = W @ source_rates``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from neuronav.angles import angle_difference_rad
from neuronav.errors import CircuitError


def one_to_one(target_size: int, source_size: int) -> np.ndarray:
    """Identity: cell i drives cell i. Sizes must match."""
    if target_size != source_size:
        raise CircuitError(f"rule 'one_to_one' needs equal sizes, got {source_size} -> {target_size}")
    return np.eye(target_size)


def all_to_all(target_size: int, source_size: int) -> np.ndarray:
    """Every source cell drives every target cell with weight 1."""
    return np.ones((target_size, source_size))


def tile(target_size: int, source_size: int) -> np.ndarray:
    """Target cell j reads source cell ``j mod source_size`` (e.g. 8 TB1 columns -> 16 CPU cells)."""
    weights = np.zeros((target_size, source_size))
    weights[np.arange(target_size), np.arange(target_size) % source_size] = 1.0
    return weights


def fold(target_size: int, source_size: int) -> np.ndarray:
    """Target cell j sums source cells ``j, j + target_size, ...`` (e.g. 16 CL1 -> 8 TB1)."""
    weights = np.zeros((target_size, source_size))
    weights[np.arange(source_size) % target_size, np.arange(source_size)] = 1.0
    return weights


def roll(target_size: int, source_size: int, shift: int = 0) -> np.ndarray:
    """Target cell j reads source cell ``(j - shift) mod n``: the bump moves by ``shift`` cells."""
    if target_size != source_size:
        raise CircuitError(f"rule 'roll' needs equal sizes, got {source_size} -> {target_size}")
    return np.roll(np.eye(target_size), shift, axis=0)


def cosine_ring(target_size: int, source_size: int) -> np.ndarray:
    """``(1 - cos(2 pi (j - i) / n)) / 2``: Stone et al. 2017's TB1 -> TB1 inhibition profile."""
    if target_size != source_size:
        raise CircuitError(f"rule 'cosine_ring' needs equal sizes, got {source_size} -> {target_size}")
    i = np.arange(source_size)[None, :]
    j = np.arange(target_size)[:, None]
    return (1.0 - np.cos(2.0 * np.pi * (j - i) / target_size)) / 2.0


def gaussian_ring(target_size: int, source_size: int, sigma_rad: float = 1.0) -> np.ndarray:
    """``exp(-d_ij^2 / (2 sigma^2))`` with d the angular distance between cells on a ring."""
    if target_size != source_size:
        raise CircuitError(f"rule 'gaussian_ring' needs equal sizes, got {source_size} -> {target_size}")
    angles = 2.0 * np.pi * np.arange(target_size) / target_size
    difference = angle_difference_rad(angles[:, None], angles[None, :])
    return np.exp(-(difference**2) / (2.0 * sigma_rad**2))


RULES: dict[str, Callable[..., np.ndarray]] = {
    "one_to_one": one_to_one,
    "all_to_all": all_to_all,
    "tile": tile,
    "fold": fold,
    "roll": roll,
    "cosine_ring": cosine_ring,
    "gaussian_ring": gaussian_ring,
}


def make_weights(rule: str, target_size: int, source_size: int, params: dict | None = None) -> np.ndarray:
    """Generate the weight matrix of a named rule, or raise :class:`CircuitError`."""
    if rule not in RULES:
        raise CircuitError(f"unknown connectivity rule {rule!r}; allowed: {', '.join(RULES)}")
    try:
        return RULES[rule](target_size, source_size, **(params or {}))
    except TypeError as error:
        raise CircuitError(f"rule {rule!r}: bad parameters {params!r} ({error})") from None
