"""Brain circuits: factories that return :class:`neuronav.Circuit` objects, and their readouts.

Imports only neuronav, numpy, scipy and networkx.
"""

from neuronav.brains import cx
from neuronav.brains.cx import decode_home_vector, stone2017
from neuronav.brains.ring import bump_heading_rad, ring_attractor
from neuronav.brains.steering import copy_and_shift

__all__ = ["cx", "stone2017", "decode_home_vector", "ring_attractor", "bump_heading_rad", "copy_and_shift"]
