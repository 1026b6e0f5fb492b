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

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from omniloc.errors import MapError
from omniloc.io import (
    MAX_COORDINATE,
    MapFileData,
    PathLike,
    check_positions,
    read_map_csv,
    read_map_file,
    read_map_json,
    real_array,
    write_map_csv,
    write_map_json,
)

__all__ = ["COINCIDENCE_TOLERANCE", "LandmarkId", "LandmarkMap", "as_landmark_map"]

LandmarkId = int | str
"""A landmark id: an int or a non-empty string."""

COINCIDENCE_TOLERANCE = 1e-9
"""Two landmarks closer than this (metres) are the same place, which a map may not contain."""


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
    if isinstance(ids, dict) or not isinstance(ids, Iterable):
        raise MapError(
            f"ids must be a sequence of one id (int or str) per landmark, got "
            f"{type(ids).__name__} {ids!r}"[:200]
        )
    out: list[LandmarkId] = []
    for row, lid in enumerate(ids):
        if isinstance(lid, np.generic):
            lid = lid.item()
        if isinstance(lid, bool) or not isinstance(lid, int | str):
            raise MapError(
                f"landmark {row}: id must be an int or a str, got {type(lid).__name__} {lid!r}"[
                    :200
                ]
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
    if isinstance(names, dict) or not isinstance(names, Iterable):
        raise MapError(
            f"names must be a sequence of one name per landmark, got {type(names).__name__}"
        )
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
        check_positions(xy, "landmarks_xy", MapError, ids)
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

    # ----------------------------------------------------------------------------------------
    # Files
    # ----------------------------------------------------------------------------------------

    @classmethod
    def load(cls, path: PathLike) -> LandmarkMap:
        """Read a map from a ``.csv`` or ``.json`` file (chosen by extension).

        Raises
        ------
        MapError
            If the extension is not supported or the file is unreadable or invalid (the
            message names the file and the line or entry; both for a duplicate id or a
            coincident pair).
        """
        return cls._from_file(read_map_file(path))

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
        return cls._from_file(read_map_csv(path))

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
        return cls._from_file(read_map_json(path))

    @classmethod
    def _from_file(cls, data: MapFileData) -> LandmarkMap:
        """Map-level checks with file positions in the messages, then construction."""
        src, coords, ids, names, place = (
            data.source, data.coords, data.ids, data.names, data.place
        )  # fmt: skip
        n = len(coords)
        if n < 3:
            raise MapError(f"{src}: a map needs at least 3 landmarks, got {n}")
        first_row: dict[LandmarkId, int] = {}
        for row, lid in enumerate(ids):
            prev = first_row.setdefault(lid, row)
            if prev != row:
                raise MapError(f"{place(prev, row)}: duplicate landmark id {lid!r}")
        xy = np.array(coords, dtype=np.float64).reshape(n, 2)
        big = np.flatnonzero(np.abs(xy).max(axis=1) > MAX_COORDINATE)
        if big.size:
            k = int(big[0])
            raise MapError(
                f"{src}: landmark {ids[k]!r} has a coordinate of {float(np.abs(xy[k]).max()):.3g} "
                f"m; positions are metres of magnitude at most {MAX_COORDINATE:.0e} (move the "
                "origin near the landmarks)"
            )
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
        write_map_csv(path, self.xy, self.ids, self.names)

    def to_json(self, path: PathLike) -> None:
        """Write the map as ``{"landmarks": [{"id": ..., "x": ..., "y": ...}, ...]}``.

        One landmark per line; coordinates read back exactly with :meth:`from_json`.

        Raises
        ------
        MapError
            If the file cannot be written.
        """
        write_map_json(path, self.xy, self.ids, self.names)


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
