"""A pose from two landmarks seen from a moving sensor (``pair_candidates``, the tracker's
``pair_search``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from omniloc import LandmarkMap, SensorModel
from omniloc.angles import wrap
from omniloc.errors import InputError
from omniloc.track import TrackerConfig, preset, track, with_settings
from omniloc.track.motion import between
from omniloc.track.relocalize import pair_candidates, search_window
from omniloc.track.simulate import lookalike_run
from omniloc.track.window import WindowFrame

SENSOR = SensorModel(sigma=math.radians(0.5), max_range=5.0, p_detect=0.9, clutter=0.3)


def _frames(path: np.ndarray, L: np.ndarray, seen: list[int]) -> list[WindowFrame]:
    """Noise-free frames along ``path`` (k, 3) of the landmarks ``seen``, the odometry the
    true poses (from the first)."""
    out = []
    for p in path:
        d = L[seen] - p[:2]
        b = np.asarray(wrap(np.arctan2(d[:, 1], d[:, 0]) - p[2]))
        odom = between(path[0], p)
        out.append(WindowFrame(0.0, b, odom, np.zeros(3), np.zeros((3, 3))))
    return out


def _straight(start: np.ndarray, speed: float, turn: float, n: int = 7) -> np.ndarray:
    """Poses every 0.25 s from ``start`` at ``speed`` (m/s), turning at ``turn`` (rad/s)."""
    out = [start.astype(float)]
    for _ in range(n - 1):
        x, y, t = out[-1]
        out.append(
            np.array(
                [x + 0.25 * speed * math.cos(t), y + 0.25 * speed * math.sin(t), t + 0.25 * turn]
            )
        )
    return np.array(out)


@settings(max_examples=25, deadline=None)
@given(
    near=st.floats(0.6, 2.0),
    far=st.floats(3.0, 4.5),
    side=st.floats(0.6, 2.4),
    heading=st.floats(-math.pi, math.pi),
    turn=st.floats(-0.3, 0.3),
)
# (Found by this test: the sensor between the two landmarks at the last frame, their
# bearings 179.1 and 179.96 degrees apart -- a family on a circle too large for a whole
# turn's steps, and one the kernel skipped as in line. The search seeds from the newest
# frame whose bearings are not nearly in line now: here the first, 161 degrees apart.)
@example(near=2.0, far=3.0, side=1.40625, heading=0.0, turn=0.0)
@example(
    near=1.727628064683195,
    far=3.4007873767518912,
    side=1.40625,
    heading=2.0387814393209416,
    turn=0.14756902810579353,
)
def test_two_landmarks_seen_while_moving_give_the_pose(
    near: float, far: float, side: float, heading: float, turn: float
) -> None:
    # Two landmarks, one near and one far, seen for 1.5 s of travel at 0.25 m/s: the
    # window search has no third landmark; the pair search finds the last pose.
    start = np.array([0.0, 0.0, heading])
    a = np.array([near * math.cos(heading + side), near * math.sin(heading + side)])
    b = np.array([far * math.cos(heading - side), far * math.sin(heading - side)])
    others = np.array([[20.0, 20.0], [-20.0, 15.0], [15.0, -20.0]])
    L = np.vstack([a, b, others])
    path = _straight(start, 0.25, turn)
    frames = _frames(path, L, [0, 1])
    got = pair_candidates(LandmarkMap(L), frames, SENSOR, min_hits=4, cov_inflation=1.0)
    truth = path[-1]
    err = np.hypot(*(got.poses[:, :2] - truth[:2]).T) if len(got) else np.array([np.inf])
    dh = np.abs(np.asarray(wrap(got.poses[:, 2] - truth[2]))) if len(got) else np.array([np.inf])
    best = int(np.argmin(err))
    assert err[best] < 0.01 and dh[best] < math.radians(0.1)
    assert np.all(np.linalg.eigvalsh(got.covs[best]) > 0)


def test_the_window_search_cannot_propose_two_landmarks_and_the_pair_search_can() -> None:
    L = np.array([[1.0, 1.0], [4.0, -1.0], [20.0, 20.0], [-20.0, 15.0], [15.0, -20.0]])
    path = _straight(np.array([0.0, 0.0, 0.0]), 0.25, 0.1)
    frames = _frames(path, L, [0, 1])
    lm = LandmarkMap(L)
    stacked = search_window(
        lm,
        frames,
        SENSOR,
        near_range_m=2.0,
        min_bearings=4,
        max_bearings=12,
        max_spurious=2,
        max_nodes=100_000,
        timeout_s=5.0,
        cov_inflation=1.0,
    )
    truth = path[-1]

    def nearest(poses: np.ndarray) -> float:
        return float(np.min(np.hypot(*(poses[:, :2] - truth[:2]).T))) if len(poses) else math.inf

    assert nearest(stacked.poses) > 0.3
    pairs = pair_candidates(lm, frames, SENSOR, min_hits=4, cov_inflation=1.0)
    assert nearest(pairs.poses) < 0.01


def test_a_sensor_standing_still_fixes_nothing() -> None:
    # The same two bearings frame after frame: every pose of the family explains them
    # alike, and none is proposed.
    L = np.array([[1.0, 1.0], [4.0, -1.0], [20.0, 20.0]])
    path = np.repeat(np.array([[0.0, 0.0, 0.3]]), 7, axis=0)
    frames = _frames(path, L, [0, 1])
    assert len(pair_candidates(LandmarkMap(L), frames, SENSOR, min_hits=4, cov_inflation=1.0)) == 0


def test_no_frame_with_two_bearings_or_too_few_hits_asked_proposes_nothing() -> None:
    L = np.array([[1.0, 1.0], [4.0, -1.0], [20.0, 20.0]])
    path = _straight(np.array([0.0, 0.0, 0.0]), 0.25, 0.0)
    one_each = _frames(path, L, [0])
    assert (
        len(pair_candidates(LandmarkMap(L), one_each, SENSOR, min_hits=4, cov_inflation=1.0)) == 0
    )
    with pytest.raises(InputError, match="min_hits must be at least 3"):
        pair_candidates(LandmarkMap(L), one_each, SENSOR, min_hits=2, cov_inflation=1.0)


def test_the_tracker_with_pair_search_is_right_where_a_look_alike_took_the_mass() -> None:
    # Look-alikes' run 3: the robot sees two landmarks for its first 8 s; without the pair
    # search the true place is never proposed (and until the entries from a search's own
    # frames, 2026-12-08, a place 13 m off was localized at 7.6-10.1 s).
    ex = lookalike_run(3)
    run = ex.run
    config = preset("generic")[2]

    def wrong_and_right(cfg: TrackerConfig) -> tuple[int, int]:
        res = track(
            ex.landmarks,
            run.odometry,
            run.frames[:44],
            sensor=ex.sensor,
            motion=ex.motion,
            config=cfg,
        )
        wrong = right = 0
        for e in res.estimates:
            if e.state.value != "localized":
                continue
            p = run.truth.at(np.array([e.t]))[0][0]
            ok = math.hypot(e.pose.x - p[0], e.pose.y - p[1]) <= 0.3 and abs(
                float(wrap(e.pose.theta - p[2]))
            ) <= math.radians(5)
            wrong += not ok
            right += ok
        return wrong, right

    assert wrong_and_right(config) == (0, 0)
    wrong, right = wrong_and_right(
        with_settings(ex.sensor, ex.motion, config, {"pair_search": True})[2]
    )
    assert wrong == 0 and right >= 20


def test_pair_search_is_a_switch() -> None:
    assert TrackerConfig().pair_search is False
    with pytest.raises(InputError, match="pair_search"):
        with_settings(SENSOR, preset("generic")[1], TrackerConfig(), {"pair_search": 1})


def test_a_pair_search_on_a_large_map_is_refused_with_the_reason() -> None:
    from omniloc.track import Tracker
    from omniloc.track.relocalize import PAIR_MAX_LANDMARKS

    rng = np.random.default_rng(1)
    big = LandmarkMap(rng.uniform(0, 100, (PAIR_MAX_LANDMARKS + 1, 2)))
    sensor, motion, config = preset("generic")
    with pytest.raises(InputError, match="pair_search on a map of 101 landmarks"):
        Tracker(
            big, sensor, motion, with_settings(sensor, motion, config, {"pair_search": True})[2]
        )
    Tracker(big, sensor, motion, config)  # without it, any map
    frames = _frames(_straight(np.zeros(3), 0.25, 0.0), big.xy, [0, 1])
    with pytest.raises(InputError, match="at most 100"):
        pair_candidates(big, frames, SENSOR, min_hits=4, cov_inflation=1.0)


def test_a_clutter_bearing_first_in_the_seed_frame_does_not_spoil_every_seed() -> None:
    # The newest frame holds a clutter bearing, the two landmarks, and another clutter
    # bearing: the seeds must not all pair the first one (they did, until 2026-12-08).
    L = np.array([[1.0, 1.0], [4.0, -1.0], [20.0, 20.0], [-20.0, 15.0], [15.0, -20.0]])
    path = _straight(np.array([0.0, 0.0, 0.0]), 0.25, 0.1)
    frames = _frames(path, L, [0, 1])
    last = frames[-1]
    b = np.array([-2.5, last.bearings[0], last.bearings[1], 2.9])
    frames[-1] = WindowFrame(last.t, b, last.odom, last.delta, last.Q)
    got = pair_candidates(LandmarkMap(L), frames, SENSOR, min_hits=4, cov_inflation=1.0)
    err = np.hypot(*(got.poses[:, :2] - path[-1][:2]).T) if len(got) else np.array([np.inf])
    assert err.min() < 0.01
