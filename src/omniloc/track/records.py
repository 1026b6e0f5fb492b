"""What a localizer over time reports after each frame: a state, a pose, its hypotheses.

Every localizer over time in omniloc -- the :class:`~omniloc.track.Tracker` and the
baselines it is compared with (``benchmarks/track_baselines.py``) -- reports a
:class:`TrackEstimate` per frame, and :mod:`omniloc.evaluate.tracking` scores sequences of them
with one piece of code.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io import shorten
from ..pose import Pose

__all__ = ["Hypothesis", "TrackEstimate", "TrackState"]

FloatArray = NDArray[np.float64]


class TrackState(str, enum.Enum):
    """The state a localizer over time reports after a frame.

    ``lost``
        No pose is supported by the evidence (at wake-up, or after the evidence rejected
        every hypothesis).
    ``ambiguous``
        Several poses compete (see :attr:`TrackEstimate.hypotheses`); none holds the share of
        the posterior mass that ``localized`` requires.
    ``localized``
        One hypothesis holds at least the required share of the mass: its pose can be used.
    """

    LOST = "lost"
    AMBIGUOUS = "ambiguous"
    LOCALIZED = "localized"


def _check_share(name: str, value: object) -> None:
    """``value`` None or a real number in [0, 1], or an InputError naming ``name``."""
    if value is None:
        return
    ok = isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
    if not (ok and 0.0 <= float(value) <= 1.0):  # type: ignore[arg-type]
        raise InputError(f"{name} must be a number in [0, 1] or None, got {value!r}")


@dataclass(frozen=True)
class Hypothesis:
    """One competing pose: its estimate, covariance and posterior weight.

    Attributes
    ----------
    pose : Pose
    covariance : ndarray, shape (3, 3)
        Covariance of (x, y, theta), m^2 and rad^2.
    weight : float
        Posterior probability that the robot is at this hypothesis. All the hypotheses and
        *elsewhere* (a pose none of them covers) sum to 1, so the reported ones (at most
        ``TrackerConfig.max_reported``) sum to 1 less elsewhere's share and any not reported.
        It is the model's probability, as good as the sensor model: on MRCLAM, where the
        camera's errors and detections are correlated, it is overconfident (the strongest
        hypothesis at 0.9 or more is right in 58 % of the frames; docs/tracking.md), and
        every tracking evaluation reports its calibration (``best_weight_ece``).
    confidence : float or None
        The probability, as recordings measured it, that the robot is within the
        localizer's tolerance of ``pose``: the weight mapped by the configuration's
        ``confidence_hypothesis`` table (``confidence_hypothesis_recent`` in a frame soon
        after a localized one; :mod:`omniloc.track.confidence`). None without one.
    """

    pose: Pose
    covariance: FloatArray = field(repr=False, compare=False)
    weight: float = 1.0
    confidence: float | None = None

    def __post_init__(self) -> None:
        _check_share("confidence", self.confidence)


@dataclass(frozen=True)
class TrackEstimate:
    """A localizer's report after one frame.

    Attributes
    ----------
    t : float
        Time of the frame, seconds.
    state : TrackState
    pose : Pose or None
        The best hypothesis's pose (None when ``lost``). Only a ``localized`` pose is
        meant to be used; an ``ambiguous`` one is the strongest candidate.
    covariance : ndarray, shape (3, 3), or None
        Its covariance.
    hypotheses : tuple of Hypothesis
        The competing hypotheses, best first (empty when ``lost``).
    reason : str
        Why the state is what it is, in a few words (for people and logs).
    kidnapped : bool
        True on the frame at which the localizer concluded that the pose it was tracking no
        longer explains the bearings (a kidnapping, or a tracking failure) and started to
        relocalize.
    probability : float or None
        The localizer's own probability that ``pose`` is within its tolerance of the truth
        (the :class:`~omniloc.track.Tracker`: the best place's share of the mass times the
        chance its covariance gives the tolerance). As good as the model: on MRCLAM it is
        overconfident (0.97 is right about two times in three). None when lost, or from a
        localizer that does not say.
    confidence : float or None
        The same probability as measured on recordings with a ground truth: ``probability``
        mapped, per state, by the calibration the localizer was given
        (:class:`~omniloc.track.TrackerConfig`'s ``confidence_localized`` and
        ``confidence_ambiguous``, fitted by :func:`~omniloc.track.fit_confidence`; an
        ambiguous frame soon after a localized one by ``confidence_recent``). None without
        one, or when lost.
    since_localized : float or None
        Seconds since the localizer's last ``localized`` frame (0 when this one is). None
        when it has not been localized since it started, or since it last flagged a
        kidnapping or lost its motion to an odometry gap -- or from a localizer that does
        not say. Offline, with the pass backward (``track(..., backward_s=)``), the same
        counted on the frames reported: since the last one reported ``localized``, at or
        before this one (:func:`~omniloc.track.backward.since_reported`); a frame of the
        pass says in its ``reason`` how far before its sure frame it is.
    backward : bool
        True when the estimate comes from the second pass backward in time over a whole
        recording (:mod:`omniloc.track.backward`), not from the frames before it.
    """

    t: float
    state: TrackState
    pose: Pose | None = None
    covariance: FloatArray | None = field(default=None, repr=False, compare=False)
    hypotheses: tuple[Hypothesis, ...] = ()
    reason: str = ""
    kidnapped: bool = False
    probability: float | None = None
    confidence: float | None = None
    since_localized: float | None = None
    backward: bool = False

    def __post_init__(self) -> None:
        if not math.isfinite(float(self.t)):
            raise InputError(f"t must be finite, got {self.t!r}")
        for name in ("probability", "confidence"):
            _check_share(name, getattr(self, name))
        s = self.since_localized
        if s is not None:
            ok = isinstance(s, (int, float, np.integer, np.floating)) and not isinstance(s, bool)
            try:
                seconds = float(s) if ok else math.nan
            except OverflowError:
                seconds = math.inf
            if not (math.isfinite(seconds) and seconds >= 0.0):
                raise InputError(f"since_localized must be seconds >= 0 or None, got {shorten(s)}")
        object.__setattr__(self, "state", TrackState(self.state))
        if self.state is not TrackState.LOST and self.pose is None:
            raise InputError(f"a {self.state.value} estimate needs a pose")

    @property
    def localized(self) -> bool:
        """Whether the state is ``localized``."""
        return self.state is TrackState.LOCALIZED

    def as_dict(self) -> dict[str, object]:
        """Plain-JSON dictionary: ``t``, ``state``, ``reason``, ``kidnapped``,
        ``since_localized`` (null when not given), ``backward`` and, unless lost, ``x``, ``y``,
        ``theta``, ``covariance`` (3x3 nested lists), ``probability`` and ``confidence``
        (null when not given) and ``hypotheses`` (each ``x``, ``y``, ``theta``, ``weight``,
        ``confidence``, ``covariance``)."""
        since = self.since_localized
        out: dict[str, object] = {
            "t": float(self.t),
            "state": self.state.value,
            "reason": self.reason,
            "kidnapped": bool(self.kidnapped),
            "since_localized": None if since is None else float(since),
            "backward": bool(self.backward),
        }
        if self.pose is not None:
            out.update(x=self.pose.x, y=self.pose.y, theta=self.pose.theta)
            cov = self.covariance
            out["covariance"] = None if cov is None else np.asarray(cov, float).tolist()
            for name in ("probability", "confidence"):
                v = getattr(self, name)
                out[name] = None if v is None else float(v)
            out["hypotheses"] = [
                {
                    "x": h.pose.x,
                    "y": h.pose.y,
                    "theta": h.pose.theta,
                    "weight": float(h.weight),
                    "confidence": None if h.confidence is None else float(h.confidence),
                    "covariance": np.asarray(h.covariance, float).tolist(),
                }
                for h in self.hypotheses
            ]
        return out
