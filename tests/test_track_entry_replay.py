"""``TrackerConfig.entry_replay``: a place found after the tracked places stopped explaining
the frames (a kidnapping) is weighed as a place that left elsewhere then, not with a state
shaped by the frames before it."""

from __future__ import annotations

from functools import cache

import pytest

from omniloc.errors import InputError
from omniloc.evaluate.tracking import errors_against
from omniloc.track import SimulatedRun, TrackerConfig, TrackRun, track
from omniloc.track.simulate import lookalike_run


def _wrong_after(run: SimulatedRun, result: TrackRun, t0: float) -> list[float]:
    """The times after ``t0`` of the localized frames more than 0.3 m or 5 deg off."""
    ok, _, _ = errors_against(run.truth, result.estimates)
    return [
        e.t for e, o in zip(result.estimates, ok, strict=True) if e.t > t0 and e.localized and not o
    ]


@cache
def _run(seed: int, entry_replay: bool) -> tuple[SimulatedRun, TrackRun]:
    ex = lookalike_run(seed)
    config = TrackerConfig(entry_replay=entry_replay)
    res = track(
        ex.landmarks,
        ex.run.odometry,
        ex.run.frames,
        sensor=ex.sensor,
        motion=ex.motion,
        config=config,
    )
    return ex.run, res


# Runs 169 and 175 of the look-alikes' battery: the example's grid (the same under a half
# turn but for one landmark), carried off at 30 s. Replayed from the window's first frame,
# the first search after the jump weighed the truth 15-30 nats below a half-turn twin whose
# replay had been sharpened by frames from before the jump (and the truth's pulled off by
# them), and the tracker was sure of the twin, 5 m off, from 33 s for 15-20 s.
@pytest.mark.parametrize("seed", [169, 175])
def test_the_twin_after_a_kidnapping_is_not_localized(seed: int) -> None:
    run, old = _run(seed, False)
    assert run.kidnap_t == 30.0
    assert len(_wrong_after(run, old, 31.0)) >= 20
    run, new = _run(seed, True)
    assert _wrong_after(run, new, 31.0) == []
    # The tracker is sure of the true place again once the frames tell the twins apart (the
    # landmark that breaks the grid's symmetry seen: after 52 s on run 175).
    right = [e for e in new.estimates if e.t > 31.0 and e.localized]
    assert len(right) >= 25


def test_entry_replay_defaults_and_validation() -> None:
    assert TrackerConfig().entry_replay is True
    with pytest.raises(InputError, match="entry_replay"):
        TrackerConfig(entry_replay="yes")  # type: ignore[arg-type]
