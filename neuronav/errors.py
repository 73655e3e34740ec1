"""The project's own error types.

Every failure a user can cause (an unknown name, a wrong shape, a bad config value, a backend
that is not installed, a simulation that diverges) is raised as a subclass of
:class:`NeuronavError` with a one-line message that names the thing and what is allowed. The CLI
prints that line and exits 2; anything else escaping is a bug.
"""

from __future__ import annotations


class NeuronavError(Exception):
    """Base class of every error neuronav raises on purpose."""


class CircuitError(NeuronavError):
    """A circuit is declared or compiled wrongly (unknown population, weight shape, cycle)."""


class PortError(NeuronavError):
    """A sensor or motor port is missing or has the wrong shape or units."""


class ConfigError(NeuronavError):
    """A configuration key is unknown, or its value has the wrong type or is out of range."""


class RegistryError(NeuronavError):
    """A registered name (scenario, backend, brain, body) is unknown or cannot be loaded."""


class SimulationError(NeuronavError):
    """A simulation diverged or was asked to do something it cannot do."""


def real_or_nan(value) -> float:
    """``value`` as a float, or NaN when it is not a real number (a bool, a string, None, an array...).

    For range checks: NaN fails every comparison, so ``if not low <= real_or_nan(x) <= high: raise
    ConfigError(...)`` refuses non-numbers, NaN and out-of-range values in one test.
    """
    if isinstance(value, bool | str | bytes):
        return float("nan")
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return float("nan")
