"""Both eyes of a binocular read in one render call (issue 24: "Render both eyes ... in one scene update").

A read that asks for several body cameras renders their views together — on MuJoCo one read of the
offscreen buffer, and one scene update for the views that can show the same objects (both eyes in an open
world; in a forest each eye gets the scene of the trees it faces, cheaper to draw than all) — and each
eye's image is the one it gets when read alone (culling is exact).
"""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import registry

pytest.importorskip("mujoco")


def ant_in(objects: int):
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.worlds.scenes import forest, vision_appearance
    from neuronav.spec.world import World

    engine = registry.load("backend", "mujoco")()
    trees = forest(objects, seed=3, inner_radius_m=2.0, outer_radius_m=15.0) if objects else ()
    engine.load(World(objects=trees, appearance=vision_appearance()), [desert_ant()])
    engine.reset(seed=0)
    engine.step(5)
    return engine


@pytest.fixture(scope="module")
def forest_ant():
    engine = ant_in(12)
    yield engine
    engine.close()


@pytest.fixture(scope="module")
def open_ant():
    engine = ant_in(0)
    yield engine
    engine.close()


class Counted:
    """Counts MuJoCo's scene updates and buffer reads (monkeypatched in for one test)."""

    def __init__(self, monkeypatch):
        import mujoco

        self.update, self.read = 0, 0
        update, read_pixels = mujoco.mjv_updateScene, mujoco.mjr_readPixels

        def counted_update(*args):
            self.update += 1
            return update(*args)

        def counted_read(*args):
            self.read += 1
            return read_pixels(*args)

        monkeypatch.setattr(mujoco, "mjv_updateScene", counted_update)
        monkeypatch.setattr(mujoco, "mjr_readPixels", counted_read)


@pytest.mark.parametrize("where", ["forest_ant", "open_ant"])
def test_both_eyes_read_together_are_the_eyes_read_alone(where, request):
    ant = request.getfixturevalue(where)
    together = ant.read(["eye_L", "eye_R"])
    alone = {name: ant.read([name])[name] for name in ("eye_L", "eye_R")}
    for name in ("eye_L", "eye_R"):
        np.testing.assert_array_equal(together[name], alone[name])
    assert not np.array_equal(together["eye_L"], together["eye_R"])  # two eyes, not one image twice


def test_in_the_open_both_eyes_take_one_scene_update_and_one_buffer_read(open_ant, monkeypatch):
    counted = Counted(monkeypatch)
    open_ant.read(["eye_L", "eye_R"])
    assert (counted.update, counted.read) == (1, 1)
    open_ant.read(["eye_L"])
    open_ant.read(["eye_R"])
    assert (counted.update, counted.read) == (3, 3)


def test_in_a_forest_both_eyes_take_one_buffer_read_and_a_scene_each(forest_ant, monkeypatch):
    counted = Counted(monkeypatch)
    forest_ant.read(["eye_L", "eye_R"])
    assert (counted.update, counted.read) == (2, 1)
