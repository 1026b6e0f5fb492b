"""The tracker's occlusion model where it is right: simulated runs on MRCLAM's map of tube
clusters, in a world whose tubes hide each other, tracked with and without being told so.

Run:  python benchmarks/track_occlusion_sim.py [--runs N] [--width W] [--workers K] [--out PATH]

Run ``s`` (0 to ``--runs``) starts at a pose drawn by seed ``s`` over the tubes' area and
drives for 90 s at 0.2 m/s (``omniloc.track.simulate.simulate_run``, seed ``s``): a
67-degree camera seeing 7.5 m, ``p_detect`` 0.6, sigma 0.5 deg, 0.3 clutter bearings a
frame, each tube hidden behind nearer ones by ``occlusion_width`` ``--width`` (default
0.04 m, what MRCLAM's reports fit: ``detection_occlusion.py``). Each run is tracked twice
with the ``generic`` preset and that sensor: with ``occlusion_width`` 0 (the frame model
expects every tube in view) and with ``--width`` (the model the world follows). The
figures: frames localized, right (0.3 m, 5 deg) and wrong, and the runs with a wrong frame
and with one beyond 1 m. Writes ``results_track_occlusion_sim.json`` beside this file;
docs/tracking-notebook.md ("Tubes behind tubes") has what it found.
"""

from __future__ import annotations

import argparse
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc import LandmarkMap, Pose, SensorModel  # noqa: E402
from omniloc.track import preset, track, with_settings  # noqa: E402
from omniloc.track.simulate import simulate_run  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: The simulated camera: MRCLAM's view, a cleaner detector.
SENSOR = SensorModel(
    sigma=math.radians(0.5), fov=math.radians(67), max_range=7.5, p_detect=0.6, clutter=0.3
)
#: Where the runs start (x0, x1, y0, y1), metres: the tubes' area.
START_BOX = (0.0, 4.5, -5.0, 5.5)


def one(job: tuple[str, int, float, float]) -> dict[str, Any]:
    """Run ``seed`` simulated with occlusion ``world`` and tracked with ``told``."""
    data, seed, world, told = job
    lm = LandmarkMap.load(Path(data) / "landmarks.csv")
    rng = np.random.default_rng(seed)
    x0, x1, y0, y1 = START_BOX
    start = Pose(rng.uniform(x0, x1), rng.uniform(y0, y1), rng.uniform(-math.pi, math.pi))
    run = simulate_run(
        lm, SENSOR, start, duration_s=90.0, speed=0.2, turn_rate=0.3,
        occlusion_width=world, rng=seed,
    )  # fmt: skip
    _, motion, config = preset("generic")
    sensor, motion, config = with_settings(SENSOR, motion, config, {"occlusion_width": told})
    out = track(lm, run.odometry, run.frames, sensor=sensor, motion=motion, config=config)
    localized = right = wrong = 0
    far = 0.0
    for e in out.estimates:
        if not e.localized or e.pose is None:
            continue
        g = run.truth.pose_at(e.t)
        off = math.hypot(e.pose.x - g.x, e.pose.y - g.y)
        turn = abs((e.pose.theta - g.theta + math.pi) % (2 * math.pi) - math.pi)
        ok = off <= 0.3 and turn <= math.radians(5.0)
        localized += 1
        right += ok
        if not ok:
            wrong += 1
            far = max(far, off)
    return {"seed": seed, "told": told, "frames": len(out.estimates), "localized": localized,
            "right": right, "wrong": wrong, "farthest_wrong_m": far}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(DATA), help="the MRCLAM set 6 folder (its map)")
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--width", type=float, default=0.04, help="occlusion width, metres")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(HERE / "results_track_occlusion_sim.json"))
    args = ap.parse_args(argv)
    jobs = [
        (args.data, s, args.width, told) for s in range(args.runs) for told in (0.0, args.width)
    ]
    with ProcessPoolExecutor(args.workers) as ex:
        runs = list(ex.map(one, jobs))
    totals: list[dict[str, Any]] = []
    for told in (0.0, args.width):
        mine = [r for r in runs if r["told"] == told]
        t = {
            "told_occlusion_width_m": told,
            "frames": sum(r["frames"] for r in mine),
            "localized": sum(r["localized"] for r in mine),
            "right": sum(r["right"] for r in mine),
            "wrong": sum(r["wrong"] for r in mine),
            "runs_with_wrong": sum(r["wrong"] > 0 for r in mine),
            "runs_wrong_beyond_1m": sum(r["farthest_wrong_m"] > 1.0 for r in mine),
        }
        totals.append(t)
        print(
            f"told {told:.3f} m: {t['localized']} of {t['frames']} frames localized, "
            f"{t['right']} right, {t['wrong']} wrong (in {t['runs_with_wrong']} runs, "
            f"{t['runs_wrong_beyond_1m']} of them beyond 1 m)"
        )
    write_results(
        args.out,
        run_meta("track_occlusion_sim.py", argv),
        world_occlusion_width_m=args.width,
        runs=args.runs,
        totals=totals,
        by_run=runs,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
