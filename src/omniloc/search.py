"""Interpretation Tree search: correspondences and pose together (the seed paper's section 3).

Level ``k`` of the tree assigns observation ``k`` to a landmark (or, with ``max_spurious``, to
the wildcard "not on the map"). A path is pruned by the paper's two rules:

(i)  when its third landmark is assigned, a pose must exist (eqs. 1-6 with positive distance
     ratios);
(ii) below that, the bearing predicted from the path's pose must match the measured one,
     ``|wrap(predicted - measured)| <= threshold`` (or, with ``sigma``, a chi-square gate on the
     innovation whose variance includes the pose uncertainty).

Every validated node re-estimates the pose from all its pairs (eq. 4 over the path's pairs;
the sums of eq. 4 are kept incrementally, which gives the same numbers). Every complete path
that survives is a solution. Beyond the paper, the search also offers wildcards for spurious
bearings with a branch-and-bound on the number of matches, the angular ordering constraint,
visibility limits (range, field of view) with negative evidence, merging of equivalent
solutions, ambiguity reporting and node/time budgets.

Implementation: the tree is walked depth first, but a whole batch of sibling paths is expanded
at once with numpy (a "batched" depth-first search). Without a budget this visits exactly the
nodes the plain depth-first reading visits, in another order, so the solutions and the
statistics are the same; memory stays bounded by the batch size times the depth.
"""

from __future__ import annotations

import enum
import functools
import itertools
import logging
import math
import os
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import chdtri, ndtri
from scipy.stats import binom

from . import _compiled, _seeds
from .angles import TWO_PI, wrap
from .errors import InputError
from .io import check_bearings
from .maps import LandmarkMap, as_landmark_map
from .pose import SINGULAR_RTOL, Pose, _bearing_jacobian

__all__ = [
    "LocalizationResult",
    "Method",
    "SearchStats",
    "Solution",
    "localize",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

log = logging.getLogger(__name__)

#: Relative slack of the range limits in the search (see _Options.reach_max).
RANGE_SLACK = 0.05

#: Rate at which a time budget becomes a budget of work in the hypothesise-and-verify kernel
#: (candidate landmarks looked at, a verification node once per landmark near its hypothesis
#: plus _compiled.NODE_WORK, a complete path _compiled.LEAF_WORK; see _compiled.hypotheses).
HYPOTHESIS_WORK_PER_SECOND = 600_000_000

#: From a narrow seed (three bearings spanning less than _seeds.WIDE_SPAN), the hypotheses'
#: verification relinearises (two Gauss-Newton steps and a fresh covariance, as the tree does
#: at every node) while a path has at most this many pairs, and uses one Kalman update per
#: match after that: such poses are far from linear at first (with a 67-degree field of
#: view, Kalman updates alone lost the true pose in 2 % more MRCLAM frames).
RELINEARISE = 4

#: Margins on the first-order bound of the hypotheses search's cheap test before it verifies
#: a hypothesis (``_compiled._can_reach``): (wide seeds, narrow seeds) for an exhaustive search
#: and for a first fit; 0 turns the test off. The bound is exact for a linear bearing
#: function; poses from three bearings are not (one seed pose was 4x off its linearised
#: covariance). Measured against the search without the test: with (4, 8), 1 of 977 scenes
#: (scene b, random 12-30 landmark maps with 2 spurious, all MRCLAM frames) lost one poorly
#: fitting interpretation, never the best; with (1.5, 3), 5 of 380. A first fit gives up
#: completeness anyway and takes the faster margin (scene c: 0.59 s median with it, 0.83 s
#: with the exhaustive one, 1.08 s without).
PRETEST_SLACK = {True: (4.0, 8.0), False: (1.5, 3.0)}

#: Bearings closer than this (radians) may compete for one landmark: the hypotheses search
#: tries each of them as spurious even where a landmark fits (as the tree tries every bearing).
CONTESTED = float(np.deg2rad(25.0))

#: First landmarks per chunk of a large map's hypothesis search, and threads that run chunks.
CHUNK_ANCHORS = 256
THREADS = 2

#: Upper bound on candidate (path, landmark) pairs evaluated in one numpy batch.
BATCH_PAIRS = 1 << 16

#: The compiled walk enforces ``timeout_s`` as a budget of this many nodes per second.
COMPILED_NODES_PER_SECOND = 2_000_000

#: Maps larger than this, searched without max_range or a budget, get a warning in the log.
LARGE_MAP = 1000

#: The compiled walk keeps at most this many complete paths (the first ones found); more mark
#: the result incomplete. (A few bearings against a big map can leave millions.)
MAX_COMPILED_LEAVES = 200_000

#: At most this many complete paths are refined and returned (the best by matches and fit).
#: Measured on MRCLAM set 6 (8 bearings, 3 of them robots, are explained 6 at a time by
#: ~1,800 interpretations of a clustered map, the true one only 5 at a time): true pose among
#: the solutions 87.9 % at 2,000, 90.0 % at 8,000, 90.1 % at 16,000 and 32,000.
MAX_LEAVES = 8000


class Method(str, enum.Enum):
    """Which search semantics :func:`localize` follows.

    ``paper``
        The published algorithm to the letter: observations in the order given, rules (i) and
        (ii) with a fixed threshold, every consistent complete path reported as its own
        solution (this reproduces the paper's Table 1). Robust options are refused.
    ``robust``
        The same tree with everything beyond the paper available (wildcards, chi-square
        gating, ordering, visibility, negative evidence); the observation order is chosen to
        prune early, and solutions that are the same pose are merged.
    """

    PAPER = "paper"
    ROBUST = "robust"


class Strategy(str, enum.Enum):
    """How :func:`localize` runs a robust search (see its ``strategy`` parameter).

    ``auto``
        The compiled paper tree where the paper's rules alone apply, the hypotheses search
        for the robust options when numba is installed, the tree otherwise.
    ``tree``
        The interpretation tree with wildcard branches (the reference).
    ``hypotheses``
        Compiled: a pose hypothesis from every landmark triple that can be seen together, for
        a few seed triples of bearings, verified on the other bearings.
    """

    AUTO = "auto"
    TREE = "tree"
    HYPOTHESES = "hypotheses"


@dataclass(frozen=True)
class SearchStats:
    """What the search did.

    Attributes
    ----------
    total_paths : int
        Complete paths of the tree without wildcards, ``N! / (N - m)!`` (the paper's Table 1,
        second column).
    examined_paths : int
        Nodes visited at depth four or deeper: each is a path the search traced more than
        three nodes deep (Table 1, third column). A wildcard node deeper than three counts too.
    nodes : int
        Every node visited, at any depth, wildcards included (a node is "visited" when its
        pairing is generated and tested, whether it passes or not).
    elapsed_s : float
        Wall-clock time of the search and the final refinement, seconds.
    triples_solved : int
        Depth-3 pose solutions attempted (rule i).
    pruned_existence, pruned_gate, pruned_ordering, pruned_visibility, pruned_bound : int
        Nodes cut by rule (i), by rule (ii), by the ordering constraint, by range/field of
        view, and paths cut by the match-count bound (wildcards).
    complete : bool
        False when a budget (``max_nodes``, ``timeout_s``) stopped the search early.
    exhaustive : bool
        False when the search stopped at a first fit (``exhaustive=False``) and so did not
        look for rival interpretations.
    """

    total_paths: int
    examined_paths: int
    nodes: int
    elapsed_s: float
    triples_solved: int = 0
    pruned_existence: int = 0
    pruned_gate: int = 0
    pruned_ordering: int = 0
    pruned_visibility: int = 0
    pruned_bound: int = 0
    complete: bool = True
    exhaustive: bool = True

    def as_dict(self) -> dict[str, int | float | bool]:
        """Plain-JSON dictionary of the statistics."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class Solution:
    """One consistent interpretation: which landmark each bearing is, and the pose.

    Attributes
    ----------
    pose : Pose
        Maximum-likelihood pose refined from all matched pairs.
    assignment : tuple of (int or None)
        For each observation, in the order given, the index of its landmark in the map, or
        None when the observation was declared spurious (wildcard).
    residual_rms : float
        RMS of the wrapped bearing residuals over the matched observations, radians.
    matched : int
        Number of matched observations.
    covariance : ndarray, shape (3, 3)
        Covariance of (x, y, theta); from ``sigma`` when given, else from ``threshold / 3``.
    cost : float
        Negative log-likelihood used for ranking after ``matched`` (bearing residuals,
        spurious observations and, with ``p_miss``, landmarks that should have been seen).
    confidence : float
        Normalised posterior weight among the returned solutions (they sum to 1).
    missed : int
        Landmarks plainly visible from ``pose`` (by ``max_range``/``fov``) but not observed.
    """

    pose: Pose
    assignment: tuple[int | None, ...]
    residual_rms: float
    matched: int
    covariance: FloatArray = field(repr=False, compare=False)
    cost: float = 0.0
    confidence: float = 1.0
    missed: int = 0


@dataclass(frozen=True)
class LocalizationResult:
    """The outcome of :func:`localize`; tests false when there is no solution.

    Attributes
    ----------
    solutions : list of Solution
        Best first: most matched observations, then lowest cost.
    stats : SearchStats
    landmarks : LandmarkMap
        The map searched (for landmark ids).
    ambiguous : bool
        More than one distinct pose fits about as well as the best (same number of matches and
        confidence at least 1 % of the best): symmetric maps, too few observations.
    """

    solutions: list[Solution]
    stats: SearchStats
    landmarks: LandmarkMap
    ambiguous: bool = False

    @property
    def best(self) -> Solution | None:
        """The best solution, or None."""
        return self.solutions[0] if self.solutions else None

    @property
    def complete(self) -> bool:
        """False when a budget stopped the search before the whole tree was walked."""
        return self.stats.complete

    def __bool__(self) -> bool:
        return bool(self.solutions)

    def __len__(self) -> int:
        return len(self.solutions)

    def assignment_ids(self, solution: Solution) -> list[int | str | None]:
        """A solution's assignment as landmark ids (None for spurious observations)."""
        return [None if i is None else self.landmarks.ids[i] for i in solution.assignment]


# --------------------------------------------------------------------------------------------
# Option handling
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Options:
    threshold: float
    sigma: float | None
    gate_chi2: float
    joint_chi2: FloatArray  # by number of matched pairs: chi-square quantile with n - 3 dof
    max_wild: int
    min_match: int
    ordering: bool
    max_range: float | None
    min_range: float | None
    half_fov: float | None
    p_miss: float | None
    max_nodes: int | None
    timeout_s: float | None
    merge: bool
    # Range limits as the search applies them: RANGE_SLACK wider, since a hypothesis's pose is
    # an estimate (a landmark at 19.9 m must not fall out of a 20 m range by 0.2 m of error).
    reach_max: float | None = None
    reach_min: float | None = None

    @property
    def sigma_eff(self) -> float:
        """Bearing noise used for likelihoods and covariances."""
        return self.sigma if self.sigma is not None else self.threshold / 3.0


def _positive(name: str, value: float | None, *, allow_zero: bool = False) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise InputError(f"{name} must be a positive finite number, got {value!r}")
    return v


@functools.lru_cache(maxsize=64)
def _chi2_gates(confidence: float, m: int) -> tuple[float, FloatArray]:
    """The 1-dof gate and, by number of matched pairs, the joint gate with n - 3 dof."""
    gate = float(ndtri(0.5 + 0.5 * confidence) ** 2)
    dof = np.arange(m + 1) - 3.0
    with np.errstate(invalid="ignore"):
        joint = np.where(dof > 0, chdtri(np.maximum(dof, 1.0), 1.0 - confidence), np.inf)
    joint.setflags(write=False)
    return gate, joint


def _make_options(
    m: int,
    *,
    method: Method,
    threshold: float,
    sigma: float | None,
    confidence: float,
    max_spurious: int | float,
    ordering: bool,
    max_range: float | None,
    min_range: float | None,
    fov: float | None,
    p_miss: float | None,
    max_nodes: int | None,
    timeout_s: float | None,
) -> _Options:
    thr = _positive("threshold", threshold, allow_zero=True)
    assert thr is not None
    sig = _positive("sigma", sigma)
    if not (0.0 < float(confidence) < 1.0):
        raise InputError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
    if isinstance(max_spurious, bool) or not isinstance(max_spurious, (int, float, np.number)):
        raise InputError(f"max_spurious must be an int or a fraction of m, got {max_spurious!r}")
    if isinstance(max_spurious, (float, np.floating)) and not float(max_spurious).is_integer():
        if not 0.0 <= float(max_spurious) < 1.0:
            raise InputError(f"max_spurious as a fraction must lie in [0, 1), got {max_spurious}")
        k = math.floor(float(max_spurious) * m)
    else:
        k = int(max_spurious)
    if k < 0:
        raise InputError(f"max_spurious must be >= 0, got {max_spurious}")
    if m - k < 3:
        raise InputError(
            f"max_spurious={max_spurious} leaves {m - k} matched bearings out of {m}; "
            "a pose needs at least 3"
        )
    rmax = _positive("max_range", max_range)
    rmin = _positive("min_range", min_range, allow_zero=True)
    if rmax is not None and rmin is not None and rmin >= rmax:
        raise InputError(f"min_range ({rmin}) must be smaller than max_range ({rmax})")
    fv = _positive("fov", fov)
    if fv is not None and fv > TWO_PI + 1e-9:
        raise InputError(f"fov is a full angle in radians, at most 2*pi, got {fv}")
    pm = None
    if p_miss is not None:
        pm = float(p_miss)
        if not 0.0 < pm < 1.0:
            raise InputError(f"p_miss must lie strictly between 0 and 1, got {p_miss!r}")
    if max_nodes is not None and (not isinstance(max_nodes, (int, np.integer)) or max_nodes < 1):
        raise InputError(f"max_nodes must be a positive integer, got {max_nodes!r}")
    tmo = _positive("timeout_s", timeout_s)
    if method is Method.PAPER:
        extras = {
            "sigma": sig is not None,
            "max_spurious": k > 0,
            "ordering": bool(ordering),
            "max_range": rmax is not None,
            "min_range": rmin is not None,
            "fov": fv is not None,
            "p_miss": pm is not None,
        }
        used = [name for name, on in extras.items() if on]
        if used:
            raise InputError(
                f"method='paper' is the published algorithm and takes no {', '.join(used)}; "
                "use method='robust'"
            )
    gate, joint = _chi2_gates(float(confidence), m)
    return _Options(
        threshold=thr,
        sigma=sig,
        gate_chi2=gate,
        joint_chi2=joint,
        max_wild=k,
        min_match=m - k,
        ordering=bool(ordering),
        max_range=rmax,
        min_range=rmin,
        half_fov=None if fv is None or fv >= TWO_PI - 1e-9 else 0.5 * fv,
        p_miss=pm,
        max_nodes=None if max_nodes is None else int(max_nodes),
        timeout_s=tmo,
        merge=method is Method.ROBUST,
        reach_max=None if rmax is None else rmax * (1.0 + RANGE_SLACK),
        reach_min=None if rmin is None else rmin / (1.0 + RANGE_SLACK),
    )


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

    def __len__(self) -> int:
        return int(self.nmatch.shape[0])

    def take(self, idx: IntArray | slice) -> _Batch:
        return _Batch(
            self.level,
            self.assign[idx],
            self.nmatch[idx],
            self.nwild[idx],
            self.anchor[idx],
            self.anchor_b[idx],
            self.S[idx],
            self.T[idx],
            self.a1[idx],
            self.b1[idx],
            self.pose[idx],
        )


def _concat(level: int, parts: list[_Batch]) -> _Batch:
    def cat(name: str) -> Any:
        return np.concatenate([getattr(p, name) for p in parts])

    return _Batch(
        level,
        cat("assign"),
        cat("nmatch"),
        cat("nwild"),
        cat("anchor"),
        cat("anchor_b"),
        cat("S"),
        cat("T"),
        cat("a1"),
        cat("b1"),
        cat("pose"),
    )


def _root(m: int) -> _Batch:
    return _Batch(
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


class _Counter:
    def __init__(self) -> None:
        self.nodes = 0
        self.examined = 0
        self.triples = 0
        self.existence = 0
        self.gate = 0
        self.ordering = 0
        self.visibility = 0
        self.bound = 0


def _wrap_fast(a: FloatArray) -> FloatArray:
    """Wrap to [-pi, pi) for arrays on the hot path (no scalar handling)."""
    return np.remainder(a + np.pi, TWO_PI) - np.pi


def _gauss_newton(
    Lm: FloatArray, bm: FloatArray, w: FloatArray, start: FloatArray, *, iters: int
) -> tuple[FloatArray, FloatArray]:
    """Gauss-Newton on wrapped bearing residuals for K paths at once.

    ``Lm`` (K, n, 2) landmarks, ``bm`` (K, n) bearings, ``w`` (K, n) weights (0 for padding),
    ``start`` (K, 3) poses. The 3x3 normal equations are solved by Cramer's rule; a step is
    kept only where it lowers the squared error (a step that does not is halved, up to
    ``_compiled.GN_HALVINGS`` times), so the result is never worse than ``start``.
    Returns the poses and their weighted squared errors.
    """
    if _compiled.AVAILABLE:
        # Writable C arrays always: numba compiles (and caches) one version per array type,
        # and a read-only view would be a second type.
        return _compiled.gauss_newton(
            np.require(Lm, np.float64, ["C", "W"]),
            np.require(bm, np.float64, ["C", "W"]),
            np.require(w, np.float64, ["C", "W"]),
            np.require(start, np.float64, ["C", "W"]),
            iters,
        )
    p = start.copy()
    lx, ly = Lm[..., 0], Lm[..., 1]

    def residuals_of(
        q: FloatArray, rows: IntArray | slice
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        dx = lx[rows] - q[:, None, 0]
        dy = ly[rows] - q[:, None, 1]
        res = _wrap_fast(np.arctan2(dy, dx) - q[:, None, 2] - bm[rows]) * w[rows]
        return dx, dy, res, (res * res).sum(axis=1)

    dx, dy, res, sse = residuals_of(p, slice(None))
    for _ in range(iters):
        r2 = dx * dx + dy * dy
        gx, gy = dy / r2 * w, -dx / r2 * w
        gt = -w
        h00, h01, h02 = (gx * gx).sum(1), (gx * gy).sum(1), (gx * gt).sum(1)
        h11, h12, h22 = (gy * gy).sum(1), (gy * gt).sum(1), (gt * gt).sum(1)
        b0, b1, b2 = -(gx * res).sum(1), -(gy * res).sum(1), -(gt * res).sum(1)
        c00 = h11 * h22 - h12 * h12
        c01 = h02 * h12 - h01 * h22
        c02 = h01 * h12 - h02 * h11
        det = h00 * c00 + h01 * c01 + h02 * c02
        ok = np.abs(det) > 1e-12 * np.maximum(h00 * h11 * h22, 1e-300)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(ok, 1.0 / det, 0.0)
            c11 = h00 * h22 - h02 * h02
            c12 = h01 * h02 - h00 * h12
            c22 = h00 * h11 - h01 * h01
            step = np.stack(
                [
                    (c00 * b0 + c01 * b1 + c02 * b2) * inv,
                    (c01 * b0 + c11 * b1 + c12 * b2) * inv,
                    (c02 * b0 + c12 * b1 + c22 * b2) * inv,
                ],
                axis=1,
            )
        step[~np.isfinite(step).all(axis=1)] = 0.0
        step[np.abs(step).max(axis=1) < 1e-13] = 0.0
        moved = np.zeros(len(p), dtype=bool)
        for _ in range(_compiled.GN_HALVINGS + 1):
            # Backtracking, as in _compiled._gn_core: halve the steps that do not descend.
            todo = np.flatnonzero(~moved & (step != 0.0).any(axis=1))
            if todo.size == 0:
                break
            cand = p[todo] + step[todo]
            cdx, cdy, cres, csse = residuals_of(cand, todo)
            better = csse < sse[todo]
            take = todo[better]
            p[take], sse[take] = cand[better], csse[better]
            dx[take], dy[take], res[take] = cdx[better], cdy[better], cres[better]
            moved[take] = True
            step[todo[~better]] *= 0.5
        if not moved.any():
            break
    p[:, 2] = _wrap_fast(p[:, 2])
    return p, sse


def _projector(a: NDArray[np.complex128], b: NDArray[np.complex128]) -> tuple[FloatArray, ...]:
    """Entries of P = a a^T / a^T a - I (eq. 3) and of P b, for complex a and b."""
    ar, ai = a.real, a.imag
    aa = ar * ar + ai * ai
    p00 = ar * ar / aa - 1.0
    p01 = ar * ai / aa
    p11 = ai * ai / aa - 1.0
    br, bi = b.real, b.imag
    return p00, p01, p11, p00 * br + p01 * bi, p01 * br + p11 * bi


def _solve_f(S: FloatArray, T: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """f = -S^-1 T (eq. 4) for S given as (s00, s01, s11); returns f_x, f_y and det S."""
    s00, s01, s11 = S[:, 0], S[:, 1], S[:, 2]
    det = s00 * s11 - s01 * s01
    with np.errstate(divide="ignore", invalid="ignore"):
        fx = -(s11 * T[:, 0] - s01 * T[:, 1]) / det
        fy = -(-s01 * T[:, 0] + s00 * T[:, 1]) / det
    return fx, fy, det


def _pose_from_f(
    fx: FloatArray, fy: FloatArray, L0: FloatArray, b0: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Eqs. (5) and (6): the pose from f, the anchor landmark and its bearing."""
    f2 = fx * fx + fy * fy
    with np.errstate(divide="ignore", invalid="ignore"):
        rx = L0[:, 0] - fx / f2
        ry = L0[:, 1] + fy / f2
    theta = np.arctan2(L0[:, 1] - ry, L0[:, 0] - rx) - b0
    return np.stack([rx, ry, np.asarray(wrap(theta))], axis=1), f2


class _Search:
    """One run of the tree: the map, the bearings in level order, options and counters."""

    def __init__(
        self,
        lm: LandmarkMap,
        bearings: FloatArray,
        order: IntArray,
        opt: _Options,
        strategy: str = "tree",
    ) -> None:
        self.strategy = strategy
        self.L = lm.xy
        self.lm = lm
        self.N = lm.n
        self.beta = bearings[order]  # bearings in level order
        self.order = order
        self.m = int(bearings.shape[0])
        self.opt = opt
        self.count = _Counter()
        self.leaves: list[_Batch] = []
        self.use_compiled = True
        self.complete = True
        self.exhaustive = True
        self.t0 = time.perf_counter()
        # Bearings closer than this may come in either order (twice the gate half-width).
        gate = opt.threshold if opt.sigma is None else math.sqrt(opt.gate_chi2) * opt.sigma
        self.order_tol = 2.0 * gate
        # Scale for "robot at infinity" tests.
        x0, y0, x1, y1 = lm.bounds
        self.scale = max(x1 - x0, y1 - y0) or 1.0

    # ---- budget --------------------------------------------------------------------------
    def _over_budget(self) -> bool:
        o = self.opt
        if o.max_nodes is not None and self.count.nodes >= o.max_nodes:
            return True
        return o.timeout_s is not None and time.perf_counter() - self.t0 > o.timeout_s

    # ---- driver ----------------------------------------------------------------------------
    def _compiled_ok(self) -> bool:
        """Whether the compiled walk of the paper's rules covers this search."""
        o = self.opt
        return (
            _compiled.AVAILABLE
            and self.use_compiled
            and o.sigma is None
            and o.max_wild == 0
            and not o.ordering
            and o.max_range is None
            and o.min_range is None
        )

    def _run_compiled(self) -> None:
        capacity = 64  # grown and run again in the rare case of more complete paths
        # The compiled loop cannot read the clock: a time budget becomes a node budget at a
        # rate it comfortably exceeds (it visits about ten million nodes a second).
        cap = 0
        if self.opt.max_nodes is not None:
            cap = self.opt.max_nodes
        if self.opt.timeout_s is not None:
            by_time = max(1, int(self.opt.timeout_s * COMPILED_NODES_PER_SECOND))
            cap = by_time if cap == 0 else min(cap, by_time)
        while True:
            assign, pose, counts = _compiled.paper_tree(
                np.require(self.L, np.float64, ["C", "W"]),
                np.require(self.beta, np.float64, ["C", "W"]),
                float(self.opt.threshold),
                self.scale,
                SINGULAR_RTOL,
                cap,
                capacity,
            )
            if counts[5] <= capacity or capacity >= MAX_COMPILED_LEAVES:
                break
            capacity = min(int(counts[5]), MAX_COMPILED_LEAVES)
        c = self.count
        c.nodes, c.examined, c.triples, c.existence, c.gate = (int(v) for v in counts[:5])
        if counts[6] or counts[5] > capacity:
            self.complete = False
        if counts[5] > capacity:
            log.warning(
                "localize: %d complete paths; kept the first %d (result marked incomplete)",
                int(counts[5]),
                capacity,
            )
        if len(assign):
            self.leaves.append(self._leaf_batch(assign, pose))

    def _leaf_batch(self, assign: IntArray, pose: FloatArray) -> _Batch:
        """Complete paths found by a compiled kernel, as a batch for :func:`_finish`."""
        k = len(assign)
        nmatch = (assign >= 0).sum(axis=1).astype(np.int64)
        # Complete paths need no eq. 1-4 state (anchor, sums) any more: only the assignment
        # and the pose are read from here on.
        return _Batch(
            self.m,
            assign,
            nmatch,
            self.m - nmatch,
            np.full(k, -1, dtype=np.int64),
            np.full(k, float(self.beta[0])),
            np.zeros((k, 3)),
            np.zeros((k, 2)),
            np.zeros(k, dtype=np.complex128),
            np.zeros(k, dtype=np.complex128),
            pose,
        )

    def _run_hypotheses(self, stop_first: bool) -> None:
        """Hypothesise and verify (see :func:`omniloc._compiled.hypotheses`): every landmark
        triple that can be seen together, for each seed triple of bearings, predicts the other
        bearings; the seeds cover every choice of up to ``max_spurious`` spurious bearings.

        Large maps are cut into chunks of first landmarks, run on two threads (the kernel
        releases the GIL); ``stop_first`` stops handing out chunks once one has an answer.
        """
        o = self.opt
        gate = o.threshold if o.sigma is None else math.sqrt(o.gate_chi2) * o.sigma
        limits = _seeds.pair_limits(self.beta, o.reach_max, o.reach_min, 2.0 * gate)
        seeds = _seeds.seed_triples(self.beta, o.max_wild, limits)
        use_nb = o.max_range is not None and self.N > 64
        if use_nb:
            assert o.reach_max is not None
            # The pose lies within range of the first landmark, so every landmark it sees
            # lies within twice that of it.
            ptr, idx = self.lm.neighbours(2.0 * o.reach_max)
            nb_xy = self.lm.neighbour_xy(2.0 * o.reach_max)
            lo, hi = ptr[:-1], ptr[1:]
        else:
            # Every other landmark: in the list 0..N-1 written twice, the N - 1 entries after
            # position i are all landmarks but i.
            N = self.N
            idx = np.tile(np.arange(N, dtype=np.int64), 2)
            nb_xy = np.ascontiguousarray(self.L[idx])
            lo = np.arange(1, N + 1, dtype=np.int64)
            hi = lo + (N - 1)
        budget = 0 if o.max_nodes is None else o.max_nodes
        miss_allow = self.m + self.N
        if stop_first and o.p_miss is not None:
            # A first fit must not leave more plainly visible landmarks unseen than misses
            # typically explain: the median of Binomial(m, p_miss). The true interpretation
            # with more misses than that does not stop the search early but is still found
            # (it costs time, not the answer), while a generous allowance would let a wrong
            # pose that hides a landmark or two stop it (it did on a 100,000-landmark map).
            miss_allow = int(binom.ppf(0.5, self.m, o.p_miss))
        L = np.require(self.L, np.float64, ["C"])
        beta = np.require(self.beta, np.float64, ["C"])
        joint = np.require(o.joint_chi2, np.float64, ["C"])

        # Poses from narrow seeds are far from linear: relinearise their first matches.
        relin = np.where(_seeds.narrow(self.beta, seeds), RELINEARISE, 0).astype(np.int64)
        # The kernel's cheap necessary test before verifying a hypothesis, with its margin.
        wide, narrow = PRETEST_SLACK[not stop_first]
        pretest = np.where(relin > 0, narrow, wide)
        # Bearings that another bearing could rob of its landmark (see _compiled._verify).
        near_pair = _seeds.angle_between(self.beta) <= CONTESTED
        np.fill_diagonal(near_pair, False)
        contested = np.ascontiguousarray(near_pair.any(axis=1))

        # The kernel keeps the best interpretations by the cost _finish ranks with.
        sig = o.sigma_eff
        if o.p_miss is None:
            spur_w, miss_w = 1e6, 0.0  # matches first
        else:
            spur_w = max(0.5 * math.log(TWO_PI) - math.log(sig), 0.0)
            miss_w = -math.log(o.p_miss)

        def call(rows: slice, i0: int, i1: int, cap: tuple[int, int]) -> tuple[Any, ...]:
            """One kernel run; ``cap`` = (nodes, work) it may spend, 0 for no limit."""
            return _compiled.hypotheses(
                L,
                beta,
                seeds[rows],
                i0,
                i1,
                lo,
                hi,
                idx,
                nb_xy,
                limits,
                -1.0 if o.sigma is None else float(o.sigma),
                float(o.gate_chi2),
                float(o.threshold),
                joint,
                int(o.min_match),
                np.inf if o.reach_max is None else o.reach_max**2,
                0.0 if o.reach_min is None else o.reach_min**2,
                np.inf if o.half_fov is None else float(o.half_fov),
                # Plainly visible, as in _missed: 5 % inside the range limits.
                np.inf if o.max_range is None else (0.95 * o.max_range) ** 2,
                0.0 if o.min_range is None else (1.05 * o.min_range) ** 2,
                miss_allow,
                self.scale,
                SINGULAR_RTOL,
                cap[0],
                cap[1],
                stop_first,
                2 * MAX_LEAVES,
                relin[rows],
                contested,
                spur_w,
                miss_w,
                pretest[rows],
            )

        if self.N <= 4 * CHUNK_ANCHORS:
            work = self._work_left()
            results = [call(slice(None), 0, self.N, (budget, 1 if work < 0 else work))]
        else:
            chunks = [
                (slice(r, r + 1), i0, min(i0 + CHUNK_ANCHORS, self.N))
                for r in range(len(seeds))
                for i0 in range(0, self.N, CHUNK_ANCHORS)
            ]
            results = self._run_chunks(call, chunks, budget)
        if not results:
            # The time was up before the first chunk (a big map's neighbour lists took it).
            self.complete = False
            return
        counts = np.sum([r[3] for r in results], axis=0)
        stopped = max(int(r[3][6]) for r in results)
        c = self.count
        c.nodes, c.examined, c.triples, c.existence, c.gate = (int(v) for v in counts[:5])
        c.visibility, c.bound = int(counts[7]), int(counts[8])
        if any(int(r[3][6]) == 1 for r in results):
            self.complete = False
        if stopped == 2:
            self.exhaustive = False
        assign = np.concatenate([r[0] for r in results])
        if len(assign) == 0:
            return
        pose = np.concatenate([r[1] for r in results])
        if stopped == 2:
            # A first fit: what the other chunks in flight found counts only if it, too, is
            # an acceptable fit (the rest would rank below it on negative evidence anyway).
            fits = np.concatenate([r[2] for r in results]) <= miss_allow
            assign, pose = assign[fits], pose[fits]
        # One interpretation is often reached from several seeds.
        assign, first = np.unique(assign, axis=0, return_index=True)
        pose = pose[first]
        if stop_first:
            assign, pose = self._polish(assign, pose)
        C = self._leaf_batch(assign, pose)
        if o.ordering:
            good = self._order_ok_path(C)
            c.ordering += int((~good).sum())
            C = C.take(np.flatnonzero(good))
        if len(C):
            self.leaves.append(C)

    def _polish(self, assign: IntArray, pose: FloatArray) -> tuple[IntArray, FloatArray]:
        """Move a landmark to an unmatched bearing where that fits better (first fit).

        Verification takes bearings in a fixed order and gives each the best landmark in its
        gate, so a spurious bearing next to a true one can take the true one's landmark when
        the true one is checked first and falls just outside its gate. The exhaustive search
        also reaches the other interpretation (from another seed) and the ranking settles it;
        a first fit instead tries every such swap on the interpretation it stops at.
        """
        reach = 3.0 * math.sqrt(self.opt.gate_chi2) * self.opt.sigma_eff
        assign, pose = assign.copy(), pose.copy()
        for r in range(len(assign)):
            a = assign[r]
            _, sse = _gauss_newton(
                self.L[np.maximum(a, 0)][None], self.beta[None], (a >= 0)[None] * 1.0,
                pose[r][None], iters=0,
            )  # fmt: skip
            best = (float(sse[0]), a, pose[r])
            for u in np.flatnonzero(a < 0):
                for o in np.flatnonzero(a >= 0):
                    if abs(float(wrap(self.beta[u] - self.beta[o]))) > reach:
                        continue
                    alt = a.copy()
                    alt[u], alt[o] = a[o], -1
                    w = (alt >= 0) * 1.0
                    p2, sse2 = _gauss_newton(
                        self.L[np.maximum(alt, 0)][None], self.beta[None], w[None],
                        pose[r][None], iters=10,
                    )  # fmt: skip
                    if float(sse2[0]) < best[0]:
                        best = (float(sse2[0]), alt, p2[0])
            assign[r], pose[r] = best[1], best[2]
        return assign, pose

    def _work_left(self) -> int:
        """The kernel cannot read the clock: what is left of ``timeout_s`` (measured here)
        becomes work at HYPOTHESIS_WORK_PER_SECOND; 0 without a timeout, -1 when spent."""
        if self.opt.timeout_s is None:
            return 0
        left = self.opt.timeout_s - (time.perf_counter() - self.t0)
        return max(1, int(left * HYPOTHESIS_WORK_PER_SECOND)) if left > 0 else -1

    def _run_chunks(
        self,
        call: Any,
        chunks: list[tuple[slice, int, int]],
        budget: int,
    ) -> list[tuple[Any, ...]]:
        """Run chunks on a small thread pool, in order; stop early on an answer (first fit),
        when the node budget is spent (summed over chunks) or when the time is up (each
        chunk in flight may use what is left of it: they run side by side)."""
        results: list[tuple[Any, ...]] = []
        spent = 0
        workers = max(1, min(THREADS, os.cpu_count() or 1))
        with ThreadPoolExecutor(max_workers=workers) as pool:
            pending: list[Future[tuple[Any, ...]]] = []
            it = iter(chunks)
            done = False
            while True:
                while not done and len(pending) < workers:
                    nxt = next(it, None)
                    if nxt is None:
                        done = True
                        break
                    work = self._work_left()
                    if work < 0:
                        self.complete = False
                        done = True
                        break
                    left = 0 if budget == 0 else max(1, budget - spent)
                    pending.append(pool.submit(call, nxt[0], nxt[1], nxt[2], (left, work)))
                if not pending:
                    break
                r = pending.pop(0).result()
                results.append(r)
                spent += int(r[3][0])
                if int(r[3][6]) or (budget and spent >= budget):
                    done = True
        return results

    def run(self) -> None:
        if self.strategy == "hypotheses":
            self._run_hypotheses(stop_first=False)
            return
        if self.strategy == "first":
            self._run_hypotheses(stop_first=True)
            return
        if self._compiled_ok():
            self._run_compiled()
            return
        stack: list[_Batch] = [_root(self.m)]
        while stack:
            if self._over_budget():
                self.complete = False
                break
            batch = stack.pop()
            if batch.level == self.m:
                self.leaves.append(batch)
                continue
            per = max(1, BATCH_PAIRS // (self.N + 1))
            if len(batch) > per:
                parts = [batch.take(slice(i, i + per)) for i in range(0, len(batch), per)]
                stack.extend(reversed(parts))
                continue
            children = self._expand(batch)
            if children is not None and len(children):
                stack.append(children)

    def leaf_sse(self, B: _Batch) -> FloatArray:
        """Squared bearing error of complete paths at their current poses."""
        Lm, bm, w = self._matched(B)
        P = B.pose
        pred = np.arctan2(Lm[..., 1] - P[:, None, 1], Lm[..., 0] - P[:, None, 0]) - P[:, None, 2]
        res = _wrap_fast(pred - bm) * w
        return np.asarray((res * res).sum(axis=1))

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
        out = parts[0] if len(parts) == 1 else _concat(depth, parts)
        out.level = depth
        return out

    def _candidates(self, G: _Batch, k: int) -> tuple[IntArray, IntArray]:
        """(parent row, landmark) pairs to test: unused landmarks, cut by range if known."""
        K, N = len(G), self.N
        opt = self.opt
        if opt.max_range is not None and k >= 1 and N > 64:
            par, lmk = self._range_candidates(G, k)
        else:
            # Every landmark not yet on the path: mark the used ones in a (K, N) table.
            free = np.ones((K, N), dtype=bool)
            A = G.assign[:, : G.level]
            rows, cols = np.nonzero(A >= 0)
            free[rows, A[rows, cols]] = False
            par, lmk = np.nonzero(free)
            par, lmk = par.astype(np.int64), lmk.astype(np.int64)
        if opt.max_range is not None and k >= 1 and N > 64:
            # Distinct landmarks along a path.
            used = (G.assign[par] == lmk[:, None]).any(axis=1)
            if used.any():
                keep = ~used
                par, lmk = par[keep], lmk[keep]
        if opt.reach_max is not None and 1 <= k <= 2:
            # Two landmarks seen from one point within max_range are at most 2 max_range apart.
            lim = (2.0 * opt.reach_max) ** 2
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
        reach = self.opt.reach_max
        assert reach is not None
        tree = self.lm.kdtree
        if k >= 3:
            centres, radius = G.pose[:, :2], reach
        else:
            centres, radius = self.L[G.anchor], 2.0 * reach
        lists = tree.query_ball_point(centres, radius, return_sorted=False)
        lens = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
        par = np.repeat(np.arange(len(G)), lens)
        lmk = (
            np.concatenate([np.asarray(x, dtype=np.int64) for x in lists])
            if lens.sum()
            else np.zeros(0, dtype=np.int64)
        )
        return par, lmk

    # ---- children before a pose exists (depth 1, 2) ------------------------------------------
    def _add_pair(self, G: _Batch, par: IntArray, lmk: IntArray, beta: float) -> _Batch:
        C = G.take(par)
        C.assign = C.assign.copy()
        C.assign[:, G.level] = lmk
        first = C.nmatch == 0
        C.anchor = np.where(first, lmk, C.anchor)
        C.anchor_b = np.where(first, beta, C.anchor_b)
        second = ~first
        if second.any():
            z = self._z(lmk[second], C.anchor[second])
            a = np.exp(1j * (beta - C.anchor_b[second])) / z
            b = 1.0 / z
            p00, p01, p11, pb0, pb1 = _projector(a, b)
            C.S = C.S.copy()
            C.T = C.T.copy()
            C.S[second] = np.stack([p00, p01, p11], axis=1)
            C.T[second] = np.stack([pb0, pb1], axis=1)
            C.a1 = C.a1.copy()
            C.b1 = C.b1.copy()
            C.a1[second] = a
            C.b1[second] = b
        C.nmatch = C.nmatch + 1
        C.level = G.level + 1
        return C

    def _sums_with_pair(
        self, G: _Batch, par: IntArray, lmk: IntArray, beta: float
    ) -> tuple[NDArray[np.complex128], NDArray[np.complex128], FloatArray, FloatArray]:
        """a and b of a new pair (eqs. 1-2) and the sums of eq. 4 with its P added."""
        z = self._z(lmk, G.anchor[par])
        a = np.exp(1j * (beta - G.anchor_b[par])) / z
        b = 1.0 / z
        p00, p01, p11, pb0, pb1 = _projector(a, b)
        S = G.S[par] + np.stack([p00, p01, p11], axis=1)
        T = G.T[par] + np.stack([pb0, pb1], axis=1)
        return a, b, S, T

    def _z(self, lmk: IntArray, anchor: IntArray) -> NDArray[np.complex128]:
        d = self.L[lmk] - self.L[anchor]
        return d[:, 0] + 1j * d[:, 1]

    # ---- rule (i): the third pair --------------------------------------------------------------
    def _add_third(self, G: _Batch, par: IntArray, lmk: IntArray, beta: float) -> _Batch | None:
        self.count.triples += int(par.size)
        anchor = G.anchor[par]
        a, b, S, T = self._sums_with_pair(G, par, lmk, beta)
        fx, fy, det = _solve_f(S, T)
        # Rule (i): the pose exists -- S invertible, both distance ratios positive, f finite.
        a1, b1 = G.a1[par], G.b1[par]
        with np.errstate(divide="ignore", invalid="ignore"):
            r1 = (a1.real * (fx + b1.real) + a1.imag * (fy + b1.imag)) / np.abs(a1) ** 2
            r2 = (a.real * (fx + b.real) + a.imag * (fy + b.imag)) / np.abs(a) ** 2
        smax = np.maximum(1.0, np.abs(S).max(axis=1))
        ok = (np.abs(det) > SINGULAR_RTOL * smax * smax) & (r1 > 0) & (r2 > 0)
        pose, f2 = _pose_from_f(fx, fy, self.L[anchor], G.anchor_b[par])
        ok &= np.isfinite(f2) & (f2 > (1e-12 / self.scale) ** 2) & np.isfinite(pose).all(axis=1)
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
        opt = self.opt
        P = G.pose[par]
        Lc = self.L[lmk]
        dx = Lc[:, 0] - P[:, 0]
        dy = Lc[:, 1] - P[:, 1]
        pred = np.arctan2(dy, dx) - P[:, 2]
        innov = _wrap_fast(pred - beta)
        if opt.sigma is None:
            ok = np.abs(innov) <= opt.threshold
        else:
            ok = self._sigma_gate(G, par, dx, dy, innov)
        self.count.gate += int((~ok).sum())
        if opt.max_range is not None or opt.min_range is not None:
            r2 = dx * dx + dy * dy
            vis = np.ones_like(ok)
            if opt.reach_max is not None:
                vis &= r2 <= opt.reach_max**2
            if opt.reach_min is not None:
                vis &= r2 >= opt.reach_min**2
            self.count.visibility += int((ok & ~vis).sum())
            ok &= vis
        if opt.ordering and ok.any():
            sel = np.flatnonzero(ok)
            good = self._order_ok_candidate(G, par[sel], np.asarray(wrap(pred[sel])), beta)
            self.count.ordering += int((~good).sum())
            ok[sel[~good]] = False
        keep = np.flatnonzero(ok)
        if keep.size == 0:
            return None
        par, lmk = par[keep], lmk[keep]
        # A validated node re-estimates the pose from all its pairs (eq. 4 over the path).
        _, _, S, T = self._sums_with_pair(G, par, lmk, beta)
        fx, fy, det = _solve_f(S, T)
        pose, f2 = _pose_from_f(fx, fy, self.L[G.anchor[par]], G.anchor_b[par])
        C = G.take(par)
        C.assign = C.assign.copy()
        C.assign[:, G.level] = lmk
        C.S, C.T = S, T
        # Where the re-estimate is not a valid pose by eqs. 1-6 (a singular sum, a distance
        # ratio <= 0, a robot at infinity), the path keeps its previous pose.
        valid = self._valid_estimate(C, fx, fy, det, f2, S)
        C.pose = np.where(valid[:, None], pose, G.pose[par])
        C.nmatch = C.nmatch + 1
        C.level = G.level + 1
        if opt.sigma is not None:
            C.pose = self._refine(C)
        if opt.ordering:
            good = self._order_ok_path(C)
            self.count.ordering += int((~good).sum())
            if not good.all():
                C = C.take(np.flatnonzero(good))
        return C

    def _valid_estimate(
        self,
        C: _Batch,
        fx: FloatArray,
        fy: FloatArray,
        det: FloatArray,
        f2: FloatArray,
        S: FloatArray,
    ) -> NDArray[np.bool_]:
        """Whether eq. 4 over a path's pairs gives a pose, by the tests of estimate_pose."""
        smax = np.maximum(1.0, np.abs(S).max(axis=1))
        ok = np.abs(det) > SINGULAR_RTOL * smax * smax
        ok &= np.isfinite(f2) & (f2 > (1e-12 / self.scale) ** 2)
        Lm, bm, w = self._matched(C)
        L0 = self.L[C.anchor]
        z = (Lm[..., 0] - L0[:, None, 0]) + 1j * (Lm[..., 1] - L0[:, None, 1])
        pair = (w > 0) & (C.assign[:, : C.level] != C.anchor[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):
            b = 1.0 / z
            a = np.exp(1j * (bm - C.anchor_b[:, None])) * b
            r = (a.real * (fx[:, None] + b.real) + a.imag * (fy[:, None] + b.imag)) / (
                a.real * a.real + a.imag * a.imag
            )
        ok &= ((r > 0) | ~pair).all(axis=1)
        return np.asarray(ok)

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
        return _gauss_newton(Lm, bm, w, C.pose, iters=2)[0]

    def _sigma_gate(
        self, G: _Batch, par: IntArray, dx: FloatArray, dy: FloatArray, innov: FloatArray
    ) -> NDArray[np.bool_]:
        """Chi-square gate: innov^2 <= chi2 (g^T Cov(pose) g + sigma^2).

        Most candidates are far outside any gate, so they are first tested against an upper
        bound of the variance (trace(Cov) |g|^2 >= g^T Cov g), and the exact quadratic form
        is only evaluated for the few that pass it.
        """
        sig = self.opt.sigma
        assert sig is not None
        chi2 = self.opt.gate_chi2
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
        """Covariance of each path's pose from its matched pairs, sigma^2 (G^T G)^-1."""
        sig = self.opt.sigma
        assert sig is not None
        Lm, _, w = self._matched(G)
        _, g = _bearing_jacobian(Lm, G.pose)
        gw = g * w[..., None]
        J = np.einsum("kni,knj->kij", gw, gw)  # information times sigma^2
        # A floor on the information: a near-singular geometry (the robot near the circle
        # through three landmarks) gives a huge variance, which admits rather than rejects.
        J = J + 1e-9 * np.eye(3)
        return np.asarray(np.linalg.inv(J) * sig * sig)

    def _order_ok_candidate(
        self, G: _Batch, par: IntArray, pred: FloatArray, beta: float
    ) -> NDArray[np.bool_]:
        """Ordering: the candidate's predicted bearing falls between the same matched
        neighbours, around the pose, as the measured bearing does among the measured ones."""
        Lm, bm, w = self._matched(G)
        P = G.pose
        predm = np.arctan2(Lm[..., 1] - P[:, None, 1], Lm[..., 0] - P[:, None, 0]) - P[:, None, 2]
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
        """Ordering over a whole path at its re-estimated pose: the matched landmarks go round
        the pose in the measured cyclic order (one turn exactly), where a step back smaller
        than the noise tolerance counts as no step (such bearings may swap under noise)."""
        Lm, bm, w = self._matched(C)
        P = C.pose
        predm = np.arctan2(Lm[..., 1] - P[:, None, 1], Lm[..., 0] - P[:, None, 0]) - P[:, None, 2]
        key = np.where(w > 0, np.mod(bm, TWO_PI), np.inf)
        idx = np.argsort(key, axis=1, kind="stable")
        ps = np.take_along_axis(predm, idx, axis=1)
        ws = np.take_along_axis(w, idx, axis=1)
        n = ws.sum(axis=1).astype(np.int64)
        turns = np.zeros(len(C))
        for k in np.unique(n):
            rows = np.flatnonzero(n == k)
            seq = ps[rows, :k]
            steps = np.mod(np.diff(np.concatenate([seq, seq[:, :1]], axis=1), axis=1), TWO_PI)
            steps = np.where(steps > TWO_PI - self.order_tol, steps - TWO_PI, steps)
            turns[rows] = steps.sum(axis=1)
        return np.asarray(np.abs(turns - TWO_PI) < 1e-6)

    def _visible_path(self, C: _Batch) -> _Batch | None:
        """Range limits on a fresh triple: the pose must see its three landmarks in range."""
        opt = self.opt
        if opt.max_range is None and opt.min_range is None:
            return C
        Lm, _, w = self._matched(C)
        d2 = ((Lm - C.pose[:, None, :2]) ** 2).sum(axis=2)
        ok = np.ones(len(C), dtype=bool)
        if opt.reach_max is not None:
            ok &= ((d2 <= opt.reach_max**2) | (w == 0)).all(axis=1)
        if opt.reach_min is not None:
            ok &= ((d2 >= opt.reach_min**2) | (w == 0)).all(axis=1)
        self.count.visibility += int((~ok).sum())
        return C.take(np.flatnonzero(ok)) if not ok.all() else C


# --------------------------------------------------------------------------------------------
# Observation order
# --------------------------------------------------------------------------------------------


def _robust_order(bearings: FloatArray) -> IntArray:
    """Observation order that prunes early: the widest-spread triple first.

    Three bearings spread round the robot fix the pose best (their pose has the smallest
    covariance), so the depth > 3 gates are tightest. The rest follow in the order given.
    """
    m = bearings.shape[0]
    if m <= 3:
        return np.arange(m)
    if _compiled.AVAILABLE:
        best = list(_compiled.widest_triple(np.require(bearings[:12], np.float64, ["C", "W"])))
    else:
        triples = _TRIPLES[min(m, 12)]
        widest = int(np.argmax(_seeds.gaps(bearings, triples).min(axis=1)))  # the first one
        best = [int(i) for i in triples[widest]]
    return np.array(best + [o for o in range(m) if o not in best], dtype=np.int64)


_TRIPLES = {
    n: np.array(list(itertools.combinations(range(n), 3)), dtype=np.int64) for n in range(3, 13)
}


# --------------------------------------------------------------------------------------------
# Solutions: refinement, ranking, merging
# --------------------------------------------------------------------------------------------


def _finish(s: _Search, bearings: FloatArray, opt: _Options) -> tuple[list[Solution], bool]:
    if not s.leaves:
        return [], False
    leaves = _concat(s.m, s.leaves) if len(s.leaves) > 1 else s.leaves[0]
    if len(leaves) > MAX_LEAVES:
        # Pathological inputs (huge gates, tiny maps) can leave very many paths; only the best
        # MAX_LEAVES by matches and fit are refined, merged and returned.
        sse0 = s.leaf_sse(leaves)
        leaves = leaves.take(np.lexsort((sse0, -leaves.nmatch))[:MAX_LEAVES])
    m = s.m
    # Back from level order to observation order.
    assign = np.full((len(leaves), m), -1, dtype=np.int64)
    assign[:, s.order] = leaves.assign
    w = (assign >= 0).astype(np.float64)
    Lm = s.L[np.maximum(assign, 0)]
    bm = np.broadcast_to(bearings, assign.shape)
    poses, sse = _gauss_newton(Lm, np.ascontiguousarray(bm), w, leaves.pose, iters=10)
    nmatch = w.sum(axis=1).astype(np.int64)
    # A pose on one of its own landmarks has no bearing to it (atan2(0, 0) = 0 can pass a gate
    # by accident on a grid map): not a pose.
    gap2 = ((Lm - poses[:, None, :2]) ** 2).sum(axis=2)
    joint = ((gap2 > (1e-9 * s.scale) ** 2) | (w == 0)).all(axis=1)
    if opt.sigma is not None:
        # Joint compatibility (JCBB): each pairing passed its own gate, but all of them
        # together must also fit one pose: sse / sigma^2 ~ chi-square with n - 3 dof.
        joint &= sse / opt.sigma**2 <= opt.joint_chi2[nmatch]
    if not joint.any():
        return [], False
    if not joint.all():
        keep_j = np.flatnonzero(joint)
        assign, w, Lm, poses, sse, nmatch = (
            assign[keep_j],
            w[keep_j],
            Lm[keep_j],
            poses[keep_j],
            sse[keep_j],
            nmatch[keep_j],
        )
    rms = np.sqrt(sse / nmatch)
    sig = opt.sigma_eff
    # Covariance at the refined pose: sigma^2 (G^T G)^-1 over the matched pairs.
    if _compiled.AVAILABLE:
        cov = _compiled.covariances(
            np.require(Lm, np.float64, ["C", "W"]),
            np.require(w, np.float64, ["C", "W"]),
            np.require(poses, np.float64, ["C", "W"]),
            sig * sig,
        )
    else:
        _, g = _bearing_jacobian(Lm, poses)
        gw = g * w[..., None]
        H = np.einsum("kni,knj->kij", gw, gw) + 1e-12 * np.eye(3)
        cov = np.linalg.inv(H) * sig * sig
    # Cost: Gaussian bearing residuals, plus clutter for each spurious observation (uniform on
    # the circle against the matched bearing's density), plus missed landmarks.
    spur = max(0.5 * math.log(TWO_PI) - math.log(sig), 0.0)  # ln(density ratio) at the peak
    cost = 0.5 * sse / (sig * sig) + (m - nmatch) * spur
    missed = np.zeros(len(poses), dtype=np.int64)
    if opt.p_miss is not None:
        missed = _missed(s, poses, assign, bearings, opt)
        cost = cost + missed * -math.log(opt.p_miss) + nmatch * -math.log1p(-opt.p_miss)
    if opt.p_miss is None:
        rank = np.lexsort((cost, -nmatch))
    else:
        # With negative evidence a match is no longer worth more than any number of landmarks
        # left unseen: the whole cost ranks (a pose that explains one more bearing but should
        # have seen eight more landmarks is worse than one that explains all it should see).
        rank = np.lexsort((-nmatch, cost))
    keep = _merge(rank, poses, cov) if opt.merge else [int(i) for i in rank]
    c = cost[keep]
    lik = np.exp(-(c - c.min()))
    conf = lik / lik.sum()
    sols = [
        Solution(
            pose=Pose.from_array(poses[i]),
            assignment=tuple(int(v) if v >= 0 else None for v in assign[i]),
            residual_rms=float(rms[i]),
            matched=int(nmatch[i]),
            covariance=cov[i],
            cost=float(cost[i]),
            confidence=float(cf),
            missed=int(missed[i]),
        )
        for i, cf in zip(keep, conf, strict=True)
    ]
    top = sols[0]
    rivals = any(
        (t.matched == top.matched or opt.p_miss is not None)
        and t.confidence >= 0.01 * top.confidence
        and not _same_pose(t.pose.as_array(), t.covariance, top.pose.as_array(), top.covariance)
        for t in sols[1:]
    )
    return sols, rivals


#: Two solutions are "the same pose" when each lies within one standard deviation (Mahalanobis
#: distance 1) of the other: equivalent assignments (a spurious bearing that also matches a
#: landmark, two landmarks on one ray) land far closer than that, while distinct nearby poses
#: (tubes of one cluster swapped) stay apart so that the true one is not hidden behind another.
SAME_POSE_CHI2 = 1.0


def _regularised(cov: FloatArray) -> FloatArray:
    """(K, 3, 3) covariances nudged so that exact fits stay invertible."""
    scale = np.maximum(np.abs(cov).max(axis=(1, 2)), 1e-300)
    return np.asarray(cov + (1e-12 * scale + 1e-24)[:, None, None] * np.eye(3))


def _inv_cov(cov: FloatArray) -> FloatArray:
    """Inverses of (K, 3, 3) covariances, regularised so that exact fits stay finite."""
    return np.asarray(np.linalg.inv(_regularised(cov)))


def _pose_gaps(p: FloatArray, q: FloatArray) -> FloatArray:
    d = q - p
    d[..., 2] = np.asarray(wrap(d[..., 2]))
    return d


def _merge(rank: IntArray, poses: FloatArray, cov: FloatArray) -> list[int]:
    """Greedy merge in rank order: a solution indistinguishable from a better one (inside
    the confidence ellipsoid of each, or within a micrometre) is dropped."""
    if len(rank) == 1:
        return [int(rank[0])]
    reg = _regularised(cov)
    inv = np.asarray(np.linalg.inv(reg))
    if _compiled.AVAILABLE:
        # d^T C^-1 d >= |d|^2 / lambda_max(C) >= |d|^2 / trace(C): beyond that reach no merge
        # is possible. (A covariance that is not finite gives no reach and is left to the
        # quadratic forms, as below.)
        with np.errstate(invalid="ignore", over="ignore"):
            reach2 = SAME_POSE_CHI2 * np.trace(reg, axis1=1, axis2=2) * (1.0 + 1e-9)
        kept = _compiled.merge(
            np.ascontiguousarray(rank, dtype=np.int64),
            np.ascontiguousarray(poses),
            np.ascontiguousarray(inv),
            reach2,
            SAME_POSE_CHI2,
        )
        return [int(i) for i in kept]
    keep: list[int] = []
    for i in rank:
        if keep:
            k = np.asarray(keep)
            d = _pose_gaps(poses[i], poses[k])
            tiny = (np.abs(d[:, :2]).max(axis=1) < 1e-6) & (np.abs(d[:, 2]) < 1e-6)
            m_k = np.einsum("ki,kij,kj->k", d, inv[k], d)
            m_i = np.einsum("ki,ij,kj->k", d, inv[i], d)
            if (tiny | (np.maximum(m_k, m_i) <= SAME_POSE_CHI2)).any():
                continue
        keep.append(int(i))
    return keep


def _same_pose(p: FloatArray, cp: FloatArray, q: FloatArray, cq: FloatArray) -> bool:
    """Two poses indistinguishable at the uncertainty of each (see SAME_POSE_CHI2).

    Both must lie inside the other's confidence ellipsoid: a vague solution cannot swallow a
    precise one that happens to fall inside its own wide ellipsoid.
    """
    d = _pose_gaps(p, q)
    if np.abs(d[:2]).max() < 1e-6 and abs(d[2]) < 1e-6:
        return True
    inv = _inv_cov(np.stack([cp, cq]))
    return max(float(d @ inv[0] @ d), float(d @ inv[1] @ d)) <= SAME_POSE_CHI2


#: _missed works on all poses x all landmarks at once up to this many pairs (scene b: 30
#: landmarks x a few hundred poses), else pose by pose on the landmarks within range.
MISSED_DENSE = 200_000
#: ... and, with a range, only on maps up to this size: beyond, the k-d tree's few landmarks
#: in range beat every landmark of the map (4 ms per pose at 10,000 landmarks).
MISSED_DENSE_MAP = 256


def _missed(
    s: _Search, poses: FloatArray, assign: IntArray, bearings: FloatArray, opt: _Options
) -> IntArray:
    """Landmarks plainly visible from each pose but not observed (negative evidence)."""
    small = opt.max_range is None or s.N <= MISSED_DENSE_MAP
    if small and len(poses) * s.N <= MISSED_DENSE:
        cand = np.broadcast_to(np.arange(s.N), (len(poses), s.N))
        return _missed_among(s, poses, assign, cand, bearings, opt)
    out = np.zeros(len(poses), dtype=np.int64)
    for k, p in enumerate(poses):
        if opt.max_range is not None:
            near = np.asarray(s.lm.kdtree.query_ball_point(p[:2], 0.95 * opt.max_range))
            near = near.astype(np.int64)
        else:
            near = np.arange(s.N)
        if near.size:
            out[k] = _missed_among(s, p[None], assign[k : k + 1], near[None], bearings, opt)[0]
    return out


def _missed_among(
    s: _Search,
    poses: FloatArray,
    assign: IntArray,
    cand: IntArray,
    bearings: FloatArray,
    opt: _Options,
) -> IntArray:
    """For each pose k, how many of the landmarks ``cand[k]`` it should
    plainly see -- within 0.95 max_range and beyond 1.05 min_range, inside the field of view
    by a margin, away from every reported bearing (not hidden behind one) -- but did not match."""
    margin = 3.0 * opt.sigma_eff
    vis = ~(cand[:, :, None] == assign[:, None, :]).any(axis=2)
    d = s.L[cand] - poses[:, None, :2]
    r2 = d[..., 0] ** 2 + d[..., 1] ** 2
    if opt.max_range is not None:
        vis &= r2 <= (0.95 * opt.max_range) ** 2
    if opt.min_range is not None:
        vis &= r2 >= (1.05 * opt.min_range) ** 2
    pred = np.asarray(wrap(np.arctan2(d[..., 1], d[..., 0]) - poses[:, 2:3]))
    if opt.half_fov is not None:
        vis &= np.abs(pred) <= opt.half_fov - margin
    if bearings.size:
        sep = np.abs(np.asarray(wrap(pred[..., None] - bearings)))
        vis &= sep.min(axis=2) > 2.0 * margin
    return np.asarray(vis.sum(axis=1), dtype=np.int64)


# --------------------------------------------------------------------------------------------
# Public entry point
# --------------------------------------------------------------------------------------------


def _choose_strategy(
    strategy: Strategy | str, meth: Method, opt: _Options, exhaustive: bool
) -> str:
    """ "tree", "hypotheses" or "first" (hypotheses, stopping at the first fit)."""
    try:
        strategy = Strategy(strategy).value
    except ValueError as exc:
        raise InputError(
            f"strategy must be one of {[s.value for s in Strategy]}, got {strategy!r}"
        ) from exc
    if not isinstance(exhaustive, (bool, np.bool_)):
        raise InputError(f"exhaustive must be True or False, got {exhaustive!r}")
    if meth is Method.PAPER:
        if strategy == "hypotheses" or not exhaustive:
            raise InputError(
                "method='paper' walks the paper's tree exhaustively; "
                "strategy='hypotheses' and exhaustive=False need method='robust'"
            )
        return "tree"
    if strategy == "auto":
        paper_rules = (
            opt.sigma is None
            and opt.max_wild == 0
            and not opt.ordering
            and opt.max_range is None
            and opt.min_range is None
        )
        if exhaustive and (paper_rules or not _compiled.AVAILABLE):
            return "tree"
        strategy = "hypotheses"
    if strategy == "tree":
        if not exhaustive:
            raise InputError("exhaustive=False needs strategy='hypotheses' (or 'auto')")
        return "tree"
    return "hypotheses" if exhaustive else "first"


def localize(
    landmarks: LandmarkMap | ArrayLike,
    bearings: ArrayLike,
    *,
    threshold: float = float(np.deg2rad(1.0)),
    method: Method | str = Method.ROBUST,
    sigma: float | None = None,
    confidence: float = 0.99,
    max_spurious: int | float = 0,
    ordering: bool = False,
    max_range: float | None = None,
    min_range: float | None = None,
    fov: float | None = None,
    p_miss: float | None = None,
    max_nodes: int | None = None,
    timeout_s: float | None = None,
    strategy: Strategy | str = Strategy.AUTO,
    exhaustive: bool = True,
) -> LocalizationResult:
    """Find where the robot is, and which landmark each bearing is, from bearings alone.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
        The known map, metres.
    bearings : array_like, shape (m,)
        Measured bearings in the robot frame, radians, counter-clockwise from forward.
        3 <= m <= N (at most N + max_spurious with wildcards).
    threshold : float, default 1 degree
        Rule (ii): largest accepted ``|predicted - measured|`` bearing, radians. Used when
        ``sigma`` is not given.
    method : {"robust", "paper"}
        ``"paper"`` is the published algorithm to the letter (see :class:`Method`).
    sigma : float, optional
        Bearing noise standard deviation, radians. Replaces the fixed threshold with a
        chi-square gate on the innovation at ``confidence``, using the predicted bearing's
        variance (pose covariance propagated through the bearing function, plus sigma^2).
    confidence : float, default 0.99
        Confidence level of the chi-square gate.
    max_spurious : int or float, default 0
        How many bearings may be spurious (not on the map): an int, or a fraction of m.
        Unmatched observations appear as None in :attr:`Solution.assignment`.
    ordering : bool, default False
        Prune paths whose landmarks go round the hypothesised pose in another cyclic order
        than the measured bearings (the paper's future work).
    max_range, min_range : float, optional
        Sensor range limits, metres: prune, and with a large map restrict candidates to the
        landmarks near the pose with a k-d tree.
    fov : float, optional
        Full field of view in radians for non-omnidirectional sensors (e.g. 65 degrees).
    p_miss : float, optional
        Probability that a plainly visible landmark is not detected. When given, every such
        landmark costs a solution ``-log(p_miss)`` (negative evidence).
    max_nodes, timeout_s : optional
        Budget. Past it the search stops and returns what it has; ``result.complete`` is then
        False. Where the compiled walk runs (fixed threshold, no robust option), ``timeout_s``
        is enforced as a budget of :data:`COMPILED_NODES_PER_SECOND` nodes per second (in
        the hypotheses search, of :data:`HYPOTHESIS_WORK_PER_SECOND` units of work: the kernel
        cannot read the clock, so the time it stops at is approximate: within 0.8-1.5x of
        ``timeout_s`` on the scenes measured).
    strategy : Strategy or {"auto", "tree", "hypotheses"}
        How the robust search runs. ``"tree"`` walks the interpretation tree with wildcard
        branches (the reference). ``"hypotheses"`` (compiled) starts a hypothesis from every
        landmark triple that can be seen together, for a few seed triples of bearings that
        together avoid every possible set of ``max_spurious`` spurious bearings, and
        verifies it on the other bearings (each matched to its best landmark inside the
        gate); it finds the same interpretations far faster when there are wildcards, a
        chi-square gate or a large map. ``"auto"`` uses the compiled paper tree where the
        paper's rules alone apply, ``"hypotheses"`` for the robust options when numba is
        installed, and the tree otherwise. ``method="paper"`` always walks the tree.
    exhaustive : bool, default True
        False stops at the first interpretation that explains ``m - max_spurious`` bearings
        (and passes the joint test with ``sigma``): much faster on large maps, where a wrong
        interpretation of that many bearings is practically impossible, but rival
        interpretations are not sought, so ``ambiguous`` cannot be trusted
        (``stats.exhaustive`` is then False). With ``p_miss``, a first fit must also leave
        no more plainly visible landmarks unseen than the median of Binomial(m, p_miss)
        (a true interpretation with more misses does not stop the search, which then runs
        on and still finds it). Needs the hypotheses strategy.

    Returns
    -------
    LocalizationResult
        Falsy when no interpretation is consistent.

    Raises
    ------
    InputError
        Malformed map or bearings, or options out of range.

    References
    ----------
    Lee & Chung, section 3 (rules i and ii); Grimson (1990) for the wildcard branch.

    Examples
    --------
    >>> from omniloc.pose import Pose, predict_bearings
    >>> L = np.array([[0, 0], [6, 0], [6, 4], [0, 4], [3, 7], [-2, 2]], dtype=float)
    >>> z = predict_bearings(L[[1, 4, 0, 2]], Pose(2.0, 1.5, 0.4))
    >>> result = localize(L, z)
    >>> result.best.assignment
    (1, 4, 0, 2)
    >>> round(result.best.pose.x, 6), round(result.best.pose.y, 6)
    (2.0, 1.5)
    """
    t0 = time.perf_counter()
    lm = as_landmark_map(landmarks)
    try:
        meth = Method(method)
    except ValueError as exc:
        raise InputError(
            f"method must be one of {[m.value for m in Method]}, got {method!r}"
        ) from exc
    b = check_bearings(bearings, n_landmarks=None, min_count=3)
    m = int(b.shape[0])
    opt = _make_options(
        m,
        method=meth,
        threshold=threshold,
        sigma=sigma,
        confidence=confidence,
        max_spurious=max_spurious,
        ordering=ordering,
        max_range=max_range,
        min_range=min_range,
        fov=fov,
        p_miss=p_miss,
        max_nodes=max_nodes,
        timeout_s=timeout_s,
    )
    if opt.min_match > lm.n:
        raise InputError(
            f"{m} bearings but the map has only {lm.n} landmarks"
            + (f" (with max_spurious={opt.max_wild})" if opt.max_wild else "")
        )
    unbounded = opt.max_range is None and opt.max_nodes is None and opt.timeout_s is None
    if lm.n > LARGE_MAP and unbounded:
        log.warning(
            "localize: %d landmarks without max_range or a budget: the tree holds about %.1e "
            "landmark triples per seed and may run for a very long time; pass max_range, "
            "timeout_s or max_nodes",
            lm.n,
            float(lm.n) ** 3,
        )
    strat = _choose_strategy(strategy, meth, opt, exhaustive)
    if meth is Method.PAPER or strat != "tree":
        order = np.arange(m)
    else:
        order = _robust_order(b)
    s = _Search(lm, b, order, opt, strat)
    s.run()
    solutions, ambiguous = _finish(s, b, opt)
    c = s.count
    stats = SearchStats(
        total_paths=math.perm(lm.n, m) if m <= lm.n else 0,
        examined_paths=c.examined,
        nodes=c.nodes,
        elapsed_s=time.perf_counter() - t0,
        triples_solved=c.triples,
        pruned_existence=c.existence,
        pruned_gate=c.gate,
        pruned_ordering=c.ordering,
        pruned_visibility=c.visibility,
        pruned_bound=c.bound,
        complete=s.complete,
        exhaustive=s.exhaustive,
    )
    return LocalizationResult(solutions, stats, lm, ambiguous)
