"""The tracker's compiled kernels (numba): odometry integration, association, EKF update,
merging of hypotheses.

Each kernel is the one implementation of its piece of maths; the Python modules around them
(:mod:`omniloc.track.motion`, :mod:`omniloc.track.ekf`) validate their input and say what
they mean. Angles are wrapped, 3x3 inverses taken and squared bearing errors summed by the
section-2 building blocks of :mod:`.geometry` (one implementation each). The frame
likelihood itself (what a matched bearing, a clutter bearing and a missed landmark are
worth) is not here: it is :class:`omniloc.sensor.SensorModel`'s, computed with numpy before
the association kernel, which only chooses the assignment that maximises the sum it is given.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import information, inv3, squared_error, wrap_angle

__all__ = ["associate", "collapse", "distinct", "iekf_update", "integrate_pieces"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@njit(cache=True, error_model="numpy")
def integrate_pieces(
    dt: FloatArray, vx: FloatArray, vy: FloatArray, w: FloatArray, noise: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Compose pieces of constant body twist into ``(delta, Q)``.

    For each piece, in order: its exact motion (the SE(2) exponential of the twist times
    ``dt``: ``dtheta = w dt``, ``[dx, dy] = V(dtheta) [vx, vy] dt`` with
    ``V = [[sin/th, -(1-cos)/th], [(1-cos)/th, sin/th]]``), its noise in its start frame
    (diagonal: along x, across, heading; ``noise`` = along_per_m, across_per_m,
    turn_per_rad, turn_per_m, turn_per_s, along_per_s), then the composition
    ``T <- T (+) d`` with ``Q <- Jp Q Jp^T + Jd N Jd^T``. The total heading is not wrapped.
    """
    tx = 0.0
    ty = 0.0
    tt = 0.0
    Q = np.zeros((3, 3))
    Jp = np.eye(3)
    Jd = np.eye(3)
    N = np.zeros((3, 3))
    for k in range(dt.size):
        h = dt[k]
        if h <= 0.0:
            continue
        phi = w[k] * h
        if abs(phi) < 1e-9:
            a = 1.0 - phi * phi / 6.0
            b = 0.5 * phi
        else:
            a = np.sin(phi) / phi
            b = (1.0 - np.cos(phi)) / phi
        ux = vx[k] * h
        uy = vy[k] * h
        dx = a * ux - b * uy
        dy = b * ux + a * uy
        dist = np.sqrt(ux * ux + uy * uy)
        N[0, 0] = noise[0] * dist + noise[5] * h
        N[1, 1] = noise[1] * dist
        N[2, 2] = noise[2] * abs(phi) + noise[3] * dist + noise[4] * h
        c = np.cos(tt)
        s = np.sin(tt)
        Jp[0, 2] = -s * dx - c * dy
        Jp[1, 2] = c * dx - s * dy
        Jd[0, 0] = c
        Jd[0, 1] = -s
        Jd[1, 0] = s
        Jd[1, 1] = c
        Q = Jp @ Q @ Jp.T + Jd @ N @ Jd.T
        tx += c * dx - s * dy
        ty += s * dx + c * dy
        tt += phi
    out = np.array([tx, ty, tt])
    return out, 0.5 * (Q + Q.T)


@njit(cache=True, error_model="numpy")
def associate(gain: FloatArray, out: IntArray, totals: FloatArray) -> IntArray:
    """For each hypothesis, the K assignments of bearings to landmarks with the largest
    total gain (K = ``out.shape[1]``): ``gain[h, i, j]`` is what matching bearing i to
    landmark j adds over leaving the bearing as clutter (and the landmark unseen); only
    positive, finite gains are candidates; a landmark takes at most one bearing; "all
    clutter" (total 0) is always one of the assignments. Exhaustive depth-first search with
    the bound "current + best remaining gain of each later bearing" against the K-th best.

    Writes ``out[h, k, i]`` (landmark, or -1 for clutter) and ``totals[h, k]``, best first,
    and returns how many assignments each hypothesis has (1..K).
    """
    H, m, n = gain.shape
    K = out.shape[1]
    found = np.ones(H, dtype=np.int64)
    out[:, :, :] = -1
    totals[:, :] = -np.inf
    totals[:, 0] = 0.0
    if m == 0 or n == 0:
        return found
    cand = np.empty((m, n), dtype=np.int64)
    ncand = np.zeros(m, dtype=np.int64)
    best_rest = np.zeros(m + 1)
    choice = np.zeros(m, dtype=np.int64)
    used = np.zeros(n, dtype=np.bool_)
    cur = np.empty(m, dtype=np.int64)
    for h in range(H):
        any_cand = False
        for i in range(m):
            k = 0
            for j in range(n):
                g = gain[h, i, j]
                if g > 0.0 and np.isfinite(g):
                    p = k  # insertion sort, best gain first
                    while p > 0 and gain[h, i, cand[i, p - 1]] < g:
                        cand[i, p] = cand[i, p - 1]
                        p -= 1
                    cand[i, p] = j
                    k += 1
            ncand[i] = k
            if k > 0:
                any_cand = True
        if not any_cand:
            continue
        best_rest[m] = 0.0
        for i in range(m - 1, -1, -1):
            best_rest[i] = best_rest[i + 1] + (gain[h, i, cand[i, 0]] if ncand[i] > 0 else 0.0)
        nf = 0
        used[:] = False
        i = 0
        total = 0.0
        choice[0] = -1
        while i >= 0:
            if choice[i] >= 0 and choice[i] < ncand[i]:
                used[cand[i, choice[i]]] = False
                total -= gain[h, i, cand[i, choice[i]]]
            choice[i] += 1
            while choice[i] < ncand[i] and used[cand[i, choice[i]]]:
                choice[i] += 1
            if choice[i] > ncand[i]:
                i -= 1
                continue
            if choice[i] < ncand[i]:
                j = cand[i, choice[i]]
                used[j] = True
                total += gain[h, i, j]
                cur[i] = j
            else:
                cur[i] = -1
            kth = totals[h, K - 1] if nf >= K else -np.inf
            if total + best_rest[i + 1] <= kth:
                continue
            if i < m - 1:
                i += 1
                choice[i] = -1
                continue
            # A complete assignment better than the K-th: insert it in order.
            p = nf if nf < K else K - 1
            while p > 0 and totals[h, p - 1] < total:
                if p < K:
                    totals[h, p] = totals[h, p - 1]
                    for q in range(m):
                        out[h, p, q] = out[h, p - 1, q]
                p -= 1
            totals[h, p] = total
            for q in range(m):
                out[h, p, q] = cur[q]
            if nf < K:
                nf += 1
        found[h] = nf
    return found


@njit(cache=True, error_model="numpy")
def _inv3(A: FloatArray) -> FloatArray:
    """The inverse of a symmetric 3x3 (its upper triangle read) as a full matrix."""
    c00, c01, c02, c11, c12, c22, _ = inv3(
        A[0, 0], A[0, 1], A[0, 2], A[1, 1], A[1, 2], A[2, 2], 1.0, 0.0
    )
    out = np.empty((3, 3))
    out[0, 0], out[0, 1], out[0, 2] = c00, c01, c02
    out[1, 0], out[1, 1], out[1, 2] = c01, c11, c12
    out[2, 0], out[2, 1], out[2, 2] = c02, c12, c22
    return out


@njit(cache=True, error_model="numpy")
def _map_cost(
    x: FloatArray,
    x0: FloatArray,
    Pinv: FloatArray,
    Lx: FloatArray,
    Ly: FloatArray,
    z: FloatArray,
    ones: FloatArray,
    k: int,
    inv_r: float,
) -> float:
    e0 = x[0] - x0[0]
    e1 = x[1] - x0[1]
    e2 = wrap_angle(x[2] - x0[2])
    c = (
        Pinv[0, 0] * e0 * e0
        + Pinv[1, 1] * e1 * e1
        + Pinv[2, 2] * e2 * e2
        + 2.0 * (Pinv[0, 1] * e0 * e1 + Pinv[0, 2] * e0 * e2 + Pinv[1, 2] * e1 * e2)
    )
    c += squared_error(Lx, Ly, z, ones, k, x[0], x[1], x[2]) * inv_r
    return 0.5 * c


@njit(cache=True, error_model="numpy")
def _posterior_information(
    A: FloatArray,
    Pinv: FloatArray,
    Lx: FloatArray,
    Ly: FloatArray,
    ones: FloatArray,
    k: int,
    x: FloatArray,
    inv_r: float,
) -> None:
    """``A <- P^-1 + sum g g^T / var`` (the bearings' information from :mod:`.geometry`)."""
    h00, h01, h02, h11, h12, h22 = information(Lx, Ly, ones, k, x[0], x[1])
    A[0, 0] = Pinv[0, 0] + h00 * inv_r
    A[0, 1] = A[1, 0] = Pinv[0, 1] + h01 * inv_r
    A[0, 2] = A[2, 0] = Pinv[0, 2] + h02 * inv_r
    A[1, 1] = Pinv[1, 1] + h11 * inv_r
    A[1, 2] = A[2, 1] = Pinv[1, 2] + h12 * inv_r
    A[2, 2] = Pinv[2, 2] + h22 * inv_r


@njit(cache=True, error_model="numpy")
def iekf_update(
    poses: FloatArray,
    covs: FloatArray,
    L: FloatArray,
    z: FloatArray,
    assign: IntArray,
    var: float,
    iters: int,
) -> tuple[FloatArray, FloatArray]:
    """Iterated EKF update of every hypothesis with its assigned bearings.

    The maximum a posteriori pose of the prior ``N(poses[h], covs[h])`` and the bearings
    ``z[i]`` of landmarks ``L[assign[h, i]]`` (``assign < 0``: not used), noise variance
    ``var``, by Gauss-Newton in information form (``(P^-1 + sum g g^T / var) dx = ...``),
    a step kept only when it lowers the MAP cost (halved up to 6 times), at most ``iters``
    steps; the covariance is the inverse information at the final pose. Bearing gradient
    ``g = [dy / r^2, -dx / r^2, -1]``.
    """
    H = poses.shape[0]
    m = z.size
    out_p = poses.copy()
    out_c = covs.copy()
    Lx = np.empty(m)
    Ly = np.empty(m)
    zz = np.empty(m)
    ones = np.ones(m)
    inv_r = 1.0 / var
    for h in range(H):
        k = 0
        for i in range(m):
            j = assign[h, i]
            if j >= 0:
                Lx[k] = L[j, 0]
                Ly[k] = L[j, 1]
                zz[k] = z[i]
                k += 1
        if k == 0:
            continue
        x0 = poses[h].copy()
        P0 = covs[h] + 1e-12 * np.eye(3)
        Pinv = _inv3(P0)
        x = x0.copy()
        cost = _map_cost(x, x0, Pinv, Lx, Ly, zz, ones, k, inv_r)
        A = np.empty((3, 3))
        b = np.empty(3)
        for _ in range(iters):
            _posterior_information(A, Pinv, Lx, Ly, ones, k, x, inv_r)
            e0 = x[0] - x0[0]
            e1 = x[1] - x0[1]
            e2 = wrap_angle(x[2] - x0[2])
            for r in range(3):
                b[r] = -(Pinv[r, 0] * e0 + Pinv[r, 1] * e1 + Pinv[r, 2] * e2)
            for q in range(k):
                dx = Lx[q] - x[0]
                dy = Ly[q] - x[1]
                r2 = dx * dx + dy * dy
                res = wrap_angle(zz[q] - (np.arctan2(dy, dx) - x[2])) * inv_r
                b[0] += dy / r2 * res
                b[1] -= dx / r2 * res
                b[2] -= res
            Ai = _inv3(A)
            step = Ai @ b
            scale = 1.0
            accepted = False
            for _h in range(7):
                cand = x + scale * step
                c2 = _map_cost(cand, x0, Pinv, Lx, Ly, zz, ones, k, inv_r)
                if c2 <= cost:
                    x = cand
                    cost = c2
                    accepted = True
                    break
                scale *= 0.5
            if not accepted:
                break
            if abs(step[0]) + abs(step[1]) < 1e-7 and abs(step[2]) < 1e-8:
                break
        # covariance: inverse information at the final pose
        _posterior_information(A, Pinv, Lx, Ly, ones, k, x, inv_r)
        C = _inv3(A)
        x[2] = wrap_angle(x[2])
        out_p[h] = x
        out_c[h] = 0.5 * (C + C.T)
    return out_p, out_c


@njit(cache=True, error_model="numpy")
def distinct(
    poses: FloatArray, covs: FloatArray, chi2: float, max_dpos: float, max_dtheta: float
) -> NDArray[np.bool_]:
    """Which hypotheses to keep when equal ones merge: going through them in the order
    given (best first), a hypothesis is dropped when it is the same as one already kept --
    squared Mahalanobis distance below ``chi2`` on the sum of the two covariances, AND
    within ``max_dpos`` metres and ``max_dtheta`` radians."""
    H = poses.shape[0]
    keep = np.zeros(H, dtype=np.bool_)
    kept = np.empty(H, dtype=np.int64)
    nk = 0
    for a in range(H):
        same = False
        for q in range(nk):
            b = kept[q]
            dx = poses[a, 0] - poses[b, 0]
            dy = poses[a, 1] - poses[b, 1]
            dt = wrap_angle(poses[a, 2] - poses[b, 2])
            if dx * dx + dy * dy > max_dpos * max_dpos or abs(dt) > max_dtheta:
                continue
            S = covs[a] + covs[b]
            Si = _inv3(S)
            d2 = 0.0
            e = (dx, dy, dt)
            for i in range(3):
                for j in range(3):
                    d2 += e[i] * Si[i, j] * e[j]
            if d2 < chi2:
                same = True
                break
        if not same:
            keep[a] = True
            kept[nk] = a
            nk += 1
    return keep


@njit(cache=True, error_model="numpy")
def collapse(
    parent: IntArray, poses: FloatArray, covs: FloatArray, logw: FloatArray, chi2: float
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
    """Collapse each hypothesis's children that end up at the same pose.

    ``parent`` is sorted, and within a parent the children come best (largest ``logw``)
    first. A child joins the first group of its parent whose leader is within squared
    Mahalanobis distance ``chi2`` (on the sum of the two covariances); otherwise it leads a
    new group. Each group becomes one Gaussian by moment matching with weights
    ``exp(logw)`` (headings averaged as wrapped offsets from the leader), and its log
    weight is the log-sum-exp of its members' (the joint probabilistic data association
    of the members' assignments).

    Returns the groups' leaders (the index of each group's best child), poses,
    covariances and log weights.
    """
    n = parent.size
    group = np.empty(n, dtype=np.int64)
    leaders = np.empty(n, dtype=np.int64)
    g_parent = np.empty(n, dtype=np.int64)
    ng = 0
    first_g = 0
    for a in range(n):
        if a == 0 or parent[a] != parent[a - 1]:
            first_g = ng
        found = -1
        for g in range(first_g, ng):
            b = leaders[g]
            dx = poses[a, 0] - poses[b, 0]
            dy = poses[a, 1] - poses[b, 1]
            dt = wrap_angle(poses[a, 2] - poses[b, 2])
            Si = _inv3(covs[a] + covs[b])
            e0, e1, e2 = dx, dy, dt
            d2 = (
                Si[0, 0] * e0 * e0
                + Si[1, 1] * e1 * e1
                + Si[2, 2] * e2 * e2
                + 2.0 * (Si[0, 1] * e0 * e1 + Si[0, 2] * e0 * e2 + Si[1, 2] * e1 * e2)
            )
            if d2 < chi2:
                found = g
                break
        if found < 0:
            leaders[ng] = a
            g_parent[ng] = parent[a]
            found = ng
            ng += 1
        group[a] = found
    gmax = np.full(ng, -np.inf)
    for a in range(n):
        gmax[group[a]] = max(gmax[group[a]], logw[a])
    ssum = np.zeros(ng)
    for a in range(n):
        ssum[group[a]] += np.exp(logw[a] - gmax[group[a]])
    out_w = gmax + np.log(ssum)
    out_p = np.zeros((ng, 3))
    out_c = np.zeros((ng, 3, 3))
    for a in range(n):
        g = group[a]
        w = np.exp(logw[a] - out_w[g])
        out_p[g, 0] += w * poses[a, 0]
        out_p[g, 1] += w * poses[a, 1]
        out_p[g, 2] += w * wrap_angle(poses[a, 2] - poses[leaders[g], 2])
    for g in range(ng):
        out_p[g, 2] = wrap_angle(out_p[g, 2] + poses[leaders[g], 2])
    for a in range(n):
        g = group[a]
        w = np.exp(logw[a] - out_w[g])
        e0 = poses[a, 0] - out_p[g, 0]
        e1 = poses[a, 1] - out_p[g, 1]
        e2 = wrap_angle(poses[a, 2] - out_p[g, 2])
        e = (e0, e1, e2)
        for i in range(3):
            for j in range(3):
                out_c[g, i, j] += w * (covs[a, i, j] + e[i] * e[j])
    return leaders[:ng], out_p, out_c, out_w
