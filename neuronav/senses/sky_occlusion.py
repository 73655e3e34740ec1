"""How far the dorsal rims' sky rays must be cast: :class:`SkyOcclusion`.

The sky compass (:class:`neuronav.scenarios.path_integration.inputs.SkyView`) learns which ommatidia the
scene hides from the sky by casting a ray from the head along each one's view (``backend.cast_rays``,
the engine's own ray test), up to ``SKY_RAY_M`` (50 m). None needs that far: a ray that rises (its unit
direction's z > 0) is above every object and the ground once it has climbed from the head to the scene's
top (the highest point of every object's bounds, widened as :func:`neuronav.senses.raycast.object_bounds`
widens them for the engines' shapes, and of the terrain, + ``GROUND_MARGIN_M``). So no ray is cast farther
than (top − lowest head) / (the lowest ray's rise), and none at all when that is 0. This changes no result
(a hit beyond that distance cannot exist) and saves the engines the objects beyond it (MuJoCo's
``mj_multiRay`` leaves out every geom farther than its cutoff). A wall world, or a ray that does not
rise, has every ray cast the full distance.

Casting only the rays whose direction meets some object's bounding sphere was measured too and left out:
per read, the test (one (M, 3) @ (3, O) product over the objects within reach) cost about what it saved
in MuJoCo's ray test in a forest (49 of 160 rays kept), and under a roof, whose bounds hold the head, it
only added (``python benchmarks/dorsal_rim_read.py``, benchmarks/README.md).
"""

from __future__ import annotations

import numpy as np

from neuronav.senses.raycast import object_bounds

# The terrain's top is raised by this much (the engines' heightfields are interpolated between cells).
GROUND_MARGIN_M = 0.05


class SkyOcclusion:
    """The reach of sky rays in a world's scene (:meth:`reach_m`).

    Parameters
    ----------
    world : World

    Attributes
    ----------
    top_m : float or None
        The highest point a rising ray can meet (m); None for a wall world (a wall stands in every
        direction's way).
    """

    def __init__(self, world) -> None:
        if world.ground.kind == "wall":
            self.top_m = None
            return
        tops = [float(world.ground.heights_m().max()) + GROUND_MARGIN_M]
        if world.objects:
            centres, _, extents = object_bounds(world.objects)
            tops.append(float((centres[:, 2] + extents[:, 2]).max()))  # the scene's yaw turns them about z
        self.top_m = max(tops)

    def reach_m(self, heads_m: np.ndarray, directions: np.ndarray, far_m: float) -> float:
        """How far the rays must be cast: ``far_m``, or when every ray rises, no farther than where the
        lowest-rising ray from the lowest head is above the scene's top; 0 when nothing can be hit.

        Parameters
        ----------
        heads_m : ndarray, shape (N, 3)
            The rays' origins (one per agent), world frame.
        directions : ndarray, shape (..., 3)
            Unit ray directions, world frame.
        far_m : float
            The distance ``cast_rays`` would test.
        """
        rise = float(directions[..., 2].min())
        if self.top_m is None or rise <= 0.0:
            return far_m
        return min(far_m, max(0.0, (self.top_m - float(heads_m[:, 2].min())) / rise))
