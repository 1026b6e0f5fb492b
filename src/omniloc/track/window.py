"""The recent past: frames with the odometry that joins them.

The tracker keeps the frames of the last seconds, each with its *dead-reckoned* pose (the
odometry integrated in a frame of its own, which drifts but is locally exact) and the
relative motion and covariance from the frame before. Two things read it:

* the relocalization (:mod:`.relocalize`) stacks the bearings of the last ~second into the
  current robot frame, for :func:`~omniloc.localize` (which needs one pose for all its
  bearings), and
* the tracker's replay scores new hypotheses on the window, frame by frame from the oldest,
  each bearing predicted from the odometry-predicted pose of its own frame.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..angles import wrap
from .motion import between, compose

__all__ = ["Window", "WindowFrame", "stack_bearings"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class WindowFrame:
    """One frame of the window.

    Attributes
    ----------
    t : float
        Time, seconds.
    bearings : ndarray, shape (m,)
        Radians, robot frame.
    odom : ndarray, shape (3,)
        Dead-reckoned pose (odometry frame: origin where the window began).
    delta : ndarray, shape (3,)
        Motion from the previous frame of the window (robot frame of that frame); zeros for
        the first.
    Q : ndarray, shape (3, 3)
        Covariance of ``delta``.
    turn_rate : float
        The odometry's turn rate on the way to this frame (rad/s; 0 for the first frame of
        the tracker or after a gap).
    """

    t: float
    bearings: FloatArray = field(repr=False)
    odom: FloatArray = field(repr=False)
    delta: FloatArray = field(repr=False)
    Q: FloatArray = field(repr=False)
    turn_rate: float = 0.0


class Window:
    """The frames of the last ``span_s`` seconds, in time order (a FIFO).

    Parameters
    ----------
    span_s : float
        Frames older than this (relative to the newest) are dropped.
    """

    def __init__(self, span_s: float) -> None:
        self.span_s = float(span_s)
        self._frames: deque[WindowFrame] = deque()

    def __len__(self) -> int:
        return len(self._frames)

    def __iter__(self) -> Iterator[WindowFrame]:
        return iter(self._frames)

    def __getitem__(self, k: int) -> WindowFrame:
        return self._frames[k]

    def clear(self) -> None:
        """Forget everything (the odometry that joins the frames was lost)."""
        self._frames.clear()

    def append(
        self,
        t: float,
        bearings: FloatArray,
        delta: FloatArray,
        Q: FloatArray,
        turn_rate: float = 0.0,
    ) -> None:
        """Add a frame reached from the previous one by ``delta`` (covariance ``Q``), the
        robot turning at ``turn_rate`` (rad/s) on the way."""
        if self._frames:
            odom = compose(self._frames[-1].odom, delta)
        else:
            odom = np.zeros(3)
            delta = np.zeros(3)
            Q = np.zeros((3, 3))
        self._frames.append(WindowFrame(float(t), bearings, odom, delta, Q, float(turn_rate)))
        while self._frames and self._frames[0].t < t - self.span_s:
            self._frames.popleft()

    def since(self, t0: float) -> list[WindowFrame]:
        """The frames at or after ``t0``."""
        return [f for f in self._frames if f.t >= t0]


def stack_bearings(
    frames: list[WindowFrame], merge_tol: float
) -> tuple[FloatArray, FloatArray, float, IntArray]:
    """The bearings of several frames in the robot frame of the last one, rotation only,
    with bearings closer than ``merge_tol`` (radians) merged into their mean.

    The translation between the frames is left out (a bearing cannot be moved without the
    landmark's range); the caller widens the noise by the returned travel.

    Returns
    -------
    bearings : ndarray, shape (k,)
        Merged bearings, radians, sorted.
    counts : ndarray, shape (k,)
        How many bearings each merged one stands for.
    travel : float
        Largest distance (m) from a frame's dead-reckoned position to the last one's.
    member : ndarray of int, shape (n,)
        For each of the frames' bearings, in order (frame by frame), the merged bearing it
        went into.
    """
    if not frames:
        return np.zeros(0), np.zeros(0), 0.0, np.zeros(0, dtype=np.int64)
    ref = frames[-1].odom
    parts = []
    travel = 0.0
    for f in frames:
        rel = between(ref, f.odom)
        travel = max(travel, float(np.hypot(rel[0], rel[1])))
        parts.append(f.bearings + rel[2])
    raw = np.asarray(wrap(np.concatenate(parts))) if parts else np.zeros(0)
    if raw.size == 0:
        return raw, np.zeros(0), travel, np.zeros(0, dtype=np.int64)
    order = np.argsort(raw, kind="stable")
    b = raw[order]
    # Greedy chaining of sorted bearings (across the -pi/pi seam too).
    group = np.zeros(b.size, dtype=np.int64)
    for k in range(1, b.size):
        group[k] = group[k - 1] + (b[k] - b[k - 1] > merge_tol)
    n_groups = int(group[-1]) + 1
    if n_groups > 1 and b[0] + 2 * np.pi - b[-1] <= merge_tol:
        last = group == n_groups - 1
        b = np.where(last, b - 2 * np.pi, b)
        group[last] = 0
        n_groups -= 1
    merged = np.array([b[group == g].mean() for g in range(n_groups)])
    counts = np.bincount(group, minlength=n_groups).astype(np.float64)
    merged = np.asarray(wrap(merged))
    by_value = np.argsort(merged, kind="stable")
    rank = np.empty(n_groups, dtype=np.int64)
    rank[by_value] = np.arange(n_groups)
    member = np.empty(raw.size, dtype=np.int64)
    member[order] = rank[group]
    return merged[by_value], counts[by_value], travel, member
