"""``omniloc track`` end to end: files in, TUM and JSON lines out, evo's APE equals ours;
bad files get one line on stderr and exit status 1."""

from __future__ import annotations

import contextlib
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import omniloc
from omniloc.cli import main
from omniloc.evaluate.tracking import errors_against
from omniloc.track import SimulatedRun, TrackState, preset, read_tum, simulate_run

ROOM = omniloc.demo_room()


@cache
def _run() -> SimulatedRun:
    sensor, _, _ = preset("generic")
    return simulate_run(
        ROOM, sensor, omniloc.Pose(4.0, 3.0, 0.3), duration_s=12.0, speed=0.2, rng=5
    )


def _write_inputs(folder: Path, degrees: bool = False) -> tuple[Path, Path, Path]:
    run = _run()
    lm = folder / "map.csv"
    lm.write_text(
        "id,x,y\n" + "".join(f"{k},{float(x)!r},{float(y)!r}\n" for k, (x, y) in enumerate(ROOM.xy))
    )
    odo = folder / "odometry.csv"
    o = run.odometry
    odo.write_text(
        "t,v,w\n"
        + "".join(
            f"{float(t)!r},{float(v)!r},{float(w)!r}\n"
            for t, v, w in zip(o.t, o.v, o.w, strict=True)
        )
    )
    fr = folder / "frames.csv"
    rows = []
    for f in run.frames:
        b = np.rad2deg(f.bearings) if degrees else f.bearings
        rows += [f"{float(f.t)!r},{float(x)!r}\n" for x in b]
    fr.write_text("t,bearing\n" + "".join(rows))
    return lm, odo, fr


def test_track_writes_tum_and_json_lines_and_evo_agrees(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lm, odo, fr = _write_inputs(tmp_path)
    tum = tmp_path / "traj.tum"
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    assert main([*argv, "--out", str(tum), "--json"]) == 0
    lines = [json.loads(s) for s in capsys.readouterr().out.splitlines()]
    run = _run()
    assert len(lines) == len(run.frames)
    assert {"t", "state", "reason"} <= set(lines[0])
    loc = [d for d in lines if d["state"] == "localized"]
    assert len(loc) > len(lines) // 2  # a room with distinct landmarks: localized soon
    for d in loc:
        assert {"x", "y", "theta", "covariance", "hypotheses"} <= set(d)
        assert np.asarray(d["covariance"]).shape == (3, 3)
    # the TUM file holds exactly the localized frames
    traj = read_tum(tum)
    assert traj.shape == (len(loc), 4)
    assert np.allclose(traj[:, 0], [d["t"] for d in loc], atol=1e-6)
    # evo's absolute pose error (translation, no alignment) equals ours
    evo_file = pytest.importorskip("evo.tools.file_interface")
    from evo.core import metrics
    from evo.core.trajectory import PoseTrajectory3D

    est = evo_file.read_tum_trajectory_file(str(tum))
    true_xyz, _ = run.truth.at(traj[:, 0])
    half = 0.5 * true_xyz[:, 2]
    ref = PoseTrajectory3D(
        positions_xyz=np.column_stack([true_xyz[:, :2], np.zeros(len(traj))]),
        orientations_quat_wxyz=np.column_stack(
            [np.cos(half), np.zeros(len(traj)), np.zeros(len(traj)), np.sin(half)]
        ),
        timestamps=traj[:, 0],
    )
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    evo_rmse = ape.get_statistic(metrics.StatisticsType.rmse)
    from omniloc.track import Frame, track

    ours = track(
        ROOM,
        run.odometry,
        [Frame(f.t, f.bearings) for f in run.frames],
        **dict(zip(("sensor", "motion", "config"), preset("generic"), strict=True)),
    )
    _, d_pos, _ = errors_against(run.truth, ours.estimates)
    mask = np.array([e.state is TrackState.LOCALIZED for e in ours.estimates])
    assert mask.sum() == len(traj)
    our_rmse = float(np.sqrt(np.mean(d_pos[mask] ** 2)))
    assert evo_rmse == pytest.approx(our_rmse, rel=1e-5, abs=1e-6)
    assert our_rmse < 0.05


def test_track_reads_degrees_prints_a_summary_and_plots(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lm, odo, fr = _write_inputs(tmp_path, degrees=True)
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    png = tmp_path / "run.png"
    assert main([*argv, "--degrees", "--plot", str(png)]) == 0
    assert png.stat().st_size > 10_000
    out = capsys.readouterr().out
    assert f"{len(_run().frames)} frames over" in out
    assert "last frame: localized" in out


@pytest.mark.parametrize(
    ("odometry_text", "message"),
    [
        ("t,v,w\n0.0,0.1,0.0\n-1.0,0.1,0.0\n", "odometry"),
        ("t,v,w\n0.0,nan,0.0\n", "finite"),
        ("t,speed\n0.0,0.1\n", "odometry"),
    ],
)
def test_bad_odometry_file_is_one_line_and_status_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], odometry_text: str, message: str
) -> None:
    lm, _, fr = _write_inputs(tmp_path)
    odo = tmp_path / "bad.csv"
    odo.write_text(odometry_text)
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err


def test_missing_frames_file_is_one_line_and_status_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lm, odo, _ = _write_inputs(tmp_path)
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo)]
    assert main([*argv, "--frames", str(tmp_path / "nope.csv")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nope.csv" in err


def _first_localized_after(out: str) -> float:
    """Seconds from the first frame to the first localized one, from the summary."""
    line = next(x for x in out.splitlines() if x.startswith("first localized"))
    return float(line.split("(")[1].split(" s after")[0])


def test_settings_from_a_file_and_the_command_line_change_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # min_age_s: a place must be tracked that long before it is called localized. The
    # files set 4 s then 6 s (the later wins), --set (applied after the files) 8 s.
    lm, odo, fr = _write_inputs(tmp_path)
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    assert main(argv) == 0
    plain = _first_localized_after(capsys.readouterr().out)
    settings = tmp_path / "settings.json"
    settings.write_text('{"min_age_s": 4.0, "split_clutter": 0.02}')
    later = tmp_path / "later.json"
    later.write_text('{"min_age_s": 6.0}')
    assert main([*argv, "--config", str(settings), "--config", str(later)]) == 0
    from_file = _first_localized_after(capsys.readouterr().out)
    assert main([*argv, "--config", str(settings), "--set", "min_age_s=8"]) == 0
    both = _first_localized_after(capsys.readouterr().out)
    assert plain < 6.0 <= from_file < both and both >= 8.0


@pytest.mark.parametrize(
    ("extra", "settings_text", "message"),
    [
        (["--set", "min_agee_s=3"], None, "did you mean 'min_age_s'"),
        (["--set", "min_age_s=-3"], None, "min_age_s must be finite and >= 0"),
        (["--set", "min_age_s"], None, "expected NAME=VALUE"),
        (["--set", "min_age_s=three"], None, "the value must be JSON"),
        (["--set", "region=[1,2]"], None, "region must be"),
        (["--set", "sigma=1e400"], None, "sigma"),
        ([], "[1, 2]", "one JSON object"),
        ([], "{min_age_s: 3}", "invalid JSON"),
        ([], '{"kidnap_share": 2}', "kidnap_share must lie strictly between 0 and 1"),
    ],
)
def test_bad_settings_are_one_line_and_status_1(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    settings_text: str | None,
    message: str,
) -> None:
    lm, odo, fr = _write_inputs(tmp_path)
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    if settings_text is not None:
        settings = tmp_path / "settings.json"
        settings.write_text(settings_text)
        extra = [*extra, "--config", str(settings)]
    assert main([*argv, *extra]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err


MRCLAM = Path(__file__).resolve().parents[2] / "shared" / "data" / "mrclam-ds6"


def _truncated_mrclam(folder: Path, seconds: float) -> Path:
    """The MRCLAM folder with every robot's files cut to their first ``seconds``."""
    folder.mkdir()
    (folder / "landmarks.csv").write_text((MRCLAM / "landmarks.csv").read_text())
    for r in range(1, 6):
        for kind in ("odometry", "frames", "groundtruth_10hz"):
            name = f"robot{r}_{kind}.csv"
            lines = (MRCLAM / name).read_text().splitlines()
            col = lines[0].split(",").index("t")
            t0 = float(lines[1].split(",")[col])
            keep = [s for s in lines[1:] if float(s.split(",")[col]) < t0 + seconds]
            (folder / name).write_text("\n".join([lines[0], *keep]) + "\n")
    return folder


def _evaluate_track_argv(tmp_path: Path, seconds: float) -> tuple[list[str], Path]:
    """``omniloc evaluate --dataset mrclam-track`` on the first ``seconds`` of each run,
    without kidnapped streams (they need minutes), and its output folder."""
    data = _truncated_mrclam(tmp_path / "mrclam", seconds)
    out = tmp_path / "out"
    argv = ["-q", "evaluate", "--dataset", "mrclam-track", str(data), "--kidnap", "0"]
    return [*argv, "--out", str(out)], out


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_evaluate_mrclam_track_reports_runs_and_totals(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv, out = _evaluate_track_argv(tmp_path, 4.0)
    assert main(argv) == 0
    text = capsys.readouterr().out
    for r in range(1, 6):
        assert f"robot{r}" in text
    assert "all runs: time to localize median" in text
    # What the recording allows, beside the tracker: in 4 s at most one run could be known.
    assert "what the data allow (a localizer told the correspondences" in text
    report = json.loads((out / "mrclam_track.json").read_text())
    assert report["whole_runs"]["totals"]["runs"] == 5
    assert report["kidnap_streams"] is None
    runs = report["whole_runs"]["runs"]
    assert sum(r["bound_time_to_localize_s"] is not None for r in runs) <= 1
    assert report["whole_runs"]["totals"]["bound_time_to_localize_median_s"] is None  # never
    csv_text = (out / "mrclam_track_runs.csv").read_text()
    assert csv_text.count("\n") == 6  # header + 5 runs
    assert "bound_time_to_localize_s" in csv_text.splitlines()[0]


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_evaluate_mrclam_track_over_tracker_seeds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import omniloc.evaluate.tracking as tracking

    # Each run gets its own seed on top of the settings given (--set), once per seed.
    real = tracking.evaluate_mrclam_tracking
    asked: list[dict[str, object]] = []

    def spy(*args: object, **kw: object) -> object:
        asked.append(dict(kw["settings"]))  # type: ignore[call-overload]
        return real(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(tracking, "evaluate_mrclam_tracking", spy)
    argv, out = _evaluate_track_argv(tmp_path, 20.0)
    assert main([*argv, "--set", "min_age_s=5", "--tracker-seeds", "3", "0", "3"]) == 0
    assert asked == [{"min_age_s": 5, "seed": 3}, {"min_age_s": 5, "seed": 0}]
    text = capsys.readouterr().out
    assert "== tracker seed 3" in text and "== tracker seed 0" in text
    assert "over the tracker's seeds 3, 0:" in text
    spread = json.loads((out / "mrclam_track_seeds.json").read_text())
    for seed in ("3", "0"):
        report = json.loads((out / f"seed-{seed}" / "mrclam_track.json").read_text())
        totals = report["whole_runs"]["totals"]
        assert spread["localized frames"]["by_seed"][seed] == totals["localized_frames"]
        ece = spread["weight ECE"]["by_seed"][seed]
        assert ece == pytest.approx(totals["best_weight_ece"], nan_ok=True)
    # Without kidnapped streams, no figure of theirs.
    assert "kidnapped: recovered" not in spread and "plain: false alarms" not in spread
    fig = spread["localized frames"]
    assert list(fig["by_seed"]) == ["3", "0"] and fig["min"] <= fig["max"]
    table = (out / "mrclam_track_seeds.md").read_text().splitlines()
    assert table[0] == "| figure | seed 3 | seed 0 | range |" and len(table) == 2 + len(spread)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--tracker-seeds", "1", "--set", "seed=2"], "leave seed out of --set"),
        (["--tracker-seeds", "-1"], "must be >= 0"),
        (["--tracker-seeds", str(2**63)], "seed must be an integer"),
    ],
)
def test_bad_tracker_seeds_are_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    argv = ["-q", "evaluate", "--dataset", "mrclam-track", str(tmp_path / "none"), "--kidnap", "0"]
    with contextlib.suppress(SystemExit):
        assert main([*argv, *extra, "--out", str(tmp_path / "out")]) == 1
    assert message in capsys.readouterr().err


def test_tracker_seeds_need_the_tracking_dataset(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["-q", "evaluate", "--tracker-seeds", "1", "--out", str(tmp_path / "out")]
    assert main(argv) == 1
    assert "--tracker-seeds applies to --dataset mrclam-track only" in capsys.readouterr().err


def test_seed_spread_needs_reports_with_integer_seeds() -> None:
    from omniloc.errors import InputError
    from omniloc.evaluate.tracking import seed_spread

    with pytest.raises(InputError, match="at least one report"):
        seed_spread({})
    with pytest.raises(InputError, match="seeds must be integers"):
        seed_spread({"a": None})  # type: ignore[dict-item]


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_seed_spread_reads_the_streams_figures(tmp_path: Path) -> None:
    from omniloc.evaluate.tracking import (
        TrackingReport,
        evaluate_mrclam_tracking,
        seed_spread,
        seed_spread_table,
    )

    data = _truncated_mrclam(tmp_path / "mrclam", 20.0)
    res, _ = evaluate_mrclam_tracking(data, kidnapped=0, progress=False)
    # The whole runs standing in for streams: none has a jump, all are plain.
    rep = TrackingReport(res.whole, kidnap=res.whole)
    spread = seed_spread({5: rep, 1: rep})
    assert spread["kidnapped: recovered"]["by_seed"] == {5: 0.0, 1: 0.0}
    plain = res.whole.totals(False)
    want = 100.0 * plain["false_alarm_run_rate"]
    assert spread["plain: false alarms"]["by_seed"][5] == pytest.approx(want)
    wrong = spread["confidently wrong"]
    assert wrong["min"] == wrong["max"] == wrong["by_seed"][1]
    lines = seed_spread_table(spread).splitlines()
    assert lines[0] == "| figure | seed 5 | seed 1 | range |"
    assert any(line.startswith("| plain: false alarms (%) |") for line in lines)


def test_generic_frames_with_a_ground_truth_say_nothing_of_the_bound(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from omniloc.track import write_groundtruth

    lm, odo, fr = _write_inputs(tmp_path)
    gt = tmp_path / "gt.csv"
    write_groundtruth(gt, _run().truth)
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    assert main([*argv, "--groundtruth", str(gt)]) == 0
    out = capsys.readouterr().out
    assert "against the ground truth" in out
    assert "what the data allow" not in out  # the frames do not say which landmark is which


def test_a_ground_truth_of_another_time_is_refused_and_a_partial_one_said(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from omniloc.track import GroundTruth, write_groundtruth

    lm, odo, fr = _write_inputs(tmp_path)
    truth = _run().truth
    argv = ["-q", "track", "--map", str(lm), "--odometry", str(odo), "--frames", str(fr)]
    # Stamped by another clock: refused before the tracker runs (it used to print "0.0 % of
    # localized frames" and an RMSE of nan, with numpy's warning).
    late = tmp_path / "late.csv"
    write_groundtruth(late, GroundTruth(truth.t + 1.7e9, truth.x, truth.y, truth.theta))
    assert main([*argv, "--groundtruth", str(late)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "share no time" in err and "t = 1700000000 to" in err
    # Covering the first half only: the errors are over the frames it covers, and it says
    # how many localized frames it leaves out.
    half = tmp_path / "half.csv"
    keep = truth.t <= truth.t[0] + 0.5 * (truth.t[-1] - truth.t[0])
    write_groundtruth(
        half, GroundTruth(truth.t[keep], truth.x[keep], truth.y[keep], truth.theta[keep])
    )
    assert main([*argv, "--groundtruth", str(half)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("against the ground truth"))
    assert "100.0 % of localized frames" in line and "nan" not in line
    assert "localized frames outside the ground truth's time)" in line


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_track_on_mrclam_with_its_ground_truth_says_what_the_data_allow(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = _truncated_mrclam(tmp_path / "mrclam", 30.0)
    argv = [
        "-q", "track", "--map", str(data / "landmarks.csv"), "--preset", "mrclam",
        "--odometry", str(data / "robot2_odometry.csv"),
        "--frames", str(data / "robot2_frames.csv"),
    ]  # fmt: skip
    assert main(argv) == 0
    assert "what the data allow" not in capsys.readouterr().out  # no ground truth
    gt = ["--groundtruth", str(data / "robot2_groundtruth_10hz.csv")]
    assert main([*argv, *gt]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if "what the data allow" in s)
    # Robot 2 sees four tubes in its first seconds: a localizer told them is sure at once.
    after = float(line.split("(")[2].split(" s after")[0])
    assert 0.0 <= after < 10.0 and "% of the frames" in line
    # A camera off the centre: the bound takes its bearings from where the camera is.
    assert main([*argv, *gt, "--mount", "0.1,0.03,0.6"]) == 0
    seated = next(s for s in capsys.readouterr().out.splitlines() if "what the data allow" in s)
    assert "sure enough to be localized from t = " in seated
    # A map that lacks a tube the frames name: the run goes on, without the bound.
    lines = (data / "landmarks.csv").read_text().splitlines()
    kept = [s for s in lines if not s.startswith("15,")]  # tube 15, in robot 2's first frame
    assert len(kept) == len(lines) - 1
    (tmp_path / "fewer.csv").write_text("\n".join(kept) + "\n")
    fewer = [*argv[:3], str(tmp_path / "fewer.csv"), *argv[4:], *gt]
    assert main(fewer) == 0
    out = capsys.readouterr().out
    assert "against the ground truth" in out or "frames over" in out
    assert "what the data allow" not in out


def test_the_last_line_says_when_the_tracker_was_last_localized() -> None:
    from omniloc import Pose
    from omniloc.cli import _last_frame_line
    from omniloc.track import TrackEstimate, TrackState

    pose = Pose(1.0, 2.0, 0.5)
    amb = TrackEstimate(
        9.0, TrackState.AMBIGUOUS, pose, reason="two places", confidence=0.25, since_localized=3.25
    )
    assert _last_frame_line(amb) == (
        "last frame: ambiguous: x = 1.000 m, y = 2.000 m, theta = 28.65 deg, last localized "
        "3.2 s before, confidence 0.2500 (two places)"
    )
    lost = TrackEstimate(9.0, TrackState.LOST, reason="nothing fits", since_localized=12.0)
    assert _last_frame_line(lost) == (
        "last frame: lost: no pose, last localized 12.0 s before (nothing fits)"
    )
    never = TrackEstimate(9.0, TrackState.LOST, reason="waking up")
    assert _last_frame_line(never) == "last frame: lost: no pose (waking up)"
    # Localized now: no "last localized".
    loc = TrackEstimate(9.0, TrackState.LOCALIZED, pose, reason="r", since_localized=0.0)
    assert "last localized" not in _last_frame_line(loc)
