"""How a recording's bearing errors repeat: what the bound on what the data allow
(:mod:`omniloc.evaluate.bounds`, ``repeat=``) needs to know of them.

A localizer's evidence depends on more than one bearing's error spread: errors that repeat
from frame to frame add little when a landmark is seen again, and errors that every bearing
of a moment shares move them all as a turn of the robot would, so they cost the heading and
spare the differences between bearings, which place the robot. On MRCLAM set 6 both are
large: two different tubes' errors in one frame are correlated 0.54, and most of what
repeats is shared (``benchmarks/bearing_correlation.py``).

* :func:`sightings` -- each bearing of a known landmark with its error against the true pose;
* :func:`same_frame_correlation` -- how two landmarks' errors in one frame go together;
* :func:`fit_shared_biases` -- the errors as a drifting bias common to every landmark, an
  offset common to each frame, each landmark's own drifting bias and white noise (maximum
  likelihood), and :meth:`SharedBiasFit.repeating`, the :class:`~omniloc.evaluate.bounds.
  RepeatingErrors` the bound takes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .._kernels.errors import shared_bias_nll
from ..angles import wrap
from ..errors import InputError
from ..io import finite_number, real_array, shorten
from ..pose import predict_bearings
from .bounds import MAX_SHARE, RepeatingErrors

if TYPE_CHECKING:
    from .tracking import Stream

__all__ = [
    "FrameCorrelation",
    "SharedBiasFit",
    "Sightings",
    "fit_shared_biases",
    "same_frame_correlation",
    "shared_bias_likelihood",
    "sightings",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Errors beyond this (radians) are left out of :func:`sightings` by default: the heavy
#: tail a tracker's gate handles, not the errors' spread.
MAX_ERROR = math.radians(5.0)
#: The fewest sightings :func:`fit_shared_biases` fits, and the most likelihood
#: evaluations it may be asked for.
MIN_SIGHTINGS = 10
MAX_EVALUATIONS = 1_000_000


@dataclass(frozen=True)
class Sightings:
    """Bearings of known landmarks and their errors against the true poses, in time order
    within each run.

    Attributes
    ----------
    run, landmark : ndarray of int, shape (n,)
        Which run (stream) and which landmark (row of the map) each error is of.
    t : ndarray, shape (n,)
        The frame's time; the errors of one run at one time are one frame's.
    error : ndarray, shape (n,)
        Measured minus predicted bearing, radians.
    """

    run: IntArray
    landmark: IntArray
    t: FloatArray
    error: FloatArray

    def __post_init__(self) -> None:
        arrays = {
            "run": np.asarray(self.run),
            "landmark": np.asarray(self.landmark),
            "t": real_array(self.t, "Sightings.t", InputError).reshape(-1),
            "error": real_array(self.error, "Sightings.error", InputError).reshape(-1),
        }
        n = arrays["error"].size
        for name in ("run", "landmark"):
            a = arrays[name]
            if a.ndim != 1 or (a.size and a.dtype.kind not in "iu") or (a.size and a.min() < 0):
                raise InputError(
                    f"Sightings.{name} must be a flat array of indices >= 0, got an array of "
                    f"{a.dtype} of shape {a.shape}"
                )
            arrays[name] = a.astype(np.int64)
        if any(a.shape != (n,) for a in arrays.values()):
            raise InputError(
                "Sightings' run, landmark, t and error must have one entry each per sighting, "
                f"got shapes {[a.shape for a in arrays.values()]}"
            )
        if not (np.isfinite(arrays["t"]).all() and np.isfinite(arrays["error"]).all()):
            raise InputError("Sightings' times and errors must be finite")
        order = np.lexsort((arrays["t"], arrays["run"]))
        for name, a in arrays.items():
            object.__setattr__(self, name, a[order])

    @property
    def size(self) -> int:
        """How many sightings."""
        return int(self.error.size)


def sightings(streams: Sequence[Stream], max_error: float = MAX_ERROR) -> Sightings:
    """Every bearing of a known landmark (:attr:`~omniloc.track.Frame.truth`) in frames with
    a true pose (within :data:`~omniloc.evaluate.tracking.MAX_GAP_S` of a ground-truth
    sample), with its error against that pose; errors beyond ``max_error`` (radians) left
    out.

    Raises
    ------
    InputError
        ``max_error`` not a number of radians in (0, pi].
    """
    from .tracking import MAX_GAP_S

    limit = finite_number(max_error, "sightings' max_error")
    if not 0.0 < limit <= math.pi:
        raise InputError(f"sightings' max_error must lie in (0, pi] radians, got {max_error!r}")
    run: list[int] = []
    lm: list[int] = []
    ts: list[float] = []
    err: list[float] = []
    for k, st in enumerate(streams):
        t_all = np.array([f.t for f in st.frames], dtype=np.float64)
        if t_all.size == 0:
            continue
        truth, gaps = st.truth_at(t_all)
        L = st.landmarks.xy
        for f, x, gap in zip(st.frames, truth, gaps, strict=True):
            if f.truth is None or not (gap <= MAX_GAP_S and np.isfinite(x).all()):
                continue
            for b, row in zip(f.bearings, f.truth, strict=True):
                if row is None:
                    continue
                e = float(wrap(b - predict_bearings(L[row][None], x)[0]))
                if abs(e) <= limit:
                    run.append(k)
                    lm.append(int(row))
                    ts.append(float(f.t))
                    err.append(e)
    return Sightings(
        np.array(run, dtype=np.int64),
        np.array(lm, dtype=np.int64),
        np.array(ts, dtype=np.float64),
        np.array(err, dtype=np.float64),
    )


@dataclass(frozen=True)
class FrameCorrelation:
    """:func:`same_frame_correlation`'s figures."""

    #: Pairs of different landmarks' errors in one frame.
    pairs: int
    #: Their correlation, about the errors' overall mean and variance (NaN: no pair).
    correlation: float
    #: The sd of their differences over sqrt 2 (radians): what each error would have, were
    #: the pair's independent (NaN: no pair).
    difference_sd: float


def same_frame_correlation(s: Sightings) -> FrameCorrelation:
    """How two different landmarks' errors in one frame go together.

    Examples
    --------
    >>> s = Sightings([0, 0, 0, 0], [1, 2, 1, 2], [0.0, 0.0, 1.0, 1.0], [0.01, 0.01, -0.01, -0.01])
    >>> out = same_frame_correlation(s)
    >>> out.pairs, round(out.correlation, 2), out.difference_sd
    (2, 1.0, 0.0)
    """
    e = _sightings(s, "same_frame_correlation").error
    if e.size == 0:
        return FrameCorrelation(0, math.nan, math.nan)
    mean, var = float(e.mean()), float(e.var())
    prod: list[float] = []
    diff: list[float] = []
    for lo, hi in _frame_bounds(s):
        es = e[lo:hi]
        for i in range(es.size):
            for j in range(i + 1, es.size):
                prod.append((es[i] - mean) * (es[j] - mean))
                diff.append(es[i] - es[j])
    if not prod:
        return FrameCorrelation(0, math.nan, math.nan)
    return FrameCorrelation(
        len(prod),
        float(np.mean(prod) / var) if var > 0 else math.nan,
        float(np.std(diff) / math.sqrt(2.0)),
    )


def _sightings(s: object, where: str) -> Sightings:
    """``s`` if it is a :class:`Sightings`, else an :class:`InputError` naming ``where``."""
    if not isinstance(s, Sightings):
        raise InputError(f"{where} takes Sightings (see sightings()), got {shorten(s)}")
    return s


def _frame_bounds(s: Sightings) -> list[tuple[int, int]]:
    """Each frame's slice of the (sorted) sightings."""
    if s.size == 0:
        return []
    new = np.flatnonzero((np.diff(s.run) != 0) | (np.diff(s.t) != 0)) + 1
    edges = np.concatenate([[0], new, [s.size]])
    return list(zip(edges[:-1].tolist(), edges[1:].tolist(), strict=True))


@dataclass(frozen=True)
class SharedBiasFit:
    """:func:`fit_shared_biases`' maximum-likelihood model of the errors (radians and
    seconds): each error is ``common + landmark + frame + white``.

    Attributes
    ----------
    common_sd, common_tau_s : float
        The bias common to every landmark (an Ornstein-Uhlenbeck process: stationary sd,
        correlation time).
    landmark_sd, landmark_tau_s : float
        Each landmark's own bias (the same kind).
    frame_sd : float
        The offset common to one frame's bearings, drawn afresh at each frame.
    white_sd : float
        Independent noise.
    gain_per_sighting : float
        Its log-likelihood per sighting above independent Gaussian errors of the errors'
        own sd (nats).
    sightings, evaluations : int
        Errors fitted, and likelihood evaluations the fit took.
    converged : bool
        Whether the search met its tolerances within ``max_evaluations`` (False: the
        numbers are where it stopped, not a maximum).
    """

    common_sd: float
    common_tau_s: float
    landmark_sd: float
    landmark_tau_s: float
    frame_sd: float
    white_sd: float
    gain_per_sighting: float
    sightings: int
    evaluations: int
    converged: bool = True

    def shares(self) -> tuple[float, float, float, float]:
        """Each part's share of the variance (the stationary variances' sum): common,
        frame, landmark, white."""
        sds = np.array([self.common_sd, self.frame_sd, self.landmark_sd, self.white_sd])
        if not (np.isfinite(sds).all() and (sds >= 0).all() and (sds > 0).any()):
            raise InputError(
                "SharedBiasFit's sds (common, frame, landmark, white) must be finite, >= 0 "
                f"and not all 0, got {shorten(sds.tolist())}"
            )
        v = sds**2
        return tuple(float(x) for x in v / float(v.sum()))  # type: ignore[return-value]

    def repeating(self) -> RepeatingErrors:
        """The fit as the bound takes it (:class:`~omniloc.evaluate.bounds.RepeatingErrors`):
        the shares of the variance; the independent share at least ``1 - MAX_SHARE``."""
        common, frame, own, _ = self.shares()
        scale = min(1.0, MAX_SHARE / (common + frame + own)) if common + frame + own else 1.0
        return RepeatingErrors(
            share=own * scale,
            tau_s=self.landmark_tau_s,
            common_share=common * scale,
            common_tau_s=self.common_tau_s,
            frame_share=frame * scale,
        )


#: Longest and shortest time constants the fit searches (seconds), and the smallest sd
#: (radians): the search runs on their logarithms, within these bounds.
FIT_TAU_S = (0.05, 1e5)
FIT_MIN_SD = 1e-7


def _packed(s: Sightings) -> tuple[IntArray, IntArray, FloatArray, IntArray, IntArray]:
    """The sightings as the kernel reads them: runs' frame offsets, state sizes, frame
    times, frames' sighting offsets, each sighting's state column."""
    frames = _frame_bounds(s)
    frame_off = np.array([lo for lo, _ in frames] + [s.size], dtype=np.int64)
    frame_t = np.array([s.t[lo] for lo, _ in frames], dtype=np.float64)
    frame_run = np.array([s.run[lo] for lo, _ in frames], dtype=np.int64)
    runs = np.unique(frame_run)
    run_off = [*np.searchsorted(frame_run, runs, side="left").tolist(), len(frames)]
    cols = np.zeros(s.size, dtype=np.int64)
    state = np.zeros(runs.size, dtype=np.int64)
    for r, run in enumerate(runs.tolist()):
        on = s.run == run
        lms, inverse = np.unique(s.landmark[on], return_inverse=True)
        cols[on] = inverse + 1
        state[r] = lms.size + 1
    return np.array(run_off, dtype=np.int64), state, frame_t, frame_off, cols


def fit_shared_biases(s: Sightings, max_evaluations: int = 2000) -> SharedBiasFit:
    """Maximum-likelihood fit of the errors as a drifting bias common to every landmark, an
    offset common to each frame, each landmark's own drifting bias and white noise (a
    Kalman filter per run over the biases; Nelder-Mead on the six numbers' logarithms, at
    most ``max_evaluations`` evaluations).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_SIGHTINGS` sightings, errors all equal, or
        ``max_evaluations`` not a whole number in [1, :data:`MAX_EVALUATIONS`].

    Examples
    --------
    Errors that are one frame offset each, plus a little noise: most of the variance is the
    frame's.

    >>> rng = np.random.default_rng(0)
    >>> t = np.repeat(np.arange(300) * 0.25, 3)
    >>> e = np.repeat(rng.normal(0, 0.01, 300), 3) + rng.normal(0, 0.002, 900)
    >>> fit = fit_shared_biases(Sightings(np.zeros(900, int), np.tile([0, 1, 2], 300), t, e))
    >>> bool(fit.shares()[1] + fit.shares()[0] > 0.8), bool(fit.gain_per_sighting > 0.5)
    (True, True)
    """
    from scipy.optimize import minimize

    s = _sightings(s, "fit_shared_biases")
    if isinstance(max_evaluations, bool) or not isinstance(max_evaluations, (int, np.integer)):
        raise InputError(f"max_evaluations must be a whole number, got {shorten(max_evaluations)}")
    if not 1 <= max_evaluations <= MAX_EVALUATIONS:
        raise InputError(
            f"max_evaluations must lie in [1, {MAX_EVALUATIONS:,}], got {shorten(max_evaluations)}"
        )
    if s.size < MIN_SIGHTINGS:
        raise InputError(
            f"fit_shared_biases needs at least {MIN_SIGHTINGS} sightings, got {s.size}"
        )
    sd = float(s.error.std())
    if not (sd > 0 and np.ptp(s.error) > 0):
        raise InputError("fit_shared_biases: the errors are all equal (no spread to fit)")
    packed = _packed(s)
    lo = np.log([FIT_MIN_SD, FIT_TAU_S[0], FIT_MIN_SD, FIT_TAU_S[0], FIT_MIN_SD, FIT_MIN_SD])
    hi = np.log([1.0, FIT_TAU_S[1], 1.0, FIT_TAU_S[1], 1.0, 1.0])

    def nll(p: FloatArray) -> float:
        q = np.exp(np.clip(p, lo, hi))
        v = float(shared_bias_nll(q, *packed, s.error))
        return v if math.isfinite(v) else 1e300

    p0 = np.log([sd * 0.6, 10.0, sd * 0.3, 10.0, sd * 0.3, sd * 0.3])
    res = minimize(
        nll,
        p0,
        method="Nelder-Mead",
        options={"xatol": 2e-3, "fatol": 0.5, "maxfev": int(max_evaluations)},
    )
    sc, tc, sb, tb, sf, sw = (float(v) for v in np.exp(np.clip(res.x, lo, hi)))
    independent = 0.5 * s.size * (1.0 + math.log(2.0 * math.pi * sd * sd))
    return SharedBiasFit(
        common_sd=sc,
        common_tau_s=tc,
        landmark_sd=sb,
        landmark_tau_s=tb,
        frame_sd=sf,
        white_sd=sw,
        gain_per_sighting=(independent - float(res.fun)) / s.size,
        sightings=s.size,
        evaluations=int(res.nfev),
        converged=bool(res.success),
    )


def shared_bias_likelihood(s: Sightings, fit: SharedBiasFit | Sequence[float]) -> float:
    """Minus the log-likelihood of the sightings' errors under a shared-bias model (a fit,
    or its six numbers in :class:`SharedBiasFit`'s order: common sd and time constant,
    landmark sd and time constant, frame sd, white sd); inf where it is not defined."""
    s = _sightings(s, "shared_bias_likelihood")
    if isinstance(fit, SharedBiasFit):
        p: object = [
            fit.common_sd,
            fit.common_tau_s,
            fit.landmark_sd,
            fit.landmark_tau_s,
            fit.frame_sd,
            fit.white_sd,
        ]
    else:
        p = fit
    try:
        params = np.array(p, dtype=np.float64).reshape(-1)
        ok = params.shape == (6,) and bool(np.isfinite(params).all() and (params > 0).all())
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise InputError(
            "a shared-bias model is six positive numbers (sds and time constants), got "
            f"{shorten(fit)}"
        )
    if s.size == 0:
        return 0.0
    return float(shared_bias_nll(params, *_packed(s), s.error))
