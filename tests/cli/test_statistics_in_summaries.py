"""Every run's summary.json, every sweep's and every comparison carries its statistics (issue 22)."""

import json

from neuronav.runs.cli import main

SHORT = ["--set", "outbound_steps=300", "--set", "inbound_steps=300"]


def test_a_run_summary_has_per_condition_statistics(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "path-integration", "--trials", "6", *SHORT, "--no-figures", "--out", str(out)]) == 0
    block = json.loads((out / "summary.json").read_text())["statistics"]
    assert block["n_trials"] == 6 and block["n_failed"] == 0
    group = next(iter(block["conditions"].values()))
    assert group["metrics"]["home_distance"]["n"] == 6
    low, high = group["metrics"]["home_distance"]["median_ci"]
    assert low <= group["metrics"]["home_distance"]["median"] <= high
    assert group["success"]["n"] == 6


def test_a_sweep_compares_its_grid_points_with_the_first(tmp_path):
    out = tmp_path / "sweep"
    assert main(["sweep", "path-integration", "--grid", "noise=0.0,0.3", "--trials", "5", *SHORT,
                 "--no-figures", "--out", str(out)]) == 0
    block = json.loads((out / "summary.json").read_text())["statistics"]
    assert list(block["conditions"]) == ["noise=0.0", "noise=0.3"]
    (comparison,) = block["comparisons"]
    assert (comparison["condition"], comparison["reference"]) == ("noise=0.3", "noise=0.0")
    assert "noise" not in comparison["metrics"]  # a setting of the grid is not a measurement
    assert comparison["metrics"]["home_distance"]["test"] == "Mann-Whitney U, two-sided"


def test_a_comparison_writes_compare_json(tmp_path):
    out = tmp_path / "compare"
    assert main(["compare", "path-integration", "--backends", "kinematic", "--trials", "4", *SHORT,
                 "--out", str(out)]) == 0
    document = json.loads((out / "compare.json").read_text())
    assert document["backends"] == ["kinematic"]
    assert document["statistics"]["kinematic"]["n_trials"] == 4
    assert document["agreement"] == {} and document["across_backends"] == {}  # one backend: nothing to compare
