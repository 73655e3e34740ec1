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


def spheres_in_view(centres_m: np.ndarray, radii_m: np.ndarray, view: View) -> np.ndarray:
    """Which spheres (n, 3) centres, (n,) radii reach into ``view``'s frustum (between ``NEAR_M`` and
    ``FAR_M``, inside its four sides); a side at or beyond 90° from the axis is not tested."""
    local = (np.asarray(centres_m, float) - view.eye_m) @ view.rotation  # view axes: x right, y up, z backwards
    depth = -local[:, 2]
    inside = (depth + radii_m > NEAR_M) & (depth - radii_m < FAR_M)
    for axis, half_rad in ((0, view.fov_rad[0] / 2.0), (1, view.fov_rad[1] / 2.0)):
        if half_rad < math.pi / 2.0:  # the signed distance to each side plane is at most the radius
            inside &= np.abs(local[:, axis]) * math.cos(half_rad) - depth * math.sin(half_rad) <= radii_m
    return inside


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
    """

    def __init__(self, cid: int, handles: list[int], objects) -> None:
        self._cid, self._handles = cid, list(handles)
        self._positions_m = np.array([obj.position_m for obj in objects], float).reshape(-1, 3)
        self._radii_m = np.array([bounding_radius_m(obj) for obj in objects], float)
        self._rgba = [exact_rgba(obj.rgba) for obj in objects]
        self._hidden = np.zeros(len(self._handles), dtype=bool)
        self.yaw_rad = 0.0  # the scene's turn about the world z axis

    def only_for(self, view: View) -> None:
        """Hide the objects ``view`` cannot show and show the others (only those that change are touched)."""
        if not self._handles:
            return
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        x, y, z = self._positions_m.T
        centres = np.column_stack([c * x - s * y, s * x + c * y, z])
        shown = spheres_in_view(centres, self._radii_m, view)
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
                    floor: tuple[int, float] | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Views in the compound eyes' colouring: for each, its uint8 image (h, w, 3) (G green, B UV) coloured from
    the segmentation mask through ``lut`` (:func:`spectral_lut`), and its sky mask (h, w).

    ``floor``: (body, top z) of a flat world's floor that the caller has hidden (alpha 0): its pixels are drawn
    here from their rays, where a ray meets the plane between ``NEAR_M`` and ``FAR_M`` (as the kinematic
    backend's rays see it) nearer than what TinyRenderer drew, in the floor's colour. TinyRenderer spends most
    of a face's time filling the floor's huge triangles (1.25 of 1.57 ms for an eye's five faces in the open).
    """
    out = []
    for view in views:
        if culling is not None:
            culling.only_for(view)
        width, height = int(view.width_px), int(view.height_px)
        eye = np.asarray(view.eye_m, float) + EYE_NUDGE_M
        _, _, _, depth, seg = pb.getCameraImage(width, height, view_matrix(eye, np.asarray(view.rotation)),
                                                projection(view.fov_rad[0], view.fov_rad[1], width, height),
                                                shadow=0, renderer=pb.ER_TINY_RENDERER, physicsClientId=cid,
                                                **FLAT_LIGHT)
        depth = np.asarray(depth, np.float32).reshape(height, width)
        image, sky = lut[np.clip(np.asarray(seg).reshape(height, width), 0, len(lut) - 1)], depth >= 1.0
        if floor is not None:
            local, back = _floor_rays(width, height, *view.fov_rad)
            down = local @ np.asarray(view.rotation, float)[2]  # each ray's world z
            with np.errstate(divide="ignore", invalid="ignore"):
                reach_m = (floor[1] - float(view.eye_m[2])) / down  # along the ray to the plane
            ground = (down < 0) & (reach_m >= NEAR_M) & (reach_m <= FAR_M)
            ground &= sky | (linear_depth_m(depth) > reach_m * back)  # nearer than what was drawn
            image[ground] = lut[floor[0]]
            sky &= ~ground
        out.append((image, sky))
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
