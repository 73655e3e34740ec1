"""The ant's plain-Python solvers (bodies/desert_ant/solvers.py) give exactly scipy's doubles.

scipy stays the reference here: each solver is compared with the scipy routine it replaces on
thousands of random problems (equal as doubles, not close), and whole ants built with the solvers
are compared with ants built with scipy (``repr`` equal: every float of the spec).
"""

import importlib
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import brentq as scipy_brentq
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation

from bodies.desert_ant import desert_ant
from bodies.desert_ant.solvers import brentq, minimize_bounded, quat_from_matrix
from neuronav.body import quat_to_matrix

ant_body = importlib.import_module("bodies.desert_ant.body")  # `bodies.desert_ant` is also a function


def _scipy_minimize_bounded(f, low, high, xatol=1e-5, maxiter=500):
    return minimize_scalar(f, bounds=(low, high), method="bounded",
                           options={"xatol": xatol, "maxiter": maxiter}).x


def _scipy_quat(matrix):
    x, y, z, w = Rotation.from_matrix(matrix).as_quat()
    return (float(w), float(x), float(y), float(z))


def _same(a, b) -> bool:
    """Equal as doubles (``-0.0`` and ``0.0`` told apart)."""
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    return a.shape == b.shape and a.tobytes() == b.tobytes()


ANTS = [{}, {"scale": 0.7}, {"scale": 1.3}, {"leg_length_factors": {"HL": 1.2, "HR": 1.2}},
        {"leg_length_factors": {"FL": 0.8, "MR": 1.15, "HL": 0.9}}, {"antenna_length_m": 0.4},
        {"scale": 0.85, "leg_length_factors": {"ML": 1.1, "MR": 1.1}, "antenna_length_m": 0.3},
        {"standing_height_m": 0.38}]


@pytest.mark.parametrize("kwargs", ANTS, ids=lambda k: repr(k))
def test_an_ant_solved_in_python_equals_one_solved_by_scipy_bit_for_bit(kwargs, monkeypatch):
    ours = desert_ant(**kwargs)
    monkeypatch.setattr(ant_body, "brentq", scipy_brentq)
    monkeypatch.setattr(ant_body, "minimize_bounded", _scipy_minimize_bounded)
    monkeypatch.setattr(ant_body, "quat_from_matrix", _scipy_quat)
    assert repr(desert_ant(**kwargs)) == repr(ours)


def _claw_problem(rng):
    """A random coxa-tilt problem of the ant's kind: lengths, rest angles, anchor, target depth."""
    lengths = (0.0, *rng.uniform(0.05, 0.4, 3))
    rest = (0.0, 0.0, *rng.uniform(-1.5, 1.5, 3))
    anchor_z = rng.uniform(-0.1, 0.1)
    return lengths, rest, anchor_z


def test_brentq_equals_scipy_on_random_problems():
    rng = np.random.default_rng(1)
    checked = 0
    for trial in range(3000):
        kind = trial % 3
        if kind == 0:  # the ant's own function, at a random target depth
            lengths, rest, anchor_z = _claw_problem(rng)
            target = rng.uniform(-0.3, 0.6)

            def f(t, lengths=lengths, rest=rest, anchor_z=anchor_z, target=target):
                return ant_body._claw_depth(t, anchor_z, lengths, rest) - target
        elif kind == 1:  # a cubic with a random root
            c = rng.normal(size=4)

            def f(t, c=c):
                return ((c[0] * t + c[1]) * t + c[2]) * t + c[3]
        else:  # tanh and sine, steep or flat
            k, s, r = rng.uniform(0.1, 50), rng.uniform(-0.5, 0.5), rng.uniform(-1, 1)

            def f(t, k=k, s=s, r=r):
                return math.tanh(k * (t - r)) + s * math.sin(3 * t)
        a, b = sorted(rng.uniform(-2, 2, 2))
        if not f(a) * f(b) < 0:
            continue
        xtol = float(10.0 ** rng.uniform(-15, -3))
        assert _same(brentq(f, a, b, xtol=xtol), scipy_brentq(f, a, b, xtol=xtol)), (trial, a, b, xtol)
        checked += 1
    assert checked > 1000


def test_minimize_bounded_equals_scipy_on_random_problems():
    rng = np.random.default_rng(2)
    for trial in range(2000):
        kind = trial % 3
        if kind == 0:
            lengths, rest, anchor_z = _claw_problem(rng)

            def f(t, lengths=lengths, rest=rest, anchor_z=anchor_z):
                return -ant_body._claw_depth(t, anchor_z, lengths, rest)
        elif kind == 1:
            c = rng.normal(size=4)

            def f(t, c=c):
                return ((c[0] * t + c[1]) * t + c[2]) * t + c[3]
        else:
            k, r = rng.uniform(0.5, 20), rng.uniform(-2, 2)

            def f(t, k=k, r=r):
                return math.cos(k * t) + abs(t - r)
        low, high = sorted(rng.uniform(-3, 3, 2))
        xatol = float(10.0 ** rng.uniform(-13, -2))
        maxiter = 500 if trial % 7 else int(rng.integers(3, 20))
        assert _same(minimize_bounded(f, low, high, xatol=xatol, maxiter=maxiter),
                     _scipy_minimize_bounded(f, low, high, xatol=xatol, maxiter=maxiter)), trial


def _random_rotations(rng, n):
    """Rotation matrices as the ant makes them (from quaternions, products, stacked frames) and edge cases."""
    for _ in range(n):
        q = rng.normal(size=4)
        yield quat_to_matrix(tuple(q / np.linalg.norm(q)))
        a, b = rng.normal(size=4), rng.normal(size=4)
        yield quat_to_matrix(tuple(a / np.linalg.norm(a))) @ quat_to_matrix(tuple(b / np.linalg.norm(b)))
        look, up = rng.normal(size=3), rng.normal(size=3)
        z = -look / np.linalg.norm(look)
        y = up - (up @ z) * z
        y /= np.linalg.norm(y)
        yield np.column_stack([np.cross(y, z), y, z])
        yield Rotation.random(rng=rng).as_matrix()
    for axis in np.eye(3):  # half turns and quarter turns: ties in the trace and diagonal
        for angle in (0.0, math.pi / 2, math.pi, -math.pi / 2, 2 * math.pi / 3):
            yield Rotation.from_rotvec(axis * angle).as_matrix()
    yield np.eye(3)
    yield np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 0]])


def test_quat_from_matrix_equals_scipy_on_random_rotations():
    rng = np.random.default_rng(3)
    count = 0
    for matrix in _random_rotations(rng, 1500):
        assert _same(quat_from_matrix(matrix), _scipy_quat(matrix)), matrix
        count += 1
    assert count > 6000


def test_quat_from_matrix_hands_what_scipy_orthogonalises_to_scipy():
    rng = np.random.default_rng(4)
    for _ in range(50):
        matrix = Rotation.random(rng=rng).as_matrix() + rng.normal(scale=1e-6, size=(3, 3))
        assert _same(quat_from_matrix(matrix), _scipy_quat(matrix))
    with pytest.raises(ValueError):
        quat_from_matrix(np.diag([1.0, 1.0, -1.0]))


def test_building_an_ant_imports_neither_scipy_optimize_nor_spatial():
    code = ("import sys; from bodies.desert_ant import desert_ant; desert_ant(); desert_ant(scale=0.7); "
            "print(sorted(m for m in ('scipy.optimize', 'scipy.spatial') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
