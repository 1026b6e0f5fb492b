"""The landmark map: validated landmark positions with ids, and its CSV and JSON files.

A :class:`LandmarkMap` is immutable and always valid: at least 3 landmarks, finite
coordinates in metres, unique ids, no two landmarks at the same place. Public functions take
either a map or a plain (N, 2) array and call :func:`as_landmark_map` at the door.

File formats
------------
CSV
    A header containing ``id``, ``x`` and ``y`` in any order (case-insensitive); an optional
    ``name`` column fills :attr:`LandmarkMap.names`; other columns are ignored. Blank lines
    are skipped and lines starting with ``#`` are comments.
JSON
    ``{"landmarks": [{"id": 1, "x": 0.0, "y": 1.0, "name": "door"}, ...]}``, the bare list
    of such objects, or ``{"xy": [[x, y], ...], "ids": [...], "names": [...]}`` (``ids`` and
    ``names`` optional).

Ids read from a file are integers when every id is an integer (``7``, ``"007"``), otherwise
strings; so a map whose ids are all integer-like strings reads back with integer ids.
"""

from __future__ import annotations

import csv
import io as _stdio
import json
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from omniloc.errors import MapError
from omniloc.io import (
    PathLike,
    content_lines,
    json_float,
    parse_float,
    parse_json,
    read_text,
    real_array,
    split_csv_line,
    type_name,
    write_text,
)

__all__ = ["COINCIDENCE_TOLERANCE", "LandmarkId", "LandmarkMap", "as_landmark_map"]

LandmarkId = int | str
"""A landmark id: an int or a non-empty string."""

COINCIDENCE_TOLERANCE = 1e-9
"""Two landmarks closer than this (metres) are the same place, which a map may not contain."""

_REQUIRED_COLUMNS = ("id", "x", "y")
_INT_ID = re.compile(r"[+-]?[0-9]+\Z")


def _min_pair(pairs: NDArray[np.intp]) -> tuple[int, int]:
    """Lexicographically smallest (i, j) row of an (k, 2) array of index pairs with i < j."""
    k = np.lexsort((pairs[:, 1], pairs[:, 0]))[0]
    return int(pairs[k, 0]), int(pairs[k, 1])


def _coincident_pair(xy: NDArray[np.float64], tree: cKDTree) -> tuple[int, int] | None:
    """Return a pair ``(i, j)``, ``i < j``, of landmarks closer than the tolerance, or None.

    Exact duplicates are reported first (smallest ``i``), else the lexicographically smallest
    near pair, so the message is deterministic.

    Exact duplicates are found by sorting, so even a map of 100,000 copies of one point is
    handled in O(N log N); the KD-tree then finds near-duplicates with ``query_pairs``.
    """
    order = np.lexsort((xy[:, 1], xy[:, 0]))
    sorted_xy = xy[order]
    same = np.all(sorted_xy[1:] == sorted_xy[:-1], axis=1)
    if np.any(same):
        involved = np.union1d(order[1:][same], order[:-1][same])
        i = int(involved[0])
        partners = np.flatnonzero(np.all(xy == xy[i], axis=1))
        return i, int(partners[partners != i][0])
    pairs = tree.query_pairs(COINCIDENCE_TOLERANCE, output_type="ndarray")
    if len(pairs) == 0:
        return None
    return _min_pair(np.sort(pairs, axis=1))


def _normalize_ids(ids: Sequence[Any] | NDArray[Any] | None, n: int) -> tuple[LandmarkId, ...]:
    if ids is None:
        return tuple(range(n))
    if isinstance(ids, str | bytes):
        raise MapError("ids must be a sequence of ids (int or str), not a single string")
    out: list[LandmarkId] = []
    for row, lid in enumerate(ids):
        if isinstance(lid, np.generic):
            lid = lid.item()
        if isinstance(lid, bool) or not isinstance(lid, int | str):
            raise MapError(
                f"landmark {row}: id must be an int or a str, got {type(lid).__name__} {lid!r}"
            )
        if isinstance(lid, str) and not lid:
            raise MapError(f"landmark {row}: id must not be an empty string")
        out.append(lid)
    if len(out) != n:
        raise MapError(f"ids must have one entry per landmark: expected {n}, got {len(out)}")
    return tuple(out)


def _normalize_names(names: Sequence[Any] | None, n: int) -> tuple[str, ...] | None:
    if names is None:
        return None
    if isinstance(names, str | bytes):
        raise MapError("names must be a sequence of strings, not a single string")
    out = tuple(names)
    if len(out) != n:
        raise MapError(f"names must have one entry per landmark: expected {n}, got {len(out)}")
    for row, name in enumerate(out):
        if not isinstance(name, str):
            raise MapError(f"landmark {row}: name must be a str, got {type(name).__name__}")
    return out


@dataclass(frozen=True, eq=False, repr=False, init=False)
class LandmarkMap:
    """Landmark positions (metres) with ids and optional names; immutable and validated.

    Parameters
    ----------
    xy : array_like, shape (N, 2)
        Landmark positions in metres, N >= 3. A read-only C-contiguous float64 copy is kept.
    ids : sequence of int or str, optional
        One unique id per landmark (numpy integers and strings are converted to ``int`` and
        ``str``); default ``0 .. N-1``.
    names : sequence of str, optional
        One human-readable name per landmark.

    Attributes
    ----------
    xy : ndarray of float64, shape (N, 2)
        Read-only landmark positions in metres.
    ids : tuple of (int or str)
        Landmark ids, in row order.
    names : tuple of str or None
        Landmark names, in row order, if any.

    Raises
    ------
    MapError
        If ``xy`` is not an (N, 2) array of finite real numbers, N < 3, ``ids`` or ``names``
        have the wrong length or type, an id repeats, or two landmarks are closer than
        :data:`COINCIDENCE_TOLERANCE`.

    Notes
    -----
    Validation (in ``__post_init__``) is O(N log N): a 100,000-landmark map is checked in a
    fraction of a second. The KD-tree built to find coincident landmarks is kept as
    :attr:`kdtree`.

    Examples
    --------
    >>> m = LandmarkMap([[0, 0], [4, 0], [0, 3]], ids=["A", "B", "C"])
    >>> m
    LandmarkMap(n=3, ids=('A', 'B', 'C'), bounds=(0, 0, 4, 3))
    >>> m.index_of("B"), m.ids_of([2, None, 0]), m.bounds
    (1, ['C', None, 'A'], (0.0, 0.0, 4.0, 3.0))
    >>> LandmarkMap([[0, 0], [1, 2], [1, 2]])
    Traceback (most recent call last):
    ...
    omniloc.errors.MapError: landmarks 1 and 2 (ids 1, 2) coincide at (1.000, 2.000)
    """

    xy: NDArray[np.float64]
    ids: tuple[LandmarkId, ...]
    names: tuple[str, ...] | None

    def __init__(
        self,
        xy: ArrayLike,
        ids: Sequence[LandmarkId] | NDArray[Any] | None = None,
        names: Sequence[str] | None = None,
    ) -> None:
        # A hand-written __init__ only so that type checkers accept array-likes and None;
        # conversion and validation happen in __post_init__, as in any frozen dataclass.
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "names", names)
        self.__post_init__()

    def __post_init__(self) -> None:
        xy = real_array(self.xy, "landmarks_xy", MapError)
        if xy.ndim != 2 or xy.shape[1] != 2:
            raise MapError(f"landmarks_xy must have shape (N, 2), got {xy.shape}")
        n = xy.shape[0]
        if n < 3:
            raise MapError(f"a map needs at least 3 landmarks, got {n}")
        ids = _normalize_ids(self.ids, n)
        names = _normalize_names(self.names, n)
        finite = np.all(np.isfinite(xy), axis=1)
        if not np.all(finite):
            row = int(np.flatnonzero(~finite)[0])
            raise MapError(f"landmark {row} (id {ids[row]!r}) has a non-finite coordinate")
        first_row: dict[LandmarkId, int] = {}
        for row, lid in enumerate(ids):
            prev = first_row.setdefault(lid, row)
            if prev != row:
                raise MapError(f"duplicate landmark id {lid!r} (rows {prev} and {row})")
        xy = np.ascontiguousarray(xy)
        xy.setflags(write=False)
        tree = cKDTree(xy)
        pair = _coincident_pair(xy, tree)
        if pair is not None:
            i, j = pair
            raise MapError(
                f"landmarks {i} and {j} (ids {ids[i]!r}, {ids[j]!r}) coincide at "
                f"({xy[i, 0]:.3f}, {xy[i, 1]:.3f})"
            )
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "names", names)
        # Seed the cached properties with what validation has already built.
        self.__dict__["_id_to_row"] = first_row
        self.__dict__["kdtree"] = tree

    # ----------------------------------------------------------------------------------------
    # Basic protocol
    # ----------------------------------------------------------------------------------------

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    @property
    def n(self) -> int:
        """Number of landmarks N."""
        return int(self.xy.shape[0])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, LandmarkMap):
            return NotImplemented
        return (
            self.ids == other.ids
            and self.names == other.names
            and bool(np.array_equal(self.xy, other.xy))
        )

    def __hash__(self) -> int:
        return self._hash

    @cached_property
    def _hash(self) -> int:
        # + 0.0 turns -0.0 into 0.0 so that equal maps (np.array_equal) hash equally.
        return hash((self.ids, self.names, (self.xy + 0.0).tobytes()))

    def __reduce__(self) -> tuple[type[LandmarkMap], tuple[Any, ...]]:
        # Rebuild through the constructor: the copy is validated, its xy read-only again
        # (numpy unpickles arrays writeable) and caches such as the KD-tree are not shipped.
        return (type(self), (self.xy, self.ids, self.names))

    def __repr__(self) -> str:
        if self.n <= 6:
            ids = repr(self.ids)
        else:
            head = ", ".join(repr(i) for i in self.ids[:3])
            tail = ", ".join(repr(i) for i in self.ids[-2:])
            ids = f"({head}, ..., {tail})"
        b = ", ".join(f"{v:.6g}" for v in self.bounds)
        return f"LandmarkMap(n={self.n}, ids={ids}, bounds=({b}))"

    # ----------------------------------------------------------------------------------------
    # Lookups
    # ----------------------------------------------------------------------------------------

    def index_of(self, landmark_id: LandmarkId) -> int:
        """Row index of the landmark with id ``landmark_id``.

        Raises
        ------
        MapError
            If no landmark has that id (ids compare by type too: ``7`` is not ``"7"``).

        Examples
        --------
        >>> LandmarkMap([[0, 0], [1, 0], [0, 1]], ids=[10, 20, 30]).index_of(30)
        2
        """
        row = self._id_to_row.get(landmark_id)
        if row is None:
            raise MapError(f"unknown landmark id {landmark_id!r}")
        return row

    def ids_of(self, indices: Iterable[int | None]) -> list[LandmarkId | None]:
        """Map row indices to ids; ``None`` (an unmatched bearing) stays ``None``.

        Raises
        ------
        MapError
            If an index is not an integer in ``0 .. N-1``.

        Examples
        --------
        >>> LandmarkMap([[0, 0], [1, 0], [0, 1]], ids=list("abc")).ids_of([2, None])
        ['c', None]
        """
        out: list[LandmarkId | None] = []
        for k in indices:
            if k is None:
                out.append(None)
                continue
            if isinstance(k, bool) or not isinstance(k, int | np.integer):
                raise MapError(f"landmark index must be an int or None, got {k!r}")
            if not 0 <= k < self.n:
                raise MapError(f"landmark index {k} out of range for a map of {self.n} landmarks")
            out.append(self.ids[int(k)])
        return out

    @cached_property
    def _id_to_row(self) -> dict[LandmarkId, int]:
        return {lid: row for row, lid in enumerate(self.ids)}

    @cached_property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of the landmarks, in metres (computed once)."""
        lo = self.xy.min(axis=0)
        hi = self.xy.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @cached_property
    def kdtree(self) -> cKDTree:
        """``scipy.spatial.cKDTree`` over :attr:`xy`, built once."""
        return cKDTree(self.xy)

    def neighbours(self, radius: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Landmarks within ``radius`` of each landmark (itself excluded), as CSR lists.

        Returns ``(ptr, idx)``: the neighbours of landmark ``i`` are
        ``idx[ptr[i]:ptr[i + 1]]``, in increasing order. Built once per radius from the
        k-d tree (the last few radii are kept), in memory proportional to the number of
        neighbouring pairs.

        Examples
        --------
        >>> lm = LandmarkMap([[0, 0], [1, 0], [5, 0]])
        >>> ptr, idx = lm.neighbours(2.0)
        >>> idx[ptr[0]:ptr[1]].tolist(), idx[ptr[2]:ptr[3]].tolist()
        ([1], [])
        """
        cache: dict[float, tuple[NDArray[np.int64], NDArray[np.int64]]]
        cache = self.__dict__.setdefault("_neighbour_lists", {})
        key = float(radius)
        if key not in cache:
            pairs = self.kdtree.query_pairs(key, output_type="ndarray").astype(np.int64)
            src = np.concatenate([pairs[:, 0], pairs[:, 1]])
            dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
            del pairs
            order = np.lexsort((dst, src))
            ptr = np.zeros(self.n + 1, dtype=np.int64)
            np.cumsum(np.bincount(src, minlength=self.n), out=ptr[1:])
            if len(cache) >= 4:
                cache.pop(next(iter(cache)))
            cache[key] = (ptr, dst[order])
        return cache[key]

    def neighbour_xy(self, radius: float) -> NDArray[np.float64]:
        """Coordinates of :meth:`neighbours`' ``idx``, contiguous (for sequential reads)."""
        cache: dict[float, NDArray[np.float64]]
        cache = self.__dict__.setdefault("_neighbour_xy", {})
        key = float(radius)
        if key not in cache:
            if len(cache) >= 4:
                cache.pop(next(iter(cache)))
            cache[key] = np.ascontiguousarray(self.xy[self.neighbours(radius)[1]])
        return cache[key]

    # ----------------------------------------------------------------------------------------
    # Files
    # ----------------------------------------------------------------------------------------

    @classmethod
    def load(cls, path: PathLike) -> LandmarkMap:
        """Read a map from a ``.csv`` or ``.json`` file (chosen by extension).

        Raises
        ------
        MapError
            If the extension is not supported or the file is unreadable or invalid.
        """
        src = os.fspath(path)
        suffix = Path(src).suffix.lower()
        if suffix == ".csv":
            return cls.from_csv(path)
        if suffix == ".json":
            return cls.from_json(path)
        shown = repr(suffix) if suffix else "no extension"
        raise MapError(f"{src}: unsupported map file ({shown}); supported extensions: .csv, .json")

    @classmethod
    def from_csv(cls, path: PathLike) -> LandmarkMap:
        """Read a map from a CSV file with columns ``id``, ``x``, ``y`` (and optional ``name``).

        Parameters
        ----------
        path : str or path-like
            The CSV file (see the module docstring for the format).

        Returns
        -------
        LandmarkMap

        Raises
        ------
        MapError
            If the file is missing or unreadable, or is not a valid map; the message names the
            file and the line (both lines for a duplicate id or a coincident pair).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "map.csv"
        >>> _ = p.write_text("# my room\\nid,x,y,name\\n1,0,0,door\\n2,5,0,lamp\\n3,0,4,plant\\n")
        >>> m = LandmarkMap.from_csv(p)
        >>> m.ids, m.names
        ((1, 2, 3), ('door', 'lamp', 'plant'))
        >>> _ = p.write_text("id,x,y\\n1,0,0\\n2,abc,0\\n3,0,4\\n")
        >>> LandmarkMap.from_csv(p)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        omniloc.errors.MapError: ...map.csv line 3: x is not a number: 'abc'
        """
        src = os.fspath(path)
        text = read_text(path, MapError)
        lines = content_lines(text)
        if not lines:
            raise MapError(f"{src}: file is empty (expected a header with columns id, x, y)")
        header_line, header_text = lines[0]
        where = f"{src} line {header_line}"
        header = [h.lower() for h in split_csv_line(header_text, where, MapError)]
        missing = [c for c in _REQUIRED_COLUMNS if c not in header]
        if missing:
            found = ", ".join(repr(h) for h in header)
            raise MapError(
                f"{where}: header must contain columns id, x, y; missing: {', '.join(missing)} "
                f"(found: {found})"
            )
        for col in (*_REQUIRED_COLUMNS, "name"):
            if header.count(col) > 1:
                raise MapError(f"{where}: column {col!r} appears more than once in the header")
        c_id, c_x, c_y = (header.index(c) for c in _REQUIRED_COLUMNS)
        c_name = header.index("name") if "name" in header else None
        width = len(header)

        raw_ids: list[str] = []
        coords: list[tuple[float, float]] = []
        names: list[str] = []
        line_numbers: list[int] = []
        for lineno, line in lines[1:]:
            where = f"{src} line {lineno}"
            fields = split_csv_line(line, where, MapError)
            if len(fields) != width:
                raise MapError(
                    f"{where}: expected {width} fields ({', '.join(header)}), got {len(fields)}"
                )
            if not fields[c_id]:
                raise MapError(f"{where}: id is empty")
            raw_ids.append(fields[c_id])
            coords.append(
                (
                    parse_float(fields[c_x], where, "x", MapError),
                    parse_float(fields[c_y], where, "y", MapError),
                )
            )
            if c_name is not None:
                names.append(fields[c_name])
            line_numbers.append(lineno)

        def place(i: int, j: int) -> str:
            return f"{src} lines {line_numbers[i]} and {line_numbers[j]}"

        return cls._from_file(
            src, coords, _ids_from_file(raw_ids), names if c_name is not None else None, place
        )

    @classmethod
    def from_json(cls, path: PathLike) -> LandmarkMap:
        """Read a map from a JSON file (see the module docstring for the accepted layouts).

        Raises
        ------
        MapError
            If the file is missing, unreadable, not valid JSON (the message gives line and
            column) or not a valid map (the message names the bad entry, e.g.
            ``landmarks[3]``).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "map.json"
        >>> _ = p.write_text('{"xy": [[0, 0], [5, 0], [0, 4]], "ids": ["a", "b", "c"]}')
        >>> LandmarkMap.from_json(p)
        LandmarkMap(n=3, ids=('a', 'b', 'c'), bounds=(0, 0, 5, 4))
        """
        src = os.fspath(path)
        data = parse_json(read_text(path, MapError), src, MapError)
        if isinstance(data, dict) and "landmarks" in data:
            entries = data["landmarks"]
            if not isinstance(entries, list):
                raise MapError(
                    f"{src}: 'landmarks' must be a list of objects, got {type_name(entries)}"
                )
            return cls._from_json_entries(src, entries)
        if isinstance(data, list):
            return cls._from_json_entries(src, data)
        if isinstance(data, dict) and "xy" in data:
            return cls._from_json_xy(src, data)
        got = (
            f"an object with keys {', '.join(repr(k) for k in data) or 'none'}"
            if isinstance(data, dict)
            else type_name(data)
        )
        raise MapError(
            f"{src}: expected a list of landmarks, an object with a 'landmarks' list or an "
            f"object with 'xy' (and optional 'ids', 'names'); got {got}"
        )

    @classmethod
    def _from_json_entries(cls, src: str, entries: list[Any]) -> LandmarkMap:
        raw_ids: list[int | str] = []
        coords: list[tuple[float, float]] = []
        names: list[str] = []
        has_names = any(isinstance(e, dict) and "name" in e for e in entries)
        for k, entry in enumerate(entries):
            where = f"{src}: landmarks[{k}]"
            if not isinstance(entry, dict):
                raise MapError(f"{where}: expected an object with id, x, y; got {type_name(entry)}")
            missing = [key for key in _REQUIRED_COLUMNS if key not in entry]
            if missing:
                raise MapError(f"{where}: missing {', '.join(repr(m) for m in missing)}")
            raw_ids.append(_json_id(entry["id"], where))
            coords.append(
                (
                    json_float(entry["x"], where, "x", MapError),
                    json_float(entry["y"], where, "y", MapError),
                )
            )
            if has_names:
                name = entry.get("name", "")
                if not isinstance(name, str):
                    raise MapError(f"{where}: name must be a string, got {type_name(name)}")
                names.append(name)

        def place(i: int, j: int) -> str:
            return f"{src}: landmarks[{i}] and landmarks[{j}]"

        return cls._from_file(
            src, coords, _ids_from_file(raw_ids), names if has_names else None, place
        )

    @classmethod
    def _from_json_xy(cls, src: str, data: dict[str, Any]) -> LandmarkMap:
        rows = data["xy"]
        if not isinstance(rows, list):
            raise MapError(f"{src}: 'xy' must be a list of [x, y] pairs, got {type_name(rows)}")
        coords: list[tuple[float, float]] = []
        for k, row in enumerate(rows):
            where = f"{src}: xy[{k}]"
            if not isinstance(row, list) or len(row) != 2:
                raise MapError(f"{where}: expected a pair [x, y], got {json.dumps(row)}")
            coords.append(
                (
                    json_float(row[0], where, "x", MapError),
                    json_float(row[1], where, "y", MapError),
                )
            )
        ids: tuple[LandmarkId, ...] | None = None
        if data.get("ids") is not None:
            raw = data["ids"]
            if not isinstance(raw, list):
                raise MapError(f"{src}: 'ids' must be a list, got {type_name(raw)}")
            if len(raw) != len(coords):
                raise MapError(f"{src}: 'ids' has {len(raw)} entries but 'xy' has {len(coords)}")
            ids = _ids_from_file([_json_id(v, f"{src}: ids[{k}]") for k, v in enumerate(raw)])
        names: list[str] | None = None
        if data.get("names") is not None:
            raw = data["names"]
            if not isinstance(raw, list):
                raise MapError(f"{src}: 'names' must be a list, got {type_name(raw)}")
            if len(raw) != len(coords):
                raise MapError(f"{src}: 'names' has {len(raw)} entries but 'xy' has {len(coords)}")
            for k, name in enumerate(raw):
                if not isinstance(name, str):
                    raise MapError(f"{src}: names[{k}] must be a string, got {type_name(name)}")
            names = raw

        def place(i: int, j: int) -> str:
            return f"{src}: xy[{i}] and xy[{j}]"

        return cls._from_file(
            src, coords, ids if ids is not None else tuple(range(len(coords))), names, place
        )

    @classmethod
    def _from_file(
        cls,
        src: str,
        coords: list[tuple[float, float]],
        ids: tuple[LandmarkId, ...],
        names: list[str] | None,
        place: Callable[[int, int], str],
    ) -> LandmarkMap:
        """Map-level checks with file positions in the messages, then construction."""
        n = len(coords)
        if n < 3:
            raise MapError(f"{src}: a map needs at least 3 landmarks, got {n}")
        first_row: dict[LandmarkId, int] = {}
        for row, lid in enumerate(ids):
            prev = first_row.setdefault(lid, row)
            if prev != row:
                raise MapError(f"{place(prev, row)}: duplicate landmark id {lid!r}")
        xy = np.array(coords, dtype=np.float64).reshape(n, 2)
        pair = _coincident_pair(xy, cKDTree(xy))
        if pair is not None:
            i, j = pair
            raise MapError(
                f"{place(i, j)}: landmarks {ids[i]!r} and {ids[j]!r} coincide at "
                f"({xy[i, 0]:.3f}, {xy[i, 1]:.3f})"
            )
        try:
            return cls(xy, ids, names)
        except MapError as e:  # pragma: no cover - every check above mirrors __post_init__
            raise MapError(f"{src}: {e}") from None

    def to_csv(self, path: PathLike) -> None:
        """Write the map as CSV (``id,x,y`` plus ``name`` if the map has names).

        Coordinates are written with enough digits to read back exactly, so
        ``LandmarkMap.from_csv`` returns an equal map (ids that are all integer-like strings
        come back as ints, and surrounding whitespace in ids and names is not kept).

        Raises
        ------
        MapError
            If the file cannot be written, or an id or name contains a line break (use JSON).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "map.csv"
        >>> LandmarkMap([[0, 0], [0.1, 0], [0, 2]]).to_csv(p)
        >>> print(p.read_text(), end="")
        id,x,y
        0,0.0,0.0
        1,0.1,0.0
        2,0.0,2.0
        """
        for row, lid in enumerate(self.ids):
            texts = [str(lid)] + ([self.names[row]] if self.names is not None else [])
            if any("\n" in t or "\r" in t for t in texts):
                raise MapError(
                    f"{os.fspath(path)}: landmark {row} (id {lid!r}) has a line break in its "
                    "id or name, which CSV maps cannot hold; use JSON"
                )
        # Quote every text field if a line could otherwise be mistaken for a comment.
        leading_hash = any(
            isinstance(lid, str) and lid.lstrip().startswith("#") for lid in self.ids
        )
        buf = _stdio.StringIO()
        writer = csv.writer(
            buf,
            lineterminator="\n",
            quoting=csv.QUOTE_NONNUMERIC if leading_hash else csv.QUOTE_MINIMAL,
        )
        header = ["id", "x", "y"] + (["name"] if self.names is not None else [])
        writer.writerow(header)
        for row, lid in enumerate(self.ids):
            x, y = (float(v) for v in self.xy[row])
            writer.writerow([lid, x, y] + ([self.names[row]] if self.names is not None else []))
        write_text(path, buf.getvalue(), MapError)

    def to_json(self, path: PathLike) -> None:
        """Write the map as ``{"landmarks": [{"id": ..., "x": ..., "y": ...}, ...]}``.

        One landmark per line; coordinates read back exactly with :meth:`from_json`.

        Raises
        ------
        MapError
            If the file cannot be written.
        """
        entries = []
        for row, lid in enumerate(self.ids):
            entry: dict[str, Any] = {"id": lid, "x": float(self.xy[row, 0])}
            entry["y"] = float(self.xy[row, 1])
            if self.names is not None:
                entry["name"] = self.names[row]
            entries.append("  " + json.dumps(entry))
        text = '{"landmarks": [\n' + ",\n".join(entries) + "\n]}\n"
        write_text(path, text, MapError)


def _ids_from_file(raw: Sequence[int | str]) -> tuple[LandmarkId, ...]:
    """Ids as read from a file: all ints if every id is integer-like, otherwise all strings."""
    texts = [str(v).strip() for v in raw]
    if all(_INT_ID.match(t) for t in texts):
        return tuple(int(t) for t in texts)
    return tuple(texts)


def _json_id(value: object, where: str) -> int | str:
    if isinstance(value, bool) or not isinstance(value, int | str):
        raise MapError(f"{where}: id must be an integer or a string, got {json.dumps(value)}")
    if isinstance(value, str) and not value.strip():
        raise MapError(f"{where}: id is empty")
    return value


def as_landmark_map(landmarks: LandmarkMap | ArrayLike) -> LandmarkMap:
    """Return ``landmarks`` as a :class:`LandmarkMap`, validating a plain array at the door.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
        A map (returned as is) or landmark positions in metres (ids become ``0 .. N-1``).

    Returns
    -------
    LandmarkMap

    Raises
    ------
    MapError
        If ``landmarks`` is not a valid map (see :class:`LandmarkMap`).

    Examples
    --------
    >>> as_landmark_map(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])).ids
    (0, 1, 2)
    >>> as_landmark_map([[0, 0], [1, 0]])
    Traceback (most recent call last):
    ...
    omniloc.errors.MapError: a map needs at least 3 landmarks, got 2
    """
    if isinstance(landmarks, LandmarkMap):
        return landmarks
    return LandmarkMap(landmarks)
