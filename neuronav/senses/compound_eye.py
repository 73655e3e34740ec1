"""Compound eyes: the desert ant's ommatidia as data, the world in green and UV, and reading the eyes.

**The eye** (:func:`cataglyphis_eye`): 1287 ommatidia per eye at ``ommatidia_scale`` 1, laid out
after the published description of the *Cataglyphis* worker eye (Zollikofer et al. 1995; every number and
its source in docs/parameters.md, section 12). In the eye's frame (the head convention of
:mod:`neuronav.senses.dorsal_rim`: +x forward, +y left, +z up; azimuths clockwise from forward):

- rows of ommatidia within elevations -50° to +80°, symmetric about the equator (the first at ±1°), the
  vertical spacing 2° on the equator widening linearly to 6° at ±60° (the "visual stretch": a band of
  higher vertical acuity viewing the horizon), each row sampled every 4.05° of arc along the row
  (azimuth step 4.05° / cos(elevation));
- each eye sees 180° of azimuth, from 10° across the midline (a 20° binocular overlap in front) to
  170° on its own side (a 20° blind sector behind); the left eye is the right one mirrored (y -> -y);
- every ommatidium a Gaussian angular sensitivity of full width at half maximum 3.7°, reading two
  receptor types, green and UV;
- ``ommatidia_scale`` s multiplies the count and divides every angle (spacings and acceptance) by √s,
  as the eyes of larger and smaller conspecific workers differ (Zollikofer et al. 1995: the visual field
  stays, the ommatidia and their angles scale reciprocally).

**The world in green and UV**: the World's :class:`~neuronav.spec.world.Appearance` gives the sky's and the
ground's values per channel, each :class:`~neuronav.spec.world.WorldObject` its own (``spectral``; vegetation
by default); :func:`spectral_world` draws them as colours (green in G, UV in B) so that any renderer
that draws a World (MuJoCo, PyBullet, the ray caster) renders both channels in one pass.

**Reading an eye**: an ommatidium's value per channel is the acceptance-weighted mean of the scene
around its axis.

- From rendered views: :func:`sampling_matrix` (M, P) maps P rendered pixels (directions and solid angles
  in the eye's frame) to the M ommatidia in one sparse product: Gaussian weights times solid angle,
  truncated at ``truncate_fwhm`` acceptance widths, rows summing to 1.
- By rays (the kinematic backend): :mod:`neuronav.senses.compound_eye_rays` casts 7 rays per ommatidium,
  batched over agents.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np

from neuronav.errors import ConfigError, real_or_nan
from neuronav.spec.body import IDENTITY_QUAT, OMMATIDIUM_CHANNELS, CompoundEye
from neuronav.spec.odour_scene import OdourScene
from neuronav.spec.world import World

# The layout at ommatidia_scale 1 (docs/parameters.md, section 12).
HORIZONTAL_SPACING_DEG = 4.05
VERTICAL_SPACING_EQUATOR_DEG = 2.0
VERTICAL_SPACING_60_DEG = 6.0
ELEVATION_RANGE_DEG = (-50.0, 80.0)
AZIMUTH_RANGE_DEG = (-10.0, 170.0)
ACCEPTANCE_DEG = 3.7
SCALE_RANGE = (0.01, 4.0)
SIDES = ("L", "R")
# Gaussian: sigma = FWHM / (2 sqrt(2 ln 2)).
FWHM_TO_SIGMA = 1.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))
RAY_PATTERNS = (1, 7)
# Ray readers (neuronav.senses.compound_eye_rays): rays per ommatidium allowed, and the tiles of ommatidia
# tested together against an object's bounding sphere (bins this wide in the eye's azimuth and elevation).
TILE_DEG = 12.0


def check_scale(ommatidia_scale) -> float:
    """``ommatidia_scale`` as a float in :data:`SCALE_RANGE`, or a ConfigError."""
    scale = real_or_nan(ommatidia_scale)
    if not SCALE_RANGE[0] <= scale <= SCALE_RANGE[1]:
        raise ConfigError(f"compound eye ommatidia_scale must be a number in [{SCALE_RANGE[0]}, {SCALE_RANGE[1]}] "
                          f"(1: the ant's 1287 ommatidia per eye), got {ommatidia_scale!r}")
    return float(scale)


def _rows_rad(scale: float) -> np.ndarray:
    """Row elevations: from the equator up and down, each step the vertical spacing at its midpoint."""
    k = 1.0 / math.sqrt(scale)
    equator, at_60 = math.radians(VERTICAL_SPACING_EQUATOR_DEG) * k, math.radians(VERTICAL_SPACING_60_DEG) * k
    low, high = (math.radians(v) for v in ELEVATION_RANGE_DEG)

    def spacing(elevation: float) -> float:
        return equator + (at_60 - equator) * abs(elevation) / math.radians(60.0)

    # Symmetric about the equator, no row on it: the first rows half the equatorial spacing above and below
    # (a row on the horizon would put the level agents' axes on the ground's edge).
    rows = []
    for sign, limit in ((1.0, high), (-1.0, low)):
        elevation = sign * equator / 2.0
        while sign * elevation <= sign * limit:
            rows.append(elevation)
            elevation += sign * spacing(elevation + sign * spacing(elevation) / 2.0)
    return np.sort(np.array(rows))


@lru_cache(maxsize=32)
def cataglyphis_ommatidia(side: str, ommatidia_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """One *Cataglyphis* eye's ommatidia (see the module doc): unit directions (M, 3) in the eye's frame
    and acceptance angles (M,) rad (FWHM), rows from the lowest up, each from the front backwards.

    Parameters
    ----------
    side : str
        ``L`` (looks to +y) or ``R`` (to -y); the left eye is the right one with y negated.
    ommatidia_scale : float
        Multiplies the count (1287 at 1), in :data:`SCALE_RANGE`.

    Returns
    -------
    directions, acceptance_rad : read-only ndarrays
    """
    if side not in SIDES:
        raise ConfigError(f"compound eye side must be one of {SIDES}, got {side!r}")
    scale = check_scale(ommatidia_scale)
    k = 1.0 / math.sqrt(scale)
    step = math.radians(HORIZONTAL_SPACING_DEG) * k
    first, last = (math.radians(v) for v in AZIMUTH_RANGE_DEG)
    span = last - first
    azimuths, elevations = [], []
    for elevation in _rows_rad(scale):
        count = max(1, int(round(span * math.cos(elevation) / step)))
        azimuths.append(first + span * (np.arange(count) + 0.5) / count)
        elevations.append(np.full(count, elevation))
    azimuth, elevation = np.concatenate(azimuths), np.concatenate(elevations)
    sign = -1.0 if side == "R" else 1.0  # clockwise azimuths look to the right (-y)
    directions = np.stack([np.cos(azimuth) * np.cos(elevation), sign * np.sin(azimuth) * np.cos(elevation),
                           np.sin(elevation)], axis=-1)
    acceptance = np.full(azimuth.size, math.radians(ACCEPTANCE_DEG) * k)
    directions.setflags(write=False)
    acceptance.setflags(write=False)
    return directions, acceptance


def cataglyphis_eye(name: str, segment: str, pos_m, side: str, quat=IDENTITY_QUAT,
                    ommatidia_scale: float = 1.0) -> CompoundEye:
    """A :class:`~neuronav.spec.body.CompoundEye` mount holding :func:`cataglyphis_ommatidia` of ``side``."""
    directions, acceptance = cataglyphis_ommatidia(side, float(real_or_nan(ommatidia_scale)))
    return CompoundEye(name, segment, tuple(pos_m), tuple(quat), directions, acceptance, OMMATIDIUM_CHANNELS)


def spectral_world(world: World) -> World:
    """``world`` drawn in the compound eyes' channels: every colour (0, green, UV) (G the green value, B
    the UV value), the sky plain, the ground plain, no odour trails on the floor. Render it flat (as body
    cameras are, :mod:`neuronav.senses.vision`) and read G and B / 255 for both channels in one pass."""
    if not isinstance(world, World):
        raise ConfigError(f"spectral_world: expected a World, got {type(world).__name__}")
    look = world.appearance
    appearance = replace(look, sky_rgb=(0.0, *look.sky_green_uv), horizon_rgb=None,
                         ground_rgb=(0.0, *look.ground_green_uv), ground_texture="plain")
    objects = tuple(replace(obj, rgba=(0.0, *obj.spectral, 1.0)) for obj in world.objects)
    return replace(world, appearance=appearance, objects=objects, odour=OdourScene())


def sampling_matrix(eye: CompoundEye, pixel_directions, pixel_solid_angle_sr, truncate_fwhm: float = 2.0):
    """The sparse (M, P) matrix that turns P rendered pixel values into the eye's M ommatidium values.

    Row m holds ``Ω_p exp(-θ² / 2σ²)`` for the pixels p within ``truncate_fwhm`` acceptance widths of
    ommatidium m's axis (θ the angle to the axis, σ = FWHM / 2.355, Ω_p the pixel's solid angle),
    normalised to sum to 1; an ommatidium with no pixel that near takes its nearest pixel.

    Parameters
    ----------
    eye : CompoundEye
    pixel_directions : array_like, shape (P, 3)
        Each pixel's viewing direction in the eye's frame (normalised here).
    pixel_solid_angle_sr : array_like, shape (P,)
        Each pixel's solid angle (sr), > 0.
    truncate_fwhm : float
        Cut-off radius in acceptance widths (FWHM), > 0.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (M, P)
    """
    from scipy import sparse
    from scipy.spatial import cKDTree

    try:
        pixels = np.asarray(pixel_directions, dtype=float)
        solid = np.asarray(pixel_solid_angle_sr, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ConfigError("sampling_matrix: pixel_directions and pixel_solid_angle_sr must be numbers") from None
    if pixels.ndim != 2 or pixels.shape[1] != 3 or pixels.shape[0] < 1 or not np.isfinite(pixels).all():
        raise ConfigError(f"sampling_matrix: pixel_directions must be finite, shape (P, 3), got {pixels.shape}")
    norm = np.linalg.norm(pixels, axis=1)
    if not norm.min() > 0:
        raise ConfigError("sampling_matrix: a pixel direction is zero")
    if solid.shape != (pixels.shape[0],) or not (np.isfinite(solid).all() and solid.min() > 0):
        raise ConfigError(f"sampling_matrix: pixel_solid_angle_sr must be {pixels.shape[0]} positive numbers, "
                          f"got shape {solid.shape}")
    if not 0 < real_or_nan(truncate_fwhm) < np.inf:
        raise ConfigError(f"sampling_matrix: truncate_fwhm must be > 0, got {truncate_fwhm!r}")
    pixels = pixels / norm[:, None]
    axes, fwhm = eye.directions, eye.acceptance_rad
    sigma = fwhm * FWHM_TO_SIGMA
    reach = np.minimum(truncate_fwhm * fwhm, np.pi)
    tree = cKDTree(pixels)
    near = tree.query_ball_point(axes, r=2.0 * np.sin(reach / 2.0) + 1e-12)
    counts = np.array([len(found) for found in near])
    empty = np.flatnonzero(counts == 0)
    if empty.size:  # no pixel within the cut-off: the nearest one
        _, nearest = tree.query(axes[empty])
        for row, column in zip(empty, np.atleast_1d(nearest)):
            near[row] = [int(column)]
        counts[empty] = 1
    rows = np.repeat(np.arange(axes.shape[0]), counts)
    columns = np.concatenate([np.asarray(found, dtype=np.int64) for found in near])
    cosine = np.clip((axes[rows] * pixels[columns]).sum(axis=1), -1.0, 1.0)
    weights = solid[columns] * np.exp(-np.arccos(cosine) ** 2 / (2.0 * sigma[rows] ** 2))
    weights = np.where(weights > 0, weights, 1e-300)  # a lone far pixel keeps its row
    totals = np.bincount(rows, weights=weights, minlength=axes.shape[0])
    matrix = sparse.csr_matrix((weights / totals[rows], (rows, columns)), shape=(axes.shape[0], pixels.shape[0]))
    matrix.sum_duplicates()
    return matrix
