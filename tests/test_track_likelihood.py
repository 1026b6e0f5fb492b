"""The frame likelihood and update of the tracker's hypotheses (omniloc.track.likelihood),
checked against the formulas written out by hand for one hypothesis."""

from __future__ import annotations

import dataclasses
import math
import os
import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm

from omniloc.angles import wrap
from omniloc.sensor import SensorModel
from omniloc.track.likelihood import (
    FrameModel,
    Objects,
    frame_update,
    frame_update_clutter,
    log_ratios,
    log_ratios_clutter,
)

SIGMA = np.deg2rad(1.0)


def _model(**kw: float) -> FrameModel:
    base: dict[str, float] = dict(sigma=SIGMA, p_detect=0.6, clutter=0.5)
    base.update(kw)
    return FrameModel.of(SensorModel(**base))


def _bearing(pose: np.ndarray, lm: np.ndarray) -> float:
    a = math.atan2(lm[1] - pose[1], lm[0] - pose[0]) - pose[2]
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_a_frame_without_bearings_costs_the_landmarks_in_view_and_moves_nothing() -> None:
    model = _model(fov=np.deg2rad(90.0), max_range=6.0)
    L = np.array([[3.0, 0.0], [3.0, 0.5], [-3.0, 0.0], [10.0, 0.0]])  # 2 in view, 1 behind, 1 far
    mu = np.array([[0.0, 0.0, 0.0]])
    P = np.diag([1e-6, 1e-6, 1e-8])[None]
    mu2, P2, lr, explained = frame_update(mu, P, np.zeros(0), L, model)
    assert math.isclose(lr[0], 2 * math.log(1 - 0.6), rel_tol=1e-9)
    assert explained[0] == 0.0
    np.testing.assert_array_equal(mu2, mu)
    np.testing.assert_array_equal(P2, P)


def test_one_bearing_earns_the_mixture_of_clutter_and_the_landmark() -> None:
    model = _model()
    L = np.array([[4.0, 1.0]])
    mu = np.array([[0.0, 0.0, 0.2]])
    P = np.diag([0.01, 0.02, 0.003])[None]
    z = _bearing(mu[0], L[0]) + np.deg2rad(2.0)
    _, _, lr, explained = frame_update(mu, P, np.array([z]), L, model)
    dx, dy = L[0] - mu[0, :2]
    q = dx * dx + dy * dy
    J = np.array([dy / q, -dx / q, -1.0])
    S = J @ P[0] @ J + SIGMA**2
    kappa = 0.5 / (2 * math.pi)
    p = 0.6
    g = norm.pdf(np.deg2rad(2.0), scale=math.sqrt(S))
    expected = math.log(1 - p) + math.log(1 + p / (1 - p) * g / kappa)
    assert math.isclose(lr[0], expected, rel_tol=1e-9)
    a = p / (1 - p) * g / kappa
    assert math.isclose(explained[0], a / (1 + a), rel_tol=1e-9)


def test_a_bearing_that_can_only_be_the_landmark_is_a_kalman_step() -> None:
    # Clutter so rare that the reading is the landmark with probability ~1.
    model = _model(p_detect=0.9, clutter=1e-9)
    L = np.array([[5.0, -1.0]])
    mu = np.array([[0.3, 0.1, -0.1]])
    P = np.diag([0.04, 0.02, 0.001])[None]
    z = _bearing(mu[0], L[0]) - np.deg2rad(1.5)
    mu2, P2, _, _ = frame_update(mu, P, np.array([z]), L, model)
    dx, dy = L[0] - mu[0, :2]
    q = dx * dx + dy * dy
    J = np.array([dy / q, -dx / q, -1.0])
    S = J @ P[0] @ J + SIGMA**2
    K = P[0] @ J / S
    np.testing.assert_allclose(mu2[0], mu[0] + K * (z - _bearing(mu[0], L[0])), atol=1e-12)
    np.testing.assert_allclose(P2[0], P[0] - np.outer(K, K) * S, atol=1e-12)


def test_a_landmark_closer_than_the_minimum_range_explains_nothing() -> None:
    model = _model(min_range=1.0)
    L = np.array([[0.5, 0.0]])
    mu = np.array([[0.0, 0.0, 0.0]])
    P = np.diag([1e-4, 1e-4, 1e-5])[None]
    mu2, _, lr, explained = frame_update(mu, P, np.array([0.0]), L, model)
    assert lr[0] == 0.0 and explained[0] == 0.0
    np.testing.assert_array_equal(mu2, mu)
    assert log_ratios(mu, np.array([0.0]), L, model)[0] == 0.0


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_hyp=st.integers(1, 6),
    n_lm=st.integers(1, 8),
    n_b=st.integers(0, 4),
    fov=st.sampled_from([None, 1.2, 4.0]),
)
def test_hypotheses_are_updated_independently(
    seed: int, n_hyp: int, n_lm: int, n_b: int, fov: float | None
) -> None:
    rng = np.random.default_rng(seed)
    kw: dict[str, float] = {} if fov is None else {"fov": fov}
    model = _model(max_range=8.0, **kw)
    L = rng.uniform(-5, 5, (n_lm, 2))
    mu = np.c_[rng.uniform(-5, 5, (n_hyp, 2)), rng.uniform(-3, 3, n_hyp)]
    A = rng.normal(size=(n_hyp, 3, 3)) * 0.1
    P = A @ A.transpose(0, 2, 1) + 1e-4 * np.eye(3)
    b = rng.uniform(-math.pi, math.pi, n_b)
    together = frame_update(mu, P, b, L, model)
    for k in range(n_hyp):
        alone = frame_update(mu[k : k + 1], P[k : k + 1], b, L, model)
        for x, y in zip(together, alone, strict=True):
            np.testing.assert_allclose(x[k], y[0], rtol=1e-12, atol=1e-12)
    # Exactly known poses (particles): the formula of the module's docstring, by hand.
    expected = []
    for pose in mu:
        h = np.array([_bearing(pose, lm) for lm in L])
        r = np.hypot(*(L - pose[:2]).T)
        d = 0.6 * (r <= 8.0) * (1.0 if fov is None else (np.abs(h) < fov / 2))
        kappa = 0.5 / (2 * math.pi if fov is None else fov)
        nu = (b[:, None] - h[None, :] + math.pi) % (2 * math.pi) - math.pi
        g = norm.pdf(nu, scale=SIGMA)
        expected.append(np.log1p(-d).sum() + np.log1p((d / (1 - d) * g / kappa).sum(axis=1)).sum())
    np.testing.assert_allclose(log_ratios(mu, b, L, model), expected, rtol=1e-9, atol=1e-9)


# ---- clutter with memory ---------------------------------------------------------------------


def _memory_model(fresh: float, sd: float) -> FrameModel:
    return dataclasses.replace(
        _model(fov=np.deg2rad(90.0), max_range=6.0), fresh=fresh, object_var=sd**2
    )


def test_an_object_seen_again_by_hand() -> None:
    # No landmark in view: the frame is clutter only. Density at z: kappa * fresh plus the
    # object's expected count times a Gaussian around it; the objects' count is paid once and
    # the new clutter's count is (1 - fresh) of the memoryless one's: the ratio is
    #   (1 - fresh) kappa fov - w + ln((kappa fresh + w N(z; b, s^2)) / kappa).
    model = _memory_model(fresh=0.2, sd=np.deg2rad(1.5))
    L = np.array([[-3.0, 0.0]])  # behind
    kappa = math.exp(model.log_kappa)
    fov = np.deg2rad(90.0)
    z, b, w = 0.1, 0.12, 0.6
    objects = Objects(np.array([b]), np.array([[w]]))
    lr, post = log_ratios_clutter(np.zeros((1, 3)), np.array([z]), L, model, objects)
    dens = kappa * 0.2 + w * norm.pdf(z, b, np.deg2rad(1.5))
    want = 0.8 * kappa * fov - w + math.log(dens / kappa)
    assert math.isclose(lr[0], want, rel_tol=1e-9)
    assert post[0, 0] == 1.0  # nothing else could have made it
    # the same through the update, for a hypothesis with a covariance
    P = np.diag([1e-4, 1e-4, 1e-6])[None]
    _, _, lr2, explained, post2 = frame_update_clutter(
        np.zeros((1, 3)), P, np.array([z]), L, model, objects
    )
    assert math.isclose(lr2[0], want, rel_tol=1e-9) and explained[0] == 0.0 and post2[0, 0] == 1.0


def test_objects_and_bearings_each_paired_by_hand() -> None:
    # Two bearings, two objects, two poses that remember them differently: each bearing's
    # density sums every object's Gaussian at that bearing, weighed by that pose's count.
    model = _memory_model(fresh=0.3, sd=np.deg2rad(2.0))
    L = np.array([[-3.0, 0.0]])  # behind: every bearing is clutter
    kappa = math.exp(model.log_kappa)
    fov = np.deg2rad(90.0)
    z = np.array([0.1, -0.4])
    b = np.array([0.12, -0.38])
    w = np.array([[0.6, 0.1], [0.0, 0.9]])
    lr, post = log_ratios_clutter(np.zeros((2, 3)), z, L, model, Objects(b, w))
    sd = np.deg2rad(2.0)
    for k in range(2):
        want = 0.7 * kappa * fov - w[k].sum()
        for zi in z:
            dens = kappa * 0.3 + sum(w[k, o] * norm.pdf(zi, b[o], sd) for o in range(2))
            want += math.log(dens / kappa)
        assert math.isclose(lr[k], want, rel_tol=1e-9)
    assert (post == 1.0).all()


def test_an_object_seen_again_weighs_less_for_a_landmark_and_more_for_clutter() -> None:
    # Two poses: one explains the bearing with a landmark, one as clutter. A persistent
    # object at that bearing narrows their gap: the windfall of calling a robot a landmark.
    L = np.array([[3.0, 0.0]])
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5]])  # the landmark at 0 rad, or -0.5 rad
    z = np.array([_bearing(poses[0], L[0])])
    model = _memory_model(fresh=0.2, sd=np.deg2rad(1.0))
    plain, _ = log_ratios_clutter(poses, z, L, model, None)
    objects = Objects(z.copy(), np.array([[0.0], [0.8]]))  # the clutter pose remembers it
    memory, post = log_ratios_clutter(poses, z, L, model, objects)
    assert memory[1] - memory[0] > plain[1] - plain[0] + 2.0
    assert post[0, 0] < 0.01 and post[1, 0] == 1.0


def test_without_memory_the_update_is_the_plain_one() -> None:
    rng = np.random.default_rng(2)
    L = rng.uniform(-5, 5, (12, 2))
    mu = rng.uniform(-1, 1, (6, 3))
    P = np.repeat(np.diag([0.01, 0.01, 0.001])[None], 6, axis=0)
    b = rng.uniform(-1, 1, 4)
    model = _model(fov=np.deg2rad(120.0), max_range=8.0)
    plain = frame_update(mu, P, b, L, model)
    full = frame_update_clutter(mu, P, b, L, model, None)
    for x, y in zip(plain, full[:4], strict=True):
        np.testing.assert_array_equal(x, y)
    assert ((full[4] >= 0.0) & (full[4] <= 1.0)).all()
    np.testing.assert_allclose(full[3], (1.0 - full[4]).sum(axis=1), rtol=1e-12, atol=1e-12)


def test_at_an_exact_pose_the_field_of_view_has_a_sharp_edge() -> None:
    # Particles of elsewhere: a landmark 1 deg inside the view counts as fully in view, one
    # 1 deg outside not at all (no covariance blurs the edge).
    model = _model(fov=np.deg2rad(90.0))
    inside, outside = np.deg2rad(44.0), np.deg2rad(46.0)
    L = 3.0 * np.array([[np.cos(inside), np.sin(inside)], [np.cos(outside), np.sin(outside)]])
    lr = log_ratios(np.zeros((1, 3)), np.zeros(0), L, model)
    assert math.isclose(lr[0], math.log(1.0 - 0.6), rel_tol=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    fov_deg=st.floats(1.0, 360.0),
    seed=st.integers(0, 2**31),
    edge=st.booleans(),
)
def test_exact_poses_skip_the_landmarks_out_of_view_without_changing_a_bit(
    fov_deg: float, seed: int, edge: bool
) -> None:
    # Particles (no covariance) test who is out of view without the bearing's atan2; the
    # ratios must be those of the full test, bit for bit, landmarks on the edge of the view
    # included. The update path always takes the full test; at a zero covariance and with
    # one bearing, its ratio comes from the poses as given (a bearing's update, which
    # moves nothing but wraps the heading, comes after it).
    rng = np.random.default_rng(seed)
    poses = np.column_stack(
        [rng.uniform(-2, 2, 40), rng.uniform(-2, 2, 40), rng.uniform(-9, 9, 40)]
    )
    L = rng.uniform(-6, 6, (10, 2))
    half = math.radians(fov_deg) / 2.0
    if edge:
        # Landmarks exactly at the edge of the first pose's view, and just either side of it.
        for n, off in enumerate((0.0, 1e-12, -1e-12, 1e-8, -1e-8, 1e-7, -1e-7)):
            a = poses[0, 2] + (half + off) * (1 if n % 2 else -1)
            L[n] = poses[0, :2] + 3.0 * np.array([math.cos(a), math.sin(a)])
    model = _model(fov=math.radians(fov_deg), max_range=7.0)
    zero = np.zeros((poses.shape[0], 3, 3))
    for b in rng.uniform(-math.pi, math.pi, (3, 1)):
        fast = log_ratios(poses, b, L, model)
        np.testing.assert_array_equal(fast, frame_update(poses, zero, b, L, model)[2])


def test_many_hypotheses_run_in_two_halves_with_the_same_results(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import omniloc._pools as pools
    import omniloc.track.likelihood as lk

    rng = np.random.default_rng(5)
    H = 2 * lk.PARALLEL_MIN + 3
    L = rng.uniform(-5, 5, (12, 2))
    mu = np.column_stack([rng.uniform(-3, 3, (H, 2)), rng.uniform(-math.pi, math.pi, H)])
    P = np.repeat(np.diag([0.04, 0.04, 0.01])[None], H, axis=0)
    b = rng.uniform(-1, 1, 4)
    objects = Objects(rng.uniform(-1, 1, 2), rng.uniform(0, 0.5, (H, 2)))
    model = _memory_model(fresh=0.3, sd=np.deg2rad(1.0))
    monkeypatch.setattr(pools, "_local", threading.local())
    halves = frame_update_clutter(mu, P, b, L, model, objects)
    particles = log_ratios_clutter(mu, b, L, model, objects)
    if (os.cpu_count() or 1) >= 2:
        assert ("omniloc-frame", 1) in pools._local.pools  # it did run in two halves
    monkeypatch.setattr(lk, "PARALLEL_MIN", 10**9)
    for x, y in zip(halves, frame_update_clutter(mu, P, b, L, model, objects), strict=True):
        np.testing.assert_array_equal(x, y)
    for x, y in zip(particles, log_ratios_clutter(mu, b, L, model, objects), strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.skipif(
    "fork" not in __import__("multiprocessing").get_all_start_methods(), reason="no fork"
)
def test_a_forked_child_runs_many_hypotheses_on_its_own_pool() -> None:
    # The parent's helper thread does not exist in a child made by fork: the child must not
    # hand its half to it (it would wait for ever), e.g. evaluation workers forked after a
    # run in the parent.
    import multiprocessing as mp

    import omniloc.track.likelihood as lk

    rng = np.random.default_rng(6)
    H = 2 * lk.PARALLEL_MIN
    L = rng.uniform(-5, 5, (8, 2))
    poses = np.column_stack([rng.uniform(-3, 3, (H, 2)), rng.uniform(-math.pi, math.pi, H)])
    b = rng.uniform(-1, 1, 3)
    model = _model(fov=np.deg2rad(120.0), max_range=8.0)
    want = log_ratios(poses, b, L, model)  # the parent's pool now exists
    ctx = mp.get_context("fork")
    with ctx.Pool(1) as pool:
        got = pool.apply_async(log_ratios, (poses, b, L, model)).get(timeout=60)
    np.testing.assert_array_equal(got, want)


def test_each_bearing_is_read_from_the_pose_the_bearings_before_it_moved() -> None:
    # The chain rule of the frame: the second bearing is predicted from the hypothesis as the
    # first left it, exactly as if it came alone in a frame after it.
    L = np.array([[3.0, 0.4], [2.0, -1.5], [4.0, 2.0]])
    mu = np.array([[0.05, -0.04, 0.02]])
    P = np.diag([0.02, 0.02, 0.004])[None]
    truth = np.zeros(3)
    b = np.array([_bearing(truth, L[0]), _bearing(truth, L[1])])
    model = _model(fov=np.deg2rad(120.0), max_range=8.0)
    both = frame_update_clutter(mu, P, b, L, model, None)
    mu1, P1 = frame_update(mu, P, b[:1], L, model)[:2]
    mu2, P2, _, _, post2 = frame_update_clutter(mu1, P1, b[1:], L, model, None)
    assert not np.allclose(mu1, mu)  # the first bearing moved the hypothesis
    np.testing.assert_allclose(both[0], mu2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(both[1], P2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(both[4][:, 1], post2[:, 0], rtol=1e-12)


def test_a_mixture_of_one_noise_twice_is_the_single_gaussian() -> None:
    # (1 - c) N(0, s^2) + c N(0, s^2) = N(0, s^2): the same ratio and the same update.
    L = np.array([[4.0, 1.0], [3.0, -2.0], [5.0, 0.5]])
    mu = np.array([[0.0, 0.0, 0.2], [0.1, -0.1, 0.15]])
    P = np.array([np.diag([0.01, 0.02, 0.003]), np.diag([0.02, 0.01, 0.002])])
    z = np.array([_bearing(mu[0], L[0]) + 0.01, _bearing(mu[0], L[1]) - 0.02, 0.9])
    plain = _model()
    mixed = dataclasses.replace(plain, core_share=0.4, core_sigma2=plain.sigma2)
    a = frame_update(mu, P, z, L, plain)
    b = frame_update(mu, P, z, L, mixed)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_allclose(y, x, rtol=1e-12, atol=1e-15)


def test_a_sharp_core_rewards_a_precise_fit_more_than_one_wide_gaussian() -> None:
    # One landmark, a bearing 0.15 deg off the first pose's prediction and 1 deg off the
    # second's: the mixture (57 % at 0.33 deg, the rest at 1 deg) tells them apart by
    # ln of its densities' ratio, the 1-deg Gaussian by much less.
    L = np.array([[4.0, 0.0]])
    mu = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, np.deg2rad(0.85)]])
    z = np.array([np.deg2rad(0.15)])
    plain = _model()
    mixed = dataclasses.replace(plain, core_share=0.57, core_sigma2=np.deg2rad(0.33) ** 2)
    lp = log_ratios(mu, z, L, plain)
    lm = log_ratios(mu, z, L, mixed)

    def density(e: float, model: FrameModel) -> float:
        s, c = math.sqrt(model.sigma2), math.sqrt(model.core_sigma2) if model.core_share else 1.0
        return (1 - model.core_share) * norm.pdf(e, 0, s) + model.core_share * norm.pdf(e, 0, c)

    rho = 0.6 / 0.4
    kappa = math.exp(plain.log_kappa)

    def ratio(e: float, model: FrameModel) -> float:
        return math.log(0.4) + math.log(1 + rho * density(e, model) / kappa)

    e0, e1 = np.deg2rad(0.15), np.deg2rad(1.0)
    assert lm[0] == pytest.approx(ratio(e0, mixed), rel=1e-9)
    assert lm[1] == pytest.approx(ratio(e1, mixed), rel=1e-9)
    assert lp[0] - lp[1] == pytest.approx(ratio(e0, plain) - ratio(e1, plain), rel=1e-9)
    assert lm[0] - lm[1] > 1.5 > 2 * (lp[0] - lp[1])


def test_a_core_that_only_weighs_leaves_the_update_to_the_tail() -> None:
    # One landmark in view, a bearing 0.1 deg off: with core_update False the frame's ratio
    # is the mixture's (as with the core in the update), but the pose moves and its
    # covariance shrinks as with the tail's variance alone; with the core in the update the
    # covariance shrinks more.
    L = np.array([[4.0, 1.0]])
    mu = np.array([[0.0, 0.0, 0.2]])
    P = np.diag([1e-4, 1e-4, 1e-5])[None]
    z = np.array([_bearing(mu[0], L[0]) + np.deg2rad(0.1)])
    plain = dataclasses.replace(_model(), log_kappa=math.log(1e-9))  # no clutter to speak of
    sharp = dataclasses.replace(plain, core_share=0.57, core_sigma2=np.deg2rad(0.33) ** 2)
    weighs = dataclasses.replace(sharp, core_update=False)
    mu_p, P_p, lr_p = frame_update(mu, P, z, L, plain)[:3]
    _, P_s, lr_s = frame_update(mu, P, z, L, sharp)[:3]
    mu_w, P_w, lr_w = frame_update(mu, P, z, L, weighs)[:3]
    np.testing.assert_allclose(lr_w, lr_s, rtol=1e-12)
    assert abs(lr_w[0] - lr_p[0]) > 0.3  # the weights are the mixture's, not the tail's
    np.testing.assert_allclose(mu_w, mu_p, rtol=0, atol=1e-9)
    np.testing.assert_allclose(P_w, P_p, rtol=1e-6, atol=1e-12)
    # The sharp update pins the landmark's bearing harder: its predicted variance after it.
    d = L[0] - mu[0, :2]
    J = np.array([d[1], -d[0], -(d @ d)]) / (d @ d)
    assert J @ P_s[0] @ J < 0.85 * (J @ P_w[0] @ J)


def test_core_update_is_a_boolean_setting() -> None:
    from omniloc.errors import InputError
    from omniloc.track import TrackerConfig, preset, with_settings

    _, _, c = with_settings(*preset("mrclam"), {"core_share": 0.2, "core_update": False})
    assert c.core_update is False and c.core_share == 0.2
    assert TrackerConfig().core_update is True
    for bad in (0, 1.0, "false", None):
        with pytest.raises(InputError, match="core_update must be true or false"):
            TrackerConfig(core_update=bad)  # type: ignore[arg-type]


def test_an_update_scale_tempers_the_kalman_step_and_not_the_weights() -> None:
    # The Kalman step of a bearing that can only be the landmark, with the bearing variance
    # scaled by 2 in the update (a likelihood tempered by 0.5): the gain and the shrink of
    # variance 2 sigma^2, the frame's ratio that of sigma^2.
    model = _model(p_detect=0.9, clutter=1e-9)
    tempered = dataclasses.replace(model, update_scale=2.0)
    L = np.array([[5.0, -1.0]])
    mu = np.array([[0.3, 0.1, -0.1]])
    P = np.diag([0.04, 0.02, 0.001])[None]
    z = np.array([_bearing(mu[0], L[0]) - np.deg2rad(1.5)])
    _, _, lr = frame_update(mu, P, z, L, model)[:3]
    mu2, P2, lr2 = frame_update(mu, P, z, L, tempered)[:3]
    np.testing.assert_array_equal(lr2, lr)
    dx, dy = L[0] - mu[0, :2]
    q = dx * dx + dy * dy
    J = np.array([dy / q, -dx / q, -1.0])
    S = J @ P[0] @ J + 2.0 * SIGMA**2
    K = P[0] @ J / S
    np.testing.assert_allclose(mu2[0], mu[0] + K * (z[0] - _bearing(mu[0], L[0])), atol=1e-12)
    np.testing.assert_allclose(P2[0], P[0] - np.outer(K, K) * S, atol=1e-12)
    # With a sharp core in the update its variance is scaled too: a bearing that is all but
    # surely the core's reading is the Kalman step of twice the core's variance.
    core2 = np.deg2rad(0.3) ** 2
    sharp = dataclasses.replace(tempered, core_share=1.0 - 1e-9, core_sigma2=core2)
    mu3, P3 = frame_update(mu, P, z, L, sharp)[:2]
    S = J @ P[0] @ J + 2.0 * core2
    K = P[0] @ J / S
    np.testing.assert_allclose(mu3[0], mu[0] + K * (z[0] - _bearing(mu[0], L[0])), atol=1e-9)
    np.testing.assert_allclose(P3[0], P[0] - np.outer(K, K) * S, rtol=1e-6, atol=1e-12)


def test_temper_update_divides_the_update_variance_by_the_evidence_weight() -> None:
    from omniloc.errors import InputError
    from omniloc.maps import LandmarkMap
    from omniloc.track import Tracker, TrackerConfig

    lm = LandmarkMap(np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]]))
    sensor = SensorModel(sigma=SIGMA)

    def scale(**kw: object) -> float:
        return Tracker(lm, sensor, config=TrackerConfig(**kw))._model.update_scale

    assert scale() == 1.0
    assert scale(evidence_weight=0.7) == 1.0
    assert scale(temper_update=True) == 1.0
    assert scale(temper_update=True, evidence_weight=0.7) == 1.0 / 0.7
    with pytest.raises(InputError, match="temper_update must be true or false"):
        TrackerConfig(temper_update=1)  # type: ignore[arg-type]
    # A weight so small that its inverse overflows would give the update an infinite
    # variance (NaN covariances, every hypothesis dropped): refused by name.
    for w in (5e-324, 1e-300, 1e-7):
        with pytest.raises(InputError, match="evidence_weight must be >= 1e-06 with temper_update"):
            TrackerConfig(temper_update=True, evidence_weight=w)
    assert scale(temper_update=True, evidence_weight=1e-6) == 1e6
    TrackerConfig(evidence_weight=1e-7)  # without temper_update the weight alone is fine


def test_the_kernels_shortcuts_of_erfc_and_exp_are_bit_for_bit(rng: np.random.Generator) -> None:
    # _in_view, _reading and _exp skip erfc where it is 0 or 2 and exp where it is 0; the plain
    # formulas they replace, compiled the same way, are the oracle, over the thresholds
    # and far beyond.
    from numba import njit

    from omniloc._kernels.track import _exp, _in_view, _reading

    @njit(error_model="numpy")
    def plain_in_view(e: float, sd: float) -> float:
        return 0.5 * math.erfc(-(e / sd) / math.sqrt(2.0))

    @njit(error_model="numpy")
    def plain_reading(share: float, rho: float, nu: float, S: float, norm: float) -> float:
        return share * rho * math.exp(-0.5 * nu * nu / S) / math.sqrt(S) * norm

    @njit(error_model="numpy")
    def plain_exp(x: float) -> float:
        return math.exp(x)

    def same(a: float, b: float) -> bool:
        return np.float64(a).tobytes() == np.float64(b).tobytes()

    e = np.concatenate(
        [rng.uniform(-3, 3, 3000), rng.normal(0, 1e-3, 1000), [0.0, -0.0, np.inf, -np.inf, np.nan]]
    )
    sd = np.concatenate([10.0 ** rng.uniform(-9, 1, e.size - 5), [1e-9, 1.0, 1e-3, 1.0, 1.0]])
    for x, s in zip(e.tolist(), sd.tolist(), strict=True):
        assert same(_in_view(x, s), plain_in_view(x, s)), (x, s)
    for arg in (27.5, 27.5 + 1e-12, 27.5 - 1e-12, -6.5, -6.5 - 1e-12, -6.5 + 1e-12, 1e300, -1e300):
        x = -arg * math.sqrt(2.0)
        assert same(_in_view(x, 1.0), plain_in_view(x, 1.0)), arg
    nu = np.concatenate([rng.uniform(-4, 4, 3000), [0.0, np.pi, -np.pi, np.inf, np.nan]])
    S = np.concatenate([10.0 ** rng.uniform(-8, 0, nu.size - 5), [1e-8, 1e-8, 1e-3, 1.0, 1.0]])
    for n, v in zip(nu.tolist(), S.tolist(), strict=True):
        for share, rho, norm_ in ((1.0, 0.5, 30.0), (0.43, 1e-6, 2.0), (0.0, 2.0, 1.0)):
            assert same(_reading(share, rho, n, v, norm_), plain_reading(share, rho, n, v, norm_))
    for x in np.concatenate([[-750.0, -750.0 - 1e-12, -745.2, -1e300, -np.inf, np.nan], -(nu**2)]):
        assert same(_exp(float(x)), plain_exp(float(x))), x


def test_a_log_of_nonempty_frames_weighs_each_frame_given_that_it_holds_a_bearing() -> None:
    # Two exactly known poses, one seeing two landmarks, one seeing none; an object of the
    # previous frame (clutter with memory). With ``nonempty`` each frame with bearings is
    # weighed by p(z | pose) / P(some bearing | pose), against the null's likewise:
    #   + ln(1 - exp(-kappa fov)) - ln(1 - (1 - p)^2 exp(-fresh kappa fov - w)).
    # A frame without bearings is weighed as it was (it was not selected).
    plain = _memory_model(fresh=0.3, sd=np.deg2rad(1.5))
    plain = dataclasses.replace(plain, p_detect=0.6)
    model = dataclasses.replace(plain, nonempty=True)
    L = np.array([[3.0, 0.0], [3.0, 0.5]])
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, math.pi]])
    objects = Objects(np.array([0.4]), np.array([[0.5], [0.2]]))
    kappa, fov = math.exp(model.log_kappa), np.deg2rad(90.0)
    lam = kappa * fov
    for z in (np.array([0.05]), np.array([0.0, 0.4])):
        lr0, post0 = log_ratios_clutter(poses, z, L, plain, objects)
        lr1, post1 = log_ratios_clutter(poses, z, L, model, objects)
        for k, (seen, w) in enumerate(((2, 0.5), (0, 0.2))):
            none = (1 - 0.6) ** seen * math.exp(-0.3 * lam - w)
            want = lr0[k] + math.log(1 - math.exp(-lam)) - math.log(1 - none)
            assert math.isclose(lr1[k], want, rel_tol=1e-12, abs_tol=1e-12)
        np.testing.assert_array_equal(post1, post0)
        # the same through the update, for hypotheses with a covariance
        P = np.repeat(np.diag([1e-8, 1e-8, 1e-10])[None], 2, axis=0)
        a = frame_update_clutter(poses, P, z, L, plain, objects)
        b = frame_update_clutter(poses, P, z, L, model, objects)
        np.testing.assert_allclose(b[2] - a[2], lr1 - lr0, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(b[0], a[0])
        np.testing.assert_array_equal(b[1], a[1])
    empty = np.zeros(0)
    np.testing.assert_array_equal(
        log_ratios_clutter(poses, empty, L, model, objects)[0],
        log_ratios_clutter(poses, empty, L, plain, objects)[0],
    )


def test_nonempty_frames_reaches_the_frame_model() -> None:
    from omniloc import LandmarkMap
    from omniloc.track import TrackerConfig
    from omniloc.track.motion import MotionModel
    from omniloc.track.tracker import Tracker

    lm = LandmarkMap(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    sensor = SensorModel(sigma=SIGMA)
    assert not Tracker(lm, sensor, MotionModel(), TrackerConfig())._model.nonempty
    assert Tracker(lm, sensor, MotionModel(), TrackerConfig(nonempty_frames=True))._model.nonempty


@pytest.mark.parametrize("w", [1.0, 0.5, 0.0])
def test_a_miss_weight_scales_the_cost_of_the_landmarks_not_reported(w: float) -> None:
    # Two landmarks in view, none reported: 2 w ln(1 - p). One reported, exactly and
    # without clutter's competition to speak of: it earns p times its density whatever the
    # weight, and the other's miss costs w ln(1 - p).
    model = dataclasses.replace(_model(fov=np.deg2rad(90.0), max_range=6.0), miss_weight=w)
    plain = _model(fov=np.deg2rad(90.0), max_range=6.0)
    L = np.array([[3.0, 0.0], [3.0, 0.5], [-3.0, 0.0]])
    mu = np.array([[0.0, 0.0, 0.0]])
    P = np.diag([1e-6, 1e-6, 1e-8])[None]
    lr = frame_update(mu, P, np.zeros(0), L, model)[2]
    assert math.isclose(lr[0], w * 2 * math.log(1 - 0.6), rel_tol=1e-12, abs_tol=1e-15)
    z = np.array([_bearing(mu[0], L[0])])
    a = frame_update(mu, P, z, L, plain)
    b = frame_update(mu, P, z, L, model)
    dx, dy = L[0] - mu[0, :2]
    J = np.array([dy, -dx, -(dx * dx + dy * dy)]) / (dx * dx + dy * dy)
    g = norm.pdf(0.0, scale=math.sqrt(J @ P[0] @ J + SIGMA**2)) / math.exp(model.log_kappa)
    want = (w - 1) * 2 * math.log(1 - 0.6) + math.log1p(0.6 / 0.4**w * g) - math.log1p(1.5 * g)
    assert math.isclose(b[2][0] - a[2][0], want, rel_tol=1e-9, abs_tol=1e-12)
    # (without the clutter's share of the reading: the miss of the other landmark alone)
    assert b[2][0] - a[2][0] == pytest.approx((w - 1) * math.log(1 - 0.6), rel=0.02, abs=1e-9)


@pytest.mark.parametrize(
    "setting, attr, value, default, bad",
    [
        ("miss_weight", "miss_weight", 0.5, 1.0, (-0.1, 1.5, float("nan"))),
        ("occlusion_width", "occlusion", 0.04, 0.0, (-0.1, float("nan"), float("inf"))),
    ],
)
def test_a_frame_model_setting_reaches_the_frame_model_and_is_checked(
    setting: str, attr: str, value: float, default: float, bad: tuple[float, ...]
) -> None:
    from omniloc import LandmarkMap
    from omniloc.errors import InputError
    from omniloc.track import TrackerConfig
    from omniloc.track.motion import MotionModel
    from omniloc.track.tracker import Tracker

    lm = LandmarkMap(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    sensor = SensorModel(sigma=SIGMA)
    tr = Tracker(lm, sensor, MotionModel(), TrackerConfig(**{setting: value}))
    assert getattr(tr._model, attr) == value
    assert getattr(Tracker(lm, sensor, MotionModel(), TrackerConfig())._model, attr) == default
    for v in bad:
        with pytest.raises(InputError, match=setting):
            TrackerConfig(**{setting: v})


def _assignment_sum(R: np.ndarray) -> float:
    """The sum over the assignments of bearings (rows) to landmarks (columns), each landmark
    to at most one bearing and each bearing to at most one landmark, of the product of
    their readings ``R`` (over the clutter's density; an unassigned bearing counts 1)."""
    import itertools

    k, n = R.shape
    total = 0.0
    for choice in itertools.product(range(-1, n), repeat=k):
        used = [c for c in choice if c >= 0]
        if len(used) != len(set(used)):
            continue
        total += math.prod(R[i, c] for i, c in enumerate(choice) if c >= 0)
    return total


def _readings(mu: np.ndarray, zs: np.ndarray, L: np.ndarray, model: FrameModel) -> np.ndarray:
    """Each bearing's reading of each landmark in view from an exactly known pose, over the
    clutter's density (a single Gaussian or the sharp-core mixture)."""
    kappa = math.exp(model.log_kappa)
    rho = model.p_detect / (1.0 - model.p_detect)
    R = np.zeros((zs.size, L.shape[0]))
    for i, z in enumerate(zs):
        for n, lm in enumerate(L):
            e = float(wrap(z - _bearing(mu[0], lm)))
            g = (1 - model.core_share) * norm.pdf(e, scale=math.sqrt(model.sigma2))
            if model.core_share:
                g += model.core_share * norm.pdf(e, scale=math.sqrt(model.core_sigma2))
            R[i, n] = rho * g / kappa
    return R


@pytest.mark.parametrize("core_share", [0.0, 0.43])
@pytest.mark.parametrize(
    "offsets",
    [
        ((0.0, 0.0), (0.5, -1.2)),  # one landmark, two bearings
        ((0.0, 0.0), (0.5, -1.2, 2.0)),  # one landmark, three bearings
        ((0.0, 0.3), (0.4, 3.5)),  # a pair of landmarks 4 deg apart, a bearing near each
        ((0.0, 0.3, -0.3), (0.4, 3.5, 1.5)),  # three landmarks, three bearings between them
    ],
)
def test_exclusive_landmarks_weigh_the_sum_over_assignments(
    core_share: float, offsets: tuple[tuple[float, ...], tuple[float, ...]]
) -> None:
    # Each landmark explains at most one bearing of the frame: the frame's ratio is the sum
    # over such assignments (times the misses), where weighing each bearing on its own
    # counts one landmark for two bearings too. Exact for an exactly known pose, and for a
    # hypothesis whose covariance is as good as zero.
    base = _model(fov=np.deg2rad(120.0), max_range=8.0)
    if core_share:
        base = dataclasses.replace(base, core_share=core_share, core_sigma2=(SIGMA / 3) ** 2)
    model = dataclasses.replace(base, exclusive=True)
    lm_dy, z_deg = offsets
    L = np.array([[4.0, 1.0 + dy] for dy in lm_dy])
    mu = np.array([[0.0, 0.0, 0.2]])
    zs = _bearing(mu[0], L[0]) + np.deg2rad(np.array(z_deg))
    R = _readings(mu, zs, L, base)
    misses = L.shape[0] * math.log(1 - 0.6)
    exact = misses + math.log(_assignment_sum(R))
    apart = misses + np.log1p(R.sum(axis=1)).sum()
    got = log_ratios(mu, zs, L, model)[0]
    assert math.isclose(got, exact, rel_tol=1e-12, abs_tol=1e-12)
    assert math.isclose(log_ratios(mu, zs, L, base)[0], apart, rel_tol=1e-12, abs_tol=1e-12)
    assert got < apart
    P = np.diag([1e-14, 1e-14, 1e-16])[None]
    assert math.isclose(frame_update(mu, P, zs, L, model)[2][0], exact, rel_tol=1e-6)


def test_exclusive_changes_nothing_when_no_two_bearings_contest_a_landmark() -> None:
    # Three landmarks spread over the view, one bearing on each: no landmark reads two
    # bearings (the others' readings are thousands of sigmas off and not computed), so the
    # frame weighs and moves the hypotheses as before, bit for bit.
    model = _model(fov=np.deg2rad(120.0), max_range=8.0)
    L = np.array([[4.0, -2.0], [5.0, 0.5], [3.0, 2.5]])
    rng = np.random.default_rng(3)
    mu = np.column_stack([rng.normal(0, 0.05, 6), rng.normal(0, 0.05, 6), rng.normal(0, 0.02, 6)])
    P = np.tile(np.diag([1e-4, 1e-4, 1e-5]), (6, 1, 1))
    zs = np.array([_bearing(np.zeros(3), lm) for lm in L]) + np.deg2rad([0.4, -0.3, 0.8])
    ex = dataclasses.replace(model, exclusive=True)
    for a, b in zip(frame_update(mu, P, zs, L, model), frame_update(mu, P, zs, L, ex), strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(log_ratios(mu, zs, L, model), log_ratios(mu, zs, L, ex))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 6), update=st.booleans())
def test_exclusive_landmarks_never_weigh_a_frame_more(seed: int, k: int, update: bool) -> None:
    # Taking a landmark's reading away from all but one bearing can only lower the sum:
    # every pose earns at most what weighing the bearings on their own gives it.
    rng = np.random.default_rng(seed)
    model = _model(fov=np.deg2rad(90.0), max_range=7.0)
    L = np.column_stack([rng.uniform(1, 6, 6), rng.uniform(-2, 2, 6)])
    mu = np.column_stack([rng.normal(0, 0.3, (8, 2)), rng.normal(0, 0.2, 8)])
    P = np.tile(np.diag([0.05, 0.05, 0.01]), (8, 1, 1))
    zs = np.asarray(wrap(rng.uniform(-0.6, 0.6, k)), dtype=np.float64)
    ex = dataclasses.replace(model, exclusive=True)
    if update:
        a, b = frame_update(mu, P, zs, L, model)[2], frame_update(mu, P, zs, L, ex)[2]
    else:
        a, b = log_ratios(mu, zs, L, model), log_ratios(mu, zs, L, ex)
    assert np.all(b <= a + 1e-12)


def test_exclusive_landmarks_reaches_the_frame_model_and_is_checked() -> None:
    from omniloc import LandmarkMap
    from omniloc.errors import InputError
    from omniloc.track import TrackerConfig
    from omniloc.track.motion import MotionModel
    from omniloc.track.tracker import Tracker

    lm = LandmarkMap(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    sensor = SensorModel(sigma=SIGMA)
    on = Tracker(lm, sensor, MotionModel(), TrackerConfig(exclusive_landmarks=True))
    assert on._model.exclusive
    assert not Tracker(lm, sensor, MotionModel(), TrackerConfig())._model.exclusive
    with pytest.raises(InputError, match="exclusive_landmarks"):
        TrackerConfig(exclusive_landmarks="yes")  # type: ignore[arg-type]


def test_exclusive_landmarks_stay_finite_where_the_clutter_is_nearly_all_memory() -> None:
    # The most memory the configuration accepts (clutter_persistence just below 1: fresh
    # 2^-53) and no object near: a bearing's clutter density is nearly 0 and its readings
    # are ~1e18 times it. Ten bearings on a cluster of four landmarks: the sum over
    # assignments is a tiny share of the product; finite and far below it, never inf or NaN.
    model = dataclasses.replace(_model(), fresh=2.0**-53, object_var=1e-4)
    ex = dataclasses.replace(model, exclusive=True)
    L = np.array([[4.0, 1.0], [4.0, 1.04], [4.0, 0.96], [4.0, 1.08]])
    mu = np.array([[0.0, 0.0, 0.2]])
    zs = _bearing(mu[0], L[0]) + np.deg2rad(np.linspace(-0.5, 1.0, 10))
    objects = Objects(np.array([2.0]), np.zeros((1, 1)))
    plain = log_ratios_clutter(mu, zs, L, model, objects)[0][0]
    got = log_ratios_clutter(mu, zs, L, ex, objects)[0][0]
    assert np.isfinite(plain) and np.isfinite(got)
    assert got < plain - 100.0


def _occluded_cost(gap: float, width: float, update: bool) -> float:
    """ln ratio of an empty frame with a landmark 2 m ahead and one 4 m ahead whose line of
    sight passes ``gap`` metres beside the first (at the first's distance)."""
    model = dataclasses.replace(_model(fov=np.deg2rad(90.0), max_range=6.0), occlusion=width)
    # The second landmark's bearing is gap / 2 rad off the first's (gap metres at 2 m).
    L = np.array([[2.0, 0.0], [4.0 * math.cos(gap / 2.0), 4.0 * math.sin(gap / 2.0)]])
    mu = np.array([[0.0, 0.0, 0.0]])
    if update:
        P = np.diag([1e-6, 1e-6, 1e-8])[None]
        return float(frame_update(mu, P, np.zeros(0), L, model)[2][0])
    return float(log_ratios(mu, np.zeros(0), L, model)[0])


@pytest.mark.parametrize("update", [True, False])
def test_a_landmark_behind_a_nearer_one_is_not_expected_to_be_seen(update: bool) -> None:
    # Right behind: the farther landmark's miss costs nothing; far beside it: its full
    # ln(1 - p); in between: the notch 1 - exp(-l^2 / (2 w^2)) on its detection probability.
    p, w = 0.6, 0.04
    assert _occluded_cost(0.0, w, update) == pytest.approx(math.log(1 - p), rel=1e-6)
    assert _occluded_cost(1.0, w, update) == pytest.approx(2 * math.log(1 - p), rel=1e-6)
    f = 1.0 - math.exp(-0.5 * (0.05 / w) ** 2)
    want = math.log(1 - p) + math.log(1 - p * f)
    assert _occluded_cost(0.05, w, update) == pytest.approx(want, rel=1e-5)
    # Without occlusion the two misses cost in full wherever the second stands.
    assert _occluded_cost(0.0, 0.0, update) == pytest.approx(2 * math.log(1 - p), rel=1e-6)
    # A width whose square underflows still hides a landmark right behind, and only it.
    assert _occluded_cost(0.0, 1e-200, update) == pytest.approx(math.log(1 - p), rel=1e-6)
    assert _occluded_cost(1e-3, 1e-200, update) == pytest.approx(2 * math.log(1 - p), rel=1e-6)


def test_a_hidden_landmark_costs_no_miss_and_leaves_a_clear_ones_reading() -> None:
    # Landmark 1 right behind landmark 0; a bearing at landmark 2, which stands clear: its
    # reading and clutter posterior are the same with occlusion, and the frame costs one
    # miss fewer (the hidden landmark's).
    L = np.array([[2.0, 0.0], [4.0, 0.0], [3.0, 2.0]])
    mu = np.array([[0.0, 0.0, 0.0]])
    P = np.diag([1e-4, 1e-4, 1e-6])[None]
    plain = _model(fov=np.deg2rad(120.0), max_range=6.0)
    hidden = dataclasses.replace(plain, occlusion=0.04)
    z = np.array([_bearing(mu[0], L[2])])
    a = frame_update_clutter(mu, P, z, L, plain, None)
    b = frame_update_clutter(mu, P, z, L, hidden, None)
    assert b[2][0] - a[2][0] == pytest.approx(-math.log(1 - 0.6), rel=1e-6)
    np.testing.assert_allclose(b[4], a[4], rtol=1e-9)


def test_a_bearing_at_a_nearly_hidden_landmark_is_more_likely_clutter() -> None:
    # Landmark 1 passes 2 cm beside landmark 0 (at landmark 0's 2 m; its bearing 0.57 deg
    # off, 11 sigmas of a 0.05-deg sensor): a bearing at it is read as landmark 1 with
    # the detection probability the occlusion leaves it, 1 - exp(-(0.02 / 0.04)^2 / 2) of
    # the plain one, so clutter takes a larger share of it.
    L = np.array([[2.0, 0.0], [4.0, 0.04]])
    mu = np.array([[0.0, 0.0, 0.0]])
    P = np.diag([1e-10, 1e-10, 1e-12])[None]
    plain = dataclasses.replace(
        _model(fov=np.deg2rad(120.0), max_range=6.0), sigma2=np.deg2rad(0.05) ** 2
    )
    hidden = dataclasses.replace(plain, occlusion=0.04)
    z = np.array([_bearing(mu[0], L[1])])
    a = frame_update_clutter(mu, P, z, L, plain, None)
    b = frame_update_clutter(mu, P, z, L, hidden, None)
    assert b[4][0, 0] > 2.0 * a[4][0, 0]
    # The reading's odds by hand: d / (1 - d), d = p times the notch.
    f = 1.0 - math.exp(-0.5 * (2.0 * math.atan2(0.04, 4.0) / 0.04) ** 2)
    odds = lambda d: d / (1.0 - d)  # noqa: E731
    ratio = (1.0 / a[4][0, 0] - 1.0) / (1.0 / b[4][0, 0] - 1.0)
    assert ratio == pytest.approx(odds(0.6) / odds(0.6 * f), rel=1e-3)
