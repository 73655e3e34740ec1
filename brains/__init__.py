"""Brain circuits: factories that return :class:`neuronav.Circuit` objects, and their readouts.

Imports only neuronav, numpy, scipy and networkx.
"""

from brains import cx
from brains.cx import decode_home_vector, stone2017

__all__ = ["cx", "stone2017", "decode_home_vector"]
