"""Body specifications (morphology as data) and gaits. Imports only neuronav, numpy and scipy."""

from neuronav.bodies.desert_ant import LEG_JOINTS, LEGS, desert_ant, leg_geometry
from neuronav.bodies.gaits import FKGait, IKGait, foot_position, make_gait

__all__ = ["LEGS", "LEG_JOINTS", "FKGait", "IKGait", "desert_ant", "foot_position", "leg_geometry", "make_gait"]
