"""benchmarks/track_oracle_limits.py: how soon a localizer told the correspondences could
know the pose on the MRCLAM runs (the method is omniloc.evaluate.bounds, tested in
test_evaluate_bounds.py)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import track_oracle_limits as tol  # noqa: E402
from omniloc.evaluate.bounds import MRCLAM_REPEATING, RepeatingErrors  # noqa: E402

MRCLAM = Path(__file__).resolve().parents[2] / "shared" / "data" / "mrclam-ds6"


@pytest.mark.skipif(not MRCLAM.is_dir(), reason="the MRCLAM recordings are not here")
def test_the_script_bounds_the_recordings(tmp_path: Path) -> None:
    out = tmp_path / "oracle.json"
    assert tol.main([str(MRCLAM), "--robots", "4", "--every", "60", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["runs"]["robot4"]["frames"] > 1000
    assert len(data["bounds"]) == len(tol.ERROR_MODELS) * len(tol.PROBABILITIES)
    for b in data["bounds"].values():
        first = b["first_from_first_frame_s"]["robot4"]
        assert first == b["first_median_s"] and (first is None or first >= 0)
        a = b["from_any_start"]
        assert a["starts"] >= 10 and 0 <= a["within_10_s"] <= a["within_15_s"] <= 1
        assert 0 <= b["confident_after_first"]["robot4"] <= 1
    # The sharper error model never needs longer from the run's start; a looser
    # probability never longer either; the same errors repeating as measured are the
    # evaluation's model, written out in full.
    g, m, r = (data["bounds"][f"{k}, p >= 0.99"] for k in tol.ERROR_MODELS)
    assert m["first_median_s"] <= g["first_median_s"]
    assert m["repeating"] is None
    assert RepeatingErrors(**r["repeating"]) == MRCLAM_REPEATING
    loose = data["bounds"][f"{next(iter(tol.ERROR_MODELS))}, p >= 0.9"]
    assert loose["first_median_s"] <= g["first_median_s"]


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(SystemExit):
        tol.main(["--every", "0"])
    with pytest.raises(SystemExit):
        tol.main(["--horizon", "-1"])
