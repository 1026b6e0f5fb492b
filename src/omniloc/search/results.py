"""What a search returns: solutions, statistics, and the choices of method and strategy."""

from __future__ import annotations

import enum
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import overload

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..maps import LandmarkMap
from ..pose import Pose

__all__ = ["LocalizationResult", "Method", "SearchStats", "Solution", "Solutions", "Strategy"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


class Method(str, enum.Enum):
    """Which search semantics :func:`localize` follows.

    ``paper``
        The published algorithm to the letter: observations in the order given, rules (i) and
        (ii) with a fixed threshold, every consistent complete path reported as its own
        solution (this reproduces the paper's Table 1). Robust options are refused.
    ``robust``
        The same tree with everything beyond the paper available (wildcards, chi-square
        gating, ordering, visibility, negative evidence); the observation order is chosen to
        prune early, and solutions that are the same pose are merged.
    """

    PAPER = "paper"
    ROBUST = "robust"


class Strategy(str, enum.Enum):
    """How :func:`localize` runs a robust search (see its ``strategy`` parameter).

    ``auto``
        The compiled paper tree where the paper's rules alone apply, the hypotheses search
        for the robust options when numba is installed, the tree otherwise.
    ``tree``
        The interpretation tree with wildcard branches (the reference).
    ``hypotheses``
        Compiled: a pose hypothesis from every landmark triple that can be seen together, for
        a few seed triples of bearings, verified on the other bearings.
    """

    AUTO = "auto"
    TREE = "tree"
    HYPOTHESES = "hypotheses"


@dataclass(frozen=True)
class SearchStats:
    """What the search did.

    Attributes
    ----------
    total_paths : int
        Complete paths of the tree without wildcards, ``N! / (N - m)!`` (the paper's Table 1,
        second column).
    examined_paths : int
        Nodes visited at depth four or deeper: each is a path the search traced more than
        three nodes deep (Table 1, third column). A wildcard node deeper than three counts too.
    nodes : int
        Every node visited, at any depth, wildcards included (a node is "visited" when its
        pairing is generated and tested, whether it passes or not).
    elapsed_s : float
        Wall-clock time of the search and the final refinement, seconds.
    triples_solved : int
        Depth-3 pose solutions attempted (rule i).
    pruned_existence, pruned_gate, pruned_ordering, pruned_visibility, pruned_bound : int
        Nodes cut by rule (i), by rule (ii), by the ordering constraint, by range/field of
        view, and paths cut by the match-count bound (wildcards).
    complete : bool
        False when a budget (``max_nodes``, ``timeout_s``) stopped the search early.
    exhaustive : bool
        False when the search stopped at a first fit (``exhaustive=False``) and so did not
        look for rival interpretations.
    stopped : str
        Why the search stopped before looking at everything: ``"budget"`` (``max_nodes`` or
        ``timeout_s``), ``"first fit: rivals not sought"``, or ``""`` (it did not).
    default_budget : str
        Why the search ran under a default budget the caller did not give ("" when it did
        not): nothing else bounded it (a gate wider than 10 degrees, a large map without
        ``max_range``), or a first fit's second look (``exhaustive=None``) ran, bounded by
        a multiple of the first fit's work; the note says what to pass. ``complete`` tells
        whether the budget stopped it.
    """

    total_paths: int
    examined_paths: int
    nodes: int
    elapsed_s: float
    triples_solved: int = 0
    pruned_existence: int = 0
    pruned_gate: int = 0
    pruned_ordering: int = 0
    pruned_visibility: int = 0
    pruned_bound: int = 0
    complete: bool = True
    exhaustive: bool = True
    stopped: str = ""
    default_budget: str = ""

    def as_dict(self) -> dict[str, int | float | bool | str]:
        """Plain-JSON dictionary of the statistics."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class Solution:
    """One consistent interpretation: which landmark each bearing is, and the pose.

    Attributes
    ----------
    pose : Pose
        Maximum-likelihood pose refined from all matched pairs.
    assignment : tuple of (int or None)
        For each observation, in the order given, the index of its landmark in the map, or
        None when the observation was declared spurious (wildcard).
    residual_rms : float
        RMS of the wrapped bearing residuals over the matched observations, radians.
    matched : int
        Number of matched observations.
    covariance : ndarray, shape (3, 3)
        Covariance of (x, y, theta); from ``sigma`` when given, else from ``threshold / 3``.
    cost : float
        Minus the interpretation's log evidence under the sensor model (see
        :mod:`omniloc.search.scoring`): residuals, matched and spurious bearings, plainly
        visible landmarks not observed, the volume of poses it allows.
    confidence : float
        Posterior probability that the robot is at this pose: the evidence of this
        interpretation and of the equivalent ones merged into it, normalised over every
        solution and the null interpretation (every bearing clutter). The confidences and
        :attr:`LocalizationResult.unexplained` sum to 1.
    missed : int
        Landmarks plainly visible from ``pose`` (by ``max_range``/``fov``) but not observed
        (counted when the sensor's ``p_detect`` is known, or its ``max_range`` is).
    """

    pose: Pose
    assignment: tuple[int | None, ...]
    residual_rms: float
    matched: int
    covariance: FloatArray = field(repr=False, compare=False)
    cost: float = 0.0
    confidence: float = 1.0
    missed: int = 0


class Solutions(Sequence[Solution]):
    """The solutions of a search, best first: a read-only sequence of :class:`Solution`
    held as arrays, each ``Solution`` made when it is first read.

    A window search of the tracker finds about a thousand interpretations and reads only
    their poses and assignments (:attr:`poses`, :attr:`assignments`): making a ``Solution``
    (and its ``Pose``) for each cost as much as the search's refinement.

    Parameters
    ----------
    poses : ndarray, shape (K, 3)
    assignments : ndarray of int, shape (K, m)
        Landmark row of each observation, -1 for a spurious one.
    residual_rms, cost, confidence : ndarray, shape (K,)
    matched, missed : ndarray of int, shape (K,)
    covariances : ndarray, shape (K, 3, 3)
    """

    __slots__ = ("_arrays", "_made")

    def __init__(
        self,
        poses: FloatArray,
        assignments: IntArray,
        residual_rms: FloatArray,
        matched: IntArray,
        covariances: FloatArray,
        cost: FloatArray,
        confidence: FloatArray,
        missed: IntArray,
    ) -> None:
        k = len(poses)
        given = (poses, assignments, residual_rms, matched, covariances, cost, confidence, missed)
        if any(len(a) != k for a in given) or poses.shape[1:] != (3,):
            raise InputError("Solutions: every array must have one row per solution")
        # Read-only views: the caller's arrays keep their flags.
        arrays = tuple(np.asarray(a).view() for a in given)
        for a in arrays:
            a.setflags(write=False)
        self._arrays = arrays
        self._made: list[Solution | None] = [None] * k

    @classmethod
    def empty(cls, m: int = 0) -> Solutions:
        """No solution (for ``m`` observations)."""
        z = np.zeros(0)
        zi = np.zeros(0, dtype=np.int64)
        return cls(
            np.zeros((0, 3)), np.zeros((0, m), dtype=np.int64), z, zi, np.zeros((0, 3, 3)), z, z, zi
        )

    @property
    def poses(self) -> FloatArray:
        """(K, 3) poses ``(x, y, theta)``, best first (read-only)."""
        return self._arrays[0]

    @property
    def assignments(self) -> IntArray:
        """(K, m) landmark rows of each observation, -1 for spurious (read-only)."""
        return self._arrays[1]

    @property
    def covariances(self) -> FloatArray:
        """(K, 3, 3) covariances of the poses (read-only)."""
        return self._arrays[4]

    def with_poses(self, poses: FloatArray, covariances: FloatArray) -> Solutions:
        """The same solutions at other poses with other covariances (the robot's, when the
        sensor sits elsewhere on it: :meth:`omniloc.SensorModel.robot_poses`)."""
        a = self._arrays
        return Solutions(poses, a[1], a[2], a[3], covariances, a[5], a[6], a[7])

    def with_columns(self, order: NDArray[np.intp]) -> Solutions:
        """The same solutions with their assignments' columns taken in ``order`` (column
        ``j`` of the result is column ``order[j]`` of these): the bearings' order given back
        after a search that took them in another."""
        a = self._arrays
        assign = np.ascontiguousarray(a[1][:, order])
        return Solutions(a[0], assign, a[2], a[3], a[4], a[5], a[6], a[7])

    def __len__(self) -> int:
        return len(self._made)

    def _make(self, i: int) -> Solution:
        sol = self._made[i]
        if sol is None:
            pose, assign, rms, nmatch, cov, cost, conf, missed = (a[i] for a in self._arrays)
            sol = Solution(
                pose=Pose(*pose.tolist()),
                assignment=tuple([v if v >= 0 else None for v in assign.tolist()]),
                residual_rms=float(rms),
                matched=int(nmatch),
                covariance=cov,
                cost=float(cost),
                confidence=float(conf),
                missed=int(missed),
            )
            self._made[i] = sol
        return sol

    @overload
    def __getitem__(self, i: int) -> Solution: ...

    @overload
    def __getitem__(self, i: slice) -> list[Solution]: ...

    def __getitem__(self, i: int | slice) -> Solution | list[Solution]:
        if isinstance(i, slice):
            return [self._make(j) for j in range(*i.indices(len(self)))]
        n = len(self)
        j = i + n if i < 0 else i
        if not 0 <= j < n:
            raise IndexError(f"solution {i} of {n}")
        return self._make(j)

    def __iter__(self) -> Iterator[Solution]:
        return (self._make(j) for j in range(len(self)))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Sequence) and not isinstance(other, (str, bytes)):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Solutions({len(self)} solutions)"


@dataclass(frozen=True)
class LocalizationResult:
    """The outcome of :func:`localize`; tests false when there is no solution.

    Attributes
    ----------
    solutions : Solutions (a sequence of Solution)
        Best first, by posterior confidence; :attr:`poses` and :attr:`assignments` give
        them all as arrays.
    stats : SearchStats
    landmarks : LandmarkMap
        The map searched (for landmark ids).
    ambiguous : bool
        True unless the best solution holds at least ``decisive`` (0.95 by default) of the
        posterior, beats the null interpretation by the decisive odds times the map's
        landmark count (a weak fit on a map of thousands may be chance), and the search
        looked for every rival (it was neither cut short by its budget nor stopped at a first
        fit). Only an unambiguous answer should be acted on without more evidence (symmetric
        maps, few bearings, clutter). True when there is no solution.
    unexplained : float
        Posterior probability that none of the solutions is right: every bearing clutter.
    mount : tuple of 3 floats or None
        Where the sensor sits on the robot (:attr:`omniloc.SensorModel.mount`): the poses
        are the robot's, the bearings were measured from ``compose(pose, mount)``.
    """

    solutions: Sequence[Solution]
    stats: SearchStats
    landmarks: LandmarkMap
    ambiguous: bool = False
    unexplained: float = 0.0
    mount: tuple[float, float, float] | None = None

    @property
    def competing(self) -> int:
        """How many distinct poses hold at least 1 % of the posterior."""
        return sum(s.confidence >= 0.01 for s in self.solutions)

    @property
    def best(self) -> Solution | None:
        """The best solution, or None."""
        return self.solutions[0] if self.solutions else None

    @property
    def poses(self) -> FloatArray:
        """Every solution's pose ``(x, y, theta)``, best first, shape (K, 3)."""
        if isinstance(self.solutions, Solutions):
            return self.solutions.poses
        return np.array([s.pose.as_tuple() for s in self.solutions], dtype=np.float64).reshape(
            -1, 3
        )

    @property
    def assignments(self) -> IntArray:
        """Every solution's landmark row for each observation (-1: spurious), best first,
        shape (K, m) (``(0, 0)`` for a result made from an empty list)."""
        if isinstance(self.solutions, Solutions):
            return self.solutions.assignments
        rows = [[-1 if a is None else a for a in s.assignment] for s in self.solutions]
        return np.array(rows, dtype=np.int64) if rows else np.zeros((0, 0), dtype=np.int64)

    @property
    def complete(self) -> bool:
        """False when a budget stopped the search before the whole tree was walked."""
        return self.stats.complete

    def __bool__(self) -> bool:
        return bool(self.solutions)

    def __len__(self) -> int:
        return len(self.solutions)

    def assignment_ids(self, solution: Solution) -> list[int | str | None]:
        """A solution's assignment as landmark ids (None for spurious observations)."""
        return [None if i is None else self.landmarks.ids[i] for i in solution.assignment]
