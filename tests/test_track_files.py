"""Recordings written to files and read back: odometry, frames (empty ones too), ground truth;
the example recording in ``examples/grid-run`` and ``omniloc track`` on it."""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc.cli import main
from omniloc.errors import InputError
from omniloc.track import (
    Frame,
    GroundTruth,
    Odometry,
    load_frames,
    load_groundtruth,
    load_odometry,
    write_frames,
    write_groundtruth,
    write_odometry,
    write_tum_truth,
)
from omniloc.track.io import read_tum
from omniloc.track.simulate import example_run

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False, exclude_max=True)


@st.composite
def _times(draw: st.DrawFn, n: int) -> np.ndarray:
    """``n`` strictly increasing times."""
    t0 = draw(st.floats(-1e6, 1e6))
    steps = draw(st.lists(st.floats(1e-3, 100.0), min_size=n, max_size=n))
    return np.asarray(t0 + np.cumsum(steps))


@settings(max_examples=40, deadline=None)
@given(data=st.data(), n=st.integers(1, 30))
def test_odometry_and_ground_truth_read_back_exactly(
    tmp_path_factory: pytest.TempPathFactory, data: st.DataObject, n: int
) -> None:
    folder = tmp_path_factory.mktemp("rec")
    t = data.draw(_times(n))
    v, w = (np.array(data.draw(st.lists(finite, min_size=n, max_size=n))) for _ in range(2))
    odo = Odometry(t, v, w)
    assert write_odometry(folder / "o.csv", odo) == n
    back = load_odometry(folder / "o.csv")
    assert np.array_equal(back.t, odo.t) and np.array_equal(back.v, odo.v)
    assert np.array_equal(back.w, odo.w)
    if n < 2:
        return
    xy = [np.array(data.draw(st.lists(finite, min_size=n, max_size=n))) for _ in range(2)]
    th = np.array(data.draw(st.lists(angle, min_size=n, max_size=n)))
    gap = np.array(data.draw(st.lists(st.floats(0.0, 10.0), min_size=n, max_size=n)))
    truth = GroundTruth(t, xy[0], xy[1], th, gap)
    assert write_groundtruth(folder / "g.csv", truth) == n
    g = load_groundtruth(folder / "g.csv")
    for k in ("t", "x", "y", "theta", "gap"):
        assert np.array_equal(getattr(g, k), getattr(truth, k)), k


@settings(max_examples=40, deadline=None)
@given(data=st.data(), n=st.integers(1, 12))
def test_frames_read_back_exactly_empty_ones_too(
    tmp_path_factory: pytest.TempPathFactory, data: st.DataObject, n: int
) -> None:
    path = tmp_path_factory.mktemp("rec") / "f.csv"
    t = data.draw(_times(n))
    frames = [Frame(float(tt), data.draw(st.lists(angle, max_size=5))) for tt in t]
    assert write_frames(path, frames) == n
    back = load_frames(path)
    assert [f.t for f in back] == [f.t for f in frames]
    for a, b in zip(back, frames, strict=True):
        assert np.array_equal(a.bearings, b.bearings)


def test_a_row_without_a_bearing_is_a_frame_in_which_nothing_was_seen(tmp_path: Path) -> None:
    path = tmp_path / "f.csv"
    path.write_text("t,bearing_deg\n0.5,10\n0.5,-20\n1.0,\n1.5,30\n2.0, \n2.0,45\n")
    frames = load_frames(path)
    assert [f.t for f in frames] == [0.5, 1.0, 1.5, 2.0]
    assert [f.bearings.size for f in frames] == [2, 0, 1, 1]
    assert np.allclose(np.rad2deg(frames[0].bearings), [10, -20])
    assert np.allclose(np.rad2deg(frames[3].bearings), [45])
    # A bearing that is there but not a number is still an error, named.
    path.write_text("t,bearing\n0.5,0.1\n1.0,north\n")
    with pytest.raises(InputError, match=r"f\.csv:3: bearing is not a number: 'north'"):
        load_frames(path)


@pytest.mark.parametrize(
    "header",
    [
        "t,bearing",
        "t,bearing_deg",
        "frame_id,t,t_span,n_landmarks,landmarks,robot_detections",  # MRCLAM's columns
    ],
)
def test_a_frames_file_with_a_header_alone_holds_no_frames_and_the_commands_say_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], header: str
) -> None:
    path = tmp_path / "f.csv"
    path.write_text(f"{header}\n# nothing recorded\n")
    assert load_frames(path) == []
    grid = EXAMPLES / "grid-run"
    common = ["--map", str(grid / "landmarks.csv"), "--frames", str(path)]
    truth = ["--groundtruth", str(grid / "groundtruth.csv")]
    odometry = ["--odometry", str(grid / "odometry.csv")]
    for argv in (
        ["track", *common, *odometry],
        ["fit-sensor", *common, *truth],
        ["fit-confidence", *common, *truth, *odometry],
    ):
        assert main(["-q", *argv]) == 1, argv[0]
        err = capsys.readouterr().err
        assert err == f"error: {path}: no frames\n", argv[0]


def _read_warned(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, text: str, load: Any, warning: str
) -> Any:
    """``text`` written to o.csv and read by ``load``: the warning logged is ``warning``
    alone (one, naming its line), or none for ""."""
    path = tmp_path / "o.csv"
    path.write_text(text)
    with caplog.at_level("WARNING", logger="omniloc.track.data"):
        rec = load(path)
    if warning:
        assert warning in caplog.text and caplog.text.count("WARNING") == 1
    else:
        assert caplog.text == ""
    return rec


@pytest.mark.parametrize(
    ("text", "warning"),
    [
        # odometry: a turn rate in degrees per second, a speed in mm/s, neither at the limits
        ("t,v,w\n0,0.2,0.5\n1,0.2,-30\n2,0.2,3\n", "o.csv:3: turn rate w -30 rad/s"),
        ("t,v,w\n0,250,0.1\n1,0.2,6.2\n", "o.csv:2: speed v 250 m/s"),
        ("t,v,w\n0,9.9,6.28\n1,-0.2,-6.2\n", ""),
        ("t,v,w\n0,0.2,0.1\n1,9.9,-6.3\n", "o.csv:3: turn rate w -6.3 rad/s"),
        ("t,v,w\n0,0.2,0.1\n1,-10.1,0.1\n", "o.csv:3: speed v -10.1 m/s"),
        # ground truth: headings in degrees, none within a full turn
        ("t,x,y,theta\n0,1,2,45\n1,1,2,-170\n", "o.csv:3: heading theta -170 is more than"),
        ("t,x,y,theta\n0,1,2,3.1\n1,1,2,-6.28\n", ""),
        ("t,x,y,theta\n0,1,2,3.1\n1,1,2,6.3\n", "o.csv:3: heading theta 6.3 is more than"),
    ],
)
def test_recordings_in_other_units_are_warned_of_with_their_line(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, text: str, warning: str
) -> None:
    load = load_odometry if text.startswith("t,v,w") else load_groundtruth
    rec = _read_warned(tmp_path, caplog, text, load, warning)
    if not warning:
        return
    # Read as written: a warning, not an error.
    values = rec.w if isinstance(rec, Odometry) else rec.theta
    assert values[-1] == float(text.splitlines()[-1].split(",")[-1])


@pytest.mark.parametrize(
    ("text", "warning"),
    [
        # headings in degrees: 2 deg in 0.25 s read as 8 rad/s, named by the later pose
        (
            "t,x,y,theta\n0,0,0,0\n0.25,0.1,0,0\n0.25,0.1,0,0\n0.5,0.2,0,2\n",
            "o.csv:5: turn rate w 8 rad/s from the pose before this one, more than 6.28 rad/s: "
            "are the headings in degrees? omniloc reads radians",
        ),
        # positions in mm: 100 mm in 0.5 s read as 200 m/s
        (
            "t,x,y,theta\n0,0,0,0\n0.5,100,0,0\n1.0,100,0,0.1\n",
            "o.csv:3: speed v 200 m/s from the pose before this one",
        ),
        # the same track in radians and metres: quiet
        ("t,x,y,theta\n0,0,0,0\n0.5,0.1,0,0\n1.0,0.2,0,0.5236\n", ""),
    ],
)
def test_a_pose_track_in_other_units_is_warned_of_with_its_line(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, text: str, warning: str
) -> None:
    odo = _read_warned(tmp_path, caplog, text, load_odometry, warning)
    if not warning:
        assert np.max(np.abs(odo.w)) == pytest.approx(0.5236 / 0.5)


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("g.csv", "t,x,y,theta\n"),
        ("g.csv", "t,x,y,theta\n0,1,2,0.5\n"),
        ("g.tum", "0 1 2 0 0 0 0 1\n"),
    ],
)
def test_a_ground_truth_of_fewer_than_two_samples_is_refused_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, text: str
) -> None:
    path = tmp_path / name
    path.write_text(text)
    message = f"{path}: ground truth needs at least 2 samples"
    with pytest.raises(InputError, match="^" + re.escape(message)):
        load_groundtruth(path)
    grid = EXAMPLES / "grid-run"
    argv = ["-q", "fit-motion", "--odometry", str(grid / "odometry.csv")]
    assert main([*argv, "--groundtruth", str(path)]) == 1
    assert capsys.readouterr().err.startswith(f"error: {path}: ground truth needs at least 2")


def test_frames_in_degrees_without_saying_so_are_an_error(tmp_path: Path) -> None:
    # Read as radians, degrees would be wrapped into bearings the robot never saw.
    path = tmp_path / "f.csv"
    path.write_text("t,bearing\n0.5,0.1\n0.5,\n1.0,-0.2\n1.0,120\n")
    with pytest.raises(InputError, match=r"f\.csv:5: bearing is 120, more than a full turn"):
        load_frames(path)
    frames = load_frames(path, degrees=True)
    assert np.allclose(np.rad2deg(frames[1].bearings), [-0.2, 120])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,bearing_rad\n0.5,0.1\n", r"f\.csv:1: the column says radians \(bearing_rad\)"),
        (
            "t,landmarks,robot_detections\n0.5,6:0.1:2.0,\n",
            r"f\.csv:1: an MRCLAM frames file \(landmarks, robot_detections\) holds radians",
        ),
    ],
)
def test_degrees_for_a_file_whose_bearings_say_radians_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    path = tmp_path / "f.csv"
    path.write_text(text)
    assert np.allclose(load_frames(path)[0].bearings, [0.1])
    with pytest.raises(InputError, match=message):
        load_frames(path, degrees=True)
    grid = EXAMPLES / "grid-run"
    argv = ["-q", "track", "--map", str(grid / "landmarks.csv"), "--degrees"]
    argv += ["--odometry", str(grid / "odometry.csv"), "--frames", str(path)]
    assert main(argv) == 1
    assert "degrees=True" in capsys.readouterr().err


def test_the_truth_as_tum_is_the_track_at_the_times_asked(tmp_path: Path) -> None:
    t = np.linspace(0.0, 10.0, 11)
    truth = GroundTruth(t, t * 0.5, -t, np.linspace(-3.0, 3.0, 11))
    asked = [-1.0, 0.25, 4.5, 9.99, 10.5]
    assert write_tum_truth(tmp_path / "g.tum", truth, asked) == 3  # two outside the span
    back = read_tum(tmp_path / "g.tum")
    want, _ = truth.at(np.array([0.25, 4.5, 9.99]))
    assert np.allclose(back[:, 0], [0.25, 4.5, 9.99])
    assert np.allclose(back[:, 1:3], want[:, :2], atol=1e-6)
    assert np.allclose(np.angle(np.exp(1j * (back[:, 3] - want[:, 2]))), 0.0, atol=1e-8)
    with pytest.raises(InputError, match="write_tum_truth needs a GroundTruth"):
        write_tum_truth(tmp_path / "g.tum", t, [1.0])  # type: ignore[arg-type]
    with pytest.raises(InputError, match="times must be finite"):
        write_tum_truth(tmp_path / "g.tum", truth, [1.0, np.nan])
    with pytest.raises(InputError, match="times must be numbers"):
        write_tum_truth(tmp_path / "g.tum", truth, ["soon"])


def test_bad_recordings_are_refused_by_name(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="write_odometry needs an Odometry, got list"):
        write_odometry(tmp_path / "o.csv", [])  # type: ignore[arg-type]
    with pytest.raises(InputError, match="write_groundtruth needs a GroundTruth, got dict"):
        write_groundtruth(tmp_path / "g.csv", {})  # type: ignore[arg-type]
    with pytest.raises(InputError, match="write_frames needs an iterable of Frame, got int"):
        write_frames(tmp_path / "f.csv", 3)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="item 1 is a float, not a Frame"):
        write_frames(tmp_path / "f.csv", [Frame(0.0, [0.1]), 0.5])  # type: ignore[list-item]
    # Two frames at one time would read back as one.
    with pytest.raises(InputError, match=r"frame 1 at t=1\.0 does not come after"):
        write_frames(tmp_path / "f.csv", [Frame(1.0, [0.1]), Frame(1.0, [0.2])])
    with pytest.raises(InputError, match="cannot"):
        write_frames(tmp_path / "no" / "such" / "f.csv", [Frame(1.0, [0.1])])


def _same_table(a: Path, b: Path) -> bool:
    """The same text table, line for line, numbers equal to 1e-12 (numpy's trigonometry
    differs in the last bit from one processor's vector unit to another's: the files are
    written on one machine and tested on any)."""
    la, lb = a.read_text().splitlines(), b.read_text().splitlines()
    if len(la) != len(lb):
        return False
    for x, y in zip(la, lb, strict=True):
        if x == y:
            continue
        fx, fy = x.replace(",", " ").split(), y.replace(",", " ").split()
        try:
            u, v = np.array(fx, dtype=float), np.array(fy, dtype=float)
        except ValueError:
            return False
        if u.shape != v.shape or not np.allclose(u, v, rtol=1e-12, atol=1e-12):
            return False
    return True


def test_same_table_tells_numbers_apart_beyond_the_last_bits(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("t,bearing\n1.0,0.6706382187952782\n")
    b.write_text("t,bearing\n1.0,0.6706382187952777\n")
    assert _same_table(a, b)
    b.write_text("t,bearing\n1.0,0.670638219\n")
    assert not _same_table(a, b)
    b.write_text("t,bearing\n1.0,0.6706382187952782\n2.0,0.1\n")
    assert not _same_table(a, b)
    b.write_text("t,heading\n1.0,0.6706382187952782\n")
    assert not _same_table(a, b)


def test_the_example_files_are_what_the_library_simulates(tmp_path: Path) -> None:
    # examples/grid-run is written by examples/make_grid_run.py from example_run(): the
    # files in the repository must be what the library simulates today, to the last bits
    # that numpy's trigonometry leaves to the processor (after a change to the simulation,
    # run the script again).
    sys.path.insert(0, str(EXAMPLES))
    try:
        import make_grid_run
    finally:
        sys.path.remove(str(EXAMPLES))
    assert make_grid_run.main(["--out", str(tmp_path)]) == 0
    for name in (
        "landmarks.csv",
        "odometry.csv",
        "frames.csv",
        "groundtruth.csv",
        "groundtruth.tum",
    ):
        assert _same_table(tmp_path / name, EXAMPLES / "grid-run" / name), name
    settings = json.loads((EXAMPLES / "grid-run" / "settings.json").read_text())
    assert settings == json.loads((tmp_path / "settings.json").read_text())
    # And the files are the demo's recording (to the same last bits).
    run = example_run().run
    odo = load_odometry(EXAMPLES / "grid-run" / "odometry.csv")
    assert np.array_equal(odo.v, run.odometry.v) and np.array_equal(odo.t, run.odometry.t)
    frames = load_frames(EXAMPLES / "grid-run" / "frames.csv")
    assert len(frames) == len(run.frames)
    pairs = zip(frames, run.frames, strict=True)
    assert all(
        np.array_equal(a.t, b.t) and np.allclose(a.bearings, b.bearings, rtol=0, atol=1e-12)
        for a, b in pairs
    )


def test_track_on_the_example_wakes_up_is_kidnapped_and_recovers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The README's example: the command and what it prints.
    d = EXAMPLES / "grid-run"
    argv = ["-q", "track", "--map", str(d / "landmarks.csv"), "--odometry"]
    argv += [str(d / "odometry.csv"), "--frames", str(d / "frames.csv"), "--config"]
    argv += [str(d / "settings.json"), "--groundtruth", str(d / "groundtruth.csv")]
    gt = tmp_path / "gt.tum"
    assert main([*argv, "--out", str(tmp_path / "t.tum"), "--truth-out", str(gt)]) == 0
    out = capsys.readouterr().out
    # --truth-out: the truth at the frames' times, the example's groundtruth.tum itself.
    assert gt.read_bytes() == (d / "groundtruth.tum").read_bytes()
    assert "localized 90.0 %, ambiguous 10.0 %, lost 0.0 %" in out
    assert "first localized at t = 3.125 s" in out
    assert "kidnapping flagged at t = 30.4\n" in out
    assert "within 0.3 m / 5 deg 100.0 % of localized frames; position RMSE 0.011 m" in out
    assert len((tmp_path / "t.tum").read_text().splitlines()) == 216


def test_evo_on_the_example_gives_the_readme_figure(tmp_path: Path) -> None:
    # evo_ape tum examples/grid-run/groundtruth.tum track.tum (the README): evo's APE,
    # without alignment, equals the RMSE omniloc track prints (0.011 m).
    evo_file = pytest.importorskip("evo.tools.file_interface")
    from evo.core import metrics, sync

    d = EXAMPLES / "grid-run"
    argv = ["-q", "track", "--map", str(d / "landmarks.csv"), "--odometry"]
    argv += [str(d / "odometry.csv"), "--frames", str(d / "frames.csv"), "--config"]
    argv += [str(d / "settings.json"), "--out", str(tmp_path / "t.tum")]
    assert main(argv) == 0
    ref = evo_file.read_tum_trajectory_file(str(d / "groundtruth.tum"))
    est = evo_file.read_tum_trajectory_file(str(tmp_path / "t.tum"))
    ref, est = sync.associate_trajectories(ref, est)
    assert est.num_poses == 216
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    evo_rmse = ape.get_statistic(metrics.StatisticsType.rmse)
    assert evo_rmse == pytest.approx(0.011047, abs=1e-6)
    # ... which is ours, against the CSV track the reference was written from.
    from omniloc.evaluate.tracking import errors_against
    from omniloc.track import track

    ex = example_run()
    run = track(ex.landmarks, ex.run.odometry, ex.run.frames, sensor=ex.sensor, motion=ex.motion)
    _, d_pos, _ = errors_against(load_groundtruth(d / "groundtruth.csv"), run.estimates)
    loc = np.array([e.localized for e in run.estimates])
    assert evo_rmse == pytest.approx(float(np.sqrt(np.mean(d_pos[loc] ** 2))), rel=1e-5)


def test_truth_out_needs_the_ground_truth(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d = EXAMPLES / "grid-run"
    argv = ["-q", "track", "--map", str(d / "landmarks.csv"), "--odometry"]
    argv += [str(d / "odometry.csv"), "--frames", str(d / "frames.csv")]
    assert main([*argv, "--truth-out", str(tmp_path / "gt.tum")]) == 1
    err = capsys.readouterr().err
    assert "--truth-out writes the ground truth: give it with --groundtruth" in err
    assert err.count("\n") == 1 and not (tmp_path / "gt.tum").exists()
