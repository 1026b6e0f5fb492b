"""Bearing files and in-memory bearing validation: everything that checks bearings at the door.

Inside omniloc bearings are radians wrapped to [-pi, pi), in a float64 array of shape (m,).
Degrees exist only at the edges: in files (``bearing_deg`` columns, ``"units": "deg"``) and
behind ``degrees=True`` flags.

File formats understood by :func:`load_bearings` (chosen by extension):

``.csv``
    A header with exactly one column named ``bearing``, ``bearing_rad`` or ``bearing_deg``
    (other columns are allowed and ignored), or a single column of numbers without header.
    ``bearing_deg`` means degrees, ``bearing_rad`` radians, ``bearing`` follows ``degrees``.
``.json``
    A list of numbers, ``{"bearings": [...], "units": "deg" | "rad"}``, or what ``omniloc
    bearings --json`` writes (``{"units": "radians" | "degrees", "detections": [{"bearing":
    ..., "ambiguous": ...}, ...]}``; :func:`read_bearings` returns the flags too).
anything else
    Plain text: numbers separated by whitespace, commas or newlines; ``#`` starts a comment.

In every format blank lines are skipped and lines starting with ``#`` are comments.
"""

from __future__ import annotations

import csv
import dataclasses
import enum
import io as _stdio
import json
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from omniloc.errors import InputError, MapError, ObservationError

__all__ = [
    "MAX_COORDINATE",
    "MAX_FILE_RADIANS",
    "MapFileData",
    "as_path",
    "check_bearings",
    "check_positions",
    "check_radians",
    "content_lines",
    "finite_number",
    "json_float",
    "load_bearings",
    "make_folder",
    "parse_float",
    "parse_json",
    "read_bearings",
    "read_map_csv",
    "read_map_file",
    "read_map_json",
    "read_text",
    "real_array",
    "save_bearings",
    "shorten",
    "split_csv_line",
    "to_jsonable",
    "type_name",
    "write_json",
    "write_map_csv",
    "write_map_json",
    "write_text",
]

PathLike = str | os.PathLike[str]

_BEARING_COLUMNS = ("bearing", "bearing_rad", "bearing_deg")

#: Largest magnitude of a coordinate, metres. Positions are metres about an origin near the
#: landmarks (UTM or a building's frame): 1e9 m is well past any of them, and far below where
#: squared distances overflow and float64 can no longer tell two landmarks apart.
MAX_COORDINATE = 1e9
_TEXT_SEPARATORS = re.compile(r"[\s,]+")


# --------------------------------------------------------------------------------------------
# Helpers for reading and writing text files, shared by every file format of omniloc
# --------------------------------------------------------------------------------------------


def as_path(path: object, what: str, error: type[InputError] = InputError) -> Path:
    """``path`` as a :class:`~pathlib.Path`, or ``error`` when it is not a file name.

    A file name is a ``str``, ``bytes`` or path-like object without NUL characters (an int
    would be taken by :func:`open` as a file descriptor).

    Examples
    --------
    >>> as_path("map.csv", "map").name
    'map.csv'
    >>> as_path(3, "map")
    Traceback (most recent call last):
    ...
    omniloc.errors.InputError: map must be a file name (str or path-like), got int 3
    """
    try:
        text = os.fsdecode(path)  # type: ignore[arg-type]
    except TypeError:
        raise error(
            f"{what} must be a file name (str or path-like), got {type(path).__name__} "
            f"{shorten(path)}"
        ) from None
    if "\x00" in text or not text:
        raise error(f"{what} must be a file name, got {text!r}")
    return Path(text)


def shorten(value: object, width: int = 60) -> str:
    """``repr(value)`` cut to ``width`` characters, for messages that quote what they got."""
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def _as_float(value: int | float | np.integer | np.floating) -> float:
    """``float(value)``, with an int beyond the float range as infinity."""
    try:
        return float(value)
    except OverflowError:
        return math.inf


def finite_number(value: object, name: str, error: type[InputError] = InputError) -> float:
    """A finite real number (not a bool, a string or an array) as a float, or ``error``
    naming ``name``.

    Examples
    --------
    >>> finite_number(2, "sigma")
    2.0
    >>> finite_number(10**400, "sigma")
    Traceback (most recent call last):
    ...
    omniloc.errors.InputError: sigma must be a finite number, got an int of 401 digits
    """
    if type(value) is float and math.isfinite(value):  # the common case, first
        return value
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise error(f"{name} must be a number, got {type(value).__name__} {shorten(value)}")
    out = _as_float(value)
    if not math.isfinite(out):
        if isinstance(value, (int, np.integer)):
            raise error(f"{name} must be a finite number, got an int of {len(str(value))} digits")
        raise error(f"{name} must be a finite number, got {value!r}")
    return out


def _file_error(src: str, exc: BaseException, error: type[InputError]) -> InputError:
    """``error`` saying why the file ``src`` could not be read (``exc``: what reading raised)."""
    if isinstance(exc, FileNotFoundError):
        return error(f"{src}: file not found")
    if isinstance(exc, IsADirectoryError):
        return error(f"{src}: is a directory, not a file")
    if isinstance(exc, PermissionError):
        return error(f"{src}: permission denied")
    if isinstance(exc, UnicodeDecodeError):
        return error(f"{src}: not a UTF-8 text file (undecodable byte at offset {exc.start})")
    if isinstance(exc, MemoryError):
        return error(f"{src}: file too large to read")
    return error(f"{src}: cannot read file: {getattr(exc, 'strerror', None) or exc}")


def read_text(path: PathLike, error: type[InputError]) -> str:
    """Read a UTF-8 text file, turning every OS or decoding failure into ``error``."""
    src = os.fspath(as_path(path, "path", error))
    try:
        with open(src, encoding="utf-8-sig") as f:
            return f.read()
    except (OSError, UnicodeDecodeError, MemoryError) as e:
        raise _file_error(src, e, error) from None


def first_content_line(path: PathLike, error: type[InputError]) -> str | None:
    """The first line of a UTF-8 text file that is neither blank nor a comment (as
    :func:`content_lines` counts them), None for a file without one. The file is read in
    blocks as far as that line, not to its end (to sniff a format before parsing). Every OS
    or decoding failure on the way becomes ``error``, as in :func:`read_text`."""
    src = os.fspath(as_path(path, "path", error))
    try:
        # (newline="\n": only "\n" ends a line, as in content_lines.)
        with open(src, encoding="utf-8-sig", newline="\n") as f:
            for raw in f:
                line = raw.rstrip("\n").rstrip("\r")
                stripped = line.strip()
                if stripped and not stripped.startswith("#"):
                    return line
        return None
    except (OSError, UnicodeDecodeError, MemoryError) as e:
        raise _file_error(src, e, error) from None


def make_folder(folder: Path, what: str, error: type[InputError] = InputError) -> Path:
    """Create ``folder`` (and its parents) for ``what``, or ``error`` saying why not."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise error(f"{what}: cannot create the folder {folder}: a file is there") from None
    except NotADirectoryError:
        raise error(f"{what}: cannot create the folder {folder}: a part of it is a file") from None
    except OSError as exc:
        raise error(f"{what}: cannot create the folder {folder}: {exc.strerror or exc}") from None
    return folder


def write_text(path: PathLike, text: str, error: type[InputError]) -> None:
    """Write ``text`` (already complete in memory) to ``path`` as UTF-8."""
    dest = as_path(path, "path", error)
    try:
        with open(dest, "w", encoding="utf-8", newline="") as f:
            f.write(text)
    except IsADirectoryError:
        raise error(f"{dest}: is a directory, not a file") from None
    except FileNotFoundError:
        raise error(f"{dest}: cannot write file: the folder {dest.parent} does not exist") from None
    except NotADirectoryError:
        raise error(f"{dest}: cannot write file: a part of {dest.parent} is a file") from None
    except OSError as e:
        raise error(f"{dest}: cannot write file: {e.strerror or e}") from None


def _columns(fields: Sequence[str], most: int = 8) -> str:
    """The column names of a header for a message: the first ``most`` and how many more."""
    shown = ", ".join(shorten(f, 30) for f in fields[:most])
    return shown + (f" ... ({len(fields)} columns)" if len(fields) > most else "")


def content_lines(text: str) -> list[tuple[int, str]]:
    """Return ``(line_number, line)`` for every line that is neither blank nor a comment.

    Line numbers count from 1 and only ``\\n`` ends a line, as in any text editor.
    """
    out = []
    for lineno, raw in enumerate(text.split("\n"), start=1):
        line = raw.rstrip("\r")
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            out.append((lineno, line))
    return out


def split_csv_line(line: str, where: str, error: type[InputError]) -> list[str]:
    """Split one CSV line into stripped fields (quotes allowed, no line breaks in fields)."""
    try:
        row = next(csv.reader([line], strict=True))
    except csv.Error as e:
        raise error(f"{where}: malformed CSV: {e}") from None
    return [field.strip() for field in row]


def parse_json(text: str, src: str, error: type[InputError]) -> Any:
    """``json.loads`` with syntax errors reported as ``error`` naming file, line and column."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise error(f"{src} line {e.lineno} column {e.colno}: invalid JSON: {e.msg}") from None
    except RecursionError:
        raise error(f"{src}: invalid JSON: nested too deeply") from None


def parse_float(token: str, where: str, what: str, error: type[InputError]) -> float:
    """Parse a finite float from text, else raise ``error`` quoting the offending token.

    Python's digit separators are refused: ``float("1_0")`` is 10, but in a data file
    ``1_0`` is a typo, not ten.
    """
    try:
        if "_" in token:
            raise ValueError(token)
        value = float(token)
    except ValueError:
        raise error(f"{where}: {what} is not a number: {token!r}") from None
    if not math.isfinite(value):
        shown = token if len(token) <= 40 else f"{token[:20]}...({len(token)} characters)"
        raise error(f"{where}: {what} is not finite: {shown!r}")
    return value


def json_float(value: object, where: str, what: str, error: type[InputError]) -> float:
    """Accept a JSON number (not a bool, not a string) that is finite."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise error(f"{where}: {what} is not a number: {shorten(value)}")
    out = _as_float(value)
    if not math.isfinite(out):
        shown = repr(value) if len(repr(value)) <= 40 else f"a number of {len(repr(value))} digits"
        raise error(f"{where}: {what} is not finite: {shown}")
    return out


def type_name(value: object) -> str:
    """JSON-flavoured name of a parsed JSON value's type, for messages."""
    names = {dict: "an object", list: "a list", str: "a string", bool: "a boolean"}
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return "a number"
    return names.get(type(value), type(value).__name__)


def _wrap_keep_in_range(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrap to [-pi, pi), leaving values already in range bit-for-bit unchanged."""
    out = np.array(a, dtype=np.float64, copy=True)
    bad = (out < -np.pi) | (out >= np.pi)
    if np.any(bad):
        wrapped = np.mod(out[bad] + np.pi, 2.0 * np.pi) - np.pi
        # np.mod can round up to exactly 2*pi for tiny negative inputs.
        wrapped[wrapped >= np.pi] -= 2.0 * np.pi
        out[bad] = wrapped
    return out


def real_array(values: ArrayLike, name: str, error: type[InputError]) -> NDArray[np.float64]:
    """Convert to a float64 array, refusing strings, booleans, complex numbers and ragged data."""
    if values is None or isinstance(values, (str, bytes, dict)):
        raise error(f"{name} must be a numeric array of real numbers, got {type(values).__name__}")
    try:
        arr = np.asarray(values)
    except (ValueError, TypeError, OverflowError):
        raise error(f"{name} must be a rectangular array of real numbers") from None
    if arr.dtype.kind == "O":
        try:
            out = np.array(arr, dtype=np.float64)
        except (ValueError, TypeError, OverflowError):
            raise error(f"{name} must contain only real numbers") from None
        if not all(
            v is None  # a gap: NaN, refused later as non-finite with its row
            or (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool))
            for v in arr.reshape(-1)
        ):
            raise error(f"{name} must contain only real numbers")
        return out
    if arr.dtype.kind not in "iuf":
        raise error(f"{name} must contain real numbers, got an array of dtype {arr.dtype}")
    return np.array(arr, dtype=np.float64)


# --------------------------------------------------------------------------------------------
# In-memory validation
# --------------------------------------------------------------------------------------------


def check_positions(
    values: ArrayLike, name: str, error: type[InputError], ids: Sequence[object] | None = None
) -> NDArray[np.float64]:
    """Positions of shape (N, 2), metres: real, finite and within :data:`MAX_COORDINATE`.

    The message names ``name``, the first bad row (and its id when ``ids`` is given).

    Examples
    --------
    >>> check_positions([[0, 0], [1, 2e9]], "landmarks_xy", InputError)
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    omniloc.errors.InputError: landmark 1 has a coordinate of 2e+09 m (landmarks_xy); ...
    """
    xy = real_array(values, name, error)
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise error(f"{name} must have shape (N, 2), got {xy.shape}")
    finite = np.asarray(np.isfinite(xy).all(axis=1), dtype=bool)
    big = np.abs(np.where(np.isfinite(xy), xy, 0.0)).max(axis=1, initial=0.0) > MAX_COORDINATE
    bad = np.flatnonzero(~finite | big)
    if bad.size:
        row = int(bad[0])
        who = f"landmark {row}" + (f" (id {ids[row]!r})" if ids is not None else "")
        if not finite[row]:
            raise error(f"{who} has a non-finite coordinate ({name}): {xy[row].tolist()}")
        v = float(xy[row][np.argmax(np.abs(xy[row]))])
        raise error(
            f"{who} has a coordinate of {v:.3g} m ({name}); positions are metres of magnitude "
            f"at most {MAX_COORDINATE:.0e} (move the origin near the landmarks)"
        )
    return xy


def check_bearings(
    bearings: ArrayLike,
    *,
    n_landmarks: int | None = None,
    min_count: int = 3,
    name: str = "bearings",
) -> NDArray[np.float64]:
    """Validate bearings at the door of a public function and return a wrapped copy.

    Parameters
    ----------
    bearings : array_like, shape (m,)
        Bearings in radians, any range.
    n_landmarks : int, optional
        Number of landmarks in the map; more bearings than this is an error.
    min_count : int, default 3
        Smallest acceptable number of bearings.
    name : str, default "bearings"
        What to call the array in error messages.

    Returns
    -------
    ndarray of float64, shape (m,)
        A new array with the bearings wrapped to [-pi, pi) (values already in range are kept
        exactly).

    Raises
    ------
    ObservationError
        If ``bearings`` is not a 1-D array of real numbers (a (m, 1) or (1, m) array is
        refused, not flattened), has a non-finite entry, has fewer than ``min_count`` entries
        or more than ``n_landmarks``.

    Examples
    --------
    >>> check_bearings([0.0, 3 * np.pi / 2, -np.pi])
    array([ 0.        , -1.57079633, -3.14159265])
    >>> check_bearings([[0.1, 0.2, 0.3]])
    Traceback (most recent call last):
    ...
    omniloc.errors.ObservationError: bearings must have shape (m,), got (1, 3)
    >>> check_bearings([0.1, 0.2, 0.3, 0.4], n_landmarks=3)
    Traceback (most recent call last):
    ...
    omniloc.errors.ObservationError: 4 bearings but the map has only 3 landmarks
    """
    if not isinstance(name, str):
        raise InputError(f"name must be a str (for messages), got {type(name).__name__}")
    name = shorten(name, 40).strip("'")
    for key, v in (("n_landmarks", n_landmarks), ("min_count", min_count)):
        if (v is None and key == "min_count") or (
            v is not None and (isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 0)
        ):
            raise InputError(f"{key} must be an int >= 0, got {shorten(v)}")
    arr = real_array(bearings, name, ObservationError)
    if arr.ndim != 1:
        raise ObservationError(f"{name} must have shape (m,), got {arr.shape}")
    finite = np.isfinite(arr)
    if not np.all(finite):
        bad = np.flatnonzero(~finite)
        more = f" (and {bad.size - 1} more)" if bad.size > 1 else ""
        raise ObservationError(f"{name}[{int(bad[0])}] is not finite: {float(arr[bad[0]])!r}{more}")
    m = arr.shape[0]
    if m < min_count:
        shown = f"{min_count}" if min_count < 10**6 else f"a number of {len(str(min_count))} digits"
        raise ObservationError(f"localization needs at least {shown} {name}, got {m}")
    if n_landmarks is not None and m > n_landmarks:
        raise ObservationError(f"{m} {name} but the map has only {n_landmarks} landmarks")
    return _wrap_keep_in_range(arr)


# --------------------------------------------------------------------------------------------
# Bearing files
# --------------------------------------------------------------------------------------------


def _units_conflict(where: str, says: str, degrees: bool) -> None:
    """Raise if the file declares radians while the caller asked for degrees."""
    if degrees and says == "rad":
        raise ObservationError(
            f"{where}: the file declares radians but degrees=True was given; "
            "drop degrees=True or fix the file"
        )


def _bearings_from_csv(text: str, src: str, degrees: bool) -> tuple[list[float], bool]:
    values: list[float] = []
    column = 0
    n_fields = 1
    in_degrees = degrees
    header_done = False
    for lineno, line in content_lines(text):
        where = f"{src} line {lineno}"
        fields = split_csv_line(line, where, ObservationError)
        if not header_done:
            header_done = True
            if len(fields) == 1 and _looks_numeric(fields[0]):
                pass  # a single column of numbers, no header: this line is data
            else:
                names = [f.lower() for f in fields]
                found = [k for k, nm in enumerate(names) if nm in _BEARING_COLUMNS]
                if not found:
                    raise ObservationError(
                        f"{where}: header must contain a column named bearing, bearing_rad "
                        f"or bearing_deg (or the file must be a single column of numbers "
                        f"without header); found: {_columns(fields)}"
                    )
                if len(found) > 1:
                    cols = ", ".join(repr(fields[k]) for k in found)
                    raise ObservationError(f"{where}: several bearing columns ({cols}); keep one")
                column, n_fields = found[0], len(fields)
                if names[column] == "bearing_deg":
                    in_degrees = True
                elif names[column] == "bearing_rad":
                    _units_conflict(where, "rad", degrees)
                continue
        if len(fields) != n_fields:
            raise ObservationError(f"{where}: expected {n_fields} fields, got {len(fields)}")
        values.append(parse_float(fields[column], where, "bearing", ObservationError))
    return values, in_degrees


def _looks_numeric(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


#: Units a JSON bearings file may declare, as ``"deg"`` or ``"rad"`` (``omniloc bearings
#: --json`` writes the words).
_JSON_UNITS = {"deg": "deg", "degrees": "deg", "rad": "rad", "radians": "rad"}


def _bearings_from_json(
    text: str, src: str, degrees: bool
) -> tuple[list[float], bool, list[bool] | None]:
    """The bearings of a JSON file, whether they are degrees, and for the detections that
    ``omniloc bearings --json`` writes, their ``ambiguous`` flags (else None)."""
    data = parse_json(text, src, ObservationError)
    in_degrees = degrees
    flags: list[bool] | None = None
    if isinstance(data, dict):
        if "bearings" not in data and "detections" not in data:
            keys = ", ".join(repr(k) for k in data) or "none"
            raise ObservationError(
                f"{src}: expected a list of numbers, an object with a 'bearings' list or the "
                f"'detections' of omniloc bearings --json; got an object with keys {keys}"
            )
        units = data.get("units")
        if units is not None:
            if units not in _JSON_UNITS:
                raise ObservationError(
                    f"{src}: units must be 'deg' or 'rad', got {units!r} ('degrees' and "
                    "'radians' are read too)"
                )
            _units_conflict(src, _JSON_UNITS[units], degrees)
            in_degrees = _JSON_UNITS[units] == "deg"
        if "bearings" in data:
            items = data["bearings"]
            if not isinstance(items, list):
                raise ObservationError(
                    f"{src}: 'bearings' must be a list of numbers, got {type_name(items)}"
                )
        else:
            dets = data["detections"]
            if not isinstance(dets, list):
                raise ObservationError(
                    f"{src}: 'detections' must be a list of objects, got {type_name(dets)}"
                )
            items, flags = [], []
            for k, d in enumerate(dets):
                if not isinstance(d, dict) or "bearing" not in d:
                    raise ObservationError(
                        f"{src}: detections[{k}] must be an object with a 'bearing', got "
                        f"{type_name(d)}"
                    )
                amb = d.get("ambiguous", False)
                if not isinstance(amb, bool):
                    raise ObservationError(
                        f"{src}: detections[{k}].ambiguous must be true or false, got {amb!r}"
                    )
                items.append(d["bearing"])
                flags.append(amb)
    elif isinstance(data, list):
        items = data
    else:
        raise ObservationError(
            f"{src}: expected a list of numbers or an object with a 'bearings' list; "
            f"got {type_name(data)}"
        )
    values = [json_float(v, src, f"bearings[{k}]", ObservationError) for k, v in enumerate(items)]
    return values, in_degrees, flags


def _bearings_from_text(text: str, src: str) -> list[float]:
    values: list[float] = []
    for lineno, raw in enumerate(text.split("\n"), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        where = f"{src} line {lineno}"
        for token in _TEXT_SEPARATORS.split(line):
            if token:
                values.append(parse_float(token, where, "bearing", ObservationError))
    return values


def load_bearings(path: PathLike, *, degrees: bool = False) -> NDArray[np.float64]:
    """Read bearings from a CSV, JSON or plain-text file.

    Parameters
    ----------
    path : str or path-like
        The file; its extension (``.csv``, ``.json``, anything else = plain text) chooses the
        format (see the module docstring).
    degrees : bool, default False
        Read the numbers as degrees. Units written in the file (a ``bearing_deg`` or
        ``bearing_rad`` column, a JSON ``"units"``) take precedence over the default; a file
        that declares radians while ``degrees=True`` is an error rather than a guess.

    Returns
    -------
    ndarray of float64, shape (m,)
        Bearings in radians wrapped to [-pi, pi), in file order.

    Raises
    ------
    ObservationError
        If the file cannot be read, is empty, has a value that is not a finite number (the
        message names the file and the line or entry), its units conflict with ``degrees``,
        or it is read as radians and a value exceeds a full turn (:func:`check_radians`:
        degrees without the flag).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "b.txt").write_text("# three bearings\\n0, 90\\n270\\n")
    >>> np.rad2deg(load_bearings(d / "b.txt", degrees=True))
    array([  0.,  90., -90.])
    """
    return read_bearings(path, degrees=degrees)[0]


def read_bearings(
    path: PathLike, *, degrees: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """:func:`load_bearings`, and which bearings are flagged ``ambiguous``.

    A JSON file may also be what ``omniloc bearings --json`` writes (``{"units": "radians" |
    "degrees", "detections": [{"bearing": ..., "ambiguous": ...}, ...]}``): its flags mark
    the edges of a stripe that could be a pole or a narrow wall segment, which a search may
    take as spurious (``omniloc localize --bearings`` adds them to ``--max-spurious``, as
    ``--image`` does). Every other file flags none.

    Returns
    -------
    bearings : ndarray of float64, shape (m,)
        As :func:`load_bearings`.
    ambiguous : ndarray of bool, shape (m,)

    Raises
    ------
    ObservationError
        As :func:`load_bearings`.
    """
    src = os.fspath(as_path(path, "path", ObservationError))
    text = read_text(src, ObservationError)
    suffix = Path(src).suffix.lower()
    in_degrees = degrees
    flags: list[bool] | None = None
    if suffix == ".csv":
        values, in_degrees = _bearings_from_csv(text, src, degrees)
    elif suffix == ".json":
        values, in_degrees, flags = _bearings_from_json(text, src, degrees)
    else:
        values = _bearings_from_text(text, src)
    if not values:
        raise ObservationError(f"{src}: no bearings found (the file is empty)")
    arr = np.array(values, dtype=np.float64)
    if in_degrees:
        arr = np.deg2rad(arr)
    else:
        check_radians(arr, lambda k: f"{src}: bearings[{k}]")
    amb = np.zeros(arr.size, dtype=bool) if flags is None else np.array(flags, dtype=bool)
    return _wrap_keep_in_range(arr), amb


#: Largest magnitude (rad) a bearing read from a file as radians may have: a full turn.
#: Beyond it the numbers are degrees read as radians far more often than angles summed past
#: a turn, and read as radians they would localize the robot somewhere, wrongly.
MAX_FILE_RADIANS = 2.0 * math.pi


def check_radians(
    values: NDArray[np.float64],
    where: Callable[[int], str],
    error: type[Exception] = ObservationError,
) -> None:
    """Refuse bearings read from a file as radians that exceed a full turn
    (:data:`MAX_FILE_RADIANS`): they are degrees without the flag that says so. ``where(k)``
    names the place of value ``k`` in the file, for the message.

    Examples
    --------
    >>> check_radians(np.array([0.5, -3.0, 6.2]), lambda k: f"b.csv: bearings[{k}]")
    >>> check_radians(np.array([0.5, 45.0]), lambda k: f"b.csv: bearings[{k}]")
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    omniloc.errors.ObservationError: b.csv: bearings[1] is 45, more than a full turn in ...
    """
    over = np.flatnonzero(np.abs(values) > MAX_FILE_RADIANS)
    if over.size:
        k = int(over[0])
        raise error(
            f"{where(k)} is {float(values[k]):g}, more than a full turn in radians: are the "
            "bearings in degrees? Say so (--degrees, degrees=True, or a bearing_deg column)"
        )


def _float_text(value: float) -> str:
    """Shortest text that reads back as exactly the same float."""
    return repr(float(value))


def save_bearings(path: PathLike, bearings: ArrayLike, *, degrees: bool = False) -> None:
    """Write bearings to a CSV, JSON or plain-text file (the format follows the extension).

    The file reads back with :func:`load_bearings` (for plain text, pass the same
    ``degrees``; CSV and JSON record their units). Values are written wrapped to [-pi, pi)
    (or the same range in degrees) with enough digits to read back exactly.

    Parameters
    ----------
    path : str or path-like
        Destination; ``.csv`` writes a ``bearing_rad``/``bearing_deg`` column, ``.json`` writes
        ``{"bearings": [...], "units": ...}``, anything else one number per line.
    bearings : array_like, shape (m,)
        Bearings in radians, m >= 1.
    degrees : bool, default False
        Write degrees instead of radians.

    Raises
    ------
    ObservationError
        If ``bearings`` is invalid (see :func:`check_bearings`) or the file cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "b.csv"
    >>> save_bearings(p, [0.5, -1.0, 4.0])
    >>> print(p.read_text(), end="")
    bearing_rad
    0.5
    -1.0
    -2.2831853071795862
    >>> load_bearings(p)
    array([ 0.5       , -1.        , -2.28318531])
    """
    arr = check_bearings(bearings, min_count=1)
    if degrees:
        arr = np.rad2deg(arr)
    units = "deg" if degrees else "rad"
    suffix = as_path(path, "path", ObservationError).suffix.lower()
    if suffix == ".csv":
        text = f"bearing_{units}\n" + "".join(f"{_float_text(v)}\n" for v in arr)
    elif suffix == ".json":
        items = ", ".join(_float_text(v) for v in arr)
        text = f'{{"bearings": [{items}], "units": "{units}"}}\n'
    else:
        unit_word = "degrees (load with degrees=True)" if degrees else "radians"
        text = f"# bearings in {unit_word}\n" + "".join(f"{_float_text(v)}\n" for v in arr)
    write_text(path, text, ObservationError)


# --------------------------------------------------------------------------------------------
# JSON output
# --------------------------------------------------------------------------------------------


def to_jsonable(obj: Any) -> Any:
    """Turn numpy arrays and scalars, dataclasses, enums and paths into plain JSON values.

    Non-finite floats become ``None`` (JSON ``null``) because strict JSON has no NaN.
    Tuples become lists; dictionary keys that are numpy scalars or enums become their values.

    Examples
    --------
    >>> to_jsonable({"xy": np.array([[1.0, 2.0]]), "n": np.int64(3), "r": float("nan")})
    {'xy': [[1.0, 2.0]], 'n': 3, 'r': None}
    """
    if obj is None or isinstance(obj, bool | str):
        return obj
    if isinstance(obj, enum.Enum):
        return to_jsonable(obj.value)
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {_json_key(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(v) for v in obj]
    raise TypeError(f"cannot convert {type(obj).__name__} to JSON")


def _json_key(key: object) -> str | int | float | bool | None:
    if isinstance(key, enum.Enum):
        key = key.value
    if isinstance(key, np.generic):
        key = key.item()
    if key is None or isinstance(key, str | int | float | bool):
        return key
    return str(key)


def write_json(path: PathLike, obj: Any, *, indent: int | None = 2) -> None:
    """Write ``obj`` as strict JSON (see :func:`to_jsonable` for what is converted).

    Parameters
    ----------
    path : str or path-like
        Destination file, written as UTF-8 with a final newline.
    obj : object
        Dicts, lists, tuples, numbers, strings, numpy arrays and scalars, dataclasses, enums.
    indent : int or None, default 2
        Indentation passed to :func:`json.dumps`.

    Raises
    ------
    InputError
        If the file cannot be written.
    TypeError
        If ``obj`` contains something with no JSON form.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "out.json"
    >>> write_json(p, {"bearings": np.array([0.5, 1.5])}, indent=None)
    >>> p.read_text()
    '{"bearings": [0.5, 1.5]}\\n'
    """
    text = json.dumps(to_jsonable(obj), indent=indent, allow_nan=False) + "\n"
    write_text(path, text, InputError)


# --------------------------------------------------------------------------------------------
# Map files (omniloc.maps builds and validates the LandmarkMap from what is read here)
# --------------------------------------------------------------------------------------------

_MAP_COLUMNS = ("id", "x", "y")
_INT_ID = re.compile(r"[+-]?[0-9]+\Z")


@dataclass(frozen=True)
class MapFileData:
    """What a map file holds, before the map-level checks of :class:`omniloc.LandmarkMap`.

    ``place(i, j)`` names the file positions of entries i and j for messages (``"map.csv
    lines 4 and 9"``).
    """

    source: str
    coords: list[tuple[float, float]]
    ids: tuple[int | str, ...]
    names: list[str] | None
    place: Callable[[int, int], str]


def read_map_file(path: PathLike) -> MapFileData:
    """Read a ``.csv`` or ``.json`` map file (chosen by extension); see :mod:`omniloc.maps`
    for the formats.

    Raises
    ------
    MapError
        Unsupported extension, unreadable file, or content that is not a map (the message
        names the file and the line or entry).
    """
    src = os.fspath(as_path(path, "map path", MapError))
    suffix = Path(src).suffix.lower()
    if suffix == ".csv":
        return read_map_csv(path)
    if suffix == ".json":
        return read_map_json(path)
    shown = repr(suffix) if suffix else "no extension"
    raise MapError(f"{src}: unsupported map file ({shown}); supported extensions: .csv, .json")


def read_map_csv(path: PathLike) -> MapFileData:
    """Read a CSV map file (a header with ``id``, ``x``, ``y`` and optional ``name``)."""
    src = os.fspath(path)
    text = read_text(path, MapError)
    lines = content_lines(text)
    if not lines:
        raise MapError(f"{src}: file is empty (expected a header with columns id, x, y)")
    header_line, header_text = lines[0]
    where = f"{src} line {header_line}"
    header = [h.lower() for h in split_csv_line(header_text, where, MapError)]
    missing = [c for c in _MAP_COLUMNS if c not in header]
    if missing:
        found = _columns(header)
        raise MapError(
            f"{where}: header must contain columns id, x, y; missing: {', '.join(missing)} "
            f"(found: {found})"
        )
    for col in (*_MAP_COLUMNS, "name"):
        if header.count(col) > 1:
            raise MapError(f"{where}: column {col!r} appears more than once in the header")
    c_id, c_x, c_y = (header.index(c) for c in _MAP_COLUMNS)
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

    return MapFileData(
        src, coords, _ids_from_file(raw_ids), names if c_name is not None else None, place
    )


def read_map_json(path: PathLike) -> MapFileData:
    """Read a JSON map file (the layouts of :mod:`omniloc.maps`)."""
    src = os.fspath(path)
    data = parse_json(read_text(path, MapError), src, MapError)
    if isinstance(data, dict) and "landmarks" in data:
        entries = data["landmarks"]
        if not isinstance(entries, list):
            raise MapError(
                f"{src}: 'landmarks' must be a list of objects, got {type_name(entries)}"
            )
        return _map_json_entries(src, entries)
    if isinstance(data, list):
        return _map_json_entries(src, data)
    if isinstance(data, dict) and "xy" in data:
        return _map_json_xy(src, data)
    got = (
        f"an object with keys {', '.join(repr(k) for k in data) or 'none'}"
        if isinstance(data, dict)
        else type_name(data)
    )
    raise MapError(
        f"{src}: expected a list of landmarks, an object with a 'landmarks' list or an "
        f"object with 'xy' (and optional 'ids', 'names'); got {got}"
    )


def _map_json_entries(src: str, entries: list[Any]) -> MapFileData:
    raw_ids: list[int | str] = []
    coords: list[tuple[float, float]] = []
    names: list[str] = []
    has_names = any(isinstance(e, dict) and "name" in e for e in entries)
    for k, entry in enumerate(entries):
        where = f"{src}: landmarks[{k}]"
        if not isinstance(entry, dict):
            raise MapError(f"{where}: expected an object with id, x, y; got {type_name(entry)}")
        missing = [key for key in _MAP_COLUMNS if key not in entry]
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

    return MapFileData(src, coords, _ids_from_file(raw_ids), names if has_names else None, place)


def _map_json_xy(src: str, data: dict[str, Any]) -> MapFileData:
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
    ids: tuple[int | str, ...] | None = None
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

    return MapFileData(
        src, coords, ids if ids is not None else tuple(range(len(coords))), names, place
    )


def write_map_csv(
    path: PathLike,
    xy: NDArray[np.float64],
    ids: Sequence[int | str],
    names: Sequence[str] | None,
) -> None:
    """Write a map as CSV (``id,x,y`` plus ``name``), with enough digits to read back
    exactly."""
    for row, lid in enumerate(ids):
        texts = [str(lid)] + ([names[row]] if names is not None else [])
        if any("\n" in t or "\r" in t for t in texts):
            raise MapError(
                f"{os.fspath(path)}: landmark {row} (id {lid!r}) has a line break in its "
                "id or name, which CSV maps cannot hold; use JSON"
            )
    # Quote every text field if a line could otherwise be mistaken for a comment.
    leading_hash = any(isinstance(lid, str) and lid.lstrip().startswith("#") for lid in ids)
    buf = _stdio.StringIO()
    writer = csv.writer(
        buf,
        lineterminator="\n",
        quoting=csv.QUOTE_NONNUMERIC if leading_hash else csv.QUOTE_MINIMAL,
    )
    header = ["id", "x", "y"] + (["name"] if names is not None else [])
    writer.writerow(header)
    for row, lid in enumerate(ids):
        x, y = (float(v) for v in xy[row])
        writer.writerow([lid, x, y] + ([names[row]] if names is not None else []))
    write_text(path, buf.getvalue(), MapError)


def write_map_json(
    path: PathLike,
    xy: NDArray[np.float64],
    ids: Sequence[int | str],
    names: Sequence[str] | None,
) -> None:
    """Write a map as ``{"landmarks": [{"id": ..., "x": ..., "y": ...}, ...]}``, one
    landmark per line."""
    entries = []
    for row, lid in enumerate(ids):
        entry: dict[str, Any] = {"id": lid, "x": float(xy[row, 0])}
        entry["y"] = float(xy[row, 1])
        if names is not None:
            entry["name"] = names[row]
        entries.append("  " + json.dumps(entry))
    text = '{"landmarks": [\n' + ",\n".join(entries) + "\n]}\n"
    write_text(path, text, MapError)


def _ids_from_file(raw: Sequence[int | str]) -> tuple[int | str, ...]:
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
