"""Worlds and bodies as backend-agnostic data.

A :class:`World` says what surrounds the agents (ground, objects); each backend builds it in its
own engine. :class:`PointAgents` is the simplest body: a batch of points with a heading, which
the kinematic backend moves (Stone et al. 2017's agent, or a unicycle driven by the locomotion
command). Articulated bodies are declared with the body-spec types.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from neuronav.errors import ConfigError, real_or_nan
from neuronav.spec.body import CompoundEye
from neuronav.spec.odour_scene import OdourScene

GROUND_KINDS = ("flat", "uneven", "wall")
OBJECT_SHAPES = ("box", "cylinder", "sphere", "cone")
POINT_MODES = ("stone", "unicycle")
# Sizes each object shape takes (see WorldObject).
OBJECT_SIZES = {"box": 3, "cylinder": 2, "cone": 2, "sphere": 1}
# Lengths (positions, sizes, ground extents) within ±MAX_LENGTH_M: a 2000 km world, far beyond any
# scene, and small enough that no engine's squared distance overflows.
MAX_LENGTH_M = 1e6
# The most point agents in one batch: their state (a few float64 per agent) stays under 1 GB.
MAX_POINT_AGENTS = 10 ** 7
# The most heightfield samples per side (1025² float64: 8 MB; 2 cm apart on a 20 m field). With
# feature_m <= size_m / 4 the smoothing kernel spans at most 2 · 4 · 256 cells: a few seconds at most.
MAX_GROUND_CELLS = 1025
# What the compound eyes' green and UV receptors see (neuronav.senses.compound_eye): each surface's value
# per channel (green, UV) in [0, 1], 1 being a white Lambertian surface under the full daylight (sun and
# sky) of that channel, so a surface's value is its reflectance and the sky's the fraction of the
# daylight that comes from the sky. Defaults (docs/parameters.md, section 12; *ours* from the sources there):
# the sky 0.15 in green and 0.5 in UV (Rayleigh scattering makes the UV daylight about half skylight, the
# green mostly direct sun), desert sand 0.27 / 0.10, vegetation (the objects' default) 0.12 / 0.04: in UV
# the sky outshines every surface, in green the sand outshines the sky (Möller 2002's UV-green contrast).
SKY_GREEN_UV = (0.15, 0.50)
GROUND_GREEN_UV = (0.27, 0.10)
OBJECT_GREEN_UV = (0.12, 0.04)



@dataclass(frozen=True)
class Ground:
    """The ground under the agents.

    ``flat``: a plane. ``uneven``: a heightfield of ``cells`` x ``cells`` over a square of
    ``size_m``, smooth random bumps with standard deviation ``roughness_m`` and correlation length
    ``feature_m``, the same for every backend (generated here from ``seed``). ``wall``: flat ground
    and a vertical wall facing -x at x = ``wall_distance_m``, spanning y, ``wall_height_m`` high.

    Every length is finite: ``roughness_m`` >= 0, the others > 0, all at most
    :data:`MAX_LENGTH_M`; on uneven ground ``feature_m`` at most ``size_m / 4`` (a longer correlation
    length is a tilted plane, not bumps); ``cells`` in [3, :data:`MAX_GROUND_CELLS`]; ``seed`` an int
    >= 0; ``friction`` in (0, 100].
    """

    kind: str = "flat"
    roughness_m: float = 0.0
    size_m: float = 20.0
    cells: int = 129
    feature_m: float = 0.4
    seed: int = 0
    wall_distance_m: float = 1.0
    wall_height_m: float = 8.0
    friction: float = 1.0

    def __post_init__(self) -> None:
        if self.kind not in GROUND_KINDS:
            raise ConfigError(f"ground kind {self.kind!r} is unknown; allowed: {', '.join(GROUND_KINDS)}")
        if not 0 <= real_or_nan(self.roughness_m) <= MAX_LENGTH_M:
            raise ConfigError(f"ground roughness_m must be a finite number >= 0 (m, up to {MAX_LENGTH_M:g}), "
                              f"got {self.roughness_m!r}")
        for label, high in (("size_m", MAX_LENGTH_M), ("feature_m", MAX_LENGTH_M), ("wall_distance_m", MAX_LENGTH_M),
                            ("wall_height_m", MAX_LENGTH_M), ("friction", 100.0)):
            if not 0 < real_or_nan(getattr(self, label)) <= high:
                raise ConfigError(f"ground {label} must be a finite number > 0 (up to {high:g}), "
                                  f"got {getattr(self, label)!r}")
        if self.kind == "uneven" and not self.feature_m <= self.size_m / 4:
            raise ConfigError(f"ground feature_m must be at most size_m / 4 ({self.size_m / 4:g}) on uneven ground, "
                              f"got {self.feature_m!r}")
        if isinstance(self.cells, bool) or not isinstance(self.cells, int) or not 3 <= self.cells <= MAX_GROUND_CELLS:
            raise ConfigError(f"ground cells must be an int in [3, {MAX_GROUND_CELLS}], got {self.cells!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer) or self.seed < 0:
            raise ConfigError(f"ground seed must be an int >= 0, got {self.seed!r}")

    def heights_m(self) -> np.ndarray:
        """Terrain heights, shape (cells, cells): row i is y, column j is x, both from -size/2 to size/2.

        Zero-mean Gaussian-filtered white noise scaled to ``roughness_m``, then shifted so that the
        lowest point is at 0 (engines' heightfields start at the ground plane). Flat and wall
        grounds are all zeros. A copy of the field computed once per ground.
        """
        return self._heights.copy()

    @property
    def is_flat(self) -> bool:
        """Whether the terrain is at height 0 everywhere (flat, wall, or uneven with no roughness)."""
        return self.kind != "uneven" or self.roughness_m == 0

    @cached_property
    def _heights(self) -> np.ndarray:
        """The heightfield, computed on first use and kept (read-only) with this frozen ground."""
        if self.is_flat:
            heights = np.zeros((self.cells, self.cells))
        else:
            from scipy.ndimage import gaussian_filter

            rng = np.random.default_rng(self.seed)
            spacing_m = self.size_m / (self.cells - 1)
            heights = gaussian_filter(rng.standard_normal((self.cells, self.cells)), self.feature_m / spacing_m,
                                      mode="wrap")
            heights *= self.roughness_m / heights.std()
            heights -= heights.min()
        heights.setflags(write=False)
        return heights

    def height_at(self, x_m, y_m):
        """Terrain height (m) under (x, y), bilinear between heightfield samples; the one terrain lookup.

        ``x_m`` and ``y_m`` are finite numbers (a float comes back) or arrays of one shape (an array
        of it). Outside the field the edge samples continue.
        """
        scalar = np.ndim(x_m) == 0 and np.ndim(y_m) == 0
        try:
            x, y = np.broadcast_arrays(np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float))
        except (TypeError, ValueError):
            raise ConfigError(f"ground height_at: x_m and y_m must be numbers or arrays of one shape, got shapes "
                              f"{np.shape(x_m)} and {np.shape(y_m)}") from None
        if not (np.isfinite(x).all() and np.isfinite(y).all()):
            raise ConfigError("ground height_at: x_m and y_m must be finite")
        if self.is_flat:
            heights = np.zeros(x.shape)
        else:
            half, scale = self.size_m / 2.0, (self.cells - 1) / self.size_m
            u = np.clip((x + half) * scale, 0, self.cells - 1.000001)
            v = np.clip((y + half) * scale, 0, self.cells - 1.000001)
            j, i = u.astype(int), v.astype(int)
            fu, fv = u - j, v - i
            h = self._heights
            heights = ((1 - fv) * ((1 - fu) * h[i, j] + fu * h[i, j + 1])
                       + fv * ((1 - fu) * h[i + 1, j] + fu * h[i + 1, j + 1]))
        return float(heights) if scalar else heights


@dataclass(frozen=True)
class WorldObject:
    """A static object: a primitive ``shape`` of ``size_m`` at ``position_m`` with an RGBA colour.

    Sizes as for body geoms: box half-extents (3); cylinder and cone (radius, half_height); sphere
    (radius,). Cylinders and cones stand upright (along z). ``green_uv``: what the compound eyes' green
    and UV receptors see of it (2 numbers in [0, 1], see :data:`SKY_GREEN_UV`; None: vegetation's).
    A :class:`World` checks the rest (:func:`check_objects`), so that every backend refuses the same objects.
    """

    shape: str
    position_m: tuple[float, float, float]
    size_m: tuple[float, ...]
    rgba: tuple[float, float, float, float] = (0.2, 0.2, 0.2, 1.0)
    green_uv: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.shape not in OBJECT_SHAPES:
            raise ConfigError(f"object shape {self.shape!r} is unknown; allowed: {', '.join(OBJECT_SHAPES)}")

    @property
    def spectral(self) -> tuple[float, float]:
        """What the compound eyes see of it, (green, UV) in [0, 1]: ``green_uv``, or vegetation's
        :data:`OBJECT_GREEN_UV` when it is None."""
        return OBJECT_GREEN_UV if self.green_uv is None else tuple(float(v) for v in self.green_uv)


def check_objects(objects) -> None:
    """Refuse objects no backend can build: not a WorldObject, the wrong number of sizes, sizes not
    finite and positive, a position not 3 finite numbers, lengths beyond :data:`MAX_LENGTH_M`, or
    an RGBA colour not 4 numbers in [0, 1]."""
    for index, obj in enumerate(objects):
        if not isinstance(obj, WorldObject):
            raise ConfigError(f"world object {index}: expected a WorldObject, got {type(obj).__name__}")
        size = _numbers(obj.size_m)
        expected = OBJECT_SIZES[obj.shape]
        if size.size != expected or not (np.isfinite(size).all() and 0 < size.min() and size.max() <= MAX_LENGTH_M):
            raise ConfigError(f"world object {index} ({obj.shape}): size_m needs {expected} positive values "
                              f"(up to {MAX_LENGTH_M:g} m), got {obj.size_m!r}")
        position = _numbers(obj.position_m)
        if position.size != 3 or not (np.isfinite(position).all() and np.abs(position).max() <= MAX_LENGTH_M):
            raise ConfigError(f"world object {index} ({obj.shape}): position_m needs 3 finite values "
                              f"(within ±{MAX_LENGTH_M:g} m), got {obj.position_m!r}")
        rgba = _numbers(obj.rgba)
        if rgba.size != 4 or not (np.isfinite(rgba).all() and rgba.min() >= 0 and rgba.max() <= 1):
            raise ConfigError(f"world object {index} ({obj.shape}): rgba needs 4 numbers in [0, 1], got {obj.rgba!r}")
        if obj.green_uv is not None:
            spectral = _numbers(obj.green_uv)
            if spectral.size != 2 or not (np.isfinite(spectral).all() and spectral.min() >= 0 and spectral.max() <= 1):
                raise ConfigError(f"world object {index} ({obj.shape}): green_uv needs 2 numbers in [0, 1] (green, UV) "
                                  f"or None, got {obj.green_uv!r}")


def _numbers(values) -> np.ndarray:
    """``values`` as a flat float array, or one NaN when they are not numbers (refused by the caller)."""
    try:
        return np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return np.full(1, np.nan)


GROUND_TEXTURES = ("checker", "plain")


def _check_rgb(label: str, rgb) -> None:
    if rgb is None:
        return
    values = np.asarray(rgb, dtype=float) if np.ndim(rgb) == 1 else np.full(0, np.nan)
    if values.shape != (3,) or not (np.isfinite(values).all() and values.min() >= 0 and values.max() <= 1):
        raise ConfigError(f"appearance {label} must be 3 numbers in [0, 1] (red, green, blue), got {rgb!r}")


@dataclass(frozen=True)
class Appearance:
    """How the sky and the ground look to the body's cameras, the same on every backend.

    ``sky_rgb``: the sky's colour (at the zenith when ``horizon_rgb`` is set: then the sky runs from
    ``horizon_rgb`` at the horizon to ``sky_rgb`` overhead, see :func:`neuronav.senses.vision.sky_rgb`).
    ``ground_rgb``: the ground's colour; ``ground_texture`` ``checker`` alternates it with
    ``checker_rgb`` in squares of ``checker_m`` (the videos' default: the motion shows against it),
    ``plain`` draws it in one colour (what visual experiments use: a uniform ground shows no
    structure a compass could lock onto).
    ``sky_green_uv``, ``ground_green_uv``: what the compound eyes' green and UV receptors see of the sky
    and of the ground (plain: the checker is not drawn for them), see :data:`SKY_GREEN_UV`.
    """

    sky_rgb: tuple[float, float, float] = (0.62, 0.78, 0.95)
    horizon_rgb: tuple[float, float, float] | None = None
    ground_rgb: tuple[float, float, float] = (0.86, 0.76, 0.56)
    ground_texture: str = "checker"
    checker_rgb: tuple[float, float, float] = (0.66, 0.57, 0.40)
    checker_m: float = 0.5
    sky_green_uv: tuple[float, float] = SKY_GREEN_UV
    ground_green_uv: tuple[float, float] = GROUND_GREEN_UV

    def __post_init__(self) -> None:
        for label in ("sky_rgb", "horizon_rgb", "ground_rgb", "checker_rgb"):
            _check_rgb(label, getattr(self, label))
        for label in ("sky_green_uv", "ground_green_uv"):
            values = _numbers(getattr(self, label))
            if values.size != 2 or not (np.isfinite(values).all() and values.min() >= 0 and values.max() <= 1):
                raise ConfigError(f"appearance {label} must be 2 numbers in [0, 1] (green, UV), "
                                  f"got {getattr(self, label)!r}")
            object.__setattr__(self, label, tuple(float(v) for v in values))
        if self.ground_texture not in GROUND_TEXTURES:
            raise ConfigError(f"appearance ground_texture {self.ground_texture!r} is unknown; allowed: "
                              f"{', '.join(GROUND_TEXTURES)}")
        if not 0 < real_or_nan(self.checker_m) <= MAX_LENGTH_M:
            raise ConfigError(f"appearance checker_m must be > 0, got {self.checker_m}")


@dataclass(frozen=True)
class World:
    """What every backend builds: a ground, static objects, their look, its odours, and adhesion.

    ``odour``: trails on the floor and a live plume with its wind (:class:`~neuronav.spec.odour_scene.OdourScene`;
    default none), computed engine-free and read by every backend at its odour and wind sites.

    ``sky``: the sun and the polarised light of the dome (:class:`~neuronav.senses.sky.Sky`; None: no sky
    compass cue), computed engine-free; scene objects occlude it where the backends cast rays.

    ``adhesion_n``: while an adhesive contact site's geom (a claw: ``Site.adhesive``) touches a
    surface, a force of this size presses it into that surface (0: off). Backends apply it every
    physics step.

    The objects can be turned together about the world's vertical axis through the origin while a
    simulation runs (``backend.set_scene_yaw(yaw_rad)``, counter-clockwise seen from above; the
    ground stays): the visual compass's rotating world.
    """

    ground: Ground = field(default_factory=Ground)
    objects: tuple[WorldObject, ...] = ()
    adhesion_n: float = 0.0
    appearance: Appearance = field(default_factory=Appearance)
    odour: OdourScene = field(default_factory=OdourScene)
    sky: Sky | None = None  # noqa: F821 - neuronav.senses.sky.Sky, a description

    def __post_init__(self) -> None:
        if not isinstance(self.ground, Ground):
            raise ConfigError(f"world ground must be a Ground, got {type(self.ground).__name__}")
        objects = tuple(self.objects) if isinstance(self.objects, list | tuple) else None
        if objects is None:
            raise ConfigError(f"world objects must be a tuple of WorldObject, got {type(self.objects).__name__}")
        check_objects(objects)
        object.__setattr__(self, "objects", objects)
        if not 0 <= real_or_nan(self.adhesion_n) < np.inf:
            raise ConfigError(f"world adhesion_n must be a finite number >= 0, got {self.adhesion_n!r}")
        if not isinstance(self.odour, OdourScene):
            raise ConfigError(f"world odour must be a neuronav.spec.odour_scene.OdourScene, "
                              f"got {type(self.odour).__name__}")
        if not isinstance(self.appearance, Appearance):
            raise ConfigError(f"world appearance must be an Appearance, got {type(self.appearance).__name__}")
        if self.sky is not None and not _is_sky(self.sky):
            raise ConfigError(f"world sky must be a neuronav.senses.sky.Sky or None, got {type(self.sky).__name__}")


def _is_sky(sky) -> bool:
    """Whether ``sky`` is a :class:`~neuronav.senses.sky.Sky` (the sun's position and ``light``); checked by
    what it holds, since the sky's model lives in :mod:`neuronav.senses` (as the odour plume's does)."""
    return (type(sky).__name__ == "Sky" and callable(getattr(sky, "light", None))
            and all(hasattr(sky, name) for name in ("sun_azimuth_rad", "sun_elevation_rad", "cloud_cover")))


@dataclass(frozen=True)
class PointAntenna:
    """An antenna of a point agent: a tip that smells and feels the wind, swinging about its base.

    Both points are in the agent's frame (x forward, y left, z up, origin on the ground under the
    agent), the tip at rest. The ``antenna_yaw`` command turns the tip about the vertical axis
    through the base by that many radians from rest (positive: to the left), as the yaw joint of an
    articulated antenna does.
    """

    name: str
    base_m: tuple[float, float, float]
    tip_m: tuple[float, float, float]

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"PointAntenna name must be a non-empty string, got {self.name!r}")
        for label in ("base_m", "tip_m"):
            values = np.asarray(getattr(self, label), dtype=float) if np.ndim(getattr(self, label)) == 1 else None
            if values is None or values.shape != (3,) or not np.isfinite(values).all():
                raise ConfigError(f"antenna {self.name!r}: {label} must be 3 finite numbers, "
                                  f"got {getattr(self, label)!r}")
            object.__setattr__(self, label, tuple(float(v) for v in values))


@dataclass(frozen=True)
class PointAgents:
    """A batch of point agents for the kinematic backend.

    Parameters
    ----------
    count : int
        Number of agents N (1 to :data:`MAX_POINT_AGENTS`).
    mode : str
        ``stone``: Stone et al. 2017's agent — each step ``heading += rotation`` and
        ``velocity = (velocity + acceleration * (sin h, cos h)) * (1 - drag)``, in distance units
        per step. ``unicycle``: forward speed and turn rate from the locomotion command
        (``turn``, ``stride``) through a calibration table, in m and s.
    drag : float
        Fraction of the velocity lost each step (``stone`` mode), in [0, 1).
    mass_kg : float
        Mass used by ``apply_force`` (finite, > 0).
    cameras : tuple of Camera
        Cameras carried by every agent, placed in the agent's frame (x forward, y left, z up,
        origin on the ground under the agent; ``Camera.segment`` is ignored). The kinematic backend
        renders them by ray casting (:mod:`neuronav.senses.raycast`).
    antennae : tuple of PointAntenna
        Antennae carried by every agent: their tips are the agents' odour and wind sites.
    head_height_m : float
        Height of the agents' head above the ground (finite, >= 0, at most :data:`MAX_LENGTH_M`): the
        kinematic backend's ``head_pos`` is (x, y, head_height_m), e.g. where a sky compass looks from.
    compound_eyes : tuple of CompoundEye
        Compound eyes (:class:`neuronav.spec.body.CompoundEye`) carried by every agent, placed in the
        agent's frame as cameras are (``segment`` ignored); the kinematic backend reads each as a sensor
        of its name, (M, 2) green and UV (:mod:`neuronav.senses.compound_eye`).
    """

    count: int = 1
    mode: str = "stone"
    drag: float = 0.15
    mass_kg: float = 1.0
    cameras: tuple = ()
    antennae: tuple = ()
    head_height_m: float = 0.5
    compound_eyes: tuple = ()

    def __post_init__(self) -> None:
        if isinstance(self.count, bool) or not isinstance(self.count, int) or not 1 <= self.count <= MAX_POINT_AGENTS:
            raise ConfigError(f"PointAgents count must be a positive int (at most {MAX_POINT_AGENTS}), "
                              f"got {self.count!r}")
        if self.mode not in POINT_MODES:
            raise ConfigError(f"PointAgents mode {self.mode!r} is unknown; allowed: {', '.join(POINT_MODES)}")
        if not 0.0 <= real_or_nan(self.drag) < 1.0:
            raise ConfigError(f"PointAgents drag must be in [0, 1), got {self.drag!r}")
        if not 0 < real_or_nan(self.mass_kg) < np.inf:
            raise ConfigError(f"PointAgents mass_kg must be a finite number > 0, got {self.mass_kg!r}")
        if not 0.0 <= real_or_nan(self.head_height_m) <= MAX_LENGTH_M:
            raise ConfigError(f"PointAgents head_height_m must be a finite number >= 0 (m, up to {MAX_LENGTH_M:g}), "
                              f"got {self.head_height_m!r}")
        antennae = tuple(self.antennae)
        if not all(isinstance(a, PointAntenna) for a in antennae):
            raise ConfigError("PointAgents antennae must be neuronav.spec.world.PointAntenna instances")
        names = [a.name for a in antennae]
        if len(set(names)) != len(names):
            raise ConfigError(f"PointAgents antennae: a name is used twice in {names}")
        object.__setattr__(self, "antennae", antennae)
        eyes = tuple(self.compound_eyes) if isinstance(self.compound_eyes, list | tuple) else None
        if eyes is None or not all(isinstance(e, CompoundEye) for e in eyes):
            raise ConfigError("PointAgents compound_eyes must be a tuple of neuronav.spec.body.CompoundEye")
        eye_names = [e.name for e in eyes]
        if len(set(eye_names)) != len(eye_names):
            raise ConfigError(f"PointAgents compound_eyes: a name is used twice in {eye_names}")
        object.__setattr__(self, "compound_eyes", eyes)
