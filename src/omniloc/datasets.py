"""Loaders for the two real bearing recordings shipped under ``shared/data``.

* :func:`load_roh` -- a 360-degree rotating infrared beacon detector (KAIST): 4 beacons at the
  corners of a 6 m square, 9 known grid positions, 200 samples each.
* :func:`load_mrclam` -- UTIAS MRCLAM set 6: a 65-degree monocular camera seeing 15 tube
  landmarks in tight clusters, plus the other robots (spurious bearings), Vicon ground truth.

Both datasets give the correspondences (column order for Roh, landmark ids for MRCLAM). The
loaders keep that truth in :attr:`DatasetSample.assignment` and hand the solver only shuffled
bearings, so localization is correspondence-free.
"""

from __future__ import annotations

import csv
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .angles import wrap
from .errors import InputError
from .io import as_path, shorten
from .maps import LandmarkMap
from .pose import Pose

__all__ = [
    "DatasetSample",
    "MrclamDataset",
    "RohDataset",
    "load_mrclam",
    "load_roh",
]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None
PathLike = str | Path


@dataclass(frozen=True)
class DatasetSample:
    """One real observation with its ground truth.

    Attributes
    ----------
    bearings : ndarray, shape (m,)
        Bearings in the robot frame, radians, in the order handed to the solver.
    assignment : tuple of (int or None)
        True landmark index (row of the dataset's map) of each bearing; None for a spurious
        bearing (MRCLAM: another robot).
    pose : Pose
        Ground-truth pose.
    source : str
        Where the sample comes from, ``"file:line"``.
    """

    bearings: FloatArray
    assignment: tuple[int | None, ...]
    pose: Pose
    source: str

    @property
    def n_spurious(self) -> int:
        """Number of bearings that are not landmarks of the map."""
        return sum(a is None for a in self.assignment)


def _shuffled(sample: DatasetSample, gen: np.random.Generator) -> DatasetSample:
    perm = gen.permutation(sample.bearings.size)
    return DatasetSample(
        sample.bearings[perm],
        tuple(sample.assignment[i] for i in perm),
        sample.pose,
        sample.source,
    )


def _float(text: str, what: str, where: str) -> float:
    try:
        v = float(text)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: {what} must be a number, got {text!r}") from exc
    if not np.isfinite(v):
        raise InputError(f"{where}: {what} must be finite, got {text!r}")
    return v


def _read_rows(path: Path, required: tuple[str, ...]) -> Iterator[tuple[int, dict[str, str]]]:
    """Rows of a CSV file as dicts with their 1-based line numbers; checks the header."""
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    line = 1
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            header = reader.fieldnames or []
            missing = [c for c in required if c not in header]
            if missing:
                raise InputError(
                    f"{path}:1: missing column(s) {missing}; header is {shorten(header, 120)}"
                )
            for row in reader:
                line = reader.line_num
                if None in row or any(row.get(c) is None for c in required):
                    raise InputError(
                        f"{path}:{line}: expected {len(header)} fields, got a row of another length"
                    )
                yield line, row
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not a UTF-8 text file (byte {e.start} of a line)") from None
    except csv.Error as e:
        raise InputError(f"{path}:{line}: not a readable CSV file ({e})") from None
    except OSError as e:
        raise InputError(f"{path}: cannot read the file: {e.strerror or e}") from None


# --------------------------------------------------------------------------------------------
# Roh: 360-degree IR beacons
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RohDataset:
    """The Roh infrared-beacon recording.

    Attributes
    ----------
    landmarks : LandmarkMap
        The 4 beacons.
    poses : ndarray, shape (S, 3)
        Ground-truth ``(x, y, theta)`` per sample.
    bearings : ndarray, shape (S, 4)
        Column k is the bearing of landmark k (row k of ``landmarks``), radians.
    lines : ndarray of int, shape (S,)
        Line of each sample in ``measurements.csv``.
    path : Path
        The measurements file.
    """

    landmarks: LandmarkMap
    poses: FloatArray
    bearings: FloatArray
    lines: NDArray[np.int64]
    path: Path

    def __len__(self) -> int:
        return int(self.poses.shape[0])

    def samples(
        self, rng: RngLike = None, *, max_samples: int | None = None
    ) -> Iterator[DatasetSample]:
        """Samples with the bearings shuffled (correspondences hidden), in file order.

        ``max_samples`` keeps the first samples only.
        """
        gen = np.random.default_rng(rng)
        n = len(self) if max_samples is None else min(len(self), int(max_samples))
        idx = tuple(range(self.bearings.shape[1]))
        for s in range(n):
            raw = DatasetSample(
                self.bearings[s].copy(),
                idx,
                Pose.from_array(self.poses[s]),
                f"{self.path.name}:{int(self.lines[s])}",
            )
            yield _shuffled(raw, gen)


def _existing(path: PathLike, name: str) -> Path:
    """``path`` as a Path, or an error naming it when there is nothing there."""
    p = as_path(path, f"the {name} dataset path")
    if not p.exists():
        raise InputError(f"{p}: no such folder or file (the {name} dataset)")
    return p


def load_roh(path: PathLike) -> RohDataset:
    """Load the Roh dataset from its folder (or from its ``measurements.csv``).

    Raises
    ------
    InputError
        A file is missing or a row is malformed (the message names the file and line).
    """
    p = _existing(path, "Roh")
    folder = p if p.is_dir() else p.parent
    meas = folder / "measurements.csv" if p.is_dir() else p
    lm_path = folder / "landmarks.csv"
    if not lm_path.is_file():
        raise InputError(f"{lm_path}: no such file (the Roh landmarks)")
    lm = LandmarkMap.from_csv(lm_path)
    cols = tuple(f"bearing_lm{k + 1}" for k in range(lm.n))
    poses: list[list[float]] = []
    bears: list[list[float]] = []
    lines: list[int] = []
    for line, row in _read_rows(meas, ("gt_x", "gt_y", "gt_theta", *cols)):
        where = f"{meas}:{line}"
        poses.append([_float(row[c], c, where) for c in ("gt_x", "gt_y", "gt_theta")])
        bears.append([_float(row[c], c, where) for c in cols])
        lines.append(line)
    if not poses:
        raise InputError(f"{meas}: no samples")
    return RohDataset(
        lm,
        np.asarray(poses, dtype=np.float64),
        np.asarray(wrap(np.asarray(bears, dtype=np.float64)), dtype=np.float64),
        np.asarray(lines, dtype=np.int64),
        meas,
    )


# --------------------------------------------------------------------------------------------
# MRCLAM: 65-degree camera, clustered tubes, other robots as clutter
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MrclamDataset:
    """UTIAS MRCLAM set 6 camera frames.

    Attributes
    ----------
    landmarks : LandmarkMap
        The 15 tubes (ids 6-20).
    frames : list of DatasetSample
        Kept frames, unshuffled: landmark bearings first, then robot detections
        (assignment None).
    folder : Path
    """

    landmarks: LandmarkMap
    frames: list[DatasetSample]
    folder: Path

    def __len__(self) -> int:
        return len(self.frames)

    def samples(
        self, rng: RngLike = None, *, max_samples: int | None = None
    ) -> Iterator[DatasetSample]:
        """Frames with the bearings shuffled (correspondences hidden), in order."""
        gen = np.random.default_rng(rng)
        frames = self.frames if max_samples is None else self.frames[: int(max_samples)]
        for f in frames:
            yield _shuffled(f, gen)


def _detections(text: str, what: str, where: str) -> list[tuple[str, float]]:
    """Parse ``id:bearing:range;...`` into (id, bearing) pairs."""
    out: list[tuple[str, float]] = []
    text = text.strip()
    if not text:
        return out
    for item in text.split(";"):
        parts = item.split(":")
        if len(parts) != 3 or not parts[0].strip():
            raise InputError(f"{where}: {what} entry {item!r} is not 'id:bearing:range'")
        b = _float(parts[1], f"{what} bearing", where)
        _float(parts[2], f"{what} range", where)
        out.append((parts[0].strip(), b))
    return out


def load_mrclam(
    path: PathLike,
    robots: tuple[int, ...] = (1, 2, 3, 4, 5),
    *,
    min_landmarks: int = 4,
    include_robots: bool = True,
) -> MrclamDataset:
    """Load MRCLAM camera frames.

    Parameters
    ----------
    path : str or Path
        The dataset folder (holding ``landmarks.csv`` and ``robotR_frames.csv``), or one
        ``robotR_frames.csv`` file (then only that robot is read).
    robots : tuple of int
        Robots whose frames to read.
    min_landmarks : int
        Keep frames with at least this many distinct landmark detections.
    include_robots : bool
        Append detections of other robots as spurious bearings (assignment None).

    Raises
    ------
    InputError
        Missing files, an unknown landmark id, or a malformed row (file and line named).
    """
    if isinstance(robots, str | bytes) or not isinstance(robots, tuple | list):
        raise InputError(f"robots must be a tuple of robot numbers, got {shorten(robots)}")
    for r in robots:
        if isinstance(r, bool) or not isinstance(r, int | np.integer) or not 1 <= r <= 99:
            raise InputError(f"robots must hold robot numbers 1-99, got {shorten(r)}")
    if isinstance(min_landmarks, bool) or not isinstance(min_landmarks, int | np.integer):
        raise InputError(f"min_landmarks must be an int, got {shorten(min_landmarks)}")
    if min_landmarks < 0:
        raise InputError(f"min_landmarks must be >= 0, got {min_landmarks}")
    p = _existing(path, "MRCLAM")
    if p.is_dir():
        folder = p
        files = [folder / f"robot{r}_frames.csv" for r in robots]
    else:
        folder = p.parent
        files = [p]
    lm_path = folder / "landmarks.csv"
    if not lm_path.is_file():
        raise InputError(f"{lm_path}: no such file (the MRCLAM landmarks)")
    lm = LandmarkMap.from_csv(lm_path)
    row_of = {str(i): k for k, i in enumerate(lm.ids)}
    frames: list[DatasetSample] = []
    for f in files:
        for line, row in _read_rows(
            f, ("gt_x", "gt_y", "gt_theta", "landmarks", "robot_detections")
        ):
            where = f"{f}:{line}"
            pose = Pose(*(_float(row[c], c, where) for c in ("gt_x", "gt_y", "gt_theta")))
            dets = _detections(row["landmarks"], "landmark", where)
            bearings: list[float] = []
            assign: list[int | None] = []
            seen: set[int] = set()
            for ident, b in dets:
                if ident not in row_of:
                    raise InputError(f"{where}: landmark id {ident!r} is not in {lm_path.name}")
                k = row_of[ident]
                if k in seen:  # a second sighting of the same tube in one frame: keep the first
                    continue
                seen.add(k)
                bearings.append(b)
                assign.append(k)
            robots_b = _detections(row["robot_detections"], "robot detection", where)
            if len(seen) < min_landmarks:
                continue
            if include_robots:
                bearings += [b for _, b in robots_b]
                assign += [None] * len(robots_b)
            frames.append(
                DatasetSample(
                    np.asarray(wrap(np.asarray(bearings, dtype=np.float64)), dtype=np.float64),
                    tuple(assign),
                    pose,
                    f"{f.name}:{line}",
                )
            )
    return MrclamDataset(lm, frames, folder)
