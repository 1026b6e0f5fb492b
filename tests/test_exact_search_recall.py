"""The exact multi-frame search of benchmarks/exact_search_recall.py (an experiment) finds the
pose from bearings that no single frame could fix."""

from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from exact_search_recall import exact_frames_search
from omniloc.track.motion import compose


def test_pose_from_bearings_of_three_frames_joined_by_odometry() -> None:
    rng = np.random.default_rng(4)
    L = rng.uniform(-6.0, 6.0, (12, 2))
    current = np.array([0.4, -0.3, 0.7])
    # Poses of the earlier frames in the current robot frame (the robot drove and turned).
    rel = np.array([[-1.2, 0.3, -0.4], [-0.6, 0.1, -0.2], [0.0, 0.0, 0.0]])
    seen = [[0], [3, 5], [7, 9]]  # at most two landmarks per frame
    z, tx, ty, ph, truth = [], [], [], [], []
    for k, lms in enumerate(seen):
        pose = compose(current, rel[k])
        for j in lms:
            d = L[j] - pose[:2]
            z.append(math.atan2(d[1], d[0]) - pose[2])
            tx.append(rel[k, 0])
            ty.append(rel[k, 1])
            ph.append(rel[k, 2])
            truth.append(j)
    z_ = np.angle(np.exp(1j * np.array(z)))
    seeds = np.array(list(itertools.combinations(range(len(z)), 3)), dtype=np.int64)
    poses, assign = exact_frames_search(
        L, z_, np.array(tx), np.array(ty), np.array(ph), seeds,
        math.radians(0.5), 100.0, 0.0, math.pi, len(z), 1000,
    )  # fmt: skip
    assert len(poses) > 0
    err = np.hypot(*(poses[:, :2] - current[:2]).T)
    dth = np.abs(np.angle(np.exp(1j * (poses[:, 2] - current[2]))))
    hit = (err < 1e-6) & (dth < 1e-6)
    assert hit.any()
    assert (assign[hit] == np.array(truth)).all(axis=1).any()
    # Every interpretation returned explains all five bearings within the gate: a wrong sign
    # in the frames' offsets would leave none at the true pose.
    assert (assign >= 0).all()
