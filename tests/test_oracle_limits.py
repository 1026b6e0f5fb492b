"""benchmarks/oracle_limits.py: the true pairs' pose of the large-map scenes against the
benchmark's tolerance."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import oracle_limits  # noqa: E402


def test_counts_the_trials_whose_true_pairs_miss_the_tolerance(tmp_path: Path) -> None:
    out = tmp_path / "oracle.json"
    # Scene (c) trials 0-41: trial 41's true pairs give a pose 0.18 m off.
    assert oracle_limits.main(["--scene", "c", "--trials", "42", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    c = data["scenes"]["c"]
    assert c["trials"] == 42 and c["beyond_tolerance"] == len(c["beyond"]) >= 1
    assert c["at_most_right"] == 42 - c["beyond_tolerance"]
    (t41,) = [r for r in c["beyond"] if r["trial"] == 41]
    assert t41["error_m"] == pytest.approx(0.184, abs=0.005) and t41["pairs"] == 6
    assert all(r["error_m"] > 0.1 or r["error_deg"] > 1.0 for r in c["beyond"])
    assert data["meta"][
        "command"
    ] == "python benchmarks/oracle_limits.py --scene c --trials 42 --out " + str(out)


def test_the_errors_are_those_of_refine_pose_on_the_true_pairs() -> None:
    (row,) = oracle_limits.oracle_errors("cgrid", 1)
    assert row["trial"] == 0 and row["pairs"] >= 4
    assert 0.0 <= row["error_m"] < 0.1 and row["crlb_pos_sd_m"] > 0.0
