"""The tracker on simulated runs where the truth is known and the sensor model is right.

Run:  python benchmarks/track_sim.py [--runs N] [--seed S] [--set NAME=VALUE ...] [--out PATH]

MRCLAM (``benchmarks/track_baselines.py``) is one hard case: a 65-degree camera, one or two
bearings per frame, a map of near-symmetric clusters. This script measures the tracker where
the sensor is the paper's -- an omnidirectional camera -- on maps with a symmetry that one
frame cannot break, scored by the same code (``omniloc.evaluate.tracking``):

* ``grid-360``: a 4 x 3 grid of landmarks 4 m apart (symmetric under a half turn) plus one
  landmark that breaks the symmetry, seen only from the east side; 360-degree sensor, 5 m
  range, sigma 0.5 deg, p_detect 0.9, 0.3 clutter bearings per frame;
* ``grid-180``: the same with a 180-degree field of view.

Each scenario has ``--runs`` runs of 60 s from random poses inside the grid (0.25 m/s, a new
turn rate every 4 s), half of them kidnapped at 30 s to a random pose at least 2 m away.
The tracker uses the sensor model the frames were simulated with and the default
configuration; ``--set`` changes a setting of the tracker's models, not of the simulation
(``omniloc.track.with_settings`` names, as in ``track_lookalikes.py``), e.g. ``--set
search_miss=0.1``. Writes ``results_track_sim.json``
and ``.md`` beside this file.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

import dataclasses  # noqa: E402

from _results import libraries  # noqa: E402
from omniloc import Pose  # noqa: E402
from omniloc.errors import InputError  # noqa: E402
from omniloc.evaluate.tracking import (  # noqa: E402
    Segment,
    Stream,
    TrackingResult,
    run_stream,
    score_run,
)
from omniloc.sensor import SensorModel  # noqa: E402
from omniloc.track import Tracker, TrackerConfig, simulate_run, with_settings  # noqa: E402
from omniloc.track.simulate import EXAMPLE_MAP, EXAMPLE_MOTION, EXAMPLE_SENSOR  # noqa: E402
from track_lookalikes import parse_set  # noqa: E402

# The scenario of omniloc's example recording (omniloc.track.simulate.example_run).
GRID = EXAMPLE_MAP
MOTION = EXAMPLE_MOTION
SCENARIOS: dict[str, SensorModel] = {
    "grid-360": EXAMPLE_SENSOR,
    "grid-180": dataclasses.replace(EXAMPLE_SENSOR, fov=math.pi),
}
DURATION_S = 60.0
JUMP_S = 30.0


def _stream(name: str, run: object, kidnap_t: float) -> Stream:
    odo, frames, truth = run.odometry, run.frames, run.truth  # type: ignore[attr-defined]
    end = float(odo.t[-1]) + 1.0
    segs: tuple[Segment, ...] = (Segment(0.0, end, 0.0, truth, name),)
    if math.isfinite(kidnap_t):
        segs = (Segment(0.0, kidnap_t, 0.0, truth, name), Segment(kidnap_t, end, 0.0, truth, name))
    return Stream(name, GRID, odo, frames, segs)


def run_scenario(
    name: str, sensor: SensorModel, n: int, seed: int, settings: dict[str, Any] | None = None
) -> TrackingResult:
    gen = np.random.default_rng(seed)
    # (A setting changes the tracker's models, never the simulation's.)
    tracked, motion, config = sensor, MOTION, TrackerConfig()
    if settings:
        tracked, motion, config = with_settings(sensor, MOTION, config, settings)
    x0, y0, x1, y1 = GRID.bounds
    scores = []
    for k in range(n):
        start = Pose(gen.uniform(x0, x1), gen.uniform(y0, y1), gen.uniform(-math.pi, math.pi))
        kidnap = None
        if k % 2 == 1:
            while True:
                to = Pose(gen.uniform(x0, x1), gen.uniform(y0, y1), gen.uniform(-math.pi, math.pi))
                if math.hypot(to.x - start.x, to.y - start.y) >= 2.0:
                    break
            kidnap = (JUMP_S, to)
        run = simulate_run(
            GRID,
            sensor,
            start,
            duration_s=DURATION_S,
            speed=0.25,
            turn_rate=0.3,
            v_noise=0.02,
            w_noise=0.01,
            kidnap=kidnap,
            rng=int(gen.integers(2**31)),
        )
        stream = _stream(f"{name}-{k}", run, JUMP_S if kidnap else math.nan)
        est, cpu = run_stream(Tracker(GRID, tracked, motion, config), stream)
        scores.append(score_run(stream, est, cpu_s=cpu))
        print(f"  {stream.name}: localized {sum(e.localized for e in est)}/{len(est)}", flush=True)
    return TrackingResult(name, scores)


def _f(v: float, spec: str) -> str:
    if v == math.inf:
        return "never"  # (a median time over runs half of which never got there)
    return "-" if v is None or not math.isfinite(v) else format(v, spec)


def table(results: dict[str, TrackingResult]) -> str:
    rows = [
        "| scenario | streams | first correct localized, median / max s | never | "
        "correct after it | confidently wrong | position RMSE m | heading RMSE deg | "
        "kidnap detected, median s | correct again, median s | unrecovered | "
        "false-alarm runs | weight ECE | own probability ECE | "
        "truth in the covariance's 50 % / 99 % region | CPU s per s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, res in results.items():
        for label, sel in (("without a jump", False), ("kidnapped at 30 s", True)):
            t = res.totals(sel)
            rows.append(
                f"| {name} | {label} ({int(t['runs'])}) | "
                f"{_f(t['time_to_localize_median_s'], '.1f')} / "
                f"{_f(t['time_to_localize_max_s'], '.1f')} | {int(t['never_localized'])} | "
                f"{_f(100 * t['correct_after_rate'], '.1f')} % | "
                f"{_f(100 * t['confidently_wrong_rate'], '.2f')} % | "
                f"{_f(t['pos_rmse_m'], '.3f')} | {_f(t['heading_rmse_deg'], '.2f')} | "
                f"{_f(t['detection_delay_median_s'], '.1f')} | "
                f"{_f(t['recovery_median_s'], '.1f')} | "
                f"{int(t['unrecovered']) if sel else '-'} | "
                f"{'-' if sel else _f(100 * t['false_alarm_run_rate'], '.0f') + ' %'} | "
                f"{_f(t['best_weight_ece'], '.3f')} | "
                f"{_f(t['probability_ece'], '.3f')} | "
                f"{_f(100 * t['cov_inside_50_rate'], '.0f')} / "
                f"{_f(100 * t['cov_inside_99_rate'], '.0f')} % | "
                f"{_f(1.0 / t['realtime_factor'], '.3f')} |"
            )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=12, help="runs per scenario (half kidnapped)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--out", type=Path, default=HERE / "results_track_sim.json")
    args = ap.parse_args(argv)
    if args.runs < 2:
        ap.error("--runs must be at least 2 (half of them are kidnapped)")
    settings = parse_set(args.set)
    try:  # (a bad name or value fails here, once)
        with_settings(EXAMPLE_SENSOR, MOTION, TrackerConfig(), settings)
    except InputError as exc:
        ap.error(f"--set: {exc}")
    t0 = time.time()
    results = {}
    for k, (name, sensor) in enumerate(SCENARIOS.items()):
        print(name, flush=True)
        results[name] = run_scenario(name, sensor, args.runs, args.seed + k, settings)
    md = table(results)
    meta = {
        "when": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(["python benchmarks/track_sim.py", *(argv or sys.argv[1:])]),
        "python": platform.python_version(),
        "machine": platform.processor() or platform.machine(),
        "libraries": libraries(),
        "wall_s": round(time.time() - t0, 1),
        "settings": settings,
    }
    args.out.write_text(
        json.dumps(
            {"meta": meta, "results": {k: v.as_dict() for k, v in results.items()}},
            indent=1,
            default=str,
        )
        + "\n"
    )
    head = (
        f"Measured {meta['when']} ({meta['machine']}, Python {meta['python']}, "
        + ", ".join(f"{k} {v}" for k, v in meta["libraries"].items())
        + f"): `{meta['command']}`, {meta['wall_s']:.0f} s.\n\n"
    )
    args.out.with_suffix(".md").write_text(head + md + "\n")
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
