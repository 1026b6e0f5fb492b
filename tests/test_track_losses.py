"""benchmarks/track_losses.py: finding the losses of the true place, and the share of the
tubes in view reported."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from track_losses import GONE, HELD, WITHIN_S, find_losses, reported_share


def test_a_loss_is_a_fall_from_held_to_gone_within_the_time() -> None:
    t = [0.0, 1.0, 2.0, 3.0, 4.0, 10.0, 11.0, 20.0, 20.5, 30.0, 30.2]
    s = [HELD, 0.5, 0.5, GONE / 2, HELD, HELD, 0.5, HELD, GONE / 2, HELD + 0.05, GONE]
    # 0 -> 3 (3 s: within); 4 -> nothing within 3 s; 7 -> 8; 9 -> 10 is GONE itself: no.
    assert WITHIN_S == 3.0
    assert find_losses(t, s) == [(0, 3), (7, 8)]
    assert find_losses([0.0, 3.5], [HELD, 0.0]) == []  # too slow
    assert find_losses([], []) == []


def test_the_reported_share_counts_frames_with_three_tubes_in_view_or_more() -> None:
    assert reported_share([(1, 4), (0, 2), (3, 4)]) == {"frames": 2, "reported": 0.5}
    assert reported_share([]) == {"frames": 0, "reported": 0.0}
    assert reported_share([(2, 3)])["reported"] == pytest.approx(2 / 3)
