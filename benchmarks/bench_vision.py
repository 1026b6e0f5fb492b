"""Benchmark of the vision front end on rendered 640x480 omnidirectional images.

Over N random rooms (random_scene: 5 poles, 7 wall edges, well separated) and random cameras
(centre within +-20 px, aspect 0.95-1.08, rim radius 195-220 px, random forward, mirrored half
the time; noise sigma 2 grey levels, blur 0.8 px, texture and a lighting gradient), measure:
rim centre and aspect errors, median bearing error, recall of visible edges and poles, rate
of spurious detections, pole/edge classification, and time from image to bearings.

Run:  python benchmarks/bench_vision.py [--scenes 50] [--seed 0]
Writes benchmarks/results_vision.json and prints a table.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from omniloc.angles import angdiff
from omniloc.pose import Pose
from omniloc.search import localize
from omniloc.vision import (
    OmniCamera,
    calibrate_mirror,
    extract_bearings,
    random_scene,
    render_omni_image,
    true_features,
)

TARGETS = {
    "center_err_px_max": 0.5,
    "aspect_err_pct_max": 0.5,
    "median_bearing_err_deg": 0.2,
    "recall_pct": 95.0,
    "spurious_pct": 5.0,
    "median_time_ms": 100.0,
    "image_to_pose_median_ms": 100.0,
}


def run(n_scenes: int, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    center_err: list[float] = []
    aspect_err: list[float] = []
    bearing_err: list[float] = []
    t_full: list[float] = []
    t_cal: list[float] = []
    t_known: list[float] = []
    t_pose: list[float] = []
    pose_ok = 0
    n_true = n_found = n_det = n_spur = n_kind_ok = 0
    for i in range(n_scenes):
        scene, pose = random_scene(rng)
        cam = OmniCamera(
            image_size=(640, 480),
            center=(320 + rng.uniform(-20, 20), 240 + rng.uniform(-15, 15)),
            aspect=float(rng.uniform(0.95, 1.08)),
            radius=float(rng.uniform(195, 220)),
            forward=float(rng.uniform(-np.pi, np.pi)),
            mirrored=bool(i % 2),
            blur_sigma=0.8,
            noise_sigma=2.0,
        )
        img = render_omni_image(scene, pose, cam, rng=rng)
        truth = true_features(scene, pose, cam)

        t0 = time.perf_counter()
        det = extract_bearings(img, forward=cam.forward, mirrored=cam.mirrored)
        t_full.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        cal = calibrate_mirror(img)
        t_cal.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        extract_bearings(img, calibration=cal, forward=cam.forward, mirrored=cam.mirrored)
        t_known.append(time.perf_counter() - t0)

        # The whole chain: image -> bearings -> pose (one detection may be spurious).
        t0 = time.perf_counter()
        det2 = extract_bearings(img, forward=cam.forward, mirrored=cam.mirrored)
        spur = 1 if len(det2) >= 5 else 0
        res = localize(
            scene.landmarks_xy,
            det2.bearings,
            sigma=np.deg2rad(0.1),
            max_spurious=spur,
            timeout_s=5.0,
        )
        t_pose.append(time.perf_counter() - t0)
        if res.best is not None:
            dxy, dth = res.best.pose.distance_to(Pose(*pose))
            pose_ok += bool(dxy < 0.1 and dth < np.deg2rad(1.0))

        c = det.calibration
        center_err.append(float(np.hypot(*np.subtract(c.center, cam.center))))
        aspect_err.append(abs(c.aspect / cam.aspect - 1) * 100)
        err = np.abs(np.asarray(angdiff(det.bearings[:, None], truth.bearings[None, :])))
        tol = np.deg2rad(0.5)
        per_truth = err.min(axis=0) if len(det) else np.full(len(truth), np.inf)
        found = per_truth < tol
        n_true += len(truth)
        n_found += int(found.sum())
        n_det += len(det)
        n_spur += int(np.sum(err.min(axis=1) >= tol)) if len(truth) else len(det)
        bearing_err.extend(np.rad2deg(per_truth[found]).tolist())
        if len(det):
            nearest = err.argmin(axis=0)
            n_kind_ok += int(np.sum(det.kind[nearest][found] == truth.kind[found]))
    return {
        "scenes": n_scenes,
        "center_err_px_median": float(np.median(center_err)),
        "center_err_px_max": float(np.max(center_err)),
        "aspect_err_pct_median": float(np.median(aspect_err)),
        "aspect_err_pct_max": float(np.max(aspect_err)),
        "median_bearing_err_deg": float(np.median(bearing_err)),
        "p95_bearing_err_deg": float(np.percentile(bearing_err, 95)),
        "visible_features": n_true,
        "recall_pct": 100.0 * n_found / max(n_true, 1),
        "detections": n_det,
        "spurious_pct": 100.0 * n_spur / max(n_det, 1),
        "kind_correct_pct": 100.0 * n_kind_ok / max(n_found, 1),
        "median_time_ms": 1000 * float(np.median(t_full)),
        "median_time_calibration_ms": 1000 * float(np.median(t_cal)),
        "median_time_known_calibration_ms": 1000 * float(np.median(t_known)),
        "image_to_pose_median_ms": 1000 * float(np.median(t_pose)),
        "image_to_pose_p95_ms": 1000 * float(np.percentile(t_pose, 95)),
        "image_to_pose_success_pct": 100.0 * pose_ok / n_scenes,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("results_vision.json"))
    args = parser.parse_args()
    res = run(args.scenes, args.seed)
    print(f"vision benchmark: {args.scenes} scenes, 640x480, noise 2 grey levels, blur 0.8 px")
    print(f"{'metric':36s} {'value':>10s} {'target':>10s}")
    for key, val in res.items():
        target = TARGETS.get(key)
        if target is None:
            tgt = ""
        elif key in ("recall_pct",):
            tgt = f">= {target:g}"
        else:
            tgt = f"<= {target:g}"
        print(f"{key:36s} {val:10.4g} {tgt:>10s}")
    passed = all(res[k] >= v if k == "recall_pct" else res[k] <= v for k, v in TARGETS.items())
    print("all targets met" if passed else "SOME TARGETS MISSED")
    payload = {
        "results": res,
        "targets": TARGETS,
        "all_targets_met": passed,
        "seed": args.seed,
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    args.out.write_text(json.dumps(payload, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
