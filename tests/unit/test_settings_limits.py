"""Every value a scenario's settings accept can run: the ends of every numeric range, for every
registered scenario, either run a trial on the kinematic backend (or the scenario's default backend
where it has no kinematic body) or are refused before the first trial, in one line naming the setting
(a ConfigError from :func:`neuronav.runs.sweep.plan`: the CLI's exit 2).

The CI variants take the smallest value of every duration (``*_s``), alone and all at once: a trial
too short for one brain cycle used to fail (an empty log) after passing the checks. The slow test
takes both ends of every numeric range (about 6 minutes on one core, measured).
"""

import dataclasses
import math

import numpy as np
import pytest

from neuronav import registry
from neuronav.config import field_kind
from neuronav.errors import ConfigError
from neuronav.runs.runner import load_scenario, run_trials
from neuronav.runs.sweep import plan

# Settings a trial starts from, besides each scenario's smoke settings: path-integration's embodied
# protocol (its *_s settings) does not run by default on the kinematic backend.
PROTOCOLS = {"path-integration": ({}, {"protocol": "i2bot", "outbound_s": 3.2, "homing_timeout_s": 3.2})}
# A time limit's largest value (up to an hour) runs the same loop for longer: minutes of compute per
# trial, and memory the scenarios' estimates cover (tests/unit/test_settings_memory.py). Not run.
LONGEST_RUN_S = 60.0


def numeric_fields(scenario):
    """The fields of ``scenario``'s settings whose values are numbers in a range (not choices)."""
    for f in dataclasses.fields(scenario.config_type):
        if field_kind(f) in (int, float) and "choices" not in f.metadata:
            yield f


def smallest(f):
    """The smallest value ``f``'s range allows."""
    meta = f.metadata
    if "min" in meta:
        return meta["min"]
    if field_kind(f) is int:
        return meta["min_exclusive"] + 1
    return math.nextafter(meta["min_exclusive"], math.inf)


def largest(f):
    """The largest value ``f``'s range allows."""
    meta = f.metadata
    if "max" in meta:
        return meta["max"]
    if field_kind(f) is int:
        return meta["max_exclusive"] - 1
    return math.nextafter(meta["max_exclusive"], -math.inf)


def cases(ends, only_durations):
    """(scenario, base settings, key, value) of every numeric field's ``ends`` (durations only if asked)."""
    found = []
    for name in registry.names("scenario"):
        scenario = load_scenario(name)
        for base in PROTOCOLS.get(name, ({},)):
            for f in numeric_fields(scenario):
                if only_durations and not f.name.endswith("_s"):
                    continue
                for end in ends:
                    if end is largest and f.name.endswith("_s") and largest(f) > LONGEST_RUN_S:
                        continue
                    label = f"{name}{'-' + base['protocol'] if base else ''}-{f.name}={end(f)!r}"
                    found.append(pytest.param(name, base, f.name, end(f), id=label))
    return found


def runs_or_is_refused(name, base, settings, tmp_path):
    """Plan one trial with ``settings`` (over the smoke settings and ``base``) on the kinematic backend (or
    the scenario's own where it has no kinematic body): refused in one line naming one of them, or it runs."""
    scenario = load_scenario(name)
    backend = "kinematic" if "kinematic" in scenario.backends else scenario.default_backend
    overrides = {**scenario.smoke_config(), **base, **settings}
    try:
        checked = plan(name, backend=backend, trials=1, overrides=overrides, out_dir=tmp_path / "out")
    except ConfigError as error:
        assert "\n" not in str(error) and any(key in str(error) for key in settings), str(error)
        return "refused"
    result = run_trials(scenario, checked.points[0].config, backend, trials=1, seed=0)
    row = result.trials[0]
    assert row["status"] == "ok", f"{name} {settings} passed the checks, then the trial failed: {row['error']}"
    for metric, metric_value in row.items():
        if isinstance(metric_value, (float, np.floating)) and metric not in scenario.optional_metrics:
            assert np.isfinite(metric_value), f"{name} {settings}: metric {metric} = {metric_value}"
    return "ran"


@pytest.mark.parametrize("name, base, key, value", cases((smallest,), only_durations=True))
def test_the_shortest_time_a_scenario_accepts_runs_a_trial(name, base, key, value, tmp_path):
    runs_or_is_refused(name, base, {key: value}, tmp_path)


@pytest.mark.parametrize("name, base", [pytest.param(name, base, id=f"{name}{'-' + base['protocol'] if base else ''}")
                                        for name in registry.names("scenario") for base in PROTOCOLS.get(name, ({},))])
def test_every_time_of_a_scenario_at_its_shortest_at_once_runs_a_trial_or_is_refused(name, base, tmp_path):
    """Times that each run alone may not together (path-integration's embodied trip: outbound_s and
    homing_timeout_s each near 0 s, no control step at all)."""
    durations = {f.name: smallest(f) for f in numeric_fields(load_scenario(name)) if f.name.endswith("_s")}
    runs_or_is_refused(name, base, durations, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("name, base, key, value", cases((smallest, largest), only_durations=False))
def test_both_ends_of_every_range_run_a_trial_or_are_refused(name, base, key, value, tmp_path):
    runs_or_is_refused(name, base, {key: value}, tmp_path)
