"""Engine-free cameras: ray casting a World's primitive objects, the ground and the sky, batched over agents.

The kinematic backend's eyes. Every pixel of every agent's camera casts one ray (its direction from
:func:`neuronav.senses.vision.pixel_directions`, turned into the world by the agent's camera rotation) and
shows, by the rules of :mod:`neuronav.senses.vision`:

- the nearest surface hit between ``vision.NEAR_M`` and ``vision.FAR_M``: a :class:`WorldObject`
  (box: axis-aligned half extents about its position; cylinder: upright, (radius, half height)
  about its position; cone: upright, base of that radius at position z - half height, apex at
  z + half height, as the MuJoCo and PyBullet backends build it, here a true cone rather than their
  32-sided pyramid; sphere) in its flat colour ``rgba[:3]``, or the ground plane z = 0 (infinite,
  plain or checker as the World's :class:`~neuronav.spec.world.Appearance` says, and where the World has
  odour trails, inside their floor image's rectangle, that image's texel under the hit
  (:meth:`neuronav.senses.trail_floor.TrailFloor.rgb_at`: what MuJoCo and PyBullet draw there);
- where nothing is hit, the sky (:func:`neuronav.senses.vision.sky_rgb`).

The objects can be turned about the world's z axis through the origin (the scene yaw; the ground
stays): a ray is tested against the declared objects after turning it by the opposite angle.

Speed: rays are grouped in square tiles of pixels, each with a bounding cone of directions; an
object is tested only on the (agent, tile) pairs whose cone meets the object's bounding sphere, so
a small object far away costs a few tiles, not the whole image. Everything is array operations
over agents and objects (a loop over the shapes only), in chunks of agents, and of tested rays,
of at most ``MAX_RAYS_PER_CHUNK`` rays (memory stays near 300 MB at most). Results do not depend on the batch: an agent
renders the same image alone or among a thousand.
"""

from __future__ import annotations

import numpy as np

from neuronav.errors import ConfigError
from neuronav.senses.trail_floor import trail_floor
from neuronav.senses.vision import FAR_M, NEAR_M, sky_rgb, to_uint8
from neuronav.spec.world import OBJECT_SIZES, World, WorldObject

# Rays per chunk of agents: each float64 array over a chunk is 8 MB; the ground, the sky and the
# hit bookkeeping hold a few dozen of them.
MAX_RAYS_PER_CHUNK = 1 << 20
TILE_PX = 6
# Palette slots before the objects' colours: the sky (painted from its direction), the ground, its checker.
_SKY, _GROUND, _CHECKER, _FIRST_OBJECT = 0, 1, 2, 3


def _floats(label: str, values) -> np.ndarray:
    """``values`` as a float array, or a ConfigError naming ``label`` when they are not numbers."""
    try:
        return np.asarray(values, float)
    except (TypeError, ValueError):
        raise ConfigError(f"ray caster: {label} must be numbers, got {type(values).__name__}") from None


def bounding_radius_m(obj: WorldObject) -> float:
    """Radius of a sphere about ``obj.position_m`` that holds the whole object."""
    size = np.asarray(obj.size_m, float)
    return float(size[0]) if obj.shape == "sphere" else float(np.linalg.norm(size))


class RayCaster:
    """One camera's rays against one World, for any batch of camera poses.

    Parameters
    ----------
    world : World
        Its objects and appearance (the ground is the plane z = 0 whatever ``world.ground`` says:
        callers refuse terrain that is not flat).
    directions : ndarray, shape (H, W, 3)
        Unit pixel rays in the camera's frame (:func:`neuronav.senses.vision.pixel_directions`).
    tile_px : int
        Side of the square pixel tiles used to skip objects a tile cannot see.
    """

    def __init__(self, world: World, directions: np.ndarray, tile_px: int = TILE_PX) -> None:
        if not isinstance(world, World):
            raise ConfigError(f"ray caster: expected a World (which checks its objects), got {type(world).__name__}")
        directions = _floats("directions", directions)
        if directions.ndim != 3 or directions.shape[-1] != 3 or not np.isfinite(directions).all():
            raise ConfigError(f"ray caster: directions must be finite numbers of shape (H, W, 3), got shape "
                              f"{directions.shape}")
        self.appearance = world.appearance
        self.objects = tuple(world.objects)
        self.height_px, self.width_px = directions.shape[:2]
        self._rays = directions.reshape(-1, 3)
        self._tiles(tile_px)
        self._centres = np.array([o.position_m for o in self.objects], float).reshape(-1, 3)
        self._radii = np.array([bounding_radius_m(o) for o in self.objects], float)
        self._sizes = np.zeros((len(self.objects), 3))
        for k, obj in enumerate(self.objects):
            self._sizes[k, :len(obj.size_m)] = obj.size_m
        shapes = np.array([o.shape for o in self.objects])
        self._by_shape = {shape: np.flatnonzero(shapes == shape) for shape in OBJECT_SIZES if (shapes == shape).any()}
        look = self.appearance
        fixed = [look.sky_rgb, look.ground_rgb, look.checker_rgb]
        self._palette = to_uint8(np.array(fixed + [o.rgba[:3] for o in self.objects], float))
        self._sky_gradient = look.horizon_rgb is not None  # else the palette's sky slot is the sky
        self._trails = trail_floor(world)  # the odour trails' floor image, None without trails

    def _tiles(self, tile_px: int) -> None:
        """Group pixels into tiles (padded by repeating a member) with a bounding cone each."""
        h, w = self.height_px, self.width_px
        index = np.arange(h * w).reshape(h, w)
        members = []
        for r in range(0, h, tile_px):
            for c in range(0, w, tile_px):
                block = index[r:r + tile_px, c:c + tile_px].ravel()
                members.append(np.concatenate([block, np.full(tile_px * tile_px - block.size, block[0])]))
        self._tile_pixels = np.array(members)  # (T, K)
        rays = self._rays[self._tile_pixels]  # (T, K, 3)
        axis = rays.sum(axis=1)
        norm = np.linalg.norm(axis, axis=1, keepdims=True)
        # A tile whose rays cancel out (it spans a half turn) gets any axis and a cone of π.
        axis = np.where(norm > 1e-9, axis / np.maximum(norm, 1e-300), np.array([0.0, 0.0, -1.0]))
        cosines = np.clip(np.einsum("tkc,tc->tk", rays, axis), -1.0, 1.0)
        self._tile_axis = axis
        self._tile_half_rad = np.where(norm[:, 0] > 1e-9, np.arccos(cosines.min(axis=1)), np.pi) + 1e-6
        self._tile_cos, self._tile_sin = np.cos(self._tile_half_rad), np.sin(self._tile_half_rad)

    def render(self, eyes_m: np.ndarray, rotations: np.ndarray, scene_yaw_rad: float = 0.0) -> np.ndarray:
        """uint8 RGB images (N, H, W, 3) seen from ``eyes_m`` (N, 3) with camera frames ``rotations``
        (N, 3, 3) (columns: the camera's x, y, z axes in the world), objects turned by ``scene_yaw_rad``."""
        eyes_m, rotations = _floats("eyes_m", eyes_m), _floats("rotations", rotations)
        if eyes_m.size % 3 or rotations.size % 9:
            raise ConfigError(f"ray caster: eyes_m must be (N, 3) and rotations (N, 3, 3), got shapes {eyes_m.shape} "
                              f"and {rotations.shape}")
        eyes_m, rotations = eyes_m.reshape(-1, 3), rotations.reshape(-1, 3, 3)
        if eyes_m.shape[0] != rotations.shape[0]:
            raise ConfigError(f"ray caster: {eyes_m.shape[0]} eyes but {rotations.shape[0]} rotations")
        yaw = _floats("scene_yaw_rad", scene_yaw_rad)
        if not (np.isfinite(eyes_m).all() and np.isfinite(rotations).all() and yaw.size == 1
                and np.isfinite(yaw).all()):
            raise ConfigError("ray caster: eye positions, rotations and the scene yaw must be finite")
        scene_yaw_rad = float(yaw.reshape(()))
        n, pixels = eyes_m.shape[0], self._rays.shape[0]
        image = np.empty((n, pixels, 3), np.uint8)
        chunk = max(1, MAX_RAYS_PER_CHUNK // pixels)
        for start in range(0, n, chunk):
            stop = min(n, start + chunk)
            image[start:stop] = self._render_chunk(eyes_m[start:stop], rotations[start:stop], float(scene_yaw_rad))
        return image.reshape(n, self.height_px, self.width_px, 3)

    # -- one chunk of agents -------------------------------------------------------------------------
    def _render_chunk(self, eyes: np.ndarray, rotations: np.ndarray, yaw: float) -> np.ndarray:
        n, pixels = eyes.shape[0], self._rays.shape[0]
        # World directions, written out as sums of products (elementwise: the same bits at any batch size).
        d = self._rays
        world = [d[None, :, 0] * rotations[:, i, None, 0] + d[None, :, 1] * rotations[:, i, None, 1]
                 + d[None, :, 2] * rotations[:, i, None, 2] for i in range(3)]
        best_t = np.full((n, pixels), np.inf)
        slot = np.full((n, pixels), _SKY, np.int32)
        self._ground(eyes, world, best_t, slot)
        if self.objects:
            self._objects(eyes, rotations, world, yaw, best_t, slot)
        image = self._palette[slot]
        if self._trails is not None:
            self._paint_trails(eyes, world, best_t, slot, image)
        sky = slot == _SKY
        # The gradient sky by each pixel's elevation, by the one formula of vision.sky_rgb.
        if self._sky_gradient and sky.any():
            image[sky] = to_uint8(sky_rgb(self.appearance, np.stack([w[sky] for w in world], axis=-1)))
        return image

    def _ground(self, eyes: np.ndarray, world: list, best_t: np.ndarray, slot: np.ndarray) -> None:
        """The plane z = 0 seen from above: plain, or checker squares aligned with the world axes."""
        dz = world[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -eyes[:, 2, None] / dz
        hit = (dz < 0) & (t >= NEAR_M) & (t <= FAR_M)
        best_t[hit] = t[hit]
        slot[hit] = _GROUND
        if self.appearance.ground_texture == "checker" and hit.any():
            rows = np.nonzero(hit)[0]
            th = t[hit]
            x = eyes[rows, 0] + th * world[0][hit]
            y = eyes[rows, 1] + th * world[1][hit]
            size = self.appearance.checker_m
            odd = (np.floor(x / size) + np.floor(y / size)) % 2 == 1
            slot[hit] = np.where(odd, _CHECKER, _GROUND)

    def _paint_trails(self, eyes: np.ndarray, world: list, best_t: np.ndarray, slot: np.ndarray,
                      image: np.ndarray) -> None:
        """Ground pixels whose hit lies on the trails' floor image take its texel's colour."""
        agent, pixel = np.nonzero((slot == _GROUND) | (slot == _CHECKER))
        if agent.size == 0:
            return
        t = best_t[agent, pixel]
        points = np.stack([eyes[agent, 0] + t * world[0][agent, pixel], eyes[agent, 1] + t * world[1][agent, pixel]],
                          axis=-1)
        rgb, inside = self._trails.rgb_at(points)
        image[agent[inside], pixel[inside]] = rgb[inside]

    def _objects(self, eyes: np.ndarray, rotations: np.ndarray, world: list, yaw: float, best_t: np.ndarray,
                 slot: np.ndarray) -> None:
        """All objects of a shape at once, on the (object, agent, tile) triples whose cone of rays
        meets the object's bounding sphere; the nearest hit wins each pixel."""
        c, s = np.cos(yaw), np.sin(yaw)
        # The rays in the objects' declared frame: turned by -yaw about z (origins and directions).
        eyes_local = np.stack([c * eyes[:, 0] + s * eyes[:, 1], -s * eyes[:, 0] + c * eyes[:, 1], eyes[:, 2]], axis=1)
        local = world if yaw == 0.0 else [c * world[0] + s * world[1], -s * world[0] + c * world[1], world[2]]
        local = [component.reshape(-1) for component in local]
        seen = self._seen(eyes_local, rotations, c, s)  # (O, n, T)
        best_flat, slot_flat = best_t.reshape(-1), slot.reshape(-1)
        step = max(1, MAX_RAYS_PER_CHUNK // self._tile_pixels.shape[1])  # triples per batch of tested rays
        for shape, index in self._by_shape.items():
            triples = np.nonzero(seen[index])
            for start in range(0, triples[0].size, step):
                k, agent, tile = (part[start:start + step] for part in triples)
                self._hits(shape, index[k], agent, tile, local, eyes_local, best_flat, slot_flat)

    def _hits(self, shape: str, k: np.ndarray, agent: np.ndarray, tile: np.ndarray, local: list,
              eyes_local: np.ndarray, best_flat: np.ndarray, slot_flat: np.ndarray) -> None:
        """Objects ``k`` (all of one shape) on the rays of (``agent``, ``tile``): nearer hits win their pixels."""
        flat = agent[:, None] * self._rays.shape[0] + self._tile_pixels[tile]  # (m, K)
        direction = tuple(component[flat] for component in local)
        origin = tuple((eyes_local[agent, i] - self._centres[k, i])[:, None] for i in range(3))
        size = [self._sizes[k, i, None] for i in range(OBJECT_SIZES[shape])]
        t = _INTERSECT[shape](origin, direction, size)
        hit = np.isfinite(t)
        flat, t, owner = flat[hit], t[hit], np.broadcast_to((_FIRST_OBJECT + k)[:, None], hit.shape)[hit]
        # Nearest wins: write the nearer candidates; where two objects of this batch share a pixel the
        # later write may be the farther one, so write again those still nearer, until none is.
        nearer = t < best_flat[flat]
        while nearer.any():
            flat, t, owner = flat[nearer], t[nearer], owner[nearer]
            best_flat[flat] = t
            slot_flat[flat] = owner
            nearer = t < best_flat[flat]

    def _seen(self, eyes_local: np.ndarray, rotations: np.ndarray, c: float, s: float) -> np.ndarray:
        """Whether a tile's cone of rays can meet an object's bounding sphere, bool (O, n, T).

        The angle between the tile's axis and the direction to the sphere's centre must be at most
        the tile's half angle plus the sphere's angular radius: compared as cosines,
        cos(axis, centre) >= cos(half + reach), with a margin so that no hit is ever culled.
        """
        # Tile axes in the objects' frame: the camera rotation, then the turn by -yaw, (n, T, 3).
        axes_world = np.einsum("nij,tj->nti", rotations, self._tile_axis)
        axes = np.stack([c * axes_world[..., 0] + s * axes_world[..., 1],
                         -s * axes_world[..., 0] + c * axes_world[..., 1], axes_world[..., 2]], axis=-1)
        return tiles_meet_spheres(axes, eyes_local, self._centres, self._radii, self._tile_cos, self._tile_sin,
                                  self._tile_half_rad >= np.pi / 2)


def tiles_meet_spheres(axes: np.ndarray, eyes_local: np.ndarray, centres: np.ndarray, radii: np.ndarray,
                       tile_cos: np.ndarray, tile_sin: np.ndarray, wide: np.ndarray) -> np.ndarray:
    """Whether each tile's cone of rays can meet each bounding sphere, bool (O, n, T).

    ``axes`` (n, T, 3): the tiles' unit axes; ``eyes_local`` (n, 3): the eyes, both in the spheres' frame;
    ``centres`` (O, 3), ``radii`` (O,); ``tile_cos``, ``tile_sin`` (T,): cosine and sine of each tile's half
    angle; ``wide`` (T,): tiles wider than a right angle (every ray tested). The angle between a tile's axis
    and the direction to a sphere's centre must be at most the tile's half angle plus the sphere's angular
    radius, compared as cosines with a margin so that no hit is culled; an eye inside a sphere tests every
    ray; spheres beyond ``FAR_M`` are never seen.
    """
    to_centre = centres[None] - eyes_local[:, None]  # (n, O, 3)
    distance = np.linalg.norm(to_centre, axis=2)
    inside = distance <= radii
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = np.where(inside[..., None], 0.0, to_centre / distance[..., None])
        sin_reach = np.where(inside, 0.0, radii / distance)
    cos_reach = np.sqrt(1.0 - sin_reach ** 2)
    cosine = unit @ axes.transpose(0, 2, 1)  # (n, O, T)
    threshold = cos_reach[..., None] * tile_cos - sin_reach[..., None] * tile_sin
    threshold[inside] = -2.0
    threshold[:, :, wide] = -2.0
    seen = cosine >= threshold - 1e-6
    seen &= (distance - radii <= FAR_M)[..., None]
    return seen.transpose(1, 0, 2)


# -- intersections: rays (origin relative to the object's position, unit direction), each a tuple
# of 3 arrays broadcasting to (m, K); the nearest t in [near, far] (default [NEAR_M, FAR_M], the
# cameras' range) or inf ---------------------------------------------------------------------------------

def _first(*candidates: tuple[np.ndarray, np.ndarray], near: float = NEAR_M, far: float = FAR_M) -> np.ndarray:
    """The smallest valid t in [near, far] among (t, valid) candidates, inf where none is valid or in range."""
    best = None
    for t, valid in candidates:
        t = np.where(valid & (t >= near) & (t <= far), t, np.inf)
        best = t if best is None else np.minimum(best, t)
    return best


def _roots(a, b, c):
    """Both roots of a t² + 2 b t + c = 0 (nan where none), the smaller first when a > 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(b * b - a * c)
        return (-b - root) / a, (-b + root) / a


def _sphere(o, d, size, near=NEAR_M, far=FAR_M):
    t0, t1 = _roots(1.0, o[0] * d[0] + o[1] * d[1] + o[2] * d[2], o[0] ** 2 + o[1] ** 2 + o[2] ** 2 - size[0] ** 2)
    valid = np.isfinite(t0)
    return _first((t0, valid), (t1, valid), near=near, far=far)


def _box(o, d, size, near=NEAR_M, far=FAR_M):
    """Slabs: the ray is inside the box from the largest entry to the smallest exit."""
    enter, leave = -np.inf, np.inf
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(3):
            lo, hi = (-size[i] - o[i]) / d[i], (size[i] - o[i]) / d[i]
            # A ray parallel to a slab is inside it for every t or for none.
            parallel = d[i] == 0
            inside = np.abs(o[i]) <= size[i]
            lo = np.where(parallel, np.where(inside, -np.inf, np.inf), lo)
            hi = np.where(parallel, np.where(inside, np.inf, -np.inf), hi)
            enter = np.maximum(enter, np.minimum(lo, hi))
            leave = np.minimum(leave, np.maximum(lo, hi))
    valid = enter <= leave
    return _first((enter, valid), (leave, valid), near=near, far=far)


def _caps(o, d, radius, z_caps):
    """Hits on horizontal discs of ``radius`` at heights ``z_caps`` (relative to the centre)."""
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for z in z_caps:
            t = (z - o[2]) / d[2]
            out.append((t, (o[0] + t * d[0]) ** 2 + (o[1] + t * d[1]) ** 2 <= radius * radius))
    return out


def _cylinder(o, d, size, near=NEAR_M, far=FAR_M):
    radius, half = size
    a = d[0] ** 2 + d[1] ** 2
    t0, t1 = _roots(a, o[0] * d[0] + o[1] * d[1], o[0] ** 2 + o[1] ** 2 - radius * radius)
    side = [(t, np.abs(o[2] + t * d[2]) <= half) for t in (t0, t1)]
    return _first(*side, *_caps(o, d, radius, (-half, half)), near=near, far=far)


def _cone(o, d, size, near=NEAR_M, far=FAR_M):
    """Side: x² + y² = k² (h - z)² with k = radius / (2 h), on the nappe below the apex (h - z in
    [0, 2h]); the base: a disc at z = -h."""
    radius, half = size
    k2 = (radius / (2.0 * half)) ** 2
    w0 = half - o[2]
    a = d[0] ** 2 + d[1] ** 2 - k2 * d[2] ** 2
    t0, t1 = _roots(a, o[0] * d[0] + o[1] * d[1] + k2 * w0 * d[2], o[0] ** 2 + o[1] ** 2 - k2 * w0 * w0)
    side = []
    for t in (t0, t1):
        w = w0 - t * d[2]
        side.append((t, (w >= 0) & (w <= 2.0 * half)))
    return _first(*side, *_caps(o, d, radius, (-half,)), near=near, far=far)


_INTERSECT = {"sphere": _sphere, "box": _box, "cylinder": _cylinder, "cone": _cone}


def render(world: World, directions: np.ndarray, eyes_m: np.ndarray, rotations: np.ndarray,
           scene_yaw_rad: float = 0.0) -> np.ndarray:
    """uint8 RGB images (N, H, W, 3) of ``world`` (see :class:`RayCaster`; builds one for this call)."""
    return RayCaster(world, directions).render(eyes_m, rotations, scene_yaw_rad)


def _turned(origins_m: np.ndarray, directions: np.ndarray, scene_yaw_rad: float) -> tuple[tuple, tuple]:
    """Rays (N, 3) in the objects' declared frame (turned by -scene_yaw_rad about z), as 3-tuples of (N,)."""
    c, s = np.cos(scene_yaw_rad), np.sin(scene_yaw_rad)
    o = (c * origins_m[:, 0] + s * origins_m[:, 1], -s * origins_m[:, 0] + c * origins_m[:, 1], origins_m[:, 2])
    d = (c * directions[:, 0] + s * directions[:, 1], -s * directions[:, 0] + c * directions[:, 1], directions[:, 2])
    return o, d


def _sphere_entry(o: tuple, d: tuple, centre, radius: float) -> np.ndarray:
    """Where each ray (unit direction) first is within ``radius`` of ``centre``: 0 for an origin inside,
    ``np.inf`` for a ray that never comes that close."""
    rel = [o[i] - centre[i] for i in range(3)]
    along = -(rel[0] * d[0] + rel[1] * d[1] + rel[2] * d[2])  # distance to the point nearest the centre
    gap2 = rel[0] ** 2 + rel[1] ** 2 + rel[2] ** 2 - radius * radius  # < 0: the origin is inside
    with np.errstate(invalid="ignore"):
        enter = along - np.sqrt(along * along - gap2)  # nan where the line misses the sphere
    return np.where(gap2 <= 0, 0.0, np.where((along > 0) & (enter >= 0), enter, np.inf))


def object_bounds(objects, margin: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounds of ``objects`` at their declared poses, each widened by ``margin`` of its size and ``margin``
    m (for the engines' polygonal cones and collision margins): bounding-sphere centres (O, 3) and radii
    (O,), and the half extents (O, 3) of their boxes along the world axes about the same centres."""
    centres = np.array([obj.position_m for obj in objects], float).reshape(-1, 3)
    radii = np.array([bounding_radius_m(obj) for obj in objects], float) * (1.0 + margin) + margin
    half = np.zeros((len(objects), 3))
    for k, obj in enumerate(objects):
        size = [float(v) for v in obj.size_m]
        half[k] = size if obj.shape == "box" else (size[0],) * 3 if obj.shape == "sphere" else (size[0], *size)
    return centres, radii, half * (1.0 + margin) + margin


def bounds_span_m(bounds: tuple[np.ndarray, np.ndarray, np.ndarray], origins_m: np.ndarray, directions: np.ndarray,
                  max_distance_m: float, scene_yaw_rad: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The stretch of each ray on which something within ``bounds`` (:func:`object_bounds`, the objects
    turned by ``scene_yaw_rad`` about the world z axis) may be hit: from where the ray first enters one of
    the objects' boxes (0 from inside one) to where it leaves the last it enters; (``np.inf``,
    ``-np.inf``) where it enters none within ``max_distance_m``.

    The bounding spheres pick the (ray, object) pairs to test (one matrix product over all of them);
    the boxes, tighter (a flat roof's sphere would hold the agent under it), give the distances.

    Parameters
    ----------
    bounds : (centres (O, 3), radii (O,), half extents (O, 3))
    origins_m, directions : ndarray, shape (N, 3)
        World frame; unit directions.
    max_distance_m, scene_yaw_rad : float

    Returns
    -------
    entry, leave : ndarray, shape (N,)
    """
    centres, radii, half = bounds
    origins_m, directions = np.asarray(origins_m, float), np.asarray(directions, float)
    entry, last = np.full(origins_m.shape[0], np.inf), np.full(origins_m.shape[0], -np.inf)
    if centres.shape[0] == 0 or origins_m.shape[0] == 0:
        return entry, last
    o, d = (np.column_stack(part) for part in _turned(origins_m, directions, scene_yaw_rad))
    # Spheres, (N, O): along = d·(c - o), the distance to the point nearest the centre, and
    # gap2 = |o - c|² - r² (<= 0: the origin is inside).
    if (origins_m == origins_m[0]).all():  # one origin (an agent's rays): fewer (N, O) operations
        to_centre = centres - o[0]
        gap2 = ((to_centre * to_centre).sum(axis=1) - radii * radii)[None, :]
        along = d @ to_centre.T
    else:
        along = d @ centres.T - (o * d).sum(axis=1)[:, None]
        gap2 = ((o * o).sum(axis=1)[:, None] - 2.0 * (o @ centres.T)
                + ((centres * centres).sum(axis=1) - radii * radii)[None, :])
    ray, obj = np.nonzero((gap2 <= 0) | ((along >= 0) & (along * along >= gap2)))
    if ray.size == 0:
        return entry, last
    # Boxes (slabs) on those pairs.
    rel, step, size = o[ray] - centres[obj], d[ray], half[obj]
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = (-size - rel) / step, (size - rel) / step
    parallel = step == 0
    inside = np.abs(rel) <= size
    lo = np.where(parallel, np.where(inside, -np.inf, np.inf), lo)
    hi = np.where(parallel, np.where(inside, np.inf, -np.inf), hi)
    enter, leave = np.minimum(lo, hi).max(axis=1), np.maximum(lo, hi).min(axis=1)
    meets = (enter <= leave) & (leave >= 0) & (enter <= max_distance_m)
    np.minimum.at(entry, ray, np.where(meets, np.maximum(enter, 0.0), np.inf))
    np.maximum.at(last, ray, np.where(meets, leave, -np.inf))
    return entry, last


def object_entry_m(objects, origins_m: np.ndarray, directions: np.ndarray, max_distance_m: float,
                   scene_yaw_rad: float = 0.0, margin: float = 0.05) -> np.ndarray:
    """How far along each ray none of ``objects`` can be hit (:func:`bounds_span_m` of their
    :func:`object_bounds`), ``np.inf`` where none can be within ``max_distance_m``."""
    return bounds_span_m(object_bounds(objects, margin), origins_m, directions, max_distance_m, scene_yaw_rad)[0]


def first_hit_distance(world: World, origins_m: np.ndarray, directions: np.ndarray, max_distance_m: float = 50.0,
                       scene_yaw_rad: float = 0.0) -> np.ndarray:
    """Distance along each ray to the first surface of ``world``: its objects (turned by
    ``scene_yaw_rad`` about the world z axis, as :class:`RayCaster` turns them) and the ground plane z = 0
    seen from above; ``np.inf`` where nothing lies within ``max_distance_m``.

    The kinematic backend's ``cast_rays`` (occlusion of the sky); the shapes are the renderer's
    (:data:`_INTERSECT`), tested from t = 0 (a ray that starts inside an object hits it where it
    leaves), each only on the rays that enter its bounding sphere. ``world.ground`` is not read: the
    ground is the plane z = 0 (the kinematic agents walk on it whatever the world says).

    Parameters
    ----------
    world : World
    origins_m : ndarray, shape (N, 3)
        Ray origins, world frame (m).
    directions : ndarray, shape (N, 3)
        Unit ray directions, world frame (the caller normalises them).
    max_distance_m : float
        Hits farther than this are no hits.
    scene_yaw_rad : float

    Returns
    -------
    ndarray, shape (N,)
        Hit distances (m), ``np.inf`` for none.
    """
    origins_m, directions = np.asarray(origins_m, float), np.asarray(directions, float)
    far = float(max_distance_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -origins_m[:, 2] / directions[:, 2]
    best = np.where((directions[:, 2] < 0) & (origins_m[:, 2] >= 0) & (t <= far), np.maximum(t, 0.0), np.inf)
    if not world.objects:
        return best
    o, d = _turned(origins_m, directions, scene_yaw_rad)
    for obj in world.objects:
        reach = bounding_radius_m(obj) * (1.0 + 1e-9) + 1e-9
        rows = np.flatnonzero(_sphere_entry(o, d, np.asarray(obj.position_m, float), reach) <= far)
        if rows.size == 0:
            continue
        rel = tuple(o[i][rows] - obj.position_m[i] for i in range(3))
        size = [float(v) for v in obj.size_m]
        best[rows] = np.minimum(best[rows], _INTERSECT[obj.shape](rel, tuple(v[rows] for v in d), size, near=0.0,
                                                                  far=far))
    return best
