"""The tracker against the particle filter on MRCLAM (the five whole runs and seeded
kidnapped and plain streams), each under several seeds of its own random draws: is "right
about as often" a difference or the luck of one draw?

Run:  python benchmarks/track_baselines_seeds.py [--seeds 0 1 2 3 4]
      [--particles 2000,10000,50000] [--streams N] [--large-streams N] [--workers 2]
      [--data PATH] [--out PATH]

``track_baselines.py`` scores every localizer once: the tracker under its default seed
(``TrackerConfig.seed`` 0), the particle filter under the evaluation's ``--seed`` 0. Both
draw particles at random, and on MRCLAM the draw alone moves the tracker's localized frames
by a quarter (``omniloc evaluate --tracker-seeds``). Here each runs the five whole runs, and
``--streams`` kidnapped and as many plain streams (``kidnap_streams`` with seed 0: the
streams of ``track_baselines.py`` and of ``omniloc evaluate --kidnap N``; from
``LARGE`` particles on only the first ``--large-streams`` of each, as there), once per
seed: the tracker with ``TrackerConfig.seed`` = s (the ``mrclam`` preset otherwise), the
filter with its random draws seeded as ``track_baselines.py --seed s`` seeds them
(:func:`baselines_track.tuning.stream_seed` per stream; seed 0 is the filter of
``results_tracking.json``), with the options of the tuning record
(``baselines_track/tuning.json``), scored by the same code
(:func:`baselines_track.harness.evaluate_streams`). Each (localizer, seed) is one job; jobs
run in ``--workers`` processes (CPU time per second of recording is each job's own).

Per localizer and kind of stream (whole runs, kidnapped, plain): each seed's figures (the
median time to the first correct ``localized`` state, streams never localized, the mean share
of frames correct after it, the shares of all frames correct and confidently wrong, the
position RMSE over localized frames, kidnapped streams correct again, plain streams flagged
``kidnapped``, CPU per second of recording) and their range over the seeds. Writes
``results_tracking_seeds.json`` and ``.md`` beside this file. The whole runs alone
(``--streams 0``) take about 10 minutes on two cores (2026-12-06: 610 s, the
50,000-particle filter most of it); with the default 20 streams of each kind, 21 minutes
(1,286 s).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from baselines_track.harness import evaluate_streams  # noqa: E402
from baselines_track.motion import calibrate_motion_noise  # noqa: E402
from baselines_track.tuning import pf_factory  # noqa: E402
from omniloc.evaluate.common import jsonable  # noqa: E402
from omniloc.evaluate.tracking import kidnap_streams, mrclam_streams  # noqa: E402
from track_baselines import (  # noqa: E402
    DEFAULT_DATA,
    LARGE,
    TUNING_RECORD,
    chosen_options,
    pf_config,
    warm_up,
)

#: The figures of one (localizer, seed, kind of stream), from ``TrackingResult.totals()``.
FIGURES = (
    ("time_to_localize_median_s", "first correct, median s"),
    ("never_localized", "never localized"),
    ("correct_after_rate", "correct after it (mean over runs)"),
    ("correct_rate", "correct (all frames)"),
    ("confidently_wrong_rate", "confidently wrong"),
    ("pos_rmse_m", "position RMSE m"),
    ("recovered", "kidnappings correct again"),
    ("false_alarm_run_rate", "flagged kidnapped without a jump"),
    ("cpu_per_s", "CPU s / s"),
)
#: The kinds of stream, in the tables' order.
GROUPS = ("whole runs", "kidnapped", "plain")


def _job(
    kind: str, n: int, seed: int, data: str, n_streams: int, large_streams: int
) -> list[dict[str, Any]]:
    """One localizer under one seed on the whole runs and the streams: its totals per kind of
    stream."""
    runs = mrclam_streams(data)
    kid, plain = kidnap_streams(runs, n_streams, rng=0) if n_streams else ([], [])
    if kind == "tracker":
        from omniloc.track import Tracker, preset, with_settings

        sensor, motion, config = with_settings(*preset("mrclam"), {"seed": seed})

        def make(s: Any, _start: Any) -> Tracker:
            return Tracker(s.landmarks, sensor, motion, config)

        name = "omniloc Tracker (mrclam preset)"
    else:
        noise, _ = calibrate_motion_noise(
            [r.odometry for r in runs], [r.segments[0].truth for r in runs]
        )
        warm_up(runs[0].landmarks.xy, noise)
        chosen = chosen_options(json.loads(TUNING_RECORD.read_text()), [n])
        make = pf_factory(pf_config(n, noise, chosen["pf"][n]), seed)
        name = f"PF {n:,} particles, uniform start"
        if n >= LARGE:
            kid, plain = kid[:large_streams], plain[:large_streams]
    rows = []
    for group, streams in zip(GROUPS, (runs, kid, plain), strict=True):
        if not streams:
            continue
        t0 = time.time()
        res = evaluate_streams(streams, make, name=name, progress=False)
        t = res.totals()
        dur = sum(r.duration_s for r in res.runs)
        rows.append(
            {
                "localizer": name,
                "kind": kind,
                "particles": n,
                "seed": seed,
                "streams": group,
                "n_streams": len(streams),
                "wall_s": round(time.time() - t0, 1),
                "time_to_localize_median_s": t["time_to_localize_median_s"],
                "never_localized": t["never_localized"],
                "correct_after_rate": t["correct_after_rate"],
                "correct_rate": t["localized_rate"] - t["confidently_wrong_rate"],
                "confidently_wrong_rate": t["confidently_wrong_rate"],
                "pos_rmse_m": t["pos_rmse_m"],
                "recovered": (t["runs"] - t["unrecovered"] if group == "kidnapped" else math.nan),
                "false_alarm_run_rate": t["false_alarm_run_rate"],
                "cpu_per_s": sum(r.cpu_s for r in res.runs) / dur if dur > 0 else math.nan,
                "localized_frames": t["localized_frames"],
                "frames_scored": t["frames_scored"],
            }
        )
    return rows


def _fmt(key: str, v: float) -> str:
    if not math.isfinite(v):
        return "never" if key.startswith("time") else "-"
    if key == "confidently_wrong_rate":
        return f"{100 * v:.2f} %"
    if key.endswith("_rate"):
        return f"{100 * v:.1f} %"
    if key == "pos_rmse_m":
        return f"{v:.3f}"
    if key == "cpu_per_s":
        return f"{v:.4f}"
    if key in ("never_localized", "recovered"):
        return f"{v:.0f}"
    return f"{v:.1f}"


def _span(key: str, vals: list[float]) -> str:
    """min-max over the seeds (a time that is never on some seeds says how many)."""
    fin = [v for v in vals if math.isfinite(v)]
    if not fin:
        return _fmt(key, math.nan)
    lo, hi = _fmt(key, min(fin)), _fmt(key, max(fin))
    s = lo if lo == hi else f"{lo} - {hi}"
    if len(fin) < len(vals):
        s += f" ({len(vals) - len(fin)} never)"
    return s


def table(rows: list[dict[str, Any]], seeds: list[int]) -> str:
    """The markdown tables: per kind of stream, localizer and seed, then the ranges over
    the seeds (the tracker first, then the filter by its particle count)."""
    order = sorted({(r["kind"] != "tracker", r["particles"], r["localizer"]) for r in rows})
    groups = [g for g in GROUPS if any(r["streams"] == g for r in rows)]
    head = "| localizer | streams | seed | " + " | ".join(h for _, h in FIGURES) + " |"
    sep = "|" + "---|" * (len(FIGURES) + 3)

    def mine(name: str, group: str) -> list[dict[str, Any]]:
        return sorted(
            (r for r in rows if r["localizer"] == name and r["streams"] == group),
            key=lambda r: r["seed"],
        )

    lines = ["**Each seed**", "", head, sep]
    for group in groups:
        for _, _, name in order:
            for r in mine(name, group):
                cells = " | ".join(_fmt(k, float(r[k])) for k, _ in FIGURES)
                lines.append(f"| {name} | {group} ({r['n_streams']}) | {r['seed']} | {cells} |")
    lines += ["", f"**Over seeds {', '.join(map(str, seeds))}** (min - max)", "", head, sep]
    for group in groups:
        for _, _, name in order:
            rs = mine(name, group)
            if not rs:
                continue
            cells = " | ".join(_span(k, [float(r[k]) for r in rs]) for k, _ in FIGURES)
            lines.append(f"| {name} | {group} ({rs[0]['n_streams']}) | {len(rs)} seeds | {cells} |")
    return "\n".join(lines) + "\n"


def markdown(meta: dict[str, Any], rows: list[dict[str, Any]]) -> str:
    """The results file's markdown: what ran (from ``meta``) and :func:`table`. ``rows`` as
    written to the JSON file (null where a figure is not defined) or as measured."""
    rows = [{k: (math.nan if v is None else v) for k, v in r.items()} for r in rows]
    intro = (
        f"# The tracker and the particle filter under several seeds "
        f"(`benchmarks/track_baselines_seeds.py`)\n\n{meta['date']}, {meta['machine']}; "
        f"`{meta['command']}`, {meta['wall_s']} s"
        + (
            f" (the filter's rows from {meta['filter_rows_from']})"
            if meta.get("filter_rows_from")
            else ""
        )
        + f". MRCLAM set 6, the five whole runs and "
        f"{meta['streams']} kidnapped and {meta['streams']} plain streams (`kidnap_streams`, "
        f"seed 0; the first {meta['large_streams']} of each from {LARGE:,} particles on); "
        "the tracker's `mrclam` preset with `TrackerConfig.seed` = seed, the filter seeded "
        "as `track_baselines.py --seed` seeds it (seed 0: the rows of "
        "`results_tracking.md`).\n\n"
    )
    return intro + table(rows, list(meta["seeds"]))


def _kept_rows(args: argparse.Namespace) -> tuple[list[dict[str, Any]], str]:
    """``--tracker-only``: the filter's rows of the results file at ``--out`` (null figures
    read back as NaN) and when and how they were measured; refused unless that file holds
    them for the same seeds and streams."""
    try:
        old = json.loads(args.out.read_text())
    except (OSError, ValueError) as exc:
        raise SystemExit(f"--tracker-only reads the filter's rows from {args.out}: {exc}") from None
    meta = old.get("meta", {})
    same = (meta.get("seeds"), meta.get("streams"), meta.get("large_streams")) == (
        args.seeds,
        args.streams,
        args.large_streams,
    )
    rows = [
        {k: (math.nan if v is None else v) for k, v in r.items()}
        for r in old.get("rows", [])
        if r.get("kind") != "tracker"
    ]
    if not rows or not same:
        raise SystemExit(
            f"--tracker-only: {args.out} holds no filter rows for seeds {args.seeds}, "
            f"{args.streams} streams and {args.large_streams} large streams: run it whole"
        )
    # (A file written by --tracker-only already says when its filter rows were measured.)
    when = meta.get("filter_rows_from") or (
        f"{meta.get('date')} ({meta.get('command')}, {meta.get('wall_s')} s)"
    )
    return rows, when


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--particles", default="2000,10000,50000", help="comma-separated counts")
    ap.add_argument(
        "--streams", type=int, default=20, help="kidnapped (and plain) streams; 0: whole runs only"
    )
    ap.add_argument(
        "--large-streams",
        type=int,
        default=4,
        help=f"kidnapped (and plain) streams scored from {LARGE:,} particles on",
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=HERE / "results_tracking_seeds.json")
    ap.add_argument(
        "--tracker-only",
        action="store_true",
        help="run omniloc's Tracker only and put its rows beside the filter's rows already in "
        "--out (the filter is seeded and does not use omniloc's presets: its figures do not "
        "change when the tracker does)",
    )
    args = ap.parse_args(argv)
    if not (args.data / "landmarks.csv").is_file():
        raise SystemExit(f"no MRCLAM set 6 at {args.data} (landmarks.csv missing): --data PATH")
    try:
        counts = [int(p) for p in args.particles.split(",") if p.strip()]
    except ValueError:
        raise SystemExit(
            f"--particles: comma-separated whole numbers, got {args.particles!r}"
        ) from None
    if args.workers < 1:
        raise SystemExit(f"--workers must be at least 1, got {args.workers}")
    if args.streams < 0 or args.large_streams < 0:
        raise SystemExit(
            f"--streams and --large-streams must be at least 0, got {args.streams} and "
            f"{args.large_streams}"
        )
    kept, kept_meta = _kept_rows(args) if args.tracker_only else ([], None)
    # The slowest jobs first, so that the pool's last minutes are not one long job alone.
    jobs = (
        []
        if args.tracker_only
        else [("pf", n, s) for n in sorted(counts, reverse=True) for s in args.seeds]
    )
    jobs += [("tracker", 0, s) for s in args.seeds]
    t0 = time.time()
    rows: list[dict[str, Any]] = list(kept)
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futs = [
            pool.submit(_job, k, n, s, str(args.data), args.streams, args.large_streams)
            for k, n, s in jobs
        ]
        for f in futs:
            for r in f.result():
                rows.append(r)
                print(
                    f"{r['localizer']}, seed {r['seed']}, {r['streams']}: correct "
                    f"{100 * r['correct_rate']:.1f} %, wrong "
                    f"{100 * r['confidently_wrong_rate']:.2f} % ({r['wall_s']:.0f} s)",
                    flush=True,
                )
    meta = run_meta(
        "track_baselines_seeds.py",
        argv,
        seeds=args.seeds,
        streams=args.streams,
        large_streams=args.large_streams,
        wall_s=round(time.time() - t0),
        **({"filter_rows_from": kept_meta} if kept_meta else {}),
    )
    # (JSON has no inf or NaN: a time never reached, or a figure not defined, is null.)
    write_results(args.out, meta, rows=[{k: jsonable(v) for k, v in r.items()} for r in rows])
    md = markdown(meta, rows)
    print(md)
    args.out.with_suffix(".md").write_text(md)
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
