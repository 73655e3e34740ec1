"""The world in PyBullet: ground (plane, heightfield, wall) and static objects, for physics and for vision.

Two builds of one :class:`World`:

- :func:`build_ground` and :func:`build_object` in the physics client: collision shapes, with a look
  for the follow camera's videos (the floor over ``Ground.size_m`` in the World's appearance: plain,
  or a checker texture aligned with the world axes);
- :func:`build_vision_world` in a render-only client that holds no body: looks only, the ground
  reaching :data:`neuronav.vision.GROUND_REACH_M` from the origin. Body cameras colour the ground
  themselves (:mod:`backends.pybullet.camera`), so its look there does not matter.

TinyRenderer truncates ``255 * rgba`` to an integer; :func:`exact_rgba` asks for the middle of the
colour's 8-bit step, so that a surface shows ``round(255 * rgba)``, as on the other engines.
"""

from __future__ import annotations

import math
import os
import struct
import zlib

import numpy as np

from backends.pybullet.engine import pb
from neuronav.errors import ConfigError
from neuronav.vision import GROUND_REACH_M, to_uint8
from neuronav.world import World, WorldObject

WALL_THICKNESS_M = 0.2
WALL_RGB = (0.6, 0.6, 0.65)
CONE_SIDES = 32
# The videos' floor texture has one texel per checker square, at most this many squares a side.
MAX_FLOOR_SQUARES = 1024
# Below the heightfield (uneven ground), the flat floor's look hides this far under z = 0.
UNDER_FIELD_M = 2e-3


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
    half = ground.size_m / 2.0
    if checker and squares <= MAX_FLOOR_SQUARES:
        half = squares * appearance.checker_m / 2.0  # whole squares, a corner at the origin
    visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half, half, 0.005],
                                  visualFramePosition=[0.0, 0.0, top - 0.005],
                                  rgbaColor=[1.0, 1.0, 1.0, 1.0] if checker else exact_rgba(appearance.ground_rgb),
                                  physicsClientId=cid)
    floor = pb.createMultiBody(0.0, plane, visual, [0.0, 0.0, 0.0], physicsClientId=cid)
    if checker and squares <= MAX_FLOOR_SQUARES:
        pb.changeVisualShape(floor, -1, textureUniqueId=checker_texture(cid, world, squares, folder),
                             physicsClientId=cid)
    set_friction(cid, world, floor)
    bodies.append(floor)
    wall = _wall(cid, world, with_collision=True)
    if wall is not None:
        set_friction(cid, world, wall)
    return bodies


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


def checker_texture(cid: int, world: World, squares: int, folder: str) -> int:
    """The appearance's checker, one texel per square, ``squares`` (even) a side; texel (i, j) has
    ``ground_rgb`` where i + j is even (the square with a corner at the origin, on the floor's centre)."""
    appearance = world.appearance
    colours = to_uint8(np.array([appearance.ground_rgb, appearance.checker_rgb]))
    path = os.path.join(folder, f"checker_{squares}_{colours.tobytes().hex()}.png")
    if not os.path.exists(path):
        parity = np.add.outer(np.arange(squares), np.arange(squares)) % 2
        with open(path, "wb") as handle:
            handle.write(_png(colours[parity]))
    return pb.loadTexture(path, physicsClientId=cid)


def _png(image: np.ndarray) -> bytes:
    """An RGB uint8 image (H, W, 3) as PNG bytes (no imaging library needed)."""
    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    height, width = image.shape[:2]
    rows = b"".join(b"\x00" + row.tobytes() for row in np.ascontiguousarray(image, np.uint8))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def build_object(cid: int, world: World, obj: WorldObject, with_collision: bool = True) -> int:
    """A static primitive (a cone: the convex hull of a many-sided pyramid) at its declared pose; its body."""
    rgba = exact_rgba(obj.rgba)
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
        radius, half = obj.size_m
        angles = np.linspace(0.0, 2 * np.pi, CONE_SIDES, endpoint=False)
        ring = [[radius * math.cos(a), radius * math.sin(a), -half] for a in angles]
        vertices = [*ring, [0.0, 0.0, half], [0.0, 0.0, -half]]
        apex, centre = CONE_SIDES, CONE_SIDES + 1
        indices = []
        for k in range(CONE_SIDES):
            nxt = (k + 1) % CONE_SIDES
            indices += [k, nxt, apex, nxt, k, centre]
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


def check_object(obj: WorldObject) -> None:
    expected = {"box": 3, "sphere": 1, "cylinder": 2, "cone": 2}[obj.shape]
    size = tuple(obj.size_m)
    if len(size) != expected or not all(np.isfinite(s) and s > 0 for s in size):
        raise ConfigError(f"world object {obj.shape}: size_m needs {expected} positive numbers, got {size}")
    if len(obj.position_m) != 3 or not np.isfinite(obj.position_m).all():
        raise ConfigError(f"world object {obj.shape}: position_m must be 3 finite numbers, got {obj.position_m}")
