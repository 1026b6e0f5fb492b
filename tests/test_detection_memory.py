"""benchmarks/detection_memory.py: each landmark's reports and misses over its run of frames in
view, and the Beta-predictive model of a detection rate learned from them."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from detection_memory import log_likelihood, sightings
from omniloc import LandmarkMap
from omniloc.evaluate.tracking import Segment, Stream
from omniloc.sensor import SensorModel
from omniloc.track import Frame, GroundTruth, Odometry


def test_counts_each_landmarks_reports_and_misses_over_its_run_in_view() -> None:
    # Robot at the origin facing +x, 90-degree camera, 5 m: landmarks 0 and 1 in view, 2
    # behind. Landmark 0 reported in the first two frames and missed in the third, landmark 1
    # never; the fourth frame comes 3 s later: every run starts again.
    lm = LandmarkMap(np.array([[3.0, 0.5], [2.0, -1.0], [-3.0, 0.0]]))
    t = np.array([0.0, 10.0])
    truth = GroundTruth(t, np.zeros(2), np.zeros(2), np.zeros(2))
    frames = [
        Frame(0.5, np.array([0.16, 3.0]), truth=(0, 2)),
        Frame(0.7, np.array([0.16]), truth=(0,)),
        Frame(0.9, np.array([0.4]), truth=(None,)),
        Frame(3.9, np.array([0.16]), truth=(0,)),
    ]
    odo = Odometry(t, np.zeros(2), np.zeros(2))
    stream = Stream("s", lm, odo, frames, (Segment(0.0, 10.0, 0.0, truth, "test"),))
    sensor = SensorModel(sigma=0.01, fov=np.deg2rad(90.0), max_range=5.0)
    # (Landmark 0's sighting, then landmark 1's, frame by frame.)
    first = [(0, 0, True), (0, 0, False)]
    second = [(1, 0, True), (0, 1, False)]
    third = [(2, 0, False), (0, 2, False)]
    after_gap = [(0, 0, True), (0, 0, False)]
    assert sightings([stream], sensor) == first + second + third + after_gap


def test_the_learned_rate_is_the_beta_predictive_and_tends_to_independence() -> None:
    rows = np.array([[0, 0, 1], [1, 0, 1], [2, 0, 0], [0, 3, 0]])
    p, n0 = 0.4, 2.0
    q = [(p * n0 + h) / (n0 + h + m) for h, m, _ in rows]
    want = math.log(q[0]) + math.log(q[1]) + math.log(1 - q[2]) + math.log(1 - q[3])
    assert log_likelihood(rows, p, n0) == pytest.approx(want)
    independent = 2 * math.log(p) + 2 * math.log(1 - p)
    assert log_likelihood(rows, p, math.inf) == pytest.approx(independent)
    assert log_likelihood(rows, p, 1e9) == pytest.approx(independent, abs=1e-6)
