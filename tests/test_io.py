"""Tests for omniloc.io: bearing validation, bearing files and JSON output."""

from __future__ import annotations

import dataclasses
import enum
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from omniloc.angles import angdiff
from omniloc.errors import InputError, ObservationError
from omniloc.io import (
    check_bearings,
    content_lines,
    first_content_line,
    load_bearings,
    read_bearings,
    read_text,
    save_bearings,
    to_jsonable,
    write_json,
)
from omniloc.maps import LandmarkMap

DATA = Path(__file__).parent / "data"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(7)


# --------------------------------------------------------------------------------------------
# check_bearings
# --------------------------------------------------------------------------------------------


def test_check_bearings_wraps_and_copies() -> None:
    given = np.array([0.0, 3 * np.pi / 2, -np.pi, np.pi, 7.0, -1e-300])
    out = check_bearings(given)
    assert out is not given and not np.shares_memory(out, given)
    assert out.dtype == np.float64 and out.shape == (6,)
    assert np.all((out >= -np.pi) & (out < np.pi))
    np.testing.assert_allclose(out, [0.0, -np.pi / 2, -np.pi, -np.pi, 7.0 - 2 * np.pi, -1e-300])
    assert out[5] == -1e-300  # in-range values are kept exactly, not rounded through +pi -pi
    out[0] = 1.0
    assert given[0] == 0.0


def test_check_bearings_accepts_lists_ints_and_limits() -> None:
    np.testing.assert_array_equal(check_bearings([0, 1, 2]), [0.0, 1.0, 2.0])
    assert check_bearings([0.1, 0.2, 0.3, 0.4, 0.5], n_landmarks=5).shape == (5,)
    assert check_bearings([0.1], min_count=1).shape == (1,)
    assert check_bearings([], min_count=0).shape == (0,)


@pytest.mark.parametrize(
    ("bearings", "kwargs", "expected"),
    [
        (np.zeros((3, 2)), {}, "bearings must have shape (m,), got (3, 2)"),
        (np.zeros((3, 1)), {}, "bearings must have shape (m,), got (3, 1)"),
        (np.zeros((1, 3)), {}, "bearings must have shape (m,), got (1, 3)"),
        (0.5, {}, "bearings must have shape (m,), got ()"),
        ([1.0, 2.0], {}, "localization needs at least 3 bearings, got 2"),
        ([], {}, "localization needs at least 3 bearings, got 0"),
        ([1.0, 2.0, 3.0], {"min_count": 4}, "localization needs at least 4 bearings, got 3"),
        ([0.0] * 7, {"n_landmarks": 5}, "7 bearings but the map has only 5 landmarks"),
        ([0.1, np.nan, 0.3, np.inf], {}, "bearings[1] is not finite: nan (and 1 more)"),
        ([0.1, 0.2, -np.inf], {}, "bearings[2] is not finite: -inf"),
        (["a", "b", "c"], {}, "bearings must contain real numbers, got an array of dtype <U1"),
        ([1j, 2, 3], {}, "bearings must contain real numbers, got an array of dtype complex128"),
        ([True, False, True], {}, "bearings must contain real numbers, got an array of dtype bool"),
        ([[1, 2], [3]], {}, "bearings must be a rectangular array of real numbers"),
        ([1.0, "x", 3.0], {}, "bearings must contain real numbers"),
        ([1.0, 2.0], {"name": "observed"}, "localization needs at least 3 observed, got 2"),
        (np.zeros((2, 2)), {"name": "observed"}, "observed must have shape (m,), got (2, 2)"),
    ],
)
def test_check_bearings_bad(bearings: Any, kwargs: dict[str, Any], expected: str) -> None:
    with pytest.raises(ObservationError) as info:
        check_bearings(bearings, **kwargs)
    assert expected in str(info.value)
    assert isinstance(info.value, ValueError)


# --------------------------------------------------------------------------------------------
# load_bearings
# --------------------------------------------------------------------------------------------


def test_golden_bearings_match_golden_map() -> None:
    bearings = load_bearings(DATA / "bearings_deg.csv")
    landmarks = LandmarkMap.from_csv(DATA / "map_small.csv")
    d = landmarks.xy - [1.0, 1.0]
    np.testing.assert_allclose(bearings, np.arctan2(d[:, 1], d[:, 0]), rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("name", "text", "degrees", "expected_deg"),
    [
        ("b.csv", "bearing\n10\n20\n-30\n", True, [10, 20, -30]),
        ("b.csv", "# c\n\nBearing_Deg\n10\n\n# x\n370\n", False, [10, 10]),
        ("b.csv", "bearing_deg\n10\n190\n", True, [10, -170]),
        ("b.csv", "time, bearing_deg ,conf\n0,45,0.9\n1,-45,0.8\n", False, [45, -45]),
        ("b.csv", "10\n20\n30\n", True, [10, 20, 30]),
        ("b.csv", "\ufeff10\r\n20\r\n", True, [10, 20]),
        ("b.json", "[10, 20, 30.5]", True, [10, 20, 30.5]),
        ("b.json", '{"bearings": [10, 20], "units": "deg"}', False, [10, 20]),
        ("b.json", '{"bearings": [10, 20], "units": "deg"}', True, [10, 20]),
        ("b.json", '{"bearings": [10, 20]}', True, [10, 20]),
        (
            "b.txt",
            "10 20,30\n# comment 99\n\n40 # trailing 99\n,,50\t60\n",
            True,
            [10, 20, 30, 40, 50, 60],
        ),
        ("bearings", "180\n-180\n540\n", True, [-180, -180, -180]),
    ],
)
def test_load_bearings_degrees(
    tmp_path: Path, name: str, text: str, degrees: bool, expected_deg: list[float]
) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    out = load_bearings(path, degrees=degrees)
    assert out.dtype == np.float64 and out.ndim == 1
    assert np.all((out >= -np.pi) & (out < np.pi))
    np.testing.assert_allclose(out, np.deg2rad(expected_deg), rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("b.csv", "bearing\n0.5\n-1.0\n"),
        ("b.csv", "bearing_rad\n0.5\n-1.0\n"),
        ("b.csv", "0.5\n-1.0\n"),
        ("b.json", "[0.5, -1.0]"),
        ("b.json", '{"bearings": [0.5, -1.0], "units": "rad"}'),
        ("b.txt", "0.5 -1.0"),
        ("b.dat", "0.5\n-1.0\n"),
    ],
)
def test_load_bearings_radians(tmp_path: Path, name: str, text: str) -> None:
    path = tmp_path / name
    path.write_text(text)
    np.testing.assert_array_equal(load_bearings(path), [0.5, -1.0])
    np.testing.assert_array_equal(load_bearings(str(path)), [0.5, -1.0])


@pytest.mark.parametrize(
    ("name", "text", "degrees", "expected"),
    [
        ("b.csv", "", False, "b.csv: no bearings found"),
        ("b.csv", "# nothing\n\n", False, "b.csv: no bearings found"),
        ("b.csv", "bearing_deg\n", False, "b.csv: no bearings found"),
        ("b.csv", "angle\n1\n", False, "b.csv line 1: header must contain a column named bearing"),
        ("b.csv", "bearing,bearing_deg\n1,2\n", False, "b.csv line 1: several bearing columns"),
        ("b.csv", "bearing\n1\n2\nabc\n", False, "b.csv line 4: bearing is not a number: 'abc'"),
        # Python's float() reads digit separators: "1_0" would be 10.
        ("b.csv", "bearing\n1\n2\n1_0\n", False, "b.csv line 4: bearing is not a number: '1_0'"),
        ("b.csv", "1_0\n2\n3\n", False, "b.csv line 1: bearing is not a number: '1_0'"),
        ("b.csv", "bearing\n1\n\nnan\n", False, "b.csv line 4: bearing is not finite: 'nan'"),
        ("b.csv", "1\n2\ninf\n", False, "b.csv line 3: bearing is not finite: 'inf'"),
        ("b.csv", "t,bearing\n0,1\n0\n", False, "b.csv line 3: expected 2 fields, got 1"),
        ("b.csv", "1\n2,3\n", False, "b.csv line 2: expected 1 fields, got 2"),
        ("b.csv", 'bearing\n"1\n', False, "b.csv line 2: malformed CSV"),
        (
            "b.csv",
            "bearing_rad\n1\n",
            True,
            "b.csv line 1: the file declares radians but degrees=True",
        ),
        ("b.json", "", False, "b.json line 1 column 1: invalid JSON"),
        ("b.json", "[1,\n 2,,]", False, "b.json line 2 column 4: invalid JSON"),
        ("b.json", "[]", False, "b.json: no bearings found"),
        ("b.json", '[1, 2, "x"]', False, "b.json: bearings[2] is not a number: 'x'"),
        ("b.json", "[1, NaN]", False, "b.json: bearings[1] is not finite: nan"),
        ("b.json", "[1, -Infinity]", False, "b.json: bearings[1] is not finite: -inf"),
        ("b.json", "[1, null]", False, "b.json: bearings[1] is not a number: None"),
        ("b.json", "[1, true]", False, "b.json: bearings[1] is not a number: True"),
        ("b.json", "[[1, 2]]", False, "b.json: bearings[0] is not a number: [1, 2]"),
        ("b.json", "3", False, "b.json: expected a list of numbers or an object"),
        ("b.json", '{"b": [1]}', False, "got an object with keys 'b'"),
        (
            "b.json",
            '{"bearings": 1}',
            False,
            "b.json: 'bearings' must be a list of numbers, got a number",
        ),
        (
            "b.json",
            '{"bearings": [1], "units": "grad"}',
            False,
            "units must be 'deg' or 'rad', got 'grad'",
        ),
        ("b.json", '{"bearings": [1], "units": "rad"}', True, "b.json: the file declares radians"),
        ("b.txt", "", False, "b.txt: no bearings found"),
        ("b.txt", "# only\n  \n", False, "b.txt: no bearings found"),
        ("b.txt", "1 2\n3\n4 abc 5\n", False, "b.txt line 3: bearing is not a number: 'abc'"),
        ("b.txt", "1; 2\n", False, "b.txt line 1: bearing is not a number: '1;'"),
        ("b.txt", "1 2\n3 4_5\n", False, "b.txt line 2: bearing is not a number: '4_5'"),
        ("b.txt", "1\n\n-nan\n", False, "b.txt line 3: bearing is not finite: '-nan'"),
    ],
)
def test_load_bearings_bad(
    tmp_path: Path, name: str, text: str, degrees: bool, expected: str
) -> None:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ObservationError) as info:
        load_bearings(path, degrees=degrees)
    assert expected in str(info.value)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("name", "text", "expected"),
    [
        ("b.csv", "bearing\n0.5\n45\n-120\n", "b.csv: bearings[1] is 45, more than a full turn"),
        ("b.csv", "bearing_rad\n-7\n", "b.csv: bearings[0] is -7, more than a full turn"),
        ("b.json", "[10, 20, 30.5]", "b.json: bearings[0] is 10, more than a full turn"),
        ("b.txt", "0.1 0.2\n350\n", "b.txt: bearings[2] is 350, more than a full turn"),
    ],
)
def test_load_bearings_in_degrees_without_saying_so_is_an_error(
    tmp_path: Path, name: str, text: str, expected: str
) -> None:
    # Degrees read as radians would localize the robot somewhere, wrongly: a value beyond a
    # full turn in radians is refused, naming it and the flag that reads degrees.
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ObservationError) as info:
        load_bearings(path)
    assert expected in str(info.value) and "--degrees" in str(info.value)
    # A full turn and a hair under it are still radians.
    ok = tmp_path / "ok.txt"
    ok.write_text("6.283185307179586\n-6.28\n6.2\n")
    np.testing.assert_allclose(load_bearings(ok), [0.0, 0.00318531, -0.08318531], atol=1e-8)


@pytest.mark.parametrize("name", ["b.csv", "b.json", "b.txt"])
def test_load_bearings_unreadable(tmp_path: Path, name: str) -> None:
    with pytest.raises(
        ObservationError, match=r"missing_" + name.replace(".", r"\.") + ": file not found"
    ):
        load_bearings(tmp_path / f"missing_{name}")
    (tmp_path / name).mkdir()
    with pytest.raises(ObservationError, match="is a directory"):
        load_bearings(tmp_path / name)
    binary = tmp_path / f"bin_{name}"
    binary.write_bytes(b"\x80\x81\x82")
    with pytest.raises(ObservationError, match=r"not a UTF-8 text file"):
        load_bearings(binary)


def test_first_content_line_counts_lines_as_content_lines_does(tmp_path: Path) -> None:
    f = tmp_path / "f.txt"
    for text in (
        "\ufeff# a comment\n\n   \n  # another\r\n1 2 3\r\n4 5 6\n",
        "1 2 3\n",
        "1 2 3",  # no line end
        "# only\n1 2 3\rstill the same line\n",  # a lone CR ends no line
    ):
        f.write_bytes(text.encode("utf-8"))
        first = first_content_line(f, InputError)
        lines = content_lines(f.read_bytes().decode("utf-8-sig"))
        assert first == lines[0][1]
    f.write_text("# nothing but comments\n\n")
    assert first_content_line(f, InputError) is None
    f.write_text("")
    assert first_content_line(f, InputError) is None


def test_first_content_line_reads_no_further_and_names_failures(tmp_path: Path) -> None:
    # The file is read in blocks as far as the first content line, not to its end: an
    # undecodable byte a megabyte further is no error (reading the whole file is).
    f = tmp_path / "f.txt"
    f.write_bytes(b"# head\n1 2 3\n" + b"4 5 6\n" * 200_000 + b"\x80")
    assert first_content_line(f, InputError) == "1 2 3"
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        read_text(f, InputError)
    f.write_bytes(b"# head\n\x80\n")
    with pytest.raises(InputError, match=r"f\.txt: not a UTF-8 text file \(undecodable byte at"):
        first_content_line(f, InputError)
    with pytest.raises(ObservationError, match=r"missing\.txt: file not found"):
        first_content_line(tmp_path / "missing.txt", ObservationError)
    with pytest.raises(InputError, match="is a directory"):
        first_content_line(tmp_path, InputError)


# --------------------------------------------------------------------------------------------
# save_bearings
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["b.csv", "b.json", "b.txt", "b.CSV", "bearings"])
@pytest.mark.parametrize("degrees", [False, True])
def test_save_load_round_trip(
    tmp_path: Path, rng: np.random.Generator, name: str, degrees: bool
) -> None:
    bearings = rng.uniform(-np.pi, np.pi, size=50)
    bearings[:4] = [-np.pi, 0.0, -0.0, np.nextafter(np.pi, 0.0)]
    path = tmp_path / name
    save_bearings(path, bearings, degrees=degrees)
    # CSV and JSON record their units; plain text needs the same flag back.
    plain = path.suffix.lower() not in (".csv", ".json")
    back = load_bearings(path, degrees=degrees if plain else False)
    assert back.shape == bearings.shape
    if degrees:
        np.testing.assert_allclose(angdiff(back, bearings), 0.0, rtol=0, atol=1e-14)
    else:
        np.testing.assert_array_equal(back, bearings)  # radians read back bit for bit


def test_save_bearings_wraps_and_writes_units(tmp_path: Path) -> None:
    save_bearings(tmp_path / "b.json", [np.pi / 2, 3 * np.pi / 2], degrees=True)
    data = json.loads((tmp_path / "b.json").read_text())
    assert data == {"bearings": [90.0, -90.0], "units": "deg"}
    save_bearings(tmp_path / "b.csv", [np.pi / 2, 3 * np.pi / 2], degrees=True)
    assert (tmp_path / "b.csv").read_text() == "bearing_deg\n90.0\n-90.0\n"
    save_bearings(tmp_path / "b.txt", [0.25], degrees=False)
    assert (tmp_path / "b.txt").read_text() == "# bearings in radians\n0.25\n"


@pytest.mark.parametrize(
    ("bearings", "expected"),
    [
        ([], "localization needs at least 1 bearings, got 0"),
        ([[0.1, 0.2]], "bearings must have shape (m,), got (1, 2)"),
        ([0.1, np.nan], "bearings[1] is not finite"),
    ],
)
def test_save_bearings_bad(tmp_path: Path, bearings: Any, expected: str) -> None:
    with pytest.raises(ObservationError) as info:
        save_bearings(tmp_path / "b.csv", bearings)
    assert expected in str(info.value)
    assert not (tmp_path / "b.csv").exists()


def test_save_bearings_unwritable(tmp_path: Path) -> None:
    with pytest.raises(ObservationError, match=r"no_dir.*cannot write file"):
        save_bearings(tmp_path / "no_dir" / "b.csv", [0.1])


# --------------------------------------------------------------------------------------------
# JSON output
# --------------------------------------------------------------------------------------------


class Colour(enum.Enum):
    RED = "red"


@dataclasses.dataclass(frozen=True)
class Point:
    x: float
    y: np.float64


def test_the_detections_of_omniloc_bearings_json_are_bearings(tmp_path: Path) -> None:
    det = {
        "units": "degrees",
        "calibration": {"center": [320.0, 240.0], "aspect": 1.0, "radius": 200.0},
        "detections": [
            {"bearing": -170.0, "strength": 30.0, "kind": "edge", "ambiguous": False},
            {"bearing": 10.0, "strength": 40.0, "kind": "edge", "ambiguous": True},
            {"bearing": 95.0, "strength": 50.0, "kind": "pole", "ambiguous": False},
        ],
    }
    p = tmp_path / "det.json"
    p.write_text(json.dumps(det))
    b, amb = read_bearings(p)
    np.testing.assert_allclose(np.rad2deg(b), [-170.0, 10.0, 95.0])
    assert amb.tolist() == [False, True, False]
    np.testing.assert_array_equal(load_bearings(p), b)
    # Radians said in words; any other file flags nothing.
    det["units"] = "radians"
    det["detections"] = [{"bearing": x} for x in (0.1, -0.2, 3.0)]
    p.write_text(json.dumps(det))
    b, amb = read_bearings(p)
    np.testing.assert_allclose(b, [0.1, -0.2, 3.0])
    assert not amb.any()
    with pytest.raises(ObservationError, match="declares radians"):
        read_bearings(p, degrees=True)
    q = tmp_path / "b.txt"
    q.write_text("0.1 0.2 0.3\n")
    assert read_bearings(q)[1].tolist() == [False, False, False]
    for bad, message in (
        ({"detections": [{"strength": 3}]}, r"detections\[0\] must be an object with a 'bearing'"),
        ({"detections": [{"bearing": 0.1, "ambiguous": "yes"}]}, r"ambiguous must be true"),
        ({"detections": {"bearing": 0.1}}, "'detections' must be a list"),
        ({"units": "grads", "bearings": [1.0]}, "units must be 'deg' or 'rad'"),
    ):
        p.write_text(json.dumps(bad))
        with pytest.raises(ObservationError, match=message):
            read_bearings(p)


def test_to_jsonable_and_write_json(tmp_path: Path) -> None:
    obj = {
        "array": np.arange(4, dtype=np.int32).reshape(2, 2),
        "floats": np.array([0.5, np.nan, np.inf]),
        "scalars": (np.float32(0.5), np.int64(7), np.bool_(True)),
        "nan": float("nan"),
        "enum": Colour.RED,
        "path": tmp_path / "x.txt",
        "point": Point(1.0, np.float64(2.5)),
        np.int64(3): "numpy key",
        Colour.RED: "enum key",
        "nested": [{"a": np.float64(1.25)}],
    }
    expected = {
        "array": [[0, 1], [2, 3]],
        "floats": [0.5, None, None],
        "scalars": [0.5, 7, True],
        "nan": None,
        "enum": "red",
        "path": str(tmp_path / "x.txt"),
        "point": {"x": 1.0, "y": 2.5},
        3: "numpy key",
        "red": "enum key",
        "nested": [{"a": 1.25}],
    }
    assert to_jsonable(obj) == expected
    write_json(tmp_path / "out.json", obj)
    text = (tmp_path / "out.json").read_text()
    assert text.endswith("}\n")
    loaded = json.loads(text)
    expected["3"] = expected.pop(3)  # JSON keys are strings
    assert loaded == expected
    types = [type(v) for v in to_jsonable(obj)["scalars"]]
    assert types == [float, int, bool]


def test_write_json_map_reads_back_as_map(tmp_path: Path) -> None:
    m = LandmarkMap([[0.0, 0.0], [3.0, 0.0], [0.0, 4.0]], ids=["a", "b", "c"])
    write_json(tmp_path / "m.json", m)
    assert LandmarkMap.from_json(tmp_path / "m.json") == m


def test_write_json_errors(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="cannot convert object to JSON"):
        write_json(tmp_path / "x.json", {"a": object()})
    with pytest.raises(InputError, match=r"no_dir.*cannot write file"):
        write_json(tmp_path / "no_dir" / "x.json", {"a": 1})
