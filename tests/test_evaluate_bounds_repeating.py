"""What the data allow when the bearing errors repeat on each landmark
(omniloc.evaluate.bounds.RepeatingErrors): the information filter carries each landmark's
drifting bias beside the pose."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from omniloc import LandmarkMap, Pose, predict_bearings
from omniloc.errors import InputError
from omniloc.evaluate.bounds import (
    MRCLAM_BEARING_ERRORS,
    MRCLAM_REPEATING,
    BoundSteps,
    RepeatingErrors,
    _Repeating,
    bearing_information,
    bound_steps,
    confident_frames,
    stream_bound,
    times_to_localize,
)
from omniloc.evaluate.tracking import (
    Stream,
    evaluate_tracking,
    mrclam_bound,
    tracking_summary,
    whole_run,
)
from omniloc.pose import bearing_jacobian
from omniloc.track import Frame, MotionModel, Odometry, TrackEstimate, TrackState
from omniloc.track.data import GroundTruth

LANDMARKS = np.array([[3.0, 0.5], [2.5, -1.5], [4.0, 2.0], [-2.0, 3.0]])
INFO = 1 / math.radians(0.5) ** 2


def _steps(frames: list[list[int]], dt: float = 0.25, noise: bool = True) -> BoundSteps:
    """Standing at the origin facing +x, frames of the given landmark rows (with each
    bearing's row and gradient), the heading noise growing with time (no motion noise at
    all without ``noise``)."""
    k = len(frames)
    F = np.tile(np.eye(3), (k, 1, 1))
    N = np.zeros((k, 3, 3))
    if noise:
        N[1:] = np.diag([1e-6, 1e-6, 1e-4 * dt])
    HtH = np.zeros((k, 3, 3))
    grads = []
    for i, rows in enumerate(frames):
        if rows:
            _, G = bearing_jacobian(LANDMARKS[rows], np.zeros(3))
            HtH[i] = G.T @ G
            grads.append(G)
    rows_all = np.array([r for f in frames for r in f], dtype=np.int64)
    G_all = np.concatenate(grads) if grads else np.zeros((0, 3))
    return BoundSteps(
        np.arange(k) * dt, F, N, HtH, np.array([len(r) for r in frames]), rows_all, G_all
    )


def _run(steps: BoundSteps, repeat: RepeatingErrors) -> tuple[np.ndarray, list[list[int]]]:
    """The pose's information at each frame, the filter started at the first, and the
    landmarks whose biases its state holds there."""
    rf = _Repeating(steps, INFO, repeat, 1)
    on = np.ones(1, dtype=bool)
    out, lms = [], []
    for i in range(steps.t.size):
        rf.advance(i, on)
        rf.update(i, on)
        out.append(rf.pose(on)[0])
        lms.append(list(rf.lms))
        assert rf.Y.shape[1:] == (rf.first + len(rf.lms),) * 2
    return np.array(out), lms


def _pose_information(steps: BoundSteps, repeat: RepeatingErrors) -> np.ndarray:
    return _run(steps, repeat)[0]


def test_a_landmark_seen_again_at_once_adds_only_its_independent_part() -> None:
    # Standing still, no motion noise, a bias that never drifts: after n frames of the same
    # three landmarks, each landmark's n bearings are worth one of variance
    # share / info + (1 - share) / (n info) -- the bias is not averaged away.
    repeat = RepeatingErrors(share=0.8, tau_s=1e7)
    n = 12
    st_ = _steps([[0, 1, 2]] * n, noise=False)
    got = _pose_information(st_, repeat)
    _, G = bearing_jacobian(LANDMARKS[[0, 1, 2]], np.zeros(3))
    for k in (1, 4, n):
        var = repeat.share / INFO + (1 - repeat.share) / (k * INFO)
        np.testing.assert_allclose(got[k - 1], G.T @ G / var, rtol=1e-6)
    # Independent errors would have grown it n-fold; here it is less than 1.25-fold.
    indep = n * INFO * G.T @ G
    assert np.linalg.eigvalsh(got[-1] - indep).max() < 0
    assert np.trace(got[-1]) < 1.25 * np.trace(INFO * G.T @ G)


def test_a_bias_half_forgotten_between_two_sightings_counts_by_its_correlation() -> None:
    # Two frames of the same three landmarks, the bias's correlation between them 0.5:
    # each landmark's two errors have variance v = vb + vw and covariance 0.5 vb, so the
    # pair is worth 1' C^-1 1 = 2 / (v + 0.5 vb) times its gradient's outer product.
    dt = 0.25
    repeat = RepeatingErrors(share=0.6, tau_s=dt / math.log(2.0))
    got = _pose_information(_steps([[0, 1, 2]] * 2, dt=dt, noise=False), repeat)
    vb, vw = repeat.share / INFO, (1 - repeat.share) / INFO
    _, G = bearing_jacobian(LANDMARKS[[0, 1, 2]], np.zeros(3))
    np.testing.assert_allclose(got[1], G.T @ G * 2 / (vb + vw + 0.5 * vb), rtol=1e-9)


def test_errors_forgotten_between_frames_are_independent_ones() -> None:
    # A time constant far below the frame period: every frame's biases are new, and each
    # bearing is worth info, as without repeat.
    frames = [[0], [1], [2], [0], [0, 1], [3], [3], [2], [0, 1, 2], [1]]
    st_ = _steps(frames)
    fast = RepeatingErrors(share=0.8, tau_s=1e-6)  # (exp(-dt / tau) underflows to 0)
    indep = confident_frames(st_, INFO, 0.99)
    assert indep.any() and not indep.all()
    assert confident_frames(st_, INFO, 0.99, repeat=fast).tolist() == indep.tolist()
    starts = list(range(len(frames)))
    np.testing.assert_allclose(
        times_to_localize(st_, starts, INFO, 0.99, repeat=fast),
        times_to_localize(st_, starts, INFO, 0.99),
    )
    # A share of 0 (or below MIN_SHARE) is the independent bound itself.
    for share in (0.0, 1e-300, 1e-12):
        none = RepeatingErrors(share=share, tau_s=5.0)
        assert confident_frames(st_, INFO, 0.99, repeat=none).tolist() == indep.tolist()


def _gls_information(frames: list[list[int]], dt: float, repeat: RepeatingErrors) -> np.ndarray:
    """Standing still, no motion noise: the pose's information from every bearing at once,
    ``G^T C^-1 G``, ``C`` the bearings' error covariance written out pair by pair (the
    independent part, the frame's offset, the common bias and each landmark's own, each
    bias correlated by ``exp(-lag / tau)``)."""
    rows = [r for f in frames for r in f]
    when = np.array([i * dt for i, f in enumerate(frames) for _ in f])
    frame = np.array([i for i, f in enumerate(frames) for _ in f])
    _, G = bearing_jacobian(LANDMARKS[rows], np.zeros(3))
    lag = np.abs(when[:, None] - when[None, :])
    same_lm = np.equal.outer(rows, rows)
    assert repeat.common_tau_s is not None
    C = (
        np.eye(len(rows)) * (1 - repeat.share - repeat.common_share - repeat.frame_share)
        + repeat.frame_share * np.equal.outer(frame, frame)
        + repeat.common_share * np.exp(-lag / repeat.common_tau_s)
        + repeat.share * same_lm * np.exp(-lag / repeat.tau_s)
    ) / INFO
    return G.T @ np.linalg.solve(C, G)


@pytest.mark.parametrize(
    "repeat",
    [
        RepeatingErrors(share=0.0, tau_s=1.0, common_share=0.7, common_tau_s=1e7),
        RepeatingErrors(share=0.0, tau_s=1.0, common_share=0.6, common_tau_s=0.8),
        RepeatingErrors(share=0.0, tau_s=1.0, frame_share=0.7),
        RepeatingErrors(share=0.3, tau_s=2.0, common_share=0.3, common_tau_s=0.5, frame_share=0.2),
        RepeatingErrors(share=0.5, tau_s=1.5, frame_share=0.3),
    ],
)
def test_shared_and_own_biases_weigh_the_bearings_as_their_covariance_does(
    repeat: RepeatingErrors,
) -> None:
    # Standing still without motion noise the filter must give, frame after frame, what
    # generalised least squares on all the bearings so far gives (every landmark seen again
    # within five time constants, so none is forgotten).
    frames = [[0, 1], [2], [0, 1, 2], [], [1, 3], [0], [0, 2, 3], [1]]
    dt = 0.25
    got = _pose_information(_steps(frames, dt=dt, noise=False), repeat)
    for k in range(1, len(frames) + 1):
        want = _gls_information(frames[:k], dt, repeat)
        np.testing.assert_allclose(got[k - 1], want, rtol=1e-7, atol=1e-9 * INFO)


def test_a_shared_bias_spares_the_position_and_bounds_the_heading() -> None:
    # One frame of three landmarks, the same total error: with most of it shared, the
    # bearings' differences place the robot far more precisely than independent errors
    # do; the heading, which the shared part moves as a turn of the robot would, cannot be
    # known better than that part.
    st_ = _steps([[0, 1, 2]], noise=False)
    own = _pose_information(st_, RepeatingErrors(share=0.0, tau_s=1.0))[0]
    shared = _pose_information(
        st_, RepeatingErrors(share=0.0, tau_s=1.0, common_share=0.45, frame_share=0.45)
    )[0]
    _, G = bearing_jacobian(LANDMARKS[[0, 1, 2]], np.zeros(3))
    np.testing.assert_allclose(own, INFO * G.T @ G, rtol=1e-9)
    cov_own, cov_shared = np.linalg.inv(own), np.linalg.inv(shared)
    # (Independent errors of a tenth of the variance: the differences as precise as there.)
    sharp = np.linalg.inv(10 * INFO * G.T @ G)
    assert np.trace(cov_shared[:2, :2]) < 0.5 * np.trace(cov_own[:2, :2])
    np.testing.assert_allclose(cov_shared[:2, :2], sharp[:2, :2], rtol=1e-6)
    assert cov_shared[2, 2] >= 0.9 / INFO


def test_a_common_bias_forgotten_between_frames_is_a_frame_offset() -> None:
    frames = [[0], [1, 2], [2], [0, 1, 3], [0, 2], [3], [3], [1]]
    st_ = _steps(frames)
    fast = RepeatingErrors(share=0.3, tau_s=2.0, common_share=0.5, common_tau_s=1e-6)
    frame = RepeatingErrors(share=0.3, tau_s=2.0, frame_share=0.5)
    np.testing.assert_allclose(
        _pose_information(st_, fast), _pose_information(st_, frame), rtol=1e-9, atol=1e-6
    )
    starts = list(range(len(frames)))
    np.testing.assert_allclose(
        times_to_localize(st_, starts, INFO, 0.9, repeat=fast),
        times_to_localize(st_, starts, INFO, 0.9, repeat=frame),
    )


def test_a_landmark_not_seen_for_five_time_constants_leaves_the_state() -> None:
    repeat = RepeatingErrors(share=0.5, tau_s=0.2)
    st_ = _steps([[0], [1], [1], [1], [1], [2]])  # 0.25 s apart: landmark 0 leaves at 1.25 s
    _, seen = _run(st_, repeat)
    assert seen == [[0], [0, 1], [0, 1], [0, 1], [0, 1], [1, 2]]


def _line(n: int = 160, dt: float = 0.25) -> Stream:
    """Driving along x at 0.2 m/s, seeing three landmarks ahead one at a time, in turn."""
    lm = LandmarkMap(np.array([[8.0, 0.0], [9.0, 3.0], [10.0, -2.0], [7.0, 4.0]]))
    t = np.arange(n) * dt
    gt_t = np.arange(-1.0, n * dt + 1.0, 0.1)
    truth = GroundTruth(t=gt_t, x=0.2 * gt_t, y=np.zeros(gt_t.size), theta=np.zeros(gt_t.size))
    frames = [
        Frame(float(tk), predict_bearings(lm.xy[[k % 3]], Pose(0.2 * tk, 0.0, 0.0)), (k % 3,))
        for k, tk in enumerate(t)
    ]
    return whole_run("a", lm, Odometry(t=t, v=np.full(n, 0.2), w=np.zeros(n)), frames, truth)


def test_repeating_errors_slow_the_bound_where_a_robot_sees_landmarks_in_turn() -> None:
    s = _line()
    motion = MotionModel(delay_s=0.0)
    plain = stream_bound(s, motion, INFO, 0.99)
    rep = stream_bound(s, motion, INFO, 0.99, repeat=MRCLAM_REPEATING)
    assert 0.0 < plain.time_to_localize_s < rep.time_to_localize_s < 40.0
    assert rep.correct_after_rate <= plain.correct_after_rate


def test_the_mrclam_evaluation_s_bound_takes_the_tubes_repeating_errors() -> None:
    s = _line()
    motion = MotionModel.mrclam()
    info = bearing_information(*MRCLAM_BEARING_ERRORS)
    assert mrclam_bound()(s) == stream_bound(s, motion, info, 0.99, repeat=MRCLAM_REPEATING)
    assert mrclam_bound(0.9, repeat=None)(s) == stream_bound(s, motion, info, 0.9)
    assert mrclam_bound()(s) != mrclam_bound(repeat=None)(s)


def test_the_evaluation_says_what_its_bound_assumed() -> None:
    class Lost:
        def odometry(self, t: object, v: object, w: object) -> None:
            pass

        def frame(self, t: float, bearings: np.ndarray) -> TrackEstimate:
            return TrackEstimate(t, TrackState.LOST)

    for bound, said in (
        (mrclam_bound(), "68 % of their variance common to every landmark, forgotten over 13.8 s"),
        (mrclam_bound(repeat=None), "independent from frame to frame"),
    ):
        res, _ = evaluate_tracking([_line(40)], lambda lm, p: Lost(), progress=False, bound=bound)
        assert said in res.bound_model and res.as_dict()["bound_model"] == res.bound_model
        line = next(x for x in tracking_summary(res).splitlines() if "what the data allow" in x)
        assert said in line
    # A bound that says nothing of itself is scored all the same, its model unsaid.
    bare, _ = evaluate_tracking(
        [_line(40)], lambda lm, p: Lost(), progress=False, bound=lambda st: mrclam_bound()(st)
    )
    assert bare.bound_model == "" and "what the data allow (a localizer" in tracking_summary(bare)


@pytest.mark.parametrize("mount", [None, (0.3, 0.1, 0.5)])
def test_the_steps_carry_each_bearing_s_landmark_and_gradient(mount: object) -> None:
    lm = LandmarkMap(np.array([[8.0, 0.0], [9.0, 3.0], [10.0, -2.0]]))
    t = np.arange(6) * 0.25
    gt_t = np.arange(-1.0, 3.0, 0.1)
    truth = GroundTruth(t=gt_t, x=0.2 * gt_t, y=np.zeros(gt_t.size), theta=np.zeros(gt_t.size))
    rows = [(0, 1), (), (2,), (1, 0, 2), (None, 1), (0,)]
    frames = [Frame(float(tk), np.zeros(len(r)), r or None) for tk, r in zip(t, rows, strict=True)]
    s = whole_run("a", lm, Odometry(t=t, v=np.full(6, 0.2), w=np.zeros(6)), frames, truth)
    st_ = bound_steps(s, MotionModel(delay_s=0.0), mount)  # type: ignore[arg-type]
    assert st_.rows is not None and st_.G is not None
    assert st_.rows.tolist() == [0, 1, 2, 1, 0, 2, 1, 0]  # the clutter (None) dropped
    off = np.concatenate([[0], np.cumsum(st_.bearings)])
    for i in range(t.size):
        g = st_.G[off[i] : off[i + 1]]
        np.testing.assert_allclose(g.T @ g, st_.HtH[i], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    "share, tau",
    [
        (1.0, 5.0),
        (0.9999999, 5.0),
        (-0.1, 5.0),
        (math.nan, 5.0),
        ("a", 5.0),
        (0.5, 0.0),
        (0.5, -1.0),
        (0.5, math.inf),
        (0.5, math.nan),
        (0.5, 1e8),
    ],
)
def test_repeating_errors_that_are_not_a_model_are_refused(share: object, tau: object) -> None:
    with pytest.raises(InputError, match="RepeatingErrors"):
        RepeatingErrors(share=share, tau_s=tau)  # type: ignore[arg-type]
    # The same values as the shared parts' (the landmarks' own share then 0).
    with pytest.raises(InputError, match="RepeatingErrors"):
        RepeatingErrors(share=0.0, tau_s=1.0, common_share=share, common_tau_s=tau)  # type: ignore[arg-type]
    if isinstance(share, str) or not 0.0 <= share <= 0.999999:  # type: ignore[operator]
        with pytest.raises(InputError, match=r"RepeatingErrors\.frame_share"):
            RepeatingErrors(share=0.0, tau_s=1.0, frame_share=share)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "shares", [(0.5, 0.5, 0.0), (0.4, 0.3, 0.3), (0.0, 0.6, 0.4), (0.9, 0.0, 0.0999999)]
)
def test_shares_that_leave_nothing_independent_are_refused(shares: tuple[float, ...]) -> None:
    with pytest.raises(InputError, match="shares must sum to at most"):
        RepeatingErrors(shares[0], 1.0, common_share=shares[1], frame_share=shares[2])
    # Just inside: accepted, the common time constant the landmarks' when not given.
    ok = RepeatingErrors(shares[0] * 0.99, 1.0, common_share=shares[1] * 0.99)
    assert ok.common_tau_s == 1.0


def test_a_repeat_that_is_not_one_or_steps_without_their_bearings_are_refused() -> None:
    st_ = _steps([[0, 1, 2]])
    with pytest.raises(InputError, match="repeat must be a RepeatingErrors"):
        confident_frames(st_, INFO, 0.99, repeat=0.5)  # type: ignore[arg-type]
    bare = BoundSteps(st_.t, st_.F, st_.N, st_.HtH, st_.bearings)
    with pytest.raises(InputError, match=r"BoundSteps\.rows"):
        times_to_localize(bare, [0], INFO, 0.99, repeat=MRCLAM_REPEATING)
    # Without repeat the bare steps are enough, as before.
    assert confident_frames(bare, INFO, 0.99).tolist() == [True]


def test_mrclam_s_repeating_errors_are_the_benchmark_s_fit() -> None:
    # The constant is benchmarks/bearing_correlation.py's shared-bias fit, as its results
    # file has it: run again with other figures, this says the constant is stale.
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "results_bearing_correlation.json"
    fit = json.loads(path.read_text())["shared_bias"]
    assert MRCLAM_REPEATING.share == pytest.approx(fit["tube_share"], abs=5e-4)
    assert MRCLAM_REPEATING.tau_s == pytest.approx(fit["tube_tau_s"], abs=0.05)
    assert MRCLAM_REPEATING.common_share == pytest.approx(fit["common_share"], abs=5e-4)
    assert MRCLAM_REPEATING.common_tau_s == pytest.approx(fit["common_tau_s"], abs=0.05)
    assert MRCLAM_REPEATING.frame_share == pytest.approx(fit["frame_share"], abs=5e-4)
