"""Tests for omniloc.maps: LandmarkMap validation, lookups and its CSV/JSON files."""

from __future__ import annotations

import dataclasses
import pickle
import tempfile
from copy import deepcopy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from omniloc.errors import InputError, MapError
from omniloc.maps import LandmarkMap, as_landmark_map

DATA = Path(__file__).parent / "data"

SQUARE = [[0.0, 0.0], [5.0, 0.0], [5.0, 4.0], [0.0, 4.0], [2.5, 2.0]]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)


@pytest.fixture
def small_map() -> LandmarkMap:
    return LandmarkMap(
        SQUARE, ids=[1, 2, 3, 4, 10], names=["door", "lamp", "plant", "shelf, left", "table"]
    )


# --------------------------------------------------------------------------------------------
# Construction
# --------------------------------------------------------------------------------------------


def test_defaults_and_stored_copy() -> None:
    given_xy = np.array(SQUARE)
    m = LandmarkMap(given_xy)
    assert m.ids == (0, 1, 2, 3, 4)
    assert m.names is None
    assert len(m) == m.n == 5
    assert m.xy is not given_xy
    given_xy[0, 0] = 99.0  # the caller's array is not shared
    assert m.xy[0, 0] == 0.0
    assert m.xy.dtype == np.float64
    assert m.xy.flags.c_contiguous
    assert not m.xy.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        m.xy[0, 0] = 1.0


def test_fortran_order_int_input_is_stored_as_c_float64() -> None:
    xy = np.asfortranarray(np.array([[0, 0], [3, 0], [0, 4]], dtype=np.int32))
    m = LandmarkMap(xy, ids=np.array([7, 8, 9]))
    assert m.xy.flags.c_contiguous and m.xy.dtype == np.float64
    np.testing.assert_array_equal(m.xy, xy)
    assert m.ids == (7, 8, 9)
    assert all(type(i) is int for i in m.ids)  # numpy integers become plain ints


def test_frozen() -> None:
    m = LandmarkMap(SQUARE)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.ids = (5, 6, 7, 8, 9)  # type: ignore[misc]


def test_replace_validates_and_pickle_keeps_map_read_only() -> None:
    m = LandmarkMap(SQUARE, names=list("abcde"))
    assert dataclasses.replace(m, ids=tuple("vwxyz")).ids == tuple("vwxyz")
    with pytest.raises(MapError, match="duplicate landmark id 'v'"):
        dataclasses.replace(m, ids=tuple("vwxyv"))
    _ = m.kdtree
    for copy in (pickle.loads(pickle.dumps(m)), deepcopy(m)):
        assert copy == m and copy is not m
        assert not copy.xy.flags.writeable
        assert copy.kdtree.n == 5


@pytest.mark.parametrize(
    ("xy", "kwargs", "expected"),
    [
        (np.zeros((5, 3)), {}, "landmarks_xy must have shape (N, 2), got (5, 3)"),
        (np.zeros(6), {}, "landmarks_xy must have shape (N, 2), got (6,)"),
        (np.zeros((2, 2, 2)), {}, "landmarks_xy must have shape (N, 2), got (2, 2, 2)"),
        (5.0, {}, "landmarks_xy must have shape (N, 2), got ()"),
        ([[0, 0], [1, 1]], {}, "a map needs at least 3 landmarks, got 2"),
        (np.zeros((0, 2)), {}, "a map needs at least 3 landmarks, got 0"),
        ([[0, 0], [1, 1], [2, 2, 2]], {}, "landmarks_xy must be a rectangular array"),
        ([["a", "b"], [1, 1], [2, 2]], {}, "landmarks_xy must contain real numbers"),
        (np.ones((3, 2), dtype=complex), {}, "landmarks_xy must contain real numbers"),
        (np.ones((3, 2), dtype=bool), {}, "landmarks_xy must contain real numbers"),
        ([[0, 0], [1, None], [2, 2]], {}, "landmark 1 (id 1) has a non-finite coordinate"),
        (
            [[0, 0], [1, 0], [2, 0], [3, np.nan], [4, 0]],
            {"ids": ["A", "x", "y", "B", "C"]},
            "landmark 3 (id 'B') has a non-finite coordinate",
        ),
        ([[0, 0], [np.inf, 0], [2, 0]], {}, "landmark 1 (id 1) has a non-finite coordinate"),
        (SQUARE, {"ids": [1, 2, 3]}, "ids must have one entry per landmark: expected 5, got 3"),
        (SQUARE, {"ids": "abcde"}, "not a single string"),
        (SQUARE, {"ids": [1, 2, 3, 4, 1.5]}, "landmark 4: id must be an int or a str"),
        (SQUARE, {"ids": [1, 2, True, 4, 5]}, "landmark 2: id must be an int or a str"),
        (SQUARE, {"ids": [1, 2, "", 4, 5]}, "landmark 2: id must not be an empty string"),
        (
            [[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [5, 0], [6, 0]],
            {"ids": [0, 1, 7, 3, 4, 7, 6]},
            "duplicate landmark id 7 (rows 2 and 5)",
        ),
        (SQUARE, {"ids": ["a", "b", "c", "b", "e"]}, "duplicate landmark id 'b' (rows 1 and 3)"),
        (SQUARE, {"names": ["a", "b"]}, "names must have one entry per landmark: expected 5"),
        (SQUARE, {"names": "abcde"}, "not a single string"),
        (SQUARE, {"names": ["a", "b", "c", "d", 5]}, "landmark 4: name must be a str, got int"),
        (
            [[0, 0], [9, 9], [1, 2], [8, 8], [7, 7], [1, 2]],
            {"ids": ["x", "y", "A", "z", "w", "C"]},
            "landmarks 2 and 5 (ids 'A', 'C') coincide at (1.000, 2.000)",
        ),
        (
            [[0, 0], [9, 9], [1, 2], [8, 8], [7, 7], [1 + 1e-12, 2]],
            {"ids": ["x", "y", "A", "z", "w", "C"]},
            "landmarks 2 and 5 (ids 'A', 'C') coincide at (1.000, 2.000)",
        ),
    ],
)
def test_bad_constructor_input(xy: Any, kwargs: dict[str, Any], expected: str) -> None:
    with pytest.raises(MapError) as info:
        LandmarkMap(xy, **kwargs)
    assert expected in str(info.value)
    assert isinstance(info.value, ValueError)  # MapError is an InputError, hence a ValueError


def test_landmarks_just_apart_are_accepted() -> None:
    m = LandmarkMap([[0.0, 0.0], [1e-8, 0.0], [1.0, 1.0]])
    assert m.n == 3


def test_large_map_validates(rng: np.random.Generator) -> None:
    xy = rng.uniform(-500.0, 500.0, size=(100_000, 2))
    m = LandmarkMap(xy)
    assert m.n == 100_000
    assert m.ids[-1] == 99_999
    np.testing.assert_array_equal(m.xy, xy)
    assert m.kdtree.n == 100_000


def test_large_map_with_one_coincident_pair_names_it(rng: np.random.Generator) -> None:
    xy = rng.uniform(-500.0, 500.0, size=(100_000, 2))
    xy[77_000] = xy[1234] + [0.0, 1e-12]
    with pytest.raises(MapError, match=r"landmarks 1234 and 77000 \(ids 1234, 77000\) coincide"):
        LandmarkMap(xy)


def test_map_of_identical_points_is_rejected_quickly() -> None:
    # Quadratic pair enumeration would need 5e9 pairs here; the check must not do that.
    with pytest.raises(MapError, match=r"landmarks 0 and 1 \(ids 0, 1\) coincide at \(3\.000"):
        LandmarkMap(np.full((100_000, 2), 3.0))


@st.composite
def valid_maps(draw: st.DrawFn) -> tuple[np.ndarray, list[int | str] | None, list[str] | None]:
    n = draw(st.integers(min_value=3, max_value=25))
    coord = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
    points = draw(st.lists(st.tuples(coord, coord), min_size=n, max_size=n, unique=True))
    xy = np.array(points, dtype=np.float64)
    gaps = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(gaps, np.inf)
    assume(gaps.min() > 1e-9)
    id_strategy = st.one_of(st.integers(), st.text(min_size=1, max_size=8))
    ids = draw(st.none() | st.lists(id_strategy, min_size=n, max_size=n, unique=True))
    names = draw(st.none() | st.lists(st.text(max_size=8), min_size=n, max_size=n))
    return xy, ids, names


@settings(max_examples=150, deadline=None)
@given(valid_maps())
def test_map_keeps_exactly_what_it_is_given(
    case: tuple[np.ndarray, list[int | str] | None, list[str] | None],
) -> None:
    xy, ids, names = case
    m = LandmarkMap(xy.tolist(), ids=ids, names=names)
    assert m.xy.tobytes() == xy.tobytes()  # bit for bit, including the sign of zero
    assert m.ids == (tuple(ids) if ids is not None else tuple(range(len(xy))))
    assert m.names == (tuple(names) if names is not None else None)
    for row, lid in enumerate(m.ids):
        assert m.index_of(lid) == row
    assert m == LandmarkMap(xy, ids=ids, names=names)
    assert hash(m) == hash(LandmarkMap(xy, ids=ids, names=names))


# --------------------------------------------------------------------------------------------
# Lookups and protocol
# --------------------------------------------------------------------------------------------


def test_index_of_and_ids_of(small_map: LandmarkMap) -> None:
    assert small_map.index_of(10) == 4
    assert small_map.index_of(1) == 0
    assert small_map.ids_of([4, None, 0, np.int64(2)]) == [10, None, 1, 3]
    assert small_map.ids_of([]) == []


@pytest.mark.parametrize(
    ("landmark_id", "expected"), [(5, "unknown landmark id 5"), ("10", "unknown landmark id '10'")]
)
def test_index_of_unknown(small_map: LandmarkMap, landmark_id: int | str, expected: str) -> None:
    with pytest.raises(MapError, match=expected):
        small_map.index_of(landmark_id)


@pytest.mark.parametrize(
    ("indices", "expected"),
    [
        ([0, 5], "landmark index 5 out of range for a map of 5 landmarks"),
        ([-1], "landmark index -1 out of range"),
        ([1.0], "landmark index must be an int or None, got 1.0"),
        ([True], "landmark index must be an int or None, got True"),
    ],
)
def test_ids_of_bad_index(small_map: LandmarkMap, indices: list[Any], expected: str) -> None:
    with pytest.raises(MapError, match=expected):
        small_map.ids_of(indices)


def test_bounds_kdtree_repr(small_map: LandmarkMap) -> None:
    assert small_map.bounds == (0.0, 0.0, 5.0, 4.0)
    assert all(type(v) is float for v in small_map.bounds)
    assert isinstance(small_map.kdtree, cKDTree)
    assert small_map.kdtree is small_map.kdtree  # built once
    dist, row = small_map.kdtree.query([2.4, 2.1])
    assert row == 4 and dist == pytest.approx(np.hypot(0.1, 0.1))
    assert repr(small_map) == "LandmarkMap(n=5, ids=(1, 2, 3, 4, 10), bounds=(0, 0, 5, 4))"
    big = LandmarkMap([[float(i), float(i * i)] for i in range(10)])
    assert repr(big) == "LandmarkMap(n=10, ids=(0, 1, 2, ..., 8, 9), bounds=(0, 0, 9, 81))"


def test_equality_and_hash() -> None:
    a = LandmarkMap(SQUARE, ids=list("abcde"))
    assert a == LandmarkMap(np.array(SQUARE), ids=tuple("abcde"))
    assert hash(a) == hash(LandmarkMap(np.array(SQUARE), ids=tuple("abcde")))
    assert a != LandmarkMap(SQUARE)  # different ids
    assert a != LandmarkMap(SQUARE, ids=list("abcde"), names=list("vwxyz"))
    moved = np.array(SQUARE)
    moved[2, 1] += 1e-6
    assert a != LandmarkMap(moved, ids=list("abcde"))
    assert a != SQUARE
    assert a != "not a map"
    signed = [[-0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    unsigned = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    assert LandmarkMap(signed) == LandmarkMap(unsigned)
    assert hash(LandmarkMap(signed)) == hash(LandmarkMap(unsigned))


def test_as_landmark_map(small_map: LandmarkMap) -> None:
    assert as_landmark_map(small_map) is small_map
    wrapped = as_landmark_map(np.array(SQUARE))
    assert isinstance(wrapped, LandmarkMap)
    assert wrapped == LandmarkMap(SQUARE)
    with pytest.raises(MapError, match=r"landmarks_xy must have shape \(N, 2\), got \(3, 3\)"):
        as_landmark_map(np.zeros((3, 3)))


# --------------------------------------------------------------------------------------------
# Files: golden data and round trips
# --------------------------------------------------------------------------------------------


def test_golden_files(small_map: LandmarkMap) -> None:
    assert LandmarkMap.from_csv(DATA / "map_small.csv") == small_map
    assert LandmarkMap.from_json(DATA / "map_small.json") == small_map
    assert LandmarkMap.load(DATA / "map_small.csv") == small_map
    assert LandmarkMap.load(str(DATA / "map_small.json")) == small_map


@pytest.mark.parametrize("suffix", [".csv", ".json", ".CSV", ".Json"])
@pytest.mark.parametrize(
    ("ids", "names"),
    [
        (None, None),
        ([3, -1, 100, 7, 0], None),
        (["a", "b,c", 'q"uote', "#hash", "é"], ["door", "", "x, y", "#n", 'say "hi"']),
        ([1, "two", 3, "four", 5], ["1", "2", "3", "4", "5"]),
    ],
)
def test_round_trip(
    tmp_path: Path, suffix: str, ids: list[int | str] | None, names: list[str] | None
) -> None:
    xy = np.array(SQUARE) * np.pi - [1e-7, 3e5]  # digits that only an exact writer keeps
    m = LandmarkMap(xy, ids=ids, names=names)
    path = tmp_path / f"map{suffix}"
    if suffix.lower() == ".csv":
        m.to_csv(path)
        back = LandmarkMap.from_csv(path)
    else:
        m.to_json(path)
        back = LandmarkMap.from_json(path)
    assert back.xy.tobytes() == m.xy.tobytes()
    assert back.names == m.names
    if ids is not None and any(isinstance(i, str) for i in ids):
        assert back.ids == tuple(str(i) for i in ids)  # mixed ids come back as strings
    else:
        assert back.ids == m.ids
        assert back == m
    assert LandmarkMap.load(path) == back


@settings(max_examples=40, deadline=None)
@given(valid_maps())
def test_json_round_trip_property(
    case: tuple[np.ndarray, list[int | str] | None, list[str] | None],
) -> None:
    xy, _, names = case
    m = LandmarkMap(xy, names=names)
    with tempfile.TemporaryDirectory() as d:
        m.to_json(Path(d) / "m.json")
        back = LandmarkMap.from_json(Path(d) / "m.json")
    assert back == m
    assert back.xy.tobytes() == m.xy.tobytes()


def test_integer_like_string_ids_come_back_as_ints(tmp_path: Path) -> None:
    m = LandmarkMap(SQUARE, ids=["1", "2", "3", "4", "5"])
    m.to_csv(tmp_path / "m.csv")
    assert LandmarkMap.from_csv(tmp_path / "m.csv").ids == (1, 2, 3, 4, 5)


def test_csv_format_details(tmp_path: Path) -> None:
    path = tmp_path / "m.csv"
    path.write_text(
        "\ufeff# exported by hand\r\n"
        "\r\n"
        "  Y , notes, ID ,X\r\n"
        "0, whatever ,007,0\r\n"
        "   # an indented comment\r\n"
        "0,,-8,5\r\n"
        "4,x,+9,5\r\n",
        encoding="utf-8",
    )
    m = LandmarkMap.from_csv(path)
    assert m.ids == (7, -8, 9)
    np.testing.assert_array_equal(m.xy, [[0.0, 0.0], [5.0, 0.0], [5.0, 4.0]])
    assert m.names is None


def test_csv_to_csv_writes_expected_text(tmp_path: Path) -> None:
    m = LandmarkMap(
        [[0.0, 0.0], [0.1, 0.0], [0.0, 2.0]], ids=["a", "b", "c"], names=["x", "y,z", ""]
    )
    m.to_csv(tmp_path / "m.csv")
    assert (
        tmp_path / "m.csv"
    ).read_text() == 'id,x,y,name\na,0.0,0.0,x\nb,0.1,0.0,"y,z"\nc,0.0,2.0,\n'


def test_json_layouts(tmp_path: Path) -> None:
    expected = LandmarkMap(SQUARE[:3], ids=["a", "b", "c"])
    layouts = [
        '[{"id": "a", "x": 0, "y": 0}, {"id": "b", "x": 5, "y": 0}, {"id": "c", "x": 5, "y": 4}]',
        '{"xy": [[0, 0], [5, 0], [5, 4]], "ids": ["a", "b", "c"]}',
        '{"landmarks": [{"id": "a", "x": 0, "y": 0, "extra": [1]},'
        ' {"id": "b", "x": 5.0, "y": 0}, {"id": "c", "x": 5, "y": 4e0}]}',
    ]
    for k, text in enumerate(layouts):
        path = tmp_path / f"m{k}.json"
        path.write_text(text)
        assert LandmarkMap.from_json(path) == expected, text
    path = tmp_path / "ints.json"
    path.write_text('{"xy": [[0, 0], [5, 0], [5, 4]], "names": ["p", "q", "r"]}')
    m = LandmarkMap.from_json(path)
    assert m.ids == (0, 1, 2) and m.names == ("p", "q", "r")
    path.write_text(
        '[{"id": 3, "x": 0, "y": 0}, {"id": "04", "x": 5, "y": 0, "name": "n"},'
        ' {"id": 5, "x": 5, "y": 4}]'
    )
    m = LandmarkMap.from_json(path)
    assert m.ids == (3, 4, 5) and m.names == ("", "n", "")


# --------------------------------------------------------------------------------------------
# Files: every bad input names the file and the place
# --------------------------------------------------------------------------------------------

GOOD_ROWS = "1,0,0\n2,5,0\n3,5,4\n"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "map.csv: file is empty"),
        ("# only a comment\n\n   \n", "map.csv: file is empty"),
        ("id,x\n1,2\n", "map.csv line 1: header must contain columns id, x, y; missing: y"),
        (
            "1,0,0\n2,5,0\n",
            "map.csv line 1: header must contain columns id, x, y; missing: id, x, y",
        ),
        ("id,x,y,x\n1,0,0,0\n", "map.csv line 1: column 'x' appears more than once"),
        ('id,x,"y\n1,0,0\n', "map.csv line 1: malformed CSV"),
        ("id,x,y\n1,0,0\n2,5,0\n3,abc,4\n", "map.csv line 4: x is not a number: 'abc'"),
        ("id,x,y\n1,0,0\n2,5,0\n3,1_0,4\n", "map.csv line 4: x is not a number: '1_0'"),
        ("id,x,y\n1,0,0\n2,5,0\n3,5,nan\n", "map.csv line 4: y is not finite: 'nan'"),
        ("id,x,y\n1,0,0\n2,5,0\n3,5,-inf\n", "map.csv line 4: y is not finite: '-inf'"),
        ("id,x,y\n1,0,0\n2,5,0\n3,5,\n", "map.csv line 4: y is not a number: ''"),
        (
            "id,x,y\n# c\n1,0,0\n\n2,5\n3,5,4\n",
            "map.csv line 5: expected 3 fields (id, x, y), got 2",
        ),
        ("id,x,y\n1,0,0,9\n", "map.csv line 2: expected 3 fields (id, x, y), got 4"),
        ("id,x,y\n1,0,0\n ,5,0\n3,5,4\n", "map.csv line 3: id is empty"),
        ("id,x,y\n", "map.csv: a map needs at least 3 landmarks, got 0"),
        ("id,x,y\n1,0,0\n2,5,0\n", "map.csv: a map needs at least 3 landmarks, got 2"),
        (
            "id,x,y\n7,0,0\n2,5,0\n\n# dup\n7,5,4\n",
            "map.csv lines 2 and 6: duplicate landmark id 7",
        ),
        ("id,x,y\n7,0,0\n2,5,0\n007,5,4\n", "map.csv lines 2 and 4: duplicate landmark id 7"),
        (
            "id,x,y\nA,0,0\nB,5,0\nC,0,0.0000000000001\n",
            "map.csv lines 2 and 4: landmarks 'A' and 'C' coincide at (0.000, 0.000)",
        ),
    ],
)
def test_bad_csv(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "map.csv"
    path.write_text(text)
    with pytest.raises(MapError) as info:
        LandmarkMap.from_csv(path)
    assert expected in str(info.value)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "map.json line 1 column 1: invalid JSON: Expecting value"),
        (
            '{"landmarks": [\n  {"id": 1, "x": 0 "y": 0}\n]}',
            "map.json line 2 column 20: invalid JSON",
        ),
        ("42", "map.json: expected a list of landmarks"),
        ('{"points": []}', "got an object with keys 'points'"),
        (
            '{"landmarks": {"id": 1}}',
            "map.json: 'landmarks' must be a list of objects, got an object",
        ),
        ("[1, 2, 3]", "map.json: landmarks[0]: expected an object with id, x, y; got a number"),
        ('[{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": 1}]', "map.json: landmarks[1]: missing 'y'"),
        (
            '[{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": "abc", "y": 1}]',
            "map.json: landmarks[1]: x is not a number: 'abc'",
        ),
        (
            '[{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": 1, "y": NaN}]',
            "map.json: landmarks[1]: y is not finite: nan",
        ),
        ('[{"id": 1, "x": 0, "y": true}]', "map.json: landmarks[0]: y is not a number: True"),
        (
            '[{"id": 1.5, "x": 0, "y": 0}]',
            "map.json: landmarks[0]: id must be an integer or a string",
        ),
        ('[{"id": null, "x": 0, "y": 0}]', "map.json: landmarks[0]: id must be an integer"),
        ('[{"id": " ", "x": 0, "y": 0}]', "map.json: landmarks[0]: id is empty"),
        ('[{"id": 1, "x": 0, "y": 0, "name": 3}]', "map.json: landmarks[0]: name must be a string"),
        (
            '[{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": 1, "y": 0}]',
            "map.json: a map needs at least 3",
        ),
        (
            '[{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": 1, "y": 0}, {"id": "1", "x": 2, "y": 0}]',
            "map.json: landmarks[0] and landmarks[2]: duplicate landmark id 1",
        ),
        (
            '[{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": 1, "y": 0}, {"id": 3, "x": 1, "y": 0}]',
            "map.json: landmarks[1] and landmarks[2]: landmarks 2 and 3 coincide at (1.000, 0.000)",
        ),
        (
            '{"xy": [[0, 0], [1, 0], [1, 2, 3]]}',
            "map.json: xy[2]: expected a pair [x, y], got [1, 2, 3]",
        ),
        ('{"xy": [[0, 0], [1, 0], [1, "q"]]}', "map.json: xy[2]: y is not a number: 'q'"),
        ('{"xy": {"a": 1}}', "map.json: 'xy' must be a list of [x, y] pairs, got an object"),
        ('{"xy": [[0, 0], [1, 0], [1, 1]], "ids": [1, 2]}', "'ids' has 2 entries but 'xy' has 3"),
        (
            '{"xy": [[0, 0], [1, 0], [1, 1]], "ids": 3}',
            "map.json: 'ids' must be a list, got a number",
        ),
        ('{"xy": [[0, 0], [1, 0], [1, 1]], "ids": [1, 2, [3]]}', "map.json: ids[2]: id must be"),
        (
            '{"xy": [[0, 0], [1, 0], [1, 1]], "ids": [1, 2, 1]}',
            "map.json: xy[0] and xy[2]: duplicate",
        ),
        (
            '{"xy": [[0, 0], [1, 0], [1, 1]], "names": ["a"]}',
            "'names' has 1 entries but 'xy' has 3",
        ),
        ('{"xy": [[0, 0], [1, 0], [1, 1]], "names": ["a", 2, "c"]}', "map.json: names[1] must be"),
    ],
)
def test_bad_json(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "map.json"
    path.write_text(text)
    with pytest.raises(MapError) as info:
        LandmarkMap.from_json(path)
    assert expected in str(info.value)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("reader", [LandmarkMap.from_csv, LandmarkMap.from_json, LandmarkMap.load])
def test_unreadable_files(tmp_path: Path, reader: Any) -> None:
    missing = tmp_path / "nope.csv"
    with pytest.raises(MapError, match=r"nope\.csv: file not found"):
        reader(missing)
    folder = tmp_path / "folder.json"
    folder.mkdir()
    with pytest.raises(MapError, match=r"folder\.json: is a directory"):
        reader(folder)
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"id,x,y\n\xff\xfe,0,0\n")
    with pytest.raises(MapError, match=r"binary\.csv: not a UTF-8 text file"):
        reader(binary)


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("map.txt", "map.txt: unsupported map file ('.txt'); supported extensions: .csv, .json"),
        ("map", "map: unsupported map file (no extension); supported extensions: .csv, .json"),
    ],
)
def test_load_unsupported_extension(tmp_path: Path, name: str, expected: str) -> None:
    (tmp_path / name).write_text("id,x,y\n" + GOOD_ROWS)
    with pytest.raises(MapError) as info:
        LandmarkMap.load(tmp_path / name)
    assert expected in str(info.value)


def test_to_csv_refuses_line_breaks(tmp_path: Path) -> None:
    m = LandmarkMap(SQUARE[:3], names=["a", "two\nlines", "c"])
    with pytest.raises(MapError, match=r"m\.csv: landmark 1 \(id 1\) has a line break"):
        m.to_csv(tmp_path / "m.csv")
    assert not (tmp_path / "m.csv").exists()
    m.to_json(tmp_path / "m.json")
    assert LandmarkMap.from_json(tmp_path / "m.json") == m


@pytest.mark.parametrize("writer", ["to_csv", "to_json"])
def test_unwritable_destination(tmp_path: Path, writer: str) -> None:
    target = tmp_path / "no_such_dir" / "m.out"
    with pytest.raises(MapError, match=r"no_such_dir.*cannot write file"):
        getattr(LandmarkMap(SQUARE), writer)(target)


def test_map_error_is_an_input_error() -> None:
    with pytest.raises(InputError):
        LandmarkMap([[0, 0]])
