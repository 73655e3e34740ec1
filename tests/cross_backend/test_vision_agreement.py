"""The three backends see the same world: a dark cylinder lands in the same image column on MuJoCo,
PyBullet and the kinematic ray caster (±1 px), and their Zernike compass phases agree (±3°).

The physics ants stand at rest (just reset, no step); the kinematic unicycle carries the ant's own
cameras where they sit on the standing ant (:func:`neuronav.scenarios.visual_setup.point_agent_cameras`).
"""

import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.brains.vision import ZernikeBasis
from neuronav.scenarios.visual_setup import point_agent_cameras
from neuronav.scenarios.worlds.scenes import compass_scene, vision_appearance
from neuronav.spec.world import PointAgents, World, WorldObject

BACKENDS = ("kinematic", "mujoco", "pybullet")


def _engine(name: str):
    engine = registry.load("backend", name)(timestep_s=0.008 if name == "kinematic" else 0.002)
    body = PointAgents(count=1, mode="unicycle", cameras=point_agent_cameras(desert_ant())) \
        if name == "kinematic" else desert_ant()
    return engine, body


def _views(world: World, yaw_rad: float, cameras: tuple[str, ...]) -> dict[str, dict[str, np.ndarray]]:
    seen = {}
    for name in BACKENDS:
        engine, body = _engine(name)
        with engine:
            engine.load(world, [body])
            engine.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=yaw_rad)
            seen[name] = {camera: engine.read((camera,))[camera][0] for camera in cameras}
    return seen


def _dark_columns(image: np.ndarray) -> float:
    columns = np.flatnonzero((image <= 0.1).any(axis=0))
    assert columns.size, "the cylinder is not in view"
    return float(columns.mean())


@pytest.mark.parametrize("bearing_deg", [-20.0, 15.0])
def test_a_dark_cylinder_lands_in_the_same_column_on_every_backend(bearing_deg):
    # Heading 0 (along +y); the cylinder 12 m away at a bearing clockwise from +y.
    bearing = np.radians(bearing_deg)
    cylinder = WorldObject("cylinder", (12.0 * np.sin(bearing), 12.0 * np.cos(bearing), 3.0), (1.0, 3.0),
                           (0.0, 0.0, 0.0, 1.0))
    world = World(objects=(cylinder,), appearance=vision_appearance())
    seen = _views(world, np.pi / 2, ("eye_L", "eye_R", "panorama"))
    for camera in ("eye_L", "eye_R", "panorama"):
        columns = {name: _dark_columns(seen[name][camera]) for name in BACKENDS}
        assert max(columns.values()) - min(columns.values()) <= 1.0, (camera, columns)
    # And where geometry puts it in the panorama: 5° per column, forward between columns 35 and 36.
    expected = 36 + bearing_deg / 5.0 - 0.5
    assert abs(_dark_columns(seen["kinematic"]["panorama"]) - expected) <= 1.0


def test_zernike_compass_phases_agree_across_backends():
    basis = ZernikeBasis(72, 72)
    for yaw in (np.pi / 2, 1.0):
        seen = _views(compass_scene(), yaw, ("panorama",))
        phases = {name: float(basis.compass_phase(seen[name]["panorama"][None])[0]) for name in BACKENDS}
        spread = np.degrees(np.ptp(np.unwrap(np.array(list(phases.values())))))
        assert spread <= 3.0, phases
