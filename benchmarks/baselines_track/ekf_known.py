"""The upper bound: an EKF that is told which landmark each bearing comes from.

State ``(x, y, theta)``; started at the true pose. Between frames it predicts with the
odometry (:func:`.motion.predict_ekf`, noise :class:`.motion.MotionNoise`); at a frame it
updates with each landmark bearing in turn, using the TRUE landmark row
(:attr:`omniloc.track.Frame.truth`; bearings of other robots, the clutter, are skipped: it
knows which they are). A bearing whose normalised innovation ``nu^2 / S`` exceeds
``gate_sigmas^2`` is rejected. It always reports ``localized`` with its pose and covariance:
it was given the answer, so what it measures is how well odometry and bearings can track,
not whether a localizer can tell where it is.

The localizer protocol of :func:`omniloc.evaluate.tracking.run_stream` passes only the
bearings of a frame, so the EKF is given the frames' truth at construction
(``frames``: the stream's frames, in order) and checks that each frame it is asked about is
the next of them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import NDArray

from omniloc.angles import wrap
from omniloc.pose import Pose, bearing_jacobian
from omniloc.track import Frame, Hypothesis, TrackEstimate, TrackState

from .motion import MotionNoise, OdometryBuffer, predict_ekf

FloatArray = NDArray[np.float64]

__all__ = ["EkfConfig", "EkfKnown"]


@dataclass(frozen=True)
class EkfConfig:
    """The EKF's tuning (see ``benchmarks/track_baselines.py`` for how it was chosen).

    Attributes
    ----------
    noise : MotionNoise
        The odometry's error model.
    sigma : float
        Bearing noise standard deviation, radians.
    gate_sigmas : float
        Innovation gate in standard deviations of the innovation (inf: no gate).
    start_std : tuple of float
        Standard deviations of the starting pose (m, m, rad): it starts at the truth.
    """

    noise: MotionNoise = field(default_factory=MotionNoise)
    sigma: float = math.radians(1.0)
    gate_sigmas: float = 10.0
    start_std: tuple[float, float, float] = (0.05, 0.05, math.radians(2.0))

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["sigma_deg"] = math.degrees(self.sigma)
        return d


class EkfKnown:
    """EKF with known correspondences (see the module's documentation)."""

    def __init__(
        self,
        landmarks_xy: FloatArray,
        start: Pose,
        frames: Sequence[Frame],
        config: EkfConfig | None = None,
    ) -> None:
        self.config = config or EkfConfig()
        self.landmarks_xy = np.asarray(landmarks_xy, dtype=np.float64)
        self.mean = start.as_array().astype(np.float64)
        self.cov = np.diag(np.square(self.config.start_std)).astype(np.float64)
        self._frames = list(frames)
        self._next = 0
        self._odo = OdometryBuffer()
        self.n_used = 0
        self.n_gated = 0

    def odometry(self, t: object, v: object, w: object) -> None:
        self._odo.add(t, v, w)

    def update(self, bearing: float, row: int) -> bool:
        """One bearing of landmark ``row``: gate, then the Kalman update (Joseph form).
        Returns whether it passed the gate."""
        h, G = bearing_jacobian(self.landmarks_xy[row][None], self.mean)
        H = G[0]
        nu = float(wrap(bearing - h[0]))
        PH = self.cov @ H
        S = float(H @ PH) + self.config.sigma**2
        if nu * nu > self.config.gate_sigmas**2 * S:
            return False
        K = PH / S
        self.mean = self.mean + K * nu
        self.mean[2] = wrap(self.mean[2])
        A = np.eye(3) - np.outer(K, H)
        P = A @ self.cov @ A.T + np.outer(K, K) * self.config.sigma**2
        self.cov = 0.5 * (P + P.T)
        return True

    def frame(self, t: float, bearings: FloatArray) -> TrackEstimate:
        if self._next >= len(self._frames) or self._frames[self._next].t != t:
            raise ValueError(f"frame at t={t!r} is not the next frame of the stream given")
        truth = self._frames[self._next].truth
        self._next += 1
        self.mean, self.cov = predict_ekf(self.mean, self.cov, self._odo.take(t), self.config.noise)
        if truth is not None:
            for b, row in zip(np.asarray(bearings, dtype=np.float64), truth, strict=True):
                if row is None:
                    continue
                if self.update(float(b), int(row)):
                    self.n_used += 1
                else:
                    self.n_gated += 1
        pose = Pose.from_array(self.mean)
        cov = self.cov.copy()
        return TrackEstimate(
            t,
            TrackState.LOCALIZED,
            pose,
            cov,
            (Hypothesis(pose, cov, 1.0),),
            reason="known correspondences",
        )
