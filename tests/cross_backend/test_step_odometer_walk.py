"""The step odometer on the physics engines: the ant walks the FK tripod straight (stride 15°), one
cycle of start-up and then ``CYCLES`` gait cycles (0.64 s each), while
:class:`neuronav.bodies.step_odometer.StepOdometer` reads its joint angles and claw loads through
the leg kinematics of the body it *believes* it has (its loads: ``contact_load``, as the scenarios read them).

- ``contact_load`` is the load of the last physics step: on MuJoCo the norm of the forces the step solved
  (``contact_force`` read before the step solves the same problem), on PyBullet the norm of ``contact_force``.

- Normal legs, believed normal: the odometer reads close to the true distance (the root's horizontal
  displacement), within ``BAND`` of what each engine measured; it is not exact, because the FK tripod's
  feet slip and its stance legs unload now and then (README: bodies/desert_ant/README.md, "Step odometer").
- Longer legs (``leg_length_factors=1.3``) read through the believed normal legs: the odometer
  underestimates, relative to the normal legs' reading.
- The named manipulations (:mod:`neuronav.bodies.desert_ant.manipulations`) change the true stride:
  stilts longer, stumps shorter.

Measured (this test's walk) with ``python benchmarks/step_odometer.py --manipulations --cycles 3``
(odometer / true): MuJoCo normal 0.928, stilts 0.739; PyBullet normal 1.187, stilts 0.984.
"""

from __future__ import annotations

import numpy as np
import pytest

from neuronav import registry
from neuronav.bodies.desert_ant import desert_ant
from neuronav.bodies.desert_ant.manipulations import manipulated_ant
from neuronav.bodies.gaits import make_gait
from neuronav.bodies.step_odometer import StepOdometer
from neuronav.spec.world import World

BACKENDS = ["mujoco", "pybullet"]
CYCLES = 3
CYCLE_STEPS = 80
MEASURED_RATIO = {"mujoco": 0.928, "pybullet": 1.187}  # odometer / true, normal legs
BAND = 0.1


def walk(backend: str, body, believed) -> tuple[float, StepOdometer]:
    """(true distance m, the odometer) of the straight walk."""
    pytest.importorskip(backend, reason=f"{backend} is not installed")
    with registry.load("backend", backend)(timestep_s=0.002) as engine:
        engine.load(World(), [body])
        gait = make_gait("tripod", body)
        engine.reset(0)
        odometer = StepOdometer(believed)
        for k in range((CYCLES + 1) * CYCLE_STEPS):
            engine.write({"joint_targets": gait.step(0.0, np.radians(15.0))[None, :]})
            engine.step(4)
            sensed = engine.read(("joint_pos", "contact_load", "body_pos"))
            if k == CYCLE_STEPS - 1:
                start = sensed["body_pos"][0, :2].copy()
            if k >= CYCLE_STEPS - 1:
                odometer.update(sensed["joint_pos"][0], sensed["contact_load"][0])
        return float(np.hypot(*(sensed["body_pos"][0, :2] - start))), odometer


@pytest.fixture(scope="module")
def normal():
    return desert_ant()


def _step_forces_mujoco(engine) -> np.ndarray:
    """Each contact site's total contact force as MuJoCo's last step solved it (mj_contactForce summed),
    computed here by one more mj_step1/mj_step2 on the engine's own model and data."""
    import mujoco

    model, data = engine.model, engine.data
    mujoco.mj_step2(model, data)  # the engine left its state after mj_step1: this is the next step's solve
    forces, wrench = np.zeros((len(engine._contact_sites), 3)), np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        site1, site2 = engine._site_of_geom[contact.geom1], engine._site_of_geom[contact.geom2]
        if contact.efc_address < 0 or (site1 < 0 and site2 < 0):
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        world = contact.frame.reshape(3, 3).T @ wrench[:3]
        forces[site2] += world if site2 >= 0 else 0.0
        forces[site1] -= world if site1 >= 0 else 0.0
    mujoco.mj_step1(model, data)
    return forces


@pytest.mark.parametrize("backend", BACKENDS)
def test_contact_load_is_the_last_steps_contact_force(backend, normal):
    # MuJoCo: the loads its contact sensors computed in the step equal the forces that step solved
    # (mj_contactForce); PyBullet: its contact points are the last step's, so the load is contact_force's norm.
    pytest.importorskip(backend, reason=f"{backend} is not installed")
    with registry.load("backend", backend)(timestep_s=0.002) as engine:
        engine.load(World(), [normal])
        gait = make_gait("tripod", normal)
        engine.reset(0)
        loaded = 0
        for _ in range(60):
            engine.write({"joint_targets": gait.step(0.0, np.radians(15.0))[None, :]})
            if backend == "mujoco":
                expected = np.linalg.norm(_step_forces_mujoco(engine), axis=1)
            else:
                engine.step(1)
                expected = np.linalg.norm(engine.read(("contact_force",))["contact_force"][0], axis=1)
            load = engine.read(("contact_load",))["contact_load"][0]
            np.testing.assert_allclose(load, expected, rtol=1e-9, atol=1e-9)
            loaded += int((expected > 1.0).sum())
        assert loaded > 100  # the legs were loaded: the comparison was not between zeros


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_sampler_reads_what_read_reads(backend, normal):
    from neuronav.errors import PortError

    pytest.importorskip(backend, reason=f"{backend} is not installed")
    with registry.load("backend", backend)(timestep_s=0.002) as engine:
        engine.load(World(), [normal])
        engine.reset(0)
        engine.step(30)
        for names in (("joint_pos", "contact_load"), ("heading", "contact_force", "joint_vel")):
            sample = engine.sampler(names)
            engine.step(3)
            sensed = engine.read(names)
            np.testing.assert_array_equal(sample(), np.concatenate([sensed[n][0].ravel() for n in names]))
            assert sample() is not sample()  # each call its own array: a buffer of samples stays intact
        with pytest.raises(PortError, match="no sensor 'legs'"):
            engine.sampler(("joint_pos", "legs"))


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_sampler_records_what_read_reads_at_each_record(backend, normal):
    """record() keeps each step's values (MuJoCo: raw state, finished at drain()); drain() gives them in order,
    past the first buffer's 128 rows, and empties the record."""
    pytest.importorskip(backend, reason=f"{backend} is not installed")
    names = ("joint_pos", "contact_load")
    with registry.load("backend", backend)(timestep_s=0.002) as engine:
        engine.load(World(), [normal])
        engine.reset(0)
        gait = make_gait("tripod", normal)
        sampler, expected = engine.sampler(names), []
        for _ in range(130):
            engine.write({"joint_targets": gait.step(0.0, np.radians(15.0))[None, :]})
            engine.step(2)
            sampler.record()
            sensed = engine.read(names)
            expected.append(np.concatenate([sensed[n][0].ravel() for n in names]))
        recorded = sampler.drain()
        np.testing.assert_allclose(recorded, np.array(expected), rtol=1e-12, atol=1e-12)
        assert (recorded[:, -8:] > 1.0).any() and len(np.unique(recorded[:, 0])) > 100  # loads and moving joints
        assert sampler.drain().shape[0] == 0


@pytest.mark.parametrize("backend", BACKENDS)
def test_normal_legs_read_close_to_the_true_distance(backend, normal):
    true_m, odometer = walk(backend, normal, normal)
    assert true_m > 0.8, true_m  # it walked (~0.33 m per cycle)
    ratio = odometer.distance_m / true_m
    assert ratio == pytest.approx(MEASURED_RATIO[backend], rel=BAND), ratio
    assert len(odometer.stride_lengths_m) == CYCLES - 1, odometer.stride_lengths_m
    np.testing.assert_allclose(odometer.stride_lengths_m, odometer.distance_m / CYCLES, rtol=0.2)


@pytest.mark.parametrize("backend", BACKENDS)
def test_longer_legs_read_through_the_believed_normal_legs_underestimate(backend, normal):
    true_normal, normal_reading = walk(backend, normal, normal)
    true_long, long_reading = walk(backend, desert_ant(leg_length_factors=1.3), normal)
    assert true_long > 1.1 * true_normal  # the longer legs walk farther ...
    ratio_normal = normal_reading.distance_m / true_normal
    ratio_long = long_reading.distance_m / true_long
    assert ratio_long < 0.93 * ratio_normal, (ratio_long, ratio_normal)  # ... than the odometer believes


@pytest.mark.parametrize("backend", BACKENDS)
def test_stilts_lengthen_and_stumps_shorten_the_stride(backend, normal):
    true_m = {name: walk(backend, manipulated_ant(name), normal)[0] for name in ("normal", "stilts", "stumps")}
    assert true_m["stilts"] > 1.1 * true_m["normal"], true_m
    assert true_m["stumps"] < 0.8 * true_m["normal"], true_m
