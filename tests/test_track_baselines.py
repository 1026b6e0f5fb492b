"""The maths of the tracking baselines (``benchmarks/baselines_track``): the odometry's
integration, the EKF's Jacobians and update, the particle filter's bearing likelihood,
resampling and clustering, and a short end-to-end check of each."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from baselines_track.ekf_known import EkfConfig, EkfKnown
from baselines_track.motion import (
    Delta,
    MotionNoise,
    OdometryBuffer,
    odometry_delta,
    predict_ekf,
)
from baselines_track.particle_filter import (
    ParticleFilter,
    PfConfig,
    bearing_log_ratio,
    cluster_particles,
    systematic_resample,
)
from omniloc import bearing_jacobian
from omniloc.pose import Pose
from omniloc.track import Frame, Odometry, TrackState


def _wrap(a: np.ndarray | float) -> np.ndarray | float:
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# ---- odometry ---------------------------------------------------------------------------------


def test_odometry_delta_is_the_exact_arc_and_splits_freely() -> None:
    v, w, T = 0.3, 0.5, 2.0
    d = odometry_delta(np.array([T]), np.array([v]), np.array([w]))
    r = v / w
    assert d.dx == pytest.approx(r * math.sin(w * T), abs=1e-12)
    assert d.dy == pytest.approx(r * (1 - math.cos(w * T)), abs=1e-12)
    assert d.dtheta == pytest.approx(w * T)
    assert (d.dist, d.turn, d.dt) == pytest.approx((v * T, w * T, T))
    # The same motion cut into 200 pieces composes to the same relative pose.
    k = 200
    d2 = odometry_delta(np.full(k, T / k), np.full(k, v), np.full(k, w))
    assert (d2.dx, d2.dy, d2.dtheta) == pytest.approx((d.dx, d.dy, d.dtheta), abs=1e-9)


def test_odometry_buffer_matches_between(rng: np.random.Generator) -> None:
    t = np.cumsum(rng.uniform(0.005, 0.02, 300))
    v = rng.uniform(-0.1, 0.4, t.size)
    w = rng.uniform(-1.0, 1.0, t.size)
    odo = Odometry(t, v, w)
    buf = OdometryBuffer()
    frames = [float(t[0]) + 0.37 * k for k in range(1, 8)]
    prev = float(t[0])
    k = 0
    for tf in frames:
        k1 = int(np.searchsorted(t, tf, side="right"))
        buf.add(t[k:k1], v[k:k1], w[k:k1])
        k = k1
        got = buf.take(tf)
        want = odometry_delta(*odo.between(prev, tf))
        assert (got.dx, got.dy, got.dtheta, got.dt) == pytest.approx(
            (want.dx, want.dy, want.dtheta, want.dt), abs=1e-12
        )
        prev = tf


# ---- EKF ----------------------------------------------------------------------------------------


def test_ekf_prediction_jacobian_and_noise(rng: np.random.Generator) -> None:
    mean = np.array([1.0, -2.0, 0.7])
    delta = Delta(0.3, 0.05, 0.2, 0.31, 0.2, 1.0)
    zero = MotionNoise(*(0.0,) * 8)
    P0 = np.diag([0.01, 0.02, 0.003])
    _, P = predict_ekf(mean, P0, delta, zero)
    # F by finite differences of the composition.
    F = np.empty((3, 3))
    eps = 1e-6
    for i in range(3):
        dp = np.zeros(3)
        dp[i] = eps
        a, _ = predict_ekf(mean + dp, P0, delta, zero)
        b, _ = predict_ekf(mean - dp, P0, delta, zero)
        diff = a - b
        diff[2] = _wrap(diff[2])
        F[:, i] = diff / (2 * eps)
    assert P == pytest.approx(F @ P0 @ F.T, abs=1e-9)
    # The noise enters rotated into the world frame.
    noise = MotionNoise(along_per_m=0.01, lateral_per_m=0.001, heading_per_rad=0.02)
    _, P2 = predict_ekf(mean, np.zeros((3, 3)), delta, noise)
    va, vl, vh = delta.variances(noise)
    c, s = math.cos(mean[2]), math.sin(mean[2])
    R = np.array([[c, -s], [s, c]])
    assert P2[:2, :2] == pytest.approx(R @ np.diag([va, vl]) @ R.T)
    assert P2[2, 2] == pytest.approx(vh)


def _predict(mean: np.ndarray, landmark: np.ndarray) -> tuple[float, np.ndarray]:
    """omniloc's bearing and its gradient for one landmark (what the EKF linearises)."""
    h, g = bearing_jacobian(landmark[None], mean)
    return float(_wrap(h[0])), g[0]


def test_ekf_update_is_the_kalman_update_and_gates() -> None:
    lm = np.array([[4.0, 1.0]])
    start = Pose(0.0, 0.0, 0.1)
    cfg = EkfConfig(sigma=math.radians(1.0), gate_sigmas=3.0, start_std=(0.1, 0.1, 0.05))
    ekf = EkfKnown(lm, start, [], cfg)
    P0, m0 = ekf.cov.copy(), ekf.mean.copy()
    h, H = _predict(m0, lm[0])
    z = h + math.radians(2.0)
    S = H @ P0 @ H + cfg.sigma**2
    K = P0 @ H / S
    assert ekf.update(z, 0)
    assert ekf.mean == pytest.approx(m0 + K * _wrap(z - h))
    assert ekf.cov == pytest.approx((np.eye(3) - np.outer(K, H)) @ P0, abs=1e-12)
    # A bearing 30 sigma of the innovation away is rejected and changes nothing.
    m1, P1 = ekf.mean.copy(), ekf.cov.copy()
    h1, H1 = _predict(m1, lm[0])
    far = h1 + 30 * math.sqrt(H1 @ P1 @ H1 + cfg.sigma**2)
    assert not ekf.update(far, 0)
    assert ekf.mean == pytest.approx(m1)


# ---- particle filter ----------------------------------------------------------------------------


@pytest.mark.parametrize("association", ["mean", "sum", "nearest"])
def test_bearing_likelihood_against_direct_evaluation(
    rng: np.random.Generator, association: str
) -> None:
    L = rng.uniform(-5, 5, (15, 2))
    P = np.column_stack(
        [rng.uniform(-5, 5, 300), rng.uniform(-5, 5, 300), rng.uniform(-np.pi, np.pi, 300)]
    )
    b = rng.uniform(-0.5, 0.5, 4)
    sig, c, fov, R = math.radians(2.0), 0.3, math.radians(67.0), 6.0
    got = bearing_log_ratio(
        P, b, L, sigma=sig, clutter=c, fov=fov, max_range=R, association=association
    )
    want = []
    for p in P:
        d = L - p[:2]
        h = _wrap(np.arctan2(d[:, 1], d[:, 0]) - p[2])
        vis = (np.hypot(d[:, 0], d[:, 1]) <= R) & (np.abs(h) <= fov / 2 + 3 * sig)
        total = 0.0
        for z in b:
            g = np.exp(-0.5 * (_wrap(z - h[vis]) / sig) ** 2)
            A = {
                "mean": g.mean() if g.size else 0.0,
                "sum": g.sum(),
                "nearest": g.max() if g.size else 0.0,
            }[association]
            total += math.log(c + (1 - c) * fov / (math.sqrt(2 * math.pi) * sig) * A)
        want.append(total)
    assert got == pytest.approx(np.array(want), abs=1e-9)


def test_systematic_resampling_keeps_the_expectation(rng: np.random.Generator) -> None:
    n = 1000
    w = rng.gamma(0.3, size=n)
    w /= w.sum()
    vals = np.sort(rng.normal(size=n))
    idx = systematic_resample(w, float(rng.random()))
    counts = np.bincount(idx, minlength=n)
    # Low variance: each particle is drawn floor or ceil of n w_i times ...
    assert np.all(counts >= np.floor(n * w) - 1e-9)
    assert np.all(counts <= np.ceil(n * w) + 1e-9)
    # ... and the running count never strays by a whole particle from n times the running
    # weight, so the mean of a function monotone in the index moves by less than its range / n.
    bound = (vals.max() - vals.min()) / n
    assert vals[idx].mean() == pytest.approx(float(w @ vals), abs=bound)
    # And on average over offsets, exactly n w_i.
    mean_counts = np.mean(
        [np.bincount(systematic_resample(w, u), minlength=n) for u in np.linspace(0, 1, 400)],
        axis=0,
    )
    assert mean_counts == pytest.approx(n * w, abs=0.01)


def test_clusters_find_two_blobs_and_their_shares(rng: np.random.Generator) -> None:
    a = np.column_stack([rng.normal(1.0, 0.05, 700), rng.normal(2.0, 0.05, 700)])
    a = np.column_stack([a, rng.normal(3.1, 0.02, 700)])  # headings across +-pi
    b = np.column_stack([rng.normal(-1.0, 0.05, 300), rng.normal(-2.0, 0.05, 300)])
    b = np.column_stack([b, rng.normal(0.5, 0.02, 300)])
    p = np.vstack([a, b])
    p[:, 2] = _wrap(p[:, 2])
    means, covs, ws = cluster_particles(p, np.ones(len(p)), (-3.0, -3.0, 3.0, 3.0))
    assert ws[:2] == pytest.approx([0.7, 0.3], abs=1e-9)
    assert means[0, :2] == pytest.approx([1.0, 2.0], abs=0.02)
    assert abs(_wrap(means[0, 2] - 3.1)) < 0.01
    assert means[1] == pytest.approx([-1.0, -2.0, 0.5], abs=0.02)
    assert np.sqrt(covs[0, 0, 0]) == pytest.approx(0.05, rel=0.2)


def _synthetic_run(n: int = 160) -> tuple[np.ndarray, list[tuple[float, float, float]], list]:
    """A robot driving a circle among 6 landmarks: odometry rows and frames of bearings."""
    lm = np.array([[3.0, 0.0], [0.0, 3.0], [-3.0, 0.0], [0.0, -3.0], [2.5, 2.5], [-2.5, -2.0]])
    gen = np.random.default_rng(3)
    v, w, dt = 0.3, 0.2, 0.25
    pose = np.array([0.0, -1.5, 0.0])
    rows, frames = [], []
    for k in range(n):
        t = k * dt
        rows.append((t, v, w))
        d = odometry_delta(np.array([dt]), np.array([v]), np.array([w]))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        pose = pose + np.array([c * d.dx - s * d.dy, s * d.dx + c * d.dy, d.dtheta])
        off = lm - pose[:2]
        h = _wrap(np.arctan2(off[:, 1], off[:, 0]) - pose[2])
        seen = np.flatnonzero(np.abs(h) < math.radians(33))
        b = h[seen] + gen.normal(0, math.radians(0.5), seen.size)
        frames.append((t + dt, b, pose.copy(), tuple(int(j) for j in seen)))
    return lm, rows, frames


def test_ekf_and_pf_track_a_synthetic_run() -> None:
    lm, rows, frames = _synthetic_run()
    start = Pose(0.0, -1.5, 0.0)
    ekf = EkfKnown(lm, start, [Frame(f[0], f[1], f[3]) for f in frames], EkfConfig())
    cfg = PfConfig(n_particles=3000, sigma=math.radians(1.5), clutter=0.5, association="sum")
    pf = ParticleFilter(lm, cfg, start=start, rng=1)
    rows_a = np.array(rows)
    k = 0
    for t, b, _, _ in frames:
        k1 = int(np.searchsorted(rows_a[:, 0], t, side="right"))
        for loc in (ekf, pf):
            loc.odometry(rows_a[k:k1, 0], rows_a[k:k1, 1], rows_a[k:k1, 2])
        k = k1
        e1 = ekf.frame(t, b)
        e2 = pf.frame(t, b)
    truth = frames[-1][2]
    for e in (e1, e2):
        assert e.state is TrackState.LOCALIZED
        assert math.hypot(e.pose.x - truth[0], e.pose.y - truth[1]) < 0.1
        assert abs(_wrap(e.pose.theta - truth[2])) < math.radians(3)


def test_pf_from_uniform_start_localizes() -> None:
    lm, rows, frames = _synthetic_run(400)
    cfg = PfConfig(
        n_particles=20000,
        sigma=math.radians(1.5),
        clutter=0.5,
        association="sum",
        kidnap_ratio=0.7,
        map_margin_m=0.5,
    )
    pf = ParticleFilter(lm, cfg, rng=2)
    rows_a = np.array(rows)
    k = 0
    states = []
    for t, b, truth, _ in frames:
        k1 = int(np.searchsorted(rows_a[:, 0], t, side="right"))
        pf.odometry(rows_a[k:k1, 0], rows_a[k:k1, 1], rows_a[k:k1, 2])
        k = k1
        e = pf.frame(t, b)
        ok = math.hypot(e.pose.x - truth[0], e.pose.y - truth[1]) < 0.2
        states.append(e.localized and ok)
    assert states[0] is False
    assert np.mean(states[-100:]) > 0.9


# ---- the script: what the tuning record chooses ----------------------------------------------


def test_tuned_options_take_the_nearest_count_tuned() -> None:
    import track_baselines as tb

    def best(**o: object) -> dict[str, object]:
        return {"best": {"options": o}}

    rec = {
        "ekf": best(noise_scale=8, sigma_deg=0.25, gate_sigmas=10.0),
        "pf_global_2000": best(sigma_deg=1.0, clutter=0.99, alphas=[0.001, 0.1]),
        "pf_global_10000": best(sigma_deg=0.5, clutter=0.95, alphas=[0.001, 0.1]),
        "recovery_2000": {
            **best(alphas=[0.01, 0.1], per_bearing=False),
            "kidnap_ratio": {"kidnap_ratio": 0.5},
        },
        "kidnap_10000": {"best": {"kidnap_ratio": 0.3}},
    }
    chosen = tb.chosen_options(rec, [2000, 10_000, 50_000])
    assert chosen["ekf"]["noise_scale"] == 8
    pf = chosen["pf"]
    assert pf[2000]["sigma_deg"] == 1.0 and pf[2000]["kidnap_ratio"] == 0.5
    # 10,000 and 50,000: the 10,000 descent, the 2,000 random particles, the 10,000 threshold.
    for n in (10_000, 50_000):
        assert pf[n]["sigma_deg"] == 0.5 and pf[n]["clutter"] == 0.95
        assert pf[n]["alphas"] == (0.01, 0.1) and pf[n]["per_bearing"] is False
        assert pf[n]["kidnap_ratio"] == 0.3
    cfg = tb.pf_config(50_000, MotionNoise(), pf[50_000])
    assert cfg.n_particles == 50_000 and cfg.alpha_slow == 0.01
    assert cfg.sigma == pytest.approx(math.radians(0.5))


def _score(name: str, jump: float, bound_ttl: float, bound_rec: float) -> object:
    from omniloc.evaluate.tracking import RunScore

    nan = math.nan
    return RunScore(
        name, 100.0, 10, 10, 50.0, 0.5, 5, 0, 0.1, 1.0, jump, nan, nan, 0, 1.0,
        bound_time_to_localize_s=bound_ttl, bound_correct_after_rate=0.8,
        bound_recovery_s=bound_rec,
    )  # fmt: skip


def test_the_tables_show_what_the_data_allow_beside_the_tracker() -> None:
    import track_baselines as tb
    from omniloc.evaluate.tracking import TrackingResult

    runs = [
        _score("robot1", math.nan, 30.0, math.nan),
        _score("robot2", math.nan, math.inf, math.nan),
        _score("robot3", math.nan, 10.0, math.nan),
        _score("kidnap0", 50.0, 5.0, 12.0),
        _score("kidnap1", 50.0, 5.0, 14.0),
        _score("kidnap2", 50.0, 5.0, math.inf),
    ]
    # Stored as JSON would be (inf and NaN both null), and read back.
    results = {"tracker": TrackingResult("t", runs).as_dict()}
    text = tb.tables(results)
    rows = [ln for ln in text.splitlines() if ln.startswith(f"| {tb.BOUND_LABEL} |")]
    assert f"| {tb.BOUND_LABEL} | robot1 | 30.0 | 80.0 % |" in text
    assert f"| {tb.BOUND_LABEL} | robot2 | never |" in text
    (whole,) = [r for r in rows if "| whole runs |" in r]
    assert "| 3 | 30.0 / never | 1 | 80.0 % |" in whole
    (kid,) = [r for r in rows if "| kidnapped |" in r]
    assert kid.split(" | ")[-5] == "14.0"  # the recovery median counts the stream never back
    # Results stored before the bound existed show no such rows.
    for r in results["tracker"]["runs"]:
        for k in ("bound_time_to_localize_s", "bound_correct_after_rate", "bound_recovery_s"):
            del r[k]
    assert tb.BOUND_LABEL not in tb.tables(results)
