"""A world's odour and wind, computed once in engine-free code and read at the sites a backend reports.

:class:`OdourScene` declares what a :class:`~neuronav.world.World` smells of: trails on the floor
(:mod:`neuronav.odour`) and at most one live filament plume with its wind (:mod:`neuronav.plume`).
:class:`Chemistry` is its running state inside a backend: every backend builds one from the world at
``load``, seeds it at ``reset`` and reads it at its odour and wind sites, so the same seed gives the
same plume on every backend, whatever the engine's timestep.

The plume's own clock
---------------------
The plume steps at its own ``plume_dt_s`` (Farrell et al.'s 0.01 s), not at the engine's timestep:
before a reading at simulation time t, it is advanced by as many whole steps as fit in t (plus the
warm-up). A plume step costs about as much as a physics step of the ant, so stepping it at a 1 ms
engine timestep would double the cost of a trial; at 10 ms it is a tenth of that, and the plume is
the same sequence of states on every backend (a reading may lag the engine by less than one plume
step). A trial that never reads odour or wind never steps its plume.

Odour channels
--------------
Sensors read ``n_odours`` channels per site (at least 1): channel k sums every trail with
``odour == k`` (floor concentration, 1 on a trail) and the plume's odour k (amount per m³).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neuronav.errors import ConfigError
from neuronav.plume import Plume, PlumeConfig

# Farrell et al. 2002's timestep (docs/parameters.md §5).
PLUME_DT_S = 0.01


@dataclass(frozen=True)
class OdourScene:
    """What a world smells of.

    Parameters
    ----------
    trails : tuple
        Floor odour fields: :class:`~neuronav.odour.PolylineTrail` or :class:`~neuronav.odour.ImageTrail`
        (anything with ``concentration_at(points_m)`` and an ``odour`` index). Physics backends draw
        them on the floor.
    plume : PlumeConfig or None
        A live filament plume and its wind (None: still air, no plume).
    warmup_s : float
        How long the plume runs before the trial starts (the paper lets it fill the arena first).
    plume_dt_s : float
        The plume's own timestep, seconds.
    """

    trails: tuple = ()
    plume: PlumeConfig | None = None
    warmup_s: float = 0.0
    plume_dt_s: float = PLUME_DT_S

    def __post_init__(self) -> None:
        trails = tuple(self.trails) if isinstance(self.trails, list | tuple) else (self.trails,)
        for index, trail in enumerate(trails):
            if not callable(getattr(trail, "concentration_at", None)) or not hasattr(trail, "odour"):
                raise ConfigError(f"odour trail {index}: expected a PolylineTrail or ImageTrail, "
                                  f"got {type(trail).__name__}")
        object.__setattr__(self, "trails", trails)
        if self.plume is not None and not isinstance(self.plume, PlumeConfig):
            raise ConfigError(f"odour plume: expected a PlumeConfig or None, got {type(self.plume).__name__}")
        for label in ("warmup_s", "plume_dt_s"):
            value = getattr(self, label)
            if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value) or value < 0:
                raise ConfigError(f"odour {label}: expected a finite number of seconds >= 0, got {value!r}")
        if not self.plume_dt_s > 0:
            raise ConfigError(f"odour plume_dt_s: expected a number of seconds > 0, got {self.plume_dt_s!r}")

    @property
    def n_odours(self) -> int:
        """Channels a sensor reads: one more than the largest odour index, at least 1."""
        indices = [trail.odour for trail in self.trails]
        if self.plume is not None:
            indices.append(self.plume.n_odours - 1)
        return 1 + max(indices, default=0)

    @property
    def is_empty(self) -> bool:
        """No trail and no plume: every reading is 0."""
        return not self.trails and self.plume is None


class Chemistry:
    """The running odour and wind of one :class:`OdourScene`.

    Parameters
    ----------
    scene : OdourScene
        What to simulate.

    Examples
    --------
    >>> chemistry = Chemistry(world.odour)
    >>> chemistry.reset(seed=3)                  # a fresh plume, warmed up
    >>> chemistry.advance_to(backend.time)       # catch up with the engine's clock
    >>> chemistry.odour_at(tips_m)               # (..., 3) -> (..., n_odours)
    """

    def __init__(self, scene: OdourScene) -> None:
        if not isinstance(scene, OdourScene):
            raise ConfigError(f"chemistry: expected an OdourScene, got {type(scene).__name__}")
        self.scene = scene
        self.n_odours = scene.n_odours
        self.plume: Plume | None = None
        self._steps_done = 0
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """A new plume from ``seed`` (None: 0), run for the scene's warm-up; trails have no state."""
        self._steps_done = 0
        if self.scene.plume is None:
            self.plume = None
            return
        self.plume = Plume(self.scene.plume, seed=0 if seed is None else int(seed))
        warmup_steps = int(round(self.scene.warmup_s / self.scene.plume_dt_s))
        if warmup_steps:
            self.plume.advance(self.scene.plume_dt_s, warmup_steps)

    def advance_to(self, time_s: float) -> None:
        """Step the plume until it has run every whole plume step up to simulation time ``time_s``."""
        if self.plume is None:
            return
        # A hair of tolerance: time kept as a sum of engine steps lands just under a plume step.
        due = int(np.floor(float(time_s) / self.scene.plume_dt_s + 1e-9))
        if due > self._steps_done:
            self.plume.advance(self.scene.plume_dt_s, due - self._steps_done)
            self._steps_done = due

    def odour_at(self, points_m) -> np.ndarray:
        """Every odour's concentration at points (..., 2 or 3) m: shape (..., n_odours)."""
        points = np.asarray(points_m, dtype=float)
        if points.ndim < 1 or points.shape[-1] not in (2, 3):
            raise ConfigError(f"odour query points: expected shape (..., 2) or (..., 3), got {points.shape}")
        out = np.zeros(points.shape[:-1] + (self.n_odours,))
        for trail in self.scene.trails:
            out[..., trail.odour] += trail.concentration_at(points)
        if self.plume is not None:
            out[..., : self.plume.n_odours] += self.plume.concentration_at(points)
        return out

    def wind_at(self, points_m) -> np.ndarray:
        """Wind (x, y) m/s at points (..., 2 or 3): shape (..., 2); still air without a plume."""
        points = np.asarray(points_m, dtype=float)
        if points.ndim < 1 or points.shape[-1] not in (2, 3):
            raise ConfigError(f"wind query points: expected shape (..., 2) or (..., 3), got {points.shape}")
        if self.plume is None:
            return np.zeros(points.shape[:-1] + (2,))
        return self.plume.wind_at(points)
