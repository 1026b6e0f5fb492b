"""The tracker's compiled kernel (numba): odometry integration.

:mod:`omniloc.track.motion` validates the input and says what it means; this is the one
implementation of composing pieces of constant body twist with their noise.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["integrate_pieces"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@njit(cache=True, error_model="numpy")
def integrate_pieces(
    dt: FloatArray, vx: FloatArray, vy: FloatArray, w: FloatArray, noise: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Compose pieces of constant body twist into ``(delta, Q)``.

    For each piece, in order: its exact motion (the SE(2) exponential of the twist times
    ``dt``: ``dtheta = w dt``, ``[dx, dy] = V(dtheta) [vx, vy] dt`` with
    ``V = [[sin/th, -(1-cos)/th], [(1-cos)/th, sin/th]]``), its noise in its start frame
    (diagonal: along x, across, heading; ``noise`` = along_per_m, across_per_m,
    turn_per_rad, turn_per_m, turn_per_s, along_per_s), then the composition
    ``T <- T (+) d`` with ``Q <- Jp Q Jp^T + Jd N Jd^T``. The total heading is not wrapped.
    """
    tx = 0.0
    ty = 0.0
    tt = 0.0
    Q = np.zeros((3, 3))
    Jp = np.eye(3)
    Jd = np.eye(3)
    N = np.zeros((3, 3))
    for k in range(dt.size):
        h = dt[k]
        if h <= 0.0:
            continue
        phi = w[k] * h
        if abs(phi) < 1e-9:
            a = 1.0 - phi * phi / 6.0
            b = 0.5 * phi
        else:
            a = np.sin(phi) / phi
            b = (1.0 - np.cos(phi)) / phi
        ux = vx[k] * h
        uy = vy[k] * h
        dx = a * ux - b * uy
        dy = b * ux + a * uy
        dist = np.sqrt(ux * ux + uy * uy)
        N[0, 0] = noise[0] * dist + noise[5] * h
        N[1, 1] = noise[1] * dist
        N[2, 2] = noise[2] * abs(phi) + noise[3] * dist + noise[4] * h
        c = np.cos(tt)
        s = np.sin(tt)
        Jp[0, 2] = -s * dx - c * dy
        Jp[1, 2] = c * dx - s * dy
        Jd[0, 0] = c
        Jd[0, 1] = -s
        Jd[1, 0] = s
        Jd[1, 1] = c
        Q = Jp @ Q @ Jp.T + Jd @ N @ Jd.T
        tx += c * dx - s * dy
        ty += s * dx + c * dy
        tt += phi
    out = np.array([tx, ty, tt])
    return out, 0.5 * (Q + Q.T)
