"""Merging equal poses, compiled: the greedy pass behind :mod:`omniloc.search.scoring`."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import form3, inv3, wrap_float

__all__ = ["merge"]


@njit(cache=True, error_model="numpy")
def _form(c: NDArray[np.float64], d0: float, d1: float, d2: float) -> float:
    """``d^T c d`` for a symmetric 3x3 ``c``."""
    return form3(c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2], d0, d1, d2)


@njit(cache=True, error_model="numpy", inline="always")
def _joins(
    i: int,
    k: int,
    poses: NDArray[np.float64],
    cov: NDArray[np.float64],
    inv: NDArray[np.float64],
    tr: NDArray[np.float64],
    near_chi2: float,
    place_chi2: float,
    place_xy: float,
    place_theta: float,
) -> bool:
    """Whether pose ``i`` merges into the kept pose ``k`` (the tests of :func:`merge`
    after the reach's, which the caller makes)."""
    d0 = poses[k, 0] - poses[i, 0]
    d1 = poses[k, 1] - poses[i, 1]
    d2 = wrap_float(poses[k, 2] - poses[i, 2])
    if abs(d0) < 1e-6 and abs(d1) < 1e-6 and abs(d2) < 1e-6:
        return True
    dd = d0 * d0 + d1 * d1 + d2 * d2
    # d^T C^-1 d >= |d|^2 / trace(C): beyond that no ellipsoid reaches.
    if dd <= near_chi2 * min(tr[i], tr[k]) * (1.0 + 1e-9):
        if _form(inv[i], d0, d1, d2) <= near_chi2 and _form(inv[k], d0, d1, d2) <= near_chi2:
            return True
    if d0 * d0 + d1 * d1 <= place_xy * place_xy and abs(d2) <= place_theta:
        ci, ck = cov[i], cov[k]
        c00, c01, c02, c11, c12, c22, _ = inv3(
            ci[0, 0] + ck[0, 0],
            ci[0, 1] + ck[0, 1],
            ci[0, 2] + ck[0, 2],
            ci[1, 1] + ck[1, 1],
            ci[1, 2] + ck[1, 2],
            ci[2, 2] + ck[2, 2],
            1.0,
            0.0,
        )
        if form3(c00, c01, c02, c11, c12, c22, d0, d1, d2) <= place_chi2:
            return True
    return False


#: Cells of the merge's grid per pose, at most (a wider cell when the poses spread further).
CELLS_PER_POSE = 4


@njit(cache=True, error_model="numpy")
def merge(
    rank: NDArray[np.int64],
    poses: NDArray[np.float64],
    cov: NDArray[np.float64],
    inv: NDArray[np.float64],
    near_chi2: float,
    place_chi2: float,
    place_xy: float,
    place_theta: float,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Greedy merge in rank order; returns the indices kept and, for every pose, the kept
    one it merged into (itself when kept).

    Pose ``i = rank[a]`` merges into the first kept pose ``k`` with gap ``d`` (x, y, theta)
    when they are within a micrometre (and a micro-radian), or each lies inside the other's
    ellipsoid ``d^T C^-1 d <= near_chi2`` (``inv``: the inverse covariances), or they are
    one place: closer than ``place_xy`` metres and ``place_theta`` radians, and the data
    cannot tell them apart (``d^T (C_i + C_k)^-1 d <= place_chi2``). A form that is not a
    number (a covariance that is not finite) merges nothing.

    No test passes a kept pose farther in x, y than ``i``'s reach (the ellipsoid test's
    bound with ``tr[i] >= min(tr[i], tr[k])``), so the kept poses are filed in a grid of
    square cells: a pose is tested only against the kept poses of the cells its reach
    touches (joining the one kept first of those it joins), or, when those cells are more
    than the kept poses, against every kept pose in order; the same answer as testing
    every kept pose in order. (A tracker's window search on MRCLAM: 1,900 solutions, 750
    kept, a third less time; 8,000 solutions spread over 100 m, a tenth.)
    """
    K = rank.shape[0]
    N = poses.shape[0]
    keep = np.empty(K, np.int64)
    owner = np.arange(N)
    tr = np.empty(N)
    reach = np.empty(N)
    finite = True
    for i in range(N):
        tr[i] = cov[i, 0, 0] + cov[i, 1, 1] + cov[i, 2, 2]
        reach[i] = max(place_xy * place_xy, near_chi2 * tr[i] * (1.0 + 1e-9), 2e-12)
        if not (np.isfinite(reach[i]) and np.isfinite(poses[i, 0]) and np.isfinite(poses[i, 1])):
            finite = False
    # The grid: cells as wide as the median reach, or wider so that there are at most
    # CELLS_PER_POSE cells a pose (none when a pose, a reach or the poses' spread is not
    # finite: every pose is then tested against every kept one).
    nx = ny = 1
    size = 1.0
    x0 = y0 = 0.0
    if finite and N > 0:
        x0, x1 = poses[:, 0].min(), poses[:, 0].max()
        y0, y1 = poses[:, 1].min(), poses[:, 1].max()
        wx, wy = x1 - x0, y1 - y0
        cells = CELLS_PER_POSE * N + 64.0
        size = max(math.sqrt(np.median(reach)), math.sqrt(wx * wy / cells), 1e-9)
        finite = math.isfinite(wx) and math.isfinite(wy) and math.isfinite(size)
        # (Counted in floats: poses millions of cells apart must not overflow the count.)
        while finite and (wx / size + 1.0) * (wy / size + 1.0) > cells:
            size *= 2.0
            finite = math.isfinite(size)
        if finite:
            nx = int(wx / size) + 1
            ny = int(wy / size) + 1
    head = np.full(nx * ny, -1, np.int64)
    tail = np.full(nx * ny, -1, np.int64)
    after = np.full(K, -1, np.int64)  # the next kept pose of the same cell
    nk = 0
    for a in range(K):
        i = rank[a]
        ci = cx = cy = 0
        if finite:
            cx = min(int((poses[i, 0] - x0) / size), nx - 1)
            cy = min(int((poses[i, 1] - y0) / size), ny - 1)
            ci = cy * nx + cx
        xi, yi, ri = poses[i, 0], poses[i, 1], reach[i]
        # Kept poses within its reach lie within r cells of its own in x and in y (the
        # millionth of a cell to spare covers the rounding of the cells); -1: no grid.
        r = -1
        if finite:
            cells_out = math.sqrt(ri) / size + 1e-6
            if cells_out < nx + ny:
                r = int(cells_out) + 1
        if r >= 0 and (2 * r + 1) ** 2 < nk:
            # The first kept pose it joins is the one of least index among all it joins.
            first = nk
            for gy in range(max(cy - r, 0), min(cy + r + 1, ny)):
                for gx in range(max(cx - r, 0), min(cx + r + 1, nx)):
                    b = head[gy * nx + gx]
                    while 0 <= b < first:
                        k = keep[b]
                        d0 = poses[k, 0] - xi
                        d1 = poses[k, 1] - yi
                        if not d0 * d0 + d1 * d1 > ri and _joins(
                            i, k, poses, cov, inv, tr,
                            near_chi2, place_chi2, place_xy, place_theta,
                        ):  # fmt: skip
                            first = b
                            break
                        b = after[b]
            if first < nk:
                owner[i] = keep[first]
        else:
            for b in range(nk):
                k = keep[b]
                d0 = poses[k, 0] - xi
                d1 = poses[k, 1] - yi
                # (The reach's test here, not in _joins: a call per kept pose, with its
                # arrays' reference counts, cost ten times the loop.)
                if not d0 * d0 + d1 * d1 > ri and _joins(
                    i, k, poses, cov, inv, tr,
                    near_chi2, place_chi2, place_xy, place_theta,
                ):  # fmt: skip
                    owner[i] = keep[b]
                    break
        if owner[i] == i:
            keep[nk] = i
            if tail[ci] >= 0:
                after[tail[ci]] = nk
            else:
                head[ci] = nk
            tail[ci] = nk
            nk += 1
    return keep[:nk].copy(), owner
