"""Hypothesise and verify, compiled: every landmark triple that can be seen together, for a
few seed triples of bearings, predicts the other bearings and is verified on them.

What :func:`hypotheses` computes, in order, for each seed (three bearings ``oa, ob, oc``) and
each anchor landmark ``i`` of the chunk ``[i0, i1)``:

1. the pair terms (eqs. 1-3) of every neighbour of ``i`` within the seed's pair limits, as the
   second landmark (bearing ``ob``) and as the third (``oc``), once per anchor
   (:func:`_anchor_pairs`);
2. for each second landmark ``j``, the pose of every third candidate ``k`` (eqs. 4-5) and its
   fate -- same landmark, beyond the pair limit, no pose (rule i), out of range, or a
   hypothesis -- in one pass the compiler vectorises (:func:`_triple_poses`);
3. for each hypothesis: the landmarks near its pose (:func:`_gather`), its covariance, a cheap
   necessary test that enough other bearings have a landmark inside a widened gate
   (:func:`_can_reach`), then the depth-first verification (:func:`_verify`): each other
   bearing matched to every landmark inside its chi-square gate, best first, the pose and
   covariance taking it in with a Kalman update, or left unmatched (a wildcard) while the
   path can still reach ``min_match`` matches; complete paths are refined by Gauss-Newton
   (once per interpretation: one reached again from another seed is skipped, :func:`_first_visit`),
   tested jointly, counted for negative evidence and kept in a bounded buffer by their cost
   (:func:`_keep`, :func:`_compact`).

Work is counted (:func:`_walk_work`) so that a time budget, which a kernel cannot read from a
clock, can stop it. The kernels release the GIL: the driver runs chunks of a large map on two
threads. The readable description of the same search, and its driver, is
:mod:`omniloc.search.hypotheses`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .evidence import detection_term, prior_log_density
from .geometry import (
    GATE_FLOOR,
    det3,
    gn_refine,
    information,
    inv3,
    pair_terms,
    pose_exists,
    position_from_sums,
    pred_var,
    ratio_from_parts,
    wrap_float,
)

__all__ = [
    "LEAF_WORK",
    "NODE_WORK",
    "Bearings",
    "Budget",
    "Gate",
    "HypothesisCounts",
    "Neighbours",
    "Scoring",
    "Seeds",
    "Visibility",
    "hypotheses",
]

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

#: A verification node's work beyond the landmarks it scans (its Kalman update or
#: relinearisation), and a complete path's (its Gauss-Newton refinement, the output buffer).
#: With HYPOTHESIS_WORK_PER_SECOND in omniloc.search.hypotheses, fitted to the kernel's time
#: on benchmark scenes b, b360 and c, 150 MRCLAM frames and maps of 40 and 60 landmarks
#: without a range: predicted / actual time 0.9-1.25.
NODE_WORK = 256
LEAF_WORK = 4096

#: Every kernel here: cached on disk, numpy's error model (inf and nan, no exceptions), no GIL.
_jit = njit(cache=True, error_model="numpy", nogil=True)


class Neighbours(NamedTuple):
    """The map and, per landmark, the landmarks it can be seen with (CSR lists)."""

    xy: FloatArray  #: (N, 2) landmark positions
    lo: IntArray  #: (N,) start of landmark i's list in ``idx``
    hi: IntArray  #: (N,) end of it
    idx: IntArray  #: (E,) neighbour landmark indices (never i itself... but may be: skipped)
    nb_xy: FloatArray  #: (E, 2) their positions, contiguous with ``idx``


class Bearings(NamedTuple):
    """The measured bearings and what is known of their pairs."""

    beta: FloatArray  #: (m,) bearings, radians
    pair_d2: FloatArray  #: (m, m) squared largest distance of the landmarks of two bearings
    contested: NDArray[np.bool_]  #: (m,) the wildcard is tried after a landmark fits


class Seeds(NamedTuple):
    """The seed triples of bearings and how each is verified."""

    triples: IntArray  #: (S, 3) observation indices
    relin: IntArray  #: (S,) relinearise while a path has at most this many pairs
    pretest: FloatArray  #: (S,) margin of the cheap test (0: off)


class Gate(NamedTuple):
    """Noise, gates and the existence test."""

    sigma: float  #: bearing noise, radians; <= 0: the fixed threshold gates
    gate_chi2: float  #: one-dof chi-square gate
    threshold: float  #: fixed gate, radians (with sigma <= 0)
    joint_chi2: FloatArray  #: (m + 1,) joint test by number of pairs
    min_match: int  #: matched bearings a complete path needs
    singular_rtol: float  #: rule (i): singular sum of P_i
    eps_f2: float  #: rule (i): robot at infinity


class Visibility(NamedTuple):
    """Range limits (squared) and field of view."""

    rmax2: float  #: a matched landmark lies within this (search's slack included)
    rmin2: float  #: ... and beyond this
    half_fov: float  #: half the field of view, radians (inf: omnidirectional)
    plain_hi: float  #: plainly visible: within this (squared)
    plain_lo: float  #: ... and beyond this (squared)


class Scoring(NamedTuple):
    """The cost that orders complete paths in the bounded buffer (lower is better):
    ``(m - n) spur_w + sse / (2 sigma^2) + missed miss_w`` (or ``- ln B(n + 1, missed + 1)``
    when the detection rate is unknown) -- minus the log evidence of
    omniloc.search.scoring without its pose-volume term; and what a first fit needs to stop:
    that evidence, volume term included, above the null interpretation's by ``stop_margin``.
    """

    spur_w: float  #: an unmatched bearing, relative to a matched one
    miss_w: float  #: a plainly visible landmark not observed (0: not counted)
    unknown_rate: bool  #: detection rate unknown: missed count as -ln B(n + 1, missed + 1)
    log_null: float  #: log evidence of the null interpretation (every bearing clutter)
    region: tuple[float, float, float, float]  #: the prior's region of poses (x0, y0, x1, y1)
    edge: float  #: its Gaussian edges, metres
    log_volume: float  #: ln of its normalisation
    stop_margin: float  #: a first fit stops only this far above the null (nats) ...
    total_units: float  #: ... plus ln of the hypotheses the whole search would try, estimated
    #: from the rate so far over this many (seed, anchor) units (all seeds x the map)


class Budget(NamedTuple):
    """When to stop, and how much to keep."""

    max_nodes: int  #: 0: no limit
    max_work: int  #: 0: no limit (see :func:`_walk_work`)
    stop_first: bool  #: stop at the first acceptable fit
    miss_allow: int  #: a first fit leaves at most this many plainly visible landmarks unseen
    capacity: int  #: complete paths kept


class HypothesisCounts(NamedTuple):
    """What :func:`hypotheses` did."""

    nodes: int  #: triples solved + verification nodes
    examined: int  #: verification nodes
    triples: int  #: landmark triples whose pose was solved
    pruned_existence: int  #: triples with no pose (rule i)
    pruned_gate: int  #: verification nodes where no landmark fell in the gate
    found: int  #: complete paths that passed the joint test (a repeat from another seed once)
    stopped: int  #: 1 a budget ran out, 2 a first fit ended the search
    pruned_visibility: int  #: candidates beyond a pair limit or out of range
    pruned_bound: int  #: hypotheses cut by the cheap test, paths cut by the match bound
    work: int  #: units of work (see :func:`_walk_work`)


class _Path(NamedTuple):
    """The pairs of the path being verified, in match order (the seed's three first)."""

    map_xy: FloatArray  #: (N, 2) every landmark's position
    lm: IntArray  #: (m,) landmarks
    lx: FloatArray  #: (m,) their x
    ly: FloatArray  #: (m,) their y
    bearing: FloatArray  #: (m,) their bearings
    obs: IntArray  #: (m,) their observation indices
    ones: FloatArray  #: (m,) weights of 1 for the geometry helpers
    stamp: IntArray  #: (N,) == the hypothesis number where a landmark is on the path


class _Near(NamedTuple):
    """The landmarks a hypothesis can see (gathered once per hypothesis)."""

    q: IntArray
    x: FloatArray
    y: FloatArray


class _Walk(NamedTuple):
    """The verification's depth-first state, one row per level (the rest's bearings)."""

    pose: FloatArray  #: (m + 1, 4) x, y, theta and trace of the covariance on entering
    cov: FloatArray  #: (m + 1, 6) covariance (upper triangle) on entering
    n: IntArray  #: (m + 1,) pairs on entering
    wild: IntArray  #: (m + 1,) wildcards on entering
    chosen: IntArray  #: (m + 1,) landmark chosen at the level (-1: none)
    next: IntArray  #: (m + 1,) next option at the level
    n_cand: IntArray  #: (m + 1,) landmarks inside the level's gate
    ahead: IntArray  #: (m + 1,) wildcards reserved for the bearings from the level on
    cand_lm: IntArray  #: (m, W) the level's gated landmarks, best first
    cand_innov: FloatArray  #: (m, W) their innovations (predicted - measured)
    cand_gx: FloatArray  #: (m, W) their bearing gradients in x
    cand_gy: FloatArray  #: (m, W) ... and in y
    cand_var: FloatArray  #: (m, W) their innovation variances
    cand_score: FloatArray  #: (m, W) normalised squared innovations
    pick: IntArray  #: (2, W) scratch of the first bound


class _Out(NamedTuple):
    """The bounded buffer of complete paths."""

    assign: IntArray  #: (capacity, m) landmark per observation, -1 unmatched
    pose: FloatArray  #: (capacity, 3)
    missed: IntArray  #: (capacity,)
    key: FloatArray  #: (capacity,) cost (lower is better)
    bar: FloatArray  #: (1,) worst cost a path may have to enter


class _Derived(NamedTuple):
    """Per-search constants derived from the gate."""

    cb: FloatArray  #: (m,) cosines of the bearings
    sb: FloatArray  #: (m,) sines
    sig2: float  #: bearing variance (threshold / 3 squared without sigma)
    use_sigma: bool
    bound_k: float  #: the gate of the first bound, in units of the variance
    margin: float  #: angular margin of "plainly visible"


@_jit
def _anchor_pairs(
    nb: Neighbours, i: int, d2max: float, rot: complex, q: IntArray, t: FloatArray
) -> int:
    """The neighbours of anchor ``i`` within sqrt(d2max) of it, to ``q``, with their
    coordinates, ``a`` and ``b`` (eqs. 1-2, real and imaginary parts) and the entries of P and
    P b (eq. 3) for the rotation ``rot`` in the columns of ``t`` (11, >= n: one row per
    quantity, so that :func:`_triple_poses` reads each contiguously); returns how many."""
    n = 0
    lix, liy = nb.xy[i, 0], nb.xy[i, 1]
    for qq in range(nb.lo[i], nb.hi[i]):
        j = nb.idx[qq]
        if j == i:
            continue
        qx, qy = nb.nb_xy[qq, 0], nb.nb_xy[qq, 1]
        ex, ey = qx - lix, qy - liy
        if ex * ex + ey * ey > d2max:
            continue
        a, b, p00, p01, p11, pb0, pb1 = pair_terms(ex, ey, rot)
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


@_jit
def _gather(nb: Neighbours, i: int, px: float, py: float, near2: float, near: _Near) -> int:
    """Copy the neighbours of anchor ``i`` within sqrt(near2) of (px, py), and the anchor
    itself, to ``near``; return how many. Branch-free: every candidate is written, and the
    count advances past the near ones."""
    nn = 0
    for qq in range(nb.lo[i], nb.hi[i]):
        qx, qy = nb.nb_xy[qq, 0], nb.nb_xy[qq, 1]
        near.q[nn], near.x[nn], near.y[nn] = nb.idx[qq], qx, qy
        ex, ey = qx - px, qy - py
        nn += ex * ex + ey * ey <= near2
    near.q[nn], near.x[nn], near.y[nn] = i, nb.xy[i, 0], nb.xy[i, 1]
    return nn + 1


@_jit
def _compact(out: _Out) -> int:
    """Make room in a full output buffer, in place: repeats of one interpretation (reached
    from several seeds) keep only their best row, then at most the better half of the rest
    stays (lowest key first, stable). When rows had to go, ``out.bar[0]`` becomes the worst
    key kept. Returns the rows kept."""
    out_a, out_key = out.assign, out.key
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
        out.bar[0] = out_key[order[keep - 1]]
    order = order[:keep]
    out_a[:keep] = out_a[order].copy()
    out.pose[:keep] = out.pose[order].copy()
    out.missed[:keep] = out.missed[order].copy()
    out_key[:keep] = out_key[order].copy()
    return keep


@_jit
def _can_reach(
    rest: IntArray,
    nr: int,
    need: int,
    d: _Derived,
    px: float,
    py: float,
    ct: float,
    st: float,
    near: _Near,
    nn: int,
    own: tuple[int, int, int],
    cov: tuple[float, float, float, float, float, float],
    k_pre: float,
    work: FloatArray,
) -> bool:
    """Whether at least ``need`` of the bearings ``rest[:nr]`` each have some near landmark
    (other than the hypothesis's ``own`` three) inside a gate of ``k_pre`` at the hypothesis's
    pose (px, py, heading with cosine ``ct`` and sine ``st``) and covariance ``cov`` (upper
    triangle): a necessary condition for :func:`_verify` to find a complete path, tested first
    because it is cheap (no arctangent; the inner loop has no branch, and the bearings stop as
    soon as too many have missed).

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
        dx, dy = near.x[t] - px, near.y[t] - py
        rr = dx * dx + dy * dy
        # (g^T Cov g) r^2 with g = [dy / r^2, -dx / r^2, -1], as in pred_var.
        vr = (dy * dy * c00 + dx * dx * c11 - 2.0 * dx * dy * c01) / rr
        vr += 2.0 * (dx * c12 - dy * c02) + c22 * rr
        tx[t], ty[t] = dx, dy
        # |r sin(innovation)|^2 <= k_pre v r^2 (sin x <= x); never for the hypothesis's own
        # landmarks (compared by index: cheaper than a lookup in a map-sized array).
        q = near.q[t]
        mine = (q == own[0]) | (q == own[1]) | (q == own[2])
        tg[t] = -1.0 if mine else k_pre * (max(vr, 0.0) + d.sig2 * rr)
    allow = nr - need
    missed = 0
    for r in range(nr):
        o = rest[r]
        ux = ct * d.cb[o] - st * d.sb[o]  # the bearing's direction in the world
        uy = st * d.cb[o] + ct * d.sb[o]
        hit = False
        for t in range(nn):
            cr = ux * ty[t] - uy * tx[t]
            hit |= (cr * cr <= tg[t]) & (ux * tx[t] + uy * ty[t] > 0)
        work[3, r] = not hit
        missed += not hit
        if missed > allow:
            return False
    return True


@_jit
def _triple_poses(
    j: int,
    jr: FloatArray,
    lix: float,
    liy: float,
    kq: IntArray,
    kt: FloatArray,
    nk: int,
    d_bc: float,
    gate: Gate,
    vis: Visibility,
    hk: IntArray,
    hx: FloatArray,
    hy: FloatArray,
    hd: FloatArray,
    status: IntArray,
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
    k0, k1, k2, k3, k4, k5 = kt[0], kt[1], kt[2], kt[3], kt[4], kt[5]
    k6, k7, k8, k9, k10 = kt[6], kt[7], kt[8], kt[9], kt[10]
    for kk in range(nk):
        lkx, lky = k0[kk], k1[kk]
        ex, ey = lkx - ljx, lky - ljy
        other = kq[kk] != j
        paired = other & (ex * ex + ey * ey <= d_bc)
        s00, s01, s11 = p00 + k6[kk], p01 + k7[kk], p11 + k8[kk]
        # Eq. 4 then eq. 5; the heading (eq. 6) waits until the hypothesis passes.
        fx, fy, det, f2, px, py = position_from_sums(
            s00, s01, s11, pb0 + k9[kk], pb1 + k10[kk], lix, liy
        )
        exists = (
            pose_exists(det, s00, s01, s11, f2, gate.singular_rtol, gate.eps_f2)
            & (ratio_from_parts(a1r, a1i, b1r, b1i, fx, fy) > 0)
            & (ratio_from_parts(k2[kk], k3[kk], k4[kk], k5[kk], fx, fy) > 0)
        )
        # The pose must see its three landmarks within the range limits.
        ex, ey = lix - px, liy - py
        d2a = ex * ex + ey * ey
        ex, ey = ljx - px, ljy - py
        d2b = ex * ex + ey * ey
        ex, ey = lkx - px, lky - py
        d2c = ex * ex + ey * ey
        seen = (max(d2a, d2b, d2c) <= vis.rmax2) & (min(d2a, d2b, d2c) >= vis.rmin2)
        status[kk] = other + paired + (paired & exists) + (paired & exists & seen)
        hx[kk], hy[kk], hd[kk] = px, py, d2a
    # The hypotheses, in order (a separate pass, so that the one above vectorises).
    n = 0
    for kk in range(nk):
        hk[n] = kk
        n += status[kk] == 4
    return n


@_jit
def _tally(status: IntArray, lo: int, hi: int) -> tuple[int, int, int]:
    """The counters of the third-landmark candidates ``lo:hi`` by their ``status`` (see
    :func:`_triple_poses`): (out of range or beyond the pair limit, no pose, solved)."""
    vis = existence = solved = 0
    for kk in range(lo, hi):
        st_k = status[kk]
        vis += (st_k == 1) | (st_k == 3)
        existence += st_k == 2
        solved += st_k >= 2
    return vis, existence, solved


class _Seen(NamedTuple):
    """The complete paths refined so far, by their assignment's two 64-bit hashes (open
    addressing; a row of zeros is empty): the same interpretation reached again from another
    seed is not refined again."""

    keys: NDArray[np.uint64]  #: (S, 2), S a power of two
    used: IntArray  #: (1,) rows in use


#: Rows of the first table of refined paths, and the most it grows to (16 MiB).
SEEN_ROWS = 1 << 10
SEEN_MAX_ROWS = 1 << 20


@_jit
def _mix(z: np.uint64) -> np.uint64:
    """SplitMix64's finaliser: a 64-bit value spread over all 64 bits."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@_jit
def _first_visit(seen: _Seen, path: _Path, n: int) -> bool:
    """Whether the path's set of pairs (observation, landmark) was not refined before, and
    note it (while the table is at most half full). Two independent sums of mixed pairs,
    so the order in which the pairs were matched does not matter."""
    h1 = np.uint64(0)
    h2 = np.uint64(0)
    for q in range(n):
        k = np.uint64(path.obs[q]) * np.uint64(0x100000000) + np.uint64(path.lm[q])
        h1 = h1 + _mix(k)
        h2 = h2 + _mix(k ^ np.uint64(0x5851F42D4C957F2D))
    if h1 == np.uint64(0):
        h1 = np.uint64(1)
    keys = seen.keys
    mask = np.uint64(keys.shape[0] - 1)
    at = h1 & mask
    while keys[at, 0] != np.uint64(0):
        if keys[at, 0] == h1 and keys[at, 1] == h2:
            return False
        at = (at + np.uint64(1)) & mask
    if 2 * seen.used[0] < keys.shape[0]:
        keys[at, 0] = h1
        keys[at, 1] = h2
        seen.used[0] += 1
    return True


@_jit
def _grown(seen: _Seen) -> _Seen:
    """The table four times larger (at most SEEN_MAX_ROWS) once a quarter full."""
    rows = seen.keys.shape[0]
    if 4 * seen.used[0] < rows or rows >= SEEN_MAX_ROWS:
        return seen
    new = np.zeros((min(4 * rows, SEEN_MAX_ROWS), 2), dtype=np.uint64)
    mask = np.uint64(new.shape[0] - 1)
    for r in range(rows):
        h1 = seen.keys[r, 0]
        if h1 != np.uint64(0):
            at = h1 & mask
            while new[at, 0] != np.uint64(0):
                at = (at + np.uint64(1)) & mask
            new[at, 0] = h1
            new[at, 1] = seen.keys[r, 1]
    return _Seen(new, seen.used)


@_jit
def _walk_work(nodes: int, leaves: int, nn: int, counts_missed: bool) -> int:
    """The work of a verification that visited ``nodes`` nodes and reached ``leaves``
    complete paths among ``nn`` near landmarks: each node scans them (plus NODE_WORK), each
    complete path is refined (LEAF_WORK) and, with negative evidence, scans them again."""
    return nodes * (nn + NODE_WORK) + leaves * (LEAF_WORK + (nn if counts_missed else 0))


@_jit
def _missed_count(
    near: _Near,
    nn: int,
    path: _Path,
    hyp: int,
    px: float,
    py: float,
    pt: float,
    beta: FloatArray,
    vis: Visibility,
    margin: float,
) -> int:
    """Near landmarks plainly visible from (px, py, pt) -- inside the plain range limits,
    inside the field of view by ``margin``, more than twice that from every measured
    bearing -- that the path did not match (negative evidence; as
    :meth:`omniloc.sensor.SensorModel.plainly_visible`)."""
    missed = 0
    for t in range(nn):
        if path.stamp[near.q[t]] == hyp:
            continue
        dx, dy = near.x[t] - px, near.y[t] - py
        rr = dx * dx + dy * dy
        if rr > vis.plain_hi or rr < vis.plain_lo:
            continue
        pred = np.arctan2(dy, dx) - pt
        if abs(wrap_float(pred)) > vis.half_fov - margin:
            continue
        alone = True
        for o in range(beta.shape[0]):
            if abs(wrap_float(pred - beta[o])) <= 2.0 * margin:
                alone = False
                break
        if alone:
            missed += 1
    return missed


@_jit
def _counts_missed(scoring: Scoring) -> bool:
    """Whether complete paths count the plainly visible landmarks they leave unseen."""
    return scoring.miss_w > 0.0 or scoring.unknown_rate


@_jit
def _occam(path: _Path, n: int, x: float, y: float, sig2: float, scoring: Scoring) -> float:
    """The pose-volume term of the log evidence (as omniloc.search.scoring.log_evidence): ln
    sqrt(det(2 pi Cov)) of the pose at (x, y) from the path's n pairs, plus the prior's log
    density there, at most 0."""
    h00, h01, h02, h11, h12, h22 = information(path.lx, path.ly, path.ones, n, x, y)
    det_h = det3(h00, h01, h02, h11, h12, h22)
    if not det_h > 0:
        return 0.0
    vol = 0.5 * (3.0 * np.log(2.0 * np.pi * sig2) - np.log(det_h))
    prior = prior_log_density(x, y, scoring.region, scoring.edge, scoring.log_volume)
    return min(vol + prior, 0.0)


@_jit
def _keep(
    out: _Out,
    n_out: int,
    path: _Path,
    n: int,
    m: int,
    pose: tuple[float, float, float],
    missed: int,
    key: float,
    force: bool,
) -> int:
    """Write a complete path to the buffer if its cost passes the bar (or ``force``),
    compacting a full buffer first; returns the new row count."""
    if n_out == out.assign.shape[0]:
        n_out = _compact(out)
    if key <= out.bar[0] or force:
        for o in range(m):
            out.assign[n_out, o] = -1
        for q in range(n):
            out.assign[n_out, path.obs[q]] = path.lm[q]
        out.pose[n_out, 0], out.pose[n_out, 1], out.pose[n_out, 2] = pose
        out.missed[n_out] = missed
        out.key[n_out] = key
        n_out += 1
    return n_out


@_jit
def _gate_level(
    level: int,
    o: int,
    near: _Near,
    nn: int,
    path: _Path,
    hyp: int,
    walk: _Walk,
    d: _Derived,
    gate: Gate,
    vis: Visibility,
    pose: tuple[float, float, float, float],
    cov: tuple[float, float, float, float, float, float],
) -> int:
    """The near landmarks inside bearing ``o``'s gate at the path's pose and covariance,
    best (smallest normalised innovation) first, into ``walk.cand_*[level]``; returns how
    many.

    One bound first, for every near landmark in a pass that vectorises: |sin(innov)| <=
    |innov| and g^T Cov g <= trace(Cov) |g|^2 with |g|^2 = 1 / r^2 + 1, so most candidates
    fail it, and it needs no division or arctangent. The few that pass are listed, then gated
    exactly (chi-square with sigma, else the fixed threshold).
    """
    px, py, pt, tr = pose
    c00, c01, c02, c11, c12, c22 = cov
    ct, st = np.cos(pt), np.sin(pt)
    ux = ct * d.cb[o] - st * d.sb[o]  # measured direction in the world
    uy = st * d.cb[o] + ct * d.sb[o]
    okf, sel = walk.pick[0], walk.pick[1]
    for t in range(nn):
        dx, dy = near.x[t] - px, near.y[t] - py
        rr = dx * dx + dy * dy
        dot = dx * ux + dy * uy
        cr = ux * dy - uy * dx  # r sin(innovation)
        okf[t] = (
            (cr * cr <= d.bound_k * (tr * (1.0 + rr) + d.sig2 * rr))
            & (dot > 0)
            & (rr <= vis.rmax2)
            & (rr >= vis.rmin2)
        )
    nsel = 0
    for t in range(nn):
        sel[nsel] = t
        nsel += okf[t]
    cq, cin, cgx = walk.cand_lm[level], walk.cand_innov[level], walk.cand_gx[level]
    cgy, cv, cs = walk.cand_gy[level], walk.cand_var[level], walk.cand_score[level]
    nc = 0
    for u in range(nsel):
        t = sel[u]
        dx, dy = near.x[t] - px, near.y[t] - py
        rr = dx * dx + dy * dy
        dot = dx * ux + dy * uy
        cr = ux * dy - uy * dx
        q = near.q[t]
        if path.stamp[q] == hyp:
            continue
        gx, gy = dy / rr, -dx / rr
        v = pred_var(gx, gy, c00, c01, c02, c11, c12, c22, d.sig2)
        if d.use_sigma:
            if cr * cr > gate.gate_chi2 * v * rr:
                continue
            innov = np.arctan2(cr, dot)
            score = innov * innov / v
            if score > gate.gate_chi2:
                continue
        else:
            if cr * cr > gate.threshold * gate.threshold * rr:
                continue
            innov = np.arctan2(cr, dot)
            score = innov * innov / v
            if abs(innov) > gate.threshold:
                continue
        # Insertion by score (the gated few).
        at = nc
        while at > 0 and cs[at - 1] > score:
            cq[at], cin[at], cgx[at] = cq[at - 1], cin[at - 1], cgx[at - 1]
            cgy[at], cv[at], cs[at] = cgy[at - 1], cv[at - 1], cs[at - 1]
            at -= 1
        cq[at], cin[at], cgx[at] = q, innov, gx
        cgy[at], cv[at], cs[at] = gy, v, score
        nc += 1
    return nc


@_jit
def _verify(
    bearings: Bearings,
    rest: IntArray,
    nr: int,
    path: _Path,
    hyp: int,
    near: _Near,
    nn: int,
    walk: _Walk,
    d: _Derived,
    gate: Gate,
    vis: Visibility,
    scoring: Scoring,
    budget: Budget,
    out: _Out,
    n_out: int,
    node_budget: int,
    work_budget: int,
    relin: int,
    look: float,
    cnt: IntArray,
    seen: _Seen,
) -> tuple[int, int]:
    """Verify one hypothesis: a depth-first walk over the other bearings (``rest``), each
    matched in turn to every landmark inside its gate, best first, then left unmatched (a
    wildcard) while at most ``max_wild`` are, as in the tree. The state of a path (pose,
    covariance, matches) takes each match in with one Kalman update (relinearised by two
    Gauss-Newton steps and a fresh covariance while it has at most ``relin`` pairs) and is
    restored on the way back. Complete paths with at least ``min_match`` matches are refined,
    tested for joint compatibility (with sigma) and kept with their count of missed
    landmarks.

    ``walk.ahead[level]`` wildcards are reserved for the bearings from ``level`` on that
    failed the cheap test (:func:`_can_reach`): a wildcard is taken only while the path's
    wildcards and those still fit within ``max_wild``, so a first fit drops a hypothesis at
    its first unexplained bearing once the cheap test's misses use up the allowance (all
    zero: the tree's rule).

    The hypothesis's three seed pairs are ``path.*[:3]``, its pose and covariance
    ``walk.pose[0]`` / ``walk.cov[0]``. Adds [nodes, examined, gate, bound, complete paths]
    to ``cnt``; returns the new output count and 2 when ``stop_first`` found its fit (1 when
    ``node_budget`` nodes or ``work_budget`` work ran out; 0 for no limit). A fit stops a
    first fit only when it is decisive against the null interpretation even after the
    look-elsewhere allowance ``look`` (ln of the hypotheses the whole search would try: among
    that many, chance alone makes some fits).
    """
    beta, contested = bearings.beta, bearings.contested
    m = beta.shape[0]
    max_wild = m - gate.min_match
    n = 3
    wild = 0
    px, py, pt, tr = walk.pose[0, 0], walk.pose[0, 1], walk.pose[0, 2], walk.pose[0, 3]
    c00, c01, c02 = walk.cov[0, 0], walk.cov[0, 1], walk.cov[0, 2]
    c11, c12, c22 = walk.cov[0, 3], walk.cov[0, 4], walk.cov[0, 5]
    level = 0
    enter = True
    while level >= 0:
        if enter:
            enter = False
            walk.pose[level, 0], walk.pose[level, 1] = px, py
            walk.pose[level, 2], walk.pose[level, 3] = pt, tr
            walk.cov[level, 0], walk.cov[level, 1], walk.cov[level, 2] = c00, c01, c02
            walk.cov[level, 3], walk.cov[level, 4], walk.cov[level, 5] = c11, c12, c22
            walk.n[level], walk.wild[level] = n, wild
            walk.chosen[level], walk.next[level] = -1, 0
            if level == nr:
                # The same interpretation reached again from another seed is not refined
                # again (its first visit was; the buffer kept it or it was no better than
                # the bar). A first fit refines every one: its stop test moves as it goes.
                if n >= gate.min_match and (budget.stop_first or _first_visit(seen, path, n)):
                    qx, qy, qt, sse = gn_refine(
                        path.lx, path.ly, path.bearing, path.ones, n, px, py, pt, 10
                    )
                    if not d.use_sigma or sse / d.sig2 <= gate.joint_chi2[n]:
                        # Negative evidence only where it is asked for (miss_w > 0, or an
                        # unknown rate with a range); without a range it would look at the
                        # whole map for every path.
                        missed = 0
                        if _counts_missed(scoring):
                            missed = _missed_count(
                                near, nn, path, hyp, qx, qy, qt, beta, vis, d.margin
                            )
                        # Keep the best ``capacity`` by the ranking's cost: when full, the
                        # worse half goes and the bar for entry rises.
                        key = (m - n) * scoring.spur_w + 0.5 * sse / d.sig2
                        key -= detection_term(n, missed, -scoring.miss_w, scoring.unknown_rate)
                        cnt[4] += 1
                        fits = budget.stop_first and missed <= budget.miss_allow
                        if fits:
                            # A fit worth stopping for is decisive against the null: every
                            # bearing clutter (a chance fit on a large map is not).
                            ln_e = m * scoring.spur_w - key
                            ln_e += _occam(path, n, qx, qy, d.sig2, scoring)
                            fits = ln_e - scoring.log_null >= scoring.stop_margin + look
                        n_out = _keep(out, n_out, path, n, m, (qx, qy, qt), missed, key, fits)
                        if fits:
                            return n_out, 2
                        # The budget is checked per complete path too, not only per node: with
                        # a range that takes in a whole map, one node's gate held ~900 paths,
                        # each refined and scanned against every landmark (200,000 landmarks:
                        # 1.9e8 units on a 1.2e7 budget, 25 s for 2 s).
                        work_now = _walk_work(cnt[0], cnt[4], nn, _counts_missed(scoring))
                        if work_budget > 0 and work_now >= work_budget:
                            return n_out, 1
                level -= 1
                continue
            o = rest[level]
            cnt[0] += 1
            cnt[1] += 1
            if node_budget > 0 and cnt[0] >= node_budget:
                return n_out, 1
            work_now = _walk_work(cnt[0], cnt[4], nn, _counts_missed(scoring))
            if work_budget > 0 and work_now >= work_budget:
                return n_out, 1
            walk.n_cand[level] = _gate_level(
                level, o, near, nn, path, hyp, walk, d, gate, vis,
                (px, py, pt, tr), (c00, c01, c02, c11, c12, c22),
            )  # fmt: skip
            if walk.n_cand[level] == 0:
                cnt[2] += 1
        # Next option at this level, from the state on entering it.
        px, py, pt, tr = (
            walk.pose[level, 0],
            walk.pose[level, 1],
            walk.pose[level, 2],
            walk.pose[level, 3],
        )
        c00, c01, c02 = walk.cov[level, 0], walk.cov[level, 1], walk.cov[level, 2]
        c11, c12, c22 = walk.cov[level, 3], walk.cov[level, 4], walk.cov[level, 5]
        n, wild = walk.n[level], walk.wild[level]
        if walk.chosen[level] >= 0:
            path.stamp[walk.chosen[level]] = 0
            walk.chosen[level] = -1
        p = walk.next[level]
        walk.next[level] = p + 1
        o = rest[level]
        if p < walk.n_cand[level]:
            q = walk.cand_lm[level, p]
            path.lm[n], path.bearing[n], path.obs[n] = q, beta[o], o
            path.lx[n], path.ly[n] = path.map_xy[q, 0], path.map_xy[q, 1]
            path.stamp[q] = hyp
            walk.chosen[level] = q
            n += 1
            # Kalman update with the matched bearing: h = g^T, innovation (predicted -
            # measured) b_in, its variance b_v.
            b_in, b_gx = walk.cand_innov[level, p], walk.cand_gx[level, p]
            b_gy, b_v = walk.cand_gy[level, p], walk.cand_var[level, p]
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
                px, py, pt, _ = gn_refine(
                    path.lx, path.ly, path.bearing, path.ones, n, px, py, pt, 2
                )
                h00, h01, h02, h11, h12, h22 = information(path.lx, path.ly, path.ones, n, px, py)
                c00, c01, c02, c11, c12, c22, tr = inv3(
                    h00, h01, h02, h11, h12, h22, d.sig2, GATE_FLOOR
                )
            level += 1
            enter = True
        elif p == walk.n_cand[level] and (p == 0 or (contested[o] and not budget.stop_first)):
            # After every landmark that fits, the wildcard ("not on the map": a spurious bearing
            # may fall on a landmark's ray and take it from the true one), while the path can
            # still reach min_match. Where a landmark fits, only for the bearings marked
            # ``contested`` (by default all of them: a spurious bearing inside a landmark's
            # gate pulls the pose, and the interpretation that calls it clutter can be
            # another answer, metres away; the tracker's searches mark only the bearings
            # with another one close by). A first fit, which gives up completeness anyway,
            # takes it only where nothing fits.
            if wild + 1 + walk.ahead[level + 1] <= max_wild:
                wild += 1
                level += 1
                enter = True
            else:
                cnt[3] += 1
                level -= 1
        else:
            level -= 1
    return n_out, 0


@_jit
def hypotheses(
    nb: Neighbours,
    i0: int,
    i1: int,
    bearings: Bearings,
    seeds: Seeds,
    gate: Gate,
    vis: Visibility,
    scoring: Scoring,
    budget: Budget,
) -> tuple[IntArray, FloatArray, IntArray, HypothesisCounts]:
    """Every interpretation that a seed triple of bearings starts, verified bearing by bearing
    (see the module's documentation for the order of the work).

    The first landmark of a triple is ``i`` in ``[i0, i1)``, the others among its neighbours
    (``nb``: without a range, every other landmark), their distances within the seed's pair
    limits. A hypothesis whose three landmarks are not all in range of its pose is not one.

    Returns assignments (K, m) in observation order (-1 unmatched), poses (K, 3) and the
    counts of plainly visible landmarks missed (K,) of at most ``budget.capacity`` complete
    paths, best first by the cost of :class:`Scoring` (when more are found, repeats of an
    interpretation from other seeds and then the worse ones are dropped as they come), and
    the counters. ``budget.max_work`` counts every candidate landmark looked at, and each
    verification node and complete path by :func:`_walk_work`; it is checked after every
    hypothesis and inside the verification, so a search of a large map without a range still
    stops when told to.
    """
    L = nb.xy
    beta = bearings.beta
    N = L.shape[0]
    m = beta.shape[0]
    capacity = budget.capacity
    use_sigma = gate.sigma > 0
    # The Kalman updates need a bearing variance in threshold mode too.
    sig_eff = gate.sigma if use_sigma else gate.threshold / 3.0
    sig2 = sig_eff * sig_eff
    cb = np.cos(beta)
    sb = np.sin(beta)
    # The gate in the first bound: chi-square with sigma, else threshold^2 against
    # sigma_eff^2 (whatever the variance, |innovation| <= threshold rejects no more).
    bound_k = gate.gate_chi2 if use_sigma else gate.threshold * gate.threshold / sig2
    d = _Derived(cb, sb, sig2, use_sigma, bound_k, 3.0 * sig_eff)
    out = _Out(
        np.empty((capacity, m), dtype=np.int64),
        np.empty((capacity, 3)),
        np.empty(capacity, dtype=np.int64),
        np.empty(capacity),
        np.full(1, np.inf),
    )
    path = _Path(
        L,
        np.empty(m, dtype=np.int64),
        np.empty(m),
        np.empty(m),
        np.empty(m),
        np.empty(m, dtype=np.int64),
        np.ones(m),
        np.zeros(N, dtype=np.int64),
    )
    rest = np.empty(m, dtype=np.int64)
    # The landmarks a hypothesis can see (within max_range, with a margin for the updates
    # of its pose), gathered once per hypothesis.
    width = 1
    for i in range(i0, i1):
        width = max(width, nb.hi[i] - nb.lo[i])
    near = _Near(np.empty(width + 1, dtype=np.int64), np.empty(width + 1), np.empty(width + 1))
    near2 = vis.rmax2 * 1.05**2
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
    walk = _Walk(
        np.empty((m + 1, 4)),
        np.empty((m + 1, 6)),
        np.empty(m + 1, dtype=np.int64),
        np.empty(m + 1, dtype=np.int64),
        np.empty(m + 1, dtype=np.int64),
        np.empty(m + 1, dtype=np.int64),
        np.empty(m + 1, dtype=np.int64),
        # Wildcards reserved per level of a first fit (zero in an exhaustive search).
        np.zeros(m + 1, dtype=np.int64),
        np.empty((m, width + 1), dtype=np.int64),
        np.empty((m, width + 1)),
        np.empty((m, width + 1)),
        np.empty((m, width + 1)),
        np.empty((m, width + 1)),
        np.empty((m, width + 1)),
        np.empty((2, width + 1), dtype=np.int64),
    )
    cnt = np.zeros(5, dtype=np.int64)
    seen = _Seen(np.zeros((SEEN_ROWS, 2), dtype=np.uint64), np.zeros(1, dtype=np.int64))
    pre_work = np.empty((4, max(width + 1, m)))
    found = 0
    nodes = examined = triples = existence = n_gate = n_out = stopped = n_vis = bound = 0
    hyp = 0
    work = 0
    max_nodes, max_work = budget.max_nodes, budget.max_work
    upfront = max_nodes == 0 and max_work == 0
    for s in range(seeds.triples.shape[0]):
        if stopped:
            break
        oa, ob, oc = seeds.triples[s, 0], seeds.triples[s, 1], seeds.triples[s, 2]
        nr = 0
        for o in range(m):
            if o != oa and o != ob and o != oc:
                rest[nr] = o
                nr += 1
        rot_b = np.exp(1j * (beta[ob] - beta[oa]))
        rot_c = np.exp(1j * (beta[oc] - beta[oa]))
        pd2 = bearings.pair_d2
        d_ab, d_ac, d_bc = pd2[oa, ob], pd2[oa, oc], pd2[ob, oc]
        # The cheap test of _can_reach (with sigma; 0 turns it off).
        k_pre = seeds.pretest[s] * gate.joint_chi2[m] if use_sigma else 0.0
        for i in range(i0, i1):
            if stopped:
                break
            lo, hi = nb.lo[i], nb.hi[i]
            lix, liy = L[i, 0], L[i, 1]
            # Each neighbour's terms of eqs. 1-3 as the second landmark (bearing ob) and as
            # the third (oc), once per anchor, for those within the pair limits.
            nj = _anchor_pairs(nb, i, d_ab, rot_b, jq, jt)
            nk = _anchor_pairs(nb, i, d_ac, rot_c, kq, kt)
            n_vis += 2 * (hi - lo) - nj - nk
            work += 2 * (hi - lo)
            for jj in range(nj):
                if stopped:
                    break
                j = jq[jj]
                ljx, ljy = jt[0, jj], jt[1, jj]
                nh = _triple_poses(
                    j, jt[:, jj], lix, liy, kq, kt, nk, d_bc, gate, vis, hk, hx, hy, hd, status
                )
                work += nk
                # The counters advance over the candidates in order, as if each were taken in
                # turn, so that they (and the node budget) read the same wherever it stops.
                # Without a budget they are added for all at once, in a pass that vectorises,
                # and those of the candidates after a stop are taken back.
                if upfront:
                    t_vis, t_ex, t_sol = _tally(status, 0, nk)
                    n_vis += t_vis
                    existence += t_ex
                    triples += t_sol
                    nodes += t_sol
                done = 0
                for h in range(nh + 1):
                    upto = hk[h] if h < nh else nk
                    if not upfront:
                        t_vis, t_ex, t_sol = _tally(status, done, upto)
                        n_vis += t_vis
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
                    nn = _gather(nb, i, px, py, near2, near)
                    work += (hi - lo) + nr * nn
                    if (max_work > 0 and work >= max_work) or (
                        max_nodes > 0 and nodes >= max_nodes
                    ):
                        stopped = 1
                        break
                    hyp += 1
                    path.lm[0], path.lm[1], path.lm[2] = i, j, k
                    path.lx[0], path.lx[1], path.lx[2] = lix, ljx, lkx
                    path.ly[0], path.ly[1], path.ly[2] = liy, ljy, lky
                    path.bearing[0], path.bearing[1], path.bearing[2] = beta[oa], beta[ob], beta[oc]
                    path.obs[0], path.obs[1], path.obs[2] = oa, ob, oc
                    path.stamp[i] = path.stamp[j] = path.stamp[k] = hyp
                    h00, h01, h02, h11, h12, h22 = information(
                        path.lx, path.ly, path.ones, 3, px, py
                    )
                    c00, c01, c02, c11, c12, c22, tr = inv3(
                        h00, h01, h02, h11, h12, h22, sig2, GATE_FLOOR
                    )
                    if k_pre > 0 and not _can_reach(
                        rest, nr, gate.min_match - 3, d, px, py, ct, st, near, nn, (i, j, k),
                        (c00, c01, c02, c11, c12, c22), k_pre, pre_work,
                    ):  # fmt: skip
                        bound += 1
                        continue
                    if k_pre > 0 and budget.stop_first:
                        for r in range(nr - 1, -1, -1):
                            walk.ahead[r] = walk.ahead[r + 1] + int(pre_work[3, r])
                    pt = wrap_float(np.arctan2(liy - py, lix - px) - beta[oa])
                    walk.pose[0, 0], walk.pose[0, 1], walk.pose[0, 2], walk.pose[0, 3] = (
                        px,
                        py,
                        pt,
                        tr,
                    )
                    walk.cov[0, 0], walk.cov[0, 1], walk.cov[0, 2] = c00, c01, c02
                    walk.cov[0, 3], walk.cov[0, 4], walk.cov[0, 5] = c11, c12, c22
                    cnt[:] = 0
                    # Budgets left to the verification (0: no limit; at least 1 when limited).
                    left = max(1, max_nodes - nodes) if max_nodes > 0 else 0
                    left_work = max(1, max_work - work) if max_work > 0 else 0
                    units = s * (i1 - i0) + (i - i0 + 1)
                    look = np.log(hyp * scoring.total_units / units)
                    n_out, stop = _verify(
                        bearings, rest, nr, path, hyp, near, nn, walk, d, gate, vis, scoring,
                        budget, out, n_out, left, left_work, seeds.relin[s], look, cnt, seen,
                    )  # fmt: skip
                    seen = _grown(seen)
                    nodes += cnt[0]
                    work += _walk_work(cnt[0], cnt[4], nn, _counts_missed(scoring))
                    examined += cnt[1]
                    n_gate += cnt[2]
                    bound += cnt[3]
                    found += cnt[4]
                    if stop:
                        stopped = stop
                        if upfront:
                            t_vis, t_ex, t_sol = _tally(status, kk + 1, nk)
                            n_vis -= t_vis
                            existence -= t_ex
                            triples -= t_sol
                            nodes -= t_sol
                        break
                if (max_nodes > 0 and nodes >= max_nodes) or (max_work > 0 and work >= max_work):
                    stopped = 1
    counts = HypothesisCounts(
        nodes, examined, triples, existence, n_gate, found, stopped, n_vis, bound, work
    )
    order = np.argsort(out.key[:n_out], kind="mergesort")
    return out.assign[order], out.pose[order], out.missed[order], counts
