"""Pose from bearings with known landmark/bearing pairs (the seed paper's section 2).

* :func:`estimate_pose` -- the closed-form linear estimate of Lee & Chung (eqs. 1-6), after
  Betke & Gurvits' complex-number formulation: one 2x2 inverse, whatever the number of pairs;
  :func:`poses_from_pairs` does the same for many sets of pairs at once and says which have a
  pose (rule i of the search);
* :func:`refine_pose` -- maximum-likelihood refinement on wrapped angular residuals
  (Gauss-Newton, a step that does not lower the error halved), with the pose covariance. The
  linear estimate minimises an algebraic error, not the bearing error, so it is biased under
  noise; the refinement removes that;
* :func:`bearing_jacobian`, :func:`fisher_information`, :func:`pose_covariance` and
  :func:`crlb` -- the bearing function's derivatives, the information, the covariance of the
  maximum-likelihood pose and the Cramer-Rao lower bound for Gaussian bearing noise;
* :func:`compose`, :func:`inverse`, :func:`between` and :func:`compose_jacobians` -- poses
  moved by motions in SE(2) (the tracker's odometry, a sensor's mount on the robot).

The formulas themselves are written once, in :mod:`omniloc._kernels.geometry`, and shared with
the compiled search engines; this module applies them to numpy arrays and checks the input.

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

from ._kernels import geometry as _geo
from .angles import wrap
from .errors import DegenerateGeometryError, InputError
from .io import MAX_COORDINATE, check_positions, finite_number, real_array

__all__ = [
    "MIN_SIGMA",
    "SINGULAR_RTOL",
    "Pose",
    "bearing_jacobian",
    "between",
    "compose",
    "compose_jacobians",
    "crlb",
    "estimate_pose",
    "fisher_information",
    "inverse",
    "pose_covariance",
    "poses_from_pairs",
    "predict_bearings",
    "refine_pose",
]

FloatArray = NDArray[np.float64]

#: Relative tolerance below which the 2x2 matrix of eq. (4) counts as singular.
SINGULAR_RTOL = 1e-10

#: A covariance is refused (DegenerateGeometryError) when the information's condition number
#: exceeds this: the pairs do not fix the pose (the robot on the circle through three
#: landmarks, landmarks all on one line through it).
MAX_CONDITION = 1e12

#: The smallest bearing noise standard deviation (and gate) accepted, radians: below it the
#: variance underflows against the rounding of the bearings themselves (1e-12 rad is a
#: millionth of an arc-second).
MIN_SIGMA = 1e-12

#: Gauss-Newton iterations of :func:`refine_pose` (it stops earlier when a step no longer
#: lowers the error).
REFINE_ITERATIONS = 50


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
        x, y, t = self.x, self.y, self.theta
        if (
            type(x) is float
            and type(y) is float
            and type(t) is float
            and math.isfinite(x)
            and math.isfinite(y)
            and -math.pi <= t < math.pi
        ):
            return  # already what the checks below would make of it (the common case)
        x, y, t = (
            finite_number(v, f"pose {k}")
            for k, v in zip(("x", "y", "theta"), self.as_tuple(), strict=True)
        )
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "y", y)
        if not -math.pi <= t < math.pi:
            object.__setattr__(self, "theta", float(wrap(t)))
        else:
            object.__setattr__(self, "theta", t)

    def as_tuple(self) -> tuple[float, float, float]:
        """``(x, y, theta)``."""
        return self.x, self.y, self.theta

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
        a = real_array(arr, "pose", InputError)
        if a.shape != (3,):
            raise InputError(f"a pose must be (x, y, theta) of shape (3,), got shape {a.shape}")
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


def _check_landmarks(landmarks_xy: ArrayLike, name: str = "landmarks_xy") -> FloatArray:
    return check_positions(landmarks_xy, name, InputError)


def _check_pairs(landmarks_xy: ArrayLike, bearings: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Validate a set of known landmark/bearing pairs and return float64 arrays."""
    L = _check_landmarks(landmarks_xy)
    b = real_array(bearings, "bearings", InputError)
    if b.ndim != 1:
        raise InputError(f"bearings must have shape (N,), got {b.shape}")
    if L.shape[0] != b.shape[0]:
        raise InputError(
            f"need one bearing per landmark: {L.shape[0]} landmarks but {b.shape[0]} bearings"
        )
    if L.shape[0] < 3:
        raise InputError(f"a pose from bearings needs at least 3 pairs, got {L.shape[0]}")
    bad = np.flatnonzero(~np.isfinite(b))
    if bad.size:
        raise InputError(f"bearing {int(bad[0])} is not finite: {b[bad[0]]}")
    return L, b


def _check_pose(pose: Pose | ArrayLike, name: str = "pose") -> FloatArray:
    if isinstance(pose, Pose):
        p = pose.as_array()
    else:
        try:
            p = Pose.from_array(pose).as_array()
        except InputError as exc:
            raise InputError(f"{name}: {exc}") from None
    if max(abs(p[0]), abs(p[1])) > MAX_COORDINATE:
        raise InputError(
            f"{name}: ({p[0]:.3g}, {p[1]:.3g}) lies more than {MAX_COORDINATE:.0e} m from the "
            "origin: positions are metres near the landmarks"
        )
    return p


def _check_sigma(sigma: object) -> float:
    s = finite_number(sigma, "sigma (radians)")
    if not MIN_SIGMA <= s <= np.pi:
        raise InputError(
            f"sigma must be a bearing standard deviation in [{MIN_SIGMA:g}, pi] radians, "
            f"got {s:.4g}"
        )
    return s


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
        ``wrap(atan2(Ly - y, Lx - x) - theta)`` in radians (a landmark at the pose's own
        position has no bearing: that is an error).

    Examples
    --------
    >>> predict_bearings([[1.0, 0.0], [0.0, 2.0]], Pose(0.0, 0.0, np.pi / 2)).round(6)
    array([-1.570796,  0.      ])
    """
    L = _check_landmarks(landmarks_xy)
    p = _check_pose(pose)
    d = L - p[:2]
    at = np.flatnonzero((d == 0).all(axis=1))
    if at.size:
        raise DegenerateGeometryError(
            f"landmark {int(at[0])} is at the pose ({p[0]:g}, {p[1]:g}): it has no bearing"
        )
    return np.asarray(wrap(np.arctan2(d[:, 1], d[:, 0]) - p[2]))


def bearing_jacobian(landmarks_xy: FloatArray, poses: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Predicted bearings (unwrapped) and their gradients with respect to (x, y, theta).

    Parameters
    ----------
    landmarks_xy : ndarray, shape (..., n, 2)
    poses : ndarray, shape (..., 3)

    Returns
    -------
    bearings : ndarray, shape (..., n)
        ``atan2(Ly - y, Lx - x) - theta``, not wrapped.
    gradients : ndarray, shape (..., n, 3)
        Rows ``[dy / r^2, -dx / r^2, -1]``.
    """
    L = real_array(landmarks_xy, "landmarks_xy", InputError)
    p = real_array(poses, "poses", InputError)
    if L.ndim < 2 or L.shape[-1] != 2:
        raise InputError(f"landmarks_xy must have shape (..., n, 2), got {L.shape}")
    if p.shape != (*L.shape[:-2], 3):
        raise InputError(f"poses must have shape {(*L.shape[:-2], 3)} (x, y, theta), got {p.shape}")
    check_positions(L.reshape(-1, 2), "landmarks_xy", InputError)
    check_positions(p[..., :2].reshape(-1, 2), "poses", InputError)
    if not np.isfinite(p).all():
        raise InputError("poses must be finite")
    dx = L[..., 0] - p[..., None, 0]
    dy = L[..., 1] - p[..., None, 1]
    r2 = dx * dx + dy * dy
    if not (r2 > 0).all():
        raise DegenerateGeometryError("a landmark stands on its pose: it has no bearing there")
    pred = np.arctan2(dy, dx) - p[..., None, 2]
    g = np.stack([dy / r2, -dx / r2, -np.ones_like(r2)], axis=-1)
    return pred, g


# --------------------------------------------------------------------------------------------
# Section 2: the linear estimate, eqs. (1)-(6)
# --------------------------------------------------------------------------------------------


def poses_from_pairs(
    landmarks_xy: FloatArray, bearings: FloatArray, *, scale: float | FloatArray | None = None
) -> tuple[FloatArray, NDArray[np.bool_], dict[str, NDArray[np.bool_]]]:
    """Eqs. (1)-(6) for K sets of n known pairs at once, and whether each has a pose.

    Pair 0 of each set is the reference ``L_0, theta_0`` (see :func:`estimate_pose`).

    Parameters
    ----------
    landmarks_xy : ndarray, shape (K, n, 2)
    bearings : ndarray, shape (K, n)
    scale : float or ndarray (K,), optional
        Size of the scene, metres, for the "robot at infinity" test (``|f| <= 1e-12 /
        scale``); default the largest distance of a set's landmarks from their mean.

    Returns
    -------
    poses : ndarray, shape (K, 3)
        ``(x, y, theta)``; meaningless where ``ok`` is False.
    ok : ndarray of bool, shape (K,)
        Rule (i): the pose exists.
    why : dict of str to ndarray of bool, shape (K,)
        Which test failed: ``"coincident"`` (a landmark on the reference), ``"singular"``
        (``sum P_i`` singular), ``"behind"`` (a distance ratio ``r_i <= 0``), ``"infinity"``.
        ``why["behind_at"]`` holds the first pair with ``r_i <= 0`` (as an int array).
    """
    L = real_array(landmarks_xy, "landmarks_xy", InputError)
    b = real_array(bearings, "bearings", InputError)
    if L.ndim != 3 or L.shape[2] != 2 or L.shape[1] < 2:
        raise InputError(f"landmarks_xy must have shape (K, n, 2) with n >= 2, got {L.shape}")
    if b.shape != L.shape[:2]:
        raise InputError(f"bearings must have shape {L.shape[:2]} (K, n), got {b.shape}")
    check_positions(L.reshape(-1, 2), "landmarks_xy", InputError)
    if not np.isfinite(b).all():
        raise InputError("bearings must be finite")
    if scale is not None:
        sc = real_array(scale, "scale", InputError)
        if sc.shape not in ((), (L.shape[0],)) or not (np.isfinite(sc) & (sc > 0)).all():
            raise InputError(
                f"scale must be a positive finite number or one per set (shape ({L.shape[0]},))"
            )
        scale = sc
    if scale is None:
        scale = np.abs(L - L.mean(axis=1, keepdims=True)).max(axis=(1, 2))
        scale = np.where(scale > 0, scale, 1.0)
    zx = L[:, 1:, 0] - L[:, :1, 0]
    zy = L[:, 1:, 1] - L[:, :1, 1]
    coincident = (np.hypot(zx, zy) <= 1e-12 * np.asarray(scale)[..., None]).any(axis=1)
    rot = np.exp(1j * (b[:, 1:] - b[:, :1]))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a, bb, p00, p01, p11, pb0, pb1 = _geo.np_pair_terms(zx, zy, rot)  # eqs. (1)-(3)
        s00, s01, s11 = p00.sum(axis=1), p01.sum(axis=1), p11.sum(axis=1)
        t0, t1 = pb0.sum(axis=1), pb1.sum(axis=1)
        fx, fy, det, f2, rx, ry, th = _geo.np_pose_from_sums(  # eqs. (4)-(6)
            s00, s01, s11, t0, t1, L[:, 0, 0], L[:, 0, 1], b[:, 0]
        )
        singular = ~_geo.np_sums_invertible(det, s00, s01, s11, SINGULAR_RTOL)
        r = _geo.np_distance_ratio(a, bb, fx[:, None], fy[:, None])  # eq. (10)
        behind = ~(r > 0)
        infinity = ~(np.isfinite(f2) & (f2 > (1e-12 / np.asarray(scale)) ** 2))
    why = {
        "coincident": coincident,
        "singular": singular & ~coincident,
        "behind": behind.any(axis=1) & ~singular & ~coincident,
        "infinity": infinity & ~coincident & ~singular,
        "behind_at": np.argmax(behind, axis=1),
    }
    ok = ~(coincident | singular | behind.any(axis=1) | infinity)
    return np.stack([rx, ry, th], axis=1), ok, why


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
        Wrong shapes, non-finite or non-real values, fewer than 3 pairs.
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
    # Coincident landmarks anywhere (not only on the reference): no a_i or b_i exists.
    diff = L[:, None, :] - L[None, :, :]
    dist = np.hypot(diff[..., 0], diff[..., 1])
    np.fill_diagonal(dist, np.inf)
    i, j = np.unravel_index(int(np.argmin(dist)), dist.shape)
    if dist[i, j] <= 1e-12 * scale:
        lo, hi = sorted((int(i), int(j)))
        raise DegenerateGeometryError(f"landmarks {lo} and {hi} coincide at {L[lo].tolist()}")
    poses, ok, why = poses_from_pairs(L[None], b[None], scale=scale)
    if why["singular"][0]:
        raise DegenerateGeometryError(
            "the sum of P_i in eq. (4) is singular: the pairs do not fix the pose "
            "(the robot lies on the circle through the landmarks, or the bearings carry no "
            "independent information)"
        )
    if why["behind"][0]:
        k = int(why["behind_at"][0]) + 1
        raise DegenerateGeometryError(
            f"no pose exists: the distance ratio r_{k} = |L_{k} - R| / |L_0 - R| is not "
            f"positive (landmark {k} would be seen opposite its bearing)"
        )
    if not ok[0]:
        raise DegenerateGeometryError("no pose exists: the solution lies at infinity (f = 0)")
    return Pose.from_array(poses[0])


# --------------------------------------------------------------------------------------------
# Maximum likelihood: information, covariance, refinement, Cramer-Rao bound
# --------------------------------------------------------------------------------------------


def fisher_information(landmarks_xy: ArrayLike, pose: Pose | ArrayLike, sigma: float) -> FloatArray:
    """Fisher information of (x, y, theta) from bearings with Gaussian noise ``sigma``.

    ``J = sum_i g_i g_i^T / sigma^2`` with ``g_i = [dy_i / r_i^2, -dx_i / r_i^2, -1]``.

    Returns
    -------
    ndarray, shape (3, 3)

    Raises
    ------
    InputError
        Malformed landmarks, pose or sigma (the message names which).
    DegenerateGeometryError
        The pose stands on one of the landmarks (no bearing to it).
    """
    L = _check_landmarks(landmarks_xy)
    s = _check_sigma(sigma)
    p = _check_pose(pose)
    d = np.hypot(L[:, 0] - p[0], L[:, 1] - p[1])
    scale = max(float(np.max(np.abs(L - p[:2]), initial=0.0)), 1.0)
    at = np.flatnonzero(d <= 1e-9 * scale)
    if at.size:
        raise DegenerateGeometryError(
            f"the pose ({p[0]:.3f}, {p[1]:.3f}) coincides with landmark {int(at[0])}: "
            "it has no bearing from there"
        )
    _, g = bearing_jacobian(L, p)
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        J = g.T @ g / (s * s)
    return np.asarray(J)


def pose_covariance(landmarks_xy: ArrayLike, pose: Pose | ArrayLike, sigma: float) -> FloatArray:
    """Covariance of the maximum-likelihood pose from matched landmarks: ``sigma^2 (G^T
    G)^-1`` at ``pose`` (the inverse Fisher information).

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
        The matched landmarks, metres.
    pose : Pose or array_like, shape (3,)
    sigma : float
        Bearing noise standard deviation, radians.

    Returns
    -------
    ndarray, shape (3, 3)
        Symmetric positive definite.

    Raises
    ------
    DegenerateGeometryError
        The information is singular (fewer than 3 landmarks, the pose on their circle, or the
        pose at one of them): the landmarks do not fix the pose, and no finite covariance
        describes it.
    """
    J = fisher_information(landmarks_xy, pose, sigma)
    if not np.isfinite(J).all():
        raise DegenerateGeometryError(
            "the Fisher information is not finite: sigma is too small for these distances"
        )
    w, V = np.linalg.eigh(J)
    if not (w[0] > 0 and w[-1] / w[0] <= MAX_CONDITION):
        raise DegenerateGeometryError(
            "the Fisher information is singular: these landmarks do not fix the pose "
            f"(condition number {w[-1] / max(w[0], 1e-300):.2g}; the pose may lie on the "
            "circle through three of them, or they may be too few or on one line)"
        )
    C = (V / w) @ V.T
    return np.asarray(0.5 * (C + C.T))


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
    return pose_covariance(landmarks_xy, pose, sigma)


def refine_pose(
    landmarks_xy: ArrayLike,
    bearings: ArrayLike,
    initial: Pose | ArrayLike | None = None,
    *,
    sigma: float | None = None,
) -> tuple[Pose, FloatArray]:
    """Maximum-likelihood pose from known pairs, with its covariance.

    Minimises ``sum_i wrap(predicted_i - measured_i)^2`` by Gauss-Newton from ``initial`` (by
    default the linear estimate of :func:`estimate_pose`); a step that does not lower the
    error is halved until it does, so the result is never worse than ``initial``.

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
        estimate it from, and an exact fit has none to show, so the covariance is then all NaN
        (unknown), never a made-up number.

    Returns
    -------
    pose : Pose
        The refined pose.
    covariance : ndarray, shape (3, 3)
        ``sigma^2 (G^T G)^-1`` at the refined pose (Gauss-Newton approximation), positive
        definite; all NaN (unknown) without ``sigma`` when the residuals cannot tell the
        noise: exactly 3 pairs, or an exact fit.

    Raises
    ------
    InputError
        Malformed input (the message names the argument).
    DegenerateGeometryError
        No linear estimate exists (without ``initial``), a landmark lies at the starting or
        the refined pose, or the pairs do not fix the pose (see :func:`pose_covariance`).

    Examples
    --------
    >>> L = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0], [4.0, 3.0]])
    >>> z = predict_bearings(L, Pose(1.0, 1.0, 0.3)) + [0.01, -0.01, 0.0, 0.005]
    >>> pose, cov = refine_pose(L, z, sigma=0.01)
    >>> cov.shape
    (3, 3)
    """
    L, b = _check_pairs(landmarks_xy, bearings)
    s = None if sigma is None else _check_sigma(sigma)
    p0 = estimate_pose(L, b).as_array() if initial is None else _check_pose(initial, "initial")
    scale = max(float(np.max(np.abs(L - L.mean(axis=0)))), 1.0)
    if np.abs(p0[:2] - L.mean(axis=0)).max() > 1e6 * scale:
        raise InputError(
            f"initial=({p0[0]:.3g}, {p0[1]:.3g}) is more than a million times the landmarks' "
            "spread away from them: no bearing can tell that pose"
        )
    start_gap = np.hypot(L[:, 0] - p0[0], L[:, 1] - p0[1]).min()
    if start_gap <= 1e-9 * scale:
        raise DegenerateGeometryError(
            "the starting pose stands on a landmark (it has no bearing from there): "
            "give another initial pose"
        )
    w = np.ones((1, L.shape[0]))
    p, sse = _geo.gauss_newton(
        L[None].copy(), b[None].copy(), w, p0[None].copy(), REFINE_ITERATIONS
    )
    pose = Pose.from_array(p[0])
    n = L.shape[0]
    if s is not None:
        return pose, pose_covariance(L, pose, s)
    unit = pose_covariance(L, pose, 1.0)  # the geometry must fix the pose, whatever the noise
    s2 = float(sse[0]) / (n - 3) if n > 3 else 0.0
    if s2 > 0:
        return pose, unit * s2
    # Three pairs (no redundancy) or an exact fit: the residuals say nothing of the noise, and
    # a zero covariance would claim a certainty nobody has.
    return pose, np.full((3, 3), np.nan)


# ---- SE(2): moving poses by motions -------------------------------------------------------
def _poses(a: Pose | ArrayLike, name: str) -> FloatArray:
    """Poses (or motions) ``(x, y, theta)`` of shape (3,) or (n, 3), real and finite, as
    floats; or an :class:`InputError` naming ``name``."""
    if isinstance(a, Pose):
        return a.as_array()
    p = real_array(a, name, InputError)
    if p.ndim not in (1, 2) or p.shape[-1:] != (3,):
        raise InputError(f"{name} must have shape (3,) or (n, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise InputError(f"{name} must be finite (no NaN or inf)")
    return p


#: Largest magnitude of a pose covariance's entry accepted (beyond it, squares overflow).
MAX_COVARIANCE_ENTRY = 1e100


def _covariance(a: ArrayLike, name: str, *, definite: bool = False) -> FloatArray:
    """A pose covariance: a finite, symmetric 3 x 3 matrix, positive semi-definite (with
    ``definite``, positive definite), entries at most :data:`MAX_COVARIANCE_ENTRY`; or an
    :class:`InputError` naming ``name``."""
    c = real_array(a, name, InputError)
    if c.shape != (3, 3):
        raise InputError(f"{name} must have shape (3, 3), got {c.shape}")
    if not np.isfinite(c).all() or np.abs(c).max() > MAX_COVARIANCE_ENTRY:
        raise InputError(f"{name} must be finite, at most {MAX_COVARIANCE_ENTRY:g} in magnitude")
    scale = max(float(np.abs(c).max()), 1e-300)
    low = float(np.linalg.eigvalsh(0.5 * (c + c.T))[0])
    if not (
        np.abs(c - c.T).max() <= 1e-9 * scale and (low > 0.0 if definite else low >= -1e-12 * scale)
    ):
        kind = "definite" if definite else "semi-definite"
        raise InputError(f"{name} must be a 3 x 3 covariance: symmetric, positive {kind}")
    return c


def _pair_shape(a: FloatArray, b: FloatArray, names: str) -> tuple[int, ...]:
    """The broadcast shape of two pose arrays, or an error naming both shapes."""
    try:
        return np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise InputError(
            f"{names}: one pose, or as many rows as the other, expected; got shapes {a.shape} "
            f"and {b.shape}"
        ) from None


def compose(pose: Pose | ArrayLike, delta: Pose | ArrayLike) -> FloatArray:
    """``pose (+) delta``: move by ``delta`` given in the frame of ``pose``.

    Parameters
    ----------
    pose : Pose or array_like, shape (3,) or (n, 3)
        ``(x, y, theta)``, metres and radians, finite.
    delta : Pose or array_like, shape (3,) or (n, 3)
        ``(dx, dy, dtheta)`` in the robot frame of ``pose``; one row, or as many as ``pose``.

    Returns
    -------
    ndarray, shape of the broadcast inputs
        Headings wrapped to [-pi, pi).

    Raises
    ------
    InputError
        An argument that is not finite real poses of shape (3,) or (n, 3), or rows that do
        not pair (the message names the argument, or both shapes); as do
        :func:`compose_jacobians`, :func:`inverse` and :func:`between`.

    Examples
    --------
    >>> compose([1.0, 2.0, np.pi / 2], [1.0, 0.0, 0.0]).round(6).tolist()
    [1.0, 3.0, 1.570796]
    """
    p = _poses(pose, "pose")
    d = _poses(delta, "delta")
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    out = np.empty(_pair_shape(p, d, "pose and delta"))
    out[..., 0] = p[..., 0] + c * d[..., 0] - s * d[..., 1]
    out[..., 1] = p[..., 1] + s * d[..., 0] + c * d[..., 1]
    out[..., 2] = np.asarray(wrap(p[..., 2] + d[..., 2]))
    return out


def compose_jacobians(
    pose: Pose | ArrayLike, delta: Pose | ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Jacobians of :func:`compose` with respect to ``pose`` and to ``delta``.

    Returns
    -------
    J_pose, J_delta : ndarray, shape (..., 3, 3)
    """
    p = _poses(pose, "pose")
    d = _poses(delta, "delta")
    shape = _pair_shape(p, d, "pose and delta")[:-1]
    c = np.broadcast_to(np.cos(p[..., 2]), shape)
    s = np.broadcast_to(np.sin(p[..., 2]), shape)
    dx = np.broadcast_to(d[..., 0], shape)
    dy = np.broadcast_to(d[..., 1], shape)
    Jp = np.zeros((*shape, 3, 3))
    Jp[..., 0, 0] = Jp[..., 1, 1] = Jp[..., 2, 2] = 1.0
    Jp[..., 0, 2] = -s * dx - c * dy
    Jp[..., 1, 2] = c * dx - s * dy
    Jd = np.zeros((*shape, 3, 3))
    Jd[..., 0, 0], Jd[..., 0, 1] = c, -s
    Jd[..., 1, 0], Jd[..., 1, 1] = s, c
    Jd[..., 2, 2] = 1.0
    return Jp, Jd


def inverse(delta: Pose | ArrayLike) -> FloatArray:
    """The motion that undoes ``delta``: ``compose(compose(p, d), inverse(d)) == p``."""
    d = _poses(delta, "delta")
    c, s = np.cos(d[..., 2]), np.sin(d[..., 2])
    out = np.empty(d.shape)
    out[..., 0] = -c * d[..., 0] - s * d[..., 1]
    out[..., 1] = s * d[..., 0] - c * d[..., 1]
    out[..., 2] = np.asarray(wrap(-d[..., 2]))
    return out


def between(a: Pose | ArrayLike, b: Pose | ArrayLike) -> FloatArray:
    """The motion from pose ``a`` to pose ``b``, in the frame of ``a``:
    ``compose(a, between(a, b)) == b``."""
    pa = _poses(a, "a")
    pb = _poses(b, "b")
    out = np.empty(_pair_shape(pa, pb, "a and b"))
    c, s = np.cos(pa[..., 2]), np.sin(pa[..., 2])
    dx = pb[..., 0] - pa[..., 0]
    dy = pb[..., 1] - pa[..., 1]
    out[..., 0] = c * dx + s * dy
    out[..., 1] = -s * dx + c * dy
    out[..., 2] = np.asarray(wrap(pb[..., 2] - pa[..., 2]))
    return out
