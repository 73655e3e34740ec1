"""A world's odour and wind, computed once in engine-free code and read at the sites a backend reports.

:class:`OdourScene` declares what a :class:`~neuronav.spec.world.World` smells of: trails on the floor
(:mod:`neuronav.senses.odour`) and at most one live filament plume with its wind (:mod:`neuronav.senses.plume`).
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

A plume runs at most :data:`MAX_PLUME_STEPS` steps in all (warm-up included: about 28 h of plume
time at the default step, against minutes in any scenario), and its step is at most
:data:`~neuronav.senses.plume.MAX_PLUME_DT_S`: a longer warm-up or a later time is refused at once
(:class:`~neuronav.errors.ConfigError`) rather than run for hours.

Odour channels
--------------
Sensors read ``n_odours`` channels per site (at least 1): channel k sums every trail with
``odour == k`` (floor concentration, 1 on a trail) and the plume's odour k (amount per m³).
"""

from __future__ import annotations

import numpy as np

from neuronav.errors import ConfigError
from neuronav.senses.odour import query_points
from neuronav.senses.plume import Plume, plume_seed
from neuronav.spec.odour_scene import MAX_PLUME_DT_S, MAX_PLUME_STEPS, PLUME_DT_S, OdourScene, finite_seconds

__all__ = ["MAX_PLUME_DT_S", "MAX_PLUME_STEPS", "PLUME_DT_S", "Chemistry", "OdourScene"]

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
        """A new plume from ``seed`` (None: 0, else an int >= 0), run for the scene's warm-up; trails
        have no state."""
        seed = plume_seed("chemistry reset", seed)
        self._steps_done = 0
        if self.scene.plume is None:
            self.plume = None
            return
        self.plume = Plume(self.scene.plume, seed=0 if seed is None else seed)
        warmup_steps = int(round(self.scene.warmup_s / self.scene.plume_dt_s))
        if warmup_steps:
            self.plume.advance(self.scene.plume_dt_s, warmup_steps)

    def advance_to(self, time_s: float) -> None:
        """Step the plume until it has run every whole plume step up to simulation time ``time_s``.

        ``time_s``: a finite number of seconds >= 0, with the warm-up at most :data:`MAX_PLUME_STEPS`
        plume steps in all (a ConfigError beyond, before any step is run).
        """
        scene = self.scene
        # A hair of tolerance: time kept as a sum of engine steps lands just under a plume step.
        due = np.floor(finite_seconds("chemistry advance_to time_s", time_s) / scene.plume_dt_s + 1e-9)
        if due + np.rint(scene.warmup_s / scene.plume_dt_s) > MAX_PLUME_STEPS:
            raise ConfigError(f"chemistry advance_to time_s: {time_s!r} s and the {scene.warmup_s:g} s warm-up make "
                              f"more than {MAX_PLUME_STEPS} plume steps of {scene.plume_dt_s:g} s")
        if self.plume is None:
            return
        due = int(due)
        if due > self._steps_done:
            self.plume.advance(self.scene.plume_dt_s, due - self._steps_done)
            self._steps_done = due

    def odour_at(self, points_m) -> np.ndarray:
        """Every odour's concentration at points (..., 2 or 3) m: shape (..., n_odours)."""
        points = query_points("odour query points", points_m)
        out = np.zeros(points.shape[:-1] + (self.n_odours,))
        for trail in self.scene.trails:
            out[..., trail.odour] += trail.concentration_at(points)
        if self.plume is not None:
            out[..., : self.plume.n_odours] += self.plume.concentration_at(points)
        return out

    def wind_at(self, points_m) -> np.ndarray:
        """Wind (x, y) m/s at points (..., 2 or 3): shape (..., 2); still air without a plume."""
        points = query_points("wind query points", points_m)
        if self.plume is None:
            return np.zeros(points.shape[:-1] + (2,))
        return self.plume.wind_at(points)
