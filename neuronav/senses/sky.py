"""The sky: the sun's position and, for every direction of the dome, its radiance and polarisation.

A :class:`Sky` is the ``sky`` of a :class:`~neuronav.spec.world.World` (checked there by what it holds,
as the odour plume is, since the model lives here): the sun's azimuth and elevation (set directly, or
from latitude, day and solar time with :meth:`Sky.from_place`), a cloud cover and the clear sky's
maximum degree of polarisation. :meth:`Sky.light` returns a :class:`SkyLight` for any array of view
directions: the single-scattering Rayleigh sky (docs/parameters.md §11, each formula with its source).

World frame: x east, y north, z up; azimuths clockwise from north (+y), like headings: the direction
of azimuth a and elevation e is ``(sin a cos e, cos a cos e, sin e)``.

- **Degree** of polarisation ``(1 − cloud_cover) · max_degree · sin²γ / (1 + cos²γ)``, γ the angular
  distance from the sun: the single-scattering Rayleigh sky, maximal 90° from the sun, 0 at the sun
  and the antisun.
- **E-vector** along ``sun × direction`` (normalised): perpendicular to the plane through the sun, the
  observer and the point, hence perpendicular to the view direction and to the sun. Where it is
  undefined (at the sun and the antisun) any unit vector perpendicular to the view, with degree 0.
  Clouds leave it unchanged (the clear-sky pattern continues under clouds, Pomozi et al. 2001).
- **Radiance** (relative): the Rayleigh phase function ``(1 + cos²γ) / 2`` times the CIE clear-sky
  gradation ``φ(Z) / φ(0)``, ``φ(Z) = 1 − exp(−0.32 / cos Z)`` (Z the zenith angle), mixed with the CIE
  overcast sky ``(1 + 2 cos Z) / 3`` in proportion to the cloud cover.
- Below the horizon (z < 0): radiance 0, degree 0.

Occlusion (trees, walls seen against the sky) is cast by the backends; :meth:`SkyLight.occluded`
blanks the blocked directions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from neuronav.errors import ConfigError, real_or_nan

# The clear sky's maximum degree of polarisation, 90° from the sun: clear skies reach 0.7-0.8 at best
# (docs/parameters.md §11).
MAX_DEGREE = 0.75
# The CIE clear-sky luminance gradation φ(Z) = 1 + a exp(b / cos Z) (CIE S 011/E:2003, gradation of the
# standard clear sky, types 11-13; Kittler et al. 1997): the sky brightens towards the horizon.
CIE_CLEAR_A = -1.0
CIE_CLEAR_B = -0.32
# Spencer 1971's Fourier series of the solar declination (rad) in the day angle Γ = 2π (n − 1) / 365.
SPENCER_DECLINATION = (0.006918, -0.399912, 0.070257, -0.006758, 0.000907, -0.002697, 0.00148)
# Below this |cross(sun, direction)| the e-vector is undefined (sun or antisun): degree 0.
_PARALLEL = 1e-12


@dataclass(frozen=True)
class SkyLight:
    """What the sky sends along each view direction.

    Attributes
    ----------
    radiance : ndarray, shape (...)
        Relative radiance (1 at the zenith of a clear sky with the sun overhead); 0 below the horizon.
    degree : ndarray, shape (...)
        Degree of polarisation in [0, 1]; 0 below the horizon, at the sun and at the antisun.
    evector : ndarray, shape (..., 3)
        Unit e-vector (the polarisation's electric-field axis; its sign means nothing) in the world
        frame, perpendicular to the view direction.
    """

    radiance: np.ndarray
    degree: np.ndarray
    evector: np.ndarray

    def occluded(self, mask) -> SkyLight:
        """This light with radiance and degree 0 where ``mask`` is True (the sky is blocked there).

        Parameters
        ----------
        mask : array_like of bool
            Broadcastable to the leading shape (...) of the light: True where something blocks the sky.

        Returns
        -------
        SkyLight
            A new light; the e-vectors are kept (they are unit vectors wherever the degree is 0).
        """
        blocked = np.asarray(mask)
        if blocked.dtype != bool:
            raise ConfigError(f"sky light occluded: mask must be booleans, got dtype {blocked.dtype}")
        try:
            blocked = np.broadcast_to(blocked, self.degree.shape)
        except ValueError:
            raise ConfigError(f"sky light occluded: mask of shape {blocked.shape} does not broadcast to the "
                              f"light's shape {self.degree.shape}") from None
        return SkyLight(radiance=np.where(blocked, 0.0, self.radiance), degree=np.where(blocked, 0.0, self.degree),
                        evector=self.evector)


@dataclass(frozen=True)
class Sky:
    """The sun's position and the state of the sky.

    Parameters
    ----------
    sun_azimuth_rad : float
        The sun's azimuth, clockwise from north (+y), any finite number; kept wrapped to [0, 2π).
    sun_elevation_rad : float
        The sun's elevation above the horizon, in [0, π/2] (no night sky).
    cloud_cover : float
        Fraction of the sky under cloud, in [0, 1]: scales the degree of polarisation by
        ``1 − cloud_cover`` (the e-vector pattern persists, Pomozi et al. 2001) and mixes the radiance
        towards the uniform-in-azimuth overcast sky.
    max_degree : float
        The clear sky's degree of polarisation 90° from the sun, in (0, 1]
        (:data:`MAX_DEGREE`, docs/parameters.md §11).
    """

    sun_azimuth_rad: float = 0.0
    sun_elevation_rad: float = math.pi / 6
    cloud_cover: float = 0.0
    max_degree: float = MAX_DEGREE

    def __post_init__(self) -> None:
        azimuth = real_or_nan(self.sun_azimuth_rad)
        if not np.isfinite(azimuth):
            raise ConfigError(f"sky sun_azimuth_rad must be a finite number (rad, clockwise from north), "
                              f"got {self.sun_azimuth_rad!r}")
        azimuth = azimuth % (2.0 * math.pi)
        object.__setattr__(self, "sun_azimuth_rad", 0.0 if azimuth >= 2.0 * math.pi else azimuth)
        if not 0.0 <= real_or_nan(self.sun_elevation_rad) <= math.pi / 2:
            raise ConfigError(f"sky sun_elevation_rad must be in [0, pi/2] (rad above the horizon), "
                              f"got {self.sun_elevation_rad!r}")
        if not 0.0 <= real_or_nan(self.cloud_cover) <= 1.0:
            raise ConfigError(f"sky cloud_cover must be in [0, 1], got {self.cloud_cover!r}")
        if not 0.0 < real_or_nan(self.max_degree) <= 1.0:
            raise ConfigError(f"sky max_degree must be in (0, 1] (degree of polarisation 90 deg from the sun), "
                              f"got {self.max_degree!r}")
        for label in ("sun_elevation_rad", "cloud_cover", "max_degree"):
            object.__setattr__(self, label, float(getattr(self, label)))

    @classmethod
    def from_place(cls, latitude_deg: float, day_of_year: float, solar_hour: float, **rest) -> Sky:
        """The sky at a place, day and local solar time.

        The declination δ from Spencer 1971's Fourier series in the day angle Γ = 2π (n − 1) / 365, the
        hour angle H = 15° (solar_hour − 12), then ``sin e = sin φ sin δ + cos φ cos δ cos H`` and the
        azimuth ``atan2(−cos δ sin H, sin δ cos φ − cos δ sin φ cos H)`` clockwise from north (the
        standard horizontal coordinates, e.g. Duffie & Beckman 2013, ch. 1).

        Parameters
        ----------
        latitude_deg : float
            Geographic latitude φ in [−90, 90] (north positive).
        day_of_year : float
            Day n in [1, 366] (1: 1 January; a fraction is a time within the day's declination).
        solar_hour : float
            Local apparent solar time in [0, 24] hours (12: the sun on the meridian).
        **rest
            Further :class:`Sky` fields (``cloud_cover``, ``max_degree``).

        Raises
        ------
        ConfigError
            A value out of range, or the sun below the horizon at that place and time.
        """
        if not -90.0 <= real_or_nan(latitude_deg) <= 90.0:
            raise ConfigError(f"sky latitude_deg must be in [-90, 90], got {latitude_deg!r}")
        if not 1.0 <= real_or_nan(day_of_year) <= 366.0:
            raise ConfigError(f"sky day_of_year must be in [1, 366], got {day_of_year!r}")
        if not 0.0 <= real_or_nan(solar_hour) <= 24.0:
            raise ConfigError(f"sky solar_hour must be in [0, 24] (local solar time, h), got {solar_hour!r}")
        azimuth_rad, elevation_rad = sun_position(float(latitude_deg), float(day_of_year), float(solar_hour))
        if elevation_rad < 0.0:
            raise ConfigError(f"sky from_place: the sun is {-math.degrees(elevation_rad):.2f} deg below the horizon "
                              f"at latitude {latitude_deg} deg, day {day_of_year}, {solar_hour} h solar time; "
                              f"the sky model needs daylight")
        return cls(sun_azimuth_rad=azimuth_rad, sun_elevation_rad=elevation_rad, **rest)

    @property
    def sun_direction(self) -> np.ndarray:
        """Unit vector towards the sun in the world frame, shape (3,) (a copy: the sky keeps its own)."""
        return self._sun.copy()

    @cached_property
    def _sun(self) -> np.ndarray:
        """The sun's unit vector, computed once per sky (read-only)."""
        sun = direction(self.sun_azimuth_rad, self.sun_elevation_rad)
        sun.setflags(write=False)
        return sun

    @cached_property
    def _sun_cross(self) -> np.ndarray:
        """``S`` with ``views @ S == cross(sun, views)`` (the transposed cross-product matrix of the sun)."""
        x, y, z = self._sun
        cross = np.array([[0.0, z, -y], [-z, 0.0, x], [y, -x, 0.0]])
        cross.setflags(write=False)
        return cross

    @cached_property
    def _degree_scale(self) -> float:
        """``(1 − cloud_cover) · max_degree``: the degree of polarisation 90° from the sun."""
        return (1.0 - self.cloud_cover) * self.max_degree

    def light(self, directions) -> SkyLight:
        """Radiance, degree of polarisation and e-vector along each view direction.

        Parameters
        ----------
        directions : array_like, shape (..., 3)
            View directions in the world frame (x east, y north, z up), any leading shape; normalised
            here (each must be finite and non-zero).

        Returns
        -------
        SkyLight
            Arrays of the leading shape (...) (``evector``: (..., 3)).
        """
        views = _unit_directions(directions)
        cos_gamma = np.clip(views @ self._sun, -1.0, 1.0)
        cross = views @ self._sun_cross  # sun × view, one product for all three components
        cross_norm = np.sqrt(np.einsum("...i,...i->...", cross, cross))
        defined = cross_norm > _PARALLEL
        if defined.all():
            evector = cross / cross_norm[..., None]
        else:
            evector = cross / np.where(defined, cross_norm, 1.0)[..., None]
            evector[~defined] = _any_perpendicular(views[~defined])
        cos2_gamma = cos_gamma * cos_gamma
        z = views[..., 2]
        above = z >= 0.0
        sin2_gamma = np.clip(1.0 - cos2_gamma, 0.0, 1.0)
        degree = np.where(above & defined, self._degree_scale * sin2_gamma / (1.0 + cos2_gamma), 0.0)
        cos_zenith = np.where(z > 0.0, np.minimum(z, 1.0), 0.0)  # never −0: φ finite
        radiance = (0.5 / _GRADATION_ZENITH) * (1.0 + cos2_gamma) * _gradation(cos_zenith)  # the clear sky
        if self.cloud_cover:
            radiance = (1.0 - self.cloud_cover) * radiance + self.cloud_cover * (1.0 + 2.0 * cos_zenith) / 3.0
        radiance = np.where(above, radiance, 0.0)
        return SkyLight(radiance=radiance, degree=degree, evector=evector)

    def analysed_degree(self, views: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """The degree of polarisation as analysers see it, ``P cos 2(φ_e − φ_a)``, without the e-vectors.

        For a unit view ``d`` and a unit analyser axis ``a`` across it, with ``n = d × a``: the Rayleigh
        e-vector ``e = (s × d) / sin γ`` (s the sun, γ the angle from it) gives ``cos(φ_e − φ_a) = e · a =
        s · n / sin γ``, so ``P cos 2(φ_e − φ_a) = P (2 (s · n)² / sin²γ − 1)
        = (1 − cloud_cover) max_degree (2 (s · n)² − sin²γ) / (1 + cos²γ)``: the same number as
        ``degree · (2 (evector · a)² − 1)`` from :meth:`light` to rounding (0 below the horizon; at the
        sun and the antisun, where :meth:`light` gives degree 0, within rounding of 0), in a few array
        operations.
        What :class:`~neuronav.senses.dorsal_rim.DorsalRim` reads, one ray per ommatidium.

        Parameters
        ----------
        views : ndarray, shape (..., 3)
            Unit view directions in the world frame (not checked nor normalised here).
        normals : ndarray, shape (..., 3)
            Unit ``view × axis`` of each analyser axis (perpendicular to its view), world frame.

        Returns
        -------
        ndarray, shape (...)
            In [−P, P]; positive where the e-vector lies nearer the analyser axis than across it.
        """
        cos_gamma = views @ self._sun
        along = normals @ self._sun
        cos2_gamma = cos_gamma * cos_gamma
        value = (2.0 * along * along + cos2_gamma - 1.0) / (1.0 + cos2_gamma)  # (2 (s · n)² − sin²γ) / (1 + cos²γ)
        return np.where(views[..., 2] >= 0.0, self._degree_scale * value, 0.0)


def direction(azimuth_rad, elevation_rad) -> np.ndarray:
    """Unit vectors of azimuth (clockwise from north) and elevation: ``(sin a cos e, cos a cos e, sin e)``.

    Parameters
    ----------
    azimuth_rad, elevation_rad : float or array_like
        Angles (rad), broadcast against each other.

    Returns
    -------
    ndarray, shape (..., 3)
    """
    azimuth, elevation = np.broadcast_arrays(np.asarray(azimuth_rad, dtype=float),
                                             np.asarray(elevation_rad, dtype=float))
    return np.stack([np.sin(azimuth) * np.cos(elevation), np.cos(azimuth) * np.cos(elevation), np.sin(elevation)],
                    axis=-1)


def solar_declination_rad(day_of_year: float) -> float:
    """The sun's declination (rad) on day ``day_of_year`` (1: 1 January), Spencer 1971's series
    (its maximum error is usually quoted as 0.0006 rad)."""
    gamma = 2.0 * math.pi * (day_of_year - 1.0) / 365.0
    c = SPENCER_DECLINATION
    return (c[0] + c[1] * math.cos(gamma) + c[2] * math.sin(gamma) + c[3] * math.cos(2 * gamma)
            + c[4] * math.sin(2 * gamma) + c[5] * math.cos(3 * gamma) + c[6] * math.sin(3 * gamma))


def sun_position(latitude_deg: float, day_of_year: float, solar_hour: float) -> tuple[float, float]:
    """The sun's (azimuth clockwise from north in [0, 2π), elevation) in rad; the elevation is
    negative at night. See :meth:`Sky.from_place` for the formulas."""
    latitude = math.radians(latitude_deg)
    declination = solar_declination_rad(day_of_year)
    hour_angle = math.radians(15.0 * (solar_hour - 12.0))
    east = -math.cos(declination) * math.sin(hour_angle)
    north = (math.sin(declination) * math.cos(latitude)
             - math.cos(declination) * math.sin(latitude) * math.cos(hour_angle))
    up = math.sin(latitude) * math.sin(declination) + math.cos(latitude) * math.cos(declination) * math.cos(hour_angle)
    elevation = math.asin(max(-1.0, min(1.0, up)))
    azimuth = math.atan2(east, north) % (2.0 * math.pi)
    return (0.0 if azimuth >= 2.0 * math.pi else azimuth), elevation


def _gradation(cos_zenith):
    """CIE clear-sky gradation φ(Z) = 1 + a exp(b / cos Z); 1 at the horizon (cos Z = 0)."""
    with np.errstate(divide="ignore"):
        return 1.0 + CIE_CLEAR_A * np.exp(CIE_CLEAR_B / cos_zenith)


_GRADATION_ZENITH = float(_gradation(np.float64(1.0)))  # φ(0), the zenith's: the clear sky's gradation is φ(Z) / φ(0)


def _unit_directions(directions) -> np.ndarray:
    """``directions`` as finite unit vectors, shape (..., 3), or a ConfigError."""
    try:
        views = np.asarray(directions, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError("sky light: directions must be an array of numbers of shape (..., 3)") from None
    if views.ndim == 0 or views.shape[-1] != 3:
        raise ConfigError(f"sky light: directions must have shape (..., 3), got {views.shape}")
    norms = np.linalg.norm(views, axis=-1)
    if not (np.isfinite(norms).all() and (norms > 0).all()):
        raise ConfigError("sky light: every direction must be finite and non-zero")
    return views / norms[..., None]


def _any_perpendicular(views: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each unit view: ``z × view`` normalised, or x for a vertical view."""
    side = np.stack([-views[..., 1], views[..., 0], np.zeros(views.shape[:-1])], axis=-1)
    norm = np.linalg.norm(side, axis=-1)
    vertical = norm <= _PARALLEL
    return np.where(vertical[..., None], np.array([1.0, 0.0, 0.0]), side / np.where(vertical, 1.0, norm)[..., None])
