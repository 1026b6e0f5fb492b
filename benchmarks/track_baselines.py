"""Baselines for localization over time on MRCLAM set 6, scored by omniloc's one scoring code.

Run:  python benchmarks/track_baselines.py [--quick] [--particles 2000,10000,50000]
                                           [--kidnap N] [--large-streams N] [--seed S]
                                           [--out PATH]
      python benchmarks/track_baselines.py --tune {ekf,pf-track,pf-global,recovery,kidnap}
                                           [--particles N] [--tune-streams N] [--passes N]

What runs (every localizer through :func:`omniloc.evaluate.tracking.evaluate_tracking`, on the
same streams, in this one process):

* **EKF, known correspondences, started at the truth** (``baselines_track/ekf_known.py``):
  the upper bound. Odometry prediction with the calibrated noise model times a tuned
  multiplier; an update per landmark bearing with the TRUE landmark (``Frame.truth``; other
  robots' bearings skipped); an innovation gate. Always ``localized``; never flags a
  kidnapping (it is told where it starts and which landmark is which, not that it moved).
* **Particle filter, unknown correspondences, uniform start** (``particle_filter.py``):
  what users pick instead (AMCL; Beluga's bearing model with a field of view and a clutter
  term): a mixture likelihood per bearing over the landmarks visible from each particle,
  odometry motion sampling, low-variance resampling when the effective sample size drops,
  augmented MCL (w_slow / w_fast) random particles, a clustered state (``localized`` when
  the densest cluster holds ``localized_share`` = 0.95 of the weight), ``kidnapped`` when
  w_fast / w_slow drops below its threshold after being localized. Run at each particle
  count of ``--particles``; its tracking check (started at the truth) on the whole runs too.
* **omniloc's Tracker**, when ``omniloc.track`` exposes ``Tracker`` (see
  :func:`make_tracker`, the one place to adapt), else skipped with a note.

Streams: the five whole runs, ``--kidnap`` kidnapped streams and as many plain streams of the
same lengths without a jump (``kidnap_streams``, seeded by ``--seed``). From
:data:`LARGE` particles on, the filter is scored on the whole runs and the first
``--large-streams`` kidnapped and plain streams only (the bound on its time). The
tracking check (the filter started at the truth, whole runs) runs at the smallest count.

How the baselines were tuned (``--tune``; the record is ``baselines_track/tuning.json``)
-----------------------------------------------------------------------------------------
On TUNING streams, never on the scored ones: ``--tune-streams`` kidnapped and plain
stretches drawn with seed ``--seed + 1000`` (:func:`tuning_streams`). There is no second
recording, so they are other stretches of the same five runs, started at other times -- what
a user tuning on their own robot's logs would have. Both filters use the odometry noise model
fitted to the recording's ground truth (:func:`baselines_track.motion.calibrate_motion_noise`,
1-s windows) times a tuned multiplier. The objective everywhere is J = share of frames
correct - share confidently wrong, pooled over the tuning streams' frames.

* EKF: the grid noise multiplier x bearing sigma x gate (:data:`EKF_GRID`) on the plain
  tuning streams, started at the truth.
* PF: (1) the start of the search: started at the truth, without random particles, 2,000
  particles, grids over the association (mean / sum / nearest), the bearing sigma, the
  clutter weight and the noise multiplier (:data:`PF_TRACK_GRIDS`), and a first descent
  from a uniform start (both on the whole runs: the record marks them; only the start of
  the search comes from them); (2) from a uniform start on the plain tuning streams,
  coordinate descent over :data:`PF_GLOBAL_AXES` at 2,000 particles, over sigma and clutter
  from 10,000 on (starting from the nearest count's best); (3) the random particles
  (:data:`PF_RECOVERY_AXES`) on the kidnapped and plain tuning streams, and the kidnap
  threshold replayed on the same runs: the most kidnappings flagged within 30 s at a
  false-alarm run rate <= 10 %. Counts not tuned take the nearest tuned count's options
  (:func:`tuned_options`); the options used are in the results' ``meta``.

Time: see ``benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _results import libraries  # noqa: E402
from baselines_track.ekf_known import EkfConfig, EkfKnown  # noqa: E402
from baselines_track.harness import evaluate_streams  # noqa: E402
from baselines_track.motion import MotionNoise, calibrate_motion_noise  # noqa: E402
from baselines_track.particle_filter import ParticleFilter, PfConfig  # noqa: E402
from baselines_track.tuning import (  # noqa: E402
    pf_factory,
    tune_ekf,
    tune_kidnap_ratio,
    tune_pf_global,
    tune_pf_tracking,
    tune_recovery,
)
from omniloc.evaluate.bounds import MRCLAM_REPEATING  # noqa: E402
from omniloc.evaluate.tracking import (  # noqa: E402
    LocalizerOverTime,
    Stream,
    TrackingResult,
    kidnap_streams,
    mrclam_bound,
    mrclam_streams,
)
from omniloc.maps import LandmarkMap  # noqa: E402
from omniloc.pose import Pose  # noqa: E402

DEFAULT_DATA = HERE.parents[1] / "shared" / "data" / "mrclam-ds6"
DEFAULT_OUT = HERE / "results_tracking.json"
TUNING_RECORD = HERE / "baselines_track" / "tuning.json"
#: The tuning streams are drawn with the evaluation's seed plus this.
TUNING_SEED_OFFSET = 1000

#: The EKF's tuning grid (``--tune ekf``; what it chose is in the record).
#: (A first, full grid -- noise 1-64, sigma 0.25-2 deg, gates 3, 5, 10, none -- on the whole
#: runs put the best at noise 8, sigma 0.25 deg, gate 10: this grid spans that region.)
EKF_GRID: dict[str, list[Any]] = {
    "noise_scale": [2, 4, 8, 16, 32],
    "sigma_deg": [0.25, 0.5, 1.0],
    "gate_sigmas": [5.0, 10.0],
}

#: The particle filter's tracking grids (``--tune pf-track --grid coarse|refine``): the
#: coarse grid's best lay on its edges (clutter 0.99, sigma 0.5 deg), so a second grid
#: extends beyond them.
PF_TRACK_GRIDS: dict[str, dict[str, list[Any]]] = {
    "coarse": {
        "association": ["sum", "nearest", "mean"],
        "sigma_deg": [0.5, 1.0, 2.0],
        "clutter": [0.5, 0.8, 0.95, 0.99],
        "noise_scale": [0.5, 1, 2, 4],
    },
    "refine": {
        "association": ["sum", "nearest"],
        "sigma_deg": [0.25, 0.5],
        "clutter": [0.99, 0.995, 0.999],
        "noise_scale": [0.5, 1, 2],
    },
}
#: Coordinate descent from a uniform start on the whole runs (``--tune pf-global``), with
#: Thrun's alphas (0.001, 0.1) held: on whole runs nothing needs recovering, so the random
#: particles are tuned on kidnapped streams instead (``--tune recovery``). With 50,000
#: particles (5 minutes per setting) only the likelihood and the noise are searched again.
#: (The 2,000-particle descent, run first, also searched the alphas and the per-bearing
#: average on the whole runs; its record keeps them.)
PF_GLOBAL_AXES: dict[str, list[Any]] = {
    "noise_scale": [0.5, 1, 2, 4],
    "sigma_deg": [0.25, 0.5, 1.0, 2.0],
    "clutter": [0.9, 0.95, 0.99, 0.995],
    "association": ["sum", "nearest"],
    "resample_ess": [0.25, 0.5, 1.0],
}
PF_GLOBAL_AXES_LARGE = ("sigma_deg", "clutter")
#: From this many particles on, the evaluation scores the whole runs and only the first
#: ``--large-streams`` kidnapped and plain streams (50,000 particles cost about 0.07 CPU s
#: per second of recording: all 200 streams would take an hour on this machine).
LARGE = 50_000
#: The random particles, on the tuning streams (``--tune recovery``).
PF_RECOVERY_AXES: dict[str, list[Any]] = {
    "alphas": [(0.0, 0.0), (0.001, 0.1), (0.01, 0.1), (0.001, 0.02)],
    "per_bearing": [True, False],
}
KIDNAP_THRESHOLDS = [0.99, 0.95, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2]


def pf_config(n: int, noise: MotionNoise, opts: dict[str, Any]) -> PfConfig:
    """The :class:`PfConfig` for ``n`` particles with ``opts`` on top of its defaults
    (``noise_scale`` multiplies the calibrated noise, ``alphas`` is (slow, fast))."""
    o = dict(opts)
    slow, fast = o.pop("alphas", (0.001, 0.1))
    return PfConfig(
        n_particles=n,
        noise=noise.scaled(float(o.pop("noise_scale", 1.0))),
        sigma=math.radians(float(o.pop("sigma_deg", 2.0))),
        alpha_slow=slow,
        alpha_fast=fast,
        **o,
    )


def ekf_config(noise: MotionNoise, opts: dict[str, Any]) -> EkfConfig:
    return EkfConfig(
        noise=noise.scaled(float(opts["noise_scale"])),
        sigma=math.radians(float(opts["sigma_deg"])),
        gate_sigmas=float(opts["gate_sigmas"]),
    )


# --------------------------------------------------------------------------------------------
# omniloc's own tracker
# --------------------------------------------------------------------------------------------


def make_tracker(landmarks: LandmarkMap, start: Pose | None) -> LocalizerOverTime:
    """A fresh omniloc Tracker for one stream, with the ``mrclam`` preset (``start`` is
    ignored: the tracker is not told where it starts). Without presets (an older omniloc) the
    MRCLAM sensor settings of ``omniloc.evaluate.DATASET_DEFAULTS`` and the defaults."""
    import omniloc.track as track
    from omniloc.evaluate import DATASET_DEFAULTS
    from omniloc.sensor import SensorModel
    from omniloc.track import Tracker  # type: ignore[attr-defined]

    if hasattr(track, "preset"):
        sensor, motion, config = track.preset("mrclam")
        return Tracker(landmarks, sensor, motion, config)  # type: ignore[no-any-return]
    opts = DATASET_DEFAULTS["mrclam"]["options"]
    sensor = SensorModel(sigma=opts["sigma"], fov=opts["fov"], max_range=opts["max_range"])
    return Tracker(landmarks, sensor=sensor)  # type: ignore[no-any-return]


def tracker_available() -> tuple[bool, str]:
    try:
        import omniloc.track as track
    except ImportError as exc:  # pragma: no cover
        return False, f"omniloc.track does not import: {exc}"
    if not hasattr(track, "Tracker"):
        return False, "omniloc.track has no Tracker yet: its row is skipped"
    return True, ""


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------


def warm_up(landmarks_xy: np.ndarray, noise: MotionNoise) -> None:
    """Compile the kernels (or load them from numba's cache) before anything is timed."""
    pf = ParticleFilter(landmarks_xy, PfConfig(n_particles=50, noise=noise), rng=0)
    ekf = EkfKnown(landmarks_xy, Pose(1.0, 0.0, 0.0), [], EkfConfig(noise=noise))
    for k in range(3):
        t = 0.25 * (k + 1)
        pf.odometry([t - 0.25], [0.1], [0.05])
        ekf.odometry([t - 0.25], [0.1], [0.05])
        pf.frame(t, np.array([0.1, -0.2]))
    ekf._odo.take(1.0)


def run_all(
    runs: list[Stream],
    kid: list[Stream],
    plain: list[Stream],
    particles: Sequence[int],
    noise: MotionNoise,
    seed: int,
    log: Callable[[str], None],
    *,
    chosen: dict[str, Any],
    large_streams: int,
    save: Callable[[dict[str, dict[str, Any]]], Any] | None = None,
) -> dict[str, dict[str, Any]]:
    streams = [*runs, *kid, *plain]
    out: dict[str, dict[str, Any]] = {}

    def record(key: str, res: TrackingResult, wall: float, **extra: Any) -> None:
        d = res.as_dict()
        d["wall_s"] = round(wall, 1)
        d.update(extra)
        out[key] = d
        if save is not None:
            save({key: d})
        t = res.totals()
        log(
            f"{key}: {len(res.runs)} streams in {wall:.0f} s; correct "
            f"{t['localized_rate'] - t['confidently_wrong_rate']:.3f}, wrong "
            f"{t['confidently_wrong_rate']:.3f}"
        )

    cfg = ekf_config(noise, chosen["ekf"])

    def make_ekf(s: Stream, start: Pose | None) -> EkfKnown:
        assert start is not None
        return EkfKnown(s.landmarks.xy, start, s.frames, cfg)

    t0 = time.time()
    res = evaluate_streams(streams, make_ekf, name="EKF known (truth start)", oracle_start=True)
    record("ekf_known", res, time.time() - t0, config=cfg.as_dict(), oracle_start=True)

    for n in particles:
        pcfg = pf_config(n, noise, chosen["pf"][n])
        some = streams
        if n >= LARGE:
            some = [*runs, *kid[:large_streams], *plain[:large_streams]]
        if n == min(particles):
            t0 = time.time()
            res = evaluate_streams(
                runs, pf_factory(pcfg, seed), name=f"PF {n} (truth start)", oracle_start=True
            )
            record(
                f"pf{n}_truth_start",
                res,
                time.time() - t0,
                config=pcfg.as_dict(),
                oracle_start=True,
            )
        t0 = time.time()
        res = evaluate_streams(some, pf_factory(pcfg, seed), name=f"PF {n}")
        record(
            f"pf{n}",
            res,
            time.time() - t0,
            config=pcfg.as_dict(),
            options=chosen["pf"][n],
            oracle_start=False,
        )

    return out


def run_tracker(streams: list[Stream], log: Callable[[str], None]) -> dict[str, Any]:
    """omniloc's Tracker on the same streams, or why it was skipped (no Tracker yet, or the
    factory does not fit it: then the error is recorded and the baselines still run)."""
    ok, why = tracker_available()
    if ok:
        try:
            make_tracker(streams[0].landmarks, None)
        except Exception as exc:  # the factory is the lead's to adapt: report, do not stop
            ok, why = False, f"make_tracker failed ({type(exc).__name__}: {exc}): adapt it"
    if not ok:
        log(why)
        return {"skipped": why}
    t0 = time.time()
    res = evaluate_streams(
        streams,
        lambda s, st: make_tracker(s.landmarks, None),
        name="omniloc Tracker",
        bound=mrclam_bound(BOUND_P),
    )
    d = res.as_dict()
    d["wall_s"] = round(time.time() - t0, 1)
    d["oracle_start"] = False
    return d


# --------------------------------------------------------------------------------------------
# Tables
# --------------------------------------------------------------------------------------------

#: What the data allow: a localizer told the correspondences, as sure as the tracker's
#: ``localized_probability`` (omniloc.evaluate.bounds).
BOUND_P = 0.99
BOUND_LABEL = f"told the correspondences, sure at {BOUND_P} (what the data allow)"

LABELS = {
    "ekf_known": "EKF, known correspondences, truth start (upper bound)",
    "tracker": "omniloc Tracker",
}


def _label(key: str) -> str:
    if key in LABELS:
        return LABELS[key]
    if key.endswith("_truth_start"):
        return f"PF {int(key[2:-12]):,} particles, truth start (tracking check)"
    return f"PF {int(key[2:]):,} particles, uniform start"


def _f(v: Any, fmt: str = "{:.3g}") -> str:
    if v == math.inf:
        return "never"  # (a median time over runs half of which never got there)
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return fmt.format(v)


def _pct(v: Any) -> str:
    return _f(None if v is None else 100 * v, "{:.1f} %")


def _cpu_per_s(runs: list[dict[str, Any]]) -> float:
    cpu = sum(r["cpu_s"] for r in runs)
    dur = sum(r["duration_s"] for r in runs)
    return cpu / dur if dur else math.nan


def _cov(t: dict[str, Any]) -> str:
    """The truth inside the reported covariance's 50 % / 99 % regions, over the localized
    frames ("-" for rows measured before the scoring had it)."""
    if not t.get("cov_frames"):
        return "-"
    inside_50 = _f(100 * t["cov_inside_50_rate"], "{:.0f}")
    return f"{inside_50} / {_f(100 * t['cov_inside_99_rate'], '{:.0f}')} %"


def _run_scores(runs: list[dict[str, Any]]) -> list[Any]:
    """Stored runs (JSON: None where NaN) as :class:`RunScore`."""
    from omniloc.evaluate.tracking import RunScore

    return [RunScore(**{k: (math.nan if v is None else v) for k, v in r.items()}) for r in runs]


def _totals(runs: list[dict[str, Any]]) -> dict[str, Any]:
    return TrackingResult("x", _run_scores(runs)).totals()


def _retotal(result: dict[str, Any]) -> dict[str, Any]:
    """A stored result with its totals computed again from its runs by today's scoring."""
    if "runs" not in result:
        return result
    fresh = TrackingResult(result.get("name", "x"), _run_scores(result["runs"])).as_dict()
    keys = ("totals", "totals_without_jump", "totals_kidnapped")
    return {**result, **{k: fresh[k] for k in keys}}


def _bound_runs(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """The runs that carry what the data allow (the tracker's, since 2026-12-04 21:30),
    their "never" restored: JSON keeps inf as null, and a bound's time is never undefined
    (a recovery is, on a stream without a jump)."""
    runs = results.get("tracker", {}).get("runs", [])
    if not runs or not all("bound_time_to_localize_s" in r for r in runs):
        return []
    out = []
    for r in runs:
        r = dict(r)
        if r["bound_time_to_localize_s"] is None:
            r["bound_time_to_localize_s"] = math.inf
        if r["bound_recovery_s"] is None and r["jump_t"] is not None:
            r["bound_recovery_s"] = math.inf
        out.append(r)
    return out


def tables(results: dict[str, dict[str, Any]]) -> str:
    lines: list[str] = []
    keys = [k for k, v in results.items() if "runs" in v]
    bound_runs = _bound_runs(results)

    # Per robot (whole runs).
    lines += [
        "**Whole runs, per robot** (time to first correct localized state; share of frames "
        "correct after it; shares of all scored frames correct / confidently wrong; RMSE over "
        "localized frames; CPU seconds per second of recording)",
        "",
        "| localizer | robot | time to localize s | correct after | correct | "
        "confidently wrong | pos RMSE m | heading RMSE deg | CPU s / s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for k in keys:
        for r in results[k]["runs"]:
            if not r["name"].startswith("robot"):
                continue
            sc = max(r["n_scored"], 1)
            lines.append(
                f"| {_label(k)} | {r['name']} | {_f(r['time_to_localize_s'], '{:.1f}')} | "
                f"{_pct(r['correct_after_rate'])} | "
                f"{_pct((r['n_localized'] - r['n_confidently_wrong']) / sc)} | "
                f"{_pct(r['n_confidently_wrong'] / sc)} | {_f(r['pos_rmse_m'], '{:.3f}')} | "
                f"{_f(r['heading_rmse_deg'], '{:.2f}')} | "
                f"{_f(r['cpu_s'] / r['duration_s'], '{:.4f}')} |"
            )
    for r in bound_runs:
        if r["name"].startswith("robot"):
            lines.append(
                f"| {BOUND_LABEL} | {r['name']} | "
                f"{_f(r['bound_time_to_localize_s'], '{:.1f}')} | "
                f"{_pct(r['bound_correct_after_rate'])} | - | - | - | - | - |"
            )
    lines.append("")

    # Where the localized frames' errors lie, and which part of the pose the covariance is
    # too sure of (rows measured before the scoring had them are left out).
    split = [k for k in keys if all("along_mean_m" in r for r in results[k]["runs"])]
    if split:
        lines += [
            "**Where the error lies, per robot** (over the localized frames: the position "
            "error along the robot's true heading, + ahead, and across it, + to its left, "
            "mean / RMSE; the truth inside the 99 % region of the reported covariance's "
            "position block, and of its heading variance)",
            "",
            "| localizer | robot | localized frames | along mean / RMSE m | "
            "across mean / RMSE m | position in its 99 % region | heading in its 99 % "
            "interval |",
            "|---|---|---|---|---|---|---|",
        ]
        for k in split:
            for r in results[k]["runs"]:
                if not r["name"].startswith("robot"):
                    continue
                cov = max(r["cov_frames"], 1)
                lines.append(
                    f"| {_label(k)} | {r['name']} | {r['n_localized']} | "
                    f"{_f(r['along_mean_m'], '{:+.3f}')} / {_f(r['along_rmse_m'], '{:.3f}')} | "
                    f"{_f(r['across_mean_m'], '{:+.3f}')} / "
                    f"{_f(r['across_rmse_m'], '{:.3f}')} | "
                    + (
                        f"{_pct(r['cov_position_inside_99'] / cov)} | "
                        f"{_pct(r['cov_heading_inside_99'] / cov)} |"
                        if r["cov_frames"]
                        else "- | - |"
                    )
                )
        lines.append("")

    # Totals per stream set.
    lines += [
        "**Totals per set of streams** (whole runs: the five robots; kidnapped: the streams "
        "with a jump; plain: the same stretches without one; a median time counts a stream "
        "that never got there as later than any that did: never, when half or more never "
        "did)",
        "",
        "| localizer | streams | n | time to localize median / max s | never | "
        "correct after | correct | confidently wrong | pos RMSE m | heading RMSE deg | "
        "detection delay median s | undetected | recovery median s | unrecovered | "
        "false-alarm run rate | truth in the covariance's 50 % / 99 % region | CPU s / s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for k in keys:
        runs = results[k]["runs"]
        sets = {
            "whole runs": [r for r in runs if r["name"].startswith("robot")],
            "kidnapped": [r for r in runs if r["name"].startswith("kidnap")],
            "plain": [r for r in runs if r["name"].startswith("plain")],
        }
        for set_name, rs in sets.items():
            if not rs:
                continue
            t = _totals(rs)
            kid = set_name == "kidnapped"
            lines.append(
                f"| {_label(k)} | {set_name} | {len(rs)} | "
                f"{_f(t['time_to_localize_median_s'], '{:.1f}')} / "
                f"{_f(t['time_to_localize_max_s'], '{:.0f}')} | {int(t['never_localized'])} | "
                f"{_pct(t['correct_after_rate'])} | "
                f"{_pct(t['localized_rate'] - t['confidently_wrong_rate'])} | "
                f"{_pct(t['confidently_wrong_rate'])} | {_f(t['pos_rmse_m'], '{:.3f}')} | "
                f"{_f(t['heading_rmse_deg'], '{:.2f}')} | "
                f"{_f(t['detection_delay_median_s'], '{:.1f}') if kid else '-'} | "
                f"{int(t['undetected']) if kid else '-'} | "
                f"{_f(t['recovery_median_s'], '{:.1f}') if kid else '-'} | "
                f"{int(t['unrecovered']) if kid else '-'} | "
                f"{_pct(t['false_alarm_run_rate']) if set_name == 'plain' else '-'} | "
                f"{_cov(t)} | {_f(_cpu_per_s(rs), '{:.4f}')} |"
            )
    for set_name, prefix in (("whole runs", "robot"), ("kidnapped", "kidnap"), ("plain", "plain")):
        rs = [r for r in bound_runs if r["name"].startswith(prefix)]
        if not rs:
            continue
        t = _totals(rs)
        kid = set_name == "kidnapped"
        lines.append(
            f"| {BOUND_LABEL} | {set_name} | {len(rs)} | "
            f"{_f(t['bound_time_to_localize_median_s'], '{:.1f}')} / "
            f"{_f(t['bound_time_to_localize_max_s'], '{:.0f}')} | "
            f"{sum(r.bound_time_to_localize_s == math.inf for r in _run_scores(rs))} | "
            f"{_pct(t['bound_correct_after_rate'])} | - | - | - | - | - | - | "
            f"{_f(t['bound_recovery_median_s'], '{:.1f}') if kid else '-'} | - | - | - | - |"
        )
    if bound_runs:
        lines += [
            "",
            f"*{BOUND_LABEL}*: `omniloc.evaluate.bounds.stream_bound` on each stream -- the "
            "Cramer-Rao recursion of the bearings (told which tube each is; the measured "
            "errors, 57 % at 0.33 deg and 43 % at 1.03 deg, "
            f"{MRCLAM_REPEATING.describe()}: `MRCLAM_REPEATING`) and the odometry "
            "(`MotionModel.mrclam()`) along the true path from no information, afresh at a "
            f"kidnapping; a frame counts once the pose is within tolerance with probability "
            f"{BOUND_P}. Optimistic (the correspondences known, the odometry without biases), "
            "so its times are the least any honest localizer needs.",
        ]
    skipped = [f"{_label(k)}: {v['skipped']}" for k, v in results.items() if "skipped" in v]
    if skipped:
        lines += ["", *(f"*Skipped*: {s}" for s in skipped)]
    return "\n".join(lines)


def tuning_summary(rec: dict[str, Any]) -> str:
    """The tuning record in short: each search's best and its runners-up."""

    def opts(o: dict[str, Any]) -> str:
        return ", ".join(f"{k} {v}" for k, v in o.items())

    lines = [
        "**How the baselines were tuned** (`baselines_track/tuning.json`; J = correct - "
        "confidently wrong, pooled over frames)",
        "",
    ]
    for key, v in rec.items():
        if key.startswith("superseded"):
            lines.append(f"* `{key}` ({', '.join(k for k in v if k != 'why')}): {v['why']}")
            continue
        rows = v.get("rows", [])
        if key.startswith("recovery_"):
            lines.append(
                f"* `{key}` ({v['streams']} kidnapped + {v['streams']} plain tuning streams, "
                f"seed + 1000): best {opts(v['best']['options'])} (J {v['best']['J']}, "
                f"unrecovered {v['best']['unrecovered']:.0f}, the others after a median of "
                f"{_f(v['best']['recovery_median_recovered_s'], '{:.0f}')} s); kidnap threshold "
                f"{v['kidnap_ratio']['kidnap_ratio']} (false-alarm run rate "
                f"{v['kidnap_ratio']['false_alarm_run_rate']}, flagged within 30 s "
                f"{v['kidnap_ratio']['flagged_within_30s']}). Thresholds: "
                + "; ".join(
                    f"{r['kidnap_ratio']}: FA {r['false_alarm_run_rate']}, "
                    f"30 s {r['flagged_within_30s']}"
                    for r in v["kidnap_rows"]
                )
            )
            continue
        if key.startswith("kidnap_"):
            b = v["best"]
            lines.append(
                f"* `{key}`: threshold {b['kidnap_ratio']} (false-alarm run rate "
                f"{b['false_alarm_run_rate']}, flagged within 30 s {b['flagged_within_30s']})"
            )
            continue
        top = sorted(rows, key=lambda r: -r["J"])[:4]
        lines.append(
            f"* `{key}` ({len(rows)} settings on {v.get('streams', 'the whole runs')}): "
            f"best {opts(v['best']['options'])}: J "
            f"{v['best']['J']} (correct {v['best']['correct']}, wrong {v['best']['wrong']}); "
            "next: " + "; ".join(f"{opts(r['options'])}: J {r['J']}" for r in top[1:])
        )
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Tuning
# --------------------------------------------------------------------------------------------


def _save_tuning(key: str, value: Any) -> None:
    rec: dict[str, Any] = {}
    if TUNING_RECORD.is_file():
        rec = json.loads(TUNING_RECORD.read_text())
    rec[key] = {"when": datetime.now(timezone.utc).isoformat(timespec="seconds"), **value}
    TUNING_RECORD.write_text(json.dumps(rec, indent=1, default=str) + "\n")


def tuned_options(rec: dict[str, Any], n: int) -> dict[str, Any]:
    """What the tuning record says for ``n`` particles: the uniform-start descent's best,
    with the random particles of ``recovery_n`` (or of the nearest count tuned for recovery)
    and the kidnap threshold of the nearest count replayed (``kidnap_n``, else
    ``recovery_n``)."""
    opts = _global_best(rec, n)
    recs = {int(k.rsplit("_", 1)[1]): v for k, v in rec.items() if k.startswith("recovery_")}
    if recs:
        near = recs[min(recs, key=lambda m: abs(math.log(m / n)))]
        opts.update(near["best"]["options"])
    # The threshold: the nearest count's (a kidnap_ replay beats recovery_'s at one count).
    ratios = {m: v["kidnap_ratio"]["kidnap_ratio"] for m, v in recs.items()}
    for k, v in rec.items():
        if k.startswith("kidnap_"):
            ratios[int(k.rsplit("_", 1)[1])] = v["best"]["kidnap_ratio"]
    if ratios:
        opts["kidnap_ratio"] = ratios[min(ratios, key=lambda m: abs(math.log(m / n)))]
    opts["alphas"] = tuple(opts.get("alphas", (0.001, 0.1)))
    return opts


def chosen_options(rec: dict[str, Any], particles: Sequence[int]) -> dict[str, Any]:
    """What the tuning record chose: the EKF's grid best and, per particle count, the
    filter's options (:func:`tuned_options`)."""
    if "ekf" not in rec:
        raise SystemExit("no EKF tuning in the record: run --tune ekf first")
    return {
        "ekf": dict(rec["ekf"]["best"]["options"]),
        "pf": {n: tuned_options(rec, n) for n in particles},
    }


def _global_best(rec: dict[str, Any], n: int) -> dict[str, Any]:
    """The uniform-start descent's best for ``n`` particles, or for the nearest count tuned."""
    done = {int(k.rsplit("_", 1)[1]): v for k, v in rec.items() if k.startswith("pf_global_")}
    if not done:
        raise SystemExit("run --tune pf-global first")
    near = min(done, key=lambda m: abs(math.log(m / n)))
    opts = dict(done[near]["best"]["options"])
    opts["alphas"] = tuple(opts.get("alphas", (0.001, 0.1)))
    return opts


def _global_start(rec: dict[str, Any], n: int) -> dict[str, Any]:
    """Where the coordinate descent for ``n`` particles starts: the options of the nearest
    particle count already tuned from a uniform start (with its random particles), else the
    superseded descent's best, else the best tracking setting (with Thrun's alphas 0.001 / 0.1
    and resampling at half the particles)."""
    done = {int(k.rsplit("_", 1)[1]): v for k, v in rec.items() if k.startswith("pf_global_")}
    old = rec.get("superseded_scored_runs", {}).get("pf_global_2000")
    if done:
        opts = tuned_options(rec, n)  # the nearest count's, with its random particles
        opts.pop("kidnap_ratio", None)
    elif old:
        opts = dict(old["best"]["options"])
    else:
        track = [v["best"] for k, v in rec.items() if k.startswith("pf_track_")]
        if not track:
            raise SystemExit("run --tune pf-track first")
        opts = dict(max(track, key=lambda r: r["J"])["options"])
        opts.update(alphas=(0.001, 0.1), resample_ess=0.5, per_bearing=True)
    if isinstance(opts.get("alphas"), list):
        opts["alphas"] = tuple(opts["alphas"])
    return opts


def tuning_streams(runs: list[Stream], n: int, seed: int) -> tuple[list[Stream], list[Stream]]:
    """The streams every search is scored on: ``n`` kidnapped and ``n`` plain stretches of
    the runs drawn with seed ``seed + 1000``, never the evaluation's streams (seed ``seed``)
    nor the whole runs. (There is no second recording: they are other stretches of the same
    five runs, started at other times, which a user tuning on their own robot would have.)"""
    return kidnap_streams(runs, n, rng=seed + TUNING_SEED_OFFSET)


def tune(args: argparse.Namespace, runs: list[Stream], noise: MotionNoise) -> int:
    log = print
    n_tune = args.tune_streams
    kid, plain = tuning_streams(runs, n_tune, args.seed)
    where = {
        "streams": f"{n_tune} plain tuning streams (kidnap_streams seed {args.seed} + "
        f"{TUNING_SEED_OFFSET})",
        "tuning_recording_s": round(sum(s.segments[-1].end - s.segments[0].start for s in plain)),
    }
    if args.tune == "ekf":
        best, rows = tune_ekf(plain, noise, EKF_GRID, log=log)
        _save_tuning("ekf", {**where, "grid": EKF_GRID, "best": best, "rows": rows})
    elif args.tune == "pf-track":
        n = args.particles[0]
        base = pf_config(n, noise, {"alphas": (0.0, 0.0)})
        grid = PF_TRACK_GRIDS[args.grid]
        best, rows = tune_pf_tracking(plain, noise, base, grid, seed=args.seed, log=log)
        _save_tuning(
            f"pf_track_{n}_{args.grid}", {**where, "grid": grid, "best": best, "rows": rows}
        )
    elif args.tune == "pf-global":
        rec = json.loads(TUNING_RECORD.read_text()) if TUNING_RECORD.is_file() else {}
        for n in args.particles:
            start = _global_start(rec, n)
            axes = PF_GLOBAL_AXES
            if n > 2000:
                axes = {k: v for k, v in axes.items() if k in PF_GLOBAL_AXES_LARGE}
            best, rows = tune_pf_global(
                plain,
                noise,
                PfConfig(n_particles=n),
                start,
                axes,
                seed=args.seed,
                max_passes=args.passes,
                log=log,
            )
            _save_tuning(
                f"pf_global_{n}",
                {**where, "axes": axes, "start": start, "best": best, "rows": rows},
            )
            rec = json.loads(TUNING_RECORD.read_text())
    elif args.tune in ("recovery", "kidnap"):
        rec = json.loads(TUNING_RECORD.read_text()) if TUNING_RECORD.is_file() else {}
        for n in args.particles:
            opts = _global_best(rec, n)
            if args.tune == "recovery":
                base = pf_config(n, noise, opts)
                out = tune_recovery(
                    kid,
                    plain,
                    noise,
                    base,
                    PF_RECOVERY_AXES,
                    KIDNAP_THRESHOLDS,
                    seed=args.seed,
                    log=log,
                )
                _save_tuning(f"recovery_{n}", {"streams": n_tune, "start": opts, **out})
            else:
                cfg = pf_config(n, noise, tuned_options(rec, n))
                best, rows = tune_kidnap_ratio(
                    kid, plain, cfg, KIDNAP_THRESHOLDS, seed=args.seed, log=log
                )
                _save_tuning(f"kidnap_{n}", {"streams": n_tune, "best": best, "rows": rows})
    return 0


# --------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="10 kidnappings, 2,000 particles")
    ap.add_argument("--particles", default=None, help="comma-separated particle counts")
    ap.add_argument("--kidnap", type=int, default=None, help="kidnapped (and plain) streams")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument(
        "--tune",
        choices=["ekf", "pf-track", "pf-global", "recovery", "kidnap"],
        default=None,
    )
    ap.add_argument("--grid", choices=sorted(PF_TRACK_GRIDS), default="coarse")
    ap.add_argument(
        "--tune-streams", type=int, default=20, help="plain (and kidnapped) tuning streams"
    )
    ap.add_argument(
        "--large-streams",
        type=int,
        default=4,
        help=f"kidnapped (and plain) streams scored from {LARGE:,} particles on",
    )
    ap.add_argument("--passes", type=int, default=2, help="coordinate-descent passes")
    ap.add_argument(
        "--tracker-only",
        action="store_true",
        help="run omniloc's Tracker only and put its rows beside the baselines' rows already "
        "in --out (the baselines are seeded: their figures do not change between runs)",
    )
    args = ap.parse_args(argv)
    default_particles = "2000" if args.quick else "2000,10000,50000"
    args.particles = [int(p) for p in (args.particles or default_particles).split(",")]
    n_kid = args.kidnap if args.kidnap is not None else (10 if args.quick else 20)
    out = args.out or (
        HERE / "results_tracking-quick.json" if args.quick and not args.tune else DEFAULT_OUT
    )

    t_start = time.time()
    runs = mrclam_streams(args.data)
    noise, fit = calibrate_motion_noise(
        [r.odometry for r in runs], [r.segments[0].truth for r in runs]
    )
    print(f"odometry noise fitted on {int(fit['windows'])} windows: {noise.as_dict()}")
    warm_up(runs[0].landmarks.xy, noise)
    if args.tune:
        return tune(args, runs, noise)

    kid, plain = kidnap_streams(runs, n_kid, rng=args.seed)
    print(
        f"{len(runs)} whole runs, {len(kid)} kidnapped and {len(plain)} plain streams "
        f"(seed {args.seed}); particles {args.particles}"
    )
    chosen = chosen_options(json.loads(TUNING_RECORD.read_text()), args.particles)

    import omniloc

    meta = {
        "when": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(["python benchmarks/track_baselines.py", *(argv or sys.argv[1:])]),
        "python": platform.python_version(),
        "libraries": libraries(),
        "omniloc": getattr(omniloc, "__version__", "?"),
        "machine": platform.processor() or platform.machine(),
        "seed": args.seed,
        "kidnapped_streams": len(kid),
        "plain_streams": len(plain),
        "particles": args.particles,
        "odometry_noise": noise.as_dict(),
        "odometry_fit": fit,
        "ekf_tuned": chosen["ekf"],
        "pf_tuned": {str(k): v for k, v in chosen["pf"].items()},
        "large_streams": args.large_streams,
    }
    results: dict[str, dict[str, Any]] = {}

    def save(done: dict[str, dict[str, Any]], final: bool = False) -> str:
        """Write the JSON and the tables of what has run so far (after each localizer, so
        that a run cut short keeps its figures; ``meta.complete`` says whether it was)."""
        results.update(done)
        meta["wall_s"] = round(time.time() - t_start, 1)
        meta["complete"] = final
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"meta": meta, "results": results}, indent=1, default=str) + "\n")
        md = tables(results)
        if TUNING_RECORD.is_file():
            md += "\n\n" + tuning_summary(json.loads(TUNING_RECORD.read_text()))
        baselines = (
            f" (the baselines' rows: {meta['baselines_measured']})"
            if meta.get("baselines_measured")
            else ""
        )
        head = (
            f"Measured {meta['when']}{baselines} ({meta['machine']}, Python {meta['python']}, "
            f"numpy {meta['libraries']['numpy']}): `{meta['command']}`, {meta['wall_s']:.0f} s"
            + ("" if final else " (INCOMPLETE: the run was still going)")
            + ".\n\n"
        )
        out.with_suffix(".md").write_text(head + md + "\n")
        return md

    if args.tracker_only:
        if not out.is_file():
            print(f"{out}: no earlier results to add the tracker to; run without --tracker-only")
            return 1
        earlier = json.loads(out.read_text())
        old_meta = earlier.get("meta", {})
        if (old_meta.get("seed"), old_meta.get("kidnapped_streams")) != (args.seed, len(kid)):
            print(
                f"{out} holds other streams (seed {old_meta.get('seed')}, "
                f"{old_meta.get('kidnapped_streams')} kidnappings): run the same --seed and "
                "--kidnap"
            )
            return 1
        meta.update({k: v for k, v in old_meta.items() if k not in ("when", "command", "omniloc")})
        # The baselines' rows keep the date they were measured (an earlier --tracker-only
        # run passes it on); the time reported is this run's.
        meta["baselines_measured"] = old_meta.get("baselines_measured") or old_meta.get("when")
        # The earlier rows' totals are computed again from their runs (the scoring may have
        # changed since: e.g. medians that count the runs that never got there).
        results.update({k: _retotal(v) for k, v in earlier.get("results", {}).items()})
        print(save({"tracker": run_tracker([*runs, *kid, *plain], print)}, final=True))
        return 0
    save({"tracker": run_tracker([*runs, *kid, *plain], print)})
    run_all(
        runs,
        kid,
        plain,
        args.particles,
        noise,
        args.seed,
        print,
        chosen=chosen,
        large_streams=args.large_streams,
        save=save,
    )
    print(save({}, final=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
