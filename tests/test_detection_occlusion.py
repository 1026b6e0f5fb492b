"""benchmarks/detection_occlusion.py: how far each sighting's line of sight passes beside the
nearer landmarks, and the occlusion model's width fitted to the reports."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from detection_occlusion import fit, sightings
from omniloc import LandmarkMap
from omniloc.evaluate.tracking import Segment, Stream
from omniloc.sensor import SensorModel
from omniloc.track import Frame, GroundTruth, Odometry


def test_each_sighting_has_the_offsets_of_the_nearer_landmarks_in_view() -> None:
    # Robot at the origin facing +x, 90-degree camera, 6 m: landmark 1 stands 1 cm beside
    # the line of sight over landmark 0 (0.5 cm at landmark 0's 2 m), landmark 2 in view
    # and clear, landmark 3 behind the robot (no sighting, no occluder). The frame reports 0
    # and 2.
    lm = LandmarkMap(np.array([[2.0, 0.0], [4.0, 0.01], [3.0, 1.0], [-1.0, 0.0]]))
    t = np.array([0.0, 1.0])
    truth = GroundTruth(t, np.zeros(2), np.zeros(2), np.zeros(2))
    frame = Frame(0.5, np.array([0.0, 0.32]), truth=(0, 2))
    odo = Odometry(t, np.zeros(2), np.zeros(2))
    stream = Stream("s", lm, odo, [frame], (Segment(0.0, 1.0, 0.0, truth, "test"),))
    sensor = SensorModel(sigma=0.01, fov=np.deg2rad(90.0), max_range=6.0)
    offsets, seen = sightings([stream], sensor)
    assert seen.tolist() == [True, False, True]
    assert offsets[0].size == 0  # the nearest has nothing in front of it
    sep = math.atan2(0.01, 4.0)
    assert sorted(offsets[1]) == pytest.approx(
        sorted([2.0 * sep, math.hypot(3.0, 1.0) * (math.atan2(1.0, 3.0) - sep)])
    )
    assert offsets[2] == pytest.approx([2.0 * math.atan2(1.0, 3.0)])


def test_the_fit_finds_the_width_the_reports_were_drawn_with() -> None:
    rng = np.random.default_rng(3)
    n = 40_000
    offsets = [rng.uniform(0.0, 0.3, rng.integers(0, 3)) for _ in range(n)]
    w, p = 0.04, 0.4
    factor = np.array([np.prod(-np.expm1(-0.5 * (o / w) ** 2)) for o in offsets])
    seen = rng.random(n) < p * factor
    fits = {r["width_m"]: r for r in (fit(offsets, seen, x) for x in (0.0, 0.02, 0.04, 0.06))}
    best = max(fits.values(), key=lambda r: r["log_likelihood"])
    assert best["width_m"] == 0.04
    assert best["p_detect"] == pytest.approx(p, rel=0.03)
    assert fits[0.0]["p_detect"] == pytest.approx(seen.mean())
