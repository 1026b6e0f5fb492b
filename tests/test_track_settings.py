"""Settings by name (omniloc.track.with_settings, load_settings): each name belongs to one
of the sensor model, the motion model and the tracker configuration, and every value is
checked as when those are made."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from omniloc.errors import InputError
from omniloc.sensor import SensorModel
from omniloc.track import (
    MotionModel,
    TrackerConfig,
    load_settings,
    preset,
    settings_names,
    with_settings,
)


def test_each_name_goes_to_its_owner_and_the_rest_is_kept() -> None:
    sensor, motion, config = preset("mrclam")
    s, m, c = with_settings(
        sensor, motion, config, {"p_detect": 0.5, "delay_s": 0.1, "min_age_s": 12.0}
    )
    assert s == sensor.replace(p_detect=0.5)
    assert m == dataclasses.replace(motion, delay_s=0.1)
    assert c == dataclasses.replace(config, min_age_s=12.0)
    # nothing asked, nothing changed (the same objects)
    assert with_settings(sensor, motion, config, {}) == (sensor, motion, config)


def test_the_names_are_the_three_classes_fields_and_none_is_shared() -> None:
    names = settings_names()
    owners = {"sensor": SensorModel, "motion": MotionModel, "tracker": TrackerConfig}
    total = 0
    for owner, cls in owners.items():
        fields = {f.name for f in dataclasses.fields(cls)}
        assert {n for n, o in names.items() if o == owner} == fields
        total += len(fields)
    assert len(names) == total


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"min_agee_s": 1.0}, "did you mean 'min_age_s'"),
        ({"nothing_like_it": 1.0}, "unknown setting 'nothing_like_it': not a field"),
        ({"min_age_s": "x"}, "min_age_s must be a number"),
        ({"sigma": -1.0}, "sigma"),
        ({"max_hypotheses": 2.5}, "max_hypotheses must be a positive integer"),
        ({"v_scale": 0.0}, "v_scale"),
        ({"region": [0, 1]}, "region must be"),
    ],
)
def test_a_bad_name_or_value_is_named(settings: dict[str, object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        with_settings(*preset("generic"), settings)


def test_settings_must_be_a_mapping() -> None:
    with pytest.raises(InputError, match="mapping"):
        with_settings(*preset("generic"), [("min_age_s", 1.0)])  # type: ignore[arg-type]


def test_a_settings_file(tmp_path: Path) -> None:
    f = tmp_path / "s.json"
    f.write_text('{"min_age_s": 10, "region": [-1, 5.5, -6, 6.5]}')
    settings = load_settings(f)
    _, _, c = with_settings(*preset("generic"), settings)
    assert c.min_age_s == 10.0 and c.region == (-1.0, 5.5, -6.0, 6.5)
    for text, message in (
        ("[1, 2]", "one JSON object"),
        ("{not json", "invalid JSON"),
        ('"min_age_s"', "one JSON object"),
    ):
        f.write_text(text)
        with pytest.raises(InputError, match=message):
            load_settings(f)
    f.write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        load_settings(f)
    with pytest.raises(InputError, match="file not found"):
        load_settings(tmp_path / "missing.json")
    with pytest.raises(InputError, match="settings file must be a file name"):
        load_settings(3)  # type: ignore[arg-type]


def test_the_evaluation_builds_its_trackers_with_the_settings() -> None:
    from omniloc import demo_room
    from omniloc.evaluate.tracking import tracker_factory

    make = tracker_factory("mrclam", {"min_age_s": 7.0, "p_detect": 0.4, "delay_s": 0.1})
    tr = make(demo_room(), None)
    assert tr.config.min_age_s == 7.0 and tr.sensor.p_detect == 0.4 and tr.motion.delay_s == 0.1
    assert tracker_factory("mrclam")(demo_room(), None).config == preset("mrclam")[2]


def test_evaluate_refuses_bad_settings_before_reading_the_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from omniloc.cli import main

    argv = ["-q", "evaluate", "--out", str(tmp_path / "out")]
    missing = str(tmp_path / "no-such-folder")
    assert main([*argv, "--dataset", "mrclam-track", missing, "--set", "min_agee_s=3"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "did you mean 'min_age_s'" in err
    # settings are the tracker's: a sweep or a single-frame dataset refuses them
    assert main([*argv, "--preset", "quick", "--set", "min_age_s=3"]) == 1
    err = capsys.readouterr().err.strip()
    assert "apply to --dataset mrclam-track only" in err
    assert not (tmp_path / "out").exists()
