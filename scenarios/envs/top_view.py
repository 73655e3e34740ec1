"""Frames of an episode: a cheap top view without a camera, and the goal drawn into a follow camera's frame.

The kinematic backend has no follow camera: :func:`top_view` draws the path walked so far, the
agent and its heading, and the goal with its success radius, in numpy, on a square framing them. A
physics backend's follow camera does not show the goal (nothing is built at the nest or the plume's
source): :func:`draw_goal` projects the goal's success circle and a pole into its frame.
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


def _stamp(image: np.ndarray, rows: np.ndarray, cols: np.ndarray, colour: tuple[int, int, int],
           half_px: int = 1) -> None:
    """Set the pixels within ``half_px`` of each (row, col) inside the image to ``colour``."""
    height, width = image.shape[:2]
    for dr in range(-half_px, half_px + 1):
        for dc in range(-half_px, half_px + 1):
            r, c = rows + dr, cols + dc
            inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            image[r[inside], c[inside]] = colour


def project(view, points_m: np.ndarray, image_shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel (rows, cols) of world points (P, 3) in a follow camera's image, and whether each lies in front of it.

    ``view``: a :class:`~neuronav.engine.articulated.FollowView` (eye, target, up, ``fov_deg`` vertical); a
    pinhole camera looking from ``eye`` at ``target`` with ``up`` up, on an image of ``image_shape`` (H, W, ...).
    """
    height, width = image_shape[:2]
    forward = np.asarray(view.target, float) - np.asarray(view.eye, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(view.up, float))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    offset = np.asarray(points_m, float) - np.asarray(view.eye, float)
    depth = offset @ forward
    front = depth > 1e-6
    focal_px = height / 2.0 / np.tan(np.radians(view.fov_deg) / 2.0)
    safe = np.where(front, depth, 1.0)
    cols = width / 2.0 + focal_px * (offset @ right) / safe
    rows = height / 2.0 - focal_px * (offset @ up) / safe
    return rows, cols, front


def draw_goal(frame: np.ndarray, view, goal_m: np.ndarray, radius_m: float, ground_z_m: float = 0.0) -> np.ndarray:
    """A copy of a follow-camera ``frame`` (H, W, 3) uint8 with the goal drawn in :data:`GOAL` colour: its
    success circle of ``radius_m`` on the ground, a pole at its centre (as high as the radius, at least
    0.3 m), and, when the goal's centre is out of view, a square on the frame's edge toward it."""
    image = np.array(frame, copy=True)
    height, width = image.shape[:2]
    goal = np.asarray(goal_m, float).reshape(-1)[:2]
    angles = np.linspace(0.0, 2.0 * np.pi, 129)
    ring = np.column_stack([goal[0] + radius_m * np.cos(angles), goal[1] + radius_m * np.sin(angles),
                            np.full(angles.size, ground_z_m)])
    pole = np.column_stack([np.repeat(goal[None], 33, axis=0), ground_z_m + np.linspace(0.0, max(radius_m, 0.3), 33)])
    for points in (ring, pole):  # each polyline densified to about half a pixel between samples
        rows, cols, front = project(view, points, image.shape)
        for k in range(len(points) - 1):
            if not (front[k] and front[k + 1]):
                continue
            span = max(abs(rows[k + 1] - rows[k]), abs(cols[k + 1] - cols[k]))
            if not np.isfinite(span) or span > 4 * (height + width):
                continue
            t = np.linspace(0.0, 1.0, int(span * 2) + 2)
            _stamp(image, np.rint(rows[k] + t * (rows[k + 1] - rows[k])).astype(int),
                   np.rint(cols[k] + t * (cols[k + 1] - cols[k])).astype(int), GOAL)
    rows, cols, front = project(view, np.array([[goal[0], goal[1], ground_z_m]]), image.shape)
    if not (front[0] and 0 <= rows[0] < height and 0 <= cols[0] < width):
        # Out of view: a square on the edge, in the goal's direction from the image centre.
        direction = np.array([rows[0] - height / 2.0, cols[0] - width / 2.0]) * (1.0 if front[0] else -1.0)
        direction /= max(np.abs(direction / np.array([height / 2.0 - 8, width / 2.0 - 8])).max(), 1e-9)
        row, col = int(height / 2.0 + direction[0]), int(width / 2.0 + direction[1])
        _stamp(image, np.array([row]), np.array([col]), GOAL, half_px=6)
    return image
