"""benchmarks/track_baselines_seeds.py: the ranges over seeds it reports, and its errors."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import track_baselines_seeds
from test_track_cli import _truncated_mrclam
from track_baselines_seeds import _job, _span, main, markdown, table


def _row(
    name: str, kind: str, seed: int, ttl: float, correct: float, streams: str = "whole runs"
) -> dict[str, object]:
    return {
        "localizer": name,
        "kind": kind,
        "particles": 0 if kind == "tracker" else 2000,
        "seed": seed,
        "streams": streams,
        "n_streams": 5 if streams == "whole runs" else 20,
        "recovered": 3.0 if streams == "kidnapped" else math.nan,
        "false_alarm_run_rate": 0.05 if streams == "plain" else math.nan,
        "time_to_localize_median_s": ttl,
        "never_localized": 0.0 if math.isfinite(ttl) else 5.0,
        "correct_after_rate": 0.336,
        "correct_rate": correct,
        "confidently_wrong_rate": 0.0005,
        "pos_rmse_m": 0.106,
        "cpu_per_s": 0.009,
    }


def test_a_range_over_seeds_says_how_many_never_got_there() -> None:
    assert _span("time_to_localize_median_s", [396.6, 142.2, math.inf]) == (
        "142.2 - 396.6 (1 never)"
    )
    assert _span("correct_rate", [0.162, 0.162]) == "16.2 %"
    assert _span("time_to_localize_median_s", [math.inf, math.inf]) == "never"
    assert _span("confidently_wrong_rate", [0.0, 0.0012]) == "0.00 % - 0.12 %"


def test_the_tables_list_each_seed_then_the_range_the_tracker_first() -> None:
    rows = [
        _row("PF 2,000", "pf", 1, math.inf, 0.150),
        _row("omniloc Tracker", "tracker", 1, 142.2, 0.170),
        _row("PF 2,000", "pf", 0, 657.6, 0.155),
        _row("omniloc Tracker", "tracker", 0, 396.6, 0.162),
        _row("omniloc Tracker", "tracker", 0, math.inf, 0.076, "kidnapped"),
        _row("omniloc Tracker", "tracker", 0, math.inf, 0.147, "plain"),
    ]
    md = table(rows, [0, 1])
    each, over = md.split("**Over seeds 0, 1**")
    lines = [ln for ln in each.splitlines() if ln.startswith("| omniloc") or ln.startswith("| PF")]
    assert [ln.split(" | ")[:3] for ln in lines] == [
        ["| omniloc Tracker", "whole runs (5)", "0"],
        ["| omniloc Tracker", "whole runs (5)", "1"],
        ["| PF 2,000", "whole runs (5)", "0"],
        ["| PF 2,000", "whole runs (5)", "1"],
        ["| omniloc Tracker", "kidnapped (20)", "0"],
        ["| omniloc Tracker", "plain (20)", "0"],
    ]
    assert "| never |" in lines[3]
    # The whole runs have no kidnapping to recover from nor plain streams to flag: "-".
    assert lines[0].endswith("| - | - | 0.0090 |")
    assert "| 3 | - |" in lines[4] and "| - | 5.0 % |" in lines[5]
    assert "| omniloc Tracker | whole runs (5) | 2 seeds | 142.2 - 396.6 |" in over
    assert "| PF 2,000 | whole runs (5) | 2 seeds | 657.6 (1 never) |" in over
    assert "15.0 % - 15.5 %" in over
    assert "| omniloc Tracker | kidnapped (20) | 1 seeds | never |" in over


def test_the_markdown_reads_the_json_file_s_rows_with_their_nulls() -> None:
    row = _row("omniloc Tracker", "tracker", 0, math.inf, 0.162)
    written = {
        k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()
    }
    meta = {
        "date": "2026-12-06T09:33:09+00:00",
        "machine": "x86_64",
        "command": "python benchmarks/track_baselines_seeds.py",
        "wall_s": 1286,
        "seeds": [0],
        "streams": 20,
        "large_streams": 4,
    }
    md = markdown(meta, [written])
    assert md == markdown(meta, [row])
    assert "20 kidnapped and 20 plain streams" in md and "the first 4 of each" in md
    assert "| omniloc Tracker | whole runs (5) | 0 | never |" in md


def test_a_missing_recording_or_a_bad_count_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SystemExit, match="no MRCLAM set 6 at"):
        main(["--data", str(tmp_path)])
    (tmp_path / "landmarks.csv").write_text("x,y\n0,0\n")
    with pytest.raises(SystemExit, match="--particles: comma-separated whole numbers"):
        main(["--data", str(tmp_path), "--particles", "2k"])
    with pytest.raises(SystemExit, match="--workers must be at least 1"):
        main(["--data", str(tmp_path), "--workers", "0"])
    with pytest.raises(SystemExit, match="--streams and --large-streams must be at least 0"):
        main(["--data", str(tmp_path), "--streams", "-1"])


def test_a_job_scores_each_kind_of_stream_apart(
    shared_data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The five runs cut to their first 400 s, one kidnapped and one plain stream, a filter of
    # 200 particles (a few seconds): one row per kind of stream, each with its own counts.
    data = _truncated_mrclam(tmp_path / "mrclam", 400.0)
    rows = _job("pf", 200, 0, str(data), 1, 1)
    assert [(r["streams"], r["n_streams"]) for r in rows] == [
        ("whole runs", 5),
        ("kidnapped", 1),
        ("plain", 1),
    ]
    for r in rows:
        assert r["correct_rate"] == pytest.approx(
            (r["localized_frames"] / r["frames_scored"]) - r["confidently_wrong_rate"]
        )
        assert 0.0 <= r["confidently_wrong_rate"] <= r["localized_frames"] / r["frames_scored"]
    # Recoveries only where there was a jump; false alarms only where there was none.
    assert [math.isnan(r["recovered"]) for r in rows] == [True, False, True]
    assert [math.isnan(r["false_alarm_run_rate"]) for r in rows] == [False, True, False]
    # From LARGE particles on, only the first --large-streams streams of each kind.
    monkeypatch.setattr(track_baselines_seeds, "LARGE", 100)
    assert [r["streams"] for r in _job("pf", 200, 0, str(data), 1, 0)] == ["whole runs"]


def test_tracker_only_keeps_the_filter_s_rows_and_says_when_they_were_measured(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The jobs run in threads here, and a tracker job is a stand-in row: what is checked is
    # how --tracker-only merges, not the tracker.
    from concurrent.futures import ThreadPoolExecutor

    jobs: list[tuple[str, int]] = []

    def job(kind: str, n: int, seed: int, *_: object) -> list[dict[str, object]]:
        jobs.append((kind, seed))
        return [{**_row("omniloc Tracker", kind, seed, 142.0, 0.151), "wall_s": 1.0}]

    monkeypatch.setattr(track_baselines_seeds, "ProcessPoolExecutor", ThreadPoolExecutor)
    monkeypatch.setattr(track_baselines_seeds, "_job", job)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "landmarks.csv").write_text("x,y\n0,0\n")
    out = tmp_path / "seeds.json"
    args = ["--data", str(tmp_path / "data"), "--out", str(out), "--seeds", "0", "1"]
    # No results file to take the filter's rows from, or one without them: refused.
    with pytest.raises(SystemExit, match="--tracker-only reads the filter's rows from"):
        main([*args, "--tracker-only"])
    old_rows = [_row("PF 2,000 particles", "pf", s, 600.0, 0.155) for s in (0, 1)] + [
        _row("omniloc Tracker", "tracker", s, 396.6, 0.162) for s in (0, 1)
    ]
    meta = {"date": "2026-12-06T09:33", "command": "x", "wall_s": 1286, "seeds": [0, 1]}
    out.write_text(
        json.dumps({"meta": {**meta, "streams": 20, "large_streams": 4}, "rows": old_rows})
    )
    with pytest.raises(SystemExit, match="no filter rows for seeds \\[0\\], 20 streams"):
        main([*args[:-1], "--tracker-only"])  # another set of seeds than the file's
    assert main([*args, "--tracker-only"]) == 0
    assert sorted(jobs) == [("tracker", 0), ("tracker", 1)]
    new = json.loads(out.read_text())
    kept = [r for r in new["rows"] if r["kind"] == "pf"]
    assert [r["correct_rate"] for r in kept] == [0.155, 0.155]
    assert [r["correct_rate"] for r in new["rows"] if r["kind"] == "tracker"] == [0.151, 0.151]
    assert new["meta"]["filter_rows_from"] == "2026-12-06T09:33 (x, 1286 s)"
    assert (
        "(the filter's rows from 2026-12-06T09:33 (x, 1286 s))"
        in out.with_suffix(".md").read_text()
    )
    # Run again on its own output: the filter's rows keep the date they were measured on.
    assert main([*args, "--tracker-only"]) == 0
    again = json.loads(out.read_text())
    assert again["meta"]["filter_rows_from"] == "2026-12-06T09:33 (x, 1286 s)"
    assert [r["kind"] for r in again["rows"]].count("pf") == 2
