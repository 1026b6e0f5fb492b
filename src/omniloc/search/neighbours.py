"""Which landmarks can be seen together: neighbour lists of a map, built once per radius.

With a range limit R, the landmarks a robot sees lie within R of it, so within 2R of each
other: the hypotheses search pairs each landmark only with its neighbours within 2R. The
lists are CSR arrays (memory linear in the number of neighbouring pairs, not N^2), built
from the map's k-d tree and kept for the last few radii of each map.
"""

from __future__ import annotations

import threading
import weakref
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..maps import LandmarkMap

__all__ = ["NeighbourLists", "expected_entries", "neighbour_lists"]

#: Radii kept per map.
KEEP = 4

_cache: weakref.WeakKeyDictionary[LandmarkMap, dict[float, NeighbourLists]]
_cache = weakref.WeakKeyDictionary()
_lock = threading.Lock()


class NeighbourLists(NamedTuple):
    """Landmarks within a radius of each landmark (itself excluded), as CSR lists: the
    neighbours of landmark ``i`` are ``idx[ptr[i]:ptr[i + 1]]``, in increasing order, at
    ``xy[ptr[i]:ptr[i + 1]]`` (their positions, contiguous for sequential reads)."""

    ptr: NDArray[np.int64]
    idx: NDArray[np.int64]
    xy: NDArray[np.float64]


def expected_entries(lm: LandmarkMap, radius: float, sample: int = 256) -> float:
    """About how many entries the neighbour lists of ``lm`` within ``radius`` hold (each pair
    twice), from the neighbour counts of an evenly spread sample of landmarks: what building
    them would cost in memory, before it is spent.

    Examples
    --------
    >>> lm = LandmarkMap([[0, 0], [1, 0], [5, 0]])
    >>> expected_entries(lm, 2.0), expected_entries(lm, 100.0)
    (2.0, 6.0)
    """
    x0, y0, x1, y1 = lm.bounds
    if radius >= float(np.hypot(x1 - x0, y1 - y0)):
        return float(lm.n) * (lm.n - 1)
    rows = np.unique(np.linspace(0, lm.n - 1, min(sample, lm.n)).astype(np.int64))
    counts = lm.kdtree.query_ball_point(lm.xy[rows], float(radius), return_length=True)
    return float(np.mean(np.asarray(counts) - 1)) * lm.n


def neighbour_lists(lm: LandmarkMap, radius: float) -> NeighbourLists:
    """The neighbour lists of ``lm`` within ``radius`` (built once, then cached).

    Examples
    --------
    >>> lm = LandmarkMap([[0, 0], [1, 0], [5, 0]])
    >>> nb = neighbour_lists(lm, 2.0)
    >>> nb.idx[nb.ptr[0]:nb.ptr[1]].tolist(), nb.idx[nb.ptr[2]:nb.ptr[3]].tolist()
    ([1], [])
    """
    key = float(radius)
    with _lock:
        per_map = _cache.setdefault(lm, {})
        found = per_map.get(key)
    if found is not None:
        return found
    pairs = lm.kdtree.query_pairs(key, output_type="ndarray").astype(np.int64)
    # Each pair both ways, as one number src * N + dst: sorted, they run by source, then by
    # neighbour (a fifth of the time of a lexsort of the two columns on dense maps).
    n = np.int64(lm.n)
    both = np.concatenate([pairs[:, 0] * n + pairs[:, 1], pairs[:, 1] * n + pairs[:, 0]])
    del pairs
    both.sort()
    ptr = np.zeros(lm.n + 1, dtype=np.int64)
    np.cumsum(np.bincount(both // n, minlength=lm.n), out=ptr[1:])
    idx = both % n
    del both
    lists = NeighbourLists(ptr, idx, np.ascontiguousarray(lm.xy[idx]))
    with _lock:
        if len(per_map) >= KEEP:
            per_map.pop(next(iter(per_map)))
        per_map[key] = lists
    return lists
