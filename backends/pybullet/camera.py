"""Cameras in PyBullet: flat-shaded views for body cameras and the lit follow view, through TinyRenderer.

What TinyRenderer does and how it is made to follow :mod:`neuronav.senses.vision`:

- **Projection.** The OpenGL matrix is written here with independent horizontal and vertical fields
  of view (``f_x = 1 / tan(fov_h / 2)``, ``f_y = 1 / tan(fov_v / 2)``), clipping at
  ``vision.NEAR_M`` and ``vision.FAR_M``. TinyRenderer samples each pixel at its corner, not its
  centre; the matrix shifts the image by half a pixel in x and y so that pixel (r, c) shows what
  lies along the ray through its centre (checked against the geometry of a box's edges).
- **Flat shading.** ``lightAmbientCoeff`` 1, diffuse and specular 0, no shadow: a surface shows
  ``int(255 * rgba)`` (TinyRenderer truncates; :func:`neuronav.backends.pybullet.scene.exact_rgba` asks for
  the middle of each 8-bit step, so the pixel is ``round(255 * rgba)``).
- **Ground.** TinyRenderer's texture coordinates go wrong across the large triangles of a ground
  that reaches hundreds of metres, so body cameras do not use a texture: the ground's pixels
  (its bodies in the segmentation mask) are coloured here from where their ray meets the ground
  (the plane z = 0 for a flat ground, the depth buffer's distance on a heightfield):
  ``ground_rgb`` or the checker of ``World.appearance``, and on the odour trails' floor image
  (:mod:`neuronav.senses.trail_floor`) that image's texel, as the kinematic ray caster paints it.
- **Sky.** The depth buffer is exactly 1 (the far plane) where nothing was drawn: that is the sky
  mask, which the caller paints (:func:`neuronav.senses.vision.compose_image`). With the near plane at
  5 mm, ground 500 m away still has a depth below 1 (1 - 5e-6; float32 resolves 6e-8 there).
- **Compound eyes.** Their cube faces (:mod:`neuronav.senses.compound_eye_views`) are coloured from the
  segmentation mask, body by body (:func:`spectral_lut`: each object's green and UV, the ground's for the rest);
  a flat world's floor is hidden from TinyRenderer and drawn from the pixels' rays (:func:`render_spectral`).
  They draw their own, coarser copies of the objects (:func:`neuronav.backends.pybullet.scene.build_eye_objects`),
  each face only those it can show, the faces in the order that toggles fewest objects in between.
- **Follow view.** Lit with TinyRenderer's default light, at half its size a side (:data:`FOLLOW_SCALE`:
  a quarter of the pixels to shade, what a frame of video costs), scaled up bilinearly (:func:`upsample2`).
- **Culling.** TinyRenderer transforms every triangle of every shape, in view or not; it skips a shape
  whose alpha is 0. :class:`ObjectCulling` gives alpha 0 to each world object whose bounding sphere lies
  outside the view's frustum (exact: it could not cover a pixel) and its colour back when a view faces it.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from neuronav.backends.pybullet.engine import pb
from neuronav.backends.pybullet.scene import exact_rgba
from neuronav.engine.articulated import FollowView
from neuronav.senses.trail_floor import trail_floor
from neuronav.senses.vision import FAR_M, NEAR_M, View, pixel_directions, sky_rgb, to_uint8
from neuronav.spec.body import Camera
from neuronav.spec.world import World, WorldObject

# TinyRenderer takes seconds for an eye exactly on a heightfield grid line with an axis-aligned view
# (e.g. a forward camera after the default reset); a sub-micrometre shift avoids that.
EYE_NUDGE_M = np.array([3.1e-7, 1.7e-7, 0.0])
FLAT_LIGHT = {"lightAmbientCoeff": 1.0, "lightDiffuseCoeff": 0.0, "lightSpecularCoeff": 0.0}
# The follow view (videos) is drawn at 1/FOLLOW_SCALE of its size a side, then scaled up (upsample2): TinyRenderer's
# time grows with the pixels (90 ms for 640 x 480, 24 ms for 320 x 240 in the odour-trail world, upsample2 5 ms).
FOLLOW_SCALE = 2


def projection(fov_h_rad: float, fov_v_rad: float, width_px: int, height_px: int,
               near_m: float = NEAR_M, far_m: float = FAR_M) -> list[float]:
    """OpenGL projection matrix (column-major, as PyBullet wants it), pixel centres on their rays."""
    fx, fy = 1.0 / math.tan(fov_h_rad / 2.0), 1.0 / math.tan(fov_v_rad / 2.0)
    a, b = -(far_m + near_m) / (far_m - near_m), -2.0 * far_m * near_m / (far_m - near_m)
    # Third column: the half-pixel shift (NDC spans 2 over the image: half a pixel is 1/W, 1/H).
    return [fx, 0.0, 0.0, 0.0, 0.0, fy, 0.0, 0.0, 1.0 / width_px, 1.0 / height_px, a, -1.0, 0.0, 0.0, b, 0.0]


def view_matrix(eye_m: np.ndarray, rotation: np.ndarray) -> list[float]:
    """World-to-camera matrix (column-major) of a camera at ``eye_m`` with frame axes ``rotation`` (columns)."""
    matrix = np.eye(4)
    matrix[:3, :3] = rotation.T
    matrix[:3, 3] = -rotation.T @ eye_m
    return matrix.T.ravel().tolist()


def linear_depth_m(depth: np.ndarray, near_m: float = NEAR_M, far_m: float = FAR_M) -> np.ndarray:
    """Distance along the camera's -z axis from OpenGL window depth in [0, 1]."""
    return far_m * near_m / (far_m - (far_m - near_m) * np.asarray(depth, float))


@lru_cache(maxsize=32)
def _directions(width_px: int, height_px: int, fov_h_rad: float, fov_v_rad: float) -> np.ndarray:
    """Unit pixel rays (H, W, 3) in the camera frame of a planar view
    (:func:`neuronav.senses.vision.pixel_directions`)."""
    camera = Camera("view", "view", (0.0, 0.0, 0.0), width_px=width_px, height_px=height_px,
                    fov_rad=(fov_h_rad, fov_v_rad))
    directions = pixel_directions(camera)
    directions.setflags(write=False)
    return directions


def _render(cid: int, eye_m, rotation, width_px: int, height_px: int, fov_rad, light: dict, segmentation: bool):
    eye = np.asarray(eye_m, float) + EYE_NUDGE_M
    flags = 0 if segmentation else pb.ER_NO_SEGMENTATION_MASK
    _, _, rgb, depth, seg = pb.getCameraImage(int(width_px), int(height_px), view_matrix(eye, np.asarray(rotation)),
                                              projection(fov_rad[0], fov_rad[1], width_px, height_px), shadow=0,
                                              renderer=pb.ER_TINY_RENDERER, flags=flags, physicsClientId=cid, **light)
    shape = (int(height_px), int(width_px))
    rgb = np.asarray(rgb, np.uint8).reshape(*shape, 4)[:, :, :3].copy()
    return rgb, np.asarray(depth, np.float32).reshape(shape), (np.asarray(seg).reshape(shape) if segmentation else None)


def bounding_radius_m(obj: WorldObject) -> float:
    """The radius of the sphere about an object's position that holds all of it (its shape turns about it)."""
    size = np.asarray(obj.size_m, float)
    if obj.shape == "sphere":
        return float(size[0])
    return float(np.linalg.norm(size))  # box: the half extents; cylinder and cone: radius and half height


def spheres_in_views(centres_m: np.ndarray, radii_m: np.ndarray, views: list[View]) -> np.ndarray:
    """Which spheres (n, 3) centres, (n,) radii reach into each view's frustum (between ``NEAR_M`` and ``FAR_M``,
    inside its four sides; a side at or beyond 90° from the axis is not tested): bool (views, n)."""
    centres_m = np.asarray(centres_m, float)
    inside = np.empty((len(views), len(centres_m)), dtype=bool)
    for v, view in enumerate(views):
        local = (centres_m - view.eye_m) @ view.rotation  # view axes: x right, y up, z backwards
        depth = -local[:, 2]
        shown = (depth + radii_m > NEAR_M) & (depth - radii_m < FAR_M)
        for axis, half_rad in ((0, view.fov_rad[0] / 2.0), (1, view.fov_rad[1] / 2.0)):
            if half_rad < math.pi / 2.0:  # the signed distance to each side plane is at most the radius
                shown &= np.abs(local[:, axis]) * math.cos(half_rad) - depth * math.sin(half_rad) <= radii_m
        inside[v] = shown
    return inside


def fewest_changes_order(shown: np.ndarray, start: np.ndarray) -> list[int]:
    """An order of the rows of ``shown`` (V, n) bool that goes from ``start`` (n,) each time to the nearest row
    left (fewest entries differing): views drawn in this order toggle few objects in between."""
    differ = (shown[:, None, :] != shown[None, :, :]).sum(axis=2)  # (V, V)
    left = list(range(len(shown)))
    order = [min(left, key=lambda v: int((shown[v] != start).sum()))]
    left.remove(order[0])
    while left:
        nearest = min(left, key=lambda v: differ[order[-1], v])
        order.append(nearest)
        left.remove(nearest)
    return order


class ObjectCulling:
    """The world objects of a render-only client, each drawn only for the views its bounding sphere reaches.

    Parameters
    ----------
    cid : int
        The client.
    handles : list of int
        The objects' bodies, in ``objects``' order (each at its declared pose turned about the world z axis).
    objects : sequence of WorldObject
        The world's objects.
    hidden : bool
        Whether the objects start hidden (alpha 0) rather than shown.
    """

    def __init__(self, cid: int, handles: list[int], objects, hidden: bool = False) -> None:
        self._cid, self._handles = cid, list(handles)
        self._positions_m = np.array([obj.position_m for obj in objects], float).reshape(-1, 3)
        self._radii_m = np.array([bounding_radius_m(obj) for obj in objects], float)
        self._rgba = [exact_rgba(obj.rgba) for obj in objects]
        self._hidden = np.full(len(self._handles), hidden)  # alpha 0, not drawn
        self.count = len(self._handles)
        self.yaw_rad = 0.0  # the scene's turn about the world z axis

    def hide_all(self) -> None:
        """Hide every object (another set of the same objects is drawn meanwhile)."""
        for k in np.flatnonzero(~self._hidden):
            pb.changeVisualShape(self._handles[k], -1, rgbaColor=[*self._rgba[k][:3], 0.0], physicsClientId=self._cid)
        self._hidden[:] = True

    def visible_in(self, views: list[View]) -> np.ndarray:
        """Whether each object's bounding sphere reaches into each view, bool (views, objects)."""
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        x, y, z = self._positions_m.T
        centres = np.column_stack([c * x - s * y, s * x + c * y, z])
        return spheres_in_views(centres, self._radii_m, views)

    def only_for(self, view: View) -> None:
        """Hide the objects ``view`` cannot show and show the others (only those that change are touched)."""
        if self._handles:
            self.show(self.visible_in([view])[0])

    @property
    def shown(self) -> np.ndarray:
        """Which objects are drawn now, bool (objects,)."""
        return ~self._hidden

    def show(self, shown: np.ndarray) -> None:
        """Show the objects ``shown`` (bool, one per object) and hide the others (only those that change)."""
        for k in np.flatnonzero(shown == self._hidden):
            rgba = self._rgba[k] if shown[k] else [*self._rgba[k][:3], 0.0]
            pb.changeVisualShape(self._handles[k], -1, rgbaColor=rgba, physicsClientId=self._cid)
        self._hidden = ~shown


def render_flat(cid: int, view: View, world: World, ground_ids: list[int],
                floor_z_m: float = 0.0, culling: ObjectCulling | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One body-camera view, flat-shaded: its uint8 image (h, w, 3) and sky mask (h, w) (see the module doc).

    ``ground_ids``: the ground's bodies, the flat floor (top at ``floor_z_m``) last. ``culling``: the
    world objects, drawn only where the view reaches them (:class:`ObjectCulling`).
    """
    if culling is not None:
        culling.only_for(view)
    # Ground pixels are painted here on a checker ground, or where the world draws odour trails.
    painted = world.appearance.ground_texture == "checker" or trail_floor(world) is not None
    rgb, depth, seg = _render(cid, view.eye_m, view.rotation, view.width_px, view.height_px, view.fov_rad,
                              FLAT_LIGHT, segmentation=painted)
    sky = depth >= 1.0
    if painted:
        # The last ground body is the flat floor (its top at floor_z_m), any other a heightfield.
        floor, field = seg == ground_ids[-1], np.isin(seg, ground_ids[:-1])
        for mask, plane_z_m in ((floor & ~sky, floor_z_m), (field & ~sky, None)):
            if mask.any():
                rgb[mask] = ground_colour(view, world, mask, depth, plane_z_m)
    return rgb, sky


def spectral_lut(world: World, ground_ids: list[int], object_ids: list[int]) -> np.ndarray:
    """The compound eyes' colours (:func:`neuronav.senses.compound_eye.spectral_world`: (0, green, UV) as uint8)
    by the vision client's body id: each object's ``spectral``, every other body (the ground, the wall) the
    ground's ``ground_green_uv``. Indexed by a segmentation mask's values."""
    ground = to_uint8((0.0, *world.appearance.ground_green_uv))
    lut = np.tile(ground, (max([*ground_ids, *object_ids, 0]) + 2, 1))
    for handle, obj in zip(object_ids, world.objects):
        lut[handle] = to_uint8((0.0, *obj.spectral))
    return lut


def render_spectral(cid: int, views: list[View], lut: np.ndarray, culling: ObjectCulling | None = None,
                    floor: tuple[int, float] | None = None,
                    only_objects: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
    """Views in the compound eyes' colouring: for each, its uint8 image (h, w, 3) (G green, B UV) coloured from
    the segmentation mask through ``lut`` (:func:`spectral_lut`), and its sky mask (h, w).

    ``floor``: (body, top z) of a flat world's floor that the caller has hidden (alpha 0): its pixels are drawn
    here from their rays, where a ray meets the plane between ``NEAR_M`` and ``FAR_M`` (as the kinematic
    backend's rays see it) nearer than what TinyRenderer drew, in the floor's colour. TinyRenderer spends most
    of a face's time filling the floor's huge triangles (1.25 of 1.57 ms for an eye's five faces in the open).

    ``culling``: each view shows only the objects it can (:class:`ObjectCulling`); the views are drawn in the
    order that toggles fewest objects between them (:func:`fewest_changes_order`) and returned in their own.

    ``only_objects``: the culled objects are all that TinyRenderer would draw (the floor hidden, no wall, the
    body hidden): a view that shows none of them is all sky, without a call (TinyRenderer's ~65 µs for a
    48 x 48 face of nothing: every face of a read in the open world, the ground-facing ones in a forest).
    """
    order = list(range(len(views)))
    if culling is not None and culling.count:
        # Each view with the objects it can show, in the order that toggles fewest objects between views.
        shown = culling.visible_in(views)
        order = fewest_changes_order(shown, culling.shown)
    drawn: list = [None] * len(views)  # (depth, segmentation) per view
    for v in order:
        view = views[v]
        width, height = int(view.width_px), int(view.height_px)
        if only_objects and not (culling is not None and culling.count and shown[v].any()):
            # What TinyRenderer returns where it draws nothing: the far plane, no body.
            drawn[v] = (np.ones((height, width), np.float32), np.full((height, width), -1, np.int32))
            continue
        if culling is not None and culling.count:
            culling.show(shown[v])
        eye = np.asarray(view.eye_m, float) + EYE_NUDGE_M
        _, _, _, depth, seg = pb.getCameraImage(width, height, view_matrix(eye, np.asarray(view.rotation)),
                                                projection(view.fov_rad[0], view.fov_rad[1], width, height),
                                                shadow=0, renderer=pb.ER_TINY_RENDERER, physicsClientId=cid,
                                                **FLAT_LIGHT)
        drawn[v] = (np.asarray(depth, np.float32).reshape(height, width), np.asarray(seg).reshape(height, width))
    # Coloured together, the views of one size and field (a compound eye's faces): one array operation each.
    groups: dict[tuple, list[int]] = {}
    for v, view in enumerate(views):
        groups.setdefault((int(view.width_px), int(view.height_px), *map(float, view.fov_rad)), []).append(v)
    # Each colour packed in one uint32 (its three bytes and a zero): one gather per pixel, not three.
    packed = np.zeros((len(lut), 4), dtype=np.uint8)
    packed[:, :3] = lut
    colour_of = packed.view(np.uint32).reshape(-1)
    out: list = [None] * len(views)
    for members in groups.values():
        depth = np.stack([drawn[v][0] for v in members])
        image = colour_of[np.clip(np.stack([drawn[v][1] for v in members]), 0, len(lut) - 1)]
        sky = depth >= 1.0
        if floor is not None:
            first = views[members[0]]
            local, back = _floor_rays(int(first.width_px), int(first.height_px), *first.fov_rad)
            world_z = np.array([np.asarray(views[v].rotation, float)[2] for v in members])  # (k, 3)
            down = (world_z @ local.reshape(-1, 3).T).reshape(len(members), *back.shape)  # each ray's world z
            eye_z_m = np.array([float(views[v].eye_m[2]) for v in members])[:, None, None]
            with np.errstate(divide="ignore", invalid="ignore"):
                reach_m = (floor[1] - eye_z_m) / down  # along the ray to the plane
            ground = (down < 0) & (reach_m >= NEAR_M) & (reach_m <= FAR_M)
            ground &= sky | (linear_depth_m(depth) > reach_m * back)  # nearer than what was drawn
            image[ground] = colour_of[floor[0]]
            sky &= ~ground
        rgb = image.view(np.uint8).reshape(*image.shape, 4)[..., :3]
        for k, v in enumerate(members):
            out[v] = (rgb[k], sky[k])
    return out


@lru_cache(maxsize=32)
def _floor_rays(width_px: int, height_px: int, fov_h_rad: float, fov_v_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """A planar view's unit pixel rays (H, W, 3) in its camera frame and their depth per metre along them (H, W)."""
    local = _directions(width_px, height_px, fov_h_rad, fov_v_rad)
    back = -local[..., 2]
    back.setflags(write=False)
    return local, back


def ground_colour(view: View, world: World, on_ground: np.ndarray, depth: np.ndarray,
                  floor_z_m: float | None) -> np.ndarray:
    """The ground's colour (uint8 (n, 3)) where the rays of the ``on_ground`` pixels meet it (the plane
    z = ``floor_z_m``, or, None: a heightfield, as far as the depth buffer says): the plain ground or
    its checker, and the odour trails' floor image where it lies."""
    local = _directions(view.width_px, view.height_px, *view.fov_rad)[on_ground]
    rays = local @ np.asarray(view.rotation, float).T
    eye = np.asarray(view.eye_m, float)
    if floor_z_m is not None:
        down = np.minimum(rays[:, 2], -1e-12)  # a ray at or above the horizon cannot be ground: far away
        reach = (floor_z_m - eye[2]) / down
    else:  # the depth buffer's distance: a few mm off at 20 m (float32 depth, 5 mm near plane)
        reach = linear_depth_m(depth[on_ground]) / np.maximum(-local[:, 2], 1e-12)
    points = eye[:2] + reach[:, None] * rays[:, :2]
    appearance = world.appearance
    if appearance.ground_texture == "checker":
        squares = np.floor(points / appearance.checker_m).sum(axis=1)
        odd = (np.mod(squares, 2.0) == 1.0)[:, None]
        colour = to_uint8(np.where(odd, appearance.checker_rgb, appearance.ground_rgb))
    else:
        colour = np.broadcast_to(to_uint8(appearance.ground_rgb), (len(points), 3)).copy()
    trails = trail_floor(world)
    if trails is not None:
        trail_rgb, inside = trails.rgb_at(points)
        colour[inside] = trail_rgb[inside]
    return colour


def render_follow(cid: int, view: FollowView, world: World) -> np.ndarray:
    """The follow camera's image (lit, for videos), the World's sky painted where nothing was drawn: drawn
    at 1/:data:`FOLLOW_SCALE` of ``view.size_px`` a side and scaled up to it (:func:`upsample2`)."""
    scale = FOLLOW_SCALE if all(side % FOLLOW_SCALE == 0 for side in view.size_px) else 1
    width, height = view.size_px[0] // scale, view.size_px[1] // scale
    forward = (view.target - view.eye) / view.distance_m
    up = np.asarray(view.up, float)
    rotation = np.column_stack([np.cross(forward, up), up, -forward])
    fov_v = math.radians(view.fov_deg)
    fov_h = 2.0 * math.atan(math.tan(fov_v / 2.0) * width / height)  # square pixels
    rgb, depth, _ = _render(cid, view.eye, rotation, width, height, (fov_h, fov_v), {}, segmentation=False)
    sky = depth >= 1.0
    if sky.any():
        rays = _directions(width, height, fov_h, fov_v)[sky] @ rotation.T
        rgb[sky] = to_uint8(sky_rgb(world.appearance, rays))
    return upsample2(rgb) if scale > 1 else rgb


def upsample2(image: np.ndarray) -> np.ndarray:
    """A uint8 image (h, w, ...) at twice its size a side (2h, 2w, ...), bilinear on pixel centres: each new
    pixel is 3/4 of its own old pixel and 1/4 of the next one toward it, in each direction (edges repeated)."""
    a = np.pad(image.astype(np.uint16), ((1, 1), (1, 1)) + ((0, 0),) * (image.ndim - 2), mode="edge")
    h, w = image.shape[:2]
    out = np.empty((h, 2, w, 2, *image.shape[2:]), np.uint8)  # (row, which new row, column, which new column)
    middle = 3 * a[1:-1]
    for k, rows in enumerate((middle + a[:-2], middle + a[2:])):  # 4 x: 3/4 of the row, 1/4 of the one above/below
        centre = 3 * rows[:, 1:-1] + 8  # 16 x the values (at most 4088), rounded below
        out[:, k, :, 0] = (centre + rows[:, :-2]) >> 4
        out[:, k, :, 1] = (centre + rows[:, 2:]) >> 4
    return out.reshape(2 * h, 2 * w, *image.shape[2:])
