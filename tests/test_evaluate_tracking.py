"""Scoring of localizers over time (omniloc.evaluate.tracking): the calibration of the
strongest hypothesis's weight, measured beside success."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

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


def _at(t: float, ahead: float, left: float, P: np.ndarray, dtheta: float = 0.0) -> TrackEstimate:
    """Localized ``ahead`` m along the true heading and ``left`` m to its left."""
    c, s = math.cos(TRUE.theta), math.sin(TRUE.theta)
    pose = Pose(TRUE.x + ahead * c - left * s, TRUE.y + ahead * s + left * c, TRUE.theta + dtheta)
    return TrackEstimate(t, TrackState.LOCALIZED, pose=pose, covariance=P)


def test_the_position_error_is_split_along_and_across_the_heading() -> None:
    from omniloc.evaluate.tracking import tracking_summary

    stream = _stream(5)
    P = np.eye(3) * 1.0
    est = [
        _at(0.0, -0.10, 0.02, P),
        _at(1.0, -0.20, 0.02, P),
        _at(2.0, -0.30, -0.01, P),
        _ambiguous(3.0, Pose(TRUE.x + 5.0, TRUE.y, TRUE.theta), 0.5),  # not localized
        TrackEstimate(4.0, TrackState.LOST),
    ]
    r = score_run(stream, est)
    assert r.along_mean_m == pytest.approx(-0.2)
    assert r.along_rmse_m == pytest.approx(math.sqrt((0.01 + 0.04 + 0.09) / 3))
    assert r.across_mean_m == pytest.approx(0.01)
    assert r.across_rmse_m == pytest.approx(math.sqrt((0.0004 + 0.0004 + 0.0001) / 3))
    # Pooled over runs by their localized frames: a run of one frame ahead by 0.4 m.
    one = score_run(_stream(1), [_at(0.0, 0.4, 0.0, P)])
    tot = TrackingResult("x", [r, one]).totals()
    assert tot["along_mean_m"] == pytest.approx((-0.6 + 0.4) / 4)
    assert tot["along_rmse_m"] == pytest.approx(math.sqrt((0.14 + 0.16) / 4))
    assert tot["across_mean_m"] == pytest.approx(0.03 / 4)
    text = tracking_summary(TrackingResult("x", [r]))
    assert "along the robot's heading: mean -0.200 m (ahead +)" in text
    assert "across it: mean +0.010 m (left +)" in text
    # Nothing localized: no mean, no line.
    none = score_run(_stream(2), [TrackEstimate(float(k), TrackState.LOST) for k in range(2)])
    assert math.isnan(none.along_mean_m) and math.isnan(none.across_rmse_m)
    assert "along the robot's heading" not in tracking_summary(TrackingResult("x", [none]))


def test_the_covariance_is_scored_by_its_position_block_and_its_heading_apart() -> None:
    from omniloc.evaluate.tracking import CHI2_1DOF_99, CHI2_2DOF_99, tracking_summary

    assert CHI2_2DOF_99 == pytest.approx(9.21034, abs=1e-5)
    assert CHI2_1DOF_99 == pytest.approx(6.63490, abs=1e-5)
    stream = _stream(6)
    small = np.eye(3) * 0.01**2
    # Correlated x and y: the position's NEES is that of the 2 x 2 block, e' P_xy^-1 e.
    corr = np.array([[4.0, 3.0, 0.0], [3.0, 4.0, 0.0], [0.0, 0.0, 1.0]]) * 0.01**2
    est = [
        _at(0.0, 0.04, 0.0, small),  # position 16 sd^2 off: outside; heading exact
        _at(1.0, 0.0, 0.0, small, dtheta=0.04),  # heading 16: outside; position exact
        _at(2.0, 0.02, 0.0, small, dtheta=0.02),  # both 4: inside both, and the whole
        TrackEstimate(
            3.0,
            TrackState.LOCALIZED,
            pose=Pose(TRUE.x + 0.05, TRUE.y + 0.05, TRUE.theta),
            covariance=corr,
        ),
        # Between the quantiles: the position 10 sd^2 off (outside 9.21 with 2 degrees of
        # freedom, inside 11.34 with 3), the heading 8 (outside 6.63 with 1, inside 9.21).
        _at(4.0, 0.01 * math.sqrt(10.0), 0.0, small),
        _at(5.0, 0.0, 0.0, small, dtheta=0.01 * math.sqrt(8.0)),
    ]
    r = score_run(stream, est)
    # The last: e = (0.05, 0.05) along the correlation's long axis, variance 7e-4 there:
    # NEES 2 * 0.05^2 / 7e-4 = 7.14, inside; against the diagonal alone it would be 12.5.
    assert r.cov_frames == 6
    assert (r.cov_position_inside_99, r.cov_heading_inside_99) == (4, 4)
    assert r.cov_inside_99 == 4  # the whole pose: 16, 16 (> 11.34), 8, 7.14, 10 and 8
    tot = TrackingResult("x", [r]).totals()
    assert tot["cov_position_inside_99_rate"] == pytest.approx(4 / 6)
    assert tot["cov_heading_inside_99_rate"] == pytest.approx(4 / 6)
    text = tracking_summary(TrackingResult("x", [r]))
    assert "the position alone inside the 99 % region of its block in 66.7 %" in text
    assert "the heading alone in 66.7 %" in text


def test_without_localized_frames_the_covariance_is_not_scored() -> None:
    from omniloc.evaluate.tracking import tracking_summary

    stream = _stream(3)
    r = score_run(stream, [_ambiguous(float(k), TRUE, 0.9) for k in range(3)])
    assert r.cov_frames == 0
    tot = TrackingResult("x", [r]).totals()
    assert math.isnan(tot["cov_inside_50_rate"]) and math.isnan(tot["cov_inside_99_rate"])
    assert "reported covariance" not in tracking_summary(TrackingResult("x", [r]))


@given(
    st.lists(st.floats(0.0, 1e4), min_size=1, max_size=12),
    st.integers(0, 12),
)
def test_a_run_that_never_got_there_counts_as_later_than_any_that_did(
    times: list[float], n_never: int
) -> None:
    from omniloc.evaluate.tracking import censored_median

    # All got there: the plain median.
    assert censored_median(times) == pytest.approx(float(np.median(times)))
    with_never = times + [math.nan] * n_never
    m = censored_median(with_never)
    # Never below the median of those that did; "never" once half of the runs never did.
    assert m >= float(np.median(times)) - 1e-9
    # (The middle one, or the upper of the middle two, is a run that never got there.)
    assert (m == math.inf) == (len(with_never) // 2 >= len(times))
    # inf and NaN both mean never.
    assert censored_median(times + [math.inf] * n_never) == m


def test_the_median_of_no_runs_is_not_a_number() -> None:
    from omniloc.evaluate.tracking import censored_median

    assert math.isnan(censored_median([]))
    assert censored_median([math.nan]) == math.inf


def test_medians_count_the_runs_that_never_got_there() -> None:
    """A localizer that fails on two runs of five must not look faster than one that
    localizes every run a little later (the medians over the runs that got there are
    reported beside, under their own names)."""
    from dataclasses import replace

    from omniloc.evaluate.tracking import tracking_summary

    stream = _stream(4)
    base = score_run(stream, [_ambiguous(float(k), TRUE, 0.5) for k in range(4)])
    times = [138.0, 150.0, 658.0, math.nan, math.nan]
    runs = [replace(base, name=f"r{i}", time_to_localize_s=t) for i, t in enumerate(times)]
    tot = TrackingResult("pf", runs).totals()
    assert tot["time_to_localize_median_s"] == 658.0
    assert tot["time_to_localize_median_localized_s"] == 150.0
    assert tot["never_localized"] == 2
    always = [replace(r, time_to_localize_s=435.0) for r in runs]
    assert TrackingResult("t", always).totals()["time_to_localize_median_s"] < 658.0
    # Three of five never: the median is never, said as such.
    runs[2] = replace(runs[2], time_to_localize_s=math.nan)
    res = TrackingResult("pf", runs)
    assert res.totals()["time_to_localize_median_s"] == math.inf
    text = tracking_summary(res)
    said = "time to localize median never, never on 3 of 5 runs; the 2 localized: median 144.0 s"
    assert said in text


def test_recovery_and_detection_medians_count_the_streams_never_recovered() -> None:
    from dataclasses import replace

    stream = _stream(4)
    base = score_run(stream, [_ambiguous(float(k), TRUE, 0.5) for k in range(4)])
    jumps = [
        replace(base, name=f"k{i}", jump_t=1.0, detection_delay_s=d, recovery_s=r)
        for i, (d, r) in enumerate([(0.3, 20.0), (0.5, math.nan), (math.nan, math.nan)])
    ]
    tot = TrackingResult("t", jumps).totals(True)
    assert tot["recovery_median_s"] == math.inf
    assert tot["recovery_median_recovered_s"] == 20.0
    assert tot["unrecovered"] == 2
    assert tot["detection_delay_median_s"] == 0.5
    assert tot["detection_delay_median_detected_s"] == pytest.approx(0.4)
    assert tot["undetected"] == 1


def test_the_seed_spread_says_never_for_a_median_that_never_came() -> None:
    from dataclasses import replace

    from omniloc.evaluate.tracking import TrackingReport, seed_spread, seed_spread_table

    stream = _stream(4)
    base = score_run(stream, [_ambiguous(float(k), TRUE, 0.5) for k in range(4)])
    late = [replace(base, name=f"r{i}", time_to_localize_s=t) for i, t in enumerate([5.0, 9.0])]
    never = [replace(r, time_to_localize_s=math.nan) for r in late]
    reports = {0: late, 1: never}
    spread = seed_spread({k: TrackingReport(TrackingResult("t", v)) for k, v in reports.items()})
    first = spread["first correct, median"]
    assert first["by_seed"] == {0: 7.0, 1: math.inf}
    assert (first["min"], first["max"]) == (7.0, math.inf)
    row = next(r for r in seed_spread_table(spread).splitlines() if r.startswith("| first correct"))
    assert row == "| first correct, median (s) | 7.0 | never | 7.0-never |"


@pytest.mark.parametrize("bad", [["a", 1.0], [[1.0, 2.0]], {1.0}, [10**400]])
def test_the_censored_median_names_times_it_cannot_read(bad: object) -> None:
    from omniloc.errors import InputError
    from omniloc.evaluate.tracking import censored_median

    with pytest.raises(InputError, match="censored_median: times must be"):
        censored_median(bad)  # type: ignore[arg-type]


def _kidnapped_stream() -> Stream:
    """Frames at t = 0..9; at t = 5 the stream jumps from TRUE to a pose 3 m away."""
    from dataclasses import replace as _replace

    from omniloc.evaluate.tracking import splice

    a = _stream(5)
    far = Pose(TRUE.x + 3.0, TRUE.y, TRUE.theta)
    t = a.segments[0].truth.t
    b_truth = GroundTruth(
        t=t, x=np.full(t.size, far.x), y=np.full(t.size, far.y), theta=np.full(t.size, far.theta)
    )
    b = _replace(a, segments=(_replace(a.segments[0], truth=b_truth),))
    return splice(a, 0.0, 5.0, b, 0.0, 5.0, "k")


def _flagged_run(localized_before: bool, flag_at: float | None) -> list[TrackEstimate]:
    out = []
    for k in range(10):
        t = float(k)
        e = _localized(t, 0.0, 0.01) if k < 5 and localized_before else _ambiguous(t, TRUE, 0.5)
        if flag_at is not None and t == flag_at:
            e = TrackEstimate(t, TrackState.LOST, kidnapped=True)
        out.append(e)
    return out


def test_the_flag_delay_is_read_where_there_was_a_place_to_leave() -> None:
    from omniloc.evaluate.tracking import tracking_summary

    stream = _kidnapped_stream()
    assert stream.jump_t == 5.0
    flagged = score_run(stream, _flagged_run(True, 7.0))
    assert flagged.flag_delay_s == 2.0 and flagged.false_alarms == 0
    never = score_run(stream, _flagged_run(True, None))
    assert never.flag_delay_s == math.inf
    # Not localized on the last frame before the jump: no place to leave, nothing to read.
    assert math.isnan(score_run(stream, _flagged_run(False, 7.0)).flag_delay_s)
    # A flag before the jump is a false alarm, not the kidnapping's flag.
    early = score_run(stream, _flagged_run(True, 3.0))
    assert early.false_alarms == 1 and early.flag_delay_s == math.inf
    # A stream without a jump has no flag delay.
    assert math.isnan(score_run(_stream(10), _flagged_run(True, 7.0)).flag_delay_s)
    res = TrackingResult("t", [flagged, never, score_run(stream, _flagged_run(False, None))])
    tot = res.totals(True)
    assert tot["localized_at_jump"] == 2 and tot["kidnaps_flagged"] == 1
    assert tot["flag_delay_median_s"] == math.inf  # half of them never flagged
    assert tot["flag_delay_median_flagged_s"] == 2.0
    from omniloc.evaluate.tracking import TrackingReport

    text = tracking_summary(TrackingReport(TrackingResult("w", [flagged]), res))
    assert "localized when carried off in 2: the kidnapping flagged in 1, a median of 2.0 s" in text


def test_a_false_alarm_that_left_a_wrong_place_is_counted_apart() -> None:
    from omniloc.evaluate.tracking import TrackingReport, tracking_summary

    stream = _stream(10)

    def run(dx: float) -> list[TrackEstimate]:
        # Localized 0-4 at dx from the truth, flagged at 6 (lost), ambiguous otherwise.
        out = [_localized(float(k), dx, 0.01) for k in range(5)]
        out += [_ambiguous(5.0, TRUE, 0.5), TrackEstimate(6.0, TrackState.LOST, kidnapped=True)]
        return out + [_ambiguous(float(k), TRUE, 0.5) for k in range(7, 10)]

    right = score_run(stream, run(0.0))  # the place it left was right: a false alarm proper
    wrong = score_run(stream, run(2.0))  # the place it left was 2 m off
    assert right.false_alarms == wrong.false_alarms == 1
    assert right.false_alarms_left_right == 1 and wrong.false_alarms_left_right == 0
    quiet = score_run(stream, [_ambiguous(float(k), TRUE, 0.5) for k in range(10)])
    res = TrackingResult("t", [right, wrong, quiet, quiet])
    tot = res.totals(False)
    assert tot["false_alarm_run_rate"] == 0.5
    assert tot["false_alarm_left_right_run_rate"] == 0.25
    text = tracking_summary(TrackingReport(TrackingResult("w", [right]), res))
    assert "false alarm on 50.0 % of runs (leaving a place that was right: 25.0 %" in text
