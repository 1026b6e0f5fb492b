"""Does the odometry's heading error grow with the changes of its turn rate?

Run:  python benchmarks/odometry_changes.py [--data PATH] [--out PATH] [--no-fit]

MRCLAM's robots log the velocities they were told to drive, 20-25 rows a second, and at times
the turn rate flips its sign row by row (robot 5 at 589-593 s: -0.56 and +0.20 rad/s). The
motion model's heading noise grows with the angle turned and the time
(``turn_per_rad``, ``turn_per_s``); a robot that answers each change of its velocities after
a time that varies leaves a heading error of that time times the change, however little it
turns in all (``MotionModel.delay_var``).

On the five runs this script takes non-overlapping windows of 1, 2 and 5 s, the heading
change the odometry predicts (the ``mrclam`` preset's latency and scales) against the Vicon
track's, and the sum of the squared changes of the turn rate inside each window; it prints
the error by that sum and the least-squares fit of the squared error on the window's length,
the angle turned and the sum (a variance per change, if the coefficient does not grow with
the window). Then how often the heading error over 2-s stretches lies inside the 50 % and
99 % regions of the heading variance each motion model propagates
(:func:`omniloc.track.motion.integrate`, with the stretch's own pieces), over all stretches
and over the tenth whose turn rate changes most: the preset, the preset with part of its
drift moved to ``delay_var``, the five runs' pooled ``estimate_motion`` fit of 2026-12-05
(before ``delay_var``) and today's (fitted here unless ``--no-fit``, which takes the values
docs/tracking.md lists). Writes ``results_odometry_changes.json`` beside
this file; docs/tracking-notebook.md ("The odometry's response to a change") says what
became of it.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc.track import (  # noqa: E402
    GroundTruth,
    MotionModel,
    Odometry,
    check_motion,
    estimate_motion,
    load_groundtruth,
    load_odometry,
)

FloatArray = NDArray[np.float64]

#: The windows' lengths (s) of the first table.
WINDOWS = (1.0, 2.0, 5.0)
#: Bins of the sum of the squared changes of the turn rate in a window, (rad/s)^2.
BINS = (0.0, 1e-4, 0.01, 0.05, 0.2, 1.0, math.inf)
#: Longest gap (s) of the Vicon track a window may hold.
MAX_GAP_S = 0.5
#: Seconds skipped before the first window: windows then start half-way between whole
#: seconds of the odometry's clock (a simulated robot changing its velocities on the
#: second has its changes inside the windows, not on their edges).
SKIP_S = 1.5
#: The five runs' pooled fit of 2026-12-05, before ``delay_var`` (as docs/tracking.md,
#: "Calibrating a robot of your own", printed it until 2026-12-07), and of 2026-12-07 with
#: it (what the docs print now, and what ``--no-fit`` takes).
SCALES = {"delay_s": 0.23, "v_scale": 1.043, "turn_slowdown": 1.08, "w_scale": 0.942}
BEFORE = MotionModel(
    along_per_m=0.0, across_per_m=7.6e-6, turn_per_rad=0.00953, turn_per_m=0.0,
    turn_per_s=3.12e-5, along_per_s=2.14e-5, **SCALES,
)  # fmt: skip
TODAY = MotionModel(
    along_per_m=0.0, across_per_m=8.45e-6, turn_per_rad=0.00352, turn_per_m=0.000784,
    turn_per_s=8.57e-7, along_per_s=9.4e-6, delay_var=0.00454, **SCALES,
)  # fmt: skip


def windows(
    odometry: Odometry, truth: GroundTruth, length: float, model: MotionModel
) -> tuple[FloatArray, FloatArray, tuple[tuple[FloatArray, ...], ...]]:
    """Non-overlapping windows of ``length`` s the odometry and the truth both cover
    (:func:`~omniloc.track.check_motion`): the heading error (the truth's change minus the
    model's), the model's variance of it (with the truth's own), and each window's pieces
    (durations, v, w, vy) in the odometry's time, shifted by the model's latency."""
    check = check_motion(odometry, truth, model, length=length, max_gap_s=MAX_GAP_S, skip_s=SKIP_S)
    return check.errors[:, 2], check.covariance[:, 2, 2], check.pieces


def changes(w: FloatArray, dt: FloatArray) -> float:
    """Sum of the squared changes of the turn rate between the pieces that move."""
    moving = w[dt > 0]
    return float(np.sum(np.diff(moving) ** 2))


def by_changes(
    runs: list[tuple[Odometry, GroundTruth]], length: float, model: MotionModel | None = None
) -> dict[str, object]:
    """The first table's row for one window length: the heading error by the sum of the
    squared changes of the turn rate, and the least-squares variance per second, per radian
    turned and per (rad/s)^2 of change (``model``'s latency and scales; the ``mrclam``
    preset's by default)."""
    model = MotionModel.mrclam() if model is None else model
    err, cols = [], []
    for odometry, truth in runs:
        e, _var, pieces = windows(odometry, truth, length, model)
        err.append(e)
        for dt, _v, w, _vy in pieces:
            cols.append((float(dt.sum()), float(np.sum(np.abs(w) * dt)), changes(w, dt)))
    e = np.concatenate(err)
    X = np.array(cols)
    coef, *_ = np.linalg.lstsq(X, e**2, rcond=None)
    bins = []
    for b0, b1 in itertools.pairwise(BINS):
        m = (X[:, 2] >= b0) & (X[:, 2] < b1)
        if m.any():
            bins.append(
                {
                    "from": b0,
                    "to": b1,
                    "windows": int(m.sum()),
                    "rms_deg": float(np.degrees(np.sqrt(np.mean(e[m] ** 2)))),
                    "turned_mean_rad": float(X[m, 1].mean()),
                }
            )
    return {
        "window_s": length,
        "windows": int(e.size),
        "fit": {"per_s": float(coef[0]), "per_rad": float(coef[1]), "per_change": float(coef[2])},
        "bins": bins,
    }


def coverage(
    runs: list[tuple[Odometry, GroundTruth]], models: dict[str, MotionModel], length: float = 2.0
) -> dict[str, dict[str, float]]:
    """How often the heading error over ``length``-s stretches lies inside each model's 50 %
    and 99 % regions: over all, and over the tenth whose turn rate changes most."""
    out = {}
    q50, q99 = chi2.ppf(0.5, 1), chi2.ppf(0.99, 1)
    for name, model in models.items():
        nees, flips = [], []
        for odometry, truth in runs:
            e, var, pieces = windows(odometry, truth, length, model)
            nees.append(e**2 / var)  # (var holds the Vicon track's own heading noise)
            flips.append(np.array([changes(w, dt) for dt, _v, w, _vy in pieces]))
        q = np.concatenate(nees)
        f = np.concatenate(flips)
        top = f > np.quantile(f, 0.9)
        out[name] = {
            "stretches": int(q.size),
            "inside_50": float(np.mean(q <= q50)),
            "inside_99": float(np.mean(q <= q99)),
            "most_changes_inside_50": float(np.mean(q[top] <= q50)),
            "most_changes_inside_99": float(np.mean(q[top] <= q99)),
        }
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=HERE.parent.parent / "shared/data/mrclam-ds6")
    ap.add_argument("--out", type=Path, default=HERE / "results_odometry_changes.json")
    ap.add_argument(
        "--no-fit", action="store_true", help="take today's pooled fit from docs/tracking.md"
    )
    args = ap.parse_args(argv)
    runs = [
        (
            load_odometry(args.data / f"robot{r}_odometry.csv"),
            load_groundtruth(args.data / f"robot{r}_groundtruth_10hz.csv"),
        )
        for r in range(1, 6)
    ]
    print("The odometry's heading error (the mrclam preset's latency and scales) by the sum of")
    print("the squared changes of its turn rate in the window, five MRCLAM runs:")
    rows = []
    for length in WINDOWS:
        row = by_changes(runs, length)
        rows.append(row)
        fit = row["fit"]
        print(
            f"  {length:g}-s windows ({row['windows']}): squared error ~ "
            f"{fit['per_s']:.2g} dt + {fit['per_rad']:.2g} |dtheta| "  # type: ignore[index]
            f"+ {fit['per_change']:.2g} sum(dw^2)"  # type: ignore[index]
        )
        for b in row["bins"]:  # type: ignore[attr-defined]
            print(
                f"    sum in [{b['from']:g}, {b['to']:g}): {b['windows']:4d} windows, "
                f"{b['rms_deg']:.2f} deg RMS (turned {b['turned_mean_rad']:.2f} rad on average)"
            )
    preset = MotionModel.mrclam()
    today = TODAY
    if not args.no_fit:
        today = estimate_motion([o for o, _ in runs], [g for _, g in runs]).model
    models = {
        "the preset": preset,
        "the preset, turn_per_s 5e-4 and delay_var 0.0025": replace(
            preset, turn_per_s=5e-4, delay_var=0.0025
        ),
        "pooled fit before delay_var (2026-12-05)": BEFORE,
        "pooled fit with delay_var" + (" (docs)" if args.no_fit else ""): today,
    }
    cov = coverage(runs, models)
    print("The heading error over 2-s stretches inside each model's 50 % / 99 % region:")
    for name, c in cov.items():
        print(
            f"  {name}: {100 * c['inside_50']:.1f} / {100 * c['inside_99']:.1f} % of "
            f"{c['stretches']}; the tenth that change most: "
            f"{100 * c['most_changes_inside_50']:.1f} / {100 * c['most_changes_inside_99']:.1f} %"
        )
    write_results(
        args.out,
        run_meta("odometry_changes.py", argv),
        windows=rows,
        coverage=cov,
        models={k: asdict(m) for k, m in models.items()},
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
