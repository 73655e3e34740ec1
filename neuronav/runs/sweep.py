"""Runs and sweeps: a scenario over a grid of settings × seeded trials, in chunks, resumably.

``neuronav run`` and ``neuronav sweep`` both go through :func:`execute` (``run`` is a sweep with no
grid): :func:`plan` checks everything knowable from the settings and writes nothing;
:meth:`RunPlan.run` claims the run folder, runs the missing chunks and assembles the results. The
pieces live in their own modules, each importing only those below it::

    runner -> sweep -> assembly -> executors -> trials
                    -> grid, sweep_figures, rundir

(all in :mod:`neuronav.runs`)

Tasks
    The trials of one grid point are cut into chunks of consecutive trials; a chunk is one task
    (:mod:`neuronav.runs.executors`). Trial numbering and seeds stay global: trial i always uses seed
    ``seed + i``. The chunk size (:func:`chunk_size_for`) gives about ``CHUNKS_PER_WORKER`` tasks per
    worker over the whole sweep; one worker runs every point's trials in one batch; a scenario may
    cap it with a ``chunk_trials`` attribute; ``--chunk-size`` sets it. Chunks start at multiples of
    the chunk size, so a resumed run computes the same chunks an uninterrupted one would.

Where tasks run
    ``workers == 1``: in this process. ``workers > 1``: a local process pool whose workers die with
    this process and never hold the folder's lock. With ``scheduler``: a Dask distributed cluster
    (``tcp://HOST:PORT``, or a ``distributed.Client``). A task that fails as a whole (its worker
    died, say) is retried one trial per task; a trial whose task fails again is recorded as failed
    with the reason, and the others finish.

Run directory (see also :mod:`neuronav.runs.rundir`)
    ::

        .neuronav-run              the marker: made by neuronav (locked while a process works here)
        settings.json              what the directory holds; a rerun must match it
        parts/[POINT/]trials-FIRST-LAST.npz   one per finished chunk, written atomically
        [POINT/]summary.json, trials.csv, timeseries.h5, *.png   assembled from the parts
        trials.csv, summary.json, sweep_metrics.png                (sweep: all points)

    POINT is ``key=value_key=value`` (a plain run has no point folders). A run writes only into a
    folder that does not exist, is empty, or holds the marker.

Resume rules
    A rerun of the same command (same scenario, backend, seed, trials, resolved config and grid;
    the number of workers, the chunk size and the scheduler may change) skips the trials its parts
    hold and runs only the others; a rerun with other settings is refused while the folder holds
    a finished trial, and takes the folder over when it holds none. Failed trials count as
    finished (a trial that raises will raise again). The results are assembled from the parts
    after every run; a point whose parts have not changed since its summary was written is kept.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from neuronav import registry
from neuronav.config import build_config, load_config_file, parse_overrides
from neuronav.errors import ConfigError, NeuronavError
from neuronav.runs.assembly import Assembler, first_failure
from neuronav.runs.executors import (  # noqa: F401 - chunk planning is part of this module's interface
    MAX_WORKERS,
    ChunkOutcome,
    ChunkTask,
    DaskCluster,
    InProcess,
    LocalPool,
    available_cpus,
    check_scheduler,
    chunk_size_for,
    connect,
    failed_row,
    plan_chunks,
    task_failure,
)
from neuronav.runs.grid import GridPoint, grid_points, parse_grid, point_name  # noqa: F401 - re-exported
from neuronav.runs.progress import Progress
from neuronav.runs.rundir import (
    VIDEO_NAME,
    DirectoryLock,
    check_out_dir,
    check_resumable,
    check_settings,
    claim_out_dir,
    git_revision,
    has_results,
    list_parts,
    package_versions,
    part_name,
    remove_stale_temporaries,
    write_part,
)
from neuronav.runs.scenario import Scenario
from neuronav.runs.sweep_figures import METRICS_FIGURE, build_metrics_figure, metrics_figure, plotted_metrics  # noqa: F401
from neuronav.runs.trials import can_film, check_backend, check_counts, load_scenario


def _check_positive(name: str, value: Any, allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 1:
        raise ConfigError(f"{name} must be a positive integer, got {value!r}")


def _scenario_name(scenario: Any) -> str:
    return getattr(scenario, "name", "") or type(scenario).__name__


def available_memory_bytes() -> int | None:
    """Memory available to new allocations (Linux ``MemAvailable``), or None when unknown."""
    try:
        with open("/proc/meminfo") as stream:
            for line in stream:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


@dataclass
class RunPlan:
    """A run or sweep checked and ready: what :func:`plan` found, nothing written yet."""

    scenario: Scenario
    name: str
    backend: str
    trials: int
    seed: int
    points: list[GridPoint]
    out: Path
    settings: dict
    workers: int | None
    scheduler: Any
    chunk_size: int | None
    progress: bool | None
    figures: bool
    video: bool
    command: list[str]
    is_sweep: bool
    summaries: dict[int, dict] = field(default_factory=dict)
    remaining: dict[int, int] = field(default_factory=dict)
    rows: list[dict] = field(default_factory=list)  # a run's per-trial rows, once it has run (not a sweep's)

    @property
    def kind(self) -> str:
        return "sweep" if self.is_sweep else "run"

    def run(self) -> dict:
        """Claim the folder, run the missing trials, assemble; return the summary plus ``out_dir``."""
        client = None
        if self.scheduler is not None and not (self.out.is_dir() and has_results(self.out)):
            client = connect(self.scheduler)  # before the folder is made: a failed start leaves nothing
        try:
            claim_out_dir(self.out, self.kind)
            with DirectoryLock(self.out) as lock:
                check_settings(self.out, self.settings)
                remove_stale_temporaries(self.out)
                return self._run_locked(lock, client)
        finally:
            if client is not None and client[1]:
                client[0].close()

    # -- running --------------------------------------------------------------------------------------
    def _run_locked(self, lock: DirectoryLock, client: tuple[Any, bool] | None) -> dict:
        assembler = Assembler(self.scenario, self.name, self.backend, self.seed, self.trials, self.out,
                              self.figures, self.command, self.is_sweep)
        missing = self._missing(assembler)
        to_run = sum(len(m) for m in missing.values())
        total = self.trials * len(self.points)
        started = time.perf_counter()
        executor, workers = self._executor(to_run, client, lock)
        try:
            tasks = self._tasks(missing, workers)
            if executor is None and tasks:
                executor = InProcess()
            with Progress(total, done=total - to_run, enabled=self.progress, description=self.name) as bar:
                self._execute(executor, tasks, bar, assembler)
        finally:
            if executor is not None:
                executor.close()
        assembler.wall_time_s = time.perf_counter() - started
        for point in self.points:
            if point.index not in self.summaries:
                self.summaries[point.index] = assembler.assemble(point)
        if not self.is_sweep:
            summary = self.summaries[0]
            self.rows = summary.pop("_rows", None) or []
            return summary | {"out_dir": str(self.out), "resumed_trials": total - to_run}
        return assembler.assemble_sweep(self.points, self.summaries, self.settings, to_run)

    def _missing(self, assembler: Assembler) -> dict[int, list[int]]:
        missing: dict[int, list[int]] = {}
        for point in self.points:
            folder = assembler.parts_folder(point)
            remove_stale_temporaries(folder)
            covered = {t for first, count, _ in list_parts(folder) for t in range(first, first + count)}
            missing[point.index] = [t for t in range(self.trials) if t not in covered]
            self.remaining[point.index] = len(missing[point.index])
            remove_stale_temporaries(assembler.point_folder(point))
        return missing

    def _executor(self, to_run: int, client: tuple[Any, bool] | None, lock: DirectoryLock) -> tuple[Any, int]:
        """The executor for ``to_run`` trials (None: decide once the tasks are known) and the worker count."""
        workers = self.workers
        if self.scheduler is not None:
            if not to_run:
                return None, workers or 1
            if client is None:
                client = connect(self.scheduler)
            executor = DaskCluster(*client)
            return executor, workers or executor.threads()  # --workers, if given, only sizes the chunks
        workers = workers or (available_cpus() if self.is_sweep else 1)
        if workers > 1 and to_run > 1:
            fds = (lock.fileno,) if lock.fileno is not None else ()
            return LocalPool(workers, close_fds=fds), workers
        return None, workers

    def _tasks(self, missing: dict[int, list[int]], workers: int) -> list[ChunkTask]:
        size = chunk_size_for(self.trials, len(self.points), workers or 1, _chunk_hint(self.scenario), self.chunk_size)
        by_name = _registered(self.scenario, self.name)  # workers then load it from the registry
        video_path = str(self.out / VIDEO_NAME) if self.video else None
        if video_path and 0 not in missing[self.points[0].index] and not Path(video_path).exists():
            sys.stderr.write(f"neuronav: warning: trial 0 already ran in {self.out}, so --video (which films trial 0 "
                             f"as it runs) makes no video; run into a new folder to film it\n")
        return [
            ChunkTask(self.name if by_name else self.scenario, point.index, point.config, self.backend,
                      first, count, self.seed, video_path if first == 0 else None)
            for point in self.points for first, count in plan_chunks(missing[point.index], size)
        ]

    def _execute(self, executor: Any, tasks: list[ChunkTask], bar: Progress, assembler: Assembler) -> None:
        if not tasks:
            return
        failed_tasks = self._record_all(executor.run(tasks), bar, assembler)
        if not failed_tasks:
            return
        # A task that failed as a whole: its trials again, one per task; then one at a time.
        singles = [dataclasses.replace(task, first=t, count=1, video_path=None)
                   for task in failed_tasks for t in range(task.first, task.first + task.count)]
        failed_singles = self._record_all(executor.run(singles), bar, assembler)
        if not failed_singles:
            return
        # Those that failed again, alone (a dying worker is blamed on its own trial): recorded as failed.
        for task, outcome in executor.isolate(failed_singles):
            if isinstance(outcome, KeyboardInterrupt):
                raise outcome
            if isinstance(outcome, BaseException):
                row = failed_row(task.first, self.seed + task.first, task_failure(outcome))
                outcome = ChunkOutcome([row], {}, {}, 0.0, 0.0, "")
            self._record(task, outcome, bar, assembler)

    def _record_all(self, outcomes: Iterator, bar: Progress, assembler: Assembler) -> list[ChunkTask]:
        failed = []
        for task, outcome in outcomes:
            if isinstance(outcome, BaseException):
                if isinstance(outcome, KeyboardInterrupt):
                    raise outcome
                failed.append(task)
            else:
                self._record(task, outcome, bar, assembler)
        return failed

    def _record(self, task: ChunkTask, outcome: ChunkOutcome, bar: Progress, assembler: Assembler) -> None:
        point = self.points[task.point]
        meta = {"first": task.first, "count": task.count, "aggregates": outcome.aggregates,
                "simulated_time_s": outcome.simulated_time_s, "compute_s": outcome.compute_s,
                "worker": outcome.worker, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        write_part(assembler.parts_folder(point) / part_name(task.first, task.count), outcome.rows,
                   outcome.timeseries, meta)
        bar.advance(task.count, sum(1 for row in outcome.rows if row.get("status") != "ok"))
        self.remaining[task.point] -= task.count
        if self.remaining[task.point] <= 0 and self.is_sweep:
            self.summaries[task.point] = assembler.assemble(point)  # a finished point is ready at once


def _chunk_hint(scenario: Scenario) -> int | None:
    hint = getattr(scenario, "chunk_trials", None)
    return hint if isinstance(hint, int) and not isinstance(hint, bool) and hint > 0 else None


def _registered(scenario: Scenario, name: str) -> bool:
    """Whether ``name`` loads this scenario's class from the registry (so workers can load it by name)."""
    try:
        return name in registry.names("scenario") and isinstance(scenario, registry.load("scenario", name))
    except (NeuronavError, TypeError):
        return False


# -- planning: every check before anything is written ---------------------------------------------------

def _check_options(workers: Any, chunk_size: Any, scheduler: Any) -> None:
    if workers is not None:
        _check_positive("workers", workers)
        if workers > MAX_WORKERS:
            raise ConfigError(f"workers must be at most {MAX_WORKERS}, got {workers}")
    _check_positive("chunk size", chunk_size, allow_none=True)
    if scheduler is not None:
        check_scheduler(scheduler)


def _configs(instance: Scenario, grid: Any, overrides: Any, config_file: Any, is_sweep: bool
             ) -> tuple[Any, dict, list[GridPoint]]:
    """(base config, parsed grid, grid points): ``--config`` < ``--set`` < the grid, each validated once merged."""
    config_type = instance.config_type
    set_values = parse_overrides(config_type, overrides)
    parsed_grid = parse_grid(config_type, grid)
    if is_sweep and not parsed_grid:
        raise ConfigError("a sweep needs at least one --grid key=v1,v2")
    both = [k for k in parsed_grid if k in set_values]
    if both:
        raise ConfigError(f"key {both[0]!r} is in both --grid and --set; give it in one place")
    winning = {**set_values, **{k: values[0][0] for k, values in parsed_grid.items()}}
    file_values = load_config_file(config_type, config_file, overridden=winning) if config_file is not None else {}
    base = {**{k: v for k, v in file_values.items() if k not in parsed_grid}, **set_values}
    base_config = build_config(config_type, {k: v for k, v in base.items()}) if not parsed_grid else None
    points = grid_points(config_type, base, parsed_grid)
    if base_config is None:
        base_config = points[0].config
    return base_config, parsed_grid, points


def _check_video(instance: Scenario, name: str, backend: str, is_sweep: bool, scheduler: Any, config: Any) -> None:
    if is_sweep:
        raise ConfigError("--video is for neuronav run, not for sweeps")
    if not can_film(registry.load("backend", backend)):
        raise ConfigError(f"--video needs a backend that films; {backend!r} cannot")
    if not instance.records_video:
        raise ConfigError(f"scenario {name!r} does not record video")
    instance.check_video(config, backend)
    if scheduler is not None:
        raise ConfigError("--video cannot be combined with --scheduler (the video is written by a worker)")


def _check_memory(instance: Scenario, points: list[GridPoint], trials: int, workers: int | None,
                  chunk_size: int | None, is_sweep: bool) -> None:
    """Refuse a run whose batches cannot fit in memory (when the scenario can estimate it)."""
    parallel = workers or (available_cpus() if is_sweep else 1)
    size = chunk_size_for(trials, len(points), parallel, _chunk_hint(instance), chunk_size)
    available = available_memory_bytes()
    needed = instance.estimate_bytes(points[0].config, size)
    if needed is None or available is None:
        return
    at_once = needed * min(parallel, max(1, len(points) * -(-trials // size)))
    if at_once > available:
        raise ConfigError(f"{trials} trials in chunks of {size} need about {at_once / 2**30:.1f} GiB at once, more "
                          f"than the {available / 2**30:.1f} GiB available; give a smaller --chunk-size or fewer "
                          "--workers")


def plan(
    scenario: str | Scenario, *, grid: Mapping[str, Any] | Sequence[str] | None = None, backend: str | None = None,
    trials: int = 1, seed: int = 0, overrides: Iterable[str] | Mapping[str, Any] = (),
    config_file: str | Path | None = None, out_dir: str | Path | None = None, workers: int | None = None,
    scheduler: Any = None, chunk_size: int | None = None, progress: bool | None = None, figures: bool = True,
    video: bool = False, command: list[str] | None = None,
) -> RunPlan:
    """Check a run or sweep (arguments as :func:`execute`) and return its plan; write nothing.

    Everything knowable from the settings is checked here: the scenario, the backend (supported and
    installed), trials (at most the scenario's ``max_trials``) and seed, workers, chunk size, the
    scheduler's address, the config (``--config`` < ``--set`` < grid, validated once merged), the
    scenario's own :meth:`~neuronav.runs.scenario.Scenario.check` of every config on this backend, the
    memory a batch needs, video, and the run folder (:func:`neuronav.runs.rundir.check_out_dir`).
    """
    is_sweep = grid is not None
    instance = load_scenario(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(instance, Scenario):
        raise ConfigError(f"scenario must be a registered name or a Scenario instance, got {scenario!r}")
    name = _scenario_name(instance)
    backend = check_backend(instance, backend)
    check_counts(trials, seed, getattr(instance, "max_trials", None), name)
    trials, seed = int(trials), int(seed)
    _check_options(workers, chunk_size, scheduler)
    base_config, parsed_grid, points = _configs(instance, grid, overrides, config_file, is_sweep)
    for point in points:
        instance.check(point.config, backend)
    _check_memory(instance, points, trials, workers, chunk_size, is_sweep)
    if video:
        _check_video(instance, name, backend, is_sweep, scheduler, base_config)
    default_out = Path("runs") / (f"sweep-{name}" if is_sweep else f"{name}-{backend}-seed{seed}")
    out = check_out_dir(default_out if out_dir is None else out_dir, "sweep" if is_sweep else "run")
    command = list(command) if command is not None else list(sys.argv)
    settings = {
        "kind": "sweep" if is_sweep else "run", "scenario": name, "backend": backend, "seed": seed,
        "trials": trials,
        "config": {k: v for k, v in dataclasses.asdict(base_config).items() if k not in parsed_grid},
        "grid": {k: [label for _, label in values] for k, values in parsed_grid.items()},
        "versions": package_versions(), "git_revision": git_revision(), "command": command,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    check_resumable(out, settings)
    return RunPlan(instance, name, backend, trials, seed, points, out, settings, workers, scheduler, chunk_size,
                   progress, figures, video, command, is_sweep)


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
        It must not exist, be empty, or have been made by a neuronav run or sweep.
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
        The summary (``summary.json``) plus ``out_dir``. ``failed_trials`` counts the trials that
        failed and ``first_error`` names the first ("" when none did).
    """
    return plan(scenario, grid=grid, backend=backend, trials=trials, seed=seed, overrides=overrides,
                config_file=config_file, out_dir=out_dir, workers=workers, scheduler=scheduler,
                chunk_size=chunk_size, progress=progress, figures=figures, video=video, command=command).run()


def run_sweep(scenario: str | Scenario, grid: Mapping[str, Any] | Sequence[str], **options: Any) -> dict:
    """Run a sweep (``neuronav sweep``): :func:`execute` with a grid; options as there."""
    if grid is None:
        raise ConfigError("a sweep needs at least one --grid key=v1,v2")
    return execute(scenario, grid=grid, **options)


__all__ = ["METRICS_FIGURE", "ChunkTask", "GridPoint", "RunPlan", "build_metrics_figure", "chunk_size_for", "execute",
           "first_failure", "metrics_figure", "parse_grid", "plan", "plan_chunks", "plotted_metrics", "run_sweep"]
