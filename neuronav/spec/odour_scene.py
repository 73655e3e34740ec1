"""What a world smells of: its odour trails and live plume, as a description (data).

:class:`OdourScene` is the ``odour`` of a :class:`~neuronav.spec.world.World`. Its trails are anything
with ``concentration_at(points_m)`` and an ``odour`` index (:class:`~neuronav.senses.odour.PolylineTrail`,
:class:`~neuronav.senses.odour.ImageTrail`), its plume a :class:`~neuronav.senses.plume.PlumeConfig`;
the running state they describe lives in :mod:`neuronav.senses.chemistry`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neuronav.errors import ConfigError, real_or_nan

# Farrell et al. 2002's timestep (docs/parameters.md §5).
PLUME_DT_S = 0.01
# The most plume steps one trial runs, warm-up included (about 28 h of plume at the default step).
MAX_PLUME_STEPS = 10 ** 7
# The longest plume step, seconds.
MAX_PLUME_DT_S = 1.0


def finite_seconds(label: str, value) -> float:
    """A finite number of seconds >= 0, or a ConfigError naming ``label``."""
    number = real_or_nan(value)
    if not (np.isfinite(number) and number >= 0):
        raise ConfigError(f"{label}: expected a finite number of seconds >= 0, got {value!r}")
    return number


@dataclass(frozen=True)
class OdourScene:
    """What a world smells of.

    Parameters
    ----------
    trails : tuple
        Floor odour fields: :class:`~neuronav.senses.odour.PolylineTrail` or :class:`~neuronav.senses.odour.ImageTrail`
        (anything with ``concentration_at(points_m)`` and an ``odour`` index). Physics backends draw
        them on the floor.
    plume : PlumeConfig or None
        A live filament plume and its wind (None: still air, no plume).
    warmup_s : float
        How long the plume runs before the trial starts (the paper lets it fill the arena first);
        at most :data:`MAX_PLUME_STEPS` plume steps.
    plume_dt_s : float
        The plume's own timestep, seconds (in (0, :data:`~neuronav.senses.plume.MAX_PLUME_DT_S`]).
    """

    trails: tuple = ()
    plume: PlumeConfig | None = None  # noqa: F821 - neuronav.senses.plume.PlumeConfig, a description
    warmup_s: float = 0.0
    plume_dt_s: float = PLUME_DT_S

    def __post_init__(self) -> None:
        trails = tuple(self.trails) if isinstance(self.trails, list | tuple) else (self.trails,)
        for index, trail in enumerate(trails):
            if not callable(getattr(trail, "concentration_at", None)) or not hasattr(trail, "odour"):
                raise ConfigError(f"odour trail {index}: expected a PolylineTrail or ImageTrail, "
                                  f"got {type(trail).__name__}")
        object.__setattr__(self, "trails", trails)
        if self.plume is not None and not _is_plume_config(self.plume):
            raise ConfigError(f"odour plume: expected a PlumeConfig or None, got {type(self.plume).__name__}")
        for label in ("warmup_s", "plume_dt_s"):
            object.__setattr__(self, label, finite_seconds(f"odour {label}", getattr(self, label)))
        if not 0 < self.plume_dt_s <= MAX_PLUME_DT_S:
            raise ConfigError(f"odour plume_dt_s: expected a number of seconds in (0, {MAX_PLUME_DT_S:g}], "
                              f"got {self.plume_dt_s!r}")
        if np.rint(self.warmup_s / self.plume_dt_s) > MAX_PLUME_STEPS:
            raise ConfigError(f"odour warmup_s: {self.warmup_s:g} s is more than {MAX_PLUME_STEPS} steps of "
                              f"plume_dt_s {self.plume_dt_s:g} s (at most {MAX_PLUME_STEPS * self.plume_dt_s:g} s)")

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


def _is_plume_config(plume) -> bool:
    """Whether ``plume`` is a :class:`~neuronav.senses.plume.PlumeConfig` (its sources, wind and odour count);
    checked by what it holds, since the plume's model lives in :mod:`neuronav.senses`."""
    return (type(plume).__name__ == "PlumeConfig" and hasattr(plume, "sources") and hasattr(plume, "wind")
            and isinstance(getattr(plume, "n_odours", None), int))
