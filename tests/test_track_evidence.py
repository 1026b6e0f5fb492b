"""The diagnosis of benchmarks/track_evidence.py: its split of a frame's evidence adds up to
the tracker's own frame likelihood, and its replays prefer the place the bearings came from."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from omniloc.sensor import SensorModel
from omniloc.track.likelihood import FrameModel, log_ratios
from omniloc.track.motion import compose
from track_evidence import replay, split_frame

SENSOR = SensorModel(
    sigma=math.radians(1.0),
    fov=math.radians(90.0),
    max_range=7.0,
    min_range=0.5,
    p_detect=0.4,
    clutter=0.5,
)


def _bearings(pose: np.ndarray, L: np.ndarray) -> np.ndarray:
    d = L - pose[:2]
    return np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - pose[2])))


def test_split_adds_up_to_the_trackers_frame_likelihood() -> None:
    # Landmarks well inside or outside the field of view (the tracker's edge is soft over a
    # few sigma, the split's is hard), one nearer than min_range, one beyond max_range.
    L = np.array([[3.0, 0.5], [2.0, -1.0], [4.0, 1.5], [-3.0, 0.0], [0.3, 0.1], [9.0, 0.0]])
    pose = np.zeros(3)
    off = np.array([0.004, -0.01])
    b = np.concatenate([_bearings(pose, L[[0, 2]]) + off, [0.6]])
    is_landmark = np.array([True, True, False])
    s = split_frame(pose, b, is_landmark, L, SENSOR)
    want = log_ratios(pose[None, :], b, L, FrameModel.of(SENSOR))[0]
    assert s.missed + s.landmarks + s.clutter == pytest.approx(want, abs=1e-9)
    # three landmarks in view (0, 1, 2): the near one and the far one cannot be seen
    assert s.missed == pytest.approx(3 * math.log(1 - SENSOR.p_detect))
    assert s.landmarks > 2.0 and 0.0 <= s.clutter < 0.1


def test_replay_prefers_the_place_the_bearings_were_taken_from() -> None:
    rng = np.random.default_rng(1)
    L = rng.uniform(-5.0, 5.0, (15, 2))
    pose = np.array([0.2, -0.4, 0.3])
    step = np.array([0.1, 0.0, 0.05])
    frames = []
    for k in range(20):
        if k:
            pose = compose(pose, step)
        z = _bearings(pose, L) + rng.normal(0.0, SENSOR.sigma, L.shape[0])
        seen = np.abs(z) < SENSOR.fov / 2
        frames.append((z[seen], step, np.diag([1e-4, 1e-4, 1e-5])))
    start = np.array([0.2, -0.4, 0.3])
    model = FrameModel.of(SENSOR)
    true_lr, means = replay(start, frames, L, model)
    wrong_lr, _ = replay(start + np.array([0.8, 0.5, 0.4]), frames, L, model)
    assert true_lr > wrong_lr + 20.0
    assert np.hypot(*(means[-1][:2] - pose[:2])) < 0.1


def test_an_empty_frame_only_pays_for_the_landmarks_in_view() -> None:
    L = np.array([[3.0, 0.5], [-3.0, 0.0]])
    s = split_frame(np.zeros(3), np.zeros(0), [], L, SENSOR)
    assert (s.landmarks, s.clutter) == (0.0, 0.0)
    assert s.missed == pytest.approx(math.log(1 - SENSOR.p_detect))
