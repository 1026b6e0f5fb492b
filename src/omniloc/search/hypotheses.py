"""Hypothesise and verify: the search for wildcards, chi-square gates and large maps.

Every landmark triple that can be seen together starts a hypothesis for a few *seed* triples
of bearings (:mod:`.seeds`: whichever ``max_spurious`` bearings are spurious, one seed is
clean), and the hypothesis is verified on the other bearings depth first -- each matched to
every landmark inside its gate, the pose and covariance taking it in with a Kalman update, or
left unmatched while the match count allows, as in the tree. The compiled kernel is
:func:`omniloc._kernels.hypotheses.hypotheses`; this module prepares its inputs (seeds, pair
limits, neighbour lists, the cost its buffer ranks by), runs large maps in chunks on two
threads, turns a time budget into a budget of work, and polishes a first fit.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from concurrent.futures import Future, wait

import numpy as np
from numpy.typing import NDArray
from scipy.special import bdtr

from .. import _pools
from .._kernels import geometry as geo
from .._kernels.hypotheses import (
    Bearings,
    Budget,
    Gate,
    HypothesisCounts,
    Neighbours,
    Scoring,
    Seeds,
    Visibility,
    hypotheses,
)
from ..maps import LandmarkMap
from ..pose import SINGULAR_RTOL
from . import seeds as seeding
from .neighbours import expected_entries, neighbour_lists
from .options import Leaves, SearchOptions
from .scoring import evidence_model
from .tree import eps_f2

__all__ = ["run_hypotheses"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
KernelResult = tuple[IntArray, FloatArray, IntArray, HypothesisCounts]

log = logging.getLogger("omniloc.search")

#: Rate at which a time budget becomes a budget of work in the kernel (candidate landmarks
#: looked at, a verification node once per landmark near its hypothesis plus NODE_WORK, a
#: complete path LEAF_WORK; see omniloc._kernels.hypotheses).
HYPOTHESIS_WORK_PER_SECOND = 600_000_000

#: From a narrow seed (three bearings spanning less than seeds.WIDE_SPAN), the verification
#: relinearises (two Gauss-Newton steps and a fresh covariance, as the tree does at every
#: node) while a path has at most this many pairs, and uses one Kalman update per match
#: after that: such poses are far from linear at first (with a 67-degree field of view,
#: Kalman updates alone lost the true pose in 2 % more MRCLAM frames).
RELINEARISE = 4

#: Margins on the first-order bound of the kernel's cheap test before it verifies a
#: hypothesis: (wide seeds, narrow seeds) for an exhaustive search and for a first fit; 0
#: turns the test off. The bound is exact for a linear bearing function; poses from three
#: bearings are not (one seed pose was 4x off its linearised covariance). Measured against
#: the search without the test: with (4, 8), 1 of 977 scenes (scene b, random 12-30 landmark
#: maps with 2 spurious, all MRCLAM frames) lost one poorly fitting interpretation, never the
#: best; with (1.5, 3), 5 of 380. A first fit gives up completeness anyway and takes the
#: faster margin (scene c: 0.59 s median with it, 0.83 s with the exhaustive one, 1.08 s
#: without).
PRETEST_SLACK = {True: (4.0, 8.0), False: (1.5, 3.0)}

#: Bearings closer than this (radians) may compete for one landmark: the search tries each
#: of them as spurious even where a landmark fits (as the tree tries every bearing).
CONTESTED = float(np.deg2rad(25.0))

#: First landmarks per chunk of a large map's search, and threads that run chunks.
CHUNK_ANCHORS = 256
THREADS = 2

#: A first fit's polish fits at most this many assignments in one call (memory).
POLISH_BATCH = 65536

#: The kernel keeps at most this many complete paths (the best by its cost), twice what the
#: scoring refines and returns (search.scoring.MAX_LEAVES).
CAPACITY = 16000


#: Neighbour lists are built while they would hold at most this many entries (24 bytes
#: each): a range that spans most of a dense map makes nearly every landmark a neighbour of
#: every other, and the lists would only copy the map N times over.
MAX_NEIGHBOUR_ENTRIES = 20_000_000

#: HYPOTHESIS_WORK_PER_SECOND was fitted to gates up to about FITTED_GATE wide and to
#: neighbour lists. A wider gate, or a range whose lists were too large to build
#: (MAX_NEIGHBOUR_ENTRIES: every landmark of the map is tested at each step), costs more per
#: unit of work: at the full rate sigma=0.1 or 0.2 on 30 landmarks overran 0.5 s by 3-9x, and
#: 200,000 landmarks with max_range=3000 overran 2 s by 7x. A time budget is then converted at
#: a lower rate, down to COSTLY_WORK_RATE of it for a wide gate (stopping early is the safe
#: side of a budget), and at UNLISTED_WORK_RATE without lists, where a unit costs more as the
#: map grows (each step scans every landmark, out of cache: ~130 ns a unit on 200,000
#: landmarks, 80x the fitted rate). With the kernel's per-path budget check, a whole-map
#: range stops at 0.8 s on a 1 s budget (20,000 landmarks) and at 1.8 s on 2 s (200,000).
FITTED_GATE = float(np.deg2rad(2.0))
COSTLY_WORK_RATE = 0.1
UNLISTED_WORK_RATE = 0.01


def binomial_median(n: int, p: float) -> int:
    """The median of Binomial(``n``, ``p``): the smallest ``k`` whose distribution function
    reaches 1/2 (what ``scipy.stats.binom.ppf(0.5, n, p)`` gives, without importing
    ``scipy.stats``, most of a second at start-up). The function is taken to reach 1/2 within
    1e-12: at an exact tie (``p`` 1/2, ``n`` odd) ``bdtr`` rounds to just below it."""
    for k in range(n):
        if bdtr(k, n, p) >= 0.5 - 1e-12:
            return k
    return n


def _neighbours(lm: LandmarkMap, opt: SearchOptions) -> tuple[Neighbours, bool]:
    """Whom each landmark can be seen with: with a range, its neighbours within twice the
    range (the pose lies within range of the first landmark, so every landmark it sees lies
    within twice that of it); else, or when those lists would be huge, every other
    landmark. The flag tells whether the lists were built."""
    s = opt.sensor
    if (
        s.reach_max is not None
        and lm.n > 64
        and expected_entries(lm, 2.0 * s.reach_max) <= MAX_NEIGHBOUR_ENTRIES
    ):
        nb = neighbour_lists(lm, 2.0 * s.reach_max)
        return Neighbours(lm.xy, nb.ptr[:-1], nb.ptr[1:], nb.idx, nb.xy), True
    # In the list 0..N-1 written twice, the N - 1 entries after position i are all
    # landmarks but i.
    N = lm.n
    idx = np.tile(np.arange(N, dtype=np.int64), 2)
    lo = np.arange(1, N + 1, dtype=np.int64)
    return Neighbours(lm.xy, lo, lo + (N - 1), idx, np.ascontiguousarray(lm.xy[idx])), False


def _scoring(lm: LandmarkMap, opt: SearchOptions, n_seeds: int) -> Scoring:
    """The cost the kernel's buffer keeps the best paths by: minus the log evidence that
    search.scoring ranks by, without its pose-volume term (a bearing left unmatched costs
    what a match would have added; a plainly visible landmark missed, -ln(1 - p_detect));
    and the first fit's condition to stop: a fit decisive against the null interpretation at
    ``opt.decisive``, after a look-elsewhere allowance for the hypotheses of all ``n_seeds``
    seeds over the whole map (see omniloc._kernels.hypotheses._verify)."""
    ev = evidence_model(lm, opt.sensor, opt.max_wild)
    p = ev.prior
    margin = math.log(opt.decisive / (1.0 - opt.decisive))
    units = float(n_seeds * lm.n)
    return Scoring(
        ev.per_match,
        -ev.log_miss,
        ev.unknown_rate,
        ev.log_null,
        p.region,
        p.edge,
        p.log_volume,
        margin,
        units,
    )


def run_hypotheses(
    lm: LandmarkMap,
    beta: FloatArray,
    opt: SearchOptions,
    out: Leaves,
    *,
    stop_first: bool,
    max_work: int = 0,
) -> None:
    """Hypothesise and verify for bearings ``beta`` (observation order), into ``out``.

    Large maps are cut into chunks of first landmarks, run on two threads (the kernel
    releases the GIL); ``stop_first`` (a first fit) stops handing out chunks once one has an
    answer. ``opt.budget.max_nodes`` counts the nodes of every run into ``out``: a run
    spends what the earlier ones left (``out.complete`` is False when none is left), and so
    does ``max_work`` (units of work, see omniloc._kernels.hypotheses; 0: no limit), the
    budget the search gives a second look by default.
    """
    # A node budget bounds the whole search: what this run may spend is what earlier runs
    # into ``out`` (a first fit, a second look, an exhaustive search after either) left.
    max_nodes = 0
    if opt.budget.max_nodes is not None:
        max_nodes = opt.budget.max_nodes - out.counts.nodes
        if max_nodes <= 0:
            out.complete = False
            return
    work_cap = 0
    if max_work > 0:
        work_cap = max_work - out.counts.work
        if work_cap <= 0:
            out.complete = False
            return
    s = opt.sensor
    m = beta.shape[0]
    limits = seeding.pair_limits(beta, s.reach_max, s.reach_min, 2.0 * s.gate_width)
    triples = seeding.seed_triples(beta, opt.max_wild, limits)
    nb, listed = _neighbours(lm, opt)
    unlisted = s.reach_max is not None and lm.n > 64 and not listed
    if unlisted:
        rate = UNLISTED_WORK_RATE
    else:
        rate = max(COSTLY_WORK_RATE, min(1.0, FITTED_GATE / s.gate_width))
    miss_allow = m + lm.n
    if stop_first and s.p_detect is not None:
        # A first fit must not leave more plainly visible landmarks unseen than misses
        # typically explain: the median of Binomial(m, p_miss). The true interpretation with
        # more misses than that does not stop the search early but is still found (it costs
        # time, not the answer), while a generous allowance would let a wrong pose that hides
        # a landmark or two stop it (it did on a 100,000-landmark map).
        miss_allow = binomial_median(m, 1.0 - s.p_detect)
    # Poses from narrow seeds are far from linear: relinearise their first matches.
    relin = np.where(seeding.narrow(beta, triples), RELINEARISE, 0).astype(np.int64)
    wide, narrow = PRETEST_SLACK[not stop_first]
    # The bearings for which the wildcard is tried after a landmark fits (a first fit tries
    # it only where none does): every one, as the tree does, unless only the contested ones
    # are asked for (another bearing close enough to rob its landmark).
    if opt.contested_wildcards:
        near_pair = seeding.angle_between(beta) <= CONTESTED
        np.fill_diagonal(near_pair, False)
        wild_after_fit = near_pair.any(axis=1)
    else:
        wild_after_fit = np.ones(m, dtype=bool)
    bearings = Bearings(
        np.require(beta, np.float64, ["C"]), limits, np.ascontiguousarray(wild_after_fit)
    )
    gate = Gate(
        -1.0 if s.sigma is None else float(s.sigma),
        float(s.gate_chi2),
        float(s.threshold),
        np.require(opt.joint_chi2, np.float64, ["C"]),
        int(opt.min_match),
        SINGULAR_RTOL,
        eps_f2(lm),
    )
    vis = Visibility(
        np.inf if s.reach_max is None else s.reach_max**2,
        0.0 if s.reach_min is None else s.reach_min**2,
        np.inf if s.half_fov is None else float(s.half_fov),
        np.inf if s.plain_max is None else s.plain_max**2,
        0.0 if s.plain_min is None else s.plain_min**2,
    )
    scoring = _scoring(lm, opt, len(triples))

    def call(rows: slice, i0: int, i1: int, cap: tuple[int, int]) -> KernelResult:
        """One kernel run; ``cap`` = (nodes, work) it may spend, 0 for no limit."""
        seeds = Seeds(
            triples[rows], relin[rows], np.where(relin[rows] > 0, narrow, wide).astype(float)
        )
        budget = Budget(cap[0], cap[1], stop_first, miss_allow, CAPACITY)
        return hypotheses(nb, i0, i1, bearings, seeds, gate, vis, scoring, budget)

    if opt.budget.timeout_s is not None and not getattr(hypotheses, "signatures", True):
        # numba loads the kernel at its first call in a process (with a cold cache, a fresh
        # install or a kernel's source changed, it compiles it: tens of seconds). That is
        # not the search's time: a first call with a budget of one node, and the clock moved
        # on past it. Else a time budget spent it, and the first search of a process stopped
        # short of the same search run again (the tracker's first MRCLAM search covered one
        # of its two seeds in a fresh clone, and the whole run's states differed). A numba
        # kernel lists no compiled signatures before its first call; a stand-in without the
        # attribute is taken as loaded.
        t = time.perf_counter()
        call(slice(0, 1), 0, 1, (1, 0))
        out.started += time.perf_counter() - t
    if lm.n <= 4 * CHUNK_ANCHORS and opt.budget.timeout_s is None:
        results = [call(slice(None), 0, lm.n, (max_nodes, work_cap))]
    elif lm.n <= 4 * CHUNK_ANCHORS:
        # A time budget on a small map: a chunk per seed, so that the clock is read between
        # them (the work rate that stands in for it inside the kernel was fitted to narrow
        # gates; a wide one costs several times more per unit and overran 0.5 s by 3-7x).
        chunks = [(slice(r, r + 1), 0, lm.n) for r in range(len(triples))]
        results = _run_chunks(call, chunks, (max_nodes, work_cap), out, opt, rate)
    else:
        chunks = [
            (slice(r, r + 1), i0, min(i0 + CHUNK_ANCHORS, lm.n))
            for r in range(len(triples))
            for i0 in range(0, lm.n, CHUNK_ANCHORS)
        ]
        results = _run_chunks(call, chunks, (max_nodes, work_cap), out, opt, rate)
    if not results:
        # The time was up before the first chunk (a big map's neighbour lists took it).
        out.complete = False
        return
    found = any(len(r[0]) for r in results)
    _collect(lm, beta, results, out, opt, stop_first, miss_allow)
    if stop_first:
        # Whether or not it stopped, a first fit took shortcuts (below) that can lose a rival
        # interpretation: its verdict is never that of a search that looked at everything.
        out.exhaustive = False
    if stop_first and not found and out.complete:
        # A first fit takes shortcuts (a tighter cheap test, wildcards reserved in advance)
        # that can lose an interpretation the exhaustive search finds. Finding nothing is
        # rare and must not be a silent "no pose": search again, exhaustively.
        log.debug("localize: the first fit found nothing; searching exhaustively")
        out.exhaustive = True
        run_hypotheses(lm, beta, opt, out, stop_first=False, max_work=max_work)


def unique_rows(a: IntArray) -> tuple[IntArray, IntArray]:
    """``np.unique(a, axis=0, return_index=True)`` for a 2-D integer array, the same rows
    in the same (lexicographic) order with the index of each one's first occurrence, by a
    stable ``lexsort`` of the columns: three times faster than numpy's sort of the rows
    as structured values (the tracker's window searches reach a few thousand paths)."""
    order = np.lexsort(a.T[::-1])
    rows = a[order]
    new = np.ones(len(rows), dtype=bool)
    new[1:] = (rows[1:] != rows[:-1]).any(axis=1)
    return rows[new], order[new]


def _collect(
    lm: LandmarkMap,
    beta: FloatArray,
    results: list[KernelResult],
    out: Leaves,
    opt: SearchOptions,
    stop_first: bool,
    miss_allow: int,
) -> None:
    """Sum the kernel runs' counters and hand their complete paths to ``out``."""
    counts = [r[3] for r in results]
    c = out.counts
    c.nodes += sum(k.nodes for k in counts)
    c.examined += sum(k.examined for k in counts)
    c.triples += sum(k.triples for k in counts)
    c.existence += sum(k.pruned_existence for k in counts)
    c.gate += sum(k.pruned_gate for k in counts)
    c.visibility += sum(k.pruned_visibility for k in counts)
    c.bound += sum(k.pruned_bound for k in counts)
    c.work += sum(k.work for k in counts)
    stopped = max(k.stopped for k in counts)
    if any(k.stopped == 1 for k in counts):
        out.complete = False
    if stopped == 2:
        out.exhaustive = False
    assign = np.concatenate([r[0] for r in results])
    if len(assign) == 0:
        return
    pose = np.concatenate([r[1] for r in results])
    missed = np.concatenate([r[2] for r in results])
    if stopped == 2:
        # A first fit: what the other chunks in flight found counts only if it, too, is an
        # acceptable fit (the rest would rank below it on negative evidence anyway).
        fits = missed <= miss_allow
        assign, pose, missed = assign[fits], pose[fits], missed[fits]
    # One interpretation is often reached from several seeds.
    assign, first = unique_rows(assign)
    pose, missed = pose[first], missed[first]
    if stop_first:
        assign, pose = _polish(lm, beta, assign, pose, opt)
    if opt.ordering:
        from .tree import order_ok

        w = (assign >= 0).astype(np.float64)
        good = order_ok(
            lm.xy[np.maximum(assign, 0)],
            np.broadcast_to(beta, assign.shape),
            w,
            pose,
            2.0 * opt.sensor.gate_width,
        )
        c.ordering += int((~good).sum())
        assign, pose, missed = assign[good], pose[good], missed[good]
    # The kernel counted the landmarks each path leaves unseen where the scoring needs them
    # (a polished first fit keeps its set of landmarks): the scoring reuses the counts
    # rather than look at every landmark in range again for thousands of paths.
    out.add(assign, pose, missed)


def _polish(
    lm: LandmarkMap, beta: FloatArray, assign: IntArray, pose: FloatArray, opt: SearchOptions
) -> tuple[IntArray, FloatArray]:
    """Move a landmark to an unmatched bearing where that fits better (first fit).

    Verification takes bearings in a fixed order and gives each the best landmark in its
    gate, so a spurious bearing next to a true one can take the true one's landmark when the
    true one is checked first and falls just outside its gate. The exhaustive search also
    reaches the other interpretation (from another seed) and the ranking settles it; a first
    fit instead tries every such swap on the interpretation it stops at.
    """
    s = opt.sensor
    reach = 3.0 * math.sqrt(s.gate_chi2) * s.noise
    L = lm.xy
    assign, pose = assign.copy(), pose.copy()

    def fit(a: IntArray, start: FloatArray, iters: int) -> tuple[FloatArray, FloatArray]:
        """Gauss-Newton for many assignments at once (rows of ``a``), in slices."""
        p, sse = np.empty((len(a), 3)), np.empty(len(a))
        for k in range(0, len(a), POLISH_BATCH):
            rows = slice(k, k + POLISH_BATCH)
            p[rows], sse[rows] = geo.gauss_newton(
                np.ascontiguousarray(L[np.maximum(a[rows], 0)]),
                np.ascontiguousarray(np.broadcast_to(beta, a[rows].shape)),
                np.ascontiguousarray((a[rows] >= 0) * 1.0),
                np.ascontiguousarray(start[rows]),
                iters,
            )
        return p, sse

    # Every swap to try, (path, unmatched bearing u, matched bearing o) with u and o close
    # enough, in the order a loop over paths, then u, then o would take them: a first fit
    # that does not stop hands over every path it found (200,000 on scene c's second look,
    # 87 s in a Python loop per path), and all are fitted in a few batched calls.
    near = seeding.angle_between(beta) <= reach
    np.fill_diagonal(near, False)
    un = assign < 0
    k, u, o = np.nonzero(un[:, :, None] & near[None] & ~un[:, None, :])
    if len(k) == 0:
        return assign, pose
    paths = np.unique(k)
    _, sse0 = fit(assign[paths], pose[paths], 0)
    before = np.full(len(assign), np.inf)
    before[paths] = sse0
    alt = assign[k]
    at = np.arange(len(k))
    alt[at, u], alt[at, o] = assign[k, o], -1
    p2, sse2 = fit(alt, pose[k], 10)
    # Per path, the swap that fits best (the first of equals), if it beats the path itself.
    order = np.lexsort((at, sse2, k))
    best = order[np.r_[True, k[order][1:] != k[order][:-1]]]
    best = best[sse2[best] < before[k[best]]]
    assign[k[best]], pose[k[best]] = alt[best], p2[best]
    return assign, pose


def _work_left(out: Leaves, opt: SearchOptions) -> int:
    """The kernel cannot read the clock: what is left of ``timeout_s`` becomes work at
    HYPOTHESIS_WORK_PER_SECOND; 0 without a timeout, -1 when spent."""
    left = out.time_left(opt.budget.timeout_s)
    if left is None:
        return 0
    if left <= 0:
        return -1
    return max(1, int(min(left * HYPOTHESIS_WORK_PER_SECOND, 2**62)))


def _run_chunks(
    call: Callable[[slice, int, int, tuple[int, int]], KernelResult],
    chunks: list[tuple[slice, int, int]],
    caps: tuple[int, int],
    out: Leaves,
    opt: SearchOptions,
    rate: float = 1.0,
) -> list[KernelResult]:
    """Run chunks on a small thread pool (a single chunk in the caller's thread), in order;
    stop early on an answer (first fit), when the budget of nodes or work (``caps``, 0 for
    no limit) is spent (summed over chunks) or when the time is up (each chunk in flight may
    use what is left of it: they run side by side)."""
    results: list[KernelResult] = []
    max_nodes, max_work = caps
    spent = spent_work = 0

    def caps_now() -> tuple[int, int] | None:
        """(nodes, work) the next chunk may spend, None when the time is up."""
        work = _work_left(out, opt)
        work = max(1, int(work * rate)) if work > 0 else work
        if work < 0:
            out.complete = False
            return None
        if max_work:
            rest = max(1, max_work - spent_work)
            work = rest if work == 0 else min(work, rest)
        return (0 if max_nodes == 0 else max(1, max_nodes - spent), work)

    if len(chunks) == 1:
        # One chunk (one seed on a small map: no spurious bearing allowed): in this thread.
        # Starting a pool for it cost as much as the search itself (a7n with a time budget:
        # 1.25 ms against 0.66 ms without one).
        cap = caps_now()
        return [] if cap is None else [call(*chunks[0], cap)]
    workers = max(1, min(THREADS, _pools.CORES))
    # The calling thread's pool: starting two threads for each search cost a tracker's window
    # searches on MRCLAM 1 ms of their 18.
    pool = _pools.pool("omniloc-search", workers)
    pending: list[Future[KernelResult]] = []
    it = iter(chunks)
    done = False
    try:
        while True:
            while not done and len(pending) < workers:
                nxt = next(it, None)
                if nxt is None:
                    done = True
                    break
                cap = caps_now()
                if cap is None:
                    done = True
                    break
                pending.append(pool.submit(call, nxt[0], nxt[1], nxt[2], cap))
            if not pending:
                break
            r = pending.pop(0).result()
            results.append(r)
            spent += r[3].nodes
            spent_work += r[3].work
            if (
                r[3].stopped
                or (max_nodes and spent >= max_nodes)
                or (max_work and spent_work >= max_work)
            ):
                done = True
    finally:
        # A chunk that raised: the others still queued are dropped and those running waited
        # for (as leaving a pool of the call's own did), so none outlives the call.
        for f in pending:
            f.cancel()
        wait(pending)
    return results
