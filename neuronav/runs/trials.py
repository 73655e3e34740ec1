"""Trials of a registered scenario: loading it, checking its backend, running a batch of trials.

The layer below :mod:`neuronav.runs.executors` and :mod:`neuronav.runs.sweep` (which run chunks of trials on
workers) and :mod:`neuronav.runs.runner` (``neuronav run``). It imports none of them.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from neuronav import registry
from neuronav.engine.backend import Capabilities
from neuronav.errors import ConfigError, SimulationError
from neuronav.runs.scenario import Scenario, ScenarioResult


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
    timeseries = merge_timeseries(pieces, trials, leading_series(scenario, config, backend))
    return ScenarioResult(trials=rows, timeseries=timeseries, simulated_time_s=simulated_time_s)


def leading_series(scenario: Scenario, config: Any, backend: str) -> dict[str, int]:
    """The scenario's :meth:`Scenario.leading_series` for ``config`` on ``backend`` ({} when it has none)."""
    hook = getattr(scenario, "leading_series", None)
    return dict(hook(config, backend)) if callable(hook) else {}


def pad_value(dtype: np.dtype) -> Any:
    """What fills a time series where a trial has no sample: NaN for floats (and complex), 0 for
    integers, False for booleans. Scenarios pad unequal trials inside a batch with it too
    (:func:`stack_padded`), so a run's file is the same whatever its chunking."""
    dtype = np.dtype(dtype)
    if dtype.kind in "fc":
        return np.nan
    return False if dtype.kind == "b" else 0


def stack_padded(arrays: Sequence[np.ndarray], dtype: Any = None) -> np.ndarray:
    """Arrays of one rank and unequal shapes as one array (len(arrays), *largest shape), padded at
    the end of every axis with :func:`pad_value`.

    Raises
    ------
    ValueError
        The arrays differ in rank (nothing could be padded to join them).
    """
    arrays = [np.asarray(a) for a in arrays]
    if not arrays:
        raise ValueError("no arrays to stack")
    if len({a.ndim for a in arrays}) > 1:
        raise ValueError(f"ranks differ ({', '.join(str(a.shape) for a in arrays)})")
    dtype = np.result_type(*arrays) if dtype is None else np.dtype(dtype)
    shape = tuple(max(sizes) for sizes in zip(*(a.shape for a in arrays)))
    out = np.full((len(arrays), *shape), pad_value(dtype), dtype)
    for i, array in enumerate(arrays):
        out[(i, *(slice(0, n) for n in array.shape))] = array
    return out


def merge_timeseries(pieces: Iterable[tuple[int, int, dict[str, np.ndarray]]], trials: int,
                     leading: Mapping[str, int] | None = None, problems: list[str] | None = None,
                     ) -> dict[str, np.ndarray]:
    """Join the time series of chunks of trials into those of one run of ``trials`` trials.

    The result is the file one batch of all the trials would give: each chunk pads its trials to its
    own longest, and the merge pads every chunk to the longest of all (:func:`stack_padded`).

    Parameters
    ----------
    pieces : iterable of (first, count, timeseries)
        A chunk's first trial, its number of trials and its time series.
    trials : int
        Trials of the whole run.
    leading : mapping of str to int, optional
        Series kept for the run's first k trials only (:meth:`Scenario.leading_series`): name -> k.
    problems : list of str, optional
        Receives one line per series that could not be joined as it should (left out, or the lowest
        chunk's kept although other chunks differ); without it, they are written to stderr.

    Returns
    -------
    dict of str to ndarray
        For each name, by the shape of the chunks' arrays:

        - declared in ``leading`` with k: the rows of trials 0 .. min(k, trials) - 1;
        - first axis = the chunk's trials (every chunk): one array of shape (trials, ...) in trial
          order, padded along the later axes; trials no chunk covered are :func:`pad_value`;
        - first axis shorter (a scenario records only its first k trials): the rows of the
          trials covered, from trial 0 up to the first trial missing;
        - anything else (not per trial): the array of the chunk with the lowest first trial.
    """
    pieces = sorted(pieces, key=lambda piece: piece[0])
    leading = dict(leading or {})
    names: list[str] = []
    for _, _, series in pieces:
        names += [name for name in series if name not in names]
    merged: dict[str, np.ndarray] = {}
    found: list[str] = []
    for name in names:
        entries = [(first, count, np.asarray(series[name])) for first, count, series in pieces if name in series]
        try:
            if all(a.ndim >= 1 for _, _, a in entries) and (
                    name in leading or all(a.shape[0] <= count for _, count, a in entries)):
                if name in leading:
                    covered = min(leading[name], trials)
                elif all(a.shape[0] == count for _, count, a in entries):
                    covered = trials
                else:  # a scenario that records its first trials only: up to the first missing
                    held = {first + j for first, _, a in entries for j in range(a.shape[0])}
                    covered = next(t for t in range(trials + 1) if t not in held)
                    if not covered and held:
                        found.append(f"{name}: no chunk holds trial 0, so no row was kept")
                merged[name] = _join(entries, covered)
            else:
                merged[name] = entries[0][2]
                if any(a.shape != entries[0][2].shape or not np.array_equal(a, entries[0][2], equal_nan=True)
                       for _, _, a in entries[1:]):
                    found.append(f"{name}: not per trial and not the same in every chunk; kept the first chunk's")
        except (ValueError, TypeError) as error:
            merged.pop(name, None)
            found.append(f"{name}: left out, its chunks cannot be joined ({error})")
    if problems is not None:
        problems += found
    else:
        for line in found:
            sys.stderr.write(f"neuronav: warning: time series {line}\n")
    return merged


def _join(entries: list[tuple[int, int, np.ndarray]], rows: int) -> np.ndarray:
    """The chunks' rows of trials 0 .. rows - 1 as one array padded (:func:`pad_value`) to the largest
    later axes; trials no chunk holds are all padding. ValueError when the chunks differ in rank."""
    if len({a.ndim for _, _, a in entries}) > 1:
        raise ValueError(f"ranks differ ({', '.join(str(a.shape) for _, _, a in entries)})")
    dtype = np.result_type(*(a for _, _, a in entries))
    later = tuple(max(sizes) for sizes in zip(*(a.shape[1:] for _, _, a in entries)))
    out = np.full((rows, *later), pad_value(dtype), dtype)
    for first, _, array in entries:
        kept = max(0, min(array.shape[0], rows - first))
        out[(slice(first, first + kept), *(slice(0, n) for n in array.shape[1:]))] = array[:kept]
    return out


def can_render(backend_class: type) -> bool:
    """Whether a backend class renders cameras, without starting an engine.

    Backends whose capabilities are fixed say so in a class-level :class:`Capabilities`; those
    that compute them on load may set a class attribute ``can_render``.
    """
    capabilities = getattr(backend_class, "capabilities", None)
    if isinstance(capabilities, Capabilities):
        return capabilities.can_render
    return bool(getattr(backend_class, "can_render", True))


def can_film(backend_class: type) -> bool:
    """Whether ``--video`` can film on a backend class: it renders cameras (:func:`can_render`), or it draws
    its ``"follow"`` view itself (a class attribute ``films_follow``: the kinematic backend films from above)."""
    return bool(getattr(backend_class, "films_follow", False)) or can_render(backend_class)


def _failed(trial: int, seed: int, error: BaseException) -> dict:
    message = str(error).splitlines()[0] if str(error) else type(error).__name__
    return {"trial": trial, "seed": seed, "success": False, "status": "failed",
            "error": f"{type(error).__name__}: {message}"}
