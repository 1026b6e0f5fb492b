"""benchmarks/track_speed.py: each MRCLAM run alone, elapsed and processor time, written as
JSON and Markdown."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import track_speed  # noqa: E402

pytestmark = pytest.mark.skipif(
    not (track_speed.DATA / "robot1_frames.csv").is_file(),
    reason="the MRCLAM recordings are not here",
)


def test_times_the_first_frames_of_a_run_and_writes_both_files(tmp_path: Path) -> None:
    out = tmp_path / "speed"
    assert track_speed.main(["--robots", "2", "--frames", "120", "--out", str(out)]) == 0
    data = json.loads(out.with_suffix(".json").read_text())
    (row,) = data["runs"]
    assert row["robot"] == 2 and row["frames"] == 120
    assert row["wall_s"] > 0 and row["cpu_s"] > 0 and row["duration_s"] > 0
    assert row["realtime_factor"] == pytest.approx(row["duration_s"] / row["wall_s"])
    assert data["total"]["wall_s"] == pytest.approx(row["wall_s"])
    assert data["meta"]["command"].startswith("python benchmarks/track_speed.py --robots 2")
    md = out.with_suffix(".md").read_text()
    assert "| robot2 |" in md and "120" in md
    ref = data["reference_ms"]
    assert set(ref) == {"before", "after"}
    assert all(ref[k][w] > 0 for k in ref for w in ("python_ms", "numpy_ms"))
    assert "the reference workload took" in md


def test_against_times_two_trees_alternately_each_from_its_own_src(tmp_path: Path) -> None:
    # A copy of this checkout's src stands for another tree: each run must import the tree it
    # was given (the first check refuses a tree whose omniloc is someone else's).
    import shutil

    src = Path(track_speed.__file__).resolve().parents[1] / "src"
    other = tmp_path / "other" / "src"
    shutil.copytree(src / "omniloc", other / "omniloc", ignore=shutil.ignore_patterns("*.pyc"))
    out = tmp_path / "speed"
    argv = ["--robots", "4", "--frames", "60", "--repeat", "2", "--against", str(other)]
    assert track_speed.main([*argv, "--out", str(out)]) == 0
    data = json.loads((tmp_path / "speed_against.json").read_text())
    (row,) = data["robots"]
    assert row["robot"] == 4 and len(row["here_s"]) == 2 and len(row["other_s"]) == 2
    assert all(t > 0 for t in row["here_s"] + row["other_s"])
    assert data["meta"]["against"] == str(other.resolve())
    # a folder without omniloc is named, not timed
    with pytest.raises(SystemExit, match="no omniloc package"):
        track_speed.main(["--robots", "4", "--against", str(tmp_path), "--out", str(out)])


def test_a_run_that_imports_another_tree_is_refused(tmp_path: Path) -> None:
    # A tree whose omniloc package is a stub that imports this checkout's: the check names it.
    stub = tmp_path / "src" / "omniloc"
    stub.mkdir(parents=True)
    real = Path(track_speed.__file__).resolve().parents[1] / "src"
    (stub / "__init__.py").write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(real)!r})\n"
        "del sys.modules['omniloc']\n"
        "import omniloc as _real\n"
        "sys.modules['omniloc'] = _real\n"
    )
    with pytest.raises(SystemExit, match="not from"):
        track_speed.run_in(stub.parent, track_speed.DATA, 4, 30)
