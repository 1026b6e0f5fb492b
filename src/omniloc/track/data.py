"""Recordings over time: odometry, frames of bearings, ground-truth tracks; their files.

File formats (CSV, a header line, ``#`` comments and blank lines allowed; every error names
the file and the line):

odometry
    ``t,v,w``: time (s), forward velocity (m/s), turn rate (rad/s), and optionally ``vy``,
    a sideways velocity (m/s). Each row holds until the next (as recorded by MRCLAM's
    robots). Times must not decrease; of rows with equal times
    (a logger's duplicates) the last one holds. Or a pose track in the odometry's own frame,
    as ROS's ``nav_msgs/Odometry`` holds it: ``t,x,y,theta`` (metres, radians), or a TUM
    file (``t x y z qx qy qz qw``, what ``evo_traj ... --save_as_tum`` writes of a bag's
    odometry); each interval becomes the velocities and turn rate that carry one pose to the
    next (:meth:`Odometry.from_poses`).
frames
    Either the generic ``t,bearing`` (one row per bearing, radians, or degrees with
    ``degrees=True`` or a ``bearing_deg`` column; rows with equal ``t`` form one frame; a row
    whose bearing is empty is a frame in which nothing was seen, which tells the tracker as
    much as one with bearings), or the ``robotR_frames.csv`` files of MRCLAM as
    they are (the ``landmarks`` and ``robot_detections`` columns, ``id:bearing:range;...``;
    the ids are dropped: every detection, robots included, is a bearing of the frame).
ground truth
    ``t,x,y,theta[,gap]``: the true pose (metres, radians) at times t; ``gap`` (s) is the
    interval between the measurements around the sample (large gaps: unreliable).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..angles import wrap
from ..errors import InputError
from ..io import (
    PathLike,
    _looks_numeric,
    check_radians,
    content_lines,
    first_content_line,
    parse_float,
    read_text,
    shorten,
    split_csv_line,
)
from ..pose import Pose
from .motion import between as motion_between
from .motion import twist_of

log = logging.getLogger(__name__)

__all__ = [
    "Frame",
    "GroundTruth",
    "Odometry",
    "load_frames",
    "load_groundtruth",
    "load_odometry",
]

FloatArray = NDArray[np.float64]


def _float_array(name: str, values: object, *, scalar: bool = False) -> FloatArray:
    """A read-only 1-D copy of finite floats, or an InputError naming ``name`` and the first
    bad entry; with ``scalar`` a single number is taken as one row."""
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"{name} must be an array of real numbers: {exc}") from exc
    if scalar:
        a = np.atleast_1d(a)
    if a.ndim != 1:
        raise InputError(f"{name} must have shape (n,), got {a.shape}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise InputError(f"{name}[{int(bad[0])}] is not finite: {a[bad[0]]!r}")
    a = a.copy()
    a.setflags(write=False)
    return a


def _check_times(
    what: str, t: FloatArray, *, strict: bool = True, lines: list[int] | None = None
) -> None:
    """Times must increase (strictly, or not decrease); ``lines`` names file lines."""
    d = np.diff(t)
    bad = np.flatnonzero(d <= 0 if strict else d < 0)
    if bad.size:
        k = int(bad[0]) + 1
        order = "increase strictly" if strict else "not decrease"
        at = f"{what}:{lines[k]}" if lines is not None else f"{what} row {k}"
        raise InputError(f"{at}: times must {order} (t={float(t[k])!r} after {float(t[k - 1])!r})")


#: Above these a file's times are probably not seconds (a warning, not an error): a time
#: beyond 1e11 s (3,000 years; milliseconds since 1970 are 1.7e12, a ROS stamp in
#: nanoseconds 1.7e18) or a median interval beyond 1e4 s (nearly three hours between rows).
TIME_WARN = 1e11
INTERVAL_WARN = 1e4


def _warn_time_unit(src: str, t: FloatArray) -> None:
    """Log a warning when the times ``t`` of file ``src`` do not look like seconds."""
    if t.size == 0:
        return
    big = float(np.max(np.abs(t)))
    distinct = np.unique(t)  # (a frame's bearings share one time)
    step = float(np.median(np.diff(distinct))) if distinct.size > 1 else 0.0
    if big > TIME_WARN or step > INTERVAL_WARN:
        log.warning(
            "%s: times up to %.3g s, a median of %.3g s apart: are they in nanoseconds (a ROS "
            "stamp), microseconds or milliseconds? omniloc reads seconds",
            src,
            big,
            step,
        )


def _moved_in_no_time(t: FloatArray, poses: FloatArray) -> int | None:
    """The first ``k`` whose poses ``k`` and ``k + 1`` (n, 3) share a time but differ (the
    heading compared wrapped), or None."""
    same = np.flatnonzero(t[1:] == t[:-1])
    if same.size == 0:
        return None
    d = motion_between(poses[same], poses[same + 1])
    moved = same[np.any(d != 0.0, axis=1)]
    return int(moved[0]) if moved.size else None


@dataclass(frozen=True)
class Odometry:
    """Recorded odometry: forward velocity and turn rate, each holding until the next row.

    Parameters
    ----------
    t : array_like, shape (n,)
        Times, seconds, not decreasing (of equal times the last row holds).
    v : array_like, shape (n,)
        Forward velocity, m/s.
    w : array_like, shape (n,)
        Turn rate, rad/s (counter-clockwise positive).
    vy : array_like, shape (n,), optional
        Sideways velocity, m/s (to the left); None: none, as for a wheeled robot's own
        frame. A frame mounted off the robot's centre (a sensor's) moves sideways as the
        robot turns: :meth:`from_poses` keeps that part.
    """

    t: FloatArray
    v: FloatArray
    w: FloatArray
    vy: FloatArray | None = None

    def __post_init__(self) -> None:
        t = _float_array("odometry t", self.t)
        v = _float_array("odometry v", self.v)
        w = _float_array("odometry w", self.w)
        vy = None if self.vy is None else _float_array("odometry vy", self.vy)
        if not (t.shape == v.shape == w.shape) or (vy is not None and vy.shape != t.shape):
            raise InputError(
                f"odometry t, v, w{' and vy' if vy is not None else ''} must have one value "
                f"per row: got {t.size}, {v.size}, {w.size}"
                + (f", {vy.size}" if vy is not None else "")
            )
        if t.size == 0:
            raise InputError("odometry has no rows")
        _check_times("odometry", t, strict=False)
        # Rows with equal times (a logger's duplicates): the last one holds from then on.
        last = np.concatenate([t[1:] > t[:-1], [True]])
        if not last.all():
            t, v, w = t[last], v[last], w[last]
            vy = None if vy is None else vy[last]
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "v", v)
        object.__setattr__(self, "w", w)
        object.__setattr__(self, "vy", vy)

    def __len__(self) -> int:
        return int(self.t.size)

    @classmethod
    def from_poses(cls, t: ArrayLike, x: ArrayLike, y: ArrayLike, theta: ArrayLike) -> Odometry:
        """Odometry from a pose track: the odometry's own estimate of the pose (m, m, rad) at
        times ``t``, in its own frame (ROS's ``nav_msgs/Odometry``; only the motion between
        poses is read, never where the frame is).

        Each interval becomes the constant velocities (forward, sideways) and turn rate that
        carry one pose to the next (the SE(2) logarithm of the motion between them, divided
        by the interval); after the last pose the robot is taken to stand still. The
        sideways part is kept: a wheeled robot's own frame has none, but the frame of a
        sensor mounted off its centre (whose poses make the bearings' geometry exact) moves
        sideways as the robot turns. The poses must be close enough in time that the robot
        turns less than a half turn between two.

        Parameters
        ----------
        t : array_like, shape (n,)
            Times, seconds, not decreasing (rows at one time must hold one pose).
        x, y, theta : array_like, shape (n,)

        Raises
        ------
        InputError
            Values that are not finite numbers, arrays of different lengths, no rows, times
            that decrease, or two different poses at one time.

        Examples
        --------
        A quarter circle of radius 1 m driven in 2 s, then a stop:

        >>> import math
        >>> odo = Odometry.from_poses([0, 2], [0, 1], [0, 1], [0, math.pi / 2])
        >>> [round(float(v), 4) for v in odo.v], [round(float(w), 4) for w in odo.w]
        ([0.7854, 0.0], [0.7854, 0.0])
        >>> [round(abs(float(vy)), 4) for vy in odo.vy]
        [0.0, 0.0]
        """
        tt = _float_array("odometry poses t", t, scalar=True)
        cols = [
            _float_array(f"odometry poses {n}", a, scalar=True)
            for n, a in (("x", x), ("y", y), ("theta", theta))
        ]
        if not all(c.size == tt.size for c in cols):
            raise InputError(
                "odometry poses t, x, y and theta must have one value per row: got "
                + ", ".join(str(a.size) for a in (tt, *cols))
            )
        if tt.size == 0:
            raise InputError("odometry poses have no rows")
        _check_times("odometry poses", tt, strict=False)
        poses = np.stack(cols, axis=1)
        same = tt[1:] == tt[:-1]
        if same.any():
            k = _moved_in_no_time(tt, poses)
            if k is not None:
                raise InputError(
                    f"odometry poses rows {k} and {k + 1} are at one time (t={float(tt[k])!r}) but "
                    "differ: the robot cannot move in no time"
                )
            keep = np.concatenate([[True], ~same])
            tt, poses = tt[keep], poses[keep]
        if tt.size == 1:
            return cls(tt, np.zeros(1), np.zeros(1), np.zeros(1))
        dt = np.diff(tt)
        steps = motion_between(poses[:-1], poses[1:])
        wide = np.flatnonzero(np.abs(steps[:, 2]) > 0.75 * math.pi)
        if wide.size:
            # Between two poses a half turn apart, which way the robot turned is a guess.
            k = int(wide[0])
            log.warning(
                "odometry poses rows %d and %d (t=%r and %r) are %.0f deg apart in heading: "
                "the turn between them is taken the short way round; poses closer in time "
                "tell (%d such pairs)",
                k,
                k + 1,
                float(tt[k]),
                float(tt[k + 1]),
                math.degrees(abs(float(steps[k, 2]))),
                wide.size,
            )
        tw = twist_of(steps, 1.0) / dt[:, None]
        stop = np.zeros(1)
        return cls(
            tt,
            np.concatenate([tw[:, 0], stop]),
            np.concatenate([tw[:, 2], stop]),
            np.concatenate([tw[:, 1], stop]),
        )

    def between(self, t0: float, t1: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The constant-velocity pieces that cover ``[t0, t1]``: durations (s), v and w.

        Before the first row the robot is taken to stand still; the last row holds forever.
        (:meth:`pieces` gives the sideways velocity too.)
        """
        dt, v, w, _ = self.pieces(t0, t1)
        return dt, v, w

    def pieces(self, t0: float, t1: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """As :meth:`between`, with each piece's sideways velocity (zeros without ``vy``):
        durations (s), v, w and vy, for :func:`~omniloc.track.motion.integrate`."""
        if not t1 >= t0:
            raise InputError(f"odometry over [t0, t1] needs t1 >= t0, got {t0!r} and {t1!r}")
        lo = int(np.searchsorted(self.t, t0, side="right"))
        hi = int(np.searchsorted(self.t, t1, side="right"))
        # Breakpoints inside (t0, t1) and the value holding on each piece.
        cuts = np.concatenate([[t0], self.t[lo:hi], [t1]])
        idx = np.arange(lo - 1, hi)
        held = idx >= 0
        at = np.maximum(idx, 0)
        v = np.where(held, self.v[at], 0.0)
        w = np.where(held, self.w[at], 0.0)
        vy = np.zeros(idx.size) if self.vy is None else np.where(held, self.vy[at], 0.0)
        return np.diff(cuts), v, w, vy


@dataclass(frozen=True)
class Frame:
    """The bearings reported at one time (radians, robot frame, in no particular order).

    ``truth`` optionally holds, for evaluation only, the true landmark row of each bearing
    (None for clutter); a localizer never reads it.
    """

    t: float
    bearings: FloatArray
    truth: tuple[int | None, ...] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        t = float(self.t)
        if not math.isfinite(t):
            raise InputError(f"frame time must be finite, got {self.t!r}")
        b = _float_array("frame bearings", self.bearings)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "bearings", np.asarray(wrap(b), dtype=np.float64).reshape(-1))
        if self.truth is not None and len(self.truth) != b.size:
            raise InputError(
                f"frame truth must give one landmark per bearing: {len(self.truth)} for {b.size}"
            )


@dataclass(frozen=True)
class GroundTruth:
    """A true trajectory sampled in time; :meth:`at` interpolates it.

    Parameters
    ----------
    t, x, y, theta : array_like, shape (n,)
        Times (s, strictly increasing) and poses (m, rad).
    gap : array_like, shape (n,), optional
        Seconds between the measurements around each sample (0 when not known).
    """

    t: FloatArray
    x: FloatArray
    y: FloatArray
    theta: FloatArray
    gap: FloatArray | None = None

    def __post_init__(self) -> None:
        arrs = {
            k: _float_array(f"ground truth {k}", getattr(self, k)) for k in "t x y theta".split()
        }
        gap = (
            np.zeros_like(arrs["t"])
            if self.gap is None
            else _float_array("ground truth gap", self.gap)
        )
        if len({a.size for a in (*arrs.values(), gap)}) != 1:
            raise InputError("ground truth t, x, y, theta and gap must have one value per row")
        if arrs["t"].size < 2:
            raise InputError("ground truth needs at least 2 samples")
        _check_times("ground truth", arrs["t"])
        for k, a in arrs.items():
            object.__setattr__(self, k, a)
        object.__setattr__(self, "gap", gap)

    @property
    def span(self) -> tuple[float, float]:
        """First and last time, seconds."""
        return float(self.t[0]), float(self.t[-1])

    def at(self, t: float | FloatArray) -> tuple[FloatArray, FloatArray]:
        """Poses (k, 3) interpolated at times ``t`` (headings along the shorter arc) and the
        gap (k,) of the sample nearest each; NaN poses outside the track's span."""
        tq = np.atleast_1d(np.asarray(t, dtype=np.float64))
        th = np.unwrap(self.theta)
        out = np.stack(
            [
                np.interp(tq, self.t, self.x),
                np.interp(tq, self.t, self.y),
                np.asarray(wrap(np.interp(tq, self.t, th))),
            ],
            axis=1,
        )
        outside = (tq < self.t[0]) | (tq > self.t[-1])
        out[outside] = np.nan
        k = np.clip(np.searchsorted(self.t, tq), 0, self.t.size - 1)
        gap = self.gap if self.gap is not None else np.zeros_like(self.t)
        return out, np.asarray(gap[k])

    def pose_at(self, t: float) -> Pose:
        """The interpolated pose at one time (an error outside the track's span)."""
        p, _ = self.at(t)
        if not np.isfinite(p).all():
            lo, hi = self.span
            raise InputError(f"t={t!r} is outside the ground truth's span [{lo}, {hi}]")
        return Pose.from_array(p[0])


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def _table(path: PathLike, what: str) -> tuple[str, list[str], list[tuple[int, list[str]]]]:
    """The header (lower case) and the data rows, with their line numbers, of a CSV file."""
    src = str(path)
    lines = content_lines(read_text(path, InputError))
    if not lines:
        raise InputError(f"{src}: empty {what} file")
    n0, head = lines[0]
    header = [
        h.lower()
        for h in split_csv_line(head, f"{src}:{n0} (header of the {what} file)", InputError)
    ]
    rows = []
    for n, line in lines[1:]:
        cells = split_csv_line(line, f"{src}:{n}", InputError)
        if len(cells) != len(header):
            raise InputError(
                f"{src}:{n}: expected {len(header)} fields ({shorten(','.join(header))}), "
                f"got {len(cells)}"
            )
        rows.append((n, cells))
    return src, header, rows


def _columns(
    src: str, header: list[str], rows: list[tuple[int, list[str]]], names: tuple[str, ...]
) -> list[FloatArray]:
    missing = [c for c in names if c not in header]
    if missing:
        raise InputError(
            f"{src}:1: missing column(s) {shorten(missing)}; the header is "
            f"{shorten(','.join(header))}"
        )
    out = []
    for c in names:
        k = header.index(c)
        out.append(np.array([parse_float(r[k], f"{src}:{n}", c, InputError) for n, r in rows]))
    return out


#: Above these an odometry file is probably in other units (a warning, not an error: some
#: platforms are that fast): a turn a second (rad/s; degrees per second read as radians
#: exceed it at 6 deg/s), and 10 m/s (mm/s or cm/s read as m/s exceed it at once).
ODOMETRY_W_WARN = 2.0 * math.pi
ODOMETRY_V_WARN = 10.0


#: Largest tilt (roll and pitch together, rad) of a TUM file's poses read as odometry or
#: ground truth: the heading of poses that lean a little (a 3-D odometry or motion capture
#: on a floor that is not quite level) is the robot's; beyond it the trajectory is not a
#: planar robot's.
TUM_MAX_TILT = math.radians(10.0)


def _is_tum(path: PathLike) -> bool:
    """Whether ``path`` reads as a TUM trajectory: its first line that is not blank or a
    comment is 8 numbers separated by blanks (the file is read only that far)."""
    line = first_content_line(path, InputError)
    if line is None:
        return False
    parts = line.split()
    return len(parts) == 8 and "," not in line and all(map(_looks_numeric, parts))


def _warn_odometry_units(
    src: str, lines: list[int], v: FloatArray, w: FloatArray, *, from_poses: bool = False
) -> None:
    """Log a warning naming the line (``lines[k]`` of row ``k``) of the fastest turn rate
    ``w`` above :data:`ODOMETRY_W_WARN` and of the fastest speed ``v`` above
    :data:`ODOMETRY_V_WARN`; ``from_poses``: the rates were derived from a pose track (each
    named by the line of the pose that ends its interval), whose units are asked after."""
    if from_poses:
        how = " from the pose before this one"
        units = (
            "are the headings in degrees? omniloc reads radians",
            "are the positions in mm or cm? omniloc reads metres",
        )
    else:
        how = ""
        units = (
            "is the file in degrees per second? omniloc reads rad/s",
            "is the file in mm/s or cm/s? omniloc reads m/s",
        )
    for values, limit, what, unit, question in (
        (w, ODOMETRY_W_WARN, "turn rate w", "rad/s", units[0]),
        (v, ODOMETRY_V_WARN, "speed v", "m/s", units[1]),
    ):
        k = int(np.argmax(np.abs(values)))
        if abs(values[k]) > limit:
            log.warning(
                "%s:%d: %s %g %s%s, more than %.3g %s: %s",
                src,
                lines[k],
                what,
                values[k],
                unit,
                how,
                limit,
                unit,
                question,
            )


def load_odometry(path: PathLike) -> Odometry:
    """Read an odometry file: velocities (``t,v,w``, and ``vy`` when there is a sideways
    part) or a pose track (``t,x,y,theta``, or a TUM file); see the module's documentation
    and :meth:`Odometry.from_poses`.

    A turn rate above :data:`ODOMETRY_W_WARN` (a turn a second) or a speed above
    :data:`ODOMETRY_V_WARN` (10 m/s) is logged as a warning naming the line: the file is
    probably in degrees per second or in mm/s, which are read as rad/s and m/s. Of a pose
    track the rates between poses are checked so, naming the line of the later pose: its
    headings in degrees, or positions in mm, are read as radians and metres.

    Raises
    ------
    InputError
        Unreadable file, missing columns, a value that is not a finite number, times that do
        not increase (file and line named).
    """
    if _is_tum(path):
        from .io import read_tum  # (io reads this module's records)

        try:
            a = read_tum(path, max_tilt=TUM_MAX_TILT)
            _check_times(str(path), a[:, 0], strict=False)
            _warn_time_unit(str(path), a[:, 0])
            return Odometry.from_poses(a[:, 0], a[:, 1], a[:, 2], a[:, 3])
        except InputError as exc:
            raise InputError(
                f"{exc}; the odometry was read as a TUM file (t x y z qx qy qz qw)"
            ) from exc
    src, header, rows = _table(path, "odometry")
    if not {"v", "w"} <= set(header) and {"x", "y", "theta"} <= set(header):
        t, x, y, theta = _columns(src, header, rows, ("t", "x", "y", "theta"))
        if t.size == 0:
            raise InputError(f"{src}: no odometry rows")
        lines = [n for n, _ in rows]
        _check_times(src, t, strict=False, lines=lines)
        _warn_time_unit(src, t)
        k = _moved_in_no_time(t, np.stack([x, y, theta], axis=1))
        if k is not None:
            raise InputError(
                f"{src}:{lines[k + 1]}: a pose at the time of the line before (t={float(t[k])!r}) "
                "that differs from it: the robot cannot move in no time"
            )
        try:
            odo = Odometry.from_poses(t, x, y, theta)
        except InputError as exc:
            raise InputError(f"{src}: {exc}") from exc
        # Row k of the odometry is the interval that ends at the pose of row k + 1, whose
        # line (the first at its time) names a rate: a heading in degrees turns fast there.
        ends = np.searchsorted(t, odo.t[1:], side="left")
        end_lines = [lines[int(k)] for k in ends] + [lines[-1]]
        _warn_odometry_units(src, end_lines, odo.v, odo.w, from_poses=True)
        return odo
    if not {"t", "v", "w"} <= set(header):
        raise InputError(
            f"{src}:1: an odometry file has the columns t,v,w (velocities) or t,x,y,theta (a "
            f"pose track), or is a TUM file; the header is {shorten(','.join(header))}"
        )
    t, v, w = _columns(src, header, rows, ("t", "v", "w"))
    if t.size == 0:
        raise InputError(f"{src}: no odometry rows")
    _check_times(src, t, strict=False, lines=[n for n, _ in rows])
    _warn_time_unit(src, t)
    _warn_odometry_units(src, [n for n, _ in rows], v, w)
    vy = _columns(src, header, rows, ("vy",))[0] if "vy" in header else None
    return Odometry(t, v, w, vy)


def load_groundtruth(path: PathLike) -> GroundTruth:
    """Read a ground-truth track: CSV ``t,x,y,theta[,gap]`` (theta in radians) or a TUM file
    (``t x y z qx qy qz qw``, as evo and ``omniloc track --truth-out`` write; poses that lean
    up to :data:`TUM_MAX_TILT` are read for their heading).

    A heading beyond a full turn is logged as a warning naming the line: degrees, probably
    (radians unwrapped over several turns are read correctly and may ignore it)."""
    if _is_tum(path):
        from .io import read_tum  # (io reads this module's records)

        try:
            a = read_tum(path, max_tilt=TUM_MAX_TILT)
            _check_times(str(path), a[:, 0])
            _warn_time_unit(str(path), a[:, 0])
            try:
                return GroundTruth(a[:, 0], a[:, 1], a[:, 2], a[:, 3])
            except InputError as exc:
                raise InputError(f"{path}: {exc}") from exc  # (e.g. too few samples)
        except InputError as exc:
            raise InputError(
                f"{exc}; the ground truth was read as a TUM file (t x y z qx qy qz qw)"
            ) from exc
    src, header, rows = _table(path, "ground truth")
    t, x, y, th = _columns(src, header, rows, ("t", "x", "y", "theta"))
    gap = _columns(src, header, rows, ("gap",))[0] if "gap" in header else None
    _check_times(src, t, lines=[n for n, _ in rows])
    _warn_time_unit(src, t)
    if th.size:
        k = int(np.argmax(np.abs(th)))
        if abs(th[k]) > 2.0 * math.pi:
            log.warning(
                "%s:%d: heading theta %g is more than a full turn: is it in degrees? omniloc "
                "reads radians (radians unwrapped over turns are read correctly)",
                src,
                rows[k][0],
                th[k],
            )
    try:
        return GroundTruth(t, x, y, th, gap)
    except InputError as exc:
        raise InputError(f"{src}: {exc}") from exc  # (e.g. too few samples)


def _detections(text: str, where: str, what: str) -> list[tuple[str, float]]:
    out: list[tuple[str, float]] = []
    for item in filter(None, (s.strip() for s in text.split(";"))):
        parts = item.split(":")
        if len(parts) < 2 or not parts[0].strip():
            raise InputError(f"{where}: {what} entry {item!r} is not 'id:bearing:range'")
        out.append((parts[0].strip(), parse_float(parts[1], where, f"{what} bearing", InputError)))
    return out


def load_frames(
    path: PathLike, *, degrees: bool = False, landmark_ids: dict[str, int] | None = None
) -> list[Frame]:
    """Read frames of bearings, in time order (see the module's documentation for formats).

    Parameters
    ----------
    path : str or path-like
        A generic ``t,bearing`` file or an MRCLAM ``robotR_frames.csv``.
    degrees : bool
        The generic file's bearings are in degrees (a ``bearing_deg`` column says so too);
        refused with a ``bearing_rad`` column or an MRCLAM file, whose bearings are radians.
    landmark_ids : dict, optional
        MRCLAM only: map from a landmark id (as written in the file) to its row in the map,
        to fill :attr:`Frame.truth` for evaluation (other robots' detections are None). The
        bearings are the same either way.

    Returns
    -------
    list of Frame
        In time order; a generic file's frames each hold the rows sharing one ``t``. Empty
        for a file with a header and no rows, of either format (callers that need frames
        say so, naming the file).

    Raises
    ------
    InputError
        The file cannot be read or is not a frames file, a value is not a number, times go
        back, ``degrees=True`` for a file whose bearings say radians, or a generic file read
        as radians has a bearing beyond a full turn (degrees without ``degrees=True``:
        :func:`omniloc.io.check_radians`); the message names the line.
    """
    src, header, rows = _table(path, "frames")
    if "landmarks" in header and "robot_detections" in header:
        if degrees:
            raise InputError(
                f"{src}:1: an MRCLAM frames file (landmarks, robot_detections) holds radians "
                "but degrees=True"
            )
        return _mrclam_frames(src, header, rows, landmark_ids)
    col = next((c for c in ("bearing", "bearing_rad", "bearing_deg") if c in header), None)
    if col is None or "t" not in header:
        raise InputError(
            f"{src}:1: a frames file needs columns t and bearing (or bearing_deg), or the "
            f"MRCLAM columns landmarks and robot_detections; the header is "
            f"{shorten(','.join(header))}"
        )
    if col == "bearing_rad" and degrees:
        raise InputError(f"{src}:1: the column says radians (bearing_rad) but degrees=True")
    # A row with an empty bearing is a frame without bearings (nothing seen at that time).
    k = header.index(col)
    seen = np.array([r[k].strip() != "" for _, r in rows], dtype=bool)
    (t,) = _columns(src, header, rows, ("t",))
    (b,) = _columns(src, header, [r for r, ok in zip(rows, seen, strict=True) if ok], (col,))
    _check_times(src, t, strict=False, lines=[n for n, _ in rows])
    _warn_time_unit(src, t)
    if degrees or col == "bearing_deg":
        b = np.deg2rad(b)
    else:
        lines = [n for (n, _), ok in zip(rows, seen, strict=True) if ok]
        check_radians(b, lambda k: f"{src}:{lines[k]}: bearing", InputError)
    if t.size == 0:
        return []  # (a header alone: no frames, as of an MRCLAM file)
    # Each bearing's place among the rows that have one: frame s..e holds b[at[s]:at[e]].
    at = np.concatenate([[0], np.cumsum(seen)])
    frames = []
    starts = np.flatnonzero(np.concatenate([[True], np.diff(t) > 0]))
    for s, e in zip(starts, [*starts[1:], t.size], strict=True):
        frames.append(Frame(float(t[s]), b[at[s] : at[e]]))
    return frames


def _mrclam_frames(
    src: str,
    header: list[str],
    rows: list[tuple[int, list[str]]],
    landmark_ids: dict[str, int] | None,
) -> list[Frame]:
    (t,) = _columns(src, header, rows, ("t",))
    _check_times(src, t, strict=False, lines=[n for n, _ in rows])
    _warn_time_unit(src, t)
    k_lm, k_rb = header.index("landmarks"), header.index("robot_detections")
    frames = []
    for (n, r), tt in zip(rows, t, strict=True):
        where = f"{src}:{n}"
        lms = _detections(r[k_lm], where, "landmark")
        rbs = _detections(r[k_rb], where, "robot detection")
        bearings = [b for _, b in lms] + [b for _, b in rbs]
        truth: tuple[int | None, ...] | None = None
        if landmark_ids is not None:
            unknown = [i for i, _ in lms if i not in landmark_ids]
            if unknown:
                raise InputError(f"{where}: landmark id {unknown[0]!r} is not in the map")
            truth = tuple([landmark_ids[i] for i, _ in lms] + [None] * len(rbs))
        frames.append(Frame(float(tt), np.asarray(bearings, dtype=np.float64), truth))
    return frames
