"""Where the chunks of a run or sweep run: here, in a local process pool, or on a Dask cluster.

A chunk of consecutive trials of one grid point is one task (:class:`ChunkTask`), run by
:func:`run_chunk` through :func:`neuronav.runs.trials.run_trials`. Every executor yields
``(task, outcome)`` pairs as tasks finish, the outcome a :class:`ChunkOutcome` or the exception
that ended the task.

Local pool workers are forked on Linux (started in milliseconds, everything imported). They are
tied to their run: they die with the process that started them (``PR_SET_PDEATHSIG`` on Linux, a
thread that watches the parent elsewhere), and they close the run directory's lock descriptor they
inherit, so a killed run leaves no process behind and no lock held. They ignore Ctrl-C (a terminal
sends it to every process of the group): the run decides, and a run that stops early (interrupted)
kills its workers at once instead of waiting for their chunks.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import signal
import socket
import sys
import threading
import time
from collections.abc import Iterable, Iterator, Mapping
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from neuronav.errors import ConfigError, NeuronavError
from neuronav.runs.trials import load_scenario, run_trials

# Tasks per worker over a whole sweep: enough to keep every worker busy to the end.
CHUNKS_PER_WORKER = 4
# A worker count above this is surely a typo.
MAX_WORKERS = 1024
# Address schemes a Dask scheduler speaks (http is its dashboard, not the scheduler).
DASK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")


def available_cpus() -> int:
    """CPUs this process may run on (the default number of sweep workers)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


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


def task_failure(error: BaseException) -> str:
    """One line saying why a task (or a figure) failed."""
    if isinstance(error, BrokenProcessPool) or type(error).__name__ == "KilledWorker":
        return f"WorkerDied: the worker process running this trial died ({type(error).__name__})"
    lines = str(error).splitlines()
    return f"{type(error).__name__}: {lines[0] if lines else ''}".rstrip(": ")


# -- in this process ------------------------------------------------------------------------------------

Outcomes = Iterator[tuple[ChunkTask, "ChunkOutcome | BaseException"]]


class InProcess:
    """Runs tasks here, one after another."""

    def run(self, tasks: list[ChunkTask]) -> Outcomes:
        for task in tasks:
            try:
                yield task, run_chunk(task)
            except Exception as error:  # noqa: BLE001 - reported as the task's failure
                yield task, error

    isolate = run

    def close(self) -> None:
        pass


# -- a local process pool -------------------------------------------------------------------------------

# Shared objects of OpenGL drivers (Mesa's per-device *_dri.so or its merged libgallium, NVIDIA's
# GL/EGL cores, OSMesa): loaded into a process when it first makes a GL context, not on import.
_GL_DRIVER_NAMES = ("_dri.so", "libgallium", "libnvidia-glcore", "libnvidia-eglcore", "libosmesa")


def gl_driver_loaded(maps_path: str = "/proc/self/maps") -> bool:
    """Whether this process has loaded an OpenGL driver (it rendered, e.g. MuJoCo's eyes through EGL).

    Read from the process's memory map (Linux); False where there is none.
    """
    try:
        with open(maps_path, encoding="utf-8", errors="replace") as maps:
            return any(name in line.lower() for line in maps for name in _GL_DRIVER_NAMES)
    except OSError:
        return False


def pool_context():
    """The multiprocessing context of local workers: fork on Linux, spawn elsewhere.

    fork starts workers in milliseconds with everything already imported, but a forked worker
    inherits the parent's descriptors; :func:`worker_initializer` closes the run's lock. A process
    that has rendered (:func:`gl_driver_loaded`) spawns its workers instead: a child forked from it
    deadlocks inside the GL driver (Mesa's swrast, waiting on a lock a thread of the parent held),
    so a pool run after a rendered trial in the same Python session used to hang for ever.
    """
    import multiprocessing

    method = "fork" if sys.platform.startswith("linux") and not gl_driver_loaded() else "spawn"
    return multiprocessing.get_context(method)


_PR_SET_PDEATHSIG = 1


def _die_with_parent_linux() -> bool:
    """Ask the kernel to SIGKILL this process when its parent dies (Linux); whether that worked."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent_pid: int, interval_s: float) -> None:
    while True:
        time.sleep(interval_s)
        if os.getppid() != parent_pid:
            os._exit(1)


@contextlib.contextmanager
def sigint_held() -> Iterator[None]:
    """Hold SIGINT back from this (main) thread while it forks, and deliver it after.

    Python runs a signal's handler at its next chance, which during a fork is inside the at-fork
    callbacks, where the KeyboardInterrupt raised is printed and dropped (the run went on). Threads
    started meanwhile (a pool's own) keep SIGINT blocked, so it always comes to this thread.
    """
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def worker_initializer(parent_pid: int, close_fds: tuple[int, ...] = (), watch_interval_s: float = 1.0) -> None:
    """Run first in every local pool worker: tie it to its parent, drop the run directory's lock.

    - ``close_fds``: descriptors inherited through fork that the worker must not keep (the lock
      of the run directory: a worker holding it would keep the folder locked after its run died).
    - The worker dies with ``parent_pid``: ``PR_SET_PDEATHSIG`` on Linux, and a daemon thread that
      checks the parent every ``watch_interval_s`` (the fallback elsewhere, and for the moment
      between fork and prctl).
    - The worker ignores SIGINT: a Ctrl-C reaches every process of the terminal's group, and a
      worker interrupted mid-task printed a traceback; its run kills it instead (:class:`LocalPool`).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):  # forked while the parent held SIGINT back (sigint_held)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    for fd in close_fds:
        try:
            os.close(fd)
        except OSError:
            pass
    _die_with_parent_linux()
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent_pid, watch_interval_s), daemon=True,
                     name="neuronav-parent-watch").start()


class LocalPool:
    """A local process pool; a pool broken by a dying worker is replaced for the next batch of tasks.

    A pool whose tasks were not all consumed (the run was interrupted) is not waited for: its queued
    tasks are cancelled and its workers killed, by the generator that ran it or by :meth:`close`.

    Parameters
    ----------
    workers : int
        Worker processes.
    close_fds : tuple of int
        Descriptors of this process the workers must close (the run directory's lock).
    """

    def __init__(self, workers: int, close_fds: tuple[int, ...] = ()) -> None:
        self.workers = workers
        self.close_fds = tuple(close_fds)
        self._running: dict[ProcessPoolExecutor, list[Future | None]] = {}  # pools not shut down yet: their futures

    def _pool(self, workers: int) -> ProcessPoolExecutor:
        context = pool_context()
        # Only a forked worker holds copies of this process's descriptors; a spawned one has its own.
        inherited = self.close_fds if context.get_start_method() == "fork" else ()
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=worker_initializer,
                                   initargs=(os.getpid(), inherited))
        self._running[pool] = []
        return pool

    def _submit(self, pool: ProcessPoolExecutor, task: ChunkTask) -> Future:
        futures = self._running[pool]
        futures.append(None)  # counted first: a task whose submit was interrupted is not done either
        with sigint_held():  # the first submit forks the workers
            futures[-1] = pool.submit(run_chunk, task)
        return futures[-1]

    def _end(self, pool: ProcessPoolExecutor) -> None:
        """Shut ``pool`` down; kill its workers first when some of its tasks are not done."""
        futures = self._running.pop(pool, None)
        if futures is None:  # already ended
            return
        if not all(future is not None and future.done() for future in futures):
            # ProcessPoolExecutor cannot end running tasks before Python 3.14 (kill_workers): kill them here.
            for process in list((getattr(pool, "_processes", None) or {}).values()):
                process.kill()
        pool.shutdown(wait=True, cancel_futures=True)

    def run(self, tasks: list[ChunkTask]) -> Outcomes:
        if not tasks:
            return
        pool = self._pool(min(self.workers, len(tasks)))
        try:
            futures = {self._submit(pool, task): task for task in tasks}
            for future in as_completed(futures):
                error = future.exception()
                yield futures[future], (error if error is not None else future.result())
        finally:
            self._end(pool)

    def isolate(self, tasks: list[ChunkTask]) -> Outcomes:
        """One worker, tasks in order: a worker that dies is blamed on the task it was running."""
        remaining = list(tasks)
        while remaining:
            pool = self._pool(1)
            try:
                futures = [self._submit(pool, task) for task in remaining]
                for i, (task, future) in enumerate(zip(remaining, futures)):
                    error = future.exception()
                    yield task, (error if error is not None else future.result())
                    if isinstance(error, BrokenProcessPool):
                        remaining = remaining[i + 1:]
                        break
                else:
                    remaining = []
            finally:
                self._end(pool)

    def close(self) -> None:
        """End the pools still running: an interrupt raised while an outcome was being recorded leaves
        the generator of :meth:`run` suspended, its pool busy, until the generator is collected."""
        for pool in list(self._running):
            self._end(pool)


# -- Dask -----------------------------------------------------------------------------------------------

class DaskCluster:
    """Tasks on a Dask distributed cluster (which retries tasks of dead workers itself).

    The cluster's workers are not children of this process: they hold no lock of the run directory,
    and when this process dies the scheduler drops its tasks with its client.
    """

    def __init__(self, client: Any, owned: bool) -> None:
        self.client, self.owned = client, owned

    def run(self, tasks: list[ChunkTask]) -> Outcomes:
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

    def threads(self) -> int:
        """Threads of the cluster's workers (waiting up to 30 s for a first worker)."""
        threads = sum(self.client.nthreads().values())
        if threads == 0:
            try:
                self.client.wait_for_workers(1, timeout=30)
            except Exception:  # noqa: BLE001
                raise ConfigError("the Dask scheduler has no workers; start some (dask worker ADDRESS)") from None
            threads = sum(self.client.nthreads().values())
        return max(1, threads)

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
    match = re.match(r"^([a-z][a-z0-9+.-]*)://\S+$", scheduler)
    if not match:
        raise ConfigError(f"--scheduler expects an address like tcp://HOST:PORT, got {scheduler!r}")
    if match.group(1) not in DASK_SCHEMES:
        raise ConfigError(f"--scheduler {scheduler}: a Dask scheduler address starts with "
                          f"{' or '.join(s + '://' for s in DASK_SCHEMES[:2])} (http:// is its dashboard), "
                          f"e.g. tcp://HOST:8786")
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ConfigError("--scheduler needs Dask distributed; install it with: pip install 'neuronav[dask]'") from None


def _reachable(address: str, timeout_s: float) -> None:
    """For an address over TCP, raise :class:`ConfigError` at once when nothing listens there; for a
    tcp:// address, also when what listens is not a Dask scheduler.

    A Dask scheduler speaks first: on a new connection it sends its handshake, a frame whose first
    8 bytes are a small little-endian length. Anything else (silence, as from a web server waiting
    for a request, or text) is refused here, where Dask's own client would wait forever.
    """
    parts = urlsplit(address)
    if parts.scheme not in ("tcp", "tls", "ws", "wss"):  # the schemes that run over TCP
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError as error:
        raise ConfigError(f"--scheduler {address}: {error}") from None
    if not host or port is None:
        raise ConfigError(f"--scheduler {address}: give a host and a port, like tcp://HOST:8786")
    try:
        probe = socket.create_connection((host, port), timeout=timeout_s)
    except OSError as error:
        reason = "timed out" if isinstance(error, TimeoutError) else error.strerror or type(error).__name__
        raise ConfigError(f"cannot reach the Dask scheduler at {address}: {reason}") from None
    with probe:
        if parts.scheme != "tcp":
            return
        header = b""
        try:
            while len(header) < 8:
                chunk = probe.recv(8 - len(header))
                if not chunk:
                    break
                header += chunk
        except TimeoutError:
            raise ConfigError(f"--scheduler {address}: no Dask scheduler answered within {timeout_s:g} s "
                              "(is it the scheduler's port, usually 8786?)") from None
        except OSError:
            pass  # reset by the peer: not a scheduler (below)
    if len(header) < 8 or not 0 < int.from_bytes(header, "little") < 2**32:
        raise ConfigError(f"--scheduler {address}: what listens there is not a Dask scheduler "
                          "(is it the scheduler's port, usually 8786?)")


def connect(scheduler: Any) -> tuple[Any, bool]:
    """A Dask client for ``scheduler`` (an address or a Client) and whether we own it.

    ``NEURONAV_SCHEDULER_TIMEOUT`` (default 10 s) bounds the wait; an address nothing listens on is
    refused at once.
    """
    check_scheduler(scheduler)
    if not isinstance(scheduler, str):
        return scheduler, False
    from distributed import Client

    class _Client(Client):
        """A Client that, when its constructor fails, does not try to close itself again when collected
        (distributed's own ``__del__`` would wait 20 s and print a traceback at exit)."""

        _failed = False

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            try:
                super().__init__(*args, **kwargs)
            except BaseException:
                self._failed = True
                raise

        def __del__(self) -> None:
            if not self._failed:
                super().__del__()

    timeout = os.environ.get("NEURONAV_SCHEDULER_TIMEOUT", "10s")
    _reachable(scheduler, timeout_s=5.0)
    try:
        client = _Client(scheduler, timeout=timeout, set_as_default=False)
    except Exception as error:  # noqa: BLE001 - any failure to connect is the user's address
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ConfigError(f"cannot reach the Dask scheduler at {scheduler}: {reason}") from None
    return client, True
