"""The paper's interpretation tree (rules i and ii, a fixed threshold, no wildcards), compiled.

The hot path of the commonest call, ``localize(map, bearings)`` with a threshold. What it
computes, in order: a depth-first walk over the assignments of the bearings (in level order)
to distinct landmarks; at depth 3 the pose of the three pairs must exist (rule i: eqs. 1-6,
positive distance ratios); deeper, the bearing predicted from the path's pose must lie within
the threshold (rule ii), and a node that passes re-estimates the pose from all its pairs
(eq. 4's sums kept incrementally; the re-estimate replaces the pose only where eqs. 1-6 accept
it). It visits exactly the nodes of the readable tree in :mod:`omniloc.search.tree` and of the
plain reading of the paper (``benchmarks/plain_reading.py``), with the same arithmetic, which
the tests check node for node.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import distance_ratio, pair_terms, pose_exists, pose_from_sums

__all__ = ["TreeCounts", "TreeLimits", "paper_tree", "widest_triple"]

TWO_PI = 2.0 * np.pi


class TreeLimits(NamedTuple):
    """The rules' constants and the budget of :func:`paper_tree`."""

    threshold: float  #: rule (ii): largest |predicted - measured|, radians
    singular_rtol: float  #: rule (i): relative tolerance of a singular sum of P_i
    eps_f2: float  #: rule (i): |f|^2 at or below this is a robot at infinity
    max_nodes: int  #: stop after this many nodes (0: no limit)
    capacity: int  #: complete paths kept (the first ones)


class TreeCounts(NamedTuple):
    """What :func:`paper_tree` did."""

    nodes: int  #: every node visited
    examined: int  #: nodes at depth four or deeper (the paper's Table 1)
    triples: int  #: depth-3 pose solutions attempted (rule i)
    pruned_existence: int  #: nodes cut by rule (i)
    pruned_gate: int  #: nodes cut by rule (ii)
    leaves: int  #: complete paths found (more than ``capacity`` when some were not kept)
    stopped: int  #: 1 when ``max_nodes`` ran out


@njit(cache=True, error_model="numpy")
def paper_tree(
    L: NDArray[np.float64], beta: NDArray[np.float64], lim: TreeLimits
) -> tuple[NDArray[np.int64], NDArray[np.float64], TreeCounts]:
    """Walk the tree for bearings ``beta`` (in level order) over landmarks ``L`` (N, 2).

    Returns the complete paths' assignments (K, m) and poses (K, 3), K <= ``lim.capacity``
    (the first ones found), and the counters.
    """
    N = L.shape[0]
    m = beta.shape[0]
    capacity = lim.capacity
    assign = np.full(m, -1, dtype=np.int64)
    used = np.zeros(N, dtype=np.bool_)
    nxt = np.zeros(m + 1, dtype=np.int64)
    # The path's state on entering each level: eq. 4's sums S (s00, s01, s11) and T, its pose,
    # and the world direction of the level's bearing from that pose.
    S = np.zeros((m + 1, 3))
    T = np.zeros((m + 1, 2))
    P = np.zeros((m + 1, 3))
    U = np.zeros((m + 1, 2))
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
    use_tan = lim.threshold < 0.5 * np.pi
    tan_thr = np.tan(lim.threshold) if use_tan else 0.0
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
            a, b, p00, p01, p11, pb0, pb1 = pair_terms(
                L[j, 0] - L[anchor, 0], L[j, 1] - L[anchor, 1], rot[1]
            )
            S[2, 0], S[2, 1], S[2, 2] = p00, p01, p11
            T[2, 0], T[2, 1] = pb0, pb1
            a1, b1 = a, b
            ok = True
        elif level == 2:
            # Rule (i): three pairs must give a pose.
            triples += 1
            a, b, p00, p01, p11, pb0, pb1 = pair_terms(
                L[j, 0] - L[anchor, 0], L[j, 1] - L[anchor, 1], rot[2]
            )
            s00, s01, s11 = S[2, 0] + p00, S[2, 1] + p01, S[2, 2] + p11
            t0, t1 = T[2, 0] + pb0, T[2, 1] + pb1
            fx, fy, det, f2, rx, ry, th = pose_from_sums(
                s00, s01, s11, t0, t1, L[anchor, 0], L[anchor, 1], b0
            )
            ok = (
                pose_exists(det, s00, s01, s11, f2, lim.singular_rtol, lim.eps_f2)
                and distance_ratio(a1, b1, fx, fy) > 0
                and distance_ratio(a, b, fx, fy) > 0
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
                passes = abs((pred - beta[level] + np.pi) % TWO_PI - np.pi) <= lim.threshold
            if passes:
                ok = True
                a, b, p00, p01, p11, pb0, pb1 = pair_terms(
                    L[j, 0] - L[anchor, 0], L[j, 1] - L[anchor, 1], rot[level]
                )
                s00 = S[level, 0] + p00
                s01 = S[level, 1] + p01
                s11 = S[level, 2] + p11
                t0, t1 = T[level, 0] + pb0, T[level, 1] + pb1
                S[level + 1, 0], S[level + 1, 1], S[level + 1, 2] = s00, s01, s11
                T[level + 1, 0], T[level + 1, 1] = t0, t1
                fx, fy, det, f2, rx, ry, th = pose_from_sums(
                    s00, s01, s11, t0, t1, L[anchor, 0], L[anchor, 1], b0
                )
                # The re-estimate replaces the pose only where eqs. 1-6 accept it.
                valid = pose_exists(det, s00, s01, s11, f2, lim.singular_rtol, lim.eps_f2)
                if valid:
                    for k in range(1, level + 1):
                        lk = assign[k] if k < level else j
                        ak, bk, _, _, _, _, _ = pair_terms(
                            L[lk, 0] - L[anchor, 0], L[lk, 1] - L[anchor, 1], rot[k]
                        )
                        if not distance_ratio(ak, bk, fx, fy) > 0:
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
        if lim.max_nodes > 0 and nodes >= lim.max_nodes:
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
    k = min(n_leaves, capacity)
    counts = TreeCounts(nodes, examined, triples, existence, gate, n_leaves, stopped)
    return out_a[:k].copy(), out_p[:k].copy(), counts


@njit(cache=True, error_model="numpy")
def widest_triple(bearings: NDArray[np.float64]) -> tuple[int, int, int]:
    """The first triple of bearings (in lexicographic order) whose smallest circular gap is
    largest: the robust tree's first three levels (the best-conditioned pose)."""
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
