"""A second pass backward in time, for a whole recording: :func:`backward_pass`.

Online, a frame can only be placed by what came before it: on MRCLAM the tracker is sure of
a place after minutes, and between its sure stretches it is often ambiguous. Offline, the
frames after are known too. Once the tracker is sure of a place, the odometry carries that
place backward as well as forward: the recording is replayed in reverse (each odometry row's
motion undone, the frames in reverse order, times negated) by a second
:class:`~omniloc.track.Tracker` told the sure pose (:meth:`~omniloc.track.Tracker.set_pose`),
and the frames before it that this pass holds ``localized`` are reported from it.

A reversed recording is an ordinary one to the tracker: every test it applies (the fit of
the bearings, the mass of the place, a kidnapping) applies backward as forward, and a place
that stops explaining the bearings is given up the same way.

Only the frames within ``horizon_s`` before a sure frame (localized with
``localized_probability``, not merely kept) are taken from the backward pass. The pose
carried back drifts with the odometry's biases, which the reported covariance does not
hold (docs/tracking.md, "What the data allow": its 50 % region holds the truth in about a
third of MRCLAM's localized frames), so the further from the sure frame, the likelier a pose
a few decimetres off that still says it is sure. On MRCLAM 20 s kept the wrong frames to
near misses in heading and 40 s did not (docs/tracking.md, "Offline: a second pass
backward"; docs/tracking-notebook.md, "A second pass backward in time").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..errors import InputError
from ..io import finite_number
from ..maps import LandmarkMap
from ..sensor import SensorModel
from .data import Frame, Odometry
from .motion import MotionModel
from .records import TrackEstimate, TrackState
from .tracker import Tracker, TrackerConfig

__all__ = ["backward_pass", "combine", "reverse_recording", "sure_frames"]


def reverse_recording(
    odometry: Odometry, frames: Sequence[Frame], delay_s: float = 0.0
) -> tuple[Odometry, list[Frame]]:
    """The recording played backward: times negated, frames in reverse order, each odometry
    row's motion undone.

    A row stamped ``t_i`` moves the robot over ``[t_i + delay_s, t_(i+1) + delay_s)``; played
    backward that piece starts at ``-(t_(i+1) + delay_s)`` with the velocities negated (the
    robot retraces the same path, facing the same way). The latency is taken into the times,
    so the reversed odometry has none: run it with ``delay_s`` 0. The last row, which holds
    from its time on, starts the reversed odometry at the last frame's (or its own) time.

    Parameters
    ----------
    odometry : Odometry
    frames : sequence of Frame
        In time order.
    delay_s : float
        The odometry's latency (:attr:`MotionModel.delay_s`).

    Returns
    -------
    odometry, frames
        The reversed recording, in (reversed) time order; a frame's ``truth`` is kept.

    Examples
    --------
    >>> import numpy as np
    >>> from omniloc.track import Frame, Odometry
    >>> odo = Odometry(np.array([0.0, 1.0]), np.array([0.5, 0.2]), np.array([0.0, 0.1]))
    >>> r_odo, r_frames = reverse_recording(odo, [Frame(0.5, [0.1]), Frame(2.0, [0.2])])
    >>> r_odo.t.tolist(), r_odo.v.tolist(), [f.t for f in r_frames]
    ([-2.0, -1.0], [-0.2, -0.5], [-2.0, -0.5])
    """
    if not math.isfinite(delay_s):
        raise InputError(f"delay_s must be finite, got {delay_s!r}")
    t = odometry.t + delay_s
    last = max(float(t[-1]), frames[-1].t if len(frames) else -math.inf)
    r_t = np.concatenate([[-last], -t[:0:-1]])
    if r_t.size > 1 and not r_t[0] < r_t[1]:
        # (Rows of equal times leave the later one holding: the first reversed row, for the
        # piece after the last row, must come strictly before the next.)
        r_t[0] = np.nextafter(r_t[1], -math.inf)
    r_vy = None if odometry.vy is None else -odometry.vy[::-1]
    r_odo = Odometry(r_t, -odometry.v[::-1], -odometry.w[::-1], r_vy)
    r_frames = [Frame(-f.t, f.bearings, f.truth) for f in reversed(frames)]
    return r_odo, r_frames


def sure_frames(estimates: Sequence[TrackEstimate], config: TrackerConfig) -> np.ndarray:
    """Which estimates are ``localized`` by the full test: within tolerance with at least
    ``config.localized_probability`` (not merely kept by ``keep_probability``)."""
    p_min = float(config.localized_probability)
    return np.array(
        [
            e.state is TrackState.LOCALIZED
            and e.probability is not None
            and e.probability >= p_min
            and e.pose is not None
            and e.covariance is not None
            for e in estimates
        ],
        dtype=bool,
    )


def _near(a: TrackEstimate, b: TrackEstimate, config: TrackerConfig) -> bool:
    """Both have a pose, within the tracker's tolerance of each other."""
    if a.pose is None or b.pose is None:
        return False
    d, dh = a.pose.distance_to(b.pose)
    return d <= config.tolerance_m and dh <= config.tolerance_heading


def backward_pass(
    landmarks: LandmarkMap,
    odometry: Odometry,
    frames: Sequence[Frame],
    forward: Sequence[TrackEstimate],
    *,
    horizon_s: float,
    sensor: SensorModel | None = None,
    motion: MotionModel | None = None,
    config: TrackerConfig | None = None,
) -> list[TrackEstimate | None]:
    """The backward pass over the frames within ``horizon_s`` before a sure frame of the
    forward pass.

    Going backward from each sure frame (:func:`sure_frames`) of ``forward``, a tracker on
    the reversed recording (:func:`reverse_recording`), fresh at the first sure frame of a
    stretch, is told that frame's pose and covariance, and takes the frames before it while
    they lie within ``horizon_s`` of the last sure frame it passed; at every sure frame it
    is told the forward pose again unless it is already localized within tolerance of it.

    Parameters
    ----------
    landmarks, odometry, frames
        The recording, as :func:`~omniloc.track.track` took it.
    forward : sequence of TrackEstimate
        The forward pass's estimates, one per frame.
    horizon_s : float
        Seconds (>= 0).
    sensor, motion, config
        The forward pass's.

    Returns
    -------
    list
        Per frame, in time order, the backward pass's estimate (its time the frame's) or
        None where it did not run.
    """
    if len(forward) != len(frames):
        raise InputError(
            f"forward must hold one estimate per frame: {len(forward)} for {len(frames)} frames"
        )
    h = finite_number(horizon_s, "horizon_s")
    if h < 0.0:
        raise InputError(f"horizon_s must be seconds >= 0, got {horizon_s!r}")
    motion = MotionModel() if motion is None else motion
    config = TrackerConfig() if config is None else config
    sure = sure_frames(forward, config)
    out: list[TrackEstimate | None] = [None] * len(frames)
    if not sure.any():
        return out
    r_odo, r_frames = reverse_recording(odometry, frames, motion.delay_s)
    r_motion = replace(motion, delay_s=0.0)
    n = len(frames)
    tracker: Tracker | None = None
    k = 0
    last_sure = math.inf
    for j, f in enumerate(r_frames):
        i = n - 1 - j
        t = frames[i].t
        if sure[i]:
            last_sure = t
        elif not last_sure - t <= h:
            tracker = None  # beyond the horizon: the stretch is over
            continue
        fe = forward[i]
        if tracker is None:
            tracker = Tracker(landmarks, sensor, r_motion, config)
            if not _tell(tracker, fe):
                tracker = None  # (a pose the tracker cannot be told: no stretch from it)
                continue
            # The odometry from the row that holds at this frame on.
            k = max(int(np.searchsorted(r_odo.t, f.t, side="right")) - 1, 0)
        k1 = int(np.searchsorted(r_odo.t, f.t, side="right"))
        if k1 > k:
            vy = None if r_odo.vy is None else r_odo.vy[k:k1]
            tracker.odometry(r_odo.t[k:k1], r_odo.v[k:k1], r_odo.w[k:k1], vy)
            k = k1
        e = tracker.frame(f.t, f.bearings)
        out[i] = replace(e, t=t)
        if sure[i] and not (e.state is TrackState.LOCALIZED and _near(e, fe, config)):
            _tell(tracker, fe)
    return out


def _tell(tracker: Tracker, estimate: TrackEstimate) -> bool:
    """Tell ``tracker`` a sure estimate's pose and covariance; False (nothing changed) when
    it refuses them -- a pose the forward pass carried outside the tracker's region."""
    if estimate.pose is None or estimate.covariance is None:
        return False
    try:
        tracker.set_pose(estimate.pose, estimate.covariance)
    except InputError:
        return False
    return True


def combine(
    forward: Sequence[TrackEstimate],
    backward: Sequence[TrackEstimate | None],
    config: TrackerConfig | None = None,
) -> list[TrackEstimate]:
    """Per frame: the forward estimate where it is ``localized`` or the backward pass did
    not localize the frame; else the backward pass's (``backward`` True), its reason saying
    so, its ``since_localized`` the seconds to the next sure forward frame and its
    ``kidnapped`` the forward pass's (the frame at which it noticed a kidnapping stays
    flagged)."""
    if len(forward) != len(backward):
        raise InputError(
            f"forward and backward must hold one estimate per frame: {len(forward)} and "
            f"{len(backward)}"
        )
    config = TrackerConfig() if config is None else config
    sure = sure_frames(forward, config)
    out: list[TrackEstimate] = []
    next_sure = math.inf
    ahead: list[float] = [math.inf] * len(forward)
    for i in range(len(forward) - 1, -1, -1):
        if sure[i]:
            next_sure = forward[i].t
        ahead[i] = next_sure - forward[i].t
    for i, (f, b) in enumerate(zip(forward, backward, strict=True)):
        if f.state is TrackState.LOCALIZED or b is None or b.state is not TrackState.LOCALIZED:
            out.append(f)
            continue
        out.append(
            replace(
                b,
                backward=True,
                kidnapped=f.kidnapped,  # (a kidnapping is the forward pass's to flag)
                since_localized=ahead[i],
                reason=f"from the pass backward, {ahead[i]:.1f} s before a sure frame: " + b.reason,
            )
        )
    return out
