"""The numbers the desert ant's spec solves for, kept for the default ant so that building it needs no
scipy.optimize (importing it costs about 0.23 s, a fifth of a short run's start-up).

Building the ant solves two things with scipy: each leg's coxa tilt (``brentq`` and a bounded
``minimize_scalar``) and rotation matrices turned into quaternions (``Rotation``). This module
keeps the exact results for the inputs the default ant (``desert_ant()``) asks for, in
``solved.json``, keyed by the exact inputs (``repr`` of the floats: they round-trip bit for bit).
Any other input — another scale, other legs — is solved by scipy on the spot, so every ant is
exactly what scipy gives; ``tests/unit/test_desert_ant_solved.py`` re-solves the whole table with
scipy and requires it bit for bit, and requires the default ant built from the table to equal the
one built by scipy alone.

Rewrite the table (after a change to the ant's geometry) with
``python -m neuronav.bodies.desert_ant.solved --write``.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

TABLE_PATH = Path(__file__).resolve().parent / "solved.json"


def tilt_key(target_depth: float, anchor_z: float, lengths, rest) -> str:
    """The table's key of one coxa-tilt problem: its exact inputs."""
    return repr((float(target_depth), float(anchor_z), tuple(float(v) for v in lengths),
                 tuple(float(v) for v in rest)))


def matrix_key(matrix: np.ndarray) -> str:
    """The table's key of one rotation matrix: its nine entries, exactly."""
    return repr(tuple(float(v) for v in np.asarray(matrix, float).ravel()))


def _load() -> dict:
    try:
        table = json.loads(TABLE_PATH.read_text())
        return {"tilts": dict(table["tilts"]), "quats": {k: tuple(v) for k, v in table["quats"].items()}}
    except (OSError, ValueError, KeyError, TypeError):
        return {"tilts": {}, "quats": {}}  # no table: everything is solved on the spot


TABLE = _load()
# While rewriting the table: every solved value is recorded here (key -> value).
_recording: dict | None = None
# Tests set this to solve everything with scipy, ignoring the table.
use_table = True


def lookup(kind: str, key: str, solve: Callable[[], object]):
    """The kept value of ``key`` (``kind``: ``tilts`` or ``quats``), else ``solve()``'s (recorded when rewriting)."""
    if use_table and _recording is None and key in TABLE[kind]:
        return TABLE[kind][key]
    value = solve()
    if _recording is not None:
        _recording[kind][key] = value
    return value


def solve_everything() -> dict:
    """Build the default ant with scipy alone and return every value it solved, by key."""
    global _recording
    from neuronav.bodies.desert_ant.body import desert_ant

    _recording = {"tilts": {}, "quats": {}}
    try:
        desert_ant()
        return _recording
    finally:
        _recording = None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"rewrite {TABLE_PATH.name} (in the package)")
    args = parser.parse_args()
    # Run as ``python -m`` this file is ``__main__``; the ant records into the package's module.
    import importlib

    solved = importlib.import_module("neuronav.bodies.desert_ant.solved").solve_everything()
    text = json.dumps({"tilts": solved["tilts"], "quats": {k: list(v) for k, v in solved["quats"].items()}},
                      indent=1, sort_keys=True) + "\n"
    if args.write:
        TABLE_PATH.write_text(text)
        print(f"wrote {TABLE_PATH} ({len(solved['tilts'])} tilts, {len(solved['quats'])} quaternions)")
    else:
        print(text)


if __name__ == "__main__":
    main()
