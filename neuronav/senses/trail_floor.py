"""Odour trails drawn on the floor: one image that every backend shows, so that eyes and videos see the trail.

Sources: the I2Bot paper (§2.5.1) draws its odour trails on the floor as a texture; here the drawing
is computed once, engine-free, from a :class:`~neuronav.spec.world.World`'s ``odour.trails`` and
``appearance``, and every backend shows that same image:

- MuJoCo draws it as a textured, visual-only plane over :attr:`TrailFloor.x_range_m` ×
  :attr:`TrailFloor.y_range_m` just above the ground (:mod:`neuronav.backends.mujoco.mjcf`);
- PyBullet draws it as a textured, visual-only box in the physics client (videos), and its body
  cameras colour their ground pixels with :meth:`TrailFloor.rgb_at` (as they colour the checker);
- the kinematic ray caster (:mod:`neuronav.senses.raycast`) colours its ground hits with :meth:`TrailFloor.rgb_at`.

The image
---------
- **Where.** The rectangle holding every trail (a polyline trail's vertices widened by half its
  width and half its edge; an image trail's own rectangle) plus :data:`MARGIN_M` on every side,
  its corners snapped outwards to whole multiples of the pixel size. Pixels are square,
  :data:`PIXEL_M` a side, larger only where a side would pass :data:`MAX_SIDE_PX` pixels. On a
  checker ground the corners snap to whole checker periods (``2 checker_m``) and a period is a
  whole number of pixels (the pixel the largest divisor of the period not finer than
  :data:`PIXEL_M`: 0.02 m for the default 0.5 m squares), so the image tiles the checker.
  Row 0 is at the rectangle's largest y and column 0 at its smallest x (the floor seen from above,
  the convention of :func:`neuronav.senses.odour.rasterise`).
- **Colour.** With ``c`` the trails' concentration at the pixel's centre (the sum over trails of
  :func:`neuronav.senses.odour.rasterise`, clipped to [0, 1]: every odour index alike) and ``g`` the
  ground's colour there, a pixel is ``(1 - c) g + c`` :data:`TRAIL_RGB`, rounded to 8 bits
  (:func:`neuronav.senses.vision.to_uint8`). On a trail's flat top (``c = 1``) it is the trail colour, far
  from every trail the ground colour, and in between it darkens monotonically with ``c``.
- **Ground under the trail.** A ``plain`` appearance gives ``g = ground_rgb`` everywhere. A
  ``checker`` appearance draws its checker into the image too (``checker_rgb`` where
  ``floor(x / checker_m) + floor(y / checker_m)`` is odd, sampled at the pixel centre), so the
  rectangle continues the floor around it in videos, every checker edge on a pixel edge when
  ``checker_m`` is a whole number of pixels (0.5 m = 25 pixels by default; else to the nearest pixel).
- **Sampling.** Engines sample the texture nearest (one texel, no blending, in body cameras);
  :meth:`TrailFloor.rgb_at` does the same from floor points, so the three backends paint the same
  texel at the same place.

A world without trails has no floor image (:func:`trail_floor` returns None) and every backend
draws exactly what it drew before. Trails are drawn on a flat ground (``Ground.is_flat``: flat, a
wall's floor, or uneven with no roughness); on uneven ground they still smell but are not drawn.

Cost: building the image is one rasterisation per trail over its own part of the rectangle;
:func:`trail_floor` keeps the last few images it built, so every camera and every reset of one
world reuses one image.
"""

from __future__ import annotations

import struct
import zlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from neuronav.errors import ConfigError, real_or_nan
from neuronav.senses.odour import MAX_COORD_M, rasterise
from neuronav.senses.vision import to_uint8

TRAIL_RGB = (0.35, 0.22, 0.10)
"""An odour trail's colour on the floor, where its concentration is 1: a dark brown (grey ≈ 0.25),
darker than any ground of :mod:`neuronav.scenarios.worlds.scenes` and the default appearance, lighter than a
landmark's black (a dark-landmark threshold of 25/255 never takes it for the beacon)."""

PIXEL_M = 0.02
"""The floor image's pixel side, metres (a narrow 0.11 m trail spans five or six pixels)."""

MAX_SIDE_PX = 2048
"""The most pixels a side of the floor image holds (pixels grow beyond :data:`PIXEL_M` to keep to it)."""

MAX_SIDE_PX_LIMIT = 16384
"""The largest ``max_side_px`` :func:`build_trail_floor` accepts (a 16384² RGB image: 805 MB)."""

MARGIN_M = 0.1
"""Plain ground drawn around the trails' outer edges inside the rectangle, metres."""

_CACHE_SIZE = 4
# A polyline trail's segments are measured in pieces of at most this length (see _polyline_distance_m).
_PIECE_M = 1.0
_cache: OrderedDict = OrderedDict()


@dataclass(frozen=True, eq=False)
class TrailFloor:
    """The floor image of a world's trails and where it lies.

    Attributes
    ----------
    image : np.ndarray, uint8 (H, W, 3)
        RGB, read-only; row 0 at ``y_range_m[1]``, column 0 at ``x_range_m[0]``.
    concentration : np.ndarray, float (H, W)
        The trails' summed concentration at each pixel's centre, clipped to [0, 1] (read-only).
    x_range_m, y_range_m : (float, float)
        The floor rectangle the image covers, metres.
    """

    image: np.ndarray
    concentration: np.ndarray
    x_range_m: tuple[float, float]
    y_range_m: tuple[float, float]

    @property
    def shape_px(self) -> tuple[int, int]:
        """(H, W)."""
        return self.image.shape[0], self.image.shape[1]

    @property
    def pixel_m(self) -> float:
        """A pixel's side, metres (pixels are square)."""
        return (self.x_range_m[1] - self.x_range_m[0]) / self.image.shape[1]

    @property
    def centre_m(self) -> tuple[float, float]:
        """The rectangle's centre (x, y), metres."""
        return (0.5 * (self.x_range_m[0] + self.x_range_m[1]), 0.5 * (self.y_range_m[0] + self.y_range_m[1]))

    @property
    def half_size_m(self) -> tuple[float, float]:
        """The rectangle's half extents (x, y), metres."""
        return (0.5 * (self.x_range_m[1] - self.x_range_m[0]), 0.5 * (self.y_range_m[1] - self.y_range_m[0]))

    def texel_at(self, points_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The texel under floor points (..., 2 or 3) (height ignored): rows, columns and whether
        the point lies on the image (rows and columns are clipped into it where it does not)."""
        points = np.asarray(points_m, dtype=float)
        if points.ndim < 1 or points.shape[-1] not in (2, 3):
            raise ConfigError(f"trail floor points: expected shape (..., 2) or (..., 3), got {points.shape}")
        height, width = self.shape_px
        (x0, x1), (y0, y1) = self.x_range_m, self.y_range_m
        col = np.floor((points[..., 0] - x0) / (x1 - x0) * width)
        row = np.floor((y1 - points[..., 1]) / (y1 - y0) * height)
        inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
        rows = np.clip(np.nan_to_num(row), 0, height - 1).astype(np.intp)
        cols = np.clip(np.nan_to_num(col), 0, width - 1).astype(np.intp)
        return rows, cols, inside

    def rgb_at(self, points_m) -> tuple[np.ndarray, np.ndarray]:
        """What the floor shows at points (..., 2 or 3): the nearest texel's uint8 RGB (..., 3) and
        whether the point lies on the image (..., ) (elsewhere the colour is meaningless)."""
        rows, cols, inside = self.texel_at(points_m)
        return self.image[rows, cols], inside


def trail_floor(world) -> TrailFloor | None:
    """The floor image of ``world``'s trails (see the module doc), or None when it has no trail or
    its ground is not flat (trails are not drawn there). Kept for the next call with the same trails
    and appearance (the last few worlds)."""
    trails = tuple(world.odour.trails)
    if not trails or not world.ground.is_flat:
        return None
    key = (tuple(id(trail) for trail in trails), world.appearance)
    cached = _cache.get(key)
    if cached is not None and all(a is b for a, b in zip(cached[0], trails)):
        _cache.move_to_end(key)
        return cached[1]
    floor = build_trail_floor(trails, world.appearance)
    _cache[key] = (trails, floor)  # the trails are kept alive with their image: their ids stay theirs
    while len(_cache) > _CACHE_SIZE:
        _cache.popitem(last=False)
    return floor


def build_trail_floor(trails, appearance, pixel_m: float = PIXEL_M, margin_m: float = MARGIN_M,
                      max_side_px: int = MAX_SIDE_PX) -> TrailFloor | None:
    """The floor image of ``trails`` on the ground of ``appearance`` (no cache; see :func:`trail_floor`).

    Parameters
    ----------
    trails : sequence
        :class:`~neuronav.senses.odour.PolylineTrail`, :class:`~neuronav.senses.odour.ImageTrail`, or fields with
        ``concentration_at`` and ``x_range_m``, ``y_range_m`` (their extent).
    appearance : neuronav.spec.world.Appearance
        The ground's look under and around the trails.
    pixel_m, margin_m : float
        The pixel side and the plain margin around the trails, metres (> 0 and >= 0, finite, at most
        :data:`neuronav.senses.odour.MAX_COORD_M`).
    max_side_px : int
        The most pixels a side may hold (2 to :data:`MAX_SIDE_PX_LIMIT`).

    Returns
    -------
    TrailFloor or None
        None when ``trails`` is empty.
    """
    trails = tuple(trails)
    if not trails:
        return None
    if not (0 < real_or_nan(pixel_m) <= MAX_COORD_M and 0 <= real_or_nan(margin_m) <= MAX_COORD_M):
        raise ConfigError(f"trail floor: pixel_m must be > 0 and margin_m >= 0 (finite metres), got {pixel_m!r}, "
                          f"{margin_m!r}")
    if isinstance(max_side_px, bool) or not isinstance(max_side_px, int | np.integer) \
            or not 2 <= max_side_px <= MAX_SIDE_PX_LIMIT:
        raise ConfigError(f"trail floor: max_side_px must be an integer in [2, {MAX_SIDE_PX_LIMIT}], "
                          f"got {max_side_px!r}")
    boxes = np.array([trail_extent_m(index, trail) for index, trail in enumerate(trails)])  # (T, 4)
    low = boxes[:, [0, 2]].min(axis=0) - margin_m
    high = boxes[:, [1, 3]].max(axis=0) + margin_m
    period = 2.0 * appearance.checker_m if appearance.ground_texture == "checker" else None
    (x0, y0), pixel, (width, height) = _grid(low, high, float(pixel_m), int(max_side_px), period)
    x1, y1 = x0 + width * pixel, y0 + height * pixel
    concentration = np.zeros((height, width))
    xs = x0 + (np.arange(width) + 0.5) * pixel  # pixel centres
    ys = y1 - (np.arange(height) + 0.5) * pixel
    for box, trail in zip(boxes, trails):
        # Only the pixels that can see this trail: its box, in whole pixels of the image.
        c0 = int(np.clip(np.floor((box[0] - x0) / pixel), 0, width))
        c1 = int(np.clip(np.ceil((box[1] - x0) / pixel), 0, width))
        r0 = int(np.clip(np.floor((y1 - box[3]) / pixel), 0, height))
        r1 = int(np.clip(np.ceil((y1 - box[2]) / pixel), 0, height))
        if c1 <= c0 or r1 <= r0:
            continue
        if _is_polyline(trail):
            distance = _polyline_distance_m(trail, xs[c0:c1], ys[r0:r1], pixel)
            near = np.isfinite(distance)  # the pixels within the trail's reach (the others stay at 0)
            concentration[r0:r1, c0:c1][near] += trail.profile(distance[near])
        else:
            concentration[r0:r1, c0:c1] += rasterise(trail, (x0 + c0 * pixel, x0 + c1 * pixel),
                                                     (y1 - r1 * pixel, y1 - r0 * pixel), (r1 - r0, c1 - c0))
    np.clip(concentration, 0.0, 1.0, out=concentration)
    # The ground's colour as an index into (ground_rgb, checker_rgb); blended only where a trail lies.
    palette = np.array([appearance.ground_rgb, appearance.checker_rgb], float)
    which = _checker_odd(appearance, xs[None, :], ys[:, None]).astype(np.intp)  # (H, W)
    image = to_uint8(palette)[which]
    on = concentration > 0.0
    image[on] = to_uint8(blend_rgb(palette[which[on]], concentration[on]))
    image.setflags(write=False)
    concentration.setflags(write=False)
    return TrailFloor(image, concentration, (float(x0), float(x1)), (float(y0), float(y1)))



def _grid(low: np.ndarray, high: np.ndarray, pixel_m: float, max_side_px: int,
          period_m: float | None) -> tuple[np.ndarray, float, tuple[int, int]]:
    """The image's corner (x0, y0), square pixel side and (W, H) for the rectangle ``low``..``high`` (2,).

    Pixels of ``pixel_m``, coarser where a side would pass ``max_side_px``; corners on multiples of
    the pixel. With a checker of period ``period_m`` (two squares) the corners are on multiples of
    the period and a period is a whole number of pixels: the image then tiles the checker seamlessly,
    so an engine's texture filtering, which wraps around the image's edges (MuJoCo's lit follow
    view), blends an edge with the same checker colours it continues. Past 1/``max_side_px`` of the
    extent per period, a pixel covers whole periods (the checker is too fine to draw there).
    """
    if period_m is None:
        pixel = max(pixel_m, float((high - low).max()) / (max_side_px - 1))  # one pixel of slack for the snap
        start = np.floor(low / pixel)
        count = np.maximum(np.ceil(high / pixel) - start, 1).astype(int)
        return start * pixel, pixel, (int(count[0]), int(count[1]))
    lo, hi = np.floor(low / period_m) * period_m, np.ceil(high / period_m) * period_m
    periods = np.maximum(np.rint((hi - lo) / period_m), 1)
    per_period = max(1, int(np.floor(period_m / pixel_m + 1e-9)))  # pixels per period, never finer than asked
    per_period = min(per_period, int(max_side_px // periods.max()))
    if per_period >= 1:
        count = (periods * per_period).astype(int)
        return lo, period_m / per_period, (int(count[0]), int(count[1]))
    step = period_m * np.ceil(float(periods.max()) / max_side_px)  # whole periods per pixel
    lo, hi = np.floor(low / step) * step, np.ceil(high / step) * step
    count = np.maximum(np.rint((hi - lo) / step), 1).astype(int)
    return lo, float(step), (int(count[0]), int(count[1]))


def _is_polyline(trail) -> bool:
    return all(hasattr(trail, name) for name in ("vertices_m", "width_m", "closed", "profile"))


def _polyline_distance_m(trail, xs: np.ndarray, ys: np.ndarray, pixel_m: float) -> np.ndarray:
    """Distance (H, W) from a polyline trail's centre line of the pixel centres ``xs`` (W,) × ``ys`` (H,),
    exact within the trail's reach (beyond it, where its concentration is 0, only a bound: inf or more).

    Each segment, cut into pieces of at most :data:`_PIECE_M`, is measured only on the pixels of its
    piece's box widened by the reach; a pixel keeps its smallest distance. The same distance as
    :meth:`~neuronav.senses.odour.PolylineTrail.distance_m` on every pixel the trail reaches, at a cost
    proportional to the trail's area rather than the rectangle's.
    """
    vertices = np.asarray(trail.vertices_m, float)
    ends = np.vstack([vertices[1:], vertices[:1]]) if trail.closed else vertices[1:]
    starts = vertices[:len(ends)]
    reach = 0.5 * (float(trail.width_m) + float(getattr(trail, "edge_m", 0.0))) + pixel_m
    distance = np.full((ys.size, xs.size), np.inf)
    x_first, y_first = xs[0], ys[0]  # xs rise, ys fall (row 0 at the top)
    for a, b in zip(starts, ends):
        pieces = max(1, int(np.ceil(np.hypot(*(b - a)) / _PIECE_M)))
        cuts = a + np.linspace(0.0, 1.0, pieces + 1)[:, None] * (b - a)
        for p, q in zip(cuts[:-1], cuts[1:]):
            delta = q - p
            c0 = max(int(np.floor((min(p[0], q[0]) - reach - x_first) / pixel_m)), 0)
            c1 = min(int(np.ceil((max(p[0], q[0]) + reach - x_first) / pixel_m)) + 1, xs.size)
            r0 = max(int(np.floor((y_first - max(p[1], q[1]) - reach) / pixel_m)), 0)
            r1 = min(int(np.ceil((y_first - min(p[1], q[1]) + reach) / pixel_m)) + 1, ys.size)
            if c1 <= c0 or r1 <= r0:
                continue
            rel_x = xs[None, c0:c1] - p[0]
            rel_y = ys[r0:r1, None] - p[1]
            t = np.clip((rel_x * delta[0] + rel_y * delta[1]) / float(delta @ delta), 0.0, 1.0)
            off = np.hypot(rel_x - t * delta[0], rel_y - t * delta[1])
            np.minimum(distance[r0:r1, c0:c1], off, out=distance[r0:r1, c0:c1])
    return distance


def trail_extent_m(index: int, trail) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) outside which ``trail``'s concentration is 0, metres."""
    vertices = getattr(trail, "vertices_m", None)
    if vertices is not None and hasattr(trail, "width_m"):
        reach = 0.5 * (float(trail.width_m) + float(getattr(trail, "edge_m", 0.0)))
        vertices = np.asarray(vertices, float).reshape(-1, 2)
        (xa, ya), (xb, yb) = vertices.min(axis=0) - reach, vertices.max(axis=0) + reach
        return float(xa), float(xb), float(ya), float(yb)
    if hasattr(trail, "x_range_m") and hasattr(trail, "y_range_m"):
        (xa, xb), (ya, yb) = trail.x_range_m, trail.y_range_m
        return float(xa), float(xb), float(ya), float(yb)
    raise ConfigError(f"odour trail {index} ({type(trail).__name__}): cannot draw it on the floor, its extent is "
                      f"unknown (expected a PolylineTrail, an ImageTrail, or x_range_m and y_range_m)")


def ground_rgb_at(appearance, x_m, y_m) -> np.ndarray:
    """The ground's float RGB (..., 3) at floor points (arrays broadcasting to (...)): ``ground_rgb``,
    or on a checker ground ``checker_rgb`` where ``floor(x / checker_m) + floor(y / checker_m)`` is odd."""
    odd = _checker_odd(appearance, x_m, y_m)[..., None]
    return np.where(odd, np.asarray(appearance.checker_rgb, float), np.asarray(appearance.ground_rgb, float))


def _checker_odd(appearance, x_m, y_m) -> np.ndarray:
    """Where the ground shows ``checker_rgb`` (bool, the broadcast shape of ``x_m`` and ``y_m``)."""
    x, y = np.asarray(x_m, float), np.asarray(y_m, float)
    if appearance.ground_texture != "checker":
        return np.zeros(np.broadcast_shapes(x.shape, y.shape), bool)
    size = appearance.checker_m
    # Each coordinate's square first (a row and a column of an image cost a row and a column), then their sum.
    return (np.floor(x / size) + np.floor(y / size)) % 2 == 1


def blend_rgb(ground_rgb, concentration) -> np.ndarray:
    """The floor's float RGB (..., 3): ``ground_rgb`` (..., 3) blended toward :data:`TRAIL_RGB` by the
    trail concentration (...) clipped to [0, 1] (0: the ground, 1: the trail colour)."""
    c = np.clip(np.asarray(concentration, float), 0.0, 1.0)[..., None]
    return (1.0 - c) * np.asarray(ground_rgb, float) + c * np.asarray(TRAIL_RGB, float)


def trail_rgb_at(world, points_m) -> tuple[np.ndarray, np.ndarray] | None:
    """What ``world``'s floor image shows at floor points (N, 2) (:meth:`TrailFloor.rgb_at`), or None
    when the world draws no trail."""
    floor = trail_floor(world)
    return None if floor is None else floor.rgb_at(points_m)


def png_bytes(image: np.ndarray) -> bytes:
    """An RGB uint8 image (H, W, 3) as PNG bytes (row 0 first; no imaging library needed), for engines
    that load textures from files."""
    image = np.ascontiguousarray(image, np.uint8)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ConfigError(f"png_bytes: expected an RGB image of shape (H, W, 3), got {image.shape}")

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    height, width = image.shape[:2]
    rows = b"".join(b"\x00" + row.tobytes() for row in image)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
