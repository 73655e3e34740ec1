"""Engine-free odour trails on the floor: a polyline with a width, or a greyscale image.

Sources (the I2Bot paper §2.5.1, Fig. 6b; ``docs/parameters.md`` §5): the trail is drawn on the floor
(widths narrow ≈ 0.11 m, normal ≈ 0.27 m, wide ≈ 1.4 m, :data:`TRAIL_WIDTHS_M`); the paper draws it
as a floor texture, which may be drawn by hand, hence :class:`ImageTrail`.

Every field here answers ``concentration_at(points_m)`` for points of shape ``(..., 2)`` or
``(..., 3)`` (agents × antennae × ..., metres) with an array of shape ``(...)`` in one array
operation; a trail is a floor field, so only (x, y) is read and a point's height is ignored.
:func:`rasterise` samples any field at the pixel centres of an (H, W) image over a floor rectangle,
for floor textures and figures; row 0 is the image's top, at the rectangle's largest y, and column 0
its left, at the smallest x (the floor seen from above, x to the right, y up).

Trail profile (:class:`PolylineTrail`): with ``d`` the distance from the centre line, ``w`` the
width and ``e`` the edge width, the concentration is a flat top with a raised-cosine edge centred
on the trail's border::

    c(d) = 1                                   d <= w/2 - e/2
    c(d) = (1 + cos(π (d - w/2 + e/2) / e)) / 2   w/2 - e/2 < d < w/2 + e/2
    c(d) = 0                                   d >= w/2 + e/2

so ``c = 1/2`` at ``d = w/2`` (the width is the full width at half maximum), the field is smooth
(continuous with a continuous slope) and exactly 0 beyond ``w/2 + e/2``. The default edge is
:data:`DEFAULT_EDGE_M` = 0.02 m (a fifth of the narrow trail).

Image trails (:class:`ImageTrail`): a greyscale image (floats in [0, 1], or uint8 read as /255)
covers a floor rectangle; pixel (i, j) sits at its pixel centre, the field is bilinear between
pixel centres, equal to the nearest border pixel between the outer pixel centres and the
rectangle's edge, and 0 outside the rectangle. Rasterised over its own rectangle at its own shape
it gives back its image.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuronav.errors import ConfigError, real_or_nan

TRAIL_WIDTHS_M = {"narrow": 0.11, "normal": 0.27, "wide": 1.4}
DEFAULT_EDGE_M = 0.02
# Query points and trail vertices lie within ±MAX_COORD_M of the origin (a 2000 km square: no real
# arena is larger), so that no squared distance overflows to inf and turns into NaN.
MAX_COORD_M = 1e6
# The most vertices a trail holds and pixels a rasterised image holds (each a few float64 arrays).
MAX_VERTICES = 10 ** 6
MAX_PIXELS = 1 << 24
# Odour indices are below MAX_ODOURS: a sensor reads one channel per index up to the largest.
MAX_ODOURS = 256
# Query points per chunk when a field is evaluated at many points (rasterising): a polyline trail
# holds (points × segments) float64 arrays, kept near 32 MB each.
_MAX_PAIRS_PER_CHUNK = 1 << 22


def query_points(label: str, points_m) -> np.ndarray:
    """Query points (..., 2) or (..., 3) as float64, finite and within ±:data:`MAX_COORD_M` m, or a
    ConfigError naming ``label``."""
    try:
        points = np.asarray(points_m, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{label}: expected numbers of shape (..., 2) or (..., 3) m, got {type(points_m).__name__}") \
            from None
    if points.ndim < 1 or points.shape[-1] not in (2, 3):
        raise ConfigError(f"{label}: expected shape (..., 2) or (..., 3), got {points.shape}")
    if not (np.isfinite(points).all() and (points.size == 0 or np.abs(points).max() <= MAX_COORD_M)):
        raise ConfigError(f"{label}: every coordinate must be finite and within ±{MAX_COORD_M:g} m")
    return points


def _floor_xy(points_m) -> np.ndarray:
    """The (x, y) of query points of shape (..., 2) or (..., 3), as float64 (..., 2)."""
    return query_points("odour query points", points_m)[..., :2]


def odour_index(label: str, value) -> int:
    """An odour index (an integer in [0, :data:`MAX_ODOURS`)), or a ConfigError naming ``label``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 0 <= value < MAX_ODOURS:
        raise ConfigError(f"{label}: expected an integer index in [0, {MAX_ODOURS}), got {value!r}")
    return int(value)


def _check_range(name: str, value) -> tuple[float, float]:
    try:
        pair = tuple(float(v) for v in np.asarray(value, float).reshape(-1))
    except (TypeError, ValueError):
        pair = ()
    if len(pair) != 2 or not (np.isfinite(pair).all() and max(map(abs, pair)) <= MAX_COORD_M) or not pair[0] < pair[1]:
        raise ConfigError(f"{name}: expected (low, high) with low < high, within ±{MAX_COORD_M:g}, got {value!r}")
    return pair



def trail_width_m(width) -> float:
    """A trail width in metres from a preset name (:data:`TRAIL_WIDTHS_M`) or a positive number."""
    if isinstance(width, str):
        if width not in TRAIL_WIDTHS_M:
            raise ConfigError(f"trail width: {width!r} is not one of {sorted(TRAIL_WIDTHS_M)} nor a number of metres")
        return TRAIL_WIDTHS_M[width]
    try:
        value = float(width)
    except (TypeError, ValueError):
        raise ConfigError(f"trail width: expected a positive number of metres or one of {sorted(TRAIL_WIDTHS_M)}, "
                          f"got {width!r}") from None
    if not (np.isfinite(value) and 0 < value <= MAX_COORD_M):
        raise ConfigError(f"trail width: expected a positive number of metres up to {MAX_COORD_M:g}, got {width!r}")
    return value


def rasterise(trail, x_range_m, y_range_m, shape_px) -> np.ndarray:
    """Sample a field's ``concentration_at`` at the pixel centres of an image over a floor rectangle.

    Parameters
    ----------
    trail : object with ``concentration_at(points_m (..., 2)) -> (...)``
        A :class:`PolylineTrail`, an :class:`ImageTrail`, or any field with that method.
    x_range_m, y_range_m : (float, float)
        The rectangle's x and y extents, metres.
    shape_px : (int, int)
        Image height H and width W in pixels (H · W at most :data:`MAX_PIXELS`).

    Returns
    -------
    np.ndarray, shape (H, W)
        Row 0 at the largest y, column 0 at the smallest x; pixel (i, j) is sampled at
        ``x = x0 + (j + 1/2)(x1 - x0)/W``, ``y = y1 - (i + 1/2)(y1 - y0)/H``.
    """
    x0, x1 = _check_range("x_range_m", x_range_m)
    y0, y1 = _check_range("y_range_m", y_range_m)
    values = np.asarray(shape_px, dtype=object).reshape(-1)
    if not (len(values) == 2 and all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in values)
            and min(values) >= 1 and int(values[0]) * int(values[1]) <= MAX_PIXELS):
        raise ConfigError(f"shape_px: expected whole numbers (H, W) >= 1 with H·W <= {MAX_PIXELS}, got {shape_px!r}")
    shape = (int(values[0]), int(values[1]))
    height, width = shape
    xs = x0 + (np.arange(width) + 0.5) * (x1 - x0) / width
    ys = y1 - (np.arange(height) + 0.5) * (y1 - y0) / height
    grid = np.stack(np.meshgrid(xs, ys), axis=-1)  # (H, W, 2)
    return np.asarray(trail.concentration_at(grid), dtype=float).reshape(height, width)


@dataclass(frozen=True, eq=False)
class PolylineTrail:
    """A trail along a polyline: concentration 1 on it, a raised-cosine edge, 0 away from it.

    Parameters
    ----------
    vertices_m : array-like, shape (V, 2)
        The centre line's vertices on the floor, metres (2 <= V <= :data:`MAX_VERTICES`; consecutive
        vertices distinct; within ±:data:`MAX_COORD_M`).
    width_m : float or str
        Full width at half maximum, metres, or a preset name of :data:`TRAIL_WIDTHS_M`.
    edge_m : float
        Width of the raised-cosine edge, metres, in [0, width_m] (0: a hard edge).
    closed : bool
        If true, the last vertex joins the first (a loop).
    odour : int
        Which odour the trail carries (index into a sensor's odour axis, >= 0).
    """

    vertices_m: np.ndarray
    width_m: float = TRAIL_WIDTHS_M["normal"]
    edge_m: float = DEFAULT_EDGE_M
    closed: bool = False
    odour: int = 0
    _starts: np.ndarray = field(init=False, repr=False)
    _deltas: np.ndarray = field(init=False, repr=False)
    _inv_len2: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        try:
            vertices = np.array(self.vertices_m, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"trail vertices_m: expected numbers of shape (V, 2), got {self.vertices_m!r}") from None
        if vertices.ndim != 2 or vertices.shape[1] != 2 or not 2 <= vertices.shape[0] <= MAX_VERTICES:
            raise ConfigError(f"trail vertices_m: expected shape (V, 2) with 2 <= V <= {MAX_VERTICES}, "
                              f"got {vertices.shape}")
        if not (np.isfinite(vertices).all() and np.abs(vertices).max() <= MAX_COORD_M):
            raise ConfigError(f"trail vertices_m: every coordinate must be finite and within ±{MAX_COORD_M:g} m")
        width = trail_width_m(self.width_m)
        edge = real_or_nan(self.edge_m)
        if not (np.isfinite(edge) and 0.0 <= edge <= width):
            raise ConfigError(f"trail edge_m: expected a number in [0, width_m = {width}], got {self.edge_m!r}")
        ends = np.vstack([vertices[1:], vertices[:1]]) if self.closed else vertices[1:]
        starts = vertices[: len(ends)]
        deltas = ends - starts
        length2 = np.einsum("sk,sk->s", deltas, deltas)
        if (length2 <= 0).any():
            index = int(np.flatnonzero(length2 <= 0)[0])
            raise ConfigError(f"trail vertices_m: segment {index} has zero length (repeated vertex)")
        vertices.setflags(write=False)
        object.__setattr__(self, "vertices_m", vertices)
        object.__setattr__(self, "width_m", width)
        object.__setattr__(self, "edge_m", edge)
        object.__setattr__(self, "closed", bool(self.closed))
        object.__setattr__(self, "odour", odour_index("trail odour", self.odour))
        object.__setattr__(self, "_starts", starts)
        object.__setattr__(self, "_deltas", deltas)
        object.__setattr__(self, "_inv_len2", 1.0 / length2)

    @property
    def length_m(self) -> float:
        """Length of the centre line, metres (the closing segment included for a loop)."""
        return float(np.sqrt(1.0 / self._inv_len2).sum())

    def distance_m(self, points_m) -> np.ndarray:
        """Distance from the centre line of points (..., 2 or 3), metres, shape (...)."""
        xy = _floor_xy(points_m)
        flat = xy.reshape(-1, 2)
        out = np.empty(len(flat))
        chunk = max(1, _MAX_PAIRS_PER_CHUNK // len(self._starts))
        for lo in range(0, len(flat), chunk):
            rel = flat[lo:lo + chunk, None, :] - self._starts[None]  # (P, S, 2)
            t = np.clip(np.einsum("psk,sk->ps", rel, self._deltas) * self._inv_len2, 0.0, 1.0)
            off = rel - t[..., None] * self._deltas[None]
            out[lo:lo + chunk] = np.sqrt(np.einsum("psk,psk->ps", off, off).min(axis=1))
        return out.reshape(xy.shape[:-1])

    def profile(self, distance_m) -> np.ndarray:
        """The concentration at a distance from the centre line (the module docstring's c(d))."""
        d = np.asarray(distance_m, dtype=float)
        half, edge = 0.5 * self.width_m, self.edge_m
        if edge == 0.0:
            return np.where(d <= half, 1.0, 0.0)
        phase = np.clip((d - half + 0.5 * edge) / edge, 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * phase))

    def concentration_at(self, points_m) -> np.ndarray:
        """Concentration (dimensionless, in [0, 1]) at points (..., 2 or 3); shape (...)."""
        return self.profile(self.distance_m(points_m))

    def rasterise(self, x_range_m, y_range_m, shape_px) -> np.ndarray:
        """This trail as an (H, W) image over a floor rectangle (see :func:`rasterise`)."""
        return rasterise(self, x_range_m, y_range_m, shape_px)


@dataclass(frozen=True, eq=False)
class ImageTrail:
    """A trail painted as a greyscale image over a floor rectangle, read bilinearly.

    Parameters
    ----------
    image : array-like, shape (H, W)
        Concentrations: floats in [0, 1], or uint8 (read as value / 255). Row 0 is at the
        rectangle's largest y, column 0 at its smallest x.
    x_range_m, y_range_m : (float, float)
        The floor rectangle the image covers, metres.
    odour : int
        Which odour the trail carries (index into a sensor's odour axis, >= 0).
    """

    image: np.ndarray
    x_range_m: tuple[float, float]
    y_range_m: tuple[float, float]
    odour: int = 0

    def __post_init__(self) -> None:
        try:
            raw = np.asarray(self.image)
        except ValueError:  # a ragged nest of lists
            raise ConfigError("trail image: expected a greyscale image of shape (H, W), got rows of unequal length") \
                from None
        if raw.ndim != 2 or min(raw.shape) < 1 or raw.size > MAX_PIXELS:
            raise ConfigError(f"trail image: expected a greyscale image of shape (H, W) with H·W <= {MAX_PIXELS}, "
                              f"got {raw.shape}")
        if raw.dtype == np.uint8:
            image = raw.astype(float) / 255.0
        elif np.issubdtype(raw.dtype, np.number) and not np.issubdtype(raw.dtype, np.complexfloating):
            image = raw.astype(float)
            if not (np.isfinite(image).all() and image.min() >= 0.0 and image.max() <= 1.0):
                raise ConfigError("trail image: float values must be finite and in [0, 1] (or give uint8 0-255)")
        else:
            raise ConfigError(f"trail image: expected floats in [0, 1] or uint8, got dtype {raw.dtype}")
        image.setflags(write=False)
        object.__setattr__(self, "image", image)
        object.__setattr__(self, "x_range_m", _check_range("trail image x_range_m", self.x_range_m))
        object.__setattr__(self, "y_range_m", _check_range("trail image y_range_m", self.y_range_m))
        object.__setattr__(self, "odour", odour_index("trail image odour", self.odour))

    def concentration_at(self, points_m) -> np.ndarray:
        """Concentration at points (..., 2 or 3), bilinear between pixel centres, 0 off the image."""
        xy = _floor_xy(points_m)
        height, width = self.image.shape
        (x0, x1), (y0, y1) = self.x_range_m, self.y_range_m
        col = (xy[..., 0] - x0) / (x1 - x0) * width - 0.5
        row = (y1 - xy[..., 1]) / (y1 - y0) * height - 0.5
        col = np.clip(col, 0.0, width - 1.0)
        row = np.clip(row, 0.0, height - 1.0)
        c0 = np.minimum(np.floor(col).astype(np.intp), max(width - 2, 0))
        r0 = np.minimum(np.floor(row).astype(np.intp), max(height - 2, 0))
        c1 = np.minimum(c0 + 1, width - 1)
        r1 = np.minimum(r0 + 1, height - 1)
        fc, fr = col - c0, row - r0
        img = self.image
        top = img[r0, c0] * (1.0 - fc) + img[r0, c1] * fc
        bottom = img[r1, c0] * (1.0 - fc) + img[r1, c1] * fc
        value = top * (1.0 - fr) + bottom * fr
        inside = (xy[..., 0] >= x0) & (xy[..., 0] <= x1) & (xy[..., 1] >= y0) & (xy[..., 1] <= y1)
        return np.where(inside, value, 0.0)

    def rasterise(self, x_range_m, y_range_m, shape_px) -> np.ndarray:
        """This trail as an (H, W) image over a floor rectangle (see :func:`rasterise`)."""
        return rasterise(self, x_range_m, y_range_m, shape_px)


def straight_trail(start_xy_m, end_xy_m, width="normal", edge_m: float = DEFAULT_EDGE_M) -> PolylineTrail:
    """A straight trail from ``start_xy_m`` to ``end_xy_m`` (metres); width a preset name or metres."""
    return PolylineTrail(np.array([start_xy_m, end_xy_m], dtype=float), width, edge_m)


def loop_trail(centre_xy_m=(0.0, 0.0), radius_m: float = 2.0, width="normal", n_vertices: int = 96,
               edge_m: float = DEFAULT_EDGE_M) -> PolylineTrail:
    """A closed circular trail: a regular polygon of ``n_vertices`` (3 to :data:`MAX_VERTICES`) on a circle of
    ``radius_m``.

    The polygon's sides sit inside the circle by at most ``radius_m (1 - cos(π / n_vertices))``
    (0.05 % of the radius at the default 96 vertices).
    """
    if not (isinstance(n_vertices, int | np.integer) and not isinstance(n_vertices, bool)
            and 3 <= n_vertices <= MAX_VERTICES):
        raise ConfigError(f"loop trail n_vertices: expected an integer in [3, {MAX_VERTICES}], got {n_vertices!r}")
    radius = real_or_nan(radius_m)
    if not (np.isfinite(radius) and 0 < radius <= MAX_COORD_M):
        raise ConfigError(f"loop trail radius_m: expected a positive number of metres up to {MAX_COORD_M:g}, "
                          f"got {radius_m!r}")
    try:
        centre = np.asarray(centre_xy_m, dtype=float).reshape(2)
    except (TypeError, ValueError):
        centre = np.full(2, np.nan)
    if not (np.isfinite(centre).all() and np.abs(centre).max() + radius <= MAX_COORD_M):
        raise ConfigError(f"loop trail centre_xy_m: expected 2 finite numbers, the loop within ±{MAX_COORD_M:g} m, "
                          f"got {centre_xy_m!r}")
    angles = np.arange(n_vertices) * (2 * np.pi / n_vertices)
    vertices = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return PolylineTrail(vertices, width, edge_m, closed=True)
