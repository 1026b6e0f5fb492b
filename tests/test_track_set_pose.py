"""A pose told to the tracker (``Tracker.set_pose``, ``track(initial_pose=...)``,
``omniloc track --initial-pose``): taken at its word when told as surely as ``localized``
asks, a prior otherwise, and never reported right while the bearings disagree."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from omniloc import Pose
from omniloc.cli import main
from omniloc.errors import InputError
from omniloc.track import Tracker, TrackerConfig, track
from omniloc.track.simulate import EXAMPLE_MAP, EXAMPLE_MOTION, EXAMPLE_SENSOR, simulate_run

TIGHT = np.diag([0.03**2, 0.03**2, math.radians(1.0) ** 2])
WIDE = np.diag([0.5**2, 0.5**2, math.radians(15.0) ** 2])


def _run(seed: int, sensor=EXAMPLE_SENSOR):
    return simulate_run(EXAMPLE_MAP, sensor, Pose(6.0, 4.0, 0.3), duration_s=40.0, rng=seed)


def _scored(run, **kw):
    """(time from the first frame to the first correct localized state, localized frames,
    wrong ones) of the tracker on ``run``."""
    sensor = kw.pop("sensor", EXAMPLE_SENSOR)
    m = track(EXAMPLE_MAP, run.odometry, run.frames, sensor=sensor, motion=EXAMPLE_MOTION, **kw)
    first, n, wrong = None, 0, 0
    for e in m.estimates:
        if not e.localized:
            continue
        tp = run.truth.pose_at(e.t)
        ok = math.hypot(e.pose.x - tp.x, e.pose.y - tp.y) <= 0.3 and abs(
            math.remainder(e.pose.theta - tp.theta, 2 * math.pi)
        ) <= math.radians(5.0)
        n += 1
        wrong += not ok
        if ok and first is None:
            first = e.t - run.frames[0].t
    return first, n, wrong, m.estimates


@pytest.mark.parametrize("seed", [3, 4])
def test_a_pose_told_surely_is_tracked_from_the_first_frame(seed: int) -> None:
    run = _run(seed)
    start = run.truth.pose_at(run.frames[0].t)
    first, n, wrong, est = _scored(run, initial_pose=start, initial_covariance=TIGHT)
    assert first == 0.0 and wrong == 0 and n == len(est)
    # Untold, the grid's symmetries hold the tracker back for seconds (seed 3) or the
    # whole run (seed 4).
    untold, n0, wrong0, _ = _scored(run)
    assert wrong0 == 0 and n0 < n and (untold is None or untold > 10.0)


def test_a_loose_pose_told_is_a_prior_that_must_be_confirmed() -> None:
    run = _run(3)
    start = run.truth.pose_at(run.frames[0].t)
    first, _, wrong, est = _scored(run, initial_pose=start, initial_covariance=WIDE)
    assert wrong == 0
    # Not localized until the searches confirm the place and it is min_age_s (3 s) old...
    min_age = TrackerConfig().min_age_s
    assert not any(e.localized for e in est if e.t - run.frames[0].t < min_age)
    assert "search" in est[0].reason
    # ... but sooner than without it.
    untold = _scored(run)[0]
    assert first is not None and untold is not None and first < untold


@pytest.mark.parametrize(
    ("offset", "cov"),
    [((1.0, 0.0, 0.0), TIGHT), ((0.0, 0.0, 20.0), TIGHT), ((1.5, 0.0, 0.0), WIDE)],
)
@pytest.mark.parametrize("seed", [3, 5])
def test_a_wrong_pose_told_is_not_reported_right(
    seed: int, offset: tuple[float, float, float], cov: np.ndarray
) -> None:
    run = _run(seed)
    start = run.truth.pose_at(run.frames[0].t).as_array()
    told = start + np.array([offset[0], offset[1], math.radians(offset[2])])
    first, _, wrong, est = _scored(run, initial_pose=told, initial_covariance=cov)
    assert wrong == 0 and not est[0].localized
    # The bearings disagree at once: the tracker behaves as if told nothing.
    assert first == _scored(run)[0]


def test_a_wrong_pose_told_mid_run_is_not_localized_on_bearings_it_does_not_explain() -> None:
    # The example recording, told surely at frame 80 a pose 0.6 m off: two of that frame's
    # three bearings miss its predictions by 6 and 29 deg. It was localized there (the
    # default fit_explained is 0); a pose told must explain half the bearings (TOLD_FIT).
    from omniloc.track.simulate import example_run

    ex = example_run()
    run, odo = ex.run, ex.run.odometry
    tr = Tracker(ex.landmarks, ex.sensor, ex.motion)
    k = 0
    for i, f in enumerate(run.frames[:81]):
        k1 = int(np.searchsorted(odo.t, f.t, side="right"))
        if k1 > k:
            tr.odometry(odo.t[k:k1], odo.v[k:k1], odo.w[k:k1])
            k = k1
        if i == 80:
            p = run.truth.pose_at(run.frames[79].t)
            tr.set_pose(
                (p.x, p.y + 0.6, p.theta), np.diag([0.05**2, 0.05**2, math.radians(1.5) ** 2])
            )
        e = tr.frame(f.t, f.bearings)
    assert not e.localized


def test_the_pose_told_is_the_robot_s_when_the_sensor_has_a_mount() -> None:
    mount = (0.3, 0.1, 0.5)
    sensor = EXAMPLE_SENSOR.replace(mount=mount)
    run = _run(3, sensor)
    start = run.truth.pose_at(run.frames[0].t)
    first, n, wrong, est = _scored(run, sensor=sensor, initial_pose=start, initial_covariance=TIGHT)
    assert first == 0.0 and wrong == 0 and n == len(est)
    assert math.hypot(est[0].pose.x - start.x, est[0].pose.y - start.y) < 0.05


def test_a_pose_told_between_frames_holds_at_the_last_frame() -> None:
    # The robot stands still seeing the room: told after three frames, localized at once.
    import omniloc

    room = omniloc.demo_room()
    truth = Pose(5.6, 2.1, math.radians(30.0))
    z = omniloc.predict_bearings(room.xy, truth)
    tracker = Tracker(room, omniloc.SensorModel(sigma=math.radians(0.3)), EXAMPLE_MOTION)
    for k in range(3):
        tracker.odometry([0.25 * k], [0.0], [0.0])
        tracker.frame(0.25 * k, z[:2])  # two bearings: not enough to localize
    tracker.set_pose(truth, TIGHT)
    assert tracker.n_hypotheses == 1
    # The masses elsewhere held under the belief replaced are not what a search's candidates
    # enter with: the history of the frames before starts afresh.
    assert len(tracker._history) == 0
    tracker.odometry([0.75], [0.0], [0.0])
    est = tracker.frame(0.75, z)
    assert est.localized and math.hypot(est.pose.x - 5.6, est.pose.y - 2.1) < 0.01


@pytest.mark.parametrize(
    ("pose", "cov", "kw", "match"),
    [
        ((1.0, 2.0), TIGHT, {}, r"pose must have shape \(3,\)"),
        ([[1.0, 2.0, 0.0]] * 2, TIGHT, {}, r"pose must be one pose"),
        ((np.nan, 2.0, 0.0), TIGHT, {}, r"pose must be finite"),
        ((100.0, 2.0, 0.0), TIGHT, {}, r"outside the tracker's region"),
        ((1.0, 2.0, 0.0), np.eye(2), {}, r"covariance must have shape \(3, 3\)"),
        ((1.0, 2.0, 0.0), np.full((3, 3), np.inf), {}, r"covariance must be finite"),
        (
            (1.0, 2.0, 0.0),
            np.triu(np.ones((3, 3))),
            {},
            r"covariance must be a 3 x 3 covariance: symmetric",
        ),
        ((1.0, 2.0, 0.0), -TIGHT, {}, r"positive definite"),
        ((1.0, 2.0, 0.0), np.diag([1.0, 1.0, 100.0]), {}, r"heading sd at most pi"),
        ((1.0, 2.0, 0.0), "abc", {}, r"covariance must be a numeric array"),
        ((1.0, 2.0, 0.0), TIGHT, {"mass": 1.0}, r"mass must lie in \(0, 1\)"),
        ((1.0, 2.0, 0.0), TIGHT, {"mass": float("nan")}, r"mass"),
    ],
)
def test_set_pose_refuses_what_is_not_a_pose_and_changes_nothing(
    pose: object, cov: object, kw: dict, match: str
) -> None:
    tracker = Tracker(EXAMPLE_MAP, EXAMPLE_SENSOR, EXAMPLE_MOTION)
    before = tracker.n_hypotheses, tracker._elsewhere.poses.copy()
    with pytest.raises(InputError, match=match):
        tracker.set_pose(pose, cov, **kw)  # type: ignore[arg-type]
    assert tracker.n_hypotheses == before[0]
    np.testing.assert_array_equal(tracker._elsewhere.poses, before[1])


def test_track_needs_the_pose_and_its_covariance_together() -> None:
    run = _run(3)
    with pytest.raises(InputError, match="initial_pose and initial_covariance go together"):
        track(EXAMPLE_MAP, run.odometry, run.frames, initial_pose=(6.0, 4.0, 0.3))


def test_omniloc_track_takes_an_initial_pose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from test_mount import _files  # (the example's recording as the files track reads)

    run = _run(4)
    paths = _files(tmp_path, run)
    argv = ["-q", "track", "--map", str(paths["map"]), "--odometry", str(paths["odometry"])]
    argv += ["--frames", str(paths["frames"]), "--groundtruth", str(paths["truth"])]
    argv += ["--sigma", str(math.degrees(EXAMPLE_SENSOR.sigma)), "--max-range", "5"]
    start = run.truth.pose_at(run.frames[0].t)
    told = f"{start.x},{start.y},{math.degrees(start.theta)}"
    assert main([*argv, "--initial-pose", told, "--initial-sd", "0.03,1"]) == 0
    out = capsys.readouterr().out
    assert "(0.0 s after the first frame)" in out and "100.0 % of localized frames" in out
    # The default spread is AMCL's (0.5 m, 15 deg): a prior, confirmed by the searches.
    assert main([*argv, "--initial-pose", told]) == 0
    assert "(0.0 s after the first frame)" not in capsys.readouterr().out
    assert main([*argv, "--initial-sd", "0.03,1"]) == 1
    assert "give the pose too" in capsys.readouterr().err
    assert main([*argv, "--initial-pose", "1,2"]) == 1
    assert "X,Y,THETA" in capsys.readouterr().err


def test_a_negative_initial_pose_or_mount_is_read_as_a_value(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # (argparse took "-1,2,30" for an option: "expected one argument".)
    grid = Path(__file__).resolve().parent.parent / "examples" / "grid-run"
    argv = ["-q", "track", "--map", str(grid / "landmarks.csv"), "--json"]
    argv += ["--odometry", str(grid / "odometry.csv"), "--frames", str(grid / "frames.csv")]
    argv += ["--config", str(grid / "settings.json")]
    assert main([*argv, "--initial-pose=-1,2,30", "--mount=-0.1,0,-5"]) == 0
    joined = capsys.readouterr().out
    assert main([*argv, "--initial-pose", "-1,2,30", "--mount", "-0.1,0,-5"]) == 0
    out = capsys.readouterr()
    assert out.err == "" and out.out == joined and joined.count("\n") == 240
    # A negative spread is still refused, now for what it is.
    assert main([*argv, "--initial-pose", "-1,2,30", "--initial-sd", "-0.5,15"]) == 1
    assert "--initial-sd" in capsys.readouterr().err
    from omniloc.cli import _join_negative_values

    assert _join_negative_values(["--mount", "-.5,0,0", "--initial-pose", "--json"]) == [
        "--mount=-.5,0,0",
        "--initial-pose",
        "--json",
    ]
    assert _join_negative_values(["--", "--mount", "-1,0,0"]) == ["--", "--mount", "-1,0,0"]


def test_a_prior_told_before_any_frame_is_as_old_as_the_first_frame() -> None:
    # (Its age, which min_age_s asks of it, counts from the first frame, whenever that is.)
    tracker = Tracker(EXAMPLE_MAP, EXAMPLE_SENSOR, EXAMPLE_MOTION)
    tracker.set_pose((6.0, 4.0, 0.3), WIDE)
    tracker.odometry([100.0], [0.0], [0.0])
    tracker.frame(100.0, [0.1])
    assert tracker._born.tolist() == [100.0] * tracker.n_hypotheses
    told = Tracker(EXAMPLE_MAP, EXAMPLE_SENSOR, EXAMPLE_MOTION)
    told.set_pose((6.0, 4.0, 0.3), TIGHT)  # told surely: old enough at once
    assert told._born.tolist() == [-math.inf]


def test_a_pose_told_surely_has_led_since_it_was_told() -> None:
    # min_best_s asks a place to have led for a while; a pose told surely has, from the
    # moment it was told (a prior, told loosely, leads from its first frame as the best).
    run = _run(3)
    start = run.truth.pose_at(run.frames[0].t)
    led = TrackerConfig(min_best_s=5.0)
    first, n, wrong, est = _scored(run, initial_pose=start, initial_covariance=TIGHT, config=led)
    assert first == 0.0 and wrong == 0 and n == len(est)
    first, _, _, est = _scored(run, initial_pose=start, initial_covariance=WIDE, config=led)
    assert first is not None and first >= 5.0
    assert any("the best place has led for" in e.reason for e in est)


def test_a_pose_told_surely_is_not_asked_to_name_landmarks() -> None:
    # min_landmarks asks the bearings of the last seconds to name that many landmarks from a
    # place a search found; a pose told surely is the user's word, as old and as confirmed
    # as localized asks (on MRCLAM, held at its first frame, robot 4's told start lost the
    # mass to elsewhere and was first right after 836 s).
    run = _run(3)
    start = run.truth.pose_at(run.frames[0].t)
    every = TrackerConfig(min_landmarks=len(EXAMPLE_MAP))
    first, n, wrong, est = _scored(run, initial_pose=start, initial_covariance=TIGHT, config=every)
    assert first == 0.0 and wrong == 0 and n == len(est)
    _, n0, _, est0 = _scored(run, config=every)
    assert n0 == 0 and any(f"{len(EXAMPLE_MAP)} needed" in e.reason for e in est0)
