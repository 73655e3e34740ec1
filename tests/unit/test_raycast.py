"""The ray caster against geometry: where an object lands in the image, in which colour, what hides what,
the sky, the checker ground, the scene's turn, and batches that change nothing."""

import numpy as np
import pytest

from neuronav.errors import ConfigError
from neuronav.senses.raycast import RayCaster
from neuronav.senses.vision import pixel_directions, to_uint8
from neuronav.spec.body import Camera
from neuronav.spec.world import Appearance, World, WorldObject

EYE = Camera("eye", "head", (0.0, 0.0, 0.0), width_px=74, height_px=19, fov_rad=(2.0, 0.5))
PANORAMA = Camera("panorama", "head", (0.0, 0.0, 0.0), width_px=72, height_px=72, fov_rad=(2 * np.pi, np.pi),
                  projection="spherical")
PLAIN = Appearance(ground_texture="plain")
EYE_HEIGHT_M = 0.5


def level(heading_rad: float) -> np.ndarray:
    """A level camera frame facing heading h (clockwise from +y): x right, y up, looking along -z."""
    forward = np.array([np.sin(heading_rad), np.cos(heading_rad), 0.0])
    right = np.array([np.cos(heading_rad), -np.sin(heading_rad), 0.0])
    return np.column_stack([right, [0.0, 0.0, 1.0], -forward])


def cast(objects, camera, heading_rad=0.0, appearance=PLAIN, yaw_rad=0.0, eye=(0.0, 0.0, EYE_HEIGHT_M)):
    caster = RayCaster(World(objects=tuple(objects), appearance=appearance), pixel_directions(camera))
    return caster.render(np.array([eye], float), level(heading_rad)[None], yaw_rad)[0]


def tall_cylinder(bearing_rad, distance_m, radius_m, rgba=(0.1, 0.2, 0.9, 1.0)):
    """A cylinder 40 m tall standing on the ground at a bearing clockwise from +y."""
    return WorldObject("cylinder", (distance_m * np.sin(bearing_rad), distance_m * np.cos(bearing_rad), 20.0),
                       (radius_m, 20.0), rgba)


def expected_columns(azimuths_rad, bearing_rad, distance_m, radius_m):
    """Columns whose rays (azimuth to the right of forward) pass within the cylinder's silhouette."""
    half = np.arcsin(radius_m / distance_m)
    offset = np.angle(np.exp(1j * (azimuths_rad - bearing_rad)))
    assert np.min(np.abs(np.abs(offset) - half)) > 1e-3, "a column centre sits on the silhouette's edge"
    return np.flatnonzero(np.abs(offset) < half)


@pytest.mark.parametrize("bearing_deg", [-37.0, 0.0, 12.0, 41.0])
def test_a_cylinder_lands_in_the_columns_geometry_predicts_in_a_planar_eye(bearing_deg):
    bearing, distance, radius = np.radians(bearing_deg), 10.0, 0.7
    rgba = (0.1, 0.2, 0.9, 1.0)
    image = cast([tall_cylinder(bearing, distance, radius, rgba)], EYE)
    x = np.tan(1.0) * (2 * (np.arange(74) + 0.5) / 74 - 1)  # planar pinhole: azimuth = atan(x)
    columns = expected_columns(np.arctan(x), bearing, distance, radius)
    assert columns.size >= 3
    seen = np.flatnonzero((image[0] == to_uint8(rgba[:3])).all(-1))  # the top row: above the horizon
    np.testing.assert_array_equal(seen, columns)
    # Every row above the horizon shows the cylinder in those columns, in exactly its colour.
    assert (image[:9, columns] == to_uint8(rgba[:3])).all()


@pytest.mark.parametrize("bearing_deg", [0.0, 63.0, -120.0, 178.0])
def test_a_cylinder_lands_in_the_columns_geometry_predicts_in_a_panorama(bearing_deg):
    bearing, distance, radius = np.radians(bearing_deg), 15.0, 1.2
    rgba = (0.8, 0.3, 0.1, 1.0)
    image = cast([tall_cylinder(bearing, distance, radius, rgba)], PANORAMA)
    azimuths = ((np.arange(72) + 0.5) / 72 - 0.5) * 2 * np.pi  # 5° a column, forward between 35 and 36
    columns = expected_columns(azimuths, bearing, distance, radius)
    seen = np.flatnonzero((image[35] == to_uint8(rgba[:3])).all(-1))  # the row just above the horizon
    np.testing.assert_array_equal(seen, columns)


def test_the_nearer_of_two_objects_wins_whatever_their_order():
    red = tall_cylinder(0.0, 10.0, 0.5, (1.0, 0.0, 0.0, 1.0))
    blue = tall_cylinder(0.0, 20.0, 3.0, (0.0, 0.0, 1.0, 1.0))
    azimuths = ((np.arange(72) + 0.5) / 72 - 0.5) * 2 * np.pi
    near = expected_columns(azimuths, 0.0, 10.0, 0.5)
    far = np.setdiff1d(expected_columns(azimuths, 0.0, 20.0, 3.0), near)
    for objects in ([red, blue], [blue, red]):
        row = cast(objects, PANORAMA)[35]
        assert (row[near] == [255, 0, 0]).all() and (row[far] == [0, 0, 255]).all()


@pytest.mark.parametrize("shape, size", [("box", (1.0, 1.0, 1.0)), ("sphere", (1.0,)), ("cone", (2.0, 1.0))])
def test_each_shape_shows_in_its_colour_where_geometry_puts_it(shape, size):
    # Straight ahead at 10 m, centred at the eye's height: the forward ray hits, one 40° aside does not.
    obj = WorldObject(shape, (0.0, 10.0, EYE_HEIGHT_M), size, (0.2, 0.9, 0.4, 1.0))
    image = cast([obj], PANORAMA)
    assert (image[35:37, 35:37] == to_uint8((0.2, 0.9, 0.4))).all()
    assert not (image[35, 27] == to_uint8((0.2, 0.9, 0.4))).all()


def test_the_cone_narrows_to_its_apex_as_the_engines_build_it():
    # Apex up at z = 2 h above the base (base at position z - h): a ray over the apex misses, one just
    # under it hits; at the base's height the silhouette is the base radius.
    radius, half = 2.0, 2.0
    cone = WorldObject("cone", (0.0, 10.0, half), (radius, half), (1.0, 1.0, 0.0, 1.0))
    caster = RayCaster(World(objects=(cone,), appearance=PLAIN), np.array([[[0.0, 0.0, -1.0]]]))
    for height, sideways, hit in ((3.9, 0.0, True), (4.1, 0.0, False), (1.0, 1.4, True), (1.0, 1.6, False),
                                  (0.1, 1.9, True), (0.1, 2.1, False)):
        # Radius at height z: radius (2h - z) / (2h); rays along +y from x = sideways, z = height.
        image = caster.render(np.array([[sideways, 0.0, height]]), level(0.0)[None])
        assert (image[0, 0, 0] == [255, 255, 0]).all() == hit, (height, sideways)


def test_sky_pixels_show_the_plain_sky_and_the_gradient_by_elevation():
    image = cast([], PANORAMA)
    assert (image[:36] == to_uint8(PLAIN.sky_rgb)).all()  # upper half: sky, nothing else
    assert (image[36:] == to_uint8(PLAIN.ground_rgb)).all()  # lower half: the infinite ground
    gradient = Appearance(sky_rgb=(0.2, 0.4, 0.9), horizon_rgb=(0.9, 0.9, 0.8), ground_texture="plain")
    image = cast([], PANORAMA, appearance=gradient)
    elevation = (0.5 - (np.arange(36) + 0.5) / 72) * np.pi
    expected = np.array([0.9, 0.9, 0.8]) + np.sin(elevation)[:, None] * (np.array([0.2, 0.4, 0.9]) - [0.9, 0.9, 0.8])
    np.testing.assert_array_equal(image[:36], np.broadcast_to(to_uint8(expected)[:, None], (36, 72, 3)))


@pytest.mark.parametrize("centre, odd", [((0.25, 0.25), False), ((0.75, 0.25), True), ((-0.25, 0.25), True),
                                         ((-0.25, -0.25), False), ((1.25, 3.75), True), ((1.75, 3.75), False)])
def test_a_checker_square_has_the_colour_of_its_parity(centre, odd):
    look = Appearance(ground_texture="checker", checker_m=0.5)
    down = np.column_stack([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # looking along -z
    camera = Camera("down", "head", (0.0, 0.0, 0.0), width_px=4, height_px=4, fov_rad=(0.1, 0.1))
    caster = RayCaster(World(appearance=look), pixel_directions(camera))
    image = caster.render(np.array([[*centre, 2.0]]), down[None])[0]  # sees ±0.1 m about the centre
    expected = look.checker_rgb if odd else look.ground_rgb
    assert (image == to_uint8(expected)).all()


def _compass_like():
    return [WorldObject("cylinder", (0.0, 14.0, 2.0), (1.0, 2.0), (0.1, 0.3, 0.9, 1.0)),
            WorldObject("sphere", (12.0, 5.0, 1.5), (1.5,), (0.9, 0.1, 0.1, 1.0)),
            WorldObject("box", (-9.0, -11.0, 1.5), (1.5, 1.0, 1.5), (0.2, 0.7, 0.2, 1.0)),
            WorldObject("cone", (-14.0, 4.0, 2.0), (1.5, 2.0), (0.6, 0.2, 0.7, 1.0))]


def test_turning_the_scene_by_one_column_rolls_the_panorama_by_one_column():
    look = Appearance(ground_texture="plain", horizon_rgb=(0.9, 0.9, 0.9))
    still = cast(_compass_like(), PANORAMA, appearance=look)
    for steps in (1, -3):
        # Counter-clockwise (from above) by k columns: objects move left, to lower columns.
        turned = cast(_compass_like(), PANORAMA, appearance=look, yaw_rad=np.radians(5.0 * steps))
        np.testing.assert_array_equal(turned, np.roll(still, -steps, axis=1))


def test_a_batch_renders_each_agent_as_if_alone():
    rng = np.random.default_rng(3)
    headings = rng.uniform(-np.pi, np.pi, 7)
    eyes = np.column_stack([rng.uniform(-3, 3, (7, 2)), np.full(7, EYE_HEIGHT_M)])
    look = Appearance(ground_texture="checker", horizon_rgb=(0.9, 0.9, 0.9))
    for camera in (EYE, PANORAMA):
        caster = RayCaster(World(objects=tuple(_compass_like()), appearance=look), pixel_directions(camera))
        rotations = np.stack([level(h) for h in headings])
        together = caster.render(eyes, rotations, 0.3)
        for k in range(7):
            np.testing.assert_array_equal(together[k], caster.render(eyes[k:k + 1], rotations[k:k + 1], 0.3)[0])


def test_chunks_of_agents_change_nothing(monkeypatch):
    import neuronav.senses.raycast as raycast

    caster = RayCaster(World(objects=tuple(_compass_like()), appearance=PLAIN), pixel_directions(PANORAMA))
    headings = np.linspace(-3.0, 3.0, 5)
    eyes, rotations = np.tile([0.0, 0.0, EYE_HEIGHT_M], (5, 1)), np.stack([level(h) for h in headings])
    whole = caster.render(eyes, rotations)
    for rays in (2 * 72 * 72, 100):  # chunks of 2 agents; of 1 agent and 2 tiles' rays at a time
        monkeypatch.setattr(raycast, "MAX_RAYS_PER_CHUNK", rays)
        np.testing.assert_array_equal(caster.render(eyes, rotations), whole)


def test_bad_objects_and_poses_are_refused():
    with pytest.raises(ConfigError, match=r"object 0 \(cylinder\): size_m needs 2 positive values"):
        RayCaster(World(objects=(WorldObject("cylinder", (0, 0, 0), (1.0,)),)), pixel_directions(EYE))
    caster = RayCaster(World(), pixel_directions(EYE))
    with pytest.raises(ConfigError, match="must be finite"):
        caster.render(np.array([[0.0, np.nan, 0.5]]), level(0.0)[None])
    with pytest.raises(ConfigError, match="2 eyes but 1 rotations"):
        caster.render(np.zeros((2, 3)), level(0.0)[None])
