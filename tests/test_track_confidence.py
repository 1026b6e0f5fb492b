"""The tracker's confidence (omniloc.track.confidence): its own probability mapped, per
state, by tables fitted on frames scored against a ground truth."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from omniloc import InputError, LandmarkMap, Pose, SensorModel
from omniloc.evaluate.common import calibration
from omniloc.evaluate.tracking import (
    TrackingResult,
    frames_within_tolerance,
    score_run,
    tracking_summary,
    whole_run,
)
from omniloc.track import (
    MotionModel,
    TrackerConfig,
    TrackEstimate,
    TrackState,
    fit_confidence,
    preset,
    simulate_run,
    track,
    with_settings,
)
from omniloc.track.confidence import MAX_KNOTS, confidence_of, confidence_table

TABLE = ((0.2, 0.1), (0.6, 0.3), (0.99, 0.8))


def test_a_table_maps_linearly_between_knots_and_flat_beyond() -> None:
    assert confidence_of(TABLE, 0.4) == pytest.approx(0.2)
    assert confidence_of(TABLE, 0.0) == 0.1
    assert confidence_of(TABLE, 1.0) == 0.8
    assert confidence_of(TABLE, 0.99) == 0.8
    assert confidence_of(None, 0.5) is None
    assert confidence_of(TABLE, math.nan) is None


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("0.5,0.2", "pairs"),
        (3.0, "pairs"),
        ([0.5, 0.2], "1 to"),
        ([[0.5, 0.2, 0.1]], "1 to"),
        ([], "1 to"),
        ([[k / 1000, k / 1000] for k in range(MAX_KNOTS + 1)], "1 to"),
        ([[0.5, math.nan]], r"\[0, 1\]"),
        ([[0.5, 1.5]], r"\[0, 1\]"),
        ([[-0.1, 0.5]], r"\[0, 1\]"),
        ([[0.5, 0.2], [0.5, 0.3]], "increase"),
        ([[0.9, 0.2], [0.5, 0.3]], "increase"),
        ([[0.5, 0.9], [0.9, 0.2]], "not decrease"),
        ([["a", "b"]], "numbers"),
        ([[10**400, 0.5]], "numbers"),
    ],
)
def test_a_bad_table_is_refused_by_name(value: object, message: str) -> None:
    with pytest.raises(InputError, match=message) as err:
        confidence_table("confidence_ambiguous", value)
    assert "confidence_ambiguous" in str(err.value)
    with pytest.raises(InputError, match="confidence_localized"):
        TrackerConfig(confidence_localized=value)  # type: ignore[arg-type]


def test_a_table_given_as_lists_is_kept_as_tuples_of_floats() -> None:
    c = TrackerConfig(confidence_localized=[[0.9, 0.95], [0.99, 0.999]])  # type: ignore[arg-type]
    assert c.confidence_localized == ((0.9, 0.95), (0.99, 0.999))
    assert TrackerConfig().confidence_ambiguous is None


def test_tables_are_settings_by_name_from_a_json_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from omniloc.track import load_settings

    path = tmp_path / "s.json"
    path.write_text(json.dumps({"confidence_ambiguous": [[0.1, 0.05], [0.9, 0.5]]}))
    _, _, cfg = with_settings(*preset("generic"), load_settings(path))
    assert cfg.confidence_ambiguous == ((0.1, 0.05), (0.9, 0.5))


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 400),
    ties=st.booleans(),
)
def test_a_fit_is_a_valid_table_for_each_state_seen(seed: int, n: int, ties: bool) -> None:
    rng = np.random.default_rng(seed)
    p = rng.uniform(0, 1, n)
    if ties:
        p = np.round(p, 1)
    states = rng.choice(["localized", "ambiguous", "lost"], n)
    right = rng.uniform(0, 1, n) < p
    if (states == "lost").all():
        with pytest.raises(InputError, match="every frame is lost"):
            fit_confidence(states, p, right)
        return
    fit = fit_confidence(states, p, right)
    for state in ("localized", "ambiguous"):
        table = getattr(fit, state)
        sel = states == state
        assert fit.frames[state] == int(sel.sum())
        assert fit.right[state] == int(right[sel].sum())
        if not sel.any():
            assert table is None
            continue
        # What the tracker's configuration takes, unchanged.
        assert confidence_table(state, table) == table
        # Never sure: half a frame wrong and half right are added to every block.
        assert all(0.0 < c < 1.0 for _, c in table)
        assert min(k[0] for k in table) >= p[sel].min() - 1e-12
        assert max(k[0] for k in table) <= p[sel].max() + 1e-12
    assert fit("lost", 0.5) is None


def test_a_fit_learns_a_known_miscalibration_and_holds_on_new_frames() -> None:
    # The model says p; the truth is right with probability p^2 (overconfident).
    rng = np.random.default_rng(7)
    p = rng.uniform(0, 1, 20_000)
    right = rng.uniform(0, 1, p.size) < p**2
    fit = fit_confidence(["ambiguous"] * p.size, p, right)
    for x in (0.2, 0.5, 0.8, 0.95):
        assert fit("ambiguous", x) == pytest.approx(x**2, abs=0.04)
    # Frames it was not fitted on: the model's ECE is about 1/6; the fitted map's is small.
    q = rng.uniform(0, 1, 20_000)
    ok = (rng.uniform(0, 1, q.size) < q**2).tolist()
    mapped = [fit("ambiguous", x) for x in q]
    assert calibration(q.tolist(), ok).ece > 0.15
    assert calibration(mapped, ok).ece < 0.02


def test_a_fit_keeps_the_states_apart() -> None:
    # Localized frames right at any probability, ambiguous ones never: two tables.
    p = np.linspace(0.5, 1.0, 200)
    states = ["localized"] * 100 + ["ambiguous"] * 100
    right = [True] * 100 + [False] * 100
    fit = fit_confidence(states, np.concatenate([p[:100], p[:100]]), right)
    assert fit("localized", 0.7) > 0.99
    assert fit("ambiguous", 0.7) < 0.01
    # Every table is a setting, None where the fit has none (no recent_s: no span fitted).
    assert fit.settings() == {
        "confidence_localized": fit.localized,
        "confidence_ambiguous": fit.ambiguous,
        "confidence_recent": None,
        "confidence_hypothesis": None,
        "confidence_hypothesis_recent": None,
        "confidence_backward": None,
    }


def test_a_fit_applied_over_a_preset_leaves_none_of_the_presets_tables_behind() -> None:
    # A fit without the times since localized has no recent tables: applied over the mrclam
    # preset, the recent frames must read the fit's own ambiguous table, not the preset's
    # recent one (two fits' tables read side by side).
    fit = fit_confidence(["ambiguous", "localized"], [0.5, 0.99], [False, True])
    sensor, motion, config = preset("mrclam")
    assert config.confidence_recent is not None
    _, _, mine = with_settings(sensor, motion, config, fit.settings())
    for name in (
        "confidence_localized",
        "confidence_ambiguous",
        "confidence_recent",
        "confidence_hypothesis",
        "confidence_hypothesis_recent",
    ):
        assert getattr(mine, name) == getattr(fit, name.removeprefix("confidence_")), name
    assert mine.confidence_recent is None and mine.confidence_hypothesis_recent is None


@pytest.mark.parametrize(
    ("states", "p", "right", "message"),
    [
        (["localized"], [0.5, 0.6], [True, True], "one entry per frame"),
        (["moving"], [0.5], [True], "states must each be one of"),
        ("localized", [0.5], [True], "states must be a sequence"),
        (["localized"], ["a"], [True], "probabilities"),
        (["localized"], [10**400], [True], "probabilities"),
        (["localized"], [1.5], [True], "frame 0"),
        (["ambiguous"], [math.nan], [True], "frame 0"),
        (["lost"], [math.nan], [False], "every frame is lost"),
        (["localized"], [0.5], [2], "booleans"),
        (["localized"], [[0.5, 0.2]], [True], "one entry per frame"),
    ],
)
def test_bad_frames_for_a_fit_are_refused(
    states: list[str], p: list[float], right: list[object], message: str
) -> None:
    with pytest.raises(InputError, match=message):
        fit_confidence(states, p, right)


def test_an_estimate_refuses_a_probability_or_confidence_outside_0_1() -> None:
    from omniloc.track import Hypothesis

    for name in ("probability", "confidence"):
        for bad in (1.5, -0.1, math.nan, "0.5", True, [0.5]):
            with pytest.raises(InputError, match=name):
                TrackEstimate(0.0, TrackState.LOST, **{name: bad})
            with pytest.raises(InputError, match="confidence"):
                Hypothesis(Pose(0, 0, 0), np.eye(3), 0.5, bad)  # type: ignore[arg-type]
    assert TrackEstimate(0.0, TrackState.LOST, probability=np.float32(0.5)).probability == 0.5
    for bad in (-1.0, math.inf, math.nan, "3", True, [1.0], 10**400):
        with pytest.raises(InputError, match="since_localized"):
            TrackEstimate(0.0, TrackState.LOST, since_localized=bad)  # type: ignore[arg-type]
    assert TrackEstimate(0.0, TrackState.LOST, since_localized=np.float32(2.5)).since_localized


# ---- the tracker ----------------------------------------------------------------------------

GRID = LandmarkMap(
    np.array([[x, y] for x in (0.0, 4.0, 8.0, 13.0) for y in (0.0, 3.5, 8.0)])
    + np.array([[0.3 * (i % 3), 0.2 * (i % 4)] for i in range(12)])
)
SENSOR = SensorModel(sigma=np.deg2rad(0.5), max_range=6.0, p_detect=0.9, clutter=0.3)


def _run(config: TrackerConfig):  # type: ignore[no-untyped-def]
    run = simulate_run(GRID, SENSOR, Pose(5.0, 4.2, 0.3), duration_s=20.0, speed=0.25, rng=5)
    res = track(GRID, run.odometry, run.frames, sensor=SENSOR, motion=MotionModel(), config=config)
    return run, res


def test_the_tracker_reports_its_probability_and_the_tables_confidence() -> None:
    loc = ((0.5, 0.6), (0.999, 0.97))
    amb = ((0.0, 0.01), (1.0, 0.4))
    hyp = ((0.0, 0.05), (1.0, 0.5))
    _, plain = _run(TrackerConfig(search_interval_s=1.0))
    _, mapped = _run(
        TrackerConfig(
            search_interval_s=1.0,
            confidence_localized=loc,
            confidence_ambiguous=amb,
            confidence_hypothesis=hyp,
        )
    )
    states = {e.state for e in plain.estimates}
    assert TrackState.LOCALIZED in states
    for a, b in zip(plain.estimates, mapped.estimates, strict=True):
        # The tables change no decision and no pose, only what is reported beside them.
        assert a.state is b.state and a.pose == b.pose and a.probability == b.probability
        assert a.confidence is None
        if a.state is TrackState.LOST:
            assert a.probability is None and b.confidence is None
            continue
        assert a.probability is not None and 0.0 <= a.probability <= 1.0
        table = loc if b.state is TrackState.LOCALIZED else amb
        assert b.confidence == confidence_of(table, a.probability)
        for ha, hb in zip(a.hypotheses, b.hypotheses, strict=True):
            assert ha.weight == hb.weight and ha.confidence is None
            assert hb.confidence == confidence_of(hyp, hb.weight)
        d = b.as_dict()
        assert d["probability"] == a.probability and d["confidence"] == b.confidence
    # A localized frame's probability is what the state was decided on (at least the
    # configuration's localized_probability or, kept, its keep rule's).
    first = next(e for e in plain.estimates if e.state is TrackState.LOCALIZED)
    assert first.probability is not None and first.probability >= 0.99


def test_the_evaluation_scores_probability_and_confidence_beside_the_weights() -> None:
    run, res = _run(
        TrackerConfig(search_interval_s=1.0, confidence_ambiguous=((0.0, 0.2), (1.0, 0.5)))
    )
    stream = whole_run("sim", GRID, run.odometry, run.frames, run.truth)
    score = score_run(stream, res.estimates)
    scored, right = frames_within_tolerance(stream, res.estimates)
    posed = [e.probability is not None for e in res.estimates]
    assert sum(b[0] for b in score.probability_bins) == int((scored & posed).sum())
    amb = [e.state is TrackState.AMBIGUOUS for e in res.estimates]
    assert sum(b[0] for b in score.confidence_bins) == int((scored & amb).sum())
    assert sum(b[2] for b in score.probability_bins) == int((scored & right).sum())
    tot = TrackingResult("sim", [score]).totals()
    assert tot["probability_frames"] == int((scored & posed).sum())
    assert 0.0 <= tot["probability_ece"] <= 1.0
    text = tracking_summary(TrackingResult("sim", [score]))
    assert "own probability" in text and "its confidence" in text
    row = score.csv_row()
    assert "probability_bins" not in row and row["probability_frames"] == tot["probability_frames"]


def test_the_mrclam_preset_carries_tables_and_the_generic_one_does_not() -> None:
    _, _, mrclam = preset("mrclam")
    _, _, generic = preset("generic")
    assert mrclam.confidence_localized is not None and mrclam.confidence_ambiguous is not None
    assert mrclam.confidence_hypothesis is not None
    assert generic.confidence_localized is None and generic.confidence_ambiguous is None
    assert generic.confidence_hypothesis is None
    # A hypothesis of weight 0.98 of a tracker still searching is right less than half the
    # time (the table: 0.30); soon after a localized frame, most of the time (0.91).
    assert 0.2 < confidence_of(mrclam.confidence_hypothesis, 0.98) < 0.5  # type: ignore[operator]
    assert confidence_of(mrclam.confidence_hypothesis_recent, 0.98) > 0.8  # type: ignore[operator]
    assert generic.confidence_hypothesis_recent is None
    # A localized frame is right far more often than an ambiguous one at the same
    # probability (measured: benchmarks/results_track_confidence.md).
    loc = confidence_of(mrclam.confidence_localized, 0.99)
    amb = confidence_of(mrclam.confidence_ambiguous, 0.99)
    assert loc is not None and amb is not None and loc > amb
    # ... and an ambiguous frame soon after a localized one more often than another.
    assert mrclam.confidence_recent is not None and generic.confidence_recent is None
    for p in (0.5, 0.9, 0.99):
        soon = confidence_of(mrclam.confidence_recent, p)
        other = confidence_of(mrclam.confidence_ambiguous, p)
        assert soon is not None and other is not None and soon > other + 0.2
    assert replace(mrclam, confidence_localized=None).confidence_localized is None


# ---- the command line -------------------------------------------------------------------------


def _write_run(folder, seed: int) -> list[str]:  # type: ignore[no-untyped-def]
    from omniloc.track import write_frames, write_groundtruth, write_odometry

    run = simulate_run(GRID, SENSOR, Pose(5.0, 4.2, 0.3), duration_s=15.0, speed=0.25, rng=seed)
    paths = [folder / f"odo{seed}.csv", folder / f"frames{seed}.csv", folder / f"gt{seed}.csv"]
    write_odometry(paths[0], run.odometry)
    write_frames(paths[1], run.frames)
    write_groundtruth(paths[2], run.truth)
    return ["--odometry", str(paths[0]), "--frames", str(paths[1]), "--groundtruth", str(paths[2])]


def _fit_confidence_inputs(folder: Path) -> tuple[list[str], list[str], Path]:
    """The grid map and two simulated runs written in ``folder``: the map and model options,
    the runs' file options, and the settings file to write."""
    mp = folder / "map.csv"
    mp.write_text("id,x,y\n" + "".join(f"{i},{x},{y}\n" for i, (x, y) in enumerate(GRID.xy)))
    runs = _write_run(folder, 1) + _write_run(folder, 2)
    common = ["--map", str(mp), "--set", "max_range=6", "--set", "p_detect=0.9"]
    return common, runs, folder / "confidence.json"


def test_fit_confidence_on_two_runs_writes_tables_that_track_reports(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from omniloc.cli import main

    common, runs, out = _fit_confidence_inputs(tmp_path)
    assert main(["fit-confidence", *common, *runs, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "localized:" in text and "own probability" in text
    assert "ambiguous within 20 s of a localized frame:" in text
    assert "fitted on the other runs" in text  # two runs: a held-out figure
    tables = json.loads(out.read_text())
    assert set(tables) == {
        "confidence_localized",
        "confidence_ambiguous",
        "confidence_recent",
        "confidence_recent_s",
        "confidence_hypothesis",
        "confidence_hypothesis_recent",
        "confidence_backward",
    }
    assert tables["confidence_backward"] is None  # (no pass backward: none fitted)
    assert tables["confidence_recent_s"] == 20.0
    assert tables["confidence_localized"] is not None
    assert "every hypothesis's weight" in text and "each run's hypotheses" in text
    # The tables are settings of omniloc track: its JSON lines then carry a confidence.
    assert main(["track", *common, *runs[:6], "--config", str(out), "--json"]) == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    posed = [x for x in lines if x["state"] != "lost"]
    assert posed and all(x["confidence"] is not None for x in posed)
    assert all(0.0 <= x["probability"] <= 1.0 for x in posed)
    hyps = [h for x in posed for h in x["hypotheses"]]
    assert hyps and all(0.0 <= h["confidence"] <= 1.0 for h in hyps)
    # The summary's last line says the last frame's confidence (not with the generic
    # preset's none).
    assert main(["-q", "track", *common, *runs[:6], "--config", str(out)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert (
        last.startswith("last frame: ") and f", confidence {posed[-1]['confidence']:.4f} (" in last
    )
    assert main(["-q", "track", *common, *runs[:6]]) == 0
    assert "confidence" not in capsys.readouterr().out.splitlines()[-1]


def test_the_summary_lines_of_streams_carry_both_calibration_errors() -> None:
    from omniloc.evaluate.tracking import _calibration_note

    assert _calibration_note({"probability_frames": 0.0}) == ""
    note = _calibration_note(
        {"probability_frames": 10.0, "probability_ece": 0.25, "confidence_frames": 0.0}
    )
    assert note == "; expected calibration error of its own probability 0.250"
    note = _calibration_note(
        {
            "probability_frames": 10.0,
            "probability_ece": 0.25,
            "confidence_frames": 10.0,
            "confidence_ece": 0.03,
        }
    )
    assert note.endswith("0.250, of its confidence 0.030")


def test_fit_confidence_refuses_runs_of_unequal_files(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from omniloc.cli import main

    mp = tmp_path / "map.csv"
    mp.write_text("id,x,y\n0,0,0\n1,4,0\n2,0,4\n")
    runs = _write_run(tmp_path, 1)
    assert main(["fit-confidence", "--map", str(mp), *runs, "--frames", runs[3]]) == 1
    assert "give the three files of each run" in capsys.readouterr().err


def test_on_a_recording_the_confidence_is_calibrated_where_the_probability_is_not(
    shared_data,  # type: ignore[no-untyped-def]
) -> None:
    # MRCLAM robot 1's whole run with the preset (its tables fitted on all five robots'
    # runs with the preset of 2026-12-05; benchmarks/track_confidence.py measures tables
    # held out by robot, 0.051 over 43,571 frames with today's preset; one run's 865 frames
    # in ten bins are noisier: measured 0.102 -- robot 1's 256 frames at confidences of
    # 0.2-0.3 are right in 9 % -- and 0.079 with the preset before 2026-12-07). The tables
    # must cut the model's error by more than half there.
    from omniloc.evaluate.tracking import mrclam_streams

    (stream,) = mrclam_streams(shared_data / "mrclam-ds6", robots=(1,))
    sensor, motion, config = preset("mrclam")
    res = track(
        stream.landmarks,
        stream.odometry,
        stream.frames,
        sensor=sensor,
        motion=motion,
        config=config,
    )
    score = score_run(stream, res.estimates)
    tot = TrackingResult("robot1", [score]).totals()
    assert tot["confidence_frames"] == tot["probability_frames"] > 500
    assert tot["probability_ece"] > 0.2  # (measured 0.276)
    assert tot["confidence_ece"] < min(0.11, 0.5 * tot["probability_ece"])
    # Every hypothesis (measured: weights 0.078, confidences 0.015 over 5,888).
    assert tot["hypothesis_confidence_ece"] < 0.5 * tot["hypothesis_weight_ece"]
    # Every frame's confidence is what its table says of its probability.
    recent = 0
    for e in res.estimates:
        if e.state is TrackState.LOCALIZED:
            assert e.confidence == confidence_of(config.confidence_localized, e.probability)
        elif e.state is TrackState.AMBIGUOUS:
            soon = e.since_localized is not None and e.since_localized <= config.confidence_recent_s
            recent += soon
            table = config.confidence_recent if soon else config.confidence_ambiguous
            assert e.confidence == confidence_of(table, e.probability)
    assert recent > 0


@pytest.mark.parametrize(
    ("probability", "confidence", "label"),
    [
        (0.9, 0.6, "confidence"),
        (0.9, None, "own probability (uncalibrated)"),
        (None, None, None),
    ],
)
def test_the_figure_draws_the_confidence_beside_the_state(
    monkeypatch, tmp_path, probability, confidence, label
) -> None:  # type: ignore[no-untyped-def]
    import omniloc.plot.track as pt

    figures = []
    monkeypatch.setattr(pt, "save_figure", lambda fig, path: figures.append(fig) or path)
    state = TrackState.LOST if probability is None else TrackState.AMBIGUOUS
    pose = None if probability is None else Pose(1.0, 2.0, 0.3)
    est = [
        TrackEstimate(
            float(k),
            state,
            pose=pose,
            covariance=None if pose is None else np.eye(3) * 0.01,
            probability=probability,
            confidence=confidence,
        )
        for k in range(5)
    ]
    pt.plot_track(GRID, est, tmp_path / "x.png")
    labels = [ax.get_ylabel() for ax in figures[0].axes]
    if label is None:
        assert not any("confidence" in x or "probability" in x for x in labels)
    else:
        assert label in labels


def test_held_out_needs_two_runs_and_a_label_per_frame() -> None:
    from omniloc.track.confidence import held_out_confidence

    frames = (["localized", "ambiguous", "lost", "ambiguous"], [0.99, 0.4, math.nan, 0.7])
    right = [True, False, False, True]
    out = held_out_confidence(*frames, right, ["a", "a", "b", "b"])
    assert np.isnan(out[2])  # lost: no pose, no confidence
    # Run b's ambiguous frame is mapped by run a's table (one ambiguous frame, wrong).
    assert out[3] == pytest.approx(0.25)
    # Run a's localized frame: no localized frame elsewhere, so no table.
    assert np.isnan(out[0])
    with pytest.raises(InputError, match="at least two runs"):
        held_out_confidence(*frames, right, [1, 1, 1, 1])
    with pytest.raises(InputError, match="one run label per frame"):
        held_out_confidence(*frames, right, [1, 2])
    with pytest.raises(InputError, match="probability must be a number"):
        confidence_of(TABLE, "0.5")  # type: ignore[arg-type]


def test_frames_of_equal_probability_weigh_by_their_number() -> None:
    # Ten frames at 0.2 (8 right), one at 0.4 (wrong), ten at 0.6 (5 right): pooled by
    # their counts, 8/11 at the first two is above 5/10, so all three pool into one block
    # of 13 right in 21 (with half a frame each way: 13.5 / 22).
    p = [0.2] * 10 + [0.4] + [0.6] * 10
    right = [True] * 8 + [False] * 2 + [False] + [True] * 5 + [False] * 5
    fit = fit_confidence(["ambiguous"] * 21, p, right)
    assert fit.ambiguous is not None and len(fit.ambiguous) == 1
    assert fit.ambiguous[0][1] == pytest.approx(13.5 / 22)
    assert fit.ambiguous[0][0] == pytest.approx(sum(p) / 21)


def test_a_new_tolerance_drops_the_tables_measured_at_the_old_one(caplog) -> None:  # type: ignore[no-untyped-def]
    import logging

    sensor, motion, config = preset("mrclam")
    with caplog.at_level(logging.WARNING, logger="omniloc.track.presets"):
        _, _, wider = with_settings(sensor, motion, config, {"tolerance_m": 0.5})
    assert wider.confidence_localized is None and wider.confidence_ambiguous is None
    assert wider.confidence_hypothesis is None
    assert "tolerance_m changed" in caplog.text
    # Given with it, a table stays; the same tolerance, or another setting, keeps them.
    _, _, given = with_settings(
        sensor, motion, config, {"tolerance_m": 0.5, "confidence_ambiguous": ((0.5, 0.3),)}
    )
    assert given.confidence_ambiguous == ((0.5, 0.3),) and given.confidence_localized is None
    for same in ({"tolerance_m": config.tolerance_m}, {"min_age_s": 10.0}):
        _, _, kept = with_settings(sensor, motion, config, same)
        assert kept.confidence_localized == config.confidence_localized


def test_a_table_of_any_values_and_the_hypotheses_table() -> None:
    from omniloc.track.confidence import fit_table

    rng = np.random.default_rng(3)
    w = rng.uniform(0, 1, 5000)
    right = rng.uniform(0, 1, w.size) < 0.5 * w  # weights twice as sure as they should be
    table = fit_table(w, right)
    assert confidence_of(table, 0.8) == pytest.approx(0.4, abs=0.05)
    fit = fit_confidence(["ambiguous"], [0.5], [True], hypothesis_weights=w, hypothesis_right=right)
    assert fit.hypothesis == table and fit.frames["hypothesis"] == w.size
    assert fit.settings()["confidence_hypothesis"] == table
    assert fit_confidence(["ambiguous"], [0.5], [True]).settings()["confidence_hypothesis"] is None
    with pytest.raises(InputError, match="give both"):
        fit_confidence(["ambiguous"], [0.5], [True], hypothesis_weights=w)
    with pytest.raises(InputError, match="at least one"):
        fit_table([], [])
    with pytest.raises(InputError, match=r"\[0, 1\]"):
        fit_table([1.5], [True])
    from omniloc.track import Hypothesis

    with pytest.raises(InputError, match="confidence"):
        Hypothesis(Pose(0, 0, 0), np.eye(3), 0.5, 1.5)


def test_the_evaluation_scores_every_hypothesis() -> None:
    run, res = _run(TrackerConfig(search_interval_s=1.0, confidence_hypothesis=((0.0, 0.35),)))
    stream = whole_run("sim", GRID, run.odometry, run.frames, run.truth)
    score = score_run(stream, res.estimates)
    scored, _ = frames_within_tolerance(stream, res.estimates)
    n = sum(len(e.hypotheses) for e, sc in zip(res.estimates, scored, strict=True) if sc)
    assert n > 0
    assert sum(b[0] for b in score.hypothesis_weight_bins) == n
    assert sum(b[0] for b in score.hypothesis_confidence_bins) == n
    # Every confidence is 0.35: all in the fourth tenth.
    assert score.hypothesis_confidence_bins[3][0] == n
    tot = TrackingResult("sim", [score]).totals()
    assert tot["hypothesis_weight_frames"] == n
    assert "every reported hypothesis" in tracking_summary(TrackingResult("sim", [score]))


def test_a_table_held_out_by_run() -> None:
    from omniloc.track.confidence import fit_table, held_out_table

    w = [0.2, 0.9, 0.9, 0.2, 0.9, 0.5]
    right = [False, True, True, False, False, True]
    runs = ["a", "a", "a", "b", "b", "c"]
    out = held_out_table(w, right, runs)
    # Run b's cases read the table fitted on runs a and c alone.
    other = fit_table([0.2, 0.9, 0.9, 0.5], [False, True, True, True])
    assert out[3] == confidence_of(other, 0.2) and out[4] == confidence_of(other, 0.9)
    with pytest.raises(InputError, match="at least two runs"):
        held_out_table(w, right, ["a"] * 6)
    with pytest.raises(InputError, match="one run label per frame"):
        held_out_table(w, right, ["a", "b"])


# ---- ambiguous frames soon after a localized one ----------------------------------------------


def test_a_fit_gives_the_frames_soon_after_a_localized_one_a_table_of_their_own() -> None:
    # At the same probability, the ambiguous frames within recent_s of a localized frame
    # are right, the others are not: one table each.
    n = 200
    p = np.full(n, 0.6)
    since = [2.0] * 100 + [None] * 50 + [45.0] * 50
    right = [True] * 100 + [False] * 100
    fit = fit_confidence(["ambiguous"] * n, p, right, since_localized=since, recent_s=20.0)
    assert fit.frames == {"localized": 0, "recent": 100, "ambiguous": 100}
    assert fit.right == {"localized": 0, "recent": 100, "ambiguous": 0}
    assert fit("ambiguous", 0.6, since_localized=2.0) > 0.99
    assert fit("ambiguous", 0.6, since_localized=20.0) > 0.99  # (the span is inclusive)
    assert fit("ambiguous", 0.6, since_localized=20.5) < 0.01
    assert fit("ambiguous", 0.6) < 0.01  # never localized
    assert fit("localized", 0.6, since_localized=0.0) is None  # no localized frame fitted
    assert fit("ambiguous", 0.6, since_localized=math.nan) < 0.01  # (NaN: never)
    with pytest.raises(InputError, match="since_localized"):
        fit("ambiguous", 0.6, since_localized="soon")  # type: ignore[arg-type]
    # A negative time would read the recent table, the surer one here: refused, as in a fit.
    for bad in (-1.0, math.inf):
        with pytest.raises(InputError, match=r"since_localized must be seconds >= 0"):
            fit("ambiguous", 0.6, since_localized=bad)
    assert fit.settings()["confidence_recent"] == fit.recent
    assert fit.settings()["confidence_recent_s"] == 20.0
    # Without the times, one table for every ambiguous frame, as before.
    plain = fit_confidence(["ambiguous"] * n, p, right)
    assert plain.recent is None and plain.recent_s is None
    assert plain.settings()["confidence_recent"] is None
    assert "confidence_recent_s" not in plain.settings()
    assert plain("ambiguous", 0.6, since_localized=2.0) == pytest.approx(100.5 / 201)


def test_held_out_reads_the_recent_table_of_the_other_runs() -> None:
    from omniloc.track.confidence import held_out_confidence

    states = ["ambiguous"] * 8
    p = [0.5] * 8
    since = [1.0, None, 1.0, None, 1.0, None, 1.0, None]
    right = [True, False, True, False, True, False, False, True]
    runs = ["a", "a", "b", "b", "c", "c", "d", "d"]
    out = held_out_confidence(states, p, right, runs, since_localized=since, recent_s=5.0)
    # Run d's recent frame reads the other runs' recent table: three recent frames, all
    # right (3.5 / 4), its other frame their other table (0.5 / 4).
    assert out[6] == pytest.approx(3.5 / 4) and out[7] == pytest.approx(0.5 / 4)
    # Without the times, one table: the other runs' six frames, three right.
    one = held_out_confidence(states, p, right, runs)
    assert one[6] == pytest.approx(3.5 / 7) == one[7]


@pytest.mark.parametrize(
    ("since", "recent_s", "message"),
    [
        ([1.0], 20.0, "one entry per case"),
        ([1.0, -2.0], 20.0, "entry 1"),
        ([math.inf, 1.0], 20.0, "entry 0"),
        (["soon", 1.0], 20.0, "since_localized"),
        ([1.0, 2.0], -1.0, "recent_s"),
        ([1.0, 2.0], math.nan, "recent_s"),
        ([1.0, 2.0], "20", "recent_s"),
        ([1.0, 2.0], True, "recent_s"),
        ([1.0, 2.0], 10**400, "recent_s"),
    ],
)
def test_bad_times_since_localized_are_refused_by_name(
    since: list[object], recent_s: object, message: str
) -> None:
    with pytest.raises(InputError, match=message):
        fit_confidence(
            ["ambiguous", "ambiguous"],
            [0.5, 0.5],
            [True, False],
            since_localized=since,  # type: ignore[arg-type]
            recent_s=recent_s,  # type: ignore[arg-type]
        )


def test_the_tracker_reads_the_recent_table_within_its_span() -> None:
    loc = ((0.5, 0.6), (0.999, 0.97))
    amb = ((0.0, 0.01), (1.0, 0.02))
    recent = ((0.0, 0.5), (1.0, 0.9))
    hyp = ((0.0, 0.0), (1.0, 0.1))
    hyp_recent = ((0.0, 0.3), (1.0, 0.95))
    from test_track_tracker import CONFIG, GRID, MOTION, SENSOR, _scenario

    run, _ = _scenario()
    for span in (1.0, 1e6):
        config = replace(
            CONFIG,
            confidence_localized=loc,
            confidence_ambiguous=amb,
            confidence_recent=recent,
            confidence_recent_s=span,
            confidence_hypothesis=hyp,
            confidence_hypothesis_recent=hyp_recent,
        )
        res = track(GRID, run.odometry, run.frames, sensor=SENSOR, motion=MOTION, config=config)
        read = {"recent": 0, "ambiguous": 0}
        for e in res.estimates:
            soon = e.since_localized is not None and e.since_localized <= span
            # Every hypothesis, localized frames' too, by the table of its frame's time.
            for h in e.hypotheses:
                assert h.confidence == confidence_of(hyp_recent if soon else hyp, h.weight)
            if e.state is not TrackState.AMBIGUOUS:
                continue
            assert e.probability is not None
            table = recent if soon else amb
            assert e.confidence == confidence_of(table, e.probability)
            read["recent" if soon else "ambiguous"] += 1
        # (Both tables are read: ambiguous frames before the first localized one and after
        # the kidnapping's flag, and some soon after a localized one.)
        assert read["recent"] > 0 and read["ambiguous"] > 0, read


def test_a_new_span_drops_the_recent_table_fitted_for_the_old_one(caplog) -> None:  # type: ignore[no-untyped-def]
    import logging

    sensor, motion, config = preset("mrclam")
    assert config.confidence_recent is not None
    assert config.confidence_hypothesis_recent is not None
    with caplog.at_level(logging.WARNING, logger="omniloc.track.presets"):
        _, _, other = with_settings(sensor, motion, config, {"confidence_recent_s": 5.0})
    assert other.confidence_recent is None and "confidence_recent_s changed" in caplog.text
    assert other.confidence_ambiguous == config.confidence_ambiguous
    _, _, given = with_settings(
        sensor, motion, config, {"confidence_recent_s": 5.0, "confidence_recent": ((0.5, 0.5),)}
    )
    assert given.confidence_recent == ((0.5, 0.5),)
    assert other.confidence_hypothesis_recent is None
    assert other.confidence_hypothesis == config.confidence_hypothesis
    _, _, wider = with_settings(sensor, motion, config, {"tolerance_heading": 0.1})
    assert wider.confidence_recent is None and wider.confidence_hypothesis_recent is None


def test_the_hypotheses_of_frames_soon_after_a_localized_one_have_a_table_of_their_own() -> None:
    from omniloc.track.confidence import held_out_table

    w = [0.9] * 6
    right = [True, True, True, False, False, False]
    since = [0.0, 5.0, 20.0, None, 30.0, math.nan]
    fit = fit_confidence(
        ["localized"],
        [0.99],
        [True],
        hypothesis_weights=w,
        hypothesis_right=right,
        hypothesis_since_localized=since,
    )
    assert fit.frames["hypothesis_recent"] == 3 and fit.right["hypothesis_recent"] == 3
    assert fit.frames["hypothesis"] == 3 and fit.right["hypothesis"] == 0
    assert confidence_of(fit.hypothesis_recent, 0.9) == pytest.approx(3.5 / 4)
    assert confidence_of(fit.hypothesis, 0.9) == pytest.approx(0.5 / 4)
    assert fit.settings()["confidence_hypothesis_recent"] == fit.hypothesis_recent
    assert fit.settings()["confidence_recent_s"] == 20.0
    # Without the times: one table, as before.
    one = fit_confidence(
        ["localized"], [0.99], [True], hypothesis_weights=w, hypothesis_right=right
    )
    assert one.hypothesis_recent is None and one.settings()["confidence_hypothesis_recent"] is None
    assert confidence_of(one.hypothesis, 0.9) == pytest.approx(3.5 / 7)
    for bad, message in (
        ({"hypothesis_since_localized": [1.0]}, "hypothesis_since_localized"),
        ({"hypothesis_since_localized": [-1.0] * 6}, "hypothesis_since_localized"),
        ({"hypothesis_right": [True] * 5}, "hypothesis_weights and hypothesis_right"),
    ):
        kw = {"hypothesis_weights": w, "hypothesis_right": right, **bad}
        with pytest.raises(InputError, match=message):
            fit_confidence(["localized"], [0.99], [True], **kw)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="needs hypothesis_weights"):
        fit_confidence(["localized"], [0.99], [True], hypothesis_since_localized=[1.0])
    # Held out by run, a table per context.
    runs = ["a", "b", "a", "b", "a", "b"]
    soon = [True, True, True, False, False, False]
    out = held_out_table(w, right, runs, contexts=soon)
    # Run a's recent case 0 reads run b's recent cases (one, right): 1.5 / 2.
    assert out[0] == pytest.approx(1.5 / 2) and out[4] == pytest.approx(0.5 / 3)
    with pytest.raises(InputError, match="contexts"):
        held_out_table(w, right, runs, contexts=[True])


def test_is_recent_is_the_one_rule_for_scalars_and_arrays() -> None:
    from omniloc.track.confidence import is_recent

    assert is_recent(20.0, 20.0) is True and is_recent(20.5, 20.0) is False
    assert is_recent(None, 20.0) is False and is_recent(math.nan, 20.0) is False
    assert is_recent(np.float64(3.0), 20.0) is True
    assert is_recent([0.0, 25.0, math.nan, None], 20.0).tolist() == [True, False, False, False]


def test_a_fit_gives_the_frames_of_the_pass_backward_a_table_of_their_own() -> None:
    # At the same probability the forward pass's localized frames are right and the pass
    # backward's are right in one of four: one table each, and the forward pass's table
    # is fitted on its own frames alone.
    n = 200
    p = np.full(n, 0.995)
    back = [False] * 100 + [True] * 100
    right = [True] * 100 + [True, False, False, False] * 25
    fit = fit_confidence(["localized"] * n, p, right, backward=back)
    assert fit.frames["localized"] == 100 and fit.frames["backward"] == 100
    assert fit.right["backward"] == 25
    assert fit("localized", 0.995) > 0.99
    assert fit("localized", 0.995, backward=True) == pytest.approx(25.5 / 101)
    assert fit("ambiguous", 0.995, backward=True) is None  # (no ambiguous frame fitted)
    assert fit.settings()["confidence_backward"] == fit.backward
    # Only localized frames are the pass's: an ambiguous frame flagged stays ambiguous.
    mixed = fit_confidence(["localized", "ambiguous"], [0.9, 0.5], [True, False], backward=[0, 1])
    assert mixed.backward is None and mixed.frames["backward"] == 0
    # Without the flags, every localized frame in one table, as before.
    plain = fit_confidence(["localized"] * n, p, right)
    assert plain.backward is None and plain.settings()["confidence_backward"] is None
    assert plain("localized", 0.995, backward=True) is None
    for bad, message in (([True], "one flag per frame"), (["yes"] * n, "booleans")):
        with pytest.raises(InputError, match=message):
            fit_confidence(["localized"] * n, p, right, backward=bad)


def test_held_out_reads_the_backward_table_of_the_other_runs() -> None:
    from omniloc.track.confidence import held_out_confidence

    states = ["localized"] * 6
    p = [0.99] * 6
    back = [False, True] * 3
    right = [True, False, True, True, True, False]
    runs = ["a", "a", "b", "b", "c", "c"]
    out = held_out_confidence(states, p, right, runs, backward=back)
    # Run c's frame of the pass reads runs a and b's: two frames, one right (1.5 / 3).
    assert out[5] == pytest.approx(1.5 / 3) and out[4] == pytest.approx(2.5 / 3)


def test_a_frame_of_the_pass_backward_reads_its_own_table_or_reports_none() -> None:
    from omniloc.track.backward import combine

    f = TrackEstimate(1.0, TrackState.AMBIGUOUS, Pose(1.0, 2.0, 0.0), np.eye(3) * 1e-2)
    # The backward pass's tracker read its frame with the forward pass's table for
    # localized frames (0.99): reported so, that overstated how often such a frame is right.
    b = TrackEstimate(
        1.0,
        TrackState.LOCALIZED,
        Pose(1.0, 2.0, 0.0),
        np.eye(3) * 1e-4,
        probability=0.995,
        confidence=0.99,
    )
    config = TrackerConfig(confidence_localized=((0.9, 0.99),))
    (out,) = combine([f], [b], config)
    assert out.backward and out.confidence is None
    (out,) = combine([f], [b])
    assert out.confidence is None
    with_table = replace(config, confidence_backward=((0.99, 0.8), (1.0, 0.9)))
    (out,) = combine([f], [b], with_table)
    assert out.confidence == pytest.approx(0.85)


def test_fit_confidence_with_the_pass_backward_fits_its_table(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from omniloc.cli import main

    common, runs, out = _fit_confidence_inputs(tmp_path)
    assert main(["fit-confidence", *common, *runs, "--backward", "20", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "localized by the forward pass:" in text and "localized by the pass backward:" in text
    tables = json.loads(out.read_text())
    assert tables["confidence_backward"] is not None
    # track --backward with these settings: the pass's frames carry their table's confidence.
    from omniloc.track.confidence import confidence_of, confidence_table

    table = confidence_table("t", tables["confidence_backward"])
    argv = ["track", *common, *runs[:6], "--config", str(out), "--backward", "20", "--json"]
    assert main(argv) == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    back = [x for x in lines if x["backward"]]
    assert back and all(x["state"] == "localized" for x in back)
    assert all(x["confidence"] == confidence_of(table, x["probability"]) for x in back)
