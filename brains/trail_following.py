"""Odour trail following (the I2Bot paper's Table 3): two antennae's concentrations -> (turn, stride).

Source: I2Bot paper §2.5.1, Table 3 and the methods' "Odour trail following"; ``docs/parameters.md``
§5. Once per gait cycle the controller reads the odour at the left and right antenna, O_l and O_r,
and their difference O_d = O_l − O_r, and picks one of three states:

=================  ===========================  ==================  ==========
state              condition                    θ (turn)            S_l
=================  ===========================  ==================  ==========
``search``         O_l < T_o and O_r < T_o      −1 or +1 at random  3°
``turn``           otherwise, |O_d| > T_d       O_d / K_d, clipped  4°
``straight``       otherwise                    0                   8°
=================  ===========================  ==================  ==========

θ > 0 turns left in this project (the paper's Table 2 convention), so θ = O_d / K_d turns toward
the antenna that smells more.

Units. The paper's thresholds (T_d = 5, T_o = 900, K_d = 400) are in the units of the Webots
DistanceSensor that read the floor texture. Our trail concentration is dimensionless, in [0, 1]
(1 on the trail, :mod:`neuronav.senses.odour`), so the controller first scales it to sensor units,
``O = sensor_scale · c`` with ``sensor_scale = 1000`` by default: a reading of 1000 on the trail,
0 off it. With that mapping "odour sensed" (T_o = 900) means an antenna is inside the trail's flat
top or the inner part of its raised-cosine edge (c >= 0.9), the dead band (T_d = 5) is a
concentration difference of 0.005, and one antenna on and one off gives O_d / K_d = ±2.5, clipped to
±1: a turn on the spot toward the trail.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neuronav.errors import ConfigError

# The paper's values (Table 3), in DistanceSensor units.
T_D = 5.0
T_O = 900.0
K_D = 400.0
# Sensor units per unit of trail concentration (our choice: the mapping documented above).
SENSOR_SCALE = 1000.0
# Hip swing per state (Table 3), rad.
STRIDE_STRAIGHT_RAD = math.radians(8.0)
STRIDE_TURN_RAD = math.radians(4.0)
STRIDE_SEARCH_RAD = math.radians(3.0)
STATES = ("search", "turn", "straight")


@dataclass(frozen=True)
class TrailFollowing:
    """The Table 3 controller with its thresholds (sensor units) and the concentration scale.

    Parameters
    ----------
    t_d : float
        Dead band on |O_l − O_r| below which the ant walks straight (paper: 5).
    t_o : float
        An antenna smells the trail when its reading is at least this (paper: 900).
    k_d : float
        Turn gain: θ = O_d / k_d, clipped to [−1, 1] (paper: 400).
    sensor_scale : float
        Sensor units per unit of concentration (O = sensor_scale · c).
    """

    t_d: float = T_D
    t_o: float = T_O
    k_d: float = K_D
    sensor_scale: float = SENSOR_SCALE

    def __post_init__(self) -> None:
        for name in ("t_d", "t_o", "k_d", "sensor_scale"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise ConfigError(f"trail following {name}: expected a finite number, got {value!r}")
        if self.t_d < 0:
            raise ConfigError(f"trail following t_d: expected a number >= 0, got {self.t_d!r}")
        for name in ("t_o", "k_d", "sensor_scale"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"trail following {name}: expected a number > 0, got {getattr(self, name)!r}")

    def state(self, left: float, right: float) -> str:
        """Which row of Table 3 the concentrations ``left`` and ``right`` (0–1) select."""
        o_left, o_right = self.sensor_scale * float(left), self.sensor_scale * float(right)
        if o_left < self.t_o and o_right < self.t_o:
            return "search"
        if abs(o_left - o_right) > self.t_d:
            return "turn"
        return "straight"

    def __call__(self, left: float, right: float, rng: np.random.Generator) -> tuple[float, float]:
        """The locomotion command for concentrations ``left``, ``right`` at the antennae.

        Parameters
        ----------
        left, right : float
            Trail concentration (dimensionless, 0–1) at the left and right antenna.
        rng : np.random.Generator
            Draws the random turn's sign in the ``search`` state (one draw there, none otherwise).

        Returns
        -------
        turn : float
            θ in [−1, 1], > 0 to the left.
        stride_rad : float
            Hip swing S_l, rad.
        """
        state = self.state(left, right)
        if state == "search":
            return (1.0 if rng.random() < 0.5 else -1.0), STRIDE_SEARCH_RAD
        if state == "turn":
            o_d = self.sensor_scale * (float(left) - float(right))
            return float(np.clip(o_d / self.k_d, -1.0, 1.0)), STRIDE_TURN_RAD
        return 0.0, STRIDE_STRAIGHT_RAD
