"""Does MRCLAM's camera miss a landmark because of where it is seen from, and does that carry
over from one robot's run to another's?

Run:  python benchmarks/detection_viewpoint.py [--data PATH] [--out PATH]

On each frame of the five MRCLAM runs, each landmark in view of the true pose (the ``mrclam``
preset's field of view, 2 deg inside its edges, and range; the same view as
``detection_dispersion.py``) is counted as reported or not, by the recording's own landmark
ids, with the range it is seen at and the direction it is seen from (the bearing of the robot
from the landmark, in sectors of the circle). Models of the detection probability are fitted
on four robots' runs and scored on the fifth (leave one robot out), by the log-likelihood of
its reports against one rate for every landmark:

* by range alone (bins of ``RANGE_BIN_M``);
* per landmark;
* per landmark and range;
* per landmark and direction (``--sectors``: 4, 8 and 16 by default);
* per landmark, direction and range.

Each cell's rate is the Beta posterior mean with ``prior`` frames of its parent's rate (a
landmark's around the one rate, a landmark-and-range or landmark-and-direction cell's around
its landmark's, the cell of all three around its landmark-and-range cell): a cell seen
rarely falls back on its parent. Writes ``results_detection_viewpoint.json`` beside this
file; see docs/tracking-notebook.md ("What would be tried next").
"""

from __future__ import annotations

import argparse
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
from omniloc.evaluate.tracking import Stream, mrclam_streams  # noqa: E402
from omniloc.sensor import SensorModel  # noqa: E402
from omniloc.track import preset  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: Width of a range bin (m); the last bin is open.
RANGE_BIN_M = 1.5
RANGE_BINS = 5
#: Strength of each cell's Beta prior around its parent's rate, in frames.
PRIOR_FRAMES = 10.0

#: Columns of :func:`sightings`'s rows.
RUN, LANDMARK, DIRECTION, RANGE, REPORTED = range(5)


def sightings(streams: Sequence[Stream], sensor: SensorModel) -> NDArray[np.float64]:
    """Every landmark in view of the true pose on every frame with ground truth, as rows
    ``(run, landmark, direction, range, reported)``: the stream's index, the landmark's,
    the direction the robot is seen from (radians in [-pi, pi), world frame), the range (m)
    and 1.0 if the frame reported it (0.0 if not)."""
    if sensor.fov is not None:
        sensor = replace(sensor, fov=sensor.fov - 2.0 * EDGE)
    rows: list[tuple[float, float, float, float, float]] = []
    for k, st in enumerate(streams):
        L = st.landmarks.xy
        for f, x in frames_with_truth(st):
            vis = sensor.visible(L, x)
            seen = reported(f, len(L))
            for j in np.flatnonzero(vis):
                dx, dy = x[0] - L[j, 0], x[1] - L[j, 1]
                rows.append((k, j, math.atan2(dy, dx), math.hypot(dx, dy), float(seen[j])))
    return np.array(rows, dtype=np.float64).reshape(-1, 5)


def cell_rates(
    keys_fit: NDArray[np.int64],
    reported: NDArray[np.float64],
    keys: NDArray[np.int64],
    parent: NDArray[np.float64],
    prior: float = PRIOR_FRAMES,
) -> NDArray[np.float64]:
    """Each row's rate: the Beta posterior mean of its cell (its row of ``keys``) from the
    fitting rows (``keys_fit``, ``reported``), with ``prior`` frames of its ``parent`` rate.

    Examples
    --------
    >>> fit = np.array([[0], [0], [0], [1]])
    >>> cell_rates(fit, np.array([1.0, 1.0, 0.0, 1.0]), np.array([[0], [2]]),
    ...            np.array([0.5, 0.5]), prior=2.0).tolist()
    [0.6, 0.5]
    """
    fit = np.ascontiguousarray(keys_fit, dtype=np.int64).reshape(len(reported), -1)
    at = np.ascontiguousarray(keys, dtype=np.int64).reshape(len(parent), -1)
    cells, inverse = np.unique(fit, axis=0, return_inverse=True)
    hits = np.bincount(inverse.reshape(-1), weights=reported, minlength=len(cells))
    counts = np.bincount(inverse.reshape(-1), minlength=len(cells)).astype(np.float64)
    lookup = {tuple(c): i for i, c in enumerate(cells.tolist())}
    out = np.empty(len(parent))
    for r, key in enumerate(at.tolist()):
        i = lookup.get(tuple(key))
        h, n = (hits[i], counts[i]) if i is not None else (0.0, 0.0)
        out[r] = (h + prior * parent[r]) / (n + prior)
    return out


def log_likelihood(p: NDArray[np.float64], reported: NDArray[np.float64]) -> float:
    """ln P(reports) with each row reported with probability ``p`` (clipped to [1e-6,
    1 - 1e-6])."""
    q = np.clip(p, 1e-6, 1.0 - 1e-6)
    return float(np.sum(np.where(reported > 0.5, np.log(q), np.log1p(-q))))


def held_out_gains(
    rows: NDArray[np.float64], sectors: Sequence[int] = (4, 8, 16)
) -> dict[str, dict[str, float]]:
    """Each model's log-likelihood gain over one rate on each run, fitted on the others
    (nats; ``"all"``: their sum), and per sighting over all runs."""
    run = rows[:, RUN].astype(np.int64)
    lm = rows[:, LANDMARK].astype(np.int64)
    rbin = np.minimum((rows[:, RANGE] / RANGE_BIN_M).astype(np.int64), RANGE_BINS - 1)
    y = rows[:, REPORTED]
    out: dict[str, dict[str, float]] = {}

    def add(name: str, k: int, gain: float) -> None:
        out.setdefault(name, {})[f"run {k}"] = gain

    for k in np.unique(run).tolist():
        fit, held = run != k, run == k
        one = np.full(int(held.sum()), float(y[fit].mean()))
        base = log_likelihood(one, y[held])

        def rates(
            keys: NDArray[np.int64],
            parent: NDArray[np.float64],
            fit: NDArray[np.bool_] = fit,
            held: NDArray[np.bool_] = held,
        ) -> NDArray[np.float64]:
            return cell_rates(keys[fit], y[fit], keys[held], parent)

        by_range = rates(rbin[:, None], one)
        by_lm = rates(lm[:, None], one)
        lm_range_keys = np.column_stack([lm, rbin])
        by_lm_range = rates(lm_range_keys, by_lm)
        add("range", k, log_likelihood(by_range, y[held]) - base)
        add("landmark", k, log_likelihood(by_lm, y[held]) - base)
        add("landmark and range", k, log_likelihood(by_lm_range, y[held]) - base)
        for s in sectors:
            sec = np.floor((rows[:, DIRECTION] + math.pi) / (2.0 * math.pi / s)).astype(np.int64)
            sec %= s
            by_dir = rates(np.column_stack([lm, sec]), by_lm)
            by_all = rates(np.column_stack([lm, sec, rbin]), by_lm_range)
            add(f"landmark and direction ({s} sectors)", k, log_likelihood(by_dir, y[held]) - base)
            add(
                f"landmark, direction ({s} sectors) and range",
                k,
                log_likelihood(by_all, y[held]) - base,
            )
    for gains in out.values():
        total = sum(gains.values())
        gains["all"] = total
        gains["per sighting"] = total / len(y)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATA, help="the mrclam-ds6 folder")
    ap.add_argument("--sectors", type=int, nargs="+", default=[4, 8, 16])
    ap.add_argument("--out", type=Path, default=HERE / "results_detection_viewpoint.json")
    args = ap.parse_args(argv)
    sensor, _, _ = preset("mrclam")
    streams = mrclam_streams(args.data)
    rows = sightings(streams, sensor)
    gains = held_out_gains(rows, args.sectors)
    print(
        f"{len(rows):,} sightings of landmarks in view of the true pose on {len(streams)} runs "
        f"(reported in {100 * rows[:, REPORTED].mean():.1f} %); held-out log-likelihood gain "
        "over one rate (each run scored by a model fitted on the others):"
    )
    for name, g in gains.items():
        runs = ", ".join(f"{g[k]:.0f}" for k in g if k.startswith("run "))
        print(f"  {name:>42}: {g['all']:7.0f} nats ({runs}; {g['per sighting']:.4f} a sighting)")
    meta: dict[str, Any] = run_meta("detection_viewpoint.py", argv)
    write_results(
        args.out,
        meta,
        sightings=len(rows),
        runs=[st.name for st in streams],
        range_bin_m=RANGE_BIN_M,
        prior_frames=PRIOR_FRAMES,
        held_out_gain_nats=gains,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
