"""A camera from above, drawn with numpy: the kinematic backend's ``"follow"`` view (it has no engine to film).

:class:`TopView` is an orthographic camera looking straight down: ``centre_m`` (x, y) at the image's
centre, ``m_per_px`` metres per pixel, +x to the right and +y up in the image. :func:`top_view_frame`
draws what a World holds — the ground with a metre grid, its odour trails (as their concentration),
its objects (seen from above, turned by the scene's yaw about the origin as the backends turn them) —
and the agents' poses; :mod:`neuronav.engine.video_overlay` draws the rest (plume, path, nest, insets)
through the same :meth:`TopView.project`, so a point lands on the same pixel in both.

:class:`TopFraming` chooses the view: everything the World holds, every point it was asked to keep in
view (:meth:`TopFraming.keep`: the agent's path, a nest) and a margin, at the follow camera's size
(640 x 480). It only grows, so the picture does not jump while the ant walks inside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neuronav.engine.video_draw import fill_polygon
from neuronav.spec.world import World

# The same size as the physics backends' follow camera (neuronav.engine.articulated.FOLLOW_SIZE_PX).
TOP_SIZE_PX = (640, 480)
# Around the world's extent and the agent: this much ground (m) on every side, and at least this wide a view (m).
TOP_MARGIN_M = 1.5
TOP_MIN_SPAN_M = 6.0
# An agent is drawn as an arrow this long (m), at least TOP_AGENT_MIN_PX pixels.
TOP_AGENT_M = 0.6
TOP_AGENT_MIN_PX = 14
AGENT_RGB = (20, 20, 20)
GRID_RGB = (0.0, 0.0, 0.0)
GRID_ALPHA = 0.12
TRAIL_RGB = np.array([120.0, 70.0, 20.0])
TRAIL_ALPHA = 0.7


@dataclass(frozen=True)
class TopView:
    """An orthographic camera looking down: ``centre_m`` (x, y) at the image's centre, ``m_per_px``
    metres per pixel, ``size_px`` (width, height); +x right, +y up."""

    centre_m: tuple[float, float]
    m_per_px: float
    size_px: tuple[int, int] = TOP_SIZE_PX

    def project(self, points_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates (..., 2) (column, row; pixel centres at whole numbers), the metres-to-pixels
        scale at each point (...,) and whether it is in front of the camera (always, from above)."""
        points = np.asarray(points_m, float)
        width, height = self.size_px
        u = (width - 1) / 2.0 + (points[..., 0] - self.centre_m[0]) / self.m_per_px
        v = (height - 1) / 2.0 - (points[..., 1] - self.centre_m[1]) / self.m_per_px
        scale = np.full(points.shape[:-1], 1.0 / self.m_per_px)
        return np.stack([u, v], axis=-1), scale, np.ones(points.shape[:-1], bool)


def world_extent_m(world: World) -> np.ndarray:
    """Points (P, 2) m that bound what ``world`` holds: its objects (with their size), odour trails and
    plume arena (none for an empty world: shape (0, 2))."""
    points = []
    for obj in world.objects:
        reach = float(max(obj.size_m[:2]))
        x, y = obj.position_m[:2]
        points += [(x - reach, y - reach), (x + reach, y + reach)]
    for trail in world.odour.trails:
        if hasattr(trail, "vertices_m"):
            points += [tuple(v) for v in np.asarray(trail.vertices_m, float)]
        elif hasattr(trail, "x_range_m"):
            points += [(trail.x_range_m[0], trail.y_range_m[0]), (trail.x_range_m[1], trail.y_range_m[1])]
    if world.odour.plume is not None:
        plume = world.odour.plume
        points += [(plume.arena_x_m[0], plume.arena_y_m[0]), (plume.arena_x_m[1], plume.arena_y_m[1])]
    return np.array(points, float).reshape(-1, 2)


class TopFraming:
    """The :class:`TopView` that shows ``world`` (or only the points given to :meth:`frame`) and every point
    kept since (it only grows)."""

    def __init__(self, world: World, size_px: tuple[int, int] = TOP_SIZE_PX) -> None:
        self.size_px = tuple(int(v) for v in size_px)
        self._base = world_extent_m(world)
        self.reset()

    def reset(self) -> None:
        """Forget the kept points (a new episode); the world's extent (or the framed points) stays."""
        self._low = self._high = None
        self.view: TopView | None = None
        if len(self._base):
            self._grow(self._base)

    def frame(self, points_m) -> None:
        """Show ``points_m`` (..., 2) m instead of the whole world (a forest around a beacon is too wide a view)."""
        self._base = np.asarray(points_m, float).reshape(-1, 2)
        self.reset()

    def keep(self, points_m) -> bool:
        """Keep ``points_m`` (..., 2 or 3) m in view; whether the view changed."""
        points = np.asarray(points_m, float).reshape(-1, np.shape(points_m)[-1])[:, :2]
        points = points[np.isfinite(points).all(axis=1)]
        if not len(points):
            return False
        # Within the margin's inner half of the kept bounds: no change. Further out, the bounds grow to hold the
        # points with the whole margin (an agent never reaches the frame's edge, and the view grows in steps).
        inner = TOP_MARGIN_M / 2.0
        if self._low is not None and (points >= self._low + inner).all() and (points <= self._high - inner).all():
            return False
        self._grow(points)
        return True

    def _grow(self, points: np.ndarray) -> None:
        low, high = points.min(axis=0) - TOP_MARGIN_M, points.max(axis=0) + TOP_MARGIN_M
        if self._low is not None:
            low, high = np.minimum(low, self._low), np.maximum(high, self._high)
        self._low, self._high = low, high
        span = np.maximum(high - low, TOP_MIN_SPAN_M)
        width, height = self.size_px
        m_per_px = float(max(span[0] / (width - 1), span[1] / (height - 1)))
        centre = (low + high) / 2.0
        self.view = TopView((float(centre[0]), float(centre[1])), m_per_px, self.size_px)


def _ground(world: World, view: TopView) -> np.ndarray:
    """The ground (H, W, 3) uint8 under ``view``: its colour, a grid every 1, 2, 5, 10 ... m (about ten
    lines across) and the odour trails, darker where they smell more."""
    width, height = view.size_px
    image = np.empty((height, width, 3))
    image[:] = np.asarray(world.appearance.ground_rgb, float) * 255.0
    columns = (np.arange(width) - (width - 1) / 2.0) * view.m_per_px + view.centre_m[0]
    rows = ((height - 1) / 2.0 - np.arange(height)) * view.m_per_px + view.centre_m[1]
    span_m = width * view.m_per_px
    step = next(s for s in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1e3, 1e4) if span_m / s <= 16)
    for axis, coords in ((1, columns), (0, rows)):
        lines = np.flatnonzero(np.diff(np.floor(coords / step)) != 0)
        index = (slice(None), lines) if axis == 1 else (lines, slice(None))
        image[index] = image[index] * (1 - GRID_ALPHA) + np.asarray(GRID_RGB) * GRID_ALPHA
    if world.odour.trails:
        grid = np.stack(np.meshgrid(columns, rows), axis=-1)
        points = np.concatenate([grid, np.zeros(grid.shape[:-1] + (1,))], axis=-1)
        amount = sum(np.clip(np.asarray(t.concentration_at(points), float).reshape(height, width), 0, 1)
                     for t in world.odour.trails)
        alpha = TRAIL_ALPHA * np.clip(amount, 0.0, 1.0)[..., None]
        image = image * (1 - alpha) + TRAIL_RGB * alpha
    return np.clip(image, 0, 255).astype(np.uint8)


def _objects(image: np.ndarray, world: World, view: TopView, scene_yaw_rad: float) -> None:
    """Each object's footprint from above (a disc of its radius, a box's turned rectangle), in its colour."""
    cos, sin = np.cos(scene_yaw_rad), np.sin(scene_yaw_rad)
    turn = np.array([[cos, -sin], [sin, cos]])
    for obj in world.objects:
        centre = turn @ np.asarray(obj.position_m[:2], float)
        if obj.shape == "box":
            hx, hy = obj.size_m[0], obj.size_m[1]
            corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]) @ turn.T + centre
        else:
            angles = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
            corners = centre + obj.size_m[0] * np.column_stack([np.cos(angles), np.sin(angles)])
        pixels = view.project(corners)[0]
        rgb = np.asarray(obj.rgba[:3], float) * 255.0
        fill_polygon(image, pixels, rgb, 1.0, min_px=5.0)


def agent_arrow_px(view: TopView, position_m, heading_rad: float) -> np.ndarray:
    """The agent's arrow (3, 2) pixels: tip ahead along ``heading_rad`` (clockwise from +y), base behind."""
    length = max(TOP_AGENT_M, TOP_AGENT_MIN_PX * view.m_per_px)
    forward = np.array([np.sin(heading_rad), np.cos(heading_rad)])
    left = np.array([-forward[1], forward[0]])
    centre = np.asarray(position_m, float)[:2]
    tip, back = centre + 0.6 * length * forward, centre - 0.4 * length * forward
    return view.project(np.array([tip, back + 0.35 * length * left, back - 0.35 * length * left]))[0]


class TopViewCamera:
    """Draws ``world`` from above (:func:`top_view_frame`), the ground cached per view."""

    def __init__(self, world: World, size_px: tuple[int, int] = TOP_SIZE_PX) -> None:
        self.world = world
        self.framing = TopFraming(world, size_px)
        self._ground: tuple[TopView, np.ndarray] | None = None

    @property
    def view(self) -> TopView:
        return self.framing.view

    def render(self, positions_m: np.ndarray, headings_rad: np.ndarray, scene_yaw_rad: float = 0.0) -> np.ndarray:
        """The frame (H, W, 3) uint8 with every agent at ``positions_m`` (N, 2) facing ``headings_rad`` (N,);
        the first agent is kept in view."""
        self.framing.keep(np.asarray(positions_m, float)[:1])
        view = self.framing.view
        if self._ground is None or self._ground[0] != view:
            self._ground = (view, _ground(self.world, view))
        image = self._ground[1].copy()
        _objects(image, self.world, view, scene_yaw_rad)
        for position, heading in zip(np.asarray(positions_m, float), np.ravel(headings_rad)):
            fill_polygon(image, agent_arrow_px(view, position, float(heading)), AGENT_RGB, 1.0)
        return image
