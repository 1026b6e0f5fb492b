"""The paper's tree (rules i and ii, fixed threshold, no wildcards) compiled with numba.

This is the hot path of the commonest call, ``localize(map, bearings)`` with a threshold: a
depth-first walk that visits exactly the nodes of the batched numpy search in
:mod:`omniloc.search` and of the plain reading of the paper, with the same arithmetic (eqs. 1-6
with the sums of eq. 4 kept incrementally), without numpy's per-call overhead. The batched
search remains the reference and handles every other option.

Kernels use numba's numpy error model: a division by zero gives inf or nan (caught by the
tests that follow it) instead of raising, exactly as in the numpy search.

numba is optional at run time: without it (or with ``OMNILOC_NO_NUMBA=1``) :data:`AVAILABLE`
is False and the batched search runs instead.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

try:  # pragma: no cover - exercised by whichever branch the machine has
    if os.environ.get("OMNILOC_NO_NUMBA"):
        raise ImportError("disabled by OMNILOC_NO_NUMBA")
    from numba import njit

    AVAILABLE = True
except ImportError:  # pragma: no cover
    AVAILABLE = False

    def njit(*args: Any, **kwargs: Any) -> Any:  # type: ignore[no-redef]
        def wrap(f: Any) -> Any:
            return f

        return wrap


__all__ = ["AVAILABLE", "paper_tree"]

TWO_PI = 2.0 * np.pi


@njit(cache=True, error_model="numpy")
def _wrap(a: float) -> float:
    t = (a + np.pi) % TWO_PI - np.pi
    if t >= np.pi:
        t -= TWO_PI
    return t


@njit(cache=True, error_model="numpy")
def _pair(
    L: NDArray[np.float64], j: int, anchor: int, rot: complex
) -> tuple[complex, complex, float, float, float, float, float]:
    """a, b (eqs. 1-2) and the entries of P (eq. 3) and P b for one pair.

    ``rot`` is exp(j (theta_i - theta_0)).
    """
    z = complex(L[j, 0] - L[anchor, 0], L[j, 1] - L[anchor, 1])
    b = 1.0 / z
    a = rot * b
    ar, ai = a.real, a.imag
    aa = ar * ar + ai * ai
    p00 = ar * ar / aa - 1.0
    p01 = ar * ai / aa
    p11 = ai * ai / aa - 1.0
    br, bi = b.real, b.imag
    return a, b, p00, p01, p11, p00 * br + p01 * bi, p01 * br + p11 * bi


@njit(cache=True, error_model="numpy")
def _pose(
    s00: float, s01: float, s11: float, t0: float, t1: float, l0x: float, l0y: float, b0: float
) -> tuple[float, float, float, float, float, float, float]:
    """Eq. 4 then eqs. 5-6: f, det S, |f|^2 and the pose."""
    det = s00 * s11 - s01 * s01
    fx = -(s11 * t0 - s01 * t1) / det
    fy = -(-s01 * t0 + s00 * t1) / det
    f2 = fx * fx + fy * fy
    rx = l0x - fx / f2
    ry = l0y + fy / f2
    th = _wrap(np.arctan2(l0y - ry, l0x - rx) - b0)
    return fx, fy, det, f2, rx, ry, th


@njit(cache=True, error_model="numpy")
def paper_tree(
    L: NDArray[np.float64],
    beta: NDArray[np.float64],
    threshold: float,
    scale: float,
    singular_rtol: float,
    max_nodes: int,
    capacity: int,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """Walk the interpretation tree for bearings ``beta`` (in level order).

    Returns the complete paths' assignments (K, m) and poses (K, 3), and the counters
    ``[nodes, examined, triples, pruned_existence, pruned_gate, n_leaves, stopped]``.
    When more than ``capacity`` leaves exist, only the first are stored (``n_leaves`` says how
    many there were, so the caller can run again with room for all).
    """
    N = L.shape[0]
    m = beta.shape[0]
    eps_f2 = (1e-12 / scale) ** 2
    assign = np.full(m, -1, dtype=np.int64)
    used = np.zeros(N, dtype=np.bool_)
    nxt = np.zeros(m + 1, dtype=np.int64)
    S = np.zeros((m + 1, 3))
    T = np.zeros((m + 1, 2))
    P = np.zeros((m + 1, 3))
    U = np.zeros((m + 1, 2))  # direction of the next bearing in the world, from P
    out_a = np.empty((capacity, m), dtype=np.int64)
    out_p = np.empty((capacity, 3))
    nodes = examined = triples = existence = gate = n_leaves = 0
    stopped = 0
    anchor = -1
    b0 = beta[0]
    a1 = 0j
    b1 = 0j
    # exp(j (theta_l - theta_0)) of eq. 1 depends on the level only: once per search.
    rot = np.empty(m, dtype=np.complex128)
    for k in range(m):
        rot[k] = np.exp(1j * (beta[k] - b0))
    # Rule (ii) without an arctangent: with u the measured direction from the pose,
    # |wrap(pred - meas)| <= threshold  <=>  dot > 0 and |cross| <= tan(threshold) dot.
    use_tan = threshold < 0.5 * np.pi
    tan_thr = np.tan(threshold) if use_tan else 0.0
    level = 0
    while level >= 0:
        if nxt[level] >= N or stopped:
            level -= 1
            if level >= 0:
                used[assign[level]] = False
                assign[level] = -1
            continue
        j = nxt[level]
        nxt[level] += 1
        if used[j]:
            continue
        nodes += 1
        if level >= 3:
            examined += 1
        ok = False
        if level == 0:
            anchor = j
            S[1, :] = 0.0
            T[1, :] = 0.0
            ok = True
        elif level == 1:
            a, b, p00, p01, p11, pb0, pb1 = _pair(L, j, anchor, rot[1])
            S[2, 0], S[2, 1], S[2, 2] = p00, p01, p11
            T[2, 0], T[2, 1] = pb0, pb1
            a1, b1 = a, b
            ok = True
        elif level == 2:
            # Rule (i): three pairs must give a pose.
            triples += 1
            a, b, p00, p01, p11, pb0, pb1 = _pair(L, j, anchor, rot[2])
            s00, s01, s11 = S[2, 0] + p00, S[2, 1] + p01, S[2, 2] + p11
            t0, t1 = T[2, 0] + pb0, T[2, 1] + pb1
            fx, fy, det, f2, rx, ry, th = _pose(
                s00, s01, s11, t0, t1, L[anchor, 0], L[anchor, 1], b0
            )
            smax = max(1.0, abs(s00), abs(s01), abs(s11))
            r1 = (a1.real * (fx + b1.real) + a1.imag * (fy + b1.imag)) / (
                a1.real * a1.real + a1.imag * a1.imag
            )
            r2 = (a.real * (fx + b.real) + a.imag * (fy + b.imag)) / (
                a.real * a.real + a.imag * a.imag
            )
            ok = (
                abs(det) > singular_rtol * smax * smax
                and r1 > 0
                and r2 > 0
                and np.isfinite(f2)
                and f2 > eps_f2
                and np.isfinite(rx)
                and np.isfinite(ry)
                and np.isfinite(th)
            )
            if ok:
                S[3, 0], S[3, 1], S[3, 2] = s00, s01, s11
                T[3, 0], T[3, 1] = t0, t1
                P[3, 0], P[3, 1], P[3, 2] = rx, ry, th
                if m > 3:
                    U[3, 0], U[3, 1] = np.cos(th + beta[3]), np.sin(th + beta[3])
            else:
                existence += 1
        else:
            # Rule (ii): the bearing predicted from the path's pose must match.
            px, py, pt = P[level, 0], P[level, 1], P[level, 2]
            if use_tan:
                ux, uy = U[level, 0], U[level, 1]
                dxj, dyj = L[j, 0] - px, L[j, 1] - py
                dot = dxj * ux + dyj * uy
                passes = dot > 0 and abs(dxj * uy - dyj * ux) <= tan_thr * dot
            else:
                pred = np.arctan2(L[j, 1] - py, L[j, 0] - px) - pt
                passes = abs((pred - beta[level] + np.pi) % TWO_PI - np.pi) <= threshold
            if passes:
                ok = True
                a, b, p00, p01, p11, pb0, pb1 = _pair(L, j, anchor, rot[level])
                s00 = S[level, 0] + p00
                s01 = S[level, 1] + p01
                s11 = S[level, 2] + p11
                t0, t1 = T[level, 0] + pb0, T[level, 1] + pb1
                S[level + 1, 0], S[level + 1, 1], S[level + 1, 2] = s00, s01, s11
                T[level + 1, 0], T[level + 1, 1] = t0, t1
                fx, fy, det, f2, rx, ry, th = _pose(
                    s00, s01, s11, t0, t1, L[anchor, 0], L[anchor, 1], b0
                )
                # The re-estimate replaces the pose only where eqs. 1-6 accept it.
                smax = max(1.0, abs(s00), abs(s01), abs(s11))
                valid = abs(det) > singular_rtol * smax * smax and np.isfinite(f2)
                valid = valid and f2 > eps_f2
                if valid:
                    for k in range(1, level + 1):
                        lk = assign[k] if k < level else j
                        z = complex(L[lk, 0] - L[anchor, 0], L[lk, 1] - L[anchor, 1])
                        bk = 1.0 / z
                        ak = rot[k] * bk
                        rk = (ak.real * (fx + bk.real) + ak.imag * (fy + bk.imag)) / (
                            ak.real * ak.real + ak.imag * ak.imag
                        )
                        if not rk > 0:
                            valid = False
                            break
                if valid:
                    P[level + 1, 0], P[level + 1, 1], P[level + 1, 2] = rx, ry, th
                else:
                    P[level + 1, 0], P[level + 1, 1], P[level + 1, 2] = px, py, pt
                if level + 1 < m:
                    tn = P[level + 1, 2] + beta[level + 1]
                    U[level + 1, 0], U[level + 1, 1] = np.cos(tn), np.sin(tn)
            else:
                gate += 1
        if max_nodes > 0 and nodes >= max_nodes:
            stopped = 1
        if ok:
            assign[level] = j
            if level + 1 == m:
                if n_leaves < capacity:
                    out_a[n_leaves, :] = assign
                    out_p[n_leaves, 0] = P[m, 0]
                    out_p[n_leaves, 1] = P[m, 1]
                    out_p[n_leaves, 2] = P[m, 2]
                n_leaves += 1
                assign[level] = -1
            else:
                used[j] = True
                level += 1
                nxt[level] = 0
    counts = np.array(
        [nodes, examined, triples, existence, gate, n_leaves, stopped], dtype=np.int64
    )
    k = min(n_leaves, capacity)
    return out_a[:k].copy(), out_p[:k].copy(), counts


@njit(cache=True, error_model="numpy")
def gauss_newton(
    Lm: NDArray[np.float64],
    bm: NDArray[np.float64],
    w: NDArray[np.float64],
    start: NDArray[np.float64],
    iters: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss-Newton on wrapped bearing residuals, path by path (see search._gauss_newton)."""
    K, n = bm.shape
    out = start.copy()
    sse_out = np.zeros(K)
    for k in range(K):
        x, y, t = out[k, 0], out[k, 1], out[k, 2]
        sse = 0.0
        for i in range(n):
            if w[k, i] > 0:
                r = _wrap(np.arctan2(Lm[k, i, 1] - y, Lm[k, i, 0] - x) - t - bm[k, i])
                sse += r * r
        for _ in range(iters):
            h00 = h01 = h02 = h11 = h12 = h22 = 0.0
            g0 = g1 = g2 = 0.0
            for i in range(n):
                if w[k, i] > 0:
                    dx = Lm[k, i, 0] - x
                    dy = Lm[k, i, 1] - y
                    r2 = dx * dx + dy * dy
                    r = _wrap(np.arctan2(dy, dx) - t - bm[k, i])
                    gx, gy, gt = dy / r2, -dx / r2, -1.0
                    h00 += gx * gx
                    h01 += gx * gy
                    h02 += gx * gt
                    h11 += gy * gy
                    h12 += gy * gt
                    h22 += gt * gt
                    g0 -= gx * r
                    g1 -= gy * r
                    g2 -= gt * r
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
            nx, ny, nt = x + s0, y + s1, t + s2
            nsse = 0.0
            for i in range(n):
                if w[k, i] > 0:
                    r = _wrap(np.arctan2(Lm[k, i, 1] - ny, Lm[k, i, 0] - nx) - nt - bm[k, i])
                    nsse += r * r
            if not nsse < sse:
                break
            x, y, t, sse = nx, ny, nt, nsse
            if max(abs(s0), abs(s1), abs(s2)) < 1e-13:
                break
        out[k, 0], out[k, 1], out[k, 2] = x, y, _wrap(t)
        sse_out[k] = sse
    return out, sse_out
