"""The ant's compound eyes read the same scene alike on the kinematic backend (7 rays per ommatidium,
:mod:`neuronav.senses.compound_eye_rays`), MuJoCo and PyBullet (cube faces rendered in the green-and-UV
colouring and one sparse product per eye, :mod:`neuronav.senses.compound_eye_views`).

The physics ants stand at rest (just reset, no step); the kinematic unicycle carries the eyes where they sit on
the standing ant (:func:`neuronav.bodies.desert_ant.body.point_agent_compound_eyes`). Four objects of three
spectral kinds (vegetation, a bright box, a UV-bright ball) stand 4 to 7 m around it under the sky.

Measured on this scene (both eyes, 1287 ommatidia each; ``python tests/cross_backend/test_compound_eye_agreement.py``):
mean |Δ| per ommatidium against the kinematic rays 0.0014 (green) and 0.0031 (UV) on MuJoCo and on PyBullet,
99th percentile 0.03, largest 0.17-0.22 (object edges, where 7 rays sample a Gaussian coarsely: against a
0.25° ray-cast panorama the physics reads err by a mean of 0.003 at most, the rays by 0.004); MuJoCo against
PyBullet 0.0001 and 0.0007. The tolerances below are about twice those means. The UV skyline (UV above 0.3):
0.16 % (MuJoCo) and 0.19 % (PyBullet) of the ommatidia differ from the rays' sky map; the lowest sky
ommatidium of each 10° column of azimuth is the same row everywhere but one column on MuJoCo (2° lower,
the horizon band's row spacing); the tests allow 0.5 % and 2.5°.
"""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.desert_ant.body import point_agent_compound_eyes
from neuronav.scenarios.worlds.scenes import forest
from neuronav.senses.compound_eye_views import EyeViews, eye_views, face_px
from neuronav.spec.body import quat_to_matrix
from neuronav.spec.world import PointAgents, World, WorldObject

BACKENDS = ("kinematic", "mujoco", "pybullet")
EYES = ("compound_eye_L", "compound_eye_R")
SCENE = World(objects=(
    WorldObject("cylinder", (3.0, 6.0, 1.5), (0.5, 1.5)),
    WorldObject("box", (-4.0, 2.0, 0.5), (0.6, 0.4, 0.5), green_uv=(0.6, 0.3)),
    WorldObject("sphere", (0.5, -5.0, 1.0), (1.0,), green_uv=(0.3, 0.8)),
    WorldObject("cone", (-3.0, -3.0, 1.0), (0.8, 1.0)),
))
# Mean |Δ| per channel (green, UV) allowed against the kinematic rays, and between the two engines.
TOLERANCE_TO_RAYS = (0.003, 0.006)
TOLERANCE_ENGINES = 0.002
UV_SKY_THRESHOLD = 0.3  # between the sky's UV (0.5) and the ground's and the objects' (<= 0.1 here but the ball)


def _engine(name: str, body):
    engine = registry.load("backend", name)(timestep_s=0.008 if name == "kinematic" else 0.002)
    carried = PointAgents(count=1, mode="unicycle", compound_eyes=point_agent_compound_eyes(body)) \
        if name == "kinematic" else body
    return engine, carried


def _read_scene() -> dict[str, np.ndarray]:
    """Both eyes (2, M, 2) on every backend, the ant at the origin heading along +y."""
    body = desert_ant(compound_eyes=True)
    values = {}
    for name in BACKENDS:
        engine, carried = _engine(name, body)
        with engine:
            engine.load(SCENE, [carried])
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=np.pi / 2)
            read = engine.read(EYES)
            values[name] = np.stack([read[eye][0] for eye in EYES])  # (2, M, 2)
    return values


@pytest.fixture(scope="module")
def seen() -> dict[str, np.ndarray]:
    return _read_scene()


def test_physics_backends_read_the_compound_eyes_as_the_rays_do(seen):
    for name in ("mujoco", "pybullet"):
        assert seen[name].shape == seen["kinematic"].shape == (2, 1287, 2)
        difference = np.abs(seen[name] - seen["kinematic"]).reshape(-1, 2)
        assert (difference.mean(axis=0) <= TOLERANCE_TO_RAYS).all(), (name, difference.mean(axis=0))
        assert np.percentile(difference, 99) < 0.06, name
    between = np.abs(seen["mujoco"] - seen["pybullet"]).reshape(-1, 2)
    assert (between.mean(axis=0) <= TOLERANCE_ENGINES).all(), between.mean(axis=0)


def test_the_uv_skyline_is_the_same_on_every_backend(seen):
    sky = {name: seen[name][..., 1] > UV_SKY_THRESHOLD for name in BACKENDS}
    # The objects and the ground hide the sky from many ommatidia; the UV-bright ball shows as sky in UV.
    below = (~sky["kinematic"]).sum()
    assert 1000 < below < 2 * 1287 - 500
    for name in ("mujoco", "pybullet"):
        assert (sky[name] != sky["kinematic"]).mean() <= 0.005, name
    # Column by column (ommatidia binned by 10° of azimuth): the lowest sky elevation, the skyline.
    for eye in range(2):
        directions = desert_ant(compound_eyes=True).compound_eyes[eye].directions
        azimuth = np.degrees(np.arctan2(directions[:, 1], directions[:, 0]))
        elevation = np.degrees(np.arcsin(directions[:, 2]))
        for column in np.unique(np.floor(azimuth / 10.0)):
            rows = np.floor(azimuth / 10.0) == column
            skyline = {name: elevation[rows & sky[name][eye]].min() for name in BACKENDS}
            assert max(skyline.values()) - min(skyline.values()) <= 2.5, (eye, column, skyline)


def test_the_ant_with_compound_eyes_loads_and_steps_on_every_backend():
    body = desert_ant(compound_eyes=True, ommatidia_scale=0.25)
    for name in BACKENDS:
        engine, carried = _engine(name, body)
        with engine:
            engine.load(SCENE, [carried])
            engine.reset(seed=0, position_m=(0.5, -0.5), yaw_rad=1.0)
            spec = {s.name: s for s in engine.capabilities.sensors}
            assert spec["compound_eye_L"].shape == (315, 2) and spec["compound_eye_L"].units == "green, UV [0, 1]"
            before = engine.read(EYES)
            if name == "kinematic":
                engine.write({"turn": np.array([[0.5]]), "stride": np.array([[0.3]])})
            engine.step(25)
            after = engine.read(EYES)
            for eye in EYES:
                assert after[eye].shape == (1, 315, 2) and np.isfinite(after[eye]).all()
                assert after[eye].min() >= 0.0 and after[eye].max() <= 1.0
            # The eyes turn with the ant: turned by 0.5 rad, they see the objects elsewhere.
            engine.reset(seed=0, position_m=(0.5, -0.5), yaw_rad=1.5)
            turned = engine.read(EYES)
            assert max(np.abs(turned[eye] - before[eye]).max() for eye in EYES) > 0.2, name


@pytest.mark.parametrize("name", ["mujoco", "pybullet"])
def test_a_compound_eye_read_leaves_the_cameras_colours_alone(name):
    body = desert_ant(compound_eyes=True, ommatidia_scale=0.25)
    engine, carried = _engine(name, body)
    with engine:
        engine.load(SCENE, [carried])
        engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=2.0)
        before = engine.render("panorama")
        eyes = engine.read(EYES)
        assert np.array_equal(engine.render("panorama"), before)
        # and the eyes saw the spectral colours: the UV-bright ball (UV 0.8) outshines the sky (0.5)
        assert max(eyes[eye][0, :, 1].max() for eye in EYES) > 0.75


def test_large_eyes_read_alike_on_mujoco_and_pybullet():
    # ommatidia_scale 4: 5074 ommatidia per eye, 94 px faces; MuJoCo lays the 10 faces out in two rows.
    body = desert_ant(compound_eyes=True, ommatidia_scale=4.0)
    seen = {}
    for name in ("mujoco", "pybullet"):
        engine, carried = _engine(name, body)
        with engine:
            engine.load(SCENE, [carried])
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=np.pi / 2)
            seen[name] = np.stack([engine.read(EYES)[eye][0] for eye in EYES])
    assert seen["mujoco"].shape == (2, 5074, 2)
    assert np.abs(seen["mujoco"] - seen["pybullet"]).mean() <= TOLERANCE_ENGINES


def test_swarm_bodies_carry_the_compound_eyes_on_their_prefixed_segments():
    from neuronav.backends.mujoco.swarm import MujocoSwarm, prefixed_body

    body = desert_ant(compound_eyes=True, ommatidia_scale=0.25)
    renamed = prefixed_body(body, "ant1/")
    assert [(e.name, e.segment) for e in renamed.compound_eyes] == [("ant1/compound_eye_L", "ant1/head"),
                                                                   ("ant1/compound_eye_R", "ant1/head")]
    swarm = MujocoSwarm(timestep_s=0.002)
    swarm.load(World(), [body, body])
    swarm.step(2)
    assert np.isfinite(swarm.read(["body_pos"])["body_pos"]).all()


def test_eye_views_cover_the_field_and_read_a_uniform_scene_exactly():
    eye = desert_ant(compound_eyes=True).compound_eyes[0]
    views = EyeViews(eye)
    assert views.face_px == face_px(eye) and views.face_px % 2 == 0  # no pixel row centred on the horizon
    assert len(views.faces) == 5  # the left eye (azimuth -10° to 170°) needs every face but the right one
    assert np.allclose(np.asarray(views.matrix.sum(axis=1)).ravel(), 1.0)
    n = views.face_px
    grey = [(np.full((n, n, 3), 51, np.uint8), np.zeros((n, n), bool)) for _ in views.faces]
    assert np.allclose(views.values(grey, (0.9, 0.9)), 0.2)
    sky = [(np.zeros((n, n, 3), np.uint8), np.ones((n, n), bool)) for _ in views.faces]
    assert np.allclose(views.values(sky, (0.15, 0.5)), (0.15, 0.5))



# Objects partly under the ground (the ball), tall and thin (the trunk: its bounding box far tighter than its
# sphere) and boxy, all around the ant.
UNDERGROUND = World(objects=(
    WorldObject("sphere", (0.5, 3.0, 0.3), (1.0,)),
    WorldObject("cylinder", (-3.0, 2.0, 2.0), (0.2, 2.0)),
    WorldObject("box", (2.0, -3.0, 0.2), (0.5, 0.5, 0.6)),
))


def _reads(name: str, world: World, yaws_rad=(0.0, 2.5)) -> np.ndarray:
    """Both compound eyes (yaws, 2, M, 2) of the ant at rest (ommatidia_scale 0.5), turned to each yaw."""
    engine, carried = _engine(name, desert_ant(compound_eyes=True, ommatidia_scale=0.5))
    with engine:
        engine.load(world, [carried])
        out = []
        for yaw in yaws_rad:
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=yaw)
            read = engine.read(EYES)
            out.append(np.stack([read[eye][0] for eye in EYES]))
    return np.array(out)


def test_pybullet_draws_the_flat_floor_from_rays_as_tinyrenderer_draws_it(monkeypatch):
    """The compound eyes' faces leave the flat floor to rays (TinyRenderer's costliest triangles): the same
    values as with the floor drawn, the ball's part under the ground hidden either way."""
    from neuronav.backends.pybullet import backend as pybullet_backend
    from neuronav.backends.pybullet import camera
    from neuronav.backends.pybullet.engine import pb
    from neuronav.backends.pybullet.scene import exact_rgba

    from_rays = _reads("pybullet", UNDERGROUND)

    def floor_drawn(cid, views, lut, culling=None, floor=None, only_objects=False):  # objects and the floor drawn
        pb.changeVisualShape(floor[0], -1, rgbaColor=exact_rgba(UNDERGROUND.appearance.ground_rgb), physicsClientId=cid)
        return camera.render_spectral(cid, views, lut, culling)

    monkeypatch.setattr(pybullet_backend, "render_spectral", floor_drawn)
    drawn = _reads("pybullet", UNDERGROUND)
    assert np.abs(from_rays - drawn).max() <= 1e-9


@pytest.mark.parametrize("world, calls", [(World(), (0, 0)), (SCENE, (1, 9)), (UNDERGROUND, (1, 9))],
                         ids=["open", "four objects", "underground ball"])
def test_pybullet_faces_that_show_no_object_are_sky_without_a_call(monkeypatch, world, calls):
    """A compound-eye face that shows none of the objects (the floor drawn from rays, no wall) costs no
    TinyRenderer call: the same values as drawing it; in the open world a read makes no call at all."""
    from neuronav.backends.pybullet import backend as pybullet_backend
    from neuronav.backends.pybullet import camera

    made = []
    get_image = camera.pb.getCameraImage

    def counted(*args, **kwargs):
        made.append(1)
        return get_image(*args, **kwargs)

    monkeypatch.setattr(camera.pb, "getCameraImage", counted)
    skipped = _reads("pybullet", world, yaws_rad=(0.0,))
    assert calls[0] <= len(made) <= calls[1], len(made)  # one read of ten faces (4 and 8 calls measured)
    render = pybullet_backend.render_spectral
    monkeypatch.setattr(pybullet_backend, "render_spectral",
                        lambda *args, **kwargs: render(*args, **{**kwargs, "only_objects": False}))
    made.clear()
    assert np.array_equal(skipped, _reads("pybullet", world, yaws_rad=(0.0,)))
    assert len(made) == 10


def test_mujoco_compound_eye_faces_draw_only_what_they_face(monkeypatch):
    """Each face draws the geoms whose bounding sphere and turned bounding box meet its frustum: under 30 % of
    the 40-tree forest's geoms per face, the same values as drawing every geom in every face."""
    from neuronav.backends.mujoco import backend as mujoco_backend

    world = World(objects=forest(40, seed=0, inner_radius_m=2.0, outer_radius_m=30.0))
    drawn = []
    visible = mujoco_backend._FlatRenderer._visible

    def counted(self, model, data, views):
        shown = visible(self, model, data, views)
        drawn.append(int(shown.sum()))
        return shown

    monkeypatch.setattr(mujoco_backend._FlatRenderer, "_visible", counted)
    yaws_rad = np.arange(0.0, 2.0 * np.pi, 0.5)
    culled = _reads("mujoco", world, yaws_rad)
    assert max(drawn) < 0.3 * 10 * len(world.objects)  # ten faces per read
    monkeypatch.setattr(mujoco_backend._FlatRenderer, "_visible",
                        lambda self, model, data, views: np.ones((len(views), self._cullable.size), bool))
    assert np.array_equal(culled, _reads("mujoco", world, yaws_rad))


@pytest.mark.parametrize("world, min_geoms", [(SCENE, 1), (World(objects=forest(40, seed=0, inner_radius_m=2.0,
                                                                                 outer_radius_m=30.0)), None)],
                         ids=["four shapes, every face batched", "forest"])
def test_mujoco_compound_eyes_draw_the_objects_in_one_call_per_face_as_mujoco_draws_them(monkeypatch, world,
                                                                                          min_geoms):
    """The objects (cylinders, boxes, spheres, MuJoCo's cone meshes) drawn by the eyes' own batch, one GL call per
    face that shows at least BATCH_MIN_GEOMS of them (here 1: every face, or the default), show the same pixels as
    MuJoCo drawing each geom (all of them here; a rare one centred on an edge may differ, see the batch's module),
    the scene turned too; MuJoCo's scene updates hold what the batch does not draw."""
    from neuronav.backends.mujoco import backend as mujoco_backend

    def faces(batched: bool) -> tuple[list[np.ndarray], list[int]]:
        if not batched:  # every object left to MuJoCo, as before the batch
            monkeypatch.setattr(mujoco_backend._FlatRenderer, "batches_objects", False)
        if min_geoms is not None:
            monkeypatch.setattr(mujoco_backend, "BATCH_MIN_GEOMS", min_geoms)
        update, scene_geoms = mujoco_backend._FlatRenderer._update_scene, []

        def counted(self, model, data, culled):  # the geoms in each of MuJoCo's scene updates
            update(self, model, data, culled)
            scene_geoms.append(int(self._scene.ngeom))

        monkeypatch.setattr(mujoco_backend._FlatRenderer, "_update_scene", counted)
        engine, body = _engine("mujoco", desert_ant(compound_eyes=True, ommatidia_scale=0.5))
        images = []
        with engine:
            engine.load(world, [body])
            for k, yaw in enumerate(np.arange(0.0, 2.0 * np.pi, 0.7)):
                engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=yaw)
                engine.set_scene_yaw(0.9 * (k // 5))  # the objects turned: the batch follows them
                engine.read(EYES)  # the eyes' renderer and views
                views = []
                for eye in body.compound_eyes:
                    pos, _, rotation = engine._segment_pose(eye.segment)
                    views += eye_views(eye).views(pos + rotation @ np.asarray(eye.pos_m, float),
                                                  rotation @ quat_to_matrix(eye.quat))
                scene_geoms.clear()
                for image, sky in engine._render_views(views, False, spectral=True):
                    images += [image, sky]
        monkeypatch.undo()
        return images, scene_geoms

    batch, batch_scene = faces(batched=True)
    each, each_scene = faces(batched=False)
    images = [(a.astype(int), b.astype(int)) for a, b in zip(batch[::2], each[::2])]
    pixels = sum(a.shape[0] * a.shape[1] for a, _ in images)
    # A colour at the middle of an 8-bit step (the box's UV 0.3: 76.5) may land on either side of it: MuJoCo's
    # lighting leaves it a hair under or over from vertex to vertex. Anything more is a different surface.
    apart = sum(int((np.abs(a - b) > 1).any(axis=-1).sum()) for a, b in images)
    sky_apart = sum(int((a != b).sum()) for a, b in zip(batch[1::2], each[1::2]))
    assert apart <= 1e-4 * pixels and sky_apart <= 1e-4 * pixels, (apart, sky_apart, pixels)  # 0 and 0 measured
    assert sum(int((a != each[0][0, 0]).any()) for a in batch[::2]) > 0  # something but the sky was drawn
    # MuJoCo's scene updates of the last read: of the ground alone where every face is batched (one update), else
    # of what the faces left to MuJoCo show; without the batch, of all that each face shows.
    assert sum(batch_scene) < sum(each_scene), (batch_scene, each_scene)
    if min_geoms == 1:
        assert len(batch_scene) == 1, batch_scene


def test_pybullet_compound_eye_faces_draw_only_what_they_face_in_few_toggles(monkeypatch):
    """Each face shows the coarse copies of the objects whose bounding sphere meets its frustum, the faces taken in
    the order that toggles fewest objects: the same values as drawing every object in every face (the scene
    turned too), with fewer toggles than in the faces' own order."""
    from neuronav.backends.pybullet import camera

    world = World(objects=forest(40, seed=0, inner_radius_m=2.0, outer_radius_m=30.0))
    toggles, show = [], camera.ObjectCulling.show

    def counted(self, shown):
        toggles.append(int((shown == self._hidden).sum()))
        show(self, shown)

    def reads() -> np.ndarray:
        engine, carried = _engine("pybullet", desert_ant(compound_eyes=True, ommatidia_scale=0.5))
        out = []
        with engine:
            engine.load(world, [carried])
            for yaw, scene_yaw in ((0.0, 0.0), (2.5, 0.0), (1.0, 0.7)):
                engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=yaw)
                engine.set_scene_yaw(scene_yaw)
                out.append(np.stack([engine.read(EYES)[eye][0] for eye in EYES]))
        return np.array(out)

    monkeypatch.setattr(camera.ObjectCulling, "show", counted)
    culled, fewest = reads(), sum(toggles)
    toggles.clear()
    monkeypatch.setattr(camera, "fewest_changes_order", lambda shown, start: list(range(len(shown))))
    assert np.array_equal(reads(), culled)
    assert fewest < 0.8 * sum(toggles), (fewest, sum(toggles))
    monkeypatch.setattr(camera.ObjectCulling, "visible_in",
                        lambda self, views: np.ones((len(views), self.count), dtype=bool))
    assert np.array_equal(reads(), culled)


def test_pybullet_cameras_and_compound_eyes_draw_their_own_copies_of_the_objects():
    """The compound eyes draw coarse copies (12 sides) of the objects, the cameras the fine ones: each read hides
    the other set, so a camera image is the same before and after a compound-eye read."""
    body = desert_ant(compound_eyes=True, ommatidia_scale=0.25)
    engine, carried = _engine("pybullet", body)
    with engine:
        engine.load(SCENE, [carried])
        engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=2.0)
        before = engine.render("eye_L")
        engine.read(EYES)
        assert engine._eye_culling.shown.any() and not engine._vision_culling.shown.any()
        assert np.array_equal(engine.render("eye_L"), before)
        assert not engine._eye_culling.shown.any() and engine._vision_culling.shown.any()


@pytest.mark.parametrize("shape, size_m, triangles", [("sphere", (1.0,), 12 * 2 + 12 * 2 * 4),
                                                      ("cylinder", (0.5, 2.0), 12 * 4), ("cone", (0.8, 1.0), 12 * 2)])
def test_round_meshes_are_closed_outward_and_on_the_surface(shape, size_m, triangles):
    from neuronav.backends.pybullet.scene import round_mesh

    obj = WorldObject(shape, (0.0, 0.0, 0.0), size_m)
    vertices, indices = round_mesh(obj, 12)
    vertices, faces = np.array(vertices), np.array(indices).reshape(-1, 3)
    assert len(faces) == triangles
    corners = vertices[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert ((normals * corners.mean(axis=1)).sum(axis=1) > 0).all()  # every triangle faces outwards
    # closed: every edge is shared by exactly two triangles, once in each direction
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    assert len({tuple(e) for e in edges}) == len(edges)
    assert {tuple(e) for e in edges} == {tuple(e[::-1]) for e in edges}
    # the mesh's volume (divergence theorem) is the shape's, less what the 12-sided polygons cut off
    volume = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum() / 6.0
    radius, half = size_m[0], size_m[-1]
    true = {"sphere": 4 / 3 * np.pi * radius ** 3, "cylinder": np.pi * radius ** 2 * 2 * half,
            "cone": np.pi * radius ** 2 * 2 * half / 3}[shape]
    assert 0.8 * true < volume < true

if __name__ == "__main__":  # the numbers in the module doc
    values = _read_scene()
    for name in ("mujoco", "pybullet"):
        d = np.abs(values[name] - values["kinematic"]).reshape(-1, 2)
        print(f"{name} vs rays: mean {d.mean(axis=0).round(4)}, p99 {np.percentile(d, 99):.3f}, max {d.max():.3f}")
    d = np.abs(values["mujoco"] - values["pybullet"]).reshape(-1, 2)
    print(f"mujoco vs pybullet: mean {d.mean(axis=0).round(4)}, max {d.max():.3f}")
