"""The tracker's frame on large maps: how long elsewhere's particles take to weigh and a
whole frame takes, on maps of 1,000 and 10,000 landmarks, with a range.

Run:  python benchmarks/track_large_maps.py [--frames N] [--repeat N] [--out PATH]

Each map is landmarks uniform over 100 m x 100 m; the sensor is the ``mrclam`` preset's
(67 deg field of view, 7.5 m range, 1 deg), the tracker's settings the preset's but for the
region (the map's bounding box). Two figures per map, each the median over ``--frames``
frames:

* the weighing: elsewhere's 3,000 particles weighed against a frame of two bearings
  (``log_ratios_clutter``, the frame kernel on exactly known poses), with the particles
  grouped by cells a range wide and with the whole map scanned for every particle -- the
  same numbers, bit for bit, checked here -- and which of the two the library picks
  (``likelihood._cell_groups``: from ``CELL_MIN_LANDMARKS`` landmarks, where the pairs it
  saves outweigh ``CELL_CALL_PAIRS`` a cell);
* a whole ``Tracker.frame``: two random bearings at 4 frames a second after odometry of a
  robot driving at 0.3 m/s and turning at 0.2 rad/s (a robot that is not localized): the
  median over the frames without a search, and over those with one (about one a second:
  the search, then the replay of its candidates through the last frames);
* the neighbour lists a map's first search builds (``search.neighbours``), once per map;
* on the largest map, the CPU a tracker that is not localized spends per second of
  recording (the same frames: every frame, searches included), with the preset's settings
  and with the two that trade a search's recall for time (``max_candidates`` 300 replayed
  instead of 3,000; ``search_max_nodes`` 10,000 instead of 50,000): above 1, such a
  robot falls behind real time.

Writes ``results_track_large_maps.json`` and ``.md`` beside this file.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

import omniloc.track.likelihood as lk  # noqa: E402
from _results import run_meta, write_results  # noqa: E402
from omniloc import LandmarkMap  # noqa: E402
from omniloc.search.neighbours import neighbour_lists  # noqa: E402
from omniloc.track import Tracker, preset  # noqa: E402

SIDE_M = 100.0
PARTICLES = 3000


def weighing_ms(n: int, frames: int, repeat: int, cells: bool, seed: int = 0) -> tuple[float, list]:
    """Median milliseconds to weigh 3,000 particles on a map of ``n`` landmarks (grouped
    by cells or not), and the last frame's numbers."""
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.0, SIDE_M, (n, 2))
    sensor, _, config = preset("mrclam")
    model = lk.FrameModel.of(sensor, p_detect=sensor.p_detect, clutter=sensor.clutter)
    model = replace(
        model, fresh=1.0 - config.clutter_persistence, object_var=config.clutter_persistence_sd**2
    )
    saved = lk.CELL_MIN_LANDMARKS, lk.CELL_CALL_PAIRS
    if cells:
        lk.CELL_CALL_PAIRS = 0  # (grouped even where the default would not)
    else:
        lk.CELL_MIN_LANDMARKS = 2**62
    try:
        times = []
        out: list = []
        for _ in range(frames):
            xy = rng.uniform(0.0, SIDE_M, (PARTICLES, 2))
            poses = np.column_stack([xy, rng.uniform(-math.pi, math.pi, PARTICLES)])
            bearings = rng.uniform(-0.5, 0.5, 2)
            objects = lk.Objects(rng.uniform(-0.5, 0.5, 1), rng.uniform(0.0, 0.75, (PARTICLES, 1)))
            best = math.inf
            for _ in range(repeat):
                t0 = time.perf_counter()
                out = list(lk.log_ratios_clutter(poses, bearings, L, model, objects))
                best = min(best, time.perf_counter() - t0)
            times.append(best)
        return 1e3 * statistics.median(times), out
    finally:
        lk.CELL_MIN_LANDMARKS, lk.CELL_CALL_PAIRS = saved


def frame_ms(n: int, frames: int, seed: int = 0, **settings: int) -> tuple[float, float, float]:
    """Median milliseconds of a whole ``Tracker.frame`` on a map of ``n`` landmarks, over
    the frames without a search and over those with one (NaN: none), and the seconds of
    all of them per second of recording (``settings``: the tracker's, changed)."""
    rng = np.random.default_rng(seed)
    lm = LandmarkMap(rng.uniform(0.0, SIDE_M, (n, 2)))
    sensor, motion, config = preset("mrclam")
    tracker = Tracker(lm, sensor, motion, replace(config, region=None, **settings))
    plain, searched = [], []
    t = 0.0
    for i in range(frames + 5):
        tracker.odometry([t], [0.3], [0.2])
        t += 0.25
        bearings = rng.uniform(-0.5, 0.5, 2)
        n_search = tracker.searches
        t0 = time.perf_counter()
        tracker.frame(t, bearings)
        dt = time.perf_counter() - t0
        if i >= 5:  # (the first frames compile and fill caches)
            (searched if tracker.searches > n_search else plain).append(dt)
    return (
        1e3 * statistics.median(plain),
        1e3 * statistics.median(searched) if searched else math.nan,
        (sum(plain) + sum(searched)) / (0.25 * frames),
    )


def neighbours_ms(n: int, repeat: int, seed: int = 0) -> float:
    """Fastest milliseconds to build a fresh map's neighbour lists at twice the preset's
    reach (what a tracker's first search, or each ``omniloc localize`` of such a map,
    builds once: ``search.neighbours.neighbour_lists``)."""
    sensor = preset("mrclam")[0]
    radius = 2.0 * float(sensor.reach_max)
    best = math.inf
    for _ in range(repeat):
        lm = LandmarkMap(np.random.default_rng(seed).uniform(0.0, SIDE_M, (n, 2)))
        _ = lm.kdtree  # (the k-d tree is the map's own, built with it)
        t0 = time.perf_counter()
        neighbour_lists(lm, radius)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=50, help="frames per figure (median)")
    ap.add_argument("--repeat", type=int, default=3, help="weighings of each frame (fastest)")
    ap.add_argument("--out", type=Path, default=HERE / "results_track_large_maps")
    args = ap.parse_args(argv)
    weighing_ms(300, 2, 1, True)  # compile the kernels once
    rows = []
    for n in (1000, 10_000):
        cells, a = weighing_ms(n, args.frames, args.repeat, True)
        whole, b = weighing_ms(n, args.frames, args.repeat, False)
        same = all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
        rng = np.random.default_rng(0)
        L = rng.uniform(0.0, SIDE_M, (n, 2))
        poses = np.column_stack(
            [rng.uniform(0.0, SIDE_M, (PARTICLES, 2)), rng.uniform(-math.pi, math.pi, PARTICLES)]
        )
        picked = "cells" if lk._cell_groups(poses, L, 7.0) is not None else "whole map"

        frame, with_search, per_s = frame_ms(n, args.frames)
        lists = neighbours_ms(n, args.repeat)
        rows.append(
            {
                "landmarks": n,
                "weighing_cells_ms": cells,
                "weighing_whole_map_ms": whole,
                "same_numbers": same,
                "default": picked,
                "frame_ms": frame,
                "frame_with_search_ms": with_search,
                "neighbour_lists_ms": lists,
                "cpu_per_s": per_s,
            }
        )
        print(
            f"{n:6d} landmarks: weighing {cells:.1f} ms by cells, {whole:.1f} ms scanning the "
            f"whole map (same numbers: {same}; the default: {picked}); a whole frame "
            f"{frame:.1f} ms, with a search {with_search:.0f} ms; neighbour lists {lists:.0f} ms"
        )
    knobs = [{}, {"max_candidates": 300}, {"max_candidates": 300, "search_max_nodes": 10_000}]
    lost = []
    for kw in knobs:
        _, searched, per_s = frame_ms(rows[-1]["landmarks"], args.frames, **kw)
        lost.append({"settings": kw, "frame_with_search_ms": searched, "cpu_per_s": per_s})
        print(
            f"{rows[-1]['landmarks']:,} landmarks, not localized, {kw or 'the preset'}: a frame "
            f"with a search {searched:.0f} ms, {per_s:.2f} s of CPU per second of recording"
        )
    meta = run_meta("track_large_maps.py", argv, particles=PARTICLES, side_m=SIDE_M)
    write_results(args.out.with_suffix(".json"), meta, rows=rows, not_localized=lost)
    lines = [
        "# The tracker's frame on large maps (`benchmarks/track_large_maps.py`)",
        "",
        f"{meta['date']}, {meta['machine']}; `{meta['command']}`. Landmarks uniform over "
        f"100 m x 100 m, the `mrclam` preset's sensor ({preset('mrclam')[0].max_range:g} m "
        f"range); elsewhere's {PARTICLES:,} "
        "particles weighed against two bearings (median over the frames), and a whole frame "
        "of a tracker that is not localized; the search's neighbour lists, built once per map "
        "(at twice the range, by the first search), fastest of `--repeat`.",
        "",
        "| landmarks | weighing, by cells | weighing, whole map scanned | same numbers | "
        "the library's choice | whole frame | a frame with a search | neighbour lists |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['landmarks']:,} | {r['weighing_cells_ms']:.1f} ms | "
            f"{r['weighing_whole_map_ms']:.1f} ms | {'yes' if r['same_numbers'] else 'NO'} | "
            f"{r['default']} | {r['frame_ms']:.1f} ms | {r['frame_with_search_ms']:.0f} ms | "
            f"{r['neighbour_lists_ms']:.0f} ms |"
        )
    lines += [
        "",
        f"A tracker that is not localized on the {rows[-1]['landmarks']:,}-landmark map, every "
        "frame (searches included) per second of recording: above 1 s it falls behind real "
        "time.",
        "",
        "| settings | a frame with a search | CPU per second of recording |",
        "|---|---|---|",
    ]
    for r in lost:
        name = ", ".join(f"`{k}` {v:,}" for k, v in r["settings"].items()) or "the preset"
        lines.append(f"| {name} | {r['frame_with_search_ms']:.0f} ms | {r['cpu_per_s']:.2f} s |")
    args.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0 if all(r["same_numbers"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
