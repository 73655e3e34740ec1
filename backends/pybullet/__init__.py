"""PyBullet backend: one articulated :class:`~neuronav.body.BodySpec` in a :class:`~neuronav.world.World`.

Registered as ``pybullet`` (entry point ``backends.pybullet:PybulletBackend``). The body is a URDF
generated from the spec (:mod:`backends.pybullet.urdf`); see :mod:`backends.pybullet.backend`.
"""

from backends.pybullet.backend import PybulletBackend

__all__ = ["PybulletBackend"]
