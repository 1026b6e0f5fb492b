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
