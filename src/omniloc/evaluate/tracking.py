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
* *time to localize*: from the start of the stream to its first correct frame.
* *localized and correct after*: the share of frames from the first correct frame on that
  are correct.
* *confidently wrong*: frames whose state is ``localized`` but whose pose is not correct.
* *RMSE*: position and heading errors over the ``localized`` frames.
* *kidnapping*: at ``jump_t`` the stream continues elsewhere. *Detection delay*: from the jump
  to the first frame that is no longer localized-and-wrong (the localizer left ``localized``,
  flagged ``kidnapped``, or is already right again). *Recovery*: from the jump to the first
  correct frame. A *false alarm* is a frame flagged ``kidnapped`` where no kidnapping
  happened (a stream without a jump, or before its jump).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..maps import LandmarkMap
from ..pose import Pose
from ..track.data import Frame, GroundTruth, Odometry
from ..track.records import TrackEstimate, TrackState
from .common import NAN, jsonable, progress_bar, write_records_csv

__all__ = [
    "LocalizerOverTime",
    "RunScore",
    "Stream",
    "TrackingResult",
    "evaluate_tracking",
    "run_stream",
    "score_run",
    "splice",
]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None

#: Ground truth whose samples are further apart than this (s) is not trusted for scoring.
MAX_GAP_S = 0.5


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
    (process time, seconds) it took."""
    o = stream.odometry
    out: list[TrackEstimate] = []
    k = 0
    c0 = time.process_time()
    for f in stream.frames:
        k1 = int(np.searchsorted(o.t, f.t, side="right"))
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

    @property
    def realtime_factor(self) -> float:
        """Seconds of recording processed per CPU second."""
        return self.duration_s / self.cpu_s if self.cpu_s > 0 else math.inf


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
    truth, gap = stream.truth_at(t) if t.size else (np.zeros((0, 3)), np.zeros(0))
    scored = np.isfinite(truth).all(axis=1) & (gap <= max_gap_s)
    loc = np.array([e.state is TrackState.LOCALIZED for e in estimates], dtype=bool)
    est = np.array(
        [e.pose.as_array() if e.pose is not None else (np.nan,) * 3 for e in estimates]
    ).reshape(-1, 3)
    d_pos = np.hypot(est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1])
    d_hdg = np.degrees(np.abs((est[:, 2] - truth[:, 2] + np.pi) % (2 * np.pi) - np.pi))
    with np.errstate(invalid="ignore"):
        right = (d_pos <= pos_tol_m) & (d_hdg <= heading_tol_deg)
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
        cpu_s=cpu_s,
    )


def _nanmedian(x: Sequence[float]) -> float:
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if a.size else NAN


@dataclass(frozen=True)
class TrackingResult:
    """Scores of a localizer over a set of streams, with the totals the targets read."""

    name: str
    runs: list[RunScore] = field(repr=False)
    pos_tol_m: float = 0.3
    heading_tol_deg: float = 5.0

    def _sel(self, kidnapped: bool | None) -> list[RunScore]:
        if kidnapped is None:
            return self.runs
        return [r for r in self.runs if math.isfinite(r.jump_t) == kidnapped]

    def totals(self, kidnapped: bool | None = None) -> dict[str, float]:
        """Aggregates over the runs (``kidnapped``: only streams with / without a jump)."""
        rs = self._sel(kidnapped)
        scored = sum(r.n_scored for r in rs)
        loc = sum(r.n_localized for r in rs)
        wrong = sum(r.n_confidently_wrong for r in rs)
        ttl = [r.time_to_localize_s for r in rs]

        def pooled(attr: str) -> float:
            num = sum(getattr(r, attr) ** 2 * r.n_localized for r in rs if r.n_localized)
            return math.sqrt(num / loc) if loc else NAN

        after = [r.correct_after_rate for r in rs if math.isfinite(r.correct_after_rate)]
        jumps = [r for r in rs if math.isfinite(r.jump_t)]
        plain = [r for r in rs if not math.isfinite(r.jump_t)]
        cpu = sum(r.cpu_s for r in rs)
        dur = sum(r.duration_s for r in rs)
        return {
            "runs": float(len(rs)),
            "frames_scored": float(scored),
            "time_to_localize_median_s": _nanmedian(ttl),
            "time_to_localize_max_s": max(ttl) if ttl and all(map(math.isfinite, ttl)) else NAN,
            "never_localized": float(sum(not math.isfinite(x) for x in ttl)),
            "correct_after_rate": float(np.mean(after)) if after else NAN,
            "localized_rate": loc / scored if scored else NAN,
            "confidently_wrong_rate": wrong / scored if scored else NAN,
            "pos_rmse_m": pooled("pos_rmse_m"),
            "heading_rmse_deg": pooled("heading_rmse_deg"),
            "detection_delay_median_s": _nanmedian([r.detection_delay_s for r in jumps]),
            "undetected": float(sum(not math.isfinite(r.detection_delay_s) for r in jumps)),
            "recovery_median_s": _nanmedian([r.recovery_s for r in jumps]),
            "unrecovered": float(sum(not math.isfinite(r.recovery_s) for r in jumps)),
            "false_alarm_run_rate": (
                sum(r.false_alarms > 0 for r in plain) / len(plain) if plain else NAN
            ),
            "realtime_factor": dur / cpu if cpu > 0 else NAN,
        }

    def to_csv(self, path: str | Path) -> None:
        """Write one row per run."""
        write_records_csv(Path(path), self.runs)

    def as_dict(self) -> dict[str, object]:
        """Plain-JSON totals (all, whole runs, kidnapped) and the runs."""
        return {
            "name": self.name,
            "pos_tol_m": self.pos_tol_m,
            "heading_tol_deg": self.heading_tol_deg,
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
) -> tuple[TrackingResult, list[list[TrackEstimate]]]:
    """Run a localizer over time on every stream and score it.

    ``make_localizer(landmarks, start)`` builds a fresh localizer per stream; ``start`` is
    the true pose at the stream's start only when ``oracle_start`` is True (for a baseline
    started at the truth), else None. Returns the scores and every estimate.
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
            runs.append(
                score_run(s, est, cpu_s=cpu, pos_tol_m=pos_tol_m, heading_tol_deg=heading_tol_deg)
            )
            all_est.append(est)
            bar.update(1)
    finally:
        bar.close()
    return TrackingResult(name, runs, pos_tol_m, heading_tol_deg), all_est


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
