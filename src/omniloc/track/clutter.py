"""Persistent clutter: what a hypothesis called clutter is likely to be seen again.

The :class:`~omniloc.sensor.SensorModel` spreads clutter uniformly over the field of view,
independently from frame to frame. Real clutter is often an *object* -- another robot, a
person, a pillar not on the map -- seen in frame after frame at a bearing that moves
smoothly. Scored as independent clutter, such an object hands a wrong hypothesis that
explains it as a landmark the full match-versus-clutter ratio (~3-4 nats on MRCLAM) in every
frame, and after a second a wrong pose out-scores the right one, which calls it clutter.

So each hypothesis remembers the bearings it called clutter in the last ``memory_s``
seconds (robot frame, turned with the odometry's rotation since). In the next frame a bearing
near one of them is scored, *for that hypothesis*, with the uniform clutter density plus the
density of that object seen again, ``p_again * N(nu; 0, s^2)`` with ``s = sd + rate * age``
(the object and the robot move; the nearest remembered bearing counts). A hypothesis
that called the object a landmark has no such memory: for it the object's bearing is a
landmark match, or new clutter. The first sighting of an object still favours a pose that
explains it; the ones after it no longer pile up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..angles import wrap

__all__ = ["ClutterMemory", "PersistentClutter"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Bearings remembered per hypothesis.
SLOTS = 8


@dataclass(frozen=True)
class PersistentClutter:
    """How clutter objects persist.

    Parameters
    ----------
    p_again : float
        Probability that a clutter object seen in a frame is seen in the next.
    sd : float
        Spread of its bearing from one frame to the next at ``dt = 0``, radians.
    rate : float
        Growth of that spread with the time between the frames, rad/s.
    memory_s : float
        Clutter bearings older than this are forgotten, seconds.
    """

    p_again: float = 0.7
    sd: float = float(np.deg2rad(1.5))
    rate: float = float(np.deg2rad(4.0))
    memory_s: float = 1.0


class ClutterMemory:
    """The clutter bearings each hypothesis saw recently (arrays of H rows).

    Attributes
    ----------
    bearings : ndarray, shape (H, SLOTS)
        Robot-frame bearings at the last frame's pose (NaN: empty slot).
    t : ndarray, shape (H, SLOTS)
        When each was last seen.
    """

    def __init__(self, n: int = 0) -> None:
        self.bearings = np.full((n, SLOTS), np.nan)
        self.t = np.full((n, SLOTS), -np.inf)

    def __len__(self) -> int:
        return int(self.bearings.shape[0])

    def take(self, idx: IntArray | NDArray[np.bool_]) -> None:
        """Keep rows ``idx`` (the hypotheses kept, or each child's parent)."""
        self.bearings = self.bearings[idx]
        self.t = self.t[idx]

    def extend(self, n: int) -> None:
        """Add ``n`` new hypotheses with no memory."""
        self.bearings = np.concatenate([self.bearings, np.full((n, SLOTS), np.nan)])
        self.t = np.concatenate([self.t, np.full((n, SLOTS), -np.inf)])

    def turn(self, dtheta: float) -> None:
        """The robot turned by ``dtheta``: remembered bearings turn the other way."""
        self.bearings = np.asarray(wrap(self.bearings - dtheta))

    def log_density(
        self, bearings: FloatArray, t: float, rule: PersistentClutter, base: float
    ) -> FloatArray:
        """ln of the clutter density of each bearing for each hypothesis, (H, m): ``base``
        (the sensor's uniform clutter, ln per radian) plus an object seen again."""
        H = len(self)
        m = bearings.size
        out = np.full((H, m), base)
        if H == 0 or m == 0:
            return out
        age = t - self.t
        live = np.isfinite(self.bearings) & (age <= rule.memory_s)
        if not live.any():
            return out
        s = rule.sd + rule.rate * np.maximum(age, 0.0)
        d = np.asarray(wrap(bearings[None, :, None] - self.bearings[:, None, :]))
        with np.errstate(invalid="ignore"):
            dens = (
                math.log(rule.p_again)
                - 0.5 * (d / s[:, None, :]) ** 2
                - np.log(math.sqrt(2 * math.pi) * s[:, None, :])
            )
        dens = np.where(live[:, None, :], dens, -np.inf)
        return np.asarray(np.logaddexp(out, dens.max(axis=2)))

    def remember(self, bearings: FloatArray, assignment: IntArray, t: float) -> None:
        """Store the bearings each hypothesis left as clutter in this frame (each replaces
        the nearest remembered one, or the oldest slot)."""
        for i in range(assignment.shape[1]):
            rows = np.flatnonzero(assignment[:, i] < 0)
            if rows.size == 0:
                continue
            b = bearings[i]
            d = np.abs(np.asarray(wrap(self.bearings[rows] - b)))
            d = np.where(np.isfinite(d), d, np.inf)
            near = np.argmin(d, axis=1)
            oldest = np.argmin(self.t[rows], axis=1)
            slot = np.where(d[np.arange(rows.size), near] < np.deg2rad(10.0), near, oldest)
            self.bearings[rows, slot] = b
            self.t[rows, slot] = t
