"""Correspondence-free localization on real recordings (Roh's IR beacons, MRCLAM frames)."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..angles import wrap
from ..datasets import DatasetSample
from ..errors import InputError
from ..maps import LandmarkMap
from ..pose import MIN_SIGMA, predict_bearings
from ..search import localize
from ..sensor import SensorModel, clutter_by_detections
from .common import (
    NAN,
    Calibration,
    calibration,
    jsonable,
    known_pairs_errors,
    matching_solutions,
    oracle_pose,
    progress_bar,
    write_records_csv,
)

__all__ = [
    "DATASET_DEFAULTS",
    "DatasetResult",
    "DatasetTrial",
    "estimate_sensor",
    "evaluate_dataset",
]

RngLike = np.random.Generator | int | None


@dataclass(frozen=True)
class DatasetTrial:
    """One real sample localized without correspondences (errors in metres and degrees)."""

    source: str
    n_bearings: int
    n_spurious: int
    n_solutions: int
    best_ok: bool
    in_solutions: bool
    true_assignment_found: bool
    ambiguous: bool
    complete: bool
    pos_err_m: float
    heading_err_deg: float
    oracle_pos_err_m: float
    oracle_heading_err_deg: float
    oracle_ok: bool
    best_near_oracle: bool
    oracle_in_solutions: bool
    decisive: bool
    best_confidence: float
    time_s: float


@dataclass(frozen=True)
class DatasetResult:
    """What :func:`evaluate_dataset` measured.

    ``best_rate``: the best solution is within tolerance of the ground truth;
    ``in_solutions_rate``: some solution is; ``assignment_rate``: some solution has exactly
    the true correspondences (spurious bearings as None); ``oracle_rate``: the refined pose
    from the TRUE correspondences is within tolerance (what any solver could reach at this
    tolerance); ``best_near_oracle_rate`` / ``oracle_in_solutions_rate``: the best / some
    solution is within tolerance of that oracle pose (judges the search alone, not the
    sensor's biases or the ground truth's placement errors).
    """

    kind: str
    options: dict[str, Any]
    pos_tol_m: float
    heading_tol_deg: float
    trials: list[DatasetTrial] = field(repr=False)
    elapsed_s: float = 0.0

    @property
    def n(self) -> int:
        return len(self.trials)

    def _rate(self, name: str) -> float:
        return float(np.mean([getattr(t, name) for t in self.trials])) if self.trials else NAN

    @property
    def best_rate(self) -> float:
        return self._rate("best_ok")

    @property
    def in_solutions_rate(self) -> float:
        return self._rate("in_solutions")

    @property
    def assignment_rate(self) -> float:
        return self._rate("true_assignment_found")

    @property
    def ambiguous_rate(self) -> float:
        return self._rate("ambiguous")

    @property
    def complete_rate(self) -> float:
        return self._rate("complete")

    @property
    def oracle_rate(self) -> float:
        return self._rate("oracle_ok")

    @property
    def best_near_oracle_rate(self) -> float:
        return self._rate("best_near_oracle")

    @property
    def oracle_in_solutions_rate(self) -> float:
        return self._rate("oracle_in_solutions")

    @property
    def confidently_wrong_rate(self) -> float:
        """Share of samples whose answer was not ambiguous and whose best was wrong."""
        return float(np.mean([t.decisive and not t.best_ok for t in self.trials]))

    @property
    def decisive_correct_rate(self) -> float:
        """Share of samples whose answer was not ambiguous and whose best was right."""
        return float(np.mean([t.decisive and t.best_ok for t in self.trials]))

    def calibration(self, bins: int = 10) -> Calibration:
        """Reliability of the best solution's confidence over every sample."""
        return calibration(
            [t.best_confidence for t in self.trials], [t.best_ok for t in self.trials], bins
        )

    @property
    def time_median_s(self) -> float:
        return float(np.median([t.time_s for t in self.trials])) if self.trials else NAN

    @property
    def time_p95_s(self) -> float:
        return float(np.percentile([t.time_s for t in self.trials], 95)) if self.trials else NAN

    def as_dict(self) -> dict[str, Any]:
        """Aggregates as a plain dictionary."""
        return {
            "kind": self.kind,
            "n": self.n,
            "pos_tol_m": self.pos_tol_m,
            "heading_tol_deg": self.heading_tol_deg,
            "best_rate": self.best_rate,
            "in_solutions_rate": self.in_solutions_rate,
            "assignment_rate": self.assignment_rate,
            "ambiguous_rate": self.ambiguous_rate,
            "complete_rate": self.complete_rate,
            "oracle_rate": self.oracle_rate,
            "best_near_oracle_rate": self.best_near_oracle_rate,
            "oracle_in_solutions_rate": self.oracle_in_solutions_rate,
            "confidently_wrong_rate": self.confidently_wrong_rate if self.trials else NAN,
            "decisive_correct_rate": self.decisive_correct_rate if self.trials else NAN,
            "ece": self.calibration().ece if self.trials else NAN,
            "time_median_s": self.time_median_s,
            "time_p95_s": self.time_p95_s,
            "elapsed_s": self.elapsed_s,
            "options": self.options,
        }

    def to_csv(self, path: str | Path) -> None:
        """Write the per-sample records as CSV."""
        write_records_csv(Path(path), self.trials)

    def to_json(self, path: str | Path) -> None:
        """Write aggregates and per-sample records as JSON (NaN as null)."""
        data = {k: jsonable(v) for k, v in self.as_dict().items()}
        data["trials"] = [{k: jsonable(v) for k, v in asdict(t).items()} for t in self.trials]
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(data, indent=1))

    def summary(self) -> str:
        """One plain-text paragraph of the aggregates."""
        d = self.as_dict()
        return (
            f"{self.kind}: {d['n']} samples in {self.elapsed_s:.1f} s, tolerance "
            f"{self.pos_tol_m} m / {self.heading_tol_deg} deg\n"
            f"  best solution correct   {d['best_rate']:.3f}\n"
            f"  true pose among sols    {d['in_solutions_rate']:.3f}\n"
            f"  true assignment found   {d['assignment_rate']:.3f}\n"
            f"  ambiguity reported      {d['ambiguous_rate']:.3f}\n"
            f"  search complete         {d['complete_rate']:.3f}\n"
            f"  oracle within tolerance {d['oracle_rate']:.3f}\n"
            f"  best near oracle pose   {d['best_near_oracle_rate']:.3f}\n"
            f"  oracle pose among sols  {d['oracle_in_solutions_rate']:.3f}\n"
            f"  confidently wrong       {d['confidently_wrong_rate']:.4f}\n"
            f"  decisive and correct    {d['decisive_correct_rate']:.3f}\n"
            f"  calibration error (ECE) {d['ece']:.3f}\n"
            f"  time median / p95       {d['time_median_s']:.3f} s / {d['time_p95_s']:.3f} s"
        )


#: Solver options and tolerances per dataset (see docs/evaluation.md for the reasons). The
#: sensor's noise, detection probability and clutter are those :func:`estimate_sensor` finds
#: in the recording (tests/test_evaluate.py checks them against it): MRCLAM set 6, all frames
#: at 67 deg / 8 m: sigma 0.48 deg, p_detect 0.49, 0.28 robots per frame, and by the tubes a
#: frame reports (1, 2, ..., 8 or more) 0.30, 0.06, 0.40, 0.89, 0.99, 1.09, 0.89, 0.43 robots:
#: the robots come with the tubes (see omniloc.sensor); Roh: sigma 2.1 deg, every beacon
#: detected (p_detect 1.0, taken as 0.99: no sensor is perfect), no clutter.
DATASET_DEFAULTS: dict[str, dict[str, Any]] = {
    "roh": {
        "options": {
            "sigma": float(np.deg2rad(2.0)),
            "p_detect": 0.99,
            "clutter": 0.01,
            "method": "robust",
            "timeout_s": 5.0,
        },
        "pos_tol_m": 0.3,
        "heading_tol_deg": 10.0,
    },
    "mrclam": {
        "options": {
            "sigma": float(np.deg2rad(0.5)),
            "fov": float(np.deg2rad(67.0)),
            "max_range": 8.0,
            "p_detect": 0.49,
            "clutter": 0.28,
            "clutter_by_detections": (0.30, 0.06, 0.40, 0.89, 0.99, 1.09, 0.89, 0.43),
            "timeout_s": 5.0,
        },
        "pos_tol_m": 0.3,
        "heading_tol_deg": 5.0,
    },
}


def evaluate_dataset(
    kind: str,
    path: str | Path,
    *,
    max_samples: int | None = None,
    rng: RngLike = 0,
    progress: bool = True,
    options: dict[str, Any] | None = None,
    pos_tol_m: float | None = None,
    heading_tol_deg: float | None = None,
    include_robots: bool = True,
    min_landmarks: int = 4,
) -> DatasetResult:
    """Correspondence-free localization on a real recording.

    Parameters
    ----------
    kind : {"roh", "mrclam"}
    path : str or Path
        The dataset folder.
    max_samples : int, optional
        Use the first samples only.
    rng : Generator, int or None
        Shuffles the bearings of each sample.
    options : dict, optional
        Overrides of the :func:`~omniloc.search.localize` options in
        :data:`DATASET_DEFAULTS`. For MRCLAM ``max_spurious`` is the number of robot
        detections in the frame unless given here.
    pos_tol_m, heading_tol_deg : float, optional
        A solution is correct within these of the ground truth.
    include_robots : bool
        MRCLAM: add the other robots' bearings as spurious observations.
    min_landmarks : int
        MRCLAM: use the frames that see at least this many distinct landmarks.

    Returns
    -------
    DatasetResult
    """
    from ..datasets import load_mrclam, load_roh

    if kind not in DATASET_DEFAULTS:
        raise InputError(f"dataset kind must be 'roh' or 'mrclam', got {kind!r}")
    if max_samples is not None and max_samples < 1:
        raise InputError(f"max_samples must be >= 1, got {max_samples}")
    dflt = DATASET_DEFAULTS[kind]
    opts: dict[str, Any] = {**dflt["options"], **(options or {})}
    ptol = float(dflt["pos_tol_m"] if pos_tol_m is None else pos_tol_m)
    htol = float(dflt["heading_tol_deg"] if heading_tol_deg is None else heading_tol_deg)
    if kind == "roh":
        ds_r = load_roh(path)
        lm = ds_r.landmarks
        n_total = len(ds_r) if max_samples is None else min(len(ds_r), max_samples)
        samples = ds_r.samples(rng, max_samples=max_samples)
    else:
        ds_m = load_mrclam(path, include_robots=include_robots, min_landmarks=min_landmarks)
        lm = ds_m.landmarks
        n_total = len(ds_m) if max_samples is None else min(len(ds_m), max_samples)
        samples = ds_m.samples(rng, max_samples=max_samples)
    t_all = time.perf_counter()
    out: list[DatasetTrial] = []
    bar = progress_bar(n_total, progress, f"dataset {kind}")
    try:
        for s in samples:
            kw = dict(opts)
            kw.setdefault("max_spurious", s.n_spurious)
            t0 = time.perf_counter()
            res = localize(lm, s.bearings, **kw)
            dt = time.perf_counter() - t0
            good = matching_solutions(res, s.pose, ptol, math.radians(htol))
            best = res.best
            err = best.pose.distance_to(s.pose) if best is not None else (NAN, NAN)
            known = known_pairs_errors(lm, s.bearings, s.assignment, s.pose, 1.0)
            near = matching_solutions(
                res, oracle_pose(lm, s.bearings, s.assignment) or s.pose, ptol, math.radians(htol)
            )
            out.append(
                DatasetTrial(
                    source=s.source,
                    n_bearings=int(s.bearings.size),
                    n_spurious=s.n_spurious,
                    n_solutions=len(res),
                    best_ok=bool(good) and good[0],
                    in_solutions=any(good),
                    true_assignment_found=any(
                        sol.assignment == s.assignment for sol in res.solutions
                    ),
                    ambiguous=res.ambiguous,
                    complete=res.complete,
                    pos_err_m=err[0],
                    heading_err_deg=math.degrees(err[1]),
                    oracle_pos_err_m=known[2],
                    oracle_heading_err_deg=known[3],
                    oracle_ok=bool(known[2] <= ptol and known[3] <= htol),
                    best_near_oracle=bool(near) and near[0],
                    oracle_in_solutions=any(near),
                    decisive=bool(res) and not res.ambiguous,
                    best_confidence=best.confidence if best is not None else 0.0,
                    time_s=dt,
                )
            )
            bar.update(1)
    finally:
        bar.close()
    return DatasetResult(kind, opts, ptol, htol, out, time.perf_counter() - t_all)


def estimate_sensor(
    landmarks: LandmarkMap,
    samples: Iterable[DatasetSample],
    *,
    fov: float | None = None,
    max_range: float | None = None,
) -> dict[str, Any]:
    """Estimate a bearing sensor's noise, detection probability and clutter from a recording
    with ground truth and known correspondences (the method of :mod:`omniloc.sensor`).

    * ``sigma``: 1.4826 times the median absolute bearing residual of the matched landmarks
      at the true poses (robust to the outliers of a real sensor);
    * ``p_detect``: over all samples pooled, the detected landmarks that are plainly visible
      (by the given ``fov`` and ``max_range``, at that ``sigma``) over those plus the plainly
      visible ones missed -- not detected, and not hidden behind a reported bearing (the two
      cases the posterior scores with ``ln p_detect`` and ``ln(1 - p_detect)``);
    * ``clutter``: mean number of bearings per sample that are no landmark of the map;
    * ``clutter_by_detections``: the same mean over the samples that report 1, 2, ...
      landmarks (:func:`omniloc.sensor.clutter_by_detections`: up to the largest count that
      at least 30 samples reach, the last entry pooling every sample with that many or more).

    Returns
    -------
    dict
        ``sigma`` (rad), ``p_detect``, ``clutter``, ``clutter_by_detections`` (a tuple),
        and ``samples`` (how many were used).

    Raises
    ------
    InputError
        No samples; no sample with a landmark (nothing to measure the noise on); no landmark
        plainly visible from any true pose (nothing to measure ``p_detect`` on).
    """
    residuals: list[float] = []
    data = list(samples)
    if not data:
        raise InputError("estimate_sensor needs at least one sample")
    for s in data:
        rows = [a for a in s.assignment if a is not None]
        b = np.asarray([s.bearings[i] for i, a in enumerate(s.assignment) if a is not None])
        if rows:
            pred = predict_bearings(landmarks.xy[rows], s.pose)
            residuals.extend(np.abs(np.asarray(wrap(b - pred))).tolist())
    if not residuals:
        raise InputError(
            f"estimate_sensor: none of the {len(data)} samples reports a landmark of the map, "
            "so the bearing noise cannot be measured"
        )
    sigma = 1.4826 * float(np.median(residuals))
    model = SensorModel(sigma=max(sigma, MIN_SIGMA), fov=fov, max_range=max_range, allow_wide=True)
    seen = missed = 0
    spurious = np.zeros(len(data))
    detected = np.zeros(len(data), dtype=np.int64)
    for j, s in enumerate(data):
        plain = model.plainly_visible(landmarks.xy, s.pose)
        alone = model.plainly_visible(landmarks.xy, s.pose, s.bearings)
        found = np.zeros(landmarks.n, dtype=bool)
        found[[a for a in s.assignment if a is not None]] = True
        seen += int((plain & found).sum())
        missed += int((alone & ~found).sum())
        spurious[j] = sum(a is None for a in s.assignment)
        detected[j] = int(found.sum())
    if seen + missed == 0:
        raise InputError(
            "estimate_sensor: no landmark is plainly visible from any true pose (by fov and "
            "max_range), so p_detect cannot be measured"
        )
    clutter = float(spurious.mean())
    return {
        "sigma": sigma,
        "p_detect": seen / (seen + missed),
        "clutter": clutter,
        "clutter_by_detections": clutter_by_detections(detected, spurious),
        "samples": float(len(data)),
    }
