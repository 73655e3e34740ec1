"""Trial-to-trial variability that real ants and rigs have, drawn from each trial's own seed.

Every scenario's trials differ through seeded sources (start jitter, sensor noise, motor noise), each
a setting with its unit and a documented default; ``variability=off`` switches them all off and gives
the paper's exact protocol. This module holds what the scenarios share:

- :func:`variability_field`: the ``variability`` setting (``on`` by default, or ``off``);
- :func:`trial_generators`: one generator per trial and per noise source, seeded from the trial's
  seed and the source's name, so a trial draws the same numbers whatever the batch, chunk or worker
  it runs in, and two sources never share a stream;
- :func:`normal_per_trial`: a batch of draws, one row per trial, each row from that trial's generator;
- :func:`jitter_start`: a start position and heading moved by a seeded offset.

Sizes are each scenario's own settings (with their sources in ``docs/parameters.md``); they are used
only when ``variability`` is ``on``.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence

import numpy as np

from neuronav.config import field

VARIABILITY_CHOICES = ("on", "off")


def variability_field():
    """``variability``: ``on`` (seeded start jitter, sensor and motor noise, each set by its own
    setting) or ``off`` (every such source off: the paper's exact protocol, identical trials)."""
    return field("on", "trial-to-trial variability: on (seeded start jitter, sensor and motor noise, sized by "
                       "their own settings) or off (the paper's exact protocol: trials repeat)",
                 choices=VARIABILITY_CHOICES)


def is_on(config) -> bool:
    """Whether ``config`` (a scenario config with a ``variability`` field) asks for variability."""
    return getattr(config, "variability", "off") == "on"


def source_id(source: str) -> int:
    """A stable number for the noise source's name (the same on every machine and Python version)."""
    return zlib.crc32(source.encode("utf-8"))


def trial_generators(seeds: Sequence[int] | np.ndarray, source: str) -> list[np.random.Generator]:
    """One generator per trial seed for the noise source ``source`` (e.g. ``"start"``, ``"odour"``).

    Seeded by (trial seed, source): a trial's draws do not depend on the other trials of its batch,
    and the sources of one trial are independent streams.
    """
    key = source_id(source)
    return [np.random.default_rng([int(seed), key]) for seed in np.asarray(seeds, dtype=np.int64).reshape(-1)]


def normal_per_trial(generators: Sequence[np.random.Generator], shape: tuple[int, ...] = (),
                     scale: float = 1.0) -> np.ndarray:
    """Normal draws of mean 0 and standard deviation ``scale``, shape (trials, *shape): row i from
    generator i (0 when ``scale`` is 0, without drawing)."""
    if scale == 0.0:
        return np.zeros((len(generators), *shape))
    return np.stack([g.normal(0.0, scale, size=shape) for g in generators]) if generators else np.zeros((0, *shape))


def jitter_start(generators: Sequence[np.random.Generator], position_m: np.ndarray, heading_rad: np.ndarray,
                 position_sd_m: float, heading_sd_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Start positions (trials, 2) m and headings (trials,) rad, each moved by a normal offset of the
    given standard deviation drawn from the trial's generator (position first, then heading)."""
    position = np.array(position_m, dtype=float, copy=True).reshape(len(generators), 2)
    heading = np.array(heading_rad, dtype=float, copy=True).reshape(len(generators))
    position += normal_per_trial(generators, (2,), position_sd_m)
    heading += normal_per_trial(generators, (), heading_sd_rad)
    return position, heading
