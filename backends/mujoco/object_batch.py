"""The world's objects as one triangle array, drawn into a view in one GL call (the compound eyes' reads).

MuJoCo's ``mjr_render`` draws every geom of a scene with its own state changes and draw call: with Mesa's
software rasteriser (llvmpipe) 8-14 µs a geom however small it is, so that in the 40-tree forest the ten cube
faces of a binocular compound-eye read (about 150 geoms after each face's cull) spent 1.2 ms of ~3 ms drawing.
:class:`ObjectBatch` keeps the world's bounded geoms (the objects: trees, landmarks; walls) as triangles in
world coordinates, one vertex array with a colour per vertex, and draws the triangles of the geoms a view can
show with one ``glDrawElements``, once MuJoCo has drawn the rest of every view (the ground, the horizon): the
same frame and depth test, flat colours (no lighting, no texture), as the flat-lit scene draws them; all the
views' calls in one pass, GL's state set once for them (0.76-0.78 of a forest read drawn by MuJoCo alone,
against 0.80-0.85 with the state set and restored around each view's call). One call costs about two or three
of MuJoCo's geoms (~20-30 µs, then ~0.1 µs a triangle), so the renderer hands a view to the batch only where it
shows several objects (:data:`neuronav.backends.mujoco.backend.BATCH_MIN_GEOMS`).

The triangles (:mod:`neuronav.engine.tessellation`): spheres of ``slices`` around and ``stacks`` from pole to
pole, cylinders of ``slices`` sides with their caps, boxes, and meshes (MuJoCo's cones) by their own faces,
the vertices where MuJoCo's own spheres and cylinders have them; a geom of another type (a heightfield) is left
to MuJoCo (:attr:`ObjectBatch.drawn`). The world frame vertices are computed again only when a geom has moved
(the scene turned). The GL calls go through PyOpenGL's raw bindings (its wrapped ones cost ~5 µs a call).

The frame: MuJoCo's projection (reverse depth, an infinite far plane) and depth test are the ones it drew its
last view with, still in the GL state: the renderer batches only reads whose views share one field of view (a
compound eye's cube faces); the viewport and the model-view matrix are set here, from each view's place and pose.
``tests/cross_backend/test_compound_eye_agreement.py`` checks that faces drawn this way show MuJoCo's pixels.
Nearly always they do (the 40-tree forest at six headings and the cue-integration forest at 40 random poses:
every one of 921,600 pixels the same). Two things can part them: a colour at the middle of an 8-bit step
(0.3 x 255 = 76.5) may take the step above where MuJoCo's lighting left it a hair under, and a pixel whose
centre lies on a surface's edge may fall on the other side of it, the vertices being turned into the view in
another order of float operations (2 pixels of 161,000 along the top of a 20 m wall). A closed-loop trial that
meets such a pixel can part from the one drawn by MuJoCo alone (a cue-integration trial reached the nest 24 ms
later): the scenarios' MuJoCo compound-eye numbers were measured again with the batch.
"""

from __future__ import annotations

import ctypes
from functools import lru_cache
from types import SimpleNamespace

import mujoco
import numpy as np

from neuronav.engine.tessellation import box_mesh, cylinder_mesh, sphere_mesh
from neuronav.senses.vision import View

# Patterns of shown geoms whose triangle indices :meth:`ObjectBatch.indices` keeps.
KEPT_PATTERNS = 256
# The geom types a batch draws: those the World's objects and walls are built of (neuronav.backends.mujoco.mjcf).
_SHAPES = (int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_CYLINDER), int(mujoco.mjtGeom.mjGEOM_BOX),
           int(mujoco.mjtGeom.mjGEOM_MESH))


def geom_triangles(model: mujoco.MjModel, geom: int, slices: int, stacks: int) -> tuple[np.ndarray, np.ndarray]:
    """Geom ``geom``'s surface in its own frame: vertices (N, 3) and triangles (T, 3) wound outwards
    (:mod:`neuronav.engine.tessellation`; a mesh by its own faces)."""
    kind, size = int(model.geom_type[geom]), np.asarray(model.geom_size[geom], float)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return sphere_mesh(float(size[0]), slices, stacks)
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return cylinder_mesh(float(size[0]), float(size[1]), slices)
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return box_mesh(size)
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        first, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        face_first, face_count = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
        vertices = np.asarray(model.mesh_vert[first:first + count], float)
        return vertices, np.asarray(model.mesh_face[face_first:face_first + face_count], np.int64)
    raise ValueError(f"geom type {kind} is not drawn in a batch")


class ObjectBatch:
    """The geoms ``geoms`` of ``model`` that :func:`geom_triangles` can draw, as one vertex array in world
    coordinates (updated from ``data`` when one has moved) with colours, drawn per view by :meth:`draw`.

    Attributes
    ----------
    drawn : numpy.ndarray of bool, shape (len(geoms),)
        Which of ``geoms`` this batch draws (the others are left to MuJoCo).
    """

    def __init__(self, model: mujoco.MjModel, geoms: np.ndarray, slices: int, stacks: int) -> None:
        geoms = np.asarray(geoms, int)
        self.drawn = np.isin(model.geom_type[geoms], _SHAPES)
        self.geoms = geoms[self.drawn]
        local, triangles, owners, start = [], [], [], 0
        for k, geom in enumerate(self.geoms):
            vertices, faces = geom_triangles(model, int(geom), slices, stacks)
            local.append(vertices)
            triangles.append(faces + start)
            owners.append(np.full(faces.size, k))
            start += len(vertices)
        self._local = local
        self._indices = np.concatenate(triangles).astype(np.uint32).ravel() if triangles else np.zeros(0, np.uint32)
        self._owner = np.concatenate(owners) if owners else np.zeros(0, int)  # each index's geom (position in geoms)
        self._first_vertex = np.cumsum([0] + [len(v) for v in local])
        self._vertices = np.zeros((start, 3), np.float32)
        self._colours = np.zeros((start, 4), np.float32)  # GL turns them into the buffer's bytes, as MuJoCo's
        self._pose: tuple[np.ndarray, np.ndarray] | None = None
        self._rgba: np.ndarray | None = None
        # Triangle indices and a pointer to them, by the pattern of geoms shown.
        self._picked: dict[bytes, tuple[np.ndarray, ctypes.c_void_p]] = {}
        # GL's model-view matrix, column-major, and pointers for the raw GL calls (numpy's .ctypes costs ~4 µs).
        self._modelview = np.eye(4)
        self._modelview_pointer = self._modelview.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._vertices_pointer = ctypes.c_void_p(self._vertices.ctypes.data)
        self._colours_pointer = ctypes.c_void_p(self._colours.ctypes.data)

    def update(self, data: mujoco.MjData, rgba: np.ndarray) -> None:
        """The vertices at the geoms' poses in ``data`` (recomputed only if one has moved) and the colours
        ``rgba`` (len(geoms), 4) in [0, 1], one per drawn geom."""
        positions, frames = data.geom_xpos[self.geoms], data.geom_xmat[self.geoms]
        if self._pose is None or not (np.array_equal(positions, self._pose[0])
                                      and np.array_equal(frames, self._pose[1])):
            for k, (vertices, position, frame) in enumerate(zip(self._local, positions, frames.reshape(-1, 3, 3))):
                self._vertices[self._first_vertex[k]:self._first_vertex[k + 1]] = vertices @ frame.T + position
            self._pose = (positions.copy(), frames.copy())
        if self._rgba is None or not np.array_equal(rgba, self._rgba):
            self._colours[:] = np.repeat(np.asarray(rgba, np.float32), np.diff(self._first_vertex), axis=0)
            self._rgba = np.array(rgba, copy=True)

    def indices(self, shown: np.ndarray) -> tuple[np.ndarray, ctypes.c_void_p]:
        """The triangle indices of the drawn geoms where ``shown`` (bool over :attr:`geoms`) is true, and a pointer
        to them (kept for the last :data:`KEPT_PATTERNS` patterns asked: a walking ant's views show the same geoms
        for many reads)."""
        shown = np.asarray(shown, bool)
        key = shown.tobytes()
        picked = self._picked.pop(key, None)
        if picked is None:
            chosen = self._indices[shown[self._owner]]
            picked = (chosen, ctypes.c_void_p(chosen.ctypes.data))
            if len(self._picked) >= KEPT_PATTERNS:
                self._picked.pop(next(iter(self._picked)))  # the least recently asked
        self._picked[key] = picked
        return picked

    def draw(self, views: list[tuple[View, tuple[int, int], tuple[np.ndarray, ctypes.c_void_p]]]) -> None:
        """Draw into each view (a :class:`View`, its place (left, bottom) in the buffer, its triangles from
        :meth:`indices`) after MuJoCo has rendered them all, with the projection and depth test MuJoCo left set
        (every view of the same field as the last it drew: the caller's to check): flat colours, no lighting,
        no texture; GL's state as it was afterwards."""
        views = [item for item in views if item[2][0].size]
        if not views:
            return
        gl = _gl()
        gl.glPushAttrib(gl.GL_ENABLE_BIT | gl.GL_VIEWPORT_BIT | gl.GL_TRANSFORM_BIT)  # as MuJoCo set them
        gl.glDisable(gl.GL_LIGHTING)
        gl.glDisable(gl.GL_TEXTURE_2D)
        gl.glDisable(gl.GL_BLEND)
        gl.glPushClientAttrib(gl.GL_CLIENT_VERTEX_ARRAY_BIT)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, 0)  # arrays in this process's memory, no buffer object bound
        gl.glBindBuffer(gl.GL_ELEMENT_ARRAY_BUFFER, 0)
        gl.glEnableClientState(gl.GL_VERTEX_ARRAY)
        gl.glEnableClientState(gl.GL_COLOR_ARRAY)
        gl.glVertexPointer(3, gl.GL_FLOAT, 0, self._vertices_pointer)
        gl.glColorPointer(4, gl.GL_FLOAT, 0, self._colours_pointer)
        gl.glMatrixMode(gl.GL_MODELVIEW)
        for view, (left, bottom), (chosen, pointer) in views:
            gl.glViewport(left, bottom, int(view.width_px), int(view.height_px))
            # The view's model-view matrix (column-major): world to camera axes (x right, y up, z backwards).
            rotation = view.rotation
            self._modelview[:3, :3] = rotation  # the transpose of R^T, column-major
            self._modelview[3, :3] = -(np.asarray(view.eye_m, float) @ rotation)
            gl.glLoadMatrixd(self._modelview_pointer)
            gl.glDrawElements(gl.GL_TRIANGLES, chosen.size, gl.GL_UNSIGNED_INT, pointer)
        gl.glPopClientAttrib()
        gl.glPopAttrib()


@lru_cache(maxsize=1)
def _gl() -> SimpleNamespace:
    """The GL 1.x functions :meth:`ObjectBatch.draw` calls, PyOpenGL's raw ctypes bindings (its wrapped ones
    cost ~5 µs a call in argument handling, several times the call) and the constants they take."""
    from OpenGL.raw.GL.VERSION import GL_1_0, GL_1_1, GL_1_5  # mujoco's EGL context comes with PyOpenGL

    names = {GL_1_0: ("glMatrixMode", "glLoadMatrixd", "glPushAttrib", "glPopAttrib", "glDisable", "glViewport",
                      "GL_MODELVIEW", "GL_ENABLE_BIT", "GL_VIEWPORT_BIT", "GL_TRANSFORM_BIT", "GL_LIGHTING",
                      "GL_TEXTURE_2D", "GL_BLEND", "GL_TRIANGLES", "GL_FLOAT", "GL_UNSIGNED_INT"),
             GL_1_1: ("glPushClientAttrib", "glPopClientAttrib", "glEnableClientState", "glVertexPointer",
                      "glColorPointer", "glDrawElements", "GL_CLIENT_VERTEX_ARRAY_BIT", "GL_VERTEX_ARRAY",
                      "GL_COLOR_ARRAY"),
             GL_1_5: ("glBindBuffer", "GL_ARRAY_BUFFER", "GL_ELEMENT_ARRAY_BUFFER")}
    return SimpleNamespace(**{name: getattr(module, name) for module, group in names.items() for name in group})
