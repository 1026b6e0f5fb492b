"""Does ``exhaustive=False`` ever return nothing where a solution exists? (issue 16, item 3)

Run:  python benchmarks/first_fit.py [--trials 1000] [--scene cgrid] [--out results_first_fit.json]

On the trials of a large-map scene (c-grid by default: 10,000 landmarks on a jittered grid,
every landmark within 20 m observed plus 2 spurious bearings, sigma 0.3 deg), runs
``localize(..., exhaustive=False)`` with the scene's noise, spurious count and range, and
counts the trials where it returned no solution, and among those the ones where it said it
stopped early (``complete=False``: a budget) -- a first fit that finds nothing searches again
exhaustively, so an empty answer means that nothing passes the gates. Also counts the first
fits that were right (0.1 m / 1 deg), and times them. Prints the figures and writes them to
the results file.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from omniloc.search import localize  # noqa: E402
from scenes import CASES, DEFAULT_KWARGS, build_map, make_trial  # noqa: E402

DEG = float(np.deg2rad(1.0))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=1000)
    ap.add_argument("--scene", default="cgrid", choices=["c", "cgrid"])
    ap.add_argument("--out", type=Path, default=HERE / "results_first_fit.json")
    args = ap.parse_args(argv)
    case = CASES[args.scene]
    lm = build_map(case.group)
    kw = {**DEFAULT_KWARGS, "exhaustive": False}
    localize(lm, make_trial(case, 0, lm)[1].bearings, **kw)  # warm-up
    empty = empty_early = right = retried = 0
    times = []
    for i in range(args.trials):
        _, sc = make_trial(case, i, lm)
        t0 = time.perf_counter()
        res = localize(lm, sc.bearings, **kw)
        times.append(time.perf_counter() - t0)
        retried += bool(res.stats.exhaustive)
        if not res:
            empty += 1
            empty_early += not res.stats.complete
            continue
        d, dth = res.best.pose.distance_to(sc.pose)
        right += bool(d <= 0.1 and dth <= DEG)
    t = np.asarray(times) * 1e3
    out = {
        "scene": args.scene,
        "trials": args.trials,
        "options": {k: v for k, v in kw.items()},
        "empty": empty,
        "empty_said_incomplete": empty_early,
        "searched_again_exhaustively": retried,
        "best_right": right,
        "median_ms": float(np.median(t)),
        "p95_ms": float(np.percentile(t, 95)),
    }
    args.out.write_text(json.dumps(out, indent=1))
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
