"""Eye pixel noise: what a trial's eyes add to the rendered image before the brain reads it.

The backends render noiseless grey images (float in [0, 1]); a real eye's photoreceptors, or a
robot's camera, add noise to every pixel at every look. :class:`EyeNoise` adds seeded Gaussian noise
of ``eye_pixel_noise_sd`` (grey levels, 0–1) to each pixel of each image the brain reads, clipped to
[0, 1], drawn from the trial's own generator (:func:`neuronav.scenarios.variability.trial_generators`,
source ``"eye_pixels"``): a trial's noise does not depend on its batch, chunk or worker.

Default 0.02 (about 5 of 255), chosen here (the I2Bot paper's Webots cameras have none; no published
value is used). Measured with it: the visual beacon's detection does not change (its landmark renders
at grey 0 and the scenery at >= 0.35 in the kinematic and MuJoCo first views, 4 and 13 standard
deviations from the 0.08 threshold), while the compass's Z_{7,1} phase scatters by 1.6° (sd; at most
4.8° in 200 looks at the compass scene, kinematic and MuJoCo panoramas alike), twice
its 0.8° dead band (``docs/parameters.md`` §7).
"""

from __future__ import annotations

import numpy as np

from neuronav.config import field
from neuronav.scenarios.variability import trial_generators

DEFAULT_EYE_PIXEL_NOISE_SD = 0.02


def eye_pixel_noise_field():
    """``eye_pixel_noise_sd``: the standard deviation of the per-pixel Gaussian noise (grey levels 0–1)."""
    return field(DEFAULT_EYE_PIXEL_NOISE_SD, "eye noise: std of the Gaussian noise added to every pixel the brain "
                 "reads (grey levels 0-1; 0.02 is about 5 of 255), with variability=on", min=0.0, max=0.5)


class EyeNoise:
    """Seeded pixel noise for the images of one trial (one agent).

    Parameters
    ----------
    seed : int
        The trial's seed.
    sd : float
        Standard deviation of the noise (grey levels); 0 adds none (the images are returned as they are).
    """

    def __init__(self, seed: int, sd: float) -> None:
        self.sd = float(sd)
        self.generator = trial_generators([seed], "eye_pixels")[0]

    def __call__(self, image: np.ndarray | None) -> np.ndarray | None:
        """``image`` (any shape, grey levels) plus noise, clipped to [0, 1]; None stays None."""
        if image is None or self.sd == 0.0:
            return image
        image = np.asarray(image, dtype=float)
        return np.clip(image + self.generator.normal(0.0, self.sd, size=image.shape), 0.0, 1.0)
