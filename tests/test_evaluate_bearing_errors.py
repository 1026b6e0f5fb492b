"""How a recording's bearing errors repeat (omniloc.evaluate.bearing_errors): the sightings
against the truth, two landmarks' errors in one frame, and the shared-bias fit the bound on
what the data allow takes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from omniloc import LandmarkMap
from omniloc.errors import InputError
from omniloc.evaluate.bearing_errors import (
    SharedBiasFit,
    Sightings,
    fit_shared_biases,
    same_frame_correlation,
    shared_bias_likelihood,
    sightings,
)
from omniloc.evaluate.bounds import MAX_SHARE
from omniloc.evaluate.tracking import Segment, Stream
from omniloc.track import Frame, GroundTruth, Odometry

# Common sd, common time constant, landmark sd, landmark time constant, frame sd, white sd.
TRUTH = (math.radians(0.6), 8.0, math.radians(0.2), 8.0, math.radians(0.3), math.radians(0.15))


def _draw(rng: np.random.Generator, params: tuple[float, ...], frames: int) -> Sightings:
    """Errors drawn from the shared-bias model: one run, frames every 0.25 s, each seeing a
    random one to three of three landmarks."""
    sc, tc, sb, tb, sf, sw = params
    ac, ab = math.exp(-0.25 / tc), math.exp(-0.25 / tb)
    c, b = sc * rng.normal(), sb * rng.normal(size=3)
    run, lm, t, e = [], [], [], []
    for i in range(frames):
        c = ac * c + math.sqrt(1 - ac * ac) * sc * rng.normal()
        b = ab * b + np.sqrt(1 - ab * ab) * sb * rng.normal(size=3)
        f = sf * rng.normal()
        for n in rng.permutation(3)[: rng.integers(1, 4)]:
            run.append(0)
            lm.append(int(n))
            t.append(0.25 * i)
            e.append(float(c + b[n] + f + sw * rng.normal()))
    return Sightings(np.array(run), np.array(lm), np.array(t), np.array(e))


def test_the_likelihood_is_the_errors_gaussian_written_out() -> None:
    # Two runs, frames of one and two landmarks: minus the log-density of the errors under
    # their covariance written out pair by pair (common bias, each landmark's own, the
    # frame's offset, white), the runs independent of each other.
    s = Sightings(
        [0, 0, 0, 0, 0, 1, 1],
        [7, 9, 9, 7, 9, 7, 2],
        [0.0, 0.0, 0.3, 1.0, 1.0, 0.0, 0.4],
        [0.01, -0.004, 0.002, 0.006, 0.0, -0.003, 0.008],
    )
    params = (0.012, 4.0, 0.006, 9.0, 0.005, 0.003)
    sc, tc, sb, tb, sf, sw = params
    lag = np.abs(s.t[:, None] - s.t[None, :])
    same_run = np.equal.outer(s.run, s.run)
    C = same_run * (
        sc**2 * np.exp(-lag / tc)
        + sb**2 * np.exp(-lag / tb) * np.equal.outer(s.landmark, s.landmark)
        + sf**2 * np.equal.outer(s.t, s.t)
    ) + sw**2 * np.eye(s.size)
    want = 0.5 * (s.error @ np.linalg.solve(C, s.error) + np.linalg.slogdet(2 * math.pi * C)[1])
    assert shared_bias_likelihood(s, params) == pytest.approx(want, rel=1e-10)


def test_shared_errors_are_found_measured_and_handed_to_the_bound() -> None:
    # Most of each error shared (a drifting common bias and a frame offset), a little each
    # landmark's own: the likelihood is higher at the truth than with any part's sd moved
    # by half either way (the time constants are known less sharply from 6 minutes); the
    # fit finds most of the error shared and gains over independent errors; the
    # correlation of two landmarks in one frame is the shared share.
    s = _draw(np.random.default_rng(3), TRUTH, 1500)
    best = shared_bias_likelihood(s, TRUTH)
    for i in (0, 2, 4, 5):
        for f in (1.5, 1 / 1.5):
            moved = list(TRUTH)
            moved[i] *= f
            assert shared_bias_likelihood(s, moved) > best + 1.0
    fit = fit_shared_biases(s)
    assert fit.converged and not fit_shared_biases(s, max_evaluations=5).converged
    common, frame, own, _ = fit.shares()
    assert sum(fit.shares()) == pytest.approx(1.0)
    assert common + frame > 0.6 and fit.gain_per_sighting > 0.3
    assert fit.common_sd == pytest.approx(TRUTH[0], rel=0.4)
    assert fit.frame_sd == pytest.approx(TRUTH[4], rel=0.25)
    assert shared_bias_likelihood(s, fit) <= best + 1.0  # (the fit at least as likely)
    rep = fit.repeating()
    assert (rep.common_share, rep.frame_share, rep.share) == pytest.approx((common, frame, own))
    assert (rep.common_tau_s, rep.tau_s) == (fit.common_tau_s, fit.landmark_tau_s)
    same = same_frame_correlation(s)
    shared = (TRUTH[0] ** 2 + TRUTH[4] ** 2) / sum(TRUTH[k] ** 2 for k in (0, 2, 4, 5))
    assert same.correlation == pytest.approx(shared, abs=0.15)
    assert same.difference_sd < 0.5 * float(np.std(s.error))


def test_independent_errors_are_fitted_as_white_noise() -> None:
    rng = np.random.default_rng(4)
    n = 900
    s = Sightings(
        np.zeros(n, int),
        np.tile([0, 1, 2], n // 3),
        np.repeat(np.arange(n // 3), 3),
        rng.normal(0, 0.01, n),
    )
    fit = fit_shared_biases(s)
    assert fit.shares()[3] > 0.8 and abs(fit.gain_per_sighting) < 0.02
    assert abs(same_frame_correlation(s).correlation) < 0.1


def test_a_fit_that_leaves_nothing_independent_still_makes_a_bound_model() -> None:
    fit = SharedBiasFit(0.01, 10.0, 0.01, 10.0, 0.01, 1e-9, 1.0, 100, 10)
    rep = fit.repeating()
    assert rep.share + rep.common_share + rep.frame_share == pytest.approx(MAX_SHARE)


def test_sightings_are_the_known_landmarks_errors_against_the_truth() -> None:
    # Robot at the origin facing +x; landmark 0 straight ahead seen 1 deg to the left,
    # landmark 1 seen 8 deg off (left out: the tail), a clutter bearing (no id: left out);
    # a frame beyond the ground truth's reach is left out too.
    lm = LandmarkMap(np.array([[3.0, 0.0], [0.0, 3.0], [-3.0, 0.0]]))
    t = np.array([0.0, 1.0])
    truth = GroundTruth(t, np.zeros(2), np.zeros(2), np.zeros(2))
    z = np.array([math.radians(1.0), math.radians(98.0), 0.3])
    frames = [Frame(0.5, z, truth=(0, 1, None)), Frame(1.9, z[:1], truth=(0,))]
    odo = Odometry(t, np.zeros(2), np.zeros(2))
    stream = Stream("s", lm, odo, frames, (Segment(0.0, 2.0, 0.0, truth, "test"),))
    s = sightings([stream])
    assert s.size == 1 and (s.run[0], s.landmark[0], s.t[0]) == (0, 0, 0.5)
    assert s.error[0] == pytest.approx(math.radians(1.0))
    assert same_frame_correlation(s).pairs == 0
    assert sightings([stream], max_error=math.radians(10.0)).size == 2  # (the 8-deg one too)
    for bad in (0.0, -1.0, 4.0, math.nan, "wide"):
        with pytest.raises(InputError, match="max_error"):
            sightings([stream], max_error=bad)  # type: ignore[arg-type]


def test_sightings_are_kept_in_time_order_within_each_run() -> None:
    s = Sightings([1, 0, 0, 1], [0, 1, 0, 2], [0.5, 2.0, 1.0, 0.0], [0.1, 0.2, 0.3, 0.4])
    assert s.run.tolist() == [0, 0, 1, 1] and s.t.tolist() == [1.0, 2.0, 0.0, 0.5]
    assert s.error.tolist() == [0.3, 0.2, 0.4, 0.1]


@pytest.mark.parametrize(
    "args, match",
    [
        (([0], [0], [0.0, 1.0], [0.1]), "one entry each"),
        (([0.5], [0], [0.0], [0.1]), "indices"),
        (([-1], [0], [0.0], [0.1]), "indices"),
        (([0], [0], [math.nan], [0.1]), "finite"),
        (([0], [0], [0.0], [math.inf]), "finite"),
        (([0], [0], [0.0], ["a"]), "Sightings.error"),
    ],
)
def test_sightings_that_are_not_are_refused(args: tuple[object, ...], match: str) -> None:
    with pytest.raises(InputError, match=match):
        Sightings(*args)  # type: ignore[arg-type]


def test_what_cannot_be_fitted_is_refused() -> None:
    few = Sightings(np.zeros(5, int), np.arange(5), np.arange(5.0), np.linspace(0, 0.01, 5))
    with pytest.raises(InputError, match="at least 10 sightings"):
        fit_shared_biases(few)
    flat = Sightings(np.zeros(20, int), np.arange(20) % 2, np.arange(20.0), np.full(20, 0.01))
    with pytest.raises(InputError, match="all equal"):
        fit_shared_biases(flat)
    s = _draw(np.random.default_rng(1), TRUTH, 20)
    for bad in (0, -3, 2.5, True, "many", 10**7, 10**400):
        with pytest.raises(InputError, match="max_evaluations"):
            fit_shared_biases(s, max_evaluations=bad)  # type: ignore[arg-type]
    for call in (
        fit_shared_biases,
        same_frame_correlation,
        lambda x: shared_bias_likelihood(x, TRUTH),
    ):
        with pytest.raises(InputError, match="takes Sightings"):
            call([0.1, 0.2])  # type: ignore[operator, arg-type]
    for model in ((1.0, 2.0), (0.01, 1.0, 0.01, 1.0, 0.01, 0.0), (0.01, 1.0, 0.01, math.nan, 1, 1)):
        with pytest.raises(InputError, match="six positive numbers"):
            shared_bias_likelihood(s, model)


@pytest.mark.parametrize(
    "sds", [(0.0, 0.0, 0.0, 0.0), (0.01, math.nan, 0.01, 0.01), (0.01, 0.01, -0.01, 0.01)]
)
def test_a_fit_without_a_spread_has_no_shares(sds: tuple[float, float, float, float]) -> None:
    common, frame, own, white = sds
    fit = SharedBiasFit(common, 10.0, own, 10.0, frame, white, 0.0, 100, 10)
    with pytest.raises(InputError, match="SharedBiasFit's sds"):
        fit.shares()
    with pytest.raises(InputError, match="SharedBiasFit's sds"):
        fit.repeating()
