"""Helper commands beside the registered scenarios (``python -m neuronav.scenarios.tools.NAME``): the
unicycle calibration, the turn response, Fig. 7's statistics and the mushroom body's familiarity capacity."""
