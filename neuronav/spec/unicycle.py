"""A body's unicycle calibration: (turn, stride) -> (forward speed, turn rate), as data.

The kinematic backend moves a point agent as a unicycle driven by the locomotion command (``turn`` θ
in [-1, 1], ``stride`` = hip swing S_l in rad). How fast a body walks and turns for each command is a
property of the body and its gait, measured on a physics engine: a body ships its table (the desert
ant's: ``bodies/desert_ant/unicycle_mujoco.json``) and registers a loader under the entry-point group
``neuronav.unicycle_calibrations`` by the body's name, so the kinematic backend finds it by name
(:func:`neuronav.registry.load`) without importing ``bodies/``.

The table's file format (JSON, written by ``python -m neuronav.scenarios.tools.calibrate_unicycle``):
``turn`` (T,), ``stride_rad`` (S,), ``speed_m_s`` and ``turn_rate_rad_s`` (T, S) nested lists and a
``source`` string. :meth:`UnicycleCalibration.rates` is the one bilinear interpolation of it that every
user (the kinematic backend's step, the learning tasks' foraging walk) calls.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from neuronav.errors import ConfigError


@dataclass(frozen=True)
class UnicycleCalibration:
    """(turn, stride) -> (forward speed, turn rate) on a grid.

    Attributes
    ----------
    turn : ndarray, shape (T,)
        Rotation configuration θ, increasing, covering [-1, 1].
    stride_rad : ndarray, shape (S,)
        Hip swing S_l in rad, increasing.
    speed_m_s : ndarray, shape (T, S)
    turn_rate_rad_s : ndarray, shape (T, S)
        Positive turns clockwise (toward increasing heading).
    source : str
        Where the numbers come from.
    """

    turn: np.ndarray
    stride_rad: np.ndarray
    speed_m_s: np.ndarray
    turn_rate_rad_s: np.ndarray
    source: str

    def rates(self, turn, stride_rad) -> tuple[np.ndarray, np.ndarray]:
        """Forward speed (m/s) and turn rate (rad/s, clockwise positive) for commands of shape (N,).

        ``turn`` is clipped to [-1, 1] and ``stride_rad`` to [0, the table's largest stride], then both
        tables are interpolated bilinearly (extrapolated linearly should the grid not reach ±1).
        Each command's result depends on that command alone, whatever N.
        """
        turn = np.clip(turn, -1.0, 1.0)
        stride = np.clip(stride_rad, 0.0, self.stride_rad[-1])
        query = np.stack([np.asarray(turn, float).reshape(-1), np.asarray(stride, float).reshape(-1)], axis=1)
        speed, turn_rate = self._interpolators
        return speed(query), turn_rate(query)

    @cached_property
    def _interpolators(self) -> tuple:
        """The speed and turn-rate interpolators, built on first use (scipy is imported only then)."""
        from scipy.interpolate import RegularGridInterpolator  # lazily: start-up cost

        grid = (self.turn, self.stride_rad)
        return (RegularGridInterpolator(grid, self.speed_m_s, bounds_error=False, fill_value=None),
                RegularGridInterpolator(grid, self.turn_rate_rad_s, bounds_error=False, fill_value=None))


def load_calibration(path: Path) -> UnicycleCalibration:
    """A calibration table written by ``python -m neuronav.scenarios.tools.calibrate_unicycle``.

    Raises
    ------
    ConfigError
        The file cannot be read, lacks a key, or its tables do not have the grid's shape (T, S).
    """
    try:
        table = json.loads(Path(path).read_text())
        calibration = UnicycleCalibration(
            turn=np.array(table["turn"], float), stride_rad=np.array(table["stride_rad"], float),
            speed_m_s=np.array(table["speed_m_s"], float), turn_rate_rad_s=np.array(table["turn_rate_rad_s"], float),
            source=str(table["source"]),
        )
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ConfigError(f"unicycle calibration {path}: cannot be read ({error})") from None
    expected = (calibration.turn.size, calibration.stride_rad.size)
    if calibration.speed_m_s.shape != expected or calibration.turn_rate_rad_s.shape != expected:
        raise ConfigError(f"unicycle calibration {path}: tables must have shape {expected}")
    return calibration
