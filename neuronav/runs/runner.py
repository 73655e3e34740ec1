"""Run a registered scenario and write its run directory (what ``neuronav run`` does).

The top of the run stack: ``neuronav.runs.cli -> neuronav.runs.runner -> neuronav.runs.sweep -> neuronav.runs.executors
-> neuronav.runs.trials``; nothing below imports it. The trial-level helpers (:func:`load_scenario`,
:func:`run_trials`, :func:`merge_timeseries`, ...) live in :mod:`neuronav.runs.trials` and are
re-exported here.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from neuronav.runs.scenario import Scenario
from neuronav.runs.sweep import execute
from neuronav.runs.trials import (  # noqa: F401 - re-exported: the runner's public names
    can_render,
    check_backend,
    check_counts,
    load_scenario,
    merge_timeseries,
    run_trials,
)

__all__ = ["can_render", "check_backend", "check_counts", "load_scenario", "merge_timeseries", "run_scenario",
           "run_trials"]


def run_scenario(
    name: str | Scenario, *, backend: str | None = None, trials: int = 1, seed: int = 0,
    overrides: Iterable[str] | dict[str, Any] = (), out_dir: str | Path | None = None,
    video: bool = False, command: list[str] | None = None, config_file: str | Path | None = None,
    workers: int | None = None, scheduler: Any = None, chunk_size: int | None = None,
    progress: bool | None = None, figures: bool = True,
) -> dict:
    """Run scenario ``name`` and write its run directory; return the summary (also in summary.json).

    With one worker (the default without a ``scheduler``) all trials run as one batch in this
    process. More workers, or a Dask ``scheduler`` (default: as many chunks as its threads want), run
    chunks of trials in parallel (:mod:`neuronav.runs.sweep`, which also makes the run resumable:
    rerunning the same command skips the trials already finished). Options as in
    :func:`neuronav.runs.sweep.execute`.
    """
    return execute(name, grid=None, backend=backend, trials=trials, seed=seed, overrides=overrides,
                   config_file=config_file, out_dir=out_dir, workers=workers, scheduler=scheduler,
                   chunk_size=chunk_size, progress=progress, figures=figures, video=video, command=command)
