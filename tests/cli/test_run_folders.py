"""Run folders: a run writes only into a new folder, an empty one, or one a neuronav run made; a
start that failed leaves no results behind; no lock file is left in a finished folder."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from neuronav.errors import ConfigError
from neuronav.runs.rundir import MARKER_FILE, DirectoryLock, claim_out_dir

NEURONAV = str(Path(sys.executable).with_name("neuronav"))
SHORT = ["--set", "outbound_steps=100", "--set", "inbound_steps=100"]


def neuronav(*args, cwd=None):
    return subprocess.run([NEURONAV, *args], capture_output=True, text=True, timeout=300, cwd=cwd)


def snapshot(folder: Path) -> dict:
    """Every entry under ``folder`` with its content (files) — to show nothing was touched."""
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*"))}


def assert_refused(result, *fragments):
    assert result.returncode == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    for fragment in fragments:
        assert fragment in lines[0]


@pytest.fixture
def users_folder(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "summary.json").write_text('{"my": "own results"}\n')
    (folder / "trials.csv").write_text("a,b\n1,2\n")
    return folder


@pytest.mark.parametrize("command", [
    ["run", "path-integration", *SHORT],
    ["sweep", "path-integration", "--grid", "noise=0.0,0.1", "--workers", "1", *SHORT],
    ["compare", "path-integration", "--backends", "kinematic", *SHORT],
])
def test_a_folder_of_the_users_own_files_is_refused_and_untouched(users_folder, command):
    before = snapshot(users_folder)
    result = neuronav(*command, "--out", str(users_folder))
    assert_refused(result, f"--out {str(users_folder)!r}", "no neuronav run wrote", MARKER_FILE)
    assert snapshot(users_folder) == before


def test_compare_checks_each_backend_folder_before_running(tmp_path):
    out = tmp_path / "cmp"
    embodied = ["--set", "protocol=i2bot", "--set", "outbound_s=1", "--set", "homing_timeout_s=1"]
    first = neuronav("compare", "path-integration", "--backends", "kinematic", *embodied, "--out", str(out))
    assert first.returncode == 0, first.stderr
    (out / "mujoco").mkdir()
    (out / "mujoco" / "notes.txt").write_text("mine\n")
    before = snapshot(out)
    result = neuronav("compare", "path-integration", "--backends", "kinematic,mujoco", *embodied, "--out", str(out))
    assert_refused(result, "mujoco", "no neuronav run wrote")
    assert snapshot(out) == before  # the kinematic run did not start either


def test_run_root_and_empty_out_are_refused(tmp_path):
    root = set(os.listdir("/"))
    assert_refused(neuronav("run", "path-integration", *SHORT, "--out", "/"), "--out '/'")
    assert set(os.listdir("/")) == root
    (tmp_path / "keep.txt").write_text("mine\n")
    before = snapshot(tmp_path)
    assert_refused(neuronav("run", "path-integration", *SHORT, "--out", "", cwd=tmp_path), "--out '' is empty")
    assert snapshot(tmp_path) == before


def test_a_run_folder_cannot_be_reused_across_run_and_compare(tmp_path):
    out = tmp_path / "cmp"
    assert neuronav("compare", "path-integration", "--backends", "kinematic", *SHORT, "--out", str(out)).returncode == 0
    before = snapshot(out)
    assert_refused(neuronav("run", "path-integration", *SHORT, "--out", str(out)), "results of a neuronav compare")
    assert snapshot(out) == before


def test_an_empty_folder_is_used_and_a_finished_run_leaves_no_lock_file(tmp_path):
    out = tmp_path / "empty"
    out.mkdir()
    result = neuronav("run", "path-integration", "--trials", "2", *SHORT, "--no-figures", "--out", str(out))
    assert result.returncode == 0, result.stderr
    names = {p.name for p in out.iterdir()}
    assert names == {MARKER_FILE, "settings.json", "parts", "summary.json", "trials.csv", "timeseries.h5"}
    assert json.loads((out / MARKER_FILE).read_text())["kind"] == "run"
    assert not list(out.rglob("*.lock"))


def test_the_marker_is_the_lock_and_is_released(tmp_path):
    out = claim_out_dir(tmp_path / "run")
    with DirectoryLock(out):
        with pytest.raises(ConfigError, match="in use by another neuronav process"):
            with DirectoryLock(out):
                pass
    with DirectoryLock(out):  # released when its holder let go
        pass
    assert sorted(p.name for p in out.iterdir()) == [MARKER_FILE]


def test_a_failed_start_leaves_nothing(tmp_path):
    out = tmp_path / "run"
    result = neuronav("run", "path-integration", *SHORT, "--scheduler", "tcp://127.0.0.1:1", "--out", str(out))
    assert_refused(result, "cannot reach the Dask scheduler at tcp://127.0.0.1:1")
    assert not out.exists()
    out.mkdir()
    result = neuronav("run", "path-integration", *SHORT, "--scheduler", "tcp://127.0.0.1:1", "--out", str(out))
    assert_refused(result, "cannot reach the Dask scheduler")
    assert list(out.iterdir()) == []
    result = neuronav("run", "path-integration", *SHORT, "--set", "noise=0.2", "--no-figures", "--out", str(out))
    assert result.returncode == 0, result.stderr


def test_a_folder_without_finished_trials_may_take_other_settings(tmp_path):
    """A start that wrote settings.json but finished no trial (killed at once): its folder holds no results."""
    out = tmp_path / "run"
    args = ["run", "path-integration", "--trials", "2", *SHORT, "--no-figures", "--out", str(out)]
    assert neuronav(*args).returncode == 0
    refused = neuronav(*args[:-2], "--set", "noise=0.3", "--out", str(out))
    assert_refused(refused, "holds results with other settings")
    for path in [*out.glob("parts/*.npz"), out / "summary.json", out / "trials.csv", out / "timeseries.h5"]:
        path.unlink()  # as if the first start had died before its first trial finished
    result = neuronav(*args[:-2], "--set", "noise=0.3", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert json.loads((out / "settings.json").read_text())["config"]["noise"] == 0.3
    assert json.loads((out / "summary.json").read_text())["config"]["noise"] == 0.3


def test_a_run_folder_made_before_the_marker_existed_is_resumed_and_adopted(tmp_path):
    out = tmp_path / "old"
    args = ["run", "path-integration", "--trials", "2", *SHORT, "--no-figures", "--out", str(out)]
    assert neuronav(*args).returncode == 0
    (out / MARKER_FILE).unlink()  # as the previous version left it: an empty lock file, no marker
    (out / ".neuronav.lock").write_text("")
    result = neuronav(*args)
    assert result.returncode == 0, result.stderr
    assert "2 already done" in result.stdout
    assert (out / MARKER_FILE).is_file() and not (out / ".neuronav.lock").exists()
    # Without its settings.json, a folder with such a file is not recognised.
    (out / MARKER_FILE).unlink()
    (out / ".neuronav.lock").write_text("")
    (out / "settings.json").unlink()
    assert_refused(neuronav(*args), "no neuronav run wrote")


def test_a_path_with_a_null_byte_is_one_error_not_a_traceback(tmp_path):
    """pathlib says such a path does not exist, then mkdir raises ValueError: both must be refused."""
    with pytest.raises(ConfigError, match="not a usable path"):
        claim_out_dir(tmp_path / "a\x00b")
    from neuronav.runs.cli import main

    assert main(["run", "path-integration", "--out", str(tmp_path / "a\x00b"), "--no-figures"]) == 2


def _fake_marker(folder: Path, how: str, tmp_path: Path) -> Path | None:
    """Put a ``.neuronav-run`` that neuronav did not write into ``folder``; return what it points at."""
    marker = folder / MARKER_FILE
    real = json.dumps({"made_by": "neuronav", "kind": "run", "created": "2026-01-01T00:00:00+0000"}) + "\n"
    if how in ("link to a file", "link to a real marker"):
        target = tmp_path / "target.txt"
        target.write_text("root:x:0:0\n" if how == "link to a file" else real)
        marker.symlink_to(target)
        return target
    if how == "directory":
        marker.mkdir()
    elif how == "fifo":
        os.mkfifo(marker)
    elif how == "not neuronav's":
        marker.write_text("my notes\n")
    elif how == "too large":  # valid JSON, padded far beyond what a real marker holds
        marker.write_text(real + " " * 1_000_000)
    return None


@pytest.mark.parametrize("how", ["link to a file", "link to a real marker", "directory", "fifo", "not neuronav's",
                                 "too large"])
def test_a_marker_neuronav_did_not_write_is_refused(users_folder, tmp_path, how):
    """A marker must be a small regular file that neuronav wrote: a link (to ``/etc/passwd``, say) would put
    the results among the user's files and the lock on the link's target."""
    target = _fake_marker(users_folder, how, tmp_path)
    target_before = target.read_bytes() if target is not None else None
    before = snapshot(users_folder) if how != "fifo" else None
    result = neuronav("run", "path-integration", *SHORT, "--no-figures", "--out", str(users_folder))
    assert_refused(result, f"--out {str(users_folder)!r}", MARKER_FILE)
    assert {p.name for p in users_folder.iterdir()} == {"summary.json", "trials.csv", MARKER_FILE}
    if before is not None:
        assert snapshot(users_folder) == before
    if target is not None:
        assert target.read_bytes() == target_before


def test_the_marker_is_read_in_bounded_memory(tmp_path):
    """A 256 MiB marker (sparse: no disk used) is refused without being read whole (the 3 GB one took 6.3 GB)."""
    out = tmp_path / "run"
    out.mkdir()
    with open(out / MARKER_FILE, "wb") as stream:
        stream.truncate(256 * 2**20)
    probe = ("import resource, sys\n"
             "from neuronav.errors import ConfigError\n"
             "from neuronav.runs.rundir import check_out_dir\n"
             "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
             "try:\n"
             "    check_out_dir(sys.argv[1])\n"
             "    print('accepted')\n"
             "except ConfigError as error:\n"
             "    print(error)\n"
             "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)\n")
    result = subprocess.run([sys.executable, "-c", probe, str(out)], capture_output=True, text=True, timeout=120)
    message, grown_kib = result.stdout.strip().splitlines()
    assert MARKER_FILE in message and str(out) in message, message
    assert int(grown_kib) < 50_000  # far below the file's 262 144 KiB


def test_a_marker_swapped_for_a_link_is_not_locked(tmp_path):
    """The lock opens the marker itself, never what a link put in its place points at."""
    out = claim_out_dir(tmp_path / "run")
    target = tmp_path / "target.txt"
    target.write_text("not neuronav's\n")
    (out / MARKER_FILE).unlink()
    (out / MARKER_FILE).symlink_to(target)
    with pytest.raises(ConfigError, match=MARKER_FILE):
        with DirectoryLock(out):
            pass


def test_a_new_marker_is_neuronavs_and_complete(tmp_path):
    out = claim_out_dir(tmp_path / "run", "sweep")
    marker = out / MARKER_FILE
    assert marker.is_file() and not marker.is_symlink()
    assert json.loads(marker.read_text())["made_by"] == "neuronav"
    assert [p.name for p in out.iterdir()] == [MARKER_FILE]  # no temporary left behind
    assert claim_out_dir(out, "run") == out  # run and sweep folders are one kind
