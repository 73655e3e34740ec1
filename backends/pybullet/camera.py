"""Cameras in PyBullet: planar views through TinyRenderer and spherical ones stitched from a cube map."""

from __future__ import annotations

import math

import numpy as np

from backends.pybullet.engine import pb
from neuronav.body import Camera
from neuronav.errors import ConfigError

NEAR_M, FAR_M = 0.005, 200.0
EYE_NUDGE_M = np.array([3.1e-7, 1.7e-7, 0.0])

# Cube-map faces in the camera frame (x right, y up, looking along -z): (forward, image up).
CUBE_FACES = (
    ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
    ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, -1.0, 0.0), (0.0, 0.0, -1.0)),
)


def _projection(fov_v_rad: float, aspect: float) -> list[float]:
    """OpenGL projection matrix (column-major, as PyBullet wants it)."""
    f = 1.0 / math.tan(fov_v_rad / 2.0)
    a, b = -(FAR_M + NEAR_M) / (FAR_M - NEAR_M), -2.0 * FAR_M * NEAR_M / (FAR_M - NEAR_M)
    return [f / aspect, 0.0, 0.0, 0.0, 0.0, f, 0.0, 0.0, 0.0, 0.0, a, -1.0, 0.0, 0.0, b, 0.0]


class SphericalLookup:
    """Which cube face and pixel each output pixel of an equirectangular camera samples."""

    def __init__(self, camera: Camera) -> None:
        fov_h, fov_v = camera.fov_rad
        if not (0 < fov_h <= 2 * np.pi and 0 < fov_v <= np.pi):
            raise ConfigError(f"camera {camera.name!r}: a spherical camera needs 0 < fov_h <= 2π and "
                              f"0 < fov_v <= π, got {camera.fov_rad}")
        w, h = camera.width_px, camera.height_px
        azimuth = ((np.arange(w) + 0.5) / w - 0.5) * fov_h
        elevation = (0.5 - (np.arange(h) + 0.5) / h) * fov_v
        az, el = np.meshgrid(azimuth, elevation)
        directions = np.stack([np.cos(el) * np.sin(az), np.sin(el), -np.cos(el) * np.cos(az)], axis=-1)
        forwards = np.array([f for f, _ in CUBE_FACES])
        face = np.argmax(directions @ forwards.T, axis=-1)
        # Face resolution: about the output's angular resolution, at least 8 px.
        step_rad = min(fov_h / w, fov_v / h)
        self.size_px = int(np.clip(math.ceil((np.pi / 2) / step_rad), 8, 512))
        self.row = np.empty((h, w), int)
        self.col = np.empty((h, w), int)
        for k, (forward, up) in enumerate(CUBE_FACES):
            mask = face == k
            if not mask.any():
                continue
            forward, up = np.array(forward), np.array(up)
            right = np.cross(forward, up)
            d = directions[mask]
            depth = d @ forward
            x, y = (d @ right) / depth, (d @ up) / depth
            n = self.size_px
            self.col[mask] = np.clip(((x + 1.0) / 2.0 * n).astype(int), 0, n - 1)
            self.row[mask] = np.clip(((1.0 - y) / 2.0 * n).astype(int), 0, n - 1)
        self.face = face
        self.faces_used = sorted(int(k) for k in np.unique(face))


def render_view(cid: int, eye, forward, up, width: int, height: int, fov_v_rad: float) -> np.ndarray:
    """An RGB image (H, W, 3) uint8 from ``eye`` looking along ``forward`` (TinyRenderer)."""
    # TinyRenderer takes seconds for an eye exactly on a heightfield grid line with an axis-aligned
    # view (e.g. a forward camera after the default reset); a sub-micrometre shift avoids that.
    eye = np.asarray(eye, float) + EYE_NUDGE_M
    view = pb.computeViewMatrix(list(map(float, eye)), list(map(float, np.asarray(eye) + forward)),
                                list(map(float, up)), physicsClientId=cid)
    _, _, rgb, _, _ = pb.getCameraImage(int(width), int(height), view, _projection(fov_v_rad, width / height),
                                        shadow=0, renderer=pb.ER_TINY_RENDERER,
                                        flags=pb.ER_NO_SEGMENTATION_MASK, physicsClientId=cid)
    return np.asarray(rgb, np.uint8).reshape(int(height), int(width), 4)[:, :, :3].copy()


def render_camera(cid: int, spec: Camera, eye: np.ndarray, rotation: np.ndarray,
                  lookup: SphericalLookup | None = None) -> np.ndarray:
    """A body camera's image: ``spec`` at ``eye`` (3,) with the world ``rotation`` (3, 3) of its frame.

    A planar camera renders directly; a spherical one (``lookup`` given) renders the cube faces it
    needs and samples them into its equirectangular image.
    """
    if spec.projection == "planar":
        return render_view(cid, eye, rotation @ np.array([0.0, 0.0, -1.0]), rotation @ np.array([0.0, 1.0, 0.0]),
                           spec.width_px, spec.height_px, spec.fov_rad[1])
    faces = np.zeros((len(CUBE_FACES), lookup.size_px, lookup.size_px, 3), np.uint8)
    for k in lookup.faces_used:
        forward, up = (np.array(v) for v in CUBE_FACES[k])
        faces[k] = render_view(cid, eye, rotation @ forward, rotation @ up, lookup.size_px, lookup.size_px, np.pi / 2)
    return faces[lookup.face, lookup.row, lookup.col]
