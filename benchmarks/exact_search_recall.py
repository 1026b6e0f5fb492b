"""How often the tracker's searches hold the true pose on MRCLAM: stacked bearings against an
interpretation search over frames joined by the odometry with the exact model.

Run:  python benchmarks/exact_search_recall.py [--robot R] [--seconds T] [--window W]
      [--bearings M] [--seeds S] [--out PATH]

The tracker (``omniloc.track``) makes candidates by stacking the bearings of the last 1.5 s
into the current frame by the odometry's *rotation* and searching them as one frame
(``omniloc.track.relocalize``). Stacking ignores the travel, so the window must stay short,
and with a 65-degree camera it rarely holds four distinct bearings. This experiment asks how
much a search with the exact model would find instead: each bearing ``z`` seen from its own
frame, whose pose ``(t_x, t_y, phi)`` in the current robot frame the odometry gives. With
``u = exp(-i theta)``, ``w = -p u`` (current pose ``p``, ``theta``) and ``alpha = phi + z``,
a landmark ``L`` at that bearing satisfies Betke and Gurvits' linear equation with one known
term more,

    Im[(L u + w - t) exp(-i alpha)] = 0,   Re[...] > 0,

so three bearings give a line of solutions ``(u, w)`` and ``|u| = 1`` picks at most two
poses (:func:`exact_frames_search`); every other bearing of the window is then matched to
the landmark nearest its prediction from its own frame's pose, within a gate.

The script runs the tracker with the ``mrclam`` preset on the first ``--seconds`` of a
robot's run; at each of its searches it records whether the stacked search's candidates hold
the truth, and whether the exact search's (on the last ``--bearings`` bearings of the last
``--window`` seconds, ``--seeds`` seed triples) do, within 0.5 m and 8 degrees (seed poses
are not refined). Writes ``results_exact_search.json`` beside this file. This is an
experiment, not a part of the library: see docs/tracking-notebook.md for what came of it.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

import omniloc.track.tracker as tracker_module  # noqa: E402
from _results import run_meta, write_results  # noqa: E402
from omniloc._kernels.geometry import det3, inv3, wrap_angle  # noqa: E402
from omniloc.angles import wrap  # noqa: E402
from omniloc.evaluate.tracking import mrclam_streams, run_stream, segment_of  # noqa: E402
from omniloc.track import Tracker, preset  # noqa: E402
from omniloc.track.motion import between  # noqa: E402

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

DEFAULT_DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
DEFAULT_OUT = HERE / "results_exact_search.json"
#: A candidate holds the truth within these (seed poses, not refined).
TRUTH_M, TRUTH_DEG = 0.5, 8.0


@njit(cache=True)
def _det3(a: FloatArray) -> float:
    """Determinant of a general 3x3 (the project's ``geometry.det3`` takes a symmetric one)."""
    return float(
        a[0, 0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1])
        - a[0, 1] * (a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0])
        + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0])
    )


@njit(cache=True)
def exact_frames_search(
    L: FloatArray,
    z: FloatArray,
    ftx: FloatArray,
    fty: FloatArray,
    fphi: FloatArray,
    seeds: IntArray,
    gate: float,
    max_range: float,
    min_range: float,
    half_fov: float,
    min_match: int,
    cap: int,
) -> tuple[FloatArray, IntArray]:
    """Interpretations of bearings seen from several frames.

    Parameters
    ----------
    L : (N, 2) landmarks. z, ftx, fty, fphi : (m,) each bearing and the pose of its frame in
    the current robot frame. seeds : (S, 3) bearing indices whose landmark triples are tried.
    gate : radians. max_range, min_range, half_fov : visibility (metres, radians).
    min_match : bearings an interpretation must explain. cap : at most this many returned.

    Returns
    -------
    poses (K, 3) of the current frame and assignments (K, m) (-1: unexplained).
    """
    N = L.shape[0]
    m = z.shape[0]
    out_p = np.empty((cap, 3))
    out_a = np.empty((cap, m), np.int64)
    n_out = 0
    A = np.empty((3, 4))
    b = np.empty(3)
    M = np.empty((3, 3))
    AA = np.empty((3, 3))
    nv = np.empty(4)
    y = np.empty(3)
    x0 = np.empty(4)
    lms = np.empty(3, np.int64)
    asg = np.empty(m, np.int64)
    for s in range(seeds.shape[0]):
        o = seeds[s]
        for ja in range(N):
            for jb in range(N):
                for jc in range(N):
                    lms[0], lms[1], lms[2] = ja, jb, jc
                    ok = True
                    for r in range(3):
                        i = o[r]
                        for r2 in range(r):
                            same_frame = (
                                ftx[o[r2]] == ftx[i]
                                and fty[o[r2]] == fty[i]
                                and fphi[o[r2]] == fphi[i]
                            )
                            if lms[r2] == lms[r] and same_frame:
                                ok = False
                        al = fphi[i] + z[i]
                        c = math.cos(al)
                        sn = math.sin(al)
                        lx = L[lms[r], 0]
                        ly = L[lms[r], 1]
                        A[r, 0] = ly * c - lx * sn
                        A[r, 1] = lx * c + ly * sn
                        A[r, 2] = -sn
                        A[r, 3] = c
                        b[r] = fty[i] * c - ftx[i] * sn
                    if not ok:
                        continue
                    # The null vector of A (generalised cross product) ...
                    for j in range(4):
                        k = 0
                        for jj in range(4):
                            if jj != j:
                                for r in range(3):
                                    M[r, k] = A[r, jj]
                                k += 1
                        nv[j] = (-1.0) ** j * _det3(M)
                    # ... and the least-norm solution A^T (A A^T)^-1 b.
                    for r in range(3):
                        for k in range(3):
                            AA[r, k] = A[r, 0] * A[k, 0] + A[r, 1] * A[k, 1]
                            AA[r, k] += A[r, 2] * A[k, 2] + A[r, 3] * A[k, 3]
                    dA = det3(AA[0, 0], AA[0, 1], AA[0, 2], AA[1, 1], AA[1, 2], AA[2, 2])
                    if abs(dA) < 1e-12:
                        continue
                    c00, c01, c02, c11, c12, c22, _ = inv3(
                        AA[0, 0], AA[0, 1], AA[0, 2], AA[1, 1], AA[1, 2], AA[2, 2], 1.0, 0.0
                    )
                    y[0] = c00 * b[0] + c01 * b[1] + c02 * b[2]
                    y[1] = c01 * b[0] + c11 * b[1] + c12 * b[2]
                    y[2] = c02 * b[0] + c12 * b[1] + c22 * b[2]
                    for j in range(4):
                        x0[j] = A[0, j] * y[0] + A[1, j] * y[1] + A[2, j] * y[2]
                    qa = nv[0] * nv[0] + nv[1] * nv[1]
                    qb = 2.0 * (x0[0] * nv[0] + x0[1] * nv[1])
                    qc = x0[0] * x0[0] + x0[1] * x0[1] - 1.0
                    disc = qb * qb - 4.0 * qa * qc
                    if qa < 1e-18 or disc < 0.0:
                        continue
                    for sg in (-1.0, 1.0):
                        t = (-qb + sg * math.sqrt(disc)) / (2.0 * qa)
                        u1, u2 = x0[0] + t * nv[0], x0[1] + t * nv[1]
                        w1, w2 = x0[2] + t * nv[2], x0[3] + t * nv[3]
                        th = -math.atan2(u2, u1)
                        px = -(w1 * u1 + w2 * u2)  # p = -w conj(u)
                        py = -(w2 * u1 - w1 * u2)
                        cth, sth = math.cos(th), math.sin(th)
                        nm = 0
                        for i in range(m):
                            fx = px + cth * ftx[i] - sth * fty[i]
                            fy = py + sth * ftx[i] + cth * fty[i]
                            ft = th + fphi[i]
                            best = gate
                            asg[i] = -1
                            for j in range(N):
                                dx = L[j, 0] - fx
                                dy = L[j, 1] - fy
                                q = dx * dx + dy * dy
                                if q > max_range * max_range or q < min_range * min_range:
                                    continue
                                h = wrap_angle(math.atan2(dy, dx) - ft)
                                if abs(h) > half_fov:
                                    continue
                                e = abs(wrap_angle(z[i] - h))
                                if e < best:
                                    best = e
                                    asg[i] = j
                            if asg[i] >= 0:
                                nm += 1
                        # The seed's own bearings must be its landmarks (in front: r > 0).
                        if asg[o[0]] != ja or asg[o[1]] != jb or asg[o[2]] != jc:
                            continue
                        if nm >= min_match and n_out < cap:
                            out_p[n_out, 0], out_p[n_out, 1], out_p[n_out, 2] = px, py, th
                            out_a[n_out] = asg
                            n_out += 1
    return out_p[:n_out], out_a[:n_out]


def window_bearings(frames: list[Any], last: int) -> tuple[FloatArray, ...]:
    """The last ``last`` bearings of ``frames`` and the poses of their frames in the last
    frame's robot frame: ``z, tx, ty, phi``."""
    ref = frames[-1].odom
    rows = []
    for f in frames:
        rel = between(ref, f.odom)
        rows += [(b, rel[0], rel[1], rel[2]) for b in f.bearings]
    arr = np.array(rows[-last:], dtype=np.float64).reshape(-1, 4)
    return arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]


def seed_triples(z: FloatArray, phi: FloatArray, n: int, rng: np.random.Generator) -> IntArray:
    """At most ``n`` triples of bearings at least 2 degrees apart (in the current frame's
    directions), drawn at random."""
    a = z + phi
    tri = [
        t
        for t in itertools.combinations(range(z.size), 3)
        if min(abs(float(wrap(a[i] - a[j]))) for i, j in itertools.combinations(t, 2))
        > math.radians(2.0)
    ]
    if len(tri) > n:
        tri = [tri[k] for k in rng.choice(len(tri), n, replace=False)]
    return np.array(tri, dtype=np.int64).reshape(-1, 3)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robot", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=150.0)
    ap.add_argument("--window", type=float, default=3.0)
    ap.add_argument("--bearings", type=int, default=10)
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        print(f"{args.data}: no MRCLAM recordings there (pass --data)")
        return 1
    t_start = time.time()
    stream = mrclam_streams(args.data, [args.robot])[0]
    stream = segment_of(stream, stream.start, stream.start + args.seconds, "recall")
    sensor, motion, config = preset("mrclam")
    assert sensor.max_range is not None and sensor.min_range is not None
    assert sensor.half_fov is not None
    rng = np.random.default_rng(0)
    tracker = Tracker(stream.landmarks, sensor, motion, config)
    stacked = tracker_module.search_window
    rows: list[dict[str, float]] = []

    def truth_among(poses: FloatArray, t: float) -> bool:
        p = stream.truth_at(t)[0][0]
        d = np.hypot(poses[:, 0] - p[0], poses[:, 1] - p[1])
        h = np.degrees(np.abs(np.asarray(wrap(poses[:, 2] - p[2]))))
        return bool(((d <= TRUTH_M) & (h <= TRUTH_DEG)).any())

    def both(landmarks: Any, frames: list[Any], sensor_: Any, **kw: Any) -> Any:
        cands = stacked(landmarks, frames, sensor_, **kw)
        t = frames[-1].t
        z, tx, ty, ph = window_bearings(tracker._window.since(t - args.window), args.bearings)
        seeds = seed_triples(z, ph, args.seeds, rng)
        c0 = time.perf_counter()
        poses = np.zeros((0, 3))
        if z.size >= 4 and len(seeds):
            poses, _ = exact_frames_search(
                landmarks.xy, z, tx, ty, ph, seeds, math.radians(3.0),
                float(sensor.max_range), float(sensor.min_range), float(sensor.half_fov),
                4, 20_000,
            )  # fmt: skip
        rows.append(
            {
                "t": t - stream.start,
                "stacked_bearings": cands.n_bearings,
                "stacked_candidates": len(cands),
                "stacked_truth": truth_among(cands.poses, t) if len(cands) else False,
                "exact_bearings": int(z.size),
                "exact_candidates": len(poses),
                "exact_truth": truth_among(poses, t) if len(poses) else False,
                "exact_s": time.perf_counter() - c0,
            }
        )
        return cands

    tracker_module.search_window = both
    try:
        run_stream(tracker, stream)
    finally:
        tracker_module.search_window = stacked
    n = len(rows)
    if not n:
        print("the tracker made no search in that stretch")
        return 1

    def share(key: str) -> float:
        return sum(bool(r[key]) for r in rows) / n

    summary = {
        "searches": n,
        "stacked_truth_rate": share("stacked_truth"),
        "stacked_nonempty_rate": sum(r["stacked_candidates"] > 0 for r in rows) / n,
        "exact_truth_rate": share("exact_truth"),
        "exact_nonempty_rate": sum(r["exact_candidates"] > 0 for r in rows) / n,
        "exact_candidates_median": float(np.median([r["exact_candidates"] for r in rows])),
        "exact_seconds_median": float(np.median([r["exact_s"] for r in rows])),
        "exact_seconds_max": float(max(r["exact_s"] for r in rows)),
    }
    meta = run_meta(
        "exact_search_recall.py",
        argv,
        args={k: str(v) for k, v in vars(args).items()},
        wall_s=round(time.time() - t_start, 1),
    )
    write_results(args.out, meta, summary=summary, searches=rows)
    print(
        f"robot {args.robot}, first {args.seconds:g} s, {n} searches: the truth among the "
        f"stacked search's candidates in {100 * summary['stacked_truth_rate']:.1f} %, among "
        f"the exact search's ({args.window:g} s, {args.bearings} bearings, {args.seeds} seeds) "
        f"in {100 * summary['exact_truth_rate']:.1f} % (median "
        f"{summary['exact_candidates_median']:.0f} candidates, "
        f"{summary['exact_seconds_median']:.2f} s per search); written to {args.out}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
