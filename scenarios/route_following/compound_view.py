"""The mushroom body's view from the compound eyes: both eyes' ommatidia laid out as the panoramic camera's image.

With ``eyes=compound`` the route-following (and cue-integration) brains read the ant's two compound eyes
(``compound_eye_L``, ``compound_eye_R``: (M, 2) green and UV per ommatidium, :mod:`neuronav.senses.compound_eye`)
instead of its panoramic camera. Each ommatidium's value in one channel (:func:`channel_values`: ``green``,
``uv``, or ``uv_green``, the UV-green contrast (UV − G) / (UV + G) of Möller 2002) is placed on the
panoramic camera's grid (72 x 72, the whole sphere, 5° per column, 2.5° per row, forward in the middle,
:mod:`neuronav.brains.visual_homing`) by :class:`CompoundPanorama`: every pixel the Gaussian-weighted mean
(σ :data:`SPREAD_DEG`) of its :data:`NEIGHBOURS` nearest ommatidia of both eyes, by their viewing directions
in the agent's frame (the eyes as they sit on the ant at rest). So the code the mushroom body learns is the
ommatidia values, binned as the camera's was (:func:`neuronav.brains.mushroom_body.panorama_code`: 10°
blocks of the upper hemisphere, z-scored), and turning on the spot is still rolling whole columns.

Pixels no ommatidium views (above 80° of elevation, below −50°, and the 20° blind sector behind the
head) take the nearest ommatidium's value: the eyes' edge is spread over the gap, no information added.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from neuronav.errors import ConfigError
from neuronav.spec.body import quat_to_matrix

EYE_CHANNELS = ("green", "uv", "uv_green")
EYE_SENSORS = ("compound_eye_L", "compound_eye_R")
NEIGHBOURS = 8
SPREAD_DEG = 3.0  # σ of the pixel's weights over ommatidia: about the horizontal interommatidial angle (4.05°)


def channel_values(values, channel: str) -> np.ndarray:
    """One channel of ommatidia readings ``values`` (..., M, 2) green and UV in [0, 1]: (..., M).

    ``green`` and ``uv`` are the receptors' values; ``uv_green`` is the contrast (UV − G) / (UV + G) in
    [−1, 1] (0 where both are 0): the sky positive, the ground and vegetation negative.
    """
    if channel not in EYE_CHANNELS:
        raise ConfigError(f"eye_channel must be one of {', '.join(EYE_CHANNELS)}, got {channel!r}")
    array = np.asarray(values, float)
    if array.ndim < 2 or array.shape[-1] != 2:
        raise ConfigError(f"compound eye values must have shape (..., M, 2) (green, UV), got {array.shape}")
    green, uv = array[..., 0], array[..., 1]
    if channel == "green":
        return green
    if channel == "uv":
        return uv
    total = green + uv
    return np.divide(uv - green, total, out=np.zeros_like(total), where=total > 1e-12)


def eye_directions(eyes) -> np.ndarray:
    """Every ommatidium's viewing direction in the agent's frame (M_L + M_R, 3), eyes in the given order."""
    return np.concatenate([eye.directions @ quat_to_matrix(eye.quat).T for eye in eyes])


class CompoundPanorama:
    """Both compound eyes' ommatidia (one channel) resampled onto a panoramic camera's pixel grid.

    Parameters
    ----------
    eyes : sequence of CompoundEye
        The eyes in the agent's frame (``point_agent_compound_eyes``), read in this order.
    camera : Camera
        The panoramic camera in the agent's frame (``point_agent_cameras``) whose grid the image takes.
    channel : str
        ``green``, ``uv`` or ``uv_green`` (:func:`channel_values`).
    """

    def __init__(self, eyes, camera, channel: str = "uv") -> None:
        from scipy import sparse
        from scipy.spatial import cKDTree

        from neuronav.senses.vision import pixel_directions

        if channel not in EYE_CHANNELS:
            raise ConfigError(f"eye_channel must be one of {', '.join(EYE_CHANNELS)}, got {channel!r}")
        if len(eyes) == 0:
            raise ConfigError("compound panorama: needs at least one compound eye")
        self.channel, self.names = channel, tuple(eye.name for eye in eyes)
        self.shape = (camera.height_px, camera.width_px)
        camera = replace(camera, supersample=1)
        pixels = pixel_directions(camera).reshape(-1, 3) @ quat_to_matrix(camera.quat).T
        axes = eye_directions(eyes)
        distance, nearest = cKDTree(axes).query(pixels, k=min(NEIGHBOURS, len(axes)))
        distance, nearest = distance.reshape(len(pixels), -1), nearest.reshape(len(pixels), -1)
        angle = 2.0 * np.arcsin(np.clip(distance / 2.0, 0.0, 1.0))
        weights = np.exp(-0.5 * (angle / np.radians(SPREAD_DEG)) ** 2)
        weights[:, 0] = np.maximum(weights[:, 0], 1e-300)  # a pixel far from every ommatidium: its nearest
        weights /= weights.sum(axis=1, keepdims=True)
        rows = np.repeat(np.arange(len(pixels)), nearest.shape[1])
        self.matrix = sparse.csr_matrix((weights.ravel(), (rows, nearest.ravel())), shape=(len(pixels), len(axes)))

    def __call__(self, sensed: dict) -> np.ndarray:
        """Panoramas (N, H, W) from the eyes' readings in ``sensed`` (each (N, M, 2))."""
        missing = [name for name in self.names if name not in sensed]
        if missing:
            raise ConfigError(f"compound panorama: the reading lacks {missing}; read {list(self.names)}")
        values = np.concatenate([channel_values(sensed[name], self.channel) for name in self.names], axis=-1)
        values = values.reshape(-1, values.shape[-1])
        return (self.matrix @ values.T).T.reshape(-1, *self.shape)


def ant_eyes(ommatidia_scale: float = 1.0) -> tuple:
    """The desert ant's two compound eyes and its panoramic camera, placed in a point agent's frame at rest."""
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.bodies.desert_ant.body import point_agent_compound_eyes
    from neuronav.scenarios.visual_setup import point_agent_cameras

    ant = desert_ant(compound_eyes=True, ommatidia_scale=ommatidia_scale)
    camera = next(c for c in point_agent_cameras(ant) if c.name == "panorama")
    return point_agent_compound_eyes(ant), camera
