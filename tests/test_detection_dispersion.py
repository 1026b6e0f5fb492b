"""benchmarks/detection_dispersion.py: the count of landmarks in view and reported per frame,
and its spread against independent detections."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from detection_dispersion import counts_in_view, dispersion
from omniloc import LandmarkMap
from omniloc.evaluate.tracking import Segment, Stream
from omniloc.sensor import SensorModel
from omniloc.track import Frame, GroundTruth, Odometry


def test_independent_detections_have_the_binomials_spread() -> None:
    rng = np.random.default_rng(0)
    k = rng.binomial(8, 0.3, 20_000)
    d = dispersion(8, k.tolist())
    assert d["variance"] == pytest.approx(d["binomial_variance"], rel=0.05)
    assert d["at_most_2"] == pytest.approx(d["binomial_at_most_2"], abs=0.02)


def test_counts_the_landmarks_in_view_of_the_true_pose_and_those_reported() -> None:
    # Robot at the origin facing +x, 90-degree camera, 5 m: landmarks 0 and 1 in view, 2 behind,
    # 3 too far. The frame reports landmark 0, landmark 2 (out of view: not counted) and clutter.
    lm = LandmarkMap(np.array([[3.0, 0.5], [2.0, -1.0], [-3.0, 0.0], [9.0, 0.0]]))
    t = np.array([0.0, 1.0])
    truth = GroundTruth(t, np.zeros(2), np.zeros(2), np.zeros(2))
    frame = Frame(0.5, np.array([0.16, 3.0, 0.4]), truth=(0, 2, None))
    odo = Odometry(t, np.zeros(2), np.zeros(2))
    stream = Stream("s", lm, odo, [frame], (Segment(0.0, 2.0, 0.0, truth, "test"),))
    sensor = SensorModel(sigma=0.01, fov=np.deg2rad(90.0), max_range=5.0)
    assert counts_in_view([stream], sensor) == {2: [1]}
