"""One step of a set of hypotheses: the odometry's motion, then one frame.

The tracker and the replay of new hypotheses (:func:`.window.replay`) both move their
hypotheses with :func:`advance` and take frames with :func:`take_frame`, so that a
hypothesis is scored the same way whether it was tracked live or replayed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..sensor import SensorModel
from . import ekf
from .clutter import ClutterMemory, PersistentClutter

__all__ = ["StepRules", "advance", "take_frame"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StepRules:
    """How a frame is taken in (see :func:`.ekf.update` and :mod:`.clutter`).

    Attributes
    ----------
    branches : int
        Rival assignments followed per hypothesis.
    branch_margin : float
        ... within this many nats of its best.
    split : ekf.Split or None
        When vague hypotheses are split.
    clutter : PersistentClutter or None
        How clutter objects persist (None: independent clutter).
    max_rows : int or None
        At most this many hypotheses come out of a frame (the best, by score).
    collapse_chi2 : float
        A hypothesis's children closer than this become one (see :func:`.ekf.update`).
    """

    branches: int = 1
    branch_margin: float = 0.0
    split: ekf.Split | None = None
    clutter: PersistentClutter | None = None
    max_rows: int | None = None
    collapse_chi2: float = 0.0


def advance(
    poses: FloatArray, covs: FloatArray, memory: ClutterMemory, delta: FloatArray, Q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Move the hypotheses by ``delta`` (covariance ``Q``); remembered clutter turns."""
    memory.turn(float(delta[2]))
    return ekf.predict(poses, covs, delta, Q)


def take_frame(
    poses: FloatArray,
    covs: FloatArray,
    memory: ClutterMemory,
    t: float,
    bearings: FloatArray,
    landmarks_xy: FloatArray,
    sensor: SensorModel,
    rules: StepRules,
    score: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, ekf.FrameEvidence]:
    """Update the hypotheses with one frame; ``memory`` follows them (children included).
    ``score`` (the hypotheses' scores so far) ranks the children when there are more than
    ``rules.max_rows``."""
    base = sensor.log_clutter_density()
    clutter_log = None
    if rules.clutter is not None:
        clutter_log = memory.log_density(bearings, t, rules.clutter, base)
    p, P, ev = ekf.update(
        poses,
        covs,
        bearings,
        landmarks_xy,
        sensor,
        branches=rules.branches,
        branch_margin=rules.branch_margin,
        split_rule=rules.split,
        clutter_log=clutter_log,
        prior_score=score,
        max_rows=rules.max_rows,
        collapse_chi2=rules.collapse_chi2,
    )
    memory.take(ev.parent)
    memory.remember(bearings, ev.assignment, t)
    return p, P, ev
