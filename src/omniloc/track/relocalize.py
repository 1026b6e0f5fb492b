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

from .._kernels.track import PAIR_MIN_SINE, pair_scan_kernel, refine_frames_kernel
from ..errors import InputError, OmnilocError
from ..maps import LandmarkMap
from ..search import localize
from ..sensor import SensorModel
from .likelihood import MIN_RANGE_M
from .motion import between
from .window import WindowFrame, stack_bearings

__all__ = ["Candidates", "pair_candidates", "refine_on_frames", "search_window"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


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
    max_nodes: int,
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
    max_nodes : int
        The search's work budget (nodes; what makes runs reproducible).
    timeout_s : float
        The search's time budget (a safety net above ``max_nodes``).
    cov_inflation : float
        Factor on the candidates' covariances (the search's covariance comes from the
        widened noise of a rotation-only move, not from the exact model).

    Returns
    -------
    Candidates
        Empty when fewer than ``min_bearings`` bearings were stacked or nothing fits.
    """
    noise = sensor.noise
    b, counts, travel, member = stack_bearings(frames, merge_tol=2.0 * noise)
    if b.size > max_bearings:
        keep = np.sort(np.argsort(-counts, kind="stable")[:max_bearings])
        new_index = np.full(b.size, -1, dtype=np.int64)
        new_index[keep] = np.arange(keep.size)
        member = new_index[member]
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
            max_nodes=max_nodes,
            timeout_s=timeout_s,
            exhaustive=True,  # every interpretation: the candidates are weighed later
            check_view=False,  # stacked from frames of a turning robot
            # Every bearing tried as spurious after a fitting landmark too (localize's
            # default) gave the five MRCLAM runs 1,406 right localized frames and 3 wrong
            # against 1,567 and 0 (2026-12-06): the node budget goes to sub-interpretations.
            contested_wildcards=True,
        )
    except OmnilocError:
        # Geometry the search refuses (e.g. too many bearings for the map): no candidates.
        return _none(m)
    if not res:
        return Candidates(np.zeros((0, 3)), np.zeros((0, 3, 3)), m, res.complete)
    poses, covs = refine_on_frames(landmarks.xy, frames, member, res.assignments, res.poses, noise)
    covs = covs * cov_inflation
    return Candidates(poses, covs, m, res.complete)


def _seen_from(frames: list[WindowFrame]) -> tuple[FloatArray, FloatArray]:
    """Every bearing of ``frames`` in order (n,) and, for each, the odometry from its frame
    to the last (n, 3): the pose it was seen from is the last frame's composed with it."""
    ref = frames[-1].odom
    rel = np.concatenate(
        [np.repeat(between(ref, f.odom)[None], f.bearings.size, axis=0) for f in frames]
    )
    return rel, np.concatenate([f.bearings for f in frames])


def refine_on_frames(
    landmarks_xy: FloatArray,
    frames: list[WindowFrame],
    member: IntArray,
    assign: IntArray,
    poses: FloatArray,
    sigma: float,
    iterations: int = 6,
) -> tuple[FloatArray, FloatArray]:
    """Refine poses of the last frame found on stacked bearings with the exact model: each
    bearing seen from its own frame's pose (the candidate composed with the odometry from
    that frame), the landmark its merged bearing was assigned (Gauss-Newton on the wrapped
    residuals, all candidates at once).

    Parameters
    ----------
    landmarks_xy : ndarray, shape (N, 2)
    frames : list of WindowFrame
        The frames whose bearings were stacked, in time order.
    member : ndarray of int, shape (n,)
        Merged bearing of each of the frames' bearings (-1: left out of the search).
    assign : ndarray of int, shape (C, k)
        Landmark row of each merged bearing per candidate (-1: clutter).
    poses : ndarray, shape (C, 3)
        Candidate poses of the last frame.
    sigma : float
        Bearing noise, radians.

    Returns
    -------
    poses, covs : ndarray, shapes (C, 3) and (C, 3, 3)
        Refined poses and ``sigma^2 (J^T J)^-1`` (a candidate whose pairs do not fix the pose
        keeps its pose, with a wide covariance).
    """
    C = poses.shape[0]
    if C == 0:
        return poses, np.zeros((0, 3, 3))
    rel, z = _seen_from(frames)
    use = member >= 0
    rel, z, member = rel[use], z[use], member[use]
    lm = np.where(member[None, :] >= 0, assign[:, member], -1)  # (C, n)
    return refine_frames_kernel(
        np.ascontiguousarray(landmarks_xy, dtype=np.float64),
        np.ascontiguousarray(rel, dtype=np.float64),
        np.ascontiguousarray(z, dtype=np.float64),
        np.ascontiguousarray(lm, dtype=np.int64),
        np.ascontiguousarray(poses, dtype=np.float64),
        float(sigma),
        int(iterations),
    )


#: Samples of the family of poses that see two landmarks at a frame's two bearings.
PAIR_STEPS = 360
#: At most this many pairs of the seed frame's bearings are tried.
PAIR_MAX_SEEDS = 3
#: At most this many bearings of the window are scored (the newest).
PAIR_MAX_BEARINGS = 24
#: At most this many places are proposed by one pair search: the first local minima in the
#: scan's order (landmark pairs in map order). On the look-alikes' battery's maps of 20
#: landmarks a search often finds more (2-6 of a run's 11-23 searches): the cut is then by
#: that order, not by quality -- the 300 of lowest scan cost did worse (the lab notebook,
#: "A pose from two landmarks and the odometry").
PAIR_MAX_OUT = 2000
#: The largest map a pair search is run on: it tries every pair of landmarks (within twice
#: the range of each other) and scores every landmark for each pose it samples.
PAIR_MAX_LANDMARKS = 100


def pair_candidates(
    landmarks: LandmarkMap,
    frames: list[WindowFrame],
    sensor: SensorModel,
    *,
    min_hits: int,
    cov_inflation: float,
) -> Candidates:
    """Candidate poses of the last frame from two landmarks seen from a moving sensor.

    The window search stacks the frames' bearings by the odometry's rotation and asks the
    interpretation tree for three distinct landmarks among them: a robot that sees two
    landmarks at a time gives it none (the near one's sightings, turned by the travel, do
    not merge and must be given distinct landmarks). Here the newest frame with two
    bearings not nearly in line (the sine of their angle apart at least
    :data:`~omniloc._kernels.track.PAIR_MIN_SINE`) seeds the search: for each of up to
    :data:`PAIR_MAX_SEEDS` pairs of its bearings (neighbours in the frame's order first;
    pairs nearly in line skipped) and each ordered pair
    of landmarks within twice the range of each other, the poses that see them there are a
    one-parameter family (:data:`PAIR_STEPS` samples), each scored against every bearing of
    ``frames`` seen from its own frame's odometry pose; the family's local minima that
    explain ``min_hits`` bearings or more within the sensor's gate, the seed's two and
    ``min_hits - 2`` that fix the family (of a third landmark, or seen from far enough
    along the path: a sensor standing still fixes nothing), are refined with the exact
    model (:func:`refine_on_frames`' Gauss-Newton on the bearings they explain).

    Parameters
    ----------
    landmarks : LandmarkMap
    frames : list of WindowFrame
        The window, in time order (the last is the frame the poses are of).
    sensor : SensorModel
        Its noise, gate, range and field of view.
    min_hits : int
        Bearings a pose must explain (at least 3: the seed's two and one more that fixes
        the family).
    cov_inflation : float
        Factor on the candidates' covariances.

    Returns
    -------
    Candidates
        Empty without a frame of two bearings or without a pose that explains enough.
    """
    if min_hits < 3:
        raise InputError(f"min_hits must be at least 3, got {min_hits}")
    if landmarks.n > PAIR_MAX_LANDMARKS:
        raise InputError(
            f"a pair search on a map of {landmarks.n} landmarks: it tries every pair of "
            f"landmarks, for maps of at most {PAIR_MAX_LANDMARKS}"
        )
    with_two = [k for k, f in enumerate(frames) if f.bearings.size >= 2]
    n_all = sum(f.bearings.size for f in frames)
    if not with_two or n_all < min_hits:
        return _none(n_all)
    rel, z = _seen_from(frames)
    start = np.cumsum([0] + [f.bearings.size for f in frames])
    # The newest frame with a pair of bearings not nearly in line (within about 6 degrees
    # of 0 or 180 degrees apart the kernel skips a pair: the sensor between the two
    # landmarks or both nearly behind each other, where the whole turn's steps miss the
    # poses and the bearings barely fix the position along the line). Its pairs of
    # bearings, neighbours first ((0, 1), (1, 2), (2, 3), ...; then (0, 2), ...): the first
    # few do not all hold one bearing, which a clutter bearing would spoil for all.
    for seed in reversed(with_two):
        b = frames[seed].bearings
        m = b.size
        pairs = [(i, i + g) for g in range(1, m) for i in range(m - g)][:PAIR_MAX_SEEDS]
        if any(abs(math.sin(b[j] - b[i])) >= PAIR_MIN_SINE for i, j in pairs):
            break
    else:
        return _none(n_all)
    seeds = np.asarray(pairs, dtype=np.int64) + start[seed]
    # The newest bearings only (the seed's among them), renumbered.
    keep = np.arange(max(0, z.size - PAIR_MAX_BEARINGS), z.size)
    if seeds.min() < keep[0]:
        keep = np.union1d(keep, seeds.ravel())
    index = np.full(z.size, -1, dtype=np.int64)
    index[keep] = np.arange(keep.size)
    rel, z, seeds = rel[keep], z[keep], index[seeds]
    # How far each bearing's frame lies from the seed frame.
    base = np.hypot(rel[:, 0] - rel[seeds[0, 0], 0], rel[:, 1] - rel[seeds[0, 0], 1])
    L = np.ascontiguousarray(landmarks.xy, dtype=np.float64)
    sigma = sensor.noise
    max_r2 = math.inf if sensor.max_range is None else sensor.max_range**2
    min_r2 = 0.0 if sensor.min_range is None else sensor.min_range**2
    half_fov = -1.0 if sensor.half_fov is None else sensor.half_fov
    poses, lm, _ = pair_scan_kernel(
        L,
        np.ascontiguousarray(rel, dtype=np.float64),
        np.ascontiguousarray(z, dtype=np.float64),
        np.ascontiguousarray(base, dtype=np.float64),
        np.ascontiguousarray(seeds, dtype=np.int64),
        float(sigma),
        float(sensor.gate_chi2),
        float(max_r2),
        float(min_r2),
        MIN_RANGE_M**2,
        float(half_fov),
        PAIR_STEPS,
        int(min_hits) - 2,
        PAIR_MAX_OUT,
    )
    if poses.shape[0] == 0:
        return _none(int(z.size))
    poses, covs = refine_frames_kernel(L, rel, z, lm, poses, float(sigma), 6)
    return Candidates(poses, covs * cov_inflation, int(z.size), True)
