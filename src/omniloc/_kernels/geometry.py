"""The section-2 maths, once: the building blocks every engine and :mod:`omniloc.pose` call.

Pose from bearings (the seed paper's eqs. 1-6, after Betke & Gurvits): with ``L_0`` the
anchor landmark seen at bearing ``theta_0`` and ``z_i = comp<L_i - L_0>``::

    b_i = 1 / z_i                                   (eq. 2)
    a_i = exp(j (theta_i - theta_0)) b_i            (eq. 1)
    P_i = a_i a_i^T / a_i^T a_i - I                 (eq. 3)
    f   = -[sum P_i]^-1 sum P_i b_i                 (eq. 4)
    R   = L_0 - [f_x, -f_y] / |f|^2                 (eq. 5)
    theta = atan2(L_0y - R_y, L_0x - R_x) - theta_0 (eq. 6)

and the least-squares distance ratios ``r_i = a_i . (f + b_i) / |a_i|^2`` of eq. 10, which must
be positive for the pose to see landmark ``i`` at its bearing (rule i).

Then the maximum-likelihood side: the bearing Jacobian rows ``g = [dy / r^2, -dx / r^2, -1]``,
the information ``sum g g^T``, its inverse by Cramer's rule, Gauss-Newton on the wrapped
bearing residuals (a step that does not lower the error is halved), and the variance of a
predicted bearing ``g^T Cov g + sigma^2``.

Each function is written with scalar arithmetic and no branch on values, so it serves twice:
compiled (numba) inside the kernels, and, through its ``py_func``, element-wise on numpy
arrays in :mod:`omniloc.pose` and the readable tree of :mod:`omniloc.search.tree` -- one
implementation of each formula. Kernels use numba's numpy error model: a division by zero
gives inf or nan, caught by the tests that follow, exactly as numpy does (callers of
``py_func`` silence numpy's warnings with ``np.errstate``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = [
    "COVARIANCE_FLOOR",
    "GATE_FLOOR",
    "GN_HALVINGS",
    "GN_ROUNDING",
    "add_pair",
    "covariances",
    "det3",
    "distance_ratio",
    "form3",
    "gauss_newton",
    "gn_refine",
    "heading_from",
    "information",
    "inv3",
    "np_distance_ratio",
    "np_pair_terms",
    "np_pose_exists",
    "np_pose_from_sums",
    "np_sums_invertible",
    "np_wrap_angle",
    "pair_terms",
    "pose_exists",
    "pose_from_sums",
    "position_from_sums",
    "pred_var",
    "ratio_from_parts",
    "sums_invertible",
    "wrap_angle",
    "wrap_float",
]

FloatArray = NDArray[np.float64]

TWO_PI = 2.0 * np.pi

#: Gauss-Newton halves a step that does not lower the squared error up to this many times
#: before it stops (a step of 1/64 of the Gauss-Newton step is still tried).
GN_HALVINGS = 6

#: A Gauss-Newton step smaller than this (metres, radians) that does not lower the squared
#: error is rounding (the quadratic model is exact to far below it unless a landmark is
#: within micrometres): the descent ends there rather than halving the step six times more.
GN_ROUNDING = 1e-9

#: Floor added to the diagonal of the information (in units of 1/sigma^2) before it is
#: inverted for a *gate*: a near-singular geometry (the robot near the circle through three
#: landmarks) then gives a huge variance, which admits rather than rejects.
GATE_FLOOR = 1e-9

#: The same floor for the covariance *reported* with a solution: only so small that an exact
#: fit stays invertible.
COVARIANCE_FLOOR = 1e-12

#: Every kernel here: cached on disk, numpy's error model (inf and nan, no exceptions), no GIL.
_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def wrap_angle(a: Any) -> Any:
    """Wrap to [-pi, pi) (``np.mod`` can round up to exactly pi: that is moved down).
    Element-wise on arrays; :func:`wrap_float` gives the same for one float, faster."""
    t = (a + np.pi) % TWO_PI - np.pi
    return t - TWO_PI * (t >= np.pi)


@_jit
def wrap_float(a: float) -> float:
    """:func:`wrap_angle` of one float, bit for bit, without its ``%`` (a call of libm's
    ``fmod``, the costliest step of the tracker's frame kernel) where that changes nothing:
    for ``0 <= s = a + pi < 2 pi``, ``s % (2 pi)`` is ``s`` exactly, and ``s - pi`` is below
    pi (exact for ``s >= pi / 2``, Sterbenz), so nothing is moved down. One turn further
    either way (the difference of two wrapped angles), ``fmod`` returns ``s`` itself
    (``-2 pi < s < 0``, to which ``%`` then adds 2 pi) or ``s - 2 pi`` (exact, Sterbenz):
    those sums are taken here without it, and moved down as :func:`wrap_angle` moves them."""
    s = a + np.pi
    if s >= 0.0 and s < TWO_PI:
        return s - np.pi
    if s < 0.0 and s > -TWO_PI:
        t = (s + TWO_PI) - np.pi
    elif s >= TWO_PI and s < 2.0 * TWO_PI:
        t = (s - TWO_PI) - np.pi
    else:
        return wrap_angle(a)  # NaN, infinities and angles more than a turn outside
    return t - TWO_PI if t >= np.pi else t


@_jit
def pair_terms(zx: Any, zy: Any, rot: Any) -> tuple[Any, Any, Any, Any, Any, Any, Any]:
    """Eqs. 1-3 for one pair: ``a``, ``b`` (complex) and the entries of ``P`` and ``P b``.

    ``(zx, zy)`` is the landmark's offset from the anchor and ``rot`` is
    ``exp(j (theta_i - theta_0))``. Returns ``a, b, p00, p01, p11, pb0, pb1``.
    """
    z = zx + 1j * zy
    b = 1.0 / z
    a = rot * b
    ar, ai = a.real, a.imag
    aa = ar * ar + ai * ai
    p00 = ar * ar / aa - 1.0
    p01 = ar * ai / aa
    p11 = ai * ai / aa - 1.0
    br, bi = b.real, b.imag
    return a, b, p00, p01, p11, p00 * br + p01 * bi, p01 * br + p11 * bi


@_jit
def position_from_sums(
    s00: Any, s01: Any, s11: Any, t0: Any, t1: Any, l0x: Any, l0y: Any
) -> tuple[Any, Any, Any, Any, Any, Any]:
    """Eq. 4 then eq. 5 from the sums ``S = sum P_i`` (s00, s01, s11) and ``T = sum P_i b_i``
    (t0, t1): returns ``fx, fy, det S, |f|^2`` and the position ``rx, ry``."""
    det = s00 * s11 - s01 * s01
    fx = -(s11 * t0 - s01 * t1) / det
    fy = -(-s01 * t0 + s00 * t1) / det
    f2 = fx * fx + fy * fy
    return fx, fy, det, f2, l0x - fx / f2, l0y + fy / f2


@_jit
def heading_from(l0x: Any, l0y: Any, rx: Any, ry: Any, b0: Any) -> Any:
    """Eq. 6: the heading of a robot at (rx, ry) that sees the anchor at bearing ``b0``."""
    return wrap_angle(np.arctan2(l0y - ry, l0x - rx) - b0)


@_jit
def pose_from_sums(
    s00: Any, s01: Any, s11: Any, t0: Any, t1: Any, l0x: Any, l0y: Any, b0: Any
) -> tuple[Any, Any, Any, Any, Any, Any, Any]:
    """Eqs. 4-6: ``fx, fy, det S, |f|^2, rx, ry, theta``."""
    fx, fy, det, f2, rx, ry = position_from_sums(s00, s01, s11, t0, t1, l0x, l0y)
    return fx, fy, det, f2, rx, ry, heading_from(l0x, l0y, rx, ry, b0)


@_jit
def ratio_from_parts(ar: Any, ai: Any, br: Any, bi: Any, fx: Any, fy: Any) -> Any:
    """The least-squares ratio ``r_i = |L_i - R| / |L_0 - R|`` of eq. 10 for a pair with
    ``a = ar + j ai``, ``b = br + j bi``: ``a . (f + b) / |a|^2``. It must be positive (the
    landmark in front of the robot, not behind)."""
    return (ar * (fx + br) + ai * (fy + bi)) / (ar * ar + ai * ai)


@_jit
def distance_ratio(a: Any, b: Any, fx: Any, fy: Any) -> Any:
    """:func:`ratio_from_parts` for complex ``a`` and ``b``."""
    return ratio_from_parts(a.real, a.imag, b.real, b.imag, fx, fy)


@_jit
def sums_invertible(det: Any, s00: Any, s01: Any, s11: Any, singular_rtol: float) -> Any:
    """Whether ``sum P_i`` is invertible: ``|det|`` above ``singular_rtol`` times its largest
    entry squared (at least 1)."""
    smax = np.maximum(np.maximum(1.0, np.abs(s00)), np.maximum(np.abs(s01), np.abs(s11)))
    return np.abs(det) > singular_rtol * smax * smax


@_jit
def pose_exists(
    det: Any, s00: Any, s01: Any, s11: Any, f2: Any, singular_rtol: float, eps_f2: float
) -> Any:
    """Rule (i) apart from the distance ratios: ``sum P_i`` invertible and ``f`` finite and
    not zero (``|f|^2 > eps_f2``: a robot at infinity is no pose)."""
    return sums_invertible(det, s00, s01, s11, singular_rtol) & np.isfinite(f2) & (f2 > eps_f2)


@_jit
def det3(h00: Any, h01: Any, h02: Any, h11: Any, h12: Any, h22: Any) -> Any:
    """Determinant of a symmetric 3x3 given by its upper triangle."""
    return (
        h00 * (h11 * h22 - h12 * h12)
        + h01 * (h02 * h12 - h01 * h22)
        + h02 * (h01 * h12 - h02 * h11)
    )


@_jit
def inv3(
    h00: Any, h01: Any, h02: Any, h11: Any, h12: Any, h22: Any, scale: Any, floor: float
) -> tuple[Any, Any, Any, Any, Any, Any, Any]:
    """``scale * (H + floor I)^-1`` of a symmetric 3x3 given by its upper triangle, by
    Cramer's rule: returns the upper triangle ``c00, c01, c02, c11, c12, c22`` and the
    trace."""
    h00 = h00 + floor
    h11 = h11 + floor
    h22 = h22 + floor
    c00 = h11 * h22 - h12 * h12
    c01 = h02 * h12 - h01 * h22
    c02 = h01 * h12 - h02 * h11
    c11 = h00 * h22 - h02 * h02
    c12 = h01 * h02 - h00 * h12
    c22 = h00 * h11 - h01 * h01
    f = scale / det3(h00, h01, h02, h11, h12, h22)
    return c00 * f, c01 * f, c02 * f, c11 * f, c12 * f, c22 * f, (c00 + c11 + c22) * f


@_jit
def pred_var(
    gx: float,
    gy: float,
    c00: float,
    c01: float,
    c02: float,
    c11: float,
    c12: float,
    c22: float,
    sig2: float,
) -> float:
    """Variance of a predicted bearing: ``g^T Cov g + sigma^2`` with ``g = [gx, gy, -1]``
    (``Cov`` by its upper triangle)."""
    v = gx * gx * c00 + gy * gy * c11 + c22
    return max(v + 2.0 * (gx * gy * c01 - gx * c02 - gy * c12), 0.0) + sig2


@_jit
def add_pair(
    h00: float, h01: float, h02: float, h11: float, h12: float, h22: float, gx: float, gy: float
) -> tuple[float, float, float, float, float, float]:
    """The upper triangle of ``H + g g^T`` for one bearing's gradient ``g = (gx, gy, -1)``
    (its derivative with respect to x, y and the heading)."""
    return h00 + gx * gx, h01 + gx * gy, h02 - gx, h11 + gy * gy, h12 - gy, h22 + 1.0


@_jit
def form3(
    c00: float,
    c01: float,
    c02: float,
    c11: float,
    c12: float,
    c22: float,
    d0: float,
    d1: float,
    d2: float,
) -> float:
    """``d^T C d`` for a symmetric 3x3 ``C`` given by its upper triangle."""
    q = c00 * d0 * d0 + c11 * d1 * d1 + c22 * d2 * d2
    return q + 2.0 * (c01 * d0 * d1 + c02 * d0 * d2 + c12 * d1 * d2)


@_jit
def information(
    lx: FloatArray, ly: FloatArray, w: FloatArray, n: int, x: float, y: float
) -> tuple[float, float, float, float, float, float]:
    """Upper triangle of ``sum_i g_i g_i^T`` over the pairs ``i < n`` with ``w[i] > 0``
    (landmarks ``(lx[i], ly[i])``) at the position (x, y)."""
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    for i in range(n):
        if w[i] > 0:
            dx = lx[i] - x
            dy = ly[i] - y
            r2 = dx * dx + dy * dy
            gx, gy = dy / r2, -dx / r2
            h00, h01, h02, h11, h12, h22 = add_pair(h00, h01, h02, h11, h12, h22, gx, gy)
    return h00, h01, h02, h11, h12, h22


@_jit
def _normal_equations(
    lx: FloatArray,
    ly: FloatArray,
    bm: FloatArray,
    w: FloatArray,
    n: int,
    x: float,
    y: float,
    t: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float]:
    """The squared error ``sum_i wrap(predicted_i - bm[i])^2`` over the pairs ``i < n`` with
    ``w[i] > 0`` at (x, y, t), and the Gauss-Newton normal equations there: ``sum g g^T``
    (six terms) and ``-sum g r`` (three), in one pass."""
    sse = 0.0
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    g0 = g1 = g2 = 0.0
    for i in range(n):
        if w[i] > 0:
            dx = lx[i] - x
            dy = ly[i] - y
            r2 = dx * dx + dy * dy
            r = wrap_float(np.arctan2(dy, dx) - t - bm[i])
            sse += r * r
            gx, gy = dy / r2, -dx / r2
            h00, h01, h02, h11, h12, h22 = add_pair(h00, h01, h02, h11, h12, h22, gx, gy)
            g0 -= gx * r
            g1 -= gy * r
            g2 += r
    return sse, h00, h01, h02, h11, h12, h22, g0, g1, g2


@_jit
def gn_refine(
    lx: FloatArray,
    ly: FloatArray,
    bm: FloatArray,
    w: FloatArray,
    n: int,
    x: float,
    y: float,
    t: float,
    iters: int,
) -> tuple[float, float, float, float]:
    """Gauss-Newton from (x, y, t) on the pairs ``i < n`` with ``w[i] > 0``: landmark
    (lx[i], ly[i]), bearing bm[i]. A step is kept only if it lowers the squared error, and is
    halved up to GN_HALVINGS times until it does (where the pose is poorly fixed -- a narrow
    field of view -- the full step can overshoot along the valley), so the result is never
    worse than the start; a step below GN_ROUNDING that does not lower it is rounding, and
    ends the descent without halving. The normal equations are solved by Cramer's rule; each
    trial point's pass gives its squared error and its normal equations together.

    Returns the pose (heading wrapped) and its squared error.
    """
    sse, h00, h01, h02, h11, h12, h22, g0, g1, g2 = _normal_equations(lx, ly, bm, w, n, x, y, t)
    for _ in range(iters):
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        det = h00 * c00 + h01 * c01 + h02 * c02
        if not abs(det) > 1e-12 * max(h00 * h11 * h22, 1e-300):
            break
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        s0 = (c00 * g0 + c01 * g1 + c02 * g2) / det
        s1 = (c01 * g0 + c11 * g1 + c12 * g2) / det
        s2 = (c02 * g0 + c12 * g1 + c22 * g2) / det
        if not (np.isfinite(s0) and np.isfinite(s1) and np.isfinite(s2)):
            break
        if max(abs(s0), abs(s1), abs(s2)) < 1e-13:
            break
        better = False
        for _ in range(GN_HALVINGS + 1):
            nx, ny, nt = x + s0, y + s1, t + s2
            nsse, n00, n01, n02, n11, n12, n22, m0, m1, m2 = _normal_equations(
                lx, ly, bm, w, n, nx, ny, nt
            )
            if nsse < sse:
                better = True
                break
            if max(abs(s0), abs(s1), abs(s2)) < GN_ROUNDING:
                break
            s0, s1, s2 = 0.5 * s0, 0.5 * s1, 0.5 * s2
        if not better:
            break
        x, y, t, sse = nx, ny, nt, nsse
        h00, h01, h02, h11, h12, h22 = n00, n01, n02, n11, n12, n22
        g0, g1, g2 = m0, m1, m2
    return x, y, wrap_float(t), sse


@_jit
def gauss_newton(
    Lm: FloatArray, bm: FloatArray, w: FloatArray, start: FloatArray, iters: int
) -> tuple[FloatArray, FloatArray]:
    """:func:`gn_refine` for K problems: landmarks ``Lm`` (K, n, 2), bearings ``bm`` (K, n),
    weights ``w`` (K, n; 0 for padding), starting poses (K, 3). Returns poses and squared
    errors."""
    K, n = bm.shape
    out = start.copy()
    sse_out = np.zeros(K)
    for k in range(K):
        x, y, t, sse = gn_refine(
            Lm[k, :, 0], Lm[k, :, 1], bm[k], w[k], n, out[k, 0], out[k, 1], out[k, 2], iters
        )
        out[k, 0], out[k, 1], out[k, 2] = x, y, t
        sse_out[k] = sse
    return out, sse_out


@_jit
def covariances(
    Lm: FloatArray, w: FloatArray, poses: FloatArray, scale: float, floor: float
) -> FloatArray:
    """``scale * (sum_i w_i g_i g_i^T + floor I)^-1`` at each pose: (K, 3, 3)."""
    K, n = w.shape
    out = np.empty((K, 3, 3))
    for k in range(K):
        h00, h01, h02, h11, h12, h22 = information(
            Lm[k, :, 0], Lm[k, :, 1], w[k], n, poses[k, 0], poses[k, 1]
        )
        c00, c01, c02, c11, c12, c22, _ = inv3(h00, h01, h02, h11, h12, h22, scale, floor)
        out[k, 0, 0], out[k, 0, 1], out[k, 0, 2] = c00, c01, c02
        out[k, 1, 0], out[k, 1, 1], out[k, 1, 2] = c01, c11, c12
        out[k, 2, 0], out[k, 2, 1], out[k, 2, 2] = c02, c12, c22
    return out


# The building blocks element-wise on numpy arrays (for omniloc.pose and the readable tree):
# the same source, run by numpy instead of compiled.
np_wrap_angle = wrap_angle.py_func
np_pair_terms = pair_terms.py_func
np_pose_from_sums = pose_from_sums.py_func
np_sums_invertible = sums_invertible.py_func
np_pose_exists = pose_exists.py_func
np_distance_ratio = distance_ratio.py_func
