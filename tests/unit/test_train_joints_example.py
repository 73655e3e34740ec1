"""examples/train_joints.py: joint-level training runs a few thousand 8 ms steps on MuJoCo without diverging."""

import csv
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def example():
    pytest.importorskip("mujoco", reason="mujoco is not installed")
    sys.path.insert(0, str(ROOT / "examples"))
    spec = importlib.util.spec_from_file_location("train_joints", ROOT / "examples" / "train_joints.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_pattern_generator_stands_at_zero_and_walks_the_tripod_in_antiphase(example):
    from neuronav.bodies.desert_ant import desert_ant

    body = desert_ant()
    rest, low, high = body.rest_pose_rad(), np.full(40, -3.0), np.full(40, 3.0)
    standing = example.PatternGenerator(np.zeros(6), body.joint_names, rest, low, high)
    np.testing.assert_allclose(standing({"home_vector": np.array([1.0, 0.0])}), rest, atol=1e-6)
    walking = example.PatternGenerator(np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.0]), body.joint_names, rest, low, high)
    walking.step = 20  # a quarter cycle (0.16 s) in: tripod A protracted, tripod B retracted
    targets = walking({"home_vector": np.array([1.0, 0.0])}) - rest
    names = body.joint_names
    assert targets[names.index("FL_ThCz")] == pytest.approx(0.3, abs=1e-6)
    assert targets[names.index("FR_ThCz")] == pytest.approx(-0.3, abs=1e-6)
    assert abs(targets[names.index("FL_CTr")]) < 1e-6 and abs(targets[names.index("head_pitch")]) < 1e-6


def test_a_quick_training_run_takes_thousands_of_steps_and_writes_its_curve(example, tmp_path, capsys):
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    steps = int(printed.split(" control steps without divergence")[0].split()[-1])
    assert steps >= 2000, printed
    with (tmp_path / "learning_curve.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 3 and all(np.isfinite(float(row["policy_return"])) for row in rows)
    assert (tmp_path / "learning_curve.png").stat().st_size > 0
