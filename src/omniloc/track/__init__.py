"""Localization over time: wake up, disambiguate while moving, track, notice a kidnapping.

* :mod:`.data` -- odometry, frames of bearings and ground-truth tracks, and their files;
* :mod:`.records` -- what a localizer over time reports after each frame.
"""

from __future__ import annotations

from .data import Frame, GroundTruth, Odometry, load_frames, load_groundtruth, load_odometry
from .records import Hypothesis, TrackEstimate, TrackState

__all__ = [
    "Frame",
    "GroundTruth",
    "Hypothesis",
    "Odometry",
    "TrackEstimate",
    "TrackState",
    "load_frames",
    "load_groundtruth",
    "load_odometry",
]
