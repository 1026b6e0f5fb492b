"""What one frame of bearings says about a set of pose hypotheses, and how it moves them.

Every hypothesis is a Gaussian over the pose, ``N(mu, P)``. For a frame of bearings
``z_1..z_k`` it earns the log-likelihood ratio of the frame against "every bearing is clutter
and no landmark could be seen" (the baseline is the same for every hypothesis, so only the
differences matter) and is updated by it.

The model (multiple-hypothesis tracking, summed over the assignments)
---------------------------------------------------------------------
A landmark ``j`` is detected with probability ``d_j = p_detect * v_j``, where ``v_j`` is the
probability that it lies in the field of view given the pose's uncertainty (``Phi`` of how far
inside the edge its predicted bearing lies, in standard deviations) and 0 out of range (with
``occlusion``, times a factor for each nearer landmark whose line of sight it nearly
shares: one right behind another is not seen); spurious bearings are a Poisson clutter of
density ``kappa = clutter / fov`` per radian. Summed over the ways of assigning bearings to
landmarks (each bearing to at most one landmark, the landmarks of a map being rarely
contested by two bearings of one frame; ``exclusive`` weighs the sum in which no landmark
takes two bearings where they are), the ratio is

    prod_j (1 - d_j)  *  prod_i (1 + sum_j rho_j g_ij / kappa),    rho_j = d_j / (1 - d_j),

where ``g_ij`` is the Gaussian density of the innovation ``z_i - h_j(mu)`` with the predicted
variance ``S_j = H_j P H_j^T + sigma^2`` (a vague hypothesis pays for its vagueness). The
bearings are taken one at a time, each on the hypothesis already updated by the ones before
it (the chain rule of the frame's likelihood).

The update by one bearing is the mixture of its readings -- clutter (no change), or landmark
``j`` (an extended Kalman filter step) -- weighted by their posterior probabilities, collapsed
to one Gaussian by moment matching (probabilistic data association): a bearing that could be
either of two tubes of a cluster leaves the pose between them with a covariance that covers
both, rather than a confident guess.

All functions work on H hypotheses at once (``mu`` of shape ``(H, 3)``, ``P`` of shape
``(H, 3, 3)``); a frame costs ``O(H N k)`` with N landmarks and k bearings. On a large map
with a range (from ``CELL_MIN_LANDMARKS`` landmarks, where it pays) the hypotheses are
grouped by square cells and each group is handed only the landmarks of the 3 x 3 cells
around it, which hold every landmark it could see: a landmark out of range contributes
nothing, so the numbers are those of the whole map, bit for bit (:func:`_cell_groups`).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _pools
from .._kernels.track import frame_update_kernel
from ..sensor import SensorModel

__all__ = [
    "FrameModel",
    "Objects",
    "frame_update",
    "frame_update_clutter",
    "log_ratios",
    "log_ratios_clutter",
]

FloatArray = NDArray[np.float64]

#: Readings whose posterior probability is below this do not move the pose (a speed-up: their
#: share of the mixture is negligible).
MIN_READING_PROBABILITY = 1e-6

#: The covariance of exactly known poses (particles): one zero matrix, which the compiled
#: kernel reads for every pose when it does not update (``frame_update_kernel``; it is
#: never written).
_NO_COVARIANCE = np.zeros((1, 3, 3))

#: From this many hypotheses (or particles) on, a frame runs in two halves side by side (the
#: compiled kernel releases the GIL; each hypothesis is computed alone, so the results are
#: the same bit for bit). Below it, a thread's hand-off costs more than it saves.
PARALLEL_MIN = 512
#: Threads for the halves (at most the machine's cores).
THREADS = 2


def shared_pool() -> ThreadPoolExecutor | None:
    """The pool of one helper thread for a frame's other half (the caller runs one half;
    :func:`omniloc._pools.pool`), made at first use; None on a machine with one core."""
    if min(THREADS, _pools.CORES) < 2:
        return None
    return _pools.pool("omniloc-frame", 1)


#: Smallest distance (m) from a pose to a landmark for which a bearing is predicted.
MIN_RANGE_M = 1e-6


@dataclass(frozen=True)
class FrameModel:
    """The numbers of the sensor model that the frame likelihood needs.

    Attributes
    ----------
    sigma2 : float
        Bearing noise variance, rad^2.
    half_fov : float or None
        Half the field of view, radians (None: omnidirectional).
    max_range, min_range : float or None
        Range limits, metres.
    p_detect : float
        Probability that a landmark in view is reported.
    log_kappa : float
        ln of the clutter density, per radian.
    fresh : float
        Share of that density that is new clutter when the clutter has memory (1: none);
        the rest comes from the objects of the previous frame (:class:`Objects`).
    object_var : float
        Variance (rad^2) of an object's bearing from one frame to the next.
    core_share, core_sigma2 : float
        A bearing's error is ``(1 - core_share) N(0, sigma2) + core_share N(0,
        core_sigma2)`` (0: the single Gaussian).
    core_update : bool
        With a sharp core: its readings move the pose by their own Kalman gain (True) or
        only weigh it, the update taking a landmark's two readings together with the
        variance ``sigma2`` (False).
    update_scale : float
        Factor on the bearing variances in the Kalman update only, not in the weighing
        (1: the same model in both; ``1 / w`` updates as a likelihood tempered by ``w``
        would, :attr:`~omniloc.track.TrackerConfig.temper_update`).
    nonempty : bool
        The frames come from a log that lists only frames with a bearing: a frame with
        bearings is weighed by its likelihood given that it holds one
        (:attr:`~omniloc.track.TrackerConfig.nonempty_frames`).
    miss_weight : float
        Weight of each landmark in view that the frame did not report: it costs
        ``miss_weight * ln(1 - d)``, and a reading's odds are ``rho = d / (1 - d) **
        miss_weight``, so that a landmark reported still earns ``d`` times its density (1:
        the model as written above; :attr:`~omniloc.track.TrackerConfig.miss_weight`).
    exclusive : bool
        Each landmark explains at most one bearing of a frame: the frame's ratio is the sum
        over the assignments in which no landmark takes two bearings, each bearing's
        readings as the chain rule above computes them (the updates are unchanged). False:
        each bearing is weighed on its own, as the product above has it
        (:attr:`~omniloc.track.TrackerConfig.exclusive_landmarks`).
    occlusion : float
        Landmarks hide the ones behind them: a landmark's detection probability is
        multiplied, for each nearer landmark, by ``1 - exp(-l^2 / (2 occlusion^2))``, where
        ``l`` (m) is how far the line of sight to it passes beside the nearer one (0: no
        landmark hides another; :attr:`~omniloc.track.TrackerConfig.occlusion_width`).
    """

    sigma2: float
    half_fov: float | None
    max_range: float | None
    min_range: float | None
    p_detect: float
    log_kappa: float
    fresh: float = 1.0
    object_var: float = 0.0
    core_share: float = 0.0
    core_sigma2: float = 0.0
    core_update: bool = True
    update_scale: float = 1.0
    nonempty: bool = False
    miss_weight: float = 1.0
    exclusive: bool = False
    occlusion: float = 0.0

    @classmethod
    def of(cls, sensor: SensorModel, *, p_detect: float = 0.5, clutter: float = 0.5) -> FrameModel:
        """From a :class:`~omniloc.sensor.SensorModel`; ``p_detect`` and ``clutter`` (bearings
        per frame) are the values used when the sensor does not give them."""
        pd = sensor.p_detect if sensor.p_detect is not None else p_detect
        rate = sensor.clutter if sensor.clutter is not None else clutter
        return cls(
            sigma2=float(sensor.noise) ** 2,
            half_fov=sensor.half_fov,
            max_range=sensor.max_range,
            min_range=sensor.min_range,
            p_detect=float(min(max(pd, 1e-9), 1.0 - 1e-9)),
            log_kappa=math.log(max(rate, 1e-12) / sensor.fov_width),
        )


@dataclass(frozen=True)
class Objects:
    """Clutter with memory: the bearings of the previous frame that may be objects seen
    again (another robot stays at one bearing for seconds).

    Attributes
    ----------
    bearings : ndarray, shape (K,)
        Where they are now, radians in the current robot frame (the previous frame's
        bearings turned by the odometry since).
    weights : ndarray, shape (H, K)
        For each hypothesis, the expected number of times each is seen again in this frame
        (its posterior probability of having been clutter there, times the chance that an
        object persists and is seen again; 0 out of view).
    """

    bearings: FloatArray
    weights: FloatArray


def frame_update(
    mu: FloatArray,
    P: FloatArray,
    bearings: FloatArray,
    L: FloatArray,
    model: FrameModel,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Take one frame into H hypotheses.

    Parameters
    ----------
    mu : ndarray, shape (H, 3)
    P : ndarray, shape (H, 3, 3)
    bearings : ndarray, shape (k,)
        Radians, robot frame.
    L : ndarray, shape (N, 2)
        Landmarks, metres.
    model : FrameModel

    Returns
    -------
    mu, P : ndarray
        The updated hypotheses.
    log_ratio : ndarray, shape (H,)
        ln of the frame's likelihood ratio (see the module's docstring).
    explained : ndarray, shape (H,)
        Expected number of the frame's bearings that are landmarks (the sum of their
        posterior probabilities of not being clutter).
    """
    if mu.shape[0] == 0:
        return mu.copy(), P.copy(), np.zeros(0), np.zeros(0)
    return _kernel(mu, P, bearings, L, model, update=True)[:4]


def frame_update_clutter(
    mu: FloatArray,
    P: FloatArray,
    bearings: FloatArray,
    L: FloatArray,
    model: FrameModel,
    objects: Objects | None,
    *,
    parallel: bool = True,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`frame_update` with clutter that has memory (``objects``, None: none); also
    returns each bearing's posterior probability of being clutter, shape (H, k).
    ``parallel`` False: on the calling thread alone, however many hypotheses (for a caller
    that runs parts of its work side by side already, with :func:`shared_pool`)."""
    if mu.shape[0] == 0:
        k = np.asarray(bearings).size
        return mu.copy(), P.copy(), np.zeros(0), np.zeros(0), np.zeros((0, k))
    return _kernel(mu, P, bearings, L, model, update=True, objects=objects, parallel=parallel)


def log_ratios_clutter(
    poses: FloatArray,
    bearings: FloatArray,
    L: FloatArray,
    model: FrameModel,
    objects: Objects | None,
) -> tuple[FloatArray, FloatArray]:
    """:func:`log_ratios` with clutter that has memory; also returns each bearing's
    posterior probability of being clutter at each pose, shape (M, k)."""
    if poses.shape[0] == 0:
        return np.zeros(0), np.zeros((0, np.asarray(bearings).size))
    out = _kernel(poses, _NO_COVARIANCE, bearings, L, model, update=False, objects=objects)
    return out[2], out[4]


def _kernel(
    mu: FloatArray,
    P: FloatArray,
    bearings: FloatArray,
    L: FloatArray,
    model: FrameModel,
    *,
    update: bool,
    objects: Objects | None = None,
    parallel: bool = True,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The compiled kernel on the model's numbers (:func:`frame_update_kernel`), on the
    whole map or, on a large one with a range, cell by cell (:func:`_by_cells`)."""
    if objects is None or objects.bearings.size == 0 or model.object_var <= 0.0:
        ob, ow = np.zeros(0), np.zeros((mu.shape[0], 0))
    else:
        ob = np.ascontiguousarray(objects.bearings, dtype=np.float64).reshape(-1)
        ow = np.ascontiguousarray(objects.weights, dtype=np.float64)
        if ow.shape != (mu.shape[0], ob.size):
            raise ValueError(
                f"object weights of shape {ow.shape} for {mu.shape[0]} poses and {ob.size} objects"
            )
    mu = np.ascontiguousarray(mu, dtype=np.float64)
    P = np.ascontiguousarray(P, dtype=np.float64)
    rest = (
        np.ascontiguousarray(np.asarray(bearings, dtype=np.float64).reshape(-1)),
        np.ascontiguousarray(L, dtype=np.float64),
        model.sigma2,
        math.exp(model.log_kappa),
        model.p_detect,
        -1.0 if model.half_fov is None else model.half_fov,
        math.inf if model.max_range is None else model.max_range**2,
        0.0 if model.min_range is None else model.min_range**2,
        MIN_RANGE_M**2,
        MIN_READING_PROBABILITY,
        update,
        model.fresh,
        model.core_share,
        model.core_sigma2,
        model.core_update,
        model.update_scale,
        model.nonempty,
        model.miss_weight,
        model.exclusive,
        model.occlusion,
        ob,
    )
    var = model.object_var if ob.size else 1.0
    if model.max_range is not None:
        margin = CELL_REACH_SHARE * model.max_range if update else 0.0
        groups = _cell_groups(mu, rest[1], model.max_range, margin)
        if groups is not None:
            return _by_cells(mu, P, rest, ow, var, groups, update, margin, parallel)
    return _scan(mu, P, rest, ow, var, update, parallel)[:5]


def _scan(
    mu: FloatArray,
    P: FloatArray,
    rest: tuple[Any, ...],
    ow: FloatArray,
    var: float,
    update: bool,
    parallel: bool = True,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`frame_update_kernel` on the map of ``rest``: in two halves side by side from
    ``PARALLEL_MIN`` hypotheses on."""
    H = mu.shape[0]
    pool = shared_pool() if parallel and H >= PARALLEL_MIN else None
    if pool is None:
        whole: tuple[Any, ...] = (mu, P, *rest, ow, var)
        return frame_update_kernel(*whole)
    half = H // 2
    # (Exactly known poses: P is the one zero covariance, shared by both halves; mu and P
    # come back as they were given.)
    Pa, Pb = (P[:half], P[half:]) if update else (P, P)
    lower: tuple[Any, ...] = (mu[:half], Pa, *rest, ow[:half], var)
    upper: tuple[Any, ...] = (mu[half:], Pb, *rest, ow[half:], var)
    first = pool.submit(frame_update_kernel, *lower)
    second = frame_update_kernel(*upper)
    a = first.result()
    return (
        np.concatenate([a[0], second[0]]) if update else mu,
        np.concatenate([a[1], second[1]]) if update else P,
        np.concatenate([a[2], second[2]]),
        np.concatenate([a[3], second[3]]),
        np.concatenate([a[4], second[4]]),
        np.concatenate([a[5], second[5]]),
    )


#: A map of at least this many landmarks, with a range, has its exactly known poses
#: (particles) weighed cell by cell (:func:`_cell_groups`); a smaller one is scanned whole.
CELL_MIN_LANDMARKS = 256
#: The cost of one cell's call of the compiled kernel (with its gathering and scattering),
#: in pose-landmark pairs of the whole scan, most of which are out of range and rejected in
#: about 1.6 ns (2026-12-05: a cell's call costs about 30 us, so 20,000 pairs): a grouping
#: that does not save more than its calls cost is not used (a map of 1,000 landmarks over
#: 100 m x 100 m, where it would save nothing measurable, is scanned whole).
CELL_CALL_PAIRS = 20_000
#: At most this many cells across the landmarks on either axis (beyond it, a map spread
#: over a huge area with a short range: the plain scan).
CELL_MAX_SPAN = 1_000_000
#: At most this many cells' lists of landmarks are kept between frames.
CELL_NEAR_KEPT = 65_536
#: Hypotheses (with a covariance, moved by each bearing) are handed the landmarks within
#: their range plus this share of it; one that moves farther within a frame is weighed
#: again against the whole map.
CELL_REACH_SHARE = 0.5


class _Cells:
    """A map's landmarks bucketed in square cells of side ``side`` (from the landmarks'
    lower corner), with, for a cell, the landmarks of the 3 x 3 cells around it in
    ascending order (made at first use)."""

    def __init__(self, L: FloatArray, side: float) -> None:
        self.side = side
        self.lo = L.min(axis=0)
        span = (L.max(axis=0) - self.lo) / side
        self.nx, self.ny = int(span[0]) + 1, int(span[1]) + 1
        c = np.floor((L - self.lo) / side).astype(np.int64)
        # (Cells are numbered with a border of one all round: a pose's cell is clipped to
        # it, and no landmark lies there, so that a cell's neighbours never wrap.)
        key = (c[:, 0] + 1) * (self.ny + 2) + (c[:, 1] + 1)
        self._order = np.argsort(key, kind="stable")
        self._keys = key[self._order]
        self._near: dict[int, NDArray[np.int64]] = {}
        w = self.ny + 2
        self._offsets = np.array([dx * w + dy for dx in (-1, 0, 1) for dy in (-1, 0, 1)])

    def keys(self, xy: FloatArray) -> NDArray[np.int64]:
        """The cell of each position, clipped to the border around the landmarks' cells
        (a position beyond the border has no landmark within a cell's width, and the
        border cell's neighbours hold none that is in range of it either)."""
        c = np.floor((xy - self.lo) / self.side)
        cx = np.clip(c[:, 0], -1, self.nx).astype(np.int64) + 1
        cy = np.clip(c[:, 1], -1, self.ny).astype(np.int64) + 1
        return cx * (self.ny + 2) + cy

    def near(self, key: int) -> NDArray[np.int64]:
        """The landmarks of the 3 x 3 cells around cell ``key``, in ascending order."""
        got = self._near.get(key)
        if got is None:
            k = key + self._offsets
            a = np.searchsorted(self._keys, k, side="left").tolist()
            b = np.searchsorted(self._keys, k, side="right").tolist()
            got = np.sort(np.concatenate([self._order[i:j] for i, j in zip(a, b, strict=True)]))
            if len(self._near) >= CELL_NEAR_KEPT:
                self._near.clear()  # (particles spread over a map of very many cells)
            self._near[key] = got
        return got


#: The last map's cells (a copy of its landmarks, and its cells by their side: the
#: particles' and the hypotheses'): a tracker weighs every frame against one map.
_cells_cache: tuple[FloatArray, dict[float, _Cells]] | None = None


def _cells_of(L: FloatArray, side: float) -> _Cells:
    """The cells of map ``L`` of side ``side`` (made once for the same map)."""
    global _cells_cache
    cached = _cells_cache
    if cached is None or not np.array_equal(cached[0], L):
        cached = (L.copy(), {})
        _cells_cache = cached
    by_side = cached[1]
    cells = by_side.get(side)
    if cells is None:
        if len(by_side) >= 4:
            by_side.clear()  # (more sides than a tracker uses: the model changed)
        cells = by_side[side] = _Cells(L, side)
    return cells


def _cell_groups(
    poses: FloatArray, L: FloatArray, max_range: float, margin: float = 0.0
) -> list[tuple[NDArray[np.int64], NDArray[np.int64]]] | None:
    """The ``poses`` grouped by square cells ``max_range + margin`` wide, each group with
    the landmarks of the 3 x 3 cells around its cell, in ascending order: every landmark
    within ``max_range + margin`` of a pose of the group is among them. The kernel gives a landmark
    out of range nothing but its zero detection probability, and sums the others in the
    order of the map, so weighing a group against its landmarks gives the same numbers as
    against the whole map, bit for bit. None where a grouping does not pay (a small map, a
    map spread over a huge area, or too few poses per cell: see ``CELL_*``)."""
    N, H = L.shape[0], poses.shape[0]
    if N < CELL_MIN_LANDMARKS or H == 0 or not (math.isfinite(max_range) and max_range > 0.0):
        return None
    side = (max_range + margin) * (1.0 + 1e-6) + 1e-9
    span = (L.max(axis=0) - L.min(axis=0)) / side
    if not (np.isfinite(span).all() and span.max() < CELL_MAX_SPAN):
        return None
    if not np.isfinite(poses[:, :2]).all():
        return None  # (a pose that is not a number: the whole scan says what it gives)
    cells = _cells_of(L, side)
    pkey = cells.keys(poses[:, :2])
    ukeys, pinv = np.unique(pkey, return_inverse=True)
    porder = np.argsort(pinv, kind="stable")
    pstart = np.searchsorted(pinv[porder], np.arange(ukeys.size + 1)).tolist()
    groups = []
    cost = 0
    for g, key in enumerate(ukeys.tolist()):
        lm = cells.near(key)
        idx = porder[pstart[g] : pstart[g + 1]]
        groups.append((idx, lm))
        cost += idx.size * lm.size + CELL_CALL_PAIRS
    if cost >= H * N:
        return None
    return groups


def _by_cells(
    mu: FloatArray,
    P: FloatArray,
    rest: tuple[Any, ...],
    ow: FloatArray,
    var: float,
    groups: list[tuple[NDArray[np.int64], NDArray[np.int64]]],
    update: bool,
    margin: float,
    parallel: bool = True,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`_kernel` cell by cell (``groups`` from :func:`_cell_groups`): the same
    numbers, bit for bit. With many poses the cells are shared between the caller and the
    pool's thread, each taking about half the work. A hypothesis that moved farther than
    ``margin`` before a bearing was predicted from it may have had landmarks in range that
    its cell's list does not hold: it is weighed again against the whole map."""
    H, k = mu.shape[0], int(np.asarray(rest[0]).size)
    L = np.asarray(rest[1])
    log_ratio, explained, post = np.zeros(H), np.zeros(H), np.zeros((H, k))
    mu_out, P_out = (mu.copy(), P.copy()) if update else (mu, P)
    far = np.zeros(H, dtype=bool)

    def run(part: list[tuple[NDArray[np.int64], NDArray[np.int64]]]) -> None:
        for idx, lm in part:
            # (The whole scan's arguments, with the cell's poses, landmarks and memory.)
            args: tuple[Any, ...] = (
                np.ascontiguousarray(mu[idx]),
                np.ascontiguousarray(P[idx]) if update else P,
                rest[0],
                np.ascontiguousarray(L[lm]),
                *rest[2:],
                np.ascontiguousarray(ow[idx]),
                var,
            )
            out = frame_update_kernel(*args)
            log_ratio[idx], explained[idx], post[idx] = out[2], out[3], out[4]
            if update:
                mu_out[idx], P_out[idx] = out[0], out[1]
                far[idx] = ~(out[5] <= margin)

    pool = shared_pool() if parallel and H >= PARALLEL_MIN else None
    if pool is None:
        run(groups)
    else:
        work = np.cumsum([idx.size * lm.size + CELL_CALL_PAIRS for idx, lm in groups])
        cut = int(np.searchsorted(work, work[-1] / 2.0)) + 1
        first = pool.submit(run, groups[:cut])
        run(groups[cut:])
        first.result()
    if far.any():
        idx = np.flatnonzero(far)
        out = _scan(
            np.ascontiguousarray(mu[idx]),
            np.ascontiguousarray(P[idx]),
            rest,
            ow[idx],
            var,
            True,
            parallel,
        )
        mu_out[idx], P_out[idx] = out[0], out[1]
        log_ratio[idx], explained[idx], post[idx] = out[2], out[3], out[4]
    return mu_out, P_out, log_ratio, explained, post


def log_ratios(
    poses: FloatArray, bearings: FloatArray, L: FloatArray, model: FrameModel
) -> FloatArray:
    """ln of the frame's likelihood ratio at each of M exactly known poses (particles).

    Parameters
    ----------
    poses : ndarray, shape (M, 3)
    bearings : ndarray, shape (k,)
    L : ndarray, shape (N, 2)
    model : FrameModel

    Returns
    -------
    ndarray, shape (M,)
    """
    if poses.shape[0] == 0:
        return np.zeros(0)
    # An exactly known pose is a hypothesis without covariance, which no bearing moves.
    return _kernel(poses, _NO_COVARIANCE, bearings, L, model, update=False)[2]
