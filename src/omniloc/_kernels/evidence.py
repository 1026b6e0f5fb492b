"""The log evidence of interpretations, compiled: the terms behind
:mod:`omniloc.search.scoring`, shared with the hypotheses kernel's first-fit test.

``ln E = n per_match - SSE / (2 sigma^2) + detection + min(volume + ln prior(pose), 0)``
(see :mod:`omniloc.search.scoring` for what each term means). Written once here so that the
ranking of the final solutions and the kernel's condition to stop cannot drift apart, and so
that scoring a handful of solutions costs microseconds, not a dozen numpy calls.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .geometry import TWO_PI, _jit, det3

__all__ = ["detection_term", "log_beta", "log_evidence", "prior_log_density"]


@_jit
def log_beta(a: float, b: float) -> float:
    """ln B(a, b) (as scipy.special.betaln, which numba cannot call)."""
    return math.lgamma(a) + math.lgamma(b) - math.lgamma(a + b)


@_jit
def prior_log_density(
    x: float, y: float, region: tuple[float, float, float, float], edge: float, log_volume: float
) -> float:
    """ln of the pose prior's density at (x, y): uniform over ``region`` (any heading), with
    Gaussian edges of scale ``edge`` outside it; ``log_volume`` its normalisation."""
    x0, y0, x1, y1 = region
    dx = max(0.0, x0 - x, x - x1)
    dy = max(0.0, y0 - y, y - y1)
    return -log_volume - (dx * dx + dy * dy) / (2.0 * edge * edge)


@_jit
def detection_term(matched: float, missed: float, log_miss: float, unknown_rate: bool) -> float:
    """ln P(which plainly visible landmarks were detected) beyond the matches' own
    ``ln p_detect``: ``missed ln(1 - p_detect)``, or with an unknown rate (uniform prior)
    ``ln B(matched + 1, missed + 1)``."""
    if unknown_rate:
        return log_beta(matched + 1.0, missed + 1.0)
    return missed * log_miss


@_jit
def log_evidence(
    nmatch: NDArray[np.int64],
    sse: NDArray[np.float64],
    cov: NDArray[np.float64],
    missed: NDArray[np.int64],
    poses: NDArray[np.float64],
    per_match: float,
    sig2: float,
    log_miss: float,
    unknown_rate: bool,
    region: tuple[float, float, float, float],
    edge: float,
    log_volume: float,
) -> NDArray[np.float64]:
    """Each interpretation's log evidence, from its match count, residual sum of squares
    (rad^2), pose covariance (K, 3, 3), plainly visible landmarks missed and pose (K, 3).

    The volume term is Laplace's ``ln sqrt(det(2 pi Cov))``; a covariance that is not
    positive definite (a pose the pairs do not fix) is as vague as the prior, and no integral
    of a likelihood times a prior exceeds the likelihood's peak (the term is at most 0)."""
    k = nmatch.shape[0]
    out = np.empty(k)
    for i in range(k):
        c = cov[i]
        det = det3(c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2])
        occam = 0.0
        if det > 0.0 and c[0, 0] > 0.0 and c[0, 0] * c[1, 1] - c[0, 1] * c[0, 1] > 0.0:
            vol = 0.5 * (3.0 * math.log(TWO_PI) + math.log(det))
            prior = prior_log_density(poses[i, 0], poses[i, 1], region, edge, log_volume)
            occam = min(vol + prior, 0.0)
        out[i] = (
            nmatch[i] * per_match
            - 0.5 * sse[i] / sig2
            + detection_term(float(nmatch[i]), float(missed[i]), log_miss, unknown_rate)
            + occam
        )
    return out
