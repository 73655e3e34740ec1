"""BodySpec + World -> a MuJoCo model, built with MuJoCo's model-editing API (``mujoco.MjSpec``).

Nothing here is converted from URDF: every element comes straight from the backend-agnostic spec.

What the model contains
-----------------------
- One MuJoCo body per :class:`~neuronav.body.Segment`, at its ``pos_m``/``quat`` in its parent, with an
  explicit inertial (mass, centre of mass, full inertia tensor from :meth:`Segment.inertial`) so the
  masses are exactly the spec's; ``inertiafromgeom`` is off. The root gets a free joint (or none when
  its joint is ``fixed``); every hinge gets its axis, range (limited), damping and armature.
- One actuator per hinge joint, in :attr:`BodySpec.joints` order, realising the project's position
  control law ``torque = clip(kp * (target - q) - kd * qdot, -max_torque, max_torque)``: a general
  actuator with gain ``kp``, affine bias ``(0, -kp, -kd)``, gear 1 and force range ``±max_torque_nm``;
  ``ctrl`` is the target angle. MuJoCo evaluates exactly that expression (tests check it against the
  formula) and, under the ``implicitfast`` integrator, integrates the ``-kd * qdot`` term implicitly,
  which keeps light distal segments with stiff gains stable at a 2 ms step.
- Body geoms collide with the world but not with each other (``contype`` 1, ``conaffinity`` 0): the
  legs may cross, as in PyBullet's default (no self-collision). ``body.notes["self_collision"] = True``
  turns self-collision on (MuJoCo still skips parent-child pairs).
- A site per spec site; a camera per planar spec camera (its horizontal and vertical FOV both honoured
  through MuJoCo's camera intrinsics); for a spherical camera, a cube of 90° cameras at the mount,
  from which the backend stitches an equirectangular panorama (:func:`panorama_lookup`).
- The world: a plane (flat, wall), a heightfield (uneven), a wall box, objects (a cone is a convex
  mesh), a sky box, a light, and the physics options (timestep, integrator, solver).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from dataclasses import dataclass, field  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from neuronav.articulated import FOLLOW_SIZE_PX  # noqa: E402
from neuronav.body import BodySpec, Camera, Segment, quat_to_matrix  # noqa: E402
from neuronav.errors import ConfigError  # noqa: E402
from neuronav.world import World  # noqa: E402

GRAVITY_M_S2 = (0.0, 0.0, -9.81)
WALL_THICKNESS_M = 0.1
HFIELD_BASE_M = 0.1  # depth of the heightfield's solid base below z = 0
CONE_EDGES = 32
# Friction-to-normal impedance ratio in worlds with adhesion (see _options).
STICKY_IMPRATIO = 10.0
# Contact bit masks: body geoms (1, 0) touch world geoms (1, 1) but never each other.
BODY_CONTYPE, BODY_CONAFFINITY = 1, 0
WORLD_CONTYPE, WORLD_CONAFFINITY = 1, 1
BODY_GROUP = 1  # world geoms stay in group 0, so rays and renders can tell them apart
SITE_GROUP = 4  # hidden in renders (MuJoCo shows groups 0-2 by default)

# Cube-map faces of a spherical camera: the rotation of each face camera in the mount camera's frame.
# Cameras look along their -z, so e.g. "left" turns -z onto -x (a +90° turn about +y).
_FACES = {
    "front": np.eye(3),
    "left": np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
    "back": np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]),
    "right": np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
    "up": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "down": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
}


@dataclass(frozen=True)
class Panorama:
    """How to stitch an equirectangular image from cube faces.

    Attributes
    ----------
    faces : tuple of str
        MuJoCo camera names of the faces actually seen, in the order of ``face_index``.
    face_px : int
        Side of each (square) face image.
    face_index, rows, cols : ndarray of int, shape (H, W)
        For each panorama pixel, which face and which face pixel it shows (nearest neighbour).
    """

    faces: tuple[str, ...]
    face_px: int
    face_index: np.ndarray
    rows: np.ndarray
    cols: np.ndarray


@dataclass(frozen=True)
class ModelNames:
    """Where each spec element went in the compiled model (MuJoCo names).

    Attributes
    ----------
    root : str
        The root segment's body.
    free_joint : str or None
        The root's free joint, None when the root is welded to the world.
    joints : tuple of str
        Hinge joints in :attr:`BodySpec.joints` order; the actuators carry the same names and order.
    geoms : dict
        ``(segment name, spec geom name or its index as str) -> MuJoCo geom name``.
    contact_geoms : tuple of tuple of str
        For each contact site (``sites_of_kind("contact")`` order), the geoms whose forces it reports.
    cameras : dict
        Planar camera name -> MuJoCo camera name.
    panoramas : dict
        Spherical camera name -> :class:`Panorama`.
    """

    root: str
    free_joint: str | None
    joints: tuple[str, ...]
    geoms: dict = field(default_factory=dict)
    contact_geoms: tuple[tuple[str, ...], ...] = ()
    cameras: dict = field(default_factory=dict)
    panoramas: dict = field(default_factory=dict)


def matrix_to_quat(matrix: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.asarray(matrix, float).ravel())
    return quat


def panorama_lookup(camera: Camera, face_px: int | None = None) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """Map each pixel of a spherical camera's image to a cube face pixel.

    The image is equirectangular in the camera's frame: column c looks at azimuth
    ``fov_h * (0.5 - (c + 0.5) / W)`` (positive to the left, 0 straight ahead along -z), row r at
    elevation ``fov_v * (0.5 - (r + 0.5) / H)`` (positive up, along +y).

    Returns
    -------
    face_px, face (H, W) index into ``_FACES`` order, row (H, W), col (H, W)
    """
    width, height = camera.width_px, camera.height_px
    fov_h, fov_v = camera.fov_rad
    if face_px is None:
        # Two face pixels per panorama pixel at the face centre, so nearest-neighbour sampling does not alias.
        pixel_rad = min(fov_h / width, fov_v / height)
        face_px = int(np.clip(np.ceil(2.0 * (np.pi / 2.0) / pixel_rad), 8, 1024))
    azimuth = fov_h * (0.5 - (np.arange(width) + 0.5) / width)
    elevation = fov_v * (0.5 - (np.arange(height) + 0.5) / height)
    az, el = np.meshgrid(azimuth, elevation)
    # Directions in the camera frame: forward -z, left -x, up +y.
    directions = np.stack([-np.cos(el) * np.sin(az), np.sin(el), -np.cos(el) * np.cos(az)], axis=-1)
    rotations = np.stack(list(_FACES.values()))  # (6, 3, 3), columns = face axes in the camera frame
    local = np.einsum("fji,hwj->hwfi", rotations, directions)  # each direction in each face's frame
    depth = -local[..., 2]  # how far along each face's viewing axis
    face = np.argmax(depth, axis=-1)
    chosen = np.take_along_axis(local, face[..., None, None], axis=2)[..., 0, :]
    forward = -chosen[..., 2]
    x, y = chosen[..., 0] / forward, chosen[..., 1] / forward  # in [-1, 1] on the face's image plane
    col = np.clip(((x + 1.0) / 2.0 * face_px).astype(int), 0, face_px - 1)
    row = np.clip(((1.0 - y) / 2.0 * face_px).astype(int), 0, face_px - 1)
    return face_px, face, row, col


def build_spec(world: World, body: BodySpec, timestep_s: float = 0.002) -> tuple[mujoco.MjSpec, ModelNames]:
    """Translate the world and the body into an (uncompiled) ``MjSpec``.

    Raises
    ------
    ConfigError
        When the body refers to an unknown geom, or a name clashes with the world's.
    """
    spec = mujoco.MjSpec()
    spec.modelname = body.name
    spec.compiler.degree = False  # every angle below is in radians (camera fovy stays in degrees)
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = True
    _options(spec, timestep_s, sticky=world.adhesion_n > 0)
    _visual(spec, body)
    _world(spec, world)
    names = _body(spec, body)
    return spec, names


def compile_model(world: World, body: BodySpec, timestep_s: float = 0.002) -> tuple[mujoco.MjModel, ModelNames]:
    """Build and compile the model; MuJoCo's compile errors come back as :class:`ConfigError`."""
    spec, names = build_spec(world, body, timestep_s)
    try:
        model = spec.compile()
    except ValueError as error:
        raise ConfigError(f"mujoco could not compile body {body.name!r}: {error}") from None
    return model, names


def to_xml(world: World, body: BodySpec, timestep_s: float = 0.002) -> str:
    """The model as MJCF text (for inspection or for loading in MuJoCo's viewer)."""
    spec, _ = build_spec(world, body, timestep_s)
    spec.compile()
    return spec.to_xml()


# -- parts -------------------------------------------------------------------------------------------
def _options(spec: mujoco.MjSpec, timestep_s: float, sticky: bool = False) -> None:
    option = spec.option
    option.timestep = timestep_s
    option.gravity = GRAVITY_M_S2
    # implicitfast: joint damping and the actuators' -kd*qdot are integrated implicitly (stable with
    # light distal segments at 2 ms), at the cost of one factorisation per step -- cheaper than RK4's four.
    option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC  # true Coulomb cone: claws slip like they should
    if sticky:
        # With adhesion the claws hold the body on a wall by friction alone. MuJoCo's soft friction
        # lets such a loaded contact creep (the ant standing on the wall at 120 N slid 3 cm/s);
        # impratio > 1 makes friction stiffer than the normal force and stops most of the creep.
        option.impratio = STICKY_IMPRATIO
    option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    option.iterations = 100
    option.ls_iterations = 50
    option.tolerance = 1e-10


def _visual(spec: mujoco.MjSpec, body: BodySpec) -> None:
    widths, heights = [FOLLOW_SIZE_PX[0]], [FOLLOW_SIZE_PX[1]]
    for camera in body.cameras:
        if camera.projection == "spherical":
            face_px = panorama_lookup(camera)[0]
            widths.append(face_px)
            heights.append(face_px)
        else:
            widths.append(camera.width_px)
            heights.append(camera.height_px)
    spec.visual.global_.offwidth = int(max(widths))
    spec.visual.global_.offheight = int(max(heights))
    spec.visual.headlight.ambient = (0.35, 0.35, 0.35)
    spec.visual.headlight.diffuse = (0.45, 0.45, 0.45)
    spec.visual.headlight.specular = (0.05, 0.05, 0.05)
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=(0.55, 0.72, 0.95), rgb2=(0.95, 0.97, 1.0), width=256, height=256)
    spec.add_texture(name="sand", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=(0.86, 0.76, 0.56), rgb2=(0.66, 0.57, 0.40), width=256, height=256)
    ground = spec.add_material(name="ground", texrepeat=(1.0, 1.0), texuniform=True)
    ground.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "sand"
    spec.add_material(name="wall", rgba=(0.62, 0.55, 0.47, 1.0))


def _world(spec: mujoco.MjSpec, world: World) -> None:
    ground = world.ground
    worldbody = spec.worldbody
    worldbody.add_light(name="world/sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=(0.0, 0.0, 10.0),
                        dir=(0.3, 0.2, -1.0), diffuse=(0.6, 0.6, 0.6), castshadow=False)
    friction = (ground.friction, 0.005, 0.0001)
    half = ground.size_m / 2.0
    heights = ground.heights_m()
    if ground.kind == "uneven" and heights.max() > 0:
        # MuJoCo's elevation data is row-major from -y to +y, columns from -x to +x (checked by a test),
        # the same layout as Ground.heights_m; it rescales the data to [0, 1] times size[2].
        top_m = float(heights.max())
        spec.add_hfield(name="terrain", nrow=ground.cells, ncol=ground.cells, size=(half, half, top_m, HFIELD_BASE_M),
                        userdata=(heights / top_m).ravel().tolist())
        worldbody.add_geom(name="world/ground", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                           material="ground", friction=friction, contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY)
    else:
        worldbody.add_geom(name="world/ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=(half, half, 0.5),
                           material="ground", friction=friction, contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY)
    if ground.kind == "wall":
        worldbody.add_geom(
            name="world/wall", type=mujoco.mjtGeom.mjGEOM_BOX,
            size=(WALL_THICKNESS_M / 2.0, half, ground.wall_height_m / 2.0),
            pos=(ground.wall_distance_m + WALL_THICKNESS_M / 2.0, 0.0, ground.wall_height_m / 2.0),
            material="wall", friction=friction, contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY)
    for index, obj in enumerate(world.objects):
        name = f"world/object{index}"
        common = dict(name=name, pos=tuple(obj.position_m), rgba=tuple(obj.rgba), friction=friction,
                      contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY)
        size = tuple(float(s) for s in obj.size_m)
        expected = {"box": 3, "cylinder": 2, "cone": 2, "sphere": 1}[obj.shape]
        if len(size) != expected or min(size) <= 0:
            raise ConfigError(f"world object {index} ({obj.shape}): size_m needs {expected} positive values, "
                              f"got {size}")
        if obj.shape == "box":
            worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=size, **common)
        elif obj.shape == "cylinder":
            worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=(*size, 0.0), **common)
        elif obj.shape == "sphere":
            worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=(size[0], 0.0, 0.0), **common)
        else:
            # MuJoCo has no cone primitive: a convex mesh (apex + a 32-gon base) is exact up to the polygon.
            radius, half_height = size
            angles = np.linspace(0.0, 2.0 * np.pi, CONE_EDGES, endpoint=False)
            ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                                    np.full(CONE_EDGES, -half_height)])
            vertices = np.vstack([[0.0, 0.0, half_height], ring])
            spec.add_mesh(name=f"{name}/mesh", uservert=vertices.ravel().tolist())
            worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}/mesh", **common)


_GEOM_TYPES = {
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "box": mujoco.mjtGeom.mjGEOM_BOX,
}


def _geom_key(segment: Segment, index: int) -> str:
    return segment.geoms[index].name or str(index)


def _body(spec: mujoco.MjSpec, body: BodySpec) -> ModelNames:
    bodies: dict[str, mujoco.MjsBody] = {}
    geoms: dict[tuple[str, str], str] = {}
    joints: list[str] = []
    free_joint = None
    # Self-collision only when the body asks for it (MuJoCo still skips parent-child pairs).
    conaffinity = 1 if body.notes.get("self_collision") is True else BODY_CONAFFINITY
    for segment in body.segments:
        parent = spec.worldbody if segment.parent is None else bodies[segment.parent]
        pos = segment.pos_m
        if segment.parent is None:
            pos = (0.0, 0.0, body.spawn_height_m)  # the backend's reset places the root
        mj_body = parent.add_body(name=segment.name, pos=pos, quat=segment.quat)
        bodies[segment.name] = mj_body
        com, inertia, _ = segment.inertial()
        mj_body.explicitinertial = True
        mj_body.mass = segment.mass_kg
        mj_body.ipos = com
        mj_body.fullinertia = (inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2])
        joint = segment.joint
        if segment.parent is None and (joint is None or joint.kind == "free"):
            free_joint = joint.name if joint is not None else f"{segment.name}/free"
            mj_body.add_freejoint(name=free_joint)
        elif joint is not None and joint.kind == "hinge":
            axis = np.asarray(joint.axis, float) / np.linalg.norm(joint.axis)
            mj_body.add_joint(name=joint.name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis, pos=(0.0, 0.0, 0.0),
                              range=joint.range_rad, limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                              damping=joint.damping, armature=joint.armature)
            joints.append(joint.name)
        for index, geom in enumerate(segment.geoms):
            key = (segment.name, _geom_key(segment, index))
            if key in geoms:
                raise ConfigError(f"body {body.name!r}, segment {segment.name!r}: geom name {key[1]!r} is used twice")
            name = f"{segment.name}/{key[1]}"
            geoms[key] = name
            size = tuple(float(s) for s in geom.size_m) + (0.0,) * (3 - len(geom.size_m))
            mj_body.add_geom(name=name, type=_GEOM_TYPES[geom.shape], size=size, pos=geom.pos_m, quat=geom.quat,
                             rgba=geom.rgba, friction=(geom.friction, 0.005, 0.0001),
                             contype=BODY_CONTYPE, conaffinity=conaffinity, group=BODY_GROUP)
    rgba = {"contact": (1.0, 0.2, 0.2, 1.0), "odour": (0.2, 0.8, 0.2, 1.0), "wind": (0.2, 0.4, 1.0, 1.0)}
    for site in body.sites:
        bodies[site.segment].add_site(name=site.name, pos=site.pos_m, size=(0.005, 0.005, 0.005), group=SITE_GROUP,
                                      rgba=rgba.get(site.kind, (0.8, 0.8, 0.8, 1.0)))
    contact_geoms = tuple(_contact_geoms(body, site, geoms) for site in body.sites_of_kind("contact"))
    cameras, panoramas = {}, {}
    for camera in body.cameras:
        mount = bodies[camera.segment]
        if camera.projection == "planar":
            _planar_camera(mount, camera)
            cameras[camera.name] = camera.name
        else:
            panoramas[camera.name] = _spherical_camera(mount, camera)
    # Actuators in BodySpec.joints order, named after their joints (MuJoCo numbers them in this order).
    for joint in body.joints:
        actuator = spec.add_actuator(name=joint.name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.gear = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        gain = np.zeros(10)
        bias = np.zeros(10)
        if joint.max_torque_nm > 0:
            gain[0] = joint.kp
            bias[1], bias[2] = -joint.kp, -joint.kd
            actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            actuator.forcerange = (-joint.max_torque_nm, joint.max_torque_nm)
        actuator.gainprm = gain
        actuator.biasprm = bias
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    return ModelNames(root=body.root.name, free_joint=free_joint, joints=tuple(joints), geoms=geoms,
                      contact_geoms=contact_geoms, cameras=cameras, panoramas=panoramas)


def _contact_geoms(body: BodySpec, site, geoms: dict) -> tuple[str, ...]:
    """The geoms a contact site reports: its named geom (on its own segment first), else its segment's."""
    segment = body.segment(site.segment)
    if not site.geom:
        return tuple(geoms[(segment.name, _geom_key(segment, i))] for i in range(len(segment.geoms)))
    if (segment.name, site.geom) in geoms:
        return (geoms[(segment.name, site.geom)],)
    matches = [name for (seg, key), name in geoms.items() if key == site.geom]
    if len(matches) != 1:
        known = sorted(key for seg, key in geoms if seg == segment.name)
        raise ConfigError(f"body {body.name!r}, contact site {site.name!r}: geom {site.geom!r} is not on segment "
                          f"{segment.name!r} (its geoms: {', '.join(known)}) nor unique elsewhere")
    return (matches[0],)


def _planar_camera(mount: mujoco.MjsBody, camera: Camera) -> None:
    fov_h, fov_v = camera.fov_rad
    if not (0 < fov_h < np.pi and 0 < fov_v < np.pi):
        raise ConfigError(f"camera {camera.name!r}: a planar camera's fov_rad must lie in (0, pi), "
                          f"got {camera.fov_rad}")
    cam = mount.add_camera(name=camera.name, pos=camera.pos_m, quat=camera.quat, fovy=float(np.degrees(fov_v)))
    # Intrinsics let the horizontal and vertical FOV differ from the image's aspect ratio (e.g. 74x19 at
    # 2 x 0.5 rad): a unit focal length and a sensor of 2 tan(fov / 2) on each axis.
    cam.sensor_size = (2.0 * np.tan(fov_h / 2.0), 2.0 * np.tan(fov_v / 2.0))
    cam.focal_length = (1.0, 1.0)
    cam.resolution = (camera.width_px, camera.height_px)


def _spherical_camera(mount: mujoco.MjsBody, camera: Camera) -> Panorama:
    fov_h, fov_v = camera.fov_rad
    if not (0 < fov_h <= 2 * np.pi + 1e-9 and 0 < fov_v <= np.pi + 1e-9):
        raise ConfigError(f"camera {camera.name!r}: a spherical camera's fov_rad must lie in (0, 2 pi] x (0, pi], "
                          f"got {camera.fov_rad}")
    face_px, face, rows, cols = panorama_lookup(camera)
    mount_matrix = quat_to_matrix(camera.quat)
    used = sorted(set(face.ravel().tolist()))
    face_names = []
    labels = list(_FACES)
    for index in used:
        name = f"{camera.name}/{labels[index]}"
        quat = matrix_to_quat(mount_matrix @ _FACES[labels[index]])
        mount.add_camera(name=name, pos=camera.pos_m, quat=quat, fovy=90.0)
        face_names.append(name)
    remap = np.full(len(_FACES), -1)
    remap[used] = np.arange(len(used))
    return Panorama(tuple(face_names), face_px, remap[face], rows, cols)
