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
    heading = heading_rad[:, 0]
    # Built as (2, batch) and returned transposed: the compiled circuit stores cells x agents.
    return np.stack([np.sin(heading), np.cos(heading)]).T


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
    heading = heading_rad[:, 0]
    sin_h, cos_h = np.sin(heading), np.cos(heading)
    vx, vy = velocity.T
    body = np.empty((2, heading.size), heading.dtype)
    np.multiply(vx, sin_h, out=body[0])
    body[0] += vy * cos_h
    np.multiply(vx, cos_h, out=body[1])
    body[1] -= vy * sin_h
    return body.T  # (batch, 2), stored agents-last like the compiled circuit's state


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
