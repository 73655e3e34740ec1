"""Stone et al. 2017's path-integration model, hand-written in plain numpy for one agent.

This is the "obvious" implementation a researcher would write (close to the structure of Stone's
own ``cx_rate.py``): one :class:`numpy.random.Generator`, one ``rng.normal`` call per population,
small weight matrices built once and applied with ``@``. It has two jobs:

- validation: with noise off it must give the same numbers as the graph-built, compiled
  :func:`neuronav.brains.cx.stone2017` (``tests/unit/test_cx_reference.py``);
- the baseline of ``benchmarks/circuit_step.py``, which the compiled circuit must match or beat.

It deliberately shares no code or constants with ``brains/cx.py``: every number is copied here from
``docs/parameters.md``§3, so a change to either implementation's equations shows up as a
mismatch in the test.

Conventions: heading in radians, clockwise from +y (moving at heading θ means velocity along
(sin θ, cos θ)); velocity world-frame (vx, vy); the returned motor (rad) is added to the heading.
"""

from __future__ import annotations

import numpy as np

N_COLUMNS = 8
# Sigmoid slope a and bias b of r = clip(σ(a·I − b) + noise, 0, 1), docs/parameters.md §3.
TL2_SLOPE, TL2_BIAS = 6.8, 3.0
CL1_SLOPE, CL1_BIAS = 3.0, -0.5
TB1_SLOPE, TB1_BIAS = 5.0, 0.0
CPU4_SLOPE, CPU4_BIAS = 5.0, 2.5
PONTINE_SLOPE, PONTINE_BIAS = 5.0, 2.5
CPU1_SLOPE, CPU1_BIAS = 7.5, -1.0
# TB1 input mixes CL1 (this step) and TB1 (previous step).
PROP_CL1, PROP_TB1 = 0.667, 0.333
# CPU4 memory: gain h per step, leak h·k per step, initial value.
CPU4_GAIN, CPU4_LEAK, CPU4_INITIAL = 0.0025, 0.125, 0.5
TN_PREFERENCE_RAD = np.pi / 4
MOTOR_GAIN = 0.25


def _sigmoid(x: np.ndarray, slope: float, bias: float) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-(slope * x - bias)))


class StoneNumpy:
    """One agent of Stone et al. 2017's CX path integrator (with Pontine cells), in plain numpy.

    Parameters
    ----------
    noise : float
        Standard deviation of the Gaussian noise added to every population's rates (TL2, CL1,
        TB1, TN1, TN2, CPU4, Pontine, CPU1) before clipping into [0, 1].
    seed : int
        Seed of the agent's :class:`numpy.random.Generator`.

    Attributes
    ----------
    tl2, cl1 : ndarray, shape (16,)
    tb1 : ndarray, shape (8,)
        Also the TB1 -> TB1 inhibition's source on the next step.
    tn1, tn2 : ndarray, shape (2,)
        Speed along heading + 45° (index 0) and heading − 45° (index 1).
    cpu4_memory : ndarray, shape (16,)
        The integrator memory in [0, 1].
    cpu4, pontine, cpu1 : ndarray, shape (16,)
    motor : float
        The last motor output (rad to add to the heading).
    """

    def __init__(self, noise: float = 0.1, seed: int = 0) -> None:
        self.noise = float(noise)
        self.seed = seed
        columns = np.arange(16) % N_COLUMNS
        self.preferred_rad = columns * (2.0 * np.pi / N_COLUMNS)

        # CL1 (16) -> TB1 (8): TB1_j sums CL1_j and CL1_{j+8}.
        self.w_cl1_tb1 = np.zeros((8, 16))
        self.w_cl1_tb1[columns, np.arange(16)] = 1.0
        # TB1 -> TB1 inhibition: W_ij = (1 − cos(2π(j − i)/8)) / 2.
        i, j = np.meshgrid(np.arange(8), np.arange(8), indexing="ij")
        self.w_tb1_tb1 = (1.0 - np.cos(2.0 * np.pi * (j - i) / N_COLUMNS)) / 2.0  # [i, j]: from i to j
        # TB1 (8) -> CPU4/CPU1 (16): cell j reads column j mod 8.
        self.w_tb1_cpu = np.zeros((16, 8))
        self.w_tb1_cpu[np.arange(16), columns] = 1.0
        # TN2 (2) -> CPU4 (16): cells 0–7 from TN2[0], 8–15 from TN2[1].
        self.w_tn2_cpu4 = np.zeros((16, 2))
        self.w_tn2_cpu4[:8, 0] = 1.0
        self.w_tn2_cpu4[8:, 1] = 1.0
        # CPU4 -> CPU1 and Pontine -> CPU1: CPU1_j reads CPU4 c(j) and Pontine p(j).
        self.w_cpu4_cpu1 = np.zeros((16, 16))
        self.w_pontine_cpu1 = np.zeros((16, 16))
        for cell in range(16):
            if cell < N_COLUMNS:
                c, p = 8 + (cell - 1) % 8, 8 + (cell + 3) % 8
            else:
                c, p = (cell - 7) % 8, (cell - 3) % 8
            self.w_cpu4_cpu1[cell, c] = 1.0
            self.w_pontine_cpu1[cell, p] = 1.0
        self.w_cpu1_motor = MOTOR_GAIN * np.r_[np.ones(8), -np.ones(8)]
        self.tn_offsets_rad = np.array([TN_PREFERENCE_RAD, -TN_PREFERENCE_RAD])
        self.reset()

    def reset(self) -> None:
        """Zero every rate, set the CPU4 memory to 0.5 and restart the noise generator."""
        self.rng = np.random.default_rng(self.seed)
        self.tl2 = np.zeros(16)
        self.cl1 = np.zeros(16)
        self.tb1 = np.zeros(8)
        self.tn1 = np.zeros(2)
        self.tn2 = np.zeros(2)
        self.cpu4_memory = np.full(16, CPU4_INITIAL)
        self.cpu4 = np.clip(_sigmoid(self.cpu4_memory, CPU4_SLOPE, CPU4_BIAS), 0.0, 1.0)
        self.pontine = np.zeros(16)
        self.cpu1 = np.zeros(16)
        self.motor = 0.0

    def _noisy(self, rates: np.ndarray) -> np.ndarray:
        """Add N(0, noise²) to ``rates`` and clip into [0, 1]."""
        if self.noise > 0:
            rates = rates + self.rng.normal(0.0, self.noise, rates.shape)
        return np.clip(rates, 0.0, 1.0)

    def step(self, heading_rad: float, velocity: np.ndarray) -> float:
        """Advance one step and return the motor output (rad to add to the heading).

        Parameters
        ----------
        heading_rad : float
            Heading, clockwise from +y.
        velocity : ndarray, shape (2,)
            World-frame (vx, vy), distance units per step.
        """
        # Compass: TL2 -> CL1 -> TB1 (TB1 -> TB1 reads the previous step's TB1).
        self.tl2 = self._noisy(_sigmoid(np.cos(heading_rad - self.preferred_rad), TL2_SLOPE, TL2_BIAS))
        self.cl1 = self._noisy(_sigmoid(-self.tl2, CL1_SLOPE, CL1_BIAS))
        tb1_input = PROP_CL1 * (self.w_cl1_tb1 @ self.cl1) - PROP_TB1 * (self.tb1 @ self.w_tb1_tb1)
        self.tb1 = self._noisy(_sigmoid(tb1_input, TB1_SLOPE, TB1_BIAS))

        # Speed: velocity projected on heading ± 45°.
        directions = heading_rad + self.tn_offsets_rad
        flow = np.sin(directions) * velocity[0] + np.cos(directions) * velocity[1]
        self.tn1 = self._noisy((1.0 - flow) / 2.0)
        self.tn2 = self._noisy(flow)

        # Memory: m ← clip(m + h·clip(TN2 − TB1, 0, 1) − h·k, 0, 1).
        drive = np.clip(self.w_tn2_cpu4 @ self.tn2 - self.w_tb1_cpu @ self.tb1, 0.0, 1.0)
        self.cpu4_memory = np.clip(self.cpu4_memory + CPU4_GAIN * drive - CPU4_GAIN * CPU4_LEAK, 0.0, 1.0)
        self.cpu4 = self._noisy(_sigmoid(self.cpu4_memory, CPU4_SLOPE, CPU4_BIAS))

        # Steering: compare memory with heading.
        self.pontine = self._noisy(_sigmoid(self.cpu4, PONTINE_SLOPE, PONTINE_BIAS))
        cpu1_input = (0.5 * (self.w_cpu4_cpu1 @ self.cpu4) - 0.5 * (self.w_pontine_cpu1 @ self.pontine)
                      - self.w_tb1_cpu @ self.tb1)
        self.cpu1 = self._noisy(_sigmoid(cpu1_input, CPU1_SLOPE, CPU1_BIAS))
        self.motor = float(self.w_cpu1_motor @ self.cpu1)
        return self.motor
