"""Find backends, bodies, brains and scenarios by name through entry points.

The core never imports its sibling packages; it asks ``importlib.metadata`` for the entry points
of the groups ``neuronav.backends``, ``neuronav.swarm_backends`` (many bodies in one engine world),
``neuronav.bodies``, ``neuronav.unicycle_calibrations`` (a body's unicycle table for the kinematic
backend, by the body's name: a function returning a :class:`~neuronav.spec.unicycle.UnicycleCalibration`),
``neuronav.brains`` and ``neuronav.scenarios``. A third-party package adds to any of them without
touching this repository.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any

from neuronav.errors import RegistryError

GROUPS = {
    "backend": "neuronav.backends",
    "swarm_backend": "neuronav.swarm_backends",
    "body": "neuronav.bodies",
    "unicycle_calibration": "neuronav.unicycle_calibrations",
    "brain": "neuronav.brains",
    "scenario": "neuronav.scenarios",
}
# What to install when a registered name cannot be imported.
EXTRAS = {"mujoco": "mujoco", "pybullet": "pybullet"}


def _group(kind: str):
    if kind not in GROUPS:
        raise RegistryError(f"unknown registry {kind!r}; allowed: {', '.join(GROUPS)}")
    return {ep.name: ep for ep in entry_points(group=GROUPS[kind])}


def names(kind: str) -> list[str]:
    """The registered names of one kind (a key of :data:`GROUPS`: ``backend``, ``body``, ...), sorted."""
    return sorted(_group(kind))


def load(kind: str, name: str) -> Any:
    """The object registered as ``name``; a clear :class:`RegistryError` when unknown or not installed."""
    group = _group(kind)
    if name not in group:
        raise RegistryError(f"unknown {kind} {name!r}; available: {', '.join(sorted(group)) or 'none'}")
    try:
        return group[name].load()
    except ImportError as error:
        extra = EXTRAS.get(name, name)
        raise RegistryError(
            f"{kind} {name!r} is not installed ({error}); install it with: pip install 'neuronav[{extra}]'"
        ) from None


def availability(kind: str, name: str) -> tuple[bool, str]:
    """(True, "") when ``name`` loads, else (False, the reason)."""
    try:
        load(kind, name)
    except RegistryError as error:
        return False, str(error)
    return True, ""
