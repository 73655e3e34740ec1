"""Scenario configurations: dataclasses whose fields carry their type, range and choices.

A field's ``metadata`` may hold ``help`` (a short description), ``min``/``max`` (inclusive bounds),
``min_exclusive`` and ``choices``. :func:`apply_overrides` turns ``key=value`` strings (the CLI's
``--set``) into a validated config; :func:`validate` checks one built in Python.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from typing import Any

from neuronav.errors import ConfigError

_TRUE = {"true", "1", "yes", "on"}
_FALSE = {"false", "0", "no", "off"}


def field(default: Any, help: str = "", **limits: Any) -> Any:
    """A dataclass field with a default, a help text and limits (min, max, min_exclusive, choices)."""
    return dataclasses.field(default=default, metadata=dict(limits, help=help))


def _type_name(kind: type) -> str:
    return {bool: "a boolean (true/false)", int: "an integer", float: "a number", str: "a string"}.get(
        kind, kind.__name__)


def parse_value(config_type: type, key: str, text: str) -> Any:
    """Convert the string ``text`` to the type of field ``key``, or raise :class:`ConfigError`."""
    fields = {f.name: f for f in dataclasses.fields(config_type)}
    if key not in fields:
        raise ConfigError(
            f"unknown key {key!r}; allowed: {', '.join(sorted(fields))}"
        )
    kind = type(fields[key].default)
    cleaned = text.strip()
    try:
        if kind is bool:
            if cleaned.lower() in _TRUE:
                return True
            if cleaned.lower() in _FALSE:
                return False
            raise ValueError
        if kind is int:
            return int(cleaned)
        if kind is float:
            value = float(cleaned)
            if not math.isfinite(value):
                raise ValueError
            return value
        return cleaned
    except ValueError:
        raise ConfigError(f"key {key!r} expects {_type_name(kind)}, got {text!r}") from None


def validate(config: Any) -> Any:
    """Check every field's type, range and choices; return the config or raise :class:`ConfigError`."""
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        kind = type(f.default)
        ok_type = isinstance(value, kind) and not (kind is not bool and isinstance(value, bool))
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            ok_type = True
        if not ok_type:
            raise ConfigError(f"key {f.name!r} expects {_type_name(kind)}, got {value!r}")
        if kind is float and not math.isfinite(value):
            raise ConfigError(f"key {f.name!r} must be finite, got {value!r}")
        meta = f.metadata
        if "choices" in meta and value not in meta["choices"]:
            raise ConfigError(f"key {f.name!r} must be one of {', '.join(map(str, meta['choices']))}; got {value!r}")
        if "min" in meta and value < meta["min"]:
            raise ConfigError(f"key {f.name!r} must be >= {meta['min']}, got {value!r}")
        if "min_exclusive" in meta and value <= meta["min_exclusive"]:
            raise ConfigError(f"key {f.name!r} must be > {meta['min_exclusive']}, got {value!r}")
        if "max" in meta and value > meta["max"]:
            raise ConfigError(f"key {f.name!r} must be <= {meta['max']}, got {value!r}")
        if "max_exclusive" in meta and value >= meta["max_exclusive"]:
            raise ConfigError(f"key {f.name!r} must be < {meta['max_exclusive']}, got {value!r}")
    return config


def split_assignment(text: str) -> tuple[str, str]:
    """``"key=value"`` -> ``("key", "value")``, or a :class:`ConfigError`."""
    if "=" not in text:
        raise ConfigError(f"--set expects key=value, got {text!r}")
    key, value = text.split("=", 1)
    return key.strip(), value


def apply_overrides(config_type: type, assignments: Iterable[str] | dict[str, Any] = ()) -> Any:
    """A validated ``config_type`` from its defaults and ``key=value`` overrides (strings or a dict)."""
    values: dict[str, Any] = {}
    items = assignments.items() if isinstance(assignments, dict) else map(split_assignment, assignments)
    for key, raw in items:
        values[key] = parse_value(config_type, key, raw) if isinstance(raw, str) else raw
    unknown = set(values) - {f.name for f in dataclasses.fields(config_type)}
    if unknown:
        allowed = ", ".join(sorted(f.name for f in dataclasses.fields(config_type)))
        raise ConfigError(f"unknown key {sorted(unknown)[0]!r}; allowed: {allowed}")
    return validate(config_type(**values))


def describe(config_type: type) -> list[tuple[str, Any, str]]:
    """(key, default, help) for every field, for ``neuronav list`` and documentation."""
    return [(f.name, f.default, f.metadata.get("help", "")) for f in dataclasses.fields(config_type)]
