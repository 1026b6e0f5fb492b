"""The bearing sensor: noise, field of view, range limits, detection and clutter.

Every part of omniloc that needs to know what the sensor does reads it from one
:class:`SensorModel`: the search (its gates and the ranges it prunes by), the scoring of
interpretations (the likelihood of a frame), the tracker (the same likelihood over time) and
the simulation (what a robot at a pose would see). Each derived value -- the gate, the range
limits the search applies, the margins of "plainly visible", the clutter density -- is
computed here and only here.

The likelihood of a frame
-------------------------
For a pose and an assignment of the bearings to landmarks (or to clutter), the log-likelihood
ratio against "every bearing is clutter" is the standard one of multiple-hypothesis tracking
(Reid 1979; Bar-Shalom & Li 1995; Cox & Leonard 1994), summed over the frame:

* a matched bearing: ``ln p_detect - nu^2 / (2 S) - ln sqrt(2 pi S)``, where ``nu`` is the
  innovation (predicted - measured) and ``S`` its variance;
* an unmatched bearing: ``ln(clutter / W)``, the clutter density (expected spurious bearings
  per frame over the width ``W`` of the field of view, per radian);
* a landmark plainly visible from the pose but not observed: ``ln(1 - p_detect)``.

See :mod:`omniloc.search.scoring` for how interpretations are turned into a posterior.

Estimating the parameters from a recording
------------------------------------------
With ground truth (or the poses of a confident run): ``sigma`` is the robust spread of the
bearing residuals of matched landmarks (1.4826 x their median absolute deviation);
``p_detect`` is, over all frames, the number of landmark detections divided by the number of
landmarks plainly visible from the true pose (:meth:`SensorModel.plainly_visible`);
``clutter`` is the mean number of bearings per frame that match no landmark, and
``clutter_by_detections`` the same mean over the frames that report 1, 2, ... landmarks
(:func:`clutter_by_detections` from the per-frame counts).
The values for the recordings in ``shared/data`` are in
:data:`omniloc.evaluate.DATASET_DEFAULTS`.

Clutter that comes with the landmarks
-------------------------------------
The standard model takes the clutter count to be Poisson with one rate, whatever the frame
detects. Where the clutter is objects seen by the same detector as the landmarks it is not:
on MRCLAM set 6 a frame that reports one tube shows 0.30 other robots on average, two tubes
0.06, three 0.40, four to seven 0.89-1.09 (the camera sees well, or the robots stand among
the tubes). Scored with one rate (0.28), a frame with four tubes and two robots pays for its
robots as if they were unlikely, and interpretations that explain a robot as a tube win: the
best solution's confidence was overconfident wherever it was low (expected calibration
error 0.071 on the frames with four or more tubes; 0.035 with the rate by detections,
``docs/evaluation.md``). With ``clutter_by_detections`` an interpretation that matches
``n`` of the ``m`` bearings takes its ``m - n`` clutter bearings as Poisson with the rate
of frames that report ``n`` landmarks: its log-likelihood changes by
``(m - n) ln(rate_n / rate) - (rate_n - rate)`` (:meth:`SensorModel.clutter_count_term`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import chdtri, gammaincinv, ndtri

from .angles import TWO_PI, wrap
from .errors import InputError
from .io import finite_number, real_array, shorten
from .pose import MIN_SIGMA, Pose, _poses, compose, compose_jacobians, inverse

__all__ = [
    "CLUTTER_ENTRY_FRAMES",
    "DEFAULT_THRESHOLD",
    "IMPLAUSIBLE_NOISE",
    "MAX_RANGE",
    "RANGE_SLACK",
    "SensorModel",
    "chi2_quantile",
    "clutter_by_detections",
]

FloatArray = NDArray[np.float64]

#: The paper's fixed gate (rule ii) when no noise level is given: 1 degree.
DEFAULT_THRESHOLD = float(np.deg2rad(1.0))

#: Relative slack of the range limits as the search applies them: a hypothesis's pose is an
#: estimate, and a landmark 19.9 m away must not fall out of a 20 m range by 0.2 m of error.
RANGE_SLACK = 0.05

#: "Plainly visible" (negative evidence): this far inside the range limits ...
VISIBLE_RANGE_MARGIN = 0.05
#: ... and this many noise standard deviations inside the field of view, and twice that away
#: from every reported bearing (a landmark right behind a reported one may be hidden by it).
VISIBLE_NOISE_MARGIN = 3.0

#: A bearing noise or gate wider than this (radians, 10 degrees) is almost surely a mistake
#: (degrees typed for radians): the gate then accepts nearly every pairing and the search
#: has nothing to prune with. It is refused unless ``allow_wide=True``.
IMPLAUSIBLE_NOISE = float(np.deg2rad(10.0))

#: The largest range limit accepted, metres: ten times the largest coordinate of a map
#: (omit ``max_range`` for a sensor without one).
MAX_RANGE = 1e10


def _number(name: str, value: Any, *, lo: float = 0.0, allow_zero: bool = False) -> float:
    """A finite float >= ``lo`` (> ``lo`` unless ``allow_zero``), or a clear error."""
    v = finite_number(value, name)
    if v < lo or (v == lo and not allow_zero):
        rel = ">=" if allow_zero else ">"
        raise InputError(f"{name} must be a finite number {rel} {lo:g}, got {value!r}")
    return v


#: At most this many entries in ``clutter_by_detections`` (a frame of more detections takes
#: the last).
MAX_CLUTTER_ENTRIES = 1000


def _rates(name: str, value: Any) -> tuple[float, ...]:
    """A non-empty sequence of finite numbers >= 0, as a tuple, or a clear error."""
    ordered = isinstance(value, Sequence) and not isinstance(value, (str, bytes))
    if not (ordered or (isinstance(value, np.ndarray) and value.ndim == 1)):
        # (A set or a dict has no order to index by; a 0-d or 2-D array is no list.)
        raise InputError(
            f"{name} must be a sequence of expected clutter counts (one per number of "
            f"landmarks detected, from 1), got {type(value).__name__}"
        )
    if not 1 <= len(value) <= MAX_CLUTTER_ENTRIES:
        raise InputError(f"{name} must hold 1 to {MAX_CLUTTER_ENTRIES} entries, got {len(value)}")
    return tuple(_number(f"{name}[{i}]", v, allow_zero=True) for i, v in enumerate(list(value)))


#: The farthest a sensor may sit from the robot's origin, metres (a mount beyond it is a
#: mistake: a pose, or millimetres).
MAX_MOUNT_M = 100.0


def _mount(value: Any) -> tuple[float, float, float] | None:
    """``(x, y, yaw)`` of a sensor on the robot, as a tuple of floats (None for the origin),
    or a clear error."""
    ordered = isinstance(value, Sequence) and not isinstance(value, (str, bytes))
    if not (ordered or (isinstance(value, np.ndarray) and value.ndim == 1)) or len(value) != 3:
        raise InputError(
            "mount must be the sensor's (x, y, yaw) on the robot: three numbers (metres, "
            f"metres, radians), got {shorten(value)}"
        )
    x, y, yaw = (finite_number(v, f"mount[{i}]") for i, v in enumerate(list(value)))
    for name, v in (("x", x), ("y", y)):
        if abs(v) > MAX_MOUNT_M:
            raise InputError(
                f"mount {name}={v:.4g} m puts the sensor more than {MAX_MOUNT_M:g} m from the "
                "robot's origin: the mount is in metres in the robot's frame"
            )
    if abs(yaw) > math.pi + 1e-9:
        raise InputError(
            f"mount yaw={yaw:.4g} rad is more than half a turn: angles are in radians (did "
            "you pass degrees?)"
        )
    if x == 0.0 and y == 0.0 and yaw == 0.0:
        return None
    return (x, y, yaw if -math.pi <= yaw < math.pi else float(wrap(yaw)))


#: :func:`clutter_by_detections` has an entry for a count of landmarks only while at least
#: this many frames report that many or more.
CLUTTER_ENTRY_FRAMES = 30


def clutter_by_detections(detected: ArrayLike, spurious: ArrayLike) -> tuple[float, ...]:
    """The ``clutter_by_detections`` of a recording: the mean number of spurious bearings of
    the frames that report 1, 2, ... landmarks, up to the largest count that at least
    :data:`CLUTTER_ENTRY_FRAMES` frames reach, the last entry pooling every frame with that
    many or more (a count no frame reports takes the mean over all frames).

    Parameters
    ----------
    detected, spurious : array_like of int, shape (F,)
        Per frame, the landmarks it reported and its bearings that are no landmark (from
        ground truth). Frames that report no landmark count in the overall mean only.

    Examples
    --------
    >>> clutter_by_detections([1] * 40 + [2] * 40 + [3] * 10, [0] * 40 + [1] * 40 + [2] * 10)
    (0.0, 1.2)
    """
    counts = []
    for name, values in (("detected", detected), ("spurious", spurious)):
        a = real_array(values, name, InputError)
        if a.ndim != 1:
            raise InputError(f"{name} must hold one count per frame (1-D), got shape {a.shape}")
        if not (np.isfinite(a).all() and (a >= 0).all() and (a == np.round(a)).all()):
            raise InputError(f"{name} must hold counts (whole numbers >= 0), one per frame")
        if a.size and a.max() > 1e9:
            raise InputError(f"{name} holds a count above 1e9: not a frame's")
        counts.append(a)
    d, k = counts[0].astype(np.int64), counts[1]
    if d.size == 0 or d.shape != k.shape:
        raise InputError(
            f"clutter_by_detections needs one count of each per frame, got {d.size} and {k.size}"
        )
    mean = float(k.mean())
    last = 1
    while (d >= last + 1).sum() >= CLUTTER_ENTRY_FRAMES:
        last += 1
    out = []
    for n in range(1, last + 1):
        sel = d >= n if n == last else d == n
        out.append(float(k[sel].mean()) if sel.any() else mean)
    return tuple(out)


def _probability(name: str, value: Any) -> float:
    v = _number(name, value, allow_zero=True)
    if not 0.0 < v < 1.0:
        raise InputError(f"{name} must lie strictly between 0 and 1, got {value!r}")
    return v


def chi2_quantile(q: float, dof: float) -> float:
    """The chi-square quantile: the value a chi-square variable of ``dof`` degrees of freedom
    stays below with probability ``q`` -- ``scipy.stats.chi2.ppf(q, dof)`` bit for bit (its
    own formula, ``2 gammaincinv(dof / 2, q)``), without importing ``scipy.stats`` (a second
    at every start of the command line).

    Examples
    --------
    >>> round(chi2_quantile(0.99, 3), 4)
    11.3449
    """
    return float(2.0 * gammaincinv(0.5 * dof, q))


@functools.lru_cache(maxsize=64)
def _joint_gates(confidence: float, m: int) -> FloatArray:
    """By number of matched pairs n = 0..m: the chi-square quantile with n - 3 dof."""
    dof = np.arange(m + 1) - 3.0
    with np.errstate(invalid="ignore"):
        joint = np.where(dof > 0, chdtri(np.maximum(dof, 1.0), 1.0 - confidence), np.inf)
    joint.setflags(write=False)
    return np.asarray(joint)


@dataclass(frozen=True)
class SensorModel:
    """What a bearing sensor measures and how well: the model every estimate relies on.

    Parameters
    ----------
    sigma : float, optional
        Standard deviation of the bearing noise, radians. When given, the search gates with a
        chi-square test on each innovation (its variance includes the pose's uncertainty).
        When omitted, the search gates with the paper's fixed ``threshold`` and likelihoods
        use ``threshold / 3``.
    threshold : float, default 1 degree
        The paper's rule (ii): the largest accepted ``|predicted - measured|``, radians. Used
        only when ``sigma`` is None.
    gate_confidence : float, default 0.999
        Confidence of the chi-square gates (each bearing, and the joint test of a complete
        interpretation). A true bearing falls outside its gate with probability ``1 -
        gate_confidence``, and an interpretation that loses one is not found (unless a
        wildcard is left for it): 0.999 keeps the true interpretation of 8 bearings in about
        99.5 % of frames (0.99: 96-98 %) at a modest cost in time.
    fov : float, optional
        Full field of view, radians (None or 2 pi: omnidirectional), centred on forward.
    max_range, min_range : float, optional
        Range limits of detection, metres.
    p_detect : float, optional
        Probability that a landmark plainly visible from the pose is detected. None: the
        sensor says nothing about landmarks it did not report (no negative evidence), and a
        matched bearing is scored as if ``p_detect`` were :attr:`DETECT_UNKNOWN`.
    clutter : float, optional
        Expected number of spurious bearings per frame (things not on the map), spread
        uniformly over the field of view. None: the search's ``max_spurious`` is taken as the
        expected count, with at least :attr:`CLUTTER_UNKNOWN`.
    clutter_by_detections : sequence of float, optional
        Expected spurious bearings per frame given how many landmarks the frame reports:
        entry ``i`` for ``i + 1`` landmarks, the last for that many or more (see *Clutter
        that comes with the landmarks* in the module's documentation). The scoring of
        interpretations uses it (the search's own buffer of paths and a first fit's stop
        test rank by ``clutter``); the null interpretation (no landmark) keeps ``clutter``,
        and so does the tracker, whose frame likelihood sums over the landmarks each
        bearing may be without counting them (it logs a warning that it does). None: one
        rate for every frame.
    mount : sequence of 3 floats, optional
        Where the sensor sits on the robot: ``(x, y, yaw)`` of the sensor's frame in the
        robot's (metres forward and to the left of the robot's origin, radians of turn from
        its forward axis; ROS's static transform ``base_link -> camera_link``). Bearings are
        measured from the sensor; poses given to and returned by omniloc are the robot's:
        :func:`~omniloc.localize` returns robot poses and covariances, and the tracker takes
        the robot's odometry and reports the robot's pose (:meth:`sensor_poses`,
        :meth:`robot_poses`). None (the default) or ``(0, 0, 0)``: the sensor is at the
        robot's origin, facing forward (stored as None).
    allow_wide : bool, default False
        Accept a ``sigma`` or ``threshold`` above :data:`IMPLAUSIBLE_NOISE` (10 degrees, up
        to pi). A search with such a gate has nearly nothing to prune with: without a budget
        it gets a default one (see :func:`omniloc.localize`).

    Raises
    ------
    InputError
        A value that is not a finite number in its range (the message names it), ``min_range
        >= max_range``, or an implausibly wide noise without ``allow_wide``.

    Examples
    --------
    >>> s = SensorModel(sigma=np.deg2rad(0.5), fov=np.deg2rad(65), max_range=8.0)
    >>> round(float(np.rad2deg(s.gate_width)), 3)
    1.645
    >>> s.half_fov is not None, s.reach_max
    (True, 8.4)
    """

    sigma: float | None = None
    threshold: float = DEFAULT_THRESHOLD
    gate_confidence: float = 0.999
    fov: float | None = None
    max_range: float | None = None
    min_range: float | None = None
    p_detect: float | None = None
    clutter: float | None = None
    clutter_by_detections: tuple[float, ...] | None = None
    mount: tuple[float, float, float] | None = None
    allow_wide: bool = field(default=False, repr=False)

    #: p_detect assumed for the likelihood of a match when the sensor does not say.
    DETECT_UNKNOWN = 0.15
    #: Expected clutter per frame assumed when neither ``clutter`` nor a spurious count says.
    CLUTTER_UNKNOWN = 0.5

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if self.sigma is not None:
            set_(self, "sigma", _number("sigma", self.sigma))
        set_(self, "threshold", _number("threshold", self.threshold, allow_zero=True))
        set_(self, "gate_confidence", _probability("gate_confidence", self.gate_confidence))
        if self.fov is not None:
            fov = _number("fov", self.fov)
            if fov > TWO_PI + 1e-9:
                raise InputError(f"fov is a full angle in radians, at most 2*pi, got {fov}")
            if fov < MIN_SIGMA:
                raise InputError(f"fov={fov:.3g} rad sees nothing (at least {MIN_SIGMA:g} rad)")
            set_(self, "fov", min(fov, TWO_PI))
        for key in ("max_range", "min_range"):
            r = getattr(self, key)
            if r is not None:
                r = _number(key, r, allow_zero=key == "min_range")
                if r > MAX_RANGE:
                    raise InputError(
                        f"{key}={r:.3g} m is beyond any map (at most {MAX_RANGE:.0e} m); "
                        "omit it for a sensor without a range limit"
                    )
                set_(self, key, r)
        if (
            self.max_range is not None
            and self.min_range is not None
            and self.min_range >= self.max_range
        ):
            raise InputError(
                f"min_range ({self.min_range}) must be smaller than max_range ({self.max_range})"
            )
        if self.p_detect is not None:
            set_(self, "p_detect", _probability("p_detect", self.p_detect))
        if self.clutter is not None:
            set_(self, "clutter", _number("clutter", self.clutter, allow_zero=True))
        if self.clutter_by_detections is not None:
            set_(
                self,
                "clutter_by_detections",
                _rates("clutter_by_detections", self.clutter_by_detections),
            )
        if self.mount is not None:
            set_(self, "mount", _mount(self.mount))
        if not isinstance(self.allow_wide, (bool, np.bool_)):
            raise InputError(f"allow_wide must be True or False, got {self.allow_wide!r}")
        name = "sigma" if self.sigma is not None else "threshold"
        wide = self.sigma if self.sigma is not None else self.threshold
        if wide < MIN_SIGMA:
            raise InputError(
                f"{name}={wide:.3g} rad is narrower than float64 bearings can be told apart "
                f"(at least {MIN_SIGMA:g} rad)"
            )
        if wide > math.pi:
            raise InputError(
                f"{name}={wide:.4g} rad ({math.degrees(wide):.4g} deg) is more than half a turn: "
                "angles are in radians (did you pass degrees?)"
            )
        if wide > IMPLAUSIBLE_NOISE and not self.allow_wide:
            raise InputError(
                f"{name}={wide:.4g} rad ({math.degrees(wide):.4g} deg) is implausibly wide for a "
                "bearing sensor (above 10 deg): angles are in radians (did you pass degrees?); "
                "pass allow_wide=True if you mean it (the search then gets a default budget)"
            )

    # ---- construction ------------------------------------------------------------------------
    @classmethod
    def from_options(
        cls,
        *,
        sigma: float | None = None,
        threshold: float = DEFAULT_THRESHOLD,
        confidence: float = 0.999,
        fov: float | None = None,
        max_range: float | None = None,
        min_range: float | None = None,
        p_miss: float | None = None,
        p_detect: float | None = None,
        clutter: float | None = None,
        clutter_by_detections: Any = None,
        mount: Any = None,
        allow_wide: bool = False,
    ) -> SensorModel:
        """A model from :func:`~omniloc.localize`'s keyword arguments (``p_miss`` is
        ``1 - p_detect``; ``confidence`` the gate's)."""
        if p_miss is not None:
            if p_detect is not None:
                raise InputError("give p_miss or p_detect, not both (p_miss = 1 - p_detect)")
            p_detect = 1.0 - _probability("p_miss", p_miss)
            if p_detect >= 1.0:
                raise InputError(
                    f"p_miss={p_miss!r} is too small to tell from 0 in floating point; pass "
                    "p_miss=None (no negative evidence) or at least 1e-16"
                )
        if not 0.0 < finite_number(confidence, "confidence") < 1.0:
            raise InputError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
        return cls(
            sigma=sigma,
            threshold=threshold,
            gate_confidence=float(confidence),
            fov=fov,
            max_range=max_range,
            min_range=min_range,
            p_detect=p_detect,
            clutter=clutter,
            clutter_by_detections=clutter_by_detections,
            mount=mount,
            allow_wide=allow_wide,
        )

    def replace(self, **changes: Any) -> SensorModel:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    # ---- where the sensor sits on the robot --------------------------------------------------
    def sensor_poses(self, robot_poses: Pose | ArrayLike) -> FloatArray:
        """The sensor's poses when the robot is at ``robot_poses`` (shape (3,) or (n, 3)):
        ``compose(robot, mount)``; a copy of them without a mount."""
        p = _poses(robot_poses, "robot_poses")
        return p.copy() if self.mount is None else compose(p, np.asarray(self.mount))

    @overload
    def robot_poses(self, sensor_poses: Pose | ArrayLike) -> FloatArray: ...

    @overload
    def robot_poses(
        self, sensor_poses: Pose | ArrayLike, covariances: ArrayLike
    ) -> tuple[FloatArray, FloatArray]: ...

    def robot_poses(
        self, sensor_poses: Pose | ArrayLike, covariances: ArrayLike | None = None
    ) -> FloatArray | tuple[FloatArray, FloatArray]:
        """The robot's poses when the sensor is at ``sensor_poses`` (shape (3,) or (n, 3)):
        ``compose(sensor, inverse(mount))``; copies without a mount.

        With ``covariances`` (shape (3, 3) or (n, 3, 3), of the sensor's poses) returns
        ``(poses, covariances)``, the covariances carried to the robot's frame to first
        order (``J C J^T``, ``J`` the Jacobian of the composition): a sensor ahead of the
        robot's origin passes its heading's uncertainty to the robot's position.

        Examples
        --------
        >>> s = SensorModel(mount=(0.2, 0.0, 0.0))
        >>> s.robot_poses([1.0, 0.0, np.pi / 2]).round(6).tolist()
        [1.0, -0.2, 1.570796]
        """
        p = _poses(sensor_poses, "sensor_poses")
        back = None if self.mount is None else inverse(np.asarray(self.mount))
        out = p.copy() if back is None else compose(p, back)
        if covariances is None:
            return out
        C = real_array(covariances, "covariances", InputError)
        if C.shape != (*p.shape[:-1], 3, 3):
            raise InputError(
                f"covariances must have shape {(*p.shape[:-1], 3, 3)} for sensor_poses of "
                f"shape {p.shape}, got {C.shape}"
            )
        if not np.isfinite(C).all():
            raise InputError("covariances must be finite (no NaN or inf)")
        if back is None:
            return out, C.copy()
        J = compose_jacobians(p, back)[0]
        return out, J @ C @ np.swapaxes(J, -1, -2)

    # ---- noise and gates ---------------------------------------------------------------------
    @property
    def noise(self) -> float:
        """Bearing noise standard deviation used for likelihoods and covariances, radians:
        ``sigma``, or ``threshold / 3`` when only a threshold is known."""
        return self.sigma if self.sigma is not None else self.threshold / 3.0

    @property
    def p_miss(self) -> float | None:
        """``1 - p_detect`` (None when the detection probability is not known)."""
        return None if self.p_detect is None else 1.0 - self.p_detect

    @property
    def gate_chi2(self) -> float:
        """The one-degree-of-freedom chi-square gate at :attr:`gate_confidence`."""
        return float(ndtri(0.5 + 0.5 * self.gate_confidence) ** 2)

    def joint_chi2(self, m: int) -> FloatArray:
        """By number of matched pairs n = 0..m, the joint test's chi-square quantile with
        n - 3 degrees of freedom (inf for n <= 3: three pairs always fit exactly)."""
        return _joint_gates(self.gate_confidence, int(m))

    @property
    def gate_width(self) -> float:
        """Half-width of a bearing's gate when the pose is known exactly, radians."""
        if self.sigma is None:
            return self.threshold
        return math.sqrt(self.gate_chi2) * self.sigma

    # ---- visibility --------------------------------------------------------------------------
    @property
    def half_fov(self) -> float | None:
        """Half the field of view, radians; None for an omnidirectional sensor."""
        if self.fov is None or self.fov >= TWO_PI - 1e-9:
            return None
        return 0.5 * self.fov

    @property
    def fov_width(self) -> float:
        """Width of the field of view, radians (2 pi when omnidirectional)."""
        half = self.half_fov
        return TWO_PI if half is None else 2.0 * half

    @property
    def reach_max(self) -> float | None:
        """``max_range`` as the search applies it: RANGE_SLACK wider."""
        return None if self.max_range is None else self.max_range * (1.0 + RANGE_SLACK)

    @property
    def reach_min(self) -> float | None:
        """``min_range`` as the search applies it: RANGE_SLACK narrower."""
        return None if self.min_range is None else self.min_range / (1.0 + RANGE_SLACK)

    @property
    def plain_max(self) -> float | None:
        """Farthest a landmark can be and still count as plainly visible, metres."""
        return None if self.max_range is None else (1.0 - VISIBLE_RANGE_MARGIN) * self.max_range

    @property
    def plain_min(self) -> float | None:
        """Nearest a landmark can be and still count as plainly visible, metres."""
        return None if self.min_range is None else (1.0 + VISIBLE_RANGE_MARGIN) * self.min_range

    @property
    def plain_margin(self) -> float:
        """Angular margin of "plainly visible": this far inside the field of view, twice
        this away from every reported bearing, radians."""
        return VISIBLE_NOISE_MARGIN * self.noise

    @property
    def limits_visibility(self) -> bool:
        """Whether the sensor's range or field of view limits what it can see."""
        return self.max_range is not None or self.min_range is not None or self.half_fov is not None

    def visible(self, landmarks_xy: ArrayLike, pose: Pose | ArrayLike) -> NDArray[np.bool_]:
        """Which landmarks lie within the range limits and the field of view of a pose.

        Parameters
        ----------
        landmarks_xy : array_like, shape (N, 2) or (K, N, 2)
            Landmark positions, metres (one set, or one per pose).
        pose : Pose or array_like, shape (3,) or (K, 3)
            ``(x, y, theta)`` of the sensor (with a ``mount``, :meth:`sensor_poses` of the
            robot's).

        Returns
        -------
        ndarray of bool, shape (N,) or (K, N)
            A landmark at the pose's own position is never visible.
        """
        return self._within(*_landmarks_pose(landmarks_xy, pose), 0.0, 0.0, ())

    def plainly_visible(
        self, landmarks_xy: ArrayLike, pose: Pose | ArrayLike, bearings: ArrayLike = ()
    ) -> NDArray[np.bool_]:
        """Which landmarks the sensor should plainly see from a pose: inside the range limits
        by :data:`VISIBLE_RANGE_MARGIN`, inside the field of view by :attr:`plain_margin`,
        and more than twice that away from every reported bearing (not hidden behind one).

        These are the landmarks whose absence is evidence against the pose (negative
        evidence), and what ``p_detect`` is the detection rate of. Shapes and the sensor's pose as
        :meth:`visible`; ``bearings`` (radians) are the frame's reported bearings.
        """
        L, p = _landmarks_pose(landmarks_xy, pose)
        b = np.asarray(bearings, dtype=np.float64).reshape(-1)
        return self._within(L, p, VISIBLE_RANGE_MARGIN, self.plain_margin, b)

    def _within(
        self, L: FloatArray, p: FloatArray, range_margin: float, angle_margin: float, b: ArrayLike
    ) -> NDArray[np.bool_]:
        d = L - p[..., None, :2]
        r2 = d[..., 0] ** 2 + d[..., 1] ** 2
        ok = r2 > 1e-18
        if self.max_range is not None:
            ok &= r2 <= ((1.0 - range_margin) * self.max_range) ** 2
        if self.min_range is not None:
            ok &= r2 >= ((1.0 + range_margin) * self.min_range) ** 2
        half = self.half_fov
        bb = np.asarray(b, dtype=np.float64)
        if half is not None or bb.size:
            pred = np.asarray(wrap(np.arctan2(d[..., 1], d[..., 0]) - p[..., None, 2]))
            if half is not None:
                ok &= np.abs(pred) <= half - angle_margin
            if bb.size:
                sep = np.abs(np.asarray(wrap(pred[..., None] - bb)))
                ok &= sep.min(axis=-1) > 2.0 * angle_margin
        return np.asarray(ok)

    # ---- the likelihood of a frame -----------------------------------------------------------
    def clutter_rate(self, max_spurious: int = 0) -> float:
        """Expected spurious bearings per frame: :attr:`clutter`, or when it is not given the
        number the caller allows for (``max_spurious``), at least CLUTTER_UNKNOWN."""
        if self.clutter is not None:
            return self.clutter
        return max(float(max_spurious), self.CLUTTER_UNKNOWN)

    def log_clutter_density(self, max_spurious: int = 0) -> float:
        """ln of the clutter density per radian: an unmatched bearing's log-likelihood."""
        rate = self.clutter_rate(max_spurious)
        return math.log(max(rate, 1e-300) / self.fov_width)

    def clutter_count_term(self, m: int, nmatch: ArrayLike, max_spurious: int = 0) -> FloatArray:
        """What ``clutter_by_detections`` changes in the log-likelihood of interpretations
        that match ``nmatch`` of ``m`` bearings: their ``m - n`` clutter bearings Poisson
        with the rate of frames that report ``n`` landmarks instead of
        :meth:`clutter_rate`, ``(m - n) ln(rate_n / rate) - (rate_n - rate)``. Zeros without
        the table, and for ``n = 0`` (the null interpretation keeps the one rate)."""
        n = np.asarray(nmatch, dtype=np.int64)
        table = self.clutter_by_detections
        if table is None:
            return np.zeros(n.shape)
        base = max(self.clutter_rate(max_spurious), 1e-300)
        rates = np.maximum(np.asarray((base, *table), dtype=np.float64), 1e-300)
        rate_n = rates[np.clip(n, 0, len(table))]
        return np.asarray((int(m) - n) * np.log(rate_n / base) - (rate_n - base))

    @property
    def log_detect(self) -> float:
        """``ln p_detect`` (of :attr:`DETECT_UNKNOWN` when unknown)."""
        return math.log(self.DETECT_UNKNOWN if self.p_detect is None else self.p_detect)

    @property
    def log_miss(self) -> float:
        """``ln(1 - p_detect)``: a plainly visible landmark not observed (0 when unknown:
        then nothing is inferred from what the sensor did not report)."""
        return 0.0 if self.p_detect is None else math.log1p(-self.p_detect)

    def match_log_likelihood(self, innovation: ArrayLike, variance: ArrayLike) -> FloatArray:
        """``ln p_detect - nu^2 / (2 S) - ln sqrt(2 pi S)`` for innovations ``nu`` with
        variances ``S`` (rad^2): a matched bearing's log-likelihood."""
        nu = np.asarray(innovation, dtype=np.float64)
        S = np.asarray(variance, dtype=np.float64)
        return np.asarray(self.log_detect - 0.5 * nu * nu / S - 0.5 * np.log(TWO_PI * S))


def _landmarks_pose(
    landmarks_xy: ArrayLike, pose: Pose | ArrayLike
) -> tuple[FloatArray, FloatArray]:
    try:
        L = np.asarray(landmarks_xy, dtype=np.float64)
        p = pose.as_array() if isinstance(pose, Pose) else np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"landmarks_xy and pose must be numeric arrays: {exc}") from exc
    if L.ndim not in (2, 3) or L.shape[-1] != 2:
        raise InputError(f"landmarks_xy must have shape (N, 2) or (K, N, 2), got {L.shape}")
    if p.shape[-1:] != (3,) or p.ndim != L.ndim - 1:
        raise InputError(f"pose must have shape (3,) (or (K, 3) with (K, N, 2)), got {p.shape}")
    if not (np.isfinite(L).all() and np.isfinite(p).all()):
        raise InputError("landmarks_xy and pose must be finite")
    return L, p
