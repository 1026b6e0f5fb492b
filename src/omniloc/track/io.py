"""Writing what the tracker reported (a TUM trajectory, JSON lines) and recordings in the
files :mod:`omniloc.track.data` reads (odometry, frames, ground truth).

TUM trajectory format (Sturm et al., 2012; what ``evo_ape tum`` reads): one pose per line,
``t x y z qx qy qz qw``, space separated, metres and a unit quaternion; a planar pose has
``z = 0`` and the rotation ``theta`` about z: ``qz = sin(theta / 2)``, ``qw = cos(theta / 2)``.
Only the frames whose state is in ``states`` are written (by default ``localized``: the
poses the tracker vouches for).

JSON lines: one object per frame, :meth:`~omniloc.track.TrackEstimate.as_dict` (``t``,
``state``, ``reason``, ``kidnapped``, ``since_localized`` and, unless lost, ``x``, ``y``,
``theta``, ``covariance``, ``probability``, ``confidence`` and ``hypotheses``).

Recordings: :func:`write_odometry`, :func:`write_frames` and :func:`write_groundtruth` write
what :func:`~omniloc.track.load_odometry`, :func:`~omniloc.track.load_frames` and
:func:`~omniloc.track.load_groundtruth` read back exactly (every number in its shortest form
that reads back as the same float), e.g. a :func:`~omniloc.track.simulate_run` to try the
tracker's command line on.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Sequence
from typing import IO

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..angles import wrap
from ..errors import InputError
from ..io import PathLike, shorten, write_text
from .data import Frame, GroundTruth, Odometry
from .records import TrackEstimate, TrackState

__all__ = [
    "read_tum",
    "tum_lines",
    "write_frames",
    "write_groundtruth",
    "write_json_lines",
    "write_odometry",
    "write_tum",
    "write_tum_truth",
]


def tum_lines(
    estimates: Iterable[TrackEstimate],
    states: Sequence[TrackState | str] = (TrackState.LOCALIZED,),
) -> list[str]:
    """The TUM lines of the estimates whose state is in ``states`` (see the module)."""
    keep = {TrackState(s) for s in states}
    return [
        _tum_line(e.t, e.pose.x, e.pose.y, e.pose.theta)
        for e in estimates
        if e.state in keep and e.pose is not None
    ]


def _tum_line(t: float, x: float, y: float, theta: float) -> str:
    """One planar pose as a TUM line (see the module)."""
    half = 0.5 * theta
    return (
        f"{t:.6f} {x:.6f} {y:.6f} 0.000000 0.000000 0.000000 "
        f"{math.sin(half):.9f} {math.cos(half):.9f}"
    )


def write_tum(
    path: PathLike,
    estimates: Iterable[TrackEstimate],
    states: Sequence[TrackState | str] = (TrackState.LOCALIZED,),
) -> int:
    """Write a TUM trajectory file; returns the number of poses written.

    Raises
    ------
    InputError
        The file cannot be written (the message names it).
    """
    lines = tum_lines(estimates, states)
    write_text(path, "".join(line + "\n" for line in lines), InputError)
    return len(lines)


def write_tum_truth(path: PathLike, truth: GroundTruth, times: ArrayLike) -> int:
    """Write a ground-truth track at ``times`` (interpolated, :meth:`GroundTruth.at`) as a
    TUM trajectory, the reference for ``evo_ape tum`` against :func:`write_tum`'s output:
    at the frames' times every estimate has a reference pose at its own time stamp. Times
    outside the track's span are left out. Returns the number of poses written.

    Raises
    ------
    InputError
        Not a :class:`~omniloc.track.GroundTruth`, times that are not finite numbers, or the
        file cannot be written.
    """
    if not isinstance(truth, GroundTruth):
        raise InputError(f"write_tum_truth needs a GroundTruth, got {type(truth).__name__}")
    try:
        tq = np.asarray(times, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"times must be numbers (s), got {shorten(times)}") from None
    if not np.isfinite(tq).all():
        raise InputError(f"times must be finite, got {shorten(times)}")
    poses, _ = truth.at(tq)
    inside = np.isfinite(poses).all(axis=1)
    lines = [
        _tum_line(float(t), float(p[0]), float(p[1]), float(p[2]))
        for t, p in zip(tq[inside], poses[inside], strict=True)
    ]
    write_text(path, "".join(line + "\n" for line in lines), InputError)
    return len(lines)


def read_tum(path: PathLike, *, max_tilt: float = 0.0) -> NDArray[np.float64]:
    """Read a planar TUM trajectory: an array (n, 4) of ``t, x, y, theta``.

    Parameters
    ----------
    path : str or Path
    max_tilt : float
        Largest tilt (roll and pitch together, rad) taken: a pose that leans at most this
        much is read for its heading (yaw). 0 (the default): only poses that turn about the
        vertical alone (``qx`` and ``qy`` within 1e-6).

    Raises
    ------
    InputError
        An unreadable file, a line without 8 finite numbers, a pose that leans more than
        ``max_tilt``, a quaternion of length 0 (file and line named).
    """
    from ..io import read_text

    rows = []
    for n, line in enumerate(read_text(path, InputError).splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.split()
        if len(parts) != 8:
            raise InputError(f"{path}:{n}: a TUM line has 8 numbers, got {len(parts)}")
        try:
            values = [float(p) for p in parts]
        except ValueError as exc:
            raise InputError(f"{path}:{n}: not a number: {exc}") from exc
        if not all(map(math.isfinite, values)):
            raise InputError(f"{path}:{n}: a value that is not a finite number: {s}")
        t, x, y, _z, qx, qy, qz, qw = values
        if max_tilt > 0.0:
            q = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
            if not q > 0.0:
                raise InputError(f"{path}:{n}: the quaternion has length 0: not a rotation")
            qx, qy, qz, qw = qx / q, qy / q, qz / q, qw / q
            tilt = math.acos(min(max(1.0 - 2.0 * (qx * qx + qy * qy), -1.0), 1.0))
            if tilt > max_tilt:
                raise InputError(
                    f"{path}:{n}: the pose leans {math.degrees(tilt):.1f} deg from upright "
                    f"(roll and pitch), more than {math.degrees(max_tilt):.1f}: not a planar "
                    "trajectory"
                )
            yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
            rows.append((t, x, y, yaw))
            continue
        if abs(qx) > 1e-6 or abs(qy) > 1e-6:
            raise InputError(f"{path}:{n}: not a planar pose (rotation about x or y)")
        rows.append((t, x, y, 2.0 * math.atan2(qz, qw)))
    out = np.array(rows, dtype=np.float64).reshape(-1, 4)
    out[:, 3] = np.asarray(wrap(out[:, 3]))
    return out


def write_json_lines(out: PathLike | IO[str], estimates: Iterable[TrackEstimate]) -> int:
    """Write one JSON object per estimate (to a path or an open text stream); returns how
    many were written."""
    lines = [json.dumps(e.as_dict(), allow_nan=False) for e in estimates]
    text = "".join(line + "\n" for line in lines)
    if isinstance(out, (str, os.PathLike)):
        write_text(out, text, InputError)
    else:
        out.write(text)
    return len(lines)


def _csv(path: PathLike, header: str, rows: Iterable[Sequence[float | str]]) -> int:
    """Write a CSV file of a header and rows of numbers (repr: they read back exactly) or
    text; returns the number of rows."""
    lines = [header]
    for row in rows:
        lines.append(",".join(v if isinstance(v, str) else repr(float(v)) for v in row))
    write_text(path, "\n".join(lines) + "\n", InputError)
    return len(lines) - 1


def write_odometry(path: PathLike, odometry: Odometry) -> int:
    """Write odometry as ``t,v,w`` (what :func:`~omniloc.track.load_odometry` reads); returns
    the number of rows.

    Raises
    ------
    InputError
        Not an :class:`~omniloc.track.Odometry`, or the file cannot be written.
    """
    if not isinstance(odometry, Odometry):
        raise InputError(f"write_odometry needs an Odometry, got {type(odometry).__name__}")
    if odometry.vy is not None:
        cols = zip(odometry.t, odometry.v, odometry.w, odometry.vy, strict=True)
        return _csv(path, "t,v,w,vy", cols)
    return _csv(path, "t,v,w", zip(odometry.t, odometry.v, odometry.w, strict=True))


def write_groundtruth(path: PathLike, truth: GroundTruth) -> int:
    """Write a ground-truth track as ``t,x,y,theta,gap`` (what
    :func:`~omniloc.track.load_groundtruth` reads); returns the number of rows.

    Raises
    ------
    InputError
        Not a :class:`~omniloc.track.GroundTruth`, or the file cannot be written.
    """
    if not isinstance(truth, GroundTruth):
        raise InputError(f"write_groundtruth needs a GroundTruth, got {type(truth).__name__}")
    gap = truth.gap if truth.gap is not None else np.zeros_like(truth.t)
    return _csv(
        path, "t,x,y,theta,gap", zip(truth.t, truth.x, truth.y, truth.theta, gap, strict=True)
    )


def write_frames(path: PathLike, frames: Iterable[Frame]) -> int:
    """Write frames as the generic ``t,bearing`` file (radians, one row per bearing; a frame
    without bearings as a row with an empty bearing), what :func:`~omniloc.track.load_frames`
    reads; returns the number of frames. Landmark ids (:attr:`Frame.truth`) are not written.

    Raises
    ------
    InputError
        Not an iterable, an item that is not a :class:`~omniloc.track.Frame`, frames out of
        time order, two frames at one time (they would read back as one), or the file cannot
        be written.
    """
    try:
        items = list(frames)
    except TypeError:
        raise InputError(
            f"write_frames needs an iterable of Frame, got {type(frames).__name__}"
        ) from None
    rows: list[tuple[float, float | str]] = []
    last = -math.inf
    n = 0
    for k, f in enumerate(items):
        if not isinstance(f, Frame):
            raise InputError(f"write_frames: item {k} is a {type(f).__name__}, not a Frame")
        if not f.t > last:
            raise InputError(
                f"write_frames: frame {k} at t={f.t!r} does not come after the one before "
                f"(t={last!r}); frames must be in strictly increasing time order"
            )
        last = f.t
        n += 1
        if f.bearings.size:
            rows.extend((f.t, float(b)) for b in f.bearings)
        else:
            rows.append((f.t, ""))
    _csv(path, "t,bearing", rows)
    return n
