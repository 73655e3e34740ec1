"""Drawing on video frames with numpy alone: discs, polylines, convex polygons, arrows, text and a colour map.

Everything works in place on uint8 RGB frames (H, W, 3), in pixel coordinates (column, row) with pixel
centres at whole numbers; :mod:`neuronav.engine.video_overlay` and :mod:`neuronav.engine.video_topview`
draw with it. Text is drawn once per string by matplotlib's Agg canvas (imported on first use) and cached.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np


@lru_cache(maxsize=64)
def disc_offsets(radius_px: int) -> np.ndarray:
    """Integer (row, column) offsets (K, 2) of the pixels within ``radius_px`` + 0.5 of a centre."""
    r = int(radius_px)
    rows, cols = np.mgrid[-r: r + 1, -r: r + 1]
    inside = rows ** 2 + cols ** 2 <= (r + 0.5) ** 2
    return np.column_stack([rows[inside], cols[inside]])


def disc_mask(shape: tuple[int, int], centres_px, radii_px) -> np.ndarray:
    """A boolean mask (H, W): discs at ``centres_px`` (N, 2) (column, row) with ``radii_px`` (N,) (at most 80)."""
    mask = np.zeros(shape, bool)
    centres = np.asarray(centres_px, float).reshape(-1, 2)
    radii = np.clip(np.rint(np.broadcast_to(radii_px, centres.shape[:1])), 0, 80).astype(int)
    keep = np.isfinite(centres).all(axis=1)
    height, width = shape
    # Discs wholly outside the frame draw nothing.
    keep &= (centres[:, 0] + radii >= 0) & (centres[:, 0] - radii < width)
    keep &= (centres[:, 1] + radii >= 0) & (centres[:, 1] - radii < height)
    centres, radii = np.rint(centres[keep]).astype(int), radii[keep]
    for radius in np.unique(radii):
        chosen = centres[radii == radius]
        offsets = disc_offsets(int(radius))
        rows = (chosen[:, None, 1] + offsets[None, :, 0]).ravel()
        cols = (chosen[:, None, 0] + offsets[None, :, 1]).ravel()
        inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
        mask[rows[inside], cols[inside]] = True
    return mask


def blend(image: np.ndarray, mask: np.ndarray, rgb, alpha: float) -> None:
    """Paint ``rgb`` over ``image`` (H, W, 3) uint8 where ``mask`` is true, with opacity ``alpha``, in place."""
    rows = np.flatnonzero(mask.any(axis=1))
    if not rows.size:
        return
    cols = np.flatnonzero(mask[rows[0]: rows[-1] + 1].any(axis=0))
    box = np.s_[rows[0]: rows[-1] + 1, cols[0]: cols[-1] + 1]  # work on the mask's bounding box only
    region, inside = image[box], mask[box]
    colour = np.asarray(rgb, float)
    if alpha >= 1.0:
        region[inside] = np.clip(colour, 0, 255).astype(np.uint8)
    else:
        region[inside] = np.clip(region[inside] * (1.0 - alpha) + colour * alpha, 0, 255).astype(np.uint8)


def blend_box(image: np.ndarray, rows: slice, cols: slice, rgb, alpha: float) -> None:
    """:func:`blend` over the rectangle ``image[rows, cols]`` (the same values, without a frame-sized mask)."""
    region = image[rows, cols]
    region[:] = np.clip(region * (1.0 - alpha) + np.asarray(rgb, float) * alpha, 0, 255).astype(np.uint8)


def polyline_mask(shape: tuple[int, int], points_px, width_px: float) -> np.ndarray:
    """A boolean mask of the polyline through ``points_px`` (P, 2), ``width_px`` wide; non-finite points
    break it."""
    points = np.asarray(points_px, float).reshape(-1, 2)
    if len(points) < 2:
        return disc_mask(shape, points, width_px / 2.0)
    a, b = points[:-1], points[1:]
    good = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1)
    # Segments far longer than the frame (a point projected from just in front of the camera) are dropped.
    length = np.hypot(*(b - a).T)
    good &= length < 4 * sum(shape)
    a, b, length = a[good], b[good], length[good]
    if not len(a):
        return np.zeros(shape, bool)
    # Samples every 0.7 px or closer along each segment, both ends included: np.linspace(0, 1, c + 1) of each
    # segment's c steps, for all segments at once (a path of a few hundred points each frame).
    counts = np.maximum(1, np.ceil(length / 0.7).astype(int))
    segment = np.repeat(np.arange(len(a)), counts + 1)
    first = np.cumsum(counts + 1) - (counts + 1)  # each segment's first sample
    step = np.arange(segment.size) - first[segment]  # 0 .. c within its segment
    fraction = np.where(step == counts[segment], 1.0, step * (1.0 / counts)[segment])
    samples = a[segment] + (b[segment] - a[segment]) * fraction[:, None]
    return disc_mask(shape, samples, max(width_px / 2.0 - 0.5, 0.0))


def fill_polygon(image: np.ndarray, vertices_px, rgb, alpha: float = 1.0, min_px: float = 0.0) -> None:
    """Fill the convex polygon ``vertices_px`` (V, 2) (column, row) in ``image`` in place; a polygon
    smaller than ``min_px`` across is drawn as a disc of that diameter (it stays visible)."""
    vertices = np.asarray(vertices_px, float)
    if not np.isfinite(vertices).all():
        return
    height, width = image.shape[:2]
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    if (high - low).max() < min_px:
        blend(image, disc_mask((height, width), vertices.mean(axis=0), min_px / 2.0), rgb, alpha)
        return
    c0, r0 = max(int(np.floor(low[0])), 0), max(int(np.floor(low[1])), 0)
    c1, r1 = min(int(np.ceil(high[0])), width - 1), min(int(np.ceil(high[1])), height - 1)
    if c0 > c1 or r0 > r1:
        return
    rows, cols = np.mgrid[r0: r1 + 1, c0: c1 + 1]
    inside_left = np.ones(rows.shape, bool)
    inside_right = np.ones(rows.shape, bool)
    for (x0, y0), (x1, y1) in zip(vertices, np.roll(vertices, -1, axis=0)):
        cross = (x1 - x0) * (rows - y0) - (y1 - y0) * (cols - x0)
        inside_left &= cross >= -1e-9
        inside_right &= cross <= 1e-9
    mask = np.zeros((height, width), bool)
    mask[r0: r1 + 1, c0: c1 + 1] = inside_left | inside_right
    blend(image, mask, rgb, alpha)


def draw_arrow(image: np.ndarray, start_px, end_px, rgb, width_px: float = 3.0) -> None:
    """An arrow from ``start_px`` to ``end_px`` (column, row), its head a filled triangle."""
    start, end = np.asarray(start_px, float), np.asarray(end_px, float)
    along = end - start
    length = float(np.hypot(*along))
    if not np.isfinite(length) or length < 1.0:
        return
    unit = along / length
    normal = np.array([-unit[1], unit[0]])
    head = min(4.0 * width_px, 0.5 * length)
    neck = end - head * unit
    blend(image, polyline_mask(image.shape[:2], np.array([start, neck]), width_px), rgb, 1.0)
    fill_polygon(image, np.array([end, neck + 0.5 * head * normal, neck - 0.5 * head * normal]), rgb)


@lru_cache(maxsize=128)
def text_image(text: str, size_px: int = 11) -> np.ndarray:
    """``text`` in white as an alpha mask (h, w) float in [0, 1] (drawn once by matplotlib's Agg and cached)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(len(text) * size_px / 100.0 + 0.2, size_px * 1.6 / 100.0), dpi=100)
    canvas = FigureCanvasAgg(figure)
    figure.patch.set_alpha(0.0)
    figure.text(0.02, 0.5, text, fontsize=size_px * 0.72, color="white", va="center", ha="left")
    canvas.draw()
    alpha = np.asarray(canvas.buffer_rgba())[..., 3].astype(float) / 255.0
    cols = np.flatnonzero(alpha.max(axis=0) > 0)
    return alpha[:, : cols[-1] + 2] if cols.size else alpha[:, :1]


def put_text(image: np.ndarray, text: str, top: int, left: int, rgb=(255, 255, 255)) -> None:
    """Write ``text`` at (``top``, ``left``) in ``image`` in place (clipped at the frame's edge)."""
    alpha = text_image(text)
    height, width = image.shape[:2]
    h, w = min(alpha.shape[0], height - top), min(alpha.shape[1], width - left)
    if h <= 0 or w <= 0 or top < 0 or left < 0:
        return
    region = image[top: top + h, left: left + w].astype(float)
    a = alpha[:h, :w, None]
    image[top: top + h, left: left + w] = (region * (1 - a) + np.asarray(rgb, float) * a).astype(np.uint8)


def heat_rgb(values) -> np.ndarray:
    """Values in [0, 1] (...,) as colours (..., 3) uint8, dark blue through teal to yellow."""
    stops = np.array([[20, 20, 80], [30, 120, 150], [90, 200, 100], [250, 230, 40]], float)
    x = np.clip(np.nan_to_num(np.asarray(values, float)), 0.0, 1.0) * (len(stops) - 1)
    low = np.minimum(np.floor(x).astype(int), len(stops) - 2)
    t = (x - low)[..., None]
    return (stops[low] * (1 - t) + stops[low + 1] * t).astype(np.uint8)
