"""How often the tracker is sure of a wrong place on maps it was not tuned on: the review's
battery of simulated runs (2026-12-06), random maps and the example grid, the `generic`
preset, the sensor model the frames were simulated with.

Run:  python benchmarks/track_lookalikes.py [--seeds A B] [--set NAME=VALUE ...] [--out PATH]

Run ``s`` of ``--seeds`` (default 0-180) is ``omniloc.track.simulate.lookalike_run(s)``, one
of three scenes by ``s % 3``:

* 0: 14 landmarks uniform on 12 m x 12 m, the example's omnidirectional camera (5 m range,
  sigma 0.5 deg, p_detect 0.9, 0.3 clutter bearings a frame);
* 1: the example's grid (the same under a half turn but for one landmark);
* 2: 20 landmarks uniform on 12 m x 12 m, a 180-degree camera 0.2 m ahead of the robot.

60 s from a random pose (0.25 m/s, turning at up to 0.3 rad/s); odd runs are carried to a
random pose at 30 s. The figures: frames localized, right (0.3 m, 5 deg) and wrong, the
wrong ones away from a jump (more than 3 s after it, or in a run without one) apart, and
the runs they fall in. ``--set`` changes a setting of the tracker's models, not of the
simulation (``omniloc.track.with_settings`` names), e.g. ``--set model_check=None`` for the
tracker without the model check.

Writes ``results_track_lookalikes.json`` and ``.md`` beside this file (or ``--out``).
"""

from __future__ import annotations

import argparse
import ast
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
from omniloc.errors import InputError  # noqa: E402
from omniloc.track import preset, track, with_settings  # noqa: E402
from omniloc.track.simulate import lookalike_run  # noqa: E402

#: Seconds after a jump in which a wrong frame is counted as "at the jump".
NEAR_JUMP_S = 3.0


def one(job: tuple[int, dict[str, Any]]) -> dict[str, Any]:
    """One run: its counts and its wrong frames."""
    seed, settings = job
    ex = lookalike_run(seed)
    run = ex.run
    # (A setting changes the tracker's models -- the run's own sensor and motion, the
    # generic preset's configuration -- never the simulation's.)
    sensor, motion, config = with_settings(ex.sensor, ex.motion, preset("generic")[2], settings)
    res = track(ex.landmarks, run.odometry, run.frames, sensor=sensor, motion=motion, config=config)
    out: dict[str, Any] = {"seed": seed, "frames": len(res.estimates), "localized": 0, "right": 0}
    wrong = []
    for e in res.estimates:
        if not e.localized or e.pose is None:
            continue
        out["localized"] += 1
        q = run.truth.pose_at(e.t)
        dm = math.hypot(e.pose.x - q.x, e.pose.y - q.y)
        dh = abs(math.remainder(e.pose.theta - q.theta, 2 * math.pi))
        if dm <= 0.3 and dh <= math.radians(5):
            out["right"] += 1
            continue
        near = math.isfinite(run.kidnap_t) and 0.0 <= e.t - run.kidnap_t < NEAR_JUMP_S
        wrong.append(
            {"t": e.t, "m": round(dm, 2), "deg": round(math.degrees(dh), 1), "near_jump": near}
        )
    out["wrong"] = wrong
    return out


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    wrong = [(r["seed"], w) for r in rows for w in r["wrong"]]
    away = [(s, w) for s, w in wrong if not w["near_jump"]]
    frames = sum(r["frames"] for r in rows)
    loc = sum(r["localized"] for r in rows)
    return {
        "runs": len(rows),
        "frames": frames,
        "localized": loc,
        "right": sum(r["right"] for r in rows),
        "wrong": len(wrong),
        "wrong_away_from_jumps": len(away),
        "wrong_rate": len(wrong) / loc if loc else math.nan,
        "runs_wrong_away_from_jumps": sorted({s for s, _ in away}),
        "far_wrong_frames": sum(1 for _, w in wrong if w["m"] > 1.0),
    }


def parse_set(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        name, _, value = item.partition("=")
        if not value:
            raise SystemExit(f"--set {item!r}: expected NAME=VALUE")
        try:
            out[name] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[name] = value
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 180), metavar=("A", "B"))
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=HERE / "results_track_lookalikes")
    args = ap.parse_args(argv)
    settings = parse_set(args.set)
    try:  # (a bad name or value fails here, once)
        ex = lookalike_run(args.seeds[0])
        with_settings(ex.sensor, ex.motion, preset("generic")[2], settings)
    except InputError as exc:
        ap.error(f"--set: {exc}")
    t0 = time.perf_counter()
    jobs = [(s, settings) for s in range(*args.seeds)]
    with ProcessPoolExecutor(args.workers) as ex:
        rows = list(ex.map(one, jobs))
    wall = time.perf_counter() - t0
    s = summary(rows)
    by_kind = {k: summary([r for r in rows if r["seed"] % 3 == k]) for k in range(3)}
    print(
        f"{s['runs']} runs, {s['frames']} frames: localized {s['localized']}, right {s['right']}, "
        f"wrong {s['wrong']} ({100 * s['wrong_rate']:.2f} % of the localized; "
        f"{s['wrong_away_from_jumps']} away from jumps, in runs {s['runs_wrong_away_from_jumps']}; "
        f"{s['far_wrong_frames']} more than 1 m off); {wall:.0f} s"
    )
    names = ("random 14, 360 deg", "example grid", "random 20, 180 deg + mount")
    command = " ".join(["python", "benchmarks/track_lookalikes.py", *(argv or sys.argv[1:])])
    lines = [
        f"`{command}` ({wall:.0f} s; settings {settings or 'of the generic preset'})",
        "",
        "| scene | runs | frames | localized | right | wrong | wrong away from jumps | runs |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for k, name in enumerate(names):
        b = by_kind[k]
        lines.append(
            f"| {name} | {b['runs']} | {b['frames']} | {b['localized']} | {b['right']} | "
            f"{b['wrong']} | {b['wrong_away_from_jumps']} | {b['runs_wrong_away_from_jumps']} |"
        )
    lines.append(
        f"| all | {s['runs']} | {s['frames']} | {s['localized']} | {s['right']} | {s['wrong']} "
        f"({100 * s['wrong_rate']:.2f} %) | {s['wrong_away_from_jumps']} | "
        f"{s['runs_wrong_away_from_jumps']} |"
    )
    meta = run_meta("track_lookalikes.py", argv, wall_s=round(wall, 1), settings=settings)
    out = args.out
    write_results(out.with_suffix(".json"), meta, summary=s, by_scene=by_kind, runs=rows)
    out.with_suffix(".md").write_text(f"Measured {meta['date']}: " + "\n".join(lines) + "\n")
    print("\n".join(lines[2:]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
