"""How soon could ANY localizer know where an MRCLAM robot is? (issue 15's time targets)

Run:  python benchmarks/track_oracle_limits.py [DATA] [--robots 1 2 3 4 5] [--every 1.0]
      [--out FILE]

Issue 15 asks for the first correct ``localized`` state within a median of 10 s of a run's
start (every run within 60 s), and for a kidnapped robot to be correct again within a median
of 15 s. This script bounds those times from below with everything a localizer could be
given short of the answer itself: it is TOLD which landmark each bearing comes from (the
frames' landmark ids; the other robots' bearings are dropped), its odometry is linearised
at the true path, and it starts from no information at all about the pose.

From a start time ``t0`` it runs the information filter of the bearings and the odometry
along the TRUE trajectory: the recursion of the posterior Cramer-Rao bound (Tichavsky,
Muravchik and Nehorai, IEEE T-SP 1998) evaluated on the recorded path, the covariance that
no estimator beats under the model linearised there:

* between frames, the odometry's noise (``MotionModel.mrclam()``, the tracker's preset,
  integrated over the recorded velocities between the frames, its latency applied) moves
  the information as a Kalman prediction does, in information form
  ``Y' = (I + Y~ N)^-1 Y~`` with ``Y~ = F^-T Y F^-1``, which holds for a singular ``Y``;
* at each frame, every landmark bearing adds ``H^T H / sigma^2`` (``H`` its gradient at
  the true pose); a bearing's information is that of the error model named (one Gaussian
  of 1 deg, the preset's sigma; or the mixture measured on the recordings, 57 % at 0.33 deg
  and 43 % at 1.03 deg, whose Fisher information is that of a Gaussian of 0.52 deg).

The first frame from which the pose at that frame is within 0.3 m and 5 deg of its estimate
with probability >= ``p`` (0.99, the tracker's ``localized_probability``; also 0.9) is the
earliest time an honest localizer could say ``localized`` and be right by design. The
probability lies above the Gaussian correlation inequality's lower bound (a circle of the
widest position variance times the heading's share: the tracker's own
``within_tolerance``) and below the smaller of the heading's and the widest position
axis's shares; where these do not settle it, a Monte Carlo of 50,000 fixed draws does (a
standard error of 0.0005 at 0.99).

What the bound leaves out makes it optimistic, so the times are lower bounds: correspondences
are known (the interpretation is the hard part: a wrong place that fits is what the tracker
must rule out); the bearing errors are taken as independent from frame to frame (on MRCLAM a
tube's errors are correlated, 0.66 at 0.3 s: benchmarks/bearing_correlation.py); the
odometry's errors are those of the fitted model, without its biases. Negative information
(tubes in view that were not reported) is not counted; with 35 % of the tubes in view
reported per frame it is weak.

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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.special import erf

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc.evaluate.tracking import Stream, mrclam_streams  # noqa: E402
from omniloc.pose import bearing_jacobian  # noqa: E402
from omniloc.track import MotionModel  # noqa: E402
from omniloc.track.motion import between, compose_jacobians, integrate  # noqa: E402
from omniloc.track.tracker import within_tolerance  # noqa: E402

FloatArray = NDArray[np.float64]

DEFAULT_DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: "Correct" in issue 15: within 0.3 m and 5 deg of the truth.
TOL_M = 0.3
TOL_HEADING = math.radians(5.0)
#: The error models compared: name -> (shares, sds in radians).
ERROR_MODELS: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "gaussian 1 deg (the preset's sigma)": ((1.0,), (math.radians(1.0),)),
    "measured mixture (57 % at 0.33 deg, 43 % at 1.03 deg)": (
        (0.57, 0.43),
        (math.radians(0.33), math.radians(1.03)),
    ),
}
PROBABILITIES = (0.99, 0.9)
MC_DRAWS = 50_000


def bearing_information(shares: tuple[float, ...], sds: tuple[float, ...]) -> float:
    """Fisher information (1/rad^2) of one bearing whose error is a zero-mean Gaussian
    mixture: ``int p'(e)^2 / p(e) de``, on a grid of 20,001 points over +-30 of the widest sd.

    Examples
    --------
    >>> round(bearing_information((1.0,), (0.5,)), 6)  # a Gaussian: 1 / sd^2
    4.0
    """
    w = np.asarray(shares, dtype=np.float64)
    s = np.asarray(sds, dtype=np.float64)
    if w.shape != s.shape or w.size == 0 or (s <= 0).any() or (w < 0).any():
        raise ValueError(f"shares and sds must pair up, sds > 0: {shares!r}, {sds!r}")
    w = w / w.sum()
    e = np.linspace(-30 * s.max(), 30 * s.max(), 20_001)
    g = w * np.exp(-0.5 * (e[:, None] / s) ** 2) / (s * math.sqrt(2 * math.pi))
    p = g.sum(axis=1)
    dp = (-g * e[:, None] / s**2).sum(axis=1)
    ok = p > 0
    return float(np.trapezoid(dp[ok] ** 2 / p[ok], e[ok]))


@dataclass(frozen=True)
class Steps:
    """A stream's frames as the information filter sees them.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Frame times.
    F, N : ndarray, shape (k, 3, 3)
        The prediction from frame ``i - 1`` to frame ``i``: the Jacobian of the motion with
        respect to the pose, and the odometry's noise in the world frame (both zero-filled
        and the identity at ``i = 0``).
    HtH : ndarray, shape (k, 3, 3)
        Sum over frame ``i``'s landmark bearings of ``H^T H`` (per unit bearing variance).
    bearings : ndarray of int, shape (k,)
        The number of landmark bearings in each frame.
    """

    t: FloatArray
    F: FloatArray
    N: FloatArray
    HtH: FloatArray
    bearings: NDArray[np.int64]


def stream_steps(stream: Stream, motion: MotionModel) -> Steps:
    """The filter's steps along a stream's true trajectory (frames with ground truth only:
    frames the Vicon track does not cover are left out, the odometry joins their
    neighbours)."""
    t_all = np.array([f.t for f in stream.frames])
    truth, _ = stream.truth_at(t_all)
    keep = np.isfinite(truth).all(axis=1)
    frames = [f for f, k in zip(stream.frames, keep, strict=True) if k]
    t = t_all[keep]
    poses = truth[keep]
    k = t.size
    F = np.tile(np.eye(3), (k, 1, 1))
    N = np.zeros((k, 3, 3))
    HtH = np.zeros((k, 3, 3))
    nb = np.zeros(k, dtype=np.int64)
    xy = stream.landmarks.xy
    for i, f in enumerate(frames):
        if i > 0:
            dt, v, w = stream.odometry.between(t[i - 1] - motion.delay_s, t[i] - motion.delay_s)
            _, Q = integrate(dt, v, w, motion)
            Jp, Jd = compose_jacobians(poses[i - 1], between(poses[i - 1], poses[i]))
            F[i] = Jp
            N[i] = Jd @ Q @ Jd.T
        rows = [r for r in (f.truth or ()) if r is not None]
        if rows:
            _, G = bearing_jacobian(xy[rows], poses[i])
            HtH[i] = G.T @ G
            nb[i] = len(rows)
    return Steps(t, F, N, HtH, nb)


def _probability(cov: FloatArray, draws: FloatArray) -> float:
    """P(|position| <= TOL_M and |heading| <= TOL_HEADING) for a zero-mean Gaussian error of
    covariance ``cov``: the bounds where they settle it, else the Monte Carlo."""
    lo = within_tolerance(cov, TOL_M, TOL_HEADING)
    lam = float(np.linalg.eigvalsh(cov[:2, :2])[-1])
    hi = min(
        float(erf(TOL_HEADING / math.sqrt(2.0 * max(cov[2, 2], 1e-300)))),
        float(erf(TOL_M / math.sqrt(2.0 * max(lam, 1e-300)))),
    )
    if hi - lo < 1e-4:
        return lo
    try:
        L = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return lo
    x = draws @ L.T
    ok = (np.hypot(x[:, 0], x[:, 1]) <= TOL_M) & (np.abs(x[:, 2]) <= TOL_HEADING)
    return float(ok.mean())


def predict_information(Y: FloatArray, F: FloatArray, N: FloatArray) -> FloatArray:
    """The Kalman prediction ``P' = F P F^T + N`` in information form, for information
    matrices ``Y`` (..., 3, 3) that may be singular: ``Y' = (I + Y~ N)^-1 Y~`` with
    ``Y~ = F^-T Y F^-1`` (``F`` invertible; ``N`` may be singular)."""
    Finv = np.linalg.inv(F)
    Yt = np.swapaxes(Finv, -1, -2) @ Y @ Finv
    Yn = np.linalg.solve(np.eye(3) + Yt @ N, Yt)
    return 0.5 * (Yn + np.swapaxes(Yn, -1, -2))


def _confident(y: FloatArray, draws: FloatArray, p_min: float) -> bool:
    """Whether the information ``y`` puts the pose within tolerance with probability
    ``p_min`` (False while it is singular: some direction not yet observed)."""
    ev = np.linalg.eigvalsh(y)
    if ev[0] <= 1e-12 * max(ev[-1], 1e-300):
        return False
    cov = np.linalg.inv(y)
    hi = min(
        float(erf(TOL_HEADING / math.sqrt(2.0 * cov[2, 2]))),
        float(erf(TOL_M / math.sqrt(2.0 * np.linalg.eigvalsh(cov[:2, :2])[-1]))),
    )
    if hi < p_min:
        return False
    return within_tolerance(cov, TOL_M, TOL_HEADING) >= p_min or _probability(cov, draws) >= p_min


def confident_frames(steps: Steps, info: float, p_min: float) -> NDArray[np.bool_]:
    """For each frame, whether the filter started at the stream's first frame (with no
    information, and told the correspondences all along) puts the pose within tolerance
    with probability ``p_min`` there: the frames an honest localizer could call
    ``localized``, at best."""
    draws = np.random.default_rng(0).standard_normal((MC_DRAWS, 3))
    out = np.zeros(steps.t.size, dtype=bool)
    Y = np.zeros((3, 3))
    for i in range(steps.t.size):
        if i > 0:
            Y = predict_information(Y, steps.F[i], steps.N[i])
        Y = Y + info * steps.HtH[i]
        out[i] = _confident(Y, draws, p_min)
    return out


def times_to_localize(
    steps: Steps, starts: NDArray[np.int64], info: float, p_min: float
) -> FloatArray:
    """For each start frame index, the time from it to the first frame (it included) at
    which the filter started there with no information could call the pose localized with
    probability ``p_min``; inf when no frame of the stream does.

    All starts run at once: each step predicts and updates the information of every start
    already begun.
    """
    draws = np.random.default_rng(0).standard_normal((MC_DRAWS, 3))
    k = steps.t.size
    out = np.full(starts.size, np.inf)
    Y = np.zeros((starts.size, 3, 3))
    active = np.zeros(starts.size, dtype=bool)
    for i in range(k):
        if i > 0 and active.any():
            Y[active] = predict_information(Y[active], steps.F[i], steps.N[i])
        active |= starts == i
        Y[active] += info * steps.HtH[i]
        todo = np.flatnonzero(active & ~np.isfinite(out))
        if todo.size == 0:
            if (starts > i).any():
                continue
            break
        for j in todo:
            if _confident(Y[j], draws, p_min):
                out[j] = steps.t[i] - steps.t[starts[j]]
        active[np.isfinite(out)] = False
    return out


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
    steps = {s.name: stream_steps(s, motion) for s in streams}
    results: dict[str, dict[str, object]] = {}
    for model, (shares, sds) in ERROR_MODELS.items():
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
                tt = times_to_localize(st, starts, info, p_min)
                runs[name] = float(tt[0])
                pooled.append(tt)
                ok = confident_frames(st, info, p_min)
                after[name] = float(ok[np.argmax(ok) :].mean()) if ok.any() else math.nan
            first = np.array(list(runs.values()))
            results[key] = {
                "bearing_sd_equivalent_deg": math.degrees(1.0 / math.sqrt(info)),
                "p_min": p_min,
                "first_from_run_start_s": runs,
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
                "  from each run's start: "
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
