"""The motion model: exact integration of constant twists, composition, noise propagation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc.errors import InputError
from omniloc.track.motion import (
    MotionModel,
    between,
    compose,
    compose_jacobians,
    integrate,
    inverse,
    move,
    twist_of,
)

angles = st.floats(-np.pi, np.pi - 1e-9)
coords = st.floats(-20, 20)
poses = st.tuples(coords, coords, angles).map(np.array)


def test_constant_turn_is_an_exact_circular_arc() -> None:
    # v = 0.5 m/s, w = 0.25 rad/s for 4 s: a 1 rad arc of radius 2 m, in 1 or 400 pieces.
    for pieces in (1, 7, 400):
        d, _ = integrate(
            np.full(pieces, 4.0 / pieces),
            np.full(pieces, 0.5),
            np.full(pieces, 0.25),
            MotionModel(),
        )
        assert d == pytest.approx([2.0 * np.sin(1.0), 2.0 * (1.0 - np.cos(1.0)), 1.0], abs=1e-12)


def test_straight_line_and_turn_in_place() -> None:
    d, _ = integrate([2.0], [0.3], [0.0], MotionModel())
    assert d == pytest.approx([0.6, 0.0, 0.0], abs=1e-15)
    d, _ = integrate([2.0], [0.0], [-0.5], MotionModel())
    assert d == pytest.approx([0.0, 0.0, -1.0], abs=1e-15)


def test_scales_and_the_slowdown_in_turns() -> None:
    # v = 0.5 m/s, w = 0.25 rad/s for 4 s, the turn scaled by 0.8 and the velocity by 1.1
    # less 40 % per rad/s of turn (10 % at 0.25 rad/s): an arc of 0.8 rad at 0.495 m/s.
    model = MotionModel(v_scale=1.1, w_scale=0.8, turn_slowdown=0.4)
    for pieces in (1, 9):
        d, _ = integrate(
            np.full(pieces, 4.0 / pieces), np.full(pieces, 0.5), np.full(pieces, 0.25), model
        )
        r = 0.495 / 0.2
        assert d == pytest.approx([r * np.sin(0.8), r * (1.0 - np.cos(0.8)), 0.8], abs=1e-12)
    # The turn's noise is of the turn made (0.8 rad), not of the one the odometry says.
    plain = MotionModel(turn_per_rad=0.02, turn_per_m=0.0, turn_per_s=0.0)
    scaled = MotionModel(turn_per_rad=0.02, turn_per_m=0.0, turn_per_s=0.0, w_scale=0.8)
    assert integrate([4.0], [0.0], [0.25], scaled)[1][2, 2] == pytest.approx(0.02 * 0.8)
    assert integrate([4.0], [0.0], [0.25], plain)[1][2, 2] == pytest.approx(0.02 * 1.0)
    # Beyond 1 / turn_slowdown rad/s the robot turns in place; straight ahead it goes at
    # v * v_scale; the sideways velocity takes the same factor.
    d, _ = integrate([2.0], [0.5], [-3.0], model)
    assert d == pytest.approx([0.0, 0.0, -4.8], abs=1e-12)
    d, _ = integrate([2.0], [0.5], [0.0], model)
    assert d == pytest.approx([1.1, 0.0, 0.0], abs=1e-12)
    d, _ = integrate([2.0], [0.0], [0.0], model, vy=[0.5])
    assert d == pytest.approx([0.0, 1.1, 0.0], abs=1e-12)
    # Without a slowdown the velocity takes v_scale alone, at any turn rate.
    d, _ = integrate([4.0], [0.5], [0.25], MotionModel(v_scale=1.1))
    r = 0.55 / 0.25
    assert d == pytest.approx([r * np.sin(1.0), r * (1.0 - np.cos(1.0)), 1.0], abs=1e-12)


def test_sideways_twist_of_an_increment_round_trips() -> None:
    delta = np.array([0.4, -0.2, 0.7])
    tw = twist_of(delta, 2.0)
    d, _ = integrate([2.0], [tw[0]], [tw[2]], MotionModel(), vy=[tw[1]])
    assert d == pytest.approx(delta, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(poses, poses)
def test_compose_between_inverse(a: np.ndarray, b: np.ndarray) -> None:
    d = between(a, b)
    assert np.allclose(compose(a, d)[:2], b[:2], atol=1e-9)
    assert abs(np.angle(np.exp(1j * (compose(a, d)[2] - b[2])))) < 1e-9
    back = compose(compose(a, d), inverse(d))
    assert np.allclose(back[:2], a[:2], atol=1e-9)
    assert abs(np.angle(np.exp(1j * (back[2] - a[2])))) < 1e-9


def test_compose_jacobians_match_finite_differences() -> None:
    p = np.array([1.0, -2.0, 0.7])
    d = np.array([0.3, 0.1, -0.4])
    Jp, Jd = compose_jacobians(p, d)
    eps = 1e-7
    for k in range(3):
        e = np.zeros(3)
        e[k] = eps
        num_p = (compose(p + e, d) - compose(p - e, d)) / (2 * eps)
        num_d = (compose(p, d + e) - compose(p, d - e)) / (2 * eps)
        assert np.allclose(Jp[:, k], num_p, atol=1e-6)
        assert np.allclose(Jd[:, k], num_d, atol=1e-6)


def test_noise_grows_with_motion_not_with_sampling() -> None:
    m = MotionModel(
        along_per_m=0.01, across_per_m=0.001, turn_per_rad=0.02, turn_per_s=0.0, along_per_s=0.0
    )
    _, Q1 = integrate([2.0], [0.5], [0.2], m)
    _, Q100 = integrate(np.full(100, 0.02), np.full(100, 0.5), np.full(100, 0.2), m)
    # heading variance is exactly additive; the rest agrees to first order
    assert Q1[2, 2] == pytest.approx(Q100[2, 2], rel=1e-12)
    assert np.trace(Q100) > 0.0
    _, Q_still = integrate([2.0], [0.0], [0.0], m)
    assert np.allclose(Q_still, 0.0)


def test_propagated_covariance_matches_monte_carlo(rng: np.random.Generator) -> None:
    """First-order propagation of per-piece noise against sampling the pieces' noise."""
    m = MotionModel(
        along_per_m=0.004,
        across_per_m=0.0005,
        turn_per_rad=0.01,
        turn_per_m=0.0,
        turn_per_s=0.0,
        along_per_s=0.0,
    )
    n, k = 50, 4000
    dt, v, w = 0.1, 0.4, 0.3
    d0, Q = integrate(np.full(n, dt), np.full(n, v), np.full(n, w), m)
    step, _ = integrate([dt], [v], [w], MotionModel())
    sd = np.sqrt([m.along_per_m * v * dt, m.across_per_m * v * dt, m.turn_per_rad * w * dt])
    pose = np.zeros((k, 3))
    for _ in range(n):
        pose = compose(pose, step + rng.normal(0.0, sd, size=(k, 3)))
    pose[:, 2] = d0[2] + np.angle(np.exp(1j * (pose[:, 2] - d0[2])))
    emp = np.cov(pose.T)
    assert np.allclose(pose.mean(axis=0), d0, atol=0.01)
    # first-order propagation against 4000 samples: variances within 12 %
    assert np.allclose(np.diag(emp), np.diag(Q), rtol=0.12)
    assert abs(emp[0, 2] - Q[0, 2]) < 0.15 * np.sqrt(Q[0, 0] * Q[2, 2])


def test_delay_var_adds_heading_noise_at_each_change_of_the_turn_rate() -> None:
    base = MotionModel(turn_per_rad=0.01, turn_per_m=0.0, turn_per_s=1e-4)
    lag = MotionModel(turn_per_rad=0.01, turn_per_m=0.0, turn_per_s=1e-4, delay_var=0.004)
    dt = np.full(6, 0.1)
    v = np.full(6, 0.2)
    # a turn rate that flips its sign row by row: five changes of 0.8 rad/s
    w = np.array([0.4, -0.4, 0.4, -0.4, 0.4, -0.4])
    (d0, Q0), (d1, Q1) = integrate(dt, v, w, base), integrate(dt, v, w, lag)
    assert d1 == pytest.approx(d0, abs=0.0)  # the mean motion is the odometry's
    # heading variances add exactly: five changes of 0.8 rad/s at 0.004 s^2
    assert Q1[2, 2] - Q0[2, 2] == pytest.approx(5 * 0.004 * 0.8**2, rel=1e-12)
    # a steady twist, sampled as finely, gains nothing; a piece of zero duration between
    # two equal twists is no change
    steady = np.full(6, 0.4)
    assert np.array_equal(integrate(dt, v, steady, lag)[1], integrate(dt, v, steady, base)[1])
    dz = np.array([0.1, 0.0, 0.1])
    _, Qz = integrate(dz, [0.2, 0.2, 0.2], [0.4, -3.0, 0.4], lag)
    assert np.array_equal(Qz, integrate(dz, [0.2, 0.2, 0.2], [0.4, 9.0, 0.4], base)[1])


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(0.0, 0.5), st.floats(-0.5, 0.5), st.floats(-2.0, 2.0)),
        min_size=1,
        max_size=12,
    ),
    st.floats(1e-4, 0.05),
)
def test_delay_var_heading_noise_is_the_changes_between_the_pieces_that_move(
    pieces: list[tuple[float, float, float]], lag: float
) -> None:
    # Heading variances add along the pieces whatever they are: the difference is lag times
    # the squared changes of the turn rate between consecutive pieces of positive duration.
    dt, v, w = (np.array(c) for c in zip(*pieces, strict=True))
    base = MotionModel(turn_per_rad=0.01, turn_per_s=1e-4)
    _, Q0 = integrate(dt, v, w, base)
    _, Q1 = integrate(dt, v, w, MotionModel(turn_per_rad=0.01, turn_per_s=1e-4, delay_var=lag))
    moving = w[dt > 0]
    assert Q1[2, 2] - Q0[2, 2] == pytest.approx(lag * np.sum(np.diff(moving) ** 2), abs=1e-12)
    assert np.all(np.linalg.eigvalsh(Q1 - Q0) > -1e-12)  # it only adds noise


def test_delay_var_matches_boundaries_moved_by_a_random_response_time(
    rng: np.random.Generator,
) -> None:
    """The change's noise, cross terms and frame included, against moving each boundary
    between two pieces by a response time drawn with variance ``delay_var``."""
    var = 0.003
    m = MotionModel(
        along_per_m=0.0, across_per_m=0.0, turn_per_rad=0.0, turn_per_m=0.0, turn_per_s=0.0,
        along_per_s=0.0, delay_var=var,
    )  # fmt: skip
    dt = np.array([0.6, 0.5, 0.7, 0.4])
    vx = np.array([0.3, 0.1, 0.4, 0.2])
    vy = np.array([0.0, 0.05, -0.05, 0.0])
    w = np.array([0.5, -0.6, 0.2, 0.9])
    d0, Q = integrate(dt, vx, w, m, vy=vy)
    k = 4000
    e = rng.normal(0.0, np.sqrt(var), size=(k, 3))
    out = np.empty((k, 3))
    for i in range(k):
        shifted = dt.copy()
        shifted[:-1] += e[i]  # each boundary moved by its own response time
        shifted[1:] -= e[i]
        out[i] = integrate(shifted, vx, w, MotionModel(), vy=vy)[0]
    emp = np.cov(out.T)
    assert np.allclose(out.mean(axis=0), d0, atol=0.005)
    assert np.allclose(np.diag(emp), np.diag(Q), rtol=0.1)
    for a, b in ((0, 1), (0, 2), (1, 2)):
        assert abs(emp[a, b] - Q[a, b]) < 0.1 * np.sqrt(Q[a, a] * Q[b, b])


def test_bad_input() -> None:
    with pytest.raises(InputError, match="turn_per_rad"):
        MotionModel(turn_per_rad=-1.0)
    with pytest.raises(InputError, match="delay_s"):
        MotionModel(delay_s=float("nan"))
    with pytest.raises(InputError, match="same shape"):
        integrate([1.0, 2.0], [0.1], [0.0], MotionModel())
    with pytest.raises(InputError, match="durations"):
        integrate([-1.0], [0.1], [0.0], MotionModel())
    with pytest.raises(InputError, match="positive duration"):
        twist_of([1.0, 0.0, 0.0], 0.0)
    assert MotionModel(delay_s=-0.1).delay_s == -0.1  # odometry stamped late
    with pytest.raises(InputError, match="w_scale must be finite and > 0"):
        MotionModel(w_scale=0.0)
    with pytest.raises(InputError, match="turn_slowdown must be finite and >= 0"):
        MotionModel(turn_slowdown=-0.5)
    with pytest.raises(InputError, match="turn_slowdown=1e\\+03 is implausibly large"):
        MotionModel(turn_slowdown=1e3)
    with pytest.raises(InputError, match="delay_var must be finite and >= 0"):
        MotionModel(delay_var=-1e-3)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: compose([np.nan, 0.0, 0.0], [1.0, 0.0, 0.0]), r"pose must be finite"),
        (lambda: compose([0.0, 0.0, 0.0], [1.0, np.inf, 0.0]), r"delta must be finite"),
        (lambda: between([0.0, 0.0, 0.0], "abc"), r"b must be a numeric array"),
        (lambda: inverse([1.0, 2.0]), r"delta must have shape \(3,\) or \(n, 3\), got \(2,\)"),
        (lambda: inverse(np.zeros((2, 2, 3))), r"got \(2, 2, 3\)"),
        (lambda: compose_jacobians([[0, 0, 1j]], [0, 0, 0]), r"pose must contain real numbers"),
        (
            lambda: compose(np.zeros((2, 3)), np.zeros((5, 3))),
            r"pose and delta: .*\(2, 3\) and \(5, 3\)",
        ),
        (lambda: between(np.zeros((4, 3)), np.zeros((3, 3))), r"a and b: .*\(4, 3\) and \(3, 3\)"),
        (lambda: compose_jacobians(np.zeros((2, 3)), np.zeros((3, 3))), r"pose and delta: "),
    ],
)
def test_se2_functions_refuse_what_is_not_poses(call: object, match: str) -> None:
    # Public functions (omniloc.track.compose and its kin): a NaN pose is an error naming the
    # argument, never a NaN answer; shapes that do not pair are named, not numpy's message.
    with pytest.raises(InputError, match=match):
        call()  # type: ignore[operator]


def test_se2_functions_take_a_pose_object() -> None:
    from omniloc import Pose

    got = compose(Pose(1.0, 2.0, np.pi / 2), [1.0, 0.0, 0.0])
    np.testing.assert_allclose(got, [1.0, 3.0, np.pi / 2], atol=1e-12)


@settings(max_examples=60, deadline=None)  # (the first call may compile the kernel)
@given(st.lists(poses, min_size=1, max_size=6), poses, st.integers(0, 2**31 - 1))
def test_moving_gaussians_is_composition_and_first_order_propagation(
    ps: list[np.ndarray], delta: np.ndarray, seed: int
) -> None:
    """The compiled move against the formula it implements, written with numpy:
    ``compose`` and ``Jp P Jp^T + Jd Q Jd^T``, symmetric."""
    r = np.random.default_rng(seed)
    mu = np.array(ps)
    A = r.normal(size=(len(ps), 3, 3)) * 0.3
    P = A @ np.swapaxes(A, 1, 2)
    B = r.normal(size=(3, 3)) * 0.05
    Q = B @ B.T
    d = delta * 0.1
    new, P2 = move(mu, P, d, Q)
    Jp, Jd = compose_jacobians(mu, d)
    want = Jp @ P @ np.swapaxes(Jp, 1, 2) + Jd @ Q @ np.swapaxes(Jd, 1, 2)
    np.testing.assert_array_equal(new, compose(mu, d))
    np.testing.assert_allclose(P2, want, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(P2, np.swapaxes(P2, 1, 2))


def test_move_refuses_shapes_it_cannot_read() -> None:
    mu, P, d, Q = np.zeros((2, 3)), np.zeros((2, 3, 3)), np.zeros(3), np.zeros((3, 3))
    assert move(mu[:0], P[:0], d, Q)[0].shape == (0, 3)
    with pytest.raises(InputError, match="poses of shape"):
        move(mu[:, :2], P, d, Q)
    with pytest.raises(InputError, match="poses of shape"):
        move(mu, P[:1], d, Q)
    with pytest.raises(InputError, match="motion of shape"):
        move(mu, P, d[:2], Q)
    with pytest.raises(InputError, match="motion of shape"):
        move(mu, P, d, Q[:2])
