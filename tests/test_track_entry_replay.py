"""``TrackerConfig.entry_replay``: a place found after the tracked places stopped explaining
the frames (a kidnapping) is weighed as a place that left elsewhere then, not with a state
shaped by the frames before it."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from omniloc.errors import InputError
from omniloc.evaluate.tracking import errors_against
from omniloc.track import SimulatedRun, Tracker, TrackerConfig, TrackRun, track
from omniloc.track.simulate import lookalike_run
from omniloc.track.window import WindowFrame


def _wrong_after(run: SimulatedRun, result: TrackRun, t0: float) -> list[float]:
    """The times after ``t0`` of the localized frames more than 0.3 m or 5 deg off."""
    ok, _, _ = errors_against(run.truth, result.estimates)
    return [
        e.t for e, o in zip(result.estimates, ok, strict=True) if e.t > t0 and e.localized and not o
    ]


def _state() -> tuple[np.ndarray, ...]:
    """Two candidates' replayed state (poses, covariances, fit counts, clutter memory,
    entry times), as :meth:`Tracker._replay_entries` is handed it."""
    mu = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]])
    P = np.stack([np.eye(3) * 0.01] * 2)
    fit_m, fit_n = np.array([1.0, 1.0]), np.array([2.0, 2.0])
    return mu, P, fit_m, fit_n, np.zeros((2, 0)), np.full(2, 1.0)


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


def test_a_candidate_the_second_replay_loses_keeps_its_early_entries(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The second replay (from the frame where elsewhere held the most mass) may lose a
    # candidate: a weight that is NaN. That candidate is weighed by its early entries alone
    # and keeps the first replay's state; the other, whose late entries weigh more, takes
    # the second replay's state and is held since the frame it was replayed from.
    tracker = Tracker([[0.0, 3.0], [3.0, 0.0], [-3.0, 0.0], [0.0, -3.0]])
    zero3, Q = np.zeros(3), np.eye(3) * 1e-4
    frames = [WindowFrame(t, np.zeros(0), zero3, zero3, Q) for t in (1.0, 1.25, 1.5)]
    C = 2
    second = (
        np.array([[0.5, 0.5, 0.1], [0.6, 0.6, 0.2]]),  # poses
        np.stack([np.eye(3) * 0.02] * C),  # covariances
        np.array([0.0, np.nan]),  # the ln of the prior volume: candidate 1 lost
        np.array([[5.0, 4.0], [5.0, 4.0]]),  # evidence to the end from frames 1 and 2
        np.array([3.0, 3.0]),
        np.array([4.0, 4.0]),
        np.full((C, 0), 0.0),
    )
    calls: list[list[float]] = []

    def fake_replay(poses, covs, sub):  # type: ignore[no-untyped-def]
        calls.append([f.t for f in sub])
        return tuple(np.copy(x) for x in second)

    monkeypatch.setattr(tracker, "_replay", fake_replay)
    entry = np.array([-20.0, -1.0, -3.0])  # elsewhere's mass highest at the second frame
    to_end = np.array([[-2.0, -1.0, 0.0], [-2.0, -1.0, 0.0]])
    volume, logw = np.zeros(2), np.zeros(2)
    state = _state()
    mu, P, fit_m, fit_n, _, born = state
    tracker._replay_entries(
        np.zeros((C, 3)), P.copy(), frames, entry, to_end, volume, logw, state, 1.0
    )
    assert calls == [[1.25, 1.5]]
    before = -20.0 - 2.0  # the entry at the first frame alone
    assert logw[1] == pytest.approx(before)
    assert logw[0] > before and np.isfinite(logw).all()
    # Candidate 0 took the second replay's state and its entry time; 1 kept its own.
    assert np.array_equal(mu[0], second[0][0]) and born[0] == 1.25
    assert np.array_equal(mu[1], [2.0, 2.0, 0.0]) and born[1] == 1.0
    assert fit_m[1] == 1.0 and fit_n[1] == 2.0 and np.array_equal(P[1], np.eye(3) * 0.01)


def test_entries_from_the_frames_the_search_looked_at_are_weighed_by_their_own_replay(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Elsewhere held the most mass at the second frame, and the search looked at the frames
    # from the third on: the entries split there, each part weighed by the replay from its
    # first frame; each candidate takes the state of its heaviest part.
    tracker = Tracker([[0.0, 3.0], [3.0, 0.0], [-3.0, 0.0], [0.0, -3.0]])
    zero3, Q = np.zeros(3), np.eye(3) * 1e-4
    frames = [WindowFrame(t, np.zeros(0), zero3, zero3, Q) for t in (1.0, 1.25, 1.5, 1.75)]
    C = 2
    ends = {
        1.25: np.array([[5.0, 4.0, 3.0], [1.0, 1.0, 1.0]]),
        1.5: np.array([[0.0, 0.0], [9.0, 8.0]]),
    }
    calls: list[list[float]] = []

    def fake_replay(poses, covs, sub):  # type: ignore[no-untyped-def]
        t0 = sub[0].t
        calls.append([f.t for f in sub])
        return (
            np.full((C, 3), t0),  # poses: the replay's first frame, to tell them apart
            np.stack([np.eye(3) * t0] * C),
            np.zeros(C),
            ends[t0],
            np.full(C, t0),
            np.full(C, 2 * t0),
            np.full((C, 0), 0.0),
        )

    monkeypatch.setattr(tracker, "_replay", fake_replay)
    entry = np.array([-20.0, -1.0, -3.0, -2.0])
    to_end = np.array([[-2.0, -1.0, 0.0, 0.5], [-2.0, -1.0, 0.0, 0.5]])
    volume, logw = np.zeros(2), np.zeros(2)
    state = _state()
    mu, P, fit_m, fit_n, _, born = state
    tracker._replay_entries(
        np.zeros((C, 3)), P.copy(), frames, entry, to_end, volume, logw, state, 1.5
    )
    assert calls == [[1.25, 1.5, 1.75], [1.5, 1.75]]
    first = np.array([-22.0, -22.0])  # the entry at the first frame, by the first replay
    second = np.array([-1.0 + 5.0, -1.0 + 1.0])  # at the second, by the replay from it
    third = np.logaddexp(entry[2] + ends[1.5][:, 0], entry[3] + ends[1.5][:, 1])
    want = np.logaddexp(np.logaddexp(first, second), third) - tracker._norm
    assert np.allclose(logw, want)
    # Candidate 0 is heaviest entering at the second frame, candidate 1 at the third.
    assert np.array_equal(mu[0], [1.25] * 3) and born[0] == 1.25 and fit_m[0] == 1.25
    assert np.array_equal(mu[1], [1.5] * 3) and born[1] == 1.5 and fit_n[1] == 3.0
    assert np.array_equal(P[1], np.eye(3) * 1.5)


def test_a_look_alike_is_not_localized_while_the_places_found_beside_it_are_kept() -> None:
    # Look-alikes' run 3, its first 11 s: the robot sees two landmarks at a time, and no
    # search proposes the truth (the pair search does: tests/test_track_pairs.py). Its
    # candidates were replayed from 4 s before each search only, through frames from before
    # the ones they were found on, which pulled most of them off: a place 13 m off was left
    # without a rival and localized at 7.6-10.1 s. Each weighed from the search's own
    # frames as well, the others stay beside it and it is not localized.
    ex = lookalike_run(3)
    res = track(
        ex.landmarks,
        ex.run.odometry,
        ex.run.frames[:44],
        sensor=ex.sensor,
        motion=ex.motion,
        config=TrackerConfig(),
    )
    assert _wrong_after(ex.run, res, 0.0) == []
    assert any(len(e.hypotheses) >= 2 for e in res.estimates if 7.5 < e.t < 10.2)
