"""How soon could ANY localizer know where an MRCLAM robot is? (issue 15's time targets)

Run:  python benchmarks/track_oracle_limits.py [DATA] [--robots 1 2 3 4 5] [--every 1.0]
      [--out FILE]

Issue 15 asks for the first correct ``localized`` state within a median of 10 s of a run's
start (every run within 60 s), and for a kidnapped robot to be correct again within a median
of 15 s. This script bounds those times from below with everything a localizer could be
given short of the answer itself: it is TOLD which landmark each bearing comes from (the
frames' landmark ids; the other robots' bearings are dropped), its odometry is linearised
at the true path, and it starts from no information at all about the pose.

The method is :mod:`omniloc.evaluate.bounds` (its documentation says what the bound assumes
and leaves out): the recursion of the posterior Cramer-Rao bound along the true path, from
no information, with the odometry's noise of ``MotionModel.mrclam()``; a frame could be
localized when the pose there is within 0.3 m and 5 deg with probability >= ``p`` (0.99,
the tracker's ``localized_probability``; also 0.9). Three bearing error models: one Gaussian
of 1 deg (the preset's sigma), and the mixture measured on the recordings (57 % at 0.33
deg, 43 % at 1.03 deg, worth a Gaussian of 0.52 deg), that mixture with its errors
independent from frame to frame and repeating as the recordings' do (68 % of a bearing's
error variance a bias common to every tube, forgotten over 13.8 s, 16 % an offset common to
the frame's bearings, 13 % the tube's own bias, forgotten over 18.1 s:
``omniloc.evaluate.bounds.MRCLAM_REPEATING``, fitted by benchmarks/bearing_correlation.py).
Everything the bound leaves out makes it optimistic -- the correspondences known, the
odometry without biases, and in the first two models the bearing errors independent from
frame to frame -- so its times are lower bounds and its shares upper bounds.
``omniloc evaluate --dataset mrclam-track`` reports the same bound (the measured mixture
repeating as measured, the tracker's ``localized_probability``) beside the tracker on every
stream.

Three figures per setting:

* per run, the time from its first frame to the first frame at which it could be localized
  (the target: median <= 10 s, every run <= 60 s);
* over start times every ``--every`` seconds of every run (up to ``--horizon`` seconds
  before its end, so that a start not localized by the run's end is censored beyond the
  median), the time from ``t0`` to the first frame after it at which it could be
  localized: what a kidnapped robot, set down at ``t0`` with no knowledge, needs at best
  (the target: a median <= 15 s);
* per run, the share of its frames after that first one at which the filter started at the
  run's first frame (told the correspondences all along) could say ``localized``: the
  frames an honest localizer could call localized, at best (the target: localized and
  correct in >= 95 % of the frames after the first correct state).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc.evaluate.bounds import (  # noqa: E402
    MRCLAM_BEARING_ERRORS,
    MRCLAM_REPEATING,
    RepeatingErrors,
    bearing_information,
    bound_steps,
    confident_frames,
    times_to_localize,
)
from omniloc.evaluate.tracking import mrclam_streams  # noqa: E402
from omniloc.track import MotionModel  # noqa: E402

FloatArray = NDArray[np.float64]

DEFAULT_DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: "Correct" in issue 15: within 0.3 m and 5 deg of the truth.
TOL_M = 0.3
TOL_HEADING = math.radians(5.0)
#: The error models compared: name -> (shares, sds in radians, repeating errors or None).
ERROR_MODELS: dict[str, tuple[tuple[float, ...], tuple[float, ...], RepeatingErrors | None]] = {
    "gaussian 1 deg (the preset's sigma)": ((1.0,), (math.radians(1.0),), None),
    "measured mixture (57 % at 0.33 deg, 43 % at 1.03 deg)": (*MRCLAM_BEARING_ERRORS, None),
    "measured mixture, repeating (68 % common over 13.8 s, 16 % the frame's, 13 % the tube's "
    "over 18.1 s)": (
        *MRCLAM_BEARING_ERRORS,
        MRCLAM_REPEATING,
    ),
}
PROBABILITIES = (0.99, 0.9)


def _summary(times: FloatArray) -> dict[str, float | int]:
    """Median, 10th and 90th percentiles (of the times themselves, no interpolation: a
    start not localized by its run's end is inf, later than any other) and shares."""
    q = np.quantile(times, [0.1, 0.5, 0.9], method="inverted_cdf") if times.size else [math.nan] * 3
    return {
        "starts": int(times.size),
        "not_localized_by_run_end": int(np.sum(~np.isfinite(times))),
        "median_s": float(q[1]),
        "p10_s": float(q[0]),
        "p90_s": float(q[2]),
        "within_10_s": float(np.mean(times <= 10.0)),
        "within_15_s": float(np.mean(times <= 15.0)),
        "within_60_s": float(np.mean(times <= 60.0)),
    }


def _finite_or_none(x: object) -> object:
    """JSON has no infinity: inf (never) is written as null."""
    if isinstance(x, dict):
        return {k: _finite_or_none(v) for k, v in x.items()}
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _s(v: float) -> str:
    return "never" if not math.isfinite(v) else f"{v:.1f} s"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", nargs="?", default=str(DEFAULT_DATA), help="MRCLAM set 6 folder")
    ap.add_argument("--robots", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--every", type=float, default=1.0, help="seconds between start times")
    ap.add_argument(
        "--horizon", type=float, default=120.0, help="seconds a start must leave of its run"
    )
    ap.add_argument("--out", default=str(HERE / "results_track_oracle.json"))
    args = ap.parse_args(argv)
    if not args.every > 0:
        ap.error("--every must be > 0")
    if not args.horizon >= 0:
        ap.error("--horizon must be >= 0")
    t_wall = time.perf_counter()
    motion = MotionModel.mrclam()
    streams = mrclam_streams(args.data, args.robots)
    steps = {s.name: bound_steps(s, motion) for s in streams}
    results: dict[str, dict[str, object]] = {}
    for model, (shares, sds, repeat) in ERROR_MODELS.items():
        info = bearing_information(shares, sds)
        for p_min in PROBABILITIES:
            key = f"{model}, p >= {p_min}"
            runs: dict[str, float] = {}
            pooled: list[FloatArray] = []
            after: dict[str, float] = {}
            for name, st in steps.items():
                # Starts at least `horizon` before the run's end: a start that has not
                # localized when the run ends is censored there, and such censored times
                # are all above the median only if the run has enough left after each.
                grid = np.arange(st.t[0], st.t[-1] - args.horizon, args.every)
                starts = np.unique(np.searchsorted(st.t, grid))
                starts = starts[starts < st.t.size]
                tt = times_to_localize(
                    st, starts, info, p_min, tol_m=TOL_M, tol_heading=TOL_HEADING, repeat=repeat
                )
                runs[name] = float(tt[0])
                pooled.append(tt)
                ok = confident_frames(
                    st, info, p_min, tol_m=TOL_M, tol_heading=TOL_HEADING, repeat=repeat
                )
                after[name] = float(ok[np.argmax(ok) :].mean()) if ok.any() else math.nan
            first = np.array(list(runs.values()))
            results[key] = {
                "bearing_sd_equivalent_deg": math.degrees(1.0 / math.sqrt(info)),
                "repeating": None if repeat is None else asdict(repeat),
                "p_min": p_min,
                "first_from_first_frame_s": runs,
                "first_median_s": float(np.median(first)),
                "first_max_s": float(first.max()),
                "from_any_start": _summary(np.concatenate(pooled)),
                "confident_after_first": after,
                "confident_after_first_mean": float(np.nanmean(list(after.values()))),
            }
            r = results[key]
            a = r["from_any_start"]
            sd = r["bearing_sd_equivalent_deg"]
            print(f"{key} (one bearing worth a Gaussian of {sd:.2f} deg)")
            print(
                "  from each run's first frame: "
                + ", ".join(f"{n} {_s(v)}" for n, v in runs.items())
                + f"; median {_s(r['first_median_s'])}, max {_s(r['first_max_s'])}"
            )
            print(
                f"  from any start ({a['starts']} starts, every {args.every:g} s): median "
                f"{_s(a['median_s'])}, 10-90 % {_s(a['p10_s'])} - {_s(a['p90_s'])}; within 10 s "
                f"{100 * a['within_10_s']:.1f} %, 15 s {100 * a['within_15_s']:.1f} %, 60 s "
                f"{100 * a['within_60_s']:.1f} %; not before the run's end "
                f"{a['not_localized_by_run_end']}"
            )
            print(
                "  frames after the first that could be localized, told the correspondences "
                "from the run's start: "
                + ", ".join(f"{n} {100 * v:.1f} %" for n, v in after.items())
                + f"; mean {100 * r['confident_after_first_mean']:.1f} %"
            )
    per_run = {
        n: {"frames": int(st.t.size), "landmark_bearings": int(st.bearings.sum())}
        for n, st in steps.items()
    }
    meta = run_meta(
        "track_oracle_limits.py",
        argv,
        wall_s=round(time.perf_counter() - t_wall, 1),
        tolerance={"m": TOL_M, "deg": math.degrees(TOL_HEADING)},
        motion="MotionModel.mrclam()",
        every_s=args.every,
        horizon_s=args.horizon,
    )
    write_results(args.out, meta, runs=per_run, bounds=_finite_or_none(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
