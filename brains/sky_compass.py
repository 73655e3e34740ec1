"""A polarised-light sky compass that drives the central complex's TB1 cells, as a graph.

Cells, from the eye inward (Gkanias et al. 2019, PLoS Comput Biol 15:e1007123, whose SOL layer this
follows; the TB1 part as in :func:`neuronav.brains.cx.heading_circuit`):

- ``pol_in`` / POL (M, one per dorsal-rim ommatidium, :class:`~neuronav.senses.dorsal_rim.DorsalRim`):
  the POL-neurons' opponent responses read on the ``pol`` port (``DorsalRim.responses``), with
  Gaussian noise ``pol_noise`` per cell and step (linear cells).
- SOL (8): the compass layer. Cell j sums the POL cells with sinusoidal weights
  ``w_ji = (2 / M) cos(a_i + p_j) / A_ref``, a_i the head azimuth of ommatidium i (clockwise from
  forward: each POL cell prefers the e-vector along its own meridian, so its preferred angle is its
  azimuth) and p_j = j 45°; logistic with TL2's slope 6.8 and bias 3.0.
- CL1 (8, inverted SOL) and TB1 (8, with TB1 -> TB1 inhibition), with Stone et al. 2017's parameters
  (CL1 -> TB1 gain 2 x 0.667: the 8 CL1 cells stand for heading_circuit's 16, which come in pairs).

The 180° ambiguity. A POL cell's response depends on the e-vector's axis only, so around a ring of
ommatidia the response pattern is mainly a *second* harmonic of the azimuth, which cannot tell the
sun from the antisun. Its *first* harmonic comes from the degree of polarisation, which is
asymmetric about the zenith: a ring of ommatidia at elevation E sees the sun side at angular distance
|E − e_sun| from the sun and the antisolar side at 180° − E − e_sun, nearer 90° (where the degree is
largest) for any sun above the horizon. The meridian-parallel channel reads the e-vector at right
angles on the solar meridian, so the POL response there is most negative where the degree is
largest (antisolar side): the first harmonic of the pattern peaks on the sun's side. The SOL weights
keep the first harmonic only: with the sun at head azimuth b, cell j receives ``A cos(b + p_j)``, so
the SOL (and TB1) bump sits at ``-b`` = (heading − sun azimuth). The two eyes' rows are evenly spaced
round the full circle, so the second harmonic does not leak into the first, and the sky's mirror
symmetry about the solar meridian makes the phase exact on a level head without noise.
Limits: with the sun on the horizon or at the zenith the degree pattern is symmetric and the first
harmonic vanishes (A = 0): the compass carries no direction there (``scenarios/tools/sky_compass_error``
measures it); clouds scale the degree, hence A, down, and the POL noise then dominates.

Gain: ``A_ref`` is the first-harmonic amplitude ``A`` of a clear sky with the sun 30° high
(:func:`reference_amplitude`, computed from the rim when the circuit is built; 0.461 for the default
rim), and the SOL weights are multiplied by ``compass_gain`` (default 2): the SOL cells receive
``compass_gain (A / A_ref) cos(heading − sun_azimuth − p_j)``, i.e. TL2's drive when A is half the
reference. A / A_ref is 0.20, 0.58, 1.00, 1.11, 0.89, 0.32 for the sun at 5°, 15°, 30°, 45°, 60°, 80°
(clear sky) and scales with 1 − cloud_cover. A strong sky saturates SOL: a gain control by
saturation (the insect's compass neurons are insensitive to the degree of polarisation, Sakura et al.
2008, J Neurophysiol 99:667), which makes weak skies usable at the price of a bump quantised toward
the 45° columns. Measured with ``compass_errors_rad`` (no noise, headings 0–45°, sun 30°): largest
systematic error 6.8° at gain 2, 11.3° at gain 3, 12.2° at gain 4 (2.2° at gain 1); with the default
noise the trade-off over sun elevation and cloud cover is printed by
``python -m neuronav.scenarios.tools.sky_compass_error --compass-gain G`` (docs/parameters.md, sky section).

Convention: TB1's inverted bump (lowest cell) sits at the heading *relative to the sun*,
``heading − sun_azimuth`` (rad, clockwise). :func:`decode_heading` reads it; a scenario compares
``decode_heading(tb1) + sun_azimuth`` with the true heading through
:func:`neuronav.angles.angle_difference_rad`.
"""

from __future__ import annotations

import numpy as np

from neuronav import Circuit, SensorSpec
from neuronav.brains.cx import CPU4_GAIN, CPU4_LEAK, N_COLUMNS, memory_populations, preferred_headings_rad
from neuronav.errors import ConfigError, real_or_nan
from neuronav.senses.dorsal_rim import DorsalRim, head_rotations_from_headings
from neuronav.senses.sky import Sky

REFERENCE_SUN_ELEVATION_RAD = float(np.deg2rad(30.0))


def pol_port(rim: DorsalRim | None = None) -> SensorSpec:
    """The sensor port the compass reads: one POL response (log ratio, no unit) per ommatidium."""
    rim = DorsalRim() if rim is None else rim
    return SensorSpec("pol", (rim.n_ommatidia,), "")


def compass_weights(rim: DorsalRim) -> np.ndarray:
    """POL -> SOL weights before the gain, ``(2 / M) cos(a_i + p_j)``, shape (8, M)."""
    preferred = preferred_headings_rad(N_COLUMNS)
    return (2.0 / rim.n_ommatidia) * np.cos(rim.azimuths_rad[None, :] + preferred[:, None])


def reference_amplitude(rim: DorsalRim | None = None,
                        sun_elevation_rad: float = REFERENCE_SUN_ELEVATION_RAD) -> float:
    """The first-harmonic amplitude A of the POL pattern under a clear sky, level head (no noise).

    ``compass_weights(rim) @ responses`` is ``A cos(heading - sun_azimuth - p_j)``; A does not depend
    on the heading or the sun's azimuth.
    """
    rim = DorsalRim() if rim is None else rim
    sky = Sky(sun_azimuth_rad=0.0, sun_elevation_rad=sun_elevation_rad)
    responses = rim.responses(sky, head_rotations_from_headings(0.0))[0]
    drive = compass_weights(rim) @ responses
    return float(np.abs((drive * np.exp(1j * preferred_headings_rad(N_COLUMNS))).sum()) * 2.0 / N_COLUMNS)


def sky_compass(noise: float = 0.1, pol_noise: float = 0.1, rim: DorsalRim | None = None,
                compass_gain: float = 2.0, name: str = "sky_compass") -> Circuit:
    """The sky compass: ``pol`` -> POL -> SOL -> CL1 -> TB1 (with TB1 -> TB1).

    Parameters
    ----------
    noise : float
        Standard deviation of the Gaussian noise on SOL, CL1 and TB1 rates (as stone2017's ``noise``).
    pol_noise : float
        Standard deviation of the Gaussian noise on each POL cell's response (log-ratio units; the
        responses of the default rim lie within ±1.43).
    rim : DorsalRim, optional
        The dorsal rim whose responses feed the ``pol`` port (default ``DorsalRim()``, M = 160).
    compass_gain : float
        Multiplies the POL -> SOL weights (> 0; see the module docstring).
    name : str

    Returns
    -------
    Circuit
        Reads ``pol`` (shape (M,)); TB1's inverted bump sits at heading − sun azimuth
        (:func:`decode_heading`). No motor port.
    """
    for label, value in (("noise", noise), ("pol_noise", pol_noise)):
        if not 0.0 <= real_or_nan(value) < np.inf:
            raise ConfigError(f"sky_compass: {label} must be a finite number >= 0, got {value!r}")
    if not 0.0 < real_or_nan(compass_gain) < np.inf:
        raise ConfigError(f"sky_compass: compass_gain must be a finite number > 0, got {compass_gain!r}")
    rim = DorsalRim() if rim is None else rim
    if not isinstance(rim, DorsalRim):
        raise ConfigError(f"sky_compass: rim must be a DorsalRim, got {type(rim).__name__}")
    amplitude = reference_amplitude(rim)
    circuit = Circuit(name)
    noisy = dict(noise_std=noise, clip=(0.0, 1.0))
    circuit.add_input("pol_in", rim.n_ommatidia, ports=[pol_port(rim)], encoder="identity")
    circuit.add_population("POL", rim.n_ommatidia, noise_std=pol_noise)
    circuit.connect("pol_in", "POL", rule="one_to_one")
    circuit.add_population("SOL", N_COLUMNS, activation="logistic", params={"slope": 6.8, "bias": 3.0}, **noisy)
    circuit.connect("POL", "SOL", weights=compass_weights(rim) * (compass_gain / amplitude))
    circuit.add_population("CL1", N_COLUMNS, activation="logistic", params={"slope": 3.0, "bias": -0.5}, **noisy)
    circuit.add_population("TB1", N_COLUMNS, activation="logistic", params={"slope": 5.0, "bias": 0.0}, **noisy)
    circuit.connect("SOL", "CL1", rule="one_to_one", sign=-1)
    circuit.connect("CL1", "TB1", rule="one_to_one", gain=2 * 0.667)
    circuit.connect("TB1", "TB1", rule="cosine_ring", gain=0.333, sign=-1, delay=True)
    return circuit


def sky_stone2017(noise: float = 0.1, pol_noise: float = 0.1, rim: DorsalRim | None = None,
                  compass_gain: float = 2.0, memory_gain: float = CPU4_GAIN, memory_leak: float = CPU4_LEAK,
                  memory_initial: float = 0.5,
                  tn_offset_rad: float = np.pi / 4) -> Circuit:
    """Stone et al. 2017's path integration with the sky compass in place of the ``heading`` port.

    TB1 comes from :func:`sky_compass`; TN1/TN2 read ``body_velocity`` (:data:`neuronav.brains.cx.BODY_VELOCITY_PORT`,
    the body-frame (forward, left) displacement per step); CPU4, Pontine, CPU1 and ``motor`` are
    stone2017's (:func:`neuronav.brains.cx.memory_populations`). No true heading is read anywhere: the
    memory is kept in the sun-relative frame, so :func:`neuronav.brains.cx.decode_home_vector` gives
    the home direction relative to the sun's azimuth (add the sun azimuth for the world direction).

    Parameters
    ----------
    noise, pol_noise, rim, compass_gain
        As in :func:`sky_compass`.
    memory_gain, memory_leak, memory_initial, tn_offset_rad
        As in :func:`neuronav.brains.cx.stone2017`.

    Returns
    -------
    Circuit
        Reads ``pol`` (M,) and ``body_velocity`` (2,); writes ``motor`` (rad to add to the heading,
        positive = clockwise).
    """
    circuit = sky_compass(noise, pol_noise, rim, compass_gain, name="sky_stone2017")
    memory_populations(circuit, noise, memory_gain, memory_leak, memory_initial, tn_offset_rad, body_frame=True)
    return circuit


def decode_heading(tb1: np.ndarray) -> np.ndarray:
    """The heading TB1 stands for: the phase of the first harmonic of its inverted bump, batched.

    Parameters
    ----------
    tb1 : ndarray, shape (batch, 8) or (8,)

    Returns
    -------
    ndarray, shape (batch,)
        Radians, clockwise, in (-π, π]: for :func:`sky_compass`, heading − sun azimuth.
    """
    try:
        rates = np.atleast_2d(np.asarray(tb1, dtype=float))
    except (TypeError, ValueError):
        rates = np.zeros((0, 0))
    if rates.ndim != 2 or rates.shape[1] != N_COLUMNS:
        raise ConfigError(f"decode_heading: tb1 must be numbers of shape (batch, {N_COLUMNS}), got {rates.shape}")
    # TB1 is lowest in the heading's column: read the first harmonic of -TB1.
    return np.angle(-(rates * np.exp(1j * preferred_headings_rad(N_COLUMNS))).sum(axis=1))


def compass_errors_rad(sky: Sky, headings_rad: np.ndarray, noise: float = 0.1, pol_noise: float = 0.1,
                       rim: DorsalRim | None = None, compass_gain: float = 2.0, steps: int = 30,
                       average_steps: int = 10, seed: int = 0) -> np.ndarray:
    """Decoded-heading errors of the sky compass without a body, one agent per heading (level head).

    Each agent holds its heading for ``steps`` brain steps (TB1 settles in about 5); TB1's rates are
    averaged over the last ``average_steps`` (the noise is per step; CPU4 integrates TB1 over many
    steps too) and the error is ``decode_heading(mean TB1) − (heading − sun azimuth)`` wrapped to [-π, π].

    Returns
    -------
    ndarray, shape (len(headings_rad),)
    """
    rim = DorsalRim() if rim is None else rim
    headings = np.atleast_1d(np.asarray(headings_rad, dtype=float))
    pol = rim.responses(sky, head_rotations_from_headings(headings))
    if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= average_steps <= steps:
        raise ConfigError(f"compass_errors_rad: need ints 1 <= average_steps <= steps, "
                          f"got {average_steps!r}, {steps!r}")
    brain = sky_compass(noise, pol_noise, rim, compass_gain).compile(batch=headings.size, seed=seed)
    tb1 = np.zeros((headings.size, N_COLUMNS))
    for step in range(steps):
        brain.step({"pol": pol})
        if step >= steps - average_steps:
            tb1 += brain.rates("TB1")
    decoded = decode_heading(tb1 / average_steps)
    return np.angle(np.exp(1j * (decoded - (headings - sky.sun_azimuth_rad))))


__all__ = ["compass_errors_rad", "compass_weights", "decode_heading", "pol_port", "reference_amplitude",
           "sky_compass", "sky_stone2017"]
