"""The default ant's kept solutions (bodies/desert_ant/solved.json) are exactly scipy's."""

import subprocess
import sys

import pytest

from neuronav.bodies.desert_ant import desert_ant

solved = sys.modules["neuronav.bodies.desert_ant.solved"]


def test_every_kept_value_is_what_scipy_solves_bit_for_bit():
    fresh = solved.solve_everything()
    assert fresh["tilts"] == solved.TABLE["tilts"]
    assert {k: tuple(v) for k, v in fresh["quats"].items()} == solved.TABLE["quats"]
    assert len(solved.TABLE["tilts"]) >= 3 and len(solved.TABLE["quats"]) >= 9


@pytest.mark.parametrize("kwargs", [{}, {"scale": 0.7}, {"leg_length_factors": {"HL": 1.2, "HR": 1.2}},
                                    {"antenna_length_m": 0.4}])
def test_an_ant_from_the_table_equals_one_solved_by_scipy(kwargs, monkeypatch):
    kept = desert_ant(**kwargs)
    monkeypatch.setattr(solved, "use_table", False)
    assert repr(desert_ant(**kwargs)) == repr(kept)


def test_building_the_default_ant_imports_no_scipy_optimize():
    code = ("import sys; from neuronav.bodies.desert_ant import desert_ant; desert_ant(); "
            "print('scipy.optimize' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
