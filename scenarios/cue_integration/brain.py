"""The cue-integration brain: path integration and visual homing as two cues into the ring attractor.

Once per gait cycle (0.64 s), for a batch of agents:

1. The CX (:func:`neuronav.brains.cx.stone2017`, the embodied settings of ``path-integration``'s i2bot protocol)
   integrates the cycle's displacement; its CPU4 memory decodes (:func:`neuronav.brains.cx.decode_home_vector`)
   to the PI home direction and a length. PI reliability ``r_PI = min(1, L / pi_full_m)``.
2. The panorama's skyline band is compared with the snapshots stored facing the nest
   (:mod:`neuronav.brains.visual_homing`): the visual homing direction and the RIDF's relative depth ``c``.
   Visual reliability ``r_V = min(1, c / vision_full)``.
3. Each cue is a Gaussian bump on the ring's 32 cells (:func:`neuronav.brains.ring.gaussian_cue`, width
   :data:`CUE_SIGMA_RAD`), of amplitude ``A r_i / (r_PI + r_V)`` with ``A`` = :data:`TOTAL_AMPLITUDE`
   (twice the ring's tuned single-cue amplitude). The ring (:func:`neuronav.brains.ring.ring_attractor`)
   starts silent and settles for 0.2 s; its bump is the combined direction.
4. The bump is written as a goal in CPU4's format (:func:`neuronav.brains.cx.goal_pattern`) into Stone et al.'s
   steering (Pontine, CPU1), which compares it with the TB1 heading (:func:`neuronav.brains.cx.goal_steering`);
   the turn and stride follow eqs. 3.6–3.7 for the batch (:func:`steering_commands`).

Why these widths, amplitudes and gains (measured): README.md in this folder, *Model choices*.
"""

from __future__ import annotations

import numpy as np

from neuronav.brains.cx import CPU4_LEAK, decode_home_vector, goal_pattern, goal_steering, stone2017
from neuronav.brains.ring import CUE_AMPLITUDE, N_CELLS, gaussian_cue, ring_attractor, settle
from neuronav.brains.visual_homing import homing_direction, skyline_view
from neuronav.scenarios.variability import is_on, trial_generators

CUE_SIGMA_RAD = float(np.radians(90.0))
TOTAL_AMPLITUDE = 2.0 * CUE_AMPLITUDE
# Embodied CX (the path-integration scenario's i2bot protocol): gain per gait cycle, rate noise.
MEMORY_GAIN = 0.04
CX_NOISE = 0.0008
# decode_home_vector's distance per metre walked at MEMORY_GAIN: straight walks at 0.29 m per cycle, 24
# headings, decode to 9.7–10.2 m for 10 m and 20.4–21.5 m for 20 m (direction within 10.5°); 1.4 per
# metre after 2 m and 1.7 after 40 m, as the memory saturates (tests/unit/test_cue_integration.py).
DECODED_PER_M = 2.0


def cue_amplitudes(r_pi: np.ndarray, r_vision: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Peak amplitudes of the two cues: ``TOTAL_AMPLITUDE`` shared in proportion to the reliabilities.

    Both reliabilities 0 gives both amplitudes 0 (no cue: the ring stays silent).
    """
    r_pi, r_vision = np.asarray(r_pi, float), np.asarray(r_vision, float)
    total = r_pi + r_vision
    safe = np.where(total > 0, total, 1.0)
    return TOTAL_AMPLITUDE * r_pi / safe, TOTAL_AMPLITUDE * r_vision / safe


def ring_cues(pi_rad, a_pi, vision_rad, a_vision) -> np.ndarray:
    """The ring's input: the two Gaussian cues summed, shape (N, 32)."""
    unit_pi = gaussian_cue(np.asarray(pi_rad, float).reshape(-1), CUE_SIGMA_RAD, N_CELLS, amplitude=1.0)
    unit_vision = gaussian_cue(np.asarray(vision_rad, float).reshape(-1), CUE_SIGMA_RAD, N_CELLS, amplitude=1.0)
    return np.asarray(a_pi, float).reshape(-1, 1) * unit_pi + np.asarray(a_vision, float).reshape(-1, 1) * unit_vision


def weighted_direction(pi_rad, a_pi, vision_rad, a_vision) -> np.ndarray:
    """The analytic combination: the amplitude-weighted circular mean of the two directions, (N,)."""
    return np.angle(np.asarray(a_pi) * np.exp(1j * np.asarray(pi_rad)) +
                    np.asarray(a_vision) * np.exp(1j * np.asarray(vision_rad)))


class CueNoise:
    """What the brain's senses and the legs add, per agent (agent i seeded by ``seeds[i]``), when
    ``variability`` is on: compass noise on every heading the brain reads (``heading_noise_deg``), odometer
    noise scaling each displacement the CX integrates (``odometry_noise``, relative), pixel noise on the
    panorama (``eye_noise``), and noise on each cycle's turn and stride (``turn_noise``, ``stride_noise_deg``).
    Each source is its own stream of each trial's seed; with ``variability`` off nothing is drawn or added.
    """

    SOURCES = ("compass", "odometry", "eye", "motor")

    def __init__(self, config, seeds) -> None:
        on = is_on(config)
        self.heading_sd_rad = float(np.radians(config.heading_noise_deg)) if on else 0.0
        self.odometry_sd = config.odometry_noise if on else 0.0
        self.eye_sd = config.eye_noise if on else 0.0
        self.turn_sd = config.turn_noise if on else 0.0
        self.stride_sd_rad = float(np.radians(config.stride_noise_deg)) if on else 0.0
        self.generators = {source: trial_generators(seeds, source) for source in self.SOURCES}

    def _normal(self, source: str, shape: tuple[int, ...] = ()) -> np.ndarray:
        """One standard normal draw of ``shape`` per agent, from each agent's own stream: (N, *shape)."""
        return np.stack([g.normal(0.0, 1.0, shape) for g in self.generators[source]])

    def compass(self, heading_rad: np.ndarray) -> np.ndarray:
        """The headings (N,) as the compass reads them."""
        if not self.heading_sd_rad:
            return heading_rad
        return heading_rad + self.heading_sd_rad * self._normal("compass")

    def odometer(self, displacement_m: np.ndarray) -> np.ndarray:
        """The displacements (N, 2) as the odometer reads them: each scaled by 1 + noise."""
        if not self.odometry_sd:
            return displacement_m
        return displacement_m * (1.0 + self.odometry_sd * self._normal("odometry"))[:, None]

    def eye(self, panorama: np.ndarray) -> np.ndarray:
        """The panoramas (N, H, W) as the eyes read them."""
        if not self.eye_sd:
            return panorama
        return panorama + self.eye_sd * self._normal("eye", np.shape(panorama)[1:])

    def motor(self, turn: np.ndarray, stride_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cycle's commands (N,) as the legs carry them out: turn clipped to [-1, 1], stride >= 0."""
        if not (self.turn_sd or self.stride_sd_rad):
            return turn, stride_rad
        draws = self._normal("motor", (2,))
        return (np.clip(turn + self.turn_sd * draws[:, 0], -1.0, 1.0),
                np.maximum(stride_rad + self.stride_sd_rad * draws[:, 1], 0.0))


class CueBrain:
    """PI + visual homing + ring + CPU1 steering for ``batch`` agents (agent i seeded by ``seeds[i]``).

    Parameters
    ----------
    config : CueIntegrationConfig
        ``cues``, ``pi_full_m``, ``vision_full``, ``k_pi``, ``band_deg`` and the noise settings
        (:class:`CueNoise`) are read.
    snapshots : ndarray, shape (K, R, W)
        Skyline views stored facing the nest.
    seeds : sequence of int
    cues : sequence of str, optional
        Each agent's cues (``both``, ``pi`` or ``vision``); default ``config.cues`` for every agent.
    """

    LOG_KEYS = ("time_s", "heading_rad", "pi_rad", "pi_length_m", "vision_rad", "certainty", "weight_pi",
                "bump_rad", "turn", "stride_rad")

    def __init__(self, config, snapshots: np.ndarray, seeds, cues=None) -> None:
        self.config = config
        self.snapshots = snapshots
        seeds = [int(s) for s in seeds]
        self.batch = len(seeds)
        self.cues = np.array([config.cues] * self.batch if cues is None else list(cues), dtype=object)
        self.noise = CueNoise(config, seeds)
        self.cx = stone2017(noise=CX_NOISE, memory_gain=MEMORY_GAIN, memory_leak=CPU4_LEAK).compile(
            batch=self.batch, seeds=seeds)
        self.ring = ring_attractor().compile(batch=self.batch)
        self.steer = goal_steering(noise=CX_NOISE).compile(batch=self.batch, seeds=[s + 7919 for s in seeds])
        self.last_position = None
        self.log: dict[str, list] = {k: [] for k in self.LOG_KEYS}

    def integrate(self, heading_rad: np.ndarray, displacement_m: np.ndarray) -> None:
        """One gait cycle of path integration: heading (N,), displacement over the cycle (N, 2) m, read
        through the compass and the odometer."""
        self._integrate(self.noise.compass(np.asarray(heading_rad, float).reshape(-1)), displacement_m)

    def _integrate(self, sensed_heading_rad: np.ndarray, displacement_m: np.ndarray) -> None:
        """One gait cycle of path integration from a compass reading (N,) and a true displacement (N, 2) m."""
        self.cx.step({"heading": np.asarray(sensed_heading_rad, float).reshape(-1, 1),
                      "velocity": self.noise.odometer(np.asarray(displacement_m, float).reshape(-1, 2))})

    def pi_cue(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(home direction, length in metres, reliability) decoded from CPU4."""
        direction, decoded = decode_home_vector(self.cx.memory("CPU4"), MEMORY_GAIN)
        length_m = decoded / DECODED_PER_M
        return direction, length_m, np.clip(length_m / self.config.pi_full_m, 0.0, 1.0)

    def vision_cue(self, panorama: np.ndarray, heading_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(visual homing direction, RIDF depth, reliability) from the panoramas (N, H, W)."""
        views = skyline_view(panorama, self.config.band_deg)
        direction, certainty, _ = homing_direction(views, heading_rad, self.snapshots)
        return direction, certainty, np.clip(certainty / self.config.vision_full, 0.0, 1.0)

    def __call__(self, time_s: float, heading_rad: np.ndarray, position_m: np.ndarray,
                 panorama: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """One gait cycle: integrate, combine the cues, steer; returns (turn, stride) arrays (N,)."""
        true_heading = np.asarray(heading_rad, float).reshape(-1)
        heading = self.noise.compass(true_heading)  # what the brain reads
        position = np.asarray(position_m, float).reshape(-1, 2)
        if self.last_position is None:
            self.last_position = position.copy()
        self._integrate(heading, position - self.last_position)
        self.last_position = position.copy()
        pi_rad, length_m, r_pi = self.pi_cue()
        if panorama is None:
            vision_rad, certainty, r_vision = np.zeros(self.batch), np.zeros(self.batch), np.zeros(self.batch)
        else:
            vision_rad, certainty, r_vision = self.vision_cue(self.noise.eye(panorama), heading)
        r_vision = np.where(self.cues == "pi", 0.0, r_vision)
        r_pi = np.where(self.cues == "vision", 0.0, r_pi)
        a_pi, a_vision = cue_amplitudes(r_pi, r_vision)
        self.ring.reset()
        bump = settle(self.ring, ring_cues(pi_rad, a_pi, vision_rad, a_vision))
        self.steer.step({"heading": heading[:, None], "goal": goal_pattern(bump)})
        turn, stride = self.noise.motor(*steering_commands(self.steer.rates("CPU1"), self.config.k_pi))
        weight_pi = np.where(a_pi + a_vision > 0, a_pi / np.where(a_pi + a_vision > 0, a_pi + a_vision, 1.0), np.nan)
        for key, value in (("time_s", np.full(self.batch, time_s)), ("heading_rad", true_heading), ("pi_rad", pi_rad),
                           ("pi_length_m", length_m), ("vision_rad", vision_rad), ("certainty", certainty),
                           ("weight_pi", weight_pi), ("bump_rad", bump), ("turn", turn), ("stride_rad", stride)):
            self.log[key].append(np.array(value, float))
        return turn, stride


def steering_commands(cpu1: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 3.6–3.7 for a batch: θ = k (ΣCPU1 8–15 − ΣCPU1 0–7) clipped to [-1, 1], S_l = 5° + 20° (1 − |θ|)."""
    theta = np.clip(k * (cpu1[:, 8:].sum(axis=1) - cpu1[:, :8].sum(axis=1)), -1.0, 1.0)
    return theta, np.radians(5.0) + np.radians(20.0) * (1.0 - np.abs(theta))
