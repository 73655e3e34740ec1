"""Killed and interrupted runs: pool workers die with their run and never hold its lock; a rerun
resumes with every trial exactly once, or only assembles when every trial is done."""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import neuronav.runs.rundir
from neuronav.runs.cli import main

NEURONAV = str(Path(sys.executable).with_name("neuronav"))
SHORT = ["--set", "outbound_steps=150", "--set", "inbound_steps=200"]
LONG = ["--set", "outbound_steps=1500", "--set", "inbound_steps=1500"]


def rows_of(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


def children_of(pid):
    """Process ids whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry))
    return found


def alive(pid):
    """Whether ``pid`` runs (a zombie waiting for a reaper has ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def sigkill_main_when(args, ready):
    """Start ``neuronav ARGS``; SIGKILL its main process (only it: its workers are not signalled) once
    ``ready(process)`` is true, which it must become within 120 s while the run still works."""
    process = subprocess.Popen([NEURONAV, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while process.poll() is None and not ready(process):
            assert time.monotonic() < deadline, "the run never got to the point of the kill"
            time.sleep(0.01)
        assert process.poll() is None, process.stderr.read().decode()
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        process.stderr.close()
    assert process.returncode == -signal.SIGKILL


def kill_once_working(args, out, parts_glob):
    """Kill ``neuronav ARGS`` once a part is written and both workers run; return the worker ids."""
    workers = []

    def ready(process):
        workers[:] = children_of(process.pid)
        return len(workers) >= 2 and bool(list(out.glob(parts_glob)))

    sigkill_main_when(args, ready)
    return workers


def wait_gone(pids, limit_s=30.0):
    deadline = time.monotonic() + limit_s
    while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = [pid for pid in pids if alive(pid)]
    for pid in left:  # never leave them behind, even when the test fails
        os.kill(pid, signal.SIGKILL)
    return left


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("command", ["run", "sweep"])
def test_killed_run_takes_its_workers_along_and_a_rerun_resumes_every_trial_once(tmp_path, command, capsys):
    out = tmp_path / "out"
    if command == "run":
        args = ["run", "path-integration", "--trials", "8", "--workers", "2", "--chunk-size", "1"]
        glob, expected = "parts/trials-*.npz", [("", t) for t in range(8)]
    else:
        args = ["sweep", "path-integration", "--grid", "noise=0.0,0.1", "--trials", "4", "--workers", "2",
                "--chunk-size", "1"]
        glob, expected = "parts/*/trials-*.npz", [(n, t) for n in ("0.0", "0.1") for t in range(4)]
    args += [*LONG, "--no-figures", "--out", str(out)]
    workers = kill_once_working(args, out, glob)
    assert len(workers) == 2
    assert wait_gone(workers) == [], "pool workers outlived their killed run"
    done = len(list(out.glob(glob)))
    assert 1 <= done < len(expected)

    assert main(args) == 0  # not "in use by another neuronav process"
    captured = capsys.readouterr()
    assert "in use" not in captured.err and f"{done} already done" in captured.out
    rows = rows_of(out / "trials.csv")
    assert sorted((r.get("noise", ""), int(r["trial"])) for r in rows) == expected  # each trial exactly once
    assert all(r["status"] == "ok" for r in rows)
    assert len(list(out.glob(glob))) == len(expected)  # one part per trial: none computed twice


def test_workers_do_not_hold_the_run_folder_lock(tmp_path):
    """A worker forked while the lock is held closes its copy: after the parent lets go, nobody holds it."""
    from neuronav.runs.executors import LocalPool

    out = tmp_path / "out"
    neuronav.runs.rundir.claim_out_dir(out)
    with neuronav.runs.rundir.DirectoryLock(out) as lock:
        pool = LocalPool(1, close_fds=(lock.fileno,))._pool(1)
        future = pool.submit(os.getpid)
        worker = future.result(timeout=60)
    try:
        assert alive(worker)
        with neuronav.runs.rundir.DirectoryLock(out):  # free although the worker still runs
            pass
    finally:
        pool.shutdown(wait=True)


def test_interrupted_assembly_is_finished_by_a_rerun(tmp_path, monkeypatch, capsys):
    """SIGINT while the results are written: trials.csv complete, no summary.json; a rerun only assembles."""
    out = tmp_path / "run"
    args = ["run", "path-integration", "--trials", "3", *SHORT, "--out", str(out)]
    real = neuronav.runs.rundir.write_timeseries

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(neuronav.runs.rundir, "write_timeseries", interrupted)
    assert main(args) == 130
    assert len(rows_of(out / "trials.csv")) == 3 and not (out / "summary.json").exists()
    parts = {p: p.stat().st_mtime_ns for p in out.glob("parts/*.npz")}
    monkeypatch.setattr(neuronav.runs.rundir, "write_timeseries", real)
    capsys.readouterr()
    assert main(args) == 0
    assert "3 already done" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["trials"] == 3 and summary["failed_trials"] == 0 and (out / "timeseries.h5").exists()
    assert {p: p.stat().st_mtime_ns for p in out.glob("parts/*.npz")} == parts  # nothing recomputed


def test_interrupted_sweep_assembly_is_finished_by_a_rerun(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep"
    args = ["sweep", "path-integration", "--grid", "noise=0.0,0.1", "--trials", "2", "--workers", "1", *SHORT,
            "--out", str(out)]
    import neuronav.runs.assembly

    real = neuronav.runs.assembly.metrics_figure

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(neuronav.runs.assembly, "metrics_figure", interrupted)
    assert main(args) == 130
    assert (out / "trials.csv").exists() and not (out / "summary.json").exists()
    monkeypatch.setattr(neuronav.runs.assembly, "metrics_figure", real)
    assert main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["total_trials"] == 4 and summary["resumed_trials"] == 4
    assert (out / "sweep_metrics.png").exists()


def test_a_killed_run_on_a_dask_cluster_leaves_the_folder_free_and_resumes(tmp_path, capsys):
    """Dask workers are not children of the run: they never hold its lock, and a rerun at once resumes."""
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "out"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  protocol="tcp", dashboard_address=None) as cluster:
        args = ["run", "path-integration", "--trials", "6", "--chunk-size", "1", *LONG, "--no-figures",
                "--scheduler", cluster.scheduler_address, "--out", str(out)]
        sigkill_main_when(args, lambda process: bool(list(out.glob("parts/trials-*.npz"))))
        done = len(list(out.glob("parts/trials-*.npz")))
        assert 1 <= done < 6
        assert main(args) == 0
    captured = capsys.readouterr()
    assert "in use" not in captured.err and f"{done} already done" in captured.out
    rows = rows_of(out / "trials.csv")
    assert [int(r["trial"]) for r in rows] == list(range(6)) and {r["status"] for r in rows} == {"ok"}
