"""Closed triangle meshes of the world's shapes, as the engines' eyes draw them: engine-free.

A sphere has ``slices`` vertices around each of its ``stacks - 1`` rings and one at each pole; a cylinder a ring
of ``slices`` at each end and the centres of its caps; a cone a ring at its base (z = -half) and its apex
(z = +half); a box its eight corners. Every triangle is wound anticlockwise seen from outside (OpenGL's front
faces), so that an engine culling back faces draws the outside. The PyBullet backend builds its compound eyes'
objects and its ray world's meshes from these (:mod:`neuronav.backends.pybullet.scene`), the MuJoCo backend
the objects its compound eyes draw in one call per view (:mod:`neuronav.backends.mujoco.object_batch`), with
the slices and stacks of MuJoCo's own spheres and cylinders (the same pixels: ``tests/cross_backend``).

Each function returns the vertices (N, 3) about the shape's centre and the triangles (T, 3) as vertex indices.
"""

from __future__ import annotations

import math

import numpy as np

# A box's faces as two triangles each over its corners (x, y, z each -1 or +1, in that nesting order).
_BOX_TRIANGLES = np.array([(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
                           (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)])


def sphere_mesh(radius_m: float, slices: int, stacks: int) -> tuple[np.ndarray, np.ndarray]:
    """A sphere of ``radius_m``: ``stacks - 1`` rings of ``slices`` vertices from the top down, and the poles."""
    polar = math.pi * np.arange(1, stacks) / stacks
    rings = [_ring(slices, radius_m * math.sin(a), radius_m * math.cos(a)) for a in polar]
    return _closed(rings, (radius_m, -radius_m))


def cylinder_mesh(radius_m: float, half_height_m: float, slices: int) -> tuple[np.ndarray, np.ndarray]:
    """A cylinder along z: its two rims of ``slices`` vertices and its caps' centres."""
    return _closed([_ring(slices, radius_m, half_height_m), _ring(slices, radius_m, -half_height_m)],
                   (half_height_m, -half_height_m))


def cone_mesh(radius_m: float, half_height_m: float, slices: int) -> tuple[np.ndarray, np.ndarray]:
    """A cone along z: its base's rim of ``slices`` vertices at z = -half, the base's centre and the apex."""
    return _closed([_ring(slices, radius_m, -half_height_m)], (half_height_m, -half_height_m))


def box_mesh(half_extents_m) -> tuple[np.ndarray, np.ndarray]:
    """A box of half extents (3,): its corners and twelve triangles."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    return corners * np.asarray(half_extents_m, float), _BOX_TRIANGLES.copy()


def wound_outwards(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``triangles`` with each turned where needed to run anticlockwise seen from outside a surface that is
    convex about the origin."""
    corners = vertices[triangles]  # (T, 3, 3)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = (normals * corners.mean(axis=1)).sum(axis=1) < 0.0
    triangles = np.array(triangles, copy=True)
    triangles[inward] = triangles[inward]
    return triangles


def _ring(slices: int, radius_m: float, z_m: float) -> np.ndarray:
    angles = np.linspace(0.0, 2.0 * np.pi, slices, endpoint=False)
    return np.column_stack([radius_m * np.column_stack([np.cos(angles), np.sin(angles)]), np.full(slices, z_m)])


def _closed(rings: list[np.ndarray], poles_z_m: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Rings of equal length from the top down, closed by a top and a bottom vertex on the z axis."""
    slices = len(rings[0])
    vertices = np.vstack([*rings, [[0.0, 0.0, poles_z_m[0]], [0.0, 0.0, poles_z_m[1]]]])
    top, bottom, last = len(rings) * slices, len(rings) * slices + 1, (len(rings) - 1) * slices
    triangles = []
    for j in range(slices):
        k = (j + 1) % slices
        triangles += [(top, j, k), (bottom, last + k, last + j)]
        for r in range(len(rings) - 1):
            a, b = r * slices, (r + 1) * slices
            triangles += [(a + j, b + j, b + k), (a + j, b + k, a + k)]
    return vertices, wound_outwards(vertices, np.array(triangles))
