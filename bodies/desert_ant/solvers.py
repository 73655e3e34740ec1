"""The three scipy routines the desert ant's spec is solved with, in plain Python, bit for bit.

Building the ant solves each leg's coxa tilt (scipy's ``brentq`` and ``minimize_scalar`` with
``method="bounded"``) and turns rotation matrices into quaternions (``Rotation.from_matrix``).
Importing scipy.optimize and scipy.spatial costs about 0.23 s, a fifth of a short run's start-up,
so these are the same algorithms written again, step for step, so that every float operation
happens in the same order as in scipy 1.17 and every result is the same double:

- :func:`brentq`: scipy's C ``brentq`` (Brent 1973, Charles Harris's version in
  ``scipy/optimize/Zeros/brentq.c``), with scipy's defaults (``rtol = 4 eps``, 100 iterations).
- :func:`minimize_bounded`: scipy's ``_minimize_scalar_bounded`` (Brent's bounded minimiser,
  golden section plus parabolic steps, ``maxiter = 500``).
- :func:`quat_from_matrix`: ``Rotation.from_matrix(m).as_quat()`` (Markley 2008: the largest of
  the trace and the diagonal picks the formula, then the quaternion is normalised; no sign change).
  scipy first orthogonalises a matrix whose Gram matrix is not the identity within 1e-12 (by SVD,
  which LAPACK does and plain Python cannot repeat bit for bit): such a matrix, or one that is not
  right-handed, is handed to scipy itself.

``tests/unit/test_desert_ant_solvers.py`` compares each with scipy on thousands of random inputs
(exactly equal) and ants built with these with ants built with scipy (``repr`` equal).
"""

from __future__ import annotations

import math

_RTOL = 4 * 2.220446049250313e-16  # scipy's brentq default: 4 eps


def brentq(f, a: float, b: float, xtol: float = 2e-12, rtol: float = _RTOL, maxiter: int = 100) -> float:
    """A root of ``f`` in ``[a, b]`` (signs must differ at the ends), as ``scipy.optimize.brentq``."""
    if xtol <= 0:
        raise ValueError(f"xtol too small ({xtol:g} <= 0)")
    if rtol < _RTOL:
        raise ValueError(f"rtol too small ({rtol:g} < {_RTOL:g})")
    x_pre, x_cur = float(a), float(b)
    f_pre, f_cur = _value(f, x_pre), _value(f, x_cur)
    if f_pre * f_cur > 0:
        raise ValueError("f(a) and f(b) must have different signs")
    if f_pre == 0:
        return x_pre
    if f_cur == 0:
        return x_cur
    x_blk = f_blk = s_pre = s_cur = 0.0
    for _ in range(maxiter):
        if f_pre * f_cur < 0:  # the root lies between the last two estimates: the far end becomes pre
            x_blk, f_blk = x_pre, f_pre
            s_pre = s_cur = x_cur - x_pre
        if abs(f_blk) < abs(f_cur):  # keep the better estimate in cur
            x_pre, x_cur, x_blk = x_cur, x_blk, x_cur
            f_pre, f_cur, f_blk = f_cur, f_blk, f_cur
        delta = (xtol + rtol * abs(x_cur)) / 2
        s_bis = (x_blk - x_cur) / 2
        if f_cur == 0 or abs(s_bis) < delta:
            return x_cur
        if abs(s_pre) > delta and abs(f_cur) < abs(f_pre):
            if x_pre == x_blk:  # secant
                s_try = -f_cur * (x_cur - x_pre) / (f_cur - f_pre)
            else:  # inverse quadratic
                d_pre = (f_pre - f_cur) / (x_pre - x_cur)
                d_blk = (f_blk - f_cur) / (x_blk - x_cur)
                s_try = -f_cur * (f_blk * d_blk - f_pre * d_pre) / (d_blk * d_pre * (f_blk - f_pre))
            if 2 * abs(s_try) < min(abs(s_pre), 3 * abs(s_bis) - delta):
                s_pre, s_cur = s_cur, s_try
            else:
                s_pre = s_cur = s_bis
        else:
            s_pre = s_cur = s_bis
        x_pre, f_pre = x_cur, f_cur
        if abs(s_cur) > delta:
            x_cur += s_cur
        else:
            x_cur += delta if s_bis > 0 else -delta
        f_cur = _value(f, x_cur)
    raise RuntimeError(f"Failed to converge after {maxiter} iterations, value is {x_cur}.")


def _value(f, x: float) -> float:
    y = float(f(x))
    if math.isnan(y):
        raise ValueError(f"The function value at x={x} is NaN; solver cannot continue.")
    return y


def _sign(v: float) -> float:
    return 1.0 if v > 0 else -1.0 if v < 0 else 0.0


def minimize_bounded(f, low: float, high: float, xatol: float = 1e-5, maxiter: int = 500) -> float:
    """The minimiser of ``f`` on ``[low, high]``: ``minimize_scalar(f, bounds=..., method="bounded").x``."""
    if not (math.isfinite(low) and math.isfinite(high)):
        raise ValueError("Optimization bounds must be finite scalars.")
    if low > high:
        raise ValueError("The lower bound exceeds the upper bound.")
    sqrt_eps = math.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - math.sqrt(5.0))
    a, b = float(low), float(high)
    x_w = a + golden_mean * (b - a)  # scipy's fulc: third best
    x_v = x_f = x = x_w  # nfc: second best; xf: best so far
    step = previous = 0.0  # rat and e
    f_x = float(f(x))
    calls = 1
    f_w = f_v = f_x
    x_mid = 0.5 * (a + b)
    tol1 = sqrt_eps * abs(x_f) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(x_f - x_mid) > (tol2 - 0.5 * (b - a)):
        golden = True
        if abs(previous) > tol1:  # try a parabola through the three best points
            golden = False
            r = (x_f - x_v) * (f_x - f_w)
            q = (x_f - x_w) * (f_x - f_v)
            p = (x_f - x_w) * q - (x_f - x_v) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r = previous
            previous = step
            if abs(p) < abs(0.5 * q * r) and p > q * (a - x_f) and p < q * (b - x_f):
                step = (p + 0.0) / q
                x = x_f + step
                if (x - a) < tol2 or (b - x) < tol2:
                    step = tol1 * (_sign(x_mid - x_f) + float((x_mid - x_f) == 0))
            else:
                golden = True
        if golden:
            previous = (a - x_f) if x_f >= x_mid else (b - x_f)
            step = golden_mean * previous
        x = x_f + (_sign(step) + float(step == 0)) * max(abs(step), tol1)
        f_u = float(f(x))
        calls += 1
        if f_u <= f_x:
            if x >= x_f:
                a = x_f
            else:
                b = x_f
            x_w, f_w = x_v, f_v
            x_v, f_v = x_f, f_x
            x_f, f_x = x, f_u
        else:
            if x < x_f:
                a = x
            else:
                b = x
            if f_u <= f_v or x_v == x_f:
                x_w, f_w = x_v, f_v
                x_v, f_v = x, f_u
            elif f_u <= f_w or x_w == x_f or x_w == x_v:
                x_w, f_w = x, f_u
        x_mid = 0.5 * (a + b)
        tol1 = sqrt_eps * abs(x_f) + xatol / 3.0
        tol2 = 2.0 * tol1
        if calls >= maxiter:
            break
    return x_f


def quat_from_matrix(matrix) -> tuple[float, float, float, float]:
    """``Rotation.from_matrix(matrix).as_quat()`` of a 3 × 3 rotation matrix, as (w, x, y, z)."""
    m = [[float(matrix[i][j]) for j in range(3)] for i in range(3)]
    if not _orthonormal(m) or _det(m) <= 0:
        from scipy.spatial.transform import Rotation  # orthogonalised by SVD, or refused: scipy's own

        x, y, z, w = Rotation.from_matrix(matrix).as_quat()
        return (float(w), float(x), float(y), float(z))
    decision = (m[0][0], m[1][1], m[2][2], m[0][0] + m[1][1] + m[2][2])
    choice = 0
    for index in (1, 2, 3):  # the first largest
        if decision[index] > decision[choice]:
            choice = index
    q = [0.0, 0.0, 0.0, 0.0]  # x, y, z, w
    if choice != 3:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1 - decision[3] + 2 * m[i][i]
        q[j] = m[j][i] + m[i][j]
        q[k] = m[k][i] + m[i][k]
        q[3] = m[k][j] - m[j][k]
    else:
        q[0] = m[2][1] - m[1][2]
        q[1] = m[0][2] - m[2][0]
        q[2] = m[1][0] - m[0][1]
        q[3] = 1 + decision[3]
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    x, y, z, w = (v / norm for v in q)
    return (w, x, y, z)


def _orthonormal(m) -> bool:
    """scipy's test before it orthogonalises: ``isclose(m @ m.T, I, atol=1e-12)`` (rtol 1e-5)."""
    for i in range(3):
        for j in range(3):
            gram = m[i][0] * m[j][0] + m[i][1] * m[j][1] + m[i][2] * m[j][2]
            target = 1.0 if i == j else 0.0
            if not abs(gram - target) <= 1e-12 + 1e-5 * target:
                return False
    return True


def _det(m) -> float:
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
