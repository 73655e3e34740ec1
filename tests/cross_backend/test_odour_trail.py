"""Odour trail following (the paper's §2.5.1, Fig. 6a–d) on every backend.

Short variants (CI): the ant starting on the wide trail walks along it, smelling it all the way, on
the kinematic unicycle and the MuJoCo ant; the metrics follow their definitions. The full protocol
(n = 10 per antenna mode and width on MuJoCo and PyBullet) is ``slow``.
"""

import functools

import numpy as np
import pytest

from neuronav import registry
from neuronav.config import apply_overrides
from neuronav.errors import ConfigError
from neuronav.runner import load_scenario, run_trials
from scenarios.odour_trail import OdourTrailConfig, arc_length_m, make_trail


def available(name):
    ok, reason = registry.availability("backend", name)
    if not ok:
        pytest.skip(reason)


def trail_run(backend: str, trials: int, seed: int = 0, **overrides):
    available(backend)
    config = apply_overrides(OdourTrailConfig, [f"{k}={v}" for k, v in overrides.items()])
    return run_trials(load_scenario("odour-trail"), config, backend, trials=trials, seed=seed)


@pytest.mark.parametrize("backend", ["kinematic", "mujoco"])
def test_the_ant_starting_on_the_wide_trail_walks_along_it(backend):
    """Both antennae on the trail: Table 3 walks straight at 8°; after 5 s the ant is further along
    the trail, its body never left it, and (fixed antennae) it never had to search."""
    result = trail_run(backend, 1, width="wide", antennae="fixed", timeout_s=5.12)
    row = result.trials[0]
    assert row["status"] == "ok" and row["time_on_trail"] == 1.0, row
    path = result.timeseries["position_m"][0]
    path = path[np.isfinite(path[:, 0])]
    trail = make_trail("wide")
    arc, distance = arc_length_m(trail, path)
    assert arc[-1] - arc[0] > 0.6, arc  # walked forward along the trail
    assert distance.max() < trail.width_m / 2, distance.max()
    turns = result.timeseries["turn"][0]
    assert np.nanmax(np.abs(turns)) < 1.0  # never searched (the search state turns by ±1)
    assert 0.0 < row["completion"] < 1.0 and not row["success"] and np.isnan(row["finish_time_s"])


def test_moving_antennae_sense_differently_and_both_modes_repeat():
    """Two trials of ``both`` on the normal trail: seed 0 fixed, seed 1 moving; the moving ant's
    antennae read other concentrations than the fixed one's, and a rerun repeats every number."""
    first = trail_run("kinematic", 2, width="normal", timeout_s=3.2)
    assert [r["antennae_moving"] for r in first.trials] == [0.0, 1.0]
    odour = first.timeseries["odour_L"]
    assert not np.array_equal(odour[0], odour[1])
    again = trail_run("kinematic", 2, width="normal", timeout_s=3.2)
    np.testing.assert_array_equal(first.timeseries["position_m"], again.timeseries["position_m"])
    assert set(first.aggregates) >= {"completion_fixed", "completion_moving", "success_fixed"}


def test_the_antenna_length_reaches_the_body():
    """On the normal trail (0.27 m) short antennae (0.25 m: odour sites 0.24 m apart) both smell
    it and the ant walks along it; the body's own (0.541 m: 0.43 m apart) both miss it, and the ant
    searches on the spot (Table 3's "no odour")."""
    def walked_m(length_m):
        result = trail_run("kinematic", 1, width="normal", antennae="fixed", antenna_length_m=length_m,
                           timeout_s=3.2)
        path = result.timeseries["position_m"][0]
        path = path[np.isfinite(path[:, 0])]
        return float(np.hypot(*(path[-1] - path[0]))), result.timeseries["turn"][0]

    short_m, short_turns = walked_m(0.25)
    long_m, long_turns = walked_m(0.541)
    assert short_m > 0.5 and np.all(np.abs(short_turns[np.isfinite(short_turns)]) < 1.0), short_m  # never searched
    assert long_m < 0.1 and np.all(np.abs(long_turns[np.isfinite(long_turns)]) == 1.0), long_m


def test_bad_settings_are_config_errors():
    with pytest.raises(ConfigError, match="width"):
        apply_overrides(OdourTrailConfig, ["width=huge"])
    with pytest.raises(ConfigError, match="antennae"):
        apply_overrides(OdourTrailConfig, ["antennae=waving"])
    scenario = load_scenario("odour-trail")
    with pytest.raises(ConfigError, match="timestep_s"):
        scenario.check(apply_overrides(OdourTrailConfig, ["timestep_s=0.003"]), "mujoco")


@functools.cache
def protocol(backend: str, width: str):
    """The full protocol at one width: 20 trials of ``both`` (seeds 0–19: 10 fixed, 10 moving); run
    once per session, shared by the two slow tests."""
    return trail_run(backend, 20, width=width)


def finish_median_s(aggregates: dict, mode: str) -> float:
    """A mode's median finish time, infinite when none of its trials finished."""
    value = aggregates[f"median_finish_{mode}_s"]
    return float("inf") if np.isnan(value) else value


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_full_protocol_what_the_model_does(backend):
    """What was measured (n = 10 per mode and width): with the body's antennae (odour sites 0.43 m
    apart) neither mode follows the normal trail (0.27 m) past its first metres, both sites off
    it whenever the ant is centred on it; on the wide trail both modes get round the first bend and
    some trials of each reach the end."""
    normal = protocol(backend, "normal").aggregates
    wide = protocol(backend, "wide").aggregates
    assert normal["completion_fixed"] < 0.3 and normal["completion_moving"] < 0.3, normal
    assert normal["success_fixed"] == 0.0 and normal["success_moving"] == 0.0, normal
    assert wide["completion_fixed"] > 0.5 and wide["completion_moving"] > 0.5, wide
    assert wide["success_fixed"] > 0.0 and wide["success_moving"] > 0.0, wide


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the paper's finding does not emerge in this model (measured on MuJoCo and "
                   "PyBullet, n = 10 per mode and width: see the scenario's module docstring)")
@pytest.mark.parametrize("backend", ["mujoco", "pybullet"])
def test_full_protocol_the_papers_finding(backend):
    """The paper's Fig. 6c–d: moving antennae do about as well as fixed ones on the normal trail and
    clearly better on the wide one (completion and finish time)."""
    normal = protocol(backend, "normal").aggregates
    wide = protocol(backend, "wide").aggregates
    assert abs(normal["completion_moving"] - normal["completion_fixed"]) < 0.1, normal
    assert normal["completion_moving"] > 0.5, normal  # "about as well" must mean following the trail
    assert wide["completion_moving"] > wide["completion_fixed"] + 0.1, wide
    assert finish_median_s(wide, "moving") < finish_median_s(wide, "fixed"), wide
