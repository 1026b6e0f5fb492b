"""What users pick instead: a particle filter (AMCL-style) with unknown correspondences.

Per frame, in this order:

1. **Motion.** Every particle moves by the odometry's relative motion since the last frame
   (:func:`.motion.odometry_delta`) plus a sample of its noise (:class:`.motion.MotionNoise`,
   along / lateral / heading in the robot's frame), as AMCL's odometry model does.
2. **Weights** (frames with bearings only; a frame without bearings says nothing). Each
   bearing ``z`` of the frame has, for a particle at pose ``x``, the likelihood ratio against
   "it is clutter, uniform over the field of view of width W"::

       l(z | x) = c + (1 - c) * W * A_j N(z - h_j(x); 0, sigma^2)

   over the landmarks ``j`` visible from the particle (within ``max_range`` and within the
   field of view widened by 3 sigma), where ``A_j`` is the mean over them (``"mean"``: a
   mixture with equal weights, the default), their sum (``"sum"``) or the nearest one
   (``"nearest"``: Beluga's ``BearingSensorModel``, which takes the landmark closest in
   bearing, plus the clutter floor it lacks); ``c`` is the clutter weight. A particle that
   sees no landmark gets ``c`` for every bearing. Bearings are independent: the frame's
   ratio is the product. Beluga's model, for comparison, is ``exp(-e^2 / 2 sigma^2)`` of
   the nearest landmark in bearing over the whole map (no field of view, no range, no clutter
   term), multiplied over the detections.
3. **Recovery estimate** (augmented MCL, Thrun et al. 2005, table 8.3; Beluga's
   ``ThrunRecoveryProbabilityEstimator``, Nav2's ``pf_update_sensor``): ``w_avg`` is the
   weighted mean of the particles' frame ratios (taken to the power ``1 / m`` for ``m``
   bearings, so that frames with more bearings do not swamp the averages; see
   :attr:`PfConfig.per_bearing`), and ``w_slow += alpha_slow (w_avg - w_slow)``, ``w_fast +=
   alpha_fast (w_avg - w_fast)`` (both start at the first value).
4. **Resampling** when the effective sample size ``1 / sum w^2`` falls below
   ``resample_ess * N`` (Beluga's ``on_effective_size_drop``; ``1.0``: every frame with
   bearings): low-variance (systematic) resampling, with each new particle drawn instead
   uniformly over the map's area and all headings with probability ``max(0, 1 - w_fast /
   w_slow)``; after an injection both averages restart (Beluga, Nav2).
5. **State.** The particles are clustered (:func:`cluster_particles`: the heaviest cell of
   a coarse grid in x, y, theta, refined by mean shift within ``cluster_radius_m`` and
   ``cluster_radius_deg``). ``localized`` when the densest cluster holds at least
   ``localized_share`` of the weight (its weighted mean is the pose), else ``ambiguous``
   with the top clusters as hypotheses. ``kidnapped`` is set on the frame where
   ``w_fast / w_slow`` first drops below ``kidnap_ratio`` after the filter has been
   localized (it re-arms once localized again with the ratio back above it).

Start: uniform over the landmarks' bounding box widened by ``map_margin_m`` and all
headings, or (``start`` given: the check that a tuned filter can track) a Gaussian around it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

from omniloc.angles import wrap
from omniloc.pose import Pose
from omniloc.sensor import SensorModel
from omniloc.track import Hypothesis, TrackEstimate, TrackState

from .motion import Delta, MotionNoise, OdometryBuffer

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = [
    "ASSOCIATIONS",
    "ParticleFilter",
    "PfConfig",
    "bearing_log_ratio",
    "cluster_particles",
    "kidnap_step",
    "replay_kidnap_flags",
    "systematic_resample",
]

#: How a bearing's landmark components are combined (see the module's documentation).
ASSOCIATIONS = {"mean": 0, "sum": 1, "nearest": 2}


@dataclass(frozen=True)
class PfConfig:
    """The particle filter's options (``benchmarks/track_baselines.py`` says how they were
    tuned).

    Attributes
    ----------
    n_particles : int
    noise : MotionNoise
        The odometry's error model the particles are moved with.
    sigma : float
        Bearing noise standard deviation of the likelihood, radians.
    clutter : float
        Clutter weight ``c`` in (0, 1): the share of the uniform component.
    association : str
        ``"mean"``, ``"sum"`` or ``"nearest"`` (see the module's documentation).
    fov, max_range : float
        The sensor's field of view (radians) and range (m).
    alpha_slow, alpha_fast : float
        Augmented MCL's averaging rates (``0, 0``: no random particles).
    per_bearing : bool
        Average the recovery estimate per bearing (``w_avg ** (1/m)``).
    resample_ess : float
        Resample when the effective sample size falls below this share of ``n_particles``.
    kidnap_ratio : float
        ``kidnapped`` when ``w_fast / w_slow`` drops below this after being localized.
    localized_share : float
        Share of the weight the densest cluster must hold for ``localized``.
    cluster_radius_m, cluster_radius_deg : float
        Mean-shift window of a cluster.
    cluster_cell_m, cluster_cell_deg : float
        Cell of the grid that seeds the clusters.
    max_hypotheses : int
        Clusters reported when ambiguous.
    map_margin_m : float
        The uniform start and the random particles cover the landmarks' bounding box widened
        by this much (the robots' paths lie within 1.3 m of it).
    start_std : tuple of float
        With a start pose: standard deviations of the Gaussian around it (m, m, rad).
    """

    n_particles: int = 10_000
    noise: MotionNoise = field(default_factory=MotionNoise)
    sigma: float = math.radians(2.0)
    clutter: float = 0.2
    association: str = "mean"
    fov: float = math.radians(67.0)
    max_range: float = 8.0
    alpha_slow: float = 0.001
    alpha_fast: float = 0.1
    per_bearing: bool = True
    resample_ess: float = 0.5
    kidnap_ratio: float = 0.5
    localized_share: float = 0.95
    cluster_radius_m: float = 0.5
    cluster_radius_deg: float = 20.0
    cluster_cell_m: float = 0.5
    cluster_cell_deg: float = 30.0
    max_hypotheses: int = 4
    map_margin_m: float = 1.5
    start_std: tuple[float, float, float] = (0.05, 0.05, math.radians(2.0))

    def __post_init__(self) -> None:
        if self.association not in ASSOCIATIONS:
            raise ValueError(
                f"association must be one of {sorted(ASSOCIATIONS)}, got {self.association!r}"
            )
        if not 0.0 < self.clutter < 1.0:
            raise ValueError(f"clutter must lie in (0, 1), got {self.clutter!r}")
        if self.n_particles < 1:
            raise ValueError(f"n_particles must be positive, got {self.n_particles!r}")

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["sigma_deg"] = math.degrees(self.sigma)
        d["fov_deg"] = math.degrees(self.fov)
        return d


# --------------------------------------------------------------------------------------------
# Kernels
# --------------------------------------------------------------------------------------------


@njit(cache=True, fastmath=False, inline="always")
def _wrap1(a: float) -> float:
    # One angle to [-pi, pi) for inputs within a few turns (cheaper than a float modulo).
    while a >= math.pi:
        a -= 2.0 * math.pi
    while a < -math.pi:
        a += 2.0 * math.pi
    return a


@njit(cache=True, fastmath=False)
def _move(
    x: FloatArray,
    y: FloatArray,
    th: FloatArray,
    dx: float,
    dy: float,
    dth: float,
    std: FloatArray,
    normals: FloatArray,
) -> None:
    # Each particle: pose (+) (dx + e_s, dy + e_l, dth + e_h), the errors e = std * normals
    # (normals: shape (3, N)), in the particle's own frame. Headings wrapped to [-pi, pi).
    for i in range(x.size):
        c = math.cos(th[i])
        s = math.sin(th[i])
        ex = dx + std[0] * normals[0, i]
        ey = dy + std[1] * normals[1, i]
        x[i] += c * ex - s * ey
        y[i] += s * ex + c * ey
        th[i] = _wrap1(th[i] + dth + std[2] * normals[2, i])


@njit(cache=True, fastmath=False)
def _log_ratios(
    x: FloatArray,
    y: FloatArray,
    th: FloatArray,
    bearings: FloatArray,
    landmarks: FloatArray,
    sigma: float,
    clutter: float,
    fov_width: float,
    vis_half: float,
    max_range: float,
    mode: int,
    out: FloatArray,
) -> None:
    # out[i] = sum over the frame's bearings of ln l(z | particle i) (module documentation).
    # No trigonometry per landmark: first the landmarks visible from the particle (ahead
    # within the half-angle, |side| <= tan(vis_half) * fwd against the heading, vis_half < 90
    # deg, and within range), then for each bearing its error against each of them,
    # atan(cross / dot) of the bearing's world direction and the landmark's offset, evaluated
    # only within 8 sigma (beyond, the Gaussian is below exp(-32) and counts as 0).
    m = bearings.size
    n_lm = landmarks.shape[0]
    cb = np.cos(bearings)
    sb = np.sin(bearings)
    tan_half = math.tan(vis_half)
    tan_cut = math.tan(min(8.0 * sigma, 1.5))
    norm = (1.0 - clutter) * fov_width / (math.sqrt(2.0 * math.pi) * sigma)
    inv2s2 = 0.5 / (sigma * sigma)
    r2max = max_range * max_range
    lx = landmarks[:, 0].copy()
    ly = landmarks[:, 1].copy()
    ax = np.empty(n_lm)
    ay = np.empty(n_lm)
    for i in range(x.size):
        c = math.cos(th[i])
        s = math.sin(th[i])
        n_vis = 0
        for j in range(n_lm):
            dx = lx[j] - x[i]
            dy = ly[j] - y[i]
            fwd = c * dx + s * dy
            side = c * dy - s * dx
            if fwd > 0.0 and abs(side) <= tan_half * fwd and dx * dx + dy * dy <= r2max:
                ax[n_vis] = dx
                ay[n_vis] = dy
                n_vis += 1
        total = 0.0
        for k in range(m):
            ux = c * cb[k] - s * sb[k]
            uy = s * cb[k] + c * sb[k]
            acc = 0.0
            for q in range(n_vis):
                dot = ux * ax[q] + uy * ay[q]
                cr = ux * ay[q] - uy * ax[q]
                if dot > 0.0 and abs(cr) <= tan_cut * dot:
                    e = math.atan(cr / dot)
                    g = math.exp(-e * e * inv2s2)
                    if mode == 2:
                        acc = max(acc, g)
                    else:
                        acc += g
            if mode == 0 and n_vis > 0:
                acc /= n_vis
            total += math.log(clutter + norm * acc)
        out[i] = total


@njit(cache=True, fastmath=False)
def _systematic(w: FloatArray, u: float, n_out: int) -> IntArray:
    # Low-variance resampling: the n_out points (u + k) / n_out, k = 0..n_out-1, against the
    # cumulative weights (w sums to 1). Particle i is drawn floor or ceil of n_out * w[i] times.
    idx = np.empty(n_out, dtype=np.int64)
    cum = w[0]
    i = 0
    last = w.size - 1
    for k in range(n_out):
        p = (u + k) / n_out
        while p > cum and i < last:
            i += 1
            cum += w[i]
        idx[k] = i
    return idx


@njit(cache=True, fastmath=False)
def _window(
    x: FloatArray,
    y: FloatArray,
    th: FloatArray,
    cs: FloatArray,
    sn: FloatArray,
    w: FloatArray,
    taken: NDArray[np.bool_],
    order: IntArray,
    start: IntArray,
    grid: FloatArray,
    mx: float,
    my: float,
    mt: float,
    r_xy: float,
    r_th: float,
    take: bool,
    sums: FloatArray,
    hist: FloatArray,
) -> None:
    # Over the particles not taken inside the window (|p - m| <= r_xy, |wrap(t - mt)| <=
    # r_th), visiting only the grid cells the window overlaps: sums = [weight, w x, w y,
    # w cos t, w sin t, then w d and w d d^T of the offsets d from the window's centre
    # (3 + 9 values)]. With take, the particles are marked taken and their weight leaves the
    # cell histogram.
    x0, y0, cxy, cth = grid[0], grid[1], grid[2], grid[5]
    inx, iny, inth = int(grid[3]), int(grid[4]), int(grid[6])
    sums[:] = 0.0
    # Particles outside the grid sit in its border cells: the cell range is clamped into the
    # grid at both ends, so a window beyond the border still visits the border cells.
    ix0 = min(max(math.floor((mx - r_xy - x0) / cxy), 0), inx - 1)
    ix1 = max(min(math.floor((mx + r_xy - x0) / cxy), inx - 1), 0)
    iy0 = min(max(math.floor((my - r_xy - y0) / cxy), 0), iny - 1)
    iy1 = max(min(math.floor((my + r_xy - y0) / cxy), iny - 1), 0)
    it0 = math.floor((mt - r_th + math.pi) / cth)
    it1 = math.floor((mt + r_th + math.pi) / cth)
    n_t = min(it1 - it0 + 1, inth)
    r2 = r_xy * r_xy
    for ix in range(ix0, ix1 + 1):
        for iy in range(iy0, iy1 + 1):
            for q in range(n_t):
                it = (it0 + q) % inth
                c = (ix * iny + iy) * inth + it
                for p in range(start[c], start[c + 1]):
                    i = order[p]
                    if taken[i]:
                        continue
                    dx = x[i] - mx
                    dy = y[i] - my
                    dt = _wrap1(th[i] - mt)
                    if dx * dx + dy * dy > r2 or abs(dt) > r_th:
                        continue
                    wi = w[i]
                    sums[0] += wi
                    sums[1] += wi * x[i]
                    sums[2] += wi * y[i]
                    sums[3] += wi * cs[i]
                    sums[4] += wi * sn[i]
                    sums[5] += wi * dx
                    sums[6] += wi * dy
                    sums[7] += wi * dt
                    sums[8] += wi * dx * dx
                    sums[9] += wi * dx * dy
                    sums[10] += wi * dx * dt
                    sums[11] += wi * dy * dy
                    sums[12] += wi * dy * dt
                    sums[13] += wi * dt * dt
                    if take:
                        taken[i] = True
                        hist[c] -= wi


@njit(cache=True, fastmath=False)
def _cluster(
    x: FloatArray,
    y: FloatArray,
    th: FloatArray,
    w: FloatArray,
    grid: FloatArray,
    r_xy: float,
    r_th: float,
    k_max: int,
    means: FloatArray,
    covs: FloatArray,
    weights: FloatArray,
) -> int:
    # Up to k_max clusters, heaviest first. The particles are binned once into the grid
    # (x0, y0, cell_xy, nx, ny, cell_th, nth; outside: the border cells). Each cluster: the
    # heaviest cell of what is not yet taken seeds a window (r_xy, r_th) at its particles'
    # weighted mean; the window moves to the weighted mean of the particles inside it (4
    # mean-shift steps, headings averaged on the circle); the particles inside the final
    # window form the cluster (weight, mean, covariance) and are taken. Returns the count.
    n = x.size
    x0, y0, cxy, cth = grid[0], grid[1], grid[2], grid[5]
    inx, iny, inth = int(grid[3]), int(grid[4]), int(grid[6])
    n_cells = inx * iny * inth
    cell = np.empty(n, dtype=np.int64)
    hist = np.zeros(n_cells)
    start = np.zeros(n_cells + 1, dtype=np.int64)
    cs = np.empty(n)
    sn = np.empty(n)
    for i in range(n):
        ix = min(max(math.floor((x[i] - x0) / cxy), 0), inx - 1)
        iy = min(max(math.floor((y[i] - y0) / cxy), 0), iny - 1)
        it = min(max(int((th[i] + math.pi) / cth), 0), inth - 1)
        c = (ix * iny + iy) * inth + it
        cell[i] = c
        hist[c] += w[i]
        start[c + 1] += 1
        cs[i] = math.cos(th[i])
        sn[i] = math.sin(th[i])
    for c in range(n_cells):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    taken = np.zeros(n, dtype=np.bool_)
    sums = np.zeros(14)
    count = 0
    for _ in range(k_max):
        best = int(np.argmax(hist))
        if hist[best] <= 1e-12:
            break
        sw = 0.0
        sx = 0.0
        sy = 0.0
        sc = 0.0
        ss = 0.0
        for p in range(start[best], start[best + 1]):
            i = order[p]
            if not taken[i]:
                sw += w[i]
                sx += w[i] * x[i]
                sy += w[i] * y[i]
                sc += w[i] * cs[i]
                ss += w[i] * sn[i]
        if sw <= 0.0:
            hist[best] = 0.0
            continue
        mx = sx / sw
        my = sy / sw
        mt = math.atan2(ss, sc)
        for _step in range(4):
            _window(
                x,
                y,
                th,
                cs,
                sn,
                w,
                taken,
                order,
                start,
                grid,
                mx,
                my,
                mt,
                r_xy,
                r_th,
                False,
                sums,
                hist,
            )
            if sums[0] <= 0.0:
                break
            mx = sums[1] / sums[0]
            my = sums[2] / sums[0]
            mt = math.atan2(sums[4], sums[3])
        _window(
            x, y, th, cs, sn, w, taken, order, start, grid, mx, my, mt, r_xy, r_th, True, sums, hist
        )
        sw = sums[0]
        if sw <= 0.0:
            # The window lost every particle: drop the seed cell and go on.
            hist[best] = 0.0
            continue
        md0 = sums[5] / sw
        md1 = sums[6] / sw
        md2 = sums[7] / sw
        means[count, 0] = mx + md0
        means[count, 1] = my + md1
        means[count, 2] = _wrap1(mt + md2)
        covs[count, 0, 0] = sums[8] / sw - md0 * md0
        covs[count, 0, 1] = sums[9] / sw - md0 * md1
        covs[count, 0, 2] = sums[10] / sw - md0 * md2
        covs[count, 1, 1] = sums[11] / sw - md1 * md1
        covs[count, 1, 2] = sums[12] / sw - md1 * md2
        covs[count, 2, 2] = sums[13] / sw - md2 * md2
        covs[count, 1, 0] = covs[count, 0, 1]
        covs[count, 2, 0] = covs[count, 0, 2]
        covs[count, 2, 1] = covs[count, 1, 2]
        weights[count] = sw
        count += 1
    return count


# --------------------------------------------------------------------------------------------
# Python faces of the kernels (also what the tests call)
# --------------------------------------------------------------------------------------------


def bearing_log_ratio(
    poses: FloatArray,
    bearings: FloatArray,
    landmarks_xy: FloatArray,
    *,
    sigma: float,
    clutter: float,
    fov: float,
    max_range: float,
    association: str = "mean",
) -> FloatArray:
    """``sum_z ln l(z | x)`` for poses (K, 3) and one frame's bearings (see the module's
    documentation); the visibility half-angle is ``fov / 2 + 3 sigma``."""
    p = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
    out = np.empty(p.shape[0])
    _log_ratios(
        p[:, 0].copy(),
        p[:, 1].copy(),
        p[:, 2].copy(),
        np.ascontiguousarray(bearings, dtype=np.float64),
        np.ascontiguousarray(landmarks_xy, dtype=np.float64),
        float(sigma),
        float(clutter),
        float(fov),
        0.5 * float(fov) + 3.0 * float(sigma),
        float(max_range),
        ASSOCIATIONS[association],
        out,
    )
    return out


def systematic_resample(weights: FloatArray, u: float, n_out: int | None = None) -> IntArray:
    """Indices drawn by low-variance resampling from normalised ``weights`` with the offset
    ``u`` in [0, 1)."""
    w = np.ascontiguousarray(weights, dtype=np.float64)
    return _systematic(w / w.sum(), float(u), int(w.size if n_out is None else n_out))


def cluster_particles(
    particles: FloatArray,
    weights: FloatArray,
    bounds: tuple[float, float, float, float],
    *,
    cell_m: float = 0.5,
    cell_deg: float = 30.0,
    radius_m: float = 0.5,
    radius_deg: float = 20.0,
    k_max: int = 4,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Clusters of weighted particles (N, 3), heaviest first: means (k, 3), covariances
    (k, 3, 3) and weights (k,) (shares of the total). ``bounds``: the grid's
    ``(xmin, ymin, xmax, ymax)`` (particles outside fall in its border cells)."""
    p = np.ascontiguousarray(particles, dtype=np.float64)
    w = np.ascontiguousarray(weights, dtype=np.float64)
    w = w / w.sum()
    x0, y0, x1, y1 = bounds
    nth = max(round(360.0 / cell_deg), 1)
    grid = np.array(
        [
            x0,
            y0,
            cell_m,
            max(math.ceil((x1 - x0) / cell_m), 1),
            max(math.ceil((y1 - y0) / cell_m), 1),
            2.0 * math.pi / nth,
            nth,
        ]
    )
    means = np.zeros((k_max, 3))
    covs = np.zeros((k_max, 3, 3))
    ws = np.zeros(k_max)
    k = _cluster(
        p[:, 0].copy(),
        p[:, 1].copy(),
        p[:, 2].copy(),
        w,
        grid,
        float(radius_m),
        math.radians(radius_deg),
        int(k_max),
        means,
        covs,
        ws,
    )
    return means[:k], covs[:k], ws[:k]


def kidnap_step(
    armed: bool, ratio: float, localized: bool, has_bearings: bool, threshold: float
) -> tuple[bool, bool]:
    """The kidnap flag of one frame and whether it is armed for the next: the flag goes up
    when armed and ``w_fast / w_slow`` drops below ``threshold`` on a frame with bearings;
    it is armed (again) by a ``localized`` frame whose ratio is at or above the threshold."""
    if armed and has_bearings and ratio < threshold:
        return True, False
    if localized and ratio >= threshold:
        return False, True
    return False, armed


def replay_kidnap_flags(trace: list[tuple[float, bool, bool]], threshold: float) -> list[bool]:
    """The flags a filter would have raised with another threshold (its ``trace``)."""
    armed = False
    out = []
    for ratio, localized, has_b in trace:
        flag, armed = kidnap_step(armed, ratio, localized, has_b, threshold)
        out.append(flag)
    return out


# --------------------------------------------------------------------------------------------
# The filter
# --------------------------------------------------------------------------------------------


class ParticleFilter:
    """Augmented MCL over bearings with unknown correspondences (module documentation).

    Parameters
    ----------
    landmarks_xy : ndarray, shape (N, 2)
    config : PfConfig
    start : Pose, optional
        Start around this pose instead of uniformly (the tracking check).
    rng : numpy Generator, int or None
    """

    def __init__(
        self,
        landmarks_xy: FloatArray,
        config: PfConfig | None = None,
        start: Pose | None = None,
        rng: np.random.Generator | int | None = None,
    ) -> None:
        self.config = cfg = config or PfConfig()
        self.rng = np.random.default_rng(rng)
        self.landmarks_xy = np.ascontiguousarray(landmarks_xy, dtype=np.float64)
        lo = self.landmarks_xy.min(axis=0) - cfg.map_margin_m
        hi = self.landmarks_xy.max(axis=0) + cfg.map_margin_m
        self.bounds = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
        self.sensor = SensorModel(sigma=cfg.sigma, fov=cfg.fov, max_range=cfg.max_range)
        n = cfg.n_particles
        if start is None:
            p = self._uniform(n)
        else:
            p = start.as_array() + self.rng.standard_normal((n, 3)) * np.asarray(cfg.start_std)
            p[:, 2] = wrap(p[:, 2])
        self.x = np.ascontiguousarray(p[:, 0])
        self.y = np.ascontiguousarray(p[:, 1])
        self.th = np.ascontiguousarray(p[:, 2])
        self.w = np.full(n, 1.0 / n)
        self._logl = np.empty(n)
        self._odo = OdometryBuffer()
        self.w_slow = 0.0
        self.w_fast = 0.0
        self.ratio = 1.0
        self._armed = False
        self.n_resamples = 0
        self.n_injected = 0
        #: Per frame: w_fast / w_slow (1 on frames without bearings) and whether the state was
        #: localized -- enough to replay the kidnap flag for another ``kidnap_ratio``.
        self.trace: list[tuple[float, bool, bool]] = []

    # ---- pieces ----------------------------------------------------------------------------
    def _uniform(self, n: int) -> FloatArray:
        x0, y0, x1, y1 = self.bounds
        u = self.rng.random((n, 3))
        return np.stack(
            [x0 + (x1 - x0) * u[:, 0], y0 + (y1 - y0) * u[:, 1], -math.pi + 2 * math.pi * u[:, 2]],
            axis=1,
        )

    def _move(self, d: Delta) -> None:
        if d.dt <= 0.0 and d.dist == 0.0 and d.turn == 0.0:
            return
        std = np.sqrt(np.array(d.variances(self.config.noise)))
        normals = self.rng.standard_normal((3, self.x.size))
        _move(self.x, self.y, self.th, d.dx, d.dy, d.dtheta, std, normals)

    def _weigh(self, bearings: FloatArray) -> None:
        cfg = self.config
        _log_ratios(
            self.x,
            self.y,
            self.th,
            bearings,
            self.landmarks_xy,
            cfg.sigma,
            cfg.clutter,
            self.sensor.fov_width,
            0.5 * self.sensor.fov_width + 3.0 * cfg.sigma,
            cfg.max_range,
            ASSOCIATIONS[cfg.association],
            self._logl,
        )
        top = float(self._logl.max())
        lw = np.log(np.maximum(self.w, 1e-300)) + self._logl - top
        pw = np.exp(lw)
        total = float(pw.sum())
        # Weighted mean ratio of the frame (the previous weights sum to 1).
        log_avg = math.log(total) + top
        if cfg.per_bearing:
            log_avg /= bearings.size
        w_avg = math.exp(log_avg)
        self.w = pw / total
        if self.w_slow == 0.0:
            self.w_slow = self.w_fast = w_avg
        else:
            self.w_slow += cfg.alpha_slow * (w_avg - self.w_slow)
            self.w_fast += cfg.alpha_fast * (w_avg - self.w_fast)
        self.ratio = self.w_fast / self.w_slow if self.w_slow > 0 else 1.0

    def _resample(self) -> None:
        cfg = self.config
        n = self.x.size
        ess = 1.0 / float(np.sum(self.w * self.w))
        if ess >= cfg.resample_ess * n:
            return
        self.n_resamples += 1
        p_inject = 0.0
        if cfg.alpha_slow > 0.0 or cfg.alpha_fast > 0.0:
            p_inject = min(max(1.0 - self.ratio, 0.0), 1.0)
        k = int(self.rng.binomial(n, p_inject)) if p_inject > 0.0 else 0
        idx = _systematic(self.w, float(self.rng.random()), n - k)
        x = np.empty(n)
        y = np.empty(n)
        th = np.empty(n)
        x[: n - k], y[: n - k], th[: n - k] = self.x[idx], self.y[idx], self.th[idx]
        if k:
            r = self._uniform(k)
            x[n - k :], y[n - k :], th[n - k :] = r[:, 0], r[:, 1], r[:, 2]
            self.n_injected += k
        if p_inject > 0.0:
            self.w_slow = self.w_fast = 0.0
        self.x, self.y, self.th = x, y, th
        self.w = np.full(n, 1.0 / n)

    def clusters(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The particles' clusters, heaviest first (means, covariances, weight shares)."""
        cfg = self.config
        return cluster_particles(
            np.stack([self.x, self.y, self.th], axis=1),
            self.w,
            self.bounds,
            cell_m=cfg.cluster_cell_m,
            cell_deg=cfg.cluster_cell_deg,
            radius_m=cfg.cluster_radius_m,
            radius_deg=cfg.cluster_radius_deg,
            k_max=cfg.max_hypotheses,
        )

    # ---- the localizer protocol --------------------------------------------------------------
    def odometry(self, t: object, v: object, w: object) -> None:
        self._odo.add(t, v, w)

    def frame(self, t: float, bearings: FloatArray) -> TrackEstimate:
        cfg = self.config
        self._move(self._odo.take(t))
        b = np.ascontiguousarray(bearings, dtype=np.float64).reshape(-1)
        ratio = 1.0
        if b.size:
            self._weigh(b)
            ratio = self.ratio
            self._resample()
        means, covs, ws = self.clusters()
        if ws.size == 0:
            # Every particle far outside the map in scattered border cells: nothing to report.
            return TrackEstimate(t, TrackState.LOST, reason="no cluster of particles")
        localized = bool(ws[0] >= cfg.localized_share)
        self.trace.append((ratio, localized, bool(b.size)))
        kidnapped, self._armed = kidnap_step(
            self._armed, ratio, localized, bool(b.size), cfg.kidnap_ratio
        )
        hyps = tuple(
            Hypothesis(Pose.from_array(means[k]), covs[k], float(ws[k] / ws.sum()))
            for k in range(ws.size)
        )
        state = TrackState.LOCALIZED if localized else TrackState.AMBIGUOUS
        return TrackEstimate(
            t,
            state,
            hyps[0].pose,
            covs[0],
            hyps if not localized else hyps[:1],
            reason=f"densest cluster {ws[0]:.2f} of the weight; w_fast/w_slow {ratio:.3f}",
            kidnapped=kidnapped,
        )
