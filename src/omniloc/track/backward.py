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

A sure frame is the forward pass's word, and the forward pass is sometimes sure of a wrong
place (a twin of the true one, or the old place after a kidnapping). Carried back, such a
place would add up to ``horizon_s`` of wrong frames before it. What gives it away is what the
forward pass does next: it gives the place up within seconds (its pose leaves where the
odometry carries the sure pose, it goes lost, or it flags a kidnapping) where a right sure
place is most often held. So only the sure frames whose place the forward pass holds for
``confirm_s`` seconds after them start the pass (:func:`kept_frames`); on MRCLAM's kidnapped
streams that took the wrong frames the pass added from 39 to 3, all heading near misses at
the right place. And the same test, applied to every ``localized`` frame of the forward
pass, finds most of its own wrong ones: such a frame is reported ``ambiguous`` after the
pass (:func:`hold`), unless the pass localizes it (docs/tracking.md, "Offline: a second pass
backward").

:func:`refine` runs :func:`hold`, :func:`backward_pass` and :func:`combine` in that order:
what :func:`~omniloc.track.track` with ``backward_s`` reports.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..angles import wrap
from ..errors import InputError
from ..io import finite_number
from ..maps import LandmarkMap
from ..pose import between, compose
from ..sensor import SensorModel
from .confidence import confidence_of
from .data import Frame, Odometry
from .motion import MotionModel, integrate
from .records import TrackEstimate, TrackState
from .tracker import Tracker, TrackerConfig

__all__ = [
    "CONFIRM_S",
    "PLACE_HEADING",
    "PLACE_M",
    "TOLD_SCALE",
    "backward_pass",
    "combine",
    "held_frames",
    "hold",
    "kept_frames",
    "refine",
    "reverse_recording",
    "since_reported",
    "sure_frames",
]

#: A sure frame starts the pass backward only if the forward pass holds its place this many
#: seconds after it (:func:`kept_frames`). On MRCLAM (the default evaluation's whole runs
#: and 100 + 100 streams) the forward pass gave each of its three wrong sure places up at
#: most 8.6 s after a sure frame at it; 5, 8 and 10 s left 10, 6 and 4 of the 44 wrong
#: frames the pass added without the test (the 4: heading near misses at the right place),
#: at a cost of 6, 10 and 10 % of its right ones (docs/tracking-notebook.md, "A sure place
#: the forward pass gives up").
CONFIRM_S = 10.0

#: The pass is told each sure pose with the forward pass's covariance times this factor.
#: The reported covariance is too small: on MRCLAM its 99 % region held the truth in about
#: 90 % of the localized frames, and 1.89 times the variance would have made it honest
#: (docs/tracking-notebook.md, "A scale on the reported covariance"). A pose told too sure
#: is carried back sure: robot 2's near miss, 0.3 m off with sds of 0.05-0.07 m, carried
#: back 20 s, was 157 of the 174 wrong frames the pass added to the five whole runs under the
#: tracker's seeds 0-4. Told twice the covariance it added 17, for two fifths fewer right
#: frames of its own (the whole runs wrong in at most 8 frames a seed, against 49); 1.4 and
#: 1.7 added 164 and 44 (docs/tracking-notebook.md, "The pass backward told the covariance
#: the forward pass has earned").
TOLD_SCALE = 2.0

#: The forward pass holds a place while its pose is within this distance (m) and heading
#: (rad) of the sure pose carried by the odometry: wider than the tolerance (a place kept
#: drifts by decimetres over seconds), narrower than MRCLAM's twins (1.5 m and more, or a
#: half turn).
PLACE_M = 1.0
PLACE_HEADING = math.radians(30.0)


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


def held_frames(
    estimates: Sequence[TrackEstimate],
    odometry: Odometry,
    *,
    motion: MotionModel | None = None,
    confirm_s: float = CONFIRM_S,
    among: np.ndarray | None = None,
) -> np.ndarray:
    """The frames whose place the forward pass holds for ``confirm_s`` seconds after them.

    A frame's pose is carried forward by the odometry; the forward pass holds the place
    while, frame after frame, its pose is within :data:`PLACE_M` and :data:`PLACE_HEADING`
    of it, it is not ``lost`` and it flags no kidnapping. A frame is held when that holds
    for every frame within ``confirm_s`` seconds after it (the recording may end sooner);
    else the forward pass gave the place up.

    Parameters
    ----------
    estimates : sequence of TrackEstimate
        The forward pass's estimates, one per frame, in time order.
    odometry : Odometry
        The recording's.
    motion : MotionModel, optional
        The forward pass's (the odometry's latency and scales).
    confirm_s : float
        Seconds (>= 0; 0: every frame with a pose is held).
    among : ndarray of bool, shape (n,), optional
        The frames to look at (default: every frame with a pose); the others are False.

    Returns
    -------
    ndarray of bool, shape (n,)

    Raises
    ------
    InputError
        ``confirm_s`` not a number of seconds >= 0, or ``among`` of another length.
    """
    motion = MotionModel() if motion is None else motion
    w = finite_number(confirm_s, "confirm_s")
    if w < 0.0:
        raise InputError(f"confirm_s must be seconds >= 0, got {confirm_s!r}")
    posed = np.array([e.pose is not None for e in estimates], dtype=bool)
    if among is not None:
        sel = np.asarray(among, dtype=bool)
        if sel.shape != posed.shape:
            raise InputError(
                f"among must hold one flag per estimate: shape {sel.shape} for {posed.size}"
            )
        posed &= sel
    held = posed.copy()
    if w == 0.0 or not posed.any():
        return held
    t = np.array([e.t for e in estimates])
    pose = np.array([e.pose.as_array() if e.pose is not None else [np.nan] * 3 for e in estimates])
    # A frame no place can be held through: lost, or flagged kidnapped.
    broken = np.array([e.pose is None or e.kidnapped for e in estimates], dtype=bool)
    # The odometry's pose at each frame (from the first frame looked at, to the last frame
    # any window reaches): one chain, so that each window is two array operations.
    end = np.searchsorted(t, t + w, side="right")  # (each frame's window: s + 1 .. end - 1)
    first = int(np.flatnonzero(posed)[0])
    last = int(end[np.flatnonzero(posed)].max())
    odo = np.zeros((last - first, 3))
    for k in range(first + 1, last):
        dt, v, om, vy = odometry.pieces(t[k - 1] - motion.delay_s, t[k] - motion.delay_s)
        odo[k - first] = compose(odo[k - 1 - first], integrate(dt, v, om, motion, vy=vy)[0])
    for s in np.flatnonzero(posed).tolist():
        win = slice(s + 1, int(end[s]))
        if win.start >= win.stop:
            continue  # (the recording ends: nothing gives the place up)
        if broken[win].any():
            held[s] = False
            continue
        rel = between(odo[s - first], odo[win.start - first : win.stop - first])
        carried = compose(pose[s], rel)
        d = np.hypot(*(pose[win, :2] - carried[:, :2]).T)
        dh = np.abs(wrap(pose[win, 2] - carried[:, 2]))
        held[s] = bool(((d <= PLACE_M) & (dh <= PLACE_HEADING)).all())
    return held


def kept_frames(
    estimates: Sequence[TrackEstimate],
    odometry: Odometry,
    *,
    motion: MotionModel | None = None,
    config: TrackerConfig | None = None,
    confirm_s: float = CONFIRM_S,
) -> np.ndarray:
    """The sure frames (:func:`sure_frames`) whose place the forward pass holds for
    ``confirm_s`` seconds after them (:func:`held_frames`): those that start the pass.

    Raises
    ------
    InputError
        ``confirm_s`` not a number of seconds >= 0.
    """
    sure = sure_frames(estimates, TrackerConfig() if config is None else config)
    return held_frames(estimates, odometry, motion=motion, confirm_s=confirm_s, among=sure)


def hold(
    forward: Sequence[TrackEstimate],
    odometry: Odometry,
    *,
    motion: MotionModel | None = None,
    config: TrackerConfig | None = None,
    confirm_s: float = CONFIRM_S,
) -> list[TrackEstimate]:
    """The forward pass's estimates, each ``localized`` one whose place the forward pass gives
    up within ``confirm_s`` seconds after it (:func:`held_frames`) reported ``ambiguous``.

    Offline, what the forward pass does next is known: a place it gives up within seconds
    was one it should not have been sure of (on MRCLAM most of its wrong localized frames,
    and the right ones just before a kidnapping). Such a frame keeps its pose, covariance,
    hypotheses and probability; its reason says why it is not localized, and its confidence
    is read from ``config``'s table for an ambiguous frame soon after a localized one
    (``confidence_recent``, or ``confidence_ambiguous`` without it; None without tables).

    Raises
    ------
    InputError
        ``confirm_s`` not a number of seconds >= 0.
    """
    config = TrackerConfig() if config is None else config
    localized = np.array([e.state is TrackState.LOCALIZED for e in forward], dtype=bool)
    held = held_frames(forward, odometry, motion=motion, confirm_s=confirm_s, among=localized)
    table = config.confidence_ambiguous
    if config.confidence_recent is not None:
        table = config.confidence_recent
    out = list(forward)
    for i in np.flatnonzero(localized & ~held).tolist():
        e = forward[i]
        p = e.probability
        out[i] = replace(
            e,
            state=TrackState.AMBIGUOUS,
            confidence=None if p is None or table is None else confidence_of(table, p),
            reason=f"the forward pass gives this place up within {float(confirm_s):g} s after "
            f"(localized when it came): {e.reason}",
        )
    return out


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
    confirm_s: float = CONFIRM_S,
    told_scale: float = TOLD_SCALE,
) -> list[TrackEstimate | None]:
    """The backward pass over the frames within ``horizon_s`` before a sure frame of the
    forward pass whose place it holds.

    Going backward from each sure frame of ``forward`` that :func:`kept_frames` keeps, a
    tracker on the reversed recording (:func:`reverse_recording`), fresh at the first such
    frame of a stretch, is told that frame's pose and covariance (times ``told_scale``),
    and takes the frames before it while they lie within ``horizon_s`` of the last one it
    passed; at every one it is told the forward pose again unless it is already localized
    within tolerance of it. A sure frame given up is passed like any other frame.

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
    confirm_s : float
        Seconds the forward pass must hold a sure frame's place for it to start the pass
        (:func:`kept_frames`; default :data:`CONFIRM_S`).
    told_scale : float
        The factor (>= 1) on the forward pass's covariance told (default
        :data:`TOLD_SCALE`; 1: the covariance as the forward pass reports it).

    Returns
    -------
    list
        Per frame, in time order, the backward pass's estimate (its time the frame's, its
        ``since_localized`` the seconds to the sure frame it was carried from) or None
        where it did not run.
    """
    if len(forward) != len(frames):
        raise InputError(
            f"forward must hold one estimate per frame: {len(forward)} for {len(frames)} frames"
        )
    h = finite_number(horizon_s, "horizon_s")
    if h < 0.0:
        raise InputError(f"horizon_s must be seconds >= 0, got {horizon_s!r}")
    scale = finite_number(told_scale, "told_scale")
    if scale < 1.0:
        raise InputError(f"told_scale must be a factor >= 1, got {told_scale!r}")
    motion = MotionModel() if motion is None else motion
    config = TrackerConfig() if config is None else config
    sure = kept_frames(forward, odometry, motion=motion, config=config, confirm_s=confirm_s)
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
            if not _tell(tracker, fe, scale):
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
        out[i] = replace(e, t=t, since_localized=last_sure - t)
        if sure[i] and not (e.state is TrackState.LOCALIZED and _near(e, fe, config)):
            _tell(tracker, fe, scale)
    return out


def _tell(tracker: Tracker, estimate: TrackEstimate, scale: float = 1.0) -> bool:
    """Tell ``tracker`` a sure estimate's pose and covariance (times ``scale``); False
    (nothing changed) when it refuses them -- a pose the forward pass carried outside the
    tracker's region."""
    if estimate.pose is None or estimate.covariance is None:
        return False
    try:
        tracker.set_pose(estimate.pose, estimate.covariance * scale)
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
    so (and the seconds to the sure frame it was carried from, its ``since_localized``), its
    ``kidnapped`` the forward pass's (the frame at which it noticed a kidnapping stays
    flagged) and its ``confidence`` read from ``config``'s table for such frames
    (``confidence_backward``; None without one: the forward pass's table for localized
    frames would overstate it, a place carried back being right less often)."""
    table = None if config is None else config.confidence_backward
    if len(forward) != len(backward):
        raise InputError(
            f"forward and backward must hold one estimate per frame: {len(forward)} and "
            f"{len(backward)}"
        )
    out: list[TrackEstimate] = []
    for f, b in zip(forward, backward, strict=True):
        if f.state is TrackState.LOCALIZED or b is None or b.state is not TrackState.LOCALIZED:
            out.append(f)
            continue
        ahead = (
            "" if b.since_localized is None else f", {b.since_localized:.1f} s before a sure frame"
        )
        out.append(
            replace(
                b,
                backward=True,
                kidnapped=f.kidnapped,  # (a kidnapping is the forward pass's to flag)
                confidence=None if b.probability is None else confidence_of(table, b.probability),
                reason=f"from the pass backward{ahead}: {b.reason}",
            )
        )
    return out


def refine(
    landmarks: LandmarkMap,
    odometry: Odometry,
    frames: Sequence[Frame],
    forward: Sequence[TrackEstimate],
    *,
    horizon_s: float,
    sensor: SensorModel | None = None,
    motion: MotionModel | None = None,
    config: TrackerConfig | None = None,
    confirm_s: float = CONFIRM_S,
    told_scale: float = TOLD_SCALE,
) -> list[TrackEstimate]:
    """The forward pass's estimates after the offline steps, what ``track(...,
    backward_s=horizon_s)`` reports: the places the forward pass gives up within
    ``confirm_s`` seconds not localized (:func:`hold`), then the pass backward over the
    frames within ``horizon_s`` before a sure frame (:func:`backward_pass`), the two
    combined (:func:`combine`), with ``since_localized`` counted on what is reported
    (:func:`since_reported`). A frame the forward pass localized is ``is`` the same
    estimate in the result unless it was given up.

    Parameters
    ----------
    landmarks, odometry, frames, forward, horizon_s, sensor, motion, config, confirm_s
        As :func:`hold` and :func:`backward_pass`.
    told_scale : float
        As :func:`backward_pass` (default :data:`TOLD_SCALE`).

    Raises
    ------
    InputError
        As :func:`hold` and :func:`backward_pass`.
    """
    held = hold(forward, odometry, motion=motion, config=config, confirm_s=confirm_s)
    behind = backward_pass(
        landmarks,
        odometry,
        frames,
        held,
        horizon_s=horizon_s,
        sensor=sensor,
        motion=motion,
        config=config,
        confirm_s=0.0,  # (hold left localized only the places the forward pass holds)
        told_scale=told_scale,
    )
    return since_reported(combine(held, behind, config), forward)


def since_reported(
    estimates: Sequence[TrackEstimate], forward: Sequence[TrackEstimate]
) -> list[TrackEstimate]:
    """The offline ``estimates`` with their ``since_localized`` counted on themselves: the
    seconds since the last frame they report ``localized``, at or before each one (0 when
    it is), None when there is none since the start or since the forward pass last started
    its count again (a kidnapping it flagged, an odometry gap: a frame it reports None for
    where the frame before had a count, or one it flagged).

    :func:`hold` leaves a place given up the forward pass's count (0: it was localized) and
    the pass backward gives its frames the seconds *to* their sure frame (which
    :func:`combine` puts in their reason); counted again, the field means what it does
    online. Nothing else changes: an estimate whose count is the same is returned as it is.

    Parameters
    ----------
    estimates : sequence of TrackEstimate
        The offline estimates (:func:`combine`'s), one per frame, in time order.
    forward : sequence of TrackEstimate
        The forward pass's, one per frame (its counts and flags say where a count starts
        again).

    Returns
    -------
    list of TrackEstimate

    Raises
    ------
    InputError
        ``estimates`` and ``forward`` of different lengths.
    """
    if len(estimates) != len(forward):
        raise InputError(
            f"estimates and forward must hold one estimate per frame: {len(estimates)} and "
            f"{len(forward)}"
        )
    out: list[TrackEstimate] = []
    last: float | None = None  # the time of the last frame reported localized
    counted = False  # whether the forward pass had a count at the frame before
    for e, f in zip(estimates, forward, strict=True):
        if f.kidnapped or (counted and f.since_localized is None):
            last = None  # (the forward pass starts its count again here)
        counted = f.since_localized is not None
        if e.state is TrackState.LOCALIZED:
            last = e.t
        since = None if last is None else max(e.t - last, 0.0)
        out.append(e if since == e.since_localized else replace(e, since_localized=since))
    return out
