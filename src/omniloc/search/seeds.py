"""Seed triples for hypothesise-and-verify: which three bearings start the hypotheses.

With up to ``k`` spurious bearings among ``m``, a search that starts every hypothesis from
one fixed triple of bearings could start from a spurious one and miss the truth. It is
complete when its seed triples *cover* every possible set of spurious bearings: for each
``k``-subset of the bearings, some seed triple avoids it entirely (a Turan-type covering:
10 bearings with 3 spurious need 6 triples -- 8 when well-spread triples are preferred --
where the tree's wildcard levels start from all 20 triples of the first 6 bearings).

Seeds are chosen greedily, most newly covered spurious sets per unit of cost first, where
the cost of a triple estimates how many landmark triples it makes the search solve.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np
from numpy.typing import NDArray

from ..angles import TWO_PI
from ..errors import InputError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = [
    "angle_between",
    "gaps",
    "hypothesis_volume",
    "narrow",
    "pair_limits",
    "seed_triples",
    "spans",
    "triple_cost",
]

#: Span of three bearings (radians) below which a seed is thought poorly conditioned.
WIDE_SPAN = float(np.deg2rad(150.0))

#: Largest (number of triples) x (number of spurious sets) for the exact greedy cover.
MAX_GREEDY = 3_000_000

#: Most triples of bearings enumerated as candidates (C(m, 3): m = 182). More bearings choose
#: their seeds among m / 3 disjoint triples spread round the robot instead.
MAX_TRIPLES = 1_000_000

#: Most seed triples a search may need: more (many bearings, most of them possibly spurious)
#: are refused rather than allocated (1,000 bearings with max_spurious=0.99 would need 1.6e8).
MAX_SEEDS = 100_000

#: Verifying a hypothesis from a narrow seed costs about this many times one from a wide seed
#: (its cheap test has a wider margin and its first matches are relinearised): 1.5-2.5x,
#: measured per seed on scene c of the benchmarks.
NARROW_COST = 2.0

#: :func:`hypothesis_volume` of three bearings 120 degrees apart: sin(120 deg) x 1.5.
SPREAD_VOLUME = float(np.sin(np.deg2rad(120.0)) * 1.5)

#: Two bearings of a seed closer than this fix its pose poorly (the same noise moves it
#: far): such seeds pay steeply, as narrow ones do.
MIN_GAP = float(np.deg2rad(15.0))

#: Midpoints of a 6 x 6 x 6 grid on the unit cube: the ranges of a seed's three landmarks,
#: in units of max_range, for :func:`hypothesis_volume`.
_MID = (np.arange(6) + 0.5) / 6.0
_RANGES = np.stack(np.meshgrid(_MID, _MID, _MID, indexing="ij"), axis=-1).reshape(-1, 3)


def angle_between(bearings: FloatArray) -> FloatArray:
    """(m, m) unsigned angle between each two bearings, in [0, pi]."""
    d = np.mod(bearings[:, None] - bearings[None, :], TWO_PI)
    return np.asarray(np.minimum(d, TWO_PI - d))


def pair_limits(
    bearings: FloatArray, max_range: float | None, min_range: float | None, slack: float
) -> FloatArray:
    """(m, m) squared largest distance between two landmarks seen at two bearings.

    Both lie between ``min_range`` and ``max_range`` of the robot and subtend the angle
    between the bearings (widened by ``slack`` for noise), so by the law of cosines their
    distance is at most ``max(2 R sin(a / 2), sqrt(R^2 + r^2 - 2 R r cos a))``. Without a
    range every distance is possible (inf).
    """
    m = bearings.shape[0]
    if max_range is None:
        return np.full((m, m), np.inf)
    R = float(max_range)
    r = float(min_range or 0.0)
    a = np.minimum(angle_between(bearings) + slack, np.pi)
    d = np.maximum(2.0 * R * np.sin(0.5 * a), np.sqrt(R * R + r * r - 2.0 * R * r * np.cos(a)))
    return np.asarray((d * (1.0 + 1e-9) + 1e-9) ** 2)


def gaps(bearings: FloatArray, triples: IntArray) -> FloatArray:
    """(T, 3) circular gaps between the bearings of each triple, going round once."""
    s = np.sort(np.mod(bearings[triples], TWO_PI), axis=1)
    return np.asarray(np.diff(np.concatenate([s, s[:, :1] + TWO_PI], axis=1), axis=1))


def spans(bearings: FloatArray, triples: IntArray) -> FloatArray:
    """Angle each triple of bearings spans: 2 pi minus its largest circular gap."""
    return np.asarray(TWO_PI - gaps(bearings, triples).max(axis=1))


def narrow(bearings: FloatArray, triples: IntArray) -> NDArray[np.bool_]:
    """Whether each triple spans less than WIDE_SPAN (its pose is poorly conditioned)."""
    return np.asarray(spans(bearings, triples) < WIDE_SPAN)


def hypothesis_volume(bearings: FloatArray, triples: IntArray) -> FloatArray:
    """How many hypotheses each triple of bearings makes, relative to each other, on a map
    of uniformly spread landmarks seen within a range.

    A landmark triple (six coordinates) is the same thing as a pose (x, y, theta) and the
    three ranges r along the bearings' rays; the Jacobian of that change of variables is
    ``|r_a sin(b_c - b_b) + r_b sin(b_a - b_c) + r_c sin(b_b - b_a)|``. So the expected count
    of landmark triples whose pose exists and sees all three in range is the map's density
    cubed times the integral of that over the poses and the ranges in ``[0, R]^3``: up to a
    factor common to all triples, its mean over the unit cube (midpoint rule). Bearings
    close together make fewer: the count falls with the sines of their differences
    (measured on scene c, within 2 % of the count the search solves).

    Examples
    --------
    >>> b = np.deg2rad([0.0, 120.0, 240.0, 10.0])
    >>> v = hypothesis_volume(b, np.array([[0, 1, 2], [0, 3, 1]]))
    >>> bool(v[0] > v[1])
    True
    """
    s = np.sin(
        bearings[triples[:, [2, 0, 1]]] - bearings[triples[:, [1, 2, 0]]]
    )  # (T, 3): sin(b_c - b_b), sin(b_a - b_c), sin(b_b - b_a)
    return np.asarray(np.abs(_RANGES @ s.T).mean(axis=0))


def triple_cost(bearings: FloatArray, triples: IntArray, limits: FloatArray) -> FloatArray:
    """Relative work of starting from each triple of bearings (lower is cheaper).

    With a range, the search solves a number of hypotheses given by
    :func:`hypothesis_volume`, each dearer from a narrow seed (NARROW_COST). Without one
    every triple costs the same, and wider triples (better conditioned poses, tighter gates)
    are preferred by a small margin.
    """
    g = gaps(bearings, triples)
    # Three bearings within a narrow sector fix the pose poorly (the robot is outside the
    # triangle of their landmarks, often near its circumcircle): a pose metres off would
    # reject the true matches. Such seeds pay steeply below a span of WIDE_SPAN, and among
    # the rest the widest-spread are preferred by a small margin.
    span = TWO_PI - g.max(axis=1)
    short = np.maximum(0.0, (WIDE_SPAN - span) / WIDE_SPAN)
    quality = 1.0 + 100.0 * short**2 + 0.01 * (1.0 - g.min(axis=1) / (TWO_PI / 3.0))
    if np.isfinite(limits).all():
        # Fewer hypotheses come from worse-conditioned seeds (the volume is the Jacobian of
        # the pose), so the count decides only among wide seeds, two bearings close together
        # paying steeply. A narrow seed counts as a well-spread one, twice over, times the
        # areas its pair limits allow (the second landmark near the first, the third near
        # both) relative to the smallest: with a narrow field of view conditioning matters
        # more than the count (on MRCLAM, ranking narrow seeds by their count lost the truth
        # in 1.5-3 % more frames).
        a, b, c = triples[:, 0], triples[:, 1], triples[:, 2]
        close = np.maximum(0.0, (MIN_GAP - g.min(axis=1)) / MIN_GAP)
        wide = hypothesis_volume(bearings, triples) * (1.0 + 100.0 * close**2)
        areas = limits[a, b] * np.minimum(limits[a, c], limits[b, c]) / limits.min() ** 2
        work = np.where(span < WIDE_SPAN, NARROW_COST * SPREAD_VOLUME * areas, wide)
        return np.asarray(work * quality)
    return np.asarray(quality)


def _tightest_pair_first(triples: IntArray, limits: FloatArray) -> IntArray:
    """Reorder each triple so that its first two bearings have the smallest pair limit (the
    search takes the second landmark among the first's neighbours within that limit)."""
    out = triples.copy()
    for r, (a, b, c) in enumerate(triples.tolist()):
        pairs = [(limits[a, b], (a, b, c)), (limits[a, c], (a, c, b)), (limits[b, c], (b, c, a))]
        out[r] = min(pairs, key=lambda p: p[0])[1]
    return out


def seed_triples(bearings: FloatArray, max_wild: int, limits: FloatArray) -> IntArray:
    """Seed triples that avoid every possible set of ``max_wild`` spurious bearings.

    Parameters
    ----------
    bearings : ndarray, shape (m,)
        Measured bearings, m >= max_wild + 3.
    max_wild : int
        Largest number of spurious bearings.
    limits : ndarray, shape (m, m)
        Squared pair-distance limits (see :func:`pair_limits`), for the cost.

    Returns
    -------
    ndarray, shape (S, 3)
        Observation indices, cheapest first.

    Examples
    --------
    >>> b = np.linspace(-3.0, 3.0, 10)
    >>> seeds = seed_triples(b, 3, np.full((10, 10), np.inf))
    >>> len(seeds)
    8
    >>> import itertools
    >>> all(any(not set(t) & set(s) for t in seeds.tolist())
    ...     for s in itertools.combinations(range(10), 3))
    True
    """
    m = int(bearings.shape[0])
    k = int(max_wild)
    if m >= 3 * (k + 1) and math.comb(m, 3) > MAX_TRIPLES:
        # Too many bearings to weigh every triple: k + 1 of m / 3 disjoint triples, each
        # spread round the robot (every third bearing in angular order), cheapest first.
        spread = _spread_triples(bearings)
        pick = np.argsort(triple_cost(bearings, spread, limits), kind="stable")[: k + 1]
        return _tightest_pair_first(spread[pick], limits)
    if m < 3 * (k + 1) and math.comb(m, k) * math.comb(m, 3) > MAX_GREEDY:
        n_seeds = math.comb(k + 3, 3)
        if n_seeds > MAX_SEEDS:
            raise InputError(
                f"max_spurious={k} of {m} bearings would need {n_seeds:.3g} seed triples to "
                f"be sure one is clean (at most {MAX_SEEDS:,}): allow fewer spurious "
                "bearings, or give fewer bearings"
            )
    triples = _triples(m)
    cost = triple_cost(bearings, triples, limits)
    if k == 0:
        out = triples[[int(np.argmin(cost))]]
    elif math.comb(m, k) * len(triples) <= MAX_GREEDY:
        out = _greedy(m, k, triples, cost)
    elif m >= 3 * (k + 1):
        out = _disjoint(m, k, triples, cost)
    else:
        # Any k spurious bearings leave three of the first k + 3 clean.
        out = np.array(list(itertools.combinations(range(k + 3), 3)), dtype=np.int64)
    return _tightest_pair_first(out, limits)


def _spread_triples(bearings: FloatArray) -> IntArray:
    """m // 3 disjoint triples of bearings, each of every third bearing in angular order."""
    order = np.argsort(bearings, kind="stable")
    third = bearings.shape[0] // 3
    return np.stack([order[:third], order[third : 2 * third], order[2 * third : 3 * third]], 1)


@functools.lru_cache(maxsize=64)
def _triples(m: int) -> IntArray:
    """All triples of m bearings, in lexicographic order (read-only, cached)."""
    out = np.array(list(itertools.combinations(range(m), 3)), dtype=np.int64).reshape(-1, 3)
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=64)
def _avoids(m: int, k: int) -> NDArray[np.bool_]:
    """(triples, k-subsets): whether triple t avoids spurious set s (read-only, cached)."""
    one = np.int64(1)
    tmask = (one << _triples(m)).sum(axis=1)
    sets = np.array(list(itertools.combinations(range(m), k)), dtype=np.int64).reshape(-1, k)
    smask = (one << sets).sum(axis=1)
    out = (tmask[:, None] & smask[None, :]) == 0
    out.setflags(write=False)
    return out


def _greedy(m: int, k: int, triples: IntArray, cost: FloatArray) -> IntArray:
    """Greedy set cover: most uncovered spurious sets per unit cost, repeatedly."""
    avoid = _avoids(m, k)
    weight = _avoids_f(m, k)
    open_ = np.ones(avoid.shape[1])
    chosen: list[int] = []
    while open_.any():
        gain = weight @ open_  # uncovered sets each triple avoids
        t = int(np.argmax(gain / cost))
        chosen.append(t)
        open_[avoid[t]] = 0.0
    out = triples[chosen]
    return out[np.argsort(cost[chosen], kind="stable")]


@functools.lru_cache(maxsize=64)
def _avoids_f(m: int, k: int) -> FloatArray:
    """:func:`_avoids` as 0/1 floats, for a matrix product (read-only, cached)."""
    out = _avoids(m, k).astype(np.float64)
    out.setflags(write=False)
    return out


def _disjoint(m: int, k: int, triples: IntArray, cost: FloatArray) -> IntArray:
    """k + 1 disjoint triples, cheapest first: k spurious bearings spoil at most k of them."""
    free = np.ones(m, dtype=bool)
    chosen: list[int] = []
    for t in np.argsort(cost, kind="stable"):
        if free[triples[t]].all():
            chosen.append(int(t))
            free[triples[t]] = False
            if len(chosen) == k + 1:
                break
    return triples[chosen]
