"""Learning environments over neuronav's bodies, worlds and scenarios.

:mod:`neuronav.scenarios.envs.tasks` holds the engine-free task definitions (start, observations, reward,
termination) that every adapter shares; :mod:`neuronav.scenarios.envs.gym_env` runs them as Gymnasium
environments. Importing this package registers them with Gymnasium (when it is installed, the
``gym`` extra) under versioned ids (:data:`GYM_IDS`)::

    import gymnasium
    import neuronav.scenarios.envs  # noqa: F401  (registers the ids)
    env = gymnasium.make("neuronav/AntHoming-v0", backend="mujoco")

Gymnasium 1.x loads no plugin entry points; ``gymnasium.make("neuronav.scenarios.envs:neuronav/AntHoming-v0")``
imports this package itself, so no import is needed in that form.
"""

from __future__ import annotations

# Gymnasium id -> task name (neuronav.scenarios.envs.tasks.TASKS).
GYM_IDS = {
    "neuronav/AntHoming-v0": "homing",
    "neuronav/AntBeacon-v0": "beacon",
    "neuronav/AntPlume-v0": "plume",
}


def register_gym_envs() -> None:
    """Register every id of :data:`GYM_IDS` with Gymnasium (once; again is a no-op)."""
    import gymnasium

    for env_id, task in GYM_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(env_id, entry_point="neuronav.scenarios.envs.gym_env:NeuronavEnv", kwargs={"task": task})


try:
    import gymnasium as _gymnasium  # noqa: F401
except ImportError:  # the gym extra is not installed: the tasks still are
    pass
else:
    register_gym_envs()
