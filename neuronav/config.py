"""Scenario configurations: dataclasses whose fields carry their type, range and choices.

A field's ``metadata`` may hold ``help`` (a short description), ``min``/``max`` (inclusive bounds),
``min_exclusive``, ``max_exclusive`` and ``choices``. :func:`apply_overrides` turns ``key=value``
strings (the CLI's ``--set``) into a validated config; a config class may define ``cross_check(self)``,
called by :func:`validate` once every field is valid, for rules between fields (raising
:class:`ConfigError`); :func:`load_config_file` reads the same keys
from a TOML file (``--config``); :func:`build_config` layers defaults, a file, ``--set`` and a grid
point; :func:`validate` checks a config built in Python.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from neuronav.errors import ConfigError

_TRUE = {"true", "1", "yes", "on"}
_FALSE = {"false", "0", "no", "off"}
# No setting takes a table or an array, so a file nested deeper than this is surely not settings; the
# limit also keeps tomllib's recursive parser (RecursionError at about 500 levels) out of reach.
MAX_TOML_NESTING = 4


def field(default: Any, help: str = "", **limits: Any) -> Any:
    """A dataclass field with a default, a help text and limits (min, max, min_exclusive, choices)."""
    return dataclasses.field(default=default, metadata=dict(limits, help=help))


_ANNOTATIONS = {"bool": bool, "int": int, "float": float, "str": str}


def field_kind(f: dataclasses.Field) -> type:
    """The value type of a config field: its default's type, or its annotation when it has no default."""
    if f.default is not dataclasses.MISSING:
        return type(f.default)
    if isinstance(f.type, type):
        return f.type
    return _ANNOTATIONS.get(str(f.type), object)


def _fields(config_type: type) -> dict[str, dataclasses.Field]:
    if not (isinstance(config_type, type) and dataclasses.is_dataclass(config_type)):
        raise ConfigError(f"a scenario config type must be a dataclass, got {config_type!r}")
    return {f.name: f for f in dataclasses.fields(config_type)}


def _type_name(kind: type) -> str:
    return {bool: "a boolean (true/false)", int: "an integer", float: "a number", str: "a string"}.get(
        kind, kind.__name__)


def parse_value(config_type: type, key: str, text: str) -> Any:
    """Convert the string ``text`` to the type of field ``key``, or raise :class:`ConfigError`."""
    fields = _fields(config_type)
    if key not in fields:
        raise ConfigError(
            f"unknown key {key!r}; allowed: {', '.join(sorted(fields))}"
        )
    kind = field_kind(fields[key])
    if not isinstance(text, str):
        raise ConfigError(f"key {key!r}: expected text to parse, got {text!r}")
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
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise ConfigError(f"a scenario config must be a dataclass instance, got {config!r}")
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        kind = field_kind(f)
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
    cross_check = getattr(config, "cross_check", None)
    if callable(cross_check):  # rules between fields, once every field is valid on its own
        cross_check()
    return config


def split_assignment(text: str) -> tuple[str, str]:
    """``"key=value"`` -> ``("key", "value")``, or a :class:`ConfigError`."""
    if not isinstance(text, str) or "=" not in text:
        raise ConfigError(f"--set expects key=value, got {text!r}")
    key, value = text.split("=", 1)
    return key.strip(), value


def parse_overrides(config_type: type, assignments: Iterable[str] | Mapping[str, Any] = ()) -> dict[str, Any]:
    """Typed values of ``key=value`` strings (or of a mapping, whose string values are parsed).

    Keys are checked against the config's fields; values are checked when the config is built.
    """
    fields = _fields(config_type)
    if isinstance(assignments, str):
        assignments = [assignments]
    if isinstance(assignments, Mapping):
        items = list(assignments.items())
    else:
        try:
            items = [split_assignment(text) for text in assignments]
        except TypeError:
            raise ConfigError(f"overrides must be key=value strings or a dict, got {assignments!r}") from None
    values: dict[str, Any] = {}
    for key, raw in items:
        if key not in fields:
            raise ConfigError(f"unknown key {key!r}; allowed: {', '.join(sorted(fields))}")
        values[key] = (parse_value(config_type, key, raw) if isinstance(raw, str)
                       else _number_as_text(field_kind(fields[key]), raw))
    return values


def _number_as_text(kind: type, value: Any) -> Any:
    """A finite number given to a text setting (``conflict_deg = 60`` in TOML or Python) as its text;
    any other value unchanged (for :func:`validate` to judge)."""
    if (kind is str and isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value)):
        return str(value)
    return value


def build_config(config_type: type, *layers: Mapping[str, Any] | Iterable[str]) -> Any:
    """A validated ``config_type``: its defaults, then each layer of overrides in turn (later wins).

    A layer is a mapping of typed values (e.g. from :func:`load_config_file`) or ``key=value``
    strings (``--set``). A float field given an integer stores it as a float.
    """
    fields = _fields(config_type)
    values: dict[str, Any] = {}
    for layer in layers:
        values.update(parse_overrides(config_type, layer))
    for key, value in values.items():
        if field_kind(fields[key]) is float and isinstance(value, int) and not isinstance(value, bool):
            values[key] = float(value)
    missing = [name for name, f in fields.items() if name not in values and f.default is dataclasses.MISSING
               and f.default_factory is dataclasses.MISSING]
    if missing:
        raise ConfigError(f"key {missing[0]!r} has no default and must be set")
    try:
        config = config_type(**values)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{config_type.__name__}: {error}") from None
    return validate(config)


def apply_overrides(config_type: type, assignments: Iterable[str] | Mapping[str, Any] = ()) -> Any:
    """A validated ``config_type`` from its defaults and ``key=value`` overrides (strings or a dict)."""
    return build_config(config_type, assignments)


def load_config_file(config_type: type, path: str | Path,
                     overridden: Mapping[str, Any] | Iterable[str] = ()) -> dict[str, Any]:
    """The settings in a TOML file, checked against ``config_type``: ``{key: typed value}``.

    The file holds ``key = value`` pairs with the keys of ``--set`` (``neuronav list`` shows them),
    e.g. ``noise = 0.2`` or ``dtype = "float64"``; a number for a text setting stands for its text
    (``conflict_deg = 60``). Unknown keys, values of the wrong type and values out of range raise
    :class:`ConfigError` naming the key and what is allowed, as does a file nested more than
    :data:`MAX_TOML_NESTING` tables or arrays deep. ``overridden`` holds the values that win over the
    file (``--set``, a grid point), or just their keys: the file's values of those keys are not checked,
    neither type nor range (they are not used), and rules between fields are checked with the winning
    values in place.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"config file {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise ConfigError(f"config file {str(path)!r} cannot be read: {_reason(error)}") from None
    too_deep = (f"config file {str(path)!r} nests tables or arrays more than {MAX_TOML_NESTING} deep; "
                "settings are plain key = value pairs")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"config file {str(path)!r} is not valid TOML: {_reason(error)}") from None
    except RecursionError:
        raise ConfigError(too_deep) from None
    if _nesting(data) > MAX_TOML_NESTING:
        raise ConfigError(too_deep)
    fields = _fields(config_type)
    allowed = ", ".join(sorted(fields))
    winning = dict(overridden) if isinstance(overridden, Mapping) else {}
    skipped = set(overridden)
    for key, value in data.items():
        if key not in fields:
            raise ConfigError(f"config file {str(path)!r}: unknown key {key!r}; allowed: {allowed}")
        kind = field_kind(fields[key])
        data[key] = value = _number_as_text(kind, value)
        # TOML values are typed: a number written as a string is a wrong type, as is a table or array.
        if key not in skipped and (isinstance(value, (dict, list)) or (isinstance(value, str) and kind is not str)):
            raise ConfigError(f"config file {str(path)!r}: key {key!r} expects {_type_name(kind)}, got {value!r}")
    try:  # types, ranges and rules between fields, of the config the file's values end up in
        build_config(config_type, {k: v for k, v in data.items() if k not in skipped}, winning)
    except ConfigError as error:
        try:
            build_config(config_type, winning)
        except ConfigError:
            raise error from None  # the winning values' own error, not the file's
        raise ConfigError(f"config file {str(path)!r}: {error}") from None
    return dict(data)


def _nesting(data: Mapping[str, Any]) -> int:
    """How many tables or arrays deep ``data``'s values go (0: plain values), counted without recursion
    and only up to one past :data:`MAX_TOML_NESTING`."""
    deepest, pending = 0, [(value, 1) for value in data.values()]
    while pending and deepest <= MAX_TOML_NESTING:
        value, depth = pending.pop()
        if isinstance(value, (dict, list)):
            deepest = max(deepest, depth)
            pending.extend((inner, depth + 1) for inner in (value.values() if isinstance(value, dict) else value))
    return deepest


def _reason(error: BaseException) -> str:
    text = str(error).splitlines()
    return text[0] if text else type(error).__name__


def _limit_text(value: Any) -> str:
    """A limit as written: an integer in full (``2147483647``), a number shortest (``0.64``, ``1e+06``)."""
    return str(value) if isinstance(value, int) else f"{value:g}"


def limits_text(f: dataclasses.Field) -> str:
    """A field's valid values in words, e.g. ``0 <= x <= 1``, ``> 0`` or ``one of: a, b``; ``""`` if any."""
    meta = f.metadata
    if "choices" in meta:
        return "one of: " + ", ".join(map(str, meta["choices"]))
    low = (f"{_limit_text(meta['min'])} <= " if "min" in meta
           else f"{_limit_text(meta['min_exclusive'])} < " if "min_exclusive" in meta else "")
    high = (f" <= {_limit_text(meta['max'])}" if "max" in meta
            else f" < {_limit_text(meta['max_exclusive'])}" if "max_exclusive" in meta else "")
    if not low and not high:
        return ""
    if low and high:
        return f"{low}x{high}"
    if "min" in meta:
        return f">= {_limit_text(meta['min'])}"
    return f"> {_limit_text(meta['min_exclusive'])}" if low else high.strip()


def describe(config_type: type) -> list[tuple[str, Any, str]]:
    """(key, default, help) for every field, for ``neuronav list`` and documentation.

    The help ends with the field's valid values in brackets (:func:`limits_text`) when it has limits.
    """
    rows = []
    for f in _fields(config_type).values():
        text, limits = f.metadata.get("help", ""), limits_text(f)
        rows.append((f.name, f.default, f"{text} [{limits}]" if limits else text))
    return rows
