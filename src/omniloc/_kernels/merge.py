"""Merging equal poses, compiled: the greedy pass behind :mod:`omniloc.search.scoring`."""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import wrap_angle

__all__ = ["merge"]


@njit(cache=True, error_model="numpy")
def merge(
    rank: NDArray[np.int64],
    poses: NDArray[np.float64],
    inv: NDArray[np.float64],
    reach2: NDArray[np.float64],
    same_chi2: float,
) -> NDArray[np.int64]:
    """Greedy merge in rank order; returns the indices kept.

    Pose ``rank[a]`` is dropped when it is within a micrometre (and micro-radian) of a kept
    one, or when each of the two lies inside the other's ellipsoid ``d^T inv d <= same_chi2``
    (``inv`` the inverse covariances). ``reach2[i]`` bounds the squared Euclidean gap (x, y,
    theta) at which pose i can still be that close in its own metric (``same_chi2`` times the
    trace of its covariance, which bounds the largest eigenvalue), so most pairs are passed
    over before the quadratic forms. A form that is not a number (a covariance that is not
    finite) merges nothing.
    """
    K = rank.shape[0]
    keep = np.empty(K, np.int64)
    nk = 0
    for a in range(K):
        i = rank[a]
        xi, yi, ti = poses[i, 0], poses[i, 1], poses[i, 2]
        dup = False
        for b in range(nk):
            k = keep[b]
            d0 = poses[k, 0] - xi
            d1 = poses[k, 1] - yi
            d2 = wrap_angle(poses[k, 2] - ti)
            if abs(d0) < 1e-6 and abs(d1) < 1e-6 and abs(d2) < 1e-6:
                dup = True
                break
            dd = d0 * d0 + d1 * d1 + d2 * d2
            if dd > reach2[i] or dd > reach2[k]:
                continue
            for j in (i, k):
                q = (
                    inv[j, 0, 0] * d0 * d0
                    + inv[j, 1, 1] * d1 * d1
                    + inv[j, 2, 2] * d2 * d2
                    + (inv[j, 0, 1] + inv[j, 1, 0]) * d0 * d1
                    + (inv[j, 0, 2] + inv[j, 2, 0]) * d0 * d2
                    + (inv[j, 1, 2] + inv[j, 2, 1]) * d1 * d2
                )
                if not q <= same_chi2:
                    break
            else:
                dup = True
                break
        if not dup:
            keep[nk] = i
            nk += 1
    return keep[:nk].copy()
