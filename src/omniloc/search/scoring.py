"""From complete paths to solutions: refinement, the joint test, ranking, merging, ambiguity.

What :func:`finish` does with the complete paths an engine found, in order:

1. keeps at most MAX_LEAVES of them (the best by matches and fit);
2. refines each pose by Gauss-Newton on all its pairs and drops a pose that stands on one of
   its own landmarks; with ``sigma``, keeps the paths that pass the joint chi-square test on
   all their pairs (joint compatibility, as in JCBB);
3. computes each pose's covariance and its cost (negative log-likelihood: bearing residuals,
   spurious bearings, and, with ``p_detect``, plainly visible landmarks not observed);
4. ranks, merges solutions that are the same pose (inside each other's confidence ellipsoid),
   normalises the confidences and decides whether the answer is ambiguous.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .._kernels import geometry as geo
from .._kernels.merge import merge
from ..angles import TWO_PI, wrap
from ..maps import LandmarkMap
from ..pose import Pose
from .options import Leaves, SearchOptions
from .results import Solution
from .tree import map_scale, path_sse

__all__ = ["MAX_LEAVES", "SAME_POSE_CHI2", "finish", "same_pose"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: At most this many complete paths are refined and returned (the best by matches and fit).
#: Measured on MRCLAM set 6 (8 bearings, 3 of them robots, are explained 6 at a time by
#: ~1,800 interpretations of a clustered map, the true one only 5 at a time): true pose among
#: the solutions 87.9 % at 2,000, 90.0 % at 8,000, 90.1 % at 16,000 and 32,000.
MAX_LEAVES = 8000

#: Two solutions are "the same pose" when each lies within one standard deviation (Mahalanobis
#: distance 1) of the other: equivalent assignments (a spurious bearing that also matches a
#: landmark, two landmarks on one ray) land far closer than that, while distinct nearby poses
#: (tubes of one cluster swapped) stay apart so that the true one is not hidden behind another.
SAME_POSE_CHI2 = 1.0

#: Negative evidence works on all poses x all landmarks at once up to this many pairs (scene
#: b: 30 landmarks x a few hundred poses), else pose by pose on the landmarks within range ...
MISSED_DENSE = 200_000
#: ... and, with a range, only on maps up to this size: beyond, the k-d tree's few landmarks
#: in range beat every landmark of the map (4 ms per pose at 10,000 landmarks).
MISSED_DENSE_MAP = 256


def finish(
    lm: LandmarkMap, bearings: FloatArray, leaves: Leaves, opt: SearchOptions
) -> tuple[list[Solution], bool]:
    """Solutions, best first, from an engine's complete paths; and whether it is ambiguous."""
    level_assign, level_pose = leaves.arrays()
    if len(level_assign) == 0:
        return [], False
    m = leaves.m
    order = leaves.order
    if len(level_assign) > MAX_LEAVES:
        # Pathological inputs (huge gates, tiny maps) can leave very many paths; only the best
        # MAX_LEAVES by matches and fit are refined, merged and returned.
        sse0 = path_sse(lm.xy, bearings[order], level_assign, level_pose)
        nm = (level_assign >= 0).sum(axis=1)
        keep0 = np.lexsort((sse0, -nm))[:MAX_LEAVES]
        level_assign, level_pose = level_assign[keep0], level_pose[keep0]
    # Back from level order to observation order.
    assign = np.full((len(level_assign), m), -1, dtype=np.int64)
    assign[:, order] = level_assign
    w = (assign >= 0).astype(np.float64)
    Lm = lm.xy[np.maximum(assign, 0)]
    bm = np.ascontiguousarray(np.broadcast_to(bearings, assign.shape))
    poses, sse = geo.gauss_newton(
        np.require(Lm, np.float64, ["C", "W"]),
        bm,
        w,
        np.require(level_pose, np.float64, ["C", "W"]),
        10,
    )
    nmatch = w.sum(axis=1).astype(np.int64)
    s = opt.sensor
    # A pose on one of its own landmarks has no bearing to it (atan2(0, 0) = 0 can pass a gate
    # by accident on a grid map): not a pose.
    gap2 = ((Lm - poses[:, None, :2]) ** 2).sum(axis=2)
    joint = ((gap2 > (1e-9 * map_scale(lm)) ** 2) | (w == 0)).all(axis=1)
    if s.sigma is not None:
        # Joint compatibility (JCBB): each pairing passed its own gate, but all of them
        # together must also fit one pose: sse / sigma^2 ~ chi-square with n - 3 dof.
        joint &= sse / s.sigma**2 <= opt.joint_chi2[nmatch]
    if not joint.any():
        return [], False
    if not joint.all():
        k = np.flatnonzero(joint)
        assign, w, Lm, poses, sse, nmatch = assign[k], w[k], Lm[k], poses[k], sse[k], nmatch[k]
    rms = np.sqrt(sse / nmatch)
    sig = s.noise
    # Covariance at the refined pose: sigma^2 (G^T G)^-1 over the matched pairs.
    cov = geo.covariances(
        np.require(Lm, np.float64, ["C", "W"]),
        np.require(w, np.float64, ["C", "W"]),
        np.require(poses, np.float64, ["C", "W"]),
        sig * sig,
        geo.COVARIANCE_FLOOR,
    )
    # Cost: Gaussian bearing residuals, plus clutter for each spurious observation (uniform on
    # the circle against the matched bearing's density), plus missed landmarks.
    spur = max(0.5 * math.log(TWO_PI) - math.log(sig), 0.0)  # ln(density ratio) at the peak
    cost = 0.5 * sse / (sig * sig) + (m - nmatch) * spur
    missed = np.zeros(len(poses), dtype=np.int64)
    if s.p_detect is not None:
        missed = missed_landmarks(lm, poses, assign, bearings, opt)
        cost = cost + missed * -s.log_miss + nmatch * -math.log(s.p_detect)
        # With negative evidence a match is no longer worth more than any number of landmarks
        # left unseen: the whole cost ranks (a pose that explains one more bearing but should
        # have seen eight more landmarks is worse than one that explains all it should see).
        rank = np.lexsort((-nmatch, cost))
    else:
        rank = np.lexsort((cost, -nmatch))
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
        (t.matched == top.matched or s.p_detect is not None)
        and t.confidence >= 0.01 * top.confidence
        and not same_pose(t.pose.as_array(), t.covariance, top.pose.as_array(), top.covariance)
        for t in sols[1:]
    )
    return sols, rivals


def _regularised(cov: FloatArray) -> FloatArray:
    """(K, 3, 3) covariances nudged so that exact fits stay invertible."""
    scale = np.maximum(np.abs(cov).max(axis=(1, 2)), 1e-300)
    return np.asarray(cov + (1e-12 * scale + 1e-24)[:, None, None] * np.eye(3))


def _merge(rank: IntArray, poses: FloatArray, cov: FloatArray) -> list[int]:
    """Greedy merge in rank order (see :func:`omniloc._kernels.merge.merge`): a solution
    indistinguishable from a better one (inside the confidence ellipsoid of each, or within a
    micrometre) is dropped."""
    if len(rank) == 1:
        return [int(rank[0])]
    reg = _regularised(cov)
    inv = np.asarray(np.linalg.inv(reg))
    # d^T C^-1 d >= |d|^2 / lambda_max(C) >= |d|^2 / trace(C): beyond that reach no merge is
    # possible. (A covariance that is not finite gives no reach and is left to the forms.)
    with np.errstate(invalid="ignore", over="ignore"):
        reach2 = SAME_POSE_CHI2 * np.trace(reg, axis1=1, axis2=2) * (1.0 + 1e-9)
    kept = merge(
        np.ascontiguousarray(rank, dtype=np.int64),
        np.ascontiguousarray(poses),
        np.ascontiguousarray(inv),
        reach2,
        SAME_POSE_CHI2,
    )
    return [int(i) for i in kept]


def merge_numpy(rank: IntArray, poses: FloatArray, cov: FloatArray) -> list[int]:
    """:func:`_merge` read plainly, pair by pair (the compiled merge's test oracle)."""
    inv = np.asarray(np.linalg.inv(_regularised(cov)))
    keep: list[int] = []
    for i in rank:
        if keep:
            k = np.asarray(keep)
            d = poses[k] - poses[i]
            d[:, 2] = np.asarray(wrap(d[:, 2]))
            tiny = (np.abs(d[:, :2]).max(axis=1) < 1e-6) & (np.abs(d[:, 2]) < 1e-6)
            m_k = np.einsum("ki,kij,kj->k", d, inv[k], d)
            m_i = np.einsum("ki,ij,kj->k", d, inv[i], d)
            if (tiny | (np.maximum(m_k, m_i) <= SAME_POSE_CHI2)).any():
                continue
        keep.append(int(i))
    return keep


def same_pose(p: FloatArray, cp: FloatArray, q: FloatArray, cq: FloatArray) -> bool:
    """Two poses indistinguishable at the uncertainty of each (see SAME_POSE_CHI2).

    Both must lie inside the other's confidence ellipsoid: a vague solution cannot swallow a
    precise one that happens to fall inside its own wide ellipsoid.
    """
    d = q - p
    d[2] = float(wrap(d[2]))
    if np.abs(d[:2]).max() < 1e-6 and abs(d[2]) < 1e-6:
        return True
    inv = np.linalg.inv(_regularised(np.stack([cp, cq])))
    return max(float(d @ inv[0] @ d), float(d @ inv[1] @ d)) <= SAME_POSE_CHI2


def missed_landmarks(
    lm: LandmarkMap, poses: FloatArray, assign: IntArray, bearings: FloatArray, opt: SearchOptions
) -> IntArray:
    """For each pose, the landmarks it should plainly see (see
    :meth:`~omniloc.sensor.SensorModel.plainly_visible`) but did not match (negative
    evidence)."""
    s = opt.sensor
    small = s.max_range is None or lm.n <= MISSED_DENSE_MAP
    if small and len(poses) * lm.n <= MISSED_DENSE:
        cand = np.broadcast_to(np.arange(lm.n), (len(poses), lm.n))
        return _missed_among(lm, poses, assign, cand, bearings, opt)
    out = np.zeros(len(poses), dtype=np.int64)
    for k, p in enumerate(poses):
        if s.plain_max is not None:
            near = np.asarray(lm.kdtree.query_ball_point(p[:2], s.plain_max), dtype=np.int64)
        else:
            near = np.arange(lm.n)
        if near.size:
            out[k] = _missed_among(lm, p[None], assign[k : k + 1], near[None], bearings, opt)[0]
    return out


def _missed_among(
    lm: LandmarkMap,
    poses: FloatArray,
    assign: IntArray,
    cand: IntArray,
    bearings: FloatArray,
    opt: SearchOptions,
) -> IntArray:
    """For each pose k, how many of the landmarks ``cand[k]`` it should plainly see but did
    not match."""
    unmatched = ~(cand[:, :, None] == assign[:, None, :]).any(axis=2)
    plain = opt.sensor.plainly_visible(lm.xy[cand], poses, bearings)
    return np.asarray((unmatched & plain).sum(axis=1), dtype=np.int64)
