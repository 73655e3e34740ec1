"""Visual homing by rotational image difference (Zeil et al. 2003; Baddeley et al. 2012): engine-free.

An ant that has stored views (snapshots) near its nest, each taken facing the nest (as on its learning
walks), can find the way home from a view alone: turn the current panorama through every heading,
compare each with every snapshot, and face the heading of the best match. The comparison against one
snapshot over all headings is the rotational image difference function (RIDF, Zeil et al. 2003,
J. Opt. Soc. Am. A 20: 450): the root-mean-square grey-level difference between the snapshot and
the current view turned by δ. Near where a snapshot was taken its RIDF has a deep, narrow minimum at
the heading the snapshot faced; farther away the minimum grows shallower until it is lost in the
noise of the other headings. Taking the best match over several snapshots around the nest is the
multi-snapshot reading of Baddeley et al. 2012 (PLoS Comput Biol 8: e1002336) and Wystrach et al.
2013 (J. Exp. Biol. 216: 1766).

Views are the body's ``panorama`` camera (equirectangular, the whole sphere, forward in the middle,
5° per column, 2.5° per row, grey in [0, 1]; ``bodies/desert_ant``). Turning the body clockwise by
5° rolls the image one column toward lower indices (measured on the kinematic ray caster; the
cross-backend tests check the same on MuJoCo and PyBullet), so the view the agent would see at
heading ``h + k · 5°`` is ``roll(view, -k)``. :func:`skyline_view` keeps the band from the horizon up
to ``band_deg`` of elevation (where the trees stand against the sky; the plain ground below carries
nothing), averaging pairs of rows.

Certainty of the visual cue: the RIDF's relative depth, ``1 - min / median`` over headings (0 for
a flat RIDF, which says nothing; 1 for a perfect match that differs from every other heading).
"""

from __future__ import annotations

import numpy as np

from neuronav.angles import angle_difference_rad
from neuronav.errors import ConfigError

COLUMN_DEG = 5.0


def _images(where: str, label: str, images) -> np.ndarray:
    """``images`` as a float array of finite grey values, or a ConfigError naming ``where`` and ``label``."""
    try:
        array = np.asarray(images, float)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {label} must be grey images (numbers), got {type(images).__name__}") from None
    # Grey values are in [0, 1]: bounding them keeps every square and sum finite.
    if not (np.isfinite(array).all() and (array.size == 0 or np.abs(array).max() <= 1e100)):
        raise ConfigError(f"{where}: {label} must be finite grey values (|value| <= 1e100)")
    return array


def skyline_view(panorama: np.ndarray, band_deg: float = 45.0) -> np.ndarray:
    """The band of a spherical panorama from the horizon up to ``band_deg``, pairs of rows averaged.

    Parameters
    ----------
    panorama : ndarray, shape (N, H, W) or (H, W)
        Grey images, finite, row 0 at the zenith, row H/2 at the horizon (the ``panorama`` camera).
    band_deg : float
        Elevation the band reaches, degrees (0 < band_deg <= 90).

    Returns
    -------
    ndarray, shape (N, rows, W)
        ``rows = round(band_deg / (180 / H)) // 2`` rows of averaged pairs, top first.
    """
    images = _images("skyline_view", "panorama", panorama)
    if images.ndim == 2:
        images = images[None]
    if images.ndim != 3 or images.shape[1] < 4:
        raise ConfigError(f"skyline_view: expected panoramas of shape (N, H, W), got {np.shape(panorama)}")
    if isinstance(band_deg, bool) or not isinstance(band_deg, int | float | np.integer | np.floating) \
            or not 0 < band_deg <= 90:
        raise ConfigError(f"skyline_view: band_deg must be in (0, 90], got {band_deg!r}")
    height = images.shape[1]
    horizon = height // 2
    rows = max(2, int(round(band_deg / (180.0 / height))) // 2 * 2)
    band = images[:, horizon - rows:horizon]
    return 0.5 * (band[:, 0::2] + band[:, 1::2])


def ridf(views: np.ndarray, snapshots: np.ndarray) -> np.ndarray:
    """Rotational image difference of every view against every snapshot, at every whole-column turn.

    Parameters
    ----------
    views : ndarray, shape (N, R, W)
    snapshots : ndarray, shape (K, R, W)
        Finite grey values (|value| <= 1e100), else a ConfigError.

    Returns
    -------
    ndarray, shape (N, K, W)
        Entry (n, k, j): RMS difference between snapshot k and view n turned clockwise by j columns
        (``roll(view, -j)``, the view at heading + j · 5°).
    """
    views, snapshots = _images("ridf", "views", views), _images("ridf", "snapshots", snapshots)
    if views.ndim != 3 or snapshots.ndim != 3 or views.shape[1:] != snapshots.shape[1:] or min(views.shape[1:]) < 1:
        raise ConfigError(f"ridf: views {views.shape} and snapshots {snapshots.shape} must be (N, R, W) and "
                          "(K, R, W) with the same R >= 1 and W >= 1")
    width = views.shape[2]
    # sum_c roll(V, -j)[c] S[c] = sum_c V[c + j] S[c]: a circular cross-correlation along the columns.
    spectrum_v = np.fft.rfft(views, axis=2)
    spectrum_s = np.fft.rfft(snapshots, axis=2)
    cross = np.einsum("nrf,krf->nkf", spectrum_v, np.conj(spectrum_s))
    correlation = np.fft.irfft(cross, n=width, axis=2)
    energy_v = (views ** 2).sum(axis=(1, 2))[:, None, None]
    energy_s = (snapshots ** 2).sum(axis=(1, 2))[None, :, None]
    squared = np.maximum(energy_v + energy_s - 2.0 * correlation, 0.0)
    return np.sqrt(squared / (views.shape[1] * width))


def homing_direction(views: np.ndarray, heading_rad: np.ndarray,
                     snapshots: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Direction to walk from each view: the heading whose turned view best matches a snapshot.

    Parameters
    ----------
    views : ndarray, shape (N, R, W)
        Current :func:`skyline_view` of each agent, taken at ``heading_rad``.
    heading_rad : ndarray, shape (N,)
        Heading each view was taken at (clockwise from +y).
    snapshots : ndarray, shape (K, R, W)
        Stored views, each taken facing the nest (so the matching heading points home).

    Returns
    -------
    direction_rad : ndarray, shape (N,)
        In (-pi, pi]: the heading at which the view best matches the best snapshot.
    certainty : ndarray, shape (N,)
        ``1 - min / median`` of the RIDF taken as the minimum over snapshots at each turn, in [0, 1].
    best_snapshot : ndarray, shape (N,)
        Index of the matching snapshot.

    Raises
    ------
    ConfigError
        No snapshot to match (N = 0 views give empty results), or a bad heading.
    """
    differences = ridf(views, snapshots)
    n_views, n_snapshots, width = differences.shape
    if n_snapshots == 0:
        raise ConfigError(f"homing_direction: needs at least one snapshot (K, R, W), got shape {differences.shape[1:]}")
    flat = differences.reshape(n_views, n_snapshots * width).argmin(axis=1)
    best_snapshot, best_shift = np.divmod(flat, width)
    turn_rad = np.radians(COLUMN_DEG) * best_shift
    try:
        heading = np.asarray(heading_rad, float).reshape(-1)
    except (TypeError, ValueError):
        heading = np.full(0, np.nan)
    if heading.size not in (1, n_views) or not np.isfinite(heading).all():
        raise ConfigError(f"homing_direction: heading_rad must be one finite number or {n_views}, got "
                          f"{heading_rad!r}")
    direction = angle_difference_rad(heading + turn_rad, 0.0)  # the heading turned by turn_rad, wrapped
    envelope = differences.min(axis=1)
    median = np.median(envelope, axis=1)
    certainty = np.where(median > 0, 1.0 - envelope.min(axis=1) / np.where(median > 0, median, 1.0), 0.0)
    return direction, np.clip(certainty, 0.0, 1.0), best_snapshot
