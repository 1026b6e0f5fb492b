"""Does a MRCLAM tube hide the tubes behind it, and by how much?

Run:  python benchmarks/detection_occlusion.py [--data PATH] [--out PATH]

On each frame of the five MRCLAM runs, each landmark in view of the true pose (the ``mrclam``
preset's field of view, 2 deg inside its edges, and range; the same view as
``detection_dispersion.py``) is counted as reported or not, by the recording's own landmark
ids, with how far its line of sight passes beside the nearest-passing landmark nearer to the
robot that is itself in the (full) view: the bearings' separation times that landmark's
distance, in metres at its distance. The rate of reports is given by that offset, as a share
of the rate of the landmarks with no nearer one within 0.3 m of their line of sight.

Then the tracker's occlusion model (``TrackerConfig.occlusion_width``: a landmark's detection
probability times ``1 - exp(-l^2 / (2 w^2))`` for each nearer landmark in view, ``l`` its
offset) is fitted: for each width ``w`` of ``WIDTHS_M`` the detection probability that
maximises the likelihood of the reports (reported over the sum of the factors) and that
log-likelihood, against ``w`` 0 (no occlusion). In sample: the five runs are both what is
fitted and what is scored (two parameters over 44,000 sightings). Writes
``results_detection_occlusion.json`` beside this file; docs/tracking-notebook.md ("Tubes
behind tubes") has what it found and what the model did in the tracker.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from detection_dispersion import EDGE, frames_with_truth, reported  # noqa: E402  (the same view)
from omniloc.angles import wrap  # noqa: E402
from omniloc.evaluate.tracking import Stream, mrclam_streams  # noqa: E402
from omniloc.sensor import SensorModel  # noqa: E402
from omniloc.track import preset  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: Bins of the offset (m) at which the rates are given.
OFFSET_BINS_M = (0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.10, 0.15, 0.20, 0.30)
#: Widths (m) of the occlusion model that are fitted.
WIDTHS_M = (0.0, 0.02, 0.025, 0.03, 0.035, 0.04, 0.045, 0.05, 0.06)
#: Beyond this many widths a nearer landmark's factor is taken as 1 (as the tracker's kernel).
REACH = 6.0


def sightings(
    streams: Sequence[Stream], sensor: SensorModel
) -> tuple[list[NDArray[np.float64]], NDArray[np.bool_]]:
    """For every landmark in view of a frame's true pose (``sensor``'s view, ``EDGE``
    inside its edges): the offsets (m) of the nearer landmarks in the full view from its
    line of sight, and whether it was reported."""
    inner = replace(sensor, fov=sensor.fov - 2.0 * EDGE) if sensor.fov is not None else sensor
    offsets: list[NDArray[np.float64]] = []
    seen: list[bool] = []
    for st in streams:
        L = st.landmarks.xy
        for f, x in frames_with_truth(st):
            count = inner.visible(L, x)
            full = sensor.visible(L, x)
            rep = reported(f, L.shape[0])
            dist = np.hypot(L[:, 0] - x[0], L[:, 1] - x[1])
            bear = np.asarray(wrap(np.arctan2(L[:, 1] - x[1], L[:, 0] - x[0]) - x[2]))
            for n in np.flatnonzero(count):
                near = full & (dist < dist[n])
                sep = np.abs(np.asarray(wrap(bear[near] - bear[n])))
                offsets.append(sep * dist[near])
                seen.append(bool(rep[n]))
    return offsets, np.array(seen)


def fit(offsets: list[NDArray[np.float64]], seen: NDArray[np.bool_], w: float) -> dict[str, float]:
    """The detection probability that maximises the reports' likelihood under width ``w``,
    and that log-likelihood (nats)."""
    f = np.ones(seen.size)
    if w > 0:
        for i, o in enumerate(offsets):
            o = o[o < REACH * w]
            if o.size:
                f[i] = float(np.prod(-np.expm1(-0.5 * (o / w) ** 2)))
    p = float(seen.sum() / f.sum())
    q = np.clip(p * f, 1e-12, 1 - 1e-12)
    ll = float(np.sum(np.where(seen, np.log(q), np.log1p(-q))))
    return {"width_m": w, "p_detect": p, "log_likelihood": ll}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(DATA), help="the MRCLAM set 6 folder")
    ap.add_argument("--out", default=str(HERE / "results_detection_occlusion.json"))
    args = ap.parse_args(argv)
    offsets, seen = sightings(mrclam_streams(args.data), preset("mrclam")[0])
    nearest = np.array([o.min() if o.size else math.inf for o in offsets])
    clear = nearest >= OFFSET_BINS_M[-1]
    base = float(seen[clear].mean())
    print(
        f"{seen.size} sightings in view, {seen.mean():.3f} reported; with no nearer landmark "
        f"within {OFFSET_BINS_M[-1]} m of the line of sight ({clear.sum()}): {base:.3f}"
    )
    bins: list[dict[str, Any]] = []
    for lo, hi in itertools.pairwise(OFFSET_BINS_M):
        m = (nearest >= lo) & (nearest < hi)
        rate = float(seen[m].mean()) if m.any() else math.nan
        bins.append({"offset_m": [lo, hi], "sightings": int(m.sum()), "reported": rate,
                     "share_of_clear": rate / base})  # fmt: skip
        print(f"  passes {lo:.2f}-{hi:.2f} m beside a nearer one: {int(m.sum()):6d} sightings, "
              f"reported {rate:.3f} ({rate / base:.2f} of the clear ones')")  # fmt: skip
    fits = [fit(offsets, seen, w) for w in WIDTHS_M]
    for r in fits:
        gain = r["log_likelihood"] - fits[0]["log_likelihood"]
        print(f"  width {r['width_m']:.3f} m: p_detect {r['p_detect']:.4f}, log-likelihood "
              f"{r['log_likelihood']:.1f} ({gain:+.1f} nats against no occlusion)")  # fmt: skip
    write_results(
        args.out,
        run_meta("detection_occlusion.py", argv),
        sightings=int(seen.size),
        reported=float(seen.mean()),
        clear_rate=base,
        by_offset=bins,
        fits=fits,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
