"""The dorsal rim area (DRA) of the ant's two compound eyes: where the sky's polarisation is read.

Geometry, in the HEAD frame (+x forward, +y left, +z up). Head azimuths are measured clockwise from
+x seen from above (like headings in the world, clockwise from north), so the head-frame direction of
azimuth ``a`` and elevation ``e`` is ``(cos a cos e, -sin a cos e, sin e)``. Each eye's DRA looks
upward at the *contralateral* half of the sky (Labhart & Meyer 1999's survey; the left eye's DRA sees
the right half, azimuths 0–180°, the right eye's the left half): the two eyes together see a full
ring of sky, mirrored about the head's sagittal (x-z) plane. Ommatidia sit on ``rows`` elevations
evenly spaced across ``[elevation_low_rad, elevation_high_rad]`` and ``columns`` azimuths evenly
spaced (at half-step offsets) across each eye's ``azimuth_span_rad`` centred on its side; the left eye
comes first, row by row.

What the numbers are and where they come from (see also ``docs/parameters.md``, sky section):

- 80 ommatidia per eye (4 rows x 20 columns): the DRA of *Cataglyphis bicolor* holds about 80
  ommatidia per eye (Räber 1979, cited in Labhart & Meyer 1999, Microsc. Res. Tech. 47:368; neither
  read here in full). Gkanias et al. 2019 (PLoS Comput Biol 15:e1007123) used 60 ommatidia on one
  dome for both eyes; we keep the ant's own count and split it
  into the two contralateral halves, so that the 40 azimuths of a row are evenly spaced around the
  full circle (9° apart), which keeps the first and second spatial harmonics of the sky pattern
  apart in the compass (:mod:`neuronav.brains.sky_compass`).
- Elevations 40° to 70°: Duelli 1975 (J Comp Physiol 102:43) located the ommatidia that Cataglyphis
  needs for e-vector orientation in a dorsal "fovea" viewing elevations of about 43° to 65° (centre
  51°) at about 45° from the sagittal plane; the band covers it with a 3–5° margin. The real DRA's
  fields are not a regular grid (their exact map is not in the sources we could read): the grid is our
  choice.
- Acceptance angle 5.4° (the full width at half maximum of each ommatidium's angular sensitivity):
  the value Gkanias et al. 2019 give their desert-ant DRA ommatidia.
- Microvilli: each ommatidium has two orthogonal analyser channels (the DRA's crossed microvilli,
  Labhart & Meyer 1999), one with its preferred e-vector along the ommatidium's meridian (the
  great circle through the zenith and its viewing direction), the other along the horizontal tangent.
  Across the DRA the analysers so form the fan pattern the survey describes.
- Polarisation sensitivity PS = 10 (ratio of a channel's response to light polarised along and
  across its microvilli): DRA photoreceptors of bees, crickets and ants measure PS of the order of 5
  to 10 (Labhart & Meyer 1999); an ideal analyser (PS infinite) would make the log ratio infinite
  where the degree of polarisation reaches 1.

Photoreceptor signals (Malus's law for a partial analyser, as in Gkanias et al. 2019):
``s = I (1 + k P cos 2(phi_e - phi_axis)) / 2`` with ``k = (PS - 1) / (PS + 1)``, I the radiance,
P the degree of polarisation and phi the e-vector and analyser angles; the orthogonal channel has
``-cos`` in place of ``cos``. POL-neurons are polarisation-opponent (Labhart 1988, Nature 331:435:
antagonistic input from the two orthogonal analysers); we take the log ratio ``log(s_par / s_perp)``
(Labhart 1999's logarithmic POL1 model), which does not depend on the radiance. An occluded
ommatidium (``visible`` False) sees the dim unpolarised light under the canopy: both channels equal,
response 0.

Acceptance angle and rays: by default each ommatidium reads the sky along its optical axis only
(``acceptance_samples=1``). ``acceptance_samples=7`` averages each channel's signal over the axis and
six directions on a cone of half the acceptance angle (the half width at half maximum), in one array
operation. The Rayleigh pattern changes over tens of degrees, so over a 5.4° field the two differ
little: measured with :func:`neuronav.senses.dorsal_rim.acceptance_difference` (the sky section of
``docs/parameters.md`` gives the numbers and the command).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from neuronav.errors import ConfigError, real_or_nan

ACCEPTANCE_SAMPLES = (1, 7)
MAX_OMMATIDIA_PER_EYE = 10_000


@dataclass(frozen=True)
class DorsalRim:
    """Both eyes' dorsal-rim ommatidia: viewing directions and analyser axes in the head frame.

    Parameters
    ----------
    rows : int
        Elevation rows per eye (>= 1).
    columns : int
        Azimuth columns per eye (>= 1); ``rows * columns`` ommatidia per eye, at most 10000.
    elevation_low_rad, elevation_high_rad : float
        The band of elevations (head frame) the rows span, centres included, 0 < low <= high < π/2.
    azimuth_span_rad : float
        The azimuth range each eye covers on its contralateral side, in (0, π]; π (the default)
        makes the two eyes together see a full ring.
    acceptance_angle_rad : float
        Full width at half maximum of an ommatidium's angular sensitivity, in (0, π/4].
    acceptance_samples : int
        1 (the optical axis) or 7 (the axis and six directions at half the acceptance angle).
    polarisation_sensitivity : float
        PS of each analyser channel, > 1 (``inf`` for an ideal analyser).
    """

    rows: int = 4
    columns: int = 20
    elevation_low_rad: float = float(np.deg2rad(40.0))
    elevation_high_rad: float = float(np.deg2rad(70.0))
    azimuth_span_rad: float = float(np.pi)
    acceptance_angle_rad: float = float(np.deg2rad(5.4))
    acceptance_samples: int = 1
    polarisation_sensitivity: float = 10.0

    def __post_init__(self) -> None:
        for label in ("rows", "columns"):
            value = getattr(self, label)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ConfigError(f"DorsalRim {label} must be an int >= 1, got {value!r}")
        if self.rows * self.columns > MAX_OMMATIDIA_PER_EYE:
            raise ConfigError(f"DorsalRim rows * columns must be at most {MAX_OMMATIDIA_PER_EYE} ommatidia per eye, "
                              f"got {self.rows} * {self.columns}")
        low, high = real_or_nan(self.elevation_low_rad), real_or_nan(self.elevation_high_rad)
        if not (0.0 < low <= high < np.pi / 2):
            raise ConfigError(f"DorsalRim elevations must satisfy 0 < elevation_low_rad <= elevation_high_rad < pi/2, "
                              f"got {self.elevation_low_rad!r}, {self.elevation_high_rad!r}")
        if not 0.0 < real_or_nan(self.azimuth_span_rad) <= np.pi:
            raise ConfigError(f"DorsalRim azimuth_span_rad must be in (0, pi], got {self.azimuth_span_rad!r}")
        if not 0.0 < real_or_nan(self.acceptance_angle_rad) <= np.pi / 4:
            raise ConfigError(f"DorsalRim acceptance_angle_rad must be in (0, pi/4], got {self.acceptance_angle_rad!r}")
        if self.acceptance_samples not in ACCEPTANCE_SAMPLES or isinstance(self.acceptance_samples, bool):
            raise ConfigError(f"DorsalRim acceptance_samples must be one of {ACCEPTANCE_SAMPLES}, "
                              f"got {self.acceptance_samples!r}")
        ps = real_or_nan(self.polarisation_sensitivity)
        if not ps > 1.0:  # inf allowed, NaN refused
            raise ConfigError(f"DorsalRim polarisation_sensitivity must be > 1 (inf allowed), "
                              f"got {self.polarisation_sensitivity!r}")

    # -- geometry (head frame) -------------------------------------------------------------------
    @property
    def n_ommatidia(self) -> int:
        """Ommatidia of both eyes together, M = 2 rows columns."""
        return 2 * self.rows * self.columns

    @cached_property
    def elevations_rad(self) -> np.ndarray:
        """Head-frame elevation of each ommatidium, shape (M,)."""
        if self.rows == 1:
            rows = np.array([0.5 * (self.elevation_low_rad + self.elevation_high_rad)])
        else:
            rows = np.linspace(self.elevation_low_rad, self.elevation_high_rad, self.rows)
        one_eye = np.repeat(rows, self.columns)
        return np.concatenate([one_eye, one_eye])

    @cached_property
    def azimuths_rad(self) -> np.ndarray:
        """Head-frame azimuth of each ommatidium, clockwise from forward, shape (M,).

        The left eye (first half) sees the right side, azimuths in (0, π); the right eye the mirror
        image, azimuths in (-π, 0).
        """
        fraction = (np.arange(self.columns) + 0.5) / self.columns - 0.5
        left_eye = np.tile(0.5 * np.pi + self.azimuth_span_rad * fraction, self.rows)
        return np.concatenate([left_eye, -left_eye])

    @cached_property
    def directions(self) -> np.ndarray:
        """Unit viewing directions in the head frame, shape (M, 3)."""
        return _direction(self.azimuths_rad, self.elevations_rad)

    @cached_property
    def axes(self) -> np.ndarray:
        """Preferred e-vector of each ommatidium's first (meridian-parallel) channel, head frame, (M, 3).

        The unit tangent of the meridian at the viewing direction, pointing toward the zenith; the
        second channel's axis is ``cross(direction, axis)``, the horizontal tangent.
        """
        a, e = self.azimuths_rad, self.elevations_rad
        return np.stack([-np.cos(a) * np.sin(e), np.sin(a) * np.sin(e), np.cos(e)], axis=-1)

    @cached_property
    def _normals(self) -> np.ndarray:
        """``cross(direction, axis)`` of each ommatidium, head frame (M, 3): the second channel's axis, and
        the normal :meth:`neuronav.senses.sky.Sky.analysed_degree` takes (read-only)."""
        normals = np.cross(self.directions, self.axes)
        normals.setflags(write=False)
        return normals

    @cached_property
    def _samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample directions (M, S, 3) over each acceptance field, and their projected axes (M, S, 3)."""
        d, axis = self.directions, self.axes
        if self.acceptance_samples == 1:
            return d[:, None, :], axis[:, None, :]
        other = np.cross(d, axis)
        radius = 0.5 * self.acceptance_angle_rad
        psi = 2.0 * np.pi * np.arange(6) / 6
        offsets = np.cos(psi)[None, :, None] * axis[:, None, :] + np.sin(psi)[None, :, None] * other[:, None, :]
        ring = np.cos(radius) * d[:, None, :] + np.sin(radius) * offsets
        samples = np.concatenate([d[:, None, :], ring], axis=1)
        # The analyser is fixed in the head: seen along a sample direction it is the axis projected
        # onto the plane across that direction.
        projected = axis[:, None, :] - (samples @ axis[:, :, None]) * samples
        projected /= np.linalg.norm(projected, axis=-1, keepdims=True)
        return samples, projected

    @property
    def analyser_contrast(self) -> float:
        """k = (PS - 1) / (PS + 1): how much a fully polarised e-vector modulates a channel (1 when PS is inf)."""
        ps = float(self.polarisation_sensitivity)
        return 1.0 if math.isinf(ps) else (ps - 1.0) / (ps + 1.0)

    # -- reading the sky ---------------------------------------------------------------------------
    def sky_directions(self, head_rotations: np.ndarray) -> np.ndarray:
        """World viewing directions of every agent's ommatidia.

        Parameters
        ----------
        head_rotations : ndarray, shape (N, 3, 3)
            Rotation matrices from the head frame to the world frame (columns: the head's forward,
            left and up axes in world coordinates).

        Returns
        -------
        ndarray, shape (N, M, 3)
        """
        return self.directions @ _rotations(head_rotations).transpose(0, 2, 1)

    def responses(self, sky, head_rotations: np.ndarray, visible: np.ndarray | None = None) -> np.ndarray:
        """POL-neuron opponent responses ``log(s_par / s_perp)`` of every ommatidium, batched.

        With one ray per ommatidium (``acceptance_samples=1``) and a sky that has ``analysed_degree``
        (:meth:`neuronav.senses.sky.Sky.analysed_degree`), the sky gives each analyser's
        ``P cos 2(phi_e - phi_axis)`` without building e-vectors: the same responses as through
        ``light`` to rounding, in a few array operations (one agent's read costs tens of microseconds).

        Parameters
        ----------
        sky : neuronav.senses.sky.Sky
            Anything with ``light(directions) -> SkyLight`` (radiance, degree, evector), and optionally
            ``analysed_degree(views, normals)``.
        head_rotations : ndarray, shape (N, 3, 3)
            Head-to-world rotations (see :meth:`sky_directions`).
        visible : ndarray of bool, shape (N, M), optional
            False where the ommatidium's view of the sky is blocked (it then reads 0).

        Returns
        -------
        ndarray, shape (N, M)
            0 for unpolarised light; positive when the e-vector lies nearer the meridian-parallel
            analyser; bounded by ``±log(PS)``.
        """
        rotations = _rotations(head_rotations)
        if self.acceptance_samples == 1 and hasattr(sky, "analysed_degree"):
            # One ray per ommatidium, and a sky that gives P cos 2(phi_e - phi_axis) directly (Sky does):
            # the directions and analyser normals turned into the world, a few array operations in all.
            turn = rotations.transpose(0, 2, 1)
            modulation = sky.analysed_degree(self.directions @ turn, self._normals @ turn)
            modulation *= self.analyser_contrast
            return self._mask(2.0 * np.arctanh(modulation), visible)  # log((1 + m) / (1 - m))
        samples, projected = self._samples
        n, (m, s, _) = rotations.shape[0], samples.shape
        # (M S, 3) @ (N, 3, 3)ᵀ: every sample direction and analyser axis in the world frame.
        turn = rotations.transpose(0, 2, 1)
        directions = (samples.reshape(-1, 3) @ turn).reshape(n, m, s, 3)
        axes = (projected.reshape(-1, 3) @ turn).reshape(n, m, s, 3)
        light = sky.light(directions)
        radiance = np.asarray(light.radiance, float)
        degree = np.asarray(light.degree, float)
        cos_delta = (np.asarray(light.evector, float) * axes).sum(axis=-1)
        modulation = self.analyser_contrast * degree * (2.0 * cos_delta ** 2 - 1.0)
        if s == 1:
            # One ray: the radiance cancels in the ratio; where there is no light the degree is 0 too.
            modulation = modulation[..., 0]
            response = np.log((1.0 + modulation) / (1.0 - modulation))
        else:
            s_par = (radiance * (1.0 + modulation)).mean(axis=-1) / 2.0
            s_perp = (radiance * (1.0 - modulation)).mean(axis=-1) / 2.0
            with np.errstate(divide="ignore", invalid="ignore"):
                response = np.log(s_par / s_perp)
            # No light (radiance 0 below the horizon, say) carries no polarisation.
            response = np.where((s_par > 0.0) & (s_perp > 0.0), response, 0.0)
        return self._mask(response, visible)

    @staticmethod
    def _mask(response: np.ndarray, visible) -> np.ndarray:
        """``response`` with 0 where ``visible`` (bool, the response's shape, or None: all) is False."""
        if visible is None:
            return response
        visible = np.asarray(visible)
        if visible.shape != response.shape or visible.dtype != bool:
            raise ConfigError(f"DorsalRim.responses: visible must be bool of shape {response.shape}, "
                              f"got {visible.dtype} {visible.shape}")
        return np.where(visible, response, 0.0)


def _direction(azimuth_rad: np.ndarray, elevation_rad: np.ndarray) -> np.ndarray:
    """Head-frame unit vectors of azimuth (clockwise from +x) and elevation: shape (..., 3)."""
    cos_e = np.cos(elevation_rad)
    return np.stack([np.cos(azimuth_rad) * cos_e, -np.sin(azimuth_rad) * cos_e, np.sin(elevation_rad)], axis=-1)


def _rotations(head_rotations) -> np.ndarray:
    rotations = np.asarray(head_rotations, dtype=float)
    if rotations.ndim != 3 or rotations.shape[1:] != (3, 3) or not np.all(np.isfinite(rotations)):
        raise ConfigError(f"DorsalRim: head_rotations must be finite numbers of shape (N, 3, 3), got {rotations.shape}")
    return rotations


def head_rotations_from_headings(heading_rad, pitch_rad=0.0, roll_rad=0.0) -> np.ndarray:
    """Head-to-world rotations of heads with world heading (clockwise from +y), pitch and roll.

    The head first yaws to its heading (forward ``(sin h, cos h, 0)``, left ``(-cos h, sin h, 0)``), then
    pitches nose-up by ``pitch_rad`` about its left axis and rolls right-side-down by ``roll_rad`` about
    its forward axis (intrinsic yaw, pitch, roll).

    Returns
    -------
    ndarray, shape (N, 3, 3)
        Columns: the head's forward, left and up axes in world coordinates.
    """
    heading, pitch, roll = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float)) for v in
                                                 (heading_rad, pitch_rad, roll_rad)))
    if heading.ndim != 1:
        raise ConfigError(f"head_rotations_from_headings: angles must be scalars or 1-d, got shape {heading.shape}")
    sh, ch, sp, cp, sr, cr = np.sin(heading), np.cos(heading), np.sin(pitch), np.cos(pitch), np.sin(roll), np.cos(roll)
    zero, one = np.zeros_like(heading), np.ones_like(heading)
    yaw = np.stack([np.stack([sh, -ch, zero], -1), np.stack([ch, sh, zero], -1), np.stack([zero, zero, one], -1)], 1)
    # In the head frame: pitch about +y (nose up: forward tilts toward +z), roll about +x (right side down).
    pitch_m = np.stack([np.stack([cp, zero, -sp], -1), np.stack([zero, one, zero], -1),
                        np.stack([sp, zero, cp], -1)], 1)
    roll_m = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cr, -sr], -1),
                       np.stack([zero, sr, cr], -1)], 1)
    return yaw @ pitch_m @ roll_m


def rotations_from_quaternions(quaternions) -> np.ndarray:
    """Rotation matrices of unit quaternions (w, x, y, z), shape (N, 4) -> (N, 3, 3) (normalised first).

    One quaternion (a physics backend's head) is turned with Python floats, many with array operations:
    the same formula (:func:`_quaternion_matrix`), the same numbers.
    """
    q = np.asarray(quaternions, dtype=float)
    if q.ndim == 1:
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != 4 or not np.isfinite(q).all():
        raise ConfigError(f"rotations_from_quaternions: quaternions must be finite numbers of shape (N, 4), "
                          f"got {q.shape}")
    if q.shape[0] == 1:
        w, x, y, z = q[0].tolist()
        norm2 = w * w + x * x + y * y + z * z
        if norm2 == 0.0:
            raise ConfigError("rotations_from_quaternions: a quaternion is zero")
        return np.array(_quaternion_matrix(w, x, y, z, 2.0 / norm2)).reshape(1, 3, 3)
    w, x, y, z = q.T
    norm2 = w * w + x * x + y * y + z * z
    if not norm2.all():
        raise ConfigError("rotations_from_quaternions: a quaternion is zero")
    return np.stack(_quaternion_matrix(w, x, y, z, 2.0 / norm2), axis=-1).reshape(-1, 3, 3)


def _quaternion_matrix(w, x, y, z, s) -> list:
    """The 9 entries (row by row) of the rotation of quaternion (w, x, y, z) with ``s = 2 / |q|²``
    (floats or arrays alike)."""
    return [1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y),
            s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x),
            s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y)]


def acceptance_difference(sky, rim: DorsalRim | None = None, n_headings: int = 36) -> float:
    """Largest |response| difference between 7-ray and 1-ray acceptance over headings all around.

    For the claim in the module docstring: a single ray per ommatidium stands for its 5.4° field.
    """
    rim = DorsalRim() if rim is None else rim
    from dataclasses import replace

    rotations = head_rotations_from_headings(np.linspace(0.0, 2.0 * np.pi, n_headings, endpoint=False))
    one = replace(rim, acceptance_samples=1).responses(sky, rotations)
    seven = replace(rim, acceptance_samples=7).responses(sky, rotations)
    return float(np.max(np.abs(seven - one)))
