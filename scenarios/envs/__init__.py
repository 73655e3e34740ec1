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
# The spec's max_episode_steps: the longest episode an id's default settings allow (the task's time limit in
# joints mode's 8 ms steps; in locomotion mode, 0.64 s steps, the env truncates itself at task.step_limit(0.64),
# env.unwrapped.max_steps). A longer time limit in joints mode needs gymnasium.make(..., max_episode_steps=-1).
MAX_EPISODE_STEPS = {"neuronav/AntHoming-v0": 11250, "neuronav/AntBeacon-v0": 15000, "neuronav/AntPlume-v0": 7500}
# The ids with a native kinematic vector environment (neuronav.scenarios.envs.vector_env): gymnasium.make_vec
# uses it by default (vectorization_mode="vector_entry_point"); other backends need vectorization_mode="sync"
# or "async".
VECTOR_IDS = ("neuronav/AntHoming-v0", "neuronav/AntBeacon-v0")
VECTOR_ENTRY_POINT = "neuronav.scenarios.envs.vector_env:NeuronavVectorEnv"


def register_gym_envs() -> None:
    """Register every id of :data:`GYM_IDS` with Gymnasium (once; again is a no-op)."""
    import gymnasium

    for env_id, task in GYM_IDS.items():
        if env_id not in gymnasium.registry:
            vector = VECTOR_ENTRY_POINT if env_id in VECTOR_IDS else None
            gymnasium.register(env_id, entry_point="neuronav.scenarios.envs.gym_env:NeuronavEnv", kwargs={"task": task},
                               vector_entry_point=vector, max_episode_steps=MAX_EPISODE_STEPS[env_id])


try:
    import gymnasium as _gymnasium  # noqa: F401
except ImportError:  # the gym extra is not installed: the tasks still are
    pass
else:
    register_gym_envs()
