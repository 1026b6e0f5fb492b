"""What the data allow: how soon ANY localizer could honestly say ``localized`` on a stream.

A localizer over time is judged by when it is first right, how often it is right after, and
how soon it is right again after a kidnapping. Those figures mean little without what the
recording itself allows. This module bounds them with everything a localizer could be given
short of the answer: it is TOLD which landmark each bearing comes from (the frames' truth,
:attr:`omniloc.track.Frame.truth`; clutter is dropped), its odometry is linearised at the
true path, and it starts from no information about the pose.

Along the stream's true trajectory it runs the information filter of the bearings and the
odometry -- the recursion of the posterior Cramer-Rao bound (Tichavsky, Muravchik and
Nehorai, IEEE T-SP 1998) evaluated on the recorded path: the covariance no estimator beats
under the model linearised there.

* Between frames, the odometry's noise (a :class:`~omniloc.track.MotionModel`, integrated over
  the recorded velocities between the frames, its latency applied) moves the information as a
  Kalman prediction does, in information form (:func:`predict_information`), which holds
  while the information is still singular.
* At each frame every landmark bearing adds ``info * H^T H``, ``H`` its gradient at the true
  pose and ``info`` one bearing's Fisher information (:func:`bearing_information`: ``1 /
  sigma^2`` for a Gaussian, more for a sharp core with a heavier tail).

A frame *could be localized* when the pose there is within the tolerance (0.3 m, 5 deg) of
its estimate with probability ``p_min`` under that covariance (:func:`tolerance_probability`):
the earliest an honest localizer -- one that says ``localized`` only when it is that sure --
could say it and be right by design.

With ``repeat`` (:class:`RepeatingErrors`) the bearing errors are not independent: shares
of each one's variance are a bias common to every landmark, an offset common to the
frame's bearings and its landmark's own bias, the biases drifting and forgotten over their
time constants, as MRCLAM's errors are (:data:`MRCLAM_REPEATING`). The filter then also
carries the common bias and the bias of each landmark seen lately (the state augmented,
each bias an Ornstein-Uhlenbeck process; one not seen for five time constants is
marginalised out) and weighs a frame's bearings with their shared offset: a landmark seen
again soon after adds less than a new one, and a second landmark in the same frame adds
what their difference says.

What the bound leaves out makes it optimistic, so its times are lower bounds and its shares
upper bounds: the correspondences are known (ruling out the wrong places that fit is a real
localizer's hard part), the bearing errors as their model has them (independent from frame
to frame unless ``repeat`` says otherwise: a bound is only as good as the errors' fit), the
odometry's errors as the model's, without biases.
Left out, and so possibly in a real localizer's favour: the landmarks in view that were not
reported (weak evidence where few are: on MRCLAM a third of the tubes in view are reported
per frame) and the extent of the map (metres wide, against the 0.3 m asked).

* :func:`stream_bound` -- a stream's bound in the terms of
  :func:`~omniloc.evaluate.tracking.score_run`: the time from its start to the first frame
  that could be localized, the share of the frames from there on that could be, and the time
  from a kidnapping to the first frame after it that could be (the filter started afresh at
  the jump);
* :func:`times_to_localize` -- from each of many start frames, the time to the first frame
  that could be localized (a robot set down there knowing nothing);
* :func:`confident_frames` -- which frames could be localized, by a filter started at the
  first frame (and afresh at given frames).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import erf

from ..errors import InputError
from ..io import finite_number, real_array, shorten
from ..pose import _covariance, bearing_jacobian, fisher_information
from ..track.motion import MotionModel, between, compose, compose_jacobians, integrate
from ..track.tracker import within_tolerance

if TYPE_CHECKING:
    from .tracking import Stream

__all__ = [
    "MRCLAM_BEARING_ERRORS",
    "MRCLAM_REPEATING",
    "BoundSteps",
    "RepeatingErrors",
    "StreamBound",
    "bearing_information",
    "bound_steps",
    "confident_frames",
    "predict_information",
    "stream_bound",
    "times_to_localize",
    "tolerance_probability",
]

FloatArray = NDArray[np.float64]

#: MRCLAM set 6's bearing errors at the true poses (docs/tracking.md, measured against the
#: Vicon track): a mixture of zero-mean Gaussians, 57 % with an sd of 0.33 deg and 43 % with
#: 1.03 deg, as (shares, sds in radians). One such bearing is worth a Gaussian of 0.52 deg.
MRCLAM_BEARING_ERRORS: tuple[tuple[float, ...], tuple[float, ...]] = (
    (0.57, 0.43),
    (math.radians(0.33), math.radians(1.03)),
)


#: The longest time constant of repeating errors (seconds: a year).
MAX_TAU_S = 3.2e7
#: The largest share of a bearing's error variance that may repeat (the rest, independent,
#: is what a landmark seen again adds), and the share below which errors count as
#: independent (the difference below any bound's precision).
MAX_SHARE = 0.999999
MIN_SHARE = 1e-9
#: A landmark not seen for this many time constants leaves the filter's state (its bias
#: then as good as independent of the one it will have when seen again: exp(-5) = 0.007).
FORGET_TAUS = 5.0


@dataclass(frozen=True)
class RepeatingErrors:
    """Bearing errors that repeat: on each landmark from one sighting to the next, and on
    every landmark at once.

    A bearing's error variance ``1 / info`` (one bearing keeps the information the bound is
    given) splits into up to four parts:

    * ``share``: its landmark's own bias, which drifts (an Ornstein-Uhlenbeck process:
      stationary, its correlation ``exp(-lag / tau_s)``);
    * ``common_share``: a bias shared by every bearing, which drifts over ``common_tau_s``
      (what a camera's heading, its clock against the odometry's, or the robot's wobble
      add to all it sees);
    * ``frame_share``: an offset shared by the bearings of one frame and drawn afresh at
      the next;
    * the rest, independent from bearing to bearing.

    So a landmark seen once is worth what it is worth under independent errors, and seen
    again soon after, less: with ``share`` 0.8, ten sightings within a second are worth
    about 1.2 where independent ones are worth 10. A shared part moves every bearing as a
    turn of the robot would: it spares the differences between bearings, which place the
    robot, and the heading cannot be known better than it.

    Attributes
    ----------
    share : float
        The share of a bearing's error variance that is its landmark's own drifting bias
        (0, or below MIN_SHARE: none).
    tau_s : float
        The time constant over which a landmark's bias is forgotten, seconds (> 0).
    common_share : float, optional
        The share that is a drifting bias common to every bearing (0: none).
    common_tau_s : float, optional
        Its time constant, seconds (None: ``tau_s``).
    frame_share : float, optional
        The share common to the bearings of one frame, independent between frames (0: none).

    The shares are each in [0, MAX_SHARE] and so is their sum (some of each error
    independent); all below MIN_SHARE: independent errors, the bound without ``repeat``.

    Raises
    ------
    InputError
        A share outside [0, MAX_SHARE], shares summing beyond it, or a time constant that is
        not a number of seconds in (0, MAX_TAU_S].

    Notes
    -----
    The filter's state holds the common bias and one bias per landmark seen within the last
    ``FORGET_TAUS * tau_s`` seconds, and each frame costs the cube of its size (and, in
    :func:`times_to_localize`, that times the starts still running): on MRCLAM, up to 15
    tubes, the bound takes about 40 % longer than with independent errors; a recording
    that sees hundreds of landmarks within that time would take far longer.
    """

    share: float
    tau_s: float
    common_share: float = 0.0
    common_tau_s: float | None = None
    frame_share: float = 0.0

    def __post_init__(self) -> None:
        tau = finite_number(self.tau_s, "RepeatingErrors.tau_s")
        common_tau = (
            tau
            if self.common_tau_s is None
            else finite_number(self.common_tau_s, "RepeatingErrors.common_tau_s")
        )
        shares = {}
        for name in ("share", "common_share", "frame_share"):
            v = finite_number(getattr(self, name), f"RepeatingErrors.{name}")
            if not 0.0 <= v <= MAX_SHARE:
                raise InputError(
                    f"RepeatingErrors.{name} must lie in [0, {MAX_SHARE}] (some of each error "
                    f"independent), got {getattr(self, name)!r}"
                )
            shares[name] = v
        if sum(shares.values()) > MAX_SHARE:
            raise InputError(
                f"RepeatingErrors' shares must sum to at most {MAX_SHARE} (some of each error "
                f"independent), got {sum(shares.values())!r}"
            )
        for name, v, given in (
            ("tau_s", tau, self.tau_s),
            ("common_tau_s", common_tau, self.common_tau_s),
        ):
            if not 0.0 < v <= MAX_TAU_S:
                raise InputError(
                    f"RepeatingErrors.{name} must be a number of seconds in (0, "
                    f"{MAX_TAU_S:g}], got {given!r}"
                )
        for name, v in shares.items():
            object.__setattr__(self, name, v)
        object.__setattr__(self, "tau_s", tau)
        object.__setattr__(self, "common_tau_s", common_tau)

    @property
    def repeats(self) -> bool:
        """Whether any share is at least MIN_SHARE (else: independent errors)."""
        return max(self.share, self.common_share, self.frame_share) >= MIN_SHARE

    def describe(self) -> str:
        """The model in words, its parts as shares of the variance.

        Examples
        --------
        >>> for part in RepeatingErrors(0.13, 18.1, 0.68, 13.8).describe().split("; "):
        ...     print(part)
        68 % of their variance common to every landmark, forgotten over 13.8 s
        13 % each landmark's own, forgotten over 18.1 s
        >>> RepeatingErrors(0.0, 1.0).describe()
        'independent from frame to frame'
        """
        parts = [
            (share, what)
            for share, what in (
                (
                    self.common_share,
                    f"common to every landmark, forgotten over {self.common_tau_s:g} s",
                ),
                (self.frame_share, "common to one frame's bearings"),
                (self.share, f"each landmark's own, forgotten over {self.tau_s:g} s"),
            )
            if share >= MIN_SHARE
        ]
        if not parts:
            return "independent from frame to frame"
        return "; ".join(
            f"{100 * share:.0f} %{' of their variance' if k == 0 else ''} {what}"
            for k, (share, what) in enumerate(parts)
        )


#: MRCLAM set 6's repeating bearing errors: ``benchmarks/bearing_correlation.py`` fits the
#: errors at the true poses (maximum likelihood over each run's frames, the five runs) as a
#: bias common to every tube of sd 0.74 deg forgotten over 13.8 s (68 % of the variance),
#: an offset common to one frame's bearings of 0.35 deg (16 %), each tube's own bias of
#: 0.32 deg forgotten over 18.1 s (13 %) and independent noise of 0.17 deg (4 %). (Two
#: tubes' errors in one frame are correlated 0.54; one tube's two sightings 0.66 within
#: 0.3 s and 0.48 at 2.5-5 s. The fit with each tube's own bias alone, 78 % over 13.9 s,
#: was 0.24 nats a sighting less likely.)
MRCLAM_REPEATING = RepeatingErrors(
    share=0.005573**2 / (0.012877**2 + 0.005573**2 + 0.006184**2 + 0.003006**2),
    tau_s=18.1,
    common_share=0.012877**2 / (0.012877**2 + 0.005573**2 + 0.006184**2 + 0.003006**2),
    common_tau_s=13.8,
    frame_share=0.006184**2 / (0.012877**2 + 0.005573**2 + 0.006184**2 + 0.003006**2),
)

#: The narrowest bearing error sd :func:`bearing_information` takes (radians).
MIN_SD = 1e-9
#: The largest one bearing's information (1/rad^2: an sd of 3e-8 rad), tolerance in
#: position (m) and entry of a covariance or information matrix the bound takes.
MAX_INFO = 1e15
MAX_TOL_M = 1e6
MAX_ENTRY = 1e100

#: Draws of the Monte Carlo that settles a tolerance probability the bounds do not (a
#: standard error of 0.0005 at 0.99).
MC_DRAWS = 50_000


def bearing_information(shares: ArrayLike, sds: ArrayLike) -> float:
    """Fisher information (1/rad^2) of one bearing whose error is a zero-mean Gaussian
    mixture: ``int p'(e)^2 / p(e) de``.

    Parameters
    ----------
    shares : array_like, shape (k,)
        The components' shares (>= 0, not all 0; normalised here).
    sds : array_like, shape (k,)
        Their standard deviations, radians (from 1e-9 to 2 pi).

    Raises
    ------
    InputError
        Shares and sds that do not pair up, a share below 0 or all 0, an sd outside
        [1e-9, 2 pi].

    Examples
    --------
    >>> round(bearing_information([1.0], [0.5]), 6)  # a Gaussian: 1 / sd^2
    4.0
    """
    w = real_array(shares, "shares and sds: shares", InputError).reshape(-1)
    s = real_array(sds, "shares and sds: sds", InputError).reshape(-1)
    if (
        w.shape != s.shape
        or w.size == 0
        or not (np.isfinite(w).all() and np.isfinite(s).all())
        or (s < MIN_SD).any()
        or (s > 2 * math.pi).any()
        or (w < 0).any()
        or not w.max() > 0
    ):
        raise InputError(
            "shares and sds must pair up, the shares >= 0 and not all 0, the sds in "
            f"[{MIN_SD:g}, 2 pi] radians: got {_describe(shares)} and {_describe(sds)}"
        )
    w = w / w.max()
    w = w / w.sum()
    # The integrand is even: twice the integral over e >= 0, on a grid that is geometric from
    # far inside the sharpest component to far beyond the widest (exact to ~1e-7).
    e = np.concatenate([[0.0], np.geomspace(1e-4 * s.min(), 40.0 * s.max(), 20_000)])
    g = w * np.exp(-0.5 * (e[:, None] / s) ** 2) / (s * math.sqrt(2 * math.pi))
    p = g.sum(axis=1)
    dp = (-g * e[:, None] / s**2).sum(axis=1)
    ok = p > 0
    return float(2.0 * np.trapezoid(dp[ok] ** 2 / p[ok], e[ok]))


def predict_information(Y: FloatArray, F: FloatArray, N: FloatArray) -> FloatArray:
    """The Kalman prediction ``P' = F P F^T + N`` in information form.

    ``Y' = (I + Y~ N)^-1 Y~`` with ``Y~ = F^-T Y F^-1``: it holds for information matrices
    that are singular (a direction not observed yet) and for a singular ``N``.

    Parameters
    ----------
    Y : ndarray, shape (..., 3, 3)
        Information matrices (symmetric, positive semi-definite).
    F : ndarray, shape (3, 3)
        The motion's Jacobian with respect to the pose (invertible).
    N : ndarray, shape (3, 3)
        The motion noise's covariance in the world frame.
    """
    Y = _matrices("predict_information's Y", Y, (..., 3, 3))
    F = _matrices("predict_information's F", F, (3, 3))
    N = _matrices("predict_information's N", N, (3, 3))
    try:
        out = _predict(Y, F, N)
    except np.linalg.LinAlgError as exc:
        raise InputError(f"predict_information: F or I + Y~ N is singular ({exc})") from exc
    if not np.isfinite(out).all():
        raise InputError("predict_information: the prediction overflows (Y, F or N too large)")
    return out


def _predict(Y: FloatArray, F: FloatArray, N: FloatArray) -> FloatArray:
    """:func:`predict_information` without its checks, for the filter's own steps."""
    return _predict_inv(Y, np.asarray(np.linalg.inv(F), dtype=np.float64), N)


def _predict_inv(Y: FloatArray, Finv: FloatArray, N: FloatArray) -> FloatArray:
    """:func:`_predict` of any size, given ``F``'s inverse."""
    Yt = np.swapaxes(Finv, -1, -2) @ Y @ Finv
    Yn = np.linalg.solve(np.eye(Y.shape[-1]) + Yt @ N, Yt)
    return _symmetric(Yn)


def _symmetric(Y: NDArray[np.floating[Any]]) -> FloatArray:
    return np.asarray(0.5 * (Y + np.swapaxes(Y, -1, -2)), dtype=np.float64)


def _marginal(Y: FloatArray, keep: NDArray[np.int64], drop: NDArray[np.int64]) -> FloatArray:
    """The information of the entries ``keep`` of stacked information matrices ``Y`` with
    those of ``drop`` marginalised out (the Schur complement; ``drop``'s block invertible)."""
    Ykd = Y[:, keep][:, :, drop]
    Yk = Y[:, keep][:, :, keep] - Ykd @ np.linalg.solve(
        Y[:, drop][:, :, drop], np.swapaxes(Ykd, 1, 2)
    )
    return _symmetric(Yk)


class _Repeating:
    """Information filters over the pose, the common bias and the biases of the landmarks
    seen lately, one per start (``S`` of them, over the frames of ``steps``): the bound
    with repeating errors (:class:`RepeatingErrors`). The state is the pose, then the
    common bias (if ``common_share``), then one bias per landmark of ``lms`` (if
    ``share``); every start carries the same landmarks (a start not begun or done is
    carried but neither predicted nor updated). At each frame: :meth:`advance`, then
    :meth:`reset` for the starts that begin there, then :meth:`update`."""

    def __init__(self, steps: BoundSteps, info: float, repeat: RepeatingErrors, S: int) -> None:
        nb = int(steps.bearings.sum())
        if (
            steps.rows is None
            or steps.G is None
            or steps.rows.shape != (nb,)
            or (steps.G.shape != (nb, 3))
        ):
            raise InputError(
                "the bound with repeating errors needs each bearing's landmark and gradient "
                "(BoundSteps.rows and BoundSteps.G, as bound_steps fills them)"
            )
        self.steps = steps
        self.per_landmark = repeat.share >= MIN_SHARE
        self.var_b = repeat.share / info
        self.tau = repeat.tau_s
        #: Where the landmarks' biases begin in the state (after the common bias, if any).
        self.first = 4 if repeat.common_share >= MIN_SHARE else 3
        self.var_c = repeat.common_share / info
        assert repeat.common_tau_s is not None  # (RepeatingErrors fills it)
        self.tau_c = repeat.common_tau_s
        self.var_f = repeat.frame_share / info if repeat.frame_share >= MIN_SHARE else 0.0
        self.var_w = (1.0 - repeat.share - repeat.common_share - repeat.frame_share) / info
        self.off = np.concatenate([[0], np.cumsum(steps.bearings)])
        self.lms: list[int] = []
        self.seen: list[float] = []
        self.Y = np.tile(self._prior(self.first), (S, 1, 1))

    def _prior(self, n: int) -> FloatArray:
        """The information (state of size ``n``) of a start that knows nothing of the pose:
        each bias its prior."""
        Y0 = np.zeros((n, n))
        if self.first == 4:
            Y0[3, 3] = 1.0 / self.var_c
        d = np.arange(self.first, n)
        Y0[d, d] = 1.0 / self.var_b if self.per_landmark else 0.0
        return Y0

    def advance(self, i: int, which: NDArray[np.bool_]) -> None:
        """To frame ``i``: the landmarks not seen for ``FORGET_TAUS`` time constants
        marginalised out, the starts ``which`` predicted (from frame ``i - 1``), and a bias
        (at its prior) for each landmark the frame sees first."""
        st, t = self.steps, float(self.steps.t[i])
        f0 = self.first
        old = {k for k, ts in enumerate(self.seen) if t - ts > FORGET_TAUS * self.tau}
        if old:
            keep = np.array(
                list(range(f0)) + [f0 + k for k in range(len(self.lms)) if k not in old]
            )
            self.Y = _marginal(self.Y, keep, np.array([f0 + k for k in sorted(old)]))
            self.lms = [r for k, r in enumerate(self.lms) if k not in old]
            self.seen = [v for k, v in enumerate(self.seen) if k not in old]
        n = self.Y.shape[1]
        dt = t - float(st.t[i - 1]) if i > 0 else 0.0
        fresh = f0 == 4 and dt > FORGET_TAUS * self.tau_c
        if fresh:
            # The common bias forgotten (as a landmark's is): marginalised out, and drawn
            # afresh from its prior.
            rest = np.array([k for k in range(n) if k != 3])
            Y = np.zeros_like(self.Y)
            Y[:, rest[:, None], rest] = _marginal(self.Y, rest, np.array([3]))
            Y[:, 3, 3] = 1.0 / self.var_c
            self.Y = Y
        if i > 0 and which.any():
            Finv = np.zeros((n, n))
            Finv[:3, :3] = np.linalg.inv(st.F[i])
            Nt = np.zeros((n, n))
            Nt[:3, :3] = st.N[i]
            if f0 == 4:
                # (Kept: seen within FORGET_TAUS time constants, a >= exp(-5).)
                a = 1.0 if fresh else math.exp(-dt / self.tau_c)
                Finv[3, 3] = 1.0 / a
                Nt[3, 3] = self.var_c * (1.0 - a * a)
            if n > f0:
                # Every bias left was seen within FORGET_TAUS time constants: a >= exp(-5).
                a = math.exp(-dt / self.tau)
                b = np.arange(f0, n)
                Finv[b, b] = 1.0 / a
                Nt[b, b] = self.var_b * (1.0 - a * a)
            self.Y[which] = _predict_inv(self.Y[which], Finv, Nt)
        if not self.per_landmark:
            return
        assert st.rows is not None  # (checked in __init__)
        new = [
            r
            for r in dict.fromkeys(st.rows[self.off[i] : self.off[i + 1]].tolist())
            if r not in self.lms
        ]
        if new:
            m = n + len(new)
            Y = np.zeros((self.Y.shape[0], m, m))
            Y[:, :n, :n] = self.Y
            d = np.arange(n, m)
            Y[:, d, d] = 1.0 / self.var_b
            self.Y = Y
            self.lms.extend(new)
            self.seen.extend([t] * len(new))

    def reset(self, which: NDArray[np.bool_]) -> None:
        """The starts ``which`` begin afresh: nothing known of the pose, each bias its prior."""
        self.Y[which] = self._prior(self.Y.shape[1])

    def update(self, i: int, which: NDArray[np.bool_]) -> None:
        """Frame ``i``'s bearings into the starts ``which``: their errors' covariance is the
        independent part plus the frame's common offset, ``var_w I + var_f 1 1^T``."""
        st, lo, hi = self.steps, int(self.off[i]), int(self.off[i + 1])
        if hi == lo:
            return
        assert st.rows is not None and st.G is not None  # (checked in __init__)
        k = hi - lo
        H = np.zeros((k, self.Y.shape[1]))
        H[:, :3] = st.G[lo:hi]
        if self.first == 4:
            H[:, 3] = 1.0
        if self.per_landmark:
            col = {r: self.first + j for j, r in enumerate(self.lms)}
            H[np.arange(k), [col[r] for r in st.rows[lo:hi].tolist()]] = 1.0
        # (var_w I + var_f 1 1^T)^-1 = (I - var_f / (var_w + k var_f) 1 1^T) / var_w
        Rinv = (np.eye(k) - self.var_f / (self.var_w + k * self.var_f)) / self.var_w
        self.Y[which] += _symmetric(H.T @ Rinv @ H)
        if self.per_landmark:
            t = float(st.t[i])
            for r in st.rows[lo:hi].tolist():
                self.seen[col[r] - self.first] = t

    def pose(self, which: NDArray[np.bool_]) -> FloatArray:
        """The pose's information (the biases marginalised out) of the starts ``which``."""
        Y = self.Y[which]
        if Y.shape[1] == 3:
            return Y
        return _marginal(Y, np.arange(3), np.arange(3, Y.shape[1]))


def _describe(a: object) -> str:
    """A value as one short line (an array by its type and shape: numpy prints on many)."""
    if isinstance(a, np.ndarray):
        return f"an array of {a.dtype} of shape {a.shape}"
    return " ".join(shorten(a).split())


def _matrices(name: str, a: ArrayLike, shape: tuple[object, ...]) -> FloatArray:
    """``a`` as finite float64 of ``shape`` (``...``: any leading axes), entries at most
    MAX_ENTRY in magnitude, or an :class:`InputError` naming it."""
    m = real_array(a, name, InputError)
    fixed = shape[1:] if shape[0] is ... else shape
    if (
        m.ndim < len(fixed)
        or m.shape[m.ndim - len(fixed) :] != fixed
        or (shape[0] is not ... and m.ndim != len(fixed))
    ):
        dims = ", ".join(str(d) for d in fixed)
        want = f"(..., {dims})" if shape[0] is ... else f"({dims})"
        raise InputError(f"{name} must have shape {want}, got {m.shape}")
    if not np.isfinite(m).all() or (m.size and np.abs(m).max() > MAX_ENTRY):
        raise InputError(f"{name} must be finite, at most {MAX_ENTRY:g} in magnitude")
    return m


def _draws() -> FloatArray:
    return np.random.default_rng(0).standard_normal((MC_DRAWS, 3))


def _bounds(cov: FloatArray, tol_m: float, tol_heading: float) -> tuple[float, float]:
    """Lower and upper bounds of the tolerance probability of a zero-mean Gaussian error.

    Lower: the position's circle under its widest variance (Anderson's theorem) times the
    heading's share (the Gaussian correlation inequality). Upper: the smaller of the
    heading's share and the share of the strip along the widest position axis."""
    lam = max(float(np.linalg.eigvalsh(cov[:2, :2])[-1]), 1e-300)
    sd_h = math.sqrt(max(float(cov[2, 2]), 1e-300))
    hi = min(
        float(erf(tol_heading / (math.sqrt(2.0) * sd_h))),
        float(erf(tol_m / math.sqrt(2.0 * lam))),
    )
    return within_tolerance(cov, tol_m, tol_heading), hi


def tolerance_probability(
    cov: ArrayLike,
    tol_m: float = 0.3,
    tol_heading: float = math.radians(5.0),
    draws: FloatArray | None = None,
) -> float:
    """P(|position error| <= ``tol_m`` and |heading error| <= ``tol_heading``) for a
    zero-mean Gaussian pose error of covariance ``cov`` (3 x 3).

    Bounded below by the position's circle under its widest variance times the heading's
    share (the tracker's ``within_tolerance``), above by the smaller of the heading's share
    and that of the strip along the widest position axis; where the two agree within 1e-4
    the lower is returned, else a Monte Carlo of ``draws`` (standard normal rows, 50,000
    fixed ones by default: a standard error of 0.0005 at 0.99).

    Raises
    ------
    InputError
        A ``cov`` that is not a finite, symmetric, positive semi-definite 3 x 3 matrix;
        tolerances that are not numbers in (0, 1e6] m and (0, pi] rad.

    Examples
    --------
    >>> round(tolerance_probability(np.diag([1e-4, 1e-4, 1e-6])), 4)
    1.0
    """
    _positive("tol_m", tol_m, MAX_TOL_M)
    _positive("tol_heading", tol_heading, math.pi)
    c = _covariance(cov, "cov")
    if draws is not None:
        draws = _matrices("draws", draws, (..., 3))
        if draws.ndim != 2 or draws.shape[0] == 0:
            raise InputError(f"draws must have shape (n, 3) with n >= 1, got {draws.shape}")
    return _settle(c, tol_m, tol_heading, *_bounds(c, tol_m, tol_heading), draws)


def _settle(
    c: FloatArray, tol_m: float, tol_heading: float, lo: float, hi: float, draws: FloatArray | None
) -> float:
    """The tolerance probability from its bounds ``lo`` and ``hi``: the lower where they
    agree within 1e-4, else the share of the Monte Carlo ``draws`` within tolerance (the
    lower, an under-statement, when ``c`` has no Cholesky factor: a direction of no error)."""
    if hi - lo < 1e-4:
        return lo
    try:
        L = np.linalg.cholesky(0.5 * (c + c.T))
    except np.linalg.LinAlgError:
        return lo
    x = (_draws() if draws is None else draws) @ L.T
    ok = (np.hypot(x[:, 0], x[:, 1]) <= tol_m) & (np.abs(x[:, 2]) <= tol_heading)
    return float(ok.mean())


def _could_localize(
    Y: FloatArray, p_min: float, tol_m: float, tol_heading: float, draws: FloatArray
) -> bool:
    """Whether the information ``Y`` puts the pose within tolerance with probability
    ``p_min`` (False while it is singular: some direction not observed yet)."""
    ev = np.linalg.eigvalsh(Y)
    if not ev[0] > 1e-12 * max(ev[-1], 1e-300):
        return False
    cov = np.asarray(np.linalg.inv(Y), dtype=np.float64)
    lo, hi = _bounds(cov, tol_m, tol_heading)
    if hi < p_min:
        return False
    if lo >= p_min:
        return True
    return _settle(cov, tol_m, tol_heading, lo, hi, draws) >= p_min


@dataclass(frozen=True)
class BoundSteps:
    """A stream's frames as the information filter sees them (frames with ground truth).

    Attributes
    ----------
    t : ndarray, shape (k,)
        Frame times (stream time).
    F, N : ndarray, shape (k, 3, 3)
        The prediction from frame ``i - 1`` to frame ``i``: the motion's Jacobian with
        respect to the pose, and the odometry's noise in the world frame (the identity and
        zero at ``i = 0``).
    HtH : ndarray, shape (k, 3, 3)
        Sum over frame ``i``'s landmark bearings of ``H^T H``.
    bearings : ndarray of int, shape (k,)
        The landmark bearings of each frame.
    rows : ndarray of int, shape (sum of bearings,), optional
        The landmark (row of the map) of each bearing, frame after frame.
    G : ndarray, shape (sum of bearings, 3), optional
        The gradient of each bearing with respect to the pose (``HtH`` is the sum of
        ``G^T G`` over a frame's rows). These two are what the bound with repeating errors
        needs (:class:`RepeatingErrors`); :func:`bound_steps` fills them.
    """

    t: FloatArray
    F: FloatArray
    N: FloatArray
    HtH: FloatArray
    bearings: NDArray[np.int64]
    rows: NDArray[np.int64] | None = None
    G: FloatArray | None = None


def bound_steps(
    stream: Stream, motion: MotionModel, mount: Sequence[float] | None = None
) -> BoundSteps:
    """The information filter's steps along a stream's true trajectory.

    Frames outside the ground truth are left out (the odometry joins their neighbours);
    bearings without a true landmark (clutter) are dropped.

    Parameters
    ----------
    stream : Stream
    motion : MotionModel
    mount : sequence of 3 floats, optional
        Where the sensor sits on the robot, ``(x, y, yaw)`` (:attr:`omniloc.SensorModel.
        mount`): the bearings are taken from the sensor's pose, and their information about
        it carried to the robot's pose by the mount's Jacobian. None: at the robot's origin.

    Raises
    ------
    InputError
        A stream whose frames carry no truth (:attr:`Frame.truth`): the bound needs the
        correspondences; a mount that is not one (as :class:`~omniloc.SensorModel` says).
    """
    from ..sensor import _mount  # (the sensor's own check of a mount)

    seat = _mount(mount) if mount is not None else None
    if stream.frames and all(f.truth is None for f in stream.frames):
        raise InputError(
            f"{stream.name}: the frames carry no landmark truth (Frame.truth); the bound "
            "needs the correspondences"
        )
    t_all = np.array([f.t for f in stream.frames], dtype=np.float64)
    truth, _ = stream.truth_at(t_all) if t_all.size else (np.zeros((0, 3)), None)
    keep = np.asarray(np.isfinite(truth).all(axis=1), dtype=bool)
    frames = [f for f, k in zip(stream.frames, keep.tolist(), strict=True) if k]
    t = t_all[keep]
    poses = truth[keep]
    k = t.size
    F = np.tile(np.eye(3), (k, 1, 1))
    N = np.zeros((k, 3, 3))
    HtH = np.zeros((k, 3, 3))
    nb = np.zeros(k, dtype=np.int64)
    all_rows: list[int] = []
    grads: list[FloatArray] = []
    xy = stream.landmarks.xy
    for i, f in enumerate(frames):
        if i > 0:
            dt, v, w = stream.odometry.between(t[i - 1] - motion.delay_s, t[i] - motion.delay_s)
            _, Q = integrate(dt, v, w, motion)
            Jp, Jd = compose_jacobians(poses[i - 1], between(poses[i - 1], poses[i]))
            F[i] = Jp
            N[i] = Jd @ Q @ Jd.T
        rows = [r for r in (f.truth or ()) if r is not None]
        if rows:
            if seat is None:
                HtH[i] = fisher_information(xy[rows], poses[i], 1.0)
                g = bearing_jacobian(xy[rows], poses[i])[1]
            else:
                # d bearing / d robot = d bearing / d sensor . d (robot (+) mount) / d robot.
                J = compose_jacobians(poses[i], seat)[0]
                HtH[i] = J.T @ fisher_information(xy[rows], compose(poses[i], seat), 1.0) @ J
                g = bearing_jacobian(xy[rows], compose(poses[i], seat))[1] @ J
            nb[i] = len(rows)
            all_rows.extend(rows)
            grads.append(g)
    G = np.concatenate(grads) if grads else np.zeros((0, 3))
    return BoundSteps(t, F, N, HtH, nb, np.array(all_rows, dtype=np.int64), G)


def _indices(name: str, a: object, n: int) -> NDArray[np.int64]:
    """``a`` as a flat array of frame indices in [0, n), or an :class:`InputError`."""
    try:
        arr = np.asarray(a)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"{name} must be frame indices, got {_describe(a)}") from exc
    if arr.size == 0:
        return np.zeros(0, dtype=np.int64)
    if arr.ndim > 1 or arr.dtype.kind not in "iu" or arr.min() < 0 or arr.max() >= n:
        raise InputError(f"{name} must be frame indices in [0, {n}), got {_describe(a)}")
    return arr.reshape(-1).astype(np.int64)


def _positive(name: str, v: object, hi: float) -> float:
    """A finite number in (0, hi] (:func:`omniloc.io.finite_number`), or an
    :class:`InputError` naming it."""
    x = finite_number(v, name)
    if not 0.0 < x <= hi:
        raise InputError(f"{name} must be a number in (0, {hi:g}], got {_describe(v)}")
    return x


def _repeat(repeat: object) -> RepeatingErrors | None:
    """``repeat`` as the filters take it: None for independent errors (a share of 0 too),
    or an :class:`InputError` for what is not a :class:`RepeatingErrors`."""
    if repeat is None:
        return None
    if not isinstance(repeat, RepeatingErrors):
        raise InputError(f"repeat must be a RepeatingErrors or None, got {_describe(repeat)}")
    return repeat if repeat.repeats else None


def _check(info: float, p_min: float, tol_m: float, tol_heading: float) -> None:
    _positive("info", info, MAX_INFO)
    _positive("tol_m", tol_m, MAX_TOL_M)
    _positive("tol_heading", tol_heading, math.pi)
    ok = isinstance(p_min, (int, float, np.integer, np.floating)) and not isinstance(p_min, bool)
    if not (ok and 0.0 < p_min < 1.0):
        raise InputError(f"p_min must lie in (0, 1), got {_describe(p_min)}")


def confident_frames(
    steps: BoundSteps,
    info: float,
    p_min: float,
    *,
    restarts: Sequence[int] = (),
    tol_m: float = 0.3,
    tol_heading: float = math.radians(5.0),
    repeat: RepeatingErrors | None = None,
) -> NDArray[np.bool_]:
    """For each frame, whether the filter started at the first frame with no information
    (and again at each frame index of ``restarts``: a kidnapping) could call the pose
    localized there with probability ``p_min``; with ``repeat``, bearing errors that repeat
    (:class:`RepeatingErrors`).

    Examples
    --------
    Standing still, one bearing a frame at three landmarks in turn: from the third frame on.

    >>> import math
    >>> L = np.array([[3.0, 0.5], [2.5, -1.5], [4.0, 2.0]])
    >>> from omniloc.pose import bearing_jacobian
    >>> HtH = np.stack([bearing_jacobian(L[[i % 3]], np.zeros(3))[1] for i in range(5)])
    >>> HtH = np.einsum("kij,kil->kjl", HtH, HtH)
    >>> st = BoundSteps(np.arange(5.0), np.tile(np.eye(3), (5, 1, 1)),
    ...                 np.zeros((5, 3, 3)), HtH, np.ones(5, dtype=np.int64))
    >>> confident_frames(st, 1 / math.radians(0.3) ** 2, 0.99).tolist()
    [False, False, True, True, True]
    """
    _check(info, p_min, tol_m, tol_heading)
    repeat = _repeat(repeat)
    again = set(_indices("restarts", restarts, steps.t.size).tolist())
    draws = _draws()
    out = np.zeros(steps.t.size, dtype=bool)
    if repeat is not None:
        rf = _Repeating(steps, info, repeat, 1)
        on, off = np.ones(1, dtype=bool), np.zeros(1, dtype=bool)
        for i in range(steps.t.size):
            rf.advance(i, off if i in again else on)
            if i in again:
                rf.reset(on)
            rf.update(i, on)
            out[i] = _could_localize(rf.pose(on)[0], p_min, tol_m, tol_heading, draws)
        return out
    Y = np.zeros((3, 3))
    for i in range(steps.t.size):
        if i in again:
            Y = np.zeros((3, 3))
        elif i > 0:
            Y = _predict(Y, steps.F[i], steps.N[i])
        Y = Y + info * steps.HtH[i]
        out[i] = _could_localize(Y, p_min, tol_m, tol_heading, draws)
    return out


def times_to_localize(
    steps: BoundSteps,
    starts: ArrayLike,
    info: float,
    p_min: float,
    *,
    tol_m: float = 0.3,
    tol_heading: float = math.radians(5.0),
    repeat: RepeatingErrors | None = None,
) -> FloatArray:
    """For each start frame index, the time from it to the first frame (itself included) at
    which a filter started there with no information could call the pose localized with
    probability ``p_min``; inf when no frame of the stream does. With ``repeat``, bearing
    errors that repeat (:class:`RepeatingErrors`).

    All starts run at once: each frame predicts and updates the information of every start
    begun and not yet localized.
    """
    _check(info, p_min, tol_m, tol_heading)
    repeat = _repeat(repeat)
    s = _indices("starts", starts, steps.t.size)
    draws = _draws()
    out = np.full(s.size, np.inf)
    Y = np.zeros((s.size, 3, 3))
    rf = None if repeat is None else _Repeating(steps, info, repeat, s.size)
    active = np.zeros(s.size, dtype=bool)
    last = int(s.max()) if s.size else -1
    for i in range(steps.t.size):
        if rf is not None:
            rf.advance(i, active)
            rf.reset(s == i)
            active |= s == i
            rf.update(i, active)
            if active.any():
                Y[active] = rf.pose(active)
        else:
            if i > 0 and active.any():
                Y[active] = _predict(Y[active], steps.F[i], steps.N[i])
            active |= s == i
            Y[active] += info * steps.HtH[i]
        for j in np.flatnonzero(active):
            if _could_localize(Y[j], p_min, tol_m, tol_heading, draws):
                out[j] = steps.t[i] - steps.t[s[j]]
                active[j] = False
        if i >= last and not active.any():
            break
    return out


@dataclass(frozen=True)
class StreamBound:
    """What a localizer told the correspondences could do on one stream (see
    :func:`stream_bound`; inf: never within the stream, NaN: not defined)."""

    #: From the stream's start to the first frame (before any jump) that could be localized.
    time_to_localize_s: float
    #: The share of the frames from that one on that could be localized.
    correct_after_rate: float
    #: From the jump to the first frame after it that could be localized (NaN: no jump).
    recovery_s: float


def stream_bound(
    stream: Stream,
    motion: MotionModel,
    info: float,
    p_min: float,
    *,
    tol_m: float = 0.3,
    tol_heading: float = math.radians(5.0),
    mount: Sequence[float] | None = None,
    repeat: RepeatingErrors | None = None,
) -> StreamBound:
    """The bound on one stream, in the terms :func:`~omniloc.evaluate.tracking.score_run`
    scores a localizer by (its time to localize, correct-after share and recovery).

    The filter starts at the stream's first frame and afresh at its kidnapping, if any.

    Parameters
    ----------
    stream : Stream
        With the frames' landmark truth (:func:`~omniloc.evaluate.tracking.mrclam_streams`).
    motion : MotionModel
        The odometry's noise.
    info : float
        One bearing's Fisher information (:func:`bearing_information`).
    p_min : float
        How sure a localizer must be to say ``localized`` (a tracker's
        ``localized_probability``).
    tol_m, tol_heading : float
        The tolerance of a correct pose, metres and radians (of the robot's pose).
    mount : sequence of 3 floats, optional
        Where the sensor sits on the robot (:func:`bound_steps`).
    repeat : RepeatingErrors, optional
        Bearing errors that repeat (None: independent ones).
    """
    _check(info, p_min, tol_m, tol_heading)
    steps = bound_steps(stream, motion, mount)
    jump = stream.jump_t
    j = int(np.searchsorted(steps.t, jump, side="left")) if math.isfinite(jump) else steps.t.size
    ok = confident_frames(
        steps,
        info,
        p_min,
        restarts=[j] if j < steps.t.size else [],
        tol_m=tol_m,
        tol_heading=tol_heading,
        repeat=repeat,
    )
    pre = np.flatnonzero(ok[:j])
    ttl = float(steps.t[pre[0]] - stream.start) if pre.size else math.inf
    first = np.flatnonzero(ok)
    rate = float(ok[first[0] :].mean()) if first.size else math.nan
    recovery = math.nan
    if math.isfinite(jump):
        post = np.flatnonzero(ok[j:])
        recovery = float(steps.t[j + post[0]] - jump) if post.size else math.inf
    return StreamBound(ttl, rate, recovery)
