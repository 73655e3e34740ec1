"""The grid of a sweep: ``--grid key=v1,v2`` parsed into typed values, points, labels and folder names."""

from __future__ import annotations

import hashlib
import itertools
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from neuronav.config import build_config, parse_overrides, parse_value
from neuronav.errors import ConfigError


@dataclass(frozen=True)
class GridPoint:
    """One point of a sweep's grid.

    Attributes
    ----------
    index : int
        Position in the grid (the product of the keys' values, in the order given).
    labels : dict of str to str
        Each grid key's value as text (the canonical form of the typed value).
    name : str
        Folder of the point in the run directory ("" for a plain run).
    config : dataclass
        The point's validated config.
    """

    index: int
    labels: dict
    name: str
    config: Any


def label(value: Any) -> str:
    """The canonical text of a typed grid value (``true``/``false`` for booleans)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def _items(grid: Mapping[str, Any] | Sequence[str]) -> list[tuple[str, Any]]:
    if isinstance(grid, str):
        grid = [grid]
    if isinstance(grid, Mapping):
        return list(grid.items())
    items = []
    for item in grid:
        if not isinstance(item, str) or "=" not in item:
            raise ConfigError(f"--grid expects key=v1,v2,..., got {item!r}")
        key, values = item.split("=", 1)
        items.append((key.strip(), values))
    return items


def _raw_values(key: str, values: Any) -> list:
    if isinstance(values, str):
        if values.strip() == "":
            raise ConfigError(f"--grid {key!r} has no values")
        raw = values.split(",")
        if any(v.strip() == "" for v in raw):
            raise ConfigError(f"--grid {key!r} has an empty value in {values!r}; list the values as v1,v2")
        return raw
    if isinstance(values, bytes) or not isinstance(values, Iterable):
        raise ConfigError(f"--grid {key!r}: expected a list of values, got {values!r}")
    raw = list(values)
    if not raw:
        raise ConfigError(f"--grid {key!r} has no values")
    return raw


def parse_grid(config_type: type, grid: Mapping[str, Any] | Sequence[str] | None) -> dict[str, list[tuple[Any, str]]]:
    """The grid as ``{key: [(typed value, label), ...]}``.

    ``grid`` is either the CLI's ``key=v1,v2`` strings or a mapping of keys to values (a list, or
    a comma-separated string). Keys must be config keys; each value is parsed and checked for its
    type; a key given twice, no values, an empty value (``a,,b``) or a value listed twice is an error.
    """
    if grid is None:
        return {}
    parsed: dict[str, list[tuple[Any, str]]] = {}
    for key, values in _items(grid):
        if key in parsed:
            raise ConfigError(f"--grid {key!r} is given twice; list all its values in one --grid")
        entries: list[tuple[Any, str]] = []
        for value in _raw_values(key, values):
            typed = parse_value(config_type, key, value) if isinstance(value, str) else \
                parse_overrides(config_type, {key: value})[key]
            text = label(typed)
            if any(text == known for _, known in entries):
                raise ConfigError(f"--grid {key!r} lists the value {text} twice")
            entries.append((typed, text))
        parsed[key] = entries
    return parsed


_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]")


def point_name(labels: Mapping[str, str]) -> str:
    """A folder name for a grid point: ``key=value_key=value``, made safe for file systems."""
    text = "_".join(f"{k}={v}" for k, v in labels.items())
    safe = _UNSAFE.sub("_", text)
    if safe != text or len(safe) > 100 or safe.startswith("."):
        safe = f"{safe.lstrip('.')[:80]}-{hashlib.sha1(text.encode('utf-8', 'surrogatepass')).hexdigest()[:10]}"
    return safe


def grid_points(config_type: type, base: Mapping[str, Any], grid: dict[str, list[tuple[Any, str]]]) -> list[GridPoint]:
    """Every point of the grid, its config validated (the grid's values over ``base``)."""
    keys = list(grid)
    points = []
    for index, combination in enumerate(itertools.product(*(grid[k] for k in keys))):
        values = {k: typed for k, (typed, _) in zip(keys, combination)}
        labels = {k: text for k, (_, text) in zip(keys, combination)}
        config = build_config(config_type, base, values)
        points.append(GridPoint(index=index, labels=labels, name=point_name(labels) if keys else "", config=config))
    return points
