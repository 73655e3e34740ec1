"""Long runs hold steady memory: the compiled Stone circuit and the kinematic backend, stepped for long.

Resident memory (VmRSS from /proc/self/status) is sampled at regular intervals after a warm-up; a
leak of even a few hundred bytes a step would show as growth of megabytes between the first and
the last samples. The full lengths (10^6 brain steps at batch 1, 10^5 backend steps) are marked
``slow``; CI runs shorter versions at a larger batch.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from neuronav.backends.kinematic import KinematicBackend
from neuronav.brains.cx import stone2017
from neuronav.spec.world import PointAgents, World

# The compiled circuit draws its noise in blocks of a multiple of 4 steps (256 at these batches):
# sampling every multiple of 1024 steps samples the same point of that cycle.
SAMPLE_EVERY = 1024
# Allowed growth of resident memory from the first samples to the last.
LIMIT_KIB = 2048


def rss_kib() -> int:
    """Resident set size of this process in KiB."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def _proc_available() -> bool:
    try:
        rss_kib()
        return True
    except (OSError, RuntimeError):
        return False


pytestmark = pytest.mark.skipif(not _proc_available(), reason="needs /proc/self/status (Linux)")


def steady(samples: list[int]) -> tuple[bool, str]:
    """Whether memory is steady: the median of the last quarter of samples is within LIMIT_KIB of the first."""
    quarter = max(1, len(samples) // 4)
    growth = float(np.median(samples[-quarter:]) - np.median(samples[:quarter]))
    return growth < LIMIT_KIB, f"grew {growth:.0f} KiB over the run; samples (KiB): {samples}"


def stone_rss(batch: int, steps: int) -> list[int]:
    brain = stone2017(noise=0.1).compile(batch=batch, seed=0, dtype=np.float32, noise_method="table")
    rng = np.random.default_rng(0)
    heading = np.cumsum(rng.vonmises(0.0, 20.0, (SAMPLE_EVERY, batch, 1)), axis=0)
    velocity = 0.5 * np.concatenate([np.sin(heading), np.cos(heading)], axis=2)
    inputs = [{"heading": heading[i], "velocity": velocity[i]} for i in range(SAMPLE_EVERY)]
    samples = []
    for step in range(steps):
        brain.step(inputs[step % SAMPLE_EVERY])
        if step % SAMPLE_EVERY == SAMPLE_EVERY - 1 and step >= steps // 10:  # after a warm-up
            samples.append(rss_kib())
    assert brain.all_finite()
    return samples


def kinematic_rss(mode: str, batch: int, steps: int) -> list[int]:
    rng = np.random.default_rng(1)
    with KinematicBackend() as backend:
        backend.load(World(), [PointAgents(count=batch, mode=mode)])
        backend.reset(0)
        if mode == "stone":
            commands = [{"rotation": rng.normal(0, 0.05, (batch, 1)), "acceleration": np.full((batch, 1), 0.05)}
                        for _ in range(64)]
        else:
            commands = [{"turn": rng.uniform(-1, 1, (batch, 1)), "stride": np.full((batch, 1), 0.2)}
                        for _ in range(64)]
        samples = []
        for step in range(steps):
            backend.write(commands[step % 64])
            backend.step()
            backend.read(("heading", "velocity", "position", "speed"))
            if step % SAMPLE_EVERY == SAMPLE_EVERY - 1 and step >= steps // 10:
                samples.append(rss_kib())
        assert np.isfinite(backend.position).all()
    return samples


def test_compiled_stone_circuit_holds_steady_memory():
    ok, message = steady(stone_rss(batch=16, steps=16 * SAMPLE_EVERY))
    assert ok, message


@pytest.mark.slow
def test_compiled_stone_circuit_holds_steady_memory_for_a_million_steps():
    ok, message = steady(stone_rss(batch=1, steps=1_000_000))
    assert ok, message


@pytest.mark.parametrize("mode", ["stone", "unicycle"])
def test_kinematic_backend_holds_steady_memory(mode):
    ok, message = steady(kinematic_rss(mode, batch=16, steps=12 * SAMPLE_EVERY))
    assert ok, message


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["stone", "unicycle"])
def test_kinematic_backend_holds_steady_memory_for_100k_steps(mode):
    ok, message = steady(kinematic_rss(mode, batch=1, steps=100_000))
    assert ok, message


def mujoco_samples(steps: int, sample) -> list:
    """The desert ant on MuJoCo, its joints held at sinusoidal targets, read every control step;
    ``sample()`` taken every :data:`SAMPLE_EVERY` physics steps after a warm-up of a tenth of the run."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    from neuronav.backends.mujoco import MujocoBackend
    from neuronav.bodies.desert_ant import desert_ant

    body = desert_ant()
    samples = []
    with MujocoBackend() as backend:
        backend.load(World(), [body])
        backend.reset(0)
        joints = len(body.joint_names)
        phases = np.linspace(0.0, 2 * np.pi, joints, endpoint=False)
        names = [s.name for s in backend.capabilities.sensors if s.name in ("joint_pos", "joint_torque", "body_pos")]
        for step in range(0, steps, 4):  # control every 4 physics steps
            targets = 0.05 * np.sin(2 * np.pi * step * 0.002 + phases)
            backend.write({"joint_targets": targets[None]})
            backend.step(4)
            backend.read(names)
            if step % SAMPLE_EVERY == 0 and step >= steps // 10:
                samples.append(sample())
    return samples


def test_mujoco_backend_keeps_no_python_objects_step_after_step():
    """The slow RSS test's claim on 12k physics steps: resident memory is too coarse at that length
    (it fell from 94 to 71 MB over 16k steps), so count what Python allocates (numpy's arrays
    included) and keeps between the samples; 8 bytes kept per control step would add about 16 KiB
    (a small array kept per step adds 257 KiB)."""
    import tracemalloc

    tracemalloc.start()
    try:
        traced_kib = mujoco_samples(12 * SAMPLE_EVERY, lambda: tracemalloc.get_traced_memory()[0] / 1024)
    finally:
        tracemalloc.stop()
    quarter = len(traced_kib) // 4
    growth_kib = float(np.median(traced_kib[-quarter:]) - np.median(traced_kib[:quarter]))
    assert growth_kib < 8.0, f"grew {growth_kib:.1f} KiB; samples (KiB): {traced_kib}"


@pytest.mark.slow
def test_mujoco_backend_holds_steady_memory_for_100k_physics_steps():
    ok, message = steady(mujoco_samples(100_000, rss_kib))
    assert ok, message
