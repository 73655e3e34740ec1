"""The sweep and run commands end to end: killed and resumed, settings recorded, a trial re-run alone."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from neuronav.runs.cli import main
from neuronav.runs.rundir import list_parts, read_part

SHORT = ["--set", "outbound_steps=150", "--set", "inbound_steps=200"]
METRICS = ("home_distance", "decode_error_deg", "closest_distance", "tortuosity_mu", "decoded_distance")


def rows_of(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


def toml_text(config: dict) -> str:
    """A config dict as TOML ``key = value`` lines (strings quoted, booleans lower case)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        return repr(v)

    return "".join(f"{key} = {value(v)}\n" for key, v in config.items())


def test_a_killed_sweep_resumes_and_finishes_every_trial_exactly_once(tmp_path):
    out = tmp_path / "sweep"
    args = ["sweep", "path-integration", "--grid", "noise=0.0,0.1", "--trials", "8", "--seed", "5",
            "--set", "outbound_steps=1000", "--set", "inbound_steps=1000", "--workers", "2", "--chunk-size", "1",
            "--no-figures", "--out", str(out)]
    process = subprocess.Popen([sys.executable, "-m", "neuronav", *args], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while len(list(out.glob("parts/*/trials-*.npz"))) < 3 and process.poll() is None:
            assert time.monotonic() < deadline, "the sweep wrote no parts"
            time.sleep(0.005)
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the sweep and its worker processes, mid-run
        process.wait(timeout=30)
    assert process.returncode == -signal.SIGKILL, process.stderr.read().decode()
    done = {path: path.stat().st_mtime_ns for path in out.glob("parts/*/trials-*.npz")}
    assert 3 <= len(done) < 16
    for path in done:  # nothing half-written: every part reads back whole
        rows, _, meta = read_part(path)
        assert len(rows) == 1 and rows[0]["trial"] == meta["first"]
    assert not (out / "summary.json").exists()

    assert main(args) == 0
    rows = rows_of(out / "trials.csv")
    assert sorted((r["noise"], int(r["trial"])) for r in rows) == [(n, t) for n in ("0.0", "0.1") for t in range(8)]
    assert all(r["status"] == "ok" and int(r["seed"]) == 5 + int(r["trial"]) for r in rows)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["total_trials"] == 16 and summary["resumed_trials"] == len(done)
    assert all(path.stat().st_mtime_ns == mtime for path, mtime in done.items())  # not recomputed
    assert sum(count for point in ("noise=0.0", "noise=0.1") for _, count, _ in
               list_parts(out / "parts" / point)) == 16


def test_a_rerun_with_other_settings_is_refused_in_one_line(tmp_path, capsys):
    out = str(tmp_path / "run")
    assert main(["run", "path-integration", "--trials", "2", *SHORT, "--no-figures", "--out", out]) == 0
    capsys.readouterr()
    assert main(["run", "path-integration", "--trials", "2", *SHORT, "--set", "noise=0.2", "--out", out]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "holds results with other settings (config.noise: 0.1 there, 0.2 now)" in error
    assert main(["run", "path-integration", "--trials", "2", *SHORT, "--no-figures", "--out", out]) == 0
    assert "2 already done" in capsys.readouterr().out
    settings = json.loads((tmp_path / "run" / "settings.json").read_text())
    assert settings["trials"] == 2 and settings["config"]["outbound_steps"] == 150 and settings["versions"]["numpy"]


@pytest.mark.parametrize("dtype, chunk, tolerance", [
    ("float64", 4, 1e-9),
    ("float32", 4, 1e-4),
    ("float32", 1, 0.0),
])
def test_a_trial_from_trials_csv_rerun_alone_gives_the_same_numbers(tmp_path, dtype, chunk, tolerance):
    """Pick a trial of a sweep, rerun it alone with its seed and the config its summary recorded.

    Trial i's route and noise come from seed + i alone, so the rerun computes the same trial. The
    arithmetic differs only in rounding: numpy and BLAS vectorise over the batch (SIMD lanes, matrix
    blocking), so a batch of 4 and a batch of 1 may round the last bit differently, and the closed
    loop (3 x 350 steps of steering feedback) carries that along. In float64 that stays near 1e-14
    relative (tolerance 1e-9); in float32 near 1e-6 (tolerance 1e-4). Computed the same way (a chunk
    of one trial, as the rerun is), the numbers are identical.
    """
    out = tmp_path / "sweep"
    assert main(["sweep", "path-integration", "--grid", "noise=0.05,0.1", "--trials", "4", "--seed", "20", *SHORT,
                 "--set", f"dtype={dtype}", "--chunk-size", str(chunk), "--workers", "1", "--no-figures",
                 "--out", str(out)]) == 0
    picked = [r for r in rows_of(out / "trials.csv") if r["noise"] == "0.1" and r["trial"] == "2"][0]
    recorded = json.loads((out / "noise=0.1" / "summary.json").read_text())["config"]
    (tmp_path / "trial.toml").write_text(toml_text(recorded))
    alone = tmp_path / "alone"
    assert main(["run", "path-integration", "--trials", "1", "--seed", picked["seed"], "--config",
                 str(tmp_path / "trial.toml"), "--no-figures", "--out", str(alone)]) == 0
    again = rows_of(alone / "trials.csv")[0]
    assert (again["seed"], again["success"], again["status"]) == (picked["seed"], picked["success"], "ok")
    for key in METRICS:
        if tolerance == 0.0:
            assert again[key] == picked[key], key
        else:
            assert float(again[key]) == pytest.approx(float(picked[key]), rel=tolerance), key


def test_run_with_workers_splits_the_trials_and_keeps_their_numbers(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    assert main(["run", "path-integration", "--trials", "6", *SHORT, "--set", "dtype=float64",
                 "--no-figures", "--out", str(one)]) == 0
    assert main(["run", "path-integration", "--trials", "6", *SHORT, "--set", "dtype=float64", "--workers", "2",
                 "--no-figures", "--out", str(two)]) == 0
    assert len(list_parts(one / "parts")) == 1 and len(list_parts(two / "parts")) == 6
    for a, b in zip(rows_of(one / "trials.csv"), rows_of(two / "trials.csv"), strict=True):
        assert (a["trial"], a["seed"]) == (b["trial"], b["seed"])
        assert np.allclose([float(a[k]) for k in METRICS], [float(b[k]) for k in METRICS], rtol=1e-9)


def test_sweep_writes_per_point_results_and_the_metric_figure(tmp_path):
    assert main(["sweep", "path-integration", "--grid", "noise=0.0,0.2", "--grid", "kappa=50,100", "--trials", "2",
                 *SHORT, "--set", "record_trials=1", "--workers", "1", "--out", str(tmp_path)]) == 0
    rows = rows_of(tmp_path / "trials.csv")
    assert list(rows[0])[:7] == ["noise", "kappa", "trial", "seed", "success", "status", "error"]
    assert [(r["noise"], r["kappa"]) for r in rows[::2]] == [("0.0", "50.0"), ("0.0", "100.0"),
                                                             ("0.2", "50.0"), ("0.2", "100.0")]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [p["dir"] for p in summary["points"]] == ["noise=0.0_kappa=50.0", "noise=0.0_kappa=100.0",
                                                     "noise=0.2_kappa=50.0", "noise=0.2_kappa=100.0"]
    assert summary["figures"] == ["sweep_metrics.png"] and (tmp_path / "sweep_metrics.png").stat().st_size > 10000
    point = json.loads((tmp_path / "noise=0.2_kappa=50.0" / "summary.json").read_text())
    assert point["grid"] == {"noise": "0.2", "kappa": "50.0"} and point["config"]["kappa"] == 50.0
    assert (tmp_path / "noise=0.2_kappa=50.0" / "trajectories.png").exists()
