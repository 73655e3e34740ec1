"""Reading compound eyes by rays, batched over agents: the kinematic backend's compound eyes.

Each ommatidium (:class:`~neuronav.spec.body.CompoundEye`, e.g. :func:`neuronav.senses.compound_eye.cataglyphis_eye`)
casts a fixed pattern of rays (:func:`ray_pattern`): the axis with weight 1/2 and six rays 2σ off it with
1/12 each (σ = FWHM / 2.355), the 7-point rule that integrates a 2-D Gaussian exactly for polynomials up to
degree 5; its value per channel (green, UV) is the weighted mean of what the rays see. Rays that hit nothing
see the ground (the plane z = 0, plain) below the horizon and the sky above it, in the World's green and UV
values (:func:`neuronav.senses.compound_eye.spectral_world` draws the same values for engines); objects are
intersected with the ray caster's shapes (:mod:`neuronav.senses.raycast`), the nearest hit in front of the
ground winning each ray.

Level eyes (the eye's up along the world's: every kinematic agent) read the ground and sky from a table made
once per eye height and test an upright object (cylinder, cone, sphere) only on the rays inside its azimuth
wedge and elevation band in the eye's frame (the rays kept in bands of 2° of elevation, each sorted by
azimuth: a search per band finds them); tilted eyes, and boxes, only on the tiles of ommatidia, then the
ommatidia, whose cones of rays meet the object's bounding sphere. Both give the same values. Values do not
depend on the batch: an agent reads the same alone or among a thousand. Agreement with the acceptance
integral over a rendered panorama (:func:`neuronav.senses.compound_eye.sampling_matrix`) and the speed:
docs/parameters.md, section 12.
"""

from __future__ import annotations

import math

import numpy as np

from neuronav.errors import ConfigError
from neuronav.senses.compound_eye import FWHM_TO_SIGMA, RAY_PATTERNS, TILE_DEG
from neuronav.senses.raycast import _INTERSECT, MAX_RAYS_PER_CHUNK, bounding_radius_m, tiles_meet_spheres
from neuronav.senses.vision import FAR_M, NEAR_M
from neuronav.spec.body import CompoundEye
from neuronav.spec.world import OBJECT_SIZES, World

# A level eye's rays in bands of this much elevation, found by one sorted key (:meth:`CompoundEyeReader._band_index`).
_BAND_RAD = math.radians(2.0)
_BAND_KEY = 16.0  # > 4π: one band's keys never reach the next band's
# Rays a level eye intersects per batch: its arrays (0.5 MB each) stay in the cache.
_CANDIDATES_PER_BATCH = 1 << 16
# Object-rays (objects x rays) per chunk of agents read together (between 1 and 4 MAX_RAYS_PER_CHUNK rays).
_OBJECT_RAYS_PER_CHUNK = 1 << 26
_SHAPE_CODE = {shape: code for code, shape in enumerate(OBJECT_SIZES)}


def ray_pattern(eye: CompoundEye, rays_per_ommatidium: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Each ommatidium's rays in the eye's frame (M, S, 3) and their weights (S,), summing to 1.

    S = 1: the axis. S = 7: the axis (weight 1/2) and six rays at 2σ from it, 60° apart about it from 30°
    off the horizontal across the axis (1/12 each), σ = FWHM / 2.355: exact for the Gaussian's moments up
    to degree 5.
    """
    if isinstance(rays_per_ommatidium, bool) or rays_per_ommatidium not in RAY_PATTERNS:
        raise ConfigError(f"compound eye rays_per_ommatidium must be one of {RAY_PATTERNS}, "
                          f"got {rays_per_ommatidium!r}")
    axes = eye.directions
    if rays_per_ommatidium == 1:
        return axes[:, None, :].copy(), np.ones(1)
    # An orthonormal pair across each axis (the world's z, or x near the poles, crossed with it).
    helper = np.where(np.abs(axes[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))
    u = np.cross(axes, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(axes, u)
    offset = 2.0 * eye.acceptance_rad * FWHM_TO_SIGMA  # (M,)
    psi = (np.arange(6) + 0.5) * np.pi / 3.0  # none along the row (u): a level eye's rays split 3 up, 3 down
    around = np.cos(psi)[None, :, None] * u[:, None, :] + np.sin(psi)[None, :, None] * v[:, None, :]
    ring = np.cos(offset)[:, None, None] * axes[:, None, :] + np.sin(offset)[:, None, None] * around
    rays = np.concatenate([axes[:, None, :], ring], axis=1)
    return rays, np.array([0.5] + [1.0 / 12.0] * 6)


class CompoundEyeReader:
    """One compound eye's rays against one World, for any batch of eye poses (the kinematic backend).

    Parameters
    ----------
    world : World
        Its objects and its appearance's green and UV values; the ground is the plane z = 0 (callers
        refuse other terrain), plain.
    eye : CompoundEye
    rays_per_ommatidium : int
        1 or 7 (:func:`ray_pattern`).

    Attributes
    ----------
    rays_tested, rays_hit : int
        The last :meth:`read`'s rays intersected with an object, and those that hit one (what its time among
        objects grows with: ``benchmarks/compound_eye_read.py``).
    """

    def __init__(self, world: World, eye: CompoundEye, rays_per_ommatidium: int = 7) -> None:
        if not isinstance(world, World):
            raise ConfigError(f"compound eye reader: expected a World, got {type(world).__name__}")
        if not isinstance(eye, CompoundEye):
            raise ConfigError(f"compound eye reader: expected a CompoundEye, got {type(eye).__name__}")
        self.eye = eye
        self.rays_tested = self.rays_hit = 0
        rays, self.weights = ray_pattern(eye, rays_per_ommatidium)
        self.n_ommatidia, self.n_rays = rays.shape[0], rays.shape[1]
        self._rays = rays.reshape(-1, 3)  # (M S, 3), eye frame
        look = world.appearance
        self._sky = np.array(look.sky_green_uv, float)
        self._ground = np.array(look.ground_green_uv, float)
        self.objects = tuple(world.objects)
        self._values = np.array([obj.spectral for obj in self.objects], float).reshape(-1, 2)
        self._centres = np.array([obj.position_m for obj in self.objects], float).reshape(-1, 3)
        self._radii = np.array([bounding_radius_m(obj) for obj in self.objects], float)
        self._sizes = np.zeros((len(self.objects), 3))
        for k, obj in enumerate(self.objects):
            self._sizes[k, :len(obj.size_m)] = obj.size_m
        shapes = np.array([obj.shape for obj in self.objects])
        self._shape_code = np.array([_SHAPE_CODE[obj.shape] for obj in self.objects], np.int64)
        self._by_shape = {shape: np.flatnonzero(shapes == shape) for shape in OBJECT_SIZES if (shapes == shape).any()}
        self._level_tables: dict[float, np.ndarray] = {}
        self._ray_backgrounds: dict[float, np.ndarray] = {}
        # Each ray's weight and ommatidium (rays run ommatidium by ommatidium).
        self._ray_weight = np.tile(self.weights, self.n_ommatidia)
        self._ray_ommatidium = np.repeat(np.arange(self.n_ommatidia), self.n_rays)
        self._tiles()
        # Level eyes (the kinematic agents): upright objects (all but boxes) are found by azimuth wedge and
        # elevation band in the eye's own frame, the rays sorted by azimuth once (and again 2π on, for wedges
        # across ±π).
        self._upright = np.array([obj.shape != "box" for obj in self.objects], bool)
        self._horizontal_m = np.array([float(obj.size_m[0]) for obj in self.objects]).reshape(-1)
        self._half_height_m = np.array([float(obj.size_m[0] if obj.shape == "sphere" else obj.size_m[-1])
                                        for obj in self.objects]).reshape(-1)
        self._ray_elevation = np.arcsin(np.clip(self._rays[:, 2], -1.0, 1.0))
        self._band_index()

    def _band_index(self) -> None:
        """Sort the rays into bands of elevation (eye frame), each sorted by azimuth and repeated 2π on (for
        wedges across ±π), under one increasing key: ``band * _BAND_KEY + azimuth + π``. A level eye's upright
        object then costs a search per band its elevation range meets, and only the rays inside its wedge."""
        azimuth = np.arctan2(self._rays[:, 1], self._rays[:, 0])
        band = np.floor((self._ray_elevation + np.pi / 2) / _BAND_RAD).astype(np.int64)
        self._n_bands = int(band.max()) + 1
        order = np.lexsort((azimuth, band))
        counts = np.bincount(band, minlength=self._n_bands)
        keys, rays = [], []
        for b, (first, size) in enumerate(zip(np.cumsum(counts) - counts, counts)):
            members = order[first:first + size]
            keys.append(b * _BAND_KEY + np.pi + np.concatenate([azimuth[members], azimuth[members] + 2.0 * np.pi]))
            rays.append(np.concatenate([members, members]))
        self._band_key, self._band_ray, self._band_count = np.concatenate(keys), np.concatenate(rays), counts

    def _tiles(self) -> None:
        """Group ommatidia into bins of the eye's azimuth and elevation, each with a bounding cone of rays."""
        axes = self.eye.directions
        azimuth = np.arctan2(axes[:, 1], axes[:, 0])
        elevation = np.arcsin(np.clip(axes[:, 2], -1.0, 1.0))
        width = math.radians(TILE_DEG)
        key = np.floor((azimuth + np.pi) / width) * 1000 + np.floor((elevation + np.pi / 2) / width)
        _, tile_of = np.unique(key, return_inverse=True)
        members = [np.flatnonzero(tile_of == t) for t in range(tile_of.max() + 1)]
        size = max(m.size for m in members)
        padded = np.array([np.concatenate([m, np.full(size - m.size, m[0])]) for m in members])  # (T, K)
        s = self.n_rays
        self._tile_members = padded
        self._tile_real = np.array([np.arange(size) < m.size for m in members])  # False: padding
        self._tile_rays = (padded[:, :, None] * s + np.arange(s)[None, None, :]).reshape(len(members), -1)
        rays = self._rays[self._tile_rays]  # (T, K S, 3)
        axis = rays.sum(axis=1)
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        cosine = np.clip(np.einsum("tkc,tc->tk", rays, axis), -1.0, 1.0)
        half = np.arccos(cosine.min(axis=1)) + 1e-6
        self._tile_axis, self._tile_cos, self._tile_sin = axis, np.cos(half), np.sin(half)
        # Each ommatidium's own cone of rays: its axis and the widest of its rays, for a second cull.
        spread = np.arccos(np.clip((self._rays.reshape(-1, s, 3) * axes[:, None, :]).sum(axis=2), -1.0, 1.0))
        own = spread.max(axis=1) + 1e-6
        self._own_cos, self._own_sin = np.cos(own), np.sin(own)
        self._tile_wide = half >= np.pi / 2

    # -- reading -------------------------------------------------------------------------------------
    def read(self, eyes_m, rotations, scene_yaw_rad: float = 0.0) -> np.ndarray:
        """Every agent's ommatidium values (N, M, 2), green and UV in [0, 1].

        Parameters
        ----------
        eyes_m : array_like, shape (N, 3)
            Eye positions, world frame (m).
        rotations : array_like, shape (N, 3, 3)
            Eye-to-world rotations (columns: the eye's forward, left and up axes in world coordinates).
        scene_yaw_rad : float
            The objects turned by this angle about the world's z axis (the ground and sky stay).
        """
        try:
            eyes = np.asarray(eyes_m, dtype=float).reshape(-1, 3)
            rotations = np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
            yaw = float(scene_yaw_rad)
        except (TypeError, ValueError):
            raise ConfigError("compound eye reader: eyes_m must be (N, 3), rotations (N, 3, 3) and scene_yaw_rad "
                              "a number") from None
        if eyes.shape[0] != rotations.shape[0]:
            raise ConfigError(f"compound eye reader: {eyes.shape[0]} eye positions but {rotations.shape[0]} rotations")
        if not (np.isfinite(eyes).all() and np.isfinite(rotations).all() and math.isfinite(yaw)):
            raise ConfigError("compound eye reader: eye positions, rotations and the scene yaw must be finite")
        n, m = eyes.shape[0], self.n_ommatidia
        self.rays_tested = self.rays_hit = 0
        out = np.empty((n, m, 2))
        level = np.abs(rotations[:, 2, :] - np.array([0.0, 0.0, 1.0])).max(axis=1) <= 1e-12 if n else np.ones(0, bool)
        heights = np.unique(eyes[level, 2])
        if level.all() and heights.size == 1:  # every agent level at one height (the kinematic agents)
            out[...] = self._level_table(float(heights[0]))
        else:
            for height in heights:
                out[level & (eyes[:, 2] == height)] = self._level_table(float(height))
        general = np.flatnonzero(~level)
        for start in range(0, general.size, max(1, MAX_RAYS_PER_CHUNK // self._rays.shape[0])):
            rows = general[start:start + max(1, MAX_RAYS_PER_CHUNK // self._rays.shape[0])]
            out[rows] = self._background(eyes[rows, 2], self._world_z(rotations[rows], np.arange(self._rays.shape[0])))
        if self.objects and n:
            # In chunks of agents: the merge keeps a few arrays of one entry per ray of each agent; among many
            # objects smaller chunks keep them nearer the cache (1000 agents in the 40-tree forest: 0.89 s per
            # read in chunks of 116 agents, 1.16 s in chunks of 464), among few the chunks' own cost stays small.
            rays = int(np.clip(_OBJECT_RAYS_PER_CHUNK // len(self.objects), MAX_RAYS_PER_CHUNK, 4 * MAX_RAYS_PER_CHUNK))
            chunk = max(1, rays // self._rays.shape[0])
            for start in range(0, n, chunk):
                rows = slice(start, min(n, start + chunk))
                self._objects(eyes[rows], rotations[rows], yaw, out[rows], level[rows])
        return out

    def _world_z(self, rotations: np.ndarray, rays: np.ndarray) -> np.ndarray:
        """World z of ray directions ``rays`` (indices, shape (...)) of each agent (rotations (n, 3, 3)),
        written out elementwise (the same bits at any batch size): shape (n, ...)."""
        d = self._rays[rays]
        extra = (slice(None),) + (None,) * rays.ndim
        return (rotations[:, 2, 0][extra] * d[..., 0] + rotations[:, 2, 1][extra] * d[..., 1]
                + rotations[:, 2, 2][extra] * d[..., 2])

    def _ground_t(self, heights: np.ndarray, dz: np.ndarray) -> np.ndarray:
        """Distance to the ground plane along rays with world z ``dz`` from eyes at ``heights`` (broadcast),
        inf where the ground is not hit within the cameras' range [NEAR_M, FAR_M]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -heights / dz
        return np.where((dz < 0) & (t >= NEAR_M) & (t <= FAR_M), t, np.inf)

    def _background(self, heights: np.ndarray, dz: np.ndarray) -> np.ndarray:
        """Ground and sky only: values (n, M, 2) of agents with eye ``heights`` (n,) and ray world z (n, M S)."""
        ground = np.isfinite(self._ground_t(heights[:, None], dz))
        values = np.where(ground[..., None], self._ground, self._sky)  # (n, M S, 2)
        values = values.reshape(dz.shape[0], self.n_ommatidia, self.n_rays, 2)
        return (values * self.weights[None, None, :, None]).sum(axis=2)

    def _level_table(self, height: float) -> np.ndarray:
        """A level eye's ground-and-sky values at ``height`` (M, 2): its rays' world z are their eye-frame z."""
        table = self._level_tables.get(height)
        if table is None:
            table = self._level_tables[height] = self._background(np.array([height]), self._rays[None, :, 2])[0]
        return table

    def _objects(self, eyes: np.ndarray, rotations: np.ndarray, yaw: float, out: np.ndarray,
                 level: np.ndarray) -> None:
        """Replace, ray by ray, the background by the nearest object hit in front of the ground.

        Candidate hits come from the wedges (level agents, upright objects) and from the tiles (the other
        agents, and the level agents' boxes); the nearest of each ray wins."""
        c, s = math.cos(yaw), math.sin(yaw)
        turn = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world -> objects' declared frame
        eyes_local = eyes @ turn.T
        rot_local = np.einsum("ij,njk->nik", turn, rotations)  # eye -> objects' frame
        keys, ts, owners = [], [], []
        flat, tilted = np.flatnonzero(level), np.flatnonzero(~level)
        if flat.size and self._upright.any():
            self._wedge_hits(flat, eyes_local, rot_local, eyes, keys, ts, owners)
        for agents, objects in ((tilted, np.ones(len(self.objects), bool)), (flat, ~self._upright)):
            if agents.size and objects.any():
                self._tile_hits(agents, objects, eyes_local, rot_local, eyes, keys, ts, owners)
        self._merge(keys, ts, owners, eyes, rotations, out, level)

    def _wedge_hits(self, agents: np.ndarray, eyes_local: np.ndarray, rot_local: np.ndarray, eyes: np.ndarray,
                    keys: list, ts: list, owners: list) -> None:
        """Level ``agents`` against the upright objects: in each eye's frame an object's vertical bounding
        cylinder spans an azimuth wedge and an elevation band; only the rays inside both are intersected
        (upright shapes look the same in a frame turned about z, so the rays stay in the eye's frame)."""
        objects = np.flatnonzero(self._upright)
        # Object centres in each eye's frame (n, O', 3): rot_local is a turn about z for a level eye.
        offset = self._centres[objects][None] - eyes_local[agents][:, None]
        r = rot_local[agents]
        centre = np.stack([sum(r[:, j, i, None] * offset[..., j] for j in range(3)) for i in range(3)], axis=-1)
        reach = self._horizontal_m[objects] * (1.0 + 1e-9) + 1e-9
        half = self._half_height_m[objects] * (1.0 + 1e-9) + 1e-9
        distance = np.hypot(centre[..., 0], centre[..., 1])
        inside = distance <= reach
        near, far = np.maximum(distance - reach, 0.0), distance + reach
        low, high = centre[..., 2] - half, centre[..., 2] + half
        top = np.where(high > 0, np.arctan2(high, near), np.arctan2(high, far))
        bottom = np.where(low < 0, np.arctan2(low, near), np.arctan2(low, far))
        with np.errstate(divide="ignore", invalid="ignore"):
            width = np.where(inside, np.pi, np.arcsin(np.clip(reach / distance, 0.0, 1.0)) + 1e-9)
        first = np.where(inside, -np.pi, np.mod(np.arctan2(centre[..., 1], centre[..., 0]) - width + np.pi,
                                                2.0 * np.pi) - np.pi)
        pair_agent, pair_object = np.nonzero(distance - reach <= FAR_M)
        low_rad, high_rad = bottom[pair_agent, pair_object] - 1e-9, top[pair_agent, pair_object] + 1e-9
        left_rad, span_rad = first[pair_agent, pair_object], 2.0 * width[pair_agent, pair_object]
        # (pair, band) entries: each pair's wedge searched in every band its elevation range meets.
        last_band = self._n_bands - 1
        band0 = np.clip(np.floor((low_rad + np.pi / 2) / _BAND_RAD), 0, last_band).astype(np.int64)
        band1 = np.clip(np.floor((high_rad + np.pi / 2) / _BAND_RAD), 0, last_band).astype(np.int64)
        bands = band1 - band0 + 1
        entry_pair = np.repeat(np.arange(bands.size), bands)
        band = band0[entry_pair] + np.arange(entry_pair.size) - np.repeat(np.cumsum(bands) - bands, bands)
        base = band * _BAND_KEY + np.pi + left_rad[entry_pair]
        start = np.searchsorted(self._band_key, base, side="left")
        stop = np.searchsorted(self._band_key, base + span_rad[entry_pair], side="right")
        counts = np.minimum(stop, start + self._band_count[band]) - start
        ends = np.cumsum(counts)
        source = start - (ends - counts)  # + a ray's place in the flat list of candidates: its slot in _band_ray
        # Per pair: the ray origin from the object's centre (eye frame), the object's sizes, owner and eye height,
        # and the key of the agent's first ray.
        pair_origin = [np.ascontiguousarray(-centre[pair_agent, pair_object, j]) for j in range(3)]
        pair_owner = objects[pair_object]
        pair_size = [self._sizes[pair_owner, j] for j in range(3)]
        pair_code = self._shape_code[pair_owner]
        pair_height = eyes[agents[pair_agent], 2]
        pair_key = agents[pair_agent].astype(np.int64) * self._rays.shape[0]
        begin = 0
        while begin < counts.size:  # in batches of about _CANDIDATES_PER_BATCH rays
            offset = int(ends[begin - 1]) if begin else 0
            end = max(int(np.searchsorted(ends, offset + _CANDIDATES_PER_BATCH, side="right")), begin + 1)
            entry = np.repeat(np.arange(begin, end), counts[begin:end])
            ray = self._band_ray[source[entry] + offset + np.arange(entry.size)]
            pair = entry_pair[entry]
            elevation = self._ray_elevation[ray]
            keep = (elevation >= low_rad[pair]) & (elevation <= high_rad[pair])
            ray, pair = ray[keep], pair[keep]
            code = pair_code[pair]
            for shape in self._by_shape:
                if shape == "box":
                    continue
                mine = code == _SHAPE_CODE[shape]
                if not mine.any():
                    continue
                ray_s, pair_s = ray[mine], pair[mine]
                d = self._rays[ray_s]
                direction = (d[:, 0], d[:, 1], d[:, 2])
                origin = tuple(part[pair_s] for part in pair_origin)
                size = [part[pair_s] for part in pair_size[:OBJECT_SIZES[shape]]]
                hit_t = _INTERSECT[shape](origin, direction, size)
                hit_t = np.where(hit_t < self._ground_t(pair_height[pair_s], d[:, 2]), hit_t, np.inf)
                hit = np.flatnonzero(np.isfinite(hit_t))
                self.rays_tested, self.rays_hit = self.rays_tested + hit_t.size, self.rays_hit + hit.size
                keys.append(pair_key[pair_s[hit]] + ray_s[hit])
                ts.append(hit_t[hit])
                owners.append(pair_owner[pair_s[hit]])
            begin = end

    def _tile_hits(self, agents: np.ndarray, objects: np.ndarray, eyes_local: np.ndarray, rot_local: np.ndarray,
                   eyes: np.ndarray, keys: list, ts: list, owners: list) -> None:
        """``agents`` against the ``objects`` (bool mask): the rays of the tiles, then of the ommatidia, whose
        cones meet an object's bounding sphere are intersected."""
        seen = self._seen(eyes_local[agents], rot_local[agents])  # (O, n, T)
        width = self._tile_members.shape[1]
        step = max(1, MAX_RAYS_PER_CHUNK // (width * self.n_rays))
        axes_eye = self.eye.directions
        for shape, index in self._by_shape.items():
            index = index[objects[index]]
            if index.size == 0:
                continue
            obj, agent, tile = np.nonzero(seen[index])
            agent = agents[agent]
            for start in range(0, obj.size, step):
                k, a, t = index[obj[start:start + step]], agent[start:start + step], tile[start:start + step]
                # Second cull: the tiles' ommatidia whose own cone of rays meets the bounding sphere.
                members = self._tile_members[t]  # (q, K)
                axis, r = axes_eye[members], rot_local[a]
                to_centre = self._centres[k] - eyes_local[a]  # (q, 3)
                distance = np.linalg.norm(to_centre, axis=1)
                inside = distance <= self._radii[k]
                with np.errstate(divide="ignore", invalid="ignore"):
                    unit = np.where(inside[:, None], 0.0, to_centre / distance[:, None])
                    sin_reach = np.where(inside, 0.0, self._radii[k] / distance)
                cos_reach = np.sqrt(1.0 - sin_reach ** 2)
                cosine = sum(unit[:, i, None] * (r[:, i, 0, None] * axis[..., 0] + r[:, i, 1, None] * axis[..., 1]
                                                 + r[:, i, 2, None] * axis[..., 2]) for i in range(3))
                own_cos, own_sin = self._own_cos[members], self._own_sin[members]
                near = inside[:, None] | (cosine >= cos_reach[:, None] * own_cos - sin_reach[:, None] * own_sin - 1e-6)
                near &= self._tile_real[t]
                q, column = np.nonzero(near)
                k, a, ommatidium = k[q], a[q], members[q, column]
                ray = ommatidium[:, None] * self.n_rays + np.arange(self.n_rays)[None, :]  # (p, S)
                d = self._rays[ray]  # (p, S, 3), eye frame
                r = rot_local[a]
                direction = tuple(r[:, i, 0, None] * d[..., 0] + r[:, i, 1, None] * d[..., 1]
                                  + r[:, i, 2, None] * d[..., 2] for i in range(3))
                origin = tuple((eyes_local[a, i] - self._centres[k, i])[:, None] for i in range(3))
                size = [self._sizes[k, i, None] for i in range(OBJECT_SIZES[shape])]
                hit_t = _INTERSECT[shape](origin, direction, size)
                # An object behind the ground (seen through it) is no hit.
                hit_t = np.where(hit_t < self._ground_t(eyes[a, 2, None], direction[2]), hit_t, np.inf)
                p, col = np.nonzero(np.isfinite(hit_t))
                self.rays_tested, self.rays_hit = self.rays_tested + hit_t.size, self.rays_hit + p.size
                keys.append(a[p].astype(np.int64) * self._rays.shape[0] + ray[p, col])
                ts.append(hit_t[p, col])
                owners.append(k[p])
    def _ray_background(self, height: float) -> np.ndarray:
        """What each ray of a level eye at ``height`` sees without objects (M S, 2): the ground or the sky."""
        table = self._ray_backgrounds.get(height)
        if table is None:
            under = np.isfinite(self._ground_t(height, self._rays[:, 2]))
            table = self._ray_backgrounds[height] = np.where(under[:, None], self._ground, self._sky)
        return table

    def _merge(self, keys: list, ts: list, owners: list, eyes: np.ndarray, rotations: np.ndarray,
               out: np.ndarray, level: np.ndarray) -> None:
        """The nearest hit of each ray (key: agent * rays + ray) replaces its background in ``out``."""
        if not keys:
            return
        key, t, owner = np.concatenate(keys), np.concatenate(ts), np.concatenate(owners)
        if key.size == 0:
            return
        # The nearest hit of each ray: in a world of one object each hit is its ray's (an object is tested once
        # on a ray); else few hits are sorted by (key, t); many go through an array of one entry per ray (the
        # least t per key, then the owner of a hit at that t). (Decided by the world alone, so that an agent's
        # hits add up in the same order whatever the batch.)
        rays = out.shape[0] * self._rays.shape[0]
        if len(self.objects) == 1:
            pass
        elif key.size < rays // 16:
            order = np.lexsort((t, key))
            key, owner = key[order], owner[order]
            first = np.ones(key.size, bool)
            first[1:] = key[1:] != key[:-1]
            key, owner = key[first], owner[first]
        else:
            best = np.full(rays, np.inf)
            np.minimum.at(best, key, t)
            win = t <= best[key]
            slot = np.full(rays, -1, np.int32)
            slot[key[win]] = owner[win]
            key = np.flatnonzero(slot >= 0)
            owner = slot[key]
        agent, ray = np.divmod(key, self._rays.shape[0])
        if level.all() and (eyes[:, 2] == eyes[0, 2]).all():  # level eyes at one height: each ray's from a table
            background = self._ray_background(float(eyes[0, 2]))[ray]
        else:
            d, up = self._rays[ray], rotations[:, 2, :][agent]  # the world z row of each hit's agent
            dz = up[:, 0] * d[:, 0] + up[:, 1] * d[:, 1] + up[:, 2] * d[:, 2]
            under = np.isfinite(self._ground_t(eyes[agent, 2], dz))
            background = np.where(under[:, None], self._ground, self._sky)
        change = self._ray_weight[ray][:, None] * (self._values[owner] - background)
        place = 2 * (agent * self.n_ommatidia + self._ray_ommatidium[ray])
        flat = out.reshape(-1)  # out is contiguous: a view; one channel at a time (ufunc.at is fastest in 1-D)
        np.add.at(flat, place, change[:, 0])
        np.add.at(flat, place + 1, change[:, 1])

    def _seen(self, eyes_local: np.ndarray, rot_local: np.ndarray) -> np.ndarray:
        """Whether a tile's cone of rays can meet an object's bounding sphere, bool (O, n, T) (as
        :class:`neuronav.senses.raycast.RayCaster` culls its pixel tiles)."""
        axes = np.einsum("nij,tj->nti", rot_local, self._tile_axis)  # (n, T, 3)
        return tiles_meet_spheres(axes, eyes_local, self._centres, self._radii, self._tile_cos, self._tile_sin,
                                  self._tile_wide)
