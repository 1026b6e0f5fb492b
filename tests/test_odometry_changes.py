"""benchmarks/odometry_changes.py: the odometry's heading error by the changes of its turn
rate, and how often each motion model's heading variance holds it."""

from __future__ import annotations

import sys
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from _odometry import lagging_recording
from odometry_changes import by_changes, changes, coverage
from omniloc.track import GroundTruth, MotionModel, Odometry

#: The simulated robot's latency, and a model of it without noise on the distance.
AT = MotionModel(
    along_per_m=0.0, across_per_m=0.0, turn_per_rad=0.0, turn_per_m=0.0, turn_per_s=1e-5,
    along_per_s=0.0, delay_s=0.2,
)  # fmt: skip


@cache
def _runs(delay_var: float) -> list[tuple[Odometry, GroundTruth]]:
    return [lagging_recording(delay_var)]


def test_changes_are_counted_between_the_pieces_that_move() -> None:
    dt = np.array([0.1, 0.0, 0.1, 0.1])
    w = np.array([0.5, 9.0, -0.5, -0.5])
    assert changes(w, dt) == pytest.approx(1.0)


def test_the_variance_per_change_is_the_robots_response_variance() -> None:
    # A robot whose response to each change varies by 0.063 s (delay_var 0.004): the squared
    # heading error grows by about that per (rad/s)^2 of change, over 1- and 2-s windows
    # (a little low, as the fit reads it: a change just outside a window whose response falls
    # inside it is not among its changes); one that answers on time, by none.
    for length in (1.0, 2.0):
        row = by_changes(_runs(0.004), length, AT)
        assert row["fit"]["per_change"] == pytest.approx(0.004, rel=0.2)  # type: ignore[index]
        steady = by_changes(_runs(0.0), length, AT)
        assert abs(steady["fit"]["per_change"]) < 4e-4  # type: ignore[index]
    # The errors are larger where the changes are.
    rms = [b["rms_deg"] for b in row["bins"]]  # type: ignore[attr-defined]
    assert rms[-1] > 2 * rms[0]


def test_the_model_with_the_response_variance_holds_the_errors_where_the_rate_changes() -> None:
    out = coverage(_runs(0.004), {"with": replace(AT, delay_var=0.004), "without": AT})
    assert out["with"]["most_changes_inside_99"] >= 0.95
    assert out["with"]["inside_50"] == pytest.approx(0.5, abs=0.1)
    assert out["without"]["most_changes_inside_99"] < 0.3
    assert out["with"]["stretches"] == out["without"]["stretches"] > 300
