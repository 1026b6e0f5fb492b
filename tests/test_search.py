from __future__ import annotations

import math
import time

import numpy as np
import pytest

from omniloc.errors import InputError
from omniloc.maps import LandmarkMap
from omniloc.pose import Pose, predict_bearings
from omniloc.search import LocalizationResult, Method, Solutions, localize
from omniloc.simulate import demo_room, observe, random_map, random_pose, symmetric_map

DEG = np.pi / 180


def _has_pose(result, pose: Pose, tol_xy: float = 1e-6, tol_th: float = 1e-6) -> bool:
    return any(
        s.pose.distance_to(pose)[0] <= tol_xy and s.pose.distance_to(pose)[1] <= tol_th
        for s in result.solutions
    )


def test_solutions_are_a_sequence_with_arrays_of_them_all() -> None:
    # Many interpretations (a symmetric map, clutter allowed): the result's arrays are its
    # solutions', row for row, and the sequence reads like a list.
    lm = symmetric_map("octagon")
    scene = observe(lm, random_pose(lm, rng=3), n_obs=5, rng=4)
    res = localize(lm, scene.bearings, sigma=DEG, max_spurious=1)
    sols = list(res.solutions)
    k = len(sols)
    assert isinstance(res.solutions, Solutions) and k > 1 and len(res) == k
    assert res.poses.shape == (k, 3) and res.assignments.shape == (k, scene.bearings.size)
    for i, s in enumerate(sols):
        assert tuple(res.poses[i]) == s.pose.as_tuple()
        assert tuple(None if a < 0 else int(a) for a in res.assignments[i]) == s.assignment
        assert isinstance(s.residual_rms, float) and isinstance(s.matched, int)
    conf = [s.confidence for s in sols]
    assert conf == sorted(conf, reverse=True)
    assert res.solutions[-1] == sols[-1] and res.solutions[1:3] == sols[1:3]
    assert res.solutions == sols and res.solutions[0] is res.best
    with pytest.raises(IndexError):
        res.solutions[k]
    with pytest.raises(ValueError, match="read-only"):
        res.poses[0, 0] = 1.0
    # A result made from a list of solutions gives the same arrays.
    again = LocalizationResult(sols, res.stats, lm)
    np.testing.assert_array_equal(again.poses, res.poses)
    np.testing.assert_array_equal(again.assignments, res.assignments)
    empty = LocalizationResult([], res.stats, lm)
    assert empty.poses.shape == (0, 3) and empty.assignments.shape[0] == 0
    # Made from the caller's arrays: read-only views, the caller's arrays left writable.
    mine = [np.asarray(a).copy() for a in res.solutions._arrays]
    again = Solutions(*mine)
    assert again == res.solutions and all(a.flags.writeable for a in mine)
    with pytest.raises(InputError, match="one row per solution"):
        Solutions(mine[0], mine[1][:1], *mine[2:])


@pytest.mark.parametrize(("n", "m"), [(12, 4), (12, 7), (5, 5), (30, 3)])
def test_total_paths_is_n_perm_m(n: int, m: int) -> None:
    lm = random_map(n, rng=n)
    scene = observe(lm, random_pose(lm, rng=1), n_obs=m, rng=2)
    res = localize(lm, scene.bearings, method="paper")
    assert res.stats.total_paths == math.factorial(n) // math.factorial(n - m)
    assert res.stats.total_paths == math.perm(n, m)


@pytest.mark.parametrize("method", ["paper", "robust"])
@pytest.mark.parametrize("seed", range(8))
def test_true_pose_among_solutions_noise_free(method: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    lm = demo_room() if seed % 2 == 0 else random_map(15, rng=rng)
    pose = random_pose(lm, rng=rng)
    scene = observe(lm, pose, n_obs=int(rng.integers(4, 8)), rng=rng)
    res = localize(lm, scene.bearings, method=method)
    assert res
    assert _has_pose(res, pose)
    assert any(s.assignment == scene.assignment for s in res.solutions) or method == "robust"
    best = res.best
    # The best is the most probable pose: it fits within the noise the threshold stands for,
    # and when the answer is not ambiguous it is the truth.
    assert best is not None and best.residual_rms < np.deg2rad(1.0) / 3
    if not res.ambiguous:
        assert best.pose.distance_to(pose)[0] < 1e-6


def test_result_fields_and_stats() -> None:
    lm = demo_room()
    pose = Pose(5.6, 2.1, 0.5)
    scene = observe(lm, pose, visible=[10, 3, 0, 6, 8, 4], rng=0)
    res = localize(lm, scene.bearings, method="paper")
    st = res.stats
    assert st.complete and res.complete
    assert 0 < st.examined_paths < st.nodes < st.total_paths
    # Every depth-3 node is a triple to solve (rule i), and rule (i) cuts some but not all.
    assert st.triples_solved == 12 * 11 * 10
    assert 0 < st.pruned_existence < st.triples_solved
    d = st.as_dict()
    assert d["total_paths"] == math.perm(12, 6) and isinstance(d["elapsed_s"], float)
    assert len(res) == len(res.solutions) and bool(res)
    assert res.assignment_ids(res.best) == [lm.ids[i] for i in res.best.assignment]
    # The posterior: the solutions and the null interpretation (all clutter) share it.
    assert abs(sum(s.confidence for s in res.solutions) + res.unexplained - 1.0) < 1e-9
    assert 0.0 <= res.unexplained < 1e-3


@pytest.mark.parametrize("seed", range(5))
def test_invariant_to_observation_order(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    lm = random_map(14, rng=rng)
    pose = random_pose(lm, rng=rng)
    scene = observe(lm, pose, n_obs=6, rng=rng)
    perm = rng.permutation(6)
    inv = np.argsort(perm)
    for method in ("paper", "robust"):
        a = localize(lm, scene.bearings, method=method)
        b = localize(lm, scene.bearings[perm], method=method)
        # The true interpretation does not depend on the order of the bearings (the set of
        # false interpretations near the gate may: the paper's gate uses the pose of whichever
        # three bearings come first, so the posterior's verdict may too).
        sol_a = next(s for s in a.solutions if s.assignment == scene.assignment)
        sol_b = next(
            s for s in b.solutions if tuple(s.assignment[k] for k in inv) == scene.assignment
        )
        assert np.allclose(sol_a.pose.as_array(), sol_b.pose.as_array(), atol=1e-8)
        for r in (a, b):
            assert r.best is not None
            if not r.ambiguous:
                assert r.best.pose.distance_to(pose)[0] < 1e-6


@pytest.mark.parametrize("seed", range(5))
def test_invariant_to_rigid_motion_of_the_world(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    lm = random_map(12, rng=rng)
    pose = random_pose(lm, rng=rng)
    scene = observe(lm, pose, n_obs=5, rng=rng)
    rot, t = rng.uniform(-np.pi, np.pi), rng.uniform(-50, 50, 2)
    c, s = np.cos(rot), np.sin(rot)
    R = np.array([[c, -s], [s, c]])
    lm2 = LandmarkMap(lm.xy @ R.T + t)
    a = localize(lm, scene.bearings)
    b = localize(lm2, scene.bearings)
    assert [x.assignment for x in a.solutions] == [x.assignment for x in b.solutions]
    for x, y in zip(a.solutions, b.solutions, strict=True):
        moved = R @ x.pose.xy + t
        assert np.allclose(moved, y.pose.xy, atol=1e-6)
        assert abs(np.angle(np.exp(1j * (x.pose.theta + rot - y.pose.theta)))) < 1e-8


def test_spurious_bearings_are_wildcards() -> None:
    lm = demo_room()
    pose = Pose(5.6, 2.1, 0.5)
    scene = observe(lm, pose, n_obs=6, n_spurious=2, sigma=0.2 * DEG, rng=4)
    plain = localize(lm, scene.bearings, sigma=0.2 * DEG)
    assert not _has_pose(plain, pose, 0.1, DEG)
    res = localize(lm, scene.bearings, sigma=0.2 * DEG, max_spurious=2)
    best = res.best
    assert best is not None
    assert best.assignment == scene.assignment  # None exactly at the spurious bearings
    assert best.matched == 6
    assert best.pose.distance_to(pose)[0] < 0.1
    # A fraction of m works too: 2 of 8 bearings.
    frac = localize(lm, scene.bearings, sigma=0.2 * DEG, max_spurious=0.25)
    assert frac.best is not None and frac.best.assignment == scene.assignment


def test_branch_and_bound_on_matches() -> None:
    lm = demo_room()
    pose = Pose(5.6, 2.1, 0.5)
    scene = observe(lm, pose, n_obs=7, rng=1)  # no spurious bearing at all
    res = localize(lm, scene.bearings, max_spurious=3)
    assert res.best is not None and res.best.assignment == scene.assignment
    assert res.stats.pruned_bound > 0
    # Every solution matches at least the required 7 - 3 bearings; the full one ranks first.
    assert min(s.matched for s in res.solutions) >= 4
    assert res.best.matched == 7


def test_max_spurious_rejects_too_few_left() -> None:
    lm = demo_room()
    z = predict_bearings(lm.xy[:4], Pose(5, 3, 0))
    with pytest.raises(InputError, match="leaves 2 matched"):
        localize(lm, z, max_spurious=2)


def test_sigma_gating_keeps_true_matches_under_noise() -> None:
    rng = np.random.default_rng(7)
    sig = 0.5 * DEG
    hits = 0
    trials = 15
    for _ in range(trials):
        lm = demo_room()
        pose = random_pose(lm, rng=rng)
        scene = observe(lm, pose, n_obs=6, sigma=sig, rng=rng)
        res = localize(lm, scene.bearings, sigma=sig)
        hits += any(s.assignment == scene.assignment for s in res.solutions) or _has_pose(
            res, pose, 0.2, 2 * DEG
        )
    assert hits >= trials - 1


def test_threshold_gate_is_the_papers_rule() -> None:
    lm = demo_room()
    pose = Pose(5.6, 2.1, 0.5)
    scene = observe(lm, pose, visible=[10, 3, 0, 6, 8, 4], rng=0)
    z = scene.bearings.copy()
    z[4] += 2 * DEG  # the fifth observation is off by 2 degrees
    narrow = localize(lm, z, method="paper")
    assert not any(s.assignment == scene.assignment for s in narrow.solutions)
    wide = localize(lm, z, method="paper", threshold=5 * DEG)
    assert any(s.assignment == scene.assignment for s in wide.solutions)


@pytest.mark.parametrize("seed", range(6))
def test_ordering_never_loses_the_truth_and_only_prunes(seed: int) -> None:
    rng = np.random.default_rng(300 + seed)
    lm = random_map(15, rng=rng)
    pose = random_pose(lm, rng=rng)
    sig = 0.5 * DEG
    scene = observe(lm, pose, n_obs=6, sigma=sig, rng=rng)
    plain = localize(lm, scene.bearings, sigma=sig)
    ordered = localize(lm, scene.bearings, sigma=sig, ordering=True)
    assert ordered.stats.nodes <= plain.stats.nodes
    # Equivalent solutions are merged after the search, so compare poses, not assignments.
    for s in ordered.solutions:
        assert any(s.pose.distance_to(t.pose)[0] < 0.5 for t in plain.solutions)
    if any(s.assignment == scene.assignment for s in plain.solutions):
        assert any(s.assignment == scene.assignment for s in ordered.solutions)


def test_ordering_prunes_at_wide_gates() -> None:
    # With a tight gate the ordering is implied by the bearings; with a wide one (2 degree
    # noise) it cuts paths whose landmarks go round the pose in another order.
    rng = np.random.default_rng(1)
    lm = random_map(20, rng=rng)
    pose = random_pose(lm, rng=rng)
    sig = 2.0 * DEG
    scene = observe(lm, pose, n_obs=7, sigma=sig, rng=rng)
    loose = localize(lm, scene.bearings, sigma=sig, strategy="tree")
    strict = localize(lm, scene.bearings, sigma=sig, ordering=True, strategy="tree")
    assert strict.stats.pruned_ordering > 0
    assert strict.stats.nodes < loose.stats.nodes
    assert len(strict.solutions) <= len(loose.solutions)
    # The hypotheses strategy checks the order on complete interpretations only: it drops
    # the same out-of-order ones, and never the truth.
    hyp = localize(lm, scene.bearings, sigma=sig, ordering=True, strategy="hypotheses")
    assert any(s.pose.distance_to(pose)[0] < 0.5 for s in hyp.solutions)


def test_visibility_prunes_and_negative_evidence_ranks() -> None:
    # A square (4-fold symmetric) plus one far landmark that only some of the symmetric
    # poses would see within range.
    L = np.array([[0, 0], [6, 0], [6, 6], [0, 6], [3, -8]], float)
    truth = Pose(1.5, 4.5, 0.3)
    z = predict_bearings(L[:4], truth)
    plain = localize(L, z, max_range=11.0)
    assert len(plain) == 4 and plain.ambiguous
    neg = localize(L, z, max_range=11.0, p_miss=0.05)
    assert [s.missed for s in neg.solutions] == [0, 0, 1, 1]
    assert _has_pose(neg, truth)
    top2 = neg.solutions[:2]
    assert any(s.pose.distance_to(truth)[0] < 1e-6 for s in top2)
    assert neg.solutions[2].confidence < 0.1 * top2[0].confidence
    # With a range limit that excludes two corners, the search prunes by visibility.
    short = localize(L, z, max_range=5.0)
    assert short.stats.pruned_visibility > 0 and not _has_pose(short, truth)


def test_fov_limits_negative_evidence() -> None:
    L = np.array([[0, 0], [6, 0], [6, 6], [0, 6], [3, -8]], float)
    truth = Pose(1.5, 4.5, 0.3)
    z = predict_bearings(L[:4], truth)
    res = localize(L, z, fov=2 * np.pi, p_miss=0.2)
    # 360-degree field of view and no range: every unobserved landmark counts as missed.
    assert all(s.missed == 1 for s in res.solutions)


def test_a_bearing_outside_the_field_of_view_is_refused() -> None:
    # Bearings measured from one edge of the view (0 to fov) instead of from the forward
    # axis: the search would otherwise match them and report a pose turned by fov / 2.
    lm = demo_room()
    truth = Pose(5.6, 2.1, math.radians(30))
    fov = math.radians(100)
    scene = observe(lm, truth, fov=fov, rng=0)
    assert scene.bearings.size >= 3
    ok = localize(lm, scene.bearings, fov=fov, sigma=math.radians(0.2))
    assert ok.best is not None and ok.best.pose.distance_to(truth)[0] < 0.05
    with pytest.raises(InputError, match="outside the field of view"):
        localize(lm, scene.bearings + fov / 2, fov=fov, sigma=math.radians(0.2))
    # A bearing just past the edge, within a gate's width, is noise, not a convention.
    edge = np.append(scene.bearings[:3], fov / 2 + math.radians(0.5))
    localize(lm, edge, fov=fov, sigma=math.radians(0.2), max_spurious=1)
    # Stacked from several frames of a turning robot (a tracker's window): not refused.
    localize(lm, scene.bearings + fov / 2, fov=fov, sigma=math.radians(0.2), check_view=False)


def test_a_spurious_bearing_in_a_landmarks_gate_is_also_tried_as_spurious() -> None:
    # 16 landmarks, 9 true bearings and 2 spurious ones, sigma 0.5 deg. Bearing 3 is spurious
    # and falls inside landmark 5's gate: the interpretation that takes it for landmark 5 lies
    # 0.64 m from the truth (15 of its standard deviations). The hypotheses engine, trying
    # the wildcard after a fitting landmark only for bearings with another one close by,
    # never scored the true interpretation and called that pose decisive (99.9 %).
    L = np.array(
        [
            [3.425065, 3.178875],
            [0.976122, 18.1908],
            [10.917499, 2.531848],
            [2.944842, 18.757094],
            [1.512456, 12.349981],
            [0.597985, 7.633556],
            [18.847695, 7.337913],
            [8.891307, 1.417676],
            [1.434226, 11.474866],
            [19.079127, 17.343161],
            [13.00917, 19.571281],
            [8.634995, 19.155462],
            [10.482388, 1.269059],
            [9.290899, 19.336263],
            [8.334987, 19.708606],
            [7.778475, 3.23285],
        ]
    )
    z = np.array(
        [
            0.814193345,
            0.585374602,
            1.455973738,
            2.420309508,
            0.885734303,
            -1.313201355,
            -1.516238662,
            1.1978607,
            0.85311605,
            1.282554995,
            -0.415288464,
        ]
    )
    truth = Pose(6.0725, 5.8352, 0.51813)
    kw = {"sigma": math.radians(0.5), "max_spurious": 2}
    for res in (localize(L, z, **kw), localize(L, z, strategy="tree", **kw)):
        assert res.ambiguous
        assert res.best.assignment[3] is None
        assert res.best.pose.distance_to(truth)[0] < 0.3
    # Only the contested bearings (the tracker's searches): the rival alone, decisive.
    fast = localize(L, z, contested_wildcards=True, **kw)
    assert fast.best.assignment[3] == 5 and not fast.ambiguous


@pytest.mark.parametrize("seed", range(12))
def test_the_order_of_the_bearings_does_not_change_the_answer(seed: int) -> None:
    # The same bearings in any order: the same solutions, their assignments in the order
    # given. (The gates follow the pose built up along each path: taken in the order given,
    # one order could let a true bearing at the edge of its gate through and another not.)
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.0, 20.0, size=(int(rng.integers(8, 16)), 2))
    truth = Pose(*rng.uniform(4.0, 16.0, 2), float(rng.uniform(-np.pi, np.pi)))
    seen = rng.choice(len(L), size=int(rng.integers(4, 8)), replace=False)
    z = predict_bearings(L[seen], truth) + rng.normal(0.0, math.radians(0.5), seen.size)
    z = np.append(z, rng.uniform(-np.pi, np.pi, 1))
    kw = {"sigma": math.radians(0.5), "max_spurious": 1}
    first = localize(L, z, **kw)
    perm = rng.permutation(z.size)
    other = localize(L, z[perm], **kw)
    assert len(other) == len(first) and other.ambiguous == first.ambiguous
    np.testing.assert_array_equal(other.poses, first.poses)
    np.testing.assert_array_equal(other.assignments, first.assignments[:, perm])


def test_symmetric_map_is_ambiguous_with_equal_confidence() -> None:
    lm = symmetric_map("square", size=6.0)
    truth = Pose(1.5, 2.0, 0.7)
    res = localize(lm, predict_bearings(lm.xy, truth))
    assert len(res) == 4 and res.ambiguous
    conf = [s.confidence for s in res.solutions]
    assert np.ptp(conf) < 1e-9 and min(conf) > 0.2  # all four alike
    assert sum(conf) + res.unexplained == pytest.approx(1.0)
    assert _has_pose(res, truth)


def test_unique_solution_is_not_ambiguous() -> None:
    lm = demo_room()
    scene = observe(lm, Pose(5.6, 2.1, 0.5), visible=[10, 3, 0, 6, 8, 4, 11], rng=0)
    res = localize(lm, scene.bearings)
    assert len(res) == 1 and not res.ambiguous and res.best.confidence == pytest.approx(1.0)


def test_equivalent_assignments_are_merged() -> None:
    # Landmarks 4 and 5 lie on one ray from the robot: swapping them gives the same pose.
    pose = Pose(2.0, 2.0, 0.0)
    L = np.array([[8, 2], [2, 9], [-4, 1], [-1, -5], [6, 6], [10, 10]], float)
    z = predict_bearings(L[:5], pose)
    paper = localize(L, z, method="paper")
    robust = localize(L, z)
    assert len(paper) == 2  # (..., 4) and (..., 5) are both consistent complete paths
    assert len(robust) == 1


def test_budget_stops_early_and_says_so() -> None:
    lm = random_map(25, rng=0)
    scene = observe(lm, random_pose(lm, rng=0), n_obs=7, rng=0)
    res = localize(lm, scene.bearings, max_nodes=50)
    assert not res.complete and not res.stats.complete
    full = localize(lm, scene.bearings)
    assert full.complete and full.stats.nodes > res.stats.nodes
    quick = localize(lm, scene.bearings, max_spurious=2, timeout_s=1e-4)
    assert not quick.complete


def test_a_time_budget_on_one_seed_answers_as_without_one_and_still_stops() -> None:
    # No spurious bearing allowed on a small map: one seed, one chunk, run in the caller's
    # thread (a thread pool for it cost as much as the search). Same answer as without a
    # budget; a budget too short for it still stops it and says so.
    lm = random_map(60, rng=3)
    scene = observe(lm, random_pose(lm, rng=3), n_obs=7, sigma=0.2 * DEG, rng=3)
    free = localize(lm, scene.bearings, sigma=0.2 * DEG)
    timed = localize(lm, scene.bearings, sigma=0.2 * DEG, timeout_s=30.0)
    assert free.complete and timed.complete
    assert [s.assignment for s in timed.solutions] == [s.assignment for s in free.solutions]
    assert timed.stats.nodes == free.stats.nodes
    cut = localize(lm, scene.bearings, sigma=0.2 * DEG, timeout_s=1e-6)
    assert not cut.complete and cut.stats.nodes < free.stats.nodes


def test_no_solution_is_falsy() -> None:
    lm = symmetric_map("square")
    res = localize(lm, np.deg2rad([0.0, 5.0, 10.0, 180.0]))
    assert not res and res.best is None and len(res) == 0
    # Nothing found decides nothing: "not ambiguous" always has a best to read.
    assert res.ambiguous


def test_unknown_detection_rate_with_a_range_counts_landmarks_left_unseen() -> None:
    # As test_visibility_prunes_and_negative_evidence_ranks, but without p_miss: with a
    # range, the detection rate is integrated out and the poses that would see the far
    # landmark without reporting it fall behind (not to zero: the rate might be low).
    L = np.array([[0, 0], [6, 0], [6, 6], [0, 6], [3, -8]], float)
    truth = Pose(1.5, 4.5, 0.3)
    z = predict_bearings(L[:4], truth)
    res = localize(L, z, sigma=0.1 * DEG, max_range=11.0)
    assert sorted(s.missed for s in res.solutions) == [0, 0, 1, 1]
    assert res.ambiguous and _has_pose(res, truth)
    top2 = res.solutions[:2]
    assert all(s.missed == 0 for s in top2)
    # Four matched: B(5, 1) / B(5, 2) = (1/5) / (1/30) = 6, a fifth landmark in plain view
    # left unseen costs a factor 6.
    assert res.solutions[2].confidence == pytest.approx(top2[0].confidence / 6.0, rel=1e-6)
    # Without a range there is no plainly visible set: nothing is counted.
    assert all(s.missed == 0 for s in localize(L, z, sigma=0.1 * DEG).solutions)


def test_convincing_needs_the_decisive_odds_per_place() -> None:
    from omniloc.search.options import make_options
    from omniloc.search.scoring import convincing

    opt = make_options(
        5, method=Method.ROBUST, sensor=None, budget=None, max_spurious=0, ordering=False,
        legacy={},
    )  # fmt: skip
    # decisive 0.95: odds 19 per place.
    assert convincing(0.999, 0.999 / 19 / 100 / 1.01, 100, opt)
    assert not convincing(0.999, 0.999 / 19 / 100 * 1.1, 100, opt)
    assert convincing(0.5, 0.0, 10**6, opt)


def test_a_weak_fit_after_a_large_search_is_not_decisive() -> None:
    # Three exact bearings always fit some pose: alone against the null it may hold most of
    # the posterior, but a chance fit somewhere on a map of 400 landmarks is as likely.
    lm = random_map(400, density=0.05, rng=3)
    truth = random_pose(lm, rng=4)
    sc = observe(lm, truth, max_range=10.0, n_obs=3, rng=5)
    res = localize(lm, sc.bearings, sigma=0.5 * DEG, max_range=10.0, exhaustive=True)
    assert res.ambiguous
    # The same search with many bearings is decisive.
    sc = observe(lm, truth, max_range=10.0, rng=5)
    assert sc.bearings.size >= 8
    res = localize(lm, sc.bearings, sigma=0.5 * DEG, max_range=10.0, exhaustive=True)
    assert not res.ambiguous and res.best.pose.distance_to(truth)[0] < 0.1


def test_paper_method_refuses_robust_options() -> None:
    lm = demo_room()
    z = predict_bearings(lm.xy[:4], Pose(5, 3, 0))
    for kw in ({"sigma": 0.01}, {"max_spurious": 1}, {"ordering": True}, {"fov": 1.0}):
        with pytest.raises(InputError, match="method='paper'"):
            localize(lm, z, method=Method.PAPER, **kw)


@pytest.mark.parametrize(
    ("landmarks", "bearings", "kw", "match"),
    [
        (np.zeros((2, 2)), [0.1, 0.2, 0.3], {}, "at least 3 landmarks"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, np.nan, 0.3], {}, "not finite|non-finite"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2], {}, "at least 3"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3, 0.4], {}, "only 3 landmarks"),
        ([[0, 0], [1, 0], [0, 1]], [[0.1, 0.2, 0.3]], {}, "shape"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"threshold": -1.0}, "threshold"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"method": "magic"}, "method"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"sigma": 0.0}, "sigma"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"confidence": 1.0}, "confidence"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"max_spurious": -1}, "max_spurious"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"max_spurious": 1.5}, "max_spurious"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"max_range": np.nan}, "max_range"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"min_range": 5, "max_range": 2}, "min_range"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"fov": 7.0}, "fov"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"p_miss": 1.0}, "p_miss"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"max_nodes": 0}, "max_nodes"),
        ([[0, 0], [1, 0], [0, 1]], [0.1, 0.2, 0.3], {"timeout_s": -1}, "timeout_s"),
    ],
)
def test_bad_input_gets_a_clear_error(landmarks, bearings, kw, match) -> None:
    with pytest.raises(InputError, match=match):
        localize(landmarks, bearings, **kw)


def _walk(lm: object, bearings: np.ndarray, method: str, compiled: bool) -> object:
    """A search by the compiled paper walk or by the readable tree, from the same options."""
    from omniloc.maps import as_landmark_map
    from omniloc.search import Method
    from omniloc.search.options import Leaves, make_options
    from omniloc.search.scoring import finish
    from omniloc.search.tree import TreeSearch, robust_order, run_paper_kernel

    lmap = as_landmark_map(lm)
    meth = Method(method)
    opt = make_options(
        len(bearings), method=meth, sensor=None, budget=None, max_spurious=0, ordering=False,
        legacy={},
    )  # fmt: skip
    order = robust_order(bearings) if meth is Method.ROBUST else np.arange(len(bearings))
    leaves = Leaves(len(bearings), order)
    if compiled:
        run_paper_kernel(lmap, bearings[order], opt, leaves)
    else:
        TreeSearch(lmap, bearings[order], opt, leaves).run()
    return leaves.counts, finish(lmap, bearings, leaves, opt).solutions


@pytest.mark.parametrize("seed", range(6))
def test_compiled_walk_equals_batched_search(seed: int) -> None:
    """The numba walk of the paper's rules and the readable batched tree (its oracle) visit
    the same nodes and find the same solutions."""
    rng = np.random.default_rng(400 + seed)
    lm = demo_room() if seed % 2 else random_map(16, rng=rng)
    pose = random_pose(lm, rng=rng)
    scene = observe(lm, pose, n_obs=int(rng.integers(3, 8)), sigma=0.3 * DEG, rng=rng)
    for method in ("paper", "robust"):
        (c_fast, fast), (c_ref, ref) = (
            _walk(lm, scene.bearings, method, flag) for flag in (True, False)
        )
        for key in ("nodes", "examined", "triples", "existence", "gate"):
            assert getattr(c_fast, key) == getattr(c_ref, key)
        assert sorted(s.assignment for s in fast) == sorted(s.assignment for s in ref)
        for s in fast:
            t = next(t for t in ref if t.assignment == s.assignment)
            assert np.allclose(s.pose.as_array(), t.pose.as_array(), atol=1e-9)
    # localize itself takes the compiled walk for the paper's rules.
    res = localize(lm, scene.bearings, method="paper")
    assert res.stats.nodes == _walk(lm, scene.bearings, "paper", True)[0].nodes


def test_large_map_without_range_or_budget_warns(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    import omniloc.search as search_module

    monkeypatch.setattr(search_module, "LARGE_MAP", 40)
    lm = random_map(50, size=40.0, rng=0)
    z = predict_bearings(lm.xy[:4], Pose(20.0, 20.0, 0.0))
    with caplog.at_level("WARNING", logger="omniloc.search"):
        localize(lm, z, max_nodes=10)
        localize(lm.xy[:30], z)
    assert not caplog.records  # a budget, or a small map: nothing to warn about
    with caplog.at_level("WARNING", logger="omniloc.search"):
        localize(lm, z)
    assert any("max_range" in r.getMessage() for r in caplog.records)


def test_too_many_complete_paths_are_capped(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    import omniloc.search.tree as tree_module

    monkeypatch.setattr(tree_module, "MAX_COMPILED_LEAVES", 100)
    lm = random_map(20, rng=0)
    z = np.deg2rad([0.0, 120.0, 240.0])  # three bearings: thousands of consistent triples
    with caplog.at_level("WARNING", logger="omniloc.search"):
        res = localize(lm, z, method="paper")
    assert not res.complete
    assert len(res) <= 100
    assert any("kept the first 100" in r.getMessage() for r in caplog.records)


# A real MRCLAM frame (robot 2, frames line 1931): six tubes seen through a 65 degree lens, a
# pose that is poorly fixed along the robot's forward axis.
NARROW_L = np.array([[0.59, -4.28], [0.68, -4.45], [3.05, -2.54], [3.12, -2.29], [2.86, -2.39]])
NARROW_L = np.vstack([NARROW_L, [[0.86, -4.47]]])
NARROW_B = np.deg2rad([-19.65, -18.51, 21.94, 24.81, 20.8, -16.33])


def test_gauss_newton_reaches_the_least_squares_pose_when_poorly_fixed() -> None:
    """A full Gauss-Newton step overshoots along the valley here; without backtracking the
    search kept a pose 0.42 m from the least-squares one (it stopped at the first failed
    step), so the solution with the true pairs was not reported where it belongs."""
    from scipy.optimize import least_squares

    from omniloc._kernels.geometry import gauss_newton

    def residuals(p: np.ndarray) -> np.ndarray:
        pred = np.arctan2(NARROW_L[:, 1] - p[1], NARROW_L[:, 0] - p[0]) - p[2]
        return np.angle(np.exp(1j * (pred - NARROW_B)))

    # The least-squares pose by an independent solver (scipy's trust region).
    best = least_squares(residuals, [0.5, 0.5, -1.2], xtol=1e-14, ftol=1e-14).x
    start = np.array(
        [[0.2002, 0.2398, -1.1444], [0.9, 0.3, -1.3], best + np.array([0.0, 0.0, 0.01])]
    )
    K = len(start)
    poses, sse = gauss_newton(
        np.repeat(NARROW_L[None], K, 0), np.repeat(NARROW_B[None], K, 0), np.ones((K, 6)),
        start, 10,
    )  # fmt: skip
    assert np.allclose(poses, best, atol=1e-5)
    assert np.allclose(sse, sse.min(), rtol=1e-6)


@pytest.mark.parametrize(
    ("method", "strategy"), [("paper", "tree"), ("robust", "tree"), ("robust", "auto")]
)
def test_no_solution_stands_on_one_of_its_landmarks(method: str, strategy: str) -> None:
    """On a grid, a pose exactly on a matched landmark passed the gate by accident (the
    bearing of a landmark at the robot is atan2(0, 0) = 0) and came back with an infinite
    covariance."""
    grid = np.array([[i % 6, i // 6] for i in range(36)], dtype=float)
    res = localize(grid, np.deg2rad([0.0, 90.0, 180.0]), method=method, strategy=strategy)
    assert len(res) > 100
    for s in res.solutions:
        rows = [a for a in s.assignment if a is not None]
        gaps = np.hypot(*(grid[rows] - s.pose.xy).T)
        assert gaps.min() > 1e-6
        assert np.isfinite(s.covariance).all()


@pytest.mark.parametrize("strategy", ["hypotheses", "tree"])
def test_a_time_budget_stops_a_large_map_without_a_range(strategy: str) -> None:
    """Without a range every landmark triple is a hypothesis and every landmark is near
    each: the kernel once counted only solved triples and verification nodes against a time
    budget, and ran for minutes on 0.3 s (the candidates and the landmarks a node scans
    count now). Not a speed test: the bound only says that it stops."""
    lm = random_map(5000, density=0.01, min_separation=1.0, rng=1)
    scene = observe(lm, random_pose(lm, rng=2), max_range=20.0, sigma=0.3 * DEG, rng=3)
    t0 = time.perf_counter()
    res = localize(
        lm, scene.bearings[:9], sigma=0.3 * DEG, max_spurious=2, timeout_s=0.3, strategy=strategy
    )
    assert time.perf_counter() - t0 < 60.0
    assert not res.complete


def test_a_timeout_spent_before_the_search_starts_is_incomplete(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """On a big map the neighbour lists can take the whole timeout: no chunk runs, and the
    answer is an empty, incomplete result (it was a crash on an empty list of chunks)."""
    from omniloc.search import hypotheses

    monkeypatch.setattr(hypotheses, "CHUNK_ANCHORS", 16)
    monkeypatch.setattr(hypotheses, "_work_left", lambda out, opt: -1)
    lm = random_map(200, density=0.01, min_separation=1.0, rng=1)
    scene = observe(lm, random_pose(lm, rng=2), max_range=20.0, sigma=0.3 * DEG, rng=3)
    res = localize(
        lm, scene.bearings, sigma=0.3 * DEG, max_range=20.0, timeout_s=1.0, exhaustive=False
    )
    assert not res and not res.complete


def test_the_engines_counts_of_missed_landmarks_match_the_scorings(monkeypatch) -> None:
    # The hypotheses kernel counts the plainly visible landmarks each path leaves unseen and
    # the scoring reuses them (aligned through its filters); counting again from the refined
    # poses gives the same answers.
    from omniloc.search import options

    for seed in range(4):
        lm = random_map(30, size=40.0, rng=seed)
        truth = random_pose(lm, rng=seed + 10)
        sc = observe(lm, truth, max_range=12.0, n_spurious=2, sigma=0.5 * DEG, rng=seed)
        if sc.bearings.size < 6:
            continue
        kw = {"sigma": 0.5 * DEG, "max_spurious": 2, "max_range": 12.0, "p_miss": 0.05}
        engine = localize(lm, sc.bearings, strategy="hypotheses", **kw)
        monkeypatch.setattr(options.Leaves, "missed_counts", lambda self: None)
        again = localize(lm, sc.bearings, strategy="hypotheses", **kw)
        monkeypatch.undo()

        # Poses that hold a share of the posterior agree; in the far tail a pose the pairs
        # barely fix can move a landmark across the edge of the range when refined.
        def top(res):
            return [(s.assignment, s.missed) for s in res.solutions if s.confidence >= 1e-3]

        assert top(engine) == top(again) and engine.ambiguous == again.ambiguous


def test_the_cap_on_complete_paths_keeps_the_truth_on_a_large_map(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Benchmark scene (c), trial 189: four true bearings on a map of 10,000 landmarks. An
    # exhaustive search finds tens of thousands of chance fits of four bearings; the cap
    # (MAX_LEAVES) must keep the paths with the most evidence, volume term included: chance
    # fits fit tightly but fix their pose poorly, and ranked by fit alone they crowded the
    # true interpretation out of the solutions.
    import sys
    from pathlib import Path

    import omniloc.search as search_package
    from omniloc.search.scoring import MAX_LEAVES, finish

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from scenes import CASES, DEFAULT_KWARGS, build_map, make_trial

    lm = build_map("c")
    _, scene = make_trial(CASES["c-default"], 189, lm)
    true = [i for i, a in enumerate(scene.assignment) if a is not None]
    assert len(true) == 4
    leaves_seen: list[int] = []

    def counting_finish(lm_, b_, leaves, opt):  # type: ignore[no-untyped-def]
        leaves_seen.append(len(leaves.arrays()[0]))
        return finish(lm_, b_, leaves, opt)

    monkeypatch.setattr(search_package, "finish", counting_finish)
    kwargs = {**DEFAULT_KWARGS, "max_spurious": 0, "exhaustive": True}
    res = localize(lm, scene.bearings[true], **kwargs)
    assert leaves_seen and leaves_seen[-1] > MAX_LEAVES  # the cap did cut
    near = [s for s in res.solutions if s.pose.distance_to(scene.pose)[0] < 0.3]
    # (Two of its landmarks lie 0.8 deg apart on one ray: the swapped pairing is the same
    # pose, merged with it.)
    assert near and set(near[0].assignment) == {scene.assignment[i] for i in true}
