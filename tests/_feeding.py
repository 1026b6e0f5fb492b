"""Feeding a :class:`~omniloc.track.Tracker` a simulated recording by hand, for the tests
that change something between frames (a pose told, a bearing added, a state set)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from omniloc.track import Frame, SimulatedRun, Tracker, TrackEstimate


def first_row(run: SimulatedRun, t: float) -> int:
    """The odometry row at or before time ``t`` (0 before the first): where to start
    feeding a tracker whose first frame is at ``t``."""
    return max(int(np.searchsorted(run.odometry.t, t, side="right")) - 1, 0)


def feed(
    tr: Tracker,
    run: SimulatedRun,
    frames: Sequence[Frame],
    row: int = 0,
    extra: Callable[[float], np.ndarray] | None = None,
) -> list[TrackEstimate]:
    """Feed ``tr`` the run's odometry from row ``row`` on and ``frames``, each with the
    bearings ``extra(t)`` added; its estimates."""
    odo = run.odometry
    out = []
    for f in frames:
        k1 = int(np.searchsorted(odo.t, f.t, side="right"))
        if k1 > row:
            tr.odometry(odo.t[row:k1], odo.v[row:k1], odo.w[row:k1])
        row = k1
        b = f.bearings if extra is None else np.concatenate([f.bearings, extra(f.t)])
        out.append(tr.frame(f.t, b))
    return out
