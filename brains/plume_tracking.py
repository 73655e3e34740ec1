"""Plume tracking's controller (the I2Bot paper's eq. 3.11, methods "Odour plume tracking"), body-free.

Once per gait cycle the controller reads the odour and the wind at the two antenna tips and the
body's heading, and gives the locomotion command (turn θ in [-1, 1], stride S_l in rad):

- **Orient** (the odour at either antenna is above the threshold T_o = 1e-6): the antenna with more
  odour gives the wind to follow; the desired direction is upwind, against that antenna's wind
  vector, and the ant turns toward it for one gait cycle

      θ   = sign(m − h)
      S_l = min(5° + |(m − h) mod 5°|, 15°)                         (eq. 3.11)

  then walks straight (θ = 0, S_l = 15°) for two gait cycles, without looking, before it decides again.
- **Search** (no odour above the threshold): a random turn on the spot, θ = ±1 with equal
  probability, S_l = 5°.

Angles and signs
----------------
The paper writes m = tan⁻¹(w_y / w_x) and h as angles counter-clockwise from +x, with θ > 0 a left
(counter-clockwise) turn. In neuronav a heading is clockwise from +y (the ``heading`` sensor) and
θ > 0 also turns left, so the paper's ``m − h`` is ``h_cw − m_cw`` here, with both headings
clockwise from +y and the difference wrapped to [−180°, 180°): a desired heading to the right of
the current one (m_cw > h_cw) gives θ = −1, a right turn. "mod 5°" is the floor modulo (Python's
``%``, the value in [0°, 5°)), so S_l lies in [5°, 10°) and the 15° cap never binds; the formula is
kept as written. The upwind heading of a wind (w_x, w_y) is that of the vector (−w_x, −w_y):
``atan2(−w_x, −w_y)`` clockwise from +y.

``stride_rule="divide"`` reads the stride as ``min(5° + |m − h| / 5, 15°)`` instead, the form of the
visual compass's eq. 3.10 (S_l = |Φ(t) − Φ(0)| / 5) and the only reading in which the 15° cap binds
(from a 50° difference on). It is an option, not the default: eq. 3.11 is printed with "%". It turns
the ant faster toward upwind (a 15° stride turns it about 35° per gait cycle on the spot, a 5° one
about 12°), so fewer of its straight runs leave the plume. When both antennae smell the same, the left one's wind is
used (the wind is the same at both tips in neuronav's uniform wind, so nothing depends on it).

The controller keeps one number per agent (straight cycles still to walk) and works on a batch of
N agents in one array operation.
"""

from __future__ import annotations

import numpy as np

from neuronav.angles import wrap_rad
from neuronav.errors import ConfigError

# T_o^p, the odour detection threshold (paper, methods "Odour plume tracking").
ODOUR_THRESHOLD = 1e-6
SEARCH_STRIDE_RAD = np.radians(5.0)
STRAIGHT_STRIDE_RAD = np.radians(15.0)
STRAIGHT_CYCLES = 2
# eq. 3.11's stride: 5° plus the difference's remainder modulo 5°, at most 15°.
MIN_STRIDE_DEG, STRIDE_STEP_DEG, MAX_STRIDE_DEG = 5.0, 5.0, 15.0

# Branch codes of :meth:`PlumeController.step`.
SEARCH, ORIENT, STRAIGHT = 0, 1, 2
BRANCHES = ("search", "orient", "straight")


def upwind_heading_rad(wind_mps) -> np.ndarray:
    """The heading (clockwise from +y, rad) that points against the wind (..., 2) m/s: shape (...)."""
    wind = np.asarray(wind_mps, dtype=float)
    return np.arctan2(-wind[..., 0], -wind[..., 1])


STRIDE_RULES = ("mod", "divide")


def eq_3_11(desired_heading_rad, heading_rad, stride_rule: str = "mod") -> tuple[np.ndarray, np.ndarray]:
    """Turn θ and stride S_l (rad) of eq. 3.11 toward a desired heading (both clockwise from +y).

    ``stride_rule``: ``mod`` (as printed: ``(m − h) mod 5°``) or ``divide`` (``|m − h| / 5``).

    Returns
    -------
    turn : ndarray
        sign of the paper's m − h (here h_cw − m_cw, wrapped): +1 turns left, −1 right, 0 when aligned.
    stride_rad : ndarray
        ``min(5° + |(m − h) mod 5°|, 15°)`` (or ``min(5° + |m − h| / 5, 15°)``) in radians.
    """
    if stride_rule not in STRIDE_RULES:
        raise ConfigError(f"plume stride_rule: expected one of {', '.join(STRIDE_RULES)}, got {stride_rule!r}")
    difference_deg = np.degrees(wrap_rad(np.asarray(heading_rad, float) - np.asarray(desired_heading_rad, float)))
    turn = np.sign(difference_deg)
    extra_deg = np.abs(np.mod(difference_deg, STRIDE_STEP_DEG) if stride_rule == "mod"
                       else difference_deg / STRIDE_STEP_DEG)
    stride_deg = np.minimum(MIN_STRIDE_DEG + extra_deg, MAX_STRIDE_DEG)
    return turn, np.radians(stride_deg)


class PlumeController:
    """Eq. 3.11 plume tracking for N agents, called once per gait cycle.

    Parameters
    ----------
    agents : int
        Batch size N.
    seed : int or np.random.Generator
        Seeds the search turns' signs (one draw per agent per call, used or not, so the sequence of
        draws does not depend on what the agents smell).
    threshold : float
        Odour detection threshold (amount/m³), the paper's 1e-6.
    straight_cycles : int
        Gait cycles walked straight after each orienting cycle (the paper's 2).
    stride_rule : str
        ``mod`` (eq. 3.11 as printed) or ``divide`` (see the module docstring).
    """

    def __init__(self, agents: int = 1, seed: int | np.random.Generator | None = 0,
                 threshold: float = ODOUR_THRESHOLD, straight_cycles: int = STRAIGHT_CYCLES,
                 stride_rule: str = "mod") -> None:
        if not (isinstance(agents, int | np.integer) and agents >= 1):
            raise ConfigError(f"plume controller agents: expected an integer >= 1, got {agents!r}")
        if isinstance(threshold, bool) or not (isinstance(threshold, int | float) and np.isfinite(threshold)
                                               and threshold >= 0):
            raise ConfigError(f"plume controller threshold: expected a finite number >= 0, got {threshold!r}")
        if not (isinstance(straight_cycles, int | np.integer) and straight_cycles >= 0):
            raise ConfigError(f"plume controller straight_cycles: expected an integer >= 0, got {straight_cycles!r}")
        if stride_rule not in STRIDE_RULES:
            raise ConfigError(f"plume controller stride_rule: expected one of {', '.join(STRIDE_RULES)}, "
                              f"got {stride_rule!r}")
        self.agents, self.threshold, self.straight_cycles = int(agents), float(threshold), int(straight_cycles)
        self.stride_rule = stride_rule
        self.rng = np.random.default_rng(seed)
        self.straight_left = np.zeros(self.agents, dtype=int)

    def step(self, odour, wind_mps, heading_rad) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One gait cycle's command.

        Parameters
        ----------
        odour : array (N, 2) or (N, 2, K)
            Concentration at the (left, right) antenna tips; with K odours their sum is smelled.
        wind_mps : array (N, 2, 2)
            Wind (x, y) at the (left, right) antenna tips, m/s.
        heading_rad : array (N,) or (N, 1)
            Heading, clockwise from +y.

        Returns
        -------
        turn : ndarray (N,)
        stride_rad : ndarray (N,)
        branch : ndarray (N,) of int
            :data:`SEARCH`, :data:`ORIENT` or :data:`STRAIGHT` per agent.
        """
        n = self.agents
        odour = np.asarray(odour, dtype=float)
        if odour.ndim == 3:
            odour = odour.sum(axis=2)
        wind = np.asarray(wind_mps, dtype=float)
        heading = np.asarray(heading_rad, dtype=float).reshape(-1)
        if odour.shape != (n, 2) or wind.shape != (n, 2, 2) or heading.shape != (n,):
            raise ConfigError(f"plume controller: expected odour ({n}, 2[, K]), wind ({n}, 2, 2), heading ({n},); "
                              f"got {odour.shape}, {wind.shape}, {heading.shape}")
        signs = np.where(self.rng.random(n) < 0.5, -1.0, 1.0)
        straight = self.straight_left > 0
        smelled = ~straight & (odour.max(axis=1) > self.threshold)
        stronger = np.argmax(odour, axis=1)  # 0 (left) on ties
        desired = upwind_heading_rad(wind[np.arange(n), stronger])
        orient_turn, orient_stride = eq_3_11(desired, heading, self.stride_rule)
        turn = np.where(straight, 0.0, np.where(smelled, orient_turn, signs))
        stride = np.where(straight, STRAIGHT_STRIDE_RAD, np.where(smelled, orient_stride, SEARCH_STRIDE_RAD))
        branch = np.where(straight, STRAIGHT, np.where(smelled, ORIENT, SEARCH))
        self.straight_left = np.where(straight, self.straight_left - 1,
                                      np.where(smelled, self.straight_cycles, 0))
        return turn, stride, branch
