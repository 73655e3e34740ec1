"""The run directory: summary.json, trials.csv, timeseries.h5 and figures, written atomically.

Every file is written to a temporary name in the same directory and renamed into place, so a
reader (or a resumed run) never sees half a file.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

FIXED_COLUMNS = ("trial", "seed", "success", "status", "error")
VERSIONED_PACKAGES = ("neuronav", "numpy", "scipy", "networkx", "matplotlib", "h5py", "mujoco",
                      "dm-control", "pybullet", "dask", "distributed")


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    mode = "wb" if isinstance(data, bytes) else "w"
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, mode) as stream:
            stream.write(data)
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
) -> dict:
    """Write summary.json, trials.csv and timeseries.h5 into ``out_dir``; return the summary."""
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
    }
    write_atomic(out_dir / "trials.csv", trials_csv(trials))
    if timeseries:
        write_timeseries(out_dir / "timeseries.h5", timeseries)
    write_atomic(out_dir / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary
