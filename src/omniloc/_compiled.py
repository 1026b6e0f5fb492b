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


__all__ = ["AVAILABLE", "gauss_newton", "hypotheses", "paper_tree"]

TWO_PI = 2.0 * np.pi

#: A verification node's work (see :func:`hypotheses`) beyond the landmarks it scans (its
#: Kalman update or relinearisation), and a complete path's (its Gauss-Newton refinement,
#: the output buffer). With HYPOTHESIS_WORK_PER_SECOND in search.py, fitted to the kernel's
#: time on benchmark scenes b, b360 and c, 150 MRCLAM frames and maps of 40 and 60
#: landmarks without a range: predicted / actual time 0.9-1.25.
NODE_WORK = 256
LEAF_WORK = 4096

#: Gauss-Newton halves a step that does not lower the squared error up to this many times
#: before it stops (a step of 1/64 of the Gauss-Newton step is still tried).
GN_HALVINGS = 6


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
    return _pair_z(L[j, 0] - L[anchor, 0], L[j, 1] - L[anchor, 1], rot)


@njit(cache=True, error_model="numpy")
def _pair_z(
    zx: float, zy: float, rot: complex
) -> tuple[complex, complex, float, float, float, float, float]:
    """:func:`_pair` from the landmark's offset (zx, zy) from the anchor."""
    z = complex(zx, zy)
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
        x, y, t, sse = _gn_core(
            Lm[k, :, 0], Lm[k, :, 1], bm[k], w[k], n, out[k, 0], out[k, 1], out[k, 2], iters
        )
        out[k, 0], out[k, 1], out[k, 2] = x, y, t
        sse_out[k] = sse
    return out, sse_out


@njit(cache=True, error_model="numpy", nogil=True)
def _gn_core(
    lx: NDArray[np.float64],
    ly: NDArray[np.float64],
    bm: NDArray[np.float64],
    w: NDArray[np.float64],
    n: int,
    x: float,
    y: float,
    t: float,
    iters: int,
) -> tuple[float, float, float, float]:
    """Gauss-Newton from (x, y, t) on the pairs ``i < n`` with ``w[i] > 0``: landmark
    (lx[i], ly[i]), bearing bm[i]. A step is kept only if it lowers the squared error (halved
    up to GN_HALVINGS times until it does).
    Returns the pose (heading wrapped) and its squared error."""
    sse = 0.0
    for i in range(n):
        if w[i] > 0:
            r = _wrap(np.arctan2(ly[i] - y, lx[i] - x) - t - bm[i])
            sse += r * r
    for _ in range(iters):
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        g0 = g1 = g2 = 0.0
        for i in range(n):
            if w[i] > 0:
                dx = lx[i] - x
                dy = ly[i] - y
                r2 = dx * dx + dy * dy
                r = _wrap(np.arctan2(dy, dx) - t - bm[i])
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
        if max(abs(s0), abs(s1), abs(s2)) < 1e-13:
            break
        # Backtracking: where the pose is poorly fixed (a narrow field of view) the full step
        # can overshoot along the valley; halving it keeps a descent direction going.
        nsse = sse
        for _ in range(GN_HALVINGS + 1):
            nx, ny, nt = x + s0, y + s1, t + s2
            nsse = 0.0
            for i in range(n):
                if w[i] > 0:
                    r = _wrap(np.arctan2(ly[i] - ny, lx[i] - nx) - nt - bm[i])
                    nsse += r * r
            if nsse < sse:
                break
            s0, s1, s2 = 0.5 * s0, 0.5 * s1, 0.5 * s2
        if not nsse < sse:
            break
        x, y, t, sse = nx, ny, nt, nsse
    return x, y, _wrap(t), sse


@njit(cache=True, error_model="numpy")
def _info(
    lx: NDArray[np.float64], ly: NDArray[np.float64], n: int, x: float, y: float
) -> tuple[float, float, float, float, float, float]:
    """Upper triangle of sum g g^T over the first n matched landmarks (lx, ly) at (x, y)."""
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    for i in range(n):
        dx = lx[i] - x
        dy = ly[i] - y
        r2 = dx * dx + dy * dy
        gx, gy = dy / r2, -dx / r2
        h00 += gx * gx
        h01 += gx * gy
        h02 -= gx
        h11 += gy * gy
        h12 -= gy
        h22 += 1.0
    return h00, h01, h02, h11, h12, h22


@njit(cache=True, error_model="numpy")
def _inv3(
    h00: float, h01: float, h02: float, h11: float, h12: float, h22: float, scale: float
) -> tuple[float, float, float, float, float, float, float]:
    """scale * H^-1 of a symmetric 3x3 (upper triangle), and its trace; H gets a 1e-9 floor
    as in the numpy search, so a near-singular geometry admits rather than rejects."""
    h00 += 1e-9
    h11 += 1e-9
    h22 += 1e-9
    c00 = h11 * h22 - h12 * h12
    c01 = h02 * h12 - h01 * h22
    c02 = h01 * h12 - h02 * h11
    c11 = h00 * h22 - h02 * h02
    c12 = h01 * h02 - h00 * h12
    c22 = h00 * h11 - h01 * h01
    det = h00 * c00 + h01 * c01 + h02 * c02
    f = scale / det
    return c00 * f, c01 * f, c02 * f, c11 * f, c12 * f, c22 * f, (c00 + c11 + c22) * f


@njit(cache=True, error_model="numpy", nogil=True)
def _pair_terms(
    lo: int,
    hi: int,
    nb_idx: NDArray[np.int64],
    nb_xy: NDArray[np.float64],
    i: int,
    lix: float,
    liy: float,
    d2max: float,
    rot: complex,
    q: NDArray[np.int64],
    t: NDArray[np.float64],
) -> int:
    """The neighbours of anchor ``i`` within sqrt(d2max) of it, to ``q``, with their
    coordinates, ``a`` and ``b`` (eqs. 1-2, real and imaginary parts) and the entries of P and
    P b (eq. 3) for the rotation ``rot`` in the columns of ``t`` (11, >= n: one row per
    quantity, so that :func:`_triple_poses` reads each contiguously); returns how many."""
    n = 0
    for qq in range(lo, hi):
        j = nb_idx[qq]
        if j == i:
            continue
        qx, qy = nb_xy[qq, 0], nb_xy[qq, 1]
        ex, ey = qx - lix, qy - liy
        if ex * ex + ey * ey > d2max:
            continue
        a, b, p00, p01, p11, pb0, pb1 = _pair_z(ex, ey, rot)
        q[n] = j
        t[0, n], t[1, n], t[2, n], t[3, n], t[4, n], t[5, n] = (
            qx,
            qy,
            a.real,
            a.imag,
            b.real,
            b.imag,
        )
        t[6, n], t[7, n], t[8, n], t[9, n], t[10, n] = p00, p01, p11, pb0, pb1
        n += 1
    return n


@njit(cache=True, error_model="numpy", nogil=True)
def _gather(
    lo: int,
    hi: int,
    nb_idx: NDArray[np.int64],
    nb_xy: NDArray[np.float64],
    i: int,
    lix: float,
    liy: float,
    px: float,
    py: float,
    near2: float,
    near_q: NDArray[np.int64],
    near_x: NDArray[np.float64],
    near_y: NDArray[np.float64],
) -> int:
    """Copy the neighbours of anchor ``i`` within sqrt(near2) of (px, py), and the anchor
    itself, to ``near_*``; return how many. Branch-free: every candidate is written, and the
    count advances past the near ones."""
    nn = 0
    for qq in range(lo, hi):
        qx, qy = nb_xy[qq, 0], nb_xy[qq, 1]
        near_q[nn], near_x[nn], near_y[nn] = nb_idx[qq], qx, qy
        ex, ey = qx - px, qy - py
        nn += ex * ex + ey * ey <= near2
    near_q[nn], near_x[nn], near_y[nn] = i, lix, liy
    return nn + 1


@njit(cache=True, error_model="numpy", nogil=True)
def _compact(
    out_a: NDArray[np.int64],
    out_p: NDArray[np.float64],
    out_miss: NDArray[np.int64],
    out_key: NDArray[np.float64],
    bar: NDArray[np.float64],
) -> int:
    """Make room in full output buffers, in place: repeats of one interpretation (reached
    from several seeds) keep only their best row, then at most the better half of the rest
    stays (lowest key first, stable). When rows had to go, ``bar[0]`` becomes the worst key
    kept. Returns the rows kept."""
    full, m = out_a.shape
    # Rows that hold the same assignment: a hash (FNV-1a) groups them, a comparison decides.
    h = np.empty(full, dtype=np.uint64)
    for r in range(full):
        v = np.uint64(14695981039346656037)
        for o in range(m):
            v = (v ^ np.uint64(out_a[r, o] + 2)) * np.uint64(1099511628211)
        h[r] = v
    by_h = np.argsort(h, kind="mergesort")
    alive = np.ones(full, dtype=np.bool_)
    # Within a run of equal hashes, the best row of each distinct assignment so far (more
    # than one only on a hash collision): each row is compared with these rather than walking
    # back over every repeat before it (quadratic in the repeats of one interpretation).
    reps = np.empty(full, dtype=np.int64)
    n_reps = 0
    for u in range(full):
        r = by_h[u]
        if u == 0 or h[by_h[u - 1]] != h[r]:
            reps[0] = r
            n_reps = 1
            continue
        new_rep = True
        for t in range(n_reps):
            q = reps[t]
            same = True
            for o in range(m):
                if out_a[q, o] != out_a[r, o]:
                    same = False
                    break
            if same:
                if out_key[r] < out_key[q]:
                    alive[q] = False
                    reps[t] = r
                else:
                    alive[r] = False
                new_rep = False
                break
        if new_rep:
            reps[n_reps] = r
            n_reps += 1
    rows = np.flatnonzero(alive)
    order = rows[np.argsort(out_key[rows], kind="mergesort")]
    keep = min(order.shape[0], full // 2)
    if keep < order.shape[0]:
        bar[0] = out_key[order[keep - 1]]
    order = order[:keep]
    out_a[:keep] = out_a[order].copy()
    out_p[:keep] = out_p[order].copy()
    out_miss[:keep] = out_miss[order].copy()
    out_key[:keep] = out_key[order].copy()
    return keep


@njit(cache=True, error_model="numpy", nogil=True)
def _pred_var(
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
    """Variance of a predicted bearing: g^T Cov g + sigma^2 with g = [gx, gy, -1]."""
    v = gx * gx * c00 + gy * gy * c11 + c22
    return max(v + 2.0 * (gx * gy * c01 - gx * c02 - gy * c12), 0.0) + sig2


@njit(cache=True, error_model="numpy", nogil=True)
def _can_reach(
    rest: NDArray[np.int64],
    nr: int,
    need: int,
    cb: NDArray[np.float64],
    sb: NDArray[np.float64],
    px: float,
    py: float,
    ct: float,
    st: float,
    near_q: NDArray[np.int64],
    near_x: NDArray[np.float64],
    near_y: NDArray[np.float64],
    nn: int,
    own: tuple[int, int, int],
    cov: tuple[float, float, float, float, float, float],
    sig2: float,
    k_pre: float,
    work: NDArray[np.float64],
) -> bool:
    """Whether at least ``need`` of the bearings ``rest[:nr]`` each have some near landmark
    (other than the hypothesis's ``own`` three) inside a gate of ``k_pre``
    at the hypothesis's pose (px, py, heading with cosine ``ct`` and sine ``st``) and
    covariance ``cov`` (upper triangle): a necessary condition for :func:`_verify` to find a
    complete path, tested first because it is cheap (no arctangent; the inner loop has no
    branch, and the bearings stop as soon as too many have missed).

    Why it is necessary: to first order, the normalised squared innovation of a bearing at
    the seed's pose is at most the joint chi-square statistic of every match the path goes on
    to make (a marginal of a quadratic form is at most the whole), which the joint test
    bounds by ``joint_chi2[n] <= joint_chi2[m]``; ``k_pre`` is that with a margin for the
    nonlinearity. ``work`` (4, >= max(nn, nr)) is scratch; when the test passes, ``work[3,
    r]`` is 1 for each bearing ``rest[r]`` that has no landmark in its gate (which no path
    that passes the joint test can match, by the same argument), else 0.
    """
    c00, c01, c02, c11, c12, c22 = cov
    tx, ty, tg = work[0], work[1], work[2]
    for t in range(nn):
        dx, dy = near_x[t] - px, near_y[t] - py
        rr = dx * dx + dy * dy
        # (g^T Cov g) r^2 with g = [dy / r^2, -dx / r^2, -1], as in _pred_var.
        vr = (dy * dy * c00 + dx * dx * c11 - 2.0 * dx * dy * c01) / rr
        vr += 2.0 * (dx * c12 - dy * c02) + c22 * rr
        tx[t], ty[t] = dx, dy
        # |r sin(innovation)|^2 <= k_pre v r^2 (sin x <= x); never for the hypothesis's own
        # landmarks (compared by index: cheaper than a lookup in a map-sized array).
        q = near_q[t]
        mine = (q == own[0]) | (q == own[1]) | (q == own[2])
        tg[t] = -1.0 if mine else k_pre * (max(vr, 0.0) + sig2 * rr)
    allow = nr - need
    missed = 0
    for r in range(nr):
        o = rest[r]
        ux = ct * cb[o] - st * sb[o]  # the bearing's direction in the world
        uy = st * cb[o] + ct * sb[o]
        hit = False
        for t in range(nn):
            cr = ux * ty[t] - uy * tx[t]
            hit |= (cr * cr <= tg[t]) & (ux * tx[t] + uy * ty[t] > 0)
        work[3, r] = not hit
        missed += not hit
        if missed > allow:
            return False
    return True


@njit(cache=True, error_model="numpy", nogil=True)
def _triple_poses(
    j: int,
    jr: NDArray[np.float64],
    lix: float,
    liy: float,
    kq: NDArray[np.int64],
    kt: NDArray[np.float64],
    nk: int,
    d_bc: float,
    singular_rtol: float,
    eps_f2: float,
    rmax2: float,
    rmin2: float,
    hk: NDArray[np.int64],
    hx: NDArray[np.float64],
    hy: NDArray[np.float64],
    hd: NDArray[np.float64],
    status: NDArray[np.int64],
) -> int:
    """The poses of the anchor, the second landmark ``j`` (its pair terms ``jr``) and each
    third-landmark candidate ``kt[:, :nk]`` (eqs. 4-5), in one pass without branches that
    the compiler vectorises: each candidate's position goes to ``hx[kk]``, ``hy[kk]`` and its
    squared distance to the anchor to ``hd[kk]``, and ``status[kk]`` says what became of it:
    0 the same landmark as ``j``, 1 beyond the pair limit, 2 no pose (existence), 3 out of
    range, 4 a hypothesis (its pose exists and sees all three within the range limits).
    ``hk`` lists the hypotheses' candidate indices, in order; returns how many."""
    ljx, ljy, a1r, a1i, b1r, b1i = jr[0], jr[1], jr[2], jr[3], jr[4], jr[5]
    p00, p01, p11, pb0, pb1 = jr[6], jr[7], jr[8], jr[9], jr[10]
    a1n = a1r * a1r + a1i * a1i
    k0, k1, k2, k3, k4, k5 = kt[0], kt[1], kt[2], kt[3], kt[4], kt[5]
    k6, k7, k8, k9, k10 = kt[6], kt[7], kt[8], kt[9], kt[10]
    for kk in range(nk):
        lkx, lky = k0[kk], k1[kk]
        ex, ey = lkx - ljx, lky - ljy
        other = kq[kk] != j
        paired = other & (ex * ex + ey * ey <= d_bc)
        s00, s01, s11 = p00 + k6[kk], p01 + k7[kk], p11 + k8[kk]
        t0, t1 = pb0 + k9[kk], pb1 + k10[kk]
        a2r, a2i, b2r, b2i = k2[kk], k3[kk], k4[kk], k5[kk]
        # Eq. 4 then eq. 5; the heading (eq. 6) waits until the position passes.
        det = s00 * s11 - s01 * s01
        fx = -(s11 * t0 - s01 * t1) / det
        fy = -(-s01 * t0 + s00 * t1) / det
        f2 = fx * fx + fy * fy
        smax = max(1.0, abs(s00), abs(s01), abs(s11))
        r1 = (a1r * (fx + b1r) + a1i * (fy + b1i)) / a1n
        r2 = (a2r * (fx + b2r) + a2i * (fy + b2i)) / (a2r * a2r + a2i * a2i)
        px = lix - fx / f2
        py = liy + fy / f2
        exists = (
            (abs(det) > singular_rtol * smax * smax)
            & (r1 > 0)
            & (r2 > 0)
            & np.isfinite(f2)
            & (f2 > eps_f2)
            & np.isfinite(px)
            & np.isfinite(py)
        )
        # The pose must see its three landmarks within the range limits.
        ex, ey = lix - px, liy - py
        d2a = ex * ex + ey * ey
        ex, ey = ljx - px, ljy - py
        d2b = ex * ex + ey * ey
        ex, ey = lkx - px, lky - py
        d2c = ex * ex + ey * ey
        seen = (max(d2a, d2b, d2c) <= rmax2) & (min(d2a, d2b, d2c) >= rmin2)
        status[kk] = other + paired + (paired & exists) + (paired & exists & seen)
        hx[kk], hy[kk], hd[kk] = px, py, d2a
    # The hypotheses, in order (a separate pass, so that the one above vectorises).
    n = 0
    for kk in range(nk):
        hk[n] = kk
        n += status[kk] == 4
    return n


@njit(cache=True, error_model="numpy", nogil=True)
def _tally(status: NDArray[np.int64], lo: int, hi: int) -> tuple[int, int, int]:
    """The counters of the third-landmark candidates ``lo:hi`` by their ``status`` (see
    :func:`_triple_poses`): (out of range or beyond the pair limit, no pose, solved)."""
    vis = existence = solved = 0
    for kk in range(lo, hi):
        st_k = status[kk]
        vis += (st_k == 1) | (st_k == 3)
        existence += st_k == 2
        solved += st_k >= 2
    return vis, existence, solved


@njit(cache=True, error_model="numpy", nogil=True)
def _walk_work(nodes: int, leaves: int, nn: int, miss_w: float) -> int:
    """The work (see :func:`hypotheses`) of a verification that visited ``nodes`` nodes and
    reached ``leaves`` complete paths among ``nn`` near landmarks: each node scans them, each
    complete path is refined (and, with negative evidence, scans them again)."""
    return nodes * (nn + NODE_WORK) + leaves * (LEAF_WORK + (nn if miss_w > 0.0 else 0))


@njit(cache=True, error_model="numpy", nogil=True)
def _verify(
    L: NDArray[np.float64],
    beta: NDArray[np.float64],
    cb: NDArray[np.float64],
    sb: NDArray[np.float64],
    rest: NDArray[np.int64],
    nr: int,
    lm: NDArray[np.int64],
    mx: NDArray[np.float64],
    my: NDArray[np.float64],
    ones: NDArray[np.float64],
    bm: NDArray[np.float64],
    om: NDArray[np.int64],
    stamp: NDArray[np.int64],
    hyp: int,
    near_q: NDArray[np.int64],
    near_x: NDArray[np.float64],
    near_y: NDArray[np.float64],
    nn: int,
    sp: NDArray[np.float64],
    scov: NDArray[np.float64],
    sn: NDArray[np.int64],
    sw: NDArray[np.int64],
    chosen: NDArray[np.int64],
    pos: NDArray[np.int64],
    ncand: NDArray[np.int64],
    cq: NDArray[np.int64],
    cin: NDArray[np.float64],
    cgx: NDArray[np.float64],
    cgy: NDArray[np.float64],
    cv: NDArray[np.float64],
    cs: NDArray[np.float64],
    sig2: float,
    use_sigma: bool,
    gate_chi2: float,
    threshold: float,
    bound_k: float,
    rmax2: float,
    rmin2: float,
    max_wild: int,
    min_match: int,
    joint_chi2: NDArray[np.float64],
    vis_hi: float,
    vis_lo: float,
    half_fov: float,
    margin: float,
    out_a: NDArray[np.int64],
    out_p: NDArray[np.float64],
    out_miss: NDArray[np.int64],
    out_key: NDArray[np.float64],
    bar: NDArray[np.float64],
    spur_w: float,
    miss_w: float,
    n_out: int,
    stop_first: bool,
    miss_allow: int,
    node_budget: int,
    work_budget: int,
    relin: int,
    contested: NDArray[np.bool_],
    cnt: NDArray[np.int64],
    ahead: NDArray[np.int64],
    pick: NDArray[np.int64],
) -> tuple[int, int]:
    """Verify one hypothesis: a depth-first walk over the other bearings (``rest``), each
    matched in turn to every landmark inside its gate, best first, then left unmatched (a
    wildcard) while at most ``max_wild`` are, as in the tree. The state of a path (pose,
    covariance, matches) takes each match in with one Kalman update and is restored on the
    way back. Complete paths with at least ``min_match`` matches are refined, tested for
    joint compatibility (with sigma) and written out with their count of missed landmarks.

    ``ahead[level]`` wildcards are reserved for the bearings from ``level`` on that failed
    the cheap test (:func:`_can_reach`): a wildcard is taken only while the path's wildcards
    and those still fit within ``max_wild``, so a first fit drops a hypothesis at its first
    unexplained bearing once the cheap test's misses use up the allowance (all zero: the
    tree's rule).

    The hypothesis's three seed pairs are ``lm/mx/my/bm/om[:3]``, its pose and covariance
    ``sp[0]``/``scov[0]``; ``pick`` (2, >= nn) is scratch. Adds [nodes, examined, gate,
    bound, complete paths] to ``cnt``; returns the new output count and 2 when
    ``stop_first`` found its fit (1 when ``node_budget`` nodes or ``work_budget`` work, see
    :func:`_walk_work`, ran out; 0 for no limit).
    """
    m = beta.shape[0]
    capacity = out_a.shape[0]
    n = 3
    wild = 0
    px, py, pt, tr = sp[0, 0], sp[0, 1], sp[0, 2], sp[0, 3]
    c00, c01, c02, c11, c12, c22 = (
        scov[0, 0],
        scov[0, 1],
        scov[0, 2],
        scov[0, 3],
        scov[0, 4],
        scov[0, 5],
    )
    level = 0
    enter = True
    while level >= 0:
        if enter:
            enter = False
            sp[level, 0], sp[level, 1], sp[level, 2], sp[level, 3] = px, py, pt, tr
            scov[level, 0], scov[level, 1], scov[level, 2] = c00, c01, c02
            scov[level, 3], scov[level, 4], scov[level, 5] = c11, c12, c22
            sn[level], sw[level], chosen[level], pos[level] = n, wild, -1, 0
            if level == nr:
                if n >= min_match:
                    qx, qy, qt, sse = _gn_core(mx, my, bm, ones, n, px, py, pt, 10)
                    if not use_sigma or sse / sig2 <= joint_chi2[n]:
                        # Negative evidence only where it is asked for (p_miss: miss_w > 0);
                        # without a range it would look at the whole map for every path.
                        missed = 0
                        if miss_w > 0.0:
                            missed = _missed_count(
                                near_q, near_x, near_y, nn, stamp, hyp, qx, qy, qt, beta,
                                vis_hi, vis_lo, half_fov, margin,
                            )  # fmt: skip
                        # Keep the best ``capacity`` by the ranking's cost: when full, the
                        # worse half goes and the bar for entry rises.
                        key = (m - n) * spur_w + 0.5 * sse / sig2 + missed * miss_w
                        cnt[4] += 1
                        if n_out == capacity:
                            n_out = _compact(out_a, out_p, out_miss, out_key, bar)
                        if key <= bar[0] or (stop_first and missed <= miss_allow):
                            for o in range(m):
                                out_a[n_out, o] = -1
                            for q in range(n):
                                out_a[n_out, om[q]] = lm[q]
                            out_p[n_out, 0], out_p[n_out, 1], out_p[n_out, 2] = qx, qy, qt
                            out_miss[n_out] = missed
                            out_key[n_out] = key
                            n_out += 1
                        if stop_first and missed <= miss_allow:
                            return n_out, 2
                level -= 1
                continue
            o = rest[level]
            cnt[0] += 1
            cnt[1] += 1
            if node_budget > 0 and cnt[0] >= node_budget:
                return n_out, 1
            if work_budget > 0 and _walk_work(cnt[0], cnt[4], nn, miss_w) >= work_budget:
                return n_out, 1
            ct, st = np.cos(pt), np.sin(pt)
            ux = ct * cb[o] - st * sb[o]  # measured direction in the world
            uy = st * cb[o] + ct * sb[o]
            # The landmarks inside the gate, best (smallest normalised innovation) first.
            nc = 0
            # One bound first, for every near landmark in a pass that vectorises: |sin(innov)|
            # <= |innov| and g^T Cov g <= trace(Cov) |g|^2 with |g|^2 = 1 / r^2 + 1, so most
            # candidates fail it, and it needs no division or arctangent. The few that pass
            # are listed, then gated exactly.
            okf, sel = pick[0], pick[1]
            for t in range(nn):
                dx, dy = near_x[t] - px, near_y[t] - py
                rr = dx * dx + dy * dy
                dot = dx * ux + dy * uy
                cr = ux * dy - uy * dx  # r sin(innovation)
                okf[t] = (
                    (cr * cr <= bound_k * (tr * (1.0 + rr) + sig2 * rr))
                    & (dot > 0)
                    & (rr <= rmax2)
                    & (rr >= rmin2)
                )
            nsel = 0
            for t in range(nn):
                sel[nsel] = t
                nsel += okf[t]
            for u in range(nsel):
                t = sel[u]
                dx, dy = near_x[t] - px, near_y[t] - py
                rr = dx * dx + dy * dy
                dot = dx * ux + dy * uy
                cr = ux * dy - uy * dx
                q = near_q[t]
                if stamp[q] == hyp:
                    continue
                gx, gy = dy / rr, -dx / rr
                v = _pred_var(gx, gy, c00, c01, c02, c11, c12, c22, sig2)
                if use_sigma:
                    if cr * cr > gate_chi2 * v * rr:
                        continue
                    innov = np.arctan2(cr, dot)
                    score = innov * innov / v
                    if score > gate_chi2:
                        continue
                else:
                    if cr * cr > threshold * threshold * rr:
                        continue
                    innov = np.arctan2(cr, dot)
                    score = innov * innov / v
                    if abs(innov) > threshold:
                        continue
                at = nc
                while at > 0 and cs[level, at - 1] > score:
                    cq[level, at], cin[level, at] = cq[level, at - 1], cin[level, at - 1]
                    cgx[level, at], cgy[level, at] = cgx[level, at - 1], cgy[level, at - 1]
                    cv[level, at], cs[level, at] = cv[level, at - 1], cs[level, at - 1]
                    at -= 1
                cq[level, at], cin[level, at], cgx[level, at] = q, innov, gx
                cgy[level, at], cv[level, at], cs[level, at] = gy, v, score
                nc += 1
            ncand[level] = nc
            if ncand[level] == 0:
                cnt[2] += 1
        # Next option at this level, from the state on entering it.
        px, py, pt, tr = sp[level, 0], sp[level, 1], sp[level, 2], sp[level, 3]
        c00, c01, c02 = scov[level, 0], scov[level, 1], scov[level, 2]
        c11, c12, c22 = scov[level, 3], scov[level, 4], scov[level, 5]
        n, wild = sn[level], sw[level]
        if chosen[level] >= 0:
            stamp[chosen[level]] = 0
            chosen[level] = -1
        p = pos[level]
        pos[level] = p + 1
        o = rest[level]
        if p < ncand[level]:
            q = cq[level, p]
            lm[n], bm[n], om[n] = q, beta[o], o
            mx[n], my[n] = L[q, 0], L[q, 1]
            stamp[q] = hyp
            chosen[level] = q
            n += 1
            # Kalman update with the matched bearing: h = g^T, innovation (predicted -
            # measured) b_in, its variance b_v.
            b_in, b_gx, b_gy, b_v = cin[level, p], cgx[level, p], cgy[level, p], cv[level, p]
            k0 = (c00 * b_gx + c01 * b_gy - c02) / b_v
            k1 = (c01 * b_gx + c11 * b_gy - c12) / b_v
            k2 = (c02 * b_gx + c12 * b_gy - c22) / b_v
            px -= k0 * b_in
            py -= k1 * b_in
            pt -= k2 * b_in
            c00 -= k0 * k0 * b_v
            c01 -= k0 * k1 * b_v
            c02 -= k0 * k2 * b_v
            c11 -= k1 * k1 * b_v
            c12 -= k1 * k2 * b_v
            c22 -= k2 * k2 * b_v
            tr = c00 + c11 + c22
            if n <= relin:
                # Relinearise while the path has few pairs (its pose is still far from linear):
                # two Gauss-Newton steps over all its pairs, and the covariance at the new
                # pose, as the tree re-estimates at every node.
                px, py, pt, _ = _gn_core(mx, my, bm, ones, n, px, py, pt, 2)
                h00, h01, h02, h11, h12, h22 = _info(mx, my, n, px, py)
                c00, c01, c02, c11, c12, c22, tr = _inv3(h00, h01, h02, h11, h12, h22, sig2)
            level += 1
            enter = True
        elif p == ncand[level] and (p == 0 or (contested[o] and not stop_first)):
            # After every landmark that fits, the wildcard ("not on the map": a spurious bearing
            # may fall on a landmark's ray and take it from the true one), while the path can
            # still reach min_match. Where a landmark fits, only for a bearing with another
            # one close by (``contested``): otherwise the wildcard could only give the same
            # interpretation with one match fewer, which the merge would drop. A first fit,
            # which gives up completeness anyway, takes it only where nothing fits.
            if wild + 1 + ahead[level + 1] <= max_wild:
                wild += 1
                level += 1
                enter = True
            else:
                cnt[3] += 1
                level -= 1
        else:
            level -= 1
    return n_out, 0


@njit(cache=True, error_model="numpy", nogil=True)
def _missed_count(
    near_q: NDArray[np.int64],
    near_x: NDArray[np.float64],
    near_y: NDArray[np.float64],
    nn: int,
    stamp: NDArray[np.int64],
    hyp: int,
    px: float,
    py: float,
    pt: float,
    beta: NDArray[np.float64],
    vis_hi: float,
    vis_lo: float,
    half_fov: float,
    margin: float,
) -> int:
    """Near landmarks plainly visible from (px, py, pt) -- inside 0.95 max_range, beyond
    1.05 min_range, inside the field of view, away from every measured bearing -- that the
    path did not match (negative evidence)."""
    missed = 0
    for t in range(nn):
        if stamp[near_q[t]] == hyp:
            continue
        dx, dy = near_x[t] - px, near_y[t] - py
        rr = dx * dx + dy * dy
        if rr > vis_hi or rr < vis_lo:
            continue
        pred = np.arctan2(dy, dx) - pt
        if abs(_wrap(pred)) > half_fov - margin:
            continue
        alone = True
        for o in range(beta.shape[0]):
            if abs(_wrap(pred - beta[o])) <= 2.0 * margin:
                alone = False
                break
        if alone:
            missed += 1
    return missed


@njit(cache=True, error_model="numpy", nogil=True)
def hypotheses(
    L: NDArray[np.float64],
    beta: NDArray[np.float64],
    seeds: NDArray[np.int64],
    i0: int,
    i1: int,
    nb_lo: NDArray[np.int64],
    nb_hi: NDArray[np.int64],
    nb_idx: NDArray[np.int64],
    nb_xy: NDArray[np.float64],
    pair_d2: NDArray[np.float64],
    sigma: float,
    gate_chi2: float,
    threshold: float,
    joint_chi2: NDArray[np.float64],
    min_match: int,
    rmax2: float,
    rmin2: float,
    half_fov: float,
    vis_hi: float,
    vis_lo: float,
    miss_allow: int,
    scale: float,
    singular_rtol: float,
    max_nodes: int,
    max_work: int,
    stop_first: bool,
    capacity: int,
    relin: NDArray[np.int64],
    contested: NDArray[np.bool_],
    spur_w: float,
    miss_w: float,
    pretest: NDArray[np.float64],
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Every interpretation that a seed triple of bearings starts, verified bearing by bearing.

    For each seed (three observation indices) and each triple of distinct landmarks that can
    be seen together -- the first landmark ``i`` in ``[i0, i1)``, the others among its
    neighbours ``nb_idx[nb_lo[i]:nb_hi[i]]`` (coordinates ``nb_xy``; the anchor itself is
    not among them; without a range, every other landmark), their distances within
    ``pair_d2`` (squared largest distance between the landmarks of two bearings) -- the pose
    of the triple (eqs. 1-6, rule i, range limits) predicts every other bearing, and
    :func:`_verify` walks the assignments of the others depth first: each bearing matched to
    every unused landmark inside its gate (``sigma > 0``: chi-square on innovation^2 /
    (g^T Cov g + sigma^2) with the covariance of the pose so far; else ``|innovation| <=
    threshold``), the pose and covariance taking it in with a Kalman update (relinearised
    while a path has at most ``relin[s]`` pairs), or left unmatched while the path can still
    reach ``min_match`` matches. Complete paths are refined by Gauss-Newton over their pairs
    and, with sigma, kept only if ``sse / sigma^2 <= joint_chi2[n]`` (joint compatibility).

    ``missed`` counts the landmarks a kept hypothesis should plainly see (at a squared
    distance between ``vis_lo`` and ``vis_hi``, inside the field of view, away from every
    measured bearing) but matched to no bearing. ``stop_first`` ends the search at the first
    kept hypothesis with at most ``miss_allow`` of them.

    Returns assignments (K, m) in observation order (-1 unmatched), poses (K, 3) and missed
    (K,) of at most ``capacity`` complete paths, best first by the ranking's cost
    ``(m - n) spur_w + sse / (2 sigma^2) + missed miss_w`` (a huge ``spur_w`` ranks by matches
    first; when more are found, repeats of an interpretation from other seeds and then the
    worse ones are dropped as they come, as search._finish keeps its best MAX_LEAVES
    distinct ones), and the counters ``[nodes, examined, triples, existence,
    gate, found, stopped, visibility, bound, work]``; ``stopped`` is 1 when ``max_nodes`` or
    ``max_work`` ran out, 2 when ``stop_first`` ended the search.

    ``work`` measures time where ``nodes`` does not: every candidate landmark looked at
    counts, a node of the verification NODE_WORK plus once per landmark near its
    hypothesis (without a range, the whole map), a complete path LEAF_WORK. ``max_work``
    (0: none) is checked after every hypothesis and inside the verification, so a search of
    a large map without a range still stops when told to.
    """
    N = L.shape[0]
    m = beta.shape[0]
    eps_f2 = (1e-12 / scale) ** 2
    max_wild = m - min_match
    use_sigma = sigma > 0
    # The Kalman updates need a bearing variance in threshold mode too.
    sig_eff = sigma if use_sigma else threshold / 3.0
    sig2 = sig_eff * sig_eff
    cb = np.cos(beta)
    sb = np.sin(beta)
    margin = 3.0 * sig_eff
    # The gate in the bound below: chi-square with sigma, else threshold^2 against sigma_eff^2
    # (whatever the variance, |innovation| <= threshold rejects no more than this).
    bound_k = gate_chi2 if use_sigma else threshold * threshold / sig2
    out_a = np.empty((capacity, m), dtype=np.int64)
    out_p = np.empty((capacity, 3))
    out_miss = np.empty(capacity, dtype=np.int64)
    out_key = np.empty(capacity)
    bar = np.full(1, np.inf)
    stamp = np.zeros(N, dtype=np.int64)
    lm = np.empty(m, dtype=np.int64)  # matched landmarks, in match order
    mx = np.empty(m)  # and their coordinates
    my = np.empty(m)
    ones = np.ones(m)
    bm = np.empty(m)  # their bearings
    om = np.empty(m, dtype=np.int64)  # their observations
    rest = np.empty(m, dtype=np.int64)
    # The landmarks a hypothesis can see (within max_range, with a margin for the updates
    # of its pose), gathered once per hypothesis.
    width = 1
    for i in range(i0, i1):
        width = max(width, nb_hi[i] - nb_lo[i])
    near_q = np.empty(width + 1, dtype=np.int64)
    near_x = np.empty(width + 1)
    near_y = np.empty(width + 1)
    near2 = rmax2 * 1.05**2
    # Per anchor: the candidates for the second and third landmark and their pair terms.
    jq = np.empty(width, dtype=np.int64)
    kq = np.empty(width, dtype=np.int64)
    jt = np.empty((11, width))
    kt = np.empty((11, width))
    # Per second landmark: each third-landmark candidate's pose and fate, and the hypotheses.
    hk = np.empty(width, dtype=np.int64)
    hx = np.empty(width)
    hy = np.empty(width)
    hd = np.empty(width)
    status = np.empty(width, dtype=np.int64)
    # The verification's depth-first walk: state on entering each level, chosen landmark,
    # next option, and each level's gated candidates.
    sp = np.empty((m + 1, 4))
    scov = np.empty((m + 1, 6))
    sn = np.empty(m + 1, dtype=np.int64)
    sw = np.empty(m + 1, dtype=np.int64)
    chosen = np.empty(m + 1, dtype=np.int64)
    pos = np.empty(m + 1, dtype=np.int64)
    ncand = np.empty(m + 1, dtype=np.int64)
    cq = np.empty((m, width + 1), dtype=np.int64)
    cin = np.empty((m, width + 1))
    cgx = np.empty((m, width + 1))
    cgy = np.empty((m, width + 1))
    cv = np.empty((m, width + 1))
    cs = np.empty((m, width + 1))
    cnt = np.zeros(5, dtype=np.int64)
    pre_work = np.empty((4, max(width + 1, m)))
    # Per level of a first fit's verification: bearings from there on that failed the cheap
    # test (wildcards to be, reserved in advance; zero in an exhaustive search).
    ahead = np.zeros(m + 1, dtype=np.int64)
    # Scratch of the verification's first bound: flags and the near landmarks that pass.
    pick = np.empty((2, width + 1), dtype=np.int64)
    found = 0
    nodes = examined = triples = existence = gate = n_out = stopped = vis = bound = 0
    hyp = 0
    work = 0
    upfront = max_nodes == 0 and max_work == 0
    for s in range(seeds.shape[0]):
        if stopped:
            break
        oa, ob, oc = seeds[s, 0], seeds[s, 1], seeds[s, 2]
        nr = 0
        for o in range(m):
            if o != oa and o != ob and o != oc:
                rest[nr] = o
                nr += 1
        rot_b = np.exp(1j * (beta[ob] - beta[oa]))
        rot_c = np.exp(1j * (beta[oc] - beta[oa]))
        d_ab, d_ac, d_bc = pair_d2[oa, ob], pair_d2[oa, oc], pair_d2[ob, oc]
        # The cheap test of _can_reach (with sigma; 0 turns it off).
        k_pre = pretest[s] * joint_chi2[m] if use_sigma else 0.0
        for i in range(i0, i1):
            if stopped:
                break
            lo, hi = nb_lo[i], nb_hi[i]
            lix, liy = L[i, 0], L[i, 1]
            # Each neighbour's terms of eqs. 1-3 as the second landmark (bearing ob) and as
            # the third (oc), once per anchor, for those within the pair limits.
            nj = _pair_terms(lo, hi, nb_idx, nb_xy, i, lix, liy, d_ab, rot_b, jq, jt)
            nk = _pair_terms(lo, hi, nb_idx, nb_xy, i, lix, liy, d_ac, rot_c, kq, kt)
            vis += 2 * (hi - lo) - nj - nk
            work += 2 * (hi - lo)
            for jj in range(nj):
                if stopped:
                    break
                j = jq[jj]
                ljx, ljy = jt[0, jj], jt[1, jj]
                nh = _triple_poses(
                    j, jt[:, jj], lix, liy, kq, kt, nk, d_bc, singular_rtol, eps_f2, rmax2, rmin2,
                    hk, hx, hy, hd, status,
                )  # fmt: skip
                work += nk
                # The counters advance over the candidates in order, as if each were taken in
                # turn, so that they (and the node budget) read the same wherever it stops.
                # Without a budget they are added for all at once, in a pass that vectorises,
                # and those of the candidates after a stop are taken back.
                if upfront:
                    t_vis, t_ex, t_sol = _tally(status, 0, nk)
                    vis += t_vis
                    existence += t_ex
                    triples += t_sol
                    nodes += t_sol
                done = 0
                for h in range(nh + 1):
                    upto = hk[h] if h < nh else nk
                    if not upfront:
                        t_vis, t_ex, t_sol = _tally(status, done, upto)
                        vis += t_vis
                        existence += t_ex
                        triples += t_sol
                        nodes += t_sol
                    if h == nh:
                        break
                    kk = upto
                    done = kk + 1
                    if not upfront:
                        triples += 1
                        nodes += 1
                    k = kq[kk]
                    lkx, lky = kt[0, kk], kt[1, kk]
                    px, py, d2a = hx[kk], hy[kk], hd[kk]
                    # The heading's cosine and sine: the direction to the first landmark turned
                    # back by its bearing (the arctangent waits for the cheap test).
                    if d2a > 0.0:
                        da = np.sqrt(d2a)
                        ct = ((lix - px) * cb[oa] + (liy - py) * sb[oa]) / da
                        st = ((liy - py) * cb[oa] - (lix - px) * sb[oa]) / da
                    else:
                        ct, st = cb[oa], -sb[oa]
                    nn = _gather(
                        lo, hi, nb_idx, nb_xy, i, lix, liy, px, py, near2, near_q, near_x, near_y
                    )
                    work += (hi - lo) + nr * nn
                    if (max_work > 0 and work >= max_work) or (
                        max_nodes > 0 and nodes >= max_nodes
                    ):
                        stopped = 1
                        break
                    hyp += 1
                    lm[0], lm[1], lm[2] = i, j, k
                    mx[0], mx[1], mx[2] = lix, ljx, lkx
                    my[0], my[1], my[2] = liy, ljy, lky
                    bm[0], bm[1], bm[2] = beta[oa], beta[ob], beta[oc]
                    om[0], om[1], om[2] = oa, ob, oc
                    stamp[i] = stamp[j] = stamp[k] = hyp
                    h00, h01, h02, h11, h12, h22 = _info(mx, my, 3, px, py)
                    c00, c01, c02, c11, c12, c22, tr = _inv3(h00, h01, h02, h11, h12, h22, sig2)
                    if k_pre > 0 and not _can_reach(
                        rest, nr, min_match - 3, cb, sb, px, py, ct, st, near_q, near_x,
                        near_y, nn, (i, j, k), (c00, c01, c02, c11, c12, c22), sig2, k_pre,
                        pre_work,
                    ):  # fmt: skip
                        bound += 1
                        continue
                    if k_pre > 0 and stop_first:
                        for r in range(nr - 1, -1, -1):
                            ahead[r] = ahead[r + 1] + int(pre_work[3, r])
                    pt = _wrap(np.arctan2(liy - py, lix - px) - beta[oa])
                    sp[0, 0], sp[0, 1], sp[0, 2], sp[0, 3] = px, py, pt, tr
                    scov[0, 0], scov[0, 1], scov[0, 2] = c00, c01, c02
                    scov[0, 3], scov[0, 4], scov[0, 5] = c11, c12, c22
                    cnt[:] = 0
                    # Budgets left to the verification (0: no limit; at least 1 when limited).
                    left = max(1, max_nodes - nodes) if max_nodes > 0 else 0
                    left_work = max(1, max_work - work) if max_work > 0 else 0
                    n_out, stop = _verify(
                        L, beta, cb, sb, rest, nr, lm, mx, my, ones, bm, om, stamp, hyp,
                        near_q, near_x, near_y, nn, sp, scov, sn, sw, chosen, pos, ncand,
                        cq, cin, cgx, cgy, cv, cs, sig2, use_sigma, gate_chi2, threshold, bound_k,
                        rmax2, rmin2, max_wild, min_match, joint_chi2, vis_hi, vis_lo,
                        half_fov, margin, out_a, out_p, out_miss, out_key, bar, spur_w,
                        miss_w, n_out, stop_first, miss_allow, left, left_work, relin[s],
                        contested, cnt,
                        ahead, pick,
                    )  # fmt: skip
                    nodes += cnt[0]
                    work += _walk_work(cnt[0], cnt[4], nn, miss_w)
                    examined += cnt[1]
                    gate += cnt[2]
                    bound += cnt[3]
                    found += cnt[4]
                    if stop:
                        stopped = stop
                        if upfront:
                            t_vis, t_ex, t_sol = _tally(status, kk + 1, nk)
                            vis -= t_vis
                            existence -= t_ex
                            triples -= t_sol
                            nodes -= t_sol
                        break
                if (max_nodes > 0 and nodes >= max_nodes) or (max_work > 0 and work >= max_work):
                    stopped = 1
    counts = np.array(
        [nodes, examined, triples, existence, gate, found, stopped, vis, bound, work],
        dtype=np.int64,
    )
    order = np.argsort(out_key[:n_out], kind="mergesort")
    return out_a[order], out_p[order], out_miss[order], counts


@njit(cache=True, error_model="numpy")
def covariances(
    Lm: NDArray[np.float64], w: NDArray[np.float64], poses: NDArray[np.float64], scale: float
) -> NDArray[np.float64]:
    """``scale * (sum_i w_i g_i g_i^T + 1e-12 I)^-1`` for each path (see search._finish)."""
    K, n = w.shape
    out = np.empty((K, 3, 3))
    for k in range(K):
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        for i in range(n):
            if w[k, i] > 0:
                dx = Lm[k, i, 0] - poses[k, 0]
                dy = Lm[k, i, 1] - poses[k, 1]
                r2 = dx * dx + dy * dy
                gx, gy = dy / r2, -dx / r2
                h00 += gx * gx
                h01 += gx * gy
                h02 -= gx
                h11 += gy * gy
                h12 -= gy
                h22 += 1.0
        h00 += 1e-12
        h11 += 1e-12
        h22 += 1e-12
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        c11 = h00 * h22 - h02 * h02
        c12 = h01 * h02 - h00 * h12
        c22 = h00 * h11 - h01 * h01
        f = scale / (h00 * c00 + h01 * c01 + h02 * c02)
        out[k, 0, 0], out[k, 0, 1], out[k, 0, 2] = c00 * f, c01 * f, c02 * f
        out[k, 1, 0], out[k, 1, 1], out[k, 1, 2] = c01 * f, c11 * f, c12 * f
        out[k, 2, 0], out[k, 2, 1], out[k, 2, 2] = c02 * f, c12 * f, c22 * f
    return out


@njit(cache=True, error_model="numpy")
def merge(
    rank: NDArray[np.int64],
    poses: NDArray[np.float64],
    inv: NDArray[np.float64],
    reach2: NDArray[np.float64],
    same_chi2: float,
) -> NDArray[np.int64]:
    """Greedy merge in rank order (see search._merge); returns the indices kept.

    ``reach2[i]`` bounds the squared Euclidean gap (x, y, theta) at which pose i can still be
    within ``same_chi2`` of another in its own metric (``same_chi2`` times the trace of its
    covariance, which bounds the largest eigenvalue), so most pairs are passed over before
    the quadratic forms.
    """
    K = rank.shape[0]
    keep = np.empty(K, np.int64)
    nk = 0
    for a in range(K):
        i = rank[a]
        xi, yi, ti = poses[i, 0], poses[i, 1], poses[i, 2]
        dup = False
        for b in range(nk):
            k = keep[b]
            d0 = poses[k, 0] - xi
            d1 = poses[k, 1] - yi
            d2 = _wrap(poses[k, 2] - ti)
            if abs(d0) < 1e-6 and abs(d1) < 1e-6 and abs(d2) < 1e-6:
                dup = True
                break
            dd = d0 * d0 + d1 * d1 + d2 * d2
            if dd > reach2[i] or dd > reach2[k]:
                continue
            for j in (i, k):
                q = (
                    inv[j, 0, 0] * d0 * d0
                    + inv[j, 1, 1] * d1 * d1
                    + inv[j, 2, 2] * d2 * d2
                    + (inv[j, 0, 1] + inv[j, 1, 0]) * d0 * d1
                    + (inv[j, 0, 2] + inv[j, 2, 0]) * d0 * d2
                    + (inv[j, 1, 2] + inv[j, 2, 1]) * d1 * d2
                )
                if not q <= same_chi2:  # NaN (a covariance that is not finite): no merge
                    break
            else:
                dup = True
                break
        if not dup:
            keep[nk] = i
            nk += 1
    return keep[:nk].copy()


@njit(cache=True, error_model="numpy")
def widest_triple(bearings: NDArray[np.float64]) -> tuple[int, int, int]:
    """The first triple (in lexicographic order) whose smallest circular gap is largest."""
    m = bearings.shape[0]
    best = -1.0
    bi = bj = bk = 0
    for i in range(m):
        a = bearings[i] % TWO_PI
        for j in range(i + 1, m):
            b = bearings[j] % TWO_PI
            for k in range(j + 1, m):
                c = bearings[k] % TWO_PI
                lo, mid, hi = a, b, c
                if lo > mid:
                    lo, mid = mid, lo
                if mid > hi:
                    mid, hi = hi, mid
                if lo > mid:
                    lo, mid = mid, lo
                gap = min(mid - lo, hi - mid, lo + TWO_PI - hi)
                if gap > best:
                    best, bi, bj, bk = gap, i, j, k
    return bi, bj, bk
