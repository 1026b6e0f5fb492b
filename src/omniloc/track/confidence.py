"""A tracker's confidence: its own probability, mapped to what recordings measured.

The :class:`~omniloc.track.Tracker` says, every frame, how probable it is that its pose is
within its tolerance of the truth (:attr:`~omniloc.track.TrackEstimate.probability`: the
best place's share of the mass times the chance its covariance gives the tolerance). That
is the model's number, and a model is never the camera: on MRCLAM, whose bearing errors
and detections repeat from frame to frame, 0.97 is right about two times in three.

A *confidence map* is what a recording with a ground truth says instead: per state
(``localized``, ``ambiguous``), the share of frames whose pose was within the tolerance,
as a non-decreasing function of the model's probability (isotonic regression,
``scipy.optimize.isotonic_regression``, on the frames sorted by it; each block's share
taken with half a frame right and half wrong added, so that a block of a few frames, all
right, does not say 1). It is given to the tracker as two tables of knots ``(probability,
confidence)`` (``TrackerConfig.confidence_localized`` and ``confidence_ambiguous``),
linear between knots and flat beyond them, and the tracker then reports
:attr:`~omniloc.track.TrackEstimate.confidence` beside its own probability.

An ``ambiguous`` frame soon after a ``localized`` one is another matter than one of a
tracker still searching: the place it held is most often still the best, and right more
often than the probability says, while a frame that has never been localized is right
less often. So the ambiguous frames within ``recent_s`` seconds of the last ``localized``
one (:attr:`~omniloc.track.TrackEstimate.since_localized`) have a table of their own
(``TrackerConfig.confidence_recent``, with ``confidence_recent_s``): on MRCLAM, held out
by robot, it takes the whole runs' expected calibration error from 0.035 to 0.025, and the
kidnapped and plain streams' from 0.063 and 0.056 to 0.050 and 0.035
(docs/tracking-notebook.md, "A confidence for the frames after a localized one").

The same holds for each reported hypothesis's weight: a third table
(``TrackerConfig.confidence_hypothesis``) maps it to the share of hypotheses of that weight
whose pose was within tolerance, and each :class:`~omniloc.track.Hypothesis` carries that
``confidence``.

:func:`fit_confidence` fits the tables from frames scored against a ground truth
(:func:`fit_table` one table from any values and outcomes);
:func:`confidence_of` applies one; :func:`held_out_confidence` gives each frame the
confidence of tables fitted without its own run (what to expect on a run not fitted on).
A map is a measurement of one robot, camera and map: check it on runs it was not fitted on
(``benchmarks/track_confidence.py`` fits on four of MRCLAM's robots and scores the fifth).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import isotonic_regression

from ..errors import InputError
from ..io import real_array, shorten
from .records import TrackState

__all__ = [
    "RECENT_S",
    "ConfidenceFit",
    "confidence_of",
    "confidence_table",
    "fit_confidence",
    "fit_table",
    "held_out_confidence",
    "held_out_table",
    "is_recent",
]

#: At most this many knots in a table (a fit merges neighbouring blocks beyond it).
MAX_KNOTS = 200

#: A table: knots ``(probability, confidence)``, the probabilities increasing.
Knots = tuple[tuple[float, float], ...]

#: An ambiguous frame at most this many seconds after the last localized one is read by the
#: ``recent`` table (``TrackerConfig.confidence_recent_s``; chosen on MRCLAM's whole runs
#: held out by robot: 10 s 0.038, 20 s 0.025, 30 s 0.026, 60 s 0.031).
RECENT_S = 20.0

#: The tables' names in a fit, and the contexts of a frame: localized; ambiguous within
#: ``recent_s`` of a localized frame; any other ambiguous frame.
CONTEXTS = ("localized", "recent", "ambiguous")


def confidence_table(name: str, value: Any) -> Knots | None:
    """A confidence table checked: None, or 1 to ``MAX_KNOTS`` pairs ``(probability,
    confidence)`` in [0, 1], the probabilities strictly increasing and the confidences
    non-decreasing (a higher probability of the model never means a lower confidence).

    Raises
    ------
    InputError
        Naming ``name`` and what is wrong.

    Examples
    --------
    >>> confidence_table("t", [[0.5, 0.2], [0.99, 0.9]])
    ((0.5, 0.2), (0.99, 0.9))
    """
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise InputError(
            f"{name} must be None or pairs (probability, confidence), got {shorten(value)}"
        )
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(
            f"{name} must be pairs (probability, confidence) of numbers, got {shorten(value)}"
        ) from exc
    if a.ndim != 2 or a.shape[1] != 2 or not 1 <= a.shape[0] <= MAX_KNOTS:
        raise InputError(
            f"{name} must be 1 to {MAX_KNOTS} pairs (probability, confidence), got {shorten(value)}"
        )
    if not (np.isfinite(a).all() and (a >= 0.0).all() and (a <= 1.0).all()):
        raise InputError(f"{name} must hold numbers in [0, 1], got {shorten(value)}")
    if not (np.diff(a[:, 0]) > 0.0).all():
        raise InputError(f"{name}: the probabilities must increase, got {shorten(value)}")
    if not (np.diff(a[:, 1]) >= 0.0).all():
        raise InputError(
            f"{name}: the confidences must not decrease as the probability grows, got "
            f"{shorten(value)}"
        )
    return tuple((float(p), float(c)) for p, c in a)


def confidence_of(table: Knots | None, probability: float) -> float | None:
    """The confidence a table (as :func:`confidence_table` returns it) gives a model
    probability: linear between knots, flat beyond them; None without a table or for a
    probability that is NaN.

    Raises
    ------
    InputError
        A probability that is not a real number.

    Examples
    --------
    >>> round(confidence_of(((0.5, 0.2), (0.9, 0.6)), 0.7), 6)
    0.4
    >>> confidence_of(((0.5, 0.2), (0.9, 0.6)), 0.99)
    0.6
    """
    if isinstance(probability, bool) or not isinstance(probability, (int, float, np.number)):
        raise InputError(f"probability must be a number, got {shorten(probability)}")
    try:
        x = float(probability)
    except (OverflowError, TypeError) as exc:
        raise InputError(f"probability must be a number, got {shorten(probability)}") from exc
    return _interpolate(None if table is None else knot_arrays(table), np.array([x]))[0]


def knot_arrays(table: Knots) -> tuple[np.ndarray, np.ndarray]:
    """A table's knots as two arrays (probabilities, confidences), for reading many values
    (:class:`~omniloc.track.Tracker` makes them once)."""
    return np.array([k[0] for k in table]), np.array([k[1] for k in table])


def _interpolate(
    arrays: tuple[np.ndarray, np.ndarray] | None, values: np.ndarray
) -> list[float | None]:
    """What a table (its :func:`knot_arrays`) gives each of ``values``: linear between
    knots, flat beyond them, within [0, 1]; None without a table or for a NaN. The one
    reading of a table: :func:`confidence_of` and the tracker both call it."""
    if arrays is None:
        return [None] * values.size
    out = np.clip(np.interp(values, arrays[0], arrays[1]), 0.0, 1.0).tolist()
    return [None if math.isnan(v) else c for v, c in zip(values.tolist(), out, strict=True)]


@dataclass(frozen=True)
class ConfidenceFit:
    """Confidence tables fitted on scored frames (:func:`fit_confidence`).

    Attributes
    ----------
    localized, ambiguous : tuple of (probability, confidence), or None
        The knots of each state's table (None: no frame in that state). ``ambiguous`` is
        fitted on the ambiguous frames that ``recent`` does not take.
    frames : dict of str to int
        Frames each table was fitted on, by table (``"localized"``, ``"recent"``,
        ``"ambiguous"``; and ``"hypothesis"``: hypotheses).
    right : dict of str to int
        Of them, those within tolerance.
    hypothesis : tuple of (weight, confidence), or None
        The hypotheses' table (None: not fitted).
    recent : tuple of (probability, confidence), or None
        The table of the ambiguous frames at most ``recent_s`` seconds after a localized
        one (None: not fitted -- no ``since_localized`` given -- or no such frame).
    recent_s : float or None
        Its span, seconds (None when ``since_localized`` was not given).
    hypothesis_recent : tuple of (weight, confidence), or None
        The table of the hypotheses of the frames at most ``recent_s`` seconds after a
        localized one (localized frames included; then ``hypothesis`` is fitted on the
        others). None: not fitted (no ``hypothesis_since_localized``) or no such hypothesis.
    backward : tuple of (probability, confidence), or None
        The table of the frames the pass backward reported ``localized`` (then
        ``localized`` is fitted on the others). None: not fitted (no ``backward`` flags) or
        no such frame.
    """

    localized: Knots | None
    ambiguous: Knots | None
    frames: dict[str, int]
    right: dict[str, int]
    hypothesis: Knots | None = None
    recent: Knots | None = None
    recent_s: float | None = None
    hypothesis_recent: Knots | None = None
    backward: Knots | None = None

    def settings(self) -> dict[str, Any]:
        """The tables as tracker settings (``with_settings``, ``--config``): every table
        (``confidence_localized``, ``confidence_ambiguous``, ``confidence_recent``,
        ``confidence_hypothesis``, ``confidence_hypothesis_recent``,
        ``confidence_backward``; None where this fit has none, so that applied over a
        preset's tables it leaves none of them behind to be read beside its own), and
        ``confidence_recent_s`` when a span was fitted."""
        out: dict[str, Any] = {
            "confidence_localized": self.localized,
            "confidence_ambiguous": self.ambiguous,
            "confidence_recent": self.recent,
            "confidence_hypothesis": self.hypothesis,
            "confidence_hypothesis_recent": self.hypothesis_recent,
            "confidence_backward": self.backward,
        }
        if self.recent_s is not None:
            out["confidence_recent_s"] = self.recent_s
        return out

    def __call__(
        self,
        state: TrackState | str,
        probability: float,
        since_localized: float | None = None,
        *,
        backward: bool = False,
    ) -> float | None:
        """The confidence of a frame in ``state`` with the model's ``probability``, and
        ``since_localized`` seconds after the last localized frame (None: none since the
        tracker started or was flagged kidnapped); ``backward``: a frame the pass backward
        reported (:attr:`~omniloc.track.TrackEstimate.backward`), read by the ``backward``
        table (None without one)."""
        s = TrackState(state)
        if since_localized is not None:
            real = (int, float, np.integer, np.floating)
            if isinstance(since_localized, bool) or not isinstance(since_localized, real):
                raise InputError(
                    f"since_localized must be None or seconds, got {shorten(since_localized)}"
                )
            # (As in a fit: seconds >= 0, NaN for never; a negative time would read the
            # recent table, which is surer.)
            x = float(since_localized)
            if x < 0.0 or x == math.inf:
                raise InputError(
                    f"since_localized must be seconds >= 0 (None or NaN: never localized), "
                    f"got {x!r}"
                )
        if s is TrackState.LOST:
            return None
        if backward and s is TrackState.LOCALIZED:
            return confidence_of(self.backward, probability)
        return confidence_of(self._table(s, since_localized), probability)

    def _table(self, state: TrackState, since_localized: float | None) -> Knots | None:
        if state is TrackState.LOCALIZED:
            return self.localized
        if self.recent is not None and self.recent_s is not None:
            if is_recent(since_localized, self.recent_s):
                return self.recent
        return self.ambiguous


def _isotonic_knots(p: np.ndarray, right: np.ndarray) -> Knots:
    """One state's knots: the frames' equal probabilities pooled, isotonic regression of
    the share right on them, each block's share with half a frame right and half wrong
    added, at the block's mean probability."""
    u, inv = np.unique(p, return_inverse=True)
    n = np.bincount(inv, minlength=u.size).astype(np.float64)
    k = np.bincount(inv, weights=right.astype(np.float64), minlength=u.size)
    fit = isotonic_regression(k / n, weights=n, increasing=True)
    starts = np.asarray(fit.blocks[:-1], dtype=np.int64)
    blocks_n = np.add.reduceat(n, starts)
    blocks_k = np.add.reduceat(k, starts)
    blocks_p = np.add.reduceat(u * n, starts)
    while blocks_n.size > MAX_KNOTS:
        # (Neighbouring blocks merged in pairs: the shares stay in order.)
        cut = np.arange(0, blocks_n.size, 2)
        blocks_n = np.add.reduceat(blocks_n, cut)
        blocks_k = np.add.reduceat(blocks_k, cut)
        blocks_p = np.add.reduceat(blocks_p, cut)
    centre = blocks_p / blocks_n
    share = np.maximum.accumulate((blocks_k + 0.5) / (blocks_n + 1.0))
    return tuple((float(a), float(b)) for a, b in zip(centre, share, strict=True))


def _frames(
    states: Any, probabilities: Any, right: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frames of :func:`fit_confidence` checked: states (their values, an object
    array), probabilities (float) and right (bool), one each per frame."""
    names = [s.value for s in TrackState]
    if isinstance(states, (str, bytes)) or not isinstance(states, (Sequence, np.ndarray)):
        raise InputError(f"states must be a sequence of {names}, got {shorten(states)}")
    try:
        kind = np.array([TrackState(s).value for s in states], dtype=object)
    except (ValueError, TypeError) as exc:
        raise InputError(f"states must each be one of {names}: {exc}") from exc
    p = real_array(probabilities, "probabilities", InputError)
    ok = np.asarray(right) if right is not None else np.zeros(0)
    if p.ndim != 1 or ok.ndim != 1 or not (kind.size == p.size == ok.size):
        raise InputError(
            f"states, probabilities and right must have one entry per frame (1-D), got "
            f"{kind.size}, shape {p.shape} and shape {ok.shape}"
        )
    ok = _booleans(ok, "right must hold booleans (within tolerance or not)")
    posed = kind != TrackState.LOST.value
    if not posed.any():
        raise InputError("states: every frame is lost; a fit needs frames with a pose")
    with np.errstate(invalid="ignore"):
        bad = posed & ~((p >= 0.0) & (p <= 1.0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"probabilities must lie in [0, 1] for frames with a pose: frame {i} has {p[i]!r}"
        )
    return kind, p, ok


def fit_table(values: ArrayLike, right: ArrayLike) -> Knots:
    """One table: knots ``(value, confidence)`` fitted on values in [0, 1] (a model's
    probabilities, or hypotheses' weights) and whether each case was right (isotonic
    regression, half a case right and half wrong added to each block).

    Raises
    ------
    InputError
        Values outside [0, 1], lengths that differ, outcomes that are not booleans, or no
        case at all.

    Examples
    --------
    >>> fit_table([0.2, 0.9, 0.9], [False, True, True])
    ((0.2, 0.25), (0.9, 0.8333333333333334))
    """
    n = int(np.size(values)) if values is not None else 0
    if n == 0:
        raise InputError("values: fit_table needs at least one value and its outcome")
    _, v, ok = _frames(["ambiguous"] * n, values, right)
    return _isotonic_knots(v, ok)


def is_recent(since_localized: ArrayLike | None, recent_s: float) -> Any:
    """Whether a frame came at most ``recent_s`` seconds after a localized one (its
    ``since_localized``; None or NaN: never localized since the start or the last flag):
    the one rule for which frames the recent tables read. A bool for a number or None, a
    bool array for an array."""
    if since_localized is None:
        return False
    if isinstance(since_localized, float):  # (the tracker's, every frame: NaN is False)
        return bool(since_localized <= recent_s)
    with np.errstate(invalid="ignore"):
        out = np.asarray(since_localized, dtype=np.float64) <= recent_s
    return bool(out) if out.ndim == 0 else out


def _span(recent_s: Any) -> float:
    """``recent_s`` checked: finite seconds >= 0."""
    real = (int, float, np.integer, np.floating)
    if isinstance(recent_s, bool) or not isinstance(recent_s, real):
        raise InputError(f"recent_s must be a number of seconds, got {shorten(recent_s)}")
    try:
        span = float(recent_s)
    except OverflowError as exc:
        raise InputError(f"recent_s must be a number of seconds, got {shorten(recent_s)}") from exc
    if not (math.isfinite(span) and span >= 0.0):
        raise InputError(f"recent_s must be finite and >= 0 seconds, got {shorten(recent_s)}")
    return span


def _since(values: Any, n: int, name: str) -> np.ndarray:
    """Times since localized checked: one per case (1-D), seconds >= 0 or NaN (never)."""
    since = real_array(values, name, InputError)
    if since.ndim != 1 or since.size != n:
        raise InputError(
            f"{name} must hold one entry per case (1-D; None or NaN: never localized), got "
            f"shape {since.shape} for {n}"
        )
    if (since < 0.0).any() or np.isposinf(since).any():
        i = int(np.flatnonzero((since < 0.0) | np.isposinf(since))[0])
        raise InputError(
            f"{name} must be seconds >= 0 (None or NaN: never localized): entry {i} has "
            f"{float(since[i])!r}"
        )
    return since


def _contexts(
    kind: np.ndarray, since_localized: Any, recent_s: Any, n: int
) -> tuple[np.ndarray, float | None, np.ndarray | None]:
    """Each frame's table (:data:`CONTEXTS`; ``"lost"`` for a lost frame): its state, and
    for an ambiguous frame ``"recent"`` when it came at most ``recent_s`` seconds after a
    localized one; the span; and the times since localized checked (NaN: never). Without
    ``since_localized``, no frame is ``recent`` (and the span and times are None)."""
    if since_localized is None:
        return kind.copy(), None, None
    span = _span(recent_s)
    since = _since(since_localized, n, "since_localized")
    ctx = kind.copy()
    ctx[(kind == TrackState.AMBIGUOUS.value) & is_recent(since, span)] = "recent"
    return ctx, span, since


def fit_confidence(
    states: Sequence[TrackState | str],
    probabilities: ArrayLike,
    right: ArrayLike,
    *,
    since_localized: ArrayLike | None = None,
    recent_s: float = RECENT_S,
    hypothesis_weights: ArrayLike | None = None,
    hypothesis_right: ArrayLike | None = None,
    hypothesis_since_localized: ArrayLike | None = None,
    backward: ArrayLike | None = None,
) -> ConfidenceFit:
    """Fit confidence tables on frames scored against a ground truth.

    Parameters
    ----------
    states : sequence of TrackState or str
        Each frame's state (``lost`` frames are left out: they report no pose).
    probabilities : array_like of float, shape (n,)
        Each frame's :attr:`~omniloc.track.TrackEstimate.probability` (NaN for a lost frame).
    right : array_like of bool, shape (n,)
        Whether each frame's pose was within the tolerance of the truth (the tracker's
        ``tolerance_m`` and ``tolerance_heading``: the confidence is a probability of that).
    since_localized : array_like of float, shape (n,), optional
        Each frame's :attr:`~omniloc.track.TrackEstimate.since_localized` (None or NaN:
        not localized since the start or a kidnapping). With it, the ambiguous frames at
        most ``recent_s`` seconds after a localized one get a table of their own
        (``recent``); without it, one table for every ambiguous frame.
    recent_s : float
        That span, seconds (default :data:`RECENT_S`).
    hypothesis_weights, hypothesis_right : array_like, optional
        Every reported hypothesis's weight, and whether its pose was within tolerance:
        the hypotheses' table (:func:`fit_table`), given together.
    hypothesis_since_localized : array_like of float, optional
        Each hypothesis's frame's ``since_localized``: with it, the hypotheses of the frames
        at most ``recent_s`` seconds after a localized one (localized frames included) get
        a table of their own (``hypothesis_recent``).
    backward : array_like of bool, shape (n,), optional
        Whether each frame was reported by the pass backward over a recording
        (:attr:`~omniloc.track.TrackEstimate.backward`): the localized ones get a table of
        their own (``backward``), and ``localized`` is fitted on the others.

    Returns
    -------
    ConfidenceFit

    Raises
    ------
    InputError
        Lengths that differ, a state that is not one, a probability outside [0, 1] for a
        frame that is not lost, a negative time since localized, or no frame with a pose.

    Examples
    --------
    >>> fit = fit_confidence(["localized"] * 4, [0.9, 0.95, 0.99, 0.999], [True] * 4)
    >>> fit.frames["localized"], fit("localized", 0.99) > 0.8
    (4, True)
    >>> fit = fit_confidence(
    ...     ["ambiguous"] * 4, [0.5] * 4, [True, True, False, False],
    ...     since_localized=[1.0, 2.0, None, 60.0],
    ... )
    >>> fit("ambiguous", 0.5, since_localized=1.5), fit("ambiguous", 0.5)
    (0.8333333333333334, 0.16666666666666666)
    """
    kind, p, ok = _frames(states, probabilities, right)
    ctx, span, _ = _contexts(kind, since_localized, recent_s, kind.size)
    flags = _backward(backward, kind)
    if flags is not None:
        ctx[flags] = "backward"
    tables: dict[str, Knots | None] = {}
    frames: dict[str, int] = {}
    rights: dict[str, int] = {}
    for name in (*CONTEXTS, "backward"):
        if (name == "recent" and span is None) or (name == "backward" and flags is None):
            continue
        sel = ctx == name
        frames[name] = int(sel.sum())
        rights[name] = int(ok[sel].sum())
        tables[name] = _isotonic_knots(p[sel], ok[sel]) if sel.any() else None
    hyp: Knots | None = None
    hyp_recent: Knots | None = None
    if (hypothesis_weights is None) != (hypothesis_right is None):
        raise InputError("hypothesis_weights and hypothesis_right go together: give both")
    if hypothesis_since_localized is not None and hypothesis_weights is None:
        raise InputError("hypothesis_since_localized needs hypothesis_weights and _right")
    if hypothesis_weights is not None and hypothesis_right is not None:
        n = int(np.size(hypothesis_weights))
        if n == 0:
            raise InputError("hypothesis_weights: no hypothesis to fit on")
        try:
            _, hw, hr = _frames(["ambiguous"] * n, hypothesis_weights, hypothesis_right)
        except InputError as exc:
            raise InputError(f"hypothesis_weights and hypothesis_right: {exc}") from exc
        soon = np.zeros(n, dtype=bool)
        if hypothesis_since_localized is not None:
            span = _span(recent_s) if span is None else span
            hs = _since(hypothesis_since_localized, n, "hypothesis_since_localized")
            soon = is_recent(hs, span)
            frames["hypothesis_recent"] = int(soon.sum())
            rights["hypothesis_recent"] = int(hr[soon].sum())
            hyp_recent = _isotonic_knots(hw[soon], hr[soon]) if soon.any() else None
        frames["hypothesis"] = int((~soon).sum())
        rights["hypothesis"] = int(hr[~soon].sum())
        hyp = _isotonic_knots(hw[~soon], hr[~soon]) if (~soon).any() else None
    return ConfidenceFit(
        tables["localized"],
        tables["ambiguous"],
        frames,
        rights,
        hyp,
        tables.get("recent"),
        span,
        hyp_recent,
        tables.get("backward"),
    )


def _backward(flags: Any, kind: np.ndarray) -> np.ndarray | None:
    """The pass backward's flags checked (one bool per frame), as the localized frames they
    mark; None without flags."""
    if flags is None:
        return None
    if isinstance(flags, (str, bytes, dict)):
        raise InputError(f"backward must hold one flag per frame, got {shorten(flags)}")
    b = np.asarray(flags)
    if b.ndim != 1 or b.size != kind.size:
        raise InputError(
            f"backward must hold one flag per frame (1-D), got shape {b.shape} for "
            f"{kind.size} frames"
        )
    b = _booleans(b, "backward must hold booleans (reported by the pass backward or not)")
    return b & (kind == TrackState.LOCALIZED.value)


def _booleans(a: np.ndarray, message: str) -> np.ndarray:
    """``a`` as booleans: bools as they are, numbers 0 and 1 converted; else InputError
    with ``message``."""
    if a.dtype == np.bool_:
        return a
    if not (a.dtype.kind in "iuf" and np.isin(a, (0, 1)).all()):
        raise InputError(message)
    return a.astype(bool)


def held_out_confidence(
    states: Sequence[TrackState | str],
    probabilities: ArrayLike,
    right: ArrayLike,
    groups: ArrayLike,
    *,
    since_localized: ArrayLike | None = None,
    recent_s: float = RECENT_S,
    backward: ArrayLike | None = None,
) -> np.ndarray:
    """Each frame's confidence from tables fitted on the frames of the other groups (runs,
    robots): how a table fitted on some runs does on another.

    Parameters
    ----------
    states, probabilities, right, since_localized, recent_s, backward
        As for :func:`fit_confidence`.
    groups : array_like, shape (n,)
        Each frame's run (any labels); at least two.

    Returns
    -------
    ndarray, shape (n,)
        The held-out confidence (NaN for a lost frame, or where the other groups have no
        frame of its table nor, for a recent frame, an ambiguous one).

    Raises
    ------
    InputError
        Fewer than two groups, or ``groups`` of another length.
    """
    st, p, ok = _frames(states, probabilities, right)
    _, span, since = _contexts(st, since_localized, recent_s, st.size)
    flags = _backward(backward, st)
    g, labels = _groups(groups, st.size)
    out = np.full(st.size, np.nan)
    for label in labels:
        mine = g == label
        others = ~mine & (st != TrackState.LOST.value)
        if not others.any():
            continue
        fit = fit_confidence(
            st[~mine],
            p[~mine],
            ok[~mine],
            since_localized=None if since is None else since[~mine],
            recent_s=RECENT_S if span is None else span,
            backward=None if flags is None else flags[~mine],
        )
        for i in np.flatnonzero(mine & (st != TrackState.LOST.value)).tolist():
            c = fit(
                st[i],
                float(p[i]),
                None if since is None else float(since[i]),
                backward=flags is not None and bool(flags[i]),
            )
            out[i] = np.nan if c is None else c
    return out


def _groups(groups: Any, n: int) -> tuple[np.ndarray, list[Any]]:
    """Run labels checked: one per case (1-D), at least two runs; and the runs in order."""
    if groups is None or isinstance(groups, (str, bytes, dict)):
        raise InputError(f"groups must hold one run label per frame, got {shorten(groups)}")
    g = np.asarray(groups)
    if g.ndim != 1 or g.size != n:
        raise InputError(
            f"groups must hold one run label per frame (1-D), got shape {g.shape} for {n} frames"
        )
    labels = list(dict.fromkeys(g.tolist()))
    if len(labels) < 2:
        raise InputError("groups: a held-out fit needs frames of at least two runs")
    return g, labels


def held_out_table(
    values: ArrayLike, right: ArrayLike, groups: ArrayLike, *, contexts: ArrayLike | None = None
) -> np.ndarray:
    """Each case's confidence from a table (:func:`fit_table`) fitted on the cases of the
    other groups (runs, robots): e.g. every hypothesis's weight, held out by run.

    ``contexts`` (one label per case, optional): one table per label, each case read by its
    own label's (e.g. whether its frame came soon after a localized one).

    Returns
    -------
    ndarray, shape (n,)
        NaN where the other groups hold no case (of its context).

    Raises
    ------
    InputError
        As :func:`fit_table`, and fewer than two groups, or ``groups`` or ``contexts`` of
        another length.
    """
    n = int(np.size(values)) if values is not None else 0
    _, v, ok = _frames(["ambiguous"] * n, values, right)
    g, labels = _groups(groups, v.size)
    if contexts is None:
        ctx = np.zeros(v.size, dtype=np.int64)
    else:
        if isinstance(contexts, (str, bytes, dict)):
            raise InputError(f"contexts must hold one label per case, got {shorten(contexts)}")
        ctx = np.asarray(contexts)
        if ctx.ndim != 1 or ctx.size != v.size:
            raise InputError(
                f"contexts must hold one label per case (1-D), got shape {ctx.shape} for "
                f"{v.size} cases"
            )
    out = np.full(v.size, np.nan)
    for label in labels:
        mine = g == label
        for c in dict.fromkeys(ctx[mine].tolist()):
            fit_on = ~mine & (ctx == c)
            if fit_on.any():
                read = mine & (ctx == c)
                arrays = knot_arrays(_isotonic_knots(v[fit_on], ok[fit_on]))
                out[read] = [np.nan if x is None else x for x in _interpolate(arrays, v[read])]
    return out
