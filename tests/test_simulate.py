"""Synthetic maps, poses and observations (omniloc.simulate)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.distance import pdist

from omniloc.errors import InputError
from omniloc.pose import Pose, predict_bearings
from omniloc.simulate import (
    DEMO_POSE,
    DEMO_VISIBLE,
    demo_room,
    make_map,
    observe,
    paper_experiment,
    random_map,
    random_pose,
    symmetric_map,
    visible_landmarks,
)

DEG = math.pi / 180


def test_random_map_size_separation_and_seed() -> None:
    lm = random_map(30, size=(10.0, 5.0), min_separation=0.8, rng=3)
    assert lm.n == 30
    assert (lm.xy >= 0).all() and (lm.xy[:, 0] <= 10).all() and (lm.xy[:, 1] <= 5).all()
    assert pdist(lm.xy).min() >= 0.8
    assert np.array_equal(lm.xy, random_map(30, size=(10.0, 5.0), min_separation=0.8, rng=3).xy)
    dense = random_map(400, density=0.01, rng=1)
    side = math.sqrt(400 / 0.01)
    assert dense.xy.max() <= side and dense.xy.max() > 0.9 * side


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n": 2}, "n must be an integer >= 3"),
        ({"n": 5.0}, "n must be an integer"),
        ({"n": 10, "size": -1.0}, "size must be positive"),
        ({"n": 10, "size": (1.0, 2.0, 3.0)}, "size must be one side"),
        ({"n": 10, "density": 0.0}, "density must be positive"),
        ({"n": 1000, "size": 5.0, "min_separation": 1.0}, "do not fit"),
    ],
)
def test_random_map_refuses_bad_input(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        random_map(**kwargs)  # type: ignore[arg-type]


def test_symmetric_maps_and_map_kinds() -> None:
    sq = symmetric_map("square", size=6.0)
    assert np.allclose(sorted(map(tuple, sq.xy)), [(0, 0), (0, 6), (6, 0), (6, 6)])
    octo = symmetric_map("octagon", size=4.0)
    assert np.allclose(np.hypot(*octo.xy.T), 2.0)
    assert symmetric_map("grid").n == 12
    with pytest.raises(InputError, match="unknown symmetric map"):
        symmetric_map("pentagon")
    assert make_map("room").n == demo_room().n == 12
    assert make_map("symmetric").n == 12
    assert make_map("random", 17, rng=0).n == 17
    with pytest.raises(InputError, match="map kind"):
        make_map("maze")


def test_random_pose_keeps_its_clearance() -> None:
    lm = random_map(20, rng=5)
    for seed in range(20):
        p = random_pose(lm, clearance=1.0, rng=seed)
        assert np.hypot(*(lm.xy - p.xy).T).min() >= 1.0
        assert -math.pi <= p.theta < math.pi
    with pytest.raises(InputError, match="from every landmark"):
        random_pose(symmetric_map("square", size=1.0), clearance=5.0, rng=0)


def test_visible_landmarks_by_range_and_field_of_view() -> None:
    lm = symmetric_map("octagon", size=4.0)  # 8 landmarks 2 m from the origin, 45 deg apart
    p = Pose(0.0, 0.0, 0.0)
    assert visible_landmarks(lm, p).tolist() == list(range(8))
    assert visible_landmarks(lm, p, max_range=1.9).size == 0
    assert visible_landmarks(lm, p, min_range=2.1).size == 0
    # A 100 degree field of view takes in the landmarks at 0 and +-45 degrees.
    assert visible_landmarks(lm, p, fov=100 * DEG).tolist() == [0, 1, 7]
    far = visible_landmarks(lm, Pose(2.5, 0.0, 0.0), max_range=1.0)
    assert far.tolist() == [0]


def test_observe_noise_free_bearings_are_the_predicted_ones() -> None:
    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, rng=2)
    assert sorted(sc.assignment) == sorted(DEMO_VISIBLE)  # type: ignore[type-var]
    rows = list(sc.assignment)
    assert np.allclose(sc.bearings, predict_bearings(lm.xy[rows], DEMO_POSE))
    assert sc.n_spurious == 0 and sc.pose == DEMO_POSE
    same = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, shuffle=False)
    assert same.assignment == DEMO_VISIBLE


def test_observe_spurious_misses_subset_and_noise() -> None:
    lm = random_map(30, rng=0)
    p = random_pose(lm, rng=0)
    fov = 150 * DEG
    assert visible_landmarks(lm, p, fov=fov).size >= 6
    sc = observe(lm, p, n_obs=6, n_spurious=3, fov=fov, rng=1)
    assert sc.bearings.shape == (9,) and sc.n_spurious == 3
    assert (np.abs(sc.bearings) <= fov / 2).all()  # true and spurious alike
    # Misses thin out the visible landmarks at about the requested rate.
    seen = [observe(lm, p, p_miss=0.5, rng=s).bearings.size for s in range(200)]
    assert abs(np.mean(seen) / lm.n - 0.5) < 0.05
    # Noise: residuals against the truth have the requested spread.
    sig = 0.5 * DEG
    res = []
    for s in range(200):
        sc = observe(lm, p, sigma=sig, rng=s)
        pred = predict_bearings(lm.xy[list(sc.assignment)], p)
        res.append(np.angle(np.exp(1j * (sc.bearings - pred))))
    assert abs(np.std(np.concatenate(res)) / sig - 1.0) < 0.05


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sigma": -1.0}, "sigma must be >= 0"),
        ({"p_miss": 1.0}, "p_miss must lie in"),
        ({"n_obs": 50}, "only 12 landmarks are visible"),
        ({"n_spurious": -1}, "n_spurious must be an integer"),
        ({"visible": [0, 99]}, "visible must list landmark indices"),
    ],
)
def test_observe_refuses_bad_input(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        observe(demo_room(), DEMO_POSE, **kwargs)  # type: ignore[arg-type]


def test_paper_experiment_rows_are_table_1() -> None:
    rows, runs = paper_experiment((4, 5))
    assert [r.n_obs for r in rows] == [4, 5]
    assert [r.total_paths for r in rows] == [12 * 11 * 10 * 9, 12 * 11 * 10 * 9 * 8]
    assert all(r.true_pose_found and 0 < r.examined_paths < r.total_paths for r in rows)
    assert rows[1].solutions == len(runs[5][1].solutions)
    # Each row adds one observation to the previous one, as in the paper.
    assert np.array_equal(runs[5][0].bearings[:4], runs[4][0].bearings)
    with pytest.raises(InputError, match="3 to 7"):
        paper_experiment((8,))
