"""``TrackerConfig.search_rival_nats``: a place is not localized while the last search found
another place that explains its replay's frames about as well (a look-alike that took the
mass before any search proposed the truth, the truth then entering too light to count)."""

from __future__ import annotations

import math
from functools import cache

import pytest

from _feeding import feed, first_row
from omniloc.errors import InputError
from omniloc.evaluate.tracking import errors_against
from omniloc.track import TrackerConfig, TrackRun, preset, track, with_settings
from omniloc.track.simulate import Example, lookalike_run


@cache
def _run17() -> Example:
    """Run 17 of the look-alikes' battery: 20 landmarks, a 180-degree camera 0.2 m ahead.
    From 6.9 s to 12 s the robot sees nothing; at 16.9 s a search proposes the truth (its
    rank 74 of 453) beside a look-alike 6.5 m off that the searches had found before, which
    explains the replay's 4 s of frames 2.1 nats better. The truth enters too light and the
    look-alike is localized until the model check sees it through at 24.4 s."""
    return lookalike_run(17)


def _track(**settings: object) -> TrackRun:
    ex = _run17()
    sensor, motion, config = with_settings(ex.sensor, ex.motion, preset("generic")[2], settings)
    return track(
        ex.landmarks, ex.run.odometry, ex.run.frames, sensor=sensor, motion=motion, config=config
    )


def _wrong(result: TrackRun) -> list[float]:
    ok, _, _ = errors_against(_run17().run.truth, result.estimates)
    return [e.t for e, o in zip(result.estimates, ok, strict=True) if e.localized and not o]


def test_a_look_alike_a_search_cannot_tell_from_the_truth_is_not_localized() -> None:
    off = _track(search_rival_nats=0.0)
    assert len([t for t in _wrong(off) if 16.5 <= t <= 24.5]) >= 20
    on = _track(search_rival_nats=3.0)
    assert _wrong(on) == []
    # The frames it held say why.
    held = [e for e in on.estimates if "the last search found a place" in e.reason]
    assert held and all(not e.localized for e in held)
    assert any(16.5 <= e.t <= 18.0 for e in held)
    # A gap wider than the threshold holds nothing: the look-alike's 2.1 nats.
    narrow = _track(search_rival_nats=2.0)
    assert not any(
        "the last search found a place" in e.reason for e in narrow.estimates if e.t <= 17.0
    )


def test_search_rival_nats_defaults_and_bounds() -> None:
    assert TrackerConfig().search_rival_nats == 0.0
    assert preset("generic")[2].search_rival_nats == 0.0
    assert preset("mrclam")[2].search_rival_nats == 0.0
    for bad in (-1.0, math.nan, math.inf, "3", True):
        with pytest.raises(InputError, match="search_rival_nats"):
            TrackerConfig(search_rival_nats=bad)  # type: ignore[arg-type]


def test_a_rival_holds_the_place_for_a_replay_s_after_its_search() -> None:
    # A tracker told its true pose and localized; a rival noted by a search 1 s ago (within
    # replay_s, 4 s) holds the place back, one noted 10 s ago no longer does.
    import numpy as np

    from omniloc.track import Tracker

    ex = _run17()
    run = ex.run
    config = TrackerConfig(min_age_s=0.0, search_rival_nats=3.0)
    frames = [f for f in run.frames if 40.0 < f.t <= 45.0]

    def fed(rival_age: float | None) -> bool:
        tr = Tracker(ex.landmarks, ex.sensor, ex.motion, config)
        q = run.truth.pose_at(frames[0].t)
        tr.set_pose((q.x, q.y, q.theta), np.diag([0.01, 0.01, 0.002]) ** 2)
        states = feed(tr, run, frames[:-1], first_row(run, frames[0].t))
        assert states[-1].localized
        if rival_age is not None:
            leader = int(tr._ids[int(np.argmax(tr._logw))])
            tr._rival = (frames[-1].t - rival_age, leader, 1.0, 6.0)
        # (On from the row after those the frames before were fed.)
        fed_to = int(np.searchsorted(run.odometry.t, frames[-2].t, side="right"))
        (last,) = feed(tr, run, frames[-1:], fed_to)
        return last.localized and "the last search found a place" not in last.reason

    assert fed(None)
    assert not fed(1.0)
    assert fed(10.0)
