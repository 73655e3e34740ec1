"""Running a body in a world: the backend protocol, the logic every articulated backend shares, the
agent loop with its clocks and hooks, and video. Imports the base, :mod:`neuronav.spec`,
:mod:`neuronav.senses` and :mod:`neuronav.circuits`; no physics engine."""
