"""Fit the motion model to a recording with ground truth: how late the odometry is, how far
off its scale, and how much noise it gathers per metre, per radian and per second.

A user with a robot of their own has odometry and, for a while, a ground-truth track (a
motion-capture system, a survey): :func:`estimate_motion` turns them into the
:class:`~omniloc.track.MotionModel` that the tracker needs (the ``mrclam`` preset's values
were fitted by hand before this existed; ``docs/tracking.md`` compares the two). Three steps:

1. **Latency** (``delay_s``): over stretches of ``delay_stretch_s`` seconds all along the
   recording, the relative motion the odometry predicts (its rows shifted by each delay of
   the grid) against the truth's; the delay with the smallest squared error (metres and
   radians alike) wins.
2. **Scale** (``w_scale``, ``v_scale``, ``turn_slowdown``): at that delay, the
   least-squares factor between the odometry's turns over the same stretches and the truth's;
   then, at that turn scale, the least-squares factors of the truth's displacements on the
   odometry's, split in two parts -- its velocities, and its velocities times the absolute
   turn rate (a robot that goes less far while it turns: :class:`MotionModel`'s
   ``turn_slowdown``; kept at 0 unless the fit finds it). A scale that is not positive (a
   turn rate clockwise positive, another run's truth) is refused. The delay is then found
   again at those scales.
3. **Noise**: over non-overlapping stretches of each length in ``stretch_s``, the error of
   the predicted relative motion against the truth's; the seven noise values are the maximum
   of the Gaussian likelihood of those errors under the covariance the model propagates
   (:func:`~omniloc.track.motion.integrate`: linear in the seven values), a small floor
   standing for the truth's own noise. A second pass leaves out the stretches whose error is
   beyond the 99.9 % chi-square bound (the truth's glitches, a wheel that slipped once).

Several runs of one robot are fitted together by pooling their stretches, each cut from its
own run (:func:`estimate_motion` takes a list of each run's odometry and a list of their
tracks).

:func:`estimate_frame_sensor` does the same for the bearing sensor from frames of bearings
and the truth (no landmark ids needed): each bearing is taken as the landmark whose bearing
from the true pose is nearest, within a gate; then the noise (robust spread of those
errors), how it grows with the turn rate (:func:`turn_noise_fit`), the detection probability
of a landmark plainly in view, and the clutter per frame; and the errors as a sharp core and a
wider tail (:func:`fit_core_and_tail`: two zero-mean Gaussians by EM, kept only where the
likelihood's gain pays for the two extra parameters), the tracker's ``core_share`` and
``core_sigma``.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize
from scipy.special import erf

from ..angles import wrap
from ..errors import InputError
from ..io import shorten
from ..maps import LandmarkMap, as_landmark_map
from ..pose import compose
from ..sensor import SensorModel, chi2_quantile, clutter_by_detections
from .config import TrackerConfig
from .data import Frame, GroundTruth, Odometry
from .likelihood import FrameModel
from .motion import MOTION_MAX, MotionModel, between, integrate

log = logging.getLogger(__name__)

__all__ = [
    "CoreTailFit",
    "MotionCheck",
    "MotionFit",
    "MountFit",
    "SensorCheck",
    "SensorFit",
    "bias_by_bearing",
    "check_motion",
    "check_sensor",
    "empty_frame_times",
    "estimate_frame_sensor",
    "estimate_motion",
    "estimate_mount",
    "fit_core_and_tail",
    "turn_noise_fit",
]

FloatArray = NDArray[np.float64]
#: A stretch's odometry: the pieces' durations (s), forward velocities (m/s), turn rates
#: (rad/s) and sideways velocities (m/s).
Pieces = tuple[FloatArray, FloatArray, FloatArray, FloatArray]
_T = TypeVar("_T")

#: The noise values in the order of :attr:`MotionModel.noise`.
NOISE_FIELDS = (
    "along_per_m",
    "across_per_m",
    "turn_per_rad",
    "turn_per_m",
    "turn_per_s",
    "along_per_s",
    "delay_var",
)
#: Variance (m^2, m^2, rad^2) the ground truth's own error adds to a relative motion.
TRUTH_FLOOR = (1e-6, 1e-6, 1e-6)
#: Fewest stretches the noise fit needs.
MIN_STRETCHES = 20
#: Largest latency (s) and stretch length (s) accepted: beyond, nothing a robot records.
MAX_DELAY_S = 60.0
MAX_STRETCH_S = 3600.0


@dataclass(frozen=True)
class MotionFit:
    """What :func:`estimate_motion` found.

    Attributes
    ----------
    model : MotionModel
        The fitted model.
    delays : ndarray, shape (D,)
        The latencies tried (s) ...
    delay_cost : ndarray, shape (D,)
        ... and the mean squared error of the relative motions at each (at the fitted scale).
    stretches : int
        Stretches the noise was fitted on (after the second pass).
    left_out : int
        Stretches the second pass left out.
    stretches_by_run : tuple of int
        Stretches each run gave the noise fit (those without a gap in the truth, before the
        second pass; ``stretches + left_out`` in all), in the order the runs were given: a
        run that gave none did not count.
    jumps : int
        Stretches of the latency's length left out of the latency and the scales: a jump in
        the truth (:data:`JUMP_SIGMAS`).
    """

    model: MotionModel
    delays: FloatArray
    delay_cost: FloatArray
    stretches: int
    left_out: int
    stretches_by_run: tuple[int, ...] = ()
    jumps: int = 0


def _seconds(values: ArrayLike, name: str, what: str) -> FloatArray:
    """A non-empty 1-D array of finite numbers of seconds, or an InputError naming ``name``."""
    try:
        a = np.atleast_1d(np.asarray(values, dtype=np.float64))
    except (TypeError, ValueError, OverflowError):
        a = np.zeros((0, 0))
    if a.ndim != 1 or a.size == 0 or not np.isfinite(a).all():
        raise InputError(f"{name} must be {what} in seconds, got {shorten(values)}")
    return a


def _positive(name: str, value: object, top: float) -> None:
    """An InputError naming ``name`` unless ``value`` is a real number in ``(0, top]``."""
    if not (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and math.isfinite(value)
        and 0 < value <= top
    ):
        raise InputError(
            f"{name} must be a positive number (at most {top:g}), got {shorten(value)}"
        )


#: Most stretches of one length a run is cut into (a length of nanoseconds would ask for
#: billions).
MAX_STRETCHES = 1_000_000


def _stretches(t0: float, t1: float, length: float, step: float, name: str) -> FloatArray:
    """Starts of stretches ``[a, a + length]`` inside ``[t0, t1]``, ``step`` apart; more
    than :data:`MAX_STRETCHES` of them, an InputError naming ``name`` (the argument that
    gave the length)."""
    if t1 - t0 < length:
        return np.zeros(0)
    count = (t1 - length - t0) / step + 1.0
    if not count <= MAX_STRETCHES:
        raise InputError(
            f"{name}: stretches of {length:.3g} s, {step:.3g} s apart, over the {t1 - t0:.1f} s "
            f"the odometry and the truth share would be {count:.3g}, at most {MAX_STRETCHES:,}: "
            "take longer stretches"
        )
    return np.arange(t0, t1 - length + 1e-9, step)


def _true_motion(truth: GroundTruth, a: FloatArray, b: FloatArray, max_gap_s: float) -> FloatArray:
    """The truth's relative motion over each ``[a, b]`` (NaN where the track has a gap)."""
    pa, ga = truth.at(a)
    pb, gb = truth.at(b)
    rel = between(pa, pb)
    bad = ~(np.isfinite(pa).all(axis=1) & np.isfinite(pb).all(axis=1))
    bad |= (ga > max_gap_s) | (gb > max_gap_s)
    rel[bad] = np.nan
    return np.asarray(rel)


def _predicted(
    odometry: Odometry, a: FloatArray, b: FloatArray, model: MotionModel, *, sideways: bool = False
) -> tuple[FloatArray, FloatArray, list[Pieces]]:
    """The odometry's relative motion over each ``[a, b]`` (its rows describe the motion
    from ``t + delay_s``), its covariance, and the pieces of each. ``sideways`` False: the
    forward motion and turns alone, the motion the fit is of (the pieces' sideways
    velocities zeros); True: with the odometry's sideways part, as the tracker moves by it."""
    out = np.empty((a.size, 3))
    cov = np.empty((a.size, 3, 3))
    pieces = []
    for k, (s, e) in enumerate(zip(a, b, strict=True)):
        dt, v, w, vy = odometry.pieces(s - model.delay_s, e - model.delay_s)
        if not sideways:
            vy = np.zeros_like(vy)
        out[k], cov[k] = integrate(dt, v, w, model, vy)
        pieces.append((dt, v, w, vy))
    return out, cov, pieces


def _clean_stretches(
    truth: GroundTruth,
    span: tuple[float, float],
    length: float,
    max_gap_s: float,
    name: str,
) -> tuple[FloatArray, FloatArray]:
    """The non-overlapping stretches of ``length`` s (given by the argument ``name``) within
    ``span`` where the truth has no gap longer than ``max_gap_s``: their starts (n,) and the
    truth's relative motion over each (n, 3)."""
    a = _stretches(span[0], span[1], length, length, name)
    true = _true_motion(truth, a, a + length, max_gap_s)
    ok = np.isfinite(true).all(axis=1)
    return a[ok], true[ok]


def _errors(true: FloatArray, pred: FloatArray) -> FloatArray:
    """Truth minus prediction, the heading wrapped."""
    r = true - pred
    r[:, 2] = np.asarray(wrap(r[:, 2]))
    return np.asarray(r)


#: A stretch whose relative motion misses the odometry's by more than this many robust
#: standard deviations (1.4826 median absolute deviations, of its position or its heading
#: error, over all stretches) holds a jump in the truth: it is left out of the latency and
#: the scales (:func:`estimate_motion`). Odometry's own errors, heavy-tailed as they are,
#: stay far within it (MRCLAM's five runs: none beyond).
JUMP_SIGMAS = 20.0
#: Floors of those standard deviations (m, rad): a simulated odometry without noise.
JUMP_FLOOR = (0.01, 0.01)


def _without_jumps(
    runs: list[tuple[Odometry, FloatArray, FloatArray]], length: float, model: MotionModel
) -> list[tuple[Odometry, FloatArray, FloatArray]]:
    """``runs`` without the stretches (``[a, a + length]``) whose error at ``model`` is
    beyond :data:`JUMP_SIGMAS` robust standard deviations (:data:`JUMP_FLOOR` at least), in
    position or in heading; ``runs`` itself when there are none, or when they would leave
    fewer than :data:`MIN_STRETCHES`."""
    errs = [_errors(true, _predicted(o, a, a + length, model)[0]) for o, a, true in runs]
    e = np.concatenate(errs)
    if e.shape[0] == 0:
        return runs
    parts = (np.hypot(e[:, 0], e[:, 1]), np.abs(e[:, 2]))
    limits = [
        JUMP_SIGMAS * max(1.4826 * float(np.median(np.abs(x - np.median(x)))), floor)
        + float(np.median(x))
        for x, floor in zip(parts, JUMP_FLOOR, strict=True)
    ]
    out, kept = [], 0
    for (o, a, true), r in zip(runs, errs, strict=True):
        ok = (np.hypot(r[:, 0], r[:, 1]) <= limits[0]) & (np.abs(r[:, 2]) <= limits[1])
        out.append((o, a[ok], true[ok]))
        kept += int(ok.sum())
    if kept == e.shape[0] or kept < MIN_STRETCHES:
        return runs
    return out


def _delay_costs(
    runs: list[tuple[Odometry, FloatArray, FloatArray]],
    length: float,
    delays: FloatArray,
    model: MotionModel,
) -> FloatArray:
    """At each delay, the mean squared error (metres and radians alike) of the relative
    motions over every run's stretches ``[a, a + length]`` (each run as ``(odometry, a,
    true motion)``), pooled."""
    cost = np.empty(delays.size)
    for i, d in enumerate(delays):
        m = replace(model, delay_s=float(d))
        squared = [
            np.sum(_errors(true, _predicted(odometry, a, a + length, m)[0]) ** 2, axis=1)
            for odometry, a, true in runs
        ]
        cost[i] = float(np.mean(np.concatenate(squared)))
    return cost


#: Least total angle (rad) the odometry must turn over the stretches for ``w_scale`` to be
#: fitted (a robot that hardly turns keeps 1).
MIN_TURN_FOR_SCALE = 2 * math.pi
#: Stretches on which the odometry turns more than this (rad) do not count for ``w_scale``:
#: the true turn, a relative heading, is known only within a half turn either way.
MAX_TURN_FOR_SCALE = 2.5
#: Largest condition number of the two-factor fit of the velocity (``v_scale`` and
#: ``turn_slowdown``) before it falls back to ``v_scale`` alone (a robot that never turns
#: while moving, or only ever turns at one rate, cannot tell the two apart).
MAX_SCALE_CONDITION = 1e6
#: ``turn_slowdown`` is kept only when its fit lies this many standard errors above zero.
SLOWDOWN_SIGMAS = 4.0


def _fit_scales(
    runs: list[tuple[Odometry, FloatArray, FloatArray]],
    length: float,
    model: MotionModel,
    turn_scales: bool = True,
) -> MotionModel:
    """``w_scale``, ``v_scale`` and ``turn_slowdown`` at ``model``'s latency, by least squares
    over every run's stretches ``[a, a + length]`` (each run as ``(odometry, a, true
    motion)``): the true turns against the odometry's, then, at that turn scale, the true
    displacements against the odometry's two parts -- its velocities, and its velocities
    times the absolute turn rate -- which the displacement is linear in (the positions are
    integrals of the velocity along headings that the turn rates alone set). Without
    ``turn_scales``, ``v_scale`` alone."""
    unit = replace(model, v_scale=1.0, w_scale=1.0, turn_slowdown=0.0)
    true = np.concatenate([t for _, _, t in runs])
    turn, parts = np.zeros(0), []
    for odometry, a, _ in runs:
        pred, _, pieces = _predicted(odometry, a, a + length, unit)
        turn = np.concatenate([turn, pred[:, 2]])  # (the angle turned, not wrapped)
        parts += pieces
    w_scale = 1.0
    fair = np.abs(turn) <= MAX_TURN_FOR_SCALE
    if turn_scales and float(np.abs(turn[fair]).sum()) >= MIN_TURN_FOR_SCALE:
        w_scale = float(np.sum(true[fair, 2] * turn[fair]) / np.sum(turn[fair] ** 2))
        if not 0.0 < w_scale <= MOTION_MAX["w_scale"]:
            raise InputError(
                f"the odometry's turns and the truth's do not agree (a scale of "
                f"{w_scale:.3g} between them): are they of the same run, and is the turn "
                "rate counter-clockwise positive?"
            )
    at = replace(unit, w_scale=w_scale)
    p0 = np.stack([integrate(dt, v, w, at)[0][:2] for dt, v, w, _ in parts])
    p1 = np.stack([integrate(dt, v * np.abs(w), w, at)[0][:2] for dt, v, w, _ in parts])
    if not float(np.sum(p0**2)) > 0:
        raise InputError("the odometry never moves in the span it shares with the truth")
    # true ~ v_scale * p0 - (v_scale * turn_slowdown) * p1 (the true displacement along the
    # predicted one: its length would be biased upwards by the noise across it).
    A = np.stack([p0.ravel(), -p1.ravel()], axis=1)
    b = true[:, :2].ravel()
    v_scale, slowdown = float(np.sum(b * A[:, 0]) / np.sum(A[:, 0] ** 2)), 0.0
    if turn_scales and np.linalg.cond(A) <= MAX_SCALE_CONDITION:
        both, rss, _, _ = np.linalg.lstsq(A, b, rcond=None)
        # Kept only where the recording tells it from none: at least SLOWDOWN_SIGMAS
        # standard errors above zero (a noisy run fits a small one of either sign).
        var = float(rss[0]) / max(b.size - 2, 1) if rss.size else 0.0
        se = math.sqrt(var * float(np.linalg.inv(A.T @ A)[1, 1]))
        if both[0] > 0 and both[1] > SLOWDOWN_SIGMAS * se:
            v_scale, slowdown = float(both[0]), float(both[1] / both[0])
    if not 0.0 < v_scale <= MOTION_MAX["v_scale"]:
        raise InputError(
            f"the odometry's velocities and the truth's motion do not agree (a scale of "
            f"{v_scale:.3g} between them): are they of the same run?"
        )
    slowdown = min(slowdown, MOTION_MAX["turn_slowdown"])
    return replace(model, v_scale=v_scale, w_scale=w_scale, turn_slowdown=slowdown)


def _paired(
    first: object, truth: object, one: Callable[[object, str], _T], name: str, run: str
) -> list[tuple[_T, GroundTruth]]:
    """One run (``first`` and its ``truth``) or several (a list of each, paired in order) as
    a list of pairs; ``one(item, where)`` checks one run's ``first`` (called ``name``; a run
    is called ``run`` in messages)."""
    if isinstance(truth, GroundTruth):
        try:
            return [(one(first, name), truth)]
        except InputError as exc:
            raise InputError(
                f"{exc} (for several {run}s, a list of each: {name} and truth, paired in order)"
            ) from None
    if not isinstance(truth, (list, tuple)):
        raise InputError(
            f"truth must be a GroundTruth or a list of them (one per {run}), got "
            f"{type(truth).__name__}"
        )
    if not isinstance(first, (list, tuple)) or len(first) != len(truth):
        n = len(first) if isinstance(first, (list, tuple)) else "one"
        raise InputError(
            f"{n} {name} and {len(truth)} ground-truth tracks: for several {run}s, {name} and "
            f"truth must both be lists of as many, paired in order"
        )
    if not truth:
        raise InputError(f"no {run} given: {name} and truth are empty lists")
    out = []
    for k, (f, g) in enumerate(zip(first, truth, strict=True)):
        if not isinstance(g, GroundTruth):
            raise InputError(
                f"truth of {run} {k + 1} must be a GroundTruth, got {type(g).__name__}"
            )
        out.append((one(f, f"{name} of {run} {k + 1}"), g))
    return out


def _odometry(item: object, where: str) -> Odometry:
    """``item`` if it is an Odometry, or an InputError naming ``where``."""
    if not isinstance(item, Odometry):
        raise InputError(f"{where} must be an Odometry, got {type(item).__name__}")
    return item


def _by_run(counts: Sequence[int]) -> str:
    """``counts`` of each run, for a message: "run 1: 3, run 2: 0" (the first ten)."""
    text = ", ".join(f"run {k + 1}: {c}" for k, c in enumerate(counts[:10]))
    return text + (f", ... ({len(counts)} runs)" if len(counts) > 10 else "")


def estimate_motion(
    odometry: Odometry | Sequence[Odometry],
    truth: GroundTruth | Sequence[GroundTruth],
    *,
    stretch_s: ArrayLike = (0.5, 1.0, 2.0, 5.0, 10.0),
    delays: ArrayLike | None = None,
    delay_stretch_s: float = 2.0,
    max_gap_s: float = 0.5,
    turn_scales: bool = True,
) -> MotionFit:
    """Fit a :class:`~omniloc.track.MotionModel` to odometry and a ground-truth track of the
    same run, or to several runs of one robot together (see the module's documentation for
    the method).

    Parameters
    ----------
    odometry : Odometry, or a list of them
        One run's odometry; for several runs fitted together, a list (or tuple) of each
        run's.
    truth : GroundTruth, or a list of them
        The true track over (part of) the same time; several runs: one track each, in the
        order of ``odometry``.
    stretch_s : array_like of float
        Lengths (s) of the stretches the noise is fitted on (each length's stretches do not
        overlap); several lengths tell noise per second from noise per metre.
    delays : array_like of float, optional
        Latencies to try (s); default -0.5 to 0.5 s in steps of 0.05 s, then steps of
        0.01 s within 0.05 s of the best.
    delay_stretch_s : float
        Length (s) of the stretches the latency and scale are fitted on (half overlapping).
    max_gap_s : float
        Stretches whose ends fall where the truth has a gap longer than this are left out.
    turn_scales : bool
        Fit ``w_scale`` and ``turn_slowdown`` too (the default); False: ``v_scale`` alone,
        the others left at 1 and 0 (the fit before 2026-12-05).

    Returns
    -------
    MotionFit

    Raises
    ------
    InputError
        The odometry and the truth overlap too little for the fit (fewer than
        MIN_STRETCHES stretches, all runs together), lists of runs of unequal length, empty
        or holding anything but Odometry (GroundTruth), or an argument out of range.

    Notes
    -----
    Several runs: each run's stretches are cut from its own odometry and truth, over the
    span both cover less the largest delay of the grid at either end (so a stretch never
    spans two runs, and the runs' clocks may overlap or not: no time is shifted); then all
    the stretches are pooled for the latency, the scale and the noise, as one run's would
    be. A run too short for any stretch of a length gives none of that length (and a run
    whose odometry and truth do not overlap, none at all: see
    :attr:`MotionFit.stretches_by_run`); only the pool must reach MIN_STRETCHES. One run
    given as a list of one gives the same fit as given bare.
    """
    pairs = _paired(odometry, truth, _odometry, "odometry", "run")
    for n, (odo, _) in enumerate(pairs, 1):
        # The fit is of a wheeled robot's motion (forward and turning): say what it leaves out.
        if odo.vy is not None:
            dt = np.diff(odo.t)
            side = float(np.abs(odo.vy[:-1]) @ dt)
            path = float(np.hypot(odo.v[:-1], odo.vy[:-1]) @ dt)
            if side > max(0.01 * path, 0.05):
                log.warning(
                    "run %d: the odometry moves sideways by %.2f m over a path of %.2f m; the "
                    "motion model is fitted to its forward motion and turns, without it",
                    n,
                    side,
                    path,
                )
    lengths = _seconds(stretch_s, "stretch_s", "positive lengths")
    if not (lengths > 0).all():
        raise InputError(f"stretch_s must be positive lengths in seconds, got {shorten(stretch_s)}")
    refine = delays is None
    grid = (
        np.round(np.arange(-0.5, 0.5001, 0.05), 10)
        if delays is None
        else _seconds(delays, "delays", "finite latencies")
    )
    if float(np.abs(grid).max()) > MAX_DELAY_S:
        raise InputError(f"delays must lie within {MAX_DELAY_S} s, got {shorten(delays)}")
    if not isinstance(turn_scales, bool):
        raise InputError(f"turn_scales must be True or False, got {shorten(turn_scales)}")
    _positive("delay_stretch_s", delay_stretch_s, MAX_STRETCH_S)
    _positive("max_gap_s", max_gap_s, MAX_STRETCH_S)
    if float(lengths.max()) > MAX_STRETCH_S:
        raise InputError(f"stretch_s must be at most {MAX_STRETCH_S:g} s, got {shorten(stretch_s)}")
    # Each run's span that both cover, leaving room for any delay of the grid.
    margin = float(np.abs(grid).max())
    spans = [
        (max(float(o.t[0]), float(g.t[0])) + margin, min(float(o.t[-1]), float(g.t[-1])) - margin)
        for o, g in pairs
    ]
    starts = [
        _stretches(lo, hi, delay_stretch_s, 0.5 * delay_stretch_s, "delay_stretch_s")
        for lo, hi in spans
    ]
    if sum(a.size for a in starts) < MIN_STRETCHES:
        lo, hi = spans[0]
        raise InputError(
            f"the odometry and the truth overlap for {max(hi - lo, 0.0):.1f} s: too little to "
            f"fit a motion model (at least {MIN_STRETCHES} stretches of {delay_stretch_s} s)"
            if len(pairs) == 1
            else f"the odometry and the truth of the {len(pairs)} runs overlap too little to "
            f"fit a motion model: {sum(a.size for a in starts)} stretches of {delay_stretch_s} "
            f"s ({_by_run([a.size for a in starts])}), at least {MIN_STRETCHES} needed in all"
        )
    # The truth's relative motion over each run's stretches, those without a gap.
    runs = []
    for (o, g), a in zip(pairs, starts, strict=True):
        true = _true_motion(g, a, a + delay_stretch_s, max_gap_s)
        ok = np.isfinite(true).all(axis=1)
        runs.append((o, a[ok], true[ok]))
    if not any(a.size for _, a, _ in runs):
        raise InputError(
            f"no stretch of {delay_stretch_s} s without a gap in the truth (longer than "
            f"max_gap_s = {max_gap_s:g} s) to fit the latency on"
        )
    model = MotionModel()

    def best_delay(model: MotionModel) -> tuple[FloatArray, FloatArray]:
        cost = _delay_costs(runs, delay_stretch_s, grid, model)
        if not refine:
            return grid, cost
        near = float(grid[int(np.argmin(cost))])
        fine = np.round(np.arange(near - 0.04, near + 0.0401, 0.01), 10)
        fine = fine[~np.isin(fine, grid)]
        both = np.concatenate([grid, fine])
        cost = np.concatenate([cost, _delay_costs(runs, delay_stretch_s, fine, model)])
        order = np.argsort(both)
        return both[order], cost[order]

    tried, cost = best_delay(model)
    model = replace(model, delay_s=float(tried[int(np.argmin(cost))]))
    model = _fit_scales(runs, delay_stretch_s, model, turn_scales)
    # A jump in the truth (a kidnapping in the recording, a tracking system's swap) is a
    # stretch off by metres, which least squares would follow: such stretches are left out
    # and the latency and the scales fitted again without them.
    clean = _without_jumps(runs, delay_stretch_s, model)
    jumps = sum(a.size for _, a, _ in runs) - sum(a.size for _, a, _ in clean)
    if jumps:
        log.info("fit-motion: %d stretches with a jump in the truth left out of the scales", jumps)
        runs = clean
        model = MotionModel()
        tried, cost = best_delay(model)
        model = replace(model, delay_s=float(tried[int(np.argmin(cost))]))
        model = _fit_scales(runs, delay_stretch_s, model, turn_scales)
    tried, cost = best_delay(model)
    model = replace(model, delay_s=float(tried[int(np.argmin(cost))]))
    # Noise: errors over each run's stretches of each length, and the covariance of each
    # noise value.
    errs, parts, by_run = [], [], []
    for (o, g), (lo, hi) in zip(pairs, spans, strict=True):
        count = 0
        for length in lengths:
            a, true = _clean_stretches(g, (lo, hi), float(length), max_gap_s, "stretch_s")
            if not a.size:
                continue
            pred, _, pieces = _predicted(o, a, a + length, model)
            errs.append(_errors(true, pred))
            unit = []
            for j in range(len(NOISE_FIELDS)):
                m = replace(model, **{f: float(i == j) for i, f in enumerate(NOISE_FIELDS)})
                unit.append(np.stack([integrate(dt, v, w, m)[1] for dt, v, w, _ in pieces]))
            parts.append(np.stack(unit, axis=1))  # (n, 7, 3, 3)
            count += len(pieces)
        by_run.append(count)
    if sum(by_run) < MIN_STRETCHES:
        raise InputError(
            f"only {sum(by_run)} stretches of "
            + ", ".join(f"{x:g}" for x in lengths[:8])
            + (", ..." if lengths.size > 8 else "")
            + " s (stretch_s) without a gap in the truth: too few to fit the noise"
            + (f" ({_by_run(by_run)})" if len(pairs) > 1 else "")
        )
    r = np.concatenate(errs)
    Qp = np.concatenate(parts)
    floor = np.diag(TRUTH_FLOOR)

    def nll(logp: FloatArray, use: NDArray[np.bool_]) -> float:
        S = np.einsum("p,npij->nij", np.exp(logp), Qp[use]) + floor
        sign, logdet = np.linalg.slogdet(S)
        if not (sign > 0).all():
            return math.inf
        q = np.einsum("ni,ni->n", r[use], np.linalg.solve(S, r[use][:, :, None])[:, :, 0])
        return float(0.5 * np.sum(q + logdet))

    def fit(use: NDArray[np.bool_], start: FloatArray) -> FloatArray:
        # A noise value that moves no stretch's covariance (delay_var where the velocities
        # never change) is left out of the search, at zero: its likelihood is flat, and the
        # search would wander off to any value.
        active = np.any(Qp[use] != 0.0, axis=(0, 2, 3))
        out = np.full(len(NOISE_FIELDS), -np.inf)
        if not active.any():
            return out

        def cost(x: FloatArray) -> float:
            out[active] = x
            return nll(out, use)

        res = minimize(cost, start[active], method="Nelder-Mead",
                       options={"maxiter": 4000, "xatol": 1e-3, "fatol": 1e-3})  # fmt: skip
        out[active] = res.x
        return out

    use = np.ones(r.shape[0], dtype=bool)
    logp = fit(use, np.log(np.full(len(NOISE_FIELDS), 1e-3)))
    S = np.einsum("p,npij->nij", np.exp(logp), Qp) + floor
    q = np.einsum("ni,ni->n", r, np.linalg.solve(S, r[:, :, None])[:, :, 0])
    use = q <= chi2_quantile(0.999, 3)
    logp = fit(use, logp)
    noise = {f: float(v) for f, v in zip(NOISE_FIELDS, np.exp(logp), strict=True)}
    # Values the likelihood cannot tell from zero come out as tiny ones: call them zero.
    noise = {f: (v if v > 1e-9 else 0.0) for f, v in noise.items()}
    wild = {f: v for f, v in noise.items() if not v <= MOTION_MAX[f]}
    if wild:
        raise InputError(
            "the odometry and the truth disagree far beyond any robot's noise: the noise fit "
            + ", ".join(f"{f}={v:.3g}" for f, v in wild.items())
            + f" (at most {MOTION_MAX[next(iter(wild))]:g}); are they of the same run, and "
            "do their times overlap?"
        )
    model = replace(model, **noise)
    return MotionFit(model, tried, cost, int(use.sum()), int((~use).sum()), tuple(by_run), jumps)


#: The parts of a relative motion :meth:`MotionCheck.inside` asks about, and their axes.
MOTION_PARTS = {"pose": (0, 1, 2), "position": (0, 1), "heading": (2,)}


@dataclass(frozen=True)
class MotionCheck:
    """How a motion model's predictions meet a ground truth (:func:`check_motion`): over
    stretches of one length, the error of the relative motion the model predicts from the
    odometry, and the covariance it gives that motion.

    Attributes
    ----------
    start : ndarray, shape (n,)
        The stretches' starts (s, the truth's clock; a stretch is ``[start, start +
        length]``).
    length : float
        Their length (s).
    run : ndarray of int, shape (n,)
        Which run (0, 1, ...; in the order given) each stretch is of.
    errors : ndarray, shape (n, 3)
        The truth's relative motion less the model's: ``(dx, dy)`` in the robot's frame at the
        stretch's start (m) and the heading (rad, wrapped).
    covariance : ndarray, shape (n, 3, 3)
        The covariance the model propagates over each stretch
        (:func:`~omniloc.track.motion.integrate`), plus :data:`TRUTH_FLOOR` for the truth's
        own error.
    pieces : tuple of (ndarray, ndarray, ndarray, ndarray)
        Each stretch's odometry as the model integrates it (as the tracker moves by it): the
        pieces' durations (s), forward velocities (m/s), turn rates (rad/s) and sideways
        velocities (m/s; zeros for odometry of velocities, or poses that move straight
        ahead), shifted by the model's latency.
    """

    start: FloatArray
    length: float
    run: NDArray[np.int64]
    errors: FloatArray = field(repr=False)
    covariance: FloatArray = field(repr=False)
    pieces: tuple[Pieces, ...] = field(repr=False)

    def squared(self, part: str = "pose") -> FloatArray:
        """Each stretch's squared error in the model's covariance (the normalised estimation
        error squared) over ``part``: ``"pose"`` (3 degrees of freedom), ``"position"`` (2)
        or ``"heading"`` (1)."""
        axes = np.array(_motion_part(part))
        e = self.errors[:, axes]
        S = self.covariance[:, axes[:, None], axes[None, :]]
        return np.asarray(np.einsum("ni,ni->n", e, np.linalg.solve(S, e[:, :, None])[:, :, 0]))

    def of_run(self, k: int) -> MotionCheck:
        """The stretches of run ``k`` alone (0, 1, ... in the order the runs were given;
        none, if that run gave none)."""
        mine = np.flatnonzero(self.run == k)
        return MotionCheck(
            self.start[mine],
            self.length,
            self.run[mine],
            self.errors[mine],
            self.covariance[mine],
            tuple(self.pieces[i] for i in mine.tolist()),
        )

    def inside(self, probability: float = 0.99, part: str = "pose") -> float:
        """The share of the stretches whose error lies inside the model's region of
        ``probability`` (chi-square over ``part``'s degrees of freedom): about
        ``probability`` for a model whose covariance is honest, less for one too sure of
        the odometry."""
        if not (
            isinstance(probability, (int, float))
            and not isinstance(probability, bool)
            and 0.0 < probability < 1.0
        ):
            raise InputError(f"probability must be a number in (0, 1), got {shorten(probability)}")
        axes = _motion_part(part)
        if not self.start.size:
            raise InputError("no stretch to check: the share inside a region needs one")
        return float(np.mean(self.squared(part) <= chi2_quantile(float(probability), len(axes))))


def _motion_part(part: object) -> tuple[int, ...]:
    """The axes of ``part`` (a key of :data:`MOTION_PARTS`), or an InputError naming it."""
    if not isinstance(part, str) or part not in MOTION_PARTS:
        raise InputError(f"part must be one of {', '.join(MOTION_PARTS)}, got {shorten(part)}")
    return MOTION_PARTS[part]


def check_motion(
    odometry: Odometry | Sequence[Odometry],
    truth: GroundTruth | Sequence[GroundTruth],
    model: MotionModel,
    *,
    length: float = 2.0,
    max_gap_s: float = 0.5,
    skip_s: float = 0.0,
) -> MotionCheck:
    """The errors of ``model``'s predictions against a ground truth, to check a motion model
    (a fit, a preset, one widened by hand) on runs it was not fitted on.

    Parameters
    ----------
    odometry : Odometry, or a list of them
        One run's odometry, or a list of several runs' (as :func:`estimate_motion`).
    truth : GroundTruth, or a list of them
        The true track of the same run (runs, in the same order).
    model : MotionModel
        The model checked: its latency, scales and noise.
    length : float
        Length (s) of the stretches, which do not overlap.
    max_gap_s : float
        Stretches whose ends fall where the truth has a gap longer than this are left out.
    skip_s : float
        Seconds of each run left out before its first stretch, from the first time both
        the truth and the odometry (at the model's latency) cover.

    Returns
    -------
    MotionCheck
        ``inside(0.99)`` is the share of stretches inside the model's 99 % region.

    Raises
    ------
    InputError
        ``model`` not a MotionModel, a length or gap out of range, runs given as in
        :func:`estimate_motion` wrongly, or no stretch of ``length`` s without a gap in the
        truth.

    Examples
    --------
    A robot that goes straight at 0.2 m/s, exactly as its odometry says:

    >>> from omniloc.track import GroundTruth, MotionModel, Odometry
    >>> t = np.arange(0.0, 60.0, 0.1)
    >>> odometry = Odometry(t, np.full(t.size, 0.2), np.zeros(t.size))
    >>> truth = GroundTruth(t, 0.2 * t, np.zeros(t.size), np.zeros(t.size))
    >>> check = check_motion(odometry, truth, MotionModel(), length=2.0)
    >>> check.errors.shape, check.inside(0.99)
    ((29, 3), 1.0)
    """
    if not isinstance(model, MotionModel):
        raise InputError(f"model must be a MotionModel, got {type(model).__name__}")
    _positive("length", length, MAX_STRETCH_S)
    _positive("max_gap_s", max_gap_s, MAX_STRETCH_S)
    if not (
        isinstance(skip_s, (int, float))
        and not isinstance(skip_s, bool)
        and 0.0 <= skip_s <= MAX_STRETCH_S
    ):
        raise InputError(f"skip_s must be seconds in [0, {MAX_STRETCH_S:g}], got {shorten(skip_s)}")
    pairs = _paired(odometry, truth, _odometry, "odometry", "run")
    margin = abs(model.delay_s)
    starts, runs, errs, covs, pieces = [], [], [], [], []
    floor = np.diag(TRUTH_FLOOR)
    for k, (o, g) in enumerate(pairs):
        lo = max(float(o.t[0]) + margin, float(g.t[0])) + float(skip_s)
        hi = min(float(o.t[-1]) + min(model.delay_s, 0.0), float(g.t[-1]))
        a, true = _clean_stretches(g, (lo, hi), float(length), max_gap_s, "length")
        if not a.size:
            continue
        pred, cov, parts = _predicted(o, a, a + length, model, sideways=True)
        starts.append(a)
        runs.append(np.full(a.size, k, dtype=np.int64))
        errs.append(_errors(true, pred))
        covs.append(cov + floor)
        pieces.extend(parts)
    if not starts:
        raise InputError(
            f"no stretch of {length:g} s that the odometry and the truth both cover without a "
            f"gap in the truth (longer than max_gap_s = {max_gap_s:g} s): do their times "
            "overlap?"
        )
    return MotionCheck(
        np.concatenate(starts),
        float(length),
        np.concatenate(runs),
        np.concatenate(errs),
        np.concatenate(covs),
        tuple(pieces),
    )


#: Turn-rate bins (rad/s) of :func:`turn_noise_fit`.
TURN_BINS = (0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.6)


def turn_noise_fit(errors: ArrayLike, turn_rate: ArrayLike) -> dict[str, object]:
    """How the bearing noise grows with the robot's turn rate: per bin of ``|turn_rate|``
    (:data:`TURN_BINS`, rad/s; bins of fewer than 20 errors left out) the robust sd of the
    errors (1.4826 times the median absolute deviation), and the least-squares fit of
    ``var = sd0^2 + (turn_noise_s * w)^2`` to those variances at the bins' median turn rates
    (weighted by the bins' counts).

    Returns
    -------
    dict
        ``sd0`` (rad), ``turn_noise_s`` (s) and ``bins`` (each ``from``, ``to``, ``n``, ``w``,
        ``sd``).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> w = rng.uniform(-0.6, 0.6, 40000)
    >>> e = rng.normal(0, np.hypot(0.007, 0.05 * w))
    >>> fit = turn_noise_fit(e, w)
    >>> abs(fit["sd0"] - 0.007) < 0.0005, abs(fit["turn_noise_s"] - 0.05) < 0.003
    (True, True)
    """
    e = np.asarray(errors, dtype=float).reshape(-1)
    w = np.abs(np.asarray(turn_rate, dtype=float)).reshape(-1)
    if e.shape != w.shape:
        raise InputError(f"one turn rate per error: got {e.size} errors and {w.size} rates")
    ok = np.isfinite(e) & np.isfinite(w)
    e, w = e[ok], w[ok]
    bins = []
    for lo, hi in itertools.pairwise(TURN_BINS):
        m = (w >= lo) & (w < hi)
        if m.sum() < 20:
            continue
        x = e[m]
        sd = 1.4826 * float(np.median(np.abs(x - np.median(x))))
        bins.append(
            {"from": lo, "to": hi, "n": int(m.sum()), "w": float(np.median(w[m])), "sd": sd}
        )
    if not bins:
        return {"sd0": math.nan, "turn_noise_s": math.nan, "bins": bins}
    W = np.array([b["w"] for b in bins])
    V = np.array([b["sd"] for b in bins]) ** 2
    n = np.array([b["n"] for b in bins], dtype=float)
    if len(bins) == 1:
        return {"sd0": math.sqrt(float(V[0])), "turn_noise_s": 0.0, "bins": bins}
    A = np.c_[np.ones_like(W), W**2] * np.sqrt(n)[:, None]
    (a, c), *_ = np.linalg.lstsq(A, V * np.sqrt(n), rcond=None)
    return {
        "sd0": math.sqrt(max(float(a), 0.0)),
        "turn_noise_s": math.sqrt(max(float(c), 0.0)),
        "bins": bins,
    }


#: Fewest finite errors :func:`fit_core_and_tail` fits (as :func:`estimate_frame_sensor`).
MIN_ERRORS = 20
#: Smallest sd (rad, 0.2 arcseconds) either Gaussian of :func:`fit_core_and_tail` may take:
#: no camera is that sharp, and errors without spread (all equal) stay finite.
SD_FLOOR = 1e-6
#: The two sds of a mixture must differ by more than this factor, else one Gaussian.
MIN_SD_RATIO = 1.2
#: EM stops when the mean log-likelihood per error gains less than this (nats) ...
EM_TOLERANCE = 1e-9
#: ... or after this many iterations.
EM_MAX_ITERATIONS = 1000


@dataclass(frozen=True)
class CoreTailFit:
    """What :func:`fit_core_and_tail` found, in the tracker's terms.

    Attributes
    ----------
    core_share : float
        Share of the errors in the sharper Gaussian (``TrackerConfig.core_share``); 0 when
        one Gaussian fits as well.
    core_sigma : float
        Its sd (rad; ``TrackerConfig.core_sigma``); 0 with no mixture.
    tail_sigma : float
        The wider Gaussian's sd (rad; the sensor's ``sigma`` under the mixture); with no
        mixture, the one Gaussian's maximum-likelihood sd.
    loglik_mixture, loglik_single : float
        Log-likelihood (nats) of the errors under the mixture EM found (even when it was
        not kept) and under the one Gaussian.
    errors : int
        Finite errors fitted.
    iterations : int
        EM iterations run (at most :data:`EM_MAX_ITERATIONS`).
    """

    core_share: float
    core_sigma: float
    tail_sigma: float
    loglik_mixture: float
    loglik_single: float
    errors: int
    iterations: int

    @property
    def gain(self) -> float:
        """Twice the log-likelihood the mixture gains over one Gaussian (BIC asks more than
        ``2 ln(errors)`` for its two extra parameters)."""
        return 2.0 * (self.loglik_mixture - self.loglik_single)


def _log_normal(x2: FloatArray, sd: float) -> FloatArray:
    """Log density of zero-mean Gaussians of sd ``sd`` at errors whose squares are ``x2``."""
    return np.asarray(-0.5 * x2 / sd**2 - math.log(sd) - 0.5 * math.log(2 * math.pi))


def fit_core_and_tail(errors: ArrayLike) -> CoreTailFit:
    """Fit bearing errors as a mixture of two zero-mean Gaussians -- a sharp core and a wider
    tail -- by EM, and keep it only where it explains the errors better than one Gaussian.

    The errors are wrapped to [-pi, pi) and centred on their median (a constant offset, the
    camera turned on the robot, is not noise; as :attr:`SensorFit.sigma`); non-finite ones
    are left out, nothing else (gate them first). EM starts from a share of 0.5 with sds of
    0.5 and 2 times the robust sd (1.4826 times the median absolute deviation) and runs
    until the mean log-likelihood gains less than :data:`EM_TOLERANCE` per error (at most
    :data:`EM_MAX_ITERATIONS` iterations); neither sd goes below :data:`SD_FLOOR`. The
    mixture is kept when it pays for its two extra parameters by the Bayesian information
    criterion, ``2 (loglik_mixture - loglik_single) > 2 ln(n)``, and its sds differ by more
    than :data:`MIN_SD_RATIO`; else the result has ``core_share`` 0 and the one Gaussian's
    maximum-likelihood sd as ``tail_sigma``.

    Parameters
    ----------
    errors : array_like of float, shape (n,)
        Bearing errors (rad), e.g. bearing minus the matched landmark's true bearing.

    Returns
    -------
    CoreTailFit
        ``core_share`` and ``core_sigma`` for :class:`~omniloc.track.TrackerConfig`,
        ``tail_sigma`` for the sensor's ``sigma``.

    Raises
    ------
    InputError
        Fewer than :data:`MIN_ERRORS` finite errors. (Errors without spread are no error:
        one Gaussian of sd :data:`SD_FLOOR`.)

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> e = np.r_[rng.normal(0, 0.005, 6000), rng.normal(0, 0.02, 4000)] + 0.01
    >>> fit = fit_core_and_tail(e)
    >>> abs(fit.core_share - 0.6) < 0.03, abs(fit.core_sigma / 0.005 - 1) < 0.05
    (True, True)
    >>> abs(fit.tail_sigma / 0.02 - 1) < 0.05, fit.gain > 2 * math.log(fit.errors)
    (True, True)
    >>> fit_core_and_tail(rng.normal(0, 0.01, 10000)).core_share
    0.0
    """
    try:
        e = np.asarray(errors, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"errors must be numbers (rad), got {shorten(errors)}") from None
    e = np.asarray(wrap(e[np.isfinite(e)]), dtype=np.float64)  # angles: wrapped
    n = e.size
    if n < MIN_ERRORS:
        raise InputError(
            f"only {n} finite bearing errors: too few to fit a core and a tail (at least "
            f"{MIN_ERRORS})"
        )
    x2 = (e - np.median(e)) ** 2
    single = max(math.sqrt(float(np.mean(x2))), SD_FLOOR)
    loglik_single = float(np.sum(_log_normal(x2, single)))
    robust = 1.4826 * float(np.median(np.sqrt(x2)))
    scale = robust if robust > SD_FLOOR else single
    share, sd, loglik, iterations = _two_gaussians_em(x2, scale)
    keep = 2.0 * (loglik - loglik_single) > 2.0 * math.log(n) and sd[1] > MIN_SD_RATIO * sd[0]
    if not keep:
        return CoreTailFit(0.0, 0.0, single, loglik, loglik_single, n, iterations)
    return CoreTailFit(share, sd[0], sd[1], loglik, loglik_single, n, iterations)


def _two_gaussians_em(x2: FloatArray, scale: float) -> tuple[float, list[float], float, int]:
    """EM for two zero-mean Gaussians on errors whose squares are ``x2``, started at sds of
    half and twice ``scale`` (at least :data:`SD_FLOOR`) with equal shares; returns the
    first's share, the two sds, the log-likelihood and the iterations.

    The first Gaussian starts sharper and stays sharper (so it is the core, unsorted): with
    ``sd[0] < sd[1]`` an error's share ``r`` in the first falls as its size grows (the ratio
    of the two densities does), so the new ``sd[0]**2`` -- the mean of the squares weighted
    by ``r`` -- is at most the new ``sd[1]**2``, weighted by ``1 - r`` (Chebyshev's sum
    inequality). Started equal (``scale`` below the floor) they would part by rounding,
    either way round.
    """
    n = x2.size
    share = 0.5
    sd = [max(0.5 * scale, SD_FLOOR), max(2.0 * scale, SD_FLOOR)]
    loglik = -math.inf
    iterations = 0
    while True:
        a = math.log(share) + _log_normal(x2, sd[0])
        b = math.log1p(-share) + _log_normal(x2, sd[1])
        total = np.logaddexp(a, b)
        new = float(np.sum(total))
        if iterations >= EM_MAX_ITERATIONS or new - loglik < EM_TOLERANCE * n:
            loglik = max(new, loglik)
            break
        loglik = new
        iterations += 1
        r = np.exp(a - total)  # each error's share in the first Gaussian
        w = (float(np.sum(r)), float(np.sum(1.0 - r)))
        # A Gaussian left without errors keeps its sd (its share goes to 0).
        share = min(max(w[0] / n, 1e-12), 1.0 - 1e-12)
        for k, (weights, mass) in enumerate(((r, w[0]), (1.0 - r, w[1]))):
            if mass > 0:
                sd[k] = max(math.sqrt(float(np.sum(weights * x2)) / mass), SD_FLOOR)
    return share, sd, loglik, iterations


@dataclass(frozen=True)
class SensorFit:
    """What :func:`estimate_frame_sensor` found.

    Attributes
    ----------
    sigma : float
        Robust sd of the bearing errors (rad): 1.4826 times their median absolute deviation
        (around their median: a constant offset, e.g. the camera turned on the robot, which the
        tracker's heading takes in, does not count as noise; ``estimate_sensor`` takes the
        median absolute error instead).
    turn_noise_s : float
        How that noise grows with the turn rate (:func:`turn_noise_fit`; 0 when the
        recording does not turn enough to tell).
    p_detect : float
        Share of the landmarks in view (inside the field of view by more than the gate,
        within the range) that a frame reported: what the tracker's frame model means by it
        (every landmark in view is reported with that probability). Not
        :func:`omniloc.evaluate.estimate_sensor`'s, which counts only landmarks plainly
        visible and not hidden behind a reported bearing (the single-frame score's negative
        evidence): on MRCLAM robot 3 that gives 0.47 against 0.41 here, and a tracker given
        0.47 was localized at a wrong place in 16 % of its localized frames.
    clutter : float
        Bearings per frame that are no landmark (none within the gate).
    clutter_by_detections : tuple of float
        The same by the number of landmarks a frame reported (1, 2, ...; see
        :func:`omniloc.sensor.clutter_by_detections`): for scoring single frames where the
        clutter comes with the landmarks (``omniloc localize --clutter-by-detections``); not
        among the tracker's :meth:`settings`.
    frames, matched, bearings : int
        Frames with a true pose (those that saw nothing included), bearings taken as
        landmarks, all their bearings.
    core_share, core_sigma, tail_sigma : float
        The same errors as a sharp core and a wider tail (:func:`fit_core_and_tail`): the
        share of the errors in the sharper of two zero-mean Gaussians, its sd (rad) and the
        wider one's sd (rad) -- the tracker's ``core_share``, ``core_sigma`` and the sensor's
        ``sigma`` under :meth:`mixture_settings`. ``core_share`` 0 (and ``core_sigma`` 0)
        where one Gaussian fits as well (the simulator's noise); ``tail_sigma`` is then that
        Gaussian's maximum-likelihood sd, larger than :attr:`sigma` where the errors have a
        tail. Not among the tracker's :meth:`settings`.
    bias_by_bearing : tuple of (float, float, float, int)
        The errors' median by where the landmark was in view (:func:`bias_by_bearing`:
        bins of :data:`BIAS_BIN` from the forward axis, each ``(start, end, median, count)``,
        radians), around the errors' median: a camera whose error depends on the bearing
        (a lens or mirror calibration off) shows a pattern here that no setting of the
        tracker's models, all independent of the bearing, can take in. Diagnostic only.
    empty_frames : int
        Frames that saw nothing, inferred from the gaps of a log that lists only frames
        with a bearing (``frame_period_s``), among :attr:`frames`; not in
        :attr:`clutter_by_detections`, which is for frames that were listed.
    fov, max_range : float or None
        The field of view (full angle, rad) and the range (m) the landmarks in view were
        counted within (:func:`estimate_frame_sensor`'s; None: all around, no limit):
        ``p_detect`` and ``clutter`` are rates for that view, so :meth:`settings` writes
        those given, for the tracker to use the same sensor.
    """

    sigma: float
    turn_noise_s: float
    p_detect: float
    clutter: float
    frames: int
    matched: int
    bearings: int
    clutter_by_detections: tuple[float, ...] = ()
    core_share: float = 0.0
    core_sigma: float = 0.0
    tail_sigma: float = 0.0
    bias_by_bearing: tuple[tuple[float, float, float, int], ...] = ()
    empty_frames: int = 0
    fov: float | None = None
    max_range: float | None = None

    def settings(self) -> dict[str, float | bool]:
        """As settings for :func:`~omniloc.track.with_settings` (``omniloc track --config``);
        the :attr:`fov` and :attr:`max_range` the rates were measured for, where given (a
        tracker that expects ``p_detect`` of the landmarks in another view is confidently
        wrong: of the example recording's within 5 m, at any range); with frames that saw
        nothing inferred from the log's gaps (:attr:`empty_frames`), ``nonempty_frames``
        true, which the rates then are for."""
        out: dict[str, float | bool] = {
            "sigma": self.sigma,
            "p_detect": self.p_detect,
            "clutter": self.clutter,
            "turn_noise_s": self.turn_noise_s,
        }
        if self.fov is not None:
            out["fov"] = self.fov
        if self.max_range is not None:
            out["max_range"] = self.max_range
        if self.empty_frames:
            out["nonempty_frames"] = True
        return out

    def mixture_settings(self) -> dict[str, float | bool]:
        """As :meth:`settings`, with the bearing errors as a sharp core and a wider tail: the
        tail's sd as ``sigma``, ``core_share`` and ``core_sigma``, and ``core_update`` false
        (the core weighs the hypotheses but does not narrow them: a recording's errors
        usually repeat from frame to frame, and on MRCLAM the core in the update made the
        tracker confidently wrong four times as often; docs/tracking.md). Where no core was
        found (``core_share`` 0), :meth:`settings` and ``core_share`` 0 (the mixture off).
        """
        if not self.core_share > 0:
            return {**self.settings(), "core_share": 0.0}
        return {
            **self.settings(),
            "sigma": self.tail_sigma,
            "core_share": self.core_share,
            "core_sigma": self.core_sigma,
            "core_update": False,
        }


#: Width of the bins of :func:`bias_by_bearing` (10 deg) ...
BIAS_BIN = math.radians(10.0)
#: ... and the fewest errors a bin reports a median for.
BIAS_MIN_COUNT = 20


def bias_by_bearing(
    bearings: ArrayLike, errors: ArrayLike
) -> tuple[tuple[float, float, float, int], ...]:
    """Median bearing error by where the landmark was seen: bins of :data:`BIAS_BIN` (the
    first starting at 0, the forward axis, so that forward and the bins' edges are the same
    for every camera; bearings wrapped to [-pi, pi), non-finite pairs left out), in order of
    bearing, each ``(start, end, median, count)`` in radians; bins with fewer than
    :data:`BIAS_MIN_COUNT` errors are left out.

    Examples
    --------
    >>> b = np.radians(np.r_[np.full(30, -5.0), np.full(30, 15.0)])
    >>> e = np.radians(np.r_[np.full(30, 0.1), np.full(30, -0.4)])
    >>> bins = bias_by_bearing(b, e)
    >>> [(round(math.degrees(s)), round(math.degrees(m), 2), n) for s, _, m, n in bins]
    [(-10, 0.1, 30), (10, -0.4, 30)]
    """
    try:
        b = np.asarray(bearings, dtype=np.float64).reshape(-1)
        e = np.asarray(errors, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise InputError(
            f"bearings and errors must be numbers (rad), got {shorten(bearings)} and "
            f"{shorten(errors)}"
        ) from None
    if b.shape != e.shape:
        raise InputError(f"{b.size} bearings for {e.size} errors: one bearing per error")
    keep = np.isfinite(b) & np.isfinite(e)
    b, e = np.asarray(wrap(b[keep]), dtype=np.float64), e[keep]
    k = np.floor(b / BIAS_BIN).astype(np.int64)
    out = []
    for i in np.unique(k):
        m = k == i
        if m.sum() >= BIAS_MIN_COUNT:
            out.append(
                (
                    float(i * BIAS_BIN),
                    float((i + 1) * BIAS_BIN),
                    float(np.median(e[m])),
                    int(m.sum()),
                )
            )
    return tuple(out)


def _frame_list(frames: object, what: str) -> list[Frame]:
    """``frames`` as a list of Frame, or an InputError naming ``what``."""
    items: list[object]
    try:
        items = [frames] if isinstance(frames, (str, bytes)) else list(frames)  # type: ignore[call-overload]
    except TypeError:
        items = [frames]
    if not all(isinstance(f, Frame) for f in items):
        raise InputError(f"{what} must be a sequence of Frame (see omniloc.track.load_frames)")
    return [f for f in items if isinstance(f, Frame)]


def _check_view(gate: float, max_gap_s: float, fov: float | None, max_range: float | None) -> None:
    """The sensor fits' gate, gap, field of view and range, each in its range."""
    _positive("gate", gate, math.pi)
    _positive("max_gap_s", max_gap_s, MAX_STRETCH_S)
    if fov is not None:
        _positive("fov", fov, 2 * math.pi)
    if max_range is not None:
        _positive("max_range", max_range, 1e9)


def estimate_frame_sensor(
    landmarks: LandmarkMap | ArrayLike,
    frames: Sequence[Frame] | Sequence[Sequence[Frame]],
    truth: GroundTruth | Sequence[GroundTruth],
    *,
    fov: float | None = None,
    max_range: float | None = None,
    gate: float = math.radians(3.0),
    max_gap_s: float = 0.5,
    frame_period_s: float | None = None,
    mount: Sequence[float] | None = None,
) -> SensorFit:
    """Fit the bearing sensor's noise, its growth with the turn rate, the detection
    probability and the clutter from frames of bearings and a ground-truth track (see the
    module's documentation), and the same errors as a sharp core and a wider tail
    (:func:`fit_core_and_tail`).

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
    frames : sequence of Frame, or a list of them
        The recording's frames (their landmark ids, if any, are not used); for several
        recordings of one sensor fitted together, a list of each one's frames.
    truth : GroundTruth, or a list of them
        The true track over (part of) the same time; frames outside it, or where it has a gap
        longer than ``max_gap_s``, are left out. Several recordings: one track each, in the
        order of ``frames``.
    fov : float, optional
        Full field of view (rad); None: all around.
    max_range : float, optional
        Range (m) beyond which no landmark is taken as in view.
    gate : float
        A bearing is taken as the nearest landmark's within this (rad), else as clutter.
    max_gap_s : float
        Frames where the true track has a gap longer than this (s) are left out.
    frame_period_s : float, optional
        The camera's frame period (s), for a recording that lists only frames with a
        bearing (MRCLAM): a gap between two frames of about ``n`` periods (more than 1.5)
        holds ``n - 1`` frames that saw nothing, and they count in ``p_detect`` (their
        landmarks in view, at the true track, were not reported) and in ``clutter`` (per
        camera frame): the rates the tracker's ``nonempty_frames`` wants
        (:meth:`SensorFit.settings` then sets it). None: every frame the camera took is in
        ``frames``.
    mount : sequence of 3 floats, optional
        Where the sensor sits on the robot, ``(x, y, yaw)`` (see
        :attr:`omniloc.SensorModel.mount`): the truth is the robot's track, the bearings are
        measured from ``compose(truth, mount)``.

    Returns
    -------
    SensorFit

    Raises
    ------
    InputError
        Fewer than 20 bearings taken as landmarks, or an argument out of range.
    """
    lm = as_landmark_map(landmarks)
    pairs = _paired(frames, truth, _frame_list, "frames", "recording")
    _check_view(gate, max_gap_s, fov, max_range)
    if frame_period_s is not None:
        _positive("frame_period_s", frame_period_s, MAX_STRETCH_S)
    seat = None if mount is None else SensorModel(mount=mount).mount  # type: ignore[arg-type]
    seen = _sightings(
        lm.xy,
        pairs,
        fov=fov,
        max_range=max_range,
        min_range=None,
        gate=gate,
        max_gap_s=max_gap_s,
        frame_period_s=frame_period_s,
        mount=seat,
    )
    if seen.errors.size < MIN_ERRORS:
        raise InputError(
            f"only {seen.errors.size} bearings within {math.degrees(gate):.1f} deg of a "
            f"landmark seen from the true {'sensor pose (truth and mount)' if seat else 'pose'}: "
            "too few to fit the sensor (do the frames, the map"
            + (", the truth and the mount" if seat else " and the truth")
            + " belong together?)"
        )
    visible = int(seen.visible.sum())
    if visible == 0:
        raise InputError(
            "no landmark was in view of the true poses (inside the field of view by more than "
            "the gate, within the range): p_detect cannot be measured; check fov and max_range"
        )
    listed, err = seen.listed, seen.errors
    used = int(seen.frame_run.size)
    sigma = 1.4826 * float(np.median(np.abs(err - np.median(err))))
    turn = turn_noise_fit(err, seen.rates)
    tn = float(turn["turn_noise_s"])  # type: ignore[arg-type]
    mix = fit_core_and_tail(err)
    return SensorFit(
        sigma=sigma,
        turn_noise_s=tn if math.isfinite(tn) else 0.0,
        p_detect=int(seen.seen.sum()) / visible,
        clutter=int(seen.clutter.sum()) / used,
        frames=used,
        matched=int(err.size),
        bearings=seen.bearings,
        clutter_by_detections=clutter_by_detections(seen.reported[listed], seen.clutter[listed]),
        core_share=mix.core_share,
        core_sigma=mix.core_sigma,
        tail_sigma=mix.tail_sigma,
        bias_by_bearing=bias_by_bearing(seen.where, err - np.median(err)),
        empty_frames=int(np.count_nonzero(~listed)),
        fov=None if fov is None else float(fov),
        max_range=None if max_range is None else float(max_range),
    )


@dataclass(frozen=True)
class SensorCheck:
    """How a sensor model meets frames of bearings and a ground truth (:func:`check_sensor`):
    each bearing taken as the landmark whose bearing from the true sensor pose is nearest
    (within the gate), its error, and how likely the model makes an error that large; each
    frame's landmarks in view and reported, and its clutter.

    Attributes
    ----------
    errors : ndarray, shape (m,)
        The bearings taken as landmarks less those landmarks' bearings from the truth (rad),
        each less the median of its run's other errors (a constant turn of the camera, which
        the tracker's heading takes in, is not noise; the others', so that a run of few
        bearings does not look tighter than its noise; a run's one bearing as it is).
    sd, core_sd : ndarray, shape (m,)
        The model's bearing error at each (rad): one Gaussian of sd ``sd``, or with
        :attr:`core_share` a sharp core of sd ``core_sd`` and a wider tail of sd ``sd`` (the
        frame model's, widened by the truth's turn rate).
    core_share : float
        The core's share of the errors (0: one Gaussian).
    run : ndarray of int, shape (m,)
        Which run (0, 1, ... in the order given) each error is of.
    offset : ndarray, shape (runs,)
        Each run's median error (rad; NaN for a run with none).
    frame_run, visible, seen, clutter : ndarray of int, shape (F,)
        Per frame with a true pose (with ``frame_period_s``, the frames the log's gaps left
        out too): its run, the landmarks plainly in view of it (inside the field of view by
        more than the gate, within the range), how many of those it reported, and its
        bearings taken as clutter.
    p_detect, clutter_rate : float
        The model's detection probability and clutter (bearings per frame), as the tracker
        takes them (its defaults where the sensor states none).
    gate : float
        The gate (rad).
    """

    errors: FloatArray = field(repr=False)
    sd: FloatArray = field(repr=False)
    core_sd: FloatArray = field(repr=False)
    core_share: float
    run: NDArray[np.int64] = field(repr=False)
    offset: FloatArray
    frame_run: NDArray[np.int64] = field(repr=False)
    visible: NDArray[np.int64] = field(repr=False)
    seen: NDArray[np.int64] = field(repr=False)
    clutter: NDArray[np.int64] = field(repr=False)
    p_detect: float
    clutter_rate: float
    gate: float

    def below(self, size: ArrayLike) -> FloatArray:
        """The model's probability, at each bearing, of an error smaller than ``size`` (rad;
        one value, or one per bearing) -- not cut at the gate."""
        a = np.abs(np.asarray(size, dtype=np.float64))
        wide = erf(a / (np.sqrt(2.0) * self.sd))
        if not self.core_share > 0:
            return np.asarray(wide)
        return np.asarray(
            (1.0 - self.core_share) * wide
            + self.core_share * erf(a / (np.sqrt(2.0) * self.core_sd))
        )

    def levels(self) -> FloatArray:
        """Each error's level under the model: the probability of an error no larger in size,
        the model cut at the gate as the errors are. An honest model's levels are uniform on
        [0, 1]."""
        cut = np.maximum(self.below(self.gate), 1e-300)
        return np.asarray(np.minimum(self.below(self.errors) / cut, 1.0))

    def inside(self, probability: float = 0.99) -> float:
        """The share of the errors inside the model's central region of ``probability``:
        about ``probability`` for an honest model, less for one too sure of the bearings."""
        if not (
            isinstance(probability, (int, float))
            and not isinstance(probability, bool)
            and 0.0 < probability < 1.0
        ):
            raise InputError(f"probability must be a number in (0, 1), got {shorten(probability)}")
        if not self.errors.size:
            raise InputError("no bearing to check: the share inside a region needs one")
        return float(np.mean(self.levels() <= probability))

    def detected(self) -> float:
        """The share of the landmarks plainly in view that the frames reported (the model
        says :attr:`p_detect`). Refused when none was in view (no rate to give)."""
        n = int(self.visible.sum())
        if not n:
            raise InputError(
                "no landmark was plainly in view of the true poses: the share reported cannot "
                "be measured (check the sensor's fov, range and mount)"
            )
        return int(self.seen.sum()) / n

    def clutter_per_frame(self) -> float:
        """The frames' bearings taken as clutter, per frame (the model says
        :attr:`clutter_rate`). Refused without frames."""
        if not self.clutter.size:
            raise InputError("no frame to count clutter in")
        return float(self.clutter.mean())

    def of_run(self, k: int) -> SensorCheck:
        """The bearings and frames of run ``k`` alone (0, 1, ... in the order given)."""
        mine, frames = self.run == k, self.frame_run == k
        return replace(
            self,
            errors=self.errors[mine],
            sd=self.sd[mine],
            core_sd=self.core_sd[mine],
            run=self.run[mine],
            offset=self.offset[k : k + 1],
            frame_run=self.frame_run[frames],
            visible=self.visible[frames],
            seen=self.seen[frames],
            clutter=self.clutter[frames],
        )


def check_sensor(
    landmarks: LandmarkMap | ArrayLike,
    frames: Sequence[Frame] | Sequence[Sequence[Frame]],
    truth: GroundTruth | Sequence[GroundTruth],
    sensor: SensorModel,
    config: TrackerConfig | None = None,
    *,
    gate: float = math.radians(3.0),
    max_gap_s: float = 0.5,
    frame_period_s: float | None = None,
) -> SensorCheck:
    """The bearings of frames against a ground truth under a sensor model, to check a model
    (a fit, a preset, one widened by hand) on runs it was not fitted on.

    Each bearing is taken as the landmark whose bearing from the true sensor pose is nearest,
    within ``gate``, as :func:`estimate_frame_sensor` takes it, and its error is scored under
    the bearing error the tracker's frame model assumes: the sensor's ``sigma`` (or
    ``threshold / 3``), with ``config``'s ``core_share`` and ``core_sigma`` a sharp core and
    a wider tail, both widened by ``config.turn_noise_s`` times the truth's turn rate. The
    view is the sensor's (its field of view, range and mount); the detections and the
    clutter are counted as the fit counts them, for the model's ``p_detect`` and ``clutter``.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
    frames : sequence of Frame, or a list of them
        One run's frames, or a list of several runs' (as :func:`estimate_frame_sensor`).
    truth : GroundTruth, or a list of them
        The true track of the same run (runs, in the same order): the robot's, the sensor
        sitting at ``sensor.mount`` on it.
    sensor : SensorModel
        The model checked.
    config : TrackerConfig, optional
        The tracker's settings that shape the bearing error (``core_share``, ``core_sigma``,
        ``turn_noise_s``) and what a frame is (``nonempty_frames``); None: the defaults.
    gate : float
        A bearing further than this (rad) from every landmark is clutter.
    max_gap_s : float
        Frames where the truth has a gap longer than this (s) are left out.
    frame_period_s : float, optional
        The camera's frame period (s), for a log that lists only frames with a bearing, when
        the model's rates are per camera frame (``config.nonempty_frames``): required then,
        refused otherwise.

    Returns
    -------
    SensorCheck
        ``inside(0.99)`` is the share of the errors inside the model's 99 % region.

    Raises
    ------
    InputError
        ``sensor`` or ``config`` of the wrong type, a gate or gap out of range, the runs
        given wrongly, a frame period the model's rates do not call for (or none where they
        do), or no bearing within the gate of a landmark.
    """
    if not isinstance(sensor, SensorModel):
        raise InputError(f"sensor must be a SensorModel, got {type(sensor).__name__}")
    if config is None:
        config = TrackerConfig()
    elif not isinstance(config, TrackerConfig):
        raise InputError(f"config must be a TrackerConfig or None, got {type(config).__name__}")
    lm = as_landmark_map(landmarks)
    pairs = _paired(frames, truth, _frame_list, "frames", "recording")
    _check_view(gate, max_gap_s, None, None)
    if frame_period_s is not None:
        _positive("frame_period_s", frame_period_s, MAX_STRETCH_S)
        if not config.nonempty_frames:
            raise InputError(
                "frame_period_s counts the frames a log left out, but the model's p_detect "
                "and clutter are per frame listed (nonempty_frames false): give no frame "
                "period, or check a model whose rates are per camera frame"
            )
    elif config.nonempty_frames:
        raise InputError(
            "the model's p_detect and clutter are per camera frame (nonempty_frames true): "
            "give the camera's frame_period_s, so that the frames the log left out count"
        )
    seen = _sightings(
        lm.xy,
        pairs,
        fov=sensor.fov,
        max_range=sensor.max_range,
        min_range=sensor.min_range,
        gate=gate,
        max_gap_s=max_gap_s,
        frame_period_s=frame_period_s,
        mount=sensor.mount,
    )
    if not seen.errors.size:
        raise InputError(
            f"no bearing within {math.degrees(gate):.1f} deg of a landmark in view of the "
            "true sensor pose: nothing to check (do the frames, the map, the truth and the "
            "sensor's view and mount belong together?)"
        )
    model = FrameModel.of(sensor)
    offset = np.full(len(pairs), math.nan)
    errors = seen.errors.copy()
    for k in np.unique(seen.run):
        mine = seen.run == k
        offset[k] = float(np.median(errors[mine]))
        # (Each error less the median of its run's others: less its run's own median, a
        # run of a handful would look tighter than its noise -- the middle one of three
        # would be no error at all.)
        errors[mine] -= _median_of_others(errors[mine])
    extra = (seen.rates * config.turn_noise_s) ** 2
    core = config.core_share > 0
    return SensorCheck(
        errors=errors,
        sd=np.sqrt(model.sigma2 + extra),
        core_sd=np.sqrt((config.core_sigma**2 if core else model.sigma2) + extra),
        core_share=float(config.core_share) if core else 0.0,
        run=seen.run,
        offset=offset,
        frame_run=seen.frame_run,
        visible=seen.visible,
        seen=seen.seen,
        clutter=seen.clutter,
        p_detect=model.p_detect,
        clutter_rate=math.exp(model.log_kappa) * sensor.fov_width,
        gate=float(gate),
    )


def _median_of_others(x: FloatArray) -> FloatArray:
    """For each value, the median of the others (0 for a value alone: no offset can be told
    from it)."""
    n = x.size
    if n < 2:
        return np.zeros(n)
    order = np.argsort(x, kind="stable")
    s = x[order]
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)

    def other(j: int) -> FloatArray:
        # The j-th smallest of the others: the j-th of all, or the next one from the value's
        # own rank down.
        return np.where(rank > j, s[j], s[min(j + 1, n - 1)])

    m = n - 1  # the others' count
    if m % 2:
        return other(m // 2)
    return 0.5 * (other(m // 2 - 1) + other(m // 2))


def _landmarks_seen_from(
    L: FloatArray,
    x: FloatArray,
    max_range: float | None,
    half: float | None,
    gate: float,
    min_range: float | None = None,
) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """From the true pose ``x``: each landmark's bearing, which are within range (a bearing's
    candidates), and which are plainly in view (inside the field of view by more than
    ``gate``: what ``p_detect`` counts)."""
    d = L - x[:2]
    r = np.hypot(d[:, 0], d[:, 1])
    h = np.asarray(wrap(np.arctan2(d[:, 1], d[:, 0]) - x[2]))
    near = r > 1e-9
    if max_range is not None:
        near &= r <= max_range
    if min_range is not None:
        near &= r >= min_range
    plain = near & ((np.abs(h) <= half - gate) if half is not None else True)
    return h, near, plain


class _Sightings(NamedTuple):
    """Every bearing of some runs' frames taken as the landmark whose bearing from the true
    sensor pose is nearest (within a gate, one bearing per landmark and frame), or as
    clutter (:func:`_sightings`)."""

    errors: FloatArray  # (m,) each bearing taken as a landmark less that landmark's (rad)
    rates: FloatArray  # (m,) the truth's turn rate at its frame (rad/s)
    where: FloatArray  # (m,) the bearing itself (rad)
    run: NDArray[np.int64]  # (m,) its run
    frame_run: NDArray[np.int64]  # (F,) each frame's run (frames that saw nothing included)
    reported: NDArray[np.int64]  # (F,) the landmarks each frame reported
    clutter: NDArray[np.int64]  # (F,) its bearings taken as clutter
    visible: NDArray[np.int64]  # (F,) the landmarks plainly in view of it
    seen: NDArray[np.int64]  # (F,) of those, the ones it reported
    listed: NDArray[np.bool_]  # (F,) a frame of the log (False: one that saw nothing)
    bearings: int  # the frames' bearings


def _sightings(
    L: FloatArray,
    pairs: list[tuple[list[Frame], GroundTruth]],
    *,
    fov: float | None,
    max_range: float | None,
    min_range: float | None,
    gate: float,
    max_gap_s: float,
    frame_period_s: float | None,
    mount: Sequence[float] | None,
) -> _Sightings:
    """Each run's frames (and, with ``frame_period_s``, the frames its log's gaps left out)
    read against its true track: frames where the truth has a gap longer than ``max_gap_s``
    are left out; the bearings are measured from the truth composed with ``mount``."""
    half = None if fov is None else 0.5 * float(fov)
    errors: list[float] = []
    rates: list[float] = []
    where: list[float] = []
    run: list[int] = []
    rows: list[tuple[int, int, int, int, int, bool]] = []  # per frame, as _Sightings's
    total = 0
    inferred = 0
    seat = None if mount is None else np.asarray(mount, dtype=np.float64)
    for k, (fr, tr) in enumerate(pairs):
        t = np.array([f.t for f in fr], dtype=np.float64)
        poses, gaps = tr.at(t) if t.size else (np.zeros((0, 3)), np.zeros(0))
        before = tr.at(t - 0.1)[0] if t.size else np.zeros((0, 3))
        after = tr.at(t + 0.1)[0] if t.size else np.zeros((0, 3))
        # The bearings were measured from the sensor: the truth is the robot's (its turn
        # rate, read from before and after, is the sensor's too).
        if seat is not None:
            poses = compose(poses, seat)
        for i, f in enumerate(fr):
            x = poses[i]
            if not (np.isfinite(x).all() and gaps[i] <= max_gap_s):
                continue
            total += f.bearings.size
            h, near, plain = _landmarks_seen_from(L, x, max_range, half, gate, min_range)
            cand = np.flatnonzero(near)
            taken = np.zeros(L.shape[0], dtype=bool)
            rate = float(wrap(after[i, 2] - before[i, 2])) / 0.2
            unmatched = 0
            for b in f.bearings:
                if cand.size == 0:
                    unmatched += 1
                    continue
                e = np.asarray(wrap(b - h[cand]))
                j = int(np.argmin(np.abs(e)))
                if abs(e[j]) <= gate and not taken[cand[j]]:
                    taken[cand[j]] = True
                    errors.append(float(e[j]))
                    rates.append(rate)
                    where.append(float(b))
                    run.append(k)
                else:
                    unmatched += 1
            reported = int(taken.sum())
            rows.append(
                (k, reported, unmatched, int(plain.sum()), int((plain & taken).sum()), True)
            )
        if frame_period_s is None:
            continue
        try:
            te = empty_frame_times(np.sort(t), frame_period_s)
        except InputError as exc:
            raise InputError(f"frame_period_s: {exc}") from None
        inferred += te.size
        if inferred > MAX_EMPTY_FRAMES:
            raise InputError(
                f"frame_period_s: a period of {frame_period_s:g} s makes more than "
                f"{MAX_EMPTY_FRAMES:,} frames of the gaps: is it the frame period in seconds?"
            )
        pe, ge = tr.at(te) if te.size else (np.zeros((0, 3)), np.zeros(0))
        if seat is not None:
            pe = compose(pe, seat)
        for x, g in zip(pe, ge, strict=True):
            # A frame that saw nothing: its landmarks in view count as not reported.
            if np.isfinite(x).all() and g <= max_gap_s:
                plain = _landmarks_seen_from(L, x, max_range, half, gate, min_range)[2]
                rows.append((k, 0, 0, int(plain.sum()), 0, False))
    table = np.array(rows, dtype=np.int64).reshape(-1, 6)
    return _Sightings(
        np.array(errors, dtype=np.float64),
        np.array(rates, dtype=np.float64),
        np.array(where, dtype=np.float64),
        np.array(run, dtype=np.int64),
        table[:, 0],
        table[:, 1],
        table[:, 2],
        table[:, 3],
        table[:, 4],
        table[:, 5].astype(bool),
        total,
    )


#: Most frames :func:`estimate_frame_sensor` infers from a log's gaps (each is scored at the
#: true track): a period mistaken for milliseconds would make millions.
MAX_EMPTY_FRAMES = 1_000_000


def empty_frame_times(t: ArrayLike, period: float) -> FloatArray:
    """The times of the frames a log that lists only frames with a bearing left out: a gap
    of ``g`` seconds between two listed frames (``t`` in time order) holds
    ``round(g / period) - 1`` of them, evenly spaced (none in a gap under 1.5 periods).

    Examples
    --------
    >>> empty_frame_times([0.0, 0.25, 1.0, 1.3], 0.25).tolist()
    [0.5, 0.75]
    """
    _positive("period", period, MAX_STRETCH_S)
    try:
        t = np.asarray(t, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"t must be times in seconds, got {shorten(t)}") from None
    if not np.isfinite(t).all() or (np.diff(t) < 0).any():
        raise InputError("t must be finite times in seconds, in time order")
    gap = np.diff(t)
    # (capped: a gap of hours over a period of microseconds would not fit an int)
    with np.errstate(over="ignore"):
        k = np.where(gap > 1.5 * period, np.rint(gap / period) - 1.0, 0.0)
    n = np.minimum(k, MAX_EMPTY_FRAMES + 1.0).astype(np.int64)
    if int(n.sum()) > MAX_EMPTY_FRAMES:
        raise InputError(
            f"a period of {period:g} s makes more than {MAX_EMPTY_FRAMES:,} frames of the "
            "gaps: is it the frame period in seconds?"
        )
    if not n.any():
        return np.zeros(0)
    k = np.flatnonzero(n)
    return np.concatenate([t[i] + gap[i] * np.arange(1, n[i] + 1) / (n[i] + 1) for i in k])


@dataclass(frozen=True)
class MountFit:
    """Where the sensor sits on the robot, fitted to a recording (:func:`estimate_mount`).

    Attributes
    ----------
    mount : tuple of 3 floats
        ``(x, y, yaw)``, metres and radians (:attr:`omniloc.SensorModel.mount`).
    sd : tuple of 3 floats
        Their standard errors: the spread of the fit over recordings resampled by stretches
        of :data:`MOUNT_BLOCK_S` (a block bootstrap; a camera's bearing errors repeat for
        seconds, which the least squares' own covariance takes for independent evidence),
        at least that covariance's. With fewer than :data:`MOUNT_MIN_STRETCHES` stretches
        (``bootstrapped`` False) the least squares' own, which are optimistic when the
        errors repeat (on MRCLAM 3-5 times too small); a warning is logged.
    matched : int
        Bearings taken as a landmark's (within the gate) at the fitted mount.
    bearings : int
        Bearings with a true pose.
    residual_sd : float
        Robust spread of the matched bearings' errors at the fitted mount, radians.
    stretches : int
        Stretches of :data:`MOUNT_BLOCK_S` the matched bearings fall in (over every
        recording).
    """

    mount: tuple[float, float, float]
    sd: tuple[float, float, float]
    matched: int
    bearings: int
    residual_sd: float
    stretches: int = 0

    @property
    def bootstrapped(self) -> bool:
        """Whether ``sd`` comes from the block bootstrap (enough stretches), not from the
        least squares alone."""
        return self.stretches >= MOUNT_MIN_STRETCHES


#: Steps of the first look for the mount's yaw (a whole turn), radians.
MOUNT_YAW_STEP = math.radians(1.0)
#: The gate of the first look and of the first rounds of the fit: wide enough for a sensor
#: up to about 0.3 m from where the guess puts it (2 deg at 8 m, 6 deg at 3 m).
MOUNT_FIRST_GATE = math.radians(6.0)
#: Rounds of association and least squares.
MOUNT_ROUNDS = 8
#: Landmark/bearing pairs computed at once (memory).
MOUNT_CHUNK_PAIRS = 2_000_000
#: The block bootstrap of the standard errors: stretches of this many seconds (longer than
#: the errors' memory: MRCLAM's tubes drift over about 14 s), resampled this many times.
MOUNT_BLOCK_S = 20.0
MOUNT_BOOTSTRAP = 50
#: Fewest stretches the bootstrap resamples (with fewer, its spread says little: the
#: least squares' own standard errors are reported, with a warning).
MOUNT_MIN_STRETCHES = 5


def _nearest_landmark(
    L: FloatArray,
    poses: FloatArray,
    b: FloatArray,
    mount: FloatArray,
    max_range: float | None,
    half: float | None,
    gate: float,
) -> tuple[NDArray[np.int64], FloatArray]:
    """For each bearing (``b[i]`` seen from the robot at ``poses[i]``), the landmark whose
    bearing from the sensor (at ``compose(pose, mount)``) is nearest, within range and the
    view (its edge widened by ``gate``), and the error; -1 and NaN where none is."""
    idx = np.full(b.size, -1, dtype=np.int64)
    err = np.full(b.size, np.nan)
    step = max(1, MOUNT_CHUNK_PAIRS // max(L.shape[0], 1))
    for lo in range(0, b.size, step):
        s = compose(poses[lo : lo + step], mount)
        dx = L[None, :, 0] - s[:, 0, None]
        dy = L[None, :, 1] - s[:, 1, None]
        h = np.asarray(wrap(np.arctan2(dy, dx) - s[:, 2, None]))
        ok = np.ones(h.shape, dtype=bool)
        if max_range is not None:
            ok &= dx * dx + dy * dy <= max_range * max_range
        if half is not None:
            ok &= np.abs(h) <= half + gate
        e = np.where(ok, np.abs(np.asarray(wrap(b[lo : lo + step, None] - h))), np.inf)
        j = np.argmin(e, axis=1)
        best = e[np.arange(e.shape[0]), j]
        near = best <= gate
        idx[lo : lo + step] = np.where(near, j, -1)
        sign = np.asarray(wrap(b[lo : lo + step] - h[np.arange(h.shape[0]), j]))
        err[lo : lo + step] = np.where(near, sign, np.nan)
    return idx, err


def _mount_residuals(
    P: FloatArray, z: FloatArray, Lj: FloatArray, v: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The bearing errors ``z - h`` of each bearing's landmark ``Lj`` seen by a sensor at
    ``compose(P, v)``, and their Jacobian with respect to the mount ``v`` (n, 3)."""
    s = compose(P, v)
    dx, dy = Lj[:, 0] - s[:, 0], Lj[:, 1] - s[:, 1]
    q = dx * dx + dy * dy
    c, si = np.cos(P[:, 2]), np.sin(P[:, 2])
    r = np.asarray(wrap(z - (np.arctan2(dy, dx) - s[:, 2])))
    # dh/dv: through the sensor's position (robot frame axes turned by the robot's heading)
    # and its heading.
    J = np.stack([-(dy * c - dx * si) / q, -(-dy * si - dx * c) / q, np.ones_like(q)], axis=1)
    return r, J


def _robust_mount_fit(
    P: FloatArray, z: FloatArray, Lj: FloatArray, v: FloatArray, scale: float
) -> tuple[FloatArray, FloatArray]:
    """The mount that minimises the soft-L1 loss (scale ``scale``) of the bearing errors of
    fixed pairs: iteratively reweighted Gauss-Newton, a step that does not lower the loss
    halved. Returns the mount and the Jacobian at it (unweighted)."""

    def loss(r: FloatArray) -> float:
        return float(np.sum(2.0 * (np.sqrt(1.0 + (r / scale) ** 2) - 1.0)))

    r, J = _mount_residuals(P, z, Lj, v)
    cost = loss(r)
    for _ in range(50):
        w = 1.0 / np.sqrt(1.0 + (r / scale) ** 2)
        A = J.T @ (w[:, None] * J)
        try:
            step = -np.linalg.solve(A, J.T @ (w * r))
        except np.linalg.LinAlgError:
            break
        for _ in range(30):
            cand = v + step
            r2, J2 = _mount_residuals(P, z, Lj, cand)
            if (c2 := loss(r2)) <= cost:
                break
            step = 0.5 * step
        else:
            break
        done = cost - c2 <= 1e-12 * max(cost, 1e-300)
        v, r, J, cost = cand, r2, J2, c2
        if done:
            break
    return np.array([v[0], v[1], float(wrap(v[2]))]), J


def _mount_bootstrap(
    P: FloatArray,
    z: FloatArray,
    Lj: FloatArray,
    block: NDArray[np.int64],
    m: FloatArray,
    gate: float,
) -> FloatArray:
    """Standard errors of the mount ``m`` fitted to the pairs (robot poses ``P``, bearings
    ``z``, their landmarks ``Lj``): the spread of the fit over :data:`MOUNT_BOOTSTRAP`
    resamplings of the stretches ``block`` (with replacement, seeded: the same figures each
    run). Zeros with fewer than :data:`MOUNT_MIN_STRETCHES` stretches."""
    stretches = [np.flatnonzero(block == k) for k in np.unique(block)]
    if len(stretches) < MOUNT_MIN_STRETCHES:
        return np.zeros(3)
    rng = np.random.default_rng(0)
    fits = []
    for _ in range(MOUNT_BOOTSTRAP):
        pick = np.concatenate(
            [stretches[k] for k in rng.integers(0, len(stretches), len(stretches))]
        )
        v, _ = _robust_mount_fit(P[pick], z[pick], Lj[pick], m, gate / 3.0)
        fits.append([v[0] - m[0], v[1] - m[1], float(wrap(v[2] - m[2]))])
    return np.asarray(np.std(np.array(fits), axis=0, ddof=1))


def estimate_mount(
    landmarks: LandmarkMap | ArrayLike,
    frames: Sequence[Frame] | Sequence[Sequence[Frame]],
    truth: GroundTruth | Sequence[GroundTruth],
    *,
    fov: float | None = None,
    max_range: float | None = None,
    gate: float = math.radians(3.0),
    max_gap_s: float = 0.5,
    initial: Sequence[float] | None = None,
) -> MountFit:
    """Fit where the sensor sits on the robot, ``(x, y, yaw)`` (:attr:`omniloc.SensorModel.
    mount`), to frames of bearings and the robot's true track: a camera's extrinsics from a
    motion-capture session, without landmark ids.

    First the yaw: a whole turn in steps of :data:`MOUNT_YAW_STEP` at the guessed ``x, y``
    (then a tenth of a step around the best), the one whose bearings' errors to the nearest
    landmark, each at most :data:`MOUNT_FIRST_GATE`, have the least sum of squares. Then
    rounds of association (each bearing to the landmark whose bearing from the sensor is
    nearest, within the gate) and robust least squares on the bearing errors (soft L1 at
    ``gate / 3``, iteratively reweighted Gauss-Newton), until the association stands; once
    at ``gate`` throughout and once with two rounds at the wide gate first (a sensor far
    from the guess), keeping the mount whose errors, each at most ``gate``, sum least. The
    guess must put the sensor within about 0.3 m of where it is (the yaw may be anything).

    On MRCLAM set 6 (``fov`` 67 deg, ``max_range`` 7 m) it finds robot 4's camera 0.094 m
    ahead of the tracked centre and turned 0.61 deg, the others within 0.04 m and 0.13 deg:
    what a fit told the landmark of each bearing (and a clock offset) found
    (``benchmarks/bearing_correlation.py``: 0.089 m and 0.73 deg).

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
    frames : sequence of Frame, or a list of them
        The recording's bearings (landmark ids, if any, are not used); several recordings
        of one robot: a list of each one's frames.
    truth : GroundTruth, or a list of them
        The robot's true track (its origin, not the sensor's), one per recording.
    fov : float, optional
        The sensor's full field of view (rad), about its own forward axis.
    max_range : float, optional
        Range (m) beyond which no landmark is taken as in view.
    gate : float
        A bearing within this (rad) of the nearest landmark's counts as that landmark's.
    max_gap_s : float
        Frames where the true track has a gap longer than this (s) are left out.
    initial : sequence of 3 floats, optional
        A guess ``(x, y, yaw)``; only its ``x, y`` matter (default 0, 0).

    Returns
    -------
    MountFit

    Raises
    ------
    InputError
        Fewer than 20 bearings matched, a recording that cannot tell the mount's three
        values apart (a robot that never moved or turned), or an argument out of range.

    Examples
    --------
    >>> from omniloc import Pose
    >>> from omniloc.track.simulate import EXAMPLE_MAP, EXAMPLE_SENSOR, simulate_run
    >>> run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR.replace(mount=(0.2, 0.0, 0.5)),
    ...                    Pose(6.0, 4.0, 0.3), duration_s=30.0, rng=3)
    >>> fit = estimate_mount(EXAMPLE_MAP, run.frames, run.truth, max_range=5.0)
    >>> [round(v, 2) + 0.0 for v in fit.mount]  # (+ 0.0: no minus zero)
    [0.2, 0.0, 0.5]
    """
    lm = as_landmark_map(landmarks)
    pairs = _paired(frames, truth, _frame_list, "frames", "recording")
    _check_view(gate, max_gap_s, fov, max_range)
    start = SensorModel(mount=initial).mount if initial is not None else None  # type: ignore[arg-type]
    guess = np.zeros(3) if start is None else np.array(start)
    half = None if fov is None or fov >= 2 * math.pi else 0.5 * float(fov)
    poses_l: list[FloatArray] = []
    bear_l: list[FloatArray] = []
    block_l: list[tuple[int, int]] = []  # (recording, stretch) of each bearing
    for r, (fr, tr) in enumerate(pairs):
        t_first = min((f.t for f in fr), default=0.0)
        for f in fr:
            if f.bearings.size == 0:
                continue
            p, g = tr.at(f.t)
            if np.isfinite(p).all() and g[0] <= max_gap_s:
                poses_l.append(np.repeat(p, f.bearings.size, axis=0))
                bear_l.append(np.asarray(f.bearings, dtype=np.float64))
                block_l += [(r, int((f.t - t_first) // MOUNT_BLOCK_S))] * f.bearings.size
    if not bear_l:
        raise InputError("no frame with bearings lies on the true track: nothing to fit")
    poses, b = np.concatenate(poses_l), np.concatenate(bear_l)
    block = np.unique(np.array(block_l, dtype=np.int64), axis=0, return_inverse=True)[1]
    block = block.reshape(-1)
    L = np.asarray(lm.xy, dtype=np.float64)
    wide = max(MOUNT_FIRST_GATE, float(gate))

    def matched(m: FloatArray, g: float) -> tuple[NDArray[np.int64], FloatArray]:
        return _nearest_landmark(L, poses, b, m, max_range, half, g)

    def score(v: FloatArray, g: float = float(gate)) -> float:
        # Truncated squares: each bearing's error, at most the gate (none within: the gate).
        err = matched(v, g)[1]
        return float(np.sum(np.where(np.isfinite(err), np.minimum(err * err, g * g), g * g)))

    # The yaw: a whole turn at the guessed place, then a tenth of a step around the best.
    yaws = np.arange(-math.pi, math.pi, MOUNT_YAW_STEP)
    y0 = 0.0
    for _ in range(2):
        costs = [score(np.array([guess[0], guess[1], y]), wide) for y in yaws]
        y0 = float(yaws[int(np.argmin(costs))])
        yaws = y0 + MOUNT_YAW_STEP * np.arange(-1.0, 1.05, 0.1)
    m = np.array([guess[0], guess[1], float(wrap(y0))])

    def rounds(m: FloatArray, first: float) -> tuple[FloatArray, FloatArray] | int:
        # Association and robust least squares until the association stands: the first two
        # rounds at the gate ``first``, the others at ``gate``. (The count of bearings
        # matched where too few are to fit.)
        last: NDArray[np.int64] | None = None
        jac = np.zeros((0, 3))
        for k in range(MOUNT_ROUNDS):
            g = first if k < 2 else float(gate)
            idx, _ = matched(m, g)
            if k >= 2 and last is not None and np.array_equal(idx, last):
                break
            last = idx
            use = np.flatnonzero(idx >= 0)
            if use.size < MIN_ERRORS:
                return int(use.size)
            m, jac = _robust_mount_fit(poses[use], b[use], L[idx[use]], m, float(gate) / 3.0)
        return m, jac

    # Two chains from the first look: at the gate throughout, and with two rounds at the wide
    # gate first (for a sensor far from the guess; there, clutter may pass for landmarks and
    # pull the mount away). The one whose mount explains the bearings better is kept.
    chains = [c for c in (rounds(m, float(gate)), rounds(m, wide)) if not isinstance(c, int)]
    if not chains:
        raise InputError(
            f"too few bearings within {math.degrees(gate):.1f} deg of a landmark from any "
            f"mount near the guess to fit it (at least {MIN_ERRORS}; do the frames, the map "
            "and the truth belong together? is the guess within about 0.3 m?)"
        )
    m, J = min(chains, key=lambda c: score(c[0]))
    idx, err = matched(m, float(gate))
    e = err[idx >= 0]
    if e.size < MIN_ERRORS:
        raise InputError(
            f"only {e.size} bearings within {math.degrees(gate):.1f} deg of a landmark at the "
            "fitted mount: too few to trust it"
        )
    spread = 1.4826 * float(np.median(np.abs(e - np.median(e))))
    JtJ = J.T @ J
    if not np.isfinite(JtJ).all() or np.linalg.cond(JtJ) > 1e12:
        raise InputError(
            "the recording cannot tell the mount's x, y and yaw apart (landmarks seen from "
            "too few places and ranges): measure the mount, or record the robot driving and "
            "turning among the landmarks"
        )
    cov = np.linalg.inv(JtJ) * max(spread, 1e-12) ** 2
    sd = np.maximum(
        np.sqrt(np.maximum(np.diag(cov), 0.0)),
        _mount_bootstrap(poses[idx >= 0], b[idx >= 0], L[idx[idx >= 0]], block[idx >= 0], m, gate),
    )
    x, y, yaw = (float(v) for v in m)
    for name, v in (("x", x), ("y", y)):
        if abs(v) > 10.0:
            raise InputError(
                f"the fitted mount puts the sensor {v:.3g} m from the robot's origin in {name}: "
                "not a mount (do the frames and the truth belong together?)"
            )
    n_stretches = int(np.unique(block[idx >= 0]).size)
    if n_stretches < MOUNT_MIN_STRETCHES:
        log.warning(
            "the mount's bearings span %d stretch(es) of %g s, fewer than %d: its standard "
            "errors are the least squares' own, which take a camera's repeating errors for "
            "independent evidence (likely too small); record longer for honest ones",
            n_stretches,
            MOUNT_BLOCK_S,
            MOUNT_MIN_STRETCHES,
        )
    return MountFit(
        (x, y, yaw),
        (float(sd[0]), float(sd[1]), float(sd[2])),
        int(e.size),
        int(b.size),
        spread,
        n_stretches,
    )
