"""The command line: the run-directory contract, compare, sweep, and bad input (one line, exit 2)."""

import csv
import json
import subprocess
import sys

import h5py
import pytest

from neuronav.runs.cli import main

SHORT = ["--set", "outbound_steps=150", "--set", "inbound_steps=200"]


def neuronav(*args):
    """Run the installed CLI in a subprocess, as a user would."""
    return subprocess.run([sys.executable, "-m", "neuronav", *args], capture_output=True, text=True, timeout=300)


def test_list_shows_scenarios_backends_and_brains():
    result = neuronav("list")
    assert result.returncode == 0, result.stderr
    for name in ("path-integration", "kinematic", "available", "cx.stone2017", "ring_attractor"):
        assert name in result.stdout


def test_run_writes_the_run_directory(tmp_path):
    out = tmp_path / "run"
    result = neuronav("run", "path-integration", "--trials", "3", "--seed", "4", *SHORT, "--out", str(out))
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scenario"] == "path-integration" and summary["backend"] == "kinematic"
    assert summary["trials"] == 3 and summary["seed"] == 4
    assert summary["config"]["outbound_steps"] == 150
    assert {"numpy", "neuronav", "python"} <= set(summary["versions"])
    assert {"success", "closest_distance", "tortuosity", "decode_error_deg"} <= set(summary["metrics"])
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert [r["trial"] for r in rows] == ["0", "1", "2"] and [r["seed"] for r in rows] == ["4", "5", "6"]
    assert list(rows[0])[:3] == ["trial", "seed", "success"]
    with h5py.File(out / "timeseries.h5") as store:
        assert store["position"].shape[:2] == (3, (150 + 200) // 5 + 1)
    for figure in ("trajectories.png", "cpu4_activity.png", "tb1_heading.png"):
        assert (out / figure).stat().st_size > 5000


@pytest.mark.parametrize("dtype, tolerance", [("float64", 1e-9), ("float32", 1e-4)])
def test_a_trial_rerun_alone_gives_the_same_numbers(tmp_path, dtype, tolerance):
    arithmetic = ["--set", f"dtype={dtype}"]
    a, b = str(tmp_path / "a"), str(tmp_path / "b")
    assert main(["run", "path-integration", "--trials", "3", "--seed", "10", *SHORT, *arithmetic, "--out", a]) == 0
    assert main(["run", "path-integration", "--trials", "1", "--seed", "12", *SHORT, *arithmetic, "--out", b]) == 0
    batch = list(csv.DictReader((tmp_path / "a" / "trials.csv").open()))[2]
    alone = list(csv.DictReader((tmp_path / "b" / "trials.csv").open()))[0]
    assert (batch["seed"], batch["success"]) == (alone["seed"], alone["success"])
    # Same route and noise; BLAS may round the last bits differently for another batch size.
    for key in ("home_distance", "decode_error_deg", "closest_distance", "tortuosity_mu"):
        assert float(batch[key]) == pytest.approx(float(alone[key]), rel=tolerance), key


@pytest.mark.parametrize("args, message", [
    (["run", "no-such-scenario"], "unknown scenario 'no-such-scenario'; available: "),
    (["run", "path-integration", "--backend", "warp"], "unknown backend 'warp'"),
    (["run", "path-integration", "--set", "nois=1"], "unknown key 'nois'; allowed:"),
    (["run", "path-integration", "--set", "noise=loud"], "key 'noise' expects a number, got 'loud'"),
    (["run", "path-integration", "--set", "noise=-0.5"], "key 'noise' must be >= 0.0"),
    (["run", "path-integration", "--set", "noise"], "--set expects key=value"),
    (["run", "path-integration", "--trials", "0"], "trials must be a positive integer"),
    (["run", "path-integration", "--trials", "many"], "argument --trials: invalid int value"),
    (["run", "path-integration", "--video"], "--video films the i2bot protocol"),
    (["sweep", "path-integration", "--grid", "noise"], "--grid expects key=v1,v2"),
    (["sweep", "path-integration", "--grid", "noise=0.1", "--set", "noise=0.2"], "key 'noise' is in both --grid"),
    (["sweep", "path-integration", "--grid", "noise=0.1", "--workers", "0"], "workers must be a positive integer"),
    (["sweep", "path-integration", "--grid", "noise=0.1", "--scheduler", "here"], "--scheduler expects an address"),
    (["run", "path-integration", "--config", "/no/such/file.toml"], "config file '/no/such/file.toml' does not exist"),
    (["run", "path-integration", "--chunk-size", "0"], "chunk size must be a positive integer"),
    (["run", "path-integration", "--out", "/dev/null"], "--out '/dev/null' is a file; give a directory"),
    (["frobnicate"], "invalid choice: 'frobnicate'"),
])
def test_bad_input_is_one_line_and_exit_2(args, message):
    result = neuronav(*args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert message in lines[0]
    assert "Traceback" not in result.stderr


def test_video_of_a_scenario_that_films_nothing_is_refused_before_any_trial(tmp_path, capsys, monkeypatch):
    """Every registered scenario films (records_video); one that did not is refused in one line, exit 2."""
    from neuronav.scenarios.swarm_homing.scenario import SwarmHoming

    monkeypatch.setattr(SwarmHoming, "records_video", False)
    assert main(["run", "swarm-homing", "--video", "--out", str(tmp_path / "run")]) == 2
    assert "scenario 'swarm-homing' does not record video" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_compare_writes_a_side_by_side_table(tmp_path):
    assert main(["compare", "path-integration", "--backends", "kinematic", "--trials", "2", *SHORT,
                 "--out", str(tmp_path)]) == 0
    table = (tmp_path / "compare.md").read_text()
    assert "real_time_factor" in table and "| kinematic |" in table
    assert (tmp_path / "compare.png").exists() and (tmp_path / "kinematic" / "summary.json").exists()


def test_sweep_runs_the_grid(tmp_path):
    assert main(["sweep", "path-integration", "--grid", "noise=0.0,0.3", "--trials", "2", *SHORT,
                 "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "trials.csv").open()))
    assert [(r["noise"], r["trial"]) for r in rows] == [("0.0", "0"), ("0.0", "1"), ("0.3", "0"), ("0.3", "1")]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [p["grid"]["noise"] for p in summary["points"]] == ["0.0", "0.3"]
