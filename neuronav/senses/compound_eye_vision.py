"""Early-vision adapters for compound eyes: ommatidium values laid out as the images early vision reads.

A compound eye's read is (M, 2), green and UV per ommatidium (:mod:`neuronav.senses.compound_eye`). The
beacon's dark-landmark detector and the Zernike compass (:mod:`neuronav.brains.vision`) take grey images on a
regular grid; :class:`OmmatidiaImage` resamples one channel of one or more eyes onto such a grid, laid out
from the ommatidia's own directions, in one sparse product per read (batched over agents).

**The grid**: cells on an azimuth x elevation grid in the eyes' common frame (+x forward, +y left, +z up;
the desert ant's two eyes share one frame, levelled, :func:`neuronav.bodies.desert_ant.desert_ant`), azimuth
clockwise from forward increasing along the columns (to the right), elevation decreasing down the rows.

**A cell's value**: the Gaussian-weighted mean of its ``neighbours`` nearest ommatidia (σ the ommatidia's
acceptance σ, FWHM / 2.355; the nearest one always weighs 1, so a cell far from every ommatidium takes its
nearest). A cell farther than ``max_gap_rad`` from every ommatidium lies outside the eyes' field: it takes
``outside`` (a number), or its nearest ommatidium when ``outside`` is None.

Two layouts:

- :func:`panorama_grid`: the whole sphere as the ant's panoramic camera lays it out (72 x 72, 5° per column,
  2.5° per row, column 0 straight back, the zenith on top), so the same :class:`~neuronav.brains.vision.ZernikeBasis`
  reads it; the eyes' blind sector behind and the cap above 80° take their nearest ommatidium.
- :func:`eye_grid`: one camera eye's field (74 x 19 over 2 x 0.5 rad, centred ±30° to the side at the
  horizon), so :func:`~neuronav.brains.vision.beacon_shift` reads it unchanged; the cells beyond the eye's
  own field take ``outside`` = 1 (bright: never the dark landmark).
"""

from __future__ import annotations

import math

import numpy as np

from neuronav.errors import ConfigError, PortError
from neuronav.spec.body import CompoundEye

CHANNELS = ("green", "uv")
# The camera layouts reproduced (bodies/desert_ant/body.py): the panorama, and a binocular camera eye.
PANORAMA_SHAPE_PX = (72, 72)
CAMERA_EYE_SHAPE_PX = (19, 74)
CAMERA_EYE_FOV_RAD = (2.0, 0.5)
CAMERA_EYE_AZIMUTH_DEG = 30.0


def panorama_grid(height_px: int = PANORAMA_SHAPE_PX[0], width_px: int = PANORAMA_SHAPE_PX[1]) -> np.ndarray:
    """Unit directions (H, W, 3) of an equirectangular panorama: columns from straight back clockwise
    through forward (the middle) to straight back, rows from the zenith to the nadir."""
    azimuth = ((np.arange(width_px) + 0.5) / width_px - 0.5) * 2.0 * np.pi
    elevation = np.pi / 2.0 - (np.arange(height_px) + 0.5) * np.pi / height_px
    return _directions(azimuth, elevation)


def eye_grid(side: str, height_px: int = CAMERA_EYE_SHAPE_PX[0], width_px: int = CAMERA_EYE_SHAPE_PX[1],
             fov_rad=CAMERA_EYE_FOV_RAD, azimuth_deg: float = CAMERA_EYE_AZIMUTH_DEG) -> np.ndarray:
    """Unit directions (H, W, 3) of an azimuth x elevation image of ``fov_rad`` (horizontal, vertical)
    centred on the horizon ``azimuth_deg`` to the ``side`` (``L`` or ``R``), as the camera eye of that side."""
    if side not in ("L", "R"):
        raise ConfigError(f"eye_grid: side must be 'L' or 'R', got {side!r}")
    centre = math.radians(azimuth_deg) * (-1.0 if side == "L" else 1.0)  # clockwise: the left is negative
    azimuth = centre + ((np.arange(width_px) + 0.5) / width_px - 0.5) * fov_rad[0]
    elevation = ((height_px - np.arange(height_px) - 0.5) / height_px - 0.5) * fov_rad[1]
    return _directions(azimuth, elevation)


def _directions(azimuth_cw_rad: np.ndarray, elevation_rad: np.ndarray) -> np.ndarray:
    az, el = np.meshgrid(azimuth_cw_rad, elevation_rad)
    return np.stack([np.cos(az) * np.cos(el), -np.sin(az) * np.cos(el), np.sin(el)], axis=-1)


class OmmatidiaImage:
    """One channel of compound eyes resampled onto an image grid (see the module doc).

    Parameters
    ----------
    eyes : sequence of CompoundEye
        The eyes read together, in the order their values are given; they must share one orientation.
    grid : ndarray, shape (H, W, 3)
        The cells' directions in the eyes' frame (:func:`panorama_grid`, :func:`eye_grid`).
    channel : str
        ``green`` or ``uv``.
    outside : float or None
        The value of cells beyond ``max_gap_rad`` from every ommatidium; None: their nearest ommatidium's.
    neighbours : int
        Ommatidia blended per cell (>= 1).
    max_gap_rad : float, optional
        Default: twice the largest acceptance angle (FWHM).
    """

    def __init__(self, eyes, grid, channel: str = "green", outside: float | None = None, neighbours: int = 4,
                 max_gap_rad: float | None = None) -> None:
        from scipy import sparse
        from scipy.spatial import cKDTree

        eyes = tuple(eyes) if isinstance(eyes, list | tuple) else ()
        if not eyes or not all(isinstance(e, CompoundEye) for e in eyes):
            raise ConfigError("OmmatidiaImage: eyes must be a non-empty sequence of CompoundEye")
        if any(not np.allclose(e.quat, eyes[0].quat) for e in eyes):
            raise ConfigError(f"OmmatidiaImage: the eyes {[e.name for e in eyes]} must share one orientation (quat)")
        if channel not in CHANNELS:
            raise ConfigError(f"OmmatidiaImage: channel must be one of {', '.join(CHANNELS)}, got {channel!r}")
        grid = np.asarray(grid, dtype=float)
        if grid.ndim != 3 or grid.shape[2] != 3 or min(grid.shape) < 1 or not np.isfinite(grid).all():
            raise ConfigError(f"OmmatidiaImage: grid must be finite directions (H, W, 3), got shape {grid.shape}")
        if isinstance(neighbours, bool) or not isinstance(neighbours, int | np.integer) or neighbours < 1:
            raise ConfigError(f"OmmatidiaImage: neighbours must be an int >= 1, got {neighbours!r}")
        if outside is not None and not (isinstance(outside, int | float) and math.isfinite(outside)):
            raise ConfigError(f"OmmatidiaImage: outside must be a finite number or None, got {outside!r}")
        self.eyes, self.channel, self.shape = eyes, CHANNELS.index(channel), grid.shape[:2]
        self.counts = tuple(e.n_ommatidia for e in eyes)
        axes = np.concatenate([e.directions for e in eyes])
        acceptance = np.concatenate([e.acceptance_rad for e in eyes])
        gap = 2.0 * float(acceptance.max()) if max_gap_rad is None else float(max_gap_rad)
        if not gap > 0:
            raise ConfigError(f"OmmatidiaImage: max_gap_rad must be > 0, got {max_gap_rad!r}")
        cells = grid.reshape(-1, 3) / np.linalg.norm(grid.reshape(-1, 3), axis=1, keepdims=True)
        k = min(int(neighbours), axes.shape[0])
        chord, index = cKDTree(axes).query(cells, k=k)
        chord, index = chord.reshape(len(cells), k), index.reshape(len(cells), k)
        angle = 2.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))
        sigma = acceptance[index] * 0.4246609  # FWHM -> sigma
        weights = np.exp(-(angle ** 2 - angle[:, :1] ** 2) / (2.0 * sigma ** 2))  # the nearest weighs 1
        self.outside_cells = angle[:, 0] > gap
        if outside is not None:
            weights[self.outside_cells] = 0.0
        weights /= np.maximum(weights.sum(axis=1, keepdims=True), 1e-300)
        rows = np.repeat(np.arange(len(cells)), k)
        self.matrix = sparse.csr_matrix((weights.ravel(), (rows, index.ravel())), shape=(len(cells), axes.shape[0]))
        self.fill = np.where(self.outside_cells, 0.0 if outside is None else float(outside), 0.0)

    def __call__(self, *reads) -> np.ndarray:
        """The images (N, H, W) from each eye's read, (M, 2) or (N, M, 2), in the order of ``eyes``."""
        if len(reads) != len(self.eyes):
            raise PortError(f"OmmatidiaImage: needs {len(self.eyes)} reads (one per eye), got {len(reads)}")
        values = []
        for eye, count, read in zip(self.eyes, self.counts, reads):
            array = np.asarray(read, dtype=float)
            array = array[None] if array.ndim == 2 else array
            if array.ndim != 3 or array.shape[1:] != (count, 2):
                raise PortError(f"OmmatidiaImage: {eye.name} read must be ({count}, 2) or (N, {count}, 2), "
                                f"got {np.shape(read)}")
            values.append(array[:, :, self.channel])
        stacked = np.concatenate(values, axis=1)  # (N, M)
        images = (self.matrix @ stacked.T).T + self.fill
        return images.reshape(stacked.shape[0], *self.shape)


def compass_panorama(eyes, channel: str = "uv") -> OmmatidiaImage:
    """Both eyes on the panoramic camera's grid (:func:`panorama_grid`), for the Zernike compass."""
    return OmmatidiaImage(eyes, panorama_grid(), channel)


def beacon_eye_image(eye: CompoundEye, side: str, channel: str = "green") -> OmmatidiaImage:
    """One eye on its camera eye's grid (:func:`eye_grid`), for the beacon's dark-landmark detector;
    cells beyond the eye's field are bright (1)."""
    return OmmatidiaImage((eye,), eye_grid(side), channel, outside=1.0)
