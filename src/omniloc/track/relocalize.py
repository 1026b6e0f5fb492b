"""New hypotheses from the interpretation tree, on a short window of frames.

One camera frame rarely holds three landmarks; the last second of frames often does. The
bearings of the frames in the search window are moved into the current robot frame by the
odometry's rotation (:func:`.window.stack_bearings`; repeated sightings of one landmark are
merged), and :func:`~omniloc.localize` finds every interpretation of them, with the noise
widened for what the rotation-only move leaves out (the translation over the window, seen
from the nearest range that matters). Each solution becomes a candidate pose of the
current frame; the tracker then replays the candidates through the window with the exact
measurement model (each bearing from its own frame's odometry-predicted pose) before it
weighs them against the hypotheses it has.

``localize`` is used to *generate* candidates only: their weights come from the tracker's
own likelihood, never from the search's ranking.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import OmnilocError
from ..maps import LandmarkMap
from ..search import localize
from ..sensor import SensorModel
from .window import WindowFrame, stack_bearings

__all__ = ["Candidates", "search_window"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Candidates:
    """Candidate poses of the current frame from one search.

    Attributes
    ----------
    poses : ndarray, shape (C, 3)
    covs : ndarray, shape (C, 3, 3)
    n_bearings : int
        Stacked (merged) bearings searched.
    complete : bool
        Whether the search finished within its budget.
    """

    poses: FloatArray
    covs: FloatArray
    n_bearings: int
    complete: bool

    def __len__(self) -> int:
        return int(self.poses.shape[0])


def _none(n: int = 0) -> Candidates:
    return Candidates(np.zeros((0, 3)), np.zeros((0, 3, 3)), n, True)


def search_window(
    landmarks: LandmarkMap,
    frames: list[WindowFrame],
    sensor: SensorModel,
    *,
    near_range_m: float,
    min_bearings: int,
    max_bearings: int,
    max_spurious: int,
    timeout_s: float,
    cov_inflation: float,
) -> Candidates:
    """Search the stacked bearings of ``frames`` (ending at the current frame).

    Parameters
    ----------
    landmarks : LandmarkMap
    frames : list of WindowFrame
        The search window, in time order.
    sensor : SensorModel
        Its noise is widened by the window's travel seen from ``near_range_m``.
    near_range_m : float
        Range at which the translation over the window is converted into bearing noise.
    min_bearings : int
        Do not search fewer stacked bearings than this (at least 3): with few bearings on a
        map of clusters the interpretations are legion and the search is slow.
    max_bearings : int
        Use at most this many stacked bearings (the most often seen).
    max_spurious : int
        Bearings the search may leave unmatched (clutter), at most ``m - 3``.
    timeout_s : float
        The search's time budget.
    cov_inflation : float
        Factor on the candidates' covariances (the search's covariance comes from the
        widened noise of a rotation-only move, not from the exact model).

    Returns
    -------
    Candidates
        Empty when fewer than ``min_bearings`` bearings were stacked or nothing fits.
    """
    noise = sensor.noise
    b, counts, travel = stack_bearings(frames, merge_tol=2.0 * noise)
    if b.size > max_bearings:
        keep = np.sort(np.argsort(-counts, kind="stable")[:max_bearings])
        b, counts = b[keep], counts[keep]
    m = int(b.size)
    if m < max(3, min_bearings):
        return _none(m)
    sigma = math.hypot(noise, travel / near_range_m)
    k = min(m - 3, max_spurious)
    try:
        res = localize(
            landmarks,
            b,
            sigma=sigma,
            confidence=sensor.gate_confidence,
            max_spurious=k,
            fov=sensor.fov,
            max_range=sensor.max_range,
            min_range=sensor.min_range,
            timeout_s=timeout_s,
            exhaustive=True,  # every interpretation: the candidates are weighed later
        )
    except OmnilocError:
        # Geometry the search refuses (e.g. too many bearings for the map): no candidates.
        return _none(m)
    if not res:
        return Candidates(np.zeros((0, 3)), np.zeros((0, 3, 3)), m, res.complete)
    poses = np.array([s.pose.as_array() for s in res.solutions])
    covs = np.array([np.asarray(s.covariance, dtype=np.float64) for s in res.solutions])
    bad = ~np.isfinite(covs).all(axis=(1, 2))
    covs[bad] = np.diag([1.0, 1.0, 0.1])
    covs = covs * cov_inflation
    return Candidates(poses, covs, m, res.complete)
