"""The follow camera's lit view in MuJoCo (videos, ``render("follow")``): one pass per frame, in a kept GL context.

:class:`FollowRenderer` draws the model's free camera lit (headlight and the world's sun, skybox, haze) into
the offscreen buffer and reads it once. What makes it cheaper than ``mujoco.Renderer`` with the model's
defaults, with Mesa's software rasteriser (llvmpipe, one thread: see
:mod:`neuronav.backends.mujoco.gl_contexts`):

- **No multisampling** (:data:`FOLLOW_SAMPLES`): MuJoCo's default of 4 samples per pixel quadrupled the
  rasteriser's work, 30 ms of CPU per 640 × 480 frame against 7-8 ms without
  (``benchmarks/video_cost.py`` prints a trial's cost with and without video);
- **coarser round shapes** (:data:`FOLLOW_SLICES`, :data:`FOLLOW_STACKS`: 12 × 6 against 28 × 16): 8.5 ms
  a frame became 4.8 ms at 16 × 8 and 3.9 ms at 12 × 6, the ant's segments still round at the size they span
  in the view;
- **one-colour textures sampled nearest** (a plain ground is one, see :mod:`neuronav.backends.mujoco.mjcf`):
  no mipmap lookups over the floor that fills most of the frame (1.5 ms a frame);
- **no sky box where the view cannot see the sky** (:meth:`FollowRenderer.sees_sky`: the follow view looks
  25° down, its top edge 2.5° under the horizon, at a floor reaching 500 m): 1 ms a frame less;
- **an offscreen buffer the size of the view** (the model's is as wide as its widest view, the ant's eyes' 864 ×
  480 px): the wider buffer cost 0.6 ms a frame (3.9 against 3.3 ms with the odour trail's floor and the ant,
  alternating, 150 frames each; measured, not traced to one GL call), for the same picture;
- **one copy of the pixels less**: a frame is read into a buffer of its own and handed over with its rows
  reversed (a view); whoever draws on it copies it anyway, top row first;
- **no shadow map** where no light casts a shadow (the world's sun does not; the headlight never
  does): MuJoCo's default map is 4096² px, made with every context;
- **a kept GL context**: the next trial's follow view reuses this one's, as the eyes do (a new EGL context
  costs ~80 ms of CPU);
- **drawn on a thread of its own** (:class:`GLThread`, one per process, owning the follow views' GL
  contexts: an EGL context is current in one thread at a time): :meth:`FollowRenderer.render_later` copies
  what the frame shows into a scene (``mjv_updateScene``, on the caller's thread) and returns at once; the GL
  thread rasterises it (``mjr_render``, ``mjr_readPixels``: MuJoCo's bindings release the GIL in them) while
  the caller steps on, on the second core. :meth:`FollowRenderer.render` waits for it: the same picture.
  A filmed odour-trail trial's loop thread costs 1.3-1.4 x the trial without video, its process 2.8-3.0 x and
  its wall time about 2 x (``python benchmarks/video_cost.py``: ``loop s``, ``cpu s``, ``wall s``).

The GL rows run bottom-up; :meth:`FollowRenderer.render` returns the image top row first, as
``mujoco.Renderer`` does.
"""

from __future__ import annotations

import atexit
import os
import queue
import threading
from collections.abc import Callable
from concurrent.futures import Future

import mujoco
import numpy as np

from neuronav.backends.mujoco import gl_contexts
from neuronav.errors import ConfigError
from neuronav.senses.vision import GROUND_REACH_M

# Samples per pixel of the follow view (0: none; MuJoCo's default is 4).
FOLLOW_SAMPLES = 0
# The follow view's spheres, capsules and ellipsoids: slices around and stacks along (MuJoCo's default 28 and 16).
# The ant's rounded segments span tens of pixels in the view; the default's vertices cost 40 % of its frame, and
# 16 x 8 still 1.6 ms of a 4.5 ms frame against 1.05 ms at 12 x 6 (no difference to see at 640 x 480).
FOLLOW_SLICES, FOLLOW_STACKS = 12, 6
# The shadow map's side (px) when no light of the model casts a shadow.
NO_SHADOW_PX = 1
# Geoms the follow view's scene holds beyond the model's geoms and sites (mujoco.Renderer's 10000 for every model
# took 19 ms per scene to allocate, twice per trial).
FOLLOW_SPARE_GEOMS = 100
# Scenes a renderer fills in turn: the GL thread rasterises the older ones while the caller fills the next, and
# the caller waits only when it is this many frames ahead (2 stalled a filmed trial's loop more often).
FOLLOW_SCENES = 8
# Free GL contexts the GL thread keeps per buffer size for the next renderer (the next trial's).
KEPT_CONTEXTS = 2


class GLThread:
    """The thread that does every GL call of the process's follow views, in contexts only it makes current.

    Jobs run one at a time in the order given (:meth:`submit` returns a ``concurrent.futures.Future``);
    it keeps up to :data:`KEPT_CONTEXTS` free contexts per size (:meth:`acquire`, :meth:`release`, called
    on the thread). A forked child gets a thread of its own (:func:`gl_thread`); the parent's contexts are
    never touched there.
    """

    def __init__(self) -> None:
        self.pid = os.getpid()
        self.free: dict[tuple[int, int], list] = {}
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="mujoco follow view (GL)", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            job()

    def submit(self, function: Callable, *args) -> Future:
        """Run ``function(*args)`` on the GL thread; its result (or its error) in the returned future."""
        future: Future = Future()

        def job() -> None:
            if future.set_running_or_notify_cancel():
                try:
                    future.set_result(function(*args))
                except BaseException as error:  # noqa: BLE001 -- handed to the caller through the future
                    future.set_exception(error)

        self._jobs.put(job)
        return future

    def call(self, function: Callable, *args):
        """Run ``function(*args)`` on the GL thread and wait for its result."""
        if threading.current_thread() is self._thread:
            return function(*args)
        return self.submit(function, *args).result()

    def acquire(self, width: int, height: int) -> mujoco.GLContext:
        """A context of ``width`` x ``height`` px, current on this thread (a kept one, else a new one)."""
        kept = self.free.get((width, height))
        if kept:
            context = kept.pop()
        else:
            context = mujoco.GLContext(width, height)
            if not _EXIT_HOOK:  # after mujoco's own hook (made with its first context: it ends EGL at exit)
                atexit.register(_free_at_exit)
                _EXIT_HOOK.append(True)
        context.make_current()
        return context

    def release(self, context: mujoco.GLContext, width: int, height: int) -> None:
        """Keep ``context`` for the next :meth:`acquire` of its size (or free it when enough are kept)."""
        kept = self.free.setdefault((width, height), [])
        if len(kept) < KEPT_CONTEXTS:
            kept.append(context)
        else:
            context.free()

    def free_kept(self) -> None:
        """Free the kept contexts (on the thread) and end the thread (at exit, before EGL itself is ended)."""
        def free() -> None:
            gl_contexts.free_all(self.free)
            self.free = {}

        if self.pid == os.getpid() and self._thread.is_alive():
            self.submit(free)
            self._jobs.put(None)
            self._thread.join(timeout=5.0)


_GL_THREAD: list[GLThread] = []
_EXIT_HOOK: list[bool] = []


def gl_thread() -> GLThread:
    """This process's :class:`GLThread` (started on first use; a forked child starts its own)."""
    if _GL_THREAD and _GL_THREAD[0].pid == os.getpid():
        return _GL_THREAD[0]
    if _GL_THREAD:  # forked: the parent's thread is not here, its contexts are kept but never called
        gl_contexts.abandon(_GL_THREAD.pop())
    gl_contexts.contexts_made()  # a child of a parent whose driver ran rasteriser threads refuses here
    worker = GLThread()
    _GL_THREAD.append(worker)
    return worker


def _free_at_exit() -> None:
    if _GL_THREAD:
        _GL_THREAD[0].free_kept()


def _idle_before_fork() -> None:
    """Let the GL thread finish what it was given before the process forks: a child inherits the driver's locks as
    they are, and one held mid-frame would never be released there."""
    if _GL_THREAD and _GL_THREAD[0].pid == os.getpid() and _GL_THREAD[0]._thread.is_alive():
        _GL_THREAD[0].call(int)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(before=_idle_before_fork)


class FollowRenderer:
    """The follow view of one model, ``width`` × ``height`` px, drawn lit in a GL context of the process.

    Parameters
    ----------
    model : mujoco.MjModel
        Its offscreen buffer (``vis.global_.offwidth`` × ``offheight``) must hold the image.
    width, height : int
        The image's size, px.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int) -> None:
        self.width, self.height = int(width), int(height)
        self.buffer_px = (int(model.vis.global_.offwidth), int(model.vis.global_.offheight))
        if self.width > self.buffer_px[0] or self.height > self.buffer_px[1]:
            raise ConfigError(f"mujoco follow view: {self.width} x {self.height} px does not fit the model's offscreen "
                              f"buffer of {self.buffer_px[0]} x {self.buffer_px[1]} px (visual.global offwidth, "
                              f"offheight)")
        self.pid = os.getpid()
        self._worker = gl_thread()
        self._gl = None
        self._worker.call(self._make_context, model)
        max_geom = int(model.ngeom + model.nsite + model.ntendon) + FOLLOW_SPARE_GEOMS
        self._scenes = [mujoco.MjvScene(model, maxgeom=max_geom) for _ in range(FOLLOW_SCENES)]
        self._pending: list[Future | None] = [None] * FOLLOW_SCENES
        self._next = 0
        self._perturb = mujoco.MjvPerturb()
        self._rect = mujoco.MjrRect(0, 0, self.width, self.height)

    def _make_context(self, model: mujoco.MjModel) -> None:
        """On the GL thread: a context and the model's ``MjrContext`` in it (drawn to the offscreen buffer)."""
        self._gl = self._worker.acquire(*self.buffer_px)
        quality, buffer = model.vis.quality, model.vis.global_
        kept = (int(quality.offsamples), int(quality.shadowsize), int(quality.numslices), int(quality.numstacks))
        kept_size = (int(buffer.offwidth), int(buffer.offheight))
        buffer.offwidth, buffer.offheight = self.width, self.height
        quality.offsamples, quality.numslices, quality.numstacks = FOLLOW_SAMPLES, FOLLOW_SLICES, FOLLOW_STACKS
        if not np.any(model.light_castshadow):
            quality.shadowsize = NO_SHADOW_PX
        try:
            self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        except BaseException:
            self._worker.release(self._gl, *self.buffer_px)
            self._gl = None
            raise
        finally:
            quality.offsamples, quality.shadowsize, quality.numslices, quality.numstacks = kept
            buffer.offwidth, buffer.offheight = kept_size
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self._plain_textures_nearest(model)

    def _plain_textures_nearest(self, model: mujoco.MjModel) -> None:
        """Sample one-colour 2D textures (a plain ground's) nearest: the same colour, without the mipmap
        lookups that cost a ground filling the frame 1.5 ms of the rasteriser's time per frame."""
        from OpenGL import GL  # mujoco's EGL context comes with PyOpenGL

        for texture in range(model.ntex):
            if model.tex_type[texture] != mujoco.mjtTexture.mjTEXTURE_2D:
                continue
            start = model.tex_adr[texture]
            size = model.tex_width[texture] * model.tex_height[texture] * model.tex_nchannel[texture]
            texels = model.tex_data[start:start + size].reshape(-1, model.tex_nchannel[texture])
            if (texels == texels[0]).all():
                GL.glBindTexture(GL.GL_TEXTURE_2D, int(self._context.texture[texture]))
                GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MIN_FILTER, GL.GL_NEAREST)
                GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MAG_FILTER, GL.GL_NEAREST)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)

    @staticmethod
    def sees_sky(camera: mujoco.MjvGLCamera, reach_m: float = GROUND_REACH_M) -> bool:
        """Whether any pixel of ``camera`` (MuJoCo's free camera: never rolled) can miss the floor, which
        reaches ``reach_m`` from the origin along x and y, nearer than the far clipping plane (no wall or object is
        counted: they only hide sky).

        Rays of the view rise toward its top edge, and along that edge, when they point down, toward its
        corners: where both top corners meet the floor within the reach, every ray does.
        """
        forward, up = np.asarray(camera.forward, float), np.asarray(camera.up, float)
        right = np.cross(forward, up)
        eye = np.asarray(camera.pos, float)
        centre = forward * camera.frustum_near + up * camera.frustum_top
        for side in (-1.0, 1.0):
            ray = centre + right * (camera.frustum_center + side * camera.frustum_width)
            if ray[2] >= 0.0 or eye[2] <= 0.0:
                return True
            along = eye[2] / -ray[2]  # the ray (its depth along forward is frustum_near) meets z = 0 at this multiple
            if along * np.hypot(ray[0], ray[1]) >= reach_m - np.abs(eye[:2]).max() \
                    or along * camera.frustum_near >= camera.frustum_far:
                return True
        return False

    def render(self, model: mujoco.MjModel, data: mujoco.MjData, camera: mujoco.MjvCamera,
               option: mujoco.MjvOption) -> np.ndarray:
        """The view of ``camera`` (geoms as ``option`` shows them): a new uint8 (height, width, 3) image."""
        return np.ascontiguousarray(self.render_later(model, data, camera, option).result())

    def render_later(self, model: mujoco.MjModel, data: mujoco.MjData, camera: mujoco.MjvCamera,
                     option: mujoco.MjvOption) -> Future:
        """:meth:`render` as a future (its image a view with the rows reversed, not C-contiguous): the scene is
        taken now (``data`` may change once this returns), the picture drawn on the GL thread (:class:`GLThread`).
        At most :data:`FOLLOW_SCENES` are drawn at once: past them this waits for the oldest."""
        if self._gl is None:
            raise ConfigError("mujoco follow view: rendered after close()")
        slot = self._next
        self._next = (slot + 1) % FOLLOW_SCENES
        if self._pending[slot] is not None:
            self._pending[slot].exception()  # wait until its scene is drawn (its error is its own future's)
        scene = self._scenes[slot]
        mujoco.mjv_updateScene(model, data, option, self._perturb, camera, int(mujoco.mjtCatBit.mjCAT_ALL), scene)
        scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = int(self.sees_sky(scene.camera[0]))
        self._pending[slot] = future = self._worker.submit(self._draw, slot)
        return future

    def _draw(self, slot: int) -> np.ndarray:
        """On the GL thread: scene ``slot`` rasterised and read, top row first: a view, rows reversed, of a new
        buffer (whoever draws on the frame copies it anyway, in row order: a copy less per frame)."""
        self._gl.make_current()
        mujoco.mjr_render(self._rect, self._scenes[slot], self._context)
        rgb = np.empty((self.height, self.width, 3), dtype=np.uint8)
        mujoco.mjr_readPixels(rgb, None, self._rect, self._context)
        return rgb[::-1]

    def close(self) -> None:
        """Wait for the frames being drawn, free what the model put in the GL context and keep the context for the
        next renderer; in a forked child, touch nothing of the parent's."""
        if self._gl is None:
            return
        if self.pid == os.getpid():
            for future in self._pending:
                if future is not None:
                    future.exception()
            self._worker.call(self._free_context)
        else:
            gl_contexts.abandon(self._context)
            gl_contexts.abandon(self._gl)
        self._gl = None

    def _free_context(self) -> None:
        self._gl.make_current()
        self._context.free()
        self._worker.release(self._gl, *self.buffer_px)
