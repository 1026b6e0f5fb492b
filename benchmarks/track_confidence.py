"""The tracker's confidence on MRCLAM set 6, held out by robot: how its own probability and
a confidence table fitted on the other robots compare with what happened.

Run:  python benchmarks/track_confidence.py [PATH] [--seeds N ...] [--out PATH]   (~9 min)

PATH is the MRCLAM folder (default ``../shared/data/mrclam-ds6`` beside the repository).
Every robot's whole run goes through the tracker with the ``mrclam`` preset (its confidence
tables removed: they do not change a decision, only what is reported), once per seed of
elsewhere's particles (``--seeds``, default 0-4: what the preset's tables were fitted
on). Each frame with a pose is scored against
the Vicon track: within 0.3 m and 5 degrees, or not (``frames_within_tolerance``).

* *held out*: for each robot, confidence tables are fitted (``fit_confidence``) on the
  other four robots' frames and applied to its own; the five robots' held-out confidences
  together are compared with what happened (expected calibration error over tenths of
  [0, 1], and per state). The ambiguous frames within ``RECENT_S`` seconds of a localized
  one have a table of their own (``since_localized``); *held out, one table per state* is
  the same without it (the tables before 2026-12-05 08:00), for comparison.
* *the model's probability*: the tracker's own ``probability``, compared the same way.
* *every hypothesis*: each reported hypothesis's weight, and its held-out confidence (the
  hypotheses' tables fitted on the other robots, ``held_out_table``: one for the frames
  within ``RECENT_S`` of a localized one, localized frames included, one for the others;
  *one table*: without that split, as before 2026-12-05 08:40), against whether the
  truth is within tolerance of its pose.
* *the preset's tables*: fitted on all five robots (and every seed given), printed in the
  form the ``mrclam`` preset holds them -- those are in-sample on these runs; the held-out
  figures are what to expect of them on a run they were not fitted on. The preset takes
  them only if they also calibrate the evaluation's streams better than its tables do
  (they did not on 2026-12-06 nor on 2026-12-07: docs/tracking.md, "What to trust").

Writes ``results_track_confidence.json`` and ``.md`` beside this file.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

from _results import run_meta, write_results  # noqa: E402
from omniloc.evaluate.common import calibration  # noqa: E402
from omniloc.evaluate.tracking import (  # noqa: E402
    evaluate_tracking,
    frames_within_tolerance,
    hypothesis_outcomes,
    mrclam_streams,
    tracker_factory,
)
from omniloc.track.confidence import (  # noqa: E402
    RECENT_S,
    fit_confidence,
    held_out_confidence,
    held_out_table,
    is_recent,
)

NO_TABLES = {
    "confidence_localized": None,
    "confidence_ambiguous": None,
    "confidence_recent": None,
    "confidence_hypothesis": None,
    "confidence_hypothesis_recent": None,
}
BINS = 10


def frames_of(path: Path, seeds: list[int]) -> dict[str, np.ndarray]:
    """Every scored frame with a pose of every robot's whole run, per seed: robot, seed,
    state, the tracker's probability, and whether the pose was within tolerance."""
    streams = mrclam_streams(path)
    robot, seed_of, state, prob, right, since = [], [], [], [], [], []
    h_robot, h_weight, h_right, h_since = [], [], [], []
    for seed in seeds:
        make = tracker_factory("mrclam", {**NO_TABLES, "seed": seed})
        _, estimates = evaluate_tracking(streams, make, name=f"seed {seed}", progress=False)
        for k, (s, est) in enumerate(zip(streams, estimates, strict=True)):
            scored, ok = frames_within_tolerance(s, est)
            truth, _ = s.truth_at(np.array([e.t for e in est]))
            hyps = hypothesis_outcomes(est, truth, scored)
            h_robot += [k + 1] * hyps.right.size
            h_weight += hyps.weights.tolist()
            h_right += hyps.right.tolist()
            h_since += [
                np.nan if est[i].since_localized is None else est[i].since_localized
                for i in hyps.frame.tolist()
            ]
            for e, sc, r in zip(est, scored, ok, strict=True):
                if not sc or e.probability is None:
                    continue
                robot.append(k + 1)
                seed_of.append(seed)
                state.append(e.state.value)
                prob.append(e.probability)
                right.append(bool(r))
                since.append(np.nan if e.since_localized is None else e.since_localized)
        print(f"seed {seed}: {len(prob)} frames with a pose so far", flush=True)
    return {
        "robot": np.asarray(robot),
        "seed": np.asarray(seed_of),
        "state": np.asarray(state),
        "probability": np.asarray(prob, dtype=np.float64),
        "right": np.asarray(right, dtype=bool),
        "since": np.asarray(since, dtype=np.float64),
        "h_robot": np.asarray(h_robot),
        "h_weight": np.asarray(h_weight, dtype=np.float64),
        "h_right": np.asarray(h_right, dtype=bool),
        "h_since": np.asarray(h_since, dtype=np.float64),
    }


def reliability(conf: np.ndarray, right: np.ndarray) -> dict[str, object]:
    """Expected calibration error and the table over tenths of [0, 1]."""
    c = calibration(conf.tolist(), right.tolist(), bins=BINS)
    rows = [
        {
            "bin": f"{c.edges[b]:.1f}-{c.edges[b + 1]:.1f}",
            "frames": int(c.counts[b]),
            "mean": float(c.mean_confidence[b]) if c.counts[b] else None,
            "right": float(c.fraction_correct[b]) if c.counts[b] else None,
        }
        for b in range(BINS)
    ]
    # (Over the tenths from 0.1 up: most hypotheses have weights near 0, right or wrong
    # as often as those say, and they would hide the others in the pooled error.)
    hi = [r for r in rows[1:] if r["frames"]]
    n_hi = sum(int(r["frames"]) for r in hi)  # type: ignore[call-overload]
    ece_hi = (
        sum(abs(r["right"] - r["mean"]) * r["frames"] for r in hi) / n_hi  # type: ignore[operator]
        if n_hi
        else float("nan")
    )
    return {
        "frames": int(conf.size),
        "ece": c.ece,
        "frames_from_0.1": n_hi,
        "ece_from_0.1": ece_hi,
        "bins": rows,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "path", nargs="?", type=Path, default=HERE.parent.parent / "shared/data/mrclam-ds6"
    )
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--out", type=Path, default=HERE / "results_track_confidence")
    args = ap.parse_args(argv)
    f = frames_of(args.path, args.seeds)
    held = held_out_confidence(
        f["state"], f["probability"], f["right"], f["robot"], since_localized=f["since"]
    )
    held_by_state = held_out_confidence(f["state"], f["probability"], f["right"], f["robot"])
    recent = (f["state"] == "ambiguous") & is_recent(f["since"], RECENT_S)
    out: dict[str, object] = {}
    for label, values in (
        ("model probability", f["probability"]),
        ("held out", held),
        ("held out, one table per state", held_by_state),
    ):
        entry = {"all": reliability(values, f["right"])}
        for state in ("localized", "ambiguous"):
            sel = f["state"] == state
            entry[state] = reliability(values[sel], f["right"][sel])
        entry["recent"] = reliability(values[recent], f["right"][recent])
        out[label] = entry
        print(
            f"{label}: ECE {entry['all']['ece']:.3f} over {entry['all']['frames']} frames "
            f"(localized {entry['localized']['ece']:.3f}, ambiguous "
            f"{entry['ambiguous']['ece']:.3f}, of which within {RECENT_S:g} s of a localized "
            f"frame {entry['recent']['ece']:.3f} over {entry['recent']['frames']})"
        )
    h_held = held_out_table(
        f["h_weight"], f["h_right"], f["h_robot"], contexts=is_recent(f["h_since"], RECENT_S)
    )
    h_held_one = held_out_table(f["h_weight"], f["h_right"], f["h_robot"])
    for label, values in (
        ("hypotheses' weights", f["h_weight"]),
        ("hypotheses, held out", h_held),
        ("hypotheses, held out, one table", h_held_one),
    ):
        out[label] = {"all": reliability(values, f["h_right"])}
        a = out[label]["all"]  # type: ignore[index]
        print(
            f"{label}: ECE {a['ece']:.3f} over {a['frames']} hypotheses ({a['ece_from_0.1']:.3f} "
            f"over the {a['frames_from_0.1']} at 0.1 or more)"
        )
    full = fit_confidence(
        f["state"],
        f["probability"],
        f["right"],
        since_localized=f["since"],
        hypothesis_weights=f["h_weight"],
        hypothesis_right=f["h_right"],
        hypothesis_since_localized=f["h_since"],
    )
    print("tables fitted on every robot (the preset's):")
    for name, table in full.settings().items():
        print(f"    {name}={table!r},")
    meta = run_meta("track_confidence.py", argv, seeds=args.seeds)
    write_results(
        args.out.with_suffix(".json"),
        meta,
        calibration=out,
        fitted_on_all=full.settings(),
        frames=full.frames,
        right=full.right,
    )
    lines = [
        "# The tracker's confidence on MRCLAM, held out by robot "
        "(`benchmarks/track_confidence.py`)",
        "",
        f"{meta['date']}, {meta['machine']}; `{meta['command']}`; elsewhere's seeds "
        f"{', '.join(map(str, args.seeds))}. Frames with a pose of the five whole runs, the "
        "`mrclam` preset; right: within 0.3 m and 5 deg of the Vicon track. *Held out*: each "
        "robot's frames mapped by the tables fitted on the four others. *Recent*: the "
        f"ambiguous frames within {RECENT_S:g} s of a localized one (a table of their own; "
        "*one table per state*: without it).",
        "",
        "| | frames | ECE, all | ECE, localized | ECE, ambiguous | of which recent | from 0.1 "
        "up: frames, ECE |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, entry in out.items():
        e = entry  # type: ignore[assignment]
        per_state = (
            f"{e['localized']['ece']:.3f} | {e['ambiguous']['ece']:.3f} | "  # type: ignore[index]
            f"{e['recent']['ece']:.3f} ({e['recent']['frames']:,})"  # type: ignore[index]
            if "localized" in e
            else "- | - | -"
        )
        a = e["all"]  # type: ignore[index]
        lines.append(
            f"| {label} | {a['frames']:,} | {a['ece']:.3f} | {per_state} | "
            f"{a['frames_from_0.1']:,}, {a['ece_from_0.1']:.3f} |"
        )
    lines += ["", "Reliability (all frames): mean value and share right, per tenth", ""]
    lines += ["| bin | frames | model probability | right | held-out confidence | right |"]
    lines += ["|---|---|---|---|---|---|"]
    a = out["model probability"]["all"]["bins"]  # type: ignore[index]
    b = out["held out"]["all"]["bins"]  # type: ignore[index]
    for x, y in zip(a, b, strict=True):

        def cell(v: float | None) -> str:
            return "-" if v is None else f"{v:.3f}"

        lines.append(
            f"| {x['bin']} | {x['frames']:,} / {y['frames']:,} | {cell(x['mean'])} | "
            f"{cell(x['right'])} | {cell(y['mean'])} | {cell(y['right'])} |"
        )
    args.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
