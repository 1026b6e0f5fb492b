"""The tracker's compiled steps against the numpy formulas they stand for."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc._kernels.track import merge_kernel, particles_move_kernel, refine_frames_kernel
from omniloc.angles import wrap
from omniloc.track.elsewhere import JITTER, Elsewhere
from omniloc.track.motion import compose


@settings(max_examples=60, deadline=None)  # (the first call may compile the kernel)
@given(
    seed=st.integers(0, 2**32 - 1),
    m=st.integers(0, 40),
    scale=st.sampled_from([1e-6, 1e-2, 1.0, 10.0]),
)
def test_particles_move_is_numpys_compose_bit_for_bit(seed: int, m: int, scale: float) -> None:
    rng = np.random.default_rng(seed)
    poses = np.column_stack(
        [rng.uniform(-10, 10, m), rng.uniform(-10, 10, m), rng.uniform(-math.pi, math.pi, m)]
    )
    delta = rng.normal(scale=scale, size=3)
    noise = rng.normal(scale=scale, size=(m, 3))
    z_jitter = rng.normal(size=(m, 3))
    jitter = np.asarray(JITTER)
    expect = compose(poses, delta[None, :] + (noise + z_jitter * jitter))
    got = particles_move_kernel(poses, delta, noise, jitter, z_jitter)
    assert got.shape == (m, 3)
    assert np.array_equal(got, expect)


def test_elsewhere_moves_its_particles_by_the_odometry_and_its_own_draws() -> None:
    region = (-1.0, 5.0, -2.0, 3.0)
    e = Elsewhere(region, 500, 0.01, seed=7)
    twin = Elsewhere(region, 500, 0.01, seed=7)
    before = e.poses.copy()
    delta = np.array([0.05, 0.01, 0.02])
    Q = np.array([[1e-4, 1e-6, 0.0], [1e-6, 4e-5, 2e-6], [0.0, 2e-6, 3e-5]])
    e.move(delta, Q)
    # the same draws, in the same order, through numpy
    vals, vecs = np.linalg.eigh(0.5 * (Q + Q.T))
    root = vecs * np.sqrt(np.maximum(vals, 0.0))
    r = twin._rng
    noise = r.standard_normal((500, 3)) @ root.T
    noise += r.standard_normal((500, 3)) * np.asarray(JITTER)
    assert np.array_equal(e.poses, compose(before, delta[None, :] + noise))


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(2, 400),
    K=st.integers(0, 3),
    inject=st.sampled_from([0.0, 0.01, 0.3]),
    skew=st.sampled_from([1.0, 5.0, 50.0]),
)
def test_resampling_copies_the_particles_numpys_searchsorted_picks(
    seed: int, n: int, K: int, inject: float, skew: float
) -> None:
    # Elsewhere's systematic resampling (its copies in one compiled pass) against the
    # numpy it replaces, with the same draws: weights from even to one particle holding
    # nearly all, some particles with none (excluded), memory of 0-3 objects.
    rng = np.random.default_rng(seed)
    region = (-1.0, 5.0, -2.0, 3.0)
    e = Elsewhere(region, n, inject, seed=seed)
    twin = Elsewhere(region, n, inject, seed=seed)
    logw = rng.normal(scale=skew, size=n)
    logw[rng.random(n) < 0.2] = -np.inf
    logw[0] = 0.0
    logw -= math.log(float(np.exp(logw).sum()))
    memory = rng.random((n, K))
    for x in (e, twin):
        x.logw, x.memory = logw.copy(), memory.copy()
    e.resample()
    # numpy, with the twin's generator
    w = np.exp(logw)
    w = w / w.sum()
    if 1.0 / float(np.sum(w * w)) >= 0.5 * n:
        assert np.array_equal(e.poses, twin.poses) and np.array_equal(e.logw, logw)
        return
    m_new = round(inject * n)
    m_keep = n - m_new
    u = (twin._rng.uniform() + np.arange(m_keep)) / m_keep
    idx = np.minimum(np.searchsorted(np.cumsum(w), u), n - 1)
    poses = np.concatenate([twin.poses[idx], twin._uniform(m_new)])
    mem = np.concatenate([memory[idx], np.zeros((m_new, K))])
    assert np.array_equal(e.poses, poses)
    assert np.array_equal(e.memory, mem)
    assert np.array_equal(e.logw, np.full(n, -math.log(n)))
    # the generators are at the same place afterwards
    assert e._rng.uniform() == twin._rng.uniform()


def test_resampling_takes_searchsorteds_side_on_ties_and_nans() -> None:
    # Running sums equal to some u_j (ties go to the first such particle, searchsorted's
    # left side), a particle of zero weight between, and a sum that is NaN from some point.
    from omniloc._kernels.track import resample_kernel

    poses = np.arange(18, dtype=np.float64).reshape(6, 3)
    memory = np.arange(6, dtype=np.float64).reshape(6, 1)
    for cum in (
        np.array([0.25, 0.25, 0.5, 0.75, 1.0, 1.0]),
        np.array([0.0, 0.5, 0.5, 0.75, np.nan, np.nan]),
    ):
        for u0 in (0.0, 0.5, 0.999):
            u = (u0 + np.arange(4)) / 4
            idx = np.minimum(np.searchsorted(cum, u), 5)
            got_p, got_m = resample_kernel(cum, u0, 4, poses, memory, 2)
            assert np.array_equal(got_p[:4], poses[idx]), (cum, u0)
            assert np.array_equal(got_m, np.concatenate([memory[idx], np.zeros((2, 1))]))


def _merge_reference(
    mu: np.ndarray,
    P: np.ndarray,
    logw: np.ndarray,
    rest: dict[str, np.ndarray],
    pa: np.ndarray,
    pb: np.ndarray,
    ids: np.ndarray,
    localized: int | None,
) -> tuple[np.ndarray, int | None]:
    """The merge as numpy wrote it before it was compiled (in place; returns alive and the
    localized id)."""
    H = mu.shape[0]
    alive = np.ones(H, dtype=bool)
    starts = np.searchsorted(pa, np.arange(H + 1))
    for i in np.unique(pa).tolist():
        if not alive[i]:
            continue
        same = pb[starts[i] : starts[i + 1]]
        same = same[alive[same]]
        if same.size == 0:
            continue
        grp = np.concatenate([[i], same])
        w = np.exp(logw[grp] - logw[i])
        w = w / w.sum()
        d = mu[grp] - mu[i]
        d[:, 2] = np.asarray(wrap(d[:, 2]))
        mean = w @ d
        dd = d - mean
        P[i] = np.einsum("n,nij->ij", w, P[grp]) + np.einsum("n,ni,nj->ij", w, dd, dd)
        mu[i] = mu[i] + mean
        mu[i, 2] = float(wrap(mu[i, 2]))
        top = logw[grp].max()
        logw[i] = top + math.log(np.exp(logw[grp] - top).sum())
        rest["born"][i] = rest["born"][grp].min()
        rest["conf"][i] = rest["conf"][grp].max()
        rest["conf_t"][i] = rest["conf_t"][grp].max()
        rest["fit_m"][i] = w @ rest["fit_m"][grp]
        rest["fit_n"][i] = w @ rest["fit_n"][grp]
        rest["mem_w"][i] = w @ rest["mem_w"][grp]
        if localized is not None and np.isin(localized, ids[same]):
            localized = int(ids[i])
        alive[same] = False
    return alive, localized


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), H=st.integers(1, 30), K=st.integers(0, 4))
def test_merge_kernel_is_the_moment_matching_it_replaces(seed: int, H: int, K: int) -> None:
    rng = np.random.default_rng(seed)
    # A few places, several hypotheses at each (headings across the wrap), heaviest first.
    centres = rng.uniform(-3, 3, (3, 3))
    mu = centres[rng.integers(0, 3, H)] + rng.normal(scale=0.05, size=(H, 3))
    mu[:, 2] = np.asarray(wrap(mu[:, 2] + math.pi))
    A = rng.normal(scale=0.1, size=(H, 3, 3))
    P = A @ np.swapaxes(A, 1, 2) + 1e-3 * np.eye(3)
    logw = np.sort(rng.normal(size=H))[::-1].copy()
    rest = {
        "born": rng.uniform(0, 100, H),
        "conf": rng.integers(0, 5, H).astype(np.int64),
        "conf_t": rng.uniform(0, 100, H),
        "fit_m": rng.uniform(0, 5, H),
        "fit_n": rng.uniform(5, 10, H),
        "mem_w": rng.uniform(0, 1, (H, K)),
    }
    ids = rng.integers(0, max(1, H // 2), H).astype(np.int64)  # split copies share an id
    localized = int(ids[rng.integers(0, H)]) if rng.uniform() < 0.7 else None
    # pairs (a, b), a < b, ordered: those of nearby hypotheses
    d = mu[:, None, :2] - mu[None, :, :2]
    near = np.hypot(d[..., 0], d[..., 1]) < 0.08
    pa, pb = np.nonzero(np.triu(near, 1))
    pa, pb = pa.astype(np.int64), pb.astype(np.int64)

    mu0, P0, lw0 = mu.copy(), P.copy(), logw.copy()
    rest0 = {k: v.copy() for k, v in rest.items()}
    alive_ref, loc_ref = _merge_reference(mu0, P0, lw0, rest0, pa, pb, ids, localized)

    alive, total, loc = merge_kernel(
        pa,
        pb,
        np.exp(logw[pb] - logw[pa]),
        mu,
        P,
        rest["born"],
        rest["conf"],
        rest["conf_t"],
        rest["fit_m"],
        rest["fit_n"],
        rest["mem_w"],
        ids,
        -1 if localized is None else localized,
    )
    logw = logw + np.log(total)
    assert np.array_equal(alive, alive_ref)
    assert (None if localized is None else int(loc)) == loc_ref
    keep = alive_ref
    np.testing.assert_allclose(mu[keep], mu0[keep], rtol=0, atol=1e-12)
    np.testing.assert_allclose(P[keep], P0[keep], rtol=0, atol=1e-12)
    np.testing.assert_allclose(logw[keep], lw0[keep], rtol=0, atol=1e-12)
    for k in ("born", "conf", "conf_t"):
        assert np.array_equal(rest[k][keep], rest0[k][keep]), k
    for k in ("fit_m", "fit_n", "mem_w"):
        np.testing.assert_allclose(rest[k][keep], rest0[k][keep], rtol=0, atol=1e-12)
    # hypotheses that absorbed nothing are as they were
    untouched = total == 1.0
    assert np.array_equal(mu[untouched & keep], mu0[untouched & keep])


def _refine_reference(
    L: np.ndarray, rel: np.ndarray, z: np.ndarray, lm: np.ndarray, poses: np.ndarray, sigma: float
) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton on the frames' bearings as numpy wrote it before it was compiled."""
    C = poses.shape[0]
    wide = np.diag([1.0, 1.0, 0.1])
    ok = lm >= 0
    Lx = np.where(ok, L[np.maximum(lm, 0), 0], 0.0)
    Ly = np.where(ok, L[np.maximum(lm, 0), 1], 0.0)
    T = poses.copy()
    tx, ty, phi = rel[:, 0], rel[:, 1], rel[:, 2]
    info = np.zeros((C, 3, 3))
    for _ in range(6):
        c, s_ = np.cos(T[:, 2])[:, None], np.sin(T[:, 2])[:, None]
        dx = Lx - (T[:, 0:1] + c * tx - s_ * ty)
        dy = Ly - (T[:, 1:2] + s_ * tx + c * ty)
        q = np.maximum(dx * dx + dy * dy, 1e-12)
        r = np.where(ok, np.asarray(wrap(z - (np.arctan2(dy, dx) - (T[:, 2:3] + phi)))), 0.0)
        J = np.empty((C, z.size, 3))
        J[..., 0] = dy / q
        J[..., 1] = -dx / q
        J[..., 2] = J[..., 0] * (-s_ * tx - c * ty) + J[..., 1] * (c * tx - s_ * ty) - 1.0
        J[~ok] = 0.0
        info = np.einsum("cni,cnj->cij", J, J)
        g = np.einsum("cni,cn->ci", J, r)
        good = np.abs(np.linalg.det(info)) > 1e-12
        step = np.zeros((C, 3))
        if good.any():
            step[good] = np.linalg.solve(info[good], g[good][..., None])[..., 0]
        T = T + np.where(np.isfinite(step), step, 0.0)
        T[:, 2] = np.asarray(wrap(T[:, 2]))
    covs = np.repeat(wide[None], C, axis=0)
    good = (np.abs(np.linalg.det(info)) > 1e-12) & np.isfinite(T).all(axis=1)
    if good.any():
        covs[good] = sigma * sigma * np.linalg.inv(info[good])
    bad = ~good | ~np.isfinite(covs).all(axis=(1, 2))
    T[bad] = poses[bad]
    covs[bad] = wide
    return T, covs


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), C=st.integers(0, 25), n=st.integers(0, 9))
def test_refine_kernel_is_the_gauss_newton_it_replaces(seed: int, C: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    L = rng.uniform(-4, 4, (6, 2))
    truth = np.array([0.3, -0.2, 0.4])
    rel = np.column_stack(
        [
            rng.normal(scale=0.3, size=n),
            rng.normal(scale=0.1, size=n),
            rng.normal(scale=0.1, size=n),
        ]
    )
    lm_true = rng.integers(0, 6, n)
    # bearings of the assigned landmarks from the truth composed with each frame's motion
    seen = compose(np.tile(truth, (n, 1)), rel)
    z = np.asarray(
        wrap(
            np.arctan2(L[lm_true, 1] - seen[:, 1], L[lm_true, 0] - seen[:, 0])
            - seen[:, 2]
            + rng.normal(scale=0.01, size=n)
        )
    )
    lm = np.tile(lm_true, (C, 1)).astype(np.int64)
    lm[rng.uniform(size=(C, n)) < 0.2] = -1  # some bearings left as clutter
    poses = truth + rng.normal(scale=[0.2, 0.2, 0.1], size=(C, 3))
    poses[:, 2] = np.asarray(wrap(poses[:, 2]))
    T, covs = refine_frames_kernel(L, rel, z, lm, poses, 0.01, 6)
    T_ref, covs_ref = _refine_reference(L, rel, z, lm, poses, 0.01)
    assert T.shape == (C, 3) and covs.shape == (C, 3, 3)
    # The same poses, but for rounding that an ill-conditioned fit amplifies: within a
    # ten-thousandth of each candidate's own standard deviation (and the same covariances to a
    # ten-thousandth of their size) -- where the fit stayed on the map (a fit that ran off
    # kilometres, which the tracker drops, is chaotic in its last bits).
    on_map = np.hypot(T_ref[:, 0], T_ref[:, 1]) < 10.0
    sd = np.sqrt(np.diagonal(covs_ref, axis1=1, axis2=2))
    assert (np.abs(T - T_ref) <= 1e-9 + 1e-4 * sd)[on_map].all()
    size = np.abs(covs_ref).max(axis=(1, 2), initial=0.0)[:, None, None]
    assert (np.abs(covs - covs_ref) <= 1e-4 * size)[on_map].all()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), H=st.integers(1, 20))
def test_a_places_estimate_is_the_moment_matching_of_its_hypotheses(seed: int, H: int) -> None:
    from omniloc._kernels.track import place_kernel

    rng = np.random.default_rng(seed)
    mu = np.column_stack(
        [rng.normal(scale=0.1, size=(H, 2)), np.asarray(wrap(math.pi + rng.normal(0, 0.05, H)))]
    )
    A = rng.normal(scale=0.1, size=(H, 3, 3))
    P = A @ np.swapaxes(A, 1, 2) + 1e-3 * np.eye(3)
    near = np.sort(rng.choice(H, size=int(rng.integers(1, H + 1)), replace=False))
    i = int(near[0])
    w = np.exp(rng.normal(size=near.size))
    # numpy, as _place_estimate wrote it before it was compiled
    wn = w / w.sum()
    d = mu[near] - mu[i]
    d[:, 2] = np.asarray(wrap(d[:, 2]))
    mean = wn @ d
    dd = d - mean
    P_ref = np.einsum("n,nij->ij", wn, P[near]) + np.einsum("n,ni,nj->ij", wn, dd, dd)
    mu_ref = mu[i] + mean
    mu_ref[2] = float(wrap(mu_ref[2]))
    w0 = w.copy()
    got_mu, got_P = place_kernel(near, w, mu, P, i)
    np.testing.assert_allclose(got_mu, mu_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got_P, P_ref, rtol=0, atol=1e-12)
    assert np.array_equal(w, w0)  # the weights given are left as they were


def _kernel_without_faint_readings():  # type: ignore[no-untyped-def]
    """The frame kernel compiled again with no reading faint (every one computed) and every
    landmark's chance of being in view computed when it is predicted (no ``lazy_view``):
    the oracle of its faint-reading skip and of the view it computes only for the readings
    it weighs."""
    import types

    from numba import njit

    from omniloc._kernels import track as kt

    @njit
    def no_cut(fresh: float, share: float, rho_max: float, root_min: float, norm: float) -> float:
        return -math.inf

    predict = kt._predict_one

    @njit
    def eager(mu, P, L, pd, hf, r2, rmin2, q, h, J, var, d, tan_out, exact, lazy_view=False):  # type: ignore[no-untyped-def]
        predict(mu, P, L, pd, hf, r2, rmin2, q, h, J, var, d, tan_out, exact, False)

    f = kt.frame_update_kernel.py_func
    namespace = {**f.__globals__, "_faint_cut": no_cut, "_predict_one": eager}
    return njit(error_model="numpy")(types.FunctionType(f.__code__, namespace, f.__name__))


_PLAIN_KERNEL: list[object] = []


@settings(max_examples=40, deadline=None)  # (the first example compiles the oracle)
@given(
    seed=st.integers(0, 2**32 - 1),
    update=st.booleans(),
    core=st.sampled_from([(0.0, False), (0.43, False), (0.43, True)]),
    core_scale=st.sampled_from([1 / 3, 3.0]),
    fresh=st.sampled_from([1.0, 0.25, 1e-3]),
    miss_weight=st.sampled_from([1.0, 0.5]),
    exclusive=st.booleans(),
    occlusion=st.sampled_from([0.0, 0.4]),
    K=st.integers(0, 3),
)
def test_faint_readings_are_skipped_without_changing_a_bit(
    seed: int,
    update: bool,
    core: tuple[float, bool],
    core_scale: float,
    fresh: float,
    miss_weight: float,
    exclusive: bool,
    occlusion: float,
    K: int,
) -> None:
    # The frame kernel does not compute a reading below fresh * 2^-60 (it rounds away in the
    # bearing's sum), nor, after a bearing moved a hypothesis, the chance of being in view
    # of a landmark whose readings are faint: every output must be the kernel's that
    # computes them all, bit for bit, for bearings from on a landmark to many sigmas off it
    # (around the cut), with a core narrower than the tail and one wider (each reading's
    # cut is its own).
    from omniloc._kernels.track import frame_update_kernel

    if not _PLAIN_KERNEL:
        _PLAIN_KERNEL.append(_kernel_without_faint_readings())
    plain = _PLAIN_KERNEL[0]
    rng = np.random.default_rng(seed)
    H, N, k = 12, 8, 5
    L = rng.uniform(-5, 5, (N, 2))
    mu = np.column_stack(
        [rng.uniform(-3, 3, H), rng.uniform(-3, 3, H), rng.uniform(-math.pi, math.pi, H)]
    )
    A = rng.normal(scale=10.0 ** rng.uniform(-3, -1), size=(H, 3, 3))
    P = A @ np.swapaxes(A, 1, 2) if update else np.zeros((1, 3, 3))
    sigma = math.radians(rng.uniform(0.2, 2.0))
    # Bearings at the first pose's landmarks, 0-60 sigmas off them (the cut is near 10).
    to = np.arctan2(L[:k, 1] - mu[0, 1], L[:k, 0] - mu[0, 0]) - mu[0, 2]
    bearings = np.asarray(wrap(to + sigma * rng.uniform(-60, 60, k)), dtype=np.float64)
    core_share, core_update = core
    obj_b = rng.uniform(-math.pi, math.pi, K)
    obj_w = rng.uniform(0, 1, (H, K))
    args = (
        bearings, L, sigma**2, 0.2, 0.6, math.radians(60.0), 49.0, 0.0, 1e-12, 1e-6, update,
        fresh, core_share, (sigma * core_scale) ** 2, core_update, 1.0, True, miss_weight,
        exclusive, occlusion, obj_b, obj_w, (sigma * 2) ** 2,
    )  # fmt: skip
    got = frame_update_kernel(mu, P, *args)
    expect = plain(mu, P, *args)  # type: ignore[operator]
    for g, e in zip(got, expect, strict=True):
        assert np.array_equal(g, e, equal_nan=True)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    A=st.integers(0, 60),
    B=st.integers(0, 60),
    r=st.sampled_from([0.05, 0.3, 1.0]),
    spread=st.sampled_from([0.5, 5.0, 50.0]),
)
def test_grid_pairs_are_the_pairs_of_every_pair_tried(
    seed: int, A: int, B: int, r: float, spread: float
) -> None:
    # Poses in cells find the same pairs, in the same order, as every pair tried: in
    # clusters, at exactly the distance (along an axis and a diagonal) and just beyond it,
    # far from every other pose, and not finite.
    from omniloc._kernels.track import grid_pairs, near_pairs

    rng = np.random.default_rng(seed)

    def poses(n: int) -> tuple[np.ndarray, np.ndarray]:
        centres = rng.uniform(-spread, spread, (4, 2))
        xy = centres[rng.integers(0, 4, n)] + rng.normal(scale=r, size=(n, 2))
        mu = np.column_stack([xy, rng.normal(scale=0.3, size=n)])
        A_ = rng.normal(scale=0.3, size=(n, 3, 3))
        return mu, A_ @ np.swapaxes(A_, 1, 2) + 1e-3 * np.eye(3)

    mu_a, P_a = poses(A)
    mu_b, P_b = poses(B)
    if A and B:
        k = min(A, B) // 2
        step = rng.choice([r, np.nextafter(r, 1.0), r / math.sqrt(2.0)], size=(k, 1))
        direction = rng.choice([-1.0, 1.0], size=(k, 2)) * rng.integers(0, 2, (k, 2))
        mu_a[:k, :2] = mu_b[:k, :2] + step * direction
        mu_a[:k, 2] = mu_b[:k, 2]
        P_a[:k] = P_b[:k]
        mu_a[-1, :2] = 1e4  # far from all
        mu_b[0, 0] = [np.nan, np.inf, -np.inf][seed % 3]
    args = (r * r, 0.5, 30.0)
    ia, ib, done = grid_pairs(mu_a, P_a, mu_b, P_b, *args)
    ja, jb = near_pairs(mu_a, P_a, mu_b, P_b, *args)
    assert done
    assert ia.tolist() == ja.tolist()
    assert ib.tolist() == jb.tolist()


def test_grid_pairs_decline_a_spread_of_too_many_cells() -> None:
    from omniloc._kernels.track import grid_pairs

    mu = np.array([[0.0, 0.0, 0.0], [1e9, 0.0, 0.0]])
    P = np.broadcast_to(np.eye(3), (2, 3, 3)).copy()
    ia, ib, done = grid_pairs(mu, P, mu, P, 0.01, 0.5, 30.0)
    assert not done and ia.size == 0 and ib.size == 0
    ia, ib, done = grid_pairs(mu, P, mu, P, 0.0, 0.5, 30.0)
    assert not done
