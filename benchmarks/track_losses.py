"""Where the true place's mass goes when the tracker loses it on MRCLAM, and how many of
the tubes in view the frames of those losses reported.

Run:  python benchmarks/track_losses.py [--data PATH] [--robots 1 2 3 4 5]
      [--set NAME=VALUE ...] [--out PATH]

Each robot's whole run with the ``mrclam`` preset (``--set`` changes a setting by name, as
``omniloc track --set``). At each frame the true place is the reported hypotheses within
0.5 m and 10 deg of the ground truth; a loss is a frame at which it holds at least 90 % of
the mass followed, within 3 s, by a frame at which it holds under 10 %. Each loss is put
down to elsewhere (elsewhere holds half the mass or more at its end) or to a rival (the best
hypothesis then, its distance and heading from the truth). The frames of the losses (after
the 90 % frame, up to the 10 % one) are compared with the frames in which the true place
holds at least half the mass: among those with 3 or more tubes in view of the true pose
(the preset sensor's ``visible``: 0.85-7 m, the 67 deg view), the share of the tubes in view
reported. The recordings' landmark ids (``Frame.truth``) say which bearing is which; the
tracker never reads them.

Writes ``results_track_losses.json`` beside this file; docs/tracking-notebook.md ("Frames listed
only when they hold a bearing") cites it.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from _results import run_meta, write_results  # noqa: E402
from omniloc.angles import wrap  # noqa: E402
from omniloc.cli import _setting  # noqa: E402
from omniloc.evaluate.tracking import MAX_GAP_S, mrclam_streams, run_stream  # noqa: E402
from omniloc.track import Tracker, TrackEstimate, preset, with_settings  # noqa: E402

DATA = HERE.parent.parent / "shared" / "data" / "mrclam-ds6"
#: The true place: hypotheses within this of the ground truth (m, rad).
NEAR_M, NEAR_HEADING = 0.5, math.radians(10.0)
#: A loss: from at least HELD to under GONE within WITHIN_S seconds.
HELD, GONE, WITHIN_S = 0.9, 0.1, 3.0


def _true_share(e: TrackEstimate, x: float, y: float, th: float) -> float:
    return float(
        sum(
            h.weight
            for h in e.hypotheses
            if math.hypot(h.pose.x - x, h.pose.y - y) < NEAR_M
            and abs(float(wrap(h.pose.theta - th))) < NEAR_HEADING
        )
    )


def _elsewhere(e: TrackEstimate) -> float:
    return 1.0 if not e.hypotheses else max(0.0, 1.0 - sum(h.weight for h in e.hypotheses))


def find_losses(t: Any, share: Any) -> list[tuple[int, int]]:
    """Each loss of the true place as ``(i, j)``: at frame ``i`` it holds at least ``HELD``
    of the mass, at frame ``j`` (within ``WITHIN_S`` of ``i``, the first such frame after it)
    under ``GONE``, and at least ``GONE`` in between. The search goes on from ``j``.

    Examples
    --------
    >>> find_losses([0, 1, 2, 3, 10, 11], [0.95, 0.5, 0.05, 0.95, 0.95, 0.2])
    [(0, 2)]
    """
    t, share = np.asarray(t, dtype=float), np.asarray(share, dtype=float)
    out: list[tuple[int, int]] = []
    i = 0
    while i < len(t):
        if share[i] >= HELD:
            j = i + 1
            while j < len(t) and t[j] - t[i] <= WITHIN_S and share[j] >= GONE:
                j += 1
            if j < len(t) and t[j] - t[i] <= WITHIN_S and share[j] < GONE:
                out.append((i, j))
                i = j
                continue
        i += 1
    return out


def reported_share(counts: Any) -> dict[str, float]:
    """Over frames of ``(tubes in view reported, tubes in view)`` with 3 or more in view:
    how many frames, and the share of their tubes in view that were reported.

    Examples
    --------
    >>> reported_share([(1, 4), (0, 2), (3, 4)])
    {'frames': 2, 'reported': 0.5}
    """
    c = np.asarray(counts, dtype=float).reshape(-1, 2)
    c = c[c[:, 1] >= 3]
    return {"frames": len(c), "reported": float(c[:, 0].sum() / max(c[:, 1].sum(), 1.0))}


def run_robot(data: Path, robot: int, settings: dict[str, Any]) -> dict[str, Any]:
    """One robot's losses of the true place and its frames' reported shares."""
    (stream,) = mrclam_streams(data, (robot,))
    sensor, motion, config = with_settings(*preset("mrclam"), settings)
    est, _ = run_stream(Tracker(stream.landmarks, sensor, motion, config), stream)
    t = np.array([f.t for f in stream.frames])
    truth, gaps = stream.truth_at(t)
    known = (gaps <= MAX_GAP_S) & np.isfinite(truth).all(axis=1)
    share = np.full(t.size, np.nan)
    counts = np.zeros((t.size, 2))  # (tubes in view reported, tubes in view)
    view_model = preset("mrclam")[0]
    for k in np.flatnonzero(known):
        x, y, th = truth[k]
        share[k] = _true_share(est[k], x, y, th)
        view = view_model.visible(stream.landmarks.xy, truth[k])
        got = {j for j in (stream.frames[k].truth or ()) if j is not None}
        counts[k] = (sum(1 for j in got if view[j]), view.sum())
    losses: list[dict[str, Any]] = []
    during: list[int] = []
    # (a frame without a ground truth neither holds nor loses the true place)
    for i, j in find_losses(t, np.nan_to_num(share, nan=0.5)):
        x, y, th = truth[j]
        out = _elsewhere(est[j])
        loss: dict[str, Any] = {"t": float(t[j] - t[0]), "elsewhere": out}
        if out < 0.5 and est[j].hypotheses:
            best = est[j].hypotheses[0].pose
            loss["rival_m"] = math.hypot(best.x - x, best.y - y)
            loss["rival_deg"] = math.degrees(abs(float(wrap(best.theta - th))))
        losses.append(loss)
        during += range(i + 1, j + 1)
    held = np.flatnonzero(share >= 0.5)
    return {
        "robot": robot,
        "losses": losses,
        "during_losses": reported_share(counts[np.asarray(during, dtype=np.int64)]),
        "true_place_held": reported_share(counts[held]),
        "_during": during,
        "_held": held.tolist(),
        "_counts": counts.tolist(),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--robots", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--out", type=Path, default=HERE / "results_track_losses.json")
    args = ap.parse_args(argv)
    settings: dict[str, Any] = {}
    for item in args.set:
        settings.update(_setting(item))
    runs = [run_robot(args.data, r, settings) for r in args.robots]
    all_losses = [loss for r in runs for loss in r["losses"]]
    n_else = sum(1 for loss in all_losses if loss["elsewhere"] >= 0.5)
    pooled: dict[str, dict[str, float]] = {}
    for key, part in (("during_losses", "_during"), ("true_place_held", "_held")):
        pooled[key] = reported_share([r["_counts"][k] for r in runs for k in r[part]])
    for r in runs:
        for key in ("_during", "_held", "_counts"):
            del r[key]
        print(
            f"robot {r['robot']}: {len(r['losses'])} losses "
            + ", ".join(
                f"{x['t']:.1f} s to "
                + (
                    "elsewhere"
                    if x["elsewhere"] >= 0.5
                    else f"a rival {x['rival_m']:.2f} m / {x['rival_deg']:.0f} deg off"
                )
                for x in r["losses"]
            )
        )
    print(
        f"all: {len(all_losses)} losses, {n_else} to elsewhere, {len(all_losses) - n_else} to "
        f"a rival; tubes in view reported (frames with 3 or more in view): during the losses "
        f"{100 * pooled['during_losses']['reported']:.1f} % "
        f"({pooled['during_losses']['frames']} frames), while the true place holds half the "
        f"mass {100 * pooled['true_place_held']['reported']:.1f} % "
        f"({pooled['true_place_held']['frames']} frames)"
    )
    write_results(
        args.out,
        run_meta("track_losses.py", argv, settings=settings),
        runs=runs,
        losses=len(all_losses),
        to_elsewhere=n_else,
        pooled=pooled,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
