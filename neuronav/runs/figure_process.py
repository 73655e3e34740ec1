"""Figures drawn by a helper process that imports matplotlib while the trials run.

A short command (a 1 s locomotion run) spends more time importing matplotlib (about 0.2 s) than
simulating. The ``neuronav`` command therefore forks a helper at start-up, before any engine is
imported: the helper imports matplotlib on the second core while the parent loads the engine and
runs the trials, then waits for work. When a run's figures are due, the parent sends the helper the
scenario, its result, its config and the folder (pickled through a pipe); the helper calls the
scenario's own ``figures`` and replies with the paths written, or with the failure's text, which
the parent reports as it reports any figure failure. The figures are the same files either way.

Only the command-line process uses a helper (``neuronav.runs.cli.console_main``, on systems with
``os.fork``); library calls and tests that call :func:`neuronav.runs.cli.main` draw in their own
process, and so does the command with ``NEURONAV_FIGURE_HELPER=0`` in its environment (to measure
the difference, ``benchmarks/startup.py``, or to debug a figure). When no helper is active, or it
cannot take the job (it died, or the job does not pickle), :func:`draw_figures` draws in this process.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import pickle
from pathlib import Path
from typing import Any

from neuronav.runs.executors import _die_with_parent_linux
from neuronav.runs.scenario import Scenario, ScenarioResult

_ACTIVE: contextvars.ContextVar[FigureProcess | None] = contextvars.ContextVar("figure_process", default=None)


class FigureProcess:
    """A forked process that draws figures on request (see the module docstring).

    The child dies with its parent (``PR_SET_PDEATHSIG`` on Linux, and end-of-file on its pipe).
    """

    def __init__(self) -> None:
        job_read, self._job_write = os.pipe()
        self._reply_read, reply_write = os.pipe()
        self.pid = os.fork()
        if self.pid == 0:  # the helper
            os.close(self._job_write)
            os.close(self._reply_read)
            _serve(job_read, reply_write)  # never returns
        os.close(job_read)
        os.close(reply_write)
        self._jobs = os.fdopen(self._job_write, "wb")
        self._replies = os.fdopen(self._reply_read, "rb")
        self.alive = True

    def draw(self, scenario: Scenario, result: ScenarioResult, config: Any, folder: Path) -> list[Path] | None:
        """The paths the helper wrote, or None when it could not take the job (then draw here).

        Raises
        ------
        RuntimeError
            The scenario's figures failed in the helper (the message is the failure's text).
        """
        if not self.alive:
            return None
        try:
            job = pickle.dumps((scenario, result, config, Path(folder)), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError):
            return None
        try:
            self._jobs.write(len(job).to_bytes(8, "little") + job)
            self._jobs.flush()
            status, value = pickle.load(self._replies)
        except (OSError, EOFError, pickle.UnpicklingError):
            self.alive = False
            return None
        if status != "ok":
            raise RuntimeError(value)
        return value

    def close(self) -> None:
        """Tell the helper to stop (an empty job: pool workers forked meanwhile may still hold the
        pipe, so its end of file could come late) and wait for it."""
        with contextlib.suppress(OSError, ValueError):
            self._jobs.write(bytes(8))
            self._jobs.flush()
        for stream in (self._jobs, self._replies):
            with contextlib.suppress(OSError):
                stream.close()
        with contextlib.suppress(ChildProcessError, OSError):
            os.waitpid(self.pid, 0)
        self.alive = False


def _serve(job_read: int, reply_write: int) -> None:
    """The helper's life: import matplotlib, then draw each job until the pipe closes; exit without
    running the parent's exit handlers."""
    try:
        _die_with_parent_linux()
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.backends.backend_agg  # noqa: F401 - the import is the point: done while trials run
        import matplotlib.figure  # noqa: F401

        import neuronav.runs.plotting  # noqa: F401

        jobs, replies = os.fdopen(job_read, "rb"), os.fdopen(reply_write, "wb")
        while True:
            header = jobs.read(8)
            size = int.from_bytes(header, "little") if len(header) == 8 else 0
            if size == 0:  # stop, or the parent is gone
                break
            scenario, result, config, folder = pickle.loads(jobs.read(size))
            try:
                reply = ("ok", [Path(p) for p in scenario.figures(result, config, folder)])
            except Exception as error:  # noqa: BLE001 - reported to the parent, which warns as usual
                reply = ("error", f"{type(error).__name__}: {error}")
            pickle.dump(reply, replies)
            replies.flush()
    except BaseException:  # noqa: BLE001 - interrupted or the parent went away: nothing to report
        pass
    finally:
        os._exit(0)


@contextlib.contextmanager
def figure_process(enabled: bool = True):
    """Within this block, :func:`draw_figures` hands figures to a helper process (when ``enabled``
    and the system can fork)."""
    if not enabled or not hasattr(os, "fork") or os.environ.get("NEURONAV_FIGURE_HELPER") == "0":
        yield None
        return
    process = FigureProcess()
    token = _ACTIVE.set(process)
    try:
        yield process
    finally:
        _ACTIVE.reset(token)
        process.close()


def draw_figures(scenario: Scenario, result: ScenarioResult, config: Any, folder: Path) -> list[Path]:
    """``scenario.figures(result, config, folder)``, in the active helper process if there is one."""
    process = _ACTIVE.get()
    if process is not None:
        paths = process.draw(scenario, result, config, folder)
        if paths is not None:
            return paths
    return list(scenario.figures(result, config, folder))
