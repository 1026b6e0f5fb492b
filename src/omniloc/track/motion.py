"""The motion model: how odometry moves a pose, and how uncertain that leaves it.

Odometry comes as constant-velocity pieces (velocity rows ``t, v, w`` holding until the next
row, as MRCLAM's robots record them) or as increments ``(dx, dy, dtheta)`` between times.
Both become pieces of constant *body twist* ``(vx, vy, w)`` -- ``vy = 0`` for a wheeled
robot's ``(v, w)`` -- integrated exactly: over a piece of duration ``dt`` the robot moves by
the SE(2) exponential of ``(vx, vy, w) dt`` (an arc of a circle; a straight line when
``w = 0``). Pieces compose into one relative motion ``delta = (dx, dy, dtheta)`` in the frame
of the robot at the start, with a covariance ``Q``.

Noise
-----
Each piece adds independent noise in its own start frame (variances, per piece):

* along the motion: ``along_per_m * |d| + along_per_s * dt`` (m^2),
* across it: ``across_per_m * |d|`` (m^2),
* heading: ``turn_per_rad * |dtheta| + turn_per_m * |d| + turn_per_s * dt`` (rad^2),

where ``|d|`` is the distance travelled and ``|dtheta|`` the angle turned on the piece: a
variance per unit of motion, so that noise grows with the motion and not with how finely it
was sampled.

Where the velocities change from one piece to the next by ``c = (dvx, dvy, dw)``, the
next piece adds ``delay_var * J c c^T J^T``: the robot answers a change of its velocities
after a time uncertain by ``sqrt(delay_var)`` seconds, and an error ``e`` of it moves the
piece's start by the twist ``-e c`` (``J`` carries that to the piece's motion: the rest of
the piece turned by its heading part). A turn rate that flips its sign leaves a heading
error in proportion to the flip, however little the robot turns in all: on MRCLAM the
heading's error over 1-5 s grows with the sum of the squared changes of the turn rate, at
about 0.003-0.005 s^2 (docs/tracking.md).

``Q`` is propagated through the composition to first order (the Jacobians of
:func:`compose`). ``delay_s`` is the odometry's latency: a row stamped ``t`` describes the
motion from ``t + delay_s`` (MRCLAM's recorded velocities lead the true motion by ~0.2 s).

Scale
-----
The odometry's velocities may be off by a factor: ``v_scale`` on the forward (and sideways)
velocity, ``w_scale`` on the turn rate. A robot whose odometry reports what it was told to do
(speeds its motors do not reach in turns) or whose wheels slip in turns also goes less far
forward while it turns than its odometry says, as MRCLAM's robots do: ``turn_slowdown`` (s/rad)
takes that share off the velocity per rad/s of the odometry's turn rate. A piece moves at

    vx * v_scale * max(0, 1 - turn_slowdown * |w|),   w * w_scale.

On MRCLAM the robots go 4.3 % farther than their odometry says when they drive straight and
41 % less far at 0.4 rad/s, and turn 5.8 % less than it says (docs/tracking.md; the
``mrclam`` preset keeps ``v_scale`` alone, :meth:`MotionModel.mrclam` says why).

How the MRCLAM values were estimated from odometry against ground truth is in
``docs/tracking.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._kernels import track as _kernels
from ..errors import InputError
from ..io import finite_number
from ..pose import _poses, between, compose, compose_jacobians, inverse

__all__ = [
    "MotionModel",
    "between",
    "compose",
    "compose_jacobians",
    "integrate",
    "inverse",
    "move",
    "twist_of",
]

FloatArray = NDArray[np.float64]


#: Largest accepted magnitude of each motion-model value: noise variances (m^2 per metre,
#: rad^2 per radian, per second ...) far beyond any wheel, a latency of a minute, a scale
#: factor of 100. Beyond them the filter's products overflow.
MOTION_MAX = {
    "along_per_m": 1e3,
    "across_per_m": 1e3,
    "turn_per_rad": 1e3,
    "turn_per_m": 1e3,
    "turn_per_s": 1e3,
    "along_per_s": 1e3,
    "delay_var": 1e3,
    "delay_s": 60.0,
    "v_scale": 100.0,
    "w_scale": 100.0,
    "turn_slowdown": 100.0,
}
#: The factors, which must be positive.
_SCALES = ("v_scale", "w_scale")


@dataclass(frozen=True)
class MotionModel:
    """Noise of the odometry and its latency.

    Parameters
    ----------
    along_per_m : float
        Variance along the motion per metre travelled, m^2/m.
    across_per_m : float
        Variance across the motion per metre travelled, m^2/m.
    turn_per_rad : float
        Heading variance per radian turned, rad^2/rad.
    turn_per_m : float
        Heading variance per metre travelled, rad^2/m.
    turn_per_s : float
        Heading variance per second, rad^2/s (drift, also when standing still).
    along_per_s : float
        Variance along the motion per second, m^2/s.
    delay_s : float
        Latency of the odometry, seconds: a row stamped ``t`` moves the robot from
        ``t + delay_s``. May be negative (odometry stamped late).
    delay_var : float
        Variance of that latency from one change of the velocities to the next, s^2: each
        change ``c = (dvx, dvy, dw)`` between two pieces moves the robot by ``-e c``, ``e``
        of variance ``delay_var`` (0: none; the module's docstring says how and why).
    v_scale : float
        Factor on the odometry's velocities (its scale error: wheels worn, a radius off).
    w_scale : float
        Factor on the odometry's turn rates (a wheel base off, wheels that slip).
    turn_slowdown : float
        Share of the velocity lost per rad/s of the odometry's turn rate, s/rad: the
        velocity is ``v * v_scale * max(0, 1 - turn_slowdown * |w|)`` (0: none).

    Raises
    ------
    InputError
        A variance that is negative or not finite, a latency that is not finite.

    Examples
    --------
    >>> m = MotionModel.mrclam()
    >>> m.delay_s
    0.25
    """

    along_per_m: float = 0.004
    across_per_m: float = 0.0005
    turn_per_rad: float = 0.02
    turn_per_m: float = 0.002
    turn_per_s: float = 1e-6
    along_per_s: float = 1e-6
    delay_s: float = 0.0
    v_scale: float = 1.0
    w_scale: float = 1.0
    turn_slowdown: float = 0.0
    delay_var: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise InputError(f"{f.name} must be a number, got {v!r}")
            v = finite_number(v, f.name)
            if abs(v) > MOTION_MAX[f.name]:
                raise InputError(
                    f"{f.name}={v:.3g} is implausibly large (at most {MOTION_MAX[f.name]:g} in "
                    "magnitude; noises are variances per metre, radian or second)"
                )
            if (f.name != "delay_s" and v < 0) or (f.name in _SCALES and v <= 0):
                what = "finite and > 0" if f.name in _SCALES else "finite and >= 0"
                raise InputError(f"{f.name} must be {what}, got {getattr(self, f.name)!r}")
            object.__setattr__(self, f.name, v)

    @classmethod
    def mrclam(cls) -> MotionModel:
        """The values fitted to MRCLAM set 6 (odometry against the Vicon track over 0.5-10 s
        stretches of all five robots; ``docs/tracking.md``): the recorded velocities are 7 %
        too large and lead the motion by ~0.25 s; the heading wanders by ~1.3 deg/sqrt(s)
        and by ~0.05 s of each change of the turn rate (``delay_var`` 0.0025 s^2).

        ``turn_per_s`` was 8e-4 (1.6 deg/sqrt(s)) and ``delay_var`` 0 until 2026-12-07:
        the odometry's heading error grows with the changes of its turn rate, not with the
        time (``benchmarks/odometry_changes.py``; fitted 0.0034-0.0056 s^2 per robot), so
        part of the drift per second went to the changes. With ``keep_probability`` 0.95
        (:func:`~omniloc.track.preset`), over elsewhere's seeds 0-4 on the whole runs and
        20 + 20 seeded streams: 15 frames localized and wrong against 38, the first correct
        state sooner (a median of 208.8 s in three seeds of five against 396.6 s), 5 % fewer
        frames localized (docs/tracking-notebook.md, "The odometry's response to a
        change").

        One scale is not what the robots do: a robot goes 4.3 % farther than its odometry
        says driving straight, 1.08 s/rad less far in turns, and turns 5.8 % less than it says
        (:func:`~omniloc.track.estimate_motion` on the five runs: ``v_scale`` 1.043,
        ``turn_slowdown`` 1.08, ``w_scale`` 0.942). Those three halve the odometry's error
        over 2 s, but the tracker with them is wrong more often (0.04-0.32 % of the whole
        runs' frames over elsewhere's seeds 0-4, against 0.02-0.11 %; 180 frames of the
        whole runs and seeded streams against 69, near misses), so the preset keeps the one
        scale it had (docs/tracking-notebook.md, "The odometry's scale in turns", "Four
        landmarks to localize")."""
        return cls(
            along_per_m=0.004,
            across_per_m=0.0002,
            turn_per_rad=0.005,
            turn_per_m=0.0,
            turn_per_s=5e-4,
            delay_var=0.0025,
            along_per_s=1e-5,
            delay_s=0.25,
            v_scale=0.93,
        )

    @property
    def noise(self) -> FloatArray:
        """The seven variances in the order the compiled integration takes them."""
        return np.array(
            [
                self.along_per_m,
                self.across_per_m,
                self.turn_per_rad,
                self.turn_per_m,
                self.turn_per_s,
                self.along_per_s,
                self.delay_var,
            ]
        )


def twist_of(delta: ArrayLike, dt: float) -> FloatArray:
    """The constant body twist ``(vx, vy, w)`` that moves by ``delta`` in ``dt`` seconds (the
    SE(2) logarithm divided by ``dt``): how an increment becomes a piece of motion."""
    d = _poses(delta, "delta")
    if not dt > 0:
        raise InputError(f"an increment needs a positive duration, got {dt!r}")
    th = d[..., 2]
    small = np.abs(th) < 1e-9
    ths = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th * th / 6.0, np.sin(ths) / ths)  # sin(th)/th
    b = np.where(small, th / 2.0, (1.0 - np.cos(ths)) / ths)  # (1-cos th)/th
    det = a * a + b * b
    vx = (a * d[..., 0] + b * d[..., 1]) / det
    vy = (-b * d[..., 0] + a * d[..., 1]) / det
    return np.stack([vx, vy, th], axis=-1) / dt


def integrate(
    dt: ArrayLike,
    vx: ArrayLike,
    w: ArrayLike,
    model: MotionModel,
    vy: ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Compose constant-twist pieces into one relative motion with its covariance.

    Parameters
    ----------
    dt : array_like, shape (k,)
        Durations of the pieces, seconds (>= 0).
    vx, w : array_like, shape (k,)
        Forward velocity (m/s) and turn rate (rad/s) on each piece.
    model : MotionModel
    vy : array_like, shape (k,), optional
        Sideways velocity (m/s); zero for a wheeled robot.

    Returns
    -------
    delta : ndarray, shape (3,)
        ``(dx, dy, dtheta)`` in the robot frame at the start (dtheta not wrapped: the total
        angle turned).
    Q : ndarray, shape (3, 3)
        Its covariance.

    Examples
    --------
    A quarter circle of radius 1 m:

    >>> d, Q = integrate([np.pi / 2], [1.0], [1.0], MotionModel())
    >>> d.round(6)
    array([1.      , 1.      , 1.570796])
    """
    t = np.ascontiguousarray(dt, dtype=np.float64)
    v = np.ascontiguousarray(vx, dtype=np.float64)
    om = np.ascontiguousarray(w, dtype=np.float64)
    s = np.zeros_like(v) if vy is None else np.ascontiguousarray(vy, dtype=np.float64)
    if not (t.shape == v.shape == om.shape == s.shape) or t.ndim != 1:
        raise InputError(
            f"dt, vx, vy and w must have the same shape (k,), got {t.shape}, {v.shape}, "
            f"{s.shape}, {om.shape}"
        )
    if t.size and (not np.isfinite(t).all() or (t < 0).any()):
        raise InputError("piece durations must be finite and >= 0")
    f = _speed_factor(om, model)
    if model.w_scale != 1.0:
        om = om * model.w_scale
    return _kernels.integrate_pieces(t, v * f, s * f, om, model.noise)


def _speed_factor(w: FloatArray, model: MotionModel) -> FloatArray | float:
    """The factor on the odometry's velocities at its turn rates ``w`` (rad/s):
    ``v_scale * max(0, 1 - turn_slowdown * |w|)`` (``v_scale`` alone without a slowdown)."""
    if model.turn_slowdown == 0.0:
        return model.v_scale
    return np.asarray(model.v_scale * np.maximum(0.0, 1.0 - model.turn_slowdown * np.abs(w)))


def move(
    poses: FloatArray, covs: FloatArray, delta: FloatArray, Q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Move Gaussian poses by one relative motion: an extended Kalman filter's prediction.

    Parameters
    ----------
    poses : ndarray, shape (H, 3)
    covs : ndarray, shape (H, 3, 3)
    delta : ndarray, shape (3,)
        The motion, in each pose's robot frame (from :func:`integrate`).
    Q : ndarray, shape (3, 3)
        Its covariance.

    Returns
    -------
    poses, covs : ndarray
        ``compose(poses, delta)`` and ``Jp P Jp^T + Jd Q Jd^T`` with the Jacobians of
        :func:`compose` (compiled: ``omniloc._kernels.track.move_kernel``).

    Raises
    ------
    InputError
        Arrays of other shapes.
    """
    p = np.asarray(poses)
    P = np.asarray(covs)
    if p.ndim != 2 or p.shape[1:] != (3,) or P.shape != (p.shape[0], 3, 3):
        raise InputError(
            f"move needs poses of shape (H, 3) and covariances (H, 3, 3), got {p.shape} and "
            f"{P.shape}"
        )
    if np.shape(delta) != (3,) or np.shape(Q) != (3, 3):
        raise InputError(
            f"move needs a motion of shape (3,) and its covariance (3, 3), got "
            f"{np.shape(delta)} and {np.shape(Q)}"
        )
    if p.shape[0] == 0:
        return poses, covs
    return _kernels.move_kernel(
        np.ascontiguousarray(poses, dtype=np.float64),
        np.ascontiguousarray(covs, dtype=np.float64),
        np.ascontiguousarray(delta, dtype=np.float64),
        np.ascontiguousarray(Q, dtype=np.float64),
    )
