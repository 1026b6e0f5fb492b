"""The second pass backward in time (``track(..., backward_s=S)``, ``--backward S``) on MRCLAM
set 6: how many more frames it localizes, and how many of them are wrong, against the
forward pass alone, under several seeds of the tracker and several horizons.

Run:  python benchmarks/track_backward.py [--data PATH] [--seeds 0 1 2 3 4]
          [--horizons 10 20 40] [--every-sure 20] [--as-reported 20] [--kidnap 20]
          [--jobs 2] [--out PATH]

For each seed of the tracker's random particles (``TrackerConfig.seed``), the five whole runs
and ``--kidnap`` kidnapped streams with as many without a jump (``kidnap_streams`` seeded 0,
as ``omniloc evaluate --dataset mrclam-track --kidnap 20``): the forward pass once per stream
(the ``mrclam`` preset), then the pass backward over its estimates at each horizon
(``omniloc.evaluate.tracking.backward_offline``: from the sure frames whose place the forward
pass keeps, ``omniloc.track.backward.kept_frames``, told each sure pose's covariance times
``omniloc.track.backward.TOLD_SCALE``), at each ``--as-reported`` horizon also told the
covariance as the forward pass reports it (the pass before 2026-12-07), and at each
``--every-sure`` horizon also from every sure frame (``confirm_s`` 0), every result scored by
the evaluation's own ``score_run``. Each wrong frame the pass backward added is listed (its
stream, time, position and heading error). Writes ``results_track_backward.json`` and ``.md``
beside this file (about 25 minutes with two jobs).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc import Pose  # noqa: E402
from omniloc.evaluate.common import jsonable  # noqa: E402
from omniloc.evaluate.tracking import (  # noqa: E402
    TrackingResult,
    backward_offline,
    frames_within_tolerance,
    kidnap_streams,
    mrclam_streams,
    run_stream,
    score_run,
    tracker_factory,
)

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"

#: The kinds of stream, as the rows of the tables.
KINDS = ("whole runs", "kidnapped streams", "plain streams")


def _kind(name: str) -> str:
    return (
        "whole runs"
        if name.startswith("robot")
        else ("kidnapped streams" if name.startswith("kidnap") else "plain streams")
    )


def _label(variant: str) -> str:
    """A variant's column: "forward", a horizon ("20"), or one from every sure frame
    ("20/all")."""
    if variant == "forward":
        return "the forward pass alone"
    h, _, how = variant.partition("/")
    if how == "reported":
        return f"with the pass backward, {h} s, told the covariance as reported"
    return f"with the pass backward, {h} s" + (", from every sure frame" if how else "")


def job(
    data: str,
    seed: int,
    horizons: list[float],
    kidnap: int,
    every: list[float],
    reported: list[float] | None = None,
) -> dict[str, Any]:
    """One seed: the forward pass on every stream, then the pass backward at each horizon.
    Returns, per variant ("forward" or the horizon), per kind of stream, the totals of the
    evaluation and the counts of frames; and the wrong frames each horizon added."""
    runs = mrclam_streams(data)
    streams = list(runs)
    if kidnap:
        jumps, plain = kidnap_streams(runs, kidnap, rng=0)
        streams += jumps + plain
    settings = {"seed": seed}
    make = tracker_factory("mrclam", settings)
    passes = {f"{h:g}": backward_offline(h, "mrclam", settings) for h in horizons}
    passes |= {f"{h:g}/all": backward_offline(h, "mrclam", settings, confirm_s=0.0) for h in every}
    passes |= {
        f"{h:g}/reported": backward_offline(h, "mrclam", settings, told_scale=1.0)
        for h in reported or []
    }
    scores: dict[str, list[Any]] = {"forward": [], **{v: [] for v in passes}}
    added: dict[str, list[dict[str, Any]]] = {v: [] for v in passes}
    # Per variant and kind of stream: the frames the pass reported, those right, and the
    # sum of the confidences they reported (TrackerConfig.confidence_backward's).
    tallies: dict[str, dict[str, list[float]]] = {
        v: {k: [0, 0, 0.0] for k in KINDS} for v in passes
    }
    for s in streams:
        est, cpu = run_stream(make(s.landmarks, None), s)
        scores["forward"].append(score_run(s, est, cpu_s=cpu))
        for v, offline in passes.items():
            c0 = time.process_time()
            both = offline(s, est)
            dt = time.process_time() - c0
            scores[v].append(score_run(s, both, cpu_s=cpu + dt))
            # The frames the scoring counts wrong (scored, not within tolerance) that the
            # pass backward reported, with how far off they are.
            scored, right = frames_within_tolerance(s, both)
            mine = [i for i, e in enumerate(both) if e.backward and scored[i]]
            tally = tallies[v][_kind(s.name)]
            tally[0] += len(mine)
            tally[1] += int(sum(bool(right[i]) for i in mine))
            tally[2] += sum(c for i in mine if (c := both[i].confidence) is not None)
            wrong = [i for i, e in enumerate(both) if e.backward and scored[i] and not right[i]]
            true, _ = s.truth_at(np.array([both[i].t for i in wrong]))
            for i, tp in zip(wrong, true, strict=True):
                e = both[i]
                assert e.pose is not None  # (a localized frame)
                d, dh = e.pose.distance_to(Pose.from_array(tp))
                added[v].append(
                    {
                        "stream": s.name,
                        "t_s": round(e.t - s.start, 2),
                        "position_m": round(d, 3),
                        "heading_deg": round(math.degrees(dh), 2),
                    }
                )
    out: dict[str, Any] = {"seed": seed, "variants": {}, "added_wrong": added}
    for variant, rs in scores.items():
        per: dict[str, Any] = {}
        for kind in KINDS:
            sel = [r for r in rs if _kind(r.name) == kind]
            if not sel:
                continue
            tot = TrackingResult(kind, sel).totals()
            frames = sum(r.n_frames for r in sel)
            loc = sum(r.n_localized for r in sel)
            wrong = sum(r.n_confidently_wrong for r in sel)
            per[kind] = {
                "frames": frames,
                "localized": loc,
                "wrong": wrong,
                "right_share": (loc - wrong) / frames if frames else math.nan,
                "first_correct_median_s": tot["time_to_localize_median_s"],
                "correct_after": tot["correct_after_rate"],
                "pos_rmse_m": tot["pos_rmse_m"],
                "false_alarm_run_rate": tot["false_alarm_run_rate"],
                "recovered": tot["runs"] - tot["unrecovered"] if kind == KINDS[1] else None,
                "cpu_per_s": sum(r.cpu_s for r in sel) / sum(r.duration_s for r in sel),
            }
            if variant in tallies:
                n, ok, c = tallies[variant][kind]
                per[kind] |= {"backward_frames": n, "backward_right": ok, "backward_conf_sum": c}
        out["variants"][variant] = per
    return out


def _range(values: list[float], spec: str, scale: float = 1.0) -> str:
    vs = [v * scale for v in values if v is not None and not math.isnan(v)]
    if not vs:
        return "-"
    lo, hi = min(vs), max(vs)
    fmt = lambda v: "never" if math.isinf(v) else format(v, spec)  # noqa: E731
    return fmt(lo) if fmt(lo) == fmt(hi) else f"{fmt(lo)}-{fmt(hi)}"


def _share(localized: int, wrong: int, frames: int) -> str:
    """ "right %  (wrong)": the frames localized and right as a share of all."""
    return f"{100 * (localized - wrong) / frames:.1f} % ({wrong})" if frames else "-"


def _reported(n: int, right: int, conf_sum: float) -> str:
    """ "n, right % (mean confidence)" of the frames the pass backward reported."""
    if not n:
        return "none"
    return f"{n:,}, {100 * right / n:.1f} % ({conf_sum / n:.3f})"


def table(jobs: list[dict[str, Any]], variants: list[str]) -> list[str]:
    """The markdown table: one column per variant, figures as ranges over the seeds or
    totals."""
    head = [_label(v) for v in variants]
    lines = ["| over the seeds | " + " | ".join(head) + " |", "|---" * (len(variants) + 1) + "|"]

    def row(label: str, cell: Any) -> None:
        lines.append(f"| {label} | " + " | ".join(cell(v) for v in variants) + " |")

    def vals(v: str, kind: str, key: str) -> list[Any]:
        return [j["variants"][v][kind][key] for j in jobs if kind in j["variants"][v]]

    def total(v: str, kind: str, key: str) -> int:
        return int(sum(vals(v, kind, key)))

    for kind in KINDS:
        if not any(kind in j["variants"]["forward"] for j in jobs):
            continue
        row(
            f"{kind}: localized and right, share of all frames (wrong frames)",
            lambda v, k=kind: _share(
                total(v, k, "localized"), total(v, k, "wrong"), total(v, k, "frames")
            ),
        )
    k = KINDS[0]
    row(f"{k}: localized frames, per seed", lambda v: _range(vals(v, k, "localized"), ",.0f"))
    row(
        f"{k}: first correct, median over the runs (s)",
        lambda v: _range(vals(v, k, "first_correct_median_s"), ".1f"),
    )
    row(
        f"{k}: localized and right after it (%)",
        lambda v: _range(vals(v, k, "correct_after"), ".1f", 100.0),
    )
    row(f"{k}: position RMSE (m)", lambda v: _range(vals(v, k, "pos_rmse_m"), ".3f"))
    row(f"{k}: CPU per second of recording (s)", lambda v: _range(vals(v, k, "cpu_per_s"), ".4f"))
    for kind in KINDS:
        if not any(kind in j["variants"]["forward"] for j in jobs):
            continue
        row(
            f"{kind}: frames the pass backward reports, right (their mean confidence)",
            lambda v, k=kind: (
                _reported(
                    total(v, k, "backward_frames"),
                    total(v, k, "backward_right"),
                    sum(vals(v, k, "backward_conf_sum")),
                )
                if v != "forward"
                else "-"
            ),
        )
    if any(KINDS[2] in j["variants"]["forward"] for j in jobs):
        row(
            "plain streams flagged kidnapped (%)",
            lambda v: _range(vals(v, KINDS[2], "false_alarm_run_rate"), ".0f", 100.0),
        )
        row(
            "kidnapped streams right again", lambda v: _range(vals(v, KINDS[1], "recovered"), ".0f")
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATA, help="the mrclam-ds6 folder")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--horizons", type=float, nargs="+", default=[10.0, 20.0, 40.0])
    ap.add_argument(
        "--every-sure",
        type=float,
        nargs="*",
        default=[20.0],
        help="horizons to run also from every sure frame (none given up)",
    )
    ap.add_argument(
        "--as-reported",
        type=float,
        nargs="*",
        default=[20.0],
        help="horizons to run also told the forward pass's covariance as reported "
        "(told_scale 1, the pass before 2026-12-07 16:00)",
    )
    ap.add_argument("--kidnap", type=int, default=20, help="kidnapped streams (and as many plain)")
    ap.add_argument("--jobs", type=int, default=2, help="processes, one seed each")
    ap.add_argument("--out", type=Path, default=HERE / "results_track_backward.json")
    args = ap.parse_args(argv)
    if not (args.data / "landmarks.csv").is_file():
        ap.error(f"{args.data}: not the mrclam-ds6 folder")
    if any(
        not (math.isfinite(h) and h >= 0)
        for h in [*args.horizons, *args.every_sure, *args.as_reported]
    ):
        ap.error("--horizons, --every-sure, --as-reported: seconds >= 0")
    w0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [
            pool.submit(
                job,
                str(args.data),
                s,
                list(args.horizons),
                args.kidnap,
                list(args.every_sure),
                list(args.as_reported),
            )
            for s in args.seeds
        ]
        jobs = [f.result() for f in futures]
    wall = time.perf_counter() - w0
    variants = [
        "forward",
        *sorted(
            [f"{h:g}" for h in args.horizons]
            + [f"{h:g}/all" for h in args.every_sure]
            + [f"{h:g}/reported" for h in args.as_reported],
            key=lambda v: (float(v.split("/")[0]), v),
        ),
    ]
    meta = run_meta("track_backward.py", argv, wall_s=round(wall, 1))
    write_results(args.out, meta, jobs=jsonable(jobs))
    lines = table(jobs, variants)
    md = [
        "# The pass backward on MRCLAM set 6 (`benchmarks/track_backward.py`)",
        "",
        f"{meta['date']}, {meta['machine']}; `{meta['command']}`, {wall:.0f} s. The `mrclam`"
        f" preset under the tracker's seeds {', '.join(map(str, args.seeds))}; the five whole"
        f" runs and {args.kidnap} kidnapped and {args.kidnap} plain streams (`kidnap_streams`"
        " seeded 0). Scored by `omniloc.evaluate.tracking.score_run`: right means localized and"
        " within 0.3 m and 5 deg of the truth.",
        "",
        *lines,
        "",
        "Wrong frames the pass backward added (each horizon, every seed):",
        "",
    ]
    for v in variants[1:]:
        ws = [w for j in jobs for w in j["added_wrong"][v]]
        if ws:
            pos = [w["position_m"] for w in ws]
            hdg = [w["heading_deg"] for w in ws]
            md.append(
                f"* {_label(v)[len('with the pass backward, ') :]}: {len(ws)}, "
                f"{min(pos):.2f}-{max(pos):.2f} m and "
                f"{min(hdg):.1f}-{max(hdg):.1f} deg off"
                f" ({sum(p > 0.3 for p in pos)} of them more than 0.3 m off)"
            )
        else:
            md.append(f"* {_label(v)[len('with the pass backward, ') :]}: none")
    args.out.with_suffix(".md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
