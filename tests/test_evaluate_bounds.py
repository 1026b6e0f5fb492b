"""What the data allow (omniloc.evaluate.bounds): the information filter of a localizer told
the correspondences, along the true path, and its place in the tracking evaluation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc import LandmarkMap, Pose, predict_bearings
from omniloc.errors import InputError
from omniloc.evaluate.bounds import (
    MRCLAM_BEARING_ERRORS,
    BoundSteps,
    StreamBound,
    bearing_information,
    bound_steps,
    confident_frames,
    predict_information,
    stream_bound,
    times_to_localize,
    tolerance_probability,
)
from omniloc.evaluate.tracking import (
    Stream,
    TrackingResult,
    evaluate_tracking,
    segment_of,
    splice,
    tracking_summary,
    whole_run,
)
from omniloc.pose import bearing_jacobian
from omniloc.track import Frame, MotionModel, Odometry, TrackEstimate, TrackState
from omniloc.track.data import GroundTruth
from omniloc.track.motion import compose_jacobians

TOL_H = math.radians(5.0)
LANDMARKS = np.array([[3.0, 0.5], [2.5, -1.5], [4.0, 2.0], [-2.0, 3.0]])


# --- one bearing's information ---------------------------------------------------------------


def test_a_gaussian_bearing_is_worth_its_inverse_variance_and_a_mixture_more() -> None:
    assert bearing_information([1.0], [0.02]) == pytest.approx(2500.0, rel=1e-6)
    w, s = MRCLAM_BEARING_ERRORS
    info = bearing_information(w, s)
    # Between the wide and the sharp component's, above the mixture's own variance's.
    assert 1 / s[1] ** 2 < info < 1 / s[0] ** 2
    assert info > 1 / (w[0] * s[0] ** 2 + w[1] * s[1] ** 2)
    assert math.degrees(info**-0.5) == pytest.approx(0.52, abs=0.005)
    # Shares are normalised; a component of no share changes nothing.
    assert bearing_information([2.0, 0.0], [0.01, 0.5]) == pytest.approx(1e4, rel=1e-6)


@pytest.mark.parametrize(
    "shares, sds",
    [
        ([1.0], [0.0]),
        ([1.0, 1.0], [0.1]),
        ([], []),
        ([-1.0], [0.1]),
        ([0.0], [0.1]),
        ([1.0], [math.nan]),
        (["a"], [0.1]),
        ([1.0], [1e-10]),
        ([1.0], [7.0]),
    ],
)
def test_a_bearing_error_model_that_is_not_one_is_refused(shares: list, sds: list) -> None:
    with pytest.raises(InputError, match="shares and sds"):
        bearing_information(shares, sds)


def test_a_mixture_of_very_different_widths_is_integrated_as_well_as_one() -> None:
    # A component 1e6 times narrower holding a share of 1e-3: its information dominates.
    w, s = [1.0 - 1e-3, 1e-3], [1e-2, 1e-8]
    got = bearing_information(w, s)
    assert got == pytest.approx(1e-3 / 1e-16, rel=0.02)
    assert bearing_information([1.0], [2 * math.pi]) == pytest.approx(1 / (4 * math.pi**2))
    # Shares are relative, however large.
    assert bearing_information([1e300, 1e300], [0.1, 0.2]) == pytest.approx(
        bearing_information([1.0, 1.0], [0.1, 0.2])
    )


# --- the prediction in information form -------------------------------------------------------


def _random_step(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    pose = rng.uniform([-3, -3, -math.pi], [3, 3, math.pi])
    delta = rng.uniform([-0.5, -0.2, -0.4], [0.5, 0.2, 0.4])
    F, Jd = compose_jacobians(pose, delta)
    B = rng.normal(size=(3, 3)) * [[0.05], [0.02], [0.03]]
    return F, Jd @ (B @ B.T) @ Jd.T


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_information_prediction_is_the_kalman_prediction(seed: int) -> None:
    rng = np.random.default_rng(seed)
    F, N = _random_step(rng)
    A = rng.normal(size=(3, 3))
    P = A @ A.T + 0.1 * np.eye(3)
    got = predict_information(np.linalg.inv(P), F, N)
    np.testing.assert_allclose(got, np.linalg.inv(F @ P @ F.T + N), rtol=1e-8, atol=1e-8)
    # Without noise the information is carried over; a batch at once.
    Finv = np.linalg.inv(F)
    both = predict_information(np.stack([np.linalg.inv(P), 2 * np.linalg.inv(P)]), F, 0 * N)
    np.testing.assert_allclose(both[1], 2 * Finv.T @ np.linalg.inv(P) @ Finv, rtol=1e-8)


def test_a_singular_information_is_predicted_as_the_limit_of_a_vanishing_prior() -> None:
    F, N = _random_step(np.random.default_rng(3))
    _, G = bearing_jacobian(np.array([[2.0, 1.0]]), np.array([0.0, 0.0, 0.3]))
    Y = 1e4 * G.T @ G
    got = predict_information(Y, F, N)
    for eps in (1e-7, 1e-9):
        limit = np.linalg.inv(F @ np.linalg.inv(Y + eps * np.eye(3)) @ F.T + N)
        np.testing.assert_allclose(got, limit, rtol=1e-2, atol=1e-6)
    assert np.linalg.matrix_rank(got, tol=1e-6) == 1


# --- the tolerance probability ----------------------------------------------------------------


def test_the_probability_is_the_share_of_errors_within_tolerance() -> None:
    cov = np.array([[0.02, 0.012, 0.0005], [0.012, 0.015, -0.0003], [0.0005, -0.0003, 0.002]])
    x = np.random.default_rng(2).multivariate_normal(np.zeros(3), cov, 400_000)
    want = np.mean((np.hypot(x[:, 0], x[:, 1]) <= 0.3) & (np.abs(x[:, 2]) <= TOL_H))
    assert 0.2 < want < 0.9
    assert tolerance_probability(cov) == pytest.approx(want, abs=0.005)
    # Wider tolerances never give less.
    assert tolerance_probability(cov, 0.5, 2 * TOL_H) > tolerance_probability(cov)
    assert tolerance_probability(np.diag([1e-4, 1e-4, 1e-6])) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize(
    "cov",
    [
        np.eye(2),
        np.full((3, 3), np.nan),
        np.eye(3) * 1e300,
        np.diag([1.0, -1.0, 1.0]),
        np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
        [["a"] * 3] * 3,
    ],
)
def test_a_covariance_that_is_not_one_is_refused(cov: np.ndarray) -> None:
    with pytest.raises(InputError, match="cov"):
        tolerance_probability(cov)


# --- the filter over frames -------------------------------------------------------------------


def _steps(frames: list[list[int]], dt: float = 0.25) -> BoundSteps:
    """Standing at the origin facing +x, frames of the given landmark rows, the heading
    noise growing with time."""
    k = len(frames)
    F = np.tile(np.eye(3), (k, 1, 1))
    N = np.zeros((k, 3, 3))
    N[1:] = np.diag([1e-6, 1e-6, 1e-4 * dt])
    HtH = np.zeros((k, 3, 3))
    for i, rows in enumerate(frames):
        if rows:
            _, G = bearing_jacobian(LANDMARKS[rows], np.zeros(3))
            HtH[i] = G.T @ G
    return BoundSteps(np.arange(k) * dt, F, N, HtH, np.array([len(r) for r in frames]))


def test_three_landmarks_localize_at_once_and_one_never() -> None:
    info = 1 / math.radians(0.5) ** 2
    st_ = _steps([[0, 1, 2]] * 4 + [[0]] * 8)
    got = times_to_localize(st_, [0, 4, 10], info, 0.99)
    assert got[0] == 0.0
    # From frame 4 on, one landmark: the pose may turn about it unseen, never known.
    assert math.isinf(got[1]) and math.isinf(got[2])


def test_three_frames_of_one_landmark_each_are_needed_standing_still() -> None:
    st_ = _steps([[0], [1], [2], [0], [1], [2]])
    sharp = times_to_localize(st_, [0, 1], 1 / math.radians(0.3) ** 2, 0.99)
    assert sharp.tolist() == pytest.approx([0.5, 0.5])
    # A wider bearing needs a fourth frame at 0.99, not at 0.9; never less than the sharp.
    info = 1 / math.radians(0.5) ** 2
    got = times_to_localize(st_, [0, 1], info, 0.99)
    loose = times_to_localize(st_, [0, 1], info, 0.9)
    assert got[0] == pytest.approx(0.75) and loose[0] == pytest.approx(0.5)
    assert (sharp <= got).all() and (loose <= got).all()


def test_the_confident_frames_begin_where_the_first_start_localizes_and_restart() -> None:
    st_ = _steps([[0], [1], [2], [0], [0, 1, 2], [3], [3], [3], [0, 1, 2]])
    info = 1 / math.radians(0.5) ** 2
    ok = confident_frames(st_, info, 0.99)
    (first,) = times_to_localize(st_, [0], info, 0.99)
    assert first == pytest.approx(0.75) and st_.t[np.argmax(ok)] == first
    assert not ok[:3].any() and ok[3:].all()
    # Started afresh at frame 5: three frames of one landmark say nothing until frame 8.
    again = confident_frames(st_, info, 0.99, restarts=[5])
    assert again[:5].tolist() == ok[:5].tolist()
    assert not again[5:8].any() and again[8]


@pytest.mark.parametrize("kw", [{"info": 0.0}, {"info": math.inf}, {"p_min": 1.0}, {"p_min": 0.0}])
def test_an_information_or_a_probability_out_of_range_is_refused(kw: dict) -> None:
    args = {"info": 100.0, "p_min": 0.99, **kw}
    with pytest.raises(InputError, match=r"info|p_min"):
        confident_frames(_steps([[0]]), args["info"], args["p_min"])


def test_a_start_that_is_no_frame_is_refused() -> None:
    with pytest.raises(InputError, match="frame indices"):
        times_to_localize(_steps([[0], [1]]), [2], 100.0, 0.9)


# --- along a stream ---------------------------------------------------------------------------


def _line(name: str, n: int, y: float, truth_rows: bool = True) -> Stream:
    """A robot driving along x at 0.2 m/s at height y, facing +x, seeing the landmarks
    ahead of it one at a time (in turn), four frames a second."""
    lm = LandmarkMap(np.array([[8.0, 0.0], [9.0, 3.0], [10.0, -2.0], [7.0, 4.0]]))
    dt = 0.25
    t = np.arange(n) * dt
    gt_t = np.arange(-1.0, n * dt + 1.0, 0.1)
    truth = GroundTruth(t=gt_t, x=0.2 * gt_t, y=np.full(gt_t.size, y), theta=np.zeros(gt_t.size))
    odo = Odometry(t=t, v=np.full(n, 0.2), w=np.zeros(n))
    frames = []
    for k, tk in enumerate(t):
        row = k % 3
        b = predict_bearings(lm.xy[[row]], Pose(0.2 * tk, y, 0.0))
        frames.append(Frame(float(tk), b, (row,) if truth_rows else None))
    return whole_run(name, lm, odo, frames, truth)


MOTION = MotionModel(delay_s=0.0)


def test_the_steps_follow_the_true_path_and_its_bearings() -> None:
    s = _line("a", 12, 0.0)
    steps = bound_steps(s, MOTION)
    assert steps.t.tolist() == pytest.approx([f.t for f in s.frames])
    assert steps.bearings.tolist() == [1] * 12
    # Straight ahead at 0.2 m/s: the heading moves the position 0.05 m across per frame.
    assert steps.F[1][1, 2] == pytest.approx(0.05)
    assert (np.linalg.eigvalsh(steps.N[1:]) >= -1e-15).all() and steps.N[1:].trace(
        axis1=1, axis2=2
    ).min() > 0
    _, G = bearing_jacobian(s.landmarks.xy[[1]], np.array([0.05, 0.0, 0.0]))
    np.testing.assert_allclose(steps.HtH[1], G.T @ G)


@pytest.mark.parametrize("mount", [(0.3, 0.1, 0.5), (-0.2, 0.25, -2.0)])
def test_a_mounted_sensor_s_bearings_inform_the_robot_pose_through_the_mount(
    mount: tuple[float, float, float],
) -> None:
    # The information about the robot's pose of bearings taken from robot (+) mount: G^T G,
    # G the numerical gradient of those bearings with respect to the robot's pose.
    from omniloc.pose import compose

    s = _line("a", 12, 0.0)
    steps = bound_steps(s, MOTION, mount)
    robot = np.array([0.05, 0.0, 0.0])  # frame 1's true pose; it sees landmark 1
    L = s.landmarks.xy[[1]]

    def bearing(p: np.ndarray) -> np.ndarray:
        return predict_bearings(L, Pose(*compose(p, mount)))

    G = np.zeros((1, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-6
        G[:, k] = (bearing(robot + e) - bearing(robot - e)) / 2e-6
    np.testing.assert_allclose(steps.HtH[1], G.T @ G, rtol=1e-5)
    plain = bound_steps(s, MOTION)
    assert not np.allclose(steps.HtH[1], plain.HtH[1])
    # The motion's steps are the robot's either way; a mount at the origin changes nothing.
    np.testing.assert_array_equal(steps.F, plain.F)
    np.testing.assert_array_equal(bound_steps(s, MOTION, (0.0, 0.0, 0.0)).HtH, plain.HtH)
    with pytest.raises(InputError, match="mount"):
        bound_steps(s, MOTION, (0.1, 0.2))


def test_frames_without_truth_cannot_be_bounded() -> None:
    with pytest.raises(InputError, match="no landmark truth"):
        bound_steps(_line("a", 4, 0.0, truth_rows=False), MOTION)


def test_a_stream_bound_measures_from_its_start_and_from_its_jump() -> None:
    info = 1 / math.radians(0.5) ** 2
    a, b = _line("a", 160, 0.0), _line("b", 160, 1.0)
    plain = stream_bound(a, MOTION, info, 0.99)
    assert 0.0 < plain.time_to_localize_s < 20.0 and math.isnan(plain.recovery_s)
    assert plain.correct_after_rate == 1.0
    # Carried at 20 s to the other line's 5 s: right again after as long as a robot that
    # started there knowing nothing, and nothing from before the jump carries over.
    kid = splice(a, 0.0, 20.0, b, 5.0, 35.0, "a->b")
    jb = stream_bound(kid, MOTION, info, 0.99)
    fresh = stream_bound(segment_of(b, 5.0, 35.0, "b from 5 s"), MOTION, info, 0.99)
    assert jb.time_to_localize_s == plain.time_to_localize_s
    assert 0.0 < jb.recovery_s == pytest.approx(fresh.time_to_localize_s)
    assert 0.5 < jb.correct_after_rate < 1.0  # the frames after the jump, before it is known
    # Never: a localizer told only one landmark's bearings.
    one = _line("c", 40, 0.0)
    one = whole_run(
        "c",
        one.landmarks,
        one.odometry,
        [Frame(f.t, f.bearings[:0], ()) for f in one.frames],
        one.segments[0].truth,
    )
    never = stream_bound(one, MOTION, info, 0.99)
    assert never.time_to_localize_s == math.inf and math.isnan(never.correct_after_rate)


def test_the_evaluation_reports_the_bound_beside_the_localizer() -> None:
    info = 1 / math.radians(0.5) ** 2
    streams = [_line("a", 40, 0.0), _line("b", 40, 1.0)]

    class Lost:
        def odometry(self, t: object, v: object, w: object) -> None:
            pass

        def frame(self, t: float, bearings: np.ndarray) -> TrackEstimate:
            return TrackEstimate(t, TrackState.LOST)

    def bound(s: Stream) -> StreamBound:
        return stream_bound(s, MOTION, info, 0.99)

    res, _ = evaluate_tracking(streams, lambda lm, p: Lost(), progress=False, bound=bound)
    want = [bound(s) for s in streams]
    assert [r.bound_time_to_localize_s for r in res.runs] == [w.time_to_localize_s for w in want]
    tot = res.totals()
    assert tot["bound_time_to_localize_median_s"] == pytest.approx(
        np.median([w.time_to_localize_s for w in want])
    )
    assert tot["bound_correct_after_rate"] == pytest.approx(
        np.mean([w.correct_after_rate for w in want])
    )
    assert math.isnan(tot["bound_recovery_median_s"])  # no kidnapping
    assert "what the data allow" in tracking_summary(res)
    # Without a bound: nothing claimed.
    bare, _ = evaluate_tracking(streams, lambda lm, p: Lost(), progress=False)
    assert math.isnan(bare.totals()["bound_time_to_localize_median_s"])
    assert "what the data allow" not in tracking_summary(bare)
    assert "what the data allow" not in tracking_summary(TrackingResult("x", []))


@pytest.mark.parametrize(
    "kw", [{"tol_m": 0.0}, {"tol_m": math.nan}, {"tol_heading": -1.0}, {"tol_heading": True}]
)
def test_a_tolerance_that_is_not_one_is_refused(kw: dict) -> None:
    with pytest.raises(InputError, match="tol_"):
        confident_frames(_steps([[0]]), 100.0, 0.9, **kw)
    with pytest.raises(InputError, match="tol_"):
        tolerance_probability(np.eye(3), **kw)


@pytest.mark.parametrize(
    "Y, F, N",
    [
        (np.eye(2), np.eye(3), np.eye(3)),
        (np.eye(3), np.zeros((3, 3)), np.eye(3)),
        (np.eye(3), np.eye(3), np.full((3, 3), np.nan)),
    ],
)
def test_a_prediction_of_other_shapes_or_singular_motion_is_refused(
    Y: np.ndarray, F: np.ndarray, N: np.ndarray
) -> None:
    with pytest.raises(InputError, match="predict_information"):
        predict_information(Y, F, N)


def test_restarts_and_starts_that_are_no_indices_are_refused() -> None:
    with pytest.raises(InputError, match="restarts"):
        confident_frames(_steps([[0]]), 100.0, 0.9, restarts=["x"])
    with pytest.raises(InputError, match="starts"):
        times_to_localize(_steps([[0]]), ["x"], 100.0, 0.9)


MRCLAM = Path(__file__).resolve().parents[2] / "shared" / "data" / "mrclam-ds6"
DOCS = Path(__file__).resolve().parents[1] / "docs" / "tracking.md"


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_the_guides_examples_print_what_they_say(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # The guide's two blocks, run one after the other as a reader would: robot 4's bound
    # with independent errors, then its errors' shares fitted and the bound under them;
    # each prints the lines its comments say.
    text = DOCS.read_text()
    start = text.index("How soon could any localizer know where the robot is")
    first = text.index("```python\n", start)
    second = text.index("```python\n", text.index("```\n", first + 10))
    blocks = [text[i + 10 : text.index("```\n", i + 10)] for i in (first, second)]
    assert "fit_shared_biases" in blocks[1]
    monkeypatch.chdir(MRCLAM)
    env: dict[str, object] = {}
    for block, lines in zip(blocks, (1, 2), strict=True):
        said = [ln[2:] for ln in block.splitlines() if ln.startswith("# ")]
        assert len(said) == lines
        exec(compile(block, str(DOCS), "exec"), env)
        assert capsys.readouterr().out.strip().splitlines() == said


def test_draws_of_another_shape_are_refused_and_given_ones_are_used() -> None:
    cov = np.array([[0.02, 0.012, 0.0], [0.012, 0.015, 0.0], [0.0, 0.0, 0.002]])
    for bad in (np.zeros((10, 2)), np.zeros((0, 3)), np.zeros((2, 5, 3)), [[np.nan] * 3]):
        with pytest.raises(InputError, match="draws"):
            tolerance_probability(cov, draws=bad)
    # All draws at the origin: every error within tolerance.
    assert tolerance_probability(cov, draws=np.zeros((7, 3))) == 1.0


def test_a_covariance_without_a_cholesky_factor_gets_its_lower_bound() -> None:
    # No heading error, a round position error: the lower bound is then the probability
    # itself (the circle's), and it is what comes back without a factor to sample with.
    cov = np.diag([0.05, 0.05, 0.0])
    want = 1.0 - math.exp(-0.5 * 0.09 / 0.05)
    assert tolerance_probability(cov) == pytest.approx(want, rel=1e-12)


def _scored(name: str, jump: float, ttl: float, rate: float, recovery: float) -> object:
    from omniloc.evaluate.tracking import RunScore

    nan = math.nan
    return RunScore(
        name, 100.0, 10, 10, nan, nan, 0, 0, nan, nan, jump, nan, nan, 0, 1.0,
        bound_time_to_localize_s=ttl, bound_correct_after_rate=rate, bound_recovery_s=recovery,
    )  # fmt: skip


def test_correct_after_is_given_as_the_runs_mean_and_as_their_frames_pooled() -> None:
    # A short run right in 9 of its 10 frames after its first correct one, a long one in 10
    # of 1,000: the mean of the runs' shares says 45.5 %, their frames pooled 1.9 %; a run
    # never correct counts in neither.
    from dataclasses import replace

    nan = math.nan
    runs = [
        replace(
            _scored(n, nan, nan, nan, nan), correct_after_rate=k / a, n_after=a, n_correct_after=k
        )
        for n, a, k in (("short", 10, 9), ("long", 1000, 10))
    ]
    never = _scored("never", nan, nan, nan, nan)
    tot = TrackingResult("x", [*runs, never]).totals()
    assert tot["correct_after_rate"] == pytest.approx(0.455)
    assert tot["correct_after_pooled_rate"] == pytest.approx(19 / 1010)


def test_the_bounds_totals_are_the_runs_medians_and_mean() -> None:
    runs = [
        _scored("a", math.nan, 30.0, 0.2, math.nan),
        _scored("b", 50.0, 10.0, 0.3, 12.0),
        _scored("c", 50.0, 20.0, 1.0, math.inf),
        _scored("d", 50.0, math.inf, math.nan, 14.0),
    ]
    tot = TrackingResult("x", runs).totals()
    assert tot["bound_time_to_localize_median_s"] == 25.0
    assert tot["bound_time_to_localize_max_s"] == math.inf
    assert tot["bound_correct_after_rate"] == pytest.approx(0.5)  # the mean, as the tracker's
    assert tot["bound_recovery_median_s"] == 14.0  # the stream never back counts as latest
    # One run without its bound: no total claims one.
    part = TrackingResult("x", [*runs, _scored("e", math.nan, math.nan, math.nan, math.nan)])
    assert all(math.isnan(v) for k, v in part.totals().items() if k.startswith("bound_"))


def test_the_mrclam_evaluation_bounds_the_kidnapped_streams_too(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import omniloc.evaluate.tracking as T

    seen: list[object] = []

    def spy(streams: object, make: object, **kw: object) -> tuple[TrackingResult, list]:
        seen.append(kw.get("bound"))
        return TrackingResult("x", []), []

    monkeypatch.setattr(T, "mrclam_streams", lambda path, robots: ["run"])
    monkeypatch.setattr(T, "kidnap_streams", lambda runs, n, rng: (["jump"], ["plain"]))
    monkeypatch.setattr(T, "evaluate_tracking", spy)
    T.evaluate_mrclam_tracking("folder", kidnapped=1, progress=False)
    assert len(seen) == 2 and all(callable(b) for b in seen)
