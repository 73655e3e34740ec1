"""The GL contexts MuJoCo's eyes render in: kept across the backends of a process, and safe after ``fork``.

One process, one set of contexts
--------------------------------
A new GL context costs the first read of a backend about 80 ms of CPU more than a kept one (with
Mesa's software rasteriser: the driver's start-up per context), a trial's first read 138 ms before
and 11 ms now with the eyes' shadow map gone too (``benchmarks/vision_speed.py`` prints both).
:func:`acquire` hands out a free context of the asked size if one is kept, and :func:`release` keeps
it (at most :data:`KEPT_PER_SIZE` per size) for the next backend of the process, e.g. the next trial.
What is model-bound (MuJoCo's ``MjrContext``: meshes, textures) is freed before the release,
so a kept context carries nothing from one model to the next.

Fork
----
Mesa's software rasteriser (llvmpipe, what EGL gives on a machine without a GPU) runs worker threads
per context; a child forked after the parent made a context has the driver's state but none of its
threads, and its first render waits on them for ever (``gymnasium.vector.AsyncVectorEnv`` and pool
workers hung that way). Importing this module therefore sets ``LP_NUM_THREADS=0`` unless it is set
already: llvmpipe then rasterises in the calling thread, and a forked child renders in contexts of
its own. On the 2-core test machine a binocular read costs the same or less than with one rasteriser
thread (compare ``LP_NUM_THREADS=1 python benchmarks/vision_speed.py`` with the default).

Every context remembers the process that made it. A child never touches its parent's contexts (it
neither renders in them nor frees them: they are kept referenced in :data:`_INHERITED` for the
child's life) and makes its own. If the parent's driver ran rasteriser threads (``LP_NUM_THREADS`` set
to anything but 0 before the first context), a child refuses to render with a
:class:`~neuronav.errors.SimulationError` that names the fixes instead of hanging.
"""

from __future__ import annotations

import atexit
import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("LP_NUM_THREADS", "0")

import mujoco  # noqa: E402

from neuronav.errors import SimulationError  # noqa: E402

# Free contexts kept per (width, height) for the next backend of the process.
KEPT_PER_SIZE = 2

# Contexts a parent process made: a forked child keeps them referenced and never calls into them.
_INHERITED: list = []


class _Contexts:
    """This process's contexts: which process made them, with what rasteriser threads, and the free ones."""

    def __init__(self) -> None:
        self.pid: int | None = None  # the process that made a GL context first (None: none yet)
        self.threads: str | None = None  # LP_NUM_THREADS when it did
        self.free: dict[tuple[int, int], list] = {}
        self.made = 0  # contexts made by this process (for tests and benchmarks)
        self.exit_hook = False


_STATE = _Contexts()


def _this_process() -> _Contexts:
    """The state of this process, after a fork too (the parent's contexts handed to :data:`_INHERITED`)."""
    pid = os.getpid()
    if _STATE.pid is not None and _STATE.pid != pid:
        if _STATE.threads != "0" and os.environ.get("MUJOCO_GL", "egl") in ("egl", "osmesa"):
            raise SimulationError(
                f"mujoco backend: this process was forked from one (pid {_STATE.pid}) that had made a GL context "
                f"with LP_NUM_THREADS={_STATE.threads!r}; rendering here would hang in the GL driver. Start "
                "children with the 'spawn' method (e.g. gymnasium.vector.AsyncVectorEnv(..., context=\"spawn\"), "
                "multiprocessing.get_context(\"spawn\")) or set LP_NUM_THREADS=0 before the first render")
        for contexts in _STATE.free.values():
            _INHERITED.extend(contexts)
        _STATE.free, _STATE.made, _STATE.pid = {}, 0, pid
    return _STATE


def acquire(width: int, height: int) -> mujoco.GLContext:
    """A GL context of ``width`` x ``height`` px made by this process, current: a kept one, else a new one."""
    state = _this_process()
    key = (int(width), int(height))
    kept = state.free.get(key)
    if kept:
        context = kept.pop()
    else:
        context = mujoco.GLContext(*key)
        state.made += 1
        if state.pid is None:
            state.pid, state.threads = os.getpid(), os.environ.get("LP_NUM_THREADS")
        if not state.exit_hook:  # after mujoco's own hook (it ends EGL at exit): ours runs first
            atexit.register(free_kept)
            state.exit_hook = True
    context.make_current()
    return context


def release(context: mujoco.GLContext, width: int, height: int, pid: int) -> None:
    """Give back a context made by process ``pid`` (from :func:`acquire`), its model-bound resources freed.

    Kept for the next :func:`acquire` of its size (freed when enough are kept); a context made by
    another process (this one is a forked child) is only kept referenced, never called.
    """
    if pid != os.getpid():
        abandon(context)
        return
    kept = _this_process().free.setdefault((int(width), int(height)), [])
    if len(kept) < KEPT_PER_SIZE:
        kept.append(context)
    else:
        context.free()


def contexts_made() -> int:
    """How many GL contexts this process has made through :func:`acquire`."""
    return _this_process().made


def free_kept() -> None:
    """Free the kept contexts of this process (at exit, before EGL itself is ended; or to start afresh)."""
    if _STATE.pid != os.getpid():
        return
    free_all(_STATE.free)
    _STATE.free = {}


def free_all(kept: dict) -> None:
    """Free every context of ``kept`` (lists of contexts by size), whatever each free says: at interpreter
    shutdown the driver may already be gone."""
    for contexts in kept.values():
        for context in contexts:
            try:
                context.free()
            except Exception:  # noqa: BLE001 -- interpreter shutdown: the driver may already be gone
                pass


def abandon(resource) -> None:
    """Keep ``resource`` (a GL context, a renderer or an ``MjrContext`` a parent process made) referenced
    for this process's life without calling into it: freeing it here would call the parent's driver state."""
    _INHERITED.append(resource)
