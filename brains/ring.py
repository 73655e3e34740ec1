"""Ring attractor for optimal cue integration: Sun et al. 2018/2020, as a graph.

Every fixed number comes from ``docs/parameters.md``§4 (Sun et al. 2018, "An analysis of a
ring attractor model for cue integration"; Sun et al. 2020, eLife 9:e54026): N excitatory cells
``E`` on a ring and one inhibitory cell ``I``,

    tau_E dc_i/dt = -c_i + [gamma_E + sum_j W_EE,ij c_j + W_EI u + cue_i]_+
    tau_I du/dt   = -u   + [gamma_I + W_IE sum_j c_j + W_II u]_+

with W_EE,ij = (45 / N) exp(-d_ij^2 / (2 sigma^2)), W_IE = 60 / N, W_EI = -6, W_II = -1,
gamma_E = -1.5, gamma_I = -7.5, tau_E = 5 ms, tau_I = 0.25 ms, stepped at 0.1 ms (:data:`DT_S`).
Cell i prefers the angle ``2 pi i / N``.

Integration: semi-implicit Euler. Every connection is delayed (reads the state at the start of the
step) except E -> I: each step first updates E from the old E and u by Euler, then u from the *new*
E and the old u. Plain explicit Euler (E -> I delayed too) is not stable at 0.1 ms: linearised at
the cue-off bump (11 E cells active), the E–I loop is a damped oscillation with eigenvalues
-2670 ± 8400i /s (period 0.75 ms), and Euler keeps such a pair only for dt < -2 Re λ / |λ|² = 69 µs.
So after the cue is switched off the I cell swings between 0.59 and 0.94 for ever (peak-to-peak
0.36, period 0.86 ms) instead of resting at 0.7321. Measured on the cue-off state (a 40° cue at 0°
for 0.2 s, then 0.5 s without cue; peak-to-peak of u over the last 20 ms), explicit Euler is steady up to 65 µs (0 at 50
and 65 µs) and swings from 70 µs (0.037; 0.36 at 100 µs, 0.55 at 125 µs); the semi-implicit step
is steady at 100 and 125 µs (peak-to-peak 0 and 5e-15) and, in a hand-written numpy copy, up to
140 µs, swinging from 150 µs (0.20). Compile refuses steps longer than tau_I / 2 = 125 µs, so every
step it accepts is stable for this circuit (a coincidence of these parameters, not a guarantee of
that check). Exponential Euler for the leak (``r += (1 - exp(-dt/tau)) (f - r)``) does not help: it
treats each cell's own decay exactly but not the E–I coupling, and swings even more (0.41 at
0.1 ms). The fixed points are those of the equations for any step (the step only changes how they
are approached); the tests compare against a hand-written semi-implicit Euler and a 25 µs step.

What the paper leaves open, and the values chosen here (tuned with the test in
``tests/unit/test_ring_attractor.py``: two equal cues at 90° (sigma 40°) and 155° (sigma 35°),
whose inverse-variance weighted mean is 126.8°):

- ``N = 32`` cells (:data:`N_CELLS`). The decoded bump is quantised by the grid at small N: with
  N = 8 a single cue is tracked only to within ~10°, with N = 16 to within ~3°, with N = 32 to
  within 1° at any angle. The two-cue bump settles at 127.0° for N = 32 (127.8°, 128.5°, 127.3°
  and 127.2° for N = 8, 16, 64 and 128). For comparison, the summed cue itself peaks at 132.0° and
  its population vector points at 121.1°: the attractor, not the cue, does the combining.
- ``sigma = 125°`` for W_EE (:data:`SIGMA_RAD`), the middle of the paper's 120–130°. The two-cue
  bump moves by about 0.2° across that range (127.1° at 120°, 126.9° at 130°).
- Cue peak amplitude 3 (:data:`CUE_AMPLITUDE`): a cue must exceed -gamma_E = 1.5 to ignite a bump
  in a silent network; amplitude 3 is twice that. The two-cue bump lies at 126.1° for amplitude 2,
  127.0° for 3, 127.8° for 4 and 128.6° for 5 (the stronger the cues, the more the bump follows the
  peak of the summed cues rather than the attractor's own, near-optimal, combination). A single cue
  (sigma 10–60°) is tracked to within 0.8° at any angle.
- Initial state: silent (all rates 0). With uniform initial rates the symmetric state carries no
  angle; starting silent, the cues alone decide where the bump forms.
- Settling time 0.2 s (:data:`SETTLE_S`, 2000 steps of 0.1 ms): the bump is within 0.01° of its
  fixed point after 0.05 s and within 1e-5° after 0.1 s. Without cues the bump persists (it is an
  attractor), and when the cue jumps elsewhere the bump follows it.

Without a cue the bump does not stay where the cue left it: it drifts to the nearest *midpoint
between two cells*, ``2 pi (i + 1/2) / N`` (10 cells active there, against 11 for a bump centred on
a cell). For N = 32 these lie at 5.625° + k 11.25°. A 40° cue at 17° leaves the bump at 16.97°; 1 s
after the cue is switched off it is at 16.875° (0.125° from the cue) and stays there (same at 3 s).
Cues at 12°, 14°, 16°, 19° and 21° all end at 16.875° within 1 s, so the remembered heading is
quantised to the 11.25° grid of midpoints, up to 5.6° off. A cell's own angle is an equilibrium too,
but an unstable one (the linearisation there has an eigenvalue of +18 /s): a cue at exactly 22.5°,
45° or 90° leaves the bump there for 1 s and on a neighbouring midpoint after 3 s (28.125°, 50.625°,
84.375°; the side is set by rounding). The same with a 25 µs step and with a hand-written explicit
Euler of the equations at 20 µs (17° -> 16.875°). The earlier explicit 0.1 ms step, whose I cell
oscillated, drifted to the nearest cell instead (17° -> 22.5° after 3 s): an artefact of the
oscillation. Measured with::

    python -c "import numpy as np; from neuronav.brains.ring import *; s = ring_attractor().compile(batch=1); \\
    settle(s, gaussian_cue(np.deg2rad(17), np.deg2rad(40))); \\
    print(np.rad2deg(settle(s, np.zeros(N_CELLS), duration_s=3.0)))"

(it prints [16.875]); ``tests/unit/test_ring_attractor.py`` checks it.
"""

from __future__ import annotations

import numpy as np

from neuronav import Circuit, ConfigError, PortError, SensorSpec
from neuronav.angles import angle_difference_rad

N_CELLS = 32
MAX_CELLS = 10_000  # ring_attractor's bound: its n_cells² E -> E weights stay under 800 MB
SIGMA_RAD = float(np.deg2rad(125.0))
CUE_AMPLITUDE = 3.0
DT_S = 1e-4
SETTLE_S = 0.2
TAU_E_S = 5e-3
TAU_I_S = 2.5e-4


def cell_angles_rad(n_cells: int = N_CELLS) -> np.ndarray:
    """Preferred angles of the excitatory cells, ``2 pi i / n_cells``, shape (n_cells,)."""
    return 2.0 * np.pi * np.arange(n_cells) / n_cells


def cues_port(n_cells: int = N_CELLS) -> SensorSpec:
    """The sensor port the ring reads: one cue strength per excitatory cell."""
    return SensorSpec("cues", (n_cells,), "")


def ring_attractor(
    n_cells: int = N_CELLS,
    sigma_rad: float = SIGMA_RAD,
    w_ee: float = 45.0,
    w_ie: float = 60.0,
    w_ei: float = -6.0,
    w_ii: float = -1.0,
    gamma_e: float = -1.5,
    gamma_i: float = -7.5,
    tau_e_s: float = TAU_E_S,
    tau_i_s: float = TAU_I_S,
    initial_e: float = 0.0,
    initial_i: float = 0.0,
    name: str = "ring_attractor",
) -> Circuit:
    """Sun et al.'s ring attractor: ``n_cells`` excitatory cells ``E`` and one inhibitory cell ``I``.

    Compile it (``compile`` defaults to ``dt_s=DT_S``, 0.1 ms, the paper's step, and refuses
    steps longer than half of tau_I; see the module docstring for why E -> I is undelayed) and step
    it with the cue vector on the ``cues`` port for about :data:`SETTLE_S`; read the bump with
    :func:`bump_heading_rad` (or do both with :func:`settle`).

    Parameters
    ----------
    n_cells : int
        Number of excitatory cells N (4 to :data:`MAX_CELLS`).
    sigma_rad : float
        Width of the Gaussian E -> E weight profile (the paper: 120–130°).
    w_ee : float
        Peak E -> E weight times N: ``W_EE,ij = (w_ee / N) exp(-d_ij^2 / (2 sigma^2))``.
    w_ie : float
        E -> I weight times N: ``W_IE = w_ie / N`` from every E cell.
    w_ei, w_ii : float
        I -> E and I -> I weights (negative: inhibitory).
    gamma_e, gamma_i : float
        Constant drive (bias) of the E cells and of the I cell.
    tau_e_s, tau_i_s : float
        Time constants of the E cells and of the I cell, seconds.
    initial_e, initial_i : float
        Rates at reset (uniform over the E cells).
    name : str
        Circuit name.

    Returns
    -------
    Circuit
        Reads ``cues`` (shape (n_cells,), dimensionless; added to the E cells' net input); writes
        no motor port. Populations: ``cue_in`` (input), ``E`` (leaky, relu, n_cells), ``I``
        (leaky, relu, 1).

    Raises
    ------
    ConfigError
        When ``n_cells`` or ``sigma_rad`` or a time constant is out of range.
    """
    # At most MAX_CELLS: the dense E -> E matrix (n_cells², float64) stays under 800 MB.
    if not isinstance(n_cells, (int, np.integer)) or isinstance(n_cells, bool) or not 4 <= n_cells <= MAX_CELLS:
        raise ConfigError(f"ring_attractor: n_cells must be an int in [4, {MAX_CELLS}], got {n_cells!r}")
    n_cells = int(n_cells)
    for label, value in (("sigma_rad", sigma_rad), ("tau_e_s", tau_e_s), ("tau_i_s", tau_i_s)):
        if not isinstance(value, (int, float, np.floating)) or not np.isfinite(value) or value <= 0:
            raise ConfigError(f"ring_attractor: {label} must be a finite number > 0, got {value!r}")
    circuit = Circuit(name, dt_s=DT_S)
    circuit.add_input("cue_in", n_cells, ports=[cues_port(n_cells)], encoder="identity")
    circuit.add_population("E", n_cells, kind="leaky", activation="relu", bias=float(gamma_e),
                           tau_s=float(tau_e_s), initial=float(initial_e))
    circuit.add_population("I", 1, kind="leaky", activation="relu", bias=float(gamma_i),
                           tau_s=float(tau_i_s), initial=float(initial_i))
    circuit.connect("cue_in", "E", rule="one_to_one")
    circuit.connect("E", "E", rule="gaussian_ring", rule_params={"sigma_rad": float(sigma_rad)},
                    gain=w_ee / n_cells, delay=True)
    circuit.connect("I", "E", weights=np.full((n_cells, 1), float(w_ei)), delay=True)
    # Undelayed: I reads this step's E (semi-implicit Euler), which keeps the E-I loop stable at 0.1 ms.
    circuit.connect("E", "I", rule="all_to_all", gain=w_ie / n_cells, delay=False)
    circuit.connect("I", "I", weights=[[float(w_ii)]], delay=True)
    return circuit


def gaussian_cue(
    centre_rad: float | np.ndarray, sigma_rad: float, n_cells: int = N_CELLS, amplitude: float = CUE_AMPLITUDE,
) -> np.ndarray:
    """A Gaussian-tuned cue on the ring: ``amplitude * exp(-d_i^2 / (2 sigma^2))``.

    ``d_i`` is the angular distance (wrapped into [-pi, pi]) between cell i's angle
    ``2 pi i / n_cells`` and the cue's centre. Sum several cues to present them together.

    Parameters
    ----------
    centre_rad : float or ndarray, shape (batch,)
        Direction the cue indicates.
    sigma_rad : float
        Tuning width of the cue (its uncertainty).
    n_cells : int
    amplitude : float
        Peak value.

    Returns
    -------
    ndarray, shape (n_cells,) for a scalar centre, (batch, n_cells) for an array of centres
    """
    if not np.isfinite(sigma_rad) or sigma_rad <= 0:
        raise ConfigError(f"gaussian_cue: sigma_rad must be a finite number > 0, got {sigma_rad!r}")
    centre = np.asarray(centre_rad, dtype=float)
    difference = angle_difference_rad(cell_angles_rad(n_cells), centre[..., None])
    return amplitude * np.exp(-(difference**2) / (2.0 * sigma_rad**2))


def bump_heading_rad(rates: np.ndarray) -> np.ndarray:
    """Population-vector decode of the E bump: the angle of ``sum_i c_i exp(i 2 pi i / N)``.

    Parameters
    ----------
    rates : ndarray, shape (batch, N) or (N,)
        Rates of the excitatory cells (``sim.rates("E")``).

    Returns
    -------
    ndarray, shape (batch,)
        Bump direction in (-pi, pi]; 0 when every rate is 0 (no bump).
    """
    rates = np.atleast_2d(np.asarray(rates, dtype=float))
    # Summed row by row, not a BLAS product: an agent's bump is then the same bit for bit in any batch.
    return np.angle((rates * np.exp(1j * cell_angles_rad(rates.shape[1]))).sum(axis=1))


def settle(sim, cues: np.ndarray, duration_s: float = SETTLE_S) -> np.ndarray:
    """Step a compiled ring attractor with constant ``cues`` for ``duration_s``; return the bump.

    Parameters
    ----------
    sim : CompiledCircuit
        A compiled :func:`ring_attractor` (compiled with ``dt_s``).
    cues : ndarray, shape (N,) or (batch, N)
        Broadcast over the batch.
    duration_s : float

    Returns
    -------
    ndarray, shape (batch,)
        :func:`bump_heading_rad` of the E rates at the end.
    """
    port = next((s for s in sim.sensors if s.name == "cues"), None)
    if port is None:
        raise PortError(f"circuit {sim.circuit.name!r} has no 'cues' port; is it a ring attractor?")
    cues = np.asarray(cues, dtype=sim.dtype)
    try:
        inputs = {"cues": np.ascontiguousarray(np.broadcast_to(cues, (sim.batch, *port.shape)))}
    except ValueError:
        raise PortError(
            f"settle: cues of shape {cues.shape} do not fit port 'cues' {port.shape} for a batch of {sim.batch}"
        ) from None
    for _ in range(int(round(duration_s / sim.dt_s))):
        sim.step(inputs)
    return bump_heading_rad(sim.rates("E"))
