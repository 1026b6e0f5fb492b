"""How fast the tracker processes a whole MRCLAM run: each robot alone, as ``omniloc track``
runs it (the ``mrclam`` preset), elapsed and processor time.

Run:  python benchmarks/track_speed.py [--data PATH] [--robots 1 2 3 4 5] [--repeat N]
      [--frames N] [--out PATH] [--against OTHER/src]

The issue's target is a whole ~900 s run in <= 9 s on a 2-core machine (>= 100x real time,
elapsed). ``omniloc evaluate --dataset mrclam-track`` and ``track_baselines.py`` report
processor time instead (their runs share the machine's cores between worker processes, and
processor time is what compares methods fairly); here each run has the machine to itself, so
elapsed time is the figure, with the processor time beside it (more than the elapsed time
where the frame likelihood of many hypotheses runs on two threads). Before the timed runs,
one untimed run of robot 1's first 200 frames loads the compiled kernels. With ``--repeat``,
each run's fastest repeat is reported (the machine's load varies from minute to minute).

The machine itself varies from hour to hour (a shared virtual machine: the same code took
40-50 % longer on some afternoons). A fixed reference workload -- pure Python and small
numpy calls, the mix of the tracker's own per-frame work -- is timed before and after the
runs (the median of 7 each) and written beside them: tables of different days compare by
it, not by their dates.

With ``--against SRC`` (another checkout's ``src`` folder, e.g. a ``git worktree`` of the
commit before a change), each robot's run is timed ``--repeat`` times in fresh processes,
alternating this checkout's ``src`` with ``SRC`` run by run, and the medians are compared:
the way to tell a change's speed from the machine's (whose load moves a run by 10-20 %
from one minute to the next). Each process checks that it imported the tree it was given
(a helper that puts another ``src`` first on the path would otherwise time one tree
twice). Writes ``results_track_speed_against.json`` then.

Writes ``results_track_speed.json`` and ``.md`` beside this file.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc import LandmarkMap  # noqa: E402
from omniloc.track import load_frames, load_odometry, preset, track  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"


def run_robot(data: Path, robot: int, limit: int | None = None) -> dict[str, float]:
    """One robot's whole run (or its first ``limit`` frames) with the ``mrclam`` preset."""
    sensor, motion, config = preset("mrclam")
    lm = LandmarkMap.load(data / "landmarks.csv")
    odo = load_odometry(data / f"robot{robot}_odometry.csv")
    frames = load_frames(data / f"robot{robot}_frames.csv")
    if limit is not None:
        frames = frames[:limit]
    run = track(lm, odo, frames, sensor=sensor, motion=motion, config=config)
    span = frames[-1].t - frames[0].t
    return {
        "robot": float(robot),
        "frames": float(len(frames)),
        "duration_s": span,
        "wall_s": run.wall_s,
        "cpu_s": run.cpu_s,
        "realtime_factor": span / run.wall_s,
        "localized": float(sum(e.localized for e in run.estimates)),
    }


def reference_ms(repeat: int = 7) -> dict[str, float]:
    """The machine's speed now: the median over ``repeat`` of a fixed pure-Python workload
    and of a fixed one of small numpy calls, milliseconds (no randomness: the same work
    every time)."""

    def python_work() -> float:
        acc = 0.0
        table: dict[int, float] = {}
        for i in range(200_000):
            x = math.sin(i * 1e-3) + (i % 7) * 0.5
            table[i & 255] = x
            acc += x * table.get((i + 1) & 255, 0.0)
        return acc

    poses = np.linspace(0.0, 1.0, 120).reshape(40, 3)

    def numpy_work() -> float:
        acc = 0.0
        p = poses
        for _ in range(2_000):
            c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
            p = np.column_stack([p[:, 0] + 0.01 * c, p[:, 1] + 0.01 * s, p[:, 2] + 1e-3])
            acc += float(np.exp(-0.5 * (p * p).sum(axis=1)).sum())
        return acc

    out = {}
    for name, work in (("python_ms", python_work), ("numpy_ms", numpy_work)):
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            work()
            times.append(1e3 * (time.perf_counter() - t0))
        out[name] = statistics.median(times)
    return out


#: What each process of ``--against`` runs: import omniloc from the tree given, check it,
#: load the kernels, time one robot, print its row as JSON.
_ONE_RUN = """
import json, sys
from pathlib import Path
src, here, data, robot, frames = sys.argv[1:6]
sys.path.insert(0, src)
import omniloc
import omniloc.track
sys.path.insert(1, here)
import track_speed
for m in (omniloc, omniloc.track):
    if not str(Path(m.__file__).resolve()).startswith(str(Path(src).resolve())):
        raise SystemExit(f"imported {m.__file__}, not from {src}")
track_speed.run_robot(Path(data), 1, limit=200)
row = track_speed.run_robot(Path(data), int(robot), None if frames == "-" else int(frames))
print(json.dumps(row))
"""


def run_in(src: Path, data: Path, robot: int, frames: int | None) -> dict[str, float]:
    """One robot's run in a fresh process that imports omniloc from ``src``."""
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            _ONE_RUN,
            str(src),
            str(HERE),
            str(data),
            str(robot),
            "-" if frames is None else str(frames),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode:
        raise SystemExit(f"a run with {src} failed:\n{out.stderr[-2000:]}")
    row: dict[str, float] = json.loads(out.stdout.strip().splitlines()[-1])
    return row


def against(args: argparse.Namespace, argv: list[str] | None) -> int:
    """``--against``: this checkout's ``src`` and another, alternated run by run."""
    mine = (HERE.parent / "src").resolve()
    other = args.against.resolve()
    if not (other / "omniloc" / "__init__.py").is_file():
        raise SystemExit(f"--against {args.against}: no omniloc package in it (give a src folder)")
    n = max(1, args.repeat)
    out: list[dict[str, object]] = []
    for r in args.robots:
        times: dict[str, list[float]] = {"this": [], "other": []}
        for _ in range(n):
            for name, src in (("other", other), ("this", mine)):
                times[name].append(run_in(src, args.data, r, args.frames)["wall_s"])
        med = {k: statistics.median(v) for k, v in times.items()}
        change = med["this"] / med["other"] - 1.0
        print(
            f"robot{r}: {med['this']:.2f} s here against {med['other']:.2f} s "
            f"({100 * change:+.1f} %; medians of {n}: here "
            + ", ".join(f"{t:.2f}" for t in times["this"])
            + "; other "
            + ", ".join(f"{t:.2f}" for t in times["other"])
            + ")"
        )
        out.append(
            {
                "robot": r,
                "here_s": times["this"],
                "other_s": times["other"],
                "median_here_s": med["this"],
                "median_other_s": med["other"],
            }
        )
    meta = run_meta("track_speed.py", argv, repeat=n, against=str(other))
    path = args.out.with_name(args.out.name + "_against").with_suffix(".json")
    write_results(path, meta, robots=out)
    print(f"wrote {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATA, help="the mrclam-ds6 folder")
    ap.add_argument("--robots", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--repeat", type=int, default=1, help="runs of each robot (fastest kept)")
    ap.add_argument("--frames", type=int, default=None, help="only each run's first N frames")
    ap.add_argument("--out", type=Path, default=HERE / "results_track_speed")
    ap.add_argument(
        "--against",
        type=Path,
        default=None,
        metavar="SRC",
        help="another checkout's src folder: alternate runs with it and compare medians",
    )
    args = ap.parse_args(argv)
    if args.against is not None:
        return against(args, argv)
    run_robot(args.data, 1, limit=200)  # loads (or compiles) every kernel: not timed
    before = reference_ms()
    rows = []
    for r in args.robots:
        best = min(
            (run_robot(args.data, r, args.frames) for _ in range(max(1, args.repeat))),
            key=lambda row: row["wall_s"],
        )
        rows.append(best)
        print(
            f"robot{r}: {best['duration_s']:.1f} s of recording in {best['wall_s']:.2f} s "
            f"({best['realtime_factor']:.0f}x real time; {best['cpu_s']:.2f} s CPU), "
            f"{best['localized']:.0f} of {best['frames']:.0f} frames localized"
        )
    dur = sum(row["duration_s"] for row in rows)
    wall = sum(row["wall_s"] for row in rows)
    total = {"duration_s": dur, "wall_s": wall, "realtime_factor": dur / wall}
    print(f"all: {dur:.1f} s in {wall:.2f} s ({dur / wall:.0f}x real time)")
    after = reference_ms()
    reference = {"before": before, "after": after}
    said = (
        f"the reference workload took {before['python_ms']:.0f} ms (Python) and "
        f"{before['numpy_ms']:.0f} ms (numpy) before the runs, {after['python_ms']:.0f} and "
        f"{after['numpy_ms']:.0f} ms after"
    )
    print(said)
    meta = run_meta("track_speed.py", argv, repeat=args.repeat)
    write_results(
        args.out.with_suffix(".json"), meta, runs=rows, total=total, reference_ms=reference
    )
    lines = [
        "# The tracker's speed on MRCLAM set 6 (`benchmarks/track_speed.py`)",
        "",
        f"{meta['date']}, {meta['machine']}; `{meta['command']}`. Each run alone, the "
        "`mrclam` preset; elapsed time (the target: >= 100x real time), processor time beside; "
        f"the machine's speed: {said} (compare tables of different days by it).",
        "",
        "| run | recording | elapsed | x real time | CPU | localized frames |",
        "|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| robot{row['robot']:.0f} | {row['duration_s']:.0f} s | {row['wall_s']:.1f} s | "
            f"{row['realtime_factor']:.0f}x | {row['cpu_s']:.1f} s | "
            f"{row['localized']:.0f} / {row['frames']:.0f} |"
        )
    lines.append(f"| all | {dur:.0f} s | {wall:.1f} s | {dur / wall:.0f}x | | |")
    args.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
