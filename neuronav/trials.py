"""Trials of a registered scenario: loading it, checking its backend, running a batch of trials.

The layer below :mod:`neuronav.executors` and :mod:`neuronav.sweep` (which run chunks of trials on
workers) and :mod:`neuronav.runner` (``neuronav run``). It imports none of them.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from neuronav import registry
from neuronav.backend import Capabilities
from neuronav.errors import ConfigError, SimulationError
from neuronav.scenario import Scenario, ScenarioResult


def load_scenario(name: str) -> Scenario:
    """An instance of the scenario registered as ``name``."""
    return registry.load("scenario", name)()


def check_backend(scenario: Scenario, backend: str | None) -> str:
    """The backend to use: ``backend`` or the scenario's default, checked to be supported and installed.

    ``None`` means the scenario's default; an empty or blank name is an error (not the default).
    """
    if backend is not None and (not isinstance(backend, str) or not backend.strip()):
        raise ConfigError(f"--backend needs a backend name, got {backend!r}; registered: "
                          f"{', '.join(registry.names('backend'))}")
    backend = backend or scenario.default_backend
    if backend not in scenario.backends:
        known = registry.names("backend")
        if backend not in known:
            raise ConfigError(f"unknown backend {backend!r}; registered: {', '.join(known)}")
        raise ConfigError(
            f"scenario {scenario.name!r} does not run on backend {backend!r}; "
            f"it runs on: {', '.join(scenario.backends)}"
        )
    registry.load("backend", backend)  # raises a clear error when the engine is not installed
    return backend


def check_counts(trials: Any, seed: Any, max_trials: int | None = None, scenario: str = "") -> None:
    """Raise :class:`ConfigError` unless ``trials`` (at most ``max_trials``) and ``seed`` are usable."""
    if not isinstance(trials, (int, np.integer)) or isinstance(trials, bool) or trials < 1:
        raise ConfigError(f"trials must be a positive integer, got {trials!r}")
    if max_trials is not None and trials > max_trials:
        raise ConfigError(f"trials must be at most {max_trials} per run{f' of {scenario!r}' if scenario else ''}, "
                          f"got {trials}; split the work into several runs with other --seed values")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")


def run_trials(scenario: Scenario, config: Any, backend: str, trials: int, seed: int,
               video_path: Path | None = None) -> ScenarioResult:
    """Run all trials at once; if that fails, run them one by one so one bad trial loses no other.

    Trial i always uses seed ``seed + i``, so a trial re-run alone gives the same numbers. A trial
    that raises on its own is recorded as failed (``status`` "failed", ``error`` the exception's
    first line); the time series of the others are kept (see :func:`merge_timeseries`).
    """
    try:
        return scenario.run(config, backend=backend, trials=trials, seed=seed, video_path=video_path)
    except Exception as batch_error:  # noqa: BLE001 - a failed batch falls back to single trials
        if trials == 1:
            return ScenarioResult(trials=[_failed(0, seed, batch_error)])
    rows: list[dict] = []
    pieces: list[tuple[int, int, dict[str, np.ndarray]]] = []
    simulated_time_s = 0.0
    for i in range(trials):
        try:
            single = scenario.run(config, backend=backend, trials=1, seed=seed + i,
                                  video_path=video_path if i == 0 else None)
            if len(single.trials) != 1:
                raise SimulationError(f"scenario {scenario.name!r} returned {len(single.trials)} rows for 1 trial")
            row = dict(single.trials[0], trial=i)
            pieces.append((i, 1, single.timeseries))
            simulated_time_s = single.simulated_time_s
        except Exception as error:  # noqa: BLE001 - recorded as this trial's failure
            row = _failed(i, seed + i, error)
        rows.append(row)
    return ScenarioResult(trials=rows, timeseries=merge_timeseries(pieces, trials),
                          simulated_time_s=simulated_time_s)


def merge_timeseries(pieces: Iterable[tuple[int, int, dict[str, np.ndarray]]], trials: int) -> dict[str, np.ndarray]:
    """Join the time series of chunks of trials into those of one run of ``trials`` trials.

    Parameters
    ----------
    pieces : iterable of (first, count, timeseries)
        A chunk's first trial, its number of trials and its time series.
    trials : int
        Trials of the whole run.

    Returns
    -------
    dict of str to ndarray
        For each name, by the shape of the chunks' arrays:

        - first axis = the chunk's trials (every chunk): one array of shape (trials, ...) in trial
          order; trials no chunk covered are NaN (0 for integer arrays);
        - first axis shorter (a scenario records only its first k trials): the rows of the
          trials covered, from trial 0 up to the first trial missing;
        - anything else (not per trial): the array of the chunk with the lowest first trial.

        Names whose arrays cannot be joined (different shapes) are left out.
    """
    pieces = sorted(pieces, key=lambda piece: piece[0])
    names: list[str] = []
    for _, _, series in pieces:
        names += [name for name in series if name not in names]
    merged: dict[str, np.ndarray] = {}
    for name in names:
        entries = [(first, count, np.asarray(series[name])) for first, count, series in pieces if name in series]
        try:
            if all(a.ndim >= 1 and a.shape[0] == count for _, count, a in entries):
                dtype = np.result_type(*(a.dtype for _, _, a in entries))
                if dtype.kind not in "fc" and sum(count for _, count, _ in entries) < trials:
                    fill: Any = 0
                else:
                    fill = np.nan if dtype.kind in "fc" else 0
                out = np.full((trials, *entries[0][2].shape[1:]), fill, dtype)
                for first, count, array in entries:
                    out[first:first + count] = array
                merged[name] = out
            elif all(a.ndim >= 1 and a.shape[0] <= count for _, count, a in entries):
                rows = {first + j: array[j] for first, _, array in entries for j in range(array.shape[0])}
                prefix = 0
                while prefix in rows:
                    prefix += 1
                if prefix:
                    merged[name] = np.stack([rows[i] for i in range(prefix)])
            else:
                merged[name] = entries[0][2]
        except (ValueError, TypeError):
            continue  # shapes differ between chunks: not joinable
    return merged


def can_render(backend_class: type) -> bool:
    """Whether a backend class renders cameras, without starting an engine.

    Backends whose capabilities are fixed say so in a class-level :class:`Capabilities`; those
    that compute them on load may set a class attribute ``can_render``.
    """
    capabilities = getattr(backend_class, "capabilities", None)
    if isinstance(capabilities, Capabilities):
        return capabilities.can_render
    return bool(getattr(backend_class, "can_render", True))


def _failed(trial: int, seed: int, error: BaseException) -> dict:
    message = str(error).splitlines()[0] if str(error) else type(error).__name__
    return {"trial": trial, "seed": seed, "success": False, "status": "failed",
            "error": f"{type(error).__name__}: {message}"}
