"""Localization over time for a recording: :func:`track`.

The online :class:`~omniloc.track.Tracker` takes odometry and frames as they come;
:func:`track` feeds it a whole recording in time order -- before each frame, the odometry
rows up to the frame's time, and with a negative latency those whose motion starts by then
(:func:`rows_before`) -- and returns one :class:`~omniloc.track.TrackEstimate` per frame.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..io import finite_number
from ..maps import LandmarkMap, as_landmark_map
from ..pose import Pose
from ..sensor import SensorModel
from .backward import refine
from .data import Frame, Odometry
from .motion import MotionModel
from .records import TrackEstimate, TrackState
from .tracker import Tracker, TrackerConfig

__all__ = ["TrackRun", "rows_before", "track"]


def rows_before(
    odometry_t: NDArray[np.float64], frame_t: ArrayLike, delay_s: float
) -> NDArray[np.intp]:
    """How many odometry rows to feed a tracker before each frame, offline.

    The rows stamped up to the frame's time; with a negative ``delay_s`` (odometry stamped
    late: a row stamped ``t`` moves the robot from ``t + delay_s`` on) also those stamped
    later whose motion starts by the frame, ``t + delay_s <= frame time`` (the tracker
    refuses a row, fed after a frame, whose motion starts before that frame). With
    ``delay_s >= 0`` only the rows stamped up to the frame, as ever.

    Parameters
    ----------
    odometry_t : ndarray, shape (n,)
        The odometry's times, seconds, not decreasing.
    frame_t : array_like, shape (m,)
        The frames' times, seconds, not decreasing.
    delay_s : float
        The odometry's latency (:attr:`MotionModel.delay_s`), seconds.

    Returns
    -------
    ndarray of int, shape (m,)
        Per frame, the number of rows (from the first) fed before it.

    Examples
    --------
    >>> import numpy as np
    >>> rows_before(np.array([0.0, 0.1, 0.2, 0.3]), [0.1, 0.2], 0.05).tolist()
    [2, 3]
    >>> rows_before(np.array([0.0, 0.1, 0.2, 0.3]), [0.1, 0.2], -0.1).tolist()
    [3, 4]
    """
    ft = np.asarray(frame_t, dtype=np.float64)
    if delay_s < 0.0:
        # (The tracker's own sum, t + delay_s, so that no row is fed a frame too late.)
        return np.searchsorted(odometry_t + delay_s, ft, side="right")
    return np.searchsorted(odometry_t, ft, side="right")


@dataclass(frozen=True)
class TrackRun:
    """What :func:`track` produced.

    Attributes
    ----------
    estimates : tuple of TrackEstimate
        One per frame, in time order.
    searches : int
        Interpretation-tree searches the tracker ran.
    cpu_s : float
        Processor time spent, seconds (every thread's: the frame likelihood of many
        hypotheses runs on two).
    wall_s : float
        Elapsed time, seconds.
    backward : int
        Frames reported from the second pass backward in time (``track(...,
        backward_s=...)``; 0 without it).
    given_up : int
        With the pass backward, the frames the forward pass localized at a place it gave up
        within 10 s after, reported ``ambiguous`` unless the pass localized them
        (:func:`~omniloc.track.backward.hold`; 0 without it).
    """

    estimates: tuple[TrackEstimate, ...] = field(repr=False)
    searches: int = 0
    cpu_s: float = 0.0
    wall_s: float = 0.0
    backward: int = 0
    given_up: int = 0

    def __len__(self) -> int:
        return len(self.estimates)

    def share(self, state: TrackState | str) -> float:
        """Share of the frames in ``state`` (NaN without frames)."""
        if not self.estimates:
            return float("nan")
        st = TrackState(state)
        return sum(e.state is st for e in self.estimates) / len(self.estimates)


def track(
    landmarks: LandmarkMap | ArrayLike,
    odometry: Odometry,
    frames: Iterable[Frame],
    *,
    sensor: SensorModel | None = None,
    motion: MotionModel | None = None,
    config: TrackerConfig | None = None,
    progress: Callable[[int], None] | None = None,
    initial_pose: Pose | ArrayLike | None = None,
    initial_covariance: ArrayLike | None = None,
    backward_s: float | None = None,
) -> TrackRun:
    """Localize a robot over a whole recording.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
        The map, metres.
    odometry : Odometry
        Velocity odometry (``t, v, w``, and ``vy`` when it has a sideways part), in time
        order.
    frames : iterable of Frame
        Frames of bearings in time order (their ``truth``, if any, is not read); any
        iterable, a generator too (read once, into a list).
    sensor, motion, config
        See :class:`~omniloc.track.Tracker` (defaults: its defaults).
    progress : callable, optional
        Called with the number of frames done after each frame (for a progress bar).
    initial_pose, initial_covariance : optional
        Where the robot is at the first frame, ``(x, y, theta)`` and its 3 x 3 covariance
        (both or neither): :meth:`Tracker.set_pose` before the first frame. Without them the
        tracker localizes globally.
    backward_s : float, optional
        Offline only: a second pass backward in time (:mod:`omniloc.track.backward`) reports
        the frames within ``backward_s`` seconds before a sure ``localized`` frame that it
        holds ``localized``, where the forward pass did not; and a ``localized`` frame whose
        place the forward pass gives up within 10 s after it is reported ``ambiguous``
        (:func:`~omniloc.track.backward.hold`). None (the default): the forward pass alone,
        each frame placed by what came before it, as online.

    Returns
    -------
    TrackRun

    Raises
    ------
    InputError
        An item of ``frames`` that is not a :class:`Frame` or frames out of time order (the
        message names the frame), frames and odometry that share no time (two clocks), or
        what :meth:`Tracker.frame` refuses.

    Examples
    --------
    >>> import numpy as np, omniloc
    >>> from omniloc.sensor import SensorModel
    >>> from omniloc.track import Frame, Odometry, track
    >>> room = omniloc.demo_room()
    >>> truth = omniloc.Pose(5.6, 2.1, np.deg2rad(30))
    >>> z = omniloc.predict_bearings(room.xy, truth)
    >>> frames = [Frame(0.25 * k, z) for k in range(16)]
    >>> still = Odometry(0.25 * np.arange(16), np.zeros(16), np.zeros(16))
    >>> run = track(room, still, frames,
    ...             sensor=SensorModel(sigma=np.deg2rad(0.3)))
    >>> run.estimates[-1].state.value
    'localized'
    """
    lm = as_landmark_map(landmarks)
    if not isinstance(odometry, Odometry):
        raise InputError(f"odometry must be an Odometry, got {type(odometry).__name__}")
    frames = list(frames)  # (once: a generator read twice would be empty the second time)
    for i, f in enumerate(frames):
        if not isinstance(f, Frame):
            raise InputError(
                f"frames[{i}] must be a Frame (omniloc.track.Frame(t, bearings)), got "
                f"{type(f).__name__}"
            )
    times = np.array([f.t for f in frames], dtype=np.float64)
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise InputError(
            f"frames out of time order: frame {k} at t={float(times[k])!r} "
            f"after t={float(times[k - 1])!r}"
        )
    if times.size and not (times[0] <= odometry.t[-1] and odometry.t[0] <= times[-1]):
        # (Each file may be right on its own: two clocks, or seconds against nanoseconds.)
        f0, f1, o0, o1 = (float(v) for v in (times[0], times[-1], odometry.t[0], odometry.t[-1]))
        raise InputError(
            f"the frames (t = {f0:.12g} to {f1:.12g} s) and the odometry (t = {o0:.12g} to "
            f"{o1:.12g} s) share no time: are they stamped by one clock, in seconds?"
        )
    if backward_s is not None and finite_number(backward_s, "backward_s") < 0:
        raise InputError(f"backward_s must be seconds >= 0, got {backward_s!r}")
    if (initial_pose is None) != (initial_covariance is None):
        raise InputError("initial_pose and initial_covariance go together: give both or neither")
    tracker = Tracker(lm, sensor, motion, config)
    if initial_pose is not None and initial_covariance is not None:
        tracker.set_pose(initial_pose, initial_covariance)
    out: list[TrackEstimate] = []
    k = 0
    c0 = time.process_time()
    w0 = time.perf_counter()
    cuts = rows_before(odometry.t, times, tracker.motion.delay_s)
    for n, f in enumerate(frames, 1):
        k1 = int(cuts[n - 1])
        if k1 > k:
            vy = None if odometry.vy is None else odometry.vy[k:k1]
            tracker.odometry(odometry.t[k:k1], odometry.v[k:k1], odometry.w[k:k1], vy)
            k = k1
        out.append(tracker.frame(f.t, f.bearings))
        if progress is not None:
            progress(n)
    n_given = 0
    if backward_s is not None:
        forward = out
        out = refine(
            lm,
            odometry,
            frames,
            forward,
            horizon_s=backward_s,
            sensor=sensor,
            motion=motion,
            config=config,
        )
        n_given = sum(f.localized and o is not f for f, o in zip(forward, out, strict=True))
    n_back = sum(e.backward for e in out)
    return TrackRun(
        tuple(out),
        tracker.searches,
        time.process_time() - c0,
        time.perf_counter() - w0,
        n_back,
        n_given,
    )
