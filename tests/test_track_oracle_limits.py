"""benchmarks/track_oracle_limits.py: how soon a localizer told the correspondences could
know the pose, along a stream's true trajectory."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import track_oracle_limits as tol  # noqa: E402
from omniloc.pose import bearing_jacobian  # noqa: E402
from omniloc.track.motion import compose_jacobians  # noqa: E402

MRCLAM = Path(__file__).resolve().parents[2] / "shared" / "data" / "mrclam-ds6"


def test_a_gaussian_bearing_is_worth_its_inverse_variance_and_a_mixture_more() -> None:
    assert tol.bearing_information((1.0,), (0.02,)) == pytest.approx(2500.0, rel=1e-6)
    w, s = (0.57, 0.43), (math.radians(0.33), math.radians(1.03))
    info = tol.bearing_information(w, s)
    # Between the wide and the sharp component's, and above the mixture's own variance's.
    assert 1 / s[1] ** 2 < info < 1 / s[0] ** 2
    assert info > 1 / (w[0] * s[0] ** 2 + w[1] * s[1] ** 2)
    with pytest.raises(ValueError):
        tol.bearing_information((1.0,), (0.0,))


def _random_step(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    pose = rng.uniform([-3, -3, -math.pi], [3, 3, math.pi])
    delta = rng.uniform([-0.5, -0.2, -0.4], [0.5, 0.2, 0.4])
    F, Jd = compose_jacobians(pose, delta)
    B = rng.normal(size=(3, 3)) * [[0.05], [0.02], [0.03]]
    return F, Jd @ (B @ B.T) @ Jd.T


@pytest.mark.parametrize("seed", range(5))
def test_the_information_prediction_is_the_kalman_prediction(seed: int) -> None:
    rng = np.random.default_rng(seed)
    F, N = _random_step(rng)
    A = rng.normal(size=(3, 3))
    P = A @ A.T + 0.1 * np.eye(3)
    got = tol.predict_information(np.linalg.inv(P), F, N)
    np.testing.assert_allclose(got, np.linalg.inv(F @ P @ F.T + N), rtol=1e-9, atol=1e-9)
    # A singular information (one bearing's worth) is the limit of a vanishing prior.
    _, G = bearing_jacobian(np.array([[2.0, 1.0]]), np.array([0.0, 0.0, 0.3]))
    Y = 1e4 * G.T @ G
    limit = np.linalg.inv(F @ np.linalg.inv(Y + 1e-9 * np.eye(3)) @ F.T + N)
    np.testing.assert_allclose(tol.predict_information(Y, F, N), limit, rtol=1e-3)
    # Without noise the information is carried: a batch of them at once.
    both = tol.predict_information(np.stack([Y, np.linalg.inv(P)]), F, 0 * N)
    Finv = np.linalg.inv(F)
    np.testing.assert_allclose(both[0], Finv.T @ Y @ Finv, rtol=1e-9, atol=1e-6)


def test_the_probability_is_the_share_of_errors_within_tolerance() -> None:
    rng = np.random.default_rng(1)
    draws = rng.standard_normal((tol.MC_DRAWS, 3))
    cov = np.array([[0.02, 0.012, 0.0005], [0.012, 0.015, -0.0003], [0.0005, -0.0003, 0.002]])
    x = np.random.default_rng(2).multivariate_normal(np.zeros(3), cov, 400_000)
    want = np.mean((np.hypot(x[:, 0], x[:, 1]) <= tol.TOL_M) & (np.abs(x[:, 2]) <= tol.TOL_HEADING))
    got = tol._probability(cov, draws)
    assert 0.2 < want < 0.9 and got == pytest.approx(want, abs=0.005)
    # Tight enough for the bounds to settle it: at least the lower bound, and near 1.
    tight = np.diag([1e-4, 1e-4, 1e-6])
    assert tol._probability(tight, draws) == pytest.approx(1.0, abs=1e-4)


def _steps(frames: list[list[int]], landmarks: np.ndarray, dt: float = 0.25) -> tol.Steps:
    """A robot standing at the origin facing +x, frames of the given landmark rows, the
    odometry's heading noise growing with time."""
    k = len(frames)
    pose = np.zeros(3)
    F = np.tile(np.eye(3), (k, 1, 1))
    N = np.zeros((k, 3, 3))
    N[1:] = np.diag([1e-6, 1e-6, 1e-4 * dt])
    HtH = np.zeros((k, 3, 3))
    for i, rows in enumerate(frames):
        if rows:
            _, G = bearing_jacobian(landmarks[rows], pose)
            HtH[i] = G.T @ G
    nb = np.array([len(r) for r in frames])
    return tol.Steps(np.arange(k) * dt, F, N, HtH, nb)


LANDMARKS = np.array([[3.0, 0.5], [2.5, -1.5], [4.0, 2.0], [-2.0, 3.0]])


def test_three_landmarks_localize_at_once_and_one_never() -> None:
    info = 1 / math.radians(0.5) ** 2
    st = _steps([[0, 1, 2]] * 4 + [[0]] * 8, LANDMARKS)
    got = tol.times_to_localize(st, np.array([0, 4, 10]), info, 0.99)
    assert got[0] == 0.0
    # From frame 4 on, one landmark only: the pose turns about it unseen, never known.
    assert math.isinf(got[1]) and math.isinf(got[2])


def test_three_frames_of_one_landmark_each_are_needed_standing_still() -> None:
    st = _steps([[0], [1], [2], [0], [1], [2]], LANDMARKS)
    # One bearing a frame: the third frame is the first that has seen three landmarks.
    sharp = tol.times_to_localize(st, np.array([0, 1]), 1 / math.radians(0.3) ** 2, 0.99)
    assert sharp[0] == pytest.approx(0.5) and sharp[1] == pytest.approx(0.5)
    # A wider bearing needs a fourth frame at 0.99, not at 0.9; never less than the sharp.
    info = 1 / math.radians(0.5) ** 2
    got = tol.times_to_localize(st, np.array([0, 1]), info, 0.99)
    loose = tol.times_to_localize(st, np.array([0, 1]), info, 0.9)
    assert got[0] == pytest.approx(0.75) and loose[0] == pytest.approx(0.5)
    assert (sharp <= got).all() and (loose <= got).all()


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_the_script_bounds_the_recordings(tmp_path: Path) -> None:
    out = tmp_path / "oracle.json"
    assert tol.main([str(MRCLAM), "--robots", "4", "--every", "60", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["runs"]["robot4"]["frames"] > 1000
    assert len(data["bounds"]) == len(tol.ERROR_MODELS) * len(tol.PROBABILITIES)
    for b in data["bounds"].values():
        first = b["first_from_run_start_s"]["robot4"]
        assert first == b["first_median_s"] and (first is None or first >= 0)
        a = b["from_any_start"]
        assert a["starts"] >= 10 and 0 <= a["within_10_s"] <= a["within_15_s"] <= 1
        assert 0 <= b["confident_after_first"]["robot4"] <= 1
    # The sharper error model never needs longer from the run's start.
    g, m = (data["bounds"][f"{k}, p >= 0.99"] for k in tol.ERROR_MODELS)
    assert m["first_median_s"] <= g["first_median_s"]


def test_the_confident_frames_begin_where_the_first_start_localizes() -> None:
    st = _steps([[0], [1], [2], [0], [0, 1, 2], [3]], LANDMARKS)
    info = 1 / math.radians(0.5) ** 2
    ok = tol.confident_frames(st, info, 0.99)
    (first,) = tol.times_to_localize(st, np.array([0]), info, 0.99)
    assert first == pytest.approx(0.75) and st.t[np.argmax(ok)] == first
    assert ok[3:].all() and not ok[:3].any()
    assert not tol.confident_frames(st, info, 0.99)[:1].any()
    # Nothing but one landmark: never confident.
    assert not tol.confident_frames(_steps([[0]] * 6, LANDMARKS), info, 0.9).any()
