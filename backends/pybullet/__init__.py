"""PyBullet backend: one articulated :class:`~neuronav.spec.body.BodySpec` in a :class:`~neuronav.spec.world.World`.

Registered as ``pybullet`` (entry point ``neuronav.backends.pybullet:PybulletBackend``). The body is a URDF
generated from the spec (:mod:`neuronav.backends.pybullet.urdf`); see :mod:`neuronav.backends.pybullet.backend`.
"""

from neuronav.backends.pybullet.backend import PybulletBackend

__all__ = ["PybulletBackend"]
