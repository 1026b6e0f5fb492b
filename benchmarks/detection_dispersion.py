"""Are MRCLAM's detections independent from landmark to landmark, as the tracker's model says?

Run:  python benchmarks/detection_dispersion.py [--data PATH] [--out PATH]

The tracker's frame model (``omniloc.track.likelihood``) takes each landmark in view to be
reported with probability ``p_detect``, independently of the others: a place with eight tubes
in view that reports two pays for six missed ones. On each frame of the five MRCLAM runs this
script counts the landmarks in view of the true pose (the ``mrclam`` preset's field of view,
2 deg inside its edges, and range) and how many of them were reported, and compares, for each
number in view, the spread of that count with the binomial's that independent detections
would give. Writes ``results_detection_dispersion.json`` beside this file; see
docs/tracking-notebook.md ("What would be tried next") for what it found.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import binom

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc.evaluate.tracking import MAX_GAP_S, Stream, mrclam_streams  # noqa: E402
from omniloc.sensor import SensorModel  # noqa: E402
from omniloc.track import Frame, preset  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: Landmarks this close to the edge of the field of view are not counted as in view.
EDGE = math.radians(2.0)


def reported(frame: Frame, n: int) -> NDArray[np.bool_]:
    """Which of the map's ``n`` landmarks ``frame`` reported, by the recording's own ids
    (``frame.truth``; None: a bearing that is no landmark)."""
    seen = np.zeros(n, dtype=bool)
    for t in frame.truth or ():
        if t is not None:
            seen[t] = True
    return seen


def frames_with_truth(stream: Stream) -> Iterator[tuple[Frame, NDArray[np.float64]]]:
    """The frames of ``stream`` whose ground truth is known (no gap in the track longer than
    ``MAX_GAP_S`` around them), each with its true pose."""
    ts = np.array([f.t for f in stream.frames])
    truth, gaps = stream.truth_at(ts)
    for f, x, gap in zip(stream.frames, truth, gaps, strict=True):
        if gap <= MAX_GAP_S and np.isfinite(x).all():
            yield f, x


def counts_in_view(streams: Sequence[Stream], sensor: SensorModel) -> dict[int, list[int]]:
    """For each number of landmarks in view of the true pose, the number of them reported in
    each such frame (frames without ground truth are skipped)."""
    out: dict[int, list[int]] = {}
    if sensor.fov is not None:
        sensor = replace(sensor, fov=sensor.fov - 2.0 * EDGE)
    for st in streams:
        L = st.landmarks.xy
        for f, x in frames_with_truth(st):
            vis = sensor.visible(L, x)
            seen = {t for t in (f.truth or ()) if t is not None and vis[t]}
            out.setdefault(int(vis.sum()), []).append(len(seen))
    return out


def dispersion(n: int, k: Sequence[int]) -> dict[str, float]:
    """The reported counts ``k`` of frames with ``n`` landmarks in view against the binomial
    with the same mean.

    Examples
    --------
    >>> d = dispersion(4, [0, 4, 0, 4])   # all or nothing: twice the binomial's variance
    >>> d["p"], d["variance"], d["binomial_variance"]
    (0.5, 4.0, 1.0)
    """
    a = np.asarray(k, dtype=float)
    p = float(a.mean() / n)
    return {
        "in_view": n,
        "frames": int(a.size),
        "p": p,
        "variance": float(a.var()),
        "binomial_variance": n * p * (1.0 - p),
        "at_most_2": float((a <= 2).mean()),
        "binomial_at_most_2": float(binom.cdf(2, n, p)),
        "all_but_one_or_more": float((a >= n - 1).mean()),
        "binomial_all_but_one_or_more": float(binom.sf(n - 2, n, p)),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(DATA), help="the MRCLAM set 6 folder")
    ap.add_argument("--out", default=str(HERE / "results_detection_dispersion.json"))
    args = ap.parse_args(argv)
    sensor = preset("mrclam")[0]
    counts = counts_in_view(mrclam_streams(args.data), sensor)
    rows: list[dict[str, Any]] = []
    for n in sorted(counts):
        if n < 3 or len(counts[n]) < 100:
            continue
        d = dispersion(n, counts[n])
        rows.append(d)
        print(
            f"{n} in view ({d['frames']} frames): reported {d['p'] * n:.2f} on average, variance "
            f"{d['variance']:.2f} (independent detections: {d['binomial_variance']:.2f}); at most "
            f"2 reported {100 * d['at_most_2']:.0f} % ({100 * d['binomial_at_most_2']:.0f} %), "
            f"all but one or more {100 * d['all_but_one_or_more']:.1f} % "
            f"({100 * d['binomial_all_but_one_or_more']:.1f} %)"
        )
    write_results(args.out, run_meta("detection_dispersion.py", argv), rows=rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
