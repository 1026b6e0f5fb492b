"""Elsewhere: the part of the pose posterior that no hypothesis covers, as particles.

The tracker's hypotheses are Gaussians where the evidence has pointed; the rest of the
posterior -- "the robot is somewhere else" -- is all of it at wake-up, and what a kidnapping
returns the mass to. Its likelihood must remember the frames like any pose's: a robot that
is truly elsewhere keeps explaining its bearings frame after frame, and a likelihood averaged
afresh over the whole region each frame would not credit that (and would let a wrong
hypothesis that fits by chance look certain). So elsewhere is a particle filter over the
region (uniform at the start), moved by the odometry with its noise, weighted by the frames
and resampled; its *predictive* likelihood of each frame -- the weighted mean of its
particles' likelihoods -- is what elsewhere earns. Particles inside a hypothesis's
uncertainty are removed with their mass: that place is the hypothesis's.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .._kernels.track import covered_kernel, particles_move_kernel, resample_kernel

__all__ = ["Elsewhere"]

FloatArray = NDArray[np.float64]

#: A particle within this squared Mahalanobis distance of a hypothesis (99 % of a 3-D
#: Gaussian) belongs to the hypothesis.
COVERED_CHI2 = 11.34

#: Jitter added to every particle per frame (m, m, rad), so that resampled copies spread.
JITTER = (0.01, 0.01, math.radians(0.3))
_JITTER = np.asarray(JITTER, dtype=np.float64)


class Elsewhere:
    """Particles over a rectangular region and all headings.

    Parameters
    ----------
    region : tuple of 4 floats
        ``(xmin, xmax, ymin, ymax)``, metres.
    n : int
        Number of particles.
    inject : float
        Share of the particles drawn afresh from the region at each resampling (the prior's
        share: the robot may be anywhere).
    seed : int
        Seed of the random generator (runs are reproducible).
    """

    def __init__(
        self, region: tuple[float, float, float, float], n: int, inject: float, seed: int = 0
    ):
        self.region = region
        self.n = int(n)
        self.inject = float(inject)
        self._rng = np.random.default_rng(seed)
        self.poses = self._uniform(self.n)
        self.logw = np.full(self.n, -math.log(self.n))
        #: Clutter with memory: each particle's expected count of each object of the
        #: tracker's last frame with bearings (see ``TrackerConfig.clutter_persistence``).
        self.memory = np.zeros((self.n, 0))

    def _uniform(self, m: int) -> FloatArray:
        x0, x1, y0, y1 = self.region
        r = self._rng
        return np.column_stack(
            [r.uniform(x0, x1, m), r.uniform(y0, y1, m), r.uniform(-math.pi, math.pi, m)]
        )

    def reset(self) -> None:
        """Spread the particles uniformly again."""
        self.poses = self._uniform(self.n)
        self.logw = np.full(self.n, -math.log(self.n))
        self.memory = np.zeros((self.n, self.memory.shape[1]))

    def move(self, delta: FloatArray, Q: FloatArray) -> None:
        """Move every particle by ``delta`` plus a draw of the motion noise ``Q``."""
        vals, vecs = np.linalg.eigh(0.5 * (Q + Q.T))
        root = vecs * np.sqrt(np.maximum(vals, 0.0))
        noise = self._rng.standard_normal((self.n, 3)) @ root.T
        z_jitter = self._rng.standard_normal((self.n, 3))
        # (compose(poses, delta + noise + jitter) in one compiled pass, bit for bit)
        self.poses = particles_move_kernel(
            np.ascontiguousarray(self.poses, dtype=np.float64),
            np.ascontiguousarray(delta, dtype=np.float64).reshape(3),
            noise,
            _JITTER,
            z_jitter,
        )

    def weigh(self, log_ratio: FloatArray) -> float:
        """Weigh the particles by their frame log-likelihood ratios; returns elsewhere's
        predictive log-likelihood ratio of the frame."""
        a = self.logw + log_ratio
        top = float(a.max())
        total = top + math.log(float(np.exp(a - top).sum()))
        self.logw = a - total
        return total

    def exclude(self, mu: FloatArray, P: FloatArray) -> float:
        """Remove the particles covered by the hypotheses ``N(mu, P)``; returns the share of
        elsewhere's mass they held (1.0 when nothing is left)."""
        if mu.shape[0] == 0:
            return 0.0
        try:
            Pinv = np.linalg.inv(P)
        except np.linalg.LinAlgError:
            return 0.0
        # Only particles inside the ellipse that the hypothesis's region projects to in x, y
        # can be covered: those within its longest half-axis are tested.
        lam = np.linalg.eigvalsh(0.5 * (P[:, :2, :2] + np.swapaxes(P[:, :2, :2], 1, 2)))[:, -1]
        radius = np.sqrt(COVERED_CHI2 * np.maximum(lam, 0.0)) * (1.0 + 1e-9) + 1e-12
        covered = covered_kernel(
            np.ascontiguousarray(self.poses, dtype=np.float64),
            np.ascontiguousarray(mu, dtype=np.float64),
            np.ascontiguousarray(Pinv, dtype=np.float64),
            radius,
            COVERED_CHI2,
        )
        if not covered.any():
            return 0.0
        w = np.exp(self.logw)
        share = float(w[covered].sum())
        if share >= 1.0 - 1e-12 or covered.all():
            self.reset()
            return 1.0
        self.logw[covered] = -np.inf
        self.logw -= math.log(1.0 - share)
        return share

    def resample(self) -> None:
        """Systematic resampling when the effective sample size is below half, with a share
        ``inject`` drawn afresh from the region."""
        w = np.exp(self.logw)
        w = w / w.sum()
        if 1.0 / float(np.sum(w * w)) >= 0.5 * self.n:
            return
        m_new = round(self.inject * self.n)
        m_keep = self.n - m_new
        # The copies of u_j = (u + j) / m_keep, j < m_keep, in one compiled pass (the same
        # as np.searchsorted(np.cumsum(w), u_j) and fancy indexing, bit for bit).
        poses, self.memory = resample_kernel(
            np.cumsum(w),
            self._rng.uniform(),
            m_keep,
            np.ascontiguousarray(self.poses, dtype=np.float64),
            np.ascontiguousarray(self.memory, dtype=np.float64),
            m_new,
        )
        poses[m_keep:] = self._uniform(m_new)
        self.poses = poses
        self.logw = np.full(self.n, -math.log(self.n))
