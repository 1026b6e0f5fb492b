"""The odometry both baselines predict with: relative motion between frames and its noise.

* :class:`OdometryBuffer` keeps the rows a localizer has been given and hands out the
  constant-velocity pieces between two times (:meth:`omniloc.track.Odometry.between`).
* :func:`odometry_delta` integrates those pieces exactly (unicycle arcs) into the relative
  motion ``(dx, dy, dtheta)`` in the robot's frame at the start, with the distance travelled,
  the angle turned and the duration, which the noise model reads.
* :class:`MotionNoise` is the odometry's error model: variances that grow with the distance
  travelled and the angle turned, plus a floor per second (so that a robot standing still
  still diffuses a little). The same model drives the EKF's prediction (:func:`predict_ekf`)
  and the particle filter's sampling (``particle_filter.py``).
* :func:`calibrate_motion_noise` fits the model to a recording with ground truth: it is how
  the baselines' motion noise was chosen before the multipliers were tuned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray
from scipy.optimize import nnls

from omniloc.angles import wrap
from omniloc.track import Odometry

FloatArray = NDArray[np.float64]

__all__ = [
    "Delta",
    "MotionNoise",
    "OdometryBuffer",
    "calibrate_motion_noise",
    "odometry_delta",
    "predict_ekf",
]


@dataclass(frozen=True)
class MotionNoise:
    """Variances of the odometry's error over a piece of motion, in the robot's frame.

    Over a motion of ``dist`` metres, ``turn`` radians (absolute) and ``dt`` seconds:

    * along the direction of travel: ``along_per_m * dist + along_per_rad * turn +
      xy_per_s * dt`` (m^2);
    * across it: ``lateral_per_m * dist + lateral_per_rad * turn + xy_per_s * dt`` (m^2);
    * heading: ``heading_per_rad * turn + heading_per_m * dist + heading_per_s * dt`` (rad^2).

    Variances add up over consecutive pieces (a random walk), so the model does not depend on
    how the motion is cut.
    """

    along_per_m: float = 1e-4
    along_per_rad: float = 1e-5
    lateral_per_m: float = 1e-4
    lateral_per_rad: float = 1e-5
    heading_per_rad: float = 1e-3
    heading_per_m: float = 1e-3
    xy_per_s: float = 1e-6
    heading_per_s: float = 1e-5

    def scaled(self, factor: float) -> MotionNoise:
        """Every variance multiplied by ``factor``."""
        return replace(self, **{f.name: getattr(self, f.name) * factor for f in fields(self)})

    def as_array(self) -> FloatArray:
        """The eight coefficients in field order (what the kernels read)."""
        return np.array([getattr(self, f.name) for f in fields(self)], dtype=np.float64)

    def as_dict(self) -> dict[str, float]:
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


@dataclass(frozen=True)
class Delta:
    """A relative motion in the robot's frame at its start, and how much motion it was."""

    dx: float
    dy: float
    dtheta: float
    dist: float
    turn: float
    dt: float

    def variances(self, noise: MotionNoise) -> tuple[float, float, float]:
        """Along, lateral (m^2) and heading (rad^2) variances of this motion."""
        return _variances(noise.as_array(), self.dist, self.turn, self.dt)


@njit(cache=True, fastmath=False)
def _variances(c: FloatArray, dist: float, turn: float, dt: float) -> tuple[float, float, float]:
    var_s = c[0] * dist + c[1] * turn + c[6] * dt
    var_l = c[2] * dist + c[3] * turn + c[6] * dt
    var_h = c[4] * turn + c[5] * dist + c[7] * dt
    return var_s, var_l, var_h


@njit(cache=True, fastmath=False)
def _delta_kernel(
    dt: FloatArray, v: FloatArray, w: FloatArray
) -> tuple[float, float, float, float, float, float]:
    # Composes constant-velocity arcs (v, w held for dt) in the frame of the first one's start:
    # each arc's exact chord, rotated by the heading reached so far. Returns dx, dy, dtheta,
    # the distance travelled (sum |v| dt), the angle turned (sum |w| dt) and the duration.
    x = 0.0
    y = 0.0
    th = 0.0
    dist = 0.0
    turn = 0.0
    dur = 0.0
    for k in range(dt.size):
        h = dt[k]
        if h <= 0.0:
            continue
        a = w[k] * h
        s = v[k] * h
        if abs(a) > 1e-9:
            r = s / a
            cx = r * math.sin(a)
            cy = r * (1.0 - math.cos(a))
        else:
            cx = s * (1.0 - a * a / 6.0)
            cy = s * a / 2.0
        c = math.cos(th)
        sn = math.sin(th)
        x += c * cx - sn * cy
        y += sn * cx + c * cy
        th += a
        dist += abs(s)
        turn += abs(a)
        dur += h
    return x, y, th, dist, turn, dur


def odometry_delta(dt: FloatArray, v: FloatArray, w: FloatArray) -> Delta:
    """The relative motion of constant-velocity pieces (durations ``dt`` s, ``v`` m/s,
    ``w`` rad/s), integrated exactly; ``dtheta`` is not wrapped."""
    return Delta(
        *_delta_kernel(
            np.ascontiguousarray(dt, dtype=np.float64),
            np.ascontiguousarray(v, dtype=np.float64),
            np.ascontiguousarray(w, dtype=np.float64),
        )
    )


class OdometryBuffer:
    """The odometry rows a localizer has received, cut into pieces on demand.

    Rows arrive in batches (``add``); :meth:`take` returns the relative motion from the last
    time it was asked up to ``t`` and forgets the rows it no longer needs (the row holding at
    ``t`` is kept). Before the first row the robot is taken to stand still (as
    :meth:`Odometry.between` does).
    """

    def __init__(self) -> None:
        self._t = np.zeros(0)
        self._v = np.zeros(0)
        self._w = np.zeros(0)
        self.t_last: float | None = None

    def add(self, t: Any, v: Any, w: Any) -> None:
        self._t = np.concatenate([self._t, np.asarray(t, dtype=np.float64).reshape(-1)])
        self._v = np.concatenate([self._v, np.asarray(v, dtype=np.float64).reshape(-1)])
        self._w = np.concatenate([self._w, np.asarray(w, dtype=np.float64).reshape(-1)])

    def take(self, t: float) -> Delta:
        """The motion from the previous call's time to ``t``. The first call starts at the
        stream's start: the first row's time if it came before ``t``, else ``t``."""
        if self.t_last is None:
            t0 = min(float(self._t[0]), t) if self._t.size else t
        else:
            t0 = self.t_last
        if t < t0:
            raise ValueError(f"frames must come in time order: t={t!r} after {t0!r}")
        self.t_last = t
        if self._t.size == 0 or t == t0:
            return Delta(0.0, 0.0, 0.0, 0.0, 0.0, t - t0)
        dt, v, w = Odometry(self._t, self._v, self._w).between(t0, t)
        # Keep the row holding at t and the later ones.
        k = max(int(np.searchsorted(self._t, t, side="right")) - 1, 0)
        self._t, self._v, self._w = self._t[k:], self._v[k:], self._w[k:]
        return odometry_delta(dt, v, w)


def predict_ekf(
    mean: FloatArray, cov: FloatArray, delta: Delta, noise: MotionNoise
) -> tuple[FloatArray, FloatArray]:
    """EKF prediction: ``mean (+) delta`` and ``F P F^T + G Q G^T``.

    ``F`` is the Jacobian of the composition with respect to the pose, ``G`` rotates the
    robot-frame noise ``Q = diag(var_along, var_lateral, var_heading)`` into the world
    frame (the along/lateral axes are the start heading's: frames are ~0.25 s apart, so the
    turn within one is a few degrees at most).
    """
    x, y, th = mean
    c, s = math.cos(th), math.sin(th)
    gx = c * delta.dx - s * delta.dy
    gy = s * delta.dx + c * delta.dy
    new = np.array([x + gx, y + gy, wrap(th + delta.dtheta)])
    F = np.array([[1.0, 0.0, -gy], [0.0, 1.0, gx], [0.0, 0.0, 1.0]])
    G = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    Q = np.diag(delta.variances(noise))
    P = F @ cov @ F.T + G @ Q @ G.T
    return new, 0.5 * (P + P.T)


def calibrate_motion_noise(
    odometry: list[Odometry],
    truths: list[Any],
    *,
    window_s: float = 1.0,
    max_gap_s: float = 0.5,
) -> tuple[MotionNoise, dict[str, float]]:
    """Fit :class:`MotionNoise` to recordings with ground truth.

    Each recording is cut into windows of ``window_s``; over each, the odometry's relative
    motion is compared with the true one (both in the robot's frame at the window's start).
    The squared along, lateral and heading errors are regressed (non-negative least squares)
    on the distance, the angle turned and the duration. Windows whose truth has gaps above
    ``max_gap_s`` are left out.

    Returns the model and a few figures of the fit (median errors, windows used, and the
    systematic scale errors of the turn rate and of the speed, which the noise has to cover).
    """
    rows: list[tuple[float, ...]] = []
    for odo, truth in zip(odometry, truths, strict=True):
        lo = max(float(odo.t[0]), float(truth.t[0]))
        hi = min(float(odo.t[-1]), float(truth.t[-1]))
        starts = np.arange(lo, hi - window_s, window_s)
        p0, g0 = truth.at(starts)
        p1, g1 = truth.at(starts + window_s)
        for k, t0 in enumerate(starts):
            if max(g0[k], g1[k]) > max_gap_s:
                continue
            d = odometry_delta(*odo.between(t0, t0 + window_s))
            c, s = math.cos(p0[k, 2]), math.sin(p0[k, 2])
            ex = p1[k, 0] - p0[k, 0]
            ey = p1[k, 1] - p0[k, 1]
            tx = c * ex + s * ey
            ty = -s * ex + c * ey
            tth = wrap(p1[k, 2] - p0[k, 2])
            # Errors along / across the odometry's own direction of motion.
            e_s, e_l = tx - d.dx, ty - d.dy
            rows.append((e_s, e_l, wrap(tth - d.dtheta), d.dist, d.turn, d.dt, d.dtheta, d.dx))
    a = np.array(rows)
    e_s, e_l, e_h, dist, turn, dur, dth, dx = a.T
    X = np.stack([dist, turn, dur], axis=1)

    # Robust squared errors: clip the worst 1 % (Vicon glitches) before the regression.

    def fit(e: FloatArray) -> FloatArray:
        e2 = np.minimum(e * e, np.quantile(e * e, 0.99))
        coef, _ = nnls(X, e2)
        return coef

    cs, cl, ch = fit(e_s), fit(e_l), fit(e_h)
    noise = MotionNoise(
        along_per_m=cs[0],
        along_per_rad=cs[1],
        lateral_per_m=cl[0],
        lateral_per_rad=cl[1],
        heading_per_rad=ch[1],
        heading_per_m=ch[0],
        xy_per_s=0.5 * (cs[2] + cl[2]),
        heading_per_s=ch[2],
    )
    info = {
        "windows": float(len(rows)),
        "window_s": window_s,
        "median_abs_along_m": float(np.median(np.abs(e_s))),
        "median_abs_lateral_m": float(np.median(np.abs(e_l))),
        "median_abs_heading_deg": float(np.degrees(np.median(np.abs(e_h)))),
        # Systematic scale errors (least-squares slopes), which the noise has to cover.
        "turn_scale_error": float(np.sum(e_h * dth) / np.sum(dth * dth)),
        "distance_scale_error": float(np.sum(e_s * dx) / np.sum(dx * dx)),
    }
    return noise, info
