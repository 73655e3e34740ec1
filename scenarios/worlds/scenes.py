"""Visual worlds: the dark landmark, a seeded forest, the compass scene and the look of the sky and ground.

Sources (the I2Bot paper's case studies, §3.3.4; ``docs/parameters.md`` §7):

- Visual beacon: "landmark black cylinder r 1 m, h 6 m at 25 m; forests of trees around"; the eyes
  find it by thresholding dark pixels (dark <= 10–25 of 255). :func:`landmark` builds it and
  :func:`forest` the trees, every part of which is far lighter than that threshold (grey >=
  :data:`TREE_GREY_MIN`), so only the landmark reads as dark. The trees' sizes are this module's
  choice (the paper gives none): 4–9 m tall, trunks 0.15–0.35 m in radius.
- Visual compass: "12 m floor, five coloured objects (cylinder, sphere, two boxes, cone) 13–17 m
  away" (:func:`compass_scene`); the sphere is the red ball.
- The sky and the ground (:func:`vision_appearance`): a plain ground (no checker a compass could
  lock onto) under a sky lighter than it, brightest at the horizon.

Every builder returns backend-agnostic data (:class:`~neuronav.spec.world.WorldObject` tuples or a
:class:`~neuronav.spec.world.World`): all three backends draw the same scene.

A trial records its world beside its time series as arrays in metres (:func:`world_record`, stacked
over trials by :func:`pack_world`): objects as circles ``objects_m`` (x, y, radius_m), trails as
polylines, named points (nest, goal, beacon); a report's replay draws them under the path.
"""

from __future__ import annotations

import numpy as np

from neuronav.errors import ConfigError, real_or_nan
from neuronav.runs.trials import stack_padded
from neuronav.senses.vision import LUMA_WEIGHTS
from neuronav.spec.world import MAX_LENGTH_M, Appearance, Ground, World, WorldObject

LANDMARK_RGBA = (0.0, 0.0, 0.0, 1.0)
# Every part of a tree is at least this light in grey (BT.601): far above a dark-landmark threshold
# (25 of 255 ≈ 0.1), so a tree is never taken for the landmark.
TREE_GREY_MIN = 0.25
_TRUNK_RGB = ((0.50, 0.38, 0.26), (0.56, 0.45, 0.33), (0.46, 0.40, 0.34))
_CROWN_RGB = ((0.30, 0.55, 0.25), (0.42, 0.62, 0.30), (0.25, 0.48, 0.28), (0.50, 0.60, 0.32))
CROWNS = ("cone", "sphere")
# The most trees a forest holds (each placement is checked against every placed trunk: a forest of
# MAX_TREES takes seconds; the scenarios use dozens).
MAX_TREES = 2000
# Draws before a forest that does not fit is refused (about 3 s of drawing).
MAX_FOREST_ATTEMPTS = 100_000



def vision_appearance() -> Appearance:
    """The look of the visual scenarios: a plain ground (grey ≈ 0.55) under a sky gradient from a pale
    horizon (grey ≈ 0.91) to a blue zenith (grey ≈ 0.70), everywhere lighter than the ground."""
    return Appearance(sky_rgb=(0.55, 0.72, 0.95), horizon_rgb=(0.88, 0.92, 0.97), ground_rgb=(0.60, 0.55, 0.45),
                      ground_texture="plain")


def landmark(position_m=(0.0, 25.0), radius_m: float = 1.0, height_m: float = 6.0) -> WorldObject:
    """The visual beacon's landmark: a black cylinder of ``radius_m`` and ``height_m`` standing on the
    ground at ``position_m`` (x, y) (I2Bot §3.3.4, docs/parameters.md §7: r 1 m, h 6 m, 25 m away).
    Every value finite, within :data:`neuronav.spec.world.MAX_LENGTH_M`."""
    try:
        x, y = (float(v) for v in np.asarray(position_m, float).reshape(2))
    except (TypeError, ValueError):
        x = y = float("nan")
    radius, height = real_or_nan(radius_m), real_or_nan(height_m)
    if not (max(abs(x), abs(y)) <= MAX_LENGTH_M and 0 < radius <= MAX_LENGTH_M and 0 < height <= MAX_LENGTH_M):
        raise ConfigError(f"landmark: needs a finite position (x, y) and radius_m, height_m > 0, got {position_m!r}, "
                          f"{radius_m!r}, {height_m!r}")
    return WorldObject("cylinder", (x, y, height / 2.0), (radius, height / 2.0), LANDMARK_RGBA)


def forest(count: int, seed: int, inner_radius_m: float = 0.0, outer_radius_m: float = 50.0,
           height_m=(4.0, 9.0), trunk_radius_m=(0.15, 0.35), clear=(), centre_m=(0.0, 0.0),
           crowns=CROWNS) -> tuple[WorldObject, ...]:
    """``count`` trees scattered uniformly over a ring about ``centre_m``, none in a ``clear`` zone.

    Each tree is a trunk (a cylinder) and a crown (a cone or a sphere, chosen at random among
    ``crowns``), 2 objects per tree, the trunk first. A tree of height H has a trunk 0.45 H tall; a
    cone crown spans 0.3 H to H with a base radius max(3 r, 0.22 H) (r the trunk's radius); a
    sphere crown of radius 0.3 H has its top at H. Colours vary from tree to tree, every part at
    least :data:`TREE_GREY_MIN` in grey. Trunks do not overlap.

    Parameters
    ----------
    count : int
        Number of trees (0 to :data:`MAX_TREES`).
    seed : int
        The same seed gives the same forest (an int >= 0).
    inner_radius_m, outer_radius_m : float
        The ring the trunks stand in (0 <= inner < outer), about ``centre_m``.
    height_m, trunk_radius_m : (float, float)
        Ranges (low, high) drawn uniformly per tree.
    clear : sequence of (x, y, radius_m)
        Zones no part of a tree reaches (e.g. the corridor from the start to the landmark).
    centre_m : (float, float)
    crowns : sequence of str
        Crown shapes to choose from ("cone", "sphere").
    """
    _check_forest(count, seed, inner_radius_m, outer_radius_m, height_m, trunk_radius_m, clear, centre_m, crowns)
    rng = np.random.default_rng(seed)
    zones = np.asarray(clear, float).reshape(-1, 3)
    placed = np.empty((count, 3))  # (x, y, trunk radius) of the first `trees` rows
    trees = 0
    objects: list[WorldObject] = []
    attempts = 0
    while trees < count:
        attempts += 1
        if attempts > min(1000 * max(count, 1), MAX_FOREST_ATTEMPTS):
            raise ConfigError(f"forest: cannot place {count} trees in the ring {inner_radius_m}–{outer_radius_m} m "
                              f"outside the clear zones (placed {trees}); widen the ring or clear less")
        # Uniform over the ring's area: the radius as the square root of a uniform draw in r².
        radius = np.sqrt(rng.uniform(inner_radius_m ** 2, outer_radius_m ** 2))
        angle = rng.uniform(0.0, 2.0 * np.pi)
        x, y = centre_m[0] + radius * np.cos(angle), centre_m[1] + radius * np.sin(angle)
        height = rng.uniform(*height_m)
        trunk = rng.uniform(*trunk_radius_m)
        crown = crowns[rng.integers(len(crowns))]
        trunk_rgb = _lighter_than_floor(_TRUNK_RGB[rng.integers(len(_TRUNK_RGB))], rng.uniform(0.9, 1.1))
        crown_rgb = _lighter_than_floor(_CROWN_RGB[rng.integers(len(_CROWN_RGB))], rng.uniform(0.9, 1.1))
        reach = max(3.0 * trunk, 0.22 * height) if crown == "cone" else 0.3 * height
        if zones.size and np.any(np.hypot(zones[:, 0] - x, zones[:, 1] - y) < zones[:, 2] + max(reach, trunk)):
            continue
        others = placed[:trees]
        if np.any(np.hypot(others[:, 0] - x, others[:, 1] - y) < others[:, 2] + trunk):
            continue
        placed[trees] = (x, y, trunk)
        trees += 1
        objects.append(WorldObject("cylinder", (x, y, 0.225 * height), (trunk, 0.225 * height), (*trunk_rgb, 1.0)))
        if crown == "cone":
            objects.append(WorldObject("cone", (x, y, 0.65 * height), (reach, 0.35 * height), (*crown_rgb, 1.0)))
        else:
            objects.append(WorldObject("sphere", (x, y, 0.7 * height), (reach,), (*crown_rgb, 1.0)))
    return tuple(objects)


def _lighter_than_floor(rgb, scale: float) -> tuple[float, float, float]:
    """``rgb`` scaled by ``scale`` (clipped to [0, 1]), raised if needed to grey >= TREE_GREY_MIN."""
    rgb = np.clip(np.asarray(rgb, float) * scale, 0.0, 1.0)
    value = float(rgb @ LUMA_WEIGHTS)
    if value < TREE_GREY_MIN:
        rgb = np.clip(rgb * (TREE_GREY_MIN / value), 0.0, 1.0)
    return tuple(float(v) for v in rgb)


def _pair(value) -> tuple[float, float]:
    """Two numbers, or (NaN, NaN) when ``value`` is not two real numbers (refused by the caller)."""
    try:
        low, high = (float(v) for v in np.asarray(value, float).reshape(2))
    except (TypeError, ValueError):
        return float("nan"), float("nan")
    return low, high


def _check_forest(count, seed, inner_radius_m, outer_radius_m, height_m, trunk_radius_m, clear, centre_m,
                  crowns) -> None:
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or not 0 <= count <= MAX_TREES:
        raise ConfigError(f"forest: count must be a whole number in [0, {MAX_TREES}], got {count!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"forest: seed must be an int >= 0, got {seed!r}")
    inner, outer = real_or_nan(inner_radius_m), real_or_nan(outer_radius_m)
    if not 0 <= inner < outer <= MAX_LENGTH_M:
        raise ConfigError(f"forest: needs 0 <= inner_radius_m < outer_radius_m <= {MAX_LENGTH_M:g}, got "
                          f"{inner_radius_m!r}, {outer_radius_m!r}")
    for label, (low, high) in (("height_m", _pair(height_m)), ("trunk_radius_m", _pair(trunk_radius_m))):
        if not 0 < low <= high <= MAX_LENGTH_M:
            raise ConfigError(f"forest: {label} must be a range (low, high) with 0 < low <= high <= {MAX_LENGTH_M:g}, "
                              f"got {height_m if label == 'height_m' else trunk_radius_m!r}")
    if not max(map(abs, _pair(centre_m))) <= MAX_LENGTH_M:
        raise ConfigError(f"forest: centre_m must be 2 finite numbers (x, y) m, got {centre_m!r}")
    try:
        zones = np.asarray(clear, float)
    except (TypeError, ValueError):
        zones = np.full((1, 1), np.nan)
    if zones.size and (zones.ndim != 2 or zones.shape[1] != 3 or not np.isfinite(zones).all()
                       or zones[:, 2].min() < 0):
        raise ConfigError(f"forest: clear must be a list of (x, y, radius_m) with radius_m >= 0, got {clear!r}")
    if isinstance(crowns, str) or not crowns or any(c not in CROWNS for c in crowns):
        raise ConfigError(f"forest: crowns must be chosen among {', '.join(CROWNS)}, got {crowns!r}")


# The compass scene: (shape, distance m, bearing deg clockwise from +y, size m, rgba). The objects
# stand within half a turn (bearings -70° to 80°, unevenly spaced, so no turn but a whole one maps
# the scene onto itself) and are large (3–6 m across, 6–10 m tall): the panorama's first angular
# harmonic, which the Zernike compass's phase reads, is then strong. Spread evenly around and half
# this size, the objects' contributions to Z_{7,1} nearly cancelled: its amplitude was a few
# pixels' worth, and its phase moved by up to ±7° for a 0.5° turn, 10° apart between engines
# (measured; now within 0.7° of the turn and 1.3° between engines).
COMPASS_OBJECTS = (
    ("cylinder", 14.0, -70.0, (2.0, 5.0), (0.15, 0.35, 0.85, 1.0)),
    ("sphere", 13.0, 0.0, (3.0,), (0.90, 0.10, 0.10, 1.0)),  # the red ball, straight ahead of +y
    ("box", 16.0, 40.0, (3.0, 2.0, 3.0), (0.20, 0.70, 0.25, 1.0)),
    ("box", 17.0, -30.0, (2.0, 2.0, 6.0), (0.95, 0.85, 0.15, 1.0)),
    ("cone", 15.0, 80.0, (3.6, 5.0), (0.60, 0.25, 0.70, 1.0)),
)
COMPASS_FLOOR_M = 12.0


def compass_scene() -> World:
    """The visual compass's world: a 12 m floor and five coloured objects (a cylinder, the red ball,
    two boxes, a cone) 13–17 m from the origin at distinct bearings, each standing on the ground,
    under :func:`vision_appearance` (docs/parameters.md §7)."""
    objects = []
    for shape, distance, bearing_deg, size, rgba in COMPASS_OBJECTS:
        bearing = np.radians(bearing_deg)
        half_height = size[0] if shape == "sphere" else size[-1]
        position = (float(distance * np.sin(bearing)), float(distance * np.cos(bearing)), float(half_height))
        objects.append(WorldObject(shape, position, tuple(float(s) for s in size), rgba))
    return World(ground=Ground(size_m=COMPASS_FLOOR_M), objects=tuple(objects), appearance=vision_appearance())


def footprints_m(objects) -> np.ndarray:
    """Each object's footprint on the floor, (K, 3): x, y and radius_m (a cylinder's, cone's or sphere's
    radius; a box's larger horizontal half-extent): what a report's replay draws as circles
    (``objects_m``, :mod:`neuronav.runs.report.replay`)."""
    rows = [(obj.position_m[0], obj.position_m[1], max(obj.size_m[:2]) if obj.shape == "box" else obj.size_m[0])
            for obj in objects]
    return np.array(rows, float).reshape(-1, 3)


def world_record(world: World, **points_m) -> dict[str, np.ndarray]:
    """A trial's world as arrays in metres, for its time series (:func:`pack_world`): ``objects_m``
    (K, 3) (:func:`footprints_m`) when it has objects, each polyline trail's centre line (V, 2) as
    ``trail_m`` (then ``trail_1_m`` ...) and its width as ``trail_width_m`` (``trail_1_width_m`` ...), and
    ``points_m`` (name -> (x, y) or (P, 2)) as given."""
    record = {}
    if world.objects:
        record["objects_m"] = footprints_m(world.objects)
    lines = [t for t in world.odour.trails if getattr(t, "vertices_m", None) is not None]  # not image trails
    for i, trail in enumerate(lines):
        line = np.asarray(trail.vertices_m, float)
        name = "trail" if i == 0 else f"trail_{i}"
        record[f"{name}_m"] = np.vstack([line, line[:1]]) if trail.closed else line
        record[f"{name}_width_m"] = np.asarray(float(trail.width_m))
    record.update({name: np.asarray(value, float) for name, value in points_m.items()})
    return record


def pack_world(records: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The trials' :func:`world_record` dicts as arrays with the trial first, NaN-padded
    (:func:`neuronav.runs.trials.stack_padded`, as chunks are joined: the file is the same at any
    chunk size). A name some trial lacks is NaN for it."""
    names = list(dict.fromkeys(name for record in records for name in record))
    packed = {}
    for name in names:
        shape = next(np.shape(r[name]) for r in records if name in r)
        packed[name] = stack_padded([r[name] if name in r else np.full(shape, np.nan) for r in records], float)
    return packed
