"""Hypotheses as EKFs: bearing Jacobian, update, association, collapse, split, merge."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc._kernels import track as _kernels
from omniloc.pose import predict_bearings
from omniloc.sensor import SensorModel
from omniloc.simulate import demo_room
from omniloc.track import ekf
from omniloc.track.motion import MotionModel, integrate

SENSOR = SensorModel(sigma=np.deg2rad(0.5), p_detect=0.8, clutter=0.5)


def test_bearing_jacobian_matches_finite_differences() -> None:
    L = demo_room().xy
    pose = np.array([[5.6, 2.1, 0.5]])
    cov = np.eye(3)[None]
    _, pred, _, S = ekf._geometry(pose, cov, L, 0.0)
    # S = g g^T with P = I: compare g from finite differences of predict_bearings
    eps = 1e-6
    g = np.zeros((L.shape[0], 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = eps
        hi = predict_bearings(L, pose[0] + e)
        lo = predict_bearings(L, pose[0] - e)
        g[:, k] = np.angle(np.exp(1j * (hi - lo))) / (2 * eps)
    assert np.allclose(S[0], (g * g).sum(axis=1), rtol=1e-5)
    assert np.allclose(pred[0], predict_bearings(L, pose[0]), atol=1e-12)


def test_update_recovers_the_pose_and_matches_a_linear_kalman_update() -> None:
    L = demo_room().xy
    truth = np.array([5.6, 2.1, np.deg2rad(30)])
    z = predict_bearings(L[:6], truth)
    prior = truth + np.array([0.05, -0.03, np.deg2rad(0.5)])
    P = np.diag([0.05**2, 0.05**2, np.deg2rad(1.0) ** 2])
    p, C, ev = ekf.update(prior[None], P[None], z, L, SENSOR)
    assert ev.assignment[0].tolist() == list(range(6))
    # the MAP of prior and noise-free bearings: far closer to the truth than the prior
    assert np.hypot(*(p[0, :2] - truth[:2])) < 0.25 * np.hypot(0.05, 0.03)
    # one Gauss-Newton step of the information form is the linear Kalman update
    p1, C1 = _kernels.iekf_update(prior[None], P[None], L, z, ev.assignment, SENSOR.noise**2, 1)
    _, pred, _, _ = ekf._geometry(prior[None], P[None], L[:6], 0.0)
    dx = L[:6, 0] - prior[0]
    dy = L[:6, 1] - prior[1]
    r2 = dx * dx + dy * dy
    H = np.stack([dy / r2, -dx / r2, -np.ones(6)], axis=1)
    R = SENSOR.noise**2 * np.eye(6)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    nu = np.angle(np.exp(1j * (z - pred[0])))
    assert np.allclose(p1[0], prior + K @ nu, atol=1e-9)
    # ... and its covariance is the inverse information at the updated pose
    dx = L[:6, 0] - p1[0, 0]
    dy = L[:6, 1] - p1[0, 1]
    r2 = dx * dx + dy * dy
    H1 = np.stack([dy / r2, -dx / r2, -np.ones(6)], axis=1)
    info = np.linalg.inv(P + 1e-12 * np.eye(3)) + H1.T @ H1 / SENSOR.noise**2
    assert np.allclose(C1[0], np.linalg.inv(info), rtol=1e-6)
    assert np.all(np.linalg.eigvalsh(C[0]) > 0)


def test_clutter_and_missed_landmarks_in_the_likelihood() -> None:
    L = demo_room().xy
    truth = np.array([5.6, 2.1, np.deg2rad(30)])
    z = predict_bearings(L[:3], truth)
    P = np.diag([1e-6, 1e-6, 1e-8])[None]
    base = ekf.update(truth[None], P, z, L, SENSOR)[2]
    # one more bearing nowhere near a landmark: clutter, the ratio does not change
    far = float(np.mod(z.min() - 0.9 + np.pi, 2 * np.pi) - np.pi)
    gaps = np.abs(np.angle(np.exp(1j * (predict_bearings(L, truth) - far))))
    assert gaps.min() > np.deg2rad(5)
    with_clutter = ekf.update(truth[None], P, np.append(z, far), L, SENSOR)[2]
    assert with_clutter.assignment[0, -1] == -1
    assert with_clutter.loglik[0] == pytest.approx(base.loglik[0], abs=1e-9)
    # every landmark plainly visible and not seen costs ln(1 - p_detect) (the ones seen
    # are at a reported bearing, so never "plainly visible" and missed)
    assert base.missed[0] == base.plain[0] > 0
    none = ekf.update(truth[None], P, np.zeros(0), L, SENSOR)[2]
    assert none.loglik[0] == pytest.approx(none.plain[0] * SENSOR.log_miss)


@settings(max_examples=40, deadline=None)
@given(
    st.integers(1, 5),
    st.integers(1, 6),
    st.integers(0, 2**31),
)
def test_association_is_the_best_assignment(m: int, n: int, seed: int) -> None:
    """The compiled search against brute force over every assignment."""
    rng = np.random.default_rng(seed)
    gain = rng.normal(0.5, 2.0, size=(1, m, n))
    gain[rng.random((1, m, n)) < 0.3] = -np.inf
    out = np.empty((1, 3, m), dtype=np.int64)
    tot = np.empty((1, 3))
    found = _kernels.associate(gain, out, tot)
    best = []
    for a in itertools.product(range(-1, n), repeat=m):
        used = [j for j in a if j >= 0]
        if len(used) != len(set(used)):
            continue
        g = [gain[0, i, j] for i, j in enumerate(a) if j >= 0]
        if any(not np.isfinite(x) or x <= 0 for x in g):
            continue
        best.append(sum(g))
    best = sorted(best, reverse=True)
    k = min(3, len(best))
    assert found[0] == k
    assert np.allclose(tot[0, :k], best[:k])


def test_collapse_moment_matches() -> None:
    poses = np.array([[1.0, 2.0, 0.1], [1.1, 2.0, 0.12], [5.0, 5.0, 2.0]])
    covs = np.repeat((0.04 * np.eye(3))[None], 3, axis=0)
    logw = np.log(np.array([0.6, 0.4, 1.0]))
    lead, p, c, w = _kernels.collapse(np.zeros(3, dtype=np.int64), poses, covs, logw, 9.0)
    assert lead.tolist() == [0, 2]  # the first two are one pose; the third is apart
    assert p[0] == pytest.approx([1.04, 2.0, 0.108])
    spread = 0.6 * 0.4 * np.outer([0.1, 0, 0.02], [0.1, 0, 0.02])
    assert np.allclose(c[0], 0.04 * np.eye(3) + spread)
    assert w[0] == pytest.approx(0.0)  # ln(0.6 + 0.4)


def test_split_keeps_the_mixture_mean_and_covariance() -> None:
    L = demo_room().xy
    pose = np.array([[5.6, 2.1, 0.5]])
    cov = np.diag([0.02, 0.02, np.deg2rad(8.0) ** 2])[None]
    rule = ekf.Split(max_sd=np.deg2rad(2.0), target_sd=np.deg2rad(1.0), max_children=9)
    p, c, parent, logw = ekf.split(pose, cov, L, SENSOR, rule)
    assert p.shape[0] == 9 and (parent == 0).all()
    w = np.exp(logw)
    assert w.sum() == pytest.approx(1.0)
    mean = (w[:, None] * p).sum(axis=0)
    assert np.allclose(mean, pose[0], atol=1e-9)
    d = p - mean
    mix = (w[:, None, None] * (c + d[:, :, None] * d[:, None, :])).sum(axis=0)
    # the mixture keeps the covariance up to the truncation at +-2.5 sd
    assert np.allclose(mix, cov[0], atol=0.1 * cov[0].max())


def test_distinct_drops_only_equal_poses() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.001], [0.5, 0.0, 0.0]])
    covs = np.repeat((1e-3 * np.eye(3))[None], 3, axis=0)
    keep = _kernels.distinct(poses, covs, 7.8, 0.1, np.deg2rad(1.0))
    assert keep.tolist() == [True, False, True]


def test_predict_covariance_matches_the_motion_model() -> None:
    m = MotionModel()
    d, Q = integrate([1.0], [0.5], [0.3], m)
    p, P = ekf.predict(np.zeros((1, 3)), np.zeros((1, 3, 3)), d, Q)
    assert np.allclose(p[0], d) and np.allclose(P[0], Q)
    # a rotated start rotates the covariance of the position
    th = 0.7
    p, P = ekf.predict(np.array([[0.0, 0.0, th]]), np.zeros((1, 3, 3)), d, Q)
    R = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
    assert np.allclose(P[0], R @ Q @ R.T)
