"""Baselines that omniloc's interpretation tree is measured against.

* :func:`brute_force` -- every one of the N! / (N - m)! complete paths, pose from its first
  three pairs by the paper's method (eqs. 1-6), every other bearing checked against the
  threshold. Vectorised with numpy; refuses trees above ``max_paths`` (2e6 by default).
* :func:`ransac` -- random hypotheses: 3 observations and 3 distinct landmarks drawn at random,
  the pose solved from them (eqs. 1-6), the observations that some landmark explains within a
  gate counted as inliers (MSAC score), best kept; a fixed number of iterations or adaptive
  stopping at a confidence. The winner is refined on its inliers.
* :func:`triple_poses` -- eqs. (1)-(6) for many 3-pair problems at once, with the same
  existence checks as :func:`omniloc.pose.estimate_pose` (the tests compare the two).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from omniloc.angles import wrap
from omniloc.pose import Pose, poses_from_pairs, refine_pose

__all__ = ["RansacResult", "brute_force", "permutations", "ransac", "triple_poses"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def triple_poses(L: ArrayLike, b: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The paper's linear pose (eqs. 1-6) for K problems of 3 pairs each, by omniloc's own
    :func:`omniloc.pose.poses_from_pairs` (the baselines share its maths, not a copy).

    Parameters
    ----------
    L : array_like, shape (K, 3, 2)
        Landmarks of each problem, metres; pair 0 is the reference ``L_0``.
    b : array_like, shape (K, 3)
        Their bearings, radians.

    Returns
    -------
    poses : ndarray, shape (K, 3)
        ``(x, y, theta)``; meaningless where ``ok`` is False.
    ok : ndarray of bool, shape (K,)
        False where :func:`omniloc.pose.estimate_pose` would raise
        ``DegenerateGeometryError`` (coincident landmarks, singular sum of ``P_i``, a distance
        ratio ``r_i <= 0``, robot at infinity).
    """
    L = np.asarray(L, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    poses, ok, _ = poses_from_pairs(L, b)
    # estimate_pose also refuses two coincident landmarks that are not the reference.
    scale = np.abs(L - L.mean(axis=1, keepdims=True)).max(axis=(1, 2))
    scale = np.where(scale > 0, scale, 1.0)
    ok &= np.abs(L[:, 2] - L[:, 1]).max(axis=1) > 1e-12 * scale
    return poses, ok & np.isfinite(poses).all(axis=1)


def permutations(n: int, m: int) -> IntArray:
    """All ordered selections of m distinct indices out of n, shape (n! / (n - m)!, m),
    in lexicographic order."""
    out = np.arange(n, dtype=np.int64)[:, None]
    for _ in range(1, m):
        k = out.shape[0]
        rows = np.repeat(np.arange(k), n)
        cand = np.tile(np.arange(n, dtype=np.int64), k)
        keep = ~(out[rows] == cand[:, None]).any(axis=1)
        out = np.concatenate([out[rows[keep]], cand[keep, None]], axis=1)
    return out


def brute_force(
    landmarks_xy: ArrayLike,
    bearings: ArrayLike,
    threshold: float,
    *,
    max_paths: int = 2_000_000,
    chunk: int = 1 << 18,
) -> tuple[list[tuple[tuple[int, ...], Pose]], dict[str, Any]]:
    """Check every complete path of the interpretation tree.

    Each path's pose comes from its first three pairs (eqs. 1-6, computed once per ordered
    triple); the path is consistent when every other bearing is within ``threshold`` of its
    landmark's predicted bearing.

    Returns
    -------
    solutions : list of (assignment, Pose)
        The consistent paths, by increasing RMS bearing residual, with the 3-pair pose.
    stats : dict
        ``total_paths``, ``checked_paths``, ``elapsed_s``.

    Raises
    ------
    ValueError
        More than ``max_paths`` paths.
    """
    t_start = time.perf_counter()
    L = np.asarray(landmarks_xy, dtype=np.float64)
    b = np.asarray(bearings, dtype=np.float64)
    n, m = L.shape[0], b.shape[0]
    total = math.perm(n, m)
    if total > max_paths:
        raise ValueError(f"{total} paths is more than max_paths={max_paths}")
    trip = permutations(n, 3)
    tpose, tok = triple_poses(L[trip], np.broadcast_to(b[:3], (trip.shape[0], 3)))
    tindex = np.full((n, n, n), -1, dtype=np.int64)
    tindex[trip[:, 0], trip[:, 1], trip[:, 2]] = np.arange(trip.shape[0])
    paths = permutations(n, m)
    sols: list[tuple[tuple[int, ...], Pose, float]] = []
    for s in range(0, paths.shape[0], chunk):
        P = paths[s : s + chunk]
        ti = tindex[P[:, 0], P[:, 1], P[:, 2]]
        good = tok[ti]
        pose = tpose[ti]
        Lr = L[P[:, 3:]]
        pred = np.arctan2(Lr[..., 1] - pose[:, 1:2], Lr[..., 0] - pose[:, 0:1]) - pose[:, 2:3]
        res = np.asarray(wrap(pred - b[3:]))
        good &= (np.abs(res) <= threshold).all(axis=1)
        for k in np.flatnonzero(good):
            rms = float(np.sqrt(np.mean(res[k] ** 2))) if m > 3 else 0.0
            sols.append((tuple(int(v) for v in P[k]), Pose.from_array(pose[k]), rms))
    sols.sort(key=lambda t: t[2])
    stats = {
        "total_paths": total,
        "checked_paths": int(paths.shape[0]),
        "elapsed_s": time.perf_counter() - t_start,
    }
    return [(a, p) for a, p, _ in sols], stats


@dataclass(frozen=True)
class RansacResult:
    """Outcome of :func:`ransac`.

    Attributes
    ----------
    pose : Pose or None
        Best pose, refined on its inliers; None if no hypothesis had a pose.
    inliers : int
        Observations within the gate of some landmark at ``pose``.
    iterations : int
        Hypotheses drawn.
    elapsed_s : float
    """

    pose: Pose | None
    inliers: int
    iterations: int
    elapsed_s: float


def _score(
    L: FloatArray,
    b: FloatArray,
    poses: FloatArray,
    gate: float,
    tree: Any,
    max_range: float | None,
) -> tuple[FloatArray, IntArray, FloatArray, IntArray]:
    """MSAC cost, inlier count, best residual and nearest landmark of each observation."""
    K, m = poses.shape[0], b.shape[0]
    if tree is None:
        d = L[None, :, :] - poses[:, None, :2]
        pred = np.arctan2(d[..., 1], d[..., 0]) - poses[:, 2:3]  # (K, N)
        if max_range is not None:
            far = (d * d).sum(axis=2) > max_range**2
            pred = np.where(far, np.inf, pred)
        with np.errstate(invalid="ignore"):  # out of range: inf, replaced just below
            r = np.abs(np.asarray(wrap(pred[:, :, None] - b[None, None, :])))  # (K, N, m)
        if max_range is not None:
            r = np.where(np.isfinite(pred)[:, :, None], r, np.pi)
        near = r.argmin(axis=1)
        best = np.take_along_axis(r, near[:, None, :], axis=1)[:, 0, :]
    else:
        best = np.full((K, m), np.pi)
        near = np.zeros((K, m), dtype=np.int64)
        lists = tree.query_ball_point(poses[:, :2], max_range, return_sorted=False)
        for k, idx in enumerate(lists):
            if not idx:
                continue
            idx = np.asarray(idx, dtype=np.int64)
            d = L[idx] - poses[k, :2]
            pred = np.arctan2(d[:, 1], d[:, 0]) - poses[k, 2]
            r = np.abs(np.asarray(wrap(pred[:, None] - b[None, :])))
            j = r.argmin(axis=0)
            best[k] = r[j, np.arange(m)]
            near[k] = idx[j]
    inl = best <= gate
    cost = np.minimum(best, gate) ** 2
    return cost.sum(axis=1), inl.sum(axis=1), best, near


def ransac(
    landmarks_xy: ArrayLike,
    bearings: ArrayLike,
    *,
    gate: float,
    max_iter: int = 100_000,
    confidence: float | None = None,
    batch: int = 2048,
    max_range: float | None = None,
    timeout_s: float | None = None,
    rng: np.random.Generator | int | None = None,
) -> RansacResult:
    """RANSAC over triples: random 3 observations x 3 distinct landmarks -> pose -> inliers.

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
    bearings : array_like, shape (m,)
        Radians; some may be spurious.
    gate : float
        An observation is an inlier when some landmark's predicted bearing is within ``gate``
        radians of it.
    max_iter : int
        Hypotheses to draw at most.
    confidence : float, optional
        Adaptive stopping: stop once a correct hypothesis would have been drawn with this
        probability, given the best inlier count so far (inlier fraction ``w`` of the
        observations): ``P(good sample) = C(w m, 3) / C(m, 3) / (N (N-1) (N-2))``.
    batch : int
        Hypotheses scored at once.
    max_range : float, optional
        Only landmarks within this range of a hypothesis explain bearings (and with N > 2000
        they are found with a k-d tree).
    timeout_s : float, optional
        Wall-clock budget.
    rng : Generator, int or None
    """
    t0 = time.perf_counter()
    gen = np.random.default_rng(rng)
    L = np.asarray(landmarks_xy, dtype=np.float64)
    b = np.asarray(bearings, dtype=np.float64)
    n, m = L.shape[0], b.shape[0]
    tree = None
    if max_range is not None and n > 2000:
        from scipy.spatial import cKDTree

        tree = cKDTree(L)
    best_cost, best_pose, best_inl = np.inf, None, 0
    it = 0
    need = max_iter
    while it < min(max_iter, need):
        if timeout_s is not None and time.perf_counter() - t0 > timeout_s:
            break
        k = min(batch, min(max_iter, need) - it)
        it += k
        obs = np.argsort(gen.random((k, m)), axis=1)[:, :3]
        lmk = np.argsort(gen.random((k, n)), axis=1)[:, :3] if n <= 64 else _distinct3(gen, k, n)
        poses, ok = triple_poses(L[lmk], b[obs])
        if not ok.any():
            continue
        poses = poses[ok]
        cost, inl, _, _ = _score(L, b, poses, gate, tree, max_range)
        j = int(np.argmin(cost))
        if cost[j] < best_cost:
            best_cost, best_pose, best_inl = float(cost[j]), poses[j], int(inl[j])
            if confidence is not None and best_inl >= 3:
                p_obs = math.comb(best_inl, 3) / math.comb(m, 3)
                p_good = p_obs / (n * (n - 1) * (n - 2))
                need = math.ceil(math.log(1 - confidence) / math.log1p(-p_good))
    if best_pose is None:
        return RansacResult(None, 0, it, time.perf_counter() - t0)
    # Refine on the inliers (nearest landmark of each; each landmark used once).
    _, _, r, near = _score(L, b, best_pose[None], gate, tree, max_range)
    sel = np.flatnonzero(r[0] <= gate)
    _, first = np.unique(near[0, sel], return_index=True)
    sel = sel[np.sort(first)]
    pose = Pose.from_array(best_pose)
    if sel.size >= 3:
        try:
            pose, _ = refine_pose(L[near[0, sel]], b[sel], initial=best_pose)
        except ValueError:
            pass
    return RansacResult(pose, best_inl, it, time.perf_counter() - t0)


def _distinct3(gen: np.random.Generator, k: int, n: int) -> IntArray:
    """k rows of 3 distinct indices out of n (rejection of the rare collisions)."""
    out = gen.integers(0, n, size=(k, 3))
    while True:
        bad = (out[:, 0] == out[:, 1]) | (out[:, 0] == out[:, 2]) | (out[:, 1] == out[:, 2])
        if not bad.any():
            return out
        out[bad] = gen.integers(0, n, size=(int(bad.sum()), 3))
