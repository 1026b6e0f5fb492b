"""How the baselines were tuned: grids and coordinate descent on the recording, scored by
the harness's own code (:mod:`omniloc.evaluate.tracking`), recorded in ``tuning.json``.

The objective of every search is ``J = correct - confidently wrong``: the share of scored
frames that are ``localized`` and within tolerance, minus the share that are ``localized``
and not (pooled over the streams). A localizer that never commits scores 0; one that commits
to the wrong pose is worse than one that says it does not know.

* :func:`tune_ekf`: a full grid over the odometry noise multiplier, the bearing sigma and the
  gate, on the five whole runs, started at the truth.
* :func:`tune_pf_tracking`: the particle filter started at the truth, without random
  particles (the "can it track at all" check), over the likelihood's shape (association,
  sigma, clutter weight) and the motion noise multiplier; its best setting seeds ...
* :func:`tune_pf_global`: coordinate descent from a uniform start on the five whole runs,
  one option at a time over its grid, keeping a change only when J rises, until a pass
  changes nothing.
* :func:`tune_recovery`: the random particles (alpha_slow / alpha_fast, the per-bearing
  average) on kidnapped and plain tuning streams (drawn with a seed other than the
  evaluation's), where recovering matters -- on whole runs nothing ever needs recovering,
  and random particles only cost; then the kidnap flag's threshold, replayed from the best
  setting's runs (:func:`replay_thresholds`; :func:`tune_kidnap_ratio` does only that).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
import zlib
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from omniloc.evaluate.tracking import Stream, TrackingResult, run_stream, score_run
from omniloc.pose import Pose

from .ekf_known import EkfConfig, EkfKnown
from .harness import evaluate_streams
from .motion import MotionNoise
from .particle_filter import ParticleFilter, PfConfig, replay_kidnap_flags

__all__ = [
    "pf_factory",
    "replay_thresholds",
    "run_traced",
    "stream_seed",
    "summarize",
    "tune_ekf",
    "tune_kidnap_ratio",
    "tune_pf_global",
    "tune_pf_tracking",
    "tune_recovery",
]

Log = Callable[[str], None]


def stream_seed(stream: Stream, seed: int) -> int:
    """A seed per stream, stable across runs and independent of the order of streams."""
    return (zlib.crc32(stream.name.encode()) + 1_000_003 * seed) % (2**32)


def pf_factory(cfg: PfConfig, seed: int) -> Callable[[Stream, Pose | None], ParticleFilter]:
    def make(s: Stream, start: Pose | None) -> ParticleFilter:
        return ParticleFilter(s.landmarks.xy, cfg, start, rng=stream_seed(s, seed))

    return make


def summarize(res: TrackingResult) -> dict[str, Any]:
    t = res.totals()
    correct = t["localized_rate"] - t["confidently_wrong_rate"]
    return {
        "J": round(correct - t["confidently_wrong_rate"], 4),
        "correct": round(correct, 4),
        "wrong": round(t["confidently_wrong_rate"], 4),
        "pos_rmse_m": round(t["pos_rmse_m"], 4) if math.isfinite(t["pos_rmse_m"]) else None,
        # (The median over the streams that localized; how many never did is in the rows.)
        "ttl_median_localized_s": (
            round(t["time_to_localize_median_localized_s"], 1)
            if math.isfinite(t["time_to_localize_median_localized_s"])
            else None
        ),
        "per_run": [
            [
                r.name,
                round((r.n_localized - r.n_confidently_wrong) / max(r.n_scored, 1), 3),
                round(r.n_confidently_wrong / max(r.n_scored, 1), 3),
            ]
            for r in res.runs
        ],
        "cpu_s": round(sum(r.cpu_s for r in res.runs), 1),
    }


def _grid(axes: dict[str, Sequence[Any]]) -> Iterable[dict[str, Any]]:
    keys = list(axes)
    for vals in itertools.product(*(axes[k] for k in keys)):
        yield dict(zip(keys, vals, strict=True))


def _pf_config(base: PfConfig, noise: MotionNoise, opts: dict[str, Any]) -> PfConfig:
    o = dict(opts)
    changes: dict[str, Any] = {}
    if "noise_scale" in o:
        changes["noise"] = noise.scaled(float(o.pop("noise_scale")))
    if "sigma_deg" in o:
        changes["sigma"] = math.radians(float(o.pop("sigma_deg")))
    if "alphas" in o:
        changes["alpha_slow"], changes["alpha_fast"] = o.pop("alphas")
    changes.update(o)
    return dataclasses.replace(base, **changes)


# --------------------------------------------------------------------------------------------


def tune_ekf(
    runs: Sequence[Stream],
    noise: MotionNoise,
    axes: dict[str, Sequence[Any]],
    log: Log = print,
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Every combination of ``axes`` (``noise_scale``, ``sigma_deg``, ``gate_sigmas``) on
    the whole runs from the truth; the best by J (ties: lower position RMSE)."""
    rows = []
    for opts in _grid(axes):
        cfg = EkfConfig(
            noise=noise.scaled(opts["noise_scale"]),
            sigma=math.radians(opts["sigma_deg"]),
            gate_sigmas=opts["gate_sigmas"],
        )

        def make(s: Stream, start: Pose | None, cfg: EkfConfig = cfg) -> EkfKnown:
            assert start is not None
            return EkfKnown(s.landmarks.xy, start, s.frames, cfg)

        res = evaluate_streams(runs, make, name="ekf", oracle_start=True, progress=False)
        row = {"options": opts, **summarize(res)}
        rows.append(row)
        log(f"ekf {opts} -> J {row['J']} correct {row['correct']} rmse {row['pos_rmse_m']}")
    best = max(rows, key=lambda r: (r["J"], -(r["pos_rmse_m"] or 1e9)))
    return best, rows


def tune_pf_tracking(
    runs: Sequence[Stream],
    noise: MotionNoise,
    base: PfConfig,
    axes: dict[str, Sequence[Any]],
    *,
    seed: int = 0,
    log: Log = print,
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The filter started at the truth, every combination of ``axes``; best by J."""
    rows = []
    for opts in _grid(axes):
        cfg = _pf_config(base, noise, opts)
        res = evaluate_streams(
            runs, pf_factory(cfg, seed), name="pf", oracle_start=True, progress=False
        )
        row = {"options": opts, **summarize(res)}
        rows.append(row)
        log(f"pf-track {opts} -> J {row['J']} correct {row['correct']} wrong {row['wrong']}")
    best = max(rows, key=lambda r: r["J"])
    return best, rows


def tune_pf_global(
    runs: Sequence[Stream],
    noise: MotionNoise,
    base: PfConfig,
    start: dict[str, Any],
    axes: dict[str, Sequence[Any]],
    *,
    seed: int = 0,
    max_passes: int = 3,
    log: Log = print,
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Coordinate descent from a uniform start: one option at a time over its grid (the
    others held), a change kept only when J rises; until a pass changes nothing."""
    cache: dict[str, dict[str, Any]] = {}
    rows: list[dict[str, Any]] = []

    def run(opts: dict[str, Any]) -> dict[str, Any]:
        key = repr(sorted(opts.items()))
        if key not in cache:
            cfg = _pf_config(base, noise, opts)
            c0 = time.time()
            res = evaluate_streams(runs, pf_factory(cfg, seed), name="pf", progress=False)
            row = {"options": dict(opts), **summarize(res), "wall_s": round(time.time() - c0)}
            cache[key] = row
            rows.append(row)
            log(
                f"pf-global {opts} -> J {row['J']} correct {row['correct']} wrong "
                f"{row['wrong']} ttl (localized) {row['ttl_median_localized_s']} "
                f"({row['wall_s']} s)"
            )
        return cache[key]

    cur = dict(start)
    best = run(cur)
    for _ in range(max_passes):
        changed = False
        for name, values in axes.items():
            for v in values:
                if v == cur.get(name):
                    continue
                cand = {**cur, name: v}
                row = run(cand)
                if row["J"] > best["J"] + 1e-4:
                    best, cur, changed = row, cand, True
        if not changed:
            break
    return best, rows


Trace = tuple[Stream, list[Any], list[tuple[float, bool, bool]]]


def run_traced(
    streams: Sequence[Stream], cfg: PfConfig, seed: int
) -> tuple[TrackingResult, list[Trace]]:
    """The filter from a uniform start on each stream, scored, with its per-frame trace (to
    replay the kidnap flag at other thresholds)."""
    traces: list[Trace] = []
    runs = []
    for s in streams:
        pf = ParticleFilter(s.landmarks.xy, cfg, None, rng=stream_seed(s, seed))
        est, cpu = run_stream(pf, s)
        runs.append(score_run(s, est, cpu_s=cpu))
        traces.append((s, est, pf.trace))
    return TrackingResult("pf", runs), traces


def replay_thresholds(
    traces: Sequence[Trace],
    thresholds: Sequence[float],
    *,
    max_false_alarm_rate: float = 0.1,
    log: Log = print,
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Replay the kidnap flag of traced runs for each threshold: false-alarm run rate on the
    plain streams, kidnappings flagged (after the jump) and the median delay on the kidnapped
    ones. Chosen: the most kidnappings flagged within 30 s among the thresholds whose
    false-alarm run rate stays at or below ``max_false_alarm_rate``."""
    rows = []
    for th in thresholds:
        fa_runs = 0
        n_plain = 0
        delays = []
        for s, est, trace in traces:
            flags = replay_kidnap_flags(trace, th)
            est2 = [dataclasses.replace(e, kidnapped=f) for e, f in zip(est, flags, strict=True)]
            r = score_run(s, est2)
            if math.isfinite(r.jump_t):
                t = np.array([e.t for e in est2])
                k = np.flatnonzero(np.array(flags) & (t >= r.jump_t))
                delays.append(float(t[k[0]] - r.jump_t) if k.size else math.inf)
            else:
                n_plain += 1
                fa_runs += r.false_alarms > 0
        d = np.array(delays)
        row = {
            "kidnap_ratio": th,
            "false_alarm_run_rate": round(fa_runs / max(n_plain, 1), 3),
            "flagged_within_30s": round(float(np.mean(d <= 30.0)), 3) if d.size else None,
            "flagged": round(float(np.mean(np.isfinite(d))), 3) if d.size else None,
            "median_flag_delay_s": (
                round(float(np.median(d[np.isfinite(d)])), 1) if np.isfinite(d).any() else None
            ),
        }
        rows.append(row)
        log(f"kidnap_ratio {th}: {row}")
    ok = [r for r in rows if r["false_alarm_run_rate"] <= max_false_alarm_rate]
    best = max(ok, key=lambda r: r["flagged_within_30s"] or 0.0) if ok else rows[0]
    return best, rows


def tune_recovery(
    kidnapped: Sequence[Stream],
    plain: Sequence[Stream],
    noise: MotionNoise,
    base: PfConfig,
    axes: dict[str, Sequence[Any]],
    thresholds: Sequence[float],
    *,
    seed: int = 0,
    log: Log = print,
) -> dict[str, Any]:
    """The random-particle injection (``alphas``, ``per_bearing``) on kidnapped and plain
    tuning streams: every combination of ``axes``, J pooled over all the tuning streams'
    frames (recovering after a jump counts, losing the pose on a plain stream too); then the
    kidnap threshold replayed on the best one's traces."""
    rows = []
    best_traces: list[Trace] = []
    best: dict[str, Any] | None = None
    for opts in _grid(axes):
        cfg = _pf_config(base, noise, opts)
        c0 = time.time()
        res, traces = run_traced([*kidnapped, *plain], cfg, seed)
        t = res.totals(True)
        row = {
            "options": opts,
            **summarize(res),
            "recovery_median_recovered_s": t["recovery_median_recovered_s"],
            "unrecovered": t["unrecovered"],
            "wall_s": round(time.time() - c0),
        }
        row.pop("per_run")
        rows.append(row)
        log(f"recovery {opts} -> J {row['J']} correct {row['correct']} wrong {row['wrong']}")
        if best is None or row["J"] > best["J"]:
            best, best_traces = row, traces
    assert best is not None
    th_best, th_rows = replay_thresholds(best_traces, thresholds, log=log)
    return {"best": best, "rows": rows, "kidnap_ratio": th_best, "kidnap_rows": th_rows}


def tune_kidnap_ratio(
    kidnapped: Sequence[Stream],
    plain: Sequence[Stream],
    cfg: PfConfig,
    thresholds: Sequence[float],
    *,
    seed: int = 0,
    max_false_alarm_rate: float = 0.1,
    log: Log = print,
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Run the filter once on tuning streams and replay its kidnap flag for each threshold
    (:func:`replay_thresholds`)."""
    _, traces = run_traced([*kidnapped, *plain], cfg, seed)
    return replay_thresholds(traces, thresholds, max_false_alarm_rate=max_false_alarm_rate, log=log)
