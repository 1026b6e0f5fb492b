"""The options of a search, checked at the door, and what a search run collects.

:func:`omniloc.localize` takes a :class:`~omniloc.sensor.SensorModel` (what the sensor
measures and how well), a :class:`Budget` (when to stop) and the search's own choices
(``max_spurious``, ``ordering``, ``strategy``, ``exhaustive``). Its older keyword arguments
(``sigma=``, ``max_range=``, ``p_miss=``, ``timeout_s=``...) map onto those objects here, so a
user's script keeps working. Everything the engines need is in one frozen
:class:`SearchOptions`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io import finite_number
from ..sensor import DEFAULT_THRESHOLD, SensorModel
from .results import Method

__all__ = ["Budget", "Counters", "Leaves", "SearchOptions", "make_options"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The largest budget accepted (a node count or seconds): beyond it a number is no limit in
#: practice, and the compiled engines count in 64-bit integers.
MAX_BUDGET = 2**62


@dataclass(frozen=True)
class Budget:
    """When a search stops early: after ``max_nodes`` nodes or ``timeout_s`` seconds.

    A search stopped by its budget returns what it found, with ``result.complete`` False.
    ``None`` is no limit.

    Where a search runs in pieces side by side (a large map's chunks of landmarks, or a
    chunk per seed under a time budget; two threads), each piece may spend what the pieces
    finished before it left: the nodes visited may then reach up to twice ``max_nodes``
    (``result.stats.nodes`` says how many). With ``max_nodes`` alone, where a search stops
    depends on the nodes only, not on the threads' timing: the same search stops at the
    same place on any machine.
    """

    max_nodes: int | None = None
    timeout_s: float | None = None

    def __post_init__(self) -> None:
        n = self.max_nodes
        if n is not None:
            if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
                raise InputError(f"max_nodes must be a positive integer, got {n!r}")
            object.__setattr__(self, "max_nodes", int(min(int(n), MAX_BUDGET)))
        t = self.timeout_s
        if t is not None:
            if isinstance(t, bool) or not isinstance(t, (int, float, np.integer, np.floating)):
                raise InputError(f"timeout_s must be a number of seconds, got {t!r}")
            try:
                seconds = float(t)
            except OverflowError:  # an int beyond float: no limit in practice
                seconds = float(MAX_BUDGET)
            if not (seconds > 0 and not math.isnan(seconds)):
                raise InputError(f"timeout_s must be a positive number of seconds, got {t!r}")
            object.__setattr__(self, "timeout_s", float(min(seconds, MAX_BUDGET)))

    @property
    def bounded(self) -> bool:
        """Whether anything limits the search."""
        return self.max_nodes is not None or self.timeout_s is not None


@dataclass(frozen=True)
class SearchOptions:
    """Everything a search engine reads, validated (built by :func:`make_options`).

    Attributes
    ----------
    sensor : SensorModel
    m : int
        Number of bearings.
    max_wild : int
        Bearings that may be spurious (wildcards).
    ordering : bool
        Prune by the angular ordering constraint.
    merge : bool
        Merge solutions that are the same pose (``method="robust"``).
    budget : Budget
    decisive : float
        Share of the posterior the best solution must hold for the answer to be unambiguous.
    contested_wildcards : bool
        The hypotheses engine leaves a bearing that a landmark fits unmatched too only when
        another bearing lies close by (see :func:`omniloc.search.localize`); False: always,
        while the wildcards allow (as the tree does).
    """

    sensor: SensorModel
    m: int
    max_wild: int
    ordering: bool
    merge: bool
    budget: Budget = field(default_factory=Budget)
    decisive: float = 0.95
    contested_wildcards: bool = False

    @property
    def min_match(self) -> int:
        """Matched bearings a complete interpretation needs: ``m - max_wild``."""
        return self.m - self.max_wild

    @property
    def joint_chi2(self) -> FloatArray:
        """By number of matched pairs, the joint test's chi-square quantile."""
        return self.sensor.joint_chi2(self.m)

    @property
    def uses_sigma(self) -> bool:
        """Whether the gates are chi-square tests (a ``sigma`` is known)."""
        return self.sensor.sigma is not None

    @property
    def paper_rules(self) -> bool:
        """Whether only the paper's rules apply (a fixed threshold, no wildcard, ordering or
        range): the compiled paper tree covers such a search."""
        s = self.sensor
        return (
            s.sigma is None
            and self.max_wild == 0
            and not self.ordering
            and s.max_range is None
            and s.min_range is None
        )


def _max_spurious(max_spurious: Any, m: int) -> int:
    if isinstance(max_spurious, bool) or not isinstance(max_spurious, (int, float, np.number)):
        raise InputError(f"max_spurious must be an int or a fraction of m, got {max_spurious!r}")
    if isinstance(max_spurious, (int, np.integer)) and not -(2**62) < max_spurious < 2**62:
        raise InputError(
            f"max_spurious must be an int below the number of bearings ({m}), got an int of "
            f"{len(str(max_spurious))} digits"
        )
    v = finite_number(max_spurious, "max_spurious")
    if isinstance(max_spurious, (float, np.floating)) and not v.is_integer():
        if not 0.0 <= v < 1.0:
            raise InputError(f"max_spurious as a fraction must lie in [0, 1), got {max_spurious}")
        return math.floor(v * m)
    if v < 0:
        raise InputError(f"max_spurious must be >= 0, got {max_spurious}")
    if v >= m:
        raise InputError(
            f"max_spurious={v:.6g} is not below the number of bearings ({m}); a pose needs at "
            "least 3 matched bearings"
        )
    return int(v)


def make_options(
    m: int,
    *,
    method: Method,
    sensor: SensorModel | None,
    budget: Budget | None,
    max_spurious: int | float,
    ordering: bool,
    legacy: dict[str, Any],
    decisive: float = 0.95,
) -> SearchOptions:
    """Check a search's options and build its :class:`SearchOptions`.

    ``legacy`` holds the keyword arguments of :func:`~omniloc.localize` that describe the
    sensor or the budget (``threshold``, ``sigma``, ``confidence``, ``max_range``,
    ``min_range``, ``fov``, ``p_miss``, ``p_detect``, ``clutter``, ``clutter_by_detections``,
    ``mount``, ``max_nodes``,
    ``timeout_s``) that the caller actually
    gave; with ``sensor`` or ``budget`` also given, they may not repeat what those say.
    """
    sensor_keys = (
        "threshold",
        "sigma",
        "confidence",
        "max_range",
        "min_range",
        "fov",
        "p_miss",
        "p_detect",
        "clutter",
        "clutter_by_detections",
        "mount",
    )
    budget_keys = ("max_nodes", "timeout_s")
    given = {k: v for k, v in legacy.items() if v is not None}
    if sensor is not None:
        if not isinstance(sensor, SensorModel):
            raise InputError(f"sensor must be a SensorModel, got {type(sensor).__name__}")
        clash = [k for k in sensor_keys if k in given]
        if clash:
            raise InputError(
                f"give the sensor's {', '.join(clash)} in the SensorModel, not also as "
                "keyword arguments"
            )
    else:
        kw = {k: given[k] for k in sensor_keys if k in given}
        kw.setdefault("threshold", DEFAULT_THRESHOLD)
        sensor = SensorModel.from_options(**kw)
    if budget is not None:
        if not isinstance(budget, Budget):
            raise InputError(f"budget must be a Budget, got {type(budget).__name__}")
        clash = [k for k in budget_keys if k in given]
        if clash:
            raise InputError(f"give {', '.join(clash)} in the Budget, not also as keywords")
    else:
        budget = Budget(**{k: given[k] for k in budget_keys if k in given})
    k = _max_spurious(max_spurious, m)
    if m - k < 3:
        raise InputError(
            f"max_spurious={max_spurious} leaves {m - k} matched bearings out of {m}; "
            "a pose needs at least 3"
        )
    if isinstance(decisive, bool) or not isinstance(decisive, (int, float, np.number)):
        raise InputError(f"decisive must be a share of the posterior in (0, 1), got {decisive!r}")
    if not 0.5 <= finite_number(decisive, "decisive") < 1.0:
        raise InputError(
            f"decisive must lie in [0.5, 1): the best solution's share of the posterior for an "
            f"unambiguous answer, got {decisive!r}"
        )
    if not isinstance(ordering, (bool, np.bool_)):
        raise InputError(f"ordering must be True or False, got {ordering!r}")
    if method is Method.PAPER:
        extras = {
            "sigma": sensor.sigma is not None,
            "max_spurious": k > 0,
            "ordering": bool(ordering),
            "max_range": sensor.max_range is not None,
            "min_range": sensor.min_range is not None,
            "fov": sensor.fov is not None,
            "p_miss": sensor.p_detect is not None,
            "clutter": sensor.clutter is not None,
            "clutter_by_detections": sensor.clutter_by_detections is not None,
        }
        used = [name for name, on in extras.items() if on]
        if used:
            raise InputError(
                f"method='paper' is the published algorithm and takes no {', '.join(used)}; "
                "use method='robust'"
            )
    return SearchOptions(
        sensor=sensor,
        m=m,
        max_wild=k,
        ordering=bool(ordering),
        merge=method is Method.ROBUST,
        budget=budget,
        decisive=float(decisive),
    )


@dataclass
class Counters:
    """What an engine did (see :class:`~omniloc.search.results.SearchStats`)."""

    nodes: int = 0
    examined: int = 0
    triples: int = 0
    existence: int = 0
    gate: int = 0
    ordering: int = 0
    visibility: int = 0
    bound: int = 0
    work: int = 0  #: the hypotheses kernel's units of work (a complete path costs more)


@dataclass
class Leaves:
    """The complete paths an engine found, and how its run ended.

    ``assign`` rows give, per level of the search (bearings in the engine's order, see
    ``order``), the landmark (-1: unmatched); ``pose`` rows the path's pose.
    """

    m: int
    order: IntArray
    assign: list[IntArray] = field(default_factory=list)
    pose: list[FloatArray] = field(default_factory=list)
    missed: list[IntArray] = field(default_factory=list)
    counts: Counters = field(default_factory=Counters)
    complete: bool = True
    exhaustive: bool = True
    started: float = field(default_factory=time.perf_counter)

    def add(self, assign: IntArray, pose: FloatArray, missed: IntArray | None = None) -> None:
        """Add complete paths (assignments in level order, poses) and, when the engine
        counted them, the plainly visible landmarks each leaves unseen."""
        if len(assign):
            self.assign.append(np.asarray(assign, dtype=np.int64))
            self.pose.append(np.asarray(pose, dtype=np.float64))
            if missed is not None:
                self.missed.append(np.asarray(missed, dtype=np.int64))

    def missed_counts(self) -> IntArray | None:
        """The engines' counts of landmarks left unseen for all paths (as :meth:`arrays`),
        or None when some engine did not count them."""
        if not self.missed or len(self.missed) != len(self.assign):
            return None
        return np.concatenate(self.missed)

    def arrays(self) -> tuple[IntArray, FloatArray]:
        """All paths as two arrays (K, m) and (K, 3)."""
        if not self.assign:
            return np.zeros((0, self.m), dtype=np.int64), np.zeros((0, 3))
        if len(self.assign) == 1:
            return self.assign[0], self.pose[0]
        return np.concatenate(self.assign), np.concatenate(self.pose)

    def time_left(self, timeout_s: float | None) -> float | None:
        """Seconds left of ``timeout_s`` since the search started (None: no limit)."""
        if timeout_s is None:
            return None
        return timeout_s - (time.perf_counter() - self.started)
