"""The dorsal rim's one-ray read through Sky.analysed_degree gives the responses of the read through Sky.light."""

from dataclasses import dataclass

import numpy as np
import pytest

from neuronav.senses.dorsal_rim import DorsalRim, head_rotations_from_headings
from neuronav.senses.sky import Sky


@dataclass(frozen=True)
class LightOnly:
    """The same sky without ``analysed_degree``: DorsalRim reads it through ``light``."""

    sky: Sky

    def light(self, directions):
        return self.sky.light(directions)


@pytest.mark.parametrize("elevation_deg, cloud_cover", [(0.0, 0.0), (30.0, 0.0), (60.0, 0.4), (90.0, 0.0)])
def test_fast_read_equals_the_read_through_light(elevation_deg, cloud_cover):
    rng = np.random.default_rng(5)
    # Tilted heads: some ommatidia look below the horizon (they read 0 on both paths).
    rotations = head_rotations_from_headings(rng.uniform(-np.pi, np.pi, 50), rng.normal(0, 0.6, 50),
                                             rng.normal(0, 0.6, 50))
    sky = Sky(sun_azimuth_rad=1.1, sun_elevation_rad=np.radians(elevation_deg), cloud_cover=cloud_cover)
    for rim in (DorsalRim(), DorsalRim(polarisation_sensitivity=3.0)):
        fast, slow = rim.responses(sky, rotations), rim.responses(LightOnly(sky), rotations)
        assert np.abs(slow).max() > 0.2 and (slow == 0.0).any()  # polarised light seen, some views below
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(fast == 0.0, slow == 0.0)


def test_fast_read_equals_light_at_the_sun_and_on_the_horizon():
    # A head pitched so that ommatidia look at the sun and graze the horizon.
    rim = DorsalRim()
    rotations = head_rotations_from_headings(np.linspace(-np.pi, np.pi, 73), np.radians(50.0), np.radians(20.0))
    sky = Sky(sun_azimuth_rad=0.0, sun_elevation_rad=np.radians(45.0))
    np.testing.assert_allclose(rim.responses(sky, rotations), rim.responses(LightOnly(sky), rotations),
                               rtol=0, atol=1e-12)
