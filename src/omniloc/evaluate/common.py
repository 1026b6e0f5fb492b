"""Helpers shared by the evaluations: error figures, records to CSV/JSON, progress bars."""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, OmnilocError
from ..maps import LandmarkMap
from ..pose import Pose, crlb, estimate_pose, refine_pose
from ..search import LocalizationResult

__all__ = [
    "NAN",
    "Calibration",
    "calibration",
    "calibration_of_bins",
    "confidence_bins",
    "fmt_value",
    "jsonable",
    "known_pairs_errors",
    "matching_solutions",
    "oracle_pose",
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
    """One CSV row per record: dataclasses (their fields) or mappings (their keys, in the
    first record's order)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        if not records:
            return
        w = csv.writer(fh)
        if isinstance(records[0], Mapping):
            names = list(records[0])
            w.writerow(names)
            w.writerows([r[n] for n in names] for r in records)
            return
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


def oracle_pose(
    lm: LandmarkMap, bearings: FloatArray, assignment: Sequence[int | None]
) -> Pose | None:
    """The maximum-likelihood pose from the TRUE correspondences (None when fewer than 3
    landmarks were observed or they fix no pose)."""
    keep = [i for i, a in enumerate(assignment) if a is not None]
    if len(keep) < 3:
        return None
    try:
        rows = [int(a) for a in assignment if a is not None]
        return refine_pose(lm.xy[rows], np.asarray(bearings)[keep])[0]
    except OmnilocError:
        return None


def progress_bar(total: int, enabled: bool, desc: str) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=not (enabled and sys.stderr.isatty()))


@dataclass(frozen=True)
class Calibration:
    """How well the best solution's confidence predicts that it is correct.

    Attributes
    ----------
    edges : ndarray, shape (bins + 1,)
        Confidence bin edges over [0, 1].
    mean_confidence, fraction_correct : ndarray, shape (bins,)
        Per bin (NaN where empty): the mean confidence of the best solution, and the share of
        those cases in which it was correct (the reliability diagram).
    counts : ndarray of int, shape (bins,)
    ece : float
        Expected calibration error: ``sum_b n_b / n |fraction_correct_b - mean_confidence_b|``.
    """

    edges: FloatArray
    mean_confidence: FloatArray
    fraction_correct: FloatArray
    counts: NDArray[np.int64]
    ece: float


def confidence_bins(
    confidence: Sequence[float], correct: Sequence[bool], bins: int = 10
) -> tuple[NDArray[np.int64], FloatArray, NDArray[np.int64]]:
    """Per bin of [0, 1] (``bins`` equal bins): the cases, the sum of their confidences and
    how many were correct -- sums that pool over sets of cases (cases with no answer count as
    confidence 0, not correct)."""
    conf = np.nan_to_num(np.asarray(confidence, dtype=np.float64), nan=0.0)
    ok = np.asarray(correct, dtype=bool)
    if conf.shape != ok.shape:
        raise InputError("calibration needs one correctness flag per confidence")
    edges = np.linspace(0.0, 1.0, bins + 1)
    idx = np.clip(np.searchsorted(edges, conf, side="right") - 1, 0, bins - 1)
    return (
        np.bincount(idx, minlength=bins).astype(np.int64),
        np.bincount(idx, weights=conf, minlength=bins).astype(np.float64),
        np.bincount(idx, weights=ok.astype(float), minlength=bins).astype(np.int64),
    )


def calibration_of_bins(
    counts: ArrayLike, confidence_sums: ArrayLike, correct: ArrayLike
) -> Calibration:
    """The reliability from per-bin sums (:func:`confidence_bins`, or several of them added)."""
    n_b = np.asarray(counts, dtype=np.int64)
    sums = np.asarray(confidence_sums, dtype=np.float64)
    right = np.asarray(correct, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_c = sums / n_b
        frac = right / n_b
    ece = float(np.sum(np.abs(right - sums)) / max(int(n_b.sum()), 1))
    return Calibration(np.linspace(0.0, 1.0, n_b.size + 1), mean_c, frac, n_b, ece)


def calibration(
    confidence: Sequence[float], correct: Sequence[bool], bins: int = 10
) -> Calibration:
    """The reliability of a set of confidences (cases with no answer count as confidence 0,
    not correct).

    Examples
    --------
    >>> c = calibration([0.9, 0.9, 0.2, 0.2], [True, False, False, False], bins=5)
    >>> round(c.ece, 3)
    0.3
    """
    return calibration_of_bins(*confidence_bins(confidence, correct, bins))
