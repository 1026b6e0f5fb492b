"""Merging equal poses, compiled: the greedy pass behind :mod:`omniloc.search.scoring`."""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import form3, inv3, wrap_float

__all__ = ["merge"]


@njit(cache=True, error_model="numpy")
def _form(c: NDArray[np.float64], d0: float, d1: float, d2: float) -> float:
    """``d^T c d`` for a symmetric 3x3 ``c``."""
    return form3(c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2], d0, d1, d2)


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
    """
    K = rank.shape[0]
    keep = np.empty(K, np.int64)
    owner = np.arange(poses.shape[0])
    tr = np.empty(poses.shape[0])
    for i in range(poses.shape[0]):
        tr[i] = cov[i, 0, 0] + cov[i, 1, 1] + cov[i, 2, 2]
    nk = 0
    for a in range(K):
        i = rank[a]
        xi, yi, ti = poses[i, 0], poses[i, 1], poses[i, 2]
        # No test below passes a kept pose farther than this in x, y (the ellipsoid test's
        # bound with tr[i] >= min(tr[i], tr[k])): such a pose is passed over at once.
        reach = max(place_xy * place_xy, near_chi2 * tr[i] * (1.0 + 1e-9), 2e-12)
        for b in range(nk):
            k = keep[b]
            d0 = poses[k, 0] - xi
            d1 = poses[k, 1] - yi
            if d0 * d0 + d1 * d1 > reach:
                continue
            d2 = wrap_float(poses[k, 2] - ti)
            if abs(d0) < 1e-6 and abs(d1) < 1e-6 and abs(d2) < 1e-6:
                owner[i] = k
                break
            dd = d0 * d0 + d1 * d1 + d2 * d2
            # d^T C^-1 d >= |d|^2 / trace(C): beyond that no ellipsoid reaches.
            if dd <= near_chi2 * min(tr[i], tr[k]) * (1.0 + 1e-9):
                if (
                    _form(inv[i], d0, d1, d2) <= near_chi2
                    and _form(inv[k], d0, d1, d2) <= near_chi2
                ):
                    owner[i] = k
                    break
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
                    owner[i] = k
                    break
        if owner[i] == i:
            keep[nk] = i
            nk += 1
    return keep[:nk].copy(), owner
