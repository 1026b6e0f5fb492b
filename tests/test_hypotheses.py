"""The hypothesise-and-verify strategy: seed covering, pair limits, neighbour lists, agreement
with the tree, first fits on large maps, budgets and option checks."""

from __future__ import annotations

import itertools
import math
import os
import time
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc import InputError, LandmarkMap, localize, search
from omniloc._kernels import geometry as geo
from omniloc._kernels import hypotheses as hk
from omniloc.pose import Pose
from omniloc.search import Method, Strategy, choose_engine, scoring
from omniloc.search import hypotheses as hyp_search
from omniloc.search import seeds as _seeds
from omniloc.search.neighbours import neighbour_lists
from omniloc.search.options import Leaves, make_options
from omniloc.simulate import (
    DEMO_POSE,
    DEMO_VISIBLE,
    demo_room,
    observe,
    random_map,
    random_pose,
)

DEG = math.pi / 180.0


# ---- seeds -----------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    m=st.integers(4, 12),
    k=st.integers(0, 4),
    seed=st.integers(0, 2**31 - 1),
    ranged=st.booleans(),
)
def test_seeds_avoid_every_set_of_spurious_bearings(
    m: int, k: int, seed: int, ranged: bool
) -> None:
    k = min(k, m - 3)
    b = np.random.default_rng(seed).uniform(-math.pi, math.pi, m)
    limits = _seeds.pair_limits(b, 20.0 if ranged else None, None, 0.01)
    seeds = _seeds.seed_triples(b, k, limits)
    assert seeds.ndim == 2 and seeds.shape[1] == 3
    assert all(len(set(t)) == 3 and 0 <= min(t) and max(t) < m for t in seeds.tolist())
    for spurious in itertools.combinations(range(m), k):
        assert any(not set(t) & set(spurious) for t in seeds.tolist()), spurious


def test_seeds_for_many_bearings_use_disjoint_triples() -> None:
    # Too many spurious sets for the exact greedy cover: k + 1 disjoint triples do it.
    b = np.linspace(-3.0, 3.0, 40)
    seeds = _seeds.seed_triples(b, 5, np.full((40, 40), np.inf))
    assert len(seeds) == 6
    assert len(set(seeds.ravel().tolist())) == 18


def test_seeds_prefer_well_spread_bearings() -> None:
    # Three bearings in a narrow sector fix the pose poorly; a spread triple is chosen.
    b = np.deg2rad([0.0, 10.0, 20.0, 120.0, 240.0])
    (seed,) = _seeds.seed_triples(b, 0, np.full((5, 5), np.inf))
    span = np.ptp(np.sort(np.mod(b[seed], 2 * np.pi)))
    assert np.rad2deg(span) >= 200.0


def test_seeds_with_a_range_prefer_those_that_make_fewer_hypotheses() -> None:
    # With a range, of two wide seeds the one whose pose has the smaller Jacobian makes fewer
    # hypotheses; two bearings a degree apart still pay as a poorly conditioned seed.
    b = np.deg2rad([0.0, 120.0, 240.0, 60.0, 75.0, 200.0, 201.0])
    limits = _seeds.pair_limits(b, 20.0, None, 0.01)
    cost = _seeds.triple_cost(b, np.array([[0, 1, 2], [0, 4, 5], [0, 5, 6]]), limits)
    vol = _seeds.hypothesis_volume(b, np.array([[0, 1, 2], [0, 4, 5], [0, 5, 6]]))
    assert vol[1] < vol[0] and cost[1] < cost[0]
    assert vol[2] < vol[1] and cost[2] > cost[0]
    # Narrow seeds (a narrow field of view): the widest first, whatever their count.
    b = np.deg2rad([0.0, 10.0, 20.0, 30.0, 60.0])
    limits = _seeds.pair_limits(b, 8.0, None, 0.01)
    narrow = np.array([[0, 1, 2], [0, 3, 4]])
    cost = _seeds.triple_cost(b, narrow, limits)
    assert _seeds.hypothesis_volume(b, narrow)[0] < _seeds.hypothesis_volume(b, narrow)[1]
    assert cost[1] < cost[0]


@settings(max_examples=40, deadline=None)
@given(
    pose=st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-math.pi, math.pi)),
    bearings=st.lists(st.floats(-math.pi, math.pi), min_size=3, max_size=3),
    ranges=st.lists(st.floats(0.5, 20.0), min_size=3, max_size=3),
)
def test_hypothesis_volume_integrates_the_jacobian_of_the_pose(
    pose: tuple[float, float, float], bearings: list[float], ranges: list[float]
) -> None:
    # Landmarks (6 coordinates) <-> pose (x, y, theta) and ranges along the three rays: the
    # determinant of that map is the integrand of hypothesis_volume.
    b, r = np.array(bearings), np.array(ranges)

    def landmarks(q: np.ndarray) -> np.ndarray:
        ang = q[2] + b
        return np.stack([q[0] + q[3:] * np.cos(ang), q[1] + q[3:] * np.sin(ang)], 1).ravel()

    q0 = np.array([*pose, *r])
    h = 1e-6
    J = np.stack([(landmarks(q0 + h * e) - landmarks(q0 - h * e)) / (2 * h) for e in np.eye(6)])
    s = np.sin(b[[2, 0, 1]] - b[[1, 2, 0]])
    assert abs(np.linalg.det(J)) == pytest.approx(abs(r @ s), rel=1e-4, abs=1e-6)
    # ... and the volume is its mean over the ranges (in units of the largest): against a
    # fine Monte Carlo estimate of that integral (the 6^3 midpoint rule is a few per cent
    # off where the integrand's kink crosses the cube; the seeds need only the ranking).
    v = _seeds.hypothesis_volume(b, np.array([[0, 1, 2]]))[0]
    u = np.random.default_rng(0).random((200_000, 3))
    assert v == pytest.approx(float(np.abs(u @ s).mean()), rel=0.05, abs=2e-3)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    rmax=st.floats(2.0, 50.0),
    rmin_frac=st.floats(0.0, 0.9),
)
def test_pair_limits_bound_every_visible_pair(seed: int, rmax: float, rmin_frac: float) -> None:
    # Two landmarks seen from one pose within [rmin, rmax] at the angle between their
    # bearings are never farther apart than the limit.
    rng = np.random.default_rng(seed)
    rmin = rmin_frac * rmax
    r = rng.uniform(rmin, rmax, 2)
    phi = rng.uniform(-math.pi, math.pi, 2)
    pts = np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)
    lim = _seeds.pair_limits(phi, rmax, rmin or None, 0.0)
    d2 = float(((pts[0] - pts[1]) ** 2).sum())
    assert d2 <= lim[0, 1] * (1 + 1e-9) + 1e-9


def test_pair_limits_without_range_are_infinite() -> None:
    assert np.isinf(_seeds.pair_limits(np.zeros(4), None, None, 0.0)).all()


# ---- neighbour lists -------------------------------------------------------------------------


def test_neighbour_lists_match_brute_force() -> None:
    lm = random_map(300, size=100.0, rng=3)
    ptr, idx, xy = neighbour_lists(lm, 12.0)
    d = np.hypot(*(lm.xy[:, None, :] - lm.xy[None, :, :]).transpose(2, 0, 1))
    for i in range(lm.n):
        want = np.flatnonzero((d[i] <= 12.0) & (np.arange(lm.n) != i))
        assert idx[ptr[i] : ptr[i + 1]].tolist() == want.tolist()
        assert np.array_equal(xy[ptr[i] : ptr[i + 1]], lm.xy[want])
    assert neighbour_lists(lm, 12.0).idx is idx  # built once per radius


def test_neighbour_lists_keep_ties_duplicates_and_loners() -> None:
    # A grid 2 m apart at a radius of exactly 2 m (every tie kept: the k-d tree's "at most
    # r"), two landmarks off the grid 0.5 m apart, one far from all.
    g = np.array([(x, y) for x in range(0, 9, 2) for y in range(0, 7, 2)], dtype=float)
    pts = np.vstack([g, [[3.0, 3.0], [3.0, 3.5], [500.0, 500.0]]])
    lm = LandmarkMap(pts)
    ptr, idx, xy = neighbour_lists(lm, 2.0)
    d2 = ((pts[:, None, :] - pts[None, :, :]) ** 2).sum(axis=2)
    assert ptr.tolist()[-1] == idx.size
    for i in range(lm.n):
        want = np.flatnonzero((d2[i] <= 4.0) & (np.arange(lm.n) != i))
        assert idx[ptr[i] : ptr[i + 1]].tolist() == want.tolist()
        assert np.array_equal(xy[ptr[i] : ptr[i + 1]], pts[want])
    assert ptr[lm.n] == ptr[lm.n - 1]  # the loner has none
    assert lm.n - 2 in idx[ptr[lm.n - 3] : ptr[lm.n - 2]].tolist()
    assert sum(d2[i, j] == 4.0 for i in range(g.shape[0]) for j in range(g.shape[0])) > 0


# ---- agreement with the tree -----------------------------------------------------------------


def _scene(seed: int) -> tuple[LandmarkMap, np.ndarray, dict[str, float]]:
    rng = np.random.default_rng(seed)
    if seed % 2:
        lm = demo_room()
        sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=5, sigma=0.3 * DEG, rng=rng)
        return lm, sc.bearings, {"sigma": 0.3 * DEG}
    lm = random_map(15, rng=rng)
    sc = observe(lm, random_pose(lm, rng=rng), n_obs=6, sigma=0.5 * DEG, rng=rng)
    return lm, sc.bearings, {"sigma": 0.5 * DEG}


@pytest.mark.parametrize("seed", range(12))
def test_same_best_interpretation_as_the_tree(seed: int) -> None:
    lm, b, kw = _scene(seed)
    tree = localize(lm, b, strategy="tree", **kw)
    hyp = localize(lm, b, strategy="hypotheses", **kw)
    assert (tree.best is None) == (hyp.best is None)
    if tree.best is not None and hyp.best is not None:
        assert hyp.best.assignment == tree.best.assignment
        assert hyp.best.pose.distance_to(tree.best.pose)[0] < 1e-6


def test_finds_the_truth_with_spurious_bearings_and_range() -> None:
    found = 0
    for seed in range(8):
        rng = np.random.default_rng(100 + seed)
        lm = random_map(40, size=40.0, rng=rng)
        pose = random_pose(lm, rng=rng)
        sc = observe(lm, pose, max_range=12.0, n_spurious=2, sigma=0.3 * DEG, rng=rng)
        if sc.bearings.size - 2 < 4:
            continue
        kw = {"sigma": 0.3 * DEG, "max_spurious": 2, "max_range": 12.0, "p_miss": 0.05}
        res = localize(lm, sc.bearings, strategy="hypotheses", **kw)
        assert res.stats.exhaustive and res.stats.complete
        tree = localize(lm, sc.bearings, strategy="tree", **kw)
        # The hypotheses reach the true interpretation whenever the tree does. (With
        # max_spurious equal to the true count, one real bearing outside its 99 % gate
        # leaves no interpretation at all, in both.)
        truth_in_tree = any(s.assignment == sc.assignment for s in tree.solutions)
        assert truth_in_tree <= any(s.assignment == sc.assignment for s in res.solutions)
        assert (res.best is None) == (tree.best is None)
        found += res.best is not None and res.best.pose.distance_to(pose)[0] < 0.1
    assert found >= 5


# ---- large maps: chunks, threads, first fit --------------------------------------------------


@pytest.fixture(scope="module")
def big_map() -> LandmarkMap:
    return random_map(3000, density=0.01, min_separation=1.0, rng=7)


def _big_scene(lm: LandmarkMap, seed: int) -> tuple[np.ndarray, Pose]:
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = lm.bounds
    p = rng.uniform((x0 + 20, y0 + 20), (x1 - 20, y1 - 20))
    pose = Pose(float(p[0]), float(p[1]), float(rng.uniform(-math.pi, math.pi)))
    sc = observe(lm, pose, max_range=15.0, n_spurious=1, sigma=0.2 * DEG, rng=rng)
    return sc.bearings, pose


def test_first_fit_on_a_large_map(big_map: LandmarkMap) -> None:
    kw = {"sigma": 0.2 * DEG, "max_spurious": 1, "max_range": 15.0, "p_miss": 0.01}
    hits = 0
    for seed in range(3):
        b, pose = _big_scene(big_map, seed)
        res = localize(big_map, b, exhaustive=False, confidence=0.9999, **kw)
        assert res.stats.complete
        # A first fit is never decisive: stopped or not, it took shortcuts that can lose
        # a rival.
        assert not res.stats.exhaustive and res.ambiguous
        if res.best is not None and res.best.pose.distance_to(pose)[0] < 0.2:
            hits += 1
    assert hits >= 2


def test_a_first_fit_stops_only_at_a_convincing_fit(big_map: LandmarkMap) -> None:
    # Five matched bearings on 3,000 landmarks without negative evidence: a chance fit of
    # that quality exists somewhere among the hypotheses a full search tries (one stopped
    # the search 71 m from the truth, with confidence 0.999 against "all clutter"). A fit
    # stops a first fit only when it is decisive after that look-elsewhere allowance;
    # otherwise the search goes on and the posterior ranks what it finds.
    kw = {"sigma": 0.2 * DEG, "max_spurious": 1, "max_range": 15.0, "confidence": 0.9999}
    b, pose = _big_scene(big_map, 0)
    res = localize(big_map, b, exhaustive=False, p_miss=0.01, **kw)
    full = localize(big_map, b, exhaustive=True, p_miss=0.01, **kw)
    # Nothing was convincing enough to stop at: the first fit tried as many seeds as the
    # full search (it stops only between hypotheses), and still says it is no verdict.
    assert res.stats.triples_solved >= 0.9 * full.stats.triples_solved
    assert res.ambiguous and not res.stats.exhaustive
    assert res.best is not None and res.best.pose.distance_to(pose)[0] < 0.2


def test_large_maps_stop_at_the_first_fit_by_default_and_say_so(big_map: LandmarkMap) -> None:
    kw = {"sigma": 0.2 * DEG, "max_spurious": 1, "max_range": 15.0, "confidence": 0.9999}
    kw["p_miss"] = 0.01
    b, pose = _big_scene(big_map, 1)  # eight bearings: the truth is a convincing fit
    auto = localize(big_map, b, **kw)
    assert not auto.stats.exhaustive and auto.stats.stopped == "first fit: rivals not sought"
    assert auto.ambiguous  # rivals were not sought: never a decisive verdict
    assert auto.best is not None and auto.best.pose.distance_to(pose)[0] < 0.2
    full = localize(big_map, b, exhaustive=True, **kw)
    assert full.stats.exhaustive and full.stats.stopped == "" and not full.ambiguous
    assert full.best is not None and full.best.assignment == auto.best.assignment
    # On a small map the default is exhaustive.
    assert localize(big_map.xy[:500], b, **kw).stats.exhaustive


def test_a_first_fit_that_finds_nothing_searches_exhaustively(
    big_map: LandmarkMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A first fit's shortcuts (here: a cheap test so tight that it rejects every hypothesis)
    # must not turn into a silent "no pose": the search runs again, exhaustively.
    kw = {"sigma": 0.2 * DEG, "max_spurious": 1, "max_range": 15.0, "confidence": 0.9999}
    kw["p_miss"] = 0.01
    b, pose = _big_scene(big_map, 1)
    monkeypatch.setattr(hyp_search, "PRETEST_SLACK", {True: (4.0, 8.0), False: (1e-9, 1e-9)})
    res = localize(big_map, b, exhaustive=False, **kw)
    assert res.stats.exhaustive and res.stats.complete
    assert res.best is not None and res.best.pose.distance_to(pose)[0] < 0.2
    # A caller's max_nodes bounds both searches together (each used to get all of it):
    # enough for the first fit and a quarter of the exhaustive search after it.
    again = localize(big_map, b, exhaustive=True, **kw).stats.nodes
    fit = res.stats.nodes - again
    cut = localize(big_map, b, exhaustive=False, max_nodes=fit + again // 4, **kw)
    assert not cut.complete and cut.stats.stopped == "budget"
    assert fit < cut.stats.nodes <= fit + 2 * (again // 4) + 1000


def test_first_fit_counts_the_same_with_and_without_a_node_budget(
    big_map: LandmarkMap,
) -> None:
    # Without a budget the kernel adds a second landmark's counters at once and takes back
    # those after a stop; with one it adds them candidate by candidate. Same figures.
    kw = {"sigma": 0.2 * DEG, "max_spurious": 1, "max_range": 15.0, "p_miss": 0.01}
    b, _ = _big_scene(big_map, 1)
    free = localize(big_map, b, exhaustive=False, confidence=0.9999, **kw)
    budget = localize(big_map, b, exhaustive=False, confidence=0.9999, max_nodes=10**12, **kw)
    assert not free.stats.exhaustive and free.stats.complete
    assert [s.assignment for s in free.solutions] == [s.assignment for s in budget.solutions]
    figures = [
        {k: v for k, v in r.stats.as_dict().items() if k != "elapsed_s"} for r in (free, budget)
    ]
    assert figures[0] == figures[1]


def test_chunked_search_equals_one_call(big_map: LandmarkMap, monkeypatch) -> None:
    # The chunks and threads change nothing but the time (of an exhaustive search: a first
    # fit stops wherever the thread that finds it is).
    kw = {"sigma": 0.2 * DEG, "max_spurious": 1, "max_range": 15.0, "confidence": 0.9999}
    kw["exhaustive"] = True
    b, _ = _big_scene(big_map, 1)
    chunked = localize(big_map, b, **kw)
    monkeypatch.setattr(hyp_search, "CHUNK_ANCHORS", 10**6)
    whole = localize(big_map, b, **kw)
    assert [s.assignment for s in chunked.solutions] == [s.assignment for s in whole.solutions]
    assert chunked.stats.triples_solved == whole.stats.triples_solved
    assert chunked.stats.nodes == whole.stats.nodes


def test_node_budget_stops_the_hypotheses(big_map: LandmarkMap) -> None:
    b, _ = _big_scene(big_map, 2)
    res = localize(big_map, b, sigma=0.2 * DEG, max_spurious=1, max_range=15.0, max_nodes=20_000)
    assert not res.stats.complete
    # Chunks in flight may each finish their own budget, no more.
    assert res.stats.nodes < 20_000 * 3


# ---- options ---------------------------------------------------------------------------------


def _opts(m: int = 6, method: Method = Method.ROBUST, **kw: Any) -> Any:
    ms = kw.pop("max_spurious", 0)
    return make_options(
        m, method=method, sensor=None, budget=None, max_spurious=ms, ordering=False, legacy=kw
    )


def test_strategy_choice() -> None:
    paper_rules = _opts()
    robust = _opts(sigma=DEG)
    assert choose_engine("auto", Method.ROBUST, paper_rules, True) == "paper"
    assert choose_engine("tree", Method.ROBUST, paper_rules, True) == "paper"
    assert choose_engine("tree", Method.ROBUST, robust, True) == "tree"
    assert choose_engine("hypotheses", Method.ROBUST, paper_rules, False) == "first"
    assert choose_engine("auto", Method.ROBUST, robust, True) == "hypotheses"
    assert choose_engine("auto", Method.ROBUST, robust, False) == "first"
    assert choose_engine(Strategy.TREE, Method.ROBUST, robust, True) == "tree"
    assert choose_engine(Strategy.HYPOTHESES, Method.ROBUST, robust, False) == "first"
    assert choose_engine("auto", Method.PAPER, paper_rules, True) == "paper"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"strategy": "fast"}, "strategy must be one of"),
        ({"strategy": "tree", "exhaustive": False}, "exhaustive=False needs"),
        ({"method": "paper", "strategy": "hypotheses"}, "method='paper'"),
        ({"method": "paper", "exhaustive": False}, "method='paper'"),
        ({"exhaustive": "no"}, "exhaustive must be True, False or None"),
    ],
)
def test_bad_strategy_options(kwargs: dict[str, object], message: str) -> None:
    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=5)
    with pytest.raises(InputError, match=message):
        localize(lm, sc.bearings, **kwargs)  # type: ignore[arg-type]


def test_threshold_mode_with_wildcards_finds_the_truth() -> None:
    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=6, n_spurious=1, rng=4)
    res = localize(lm, sc.bearings, max_spurious=1, strategy="hypotheses")
    assert res.best is not None
    assert res.best.pose.distance_to(DEMO_POSE)[0] < 1e-6
    assert res.best.assignment == sc.assignment


# ---- small compiled helpers against their numpy references -----------------------------------


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), m=st.integers(4, 15))
def test_compiled_widest_triple_matches_numpy(seed: int, m: int) -> None:
    from omniloc._kernels.tree import widest_triple
    from omniloc.search.tree import widest_triple_numpy

    b = np.random.default_rng(seed).uniform(-math.pi, math.pi, m)
    assert widest_triple(np.ascontiguousarray(b[:12])) == widest_triple_numpy(b[:12])


def test_compiled_covariances_match_numpy() -> None:
    from omniloc.pose import bearing_jacobian

    rng = np.random.default_rng(5)
    Lm = rng.uniform(0, 20, (6, 8, 2))
    poses = np.concatenate([rng.uniform(5, 15, (6, 2)), rng.uniform(-3, 3, (6, 1))], axis=1)
    w = (rng.uniform(size=(6, 8)) > 0.3).astype(float)
    w[:, :3] = 1.0
    _, g = bearing_jacobian(Lm, poses)
    gw = g * w[..., None]
    want = np.linalg.inv(np.einsum("kni,knj->kij", gw, gw) + 1e-12 * np.eye(3)) * 0.01
    got = geo.covariances(Lm, w, poses, 0.01, geo.COVARIANCE_FLOOR)
    assert np.allclose(got, want, rtol=1e-9, atol=0)


@pytest.mark.parametrize("seed", range(4))
def test_compiled_merge_matches_numpy(seed: int) -> None:
    """The compiled merge (which skips pairs beyond the covariance's reach) keeps exactly
    the solutions the plain loop keeps, on poses clustered so that many merge: some with
    tight covariances, some wide, some at a heading across +-pi, one duplicate."""
    rng = np.random.default_rng(seed)
    K = 300
    centres = rng.uniform(0, 10, (6, 3))
    centres[0, 2] = np.pi - 1e-3
    poses = centres[rng.integers(0, 6, K)] + rng.normal(0, [0.05, 0.05, 0.02], (K, 3))
    poses[:, 2] = np.angle(np.exp(1j * poses[:, 2]))
    poses[1] = poses[0]
    scale = rng.choice([1e-4, 1e-2, 1.0], K)[:, None, None]
    A = rng.normal(size=(K, 3, 3))
    cov = (A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3)) * scale
    rank = rng.permutation(K).astype(np.int64)
    fast, owner = scoring._merge(rank, poses, cov)
    slow, slow_owner = scoring.merge_numpy(rank, poses, cov)
    assert fast == slow
    assert owner.tolist() == slow_owner.tolist()  # each merged into the same kept one
    assert set(owner.tolist()) == set(fast)
    assert 6 <= len(fast) < K - 50  # merges happened, and not everything merged


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    K=st.integers(2, 400),
    spread=st.sampled_from([0.3, 3.0, 30.0, 300.0, 1e150]),
    wide=st.floats(0.0, 0.5),
    bad=st.booleans(),
    line=st.booleans(),
)
def test_the_merges_grid_keeps_what_the_plain_loop_keeps(
    seed: int, K: int, spread: float, wide: float, bad: bool, line: bool
) -> None:
    """The compiled merge files the kept poses in a grid and tests a pose only against
    those within its reach's cells: the same kept poses, each merged into the same one, as
    the plain loop, whether the poses crowd into one cell or spread over many (or over
    1e150 m, a grid of more cells than an integer counts; on one line, a grid of no
    area), whatever share of them reach beyond a cell (wide covariances), and with a pose
    that is not finite (no grid then)."""
    rng = np.random.default_rng(seed)
    n_centres = int(rng.integers(1, 12))
    centres = rng.uniform(0, spread, (n_centres, 3))
    poses = centres[rng.integers(0, n_centres, K)] + rng.normal(0, [0.08, 0.08, 0.02], (K, 3))
    poses[:, 2] = np.angle(np.exp(1j * poses[:, 2]))
    if line:
        poses[:, 1] = poses[0, 1]
    scale = np.where(rng.uniform(size=K) < wide, rng.uniform(1.0, 50.0, K), 1e-3)
    A = rng.normal(size=(K, 3, 3))
    cov = (A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3)) * scale[:, None, None]
    if bad:
        poses[rng.integers(K), int(rng.integers(0, 2))] = np.nan
    rank = rng.permutation(K).astype(np.int64)
    with np.errstate(all="ignore"):
        fast, owner = scoring._merge(rank, poses, cov)
        slow, slow_owner = scoring.merge_numpy(rank, poses, cov)
    assert fast == slow
    assert owner.tolist() == slow_owner.tolist()


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), log_cond=st.floats(0.0, 16.0))
def test_fixed_covariances_are_what_their_eigenvalues_say(seed: int, log_cond: float) -> None:
    """_fixed tells most covariances without their eigenvalues; it must say what
    eigvalsh says for every one: well and badly conditioned ones (around the limit of
    1e12 and its own 1e10), singular, indefinite, negative, asymmetric (eigvalsh reads the
    lower triangle) and not finite."""
    from omniloc.pose import MAX_CONDITION

    rng = np.random.default_rng(seed)
    K = 200
    Q = np.linalg.qr(rng.normal(size=(K, 3, 3)))[0]
    lam = 10.0 ** rng.uniform(-8, 2, (K, 1)) * 10.0 ** np.stack(
        [-log_cond * rng.uniform(0.9, 1.1, K), -rng.uniform(0, log_cond, K), np.zeros(K)], 1
    )
    kind = rng.integers(0, 10, K)
    lam[kind == 1, 0] = 0.0
    lam[kind == 2, 0] *= -1.0
    lam[kind == 3] *= -1.0
    lam[kind == 4, :2] *= -1.0  # two negative: its determinant is positive
    lam[kind == 5] = [10.0**-11, 1.0, 1.0]  # between its own bound and the limit
    cov = np.einsum("kij,kj,klj->kil", Q, lam, Q)
    # Lower triangle made indefinite, the upper one (which eigvalsh does not read) not.
    cov[kind == 6, 2, 0] += 1e3 * np.abs(cov[kind == 6].max(axis=(1, 2)))
    cov[kind == 7, 1, 1] = np.nan
    cov[kind == 8, 2, 0] = np.inf
    cov[kind == 9] = np.diag([1.0, 1.0, 10.0**-log_cond])
    ok = np.isfinite(cov).all(axis=(1, 2))
    w = np.linalg.eigvalsh(np.where(ok[:, None, None], cov, np.eye(3)))
    want = ok & (w[:, 0] > 0) & (w[:, -1] <= MAX_CONDITION * w[:, 0])
    assert scoring._fixed(cov).tolist() == want.tolist()


def test_first_fit_polish_moves_a_landmark_to_the_better_bearing() -> None:
    # A spurious bearing just beside a true one took the true one's landmark (the first fit
    # checks bearings in a fixed order): the polish gives it back.
    lm = random_map(400, density=0.01, min_separation=1.0, rng=3)
    x0, y0, x1, y1 = lm.bounds
    pose = Pose((x0 + x1) / 2, (y0 + y1) / 2, 0.3)
    sc = observe(lm, pose, max_range=20.0, rng=1)
    bearings = np.concatenate([[sc.bearings[-1] + 0.06 * DEG], sc.bearings])
    truth = np.array([-1, *sc.assignment], dtype=np.int64)
    swapped = truth.copy()
    swapped[0], swapped[-1] = truth[-1], -1
    opt = _opts(len(bearings), sigma=0.2 * DEG, max_spurious=1, max_range=20.0)
    assign, poses = hyp_search._polish(lm, bearings, swapped[None], pose.as_array()[None], opt)
    assert assign[0].tolist() == truth.tolist()
    assert Pose.from_array(poses[0]).distance_to(pose)[0] < 0.05
    # A correct interpretation is left alone.
    assign, _ = hyp_search._polish(lm, bearings, truth[None], pose.as_array()[None], opt)
    assert assign[0].tolist() == truth.tolist()


# ---- ranking and the kernel's output buffer --------------------------------------------------


@pytest.mark.parametrize("p_miss", [None, 0.05])
def test_the_posterior_ranks_not_the_match_count(p_miss: float | None) -> None:
    # Two complete paths: the truth with its spurious bearing unmatched, and the same with
    # that bearing forced onto a far landmark (one match more, a residual of tens of
    # degrees). Matching more bearings is not worth a residual far outside the noise: the
    # truth ranks first and holds the posterior, with or without negative evidence.
    lm = random_map(60, size=40.0, rng=2)
    pose = Pose(20.0, 20.0, 0.4)
    sc = observe(lm, pose, max_range=12.0, n_spurious=1, rng=5)
    truth = np.array([-1 if a is None else a for a in sc.assignment], dtype=np.int64)
    forced = truth.copy()
    far = int(np.argmax(np.hypot(*(lm.xy - pose.as_array()[:2]).T)))
    forced[truth < 0] = far
    opt = _opts(len(truth), max_spurious=1, max_range=12.0, p_miss=p_miss)
    leaves = Leaves(len(truth), np.arange(len(truth)))
    leaves.add(np.stack([forced, truth]), np.stack([pose.as_array()] * 2))
    scored = scoring.finish(lm, sc.bearings, leaves, opt)
    best = np.array([-1 if a is None else a for a in scored.solutions[0].assignment])
    assert best.tolist() == truth.tolist()
    assert scored.solutions[0].confidence > 0.99 and not scored.ambiguous


def test_output_buffer_keeps_the_better_half_in_order() -> None:
    # The kernel's full output buffer keeps its better half, best first, rows with their keys,
    # and raises the bar for entry to the worst key kept.
    n = 16
    key0 = np.random.default_rng(0).permutation(n).astype(float)
    key = key0.copy()
    a = np.tile(np.arange(n)[:, None], (1, 3)).astype(np.int64)  # row j holds j
    p = np.tile(np.arange(n, dtype=float)[:, None], (1, 3))
    miss = np.arange(n, dtype=np.int64)
    bar = np.full(1, np.inf)
    kept = hk._compact(hk._Out(a, p, miss, key, bar))
    assert kept == n // 2
    assert key[:kept].tolist() == list(range(n // 2))
    assert bar[0] == n // 2 - 1
    for i in range(kept):
        j = a[i, 0]
        assert a[i].tolist() == [j] * 3 and p[i, 2] == j and miss[i] == j
        assert key0[j] == key[i]


def test_output_buffer_keeps_one_row_per_interpretation() -> None:
    # The same interpretation reached from several seeds takes one row (its best), so that
    # repeats do not crowd distinct interpretations out of the buffer.
    n = 16
    a = np.array([[r % 3, -1, 7] for r in range(n)], dtype=np.int64)  # 3 interpretations
    key = np.arange(n, dtype=float)[::-1].copy()  # later rows fit better
    p = np.zeros((n, 3))
    p[:, 0] = np.arange(n)
    miss = np.zeros(n, dtype=np.int64)
    bar = np.full(1, np.inf)
    kept = hk._compact(hk._Out(a, p, miss, key, bar))
    assert kept == 3
    assert sorted(a[:kept, 0].tolist()) == [0, 1, 2]
    assert key[:kept].tolist() == [0.0, 1.0, 2.0]  # each one's best row, best first
    assert p[:kept, 0].tolist() == [15.0, 14.0, 13.0]
    assert bar[0] == np.inf  # no interpretation had to go


def _path_of(pairs: list[tuple[int, int]], n_landmarks: int = 50) -> Any:
    """A kernel path holding ``pairs`` (observation, landmark) in that order."""
    m = len(pairs)
    obs = np.array([o for o, _ in pairs], dtype=np.int64)
    lm = np.array([q for _, q in pairs], dtype=np.int64)
    xy = np.zeros((n_landmarks, 2))
    return hk._Path(
        xy, lm, np.zeros(m), np.zeros(m), np.zeros(m), obs, np.ones(m),
        np.zeros(n_landmarks, dtype=np.int64),
    )  # fmt: skip


def _empty_seen(rows: int) -> Any:
    return hk._Seen(np.zeros((rows, 2), dtype=np.uint64), np.zeros(1, dtype=np.int64))


def test_a_complete_path_is_known_again_whatever_the_order_of_its_pairs() -> None:
    # The same interpretation reached from another seed has its pairs in another order.
    seen = _empty_seen(64)
    pairs = [(0, 5), (2, 9), (3, 1), (5, 40)]
    assert hk._first_visit(seen, _path_of(pairs), 4)
    for perm in itertools.permutations(pairs):
        assert not hk._first_visit(seen, _path_of(list(perm)), 4)
    # One pair more, one fewer, a landmark or an observation changed: new interpretations.
    others = [
        [*pairs, (6, 7)],
        pairs[:3],
        [(0, 5), (2, 9), (3, 1), (5, 41)],
        [(0, 5), (2, 9), (4, 1), (5, 40)],
        [(0, 9), (2, 5), (3, 1), (5, 40)],  # the same landmarks, swapped between bearings
    ]
    for other in others:
        assert hk._first_visit(seen, _path_of(other), len(other))
    assert seen.used[0] == 1 + len(others)


def test_the_table_of_refined_paths_grows_and_keeps_what_it_knew() -> None:
    seen = _empty_seen(16)
    rng = np.random.default_rng(3)
    paths = [
        _path_of([(o, int(q)) for o, q in enumerate(rng.choice(50, 4, replace=False))])
        for _ in range(40)
    ]
    for p in paths[:6]:
        assert hk._first_visit(seen, p, 4)
    # More than a quarter full: four times the rows, the same entries.
    grown = hk._grown(seen)
    assert grown.keys.shape == (64, 2) and grown.used[0] == 6
    assert sorted(map(tuple, grown.keys[grown.keys[:, 0] > 0])) == sorted(
        map(tuple, seen.keys[seen.keys[:, 0] > 0])
    )
    for p in paths[:6]:
        assert not hk._first_visit(grown, p, 4)
    # A table at most half full takes no more: a later repeat is refined again, never lost.
    small = _empty_seen(8)
    assert all(hk._first_visit(small, p, 4) for p in paths[:6])
    assert small.used[0] == 4
    assert hk._first_visit(small, paths[5], 4)


def test_loading_the_kernel_is_not_the_time_budgets(monkeypatch: pytest.MonkeyPatch) -> None:
    # numba loads (or compiles) the kernel at its first call in a process; a time budget
    # used to pay for it, so a process's first search stopped short of the same search run
    # again. A stand-in kernel that takes 0.6 s at its first call, as a load would.
    rng = np.random.default_rng(5)
    lm = random_map(30, size=30.0, rng=rng)
    sc = observe(lm, random_pose(lm, rng=rng), max_range=12.0, n_spurious=2, sigma=0.5 * DEG,
                 rng=rng)  # fmt: skip
    kw: dict[str, Any] = {"sigma": 0.5 * DEG, "max_spurious": 2, "max_range": 12.0}
    warm = localize(lm, sc.bearings, timeout_s=0.3, **kw)
    assert warm.complete
    real = hk.hypotheses

    class Loading:
        def __init__(self) -> None:
            self.signatures: list[str] = []

        def __call__(self, *args: Any) -> Any:
            if not self.signatures:
                time.sleep(0.6)
                self.signatures.append("loaded")
            return real(*args)

    monkeypatch.setattr(hyp_search, "hypotheses", Loading())
    first = localize(lm, sc.bearings, timeout_s=0.3, **kw)
    assert first.complete
    assert [s.assignment for s in first.solutions] == [s.assignment for s in warm.solutions]
    assert first.stats.nodes == warm.stats.nodes


def test_interpretations_from_several_seeds_answer_as_one_seed_at_a_time() -> None:
    # Every landmark in view, 2 spurious bearings: the same interpretation is reached from
    # several seed triples. In one kernel call it is refined once; with a time budget each
    # seed runs alone (its own table), so nothing is skipped across seeds. Same answer.
    rng = np.random.default_rng(11)
    lm = random_map(16, size=20.0, rng=rng)
    pose = random_pose(lm, rng=rng)
    sc = observe(lm, pose, n_obs=7, n_spurious=2, sigma=0.5 * DEG, rng=rng)
    kw: dict[str, Any] = {"sigma": 0.5 * DEG, "max_spurious": 2}
    one = localize(lm, sc.bearings, **kw)
    per_seed = localize(lm, sc.bearings, timeout_s=1000.0, **kw)
    assert one.stats.complete and per_seed.stats.complete
    assert len(one) > 10
    assert [s.assignment for s in one.solutions] == [s.assignment for s in per_seed.solutions]
    for a, b in zip(one.solutions, per_seed.solutions, strict=True):
        assert np.allclose(a.pose.as_array(), b.pose.as_array(), atol=1e-9)
        assert a.confidence == pytest.approx(b.confidence, abs=1e-9)


# ---- the cheap test before verification ------------------------------------------------------


def _reach(
    bearing_hits: list[bool], need: int, heading: float = 0.0, work: np.ndarray | None = None
) -> bool:
    """_can_reach on a pose at the origin with a tight covariance: one landmark 10 m out
    along each bearing that should hit, 30 degrees off it for one that should not."""
    rest = np.arange(len(bearing_hits), dtype=np.int64)
    beta = np.deg2rad(np.linspace(-150.0, 150.0, len(bearing_hits)))
    ang = heading + beta + np.where(bearing_hits, 0.0, np.deg2rad(30.0))
    x, y = 10.0 * np.cos(ang), 10.0 * np.sin(ang)
    q = np.arange(len(beta), dtype=np.int64) + 3
    c = 1e-6  # position m^2 and heading rad^2 variances: a gate of a few tenths of a degree
    d = _derived(beta)
    ct, st = np.cos(heading), np.sin(heading)
    work = np.empty((4, 8)) if work is None else work
    near = hk._Near(q, x, y)
    cov = (c, 0.0, 0.0, c, 0.0, c)
    return bool(
        hk._can_reach(rest, len(rest), need, d, 0.0, 0.0, ct, st, near, len(beta), (0, 1, 2),
                      cov, 16.0, work)
    )  # fmt: skip


def _derived(beta: np.ndarray) -> Any:
    """The kernel's per-search constants for bearings ``beta`` at sigma 0.3 degrees."""
    sig2 = (0.3 * DEG) ** 2
    return hk._Derived(np.cos(beta), np.sin(beta), sig2, True, 6.6, 0.9 * DEG)


@pytest.mark.parametrize(
    ("hits", "need", "expected"),
    [
        ([True] * 5, 5, True),
        ([True, True, False, True, True], 5, False),
        ([True, True, False, True, True], 4, True),
        ([False, False, True, True, True], 3, True),
        ([False, False, False, True, True], 3, False),
        ([False] * 5, 0, True),
    ],
)
def test_can_reach_counts_bearings_with_a_landmark_in_the_gate(
    hits: list[bool], need: int, expected: bool
) -> None:
    assert _reach(hits, need) is expected
    # The same from a turned robot: the rays turn with its heading.
    assert _reach(hits, need, heading=2.0) is expected


def test_can_reach_flags_the_bearings_without_a_landmark() -> None:
    # A first fit reserves wildcards for them (see omniloc._kernels.hypotheses._verify).
    hits = [True, False, True, True, False, True]
    work = np.full((4, 8), 7.0)
    assert _reach(hits, 4, work=work)
    assert work[3, :6].tolist() == [0.0, 1.0, 0.0, 0.0, 1.0, 0.0]


def test_can_reach_ignores_the_hypothesis_own_landmarks() -> None:
    # The seed's three landmarks cannot explain another bearing.
    beta = np.deg2rad([0.0, 90.0])
    x, y = 10.0 * np.cos(beta), 10.0 * np.sin(beta)
    q = np.array([0, 1], dtype=np.int64)
    near = hk._Near(q, x, y)
    cov = (1e-6, 0.0, 0.0, 1e-6, 0.0, 1e-6)
    rest = np.array([0, 1], dtype=np.int64)
    d = _derived(beta)

    def reach(own: tuple[int, int, int]) -> bool:
        work = np.empty((4, 2))
        return bool(hk._can_reach(rest, 2, 2, d, 0.0, 0.0, 1.0, 0.0, near, 2, own, cov, 16.0, work))

    assert reach((5, 6, 7))
    for own in [(0, 6, 7), (5, 0, 7), (5, 6, 0)]:  # landmark 0 is one of the three
        assert not reach(own)


@pytest.mark.parametrize("exhaustive", [True, False])
def test_cheap_test_only_removes_poorly_fitting_interpretations(
    exhaustive: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The cheap test is exact to first order only: with and without it the best
    # interpretation is the same and it never adds one.
    work = {"on": 0, "off": 0}
    for seed in range(10):
        rng = np.random.default_rng(300 + seed)
        lm = random_map(30, size=40.0, rng=rng)
        pose = random_pose(lm, rng=rng)
        sc = observe(lm, pose, max_range=12.0, n_spurious=3, sigma=0.5 * DEG, rng=rng)
        kw = {"sigma": 0.5 * DEG, "max_spurious": 3, "max_range": 12.0, "p_miss": 0.05}
        kw["exhaustive"] = exhaustive
        on = localize(lm, sc.bearings, strategy="hypotheses", **kw)
        with monkeypatch.context() as mp:
            mp.setattr(hyp_search, "PRETEST_SLACK", {True: (0.0, 0.0), False: (0.0, 0.0)})
            off = localize(lm, sc.bearings, strategy="hypotheses", **kw)
        assert (on.best is None) == (off.best is None)
        if off.best is not None and on.best is not None:
            assert on.best.assignment == off.best.assignment
        if exhaustive:
            assert {s.assignment for s in on.solutions} <= {s.assignment for s in off.solutions}
        work["on"] += on.stats.examined_paths
        work["off"] += off.stats.examined_paths
    # ... and it spares most of the verification.
    assert work["on"] < 0.5 * work["off"]


@pytest.fixture(scope="module")
def out_of_gate() -> tuple[LandmarkMap, np.ndarray, Pose, int, dict[str, Any]]:
    """A 2,500-landmark map (the default is a first fit) and bearings whose first real one is
    8 sigma off: with max_spurious equal to the clutter (1) the truth is out of the first
    fit's reach, and nothing else convinces."""
    lm = random_map(2500, density=0.01, min_separation=1.0, rng=21)
    sigma = np.deg2rad(0.3)
    for seed in range(30):
        truth = random_pose(lm, clearance=1.0, rng=seed)
        x0, y0, x1, y1 = lm.bounds
        if not (x0 + 20 < truth.x < x1 - 20 and y0 + 20 < truth.y < y1 - 20):
            continue
        sc = observe(lm, truth, max_range=20.0, n_spurious=1, sigma=sigma, rng=seed)
        real = [k for k, a in enumerate(sc.assignment) if a is not None]
        if len(real) >= 8:
            break
    else:
        pytest.fail("no interior pose seeing 8 landmarks")
    z = sc.bearings.copy()
    z[real[0]] += 8 * sigma
    return lm, z, truth, real[0], {"sigma": sigma, "max_spurious": 1, "max_range": 20.0}


def test_auto_first_fit_looks_again_when_a_real_bearing_is_out_of_its_gate(
    out_of_gate: tuple[LandmarkMap, np.ndarray, Pose, int, dict[str, Any]],
) -> None:
    # Nothing convinces, so the search looks again with one more bearing allowed unmatched.
    lm, z, truth, off, kw = out_of_gate
    strict = localize(lm, z, exhaustive=True, **kw)
    assert not strict or strict.best.pose.distance_to(truth)[0] > 0.5
    res = localize(lm, z, **kw)
    assert res.best is not None and res.best.pose.distance_to(truth)[0] < 0.1
    assert res.best.assignment[off] is None
    # The second look ran under its default budget and finished within it.
    assert res.stats.complete and "second look" in res.stats.default_budget
    assert "within its default budget" in res.stats.default_budget


def _spy_on_runs(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, int]]:
    """Record the work and nodes of each search run localize starts (the first fit, the
    second look; each with the exhaustive search it may start)."""
    runs: list[dict[str, int]] = []
    real = search.run_hypotheses

    def spy(lm: LandmarkMap, beta: np.ndarray, opt: Any, out: Leaves, **kw: Any) -> None:
        work, nodes = out.counts.work, out.counts.nodes
        real(lm, beta, opt, out, **kw)
        runs.append({"wild": opt.max_wild, "work": out.counts.work - work})
        runs[-1]["nodes"] = out.counts.nodes - nodes

    monkeypatch.setattr(search, "run_hypotheses", spy)
    return runs


def test_the_second_look_is_bounded_by_the_first_fits_work(
    out_of_gate: tuple[LandmarkMap, np.ndarray, Pose, int, dict[str, Any]],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Without a budget the second look (and the exhaustive search after it, should its first
    # fit find nothing) may search the whole map: minutes on 10,000 landmarks. By default it
    # may spend SECOND_LOOK_FACTOR times the first fit's work (at least SECOND_LOOK_FLOOR);
    # made small here, the bound stops it, and the result says so.
    lm, z, _, _, kw = out_of_gate
    runs = _spy_on_runs(monkeypatch)
    free = localize(lm, z, max_nodes=10**12, **kw)  # a budget of the caller's: no default
    assert free.stats.complete and free.stats.default_budget == ""
    assert [r["wild"] for r in runs] == [1, 2]
    allowance = runs[1]["work"] // 8
    runs.clear()
    monkeypatch.setattr(search, "SECOND_LOOK_FACTOR", 0)
    monkeypatch.setattr(search, "SECOND_LOOK_FLOOR", allowance)
    res = localize(lm, z, **kw)
    # Counted in work, not time: the second look spent no more than its allowance (two
    # chunks of the map in flight may each take what is left of it, and finish the
    # hypothesis they are verifying).
    assert [r["wild"] for r in runs] == [1, 2]
    assert 0 < runs[1]["work"] <= 2 * allowance + 100_000
    assert res.stats.nodes < free.stats.nodes
    assert not res.complete and res.stats.stopped == "budget"
    note = res.stats.default_budget
    assert note.startswith("second look (one more unmatched bearing) stopped after")
    assert "pass max_nodes or timeout_s" in note
    # An incomplete search is never decisive.
    assert res.ambiguous


def test_a_callers_budget_replaces_the_second_looks_default(
    out_of_gate: tuple[LandmarkMap, np.ndarray, Pose, int, dict[str, Any]],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    lm, z, truth, _, kw = out_of_gate
    first = localize(lm, z, exhaustive=False, **kw).stats.nodes
    monkeypatch.setattr(search, "SECOND_LOOK_FACTOR", 0)
    monkeypatch.setattr(search, "SECOND_LOOK_FLOOR", 1)
    # The caller allowed more than the default: the second look may spend all of it.
    res = localize(lm, z, max_nodes=10**12, **kw)
    assert res.complete and res.stats.default_budget == ""
    assert res.best is not None and res.best.pose.distance_to(truth)[0] < 0.1
    # The caller's node budget counts the whole call, first fit and second look together.
    # (Two chunks of the map in flight may each take what is left, and finish the
    # hypothesis they are verifying.)
    cut = localize(lm, z, max_nodes=first + 100_000, **kw)
    assert first < cut.stats.nodes <= first + 2 * 100_000 + 1000
    assert not cut.complete and cut.stats.stopped == "budget" and cut.ambiguous
    assert cut.stats.default_budget == ""


# ---- clutter whose rate follows the landmarks detected ---------------------------------------


def test_clutter_count_term_is_the_poisson_ratio() -> None:
    from omniloc.sensor import SensorModel

    s = SensorModel(sigma=DEG, clutter=0.3, clutter_by_detections=(0.2, 0.4, 1.2))
    n = np.arange(7)
    rate = np.array([0.3, 0.2, 0.4, 1.2, 1.2, 1.2, 1.2])  # n = 0 keeps the one rate
    want = (6 - n) * np.log(rate / 0.3) - (rate - 0.3)
    np.testing.assert_allclose(s.clutter_count_term(6, n), want, rtol=1e-12, atol=1e-15)
    assert not SensorModel(sigma=DEG, clutter=0.3).clutter_count_term(6, n).any()
    # A table equal to the one rate changes nothing.
    flat = SensorModel(sigma=DEG, clutter=0.3, clutter_by_detections=(0.3,))
    assert not flat.clutter_count_term(6, n).any()


def test_the_clutter_table_of_a_recording() -> None:
    from omniloc.sensor import CLUTTER_ENTRY_FRAMES, clutter_by_detections

    detected = [0] * 10 + [1] * 50 + [2] * 50 + [3] * 20 + [4] * 15
    spurious = [2] * 10 + [0] * 50 + [1] * 50 + [2] * 20 + [4] * 15
    assert CLUTTER_ENTRY_FRAMES == 30  # 35 frames report 3 or more, 15 report 4
    assert clutter_by_detections(detected, spurious) == pytest.approx(
        (0.0, 1.0, (20 * 2 + 15 * 4) / 35)
    )
    with pytest.raises(InputError, match="one count of each per frame"):
        clutter_by_detections([1, 2], [0])
    with pytest.raises(InputError, match="one count of each per frame"):
        clutter_by_detections([], [])
    with pytest.raises(InputError, match=r"detected must hold one count per frame \(1-D\)"):
        clutter_by_detections([[1, 2]], [[0, 0]])
    with pytest.raises(InputError, match="spurious must hold counts"):
        clutter_by_detections([1, 2], [0.5, 0])


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("0.3", "sequence"),
        (0.3, "sequence"),
        ([], "1 to 1000 entries"),
        ([0.3, float("nan")], r"clutter_by_detections\[1\]"),
        ([-1.0], r"clutter_by_detections\[0\]"),
        ([0.5] * 1001, "1 to 1000 entries"),
        ({0.3, 0.9}, "sequence"),  # no order to index by
        (np.array(0.3), "sequence"),
        (np.ones((2, 2)), "sequence"),
    ],
)
def test_clutter_table_is_checked(value: Any, message: str) -> None:
    from omniloc.sensor import SensorModel

    with pytest.raises(InputError, match=message):
        SensorModel(clutter_by_detections=value)
    with pytest.raises(InputError, match=message):
        localize(demo_room(), [0.1, 0.5, 1.0, 2.0], clutter_by_detections=value)


def test_clutter_by_detections_shifts_each_interpretation_by_its_clutter_count() -> None:
    # Without merging, each interpretation's log evidence moves by the Poisson ratio of its
    # own clutter count: the confidences' log ratios move by the difference of the terms.
    import dataclasses

    from omniloc.sensor import SensorModel

    room = demo_room()
    rng = np.random.default_rng(4)
    pose = Pose(2.0, 2.5, 0.3)
    from omniloc.pose import predict_bearings

    idx = rng.choice(room.n, 5, replace=False)
    z = np.concatenate([predict_bearings(room.xy[idx], pose), rng.uniform(-np.pi, np.pi, 2)])
    base = SensorModel(sigma=DEG, p_detect=0.5, clutter=0.5)
    table = base.replace(clutter_by_detections=(0.5, 0.5, 0.2, 1.5, 3.0))
    conf = {}
    for name, sensor in (("base", base), ("table", table)):
        opt = make_options(
            len(z), method=Method.ROBUST, sensor=sensor, budget=None, max_spurious=2,
            ordering=False, legacy={},
        )  # fmt: skip
        opt = dataclasses.replace(opt, merge=False)
        leaves = Leaves(len(z), np.arange(len(z)))
        hyp_search.run_hypotheses(room, z, opt, leaves, stop_first=False)
        scored = scoring.finish(room, z, leaves, opt)
        conf[name] = {s.assignment: s for s in scored.solutions}
    common = list(set(conf["base"]) & set(conf["table"]))
    assert len(common) > 50
    counts = {conf["base"][a].matched for a in common}
    assert len(counts) >= 2  # interpretations with different clutter counts
    shift = [
        math.log(conf["table"][a].confidence)
        - math.log(conf["base"][a].confidence)
        - float(table.clutter_count_term(len(z), conf["base"][a].matched, 2))
        for a in common
    ]
    assert np.ptp(shift) < 1e-6  # one normalising constant for all


@pytest.mark.parametrize("shape", [(1, 3), (2, 4), (50, 3), (3000, 6), (500, 12)])
def test_unique_rows_is_numpys_unique(shape: tuple[int, int], rng: np.random.Generator) -> None:
    # The search's dedup of paths against the numpy call it replaces: rows, order and the
    # index of each row's first occurrence (paths are landmark rows, -1 for a wildcard).
    a = rng.integers(-1, 6, shape).astype(np.int64)
    a = np.concatenate([a, a[rng.integers(0, shape[0], shape[0])], a[:1]])
    rows, first = hyp_search.unique_rows(a)
    want_rows, want_first = np.unique(a, axis=0, return_index=True)
    assert np.array_equal(rows, want_rows) and np.array_equal(first, want_first)
    extreme = np.array([[2**62, -1, 0], [-(2**62), 5, 1], [2**62, -1, 0], [0, 0, 0]])
    rows, first = hyp_search.unique_rows(extreme)
    want_rows, want_first = np.unique(extreme, axis=0, return_index=True)
    assert np.array_equal(rows, want_rows) and np.array_equal(first, want_first)


# ---- the search's pool of threads --------------------------------------------------------------


def test_a_chunk_that_raises_leaves_no_chunk_running() -> None:
    """The chunks run on the process's pool: when one raises, its error reaches the caller,
    the chunks still queued are dropped and the one running is waited for (none outlives
    the call)."""
    from types import SimpleNamespace

    started: list[int] = []
    finished: list[int] = []

    def call(part: slice, chunk: int, first: int, cap: tuple[int, int]) -> Any:
        started.append(chunk)
        if chunk == 1:
            raise RuntimeError("chunk 1 failed")
        time.sleep(0.05)
        finished.append(chunk)
        return (None, None, None, SimpleNamespace(nodes=0, work=0, stopped=False))

    chunks = [(slice(0, 1), k, 0) for k in range(6)]
    out = SimpleNamespace(time_left=lambda timeout: None, complete=True)
    opt = SimpleNamespace(budget=SimpleNamespace(timeout_s=None))
    with pytest.raises(RuntimeError, match="chunk 1 failed"):
        hyp_search._run_chunks(call, chunks, (0, 0), out, opt)  # type: ignore[arg-type]
    started_then, finished_then = list(started), list(finished)
    assert sorted(started_then) == sorted([*finished_then, 1])  # each one started had ended
    time.sleep(0.3)
    assert started == started_then  # and none starts after the call
    assert len(started) < len(chunks)


@pytest.mark.skipif(
    "fork" not in __import__("multiprocessing").get_all_start_methods(), reason="no fork"
)
def test_a_forked_child_searches_on_its_own_pool() -> None:
    # The parent's search threads do not exist in a child made by fork (evaluation workers
    # forked after a search in the parent): the child's chunks must not wait for them.
    import multiprocessing as mp

    import omniloc._pools as pools

    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=7, n_spurious=1, rng=3)
    # (A time budget on a small map runs a chunk per seed, as the tracker's searches do.)
    kw = {"max_spurious": 2, "sigma": np.deg2rad(1.0), "timeout_s": 30.0}
    want = localize(lm, sc.bearings, **kw)
    if (os.cpu_count() or 1) >= 2:
        assert any(name == "omniloc-search" for name, _ in pools._local.pools)  # ran on it
    ctx = mp.get_context("fork")
    with ctx.Pool(1) as pool:
        got = pool.apply_async(localize, (lm, sc.bearings), kw).get(timeout=60)
    np.testing.assert_array_equal(got.poses, want.poses)


def test_each_thread_searches_on_pools_of_its_own_that_leave_with_it() -> None:
    # Searches run from several threads at once do not queue behind each other's chunks,
    # and a thread's pool does not outlive it (its workers leave once it is collected).
    import gc
    import threading

    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=7, n_spurious=1, rng=3)
    kw = {"max_spurious": 2, "sigma": np.deg2rad(1.0), "timeout_s": 30.0}  # chunks per seed
    want = localize(lm, sc.bearings, **kw)

    def workers() -> int:
        return sum(t.name.startswith("omniloc-search") for t in threading.enumerate())

    before = workers()
    got: list[Any] = []
    seen: list[object] = []

    def run() -> None:
        import omniloc._pools as pools

        got.append(localize(lm, sc.bearings, **kw))
        seen.append(pools.pool("omniloc-search", hyp_search.THREADS))

    threads = [threading.Thread(target=run) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(got) == 3
    for res in got:
        np.testing.assert_array_equal(res.poses, want.poses)
    if (os.cpu_count() or 1) >= 2:
        assert len({id(p) for p in seen}) == 3  # one pool per thread (all alive here)
    seen.clear()
    deadline = time.monotonic() + 10.0
    while workers() > before and time.monotonic() < deadline:
        gc.collect()
        time.sleep(0.05)
    assert workers() <= before  # (other tests' threads' pools may leave meanwhile too)
