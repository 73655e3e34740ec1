"""How the walking ant turns (scenarios/tools/turn_response.py): turn rate and crab angle per turn command."""

import pytest

from neuronav.scenarios.tools.turn_response import main, turn_response


def test_the_unicycle_turns_along_its_axis_at_its_calibrated_rate():
    """The kinematic unicycle never crabs; θ > 0 turns left (heading, clockwise, falls)."""
    left_deg, left_crab = turn_response("kinematic", 0.3)
    right_deg, right_crab = turn_response("kinematic", -0.3)
    assert left_deg < -10.0 and right_deg > 10.0
    assert abs(left_crab) < 0.5 and abs(right_crab) < 0.5


def test_the_mujoco_ant_walks_crabwise_toward_the_inside_of_its_turn():
    """Measured: θ = ±0.2 turns 12.8-13.0°/cycle with the body 7.6-8.2° off its path, pointing out of the turn
    (crab = mean heading minus the path's direction, + right); walking straight it crabs under 1°."""
    rate_deg, crab_deg = turn_response("mujoco", 0.2)
    assert rate_deg < -8.0 and crab_deg > 4.0
    rate_deg, crab_deg = turn_response("mujoco", -0.2)
    assert rate_deg > 8.0 and crab_deg < -4.0
    assert abs(turn_response("mujoco", 0.0)[1]) < 2.0


def test_bad_arguments_exit_2(capsys):
    for argv in (["--backends", "nope"], ["--turns", "2"], ["--turns", "left"]):
        with pytest.raises(SystemExit) as stop:
            main(argv)
        assert stop.value.code == 2
    assert "unknown backend 'nope'" in capsys.readouterr().err
