"""Copy-and-shift steering (Sun et al. 2020; I2Bot's visual beacon): steer toward heading + s columns.

The current heading bump (TB1, 8 columns of 45°) is copied and rolled by ``s`` columns to make a
desired heading; Stone et al. 2017's steering circuit (Pontine, CPU1, ``motor``) then turns the
agent toward it, exactly as it turns the agent toward home from the CPU4 memory in
:func:`neuronav.brains.cx.stone2017`. The shift arrives on the sensor port ``shift`` (shape (1,), integer
columns, positive = clockwise = increasing heading).

The variable roll uses rate neurons only:

- ``shift_gate`` (input, 2·max_shift + 1 cells): a one-hot code of the shift, cell k on for
  s = k - max_shift.
- ``shifter`` (relu, 8 cells per allowed shift): cell (k, j) receives TB1_{(j - s_k) mod 8} +
  gate_k - 1. TB1 rates lie in [0, 1], so a cell passes TB1 when its gate is on and is silent
  otherwise.
- ``goal`` (16 cells, identity): cell j sums the shifter cells of column j mod 8 — the TB1 bump
  rolled by s, tiled over both hemispheres. It plays the role CPU4 plays in Stone's model.

The mapping, found by testing (``tests/unit/test_copy_and_shift.py``): the TB1 bump is fed as goal
*as is*, not inverted. TB1 is an inverted heading bump (lowest in the current heading's column),
and CPU4 is highest for the direction travelled out, i.e. opposite the way home; both therefore
peak half a turn away from the heading they stand for, and the rolled TB1 stands for heading +
45°·s the way CPU4 stands for the home direction. With ``heading += motor`` every step (heading
clockwise from +y), a positive shift gives a positive motor (a clockwise turn), a negative shift a
negative one, shift 0 a motor near 0 — the same sign convention as Stone's path integrator, where
``heading += motor`` turns the agent toward home. Feeding the inverted bump (1 - TB1) instead
makes the agent turn away from the desired heading.

Measured, settled (noise 0, 24 headings 15° apart, fixed heading and shift, stepped until the motor
changes by less than 1e-13 between steps, which takes 57 to 66 steps; TB1's delayed self-inhibition
is what takes that long), motor per step in rad:

    shift  1: +0.424 to +0.444
    shift  2: +0.414 to +0.416
    shift  3: +0.200 to +0.311
    shift  0: -0.007 to +0.007

and the mirror image for negative shifts: motor(-s, θ) = -motor(s, -θ), so the same ranges negated
(to 1e-12). The steering curve peaks at one column: a
shift of 1 turns faster than 2 at every heading, and 3 slower still. The response repeats every 45°
of heading (the 8-column code). Shift 0 leaves a small heading-dependent bias. A hand-written numpy
copy of the equations in ``tests/unit/test_copy_and_shift.py`` gives the same curve to 1e-13.
After only 5 steps the curve is different (1: 0.33–0.36, 2: 0.39–0.48, 3: 0.25–0.29): TB1 has not
settled yet, and it looks as if it grew up to two columns.

Closing the loop with ``heading += motor`` and ``shift = shift_toward(heading, target)`` every step
(targets 0, 1, -2.5 and π rad, 24 starts), the heading enters the dead band |heading - target| <=
22.5° (where the shift is 0) within 12 steps from every start. Inside it the shift-0 bias drifts it
slowly (at most 0.42° per step); at the band's edge the shift turns to ±1 for a step and throws it
back toward the target, so over 200 steps it stays within 22.86° of the target. With noise 0.1
(seed 2) it stays within 35° of the target from step 20 to 200. With the inverted goal it ends near
target + 180° instead (22 of 24 starts end within 26° of it; the two that start within 13° of the
target stay near it).

The allowed shifts are ±``max_shift`` (default 3): the ``shift`` port declares that range, so a
compiled circuit raises :class:`~neuronav.PortError` for a shift outside it or NaN (the
``one_hot`` encoder alone would clip it silently).
"""

from __future__ import annotations

import numpy as np

from neuronav import Circuit, ConfigError, SensorSpec
from neuronav.angles import angle_difference_rad
from neuronav.brains.cx import N_COLUMNS, heading_circuit, steering_populations

MAX_SHIFT = 3
COLUMN_RAD = 2.0 * np.pi / N_COLUMNS

def shift_port(max_shift: int = MAX_SHIFT) -> SensorSpec:
    """The ``shift`` sensor port: columns, rounded by the circuit, within ±(max_shift + 0.5)."""
    return SensorSpec("shift", (1,), "columns", range=(-max_shift - 0.5, max_shift + 0.5))


def shift_weights(max_shift: int = MAX_SHIFT) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weights of the variable roll: (TB1 -> shifter, gate -> shifter, shifter -> goal).

    Returns
    -------
    from_tb1 : ndarray, shape (8 K, 8)
        Shifter cell (k, j) = row ``8 k + j`` reads TB1 cell ``(j - s_k) mod 8``, s_k = k - max_shift.
    from_gate : ndarray, shape (8 K, K)
        Shifter cell (k, j) reads gate cell k.
    to_goal : ndarray, shape (16, 8 K)
        Goal cell i sums the shifter cells (k, i mod 8) over k.
    """
    shifts = np.arange(-max_shift, max_shift + 1)
    n_gates = shifts.size
    from_tb1 = np.zeros((N_COLUMNS * n_gates, N_COLUMNS))
    from_gate = np.zeros((N_COLUMNS * n_gates, n_gates))
    to_goal = np.zeros((2 * N_COLUMNS, N_COLUMNS * n_gates))
    for k, s in enumerate(shifts):
        for j in range(N_COLUMNS):
            row = N_COLUMNS * k + j
            from_tb1[row, (j - s) % N_COLUMNS] = 1.0
            from_gate[row, k] = 1.0
            to_goal[j, row] = to_goal[j + N_COLUMNS, row] = 1.0
    return from_tb1, from_gate, to_goal


def copy_and_shift(noise: float = 0.0, max_shift: int = MAX_SHIFT, invert_goal: bool = False) -> Circuit:
    """Copy-and-shift steering: turn toward the current heading rolled by ``shift`` columns.

    Parameters
    ----------
    noise : float
        Standard deviation of the Gaussian noise on every CX population's rates (as in
        :func:`neuronav.brains.cx.stone2017`).
    max_shift : int
        Largest allowed |shift|, in columns of 45° (1 to 4).
    invert_goal : bool
        Feed ``1 - rolled TB1`` as the goal instead of the rolled TB1 itself. Only for
        demonstrating the wrong mapping: the agent then turns away from the desired heading.

    Returns
    -------
    Circuit
        Reads ``heading`` (rad, clockwise from +y, shape (1,)) and ``shift`` (columns, shape (1,));
        writes ``motor`` (rad to add to the heading, shape (1,)). Compiled, it raises
        :class:`~neuronav.PortError` for a shift outside ±``max_shift``.
    """
    if not isinstance(max_shift, (int, np.integer)) or isinstance(max_shift, bool) or not 1 <= max_shift <= 4:
        raise ConfigError(f"copy_and_shift: max_shift must be an int in 1..4 (columns of 45°), got {max_shift!r}")
    if not isinstance(noise, (int, float)) or not np.isfinite(noise) or noise < 0:
        raise ConfigError(f"copy_and_shift: noise must be a finite number >= 0, got {noise!r}")
    base = heading_circuit(noise, name="copy_and_shift")
    circuit = Circuit.merge(base, name="copy_and_shift")

    n_gates = 2 * int(max_shift) + 1
    from_tb1, from_gate, to_goal = shift_weights(int(max_shift))
    circuit.add_input("shift_gate", n_gates, ports=[shift_port(int(max_shift))], encoder="one_hot",
                      encoder_params={"size": n_gates, "offset": int(max_shift)})
    circuit.add_population("shifter", N_COLUMNS * n_gates, activation="relu", bias=-1.0)
    circuit.connect("TB1", "shifter", weights=from_tb1)
    circuit.connect("shift_gate", "shifter", weights=from_gate)
    if invert_goal:
        circuit.add_population("goal", 2 * N_COLUMNS, bias=1.0, clip=(0.0, 1.0))
        circuit.connect("shifter", "goal", weights=to_goal, sign=-1)
    else:
        circuit.add_population("goal", 2 * N_COLUMNS, clip=(0.0, 1.0))
        circuit.connect("shifter", "goal", weights=to_goal)
    steering_populations(circuit, goal="goal", noise=noise)
    return circuit


def shift_toward(heading_rad: np.ndarray, target_rad: float | np.ndarray, max_shift: int = MAX_SHIFT) -> np.ndarray:
    """The shift that points the desired heading at ``target_rad``: columns from heading to target.

    Parameters
    ----------
    heading_rad : ndarray, shape (batch,) or (batch, 1)
        Current heading, clockwise from +y.
    target_rad : float or ndarray, shape (batch,)
    max_shift : int

    Returns
    -------
    ndarray, shape (batch, 1)
        ``clip(round(wrap(target - heading) / 45°), -max_shift, max_shift)``, ready for the
        ``shift`` port.
    """
    heading = np.asarray(heading_rad, dtype=float).reshape(-1)
    difference = angle_difference_rad(target_rad, heading)
    return np.clip(np.rint(difference / COLUMN_RAD), -max_shift, max_shift)[:, None]
