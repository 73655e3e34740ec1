"""The MuJoCo backend (``neuronav.backends.mujoco:MujocoBackend``): one articulated body, built from its spec.

Rendering is headless: ``MUJOCO_GL`` defaults to ``egl`` and is set here, before MuJoCo is imported.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from neuronav.backends.mujoco.backend import MujocoBackend  # noqa: E402

__all__ = ["MujocoBackend"]
