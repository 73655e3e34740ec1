"""Runs and sweeps: a scenario over a grid of settings × seeded trials, in chunks, resumably.

``neuronav run`` and ``neuronav sweep`` both go through :func:`execute`; ``run`` is a sweep with no
grid.

Tasks
    The trials of one grid point are cut into chunks of consecutive trials; a chunk is one task,
    run as ``scenario.run(config, trials=len(chunk), seed=seed + first)`` (through
    :func:`neuronav.runner.run_trials`, which falls back to one trial at a time when the batch
    raises). Trial numbering and seeds stay global: trial i always uses seed ``seed + i``. The
    chunk size (:func:`chunk_size_for`) gives about :data:`CHUNKS_PER_WORKER` tasks per worker over
    the whole sweep; one worker runs every point's trials in one batch; a scenario may cap it with
    a ``chunk_trials`` attribute; ``--chunk-size`` sets it. Chunks start at multiples of the chunk
    size, so a resumed run computes the same chunks an uninterrupted one would.

Where tasks run
    ``workers == 1``: in this process, one after another (no pool to start). ``workers > 1``: a
    local process pool (:class:`concurrent.futures.ProcessPoolExecutor`, forked on Linux). With
    ``scheduler``: a Dask distributed cluster (``tcp://HOST:PORT``, or a ``distributed.Client``).
    A task that fails as a whole (its worker died, say) is retried one trial per task; a trial
    whose task fails again is recorded as failed with the reason, and the others finish.

Run directory (see also :mod:`neuronav.rundir`)
    ::

        settings.json              what the directory holds; a rerun must match it
        parts/[POINT/]trials-FIRST-LAST.npz   one per finished chunk, written atomically
        [POINT/]summary.json, trials.csv, timeseries.h5, *.png   assembled from the parts
        trials.csv, summary.json, sweep_metrics.png                (sweep: all points)

    POINT is ``key=value_key=value`` (a plain run has no point folders).

Resume rules
    A rerun of the same command (same scenario, backend, seed, trials, resolved config and grid;
    the number of workers, the chunk size and the scheduler may change) skips the trials its parts
    hold and runs only the others; a rerun with other settings is refused. Failed trials count as
    finished (a trial that raises will raise again). The results are assembled from the parts
    after every run; a point whose parts have not changed since its summary was written is kept.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
import re
import sys
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from neuronav import registry
from neuronav.config import build_config, load_config_file, parse_overrides, parse_value
from neuronav.errors import ConfigError, NeuronavError
from neuronav.progress import Progress
from neuronav.rundir import (
    PARTS_DIR,
    DirectoryLock,
    check_settings,
    git_revision,
    json_default,
    list_parts,
    package_versions,
    part_name,
    read_part,
    remove_stale_temporaries,
    trials_csv,
    write_atomic,
    write_part,
    write_run_directory,
)
from neuronav.runner import can_render, check_backend, check_counts, load_scenario, merge_timeseries, run_trials
from neuronav.scenario import Scenario, ScenarioResult

# Tasks per worker over a whole sweep: enough to keep every worker busy to the end.
CHUNKS_PER_WORKER = 4
# A worker count above this is surely a typo.
MAX_WORKERS = 1024
METRICS_FIGURE = "sweep_metrics.png"
MAX_METRICS_IN_FIGURE = 12


def available_cpus() -> int:
    """CPUs this process may run on (the default number of sweep workers)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


# -- the grid -------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class GridPoint:
    """One point of a sweep's grid.

    Attributes
    ----------
    index : int
        Position in the grid (the product of the keys' values, in the order given).
    labels : dict of str to str
        Each grid key's value as text (the canonical form of the typed value).
    name : str
        Folder of the point in the run directory ("" for a plain run).
    config : dataclass
        The point's validated config.
    """

    index: int
    labels: dict
    name: str
    config: Any


def _label(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def parse_grid(config_type: type, grid: Mapping[str, Any] | Sequence[str] | None) -> dict[str, list[tuple[Any, str]]]:
    """The grid as ``{key: [(typed value, label), ...]}``.

    ``grid`` is either the CLI's ``key=v1,v2`` strings or a mapping of keys to values (a list, or
    a comma-separated string). Keys must be config keys; each value is parsed and checked for its
    type; a key given twice, an empty list or a value listed twice is an error.
    """
    if grid is None:
        return {}
    if isinstance(grid, str):
        grid = [grid]
    items: list[tuple[str, Any]] = []
    if isinstance(grid, Mapping):
        items = list(grid.items())
    else:
        for item in grid:
            if not isinstance(item, str) or "=" not in item:
                raise ConfigError(f"--grid expects key=v1,v2,..., got {item!r}")
            key, values = item.split("=", 1)
            items.append((key.strip(), values))
    parsed: dict[str, list[tuple[Any, str]]] = {}
    for key, values in items:
        if key in parsed:
            raise ConfigError(f"--grid {key!r} is given twice; list all its values in one --grid")
        raw = [v for v in values.split(",") if v.strip() != ""] if isinstance(values, str) else values
        if isinstance(raw, (str, bytes)) or not isinstance(raw, Iterable):
            raise ConfigError(f"--grid {key!r}: expected a list of values, got {values!r}")
        raw = list(raw)
        if not raw:
            raise ConfigError(f"--grid {key!r} has no values")
        entries = []
        for value in raw:
            typed = parse_value(config_type, key, value) if isinstance(value, str) else \
                parse_overrides(config_type, {key: value})[key]
            label = _label(typed)
            if any(label == known for _, known in entries):
                raise ConfigError(f"--grid {key!r} lists the value {label} twice")
            entries.append((typed, label))
        parsed[key] = entries
    return parsed


_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]")


def point_name(labels: Mapping[str, str]) -> str:
    """A folder name for a grid point: ``key=value_key=value``, made safe for file systems."""
    text = "_".join(f"{k}={v}" for k, v in labels.items())
    safe = _UNSAFE.sub("_", text)
    if safe != text or len(safe) > 100 or safe.startswith("."):
        import hashlib

        safe = f"{safe.lstrip('.')[:80]}-{hashlib.sha1(text.encode('utf-8', 'surrogatepass')).hexdigest()[:10]}"
    return safe


def grid_points(config_type: type, base: Mapping[str, Any], grid: dict[str, list[tuple[Any, str]]]) -> list[GridPoint]:
    """Every point of the grid, its config validated (the grid's values over ``base``)."""
    keys = list(grid)
    points = []
    for index, combination in enumerate(itertools.product(*(grid[k] for k in keys))):
        values = {k: typed for k, (typed, _) in zip(keys, combination)}
        labels = {k: label for k, (_, label) in zip(keys, combination)}
        config = build_config(config_type, base, values)
        points.append(GridPoint(index=index, labels=labels, name=point_name(labels) if keys else "", config=config))
    return points


# -- chunks ---------------------------------------------------------------------------------------------

def chunk_size_for(trials: int, points: int, workers: int, hint: int | None = None,
                   requested: int | None = None) -> int:
    """Trials per task.

    ``requested`` when given; else one chunk per point with one worker (the most batching);
    else enough chunks for about :data:`CHUNKS_PER_WORKER` tasks per worker over all points. A
    scenario's ``hint`` (its ``chunk_trials``) caps the result.
    """
    if requested is not None:
        return max(1, min(int(requested), trials))
    if workers <= 1:
        size = trials
    else:
        per_point = max(1, math.ceil(CHUNKS_PER_WORKER * workers / max(1, points)))
        size = math.ceil(trials / per_point)
    if hint:
        size = min(size, int(hint))
    return max(1, size)


def plan_chunks(missing: Iterable[int], size: int) -> list[tuple[int, int]]:
    """(first, count) chunks covering the ``missing`` trials, cut at multiples of ``size``."""
    chunks: list[tuple[int, int]] = []
    for trial in sorted(set(missing)):
        if chunks:
            first, count = chunks[-1]
            if trial == first + count and trial % size != 0:
                chunks[-1] = (first, count + 1)
                continue
        chunks.append((trial, 1))
    return chunks


@dataclass(frozen=True)
class ChunkTask:
    """One task: trials ``first .. first + count - 1`` of grid point ``point``."""

    scenario: Any  # a registered name (loaded on the worker) or a picklable Scenario instance
    point: int
    config: Any
    backend: str
    first: int
    count: int
    seed: int
    video_path: str | None = None


@dataclass
class ChunkOutcome:
    """What a task sends back: its rows (global trial numbers), time series, aggregates, timing."""

    rows: list
    timeseries: dict
    aggregates: dict
    simulated_time_s: float
    compute_s: float
    worker: str


def run_chunk(task: ChunkTask) -> ChunkOutcome:
    """Run one chunk of trials (on a worker) and number its rows globally."""
    scenario = load_scenario(task.scenario) if isinstance(task.scenario, str) else task.scenario
    started = time.perf_counter()
    result = run_trials(scenario, task.config, task.backend, task.count, task.seed + task.first,
                        video_path=Path(task.video_path) if task.video_path else None)
    compute_s = time.perf_counter() - started
    if len(result.trials) != task.count:
        raise NeuronavError(f"scenario {getattr(scenario, 'name', scenario)!r} returned {len(result.trials)} "
                            f"rows for {task.count} trials")
    rows = [normalise_row(row, task.first + i, task.seed + task.first + i) for i, row in enumerate(result.trials)]
    return ChunkOutcome(rows=rows, timeseries=dict(result.timeseries), aggregates=dict(result.aggregates),
                        simulated_time_s=float(result.simulated_time_s), compute_s=compute_s,
                        worker=f"{os.uname().nodename if hasattr(os, 'uname') else ''}:{os.getpid()}")


def normalise_row(row: Mapping[str, Any], trial: int, seed: int) -> dict:
    """A trial row with the global ``trial`` and ``seed``, and ``status``, ``error``, ``success`` present."""
    out = dict(row)
    out["trial"], out["seed"] = int(trial), int(seed)
    out.setdefault("status", "ok")
    out["error"] = str(out.get("error") or "")
    if out["status"] != "ok":
        out["success"] = False
    out.setdefault("success", out["status"] == "ok")
    return out


def failed_row(trial: int, seed: int, reason: str) -> dict:
    """The row of a trial whose task failed (not the scenario: the worker or the transport)."""
    return {"trial": trial, "seed": seed, "success": False, "status": "failed", "error": reason}


def _task_failure(error: BaseException) -> str:
    if isinstance(error, BrokenProcessPool) or type(error).__name__ == "KilledWorker":
        return f"WorkerDied: the worker process running this trial died ({type(error).__name__})"
    lines = str(error).splitlines()
    return f"{type(error).__name__}: {lines[0] if lines else ''}".rstrip(": ")


# -- executors ------------------------------------------------------------------------------------------

class _InProcess:
    """Runs tasks here, one after another."""

    def run(self, tasks: list[ChunkTask]) -> Iterator[tuple[ChunkTask, ChunkOutcome | BaseException]]:
        for task in tasks:
            try:
                yield task, run_chunk(task)
            except Exception as error:  # noqa: BLE001 - reported as the task's failure
                yield task, error

    isolate = run

    def close(self) -> None:
        pass


def _pool_context():
    import multiprocessing

    # fork: workers start in milliseconds with everything already imported (Linux only; elsewhere
    # fork is unsafe or missing).
    method = "fork" if sys.platform.startswith("linux") else "spawn"
    return multiprocessing.get_context(method)


class _LocalPool:
    """A local process pool; a pool broken by a dying worker is replaced for the next batch of tasks."""

    def __init__(self, workers: int) -> None:
        self.workers = workers

    def run(self, tasks: list[ChunkTask]) -> Iterator[tuple[ChunkTask, ChunkOutcome | BaseException]]:
        if not tasks:
            return
        pool = ProcessPoolExecutor(max_workers=min(self.workers, len(tasks)), mp_context=_pool_context())
        try:
            futures = {pool.submit(run_chunk, task): task for task in tasks}
            for future in as_completed(futures):
                error = future.exception()
                yield futures[future], (error if error is not None else future.result())
        finally:
            pool.shutdown(wait=True, cancel_futures=True)

    def isolate(self, tasks: list[ChunkTask]) -> Iterator[tuple[ChunkTask, ChunkOutcome | BaseException]]:
        """One worker, tasks in order: a worker that dies is blamed on the task it was running."""
        remaining = list(tasks)
        while remaining:
            pool = ProcessPoolExecutor(max_workers=1, mp_context=_pool_context())
            try:
                futures = [pool.submit(run_chunk, task) for task in remaining]
                for i, (task, future) in enumerate(zip(remaining, futures)):
                    error = future.exception()
                    yield task, (error if error is not None else future.result())
                    if isinstance(error, BrokenProcessPool):
                        remaining = remaining[i + 1:]
                        break
                else:
                    remaining = []
            finally:
                pool.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        pass


class _Dask:
    """Tasks on a Dask distributed cluster (which retries tasks of dead workers itself)."""

    def __init__(self, client: Any, owned: bool) -> None:
        self.client, self.owned = client, owned

    def run(self, tasks: list[ChunkTask]) -> Iterator[tuple[ChunkTask, ChunkOutcome | BaseException]]:
        from distributed import as_completed as dask_as_completed

        if not tasks:
            return
        # One message for all the tasks; the scheduler hands them out as workers free up.
        submitted = self.client.map(run_chunk, tasks, pure=False)
        futures = {future.key: (future, task) for future, task in zip(submitted, tasks)}
        for future in dask_as_completed(submitted, loop=self.client.loop):
            task = futures[future.key][1]
            if future.status == "error":
                outcome: Any = future.exception()
            else:
                try:
                    outcome = future.result()
                except Exception as error:  # noqa: BLE001 - e.g. the result could not be sent back
                    outcome = error
            future.release()
            yield task, outcome

    isolate = run

    def close(self) -> None:
        if self.owned:
            self.client.close()


def check_scheduler(scheduler: Any) -> None:
    """Raise :class:`ConfigError` unless ``scheduler`` is a Dask client or a scheduler address and Dask is installed."""
    if not isinstance(scheduler, str):
        if hasattr(scheduler, "submit") and hasattr(scheduler, "nthreads"):
            return
        raise ConfigError(f"scheduler must be an address like tcp://HOST:PORT or a distributed.Client, "
                          f"got {scheduler!r}")
    if not re.match(r"^[a-z][a-z0-9+.-]*://\S+$", scheduler):
        raise ConfigError(f"--scheduler expects an address like tcp://HOST:PORT, got {scheduler!r}")
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ConfigError("--scheduler needs Dask distributed; install it with: pip install 'neuronav[dask]'") from None


def connect(scheduler: Any) -> tuple[Any, bool]:
    """A Dask client for ``scheduler`` (an address or a Client) and whether we own it."""
    check_scheduler(scheduler)
    if not isinstance(scheduler, str):
        return scheduler, False
    from distributed import Client
    timeout = os.environ.get("NEURONAV_SCHEDULER_TIMEOUT", "10s")
    try:
        client = Client(scheduler, timeout=timeout, set_as_default=False)
    except Exception as error:  # noqa: BLE001 - any failure to connect is the user's address
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ConfigError(f"cannot reach the Dask scheduler at {scheduler}: {reason}") from None
    return client, True


def _dask_threads(client: Any) -> int:
    threads = sum(client.nthreads().values())
    if threads == 0:
        try:
            client.wait_for_workers(1, timeout=30)
        except Exception:  # noqa: BLE001
            raise ConfigError("the Dask scheduler has no workers; start some (dask worker ADDRESS)") from None
        threads = sum(client.nthreads().values())
    return max(1, threads)


# -- the run --------------------------------------------------------------------------------------------

def _check_positive(name: str, value: Any, allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 1:
        raise ConfigError(f"{name} must be a positive integer, got {value!r}")


def _out_dir(out_dir: Any, default: Path) -> Path:
    try:
        path = Path(out_dir) if out_dir is not None else default
        if path.exists() and not path.is_dir():
            raise ConfigError(f"--out {str(path)!r} is a file; give a directory")
        path.mkdir(parents=True, exist_ok=True)
        return path
    except (TypeError, ValueError) as error:
        raise ConfigError(f"--out {out_dir!r} is not a usable path ({error})") from None
    except OSError as error:
        reason = error.strerror or str(error)
        raise ConfigError(f"--out {str(out_dir)!r}: cannot create the run directory ({reason})") from None


def _scenario_name(scenario: Any) -> str:
    return getattr(scenario, "name", "") or type(scenario).__name__


def execute(
    scenario: str | Scenario, *, grid: Mapping[str, Any] | Sequence[str] | None = None, backend: str | None = None,
    trials: int = 1, seed: int = 0, overrides: Iterable[str] | Mapping[str, Any] = (),
    config_file: str | Path | None = None, out_dir: str | Path | None = None, workers: int | None = None,
    scheduler: Any = None, chunk_size: int | None = None, progress: bool | None = None, figures: bool = True,
    video: bool = False, command: list[str] | None = None,
) -> dict:
    """Run ``trials`` seeded trials of ``scenario`` at every point of ``grid``; write the run directory.

    Parameters
    ----------
    scenario : str or Scenario
        A registered scenario name, or a Scenario instance (it must pickle to run on workers).
    grid : mapping or list of str, optional
        ``{key: values}`` or ``["key=v1,v2", ...]``. None: a plain run (no point folders).
    backend : str, optional
        Default: the scenario's.
    trials, seed : int
        Trial i of every point uses seed ``seed + i``.
    overrides : list of ``key=value`` or mapping
        ``--set``; wins over ``config_file``; the grid wins over both.
    config_file : path, optional
        A TOML file of settings (``--config``).
    out_dir : path, optional
        Default: ``runs/SCENARIO-BACKEND-seedSEED`` for a run, ``runs/sweep-SCENARIO`` for a sweep.
    workers : int, optional
        Local worker processes (1: run here). Default: 1 for a run, the available CPUs for a sweep;
        with ``scheduler``, used only to size chunks (default: the cluster's threads).
    scheduler : str or distributed.Client, optional
        Run on this Dask cluster.
    chunk_size : int, optional
        Trials per task (default: :func:`chunk_size_for`).
    progress : bool, optional
        Draw a progress bar (default: only on a terminal).
    figures : bool
        Draw the scenario's figures (per point) and the sweep's metric figure.
    video : bool
        Record a video of trial 0 (a plain run on a rendering backend only).
    command : list of str, optional
        The command line, recorded in the summaries.

    Returns
    -------
    dict
        The summary (``summary.json``) plus ``out_dir``.
    """
    is_sweep = grid is not None
    instance = load_scenario(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(instance, Scenario):
        raise ConfigError(f"scenario must be a registered name or a Scenario instance, got {scenario!r}")
    name = _scenario_name(instance)
    backend = check_backend(instance, backend)
    check_counts(trials, seed)
    trials, seed = int(trials), int(seed)
    if workers is not None:
        _check_positive("workers", workers)
        if workers > MAX_WORKERS:
            raise ConfigError(f"workers must be at most {MAX_WORKERS}, got {workers}")
    _check_positive("chunk size", chunk_size, allow_none=True)
    if scheduler is not None:
        check_scheduler(scheduler)

    config_type = instance.config_type
    file_values = load_config_file(config_type, config_file) if config_file is not None else {}
    set_values = parse_overrides(config_type, overrides)
    parsed_grid = parse_grid(config_type, grid)
    if is_sweep and not parsed_grid:
        raise ConfigError("a sweep needs at least one --grid key=v1,v2")
    both = [k for k in parsed_grid if k in set_values]
    if both:
        raise ConfigError(f"key {both[0]!r} is in both --grid and --set; give it in one place")
    base = {**file_values, **set_values}
    base_config = build_config(config_type, base)
    points = grid_points(config_type, base, parsed_grid)
    if video:
        if is_sweep:
            raise ConfigError("--video is for neuronav run, not for sweeps")
        if not can_render(registry.load("backend", backend)):
            raise ConfigError(f"--video needs a backend with cameras; {backend!r} has none")
        if not instance.records_video:
            raise ConfigError(f"scenario {name!r} does not record video")
        if scheduler is not None:
            raise ConfigError("--video cannot be combined with --scheduler (the video is written by a worker)")

    default_out = Path("runs") / (f"sweep-{name}" if is_sweep else f"{name}-{backend}-seed{seed}")
    out = _out_dir(out_dir, default_out)
    command = list(command) if command is not None else list(sys.argv)
    base_record = {k: v for k, v in dataclasses.asdict(base_config).items() if k not in parsed_grid}
    settings = {
        "kind": "sweep" if is_sweep else "run", "scenario": name, "backend": backend, "seed": seed,
        "trials": trials, "config": base_record,
        "grid": {k: [label for _, label in values] for k, values in parsed_grid.items()},
        "versions": package_versions(), "git_revision": git_revision(), "command": command,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    with DirectoryLock(out):
        check_settings(out, settings)
        remove_stale_temporaries(out)
        context = _Context(instance, name, backend, seed, trials, out, points, figures, command, is_sweep)
        return context.run(workers, scheduler, chunk_size, progress, video, settings)


class _Context:
    """The state of one invocation: where parts go, which points are done, how to assemble them."""

    def __init__(self, scenario: Scenario, name: str, backend: str, seed: int, trials: int, out: Path,
                 points: list[GridPoint], figures: bool, command: list[str], is_sweep: bool) -> None:
        self.scenario, self.name, self.backend, self.seed, self.trials = scenario, name, backend, seed, trials
        self.out, self.points, self.figures, self.command, self.is_sweep = out, points, figures, command, is_sweep
        self.remaining: dict[int, int] = {}
        self.summaries: dict[int, dict] = {}
        self.wall_time_s = 0.0

    def parts_folder(self, point: GridPoint) -> Path:
        return self.out / PARTS_DIR / point.name if point.name else self.out / PARTS_DIR

    def point_folder(self, point: GridPoint) -> Path:
        return self.out / point.name if point.name else self.out

    # -- running --------------------------------------------------------------------------------------
    def run(self, workers: int | None, scheduler: Any, chunk_size: int | None, progress: bool | None, video: bool,
            settings: dict) -> dict:
        missing: dict[int, list[int]] = {}
        for point in self.points:
            folder = self.parts_folder(point)
            remove_stale_temporaries(folder)
            covered = {t for first, count, _ in list_parts(folder) for t in range(first, first + count)}
            missing[point.index] = [t for t in range(self.trials) if t not in covered]
            self.remaining[point.index] = len(missing[point.index])
            remove_stale_temporaries(self.point_folder(point))
        to_run = sum(self.remaining.values())
        total = self.trials * len(self.points)

        started = time.perf_counter()
        executor: Any = None
        if scheduler is None and workers is None:
            workers = available_cpus() if self.is_sweep else 1
        try:
            if to_run and scheduler is not None:
                client, owned = connect(scheduler)
                executor = _Dask(client, owned)
                workers = workers or _dask_threads(client)  # --workers, if given, only sizes the chunks
            hint = getattr(self.scenario, "chunk_trials", None)
            hint = hint if isinstance(hint, int) and not isinstance(hint, bool) and hint > 0 else None
            size = chunk_size_for(self.trials, len(self.points), workers or 1, hint, chunk_size)
            by_name = _registered(self.scenario, self.name)  # workers then load it from the registry
            tasks = [
                ChunkTask(self.name if by_name else self.scenario, point.index, point.config, self.backend,
                          first, count, self.seed, str(self.out / "trial0.mp4") if video and first == 0 else None)
                for point in self.points for first, count in plan_chunks(missing[point.index], size)
            ]
            if executor is None and tasks:
                # One task, or one worker: here, with no pool to start.
                executor = _LocalPool(workers) if workers > 1 and len(tasks) > 1 else _InProcess()
            with Progress(total, done=total - to_run, enabled=progress, description=self.name) as bar:
                self._execute(executor, tasks, bar)
        finally:
            if executor is not None:
                executor.close()
        self.wall_time_s = time.perf_counter() - started

        for point in self.points:
            if point.index not in self.summaries:
                self.summaries[point.index] = self.assemble(point)
        if not self.is_sweep:
            summary = self.summaries[0]
            summary.pop("_rows", None)
            return summary | {"out_dir": str(self.out), "resumed_trials": total - to_run}
        return self.assemble_sweep(settings, to_run)

    def _execute(self, executor: Any, tasks: list[ChunkTask], bar: Progress) -> None:
        if not tasks:
            return
        failed_tasks = self._record_all(executor.run(tasks), bar)
        if not failed_tasks:
            return
        # A task that failed as a whole: its trials again, one per task; then one at a time.
        singles = [dataclasses.replace(task, first=t, count=1, video_path=None)
                   for task in failed_tasks for t in range(task.first, task.first + task.count)]
        failed_singles = self._record_all(executor.run(singles), bar)
        if not failed_singles:
            return
        # Those that failed again, alone (a dying worker is blamed on its own trial): recorded as failed.
        for task, outcome in executor.isolate(failed_singles):
            if isinstance(outcome, KeyboardInterrupt):
                raise outcome
            if isinstance(outcome, BaseException):
                row = failed_row(task.first, self.seed + task.first, _task_failure(outcome))
                outcome = ChunkOutcome([row], {}, {}, 0.0, 0.0, "")
            self._record(task, outcome, bar)

    def _record_all(self, outcomes: Iterator, bar: Progress) -> list[ChunkTask]:
        failed = []
        for task, outcome in outcomes:
            if isinstance(outcome, BaseException):
                if isinstance(outcome, KeyboardInterrupt):
                    raise outcome
                failed.append(task)
            else:
                self._record(task, outcome, bar)
        return failed

    def _record(self, task: ChunkTask, outcome: ChunkOutcome, bar: Progress) -> None:
        point = self.points[task.point]
        meta = {"first": task.first, "count": task.count, "aggregates": outcome.aggregates,
                "simulated_time_s": outcome.simulated_time_s, "compute_s": outcome.compute_s,
                "worker": outcome.worker, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        write_part(self.parts_folder(point) / part_name(task.first, task.count), outcome.rows,
                   outcome.timeseries, meta)
        bar.advance(task.count, sum(1 for row in outcome.rows if row.get("status") != "ok"))
        self.remaining[task.point] -= task.count
        if self.remaining[task.point] <= 0 and self.is_sweep:
            self.summaries[task.point] = self.assemble(point)  # a finished point is ready at once

    # -- assembling -----------------------------------------------------------------------------------
    def assemble(self, point: GridPoint) -> dict:
        """Write the point's summary.json, trials.csv, timeseries.h5 and figures from its parts."""
        parts = list_parts(self.parts_folder(point))
        names = [path.name for _, _, path in parts]
        folder = self.point_folder(point)
        existing = folder / "summary.json"
        if existing.exists():
            try:
                summary = json.loads(existing.read_text())
                if (summary.get("parts") == names and summary.get("figures_requested") == self.figures
                        and all((folder / f).exists() for f in summary["figures"])):
                    summary["_rows"] = self._rows(parts)
                    return summary
            except (OSError, ValueError, KeyError, TypeError):
                pass
        rows_by_trial: dict[int, dict] = {}
        pieces, metas = [], []
        for first, count, path in parts:
            rows, series, meta = read_part(path)
            if any(row["trial"] in rows_by_trial for row in rows):
                continue  # overlapping parts (two runs raced): keep the first
            rows_by_trial.update({row["trial"]: row for row in rows})
            pieces.append((first, count, series))
            metas.append(meta)
        rows = [rows_by_trial[t] for t in sorted(rows_by_trial)]
        aggregates, note = self._aggregates(rows, metas, point.config)
        simulated = max((m.get("simulated_time_s", 0.0) for m in metas), default=0.0)
        result = ScenarioResult(trials=rows, timeseries=merge_timeseries(pieces, self.trials),
                                aggregates=aggregates, simulated_time_s=simulated)
        figure_paths: list[Path] = []
        extra: dict[str, Any] = {}
        folder.mkdir(parents=True, exist_ok=True)
        if self.figures and any(row.get("status") == "ok" for row in rows):
            try:
                figure_paths = list(self.scenario.figures(result, point.config, folder))
            except Exception as error:  # noqa: BLE001 - results are kept; the figure failure is reported
                reason = _task_failure(error)
                extra["figure_error"] = reason
                sys.stderr.write(f"neuronav: warning: figures of {self.name}"
                                 f"{' ' + point.name if point.name else ''} failed: {reason}\n")
        compute_s = sum(m.get("compute_s", 0.0) for m in metas)
        extra.update({
            **({"grid": point.labels} if point.labels else {}),
            "compute_time_s": compute_s, "chunks": len(parts), "parts": names,
            "figures_requested": self.figures,
            **({"aggregates_note": note} if note else {}),
        })
        summary = write_run_directory(
            folder, scenario=self.name, backend=self.backend, seed=self.seed,
            config=dataclasses.asdict(point.config), trials=rows, aggregates=aggregates,
            timeseries=result.timeseries, wall_time_s=self.wall_time_s if not self.is_sweep else compute_s,
            simulated_time_s=simulated, figures=figure_paths, command=self.command, extra=extra,
        )
        summary["_rows"] = rows
        return summary

    def _rows(self, parts: list[tuple[int, int, Path]]) -> list[dict]:
        rows: dict[int, dict] = {}
        for _, _, path in parts:
            for row in read_part(path, timeseries=False)[0]:
                rows.setdefault(row["trial"], row)
        return [rows[t] for t in sorted(rows)]

    def _aggregates(self, rows: list[dict], metas: list[dict], config: Any) -> tuple[dict, str]:
        hook = getattr(self.scenario, "aggregate", None)
        if callable(hook):
            try:
                return {k: float(v) for k, v in hook(rows, config).items()}, ""
            except Exception as error:  # noqa: BLE001
                return {}, f"the scenario's aggregate() failed: {_task_failure(error)}"
        if len(metas) == 1:
            return dict(metas[0].get("aggregates", {})), ""
        names = sorted({k for m in metas for k in m.get("aggregates", {})})
        if not names:
            return {}, ""
        return {}, (f"{', '.join(names)}: over-all-trials aggregates are not combined across {len(metas)} chunks "
                    "(the scenario has no aggregate() method); metrics show per-trial means")

    def assemble_sweep(self, settings: dict, ran: int) -> dict:
        """The sweep's trials.csv (grid columns first), summary.json and metric figure."""
        keys = list(self.points[0].labels) if self.points else []
        all_rows, entries = [], []
        for point in self.points:
            summary = self.summaries[point.index]
            all_rows += [dict(point.labels, **row) for row in summary.pop("_rows", [])]
            entries.append({"grid": point.labels, "dir": point.name, "trials": summary["trials"],
                            "failed_trials": summary["failed_trials"], "metrics": summary["metrics"],
                            "metrics_std": summary["metrics_std"], "compute_time_s": summary.get("compute_time_s")})
        write_atomic(self.out / "trials.csv", trials_csv(all_rows, extra_columns=tuple(keys)))
        figures = []
        if self.figures and entries:
            try:
                figures = [metrics_figure(all_rows, keys, self.out / METRICS_FIGURE)]
            except Exception as error:  # noqa: BLE001
                sys.stderr.write(f"neuronav: warning: the sweep's metric figure failed: {_task_failure(error)}\n")
        failed = sum(e["failed_trials"] for e in entries)
        summary = {
            "scenario": self.name, "backend": self.backend, "seed": self.seed, "trials": self.trials,
            "grid": settings["grid"], "config": settings["config"], "points": entries,
            "total_trials": len(all_rows), "failed_trials": failed, "resumed_trials": len(all_rows) - ran,
            "wall_time_s": self.wall_time_s,
            "compute_time_s": sum(e["compute_time_s"] or 0.0 for e in entries),
            "versions": package_versions(), "git_revision": git_revision(), "command": self.command,
            "figures": [Path(f).name for f in figures],
        }
        write_atomic(self.out / "summary.json", json.dumps(summary, indent=2, default=json_default) + "\n")
        return summary | {"out_dir": str(self.out)}


def _registered(scenario: Scenario, name: str) -> bool:
    """Whether ``name`` loads this scenario's class from the registry (so workers can load it by name)."""
    try:
        return name in registry.names("scenario") and isinstance(scenario, registry.load("scenario", name))
    except (NeuronavError, TypeError):
        return False


def plotted_metrics(rows: list[dict], keys: list[str]) -> list[str]:
    """The numeric metrics of finished trial rows worth a panel, in first-seen order: not the grid
    keys or bookkeeping, and not a metric that is NaN in every trial (undefined for this setting)."""
    skip = {"trial", "seed", "status", "error", *keys}
    metrics = []
    for row in rows:
        for key, value in row.items():
            if key not in skip and key not in metrics and isinstance(value, (int, float)):
                metrics.append(key)
    finite = [m for m in metrics if any(isinstance(r.get(m), (int, float)) and math.isfinite(r[m]) for r in rows)]
    return finite[:MAX_METRICS_IN_FIGURE]


def metrics_figure(rows: list[dict], keys: list[str], path: Path) -> Path:
    """Each numeric metric (mean ± std over the finished trials) against the grid, one subplot each.

    The first grid key is the x axis (numeric when all its values are numbers); every combination
    of the other keys is one line.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    metrics = plotted_metrics(ok, keys)
    x_key, others = keys[0], keys[1:]
    x_labels = list(dict.fromkeys(r[x_key] for r in rows))
    try:
        x_values = [float(v) for v in x_labels]
        numeric = all(math.isfinite(v) for v in x_values)
    except ValueError:
        numeric = False
    positions = x_values if numeric else list(range(len(x_labels)))
    series = list(dict.fromkeys(tuple(r[k] for k in others) for r in rows))
    columns = min(3, max(1, len(metrics)))
    lines = max(1, math.ceil(len(metrics) / columns))
    fig, axes = plt.subplots(lines, columns, figsize=(4.2 * columns, 3.0 * lines), squeeze=False)
    for ax, metric in zip(axes.flat, metrics):
        for combination in series:
            means, stds = [], []
            for label in x_labels:
                values = np.array([float(r[metric]) for r in ok if r[x_key] == label
                                   and tuple(r[k] for k in others) == combination
                                   and isinstance(r.get(metric), (int, float))], float)
                values = values[np.isfinite(values)]
                means.append(values.mean() if values.size else np.nan)
                stds.append(values.std() if values.size else np.nan)
            name = ", ".join(f"{k}={v}" for k, v in zip(others, combination)) or None
            ax.errorbar(positions, means, yerr=stds, marker="o", ms=3, capsize=2, lw=1, label=name)
        ax.set_title(metric, fontsize=9)
        ax.set_xlabel(x_key, fontsize=8)
        if not numeric:
            ax.set_xticks(positions, x_labels, fontsize=7)
        ax.tick_params(labelsize=7)
        if others and metric == metrics[0]:
            ax.legend(fontsize=6)
    for ax in list(axes.flat)[len(metrics):]:
        ax.axis("off")
    if not metrics:
        axes.flat[0].text(0.5, 0.5, "no finished trials with numeric metrics", ha="center", va="center")
    fig.tight_layout()
    handle = Path(path)
    temporary = handle.with_name(f".{handle.name}.{os.getpid()}.tmp")
    fig.savefig(temporary, dpi=110, format="png")
    plt.close(fig)
    os.replace(temporary, handle)
    return handle


def run_sweep(scenario: str | Scenario, grid: Mapping[str, Any] | Sequence[str], **options: Any) -> dict:
    """Run a sweep (``neuronav sweep``): :func:`execute` with a grid; options as there."""
    if grid is None:
        raise ConfigError("a sweep needs at least one --grid key=v1,v2")
    return execute(scenario, grid=grid, **options)
