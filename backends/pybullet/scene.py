"""The world in PyBullet: ground (plane, heightfield, wall) and static objects, for physics and for vision.

Three builds of one :class:`World`:

- :func:`build_ground` and :func:`build_object` in the physics client: collision shapes, with a look
  for the follow camera's videos (the floor in the World's appearance: plain out to
  :data:`neuronav.senses.vision.GROUND_REACH_M`, as the eyes' ground and MuJoCo's plane, or a checker texture
  over ``Ground.size_m`` of squares of ``checker_m`` aligned with the world axes, with the parity of
  every backend: ``ground_rgb`` where ``floor(x / checker_m) + floor(y / checker_m)`` is even, and beyond
  it, out to the same reach, a ring in the checker's mean colour: no floor edge under the horizon);
- :func:`build_ray_world` in a client of collision shapes alone, that rays from the body are cast in;
- :func:`build_vision_world` in a render-only client that holds no body: looks only, the ground
  reaching :data:`neuronav.senses.vision.GROUND_REACH_M` from the origin. Body cameras colour the ground
  themselves (:mod:`neuronav.backends.pybullet.camera`), so its look there does not matter. The compound
  eyes draw a second, coarser copy of the objects there (:func:`build_eye_objects`), hidden from the cameras.

Odour trails (:mod:`neuronav.senses.trail_floor`, flat grounds only): in the physics client, a visual-only
mesh (no collision shape: nothing touches it, no ray hits it) over the floor image's rectangle,
``TRAIL_LIFT_M`` above z = 0, textured with the image (written once per image into ``folder``
as a PNG); in the render-only client nothing: body cameras colour the floor's pixels from the
image themselves (:mod:`neuronav.backends.pybullet.camera`), as they colour the checker.

TinyRenderer truncates ``255 * rgba`` to an integer; :func:`exact_rgba` asks for the middle of the
colour's 8-bit step, so that a surface shows ``round(255 * rgba)``, as on the other engines.
"""

from __future__ import annotations

import math
import os
import zlib

import numpy as np

from neuronav.backends.pybullet.engine import pb
from neuronav.engine.tessellation import box_mesh, cone_mesh, cylinder_mesh, sphere_mesh
from neuronav.senses.trail_floor import TrailFloor, ground_rgb_at, png_bytes, trail_floor
from neuronav.senses.vision import GROUND_REACH_M, to_uint8
from neuronav.spec.world import World, WorldObject

WALL_THICKNESS_M = 0.2
WALL_RGB = (0.6, 0.6, 0.65)
CONE_SIDES = 32
# The compound eyes' copies of the round objects (in the render-only client): spheres, cylinders and cones of
# EYE_SIDES sides, a sphere of EYE_STACKS stacks, as MuJoCo's compound eyes draw them. TinyRenderer's cost grows
# with the triangles it draws: its own spheres and cylinders and the 32-sided cones cost a 40-tree forest's
# compound-eye read about 1.8 times the GL time, for silhouettes a fraction of a face pixel truer.
EYE_SIDES, EYE_STACKS = 12, 6
# The videos' floor texture has one texel per checker square, at most this many squares a side.
MAX_FLOOR_SQUARES = 1024
# Below the heightfield (uneven ground), the flat floor's look hides this far under z = 0.
UNDER_FIELD_M = 2e-3
# The trails' floor image lies this far above z = 0 (over the floor in the follow view's depth buffer).
TRAIL_LIFT_M = 2e-3
# A textured rectangle (the checker floor, the trails) is drawn in quads of at most this side.
TEXTURED_CELL_M = 10.0


def exact_rgba(rgba) -> list[float]:
    """``rgba`` such that TinyRenderer (which truncates) shows ``round(255 * rgba)`` in each channel."""
    rgb = (to_uint8(np.asarray(rgba, float)[:3]) + 0.5) / 255.0
    alpha = float(rgba[3]) if len(rgba) > 3 else 1.0
    return [*map(float, rgb), alpha]


def build_ground(cid: int, world: World, folder: str) -> list[int]:
    """The ground of ``world`` in the physics client: a plane (a heightfield, a wall) with a look in the
    World's appearance over ``Ground.size_m`` (a checker texture in ``folder``); returns the ground's bodies."""
    ground, appearance = world.ground, world.appearance
    plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=cid)
    bodies = []
    top = 0.0
    terrain = _heightfield(cid, world)
    if terrain is not None:
        set_friction(cid, world, terrain)
        bodies.append(terrain)
        top = -UNDER_FIELD_M  # the plane's look hides under the field
    checker = appearance.ground_texture == "checker"
    squares = 2 * math.ceil(ground.size_m / 2.0 / appearance.checker_m)
    if checker and squares <= MAX_FLOOR_SQUARES:
        half = squares * appearance.checker_m / 2.0  # whole squares, a corner at the origin
        look = _rectangle_look(cid, (-half, half), (-half, half), top)
        floor = pb.createMultiBody(0.0, plane, look, [0.0, 0.0, 0.0], physicsClientId=cid)
        pb.changeVisualShape(floor, -1, textureUniqueId=_texture(cid, checker_image(appearance, squares), "checker",
                                                                 folder), physicsClientId=cid)
    else:
        half = max(ground.size_m / 2.0, GROUND_REACH_M)  # plain: on to the horizon, as the eyes see it
        look = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half, half, 0.005],
                                    visualFramePosition=[0.0, 0.0, top - 0.005],
                                    rgbaColor=exact_rgba(appearance.ground_rgb), physicsClientId=cid)
        floor = pb.createMultiBody(0.0, plane, look, [0.0, 0.0, 0.0], physicsClientId=cid)
    set_friction(cid, world, floor)
    bodies.append(floor)
    if half < GROUND_REACH_M:
        _horizon_ring(cid, appearance, half, top)
    trails = trail_floor(world)
    if trails is not None:
        _trail_floor_body(cid, trails, folder)
    wall = _wall(cid, world, with_collision=True)
    if wall is not None:
        set_friction(cid, world, wall)
    return bodies


def _horizon_ring(cid: int, appearance, half_m: float, top_m: float) -> list[int]:
    """The floor's look beyond a checker floor of half side ``half_m``, out to ``GROUND_REACH_M`` (as the eyes'
    ground and MuJoCo's plane reach): four visual-only boxes around it, their tops at ``top_m``, in the
    checker's mean colour (what its squares blend to in the distance). Returns their bodies."""
    reach = GROUND_REACH_M
    rgb = np.asarray(appearance.ground_rgb, float)
    if appearance.ground_texture == "checker":
        rgb = (rgb + np.asarray(appearance.checker_rgb, float)) / 2.0
    rgba = exact_rgba(rgb)
    side, middle = (reach - half_m) / 2.0, (reach + half_m) / 2.0
    boxes = (((0.0, middle), (reach, side)), ((0.0, -middle), (reach, side)),  # (centre x, y), (half x, y)
             ((middle, 0.0), (side, half_m)), ((-middle, 0.0), (side, half_m)))
    bodies = []
    for (x, y), (hx, hy) in boxes:
        look = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[hx, hy, 0.005], visualFramePosition=[0.0, 0.0, -0.005],
                                    rgbaColor=rgba, physicsClientId=cid)
        bodies.append(pb.createMultiBody(0.0, -1, look, [x, y, top_m], physicsClientId=cid))
    return bodies


def _trail_floor_body(cid: int, floor: TrailFloor, folder: str) -> int:
    """The trails' floor image over its rectangle, ``TRAIL_LIFT_M`` up, visual only; its body."""
    look = _rectangle_look(cid, floor.x_range_m, floor.y_range_m, TRAIL_LIFT_M)
    body = pb.createMultiBody(0.0, -1, look, [0.0, 0.0, 0.0], physicsClientId=cid)
    pb.changeVisualShape(body, -1, textureUniqueId=_texture(cid, floor.image, "trails", folder), physicsClientId=cid)
    return body


def _rectangle_look(cid: int, x_range_m, y_range_m, z_m: float) -> int:
    """A horizontal rectangle at height ``z_m`` that shows one copy of its texture, as a visual shape.

    A grid of quads at most ``TEXTURED_CELL_M`` a side (TinyRenderer's texture coordinates stay
    exact on such triangles: measured within one texel in an oblique view; a box's faces would
    each show a quarter of the texture), with texture coordinates (u, v) = ((x - x0) / (x1 - x0),
    (y - y0) / (y1 - y0)): PyBullet puts v = 1 on a PNG's first row, so an image's row 0 lies at
    the rectangle's largest y and its column 0 at the smallest x.
    """
    (x0, x1), (y0, y1) = x_range_m, y_range_m
    columns = max(1, math.ceil((x1 - x0) / TEXTURED_CELL_M))
    rows = max(1, math.ceil((y1 - y0) / TEXTURED_CELL_M))
    u, v = np.meshgrid(np.linspace(0.0, 1.0, columns + 1), np.linspace(0.0, 1.0, rows + 1))
    u, v = u.ravel(), v.ravel()
    vertices = np.column_stack([x0 + u * (x1 - x0), y0 + v * (y1 - y0), np.full(u.size, float(z_m))])
    corner = (np.arange(rows)[:, None] * (columns + 1) + np.arange(columns)[None, :]).ravel()
    # Two counter-clockwise triangles (seen from above) per quad.
    triangles = np.column_stack([corner, corner + 1, corner + columns + 2, corner, corner + columns + 2,
                                 corner + columns + 1])
    return pb.createVisualShape(pb.GEOM_MESH, vertices=vertices.tolist(), indices=triangles.ravel().tolist(),
                                uvs=np.column_stack([u, v]).tolist(), normals=[[0.0, 0.0, 1.0]] * u.size,
                                rgbaColor=[1.0, 1.0, 1.0, 1.0], physicsClientId=cid)


def _texture(cid: int, image: np.ndarray, stem: str, folder: str) -> int:
    """``image`` (uint8 (H, W, 3)) loaded as a texture, from a PNG in ``folder`` written once per image."""
    image = np.ascontiguousarray(image, np.uint8)
    path = os.path.join(folder, f"{stem}_{zlib.crc32(image.tobytes()):08x}_{image.shape[0]}x{image.shape[1]}.png")
    if not os.path.exists(path):
        with open(path, "wb") as handle:
            handle.write(png_bytes(image))
    return pb.loadTexture(path, physicsClientId=cid)


def build_vision_world(cid: int, world: World) -> tuple[list[int], float, list[int]]:
    """The world's looks in a render-only client: the ground (its bodies first) reaching
    ``GROUND_REACH_M`` from the origin, the wall, then one body per object (in ``world.objects``' order).

    Returns
    -------
    ground : list of int
        The ground's bodies (its pixels are coloured by the camera): a heightfield if any, the flat floor last.
    floor_z_m : float
        The flat floor's top (0, or just under the heightfield's lowest point).
    objects : list of int
        The objects' bodies.
    """
    ground = []
    terrain = _heightfield(cid, world)
    top = 0.0
    if terrain is not None:
        ground.append(terrain)
        top = -UNDER_FIELD_M
    half = GROUND_REACH_M * 1.01
    look = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half, half, 0.005], visualFramePosition=[0.0, 0.0, -0.005],
                                rgbaColor=exact_rgba(world.appearance.ground_rgb), physicsClientId=cid)
    ground.append(pb.createMultiBody(0.0, -1, look, [0.0, 0.0, top], physicsClientId=cid))
    _wall(cid, world, with_collision=False)
    objects = [build_object(cid, world, obj, with_collision=False) for obj in world.objects]
    return ground, top, objects


def _heightfield(cid: int, world: World) -> int | None:
    """The uneven ground's heightfield (None when the ground is flat), in ``ground_rgb``."""
    ground = world.ground
    heights = ground.heights_m()
    if not heights.max() > heights.min():
        return None
    spacing = ground.size_m / (ground.cells - 1)
    field = pb.createCollisionShape(
        pb.GEOM_HEIGHTFIELD, meshScale=[spacing, spacing, 1.0], heightfieldData=heights.ravel().tolist(),
        numHeightfieldRows=ground.cells, numHeightfieldColumns=ground.cells, physicsClientId=cid)
    # PyBullet centres the field at the midpoint of its extreme heights: lift it back. Without a
    # visual shape TinyRenderer draws the collision shape (in the colour set here).
    lift = (heights.max() + heights.min()) / 2.0
    terrain = pb.createMultiBody(0.0, field, -1, [0.0, 0.0, lift], physicsClientId=cid)
    pb.changeVisualShape(terrain, -1, rgbaColor=exact_rgba(world.appearance.ground_rgb), textureUniqueId=-1,
                         physicsClientId=cid)
    return terrain


def _wall(cid: int, world: World, with_collision: bool) -> int | None:
    ground = world.ground
    if ground.kind != "wall":
        return None
    extents = [WALL_THICKNESS_M / 2.0, ground.size_m / 2.0, ground.wall_height_m / 2.0]
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=extents, physicsClientId=cid) if with_collision else -1
    look = pb.createVisualShape(pb.GEOM_BOX, halfExtents=extents, rgbaColor=exact_rgba(WALL_RGB), physicsClientId=cid)
    return pb.createMultiBody(0.0, shape, look, [ground.wall_distance_m + WALL_THICKNESS_M / 2.0, 0.0,
                                                 ground.wall_height_m / 2.0], physicsClientId=cid)


def checker_image(appearance, squares: int) -> np.ndarray:
    """The appearance's checker over a floor of ``squares`` (even) squares a side centred on the origin,
    one texel per square (uint8 (squares, squares, 3), row 0 at the largest y): the colour of
    :func:`neuronav.senses.trail_floor.ground_rgb_at` at each square's centre."""
    centres = (np.arange(squares) + 0.5 - squares / 2.0) * appearance.checker_m
    return to_uint8(ground_rgb_at(appearance, centres[None, :], centres[::-1, None]))


def build_ray_world(cid: int, world: World) -> list[int]:
    """The world's surfaces alone in a client of their own, for casting rays from the body: the plane (or the
    heightfield), the wall and the objects (in ``world.objects``' order, their bodies returned), with no body
    among them; boxes and cones as static triangle meshes of the same surface (:func:`flat_sided_mesh`). Bullet's
    ray test of a ray that starts among a body's links costs several times one that does not, even when the body
    is masked out, and a ray meets a triangle mesh (a tree of its triangles' boxes) in about half the time of a
    convex shape (which Bullet casts against by its general convex cast)."""
    if _heightfield(cid, world) is None:
        pb.createMultiBody(0.0, pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=cid), -1, [0.0, 0.0, 0.0],
                           physicsClientId=cid)
    _wall(cid, world, with_collision=True)
    handles = []
    for obj in world.objects:
        if obj.shape in ("box", "cone"):  # the same surface as a triangle mesh
            vertices, indices = flat_sided_mesh(obj)
            shape = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, indices=indices,
                                            flags=pb.GEOM_FORCE_CONCAVE_TRIMESH, physicsClientId=cid)
            handles.append(pb.createMultiBody(0.0, shape, -1, list(obj.position_m), physicsClientId=cid))
        else:  # a sphere or cylinder stays exact
            handles.append(build_object(cid, world, obj))
    return handles


def flat_sided_mesh(obj: WorldObject) -> tuple[list[list[float]], list[int]]:
    """A box, or a cone as the physics client's hull of :data:`CONE_SIDES` sides, as a closed triangle mesh about
    its centre (the same surface). Returns the vertices and the flat triangle indices."""
    if obj.shape == "cone":
        return round_mesh(obj, CONE_SIDES)
    vertices, triangles = box_mesh(obj.size_m)
    return vertices.tolist(), triangles.ravel().tolist()


def build_eye_objects(cid: int, world: World) -> list[int]:
    """The world's objects as the compound eyes draw them, in the render-only client: looks only, round shapes of
    :data:`EYE_SIDES` sides (:func:`round_mesh`), in ``world.objects``' order. Hidden (alpha 0, which TinyRenderer
    does not draw) until a culling shows them."""
    handles = [build_object(cid, world, obj, with_collision=False, sides=EYE_SIDES) for obj in world.objects]
    for handle in handles:
        pb.changeVisualShape(handle, -1, rgbaColor=[0.0, 0.0, 0.0, 0.0], physicsClientId=cid)
    return handles


def round_mesh(obj: WorldObject, sides: int, stacks: int = EYE_STACKS) -> tuple[list[list[float]], list[int]]:
    """A sphere, cylinder or cone as a closed triangle mesh about its centre (:mod:`neuronav.engine.tessellation`):
    vertices on the true surface (``sides`` around; a sphere's ``stacks`` from pole to pole), every triangle wound
    to face outwards. Returns the vertices and the flat triangle indices."""
    if obj.shape == "sphere":
        vertices, triangles = sphere_mesh(float(obj.size_m[0]), sides, stacks)
    else:
        radius, half = map(float, obj.size_m)
        vertices, triangles = (cylinder_mesh if obj.shape == "cylinder" else cone_mesh)(radius, half, sides)
    return vertices.tolist(), triangles.ravel().tolist()


def build_object(cid: int, world: World, obj: WorldObject, with_collision: bool = True,
                 sides: int | None = None) -> int:
    """A static primitive (a cone: the convex hull of a many-sided pyramid) at its declared pose; its body.
    ``sides``: a look-only object (``with_collision`` False) drawn as a mesh of that many sides if it is round
    (:func:`round_mesh`)."""
    rgba = exact_rgba(obj.rgba)
    if sides is not None and obj.shape != "box":
        if with_collision:
            raise ValueError("build_object: only a look-only object (with_collision=False) takes sides")
        vertices, indices = round_mesh(obj, sides)
        look = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, rgbaColor=rgba,
                                    physicsClientId=cid)
        return pb.createMultiBody(0.0, -1, look, list(obj.position_m), physicsClientId=cid)
    if obj.shape == "box":
        kwargs = {"shapeType": pb.GEOM_BOX, "halfExtents": list(obj.size_m)}
        shape = pb.createCollisionShape(**kwargs, physicsClientId=cid) if with_collision else -1
        look = pb.createVisualShape(**kwargs, rgbaColor=rgba, physicsClientId=cid)
    elif obj.shape == "sphere":
        shape = (pb.createCollisionShape(pb.GEOM_SPHERE, radius=obj.size_m[0], physicsClientId=cid)
                 if with_collision else -1)
        look = pb.createVisualShape(pb.GEOM_SPHERE, radius=obj.size_m[0], rgbaColor=rgba, physicsClientId=cid)
    elif obj.shape == "cylinder":
        radius, half = obj.size_m
        shape = (pb.createCollisionShape(pb.GEOM_CYLINDER, radius=radius, height=2 * half, physicsClientId=cid)
                 if with_collision else -1)
        look = pb.createVisualShape(pb.GEOM_CYLINDER, radius=radius, length=2 * half, rgbaColor=rgba,
                                    physicsClientId=cid)
    else:  # cone: a many-sided pyramid, base at -half, apex at +half
        vertices, indices = round_mesh(obj, CONE_SIDES)
        shape = (pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, physicsClientId=cid)
                 if with_collision else -1)
        look = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, rgbaColor=rgba,
                                    physicsClientId=cid)
    handle = pb.createMultiBody(0.0, shape, look, list(obj.position_m), physicsClientId=cid)
    if with_collision:
        set_friction(cid, world, handle)
    return handle


def place_objects(cid: int, handles: list[int], objects, yaw_rad: float) -> None:
    """Put each object at its declared pose turned by ``yaw_rad`` about the world z axis through the origin."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    quat = [0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0)]
    for handle, obj in zip(handles, objects):
        x, y, z = map(float, obj.position_m)
        pb.resetBasePositionAndOrientation(handle, [c * x - s * y, s * x + c * y, z], quat, physicsClientId=cid)


def set_friction(cid: int, world: World, handle: int) -> None:
    pb.changeDynamics(handle, -1, lateralFriction=world.ground.friction, restitution=0.0,
                      physicsClientId=cid)
