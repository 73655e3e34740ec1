"""Compound eyes: the Cataglyphis layout, the green/UV world, the sparse sampling matrix
(neuronav/senses/compound_eye.py), the ray reader (neuronav/senses/compound_eye_rays.py) and the kinematic
backend's compound-eye sensors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.desert_ant.body import point_agent_compound_eyes
from neuronav.errors import ConfigError
from neuronav.scenarios.worlds.scenes import forest
from neuronav.senses.compound_eye import (
    ACCEPTANCE_DEG,
    cataglyphis_eye,
    cataglyphis_ommatidia,
    sampling_matrix,
    spectral_world,
)
from neuronav.senses.compound_eye_rays import CompoundEyeReader, ray_pattern
from neuronav.senses.dorsal_rim import head_rotations_from_headings
from neuronav.senses.raycast import RayCaster
from neuronav.senses.vision import pixel_directions
from neuronav.spec.body import Camera, CompoundEye
from neuronav.spec.world import (
    OBJECT_GREEN_UV,
    Appearance,
    PointAgents,
    World,
    WorldObject,
)

SCENE = (
    WorldObject("cylinder", (0.0, 4.0, 1.5), (0.4, 1.5)),
    WorldObject("box", (3.0, 2.0, 0.8), (0.5, 0.7, 0.8), green_uv=(0.3, 0.08)),
    WorldObject("sphere", (-3.0, -1.0, 2.0), (0.8,), green_uv=(0.05, 0.02)),
    WorldObject("cone", (-2.0, 3.0, 1.2), (0.9, 1.2)),
    WorldObject("sphere", (2.5, -2.5, -0.6), (1.0,), green_uv=(0.6, 0.3)),  # mostly under the ground: hidden
    WorldObject("box", (0.0, 8.0, 2.0), (0.6, 0.3, 2.0), green_uv=(0.5, 0.25)),  # partly behind the cylinder
)


def _elevation_azimuth_deg(directions):
    elevation = np.degrees(np.arcsin(directions[:, 2]))
    azimuth = np.degrees(np.arctan2(-directions[:, 1], directions[:, 0]))  # clockwise from forward
    return elevation, azimuth


def test_ommatidia_count_and_scale_follow_the_ant():
    directions, acceptance = cataglyphis_ommatidia("R", 1.0)
    assert 1200 <= directions.shape[0] <= 1300  # Zollikofer et al. 1995: ~1200-1300 per eye in large workers
    assert np.allclose(np.linalg.norm(directions, axis=1), 1.0)
    assert np.allclose(acceptance, math.radians(ACCEPTANCE_DEG))
    quarter, quarter_acceptance = cataglyphis_ommatidia("R", 0.25)
    assert abs(quarter.shape[0] / directions.shape[0] - 0.25) < 0.02
    assert np.allclose(quarter_acceptance, 2.0 * acceptance[0])  # angles scale by 1/sqrt(scale)
    for bad in (0.0, 5.0, float("nan"), "x"):
        with pytest.raises(ConfigError, match="ommatidia_scale"):
            cataglyphis_ommatidia("R", bad)
    with pytest.raises(ConfigError, match="side"):
        cataglyphis_ommatidia("up")


def test_field_of_view_and_the_band_of_acuity_on_the_horizon():
    elevation, azimuth = _elevation_azimuth_deg(cataglyphis_ommatidia("R")[0])
    # The right eye: 10 deg across the midline to 170 deg on its side, -50 to +80 deg in elevation.
    assert -10.0 < azimuth.min() < -7.0 and 167.0 < azimuth.max() < 170.0
    assert -50.0 <= elevation.min() < -45.0 and 75.0 < elevation.max() <= 80.0
    assert np.abs(elevation).min() > 0.5  # rows symmetric about the equator, none on it
    # Ommatidia per steradian: the equatorial band holds more than the band above it.
    def density(low, high):
        inside = (elevation >= low) & (elevation < high)
        solid_sr = math.pi * (math.sin(math.radians(high)) - math.sin(math.radians(low)))  # 180 deg of azimuth
        return inside.sum() / solid_sr
    assert density(-10.0, 10.0) > 1.4 * density(30.0, 50.0)  # a uniform lattice gives 1


def test_left_eye_mirrors_the_right_eye():
    left, _ = cataglyphis_ommatidia("L")
    right, _ = cataglyphis_ommatidia("R")
    assert np.array_equal(left, right * np.array([1.0, -1.0, 1.0]))
    assert (right[:, 1] < 0).mean() > 0.9 and (left[:, 1] > 0).mean() > 0.9  # each looks to its own side


def test_the_ant_carries_two_compound_eyes():
    ant = desert_ant(compound_eyes=True, ommatidia_scale=0.5)
    names = [eye.name for eye in ant.compound_eyes]
    assert names == ["compound_eye_L", "compound_eye_R"]
    assert all(eye.segment == "head" and eye.channels == ("green", "uv") for eye in ant.compound_eyes)
    assert desert_ant().compound_eyes == ()
    assert desert_ant(compound_eyes=True) == desert_ant(compound_eyes=True)  # eyes compare by value
    # On a point agent the eyes sit level at the head's height (the rest pitch undone).
    placed = point_agent_compound_eyes(ant)
    assert all(np.allclose(eye.quat, (1.0, 0.0, 0.0, 0.0), atol=1e-9) for eye in placed)
    assert placed[0].pos_m[1] > 0 > placed[1].pos_m[1] and 0.3 < placed[0].pos_m[2] < 0.6


def test_compound_eye_refuses_bad_data():
    directions, acceptance = cataglyphis_ommatidia("R", 0.1)
    with pytest.raises(ConfigError, match="unit vectors"):
        CompoundEye("e", "head", (0, 0, 0), directions=directions * 2, acceptance_rad=acceptance)
    with pytest.raises(ConfigError, match="acceptance_rad"):
        CompoundEye("e", "head", (0, 0, 0), directions=directions, acceptance_rad=acceptance[:-1])
    with pytest.raises(ConfigError, match="channels"):
        CompoundEye("e", "head", (0, 0, 0), directions=directions, acceptance_rad=acceptance, channels=("red",))
    with pytest.raises(ConfigError, match="green_uv"):
        World(objects=(WorldObject("sphere", (0, 0, 1), (1,), green_uv=(0.5, 2.0)),))
    with pytest.raises(ConfigError, match="sky_green_uv"):
        Appearance(sky_green_uv=(0.5,))
    with pytest.raises(ConfigError, match="rays_per_ommatidium"):
        ray_pattern(cataglyphis_eye("e", "head", (0, 0, 0), "R", ommatidia_scale=0.1), 3)


def _sphere_pixels(step_deg: float):
    """An equirectangular grid over the whole sphere: directions (P, 3) and solid angles (P,)."""
    step = math.radians(step_deg)
    elevation = -math.pi / 2 + (np.arange(int(round(180 / step_deg))) + 0.5) * step
    azimuth = -math.pi + (np.arange(int(round(360 / step_deg))) + 0.5) * step
    e, a = np.meshgrid(elevation, azimuth, indexing="ij")
    directions = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1).reshape(-1, 3)
    return directions, (step * step * np.cos(e)).reshape(-1)


def test_sampling_matrix_reads_a_uniform_scene_and_a_half_bright_one():
    eye = cataglyphis_eye("e", "head", (0, 0, 0), "R", ommatidia_scale=0.05)
    pixels, solid = _sphere_pixels(0.5)
    matrix = sampling_matrix(eye, pixels, solid)
    assert matrix.shape == (eye.n_ommatidia, pixels.shape[0]) and matrix.format == "csr"
    assert np.allclose(np.asarray(matrix.sum(axis=1)).ravel(), 1.0)
    assert np.allclose(matrix @ np.full(pixels.shape[0], 0.37), 0.37)
    # Each ommatidium truncated at 2 FWHM: no weight farther than that from its axis.
    rows, columns = matrix.nonzero()
    angles = np.arccos(np.clip((eye.directions[rows] * pixels[columns]).sum(axis=1), -1, 1))
    assert angles.max() <= 2.0 * eye.acceptance_rad.max() + 1e-9
    # A scene bright on one side of a plane through each ommatidium's axis reads 0.5 there.
    rng = np.random.default_rng(3)
    for m in range(eye.n_ommatidia):
        normal = np.cross(eye.directions[m], rng.normal(size=3))
        bright = (pixels @ normal > 0).astype(float)
        assert abs(matrix[m] @ bright - 0.5) < 0.03
    with pytest.raises(ConfigError, match="pixel_solid_angle_sr"):
        sampling_matrix(eye, pixels, solid[:-1])


def test_reader_in_an_empty_world_sees_ground_below_and_sky_above():
    world = World()
    eye = cataglyphis_eye("e", "head", (0, 0, 0), "R", ommatidia_scale=0.25)
    values = CompoundEyeReader(world, eye).read([[0.0, 0.0, 0.5]], head_rotations_from_headings(0.3))[0]
    elevation, _ = _elevation_azimuth_deg(eye.directions)
    margin = 2.0 * eye.acceptance_rad[0]
    assert np.allclose(values[np.radians(elevation) > margin], world.appearance.sky_green_uv)
    assert np.allclose(values[np.radians(elevation) < -margin], world.appearance.ground_green_uv)


AGREEMENT_CASES = [(0.0, (0.2, -0.3)), (0.15, (0.2, -0.3)), (0.0, (-2.6, -1.5))]


def _against_panorama(pitch_rad: float, where, rays_per_ommatidium: int = 7):
    """|rays - acceptance integral| per ommatidium and channel (M, 2) for an eye at ``where``, 0.5 m up, heading
    -0.3 rad, pitched ``pitch_rad``, the scene turned by 0.2 rad; and whether each ommatidium sees an object."""
    world = World(objects=SCENE)
    eye = cataglyphis_eye("e", "head", (0, 0, 0), "R", ommatidia_scale=0.5)
    position = np.array([[*where, 0.5]])
    rotation = head_rotations_from_headings(-0.3, pitch_rad=pitch_rad)
    rays = CompoundEyeReader(world, eye, rays_per_ommatidium).read(position, rotation, scene_yaw_rad=0.2)[0]
    camera = Camera("pano", "head", (0, 0, 0), width_px=720, height_px=360, fov_rad=(2 * math.pi, math.pi),
                    projection="spherical")
    directions = pixel_directions(camera).reshape(-1, 3)  # camera frame: x right, y up, looks along -z
    in_eye = np.stack([-directions[:, 2], -directions[:, 0], directions[:, 1]], axis=1)
    to_eye = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # camera axes in the eye frame
    image = RayCaster(spectral_world(world), pixel_directions(camera)).render(position, rotation @ to_eye, 0.2)[0]
    solid = math.radians(0.5) ** 2 * np.cos(np.arcsin(np.clip(directions[:, 1], -1, 1)))
    panorama = sampling_matrix(eye, in_eye, solid) @ (image.reshape(-1, 3)[:, 1:] / 255.0)
    changed = np.abs(rays - CompoundEyeReader(World(), eye).read(position, rotation)[0]).max(axis=1) > 0.01
    return np.abs(rays - panorama), changed


@pytest.mark.parametrize("pitch_rad, where", AGREEMENT_CASES)
def test_reader_agrees_with_the_sampling_matrix_on_a_ray_cast_panorama(pitch_rad, where):
    """7 rays per ommatidium against the acceptance integral over a 0.5-degree panorama of the same scene,
    rendered by the camera ray caster from the spectral world (green in G, UV in B). Level eyes find upright
    objects by azimuth wedges, pitched eyes by tiles of ommatidia; the last case looks up from under the ball.
    The numbers (docs/parameters.md, section 12): ``python tests/unit/test_compound_eye.py``."""
    difference, changed = _against_panorama(pitch_rad, where)
    axes_only, _ = _against_panorama(pitch_rad, where, rays_per_ommatidium=1)
    assert changed.sum() > 30  # the objects cover many ommatidia
    # Most ommatidia agree to the panorama's 8-bit step; at edges the 7-ray rule errs by up to ~0.14 of a
    # channel, and on average by less than half as much as one ray per ommatidium.
    assert difference.mean() < 0.008 and np.percentile(difference, 99) < 0.1 and difference.max() < 0.15
    assert np.median(difference) < 0.003
    assert axes_only.mean() > 1.5 * difference.mean()


def test_level_eyes_find_every_upright_object_as_tilted_eyes_do():
    """Level eyes take the upright objects from the rays sorted into bands of elevation (one search per band
    of a wedge); eyes tilted by 1e-9 rad take the tiles. Both see the same: trees near (one around the eye),
    far, tall and flat, in front of and behind each other, across the wedge seam at +-180 degrees."""
    world = World(objects=(*SCENE, *forest(20, seed=3, inner_radius_m=0.5, outer_radius_m=25.0),
                           WorldObject("cylinder", (-6.0, 0.01, 0.2), (2.0, 0.2))))  # under the first eye
    eye = cataglyphis_eye("e", "head", (0, 0, 0), "R", ommatidia_scale=0.5)
    rng = np.random.default_rng(4)
    positions = np.column_stack([rng.uniform(-8.0, 8.0, (12, 2)), np.full(12, 0.5)])
    positions[0, :2] = (-6.0, 0.0)  # inside the flat cylinder's footprint
    headings = rng.uniform(0.0, 2.0 * np.pi, 12)
    reader = CompoundEyeReader(world, eye)
    level = reader.read(positions, head_rotations_from_headings(headings), scene_yaw_rad=0.3)
    tilted = reader.read(positions, head_rotations_from_headings(headings, pitch_rad=1e-9), scene_yaw_rad=0.3)
    empty = CompoundEyeReader(World(), eye).read(positions, head_rotations_from_headings(headings))
    assert (np.abs(level - empty).max(axis=-1) > 0.01).mean() > 0.2  # the objects cover many ommatidia
    assert np.abs(level - tilted).max() < 1e-6

def test_uv_skyline_sky_outshines_ground_and_objects_in_uv_only():
    look = Appearance()
    assert look.sky_green_uv[1] > max(look.ground_green_uv[1], OBJECT_GREEN_UV[1])
    assert look.sky_green_uv[0] < look.ground_green_uv[0]  # in green the sand is brighter than the sky
    world = World(objects=SCENE)
    eye = cataglyphis_eye("e", "head", (0, 0, 0), "L", ommatidia_scale=0.5)
    headings = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    positions = np.column_stack([np.zeros(8), np.zeros(8), np.full(8, 0.5)])
    seen = CompoundEyeReader(world, eye).read(positions, head_rotations_from_headings(headings))
    empty = CompoundEyeReader(World(), eye).read(positions, head_rotations_from_headings(headings))
    sky_only = np.all(np.abs(empty - look.sky_green_uv) < 1e-12, axis=-1) & np.all(seen == empty, axis=-1)
    not_sky = np.abs(seen - empty).max(axis=-1) > 0.05  # mostly an object
    below = np.all(np.abs(empty - look.ground_green_uv) < 1e-12, axis=-1) & np.all(seen == empty, axis=-1)
    assert sky_only.any() and not_sky.any() and below.any()
    assert seen[..., 1][sky_only].min() > max(seen[..., 1][not_sky].max(), seen[..., 1][below].max())
    assert seen[..., 0][below].min() > seen[..., 0][sky_only].max()  # no such skyline in green


def test_kinematic_backend_reads_compound_eyes_per_agent():
    from neuronav.backends.kinematic import KinematicBackend

    eyes = point_agent_compound_eyes(desert_ant(compound_eyes=True, ommatidia_scale=0.25))
    world = World(objects=(WorldObject("cylinder", (0.0, 3.0, 2.0), (0.5, 2.0)),))
    backend = KinematicBackend(timestep_s=0.008)
    backend.load(world, [PointAgents(count=3, mode="unicycle", compound_eyes=eyes)])
    spec = {s.name: s for s in backend.capabilities.sensors}["compound_eye_L"]
    assert spec.shape == (eyes[0].n_ommatidia, 2) and spec.units == "green, UV [0, 1]"
    # Agent 0 faces the tree (north), agent 1 has it on its left (faces east), agent 2 on its right.
    backend.reset(heading_rad=np.array([0.0, np.pi / 2, -np.pi / 2]))
    read = backend.read(["compound_eye_L", "compound_eye_R"])
    assert read["compound_eye_L"].shape == (3, eyes[0].n_ommatidia, 2)
    uv_sum = {side: read[f"compound_eye_{side}"][..., 1].sum(axis=1) for side in "LR"}
    assert uv_sum["L"][1] < uv_sum["R"][1] - 0.5 and uv_sum["R"][2] < uv_sum["L"][2] - 0.5  # the tree darkens UV
    # An agent reads the same alone as in its batch.
    alone = KinematicBackend(timestep_s=0.008)
    alone.load(world, [PointAgents(count=1, mode="unicycle", compound_eyes=eyes)])
    alone.reset(heading_rad=np.pi / 2)
    assert np.array_equal(alone.read(["compound_eye_L"])["compound_eye_L"][0], read["compound_eye_L"][1])
    with pytest.raises(ConfigError, match="flat ground"):
        from neuronav.spec.world import Ground

        KinematicBackend().load(World(ground=Ground(kind="uneven", roughness_m=0.1)),
                                [PointAgents(count=1, compound_eyes=eyes)])


if __name__ == "__main__":  # the agreement numbers of docs/parameters.md, section 12
    for pitch, where in AGREEMENT_CASES:
        for rays in (7, 1):
            d, _ = _against_panorama(pitch, where, rays)
            print(f"pitch {pitch} rad, eye at {where}, {rays} rays: mean {d.mean():.4f}, median {np.median(d):.4f}, "
                  f"99th percentile {np.percentile(d, 99):.3f}, largest {d.max():.3f}")
