"""Body specifications (morphology as data) and gaits. Imports only neuronav, numpy and scipy."""
