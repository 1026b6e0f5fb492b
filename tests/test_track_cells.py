"""Particles and hypotheses weighed cell by cell on large maps: the same numbers as the scan
of the whole map, bit for bit."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import omniloc.track.likelihood as lk
from omniloc import SensorModel
from omniloc.track.likelihood import (
    FrameModel,
    Objects,
    frame_update_clutter,
    log_ratios_clutter,
)


def _model(max_range: float, fov_deg: float | None) -> FrameModel:
    sensor = SensorModel(
        sigma=math.radians(1.0),
        fov=None if fov_deg is None else math.radians(fov_deg),
        max_range=max_range,
        min_range=0.1 * max_range,
        p_detect=0.35,
        clutter=0.41,
    )
    m = FrameModel.of(sensor, p_detect=0.35, clutter=0.41)
    return replace(m, fresh=0.25, object_var=math.radians(0.6) ** 2)


def _scene(
    seed: int, n: int, spread: float, H: int, k: int, K: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Objects | None]:
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.0, spread, (n, 2))
    # Poses over the map and beyond its edges (some far outside).
    xy = rng.uniform(-0.5 * spread, 1.5 * spread, (H, 2))
    poses = np.column_stack([xy, rng.uniform(-math.pi, math.pi, H)])
    # Bearings within a narrow camera's view (the landmarks seen there are weighed).
    bearings = rng.uniform(-0.6, 0.6, k)
    objects = Objects(rng.uniform(-0.6, 0.6, K), rng.uniform(0.0, 0.75, (H, K))) if K else None
    return L, poses, bearings, objects


@contextmanager
def _cells(min_landmarks: int, call_pairs: int) -> Iterator[None]:
    """The grouping's thresholds set for a test (restored after)."""
    saved = lk.CELL_MIN_LANDMARKS, lk.CELL_CALL_PAIRS
    lk.CELL_MIN_LANDMARKS, lk.CELL_CALL_PAIRS = min_landmarks, call_pairs
    try:
        yield
    finally:
        lk.CELL_MIN_LANDMARKS, lk.CELL_CALL_PAIRS = saved


def _covariances(rng: np.random.Generator, H: int, scale: float) -> np.ndarray:
    A = rng.normal(scale=scale, size=(H, 3, 3))
    return A @ np.swapaxes(A, 1, 2) + 1e-6 * np.eye(3)


@settings(max_examples=40, deadline=None)  # (the first example compiles the kernel)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(20, 1500),
    cells=st.floats(4.0, 40.0),
    max_range=st.floats(0.5, 20.0),
    H=st.integers(1, 700),
    k=st.integers(0, 3),
    K=st.integers(0, 2),
    fov=st.sampled_from([None, 67.0, 200.0]),
    spread=st.sampled_from([None, 0.01, 0.3, 3.0]),
)
def test_weighing_cell_by_cell_is_the_whole_scan_bit_for_bit_and_misses_no_landmark(
    seed: int,
    n: int,
    cells: float,
    max_range: float,
    H: int,
    k: int,
    K: int,
    fov: float | None,
    spread: float | None,
) -> None:
    # (A map `cells` ranges across; the grouping is forced whenever it looks at fewer
    # pairs, so that every example takes it. `spread` None: exactly known poses
    # (particles); else hypotheses with covariances of that scale, which the bearings move
    # -- from 3 on often farther than the cells' margin, and weighed again.)
    L, poses, bearings, objects = _scene(seed, n, cells * max_range, H, k, K)
    model = _model(max_range, fov)
    margin = 0.0 if spread is None else lk.CELL_REACH_SHARE * max_range
    if spread is None:
        with _cells(1, 0):
            groups = lk._cell_groups(poses, L, max_range)
            got = log_ratios_clutter(poses, bearings, L, model, objects)
        with _cells(2**62, 0):
            want = log_ratios_clutter(poses, bearings, L, model, objects)
    else:
        P = _covariances(np.random.default_rng(seed + 1), H, spread)
        with _cells(1, 0):
            groups = lk._cell_groups(poses, L, max_range, margin)
            got = frame_update_clutter(poses, P, bearings, L, model, objects)
        with _cells(2**62, 0):
            want = frame_update_clutter(poses, P, bearings, L, model, objects)
    if cells > 8.0:  # (on a smaller map the 3 x 3 cells may hold every landmark)
        assert groups is not None
    if groups is not None:
        # Each pose is in one group, handed every landmark within its range and the
        # margin, in the map's order.
        seen = np.zeros(H, dtype=int)
        for idx, lm in groups:
            assert np.all(np.diff(lm) > 0)
            seen[idx] += 1
            d2 = ((L[None, :, :] - poses[idx, None, :2]) ** 2).sum(axis=2)
            near = d2 <= (max_range + margin) ** 2
            assert not (near & ~np.isin(np.arange(n), lm)[None, :]).any()
        assert np.all(seen == 1)
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape
        assert np.array_equal(g, w, equal_nan=True)


def test_a_large_map_is_weighed_by_cells_and_a_small_one_is_not() -> None:
    L, poses, _, _ = _scene(1, 10_000, 100.0, 3000, 0, 0)
    groups = lk._cell_groups(poses, L, 7.0)
    assert groups is not None
    # Each pose looks at a few hundred landmarks instead of ten thousand.
    assert max(lm.size for _, lm in groups) < 1000
    assert lk._cell_groups(poses, L[:255], 7.0) is None  # a small map: scanned whole
    assert lk._cell_groups(poses, L, math.inf) is None  # no range
    assert lk._cell_groups(poses[:0], L, 7.0) is None  # no pose
    # Spread so thin that a range's cells would number in the millions: scanned whole.
    far = L.copy()
    far[0] = (1e9, 1e9)
    assert lk._cell_groups(poses, far, 7.0) is None
    # A pose that is not a number: the whole scan, whatever it makes of it.
    bad = poses.copy()
    bad[5, 0] = np.nan
    assert lk._cell_groups(bad, L, 7.0) is None
    # A range as wide as the map: one cell's work is the whole scan plus a call, not kept.
    assert lk._cell_groups(poses, L, 500.0) is None


def test_the_cells_of_a_changed_map_are_made_again() -> None:
    L, poses, bearings, _ = _scene(2, 2000, 100.0, 1000, 2, 0)
    model = _model(7.0, 67.0)
    L2 = L.copy()
    L2[:, 0] += 3.0  # the same shape, other positions
    with _cells(1, 0):
        first = log_ratios_clutter(poses, bearings, L, model, None)
        assert lk._cells_cache is not None and np.array_equal(lk._cells_cache[0], L)
        second = log_ratios_clutter(poses, bearings, L2, model, None)
        assert np.array_equal(lk._cells_cache[0], L2)
    with _cells(2**62, 0):
        want = log_ratios_clutter(poses, bearings, L2, model, None)
    assert np.array_equal(second[0], want[0])
    assert not np.array_equal(first[0], second[0])


def test_the_cells_kept_between_frames_are_bounded() -> None:
    # Ten thousand landmarks over a square of a thousand ranges: each particle in a cell of
    # its own, frame after frame; the lists kept stay bounded.
    L, _, bearings, _ = _scene(3, 10_000, 7_000.0, 1, 2, 0)
    model = _model(7.0, 67.0)
    rng = np.random.default_rng(4)
    saved = lk.CELL_NEAR_KEPT
    lk.CELL_NEAR_KEPT = 500
    try:
        for _ in range(5):
            poses = np.column_stack(
                [rng.uniform(0.0, 7_000.0, (300, 2)), rng.uniform(-math.pi, math.pi, 300)]
            )
            with _cells(1, 0):  # (grouped, whatever a cell's call costs)
                assert lk._cell_groups(poses, L, 7.0) is not None
                got = log_ratios_clutter(poses, bearings, L, model, None)
            assert lk._cells_cache is not None
            assert all(len(c._near) <= 500 for c in lk._cells_cache[1].values())
        with _cells(2**62, 0):
            want = log_ratios_clutter(poses, bearings, L, model, None)
        assert np.array_equal(got[0], want[0])
    finally:
        lk.CELL_NEAR_KEPT = saved


def test_a_tracker_on_a_large_map_reports_the_same_with_and_without_cells() -> None:
    from omniloc import LandmarkMap
    from omniloc.track import Tracker, preset

    rng = np.random.default_rng(5)
    lm = LandmarkMap(rng.uniform(0.0, 60.0, (1500, 2)))
    sensor, motion, config = preset("mrclam")
    config = replace(config, region=None, elsewhere_samples=600, search_max_nodes=2000)
    frames = [(0.25 * (i + 1), rng.uniform(-0.5, 0.5, int(rng.integers(0, 4)))) for i in range(12)]

    def run() -> list[str]:
        tracker = Tracker(lm, sensor, motion, config)
        out = []
        for t, bearings in frames:
            tracker.odometry([t - 0.25], [0.3], [0.2])
            e = tracker.frame(t, bearings)
            out.append(repr((e.state, e.pose, e.reason, e.kidnapped, e.hypotheses)))
        return out

    with _cells(1, 0):  # every frame weighed by cells
        by_cells = run()
    with _cells(2**62, 0):  # every frame scanned whole
        whole = run()
    assert by_cells == whole
