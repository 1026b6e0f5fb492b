"""The batched search against the plain depth-first reading of the paper, and the baselines.

``localize(..., method="paper")`` claims to visit exactly the nodes the plain recursive reading
(``benchmarks/plain_reading.py``) visits when no budget is set. Here both run on the same
scenes and must agree on the set of solutions (assignments, exactly), on ``nodes`` and
``examined_paths``, and on the poses (the library refines its poses with all pairs at the end,
so its pose is compared with the plain linear pose refined by ``refine_pose``).
"""

from __future__ import annotations

import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from omniloc.pose import Pose, estimate_pose, predict_bearings, refine_pose
from omniloc.search import localize
from omniloc.simulate import (
    DEMO_POSE,
    DEMO_VISIBLE,
    Scene,
    demo_room,
    observe,
    random_map,
    random_pose,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from baselines import brute_force, ransac, triple_poses
from plain_reading import plain_localize

THRESHOLD = float(np.deg2rad(1.0))
POSE_TOL = 1e-6


@cache
def _random15() -> tuple[np.ndarray, list[Scene]]:
    """A random 15-landmark map (20 m square) and six 5-bearing scenes on it."""
    gen = np.random.default_rng(5)
    lm = random_map(15, rng=gen)
    scenes = []
    for k in range(6):
        pose = random_pose(lm, rng=gen)
        scenes.append(observe(lm, pose, n_obs=5, sigma=np.deg2rad(0.1 * (k % 2)), rng=gen))
    return lm.xy, scenes


def _scene(name: str) -> tuple[np.ndarray, Scene]:
    kind, *rest = name.split("-")
    if kind == "demo":
        m, sigma_deg = int(rest[0]), float(rest[1])
        scene = observe(
            demo_room(),
            DEMO_POSE,
            visible=DEMO_VISIBLE,
            n_obs=m,
            sigma=np.deg2rad(sigma_deg),
            rng=100 * m + int(10 * sigma_deg),
        )
        return demo_room().xy, scene
    xy, scenes = _random15()
    return xy, scenes[int(rest[0])]


@cache
def _both(name: str) -> tuple[tuple[list, dict], object]:
    xy, scene = _scene(name)
    plain = plain_localize(xy, scene.bearings, THRESHOLD)
    lib = localize(xy, scene.bearings, threshold=THRESHOLD, method="paper")
    return plain, lib


DEMO = [f"demo-{m}-{s}" for m in (4, 5, 6, 7) for s in ("0.0", "0.2")]
RANDOM = [f"random15-{k}" for k in range(6)]


@pytest.mark.parametrize("name", DEMO + RANDOM)
def test_same_nodes_as_plain_reading(name: str) -> None:
    (_, st), res = _both(name)
    assert res.stats.complete
    assert res.stats.nodes == st["nodes"]
    assert res.stats.examined_paths == st["examined_paths"]
    assert res.stats.total_paths == st["total_paths"]


@pytest.mark.parametrize("name", DEMO + RANDOM)
def test_same_solutions_as_plain_reading(name: str) -> None:
    """Same assignments exactly; poses within 1e-6 after the same refinement.

    random15-2 holds a depth-4 re-estimate with a distance ratio r_1 < 0: both readings must
    then keep the depth-3 pose (``estimate_pose`` rejects the re-estimate).
    """
    xy, scene = _scene(name)
    (sols, _), res = _both(name)
    plain = dict(sols)
    lib = {s.assignment: s for s in res.solutions}
    assert sorted(lib) == sorted(plain)
    for a, p_lin in plain.items():
        ref, _ = refine_pose(xy[list(a)], scene.bearings, initial=p_lin)
        got = lib[a].pose
        assert abs(got.x - ref.x) <= POSE_TOL
        assert abs(got.y - ref.y) <= POSE_TOL
        assert abs(got.distance_to(ref)[1]) <= POSE_TOL


@pytest.mark.parametrize("m", [4, 5, 6, 7])
def test_noise_free_demo_finds_truth_with_linear_pose(m: int) -> None:
    (sols, _), _ = _both(f"demo-{m}-0.0")
    _, scene = _scene(f"demo-{m}-0.0")
    truth = [p for a, p in sols if a == scene.assignment]
    assert len(truth) == 1
    d, dth = truth[0].distance_to(DEMO_POSE)
    assert d < 1e-9 and dth < 1e-9


def test_triple_poses_match_estimate_pose() -> None:
    gen = np.random.default_rng(1)
    L = gen.uniform(0, 10, size=(200, 3, 2))
    pose = Pose(4.0, 5.0, 0.3)
    b = np.stack([predict_bearings(t, pose) for t in L]) + gen.normal(0, 0.01, (200, 3))
    got, ok = triple_poses(L, b)
    n_ok = 0
    for k in range(200):
        try:
            ref = estimate_pose(L[k], b[k])
        except ValueError:
            assert not ok[k]
            continue
        assert ok[k]
        n_ok += 1
        np.testing.assert_allclose(got[k, :2], ref.xy, atol=1e-9)
        assert abs(Pose.from_array(got[k]).distance_to(ref)[1]) < 1e-9
    assert n_ok > 100


def test_brute_force_agrees_with_tree_on_noise_free_demo() -> None:
    xy, scene = _scene("demo-5-0.0")
    sols, st = brute_force(xy, scene.bearings, THRESHOLD)
    assert st["checked_paths"] == st["total_paths"] == 95040
    assert scene.assignment in [a for a, _ in sols]


def test_ransac_finds_demo_pose() -> None:
    xy, scene = _scene("demo-7-0.2")
    out = ransac(xy, scene.bearings, gate=np.deg2rad(1.0), max_iter=20000, rng=3)
    assert out.pose is not None
    d, dth = out.pose.distance_to(DEMO_POSE)
    assert d < 0.1 and dth < np.deg2rad(1.0)
