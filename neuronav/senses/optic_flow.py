"""Ventral optic flow: how far the ground moved under a downward-looking eye patch between two images.

An engine-free odometer input (issue 23, ``odometry=optic_flow``), as Stone et al. 2017's TN cells read
speed from optic flow: a small planar camera looks straight down at the ground; the ground's image moves
opposite to the body, so its global translation between two successive grey images, scaled by how much
ground a pixel covers, is the body's displacement over the interval.

**Image motion** (:func:`image_shift_px`): the global translation ``s = (s_row, s_col)`` (pixels, rows
down, columns right) for which ``current(p) ≈ previous(p − s)``, by gradient-based least squares (Lucas and
Kanade's brightness-constancy equation summed over the whole image): with ``I_r``, ``I_c`` the spatial
derivatives of the mean of both images and ``I_t = current − previous``, ``s`` minimises
``Σ (I_r s_row + I_c s_col + I_t)²``, i.e. ``G s = −b`` with the structure tensor ``G = Σ ∇I ∇Iᵀ`` and
``b = Σ ∇I I_t``. It is refined a few times by shifting the previous image by the estimate (bilinear) and
solving again, so shifts of a few pixels are measured. A direction of ``G`` whose eigenvalue is below
``min_structure`` (grey², summed over the image) has no texture to see motion along: the shift along it
is 0 (the aperture problem: a single edge gives only the motion across it) and a plain image gives no
estimate at all (``None``).

**Ground displacement** (:func:`camera_displacement_m`): a pinhole camera at height ``h`` looking straight
down at flat ground maps it linearly onto its image, one pixel covering ``2 h tan(fov/2) / n_px`` metres
(``fov`` the full field of view across ``n_px`` pixels, per axis). The ground moves opposite to the camera,
so the camera moved ``(−s_col · m_col, +s_row · m_row)`` along its image (right, top) axes: image rows run
top to bottom, against the camera's +y. Tilting the camera or uneven ground breaks this scale, and a turn
about the camera's own axis is not a translation (it averages out about the image centre).
"""

from __future__ import annotations

import numpy as np

from neuronav.errors import ConfigError

# Eigenvalue of the structure tensor (grey², summed over the image) below which a direction counts as
# untextured. A 0.2 grey edge across a 32 px image gives ~0.6; rendering noise on plain ground gives 0.
MIN_STRUCTURE = 1e-3
REFINEMENTS = 3


def _gradients(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Central differences along rows and columns (one-sided at the border), grey per pixel."""
    return np.gradient(image, axis=0), np.gradient(image, axis=1)


def _shifted(image: np.ndarray, shift_px: np.ndarray) -> np.ndarray:
    """``image`` moved by ``shift_px`` (rows, columns), bilinear, the border repeated: ``out(p) = image(p − s)``."""
    h, w = image.shape
    rows = np.clip(np.arange(h)[:, None] - shift_px[0], 0, h - 1) * np.ones((1, w))
    cols = np.clip(np.arange(w)[None, :] - shift_px[1], 0, w - 1) * np.ones((h, 1))
    r0, c0 = np.floor(rows).astype(int), np.floor(cols).astype(int)
    r1, c1 = np.minimum(r0 + 1, h - 1), np.minimum(c0 + 1, w - 1)
    fr, fc = rows - r0, cols - c0
    top = image[r0, c0] * (1 - fc) + image[r0, c1] * fc
    bottom = image[r1, c0] * (1 - fc) + image[r1, c1] * fc
    return top * (1 - fr) + bottom * fr


def image_shift_px(previous, current, min_structure: float = MIN_STRUCTURE,
                   refinements: int = REFINEMENTS) -> np.ndarray | None:
    """The global translation of ``current`` against ``previous`` (grey images of one shape), in pixels.

    Parameters
    ----------
    previous, current : array_like, shape (H, W)
        Grey images (any scale; the renderers' are in [0, 1]).
    min_structure : float
        Structure-tensor eigenvalue (grey², summed over the image) below which a direction has no texture.
    refinements : int
        Solves after the first, each on the previous image shifted by the estimate so far.

    Returns
    -------
    ndarray, shape (2,) or None
        ``(s_row, s_col)``: the image content moved ``s_row`` pixels down and ``s_col`` right; the
        component along an untextured direction is 0. None when no direction has texture (plain ground).
    """
    previous, current = np.asarray(previous, float), np.asarray(current, float)
    if previous.ndim != 2 or previous.shape != current.shape or min(previous.shape) < 3:
        raise ConfigError(f"image_shift_px: expected two grey images of one shape, at least 3 x 3 px, got "
                          f"{previous.shape} and {current.shape}")
    shift = np.zeros(2)
    for _ in range(1 + int(refinements)):
        moved = _shifted(previous, shift) if shift.any() else previous
        g_row, g_col = _gradients(0.5 * (moved + current))
        diff = current - moved
        # Ignore the border (one-sided differences and the repeated edge of the shifted image).
        inner = (slice(1, -1), slice(1, -1))
        g_row, g_col, diff = g_row[inner], g_col[inner], diff[inner]
        tensor = np.array([[np.sum(g_row * g_row), np.sum(g_row * g_col)],
                           [np.sum(g_row * g_col), np.sum(g_col * g_col)]])
        b = np.array([np.sum(g_row * diff), np.sum(g_col * diff)])
        values, vectors = np.linalg.eigh(tensor)
        textured = values > min_structure
        if not textured.any():
            return None if not shift.any() else shift
        # The least-squares step in the textured directions only (pseudo-inverse of G).
        step = sum(-(vectors[:, k] @ b) / values[k] * vectors[:, k] for k in np.nonzero(textured)[0])
        shift = shift + step
        if np.max(np.abs(step)) < 1e-3:
            break
    return shift


def metres_per_pixel(height_m: float, fov_rad, shape_px) -> np.ndarray:
    """Ground covered by one pixel (rows, columns), m, of a camera ``height_m`` above flat ground looking
    straight down: ``2 h tan(fov/2) / n_px`` per axis (``fov_rad`` = (horizontal, vertical), ``shape_px`` =
    (H, W))."""
    fov_h, fov_v = fov_rad
    rows, cols = shape_px
    return np.array([2.0 * height_m * np.tan(fov_v / 2.0) / rows, 2.0 * height_m * np.tan(fov_h / 2.0) / cols])


def camera_displacement_m(shift_px, height_m: float, fov_rad, shape_px) -> np.ndarray:
    """How far a downward camera moved along its own image axes (right, top), m, from the image shift
    ``(s_row, s_col)`` (:func:`image_shift_px`): ``(−s_col · m_col, s_row · m_row)`` (the ground moves opposite)."""
    scale = metres_per_pixel(height_m, fov_rad, shape_px)
    return np.array([-shift_px[1] * scale[1], shift_px[0] * scale[0]])
