"""odour-trail's trial-to-trial variability and statistics (issue 22).

With the defaults (``variability=on``) no two trials are the same, on the kinematic unicycle and on the
MuJoCo ant; ``variability=off`` is the paper's protocol (fixed antennae on the normal trail repeat
exactly, with the numbers measured before the variability existed); each row names its condition, the
column the summary's statistics compare.
"""

import numpy as np
import pytest

from neuronav import registry
from neuronav.config import apply_overrides
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.runs.summary_statistics import run_statistics
from neuronav.scenarios.odour_trail.scenario import START_HEADING_RAD, OdourTrailConfig, TrailNoise, start_pose

# The columns that are not measurements of the walk (bookkeeping, the trial's identity and timing).
NOT_MEASURED = {"trial", "seed", "status", "error", "real_time_factor"}


def trail_run(backend: str, trials: int, seed: int = 0, **overrides):
    ok, reason = registry.availability("backend", backend)
    if not ok:
        pytest.skip(reason)
    config = apply_overrides(OdourTrailConfig, [f"{k}={v}" for k, v in overrides.items()])
    return run_trials(load_scenario("odour-trail"), config, backend, trials=trials, seed=seed)


def measured(rows: list[dict]) -> list[tuple]:
    return [tuple(sorted((k, repr(v)) for k, v in row.items() if k not in NOT_MEASURED)) for row in rows]


@pytest.mark.parametrize("backend, timeout_s", [("kinematic", 6.4), ("mujoco", 1.92)])
def test_with_the_defaults_no_two_trials_are_identical(backend, timeout_s):
    """Fixed antennae on the normal trail: the protocol that repeated itself exactly (36.53 s on every
    kinematic seed) now differs from trial to trial."""
    rows = trail_run(backend, 3, width="normal", antennae="fixed", timeout_s=timeout_s).trials
    assert all(r["status"] == "ok" for r in rows), rows
    assert len(set(measured(rows))) == len(rows), rows


def test_variability_off_is_the_papers_protocol_with_the_numbers_of_before():
    """``variability=off``: every fixed-antenna trial on the normal trail is the same walk, and the
    numbers are those measured before issue 22 (commit f5a9390; moving antennae differ by their sweep)."""
    fixed = trail_run("kinematic", 2, width="normal", antennae="fixed", timeout_s=6.4, variability="off").trials
    assert len(set(measured(fixed))) == 1
    assert fixed[0]["completion"] == pytest.approx(0.15161221183023837, rel=1e-12)
    moving = trail_run("kinematic", 2, width="normal", antennae="moving", timeout_s=6.4, variability="off").trials
    assert [r["completion"] for r in moving] == pytest.approx([0.21321706872599672, 0.20732664656991603], rel=1e-12)


def test_the_start_is_jittered_by_its_settings_and_only_when_on():
    on = OdourTrailConfig()
    off = apply_overrides(OdourTrailConfig, ["variability=off"])
    position, heading = start_pose(off, 7)
    np.testing.assert_array_equal(position, [0.0, 0.0])
    assert heading == START_HEADING_RAD
    starts = [start_pose(on, seed) for seed in range(300)]
    xy = np.array([p for p, _ in starts])
    headings = np.array([h for _, h in starts])
    assert np.std(xy, axis=0) == pytest.approx([on.start_position_sd_m] * 2, rel=0.15)
    assert np.degrees(np.std(headings)) == pytest.approx(on.start_heading_sd_deg, rel=0.15)
    np.testing.assert_array_equal(start_pose(on, 7)[0], start_pose(on, 7)[0])  # a seed's start repeats


def test_the_noise_reaches_the_readings_and_the_command_only_when_on():
    on = apply_overrides(OdourTrailConfig, ["odour_noise_sd=10", "turn_noise_sd=0.1", "stride_noise_fraction=0.1"])
    noise = TrailNoise(on, seed=3)
    readings = np.array([noise.odour(1.0, 0.0) for _ in range(400)])
    assert np.std(readings, axis=0) * on.sensor_scale == pytest.approx([10.0, 10.0], rel=0.15)
    commands = np.array([noise.command(0.0, np.radians(8.0)) for _ in range(400)])
    assert np.std(commands[:, 0]) == pytest.approx(0.1, rel=0.15)
    assert np.std(commands[:, 1]) == pytest.approx(0.1 * np.radians(8.0), rel=0.15)
    assert noise.command(1.0, 0.0)[0] <= 1.0 and noise.command(0.0, 0.0)[1] >= 0.0  # kept in range
    quiet = TrailNoise(apply_overrides(OdourTrailConfig, ["variability=off"]), seed=3)
    assert quiet.odour(0.25, 0.75) == (0.25, 0.75) and quiet.command(0.5, 0.1) == (0.5, 0.1)


def test_each_row_names_its_antennae_and_the_statistics_compare_moving_with_fixed():
    result = trail_run("kinematic", 4, width="normal", timeout_s=3.2)
    scenario = load_scenario("odour-trail")
    spec = scenario.statistics(OdourTrailConfig())
    assert [r[spec.condition] for r in result.trials] == [0.0, 1.0, 0.0, 1.0]  # fixed, moving by seed
    block = run_statistics(result.trials, spec, seed=0)
    assert set(block["conditions"]) == {"0.0", "1.0"} and block["reference"] == "0.0"
    (comparison,) = block["comparisons"]
    assert comparison["condition"] == "1.0" and set(comparison["metrics"]) == set(spec.metrics)
    assert "success" in comparison
