"""Odometry given as a pose track (ROS's ``nav_msgs/Odometry``, a TUM file from evo):
``Odometry.from_poses``, ``load_odometry`` on ``t,x,y,theta`` CSV and TUM files,
``Tracker.odometry_poses`` online, ``omniloc track --odometry ODOM.tum``; and a ground truth
read from a TUM file."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc import Pose, predict_bearings
from omniloc.cli import main
from omniloc.errors import InputError
from omniloc.track import (
    Frame,
    MotionModel,
    Odometry,
    Tracker,
    TrackEstimate,
    load_groundtruth,
    load_odometry,
    track,
)
from omniloc.track.motion import between, compose, integrate
from omniloc.track.simulate import Example, example_run

MODEL = MotionModel()


def _poses_of(odo: Odometry, start: tuple[float, float, float]) -> np.ndarray:
    """The poses that velocity odometry reaches at its own row times, from ``start``."""
    out = [np.asarray(start, dtype=float)]
    for k in range(len(odo) - 1):
        d, _ = integrate([odo.t[k + 1] - odo.t[k]], [odo.v[k]], [odo.w[k]], MODEL)
        out.append(compose(out[-1], d))
    return np.array(out)


def _tum_lines(t: np.ndarray, poses: np.ndarray, tilt: float = 0.0) -> str:
    """A TUM file of ``poses`` (heading about z, then leaning by ``tilt`` about x)."""
    lines = ["# timestamp tx ty tz qx qy qz qw"]
    for ti, (x, y, th) in zip(t, poses, strict=True):
        # q = q_yaw * q_roll: the robot turned by th, then leaned by tilt about its x axis.
        cz, sz, cr, sr = math.cos(th / 2), math.sin(th / 2), math.cos(tilt / 2), math.sin(tilt / 2)
        qw, qx, qy, qz = cz * cr, cz * sr, sz * sr, sz * cr
        lines.append(f"{ti:.9f} {x:.12f} {y:.12f} 0 {qx:.12f} {qy:.12f} {qz:.12f} {qw:.12f}")
    return "\n".join(lines) + "\n"


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(0.01, 1.0),
            st.floats(-2.0, 2.0, allow_nan=False),
            st.floats(-3.0, 3.0, allow_nan=False),
        ),
        min_size=1,
        max_size=12,
    ),
    st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-3.1, 3.1)),
)
def test_poses_of_velocity_odometry_give_it_back(
    pieces: list[tuple[float, float, float]], start: tuple[float, float, float]
) -> None:
    # Constant-velocity arcs (under a half turn each) sampled at their ends: the velocities
    # come back, and after the last pose the robot stands.
    t = np.concatenate([[0.0], np.cumsum([p[0] for p in pieces])])
    v = np.array([p[1] for p in pieces] + [0.0])
    w = np.array([p[2] for p in pieces] + [0.0])
    odo = Odometry(t, v, w)
    poses = _poses_of(odo, start)
    back = Odometry.from_poses(t, poses[:, 0], poses[:, 1], poses[:, 2])
    assert np.array_equal(back.t, odo.t)
    assert np.allclose(back.v, v, atol=1e-9, rtol=1e-9)
    assert np.allclose(back.w, w, atol=1e-9, rtol=1e-9)


def test_a_pose_track_is_tracked_like_the_velocities_it_came_from() -> None:
    ex = example_run()
    odo = ex.run.odometry
    poses = _poses_of(odo, (3.0, -1.0, 2.0))  # (the odometry frame's origin is arbitrary)
    from_poses = Odometry.from_poses(odo.t, poses[:, 0], poses[:, 1], poses[:, 2])
    a = track(ex.landmarks, odo, ex.run.frames, sensor=ex.sensor, motion=ex.motion).estimates
    b = track(ex.landmarks, from_poses, ex.run.frames, sensor=ex.sensor, motion=ex.motion)
    # The same velocities but the last row's (a pose track says nothing after its end),
    # to rounding.
    assert np.allclose(from_poses.v[:-1], odo.v[:-1], atol=1e-9)
    assert np.allclose(from_poses.w[:-1], odo.w[:-1], atol=1e-9)
    assert [e.state for e in a] == [e.state for e in b.estimates]
    localized = [(ea, eb) for ea, eb in zip(a, b.estimates, strict=True) if ea.localized]
    assert len(localized) > 50
    for ea, eb in localized:
        # (Ambiguous frames may list places of equal weight in another order.)
        assert ea.pose is not None and eb.pose is not None
        assert ea.pose.distance_to(eb.pose)[0] < 1e-6


def test_single_pose_and_repeated_rows_stand_still() -> None:
    one = Odometry.from_poses([5.0], [1.0], [2.0], [0.3])
    assert one.t.tolist() == [5.0] and one.v.tolist() == [0.0] and one.w.tolist() == [0.0]
    rep = Odometry.from_poses([0, 1, 1, 2], [0, 1, 1, 2], [0, 0, 0, 0], [0, 0, 0, 0])
    assert rep.t.tolist() == [0.0, 1.0, 2.0] and np.allclose(rep.v, [1.0, 1.0, 0.0])


def test_a_turn_near_a_half_turn_between_two_poses_is_warned_of(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with caplog.at_level(logging.WARNING, logger="omniloc.track.data"):
        Odometry.from_poses([0, 1, 2], [0, 0, 0], [0, 0, 0], [0.0, 2.8, 2.9])
    assert "rows 0 and 1 (t=0.0 and 1.0) are 160 deg apart" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="omniloc.track.data"):
        Odometry.from_poses([0, 1, 2], [0, 0, 0], [0, 0, 0], [0.0, 2.3, 2.9])
    assert caplog.text == ""


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([0, 1], [0, 1], [0, 0], [0]), "one value per row"),
        (([], [], [], []), "no rows"),
        (([0, 1], [0, float("nan")], [0, 0], [0, 0]), r"x\[1\] is not finite"),
        (([1, 0], [0, 1], [0, 0], [0, 0]), "time order|decrease|increase"),
        (([0, 0], [0, 1], [0, 0], [0, 0]), "cannot move in no time"),
    ],
)
def test_bad_pose_tracks_are_refused_by_name(args: tuple, match: str) -> None:
    with pytest.raises(InputError, match=match):
        Odometry.from_poses(*args)


def test_sideways_motion_is_kept_and_written_back(tmp_path: Path) -> None:
    from omniloc.track import write_odometry

    t = np.arange(0.0, 10.5, 0.5)
    crab = Odometry.from_poses(t, np.zeros_like(t), 0.2 * t, np.zeros_like(t))
    assert crab.vy is not None
    assert np.allclose(crab.v, 0.0) and np.allclose(crab.w, 0.0)
    assert np.allclose(crab.vy[:-1], 0.2) and crab.vy[-1] == 0.0
    path = tmp_path / "crab.csv"
    write_odometry(path, crab)
    assert path.read_text().splitlines()[0] == "t,v,w,vy"
    back = load_odometry(path)
    assert back.vy is not None and np.array_equal(back.vy, crab.vy)
    with pytest.raises(InputError, match="t, v, w and vy must have one value per row"):
        Odometry([0.0, 1.0], [0.0, 0.0], [0.0, 0.0], [0.0])


def test_a_sensor_frame_off_the_centre_is_tracked_offline_as_online() -> None:
    # The poses of a frame 0.3 m ahead of the robot's centre: it moves sideways whenever
    # the robot turns. Offline (Odometry.from_poses, vy kept) and online (odometry_poses)
    # carry the hypotheses alike; with the sideways part dropped they would part by
    # centimetres.
    ex = example_run()
    odo = ex.run.odometry
    centre = _poses_of(odo, (3.0, -1.0, 2.0))
    ahead = compose(centre, np.array([0.3, 0.0, 0.0]))
    from_poses = Odometry.from_poses(odo.t, ahead[:, 0], ahead[:, 1], ahead[:, 2])
    assert from_poses.vy is not None and np.abs(from_poses.vy).max() > 0.05
    # The bearings as the sensor 0.3 m ahead sees them (the same noise; clutter unmoved).
    L = ex.landmarks.xy
    frames = []
    for f in ex.run.frames:
        true_c, _ = ex.run.truth.at(f.t)
        true_s = compose(true_c[0], np.array([0.3, 0.0, 0.0]))
        b = f.bearings.copy()
        for i, row in enumerate(f.truth or ()):
            if row is not None:
                b[i] += (
                    predict_bearings(L[[row]], true_s)[0] - predict_bearings(L[[row]], true_c[0])[0]
                )
        frames.append(Frame(f.t, b))
    sensor_ex = replace(ex, run=replace(ex.run, frames=frames))
    offline = track(ex.landmarks, from_poses, frames, sensor=ex.sensor, motion=ex.motion).estimates
    online = _online(
        sensor_ex,
        lambda tr, a, b: tr.odometry_poses(odo.t[a:b], ahead[a:b, 0], ahead[a:b, 1], ahead[a:b, 2]),
    )
    both = [(a, b) for a, b in zip(online, offline, strict=True) if a.localized and b.localized]
    assert len(both) > 50
    assert max(a.pose.distance_to(b.pose)[0] for a, b in both) < 2e-3  # type: ignore[union-attr]
    # ... and the sensor's pose is the one localized: right against the truth moved ahead.
    for e in (e for e in offline if e.localized):
        true_c, _ = ex.run.truth.at(e.t)
        assert e.pose is not None
        true_s = Pose(*compose(true_c[0], np.array([0.3, 0.0, 0.0])))
        assert e.pose.distance_to(true_s)[0] < 0.1


def test_fit_motion_says_it_leaves_the_sideways_part_out(
    caplog: pytest.LogCaptureFixture,
) -> None:
    from omniloc.track import GroundTruth, estimate_motion

    ex = example_run()
    odo, truth = ex.run.odometry, ex.run.truth
    centre = _poses_of(odo, (0.0, 0.0, 0.0))
    ahead = compose(centre, np.array([0.3, 0.0, 0.0]))
    with caplog.at_level(logging.WARNING, logger="omniloc.track.calibrate"):
        estimate_motion(Odometry.from_poses(odo.t, centre[:, 0], centre[:, 1], centre[:, 2]), truth)
    assert "sideways" not in caplog.text
    moved = compose(np.c_[truth.x, truth.y, truth.theta], np.array([0.3, 0.0, 0.0]))
    truth_ahead = GroundTruth(truth.t, moved[:, 0], moved[:, 1], moved[:, 2])
    with caplog.at_level(logging.WARNING, logger="omniloc.track.calibrate"):
        estimate_motion(
            Odometry.from_poses(odo.t, ahead[:, 0], ahead[:, 1], ahead[:, 2]), truth_ahead
        )
    assert "run 1: the odometry moves sideways by" in caplog.text


def _example_pose_files(tmp_path: Path, tilt: float = 0.0) -> tuple[Odometry, Path, Path]:
    odo = example_run().run.odometry
    poses = _poses_of(odo, (0.0, 0.0, 0.0))
    csv = tmp_path / "odom_poses.csv"
    csv.write_text(
        "t,x,y,theta\n"
        + "".join(
            f"{float(t)!r},{float(x)!r},{float(y)!r},{float(th)!r}\n"
            for t, (x, y, th) in zip(odo.t, poses, strict=True)
        )
    )
    tum = tmp_path / "odom.tum"
    tum.write_text(_tum_lines(odo.t, poses, tilt))
    return odo, csv, tum


def test_pose_files_read_as_the_velocities(tmp_path: Path) -> None:
    odo, csv, tum = _example_pose_files(tmp_path, tilt=math.radians(3.0))
    for path in (csv, tum):
        got = load_odometry(path)
        assert np.allclose(got.t, odo.t, atol=1e-8)
        # (all but the last row: after the last pose the robot stands)
        assert np.allclose(got.v[:-1], odo.v[:-1], atol=1e-6)
        assert np.allclose(got.w[:-1], odo.w[:-1], atol=1e-6)
        assert got.v[-1] == got.w[-1] == 0.0


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("t,a,b\n0,1,2\n", r"t,v,w \(velocities\) or t,x,y,theta"),
        ("t,x,y,theta\n0,0,0,0\n1,1,0,0\n1,2,0,0\n", r":4: a pose at the time of the line before"),
        ("t,x,y,theta\n0,0,0,0\n1,1,0,0\n0.5,2,0,0\n", ":4"),
        ("t,x,y,theta\n", "no odometry rows"),
        ("0 0 0 0 0 0 0 1\n1 1 0 0 nan 0 0 1\n", ":2: a value that is not a finite number"),
        ("0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 0\n", ":2: the quaternion has length 0"),
    ],
)
def test_bad_odometry_files_name_the_problem(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "odom.txt"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        load_odometry(path)


def test_a_tum_file_that_leans_is_not_a_planar_robot(tmp_path: Path) -> None:
    _, _, tum = _example_pose_files(tmp_path, tilt=math.radians(20.0))
    with pytest.raises(InputError, match=r"odom.tum:2: the pose leans 20.0 deg"):
        load_odometry(tum)


def test_omniloc_track_takes_a_tum_odometry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    examples = Path(__file__).resolve().parent.parent / "examples" / "grid-run"
    _, _, tum = _example_pose_files(tmp_path)
    common = [
        "-q",
        "track",
        "--map",
        str(examples / "landmarks.csv"),
        "--frames",
        str(examples / "frames.csv"),
        "--config",
        str(examples / "settings.json"),
        "--json",
    ]
    assert main([*common, "--odometry", str(examples / "odometry.csv")]) == 0
    velocity = [line for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
    assert main([*common, "--odometry", str(tum)]) == 0
    poses = [line for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
    assert len(poses) == len(velocity) > 100
    states = [line.split('"state": ')[1].split(",")[0] for line in velocity]
    assert states == [line.split('"state": ')[1].split(",")[0] for line in poses]


def _online(ex: Example, feed: Callable[[Tracker, int, int], None]) -> list[TrackEstimate]:
    """The example's frames through a tracker fed odometry by ``feed(tracker, k0, k1)``
    (rows ``k0:k1``) before each frame."""
    tr = Tracker(ex.landmarks, ex.sensor, ex.motion)
    odo = ex.run.odometry
    k, out = 0, []
    for f in ex.run.frames:
        k1 = int(np.searchsorted(odo.t, f.t, side="right"))
        if k1 > k:
            feed(tr, k, k1)
            k = k1
        out.append(tr.frame(f.t, f.bearings))
    return out


def test_online_poses_are_the_increments_between_them() -> None:
    ex = example_run()
    odo = ex.run.odometry
    poses = _poses_of(odo, (3.0, -1.0, 2.0))
    inc = np.vstack([np.zeros((1, 3)), between(poses[:-1], poses[1:])])
    by_poses = _online(
        ex,
        lambda tr, a, b: tr.odometry_poses(odo.t[a:b], poses[a:b, 0], poses[a:b, 1], poses[a:b, 2]),
    )
    by_increments = _online(
        ex, lambda tr, a, b: tr.increments(odo.t[a:b], inc[a:b, 0], inc[a:b, 1], inc[a:b, 2])
    )
    assert [e.as_dict() for e in by_poses] == [e.as_dict() for e in by_increments]


def test_online_poses_track_as_the_recording_does() -> None:
    # A node that reads /odom poses, fed pose by pose before each frame, against the
    # offline run over Odometry.from_poses. Online, a frame between two poses is reached
    # with the last interval's motion (the next is not known yet); offline, with the
    # interval it lies in: 1 frame of 240 decides otherwise, the poses agree to a millimetre.
    ex = example_run()
    odo = ex.run.odometry
    poses = _poses_of(odo, (3.0, -1.0, 2.0))
    offline = track(
        ex.landmarks,
        Odometry.from_poses(odo.t, poses[:, 0], poses[:, 1], poses[:, 2]),
        ex.run.frames,
        sensor=ex.sensor,
        motion=ex.motion,
    ).estimates
    online = _online(
        ex,
        lambda tr, a, b: tr.odometry_poses(odo.t[a:b], poses[a:b, 0], poses[a:b, 1], poses[a:b, 2]),
    )
    same = sum(a.state == b.state for a, b in zip(online, offline, strict=True))
    assert same >= 0.99 * len(offline)
    both = [(a, b) for a, b in zip(online, offline, strict=True) if a.localized and b.localized]
    assert len(both) > 50
    for a, b in both:
        assert a.pose is not None and b.pose is not None
        assert a.pose.distance_to(b.pose)[0] < 1e-3


def test_online_poses_refused_change_nothing() -> None:
    ex = example_run()
    tr = Tracker(ex.landmarks, ex.sensor, ex.motion)
    with pytest.raises(InputError, match=r"odometry poses x\[1\] is not finite"):
        tr.odometry_poses([0.0, 1.0], [0.0, float("nan")], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputError, match="pose row 1 moves the robot in zero time"):
        tr.odometry_poses([0.0, 0.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0])
    # A refused first increment does not tie the tracker to increments either.
    with pytest.raises(InputError, match="first increment starts the clock"):
        tr.increments([0.0], [1.0], [0.0], [0.0])
    tr.odometry_poses([0.0], [5.0], [5.0], [0.0])  # the first pose: anywhere
    tr.odometry_poses([1.0, 2.0], [5.0, 5.0], [5.5, 6.0], [0.0, 0.0])  # sideways, kept
    assert tr._rows[-1][:, 2].tolist() == [0.5, 0.5]  # (t, vx, vy, w): 0.5 m/s sideways
    with pytest.raises(InputError, match="takes poses; it cannot also take velocities"):
        tr.odometry([3.0], [0.1], [0.0])
    with pytest.raises(InputError, match="out of time order"):
        tr.odometry_poses([1.5], [5.0], [6.0], [0.0])
    tr.odometry_poses([3.0], [5.0], [6.0], [math.pi / 2])  # from the pose at t = 2
    assert tr._rows[-1][:, 3].tolist() == pytest.approx([math.pi / 2])


@pytest.mark.parametrize("method", ["increments", "odometry_poses"])
def test_rows_of_different_lengths_are_named(method: str) -> None:
    # (np.stack's own error came through for increments until 2026-12-05.)
    tr = Tracker(example_run().landmarks)
    with pytest.raises(InputError, match="one value per row: got 2, 2, 3, 2"):
        getattr(tr, method)([0.0, 1.0], [0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0])


def test_a_tum_ground_truth_reads_as_the_csv(tmp_path: Path) -> None:
    # examples/grid-run/groundtruth.tum is `omniloc track --truth-out`'s: the true poses at
    # the frames' times, which the CSV track gives by interpolation.
    examples = Path(__file__).resolve().parent.parent / "examples" / "grid-run"
    tum = load_groundtruth(examples / "groundtruth.tum")
    csv = load_groundtruth(examples / "groundtruth.csv")
    poses, _ = csv.at(tum.t)
    assert tum.t.size == 240
    assert np.abs(poses[:, :2] - np.c_[tum.x, tum.y]).max() < 1e-6  # (the file's 6 decimals)
    assert np.abs(np.angle(np.exp(1j * (poses[:, 2] - tum.theta)))).max() < 1e-8
    leaning = tmp_path / "gt.tum"
    leaning.write_text(_tum_lines(np.array([0.0, 1.0]), np.zeros((2, 3)), math.radians(30.0)))
    with pytest.raises(InputError, match=r"leans 30\.0 deg.*ground truth was read as a TUM file"):
        load_groundtruth(leaning)
    same_time = tmp_path / "gt2.tum"
    same_time.write_text("0 0 0 0 0 0 0 1\n0 1 0 0 0 0 0 1\n")
    with pytest.raises(InputError, match="increase"):
        load_groundtruth(same_time)


def test_frames_and_odometry_of_two_clocks_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A bag's stamps (seconds since 1970) against frames stamped from 0: no frame lies within
    # the odometry's time, which the tracker would take for a robot standing still, lost.
    ex = example_run()
    odo = ex.run.odometry
    late = Odometry(odo.t + 1.7e9, odo.v, odo.w)
    with pytest.raises(InputError, match=r"frames \(t = 0.125 to 59.875 s\) and the odometry "):
        track(ex.landmarks, late, ex.run.frames, sensor=ex.sensor, motion=ex.motion)
    early = Odometry(odo.t - 100.0, odo.v, odo.w)
    with pytest.raises(InputError, match="share no time: are they stamped by one clock"):
        track(ex.landmarks, early, ex.run.frames, sensor=ex.sensor, motion=ex.motion)
    # Odometry that starts after the first frames, or ends before the last, is not refused.
    part = Odometry(odo.t[100:-100], odo.v[100:-100], odo.w[100:-100])
    run = track(ex.landmarks, part, ex.run.frames, sensor=ex.sensor, motion=ex.motion)
    assert len(run.estimates) == len(ex.run.frames)
    examples = Path(__file__).resolve().parent.parent / "examples" / "grid-run"
    shifted = tmp_path / "odometry.csv"
    shifted.write_text(
        "t,v,w\n"
        + "".join(
            f"{float(t) + 1.7e9!r},{float(v)!r},{float(w)!r}\n"
            for t, v, w in zip(odo.t, odo.v, odo.w, strict=True)
        )
    )
    args = ["track", "--map", str(examples / "landmarks.csv"), "--odometry", str(shifted)]
    assert main([*args, "--frames", str(examples / "frames.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "odometry (t = 1700000000 to 1700000060 s)" in err


def test_times_that_are_not_seconds_are_warned_of(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from omniloc.track import load_frames

    examples = Path(__file__).resolve().parent.parent / "examples" / "grid-run"
    files = {
        "odometry.csv": "t,v,w\n{t0},0.1,0\n{t1},0.1,0\n",
        "poses.csv": "t,x,y,theta\n{t0},0,0,0\n{t1},0.1,0,0\n",
        "odom.tum": "{t0} 0 0 0 0 0 0 1\n{t1} 0.1 0 0 0 0 0 1\n",
        "gt.csv": "t,x,y,theta\n{t0},0,0,0\n{t1},0.1,0,0\n",
        "frames.csv": "t,bearing\n{t0},0.1\n{t0},0.3\n{t0},0.4\n{t1},0.2\n",
    }
    readers = {
        "odometry.csv": load_odometry,
        "poses.csv": load_odometry,
        "odom.tum": load_odometry,
        "gt.csv": load_groundtruth,
        "frames.csv": load_frames,
    }
    for stamps, warned in (
        ((1.7e18, 1.7e18 + 2e7), True),  # a ROS stamp in nanoseconds
        ((0.0, 2e4), True),  # microseconds from the start, 50 Hz
        ((1.7e9, 1.7e9 + 0.02), False),  # seconds since 1970
    ):
        for name, text in files.items():
            path = tmp_path / name
            path.write_text(text.format(t0=repr(stamps[0]), t1=repr(stamps[1])))
            caplog.clear()
            with caplog.at_level(logging.WARNING, logger="omniloc.track.data"):
                readers[name](path)
            assert ("are they in nanoseconds" in caplog.text) is warned, (name, stamps)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="omniloc.track.data"):
        load_odometry(examples / "odometry.csv")
        load_frames(examples / "frames.csv")
        load_groundtruth(examples / "groundtruth.csv")
    assert "nanoseconds" not in caplog.text
