"""Do MRCLAM's bearing errors repeat from frame to frame, as the tracker's weighing must know?

Run:  python benchmarks/bearing_correlation.py [--data PATH] [--out PATH]

The tracker's frame model (``omniloc.track.likelihood``) takes each frame's bearing errors to
be independent of the last frame's, so a tube seen in ten frames counts as ten independent
measurements of the pose. On each frame of the five MRCLAM runs this script takes the
bearings of known tubes (the frames' own landmark ids), their errors against the Vicon pose
(measured minus predicted, those within 5 deg: the tail is left to the gate), and for each
pair of sightings of one tube on one run, the correlation of the two errors by the time
between them. Writes ``results_bearing_correlation.json`` beside this file; docs/tracking.md
("Weighing the evidence") says what the tracker does with it.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc import predict_bearings  # noqa: E402
from omniloc.angles import wrap  # noqa: E402
from omniloc.evaluate.tracking import MAX_GAP_S, Stream, mrclam_streams  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: Bearing errors beyond this (radians) are left out: the heavy tail the gate handles.
MAX_ERROR = math.radians(5.0)
#: The lags (s) whose correlation is reported: each bin is (previous, this].
LAGS = (0.3, 0.6, 1.2, 2.5, 5.0)


def sightings(streams: Sequence[Stream]) -> list[tuple[int, int, float, float]]:
    """Every bearing of a known tube as ``(run, tube, t, error)`` (error in radians, frames
    without ground truth skipped)."""
    out: list[tuple[int, int, float, float]] = []
    for k, st in enumerate(streams):
        ts = np.array([f.t for f in st.frames])
        truth, gaps = st.truth_at(ts)
        L = st.landmarks.xy
        for f, x, gap in zip(st.frames, truth, gaps, strict=True):
            if not (gap <= MAX_GAP_S and np.isfinite(x).all()) or f.truth is None:
                continue
            for b, tube in zip(f.bearings, f.truth, strict=True):
                if tube is None:
                    continue
                err = float(wrap(b - predict_bearings(L[tube][None], x)[0]))
                if abs(err) <= MAX_ERROR:
                    out.append((k, int(tube), float(f.t), err))
    return out


def lag_correlations(
    rows: Sequence[tuple[int, int, float, float]], lags: Sequence[float] = LAGS
) -> list[dict[str, float]]:
    """For each lag bin (previous lag, lag], the correlation of the errors of two sightings
    of one tube on one run that far apart.

    Examples
    --------
    >>> rows = [(0, 1, 0.25 * i, e) for i, e in enumerate([0.01, 0.01, -0.02, -0.02])]
    >>> [round(r["correlation"], 2) for r in lag_correlations(rows, (0.3,))]
    [0.5]
    """
    by: dict[tuple[int, int], list[tuple[float, float]]] = {}
    for run, tube, t, e in rows:
        by.setdefault((run, tube), []).append((t, e))
    lo = [0.0, *lags[:-1]]
    pairs: list[list[tuple[float, float]]] = [[] for _ in lags]
    for seq in by.values():
        seq.sort()
        t = np.array([s[0] for s in seq])
        e = np.array([s[1] for s in seq])
        for i in range(t.size):
            j = i + 1
            while j < t.size and t[j] - t[i] <= lags[-1]:
                dt = t[j] - t[i]
                for b, (a, c) in enumerate(zip(lo, lags, strict=True)):
                    if a < dt <= c:
                        pairs[b].append((e[i], e[j]))
                j += 1
    out = []
    for a, c, p in zip(lo, lags, pairs, strict=True):
        v = np.array(p, dtype=float).reshape(-1, 2)
        corr = float(np.corrcoef(v[:, 0], v[:, 1])[0, 1]) if len(v) > 2 else math.nan
        out.append({"lag_from_s": a, "lag_to_s": c, "pairs": len(v), "correlation": corr})
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(DATA), help="the MRCLAM set 6 folder")
    ap.add_argument("--out", default=str(HERE / "results_bearing_correlation.json"))
    args = ap.parse_args(argv)
    rows = sightings(mrclam_streams(args.data))
    err = np.array([r[3] for r in rows])
    print(f"{err.size} sightings of known tubes; error sd {math.degrees(err.std()):.2f} deg")
    lags = lag_correlations(rows)
    for r in lags:
        print(
            f"{r['lag_from_s']:.2f}-{r['lag_to_s']:.2f} s apart ({r['pairs']} pairs): "
            f"correlation {r['correlation']:.2f}"
        )
    write_results(
        args.out,
        run_meta("bearing_correlation.py", argv),
        sightings=int(err.size),
        error_sd_deg=math.degrees(float(err.std())),
        lags=lags,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
