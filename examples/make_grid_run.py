"""Write the example recording of ``omniloc demo`` to ``examples/grid-run/``, to try
``omniloc track`` on (the README's "Localization over time" shows the command and its output).

Run:  python examples/make_grid_run.py [--out FOLDER] [--seed S]

Writes ``landmarks.csv`` (the map), ``odometry.csv`` (``t,v,w``), ``frames.csv``
(``t,bearing``, radians, landmark ids not written), ``groundtruth.csv``
(``t,x,y,theta,gap``, at 10 Hz), ``groundtruth.tum`` (the truth at the frames' times in
TUM format, the reference for ``evo_ape tum``) and ``settings.json`` (the sensor and
odometry noise the frames were simulated with, for ``omniloc track --config``). The recording is
:func:`omniloc.track.simulate.example_run`: the same numbers as the demo's, bit for bit.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from omniloc.track import (
    GroundTruth,
    write_frames,
    write_groundtruth,
    write_odometry,
    write_tum_truth,
)
from omniloc.track.simulate import example_run

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=HERE / "grid-run", help="the folder to write")
    ap.add_argument("--seed", type=int, default=9, help="the recording's seed (default 9)")
    args = ap.parse_args(argv)
    ex = example_run(args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    ex.landmarks.to_csv(args.out / "landmarks.csv")
    write_odometry(args.out / "odometry.csv", ex.run.odometry)
    write_frames(args.out / "frames.csv", ex.run.frames)
    # The true track at 10 Hz (the run's own is at the odometry's 50 Hz; scoring interpolates),
    # and from it the truth at the frames' times as TUM: evo_ape's reference for omniloc track
    # --out (what omniloc track --groundtruth groundtruth.csv --truth-out writes).
    tr = ex.run.truth
    truth = GroundTruth(tr.t[::5], tr.x[::5], tr.y[::5], tr.theta[::5])
    write_groundtruth(args.out / "groundtruth.csv", truth)
    write_tum_truth(args.out / "groundtruth.tum", truth, [f.t for f in ex.run.frames])
    s, m = ex.sensor, ex.motion
    settings = {
        "sigma": s.sigma,
        "max_range": s.max_range,
        "p_detect": s.p_detect,
        "clutter": s.clutter,
        **{k: getattr(m, k) for k in ("along_per_m", "across_per_m", "turn_per_rad")},
        **{k: getattr(m, k) for k in ("turn_per_m", "turn_per_s")},
    }
    (args.out / "settings.json").write_text(json.dumps(settings, indent=1) + "\n")
    print(
        f"wrote {args.out}: landmarks, odometry, frames, groundtruth (.csv), groundtruth.tum, "
        "settings.json"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
