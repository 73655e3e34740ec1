"""The desert ant Cataglyphis fortis at ×100 scale (I2Bot's body), as a BodySpec."""

from neuronav.bodies.desert_ant.body import LEG_JOINTS, LEG_SEGMENTS, LEGS, MASS_KEYS, desert_ant, leg_geometry

__all__ = ["LEGS", "LEG_JOINTS", "LEG_SEGMENTS", "MASS_KEYS", "desert_ant", "leg_geometry"]
