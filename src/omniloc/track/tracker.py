"""The tracker: global localization, multi-hypothesis tracking with odometry, kidnapping.

A :class:`Tracker` is fed odometry and frames of bearings in time order and reports, after
every frame, a :class:`~omniloc.track.TrackEstimate`: ``lost``, ``ambiguous`` (with its
competing hypotheses) or ``localized``, with the reason.

How it works (``docs/tracking.md`` has the reasons and the figures)
-------------------------------------------------------------------
* **Hypotheses** are extended Kalman filters over the pose (:mod:`.ekf`): odometry moves
  them (:mod:`.motion`), each frame updates them with a gated, spurious-aware association
  (the assignment of bearings to landmarks or clutter that maximises the frame likelihood),
  and earns each one the frame's log-likelihood ratio under the
  :class:`~omniloc.sensor.SensorModel` (detections, clutter, visible landmarks not seen).
  A hypothesis's *score* is the sum of those, forgetting with time constant
  ``memory_s``; weights are the normalised ``exp(score)``.
* **New hypotheses** come from :func:`~omniloc.localize` on the bearings of the last
  ~second stacked by odometry (:mod:`.relocalize`), replayed through the window with the
  exact model (:func:`.window.replay`) so that they are scored on the same frames as the
  hypotheses already tracked. The tracker searches when it is lost or ambiguous (at most
  every ``search_interval_s``), and when the localized hypothesis stops explaining the
  bearings.
* **Pruning**: hypotheses whose score falls ``prune_margin`` nats behind the best are
  dropped; equal ones (Mahalanobis distance) are merged (the better score stays); at most
  ``max_hypotheses`` are kept.
* **Localized** only when the best hypothesis and those within ``cluster_position_m`` /
  ``cluster_heading`` of it (the same place, read through rival assignments that have not
  merged) hold ``localized_share`` of the mass, its
  covariance is within ``max_position_sd_m`` / ``max_heading_sd``, it has matched enough
  bearings and it explains the recent bearings (a binomial test of the share it matched
  against ``fit_explained``).
* **Kidnapping**: when the localized hypothesis fails that test strongly (p below
  ``kidnap_p``), or a distant hypothesis takes the mass from it, the estimate is flagged
  ``kidnapped``; the old hypothesis stays alongside the new ones until the evidence decides.

Bad input: times that go back, values that are not finite and frames before any odometry
get a clear :class:`~omniloc.errors.InputError` or a stated behaviour (see
:meth:`Tracker.odometry` and :meth:`Tracker.frame`); the tracker's state is unchanged by a
rejected call.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import betainc

from .._kernels import track as _kernels
from ..angles import wrap
from ..errors import InputError
from ..maps import LandmarkMap, as_landmark_map
from ..pose import Pose
from ..sensor import SensorModel
from . import ekf
from .clutter import ClutterMemory, PersistentClutter
from .motion import MotionModel, integrate, twist_of
from .records import Hypothesis, TrackEstimate, TrackState
from .relocalize import search_window
from .step import StepRules, advance, take_frame
from .window import Window, replay

__all__ = ["Tracker", "TrackerConfig"]

#: What the tracker keeps per hypothesis besides its pose and covariance (filtered together).
_PER_HYPOTHESIS = (
    "_score",
    "_support",
    "_fit_m",
    "_fit_n",
    "_fast_m",
    "_fast_n",
    "_born",
    "_ids",
)

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class TrackerConfig:
    """How the tracker decides (every value has a unit; the defaults suit a camera at a few
    frames per second; :func:`~omniloc.track.presets.preset` gives tuned sets).

    Parameters
    ----------
    memory_s : float
        Time constant (s) with which a hypothesis's score forgets old frames.
    evidence_weight : float
        Factor on each frame's log-likelihood ratio in the scores (< 1: consecutive frames
        from nearly the same pose are not independent evidence; their errors -- bearing
        biases, landmark placement -- repeat).
    localized_share : float
        Share of the posterior mass the best hypothesis, with those at the same place (see
        ``cluster_position_m``), needs to be ``localized``.
    cluster_position_m, cluster_heading : float
        Hypotheses within this many metres and radians of the best count with it towards
        ``localized_share``: rival readings of one frame (a bearing between two tubes of a
        cluster) leave near-copies of one pose that the merge, which needs the copies to
        agree within their covariances, keeps apart.
    max_position_sd_m : float
        Largest position standard deviation (m, along the worst axis) of a localized pose.
    max_heading_sd : float
        Largest heading standard deviation (rad) of a localized pose.
    min_support : float
        Bearings the best hypothesis must have matched (counted with the score's
        forgetting) to be localized.
    min_age_s : float
        Time (s) a hypothesis must have been tracked before it can be localized.
    prune_margin : float
        Hypotheses this many nats behind the best are dropped.
    max_hypotheses : int
        At most this many hypotheses are kept (the best scores).
    merge_chi2, merge_position_m, merge_heading : float
        Two hypotheses closer than this squared Mahalanobis distance (on the sum of their
        covariances), and within this many metres and radians, are the same; the better
        one stays.
    branches : int
        A hypothesis splits into at most this many children on a frame that it can explain
        in several ways (rival assignments of its bearings).
    branch_margin : float
        Rival assignments this many nats worse than the best are not followed.
    split_sd : float
        A hypothesis whose pose uncertainty spreads a landmark's predicted bearing by more
        than this (rad) is split into a Gaussian mixture (0: never split).
    split_target_sd : float
        ... into components this narrow (rad of bearing).
    split_max_children : int
        ... at most this many.
    persistent_clutter : bool
        Clutter a hypothesis saw in the last second is likelier clutter again
        (:mod:`.clutter`).
    max_rows : int
        At most this many hypotheses come out of a frame's splits and branches (the best
        by score) before merging and pruning.
    collapse_chi2 : float
        A hypothesis's children (rival assignments) that end up closer than this squared
        Mahalanobis distance become one Gaussian, their likelihoods summed (joint
        probabilistic data association); distinct ones stay apart (0: never collapse).
    search_window_s : float
        Frames of the last this many seconds are stacked for a search (0: the current
        frame alone).
    search_interval_s : float
        At most one search per this many seconds.
    search_timeout_s : float
        Time budget of one search.
    search_min_bearings : int
        A search needs at least this many (stacked) bearings.
    search_max_bearings : int
        At most this many stacked bearings go into a search.
    search_max_spurious : int
        Bearings a search may leave unmatched.
    near_range_m : float
        Range (m) at which the travel over the search window is turned into bearing noise.
    candidate_cov_inflation : float
        Factor on a search solution's covariance before its replay.
    max_candidates : int
        At most this many search solutions are scored on the whole window (the best on
        the last ``prerank_s`` seconds).
    prerank_s : float
        The window on which too many candidates are first ranked, seconds.
    replay_s : float
        New hypotheses are replayed through the frames of the last this many seconds.
    fit_window_s : float
        Time constant (s) of the counts of the recent-fit test.
    fast_fit_window_s : float
        A second, shorter time constant (s) for the same test, used only to leave
        ``localized`` (suspect) quickly after a jump, before the slower counts, still full of
        the good past, notice it; the ``kidnapped`` flag reads the slower counts.
    fit_explained : float
        Share of the bearings a right hypothesis explains (the rest is clutter), for the
        recent-fit test.
    suspect_p : float
        The localized hypothesis is suspect (search, not localized) when the binomial
        probability of so few matches is below this.
    kidnap_p : float
        ... and rejected (flagged ``kidnapped``) below this.
    min_fit_bearings : float
        The recent-fit test needs at least this many recent bearings.
    max_odometry_gap_s : float
        Odometry rows further apart than this (s) leave the motion unknown: the hypotheses
        are dropped and the tracker relocalizes.
    max_reported : int
        At most this many hypotheses in an estimate.

    Raises
    ------
    InputError
        A value out of its range (the message names it).
    """

    memory_s: float = 10.0
    evidence_weight: float = 0.5
    localized_share: float = 0.99
    cluster_position_m: float = 0.15
    cluster_heading: float = float(np.deg2rad(3.0))
    max_position_sd_m: float = 0.1
    max_heading_sd: float = float(np.deg2rad(1.5))
    min_support: float = 6.0
    min_age_s: float = 1.0
    prune_margin: float = 15.0
    max_hypotheses: int = 60
    merge_chi2: float = 7.8
    merge_position_m: float = 0.1
    merge_heading: float = float(np.deg2rad(1.0))
    branches: int = 4
    branch_margin: float = 8.0
    split_sd: float = float(np.deg2rad(4.0))
    split_target_sd: float = float(np.deg2rad(1.5))
    split_max_children: int = 9
    persistent_clutter: bool = False
    clutter_again: float = 0.35
    max_rows: int = 300
    collapse_chi2: float = 9.0
    search_window_s: float = 0.0
    search_interval_s: float = 1.0
    search_timeout_s: float = 0.1
    search_min_bearings: int = 4
    search_max_bearings: int = 10
    search_max_spurious: int = 2
    near_range_m: float = 2.0
    candidate_cov_inflation: float = 2.0
    max_candidates: int = 200
    prerank_s: float = 1.0
    replay_s: float = 10.0
    fit_window_s: float = 3.0
    fast_fit_window_s: float = 0.75
    fit_explained: float = 0.6
    suspect_p: float = 1e-2
    kidnap_p: float = 1e-4
    min_fit_bearings: float = 6.0
    max_odometry_gap_s: float = 2.0
    max_reported: int = 10

    def __post_init__(self) -> None:
        ints = {
            "max_hypotheses",
            "search_max_bearings",
            "max_candidates",
            "max_reported",
            "branches",
            "split_max_children",
            "max_rows",
            "search_min_bearings",
        }
        probs = {"localized_share", "fit_explained", "suspect_p", "kidnap_p"}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in {"persistent_clutter"}:
                if not isinstance(v, (bool, np.bool_)):
                    raise InputError(f"{f.name} must be True or False, got {v!r}")
                object.__setattr__(self, f.name, bool(v))
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise InputError(f"{f.name} must be a number, got {v!r}")
            if f.name in ints:
                if int(v) != v or v < 1:
                    raise InputError(f"{f.name} must be a positive integer, got {v!r}")
                object.__setattr__(self, f.name, int(v))
                continue
            v = float(v)
            if not math.isfinite(v) or v < 0:
                raise InputError(f"{f.name} must be finite and >= 0, got {getattr(self, f.name)!r}")
            if f.name in probs and not 0.0 < v < 1.0:
                raise InputError(f"{f.name} must lie strictly between 0 and 1, got {v!r}")
            object.__setattr__(self, f.name, v)
        for name in (
            "memory_s",
            "fit_window_s",
            "fast_fit_window_s",
            "near_range_m",
            "candidate_cov_inflation",
        ):
            if getattr(self, name) <= 0:
                raise InputError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if self.kidnap_p > self.suspect_p:
            raise InputError(
                f"kidnap_p ({self.kidnap_p}) must not exceed suspect_p ({self.suspect_p})"
            )


def _finite_1d(name: str, values: ArrayLike) -> FloatArray:
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be real numbers: {exc}") from exc
    a = np.atleast_1d(a)
    if a.ndim != 1:
        raise InputError(f"{name} must have shape (n,), got {a.shape}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise InputError(f"{name}[{int(bad[0])}] is not finite: {a[bad[0]]!r}")
    return a


class Tracker:
    """Localization over time from odometry and frames of unlabelled bearings.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
        The map, metres.
    sensor : SensorModel, optional
        Noise, field of view, range, detection probability and clutter of the bearing
        sensor (default: ``SensorModel(sigma=0.5 deg)``).
    motion : MotionModel, optional
        Odometry noise and latency (default: ``MotionModel()``).
    config : TrackerConfig, optional
        Decision parameters.

    Examples
    --------
    >>> import numpy as np, omniloc
    >>> from omniloc.track import Tracker
    >>> room = omniloc.demo_room()
    >>> tracker = Tracker(room, SensorModel(sigma=np.deg2rad(0.3)))
    >>> truth = omniloc.Pose(5.6, 2.1, np.deg2rad(30))
    >>> for k in range(12):
    ...     tracker.odometry([0.25 * k], [0.0], [0.0])  # standing still
    ...     z = omniloc.predict_bearings(room.xy, truth)
    ...     est = tracker.frame(0.25 * k, z)
    >>> est.state.value, round(est.pose.x, 2), round(est.pose.y, 2)
    ('localized', 5.6, 2.1)
    """

    def __init__(
        self,
        landmarks: LandmarkMap | ArrayLike,
        sensor: SensorModel | None = None,
        motion: MotionModel | None = None,
        config: TrackerConfig | None = None,
    ) -> None:
        self.landmarks = as_landmark_map(landmarks)
        self.sensor = sensor if sensor is not None else SensorModel(sigma=float(np.deg2rad(0.5)))
        if not isinstance(self.sensor, SensorModel):
            raise InputError(f"sensor must be a SensorModel, got {type(sensor).__name__}")
        self.motion = motion if motion is not None else MotionModel()
        if not isinstance(self.motion, MotionModel):
            raise InputError(f"motion must be a MotionModel, got {type(motion).__name__}")
        self.config = config if config is not None else TrackerConfig()
        if not isinstance(self.config, TrackerConfig):
            raise InputError(f"config must be a TrackerConfig, got {type(config).__name__}")
        self._L = np.ascontiguousarray(self.landmarks.xy)
        c = self.config
        self._window = Window(max(c.replay_s, c.search_window_s))
        self._rules = StepRules(
            branches=c.branches,
            branch_margin=c.branch_margin,
            split=(
                ekf.Split(c.split_sd, c.split_target_sd, c.split_max_children)
                if c.split_sd > 0
                else None
            ),
            clutter=PersistentClutter(p_again=c.clutter_again) if c.persistent_clutter else None,
            max_rows=c.max_rows,
            collapse_chi2=c.collapse_chi2,
        )
        self._memory = ClutterMemory()
        # Odometry: rows (t, vx, vy, w) not yet integrated, and the twist holding now.
        self._rows: list[FloatArray] = []
        self._hold = np.zeros(3)
        self._hold_t: float | None = None
        self._last_row_t: float | None = None
        self._input_kind: str | None = None
        self._t: float | None = None  # time of the last frame (motion integrated up to it)
        self._warned_no_odometry = False
        self._after_gap = False  # a gap was reported and no odometry row came since
        # Hypotheses.
        self._poses = np.zeros((0, 3))
        self._covs = np.zeros((0, 3, 3))
        self._score = np.zeros(0)
        self._support = np.zeros(0)
        self._fit_m = np.zeros(0)
        self._fit_n = np.zeros(0)
        self._fast_m = np.zeros(0)
        self._fast_n = np.zeros(0)
        self._born = np.zeros(0)
        self._ids = np.zeros(0, dtype=np.int64)
        self._next_id = 0
        self._last_search: float = -math.inf
        self._bearings_since_search = 0
        self._localized_id: int | None = None
        self._gap_reason = ""
        #: Number of searches run so far (for reports).
        self.searches = 0

    # ---- input ---------------------------------------------------------------------------
    @property
    def n_hypotheses(self) -> int:
        """Hypotheses tracked now."""
        return int(self._poses.shape[0])

    def _check_row_times(self, t: FloatArray, what: str) -> None:
        d = np.diff(t)
        bad = np.flatnonzero(d < 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise InputError(
                f"{what} times must not decrease: row {k} has t={t[k]!r} after {t[k - 1]!r}"
            )
        if self._last_row_t is not None and t[0] < self._last_row_t:
            raise InputError(
                f"{what} out of time order: t={t[0]!r} after a row at {self._last_row_t!r}"
            )
        if self._t is not None and t[0] + self.motion.delay_s < self._t:
            raise InputError(
                f"{what} at t={t[0]!r} arrived after the frame at t={self._t!r} that it would "
                "move: feed odometry before the frames it covers"
            )

    def _set_kind(self, kind: str) -> None:
        if self._input_kind is None:
            self._input_kind = kind
        elif self._input_kind != kind:
            raise InputError(
                f"this tracker takes {self._input_kind}; it cannot also take {kind} "
                "(feed one kind of odometry)"
            )

    def odometry(self, t: ArrayLike, v: ArrayLike, w: ArrayLike) -> None:
        """Velocity odometry: rows ``t`` (s), forward velocity ``v`` (m/s), turn rate ``w``
        (rad/s), each row holding until the next (and the last one until a frame).

        Raises
        ------
        InputError
            Arrays of different lengths, values that are not finite, times that decrease
            (within the call or against earlier rows), or rows older than a frame already
            processed (their motion would be lost). Nothing is changed then.
        """
        tt = _finite_1d("odometry t", t)
        vv = _finite_1d("odometry v", v)
        ww = _finite_1d("odometry w", w)
        if not (tt.shape == vv.shape == ww.shape):
            raise InputError(
                f"odometry t, v and w must have one value per row: got {tt.size}, {vv.size}, "
                f"{ww.size}"
            )
        if tt.size == 0:
            return
        self._check_row_times(tt, "odometry")
        self._set_kind("velocities")
        rows = np.stack([tt + self.motion.delay_s, vv, np.zeros_like(vv), ww], axis=1)
        self._rows.append(rows)
        self._last_row_t = float(tt[-1])
        self._after_gap = False

    def increments(self, t: ArrayLike, dx: ArrayLike, dy: ArrayLike, dtheta: ArrayLike) -> None:
        """Incremental odometry: row k is the motion ``(dx, dy, dtheta)`` (m, m, rad, in the
        robot frame at its start) from the previous row's time to ``t[k]``, taken at a
        constant body twist (exact for a constant-velocity arc). The very first row starts
        the clock and must be a zero increment; after the last row the robot is taken to go
        on with the last twist until a frame.

        Raises
        ------
        InputError
            As :meth:`odometry`; also a non-zero first increment, or two rows at one time
            with a non-zero motion between them.
        """
        tt = _finite_1d("increments t", t)
        dd = np.stack(
            [_finite_1d(n, a) for n, a in (("dx", dx), ("dy", dy), ("dtheta", dtheta))], axis=1
        )
        if dd.shape[0] != tt.size:
            raise InputError(
                f"increments t, dx, dy and dtheta must have one value per row: got {tt.size} "
                f"times and {dd.shape[0]} increments"
            )
        if tt.size == 0:
            return
        self._check_row_times(tt, "increments")
        self._set_kind("increments")
        prev = self._last_row_t
        if prev is None:
            if np.any(dd[0] != 0):
                raise InputError(
                    "the first increment starts the clock and must be zero (there is no "
                    f"interval it could belong to), got {dd[0].tolist()}"
                )
            prev = float(tt[0])
        starts = np.concatenate([[prev], tt[:-1]])
        dur = tt - starts
        moving = np.any(dd != 0, axis=1)
        bad = np.flatnonzero((dur <= 0) & moving)
        if bad.size and not (bad[0] == 0 and self._last_row_t is None):
            k = int(bad[0])
            raise InputError(f"increment row {k} moves the robot in zero time (t={tt[k]!r})")
        keep = dur > 0
        tw = np.zeros((tt.size, 3))
        if keep.any():
            tw[keep] = twist_of(dd[keep], 1.0) / dur[keep, None]
        rows = np.concatenate([(starts + self.motion.delay_s)[keep, None], tw[keep]], axis=1)
        if rows.size:
            self._rows.append(rows)
        self._last_row_t = float(tt[-1])
        self._after_gap = False

    def _motion_to(self, t: float) -> tuple[FloatArray, FloatArray, float]:
        """Integrate the odometry from the last frame to ``t``: (delta, Q, longest stretch
        without an odometry row, s)."""
        rows = np.concatenate(self._rows) if self._rows else np.zeros((0, 4))
        use = rows[:, 0] <= t
        now, later = rows[use], rows[~use]
        self._rows = [later] if later.size else []
        t0 = self._t
        if t0 is None:
            # First frame: nothing to integrate; the rows before it set the twist holding.
            if now.size:
                self._hold = now[-1, 1:].copy()
                self._hold_t = float(now[-1, 0])
            return np.zeros(3), np.zeros((3, 3)), 0.0
        starts = np.concatenate([[t0], np.maximum(now[:, 0], t0)])
        ends = np.concatenate([starts[1:], [t]])
        twists = np.concatenate([self._hold[None], now[:, 1:]], axis=0)
        gap = 0.0
        if self._hold_t is not None or now.size:
            first = [self._hold_t] if self._hold_t is not None else []
            gap = float(np.max(np.diff(np.concatenate([first, now[:, 0], [t]]))))
        if now.size:
            self._hold = now[-1, 1:].copy()
            self._hold_t = float(now[-1, 0])
        delta, Q = integrate(
            ends - starts, twists[:, 0], twists[:, 2], self.motion, vy=twists[:, 1]
        )
        return delta, Q, gap

    # ---- hypotheses ----------------------------------------------------------------------
    def _keep(self, idx: NDArray[np.int64] | NDArray[np.bool_]) -> None:
        for name in ("_poses", "_covs", *_PER_HYPOTHESIS):
            setattr(self, name, getattr(self, name)[idx])
        self._memory.take(idx)

    def _add(
        self,
        poses: FloatArray,
        covs: FloatArray,
        score: FloatArray,
        support: FloatArray,
        t: float,
        memory: ClutterMemory | None = None,
    ) -> None:
        n = poses.shape[0]
        if n == 0:
            return
        if memory is None:
            self._memory.extend(n)
        else:
            self._memory.bearings = np.concatenate([self._memory.bearings, memory.bearings])
            self._memory.t = np.concatenate([self._memory.t, memory.t])
        ids = np.arange(self._next_id, self._next_id + n)
        self._next_id += n
        self._poses = np.concatenate([self._poses, poses])
        self._covs = np.concatenate([self._covs, covs])
        self._score = np.concatenate([self._score, score])
        self._support = np.concatenate([self._support, support])
        self._fit_m = np.concatenate([self._fit_m, np.zeros(n)])
        self._fit_n = np.concatenate([self._fit_n, np.zeros(n)])
        self._fast_m = np.concatenate([self._fast_m, np.zeros(n)])
        self._fast_n = np.concatenate([self._fast_n, np.zeros(n)])
        self._born = np.concatenate([self._born, np.full(n, t)])
        self._ids = np.concatenate([self._ids, ids])

    def _drop_all(self) -> None:
        self._keep(np.zeros(0, dtype=np.int64))

    def _distinct(self, poses: FloatArray, covs: FloatArray) -> NDArray[np.bool_]:
        """Which of these (sorted best first) are not the same as a better one."""
        c = self.config
        return np.asarray(
            _kernels.distinct(
                np.ascontiguousarray(poses),
                np.ascontiguousarray(covs),
                c.merge_chi2,
                c.merge_position_m,
                c.merge_heading,
            )
        )

    def _merge_and_prune(self) -> None:
        H = self.n_hypotheses
        if H == 0:
            return
        c = self.config
        order = np.argsort(-self._score, kind="stable")
        self._keep(order)
        keep = self._score >= self._score[0] - c.prune_margin
        keep &= self._distinct(self._poses, self._covs)
        idx = np.flatnonzero(keep)[: c.max_hypotheses]
        self._keep(idx)

    def _search(self, t: float) -> int:
        """Search the window for new hypotheses; returns how many were added."""
        c = self.config
        frames = self._window.since(t - c.search_window_s)
        if sum(f.bearings.size for f in frames) < max(3, c.search_min_bearings):
            return 0  # not enough to search (stacking may merge some: checked again there)
        self._last_search = t
        self._bearings_since_search = 0
        cands = search_window(
            self.landmarks,
            frames,
            self.sensor,
            near_range_m=c.near_range_m,
            min_bearings=c.search_min_bearings,
            max_bearings=c.search_max_bearings,
            max_spurious=c.search_max_spurious,
            timeout_s=c.search_timeout_s,
            cov_inflation=c.candidate_cov_inflation,
        )
        if cands.n_bearings >= max(3, c.search_min_bearings):
            self.searches += 1
        if len(cands) == 0:
            return 0
        poses, covs = cands.poses, cands.covs
        if len(cands) > c.max_candidates:
            # Too many to score on the whole window: the best on the last second go on
            # (scored without branching: a cheap first cut).
            pre = replay(
                poses,
                covs,
                self._window.since(t - c.prerank_s),
                self._L,
                self.sensor,
                StepRules(),
                decay_per_s=1.0 / c.memory_s,
                weight=c.evidence_weight,
            )
            top = pre.source[np.argsort(-pre.score, kind="stable")[: c.max_candidates]]
            poses, covs = poses[top], covs[top]
        rframes = self._window.since(t - c.replay_s)
        r = replay(
            poses,
            covs,
            rframes,
            self._L,
            self.sensor,
            self._rules,
            decay_per_s=1.0 / c.memory_s,
            weight=c.evidence_weight,
        )
        ok = (
            np.isfinite(r.score)
            & np.isfinite(r.poses).all(axis=1)
            & np.isfinite(r.covs).all(axis=(1, 2))
        )
        best = max(r.score[ok].max(initial=-np.inf), self._score.max(initial=-np.inf))
        ok &= r.score >= best - c.prune_margin
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            return 0
        idx = idx[np.argsort(-r.score[idx], kind="stable")]
        # Candidates that are hypotheses already tracked add nothing (the tracked one keeps
        # its history); among themselves, the better score stays.
        H = self.n_hypotheses
        fresh = self._distinct(
            np.concatenate([self._poses, r.poses[idx]]), np.concatenate([self._covs, r.covs[idx]])
        )[H:]
        idx = idx[fresh]
        if idx.size == 0:
            return 0
        r.memory.take(idx)
        self._add(
            r.poses[idx], r.covs[idx], r.score[idx], r.matched[idx].astype(np.float64), t, r.memory
        )
        return int(idx.size)

    # ---- the recent-fit test -------------------------------------------------------------
    def _fit_p(self, fast: bool = False) -> FloatArray:
        """Per hypothesis: the binomial probability of matching at most the recent matches
        of the recent bearings if it were right (1 when too few bearings to tell); with
        ``fast``, on the counts of the shorter time constant."""
        n = self._fast_n if fast else self._fit_n
        k = np.minimum(self._fast_m if fast else self._fit_m, n)
        p = np.ones_like(n)
        enough = n >= self.config.min_fit_bearings
        if enough.any():
            a = np.maximum(n[enough] - k[enough], 1e-9)
            p[enough] = betainc(a, k[enough] + 1.0, 1.0 - self.config.fit_explained)
        return p

    # ---- frames --------------------------------------------------------------------------
    def frame(self, t: float, bearings: ArrayLike) -> TrackEstimate:
        """Take one frame of bearings (radians, robot frame, any order) at time ``t``.

        A frame before any odometry is taken as the robot standing still until the first
        odometry row (with a warning in the log). A frame more than ``max_odometry_gap_s``
        after the last odometry row, or after a gap of that length between rows, leaves
        the motion unknown: every hypothesis is dropped and the tracker relocalizes; until
        odometry resumes, the robot is then taken to stand still (as before the first row).

        Returns
        -------
        TrackEstimate
            The state after this frame.

        Raises
        ------
        InputError
            ``t`` not finite or before the previous frame, bearings not a 1-D array of
            finite numbers. Nothing is changed then.
        """
        try:
            tf = float(t)
        except (TypeError, ValueError) as exc:
            raise InputError(f"frame time must be a number, got {t!r}") from exc
        if not math.isfinite(tf):
            raise InputError(f"frame time must be finite, got {t!r}")
        if self._t is not None and tf < self._t:
            raise InputError(f"frames out of time order: t={tf!r} after a frame at t={self._t!r}")
        b = _finite_1d("frame bearings", bearings)
        b = np.asarray(wrap(b))
        if self._input_kind is None and not self._warned_no_odometry:
            log.warning("frame at t=%s before any odometry: the robot is taken to stand still", tf)
            self._warned_no_odometry = True
        c = self.config
        t_prev = self._t
        delta, Q, gap = self._motion_to(tf)
        self._t = tf
        reason_gap = ""
        if gap > c.max_odometry_gap_s and not self._after_gap:
            self._after_gap = True
            reason_gap = f"odometry gap of {gap:.1f} s: motion unknown, relocalizing"
            self._drop_all()
            self._window.clear()
            self._localized_id = None
            delta, Q = np.zeros(3), np.zeros((3, 3))
            # Once: until odometry resumes the robot is taken to stand still (as before
            # the first row), so the frames after the gap can build up evidence again.
            self._hold = np.zeros(3)
        self._window.append(tf, b, delta, Q)
        dt = 0.0 if t_prev is None else tf - t_prev
        if self.n_hypotheses:
            self._poses, self._covs = advance(self._poses, self._covs, self._memory, delta, Q)
            decay = math.exp(-dt / c.memory_s)
            self._poses, self._covs, ev = take_frame(
                self._poses,
                self._covs,
                self._memory,
                tf,
                b,
                self._L,
                self.sensor,
                self._rules,
                score=self._score * decay,
            )
            for name in _PER_HYPOTHESIS:
                setattr(self, name, getattr(self, name)[ev.parent])
            decay = math.exp(-dt / c.memory_s)
            fdecay = math.exp(-dt / c.fit_window_s)
            self._score = self._score * decay + c.evidence_weight * ev.loglik
            self._support = self._support * decay + ev.matched
            self._fit_m = self._fit_m * fdecay + ev.matched
            self._fit_n = self._fit_n * fdecay + b.size
            qdecay = math.exp(-dt / c.fast_fit_window_s)
            self._fast_m = self._fast_m * qdecay + ev.matched
            self._fast_n = self._fast_n * qdecay + b.size
            good = np.isfinite(self._poses).all(axis=1) & np.isfinite(self._covs).all(axis=(1, 2))
            if not good.all():
                self._keep(np.flatnonzero(good))
        self._bearings_since_search += int(b.size)
        self._merge_and_prune()
        # Decide whether to search.
        fit = self._fit_p()
        state_before, _, suspect, _ = self._decide(fit, tf)
        if self._want_search(state_before, suspect, tf) and self._search(tf):
            self._merge_and_prune()
            fit = self._fit_p()
        state, reason, _suspect, best = self._decide(fit, tf)
        if reason_gap:
            reason = reason_gap + ("; " + reason if state is not TrackState.LOST else "")
        # Kidnapping: the hypothesis we were localized on no longer explains the bearings.
        kidnapped = False
        if self._localized_id is not None:
            where = np.flatnonzero(self._ids == self._localized_id)
            if where.size == 0:
                kidnapped = True
                reason = "the localized hypothesis was rejected by the evidence; " + reason
            else:
                i = int(where[0])
                if fit[i] < c.kidnap_p:
                    kidnapped = True
                    reason = (
                        f"the localized pose explains {self._fit_m[i]:.0f} of "
                        f"{self._fit_n[i]:.0f} recent bearings: kidnapped or lost; " + reason
                    )
                elif best is not None and best != i and state is TrackState.LOCALIZED:
                    # another pose took over: the same place (merged) or a jump
                    same = (
                        bool(self._near(best)[i])
                        or not self._distinct(self._poses[[i, best]], self._covs[[i, best]])[1]
                    )
                    if not same:
                        kidnapped = True
                        reason = "another pose took over the localized one; " + reason
        if kidnapped:
            self._localized_id = None
        if state is TrackState.LOCALIZED and best is not None:
            self._localized_id = int(self._ids[best])
        elif not kidnapped and state is not TrackState.LOCALIZED:
            # left localized without a rejection (e.g. ambiguity): keep watching that one
            pass
        return self._estimate(tf, state, reason, kidnapped)

    def _want_search(self, state: TrackState, suspect: bool, t: float) -> bool:
        """Search when not localized (lost or ambiguous) or when the localized hypothesis
        is suspect, at most every ``search_interval_s`` (the search itself skips frames
        with too few bearings)."""
        c = self.config
        if self._bearings_since_search == 0 or t - self._last_search < c.search_interval_s:
            return False
        return state is not TrackState.LOCALIZED or suspect

    def _near(self, i: int) -> NDArray[np.bool_]:
        """Which hypotheses are at the same place as hypothesis ``i`` (within
        ``cluster_position_m`` and ``cluster_heading``; ``i`` included)."""
        c = self.config
        d = self._poses - self._poses[i]
        dh = np.abs(np.asarray(wrap(d[:, 2])))
        return np.asarray(
            (np.hypot(d[:, 0], d[:, 1]) <= c.cluster_position_m) & (dh <= c.cluster_heading)
        )

    def _weights(self) -> FloatArray:
        if self.n_hypotheses == 0:
            return np.zeros(0)
        s = self._score - self._score.max()
        w = np.exp(s)
        return np.asarray(w / w.sum())

    def _decide(self, fit: FloatArray, t: float) -> tuple[TrackState, str, bool, int | None]:
        """(state, reason, suspect, index of the best hypothesis)."""
        c = self.config
        H = self.n_hypotheses
        if H == 0:
            return TrackState.LOST, "no hypothesis fits the recent bearings", False, None
        w = self._weights()
        i = int(np.argmax(w))
        P = self._covs[i]
        pos_sd = math.sqrt(max(float(np.linalg.eigvalsh(P[:2, :2])[-1]), 0.0))
        hdg_sd = math.sqrt(max(float(P[2, 2]), 0.0))
        fast = bool(self._fit_p(fast=True)[i] < fit[i])
        m_i, n_i = (self._fast_m[i], self._fast_n[i]) if fast else (self._fit_m[i], self._fit_n[i])
        suspect = bool(min(fit[i], self._fit_p(fast=True)[i]) < c.suspect_p)
        rivals = H - 1
        if suspect:
            return (
                TrackState.AMBIGUOUS,
                f"the best pose explains only {m_i:.0f} of {n_i:.0f} "
                f"{'latest' if fast else 'recent'} bearings",
                True,
                i,
            )
        share = float(w[self._near(i)].sum())
        if share < c.localized_share:
            return (
                TrackState.AMBIGUOUS,
                f"{H} hypotheses; the best place holds {100 * share:.0f} % of the mass",
                False,
                i,
            )
        if pos_sd > c.max_position_sd_m or hdg_sd > c.max_heading_sd:
            return (
                TrackState.AMBIGUOUS,
                f"pose too uncertain (position sd {pos_sd:.2f} m, heading sd "
                f"{math.degrees(hdg_sd):.1f} deg)",
                False,
                i,
            )
        if self._support[i] < c.min_support or t - self._born[i] < c.min_age_s:
            return (
                TrackState.AMBIGUOUS,
                f"too little evidence yet ({self._support[i]:.0f} bearings matched)",
                False,
                i,
            )
        return (
            TrackState.LOCALIZED,
            f"one place holds {100 * share:.1f} % of the mass ({rivals} rival"
            f"{'s' if rivals != 1 else ''})",
            False,
            i,
        )

    def _estimate(self, t: float, state: TrackState, reason: str, kidnapped: bool) -> TrackEstimate:
        if self.n_hypotheses == 0:
            return TrackEstimate(t, TrackState.LOST, reason=reason, kidnapped=kidnapped)
        w = self._weights()
        order = np.argsort(-w, kind="stable")[: self.config.max_reported]
        hyps = tuple(
            Hypothesis(Pose.from_array(self._poses[k]), self._covs[k].copy(), float(w[k]))
            for k in order
        )
        best = order[0]
        if state is TrackState.LOST:
            state = TrackState.AMBIGUOUS
        return TrackEstimate(
            t,
            state,
            pose=Pose.from_array(self._poses[best]),
            covariance=self._covs[best].copy(),
            hypotheses=hyps,
            reason=reason,
            kidnapped=kidnapped,
        )
