"""A cheap top view of one agent's episode, for ``render_mode="rgb_array"`` without a camera.

The kinematic backend has no follow camera: :func:`top_view` draws the path walked so far, the
agent and its heading, and the goal with its success radius, in numpy, on a square framing them.
"""

from __future__ import annotations

import numpy as np

BACKGROUND = (235, 225, 200)
PATH = (90, 90, 90)
AGENT = (200, 30, 30)
GOAL = (30, 120, 30)


def top_view(path_m: np.ndarray, heading_rad: float, goal_m: np.ndarray, radius_m: float,
             size_px: int = 128) -> np.ndarray:
    """A (size_px, size_px, 3) uint8 image, +y up: the path (P, 2) m, the agent at its last point
    with a heading tick (clockwise from +y), and the goal's disc of ``radius_m``."""
    path = np.asarray(path_m, float).reshape(-1, 2)
    goal = np.asarray(goal_m, float)
    points = np.vstack([path, goal[None] - radius_m, goal[None] + radius_m])
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    half_m = max(float(np.ptp(points, axis=0).max()) / 2 * 1.1, 1.0)
    image = np.empty((size_px, size_px, 3), np.uint8)
    image[:] = BACKGROUND
    rows, cols = np.mgrid[0:size_px, 0:size_px]
    to_m = 2 * half_m / size_px
    x_m = centre[0] - half_m + (cols + 0.5) * to_m
    y_m = centre[1] + half_m - (rows + 0.5) * to_m
    image[np.hypot(x_m - goal[0], y_m - goal[1]) <= max(radius_m, to_m)] = GOAL

    def pixel(point: np.ndarray) -> tuple[int, int]:
        col = int(np.clip((point[0] - centre[0] + half_m) / to_m, 0, size_px - 1))
        row = int(np.clip((centre[1] + half_m - point[1]) / to_m, 0, size_px - 1))
        return row, col

    for a, b in zip(path[:-1], path[1:]):  # each segment sampled at half-pixel spacing
        for t in np.linspace(0.0, 1.0, int(np.hypot(*(b - a)) / to_m * 2) + 2):
            image[pixel(a + t * (b - a))] = PATH
    tip = path[-1] + 4 * to_m * np.array([np.sin(heading_rad), np.cos(heading_rad)])
    for t in np.linspace(0.0, 1.0, 9):
        image[pixel(path[-1] + t * (tip - path[-1]))] = AGENT
    row, col = pixel(path[-1])
    image[max(row - 1, 0):row + 2, max(col - 1, 0):col + 2] = AGENT
    return image
