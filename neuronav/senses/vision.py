"""Cameras as every backend sees them: one pixel-to-ray rule, one sky, one grey scale.

Every backend's body cameras (:class:`neuronav.spec.body.Camera`) follow the rules of this module, so a
landmark lands in the same image column on MuJoCo, PyBullet and the kinematic ray caster:

- **Frames.** A camera frame has x to the image's right, y to its top, and looks along -z
  (MuJoCo's convention). ``rotation`` (3, 3) holds those axes as columns, in world coordinates.
- **Planar** cameras are pinholes with independent horizontal and vertical fields of view
  ``fov_rad = (h, v)`` (full angles; pixels need not be square): pixel (row r, column c) looks along
  ``(tan(h/2) (2 (c + 0.5)/W - 1), tan(v/2) (1 - 2 (r + 0.5)/H), -1)``.
- **Spherical** cameras are equirectangular: column c looks at azimuth
  ``((c + 0.5)/W - 0.5) h`` (positive to the right, i.e. clockwise seen from above for a level
  camera), row r at elevation ``(0.5 - (r + 0.5)/H) v``. With ``fov_rad = (2π, π)`` the image is
  the whole sphere and a turn of the camera about its up axis by one column's angle rolls the
  image by exactly one column. Engines render a spherical camera as cube faces
  (:func:`cube_lookup`, nearest face pixel); the ray caster casts its rays directly.
- **Flat shading.** A body camera sees each surface in its declared colour (no lights, shadows or
  specular highlights), so the same world gives the same pixels on every engine.
- **Sky.** Where no surface is hit, the pixel shows :func:`sky_rgb` of its direction: the
  World's :class:`~neuronav.spec.world.Appearance` (a plain colour or a gradient in elevation), computed
  here, not by an engine.
- **Supersampling.** A camera with ``supersample`` k renders (or casts) k × k samples per pixel on
  the same rules (:func:`sampling_camera`: the camera at k times the resolution) and averages them
  (:func:`average_samples`); the sky is painted per sample.
- **Grey.** A camera read as a sensor is its image in grey, float in [0, 1] (:func:`grey`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from neuronav.errors import ConfigError
from neuronav.spec.body import Camera

# Body cameras see surfaces from NEAR_M to FAR_M; the ground reaches at least GROUND_REACH_M from
# the origin in their renders on every engine (a ray a little below the horizon hits it far away).
NEAR_M, FAR_M = 0.005, 1000.0
GROUND_REACH_M = 500.0

# ITU-R BT.601 luma weights: the grey a camera sensor reports.
LUMA_WEIGHTS = np.array([0.299, 0.587, 0.114])

# Cube faces in a camera's frame, as rotations whose columns are the face camera's (x, y, z) axes:
# front (looking along -z), left, back, right, up, down.
_FACE_AXES = (
    ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
    ((-1, 0, 0), (0, 1, 0), (0, 0, -1)),
    ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
    ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
)
CUBE_FACE_ROTATIONS = np.array([np.column_stack(axes) for axes in _FACE_AXES], dtype=float)


def check_camera(camera: Camera) -> None:
    """Refuse fields of view no camera model of this module can render, and supersampling outside 1..8."""
    if isinstance(camera.supersample, bool) or camera.supersample not in range(1, 9):
        raise ConfigError(f"camera {camera.name!r}: supersample must be an int in 1..8, got {camera.supersample!r}")
    h, v = camera.fov_rad
    if camera.projection == "planar" and not (0 < h < np.pi and 0 < v < np.pi):
        raise ConfigError(f"camera {camera.name!r}: a planar camera needs 0 < fov < π in both directions, "
                          f"got {camera.fov_rad}")
    if camera.projection == "spherical" and not (0 < h <= 2 * np.pi and 0 < v <= np.pi):
        raise ConfigError(f"camera {camera.name!r}: a spherical camera needs 0 < fov_h <= 2π and 0 < fov_v <= π, "
                          f"got {camera.fov_rad}")


def pixel_directions(camera: Camera) -> np.ndarray:
    """Unit ray direction of every pixel in the camera's frame, shape (H, W, 3) (see the module doc).

    Computed once per camera and kept (read-only): every frame of a camera uses the same rays.
    """
    return _pixel_directions(camera)


@lru_cache(maxsize=64)
def _pixel_directions(camera: Camera) -> np.ndarray:
    directions = _directions(camera)
    directions.setflags(write=False)
    return directions


def _directions(camera: Camera) -> np.ndarray:
    check_camera(camera)
    w, h = camera.width_px, camera.height_px
    fov_h, fov_v = camera.fov_rad
    u = (np.arange(w) + 0.5) / w  # 0..1 left to right
    t = (np.arange(h) + 0.5) / h  # 0..1 top to bottom
    if camera.projection == "planar":
        x = np.tan(fov_h / 2.0) * (2.0 * u - 1.0)
        y = np.tan(fov_v / 2.0) * (1.0 - 2.0 * t)
        xx, yy = np.meshgrid(x, y)
        directions = np.stack([xx, yy, -np.ones_like(xx)], axis=-1)
        return directions / np.linalg.norm(directions, axis=-1, keepdims=True)
    azimuth, elevation = np.meshgrid((u - 0.5) * fov_h, (0.5 - t) * fov_v)
    return np.stack([np.cos(elevation) * np.sin(azimuth), np.sin(elevation),
                     -np.cos(elevation) * np.cos(azimuth)], axis=-1)


def sampling_camera(camera: Camera) -> Camera:
    """The camera whose pixels are ``camera``'s samples: ``supersample`` times the width and height, one
    sample per pixel (``camera`` itself when it takes one sample per pixel)."""
    k = camera.supersample
    if k == 1:
        return camera
    return replace(camera, width_px=camera.width_px * k, height_px=camera.height_px * k, supersample=1)


def average_samples(samples: np.ndarray, k: int) -> np.ndarray:
    """A (H·k, W·k, ...) image of samples as the (H, W, ...) image of their k × k means (uint8 in, uint8 out)."""
    if k == 1:
        return samples
    h, w = samples.shape[0] // k, samples.shape[1] // k
    means = samples.reshape(h, k, w, k, *samples.shape[2:]).mean(axis=(1, 3))
    return np.rint(means).astype(np.uint8) if samples.dtype == np.uint8 else means


@dataclass(frozen=True)
class View:
    """One planar render an engine is asked for: a pinhole at ``eye_m`` with frame ``rotation``.

    Attributes
    ----------
    eye_m : ndarray, shape (3,)
    rotation : ndarray, shape (3, 3)
        Columns: the camera's x (right), y (up), z (it looks along -z), world coordinates.
    width_px, height_px : int
    fov_rad : (float, float)
        Full horizontal and vertical fields of view.
    """

    eye_m: np.ndarray
    rotation: np.ndarray
    width_px: int
    height_px: int
    fov_rad: tuple[float, float]


@dataclass(frozen=True)
class CubeLookup:
    """Which cube face, row and column each pixel of a spherical camera shows (nearest neighbour).

    Attributes
    ----------
    face_px : int
        Side of each square face image (90° by 90°).
    faces : tuple of int
        The faces the camera's field of view needs (indices into :data:`CUBE_FACE_ROTATIONS`).
    face, row, col : ndarray of int, shape (H, W)
    slot : ndarray of int, shape (H, W)
        Each pixel's face as its position in ``faces`` (the order the faces are rendered in).
    """

    face_px: int
    faces: tuple[int, ...]
    face: np.ndarray
    row: np.ndarray
    col: np.ndarray
    slot: np.ndarray


def cube_face_px(camera: Camera) -> int:
    """The side of a spherical camera's cube faces (see :func:`cube_lookup`), without building the lookup."""
    sampled = sampling_camera(camera)
    step_rad = min(sampled.fov_rad[0] / sampled.width_px, sampled.fov_rad[1] / sampled.height_px)
    return int(np.clip(np.ceil((np.pi / 2.0) / step_rad), 8, 1024))


@lru_cache(maxsize=64)
def cube_lookup(camera: Camera) -> CubeLookup:
    """How to sample a spherical camera's image from 90° cube faces rendered at its pose.

    The face resolution matches the finest angular step of the camera's samples (one face pixel per
    sample at the face centre, at least 8), so a face costs no more pixels than the image needs.
    The lookup is per sample: shape (H·k, W·k) for ``supersample`` k. Built once per camera and kept.
    """
    camera = sampling_camera(camera)
    directions = pixel_directions(camera)
    # Each direction in each face's frame: that face sees it when its -z component is the largest.
    local = np.einsum("fji,hwj->hwfi", CUBE_FACE_ROTATIONS, directions)
    face = np.argmax(-local[..., 2], axis=-1)
    chosen = np.take_along_axis(local, face[..., None, None], axis=2)[..., 0, :]
    depth = -chosen[..., 2]
    x, y = chosen[..., 0] / depth, chosen[..., 1] / depth  # in [-1, 1] on the face's image plane
    face_px = cube_face_px(camera)
    col = np.clip(((x + 1.0) / 2.0 * face_px).astype(int), 0, face_px - 1)
    row = np.clip(((1.0 - y) / 2.0 * face_px).astype(int), 0, face_px - 1)
    faces = np.unique(face)
    return CubeLookup(face_px, tuple(int(k) for k in faces), face, row, col, np.searchsorted(faces, face))


def camera_views(camera: Camera, eye_m: np.ndarray, rotation: np.ndarray,
                 lookup: CubeLookup | None = None) -> list[View]:
    """The planar renders that make ``camera``'s image at this pose: itself, or its cube faces."""
    eye_m, rotation = np.asarray(eye_m, float), np.asarray(rotation, float)
    if camera.projection == "planar":
        sampled = sampling_camera(camera)
        return [View(eye_m, rotation, sampled.width_px, sampled.height_px, tuple(camera.fov_rad))]
    lookup = lookup if lookup is not None else cube_lookup(camera)
    return [View(eye_m, rotation @ CUBE_FACE_ROTATIONS[k], lookup.face_px, lookup.face_px, (np.pi / 2, np.pi / 2))
            for k in lookup.faces]


def sky_rgb(appearance, directions_world: np.ndarray) -> np.ndarray:
    """The sky's colour (float RGB in [0, 1], shape (..., 3)) seen along unit world directions (..., 3).

    A plain sky is ``appearance.sky_rgb`` everywhere. With ``appearance.horizon_rgb`` set, the colour
    runs from ``horizon_rgb`` at and below the horizon to ``sky_rgb`` at the zenith, linear in the
    sine of the elevation.
    """
    directions_world = np.asarray(directions_world, float)
    top = np.asarray(appearance.sky_rgb, float)
    if appearance.horizon_rgb is None:
        return np.broadcast_to(top, (*directions_world.shape[:-1], 3)).copy()
    horizon = np.asarray(appearance.horizon_rgb, float)
    weight = np.clip(directions_world[..., 2], 0.0, 1.0)[..., None]
    return horizon + weight * (top - horizon)


def compose_image(camera: Camera, rotation: np.ndarray, rendered: list[tuple[np.ndarray, np.ndarray]],
                  appearance, lookup: CubeLookup | None = None) -> np.ndarray:
    """A camera's uint8 RGB image (H, W, 3) from its views' renders, with the sky filled in here.

    Parameters
    ----------
    camera : Camera
    rotation : ndarray, shape (3, 3)
        The camera frame's axes in the world (as in :class:`View`).
    rendered : list of (rgb, sky)
        For each view of :func:`camera_views`, in order: its uint8 image (h, w, 3) and a bool mask
        (h, w) of the pixels where nothing was hit.
    appearance : neuronav.spec.world.Appearance
    lookup : CubeLookup, optional
        The spherical camera's lookup (computed when not given).
    """
    if camera.projection == "planar":
        rgb, sky = rendered[0]
    else:
        lookup = lookup if lookup is not None else cube_lookup(camera)
        rgbs = np.stack([r for r, _ in rendered])
        skies = np.stack([s for _, s in rendered])
        rgb, sky = rgbs[lookup.slot, lookup.row, lookup.col], skies[lookup.slot, lookup.row, lookup.col]
    image = np.array(rgb, dtype=np.uint8, copy=True)
    if sky.any():
        directions = pixel_directions(sampling_camera(camera))[sky] @ np.asarray(rotation, float).T
        image[sky] = to_uint8(sky_rgb(appearance, directions))
    return average_samples(image, camera.supersample)


def to_uint8(rgb: np.ndarray) -> np.ndarray:
    """Float colours in [0, 1] as uint8 (rounded)."""
    return np.clip(np.rint(np.asarray(rgb, float) * 255.0), 0, 255).astype(np.uint8)


def grey(rgb: np.ndarray) -> np.ndarray:
    """A uint8 (or float in [0, 1]) RGB image (..., 3) as grey in [0, 1] (BT.601 luma)."""
    rgb = np.asarray(rgb)
    scale = 255.0 if rgb.dtype == np.uint8 else 1.0
    return (rgb.astype(float) @ LUMA_WEIGHTS) / scale
