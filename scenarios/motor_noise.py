"""Motor noise: what a trial's legs make of the brain's locomotion command, once per gait cycle.

The brain issues (turn θ in [-1, 1], stride S_l in rad) once per gait cycle; a walking ant does not
execute two cycles alike. :class:`MotorNoise` turns the command into the executed one:

    θ'   = clip(θ + ε_turn, -1, 1),         ε_turn ~ N(0, turn_noise_sd)
    S_l' = max(S_l · (1 + ε_stride), 0),    ε_stride ~ N(0, stride_noise_fraction)

so an ant that stands (S_l = 0) stays standing. Draws come from the trial's own generator
(:func:`neuronav.scenarios.variability.trial_generators`, source ``"motor"``), turn then stride each cycle.

Defaults, chosen here (the I2Bot paper's gait repeats exactly): ``turn_noise_sd`` 0.05 turns the
desert ant's body by about 3° in one gait cycle at full stride (its unicycle calibration,
``bodies/desert_ant/unicycle_mujoco.json``: 6.0° per cycle at θ = 0.05 against 3.0° at θ = 0, S_l = 25°),
a small wobble next to the 57° of a full turn; ``stride_noise_fraction`` 0.05 makes successive strides
differ by 5 % (``docs/parameters.md`` §7).
"""

from __future__ import annotations

import numpy as np

from neuronav.config import field
from neuronav.scenarios.variability import trial_generators

DEFAULT_TURN_NOISE_SD = 0.05
DEFAULT_STRIDE_NOISE_FRACTION = 0.05


def turn_noise_field():
    """``turn_noise_sd``: the standard deviation of the noise added to the turn command each gait cycle."""
    return field(DEFAULT_TURN_NOISE_SD, "motor noise: std of the Gaussian noise added to the turn command "
                 "theta (in [-1, 1]) every gait cycle, with variability=on", min=0.0, max=1.0)


def stride_noise_field():
    """``stride_noise_fraction``: the relative standard deviation of the stride each gait cycle."""
    return field(DEFAULT_STRIDE_NOISE_FRACTION, "motor noise: std of each gait cycle's stride as a fraction of "
                 "the commanded stride, with variability=on", min=0.0, max=1.0)


class MotorNoise:
    """Seeded per-cycle noise on one trial's (turn, stride) commands.

    Parameters
    ----------
    seed : int
        The trial's seed.
    turn_sd, stride_fraction : float
        Standard deviations of the turn's additive and the stride's relative noise; both 0: the
        command passes unchanged.
    """

    def __init__(self, seed: int, turn_sd: float, stride_fraction: float) -> None:
        self.turn_sd, self.stride_fraction = float(turn_sd), float(stride_fraction)
        self.generator = trial_generators([seed], "motor")[0]

    def __call__(self, turn: float, stride_rad: float) -> tuple[float, float]:
        """The executed (turn, stride in rad) of the commanded ones."""
        if self.turn_sd == 0.0 and self.stride_fraction == 0.0:
            return turn, stride_rad
        turn_noise, stride_noise = self.generator.normal(0.0, 1.0, size=2)
        executed_turn = float(np.clip(turn + self.turn_sd * turn_noise, -1.0, 1.0))
        executed_stride = float(max(stride_rad * (1.0 + self.stride_fraction * stride_noise), 0.0))
        return executed_turn, executed_stride
