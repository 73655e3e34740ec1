"""BodySpec + World -> a MuJoCo model, built with MuJoCo's model-editing API (``mujoco.MjSpec``).

Nothing here is converted from URDF: every element comes straight from the backend-agnostic spec.

What the model contains
-----------------------
- One MuJoCo body per :class:`~neuronav.spec.body.Segment`, at its ``pos_m``/``quat`` in its parent, with an
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
- A site per spec site. Body cameras are not model cameras: the backend renders them from the mount
  segment's pose by the rules of :mod:`neuronav.senses.vision` (its own frustum per view).
- The world: a plane (flat, wall), a heightfield (uneven), a wall box, objects (a cone is a convex
  mesh), a sky box (:func:`sky_box`: the World's sky, :func:`neuronav.senses.vision.sky_rgb`, as PyBullet and the
  eyes paint it) and a floor (textured, a plain one too) coloured from :class:`~neuronav.spec.world.Appearance`,
  a light, and the physics options (timestep, integrator, solver). The ground plane is drawn out to
  :data:`neuronav.senses.vision.GROUND_REACH_M` (a plane collides everywhere; its size only bounds the
  drawing); around a heightfield a visual-only plane (group ``HORIZON_GROUP``) carries the ground on.
  The objects are geoms of one mocap body at the origin (``SCENE_BODY``), turned for the scene yaw.
- Odour trails (:mod:`neuronav.senses.trail_floor`): on a flat ground, a visual-only plane (``TRAIL_GEOM``,
  group ``HORIZON_GROUP``: drawn, never touched nor hit by rays) over the floor image's rectangle,
  ``TRAIL_LIFT_M`` above z = 0, its texture the image (one copy over the plane, row 0 at its +y
  edge, column 0 at its -x edge; checked by a test). Without trails nothing is added.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from dataclasses import dataclass, field  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from neuronav.engine.articulated import FOLLOW_SIZE_PX  # noqa: E402
from neuronav.errors import ConfigError  # noqa: E402
from neuronav.senses.trail_floor import TrailFloor, png_bytes, trail_floor  # noqa: E402
from neuronav.senses.vision import (  # noqa: E402
    CUBE_FACE_ROTATIONS,
    GROUND_REACH_M,
    check_camera,
    cube_face_px,
    sky_rgb,
    to_uint8,
)
from neuronav.spec.body import BodySpec, Segment  # noqa: E402
from neuronav.spec.world import World  # noqa: E402

GRAVITY_M_S2 = (0.0, 0.0, -9.81)
WALL_THICKNESS_M = 0.1
HFIELD_BASE_M = 0.1  # depth of the heightfield's solid base below z = 0
CONE_EDGES = 32
# Friction-to-normal impedance ratio in worlds with adhesion (see _options).
STICKY_IMPRATIO = 10.0
# The contact sensors of the contact geoms: their names' prefix, and MuJoCo's contact-sensor parameters for
# "data=force, reduce=netforce, num=1" (the net force in world axes, 3 values).
LOAD_SENSOR_PREFIX = "load/"
CONTACT_NETFORCE_INTPRM = (2, 3, 1)
# Contact bit masks: body geoms (1, 0) touch world geoms (1, 1) but never each other.
BODY_CONTYPE, BODY_CONAFFINITY = 1, 0
WORLD_CONTYPE, WORLD_CONAFFINITY = 1, 1
BODY_GROUP = 1  # world geoms stay in group 0, so rays and renders can tell them apart
SITE_GROUP = 4  # hidden in renders (MuJoCo shows groups 0-2 by default)
SCENE_BODY = "world/scene"  # the mocap body that carries the world's objects
HORIZON_GROUP = 3  # the visual-only ground around a heightfield: drawn, never hit by rays
HORIZON_DROP_M = 1e-3  # that plane sits just under z = 0, so the heightfield draws over it
# A plane is drawn as a grid of PLANE_QUADS x PLANE_QUADS quads per half side (its size[2] is the grid spacing):
# flat shading needs no finer grid, and a fine grid over GROUND_REACH_M costs milliseconds per render.
PLANE_QUADS = 4
GROUND_TEXEL_PX = 256  # the checker texture (2x2 squares): sharp in the lit, mipmapped follow view too
PLAIN_TEXEL_PX = 2  # a plain ground's one-colour texture
SKY_FACE_PX = 64  # the sky box's faces (the sky is a smooth gradient: MuJoCo filters it linearly)
# The world direction each face of a MuJoCo sky box's data faces, in the data's order (checked by a test), and
# (for the four side faces) their rows run from the top (z = +1) down.
SKY_FACE_AXES = ((1, 0, 0), (-1, 0, 0), (0, 0, 1), (0, 0, -1), (0, -1, 0), (0, 1, 0))
TRAIL_GEOM = "world/trails"  # the plane that shows the odour trails (neuronav.senses.trail_floor)
# The trail plane's height above the ground: over the ground plane in the depth buffer (a body camera
# 5 cm up resolves 1e-5 m at 20 m), under anything standing on the floor by no more than this.
TRAIL_LIFT_M = 1e-3

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
    """

    root: str
    free_joint: str | None
    joints: tuple[str, ...]
    geoms: dict = field(default_factory=dict)
    contact_geoms: tuple[tuple[str, ...], ...] = ()


def matrix_to_quat(matrix: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.asarray(matrix, float).ravel())
    return quat


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
    floor = trail_floor(world)
    _visual(spec, body, world)
    _world(spec, world)
    if floor is not None:
        _trails(spec, floor)
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


def to_xml(world: World, body: BodySpec, timestep_s: float = 0.002, asset_dir: str | None = None) -> str:
    """The model as MJCF text (for inspection or for loading in MuJoCo's viewer).

    MJCF cannot hold texture data: a world with odour trails needs ``asset_dir``, a folder where
    their floor image is written (``trails.png``), which the text names by its absolute path; the sky
    box is written as MuJoCo's gradient from the World's ``sky_rgb`` to its ``horizon_rgb``.
    """
    spec, _ = build_spec(world, body, timestep_s)
    # The sky box's data cannot be written either: MuJoCo's gradient between the World's zenith and horizon
    # colours stands for it (the same colours, at other elevations).
    look = world.appearance
    sky = next(t for t in spec.textures if t.name == "sky")
    sky.data, sky.nchannel, sky.width, sky.height = b"", 3, 256, 256
    sky.builtin, sky.rgb1 = mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, tuple(look.sky_rgb)
    sky.rgb2 = tuple(look.horizon_rgb if look.horizon_rgb is not None else look.sky_rgb)
    texture = next((t for t in spec.textures if t.name == "trails"), None)
    if texture is not None:
        if asset_dir is None:
            raise ConfigError("to_xml: this world draws odour trails on the floor; give asset_dir, a folder for "
                              "their texture (MJCF cannot hold texture data)")
        path = os.path.abspath(os.path.join(asset_dir, "trails.png"))
        with open(path, "wb") as handle:
            handle.write(png_bytes(trail_floor(world).image))
        texture.data = b""
        texture.file = path
        texture.content_type = "image/png"
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


def _visual(spec: mujoco.MjSpec, body: BodySpec, world: World) -> None:
    # One offscreen buffer holds the follow view, or all the views of one body camera side by side.
    widths, heights = [FOLLOW_SIZE_PX[0]], [FOLLOW_SIZE_PX[1]]
    for camera in body.cameras:
        check_camera(camera)
        if camera.projection == "spherical":  # room for all six faces side by side
            widths.append(cube_face_px(camera) * len(CUBE_FACE_ROTATIONS))
            heights.append(cube_face_px(camera))
        else:
            widths.append(camera.width_px * camera.supersample)
            heights.append(camera.height_px * camera.supersample)
    spec.visual.global_.offwidth = int(max(widths))
    spec.visual.global_.offheight = int(max(heights))
    spec.visual.headlight.ambient = (0.35, 0.35, 0.35)
    spec.visual.headlight.diffuse = (0.45, 0.45, 0.45)
    spec.visual.headlight.specular = (0.05, 0.05, 0.05)
    look = world.appearance
    # The World's sky (neuronav.senses.vision.sky_rgb), as PyBullet's follow view and every body camera paint it.
    sky = spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, width=SKY_FACE_PX,
                           height=6 * SKY_FACE_PX, nchannel=3)
    sky.data = sky_box(look, SKY_FACE_PX).tobytes()
    if look.ground_texture == "checker":
        # A checker texture of 2x2 squares. On a plane MuJoCo maps texrepeat r to one texture per
        # 2/r m, origin-aligned, with rgb2 on the square whose corner is at the origin (checked by a test):
        # r = 1/checker_m gives squares of checker_m, ground_rgb where floor(x/s) + floor(y/s) is even.
        spec.add_texture(name="sand", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                         rgb1=tuple(look.checker_rgb), rgb2=tuple(look.ground_rgb),
                         width=GROUND_TEXEL_PX, height=GROUND_TEXEL_PX)
        repeat = 1.0 / look.checker_m
        ground = spec.add_material(name="ground", texrepeat=(repeat, repeat), texuniform=True)
        ground.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "sand"
    else:
        # A plain ground is a one-colour texture too: a lit view clips each vertex's light to 1 before a texture
        # multiplies it, not before an untextured colour does; so the ground and the trails' floor image (a
        # texture, ground-coloured around the trails) show the same colour side by side (no darker rectangle).
        # MuJoCo truncates 255 * rgb1: the middle of the 8-bit step gives round(255 * ground_rgb), as to_uint8.
        spec.add_texture(name="sand", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
                         rgb1=tuple((to_uint8(look.ground_rgb) + 0.5) / 255.0), width=PLAIN_TEXEL_PX,
                         height=PLAIN_TEXEL_PX)
        ground = spec.add_material(name="ground", texrepeat=(1.0, 1.0), texuniform=True)
        ground.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "sand"
    spec.add_material(name="wall", rgba=(0.62, 0.55, 0.47, 1.0))


def sky_box(appearance, face_px: int) -> np.ndarray:
    """The sky of ``appearance`` as a MuJoCo sky box's data: uint8 (6 face_px, face_px, 3), its faces in
    :data:`SKY_FACE_AXES` order, each texel the colour of :func:`neuronav.senses.vision.sky_rgb` along the
    direction through its centre (the sky depends on the elevation only, so how MuJoCo turns a face about
    its axis does not matter)."""
    centres = (np.arange(face_px) + 0.5) / face_px * 2.0 - 1.0  # -1..1 across a face
    across, down = np.meshgrid(centres, centres)  # (row, column): down runs +1 at the bottom row
    faces = []
    for axis in SKY_FACE_AXES:
        if axis[2]:  # the top or bottom face: every texel at z = ±1 on the cube
            directions = np.stack([across, down, np.full_like(across, float(axis[2]))], axis=-1)
        else:  # a side face: z from +1 (row 0) down to -1
            directions = np.stack([np.ones_like(across), across, -down], axis=-1)
        directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
        faces.append(to_uint8(sky_rgb(appearance, directions)))
    return np.concatenate(faces, axis=0)


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
        # The ground goes on to the horizon around the heightfield, for the eyes only (no contacts, no rays).
        horizon_m = _plane_half_m(GROUND_REACH_M, world.appearance)
        worldbody.add_geom(name="world/horizon", type=mujoco.mjtGeom.mjGEOM_PLANE, pos=(0.0, 0.0, -HORIZON_DROP_M),
                           size=(horizon_m, horizon_m, horizon_m / PLANE_QUADS), material="ground",
                           contype=0, conaffinity=0, group=HORIZON_GROUP)
    else:
        # A plane collides everywhere; its size only bounds its drawing, out to GROUND_REACH_M for the eyes.
        reach = _plane_half_m(max(half, GROUND_REACH_M), world.appearance)
        worldbody.add_geom(name="world/ground", type=mujoco.mjtGeom.mjGEOM_PLANE,
                           size=(reach, reach, reach / PLANE_QUADS), material="ground", friction=friction,
                           contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY)
    if ground.kind == "wall":
        worldbody.add_geom(
            name="world/wall", type=mujoco.mjtGeom.mjGEOM_BOX,
            size=(WALL_THICKNESS_M / 2.0, half, ground.wall_height_m / 2.0),
            pos=(ground.wall_distance_m + WALL_THICKNESS_M / 2.0, 0.0, ground.wall_height_m / 2.0),
            material="wall", friction=friction, contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY)
    # The objects hang from one mocap body at the origin: turning it turns them all about the world z axis
    # (World's scene yaw), and their collisions follow (the world body's own geoms are indexed once, at compile).
    scene = worldbody.add_body(name=SCENE_BODY, mocap=True) if world.objects else None
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
            scene.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=size, **common)
        elif obj.shape == "cylinder":
            scene.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=(*size, 0.0), **common)
        elif obj.shape == "sphere":
            scene.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=(size[0], 0.0, 0.0), **common)
        else:
            # MuJoCo has no cone primitive: a convex mesh (apex + a 32-gon base) is exact up to the polygon.
            radius, half_height = size
            angles = np.linspace(0.0, 2.0 * np.pi, CONE_EDGES, endpoint=False)
            ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                                    np.full(CONE_EDGES, -half_height)])
            vertices = np.vstack([[0.0, 0.0, half_height], ring])
            spec.add_mesh(name=f"{name}/mesh", uservert=vertices.ravel().tolist())
            scene.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}/mesh", **common)


def _trails(spec: mujoco.MjSpec, floor: TrailFloor) -> None:
    """The floor image on a visual-only plane over its rectangle (one texture copy, not per metre)."""
    height, width = floor.shape_px
    # MuJoCo puts a 2D texture's row 0 at a plane's +y edge and column 0 at its -x edge: the image's own layout.
    texture = spec.add_texture(name="trails", type=mujoco.mjtTexture.mjTEXTURE_2D, width=width, height=height,
                               nchannel=3)
    texture.data = np.ascontiguousarray(floor.image).tobytes()
    material = spec.add_material(name="trails", texrepeat=(1.0, 1.0), texuniform=False)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "trails"
    half_x, half_y = floor.half_size_m
    spec.worldbody.add_geom(name=TRAIL_GEOM, type=mujoco.mjtGeom.mjGEOM_PLANE,
                            pos=(*floor.centre_m, TRAIL_LIFT_M), size=(half_x, half_y, max(half_x, half_y)),
                            material="trails", contype=0, conaffinity=0, group=HORIZON_GROUP)


def _plane_half_m(reach_m: float, appearance) -> float:
    """A plane's half size of at least ``reach_m``, a whole number of checker periods (2 checker_m).

    MuJoCo starts a plane's texture at its corner: a whole number of periods puts a square's corner
    at the origin.
    """
    period = 2.0 * appearance.checker_m
    return float(np.ceil(reach_m / period - 1e-9) * period)


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
    # A load sensor per contact geom: the net contact force on it, computed by MuJoCo in each step's
    # acceleration stage (the contact_load sensor reads it without another constraint solve).
    for geom_name in dict.fromkeys(name for names in contact_geoms for name in names):
        sensor = spec.add_sensor(name=f"{LOAD_SENSOR_PREFIX}{geom_name}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                                 objtype=mujoco.mjtObj.mjOBJ_GEOM, objname=geom_name)
        sensor.intprm = CONTACT_NETFORCE_INTPRM
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
                      contact_geoms=contact_geoms)


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
