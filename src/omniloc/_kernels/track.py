"""The tracker's compiled kernels (numba): odometry integration and the frame update.

:mod:`omniloc.track.motion` validates the input and says what it means; ``integrate_pieces``
is the one implementation of composing pieces of constant body twist with their noise.
:mod:`omniloc.track.likelihood` says what a frame's likelihood and update are;
``frame_update_kernel`` is their one implementation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import det3, form3, inv3, wrap_float

#: A nearer landmark whose line of sight passes more than this many occlusion widths beside
#: a farther one's is taken not to hide it (its factor would exceed 1 - 2e-8).
OCCLUSION_REACH = 6.0

__all__ = [
    "covered_kernel",
    "frame_update_kernel",
    "integrate_pieces",
    "merge_kernel",
    "move_kernel",
    "near_pairs",
    "occlusion_factors",
    "particles_move_kernel",
    "place_kernel",
    "refine_frames_kernel",
    "same_of_pairs",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@njit(cache=True, error_model="numpy", nogil=True)
def _jacobians(c: float, s: float, dx: float, dy: float, Jp: FloatArray, Jd: FloatArray) -> None:
    """Write the Jacobians of ``pose (+) (dx, dy, .)`` at heading cos ``c``, sin ``s``: with
    respect to the pose (``Jp``, its last column) and to the motion (``Jd``, its rotation);
    the rest of both is the identity, written by the caller."""
    Jp[0, 2] = -s * dx - c * dy
    Jp[1, 2] = c * dx - s * dy
    Jd[0, 0] = c
    Jd[0, 1] = -s
    Jd[1, 0] = s
    Jd[1, 1] = c


@njit(cache=True, error_model="numpy")
def integrate_pieces(
    dt: FloatArray, vx: FloatArray, vy: FloatArray, w: FloatArray, noise: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Compose pieces of constant body twist into ``(delta, Q)``.

    For each piece, in order: its exact motion (the SE(2) exponential of the twist times
    ``dt``: ``dtheta = w dt``, ``[dx, dy] = V(dtheta) [vx, vy] dt`` with
    ``V = [[sin/th, -(1-cos)/th], [(1-cos)/th, sin/th]]``), its noise in its start frame
    (diagonal: along x, across, heading; ``noise`` = along_per_m, across_per_m,
    turn_per_rad, turn_per_m, turn_per_s, along_per_s, delay_var), plus, where the twist
    changes from the last piece that moved by ``c = (dvx, dvy, dw)``, ``delay_var J c c^T
    J^T`` (a response time off by ``e`` s moves the piece's start by the twist ``-e c``,
    which moves ``d`` by ``-e J c``), then the composition
    ``T <- T (+) d`` with ``Q <- Jp Q Jp^T + Jd N Jd^T``. The total heading is not wrapped.
    """
    tx = 0.0
    ty = 0.0
    tt = 0.0
    Q = np.zeros((3, 3))
    Jp = np.eye(3)
    Jd = np.eye(3)
    N = np.zeros((3, 3))
    lag = noise[6]
    last = -1
    for k in range(dt.size):
        h = dt[k]
        if h <= 0.0:
            continue
        phi = w[k] * h
        if abs(phi) < 1e-9:
            a = 1.0 - phi * phi / 6.0
            b = 0.5 * phi
        else:
            a = np.sin(phi) / phi
            b = (1.0 - np.cos(phi)) / phi
        ux = vx[k] * h
        uy = vy[k] * h
        dx = a * ux - b * uy
        dy = b * ux + a * uy
        dist = np.sqrt(ux * ux + uy * uy)
        N[:, :] = 0.0
        if lag > 0.0 and last >= 0:
            # The change ``c`` moves the piece's start by the twist ``-e c``; as a change of
            # the piece's ``d`` that is ``-e J c`` with ``J = [[1, 0, -dy], [0, 1, dx],
            # [0, 0, 1]]`` (the rest of the piece turned by the heading's part).
            ch2 = w[k] - w[last]
            ch0 = vx[k] - vx[last] - ch2 * dy
            ch1 = vy[k] - vy[last] + ch2 * dx
            N[0, 0] = lag * ch0 * ch0
            N[0, 1] = N[1, 0] = lag * ch0 * ch1
            N[0, 2] = N[2, 0] = lag * ch0 * ch2
            N[1, 1] = lag * ch1 * ch1
            N[1, 2] = N[2, 1] = lag * ch1 * ch2
            N[2, 2] = lag * ch2 * ch2
        last = k
        N[0, 0] += noise[0] * dist + noise[5] * h
        N[1, 1] += noise[1] * dist
        N[2, 2] += noise[2] * abs(phi) + noise[3] * dist + noise[4] * h
        c = np.cos(tt)
        s = np.sin(tt)
        _jacobians(c, s, dx, dy, Jp, Jd)
        Q = Jp @ Q @ Jp.T + Jd @ N @ Jd.T
        tx += c * dx - s * dy
        ty += s * dx + c * dy
        tt += phi
    out = np.array([tx, ty, tt])
    return out, 0.5 * (Q + Q.T)


@njit(cache=True, error_model="numpy", nogil=True)
def _compose_into(
    out: FloatArray, k: int, pose: FloatArray, c: float, s: float, d0: float, d1: float, d2: float
) -> None:
    """``out[k] = pose (+) (d0, d1, d2)`` for a pose whose heading has cosine ``c`` and sine
    ``s`` (the heading wrapped): :func:`omniloc.track.motion.compose`'s formula, bit for
    bit."""
    out[k, 0] = pose[0] + c * d0 - s * d1
    out[k, 1] = pose[1] + s * d0 + c * d1
    out[k, 2] = wrap_float(pose[2] + d2)


@njit(cache=True, error_model="numpy", nogil=True)
def move_kernel(
    poses: FloatArray, covs: FloatArray, delta: FloatArray, Q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """H Gaussian poses ``(poses, covs)``, shapes (H, 3) and (H, 3, 3), moved by ``delta``
    (3,) with noise ``Q`` (3, 3), both in each pose's frame: the pose ``compose(pose,
    delta)`` (the heading wrapped) and the covariance ``Jp P Jp^T + Jd Q Jd^T`` with the
    Jacobians of the composition, symmetrised (see :func:`omniloc.track.motion.move`)."""
    H = poses.shape[0]
    new = np.empty((H, 3))
    out = np.empty((H, 3, 3))
    dx = delta[0]
    dy = delta[1]
    A = np.empty((3, 3))
    B = np.empty((3, 3))
    Jp = np.eye(3)
    Jd = np.eye(3)
    for k in range(H):
        c = math.cos(poses[k, 2])
        s = math.sin(poses[k, 2])
        _compose_into(new, k, poses[k], c, s, dx, dy, delta[2])
        _jacobians(c, s, dx, dy, Jp, Jd)
        for i in range(3):
            for j in range(3):
                a = 0.0
                b = 0.0
                for m in range(3):
                    a += Jp[i, m] * covs[k, m, j]
                    b += Jd[i, m] * Q[m, j]
                A[i, j] = a
                B[i, j] = b
        for i in range(3):
            for j in range(3):
                a = 0.0
                b = 0.0
                for m in range(3):
                    a += A[i, m] * Jp[j, m]
                    b += B[i, m] * Jd[j, m]
                out[k, i, j] = a + b
        for i in range(3):
            for j in range(i + 1, 3):
                v = 0.5 * (out[k, i, j] + out[k, j, i])
                out[k, i, j] = v
                out[k, j, i] = v
    return new, out


@njit(cache=True, error_model="numpy", nogil=True)
def particles_move_kernel(
    poses: FloatArray,
    delta: FloatArray,
    noise: FloatArray,
    jitter: FloatArray,
    z_jitter: FloatArray,
) -> FloatArray:
    """M exactly known poses (M, 3) each moved by ``delta`` (3,) plus its own noise
    ``noise[m] + jitter * z_jitter[m]`` (``noise``, ``z_jitter``: (M, 3); ``jitter`` (3,)),
    in the pose's frame: ``compose(pose, delta + noise)``, the heading wrapped (the same
    numbers as numpy's ``compose(poses, delta + (noise + z_jitter * jitter))``, bit for
    bit)."""
    M = poses.shape[0]
    out = np.empty((M, 3))
    d = np.empty(3)
    for m in range(M):
        for j in range(3):
            d[j] = delta[j] + (noise[m, j] + z_jitter[m, j] * jitter[j])
        _compose_into(
            out, m, poses[m], math.cos(poses[m, 2]), math.sin(poses[m, 2]), d[0], d[1], d[2]
        )
    return out


@njit(cache=True, error_model="numpy", nogil=True)
def _moment_match(
    grp: IntArray,
    n: int,
    w: FloatArray,
    mu: FloatArray,
    P: FloatArray,
    i: int,
    d: FloatArray,
    mean: FloatArray,
) -> FloatArray:
    """The Gaussian that matches the mixture of hypotheses ``grp[:n]`` (means ``mu``,
    covariances ``P``) with weights ``w[:n]`` (normalised here, in place), about hypothesis
    ``i``: its mean is written to ``mean`` (3,) (``mu[i]`` plus the weighted offsets, heading
    differences wrapped; ``mean`` may be ``mu[i]`` itself, written after every read), its
    covariance returned (the weighted covariances plus the spread of the means). ``d`` (at
    least (n, 3)) is scratch, left holding each member's offset."""
    s = 0.0
    for a in range(n):
        s += w[a]
    for a in range(n):
        w[a] = w[a] / s
    m0 = m1 = m2 = 0.0
    for a in range(n):
        g = grp[a]
        d[a, 0] = mu[g, 0] - mu[i, 0]
        d[a, 1] = mu[g, 1] - mu[i, 1]
        d[a, 2] = wrap_float(mu[g, 2] - mu[i, 2])
        m0 += w[a] * d[a, 0]
        m1 += w[a] * d[a, 1]
        m2 += w[a] * d[a, 2]
    off = (m0, m1, m2)
    cov = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            acc = 0.0
            for a in range(n):
                acc += w[a] * P[grp[a], r, c]
            spread = 0.0
            for a in range(n):
                spread += w[a] * (d[a, r] - off[r]) * (d[a, c] - off[c])
            cov[r, c] = acc + spread
    x, y, heading = mu[i, 0], mu[i, 1], mu[i, 2]
    mean[0] = x + m0
    mean[1] = y + m1
    mean[2] = wrap_float(heading + m2)
    return cov


@njit(cache=True, error_model="numpy", nogil=True)
def place_kernel(
    near: IntArray, w: FloatArray, mu: FloatArray, P: FloatArray, i: int
) -> tuple[FloatArray, FloatArray]:
    """The mean (heading wrapped) and covariance that match the hypotheses ``near`` with
    weights ``w`` (any positive scale), about hypothesis ``i`` (see :func:`_moment_match`)."""
    n = near.shape[0]
    ww = w.copy()
    d = np.empty((n, 3))
    out = np.empty(3)
    cov = _moment_match(near, n, ww, mu, P, i, d, out)
    return out, cov


@njit(cache=True, error_model="numpy", nogil=True)
def merge_kernel(
    pa: IntArray,
    pb: IntArray,
    w_pair: FloatArray,
    mu: FloatArray,
    P: FloatArray,
    born: FloatArray,
    conf: IntArray,
    conf_t: FloatArray,
    fit_m: FloatArray,
    fit_n: FloatArray,
    mem_w: FloatArray,
    ids: IntArray,
    localized_id: int,
) -> tuple[NDArray[np.bool_], FloatArray, int]:
    """Merge H Gaussian hypotheses, heaviest first, in place (see
    ``Tracker._merge_and_prune``): each hypothesis ``i`` still alive absorbs the hypotheses
    ``pb`` of its pairs ``(i, pb)`` (``pa`` sorted, ``pb > pa``) that are still alive, by
    moment matching with weights ``w_pair`` (the absorbed one's mass over ``i``'s); the
    lineage keeps the earliest birth, the most confirmations and the latest confirmation.

    Returns which hypotheses are still alive, each absorber's summed relative mass (1 where
    nothing was absorbed: its log is what its ln mass grows by) and the localized place's
    id (``localized_id`` -1: none), taken over by the absorber of a hypothesis of that id."""
    H = mu.shape[0]
    alive = np.ones(H, dtype=np.bool_)
    total = np.ones(H)
    grp = np.empty(H, dtype=np.int64)
    w = np.empty(H)
    d = np.empty((H, 3))
    n_pairs = pa.shape[0]
    K = mem_w.shape[1]
    k = 0
    while k < n_pairs:
        i = pa[k]
        e = k
        while e < n_pairs and pa[e] == i:
            e += 1
        if alive[i]:
            grp[0] = i
            w[0] = 1.0
            n = 1
            for q in range(k, e):
                j = pb[q]
                if alive[j]:
                    grp[n] = j
                    w[n] = w_pair[q]
                    n += 1
            if n > 1:
                s = 0.0
                for a in range(n):
                    s += w[a]
                total[i] = s
                P[i] = _moment_match(grp, n, w, mu, P, i, d, mu[i])
                fm = 0.0
                fn = 0.0
                for a in range(n):
                    fm += w[a] * fit_m[grp[a]]
                    fn += w[a] * fit_n[grp[a]]
                for c in range(K):
                    acc = 0.0
                    for a in range(n):
                        acc += w[a] * mem_w[grp[a], c]
                    mem_w[i, c] = acc
                fit_m[i] = fm
                fit_n[i] = fn
                taken = False
                for a in range(1, n):
                    g = grp[a]
                    born[i] = min(born[i], born[g])
                    conf[i] = max(conf[i], conf[g])
                    conf_t[i] = max(conf_t[i], conf_t[g])
                    if ids[g] == localized_id:
                        taken = True
                    alive[g] = False
                if taken:
                    localized_id = ids[i]
        k = e
    return alive, total, localized_id


@njit(cache=True, error_model="numpy", nogil=True)
def refine_frames_kernel(
    L: FloatArray,
    rel: FloatArray,
    z: FloatArray,
    lm: IntArray,
    poses: FloatArray,
    sigma: float,
    iterations: int,
) -> tuple[FloatArray, FloatArray]:
    """Gauss-Newton on C candidate poses (C, 3) of the last frame (see
    :func:`omniloc.track.relocalize.refine_on_frames`, which says what it means): bearing
    ``b`` (``z[b]``) seen from the candidate composed with ``rel[b]`` (the odometry from its
    frame to the last), of landmark row ``lm[c, b]`` (-1: clutter, left out). Returns the
    refined poses and ``sigma^2 (J^T J)^-1``; a candidate whose pairs do not fix the pose
    (``|det J^T J|`` at most 1e-12) or whose result is not finite keeps its pose, with
    ``diag(1, 1, 0.1)``."""
    C = poses.shape[0]
    n = z.shape[0]
    T = poses.copy()
    covs = np.zeros((C, 3, 3))
    for k in range(C):
        x = T[k, 0]
        y = T[k, 1]
        t = T[k, 2]
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        for _ in range(iterations):
            c = math.cos(t)
            s = math.sin(t)
            h00 = h01 = h02 = h11 = h12 = h22 = 0.0
            g0 = g1 = g2 = 0.0
            for b in range(n):
                j = lm[k, b]
                if j < 0:
                    continue
                tx = rel[b, 0]
                ty = rel[b, 1]
                px = x + c * tx - s * ty
                py = y + s * tx + c * ty
                dx = L[j, 0] - px
                dy = L[j, 1] - py
                q = max(dx * dx + dy * dy, 1e-12)
                r = wrap_float(z[b] - (math.atan2(dy, dx) - (t + rel[b, 2])))
                j0 = dy / q
                j1 = -dx / q
                j2 = j0 * (-s * tx - c * ty) + j1 * (c * tx - s * ty) - 1.0
                h00 += j0 * j0
                h01 += j0 * j1
                h02 += j0 * j2
                h11 += j1 * j1
                h12 += j1 * j2
                h22 += j2 * j2
                g0 += j0 * r
                g1 += j1 * r
                g2 += j2 * r
            s0 = s1 = s2 = 0.0
            if abs(det3(h00, h01, h02, h11, h12, h22)) > 1e-12:
                c00, c01, c02, c11, c12, c22, _ = inv3(h00, h01, h02, h11, h12, h22, 1.0, 0.0)
                # (a step that is not finite is not taken, coordinate by coordinate)
                s0 = c00 * g0 + c01 * g1 + c02 * g2
                s1 = c01 * g0 + c11 * g1 + c12 * g2
                s2 = c02 * g0 + c12 * g1 + c22 * g2
                s0 = s0 if math.isfinite(s0) else 0.0
                s1 = s1 if math.isfinite(s1) else 0.0
                s2 = s2 if math.isfinite(s2) else 0.0
            x += s0
            y += s1
            t = wrap_float(t + s2)
        good = (
            abs(det3(h00, h01, h02, h11, h12, h22)) > 1e-12
            and math.isfinite(x)
            and math.isfinite(y)
            and math.isfinite(t)
        )
        c00 = c01 = c02 = c11 = c12 = c22 = 0.0
        if good:
            v = sigma * sigma
            c00, c01, c02, c11, c12, c22, _ = inv3(h00, h01, h02, h11, h12, h22, v, 0.0)
            good = (
                math.isfinite(c00)
                and math.isfinite(c01)
                and math.isfinite(c02)
                and math.isfinite(c11)
                and math.isfinite(c12)
                and math.isfinite(c22)
            )
        if good:
            T[k, 0] = x
            T[k, 1] = y
            T[k, 2] = t
            covs[k, 0, 0] = c00
            covs[k, 0, 1] = c01
            covs[k, 1, 0] = c01
            covs[k, 0, 2] = c02
            covs[k, 2, 0] = c02
            covs[k, 1, 1] = c11
            covs[k, 1, 2] = c12
            covs[k, 2, 1] = c12
            covs[k, 2, 2] = c22
        else:
            covs[k, 0, 0] = 1.0
            covs[k, 1, 1] = 1.0
            covs[k, 2, 2] = 0.1
    return T, covs


@njit(cache=True, error_model="numpy", nogil=True)
def _nearest_reading(
    L: FloatArray,
    x: float,
    y: float,
    t: float,
    rel: FloatArray,
    z: float,
    s2: float,
    gate2: float,
    max_range2: float,
    min_range2: float,
    min_q: float,
    half_fov: float,
    pose: FloatArray,
    h: FloatArray,
    d: FloatArray,
    scratch_J: FloatArray,
    scratch_var: FloatArray,
    zero: FloatArray,
) -> tuple[float, int, float]:
    """The landmark in range and view of the pose ``(x, y, t)`` composed with ``rel`` (3,)
    whose predicted bearing is nearest ``z``: its ``e^2 / s2`` capped at ``gate2``, its row
    (-1 when none is within the gate) and its squared distance. Which landmarks are in
    range and view, and their bearings, are the frame likelihood's
    (:func:`_predict_one` at an exactly known pose); ``pose`` (3,), ``h``, ``d``,
    ``scratch_J`` (N, 3) and ``scratch_var`` are scratch space, ``zero`` a (3, 3) zero
    covariance."""
    c, s = math.cos(t), math.sin(t)
    pose[0] = x + c * rel[0] - s * rel[1]
    pose[1] = y + s * rel[0] + c * rel[1]
    pose[2] = t + rel[2]
    _predict_one(
        pose, zero, L, 1.0, half_fov, max_range2, min_range2, min_q, h, scratch_J,
        scratch_var, d, -1.0, True,
    )  # fmt: skip
    best = gate2
    arg = -1
    for m in range(L.shape[0]):
        if d[m] <= 0.0:
            continue
        e = wrap_float(z - h[m])
        q = e * e / s2
        if q < best:
            best = q
            arg = m
    r2 = 0.0
    if arg >= 0:
        r2 = (L[arg, 0] - pose[0]) ** 2 + (L[arg, 1] - pose[1]) ** 2
    return best, arg, r2


#: Two bearings whose angle apart has a sine below this are nearly in line (within about
#: 6 degrees of 0 or 180 degrees apart): the poses that see two landmarks there lie on a
#: circle so large that a whole turn's steps step over the few of them within range, and
#: the position along the line the landmarks stand on is barely fixed by the bearings.
#: :func:`pair_scan_kernel` skips such a pair.
PAIR_MIN_SINE = 0.1


@njit(cache=True, error_model="numpy", nogil=True)
def pair_scan_kernel(
    L: FloatArray,
    rel: FloatArray,
    z: FloatArray,
    base: FloatArray,
    seeds: IntArray,
    sigma: float,
    gate2: float,
    max_range2: float,
    min_range2: float,
    min_q: float,
    half_fov: float,
    steps: int,
    min_hits: int,
    max_out: int,
) -> tuple[FloatArray, IntArray, FloatArray]:
    """Poses of the last frame from two landmarks seen from a moving sensor (see
    :func:`omniloc.track.relocalize.pair_candidates`, which says what it is for), in the
    convention of :func:`refine_frames_kernel`: bearing ``b`` (``z[b]``) is seen from the
    pose composed with ``rel[b]``.

    For each pair ``(i, j)`` of bearings of one frame (``seeds``, (S, 2)) and each ordered
    pair of landmarks ``(A, B)`` (within twice the range of each other), the poses of that
    frame that see A at ``z[i]`` and B at ``z[j]`` are a one-parameter family (the world
    direction from the pose to A); ``steps`` of it are scored against every bearing: each
    takes the landmark in range and view whose predicted bearing is nearest, a robust cost
    ``min(e^2 / sigma^2, gate2)``; a pose that can no longer explain ``min_hits`` bearings
    is given up with the cost of that (a plateau). Kept: the local minima of the cost along
    the family (below the sample before, not above the one after) with at least
    ``min_hits`` bearings within the gate that fix the family: of a third landmark, or of A
    or B from a frame ``base[b]`` metres from the seed's, far enough for its bearing to
    move by three ``sigma`` (``base >= 3 sigma r``; a sensor standing still sees every pose
    of the family alike). At most ``max_out`` of them.

    Returns the poses of the last frame (K, 3), each bearing's landmark row (K, n; -1
    beyond the gate) and each pose's cost (K,)."""
    n = z.shape[0]
    N = L.shape[0]
    out_p = np.empty((max_out, 3))
    out_lm = np.full((max_out, n), -1, dtype=np.int64)
    out_c = np.empty(max_out)
    K = 0
    cost = np.empty(steps)
    pose = np.empty((steps, 3))
    # Each sample's landmark for each bearing, and its bearings that fix the family.
    args = np.empty((steps, n), dtype=np.int64)
    hits = np.zeros(steps, dtype=np.int64)
    near2 = 4.0 * max_range2
    s2 = sigma * sigma
    # (Scratch space of _nearest_reading.)
    at = np.empty(3)
    h = np.empty(N)
    d = np.empty(N)
    sJ = np.empty((N, 3))
    svar = np.empty(N)
    zero = np.zeros((3, 3))
    for si in range(seeds.shape[0]):
        i = seeds[si, 0]
        j = seeds[si, 1]
        alpha = z[j] - z[i]
        sa = math.sin(alpha)
        if abs(sa) < PAIR_MIN_SINE:
            continue  # the two bearings nearly in line
        # The seed frame's pose relative to the last frame, and its inverse.
        fx, fy, ft = rel[i, 0], rel[i, 1], rel[i, 2]
        cf, sf = math.cos(ft), math.sin(ft)
        ix = -(cf * fx + sf * fy)
        iy = -(-sf * fx + cf * fy)
        for a in range(N):
            for bb in range(N):
                if a == bb:
                    continue
                abx = L[a, 0] - L[bb, 0]
                aby = L[a, 1] - L[bb, 1]
                if abx * abx + aby * aby > near2:
                    continue
                for k in range(steps):
                    cost[k] = math.inf
                    psi = 2.0 * math.pi * k / steps
                    u1x, u1y = math.cos(psi), math.sin(psi)
                    u2x, u2y = math.cos(psi + alpha), math.sin(psi + alpha)
                    # P + rA u1 = A, P + rB u2 = B:  rA u1 - rB u2 = A - B.
                    det = -(u1x * u2y - u2x * u1y)
                    rA = (abx * (-u2y) + u2x * aby) / det
                    rB = (u1x * aby - u1y * abx) / det
                    if not (rA > 0.0 and rB > 0.0):
                        continue
                    if rA * rA > max_range2 or rB * rB > max_range2:
                        continue
                    if rA * rA < min_range2 or rB * rB < min_range2:
                        continue
                    px = L[a, 0] - rA * u1x
                    py = L[a, 1] - rA * u1y
                    pt = psi - z[i] - ft  # the last frame's heading (the seed's: psi - z[i])
                    # The last frame's pose: the seed frame's composed with rel's inverse.
                    c0, s0 = math.cos(pt + ft), math.sin(pt + ft)
                    x = px + c0 * ix - s0 * iy
                    y = py + s0 * ix + c0 * iy
                    t = wrap_float(pt)
                    pose[k, 0] = x
                    pose[k, 1] = y
                    pose[k, 2] = t
                    tot = 0.0
                    misses = 0
                    hits[k] = 0
                    for b in range(n):
                        # (The seed's two bearings are explained and fix nothing.)
                        if misses > n - 2 - min_hits:
                            tot = n * gate2
                            hits[k] = -1  # (given up: it cannot be kept)
                            break
                        best, arg, arg_r2 = _nearest_reading(
                            L,
                            x,
                            y,
                            t,
                            rel[b],
                            z[b],
                            s2,
                            gate2,
                            max_range2,
                            min_range2,
                            min_q,
                            half_fov,
                            at,
                            h,
                            d,
                            sJ,
                            svar,
                            zero,
                        )
                        tot += best
                        args[k, b] = arg
                        if arg < 0:
                            misses += 1
                        elif (arg != a and arg != bb) or base[b] * base[b] >= 9.0 * s2 * arg_r2:
                            hits[k] += 1
                    cost[k] = tot
                for k in range(steps):
                    ck = cost[k]
                    if not math.isfinite(ck) or K >= max_out or hits[k] < min_hits:
                        continue
                    lo = cost[(k - 1) % steps]
                    hi = cost[(k + 1) % steps]
                    if not (ck < lo and ck <= hi):
                        continue
                    out_p[K] = pose[k]
                    out_lm[K] = args[k]
                    out_c[K] = ck
                    K += 1
    return out_p[:K].copy(), out_lm[:K].copy(), out_c[:K].copy()


@njit(cache=True, error_model="numpy", nogil=True)
def _exp(x: float) -> float:
    """``math.exp(x)``, bit for bit, without calling it below -750 (where its value, below
    1e-325, is under the smallest double: it returns 0)."""
    return 0.0 if x < -750.0 else math.exp(x)


@njit(cache=True, error_model="numpy", nogil=True)
def _reading(share: float, rho: float, nu: float, S: float, norm: float) -> float:
    """One reading's term of a bearing's likelihood ratio: ``share`` of the detection odds
    ``rho`` times the Gaussian density of the innovation ``nu`` with variance ``S`` (over the
    clutter density: ``norm`` = 1 / (sqrt(2 pi) kappa))."""
    return share * rho * _exp(-0.5 * nu * nu / S) / math.sqrt(S) * norm


@njit(cache=True, error_model="numpy", nogil=True)
def _reading_root(share: float, rho: float, nu: float, S: float, root: float, norm: float) -> float:
    """:func:`_reading` with ``math.sqrt(S)`` given (``root``), bit for bit."""
    return share * rho * _exp(-0.5 * nu * nu / S) / root * norm


@njit(cache=True, error_model="numpy", nogil=True)
def _in_view(e: float, sd: float) -> float:
    """The probability that a bearing predicted ``e`` radians inside the edge of the view
    (negative: outside), with standard deviation ``sd``, is in view: ``0.5 erfc(-e / (sd
    sqrt 2))``. Where ``erfc`` is 0 or 2 to the last bit (its argument beyond 27.5, where
    its value is below the smallest double, or below -6.5, within 1e-20 of 2), that value
    is taken without calling it."""
    x = -(e / sd) / math.sqrt(2.0)
    if x >= 27.5:
        return 0.5 * 0.0
    if x <= -6.5:
        return 0.5 * 2.0
    return 0.5 * math.erfc(x)


@njit(cache=True, error_model="numpy", nogil=True)
def _predict_one(
    mu: FloatArray,
    P: FloatArray,
    L: FloatArray,
    p_detect: float,
    half_fov: float,
    max_range2: float,
    min_range2: float,
    min_q: float,
    h: FloatArray,
    J: FloatArray,
    var: FloatArray,
    d: FloatArray,
    tan_out: float,
    exact: bool,
    lazy_view: bool = False,
) -> None:
    """One hypothesis's predicted bearings ``h``, their Jacobians ``J`` (N, 3), variances
    from the pose ``var`` and detection probabilities ``d``, written in place
    (``half_fov`` < 0: no field of view). For a landmark out of range only ``d`` (0) is
    written. ``exact`` (``P`` zero, an exactly known pose): ``J`` is not written and every
    variance is 0.

    ``lazy_view``: a landmark in range whose chance of being in view needs the edge's
    ``erfc`` (a variance from the pose, a field of view) gets ``d`` -1 instead, for the
    caller to compute with :func:`_view_d` when it needs it (most bearings read no
    landmark but one or two, and the others' ``d`` is then never read).

    ``tan_out`` >= 0 (an exactly known pose, ``P`` zero, and a field of view narrower than
    a half turn): a landmark whose direction is more than ``atan(tan_out)`` (a shade beyond
    the half field of view) off the heading is out of view; only its ``d`` (0) is written,
    without its bearing's ``atan2``. Beyond the shade the full test gives 0 too, so the
    results are the same, bit for bit."""
    c = math.cos(mu[2]) if tan_out >= 0.0 else 1.0
    s = math.sin(mu[2]) if tan_out >= 0.0 else 0.0
    for n in range(L.shape[0]):
        dx = L[n, 0] - mu[0]
        dy = L[n, 1] - mu[1]
        q = max(dx * dx + dy * dy, min_q)
        if q > max_range2 or q < min_range2:
            # Out of range: never detected (the rest is not read for such a landmark).
            d[n] = 0.0
            continue
        if tan_out >= 0.0:
            ahead = dx * c + dy * s
            if ahead <= 0.0 or abs(dy * c - dx * s) > ahead * tan_out:
                d[n] = 0.0
                continue
        h[n] = wrap_float(math.atan2(dy, dx) - mu[2])
        if exact:
            # (An exactly known pose: no Jacobian is read, and the variance from the pose is
            # 0, what J 0 J^T gives.)
            var[n] = 0.0
        else:
            J[n, 0] = dy / q
            J[n, 1] = -dx / q
            J[n, 2] = -1.0
            v = 0.0
            for i in range(3):
                for j in range(3):
                    v += J[n, i] * P[i, j] * J[n, j]
            var[n] = max(v, 0.0)
        if half_fov < 0.0:
            vis = 1.0
        elif var[n] == 0.0:
            # An exactly known pose: the edge of the view is sharp (what the erfc below
            # gives with its 1e-9 floor, without computing it).
            e = half_fov - abs(h[n])
            vis = 1.0 if e > 0.0 else (0.5 if e == 0.0 else 0.0)
        elif lazy_view:
            d[n] = -1.0
            continue
        else:
            vis = _in_view(half_fov - abs(h[n]), math.sqrt(var[n]) + 1e-9)
        d[n] = p_detect * vis


@njit(cache=True, error_model="numpy", nogil=True)
def _view_d(p_detect: float, half_fov: float, h: float, var: float) -> float:
    """A landmark's detection probability from its predicted bearing ``h`` and variance
    ``var`` > 0 in a field of view of half-width ``half_fov`` >= 0: what
    :func:`_predict_one` writes without ``lazy_view``, bit for bit."""
    return p_detect * _in_view(half_fov - abs(h), math.sqrt(var) + 1e-9)


@njit(cache=True, error_model="numpy", nogil=True)
def _occlude(
    mu: FloatArray,
    L: FloatArray,
    h: FloatArray,
    d: FloatArray,
    half_fov: float,
    width: float,
    occ: FloatArray,
    wi: NDArray[np.int64],
    wq: FloatArray,
) -> None:
    """Landmarks hidden behind nearer ones: each landmark ``n`` with ``d[n]`` != 0 (in range;
    -1, its view not yet computed, included) has its detection probability multiplied by
    ``occ[n] = prod_m (1 - exp(-l_m^2 / (2 width^2)))`` over the nearer landmarks ``m`` in
    range whose predicted bearing lies in the field of view (``half_fov`` < 0: every one),
    where ``l_m`` is how far the line of sight to ``n`` passes beside ``m`` (metres at
    ``m``'s distance: the bearings' separation times that distance). A factor for ``l_m``
    beyond ``OCCLUSION_REACH`` widths (above 1 - 2e-8) is taken as 1. ``d[n]`` -1 stays -1
    (the caller multiplies its view by ``occ[n]`` when it computes it). ``wi`` and ``wq``
    (N,) are scratch space. The occluders are those in view at the pose's mean, whatever
    its uncertainty, so that every path of :func:`_predict_one` (exact or not, its view
    lazy or not) gives the same factors; a landmark just outside the view hides nothing."""
    # (The landmarks in range, and their squared distances, gathered first: a pose sees a
    # few of a map's landmarks, and only pairs of those are compared.)
    k = 0
    for n in range(L.shape[0]):
        occ[n] = 1.0
        if d[n] != 0.0:
            wi[k] = n
            wq[k] = (L[n, 0] - mu[0]) ** 2 + (L[n, 1] - mu[1]) ** 2
            k += 1
    reach2 = (OCCLUSION_REACH * width) ** 2
    inv = 0.5 / (width * width)
    for a in range(k):
        n = wi[a]
        f = 1.0
        for b in range(k):
            m = wi[b]
            if b == a or not wq[b] < wq[a] or (half_fov >= 0.0 and not abs(h[m]) <= half_fov):
                continue
            e = wrap_float(h[m] - h[n])
            l2 = e * e * wq[b]
            if l2 == 0.0:
                # Right behind: hidden, whatever the width (one so small that its square
                # underflows would make 0 * inf below).
                f = 0.0
            elif l2 < reach2:
                f *= -math.expm1(-l2 * inv)
        occ[n] = f
        if d[n] > 0.0:
            d[n] *= f


@njit(cache=True, error_model="numpy", nogil=True)
def occlusion_factors(rel: FloatArray, h: FloatArray, width: float) -> FloatArray:
    """The factors :func:`_occlude` puts on the detection probabilities of landmarks at
    ``rel`` (N, 2; metres from the sensor) seen at bearings ``h`` (N,), each one in view:
    what a simulator draws its reports with, by the tracker's own model."""
    n = rel.shape[0]
    occ = np.ones(n)
    _occlude(np.zeros(3), rel, h, np.ones(n), -1.0, width, occ, np.empty(n, np.int64), np.empty(n))
    return occ


@njit(cache=True, error_model="numpy", nogil=True)
def _odds(d: float, miss_weight: float) -> float:
    """A reading's detection odds: it takes its landmark's miss term back, and with the
    misses weighed by ``miss_weight`` what it takes back is the weighed term."""
    if miss_weight == 1.0:
        return d / max(1.0 - d, 1e-12)
    return d / max((1.0 - d) ** miss_weight, 1e-12)


@njit(cache=True, error_model="numpy", nogil=True)
def _faint_cut(fresh: float, share: float, rho_max: float, root_min: float, norm: float) -> float:
    """The exponent below which a reading (:func:`_reading`, of weight ``share``, odds at most
    ``rho_max``, a variance whose root is at least ``root_min``) is below ``fresh`` times
    2^-60: added to a sum that already holds ``fresh`` or more, it rounds away, so that the
    sum is the same bit for bit without it. -inf (nothing is faint) without a positive
    ``fresh`` or ``share``."""
    if not (fresh > 0.0 and share > 0.0 and rho_max > 0.0 and math.isfinite(rho_max)):
        return -math.inf
    return math.log(fresh) - 60.0 * math.log(2.0) - math.log(share * rho_max * norm / root_min)


#: A reading below this share of its bearing's clutter density adds nothing to the frame's
#: sum that survives rounding (:func:`_faint_cut`).
_FAINT_SHARE = 2.0**-60


@njit(cache=True, error_model="numpy", nogil=True)
def _exclusive_correction(rr: FloatArray, one_plus: FloatArray) -> float:
    """ln of the sum over assignments in which each landmark takes at most one bearing,
    minus ln of the product in which each bearing is weighed on its own (both relative to
    every bearing being clutter): ``rr[i, n]`` the reading of landmark n for bearing i over the
    bearing's clutter density, ``one_plus[i] = 1 + sum_n rr[i, n]``. Only the landmarks that
    two bearings or more read, and those bearings, enter (the rest factor out alike); more
    than 12 such bearings: 0. A reading below 2^-60 of its bearing's clutter density counts
    as none (it is zeroed in ``rr``): those are the faint readings the frame kernel does not
    compute, and they would change the sum by less than its last bit."""
    kz, N = rr.shape
    for i in range(kz):
        for n in range(N):
            if rr[i, n] < _FAINT_SHARE:
                rr[i, n] = 0.0
    cn = np.empty(N, dtype=np.int64)
    nc = 0
    for n in range(N):
        cnt = 0
        for i in range(kz):
            if rr[i, n] > 0.0:
                cnt += 1
        if cnt >= 2:
            cn[nc] = n
            nc += 1
    if nc == 0:
        return 0.0
    B = np.empty(kz, dtype=np.int64)
    nb = 0
    for i in range(kz):
        hit = False
        for c in range(nc):
            if rr[i, cn[c]] > 0.0:
                hit = True
        if hit:
            B[nb] = i
            nb += 1
    if nb > 12:
        return 0.0
    # Each bearing's readings and its uncontested part are taken over its whole sum
    # ``one_plus``: the sum over assignments is then that of the product's share, at most 1
    # (it is the product's with the double readings left out), and no product of large
    # readings (a clutter density near 0) can overflow.
    u = np.empty(nb)
    for b in range(nb):
        v = one_plus[B[b]]
        for c in range(nc):
            v -= rr[B[b], cn[c]]
        u[b] = max(v, 1.0) / one_plus[B[b]]
    size = 1 << nb
    dp = np.zeros(size)
    dp[0] = 1.0
    for c in range(nc):
        n = cn[c]
        for mask in range(size - 1, 0, -1):
            acc = dp[mask]
            for b in range(nb):
                if mask & (1 << b):
                    acc += dp[mask ^ (1 << b)] * (rr[B[b], n] / one_plus[B[b]])
            dp[mask] = acc
    share = 0.0
    for mask in range(size):
        term = dp[mask]
        for b in range(nb):
            if not mask & (1 << b):
                term *= u[b]
        share += term
    # (A share below the smallest double -- a dozen bearings that all read one landmark
    # alone, each thousands of times its clutter -- is taken as that double: the frame
    # weighs the pose down by 744 nats, not to minus infinity.)
    return math.log(min(max(share, 5e-324), 1.0))


@njit(cache=True, error_model="numpy", nogil=True)
def frame_update_kernel(
    mu: FloatArray,
    P: FloatArray,
    bearings: FloatArray,
    L: FloatArray,
    sigma2: float,
    kappa: float,
    p_detect: float,
    half_fov: float,
    max_range2: float,
    min_range2: float,
    min_q: float,
    min_reading: float,
    update: bool,
    fresh: float,
    core_share: float,
    core_sigma2: float,
    core_update: bool,
    update_scale: float,
    nonempty: bool,
    miss_weight: float,
    exclusive: bool,
    occlusion: float,
    obj_b: FloatArray,
    obj_w: FloatArray,
    obj_var: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Take one frame of bearings into H Gaussian hypotheses ``(mu, P)`` (copies are
    returned; ``P`` as given when ``update`` is False): the log-likelihood ratio of the
    frame (H,), the expected number of its bearings that are landmarks (H,), each
    hypothesis updated by the mixture of each bearing's readings, one bearing at a time
    (see :mod:`omniloc.track.likelihood`), each bearing's posterior probability of
    being clutter (H, k), and the farthest (m) each hypothesis's position had moved from
    where it began the frame when a bearing was predicted from it (H,; 0 for exactly known
    poses): every landmark in range of a position predicted from lies within the range plus
    that distance of the first.
    ``update`` False: exactly known poses (particles, ``P`` zero: one (1, 3, 3) zero matrix
    is enough), which no bearing moves -- the ratio only, from one prediction per pose;
    ``mu`` and ``P`` are returned as given.

    Clutter with memory: the clutter density at a bearing is ``kappa`` times ``fresh`` plus,
    for each object ``o`` of the previous frame (its bearing ``obj_b[o]`` in this frame, its
    expected count for hypothesis ``k`` ``obj_w[k, o]``), ``obj_w[k, o]`` times a Gaussian of
    variance ``obj_var`` around it; the objects' expected count is paid once per frame.
    ``fresh`` 1 and no objects: the memoryless model.

    A bearing's error is Gaussian with variance ``sigma2`` or, with ``core_share`` > 0, the
    mixture ``(1 - core_share) N(0, sigma2) + core_share N(0, core_sigma2)`` (a camera whose
    errors have a sharp core and a heavier tail); each landmark's reading is then two, one
    per component, each moving the pose by its own Kalman gain (``core_update`` True) or
    both together by the gain of variance ``sigma2`` (False: the core weighs, the update is
    the tail's). ``core_share`` 0: exactly the single Gaussian.

    ``update_scale``: a factor on the bearing variances (``sigma2``, ``core_sigma2``) in the
    Kalman update only, not in the weighing (1: the same model in both; ``1 / w`` is the
    update under a likelihood tempered by ``w``).

    ``miss_weight``: each landmark that could have been detected and was not costs
    ``miss_weight * ln(1 - d)``, and a reading of it has the odds ``d / (1 - d) **
    miss_weight`` (1: the model as written): a landmark reported earns ``d`` times its
    density whatever the weight, one not reported ``(1 - d) ** miss_weight``.

    ``nonempty``: the frame was recorded because it holds a bearing (a log that lists only
    frames with a detection); with at least one bearing, its likelihood (and the null's) is
    conditioned on that: each ratio is multiplied by ``P_null(some bearing) / P_k(some
    bearing)``, where ``P_k(no bearing) = prod (1 - d_n) exp(-clutter expected)``.

    ``exclusive``: a landmark explains at most one bearing of the frame. Each bearing's
    readings are computed as above (one bearing at a time, each on the hypothesis the ones
    before it moved); the frame's ratio is then the sum over the assignments in which no
    landmark takes two bearings instead of the product of the bearings' sums
    (:func:`_exclusive_correction`). The updates, the clutter posteriors and the counts of
    bearings explained are as without it.

    ``occlusion`` > 0: landmarks stand in each other's way. A landmark's detection
    probability is multiplied, for each nearer landmark, by ``1 - exp(-l^2 / (2
    occlusion^2))``, ``l`` being how far (m) the line of sight to it passes beside the
    nearer one (:func:`_occlude`): a tube right behind another is not expected to be seen.
    0: no landmark hides another."""
    # (Exactly known poses: neither mu nor P is changed, and P may be a single zero
    # covariance shared by every pose.)
    mu = mu.copy() if update else mu
    P = P.copy() if update else P
    H = mu.shape[0]
    N = L.shape[0]
    K = obj_b.shape[0]
    log_ratio = np.zeros(H)
    explained = np.zeros(H)
    clutter_post = np.zeros((H, bearings.shape[0]))
    reach = np.zeros(H)
    obj_norm = 1.0 / (math.sqrt(2.0 * math.pi * obj_var) * kappa) if K else 0.0
    fresh_cost = (
        (1.0 - fresh) * kappa * 2.0 * math.pi
        if half_fov < 0.0
        else ((1.0 - fresh) * kappa * 2.0 * half_fov)
    )
    # Expected clutter counts over the view: the null's, and the fresh part of the model's.
    null_rate = kappa * (2.0 * math.pi if half_fov < 0.0 else 2.0 * half_fov)
    fresh_rate = fresh * null_rate
    null_some = math.log(-math.expm1(-null_rate)) if nonempty else 0.0
    h = np.empty(N)
    J = np.empty((N, 3))
    var = np.empty(N)
    d = np.empty(N)
    # (Landmarks hidden behind nearer ones: each one's factor, and scratch space.)
    n_occ = N if occlusion > 0.0 else 0
    occ = np.ones(n_occ)
    occ_i = np.empty(n_occ, dtype=np.int64)
    occ_q = np.empty(n_occ)
    a = np.empty(N)
    ac = np.zeros(N)
    nu = np.empty(N)
    wide = 1.0 - core_share
    components = 2 if core_share > 0.0 and core_update else 1
    PJ = np.empty(3)
    mean = np.empty(3)
    M = np.empty((3, 3))
    norm = 1.0 / (math.sqrt(2.0 * math.pi) * kappa)
    # (0 + sigma2 is sigma2: an exactly known pose's readings use these roots, bit for bit
    # the ones _reading takes.)
    root_wide = math.sqrt(sigma2)
    root_core = math.sqrt(core_sigma2)
    # Exactly known poses and a view narrower than a half turn: the cheap test of who is out
    # of view (see _predict_one), with a margin of 1e-7 rad beyond the edge.
    edge = half_fov + 1e-7
    tan_out = math.tan(edge) if not update and 0.0 <= half_fov and edge < 1.5 else -1.0
    last_d = -1.0
    last_log = 0.0
    # Faint readings: a bearing's sum of readings starts at its clutter density, at least
    # ``fresh``; a reading below fresh * 2^-60 rounds away in it and, as a share of it, is
    # below any ``min_reading`` that moves a hypothesis -- it is not computed (the results
    # are the same, bit for bit). Its exponent's cut follows from the largest odds (a
    # landmark fully in view: d = p_detect, the odds growing with d for miss_weight >= 0)
    # and the smallest variance (the sensor's alone).
    rho_max = _odds(p_detect, miss_weight)
    if not (miss_weight >= 0.0 and min_reading >= 2.0**-50):
        rho_max = 0.0
    cut_wide = _faint_cut(fresh, wide, rho_max, root_wide, norm)
    cut_core = _faint_cut(fresh, core_share, rho_max, root_core, norm)
    inv_wide = 1.0 / sigma2 if sigma2 > 0.0 else 0.0
    inv_core = 1.0 / core_sigma2 if core_sigma2 > 0.0 else 0.0
    # (Exactly known poses: the landmarks in view, and their odds.)
    view = np.empty(N, dtype=np.int64)
    view_rho = np.empty(N)
    kz = bearings.shape[0]
    rr = np.zeros((kz if exclusive else 0, N))
    one_plus = np.ones(kz if exclusive else 0)
    # Each object's Gaussian at each bearing (the same for every hypothesis; each
    # hypothesis weighs it by its own expected count).
    obj_g = np.empty((bearings.shape[0], K))
    for iz in range(bearings.shape[0]):
        for o in range(K):
            e = wrap_float(bearings[iz] - obj_b[o])
            obj_g[iz, o] = _exp(-0.5 * e * e / obj_var)
    for k in range(H):
        m = mu[k]
        C = P[k] if update else P[0]
        _predict_one(
            m,
            C,
            L,
            p_detect,
            half_fov,
            max_range2,
            min_range2,
            min_q,
            h,
            J,
            var,
            d,
            tan_out,
            not update,
        )
        if occlusion > 0.0:
            _occlude(m, L, h, d, half_fov, occlusion, occ, occ_i, occ_q)
        s = 0.0
        for n in range(N):
            if d[n] > 0.0:
                # (Exactly known poses give every landmark in view the same d: its log1p is
                # computed once.)
                dn = min(d[n], 1.0 - 1e-12)
                if dn != last_d:
                    last_d = dn
                    last_log = math.log1p(-dn)
                s += last_log * miss_weight
        for o in range(K):
            s -= obj_w[k, o]
        log_ratio[k] = s + fresh_cost
        if nonempty and bearings.shape[0] > 0:
            # ln P(no bearing) = s - fresh clutter expected (the misses weighed as above);
            # the null's: - null_rate.
            log_ratio[k] += null_some - math.log(-math.expm1(s - fresh_rate))
        n_view = 0
        if not update:
            for n in range(N):
                if d[n] != 0.0:
                    view[n_view] = n
                    view_rho[n_view] = _odds(d[n], miss_weight)
                    n_view += 1
        # The prediction is redone only after a bearing has moved the hypothesis (the same
        # pose and covariance predict the same, bit for bit).
        moved = False
        x0, y0 = m[0], m[1]
        for iz in range(bearings.shape[0]):
            z = bearings[iz]
            if update and moved:
                # (How far the position predicted from has moved in the frame.)
                r = math.hypot(m[0] - x0, m[1] - y0)
                if not r <= reach[k]:
                    reach[k] = r
                _predict_one(
                    m,
                    C,
                    L,
                    p_detect,
                    half_fov,
                    max_range2,
                    min_range2,
                    min_q,
                    h,
                    J,
                    var,
                    d,
                    -1.0,
                    False,
                    True,
                )
                if occlusion > 0.0:
                    _occlude(m, L, h, d, half_fov, occlusion, occ, occ_i, occ_q)
                moved = False
            base = fresh
            for o in range(K):
                if obj_w[k, o] > 0.0:
                    base += obj_w[k, o] * obj_g[iz, o] * obj_norm
            total = base
            if not update:
                # An exactly known pose: the landmarks in view and their odds are those of
                # the one prediction; the variances are the sensor's (var 0), their square
                # roots taken once; the readings are not kept (nothing moves).
                if exclusive:
                    rr[iz, :] = 0.0
                for j in range(n_view):
                    n = view[j]
                    e = wrap_float(z - h[n])
                    q = -0.5 * e * e
                    if q * inv_wide < cut_wide and (core_share <= 0.0 or q * inv_core < cut_core):
                        continue  # both readings faint (see above)
                    if core_share > 0.0:
                        r = _reading_root(
                            wide, view_rho[j], e, sigma2, root_wide, norm
                        ) + _reading_root(core_share, view_rho[j], e, core_sigma2, root_core, norm)
                    else:
                        r = _reading_root(1.0, view_rho[j], e, sigma2, root_wide, norm)
                    total += r
                    if exclusive:
                        rr[iz, n] = r
            for n in range(N if update else 0):
                if d[n] == 0.0:
                    a[n] = 0.0
                    ac[n] = 0.0
                    continue
                S = var[n] + sigma2
                nu[n] = wrap_float(z - h[n])
                q = -0.5 * nu[n] * nu[n]
                if q / S < cut_wide and (
                    core_share <= 0.0 or q / (var[n] + core_sigma2) < cut_core
                ):
                    # Both readings faint (see above).
                    a[n] = 0.0
                    ac[n] = 0.0
                    continue
                if d[n] < 0.0:
                    # (Its chance of being in view, not computed since the bearing before
                    # moved the hypothesis: see _predict_one's lazy_view. Out of view, d 0
                    # gives readings of 0, as the test of d above would.)
                    d[n] = _view_d(p_detect, half_fov, h[n], var[n])
                    if occlusion > 0.0:
                        d[n] *= occ[n]
                rho = _odds(d[n], miss_weight)
                if core_share > 0.0:
                    a[n] = _reading(wide, rho, nu[n], S, norm)
                    ac[n] = _reading(core_share, rho, nu[n], var[n] + core_sigma2, norm)
                    total += a[n] + ac[n]
                else:
                    a[n] = _reading(1.0, rho, nu[n], S, norm)
                    total += a[n]
            log_ratio[k] += math.log(total)
            explained[k] += 1.0 - base / total
            clutter_post[k, iz] = base / total
            if exclusive:
                if update:
                    for n in range(N):
                        rr[iz, n] = a[n] + ac[n]
                for n in range(N):
                    rr[iz, n] /= base
                one_plus[iz] = total / base
            if not update:
                continue
            mean[:] = 0.0
            M[:, :] = 0.0  # minus the shrink plus the spread of the readings
            used = False
            for n in range(N):
                for comp in range(components):
                    if comp == 0:
                        b = (a[n] if components == 2 else a[n] + ac[n]) / total
                        S = var[n] + sigma2 * update_scale
                    else:
                        b = ac[n] / total
                        S = var[n] + core_sigma2 * update_scale
                    if not b > min_reading:
                        continue
                    used = True
                    for i in range(3):
                        PJ[i] = C[i, 0] * J[n, 0] + C[i, 1] * J[n, 1] + C[i, 2] * J[n, 2]
                    for i in range(3):
                        Ki = PJ[i] / S
                        mean[i] += b * Ki * nu[n]
                        for j in range(3):
                            Kj = PJ[j] / S
                            M[i, j] += b * (Ki * Kj * nu[n] * nu[n] - S * Ki * Kj)
            if not used:
                continue
            for i in range(3):
                for j in range(3):
                    M[i, j] -= mean[i] * mean[j]
            for i in range(3):
                for j in range(i, 3):
                    v = C[i, j] + 0.5 * (M[i, j] + M[j, i])
                    C[i, j] = v
                    C[j, i] = v
            for i in range(3):
                m[i] += mean[i]
            m[2] = wrap_float(m[2])
            moved = True
        if exclusive and kz >= 2:
            log_ratio[k] += _exclusive_correction(rr, one_plus)
    return mu, P, log_ratio, explained, clutter_post, reach


@njit(cache=True, error_model="numpy", nogil=True)
def resample_kernel(
    cum: FloatArray, u0: float, m_keep: int, poses: FloatArray, memory: FloatArray, m_new: int
) -> tuple[FloatArray, FloatArray]:
    """Systematic resampling's copies: for ``u_j = (u0 + j) / m_keep``, ``j < m_keep``, the
    particle ``min(searchsorted(cum, u_j), n - 1)`` (``cum`` the weights' running sum), its
    pose and memory row copied in one pass over the sorted ``u_j``. Returns ``m_keep +
    m_new`` poses and memory rows, the last ``m_new`` poses unwritten (the fresh draws') and
    memory rows zero."""
    n = cum.shape[0]
    out_p = np.empty((m_keep + m_new, 3))
    out_m = np.zeros((m_keep + m_new, memory.shape[1]))
    i = 0
    for j in range(m_keep):
        u = (u0 + j) / m_keep
        # (searchsorted's left side: the first i with cum[i] >= u; a NaN is never below u.)
        while i < n and cum[i] < u:
            i += 1
        k = min(i, n - 1)
        out_p[j, 0] = poses[k, 0]
        out_p[j, 1] = poses[k, 1]
        out_p[j, 2] = poses[k, 2]
        for o in range(memory.shape[1]):
            out_m[j, o] = memory[k, o]
    return out_p, out_m


@njit(cache=True, error_model="numpy", nogil=True)
def covered_kernel(
    poses: FloatArray, mu: FloatArray, Pinv: FloatArray, radius: FloatArray, chi2: float
) -> NDArray[np.bool_]:
    """Which of the M poses (M, 3) lie within squared Mahalanobis distance ``chi2`` of any
    of the H Gaussians ``(mu, Pinv)`` (the inverse covariances; headings compared wrapped).
    Only poses within ``radius[k]`` of ``mu[k]`` in x, y are tested against it (the
    caller's bound on the Gaussian's region)."""
    M = poses.shape[0]
    out = np.zeros(M, dtype=np.bool_)
    for k in range(mu.shape[0]):
        r2 = radius[k] * radius[k]
        for i in range(M):
            if out[i]:
                continue
            d0 = poses[i, 0] - mu[k, 0]
            d1 = poses[i, 1] - mu[k, 1]
            if d0 * d0 + d1 * d1 > r2:
                continue
            d2 = wrap_float(poses[i, 2] - mu[k, 2])
            G = Pinv[k]
            m2 = (
                d0 * (G[0, 0] * d0 + G[0, 1] * d1 + G[0, 2] * d2)
                + d1 * (G[1, 0] * d0 + G[1, 1] * d1 + G[1, 2] * d2)
                + d2 * (G[2, 0] * d0 + G[2, 1] * d1 + G[2, 2] * d2)
            )
            if m2 <= chi2:
                out[i] = True
    return out


@njit(cache=True, error_model="numpy", nogil=True)
def _pair_form(A: FloatArray, B: FloatArray, d0: float, d1: float, d2: float) -> float:
    """``d^T (A + B)^-1 d`` (the sum's upper triangle, by Cramer's rule); inf where the
    sum's determinant is not positive."""
    h00 = A[0, 0] + B[0, 0]
    h01 = A[0, 1] + B[0, 1]
    h02 = A[0, 2] + B[0, 2]
    h11 = A[1, 1] + B[1, 1]
    h12 = A[1, 2] + B[1, 2]
    h22 = A[2, 2] + B[2, 2]
    if not det3(h00, h01, h02, h11, h12, h22) > 0.0:
        return np.inf
    c00, c01, c02, c11, c12, c22, _ = inv3(h00, h01, h02, h11, h12, h22, 1.0, 0.0)
    return form3(c00, c01, c02, c11, c12, c22, d0, d1, d2)


@njit(cache=True, error_model="numpy", nogil=True)
def _same_pose(
    mu_a: FloatArray,
    Pa: FloatArray,
    a: int,
    mu_b: FloatArray,
    Pb: FloatArray,
    b: int,
    max_d2: float,
    max_heading: float,
    max_form: float,
) -> bool:
    """Whether poses ``mu_a[a]`` and ``mu_b[b]`` are the same: their positions within
    ``max_d2`` (squared distance; inf: any), the wrapped heading difference within
    ``max_heading`` and :func:`_pair_form` of the difference on the summed covariances at
    most ``max_form`` (False for a NaN). The one test of :func:`same_of_pairs`,
    :func:`near_pairs` and :func:`grid_pairs`."""
    g0 = mu_a[a, 0] - mu_b[b, 0]
    g1 = mu_a[a, 1] - mu_b[b, 1]
    if not g0 * g0 + g1 * g1 <= max_d2:
        return False
    g2 = wrap_float(mu_a[a, 2] - mu_b[b, 2])
    if not abs(g2) <= max_heading:
        return False
    return _pair_form(Pa[a], Pb[b], g0, g1, g2) <= max_form


@njit(cache=True, error_model="numpy", nogil=True)
def same_of_pairs(
    mu_a: FloatArray,
    Pa: FloatArray,
    mu_b: FloatArray,
    Pb: FloatArray,
    ia: IntArray,
    ib: IntArray,
    max_heading: float,
    max_form: float,
) -> NDArray[np.bool_]:
    """Which of the candidate pairs ``(ia[k], ib[k])`` (near in position: a k-d tree's) are
    the same pose (:func:`_same_pose`)."""
    out = np.zeros(ia.shape[0], dtype=np.bool_)
    for k in range(ia.shape[0]):
        out[k] = _same_pose(mu_a, Pa, ia[k], mu_b, Pb, ib[k], math.inf, max_heading, max_form)
    return out


@njit(cache=True, error_model="numpy", nogil=True)
def near_pairs(
    mu_a: FloatArray,
    Pa: FloatArray,
    mu_b: FloatArray,
    Pb: FloatArray,
    max_d2: float,
    max_heading: float,
    max_form: float,
) -> tuple[IntArray, IntArray]:
    """The pairs ``(a, b)`` of the poses ``mu_a`` (A, 3) and ``mu_b`` (B, 3), ordered by
    ``a`` then ``b``, that are the same pose: ``dx^2 + dy^2 <= max_d2`` and
    :func:`_same_pose`. Every pair is tried (for small sets; :func:`same_of_pairs` takes a
    k-d tree's candidates for large ones)."""
    ia = np.empty(mu_a.shape[0] * mu_b.shape[0], dtype=np.int64)
    ib = np.empty_like(ia)
    n = 0
    for a in range(mu_a.shape[0]):
        for b in range(mu_b.shape[0]):
            if _same_pose(mu_a, Pa, a, mu_b, Pb, b, max_d2, max_heading, max_form):
                ia[n] = a
                ib[n] = b
                n += 1
    return ia[:n].copy(), ib[:n].copy()


@njit(cache=True, error_model="numpy", nogil=True)
def grid_pairs(
    mu_a: FloatArray,
    Pa: FloatArray,
    mu_b: FloatArray,
    Pb: FloatArray,
    max_d2: float,
    max_heading: float,
    max_form: float,
) -> tuple[IntArray, IntArray, bool]:
    """:func:`near_pairs` for large sets: the poses ``mu_b`` are put in square cells as wide
    as the largest distance, and each pose of ``mu_a`` tries those in the 3 x 3 cells around
    its own only (the same test, the same pairs in the same order). Returns the pairs and
    True, or empty arrays and False when the cells would be too many (a spread beyond 2^20
    cells either way; the caller then looks for the pairs another way).

    The cells are a millionth wider than the distance: two poses within it are then in
    neighbouring cells whatever the rounding of their cell numbers (below 2^20, it is
    under 1e-9 of a cell)."""
    none = np.empty(0, dtype=np.int64)
    A = mu_a.shape[0]
    B = mu_b.shape[0]
    cell = math.sqrt(max_d2) * (1.0 + 1e-6)
    if not (cell > 0.0 and math.isfinite(cell)):
        return none, none, False
    # Cells of the poses of b with a finite position (no other can pass the distance test).
    x0 = math.inf
    y0 = math.inf
    x1 = -math.inf
    y1 = -math.inf
    for b in range(B):
        x, y = mu_b[b, 0], mu_b[b, 1]
        if math.isfinite(x) and math.isfinite(y):
            x0, x1 = min(x0, x), max(x1, x)
            y0, y1 = min(y0, y), max(y1, y)
    if not x0 <= x1:
        return none, none, True  # no b with a finite position: no pair
    nx = math.floor((x1 - x0) / cell) + 3.0
    ny = math.floor((y1 - y0) / cell) + 3.0
    if not (nx < 2.0**20 and ny < 2.0**20):
        return none, none, False
    w = np.int64(ny)
    keys = np.empty(B, dtype=np.int64)
    n_in = 0
    members = np.empty(B, dtype=np.int64)
    for b in range(B):
        x, y = mu_b[b, 0], mu_b[b, 1]
        if math.isfinite(x) and math.isfinite(y):
            # (Cells numbered from 1: the cells around any of them are numbered too.)
            cx = np.int64(math.floor((x - x0) / cell)) + 1
            cy = np.int64(math.floor((y - y0) / cell)) + 1
            keys[n_in] = cx * w + cy
            members[n_in] = b
            n_in += 1
    keys = keys[:n_in]
    members = members[:n_in]
    order = np.argsort(keys, kind="mergesort")
    keys = keys[order]
    members = members[order]
    ia = np.empty(16, dtype=np.int64)
    ib = np.empty(16, dtype=np.int64)
    found = np.empty(B, dtype=np.int64)
    n = 0
    for a in range(A):
        x, y = mu_a[a, 0], mu_a[a, 1]
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        fx = math.floor((x - x0) / cell) + 1.0
        fy = math.floor((y - y0) / cell) + 1.0
        if not (-1.0 <= fx <= nx and -1.0 <= fy <= ny):
            continue  # more than a cell beyond every b: no pair
        cx = np.int64(fx)
        cy = np.int64(fy)
        m = 0
        for ddx in range(-1, 2):
            for ddy in range(-1, 2):
                kx, ky = cx + ddx, cy + ddy
                if kx < 0 or ky < 0 or ky >= w:
                    continue
                key = kx * w + ky
                j = np.searchsorted(keys, key)
                while j < n_in and keys[j] == key:
                    b = members[j]
                    j += 1
                    if _same_pose(mu_a, Pa, a, mu_b, Pb, b, max_d2, max_heading, max_form):
                        found[m] = b
                        m += 1
        if m == 0:
            continue
        found[:m].sort()
        if n + m > ia.shape[0]:
            size = max(2 * ia.shape[0], n + m)
            grown_a = np.empty(size, dtype=np.int64)
            grown_b = np.empty(size, dtype=np.int64)
            grown_a[:n] = ia[:n]
            grown_b[:n] = ib[:n]
            ia, ib = grown_a, grown_b
        for t in range(m):
            ia[n] = a
            ib[n] = found[t]
            n += 1
    return ia[:n].copy(), ib[:n].copy(), True
