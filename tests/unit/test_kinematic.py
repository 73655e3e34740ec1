"""The kinematic backend: Stone's agent and the unicycle against their equations."""

import numpy as np
import pytest

from neuronav import PortError, registry
from neuronav.backends.kinematic import KinematicBackend, default_calibration, geometric_calibration
from neuronav.engine.backend import Backend
from neuronav.errors import ConfigError, RegistryError, SimulationError
from neuronav.spec.unicycle import load_calibration
from neuronav.spec.world import PointAgents, World


def engine(count=2, mode="stone", drag=0.15, calibration=None):
    backend = KinematicBackend(calibration=calibration)
    backend.load(World(), [PointAgents(count=count, mode=mode, drag=drag)])
    return backend


def test_implements_the_backend_protocol():
    assert isinstance(engine(), Backend)


def test_stone_agent_reaches_terminal_speed():
    backend = engine(count=3)
    backend.write({"acceleration": np.full((3, 1), 0.15), "rotation": np.zeros((3, 1))})
    backend.step(200)
    speed = backend.read(["speed"])["speed"][:, 0]
    # v = (v + a)(1 - d) has the fixed point a(1 - d)/d: Stone's top speed 0.85.
    np.testing.assert_allclose(speed, 0.15 * 0.85 / 0.15, rtol=1e-9)
    np.testing.assert_allclose(backend.read(["heading"])["heading"], 0.0)
    assert np.all(backend.read(["position"])["position"][:, 1] > 150)  # heading 0 moves along +y


def test_stone_rotation_accumulates_and_sets_direction():
    backend = engine(count=2)
    backend.write({"rotation": np.array([[np.pi / 20], [-np.pi / 20]]), "acceleration": np.full((2, 1), 0.1)})
    backend.step(10)
    heading = backend.read(["heading"])["heading"][:, 0]
    np.testing.assert_allclose(heading, [np.pi / 2, -np.pi / 2])
    velocity = backend.read(["velocity"])["velocity"]
    assert velocity[0, 0] > 0 > velocity[1, 0]  # clockwise from +y: +90 deg faces +x


def test_unicycle_straight_and_turning_on_the_spot():
    backend = engine(count=3, mode="unicycle", calibration=geometric_calibration())
    backend.write({"turn": np.array([0.0, 1.0, -1.0]), "stride": np.full(3, np.radians(20))})
    backend.step(125)  # one second at 8 ms
    position = backend.read(["position"])["position"]
    heading = backend.read(["heading"])["heading"][:, 0]
    assert backend.time == pytest.approx(1.0)
    assert position[0, 1] > 0.2 and abs(position[0, 0]) < 1e-12 and heading[0] == 0.0
    np.testing.assert_allclose(position[1:], 0.0, atol=1e-12)  # turn = ±1: on the spot
    assert heading[1] < 0 < heading[2]  # turn > 0 turns left (counter-clockwise)


def test_unicycle_turn_rate_is_monotone_in_turn():
    calibration = geometric_calibration()
    stride = calibration.stride_rad.searchsorted(np.radians(20))
    assert np.all(np.diff(calibration.turn_rate_rad_s[:, stride]) <= 0)


def test_bad_commands_and_sensors_are_clear_errors():
    backend = engine(count=2)
    with pytest.raises(PortError,
                       match="no sensor 'odour'.*available: head_pos, head_quat, heading, position, speed, velocity"):
        backend.read(["odour"])
    with pytest.raises(PortError, match="accepts no command 'thrust'"):
        backend.write({"thrust": np.zeros((2, 1))})
    with pytest.raises(PortError, match=r"must have shape \(2, 1\)"):
        backend.write({"rotation": np.zeros((3, 1))})
    with pytest.raises(SimulationError, match="no cameras"):
        backend.render("head")
    with pytest.raises(ConfigError, match="mode 'legged' is unknown"):
        PointAgents(mode="legged")


def test_divergence_stops_with_a_reason():
    backend = engine(count=1)
    backend.write({"acceleration": np.full((1, 1), np.inf)})
    with pytest.raises(SimulationError, match="diverged"):
        backend.step()


def test_apply_force_pushes_one_agent():
    backend = engine(count=2, drag=0.0)
    backend.apply_force(1, "thorax", np.array([2.0, 0.0, 0.0]))
    backend.step()
    position = backend.read(["position"])["position"]
    np.testing.assert_allclose(position, [[0, 0], [2.0, 0]])


def test_measured_calibration_round_trip_and_bad_files(tmp_path):
    import json

    table = {"source": "test", "turn": [-1, 0, 1], "stride_rad": [0.0, 0.5],
             "speed_m_s": [[0, 0.1], [0, 0.4], [0, 0.1]], "turn_rate_rad_s": [[0, 1], [0, 0], [0, -1]]}
    path = tmp_path / "table.json"
    path.write_text(json.dumps(table))
    backend = KinematicBackend(calibration=load_calibration(path))
    backend.load(World(), [PointAgents(count=1, mode="unicycle")])
    backend.write({"turn": np.zeros(1), "stride": np.full(1, 0.25)})
    backend.step(125)
    # Halfway between strides 0 and 0.5 at turn 0: 0.2 m/s for one second.
    np.testing.assert_allclose(backend.read(["position"])["position"], [[0.0, 0.2]], atol=1e-9)
    table["speed_m_s"] = [[0, 1]]
    path.write_text(json.dumps(table))
    with pytest.raises(ConfigError, match="tables must have shape"):
        load_calibration(path)
    path.write_text("{not json")
    with pytest.raises(ConfigError, match="cannot be read"):
        load_calibration(path)


def test_the_shipped_table_is_measured_on_mujoco_and_has_the_gait_shape():
    calibration = KinematicBackend().calibration
    assert calibration.source.startswith("measured on mujoco")
    stride = calibration.stride_rad.searchsorted(np.radians(15))
    straight = calibration.turn.searchsorted(0.0)
    speed, rate = calibration.speed_m_s[:, stride], calibration.turn_rate_rad_s[:, stride]
    assert speed[straight] > 0.3  # the tripod walks ~0.45 m/s at 15 degrees
    assert abs(speed[0]) < 0.1 * speed[straight] and abs(speed[-1]) < 0.1 * speed[straight]  # on the spot
    assert rate[0] > 0.5 and rate[-1] < -0.5  # turn > 0 turns left: the clockwise heading falls
    assert abs(rate[straight]) < 0.15 * abs(rate[-1])


def test_the_default_calibration_is_the_desert_ants_reached_by_name():
    """The backend walks by the body data registered as ``desert_ant`` (its folder's table), found through the
    registry; a body with no registered table gets the geometric one, and is told so."""
    registered = registry.load("unicycle_calibration", "desert_ant")()
    calibration = KinematicBackend().calibration
    for name in ("turn", "stride_rad", "speed_m_s", "turn_rate_rad_s"):
        np.testing.assert_array_equal(getattr(calibration, name), getattr(registered, name))
    assert calibration.source == registered.source
    with pytest.warns(RuntimeWarning, match="no unicycle calibration is registered for body 'no_such_body'"):
        assert default_calibration("no_such_body").source == geometric_calibration().source


def test_a_registered_calibration_that_cannot_load_is_an_error_not_the_geometric_table(monkeypatch):
    def broken(kind, name):
        raise RegistryError(f"{kind} {name!r} is not installed")

    monkeypatch.setattr(registry, "load", broken)
    with pytest.raises(RegistryError, match="'desert_ant' is not installed"):
        default_calibration("desert_ant")


@pytest.mark.parametrize("body", registry.names("unicycle_calibration"))
def test_every_registered_calibration_is_a_usable_table(body):
    """Each registered table covers turn [-1, 1] on increasing grids, finite, standing still at zero stride."""
    calibration = registry.load("unicycle_calibration", body)()
    turn, stride = calibration.turn, calibration.stride_rad
    assert turn[0] == -1.0 and turn[-1] == 1.0 and np.all(np.diff(turn) > 0)
    assert stride[0] == 0.0 and np.all(np.diff(stride) > 0)
    for table in (calibration.speed_m_s, calibration.turn_rate_rad_s):
        assert table.shape == (turn.size, stride.size) and np.isfinite(table).all()
        np.testing.assert_array_equal(table[:, 0], 0.0)


def test_rates_clip_the_commands_and_do_not_depend_on_the_batch():
    calibration = default_calibration()
    top = calibration.stride_rad[-1]
    speed, rate = calibration.rates([2.0, -3.0, 0.3], [9.0, -1.0, 0.2])
    clipped = calibration.rates([1.0, -1.0, 0.3], [top, 0.0, 0.2])
    np.testing.assert_array_equal(speed, clipped[0])
    np.testing.assert_array_equal(rate, clipped[1])
    assert speed[1] == 0.0 and rate[1] == 0.0  # no stride, no motion
    alone = [calibration.rates(0.3, 0.2)[i][0] for i in (0, 1)]
    assert [speed[2], rate[2]] == alone
    # Bilinear between the grid's nodes: halfway in stride is the mean of the two columns at a grid turn.
    j, i = 2, calibration.turn.searchsorted(0.5)
    middle = (calibration.stride_rad[j] + calibration.stride_rad[j + 1]) / 2
    np.testing.assert_allclose(calibration.rates(0.5, middle)[0], calibration.speed_m_s[i, j:j + 2].mean(), atol=1e-12)
