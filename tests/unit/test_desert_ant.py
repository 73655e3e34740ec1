"""The desert-ant body spec: joints, masses, sites, cameras, parameters and the standing posture."""

import dataclasses
import math

import numpy as np
import pytest

from neuronav.bodies.desert_ant import LEG_JOINTS, LEGS, desert_ant, leg_geometry
from neuronav.bodies.gaits import foot_position, segment_pose
from neuronav.errors import ConfigError
from neuronav.spec.body import quat_to_matrix

EXPECTED_JOINTS = (
    [f"{leg}_{j}" for leg in LEGS for j in LEG_JOINTS]
    + ["head_pitch", "head_yaw", "abdomen_pitch", "abdomen_yaw"]
    + [f"antenna_{s}_{j}" for s in "LR" for j in ("pitch", "yaw", "elbow")]
)


@pytest.fixture(scope="module")
def ant():
    return desert_ant()


def leg_mass(body, leg):
    return sum(s.mass_kg for s in body.segments if s.name.startswith(f"{leg}_"))


def claws(body, angles=None):
    angles = body.rest_pose_rad() if angles is None else angles
    return np.array([foot_position(body, leg, angles) for leg in LEGS])


def test_forty_hinge_joints_with_the_expected_names(ant):
    assert ant.joint_names == EXPECTED_JOINTS
    assert all(j.kind == "hinge" for j in ant.joints)
    assert ant.root.name == "thorax" and ant.root.joint is None


def test_rest_pose_is_the_published_one(ant):
    rest = dict(zip(ant.joint_names, ant.rest_pose_rad()))
    published = {"F": (0, 0, -0.32, 1.56, -0.2), "M": (0, 0, -0.385, 1.388, -0.2), "H": (0, 0, -0.778, 1.807, -0.2)}
    for leg in LEGS:
        assert [rest[f"{leg}_{j}"] for j in LEG_JOINTS] == pytest.approx(published[leg[0]])
    assert rest["head_pitch"] == -0.2 and rest["abdomen_pitch"] == 0.5


def test_masses(ant):
    assert ant.total_mass_kg == pytest.approx(12.0, rel=0.05)
    assert ant.segment("thorax").mass_kg == pytest.approx(2.9)
    assert ant.segment("neck").mass_kg + ant.segment("head").mass_kg == pytest.approx(2.7)
    assert ant.segment("waist").mass_kg + ant.segment("gaster").mass_kg == pytest.approx(4.2)
    for leg, mass in (("FL", 0.27), ("ML", 0.37), ("HL", 0.52), ("FR", 0.27), ("MR", 0.37), ("HR", 0.52)):
        assert leg_mass(ant, leg) == pytest.approx(mass)
    # Spread by volume: the femur (thickest, long) outweighs the thin tarsus.
    assert ant.segment("HL_femur").mass_kg > ant.segment("HL_tarsus").mass_kg


def test_hind_legs_are_longest(ant):
    geometry = leg_geometry(ant)
    length = {leg: sum(geometry[leg][k] for k in ("coxa_m", "femur_m", "tibia_m", "tarsus_m")) for leg in LEGS}
    assert length["HL"] > length["ML"] > length["FL"]
    assert geometry["HL"]["femur_m"] == pytest.approx(0.368) and geometry["FL"]["tarsus_m"] == pytest.approx(0.216)
    assert np.allclose(geometry["ML"]["anchor_m"], (-0.34, 0.02, -0.02))
    assert np.allclose(geometry["MR"]["anchor_m"], (-0.34, -0.02, -0.02))


def test_standing_posture_claws_level_and_spawn_height(ant):
    feet = claws(ant)
    claw_radius = ant.segment("FL_tarsus").geoms[-1].size_m[0]
    assert claw_radius == pytest.approx(0.0095)
    # All six claws on one level, touching a floor spawn_height_m below the root; body ≈ 0.43 m up.
    assert np.ptp(feet[:, 2]) < 1e-9
    assert feet[:, 2] == pytest.approx(-(ant.spawn_height_m - claw_radius))
    assert ant.spawn_height_m == pytest.approx(0.43, abs=0.01)
    # Legs spread: left claws at +y, right at -y, mirror images; front ahead of hind.
    left, right = feet[:3], feet[3:]
    assert np.all(left[:, 1] > 0.2) and np.allclose(right * (1, -1, 1), left)
    assert feet[0, 0] > feet[1, 0] > feet[2, 0]
    # The centre of mass lies over the support polygon's interior (behind the front, ahead of the hind claws).
    rest = dict(zip(ant.joint_names, ant.rest_pose_rad()))
    com_x = 0.0
    for segment in ant.segments:
        rotation, origin = segment_pose(ant, segment.name, rest)
        com_x += segment.mass_kg * (origin + rotation @ segment.inertial()[0])[0] / ant.total_mass_kg
    assert feet[2, 0] < com_x < feet[0, 0]


@pytest.mark.parametrize("leg", LEGS)
def test_joint_signs_mean_the_same_on_both_sides(ant, leg):
    geometry = leg_geometry(ant)[leg]
    rest = geometry["rest_rad"]
    base = foot_position(ant, leg, rest)
    reach = np.linalg.norm((base - geometry["anchor_m"])[:2])

    def moved(index, delta, index2=None, delta2=0.0):
        angles = rest.copy()
        angles[index] += delta
        if index2 is not None:
            angles[index2] += delta2
        return foot_position(ant, leg, angles) - base

    assert moved(0, 0.1)[0] > 0.01  # ThCz + swings the foot forward
    assert moved(1, 0.1)[2] > 0.01  # ThCx + raises the leg
    assert moved(2, -0.1)[2] > 0.01  # CTr − raises the femur, so the foot
    folded = base + moved(3, 0.1)  # FTi + folds the tibia under: the foot comes in toward the body
    assert np.linalg.norm((folded - geometry["anchor_m"])[:2]) < reach - 0.01
    lifted = moved(2, -0.1, 3, 0.1)  # the FK gait's lift (CTr −, FTi +) raises the foot
    assert lifted[2] > 0.01


def test_scale_multiplies_lengths_and_masses_cubed(ant):
    big = desert_ant(scale=2.0)
    assert big.total_mass_kg == pytest.approx(8 * ant.total_mass_kg)
    assert big.segment("HL_femur").mass_kg == pytest.approx(8 * ant.segment("HL_femur").mass_kg)
    assert big.spawn_height_m == pytest.approx(2 * ant.spawn_height_m)
    g1, g2 = leg_geometry(ant), leg_geometry(big)
    for leg in LEGS:
        for key in ("coxa_m", "femur_m", "tibia_m", "tarsus_m"):
            assert g2[leg][key] == pytest.approx(2 * g1[leg][key])
        assert np.allclose(g2[leg]["anchor_m"], 2 * g1[leg]["anchor_m"])
    assert big.segment("head").geoms[0].size_m[0] == pytest.approx(2 * ant.segment("head").geoms[0].size_m[0])
    assert np.allclose(claws(big), 2 * claws(ant))


def test_leg_length_factors_change_the_leg_and_keep_it_standing(ant):
    longer = desert_ant(leg_length_factors={"HL": 1.2, "HR": 1.2})
    g0, g1 = leg_geometry(ant), leg_geometry(longer)
    assert g1["HL"]["tibia_m"] == pytest.approx(1.2 * g0["HL"]["tibia_m"])
    assert g1["FL"]["tibia_m"] == pytest.approx(g0["FL"]["tibia_m"])
    assert leg_mass(longer, "HL") > leg_mass(ant, "HL")  # same thickness, more volume
    assert longer.spawn_height_m > ant.spawn_height_m
    feet = claws(longer)
    assert np.ptp(feet[:, 2]) < 1e-9 and feet[0, 2] == pytest.approx(-(longer.spawn_height_m - 0.0095))
    uniform = desert_ant(leg_length_factors=0.9)
    assert leg_geometry(uniform)["ML"]["femur_m"] == pytest.approx(0.9 * 0.295)


def test_antenna_length_and_mass_overrides(ant):
    body = desert_ant(antenna_length_m=0.8, masses_kg={"head": 3.0, "hind_leg": 0.6})
    scape = body.segment("antenna_L_funiculus").pos_m[0]
    tip = next(s for s in body.sites if s.name == "antenna_L_tip").pos_m[0]
    assert scape + tip == pytest.approx(0.8)
    assert scape / tip == pytest.approx(0.224 / 0.317)
    assert body.segment("neck").mass_kg + body.segment("head").mass_kg == pytest.approx(3.0)
    assert leg_mass(body, "HR") == pytest.approx(0.6)


def test_antenna_rest_yaw_sets_the_joints_and_brings_the_odour_sites_together():
    """The rest yaw is each antenna's yaw joint rest angle, mirrored; the odour sites at rest sit
    0.43 m apart at the default 0.6 rad, 0.23 m at 0.25 rad (docs of ``desert_ant``)."""
    from neuronav.bodies.antennae import point_antennae

    def spacing_m(body):
        left, right = point_antennae(body)
        return left.tip_m[1] - right.tip_m[1]

    narrow = desert_ant(antenna_yaw_rad=0.25)
    rest = dict(zip(narrow.joint_names, narrow.rest_pose_rad()))
    assert rest["antenna_L_yaw"] == pytest.approx(0.25) and rest["antenna_R_yaw"] == pytest.approx(-0.25)
    assert spacing_m(desert_ant()) == pytest.approx(0.43, abs=0.005)
    assert spacing_m(narrow) == pytest.approx(0.23, abs=0.01)


@pytest.mark.parametrize("kwargs, fragment", [
    ({"antenna_yaw_rad": 1.2}, "antenna_yaw_rad"),
    ({"antenna_yaw_rad": "wide"}, "antenna_yaw_rad"),
    ({"scale": 0}, "scale"),
    ({"scale": -1.0}, "scale"),
    ({"antenna_length_m": -0.5}, "antenna_length_m"),
    ({"leg_length_factors": {"FL": -1.0}}, "leg_length_factors"),
    ({"leg_length_factors": {"XX": 1.1}}, "'XX'"),
    ({"leg_length_factors": 0.0}, "leg_length_factors"),
    ({"masses_kg": {"wings": 1.0}}, "'wings'"),
    ({"masses_kg": {"head": -2.0}}, "head"),
    ({"standing_height_m": float("nan")}, "standing_height_m"),
])
def test_bad_parameters_raise_config_error_naming_them(kwargs, fragment):
    with pytest.raises(ConfigError, match=fragment):
        desert_ant(**kwargs)


def test_hand_broken_specs_are_rejected(ant):
    segments = list(ant.segments)
    index = next(i for i, s in enumerate(segments) if s.name == "FL_femur")
    orphan = dataclasses.replace(segments[index], parent="no_such_segment")
    with pytest.raises(ConfigError, match="unknown parent 'no_such_segment'"):
        dataclasses.replace(ant, segments=tuple(segments[:index] + [orphan] + segments[index + 1:]))
    reversed_joint = dataclasses.replace(segments[index].joint, range_rad=(1.9, -1.9))
    broken = dataclasses.replace(segments[index], joint=reversed_joint)
    with pytest.raises(ConfigError, match="reversed"):
        dataclasses.replace(ant, segments=tuple(segments[:index] + [broken] + segments[index + 1:]))
    negative = dataclasses.replace(segments[index].geoms[0], size_m=(-0.01, 0.1))
    with pytest.raises(ConfigError, match="positive"):
        dataclasses.replace(ant, segments=tuple(segments[:index] + [dataclasses.replace(segments[index],
                                                geoms=(negative,))] + segments[index + 1:]))


def test_sites(ant):
    contact = ant.sites_of_kind("contact")
    assert [s.name for s in contact] == [f"{leg}_claw" for leg in LEGS] + ["antenna_L_tip", "antenna_R_tip"]
    geom_names = [g.name for s in ant.segments for g in s.geoms]
    assert len(geom_names) == len(set(geom_names)), "geom names must be unique"
    for site in contact:
        geom = next(g for g in ant.segment(site.segment).geoms if g.name == site.geom)
        assert geom.shape == "sphere" and np.allclose(geom.pos_m, site.pos_m)
    for kind in ("odour", "wind"):
        sites = ant.sites_of_kind(kind)
        assert [s.segment for s in sites] == ["antenna_L_funiculus", "antenna_R_funiculus"]
        tip = next(s for s in contact if s.segment == sites[0].segment).pos_m[0]
        assert 0.9 * tip < sites[0].pos_m[0] <= tip  # near the end of the funiculus
    # At rest the antenna tips are ahead of the head, spread to either side, clear of the floor.
    rest = dict(zip(ant.joint_names, ant.rest_pose_rad()))
    for site, sign in zip(ant.sites_of_kind("odour"), (1, -1)):
        rotation, origin = segment_pose(ant, site.segment, rest)
        point = origin + rotation @ np.asarray(site.pos_m)
        assert point[0] > 0.2 and sign * point[1] > 0.1 and -ant.spawn_height_m + 0.05 < point[2] < 0


def test_cameras(ant):
    cameras = {c.name: c for c in ant.cameras}
    assert set(cameras) == {"eye_L", "eye_R", "panorama"}
    for name, sign in (("eye_L", 1), ("eye_R", -1)):
        eye = cameras[name]
        assert (eye.width_px, eye.height_px, eye.fov_rad, eye.projection) == (74, 19, (2.0, 0.5), "planar")
        look = -quat_to_matrix(eye.quat)[:, 2]  # in the head frame
        assert math.degrees(math.atan2(look[1], look[0])) == pytest.approx(sign * 30.0, abs=1.0)
        assert 9.0 <= math.degrees(math.asin(look[2])) <= 10.0
    pano = cameras["panorama"]
    assert (pano.width_px, pano.height_px, pano.projection) == (72, 72, "spherical")
    rotation, _ = segment_pose(ant, "head", dict(zip(ant.joint_names, ant.rest_pose_rad())))
    frame = rotation @ quat_to_matrix(pano.quat)
    # At rest the panorama is level: its middle column looks forward (+x), its top is up (+z).
    assert np.allclose(-frame[:, 2], (1, 0, 0), atol=1e-9) and np.allclose(frame[:, 1], (0, 0, 1), atol=1e-9)
    assert pano.fov_rad == pytest.approx((2 * math.pi, math.pi))


def test_leg_geometry_needs_a_complete_leg(ant):
    trimmed = dataclasses.replace(ant, segments=tuple(s for s in ant.segments if not s.name.startswith("HR_")),
                                  sites=tuple(s for s in ant.sites if not s.name.startswith("HR_")))
    with pytest.raises(ConfigError, match="HR"):
        leg_geometry(trimmed)


def test_only_the_claws_are_adhesive():
    contact = desert_ant().sites_of_kind("contact")
    assert [s.name for s in contact if s.adhesive] == [f"{leg}_claw" for leg in LEGS]
    assert not any(s.adhesive for s in contact if "antenna" in s.name)


def test_the_ventral_eye_is_one_downward_camera_added_on_request(ant):
    """``ventral_eye=True`` adds exactly the ``ventral`` camera, looking straight down from under the thorax;
    the default body has the same cameras as before."""
    eyed = desert_ant(ventral_eye=True)
    assert [c.name for c in eyed.cameras] == [c.name for c in ant.cameras] + ["ventral"]
    assert "ventral" not in [c.name for c in ant.cameras]
    ventral = eyed.cameras[-1]
    assert ventral.segment == "thorax" and ventral.pos_m[2] < 0.0
    # Cameras look along their -z axis: straight down in the thorax frame.
    assert np.allclose(quat_to_matrix(ventral.quat) @ np.array([0.0, 0.0, -1.0]), [0.0, 0.0, -1.0])
    assert eyed.spawn_height_m + ventral.pos_m[2] == pytest.approx(0.36, abs=0.01)
