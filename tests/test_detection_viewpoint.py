"""benchmarks/detection_viewpoint.py: the landmarks in view of the true pose with the range and
direction they are seen from, and models of their detection scored on runs left out."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from detection_viewpoint import cell_rates, held_out_gains, log_likelihood, sightings
from omniloc import LandmarkMap
from omniloc.evaluate.tracking import Segment, Stream
from omniloc.sensor import SensorModel
from omniloc.track import Frame, GroundTruth, Odometry


def test_each_landmark_in_view_is_a_row_with_its_range_direction_and_report() -> None:
    # Robot at the origin facing +x, 90-degree camera, 5 m: landmarks 0 and 1 in view, 2
    # behind it. Landmark 0 reported, landmark 1 not.
    lm = LandmarkMap(np.array([[3.0, 0.5], [2.0, -1.0], [-3.0, 0.0]]))
    t = np.array([0.0, 10.0])
    truth = GroundTruth(t, np.zeros(2), np.zeros(2), np.zeros(2))
    frames = [Frame(0.5, np.array([0.16, 3.0]), truth=(0, None))]
    odo = Odometry(t, np.zeros(2), np.zeros(2))
    stream = Stream("s", lm, odo, frames, (Segment(0.0, 10.0, 0.0, truth, "test"),))
    sensor = SensorModel(sigma=0.01, fov=np.deg2rad(90.0), max_range=5.0)
    rows = sightings([stream, stream], sensor)
    assert rows.shape == (4, 5)
    np.testing.assert_allclose(rows[0], [0, 0, math.atan2(-0.5, -3.0), math.hypot(3, 0.5), 1])
    np.testing.assert_allclose(rows[1], [0, 1, math.atan2(1.0, -2.0), math.hypot(2, 1), 0])
    assert rows[2:, 0].tolist() == [1, 1]  # the second stream's index


def test_a_cell_falls_back_on_its_parent_in_proportion_to_how_little_it_was_seen() -> None:
    keys = np.array([[0]] * 90 + [[1]] * 10)
    y = np.r_[np.ones(45), np.zeros(45), np.ones(10)]
    p = cell_rates(keys, y, np.array([[0], [1], [7]]), np.full(3, 0.2), prior=10.0)
    assert p.tolist() == pytest.approx([(45 + 2) / 100, (10 + 2) / 20, 0.2])


def test_a_model_gains_on_runs_left_out_only_where_the_structure_carries_over() -> None:
    """Landmark 0 is reported far more often than landmark 1 on every run (the landmark
    model gains on each run left out); the direction each is seen from is drawn at random
    (the direction model gains nothing over the landmark model)."""
    rng = np.random.default_rng(3)
    n = 4000
    run = rng.integers(0, 4, n)
    lm = rng.integers(0, 2, n)
    direction = rng.uniform(-math.pi, math.pi, n)
    rng_m = rng.uniform(0.5, 6.0, n)
    y = (rng.uniform(size=n) < np.where(lm == 0, 0.7, 0.2)).astype(float)
    rows = np.column_stack([run, lm, direction, rng_m, y])
    g = held_out_gains(rows, sectors=(8,))
    assert all(g["landmark"][f"run {k}"] > 50 for k in range(4))
    assert g["range"]["all"] < 10
    assert g["landmark and direction (8 sectors)"]["all"] < g["landmark"]["all"]
    assert g["landmark"]["per sighting"] == pytest.approx(g["landmark"]["all"] / n)


def test_log_likelihood_of_reports() -> None:
    y = np.array([1.0, 0.0, 0.0])
    assert log_likelihood(np.array([0.5, 0.5, 0.25]), y) == pytest.approx(
        2 * math.log(0.5) + math.log(0.75)
    )
    assert math.isfinite(log_likelihood(np.array([0.0, 1.0, 0.0]), y))
