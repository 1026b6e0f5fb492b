"""Does a landmark that MRCLAM's camera reported (or missed) in the last frames get reported
again? And which prior strength describes that for ``TrackerConfig.detect_prior_frames``?

Run:  python benchmarks/detection_memory.py [--data PATH] [--out PATH]

On each frame of the five MRCLAM runs, each landmark in view of the true pose (the ``mrclam``
preset's field of view, 2 deg inside its edges, and range) is counted as reported or not,
by the recording's own landmark ids. For each landmark the script follows its run of
consecutive frames in view (broken when it leaves the view or when frames are more than 2 s
apart) and tabulates how often it is reported after k reports in a row, or after k misses
in a row. The tracker's model with memory (``omniloc.track.likelihood.Detections``) says:
reported with ``(p n0 + hits) / (n0 + hits + misses)`` after ``hits`` reports and ``misses``
misses in its run; the script fits ``n0`` by maximum likelihood over every frame of every
run (with ``p`` the preset's ``p_detect``, and ``p`` fitted too), and gives the
log-likelihood of independent detections (``n0`` infinite) beside it.

Writes ``results_detection_memory.json`` beside this file; see docs/tracking-notebook.md ("Detection
with memory").
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from detection_dispersion import EDGE, reported  # noqa: E402  (the same view as its counts)
from omniloc.evaluate.tracking import MAX_GAP_S, Stream, mrclam_streams  # noqa: E402
from omniloc.sensor import SensorModel  # noqa: E402
from omniloc.track import preset  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: Frames further apart than this break every landmark's run.
BREAK_S = 2.0
#: Runs of this many or more are tabulated together.
TOP = 16


def sightings(streams: Sequence[Stream], sensor: SensorModel) -> list[tuple[int, int, bool]]:
    """Every (reports before, misses before, reported now) of a landmark in view of the true
    pose (``sensor``'s view, ``EDGE`` inside its edges), the counts over the landmark's
    current run of frames in view."""
    if sensor.fov is not None:
        sensor = replace(sensor, fov=sensor.fov - 2.0 * EDGE)
    out: list[tuple[int, int, bool]] = []
    for st in streams:
        L = st.landmarks.xy
        hits = np.zeros(len(L), dtype=np.int64)
        misses = np.zeros(len(L), dtype=np.int64)
        ts = np.array([f.t for f in st.frames])
        truth, gaps = st.truth_at(ts)
        last = -math.inf
        for f, x, gap in zip(st.frames, truth, gaps, strict=True):
            if not (gap <= MAX_GAP_S and np.isfinite(x).all()) or f.t - last > BREAK_S:
                hits[:] = 0
                misses[:] = 0
            if not (gap <= MAX_GAP_S and np.isfinite(x).all()):
                continue
            last = f.t
            vis = sensor.visible(L, x)
            seen = reported(f, len(L))
            for j in np.flatnonzero(vis):
                out.append((int(hits[j]), int(misses[j]), bool(seen[j])))
            hits = np.where(vis, hits + seen, 0)
            misses = np.where(vis, misses + (vis & ~seen), 0)
    return out


def log_likelihood(rows: np.ndarray, p: float, n0: float) -> float:
    """ln P(reports) under the Beta-predictive model (``n0`` inf: independent with ``p``)."""
    h, m, y = rows[:, 0], rows[:, 1], rows[:, 2].astype(bool)
    q = np.full(h.size, p) if math.isinf(n0) else (p * n0 + h) / (n0 + h + m)
    return float(np.log(np.where(y, q, 1.0 - q)).sum())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATA, help="the mrclam-ds6 folder")
    ap.add_argument("--out", type=Path, default=HERE / "results_detection_memory.json")
    args = ap.parse_args(argv)
    sensor, _, _ = preset("mrclam")
    rows = np.array(sightings(mrclam_streams(args.data), sensor), dtype=np.int64)
    p_preset = float(sensor.p_detect or 0.35)
    table = []
    for kind, col in (("after reports", 0), ("after misses", 1)):
        for k in range(1, TOP + 1):
            other = 1 - col
            n = rows[:, col]
            sel = ((n == k) if k < TOP else (n >= k)) & (rows[:, other] == 0)
            if sel.any():
                table.append(
                    {
                        "history": f"{kind} only, {k}{'+' if k == TOP else ''}",
                        "frames": int(sel.sum()),
                        "reported": float(rows[sel, 2].mean()),
                    }
                )
    first = (rows[:, 0] == 0) & (rows[:, 1] == 0)
    table.insert(
        0,
        {
            "history": "first frame in view",
            "frames": int(first.sum()),
            "reported": float(rows[first, 2].mean()),
        },
    )
    fits = {}
    for name, p in (("p_detect of the preset", p_preset), ("p fitted", float(rows[:, 2].mean()))):
        res = minimize_scalar(
            lambda ln0, p=p: -log_likelihood(rows, p, math.exp(ln0)),
            bounds=(math.log(0.1), math.log(1000.0)),
            method="bounded",
        )
        n0 = math.exp(res.x)
        fits[name] = {
            "p": p,
            "n0": n0,
            "log_likelihood": -float(res.fun),
            "independent_log_likelihood": log_likelihood(rows, p, math.inf),
        }
    print(f"{rows.shape[0]:,} sightings of landmarks in view of the true pose")
    for r in table:
        share = 100 * r["reported"]
        print(f"  {r['history']:>26}: {r['frames']:6,d} frames, reported in {share:5.1f} %")
    for name, f in fits.items():
        print(
            f"  {name} ({f['p']:.3f}): n0 = {f['n0']:.2f} frames, ln L {f['log_likelihood']:,.0f} "
            f"against {f['independent_log_likelihood']:,.0f} for independent detections"
        )
    write_results(args.out, run_meta("detection_memory.py", argv), table=table, fits=fits)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
