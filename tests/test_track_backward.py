"""The second pass backward in time (``omniloc.track.backward``, ``track(backward_s=...)``,
``omniloc track --backward``): the recording played backward retraces the same path, the
frames before a sure one are localized from it and right, and a kidnapping is not carried
across."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc import LandmarkMap, Pose
from omniloc.cli import main
from omniloc.errors import InputError
from omniloc.evaluate.tracking import backward_offline, evaluate_tracking, whole_run
from omniloc.track import Frame, MotionModel, Odometry, TrackerConfig, TrackEstimate, track
from omniloc.track.backward import (
    CONFIRM_S,
    TOLD_SCALE,
    backward_pass,
    combine,
    held_frames,
    hold,
    kept_frames,
    refine,
    reverse_recording,
    since_reported,
    sure_frames,
)
from omniloc.track.motion import compose, integrate
from omniloc.track.records import TrackState
from omniloc.track.simulate import (
    EXAMPLE_MAP,
    EXAMPLE_MOTION,
    EXAMPLE_SENSOR,
    example_run,
    simulate_run,
)

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "grid-run"


def _motion(odo: Odometry, t0: float, t1: float) -> np.ndarray:
    """The odometry's relative motion over [t0, t1] (each row holding until the next)."""
    edges = np.concatenate([[t0], odo.t[(odo.t > t0) & (odo.t < t1)], [t1]])
    rows = np.searchsorted(odo.t, edges[:-1], side="right") - 1
    delta, _ = integrate(np.diff(edges), odo.v[rows], odo.w[rows], MotionModel())
    return delta


@settings(max_examples=50, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(0.01, 1.0), st.floats(-1.0, 1.0), st.floats(-1.5, 1.5)
        ),  # (dt, v, w) per row
        min_size=2,
        max_size=12,
    ),
    st.floats(-0.3, 0.3),
)
def test_the_recording_played_backward_undoes_its_motion(rows, delay) -> None:
    dt, v, w = (np.array(c) for c in zip(*rows, strict=True))
    t = np.concatenate([[0.0], np.cumsum(dt[:-1])])
    odo = Odometry(t, v, w)
    frames = [Frame(float(t[0]) + delay, [0.1]), Frame(float(t[-1]) + 0.5 + delay, [0.2])]
    r_odo, r_frames = reverse_recording(odo, frames, delay)
    assert [f.t for f in r_frames] == [-f.t for f in reversed(frames)]
    # From the first frame to the last (the odometry delayed by ``delay``) and back again.
    shifted = Odometry(odo.t + delay, odo.v, odo.w)
    there = _motion(shifted, frames[0].t, frames[-1].t)
    back = _motion(r_odo, r_frames[0].t, r_frames[-1].t)
    home = compose(there, back)
    # (Within 1e-6 m: for a turn of about 1e-9 to 1e-5 rad over a piece, integrate's
    # (1 - cos phi) / phi loses digits, at worst about 7e-9 m per metre driven near 1.5e-8
    # rad -- hypothesis found 1.8e-9 m after 0.47 m at 2.8e-8 rad; up to 24 m are driven
    # here. Nanometres, far below anything a tracker reads.)
    assert np.allclose(home[:2], 0.0, atol=1e-6)
    assert abs(math.remainder(home[2], 2 * math.pi)) < 1e-9


def test_a_sideways_velocity_is_undone_too() -> None:
    odo = Odometry(
        np.array([0.0, 1.0]), np.array([0.2, 0.1]), np.array([0.0, 0.3]), np.array([0.1, -0.2])
    )
    r_odo, _ = reverse_recording(odo, [Frame(2.0, [0.0])])
    assert r_odo.vy is not None and r_odo.vy.tolist() == [0.2, -0.1]


def _correct(run, estimates) -> np.ndarray:
    ok = []
    for e in estimates:
        if e.pose is None:
            ok.append(False)
            continue
        tp = run.truth.pose_at(e.t)
        ok.append(
            math.hypot(e.pose.x - tp.x, e.pose.y - tp.y) <= 0.3
            and abs(math.remainder(e.pose.theta - tp.theta, 2 * math.pi)) <= math.radians(5.0)
        )
    return np.array(ok)


def _same(a, b) -> bool:
    """The same estimate (from two runs of the same forward pass)."""
    return (a.t, a.state, a.pose, a.reason) == (b.t, b.state, b.pose, b.reason)


def _localized(estimates) -> np.ndarray:
    return np.array([e.state is TrackState.LOCALIZED for e in estimates])


@pytest.mark.parametrize("seed", [0, 3, 10])
def test_the_frames_before_the_first_sure_one_are_localized_from_it(seed: int) -> None:
    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=40.0, rng=seed)
    kw = dict(sensor=EXAMPLE_SENSOR, motion=EXAMPLE_MOTION)
    fwd = track(EXAMPLE_MAP, run.odometry, run.frames, **kw).estimates
    both = track(EXAMPLE_MAP, run.odometry, run.frames, backward_s=30.0, **kw)
    two = both.estimates
    lf, l2 = _localized(fwd), _localized(two)
    assert both.backward == (l2 & ~lf).sum()
    first = int(np.argmax(lf))
    assert lf.any() and first > 0  # the grid holds the forward pass back for a while
    # Every forward estimate stays; the frames before its first localized one are
    # localized by the pass backward, right, and say where they come from.
    assert all(_same(two[i], fwd[i]) for i in np.flatnonzero(lf | ~l2))
    assert l2[:first].any() and _correct(run, two)[l2].all()
    added = [two[i] for i in np.flatnonzero(l2 & ~lf)]
    assert added and all(e.reason.startswith("from the pass backward") for e in added)
    assert all(e.backward == (not lf[i] and l2[i]) for i, e in enumerate(two))
    assert all(e.as_dict()["backward"] is e.backward for e in two)
    assert all(0.0 <= _ahead(e) <= 30.0 and e.since_localized == 0.0 for e in added)
    # A shorter horizon takes fewer of them, none beyond it.
    short = track(EXAMPLE_MAP, run.odometry, run.frames, backward_s=2.0, **kw).estimates
    assert l2.sum() > _localized(short).sum() >= lf.sum()
    assert all(_ahead(e) <= 2.0 for e in short if e.backward)


def _ahead(e: TrackEstimate) -> float:
    """The seconds to its sure frame that a frame of the pass backward gives in its reason."""
    m = re.match(r"from the pass backward, ([\d.]+) s before a sure frame", e.reason)
    assert m is not None, e.reason
    return float(m.group(1))


def test_a_kidnapping_is_not_carried_back_across() -> None:
    ex = example_run()
    run = ex.run
    kw = dict(sensor=ex.sensor, motion=ex.motion)
    fwd = track(ex.landmarks, run.odometry, run.frames, **kw).estimates
    both = track(ex.landmarks, run.odometry, run.frames, backward_s=60.0, **kw)
    two = both.estimates
    ok, loc = _correct(run, two), _localized(two)
    assert not (loc & ~ok).any()
    # The localized frames of the seconds before the jump are given up by the forward pass
    # (it flags the kidnapping): counted, and those the pass did not localize say why.
    given = [e for e in two if e.reason.startswith("the forward pass gives this place up")]
    assert both.given_up > len(given) > 0
    assert all(e.state is TrackState.AMBIGUOUS and e.t < run.frames[0].t + 30.0 for e in given)
    # The kidnapping stays flagged where the forward pass noticed it.
    assert [e.kidnapped for e in two] == [e.kidnapped for e in fwd] and any(
        e.kidnapped for e in fwd
    )
    # The place found after the jump (at 30 s) is carried back to the jump and no further:
    # the frames the pass backward localized after it are right, and so are those before
    # it (from the place before the jump).
    jump = run.frames[0].t + 30.0
    added = [e for e in two if e.backward]
    assert any(jump < e.t < jump + 5.0 for e in added) and any(e.t < jump for e in added)
    assert _localized(two).sum() > _localized(fwd).sum()


def test_no_sure_frame_leaves_the_forward_pass_as_it_is() -> None:
    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=6.0, rng=4)
    kw = dict(sensor=EXAMPLE_SENSOR, motion=EXAMPLE_MOTION)
    fwd = track(EXAMPLE_MAP, run.odometry, run.frames, **kw).estimates
    cfg = TrackerConfig()
    assert not sure_frames(fwd, cfg).any()
    back = backward_pass(
        EXAMPLE_MAP, run.odometry, run.frames, fwd, horizon_s=10.0, motion=EXAMPLE_MOTION
    )
    assert back == [None] * len(fwd)
    assert combine(fwd, back) == list(fwd)


def test_a_sure_pose_outside_the_region_starts_no_stretch() -> None:
    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=4.0, rng=1)
    # A forward pass lost in every frame but the last, sure there.
    fwd = [TrackEstimate(f.t, TrackState.LOST) for f in run.frames]
    tight = np.diag([0.01, 0.01, 1e-4])
    far = TrackEstimate(
        fwd[-1].t, TrackState.LOCALIZED, Pose(1e4, 1e4, 0.0), tight, probability=1.0
    )
    near = TrackEstimate(
        fwd[-1].t, TrackState.LOCALIZED, run.truth.pose_at(fwd[-1].t), tight, probability=1.0
    )
    kw = dict(horizon_s=2.0, motion=EXAMPLE_MOTION, sensor=EXAMPLE_SENSOR)
    assert backward_pass(EXAMPLE_MAP, run.odometry, run.frames, [*fwd[:-1], far], **kw) == [
        None
    ] * len(fwd)
    told = backward_pass(EXAMPLE_MAP, run.odometry, run.frames, [*fwd[:-1], near], **kw)
    assert told[-1] is not None and told[-2] is not None and told[0] is None


def test_bad_input_is_refused() -> None:
    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=4.0, rng=1)
    for bad in (-1.0, math.nan, math.inf, "10", True, np.array([1.0, 2.0])):
        with pytest.raises(InputError, match="backward_s"):
            track(EXAMPLE_MAP, run.odometry, run.frames, backward_s=bad)  # type: ignore[arg-type]
    fwd = track(EXAMPLE_MAP, run.odometry, run.frames, motion=EXAMPLE_MOTION).estimates
    with pytest.raises(InputError, match="horizon_s"):
        backward_pass(EXAMPLE_MAP, run.odometry, run.frames, fwd, horizon_s=-2.0)
    with pytest.raises(InputError, match="one estimate per frame"):
        backward_pass(EXAMPLE_MAP, run.odometry, run.frames, fwd[1:], horizon_s=2.0)
    with pytest.raises(InputError, match="one estimate per frame"):
        combine(fwd, [None])
    with pytest.raises(InputError, match="delay_s"):
        reverse_recording(run.odometry, run.frames, math.nan)
    with pytest.raises(InputError, match="horizon"):
        backward_offline(-1.0)
    for bad in (-1.0, math.nan, "4"):
        with pytest.raises(InputError, match="confirm_s"):
            kept_frames(fwd, run.odometry, confirm_s=bad)  # type: ignore[arg-type]
        with pytest.raises(InputError, match="confirm_s"):
            backward_offline(10.0, confirm_s=bad)  # type: ignore[arg-type]


def test_the_evaluation_scores_the_two_passes() -> None:
    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=30.0, rng=3)
    stream = whole_run("sim", EXAMPLE_MAP, run.odometry, run.frames, run.truth)
    from omniloc.track import Tracker

    def make(lm, start):
        return Tracker(lm, EXAMPLE_SENSOR, EXAMPLE_MOTION)

    calls = []

    def offline(s, est):
        calls.append(s.name)
        return list(
            track(
                EXAMPLE_MAP,
                s.odometry,
                s.frames,
                sensor=EXAMPLE_SENSOR,
                motion=EXAMPLE_MOTION,
                backward_s=30.0,
            ).estimates
        )

    one, _ = evaluate_tracking([stream], make, progress=False)
    two, est = evaluate_tracking([stream], make, progress=False, offline=offline)
    assert calls == ["sim"]
    assert two.runs[0].n_localized > one.runs[0].n_localized
    assert two.runs[0].n_confidently_wrong == 0
    assert two.runs[0].time_to_localize_s < one.runs[0].time_to_localize_s
    assert two.runs[0].cpu_s > one.runs[0].cpu_s
    assert len(est[0]) == len(run.frames)


def test_the_command_line_takes_the_second_pass(tmp_path, capsys) -> None:
    args = [
        "-q",
        "track",
        "--map",
        str(EXAMPLES / "landmarks.csv"),
        "--odometry",
        str(EXAMPLES / "odometry.csv"),
        "--frames",
        str(EXAMPLES / "frames.csv"),
        "--config",
        str(EXAMPLES / "settings.json"),
        "--groundtruth",
        str(EXAMPLES / "groundtruth.csv"),
    ]
    assert main(args) == 0
    one = capsys.readouterr().out
    assert main([*args, "--backward", "20"]) == 0
    two = capsys.readouterr().out
    share = [float(o.split("localized ")[1].split(" %")[0]) for o in (one, two)]
    assert share[1] > share[0]
    assert "within 0.3 m / 5 deg 100.0 % of localized frames" in two
    assert "the pass backward (20 s before each sure frame) localized" in two
    assert "localized at a place the forward pass gave up within 10 s are not" in two
    assert "the pass backward" not in one
    assert main([*args, "--backward", "-1"]) == 1
    assert "must be >= 0" in capsys.readouterr().err
    assert main(["-q", "evaluate", "--backward", "10", "--out", str(tmp_path / "ev")]) == 1
    assert "--backward applies to --dataset mrclam-track only" in capsys.readouterr().err


def test_the_evaluation_on_mrclam_says_it_ran_the_pass_backward(
    shared_data: Path, tmp_path: Path, capsys
) -> None:
    from test_track_cli import _truncated_mrclam

    data = _truncated_mrclam(tmp_path / "mrclam", 200.0)
    argv = ["-q", "evaluate", "--dataset", "mrclam-track", str(data), "--kidnap", "0"]
    assert main([*argv, "--out", str(tmp_path / "one")]) == 0
    one = capsys.readouterr().out
    assert main([*argv, "--backward", "20", "--out", str(tmp_path / "two")]) == 0
    two = capsys.readouterr().out
    assert "tracker: whole runs" in one and "pass backward" not in one
    assert "tracker with the pass backward (20 s): whole runs" in two
    # Robot 3 is sure of its place within a minute: the pass backward localizes more
    # (within its first 200 s; told twice the covariance, none of the first 120 s).
    rows = [
        {
            r.split(",")[0]: r
            for r in (tmp_path / d / "mrclam_track_runs.csv").read_text().splitlines()
        }
        for d in ("one", "two")
    ]
    head = rows[0]["name"].split(",")
    col = head.index("n_localized")
    assert int(rows[1]["robot3"].split(",")[col]) > int(rows[0]["robot3"].split(",")[col])


@pytest.mark.parametrize("n_back", [0, 2])
def test_the_figure_marks_the_frames_of_the_pass_backward(monkeypatch, tmp_path, n_back) -> None:
    import omniloc.plot.track as pt

    figures = []
    monkeypatch.setattr(pt, "save_figure", lambda fig, path: figures.append(fig) or path)
    est = [
        TrackEstimate(
            float(k),
            TrackState.LOCALIZED,
            pose=Pose(1.0, 2.0, 0.3),
            covariance=np.eye(3) * 1e-4,
            probability=0.999,
            backward=k < n_back,
        )
        for k in range(5)
    ]
    pt.plot_track(EXAMPLE_MAP, est, tmp_path / "x.png")
    marked = [
        line
        for ax in figures[0].axes
        for line in ax.get_lines()
        if line.get_label() == "localized by the pass backward"
    ]
    assert len(marked) == (1 if n_back else 0)
    if n_back:
        assert list(marked[0].get_xdata()) == [0.0, 1.0]


def _straight(
    n: int = 41, dt: float = 0.5, jump_at: float | None = None, how: str = "twin", vy: float = 0.0
) -> tuple[list[TrackEstimate], Odometry]:
    """A forward pass along a straight drive (0.5 m/s, and ``vy`` sideways): every fourth
    frame sure, the others ambiguous at the place; from ``jump_at`` on, the pass gives the
    place up (``how``: its pose jumps 2 m to a twin, turns 45 deg, goes lost, or flags a
    kidnapping at that frame)."""
    t = np.arange(n) * dt
    odo = Odometry(t, np.full(n, 0.5), np.zeros(n), None if vy == 0.0 else np.full(n, vy))
    out = []
    for k, tk in enumerate(t.tolist()):
        pose = Pose(1.0 + 0.5 * tk, 1.0 + vy * tk, 0.0)
        state = TrackState.LOCALIZED if k % 4 == 0 else TrackState.AMBIGUOUS
        kidnapped = False
        if jump_at is not None and tk >= jump_at:
            if how == "twin":
                pose = Pose(pose.x, pose.y + 2.0, pose.theta)
            elif how == "turn":
                pose = Pose(pose.x, pose.y, math.radians(45.0))
            elif how == "lost":
                out.append(TrackEstimate(tk, TrackState.LOST))
                continue
            else:
                kidnapped = math.isclose(tk, jump_at)
        out.append(
            TrackEstimate(tk, state, pose, np.eye(3) * 1e-4, probability=0.999, kidnapped=kidnapped)
        )
    return out, odo


def test_a_held_place_keeps_every_sure_frame() -> None:
    est, odo = _straight()
    sure = sure_frames(est, TrackerConfig())
    assert sure.sum() == 11
    assert (kept_frames(est, odo) == sure).all()
    # The odometry's sideways velocity carries the place too (a holonomic robot).
    est, odo = _straight(vy=0.3)
    assert (kept_frames(est, odo) == sure_frames(est, TrackerConfig())).all()


@settings(max_examples=30, deadline=None)
@given(
    st.sampled_from(["twin", "turn", "lost", "kidnapped"]),
    st.integers(1, 40),
    st.sampled_from([0.0, 2.0, 5.0, 10.0]),
)
def test_a_place_given_up_keeps_no_sure_frame_within_confirm_s_before(how, k_jump, confirm_s):
    est, odo = _straight(jump_at=0.5 * k_jump, how=how)
    sure = sure_frames(est, TrackerConfig())
    kept = kept_frames(est, odo, confirm_s=confirm_s)
    t = np.array([e.t for e in est])
    # Given up: the sure frames with the jump within confirm_s after them.
    jump = 0.5 * k_jump
    want = sure & ((t + confirm_s < jump) | (confirm_s == 0.0))
    assert (kept[t < jump] == want[t < jump]).all()
    if how in ("twin", "kidnapped"):
        # From the jump on, the sure frames hold the place they are at (the twin's poses
        # follow the odometry; a kidnapping is flagged once).
        assert kept[(t >= jump) & sure].all()


def test_a_sure_place_given_up_starts_no_pass_backward() -> None:
    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=6.0, rng=1)
    n = len(run.frames)
    mid = n // 2
    tight = np.diag([0.01, 0.01, 1e-4])
    fwd = [TrackEstimate(f.t, TrackState.LOST) for f in run.frames]
    fwd[mid] = TrackEstimate(
        fwd[mid].t, TrackState.LOCALIZED, run.truth.pose_at(fwd[mid].t), tight, probability=1.0
    )
    kw = dict(horizon_s=3.0, motion=EXAMPLE_MOTION, sensor=EXAMPLE_SENSOR)
    # Lost right after its sure frame: the forward pass gave the place up.
    assert not kept_frames(fwd, run.odometry, motion=EXAMPLE_MOTION).any()
    assert backward_pass(EXAMPLE_MAP, run.odometry, run.frames, fwd, **kw) == [None] * n
    # Without the test (confirm_s 0) the pass runs back from it.
    told = backward_pass(EXAMPLE_MAP, run.odometry, run.frames, fwd, confirm_s=0.0, **kw)
    assert told[mid] is not None and told[mid - 1] is not None and told[mid + 1] is None
    assert told[mid - 1].since_localized == pytest.approx(fwd[mid].t - fwd[mid - 1].t)


def test_odometry_pieces_carry_the_sideways_velocity() -> None:
    odo = Odometry(
        np.array([0.0, 1.0]), np.array([0.2, 0.1]), np.array([0.0, 0.3]), np.array([0.1, -0.2])
    )
    dt, v, w, vy = odo.pieces(-0.5, 1.5)
    assert dt.tolist() == [0.5, 1.0, 0.5] and v.tolist() == [0.0, 0.2, 0.1]
    assert w.tolist() == [0.0, 0.0, 0.3] and vy.tolist() == [0.0, 0.1, -0.2]
    assert [a.tolist() for a in odo.between(-0.5, 1.5)] == [dt.tolist(), v.tolist(), w.tolist()]
    assert not Odometry(odo.t, odo.v, odo.w).pieces(0.0, 1.0)[3].any()
    with pytest.raises(InputError, match="needs t1 >= t0"):
        odo.pieces(1.0, 0.5)


def test_a_localized_frame_whose_place_is_given_up_is_reported_ambiguous() -> None:
    est, odo = _straight(jump_at=12.0)  # the pose jumps 2 m at 12 s
    cfg = TrackerConfig(
        confidence_recent=((0.5, 0.3), (1.0, 0.8)), confidence_ambiguous=((0.5, 0.1), (1.0, 0.2))
    )
    out = hold(est, odo, config=cfg)
    t = np.array([e.t for e in est])
    loc = _localized(est)
    given_up = loc & (t + CONFIRM_S >= 12.0) & (t < 12.0)
    assert given_up.sum() == 5  # the sure frames at 2, 4, ..., 10 s
    assert not _localized(out)[given_up].any()
    for i in np.flatnonzero(given_up):
        e, f = out[i], est[i]
        assert e.state is TrackState.AMBIGUOUS and (e.pose, e.probability) == (
            f.pose,
            f.probability,
        )
        assert e.reason.startswith("the forward pass gives this place up within 10 s")
        assert e.confidence == pytest.approx(0.3 + (0.999 - 0.5))  # the recent table
    assert all(out[i] is est[i] for i in np.flatnonzero(~given_up))
    # Without a recent table the ambiguous one; without tables no confidence.
    amb = hold(est, odo, config=TrackerConfig(confidence_ambiguous=((0.5, 0.1), (1.0, 0.2))))
    assert amb[int(np.flatnonzero(given_up)[0])].confidence == pytest.approx(0.1998)
    assert all(e.confidence is None for e in hold(est, odo) if e.state is TrackState.AMBIGUOUS)
    # Held for 2 s only, the sure frames from 10 s on are given up, no others.
    short = hold(est, odo, confirm_s=2.0)
    assert [e.t for e, f in zip(short, est, strict=True) if e is not f] == [10.0]
    with pytest.raises(InputError, match="among"):
        held_frames(est, odo, among=np.ones(3, dtype=bool))


def test_the_evaluation_and_track_run_the_same_offline_steps() -> None:
    ex = example_run()
    run = ex.run
    kw = dict(sensor=ex.sensor, motion=ex.motion)
    stream = whole_run("ex", ex.landmarks, run.odometry, run.frames, run.truth)
    fwd = list(track(ex.landmarks, run.odometry, run.frames, **kw).estimates)
    both = track(ex.landmarks, run.odometry, run.frames, backward_s=20.0, **kw)
    mine = refine(ex.landmarks, run.odometry, run.frames, fwd, horizon_s=20.0, **kw)
    assert [(e.t, e.state, e.pose, e.reason) for e in mine] == [
        (e.t, e.state, e.pose, e.reason) for e in both.estimates
    ]
    # A forward frame kept localized is the same estimate; one given up is not.
    assert both.given_up == sum(f.localized and o is not f for f, o in zip(fwd, mine, strict=True))
    assert both.given_up > 0
    # backward_offline (the evaluation's) is refine with the preset's models.
    ev = backward_offline(20.0, "generic")
    from omniloc.track import preset

    s_, m_, c_ = preset("generic")
    want = refine(
        ex.landmarks, run.odometry, run.frames, fwd, horizon_s=20.0, sensor=s_, motion=m_, config=c_
    )
    got = ev(stream, fwd)
    assert [(e.state, e.pose, e.reason) for e in got] == [(e.state, e.pose, e.reason) for e in want]
    assert any(e.reason.startswith("the forward pass gives this place up") for e in got)
    assert any(e.backward for e in got)


def test_a_backward_estimate_without_its_time_to_the_sure_frame_says_so_plainly() -> None:
    f = TrackEstimate(1.0, TrackState.AMBIGUOUS, Pose(1.0, 2.0, 0.0), np.eye(3) * 1e-2)
    b = TrackEstimate(1.0, TrackState.LOCALIZED, Pose(1.0, 2.0, 0.0), np.eye(3) * 1e-4, reason="r")
    (out,) = combine([f], [b])
    assert out.backward and out.reason == "from the pass backward: r"
    (out,) = combine([f], [replace(b, since_localized=2.5)])
    assert out.reason == "from the pass backward, 2.5 s before a sure frame: r"


def test_since_localized_offline_counts_from_the_last_frame_reported_localized() -> None:
    # hold kept the forward pass's 0 for a place given up, and the pass backward put the
    # seconds *to* its sure frame: "seconds since the last localized frame" was wrong for
    # both (72 frames of the example recording).
    pose, cov = Pose(1.0, 2.0, 0.0), np.eye(3) * 1e-4

    def est(t: float, state: str, since: float | None, kidnapped: bool = False):
        p = None if state == "lost" else pose
        c = None if state == "lost" else cov
        return TrackEstimate(t, state, p, c, kidnapped=kidnapped, since_localized=since)

    # forward: nothing, then localized at 2 (given up by hold), 3; lost from 4 (flagged at
    # 5: its count starts again), localized again at 7.
    fwd = [
        est(0.0, "ambiguous", None),
        est(1.0, "ambiguous", None),
        est(2.0, "localized", 0.0),
        est(3.0, "localized", 0.0),
        est(4.0, "lost", 1.0),
        est(5.0, "lost", None, kidnapped=True),
        est(6.0, "lost", None),
        est(7.0, "localized", 0.0),
    ]
    # offline: 1 from the pass backward (4.0 s to its sure frame), 2 given up.
    offline = list(fwd)
    offline[1] = replace(est(1.0, "localized", 4.0), backward=True)
    offline[2] = est(2.0, "ambiguous", 0.0)
    out = since_reported(offline, fwd)
    assert [e.since_localized for e in out] == [None, 0.0, 1.0, 0.0, 1.0, None, None, 0.0]
    # Nothing else changes; an estimate whose count was right is returned as it is.
    assert [(e.t, e.state, e.pose, e.backward) for e in out] == [
        (e.t, e.state, e.pose, e.backward) for e in offline
    ]
    assert [o is e for o, e in zip(out, offline, strict=True)] == [
        True,
        False,
        False,
        True,
        True,
        True,
        True,
        True,
    ]
    with pytest.raises(InputError, match="one estimate per frame"):
        since_reported(offline, fwd[:-1])


def test_since_localized_of_the_example_with_the_pass_backward_is_since_a_reported_frame() -> None:
    ex = example_run()
    run = ex.run
    kw = dict(sensor=ex.sensor, motion=ex.motion)
    fwd = track(ex.landmarks, run.odometry, run.frames, **kw).estimates
    both = track(ex.landmarks, run.odometry, run.frames, backward_s=20.0, **kw).estimates
    held = hold(fwd, run.odometry, motion=ex.motion)
    behind = backward_pass(
        ex.landmarks, run.odometry, run.frames, held, horizon_s=20.0, **kw, confirm_s=0.0
    )
    plain = combine(held, behind)

    def fields(e: TrackEstimate) -> tuple:
        return (e.t, e.state, e.pose, e.reason, e.probability, e.confidence, e.kidnapped)

    # Only the count differs from the steps without it.
    assert [fields(e) for e in both] == [fields(e) for e in plain]
    assert (
        sum(a.since_localized != b.since_localized for a, b in zip(both, plain, strict=True)) > 10
    )
    last = None
    for e, f in zip(both, fwd, strict=True):
        if f.kidnapped:
            last = None
        if e.state is TrackState.LOCALIZED:
            last = e.t
        assert e.since_localized == (None if last is None else e.t - last), e.t


def test_the_pass_is_told_each_sure_pose_with_its_covariance_times_told_scale(
    monkeypatch,
) -> None:
    # The forward pass's covariance is too small (a near miss told sure is carried back
    # sure): the pass is told it times TOLD_SCALE, or the factor given.
    from omniloc.track import Tracker

    run = simulate_run(EXAMPLE_MAP, EXAMPLE_SENSOR, Pose(6.0, 4.0, 0.3), duration_s=40.0, rng=0)
    kw = dict(sensor=EXAMPLE_SENSOR, motion=EXAMPLE_MOTION)
    fwd = track(EXAMPLE_MAP, run.odometry, run.frames, **kw).estimates
    told: list[tuple[Pose, np.ndarray]] = []
    real = Tracker.set_pose

    def spy(self, pose, covariance):  # type: ignore[no-untyped-def]
        told.append((pose, np.array(covariance)))
        return real(self, pose, covariance)

    monkeypatch.setattr(Tracker, "set_pose", spy)
    cov = {e.pose: e.covariance for e in fwd if e.pose is not None}
    counts = {}
    for scale in (1.0, TOLD_SCALE, 400.0):
        told.clear()
        back = backward_pass(
            EXAMPLE_MAP, run.odometry, run.frames, fwd, horizon_s=30.0, told_scale=scale, **kw
        )
        assert told and all(np.allclose(c, cov[p] * scale) for p, c in told)
        counts[scale] = sum(b is not None and b.state is TrackState.LOCALIZED for b in back)
    assert TOLD_SCALE == 2.0
    # A pose told less sure is held localized over fewer frames before it, never more.
    assert counts[1.0] >= counts[TOLD_SCALE] >= counts[400.0]
    assert counts[1.0] > counts[400.0], counts
    for bad in (0.5, math.nan, "2"):
        with pytest.raises(InputError, match="told_scale"):
            backward_pass(
                EXAMPLE_MAP, run.odometry, run.frames, fwd, horizon_s=30.0, told_scale=bad, **kw
            )


def test_on_mrclam_the_frames_of_the_pass_read_the_presets_table_for_them(
    shared_data: Path, tmp_path: Path
) -> None:
    # Robot 3's first 200 s: the pass localizes frames before its sure ones. Each such
    # frame's confidence is the backward table's, not the forward pass's table for
    # localized frames (which said 0.997 of frames right in 96 % when the pass was told the
    # forward covariance as reported).
    from omniloc.track import load_frames, load_odometry, preset
    from omniloc.track.confidence import confidence_of
    from test_track_cli import _truncated_mrclam

    data = _truncated_mrclam(tmp_path / "mrclam", 200.0)
    sensor, motion, config = preset("mrclam")
    lm = LandmarkMap.load(data / "landmarks.csv")
    odo = load_odometry(data / "robot3_odometry.csv")
    frames = load_frames(data / "robot3_frames.csv")
    run = track(lm, odo, frames, sensor=sensor, motion=motion, config=config, backward_s=20.0)
    back = [e for e in run.estimates if e.backward]
    fwd = [e for e in run.estimates if e.localized and not e.backward]
    assert back and fwd and config.confidence_backward is not None
    for e in back:
        assert e.probability is not None
        assert e.confidence == confidence_of(config.confidence_backward, e.probability)
    for e in fwd:
        assert e.probability is not None
        assert e.confidence == confidence_of(config.confidence_localized, e.probability)
    # (The two tables differ where these frames are.)
    assert any(
        confidence_of(config.confidence_localized, e.probability) != e.confidence for e in back
    )
