from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from omniloc.cli import main
from omniloc.pose import Pose, predict_bearings
from omniloc.simulate import demo_room

ROOM_POSE = Pose(5.6, 2.1, np.deg2rad(30))
SEEN = [10, 3, 0, 6, 8, 4]


@pytest.fixture
def room_files(tmp_path: Path) -> tuple[Path, Path]:
    lm = demo_room()
    map_path = tmp_path / "room.csv"
    lm.to_csv(map_path)
    z = np.rad2deg(predict_bearings(lm.xy[SEEN], ROOM_POSE))
    b_path = tmp_path / "bearings.txt"
    b_path.write_text("# degrees\n" + "\n".join(f"{v:.6f}" for v in z) + "\n")
    return map_path, b_path


def test_localize_human_output(room_files, capsys) -> None:
    m, b = room_files
    assert main(["localize", "--map", str(m), "--bearings", str(b), "--degrees"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("1 solution for 6 bearings")
    assert "x = 5.600 m, y = 2.100 m, theta = 30.000 deg" in out
    assert "landmarks [11, 4, 1, 7, 9, 5]" in out


def test_localize_json(room_files, capsys) -> None:
    m, b = room_files
    code = main(["localize", "--map", str(m), "--bearings", str(b), "--degrees", "--json"])
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    (sol,) = data["solutions"]
    assert set(sol) >= {"x", "y", "theta", "assignment", "residual_rms"}
    assert sol["x"] == pytest.approx(5.6) and sol["theta"] == pytest.approx(np.deg2rad(30))
    assert sol["assignment"] == [11, 4, 1, 7, 9, 5]
    assert data["stats"]["total_paths"] == 665280
    assert data["ambiguous"] is False and data["complete"] is True


def test_localize_with_robust_options_and_plot(room_files, tmp_path, capsys) -> None:
    m, b = room_files
    png = tmp_path / "out" / "sol.png"
    args = ["localize", "--map", str(m), "--bearings", str(b), "--degrees", "--sigma", "0.3"]
    args += ["--max-spurious", "1", "--ordering", "--plot", str(png), "--json"]
    assert main(args) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["solutions"][0]["assignment"] == [11, 4, 1, 7, 9, 5]
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("strategy", ["tree", "hypotheses"])
def test_localize_strategy_and_first_fit(room_files, capsys, strategy: str) -> None:
    m, b = room_files
    args = ["localize", "--map", str(m), "--bearings", str(b), "--degrees", "--sigma", "0.3"]
    assert main([*args, "--strategy", strategy]) == 0
    assert "x = 5.600 m, y = 2.100 m" in capsys.readouterr().out
    if strategy == "hypotheses":
        assert main([*args, "--first-fit"]) == 0
        out = capsys.readouterr().out
        # A first fit does not look for rivals: whatever it finds, it does not call decisive.
        assert "AMBIGUOUS: first fit, rivals not sought" in out


def test_human_output_says_why_an_answer_is_not_decisive(tmp_path, capsys) -> None:
    # Four bearings on a map of 400 landmarks: many poses fit about as well.
    from omniloc.simulate import observe, random_map, random_pose

    lm = random_map(400, density=0.05, rng=3)
    sc = observe(lm, random_pose(lm, rng=4), n_obs=4, max_range=10.0, rng=5)
    m, b = tmp_path / "map.csv", tmp_path / "b.txt"
    lm.to_csv(m)
    b.write_text("\n".join(f"{v:.9f}" for v in sc.bearings) + "\n")
    args = ["localize", "--map", str(m), "--bearings", str(b), "--sigma", "0.01"]
    assert main([*args, "--max-range", "10"]) == 0
    out = capsys.readouterr().out
    assert "AMBIGUOUS" in out and ("distinct poses compete" in out or "chance fit" in out)


def test_human_output_says_when_one_pose_cannot_rule_out_a_chance_fit(tmp_path, capsys) -> None:
    # Four bearings, 12 landmarks, no range: one pose fits and holds 99 % of the posterior
    # among the fits found, but four bearings are too few to rule out that it is a chance fit
    # and the truth lies where the search found nothing.
    from omniloc.simulate import observe, random_map, random_pose

    lm = random_map(12, density=0.05, rng=15)
    sc = observe(lm, random_pose(lm, rng=16), n_obs=4, rng=17)
    m, b = tmp_path / "map.csv", tmp_path / "b.txt"
    lm.to_csv(m)
    b.write_text("\n".join(f"{v:.12f}" for v in sc.bearings) + "\n")
    assert main(["localize", "--map", str(m), "--bearings", str(b), "--sigma", "0.01"]) == 0
    out = capsys.readouterr().out
    assert "AMBIGUOUS" in out and "too little to rule out that none is right" in out
    assert "distinct poses compete" not in out


def test_no_solution_is_a_sentence_and_exit_0(tmp_path, capsys) -> None:
    m = tmp_path / "sq.csv"
    m.write_text("id,x,y\n1,0,0\n2,6,0\n3,6,6\n4,0,6\n")
    b = tmp_path / "b.json"
    b.write_text(json.dumps({"bearings": [0, 5, 10, 180], "units": "deg"}))
    assert main(["localize", "--map", str(m), "--bearings", str(b)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("No pose is consistent with these 4 bearings")
    assert main(["localize", "--map", str(m), "--bearings", str(b), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["solutions"] == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["localize", "--map", "missing.csv", "--bearings", "b.txt"], "missing.csv"),
        (["localize", "--map", "{map}", "--bearings", "{bad}"], "line 2"),
        (["localize", "--map", "{map}", "--bearings", "{few}"], "at least 3"),
        (["localize", "--map", "{map}", "--bearings", "{deg}"], "--degrees"),
        (["localize", "--map", "{map}", "--bearings", "{b}", "--threshold", "x"], "threshold"),
        (["localize", "--map", "{map}"], "required"),
        (["localize", "--map", "{map}", "--bearings", "{b}", "--method", "x"], "method"),
        (["localize", "--map", "{map}", "--bearings", "{b}", "--sigma", "-1"], "sigma"),
        (["localize", "--map", "{map}", "--bearings", "{b}", "--fov", "400"], "--fov"),
        (["localize", "--map", "{map}", "--bearings", "{b}", "--p-miss", "1"], "--p-miss"),
        (["localize", "--map", "{map}", "--bearings", "{b}", "--timeout", "0"], "--timeout"),
        (["evaluate", "--dataset", "roh", "{bad}", "--max-samples", "0"], "max_samples"),
        (["evaluate", "--dataset", "roh", "{nowhere}"], "no such folder or file"),
        (["localize", "--map", "{map}", "--image", "{bad}"], "bad.txt"),
        (["bearings", "{bad}"], "bad.txt"),
        (["nonsense"], "invalid choice"),
        (["evaluate", "--dataset", "nope", "{bad}"], "nope"),
    ],
)
def test_bad_input_is_one_line_and_exit_1(room_files, tmp_path, capsys, args, message) -> None:
    m, b = room_files
    bad = tmp_path / "bad.txt"
    bad.write_text("1.0\nabc\n")
    few = tmp_path / "few.txt"
    few.write_text("1.0 2.0\n")
    deg = tmp_path / "deg.txt"
    deg.write_text("30 -45 170\n")
    subst = {"{map}": str(m), "{b}": str(b), "{bad}": str(bad), "{few}": str(few)}
    subst["{deg}"] = str(deg)
    subst["{nowhere}"] = str(tmp_path / "nowhere")
    argv = [subst.get(a, a) for a in args]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err.startswith("error:") and message in err


def test_bearings_and_localize_from_an_image(tmp_path, capsys) -> None:
    import cv2

    from omniloc.maps import LandmarkMap
    from omniloc.vision import DEMO_POSE, demo_scene, render_omni_image

    scene = demo_scene()
    img_path = tmp_path / "omni.png"
    cv2.imwrite(str(img_path), render_omni_image(scene, DEMO_POSE, rng=1))
    assert main(["bearings", str(img_path), "--json", "--plot", str(tmp_path / "b.png")]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["detections"]) >= 12 and data["units"] == "radians"
    assert (tmp_path / "b.png").stat().st_size > 10_000
    map_path = tmp_path / "scene.csv"
    LandmarkMap(scene.landmarks_xy).to_csv(map_path)
    argv = ["localize", "--map", str(map_path), "--image", str(img_path), "--sigma", "0.1"]
    assert main([*argv, "--json"]) == 0
    best = json.loads(capsys.readouterr().out)["solutions"][0]
    assert np.hypot(best["x"] - DEMO_POSE[0], best["y"] - DEMO_POSE[1]) < 0.05
    assert abs(np.angle(np.exp(1j * (best["theta"] - DEMO_POSE[2])))) < np.deg2rad(0.5)


def test_bearings_reports_ambiguous_edges(tmp_path, capsys) -> None:
    import cv2

    from omniloc.vision import extract_bearings, render_omni_image
    from omniloc.vision.render import random_stripe_scene

    scene, pose = random_stripe_scene(7)
    image = render_omni_image(scene, pose, rng=7)
    det = extract_bearings(image)
    assert 0 < det.ambiguous.sum() < len(det)
    img_path = tmp_path / "stripes.png"
    cv2.imwrite(str(img_path), image)
    assert main(["bearings", str(img_path), "--json"]) == 0
    found = json.loads(capsys.readouterr().out)["detections"]
    assert [d["ambiguous"] for d in found] == det.ambiguous.tolist()
    assert main(["bearings", str(img_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = lines[1 : 1 + len(det)]
    assert [r.endswith("  ambiguous") for r in rows] == det.ambiguous.tolist()
    assert lines[-1].startswith(f"({int(det.ambiguous.sum())} ambiguous:")


def test_bearings_json_feeds_localize_as_the_image_does(tmp_path, capsys) -> None:
    # The two steps (bearings --json, then localize --bearings on that file) give the answer
    # of localize --image: the same bearings, and the ambiguous edges allowed as spurious.
    import cv2

    from omniloc.maps import LandmarkMap
    from omniloc.vision import render_omni_image
    from omniloc.vision.render import random_stripe_scene

    scene, pose = random_stripe_scene(7)
    img_path = tmp_path / "stripes.png"
    cv2.imwrite(str(img_path), render_omni_image(scene, pose, rng=7))
    map_path = tmp_path / "scene.csv"
    LandmarkMap(scene.landmarks_xy).to_csv(map_path)
    for units in ([], ["--degrees"]):
        assert main(["bearings", str(img_path), "--json", *units]) == 0
        det_path = tmp_path / "det.json"
        det_path.write_text(capsys.readouterr().out)
        answers = []
        for source in (["--image", str(img_path)], ["--bearings", str(det_path)]):
            argv = ["localize", "--map", str(map_path), *source, "--sigma", "0.1", "--json"]
            assert main(argv) == 0
            out = json.loads(capsys.readouterr().out)
            answers.append((out["bearings"], out["solutions"][0], out["ambiguous"]))
        np.testing.assert_allclose(answers[1][0], answers[0][0], atol=1e-12)
        assert answers[1][1]["assignment"] == answers[0][1]["assignment"]
        assert answers[1][2] == answers[0][2]


def test_demo_runs_and_writes_figures(tmp_path, capsys) -> None:
    assert main(["demo", "--out", str(tmp_path), "--no-vision"]) == 0
    out = capsys.readouterr().out
    assert "| 7 | 3991680 |" in out and "| 4 | 11880 |" in out
    assert out.count("| yes |") == 4
    for m in (4, 5, 6, 7):
        assert (tmp_path / f"solutions-{m}-observations.png").stat().st_size > 10_000
    # Over time: the example recording's time line, wake-up to recovery, and its figure.
    lines = out[out.index("Over time (omniloc.track)") :].splitlines()
    states = [ln.split()[2] for ln in lines[1:] if ln.startswith("  ") and " s  " in ln]
    assert states == ["ambiguous", "localized", "ambiguous", "KIDNAPPED", "ambiguous", "localized"]
    # The flag says what the old place and the places held now explain of the bearings since.
    assert "explains 2 of the 8 bearings since (the places it holds now: 5): kidnapped" in out
    assert "localized in 216 of 240 frames, right (0.3 m, 5 deg) in 216 of them" in out
    # Offline, the pass backward localizes the frames before each sure one as well.
    assert (
        "offline, with the pass backward (--backward 20): localized in 228 of 240 frames "
        "(52 by the pass backward; 40 localized forward at a place given up within 10 s "
        "after), right in 228 of them" in out
    )
    assert (tmp_path / "track.png").stat().st_size > 10_000


def test_version(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert "omniloc" in capsys.readouterr().out


def test_human_output_lists_at_most_twenty_solutions(tmp_path, capsys) -> None:
    m = tmp_path / "sq.csv"
    m.write_text("id,x,y\n" + "".join(f"{i},{i % 6},{i // 6}\n" for i in range(36)))
    b = tmp_path / "b.txt"
    b.write_text("0\n90\n180\n")
    assert main(["localize", "--map", str(m), "--bearings", str(b), "--degrees"]) == 0
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if ln.startswith("  #")]
    assert len(lines) == 20
    assert "more (all of them with --json)" in out


def test_localize_takes_the_clutter_by_detections(room_files, capsys) -> None:
    # The CLI hands the table to the library: the same confidences as the library's call.
    import omniloc

    m, b = room_files
    z = np.deg2rad(
        [float(f"{v:.6f}") for v in np.rad2deg(predict_bearings(demo_room().xy[SEEN], ROOM_POSE))]
    )
    args = ["localize", "--map", str(m), "--bearings", str(b), "--degrees", "--sigma", "0.5"]
    args += ["--max-spurious", "1", "--clutter", "0.3", "--json"]
    assert main([*args, "--clutter-by-detections", "0.2, 0.3,1.5"]) == 0
    data = json.loads(capsys.readouterr().out)
    want = omniloc.localize(
        demo_room(), z, sigma=np.deg2rad(0.5), max_spurious=1,
        clutter=0.3, clutter_by_detections=(0.2, 0.3, 1.5),
    )  # fmt: skip
    got = [s["confidence"] for s in data["solutions"]]
    assert got == pytest.approx([s.confidence for s in want.solutions], rel=1e-9)
    assert main([*args, "--clutter-by-detections", "0.2,x"]) == 1
    err = capsys.readouterr().err
    assert "--clutter-by-detections" in err and len(err.strip().splitlines()) == 1


def test_python_dash_m_runs_the_command_line() -> None:
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-m", "omniloc", "--version"], capture_output=True, text=True, check=False
    )
    assert out.returncode == 0 and out.stdout.startswith("omniloc"), out.stderr
    bad = subprocess.run(
        [
            sys.executable,
            "-m",
            "omniloc",
            "localize",
            "--map",
            "no-such-map.csv",
            "--bearings",
            "x",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 1 and "no-such-map.csv" in bad.stderr


@pytest.mark.parametrize("command", ["bearings", "localize"])
def test_output_into_a_closed_pipe_ends_quietly(command: str, room_files, tmp_path) -> None:
    # `omniloc ... | head -3`: the reader is gone before the output is written.
    import os
    import subprocess
    import sys

    import cv2

    import omniloc
    from omniloc.vision import DEMO_POSE, demo_scene, render_omni_image

    m, b = room_files
    if command == "bearings":
        img_path = tmp_path / "omni.png"
        cv2.imwrite(str(img_path), render_omni_image(demo_scene(), DEMO_POSE, rng=1))
        argv = ["bearings", str(img_path), "--json"]
    else:
        argv = ["localize", "--map", str(m), "--bearings", str(b), "--degrees"]
    env = {**os.environ, "PYTHONPATH": str(Path(omniloc.__file__).parents[1])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "omniloc", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait(timeout=120) == 1
    assert err == ""
