"""Read a run folder for the report: what ``neuronav run``, ``compare`` and ``sweep`` wrote.

A folder is one of three kinds, told apart by the files in it:

- ``run``: ``summary.json`` with a ``trials`` count and ``metrics`` (also each point of a sweep and
  each backend of a compare), with ``trials.csv``, ``timeseries.h5``, ``*.png`` and ``trial0.mp4``;
- ``compare``: ``compare.json`` (or ``compare.md``) and one run folder per backend;
- ``sweep``: ``summary.json`` with a list of ``points``, one run folder per grid point.

Nothing here draws; the arrays of ``timeseries.h5`` are read only when asked (:meth:`RunFolder.series`).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from neuronav.errors import ConfigError


@dataclass
class RunFolder:
    """One folder of results.

    Attributes
    ----------
    path : Path
        The folder.
    kind : str
        ``"run"``, ``"compare"`` or ``"sweep"``.
    summary : dict
        ``summary.json`` (a compare folder: ``compare.json``), or ``{}``.
    settings : dict
        ``settings.json``, or ``{}``.
    rows : list of dict
        ``trials.csv``, one dict per trial (values as text).
    figures : list of Path
        The folder's ``*.png``, sorted by name.
    videos : list of Path
        The folder's ``*.mp4``, sorted by name.
    children : list of RunFolder
        A compare's backends or a sweep's points, in their order; ``[]`` for a run.
    label : str
        A short name for headings (the backend, the point, or the folder's name).
    """

    path: Path
    kind: str
    summary: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    rows: list[dict] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    videos: list[Path] = field(default_factory=list)
    children: list[RunFolder] = field(default_factory=list)
    label: str = ""

    def series(self) -> dict[str, np.ndarray]:
        """The arrays of ``timeseries.h5`` by name (``{}`` when the run recorded none)."""
        path = self.path / "timeseries.h5"
        if not path.is_file():
            return {}
        import h5py

        try:
            with h5py.File(path, "r") as store:
                return {name: np.asarray(store[name]) for name in store if isinstance(store[name], h5py.Dataset)}
        except OSError as error:
            raise ConfigError(f"{path} is not a readable HDF5 file ({error})") from None


def load(path: str | Path) -> RunFolder:
    """Read the run, compare or sweep folder ``path``.

    Raises
    ------
    ConfigError
        When ``path`` does not exist, is not a folder, or holds none of a run's, compare's or
        sweep's files.
    """
    folder = Path(path)
    if not folder.exists():
        raise ConfigError(f"report: {str(folder)!r} does not exist; give a folder written by neuronav run, "
                          "compare or sweep")
    if not folder.is_dir():
        raise ConfigError(f"report: {str(folder)!r} is not a folder; give a folder written by neuronav run, "
                          "compare or sweep")
    if (folder / "compare.json").is_file() or (folder / "compare.md").is_file():
        return _compare(folder)
    summary = _json(folder / "summary.json")
    if isinstance(summary.get("points"), list):
        return _sweep(folder, summary)
    if "metrics" in summary and "trials" in summary:
        return _run(folder, summary, label=folder.name)
    raise ConfigError(f"report: {str(folder)!r} is not a run folder (no summary.json with metrics, and no "
                      "compare.json); give a folder written by neuronav run, compare or sweep")


def _run(folder: Path, summary: dict, label: str) -> RunFolder:
    return RunFolder(path=folder, kind="run", summary=summary, settings=_json(folder / "settings.json"),
                     rows=_csv(folder / "trials.csv"), figures=sorted(folder.glob("*.png")),
                     videos=finished_videos(folder), label=label)


def _compare(folder: Path) -> RunFolder:
    document = _json(folder / "compare.json")
    backends = document.get("backends") or sorted(p.name for p in folder.iterdir()
                                                  if (p / "summary.json").is_file())
    children = []
    for backend in backends:
        summary = _json(folder / backend / "summary.json")
        if summary:
            children.append(_run(folder / backend, summary, label=str(backend)))
    return RunFolder(path=folder, kind="compare", summary=document, settings=_json(folder / "settings.json"),
                     rows=_csv(folder / "compare.csv"), figures=sorted(folder.glob("*.png")),
                     videos=finished_videos(folder), children=children, label=folder.name)


def _sweep(folder: Path, summary: dict) -> RunFolder:
    children = []
    for point in summary["points"]:
        name = str(point.get("dir", "")) if isinstance(point, dict) else ""
        child = _json(folder / name / "summary.json") if name else {}
        if child:
            children.append(_run(folder / name, child, label=name))
    return RunFolder(path=folder, kind="sweep", summary=summary, settings=_json(folder / "settings.json"),
                     rows=_csv(folder / "trials.csv"), figures=sorted(folder.glob("*.png")),
                     videos=finished_videos(folder), children=children, label=folder.name)


def _json(path: Path) -> dict:
    """A JSON object from ``path``; ``{}`` when the file is missing. ConfigError when it is not JSON."""
    if not path.is_file():
        return {}
    try:
        document = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise ConfigError(f"report: {path} is not valid JSON ({error})") from None
    return document if isinstance(document, dict) else {}


def _csv(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def finished_videos(folder: Path) -> list[Path]:
    """The MP4s in ``folder``, sorted, but for those still being written (``*.partial.mp4``: a run that was
    stopped while filming leaves one)."""
    return sorted(path for path in folder.glob("*.mp4") if not path.name.endswith(".partial.mp4"))
