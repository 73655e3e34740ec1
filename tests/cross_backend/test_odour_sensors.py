"""Odour and wind read the same world on every backend: one chemistry, read at each backend's sites."""

import sys

import numpy as np
import pytest

import neuronav.bodies  # noqa: F401
from neuronav import registry
from neuronav.bodies.antennae import AntennaSweep, SweptAntennaeGait
from neuronav.bodies.gaits import make_gait
from neuronav.engine.loop import AgentLoop, Clocks
from neuronav.scenarios.visual_setup import make_engine
from neuronav.senses.chemistry import OdourScene
from neuronav.senses.odour import straight_trail
from neuronav.senses.plume import OdourSource, PlumeConfig
from neuronav.spec.world import World

desert_ant = sys.modules["neuronav.bodies.desert_ant.body"].desert_ant
BACKENDS = ("kinematic", "mujoco", "pybullet")
STAND_S = 0.48  # 60 control steps of 8 ms, 240 physics steps of 2 ms


def _world() -> World:
    plume = PlumeConfig(sources=(OdourSource(position_m=(0.5, 0.0, 0.1), release_rate_hz=60.0),))
    trail = straight_trail((0.0, 0.2), (8.0, 0.2), "normal")  # under the left antenna's tip
    return World(odour=OdourScene(trails=(trail,), plume=plume, warmup_s=3.0))


def _stand(backend_name: str, seed: int = 9):
    """The ant (or the kinematic unicycle carrying its antennae) standing at (2, 0) facing +x."""
    engine, body, gait, physics_dt = make_engine(backend_name, 0.002)
    engine.load(_world(), [body])
    loop = AgentLoop(engine, gait, Clocks(physics_dt_s=physics_dt, control_dt_s=0.008, brain_dt_s=0.64),
                     stride_rad=0.0)
    loop.reset(seed=seed, position_m=(2.0, 0.0), yaw_rad=0.0)
    loop.run(STAND_S)
    return engine


@pytest.fixture(scope="module")
def readings():
    out = {}
    for name in BACKENDS:
        if not registry.availability("backend", name)[0]:
            continue
        engine = _stand(name)
        with engine:
            values = engine.read(("odour", "wind", "odour_sites", "wind_sites"))
            values["own"] = engine.chemistry.odour_at(values["odour_sites"])
            values["plume_time_s"] = engine.chemistry.plume.time_s
            out[name] = values
    return out


def test_every_backend_reads_its_sites_in_the_one_chemistry(readings):
    for name, values in readings.items():
        assert values["odour"].shape == (1, 2, 1) and values["wind"].shape == (1, 2, 2), name
        np.testing.assert_array_equal(values["odour"], values["own"], err_msg=name)
        assert values["plume_time_s"] == pytest.approx(3.0 + STAND_S), name  # warm-up, then the trial's clock


def test_the_same_seed_blows_the_same_wind_on_every_backend(readings):
    winds = [values["wind"][0] for values in readings.values()]
    assert len(winds) == 3
    for wind in winds[1:]:
        np.testing.assert_array_equal(wind, winds[0])
    assert 1.0 < np.linalg.norm(winds[0][0]) < 3.0  # the 2 m/s mean wind with its meander


def test_the_kinematic_antennae_are_where_the_ants_are(readings):
    """The unicycle's tips are the standing ant's odour sites (within how far the ant settles)."""
    kinematic = readings["kinematic"]["odour_sites"][0]
    for name in ("mujoco", "pybullet"):
        sites = readings[name]["odour_sites"][0]
        np.testing.assert_allclose(sites[:, :2], kinematic[:, :2], atol=0.03, err_msg=name)
        np.testing.assert_allclose(sites[:, 2], kinematic[:, 2], atol=0.1, err_msg=name)
    # The left tip stands over the trail at y = 0.2 m and smells it; the right one, 0.4 m off it,
    # smells only the plume (far weaker than the trail's 1 wherever the plume has not reached).
    odour = readings["mujoco"]["odour"][0, :, 0]
    assert odour[0] > 0.5


@pytest.mark.parametrize("backend_name", ["mujoco", "pybullet"])
def test_sweeping_antennae_move_the_odour_sites_on_the_physics_ant(backend_name):
    if not registry.availability("backend", backend_name)[0]:
        pytest.skip(f"{backend_name} is not installed")
    spread = {}
    for mode in ("fixed", "moving"):
        engine, ant, gait, physics_dt = make_engine(backend_name, 0.002)
        gait = SweptAntennaeGait(make_gait("tripod", ant), AntennaSweep(mode, seed=3), ant, 0.008, seed=3)
        with engine:
            engine.load(World(), [ant])
            loop = AgentLoop(engine, gait, Clocks(physics_dt_s=physics_dt, control_dt_s=0.008, brain_dt_s=0.64),
                             stride_rad=0.0)
            loop.reset(seed=0, position_m=(0.0, 0.0), yaw_rad=0.0)
            lateral = []
            for _ in range(160):  # 1.28 s: two sweeps
                loop.step()
                lateral.append(engine.read(("odour_sites",))["odour_sites"][0, 0, 1])
        spread[mode] = float(np.ptp(lateral[40:]))
    assert spread["fixed"] < 0.02
    assert spread["moving"] > 0.2
