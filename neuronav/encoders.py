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
    return np.cos(heading_rad - np.asarray(preferred_rad)[None, :])


def heading_vector(heading_rad: np.ndarray) -> np.ndarray:
    """The unit vector of the heading, ``(sin h, cos h)`` (heading clockwise from +y): shape (batch, 2).

    A population reading it through weights whose rows are preferred directions
    ``(sin p_i, cos p_i)`` receives ``cos(h - p_i)``: cosine tuning at the cost of two trig calls
    per agent.
    """
    return np.concatenate([np.sin(heading_rad), np.cos(heading_rad)], axis=1)


def body_velocity(heading_rad: np.ndarray, velocity: np.ndarray) -> np.ndarray:
    """World velocity resolved in the body frame: (forward, rightward), shape (batch, 2).

    Forward is along the heading ``(sin h, cos h)``, rightward 90° clockwise of it
    ``(cos h, -sin h)``. A cell reading it with weights ``(cos o, sin o)`` receives the speed along
    the direction ``h + o`` — Stone et al. 2017's TN cells use o = ±45°.

    Parameters
    ----------
    heading_rad : ndarray, shape (batch, 1)
    velocity : ndarray, shape (batch, 2)
        World-frame (vx, vy).
    """
    sin_h, cos_h = np.sin(heading_rad), np.cos(heading_rad)
    forward = velocity[:, :1] * sin_h + velocity[:, 1:2] * cos_h
    rightward = velocity[:, :1] * cos_h - velocity[:, 1:2] * sin_h
    return np.concatenate([forward, rightward], axis=1)


def one_hot(index: np.ndarray, size: int, offset: int = 0) -> np.ndarray:
    """A one-hot code of ``round(index) + offset`` (clipped into range): shape (batch, size)."""
    position = np.clip(np.rint(index[:, 0]).astype(int) + offset, 0, size - 1)
    code = np.zeros((index.shape[0], size))
    code[np.arange(index.shape[0]), position] = 1.0
    return code


ENCODERS: dict[str, Callable[..., np.ndarray]] = {
    "identity": identity,
    "cosine_tuning": cosine_tuning,
    "heading_vector": heading_vector,
    "body_velocity": body_velocity,
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
