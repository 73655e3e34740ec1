"""The world in PyBullet: ground (plane, heightfield, wall) with a checker look, and static objects."""

from __future__ import annotations

import math
import os
import struct
import zlib

import numpy as np

from backends.pybullet.engine import pb
from neuronav.errors import ConfigError
from neuronav.world import World, WorldObject

GROUND_RGBA = (0.76, 0.68, 0.52, 1.0)
# The floor's checker: two sand colours like MuJoCo's, CHECKER_M squares in the texture over the ground's size.
CHECKER_RGB = ((219, 194, 143), (168, 145, 102))
CHECKER_M = 0.5
WALL_THICKNESS_M = 0.2
CONE_SIDES = 32


def build_ground(cid: int, world: World, folder: str) -> None:
    """The ground of ``world``: a plane (a heightfield, a wall), with a checker look (texture in ``folder``)."""
    ground = world.ground
    half = ground.size_m / 2.0
    plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=cid)
    heights = ground.heights_m()
    if heights.max() > heights.min():
        spacing = ground.size_m / (ground.cells - 1)
        field = pb.createCollisionShape(
            pb.GEOM_HEIGHTFIELD, meshScale=[spacing, spacing, 1.0], heightfieldData=heights.ravel().tolist(),
            numHeightfieldRows=ground.cells, numHeightfieldColumns=ground.cells, physicsClientId=cid)
        # PyBullet centres the field at the midpoint of its extreme heights: lift it back.
        lift = (heights.max() + heights.min()) / 2.0
        terrain = pb.createMultiBody(0.0, field, -1, [0.0, 0.0, lift], physicsClientId=cid)
        pb.changeVisualShape(terrain, -1, rgbaColor=list(GROUND_RGBA), textureUniqueId=-1, physicsClientId=cid)
        set_friction(cid, world, terrain)
        top = -2e-3  # the plane's look hides under the field (without a look TinyRenderer draws a checker)
    else:
        top = 0.0
    visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half, half, 0.005],
                                  visualFramePosition=[0.0, 0.0, top - 0.005], rgbaColor=[1.0, 1.0, 1.0, 1.0],
                                  physicsClientId=cid)
    floor = pb.createMultiBody(0.0, plane, visual, [0.0, 0.0, 0.0], physicsClientId=cid)
    pb.changeVisualShape(floor, -1, textureUniqueId=checker_texture(cid, ground.size_m, folder), physicsClientId=cid)
    set_friction(cid, world, floor)
    if ground.kind == "wall":
        extents = [WALL_THICKNESS_M / 2.0, half, ground.wall_height_m / 2.0]
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=extents, physicsClientId=cid)
        look = pb.createVisualShape(pb.GEOM_BOX, halfExtents=extents, rgbaColor=[0.6, 0.6, 0.65, 1.0],
                                    physicsClientId=cid)
        wall = pb.createMultiBody(0.0, shape, look, [ground.wall_distance_m + WALL_THICKNESS_M / 2.0, 0.0,
                                                     ground.wall_height_m / 2.0], physicsClientId=cid)
        set_friction(cid, world, wall)


def checker_texture(cid: int, size_m: float, folder: str) -> int:
    """A checker of ``CHECKER_M`` squares over ``size_m`` (a PNG in the temporary folder)."""
    squares = max(1, int(round(size_m / CHECKER_M)))
    path = os.path.join(folder, f"checker_{squares}.png")
    if not os.path.exists(path):
        pixels = 8  # per square: TinyRenderer samples the nearest texel
        parity = (np.add.outer(np.arange(squares * pixels) // pixels, np.arange(squares * pixels) // pixels)) % 2
        image = np.where(parity[..., None] == 0, CHECKER_RGB[0], CHECKER_RGB[1]).astype(np.uint8)
        with open(path, "wb") as handle:
            handle.write(_png(image))
    return pb.loadTexture(path, physicsClientId=cid)


def _png(image: np.ndarray) -> bytes:
    """An RGB uint8 image (H, W, 3) as PNG bytes (no imaging library needed)."""
    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    height, width = image.shape[:2]
    rows = b"".join(b"\x00" + row.tobytes() for row in np.ascontiguousarray(image, np.uint8))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def build_object(cid: int, world: World, obj: WorldObject) -> None:
    """A static primitive (a cone: the convex hull of a many-sided pyramid)."""
    rgba = list(obj.rgba)
    if obj.shape == "box":
        kwargs = {"shapeType": pb.GEOM_BOX, "halfExtents": list(obj.size_m)}
        shape = pb.createCollisionShape(**kwargs, physicsClientId=cid)
        look = pb.createVisualShape(**kwargs, rgbaColor=rgba, physicsClientId=cid)
    elif obj.shape == "sphere":
        shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=obj.size_m[0], physicsClientId=cid)
        look = pb.createVisualShape(pb.GEOM_SPHERE, radius=obj.size_m[0], rgbaColor=rgba, physicsClientId=cid)
    elif obj.shape == "cylinder":
        radius, half = obj.size_m
        shape = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=radius, height=2 * half, physicsClientId=cid)
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
        shape = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, physicsClientId=cid)
        look = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, rgbaColor=rgba,
                                    physicsClientId=cid)
    handle = pb.createMultiBody(0.0, shape, look, list(obj.position_m), physicsClientId=cid)
    set_friction(cid, world, handle)


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
