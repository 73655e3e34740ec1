"""Run a registered scenario and write its run directory (what ``neuronav run`` does)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from neuronav import registry
from neuronav.backend import Capabilities
from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.rundir import write_run_directory
from neuronav.scenario import Scenario, ScenarioResult


def load_scenario(name: str) -> Scenario:
    """An instance of the scenario registered as ``name``."""
    return registry.load("scenario", name)()


def check_backend(scenario: Scenario, backend: str | None) -> str:
    """The backend to use: ``backend`` or the scenario's default, checked to be supported and installed."""
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


def check_counts(trials: Any, seed: Any) -> None:
    if not isinstance(trials, (int, np.integer)) or isinstance(trials, bool) or trials < 1:
        raise ConfigError(f"trials must be a positive integer, got {trials!r}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")


def run_trials(scenario: Scenario, config: Any, backend: str, trials: int, seed: int,
               video_path: Path | None = None) -> ScenarioResult:
    """Run all trials at once; if that fails, run them one by one so one bad trial loses no other.

    Trial i always uses seed ``seed + i``, so a trial re-run alone gives the same numbers.
    """
    try:
        return scenario.run(config, backend=backend, trials=trials, seed=seed, video_path=video_path)
    except Exception as batch_error:  # noqa: BLE001 - a failed batch falls back to single trials
        if trials == 1:
            return ScenarioResult(trials=[_failed(0, seed, batch_error)])
    results: list[ScenarioResult | None] = []
    rows: list[dict] = []
    for i in range(trials):
        try:
            single = scenario.run(config, backend=backend, trials=1, seed=seed + i,
                                  video_path=video_path if i == 0 else None)
            row = dict(single.trials[0], trial=i)
            results.append(single)
        except Exception as error:  # noqa: BLE001 - recorded as this trial's failure
            row = _failed(i, seed + i, error)
            results.append(None)
        rows.append(row)
    finished = [r for r in results if r is not None]
    timeseries: dict[str, np.ndarray] = {}
    if finished and len(finished) == trials:
        for key in finished[0].timeseries:
            try:
                timeseries[key] = np.concatenate([r.timeseries[key] for r in finished], axis=0)
            except (ValueError, KeyError):
                pass
    return ScenarioResult(trials=rows, timeseries=timeseries,
                          simulated_time_s=finished[0].simulated_time_s if finished else 0.0)


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


def run_scenario(
    name: str, *, backend: str | None = None, trials: int = 1, seed: int = 0,
    overrides: Iterable[str] | dict[str, Any] = (), out_dir: str | Path | None = None,
    video: bool = False, command: list[str] | None = None,
) -> dict:
    """Run scenario ``name`` and write its run directory; return the summary (also in summary.json)."""
    scenario = load_scenario(name)
    backend = check_backend(scenario, backend)
    check_counts(trials, seed)
    config = apply_overrides(scenario.config_type, overrides)
    if video:
        if not can_render(registry.load("backend", backend)):
            raise ConfigError(f"--video needs a backend with cameras; {backend!r} has none")
        if not scenario.records_video:
            raise ConfigError(f"scenario {name!r} does not record video")
    out_dir = Path(out_dir) if out_dir is not None else Path("runs") / f"{name}-{backend}-seed{seed}"
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    result = run_trials(scenario, config, backend, int(trials), int(seed),
                        video_path=out_dir / "trial0.mp4" if video else None)
    wall_time_s = time.perf_counter() - started
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = scenario.figures(result, config, out_dir) if any(
        t.get("status", "ok") == "ok" for t in result.trials) else []
    return write_run_directory(
        out_dir, scenario=name, backend=backend, seed=int(seed), config=dataclasses.asdict(config),
        trials=result.trials, aggregates=result.aggregates, timeseries=result.timeseries,
        wall_time_s=wall_time_s, simulated_time_s=result.simulated_time_s, figures=figures, command=command,
    ) | {"out_dir": str(out_dir)}
