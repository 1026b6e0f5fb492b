"""The interpretation tree (the seed paper's section 3), readable, and its compiled walk.

Level ``k`` of the tree assigns bearing ``k`` to a landmark not yet on the path (or, with
wildcards, to "not on the map"). A path is pruned by the paper's two rules:

rule (i)
    when its third landmark is assigned, a pose must exist -- eqs. 1-6 with positive distance
    ratios (:meth:`TreeSearch._add_third`);
rule (ii)
    below that, the bearing predicted from the path's pose must match the measured one:
    ``|wrap(predicted - measured)| <= threshold``, or with ``sigma`` a chi-square gate on the
    innovation whose variance includes the pose's uncertainty (:meth:`TreeSearch._add_checked`,
    :meth:`TreeSearch._sigma_gate`).

Every validated node re-estimates the pose from all its pairs (eq. 4 over the path's pairs,
its sums kept incrementally). Beyond the paper: the wildcard branch with a bound on the
number of matches (:meth:`TreeSearch._expand`), the ordering constraint, range limits and a
node/time budget.

:class:`TreeSearch` walks the tree depth first, expanding a whole batch of sibling paths at
once with numpy; without a budget it visits exactly the nodes of the plain depth-first
reading, so it is both the readable statement of the search and the test oracle of the
compiled walk (:func:`run_paper_kernel`, :func:`omniloc._kernels.tree.paper_tree`), which
must visit the same nodes and find the same paths. The section-2 formulas are the shared
building blocks of :mod:`omniloc._kernels.geometry`, applied element-wise.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._kernels import geometry as geo
from .._kernels.tree import TreeLimits, paper_tree, widest_triple
from ..angles import TWO_PI
from ..maps import LandmarkMap
from ..pose import SINGULAR_RTOL
from .options import Leaves, SearchOptions
from .seeds import gaps

__all__ = ["TreeSearch", "robust_order", "run_paper_kernel"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

log = logging.getLogger("omniloc.search")

#: Upper bound on candidate (path, landmark) pairs evaluated in one numpy batch.
BATCH_PAIRS = 1 << 16

#: The compiled walk enforces ``timeout_s`` as a budget of this many nodes per second.
COMPILED_NODES_PER_SECOND = 2_000_000

#: The compiled walk keeps at most this many complete paths (the first ones found); more mark
#: the result incomplete. (A few bearings against a big map can leave millions.)
MAX_COMPILED_LEAVES = 200_000


def predicted(landmarks_xy: FloatArray, poses: FloatArray) -> FloatArray:
    """Bearings (unwrapped) of landmarks (K, n, 2) from poses (K, 3): (K, n)."""
    d = landmarks_xy - poses[:, None, :2]
    return np.asarray(np.arctan2(d[..., 1], d[..., 0]) - poses[:, None, 2])


def map_scale(lm: LandmarkMap) -> float:
    """Size of the map (its bounding box's longer side, metres) for "at infinity" tests."""
    x0, y0, x1, y1 = lm.bounds
    return max(x1 - x0, y1 - y0) or 1.0


def eps_f2(lm: LandmarkMap) -> float:
    """``|f|^2`` at or below this is a robot at infinity (rule i)."""
    return (1e-12 / map_scale(lm)) ** 2


# --------------------------------------------------------------------------------------------
# Observation order
# --------------------------------------------------------------------------------------------


def robust_order(bearings: FloatArray) -> IntArray:
    """Observation order that prunes early: the widest-spread triple first (among the first
    12 bearings), then the rest in the order given.

    Three bearings spread round the robot fix the pose best (their pose has the smallest
    covariance), so the depth > 3 gates are tightest.
    """
    m = bearings.shape[0]
    if m <= 3:
        return np.arange(m)
    best = list(widest_triple(np.require(bearings[:12], np.float64, ["C", "W"])))
    return np.array(best + [o for o in range(m) if o not in best], dtype=np.int64)


def widest_triple_numpy(bearings: FloatArray) -> tuple[int, int, int]:
    """:func:`~omniloc._kernels.tree.widest_triple` read plainly (its test oracle)."""
    m = bearings.shape[0]
    triples = np.array(list(itertools.combinations(range(m), 3)), dtype=np.int64)
    widest = int(np.argmax(gaps(bearings, triples).min(axis=1)))
    a, b, c = (int(i) for i in triples[widest])
    return a, b, c


# --------------------------------------------------------------------------------------------
# The compiled walk of the paper's rules
# --------------------------------------------------------------------------------------------


def run_paper_kernel(lm: LandmarkMap, beta: FloatArray, opt: SearchOptions, out: Leaves) -> None:
    """The paper's tree for bearings ``beta`` (level order) by the compiled walk, into ``out``.

    The walk cannot read the clock: a time budget becomes a node budget at
    COMPILED_NODES_PER_SECOND (it visits about ten million nodes a second). Room for complete
    paths grows (the walk runs again) up to MAX_COMPILED_LEAVES; beyond, the first ones are
    kept and the result is marked incomplete.
    """
    capacity = 64
    # Room for the paths, (leaves, m) twice over in the scoring, stays within about 2e7 entries.
    most = max(64, min(MAX_COMPILED_LEAVES, 20_000_000 // max(1, beta.shape[0])))
    cap = 0
    budget = opt.budget
    if budget.max_nodes is not None:
        cap = budget.max_nodes
    if budget.timeout_s is not None:
        by_time = max(1, int(min(budget.timeout_s * COMPILED_NODES_PER_SECOND, 2**62)))
        cap = by_time if cap == 0 else min(cap, by_time)
    L = np.require(lm.xy, np.float64, ["C", "W"])
    b = np.require(beta, np.float64, ["C", "W"])
    while True:
        lim = TreeLimits(float(opt.sensor.threshold), SINGULAR_RTOL, eps_f2(lm), cap, capacity)
        assign, pose, counts = paper_tree(L, b, lim)
        if counts.leaves <= capacity or capacity >= most:
            break
        capacity = min(int(counts.leaves), most)
    c = out.counts
    c.nodes, c.examined, c.triples = counts.nodes, counts.examined, counts.triples
    c.existence, c.gate = counts.pruned_existence, counts.pruned_gate
    if counts.stopped or counts.leaves > capacity:
        out.complete = False
    if counts.leaves > capacity:
        log.warning(
            "localize: %d complete paths; kept the first %d (result marked incomplete)",
            counts.leaves,
            capacity,
        )
    out.add(assign, pose)


# --------------------------------------------------------------------------------------------
# The batched tree
# --------------------------------------------------------------------------------------------


@dataclass
class _Batch:
    """A batch of sibling paths at one level, as parallel arrays (K rows)."""

    level: int
    assign: IntArray  # (K, m) landmark per level; -1 wildcard, -2 not yet assigned
    nmatch: IntArray  # (K,)
    nwild: IntArray  # (K,)
    anchor: IntArray  # (K,) first matched landmark (L_0 of eq. 1), -1 if none
    anchor_b: FloatArray  # (K,) its bearing
    S: FloatArray  # (K, 3) sum of P_i: s00, s01, s11 (eq. 4)
    T: FloatArray  # (K, 2) sum of P_i b_i
    a1: NDArray[np.complex128]  # (K,) a_1 and b_1 of the first pair after the anchor
    b1: NDArray[np.complex128]
    pose: FloatArray  # (K, 3), valid where nmatch >= 3

    _FIELDS = ("assign", "nmatch", "nwild", "anchor", "anchor_b", "S", "T", "a1", "b1", "pose")

    def __len__(self) -> int:
        return int(self.nmatch.shape[0])

    def take(self, idx: IntArray | slice) -> _Batch:
        return _Batch(self.level, *(getattr(self, f)[idx] for f in self._FIELDS))

    @classmethod
    def concat(cls, level: int, parts: list[_Batch]) -> _Batch:
        return cls(level, *(np.concatenate([getattr(p, f) for p in parts]) for f in cls._FIELDS))

    @classmethod
    def root(cls, m: int) -> _Batch:
        return cls(
            0,
            np.full((1, m), -2, dtype=np.int64),
            np.zeros(1, dtype=np.int64),
            np.zeros(1, dtype=np.int64),
            np.full(1, -1, dtype=np.int64),
            np.zeros(1),
            np.zeros((1, 3)),
            np.zeros((1, 2)),
            np.zeros(1, dtype=np.complex128),
            np.zeros(1, dtype=np.complex128),
            np.zeros((1, 3)),
        )


class TreeSearch:
    """One walk of the tree over a map, bearings in level order, and options.

    ``run()`` fills ``out`` (a :class:`~omniloc.search.options.Leaves`) with the complete
    paths and the counters. Every robust option is available (wildcards, chi-square gates,
    ordering, range limits, budgets); without them the compiled walk is equivalent and
    faster, which :func:`omniloc.search.localize` uses unless told ``strategy="tree"``.
    """

    def __init__(self, lm: LandmarkMap, beta: FloatArray, opt: SearchOptions, out: Leaves) -> None:
        self.lm = lm
        self.L = lm.xy
        self.N = lm.n
        self.beta = beta
        self.m = int(beta.shape[0])
        self.opt = opt
        self.sensor = opt.sensor
        self.out = out
        self.count = out.counts
        # Bearings closer than this may come in either order (twice the gate half-width).
        self.order_tol = 2.0 * self.sensor.gate_width
        self.eps_f2 = eps_f2(lm)

    # ---- the walk --------------------------------------------------------------------------
    def _over_budget(self) -> bool:
        b = self.opt.budget
        if b.max_nodes is not None and self.count.nodes >= b.max_nodes:
            return True
        left = self.out.time_left(b.timeout_s)
        return left is not None and left < 0

    def run(self) -> None:
        """Walk the tree depth first, batch by batch; complete paths go to ``out``."""
        stack: list[_Batch] = [_Batch.root(self.m)]
        while stack:
            if self._over_budget():
                self.out.complete = False
                break
            batch = stack.pop()
            if batch.level == self.m:
                self.out.add(batch.assign, batch.pose)
                continue
            per = max(1, BATCH_PAIRS // (self.N + 1))
            if len(batch) > per:
                parts = [batch.take(slice(i, i + per)) for i in range(0, len(batch), per)]
                stack.extend(reversed(parts))
                continue
            children = self._expand(batch)
            if children is not None and len(children):
                stack.append(children)

    # ---- one level -------------------------------------------------------------------------
    def _expand(self, B: _Batch) -> _Batch | None:
        lev = B.level
        depth = lev + 1  # depth of the children in the tree
        beta = float(self.beta[lev])
        remaining = self.m - depth  # levels left below the children
        opt = self.opt
        parts: list[_Batch] = []

        # Wildcard children ("this bearing is not on the map"), explored after the matches.
        # Bound: a wildcard is only taken while the path can still reach the required number
        # of matched bearings, m - max_spurious; every other wildcard branch is cut.
        wild: _Batch | None = None
        if opt.max_wild > 0:
            ok = B.nmatch + remaining >= opt.min_match
            n_wild = int(ok.sum())
            self.count.nodes += n_wild
            self.count.bound += len(B) - n_wild
            if depth > 3:
                self.count.examined += n_wild
            if n_wild:
                wild = B.take(np.flatnonzero(ok))
                wild.assign = wild.assign.copy()
                wild.assign[:, lev] = -1
                wild.nwild = wild.nwild + 1
                wild.level = depth

        # Landmark children, by how many pairs their parent already has.
        groups: list[tuple[int, IntArray | None]]
        if B.nmatch.min() == B.nmatch.max():
            groups = [(int(B.nmatch[0]), None)]
        else:
            groups = [(int(k), np.flatnonzero(B.nmatch == k)) for k in np.unique(B.nmatch)]
        for k, idx in groups:
            G = B if idx is None else B.take(idx)
            child: _Batch | None
            par, lmk = self._candidates(G, k)
            n_cand = int(par.size)
            self.count.nodes += n_cand
            if depth > 3:
                self.count.examined += n_cand
            if n_cand == 0:
                continue
            if k < 2:
                child = self._add_pair(G, par, lmk, beta)
            elif k == 2:
                child = self._add_third(G, par, lmk, beta)
            else:
                child = self._add_checked(G, par, lmk, beta)
            if child is not None and len(child):
                parts.append(child)
        if wild is not None:
            parts.append(wild)
        if not parts:
            return None
        out = parts[0] if len(parts) == 1 else _Batch.concat(depth, parts)
        out.level = depth
        return out

    def _candidates(self, G: _Batch, k: int) -> tuple[IntArray, IntArray]:
        """(parent row, landmark) pairs to test: unused landmarks, cut by range if known."""
        K, N = len(G), self.N
        s = self.sensor
        near_only = s.max_range is not None and k >= 1 and N > 64
        if near_only:
            par, lmk = self._range_candidates(G, k)
            # Distinct landmarks along a path.
            used = (G.assign[par] == lmk[:, None]).any(axis=1)
            if used.any():
                par, lmk = par[~used], lmk[~used]
        else:
            # Every landmark not yet on the path: mark the used ones in a (K, N) table.
            free = np.ones((K, N), dtype=bool)
            A = G.assign[:, : G.level]
            rows, cols = np.nonzero(A >= 0)
            free[rows, A[rows, cols]] = False
            par, lmk = np.nonzero(free)
            par, lmk = par.astype(np.int64), lmk.astype(np.int64)
        reach = s.reach_max
        if reach is not None and 1 <= k <= 2:
            # Two landmarks seen from one point within max_range are at most 2 max_range apart.
            lim = (2.0 * reach) ** 2
            d = self.L[lmk] - self.L[G.anchor[par]]
            far = (d * d).sum(axis=1) > lim
            if k == 2:  # the second landmark is L_0 + 1 / b_1 (eq. 2)
                with np.errstate(divide="ignore", invalid="ignore"):
                    z1 = 1.0 / G.b1[par]
                d1 = d - np.stack([z1.real, z1.imag], axis=1)
                far |= (d1 * d1).sum(axis=1) > lim
            if far.any():
                self.count.visibility += int(far.sum())
                par, lmk = par[~far], lmk[~far]
        return par, lmk

    def _range_candidates(self, G: _Batch, k: int) -> tuple[IntArray, IntArray]:
        """Candidate landmarks from the spatial index: near the anchor, or near the pose."""
        reach = self.sensor.reach_max
        assert reach is not None  # only called with a range
        if k >= 3:
            centres, radius = G.pose[:, :2], reach
        else:
            centres, radius = self.L[G.anchor], 2.0 * reach
        lists = self.lm.kdtree.query_ball_point(centres, radius, return_sorted=False)
        lens = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
        par = np.repeat(np.arange(len(G)), lens)
        lmk = (
            np.concatenate([np.asarray(x, dtype=np.int64) for x in lists])
            if lens.sum()
            else np.zeros(0, dtype=np.int64)
        )
        return par, lmk

    # ---- children before a pose exists (depth 1, 2) ------------------------------------------
    def _pair(
        self, G: _Batch, par: IntArray, lmk: IntArray, beta: float
    ) -> tuple[Any, Any, FloatArray, FloatArray]:
        """a and b of a new pair (eqs. 1-2) and the sums of eq. 4 with its P added."""
        d = self.L[lmk] - self.L[G.anchor[par]]
        with np.errstate(divide="ignore", invalid="ignore"):
            rot = np.exp(1j * (beta - G.anchor_b[par]))
            a, b, p00, p01, p11, pb0, pb1 = geo.np_pair_terms(d[:, 0], d[:, 1], rot)
        S = G.S[par] + np.stack([p00, p01, p11], axis=1)
        T = G.T[par] + np.stack([pb0, pb1], axis=1)
        return a, b, S, T

    def _add_pair(self, G: _Batch, par: IntArray, lmk: IntArray, beta: float) -> _Batch:
        C = G.take(par)
        C.assign = C.assign.copy()
        C.assign[:, G.level] = lmk
        first = C.nmatch == 0
        C.anchor = np.where(first, lmk, C.anchor)
        C.anchor_b = np.where(first, beta, C.anchor_b)
        second = np.flatnonzero(~first)
        if second.size:
            a, b, S, T = self._pair(G, par[second], lmk[second], beta)
            C.S, C.T, C.a1, C.b1 = C.S.copy(), C.T.copy(), C.a1.copy(), C.b1.copy()
            C.S[second], C.T[second] = S, T
            C.a1[second], C.b1[second] = a, b
        C.nmatch = C.nmatch + 1
        C.level = G.level + 1
        return C

    def _pose_of(self, G: _Batch, par: IntArray, S: FloatArray, T: FloatArray) -> tuple[Any, ...]:
        """Eqs. 4-6 for the sums S, T of paths ``G[par]``: fx, fy, pose (K, 3), exists (the
        tests of rule i apart from the distance ratios)."""
        L0 = self.L[G.anchor[par]]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            fx, fy, det, f2, rx, ry, th = geo.np_pose_from_sums(
                S[:, 0], S[:, 1], S[:, 2], T[:, 0], T[:, 1], L0[:, 0], L0[:, 1], G.anchor_b[par]
            )
            exists = geo.np_pose_exists(
                det, S[:, 0], S[:, 1], S[:, 2], f2, SINGULAR_RTOL, self.eps_f2
            )
        return fx, fy, np.stack([rx, ry, th], axis=1), exists

    # ---- rule (i): the third pair --------------------------------------------------------------
    def _add_third(self, G: _Batch, par: IntArray, lmk: IntArray, beta: float) -> _Batch | None:
        self.count.triples += int(par.size)
        a, b, S, T = self._pair(G, par, lmk, beta)
        fx, fy, pose, ok = self._pose_of(G, par, S, T)
        # Rule (i): the pose exists -- S invertible, both distance ratios positive, f finite.
        with np.errstate(divide="ignore", invalid="ignore"):
            ok &= geo.np_distance_ratio(G.a1[par], G.b1[par], fx, fy) > 0
            ok &= geo.np_distance_ratio(a, b, fx, fy) > 0
        self.count.existence += int((~ok).sum())
        keep = np.flatnonzero(ok)
        if keep.size == 0:
            return None
        C = G.take(par[keep])
        C.assign = C.assign.copy()
        C.assign[:, G.level] = lmk[keep]
        C.S, C.T, C.pose = S[keep], T[keep], pose[keep]
        C.nmatch = C.nmatch + 1
        C.level = G.level + 1
        # Three pairs fit exactly: this pose is already the maximum-likelihood one.
        return self._visible_path(C)

    # ---- rule (ii): depth > 3 ------------------------------------------------------------------
    def _add_checked(self, G: _Batch, par: IntArray, lmk: IntArray, beta: float) -> _Batch | None:
        s = self.sensor
        P = G.pose[par]
        Lc = self.L[lmk]
        dx = Lc[:, 0] - P[:, 0]
        dy = Lc[:, 1] - P[:, 1]
        pred = np.arctan2(dy, dx) - P[:, 2]
        innov = np.remainder(pred - beta + np.pi, TWO_PI) - np.pi
        if s.sigma is None:
            ok = np.abs(innov) <= s.threshold
        else:
            ok = self._sigma_gate(G, par, dx, dy, innov)
        self.count.gate += int((~ok).sum())
        if s.max_range is not None or s.min_range is not None:
            r2 = dx * dx + dy * dy
            vis = np.ones_like(ok)
            if s.reach_max is not None:
                vis &= r2 <= s.reach_max**2
            if s.reach_min is not None:
                vis &= r2 >= s.reach_min**2
            self.count.visibility += int((ok & ~vis).sum())
            ok &= vis
        if self.opt.ordering and ok.any():
            sel = np.flatnonzero(ok)
            good = self._order_ok_candidate(G, par[sel], geo.np_wrap_angle(pred[sel]), beta)
            self.count.ordering += int((~good).sum())
            ok[sel[~good]] = False
        keep = np.flatnonzero(ok)
        if keep.size == 0:
            return None
        par, lmk = par[keep], lmk[keep]
        # A validated node re-estimates the pose from all its pairs (eq. 4 over the path).
        _, _, S, T = self._pair(G, par, lmk, beta)
        fx, fy, pose, exists = self._pose_of(G, par, S, T)
        C = G.take(par)
        C.assign = C.assign.copy()
        C.assign[:, G.level] = lmk
        C.S, C.T = S, T
        # Where the re-estimate is not a valid pose by eqs. 1-6 (a singular sum, a distance
        # ratio <= 0, a robot at infinity), the path keeps its previous pose.
        valid = exists & self._ratios_positive(C, fx, fy)
        C.pose = np.where(valid[:, None], pose, G.pose[par])
        C.nmatch = C.nmatch + 1
        C.level = G.level + 1
        if s.sigma is not None:
            C.pose = self._refine(C)
        if self.opt.ordering:
            good = self._order_ok_path(C)
            self.count.ordering += int((~good).sum())
            if not good.all():
                C = C.take(np.flatnonzero(good))
        return C

    def _ratios_positive(self, C: _Batch, fx: FloatArray, fy: FloatArray) -> NDArray[np.bool_]:
        """Whether every pair of each path (but its anchor) has a positive distance ratio at
        the re-estimated f (eq. 10)."""
        Lm, bm, w = self._matched(C)
        L0 = self.L[C.anchor]
        pair = (w > 0) & (C.assign[:, : C.level] != C.anchor[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):
            rot = np.exp(1j * (bm - C.anchor_b[:, None]))
            a, b, *_ = geo.np_pair_terms(
                Lm[..., 0] - L0[:, None, 0], Lm[..., 1] - L0[:, None, 1], rot
            )
            r = geo.np_distance_ratio(a, b, fx[:, None], fy[:, None])
        return np.asarray(((r > 0) | ~pair).all(axis=1))

    # ---- helpers for the robust rules -----------------------------------------------------------
    def _matched(self, C: _Batch) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Matched landmarks, bearings and weights of each path, padded to the depth."""
        d = C.level
        A = C.assign[:, :d]
        w = (A >= 0).astype(np.float64)
        Lm = self.L[np.maximum(A, 0)]
        bm = np.broadcast_to(self.beta[:d], A.shape)
        return Lm, np.ascontiguousarray(bm), w

    def _refine(self, C: _Batch) -> FloatArray:
        """Two Gauss-Newton steps from the linear pose (sigma mode), towards the ML pose.

        The linear estimate minimises an algebraic error; the gate's covariance describes the
        maximum-likelihood estimate, so the path's pose is moved to it before it predicts.
        """
        Lm, bm, w = self._matched(C)
        return geo.gauss_newton(
            np.require(Lm, np.float64, ["C", "W"]),
            np.require(bm, np.float64, ["C", "W"]),
            np.require(w, np.float64, ["C", "W"]),
            np.require(C.pose, np.float64, ["C", "W"]),
            2,
        )[0]

    def _sigma_gate(
        self, G: _Batch, par: IntArray, dx: FloatArray, dy: FloatArray, innov: FloatArray
    ) -> NDArray[np.bool_]:
        """Chi-square gate: innov^2 <= chi2 (g^T Cov(pose) g + sigma^2).

        Most candidates are far outside any gate, so they are first tested against an upper
        bound of the variance (trace(Cov) |g|^2 >= g^T Cov g), and the exact quadratic form
        is only evaluated for the few that pass it.
        """
        sig = self.sensor.noise
        chi2 = self.sensor.gate_chi2
        cov = self._pose_cov(G)
        r2 = dx * dx + dy * dy
        tr = np.einsum("kii->k", cov)[par]
        bound = tr * (1.0 / r2 + 1.0) + sig * sig
        i2 = innov * innov
        ok = i2 <= chi2 * bound
        idx = np.flatnonzero(ok)
        if idx.size:
            gx, gy = dy[idx] / r2[idx], -dx[idx] / r2[idx]
            c = cov[par[idx]]
            v = (
                gx * gx * c[:, 0, 0]
                + gy * gy * c[:, 1, 1]
                + c[:, 2, 2]
                + 2.0 * (gx * gy * c[:, 0, 1] - gx * c[:, 0, 2] - gy * c[:, 1, 2])
            )
            ok[idx] = i2[idx] <= chi2 * (np.maximum(v, 0.0) + sig * sig)
        return ok

    def _pose_cov(self, G: _Batch) -> FloatArray:
        """Covariance of each path's pose from its matched pairs, sigma^2 (G^T G)^-1, with
        the gate's floor (a near-singular geometry admits rather than rejects)."""
        Lm, _, w = self._matched(G)
        sig = self.sensor.noise
        return geo.covariances(
            np.require(Lm, np.float64, ["C", "W"]),
            np.require(w, np.float64, ["C", "W"]),
            np.require(G.pose, np.float64, ["C", "W"]),
            sig * sig,
            geo.GATE_FLOOR,
        )

    def _order_ok_candidate(
        self, G: _Batch, par: IntArray, pred: FloatArray, beta: float
    ) -> NDArray[np.bool_]:
        """Ordering: the candidate's predicted bearing falls between the same matched
        neighbours, around the pose, as the measured bearing does among the measured ones."""
        Lm, bm, w = self._matched(G)
        predm = predicted(Lm, G.pose)
        # Angle of each matched observation counter-clockwise from the new one.
        ccw_meas = np.mod(bm - beta, TWO_PI)
        big = 10.0
        ccw_meas = np.where(w > 0, ccw_meas, big)
        nxt = np.argmin(ccw_meas, axis=1)  # next matched observation counter-clockwise
        prv = np.argmax(np.where(w > 0, ccw_meas, -big), axis=1)  # previous one
        rows = np.arange(len(G))
        p_next = predm[rows, nxt][par]
        p_prev = predm[rows, prv][par]
        # The candidate must lie in the counter-clockwise arc from prev to next, give or take
        # the noise: bearings closer than that may be measured in either order.
        tol = self.order_tol
        span = np.mod(p_next - p_prev, TWO_PI)
        pos = np.mod(pred - p_prev + tol, TWO_PI) - tol
        return np.asarray(pos <= span + tol)

    def _order_ok_path(self, C: _Batch) -> NDArray[np.bool_]:
        """Ordering over a whole path at its re-estimated pose (see :func:`order_ok`)."""
        Lm, bm, w = self._matched(C)
        return order_ok(Lm, bm, w, C.pose, self.order_tol)

    def _visible_path(self, C: _Batch) -> _Batch | None:
        """Range limits on a fresh triple: the pose must see its three landmarks in range."""
        s = self.sensor
        if s.max_range is None and s.min_range is None:
            return C
        Lm, _, w = self._matched(C)
        d2 = ((Lm - C.pose[:, None, :2]) ** 2).sum(axis=2)
        ok = np.ones(len(C), dtype=bool)
        if s.reach_max is not None:
            ok &= ((d2 <= s.reach_max**2) | (w == 0)).all(axis=1)
        if s.reach_min is not None:
            ok &= ((d2 >= s.reach_min**2) | (w == 0)).all(axis=1)
        self.count.visibility += int((~ok).sum())
        return C.take(np.flatnonzero(ok)) if not ok.all() else C


def order_ok(
    Lm: FloatArray, bm: FloatArray, w: FloatArray, poses: FloatArray, tol: float
) -> NDArray[np.bool_]:
    """The ordering constraint over whole paths: the matched landmarks ``Lm`` (K, n, 2)
    (weights ``w``, 0 for unmatched) go round each pose in the cyclic order of their
    bearings ``bm`` (K, n), one turn exactly, where a step back smaller than ``tol`` counts as
    no step (such bearings may swap under noise)."""
    predm = predicted(Lm, poses)
    key = np.where(w > 0, np.mod(bm, TWO_PI), np.inf)
    idx = np.argsort(key, axis=1, kind="stable")
    ps = np.take_along_axis(predm, idx, axis=1)
    ws = np.take_along_axis(w, idx, axis=1)
    n = ws.sum(axis=1).astype(np.int64)
    turns = np.zeros(len(poses))
    for k in np.unique(n):
        rows = np.flatnonzero(n == k)
        seq = ps[rows, :k]
        steps = np.mod(np.diff(np.concatenate([seq, seq[:, :1]], axis=1), axis=1), TWO_PI)
        steps = np.where(steps > TWO_PI - tol, steps - TWO_PI, steps)
        turns[rows] = steps.sum(axis=1)
    return np.asarray(np.abs(turns - TWO_PI) < 1e-6)


def path_sse(L: FloatArray, beta: FloatArray, assign: IntArray, poses: FloatArray) -> FloatArray:
    """Squared bearing error of complete paths (assignments in level order, -1 unmatched) at
    their poses."""
    w = (assign >= 0).astype(np.float64)
    Lm = L[np.maximum(assign, 0)]
    pred = predicted(Lm, poses)
    res = (np.remainder(pred - beta + np.pi, TWO_PI) - np.pi) * w
    return np.asarray((res * res).sum(axis=1))
