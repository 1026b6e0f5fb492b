"""From complete paths to solutions: refinement, the joint test, the posterior, ambiguity.

What :func:`finish` does with the complete paths an engine found, in order:

1. keeps at most MAX_LEAVES of them, the best by the evidence below at their unrefined
   poses (volume term included: on a large map tens of thousands of chance fits of a few
   bearings fit more tightly than the truth but fix their pose poorly);
2. refines each pose by Gauss-Newton on all its pairs and drops a pose that stands on one of
   its own landmarks; with ``sigma``, keeps the paths that pass the joint chi-square test on
   all their pairs (joint compatibility, as in JCBB);
3. scores each interpretation ``a`` by its log evidence under the
   :class:`~omniloc.sensor.SensorModel`, the standard multiple-hypothesis log-likelihood
   ratio against "every bearing is clutter", integrated over the pose (Laplace)::

       ln E(a) = sum_matched [ln p_detect - ln sqrt(2 pi sigma^2) - ln c]
                 - SSE / (2 sigma^2)                   (the matched bearings' residuals)
                 + missed * ln(1 - p_detect)           (plainly visible, not observed;
                                                        p_detect unknown but a range given:
                                                        ln B(matched + 1, missed + 1))
                 + ln sqrt(det(2 pi Cov)) + ln prior(pose)   (Laplace: volume x prior)
                 [+ the clutter count's term when its rate follows the detections:
                  SensorModel.clutter_count_term]

   with ``c`` the clutter density (expected spurious bearings per frame over the width of the
   field of view) and ``prior`` the density of poses before the bearings are seen: uniform
   over the region the robot may be in (by default the landmarks' bounding box, widened by
   the range), falling off outside it (:class:`PosePrior`). The last term is what makes the
   posterior honest about interpretations that fix the pose poorly (three bearings always
   fit some pose) and about large maps where many poses could be tried; it equals the sum
   over the matched bearings of ``ln p_detect - nu^2 / 2S - ln sqrt(2 pi S)`` with ``S`` the
   innovation variance including the pose's uncertainty, taken in sequence (the form of the
   multiple-hypothesis tracking literature), plus the prior density of the first three's
   pose;
4. ranks by evidence; merges solutions that are the same pose (inside each other's
   confidence ellipsoid) and adds their evidence (the multiplicity of near-equivalent
   assignments: a spurious bearing beside a true one, two landmarks on one ray); normalises
   against the evidence of every solution and of the *null* interpretation (every bearing
   clutter, every plainly visible landmark missed); a solution's ``confidence`` is its share
   of that posterior, and the answer is ``ambiguous`` when the best holds less than
   ``decisive`` (0.95) of it, or when the search was cut short by its budget or stopped at a
   first fit (rivals may not have been found).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._kernels import evidence as _evidence
from .._kernels import geometry as geo
from .._kernels.merge import merge
from ..angles import TWO_PI, wrap
from ..maps import LandmarkMap
from ..pose import MAX_CONDITION
from ..sensor import SensorModel, chi2_quantile
from .options import Leaves, SearchOptions
from .results import Solutions
from .tree import map_scale, path_sse

__all__ = [
    "DECISIVE",
    "MAX_LEAVES",
    "SAME_POSE_CHI2",
    "EvidenceModel",
    "PosePrior",
    "Scored",
    "evidence_model",
    "finish",
    "pose_prior",
    "same_pose",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: At most this many complete paths are refined and returned (the best by matches and fit).
#: Measured on MRCLAM set 6 (8 bearings, 3 of them robots, are explained 6 at a time by
#: ~1,800 interpretations of a clustered map, the true one only 5 at a time): true pose among
#: the solutions 87.9 % at 2,000, 90.0 % at 8,000, 90.1 % at 16,000 and 32,000.
MAX_LEAVES = 8000

#: Two solutions are one answer, and their evidence adds up, when each lies within one
#: standard deviation (Mahalanobis distance 1) of the other -- equivalent assignments (a
#: spurious bearing that also matches a landmark, two landmarks on one ray) land far closer
#: than that, while distinct nearby poses (tubes of one cluster swapped) stay apart so that
#: the true one is not hidden behind another --
SAME_POSE_CHI2 = 1.0
#: ... or when they are one place: within SAME_PLACE (metres, radians) of each other, and the
#: data cannot tell them apart (their gap passes the joint test ``d^T (C_1 + C_2)^-1 d`` at
#: 99.99 %, 3 degrees of freedom). A bearing given to either of two landmarks on nearly one ray
#: gives two such poses a few centimetres apart: one answer, not an ambiguity.
SAME_PLACE = (0.1, float(np.deg2rad(1.0)))
SAME_PLACE_CHI2 = chi2_quantile(0.9999, 3)

#: ``ambiguous`` unless the best solution holds at least this share of the posterior.
DECISIVE = 0.95

#: Outside the region where the robot may be (the landmarks' bounding box, widened by the
#: sensor's range when there is one), the prior density of poses falls off as a Gaussian of
#: this fraction of the map's extent (at least PRIOR_EDGE_MIN metres): a robot seldom stands
#: far outside the landmarks it localizes with, and a pose out there sees them all from one
#: side, poorly fixed -- a vague pose the evidence would otherwise reward for its volume.
PRIOR_EDGE = 0.05
PRIOR_EDGE_MIN = 0.5


@dataclass(frozen=True)
class PosePrior:
    """Where the robot may be before the bearings are seen: uniform over ``region``
    (xmin, ymin, xmax, ymax; any heading), with Gaussian edges of scale ``edge`` metres."""

    region: tuple[float, float, float, float]
    edge: float

    @property
    def log_volume(self) -> float:
        """ln of the prior's normalisation: ``(W + edge sqrt(2 pi)) (H + edge sqrt(2 pi))
        2 pi``, m^2 rad."""
        x0, y0, x1, y1 = self.region
        skirt = self.edge * math.sqrt(TWO_PI)
        return math.log((x1 - x0 + skirt) * (y1 - y0 + skirt) * TWO_PI)

    def log_density(self, poses: FloatArray) -> FloatArray:
        """ln of the prior density at poses (K, 3)."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        return np.array(
            [
                _evidence.prior_log_density(x, y, self.region, self.edge, self.log_volume)
                for x, y in p[:, :2].tolist()
            ]
        )


def pose_prior(
    lm: LandmarkMap, sensor: SensorModel, region: tuple[float, float, float, float] | None = None
) -> PosePrior:
    """The default prior of poses for a map and a sensor (see PRIOR_EDGE), or ``region``."""
    if region is None:
        x0, y0, x1, y1 = lm.bounds
        r = sensor.max_range or 0.0
        region = (x0 - r, y0 - r, x1 + r, y1 + r)
    x0, y0, x1, y1 = region
    edge = max(PRIOR_EDGE * max(x1 - x0, y1 - y0), PRIOR_EDGE_MIN)
    return PosePrior((x0, y0, x1, y1), edge)


@dataclass(frozen=True)
class EvidenceModel:
    """The constants of the posterior of one search (see the module's documentation).

    Attributes
    ----------
    per_match : float
        ``ln p_detect - ln sqrt(2 pi sigma^2) - ln c``: what a matched bearing adds, before
        its residual, relative to calling it clutter.
    log_miss : float
        ``ln(1 - p_detect)`` for each plainly visible landmark not observed (0 without
        ``p_detect``).
    prior : PosePrior
    log_null : float
        Log evidence of the null interpretation (every bearing clutter).
    sig2 : float
        Bearing variance, rad^2.
    unknown_rate : bool
        ``p_detect`` is unknown but the sensor's range bounds what it can see: the detection
        rate is integrated out over a uniform prior (``ln B(matched + 1, missed + 1)``) instead of
        fixed, so the plainly visible landmarks a pose leaves unseen count against it as much
        as the bearings allow. Without ``p_detect`` and without a range, nothing is inferred
        from what the sensor did not report, and each match is scored with
        :attr:`~omniloc.sensor.SensorModel.DETECT_UNKNOWN`.
    """

    per_match: float
    log_miss: float
    prior: PosePrior
    log_null: float
    sig2: float
    unknown_rate: bool = False


def evidence_model(
    lm: LandmarkMap,
    sensor: SensorModel,
    max_wild: int,
    region: tuple[float, float, float, float] | None = None,
) -> EvidenceModel:
    """The posterior's constants for a search of ``lm`` with ``sensor`` (``max_wild``: the
    spurious bearings allowed, which stand for the clutter rate when the sensor has none)."""
    sig2 = sensor.noise**2
    unknown_rate = sensor.p_detect is None and sensor.plain_max is not None
    log_detect = 0.0 if unknown_rate else sensor.log_detect
    per_match = log_detect - 0.5 * math.log(TWO_PI * sig2) - sensor.log_clutter_density(max_wild)
    prior = pose_prior(lm, sensor, region)
    log_null = 0.0
    if sensor.p_detect is not None or unknown_rate:
        x0, y0, x1, y1 = prior.region
        area = (x1 - x0) * (y1 - y0)
        # Plainly visible landmarks at a random pose: about Poisson with mean mu.
        mu = float(lm.n)
        if sensor.limits_visibility:
            r = sensor.plain_max if sensor.plain_max is not None else math.sqrt(area)
            seen = math.pi * r * r * (sensor.fov_width / TWO_PI)
            mu = lm.n * min(1.0, seen / area)
        if unknown_rate:
            # Every one of K visible missed, the rate uniform: E[1 / (K + 1)] = (1 - e^-mu) / mu.
            log_null = math.log(-math.expm1(-mu) / mu) if mu > 0 else 0.0
        elif sensor.limits_visibility:
            # E[(1 - p)^K] = exp(-mu p) for K ~ Poisson(mu).
            log_null = -mu * sensor.p_detect  # type: ignore[operator]
        else:
            log_null = lm.n * sensor.log_miss
    return EvidenceModel(per_match, sensor.log_miss, prior, log_null, sig2, unknown_rate)


def log_evidence(
    ev: EvidenceModel,
    nmatch: IntArray,
    sse: FloatArray,
    cov: FloatArray,
    missed: IntArray,
    poses: FloatArray,
) -> FloatArray:
    """Each interpretation's log evidence (see the module's documentation and
    :func:`omniloc._kernels.evidence.log_evidence`)."""
    p = ev.prior
    return np.asarray(
        _evidence.log_evidence(
            np.ascontiguousarray(nmatch, dtype=np.int64),
            np.ascontiguousarray(sse, dtype=np.float64),
            np.ascontiguousarray(cov, dtype=np.float64),
            np.ascontiguousarray(missed, dtype=np.int64),
            np.ascontiguousarray(poses, dtype=np.float64),
            ev.per_match,
            ev.sig2,
            ev.log_miss,
            ev.unknown_rate,
            p.region,
            p.edge,
            p.log_volume,
        )
    )


@dataclass(frozen=True)
class Scored:
    """What :func:`finish` returns: the solutions, best first, and the posterior's verdict."""

    solutions: Solutions
    ambiguous: bool
    unexplained: float


#: Negative evidence works on all poses x all landmarks at once up to this many pairs (scene
#: b: 30 landmarks x a few hundred poses), else pose by pose on the landmarks within range ...
MISSED_DENSE = 200_000
#: ... and, with a range, only on maps up to this size: beyond, the k-d tree's few landmarks
#: in range beat every landmark of the map (4 ms per pose at 10,000 landmarks).
MISSED_DENSE_MAP = 256


def finish(lm: LandmarkMap, bearings: FloatArray, leaves: Leaves, opt: SearchOptions) -> Scored:
    """Solutions, best first, from an engine's complete paths, with the posterior's verdict
    (see the module's documentation for the steps)."""
    level_assign, level_pose = leaves.arrays()
    engine_missed = leaves.missed_counts()
    # No solution decides nothing: ambiguous, so that ``not result.ambiguous`` always has a
    # best to read.
    if len(level_assign) == 0:
        return Scored(Solutions.empty(leaves.m), True, 1.0)
    m = leaves.m
    order = leaves.order
    s = opt.sensor
    ev = evidence_model(lm, s, opt.max_wild)
    if len(level_assign) > MAX_LEAVES:
        # Huge gates, tiny maps or a few bearings on a large map can leave very many paths;
        # only the best MAX_LEAVES by their evidence at the unrefined poses are refined. The
        # volume term counts: by matches and fit alone, chance fits that fix their pose poorly
        # crowded the truth out (benchmark scene (c), trial 189). A path whose pairs do not
        # fix a pose (non-finite evidence) goes last. Landmarks left unseen count where the
        # engine counted them (the hypotheses engine, the default, does; the tree does
        # not): counting them here for every path would cost more than the refinement.
        sse0 = path_sse(lm.xy, bearings[order], level_assign, level_pose)
        nm = (level_assign >= 0).sum(axis=1)
        w0 = (level_assign >= 0).astype(np.float64)
        lp0 = np.array(level_pose, dtype=np.float64)
        cov0 = geo.covariances(
            lm.xy[np.maximum(level_assign, 0)], w0, lp0, ev.sig2, geo.COVARIANCE_FLOOR
        )
        miss0 = engine_missed if engine_missed is not None else np.zeros(len(nm), dtype=np.int64)
        score0 = log_evidence(ev, nm, sse0, cov0, miss0, lp0) + s.clutter_count_term(
            m, nm, opt.max_wild
        )
        score0 = np.where(np.isfinite(score0), score0, -np.inf)
        keep0 = np.argsort(-score0, kind="stable")
        keep0 = keep0[:MAX_LEAVES]
        level_assign, level_pose = level_assign[keep0], level_pose[keep0]
        if engine_missed is not None:
            engine_missed = engine_missed[keep0]
    # Back from level order to observation order.
    assign = np.full((len(level_assign), m), -1, dtype=np.int64)
    assign[:, order] = level_assign
    w = (assign >= 0).astype(np.float64)
    Lm = lm.xy[np.maximum(assign, 0)]
    bm = np.repeat(bearings[None, :], len(assign), axis=0)
    poses, sse = geo.gauss_newton(Lm, bm, w, np.array(level_pose, dtype=np.float64), 10)
    nmatch = w.sum(axis=1).astype(np.int64)
    # A pose on one of its own landmarks has no bearing to it (atan2(0, 0) = 0 can pass a gate
    # by accident on a grid map): not a pose.
    gap2 = ((Lm - poses[:, None, :2]) ** 2).sum(axis=2)
    joint = ((gap2 > (1e-9 * map_scale(lm)) ** 2) | (w == 0)).all(axis=1)
    if s.sigma is not None:
        # Joint compatibility (JCBB): each pairing passed its own gate, but all of them
        # together must also fit one pose: sse / sigma^2 ~ chi-square with n - 3 dof.
        joint &= sse / s.sigma**2 <= opt.joint_chi2[nmatch]
    if not joint.any():
        return Scored(Solutions.empty(leaves.m), True, 1.0)
    if not joint.all():
        k = np.flatnonzero(joint)
        assign, w, Lm, poses, sse, nmatch = assign[k], w[k], Lm[k], poses[k], sse[k], nmatch[k]
        if engine_missed is not None:
            engine_missed = engine_missed[k]
    rms = np.sqrt(sse / nmatch)
    # Covariance at the refined pose: sigma^2 (G^T G)^-1 over the matched pairs.
    cov = geo.covariances(Lm, w, poses, ev.sig2, geo.COVARIANCE_FLOOR)
    # An interpretation whose pairs do not fix its pose (every bearing alike: a robot "at
    # infinity"; a pose on the circle through its three landmarks) is no answer: its
    # covariance is the floor's, not the data's (pose_covariance refuses the same).
    fixed = _fixed(cov)
    if not fixed.any():
        return Scored(Solutions.empty(leaves.m), True, 1.0)
    if not fixed.all():
        k = np.flatnonzero(fixed)
        assign, w, Lm, poses, sse, nmatch, rms, cov = (
            assign[k], w[k], Lm[k], poses[k], sse[k], nmatch[k], rms[k], cov[k]
        )  # fmt: skip
        if engine_missed is not None:
            engine_missed = engine_missed[k]
    missed = np.zeros(len(poses), dtype=np.int64)
    # (Every filter above keeps the engine's counts aligned; a length check guards that.)
    if (s.p_detect is not None or ev.unknown_rate) and (
        engine_missed is not None and len(engine_missed) == len(poses)
    ):
        missed = engine_missed
    elif s.p_detect is not None or ev.unknown_rate:
        missed = missed_landmarks(lm, poses, assign, bearings, opt)
    ln_e = log_evidence(ev, nmatch, sse, cov, missed, poses)
    if s.clutter_by_detections is not None:
        # Clutter whose rate follows the landmarks detected (SensorModel): each
        # interpretation's clutter count at the rate of frames that report as many.
        ln_e = ln_e + s.clutter_count_term(m, nmatch, opt.max_wild)
    rank = np.argsort(-ln_e, kind="stable")
    if opt.merge and len(rank) > 1:
        keep, owner = _merge(rank, poses, cov)
        mass = np.full(len(ln_e), -np.inf)
        np.logaddexp.at(mass, owner, ln_e)
        mass = mass[keep]
    else:
        keep, mass = [int(i) for i in rank], ln_e[rank]
    # ln sum exp, by hand: scipy.special.logsumexp's array-API layer cost 1 ms per call, as
    # much as the whole search of seven bearings in the demo room.
    top = max(float(mass.max()), ev.log_null)
    total = top + math.log(float(np.exp(mass - top).sum()) + math.exp(ev.log_null - top))
    conf = np.exp(mass - total)
    # Best first by confidence (a stable order: the merge may have put a solution with more
    # evidence behind the one it absorbed). The solutions stay arrays, each made into a
    # Solution when read (:class:`Solutions`).
    keep_arr = np.asarray(keep, dtype=np.int64)
    by = np.argsort(-conf, kind="stable")
    keep_arr, conf = keep_arr[by], conf[by]
    sols = Solutions(
        poses[keep_arr],
        assign[keep_arr],
        rms[keep_arr],
        nmatch[keep_arr],
        cov[keep_arr],
        -ln_e[keep_arr],
        conf,
        missed[keep_arr].astype(np.int64),
    )
    # A search cut short by its budget, or stopped at a first fit, has not looked for every
    # rival: whatever the best's share among what was found, it is not a decisive answer.
    ambiguous = float(conf[0]) < opt.decisive or not leaves.complete or not leaves.exhaustive
    # Nor is a best that beats the null by less than a chance fit somewhere on the map could
    # (look-elsewhere over its landmarks): when the true interpretation is out of reach (a
    # real bearing outside its gate, more clutter than max_spurious), a modest chance fit on
    # a large map would otherwise hold all the posterior.
    unexplained = float(math.exp(ev.log_null - total))
    ambiguous |= not convincing(float(conf[0]), unexplained, lm.n, opt)
    return Scored(sols, bool(ambiguous), unexplained)


def convincing(confidence: float, unexplained: float, places: int, opt: SearchOptions) -> bool:
    """Whether a solution's evidence beats the null interpretation's by the decisive odds
    times the number of places a chance fit could come from (the map's landmarks):
    ``confidence / unexplained >= decisive / (1 - decisive) * places``.

    On scene c (10,000 landmarks, default options) the one wrong best in 40 scenes beat the
    null by 8 nats (the truth out of reach, 11 of 13 bearings fitted by chance 129 m away);
    the true poses, by 15 to 80 nats."""
    if unexplained <= 0.0:
        return True
    need = math.log(opt.decisive / (1.0 - opt.decisive)) + math.log(max(1, places))
    return math.log(max(confidence, 1e-300)) - math.log(unexplained) >= need


def _fixed(cov: FloatArray) -> NDArray[np.bool_]:
    """Which (K, 3, 3) covariances are finite, positive definite and conditioned like a
    pose the pairs fix (:data:`omniloc.pose.MAX_CONDITION`): what the eigenvalues say.

    Most are plainly so, and are told without them (a search's thousands of solutions:
    2 ms of ``eigvalsh``). Their leading minors (of the lower triangle, which ``eigvalsh``
    reads) are positive beyond their rounding, so the matrix is positive definite, and
    ``trace^3 / det``, a bound on the condition number, is below 1e10, a hundredth of the
    limit: the eigenvalues, backward stable to a few ulps of the largest, say the same.
    The rest go to ``eigvalsh``."""
    ok = np.asarray(np.isfinite(cov).all(axis=(1, 2)), dtype=bool)
    c = np.where(ok[:, None, None], cov, np.eye(3))
    a, b, g = c[:, 0, 0], c[:, 1, 1], c[:, 2, 2]
    d, e, f = c[:, 1, 0], c[:, 2, 0], c[:, 2, 1]
    with np.errstate(all="ignore"):
        m2 = a * b - d * d
        det = a * (b * g - f * f) - d * (d * g - f * e) + e * (d * f - b * e)
        size = np.abs(a) * (np.abs(b * g) + f * f) + np.abs(d) * (np.abs(d * g) + np.abs(f * e))
        size += np.abs(e) * (np.abs(d * f) + np.abs(b * e))
        plain = (a > 0) & (m2 > 1e-12 * (np.abs(a * b) + d * d)) & (det > 1e-12 * size)
        plain &= (a + b + g) ** 3 <= 1e10 * det
    out = ok & plain
    rest = np.flatnonzero(~plain)
    if rest.size:
        w = np.linalg.eigvalsh(c[rest])
        out[rest] = ok[rest] & (w[:, 0] > 0) & (w[:, -1] <= MAX_CONDITION * w[:, 0])
    return np.asarray(out)


def _regularised(cov: FloatArray) -> FloatArray:
    """(K, 3, 3) covariances nudged so that exact fits stay invertible."""
    scale = np.maximum(np.abs(cov).max(axis=(1, 2)), 1e-300)
    return np.asarray(cov + (1e-12 * scale + 1e-24)[:, None, None] * np.eye(3))


def _merge(rank: IntArray, poses: FloatArray, cov: FloatArray) -> tuple[list[int], IntArray]:
    """Greedy merge in rank order (see :func:`omniloc._kernels.merge.merge`, SAME_POSE_CHI2
    and SAME_PLACE): a solution that is the same answer as a better one is merged into it.
    Returns the kept indices and, for each solution, the one it went to."""
    if len(rank) == 1:
        return [int(rank[0])], np.arange(len(poses))
    reg = _regularised(cov)
    kept, owner = merge(
        np.ascontiguousarray(rank, dtype=np.int64),
        np.ascontiguousarray(poses),
        np.ascontiguousarray(reg),
        np.ascontiguousarray(np.linalg.inv(reg)),
        SAME_POSE_CHI2,
        SAME_PLACE_CHI2,
        *SAME_PLACE,
    )
    return [int(i) for i in kept], owner


def _gap(p: FloatArray, q: FloatArray) -> FloatArray:
    d = np.asarray(q - p, dtype=np.float64)
    d[..., 2] = np.asarray(wrap(d[..., 2]))
    return d


def same_pose(p: FloatArray, cp: FloatArray, q: FloatArray, cq: FloatArray) -> bool:
    """Whether two poses (with their covariances) are one answer: within a micrometre of
    each other, inside each other's one-sigma ellipsoid, or one place (SAME_PLACE)."""
    d = _gap(p, q)
    if np.abs(d[:2]).max() < 1e-6 and abs(d[2]) < 1e-6:
        return True
    reg = _regularised(np.stack([cp, cq]))
    with np.errstate(all="ignore"):
        inv = np.linalg.inv(reg)
        if max(float(d @ inv[0] @ d), float(d @ inv[1] @ d)) <= SAME_POSE_CHI2:
            return True
        near = float(np.hypot(d[0], d[1])) <= SAME_PLACE[0] and abs(d[2]) <= SAME_PLACE[1]
        return near and float(d @ np.linalg.solve(reg[0] + reg[1], d)) <= SAME_PLACE_CHI2


def merge_numpy(rank: IntArray, poses: FloatArray, cov: FloatArray) -> tuple[list[int], IntArray]:
    """:func:`_merge` read plainly, pair by pair (the compiled merge's test oracle)."""
    keep: list[int] = []
    owner = np.arange(len(poses))
    for i in rank:
        for k in keep:
            if same_pose(poses[k], cov[k], poses[i], cov[i]):
                owner[i] = k
                break
        else:
            keep.append(int(i))
    return keep, owner


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
