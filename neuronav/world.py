"""Worlds and bodies as backend-agnostic data.

A :class:`World` says what surrounds the agents (ground, objects); each backend builds it in its
own engine. :class:`PointAgents` is the simplest body: a batch of points with a heading, which
the kinematic backend moves (Stone et al. 2017's agent, or a unicycle driven by the locomotion
command). Articulated bodies are declared with the body-spec types.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from neuronav.errors import ConfigError

GROUND_KINDS = ("flat", "uneven", "wall")
OBJECT_SHAPES = ("box", "cylinder", "sphere", "cone")
POINT_MODES = ("stone", "unicycle")


@dataclass(frozen=True)
class Ground:
    """The ground: ``flat``, ``uneven`` (a heightfield of ``roughness_m``) or a vertical ``wall``."""

    kind: str = "flat"
    roughness_m: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in GROUND_KINDS:
            raise ConfigError(f"ground kind {self.kind!r} is unknown; allowed: {', '.join(GROUND_KINDS)}")
        if self.roughness_m < 0:
            raise ConfigError(f"ground roughness_m must be >= 0, got {self.roughness_m}")


@dataclass(frozen=True)
class WorldObject:
    """A static object: a primitive ``shape`` of ``size_m`` at ``position_m`` with an RGBA colour."""

    shape: str
    position_m: tuple[float, float, float]
    size_m: tuple[float, ...]
    rgba: tuple[float, float, float, float] = (0.2, 0.2, 0.2, 1.0)

    def __post_init__(self) -> None:
        if self.shape not in OBJECT_SHAPES:
            raise ConfigError(f"object shape {self.shape!r} is unknown; allowed: {', '.join(OBJECT_SHAPES)}")


@dataclass(frozen=True)
class World:
    """What every backend builds: a ground and static objects."""

    ground: Ground = field(default_factory=Ground)
    objects: tuple[WorldObject, ...] = ()


@dataclass(frozen=True)
class PointAgents:
    """A batch of point agents for the kinematic backend.

    Parameters
    ----------
    count : int
        Number of agents N.
    mode : str
        ``stone``: Stone et al. 2017's agent — each step ``heading += rotation`` and
        ``velocity = (velocity + acceleration * (sin h, cos h)) * (1 - drag)``, in distance units
        per step. ``unicycle``: forward speed and turn rate from the locomotion command
        (``turn``, ``stride``) through a calibration table, in m and s.
    drag : float
        Fraction of the velocity lost each step (``stone`` mode).
    mass_kg : float
        Mass used by ``apply_force``.
    """

    count: int = 1
    mode: str = "stone"
    drag: float = 0.15
    mass_kg: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.count, int) or self.count < 1:
            raise ConfigError(f"PointAgents count must be a positive int, got {self.count!r}")
        if self.mode not in POINT_MODES:
            raise ConfigError(f"PointAgents mode {self.mode!r} is unknown; allowed: {', '.join(POINT_MODES)}")
        if not 0.0 <= self.drag < 1.0:
            raise ConfigError(f"PointAgents drag must be in [0, 1), got {self.drag}")
        if not self.mass_kg > 0:
            raise ConfigError(f"PointAgents mass_kg must be > 0, got {self.mass_kg}")
