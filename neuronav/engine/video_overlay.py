"""What a video shows beyond the camera's picture: the experiment, drawn with numpy on every backend alike.

:class:`VideoOverlay` is a :class:`~neuronav.engine.video.VideoRecorder`'s ``compose``: called with each
frame and the loop, it projects world-space things into the frame with the camera that took it and draws
them, engine-free:

- the plume's puffs where the world's filament plume has them at the frame's time (the backend's own
  :attr:`chemistry`, caught up with its clock), its source, and the wind (an arrow at the source and one
  in the frame's top-right corner, turned into the camera's frame);
- the scenario's :class:`Marker` s (nest, beacon, goal) as discs on the floor, its routes, and the
  agent's path so far;
- where the camera does not see them, the markers and the world's objects (a scene of a few) as coloured
  wedges at the frame's edge, in their direction (the visual compass's five objects: the world's turning
  and the ant's can be seen; the beacon's goal);
- insets in the bottom-left corner (:class:`EyeInset`, :class:`OdourInset`, :class:`PopulationInset`,
  :class:`LevelInset`): what the ant senses and its brain's key population.

The camera is the backend's ``follow_view()``: a physics backend's :class:`~neuronav.engine.articulated.FollowView`
(perspective, :class:`PerspectiveCamera` — the pose and intrinsics MuJoCo and PyBullet render
``"follow"`` from) or the kinematic backend's :class:`~neuronav.engine.video_topview.TopView` (orthographic,
from above). Everything here is uint8 RGB (H, W, 3) in and out.

:meth:`VideoOverlay.prepare` takes from the loop what a frame shows (copies) and returns ``draw(frame)``, which
reads nothing of the loop's: the video's writer thread draws while the loop steps on
(:class:`~neuronav.engine.video.VideoRecorder`); called as ``compose(frame, loop)`` it does both at once.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from neuronav.engine.video_draw import (
    blend,
    blend_box,
    disc_mask,
    draw_arrow,
    fill_polygon,
    heat_rgb,
    polyline_mask,
    put_text,
    text_image,
)
from neuronav.engine.video_topview import AGENT_RGB, TopView, agent_arrow_px

# Colours (RGB 0-255) and opacities of what is drawn.
PUFF_RGB = (235, 30, 200)  # magenta: no ground, sky or object of the project's worlds has it
PUFF_ALPHA = 0.75
PUFF_MIN_PX = 1.5
SOURCE_RGB = (200, 0, 0)
WIND_RGB = (20, 40, 200)
PATH_RGB = (30, 110, 235)
ROUTE_RGB = (250, 250, 250)
PANEL_RGB = (25, 25, 25)
PANEL_ALPHA = 0.75
# Sizes: a source disc (m), the wind arrow at the source (m per m/s), line widths (px), the insets' size (px).
SOURCE_RADIUS_M = 0.12
WIND_ARROW_S = 1.0
PATH_WIDTH_PX = 3
INSET_HEIGHT_PX = 72
INSET_WIDTH_PX = 200
INSET_GAP_PX = 6
EDGE_WEDGE_PX = 12
MAX_EDGE_OBJECTS = 8
NEAR_M = 0.05
# The path's last stretch within this of the body (m) is not drawn in a perspective view (the body hides it).
PATH_HIDDEN_M = 0.8
MARKER_ALPHA = 0.35


# -- cameras -----------------------------------------------------------------------------------------------
class PerspectiveCamera:
    """A pinhole camera from a follow view: ``eye``, ``target`` and ``up`` (3,), the vertical field of view
    ``fov_deg`` and ``size_px`` (width, height), as MuJoCo and PyBullet render it: the optical axis through
    the image's centre ((W - 1) / 2, (H - 1) / 2), focal length (H / 2) / tan(fov / 2) pixels, square pixels."""

    def __init__(self, view) -> None:
        self.size_px = tuple(int(v) for v in view.size_px)
        self.eye = np.asarray(view.eye, float)
        forward = np.asarray(view.target, float) - self.eye
        self.forward = forward / np.linalg.norm(forward)
        right = np.cross(self.forward, np.asarray(view.up, float))
        self.right = right / np.linalg.norm(right)
        self.up = np.cross(self.right, self.forward)
        self.focal_px = (self.size_px[1] / 2.0) / np.tan(np.radians(view.fov_deg) / 2.0)

    def camera_coordinates(self, points_m) -> np.ndarray:
        """Points (..., 3) in the camera's frame (..., 3): right, up, depth along the view (m)."""
        d = np.asarray(points_m, float) - self.eye
        return np.stack([d @ self.right, d @ self.up, d @ self.forward], axis=-1)

    def project(self, points_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates (..., 2) (column, row), pixels per metre at each point's depth (...,) and
        whether it is in front of the camera (depth above ``NEAR_M``)."""
        camera = self.camera_coordinates(points_m)
        depth = camera[..., 2]
        front = depth > NEAR_M
        safe = np.where(front, depth, 1.0)
        width, height = self.size_px
        u = (width - 1) / 2.0 + self.focal_px * camera[..., 0] / safe
        v = (height - 1) / 2.0 - self.focal_px * camera[..., 1] / safe
        return np.stack([u, v], axis=-1), self.focal_px / safe, front


def camera_of(backend) -> PerspectiveCamera | TopView | None:
    """The camera the backend's ``"follow"`` frame was taken with (None when it has none)."""
    follow = getattr(backend, "follow_view", None)
    if follow is None:
        return None
    view = follow()
    if isinstance(view, TopView):
        return view
    return PerspectiveCamera(view)


# -- what to show --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Marker:
    """A place on the floor: ``name`` (written next to it), ``position_m`` (x, y), ``radius_m``, ``rgb`` (0-255)."""

    name: str
    position_m: tuple[float, float]
    radius_m: float = 0.3
    rgb: tuple[int, int, int] = (250, 200, 0)


class EyeInset:
    """What the ant sees: ``cameras`` rendered (``backend.render``) side by side, each scaled to the inset's height
    by whole pixels (no stretch)."""

    def __init__(self, cameras: Sequence[str], label: str = "eyes", height_px: int = INSET_HEIGHT_PX,
                 width_px: int = 320) -> None:
        self.cameras, self.label, self.height_px, self.width_px = tuple(cameras), label, int(height_px), int(width_px)

    def __call__(self, loop) -> np.ndarray:
        images = []
        for camera in self.cameras:
            image = np.asarray(loop.backend.render(camera))
            factor = max(1, self.height_px // image.shape[0])
            factor = max(1, min(factor, self.width_px // max(1, image.shape[1] * len(self.cameras))))
            images.append(np.repeat(np.repeat(image, factor, axis=0), factor, axis=1))
        height = max(i.shape[0] for i in images)
        gap = np.zeros((height, 4, 3), np.uint8)
        parts = []
        for image in images:
            padded = np.zeros((height, image.shape[1], 3), np.uint8)
            padded[: image.shape[0]] = image
            parts += [padded, gap]
        return np.concatenate(parts[:-1], axis=1)


class OdourInset:
    """Each antenna tip's odour (summed over odours) as a bar: linear up to ``full_scale`` (a trail's 1), or with
    ``decades`` a log scale whose empty bar is ``full_scale`` / 10 ** ``decades`` (a plume's readings span decades)."""

    def __init__(self, full_scale: float = 1.0, decades: float | None = None, label: str = "odour L R",
                 sensor: str = "odour") -> None:
        self.full_scale, self.decades, self.label, self.sensor = float(full_scale), decades, label, sensor

    def __call__(self, loop) -> np.ndarray:
        odour = np.asarray(loop.backend.read((self.sensor,))[self.sensor], float)[0]
        values = np.clip(odour.reshape(odour.shape[0], -1).sum(axis=-1), 0.0, None)
        if self.decades is None:
            fractions = values / self.full_scale
        else:
            fractions = 1.0 + np.log10(np.maximum(values, 1e-300) / self.full_scale) / self.decades
        return bars(np.clip(fractions, 0.0, 1.0), (240, 120, 220))


class PopulationInset:
    """A brain population's rates (``read(loop)`` -> (n,)) as a row of cells coloured by rate and bars,
    scaled to [``low``, ``high``] (None: the population's own range)."""

    def __init__(self, label: str, read: Callable, low: float | None = 0.0, high: float | None = 1.0) -> None:
        self.label, self.read, self.low, self.high = label, read, low, high

    def __call__(self, loop) -> np.ndarray:
        rates = np.ravel(np.asarray(self.read(loop), float))
        low = np.nanmin(rates) if self.low is None else self.low
        high = np.nanmax(rates) if self.high is None else self.high
        scaled = (rates - low) / (high - low) if high > low else np.zeros_like(rates)
        return bars(np.clip(scaled, 0, 1), None)


class LevelInset:
    """One value (``read(loop)`` -> float, e.g. the mushroom body's novelty) as a bar in [``low``, ``high``]."""

    def __init__(self, label: str, read: Callable, low: float = 0.0, high: float = 1.0) -> None:
        self.label, self.read, self.low, self.high = label, read, float(low), float(high)

    def __call__(self, loop) -> np.ndarray:
        value = float(np.ravel(self.read(loop))[0])
        fraction = float(np.clip((value - self.low) / (self.high - self.low), 0, 1)) if np.isfinite(value) else 0.0
        panel = np.zeros((18, INSET_WIDTH_PX, 3), np.uint8)
        panel[3:15, 2: 2 + int(round(fraction * (INSET_WIDTH_PX - 4)))] = (250, 170, 40)
        return panel


def bars(fractions, rgb) -> np.ndarray:
    """Vertical bars, one per value in [0, 1] (``rgb``; None: each coloured by its value), under a row of cells
    coloured by value: a panel (INSET_HEIGHT_PX, INSET_WIDTH_PX, 3)."""
    fractions = np.nan_to_num(np.ravel(np.asarray(fractions, float)))
    n = max(len(fractions), 1)
    cell = max(2, min(40, (INSET_WIDTH_PX - 4) // n))
    panel = np.zeros((INSET_HEIGHT_PX, cell * n + 4, 3), np.uint8)
    colours = heat_rgb(fractions)
    panel[2:10, 2: 2 + cell * n] = np.repeat(colours, cell, axis=0)[None]
    top = 12
    for k, fraction in enumerate(fractions):
        height = int(round(fraction * (INSET_HEIGHT_PX - top - 2)))
        if height:
            colour = colours[k] if rgb is None else rgb
            panel[INSET_HEIGHT_PX - 2 - height: INSET_HEIGHT_PX - 2, 2 + k * cell: 2 + (k + 1) * cell - 1] = colour
    return panel


@dataclass(frozen=True)
class VideoContent:
    """What a scenario's video shows besides the camera's picture (see the module docstring).

    ``markers`` (nest, beacon, goal), ``routes`` (each (P, 2) m, drawn on the floor), ``insets`` (callables
    ``loop -> (h, w, 3) uint8`` with a ``label``), ``plume`` (the world's plume, source and wind), ``path``
    (the agent's path so far), ``objects_off_view`` (edge wedges toward the world's objects out of view),
    ``keep_in_view`` (points (x, y) m a view from above frames, with the path, instead of the whole world).
    """

    markers: tuple[Marker, ...] = ()
    routes: tuple = ()
    insets: tuple = ()
    plume: bool = True
    path: bool = True
    objects_off_view: bool = True
    keep_in_view: tuple = field(default=())  # points (x, y) m a view from above frames instead of the whole world


# -- the overlay -----------------------------------------------------------------------------------------------
class VideoOverlay:
    """``compose(frame, loop) -> frame`` for :class:`~neuronav.engine.video.VideoRecorder`: draws ``content``
    over each frame with the backend's follow camera (see the module docstring)."""

    def __init__(self, content: VideoContent | None = None) -> None:
        self.content = content or VideoContent()
        self.path_m: list[np.ndarray] = []
        self._last_step = None

    def __call__(self, frame: np.ndarray, loop) -> np.ndarray:
        draw, again = self.prepare(loop)
        return draw(loop.backend.render("follow") if again else frame)

    def prepare(self, loop) -> tuple[Callable[[np.ndarray], np.ndarray], bool]:
        """Take what the frame of this step shows from the loop now; draw it later (on another thread too).

        Returns ``draw(frame) -> frame`` (a new image; it reads nothing of the loop's) and whether the camera
        was moved (a new episode's view from above framing what it must keep in view: take the frame again).
        """
        backend, again = loop.backend, False
        if self._last_step is None or loop.control_steps < self._last_step:  # a new episode
            self.path_m = []
            if self.content.keep_in_view and hasattr(backend, "keep_in_view"):
                backend.keep_in_view(np.asarray(self.content.keep_in_view, float).reshape(-1, 2))
                again = True
        self._last_step = loop.control_steps
        position = np.asarray(backend.read(("position",))["position"], float)[0, :2]
        self.path_m.append(position)
        camera = camera_of(backend)
        world = self._world_now(camera, backend) if camera is not None else None
        panels = [(getattr(inset, "label", ""), np.asarray(inset(loop), np.uint8)) for inset in self.content.insets]

        def draw(frame: np.ndarray) -> np.ndarray:
            image = np.array(frame, dtype=np.uint8, order="C", copy=True)
            if world is not None:
                self._draw_world(image, camera, world)
            draw_insets(image, panels)
            return image

        return draw, again

    def _world_now(self, camera, backend) -> dict:
        """What :meth:`_draw_world` draws, copied from the backend now: the path, the plume, the objects, the pose."""
        world: dict = {"path": np.array(self.path_m), "plume": None, "things": [], "heading": None}
        chemistry = getattr(backend, "chemistry", None)
        if self.content.plume and chemistry is not None and chemistry.plume is not None:
            chemistry.advance_to(backend.time)
            plume = chemistry.plume
            world["plume"] = (plume.puffs.position_m.copy(), np.array(plume.puffs.r2_m2, float),
                              np.array(plume.wind.velocity_mps, float), tuple(plume.config.sources))
        if self.content.objects_off_view and isinstance(camera, PerspectiveCamera):
            world["things"] = self._things(backend)
        if isinstance(camera, TopView):
            world["heading"] = float(np.asarray(backend.read(("heading",))["heading"], float)[0, 0])
        return world

    # world-space things
    def _draw_world(self, image: np.ndarray, camera, world: dict) -> None:
        shape = image.shape[:2]
        for route in self.content.routes:
            self._floor_line(image, camera, np.asarray(route, float), ROUTE_RGB, 3)
        for marker in self.content.markers:
            self._floor_disc(image, camera, marker.position_m, marker.radius_m, marker.rgb, MARKER_ALPHA, ring=True)
        path = world["path"]
        if self.content.path and len(path) > 1:
            if isinstance(camera, PerspectiveCamera):  # not drawn over the body the camera looks at
                near = np.hypot(*(path - path[-1]).T) < PATH_HIDDEN_M
                path = path[: len(path) - int(np.argmin(near[::-1])) if not near.all() else 0]
            self._floor_line(image, camera, path, PATH_RGB, PATH_WIDTH_PX)
        if world["plume"] is not None:
            self._draw_plume(image, camera, *world["plume"])
        if world["things"]:
            self._edge_wedges(image, camera, world["things"])
        for marker in self.content.markers:  # the name right of the disc
            uv, _, front = camera.project(np.array([marker.position_m[0] + marker.radius_m, marker.position_m[1], 0.0]))
            if front and 0 <= uv[0] < shape[1] - 20 and 0 <= uv[1] < shape[0] - 12:
                put_text(image, marker.name, int(uv[1]) - 6, int(uv[0]) + 4, (0, 0, 0))
        if world["heading"] is not None:  # the agent's pose over what was drawn on the ground (a view from above)
            fill_polygon(image, agent_arrow_px(camera, world["path"][-1], world["heading"]), AGENT_RGB, 1.0)

    def _floor_points(self, points_m: np.ndarray, height_m: float = 0.01) -> np.ndarray:
        return np.column_stack([points_m[:, :2], np.full(len(points_m), height_m)])

    def _floor_line(self, image, camera, points_m, rgb, width_px) -> None:
        uv, _, front = camera.project(self._floor_points(points_m))
        uv[~front] = np.nan
        blend(image, polyline_mask(image.shape[:2], uv, width_px), rgb, 1.0)

    def _floor_disc(self, image, camera, centre_m, radius_m, rgb, alpha, ring: bool = False) -> None:
        angles = np.linspace(0.0, 2.0 * np.pi, 33)
        edge = np.asarray(centre_m, float)[:2] + radius_m * np.column_stack([np.cos(angles), np.sin(angles)])
        uv, _, front = camera.project(self._floor_points(edge))
        if front.all():
            fill_polygon(image, uv[:-1], rgb, alpha, min_px=6.0)
            if ring:
                blend(image, polyline_mask(image.shape[:2], uv, 3.0), rgb, 1.0)

    def _draw_plume(self, image, camera, puffs_m, r2_m2, wind, sources) -> None:
        if len(puffs_m):
            points = puffs_m.copy()
            points[:, 2] = np.maximum(points[:, 2], 0.02)
            uv, scale, front = camera.project(points)
            radius = np.maximum(np.sqrt(r2_m2) * scale, PUFF_MIN_PX)
            blend(image, disc_mask(image.shape[:2], uv[front], radius[front]), PUFF_RGB, PUFF_ALPHA)
        for source in sources:
            centre = np.asarray(source.position_m, float)
            self._floor_disc(image, camera, centre, SOURCE_RADIUS_M, SOURCE_RGB, 1.0)
            tail = np.array([centre[0], centre[1], 0.02])
            head = tail + np.array([*(wind * WIND_ARROW_S), 0.0])
            (a, b), _, front = camera.project(np.array([tail, head]))
            if front.all():
                draw_arrow(image, a, b, WIND_RGB, 3.0)
        self._wind_corner(image, camera, wind)

    def _wind_corner(self, image, camera, wind_mps: np.ndarray) -> None:
        """The wind as an arrow in the frame's top-right corner, in the camera's frame (up: the way it looks)."""
        if isinstance(camera, PerspectiveCamera):
            forward = camera.forward[:2] / max(np.hypot(*camera.forward[:2]), 1e-9)
            right = np.array([forward[1], -forward[0]])
            across, ahead = float(wind_mps @ right), float(wind_mps @ forward)
        else:
            across, ahead = float(wind_mps[0]), float(wind_mps[1])
        speed = float(np.hypot(across, ahead))
        width = image.shape[1]
        centre = np.array([width - 40.0, 40.0])
        blend_box(image, slice(4, 80), slice(width - 78, width - 4), PANEL_RGB, PANEL_ALPHA)
        put_text(image, "wind", 6, width - 74)
        if speed > 1e-6:
            unit = np.array([across, -ahead]) / speed
            draw_arrow(image, centre - 22 * unit, centre + 22 * unit, (120, 170, 255), 3.0)

    def _things(self, backend) -> list:
        """The markers and the world's objects (a scene of at most ``MAX_EDGE_OBJECTS``: a forest would fill the
        edge) where they are now: (position (3,) m, rgb, name)."""
        world = getattr(backend, "world", None)
        objects = world.objects if world is not None and len(world.objects) <= MAX_EDGE_OBJECTS else ()
        yaw = float(getattr(backend, "_scene_yaw_rad", 0.0))
        cos, sin = np.cos(yaw), np.sin(yaw)
        things = [(np.array([cos * o.position_m[0] - sin * o.position_m[1], sin * o.position_m[0]
                             + cos * o.position_m[1], o.position_m[2]]), np.asarray(o.rgba[:3], float) * 255.0, "")
                  for o in objects]
        return things + [(np.array([*m.position_m, 0.0]), np.asarray(m.rgb, float), m.name)
                         for m in self.content.markers]

    def _edge_wedges(self, image, camera: PerspectiveCamera, things: list) -> None:
        """A wedge at the frame's edge toward each of ``things`` (:meth:`_things`) the camera does not see, in its
        colour."""
        height, width = image.shape[:2]
        centre = np.array([(width - 1) / 2.0, (height - 1) / 2.0])
        for point, rgb, name in things:
            uv, _, front = camera.project(point)
            if front and 0 <= uv[0] < width and 0 <= uv[1] < height:
                continue
            right, up, _ = camera.camera_coordinates(point)
            direction = np.array([right, -up * 0.25])  # mostly sideways: the objects stand around the ant
            norm = np.hypot(*direction)
            if norm < 1e-9:
                continue
            direction /= norm
            reach = min((centre[0] - EDGE_WEDGE_PX) / max(abs(direction[0]), 1e-9),
                        (centre[1] - EDGE_WEDGE_PX) / max(abs(direction[1]), 1e-9))
            tip = centre + direction * reach
            normal = np.array([-direction[1], direction[0]])
            base = tip - direction * 2 * EDGE_WEDGE_PX
            fill_polygon(image, np.array([tip, base + EDGE_WEDGE_PX * normal, base - EDGE_WEDGE_PX * normal]), rgb)
            if name:  # a marker's name behind its wedge, inside the frame
                text_h, text_w = text_image(name).shape
                label = base - direction * (4 + abs(direction[0]) * text_w / 2 + abs(direction[1]) * text_h / 2)
                put_text(image, name, int(np.clip(label[1] - text_h / 2, 0, height - text_h)),
                         int(np.clip(label[0] - text_w / 2, 0, width - text_w)), rgb)


def draw_insets(image: np.ndarray, panels: list) -> None:
    """Draw ``panels`` ((label, (h, w, 3) uint8) pairs) in ``image`` in place: each on a dark box with its label,
    stacked up from the bottom-left corner, in a new column where one is full (those that fit)."""
    height, width = image.shape[:2]
    bottom, left, column_px = height - INSET_GAP_PX, INSET_GAP_PX, 0
    for label, panel in panels:
        h, w = panel.shape[0] + 18, panel.shape[1] + 8
        if bottom - h < 0:  # no room: the next column
            bottom, left, column_px = height - INSET_GAP_PX, left + column_px + INSET_GAP_PX, 0
        column_px = max(column_px, w)
        top = bottom - h
        if left + w > width:
            break
        blend_box(image, slice(top, bottom), slice(left, left + w), PANEL_RGB, PANEL_ALPHA)
        put_text(image, label, top + 1, left + 4)
        image[top + 16: top + 16 + panel.shape[0], left + 4: left + 4 + panel.shape[1]] = panel
        bottom = top - INSET_GAP_PX
