"""What the tracker's own frame model allows without the correspondences: every place
seeded at the start, carried along the true path.

Run:  python benchmarks/seeded_filter.py [--robots 1 2 3 4 5] [--until S] [--odometry] [--out PATH]

The bound of ``omniloc.evaluate.bounds`` is told which tube each bearing is; the tracker is
not, and on MRCLAM its first correct ``localized`` state comes after a median of 435 s
against the bound's 36 s. This splits that gap. A Gaussian-sum filter is seeded over the
whole region of the ``mrclam`` preset at the first frame (every 0.4 m and 10 deg, each
seed's covariance 0.2 m and 5 deg: some seed lies in the true place's basin), carried from
frame to frame by the TRUE relative motion (no odometry noise: optimistic) and weighed by
the tracker's own frame model (clutter with memory, misses, the core and tail, the
evidence weight, ``omniloc.track.likelihood.frame_update_clutter``), never searched, never
pruned but below 1e-300 of the best; seeds that converge on one place are merged (0.1 m, 2 deg).
For each robot it reports when the hypotheses within 0.3 m and 5 deg of the truth first
hold 0.99 of the mass (how soon the model's mass gathers at the truth: a criterion only
the truth can apply), when the best hypothesis's place (the hypotheses within 0.3 m and
5 deg of it) first holds 0.99 and is right (what a localizer can tell for itself, as the
tracker's ``localized`` does, without the covariance's part), the shares of the frames
after each where the same holds, and when some wrong place first held 0.99 (the model
sure of the wrong place). Last, a decision as the tracker's ``localized`` takes it from the
model (the best place's mass times its moment-matched covariance's chance at least 0.99,
from ``min_age_s`` on; not its confirmations by searches, its fit or its hysteresis): its
first right frame, and its frames localized and right or wrong.

``--odometry``: moved instead by the recorded odometry with the preset's motion model and
its noise, as the tracker moves its hypotheses (the tracker's own integration): a tracker
whose searches never missed a place.

Writes ``results_seeded_filter.json`` and ``.md`` beside this file.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc import LandmarkMap  # noqa: E402
from omniloc.angles import wrap  # noqa: E402
from omniloc.track import (  # noqa: E402
    Tracker,
    load_frames,
    load_groundtruth,
    load_odometry,
    preset,
)
from omniloc.track.likelihood import frame_update_clutter  # noqa: E402
from omniloc.track.motion import between, move  # noqa: E402
from omniloc.track.tracker import within_tolerance  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
STEP_M, STEP_HEADING = 0.4, math.radians(10.0)
SEED_SD_M, SEED_SD_HEADING = 0.2, math.radians(5.0)
MERGE_M, MERGE_HEADING = 0.1, math.radians(2.0)
#: Hypotheses this many nats below the best are dropped (about the last that a double holds:
#: a model as sure as this one's leaves 1e-13 behind within seconds).
PRUNE = -700.0
SURE = 0.99
TOL_M, TOL_HEADING = 0.3, math.radians(5.0)
#: The truth's own error per frame (m^2, m^2, rad^2): the motion between frames is the
#: truth's, with this much noise.
Q_TRUTH = np.diag([1e-6, 1e-6, 1e-6])


def seeds(region: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    x0, x1, y0, y1 = region
    xs = np.arange(x0, x1 + 1e-9, STEP_M)
    ys = np.arange(y0, y1 + 1e-9, STEP_M)
    ths = np.arange(-math.pi, math.pi, STEP_HEADING)
    g = np.array(np.meshgrid(xs, ys, ths, indexing="ij")).reshape(3, -1).T
    P = np.tile(np.diag([SEED_SD_M**2, SEED_SD_M**2, SEED_SD_HEADING**2]), (g.shape[0], 1, 1))
    return g, P


def merge(mu: np.ndarray, P: np.ndarray, logw: np.ndarray, mem: np.ndarray) -> tuple:
    """The heaviest hypothesis of each cell (MERGE_M, MERGE_HEADING) takes the cell's mass."""
    key = np.stack(
        [
            np.floor(mu[:, 0] / MERGE_M),
            np.floor(mu[:, 1] / MERGE_M),
            np.floor((np.asarray(wrap(mu[:, 2])) + math.pi) / MERGE_HEADING),
        ],
        axis=1,
    ).astype(np.int64)
    order = np.argsort(-logw, kind="stable")
    _, first, inv = np.unique(key[order], axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    top = logw[order].max()
    mass = np.zeros(first.size)
    np.add.at(mass, inv, np.exp(logw[order] - top))
    keep = order[first]
    return mu[keep], P[keep], np.log(mass) + top, mem[keep]


def run(robot: int, until_s: float, odometry: bool = False) -> dict[str, object]:
    lm = LandmarkMap.load(DATA / "landmarks.csv")
    L = np.ascontiguousarray(lm.xy, dtype=np.float64)
    frames = load_frames(DATA / f"robot{robot}_frames.csv")
    truth = load_groundtruth(DATA / f"robot{robot}_groundtruth_10hz.csv")
    sensor, motion, config = preset("mrclam")
    tracker = Tracker(lm, sensor, motion, config)  # (its frame model, memory and motion)
    if odometry:
        odo = load_odometry(DATA / f"robot{robot}_odometry.csv")
        tracker.odometry(odo.t, odo.v, odo.w)
    assert config.region is not None
    mu, P = seeds(config.region)
    logw = np.zeros(mu.shape[0])
    mem_b, mem_w, mem_t, rot = np.zeros(0), np.zeros((mu.shape[0], 0)), -math.inf, 0.0
    t0 = frames[0].t
    prev = None
    t_prev = None
    sure_right = sure_wrong = sure_place = math.nan
    place_after = place_right_after = 0
    loc_right = loc_wrong = 0
    first_loc = math.nan
    wrong_by = (math.nan, math.nan)
    after = right_after = 0
    counts = []
    started = time.perf_counter()
    for f in frames:
        if f.t - t0 > until_s:
            break
        p, _ = truth.at(f.t)
        if not np.isfinite(p).all():
            continue
        p = p[0]
        if odometry:
            # (The tracker's own integration of the odometry to the frame.)
            d, Q, _ = tracker._motion_to(f.t)
            tracker._t = f.t
        elif prev is not None:
            d, Q = between(prev, p), Q_TRUTH
        else:
            d, Q = np.zeros(3), Q_TRUTH
        if prev is not None:
            mu, P = move(mu, P, d, Q)
            rot += float(d[2])
            turn = float(d[2]) / (f.t - t_prev) if f.t > t_prev else 0.0
        else:
            turn = 0.0
        prev, t_prev = p, f.t
        objects = tracker._objects(f.t, mem_b, rot, mem_t, mem_w)
        mu, P, lr, _, post = frame_update_clutter(
            mu, P, f.bearings, L, tracker._frame_model(turn), objects
        )
        if f.bearings.size:
            mem_b, mem_w, mem_t, rot = f.bearings, config.clutter_persistence * post, f.t, 0.0
        logw = logw + config.evidence_weight * lr
        logw -= logw.max()
        keep = logw >= PRUNE
        mu, P, logw, mem_w = mu[keep], P[keep], logw[keep], mem_w[keep]
        mu, P, logw, mem_w = merge(mu, P, logw, mem_w)
        w = np.exp(logw)
        w /= w.sum()
        dpos = np.hypot(mu[:, 0] - p[0], mu[:, 1] - p[1])
        dth = np.abs(np.asarray(wrap(mu[:, 2] - p[2])))
        right = float(w[(dpos <= TOL_M) & (dth <= TOL_HEADING)].sum())
        b = int(np.argmax(w))
        near = (np.hypot(mu[:, 0] - mu[b, 0], mu[:, 1] - mu[b, 1]) <= TOL_M) & (
            np.abs(np.asarray(wrap(mu[:, 2] - mu[b, 2]))) <= TOL_HEADING
        )
        best_right = dpos[b] <= TOL_M and dth[b] <= TOL_HEADING
        place = float(w[near].sum())
        # A decision as the tracker's `localized`: the best place's mass times the chance its
        # moment-matched covariance gives the tolerance, at least 0.99, from min_age_s on.
        wn = w[near] / place
        mbar = mu[near].T @ wn
        dm = mu[near] - mbar
        dm[:, 2] = np.asarray(wrap(dm[:, 2]))
        Pm = np.einsum("k,kij->ij", wn, P[near]) + np.einsum("k,ki,kj->ij", wn, dm, dm)
        decided = place * within_tolerance(Pm, TOL_M, TOL_HEADING) >= SURE
        if decided and f.t - t0 >= config.min_age_s:
            loc_right += int(best_right)
            loc_wrong += int(not best_right)
            if best_right and math.isnan(first_loc):
                first_loc = f.t - t0
        if best_right and place >= SURE and math.isnan(sure_place):
            sure_place = f.t - t0
        if not math.isnan(sure_place):
            place_after += 1
            place_right_after += best_right and place >= SURE
        if not best_right and place >= SURE and math.isnan(sure_wrong):
            sure_wrong = f.t - t0
            wrong_by = (float(dpos[b]), math.degrees(float(dth[b])))
        if right >= SURE and math.isnan(sure_right):
            sure_right = f.t - t0
        if not math.isnan(sure_right):
            after += 1
            right_after += right >= SURE
        counts.append(mu.shape[0])
    return {
        "robot": robot,
        "frames": len(counts),
        "seconds": min(until_s, frames[-1].t - t0),
        "sure_right_s": sure_right,
        "sure_wrong_s": sure_wrong,
        "sure_wrong_off_m_deg": wrong_by,
        "right_after": right_after / after if after else math.nan,
        "sure_place_s": sure_place,
        "place_right_after": place_right_after / place_after if place_after else math.nan,
        "hypotheses_first": counts[0] if counts else 0,
        "hypotheses_median": float(np.median(counts)) if counts else 0.0,
        "localized_first_right_s": first_loc,
        "localized_right": loc_right,
        "localized_wrong": loc_wrong,
        "cpu_s": time.perf_counter() - started,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, nargs="*", default=[1, 2, 3, 4, 5])
    ap.add_argument("--until", type=float, default=math.inf, help="seconds of each run")
    ap.add_argument("--odometry", action="store_true", help="move by the recorded odometry")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.out is None:
        name = "results_seeded_filter" + ("_odometry" if args.odometry else "")
        args.out = HERE / name
    rows = []
    for r in args.robots:
        row = run(r, args.until, args.odometry)
        rows.append(row)
        print(
            f"robot {r}: the truth holds {SURE} from {row['sure_right_s']:.1f} s (then in "
            f"{100 * row['right_after']:.1f} % of the frames); the best place sure and right "
            f"from {row['sure_place_s']:.1f} s (then {100 * row['place_right_after']:.1f} %); "
            f"a wrong place held {SURE} first at "
            f"{row['sure_wrong_s']:.1f} s ({row['sure_wrong_off_m_deg'][0]:.2f} m, "
            f"{row['sure_wrong_off_m_deg'][1]:.1f} deg off); {row['hypotheses_first']} seeds, "
            f"median {row['hypotheses_median']:.0f} hypotheses; {row['cpu_s']:.0f} s; "
            f"localized as the tracker's model would: first right at "
            f"{row['localized_first_right_s']:.1f} s, {row['localized_right']} frames right, "
            f"{row['localized_wrong']} wrong of {row['frames']}",
            flush=True,
        )
    meta = run_meta("seeded_filter.py", argv)
    write_results(args.out.with_suffix(".json"), meta, rows=rows)
    sure = [r["sure_right_s"] for r in rows]
    lines = [
        "# Every place seeded, "
        + ("moved by the odometry" if args.odometry else "along the true path")
        + " (`benchmarks/seeded_filter.py`)",
        "",
        f"{meta['date']}, {meta['machine']}; `{meta['command']}`. The `mrclam` preset's frame "
        "model, a Gaussian-sum filter seeded over its region at the first frame and moved by "
        + (
            "the recorded odometry (the preset's motion model and noise)"
            if args.odometry
            else "the true relative motion"
        )
        + "; 'sure' is 0.99 of the mass within 0.3 m and 5 deg.",
        "",
        "| robot | mass at the truth from | then in | best place sure and right from | "
        "then in | a wrong place sure first at | localized as the model decides: first right, "
        "frames right / wrong | seeds | hypotheses (median) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        off = r["sure_wrong_off_m_deg"]
        wrong = (
            "never"
            if math.isnan(r["sure_wrong_s"])
            else f"{r['sure_wrong_s']:.1f} s ({off[0]:.2f} m, {off[1]:.1f} deg off)"
        )
        right = "never" if math.isnan(r["sure_right_s"]) else f"{r['sure_right_s']:.1f} s"
        place = "never" if math.isnan(r["sure_place_s"]) else f"{r['sure_place_s']:.1f} s"
        lines.append(
            f"| {r['robot']} | {right} | {100 * r['right_after']:.1f} % | {place} | "
            f"{100 * r['place_right_after']:.1f} % | {wrong} | "
            f"{r['localized_first_right_s']:.1f} s, {r['localized_right']} / "
            f"{r['localized_wrong']} of {r['frames']} | {r['hypotheses_first']:,} | "
            f"{r['hypotheses_median']:.0f} |"
        )
    places = [r["sure_place_s"] for r in rows]
    lines += [
        "",
        f"Medians (a run that never got there counted as later than any): mass at the truth "
        f"{np.median(np.nan_to_num(np.array(sure, float), nan=np.inf)):.1f} s, best place sure "
        f"and right {np.median(np.nan_to_num(np.array(places, float), nan=np.inf)):.1f} s.",
    ]
    args.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
