"""Pose from bearings with known landmark/bearing pairs (the seed paper's section 2).

Three functions carry the geometry:

* :func:`estimate_pose` -- the closed-form linear estimate of Lee & Chung (eqs. 1-6), after
  Betke & Gurvits' complex-number formulation: one 2x2 inverse, whatever the number of pairs.
* :func:`refine_pose` -- maximum-likelihood refinement on wrapped angular residuals
  (Levenberg-Marquardt), with the pose covariance. The linear estimate minimises an algebraic
  error, not the bearing error, so it is biased under noise; the refinement removes that.
* :func:`crlb` -- the Cramer-Rao lower bound of (x, y, theta) for Gaussian bearing noise.

Conventions: a pose ``(x, y, theta)`` has theta the heading of the robot's forward axis,
counter-clockwise from world x; a bearing is ``wrap(atan2(Ly - y, Lx - x) - theta)``.

References
----------
.. [1] Y. J. Lee, M. J. Chung, "Absolute Localization of a Mobile Robot with an
   Omnidirectional Vision Sensor", KAIST (the seed paper, ``shared/reference/seed-paper.md``).
.. [2] M. Betke, L. Gurvits, "Mobile robot localization using landmarks", IEEE Trans.
   Robotics and Automation 13(2), 1997.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .angles import wrap
from .errors import DegenerateGeometryError, InputError

__all__ = [
    "Pose",
    "crlb",
    "estimate_pose",
    "fisher_information",
    "predict_bearings",
    "refine_pose",
]

FloatArray = NDArray[np.float64]

#: Relative tolerance below which the 2x2 matrix of eq. (4) counts as singular.
SINGULAR_RTOL = 1e-10


@dataclass(frozen=True)
class Pose:
    """A planar robot pose.

    Attributes
    ----------
    x, y : float
        Position in metres, world frame.
    theta : float
        Heading of the robot's forward axis in radians, counter-clockwise from world x,
        wrapped to [-pi, pi).
    """

    x: float
    y: float
    theta: float

    def __post_init__(self) -> None:
        vals = (self.x, self.y, self.theta)
        try:
            x, y, t = (float(v) for v in vals)
        except (TypeError, ValueError) as exc:
            raise InputError(f"pose components must be numbers, got {vals!r}") from exc
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(t)):
            raise InputError(f"pose components must be finite, got ({x}, {y}, {t})")
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "y", y)
        if not -math.pi <= t < math.pi:
            object.__setattr__(self, "theta", float(wrap(t)))
        else:
            object.__setattr__(self, "theta", t)

    @property
    def xy(self) -> FloatArray:
        """Position as an array of shape (2,), metres."""
        return np.array([self.x, self.y])

    def as_array(self) -> FloatArray:
        """``[x, y, theta]`` as an array of shape (3,)."""
        return np.array([self.x, self.y, self.theta])

    @classmethod
    def from_array(cls, arr: ArrayLike) -> Pose:
        """Build a pose from an array-like ``[x, y, theta]``."""
        a = np.asarray(arr, dtype=np.float64)
        if a.shape != (3,):
            raise InputError(f"a pose array must have shape (3,), got {a.shape}")
        return cls(float(a[0]), float(a[1]), float(a[2]))

    def distance_to(self, other: Pose) -> tuple[float, float]:
        """Position distance (m) and absolute heading difference (rad) to another pose."""
        return (
            float(np.hypot(self.x - other.x, self.y - other.y)),
            abs(float(wrap(self.theta - other.theta))),
        )


# --------------------------------------------------------------------------------------------
# Validation at the door
# --------------------------------------------------------------------------------------------


def _check_pairs(landmarks_xy: ArrayLike, bearings: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Validate a set of known landmark/bearing pairs and return float64 arrays."""
    try:
        L = np.asarray(landmarks_xy, dtype=np.float64)
        b = np.asarray(bearings, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"landmarks and bearings must be numeric arrays: {exc}") from exc
    if L.ndim != 2 or L.shape[1] != 2:
        raise InputError(f"landmarks_xy must have shape (N, 2), got {L.shape}")
    if b.ndim != 1:
        raise InputError(f"bearings must have shape (N,), got {b.shape}")
    if L.shape[0] != b.shape[0]:
        raise InputError(
            f"need one bearing per landmark: {L.shape[0]} landmarks but {b.shape[0]} bearings"
        )
    if L.shape[0] < 3:
        raise InputError(f"a pose from bearings needs at least 3 pairs, got {L.shape[0]}")
    bad = np.flatnonzero(~np.isfinite(L).all(axis=1))
    if bad.size:
        raise InputError(f"landmark {int(bad[0])} has a non-finite coordinate: {L[bad[0]]}")
    bad = np.flatnonzero(~np.isfinite(b))
    if bad.size:
        raise InputError(f"bearing {int(bad[0])} is not finite: {b[bad[0]]}")
    return L, b


def _check_pose(pose: Pose | ArrayLike) -> FloatArray:
    if isinstance(pose, Pose):
        return pose.as_array()
    return Pose.from_array(pose).as_array()


# --------------------------------------------------------------------------------------------
# Forward model
# --------------------------------------------------------------------------------------------


def predict_bearings(landmarks_xy: ArrayLike, pose: Pose | ArrayLike) -> FloatArray:
    """Bearings at which landmarks are seen from a pose.

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
        Landmark positions, metres.
    pose : Pose or array_like, shape (3,)
        Robot pose ``(x, y, theta)``.

    Returns
    -------
    ndarray, shape (N,)
        ``wrap(atan2(Ly - y, Lx - x) - theta)`` in radians.

    Examples
    --------
    >>> predict_bearings([[1.0, 0.0], [0.0, 2.0]], Pose(0.0, 0.0, np.pi / 2)).round(6)
    array([-1.570796,  0.      ])
    """
    L = np.asarray(landmarks_xy, dtype=np.float64)
    if L.ndim != 2 or L.shape[1] != 2:
        raise InputError(f"landmarks_xy must have shape (N, 2), got {L.shape}")
    p = _check_pose(pose)
    d = L - p[:2]
    return np.asarray(wrap(np.arctan2(d[:, 1], d[:, 0]) - p[2]))


# --------------------------------------------------------------------------------------------
# Section 2: the linear estimate, eqs. (1)-(6)
# --------------------------------------------------------------------------------------------


def estimate_pose(landmarks_xy: ArrayLike, bearings: ArrayLike) -> Pose:
    """Pose from three or more known landmark/bearing pairs, by the paper's eqs. (1)-(6).

    Pair 0 is the reference ``L_0, theta_0``. For every other pair ``i`` (eqs. 1-3)::

        a_i = vec< exp(j (theta_i - theta_0)) / comp<L_i - L_0> >
        b_i = vec< 1 / comp<L_i - L_0> >
        P_i = a_i a_i^T / (a_i^T a_i) - I

    then (eq. 4) ``f = -[sum P_i]^-1 sum P_i b_i``, a single 2x2 inverse, and (eqs. 5, 6)
    ``R = L_0 - [f_x, -f_y] / |f|^2`` and ``theta = atan2(L_0y - R_y, L_0x - R_x) - theta_0``.
    ``f`` is ``1 / (L_0 - R)`` in complex form (eq. 9) and ``r_i = |L_i - R| / |L_0 - R|`` the
    distance ratios of eq. (10); the least-squares ``r_i`` must be positive for the pose to see
    landmark ``i`` at its bearing rather than at the opposite one.

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
        Positions of the landmarks, metres, N >= 3.
    bearings : array_like, shape (N,)
        Their bearings in the robot frame, radians.

    Returns
    -------
    Pose
        The estimate. Exact for noise-free bearings.

    Raises
    ------
    InputError
        Wrong shapes, non-finite values, fewer than 3 pairs.
    DegenerateGeometryError
        Coincident landmarks, a singular ``sum P_i`` (the robot on the circle through the
        landmarks, or every pair carrying the same information), a distance ratio
        ``r_i <= 0`` (no pose sees the landmarks at these bearings), or a robot at infinity.

    References
    ----------
    Lee & Chung, eqs. (1)-(6) and the appendix (eqs. 12-18); Betke & Gurvits (1997).

    Examples
    --------
    >>> L = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0], [4.0, 3.0]])
    >>> truth = Pose(1.0, 1.0, 0.3)
    >>> est = estimate_pose(L, predict_bearings(L, truth))
    >>> np.allclose(est.as_array(), truth.as_array())
    True
    """
    L, b = _check_pairs(landmarks_xy, bearings)
    scale = float(np.max(np.abs(L - L.mean(axis=0)))) or 1.0
    # Coincident landmarks: no a_i or b_i exists (eqs. 1-2 divide by L_i - L_0).
    diff = L[:, None, :] - L[None, :, :]
    dist = np.hypot(diff[..., 0], diff[..., 1])
    np.fill_diagonal(dist, np.inf)
    i, j = np.unravel_index(int(np.argmin(dist)), dist.shape)
    if dist[i, j] <= 1e-12 * scale:
        lo, hi = sorted((int(i), int(j)))
        raise DegenerateGeometryError(f"landmarks {lo} and {hi} coincide at {L[lo].tolist()}")

    z = (L[1:, 0] - L[0, 0]) + 1j * (L[1:, 1] - L[0, 1])  # comp<L_i - L_0>
    a_c = np.exp(1j * (b[1:] - b[0])) / z  # eq. (1)
    b_c = 1.0 / z  # eq. (2)
    a = np.stack([a_c.real, a_c.imag], axis=1)  # vec<.>, shape (N-1, 2)
    bv = np.stack([b_c.real, b_c.imag], axis=1)
    aa = np.einsum("ij,ij->i", a, a)
    P = a[:, :, None] * a[:, None, :] / aa[:, None, None] - np.eye(2)  # eq. (3)
    S = P.sum(axis=0)
    T = np.einsum("ijk,ik->j", P, bv)
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    if abs(det) <= SINGULAR_RTOL * max(1.0, float(np.abs(S).max()) ** 2):
        raise DegenerateGeometryError(
            "the sum of P_i in eq. (4) is singular: the pairs do not fix the pose "
            "(the robot lies on the circle through the landmarks, or the bearings carry no "
            "independent information)"
        )
    S_inv = np.array([[S[1, 1], -S[0, 1]], [-S[1, 0], S[0, 0]]]) / det
    f = -S_inv @ T  # eq. (4)
    r = np.einsum("ij,ij->i", a, f + bv) / aa  # least-squares distance ratios, eq. (10)
    bad = np.flatnonzero(~(r > 0))
    if bad.size:
        k = int(bad[0]) + 1
        raise DegenerateGeometryError(
            f"no pose exists: the distance ratio r_{k} = |L_{k} - R| / |L_0 - R| comes out "
            f"{r[k - 1]:.3g} <= 0 (landmark {k} would be seen opposite its bearing)"
        )
    f2 = float(f @ f)
    if not np.isfinite(f2) or f2 <= (1e-12 / scale) ** 2:
        raise DegenerateGeometryError("no pose exists: the solution lies at infinity (f = 0)")
    R = L[0] - np.array([f[0], -f[1]]) / f2  # eq. (5)
    theta = np.arctan2(L[0, 1] - R[1], L[0, 0] - R[0]) - b[0]  # eq. (6)
    return Pose(float(R[0]), float(R[1]), float(theta))


# --------------------------------------------------------------------------------------------
# Maximum-likelihood refinement
# --------------------------------------------------------------------------------------------


def _bearing_jacobian(L: FloatArray, p: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Predicted bearings and their gradient with respect to (x, y, theta).

    ``L`` has shape (..., n, 2) and ``p`` shape (..., 3); returns bearings (..., n) and
    gradients (..., n, 3) with rows ``[dy / r^2, -dx / r^2, -1]``.
    """
    dx = L[..., 0] - p[..., None, 0]
    dy = L[..., 1] - p[..., None, 1]
    r2 = dx * dx + dy * dy
    pred = np.arctan2(dy, dx) - p[..., None, 2]
    g = np.stack([dy / r2, -dx / r2, -np.ones_like(r2)], axis=-1)
    return pred, g


def refine_batch(
    L: FloatArray,
    bearings: FloatArray,
    initial: FloatArray,
    weights: FloatArray | None = None,
    *,
    max_iter: int = 20,
    tol: float = 1e-12,
) -> tuple[FloatArray, FloatArray]:
    """Levenberg-Marquardt on wrapped bearing residuals for K problems at once.

    Parameters
    ----------
    L : ndarray, shape (K, n, 2)
        Landmark positions of each problem, metres.
    bearings : ndarray, shape (K, n)
        Measured bearings, radians.
    initial : ndarray, shape (K, 3)
        Starting poses.
    weights : ndarray, shape (K, n), optional
        1 for a pair that counts, 0 for padding (problems with fewer pairs).

    Returns
    -------
    poses : ndarray, shape (K, 3)
        Refined poses; never worse than ``initial`` in weighted squared bearing error.
    sse : ndarray, shape (K,)
        Weighted sum of squared wrapped residuals at the returned poses, rad^2.
    """
    p = np.array(initial, dtype=np.float64, copy=True)
    w = np.ones(bearings.shape) if weights is None else weights
    lam = np.full(p.shape[0], 1e-3)

    def cost(pp: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        pred, g = _bearing_jacobian(L, pp)
        res = np.asarray(wrap(pred - bearings)) * w
        return res, g, np.einsum("kn,kn->k", res, res)

    res, g, sse = cost(p)
    eye = np.eye(3)
    for _ in range(max_iter):
        gw = g * w[..., None]
        H = np.einsum("kni,knj->kij", gw, gw)
        grad = np.einsum("kni,kn->ki", gw, res)
        diag = np.einsum("kii->ki", H)
        A = H + lam[:, None, None] * (diag[:, :, None] * eye + 1e-12 * eye)
        try:
            step = -np.linalg.solve(A, grad[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        cand = p + step
        cand[:, 2] = np.asarray(wrap(cand[:, 2]))
        res_c, g_c, sse_c = cost(cand)
        better = np.isfinite(sse_c) & (sse_c <= sse)
        p[better] = cand[better]
        res[better], g[better], sse_new = res_c[better], g_c[better], sse_c[better]
        improvement = sse[better] - sse_new
        sse[better] = sse_new
        lam = np.where(better, lam * 0.3, lam * 10.0)
        if not better.any() and (lam > 1e8).all():
            break
        if better.all() and (improvement <= tol * (1.0 + sse[better])).all():
            break
    return p, sse


def fisher_information(landmarks_xy: ArrayLike, pose: Pose | ArrayLike, sigma: float) -> FloatArray:
    """Fisher information of (x, y, theta) from bearings with Gaussian noise ``sigma``.

    ``J = sum_i g_i g_i^T / sigma^2`` with ``g_i = [dy_i / r_i^2, -dx_i / r_i^2, -1]``.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    L = np.asarray(landmarks_xy, dtype=np.float64)
    if L.ndim != 2 or L.shape[1] != 2 or not np.isfinite(L).all():
        raise InputError(f"landmarks_xy must be a finite array of shape (N, 2), got {L.shape}")
    if not (np.isfinite(sigma) and sigma > 0):
        raise InputError(f"sigma must be a positive bearing standard deviation, got {sigma}")
    p = _check_pose(pose)
    at = np.flatnonzero(np.hypot(L[:, 0] - p[0], L[:, 1] - p[1]) <= 1e-9)
    if at.size:
        raise DegenerateGeometryError(
            f"the pose ({p[0]:.3f}, {p[1]:.3f}) coincides with landmark {int(at[0])}: "
            "it has no bearing from there"
        )
    _, g = _bearing_jacobian(L, p)
    return np.asarray(g.T @ g / sigma**2)


def crlb(landmarks_xy: ArrayLike, pose: Pose | ArrayLike, sigma: float) -> FloatArray:
    """Cramer-Rao lower bound of the covariance of (x, y, theta) from bearings.

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
        Positions of the observed (matched) landmarks, metres.
    pose : Pose or array_like, shape (3,)
        The true pose.
    sigma : float
        Standard deviation of the bearing noise, radians.

    Returns
    -------
    ndarray, shape (3, 3)
        Inverse Fisher information. ``sqrt(trace(C[:2, :2]))`` bounds the position RMSE of
        any unbiased estimator.

    Raises
    ------
    DegenerateGeometryError
        The information is singular (fewer than 3 landmarks, or the pose on their circle).

    Examples
    --------
    >>> L = [[0, 0], [10, 0], [10, 10], [0, 10]]
    >>> C = crlb(L, Pose(5.0, 5.0, 0.0), np.deg2rad(1.0))
    >>> round(float(np.sqrt(C[0, 0] + C[1, 1])), 4)
    0.1234
    """
    J = fisher_information(landmarks_xy, pose, sigma)
    if np.linalg.cond(J) > 1e12:
        raise DegenerateGeometryError(
            "the Fisher information is singular: these landmarks do not fix the pose"
        )
    return np.asarray(np.linalg.inv(J))


def refine_pose(
    landmarks_xy: ArrayLike,
    bearings: ArrayLike,
    initial: Pose | ArrayLike | None = None,
    *,
    sigma: float | None = None,
) -> tuple[Pose, FloatArray]:
    """Maximum-likelihood pose from known pairs, with its covariance.

    Minimises ``sum_i wrap(predicted_i - measured_i)^2`` by Levenberg-Marquardt from
    ``initial`` (by default the linear estimate of :func:`estimate_pose`). The result is never
    worse than ``initial`` in angular RMS: a step is only taken when it lowers the error.

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
        Landmark positions, metres, N >= 3.
    bearings : array_like, shape (N,)
        Measured bearings, radians.
    initial : Pose or array_like, shape (3,), optional
        Starting pose.
    sigma : float, optional
        Bearing noise standard deviation in radians. When omitted the covariance is scaled by
        the residual variance ``SSE / (N - 3)``; with exactly 3 pairs there is no redundancy to
        estimate it from, and the covariance is then all NaN (unknown), never a made-up number.

    Returns
    -------
    pose : Pose
        The refined pose.
    covariance : ndarray, shape (3, 3)
        ``sigma^2 (G^T G)^-1`` at the refined pose (Gauss-Newton approximation).

    Examples
    --------
    >>> L = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0], [4.0, 3.0]])
    >>> z = predict_bearings(L, Pose(1.0, 1.0, 0.3)) + [0.01, -0.01, 0.0, 0.005]
    >>> pose, cov = refine_pose(L, z, sigma=0.01)
    >>> cov.shape
    (3, 3)
    """
    L, b = _check_pairs(landmarks_xy, bearings)
    if sigma is not None and not (np.isfinite(sigma) and sigma > 0):
        raise InputError(f"sigma must be a positive bearing standard deviation, got {sigma}")
    p0 = estimate_pose(L, b).as_array() if initial is None else _check_pose(initial)
    p, sse = refine_batch(L[None], b[None], p0[None])
    n = L.shape[0]
    _, g = _bearing_jacobian(L, p[0])
    H = g.T @ g
    if sigma is not None:
        s2 = sigma**2
    elif n > 3:
        s2 = float(sse[0]) / (n - 3)
    else:
        s2 = float("nan")
    try:
        cov = np.linalg.inv(H) * s2
    except np.linalg.LinAlgError:
        cov = np.full((3, 3), np.inf)
    return Pose.from_array(p[0]), np.asarray(cov)
