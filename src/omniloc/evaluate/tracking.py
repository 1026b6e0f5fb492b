"""Evaluation of localization over time: whole runs, kidnappings, and one scoring for all.

A *stream* is what a robot's localizer sees -- odometry rows and frames of bearings, in time
order -- with the true trajectory beside it. :func:`mrclam_streams` makes the streams of the
MRCLAM recordings: each robot's whole run, and *kidnapped* streams, spliced at seeded moments
to another time of the same run or to another robot's run (the odometry goes on as if
nothing happened: the robot was carried away). :func:`run_stream` feeds a stream to any
localizer over time (anything with ``odometry(t, v, w)`` and ``frame(t, bearings) ->
TrackEstimate``), and :func:`score_run` scores what it reported; :func:`evaluate_tracking`
does both for a set of streams. The :class:`~omniloc.track.Tracker` and the baselines of
``benchmarks/track_baselines.py`` are scored by this same code.

Definitions (``pos_tol_m``, ``heading_tol_deg``: 0.3 m and 5 degrees by default)
-------------------------------------------------------------------------------
* A frame is *correct* when the localizer's state is ``localized`` and its pose is within
  tolerance of the truth at the frame's time. Frames where the truth is unreliable (its
  ``gap`` above ``max_gap_s``, or outside the track) are left out of every figure.
* *time to localize*: from the start of the stream to its first correct frame (on a
  kidnapped stream, before its jump; after it, *recovery* below).
* *localized and correct after*: the share of frames from the first correct frame on that
  are correct. Over several streams, ``correct_after_rate`` is the mean of the streams'
  shares (a stream never correct left out), ``correct_after_pooled_rate`` the share of all
  their frames from each one's first correct frame on.
* *confidently wrong*: frames whose state is ``localized`` but whose pose is not correct.
* *weight calibration*: over the frames with hypotheses, the weight of the strongest one
  (the localizer's probability that the robot is there) against whether it is within
  tolerance, in tenths of [0, 1]; its expected calibration error (``best_weight_ece``) says
  how far those weights are from the frequencies (0: calibrated). The same for the
  estimates' own ``probability`` that their pose is within tolerance (``probability_ece``)
  and their ``confidence`` (``confidence_ece``), over the frames that carry one; and for
  every reported hypothesis, its weight and its confidence against whether the truth is
  within tolerance of it (``hypothesis_weight_ece``, ``hypothesis_confidence_ece``).
* *RMSE*: position and heading errors over the ``localized`` frames.
* *covariance consistency*: over the ``localized`` frames with a covariance, whether the
  truth lies inside the reported covariance's 50 % and 99 % regions of the pose (its
  normalised estimation error squared, ``e' P^-1 e``, against the chi-square quantiles of 3
  degrees of freedom). A consistent covariance holds the truth in 50 % and 99 % of them;
  fewer say the localizer is surer of its pose than it should be.
* *kidnapping*: at ``jump_t`` the stream continues elsewhere. *Detection delay*: from the jump
  to the first frame that is no longer localized-and-wrong (the localizer left ``localized``,
  flagged ``kidnapped``, or is already right again). *Recovery*: from the jump to the first
  correct frame. A *false alarm* is a frame flagged ``kidnapped`` where no kidnapping
  happened (a stream without a jump, or before its jump). *Flag delay*: on a stream whose
  last estimate before the jump was ``localized`` (there was a place to leave), from the
  jump to the first frame flagged ``kidnapped`` (never: the kidnapping was not flagged).
  The detection delay does not read the flag; the false alarms and the flag delay do, and
  are read together: a localizer that never flags has no false alarm. Of the false alarms,
  those that left a place that was right (all but those whose last ``localized`` frame
  before the flag was scored and wrong) are counted apart: the others left a wrong place,
  which was right to leave.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..angles import wrap
from ..errors import InputError
from ..io import finite_number, shorten
from ..maps import LandmarkMap
from ..pose import Pose
from ..sensor import chi2_quantile
from ..track.data import Frame, GroundTruth, Odometry
from ..track.offline import rows_before
from ..track.records import TrackEstimate, TrackState
from .bounds import (
    MRCLAM_BEARING_ERRORS,
    MRCLAM_REPEATING,
    RepeatingErrors,
    StreamBound,
    bearing_information,
    stream_bound,
)
from .common import (
    NAN,
    calibration_of_bins,
    confidence_bins,
    jsonable,
    progress_bar,
    write_records_csv,
)

__all__ = [
    "LocalizerOverTime",
    "RunScore",
    "Stream",
    "TrackingReport",
    "TrackingResult",
    "backward_offline",
    "censored_median",
    "errors_against",
    "evaluate_mrclam_tracking",
    "evaluate_tracking",
    "frames_within_tolerance",
    "hypothesis_outcomes",
    "mrclam_bound",
    "run_stream",
    "score_run",
    "seed_spread",
    "seed_spread_table",
    "splice",
    "tracker_factory",
    "tracking_summary",
    "weight_ece",
]

if TYPE_CHECKING:
    from ..sensor import SensorModel
    from ..track.motion import MotionModel
    from ..track.tracker import TrackerConfig

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None

#: Ground truth whose samples are further apart than this (s) is not trusted for scoring.
MAX_GAP_S = 0.5

#: The calibration bins of :class:`RunScore` beyond the strongest weight's (each
#: ``<name>_bins``; the totals' ``<name>_frames`` and ``<name>_ece``).
_OWN_BINS = ("probability", "confidence", "hypothesis_weight", "hypothesis_confidence")

#: Bins of the strongest hypothesis's weight (tenths of [0, 1]) for its calibration.
WEIGHT_BINS = 10

#: The 50 % and 99 % quantiles of the chi-square distribution with 3 degrees of freedom:
#: the normalised estimation error squared of a pose (x, y, theta) under a consistent
#: covariance is below them in 50 % and 99 % of the frames.
CHI2_3DOF_50 = chi2_quantile(0.5, 3)
CHI2_3DOF_99 = chi2_quantile(0.99, 3)
#: The same for the position alone (x, y: 2 degrees of freedom) and the heading alone (1).
CHI2_2DOF_99 = chi2_quantile(0.99, 2)
CHI2_1DOF_99 = chi2_quantile(0.99, 1)


class LocalizerOverTime(Protocol):
    """What :func:`run_stream` drives: odometry rows in, an estimate per frame out."""

    def odometry(self, t: ArrayLike, v: ArrayLike, w: ArrayLike) -> None:
        """Odometry rows (times in order; each row holds until the next)."""

    def frame(self, t: float, bearings: NDArray[np.float64]) -> TrackEstimate:
        """The bearings of one frame; returns the estimate after it."""


@dataclass(frozen=True)
class Segment:
    """A piece of a stream taken from a recording: stream time ``t`` is recording time
    ``t - offset``; it covers stream times ``[start, end)``."""

    start: float
    end: float
    offset: float
    truth: GroundTruth
    source: str


@dataclass(frozen=True)
class Stream:
    """Odometry and frames in stream time, with the truth piecewise from recordings.

    Attributes
    ----------
    name : str
    landmarks : LandmarkMap
    odometry : Odometry
    frames : list of Frame
    segments : tuple of Segment
        Where the truth comes from; a kidnapped stream has two.
    """

    name: str
    landmarks: LandmarkMap
    odometry: Odometry
    frames: list[Frame] = field(repr=False)
    segments: tuple[Segment, ...]

    @property
    def start(self) -> float:
        """Stream time of the first odometry row or frame."""
        t0 = float(self.odometry.t[0])
        return min(t0, self.frames[0].t) if self.frames else t0

    @property
    def jump_t(self) -> float:
        """Stream time of the kidnapping (NaN for a stream without one)."""
        return self.segments[1].start if len(self.segments) > 1 else NAN

    def truth_at(self, t: float | FloatArray) -> tuple[FloatArray, FloatArray]:
        """True poses (k, 3) and ground-truth gaps (k,) at stream times ``t``."""
        tq = np.atleast_1d(np.asarray(t, dtype=np.float64))
        poses = np.full((tq.size, 3), np.nan)
        gaps = np.full(tq.size, np.inf)
        for seg in self.segments:
            sel = (tq >= seg.start) & (tq < seg.end)
            if sel.any():
                p, g = seg.truth.at(tq[sel] - seg.offset)
                poses[sel], gaps[sel] = p, g
        return poses, gaps


def whole_run(
    name: str, landmarks: LandmarkMap, odometry: Odometry, frames: list[Frame], truth: GroundTruth
) -> Stream:
    """A recording as one stream, in its own time."""
    end = max(float(odometry.t[-1]), frames[-1].t if frames else -np.inf) + 1.0
    t0 = min(float(odometry.t[0]), frames[0].t if frames else np.inf)
    return Stream(name, landmarks, odometry, frames, (Segment(t0, end, 0.0, truth, name),))


def splice(
    first: Stream,
    t_start: float,
    t_jump: float,
    second: Stream,
    t_target: float,
    t_end_target: float,
    name: str,
) -> Stream:
    """A kidnapped stream: ``first`` from ``t_start`` to ``t_jump``, then ``second`` from its
    time ``t_target`` to ``t_end_target``, shifted so that time goes on from ``t_jump``.

    Both streams must be whole runs (one segment each) over the same map.
    """
    if not (t_start < t_jump and t_target < t_end_target):
        raise InputError("splice needs t_start < t_jump and t_target < t_end_target")
    if first.landmarks != second.landmarks:
        raise InputError("a kidnapping must stay on the same map")
    shift = t_jump - t_target

    def cut(s: Stream, lo: float, hi: float, dt: float) -> tuple[Odometry, list[Frame]]:
        o = s.odometry
        k = (o.t >= lo) & (o.t < hi)
        # The row holding at lo starts the piece.
        k0 = int(np.searchsorted(o.t, lo, side="right")) - 1
        if k0 >= 0:
            k[k0] = True
        t = np.maximum(o.t[k], lo) + dt
        fr = [Frame(f.t + dt, f.bearings, f.truth) for f in s.frames if lo <= f.t < hi]
        return Odometry(t, o.v[k], o.w[k]), fr

    o1, f1 = cut(first, t_start, t_jump, 0.0)
    o2, f2 = cut(second, t_target, t_end_target, shift)
    # The second piece's first row starts exactly at the jump: drop first-piece rows at it.
    keep = o1.t < o2.t[0]
    odo = Odometry(
        np.concatenate([o1.t[keep], o2.t]),
        np.concatenate([o1.v[keep], o2.v]),
        np.concatenate([o1.w[keep], o2.w]),
    )
    seg1 = first.segments[0]
    seg2 = second.segments[0]
    segments = (
        Segment(t_start, t_jump, seg1.offset, seg1.truth, seg1.source),
        Segment(t_jump, t_end_target + shift, seg2.offset + shift, seg2.truth, seg2.source),
    )
    return Stream(name, first.landmarks, odo, f1 + f2, segments)


def segment_of(stream: Stream, t_start: float, t_end: float, name: str) -> Stream:
    """A piece of a whole-run stream, without a jump (to count false alarms)."""
    o = stream.odometry
    k = (o.t >= t_start) & (o.t < t_end)
    k0 = int(np.searchsorted(o.t, t_start, side="right")) - 1
    if k0 >= 0:
        k[k0] = True
    odo = Odometry(np.maximum(o.t[k], t_start), o.v[k], o.w[k])
    frames = [f for f in stream.frames if t_start <= f.t < t_end]
    seg = stream.segments[0]
    return Stream(
        name,
        stream.landmarks,
        odo,
        frames,
        (Segment(t_start, t_end, seg.offset, seg.truth, seg.source),),
    )


def kidnap_streams(
    runs: Sequence[Stream],
    n: int,
    *,
    rng: RngLike = 0,
    before_s: tuple[float, float] = (60.0, 180.0),
    after_s: float = 120.0,
    min_jump_m: float = 1.0,
    other_robot: float = 0.5,
) -> tuple[list[Stream], list[Stream]]:
    """``n`` kidnapped streams and ``n`` streams of the same lengths without a jump.

    Each kidnapped stream starts at a random time of a random run, runs for a time drawn
    from ``before_s``, then jumps (with probability ``other_robot`` to another robot's run,
    else to another time of the same run, at least 30 s away) to a moment whose true pose is
    at least ``min_jump_m`` from the pose it left, and goes on for ``after_s``. The streams
    without a jump are the same runs from the same start times, for as long.
    """
    gen = np.random.default_rng(rng)
    if len(runs) == 0:
        raise InputError("kidnap_streams needs at least one run")
    jumps: list[Stream] = []
    plain: list[Stream] = []
    tries = 0
    while len(jumps) < n:
        tries += 1
        if tries > 100 * max(n, 1):
            raise InputError("could not draw kidnappings: the runs are too short")
        a = runs[int(gen.integers(len(runs)))]
        a0, a1 = a.start, float(a.odometry.t[-1])
        before = float(gen.uniform(*before_s))
        if a1 - a0 < before + after_s:
            continue
        t_start = float(gen.uniform(a0, a1 - before - after_s))
        t_jump = t_start + before
        if len(runs) > 1 and gen.random() < other_robot:
            others = [r for r in runs if r is not a]
            b = others[int(gen.integers(len(others)))]
        else:
            b = a
        b0, b1 = b.start, float(b.odometry.t[-1])
        if b1 - b0 < after_s + 1.0:
            continue
        t_target = float(gen.uniform(b0, b1 - after_s))
        if b is a and abs(t_target - t_jump) < 30.0:
            continue
        pa, _ = a.truth_at(t_jump)
        pb, _ = b.truth_at(t_target)
        if not (np.isfinite(pa).all() and np.isfinite(pb).all()):
            continue
        if float(np.hypot(*(pa[0, :2] - pb[0, :2]))) < min_jump_m:
            continue
        k = len(jumps)
        jumps.append(
            splice(
                a, t_start, t_jump, b, t_target, t_target + after_s, f"kidnap{k}:{a.name}>{b.name}"
            )
        )
        plain.append(segment_of(a, t_start, t_jump + after_s, f"plain{k}:{a.name}"))
    return jumps, plain


# --------------------------------------------------------------------------------------------
# Running and scoring
# --------------------------------------------------------------------------------------------


def run_stream(localizer: LocalizerOverTime, stream: Stream) -> tuple[list[TrackEstimate], float]:
    """Feed a stream to a localizer in time order; return its estimates and the CPU time
    (process time, seconds) it took.

    Before each frame the odometry rows up to its time; for a localizer with a ``motion``
    model (a :class:`~omniloc.track.Tracker`) whose ``delay_s`` is negative, also the rows
    whose motion starts by then, as :func:`~omniloc.track.track` feeds them
    (:func:`~omniloc.track.offline.rows_before`)."""
    o = stream.odometry
    out: list[TrackEstimate] = []
    k = 0
    c0 = time.process_time()
    delay = float(getattr(getattr(localizer, "motion", None), "delay_s", 0.0))
    cuts = rows_before(o.t, [f.t for f in stream.frames], delay)
    for f, k1 in zip(stream.frames, cuts.tolist(), strict=True):
        if k1 > k:
            localizer.odometry(o.t[k:k1], o.v[k:k1], o.w[k:k1])
            k = k1
        out.append(localizer.frame(f.t, f.bearings))
    return out, time.process_time() - c0


@dataclass(frozen=True)
class RunScore:
    """What :func:`score_run` measured on one stream (times in seconds, errors in metres and
    degrees; NaN where not defined)."""

    name: str
    duration_s: float
    n_frames: int
    n_scored: int
    time_to_localize_s: float
    correct_after_rate: float
    n_localized: int
    n_confidently_wrong: int
    pos_rmse_m: float
    heading_rmse_deg: float
    jump_t: float
    detection_delay_s: float
    recovery_s: float
    false_alarms: int
    cpu_s: float
    #: Per tenth of [0, 1] of the strongest hypothesis's weight: (frames, sum of the weights,
    #: frames where that hypothesis was within tolerance).
    weight_bins: tuple[tuple[int, float, int], ...] = ()
    #: The same bins for the estimates' ``probability`` and ``confidence`` against whether
    #: their pose is within tolerance (the frames that carry one).
    probability_bins: tuple[tuple[int, float, int], ...] = ()
    confidence_bins: tuple[tuple[int, float, int], ...] = ()
    #: The same for every reported hypothesis: its weight, and its confidence, against
    #: whether the truth is within tolerance of its pose.
    hypothesis_weight_bins: tuple[tuple[int, float, int], ...] = ()
    hypothesis_confidence_bins: tuple[tuple[int, float, int], ...] = ()
    #: Localized frames with a covariance, and of them those whose truth lies inside the
    #: covariance's 50 % and 99 % regions (see the module's definitions).
    cov_frames: int = 0
    cov_inside_50: int = 0
    cov_inside_99: int = 0
    #: What the data allow (:func:`omniloc.evaluate.bounds.stream_bound`: a localizer told
    #: the correspondences, as sure as the localizer must be): its time to localize, its
    #: correct-after share and its recovery. NaN where not computed; inf: never.
    bound_time_to_localize_s: float = NAN
    bound_correct_after_rate: float = NAN
    bound_recovery_s: float = NAN
    #: From the jump to the first frame flagged ``kidnapped`` at or after it, on a stream
    #: whose last estimate before the jump was ``localized``; NaN otherwise (no jump, or no
    #: place to leave); inf: never flagged.
    flag_delay_s: float = NAN
    #: Scored frames from the first correct frame on, and of them the correct ones (the
    #: counts of ``correct_after_rate``, which the totals pool).
    n_after: int = 0
    n_correct_after: int = 0
    #: Of the false alarms, those that left a place that was right: all but those whose last
    #: localized frame before the flag was scored and wrong (those left a wrong place).
    false_alarms_left_right: int = 0
    #: Over the localized frames, the position error split along the robot's true heading
    #: (positive: the estimate ahead of the robot) and across it (positive: to its left):
    #: the means (a bias, such as odometry whose scale is off) and the RMSEs, metres.
    along_mean_m: float = NAN
    along_rmse_m: float = NAN
    across_mean_m: float = NAN
    across_rmse_m: float = NAN
    #: Of the ``cov_frames``, those whose true position lies inside the 99 % region of the
    #: covariance's position block, and those whose true heading lies inside the 99 %
    #: interval of its heading variance: which part of the pose the covariance is too sure
    #: of.
    cov_position_inside_99: int = 0
    cov_heading_inside_99: int = 0

    @property
    def realtime_factor(self) -> float:
        """Seconds of recording processed per CPU second."""
        return self.duration_s / self.cpu_s if self.cpu_s > 0 else math.inf

    def csv_row(self) -> dict[str, object]:
        """The run as one CSV row: every figure, the weight bins as their frame count and
        expected calibration error."""
        row: dict[str, object] = {
            f.name: getattr(self, f.name) for f in fields(self) if not f.name.endswith("_bins")
        }
        row["best_weight_frames"] = sum(int(b[0]) for b in self.weight_bins)
        row["best_weight_ece"] = weight_ece(self.weight_bins)
        for name in _OWN_BINS:
            bins = getattr(self, f"{name}_bins")
            row[f"{name}_frames"] = sum(int(b[0]) for b in bins)
            row[f"{name}_ece"] = weight_ece(bins)
        return row


def _write_runs_csv(path: str | Path, runs: Sequence[RunScore]) -> None:
    """One row per run (:meth:`RunScore.csv_row`)."""
    write_records_csv(Path(path), [r.csv_row() for r in runs])


def score_run(
    stream: Stream,
    estimates: Sequence[TrackEstimate],
    *,
    cpu_s: float = NAN,
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
    max_gap_s: float = MAX_GAP_S,
) -> RunScore:
    """Score a localizer's estimates on a stream (see the module's definitions)."""
    if len(estimates) != len(stream.frames):
        raise InputError(
            f"one estimate per frame: {len(estimates)} estimates for {len(stream.frames)} frames"
        )
    t = np.array([e.t for e in estimates], dtype=np.float64)
    truth, est, d_pos, d_hdg, scored, right = _frame_errors(
        stream, estimates, pos_tol_m, heading_tol_deg, max_gap_s
    )
    loc = np.array([e.state is TrackState.LOCALIZED for e in estimates], dtype=bool)
    correct = loc & right & scored
    wrong = loc & ~right & scored
    kid = np.array([e.kidnapped for e in estimates], dtype=bool)
    start = stream.start
    first = np.flatnonzero(correct)
    jump = stream.jump_t
    # Before the jump (or on a stream without one), "time to localize" is from the start.
    pre = t < jump if math.isfinite(jump) else np.ones(t.size, dtype=bool)
    first_pre = np.flatnonzero(correct & pre)
    ttl = float(t[first_pre[0]] - start) if first_pre.size else NAN
    after = scored & (t >= t[first[0]]) if first.size else np.zeros(t.size, dtype=bool)
    rate = float(correct[after].mean()) if after.any() else NAN
    sel = loc & scored
    pos_rmse = float(np.sqrt(np.mean(d_pos[sel] ** 2))) if sel.any() else NAN
    hdg_rmse = float(np.sqrt(np.mean(d_hdg[sel] ** 2))) if sel.any() else NAN
    delay = recovery = NAN
    if math.isfinite(jump):
        post = t >= jump
        settled = post & (~loc | kid | correct)
        if settled.any():
            delay = float(t[np.flatnonzero(settled)[0]] - jump)
        back = post & correct
        if back.any():
            recovery = float(t[np.flatnonzero(back)[0]] - jump)
    false_alarms = int((kid & pre).sum())
    # Of them, the flags that left a place that was right: all but those whose last
    # localized frame before the flag was wrong (scored, and out of tolerance), which the
    # flag was right to leave.
    loc_at = np.flatnonzero(loc)
    left_right = 0
    for k in np.flatnonzero(kid & pre).tolist():
        j = int(np.searchsorted(loc_at, k)) - 1
        left_right += int(j < 0 or not bool(wrong[loc_at[j]]))
    flag_delay = NAN
    before = np.flatnonzero(~pre)
    if math.isfinite(jump) and before.size and before[0] > 0 and loc[before[0] - 1]:
        flagged = np.flatnonzero(kid & ~pre)
        flag_delay = float(t[flagged[0]] - jump) if flagged.size else math.inf
    weight_bins = _weight_bins(estimates, truth, scored, pos_tol_m, heading_tol_deg)
    own = {
        name: _value_bins([getattr(e, name) for e in estimates], scored, right)
        for name in ("probability", "confidence")
    }
    own.update(_hypothesis_bins(estimates, truth, scored, pos_tol_m, heading_tol_deg))
    nees, nees_pos, nees_hdg = _nees(estimates, est, truth, sel)
    along, across = _along_across(est[sel], truth[sel])
    ends = [float(stream.odometry.t[-1])] + ([t[-1]] if t.size else [])
    return RunScore(
        name=stream.name,
        duration_s=max(ends) - start,
        n_frames=len(estimates),
        n_scored=int(scored.sum()),
        time_to_localize_s=ttl,
        correct_after_rate=rate,
        n_localized=int(sel.sum()),
        n_confidently_wrong=int(wrong.sum()),
        pos_rmse_m=pos_rmse,
        heading_rmse_deg=hdg_rmse,
        jump_t=jump,
        detection_delay_s=delay,
        recovery_s=recovery,
        false_alarms=false_alarms,
        false_alarms_left_right=left_right,
        cpu_s=cpu_s,
        weight_bins=weight_bins,
        probability_bins=own["probability"],
        confidence_bins=own["confidence"],
        hypothesis_weight_bins=own["hypothesis_weight"],
        hypothesis_confidence_bins=own["hypothesis_confidence"],
        cov_frames=int(nees.size),
        cov_inside_50=int((nees <= CHI2_3DOF_50).sum()),
        cov_inside_99=int((nees <= CHI2_3DOF_99).sum()),
        cov_position_inside_99=int((nees_pos <= CHI2_2DOF_99).sum()),
        cov_heading_inside_99=int((nees_hdg <= CHI2_1DOF_99).sum()),
        along_mean_m=float(along.mean()) if along.size else NAN,
        along_rmse_m=float(np.sqrt(np.mean(along**2))) if along.size else NAN,
        across_mean_m=float(across.mean()) if across.size else NAN,
        across_rmse_m=float(np.sqrt(np.mean(across**2))) if across.size else NAN,
        flag_delay_s=flag_delay,
        n_after=int(after.sum()),
        n_correct_after=int(correct[after].sum()),
    )


def _frame_errors(
    stream: Stream,
    estimates: Sequence[TrackEstimate],
    pos_tol_m: float,
    heading_tol_deg: float,
    max_gap_s: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Each frame's truth (N, 3), estimated pose (NaN when lost), position and heading
    errors (m, deg), whether it is scored, and whether its pose is within tolerance."""
    t = np.array([e.t for e in estimates], dtype=np.float64)
    truth, gap = stream.truth_at(t) if t.size else (np.zeros((0, 3)), np.zeros(0))
    scored = np.isfinite(truth).all(axis=1) & (gap <= max_gap_s)
    est, d_pos, d_hdg, right = _pose_errors(estimates, truth, pos_tol_m, heading_tol_deg)
    return truth, est, d_pos, d_hdg, scored, right


def _pose_errors(
    estimates: Sequence[TrackEstimate], truth: FloatArray, pos_tol_m: float, heading_tol_deg: float
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """The estimates' poses (NaN when lost), their position and heading errors against
    ``truth`` (m, deg) and whether they are within tolerance."""
    est = np.array(
        [e.pose.as_array() if e.pose is not None else (np.nan,) * 3 for e in estimates]
    ).reshape(-1, 3)
    d_pos = np.hypot(est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1])
    d_hdg = np.degrees(np.abs((est[:, 2] - truth[:, 2] + np.pi) % (2 * np.pi) - np.pi))
    with np.errstate(invalid="ignore"):
        right = (d_pos <= pos_tol_m) & (d_hdg <= heading_tol_deg)
    return est, d_pos, d_hdg, right


def frames_within_tolerance(
    stream: Stream,
    estimates: Sequence[TrackEstimate],
    *,
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
    max_gap_s: float = MAX_GAP_S,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Which frames are scored (the truth known there), and which estimates' poses are
    within tolerance of it (False when lost): what :func:`score_run` counts, frame by
    frame (e.g. to fit :func:`~omniloc.track.fit_confidence`)."""
    if len(estimates) != len(stream.frames):
        raise InputError(
            f"one estimate per frame: {len(estimates)} estimates for {len(stream.frames)} frames"
        )
    *_, scored, right = _frame_errors(stream, estimates, pos_tol_m, heading_tol_deg, max_gap_s)
    return scored, right


def _value_bins(
    values: Sequence[float | None],
    scored: Sequence[bool] | NDArray[np.bool_],
    right: NDArray[np.bool_],
) -> tuple[tuple[int, float, int], ...]:
    """Per tenth of [0, 1]: the scored frames that carry a value, its sum, and those right."""
    v: list[float] = []
    ok: list[bool] = []
    for k, x in enumerate(values):
        if x is None or not scored[k] or not math.isfinite(x):
            continue
        v.append(min(max(float(x), 0.0), 1.0))
        ok.append(bool(right[k]))
    if not v:
        return ()
    n, total, hit = confidence_bins(v, ok, WEIGHT_BINS)
    return tuple((int(a), float(c), int(r)) for a, c, r in zip(n, total, hit, strict=True))


def _hypothesis_bins(
    estimates: Sequence[TrackEstimate],
    truth: FloatArray,
    scored: NDArray[np.bool_],
    pos_tol_m: float,
    heading_tol_deg: float,
) -> dict[str, tuple[tuple[int, float, int], ...]]:
    """Every reported hypothesis of the scored frames: its weight and its confidence
    against whether the truth is within tolerance of its pose (per tenth of [0, 1])."""
    out = hypothesis_outcomes(estimates, truth, scored, pos_tol_m, heading_tol_deg)
    every = np.ones(out.right.size, dtype=bool)
    return {
        "hypothesis_weight": _value_bins(out.weights.tolist(), every, out.right),
        "hypothesis_confidence": _value_bins(out.confidences, every, out.right),
    }


@dataclass(frozen=True)
class HypothesisOutcomes:
    """Every reported hypothesis of the scored frames (:func:`hypothesis_outcomes`), in
    order: its frame's index, weight (at most 1), confidence (None where not reported) and
    whether the truth was within tolerance of its pose."""

    frame: NDArray[np.int64]
    weights: FloatArray
    confidences: list[float | None]
    right: NDArray[np.bool_]


def hypothesis_outcomes(
    estimates: Sequence[TrackEstimate],
    truth: FloatArray,
    scored: Sequence[bool] | NDArray[np.bool_],
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
) -> HypothesisOutcomes:
    """Every reported hypothesis of the frames that are ``scored``, against ``truth`` (N, 3)
    at the frames' times: what the evaluation scores and
    :func:`~omniloc.track.fit_confidence`'s hypotheses' table is fitted on."""
    frame: list[int] = []
    weights: list[float] = []
    confidences: list[float | None] = []
    right: list[bool] = []
    for k, e in enumerate(estimates):
        if not scored[k]:
            continue
        for h in e.hypotheses:
            d_pos = math.hypot(h.pose.x - truth[k, 0], h.pose.y - truth[k, 1])
            d_hdg = abs(math.degrees(float(wrap(h.pose.theta - truth[k, 2]))))
            frame.append(k)
            weights.append(min(float(h.weight), 1.0))
            confidences.append(h.confidence)
            right.append(d_pos <= pos_tol_m and d_hdg <= heading_tol_deg)
    return HypothesisOutcomes(
        np.asarray(frame, dtype=np.int64),
        np.asarray(weights, dtype=np.float64),
        confidences,
        np.asarray(right, dtype=bool),
    )


def _nees(
    estimates: Sequence[TrackEstimate],
    est: FloatArray,
    truth: FloatArray,
    sel: NDArray[np.bool_],
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The normalised estimation error squared of each selected frame's pose under its
    covariance (frames without a finite, positive-definite covariance left out), and over
    the same frames that of the position alone under the covariance's position block and
    that of the heading alone under its heading variance."""
    out: list[tuple[float, float, float]] = []
    for k in np.flatnonzero(sel).tolist():
        P = estimates[k].covariance
        if P is None:
            continue
        P = np.asarray(P, dtype=np.float64)
        if P.shape != (3, 3) or not np.isfinite(P).all():
            continue
        e = est[k] - truth[k]
        e[2] = float(wrap(e[2]))
        try:
            L = np.linalg.cholesky(0.5 * (P + P.T))
        except np.linalg.LinAlgError:
            continue
        z = np.linalg.solve(L, e)
        # (The position block's Cholesky factor is L's upper left block; the heading's
        # variance is positive with P.)
        zp = np.linalg.solve(L[:2, :2], e[:2])
        out.append((float(z @ z), float(zp @ zp), float(e[2] ** 2 / P[2, 2])))
    a = np.asarray(out, dtype=np.float64).reshape(-1, 3)
    return a[:, 0], a[:, 1], a[:, 2]


def _along_across(est: FloatArray, truth: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The position errors ``est - truth`` (rows ``x, y, theta``) along the true heading
    and across it (to the robot's left)."""
    d = est[:, :2] - truth[:, :2]
    c, s = np.cos(truth[:, 2]), np.sin(truth[:, 2])
    return d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c


def _weight_bins(
    estimates: Sequence[TrackEstimate],
    truth: FloatArray,
    scored: NDArray[np.bool_],
    pos_tol_m: float,
    heading_tol_deg: float,
) -> tuple[tuple[int, float, int], ...]:
    """The strongest hypothesis's weight against its correctness, per tenth of [0, 1]
    (:func:`~omniloc.evaluate.common.confidence_bins`)."""
    weights: list[float] = []
    right: list[bool] = []
    for k, e in enumerate(estimates):
        if not scored[k] or not e.hypotheses:
            continue
        h = max(e.hypotheses, key=lambda hyp: hyp.weight)
        d_pos = math.hypot(h.pose.x - truth[k, 0], h.pose.y - truth[k, 1])
        d_hdg = abs(math.degrees(float(wrap(h.pose.theta - truth[k, 2]))))
        weights.append(min(max(float(h.weight), 0.0), 1.0))
        right.append(d_pos <= pos_tol_m and d_hdg <= heading_tol_deg)
    n, total, ok = confidence_bins(weights, right, WEIGHT_BINS)
    return tuple((int(a), float(c), int(r)) for a, c, r in zip(n, total, ok, strict=True))


def weight_ece(bins: Sequence[Sequence[float]]) -> float:
    """Expected calibration error of binned weights ``(frames, sum of weights, correct)``
    (NaN without frames).

    Examples
    --------
    >>> round(weight_ece([(2, 1.8, 1), (2, 0.4, 0)]), 3)
    0.3
    """
    if not sum(int(b[0]) for b in bins):
        return NAN
    n, total, ok = zip(*bins, strict=True)
    return calibration_of_bins(n, total, ok).ece


def _bound_totals(rs: Sequence[RunScore], jumps: Sequence[RunScore]) -> dict[str, float]:
    """The bound's totals (:attr:`RunScore.bound_time_to_localize_s` and the rest): NaN
    unless every run has its bound; inf ("never") as in :func:`censored_median`."""
    have = bool(rs) and all(not math.isnan(r.bound_time_to_localize_s) for r in rs)
    ttl = [r.bound_time_to_localize_s for r in rs]
    after = [r.bound_correct_after_rate for r in rs if math.isfinite(r.bound_correct_after_rate)]
    rec = [r.bound_recovery_s for r in jumps]
    return {
        "bound_time_to_localize_median_s": censored_median(ttl) if have else NAN,
        "bound_time_to_localize_max_s": max(ttl) if have else NAN,
        "bound_correct_after_rate": float(np.mean(after)) if have and after else NAN,
        "bound_recovery_median_s": (
            censored_median(rec) if have and rec and not any(map(math.isnan, rec)) else NAN
        ),
    }


def _nanmedian(x: Sequence[float]) -> float:
    """The median of the finite values (NaN when there is none)."""
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if a.size else NAN


def censored_median(times: Sequence[float]) -> float:
    """The median time to an event over runs of which some never reached it.

    A run that never got there (NaN or inf) counts as later than every run that did, so
    the median is ``inf`` ("never") when half of the runs or more never got there; NaN
    without runs. Leaving such runs out instead would make a localizer that often fails
    look faster than one that always succeeds, a little later.

    Parameters
    ----------
    times : sequence of float
        Seconds to the event, one per run; NaN or inf for a run that never reached it.

    Returns
    -------
    float

    Raises
    ------
    InputError
        ``times`` not a flat sequence of numbers.

    Examples
    --------
    >>> censored_median([10.0, 20.0, float("nan")])
    20.0
    >>> censored_median([10.0, float("nan"), float("nan")])
    inf
    >>> censored_median([10.0, 20.0, 30.0, float("nan")])
    25.0
    """
    try:
        a = np.asarray(times, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"censored_median: times must be numbers, got {shorten(times)}") from exc
    if a.ndim != 1:
        raise InputError(f"censored_median: times must be a flat sequence, got shape {a.shape}")
    if a.size == 0:
        return NAN
    a = np.where(np.isfinite(a), a, math.inf)
    return float(np.median(a))


@dataclass(frozen=True)
class TrackingResult:
    """Scores of a localizer over a set of streams, with the totals the targets read."""

    name: str
    runs: list[RunScore] = field(repr=False)
    pos_tol_m: float = 0.3
    heading_tol_deg: float = 5.0
    #: What the bound beside the localizer assumed of the bearing errors, in words (the
    #: ``model`` of :func:`evaluate_tracking`'s ``bound``; empty: no bound, or not said).
    bound_model: str = ""

    def _sel(self, kidnapped: bool | None) -> list[RunScore]:
        if kidnapped is None:
            return self.runs
        return [r for r in self.runs if math.isfinite(r.jump_t) == kidnapped]

    def totals(self, kidnapped: bool | None = None) -> dict[str, float]:
        """Aggregates over the runs (``kidnapped``: only streams with / without a jump).

        The median times (``time_to_localize_median_s``, ``detection_delay_median_s``,
        ``recovery_median_s``) count a run that never got there as later than any that did
        (:func:`censored_median`: ``inf``, "never", when half of the runs or more never
        did); the same keys ending ``_localized_s``, ``_detected_s`` and ``_recovered_s``
        are the medians over the runs that got there, beside the counts of those that did
        not (``never_localized``, ``undetected``, ``unrecovered``)."""
        rs = self._sel(kidnapped)
        scored = sum(r.n_scored for r in rs)
        loc = sum(r.n_localized for r in rs)
        wrong = sum(r.n_confidently_wrong for r in rs)
        n_after = sum(r.n_after for r in rs)
        ttl = [r.time_to_localize_s for r in rs]

        def pooled(attr: str) -> float:
            num = sum(getattr(r, attr) ** 2 * r.n_localized for r in rs if r.n_localized)
            return math.sqrt(num / loc) if loc else NAN

        def mean_over_localized(attr: str) -> float:
            num = sum(getattr(r, attr) * r.n_localized for r in rs if r.n_localized)
            return num / loc if loc else NAN

        after = [r.correct_after_rate for r in rs if math.isfinite(r.correct_after_rate)]
        jumps = [r for r in rs if math.isfinite(r.jump_t)]
        plain = [r for r in rs if not math.isfinite(r.jump_t)]
        flags = [r.flag_delay_s for r in jumps if not math.isnan(r.flag_delay_s)]
        cpu = sum(r.cpu_s for r in rs)
        cov = sum(r.cov_frames for r in rs)
        dur = sum(r.duration_s for r in rs)

        def pooled_bins(attr: str) -> list[tuple[float, ...]]:
            return [
                tuple(
                    sum(float(getattr(r, attr)[b][i]) for r in rs if getattr(r, attr))
                    for i in range(3)
                )
                for b in range(WEIGHT_BINS)
            ]

        bins = pooled_bins("weight_bins")
        own = {name: pooled_bins(f"{name}_bins") for name in _OWN_BINS}
        return {
            "runs": float(len(rs)),
            "frames_scored": float(scored),
            "localized_frames": float(loc),
            "time_to_localize_median_s": censored_median(ttl),
            "time_to_localize_median_localized_s": _nanmedian(ttl),
            "time_to_localize_max_s": max(ttl) if ttl and all(map(math.isfinite, ttl)) else NAN,
            "never_localized": float(sum(not math.isfinite(x) for x in ttl)),
            "correct_after_rate": float(np.mean(after)) if after else NAN,
            "correct_after_pooled_rate": (
                sum(r.n_correct_after for r in rs) / n_after if n_after else NAN
            ),
            "localized_rate": loc / scored if scored else NAN,
            "confidently_wrong_rate": wrong / scored if scored else NAN,
            "pos_rmse_m": pooled("pos_rmse_m"),
            "heading_rmse_deg": pooled("heading_rmse_deg"),
            "detection_delay_median_s": censored_median([r.detection_delay_s for r in jumps]),
            "detection_delay_median_detected_s": _nanmedian([r.detection_delay_s for r in jumps]),
            "undetected": float(sum(not math.isfinite(r.detection_delay_s) for r in jumps)),
            "recovery_median_s": censored_median([r.recovery_s for r in jumps]),
            "recovery_median_recovered_s": _nanmedian([r.recovery_s for r in jumps]),
            "unrecovered": float(sum(not math.isfinite(r.recovery_s) for r in jumps)),
            "false_alarm_run_rate": (
                sum(r.false_alarms > 0 for r in plain) / len(plain) if plain else NAN
            ),
            "false_alarm_left_right_run_rate": (
                sum(r.false_alarms_left_right > 0 for r in plain) / len(plain) if plain else NAN
            ),
            "localized_at_jump": float(len(flags)),
            "kidnaps_flagged": float(sum(math.isfinite(x) for x in flags)),
            "flag_delay_median_s": censored_median(flags),
            "flag_delay_median_flagged_s": _nanmedian(flags),
            "realtime_factor": dur / cpu if cpu > 0 else NAN,
            "best_weight_frames": float(sum(b[0] for b in bins)),
            "best_weight_ece": weight_ece(bins),
            **{
                key: value
                for name, b in own.items()
                for key, value in (
                    (f"{name}_frames", float(sum(x[0] for x in b))),
                    (f"{name}_ece", weight_ece(b)),
                )
            },
            "cov_frames": float(cov),
            "cov_inside_50_rate": sum(r.cov_inside_50 for r in rs) / cov if cov else NAN,
            "cov_inside_99_rate": sum(r.cov_inside_99 for r in rs) / cov if cov else NAN,
            "cov_position_inside_99_rate": (
                sum(r.cov_position_inside_99 for r in rs) / cov if cov else NAN
            ),
            "cov_heading_inside_99_rate": (
                sum(r.cov_heading_inside_99 for r in rs) / cov if cov else NAN
            ),
            "along_mean_m": mean_over_localized("along_mean_m"),
            "along_rmse_m": pooled("along_rmse_m"),
            "across_mean_m": mean_over_localized("across_mean_m"),
            "across_rmse_m": pooled("across_rmse_m"),
            **_bound_totals(rs, jumps),
        }

    def to_csv(self, path: str | Path) -> None:
        """Write one row per run."""
        _write_runs_csv(path, self.runs)

    def as_dict(self) -> dict[str, object]:
        """Plain-JSON totals (all, whole runs, kidnapped) and the runs."""
        return {
            "name": self.name,
            "pos_tol_m": self.pos_tol_m,
            "heading_tol_deg": self.heading_tol_deg,
            "bound_model": self.bound_model,
            "totals": {k: jsonable(v) for k, v in self.totals().items()},
            "totals_without_jump": {k: jsonable(v) for k, v in self.totals(False).items()},
            "totals_kidnapped": {k: jsonable(v) for k, v in self.totals(True).items()},
            "runs": [{k: jsonable(v) for k, v in asdict(r).items()} for r in self.runs],
        }


def evaluate_tracking(
    streams: Sequence[Stream],
    make_localizer: Callable[[LandmarkMap, Pose | None], LocalizerOverTime],
    *,
    name: str = "tracker",
    oracle_start: bool = False,
    progress: bool = True,
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
    bound: Callable[[Stream], StreamBound] | None = None,
    offline: Callable[[Stream, list[TrackEstimate]], list[TrackEstimate]] | None = None,
) -> tuple[TrackingResult, list[list[TrackEstimate]]]:
    """Run a localizer over time on every stream and score it.

    ``make_localizer(landmarks, start)`` builds a fresh localizer per stream; ``start`` is
    the true pose at the stream's start only when ``oracle_start`` is True (for a baseline
    started at the truth), else None. ``bound(stream)``, when given, says what the data
    allow on each stream (:func:`mrclam_bound`), scored beside the localizer
    (:attr:`RunScore.bound_time_to_localize_s` and the rest; its ``model`` attribute, if
    any, says in words what it assumed: :attr:`TrackingResult.bound_model`). ``offline(stream,
    estimates)``, when given, turns the localizer's estimates into those scored, with the
    whole stream known (:func:`backward_offline`); its processor time is counted. Returns
    the scores and every estimate.
    """
    runs: list[RunScore] = []
    all_est: list[list[TrackEstimate]] = []
    bar = progress_bar(len(streams), progress, f"tracking {name}")
    try:
        for s in streams:
            start = None
            if oracle_start:
                p, _ = s.truth_at(s.start)
                start = Pose.from_array(p[0])
            est, cpu = run_stream(make_localizer(s.landmarks, start), s)
            if offline is not None:
                c0 = time.process_time()
                est = offline(s, est)
                cpu += time.process_time() - c0
            score = score_run(
                s, est, cpu_s=cpu, pos_tol_m=pos_tol_m, heading_tol_deg=heading_tol_deg
            )
            if bound is not None:
                b = bound(s)
                score = replace(
                    score,
                    bound_time_to_localize_s=b.time_to_localize_s,
                    bound_correct_after_rate=b.correct_after_rate,
                    bound_recovery_s=b.recovery_s,
                )
            runs.append(score)
            all_est.append(est)
            bar.update(1)
    finally:
        bar.close()
    model = "" if bound is None else str(getattr(bound, "model", ""))
    return TrackingResult(name, runs, pos_tol_m, heading_tol_deg, model), all_est


def mrclam_streams(path: str | Path, robots: Sequence[int] = (1, 2, 3, 4, 5)) -> list[Stream]:
    """Each robot's whole run of the MRCLAM folder ``path`` as a stream (frames carry the
    true landmark rows in :attr:`Frame.truth`, for baselines with known correspondences)."""
    from ..track.data import load_frames, load_groundtruth, load_odometry

    folder = Path(path)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder (the MRCLAM dataset folder)")
    lm_path = folder / "landmarks.csv"
    if not lm_path.is_file():
        raise InputError(f"{lm_path}: no such file (the MRCLAM landmarks)")
    lm = LandmarkMap.from_csv(lm_path)
    rows = {str(i): k for k, i in enumerate(lm.ids)}
    out = []
    for r in robots:
        name = f"robot{r}"
        odo = load_odometry(folder / f"{name}_odometry.csv")
        frames = load_frames(folder / f"{name}_frames.csv", landmark_ids=rows)
        truth = load_groundtruth(folder / f"{name}_groundtruth_10hz.csv")
        out.append(whole_run(name, lm, odo, frames, truth))
    return out


# --------------------------------------------------------------------------------------------
# The omniloc tracker on MRCLAM: whole runs and kidnappings, one report
# --------------------------------------------------------------------------------------------


def errors_against(
    truth: GroundTruth,
    estimates: Sequence[TrackEstimate],
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
) -> tuple[NDArray[np.bool_], FloatArray, FloatArray]:
    """Per estimate: within tolerance of the truth (any state), position error (m) and
    heading error (deg); NaN errors where there is no pose or no truth."""
    t = np.array([e.t for e in estimates], dtype=np.float64)
    true, _ = truth.at(t) if t.size else (np.zeros((0, 3)), np.zeros(0))
    _, d_pos, d_hdg, ok = _pose_errors(estimates, true, pos_tol_m, heading_tol_deg)
    return ok, d_pos, d_hdg


def tracker_factory(
    preset_name: str = "mrclam",
    settings: Mapping[str, Any] | None = None,
) -> Callable[[LandmarkMap, Pose | None], LocalizerOverTime]:
    """``make_localizer`` for :func:`evaluate_tracking`: a fresh
    :class:`~omniloc.track.Tracker` with a named preset's parameters, changed by
    ``settings`` (:func:`~omniloc.track.with_settings`; the start pose, even when given, is
    not used: the tracker localizes globally)."""
    from ..track.tracker import Tracker

    sensor, motion, config = _preset_models(preset_name, settings)

    def make(landmarks: LandmarkMap, start: Pose | None) -> LocalizerOverTime:
        return Tracker(landmarks, sensor, motion, config)

    return make


def backward_offline(
    horizon_s: float,
    preset_name: str = "mrclam",
    settings: Mapping[str, Any] | None = None,
    confirm_s: float | None = None,
    told_scale: float | None = None,
) -> Callable[[Stream, list[TrackEstimate]], list[TrackEstimate]]:
    """``offline`` for :func:`evaluate_tracking`: the tracker's second pass backward in time
    (:mod:`omniloc.track.backward`) over the frames within ``horizon_s`` before a sure frame,
    with a named preset's parameters changed by ``settings`` (those of
    :func:`tracker_factory`'s trackers), as ``track(..., backward_s=horizon_s)`` runs it
    (:func:`~omniloc.track.backward.refine`); ``confirm_s``: how long the forward pass must
    hold a place for it to stay localized and start the pass, ``told_scale``: the factor on
    the covariance it is told (None: their defaults)."""
    from ..track.backward import CONFIRM_S, TOLD_SCALE, refine

    h = finite_number(horizon_s, "the pass backward's horizon")
    if h < 0.0:
        raise InputError(f"the pass backward's horizon must be seconds >= 0, got {horizon_s!r}")
    sensor, motion, config = _preset_models(preset_name, settings)
    keep = CONFIRM_S if confirm_s is None else finite_number(confirm_s, "confirm_s")
    if keep < 0.0:
        raise InputError(f"confirm_s must be seconds >= 0, got {confirm_s!r}")

    def run(stream: Stream, estimates: list[TrackEstimate]) -> list[TrackEstimate]:
        return refine(
            stream.landmarks,
            stream.odometry,
            stream.frames,
            estimates,
            horizon_s=h,
            sensor=sensor,
            motion=motion,
            config=config,
            confirm_s=keep,
            told_scale=TOLD_SCALE if told_scale is None else told_scale,
        )

    return run


def _preset_models(
    preset_name: str, settings: Mapping[str, Any] | None
) -> tuple[SensorModel, MotionModel, TrackerConfig]:
    """A named preset's sensor, motion and tracker configuration, changed by ``settings``."""
    from ..track.presets import preset, with_settings

    sensor, motion, config = preset(preset_name)
    if settings:
        sensor, motion, config = with_settings(sensor, motion, config, settings)
    return sensor, motion, config


def mrclam_bound(
    p_min: float = 0.99,
    *,
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
    repeat: RepeatingErrors | None = MRCLAM_REPEATING,
) -> Callable[[Stream], StreamBound]:
    """``bound`` for :func:`evaluate_tracking` on MRCLAM streams: what a localizer told the
    correspondences could do (:func:`omniloc.evaluate.bounds.stream_bound`), with the
    recordings' odometry noise (:meth:`~omniloc.track.MotionModel.mrclam`), their measured
    bearing errors (:data:`~omniloc.evaluate.bounds.MRCLAM_BEARING_ERRORS`), repeating as
    measured -- most of each error shared by the tubes a frame sees (``repeat``,
    :data:`~omniloc.evaluate.bounds.MRCLAM_REPEATING`; None: independent from frame to
    frame) -- and a localizer that says
    ``localized`` when it is within tolerance with probability ``p_min``."""
    from ..track.motion import MotionModel

    return _MrclamBound(
        MotionModel.mrclam(),
        bearing_information(*MRCLAM_BEARING_ERRORS),
        p_min,
        pos_tol_m,
        math.radians(heading_tol_deg),
        repeat,
    )


@dataclass(frozen=True)
class _MrclamBound:
    """:func:`mrclam_bound`'s bound: called on a stream, with ``model`` saying in words what
    it assumed of the bearing errors."""

    motion: MotionModel
    info: float
    p_min: float
    tol_m: float
    tol_heading: float
    repeat: RepeatingErrors | None

    @property
    def model(self) -> str:
        if self.repeat is None or not self.repeat.repeats:
            return "the measured bearing errors, independent from frame to frame"
        return f"the measured bearing errors, {self.repeat.describe()}"

    def __call__(self, stream: Stream) -> StreamBound:
        return stream_bound(
            stream,
            self.motion,
            self.info,
            self.p_min,
            tol_m=self.tol_m,
            tol_heading=self.tol_heading,
            repeat=self.repeat,
        )


@dataclass(frozen=True)
class TrackingReport:
    """The tracker on MRCLAM: the whole runs, and the kidnapped streams with the same
    segments without a jump."""

    whole: TrackingResult
    kidnap: TrackingResult | None = None

    def as_dict(self) -> dict[str, object]:
        """Plain JSON."""
        return {
            "whole_runs": self.whole.as_dict(),
            "kidnap_streams": None if self.kidnap is None else self.kidnap.as_dict(),
        }

    def to_csv(self, path: str | Path) -> None:
        """One row per stream (whole runs, then kidnap streams)."""
        runs = list(self.whole.runs) + ([] if self.kidnap is None else list(self.kidnap.runs))
        _write_runs_csv(path, runs)


def evaluate_mrclam_tracking(
    path: str | Path,
    *,
    kidnapped: int = 100,
    rng: RngLike = 0,
    robots: Sequence[int] = (1, 2, 3, 4, 5),
    preset_name: str = "mrclam",
    settings: Mapping[str, Any] | None = None,
    progress: bool = True,
    backward_s: float | None = None,
) -> tuple[TrackingReport, list[list[TrackEstimate]]]:
    """Run the :class:`~omniloc.track.Tracker` on MRCLAM: each robot's whole run, and
    ``kidnapped`` kidnapped streams with as many without a jump (:func:`kidnap_streams`,
    seeded by ``rng``), with a preset's parameters changed by ``settings`` (names of
    :func:`~omniloc.track.with_settings`); ``backward_s``: with the second pass backward in
    time over the frames within that many seconds before a sure frame
    (:func:`backward_offline`; offline, every stream known in full). Returns the report and
    every estimate (whole runs first)."""
    if isinstance(kidnapped, bool) or not isinstance(kidnapped, (int, np.integer)) or kidnapped < 0:
        raise InputError(f"kidnapped must be an integer >= 0, got {kidnapped!r}")
    make = tracker_factory(preset_name, settings)  # bad settings: refused before the data
    bound = mrclam_bound(
        float(_preset_models(preset_name, settings)[2].localized_probability),
        pos_tol_m=0.3,
        heading_tol_deg=5.0,
    )
    offline = None if backward_s is None else backward_offline(backward_s, preset_name, settings)
    # (The pass backward is offline: its reports say so.)
    who = "tracker" if backward_s is None else f"tracker with the pass backward ({backward_s:g} s)"
    runs = mrclam_streams(path, robots)
    whole, est = evaluate_tracking(
        runs, make, name=f"{who}: whole runs", progress=progress, bound=bound, offline=offline
    )
    kid = None
    if kidnapped:
        jumps, plain = kidnap_streams(runs, int(kidnapped), rng=rng)
        kid, est_k = evaluate_tracking(
            jumps + plain,
            make,
            name=f"{who}: kidnap streams",
            progress=progress,
            bound=bound,
            offline=offline,
        )
        est = est + est_k
    return TrackingReport(whole, kid), est


def _fmt(v: float, spec: str = ".2f", none: str = "-") -> str:
    """``v`` formatted by ``spec``, or ``none`` (padded to the spec's width) when it is not
    a finite number: a run never localized has no time to localize and no RMSE."""
    if math.isfinite(v):
        return format(v, spec)
    width = spec.split(".")[0]
    return none.rjust(int(width)) if width.isdigit() else none


def _seconds(v: float) -> str:
    """A median time: ``"12.3 s"``, ``"never"`` (inf) or ``"-"`` (NaN)."""
    return f"{v:.1f} s" if math.isfinite(v) else ("never" if v == math.inf else "-")


def _of_those(n: int, what: str, median: float) -> str:
    """``"; the 3 localized: median 149.8 s"`` -- the median over the runs that got there,
    said beside the count of those that did not (nothing when all or none got there)."""
    if n <= 0 or not math.isfinite(median):
        return ""
    return f"; the {n} {what}: median {median:.1f} s"


def tracking_summary(report: TrackingReport | TrackingResult) -> str:
    """Plain-text table of the runs and the totals that the targets read."""
    if isinstance(report, TrackingResult):
        report = TrackingReport(report)
    w = report.whole
    lines = [
        f"{w.name}: correct = localized and within {w.pos_tol_m} m / {w.heading_tol_deg} deg",
        "run        time to localize  correct after  localized  conf. wrong  pos RMSE  hdg RMSE"
        "  CPU x real time",
    ]
    for r in w.runs:
        lines.append(
            f"{r.name:<10} {_fmt(r.time_to_localize_s, '13.1f', 'never')}"
            f"{' s' if math.isfinite(r.time_to_localize_s) else '  '}  "
            f"{_fmt(100 * r.correct_after_rate, '11.1f')} %"
            f"  {r.n_localized:5d}/{r.n_scored:<5d} {r.n_confidently_wrong:8d}"
            f"  {_fmt(r.pos_rmse_m, '6.3f')} m {_fmt(r.heading_rmse_deg, '6.2f')} deg"
            f"  {_fmt(r.realtime_factor, '8.0f')}x"
        )
    tot = w.totals()
    never = int(tot["never_localized"])
    worst = (
        f"max {_fmt(tot['time_to_localize_max_s'], '.1f')} s"
        if not never
        else f"never on {never} of {len(w.runs)} run{'s' if len(w.runs) != 1 else ''}"
        + _of_those(len(w.runs) - never, "localized", tot["time_to_localize_median_localized_s"])
    )
    lines.append(
        f"all runs: time to localize median {_seconds(tot['time_to_localize_median_s'])}, "
        f"{worst}; correct after "
        f"{_fmt(100 * tot['correct_after_rate'], '.1f')} % (mean over runs; "
        f"{_fmt(100 * tot['correct_after_pooled_rate'], '.1f')} % of their frames); "
        "confidently wrong "
        f"{_fmt(100 * tot['confidently_wrong_rate'], '.2f')} % of frames; position RMSE "
        f"{_fmt(tot['pos_rmse_m'], '.3f')} m, heading RMSE {_fmt(tot['heading_rmse_deg'])} deg; "
        f"{_fmt(tot['realtime_factor'], '.0f')}x real time"
    )
    if not math.isnan(tot["bound_time_to_localize_max_s"]):
        lines.append(
            "what the data allow (a localizer told the correspondences, as sure as localized "
            f"asks{'; ' + w.bound_model if w.bound_model else ''}): first possible after a "
            "median of "
            f"{_seconds(tot['bound_time_to_localize_median_s'])} (max "
            f"{_seconds(tot['bound_time_to_localize_max_s'])}), then in "
            f"{_fmt(100 * tot['bound_correct_after_rate'], '.1f')} % of the frames"
        )
    lines.append(
        f"strongest hypothesis's weight against the truth ({int(tot['best_weight_frames'])} "
        f"frames with hypotheses): expected calibration error {_fmt(tot['best_weight_ece'], '.3f')}"
    )
    if tot.get("probability_frames"):
        conf = (
            f"; its confidence (the probability mapped by the configuration's tables), "
            f"{_fmt(tot['confidence_ece'], '.3f')} over {int(tot['confidence_frames'])} frames"
            if tot.get("confidence_frames")
            else "; no confidence tables given"
        )
        lines.append(
            f"the localizer's own probability that its pose is within tolerance against the "
            f"truth ({int(tot['probability_frames'])} frames): expected calibration error "
            f"{_fmt(tot['probability_ece'], '.3f')}{conf}"
        )
    if tot.get("hypothesis_weight_frames"):
        hconf = (
            f", of their confidence {_fmt(tot['hypothesis_confidence_ece'], '.3f')}"
            if tot.get("hypothesis_confidence_frames")
            else ""
        )
        lines.append(
            f"every reported hypothesis against the truth "
            f"({int(tot['hypothesis_weight_frames'])}): expected calibration error of their "
            f"weights {_fmt(tot['hypothesis_weight_ece'], '.3f')}{hconf}"
        )
    if tot["cov_frames"]:
        lines.append(
            f"reported covariance over {int(tot['cov_frames'])} localized frames: the truth "
            f"inside its 50 % region in {_fmt(100 * tot['cov_inside_50_rate'], '.1f')} %, its "
            f"99 % region in {_fmt(100 * tot['cov_inside_99_rate'], '.1f')} % (consistent: 50 %"
            ", 99 %); the position alone inside the 99 % region of its block in "
            f"{_fmt(100 * tot['cov_position_inside_99_rate'], '.1f')} %, the heading alone in "
            f"{_fmt(100 * tot['cov_heading_inside_99_rate'], '.1f')} %"
        )
    if tot["localized_frames"]:
        lines.append(
            f"position error over the localized frames along the robot's heading: mean "
            f"{_fmt(tot['along_mean_m'], '+.3f')} m (ahead +), RMSE "
            f"{_fmt(tot['along_rmse_m'], '.3f')} m; across it: mean "
            f"{_fmt(tot['across_mean_m'], '+.3f')} m (left +), RMSE "
            f"{_fmt(tot['across_rmse_m'], '.3f')} m"
        )
    if report.kidnap is not None:
        k = report.kidnap
        tj = k.totals(True)
        tp = k.totals(False)
        lines.append(
            f"kidnapped streams ({int(tj['runs'])}): detection delay median "
            f"{_seconds(tj['detection_delay_median_s'])} ({int(tj['undetected'])} undetected"
            + _of_those(
                int(tj["runs"] - tj["undetected"]) if tj["undetected"] else 0,
                "detected",
                tj["detection_delay_median_detected_s"],
            )
            + f"), recovery median {_seconds(tj['recovery_median_s'])} "
            f"({int(tj['unrecovered'])} not recovered"
            + _of_those(
                int(tj["runs"] - tj["unrecovered"]) if tj["unrecovered"] else 0,
                "recovered",
                tj["recovery_median_recovered_s"],
            )
            + f"); confidently wrong {_fmt(100 * tj['confidently_wrong_rate'], '.2f')} %"
            + (
                f"; localized when carried off in {int(tj['localized_at_jump'])}: the "
                f"kidnapping flagged in {int(tj['kidnaps_flagged'])}"
                + (
                    f", a median of {_seconds(tj['flag_delay_median_flagged_s'])} after the jump"
                    if tj["kidnaps_flagged"]
                    else ""
                )
                if tj["localized_at_jump"]
                else ""
            )
            + (
                f"; told the correspondences, right again after a median of "
                f"{_seconds(tj['bound_recovery_median_s'])} at best"
                if not math.isnan(tj["bound_recovery_median_s"])
                else ""
            )
            + _calibration_note(tj)
        )
        lines.append(
            f"same segments without a jump ({int(tp['runs'])}): false alarm on "
            f"{_fmt(100 * tp['false_alarm_run_rate'], '.1f')} % of runs"
            + (
                f" (leaving a place that was right: "
                f"{_fmt(100 * tp['false_alarm_left_right_run_rate'], '.1f')} %; the others left "
                "a wrong one)"
                if tp["false_alarm_run_rate"] > 0
                else ""
            )
            + "; confidently wrong "
            f"{_fmt(100 * tp['confidently_wrong_rate'], '.2f')} %; time to localize median "
            f"{_seconds(tp['time_to_localize_median_s'])} ({int(tp['never_localized'])} never"
            + _of_those(
                int(tp["runs"] - tp["never_localized"]) if tp["never_localized"] else 0,
                "localized",
                tp["time_to_localize_median_localized_s"],
            )
            + ")"
            + _calibration_note(tp)
        )
    return "\n".join(lines)


def _calibration_note(tot: Mapping[str, float]) -> str:
    """``; ECE of the probability X, of the confidence Y`` for a summary line (empty when
    the localizer reports neither)."""
    if not tot.get("probability_frames"):
        return ""
    conf = (
        f", of its confidence {_fmt(tot['confidence_ece'], '.3f')}"
        if tot.get("confidence_frames")
        else ""
    )
    own = _fmt(tot["probability_ece"], ".3f")
    return f"; expected calibration error of its own probability {own}{conf}"


#: The figures :func:`seed_spread` compares across draws: (name, where, key of
#: :meth:`TrackingResult.totals`, kidnapped selection, scale, unit, format).
SPREAD_FIGURES: tuple[tuple[str, str, str, bool | None, float, str, str], ...] = (
    ("localized frames", "whole", "localized_frames", None, 1.0, "", ".0f"),
    ("confidently wrong", "whole", "confidently_wrong_rate", None, 100.0, "%", ".2f"),
    ("first correct, median", "whole", "time_to_localize_median_s", None, 1.0, "s", ".1f"),
    ("correct after (mean over runs)", "whole", "correct_after_rate", None, 100.0, "%", ".1f"),
    ("position RMSE", "whole", "pos_rmse_m", None, 1.0, "m", ".3f"),
    ("weight ECE", "whole", "best_weight_ece", None, 1.0, "", ".3f"),
    ("probability ECE", "whole", "probability_ece", None, 1.0, "", ".3f"),
    ("confidence ECE", "whole", "confidence_ece", None, 1.0, "", ".3f"),
    ("kidnapped: confidently wrong", "kidnap", "confidently_wrong_rate", True, 100.0, "%", ".2f"),
    ("kidnapped: recovered", "kidnap", "recovered", True, 1.0, "", ".0f"),
    ("kidnapped: recovery, median", "kidnap", "recovery_median_s", True, 1.0, "s", ".1f"),
    ("plain: confidently wrong", "kidnap", "confidently_wrong_rate", False, 100.0, "%", ".2f"),
    ("plain: false alarms", "kidnap", "false_alarm_run_rate", False, 100.0, "%", ".1f"),
    (
        "plain: false alarms leaving a right place",
        "kidnap",
        "false_alarm_left_right_run_rate",
        False,
        100.0,
        "%",
        ".1f",
    ),
)


def seed_spread(reports: Mapping[int, TrackingReport]) -> dict[str, dict[str, Any]]:
    """The tracker's figures under several seeds of its random particles
    (``TrackerConfig.seed``), side by side: how much of a result is the luck of the draw.

    Parameters
    ----------
    reports : mapping of int to TrackingReport
        One report per seed, on the same streams.

    Returns
    -------
    dict
        For each figure of :data:`SPREAD_FIGURES` that every report has: ``unit``,
        ``format`` (how :func:`seed_spread_table` prints it), the value under each seed
        (``by_seed``, in the order given; NaN where a figure has no value, inf where a
        median time is "never"), and its ``min`` and ``max`` over the seeds (NaN when none
        has a value).

    Raises
    ------
    InputError
        No report, or a key that is not an integer seed.
    """
    if not reports:
        raise InputError("seed_spread needs at least one report")
    for seed in reports:
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise InputError(f"seed_spread: seeds must be integers, got {seed!r}")
    out: dict[str, dict[str, Any]] = {}
    for name, where, key, kidnapped, scale, unit, spec in SPREAD_FIGURES:
        values: dict[int, float] = {}
        for seed, rep in reports.items():
            res = rep.whole if where == "whole" else rep.kidnap
            if res is None:
                break
            tot = res.totals(kidnapped)
            if key == "recovered":
                v = tot["runs"] - tot["unrecovered"]
            else:
                v = tot[key] * scale
            values[int(seed)] = v
        else:
            # (inf, "never", is a value: a median over runs half of which never got there.)
            known = [v for v in values.values() if not math.isnan(v)]
            out[name] = {
                "unit": unit,
                "format": spec,
                "by_seed": values,
                "min": min(known) if known else NAN,
                "max": max(known) if known else NAN,
            }
    return out


def _median_cell(v: float, spec: str) -> str:
    """A figure of :func:`seed_spread`: inf (a median time) is "never"."""
    return _fmt(v, spec, "never" if v == math.inf else "-")


def seed_spread_table(spread: Mapping[str, Mapping[str, Any]]) -> str:
    """Markdown table of :func:`seed_spread`: a row per figure, a column per seed, and the
    range."""
    if not spread:
        return ""
    seeds = list(next(iter(spread.values()))["by_seed"])
    head = "| figure | " + " | ".join(f"seed {s}" for s in seeds) + " | range |"
    rule = "|---" * (len(seeds) + 2) + "|"
    rows = [head, rule]
    for name, fig in spread.items():
        spec = fig["format"]
        label = f"{name} ({fig['unit']})" if fig["unit"] else name
        cells = " | ".join(_median_cell(fig["by_seed"][s], spec) for s in seeds)
        rows.append(
            f"| {label} | {cells} | {_median_cell(fig['min'], spec)}-"
            f"{_median_cell(fig['max'], spec)} |"
        )
    return "\n".join(rows)
