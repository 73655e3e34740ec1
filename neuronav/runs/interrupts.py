"""Ctrl-C for the ``neuronav`` command: the first one always ends the command, none cuts its shutdown short.

Python turns SIGINT into a KeyboardInterrupt raised wherever the main thread is. Two things go
wrong with that in a long run:

- A second Ctrl-C (a terminal sends one to every process of its group; people press twice) arrives
  while the first one's shutdown runs (killing the pool's workers, releasing the run folder) and cuts
  it short: the command used to hang on its workers, or print tracebacks.
- Code outside this project can swallow the KeyboardInterrupt: a Cython module's initialisation (for
  example scipy's, imported lazily by a scenario) clears errors raised while it registers its types.
  The run then went on for minutes after Ctrl-C (seen once in 40 interrupted runs).

So, while :func:`install`'s handler is active, a SIGINT raises KeyboardInterrupt unless the shutdown
is already under way (a KeyboardInterrupt is being handled: ``except``, ``finally`` or ``__exit__``),
and each one raised is checked again :data:`RETRY_S` later (SIGALRM): if nothing has handled it by
then and no shutdown is running, it was lost, and it is raised again. The command marks it handled
with :func:`interrupt_seen`; from then on every SIGINT is ignored, also while Python exits.
"""

from __future__ import annotations

import os
import signal
import sys
from typing import Any

RETRY_S = 0.5  # how long a raised KeyboardInterrupt has to reach a handler before it is raised again

_owner_pid: int | None = None  # the process whose handler raises; forked helpers ignore SIGINT
_seen = False


def install() -> None:
    """Make SIGINT raise KeyboardInterrupt in this process as described in the module docstring.

    Processes forked from this one (pool workers, the figure helper) inherit the handler and ignore
    SIGINT, which a terminal sends to them too: this process ends them.
    """
    global _owner_pid, _seen
    _owner_pid, _seen = os.getpid(), False
    signal.signal(signal.SIGINT, _on_sigint)
    if hasattr(signal, "setitimer"):
        signal.signal(signal.SIGALRM, _on_retry)


def interrupt_seen() -> None:
    """The command has handled the interrupt: ignore every later SIGINT, stop checking.

    Ignored by the system, not by the handler: the interpreter puts back the default action (end
    the process) for Python handlers when it shuts down, and a Ctrl-C then killed the command.
    """
    global _seen
    _seen = True
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, 0)


def shutting_down() -> bool:
    """Whether a KeyboardInterrupt is being handled here (or was handled by the command)."""
    if _seen:
        return True
    error = sys.exc_info()[1]
    while error is not None:
        if isinstance(error, KeyboardInterrupt):
            return True
        error = error.__context__
    return False


def _check_again_later() -> None:
    if hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, RETRY_S)


def _on_sigint(signum: int, frame: Any) -> None:
    if os.getpid() != _owner_pid or shutting_down():
        return
    _check_again_later()
    raise KeyboardInterrupt


def _on_retry(signum: int, frame: Any) -> None:
    if os.getpid() != _owner_pid or _seen:
        return
    _check_again_later()
    if not shutting_down():  # the KeyboardInterrupt raised before never arrived: raise it again
        raise KeyboardInterrupt
