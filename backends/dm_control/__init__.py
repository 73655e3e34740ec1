"""The dm_control backend (``neuronav.backends.dm_control:DmControlBackend``) and the ant as dm_control
composer environments.

dm_control drives MuJoCo: the backend steps the MuJoCo backend's own compiled model through
dm_control's :class:`dm_control.mujoco.Physics`; :mod:`neuronav.backends.dm_control.composer_env` offers the
ant, a world and an engine-free task as a ``composer`` entity, arena and task (``dm_env`` API).
Rendering is headless: ``MUJOCO_GL`` defaults to ``egl`` and is set here, before MuJoCo is imported.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
# Before dm_control starts EGL: Mesa then rasterises in the calling thread, safe after fork
# (neuronav.backends.mujoco.gl_contexts).
os.environ.setdefault("LP_NUM_THREADS", "0")

from neuronav.backends.dm_control.backend import DmControlBackend  # noqa: E402

__all__ = ["DmControlBackend"]
