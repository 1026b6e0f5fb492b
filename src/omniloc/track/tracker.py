"""The tracker: global localization, multi-hypothesis tracking with odometry, kidnapping.

A :class:`Tracker` is fed odometry and frames of bearings in time order and reports, after
every frame, a :class:`~omniloc.track.TrackEstimate`: ``lost``, ``ambiguous`` (with its
competing hypotheses) or ``localized``, with the reason.

Its settings, :class:`~omniloc.track.TrackerConfig`, and their checks are in
:mod:`omniloc.track.config`.

How it works (``docs/tracking.md`` has the reasons and the figures)
-------------------------------------------------------------------
The tracker keeps a posterior over the pose: a weighted set of Gaussian *hypotheses* plus the
mass of *elsewhere* -- "the robot is at some pose no hypothesis covers" -- which is all of it
when the tracker wakes up.

* **Motion.** Odometry moves every hypothesis (an extended Kalman filter prediction with the
  :class:`~omniloc.track.MotionModel`'s noise). Between frames a share ``kidnap_rate * dt`` of
  the hypotheses' mass moves to elsewhere: the prior chance of being carried off, which keeps
  the tracker able to notice it.
* **Frames.** Each hypothesis earns the frame's likelihood ratio under the
  :class:`~omniloc.sensor.SensorModel` -- detections, clutter, landmarks in view that were not
  seen, summed over the assignments (:mod:`.likelihood`) -- and is updated by it (a mixture of
  Kalman steps over the bearing's readings, collapsed). Elsewhere earns the same ratio
  averaged over poses spread uniformly over the region the robot may be in. The weights are
  Bayes' rule: nothing is forgotten, nothing is tempered unless ``evidence_weight`` says so.
  (With ``search_miss`` set, elsewhere instead explains each frame at least as well as the
  best hypothesis, and only searches take mass from it: for sensors and maps where the
  searches often miss the true pose; see :class:`TrackerConfig`.) With
  ``clutter_persistence`` set the clutter has memory: what a place called clutter in the
  last frame with bearings it expects again near the same bearing (another robot stays put
  for seconds), each hypothesis and each of elsewhere's particles with its own memory. With
  ``turn_noise_s`` set, a frame taken while the robot turns has noisier bearings (variance
  ``sigma^2 + (turn rate * turn_noise_s)^2``), for every hypothesis, replay and particle.
* **New hypotheses.** While not localized, at most every ``search_interval_s``, the bearings
  of the shortest run of recent frames (at most ``search_window_s`` seconds) that holds
  ``search_min_bearings`` of them, stacked into the current frame by the odometry, go
  to :func:`~omniloc.localize`, whose exhaustive search returns every pose they are
  consistent with. Each candidate is then replayed through the frames of the last
  ``replay_s`` seconds with the exact model (each bearing from its own frame's
  odometry-predicted pose) and enters with the mass it had as a part of elsewhere when the
  replay began -- its prior volume (Laplace's Occam factor) times elsewhere's mass then --
  times the likelihood of the replayed frames: it is weighed on the same evidence as the
  hypotheses already tracked.
* **Pruning.** Hypotheses at the same pose (within ``merge_chi2`` and the metric bounds) merge
  (their masses add); hypotheses below ``prune_weight`` are dropped; at most
  ``max_hypotheses`` are kept.
* **Localized** only when the probability that the reported pose is within ``tolerance_m``
  and ``tolerance_heading`` of the truth -- the mass of the best place times the chance, under
  its covariance, that it is that close -- reaches ``localized_probability``. ``ambiguous``
  otherwise, with the competing hypotheses; ``lost`` when elsewhere holds nearly all the mass.
  With ``keep_probability`` set, a place localized so for ``keep_after`` frames in a row stays
  ``localized`` while it holds that mass and its covariance puts it within tolerance with at
  least ``keep_probability`` (a hysteresis on the pose's uncertainty; the reason says
  "kept"), but not in a frame of ``keep_unexplained`` bearings or more of which it explains
  none (the reason says "not kept").
* **Kidnapping.** When the place the tracker was localized at loses its mass (below
  ``kidnap_share``) to elsewhere or to another place, the estimate is flagged ``kidnapped``;
  the old hypothesis stays alongside the new ones until the evidence decides. A place that
  loses its mass more than ``kidnap_watch_s`` after the tracker stopped calling it
  ``localized`` is not flagged: the estimates have said ``ambiguous`` or ``lost`` all that
  while. With ``kidnap_confirm_s`` the loss must last that long before it is flagged (a
  place that wins its mass back within it was not left); with ``kidnap_fit`` the place must
  also no longer explain the bearings seen since the loss began (a copy of it moved by the
  odometry alone is tested against them: a place can lose its mass to missed detections
  while every bearing reported still fits it), and the tracker's belief must explain more
  of them than that copy (bearings that no place takes for landmarks are clutter).

Bad input: times that go back, values that are not finite and frames before any odometry
get a clear :class:`~omniloc.errors.InputError` or a stated behaviour (see
:meth:`Tracker.odometry` and :meth:`Tracker.frame`); the tracker's state is unchanged by a
rejected call.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections import deque
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree
from scipy.special import erf

from .._kernels.track import grid_pairs, merge_kernel, near_pairs, place_kernel, same_of_pairs
from ..angles import wrap
from ..errors import InputError
from ..io import finite_number, shorten
from ..maps import LandmarkMap, as_landmark_map
from ..pose import Pose, _covariance, _poses, compose_jacobians
from ..sensor import SensorModel
from .confidence import _interpolate, is_recent, knot_arrays
from .config import _CONFIDENCE_TABLES, TrackerConfig
from .data import _float_array
from .elsewhere import Elsewhere
from .likelihood import (
    FrameModel,
    Objects,
    frame_update_clutter,
    log_ratios_clutter,
    shared_pool,
)
from .modelcheck import misfit
from .motion import MotionModel, between, compose, integrate, inverse, move, twist_of
from .records import Hypothesis, TrackEstimate, TrackState
from .relocalize import PAIR_MAX_LANDMARKS, Candidates, pair_candidates, search_window
from .window import Window, WindowFrame

__all__ = ["Tracker", "TrackerConfig"]

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

#: Most bearings the tracker takes in one frame (elsewhere's particles keep a clutter memory
#: of every bearing: 3,000 particles x 1,000 bearings is 24 MB; a million bearings, 24 GB).
MAX_FRAME_BEARINGS = 1000

#: How many more of the bearings since a loss began the tracker's belief must explain than
#: the copy of the lost place before the loss is taken for a kidnapping (``kidnap_fit``):
#: half a bearing, the least difference of expected counts that rounds to another whole
#: count (on MRCLAM robot 5's seconds of other robots alone, 0.26 of 7 against the copy's
#: 0.24 under one of elsewhere's seeds: a tie, not evidence of another place).
KIDNAP_MARGIN = 0.5

#: The share of the belief a pose told by :meth:`Tracker.set_pose` takes by default (the rest
#: stays with elsewhere: a wrong pose told still leaves the robot somewhere to be found).
SET_POSE_MASS = 0.99

#: From this many candidates on, a search's replay runs in two halves side by side
#: (:meth:`Tracker._replay`): a replay is many frames (14 on average on MRCLAM, 4 s), so
#: one hand-off to the helper thread (about 0.1 ms) pays long before the 512 poses from
#: which a single frame is split (``likelihood.PARALLEL_MIN``).
REPLAY_PARALLEL_MIN = 64
#: A place told surely (:meth:`Tracker.set_pose`), which no search found and no age vouches
#: for, is localized only while it explains at least this share of the recent bearings
#: (``fit_explained``, if higher): a wrong pose told is not reported right while the
#: bearings disagree (with ``fit_explained`` 0 it was, 0.6 m off, on the first frame).
TOLD_FIT = 0.5

#: Below this many pairs of poses, all pairs are compared directly (building two k-d trees
#: costs more).
_BRUTE_PAIRS = 4096


def _posterior_explained(
    hyp_logw: FloatArray, hyp_explained: FloatArray, else_logw: float, else_explained: float
) -> float:
    """The expected number of a frame's bearings that are landmarks under the tracker's
    posterior: each hypothesis's count (``hyp_explained``) and elsewhere's
    (``else_explained``, its particles' mean as weighed by the frame) weighed by their
    log-masses after the frame (``hyp_logw``, ``else_logw``; not normalised)."""
    logw = np.append(hyp_logw, else_logw)
    top = float(logw.max())
    if not math.isfinite(top):
        return 0.0
    w = np.exp(logw - top)
    return float(w @ np.append(hyp_explained, else_explained) / w.sum())


def _logsumexp_rows(a: FloatArray) -> FloatArray:
    """ln of the sum of exp over each row of ``a`` (C, K); -inf for a row of -inf. (By hand:
    scipy.special.logsumexp costs more than the sums it does here.)"""
    top = np.max(a, axis=1)
    if np.isfinite(top).all():  # the common case, in fewer steps (the same numbers)
        return top + np.log(np.exp(a - top[:, None]).sum(axis=1))
    safe = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = safe + np.log(np.exp(a - safe[:, None]).sum(axis=1))
    return np.where(np.isfinite(top), out, top)


def _logsumexp(a: FloatArray) -> float:
    """ln of the sum of exp of ``a`` (-inf when empty)."""
    return (
        float(_logsumexp_rows(np.asarray(a, dtype=np.float64).reshape(1, -1))[0])
        if a.size
        else -math.inf
    )


def within_tolerance(cov: FloatArray, tol_m: float, tol_heading: float) -> float:
    """A lower bound on the probability that a Gaussian pose error of covariance ``cov`` is
    within ``tol_m`` in position and ``tol_heading`` in heading: the position along its
    widest axis taken for both (a circle of that variance), times the heading's share,
    as if independent."""
    lam = max(float(np.linalg.eigvalsh(cov[:2, :2])[-1]), 1e-30)
    p_pos = 1.0 - math.exp(-0.5 * tol_m * tol_m / lam)
    sd_h = math.sqrt(max(float(cov[2, 2]), 1e-30))
    p_head = float(erf(tol_heading / (math.sqrt(2.0) * sd_h)))
    return p_pos * p_head


class Tracker:
    """Localization over time from odometry and frames of unlabelled bearings.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
        The map, metres.
    sensor : SensorModel, optional
        Noise, field of view, range, detection probability and clutter of the bearing
        sensor (default: ``SensorModel(sigma=0.5 deg)``; without ``p_detect`` or ``clutter``
        the tracker takes 0.5 and 0.5 per frame), and where it sits on the robot
        (``mount``): the bearings are the sensor's, the odometry and every pose the tracker
        reports are the robot's (it follows the sensor's pose inside, each odometry step
        carried to it).
    motion : MotionModel, optional
        Odometry noise and latency (default: ``MotionModel()``).
    config : TrackerConfig, optional
        Decision parameters.

    Examples
    --------
    >>> import numpy as np, omniloc
    >>> from omniloc.sensor import SensorModel
    >>> from omniloc.track import Tracker
    >>> room = omniloc.demo_room()
    >>> tracker = Tracker(room, SensorModel(sigma=np.deg2rad(0.3)))
    >>> truth = omniloc.Pose(5.6, 2.1, np.deg2rad(30))
    >>> for k in range(16):
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
        if self.sensor.clutter_by_detections is not None:
            # The frame likelihood sums over the landmarks each bearing may be, without
            # counting detections: it has no count to look the rate up by.
            log.warning(
                "Tracker: the sensor's clutter_by_detections is for scoring single frames; "
                "the tracker uses one clutter rate, %s per frame",
                self.sensor.clutter if self.sensor.clutter is not None else "0.5 (its default)",
            )
        self.motion = motion if motion is not None else MotionModel()
        if not isinstance(self.motion, MotionModel):
            raise InputError(f"motion must be a MotionModel, got {type(motion).__name__}")
        self.config = config if config is not None else TrackerConfig()
        if not isinstance(self.config, TrackerConfig):
            raise InputError(f"config must be a TrackerConfig, got {type(config).__name__}")
        c = self.config
        if c.min_landmarks > self.landmarks.n:
            raise InputError(
                f"min_landmarks={c.min_landmarks} but the map has {self.landmarks.n} landmarks: "
                "no place could ever be localized (0 turns the test off)"
            )
        if c.pair_search and self.landmarks.n > PAIR_MAX_LANDMARKS:
            raise InputError(
                f"pair_search on a map of {self.landmarks.n} landmarks: it tries every pair of "
                f"landmarks at every search, for maps of at most {PAIR_MAX_LANDMARKS}"
            )
        self._L = np.ascontiguousarray(self.landmarks.xy, dtype=np.float64)
        self._mount = None if self.sensor.mount is None else np.array(self.sensor.mount)
        self._model = FrameModel.of(self.sensor)
        if c.core_share > 0:
            self._model = replace(
                self._model,
                core_share=c.core_share,
                core_sigma2=c.core_sigma**2,
                core_update=c.core_update,
            )
        if c.temper_update and c.evidence_weight != 1.0:
            self._model = replace(self._model, update_scale=1.0 / c.evidence_weight)
        if c.nonempty_frames:
            self._model = replace(self._model, nonempty=True)
        if c.miss_weight != 1.0:
            self._model = replace(self._model, miss_weight=c.miss_weight)
        if c.exclusive_landmarks:
            self._model = replace(self._model, exclusive=True)
        if c.occlusion_width > 0:
            self._model = replace(self._model, occlusion=c.occlusion_width)
        if c.clutter_persistence > 0:
            self._model = replace(
                self._model,
                fresh=1.0 - c.clutter_persistence,
                object_var=c.clutter_persistence_sd**2,
            )
        if c.region is not None:
            x0, x1, y0, y1 = c.region
        else:
            lo = self._L.min(axis=0) - c.region_margin_m
            hi = self._L.max(axis=0) + c.region_margin_m
            x0, x1, y0, y1 = float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])
        #: The region the robot may be in, (xmin, xmax, ymin, ymax), metres.
        self.region = (x0, x1, y0, y1)
        # ln of the prior density of a pose, uniform over the region and all headings.
        self._log_prior = -math.log((x1 - x0) * (y1 - y0) * 2.0 * math.pi)
        # Elsewhere's particles are the sensor's poses: where a robot inside the region may
        # carry its sensor (the region widened by the mount's reach).
        reach = 0.0 if self._mount is None else math.hypot(self._mount[0], self._mount[1])
        x0, x1, y0, y1 = self.region
        self._elsewhere = Elsewhere(
            (x0 - reach, x1 + reach, y0 - reach, y1 + reach),
            c.elsewhere_samples,
            c.elsewhere_inject,
            seed=c.seed,
        )
        self._window = Window(
            max(c.replay_s, c.search_window_s, c.landmarks_window_s if c.min_landmarks else 0.0)
            + 1e-9
        )
        # (t, ln elsewhere mass, cumulative normaliser) before each frame of the window.
        self._history: deque[tuple[float, float, float]] = deque()
        # Odometry: rows (t, vx, vy, w) not yet integrated, and the twist holding now.
        self._rows: list[FloatArray] = []
        self._hold = np.zeros(3)
        self._hold_t: float | None = None
        self._last_row_t: float | None = None
        self._input_kind: str | None = None
        # The last odometry pose taken (odometry_poses), which the next one is moved from.
        self._last_pose: FloatArray | None = None
        self._t: float | None = None  # time of the last frame (motion integrated up to it)
        self._warned_no_odometry = False
        self._after_gap = False  # a gap was reported and no odometry row came since
        # The posterior: hypotheses (normalised log masses) and elsewhere.
        self._mu = np.zeros((0, 3))
        self._P = np.zeros((0, 3, 3))
        self._logw = np.zeros(0)
        self._ids = np.zeros(0, dtype=np.int64)
        self._born = np.zeros(0)
        self._conf = np.zeros(0, dtype=np.int64)  # searches that found this place
        self._conf_t = np.zeros(0)  # end of the last search window that did
        self._fit_m = np.zeros(0)  # bearings explained, forgetting over fit_window_s
        self._fit_n = np.zeros(0)  # bearings seen, the same
        # Clutter with memory: the last frame with bearings (its bearings, the odometry's
        # turn since, its time) and each hypothesis's expected count of each seen again.
        self._mem_b = np.zeros(0)
        self._mem_rot = 0.0
        self._mem_t = -math.inf
        self._mem_w = np.zeros((0, 0))
        self._log_out = 0.0
        # The last search's closest rival of the place that led (search_rival_nats): the
        # search's time, the leading place's hypothesis id, the evidence gap (nats) and
        # the rival's distance (m).
        self._rival: tuple[float, int, float, float] | None = None
        self._norm = 0.0  # sum of the log normalisers so far
        self._next_id = 0
        self._last_search = -math.inf
        self._bearings_since_search = 0
        self._localized_id: int | None = None
        # Hysteresis (keep_probability): frames localized in a row up to the last one (0: it
        # was not localized; a frame can only be kept after keep_after of them, all localized
        # by the full tests), whether the last decision kept a frame, and whether it refused
        # to (keep_unexplained).
        self._localized_run = 0
        self._kept = False
        self._not_kept = False
        # min_best_s: the best hypothesis's pose, the window's odometry there and since when
        # its place has been the best, as the last frame's decision left them, and as this
        # frame's makes them (a frame may decide twice: before and after a search).
        self._lead_last: tuple[FloatArray, FloatArray, float] | None = None
        self._lead_now: tuple[FloatArray, FloatArray, float] | None = None
        self._lead_t = -math.inf
        # The best place's estimate as the last decision made it (index, mean, covariance).
        #: (best hypothesis, its place's pose, covariance and probability within tolerance)
        self._best_place: tuple[int, FloatArray, FloatArray, float] | None = None
        # The place the last estimate reported, in the sensor's frame.
        self._place_out: tuple[FloatArray, FloatArray] | None = None
        # The confidence tables as arrays of knots, made once (each is read every frame).
        self._tables = {
            name: None if t is None else knot_arrays(t)
            for name in _CONFIDENCE_TABLES
            for t in (getattr(self.config, name),)
        }
        # The time of the last localized frame (None: none since the start, the last flag
        # of a kidnapping or the last odometry gap): what since_localized reports.
        self._localized_t: float | None = None
        # The first frame since the last localized one that was not localized (None while
        # localized): kidnap_watch_s runs from there.
        self._unvouched_t: float | None = None
        # The first frame of the current run of frames in which the watched place held less
        # than kidnap_share (None: it holds at least that): kidnap_confirm_s runs from there.
        self._below_t: float | None = None
        # The watched place as the last localized frame reported it, moved by the odometry
        # alone (kidnap_fit), and the bearings it explained and saw since the loss began.
        self._watch: tuple[FloatArray, FloatArray] | None = None
        self._watch_m = 0.0
        self._watch_n = 0
        self._watch_mix = 0.0  # ... and the tracker's belief explained (_posterior_explained)
        #: Number of searches run so far (for reports).
        self.searches = 0
        # A prior told by set_pose before any frame: born at the first frame.
        self._born_at_first_frame = False

    # ---- a pose told ----------------------------------------------------------------------
    def set_pose(
        self, pose: Pose | ArrayLike, covariance: ArrayLike, *, mass: float = SET_POSE_MASS
    ) -> None:
        """Tell the tracker where the robot is, as ROS's ``/initialpose`` tells AMCL: a
        robot started at its dock, or put back where an operator says.

        The belief becomes the Gaussian ``N(pose, covariance)`` with ``mass`` of it, and
        elsewhere (uniform over the region) the rest; every hypothesis before is dropped.
        The pose holds at the time of the last frame taken (before any frame: at the first
        one); the odometry moves it from there.

        A pose told as surely as ``localized`` asks (``covariance`` within tolerance with
        ``localized_probability``: sds of about 0.05 m and 1.5 deg for 0.3 m and 5 deg)
        counts as found by the searches and as old enough (``min_confirmations``,
        ``min_age_s``): it is called ``localized`` as soon as it explains the bearings
        (``fit_explained``, and at least :data:`TOLD_FIT` of them). A looser one is a prior:
        its place must be confirmed by the searches and grow old like any other (a place
        within a wide prior may be the wrong one of several that fit). A wrong pose told
        surely is not reported while most of the bearings disagree with it, but it is the
        user's word: one that half explains them is (on the example recording 7 of 63 poses
        told 0.6 m or 8 deg off were localized on the next frame), until the evidence moves
        the mass; the searches look for the robot elsewhere meanwhile.

        Parameters
        ----------
        pose : Pose or array_like, shape (3,)
            The robot's ``(x, y, theta)``, metres and radians (with a mount, the robot's,
            not the sensor's), inside the tracker's region.
        covariance : array_like, shape (3, 3)
            Its uncertainty: symmetric, positive definite; m^2 and rad^2.
        mass : float
            The share of the belief on the told pose, in (0, 1).

        Raises
        ------
        InputError
            A pose that is not one, outside the region; a covariance that is not a finite,
            symmetric, positive-definite 3 x 3 matrix; a mass outside (0, 1). Nothing is
            changed then.
        """
        p = _poses(pose, "pose")
        if p.shape != (3,):
            raise InputError(f"pose must be one pose (shape (3,)), got shape {p.shape}")
        C = _covariance(covariance, "covariance", definite=True)
        sd = np.sqrt(np.diag(C))
        if sd[2] > math.pi or max(sd[0], sd[1]) > 1e6:
            raise InputError(
                "covariance must have position sds at most 1e6 m and a heading sd at most pi "
                f"(got {sd[0]:.3g} m, {sd[1]:.3g} m, {sd[2]:.3g} rad)"
            )
        m = finite_number(mass, "mass")
        if not 0.0 < m < 1.0:
            raise InputError(f"mass must lie in (0, 1), got {m!r}")
        x0, x1, y0, y1 = self.region
        if not (x0 <= p[0] <= x1 and y0 <= p[1] <= y1):
            raise InputError(
                f"pose ({p[0]:.4g}, {p[1]:.4g}) lies outside the tracker's region x {x0:g}..{x1:g}"
                f", y {y0:g}..{y1:g} m (TrackerConfig.region)"
            )
        mu, P = p.copy(), C.copy()
        if self._mount is not None:
            # The sensor's pose, the covariance carried by the mount's Jacobian.
            J = compose_jacobians(p, self._mount)[0]
            mu, P = compose(p, self._mount), J @ C @ J.T
        c = self.config
        trusted = within_tolerance(C, c.tolerance_m, c.tolerance_heading) >= c.localized_probability
        self._drop_all()
        # The masses elsewhere held before belong to the belief replaced: a search's candidates
        # enter from the frames after this one (the window's bearings are still searched).
        self._history.clear()
        self._localized_run = 0
        self._kept = False
        self._not_kept = False
        self._unvouched_t = None
        self._mu = mu.reshape(1, 3)
        self._P = (0.5 * (P + P.T)).reshape(1, 3, 3)
        self._logw = np.array([math.log(m)])
        self._log_out = math.log1p(-m)
        self._ids = np.array([self._next_id], dtype=np.int64)
        self._next_id += 1
        # Trusted: old enough and confirmed. A prior: born at the frame it holds at and found
        # by no search yet.
        # (before any frame the first frame sets it: _born_at_first_frame)
        self._born_at_first_frame = not trusted and self._t is None
        self._born = np.array([-math.inf if trusted else (0.0 if self._t is None else self._t)])
        self._conf = np.array([c.min_confirmations if trusted else 0], dtype=np.int64)
        self._conf_t = np.array([-math.inf if self._t is None else self._t])
        self._fit_m = np.zeros(1)
        self._fit_n = np.zeros(1)
        self._mem_w = np.zeros((1, 0))
        if trusted:
            # ... and the best place since it was told (min_best_s; a prior leads from the
            # first decision that finds it the best).
            told = (mu.copy(), self._odom_now(), -math.inf)
            self._lead_last = self._lead_now = told

    # ---- input ---------------------------------------------------------------------------
    @property
    def n_hypotheses(self) -> int:
        """Hypotheses tracked now."""
        return int(self._mu.shape[0])

    def _check_row_times(self, t: FloatArray, what: str) -> None:
        d = np.diff(t)
        bad = np.flatnonzero(d < 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise InputError(
                f"{what} times must not decrease: row {k} has t={float(t[k])!r} after "
                f"{float(t[k - 1])!r}"
            )
        if self._last_row_t is not None and t[0] < self._last_row_t:
            raise InputError(
                f"{what} out of time order: t={float(t[0])!r} after a row at {self._last_row_t!r}"
            )
        if self._t is not None and t[0] + self.motion.delay_s < self._t:
            raise InputError(
                f"{what} at t={float(t[0])!r} arrived after the frame at t={self._t!r} that it "
                "would move: feed odometry before the frames it covers"
            )

    def _check_kind(self, kind: str) -> None:
        """Refuse a kind of odometry other than the one this tracker took first (call
        :meth:`_set_kind` once the rows are accepted)."""
        if self._input_kind is not None and self._input_kind != kind:
            raise InputError(
                f"this tracker takes {self._input_kind}; it cannot also take {kind} "
                "(feed one kind of odometry)"
            )

    def _set_kind(self, kind: str) -> None:
        self._check_kind(kind)
        self._input_kind = kind

    def odometry(
        self, t: ArrayLike, v: ArrayLike, w: ArrayLike, vy: ArrayLike | None = None
    ) -> None:
        """Velocity odometry: rows ``t`` (s), forward velocity ``v`` (m/s), turn rate ``w``
        (rad/s) and, optionally, sideways velocity ``vy`` (m/s, to the left), each row
        holding until the next (and the last one until a frame).

        Raises
        ------
        InputError
            Arrays of different lengths, values that are not finite, times that decrease
            (within the call or against earlier rows), or rows older than a frame already
            processed (their motion would be lost). Nothing is changed then.
        """
        tt = _float_array("odometry t", t, scalar=True)
        vv = _float_array("odometry v", v, scalar=True)
        ww = _float_array("odometry w", w, scalar=True)
        side = np.zeros_like(vv) if vy is None else _float_array("odometry vy", vy, scalar=True)
        if not (tt.shape == vv.shape == ww.shape == side.shape):
            raise InputError(
                f"odometry t, v, w{'' if vy is None else ' and vy'} must have one value per "
                f"row: got {tt.size}, {vv.size}, {ww.size}"
                + ("" if vy is None else f", {side.size}")
            )
        if tt.size == 0:
            return
        self._check_row_times(tt, "odometry")
        self._set_kind("velocities")
        rows = np.stack([tt + self.motion.delay_s, vv, side, ww], axis=1)
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
        tt = _float_array("increments t", t, scalar=True)
        cols = [
            _float_array(n, a, scalar=True) for n, a in (("dx", dx), ("dy", dy), ("dtheta", dtheta))
        ]
        if any(c.size != tt.size for c in cols):
            raise InputError(
                "increments t, dx, dy and dtheta must have one value per row: got "
                + ", ".join(str(c.size) for c in (tt, *cols))
            )
        self._add_increments(tt, np.stack(cols, axis=1).reshape(-1, 3), "increments")

    def odometry_poses(self, t: ArrayLike, x: ArrayLike, y: ArrayLike, theta: ArrayLike) -> None:
        """Odometry as poses: the odometry's own estimate of the pose (m, m, rad) at times
        ``t``, in its own frame (ROS's ``/odom``, or the transform from ``odom`` to the
        robot); only the motion between poses is read. The first pose ever starts the
        clock; each later one adds the motion from the pose before it (this call's or the
        last call's), as :meth:`increments` does, sideways part included; after the last
        pose the robot is taken to go on as in the last interval until a frame.

        Raises
        ------
        InputError
            As :meth:`increments`; also two different poses at one time. Nothing is changed
            then.
        """
        tt = _float_array("odometry poses t", t, scalar=True)
        cols = [
            _float_array(f"odometry poses {n}", a, scalar=True)
            for n, a in (("x", x), ("y", y), ("theta", theta))
        ]
        if any(c.size != tt.size for c in cols):
            raise InputError(
                "odometry poses t, x, y and theta must have one value per row: got "
                + ", ".join(str(c.size) for c in (tt, *cols))
            )
        if tt.size == 0:
            return
        poses = np.stack(cols, axis=1)
        self._check_kind("poses")
        chain = poses if self._last_pose is None else np.vstack([self._last_pose, poses])
        dd = between(chain[:-1], chain[1:])
        if self._last_pose is None:
            dd = np.vstack([np.zeros((1, 3)), dd])
        self._add_increments(tt, dd, "poses")
        self._last_pose = poses[-1].copy()

    def _add_increments(self, tt: FloatArray, dd: FloatArray, kind: str) -> None:
        """Rows of increments ``dd`` (k, 3) ending at times ``tt`` (k,), checked first:
        nothing is changed when they are refused."""
        if tt.size == 0:
            return
        self._check_row_times(tt, "odometry poses" if kind == "poses" else kind)
        self._check_kind(kind)
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
        if bad.size:
            k = int(bad[0])
            what = "pose" if kind == "poses" else "increment"
            raise InputError(f"{what} row {k} moves the robot in zero time (t={float(tt[k])!r})")
        self._set_kind(kind)
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
        delta, Q = self._sensor_motion(delta, Q)
        return delta, Q, gap

    # ---- the sensor's frame --------------------------------------------------------------
    # The hypotheses, elsewhere's particles and the window are poses of the sensor (what the
    # bearings are measured from); the odometry is the robot's, and so is what the tracker
    # reports. Without a mount the two frames are one.
    def _sensor_motion(self, delta: FloatArray, Q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The robot's motion ``delta`` (covariance ``Q``) as the sensor's: ``M^-1 (+) delta
        (+) M`` for the mount ``M``, its covariance carried to first order."""
        if self._mount is None:
            return delta, Q
        M = self._mount
        back = inverse(M)
        head = compose(back, delta)
        J = compose_jacobians(head, M)[0] @ compose_jacobians(back, delta)[1]
        return compose(head, M), J @ Q @ J.T

    def _robot(self, mu: FloatArray, P: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Sensor poses ``mu`` (n, 3) and covariances ``P`` (n, 3, 3) as the robot's."""
        if self._mount is None:
            return mu, P
        return self.sensor.robot_poses(mu, P)

    # ---- the posterior -------------------------------------------------------------------
    def _inside(self, mu: FloatArray) -> NDArray[np.bool_]:
        """Which poses lie in the region the robot may be in (the prior is zero outside it;
        a refinement or a filter that wanders off, kilometres away, is dropped), with
        ``tolerance_m`` of slack at its edges."""
        x0, x1, y0, y1 = self.region
        m = self.config.tolerance_m
        if self._mount is not None and mu.shape[0]:
            mu = self.sensor.robot_poses(mu)
        return np.asarray(
            (mu[:, 0] >= x0 - m)
            & (mu[:, 0] <= x1 + m)
            & (mu[:, 1] >= y0 - m)
            & (mu[:, 1] <= y1 + m)
        )

    def _normalise(self) -> None:
        total = float(np.logaddexp(self._log_out, _logsumexp(self._logw)))
        self._log_out -= total
        self._logw = self._logw - total
        self._norm += total

    def _keep(self, idx: NDArray[np.int64] | NDArray[np.bool_]) -> None:
        self._mu = self._mu[idx]
        self._P = self._P[idx]
        self._logw = self._logw[idx]
        self._ids = self._ids[idx]
        self._born = self._born[idx]
        self._conf = self._conf[idx]
        self._conf_t = self._conf_t[idx]
        self._fit_m = self._fit_m[idx]
        self._fit_n = self._fit_n[idx]
        self._mem_w = self._mem_w[idx]

    def _split(
        self, mu0: FloatArray, P0: FloatArray, post: FloatArray, fit_m0: FloatArray, persist: float
    ) -> None:
        """Split the hypotheses for which "every bearing of the frame was clutter" is neither
        negligible nor nearly certain (``split_clutter``): the updated one keeps the chance
        that some bearing was a landmark, a copy of it as it was before the frame (``mu0``,
        ``P0``, ``fit_m0``) takes the chance that none was. Both keep the lineage (id, age,
        confirmations): the place a localized state stands on is the heavier of them."""
        c = self.config
        # Each bearing's probability of being clutter, given the ones before it: their
        # product is the chance that all were (the frame's readings taken in sequence).
        null = np.exp(np.log(np.clip(post, 1e-300, 1.0)).sum(axis=1))
        split = np.flatnonzero((null >= c.split_clutter) & (null <= 1.0 - c.split_clutter))
        if split.size == 0:
            return
        ew = c.evidence_weight
        self._logw = self._logw.copy()
        base = self._logw[split].copy()
        self._logw[split] = base + ew * np.log1p(-null[split])
        self._mu = np.concatenate([self._mu, mu0[split]])
        self._P = np.concatenate([self._P, P0[split]])
        self._logw = np.concatenate([self._logw, base + ew * np.log(null[split])])
        self._ids = np.concatenate([self._ids, self._ids[split]])
        self._born = np.concatenate([self._born, self._born[split]])
        self._conf = np.concatenate([self._conf, self._conf[split]])
        self._conf_t = np.concatenate([self._conf_t, self._conf_t[split]])
        self._fit_m = np.concatenate([self._fit_m, fit_m0[split]])
        self._fit_n = np.concatenate([self._fit_n, self._fit_n[split]])
        self._mem_w = np.concatenate(
            [self._mem_w, np.full((split.size, self._mem_w.shape[1]), persist)]
        )

    def _drop_all(self) -> None:
        self._keep(np.zeros(0, dtype=np.int64))
        # (The window's odometry starts again: no lead is carried across.)
        self._lead_last = self._lead_now = None
        self._localized_t = None
        self._mem_b = np.zeros(0)
        self._mem_w = np.zeros((0, 0))
        self._mem_t = -math.inf
        self._log_out = 0.0
        self._localized_id = None
        self._below_t = None
        self._watch = None
        self._rival = None
        self._elsewhere.reset()

    def _exclude(self) -> None:
        """Elsewhere gives up the places the hypotheses cover (with their mass), and
        resamples."""
        if self.n_hypotheses:
            share = self._elsewhere.exclude(self._mu, self._P)
            if share > 0:
                self._log_out += math.log1p(-share) if share < 1.0 else -math.inf
                if not math.isfinite(self._log_out):
                    self._log_out = -745.0
                self._normalise()
        self._elsewhere.resample()

    def _same_pairs(
        self, mu_a: FloatArray, P_a: FloatArray, mu_b: FloatArray, P_b: FloatArray
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The pairs ``(a, b)`` of poses of ``mu_a`` and ``mu_b`` (covariances ``P_a``, ``P_b``)
        that are the same pose, ordered by ``a`` then ``b``: within ``merge_position_m`` (found
        in cells of that size, or directly for small sets) and ``merge_heading`` of each other, and
        within ``merge_chi2`` in the Mahalanobis distance of their summed covariances."""
        c = self.config
        none = np.zeros(0, dtype=np.int64)
        if mu_a.shape[0] == 0 or mu_b.shape[0] == 0:
            return none, none
        mu_a = np.ascontiguousarray(mu_a, dtype=np.float64)
        mu_b = np.ascontiguousarray(mu_b, dtype=np.float64)
        P_a = np.ascontiguousarray(P_a, dtype=np.float64)
        P_b = np.ascontiguousarray(P_b, dtype=np.float64)
        if mu_a.shape[0] * mu_b.shape[0] <= _BRUTE_PAIRS:
            return near_pairs(
                mu_a, P_a, mu_b, P_b, c.merge_position_m**2, c.merge_heading, c.merge_chi2
            )
        ia, ib, done = grid_pairs(
            mu_a, P_a, mu_b, P_b, c.merge_position_m**2, c.merge_heading, c.merge_chi2
        )
        if done:
            return ia, ib
        # (Poses spread over more than 2^20 cells of merge_position_m.)
        near = cKDTree(mu_a[:, :2]).sparse_distance_matrix(
            cKDTree(mu_b[:, :2]), c.merge_position_m, output_type="ndarray"
        )
        ia, ib = near["i"].astype(np.int64), near["j"].astype(np.int64)
        same = same_of_pairs(mu_a, P_a, mu_b, P_b, ia, ib, c.merge_heading, c.merge_chi2)
        ia, ib = ia[same], ib[same]
        order = np.lexsort((ib, ia))
        return ia[order], ib[order]

    def _merge_and_prune(self) -> None:
        """Merge hypotheses at one pose (moment matching, masses added), drop the light ones,
        keep at most ``max_hypotheses``."""
        if self.n_hypotheses == 0:
            return
        c = self.config
        order = np.argsort(-self._logw, kind="stable")
        self._keep(order[self._logw[order] >= math.log(c.prune_weight)])
        H = self.n_hypotheses
        alive = np.ones(H, dtype=bool)
        # Each hypothesis absorbs the weaker ones at its pose that are still alive (pairs of
        # the hypotheses as they are before any merge: a merge changes only the absorber,
        # which no later hypothesis is compared with).
        pa, pb = self._same_pairs(self._mu, self._P, self._mu, self._P)
        later = pb > pa
        pa, pb = pa[later], pb[later]
        if pa.size:
            # (The heaviest of each group absorbs, so the groups' log-sum-exp is its ln mass
            # plus the log of the summed mass ratios, the same ratios that weigh the merge.)
            self._mem_w = np.ascontiguousarray(self._mem_w, dtype=np.float64)
            self._conf = np.ascontiguousarray(self._conf, dtype=np.int64)
            alive, total, loc = merge_kernel(
                pa,
                pb,
                np.exp(self._logw[pb] - self._logw[pa]),
                self._mu,
                self._P,
                self._born,
                self._conf,
                self._conf_t,
                self._fit_m,
                self._fit_n,
                self._mem_w,
                self._ids,
                -1 if self._localized_id is None else self._localized_id,
            )
            self._logw = self._logw + np.log(total)
            if self._localized_id is not None:
                self._localized_id = int(loc)
        idx = np.flatnonzero(alive)
        idx = idx[np.argsort(-self._logw[idx], kind="stable")][: c.max_hypotheses]
        self._keep(idx)

    # ---- clutter with memory -------------------------------------------------------------
    def _objects(
        self, t: float, mem_b: FloatArray, rot: float, mem_t: float, weights: FloatArray
    ) -> Objects | None:
        """The objects of the last frame with bearings (``mem_b``, at ``mem_t``, turned by
        ``rot`` since) as seen at ``t``, with their expected counts ``weights`` (rows: poses);
        None without memory."""
        c = self.config
        if c.clutter_persistence <= 0 or mem_b.size == 0 or t - mem_t > c.clutter_memory_s:
            return None
        ob = np.asarray(wrap(mem_b - rot))
        w = weights
        if self.sensor.half_fov is not None:
            w = w * (np.abs(ob) <= self.sensor.half_fov)
        return Objects(ob, w)

    # ---- new hypotheses ------------------------------------------------------------------
    def _replay(
        self, poses: FloatArray, covs: FloatArray, frames: list[WindowFrame]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Candidates at the last frame of ``frames`` (poses, covariances): moved back to the
        first frame by the odometry, their covariances grown there by the odometry's noise
        over the replay (roughly: summed in the robot's frames), then filtered forward
        through every frame with the exact model. Returns
        their poses and covariances at the last frame, the ln of their prior volume, their
        log-likelihood ratios summed from each frame of the replay to its end (C, K), their
        counts of bearings explained and seen (with the recent-fit forgetting), and their
        clutter memory (the expected counts of the tracker's memory objects, zero when the
        replay does not reach the tracker's last frame with bearings).

        From ``REPLAY_PARALLEL_MIN`` candidates on, the two halves are replayed side by side
        (each candidate is replayed alone, so the results are the same bit for bit): one
        hand-off for the whole replay instead of one per frame, and the frames' own steps
        run in parallel too."""
        Q = np.zeros((3, 3))
        for f in frames[1:]:
            Q = Q + f.Q
        covs = covs + Q
        pool = shared_pool() if poses.shape[0] >= REPLAY_PARALLEL_MIN else None
        if pool is None:
            return self._replay_part(poses, covs, frames, parallel=True)
        half = poses.shape[0] // 2
        first = pool.submit(self._replay_part, poses[:half], covs[:half], frames, parallel=False)
        second = self._replay_part(poses[half:], covs[half:], frames, parallel=False)
        a = first.result()
        return tuple(  # type: ignore[return-value]
            np.concatenate([x, y]) for x, y in zip(a, second, strict=True)
        )

    def _replay_part(
        self, poses: FloatArray, covs: FloatArray, frames: list[WindowFrame], *, parallel: bool
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """:meth:`_replay` of some candidates on the calling thread (``parallel``: its frame
        likelihoods may use the helper thread)."""
        c = self.config
        rel = between(frames[0].odom, frames[-1].odom)
        mu = compose(poses, inverse(rel))
        P = covs.copy()
        sign, logdet = np.linalg.slogdet(2.0 * math.pi * P)
        volume = np.where(sign > 0, 0.5 * logdet, -math.inf) + self._log_prior
        lrs = np.zeros((mu.shape[0], len(frames)))
        fit_m = np.zeros(mu.shape[0])
        fit_n = np.zeros(mu.shape[0])
        # The clutter's memory starts empty at the first frame of the replay (what a
        # candidate called clutter before it is not known): its first frame pays for its
        # clutter as new clutter, a small handicap against the places already tracked.
        mem_b, mem_w, mem_t, rot = np.zeros(0), np.zeros((mu.shape[0], 0)), -math.inf, 0.0
        for k, f in enumerate(frames):
            if k:
                mu, P = move(mu, P, f.delta, f.Q)
                rot += float(f.delta[2])
                decay = math.exp(-(f.t - frames[k - 1].t) / c.fit_window_s)
                fit_m, fit_n = fit_m * decay, fit_n * decay
            objects = self._objects(f.t, mem_b, rot, mem_t, mem_w)
            mu, P, lr, explained, post = frame_update_clutter(
                mu,
                P,
                f.bearings,
                self._L,
                self._frame_model(f.turn_rate),
                objects,
                parallel=parallel,
            )
            if f.bearings.size:
                mem_b, mem_w, mem_t, rot = f.bearings, c.clutter_persistence * post, f.t, 0.0
            lrs[:, k] = c.evidence_weight * lr
            fit_m = fit_m + explained
            fit_n = fit_n + f.bearings.size
        to_end = np.cumsum(lrs[:, ::-1], axis=1)[:, ::-1]
        if mem_t != self._mem_t or mem_w.shape[1] != self._mem_b.size:
            mem_w = np.zeros((mu.shape[0], self._mem_b.size))
        return mu, P, volume, to_end, fit_m, fit_n, mem_w

    def _replay_entries(
        self,
        poses: FloatArray,
        covs: FloatArray,
        rframes: list[WindowFrame],
        entry: FloatArray,
        to_end: FloatArray,
        volume: FloatArray,
        logw: FloatArray,
        state: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
        found_from: float,
    ) -> None:
        """Weigh the candidates again, in place, for entries from later frames of the replay:
        the frame at which elsewhere held the most mass, and the first frame the search
        looked at (``found_from``, a time), each replayed from that frame, as places that
        left elsewhere there. The entries are split at those frames; each part is weighed
        by the replay that starts it. ``state`` (the replay's poses, covariances, fit counts,
        clutter memory and the times the places are held since) is replaced, in place, by
        the replay of each candidate's heaviest part (a tie: the later).

        The replay from the first frame reaches each later entry with a state shaped by the
        frames before it, without their evidence: sharpened by frames a look-alike happened
        to explain, or pulled off by frames from before a kidnapping that the true place
        cannot explain. A place entering after the frames that emptied the tracked places
        would not have seen them; and the frames the search found a place on are frames it
        explains, whatever came before them (a kidnapping from a state that was not
        localized leaves elsewhere's mass without a peak at the jump)."""
        starts = {0}
        k = int(np.argmax(entry))
        if np.isfinite(entry[k]):
            starts.add(k)
        f0 = next((i for i, f in enumerate(rframes) if f.t >= found_from), 0)
        if np.isfinite(entry[f0]):
            starts.add(f0)
        if len(starts) == 1:
            return
        bounds = [*sorted(starts), len(rframes)]
        mu, P, fit_m, fit_n, mem_w, born = state
        parts = [_logsumexp_rows(entry[None, : bounds[1]] + to_end[:, : bounds[1]]) + volume]
        best = parts[0].copy()
        for a, b in itertools.pairwise(bounds[1:]):
            sub = rframes[a:]
            mu2, P2, vol2, end2, fm2, fn2, mw2 = self._replay(poses, covs, sub)
            part = _logsumexp_rows(entry[None, a:b] + end2[:, : b - a]) + vol2
            # (A candidate this replay lost -- its pose or covariance no longer finite --
            # keeps its other entries.)
            part = np.where(np.isnan(part), -math.inf, part)
            parts.append(part)
            late = part >= best
            best = np.where(late, part, best)
            mu[late], P[late], fit_m[late], fit_n[late], mem_w[late] = (
                mu2[late],
                P2[late],
                fm2[late],
                fn2[late],
                mw2[late],
            )
            born[late] = sub[0].t
        total = parts[0]
        for part in parts[1:]:
            total = np.logaddexp(total, part)
        logw[:] = total - self._norm

    def _closest_rival(
        self, t: float, mu: FloatArray, evidence: FloatArray
    ) -> tuple[float, int, float, float] | None:
        """The search's candidates ``mu`` (at frame ``t``) with their evidence over the
        replay (the log-likelihood ratio of its frames): if the leading place is among them
        and another place came within ``search_rival_nats`` of its evidence, ``(t, the
        leading hypothesis's id, the gap, the rival's distance)``; else None.

        Every other place counts, tracked or not: a place tracked since before the replay
        was weighed against the leader on those frames too, but leaving such places out
        (measured on the look-alikes' battery, 2026-12-07) left 21 more wrong frames, for
        147 more right ones."""
        if not self.n_hypotheses:
            return None
        i = int(np.argmax(self._logw))
        ok = np.isfinite(evidence) & np.isfinite(mu).all(axis=1)
        here = self._at(mu, self._mu[i])
        at, rivals = here & ok, ~here & ok
        if not at.any() or not rivals.any():
            return None
        j = int(np.flatnonzero(rivals)[np.argmax(evidence[rivals])])
        gap = float(evidence[at].max() - evidence[j])
        if gap >= self.config.search_rival_nats:
            return None
        away = float(np.hypot(*(mu[j, :2] - self._mu[i, :2])))
        return (t, int(self._ids[i]), gap, away)

    def _frame_model(self, turn_rate: float) -> FrameModel:
        """The frame model of a frame taken while turning at ``turn_rate`` (rad/s): the
        bearing variance grows by ``(turn_rate * turn_noise_s)^2`` (both components' with a
        sharp core, ``core_share``)."""
        extra = (turn_rate * self.config.turn_noise_s) ** 2
        if extra == 0.0:
            return self._model
        m = self._model
        return replace(
            m,
            sigma2=m.sigma2 + extra,
            core_sigma2=m.core_sigma2 + extra if m.core_share > 0 else m.core_sigma2,
        )

    def _search(self, t: float) -> int:
        """Search the recent frames for new hypotheses; returns how many were added."""
        c = self.config
        frames = self._window.since(t - c.search_window_s)
        if sum(f.bearings.size for f in frames) < c.search_min_bearings:
            return 0
        # The shortest window ending now that holds enough bearings: stacking moves
        # bearings by the odometry's rotation only, so every frame more adds the error of
        # the travel left out (and sightings of one landmark that no longer merge).
        n = 0
        for k in range(len(frames) - 1, -1, -1):
            n += frames[k].bearings.size
            if n >= c.search_min_bearings:
                frames = frames[k:]
                break
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
            max_nodes=c.search_max_nodes,
            timeout_s=c.search_timeout_s,
            cov_inflation=c.candidate_cov_inflation,
        )
        if cands.n_bearings >= c.search_min_bearings:
            self.searches += 1
        if c.pair_search:
            pairs = pair_candidates(
                self.landmarks,
                self._window.since(t - c.search_window_s),
                self.sensor,
                min_hits=c.search_min_bearings,
                cov_inflation=c.candidate_cov_inflation,
            )
            if len(pairs):
                cands = Candidates(
                    np.concatenate([cands.poses, pairs.poses]),
                    np.concatenate([cands.covs, pairs.covs]),
                    cands.n_bearings,
                    cands.complete,
                )
        if len(cands) == 0:
            return 0
        poses = cands.poses[: c.max_candidates]
        covs = cands.covs[: c.max_candidates].copy()
        floor = np.array([c.candidate_min_sd_m, c.candidate_min_sd_m, c.candidate_min_sd_heading])
        covs[:, [0, 1, 2], [0, 1, 2]] = np.maximum(covs[:, [0, 1, 2], [0, 1, 2]], floor**2)
        # The replay starts at the oldest frame of the window whose prior masses are known.
        rframes = self._window.since(t - c.replay_s)
        hist = {h[0]: h for h in self._history}
        while rframes and rframes[0].t not in hist:
            rframes = rframes[1:]
        if not rframes:
            return 0
        mu, P, volume, to_end, fit_m, fit_n, mem_w = self._replay(poses, covs, rframes)
        if c.search_rival_nats > 0:
            self._rival = self._closest_rival(t, mu, to_end[:, 0])
        # A candidate is a part of elsewhere that has come to light: it may have left
        # elsewhere at any frame of the replay (elsewhere's mass then, which holds the chance
        # of a kidnapping, times its evidence from that frame on), not only at the first --
        # a candidate whose replay reaches back across a kidnapping must not be judged by
        # the frames from before it.
        entry = np.array(
            [hist[f.t][1] + hist[f.t][2] if f.t in hist else -math.inf for f in rframes]
        )
        logw = _logsumexp_rows(entry[None, :] + to_end) + volume - self._norm
        born = np.full(mu.shape[0], rframes[0].t)
        if c.entry_replay:
            state = (mu, P, fit_m, fit_n, mem_w, born)
            self._replay_entries(
                poses, covs, rframes, entry, to_end, volume, logw, state, t - c.search_window_s
            )
        ok = np.isfinite(logw) & np.isfinite(mu).all(axis=1) & np.isfinite(P).all(axis=(1, 2))
        ok &= self._inside(mu)
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            return 0
        idx = idx[np.argsort(-logw[idx], kind="stable")]
        light = logw < math.log(c.prune_weight)
        w0 = frames[0].t
        H0 = self.n_hypotheses
        found = np.zeros(H0, dtype=bool)
        # The tracked hypothesis each candidate is the same as (the first one), and which
        # candidates are the same as each other.
        dup_of = np.full(mu.shape[0], -1, dtype=np.int64)
        ja, ib = self._same_pairs(mu, P, self._mu, self._P)
        first, at = np.unique(ja, return_index=True)
        dup_of[first] = ib[at]
        ca, cb = self._same_pairs(mu, P, mu, P)
        # Candidate j's twins are twin[start[j]:start[j + 1]] (the pairs come ordered by a).
        other = ca != cb
        twin = cb[other].tolist()
        start = np.searchsorted(ca[other], np.arange(mu.shape[0] + 1)).tolist()
        accepted = [False] * mu.shape[0]
        added: list[int] = []
        for j in idx.tolist():
            # A candidate at a pose already tracked adds nothing: that hypothesis holds the
            # evidence of this place (over a longer time than the replay); a search on frames
            # it has not been confirmed by confirms it. A candidate at the pose of one added
            # by this search before it adds nothing either.
            dup = int(dup_of[j])
            if dup >= 0:
                found[dup] = True
                if w0 > self._conf_t[dup]:
                    self._conf[dup] += 1
                    self._conf_t[dup] = t
                continue
            if any(accepted[k] for k in twin[start[j] : start[j + 1]]):
                continue
            if light[j]:
                # Too light to be tracked -- but it was still looked for above: a search
                # that finds a tracked place again confirms it, whatever the weight the
                # replay gave the candidate.
                continue
            accepted[j] = True
            added.append(j)
        if added:
            new = np.asarray(added, dtype=np.int64)
            k = new.size
            self._mu = np.concatenate([self._mu, mu[new]])
            self._P = np.concatenate([self._P, P[new]])
            self._logw = np.concatenate([self._logw, logw[new]])
            self._ids = np.concatenate([self._ids, self._next_id + np.arange(k)])
            self._born = np.concatenate([self._born, born[new]])
            self._conf = np.concatenate([self._conf, np.ones(k, dtype=self._conf.dtype)])
            self._conf_t = np.concatenate([self._conf_t, np.full(k, t)])
            self._fit_m = np.concatenate([self._fit_m, fit_m[new]])
            self._fit_n = np.concatenate([self._fit_n, fit_n[new]])
            self._mem_w = np.concatenate([self._mem_w.reshape(-1, mem_w.shape[1]), mem_w[new]])
            self._next_id += k
        # Search theory: the search would have found the true place with probability
        # 1 - search_miss; the places it did not find -- elsewhere, and the hypotheses it did
        # not find again -- are that much less likely to hold the robot.
        if c.search_miss is None:
            return len(added)
        miss = math.log(c.search_miss)
        self._log_out += miss
        self._logw[:H0] = np.where(found, self._logw[:H0], self._logw[:H0] + miss)
        return len(added)

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
            finite numbers or more than :data:`MAX_FRAME_BEARINGS` of them. Nothing is
            changed then.
        """
        if isinstance(t, (bool, np.bool_)):
            raise InputError(f"frame time must be a number of seconds, got {t!r}")
        try:
            tf = float(t)
        except (TypeError, ValueError, OverflowError) as exc:
            raise InputError(f"frame time must be a number, got {shorten(t)}") from exc
        if not math.isfinite(tf):
            raise InputError(f"frame time must be finite, got {t!r}")
        if self._t is not None and tf < self._t:
            raise InputError(f"frames out of time order: t={tf!r} after a frame at t={self._t!r}")
        b = _float_array("frame bearings", bearings, scalar=True)
        if b.size > MAX_FRAME_BEARINGS:
            raise InputError(
                f"frame bearings: {b.size:,} in one frame, at most {MAX_FRAME_BEARINGS:,} (every "
                "hypothesis and each of elsewhere's particles weighs every bearing)"
            )
        b = np.asarray(wrap(b))
        if self._input_kind is None and not self._warned_no_odometry:
            log.warning("frame at t=%s before any odometry: the robot is taken to stand still", tf)
            self._warned_no_odometry = True
        c = self.config
        t_prev = self._t
        delta, Q, gap = self._motion_to(tf)
        self._t = tf
        if self._born_at_first_frame:  # (a prior told before the first frame)
            self._born[:] = tf
            self._born_at_first_frame = False
        reason_gap = ""
        if gap > c.max_odometry_gap_s and not self._after_gap:
            self._after_gap = True
            reason_gap = f"odometry gap of {gap:.1f} s: motion unknown, relocalizing"
            self._drop_all()
            self._window.clear()
            self._history.clear()
            delta, Q = np.zeros(3), np.zeros((3, 3))
            # Once: until odometry resumes the robot is taken to stand still (as before
            # the first row), so the frames after the gap can build up evidence again.
            self._hold = np.zeros(3)
        dt = 0.0 if t_prev is None else tf - t_prev
        if self._watch is not None:
            w_mu, w_P = move(self._watch[0], self._watch[1], delta, Q)
            self._watch = (w_mu, w_P)
        self._elsewhere.move(delta, Q)
        self._mem_rot += float(delta[2])
        if self.n_hypotheses:
            self._mu, self._P = move(self._mu, self._P, delta, Q)
            good = np.isfinite(self._mu).all(axis=1) & np.isfinite(self._P).all(axis=(1, 2))
            good &= self._inside(self._mu)
            if not good.all():
                self._keep(np.flatnonzero(good))
            # The prior chance of being carried off since the last frame.
            f = min(-math.expm1(-c.kidnap_rate * dt), 1.0 - 1e-12)
            if f > 0 and self.n_hypotheses:
                moved = math.log(f) + _logsumexp(self._logw)
                self._log_out = float(np.logaddexp(self._log_out, moved))
                self._logw = self._logw + math.log1p(-f)
        self._normalise()
        self._history.append((tf, self._log_out, self._norm))
        turn = float(delta[2]) / dt if dt > 0 else 0.0
        self._window.append(tf, b, delta, Q, turn)
        model = self._frame_model(turn)
        while self._history and self._history[0][0] < self._window[0].t:
            self._history.popleft()
        # The frame's evidence.
        mem = (tf, self._mem_b, self._mem_rot, self._mem_t)
        persist = c.clutter_persistence
        if self.n_hypotheses:
            mu0, P0 = self._mu, self._P
            self._mu, self._P, lr, explained, post = frame_update_clutter(
                self._mu, self._P, b, self._L, model, self._objects(*mem, self._mem_w)
            )
            if b.size:
                self._mem_w = persist * post
            best_lr = float(lr.max())
            self._logw = self._logw + c.evidence_weight * lr
            # (What the frame's posterior explains, for the kidnapping test below.)
            hyp_logw, hyp_explained = self._logw, explained
            decay = math.exp(-dt / c.fit_window_s)
            fit_m0 = self._fit_m * decay
            self._fit_m = fit_m0 + explained
            self._fit_n = self._fit_n * decay + b.size
            if c.split_clutter > 0.0 and b.size:
                self._split(mu0, P0, post, fit_m0, persist)
            inside = self._inside(self._mu)
            if not inside.all():
                self._keep(np.flatnonzero(inside))
        else:
            best_lr = -math.inf
            hyp_logw, hyp_explained = np.zeros(0), np.zeros(0)
            if b.size:
                self._mem_w = np.zeros((0, b.size))
        lr_else, post_else = log_ratios_clutter(
            self._elsewhere.poses,
            b,
            self._L,
            model,
            self._objects(*mem, self._elsewhere.memory),
        )
        if b.size:
            self._elsewhere.memory = persist * post_else
            self._mem_b, self._mem_rot, self._mem_t = b, 0.0, tf
        # Elsewhere explains a frame as well as its particles do (Bayes' rule); with
        # search_miss, at least as well as any hypothesis: a robot that is truly elsewhere
        # would explain its bearings like a true pose does, and only searches can rule such a
        # place out.
        pf = self._elsewhere.weigh(c.evidence_weight * lr_else)
        if c.search_miss is not None:
            pf = max(pf, c.evidence_weight * best_lr)
        # What the belief now explains of the frame, while a place is watched (kidnap_fit):
        # elsewhere's count is its particles' mean as weighed by the frame.
        mix = 0.0
        if self._localized_id is not None and c.kidnap_fit > 0 and b.size:
            else_explained = (
                float(np.exp(self._elsewhere.logw) @ (b.size - post_else.sum(axis=1)))
                if post_else.shape[0]
                else 0.0
            )
            mix = _posterior_explained(hyp_logw, hyp_explained, self._log_out + pf, else_explained)
        self._log_out += pf
        self._normalise()
        self._exclude()
        self._merge_and_prune()
        self._bearings_since_search += int(b.size)
        state, reason, best = self._decide(tf)
        # Searches run while the place is not localized by the full tests (a frame kept by
        # keep_probability is searched as it would have been without the hysteresis).
        if (
            (state is not TrackState.LOCALIZED or self._kept)
            and self._bearings_since_search
            and tf - self._last_search >= c.search_interval_s
            and self._search(tf)
        ):
            self._normalise()
            self._merge_and_prune()
            state, reason, best = self._decide(tf)
        if reason_gap:
            reason = reason_gap + "; " + reason
        kidnapped, note = self._watch_kidnapping(tf, state, b, model, mix)
        reason = note + reason
        if state is TrackState.LOCALIZED and best is not None:
            self._localized_id = int(self._ids[best])
            # A kept frame does not vouch for the place anew: the watch runs from the first
            # frame not localized by the full tests (the hysteresis does not lengthen it).
            if not self._kept:
                self._unvouched_t = None
            elif self._unvouched_t is None:
                self._unvouched_t = tf
            self._localized_run += 1
        else:
            self._localized_run = 0
            if self._unvouched_t is None:
                self._unvouched_t = tf
        if kidnapped:
            self._localized_t = None
        if state is TrackState.LOCALIZED:
            self._localized_t = tf
        est = self._estimate(tf, state, reason, kidnapped, best)
        if self._localized_id is None:
            self._watch = None
        elif c.kidnap_fit > 0 and est.localized and self._place_out is not None:
            # (The place as reported, in the sensor's frame the bearings are weighed in.)
            self._watch = (self._place_out[0][None], self._place_out[1][None])
        return est

    def _watch_kidnapping(
        self, tf: float, state: TrackState, b: FloatArray, model: FrameModel, mix: float
    ) -> tuple[bool, str]:
        """The kidnapping watch after frame ``tf`` (bearings ``b``, weighed by ``model``),
        whose decision is ``state``; ``mix`` is how many of the bearings the tracker's belief
        explains now. Returns whether the frame is flagged ``kidnapped`` and what the reason
        says of the watch first ("" when nothing)."""
        c = self.config
        kidnapped, note = False, ""
        # Kidnapping: the place we were localized at lost its mass (watched until kidnap_watch_s
        # after the estimates stopped calling it localized; a loss that began within the watch
        # is followed to its end) and did not win it back within kidnap_confirm_s.
        if (
            self._localized_id is not None
            and self._unvouched_t is not None
            and self._below_t is None
            and tf - self._unvouched_t > c.kidnap_watch_s
        ):
            self._localized_id = None
        if self._localized_id is None:
            return False, ""
        share = self._watched_share()
        if share >= c.kidnap_share:
            self._below_t = None
            return False, ""
        w_explained = self._watch_explained(b, model) if c.kidnap_fit > 0 else None
        if self._below_t is None:
            self._below_t = tf
            self._watch_m, self._watch_n, self._watch_mix = 0.0, 0, 0.0
        if w_explained is not None:
            self._watch_m += w_explained
            self._watch_n += int(b.size)
            self._watch_mix += mix
        below = tf - self._below_t
        since = f" (under {100 * c.kidnap_share:g} % for {below:.1f} s)" if below else ""
        # Still explained: as many of the bearings since the loss as kidnap_fit asks
        # (none seen yet counts as explained: nothing speaks against the place).
        fits = w_explained is not None and (self._watch_m >= c.kidnap_fit * self._watch_n)
        # ... or nothing explains them better: bearings that the tracker's belief
        # now (its hypotheses and elsewhere, weighed by the frames) does not take for
        # landmarks more often than the old place does (by KIDNAP_MARGIN) are
        # clutter, not the evidence of another place.
        clutter = (
            w_explained is not None and not fits and self._watch_mix < self._watch_m + KIDNAP_MARGIN
        )
        # (Localized now is localized at another place: this one holds under half.)
        if state is TrackState.LOCALIZED or (
            below >= c.kidnap_confirm_s and not fits and not clutter
        ):
            kidnapped = True
            self._localized_id = None
            self._below_t = None
            fit = ""
            if w_explained is not None and self._watch_n:
                fit = (
                    f", and explains {self._watch_m:.0f} of the {self._watch_n} "
                    f"bearings since (the places it holds now: {self._watch_mix:.0f})"
                )
            note = (
                f"the place it was localized at now holds {100 * share:.1f} % of the "
                f"mass{since}{fit}: kidnapped or lost; "
            )
        elif below >= c.kidnap_confirm_s:
            # The loss lasts, yet the place explains the bearings, or nothing else
            # does: not a kidnapping (yet). Watched until kidnap_watch_s after the
            # loss began.
            ended = below > c.kidnap_watch_s
            why = (
                f"explains {self._watch_m:.0f} of the {self._watch_n} bearings since, "
                f"and the places it holds now explain no more "
                f"({self._watch_mix:.0f}): clutter"
                if clutter
                else f"explains {self._watch_m:.0f} of the {self._watch_n} bearings since"
            )
            note = (
                f"the place it was localized at holds {100 * share:.1f} % of the "
                f"mass{since} but {why}: not taken for a kidnapping"
                f"{' (no longer watched)' if ended else ''}; "
            )
            if ended:
                self._localized_id = None
                self._below_t = None
        return kidnapped, note

    def _watch_explained(self, b: FloatArray, model: FrameModel) -> float | None:
        """How many of the bearings ``b`` the watched place, moved by the odometry alone
        since its last localized frame, explains (the frame kernel's expected count of
        bearings from landmarks, with its predicted covariance); None without a copy."""
        if self._watch is None or b.size == 0:
            return None if self._watch is None else 0.0
        _, _, _, explained, _ = frame_update_clutter(
            self._watch[0], self._watch[1], b, self._L, model, None
        )
        return float(explained[0])

    def _watched_share(self) -> float:
        """The mass of the place the tracker was localized at (0 when its hypotheses are
        gone)."""
        where = np.flatnonzero(self._ids == self._localized_id)
        if where.size == 0:
            return 0.0
        return float(np.exp(self._logw[self._place(int(where[0]))]).sum())

    def _place(self, i: int) -> NDArray[np.bool_]:
        """Which hypotheses are at the place of hypothesis ``i`` (within the tolerances, which
        are the robot's: with a mount, between the robot poses the sensor poses stand for)."""
        return self._at(self._mu, self._mu[i])

    def _at(self, mu: FloatArray, ref: FloatArray) -> NDArray[np.bool_]:
        """Which sensor poses ``mu`` (n, 3) lie at the place of the sensor pose ``ref``
        (within the tolerances, between the robot poses they stand for)."""
        c = self.config
        if self._mount is not None:
            mu, ref = self.sensor.robot_poses(mu), self.sensor.robot_poses(ref[None])[0]
        d = mu - ref
        dh = np.abs(np.asarray(wrap(d[:, 2])))
        return np.asarray(
            (np.hypot(d[:, 0], d[:, 1]) <= c.tolerance_m) & (dh <= c.tolerance_heading)
        )

    def _odom_now(self) -> FloatArray:
        """The window's dead-reckoned pose at its newest frame (zero before any frame)."""
        n = len(self._window)
        return np.array(self._window[n - 1].odom if n else np.zeros(3), dtype=float)

    def _place_estimate(self, i: int) -> tuple[FloatArray, FloatArray, float]:
        """Mean, covariance (moment matched, times ``covariance_inflation``) and mass of the
        place of hypothesis ``i``."""
        near = np.flatnonzero(self._place(i))
        w = np.exp(self._logw[near])
        mu, P = place_kernel(near, w, self._mu, self._P, i)
        if self.config.covariance_inflation != 1.0:
            P = P * self.config.covariance_inflation
        return mu, P, float(w.sum())

    def _landmarks_seen(self, t: float, mu: FloatArray, P: FloatArray) -> int:
        """How many distinct landmarks explain the bearings of the last
        ``landmarks_window_s`` seconds from the place ``mu`` (a sensor pose, covariance
        ``P``, at the newest frame; ``min_landmarks``): see :meth:`_named`."""
        frames = self._window.since(t - self.config.landmarks_window_s)
        named = self._named(mu, P, [f for f in frames if f.bearings.size])
        return int(np.unique(named[named >= 0]).size)

    def _named(self, mu: FloatArray, P: FloatArray, frames: list[WindowFrame]) -> NDArray[np.int64]:
        """The landmark (row of the map, -1 for none) that explains each bearing of
        ``frames`` (in their order) from the place ``mu`` (a sensor pose, covariance ``P``,
        at the newest frame): the place is carried back to each frame by the odometry, and
        each bearing is explained by the nearest landmark in view whose predicted bearing
        lies within the sensor's gate, widened by the place's heading variance."""
        n = sum(f.bearings.size for f in frames)
        none = np.full(n, -1, dtype=np.int64)
        if n == 0:
            return none
        # The place at each frame, and the landmarks in reach of the window's poses.
        poses = compose(mu, between(self._odom_now(), np.array([f.odom for f in frames])))
        sensor = self.sensor
        if sensor.max_range is None:
            idx = np.arange(self.landmarks.n)
        else:
            reach = sensor.max_range + float(
                np.max(np.hypot(poses[:, 0] - mu[0], poses[:, 1] - mu[1]))
            )
            idx = np.asarray(self.landmarks.kdtree.query_ball_point(mu[:2], reach), dtype=np.int64)
        if idx.size == 0:
            return none
        L = self._L[idx]
        view = sensor.visible(np.broadcast_to(L, (poses.shape[0], *L.shape)), poses)
        d = L[None, :, :] - poses[:, None, :2]
        pred = np.asarray(wrap(np.arctan2(d[..., 1], d[..., 0]) - poses[:, None, 2]))
        gate = math.sqrt(sensor.gate_chi2 * (sensor.noise**2 + max(float(P[2, 2]), 0.0)))
        fidx = np.repeat(np.arange(len(frames)), [f.bearings.size for f in frames])
        b = np.concatenate([f.bearings for f in frames])
        diff = np.abs(np.asarray(wrap(b[:, None] - pred[fidx])))
        diff[~view[fidx]] = np.inf
        j = np.argmin(diff, axis=1)
        return np.where(diff[np.arange(j.size), j] <= gate, idx[j], -1)

    def _misfit(self, t: float, mu: FloatArray, P: FloatArray, born: float) -> str | None:
        """Whether the frames since ``born`` (the frame since which the place is held: the
        first frame of the replay of the search that found it, or with ``entry_replay`` the
        frame its late entry was replayed from; at most the last ``model_check_s`` seconds),
        and the newest of them alone, fit the sensor model from the place ``mu`` (a sensor
        pose, covariance ``P``, at the newest frame; ``model_check``,
        :func:`~omniloc.track.modelcheck.misfit`): None if they do, else why not. A place
        held since before a kidnapping is checked on the frames from before it too, and
        held until they have left the window; the newest frame alone is what sees the jump
        at once (its bearings, unexplained, drown in the window's clutter rate)."""
        c = self.config
        if c.model_check is None:
            return None
        frames = self._window.since(max(t - c.model_check_s, born))
        for part in (frames, frames[-1:]) if len(frames) > 1 else (frames,):
            why = misfit(
                self.landmarks,
                self.sensor,
                mu,
                P,
                part,
                level=c.model_check,
                tolerance_m=c.tolerance_m,
                tolerance_heading=c.tolerance_heading,
            )
            if why is not None:
                return why
        return None

    def _unexplained(self, mu: FloatArray, P: FloatArray) -> int:
        """The newest frame's bearings if it holds ``keep_unexplained`` of them or more and
        the place ``mu`` (covariance ``P``) explains none of them (see :meth:`_named`); else
        0."""
        k = self.config.keep_unexplained
        if not k or not len(self._window):
            return 0
        newest = self._window[-1]
        if newest.bearings.size < k or (self._named(mu, P, [newest]) >= 0).any():
            return 0
        return int(newest.bearings.size)

    def _lead_since(self, t: float, i: int | None) -> float:
        """Since when the best place, that of hypothesis ``i``, has been the best, frame after
        frame, at the decision of frame ``t`` (None: no hypothesis leads). The last frame's
        best hypothesis, carried by the odometry since, must lie at this place (within the
        tolerances) for the count to go on: a place stays itself whatever becomes of its
        hypotheses (a merge may keep a search's new one), and another place that leads
        for one frame starts it again (``min_best_s``)."""
        if t != self._lead_t:
            self._lead_last, self._lead_t = self._lead_now, t
        if i is None:
            self._lead_now = None
            return t
        odom = self._odom_now()
        last = self._lead_last
        since = t
        if last is not None:
            carried = compose(last[0], between(last[1], odom))
            if self._at(carried[None], self._mu[i])[0]:
                since = last[2]
        self._lead_now = (self._mu[i].copy(), odom, since)
        return since

    def _decide(self, t: float) -> tuple[TrackState, str, int | None]:
        """(state, reason, index of the best hypothesis)."""
        c = self.config
        self._kept = False
        self._not_kept = False
        self._best_place = None
        out = math.exp(self._log_out)
        H = self.n_hypotheses
        if H == 0:
            if c.min_best_s:
                self._lead_since(t, None)
            return TrackState.LOST, "no hypothesis explains the recent bearings yet", None
        i = int(np.argmax(self._logw))
        place = self._place(i)
        lead = self._lead_since(t, i) if c.min_best_s else t
        mu_i, P, mass = self._place_estimate(i)
        p_tol = within_tolerance(
            self._robot(mu_i[None], P[None])[1][0], c.tolerance_m, c.tolerance_heading
        )
        p = mass * p_tol
        # (kept for the estimate of this frame: nothing moves the hypotheses in between)
        self._best_place = (i, mu_i, P, p)
        rivals = H - int(place.sum())
        if out >= c.lost_share:
            return (
                TrackState.LOST,
                f"no hypothesis explains the recent bearings ({100 * (1 - out):.2g} % of the "
                "mass on the hypotheses)",
                i,
            )
        age = t - float(self._born[place].min())
        fit = float(self._fit_m[i] / max(self._fit_n[i], 1e-9))
        conf = int(self._conf[place].max())
        # The searches asked of the place: a second one is there to rule out a look-alike,
        # and with min_confirmations_alone a place no rival contests asks fewer.
        needed = c.min_confirmations
        if c.min_confirmations_alone and not rivals:
            needed = c.min_confirmations_alone
        # The full tests: the probability first, then, in order, the first other test that
        # holds the place back says why.
        held: str | None = None
        if p >= c.localized_probability:
            if conf < needed:
                held = (
                    f"the best place was found by {conf} search{'es' if conf != 1 else ''} on "
                    f"separate frames, {needed} needed"
                    + (
                        f" with {rivals} rival{'s' if rivals != 1 else ''}"
                        if rivals and c.min_confirmations_alone
                        else ""
                    )
                    + f" (within tolerance with probability {p:.4f})"
                )
            elif fit < (max(c.fit_explained, TOLD_FIT) if math.isinf(age) else c.fit_explained):
                held = (
                    f"the best place explains only {100 * fit:.0f} % of the recent bearings "
                    f"(within tolerance with probability {p:.4f})"
                )
            elif age < c.min_age_s:
                held = (
                    f"the best place is new (tracked {age:.1f} s; within tolerance with "
                    f"probability {p:.4f})"
                )
            elif t - lead < c.min_best_s:
                held = (
                    f"the best place has led for {t - lead:.1f} s, {c.min_best_s:g} s needed "
                    f"(within tolerance with probability {p:.4f})"
                )
            elif (
                (r := self._rival) is not None
                and t - r[0] <= c.replay_s
                and bool(np.isin(r[1], self._ids[place]))
            ):
                held = (
                    f"the last search found a place {r[3]:.1f} m away that explains its "
                    f"frames within {r[2]:.1f} nats as well (at {r[0]:.1f} s; within "
                    f"tolerance with probability {p:.4f})"
                )
            elif (
                c.min_landmarks
                and math.isfinite(age)  # (a pose told surely is born at -inf: the user's word)
                and (n_lm := self._landmarks_seen(t, mu_i, P)) < c.min_landmarks
            ):
                held = (
                    f"the best place's bearings of the last {c.landmarks_window_s:g} s are "
                    f"explained by {n_lm} landmark{'s' if n_lm != 1 else ''}, "
                    f"{c.min_landmarks} needed (within tolerance with probability {p:.4f})"
                )
            elif misfit := self._misfit(t, mu_i, P, float(self._born[place].min())):
                held = f"{misfit} (within tolerance with probability {p:.4f})"
        full = p >= c.localized_probability and held is None
        keep = (
            c.keep_probability is not None
            and not full
            and mass >= c.localized_probability
            and p_tol >= c.keep_probability
            and self._localized_run >= c.keep_after
            and self._localized_id is not None
            and bool(np.isin(self._localized_id, self._ids[place]))
        )
        not_kept = ""
        if keep and (n_un := self._unexplained(mu_i, P)):
            keep, self._not_kept = False, True
            not_kept = f"not kept: the place explains none of the frame's {n_un} bearings; "
        if keep:
            self._kept = True
            return (
                TrackState.LOCALIZED,
                f"kept: the place holds {100 * mass:.2f} % of the mass and is within "
                f"tolerance with probability {p_tol:.4f} under its covariance (at least "
                f"{c.keep_probability:g} once localized here for {self._localized_run} frames; "
                f"{rivals} rival{'s' if rivals != 1 else ''}, {100 * out:.2g} % elsewhere)",
                i,
            )
        if held is not None:
            return TrackState.AMBIGUOUS, not_kept + held, i
        if full:
            return (
                TrackState.LOCALIZED,
                f"within tolerance with probability {p:.4f}, fit {fit:.2f} (the place holds "
                f"{100 * mass:.2f} % of the mass; {rivals} rival{'s' if rivals != 1 else ''}, "
                f"{100 * out:.2g} % elsewhere)",
                i,
            )
        if p_tol >= c.localized_probability:
            why = f"the best place holds {100 * mass:.1f} % of the mass"
        elif mass >= c.localized_probability:
            why = f"the pose is too uncertain (within tolerance with probability {p_tol:.3f})"
        else:
            why = (
                f"the best place holds {100 * mass:.1f} % of the mass and is within tolerance "
                f"with probability {p_tol:.3f}"
            )
        return (
            TrackState.AMBIGUOUS,
            f"{not_kept}{why} ({rivals} rival{'s' if rivals != 1 else ''}, {100 * out:.2g} % "
            "elsewhere)",
            i,
        )

    def _estimate(
        self, t: float, state: TrackState, reason: str, kidnapped: bool, best: int | None
    ) -> TrackEstimate:
        since = None if self._localized_t is None else max(t - self._localized_t, 0.0)
        self._place_out = None
        if best is None or self.n_hypotheses == 0:
            return TrackEstimate(
                t, TrackState.LOST, reason=reason, kidnapped=kidnapped, since_localized=since
            )
        order = np.argsort(-self._logw, kind="stable")[: self.config.max_reported]
        h_mu, h_P = self._robot(self._mu[order], self._P[order] * self.config.covariance_inflation)
        rows = h_mu.tolist()  # (tolist: the floats float() gives, at once)
        w = np.minimum(np.exp(self._logw[order]), 1.0)
        weights = w.tolist()
        # A frame the hysteresis refused because its place explains none of its bearings
        # reads the tables of a tracker still searching: the recent tables were fitted on
        # frames whose place is most often still right, and such a frame's is not (on
        # MRCLAM, the first frame after a kidnapping; its since_localized is still reported,
        # so a fit counts it among the recent frames -- a handful in a run).
        soon = is_recent(since, self.config.confidence_recent_s) and not self._not_kept
        h_table = self._tables["confidence_hypothesis"]
        if soon and self._tables["confidence_hypothesis_recent"] is not None:
            h_table = self._tables["confidence_hypothesis_recent"]
        h_conf = _interpolate(h_table, w)
        hyps = tuple(
            Hypothesis(Pose(*rows[j]), h_P[j], weights[j], h_conf[j]) for j in range(len(rows))
        )
        c = self.config
        cached, self._best_place = self._best_place, None
        if state is TrackState.LOST:
            return TrackEstimate(
                t, state, reason=reason, kidnapped=kidnapped, since_localized=since
            )
        mass: float | None = None
        if cached is not None and cached[0] == best:
            _, mu, P, prob = cached
        else:
            mu, P, mass = self._place_estimate(best)
        # (The place in the sensor's frame, for the kidnapping watch; reported as the robot's.)
        self._place_out = (mu, P)
        mu, P = (a[0] for a in self._robot(mu[None], P[None]))
        if mass is not None:
            prob = mass * within_tolerance(P, c.tolerance_m, c.tolerance_heading)
        # The model's probability that the pose is within tolerance (what _decide reads),
        # and what the configuration's table says such frames turned out to be (an ambiguous
        # frame soon after a localized one: the recent table, when there is one).
        p = min(max(prob, 0.0), 1.0) if math.isfinite(prob) else None
        if state is TrackState.LOCALIZED:
            table = self._tables["confidence_localized"]
        elif soon and self._tables["confidence_recent"] is not None:
            table = self._tables["confidence_recent"]
        else:
            table = self._tables["confidence_ambiguous"]
        return TrackEstimate(
            t,
            state,
            pose=Pose.from_array(mu),
            covariance=P,
            hypotheses=hyps,
            reason=reason,
            kidnapped=kidnapped,
            probability=p,
            confidence=None if p is None else _interpolate(table, np.array([p]))[0],
            since_localized=since,
        )
