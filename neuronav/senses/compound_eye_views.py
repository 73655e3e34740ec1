"""Compound eyes read from rendered views: how the physics backends (MuJoCo, PyBullet) read them.

An eye (:class:`~neuronav.spec.body.CompoundEye`) is read from the 90° cube faces of a cube about the eye's
frame that its ommatidia reach (:class:`EyeViews`: usually five of six), rendered flat in the world's
green-and-UV colouring (:func:`neuronav.senses.compound_eye.spectral_world`: G the green value, B the UV one),
with the World's ``sky_green_uv`` where nothing was hit. The face pixels' directions and solid angles in the
eye's frame are fixed, so the eye's :func:`~neuronav.senses.compound_eye.sampling_matrix` (Gaussian weights
times solid angle, rows summing to 1) is built once per eye and a read is one sparse product (M, P) x (P, 2).

Resolution: a face pixel at a face's centre spans at most ``FWHM / PIXELS_PER_FWHM`` of the eye's narrowest
acceptance angle (48 px per face, 2.4°, for the ant's 3.7°), at least ``MIN_FACE_PX``, and the side is even (no
pixel row centred on a level eye's horizon). The engines render all the views of one read in one call
(MuJoCo: one scene update per face, of the objects it can show, and one buffer read for both eyes).
Agreement with the kinematic backend's rays (:mod:`neuronav.senses.compound_eye_rays`):
``tests/cross_backend/test_compound_eye_agreement.py``.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from neuronav.senses.compound_eye import sampling_matrix
from neuronav.senses.vision import CUBE_FACE_ROTATIONS, View, pixel_directions
from neuronav.spec.body import Camera, CompoundEye

# A face pixel at the face's centre spans the narrowest acceptance angle (FWHM) over this.
PIXELS_PER_FWHM = 1.5
MIN_FACE_PX, MAX_FACE_PX = 8, 256
# The eye's frame (+x forward, +y left, +z up) to a camera's (x right, y up, looking along -z): columns are
# the camera's axes in the eye's frame.
EYE_TO_CAMERA = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
FACE_FOV_RAD = (math.pi / 2.0, math.pi / 2.0)


def face_px(eye: CompoundEye) -> int:
    """The side (px) of the square cube faces an eye is read from (see the module doc): even, so that no row
    of pixels is centred on a level eye's horizon (a pixel there would show the sky or the ground for all of
    its height)."""
    step_rad = float(eye.acceptance_rad.min()) / PIXELS_PER_FWHM
    n = math.ceil(2.0 / step_rad)  # the face's image plane spans 2 (tan 45° each side) at distance 1
    return int(np.clip(n + n % 2, MIN_FACE_PX, MAX_FACE_PX))


class EyeViews:
    """The cube faces one compound eye is read from, and its sampling matrix over their pixels.

    Attributes
    ----------
    eye : CompoundEye
    face_px : int
        Side of each face image (90° by 90°).
    faces : tuple of int
        The faces (indices into :data:`neuronav.senses.vision.CUBE_FACE_ROTATIONS`, taken in the eye's
        frame turned to a camera's) that some ommatidium's acceptance reaches, in render order.
    matrix : scipy.sparse.csr_matrix, shape (M, P)
        P = len(faces) * face_px², the faces' pixels row by row, face after face.
    """

    def __init__(self, eye: CompoundEye) -> None:
        self.eye = eye
        n = self.face_px = face_px(eye)
        face = Camera("face", "face", (0.0, 0.0, 0.0), width_px=n, height_px=n, fov_rad=FACE_FOV_RAD)
        local = pixel_directions(face).reshape(-1, 3)  # face camera frame
        solid_sr = (2.0 / n) ** 2 * (-local[:, 2]) ** 3  # a pixel of the image plane at distance 1, seen askew
        directions = np.concatenate([local @ (EYE_TO_CAMERA @ rotation).T for rotation in CUBE_FACE_ROTATIONS])
        whole = sampling_matrix(eye, directions, np.tile(solid_sr, len(CUBE_FACE_ROTATIONS))).tocsc()
        used = np.diff(whole.indptr).reshape(len(CUBE_FACE_ROTATIONS), -1).any(axis=1)
        self.faces = tuple(int(k) for k in np.flatnonzero(used))
        columns = np.concatenate([np.arange(k * n * n, (k + 1) * n * n) for k in self.faces])
        self.matrix = whole[:, columns].tocsr()
        self._rotations = np.array([EYE_TO_CAMERA @ CUBE_FACE_ROTATIONS[k] for k in self.faces])

    def views(self, eye_m, rotation) -> list[View]:
        """The planar renders of this eye at ``eye_m`` (3,) with frame axes ``rotation`` (3, 3) (columns: the
        eye's forward, left and up in world coordinates)."""
        eye_m, rotation = np.asarray(eye_m, float), np.asarray(rotation, float)
        return [View(eye_m, rotation @ face, self.face_px, self.face_px, FACE_FOV_RAD) for face in self._rotations]

    def values(self, rendered: list[tuple[np.ndarray, np.ndarray]], sky_green_uv) -> np.ndarray:
        """The ommatidia (M, 2), green and UV in [0, 1], from the faces rendered in the spectral colouring:
        for each view of :meth:`views`, its uint8 image (n, n, 3) (G green, B UV) and sky mask (n, n)."""
        images = np.stack([image for image, _ in rendered]).reshape(-1, 3)
        sky = np.concatenate([mask.reshape(-1) for _, mask in rendered])
        values = np.empty((self.matrix.shape[0], 2))
        # Channel by channel: two sparse matrix-vector products cost half of one product with a (P, 2) array.
        for channel in (0, 1):
            pixels = images[:, 1 + channel] * (1.0 / 255.0)
            np.copyto(pixels, sky_green_uv[channel], where=sky)
            values[:, channel] = self.matrix @ pixels
        return values


@lru_cache(maxsize=16)
def eye_views(eye: CompoundEye) -> EyeViews:
    """:class:`EyeViews` of ``eye``, built once per eye (equal eyes share it) and kept."""
    return EyeViews(eye)
