"""Scoring of localizers over time (omniloc.evaluate.tracking): the calibration of the
strongest hypothesis's weight, measured beside success."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from omniloc import LandmarkMap, Pose
from omniloc.evaluate.tracking import Stream, TrackingResult, score_run, weight_ece, whole_run
from omniloc.track import Frame, Odometry, TrackState
from omniloc.track.data import GroundTruth
from omniloc.track.records import Hypothesis, TrackEstimate

TRUE = Pose(1.0, 2.0, 0.3)


def _stream(n: int) -> Stream:
    t = np.arange(n, dtype=float)
    truth = GroundTruth(
        t=np.arange(-1.0, n + 1.0, 0.1),
        x=np.full(10 * (n + 2), TRUE.x),
        y=np.full(10 * (n + 2), TRUE.y),
        theta=np.full(10 * (n + 2), TRUE.theta),
    )
    odo = Odometry(t=t, v=np.zeros(n), w=np.zeros(n))
    frames = [Frame(float(k), np.array([0.1])) for k in t]
    lm = LandmarkMap(np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]]))
    return whole_run("s", lm, odo, frames, truth)


def _ambiguous(t: float, pose: Pose, weight: float) -> TrackEstimate:
    hyps = (Hypothesis(pose, np.eye(3) * 1e-4, weight), Hypothesis(Pose(9, 9, 0), np.eye(3), 0.01))
    return TrackEstimate(t, TrackState.AMBIGUOUS, pose=pose, covariance=np.eye(3), hypotheses=hyps)


def test_the_strongest_hypothesis_weight_is_scored_against_the_truth() -> None:
    stream = _stream(12)
    wrong = Pose(4.0, 2.0, 0.3)
    est = [_ambiguous(float(k), TRUE if k < 5 else wrong, 0.95) for k in range(10)]
    est += [TrackEstimate(10.0, TrackState.LOST), _ambiguous(11.0, TRUE, 0.15)]
    r = score_run(stream, est)
    assert r.weight_bins[9] == (10, pytest.approx(9.5), 5)
    assert r.weight_bins[1] == (1, pytest.approx(0.15), 1)
    assert sum(b[0] for b in r.weight_bins) == 11  # the lost frame has no weight to score
    # Half right at 0.95, right at 0.15: (|9.5 - 5| + |0.15 - 1|) / 11.
    tot = TrackingResult("x", [r, r]).totals()
    assert tot["best_weight_frames"] == 22
    assert math.isclose(tot["best_weight_ece"], (4.5 + 0.85) / 11)


def test_weight_ece_of_nothing_is_not_a_number() -> None:
    assert math.isnan(weight_ece([(0, 0.0, 0)] * 10))
    assert weight_ece([(4, 2.0, 2)]) == 0.0


def test_runs_csv_has_the_weight_calibration_as_plain_columns(tmp_path: Path) -> None:
    import csv

    stream = _stream(4)
    est = [_ambiguous(float(k), TRUE, 0.95) for k in range(4)]
    TrackingResult("x", [score_run(stream, est)]).to_csv(tmp_path / "runs.csv")
    with open(tmp_path / "runs.csv", newline="") as fh:
        (row,) = list(csv.DictReader(fh))
    assert "weight_bins" not in row
    assert int(row["best_weight_frames"]) == 4
    assert math.isclose(float(row["best_weight_ece"]), 0.05)


def test_the_summary_says_never_for_a_run_never_localized() -> None:
    from omniloc.evaluate.tracking import tracking_summary

    stream = _stream(4)
    right = [
        TrackEstimate(float(k), TrackState.LOCALIZED, pose=TRUE, covariance=np.eye(3) * 1e-4)
        for k in range(4)
    ]
    never = [_ambiguous(float(k), TRUE, 0.5) for k in range(4)]
    text = tracking_summary(
        TrackingResult("tracker", [score_run(stream, right), score_run(stream, never)])
    )
    assert "nan" not in text
    rows = text.splitlines()[2:4]
    assert "never" in rows[1] and "never" not in rows[0]
    assert len(rows[0]) == len(rows[1])  # the columns stay aligned
    assert "never on 1 of 2 runs" in text


def _localized(t: float, dx: float, sd: float, dtheta: float = 0.0) -> TrackEstimate:
    pose = Pose(TRUE.x + dx, TRUE.y, TRUE.theta + dtheta)
    return TrackEstimate(t, TrackState.LOCALIZED, pose=pose, covariance=np.eye(3) * sd**2)


def test_the_reported_covariance_is_scored_against_the_truth() -> None:
    from omniloc.evaluate.tracking import CHI2_3DOF_50, CHI2_3DOF_99, tracking_summary

    assert CHI2_3DOF_50 == pytest.approx(2.36597, abs=1e-5)
    assert CHI2_3DOF_99 == pytest.approx(11.3449, abs=1e-4)
    stream = _stream(8)
    est = [
        _localized(0.0, 0.01, 0.01),  # NEES 1: inside both regions
        _localized(1.0, 0.02, 0.01),  # 4: inside the 99 % region only
        _localized(2.0, 0.04, 0.01),  # 16: outside both
        # A heading error across the seam: 2 pi + 0.01 off is 0.01 off (NEES 1).
        _localized(3.0, 0.0, 0.01, dtheta=2 * math.pi + 0.01),
        TrackEstimate(4.0, TrackState.LOCALIZED, pose=TRUE),  # no covariance: not scored
        TrackEstimate(  # not positive definite: not scored
            5.0, TrackState.LOCALIZED, pose=TRUE, covariance=-np.eye(3)
        ),
        _ambiguous(6.0, Pose(TRUE.x + 1.0, TRUE.y, TRUE.theta), 0.5),  # not localized
        TrackEstimate(7.0, TrackState.LOST),
    ]
    r = score_run(stream, est)
    assert (r.cov_frames, r.cov_inside_50, r.cov_inside_99) == (4, 2, 3)
    tot = TrackingResult("x", [r, score_run(stream, est[:1] + est[1:])]).totals()
    assert tot["cov_frames"] == 8
    assert tot["cov_inside_50_rate"] == pytest.approx(0.5)
    assert tot["cov_inside_99_rate"] == pytest.approx(0.75)
    text = tracking_summary(TrackingResult("x", [r]))
    assert "over 4 localized frames: the truth inside its 50 % region in 50.0 %" in text
    assert "99 % region in 75.0 %" in text


def test_without_localized_frames_the_covariance_is_not_scored() -> None:
    from omniloc.evaluate.tracking import tracking_summary

    stream = _stream(3)
    r = score_run(stream, [_ambiguous(float(k), TRUE, 0.9) for k in range(3)])
    assert r.cov_frames == 0
    tot = TrackingResult("x", [r]).totals()
    assert math.isnan(tot["cov_inside_50_rate"]) and math.isnan(tot["cov_inside_99_rate"])
    assert "reported covariance" not in tracking_summary(TrackingResult("x", [r]))
