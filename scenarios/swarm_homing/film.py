"""The swarm's video (``neuronav run swarm-homing --video``): the whole swarm from above, on every backend.

The swarm has no agent loop to hook a :class:`~neuronav.engine.video.VideoRecorder` into (its ants step
together in :func:`~neuronav.scenarios.swarm_homing.scenario.run_swarm`), and the swarm backends have no
cameras, so :class:`SwarmFilm` draws each frame with numpy, as the kinematic backend's view from above does
(:class:`~neuronav.engine.video_topview.TopViewCamera`, the same ground, grid and framing): every home as a
ring of the nest radius, the path each ant has walked (the first :data:`MAX_PATHS`), each ant as a dot with a
tick toward its heading, coloured by its phase (foraging, homing, home), the time and how many are home,
and the first ant's CPU4 memory as an inset (the home vector it integrates). Every ant is drawn in a few
array operations (a frame of 1000 ants costs about what one of 20 does). One frame every
``VIDEO_EVERY`` control steps, played in real time; the first swarm of the run is filmed (trial 0's).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neuronav.engine.video import FrameWriter, VideoFile, real_time_fps
from neuronav.engine.video_draw import disc_mask, disc_offsets, put_text
from neuronav.engine.video_overlay import bars, draw_insets
from neuronav.engine.video_topview import TopViewCamera
from neuronav.spec.world import World

# Ants whose paths are drawn (their positions kept for every frame, to redraw the paths when the view grows).
MAX_PATHS = 1000
FORAGING_RGB = (30, 30, 30)
HOMING_RGB = (230, 110, 0)
HOME_RGB = (20, 150, 60)  # an ant that is home, and the homes' rings
PATH_RGB = (30, 110, 235)
PATH_ALPHA = 0.45
TEXT_RGB = (20, 20, 20)
# An ant: a dot of this radius (px; smaller in a swarm of more than MANY ants) and a tick this long toward its heading.
ANT_DOT_PX, ANT_TICK_PX, MANY = 3, 8, 200
RING_PX = 2.5  # the homes' rings' width (px; a thinner green ring loses its colour to the video's halved chroma)


class SwarmFilm(VideoFile):
    """Frames of one swarm into the MP4 ``path`` (written under a temporary name, given its own by :meth:`close`;
    a failed frame stops the video, not the swarm: :class:`~neuronav.engine.video.VideoFile`).

    Parameters
    ----------
    path : Path
    world : World
        The swarm's world (its ground colour and extent).
    homes_m : ndarray, shape (N, 2)
        Every ant's home; the view starts framed on them and grows to keep every ant in it.
    nest_radius_m : float
        An ant within this of its home is home (the rings' radius).
    control_dt_s : float
        The control step; a frame is taken every ``every`` of them and the video plays in real time.
    every : int
    """

    def __init__(self, path: Path, world: World, homes_m: np.ndarray, nest_radius_m: float, control_dt_s: float,
                 every: int) -> None:
        super().__init__(path)
        self.every, self._fps = int(every), real_time_fps(control_dt_s, int(every))
        self.homes_m = np.asarray(homes_m, float)
        self.nest_radius_m = float(nest_radius_m)
        self.camera = TopViewCamera(world)
        self.camera.framing.frame(self.homes_m)
        self._drawn = min(len(self.homes_m), MAX_PATHS)
        self._history: list[np.ndarray] = []  # the drawn ants' positions (n, 2) at each frame
        # (the view, the ground with the paths in it, which pixels are path (flat), the homes' rings (flat indices))
        self._kept: tuple | None = None

    def film(self, positions_m: np.ndarray, headings_rad: np.ndarray, home_at_s: np.ndarray, homing: bool,
             time_s: float, cpu4: np.ndarray | None = None) -> None:
        """One frame: the ants at ``positions_m`` (N, 2+) facing ``headings_rad`` (N,) (clockwise from +y),
        ``home_at_s`` (N,) finite for those home, ``homing`` whether the swarm has turned home, at ``time_s``;
        ``cpu4`` (the first ant's CPU4 memory) as the inset. A frame that fails stops the video, not the swarm."""
        if self.error is not None:
            return
        try:
            self._film(positions_m, headings_rad, home_at_s, homing, time_s, cpu4)
        except Exception as error:  # noqa: BLE001 -- the swarm goes on unfilmed; why is written beside the video
            self._give_up(error, time_s)

    def _film(self, positions_m, headings_rad, home_at_s, homing, time_s, cpu4) -> None:
        if self._writer is None:
            self._writer = FrameWriter(self._partial, self._fps)
        positions = np.asarray(positions_m, float)[:, :2]
        headings = np.ravel(np.asarray(headings_rad, float))
        home = np.isfinite(np.asarray(home_at_s, float))
        self._history.append(positions[:self._drawn].astype(np.float32))
        self.camera.framing.keep(positions)
        view = self.camera.view
        base, rings = self._background(view)
        image = base.copy()
        shape, pixels = image.shape[:2], image.reshape(-1, 3)
        pixels[rings] = HOME_RGB
        radius = ANT_DOT_PX if len(positions) <= MANY else ANT_DOT_PX - 1
        centres = view.project(positions)[0]
        forward = np.column_stack([np.sin(headings), -np.cos(headings)])  # image columns right, rows down
        ticks = centres[None] + np.linspace(0.0, ANT_TICK_PX, ANT_TICK_PX + 1)[:, None, None] * forward[None]
        dot = disc_offsets(radius)[:, ::-1]  # (column, row) offsets
        for state, rgb in ((False, HOMING_RGB if homing else FORAGING_RGB), (True, HOME_RGB)):
            chosen = home == state
            if chosen.any():
                ant = np.concatenate([(centres[chosen][:, None] + dot[None]).reshape(-1, 2),
                                      ticks[:, chosen].reshape(-1, 2)])
                pixels[_flat_pixels(ant, shape)] = rgb
        put_text(image, f"t = {int(time_s):4d} s   {'homing' if homing else 'foraging'}   home: {int(home.sum())} of "
                        f"{len(home)}", 6, 8, TEXT_RGB)
        if cpu4 is not None:
            rates = np.ravel(np.asarray(cpu4, float))
            low, high = float(np.min(rates)), float(np.max(rates))
            scaled = (rates - low) / (high - low) if high > low else np.zeros_like(rates)
            draw_insets(image, [("ant 0: CPU4 memory", bars(scaled, None))])
        self._writer.append(image)
        self.frames += 1

    def _background(self, view) -> tuple[np.ndarray, np.ndarray]:
        """The ground in ``view`` with the paths walked so far blended in (H, W, 3), and the homes' rings (flat
        pixel indices): the last step's new path pixels added to the kept picture, or all of it drawn again when
        the view has changed (it only grows, rarely)."""
        if self._kept is None or self._kept[0] != view:
            base = self.camera.render(np.empty((0, 2)), np.empty(0))  # the ground (and grid), framed
            shape = base.shape[:2]
            walked = np.zeros(shape[0] * shape[1], bool)
            steps = [_step_points(view, a, b) for a, b in zip(self._history[:-1], self._history[1:])]
            walked[_flat_pixels(np.concatenate(steps) if steps else np.empty((0, 2)), shape)] = True
            _blend_pixels(base, np.flatnonzero(walked))
            homes = view.project(self.homes_m)[0]
            outer_px = max(2.0, self.nest_radius_m / view.m_per_px)
            rings = disc_mask(shape, homes, outer_px) & ~disc_mask(shape, homes, max(0.0, outer_px - RING_PX))
            self._kept = (view, base, walked, np.flatnonzero(rings))
        elif len(self._history) > 1:
            _, base, walked, _ = self._kept
            new = _flat_pixels(_step_points(view, self._history[-2], self._history[-1]), base.shape[:2])
            new = np.unique(new[~walked[new]])
            walked[new] = True
            _blend_pixels(base, new)
        return self._kept[1], self._kept[3]


def _step_points(view, before_m: np.ndarray, after_m: np.ndarray) -> np.ndarray:
    """Pixels (K, 2) (column, row) along each ant's straight step from ``before_m`` to ``after_m`` (n, 2) in
    ``view``, at least one a pixel."""
    start, end = view.project(before_m)[0], view.project(after_m)[0]
    keep = np.isfinite(start).all(axis=1) & np.isfinite(end).all(axis=1)
    start, end = start[keep], end[keep]
    if not len(start):
        return np.empty((0, 2))
    samples = int(np.clip(np.ceil(np.abs(end - start).max()), 1, 64)) + 1
    t = np.linspace(0.0, 1.0, samples)[:, None, None]
    return (start[None] + t * (end - start)[None]).reshape(-1, 2)


def _flat_pixels(points_px: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Flat indices into an (H, W) image of the pixels of ``points_px`` (K, 2) (column, row; rounded) inside it."""
    points = np.rint(points_px).astype(int).reshape(-1, 2)
    height, width = shape
    inside = (points[:, 0] >= 0) & (points[:, 0] < width) & (points[:, 1] >= 0) & (points[:, 1] < height)
    return points[inside, 1] * width + points[inside, 0]


def _blend_pixels(image: np.ndarray, flat: np.ndarray) -> None:
    """Blend the path's colour over the pixels ``flat`` (flat indices) of ``image`` (H, W, 3), in place."""
    pixels = image.reshape(-1, 3)
    pixels[flat] = (pixels[flat] * (1.0 - PATH_ALPHA) + np.asarray(PATH_RGB, float) * PATH_ALPHA).astype(np.uint8)
