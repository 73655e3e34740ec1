"""Public entry points refuse bad input with the project's own errors, never hang, never return NaN.

Each case below once escaped as a bare ValueError / TypeError / IndexError, hung on a size it could
have refused, or returned NaN without a word (issue 20, "The Python API").
"""

from __future__ import annotations

import contextlib
import signal

import numpy as np
import pytest

from neuronav.backends.kinematic import KinematicBackend
from neuronav.brains.cx import decode_home_vector, preferred_headings_rad
from neuronav.brains.mushroom_body import learn_views, mushroom_body, novelty
from neuronav.brains.ring import ring_attractor
from neuronav.brains.vision import ZernikeBasis, compass_command
from neuronav.brains.visual_homing import homing_direction, ridf, skyline_view
from neuronav.errors import CircuitError, ConfigError, PortError, SimulationError
from neuronav.scenarios.worlds.scenes import forest, landmark
from neuronav.senses.chemistry import MAX_PLUME_STEPS, Chemistry, OdourScene
from neuronav.senses.odour import ImageTrail, PolylineTrail, loop_trail, rasterise
from neuronav.senses.plume import OdourSource, Plume, PlumeConfig, WindConfig
from neuronav.senses.raycast import RayCaster
from neuronav.senses.trail_floor import build_trail_floor
from neuronav.spec.world import Appearance, Ground, PointAgents, PointAntenna, World, WorldObject

NAN, INF = float("nan"), float("inf")


@contextlib.contextmanager
def within(seconds: int):
    """Fail (instead of hanging the suite) when the block runs longer than ``seconds``."""
    def expire(*_):
        raise AssertionError(f"still running after {seconds} s: the call hangs instead of refusing its input")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def one_line(error: pytest.ExceptionInfo) -> str:
    message = str(error.value)
    assert message and "\n" not in message, message
    return message


# -- seeds ------------------------------------------------------------------------------------------

def test_a_negative_seed_is_refused_by_the_plume_the_chemistry_and_the_ground():
    with pytest.raises(ConfigError, match="seed"):
        Plume(PlumeConfig(), seed=-1)
    chemistry = Chemistry(OdourScene(plume=PlumeConfig()))
    with pytest.raises(ConfigError, match="seed"):
        chemistry.reset(-1)
    with pytest.raises(ConfigError, match="seed"):
        chemistry.reset(1.5)
    with pytest.raises(ConfigError, match="seed"):
        Ground(kind="uneven", roughness_m=0.1, seed=-1)
    with pytest.raises(ConfigError, match="seed"):
        Plume(PlumeConfig(), seed="abc")


# -- the plume's clock and rates ------------------------------------------------------------------

@pytest.mark.parametrize("time_s", [NAN, INF, -1.0, "abc"])
def test_advance_to_a_time_that_is_not_a_finite_time_is_refused(time_s):
    chemistry = Chemistry(OdourScene(plume=PlumeConfig()))
    with pytest.raises(ConfigError, match="time_s") as error:
        chemistry.advance_to(time_s)
    one_line(error)


def test_huge_rates_and_steps_are_refused():
    with pytest.raises(ConfigError, match="release_rate_hz"):
        OdourSource(release_rate_hz=1e308)
    plume = Plume(PlumeConfig())
    with pytest.raises(ConfigError, match="dt_s"):
        plume.advance(1e308)
    with pytest.raises(ConfigError, match="steps"):
        plume.advance(0.01, 10 ** 12)
    with pytest.raises(ConfigError, match="puff_amount"):
        OdourSource(puff_amount=1e308)
    with pytest.raises(ConfigError, match="max_puffs"):
        PlumeConfig(max_puffs=10 ** 12)
    with pytest.raises(ConfigError, match="bandwidth_rad_s"):
        WindConfig(bandwidth_rad_s=1e308)


def test_long_warmups_and_advances_are_refused_at_once_not_run():
    with within(5):
        with pytest.raises(ConfigError, match="warmup_s"):
            OdourScene(plume=PlumeConfig(), warmup_s=1e7)
        chemistry = Chemistry(OdourScene(plume=PlumeConfig()))
        with pytest.raises(ConfigError, match="time_s"):
            chemistry.advance_to(1e7)
        with pytest.raises(ConfigError, match="plume_dt_s"):
            OdourScene(plume=PlumeConfig(), warmup_s=10.0, plume_dt_s=1e-9)
    # The documented maximum itself is accepted (and a plume without puffs costs nothing to check).
    Chemistry(OdourScene()).advance_to(MAX_PLUME_STEPS * 0.01)


def test_odour_and_wind_at_points_that_are_not_finite_are_refused():
    chemistry = Chemistry(OdourScene(trails=(PolylineTrail([[0, 0], [1, 0]]),), plume=PlumeConfig(), warmup_s=1.0))
    for read in (chemistry.odour_at, chemistry.wind_at):
        with pytest.raises(ConfigError, match="finite"):
            read(np.array([[NAN, 0.0, 0.0]]))
    with pytest.raises(ConfigError, match="within"):
        chemistry.odour_at(np.array([[1e300, -1e300, 0.0]]))  # its squares would overflow into NaN
    assert np.isfinite(chemistry.odour_at(np.array([[1e6, -1e6, 0.0], [4.0, 0.0, 0.0]]))).all()


# -- trails, ground, objects -----------------------------------------------------------------------

def test_a_trail_of_letters_is_a_config_error():
    with pytest.raises(ConfigError, match="vertices_m"):
        PolylineTrail("abc")
    with pytest.raises(ConfigError, match="image"):
        ImageTrail("abc", (0, 1), (0, 1))
    with pytest.raises(ConfigError, match="edge_m"):
        PolylineTrail([[0, 0], [1, 0]], edge_m="x")
    with pytest.raises(ConfigError, match="query points"):
        PolylineTrail([[0, 0], [1, 0]]).concentration_at("abc")


def test_sizes_that_would_hang_or_fill_memory_are_refused():
    with within(5):
        with pytest.raises(ConfigError, match="n_vertices"):
            loop_trail(n_vertices=10 ** 10)
        with pytest.raises(ConfigError, match="shape_px"):
            rasterise(PolylineTrail([[0, 0], [1, 0]]), (0, 1), (0, 1), (10 ** 6, 10 ** 6))
        with pytest.raises(ConfigError, match="count"):
            forest(10 ** 9, seed=0)
        with pytest.raises(ConfigError, match="cells"):
            Ground(kind="uneven", roughness_m=0.1, cells=10 ** 6)
        with pytest.raises(ConfigError, match="feature_m"):
            Ground(kind="uneven", roughness_m=0.1, feature_m=1e9)


@pytest.mark.parametrize("label, value", [("roughness_m", NAN), ("roughness_m", INF), ("size_m", INF),
                                          ("friction", INF), ("wall_height_m", NAN)])
def test_a_ground_that_is_not_finite_is_refused(label, value):
    with pytest.raises(ConfigError, match=label):
        Ground(kind="uneven", **{label: value})


def test_an_object_the_kinematic_backend_refuses_is_refused_in_the_world_for_every_backend():
    with pytest.raises(ConfigError, match=r"world object 0 \(box\): position_m"):
        World(objects=(WorldObject("box", (NAN, 0.0, 0.0), (1.0, 1.0, 1.0)),))
    with pytest.raises(ConfigError, match=r"world object 1 \(sphere\): size_m"):
        World(objects=(WorldObject("box", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)), WorldObject("sphere", (0, 0, 0), (INF,))))
    with pytest.raises(ConfigError, match="rgba"):
        World(objects=(WorldObject("box", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (NAN, 0, 0, 1)),))
    with pytest.raises(ConfigError, match="WorldObject"):
        World(objects=("box",))
    with pytest.raises(ConfigError, match="landmark"):
        landmark(radius_m=NAN)
    with pytest.raises(ConfigError, match="adhesion_n"):
        World(adhesion_n=INF)


# -- brains ------------------------------------------------------------------------------------------

def test_a_mushroom_body_too_large_for_memory_is_refused_at_once():
    with within(5):
        with pytest.raises(ConfigError, match="n_kc") as error:
            mushroom_body(n_kc=10 ** 7)
    one_line(error)


def test_novelty_and_learning_need_codes_of_shape_views_by_pn():
    compiled = mushroom_body(n_pn=12, n_kc=40, inputs_per_kc=3).compile(batch=2)
    for codes in (np.zeros(12), np.zeros((3, 5)), np.full((2, 12), NAN), "abc"):
        with pytest.raises(ConfigError, match="codes"):
            novelty(compiled, codes)
        with pytest.raises(ConfigError, match="codes"):
            learn_views(compiled, codes)
    assert novelty(compiled, np.zeros((0, 12))).shape == (0,)


def test_load_weights_from_an_npy_file_is_a_circuit_error(tmp_path):
    compiled = mushroom_body(n_pn=12, n_kc=40, inputs_per_kc=3).compile(batch=1)
    np.save(tmp_path / "weights.npy", np.ones((1, 1, 40)))
    with pytest.raises(CircuitError, match="npz") as error:
        compiled.load_weights(tmp_path / "weights.npy")
    one_line(error)
    (tmp_path / "junk.npz").write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(CircuitError, match="npz"):
        compiled.load_weights(tmp_path / "junk.npz")


def test_visual_homing_refuses_views_that_are_not_finite():
    views = np.zeros((1, 4, 8))
    with pytest.raises(ConfigError, match="finite"):
        ridf(np.full((1, 4, 8), NAN), views)
    with pytest.raises(ConfigError, match="finite"):
        ridf(views, np.full((1, 4, 8), INF))
    with pytest.raises(ConfigError, match="finite"):
        skyline_view(np.full((1, 8, 8), NAN))
    with pytest.raises(ConfigError, match="band_deg"):
        skyline_view(np.zeros((1, 8, 8)), "abc")
    with pytest.raises(ConfigError, match="heading_rad"):
        homing_direction(views, np.array([NAN]), views)
    with pytest.raises(ConfigError, match="at least one snapshot"):
        homing_direction(views, np.zeros(len(views)), views[:0])
    # No views (an empty batch): empty answers, not a reshape error (found by the input property test).
    assert [part.shape for part in homing_direction(views[:0], (), views)] == [(0,), (0,), (0,)]
    with pytest.raises(ConfigError, match="finite"):
        ridf(np.full((1, 4, 8), 1e300), views)  # its squares would overflow
    assert np.isfinite(ridf(np.full((1, 4, 8), 1e50), views)).all()


# -- the kinematic backend ------------------------------------------------------------------------

def point_backend(count=2, antennae=()):
    backend = KinematicBackend()
    backend.load(World(odour=OdourScene(plume=PlumeConfig(), warmup_s=2.0)),
                 [PointAgents(count=count, mode="unicycle", antennae=antennae)])
    return backend


@pytest.mark.parametrize("start", [dict(position_m=(1.0, 2.0, 3.0)), dict(position_m=np.zeros((5, 2))),
                                   dict(position_m=(NAN, 0.0)), dict(position_m="ab"), dict(heading_rad=NAN),
                                   dict(heading_rad=np.zeros(3)), dict(yaw_rad=INF)])
def test_a_wrong_start_pose_on_the_kinematic_backend_is_a_config_error(start):
    backend = point_backend()
    with pytest.raises(ConfigError) as error:
        backend.reset(**start)
    one_line(error)
    backend.reset(position_m=np.array([[0.0, 1.0], [2.0, 3.0]]), heading_rad=[0.1, 0.2])  # one per agent
    np.testing.assert_array_equal(backend.read(["position"])["position"], [[0.0, 1.0], [2.0, 3.0]])


def test_a_nan_antenna_yaw_is_refused_as_a_nan_turn_is():
    backend = point_backend(count=1, antennae=(PointAntenna("left", (0.0, 0.0, 0.0), (0.1, 0.1, 0.0)),))
    backend.reset(position_m=(0.5, 0.0))  # at the plume's source, where the odour is not 0
    with pytest.raises(PortError, match="antenna_yaw.*finite"):
        backend.write({"antenna_yaw": np.array([[NAN]])})
    odour = backend.read(["odour"])["odour"]
    assert np.isfinite(odour).all() and odour.max() > 0
    backend.write({"turn": np.array([[NAN]])})
    with pytest.raises(SimulationError, match="diverged"):
        backend.step()



# -- siblings of the reported cases ------------------------------------------------------------------

def test_siblings_of_the_reported_cases_are_refused_with_config_errors():
    with within(5):
        cases = [
            (lambda: OdourSource(odour=10 ** 12), "odour"),  # a channel axis of 10^12 per query point
            (lambda: PolylineTrail([[0, 0], [1, 0]], odour=10 ** 9), "odour"),
            (lambda: ImageTrail([[0.1, 0.2], [0.3]], (0, 1), (0, 1)), "image"),
            (lambda: PointAgents(count=10 ** 12), "count"),
            (lambda: PointAgents(mass_kg=INF), "mass_kg"),
            (lambda: Ground().height_at(NAN, 0.0), "finite"),
            (lambda: build_trail_floor([PolylineTrail([[0, 0], [1, 0]])], Appearance(), max_side_px=10 ** 6),
             "max_side_px"),
            (lambda: build_trail_floor([PolylineTrail([[0, 0], [1, 0]])], Appearance(), pixel_m="x"), "pixel_m"),
            (lambda: ZernikeBasis(10 ** 5, 10 ** 5), "memory"),
            (lambda: ZernikeBasis(8, 8, n_max=10 ** 6), "n_max"),
            (lambda: compass_command("north", 0.0), "compass_command"),
            (lambda: RayCaster(World(), np.zeros((2, 2, 3))).render("abc", np.eye(3)), "eyes_m"),
            (lambda: RayCaster(World(), np.zeros((2, 2, 3))).render(np.zeros(4), np.eye(3)), "eyes_m"),
            (lambda: forest(3, seed=-1), "seed"),
            (lambda: Plume(PlumeConfig()).rasterise(z_m="high"), "z_m"),
            (lambda: ring_attractor(n_cells=10 ** 7), "n_cells"),  # a 728 TiB weight matrix
            (lambda: preferred_headings_rad(10 ** 10), "size"),
            (lambda: decode_home_vector(np.zeros(3)), "cpu4"),
        ]
        for call, match in cases:
            with pytest.raises(ConfigError, match=match) as error:
                call()
            one_line(error)
