"""A set of pose hypotheses, each an extended Kalman filter: prediction and frame update.

:func:`predict` moves every hypothesis by one relative motion from the odometry;
:func:`update` takes in one frame of bearings: for each hypothesis it predicts the bearing of
every landmark and its variance (pose covariance through the bearing function, plus the
sensor's noise), gates, chooses the assignment of bearings to landmarks or to clutter that
maximises the frame's likelihood, updates the pose with an iterated EKF, and returns that
likelihood -- the weight the hypothesis earns from the frame.

The frame likelihood is :class:`~omniloc.sensor.SensorModel`'s (multiple-hypothesis tracking,
Reid 1979): a matched bearing ``ln p_detect - nu^2 / 2S - ln sqrt(2 pi S)`` with the
*predicted* innovation variance ``S`` (so a vague hypothesis pays for its vagueness), an
unmatched bearing the clutter density, a plainly visible landmark not seen ``ln(1 -
p_detect)``. It is reported as a log-likelihood ratio against "every bearing is clutter and
no landmark was there to be seen", the same baseline for every hypothesis.

All functions work on arrays of H hypotheses at once: poses ``(H, 3)`` and covariances
``(H, 3, 3)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._kernels import track as _kernels
from ..angles import wrap
from ..pose import bearing_jacobian
from ..sensor import SensorModel
from .motion import compose, compose_jacobians

__all__ = ["FrameEvidence", "Split", "predict", "split", "update"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: A landmark counts as missed by a hypothesis only when its predicted bearing lies inside
#: the field of view by this many standard deviations of the pose's share of the bearing
#: uncertainty (on top of the sensor's "plainly visible" margin): a vague hypothesis does not
#: know which landmarks it should see.
MISS_POSE_MARGIN = 2.0

#: Gauss-Newton steps of the iterated EKF update.
IEKF_ITERATIONS = 4


@dataclass(frozen=True)
class Split:
    """When and how finely a hypothesis too vague for its bearings is split.

    A hypothesis whose pose uncertainty alone spreads the predicted bearing of some
    landmark it may see by more than ``max_sd`` (radians) cannot associate reliably (the
    tubes of a cluster are a few degrees apart) nor be linearised well: it is replaced by
    a Gaussian mixture of up to ``max_children`` components along the direction that moves
    that bearing, spread over +-2.5 standard deviations, each ~``target_sd`` wide and
    weighted by the Gaussian it came from (a Gaussian-sum filter's split).
    """

    max_sd: float
    target_sd: float
    max_children: int = 15


@dataclass(frozen=True)
class FrameEvidence:
    """What one frame said about each hypothesis.

    Attributes
    ----------
    loglik : ndarray, shape (H,)
        Log-likelihood ratio of the frame under the hypothesis against "every bearing is
        clutter, no landmark plainly visible" (nats).
    assignment : ndarray of int, shape (H, m)
        Landmark row matched to each bearing, -1 for clutter.
    matched : ndarray of int, shape (H,)
        Bearings matched.
    plain : ndarray of int, shape (H,)
        Landmarks plainly visible from the predicted pose (matched or not).
    missed : ndarray of int, shape (H,)
        Of those, not matched.
    parent : ndarray of int, shape (H,)
        The input hypothesis each output hypothesis descends from (with branching, one
        input hypothesis may have several children: its rival assignments).
    """

    loglik: FloatArray
    assignment: IntArray
    matched: IntArray
    plain: IntArray
    missed: IntArray
    parent: IntArray


def predict(
    poses: FloatArray, covs: FloatArray, delta: FloatArray, Q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Move every hypothesis by ``delta`` (robot frame) with motion covariance ``Q``.

    ``P <- Jp P Jp^T + Jd Q Jd^T`` with the Jacobians of :func:`~.motion.compose`.
    """
    if poses.shape[0] == 0:
        return poses, covs
    Jp, Jd = compose_jacobians(poses, delta)
    new = compose(poses, delta)
    P = Jp @ covs @ np.swapaxes(Jp, -1, -2) + Jd @ Q @ np.swapaxes(Jd, -1, -2)
    return new, 0.5 * (P + np.swapaxes(P, -1, -2))


def split(
    poses: FloatArray,
    covs: FloatArray,
    landmarks_xy: FloatArray,
    sensor: SensorModel,
    rule: Split,
) -> tuple[FloatArray, FloatArray, IntArray, FloatArray]:
    """Split the hypotheses that are too vague for their bearings (see :class:`Split`).

    Returns
    -------
    poses, covs : ndarray
        The hypotheses after splitting (unsplit ones unchanged).
    parent : ndarray of int
        The input hypothesis of each.
    log_weight : ndarray
        ln of each component's share of its parent (0 for unsplit ones).
    """
    H = poses.shape[0]
    var = sensor.noise**2
    parent = np.arange(H)
    logw = np.zeros(H)
    if H == 0:
        return poses, covs, parent, logw
    _, pred, r2, S = _geometry(poses, covs, landmarks_xy, var)
    pose_var = np.maximum(S - var, 0.0)
    seen = np.ones_like(pose_var, dtype=bool)
    if sensor.reach_max is not None:
        seen &= r2 <= sensor.reach_max**2
    if sensor.half_fov is not None:
        seen &= np.abs(pred) <= sensor.half_fov + 3.0 * np.sqrt(pose_var)
    pv = np.where(seen, pose_var, 0.0)
    j = np.argmax(pv, axis=1)
    sd = np.sqrt(pv[np.arange(H), j])
    vague = np.flatnonzero(sd > rule.max_sd)
    if vague.size == 0:
        return poses, covs, parent, logw
    out_p = [poses[sd <= rule.max_sd]]
    out_c = [covs[sd <= rule.max_sd]]
    out_parent = [np.flatnonzero(sd <= rule.max_sd)]
    out_w = [np.zeros(out_parent[0].size)]
    L = landmarks_xy
    for h in vague:
        dx = L[j[h], 0] - poses[h, 0]
        dy = L[j[h], 1] - poses[h, 1]
        r = dx * dx + dy * dy
        g = np.array([dy / r, -dx / r, -1.0])
        Pg = covs[h] @ g
        gPg = float(g @ Pg)
        sig = math.sqrt(gPg)
        n = int(np.clip(math.ceil(5.0 * sig / (2.0 * rule.target_sd)), 3, rule.max_children))
        n += 1 - n % 2  # odd: one component stays at the mean
        step = 5.0 * sig / n
        s = min(0.5 * step * 1.2, 0.95 * sig)
        offs = (np.arange(n) - (n - 1) / 2) * step
        w = -0.5 * offs**2 / max(gPg - s * s, 1e-300)
        w = w - np.logaddexp.reduce(w)
        C = covs[h] - (1.0 - s * s / gPg) * np.outer(Pg, Pg) / gPg
        C = 0.5 * (C + C.T)
        out_p.append(poses[h] + offs[:, None] * (Pg / gPg)[None, :])
        out_c.append(np.repeat(C[None], n, axis=0))
        out_parent.append(np.full(n, h))
        out_w.append(w)
    new_p = np.concatenate(out_p)
    new_p[:, 2] = np.asarray(wrap(new_p[:, 2]))
    return new_p, np.concatenate(out_c), np.concatenate(out_parent), np.concatenate(out_w)


def _geometry(
    poses: FloatArray, covs: FloatArray, L: FloatArray, var: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Landmarks in each robot frame (H, N, 2), predicted bearings (H, N), squared ranges
    (H, N) and predicted bearing variances S (H, N)."""
    pred, g = bearing_jacobian(np.broadcast_to(L, (poses.shape[0], *L.shape)), poses)
    pred = np.asarray(wrap(pred))
    r2 = 1.0 / (g[..., 0] ** 2 + g[..., 1] ** 2)
    r = np.sqrt(r2)
    rel = np.stack([r * np.cos(pred), r * np.sin(pred)], axis=-1)
    # (max: a covariance a rounding error away from positive semi-definite stays usable)
    S = np.maximum(np.einsum("hni,hij,hnj->hn", g, covs, g), 0.0) + var
    return rel, pred, r2, S


def update(
    poses: FloatArray,
    covs: FloatArray,
    bearings: FloatArray,
    landmarks_xy: FloatArray,
    sensor: SensorModel,
    *,
    branches: int = 1,
    branch_margin: float = 0.0,
    split_rule: Split | None = None,
    clutter_log: FloatArray | None = None,
    prior_score: FloatArray | None = None,
    max_rows: int | None = None,
    collapse_chi2: float = 0.0,
    iterations: int = IEKF_ITERATIONS,
) -> tuple[FloatArray, FloatArray, FrameEvidence]:
    """Take one frame of bearings into every hypothesis.

    With ``branches > 1`` a hypothesis whose frame can be explained in several ways (a
    bearing between two tubes of a cluster, a clutter bearing next to a landmark) splits:
    each of its ``branches`` best assignments whose likelihood is within ``branch_margin``
    nats of its best becomes a child hypothesis (multiple-hypothesis tracking, Reid 1979);
    the evidence of later frames decides between them.

    Parameters
    ----------
    poses : ndarray, shape (H, 3)
        Predicted poses (metres, radians).
    covs : ndarray, shape (H, 3, 3)
        Their covariances.
    bearings : ndarray, shape (m,)
        The frame's bearings, radians, robot frame.
    landmarks_xy : ndarray, shape (N, 2)
        The map, metres.
    sensor : SensorModel
        Noise, gate, field of view, range, detection and clutter.
    branches : int
        Assignments kept per hypothesis (1: the best only).
    branch_margin : float
        Rival assignments this many nats worse than the best are dropped.
    split_rule : Split, optional
        Split hypotheses too vague for the association first (their components' log
        weights are part of ``loglik``).
    clutter_log : ndarray, shape (H, m), optional
        ln of the clutter density of each bearing for each hypothesis (per radian); by
        default the sensor's uniform one for all (:mod:`.clutter` makes remembered clutter
        objects likelier). ``loglik`` stays a ratio against the sensor's uniform clutter.
    prior_score : ndarray, shape (H,), optional
        The hypotheses' scores before this frame, to rank children by ...
    max_rows : int, optional
        ... when branching and splitting would make more than this many: only the best
        ``max_rows`` (by prior score + frame log-likelihood) are updated and returned.
    collapse_chi2 : float
        Children of one hypothesis that end up within this squared Mahalanobis distance
        of each other become one Gaussian (moment matching, their likelihoods summed: the
        joint probabilistic data association of their assignments); 0 keeps them apart.
    iterations : int
        Gauss-Newton steps of the iterated update.

    Returns
    -------
    poses, covs : ndarray, shapes (H', 3) and (H', 3, 3)
        Updated (H' = H without branching).
    evidence : FrameEvidence
    """
    H = poses.shape[0]
    m = bearings.size
    N = landmarks_xy.shape[0]
    var = sensor.noise**2
    if H == 0:
        empty = np.zeros(0, dtype=np.int64)
        return (
            poses,
            covs,
            FrameEvidence(np.zeros(0), np.zeros((0, m), np.int64), empty, empty, empty, empty),
        )
    base = sensor.log_clutter_density()
    if clutter_log is None:
        clutter_log = np.full((H, m), base)
    origin = np.arange(H)
    prior_w = np.zeros(H)
    if split_rule is not None:
        poses, covs, origin, prior_w = split(poses, covs, landmarks_xy, sensor, split_rule)
        H = poses.shape[0]
        clutter_log = clutter_log[origin]
    rel, pred, r2, S = _geometry(poses, covs, landmarks_xy, var)
    plain = sensor.plainly_visible(rel.reshape(-1, 2), np.zeros(3), bearings).reshape(H, N)
    half = sensor.half_fov
    if half is not None:
        pose_sd = np.sqrt(np.maximum(S - var, 0.0))
        plain &= np.abs(pred) + MISS_POSE_MARGIN * pose_sd <= half - sensor.plain_margin
    miss = np.where(plain, sensor.log_miss, 0.0)
    reach = np.ones((H, N), dtype=bool)
    if sensor.reach_max is not None:
        reach &= r2 <= sensor.reach_max**2
    if sensor.reach_min is not None:
        reach &= r2 >= sensor.reach_min**2
    nu = np.asarray(wrap(bearings[None, :, None] - pred[:, None, :]))
    Sb = S[:, None, :]
    ok = (nu * nu <= sensor.gate_chi2 * Sb) & reach[:, None, :]
    gain = np.where(
        ok,
        sensor.match_log_likelihood(nu, Sb) - clutter_log[:, :, None] - miss[:, None, :],
        -np.inf,
    )
    K = max(1, int(branches))
    assign_k = np.empty((H, K, m), dtype=np.int64)
    totals = np.empty((H, K))
    found = _kernels.associate(np.ascontiguousarray(gain), assign_k, totals)
    keep = (np.arange(K)[None, :] < found[:, None]) & (totals >= totals[:, :1] - branch_margin)
    parent, k_idx = np.nonzero(keep)
    extra = (clutter_log - base).sum(axis=1) + miss.sum(axis=1) + prior_w
    loglik = totals[parent, k_idx] + extra[parent]
    if max_rows is not None and parent.size > max_rows:
        rank = loglik + (0.0 if prior_score is None else prior_score[origin[parent]])
        best = np.sort(np.argsort(-rank, kind="stable")[:max_rows])
        parent, k_idx, loglik = parent[best], k_idx[best], loglik[best]
    assignment = assign_k[parent, k_idx]
    new_p, new_c = _kernels.iekf_update(
        np.ascontiguousarray(poses[parent]),
        np.ascontiguousarray(covs[parent]),
        np.ascontiguousarray(landmarks_xy),
        np.ascontiguousarray(bearings),
        assignment,
        var,
        iterations,
    )
    if collapse_chi2 > 0 and parent.size > H:
        lead, new_p, new_c, loglik = _kernels.collapse(
            parent.astype(np.int64), new_p, new_c, loglik, collapse_chi2
        )
        parent, assignment = parent[lead], assignment[lead]
    matched = (assignment >= 0).sum(axis=1)
    hit = np.zeros((parent.size, N), dtype=bool)
    rows, cols = np.nonzero(assignment >= 0)
    hit[rows, assignment[rows, cols]] = True
    plain_p = plain[parent]
    missed = (plain_p & ~hit).sum(axis=1)
    ev = FrameEvidence(
        loglik,
        assignment,
        matched,
        plain_p.sum(axis=1).astype(np.int64),
        missed,
        origin[parent].astype(np.int64),
    )
    return new_p, new_c, ev
