"""Angles on the circle: one turn's wrap, and the signed difference of two directions.

Two forms, each written once, because they differ in the last bits and the callers' numbers depend
on them (a heading fed back into a trajectory must not move by one bit when its code moves):

- :func:`wrap_rad` shifts by π and takes the remainder of a turn: the result lies in [−π, π) (π itself
  maps to −π). The shift rounds away what lies below π's last bit: ``wrap_rad(1e-20)`` is 0.
- :func:`angle_difference_rad` goes through the unit circle, ``arg(exp(i (a − b)))``: the result lies
  in [−π, π] (a difference of ±π keeps its sign), and a small difference comes back exactly
  (``arg(1 + i x) = x`` for tiny x: the difference 1e-20 stays 1e-20).
"""

from __future__ import annotations

import numpy as np


def wrap_rad(angle_rad):
    """Angles wrapped to one turn about zero, [−π, π).

    Parameters
    ----------
    angle_rad : float or array_like
        Angles (rad), any size and shape.

    Returns
    -------
    ndarray of float
        ``(angle + π) mod 2π − π``, the shape of ``angle_rad`` (a 0-d array for a scalar).
    """
    return (np.asarray(angle_rad, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def angle_difference_rad(a_rad, b_rad):
    """The signed smallest rotation from direction ``b_rad`` to ``a_rad``, in [−π, π].

    Parameters
    ----------
    a_rad, b_rad : float or array_like
        Directions (rad); they broadcast against each other.

    Returns
    -------
    ndarray of float
        ``arg(exp(i (a − b)))``: positive when ``a`` lies on the positive side of ``b`` (the side
        angles grow toward), exact for differences much smaller than a turn.
    """
    return np.angle(np.exp(1j * (np.asarray(a_rad, dtype=float) - np.asarray(b_rad, dtype=float))))
