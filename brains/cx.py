"""Central-complex path integration: Stone et al. 2017's model with Pontine cells, as a graph.

Every number comes from ``docs/parameters.md``§3 (Stone et al. 2017, Curr. Biol. 27:3069).
Conventions: heading is in radians, clockwise from +y (so moving at heading θ means velocity
along (sin θ, cos θ)); velocity is world-frame (vx, vy) in distance units per step.

Cells and what they carry:
- TL2 (16) and CL1 (16): the heading, cosine-tuned with preferred directions (i mod 8)·45°.
- TB1 (8): the heading as an inverted bump, sharpened by TB1 -> TB1 inhibition (previous step).
- TN1 / TN2 (2 each): speed along directions 45° left and right of the heading.
- CPU4 (16): the path-integration memory (an integrator), 0–7 driven by the first TN2 cell,
  8–15 by the second, both gated by TB1.
- Pontine (16) and CPU1 (16): compare memory with heading; motor = 0.25·(ΣCPU1_0..7 − ΣCPU1_8..15).
"""

from __future__ import annotations

import numpy as np

from neuronav import Circuit, MotorSpec, SensorSpec
from neuronav.errors import ConfigError

N_COLUMNS = 8
# Memory integration per step (h) and its constant leak factor (k), Stone et al. 2017.
CPU4_GAIN = 0.0025
CPU4_LEAK = 0.125
HEADING_PORT = SensorSpec("heading", (1,), "rad")
VELOCITY_PORT = SensorSpec("velocity", (2,), "units/step")
# The body-frame displacement (forward, left) per step: what a stride or optic-flow odometer measures,
# with no heading needed (sky_compass.sky_stone2017's TN cells read it).
BODY_VELOCITY_PORT = SensorSpec("body_velocity", (2,), "units/step")
MOTOR_PORT = MotorSpec("motor", (1,), "rad")


def preferred_headings_rad(size: int = 16) -> np.ndarray:
    """Preferred headings of TL2/CL1/CPU cells: ``(i mod 8) * 45°`` for i < size (0 to 10⁶)."""
    if isinstance(size, bool) or not isinstance(size, int | np.integer) or not 0 <= size <= 10 ** 6:
        raise ConfigError(f"preferred_headings_rad: size must be an int in [0, 1000000], got {size!r}")
    return (np.arange(size) % N_COLUMNS) * (2.0 * np.pi / N_COLUMNS)


def cpu1_memory_weights() -> tuple[np.ndarray, np.ndarray]:
    """(CPU4 -> CPU1, Pontine -> CPU1) one-hot wirings, each shape (16, 16).

    CPU1_j reads CPU4 cell c(j) and Pontine cell p(j): c(j) = 8 + ((j - 1) mod 8), p(j) =
    8 + ((j + 3) mod 8) for j < 8; c(j) = (j - 7) mod 8, p(j) = (j - 3) mod 8 for j >= 8. Each
    CPU1 hemisphere reads the other hemisphere's memory offset by one column: the offset is what
    turns a memory/heading mismatch into a left-right imbalance.
    """
    from_cpu4, from_pontine = np.zeros((16, 16)), np.zeros((16, 16))
    for j in range(16):
        if j < N_COLUMNS:
            c, p = 8 + (j - 1) % 8, 8 + (j + 3) % 8
        else:
            c, p = (j - 7) % 8, (j - 3) % 8
        from_cpu4[j, c] = 1.0
        from_pontine[j, p] = 1.0
    return from_cpu4, from_pontine


def heading_circuit(noise: float = 0.1, name: str = "heading") -> Circuit:
    """The compass part shared by every CX model: heading -> TL2 -> CL1 -> TB1 (with TB1 -> TB1)."""
    circuit = Circuit(name)
    noisy = dict(noise_std=noise, clip=(0.0, 1.0))
    # TL2 cell i receives cos(θ − φ_i): the heading's unit vector through preferred-direction weights.
    circuit.add_input("heading_in", 2, ports=[HEADING_PORT], encoder="heading_vector")
    circuit.add_population("TL2", 16, activation="logistic", params={"slope": 6.8, "bias": 3.0}, **noisy)
    circuit.add_population("CL1", 16, activation="logistic", params={"slope": 3.0, "bias": -0.5}, **noisy)
    circuit.add_population("TB1", 8, activation="logistic", params={"slope": 5.0, "bias": 0.0}, **noisy)
    preferred = preferred_headings_rad(16)
    circuit.connect("heading_in", "TL2", weights=np.stack([np.sin(preferred), np.cos(preferred)], axis=1))
    circuit.connect("TL2", "CL1", rule="one_to_one", sign=-1)
    circuit.connect("CL1", "TB1", rule="fold", gain=0.667)
    circuit.connect("TB1", "TB1", rule="cosine_ring", gain=0.333, sign=-1, delay=True)
    return circuit


def steering_populations(circuit: Circuit, goal: str, noise: float) -> None:
    """Add Pontine, CPU1 and the motor output, steering the TB1 heading toward ``goal`` (16 cells)."""
    noisy = dict(noise_std=noise, clip=(0.0, 1.0))
    circuit.add_population("Pontine", 16, activation="logistic", params={"slope": 5.0, "bias": 2.5}, **noisy)
    circuit.add_population("CPU1", 16, activation="logistic", params={"slope": 7.5, "bias": -1.0}, **noisy)
    circuit.add_output("motor", 1, port=MOTOR_PORT)
    from_goal, from_pontine = cpu1_memory_weights()
    circuit.connect(goal, "Pontine", rule="one_to_one")
    circuit.connect(goal, "CPU1", weights=from_goal, gain=0.5)
    circuit.connect("Pontine", "CPU1", weights=from_pontine, gain=0.5, sign=-1)
    circuit.connect("TB1", "CPU1", rule="tile", sign=-1)
    circuit.connect("CPU1", "motor", weights=0.25 * np.r_[np.ones(8), -np.ones(8)][None, :])


def stone2017(noise: float = 0.1, memory_gain: float = CPU4_GAIN, memory_leak: float = CPU4_LEAK,
              memory_initial: float = 0.5, tn_offset_rad: float = np.pi / 4) -> Circuit:
    """Stone et al. 2017's path-integration circuit with Pontine cells.

    Parameters
    ----------
    noise : float
        Standard deviation of the Gaussian noise added to every population's rates.
    memory_gain : float
        CPU4 integration gain h per step.
    memory_leak : float
        CPU4 leak factor k: the memory loses ``h * k`` every step.
    memory_initial : float
        CPU4 memory at the start.
    tn_offset_rad : float
        TN preferred directions: heading ± this angle.

    Returns
    -------
    Circuit
        Reads ``heading`` (rad, clockwise from +y, shape (1,)) and ``velocity`` (world frame,
        shape (2,)); writes ``motor`` (rad to add to the heading, shape (1,)).
    """
    circuit = heading_circuit(noise, name="stone2017")
    memory_populations(circuit, noise, memory_gain, memory_leak, memory_initial, tn_offset_rad)
    return circuit


def memory_populations(circuit: Circuit, noise: float, memory_gain: float, memory_leak: float,
                       memory_initial: float, tn_offset_rad: float, body_frame: bool = False) -> None:
    """Add TN1, TN2, CPU4 and the steering (Pontine, CPU1, ``motor``) to a circuit that has TB1 (8 cells).

    Parameters as in :func:`stone2017`. ``body_frame`` False: the TN cells read ``heading`` and the
    world-frame ``velocity`` (stone2017); True: they read :data:`BODY_VELOCITY_PORT`, the body-frame
    (forward, left) displacement per step, so the circuit needs no true heading.
    """
    noisy = dict(noise_std=noise, clip=(0.0, 1.0))
    # Each TN cell receives the speed along heading ± tn_offset: the body-frame velocity
    # (forward, rightward) through weights (cos o, sin o).
    offsets = np.array([tn_offset_rad, -tn_offset_rad])
    tn_directions = np.stack([np.cos(offsets), np.sin(offsets)], axis=1)
    if body_frame:
        # (forward, left): left = -rightward.
        circuit.add_input("body_velocity", 2, ports=[BODY_VELOCITY_PORT], encoder="identity")
        tn_directions = tn_directions * np.array([1.0, -1.0])
    else:
        circuit.add_input("body_velocity", 2, ports=[HEADING_PORT, VELOCITY_PORT], encoder="body_velocity")
    circuit.add_population("TN1", 2, bias=0.5, **noisy)
    circuit.add_population("TN2", 2, **noisy)
    circuit.connect("body_velocity", "TN1", weights=tn_directions, gain=0.5, sign=-1)
    circuit.connect("body_velocity", "TN2", weights=tn_directions)
    circuit.add_population(
        "CPU4", 16, kind="integrator", activation="logistic", params={"slope": 5.0, "bias": 2.5},
        gain=memory_gain, leak=memory_gain * memory_leak, drive_clip=(0.0, 1.0),
        memory_clip=(0.0, 1.0), initial=memory_initial, **noisy,
    )
    tn_to_cpu4 = np.zeros((16, 2))
    tn_to_cpu4[:8, 0] = tn_to_cpu4[8:, 1] = 1.0
    circuit.connect("TN2", "CPU4", weights=tn_to_cpu4)
    circuit.connect("TB1", "CPU4", rule="tile", sign=-1)
    steering_populations(circuit, goal="CPU4", noise=noise)


def decode_home_vector(cpu4: np.ndarray, memory_gain: float = CPU4_GAIN) -> tuple[np.ndarray, np.ndarray]:
    """Decode the home vector from CPU4 activity (memory or rates), batched.

    The two hemispheres are rolled one column toward each other (+1 and -1), summed, and the
    first Fourier harmonic read out: its phase gives the direction, its amplitude the distance.

    Parameters
    ----------
    cpu4 : ndarray, shape (batch, 16)
    memory_gain : float
        CPU4 gain h; the amplitude divided by h is the distance estimate.

    Returns
    -------
    direction_rad : ndarray, shape (batch,)
        Direction from the agent to the nest, clockwise from +y, in (-π, π].
    distance : ndarray, shape (batch,)
        Distance estimate in the integrator's units (grows with the distance travelled until the
        memory saturates).
    """
    try:
        cpu4 = np.atleast_2d(np.asarray(cpu4))
    except ValueError:  # rows of unequal length
        cpu4 = np.zeros((0, 0))
    if cpu4.ndim != 2 or cpu4.shape[1] != 16 or cpu4.dtype.kind not in "iuf":
        raise ConfigError(f"decode_home_vector: cpu4 must be numbers of shape (batch, 16), got shape {cpu4.shape}")
    signal = np.roll(cpu4[:, :8], 1, axis=1) + np.roll(cpu4[:, 8:], -1, axis=1)
    # Summed per row (not a BLAS product, which rounds a row differently for another batch size).
    harmonic = (signal * np.exp(1j * preferred_headings_rad(8))).sum(axis=1)
    # CPU4 cells fire most for travel *toward* their column: the nest lies the opposite way.
    direction = np.angle(-harmonic)
    return direction, np.abs(harmonic) / memory_gain


GOAL_PORT = SensorSpec("goal", (2 * N_COLUMNS,), "")


def goal_pattern(direction_rad: np.ndarray, amplitude: float = 0.15) -> np.ndarray:
    """A CPU4-like goal (16 cells) that :func:`decode_home_vector` reads as ``direction_rad``.

    CPU4 cells fire most for travel away from the goal, each hemisphere offset by one column: cell
    j < 8 is ``0.5 + a cos(p_j + 45° - direction - 180°)``, cell j >= 8 the same with -45°. The default
    amplitude is about CPU4's own modulation after a 10 m walk at the embodied gain (0.33–0.58).

    Returns
    -------
    ndarray, shape (N, 16)
    """
    away = np.asarray(direction_rad, float).reshape(-1, 1) + np.pi
    preferred = preferred_headings_rad(N_COLUMNS)[None, :]
    column = 2.0 * np.pi / N_COLUMNS
    left = 0.5 + amplitude * np.cos(preferred + column - away)
    right = 0.5 + amplitude * np.cos(preferred - column - away)
    return np.concatenate([left, right], axis=1)


def goal_steering(noise: float = 0.1) -> Circuit:
    """Stone et al.'s steering (Pontine, CPU1, ``motor``) toward a goal read on the ``goal`` port instead
    of the CPU4 memory: reads ``heading`` (rad, clockwise from +y) and ``goal`` (16 cells in CPU4's format,
    :func:`goal_pattern`); writes ``motor`` (rad, positive = clockwise)."""
    circuit = Circuit.merge(heading_circuit(noise, name="goal_steering"), name="goal_steering")
    circuit.add_input("goal", 2 * N_COLUMNS, ports=[GOAL_PORT], encoder="identity")
    steering_populations(circuit, goal="goal", noise=noise)
    return circuit
