"""The unicycle calibration writes the package's table (the desert ant's, in its body folder) only when
asked to, and checks where it writes before the long measurement starts."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

import neuronav.scenarios.tools.calibrate_unicycle as calibrate
from neuronav.bodies.desert_ant.unicycle import table_path

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = table_path("mujoco")


def run_module(*args, cwd):
    return subprocess.run([sys.executable, "-m", "neuronav.scenarios.tools.calibrate_unicycle", *args],
                          capture_output=True, text=True, timeout=120, cwd=cwd)


@pytest.fixture
def fake_measure(monkeypatch):
    calls = []

    def measure(backend, duration_s, seed=0):
        calls.append((backend, duration_s))
        return {"source": "test", "turn": [0.0], "stride_rad": [0.1], "speed_m_s": [[0.0]], "turn_rate_rad_s": [[0.0]]}

    monkeypatch.setattr(calibrate, "measure", measure)
    return calls


def test_the_default_output_is_the_current_folder_not_the_package(tmp_path, monkeypatch, fake_measure):
    shipped = SHIPPED.read_bytes()
    monkeypatch.chdir(tmp_path)
    assert calibrate.main(["--duration", "0.5"]) == 0
    assert fake_measure == [("mujoco", 0.5)]
    assert json.loads((tmp_path / "unicycle_mujoco.json").read_text())["source"] == "test"
    assert SHIPPED.read_bytes() == shipped


def test_writing_the_package_table_needs_the_flag(tmp_path, fake_measure):
    shipped = SHIPPED.read_bytes()
    with pytest.raises(SystemExit) as exit_info:
        calibrate.main(["--out", str(SHIPPED)])
    assert exit_info.value.code == 2 and fake_measure == []  # refused before measuring
    assert SHIPPED.read_bytes() == shipped
    args, out = calibrate.output_path(["--write-package-table", "--backend", "pybullet"])
    assert out == ROOT / "bodies" / "desert_ant" / "unicycle_pybullet.json" and args.backend == "pybullet"


@pytest.mark.parametrize("args, message", [
    (["--out", "x.json", "--write-package-table"], "not allowed with argument"),
    (["--out", "no/such/folder/x.json"], "does not exist"),
    (["--duration", "0"], "--duration must be positive"),
])
def test_bad_arguments_exit_2_at_once(tmp_path, args, message):
    shipped = SHIPPED.read_bytes()
    result = run_module(*args, cwd=ROOT)
    assert result.returncode == 2 and message in result.stderr, result.stderr
    assert "turn" not in result.stdout  # no measurement started
    assert SHIPPED.read_bytes() == shipped
