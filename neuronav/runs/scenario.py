"""The scenario interface: a world, a body, a brain, a protocol, metrics and figures.

A scenario registers under ``neuronav.scenarios`` and is run by the CLI or from Python:

>>> from neuronav.runs.runner import run_scenario
>>> summary = run_scenario("path-integration", trials=10, seed=1, out_dir="runs/pi")  # doctest: +SKIP
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from neuronav.runs.summary_statistics import Statistics


@dataclass
class ScenarioResult:
    """What one run of a scenario produced.

    Attributes
    ----------
    trials : list of dict
        One dict per trial: ``trial``, ``seed``, ``success``, ``status`` (``ok``/``failed``),
        ``error`` (text, empty when ok) and the scenario's metrics (numbers).
    timeseries : dict of str to ndarray
        Recorded signals, each with the trial as its first axis: one row per trial, or per first
        trial for the names in :meth:`Scenario.leading_series`.
    aggregates : dict of str to float
        Metrics defined over all trials rather than per trial (e.g. Stone's tortuosity).
    simulated_time_s : float
        Simulated time of one trial, for real-time factors.
    """

    trials: list[dict]
    timeseries: dict[str, np.ndarray] = field(default_factory=dict)
    aggregates: dict[str, float] = field(default_factory=dict)
    simulated_time_s: float = 0.0


class Scenario(ABC):
    """Base class of registered scenarios.

    Subclasses set ``name``, ``description``, ``config_type`` (a dataclass built with
    :func:`neuronav.config.field`) and ``backends`` (the backend names they run on), and implement
    :meth:`run` and :meth:`figures`.
    """

    name: str = ""
    description: str = ""
    config_type: type = object
    backends: tuple[str, ...] = ()
    default_backend: str = ""
    records_video: bool = False
    # Per-trial metrics that measure the computer, not the simulation (wall times): they are the
    # only numbers allowed to differ between two runs with the same seed.
    timing_metrics: tuple[str, ...] = ()
    # Per-trial columns that name a trial's condition (text allowed, e.g. a gait or the cues used),
    # not measurements: the statistics group by them, the conformance test does not require numbers.
    condition_columns: tuple[str, ...] = ()
    # Metrics that are undefined (NaN) in some trials by definition (a time to arrive for an agent
    # that never arrives); the conformance test requires every other metric to be finite.
    optional_metrics: tuple[str, ...] = ()
    # The most trials one run (or one grid point of a sweep) may ask for: more is surely a typo, and
    # its bookkeeping alone would not fit in memory. A scenario may lower or raise it.
    max_trials: int = 1_000_000

    @abstractmethod
    def run(self, config: Any, *, backend: str, trials: int, seed: int,
            video_path: Path | None = None) -> ScenarioResult:
        """Run ``trials`` seeded trials (trial i uses seed ``seed + i``).

        When ``video_path`` is given (only for scenarios with ``records_video``), write an MP4 of the
        first trial there.
        """

    @abstractmethod
    def figures(self, result: ScenarioResult, config: Any, out_dir: Path) -> list[Path]:
        """Write the scenario's figures into ``out_dir``; return their paths."""

    def check(self, config: Any, backend: str) -> None:
        """Raise :class:`neuronav.errors.ConfigError` when ``config`` cannot run on ``backend``.

        Called for every config of a run or sweep (and every backend of a compare) before anything is
        written or any trial runs, so that an error knowable from the settings alone exits 2 instead
        of failing every trial. The default accepts everything the config's own validation accepted.
        """
        return None

    def check_video(self, config: Any, backend: str) -> None:
        """Raise :class:`neuronav.errors.ConfigError` when ``--video`` cannot film ``config`` on ``backend``
        (a batched protocol with no agent loop to film); called, like :meth:`check`, before any trial runs.
        The default films whatever a scenario with ``records_video`` runs."""
        return None

    def estimate_bytes(self, config: Any, trials: int) -> int | None:
        """Memory (bytes) one batch of ``trials`` trials of ``config`` needs, or None when unknown.

        The runner compares it with the memory available before the first trial and refuses a run
        that cannot fit, naming the chunk size to use instead.
        """
        return None

    def smoke_config(self) -> dict[str, Any]:
        """Overrides that make a very short run, for conformance tests."""
        return {}

    def statistics(self, config: Any) -> Statistics:
        """What the summary's ``statistics`` block compares: the per-trial condition column, the metrics,
        the heading columns (see :class:`~neuronav.runs.summary_statistics.Statistics`). The default:
        one group, every numeric metric."""
        return Statistics()

    def leading_series(self, config: Any, backend: str) -> dict[str, int]:
        """The time series kept for the run's first k trials only (name -> k), e.g. neural activity
        recorded for a few trials, or data shared by all trials stored once (k = 1).

        Every other series holds one row per trial. A batch of trials records these for its own
        first trials; the runner keeps those of trials 0 .. k - 1 whatever the chunking.
        """
        return {}
