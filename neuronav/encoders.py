"""Encoders: how an input population turns sensor port values into its activity.

An input population reads one or more ports and applies a named encoder, vectorised over the
batch. Encoders are pure functions of the port arrays, each of shape (batch, *port_shape).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from neuronav.errors import CircuitError


def identity(*ports: np.ndarray) -> np.ndarray:
    """The port values, flattened per agent and concatenated: shape (batch, total)."""
    return np.concatenate([p.reshape(p.shape[0], -1) for p in ports], axis=1)


def cosine_tuning(heading_rad: np.ndarray, preferred_rad: np.ndarray) -> np.ndarray:
    """``cos(heading - preferred_i)`` for each cell i: a population tuned to heading.

    Parameters
    ----------
    heading_rad : ndarray, shape (batch, 1)
    preferred_rad : ndarray, shape (size,)
    """
    preferred_rad = np.asarray(preferred_rad)
    if heading_rad.shape[0] < 32:  # small batches: one call is cheapest
        return np.cos(heading_rad - preferred_rad)
    # cos(h - p) = cos h cos p + sin h sin p: two trig calls per agent instead of one per cell.
    return np.cos(heading_rad) * np.cos(preferred_rad) + np.sin(heading_rad) * np.sin(preferred_rad)


def heading_flow(
    heading_rad: np.ndarray, velocity: np.ndarray, preferred_offsets_rad: np.ndarray
) -> np.ndarray:
    """World velocity projected onto directions at fixed offsets from the heading (TN cells).

    Heading is measured clockwise from +y, so a direction ``d`` is the unit vector
    ``(sin d, cos d)``. Stone et al. 2017 use offsets of +45 deg and -45 deg.

    Parameters
    ----------
    heading_rad : ndarray, shape (batch, 1)
    velocity : ndarray, shape (batch, 2)
        World-frame (vx, vy).
    preferred_offsets_rad : ndarray, shape (size,)
    """
    # v . (sin(h + o), cos(h + o)) = cos o * forward + sin o * rightward, with the velocity
    # resolved along the heading (forward) and 90 degrees clockwise of it (rightward).
    sin_h, cos_h = np.sin(heading_rad), np.cos(heading_rad)
    forward = velocity[:, :1] * sin_h + velocity[:, 1:2] * cos_h
    rightward = velocity[:, :1] * cos_h - velocity[:, 1:2] * sin_h
    offsets = np.asarray(preferred_offsets_rad)
    return forward * np.cos(offsets) + rightward * np.sin(offsets)


def one_hot(index: np.ndarray, size: int, offset: int = 0) -> np.ndarray:
    """A one-hot code of ``round(index) + offset`` (clipped into range): shape (batch, size)."""
    position = np.clip(np.rint(index[:, 0]).astype(int) + offset, 0, size - 1)
    code = np.zeros((index.shape[0], size))
    code[np.arange(index.shape[0]), position] = 1.0
    return code


ENCODERS: dict[str, Callable[..., np.ndarray]] = {
    "identity": identity,
    "cosine_tuning": cosine_tuning,
    "heading_flow": heading_flow,
    "one_hot": one_hot,
}


def get_encoder(population: str, name: str) -> Callable[..., np.ndarray]:
    """Look an encoder up by name, or raise :class:`CircuitError` listing the allowed names."""
    try:
        return ENCODERS[name]
    except KeyError:
        raise CircuitError(
            f"input population {population!r}: unknown encoder {name!r}; allowed: {', '.join(ENCODERS)}"
        ) from None
