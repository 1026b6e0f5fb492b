"""benchmarks/track_backward.py: a job's figures (the forward pass and the pass backward on
the same estimates), and the table it writes."""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from test_track_cli import _truncated_mrclam
from track_backward import _label, _range, _share, job, table


def _variant(localized: int, wrong: int, first: float, back: int = 0) -> dict[str, object]:
    return {
        "whole runs": {
            "backward_frames": back,
            "backward_right": back - wrong,
            "backward_conf_sum": 0.95 * back,
            "frames": 1000,
            "localized": localized,
            "wrong": wrong,
            "right_share": (localized - wrong) / 1000,
            "first_correct_median_s": first,
            "correct_after": 0.5,
            "pos_rmse_m": 0.1,
            "false_alarm_run_rate": math.nan,
            "recovered": None,
            "cpu_per_s": 0.01,
        }
    }


def test_the_table_gives_totals_and_ranges_over_the_seeds() -> None:
    jobs = [
        {
            "seed": 0,
            "variants": {"forward": _variant(100, 0, 50.0), "20": _variant(180, 1, 40.0, 80)},
        },
        {
            "seed": 1,
            "variants": {"forward": _variant(120, 2, math.inf), "20": _variant(200, 3, 45.0, 80)},
        },
    ]
    lines = table(jobs, ["forward", "20"])
    text = "\n".join(lines)
    assert lines[0] == "| over the seeds | the forward pass alone | with the pass backward, 20 s |"
    # (100 + 120 - 2) of 2,000 frames right, 2 wrong; (180 + 200 - 4) of 2,000, 4 wrong.
    assert (
        "| whole runs: localized and right, share of all frames (wrong frames) | 10.9 % (2) "
        "| 18.8 % (4) |" in text
    )
    assert (
        "| whole runs: first correct, median over the runs (s) | 50.0-never | 40.0-45.0 |" in text
    )
    assert "kidnapped" not in text  # no such streams in these jobs
    # The frames the pass reported: 160, of them 160 - 4 right, reporting 0.95 on average.
    assert (
        "| whole runs: frames the pass backward reports, right (their mean confidence) | - "
        "| 160, 97.5 % (0.950) |" in text
    )
    assert _range([0.1, None, math.nan], ".2f") == "0.10"
    assert _range([], ".2f") == "-"
    assert _share(0, 0, 0) == "-"


def test_a_job_scores_the_forward_pass_and_the_pass_backward(
    shared_data: Path, tmp_path: Path
) -> None:
    # The five runs cut to their first 200 s (robot 3 is sure of its place within a minute),
    # no kidnapped streams: the pass backward localizes more frames of the same estimates.
    data = _truncated_mrclam(tmp_path / "mrclam", 200.0)
    out = job(str(data), 0, [20.0], 0, [20.0])
    fwd, back = out["variants"]["forward"]["whole runs"], out["variants"]["20"]["whole runs"]
    every = out["variants"]["20/all"]["whole runs"]
    assert set(out["variants"]) == {"forward", "20", "20/all"}
    assert every["frames"] == fwd["frames"] and every["localized"] > fwd["localized"]
    assert len(out["added_wrong"]["20/all"]) == every["wrong"] - fwd["wrong"]
    assert set(out["variants"]["forward"]) == {"whole runs"}
    assert fwd["frames"] == back["frames"] and fwd["localized"] > 0
    assert back["localized"] > fwd["localized"]
    assert back["cpu_per_s"] > fwd["cpu_per_s"]
    # Every wrong frame it lists was added by the pass backward, and is counted.
    assert len(out["added_wrong"]["20"]) == back["wrong"] - fwd["wrong"]
    for w in out["added_wrong"]["20"]:
        assert w["position_m"] > 0.3 or w["heading_deg"] > 5.0
    # The frames it reports: every one localized, counted with the wrong ones among them,
    # and each carries a confidence, summed (which table gives it is
    # test_track_backward's test_on_mrclam_the_frames_of_the_pass_read_the_presets_table_for_them).
    assert back["backward_frames"] > 0
    assert back["backward_right"] == back["backward_frames"] - len(out["added_wrong"]["20"])
    n_back = back["backward_frames"]
    assert 0.9 * n_back < back["backward_conf_sum"] <= n_back
    lines = table([out], ["forward", "20", "20/all"])
    assert lines[2].startswith("| whole runs: localized and right")
    assert lines[0].endswith("| with the pass backward, 20 s, from every sure frame |")
    assert _label("forward") == "the forward pass alone"
    assert _label("10") == "with the pass backward, 10 s"
