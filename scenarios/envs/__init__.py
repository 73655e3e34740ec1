"""Learning environments over neuronav's bodies, worlds and scenarios.

:mod:`scenarios.envs.tasks` holds the engine-free task definitions (start, observations, reward,
termination) that every adapter shares.
"""
