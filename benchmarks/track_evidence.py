"""Is the tracker wrong on MRCLAM because it missed the truth, or because its model prefers
the wrong place? The evidence of each wrong place against the truth's, on the same frames.

Run:  python benchmarks/track_evidence.py [--robots 1,2,3,4,5] [--seconds 5,20,60] [--bayes]
      [--out PATH]

The tracker runs on each robot's whole run (the ``mrclam`` preset; ``--bayes`` for Bayes'
rule for elsewhere, ``search_miss`` None, the variant that is localized often enough to be
wrong). At every frame it says ``localized`` at a pose that is wrong (beyond 0.3 m or 5 deg
of the ground truth), two extended Kalman filters with the tracker's own frame model
(``omniloc.track.likelihood.frame_update``: detections, clutter, landmarks in view not seen,
summed over the assignments) are replayed over each span of ``--seconds`` before it with
the tracker's odometry increments: one started at the wrong place (moved back by the
odometry, as the tracker replays its candidates), one at the ground truth, both with the
same covariance (5 cm, 5 cm, 1 deg). Their summed predictive log-likelihood ratios say
which place the model prefers on those frames. If the truth's is higher, the tracker missed
the truth (a failure of recall); if the wrong place's is higher, no search can help: the
model itself prefers it.

The difference is then split by where each bearing came from (the recordings say which
landmark or other robot each one is; the tracker never reads it), at the two filters'
predicted poses with the exact frame model: the landmarks missed in view, the bearings of
landmarks, the bearings of other robots (the clutter).

Writes ``results_track_evidence.json`` beside this file. A diagnosis, not a benchmark of
speed; see docs/tracking-notebook.md ("Why it is wrong there") for what it found.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc import predict_bearings  # noqa: E402
from omniloc.evaluate.tracking import MAX_GAP_S, Stream, mrclam_streams, run_stream  # noqa: E402
from omniloc.sensor import SensorModel  # noqa: E402
from omniloc.track import MotionModel, Tracker, TrackerConfig, TrackState, preset  # noqa: E402
from omniloc.track.likelihood import FrameModel, frame_update  # noqa: E402
from omniloc.track.motion import compose, inverse, move  # noqa: E402

FloatArray = NDArray[np.float64]

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: "Correct": within this of the ground truth (issue 15).
TOL_M, TOL_HEADING = 0.3, math.radians(5.0)
#: Standard deviations (m, m, rad) of both replayed filters at their start.
START_SD = (0.05, 0.05, math.radians(1.0))


class RecordingTracker(Tracker):
    """The tracker, keeping each frame's odometry increment and its noise (what its own
    replays use)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.increments: list[tuple[FloatArray, FloatArray]] = []

    def _motion_to(self, t: float) -> tuple[FloatArray, FloatArray, float]:
        delta, Q, gap = super()._motion_to(t)
        self.increments.append((delta.copy(), Q.copy()))
        return delta, Q, gap


@dataclass(frozen=True)
class Split:
    """Log-likelihood ratio of one frame at one exactly known pose, split by the source of
    each bearing (nats)."""

    missed: float  #: landmarks in view not reported
    landmarks: float  #: bearings of landmarks
    clutter: float  #: bearings of other robots


def split_frame(
    pose: FloatArray,
    bearings: FloatArray,
    is_landmark: ArrayLike,
    L: FloatArray,
    sensor: SensorModel,
) -> Split:
    """The frame's log-likelihood ratio at an exactly known pose (the formula of
    :mod:`omniloc.track.likelihood` with no pose uncertainty and a hard field of view), split
    into the missed landmarks' term and each bearing's term, summed by the bearing's source.

    Examples
    --------
    >>> s = SensorModel(sigma=0.01, fov=3.5, max_range=10.0, p_detect=0.5, clutter=1.0)
    >>> L = np.array([[2.0, 0.0], [0.0, 2.0]])
    >>> r = split_frame(np.zeros(3), np.array([0.0]), np.array([True]), L, s)
    >>> round(r.missed, 3), r.clutter   # both landmarks in view, each 1 - 0.5
    (-1.386, 0.0)
    """
    is_landmark = np.asarray(is_landmark, dtype=bool)
    pred = np.asarray(predict_bearings(L, pose))
    dj = sensor.p_detect * sensor.visible(L, pose)
    rho = dj / (1.0 - dj)
    kappa = sensor.clutter / sensor.fov
    terms = np.zeros(bearings.size)
    for i, z in enumerate(bearings):
        nu = (z - pred + math.pi) % (2 * math.pi) - math.pi
        g = np.exp(-0.5 * (nu / sensor.sigma) ** 2) / (math.sqrt(2 * math.pi) * sensor.sigma)
        terms[i] = math.log1p(float((rho * g).sum()) / kappa)
    return Split(
        missed=float(np.log1p(-dj).sum()),
        landmarks=float(terms[is_landmark].sum()),
        clutter=float(terms[~is_landmark].sum()),
    )


def replay(
    start: FloatArray,
    frames: list[tuple[FloatArray, FloatArray, FloatArray]],
    L: FloatArray,
    model: FrameModel,
) -> tuple[float, list[FloatArray]]:
    """An extended Kalman filter from ``start`` through ``frames`` (bearings, increment to
    the frame, its noise; the first increment is not applied): its summed log-likelihood
    ratio and its predicted mean at each frame."""
    mu = start[None, :].copy()
    P = np.diag(np.square(START_SD))[None, :, :]
    total = 0.0
    means = []
    for k, (b, delta, Q) in enumerate(frames):
        if k:
            mu, P = move(mu, P, delta, Q)
        means.append(mu[0].copy())
        mu, P, lr, _ = frame_update(mu, P, b, L, model)
        total += float(lr[0])
    return total, means


def compare_at(
    stream: Stream,
    tracker: RecordingTracker,
    k: int,
    wrong: FloatArray,
    seconds: float,
    sensor: SensorModel,
) -> dict[str, float] | None:
    """Replay the wrong place of frame ``k`` and the truth over the ``seconds`` before it;
    None when the ground truth does not cover the span's first frame."""
    L = np.ascontiguousarray(stream.landmarks.xy, dtype=np.float64)
    model = FrameModel.of(sensor)
    ts = np.array([f.t for f in stream.frames])
    k0 = int(np.searchsorted(ts, ts[k] - seconds, side="left"))
    truth0, gap0 = stream.truth_at(ts[k0])
    if not (gap0[0] <= MAX_GAP_S and np.isfinite(truth0).all()):
        return None
    span = range(k0, k + 1)
    # The wrong place at the first frame of the span: moved back by the odometry.
    rel = np.zeros(3)
    for j in range(k0 + 1, k + 1):
        rel = compose(rel, tracker.increments[j][0])
    frames = [
        (stream.frames[j].bearings, tracker.increments[j][0], tracker.increments[j][1])
        for j in span
    ]
    lr_wrong, means_wrong = replay(compose(wrong, inverse(rel)), frames, L, model)
    lr_true, means_true = replay(truth0[0], frames, L, model)
    parts = np.zeros(3)
    for j, mw, mt in zip(span, means_wrong, means_true, strict=True):
        f = stream.frames[j]
        lab = np.array([r is not None for r in (f.truth or (None,) * f.bearings.size)], bool)
        a = split_frame(mw, f.bearings, lab, L, sensor)
        b = split_frame(mt, f.bearings, lab, L, sensor)
        parts += (a.missed - b.missed, a.landmarks - b.landmarks, a.clutter - b.clutter)
    n = len(span)
    return {
        "frames": n,
        "lr_wrong": lr_wrong,
        "lr_truth": lr_true,
        "missed_per_frame": float(parts[0] / n),
        "landmarks_per_frame": float(parts[1] / n),
        "clutter_per_frame": float(parts[2] / n),
    }


def summary(rows: list[dict[str, float]]) -> dict[str, Any]:
    """Share of the wrong frames whose place the model prefers, and medians per frame."""
    diff = np.array([(r["lr_wrong"] - r["lr_truth"]) / r["frames"] for r in rows])

    def med(key: str) -> float:
        return float(np.median([r[key] for r in rows])) if rows else math.nan

    return {
        "compared": len(rows),
        "wrong_place_preferred": float((diff > 0).mean()) if diff.size else math.nan,
        "median_nats_per_frame": float(np.median(diff)) if diff.size else math.nan,
        "median_split_per_frame": {
            k: med(f"{k}_per_frame") for k in ("missed", "landmarks", "clutter")
        },
    }


def diagnose(
    stream: Stream,
    sensor: SensorModel,
    motion: MotionModel,
    config: TrackerConfig,
    spans: list[float],
) -> dict[str, Any]:
    """Run the tracker on ``stream`` and compare each wrong localized frame's place with the
    truth over each span (seconds) before it."""
    tracker = RecordingTracker(stream.landmarks, sensor, motion, config)
    estimates, cpu = run_stream(tracker, stream)
    ts = np.array([f.t for f in stream.frames])
    truth, gaps = stream.truth_at(ts)
    rows: dict[float, list[dict[str, float]]] = {s: [] for s in spans}
    n_loc = n_correct = n_wrong = 0
    for k, est in enumerate(estimates):
        if est.state is not TrackState.LOCALIZED or est.pose is None:
            continue
        if not (gaps[k] <= MAX_GAP_S and np.isfinite(truth[k]).all()):
            continue
        n_loc += 1
        x = np.array([est.pose.x, est.pose.y, est.pose.theta])
        dh = abs((x[2] - truth[k, 2] + math.pi) % (2 * math.pi) - math.pi)
        if float(np.hypot(*(x[:2] - truth[k, :2]))) <= TOL_M and dh <= TOL_HEADING:
            n_correct += 1
            continue
        n_wrong += 1
        for s in spans:
            row = compare_at(stream, tracker, k, x, s, sensor)
            if row is not None:
                rows[s].append(row)
    return {
        "run": stream.name,
        "frames": len(estimates),
        "localized": n_loc,
        "correct": n_correct,
        "wrong": n_wrong,
        "cpu_s": cpu,
        "spans": {f"{s:g}": {**summary(rows[s]), "rows": rows[s]} for s in spans},
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(DATA), help="the MRCLAM set 6 folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="robots, comma separated")
    ap.add_argument(
        "--seconds", default="5,20,60", help="spans replayed before a frame, comma separated"
    )
    ap.add_argument("--bayes", action="store_true", help="Bayes' rule (search_miss None)")
    ap.add_argument("--out", default=str(HERE / "results_track_evidence.json"))
    args = ap.parse_args(argv)
    try:
        robots = [int(r) for r in args.robots.split(",")]
        spans = [float(s) for s in args.seconds.split(",")]
    except ValueError:
        ap.error("--robots and --seconds take numbers separated by commas")
    if not all(s > 0 and math.isfinite(s) for s in spans):
        ap.error(f"--seconds must be positive, got {args.seconds!r}")
    sensor, motion, config = preset("mrclam")
    if args.bayes:
        config = dataclasses.replace(config, search_miss=None)
    t0 = time.time()
    runs = []
    for stream in mrclam_streams(args.data, robots):
        r = diagnose(stream, sensor, motion, config, spans)
        print(
            f"{r['run']}: localized {r['localized']} of {r['frames']} frames, correct "
            f"{r['correct']}, wrong {r['wrong']}",
            flush=True,
        )
        for key, v in r["spans"].items():
            print("  " + _line(key, v), flush=True)
        runs.append(r)
    total = {}
    for s in spans:
        key = f"{s:g}"
        total[key] = summary([x for r in runs for x in r["spans"][key]["rows"]])
        print("all " + _line(key, total[key]))
    meta = run_meta("track_evidence.py", argv, bayes=args.bayes, wall_s=round(time.time() - t0, 1))
    write_results(args.out, meta, total=total, runs=runs)
    return 0


def _line(span: str, v: dict[str, Any]) -> str:
    s = v["median_split_per_frame"]
    return (
        f"{span} s before: {v['compared']} wrong frames compared, the wrong place preferred in "
        f"{100 * v['wrong_place_preferred']:.1f} % (median {v['median_nats_per_frame']:+.2f} "
        f"nats per frame; split: missed landmarks {s['missed']:+.2f}, landmarks' bearings "
        f"{s['landmarks']:+.2f}, other robots' {s['clutter']:+.2f})"
    )


if __name__ == "__main__":
    raise SystemExit(main())
