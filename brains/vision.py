"""Early vision: the dark-landmark shift of the visual beacon and the Zernike visual compass.

Small documented functions on grey images (float in [0, 1], as the backends' camera sensors give
them), batched over agents, with no body and no engine: they are tested on synthetic images.

Visual beacon (the I2Bot paper's eqs. 3.8–3.9)
    Pixels at or below a threshold are the landmark; P is their mean column (pixel c's centre at
    c + 0.5), δ = W/2 − P the landmark's offset left of the image centre (binocular: the mean of
    the two eyes' δ, or the one eye that sees it), and the shift ⌈|6δ/W|⌉ columns of 45° toward
    it. In this project a positive shift is clockwise (a right turn), so a landmark left of centre
    (δ > 0) gives a negative shift. No dark pixel: shift 0 (the desired heading is the current one).

Zernike compass (Sun et al. 2020; the paper's eq. 3.10)
    The upper half of the equirectangular panorama (rows from the zenith down to the horizon) is
    laid on the unit disk: the zenith at the centre, the horizon on the rim (ρ grows linearly with
    the row), the column's azimuth as the polar angle φ (increasing to the right, clockwise seen
    from above). Each pixel is a polar cell of area ρ Δρ Δφ, so

        Z_{n,m} = (n + 1)/π · Σ f(ρ, φ) R_{n,m}(ρ) e^{−imφ} ρ Δρ Δφ

    and rolling the image by whole columns is exactly a rotation of the disk: every |Z_{n,m}| stays
    the same and the phase of Z_{n,m} moves by −m times the roll's angle (a roll by +1 column, the
    scene moving right, lowers the phase by m · 360°/W). The phase of Z_{7,1} is the compass. The
    basis is computed once (:class:`ZernikeBasis`); a frame, or a batch, costs one matrix product.

    The ant turning right (clockwise) by α makes the scene move left in its panorama by α, which
    raises the phase by α: the phase difference Φ(t) − Φ(0) is how far the ant has turned right of
    its stored direction, and eq. 3.10's turn θ = sign(Φ(t) − Φ(0)) is, with θ > 0 a left turn in
    this project, the turn back (:func:`compass_command`).
"""

from __future__ import annotations

from math import factorial

import numpy as np

from neuronav.angles import angle_difference_rad
from neuronav.errors import ConfigError, PortError, real_or_nan

DARK_THRESHOLD = 20.0 / 255.0  # I2Bot: 10-25 of 255
MAX_SHIFT = 3  # |6 delta / W| <= 3 for a landmark anywhere in the image
MAX_STRIDE_DEG = 40.0  # the FK gait's largest hip swing
# Size bounds of a Zernike basis: orders up to MAX_ZERNIKE_ORDER (Sun et al. use 16; the radial
# polynomials' factorials lose precision far beyond), and a complex matrix of at most
# MAX_BASIS_ENTRIES (256 MB).
MAX_ZERNIKE_ORDER = 40
MAX_BASIS_ENTRIES = 2 ** 24



def _images(image, where: str) -> np.ndarray:
    """A grey image (H, W) or batch (N, H, W) as (N, H, W) float, or a PortError naming the problem."""
    try:
        array = np.asarray(image, dtype=float)
    except (TypeError, ValueError):
        raise PortError(f"{where}: needs a grey image of numbers, got {type(image).__name__}") from None
    if array.ndim == 2:
        array = array[None]
    if array.ndim != 3 or min(array.shape) < 1:
        raise PortError(f"{where}: needs a grey image (H, W) or a batch (N, H, W), got shape {np.shape(image)}")
    if not np.isfinite(array).all():
        raise PortError(f"{where}: the image holds NaN or infinite values")
    return array


def landmark_offset_px(image, threshold: float = DARK_THRESHOLD) -> np.ndarray:
    """δ = W/2 − P per image (N,): how far the dark pixels' mean column lies left of the centre (px); NaN when none."""
    images = _images(image, "landmark_offset_px")
    if not 0.0 <= real_or_nan(threshold) <= 1.0:
        raise ConfigError(f"landmark_offset_px: threshold must be a grey level in [0, 1], got {threshold!r}")
    dark = images <= threshold
    columns = np.arange(images.shape[2]) + 0.5
    count = dark.sum(axis=(1, 2))
    mean_column = np.full(images.shape[0], np.nan)
    seen = count > 0
    mean_column[seen] = (dark[seen] * columns).sum(axis=(1, 2)) / count[seen]
    return images.shape[2] / 2.0 - mean_column


def beacon_shift(eye_left=None, eye_right=None, threshold: float = DARK_THRESHOLD) -> np.ndarray:
    """The copy-and-shift ``shift`` (N, 1) from one or both eyes (eqs. 3.8–3.9; see the module doc).

    Parameters
    ----------
    eye_left, eye_right : ndarray, shape (H, W) or (N, H, W), or None
        Grey images in [0, 1]; at least one. With both (the same shape), δ is the mean of the eyes
        that see the landmark.
    threshold : float
        Grey level at or below which a pixel is dark.

    Returns
    -------
    ndarray, shape (N, 1)
        −sign(δ) ⌈|6δ/W|⌉, within ±3; 0 where no eye sees the landmark.
    """
    eyes = [_images(e, "beacon_shift") for e in (eye_left, eye_right) if e is not None]
    if not eyes:
        raise PortError("beacon_shift: give the left eye, the right eye or both")
    if len(eyes) == 2 and eyes[0].shape != eyes[1].shape:
        raise PortError(f"beacon_shift: the eyes' images differ in shape: {eyes[0].shape} and {eyes[1].shape}")
    width = eyes[0].shape[2]
    offsets = np.stack([landmark_offset_px(e, threshold) for e in eyes])  # (eyes, N)
    seen = np.isfinite(offsets)
    # The mean over the eyes that see the landmark; 0 (keep the heading) where none does.
    delta = np.where(seen, offsets, 0.0).sum(axis=0) / np.maximum(seen.sum(axis=0), 1)
    magnitude = np.ceil(np.abs(6.0 * delta / width))
    return np.clip(-np.sign(delta) * magnitude, -MAX_SHIFT, MAX_SHIFT)[:, None]


def radial_polynomial(n: int, m: int, rho) -> np.ndarray:
    """Zernike's radial polynomial R_{n,m}(ρ) (n − |m| even, |m| <= n)."""
    if not all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in (n, m)):
        raise ConfigError(f"radial_polynomial: n and m must be ints, got n={n!r}, m={m!r}")
    m = abs(m)
    if n < 0 or m > n or (n - m) % 2 or n > MAX_ZERNIKE_ORDER:
        raise ConfigError(f"radial_polynomial: needs 0 <= |m| <= n <= {MAX_ZERNIKE_ORDER} and n - |m| even, "
                          f"got n={n}, m={m}")
    rho = np.asarray(rho, dtype=float)
    return sum((-1) ** k * factorial(n - k) / (factorial(k) * factorial((n + m) // 2 - k) * factorial((n - m) // 2 - k))
               * rho ** (n - 2 * k) for k in range((n - m) // 2 + 1))


def zernike_orders(n_max: int) -> list[tuple[int, int]]:
    """The (n, m) with 0 <= m <= n <= n_max and n − m even, by n then m. n_max = 16 gives 81 of them
    (the mushroom body's 81 inputs in Sun et al. 2020)."""
    return [(n, m) for n in range(n_max + 1) for m in range(n % 2, n + 1, 2)]


class ZernikeBasis:
    """Zernike moments of equirectangular panoramas (H, W), precomputed (see the module doc).

    Parameters
    ----------
    height_px, width_px : int
        The panorama's size; its columns cover 360° of azimuth, its rows the zenith (top) to the
        nadir (bottom) by default.
    n_max : int
        Highest order; the basis holds :func:`zernike_orders` (n_max) (m >= 0: Z_{n,−m} is the
        conjugate of Z_{n,m} for a real image).
    rows : int, optional
        How many rows from the top lie on the disk (default: the upper half, the horizon on the rim).

    Attributes
    ----------
    orders : list of (n, m)
    matrix : ndarray, complex, shape (rows * W, len(orders))
        A frame's moments are ``frame[:rows].ravel() @ matrix``.
    """

    def __init__(self, height_px: int, width_px: int, n_max: int = 7, rows: int | None = None) -> None:
        for label, value in (("height_px", height_px), ("width_px", width_px), ("n_max", n_max)):
            lowest = 0 if label == "n_max" else 1
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lowest:
                raise ConfigError(f"ZernikeBasis: {label} must be a positive int, got {value!r}")
        rows = height_px // 2 if rows is None else rows
        if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or not 1 <= rows <= height_px:
            raise ConfigError(f"ZernikeBasis: rows must be an int in 1..{height_px}, got {rows!r}")
        if n_max > MAX_ZERNIKE_ORDER:
            raise ConfigError(f"ZernikeBasis: n_max must be at most {MAX_ZERNIKE_ORDER}, got {n_max!r}")
        entries = int(rows) * int(width_px) * len(zernike_orders(int(n_max)))
        if entries > MAX_BASIS_ENTRIES:
            raise ConfigError(f"ZernikeBasis: rows x width_px x orders ({entries}) must be at most "
                              f"{MAX_BASIS_ENTRIES} (the basis matrix's memory bound)")
        self.shape = (int(height_px), int(width_px))
        self.rows = int(rows)
        self.orders = zernike_orders(int(n_max))
        d_rho, d_phi = 1.0 / rows, 2.0 * np.pi / width_px
        rho = (np.arange(rows) + 0.5) * d_rho
        phi = ((np.arange(width_px) + 0.5) / width_px - 0.5) * 2.0 * np.pi
        columns = []
        for n, m in self.orders:
            radial = (n + 1) / np.pi * radial_polynomial(n, m, rho) * rho * d_rho * d_phi
            columns.append((radial[:, None] * np.exp(-1j * m * phi)[None, :]).ravel())
        self.matrix = np.stack(columns, axis=1)
        self._compass = self.orders.index((7, 1)) if (7, 1) in self.orders else None

    def moments(self, panorama) -> np.ndarray:
        """Complex moments (N, len(orders)) of a panorama (H, W) or a batch (N, H, W)."""
        images = _images(panorama, "ZernikeBasis.moments")
        if images.shape[1:] != self.shape:
            raise PortError(f"ZernikeBasis.moments: panoramas must be {self.shape}, got {images.shape[1:]}")
        return images[:, : self.rows].reshape(images.shape[0], -1) @ self.matrix

    def amplitudes(self, panorama) -> np.ndarray:
        """|Z_{n,m}| (N, len(orders)): invariant to turning the panorama by whole columns."""
        return np.abs(self.moments(panorama))

    def compass_phase(self, panorama) -> np.ndarray:
        """The phase of Z_{7,1} (N,) in rad: rises by α when the viewer turns right by α."""
        if self._compass is None:
            raise ConfigError("ZernikeBasis.compass_phase: the basis needs n_max >= 7")
        images = _images(panorama, "ZernikeBasis.compass_phase")
        if images.shape[1:] != self.shape:
            raise PortError(f"ZernikeBasis.compass_phase: panoramas must be {self.shape}, got {images.shape[1:]}")
        return np.angle(images[:, : self.rows].reshape(images.shape[0], -1) @ self.matrix[:, self._compass])


def compass_command(phase_rad: float, stored_phase_rad: float, dead_band_deg: float = 0.8) -> tuple[float, float]:
    """Eq. 3.10: (turn θ, stride S_l in rad) from the compass phase and the stored one.

    θ = sign(Φ(t) − Φ(0)) (the difference wrapped to ±180°; θ > 0 turns left, back toward the stored
    direction when the ant has turned right of it), S_l = |Φ(t) − Φ(0)|/5 in degrees (at most the
    gait's 40°); (0, 0) within the dead band.
    """
    values = np.array([real_or_nan(v) for v in (phase_rad, stored_phase_rad, dead_band_deg)])
    if not np.isfinite(values).all() or values[2] < 0:
        raise ConfigError(f"compass_command: phases must be finite and dead_band_deg >= 0, got {phase_rad!r}, "
                          f"{stored_phase_rad!r}, {dead_band_deg!r}")
    difference_deg = float(np.degrees(angle_difference_rad(values[0], values[1])))
    if abs(difference_deg) < dead_band_deg:
        return 0.0, 0.0
    return float(np.sign(difference_deg)), float(np.radians(min(abs(difference_deg) / 5.0, MAX_STRIDE_DEG)))
