from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from omniloc.errors import DegenerateGeometryError, InputError
from omniloc.pose import (
    Pose,
    bearing_jacobian,
    crlb,
    estimate_pose,
    fisher_information,
    predict_bearings,
    refine_pose,
)

coord = st.floats(min_value=-20, max_value=20, allow_nan=False)


@st.composite
def scenes(draw: st.DrawFn, n_min: int = 3, n_max: int = 8) -> tuple[np.ndarray, Pose]:
    """Well-conditioned random geometry: landmarks spread round the robot, not too close."""
    n = draw(st.integers(n_min, n_max))
    x, y = draw(coord), draw(coord)
    theta = draw(st.floats(-np.pi, np.pi, exclude_max=True))
    # Landmarks at spread-out azimuths and moderate ranges.
    base = draw(st.floats(0, 2 * np.pi))
    jitter = draw(st.lists(st.floats(-0.3, 0.3), min_size=n, max_size=n))
    ranges = draw(st.lists(st.floats(1.0, 30.0), min_size=n, max_size=n))
    az = base + 2 * np.pi * np.arange(n) / n + np.array(jitter) * (2 * np.pi / n)
    r = np.array(ranges)
    L = np.stack([x + r * np.cos(az), y + r * np.sin(az)], axis=1)
    return L, Pose(x, y, theta)


def _well_conditioned(L: np.ndarray, p: Pose) -> bool:
    try:
        C = crlb(L, p, 1.0)
    except DegenerateGeometryError:
        return False
    return bool(np.sqrt(C[0, 0] + C[1, 1]) < 1e3)


@settings(max_examples=200, deadline=None)
@given(scenes())
def test_exact_recovery_zero_noise(scene: tuple[np.ndarray, Pose]) -> None:
    L, p = scene
    assume(_well_conditioned(L, p))
    est = estimate_pose(L, predict_bearings(L, p))
    assert abs(est.x - p.x) < 1e-9 and abs(est.y - p.y) < 1e-9
    assert abs(np.angle(np.exp(1j * (est.theta - p.theta)))) < 1e-9


@settings(max_examples=100, deadline=None)
@given(scenes(n_min=4), st.randoms(use_true_random=False))
def test_invariant_to_pair_order(scene: tuple[np.ndarray, Pose], rnd: object) -> None:
    L, p = scene
    assume(_well_conditioned(L, p))
    z = predict_bearings(L, p) + np.linspace(-1e-3, 1e-3, len(L))
    perm = np.arange(len(L))
    rnd.shuffle(perm)  # type: ignore[attr-defined]
    a, _ = refine_pose(L, z)
    b, _ = refine_pose(L[perm], z[perm])
    assert np.allclose(a.as_array()[:2], b.as_array()[:2], atol=1e-6)
    assert abs(np.angle(np.exp(1j * (a.theta - b.theta)))) < 1e-6


@settings(max_examples=100, deadline=None)
@given(scenes(), st.floats(-np.pi, np.pi), coord, coord)
def test_invariant_to_rigid_motion(
    scene: tuple[np.ndarray, Pose], rot: float, tx: float, ty: float
) -> None:
    L, p = scene
    assume(_well_conditioned(L, p))
    z = predict_bearings(L, p)
    c, s = np.cos(rot), np.sin(rot)
    R = np.array([[c, -s], [s, c]])
    L2 = L @ R.T + [tx, ty]
    est = estimate_pose(L2, z)  # same bearings: the robot moved with the world
    xy = R @ [p.x, p.y] + [tx, ty]
    assert np.allclose([est.x, est.y], xy, atol=1e-7)
    assert abs(np.angle(np.exp(1j * (est.theta - (p.theta + rot))))) < 1e-9


@settings(max_examples=100, deadline=None)
@given(scenes(n_min=4), st.integers(0, 2**32 - 1))
def test_refinement_never_worse_than_linear(scene: tuple[np.ndarray, Pose], seed: int) -> None:
    L, p = scene
    assume(_well_conditioned(L, p))
    z = predict_bearings(L, p) + np.random.default_rng(seed).normal(0, np.deg2rad(1), len(L))
    try:
        lin = estimate_pose(L, z)
    except DegenerateGeometryError:
        return
    ref, cov = refine_pose(L, z, lin)

    def rms(q: Pose) -> float:
        r = np.angle(np.exp(1j * (predict_bearings(L, q) - z)))
        return float(np.sqrt(np.mean(r**2)))

    assert rms(ref) <= rms(lin) + 1e-15
    assert cov.shape == (3, 3)


def test_refinement_reaches_crlb_statistically() -> None:
    rng = np.random.default_rng(0)
    L = np.array([[0, 0], [10, 0], [10, 8], [0, 8], [5, -3], [12, 4], [-2, 5], [6, 11]], float)
    p = Pose(4.0, 3.0, 0.5)
    sig = np.deg2rad(1.0)
    errs, lin_errs = [], []
    for _ in range(400):
        z = predict_bearings(L, p) + rng.normal(0, sig, len(L))
        errs.append(refine_pose(L, z, sigma=sig)[0].xy - p.xy)
        lin_errs.append(estimate_pose(L, z).xy - p.xy)
    rmse = np.sqrt(np.mean(np.sum(np.square(errs), axis=1)))
    bound = np.sqrt(np.trace(crlb(L, p, sig)[:2, :2]))
    assert bound * 0.85 < rmse < bound * 1.15
    assert np.sqrt(np.mean(np.sum(np.square(lin_errs), axis=1))) >= rmse * 0.99


def test_covariance_matches_crlb_at_truth() -> None:
    L = np.array([[0, 0], [10, 0], [10, 8], [0, 8]], float)
    p = Pose(4.0, 3.0, 0.5)
    z = predict_bearings(L, p)
    _, cov = refine_pose(L, z, sigma=0.01)
    assert np.allclose(cov, crlb(L, p, 0.01), rtol=1e-6)
    J = fisher_information(L, p, 0.01)
    assert np.allclose(J @ cov, np.eye(3), atol=1e-6)


def test_covariance_unknown_with_three_pairs_and_no_sigma() -> None:
    L = np.array([[0, 0], [10, 0], [0, 8]], float)
    _, cov = refine_pose(L, predict_bearings(L, Pose(3, 3, 0)))
    assert np.isnan(cov).all()


def test_three_landmarks_exact() -> None:
    L = np.array([[0, 0], [10, 0], [0, 8]], float)
    p = Pose(3, 2, 1.0)
    assert np.allclose(estimate_pose(L, predict_bearings(L, p)).as_array(), p.as_array())


@pytest.mark.parametrize(
    ("L", "b", "match"),
    [
        ([[0, 0], [0, 0], [1, 1]], [0.1, 0.2, 0.3], "landmarks 0 and 1 coincide"),
        ([[0, 0], [1, 0], [2, 0]], [0.0, 0.0, 0.0], "singular"),
        # Bearings of three landmarks round a triangle given in the wrong rotation sense.
        ([[0, 0], [4, 0], [0, 4]], [0.0, 1.0, 2.0], "distance ratio r_2"),
    ],
)
def test_degenerate_geometry(L: list, b: list, match: str) -> None:
    with pytest.raises(DegenerateGeometryError, match=match):
        estimate_pose(L, b)


def test_degenerate_is_value_error() -> None:
    assert issubclass(DegenerateGeometryError, ValueError)


def test_robot_on_circle_is_singular() -> None:
    # Robot on the circle through three landmarks: the classic danger circle.
    a = np.array([0.3, 1.9, 4.0])
    L = np.stack([np.cos(a), np.sin(a)], axis=1) * 5.0
    p = Pose(5.0 * np.cos(2.8), 5.0 * np.sin(2.8), 0.0)
    with pytest.raises(DegenerateGeometryError):
        estimate_pose(L, predict_bearings(L, p))


@pytest.mark.parametrize(
    ("L", "b", "match"),
    [
        ([[0, 0], [1, 0]], [0.1, 0.2], "at least 3 pairs"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [0.1, 0.2, 0.3], r"shape \(N, 2\)"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2], "3 landmarks but 2 bearings"),
        ([[0, 0], [1, np.nan], [0, 1]], [0.1, 0.2, 0.3], "landmark 1 has a non-finite"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, np.inf, 0.3], "bearing 1 is not finite"),
        ([[0, 0], [1, 0], [0, 1]], [[0.1, 0.2, 0.3]], r"shape \(N,\)"),
        ("abc", [0.1], "numeric"),
    ],
)
def test_bad_input(L: object, b: object, match: str) -> None:
    with pytest.raises(InputError, match=match):
        estimate_pose(L, b)  # type: ignore[arg-type]


def test_pose_validation_and_helpers() -> None:
    p = Pose(1, 2, 4.0)
    assert -np.pi <= p.theta < np.pi
    assert Pose.from_array(p.as_array()) == p
    with pytest.raises(InputError, match="finite"):
        Pose(np.nan, 0, 0)
    with pytest.raises(InputError, match="shape"):
        Pose.from_array([1, 2])
    with pytest.raises(InputError, match="sigma"):
        crlb([[0, 0], [1, 0], [0, 1]], p, 0.0)
    with pytest.raises(DegenerateGeometryError):
        crlb([[0, 0], [1, 0]], p, 0.1)


def test_crlb_at_a_landmark_names_it() -> None:
    with pytest.raises(DegenerateGeometryError, match="coincides with landmark 1"):
        crlb([[0, 0], [1, 0], [0, 1]], Pose(1.0, 0.0, 0.0), 0.01)


@settings(max_examples=40, deadline=None)
@given(
    st.floats(-3, 3), st.floats(-3, 3), st.floats(-np.pi, np.pi),
    st.floats(-5, 5), st.floats(-5, 5),
)  # fmt: skip
def test_bearing_jacobian_is_the_derivative_of_the_bearing(x, y, th, lx, ly) -> None:
    assume(np.hypot(lx - x, ly - y) > 0.1)
    pose, lm = np.array([x, y, th]), np.array([[lx, ly]])
    h, g = bearing_jacobian(lm, pose)
    assert h[0] == pytest.approx(np.arctan2(ly - y, lx - x) - th)
    eps = 1e-6
    for i in range(3):
        dp = np.zeros(3)
        dp[i] = eps
        num = np.angle(
            np.exp(1j * (bearing_jacobian(lm, pose + dp)[0] - bearing_jacobian(lm, pose - dp)[0]))
        )
        assert g[0, i] == pytest.approx(num[0] / (2 * eps), rel=1e-4, abs=1e-6)
