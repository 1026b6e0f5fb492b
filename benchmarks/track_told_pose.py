"""The tracker told where the robot starts (``Tracker.set_pose``, ``omniloc track
--initial-pose``) on MRCLAM set 6: how soon it is right, and how often wrong, told the true
start or a wrong one, surely or loosely.

Run:  python benchmarks/track_told_pose.py [--data PATH] [--robots 1 2 3 4 5] [--out PATH]

Each robot's whole run with the ``mrclam`` preset, told at its first frame:

* nothing (global localization: the figures of ``omniloc evaluate --dataset mrclam-track``);
* the true start, surely (sds 0.05 m and 1.5 deg: within 0.3 m and 5 deg with probability
  0.999, so taken at its word) or loosely (0.5 m and 15 deg, AMCL's initial covariance and
  ``--initial-sd``'s default: a prior the searches must confirm);
* a start 1 m off, surely or loosely (the wrong pose a user may give).

Scored as the evaluation scores (localized and within 0.3 m and 5 deg of the truth): the
time from the first frame to the first correct localized state, the localized frames, the
wrong ones (and the largest error among them). Writes ``results_track_told_pose.json`` and
``.md`` beside this file (about 4 minutes).
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
from omniloc.evaluate.tracking import errors_against, mrclam_streams, run_stream  # noqa: E402
from omniloc.track import Tracker, preset  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"

#: (name, offset of the told pose from the true start (m, m, deg), sds (m, deg)); None: told
#: nothing.
VARIANTS: tuple[tuple[str, tuple[float, float, float] | None, tuple[float, float]], ...] = (
    ("told nothing", None, (0.0, 0.0)),
    ("the true start, surely", (0.0, 0.0, 0.0), (0.05, 1.5)),
    ("the true start, loosely", (0.0, 0.0, 0.0), (0.5, 15.0)),
    ("1 m off, surely", (1.0, 0.0, 0.0), (0.05, 1.5)),
    ("1 m off, loosely", (1.0, 0.0, 0.0), (0.5, 15.0)),
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATA, help="the mrclam-ds6 folder")
    ap.add_argument("--robots", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--out", type=Path, default=HERE / "results_track_told_pose.json")
    args = ap.parse_args(argv)
    w0 = time.perf_counter()
    streams = mrclam_streams(args.data, args.robots)
    sensor, motion, config = preset("mrclam")
    rows = []
    for name, offset, (sd_m, sd_deg) in VARIANTS:
        for st in streams:
            truth = st.segments[0].truth
            t0 = st.frames[0].t
            tracker = Tracker(st.landmarks, sensor, motion, config)
            if offset is not None:
                start = truth.at(np.array([t0]))[0][0]
                told = start + np.array([offset[0], offset[1], math.radians(offset[2])])
                cov = np.diag([sd_m**2, sd_m**2, math.radians(sd_deg) ** 2])
                tracker.set_pose(told, cov)
            est, _ = run_stream(tracker, st)
            ok, d_pos, _ = errors_against(truth, est)
            loc = np.array([e.localized for e in est])
            right = np.flatnonzero(loc & ok)
            wrong = loc & ~ok
            row = {
                "variant": name,
                "robot": st.name,
                "first_correct_s": float(est[right[0]].t - t0) if right.size else None,
                "frames": len(est),
                "localized": int(loc.sum()),
                "wrong": int(wrong.sum()),
                "largest_wrong_m": float(np.nanmax(d_pos[wrong])) if wrong.any() else None,
            }
            rows.append(row)
            first = "never" if row["first_correct_s"] is None else f"{row['first_correct_s']:.1f} s"
            print(
                f"{name:26s} {st.name}: first correct {first}, localized {row['localized']}, "
                f"wrong {row['wrong']}"
            )
    wall = time.perf_counter() - w0
    meta = run_meta("track_told_pose.py", argv, wall_s=round(wall, 1))
    write_results(args.out, meta, rows=rows)
    md = [
        "# The tracker told where the robot starts (`benchmarks/track_told_pose.py`)",
        "",
        f"{meta['date']}, {meta['machine']}; `{meta['command']}`, {wall:.0f} s. MRCLAM set 6,"
        " the `mrclam` preset; told at the first frame (`Tracker.set_pose`). 'Wrong': "
        "localized and more than 0.3 m or 5 deg from the truth.",
        "",
        "| told | first correct localized, per robot | localized frames | wrong (% of frames) |"
        " largest position error of a wrong frame |",
        "|---|---|---|---|---|",
    ]
    for name, _, _ in VARIANTS:
        rs = [r for r in rows if r["variant"] == name]
        firsts = ", ".join(
            "never" if r["first_correct_s"] is None else f"{r['first_correct_s']:.1f} s" for r in rs
        )
        n = sum(r["frames"] for r in rs)
        loc = sum(r["localized"] for r in rs)
        bad = sum(r["wrong"] for r in rs)
        worst = max((r["largest_wrong_m"] for r in rs if r["largest_wrong_m"]), default=None)
        md.append(
            f"| {name} | {firsts} | {loc:,} | {bad} ({100 * bad / n:.2f} %) | "
            f"{'-' if worst is None else f'{worst:.2f} m'} |"
        )
    args.out.with_suffix(".md").write_text("\n".join(md) + "\n")
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
