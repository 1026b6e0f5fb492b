"""omniloc: absolute localization of a mobile robot from unlabelled landmark bearings.

A robot that wakes up lost sees point landmarks (vertical edges, poles, reflectors) at some
bearings, without knowing which landmark is which. omniloc searches the interpretation tree of
Lee & Chung for the correspondences and the pose together, with the pose from bearings of
Betke & Gurvits, and adds what real sensors need: spurious and missed detections, noise-aware
gating, ordering and visibility constraints, ambiguity reporting, and a vision front end.

>>> import numpy as np, omniloc
>>> room = omniloc.demo_room()
>>> truth = omniloc.Pose(5.6, 2.1, np.deg2rad(30))
>>> z = omniloc.predict_bearings(room.xy[[10, 3, 0, 6, 8]], truth)
>>> result = omniloc.localize(room, z)
>>> best = result.best
>>> round(best.pose.x, 3), round(best.pose.y, 3), room.ids_of(best.assignment)
(5.6, 2.1, [11, 4, 1, 7, 9])
"""

from __future__ import annotations

import logging

from .angles import angdiff, wrap
from .errors import (
    DegenerateGeometryError,
    InputError,
    MapError,
    ObservationError,
    OmnilocError,
    VisionError,
)
from .io import check_bearings, load_bearings, save_bearings
from .maps import LandmarkMap, as_landmark_map
from .pose import (
    Pose,
    bearing_jacobian,
    crlb,
    estimate_pose,
    fisher_information,
    pose_covariance,
    predict_bearings,
    refine_pose,
)
from .search import (
    Budget,
    LocalizationResult,
    Method,
    SearchStats,
    Solution,
    Solutions,
    Strategy,
    localize,
)
from .sensor import SensorModel
from .simulate import demo_room, grid_map, observe, random_map, random_pose, symmetric_map

__version__ = "0.1.0"

__all__ = [
    "Budget",
    "DegenerateGeometryError",
    "InputError",
    "LandmarkMap",
    "LocalizationResult",
    "MapError",
    "Method",
    "ObservationError",
    "OmnilocError",
    "Pose",
    "SearchStats",
    "SensorModel",
    "Solution",
    "Solutions",
    "Strategy",
    "VisionError",
    "__version__",
    "angdiff",
    "as_landmark_map",
    "bearing_jacobian",
    "check_bearings",
    "crlb",
    "demo_room",
    "estimate_pose",
    "fisher_information",
    "grid_map",
    "load_bearings",
    "localize",
    "observe",
    "pose_covariance",
    "predict_bearings",
    "random_map",
    "random_pose",
    "refine_pose",
    "save_bearings",
    "symmetric_map",
    "wrap",
]

logging.getLogger(__name__).addHandler(logging.NullHandler())
