"""How often could ANY localizer be right on the large-map scenes? (issue 16, item 3)

Run:  python benchmarks/oracle_limits.py [--scene c cgrid] [--trials 100] [--out FILE]

The benchmark calls an answer right within 0.1 m and 1 deg of the true pose. With sigma
0.3 deg and landmarks up to 20 m away, the pose computed from the TRUE correspondences -- the
maximum-likelihood pose a localizer that knew which bearing is which landmark would give,
``refine_pose`` on every true pair with the scene's sigma -- can itself fall outside that
tolerance: no search can do better than the data. For each trial of each scene this script
computes that pose, its error and its Cramer-Rao position standard deviation, counts the
trials where it is beyond the tolerance, prints them and writes them to the results file.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc.pose import crlb, refine_pose  # noqa: E402
from scenes import CASES, build_map, make_trial  # noqa: E402

#: The benchmark's tolerance (metres, degrees).
TOL_M = 0.1
TOL_DEG = 1.0


def oracle_errors(scene: str, trials: int) -> list[dict[str, float | int]]:
    """For trials ``0 .. trials - 1`` of a scene: the true pairs' pose error (m, deg), the
    Cramer-Rao position sd (m) and the number of true pairs."""
    case = CASES[scene]
    lm = build_map(case.group)
    rows: list[dict[str, float | int]] = []
    for k in range(trials):
        _, sc = make_trial(case, k, lm)
        idx = [i for i, a in enumerate(sc.assignment) if a is not None]
        xy = lm.xy[[sc.assignment[i] for i in idx]]
        pose, _ = refine_pose(xy, sc.bearings[idx], initial=sc.pose, sigma=case.sigma)
        d, dth = pose.distance_to(sc.pose)
        c = crlb(xy, sc.pose, case.sigma)
        rows.append(
            {
                "trial": k,
                "pairs": len(idx),
                "error_m": float(d),
                "error_deg": float(np.rad2deg(dth)),
                "crlb_pos_sd_m": float(np.sqrt(c[0, 0] + c[1, 1])),
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", nargs="+", default=["c", "cgrid"], choices=["c", "cgrid"])
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--out", type=Path, default=HERE / "results_oracle_limits.json")
    args = ap.parse_args(argv)
    if args.trials < 1:
        ap.error(f"--trials must be at least 1, got {args.trials}")
    t0 = time.perf_counter()
    scenes = {}
    for scene in args.scene:
        rows = oracle_errors(scene, args.trials)
        beyond = [r for r in rows if r["error_m"] > TOL_M or r["error_deg"] > TOL_DEG]
        err = np.array([r["error_m"] for r in rows])
        scenes[scene] = {
            "trials": len(rows),
            "beyond_tolerance": len(beyond),
            "at_most_right": len(rows) - len(beyond),
            "error_m_median": float(np.median(err)),
            "error_m_max": float(err.max()),
            "beyond": beyond,
        }
        print(
            f"{scene}: {len(rows)} trials; the true pairs' pose is beyond {TOL_M} m / "
            f"{TOL_DEG} deg in {len(beyond)} (at most {len(rows) - len(beyond)} right for any "
            f"localizer); its error median {np.median(err):.3f} m, max {err.max():.3f} m"
        )
        for r in beyond:
            print(
                f"  trial {r['trial']}: {r['error_m']:.3f} m, {r['error_deg']:.2f} deg "
                f"({r['pairs']} pairs, Cramer-Rao position sd {r['crlb_pos_sd_m']:.3f} m)"
            )
    meta = run_meta("oracle_limits.py", argv, wall_s=round(time.perf_counter() - t0, 1))
    write_results(args.out, meta, tolerance_m=TOL_M, tolerance_deg=TOL_DEG, scenes=scenes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
