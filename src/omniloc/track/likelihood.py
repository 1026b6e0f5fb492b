"""What one frame of bearings says about a set of pose hypotheses, and how it moves them.

Every hypothesis is a Gaussian over the pose, ``N(mu, P)``. For a frame of bearings
``z_1..z_k`` it earns the log-likelihood ratio of the frame against "every bearing is clutter
and no landmark could be seen" (the baseline is the same for every hypothesis, so only the
differences matter) and is updated by it.

The model (multiple-hypothesis tracking, summed over the assignments)
---------------------------------------------------------------------
A landmark ``j`` is detected with probability ``d_j = p_detect * v_j``, where ``v_j`` is the
probability that it lies in the field of view given the pose's uncertainty (``Phi`` of how far
inside the edge its predicted bearing lies, in standard deviations) and 0 out of range;
spurious bearings are a Poisson clutter of density ``kappa = clutter / fov`` per radian. Summed
over the ways of assigning bearings to landmarks (each bearing to at most one landmark, the
landmarks of a map being rarely contested by two bearings of one frame), the ratio is

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
``(H, 3, 3)``); a frame costs ``O(H N k)`` with N landmarks and k bearings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from ..angles import wrap
from ..sensor import SensorModel

__all__ = ["FrameModel", "frame_update", "log_ratios"]

FloatArray = NDArray[np.float64]

#: Readings whose posterior probability is below this do not move the pose (a speed-up: their
#: share of the mixture is negligible).
MIN_READING_PROBABILITY = 1e-6

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
    """

    sigma2: float
    half_fov: float | None
    max_range: float | None
    min_range: float | None
    p_detect: float
    log_kappa: float

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


def _predict(
    mu: FloatArray, P: FloatArray | None, L: FloatArray, model: FrameModel
) -> tuple[FloatArray, FloatArray | None, FloatArray, FloatArray]:
    """Predicted bearings (H, N), their Jacobians (H, N, 3) (None without ``P``), their
    variances from the pose (H, N) and the detection probabilities (H, N)."""
    dx = L[None, :, 0] - mu[:, None, 0]
    dy = L[None, :, 1] - mu[:, None, 1]
    q = np.maximum(dx * dx + dy * dy, MIN_RANGE_M**2)
    h = np.asarray(wrap(np.arctan2(dy, dx) - mu[:, None, 2]))
    if P is None:
        J = None
        var = np.zeros_like(h)
    else:
        J = np.empty((*h.shape, 3))
        J[..., 0] = dy / q
        J[..., 1] = -dx / q
        J[..., 2] = -1.0
        var = np.maximum(np.einsum("hni,hij,hnj->hn", J, P, J), 0.0)
    if model.half_fov is None:
        vis = np.ones_like(h)
    else:
        sd = np.sqrt(var) + 1e-9
        vis = ndtr((model.half_fov - np.abs(h)) / sd)
    if model.max_range is not None:
        vis = vis * (q <= model.max_range**2)
    if model.min_range is not None:
        vis = vis * (q >= model.min_range**2)
    return h, J, var, model.p_detect * vis


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
    mu = mu.copy()
    P = P.copy()
    H = mu.shape[0]
    log_ratio = np.zeros(H)
    explained = np.zeros(H)
    if H == 0:
        return mu, P, log_ratio, explained
    kappa = math.exp(model.log_kappa)
    _, _, _, d = _predict(mu, P, L, model)
    log_ratio += np.log1p(-np.minimum(d, 1.0 - 1e-12)).sum(axis=1)
    for z in np.asarray(bearings, dtype=np.float64).reshape(-1):
        h, J, var, d = _predict(mu, P, L, model)
        assert J is not None
        S = var + model.sigma2
        nu = np.asarray(wrap(z - h))
        rho = d / np.maximum(1.0 - d, 1e-12)
        a = rho * np.exp(-0.5 * nu * nu / S) / np.sqrt(2.0 * math.pi * S) / kappa  # (H, N)
        total = 1.0 + a.sum(axis=1)
        log_ratio += np.log(total)
        beta = a / total[:, None]
        explained += 1.0 - 1.0 / total
        use = beta > MIN_READING_PROBABILITY
        if not use.any():
            continue
        # Kalman step per reading: K = P J^T / S, delta = K nu, P_j = P - K S K^T.
        PJ = np.einsum("hij,hnj->hni", P, J)  # (H, N, 3)
        K = PJ / S[..., None]
        delta = K * nu[..., None]
        delta[~use] = 0.0
        b = np.where(use, beta, 0.0)
        mean = np.einsum("hn,hni->hi", b, delta)
        # Covariance of the mixture (clutter: P unchanged): P - sum_j b_j K_j S_j K_j^T
        # plus the spread of the readings' means about their mean.
        shrink = np.einsum("hn,hni,hnj->hij", b * S, K, K)
        spread = np.einsum("hn,hni,hnj->hij", b, delta, delta) - np.einsum("hi,hj->hij", mean, mean)
        P = P - shrink + spread
        P = 0.5 * (P + np.swapaxes(P, 1, 2))
        mu = mu + mean
        mu[:, 2] = np.asarray(wrap(mu[:, 2]))
    return mu, P, log_ratio, explained


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
    h, _, _, d = _predict(poses, None, L, model)
    kappa = math.exp(model.log_kappa)
    lr = np.log1p(-np.minimum(d, 1.0 - 1e-12)).sum(axis=1)
    rho = d / np.maximum(1.0 - d, 1e-12)
    c = 1.0 / math.sqrt(2.0 * math.pi * model.sigma2) / kappa
    for z in np.asarray(bearings, dtype=np.float64).reshape(-1):
        nu = np.asarray(wrap(z - h))
        a = rho * c * np.exp(-0.5 * nu * nu / model.sigma2)
        lr += np.log1p(a.sum(axis=1))
    return np.asarray(lr)
