"""Localization over time: wake up, disambiguate while moving, track, notice a kidnapping.

* :class:`Tracker` (:mod:`.tracker`) -- the online localizer: feed it odometry and frames of
  bearings, it reports ``lost``, ``ambiguous`` or ``localized`` after every frame;
* :func:`track` (:mod:`.offline`) -- the same over a whole recording, optionally with a
  second pass backward in time from each sure frame (:mod:`.backward`, ``backward_s``);
* :mod:`.motion` -- the odometry's motion and noise (:class:`MotionModel`); :mod:`.calibrate`
  -- that model fitted to odometry and a ground-truth track (:func:`estimate_motion`), and
  the bearing sensor to frames and the track (:func:`estimate_frame_sensor`), and where it
  sits on the robot (:func:`estimate_mount`);
* :mod:`.likelihood` -- what a frame of bearings says about a set of Gaussian pose
  hypotheses, and how it moves them;
* :mod:`.window`, :mod:`.relocalize` -- the recent frames, and new hypotheses from the
  interpretation tree;
* :mod:`.confidence` -- the tracker's own probability mapped to what recordings measured
  (:func:`fit_confidence`);
* :mod:`.presets` -- tuned parameters (``generic``, ``mrclam``), and single values changed by
  name (:func:`with_settings`);
* :mod:`.data` -- odometry, frames of bearings and ground-truth tracks, and their files;
  :mod:`.io` -- TUM trajectories, JSON lines and recordings written back to files;
  :mod:`.records` -- what a localizer over
  time reports; :mod:`.simulate` -- simulated recordings.

The package is callable: ``omniloc.track(map, odometry, frames, ...)`` is :func:`track`.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from .calibrate import (
    MotionCheck,
    MotionFit,
    MountFit,
    SensorCheck,
    SensorFit,
    check_motion,
    check_sensor,
    estimate_frame_sensor,
    estimate_motion,
    estimate_mount,
)
from .confidence import ConfidenceFit, fit_confidence
from .data import Frame, GroundTruth, Odometry, load_frames, load_groundtruth, load_odometry
from .io import (
    read_tum,
    write_frames,
    write_groundtruth,
    write_json_lines,
    write_odometry,
    write_tum,
    write_tum_truth,
)
from .motion import MotionModel
from .offline import TrackRun, track
from .presets import Preset, load_settings, preset, settings_names, with_settings
from .records import Hypothesis, TrackEstimate, TrackState
from .simulate import SimulatedRun, simulate_run
from .tracker import Tracker, TrackerConfig

__all__ = [
    "ConfidenceFit",
    "Frame",
    "GroundTruth",
    "Hypothesis",
    "MotionCheck",
    "MotionFit",
    "MotionModel",
    "MountFit",
    "Odometry",
    "Preset",
    "SensorCheck",
    "SensorFit",
    "SimulatedRun",
    "TrackEstimate",
    "TrackRun",
    "TrackState",
    "Tracker",
    "TrackerConfig",
    "check_motion",
    "check_sensor",
    "estimate_frame_sensor",
    "estimate_motion",
    "estimate_mount",
    "fit_confidence",
    "load_frames",
    "load_groundtruth",
    "load_odometry",
    "load_settings",
    "preset",
    "read_tum",
    "settings_names",
    "simulate_run",
    "track",
    "with_settings",
    "write_frames",
    "write_groundtruth",
    "write_json_lines",
    "write_odometry",
    "write_tum",
    "write_tum_truth",
]


class _CallablePackage(types.ModuleType):
    """``omniloc.track(...)`` calls :func:`track`: the issue's API, without hiding the
    package (``omniloc.track.Tracker`` still works)."""

    def __call__(self, *args: Any, **kwargs: Any) -> TrackRun:
        return track(*args, **kwargs)


sys.modules[__name__].__class__ = _CallablePackage
