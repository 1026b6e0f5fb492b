"""Benchmark of the vision front end on rendered 640x480 omnidirectional images.

Two blocks of random scenes, each with random cameras (centre within +-20 px, aspect
0.95-1.08, rim radius 195-220 px, random forward; noise sigma 2 grey levels, blur 0.8 px,
texture and a lighting gradient):

* ``rooms``: N rooms from random_scene (5 poles, 7 wall edges, well separated), mirrored half
  the time;
* ``stripes``: M rooms from random_stripe_scene (4 corners, 4 narrow wall segments 5-8 deg
  wide, 4 poles 1.6-5 deg wide; neighbouring walls >= 30 grey levels apart, most narrow
  segments brighter or darker than both neighbours, so they look like poles), a third
  mirrored, a quarter in colour.

Each block measures rim centre and aspect errors, median bearing error, the share of visible
edges and poles found (within 0.5 deg), the share of spurious detections, pole/edge
classification, the detections flagged ambiguous, and the time from image to bearings and
from image to pose (localize, allowing one spurious bearing plus every ambiguous one).

Run:  python benchmarks/bench_vision.py [--scenes 50] [--stripe-scenes 48] [--seed 0]
Writes benchmarks/results_vision.json and prints a table per block.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from omniloc.angles import angdiff
from omniloc.pose import Pose
from omniloc.search import localize
from omniloc.vision import (
    OmniCamera,
    OmniScene,
    calibrate_mirror,
    extract_bearings,
    random_scene,
    render_omni_image,
    true_features,
)
from omniloc.vision.render import random_stripe_scene

TARGETS = {
    "rooms": {
        "center_err_px_max": 0.5,
        "aspect_err_pct_max": 0.5,
        "median_bearing_err_deg": 0.2,
        "recall_pct": 95.0,
        "spurious_pct": 5.0,
        "median_time_ms": 100.0,
        "image_to_pose_median_ms": 100.0,
    },
    # The issue "two nearby edges are reported as one pole".
    "stripes": {
        "median_bearing_err_deg": 0.05,
        "recall_pct": 98.0,
        "spurious_pct": 3.0,
        "image_to_pose_median_ms": 100.0,
    },
}
AT_LEAST = {"recall_pct"}  # the other targets are upper bounds

Draw = Callable[[np.random.Generator], tuple[OmniScene, tuple[float, float, float]]]


def random_camera(rng: np.random.Generator, *, mirrored: bool, color: bool) -> OmniCamera:
    return OmniCamera(
        image_size=(640, 480),
        center=(320 + rng.uniform(-20, 20), 240 + rng.uniform(-15, 15)),
        aspect=float(rng.uniform(0.95, 1.08)),
        radius=float(rng.uniform(195, 220)),
        forward=float(rng.uniform(-np.pi, np.pi)),
        mirrored=mirrored,
        blur_sigma=0.8,
        noise_sigma=2.0,
        color=color,
    )


def run(
    n_scenes: int,
    rng: np.random.Generator,
    draw: Draw,
    *,
    mirrored_every: int,
    color_every: int | None = None,
) -> dict[str, float]:
    """Render, detect and localize `n_scenes` scenes; return the block's figures.

    Scene ``i`` is mirrored if ``i % mirrored_every == 1 % mirrored_every`` and in colour if
    ``i % color_every == 0``.
    """
    center_err: list[float] = []
    aspect_err: list[float] = []
    bearing_err: list[float] = []
    t_full: list[float] = []
    t_cal: list[float] = []
    t_known: list[float] = []
    t_pose: list[float] = []
    pose_ok = 0
    n_true = n_found = n_det = n_spur = n_kind_ok = 0
    n_pole = n_pole_found = n_flagged = n_flagged_spur = 0
    for i in range(n_scenes):
        scene, pose = draw(rng)
        cam = random_camera(
            rng,
            mirrored=i % mirrored_every == 1 % mirrored_every,
            color=color_every is not None and i % color_every == 0,
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

        # The whole chain: image -> bearings -> pose. One detection may be spurious, and so
        # may every ambiguous one (both edges of a stripe that could be a pole).
        t0 = time.perf_counter()
        det2 = extract_bearings(img, forward=cam.forward, mirrored=cam.mirrored)
        spur = (1 if len(det2) >= 5 else 0) + int(det2.ambiguous.sum())
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
        spurious = err.min(axis=1) >= tol if len(truth) else np.ones(len(det), dtype=bool)
        n_true += len(truth)
        n_found += int(found.sum())
        n_det += len(det)
        n_spur += int(spurious.sum())
        is_pole = truth.kind == "pole"
        n_pole += int(is_pole.sum())
        n_pole_found += int((found & is_pole).sum())
        n_flagged += int(det.ambiguous.sum())
        n_flagged_spur += int((det.ambiguous & spurious).sum())
        bearing_err.extend(np.rad2deg(per_truth[found]).tolist())
        if len(det):
            nearest = err.argmin(axis=0)
            n_kind_ok += int(np.sum(det.kind[nearest][found] == truth.kind[found]))
    n_edge = n_true - n_pole
    return {
        "scenes": n_scenes,
        "center_err_px_median": float(np.median(center_err)),
        "center_err_px_max": float(np.max(center_err)),
        "aspect_err_pct_median": float(np.median(aspect_err)),
        "aspect_err_pct_max": float(np.max(aspect_err)),
        "median_bearing_err_deg": float(np.median(bearing_err)),
        "p95_bearing_err_deg": float(np.percentile(bearing_err, 95)),
        "visible_features": n_true,
        "found": n_found,
        "recall_pct": 100.0 * n_found / max(n_true, 1),
        "poles_found_pct": 100.0 * n_pole_found / max(n_pole, 1),
        "edges_found_pct": 100.0 * (n_found - n_pole_found) / max(n_edge, 1),
        "detections": n_det,
        "spurious": n_spur,
        "spurious_pct": 100.0 * n_spur / max(n_det, 1),
        "kind_correct_pct": 100.0 * n_kind_ok / max(n_found, 1),
        "ambiguous_detections": n_flagged,
        "ambiguous_pct": 100.0 * n_flagged / max(n_det, 1),
        "ambiguous_spurious": n_flagged_spur,
        "median_time_ms": 1000 * float(np.median(t_full)),
        "median_time_calibration_ms": 1000 * float(np.median(t_cal)),
        "median_time_known_calibration_ms": 1000 * float(np.median(t_known)),
        "image_to_pose_median_ms": 1000 * float(np.median(t_pose)),
        "image_to_pose_p95_ms": 1000 * float(np.percentile(t_pose, 95)),
        "image_to_pose_success_pct": 100.0 * pose_ok / n_scenes,
    }


def met(results: dict[str, float], targets: dict[str, float]) -> bool:
    return all(results[k] >= v if k in AT_LEAST else results[k] <= v for k, v in targets.items())


def print_block(name: str, results: dict[str, float], targets: dict[str, float]) -> None:
    print(f"\n[{name}]")
    print(f"{'metric':36s} {'value':>10s} {'target':>10s}")
    for key, val in results.items():
        target = targets.get(key)
        tgt = "" if target is None else f"{'>=' if key in AT_LEAST else '<='} {target:g}"
        print(f"{key:36s} {val:10.4g} {tgt:>10s}")
    print("all targets met" if met(results, targets) else "SOME TARGETS MISSED")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=50, help="rooms block")
    parser.add_argument("--stripe-scenes", type=int, default=48, help="stripes block")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("results_vision.json"))
    args = parser.parse_args()
    print("vision benchmark: 640x480, noise 2 grey levels, blur 0.8 px")
    blocks = {
        # The same images as before this file had a second block (same seed, same draws).
        "rooms": run(args.scenes, np.random.default_rng(args.seed), random_scene, mirrored_every=2),
        "stripes": run(
            args.stripe_scenes,
            np.random.default_rng([args.seed, 1]),
            random_stripe_scene,
            mirrored_every=3,
            color_every=4,
        ),
    }
    payload: dict[str, object] = {}
    for name, results in blocks.items():
        print_block(name, results, TARGETS[name])
        payload[name] = {
            "results": results,
            "targets": TARGETS[name],
            "all_targets_met": met(results, TARGETS[name]),
        }
    payload.update(
        {
            "all_targets_met": all(met(blocks[k], TARGETS[k]) for k in blocks),
            "seed": args.seed,
            "python": platform.python_version(),
            "machine": platform.machine(),
        }
    )
    args.out.write_text(json.dumps(payload, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
