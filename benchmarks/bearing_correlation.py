"""Do MRCLAM's bearing errors repeat from frame to frame, as the tracker's weighing must know?

Run:  python benchmarks/bearing_correlation.py [--data PATH] [--out PATH]

The tracker's frame model (``omniloc.track.likelihood``) takes each frame's bearing errors to
be independent of the last frame's, so a tube seen in ten frames counts as ten independent
measurements of the pose. On each frame of the five MRCLAM runs this script takes the
bearings of known tubes (the frames' own landmark ids), their errors against the Vicon pose
(measured minus predicted, those within 5 deg: the tail is left to the gate), and for each
pair of sightings of one tube on one run, the correlation of the two errors by the time
between them. Writes ``results_bearing_correlation.json`` beside this file;
docs/tracking-notebook.md ("Splitting on clutter and weighing the evidence") says what the
tracker does with it.

How much of that is a calibration, not noise: the errors are also fitted (least squares) with
what a camera's calibration would hold -- per run a heading offset (the camera's yaw on the
robot) and the camera's offset from the tracked centre (forward, left: a bearing error of
``(forward sin b - left cos b) / range``), and one time offset between the frames' and the
truth's clocks (an error of ``offset * turn rate``) -- fitted on the first half of each run and
tested on the second; the correlations are then measured again on what the fit leaves.

And the model a tracker could use instead of independent errors: each tube's error as a bias
that drifts (an Ornstein-Uhlenbeck process: stationary sd, correlation time) plus white noise,
fitted by maximum likelihood on each tube's sequence of errors (a Kalman filter per
sequence), against independent Gaussian errors.

Much of what repeats is not the tube's own: two different tubes' errors in one frame are
correlated too (``same_frame``). So the errors are also fitted, by maximum likelihood over
each run's frames (a Kalman filter over a bias common to every tube and each tube's own),
as a common bias that drifts, each tube's own bias that drifts, an offset common to one
frame's bearings, and white noise (``shared_bias``, with
``omniloc.evaluate.bearing_errors.fit_shared_biases``; the bound on what the data allow,
``omniloc.evaluate.bounds.MRCLAM_REPEATING``, takes its shares). A part every bearing shares
moves them all as a turn of the robot would: it costs the heading, not the position.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc.angles import wrap  # noqa: E402
from omniloc.evaluate.bearing_errors import (  # noqa: E402
    MAX_ERROR,
    fit_shared_biases,
    same_frame_correlation,
)
from omniloc.evaluate.bearing_errors import sightings as error_sightings  # noqa: E402
from omniloc.evaluate.tracking import Stream, mrclam_streams  # noqa: E402
from omniloc.track.calibrate import turn_noise_fit  # noqa: E402

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: The lags (s) whose correlation is reported: each bin is (previous, this].
LAGS = (0.3, 0.6, 1.2, 2.5, 5.0)


def sightings(streams: Sequence[Stream]) -> list[tuple[int, int, float, float]]:
    """Every bearing of a known tube as ``(run, tube, t, error)`` (error in radians, frames
    without ground truth skipped; :func:`omniloc.evaluate.bearing_errors.sightings`)."""
    s = error_sightings(streams, MAX_ERROR)
    return [
        (int(r), int(n), float(t), float(e))
        for r, n, t, e in zip(s.run, s.landmark, s.t, s.error, strict=True)
    ]


def geometry(
    streams: Sequence[Stream], rows: Sequence[tuple[int, int, float, float]], dt: float = 0.1
) -> FloatArray:
    """For each sighting of :func:`sightings`: the bearing predicted from the true pose
    (rad), the range (m) and the true turn rate (rad/s, central difference over ``2 dt``),
    shape (n, 3)."""
    out = np.full((len(rows), 3), np.nan)
    for k, st in enumerate(streams):
        idx = np.array([i for i, r in enumerate(rows) if r[0] == k], dtype=np.int64)
        if idx.size == 0:
            continue
        t = np.array([rows[i][2] for i in idx])
        tube = np.array([rows[i][1] for i in idx])
        x, _ = st.truth_at(t)
        before, _ = st.truth_at(t - dt)
        after, _ = st.truth_at(t + dt)
        d = st.landmarks.xy[tube] - x[:, :2]
        out[idx, 0] = wrap(np.arctan2(d[:, 1], d[:, 0]) - x[:, 2])
        out[idx, 1] = np.hypot(d[:, 0], d[:, 1])
        out[idx, 2] = wrap(after[:, 2] - before[:, 2]) / (2 * dt)
    return out


def calibration_design(run: IntArray, geo: FloatArray, runs: int) -> FloatArray:
    """The least-squares design of the calibration: per run a constant (minus the camera's
    yaw), the camera's forward and left offsets; then the clock offset (s)."""
    b, r, w = geo[:, 0], geo[:, 1], geo[:, 2]
    cols = []
    for k in range(runs):
        on = (run == k).astype(float)
        cols += [on, on * np.sin(b) / r, -on * np.cos(b) / r]
    cols.append(w)
    return np.array(cols).T


def systematic(
    rows: Sequence[tuple[int, int, float, float]], geo: FloatArray, runs: int
) -> dict[str, object]:
    """Fit the calibration (:func:`calibration_design`) on the first half of each run (by
    time), apply it to the second, and on all of it; returns the fitted values, the error
    RMS of the second half before and after, and the residuals of the fit on all of it.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> n = 4000
    >>> geo = np.c_[rng.uniform(-0.5, 0.5, n), rng.uniform(1, 6, n), rng.normal(0, 0.2, n)]
    >>> e = -0.01 + 0.05 * np.sin(geo[:, 0]) / geo[:, 1] + 0.04 * geo[:, 2]
    >>> rows = [(0, 0, float(i), float(v)) for i, v in enumerate(e)]
    >>> out = systematic(rows, geo, 1)
    >>> [round(v, 3) + 0.0 for v in out["runs"][0].values()], round(out["clock_offset_s"], 3)
    ([0.573, 0.05, 0.0], 0.04)
    """
    run = np.array([r[0] for r in rows], dtype=np.int64)
    t = np.array([r[2] for r in rows])
    e = np.array([r[3] for r in rows])
    ok = np.isfinite(geo).all(axis=1)
    first = np.zeros(len(rows), dtype=bool)
    for k in range(runs):
        on = run == k
        if on.any():
            first |= on & (t < np.median(t[on]))
    X = calibration_design(run, np.where(ok[:, None], geo, 1.0), runs)
    used = [c for c in range(X.shape[1]) if np.abs(X[ok & first, c]).sum() > 0]
    X = X[:, used]
    half, *_ = np.linalg.lstsq(X[ok & first], e[ok & first], rcond=None)
    test = ok & ~first
    whole, *_ = np.linalg.lstsq(X[ok], e[ok], rcond=None)
    coef = np.zeros(3 * runs + 1)
    coef[used] = whole
    residual = np.where(ok, e - X @ whole, np.nan)
    return {
        "runs": [
            {
                "camera_yaw_deg": -math.degrees(coef[3 * k]),
                "camera_forward_m": float(coef[3 * k + 1]),
                "camera_left_m": float(coef[3 * k + 2]),
            }
            for k in range(runs)
        ],
        "clock_offset_s": float(coef[-1]),
        "held_out_rms_deg": math.degrees(float(np.sqrt(np.mean(e[test] ** 2)))),
        "held_out_rms_after_deg": math.degrees(
            float(np.sqrt(np.mean((e[test] - X[test] @ half) ** 2)))
        ),
        "residual": residual,
    }


def drifting_bias_fit(rows: Sequence[tuple[int, int, float, float]]) -> dict[str, float]:
    """Maximum-likelihood fit of "bias that drifts plus white noise" to each tube's errors on
    each run: the bias an Ornstein-Uhlenbeck process of stationary sd ``bias_sd`` and
    correlation time ``tau_s``, the noise of sd ``white_sd`` (radians). Returns them with the
    gain in log-likelihood per sighting over independent Gaussian errors.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> rows, b = [], 0.0
    >>> for i in range(4000):
    ...     a = math.exp(-0.25 / 5.0)
    ...     b = a * b + math.sqrt(1 - a * a) * 0.01 * rng.normal()
    ...     rows.append((0, 0, 0.25 * i, b + 0.004 * rng.normal()))
    >>> fit = drifting_bias_fit(rows)
    >>> abs(fit["bias_sd"] - 0.01) < 0.002, abs(fit["white_sd"] - 0.004) < 0.001
    (True, True)
    >>> 3 < fit["tau_s"] < 8, fit["gain_per_sighting"] > 0.5
    (True, True)
    """
    from scipy.optimize import minimize

    by: dict[tuple[int, int], list[tuple[float, float]]] = {}
    for run, tube, t, e in rows:
        by.setdefault((run, tube), []).append((t, e))
    seqs = [np.array(sorted(v)) for v in by.values()]

    def nll(p: FloatArray) -> float:
        sb, tau, sw = np.exp(p)
        total = 0.0
        for seq in seqs:
            m, v, prev = 0.0, sb * sb, seq[0, 0]
            for t, e in seq:
                a = math.exp(-(t - prev) / tau)
                prev = t
                m, v = a * m, a * a * v + (1.0 - a * a) * sb * sb
                S = v + sw * sw
                r = e - m
                total += 0.5 * (r * r / S + math.log(2.0 * math.pi * S))
                k = v / S
                m, v = m + k * r, v * (1.0 - k)
        return total

    err = np.array([r[3] for r in rows])
    sd = float(err.std())
    p0 = np.log([sd * 0.7, 10.0, sd * 0.5])
    res = minimize(nll, p0, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 0.5})
    sb, tau, sw = (float(v) for v in np.exp(res.x))
    independent = 0.5 * err.size * (1.0 + math.log(2.0 * math.pi * sd * sd))
    return {
        "bias_sd": sb,
        "tau_s": tau,
        "white_sd": sw,
        "gain_per_sighting": (independent - float(res.fun)) / err.size,
    }


def lag_correlations(
    rows: Sequence[tuple[int, int, float, float]], lags: Sequence[float] = LAGS
) -> list[dict[str, float]]:
    """For each lag bin (previous lag, lag], the correlation of the errors of two sightings
    of one tube on one run that far apart.

    Examples
    --------
    >>> rows = [(0, 1, 0.25 * i, e) for i, e in enumerate([0.01, 0.01, -0.02, -0.02])]
    >>> [round(r["correlation"], 2) for r in lag_correlations(rows, (0.3,))]
    [0.5]
    """
    by: dict[tuple[int, int], list[tuple[float, float]]] = {}
    for run, tube, t, e in rows:
        by.setdefault((run, tube), []).append((t, e))
    lo = [0.0, *lags[:-1]]
    pairs: list[list[tuple[float, float]]] = [[] for _ in lags]
    for seq in by.values():
        seq.sort()
        t = np.array([s[0] for s in seq])
        e = np.array([s[1] for s in seq])
        for i in range(t.size):
            j = i + 1
            while j < t.size and t[j] - t[i] <= lags[-1]:
                dt = t[j] - t[i]
                for b, (a, c) in enumerate(zip(lo, lags, strict=True)):
                    if a < dt <= c:
                        pairs[b].append((e[i], e[j]))
                j += 1
    out = []
    for a, c, p in zip(lo, lags, pairs, strict=True):
        v = np.array(p, dtype=float).reshape(-1, 2)
        corr = float(np.corrcoef(v[:, 0], v[:, 1])[0, 1]) if len(v) > 2 else math.nan
        out.append({"lag_from_s": a, "lag_to_s": c, "pairs": len(v), "correlation": corr})
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(DATA), help="the MRCLAM set 6 folder")
    ap.add_argument("--out", default=str(HERE / "results_bearing_correlation.json"))
    args = ap.parse_args(argv)
    streams = mrclam_streams(args.data)
    rows = sightings(streams)
    err = np.array([r[3] for r in rows])
    print(f"{err.size} sightings of known tubes; error sd {math.degrees(err.std()):.2f} deg")
    lags = lag_correlations(rows)
    fit = systematic(rows, geometry(streams, rows), len(streams))
    res = fit.pop("residual")
    assert isinstance(res, np.ndarray)
    rest = [(*r[:3], float(v)) for r, v in zip(rows, res, strict=True) if np.isfinite(v)]
    after = lag_correlations(rest)
    for r, a in zip(lags, after, strict=True):
        print(
            f"{r['lag_from_s']:.2f}-{r['lag_to_s']:.2f} s apart ({r['pairs']} pairs): "
            f"correlation {r['correlation']:.2f} ({a['correlation']:.2f} after the calibration)"
        )
    runs = fit["runs"]
    assert isinstance(runs, list)
    for k, c in enumerate(runs):
        print(
            f"run {k + 1}: camera yaw {c['camera_yaw_deg']:+.2f} deg, forward "
            f"{c['camera_forward_m']:+.3f} m, left {c['camera_left_m']:+.3f} m"
        )
    print(
        f"clock offset {fit['clock_offset_s']:+.3f} s; second halves' RMS error "
        f"{fit['held_out_rms_deg']:.2f} -> {fit['held_out_rms_after_deg']:.2f} deg "
        "(fitted on the first halves)"
    )
    geo = geometry(streams, rows)
    turn = turn_noise_fit(err, geo[:, 2])
    for b in turn["bins"]:  # type: ignore[attr-defined]
        print(
            f"turning at {b['from']:.2f}-{b['to']:.2f} rad/s ({b['n']} sightings): robust sd "
            f"{math.degrees(b['sd']):.2f} deg"
        )
    print(
        f"bearing noise: sd {math.degrees(float(turn['sd0'])):.2f} deg standing still, plus "  # type: ignore[arg-type]
        f"{float(turn['turn_noise_s']):.3f} s times the turn rate"  # type: ignore[arg-type]
    )
    ou = drifting_bias_fit(rows)
    print(
        f"drifting bias: sd {math.degrees(ou['bias_sd']):.2f} deg, correlation time "
        f"{ou['tau_s']:.1f} s, white noise {math.degrees(ou['white_sd']):.2f} deg; "
        f"{ou['gain_per_sighting']:.2f} nats a sighting better than independent errors"
    )
    S = error_sightings(streams, MAX_ERROR)
    frame = same_frame_correlation(S)
    same = {
        "pairs": frame.pairs,
        "correlation": frame.correlation,
        "difference_sd": frame.difference_sd,
    }
    print(
        f"two tubes in one frame ({same['pairs']} pairs): correlation {same['correlation']:.2f}; "
        f"their difference {math.degrees(same['difference_sd']):.2f} deg per tube"
    )
    sfit = fit_shared_biases(S)
    common, frame_share, own, white = sfit.shares()
    shared = {
        "common_sd": sfit.common_sd,
        "common_tau_s": sfit.common_tau_s,
        "tube_sd": sfit.landmark_sd,
        "tube_tau_s": sfit.landmark_tau_s,
        "frame_sd": sfit.frame_sd,
        "white_sd": sfit.white_sd,
        "common_share": common,
        "tube_share": own,
        "frame_share": frame_share,
        "white_share": white,
        "gain_per_sighting": sfit.gain_per_sighting,
        "evaluations": sfit.evaluations,
        "converged": sfit.converged,
    }
    print(
        f"shared biases: common to every tube sd {math.degrees(shared['common_sd']):.2f} deg "
        f"over {shared['common_tau_s']:.1f} s, each tube's own "
        f"{math.degrees(shared['tube_sd']):.2f} deg over {shared['tube_tau_s']:.1f} s, the "
        f"frame's offset {math.degrees(shared['frame_sd']):.2f} deg, white "
        f"{math.degrees(shared['white_sd']):.2f} deg; {shared['gain_per_sighting']:.2f} nats a "
        "sighting better than independent errors"
    )
    write_results(
        args.out,
        run_meta("bearing_correlation.py", argv),
        sightings=int(err.size),
        same_frame=same,
        shared_bias=shared,
        error_sd_deg=math.degrees(float(err.std())),
        lags=lags,
        calibration=fit,
        lags_after_calibration=after,
        drifting_bias=ou,
        turn_noise=turn,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
