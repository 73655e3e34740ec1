"""The desert ant *Cataglyphis fortis* at ×100 scale, as a :class:`neuronav.spec.body.BodySpec`.

Numbers come from ``docs/parameters.md``§1 (itself from the I2Bot paper and its Webots model);
``bodies/desert_ant/README.md`` gives the provenance of each and says what was chosen where the
sources are silent.

Frame (body = root segment ``thorax``): +x forward (toward the head), +y left, +z up. The I2Bot
model has its head toward −x and its left legs at −y; every coordinate taken from it is turned by
180° about z, ``(x, y, z) -> (−x, −y, z)`` (a proper rotation, so left stays left), and the origin
is kept where I2Bot has it (about 0.1 m ahead of the neck joint, on the thorax axis).

Joint sign conventions (the same on both sides; right-side axes are mirrored to make it so):

- ``*_ThCz`` (thorax–coxa, vertical axis): positive swings the leg forward (protraction).
- ``*_ThCx`` (thorax–coxa, longitudinal body axis): positive raises the whole leg.
- ``*_CTr`` (coxa–trochanter): negative raises the femur (rest −0.32 … −0.78: femur up).
- ``*_FTi`` (femur–tibia): positive bends the tibia down (rest 1.39 … 1.81: tibia down).
- ``*_TiTa`` (tibia–tarsus): positive bends the tarsus down (rest −0.2: tarsus a little flatter).
- ``head_pitch`` / ``abdomen_pitch`` (axis −y): positive raises the front of the part: the head
  nose-up, the gaster (which trails behind) down. Rest: head −0.2 (nose down), abdomen +0.5.
- ``head_yaw`` / ``abdomen_yaw`` (axis +z): positive turns the part counter-clockwise seen from
  above (the head looks left; the gaster's tip swings to the right).
- ``antenna_*_pitch`` (axis −y): positive raises the antenna; ``antenna_*_yaw`` (+z): positive
  turns it left; ``antenna_*_elbow`` (scape–funiculus joint at the tip of the scape, horizontal,
  across the scape): positive bends the funiculus down.

Each leg's zero pose is the straight leg pointing outward at its base azimuth (front 45° forward,
middle straight out, hind 45° back) and tilted down by a fixed angle ``tilt`` (coxa depression,
in the femur segment's mounting quaternion). The tilt is solved so that at the published rest
angles all six claws reach the same depth: the standing height (0.43 m at scale 1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from neuronav.bodies.desert_ant import solved
from neuronav.errors import ConfigError
from neuronav.senses.compound_eye import cataglyphis_eye, check_scale
from neuronav.spec.body import BodySpec, Camera, Geom, Joint, Segment, Site, axis_angle_quat, quat_to_matrix

LEGS = ("FL", "ML", "HL", "FR", "MR", "HR")
LEG_JOINTS = ("ThCz", "ThCx", "CTr", "FTi", "TiTa")
MASS_KEYS = ("thorax", "head", "gaster", "antenna", "front_leg", "middle_leg", "hind_leg")
LEG_SEGMENTS = ("coxa", "femur", "tibia", "tarsus")  # the lengths each leg's segment factors scale, in order

# -- docs/parameters.md §1 (I2Bot coordinates: head toward -x, |y|; lengths joint to joint) -----------------
_PAIRS = {
    "F": dict(kind="front", anchor=(0.239, 0.07, -0.02), lengths=(0.020, 0.250, 0.208, 0.216),
              radii=(0.011, 0.0146, 0.011, 0.006), mass=0.27, rest=(0.0, 0.0, -0.32, 1.56, -0.2), azimuth_deg=45.0),
    "M": dict(kind="middle", anchor=(0.340, 0.02, -0.02), lengths=(0.027, 0.295, 0.244, 0.272),
              radii=(0.022, 0.0146, 0.011, 0.006), mass=0.37, rest=(0.0, 0.0, -0.385, 1.388, -0.2), azimuth_deg=90.0),
    "H": dict(kind="hind", anchor=(0.426, 0.03, -0.034), lengths=(0.046, 0.368, 0.323, 0.355),
              radii=(0.022, 0.0146, 0.011, 0.006), mass=0.52, rest=(0.0, 0.0, -0.778, 1.807, -0.2), azimuth_deg=135.0),
}
CLAW_RADIUS_M = 0.0095
STANDING_HEIGHT_M = 0.43
THORAX = dict(radius=0.0664, height=0.0584, x=0.19)  # Webots capsule "height" = its cylinder part
PETIOLE = dict(radius=0.04, height=0.084, x=0.368)
HEAD = dict(radius=0.1, height=0.0088, neck_x=0.1, centre_from_neck=0.110)
GASTER = dict(radius=0.0934, height=0.0745, joint_x=0.4838, centre_from_joint=0.116)
# The Webots gaster ends in a cone (r 0.0934, h 0.16); a capsule of about its volume replaces it.
GASTER_TIP = dict(radius=0.05, half=0.04, from_centre=0.11)
ANTENNA = dict(scape=0.224, funiculus=0.317, scape_radius=0.0075, funiculus_radius=0.005,
               base=(0.0845, 0.04, 0.02), tip_radius=0.008)
# I2Bot's funiculus capsule (0.317 + two 0.005 caps = 0.327 m) is centred 0.1637 m from the elbow; its
# odour receiver sits 0.16 m and its distance ("odour trail") sensor 0.15 m beyond that centre.
ODOUR_FRACTION = (0.1637 + 0.16) / 0.327
WIND_FRACTION = (0.1637 + 0.15) / 0.327
ANTENNA_DENSITY_KG_M3 = 600.0  # the Webots model's density for head and gaster
MASSES_KG = dict(thorax=2.9, head=2.7, gaster=4.2, front_leg=0.27, middle_leg=0.37, hind_leg=0.52)
# Rest angles of the joints docs/parameters.md leaves free (antennae) and ranges it does not give.
ANTENNA_REST = dict(pitch=0.35, yaw=0.6, elbow=1.3)
LEG_RANGE_RAD = (-1.9, 1.9)
# The published hind rest FTi (1.807) plus the 20° FK lift is 2.156: beyond 1.9. I2Bot's Webots leg
# motors had no position limit (±1.9 came from its ikpy URDFs), so FTi flexes further here.
FTI_RANGE_RAD = (-1.9, 2.4)

# Position-controller settings (scale 1). See README.md "Actuators" for how they were chosen.
LEG_GAINS = dict(kp=1000.0, kd=20.0, damping=1.0, armature=0.05, max_torque_nm=50.0)
TRUNK_GAINS = dict(kp=1000.0, kd=20.0, damping=2.0, armature=0.02, max_torque_nm=1000.0)
ANTENNA_GAINS = dict(kp=20.0, kd=0.3, damping=0.02, armature=0.002, max_torque_nm=10.0)

LEG_RGBA = (0.12, 0.08, 0.05, 1.0)
BODY_RGBA = (0.55, 0.3, 0.12, 1.0)
GASTER_RGBA = (0.25, 0.12, 0.05, 1.0)


# -- small geometry helpers ------------------------------------------------------------------------
def _quat_z_to(direction) -> tuple[float, float, float, float]:
    """Quaternion turning local +z onto ``direction`` (capsules and cylinders lie along z)."""
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, d)
    sin, cos = np.linalg.norm(axis), float(z @ d)
    if sin < 1e-12:
        return (1.0, 0.0, 0.0, 0.0) if cos > 0 else (0.0, 1.0, 0.0, 0.0)
    return axis_angle_quat(axis, math.atan2(sin, cos))


def _quat_from_matrix(matrix: np.ndarray) -> tuple[float, float, float, float]:
    """scipy's quaternion of a rotation matrix, (w, x, y, z); kept for the default ant (:mod:`.solved`)."""

    def solve() -> tuple[float, float, float, float]:
        from scipy.spatial.transform import Rotation

        x, y, z, w = Rotation.from_matrix(matrix).as_quat()
        return (float(w), float(x), float(y), float(z))

    return tuple(solved.lookup("quats", solved.matrix_key(matrix), solve))


def _quat_mul(a, b) -> tuple[float, float, float, float]:
    return _quat_from_matrix(quat_to_matrix(a) @ quat_to_matrix(b))


def _camera_quat(look, up) -> tuple[float, float, float, float]:
    """Camera orientation looking along ``look`` with image-up near ``up`` (camera looks along -z, up +y)."""
    z = -np.asarray(look, float) / np.linalg.norm(look)
    y = np.asarray(up, float) - (np.asarray(up, float) @ z) * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    return _quat_from_matrix(np.column_stack([x, y, z]))


def _capsule_between(start, end, radius: float, name: str, rgba, min_half_fraction: float = 0.0) -> Geom:
    """A capsule whose cylinder runs between two points, shortened by its caps (at least a fraction kept)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(end - start))
    half = max(length / 2.0 - radius, min_half_fraction * length / 2.0, 1e-4)
    return Geom("capsule", (radius, half), tuple(float(v) for v in (start + end) / 2.0), _quat_z_to(end - start),
                rgba, name)


def _volume(geoms) -> float:
    return float(sum(g.volume_m3() for g in geoms))


def _check_antenna_yaw(value) -> float:
    """A rest yaw the joint can hold with room for a ±0.7 rad sweep: -0.9 to 0.9 rad."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not -0.9 <= value <= 0.9:
        raise ConfigError(f"antenna_yaw_rad must be a number from -0.9 to 0.9 rad, got {value!r}")
    return float(value)


def _check_positive(label: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"desert_ant: {label} must be a positive number, got {value!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise ConfigError(f"desert_ant: {label} must be positive and finite, got {value!r}")
    return value


# -- the leg's planar chain, used to solve the coxa tilt -------------------------------------------
def _claw_depth(tilt_rad: float, anchor_z: float, lengths, rest) -> float:
    """Depth (m, positive down) of the claw centre below the root at the rest angles, for a tilt."""
    _, femur, tibia, tarsus = lengths
    _, _, ctr, fti, tita = rest
    a1 = tilt_rad + ctr
    a2 = a1 + fti
    a3 = a2 + tita
    return -anchor_z + femur * math.sin(a1) + tibia * math.sin(a2) + tarsus * math.sin(a3)


def _solve_tilt(target_depth: float, anchor_z: float, lengths, rest) -> float:
    """The coxa tilt putting the claw at ``target_depth``; the deepest reachable tilt if it cannot.

    Solved by scipy; the default ant's tilts are kept (:mod:`neuronav.bodies.desert_ant.solved`).
    """
    return float(solved.lookup("tilts", solved.tilt_key(target_depth, anchor_z, lengths, rest),
                               lambda: _solve_tilt_scipy(target_depth, anchor_z, lengths, rest)))


def _solve_tilt_scipy(target_depth: float, anchor_z: float, lengths, rest) -> float:
    from scipy.optimize import brentq, minimize_scalar

    low = -1.0
    deepest = minimize_scalar(lambda t: -_claw_depth(t, anchor_z, lengths, rest), bounds=(low, 1.5),
                              method="bounded", options={"xatol": 1e-12}).x

    def f(tilt: float) -> float:
        return _claw_depth(tilt, anchor_z, lengths, rest) - target_depth

    if f(deepest) <= 0:
        return float(deepest)
    if f(low) >= 0:
        return low
    return float(brentq(f, low, deepest, xtol=1e-14))


def _leg_factors(leg_length_factors) -> dict[str, float]:
    if leg_length_factors is None:
        return {leg: 1.0 for leg in LEGS}
    if isinstance(leg_length_factors, Mapping):
        unknown = sorted(set(leg_length_factors) - set(LEGS))
        if unknown:
            raise ConfigError(f"desert_ant: leg_length_factors has unknown leg {unknown[0]!r}; "
                              f"allowed: {', '.join(LEGS)}")
        return {leg: _check_positive(f"leg_length_factors[{leg!r}]", leg_length_factors.get(leg, 1.0))
                for leg in LEGS}
    factor = _check_positive("leg_length_factors", leg_length_factors)
    return {leg: factor for leg in LEGS}


def _segment_factors(leg_segment_factors) -> tuple[float, float, float, float] | None:
    """``{segment: factor}`` for some of ``LEG_SEGMENTS`` as a factor per segment (None: no change)."""
    if leg_segment_factors is None:
        return None
    if not isinstance(leg_segment_factors, Mapping):
        raise ConfigError("desert_ant: leg_segment_factors must be a mapping segment -> factor "
                          f"(segments: {', '.join(LEG_SEGMENTS)}), got {leg_segment_factors!r}")
    unknown = sorted(set(leg_segment_factors) - set(LEG_SEGMENTS))
    if unknown:
        raise ConfigError(f"desert_ant: leg_segment_factors has unknown segment {unknown[0]!r}; "
                          f"allowed: {', '.join(LEG_SEGMENTS)}")
    return tuple(_check_positive(f"leg_segment_factors[{segment!r}]", leg_segment_factors.get(segment, 1.0))
                 for segment in LEG_SEGMENTS)


def _masses(masses_kg, scale: float, antenna_mass_kg: float) -> dict[str, float]:
    masses = {key: value * scale**3 for key, value in MASSES_KG.items()}
    masses["antenna"] = antenna_mass_kg
    if masses_kg is None:
        return masses
    if not isinstance(masses_kg, Mapping):
        raise ConfigError(f"desert_ant: masses_kg must be a mapping part -> kg (parts: {', '.join(MASS_KEYS)})")
    for key, value in masses_kg.items():
        if key not in MASS_KEYS:
            raise ConfigError(f"desert_ant: masses_kg has unknown part {key!r}; allowed: {', '.join(MASS_KEYS)}")
        masses[key] = _check_positive(f"masses_kg[{key!r}]", value)
    return masses


def _joint(name: str, axis, rest: float, limits, gains: dict, scale: float) -> Joint:
    # Froude similarity: torques ∝ m·g·l ∝ s⁴, inertias ∝ s⁵, so kd ∝ √(kp·I) ∝ s^4.5.
    return Joint(name, "hinge", tuple(float(a) for a in axis), tuple(limits), float(rest),
                 damping=gains["damping"] * scale**4.5, armature=gains["armature"] * scale**5,
                 max_torque_nm=gains["max_torque_nm"] * scale**4, kp=gains["kp"] * scale**4,
                 kd=gains["kd"] * scale**4.5)


def _from_i2bot(point) -> tuple[float, float, float]:
    """I2Bot coordinates (head toward -x) to neuronav's (head toward +x): 180° about z."""
    x, y, z = point
    return (-float(x), -float(y), float(z))


# -- the body ----------------------------------------------------------------------------------------
def desert_ant(scale: float = 1.0, leg_length_factors=None, antenna_length_m: float | None = None,
               masses_kg: Mapping[str, float] | None = None, standing_height_m: float | None = None,
               antenna_yaw_rad: float | None = None, name: str = "desert_ant",
               leg_segment_factors: Mapping[str, float] | None = None, ventral_eye: bool = False,
               compound_eyes: bool = False, ommatidia_scale: float = 1.0) -> BodySpec:
    """The Cataglyphis fortis body at ×100 scale (0.1 m in simulation ≈ 1 mm on the ant).

    Parameters
    ----------
    scale : float
        Multiplies every length; masses scale with ``scale**3`` and the actuator gains so the body
        stays dynamically similar (torques and kp ∝ scale⁴, kd and damping ∝ scale⁴·⁵, armature ∝ scale⁵).
    leg_length_factors : float or dict, optional
        One factor for every leg, or ``{leg: factor}`` for some of ``LEGS``; multiplies the coxa,
        femur, tibia and tarsus lengths (radii kept; the leg's mass follows its volume).
    leg_segment_factors : dict, optional
        ``{segment: factor}`` for some of ``LEG_SEGMENTS`` (coxa, femur, tibia, tarsus), the same on
        every leg, multiplying that segment's length on top of ``leg_length_factors`` (radii kept, mass
        by volume, standing height re-solved as for ``leg_length_factors``). For manipulations that
        change part of a leg, e.g. Wittlinger et al. 2006's stumps (tibia halved, tarsus gone):
        :mod:`neuronav.bodies.desert_ant.manipulations`.
    antenna_length_m : float, optional
        Scape + funiculus length of each antenna (default 0.541·scale, split 0.224 : 0.317).
    masses_kg : dict, optional
        Final masses (not rescaled) for any of ``MASS_KEYS``: ``thorax`` (with the petiole),
        ``head`` (with the neck link), ``gaster`` (with the waist link), ``antenna`` (each),
        ``front_leg`` / ``middle_leg`` / ``hind_leg`` (each leg of the pair).
    standing_height_m : float, optional
        Height of the root above a flat floor at the rest pose. Default 0.43·scale with the
        published legs; with changed leg lengths, the mean depth the legs reach with the default
        coxa tilts (so the body stays level and every claw touches).
    antenna_yaw_rad : float, optional
        Rest yaw of each antenna, outward from straight ahead, -0.9 to 0.9 rad (default 0.6, I2Bot's);
        smaller brings the odour sites together (at rest 0.43 m apart at 0.6 rad, 0.23 m at 0.25).
    name : str
    ventral_eye : bool
        Add the ``ventral`` camera (32×32 planar, 90°, under the thorax looking straight down, image top
        forward): the optic-flow odometer's eye patch. Default False: the cameras below only.
    compound_eyes : bool
        Carry the two compound eyes ``compound_eye_L`` and ``compound_eye_R`` on the head (default False: a
        body without them reads no eyes and loads no sampling matrices):
        :func:`neuronav.senses.compound_eye.cataglyphis_eye`, at the binocular cameras' places, levelled
        like the panorama (the eyes' equator on the horizon when the head is at rest on a level thorax).
    ommatidia_scale : float
        Multiplies each compound eye's ommatidia count (1287 at 1), in [0.01, 4].

    Returns
    -------
    BodySpec
        40 hinge joints: 6 legs × (ThCz, ThCx, CTr, FTi, TiTa) in ``LEGS`` order, then head
        (pitch, yaw), abdomen (pitch, yaw), antenna L and R (pitch, yaw, elbow). Contact sites: the
        six claws (``FL_claw`` …) then ``antenna_L_tip``, ``antenna_R_tip``. Cameras ``eye_L``,
        ``eye_R`` (74×19, planar) and ``panorama`` (72×72, spherical: the whole sphere, level, forward in the middle).
    """
    scale = _check_positive("scale", scale)
    factors = _leg_factors(leg_length_factors)
    segment_factors = _segment_factors(leg_segment_factors)
    antenna_total = ANTENNA["scape"] + ANTENNA["funiculus"]
    antenna_length = (antenna_total * scale if antenna_length_m is None
                      else _check_positive("antenna_length_m", antenna_length_m))
    if standing_height_m is not None:
        standing_height_m = _check_positive("standing_height_m", standing_height_m)
    antenna_yaw = ANTENNA_REST["yaw"] if antenna_yaw_rad is None else _check_antenna_yaw(antenna_yaw_rad)
    scape_len = antenna_length * ANTENNA["scape"] / antenna_total
    funiculus_len = antenna_length - scape_len
    scape_r, funiculus_r = ANTENNA["scape_radius"] * scale, ANTENNA["funiculus_radius"] * scale
    tip_r = ANTENNA["tip_radius"] * scale
    antenna_volume = (math.pi * scape_r**2 * scape_len + math.pi * funiculus_r**2 * funiculus_len
                      + 4.0 / 3.0 * math.pi * tip_r**3)
    masses = _masses(masses_kg, scale, ANTENNA_DENSITY_KG_M3 * antenna_volume)
    claw_r = CLAW_RADIUS_M * scale

    # Coxa tilts: first for the published legs at this scale, then re-solved for the actual legs.
    default_depths, legs = {}, {}
    for leg in LEGS:
        pair = _PAIRS[leg[0]]
        anchor_z = pair["anchor"][2] * scale
        published = tuple(v * scale for v in pair["lengths"])
        actual = tuple(v * factors[leg] for v in published)
        if segment_factors is not None:
            actual = tuple(v * f for v, f in zip(actual, segment_factors))
        tilt0 = _solve_tilt(STANDING_HEIGHT_M * scale - claw_r, anchor_z, published, pair["rest"])
        default_depths[leg] = _claw_depth(tilt0, anchor_z, actual, pair["rest"])
        legs[leg] = (pair, anchor_z, actual)
    if standing_height_m is None:
        target_depth = float(np.mean(list(default_depths.values())))
    else:
        target_depth = standing_height_m - claw_r
    tilts = {leg: _solve_tilt(target_depth, anchor_z, lengths, pair["rest"])
             for leg, (pair, anchor_z, lengths) in legs.items()}
    depth = max(_claw_depth(tilts[leg], legs[leg][1], legs[leg][2], legs[leg][0]["rest"]) for leg in LEGS)

    thorax_geoms = (
        Geom("capsule", (THORAX["radius"] * scale, THORAX["height"] / 2 * scale),
             (-THORAX["x"] * scale, 0.0, 0.0), _quat_z_to((1, 0, 0)), BODY_RGBA, "thorax"),
        Geom("capsule", (PETIOLE["radius"] * scale, PETIOLE["height"] / 2 * scale),
             (-PETIOLE["x"] * scale, 0.0, 0.0), _quat_z_to((1, 0, 0)), BODY_RGBA, "petiole"),
    )
    segments = [Segment("thorax", None, thorax_geoms, masses["thorax"])]
    sites: list[Site] = []
    for leg in LEGS:
        pair, anchor_z, lengths = legs[leg]
        key = f"{pair['kind']}_leg"
        mass = masses[key]
        if masses_kg is None or key not in masses_kg:  # a longer leg of the same thickness is heavier
            published = tuple(v * scale for v in pair["lengths"])
            mass *= (sum(_volume(g) for g in _leg_geoms(leg, pair, lengths, scale).values())
                     / sum(_volume(g) for g in _leg_geoms(leg, pair, published, scale).values()))
        segs, claw_pos = _leg_segments(leg, pair, lengths, tilts[leg], mass, scale)
        segments += segs
        sites.append(Site(f"{leg}_claw", f"{leg}_tarsus", claw_pos, "contact", f"{leg}_claw", adhesive=True))

    segments += _trunk_segments(masses, scale)
    for side in ("L", "R"):
        segs, side_sites = _antenna_segments(side, scape_len, funiculus_len, scape_r, funiculus_r, tip_r,
                                             masses["antenna"], scale, antenna_yaw)
        segments += segs
        sites += side_sites
    # Contact sites: claws in LEGS order, then the antenna tips; odour and wind after them.
    sites.sort(key=lambda s: ("contact", "odour", "wind", "marker").index(s.kind))
    sites += _markers(scale)

    notes = {
        "species": "Cataglyphis fortis, ×100 scale (I2Bot, Sun et al.)",
        "frame": "+x forward (head), +y left, +z up; I2Bot coordinates turned 180° about z",
        "self_collision": False,
        "legs": LEGS,
        "leg_joints": LEG_JOINTS,
        "leg_tilt_rad": {leg: float(t) for leg, t in tilts.items()},
        "standing_height_m": float(depth + claw_r),
        "scale": scale,
        "control": "torque = kp·(target − q) − kd·q̇, clipped to ±max_torque_nm; control step 8 ms",
    }
    cameras = _cameras(scale) + ((_ventral_camera(scale),) if ventral_eye else ())
    ommatidia_scale = check_scale(ommatidia_scale)  # checked with or without the eyes
    eyes = _compound_eyes(scale, ommatidia_scale) if compound_eyes else ()
    return BodySpec(name, tuple(segments), tuple(sites), cameras, spawn_height_m=float(depth + claw_r),
                    notes=notes, compound_eyes=eyes)


def _leg_geoms(leg: str, pair: dict, lengths, scale: float) -> dict[str, tuple[Geom, ...]]:
    """The geoms of one leg's segments (thc, coxa, femur, tibia, tarsus with its claw), each in its own frame."""
    side = 1.0 if leg[1] == "L" else -1.0
    coxa, femur, tibia, tarsus = lengths
    r_coxa, r_femur, r_tibia, r_tarsus = (r * scale for r in pair["radii"])
    azimuth = side * math.radians(pair["azimuth_deg"])
    outward = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
    x_axis = np.array([1.0, 0.0, 0.0])
    return {
        "thc": (Geom("sphere", (r_coxa,), name=f"{leg}_thc", rgba=LEG_RGBA),),
        "coxa": (_capsule_between((0, 0, 0), coxa * outward, r_coxa, f"{leg}_coxa", LEG_RGBA, 0.5),),
        "femur": (_capsule_between((0, 0, 0), femur * x_axis, r_femur, f"{leg}_femur", LEG_RGBA),),
        "tibia": (_capsule_between((0, 0, 0), tibia * x_axis, r_tibia, f"{leg}_tibia", LEG_RGBA),),
        "tarsus": (_capsule_between((0, 0, 0), tarsus * x_axis, r_tarsus, f"{leg}_tarsus", LEG_RGBA),
                   Geom("sphere", (CLAW_RADIUS_M * scale,), (float(tarsus), 0.0, 0.0), name=f"{leg}_claw",
                        rgba=(0, 0, 0, 1))),
    }


def _leg_segments(leg: str, pair: dict, lengths, tilt: float, mass_kg: float, scale: float):
    """Segments ``{leg}_thc, _coxa, _femur, _tibia, _tarsus`` and the claw's position in the tarsus frame.

    ``mass_kg`` is the whole leg's mass, spread over the segments by geom volume.
    """
    side = 1.0 if leg[1] == "L" else -1.0
    coxa, femur, tibia, tarsus = lengths
    ax, ay, az = pair["anchor"]
    anchor = _from_i2bot((ax * scale, -side * ay * scale, az * scale))  # I2Bot's left legs are at -y
    azimuth = side * math.radians(pair["azimuth_deg"])
    outward = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
    leg_quat = _quat_mul(axis_angle_quat((0, 0, 1), azimuth), axis_angle_quat((0, 1, 0), tilt))
    claw_pos = (float(tarsus), 0.0, 0.0)
    geoms = _leg_geoms(leg, pair, lengths, scale)
    total = sum(_volume(g) for g in geoms.values())
    mass = {part: mass_kg * _volume(g) / total for part, g in geoms.items()}
    rest = dict(zip(LEG_JOINTS, pair["rest"]))

    def joint(name, axis, limits=LEG_RANGE_RAD):
        return _joint(f"{leg}_{name}", axis, rest[name], limits, LEG_GAINS, scale)

    # Left and right axes are mirrored so each sign means the same motion on both sides.
    segments = [
        Segment(f"{leg}_thc", "thorax", geoms["thc"], mass["thc"], joint("ThCz", (0, 0, -side)), anchor),
        Segment(f"{leg}_coxa", f"{leg}_thc", geoms["coxa"], mass["coxa"], joint("ThCx", (side, 0, 0))),
        Segment(f"{leg}_femur", f"{leg}_coxa", geoms["femur"], mass["femur"], joint("CTr", (0, 1, 0)),
                tuple(float(v) for v in coxa * outward), leg_quat),
        Segment(f"{leg}_tibia", f"{leg}_femur", geoms["tibia"], mass["tibia"],
                joint("FTi", (0, 1, 0), FTI_RANGE_RAD), (float(femur), 0.0, 0.0)),
        Segment(f"{leg}_tarsus", f"{leg}_tibia", geoms["tarsus"], mass["tarsus"], joint("TiTa", (0, 1, 0)),
                (float(tibia), 0.0, 0.0)),
    ]
    return segments, claw_pos


def _trunk_segments(masses: dict, scale: float) -> list[Segment]:
    """Neck link + head (pitch, then yaw) and waist link + gaster (pitch, then yaw)."""
    neck = (HEAD["neck_x"] * scale, 0.0, 0.0)
    head_centre = HEAD["centre_from_neck"] * scale
    neck_geoms = (Geom("sphere", (0.03 * scale,), name="neck", rgba=BODY_RGBA),)
    head_geoms = (Geom("capsule", (HEAD["radius"] * scale, HEAD["height"] / 2 * scale), (head_centre, 0.0, 0.0),
                       _quat_z_to((0, 1, 0)), BODY_RGBA, "head"),)
    head_total = _volume(neck_geoms) + _volume(head_geoms)
    waist = (GASTER["joint_x"] * scale, 0.0, 0.0)
    gaster_centre = -GASTER["centre_from_joint"] * scale
    waist_geoms = (Geom("sphere", (0.035 * scale,), name="waist", rgba=BODY_RGBA),)
    gaster_geoms = (
        Geom("capsule", (GASTER["radius"] * scale, GASTER["height"] / 2 * scale), (gaster_centre, 0.0, 0.0),
             _quat_z_to((1, 0, 0)), GASTER_RGBA, "gaster"),
        Geom("capsule", (GASTER_TIP["radius"] * scale, GASTER_TIP["half"] * scale),
             (gaster_centre - GASTER_TIP["from_centre"] * scale, 0.0, 0.0), _quat_z_to((1, 0, 0)), GASTER_RGBA,
             "gaster_tip"),
    )
    gaster_total = _volume(waist_geoms) + _volume(gaster_geoms)
    down = (0.0, -1.0, 0.0)  # pitch axis: positive raises the front (nose up / gaster down)
    return [
        Segment("neck", "thorax", neck_geoms, masses["head"] * _volume(neck_geoms) / head_total,
                _joint("head_pitch", down, -0.2, (-0.8, 0.8), TRUNK_GAINS, scale), _from_i2bot(neck)),
        Segment("head", "neck", head_geoms, masses["head"] * _volume(head_geoms) / head_total,
                _joint("head_yaw", (0, 0, 1), 0.0, (-0.8, 0.8), TRUNK_GAINS, scale)),
        Segment("waist", "thorax", waist_geoms, masses["gaster"] * _volume(waist_geoms) / gaster_total,
                _joint("abdomen_pitch", down, 0.5, (-0.5, 1.2), TRUNK_GAINS, scale), _from_i2bot(waist)),
        Segment("gaster", "waist", gaster_geoms, masses["gaster"] * _volume(gaster_geoms) / gaster_total,
                _joint("abdomen_yaw", (0, 0, 1), 0.0, (-0.6, 0.6), TRUNK_GAINS, scale)),
    ]


def _antenna_segments(side: str, scape_len: float, funiculus_len: float, scape_r: float, funiculus_r: float,
                      tip_r: float, mass_kg: float, scale: float, yaw_rad: float):
    """Base (pitch), scape (yaw, resting ``yaw_rad`` outward), funiculus (elbow) of one antenna, its tip
    contact and its odour/wind sites."""
    sign = 1.0 if side == "L" else -1.0
    bx, by, bz = ANTENNA["base"]
    base = (HEAD["centre_from_neck"] * scale + bx * scale, sign * by * scale, bz * scale)
    prefix = f"antenna_{side}"
    x_axis = np.array([1.0, 0.0, 0.0])
    geoms = {
        "base": (Geom("sphere", (1.2 * scape_r,), name=f"{prefix}_base", rgba=LEG_RGBA),),
        "scape": (_capsule_between((0, 0, 0), scape_len * x_axis, scape_r, f"{prefix}_scape", LEG_RGBA),),
        "funiculus": (_capsule_between((0, 0, 0), funiculus_len * x_axis, funiculus_r, f"{prefix}_funiculus",
                                       LEG_RGBA),
                      Geom("sphere", (tip_r,), (funiculus_len, 0.0, 0.0), name=f"{prefix}_tip", rgba=(0, 0, 0, 1))),
    }
    total = sum(_volume(g) for g in geoms.values())
    mass = {part: mass_kg * _volume(g) / total for part, g in geoms.items()}
    odour, wind = funiculus_len * ODOUR_FRACTION, funiculus_len * WIND_FRACTION
    segments = [
        Segment(f"{prefix}_base", "head", geoms["base"], mass["base"],
                _joint(f"{prefix}_pitch", (0, -1, 0), ANTENNA_REST["pitch"], (-0.8, 1.2), ANTENNA_GAINS, scale),
                base),
        Segment(f"{prefix}_scape", f"{prefix}_base", geoms["scape"], mass["scape"],
                _joint(f"{prefix}_yaw", (0, 0, 1), sign * yaw_rad, (-1.6, 1.6), ANTENNA_GAINS, scale)),
        Segment(f"{prefix}_funiculus", f"{prefix}_scape", geoms["funiculus"], mass["funiculus"],
                _joint(f"{prefix}_elbow", (0, 1, 0), ANTENNA_REST["elbow"], (-0.3, 2.4), ANTENNA_GAINS, scale),
                (float(scape_len), 0.0, 0.0)),
    ]
    sites = [
        Site(f"{prefix}_tip", f"{prefix}_funiculus", (funiculus_len, 0.0, 0.0), "contact", f"{prefix}_tip"),
        Site(f"odour_{side}", f"{prefix}_funiculus", (odour, 0.0, 0.0), "odour"),
        Site(f"wind_{side}", f"{prefix}_funiculus", (wind, 0.0, 0.0), "wind"),
    ]
    return segments, sites


# The ventral eye patch (``ventral_eye=True``): a small downward camera under the thorax whose image motion
# is the optic-flow odometer's input (neuronav.senses.optic_flow). 90° and 32 px: 0.36 m above the ground at
# rest it sees 0.72 m of ground (1.4 checker squares of 0.5 m: edges of both directions in view), 2.25 cm per px.
VENTRAL_EYE = dict(x=-THORAX["x"], z=-0.07, size_px=32, fov_rad=math.pi / 2.0)


def _ventral_camera(scale: float) -> Camera:
    """The ventral eye: under the thorax's centre, looking straight down, image top toward the head (+x)."""
    # Camera axes in the thorax frame: x (image right) = -y (body right), y (image top) = +x, z = +z.
    return Camera("ventral", "thorax", (VENTRAL_EYE["x"] * scale, 0.0, VENTRAL_EYE["z"] * scale),
                  axis_angle_quat((0.0, 0.0, 1.0), -math.pi / 2.0), width_px=VENTRAL_EYE["size_px"],
                  height_px=VENTRAL_EYE["size_px"], fov_rad=(VENTRAL_EYE["fov_rad"], VENTRAL_EYE["fov_rad"]),
                  projection="planar")


def _cameras(scale: float) -> tuple[Camera, ...]:
    """Binocular eyes (±30° lateral, 9.5° up in the head frame) and the upward panoramic camera."""
    centre = np.array([HEAD["centre_from_neck"] * scale, 0.0, 0.0])
    cameras = []
    for side, sign in (("L", 1.0), ("R", -1.0)):
        azimuth, elevation = sign * math.radians(30.0), math.radians(9.5)
        look = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                         math.sin(elevation)])
        # I2Bot's eyes: (0.0587, ±0.077, 0.0625) m from the head centre, just outside the head.
        position = centre + np.array([0.0587, sign * 0.077, 0.0625]) * scale
        cameras.append(Camera(f"eye_{side}", "head", tuple(float(v) for v in position), _camera_quat(look, (0, 0, 1)),
                              width_px=74, height_px=19, fov_rad=(2.0, 0.5), projection="planar"))
    # The whole sphere, level at the rest head pitch (-0.2, nose down): the middle of the image looks
    # forward along the horizon, column 0 straight back, 5° per column and 2.5° per row.
    level = quat_to_matrix(axis_angle_quat((0, 1, 0), -0.2))  # undoes the head's rest pitch
    position = centre + level @ np.array([0.0, 0.0, 0.12 * scale])
    quat = _quat_from_matrix(level @ quat_to_matrix(_camera_quat((1, 0, 0), (0, 0, 1))))
    cameras.append(Camera("panorama", "head", tuple(float(v) for v in position), quat, width_px=72, height_px=72,
                          fov_rad=(2.0 * math.pi, math.pi), projection="spherical", supersample=4))
    return tuple(cameras)


def _compound_eyes(scale: float, ommatidia_scale: float) -> tuple:
    """The two compound eyes on the head, where the binocular cameras sit, levelled as the panorama is."""
    centre = np.array([HEAD["centre_from_neck"] * scale, 0.0, 0.0])
    level = axis_angle_quat((0, 1, 0), -0.2)  # undoes the head's rest pitch
    eyes = []
    for side, sign in (("L", 1.0), ("R", -1.0)):
        position = centre + np.array([0.0587, sign * 0.077, 0.0625]) * scale
        eyes.append(cataglyphis_eye(f"compound_eye_{side}", "head", tuple(float(v) for v in position), side, level,
                                    ommatidia_scale))
    return tuple(eyes)


def point_agent_compound_eyes(body: BodySpec) -> tuple:
    """``body``'s compound eyes placed in a point agent's frame as they sit on the body at rest (as
    ``neuronav.scenarios.visual_setup.point_agent_cameras`` places its cameras): the root ``spawn_height_m``
    above the ground, level, every joint at rest; ``segment`` kept. For ``PointAgents(compound_eyes=...)``."""
    from dataclasses import replace

    from neuronav.bodies.gaits import segment_pose  # lazily: gaits imports this module

    eyes = []
    for eye in body.compound_eyes:
        rotation, position = segment_pose(body, eye.segment, {})
        where = position + rotation @ np.asarray(eye.pos_m, float) + np.array([0.0, 0.0, body.spawn_height_m])
        frame = rotation @ quat_to_matrix(eye.quat)
        eyes.append(replace(eye, pos_m=tuple(float(v) for v in where), quat=_matrix_quat(frame)))
    return tuple(eyes)


def _matrix_quat(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """A rotation matrix as a unit quaternion (w, x, y, z), w >= 0 (Shepperd's method, the largest pivot)."""
    m = np.asarray(rotation, float)
    trace = np.trace(m)
    candidates = [trace, m[0, 0], m[1, 1], m[2, 2]]
    k = int(np.argmax(candidates))
    if k == 0:
        w = math.sqrt(1.0 + trace) / 2.0
        q = (w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w))
    else:
        i, j, n = k - 1, k % 3, (k + 1) % 3
        r = math.sqrt(max(0.0, 1.0 + m[i, i] - m[j, j] - m[n, n])) / 2.0
        v = [0.0, 0.0, 0.0]
        v[i], v[j], v[n] = r, (m[j, i] + m[i, j]) / (4 * r), (m[n, i] + m[i, n]) / (4 * r)
        q = ((m[n, j] - m[j, n]) / (4 * r), *v)
    q = np.asarray(q) * (1.0 if q[0] >= 0 else -1.0)
    return tuple(float(v) for v in q / np.linalg.norm(q))


def _markers(scale: float) -> list[Site]:
    head_front = (HEAD["centre_from_neck"] + HEAD["radius"]) * scale
    tip = -(GASTER["centre_from_joint"] + GASTER_TIP["from_centre"] + GASTER_TIP["half"] + GASTER_TIP["radius"]) * scale
    return [
        Site("thorax_centre", "thorax", (-THORAX["x"] * scale, 0.0, 0.0), "marker"),
        Site("head_front", "head", (head_front, 0.0, 0.0), "marker"),
        Site("gaster_tip", "gaster", (tip, 0.0, 0.0), "marker"),
    ]


# -- queries the gaits use ---------------------------------------------------------------------------
def leg_geometry(body: BodySpec) -> dict[str, dict]:
    """Per leg, the geometry read back from the spec (so gaits and IK follow any variant of the body).

    Returns
    -------
    dict
        ``{leg: {...}}`` for each of ``LEGS`` with ``anchor_m`` (3,) the ThC joint in the body frame,
        ``coxa_m``, ``femur_m``, ``tibia_m``, ``tarsus_m`` (joint to joint; tarsus to the claw centre),
        ``azimuth_rad`` (the leg's outward direction at ThCz = 0, counter-clockwise from +x),
        ``tilt_rad`` (its downward tilt at CTr = 0), ``thcz_axis_z`` (−1 left, +1 right: the ThCz
        axis's z so that positive ThCz swings forward), ``joints`` (the five names) and
        ``rest_rad`` (5,).
    """
    geometry = {}
    for leg in LEGS:
        try:
            thc, coxa, femur, tibia, tarsus = (body.segment(f"{leg}_{part}")
                                               for part in ("thc", "coxa", "femur", "tibia", "tarsus"))
        except ConfigError:
            raise ConfigError(f"body {body.name!r} has no complete leg {leg!r} "
                              f"(segments {leg}_thc, _coxa, _femur, _tibia, _tarsus)") from None
        site = next((s for s in body.sites if s.name == f"{leg}_claw"), None)
        claw = next((g for g in tarsus.geoms if site is not None and g.name == site.geom), None)
        if claw is None:
            raise ConfigError(f"body {body.name!r}: leg {leg!r} has no contact site {leg}_claw on its tarsus")
        leg_x = quat_to_matrix(femur.quat)[:, 0]
        geometry[leg] = {
            "anchor_m": np.array(thc.pos_m, float),
            "coxa_m": float(np.linalg.norm(femur.pos_m)),
            "femur_m": float(np.linalg.norm(tibia.pos_m)),
            "tibia_m": float(np.linalg.norm(tarsus.pos_m)),
            "tarsus_m": float(np.linalg.norm(claw.pos_m)),
            "azimuth_rad": float(math.atan2(leg_x[1], leg_x[0])),
            "tilt_rad": float(-math.asin(np.clip(leg_x[2], -1.0, 1.0))),
            "thcz_axis_z": float(np.sign(thc.joint.axis[2])),
            "joints": tuple(f"{leg}_{j}" for j in LEG_JOINTS),
            "rest_rad": np.array([s.joint.rest_rad for s in (thc, coxa, femur, tibia, tarsus)]),
        }
    return geometry
