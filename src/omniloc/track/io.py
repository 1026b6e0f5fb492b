"""Writing what the tracker reported: a TUM trajectory and JSON lines.

TUM trajectory format (Sturm et al., 2012; what ``evo_ape tum`` reads): one pose per line,
``t x y z qx qy qz qw``, space separated, metres and a unit quaternion; a planar pose has
``z = 0`` and the rotation ``theta`` about z: ``qz = sin(theta / 2)``, ``qw = cos(theta / 2)``.
Only the frames whose state is in ``states`` are written (by default ``localized``: the
poses the tracker vouches for).

JSON lines: one object per frame, :meth:`~omniloc.track.TrackEstimate.as_dict` (``t``,
``state``, ``reason``, ``kidnapped`` and, unless lost, ``x``, ``y``, ``theta``,
``covariance`` and ``hypotheses``).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Sequence
from typing import IO

import numpy as np
from numpy.typing import NDArray

from ..angles import wrap
from ..errors import InputError
from ..io import PathLike, write_text
from .records import TrackEstimate, TrackState

__all__ = ["read_tum", "tum_lines", "write_json_lines", "write_tum"]


def tum_lines(
    estimates: Iterable[TrackEstimate],
    states: Sequence[TrackState | str] = (TrackState.LOCALIZED,),
) -> list[str]:
    """The TUM lines of the estimates whose state is in ``states`` (see the module)."""
    keep = {TrackState(s) for s in states}
    out = []
    for e in estimates:
        if e.state not in keep or e.pose is None:
            continue
        half = 0.5 * e.pose.theta
        out.append(
            f"{e.t:.6f} {e.pose.x:.6f} {e.pose.y:.6f} 0.000000 0.000000 0.000000 "
            f"{math.sin(half):.9f} {math.cos(half):.9f}"
        )
    return out


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


def read_tum(path: PathLike) -> NDArray[np.float64]:
    """Read a planar TUM trajectory: an array (n, 4) of ``t, x, y, theta``.

    Raises
    ------
    InputError
        An unreadable file, a line without 8 numbers (file and line named).
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
            t, x, y, _z, qx, qy, qz, qw = (float(p) for p in parts)
        except ValueError as exc:
            raise InputError(f"{path}:{n}: not a number: {exc}") from exc
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
