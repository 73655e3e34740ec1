"""MuJoCo's eye rendering across processes and backends: safe after fork, one GL context kept per process.

The fork checks run in a subprocess with a timeout, so that a hang fails the test instead of CI.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytest.importorskip("mujoco")

FORK_TIMEOUT_S = 90

VECTOR_AFTER_ENV = textwrap.dedent("""
    import os, sys
    import gymnasium as gym
    import neuronav.scenarios.envs  # noqa: F401 -- registers the ids
    from neuronav.runs.executors import gl_driver_loaded

    for backend in sys.argv[1:]:
        env = gym.make("neuronav/AntBeacon-v0", backend=backend)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        assert gl_driver_loaded(), "the parent rendered nothing: this test tests nothing"
        vector = gym.vector.AsyncVectorEnv([lambda: gym.make("neuronav/AntBeacon-v0", backend=backend)] * 2)
        vector.reset(seed=0)
        vector.step(vector.action_space.sample())
        vector.close()
        env.close()
        print("stepped", backend, flush=True)
""")

FORK_SAME_BACKEND = textwrap.dedent("""
    import os, sys
    import numpy as np
    from neuronav import registry
    from neuronav.backends.mujoco import gl_contexts
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.worlds.scenes import compass_scene

    engine = registry.load("backend", "mujoco")()
    engine.load(compass_scene(), [desert_ant()])
    engine.reset(seed=0)
    parent = engine.read(("eye_L", "eye_R"))
    pid = os.fork()
    if pid == 0:  # the child reads through the parent's backend object: its own context, the same images
        try:
            child = engine.read(("eye_L", "eye_R"))
            same = all(np.array_equal(parent[k], child[k]) for k in parent)
            made = gl_contexts.contexts_made()  # the parent's context is never used here
            engine.close()
            print("child", "same" if same else "different", "made", made, flush=True)
        except Exception as error:
            print("child", type(error).__name__, error, flush=True)
        os._exit(0)
    os.waitpid(pid, 0)
    engine.close()
""")


def _run(script: str, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    environment = dict(os.environ)
    environment.pop("LP_NUM_THREADS", None)  # as a user's shell has it (importing the backend here set it)
    environment.update(MUJOCO_GL="egl", **(env or {}))
    try:
        return subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True,
                              timeout=FORK_TIMEOUT_S, env=environment)
    except subprocess.TimeoutExpired:
        pytest.fail("a process forked after rendering hung (the GL driver's state carried across fork)")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="AsyncVectorEnv forks on Linux only")
def test_an_async_vector_env_made_after_a_rendering_env_resets_and_steps_with_fork():
    pytest.importorskip("gymnasium")
    backends = ["mujoco"]
    try:
        import dm_control  # noqa: F401
        backends.append("dm_control")
    except ImportError:
        pass
    done = _run(VECTOR_AFTER_ENV, *backends)
    assert done.returncode == 0, done.stderr[-3000:]
    assert [line.split()[-1] for line in done.stdout.split("\n") if line.startswith("stepped")] == backends


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_a_forked_child_renders_through_its_parents_backend_in_a_context_of_its_own():
    done = _run(FORK_SAME_BACKEND)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "child same made 1" in done.stdout, done.stdout + done.stderr[-3000:]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_a_child_of_a_threaded_gl_driver_refuses_to_render_and_names_the_fix():
    done = _run(FORK_SAME_BACKEND, env={"LP_NUM_THREADS": "2"})
    assert done.returncode == 0, done.stderr[-3000:]
    assert "child SimulationError" in done.stdout and "spawn" in done.stdout, done.stdout


def test_the_next_backend_reuses_the_gl_context_and_sees_the_same_images():
    from neuronav import registry
    from neuronav.backends.mujoco import gl_contexts
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig, beacon_world
    from neuronav.scenarios.worlds.scenes import compass_scene

    def eyes(world):
        engine = registry.load("backend", "mujoco")()
        engine.load(world, [desert_ant()])
        engine.reset(seed=0, yaw_rad=0.3)
        images = engine.read(("eye_L", "eye_R", "panorama"))
        return engine, images

    first, seen = eyes(compass_scene())
    other, _ = eyes(beacon_world(VisualBeaconConfig(eye="both", trees=10), 1))  # textures and meshes of its own
    other.close()
    first.close()
    made = gl_contexts.contexts_made()
    again, seen_again = eyes(compass_scene())
    again.close()
    assert gl_contexts.contexts_made() == made, "a kept context was not reused"
    for name in seen:
        np.testing.assert_array_equal(seen_again[name], seen[name], err_msg=name)


def test_the_eyes_draw_only_what_they_face_and_see_what_they_saw_drawing_everything(monkeypatch):
    from neuronav import registry
    from neuronav.backends.mujoco import backend as mujoco_backend
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig, beacon_world

    world = beacon_world(VisualBeaconConfig(eye="both", trees=40), 2)

    def looks(cull: bool) -> tuple[list, list]:
        if not cull:
            monkeypatch.setattr(mujoco_backend._FlatRenderer, "_visible",
                                lambda self, model, data, views: np.ones((len(views), self._cullable.size), bool))
        images, drawn = [], []
        with registry.load("backend", "mujoco")() as engine:
            engine.load(world, [desert_ant()])
            for yaw_deg in range(0, 360, 30):
                engine.reset(seed=0, yaw_rad=np.radians(yaw_deg))
                for camera in ("eye_L", "eye_R", "panorama"):
                    images.append(engine.read((camera,))[camera])
                    drawn.append(engine._eyes._scene.ngeom)
        monkeypatch.undo()
        return images, drawn

    culled, drawn_culled = looks(cull=True)
    everything, drawn_all = looks(cull=False)
    for seen, expected in zip(culled, everything, strict=True):
        np.testing.assert_array_equal(seen, expected)
    eyes = np.array(drawn_culled).reshape(-1, 3)[:, :2]  # the panorama faces every way: nothing culled
    assert eyes.max() < 0.6 * max(drawn_all), (drawn_culled, drawn_all)


def test_pybullet_eyes_hide_what_they_cannot_see_and_see_what_they_saw_drawing_everything(monkeypatch):
    pytest.importorskip("pybullet")
    from neuronav import registry
    from neuronav.backends.pybullet import camera
    from neuronav.bodies.desert_ant import desert_ant
    from neuronav.scenarios.visual_beacon.scenario import VisualBeaconConfig, beacon_world

    world = beacon_world(VisualBeaconConfig(eye="both", trees=40), 2)

    def looks(cull: bool) -> tuple[list, list]:
        if not cull:
            monkeypatch.setattr(camera.ObjectCulling, "only_for", lambda *_: None)
        images, hidden = [], []
        with registry.load("backend", "pybullet")() as engine:
            engine.load(world, [desert_ant()])
            for yaw_deg in range(0, 360, 45):
                engine.reset(seed=0, yaw_rad=np.radians(yaw_deg))
                if yaw_deg == 180:
                    engine.set_scene_yaw(np.radians(40.0))  # the objects move: the culling follows them
                for camera_name in ("eye_L", "eye_R", "panorama"):
                    images.append(engine.read((camera_name,))[camera_name])
                    hidden.append(int(engine._vision_culling._hidden.sum()))
        monkeypatch.undo()
        return images, hidden

    culled, hidden = looks(cull=True)
    everything, _ = looks(cull=False)
    for seen, expected in zip(culled, everything, strict=True):
        np.testing.assert_array_equal(seen, expected)
    eyes = np.array(hidden).reshape(-1, 3)[:, :2]
    assert eyes.min() > 0.4 * len(world.objects), hidden  # each eye faces less than 60 % of the objects
