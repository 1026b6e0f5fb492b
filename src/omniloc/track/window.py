"""The recent past: frames with the odometry that joins them.

The tracker keeps the frames of the last seconds, each with its *dead-reckoned* pose (the
odometry integrated in a frame of its own, which drifts but is locally exact) and the
relative motion and covariance from the frame before. Two things read it:

* the relocalization (:mod:`.relocalize`) stacks the bearings of the last ~second into the
  current robot frame, for :func:`~omniloc.localize` (which needs one pose for all its
  bearings), and
* the replay (:func:`replay`) scores new hypotheses on the window, frame by frame backwards
  from the current one, each bearing predicted from the odometry-predicted pose of its own
  frame.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..angles import wrap
from ..sensor import SensorModel
from .clutter import ClutterMemory
from .motion import between, compose, inverse
from .step import StepRules, advance, take_frame

__all__ = ["Replayed", "Window", "WindowFrame", "replay", "stack_bearings"]

FloatArray = NDArray[np.float64]


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
    """

    t: float
    bearings: FloatArray = field(repr=False)
    odom: FloatArray = field(repr=False)
    delta: FloatArray = field(repr=False)
    Q: FloatArray = field(repr=False)


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

    def append(self, t: float, bearings: FloatArray, delta: FloatArray, Q: FloatArray) -> None:
        """Add a frame reached from the previous one by ``delta`` (covariance ``Q``)."""
        if self._frames:
            odom = compose(self._frames[-1].odom, delta)
        else:
            odom = np.zeros(3)
            delta = np.zeros(3)
            Q = np.zeros((3, 3))
        self._frames.append(WindowFrame(float(t), bearings, odom, delta, Q))
        while self._frames and self._frames[0].t < t - self.span_s:
            self._frames.popleft()

    def since(self, t0: float) -> list[WindowFrame]:
        """The frames at or after ``t0``."""
        return [f for f in self._frames if f.t >= t0]


def stack_bearings(
    frames: list[WindowFrame], merge_tol: float
) -> tuple[FloatArray, FloatArray, float]:
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
    """
    if not frames:
        return np.zeros(0), np.zeros(0), 0.0
    ref = frames[-1].odom
    parts = []
    travel = 0.0
    for f in frames:
        rel = between(ref, f.odom)
        travel = max(travel, float(np.hypot(rel[0], rel[1])))
        parts.append(f.bearings + rel[2])
    b = np.concatenate(parts) if parts else np.zeros(0)
    if b.size == 0:
        return b, np.zeros(0), travel
    b = np.sort(np.asarray(wrap(b)))
    # Greedy chaining of sorted bearings (across the -pi/pi seam too).
    groups: list[list[float]] = [[float(b[0])]]
    for x in b[1:]:
        if x - groups[-1][-1] <= merge_tol:
            groups[-1].append(float(x))
        else:
            groups.append([float(x)])
    if len(groups) > 1 and b[0] + 2 * np.pi - groups[-1][-1] <= merge_tol:
        groups[0] = [x - 2 * np.pi for x in groups.pop()] + groups[0]
    merged = np.array([np.mean(g) for g in groups])
    merged = np.asarray(wrap(merged))
    counts = np.array([len(g) for g in groups], dtype=np.float64)
    order = np.argsort(merged)
    return merged[order], counts[order], travel


@dataclass(frozen=True)
class Replayed:
    """Candidates scored on the window (one row per candidate kept).

    Attributes
    ----------
    poses, covs : ndarray, shapes (C, 3) and (C, 3, 3)
        At the last frame, after taking it in.
    score : ndarray, shape (C,)
        Sum of the frames' log-likelihood ratios, with the tracker's forgetting and
        weight.
    matched : ndarray of int, shape (C,)
        Bearings matched over the window.
    memory : ClutterMemory
        The clutter each saw in the last frame.
    source : ndarray of int, shape (C,)
        The input candidate of each row.
    """

    poses: FloatArray
    covs: FloatArray
    score: FloatArray
    matched: NDArray[np.int64]
    memory: ClutterMemory
    source: NDArray[np.int64]


def _inverse_motion(delta: FloatArray, Q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The motion back along ``delta`` and its covariance (first order)."""
    c, s = np.cos(delta[2]), np.sin(delta[2])
    dx, dy = delta[0], delta[1]
    J = np.array([[-c, -s, s * dx - c * dy], [s, -c, c * dx + s * dy], [0.0, 0.0, -1.0]])
    return inverse(delta), J @ Q @ J.T


def replay(
    poses: FloatArray,
    covs: FloatArray,
    frames: list[WindowFrame],
    landmarks_xy: FloatArray,
    sensor: SensorModel,
    rules: StepRules,
    *,
    decay_per_s: float = 0.0,
    weight: float = 1.0,
) -> Replayed:
    """Score candidate poses of the LAST frame on the frames before it.

    Each candidate first takes in the last frame (:func:`.step.take_frame`: that is the
    hypothesis the tracker will go on with), then a copy of it is filtered *backwards*
    through the window, frame by frame (:func:`.step.advance` with the inverse of the
    odometry's motion, so that every bearing is predicted from its own frame's pose and
    the uncertainty grows into the past, as it should: the candidate is known now, from the
    search). The backward predictive log-likelihoods sum to the likelihood of the window's
    frames given the candidate, with the tracker's forgetting (older frames count less),
    which makes a new hypothesis comparable to the ones already tracked.

    Parameters
    ----------
    poses, covs : ndarray, shapes (C, 3) and (C, 3, 3)
        Candidate poses at the last frame and their covariances.
    frames : list of WindowFrame
        The window, in time order, ending with the current frame.
    landmarks_xy : ndarray, shape (N, 2)
    sensor : SensorModel
    rules : StepRules
    decay_per_s : float
        Forgetting rate of the score (1 / memory), as the tracker applies it.
    weight : float
        Factor on each frame's log-likelihood ratio, as the tracker applies it.

    Returns
    -------
    Replayed
    """
    C = poses.shape[0]
    memory = ClutterMemory(C)
    if C == 0 or not frames:
        return Replayed(poses, covs, np.zeros(C), np.zeros(C, dtype=np.int64), memory, np.arange(C))
    rules = replace(rules, max_rows=None)  # every candidate keeps its children here
    last = frames[-1]
    p, P, ev = take_frame(poses, covs, memory, last.t, last.bearings, landmarks_xy, sensor, rules)
    # The hypotheses to go on with: each candidate's best reading of the current frame.
    keep = _best_per_root(ev.parent, ev.loglik, 1)
    source = ev.parent[keep]
    now_p, now_c = p[keep], P[keep]
    memory.take(keep)
    n = keep.size
    score = weight * ev.loglik[keep]
    matched = ev.matched[keep].astype(np.int64)
    # Backwards through the window (a copy: the memory of the past is not the tracker's).
    back = ClutterMemory(n)
    back.bearings, back.t = memory.bearings.copy(), memory.t.copy()
    bp, bP = now_p.copy(), now_c.copy()
    broot = np.arange(n)
    bscore = np.zeros(n)
    bmatched = np.zeros(n, dtype=np.int64)
    later = last
    for f in reversed(frames[:-1]):
        d_inv, Q_inv = _inverse_motion(later.delta, later.Q)
        bp, bP = advance(bp, bP, back, d_inv, Q_inv)
        bp, bP, ev = take_frame(bp, bP, back, f.t, f.bearings, landmarks_xy, sensor, rules)
        age = last.t - f.t
        bscore = bscore[ev.parent] + weight * np.exp(-decay_per_s * age) * ev.loglik
        bmatched = bmatched[ev.parent] + ev.matched
        broot = broot[ev.parent]
        later = f
        if broot.size > n:
            k = _best_per_root(broot, bscore, rules.branches)
            bp, bP, bscore, bmatched, broot = bp[k], bP[k], bscore[k], bmatched[k], broot[k]
            back.take(k)
    k = _best_per_root(broot, bscore, 1)
    score[broot[k]] += bscore[k]
    matched[broot[k]] += bmatched[k]
    return Replayed(now_p, now_c, score, matched, memory, source)


def _best_per_root(root: NDArray[np.int64], score: FloatArray, k: int) -> NDArray[np.int64]:
    """Indices of the ``k`` best scores of each root, in root order."""
    order = np.lexsort((-score, root))
    r = root[order]
    start = np.concatenate([[0], np.flatnonzero(np.diff(r)) + 1])
    rank = np.arange(r.size) - np.repeat(start, np.diff(np.concatenate([start, [r.size]])))
    return np.asarray(order[rank < k])
