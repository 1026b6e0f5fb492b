"""The likelihood of bearing errors whose biases are shared
(:func:`omniloc.evaluate.bearing_errors.fit_shared_biases`).

Each error is a bias common to every landmark of the run, plus its landmark's own bias (both
Ornstein-Uhlenbeck processes: a stationary sd and a correlation time), plus an offset common
to the bearings of one frame and drawn afresh at each frame, plus white noise. A Kalman
filter per run over the common bias and the landmarks' biases gives minus the
log-likelihood of the errors, frame after frame.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@njit(cache=True, error_model="numpy")
def shared_bias_nll(
    params: FloatArray,
    run_off: IntArray,
    state: IntArray,
    frame_t: FloatArray,
    frame_off: IntArray,
    cols: IntArray,
    errors: FloatArray,
) -> float:
    """Minus the log-likelihood of the errors under the shared-bias model.

    ``params``: common sd, common time constant, landmark sd, landmark time constant,
    frame sd, white sd (radians and seconds). Run ``r`` holds frames ``run_off[r]`` to
    ``run_off[r + 1]`` and a state of ``state[r]`` entries (the common bias, then one bias
    per landmark of the run); frame ``f`` (time ``frame_t[f]``) holds the errors
    ``frame_off[f]`` to ``frame_off[f + 1]``, each with its landmark's column of the state
    (``cols``, from 1). Returns inf where a frame's covariance is not positive definite."""
    sc, tc, sb, tb, sf, sw = params[0], params[1], params[2], params[3], params[4], params[5]
    total = 0.0
    log2pi = math.log(2.0 * math.pi)
    for r in range(run_off.shape[0] - 1):
        n = state[r]
        q = np.full(n, sb * sb)
        q[0] = sc * sc
        tau = np.full(n, tb)
        tau[0] = tc
        m = np.zeros(n)
        P = np.diag(q)
        a = np.empty(n)
        prev = frame_t[run_off[r]] if run_off[r + 1] > run_off[r] else 0.0
        for f in range(run_off[r], run_off[r + 1]):
            dt = frame_t[f] - prev
            prev = frame_t[f]
            for i in range(n):
                a[i] = math.exp(-dt / tau[i])
                m[i] *= a[i]
            for i in range(n):
                for j in range(n):
                    P[i, j] *= a[i] * a[j]
                P[i, i] += q[i] * (1.0 - a[i] * a[i])
            lo, hi = frame_off[f], frame_off[f + 1]
            k = hi - lo
            if k == 0:
                continue
            # P H^T (n, k): column j is P[:, 0] + P[:, cols[j]].
            PHt = np.empty((n, k))
            for j in range(k):
                c = cols[lo + j]
                for i in range(n):
                    PHt[i, j] = P[i, 0] + P[i, c]
            S = np.empty((k, k))
            r_ = np.empty(k)
            for i in range(k):
                ci = cols[lo + i]
                for j in range(k):
                    S[i, j] = PHt[0, j] + PHt[ci, j] + sf * sf
                S[i, i] += sw * sw
                r_[i] = errors[lo + i] - (m[0] + m[ci])
            S = 0.5 * (S + S.T)
            # Cholesky by hand (numba's raises on a matrix that is not positive definite).
            L = np.zeros((k, k))
            for i in range(k):
                for j in range(i + 1):
                    acc = S[i, j]
                    for t in range(j):
                        acc -= L[i, t] * L[j, t]
                    if i == j:
                        if not acc > 0.0:
                            return math.inf
                        L[i, i] = math.sqrt(acc)
                    else:
                        L[i, j] = acc / L[j, j]
            # z = L^-1 r; the gain K = P H^T S^-1 through the same factor.
            z = np.empty(k)
            for i in range(k):
                acc = r_[i]
                for t in range(i):
                    acc -= L[i, t] * z[t]
                z[i] = acc / L[i, i]
            quad = 0.0
            logdet = 0.0
            for i in range(k):
                quad += z[i] * z[i]
                logdet += math.log(L[i, i])
            total += 0.5 * quad + logdet + 0.5 * k * log2pi
            # W = P H^T L^-T (n, k): then K r = W z and K H P = W W^T.
            W = np.empty((n, k))
            for i in range(n):
                for j in range(k):
                    acc = PHt[i, j]
                    for t in range(j):
                        acc -= W[i, t] * L[j, t]
                    W[i, j] = acc / L[j, j]
            for i in range(n):
                acc = 0.0
                for j in range(k):
                    acc += W[i, j] * z[j]
                m[i] += acc
            for i in range(n):
                for j in range(n):
                    acc = 0.0
                    for t in range(k):
                        acc += W[i, t] * W[j, t]
                    P[i, j] -= acc
            P = 0.5 * (P + P.T)
    return total
