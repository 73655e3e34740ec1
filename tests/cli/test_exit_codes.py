"""Exit codes and input checks of the CLI: 2 for anything knowable from the settings (before any
trial runs or anything is written), 1 when trials failed, 0 when every trial ran."""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

NEURONAV = str(Path(sys.executable).with_name("neuronav"))
SHORT = ["--set", "outbound_steps=100", "--set", "inbound_steps=100"]

# A third-party scenario, registered the way any plugin is (an entry point of an installed
# distribution): trial with seed s raises when s is in ``raise_seeds``.
PLUGIN = '''
from dataclasses import dataclass

from neuronav.config import field
from neuronav.runs.scenario import Scenario, ScenarioResult


@dataclass
class BrittleConfig:
    raise_seeds: str = field("", "comma-separated seeds whose trials raise")
    level: int = field(0, "a grid key", min=0)


class Brittle(Scenario):
    name = "brittle"
    description = "test-only: some trials raise"
    config_type = BrittleConfig
    backends = ("kinematic", "mujoco")
    default_backend = "kinematic"
    max_trials = 50

    def run(self, config, *, backend, trials, seed, video_path=None):
        bad = {int(s) for s in config.raise_seeds.split(",") if s}
        for s in range(seed, seed + trials):
            if s in bad:
                raise RuntimeError(f"trial with seed {s} broke")
        rows = [{"trial": i, "seed": seed + i, "success": False, "value": float(seed + i)} for i in range(trials)]
        return ScenarioResult(trials=rows)

    def figures(self, result, config, out_dir):
        return []
'''


@pytest.fixture(scope="module")
def plugin_env(tmp_path_factory):
    root = tmp_path_factory.mktemp("plugin")
    (root / "brittle_plugin.py").write_text(PLUGIN)
    info = root / "brittle_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: brittle-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[neuronav.scenarios]\nbrittle = brittle_plugin:Brittle\n")
    return dict(os.environ, PYTHONPATH=str(root))


def neuronav(*args, env=None, timeout=300):
    return subprocess.run([NEURONAV, *args], capture_output=True, text=True, timeout=timeout, env=env)


def assert_refused(result, *fragments):
    assert result.returncode == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


# -- 2: found before the first trial, nothing written -------------------------------------------------

@pytest.mark.parametrize("args, message", [
    (["run", "path-integration", "--backend", "mujoco", "--set", "protocol=stone2017"],
     "the stone2017 protocol moves point agents"),
    (["sweep", "path-integration", "--backend", "mujoco", "--grid", "protocol=i2bot,stone2017"],
     "the stone2017 protocol moves point agents"),
    (["compare", "path-integration", "--backends", "kinematic,mujoco", "--set", "protocol=stone2017"],
     "not 'mujoco'"),
    (["compare", "path-integration", "--backends", "kinematic,warp"], "unknown backend 'warp'"),
    (["compare", "path-integration", "--backends", "kinematic,,mujoco"], "--backends needs comma-separated"),
    (["run", "path-integration", "--backend", ""], "--backend needs a backend name, got ''"),
    (["run", "path-integration", "--trials", "1000000000"], "trials must be at most 1000000 per run"),
    (["sweep", "path-integration", "--grid", "noise=0.1,,0.2"], "--grid 'noise' has an empty value"),
    (["sweep", "locomotion", "--grid", "gait=tripod,,wave"], "--grid 'gait' has an empty value"),
    (["sweep", "path-integration", "--grid", "noise=0.1,"], "--grid 'noise' has an empty value"),
    (["run", "path-integration", "--scheduler", "http://127.0.0.1:8786"], "(http:// is its dashboard)"),
    (["run", "path-integration", "--scheduler", "tcp://127.0.0.1:1"], "cannot reach the Dask scheduler"),
    # Shorter than the brain's first look (and, for the compass, its second): every trial used to fail.
    (["run", "visual-compass", "--set", "duration_s=0.001"], "key 'duration_s' must be >= 1.28, got 0.001"),
    (["run", "visual-beacon", "--set", "timeout_s=0.001"], "key 'timeout_s' must be >= 0.64, got 0.001"),
    (["run", "odour-trail", "--set", "timeout_s=0.001"], "key 'timeout_s' must be >= 0.64, got 0.001"),
])
def test_errors_knowable_from_the_settings_exit_2_before_anything_runs(tmp_path, args, message):
    out = tmp_path / "out"
    result = neuronav(*args, "--out", str(out), timeout=60)  # no waiting for a scheduler's timeout
    assert_refused(result, message)
    assert not out.exists()


def test_the_config_file_is_checked_after_set_overrides_it(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("noise = 5.0\noutbound_steps = 100\ninbound_steps = 100\n")
    assert_refused(neuronav("run", "path-integration", "--config", str(bad), "--out", str(tmp_path / "a")),
                   f"config file {str(bad)!r}: key 'noise' must be <= 1.0")
    out = tmp_path / "b"
    result = neuronav("run", "path-integration", "--config", str(bad), "--set", "noise=0.2", "--no-figures",
                      "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert json.loads((out / "summary.json").read_text())["config"]["noise"] == 0.2
    # A grid value wins over the file too.
    result = neuronav("sweep", "path-integration", "--config", str(bad), "--grid", "noise=0.0,0.2", "--workers", "1",
                      "--no-figures", "--out", str(tmp_path / "c"))
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize("args", [["run", "visual-compass"], ["sweep", "cue-integration", "--grid", "trees=1,2"]])
def test_a_config_file_nested_500_deep_exits_2_in_one_line(tmp_path, args):
    """It used to print a 3,000-line RecursionError and exit 1."""
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 500 + "]" * 500 + "\n")
    out = tmp_path / "out"
    assert_refused(neuronav(*args, "--config", str(deep), "--out", str(out)), "nests tables or arrays more than 4 deep")
    assert not out.exists()


def test_a_scenarios_own_trial_cap_is_enforced(tmp_path, plugin_env):
    assert_refused(neuronav("run", "brittle", "--trials", "51", "--out", str(tmp_path / "o"), env=plugin_env),
                   "trials must be at most 50 per run of 'brittle', got 51")


# -- 1: trials failed; 0: every trial ran --------------------------------------------------------------

def test_an_ant_that_does_not_get_home_is_not_a_failure(tmp_path):
    out = tmp_path / "run"
    result = neuronav("run", "path-integration", "--trials", "2", "--set", "outbound_steps=200",
                      "--set", "inbound_steps=1", "--set", "success_radius=0.001", "--no-figures", "--out", str(out))
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert [r["success"] for r in rows] == ["False", "False"] and {r["status"] for r in rows} == {"ok"}


def test_run_with_failed_trials_exits_1_naming_the_count_and_first_reason(tmp_path, plugin_env):
    out = tmp_path / "run"
    result = neuronav("run", "brittle", "--trials", "5", "--set", "raise_seeds=3,1", "--out", str(out), env=plugin_env)
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip().splitlines() == [
        "neuronav: 2 of 5 trials failed; first: trial 1: RuntimeError: trial with seed 1 broke"]
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert [r["status"] for r in rows] == ["ok", "failed", "ok", "failed", "ok"]
    clean = neuronav("run", "brittle", "--trials", "5", "--out", str(tmp_path / "clean"), env=plugin_env)
    assert clean.returncode == 0 and clean.stderr == ""


def test_sweep_and_compare_with_failed_trials_exit_1(tmp_path, plugin_env):
    result = neuronav("sweep", "brittle", "--grid", "level=0,1", "--trials", "3", "--set", "raise_seeds=2",
                      "--workers", "2", "--out", str(tmp_path / "sweep"), env=plugin_env)
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip().splitlines() == [
        "neuronav: 2 of 6 trials failed; first: level=0 trial 2: RuntimeError: trial with seed 2 broke"]
    result = neuronav("compare", "brittle", "--backends", "kinematic,mujoco", "--trials", "2",
                      "--set", "raise_seeds=0", "--out", str(tmp_path / "cmp"), env=plugin_env)
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip().splitlines()[-1] == (
        "neuronav: 2 of 4 trials failed; first: kinematic trial 0: RuntimeError: trial with seed 0 broke")
    assert "| kinematic |" in result.stdout and "| mujoco |" in result.stdout


# -- compare on several backends ---------------------------------------------------------------------

def test_compare_runs_path_integration_on_kinematic_and_mujoco(tmp_path):
    pytest.importorskip("mujoco")
    out = tmp_path / "cmp"
    result = neuronav("compare", "path-integration", "--backends", "kinematic,mujoco", "--trials", "2",
                      "--set", "outbound_s=1", "--set", "homing_timeout_s=1", "--out", str(out))
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader((out / "compare.csv").open()))
    assert [r["backend"] for r in rows] == ["kinematic", "mujoco"]
    assert all(r["trials"] == "2" and r["failed_trials"] == "0" for r in rows)
    for backend in ("kinematic", "mujoco"):
        summary = json.loads((out / backend / "summary.json").read_text())
        assert summary["backend"] == backend and summary["config"]["protocol"] == "i2bot"  # one protocol for both
    assert (out / "compare.png").stat().st_size > 5000


def test_compare_refuses_other_settings_in_any_backend_folder_before_running_the_first(tmp_path, plugin_env):
    out = tmp_path / "cmp"
    first = neuronav("compare", "brittle", "--backends", "mujoco", "--set", "level=1", "--out", str(out),
                     env=plugin_env)
    assert first.returncode == 0, first.stderr
    again = neuronav("compare", "brittle", "--backends", "kinematic,mujoco", "--set", "level=2", "--out", str(out),
                     env=plugin_env)
    assert_refused(again, f"run directory {str(out / 'mujoco')!r} holds results with other settings",
                   "config.level: 1 there, 2 now")
    assert not (out / "kinematic").exists()


def test_a_scheduler_address_where_something_else_listens_is_refused_in_one_line(tmp_path):
    """A web server (silent until asked) or any other service on the port: refused, no hang, no traceback."""
    import socket
    import threading

    with socket.create_server(("127.0.0.1", 0)) as silent, socket.create_server(("127.0.0.1", 0)) as chatty:
        def greet():
            try:
                connection, _ = chatty.accept()
                with connection:
                    connection.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")
                    connection.recv(1)
            except OSError:  # the probe hung up, or the server closed at the end of the test
                pass

        threading.Thread(target=greet, daemon=True).start()
        for server, message in ((silent, "no Dask scheduler answered within 5 s"),
                                (chatty, "what listens there is not a Dask scheduler")):
            address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
            result = neuronav("run", "path-integration", "--scheduler", address, "--out", str(tmp_path / "o"),
                              timeout=60)
            assert_refused(result, message)
            assert not (tmp_path / "o").exists()


def test_rules_between_fields_see_the_set_values_that_win_over_the_file(tmp_path):
    """min_acceleration <= max_acceleration: a file's min checked against --set's max, not the default."""
    settings = tmp_path / "fast.toml"
    settings.write_text("min_acceleration = 0.3\noutbound_steps = 100\ninbound_steps = 100\n")
    assert_refused(neuronav("run", "path-integration", "--config", str(settings), "--out", str(tmp_path / "a")),
                   f"config file {str(settings)!r}:", "min_acceleration")
    out = tmp_path / "b"
    result = neuronav("run", "path-integration", "--config", str(settings), "--set", "max_acceleration=0.5",
                      "--no-figures", "--out", str(out))
    assert result.returncode == 0, result.stderr
    config = json.loads((out / "summary.json").read_text())["config"]
    assert (config["min_acceleration"], config["max_acceleration"]) == (0.3, 0.5)
