"""Settings whose memory cannot fit are refused before the first trial, naming the settings and the
estimate (exit 2), instead of a MemoryError midway that leaves a failed part behind."""

import pytest

from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.runs.sweep import plan
from neuronav.scenarios.path_integration.scenario import PathIntegration, PathIntegrationConfig
from neuronav.scenarios.swarm_homing.scenario import SwarmHoming, SwarmHomingConfig

GiB = 2**30
BIG_SWARM = {"ants": 100_000, "outbound_s": 3600.0, "homing_timeout_s": 3600.0}


def test_a_swarm_too_big_for_the_memory_is_refused_naming_its_settings(tmp_path, monkeypatch):
    """The issue's command: 100,000 ants for 2 h, all in range, met a 16.8 GiB MemoryError (the
    float64 trajectories alone); the estimate says about 101 GiB (with variability's noise arrays)."""
    monkeypatch.setattr("neuronav.runs.sweep.available_memory_bytes", lambda: 16 * GiB)
    out = tmp_path / "out"
    with pytest.raises(ConfigError) as caught:
        plan("swarm-homing", trials=1, overrides=BIG_SWARM, out_dir=out)
    message = str(caught.value)
    assert "\n" not in message and not out.exists()
    for fragment in ("ants=100000", "outbound_s + homing_timeout_s = 7200 s", "need about 101.", "16.0 GiB available"):
        assert fragment in message, message
    # The defaults (1000 ants, 2 min) need about 27 MB: planned as before.
    plan("swarm-homing", trials=1, out_dir=tmp_path / "small")


def test_the_swarm_estimate_covers_its_arrays_and_every_swarm_a_chunk_touches():
    config = apply_overrides(SwarmHomingConfig, BIG_SWARM)
    one = SwarmHoming.swarm_bytes(config)
    cycles = 11_250  # (3600 s + 3600 s) / 0.64 s
    assert one > config.ants * (cycles + 1) * 2 * (8 + 4)  # the float64 trajectories and their float32 record
    assert SwarmHoming().estimate_bytes(config, 1) >= one
    # 2.5 swarms' worth of trials, from any seed, touch up to 4 swarms.
    assert SwarmHoming().estimate_bytes(config, 250_000) >= 4 * one


def test_path_integration_counts_the_recorded_neural_activity():
    """Each recorded trial keeps CPU4, TB1 and heading (25 float32) per sample: 3 GB for 10,000 trials
    of 3000 steps recorded every step, more than the rest of the batch."""
    scenario = PathIntegration()
    bare = scenario.estimate_bytes(PathIntegrationConfig(record_every=1, record_trials=0), 10_000)
    recorded = scenario.estimate_bytes(PathIntegrationConfig(record_every=1, record_trials=10_000), 10_000)
    assert recorded - bare == 10_000 * 3000 * 25 * 4
