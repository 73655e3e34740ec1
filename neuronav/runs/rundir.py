"""The run directory: summary.json, trials.csv, timeseries.h5 and figures, written atomically.

Every file is written to a temporary name in the same directory and renamed into place, so a
reader (or a resumed run) never sees half a file.

A run or sweep also keeps (see :mod:`neuronav.runs.sweep`):

- ``.neuronav-run`` — the marker: this folder was made by a neuronav run (its kind and when). A run
  writes only into a folder that does not exist yet, an empty folder, or a folder with this marker
  (:func:`check_out_dir`); anything else is refused before a file is touched, and so is a marker
  neuronav did not write (a link, not a regular file, over :data:`MARKER_MAX_BYTES`, another
  record). While a process works in the folder it holds an exclusive ``flock`` on the marker
  (:class:`DirectoryLock`), released by the kernel however the process ends; no separate lock file
  is left behind.
- ``settings.json`` — what the directory holds (scenario, backend, seed, trials, config, grid),
  written before the first trial runs; a rerun with other settings is refused while the folder
  holds finished trials, and may reuse it when it holds none (a start that failed).
- ``parts/[POINT/]trials-FIRST-LAST.npz`` — one file per finished chunk of trials: its rows, time
  series and aggregates. The results above are assembled from the parts.
"""

from __future__ import annotations

import csv
import errno
import io
import json
import math
import os
import platform
import re
import stat
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from neuronav.errors import ConfigError

FIXED_COLUMNS = ("trial", "seed", "success", "status", "error")
VERSIONED_PACKAGES = ("neuronav", "numpy", "scipy", "networkx", "matplotlib", "h5py", "mujoco",
                      "dm-control", "pybullet", "dask", "distributed")


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# Read once at import: os.umask is process-wide, so it is not touched while tasks run in threads.
_UMASK = _current_umask()


def _readable(path: str) -> None:
    """mkstemp makes 0600 files; results are for everyone who may read the directory (umask applies)."""
    os.chmod(path, 0o666 & ~_UMASK)


def write_atomic(path: Path, data) -> None:
    """Write ``data`` to ``path`` through a temporary file, an fsync and a rename.

    ``data`` is text, bytes, or a function that writes into the (binary) stream it is given.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    mode = "w" if isinstance(data, str) else "wb"
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    _readable(temporary)
    try:
        with os.fdopen(handle, mode) as stream:
            if callable(data):
                data(stream)
            else:
                stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def package_versions() -> dict[str, str]:
    """Versions of Python and the installed packages neuronav's numbers depend on."""
    versions = {"python": platform.python_version()}
    for name in VERSIONED_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return versions


def git_revision() -> str:
    """The git commit of the neuronav source tree, or "" when it is not a git checkout."""
    try:
        root = Path(__file__).resolve().parent.parent
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=5, check=False)
        return out.stdout.strip() if out.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        return ""


def _json_number(value: Any) -> Any:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def aggregate(trials: list[dict]) -> tuple[dict[str, float], dict[str, float]]:
    """Mean and standard deviation of every numeric metric over the trials that finished."""
    done = [t for t in trials if t.get("status", "ok") == "ok"]
    keys = [k for k in (done[0] if done else {}) if k not in ("trial", "seed", "status", "error")]
    means, stds = {}, {}
    for key in keys:
        values = np.array([float(t[key]) for t in done if isinstance(t.get(key), (int, float, np.number, bool))])
        values = values[np.isfinite(values)]
        if values.size:
            means[key], stds[key] = float(values.mean()), float(values.std())
    return means, stds


def trials_csv(trials: list[dict], extra_columns: tuple[str, ...] = ()) -> str:
    """The CSV text of ``trials``: extra (grid) columns, the fixed columns, then the metrics."""
    metric_columns: list[str] = []
    for trial in trials:
        for key in trial:
            if key not in FIXED_COLUMNS and key not in extra_columns and key not in metric_columns:
                metric_columns.append(key)
    columns = [*extra_columns, *FIXED_COLUMNS, *metric_columns]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for trial in trials:
        row = {k: _json_number(v) for k, v in trial.items()}
        row.setdefault("error", "")
        writer.writerow(row)
    return buffer.getvalue()


def write_timeseries(path: Path, timeseries: dict[str, np.ndarray]) -> None:
    """Write arrays into an HDF5 file (atomically: a temporary file, then a rename)."""
    import h5py

    path = Path(path)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    _readable(temporary)
    os.close(handle)
    try:
        with h5py.File(temporary, "w") as store:
            for name, array in timeseries.items():
                store.create_dataset(name, data=np.asarray(array), compression="gzip", compression_opts=4)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def write_run_directory(
    out_dir: Path, *, scenario: str, backend: str, seed: int, config: dict, trials: list[dict],
    aggregates: dict[str, float], timeseries: dict[str, np.ndarray], wall_time_s: float,
    simulated_time_s: float, figures: list[Path], command: list[str] | None = None,
    extra: dict[str, Any] | None = None,
) -> dict:
    """Write summary.json, trials.csv and timeseries.h5 into ``out_dir``; return the summary.

    ``extra`` adds fields to the summary (e.g. how a sweep ran: chunks, resumed trials).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    means, stds = aggregate(trials)
    means.update({k: float(v) for k, v in aggregates.items()})
    failed = [t for t in trials if t.get("status", "ok") != "ok"]
    summary = {
        "scenario": scenario,
        "backend": backend,
        "trials": len(trials),
        "failed_trials": len(failed),
        "seed": seed,
        "config": {k: _json_number(v) for k, v in config.items()},
        "metrics": {k: _json_number(v) for k, v in means.items()},
        "metrics_std": {k: _json_number(v) for k, v in stds.items()},
        "wall_time_s": wall_time_s,
        "simulated_time_s": simulated_time_s,
        "versions": package_versions(),
        "git_revision": git_revision(),
        "command": command or sys.argv,
        "figures": [Path(f).name for f in figures],
        **(extra or {}),
    }
    write_atomic(out_dir / "trials.csv", trials_csv(trials))
    if timeseries:
        write_timeseries(out_dir / "timeseries.h5", timeseries)
    elif (out_dir / "timeseries.h5").exists():
        os.unlink(out_dir / "timeseries.h5")  # a stale file from an earlier run would mislead
    write_atomic(out_dir / "summary.json", json.dumps(summary, indent=2, default=json_default) + "\n")
    return summary


# -- parts, settings and the lock (resumable runs) ------------------------------------------------------

SETTINGS_FILE = "settings.json"
VIDEO_NAME = "trial0.mp4"  # --video films the first trial into this file of the run folder
PARTS_DIR = "parts"
MARKER_FILE = ".neuronav-run"
# A marker holds about 90 bytes of JSON; a larger file is not one, and is not read further.
MARKER_MAX_BYTES = 4096
# Folders made before the marker existed hold this (empty) lock file and a settings.json of kind run
# or sweep; they are adopted (marker added, lock file removed) so that they can still be resumed.
LEGACY_LOCK_FILE = ".neuronav.lock"
# Kinds of run folder; a folder of one group is never reused by a command of the other.
_MARKER_GROUPS = {"run": "results", "sweep": "results", "compare": "compare"}
SETTINGS_FORMAT = 1
# The settings a rerun must repeat to resume a directory (the rest is recorded, not compared).
COMPARED_SETTINGS = ("kind", "scenario", "backend", "seed", "trials", "config", "grid")
_PART_NAME = re.compile(r"^trials-(\d+)-(\d+)\.npz$")
_ROWS_KEY, _META_KEY, _SERIES_PREFIX = "__rows__", "__meta__", "ts."


def json_default(value: Any) -> Any:
    """JSON for numpy scalars and arrays, paths and tuples (``json.dumps(..., default=json_default)``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    return str(value)


def part_name(first: int, count: int) -> str:
    """File name of the part holding trials ``first .. first + count - 1``."""
    return f"trials-{first:06d}-{first + count - 1:06d}.npz"


def part_range(name: str) -> tuple[int, int] | None:
    """(first, count) of a part file name, or None when ``name`` is not one."""
    match = _PART_NAME.match(name)
    if match is None:
        return None
    first, last = int(match.group(1)), int(match.group(2))
    return (first, last - first + 1) if last >= first else None


def write_part(path: Path, rows: list[dict], timeseries: dict[str, np.ndarray], meta: dict) -> None:
    """Write one finished chunk (rows, time series, meta) as one ``.npz`` file, atomically.

    The rows and meta are stored as JSON text (NaN allowed), the time series as plain arrays
    (uncompressed: parts are read back once, when the results are assembled).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {_ROWS_KEY: np.array(json.dumps(rows, default=json_default)),
              _META_KEY: np.array(json.dumps(meta, default=json_default))}
    for key, value in timeseries.items():
        array = np.asarray(value)
        if array.dtype.kind in "biufc":  # numbers only: parts are read without pickle
            arrays[_SERIES_PREFIX + key] = array
    write_atomic(path, lambda stream: np.savez(stream, **arrays))


def read_part(path: Path, timeseries: bool = True) -> tuple[list[dict], dict[str, np.ndarray], dict]:
    """(rows, time series, meta) of a part file written by :func:`write_part`."""
    with np.load(path, allow_pickle=False) as store:
        rows = json.loads(str(store[_ROWS_KEY]))
        meta = json.loads(str(store[_META_KEY]))
        series = {name[len(_SERIES_PREFIX):]: store[name] for name in store.files
                  if timeseries and name.startswith(_SERIES_PREFIX)}
    return rows, series, meta


def list_parts(folder: Path) -> list[tuple[int, int, Path]]:
    """The readable parts in ``folder`` as (first, count, path), sorted by first trial.

    A part that cannot be read (which atomic writes should make impossible, short of a disk
    error) is renamed ``*.corrupt`` so that its trials run again.
    """
    found = []
    folder = Path(folder)
    if not folder.is_dir():
        return found
    for path in sorted(folder.iterdir()):
        span = part_range(path.name)
        if span is None:
            continue
        try:
            with np.load(path, allow_pickle=False) as store:
                if _ROWS_KEY not in store.files:
                    raise ValueError("no rows")
        except Exception:  # noqa: BLE001 - any unreadable part is set aside and recomputed
            os.replace(path, path.with_name(path.name + ".corrupt"))
            continue
        found.append((*span, path))
    return sorted(found)


def remove_stale_temporaries(folder: Path) -> None:
    """Delete the temporary files (``.NAME.*.tmp``) a killed writer left in ``folder``."""
    folder = Path(folder)
    if folder.is_dir():
        for path in folder.glob(".*.tmp"):
            try:
                path.unlink()
            except OSError:
                pass


def _normalised(value: Any) -> Any:
    return json.loads(json.dumps(value, default=json_default))


def has_results(out_dir: Path) -> bool:
    """Whether ``out_dir`` holds a finished trial: a part file anywhere under its ``parts`` folder."""
    parts = Path(out_dir) / PARTS_DIR
    if not parts.is_dir():
        return False
    return any(part_range(path.name) is not None for path in parts.rglob("trials-*.npz"))


def _recorded_settings(out_dir: Path, settings: dict) -> dict | None:
    """The settings recorded in ``out_dir`` when they must be kept (the folder holds finished trials of
    them); None when the folder may take ``settings`` (none recorded, or no finished trial).

    Raises :class:`ConfigError` naming the first difference when the recorded settings differ and the
    folder holds finished trials. Writes nothing.
    """
    path = Path(out_dir) / SETTINGS_FILE
    if not path.exists() or not has_results(out_dir):
        return None  # nothing recorded, or a start that failed before its first trial: no results to keep
    try:
        recorded = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ConfigError(f"run directory {str(out_dir)!r}: {SETTINGS_FILE} cannot be read ({error}); "
                          "give another --out or remove that directory") from None
    have = _normalised({key: recorded.get(key) for key in COMPARED_SETTINGS})
    wanted = _normalised({key: settings.get(key) for key in COMPARED_SETTINGS})
    if have != wanted:
        where, old, new = _first_difference(have, wanted)
        raise ConfigError(
            f"run directory {str(out_dir)!r} holds results with other settings ({where}: {old!r} there, "
            f"{new!r} now); give another --out, or rerun the command that made it to resume"
        )
    return recorded


def check_resumable(out_dir: Path, settings: dict) -> None:
    """Raise :class:`ConfigError` when ``out_dir`` holds finished trials of other settings; write nothing."""
    if Path(out_dir).is_dir():
        _recorded_settings(out_dir, settings)


def check_settings(out_dir: Path, settings: dict) -> bool:
    """Record ``settings`` in ``out_dir/settings.json``, or check they match the recorded ones.

    Returns True when the directory already held finished trials of these settings (a resumed run).
    Raises :class:`ConfigError` naming the first difference when it held finished trials of other
    ones; a directory with no finished trial (see :func:`has_results`) takes the new settings.
    """
    recorded = _recorded_settings(out_dir, settings)
    if recorded is None:
        write_atomic(Path(out_dir) / SETTINGS_FILE,
                     json.dumps({"format": SETTINGS_FORMAT, **settings}, indent=2, default=json_default) + "\n")
        return False
    versions = _normalised(settings.get("versions") or {})
    changed = sorted(k for k in versions if recorded.get("versions", {}).get(k, versions[k]) != versions[k])
    if changed:
        first = changed[0]
        sys.stderr.write(f"neuronav: warning: {str(out_dir)!r} was started with {first} "
                         f"{recorded['versions'][first]} (now {versions[first]}); trials computed now may "
                         "differ from the earlier ones in rounding\n")
    return True


def _first_difference(a: Any, b: Any, where: str = "") -> tuple[str, Any, Any]:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in [*a, *(k for k in b if k not in a)]:
            if a.get(key, "<absent>") != b.get(key, "<absent>"):
                return _first_difference(a.get(key, "<absent>"), b.get(key, "<absent>"),
                                         f"{where}.{key}" if where else str(key))
    return where or "settings", a, b


def _out_label(path: Path | str) -> str:
    return repr(str(path))


def check_out_dir(out_dir: Any, kind: str = "run", flag: str = "--out") -> Path:
    """The run folder ``out_dir`` as a Path, checked to be one a ``kind`` run may write into; writes nothing.

    Allowed: a path that does not exist yet (its parents are made later), an empty directory, or a
    directory holding neuronav's marker (:data:`MARKER_FILE`, checked by :func:`read_marker`) of the
    same kind of command (run and sweep folders are one kind; compare folders another), or a run or
    sweep folder made before the marker existed (its ``.neuronav.lock`` and ``settings.json``).
    Anything else raises :class:`ConfigError`: an empty path, a file, a folder with other files (the
    user's own, or ``/``), a marker neuronav did not write (a link to ``/etc/passwd``, say).
    """
    if out_dir is None or (isinstance(out_dir, str) and not out_dir.strip()):
        raise ConfigError(f"{flag} {out_dir!r} is empty; give a folder for the results")
    try:
        path = Path(out_dir)
        if "\x00" in str(path):  # pathlib's exists() says False for it, and mkdir then raises ValueError
            raise ValueError("embedded null byte")
        exists = path.exists()
    except (TypeError, ValueError, OSError) as error:
        raise ConfigError(f"{flag} {out_dir!r} is not a usable path ({error})") from None
    if not exists:
        if path.is_symlink():
            raise ConfigError(f"{flag} {_out_label(path)} is a broken link; give a folder")
        return path
    if not path.is_dir():
        raise ConfigError(f"{flag} {_out_label(path)} is a file; give a directory")
    marker = path / MARKER_FILE
    if os.path.lexists(marker):
        try:
            made_by = read_marker(marker)["kind"]
        except ForeignMarker as error:
            raise ConfigError(f"{flag} {_out_label(path)} holds a {MARKER_FILE} that is not neuronav's marker "
                              f"({error}); give a new or empty folder") from None
        if _MARKER_GROUPS.get(made_by) != _MARKER_GROUPS.get(kind):
            raise ConfigError(f"{flag} {_out_label(path)} holds the results of a neuronav {made_by}, not of a "
                              f"{kind}; give another folder")
        return path
    if _legacy_run_folder(path) in ("run", "sweep") and _MARKER_GROUPS.get(kind) == "results":
        return path
    try:
        with os.scandir(path) as entries:
            empty = next(entries, None) is None
    except OSError as error:
        raise ConfigError(f"{flag} {_out_label(path)} cannot be read ({error.strerror or error})") from None
    if not empty:
        raise ConfigError(f"{flag} {_out_label(path)} holds files that no neuronav run wrote (it has no "
                          f"{MARKER_FILE} marker); give a new or empty folder")
    return path


def _legacy_run_folder(path: Path) -> str | None:
    """The kind ("run"/"sweep") of a run folder made before the marker existed, else None."""
    try:
        if not stat.S_ISREG(os.lstat(path / LEGACY_LOCK_FILE).st_mode):  # a link is not neuronav's
            return None
    except OSError:
        return None
    try:
        settings = json.loads((path / SETTINGS_FILE).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(settings, dict) or "format" not in settings:
        return None
    return settings.get("kind") if settings.get("kind") in ("run", "sweep") else None


class ForeignMarker(Exception):
    """A ``.neuronav-run`` that neuronav did not write; the message says why (\"it is a link\")."""


def _open_marker(marker: Path) -> int:
    """A read descriptor of the marker itself: never a link's target, and never blocking on a FIFO.

    Raises :class:`ForeignMarker` when it is a link or not a regular file, and OSError when it
    cannot be opened.
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        if stat.S_ISLNK(os.lstat(marker).st_mode):  # also where O_NOFOLLOW does not exist
            raise ForeignMarker("it is a link")
        fd = os.open(marker, flags)
    except OSError as error:
        if error.errno == errno.ELOOP:  # replaced by a link since the lstat
            raise ForeignMarker("it is a link") from None
        raise
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise ForeignMarker("it is not a regular file")
    return fd


def read_marker(marker: Path) -> dict:
    """The record in neuronav's marker ``marker``: ``made_by``, ``kind``, ``created``.

    At most :data:`MARKER_MAX_BYTES` are read. Raises :class:`ForeignMarker` when the file is a
    link, not a regular file, longer than that, unreadable, or not a record neuronav wrote.
    """
    try:
        fd = _open_marker(marker)
        with os.fdopen(fd, "rb") as stream:
            data = stream.read(MARKER_MAX_BYTES + 1)
    except OSError as error:
        raise ForeignMarker(f"it cannot be read: {error.strerror or error}") from None
    if len(data) > MARKER_MAX_BYTES:
        raise ForeignMarker(f"it holds more than the {MARKER_MAX_BYTES} bytes of a marker")
    try:
        record = json.loads(data)
    except ValueError:
        record = None
    if (not isinstance(record, dict) or record.get("made_by") != "neuronav"
            or not isinstance(record.get("kind"), str) or record["kind"] not in _MARKER_GROUPS):
        raise ForeignMarker("it does not hold neuronav's record")
    return record


def _create_marker(folder: Path, kind: str) -> None:
    """Put neuronav's marker into ``folder`` whole, unless one is there: written to a temporary file,
    then hard-linked into place (which, unlike a rename, never replaces an existing file)."""
    marker = folder / MARKER_FILE
    if os.path.lexists(marker):
        return  # an earlier run's (checked by check_out_dir, and again by the lock)
    text = json.dumps({"made_by": "neuronav", "kind": kind, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")}) + "\n"
    handle, temporary = tempfile.mkstemp(dir=folder, prefix=f"{MARKER_FILE}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w") as stream:
            stream.write(text)
        _readable(temporary)
        try:
            os.link(temporary, marker)
        except FileExistsError:
            pass  # made meanwhile by another neuronav process
        except OSError:  # a file system without hard links: create it in place
            fd = os.open(marker, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o666)
            with os.fdopen(fd, "w") as stream:
                stream.write(text)
    finally:
        os.unlink(temporary)


def claim_out_dir(out_dir: Path, kind: str = "run", flag: str = "--out") -> Path:
    """Make the run folder (checked by :func:`check_out_dir`) and put neuronav's marker in it.

    The check is repeated, so a folder filled since is still refused; the marker is created once
    and never rewritten (it is the file :class:`DirectoryLock` locks).
    """
    path = check_out_dir(out_dir, kind, flag)
    try:
        path.mkdir(parents=True, exist_ok=True)
        _create_marker(path, kind)
        if (path / LEGACY_LOCK_FILE).is_file():
            (path / LEGACY_LOCK_FILE).unlink()  # the marker is the lock now
    except (OSError, ValueError) as error:
        raise ConfigError(f"{flag} {_out_label(out_dir)}: cannot create the run directory "
                          f"({error.strerror or error})") from None
    return path


class DirectoryLock:
    """An exclusive ``flock`` on the folder's marker (``out_dir/.neuronav-run``) while a process works there.

    The kernel releases it when the process ends, however it ends (SIGKILL included). Local pool
    workers forked while it is held close their copy of :attr:`fileno` (see
    :func:`neuronav.runs.executors.worker_initializer`), so only this process ever holds it.
    """

    def __init__(self, out_dir: Path) -> None:
        self.path = Path(out_dir) / MARKER_FILE
        self._handle = None

    @property
    def fileno(self) -> int | None:
        """The locked descriptor (None when not held, or not on POSIX)."""
        return self._handle.fileno() if self._handle is not None else None

    def __enter__(self) -> DirectoryLock:
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock
            return self
        try:
            self._handle = os.fdopen(_open_marker(self.path), "rb")
        except (OSError, ForeignMarker) as error:
            raise ConfigError(f"run directory {str(self.path.parent)!r}: its {MARKER_FILE} cannot be locked "
                              f"({getattr(error, 'strerror', None) or error}); give another --out") from None
        try:
            fcntl.flock(self._handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._handle.close()
            self._handle = None
            raise ConfigError(f"run directory {str(self.path.parent)!r} is in use by another neuronav process; "
                              "wait for it or give another --out") from None
        return self

    def __exit__(self, *exc_info: Any) -> None:
        if self._handle is not None:
            self._handle.close()
            self._handle = None
