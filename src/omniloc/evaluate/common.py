"""Helpers shared by the evaluations: error figures, records to CSV/JSON, progress bars."""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import OmnilocError
from ..maps import LandmarkMap
from ..pose import Pose, crlb, estimate_pose, refine_pose
from ..search import LocalizationResult

__all__ = [
    "NAN",
    "fmt_value",
    "jsonable",
    "known_pairs_errors",
    "matching_solutions",
    "progress_bar",
    "rms",
    "text_table",
    "write_records_csv",
]

FloatArray = NDArray[np.float64]
NAN = float("nan")


def rms(x: Iterable[float]) -> float:
    a = np.asarray(list(x), dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a * a))) if a.size else NAN


def fmt_value(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)


def write_records_csv(path: Path, records: Sequence[Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        if not records:
            return
        w = csv.writer(fh)
        names = [f.name for f in fields(records[0])]
        w.writerow(names)
        for r in records:
            w.writerow([getattr(r, n) for n in names])


def jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def text_table(records: Sequence[Any], cols: Sequence[tuple[str, str]]) -> str:
    head = [h for _, h in cols]
    body = [[fmt_value(getattr(r, c)) for c, _ in cols] for r in records]
    widths = [
        max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)
    ]
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths, strict=True)) for b in body]
    return "\n".join(lines)


def known_pairs_errors(
    lm: LandmarkMap,
    bearings: FloatArray,
    assignment: Sequence[int | None],
    pose: Pose,
    sigma: float,
) -> tuple[float, float, float, float, float, float]:
    """Errors of the linear and refined estimates from the true pairs, and the CRLB."""
    keep = [i for i, a in enumerate(assignment) if a is not None]
    if len(keep) < 3:
        return (NAN,) * 6
    L = lm.xy[[int(a) for a in assignment if a is not None]]
    b = bearings[keep]
    out = [NAN] * 6
    try:
        lin = estimate_pose(L, b)
        d = lin.distance_to(pose)
        out[0], out[1] = d[0], math.degrees(d[1])
        ref, _ = refine_pose(L, b)
        d = ref.distance_to(pose)
        out[2], out[3] = d[0], math.degrees(d[1])
    except OmnilocError:
        pass
    try:
        # The bound scales linearly with sigma; sigma = 0 gives a zero bound.
        C = crlb(L, pose, 1.0)
        out[4] = sigma * math.sqrt(max(C[0, 0] + C[1, 1], 0.0))
        out[5] = math.degrees(sigma * math.sqrt(max(C[2, 2], 0.0)))
    except OmnilocError:
        pass
    return tuple(out)  # type: ignore[return-value]


def matching_solutions(
    res: LocalizationResult, pose: Pose, pos_tol: float, hdg_tol: float
) -> list[bool]:
    return [
        d[0] <= pos_tol and d[1] <= hdg_tol
        for d in (s.pose.distance_to(pose) for s in res.solutions)
    ]


def progress_bar(total: int, enabled: bool, desc: str) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=not (enabled and sys.stderr.isatty()))
