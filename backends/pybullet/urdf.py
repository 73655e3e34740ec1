"""BodySpec -> URDF text for PyBullet, generated from the spec (never converted from MJCF).

Each :class:`~neuronav.spec.body.Segment` becomes a link whose frame is the segment frame; the joint to
its parent sits at the segment's ``pos_m`` / ``quat`` (URDF joint origin, rpy from the quaternion).
Hinges become ``revolute`` joints (axis, limits, effort = ``max_torque_nm``, damping); segments
without a joint, or with a ``fixed`` one, are welded to their parent. The root link is the base:
free-floating unless its joint is ``fixed``.

Contact geoms get a link of their own. A contact site reports the force on one geom (a claw);
PyBullet reports contacts per link, not per collision shape, so a contact geom that shares its
segment with other geoms is split off into a child link welded at the geom's pose (a ``fixed``
joint named ``<segment>__<geom>``). The segment's mass is shared between the two links by geom
volume exactly as :meth:`Segment.inertial` shares it, so together they are the same rigid body
(same mass, centre of mass and inertia tensor).

Joint armature (rotor inertia), which URDF and PyBullet lack, is by default added to the segment
link's inertia about the joint axis (see :func:`body_to_urdf`).

Geometry: capsules use PyBullet's ``<capsule radius length>`` extension (length = the cylinder part,
2 * half_length, as for ``<cylinder>``); capsules and cylinders lie along the link's local z, as in
the spec. Friction is a per-link property in PyBullet: a link gets the largest ``friction`` of its
geoms.
"""

from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from neuronav.errors import ConfigError
from neuronav.spec.body import BodySpec, Geom, Segment, quat_to_matrix

# PyBullet clamps every joint velocity at 100 rad/s anyway; the URDF limit only needs to be above it.
JOINT_VELOCITY_LIMIT_RAD_S = 100.0


@dataclass(frozen=True)
class UrdfLink:
    """One URDF link and what it holds.

    Attributes
    ----------
    name : str
        Link name in the URDF (unique).
    segment : str
        The spec segment it belongs to (a split-off contact geom belongs to its segment too).
    geoms : tuple of int
        Indices into ``segment.geoms`` of the geoms this link carries.
    mass_kg : float
    com_m : ndarray, shape (3,)
        Centre of mass in the link frame.
    inertia : ndarray, shape (3, 3)
        Inertia tensor about the centre of mass, in the link frame (kg m²).
    pos_m, quat : tuple
        Pose of the link frame in its segment's frame (identity for a segment's own link).
    """

    name: str
    segment: str
    geoms: tuple[int, ...]
    mass_kg: float
    com_m: np.ndarray
    inertia: np.ndarray
    pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Urdf:
    """Generated URDF text and the map from spec parts to links.

    Attributes
    ----------
    text : str
        The URDF document.
    links : tuple of UrdfLink
        In document order; ``links[0]`` is the base (the root segment).
    segment_link : dict
        Segment name -> the link whose frame is the segment frame.
    geom_link : dict
        (segment name, geom index) -> the link carrying that geom.
    fixed_base : bool
        True when the root segment's joint is ``fixed`` (welded to the world).
    """

    text: str
    links: tuple[UrdfLink, ...]
    segment_link: dict[str, str]
    geom_link: dict[tuple[str, int], str]
    fixed_base: bool

    def link(self, name: str) -> UrdfLink:
        for link in self.links:
            if link.name == name:
                return link
        raise ConfigError(f"URDF has no link {name!r}; links: {', '.join(li.name for li in self.links)}")


def find_geom(body: BodySpec, segment: str, geom_name: str) -> tuple[str, int]:
    """(segment name, geom index) of the geom called ``geom_name``, looked up first in ``segment``.

    Raises
    ------
    ConfigError
        When no geom of that name exists in the body.
    """
    ordered = [body.segment(segment)] + [s for s in body.segments if s.name != segment]
    for seg in ordered:
        for index, geom in enumerate(seg.geoms):
            if geom.name == geom_name:
                return seg.name, index
    known = sorted({g.name for s in body.segments for g in s.geoms if g.name})
    raise ConfigError(f"body {body.name!r}: no geom named {geom_name!r} (for segment {segment!r}); "
                      f"named geoms: {', '.join(known) or 'none'}")


def contact_geoms(body: BodySpec) -> list[tuple[str, int]]:
    """(segment, geom index) of every geom a contact site reports, in site order, without repeats."""
    found: list[tuple[str, int]] = []
    for site in body.sites_of_kind("contact"):
        if site.geom:
            key = find_geom(body, site.segment, site.geom)
            if key not in found:
                found.append(key)
    return found


def subset_inertial(segment: Segment, indices) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass (3,), inertia (3, 3) about it) of some of a segment's geoms, segment frame.

    Uses the per-geom masses of :meth:`Segment.inertial` and the same formulas, so the subsets of a
    partition add up to the segment's own mass and inertia.
    """
    _, _, masses = segment.inertial()
    indices = list(indices)
    if len(indices) == len(segment.geoms):
        com, inertia, _ = segment.inertial()
        return float(segment.mass_kg), com, inertia
    sub_masses = masses[indices]
    mass = float(sub_masses.sum())
    centres = np.array([segment.geoms[i].pos_m for i in indices], float)
    com = (sub_masses[:, None] * centres).sum(axis=0) / mass
    inertia = np.zeros((3, 3))
    for i, m, centre in zip(indices, sub_masses, centres):
        geom = segment.geoms[i]
        rotation = quat_to_matrix(geom.quat)
        inertia += rotation @ np.diag(geom.local_inertia(m)) @ rotation.T
        offset = centre - com
        inertia += m * (offset @ offset * np.eye(3) - np.outer(offset, offset))
    return mass, com, inertia


def quat_to_rpy(quat) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (fixed axes x, then y, then z) of a unit quaternion (w, x, y, z)."""
    r = quat_to_matrix(np.asarray(quat, float) / np.linalg.norm(quat))
    pitch = float(np.arcsin(np.clip(-r[2, 0], -1.0, 1.0)))
    if abs(r[2, 0]) < 1.0 - 1e-12:
        roll = float(np.arctan2(r[2, 1], r[2, 2]))
        yaw = float(np.arctan2(r[1, 0], r[0, 0]))
    else:  # gimbal lock: only roll ± yaw is defined; put it all in yaw
        roll = 0.0
        yaw = float(np.arctan2(-r[0, 1], r[1, 1]))
    return roll, pitch, yaw


def _num(value: float) -> str:
    # repr keeps every digit, so the engine gets exactly the spec's numbers.
    return repr(float(value))


def _vec(values) -> str:
    return " ".join(_num(v) for v in values)


def _origin(pos, quat) -> str:
    return f'<origin xyz="{_vec(pos)}" rpy="{_vec(quat_to_rpy(quat))}"/>'


def _geometry(geom: Geom) -> str:
    if geom.shape == "sphere":
        return f'<sphere radius="{_num(geom.size_m[0])}"/>'
    if geom.shape == "box":
        return f'<box size="{_vec(2.0 * np.asarray(geom.size_m))}"/>'
    radius, half = geom.size_m
    return f'<{geom.shape} radius="{_num(radius)}" length="{_num(2.0 * half)}"/>'


def _pose_in(link_pos, link_quat, geom: Geom) -> tuple[np.ndarray, np.ndarray]:
    """A geom's pose (segment frame) expressed in a link frame placed at link_pos/link_quat."""
    rotation = quat_to_matrix(link_quat)
    pos = rotation.T @ (np.asarray(geom.pos_m, float) - np.asarray(link_pos, float))
    rot = rotation.T @ quat_to_matrix(geom.quat)
    return pos, rot


def _matrix_quat(rot: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    return float(w), float(x), float(y), float(z)


def _link_xml(link: UrdfLink, segment: Segment) -> str:
    lines = [f"  <link name={quoteattr(link.name)}>"]
    inertia = link.inertia
    lines.append(
        f'    <inertial><origin xyz="{_vec(link.com_m)}" rpy="0 0 0"/><mass value="{_num(link.mass_kg)}"/>'
        f'<inertia ixx="{_num(inertia[0, 0])}" ixy="{_num(inertia[0, 1])}" ixz="{_num(inertia[0, 2])}" '
        f'iyy="{_num(inertia[1, 1])}" iyz="{_num(inertia[1, 2])}" izz="{_num(inertia[2, 2])}"/></inertial>'
    )
    for k, index in enumerate(link.geoms):
        geom = segment.geoms[index]
        pos, rot = _pose_in(link.pos_m, link.quat, geom)
        origin = _origin(pos, _matrix_quat(rot))
        rgba = _vec(geom.rgba)
        lines.append(f"    <collision>{origin}<geometry>{_geometry(geom)}</geometry></collision>")
        lines.append(f"    <visual>{origin}<geometry>{_geometry(geom)}</geometry>"
                     f"<material name={quoteattr(f'{link.name}_m{k}')}><color rgba=\"{rgba}\"/></material></visual>")
    friction = max(segment.geoms[i].friction for i in link.geoms)
    lines.append(f'    <contact><lateral_friction value="{_num(friction)}"/>'
                 '<rolling_friction value="0.0"/><spinning_friction value="0.0"/></contact>')
    lines.append("  </link>")
    return "\n".join(lines)


def body_to_urdf(body: BodySpec, armature_as_inertia: bool = True) -> Urdf:
    """Generate the URDF of ``body`` (see the module docstring for the mapping).

    Parameters
    ----------
    body : BodySpec
    armature_as_inertia : bool
        PyBullet has no joint armature (rotor inertia). When True, a hinge's ``armature`` A is added
        to its segment link's inertia as a thin rotor disc on the joint axis u,
        ``A (u uᵀ + (I - u uᵀ) / 2)`` (armature alone would break the triangle inequality, and
        PyBullet zeroes such tensors): the joint feels A as in MuJoCo, but parent joints and the
        body as a whole feel the disc too. When False armature is ignored.

    Raises
    ------
    ConfigError
        For a joint URDF cannot express here: a hinge on the root, or a free joint below it.
    """
    _check_joints(body)
    split = set(contact_geoms(body))
    used = {s.name for s in body.segments}
    links: list[UrdfLink] = []
    joints_xml: list[str] = []
    geom_link: dict[tuple[str, int], str] = {}

    def unique(name: str) -> str:
        candidate, k = name, 1
        while candidate in used:
            candidate, k = f"{name}_{k}", k + 1
        used.add(candidate)
        return candidate

    for segment in body.segments:
        own = [i for i in range(len(segment.geoms)) if (segment.name, i) not in split]
        separate = [i for i in range(len(segment.geoms)) if (segment.name, i) in split]
        if not own:  # the segment is only its contact geom(s): keep the first in the segment's link
            own, separate = separate[:1], separate[1:]
        links.append(_segment_link(segment, own, armature_as_inertia))
        geom_link.update({(segment.name, i): segment.name for i in own})
        if segment.parent is not None:
            joints_xml.append(_joint_xml(segment))
        for i in separate:
            link, joint_xml = _geom_link(segment, i, unique(f"{segment.name}__{segment.geoms[i].name}"))
            links.append(link)
            joints_xml.append(joint_xml)
            geom_link[(segment.name, i)] = link.name
    text = "\n".join([
        '<?xml version="1.0"?>',
        f"<!-- generated by neuronav.backends.pybullet.urdf from BodySpec {body.name!r} -->",
        f"<robot name={quoteattr(body.name)}>",
        *(_link_xml(link, body.segment(link.segment)) for link in links),
        *joints_xml,
        "</robot>",
        "",
    ])
    fixed_base = body.root.joint is not None and body.root.joint.kind == "fixed"
    segment_link = {segment.name: segment.name for segment in body.segments}
    return Urdf(text, tuple(links), segment_link, geom_link, fixed_base)


def _check_joints(body: BodySpec) -> None:
    """Refuse the joints URDF cannot express here: a hinge on the root, a free joint below it."""
    root = body.root
    if root.joint is not None and root.joint.kind == "hinge":
        raise ConfigError(f"body {body.name!r}: the root segment {root.name!r} cannot have a hinge joint "
                          "in URDF; allowed root joints: none or free (floating base), fixed (welded to the world)")
    for segment in body.segments[1:]:
        if segment.joint is not None and segment.joint.kind == "free":
            raise ConfigError(f"body {body.name!r}, segment {segment.name!r}: a free joint is only allowed on "
                              "the root; use hinge or fixed")


def _segment_link(segment: Segment, geoms: list[int], armature_as_inertia: bool) -> UrdfLink:
    """The segment's own link: its ``geoms``, their mass and inertia (plus the armature's rotor disc)."""
    mass, com, inertia = subset_inertial(segment, geoms)
    joint = segment.joint
    if armature_as_inertia and joint is not None and joint.kind == "hinge" and joint.armature > 0:
        axis = np.asarray(joint.axis, float) / np.linalg.norm(joint.axis)
        # A thin rotor disc: the armature about the axis, half of it across (PyBullet rejects an
        # inertia tensor that breaks the triangle inequality, which armature alone would).
        inertia = inertia + joint.armature * (0.5 * np.eye(3) + 0.5 * np.outer(axis, axis))
    return UrdfLink(segment.name, segment.name, tuple(geoms), mass, com, inertia)


def _geom_link(segment: Segment, index: int, name: str) -> tuple[UrdfLink, str]:
    """A contact geom's own link ``name``, fixed to its segment's link, and that fixed joint's XML."""
    geom = segment.geoms[index]
    mass, com, inertia = subset_inertial(segment, [index])
    # In its own link the geom sits at the link origin: the link frame is the geom frame.
    rotation = quat_to_matrix(geom.quat)
    link = UrdfLink(name, segment.name, (index,), mass, rotation.T @ (com - np.asarray(geom.pos_m)),
                    rotation.T @ inertia @ rotation, tuple(geom.pos_m), tuple(geom.quat))
    joint_xml = (f"  <joint name={quoteattr(name)} type=\"fixed\"><parent link={quoteattr(segment.name)}/>"
                 f"<child link={quoteattr(name)}/>{_origin(geom.pos_m, geom.quat)}</joint>")
    return link, joint_xml


def _joint_xml(segment: Segment) -> str:
    joint = segment.joint
    parent = quoteattr(segment.parent)
    child = quoteattr(segment.name)
    origin = _origin(segment.pos_m, segment.quat)
    if joint is None or joint.kind == "fixed":
        name = joint.name if joint is not None else f"{segment.name}__weld"
        return (f"  <joint name={quoteattr(name)} type=\"fixed\"><parent link={parent}/><child link={child}/>"
                f"{origin}</joint>")
    axis = np.asarray(joint.axis, float)
    axis = axis / np.linalg.norm(axis)
    low, high = joint.range_rad
    return (
        f"  <joint name={quoteattr(joint.name)} type=\"revolute\"><parent link={parent}/><child link={child}/>"
        f"{origin}<axis xyz=\"{_vec(axis)}\"/>"
        f"<limit lower=\"{_num(low)}\" upper=\"{_num(high)}\" effort=\"{_num(joint.max_torque_nm)}\" "
        f"velocity=\"{_num(JOINT_VELOCITY_LIMIT_RAD_S)}\"/>"
        f"<dynamics damping=\"{_num(joint.damping)}\" friction=\"0.0\"/></joint>"
    )
