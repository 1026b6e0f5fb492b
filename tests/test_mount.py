"""A sensor that sits off the robot's origin (``SensorModel.mount``): the bearings are the
sensor's, every pose given or returned is the robot's -- single frames (``localize``),
the tracker, the simulation, the sensor fit, the command line and the figures."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import omniloc
from omniloc import Pose, SensorModel, localize, predict_bearings
from omniloc.cli import main
from omniloc.errors import InputError
from omniloc.pose import compose
from omniloc.track import Odometry, Tracker, estimate_frame_sensor, track
from omniloc.track.simulate import EXAMPLE_MAP, EXAMPLE_MOTION, EXAMPLE_SENSOR, simulate_run

MOUNT = (0.3, 0.1, 0.5)

finite = st.floats(-50.0, 50.0, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False, exclude_max=True)
seat = st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), angle)


# ---- the model -------------------------------------------------------------------------------
def test_a_mount_is_three_numbers_in_metres_and_radians() -> None:
    assert SensorModel(mount=[0.2, -0.1, 0.3]).mount == (0.2, -0.1, 0.3)
    assert SensorModel(mount=np.array([0.2, 0, 0])).mount == (0.2, 0.0, 0.0)
    assert SensorModel(mount=(0, 0, 0)).mount is None  # (the origin: no mount)
    assert SensorModel(mount=(0.1, 0, math.pi)).mount == (0.1, 0.0, -math.pi)  # (wrapped)
    for bad, words in [
        ((0.1, 0.2), "three numbers"),
        ("0.1,0,0", "three numbers"),
        (0.3, "three numbers"),
        ((0.1, 0.0, float("nan")), r"mount\[2\]"),
        ((0.1, 0.0, 30.0), "radians"),
        ((250.0, 0.0, 0.0), "metres"),
        ((0.1, "a", 0.0), r"mount\[1\]"),
    ]:
        with pytest.raises(InputError, match=words):
            SensorModel(mount=bad)


@settings(max_examples=80, deadline=None)
@given(st.tuples(finite, finite, angle), seat)
def test_robot_and_sensor_poses_undo_each_other(pose: tuple, mount: tuple) -> None:
    s = SensorModel(mount=mount)
    p = np.array(pose)
    back = s.robot_poses(s.sensor_poses(p))
    assert np.allclose(back[:2], p[:2], atol=1e-9)
    assert abs(float(omniloc.wrap(back[2] - p[2]))) < 1e-9
    if s.mount is not None:
        # The sensor sits where the mount says, seen from the robot.
        rel = s.sensor_poses(p)[:2] - p[:2]
        c, si = math.cos(p[2]), math.sin(p[2])
        assert np.allclose([c * rel[0] + si * rel[1], -si * rel[0] + c * rel[1]], mount[:2])


@settings(max_examples=40, deadline=None)
@given(st.tuples(finite, finite, angle), seat)
def test_a_covariance_is_carried_by_the_jacobian_of_the_mount(pose: tuple, mount: tuple) -> None:
    s = SensorModel(mount=mount)
    p = np.array(pose)
    C = np.diag([0.01, 0.02, 0.003])
    C[0, 2] = C[2, 0] = 0.001
    _, R = s.robot_poses(p, C)
    # Numerical Jacobian of sensor -> robot.
    J = np.zeros((3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-6
        d = s.robot_poses(p + e) - s.robot_poses(p - e)
        d[2] = float(omniloc.wrap(d[2]))
        J[:, k] = d / 2e-6
    assert np.allclose(R, J @ C @ J.T, atol=1e-8)
    # A sensor off the robot's origin passes its heading's uncertainty (uncorrelated here)
    # to the robot's position.
    if s.mount is not None and math.hypot(*mount[:2]) > 0.1:
        D = np.diag([0.01, 0.02, 0.003])
        assert np.trace(s.robot_poses(p, D)[1][:2, :2]) > np.trace(D[:2, :2]) + 0.003 * 0.009


def test_robot_poses_check_their_input() -> None:
    s = SensorModel(mount=MOUNT)
    with pytest.raises(InputError, match="shape"):
        s.robot_poses(np.zeros((2, 2)))
    with pytest.raises(InputError, match="finite"):
        s.sensor_poses([0.0, float("nan"), 0.0])
    with pytest.raises(InputError, match=r"covariances must have shape \(2, 3, 3\)"):
        s.robot_poses(np.zeros((2, 3)), np.zeros((3, 3)))
    # Many at once, and a Pose.
    assert s.sensor_poses(np.zeros((4, 3))).shape == (4, 3)
    assert s.sensor_poses(Pose(1.0, 2.0, 0.0)).tolist() == pytest.approx([1.3, 2.1, 0.5])


# ---- single frames ---------------------------------------------------------------------------
def test_localize_returns_the_robot_pose_of_a_mounted_sensor() -> None:
    room = omniloc.demo_room()
    rng = np.random.default_rng(4)
    sensor = SensorModel(sigma=math.radians(0.3), mount=(0.15, 0.05, -0.4))
    plain = sensor.replace(mount=None)
    for _ in range(10):
        robot = omniloc.random_pose(room, rng=rng).as_array()
        z = predict_bearings(room.xy, sensor.sensor_poses(robot))
        res = localize(room, z, sensor)
        assert res.mount == sensor.mount
        got = res.best.pose.as_array()
        assert np.allclose(got[:2], robot[:2], atol=1e-6)
        assert abs(float(omniloc.wrap(got[2] - robot[2]))) < 1e-6
        # The same search without the mount finds the sensor; carried to the robot with its
        # covariance, it is the answer above.
        bare = localize(room, z, plain)
        pose, cov = sensor.robot_poses(bare.best.pose.as_array(), bare.best.covariance)
        assert np.allclose(pose, got, atol=1e-9)
        assert np.allclose(cov, res.best.covariance, atol=1e-12)
        assert np.allclose(res.poses[0], got)
        assert bare.best.pose.distance_to(res.best.pose)[0] > 0.1
    # The keyword builds the same sensor, and may not repeat a sensor's.
    kw = localize(room, z, sigma=math.radians(0.3), mount=(0.15, 0.05, -0.4))
    assert np.allclose(kw.best.pose.as_array(), got)
    with pytest.raises(InputError, match="mount"):
        localize(room, z, sensor, mount=(0.1, 0.0, 0.0))


def test_the_figure_draws_the_rays_from_the_sensor(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from omniloc.plot.scene import plot_localization

    room = omniloc.demo_room()
    sensor = SensorModel(sigma=math.radians(0.3), mount=(0.5, 0.0, 0.0))
    robot = np.array([5.0, 3.0, 0.4])
    z = predict_bearings(room.xy, sensor.sensor_poses(robot))
    res = localize(room, z, sensor)
    fig = plot_localization(res, z, tmp_path / "scene.png")
    eye = sensor.sensor_poses(robot)
    starts = {
        (round(float(line.get_xdata()[0]), 6), round(float(line.get_ydata()[0]), 6))
        for line in fig.axes[0].lines
        if len(line.get_xdata()) == 2
    }
    assert (round(float(eye[0]), 6), round(float(eye[1]), 6)) in starts
    assert (round(float(robot[0]), 6), round(float(robot[1]), 6)) not in starts
    assert (tmp_path / "scene.png").stat().st_size > 0


# ---- over time -------------------------------------------------------------------------------
def _run(mount: tuple[float, float, float] | None, seed: int = 3):
    return simulate_run(
        EXAMPLE_MAP,
        EXAMPLE_SENSOR.replace(mount=mount),
        Pose(6.0, 4.0, 0.3),
        duration_s=40.0,
        rng=seed,
    )


def _errors(estimates, truth) -> np.ndarray:
    out = []
    for e in estimates:
        if e.localized:
            d = e.pose.as_array() - truth.pose_at(e.t).as_array()
            out.append((math.hypot(d[0], d[1]), abs(float(omniloc.wrap(d[2])))))
    return np.array(out).reshape(-1, 2)


def test_the_tracker_reports_the_robot_of_a_mounted_sensor() -> None:
    run = _run(MOUNT)
    sensor = EXAMPLE_SENSOR.replace(mount=MOUNT)
    est = track(EXAMPLE_MAP, run.odometry, run.frames, sensor=sensor, motion=EXAMPLE_MOTION)
    err = _errors(est.estimates, run.truth)
    assert len(err) > 80
    assert err[:, 0].max() < 0.06 and err[:, 1].max() < math.radians(3)
    # Its hypotheses are the robot's too, and so is the covariance.
    last = [e for e in est.estimates if e.localized][-1]
    assert last.hypotheses[0].pose.distance_to(run.truth.pose_at(last.t))[0] < 0.06
    assert last.covariance is not None and last.covariance.shape == (3, 3)
    # Told nothing of the mount, it localizes far less often, and where it does, it is wrong
    # by the mount.
    bare = track(
        EXAMPLE_MAP, run.odometry, run.frames, sensor=EXAMPLE_SENSOR, motion=EXAMPLE_MOTION
    )
    wrong = _errors(bare.estimates, run.truth)
    assert len(wrong) < len(err) / 2
    assert len(wrong) == 0 or np.median(wrong[:, 0]) > 0.2


def _mounted(**config: object):  # type: ignore[no-untyped-def]
    """``track`` on the run with the sensor at MOUNT, the tracker configured by ``config``."""
    from omniloc.track import TrackerConfig

    run = _run(MOUNT)
    sensor = EXAMPLE_SENSOR.replace(mount=MOUNT)
    return track(
        EXAMPLE_MAP,
        run.odometry,
        run.frames,
        sensor=sensor,
        motion=EXAMPLE_MOTION,
        config=TrackerConfig(**config),  # type: ignore[arg-type]
    )


def test_the_landmarks_a_place_names_are_seen_from_the_sensor() -> None:
    # min_landmarks carries the place back in the sensor's frame and names the landmarks from
    # there: with the mount, the run localizes as without the test (taken from the robot's
    # pose, 0.3 m and 29 deg off the sensor's, the bearings would name no landmark).
    plain, checked = _mounted(), _mounted(min_landmarks=4)
    assert sum(e.localized for e in plain.estimates) > 80
    assert [e.state for e in checked.estimates] == [e.state for e in plain.estimates]


def test_a_mount_equals_the_sensor_frames_own_odometry() -> None:
    # The workaround before the mount: the odometry of the sensor's frame (TF odom ->
    # camera_link); the tracker then tracks the sensor. Carried to the robot, the same.
    run = _run(MOUNT)
    sensor = EXAMPLE_SENSOR.replace(mount=MOUNT)
    odo = run.odometry
    robot = [run.truth.pose_at(float(odo.t[0])).as_array()]
    from omniloc.track.motion import integrate

    for k in range(len(odo) - 1):
        d, _ = integrate([odo.t[k + 1] - odo.t[k]], [odo.v[k]], [odo.w[k]], EXAMPLE_MOTION)
        robot.append(compose(robot[-1], d))
    eye = sensor.sensor_poses(np.array(robot))
    eye_odo = Odometry.from_poses(odo.t, eye[:, 0], eye[:, 1], eye[:, 2])
    mounted = track(EXAMPLE_MAP, odo, run.frames, sensor=sensor, motion=EXAMPLE_MOTION)
    by_eye = track(EXAMPLE_MAP, eye_odo, run.frames, sensor=EXAMPLE_SENSOR, motion=EXAMPLE_MOTION)
    pairs = [
        (a, b)
        for a, b in zip(mounted.estimates, by_eye.estimates, strict=True)
        if a.localized and b.localized
    ]
    assert len(pairs) > 80
    apart = []
    for a, b in pairs:
        assert a.pose is not None and b.pose is not None
        back = sensor.robot_poses(b.pose.as_array())
        apart.append(math.hypot(*(a.pose.as_array()[:2] - back[:2])))
    # (Not to the bit: the odometry's noise is modelled on the robot's motion in one, on the
    # sensor's in the other.)
    assert max(apart) < 0.03 and float(np.median(apart)) < 5e-3


def test_a_mount_at_the_origin_changes_nothing() -> None:
    run = _run(None)
    a = track(EXAMPLE_MAP, run.odometry, run.frames, sensor=EXAMPLE_SENSOR, motion=EXAMPLE_MOTION)
    b = track(
        EXAMPLE_MAP,
        run.odometry,
        run.frames,
        sensor=EXAMPLE_SENSOR.replace(mount=(0.0, 0.0, 0.0)),
        motion=EXAMPLE_MOTION,
    )
    assert [e.as_dict() for e in a.estimates] == [e.as_dict() for e in b.estimates]


def test_the_motion_of_the_sensor_is_the_robots_seen_from_the_mount() -> None:
    tracker = Tracker(EXAMPLE_MAP, EXAMPLE_SENSOR.replace(mount=MOUNT), EXAMPLE_MOTION)
    delta = np.array([0.4, 0.05, 0.3])
    Q = np.diag([1e-3, 2e-4, 5e-4])
    ds, Qs = tracker._sensor_motion(delta, Q)
    M = np.array(MOUNT)
    start = np.array([1.0, 2.0, 0.7])
    # The sensor moves from start (+) M to start (+) delta (+) M.
    assert np.allclose(
        compose(compose(start, M), ds), compose(compose(start, delta), M), atol=1e-12
    )
    # Its covariance: the robot's carried by the numerical Jacobian of that map.
    J = np.zeros((3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-6
        d = tracker._sensor_motion(delta + e, Q)[0] - tracker._sensor_motion(delta - e, Q)[0]
        J[:, k] = d / 2e-6
    assert np.allclose(Qs, J @ Q @ J.T, rtol=1e-6, atol=1e-12)
    # A robot turning on the spot moves a sensor ahead of it sideways.
    ds, _ = tracker._sensor_motion(np.array([0.0, 0.0, 0.5]), np.zeros((3, 3)))
    assert math.hypot(ds[0], ds[1]) > 0.1


# ---- calibration -----------------------------------------------------------------------------
def test_the_sensor_fit_takes_the_mount() -> None:
    sensor = EXAMPLE_SENSOR.replace(mount=MOUNT)
    run = _run(MOUNT)
    fit = estimate_frame_sensor(
        EXAMPLE_MAP, run.frames, run.truth, max_range=5.0, mount=MOUNT, gate=math.radians(3)
    )
    assert fit.sigma == pytest.approx(sensor.sigma, rel=0.25)
    assert fit.p_detect == pytest.approx(0.9, abs=0.08)
    # Taken from the robot's origin, the bearings are 29 deg off: nothing is matched.
    with pytest.raises(InputError, match="too few to fit the sensor"):
        estimate_frame_sensor(EXAMPLE_MAP, run.frames, run.truth, max_range=5.0)
    with pytest.raises(InputError, match="mount"):
        estimate_frame_sensor(EXAMPLE_MAP, run.frames, run.truth, mount=(0.1, 0.2))


# ---- the command line ------------------------------------------------------------------------
def _files(tmp_path: Path, run) -> dict[str, Path]:
    from omniloc.track import write_frames, write_groundtruth, write_odometry

    paths = {k: tmp_path / f"{k}.csv" for k in ("map", "odometry", "frames", "truth")}
    paths["map"].write_text(
        "id,x,y\n"
        + "".join(f"{i},{float(x)!r},{float(y)!r}\n" for i, (x, y) in enumerate(EXAMPLE_MAP.xy))
    )
    write_odometry(paths["odometry"], run.odometry)
    write_frames(paths["frames"], run.frames)
    write_groundtruth(paths["truth"], run.truth)
    return paths


def _options(**paths: Path) -> list[str]:
    """``--name path`` for each keyword."""
    return [a for k, v in paths.items() for a in (f"--{k}", str(v))]


def test_track_and_fit_sensor_take_mount_on_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(MOUNT)
    p = _files(tmp_path, run)
    settings_path = tmp_path / "settings.json"
    settings_path.write_text(
        json.dumps(
            {
                "sigma": EXAMPLE_SENSOR.sigma,
                "max_range": 5.0,
                "p_detect": 0.9,
                "clutter": 0.3,
                "along_per_m": EXAMPLE_MOTION.along_per_m,
            }
        )
    )
    yaw_deg = math.degrees(MOUNT[2])
    files = _options(map=p["map"], frames=p["frames"], groundtruth=p["truth"])
    common = ["-q", "track", *files, *_options(odometry=p["odometry"], config=settings_path)]
    common.append("--json")
    assert main([*common, "--mount", f"{MOUNT[0]},{MOUNT[1]},{yaw_deg}"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line[:1] == "{"]
    near = [
        math.hypot(r["x"] - run.truth.pose_at(r["t"]).x, r["y"] - run.truth.pose_at(r["t"]).y)
        for r in rows
        if r["state"] == "localized"
    ]
    assert len(near) > 80 and max(near) < 0.06
    # Without --json the summary says whose poses they are.
    assert main([*common[:-1], "--mount", f"{MOUNT[0]},{MOUNT[1]},{yaw_deg}"]) == 0
    assert "(the robot's poses; the sensor at x = 0.300 m, y = 0.100 m, yaw = 28.65 deg" in (
        capsys.readouterr().out
    )
    # The same as a setting, in radians.
    assert main([*common, "--set", f"mount={list(MOUNT)}"]) == 0
    again = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line[:1] == "{"]
    assert again == rows
    # A mount that is not three numbers is refused by argparse, by name.
    assert main([*common, "--mount", "0.3,0.1"]) == 1
    assert "X,Y,YAW" in capsys.readouterr().err
    # fit-sensor with the mount writes it into the settings it fits.
    out = tmp_path / "sensor.json"
    mount = f"{MOUNT[0]},{MOUNT[1]},{yaw_deg}"
    fit = ["fit-sensor", *files, "--max-range", "5", "--mount", mount, "--out", str(out)]
    assert main(fit) == 0
    fitted = json.loads(out.read_text())
    assert fitted["mount"] == pytest.approx(list(MOUNT))
    assert fitted["sigma"] == pytest.approx(EXAMPLE_SENSOR.sigma, rel=0.25)


def test_localize_takes_mount_on_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    room = omniloc.demo_room()
    mount = (0.2, 0.0, math.radians(90))
    sensor = SensorModel(mount=mount)
    robot = np.array([5.6, 2.1, math.radians(30)])
    z = predict_bearings(room.xy, sensor.sensor_poses(robot))
    bearings = tmp_path / "z.txt"
    bearings.write_text("\n".join(repr(float(v)) for v in z) + "\n")
    room_csv = tmp_path / "room.csv"
    room_csv.write_text(
        "id,x,y\n"
        + "".join(
            f"{i},{float(x)!r},{float(y)!r}\n" for i, (x, y) in zip(room.ids, room.xy, strict=True)
        )
    )
    args = ["localize", "--map", str(room_csv), "--bearings", str(bearings), "--sigma", "0.3"]
    assert main([*args, "--json", "--mount", "0.2,0,90"]) == 0
    best = json.loads(capsys.readouterr().out)["solutions"][0]
    assert best["x"] == pytest.approx(robot[0], abs=1e-6)
    assert best["y"] == pytest.approx(robot[1], abs=1e-6)
    assert best["theta"] == pytest.approx(robot[2], abs=1e-6)
    # The output says whose poses they are.
    assert main([*args, "--mount", "0.2,0,90", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["mount"] == pytest.approx(list(mount))
    assert main([*args, "--mount", "0.2,0,90"]) == 0
    assert "(the robot's poses; the sensor at x = 0.200 m, y = 0.000 m, yaw = 1.57080 rad" in (
        capsys.readouterr().out
    )
    assert main([*args, "--mount", "0.2,0,400"]) == 1
    assert "YAW is in degrees" in capsys.readouterr().err


# ---- the mount fitted ------------------------------------------------------------------------
@pytest.mark.parametrize("mount", [(0.3, 0.1, 0.5), (0.0, 0.0, 0.0), (0.25, -0.25, 3.0)])
def test_the_mount_is_fitted_from_a_recording(mount: tuple[float, float, float]) -> None:
    from omniloc.track import estimate_mount

    run = _run(mount)
    fit = estimate_mount(EXAMPLE_MAP, run.frames, run.truth, max_range=5.0)
    assert fit.mount[0] == pytest.approx(mount[0], abs=0.01)
    assert fit.mount[1] == pytest.approx(mount[1], abs=0.01)
    assert abs(float(omniloc.wrap(fit.mount[2] - mount[2]))) < math.radians(0.2)
    assert all(0.0 < s < 0.01 for s in fit.sd)
    # The standard errors are honest: the truth lies within four of them.
    err = [
        fit.mount[0] - mount[0],
        fit.mount[1] - mount[1],
        float(omniloc.wrap(fit.mount[2] - mount[2])),
    ]
    assert all(abs(e) <= 4.0 * s for e, s in zip(err, fit.sd, strict=True))
    assert fit.matched > 0.8 * fit.bearings
    assert fit.residual_sd == pytest.approx(EXAMPLE_SENSOR.sigma, rel=0.2)
    # 40 s are two stretches of 20 s: too few to bootstrap, said so.
    assert fit.stretches == 2 and not fit.bootstrapped
    # The same from a guess nearer the truth, and from several recordings at once.
    again = estimate_mount(
        EXAMPLE_MAP,
        [run.frames, run.frames],
        [run.truth, run.truth],
        max_range=5.0,
        initial=(0.1, 0.0, 0.0),
    )
    assert np.allclose(again.mount[:2], fit.mount[:2], atol=2e-3)


def test_the_mount_s_standard_errors_say_where_they_come_from(
    caplog: pytest.LogCaptureFixture,
) -> None:
    from omniloc.track import estimate_mount
    from omniloc.track.calibrate import MOUNT_MIN_STRETCHES

    short = _run(MOUNT)  # 40 s
    with caplog.at_level(logging.WARNING, logger="omniloc"):
        fit = estimate_mount(EXAMPLE_MAP, short.frames, short.truth, max_range=5.0)
    assert not fit.bootstrapped
    assert "span 2 stretch(es) of 20 s, fewer than 5" in caplog.text
    caplog.clear()
    # Long enough: the bootstrap's spread, at least the least squares' own (the short fit's
    # scale: the same noise), and no warning.
    long = simulate_run(
        EXAMPLE_MAP,
        EXAMPLE_SENSOR.replace(mount=MOUNT),
        Pose(6.0, 4.0, 0.3),
        duration_s=20.0 * MOUNT_MIN_STRETCHES + 5.0,
        rng=3,
    )
    with caplog.at_level(logging.WARNING, logger="omniloc"):
        fit = estimate_mount(EXAMPLE_MAP, long.frames, long.truth, max_range=5.0)
    assert fit.bootstrapped and fit.stretches == MOUNT_MIN_STRETCHES + 1
    assert "stretch" not in caplog.text
    err = np.subtract(fit.mount, MOUNT)
    err[2] = float(omniloc.wrap(err[2]))
    assert all(abs(e) <= 4.0 * s for e, s in zip(err, fit.sd, strict=True))


def test_the_mount_fit_refuses_what_it_cannot_fit() -> None:
    from omniloc.track import Frame, GroundTruth, estimate_mount

    run = _run(MOUNT)
    with pytest.raises(InputError, match="no frame with bearings lies on the true track"):
        estimate_mount(EXAMPLE_MAP, [Frame(1e6, np.array([0.1]))], run.truth)
    noise = [Frame(f.t, np.random.default_rng(1).uniform(-3, 3, 1)) for f in run.frames[:30]]
    with pytest.raises(InputError, match=r"too few bearings within 3\.0 deg"):
        estimate_mount(EXAMPLE_MAP, noise, run.truth, max_range=5.0)
    # One landmark seen from one place: its bearing fixes neither x nor y.
    t = np.arange(30.0)
    still = GroundTruth(t, np.zeros(30), np.zeros(30), np.zeros(30))
    frames = [Frame(float(ti), np.array([0.0])) for ti in t]
    with pytest.raises(InputError, match="cannot tell the mount's x, y and yaw apart"):
        estimate_mount([[3.0, 0.0], [50.0, 50.0], [60.0, -40.0]], frames, still, max_range=5.0)
    with pytest.raises(InputError, match="mount"):
        estimate_mount(EXAMPLE_MAP, run.frames, run.truth, initial=(0.1, 0.0))


def test_the_mount_of_mrclam_robot_4(shared_data: Path) -> None:
    # Its camera sits about 9 cm ahead of the tracked centre, turned 0.6-0.7 deg (a fit told
    # each bearing's landmark, benchmarks/bearing_correlation.py: 0.089 m, 0.73 deg).
    from omniloc import LandmarkMap
    from omniloc.track import estimate_mount, load_frames, load_groundtruth

    data = shared_data / "mrclam-ds6"
    fit = estimate_mount(
        LandmarkMap.load(data / "landmarks.csv"),
        load_frames(data / "robot4_frames.csv"),
        load_groundtruth(data / "robot4_groundtruth_10hz.csv"),
        fov=math.radians(67.0),
        max_range=7.0,
    )
    assert 0.06 < fit.mount[0] < 0.12 and abs(fit.mount[1]) < 0.06
    assert math.radians(0.3) < fit.mount[2] < math.radians(0.9)
    # Its errors repeat for seconds: the stretches' bootstrap says so (the least squares'
    # own covariance said 0.002 m and 0.02 deg; the fit told the landmarks and a clock
    # offset differs from this one by 0.005 m and 0.12 deg).
    assert fit.sd[0] > 0.005 and fit.sd[2] > math.radians(0.06)


def test_fit_sensor_fits_the_mount_on_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(MOUNT)
    p = _files(tmp_path, run)
    out = tmp_path / "sensor.json"
    files = _options(map=p["map"], frames=p["frames"], groundtruth=p["truth"])
    assert main(["fit-sensor", *files, "--max-range", "5", "--fit-mount", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("mount  x 0.300 m, y 0.099 m, yaw 28.63 deg")
    assert "omniloc track --mount 0.300,0.099,28.63" in text
    fitted = json.loads(out.read_text())
    assert fitted["mount"] == pytest.approx(list(MOUNT), abs=0.01)
    assert fitted["sigma"] == pytest.approx(EXAMPLE_SENSOR.sigma, rel=0.25)


def test_elsewhere_covers_where_a_far_mounted_sensor_may_be() -> None:
    # A sensor on a 2 m boom: a robot at the region's edge carries it 2 m beyond.
    far = EXAMPLE_SENSOR.replace(mount=(2.0, 0.0, 0.0))
    region = (0.0, 12.0, 0.0, 8.0)
    from omniloc.track import TrackerConfig

    tracker = Tracker(EXAMPLE_MAP, far, EXAMPLE_MOTION, TrackerConfig(region=region))
    xy = tracker._elsewhere.poses[:, :2]
    assert xy[:, 0].min() < -1.0 and xy[:, 0].max() > 13.0
    assert tracker.region == region  # (the robot's region is as given)
    plain = Tracker(EXAMPLE_MAP, EXAMPLE_SENSOR, EXAMPLE_MOTION, TrackerConfig(region=region))
    assert plain._elsewhere.poses[:, 0].min() >= 0.0


def test_places_are_grouped_by_the_robot_poses() -> None:
    # Two sensor poses at one spot, 4 deg apart (one place for a sensor at the centre): a
    # sensor on a 5 m boom puts their robots 0.35 m apart, beyond the 0.3 m tolerance.
    boom = EXAMPLE_SENSOR.replace(mount=(5.0, 0.0, 0.0))
    for sensor, together in ((EXAMPLE_SENSOR, True), (boom, False)):
        tracker = Tracker(EXAMPLE_MAP, sensor, EXAMPLE_MOTION)
        tracker._mu = np.array([[6.0, 4.0, 0.3], [6.0, 4.0, 0.3 + math.radians(4.0)]])
        assert tracker._place(0).tolist() == [True, together]


def test_a_place_leads_in_the_sensors_frame() -> None:
    # min_best_s carries the last best hypothesis (a sensor pose) by the window's odometry
    # (the sensor's) and compares robot poses: with the mount the lead holds frame after
    # frame, and the run localizes almost as often as without the test (not carried, the
    # lead starts again whenever the robot has moved a little).
    plain, led = _mounted(), _mounted(min_best_s=2.0)
    n_plain = sum(e.localized for e in plain.estimates)
    n_led = sum(e.localized for e in led.estimates)
    assert n_plain > 80
    assert 0.8 * n_plain <= n_led <= n_plain
    assert any("the best place has led for" in e.reason for e in led.estimates)
