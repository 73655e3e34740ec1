"""A progress bar for runs and sweeps: trials done, failed, and the estimated time left.

It draws (with tqdm, on stderr) only when stderr is a terminal, so logs, pipes and tests stay
clean; ``NEURONAV_PROGRESS=0`` turns it off, ``NEURONAV_PROGRESS=1`` forces it on.
"""

from __future__ import annotations

import os
import sys
from typing import Any


def progress_enabled(requested: bool | None = None) -> bool:
    """Whether to draw: ``requested`` when given, else the environment, else whether stderr is a TTY."""
    if requested is not None:
        return bool(requested)
    setting = os.environ.get("NEURONAV_PROGRESS", "").strip().lower()
    if setting in ("0", "false", "no", "off"):
        return False
    if setting in ("1", "true", "yes", "on"):
        return True
    stream = sys.stderr
    return bool(getattr(stream, "isatty", lambda: False)())


class Progress:
    """Counts trials as chunks finish; draws a tqdm bar when enabled.

    Parameters
    ----------
    total : int
        Trials in the whole run or sweep.
    done : int
        Trials already finished before this invocation (a resumed run).
    enabled : bool, optional
        Draw the bar; default :func:`progress_enabled`.
    description : str
        Shown left of the bar.
    """

    def __init__(self, total: int, done: int = 0, enabled: bool | None = None, description: str = "") -> None:
        self.total, self.done, self.failed = int(total), int(done), 0
        self._bar: Any = None
        if progress_enabled(enabled):
            import tqdm

            tqdm.tqdm.monitor_interval = 0  # no monitor thread: worker processes are forked later
            self._bar = tqdm.tqdm(total=self.total, initial=self.done, desc=description, unit="trial",
                                  file=sys.stderr, dynamic_ncols=True, smoothing=0.1)
            self._bar.set_postfix(failed=0)

    def advance(self, trials: int, failed: int = 0) -> None:
        """Count ``trials`` more finished trials, ``failed`` of them failed."""
        self.done += trials
        self.failed += failed
        if self._bar is not None:
            self._bar.set_postfix(failed=self.failed, refresh=False)
            self._bar.update(trials)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        self.close()
