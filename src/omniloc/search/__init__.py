"""Correspondences and pose together from bearings alone (the seed paper's section 3).

Where each idea lives:

* :mod:`.tree` -- the interpretation tree, readable (rule (i) in ``_add_third``, rule (ii)
  and the chi-square gate in ``_add_checked`` / ``_sigma_gate``, the wildcard bound in
  ``_expand``, the ordering constraint), and the driver of its compiled walk;
* :mod:`.hypotheses` -- hypothesise and verify, for wildcards, chi-square gates and large
  maps (the compiled kernel is :mod:`omniloc._kernels.hypotheses`), with :mod:`.seeds`
  (which bearings start hypotheses) and :mod:`.neighbours` (which landmarks can be seen
  together);
* :mod:`.scoring` -- refinement, the joint test, ranking, merging and ambiguity;
* :mod:`.options` -- the options, checked at the door; :mod:`.results` -- what is returned.

:func:`localize` is the entry point.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..io import check_bearings
from ..maps import LandmarkMap, as_landmark_map
from ..sensor import IMPLAUSIBLE_NOISE, SensorModel
from .hypotheses import run_hypotheses
from .options import Budget, Leaves, SearchOptions, make_options
from .results import LocalizationResult, Method, SearchStats, Solution, Solutions, Strategy
from .scoring import DECISIVE, MAX_LEAVES, convincing, finish
from .tree import TreeSearch, robust_order, run_paper_kernel

__all__ = [
    "MAX_LEAVES",
    "Budget",
    "LocalizationResult",
    "Method",
    "SearchStats",
    "Solution",
    "Solutions",
    "Strategy",
    "localize",
]

log = logging.getLogger("omniloc.search")

#: Maps larger than this, searched without max_range or a budget, get DEFAULT_TIMEOUT_S.
LARGE_MAP = 1000

#: With ``exhaustive=None`` (the default), maps of more than this many landmarks searched with
#: a range stop at the first fit: on 10,000 landmarks the exhaustive search solves every
#: co-visible landmark triple for every seed (~15 million), about six times the work of a
#: first fit, whose answer was right in every measured scene (docs/evaluation.md). The answer
#: is then flagged ambiguous ("first fit: rivals not sought"); ``exhaustive=True`` buys a
#: decisive verdict.
AUTO_FIRST_FIT = 2000

#: The budget (seconds) of a search that nothing else bounds: a gate wider than
#: IMPLAUSIBLE_NOISE (``allow_wide=True``), which accepts nearly every pairing, or a map larger
#: than LARGE_MAP without ``max_range``, whose tree holds N^3 landmark triples per seed. The
#: result reports it (``stats.default_budget``) and the log says what to pass instead.
DEFAULT_TIMEOUT_S = 10.0


#: The second look (one more wildcard, after a first fit with nothing convincing) may spend
#: SECOND_LOOK_FACTOR times the work of the first fit and of the exhaustive search after it
#: if it found nothing (the hypotheses kernel's units, which track time where nodes do not:
#: a complete path costs more than a node), and at least SECOND_LOOK_FLOOR (~0.3 s), when
#: the caller gave no budget; with one, it spends what the caller's budget leaves.
#: Unbounded it took 43-199 s on scene c; where it found the truth it needed at most 0.97
#: of the first fit's work (docs/status.md, issue 16).
SECOND_LOOK_FACTOR = 2
SECOND_LOOK_FLOOR = 50_000_000


def second_look_allowance(first_work: int) -> int:
    """Units of work the second look may spend by default after a first fit of
    ``first_work``."""
    return max(SECOND_LOOK_FLOOR, SECOND_LOOK_FACTOR * first_work)


def second_look_note(spent: int, first_work: int, complete: bool) -> str:
    """What ``stats.default_budget`` says of a second look under its default budget."""
    bound = (
        f"{second_look_allowance(first_work):.2g} units of work, {SECOND_LOOK_FACTOR} x the "
        f"first fit's {first_work:.2g} (at least {SECOND_LOOK_FLOOR:.2g})"
    )
    if complete:
        return f"second look (one more unmatched bearing) within its default budget of {bound}"
    return (
        f"second look (one more unmatched bearing) stopped after {spent:.2g} units of work by "
        f"its default budget of {bound}: pass max_nodes or timeout_s to search further"
    )


def unbounded(lm: LandmarkMap, opt: SearchOptions) -> str:
    """Why nothing bounds a search ("" when its budget, range or gate does)."""
    if opt.budget.bounded:
        return ""
    s = opt.sensor
    noise = s.sigma if s.sigma is not None else s.threshold
    if noise > IMPLAUSIBLE_NOISE:
        name = "sigma" if s.sigma is not None else "threshold"
        return (
            f"{name}={math.degrees(noise):.1f} deg accepts nearly every pairing; pass a "
            "narrower one, or timeout_s or max_nodes"
        )
    if lm.n > LARGE_MAP and s.max_range is None:
        return (
            f"{lm.n} landmarks without max_range (about {float(lm.n) ** 3:.1e} landmark "
            "triples per seed); pass max_range, timeout_s or max_nodes"
        )
    return ""


def choose_engine(
    strategy: Strategy | str,
    method: Method,
    opt: SearchOptions,
    exhaustive: Any,
    n_landmarks: int = 0,
) -> str:
    """``"paper"`` (the compiled paper tree), ``"tree"`` (the readable tree), ``"hypotheses"``
    or ``"first"`` (hypotheses, stopping at the first fit). ``exhaustive=None`` chooses: a
    first fit for a robust search of more than AUTO_FIRST_FIT landmarks with a range."""
    try:
        strat = Strategy(strategy)
    except ValueError as exc:
        raise InputError(
            f"strategy must be one of {[s.value for s in Strategy]}, got {strategy!r}"
        ) from exc
    if exhaustive is None:
        large = n_landmarks > AUTO_FIRST_FIT and opt.sensor.max_range is not None
        exhaustive = not (large and method is Method.ROBUST and strat is not Strategy.TREE)
    if not isinstance(exhaustive, (bool, np.bool_)):
        raise InputError(f"exhaustive must be True, False or None (auto), got {exhaustive!r}")
    if method is Method.PAPER:
        if strat is Strategy.HYPOTHESES or not exhaustive:
            raise InputError(
                "method='paper' walks the paper's tree exhaustively; "
                "strategy='hypotheses' and exhaustive=False need method='robust'"
            )
        return "paper"
    if strat is Strategy.AUTO:
        if exhaustive and opt.paper_rules:
            return "paper"
        strat = Strategy.HYPOTHESES
    if strat is Strategy.TREE:
        if not exhaustive:
            raise InputError("exhaustive=False needs strategy='hypotheses' (or 'auto')")
        # The paper's rules alone: the compiled walk visits the same nodes, faster.
        return "paper" if opt.paper_rules else "tree"
    return "hypotheses" if exhaustive else "first"


def _refuse_out_of_view(b: NDArray[np.float64], sensor: SensorModel) -> None:
    """Raise InputError if a bearing lies outside the sensor's field of view by more than
    a gate's width (see ``localize``'s ``check_view``)."""
    half = sensor.half_fov
    if half is None:
        return
    out = np.flatnonzero(np.abs(b) > half + sensor.gate_width)
    if out.size:
        i = int(out[0])
        raise InputError(
            f"bearing {i} is {math.degrees(float(b[i])):.2f} deg, outside the field of view "
            f"(fov {math.degrees(2.0 * half):.4g} deg: -{math.degrees(half):.4g} to "
            f"+{math.degrees(half):.4g} deg about the forward axis; {out.size} of {b.size} "
            "bearings are outside it). Bearings are measured from the forward axis, "
            "counter-clockwise: bearings from one edge of the view (0 to fov) must be "
            "shifted by -fov/2."
        )


def localize(
    landmarks: LandmarkMap | ArrayLike,
    bearings: ArrayLike,
    sensor: SensorModel | None = None,
    *,
    budget: Budget | None = None,
    max_spurious: int | float = 0,
    ordering: bool = False,
    method: Method | str = Method.ROBUST,
    strategy: Strategy | str = Strategy.AUTO,
    exhaustive: bool | None = None,
    decisive: float = DECISIVE,
    threshold: float | None = None,
    sigma: float | None = None,
    confidence: float | None = None,
    max_range: float | None = None,
    min_range: float | None = None,
    fov: float | None = None,
    p_miss: float | None = None,
    p_detect: float | None = None,
    clutter: float | None = None,
    clutter_by_detections: Sequence[float] | None = None,
    mount: Sequence[float] | None = None,
    max_nodes: int | None = None,
    timeout_s: float | None = None,
    check_view: bool = True,
    contested_wildcards: bool = False,
) -> LocalizationResult:
    """Find where the robot is, and which landmark each bearing is, from bearings alone.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
        The known map, metres.
    bearings : array_like, shape (m,)
        Measured bearings in the robot frame, radians, counter-clockwise from forward.
        3 <= m <= N (at most N + max_spurious with wildcards).
    sensor : SensorModel, optional
        What the sensor measures and how well: bearing noise (or the paper's fixed
        threshold), field of view, range limits, detection probability, clutter. Default:
        the paper's sensor, a fixed 1-degree threshold and nothing else known. The keyword
        arguments ``threshold`` ... ``p_miss`` below build one instead (not both). A sensor
        with a ``mount`` off the robot's origin: the poses and covariances returned are the
        robot's (the bearings are the sensor's).
    budget : Budget, optional
        ``Budget(max_nodes=, timeout_s=)``: past it the search stops and returns what it
        has; ``result.complete`` is then False. (Or the keywords ``max_nodes``,
        ``timeout_s``.) The compiled engines cannot read the clock: a time becomes a budget
        of work at a rate fitted to measured times (see the README).
    max_spurious : int or float, default 0
        How many bearings may be spurious (not on the map): an int, or a fraction of m.
        Unmatched observations appear as None in :attr:`Solution.assignment`.
    ordering : bool, default False
        Prune paths whose landmarks go round the hypothesised pose in another cyclic order
        than the measured bearings (the paper's future work).
    method : {"robust", "paper"}
        ``"paper"`` is the published algorithm to the letter (see :class:`Method`).
    strategy : Strategy or {"auto", "tree", "hypotheses"}
        How the robust search runs. ``"tree"`` walks the interpretation tree with wildcard
        branches (the readable reference). ``"hypotheses"`` (compiled) starts a hypothesis
        from every landmark triple that can be seen together, for a few seed triples of
        bearings that together avoid every possible set of ``max_spurious`` spurious
        bearings, and verifies it on the other bearings, each matched to every landmark in
        its gate and also tried as spurious while the wildcards allow, as the tree does; it
        finds the same interpretations far faster when there are wildcards, a chi-square
        gate or a large map -- up to the gates, which follow the pose built up along each
        path: a true bearing at the edge of its gate may pass in one engine (or one order of
        the bearings) and not in the other (see the README's Limitations). ``"auto"``
        uses the compiled paper tree where the paper's rules alone apply, else
        ``"hypotheses"``. ``method="paper"`` always walks the tree.
    exhaustive : bool or None, default None
        False stops at the first interpretation that explains ``m - max_spurious`` bearings
        (and passes the joint test with ``sigma``; with ``p_miss``, leaves no more plainly
        visible landmarks unseen than the median of Binomial(m, p_miss)): much faster on large
        maps, but rival interpretations are not sought, so the answer is flagged
        ``ambiguous`` (``stats.exhaustive`` is False, ``stats.stopped`` says why). A first
        fit that finds nothing searches again exhaustively. None (default): a first fit on
        maps of more than AUTO_FIRST_FIT landmarks searched with a range, else True; when
        that first fit ends with nothing convincing (a real bearing outside its gate puts the
        truth out of reach when ``max_spurious`` equals the clutter), it looks once more,
        allowing one more unmatched bearing; without a budget of the caller's, that second
        look may spend SECOND_LOOK_FACTOR times the first fit's work (reported in
        ``stats.default_budget``; ``complete`` is False if it stopped it), with one, what
        that budget leaves. Needs the hypotheses strategy.
    decisive : float, default 0.95
        The answer is ``ambiguous`` unless the best solution holds at least this share of
        the posterior (see :mod:`omniloc.search.scoring`).
    threshold : float, default 1 degree
        Rule (ii): largest accepted ``|predicted - measured|`` bearing, radians, when
        ``sigma`` is not given.
    sigma : float, optional
        Bearing noise standard deviation, radians: a chi-square gate on the innovation
        (its variance includes the pose's uncertainty) instead of the fixed threshold.
    confidence : float, default 0.999
        Confidence level of the chi-square gates (see
        :attr:`omniloc.sensor.SensorModel.gate_confidence`).
    max_range, min_range : float, optional
        Sensor range limits, metres.
    fov : float, optional
        Full field of view in radians (e.g. 65 degrees).
    p_miss, p_detect : float, optional
        Probability that a plainly visible landmark is not detected, or that it is (give one
        of them): every plainly visible landmark not observed counts against a solution
        (negative evidence), and each match is scored with ``p_detect``. Neither but a
        ``max_range``: the rate is unknown and integrated out (uniform prior), so landmarks
        left unseen still count against a pose, as much as the bearings allow.
    clutter : float, optional
        Expected number of spurious bearings per frame (default: ``max_spurious``, at least
        0.5), spread over the field of view: what a bearing left unmatched costs.
    clutter_by_detections : sequence of float, optional
        The expected clutter per frame by the number of landmarks the frame reports (entry
        ``i`` for ``i + 1``), where clutter comes with the landmarks (see
        :class:`~omniloc.sensor.SensorModel`; measured by
        :func:`omniloc.evaluate.estimate_sensor`).
    mount : sequence of 3 floats, optional
        Where the sensor sits on the robot, ``(x, y, yaw)`` in the robot's frame (see
        :class:`~omniloc.sensor.SensorModel`): the poses returned are the robot's.
    max_nodes, timeout_s : optional
        The budget (see ``budget``). A search that nothing bounds -- a gate wider than 10
        degrees (``allow_wide``) or more than LARGE_MAP landmarks without ``max_range`` --
        gets ``timeout_s=DEFAULT_TIMEOUT_S``, reported in ``stats.default_budget``. A budget
        counts the whole call: a second look (see ``exhaustive``) and the exhaustive search
        after a first fit that finds nothing spend what is left of it.
    check_view : bool, default True
        With a field of view, refuse a bearing outside it (by more than a gate's width): it
        cannot come from this sensor, and most often means bearings measured from one edge
        of the view (0 to fov) instead of from the forward axis. False: bearings stacked
        from several frames of a turning robot (a tracker's window), which may lie outside
        one frame's view.
    contested_wildcards : bool, default False
        The hypotheses engine tries a bearing as spurious after every landmark that fits
        it, as the tree does. True: only where another bearing lies close by (it could rob
        that landmark) -- faster on scenes with many interpretations (b360: 1.2x), but a
        spurious bearing that falls inside a landmark's gate is then always taken as that
        landmark, and the interpretation that calls it clutter, which can be another pose
        metres away, is never scored: the answer may be called decisive without its rival.
        The tracker's searches use it (their candidates are weighed by the frames after,
        and their node budget went to sub-interpretations without it: on the five MRCLAM
        runs 1,406 frames localized and right and 3 wrong, against 1,567 and none).

    Returns
    -------
    LocalizationResult
        Falsy when no interpretation is consistent.

    Raises
    ------
    InputError
        Malformed map or bearings, or options out of range (the message names which).

    References
    ----------
    Lee & Chung, section 3 (rules i and ii); Grimson (1990) for the wildcard branch.

    Examples
    --------
    >>> from omniloc.pose import Pose, predict_bearings
    >>> L = np.array([[0, 0], [6, 0], [6, 4], [0, 4], [3, 7], [-2, 2]], dtype=float)
    >>> z = predict_bearings(L[[1, 4, 0, 2]], Pose(2.0, 1.5, 0.4))
    >>> result = localize(L, z)
    >>> result.best.assignment
    (1, 4, 0, 2)
    >>> round(result.best.pose.x, 6), round(result.best.pose.y, 6)
    (2.0, 1.5)
    """
    t0 = time.perf_counter()
    lm = as_landmark_map(landmarks)
    try:
        meth = Method(method)
    except ValueError as exc:
        raise InputError(
            f"method must be one of {[m.value for m in Method]}, got {method!r}"
        ) from exc
    b = check_bearings(bearings, n_landmarks=None, min_count=3)
    m = int(b.shape[0])
    legacy = {
        "threshold": threshold,
        "sigma": sigma,
        "confidence": confidence,
        "max_range": max_range,
        "min_range": min_range,
        "fov": fov,
        "p_miss": p_miss,
        "p_detect": p_detect,
        "clutter": clutter,
        "clutter_by_detections": clutter_by_detections,
        "mount": mount,
        "max_nodes": max_nodes,
        "timeout_s": timeout_s,
    }
    opt = make_options(
        m,
        method=meth,
        sensor=sensor,
        budget=budget,
        max_spurious=max_spurious,
        ordering=ordering,
        legacy=legacy,
        decisive=decisive,
    )
    for name, flag in (("check_view", check_view), ("contested_wildcards", contested_wildcards)):
        if not isinstance(flag, (bool, np.bool_)):
            raise InputError(f"{name} must be True or False, got {flag!r}")
    if check_view:
        _refuse_out_of_view(b, opt.sensor)
    if contested_wildcards:
        opt = dataclasses.replace(opt, contested_wildcards=True)
    if opt.min_match > lm.n:
        raise InputError(
            f"{m} bearings but the map has only {lm.n} landmarks"
            + (f" (with max_spurious={opt.max_wild})" if opt.max_wild else "")
        )
    why = unbounded(lm, opt)
    default_budget = ""
    if why:
        default_budget = f"timeout_s={DEFAULT_TIMEOUT_S:g} by default: {why}"
        log.warning("localize: %s", default_budget)
        opt = dataclasses.replace(opt, budget=Budget(timeout_s=DEFAULT_TIMEOUT_S))
    engine = choose_engine(strategy, meth, opt, exhaustive, lm.n)
    # The robust search looks at the bearings in ascending order, whatever order they come
    # in: its gates follow the pose built up along each path, and a true bearing at the edge
    # of its gate could pass in one order and not in another -- the same bearings would give
    # other answers. (The paper's method takes them as given, as the paper does.) The
    # assignments are returned in the caller's order.
    given_order: NDArray[np.intp] | None = None
    if meth is Method.ROBUST:
        perm = np.argsort(b, kind="stable")
        if (perm != np.arange(m)).any():
            given_order = np.argsort(perm, kind="stable")
            b = b[perm]
    # The robust tree starts with the best-spread triple; the paper's takes the given order.
    robust_tree = engine in ("paper", "tree") and meth is Method.ROBUST
    order = robust_order(b) if robust_tree else np.arange(m)
    leaves = Leaves(m, order, started=t0)
    if engine == "paper":
        run_paper_kernel(lm, b[order], opt, leaves)
    elif engine == "tree":
        TreeSearch(lm, b[order], opt, leaves).run()
    else:
        run_hypotheses(lm, b, opt, leaves, stop_first=engine == "first")
    scored = finish(lm, b, leaves, opt)
    if exhaustive is None and engine == "first" and leaves.complete and opt.min_match > 3:
        best = scored.solutions[0] if scored.solutions else None
        if best is None or not convincing(best.confidence, scored.unexplained, lm.n, opt):
            # On a large map the true interpretation, when within reach, explains most
            # bearings and is convincing; nothing convincing means it may be out of reach:
            # one real bearing outside its gate (1 in 1,000 per bearing) when max_spurious
            # equals the clutter. Look once more with one more bearing allowed unmatched
            # (c-grid, default options: 12 of 1,000 trials had the truth out of reach).
            log.debug("localize: nothing convincing; searching with one more wildcard")
            first = leaves.counts.work
            cap = 0
            if not opt.budget.bounded:
                # With one more wildcard, a first fit that does not stop goes through the
                # whole map again, and one that finds nothing searches it exhaustively (1e8
                # triples, minutes, on scene c): bounded by default.
                cap = first + second_look_allowance(first)
            wider = dataclasses.replace(opt, max_wild=opt.max_wild + 1)
            run_hypotheses(lm, b, wider, leaves, stop_first=True, max_work=cap)
            scored = finish(lm, b, leaves, opt)
            if cap:
                spent = leaves.counts.work - first
                default_budget = second_look_note(spent, first, leaves.complete)
                if not leaves.complete:
                    log.warning("localize: %s", default_budget)
    c = leaves.counts
    stats = SearchStats(
        total_paths=math.perm(lm.n, m) if m <= lm.n else 0,
        examined_paths=c.examined,
        nodes=c.nodes,
        elapsed_s=time.perf_counter() - t0,
        triples_solved=c.triples,
        pruned_existence=c.existence,
        pruned_gate=c.gate,
        pruned_ordering=c.ordering,
        pruned_visibility=c.visibility,
        pruned_bound=c.bound,
        complete=leaves.complete,
        exhaustive=leaves.exhaustive,
        stopped=(
            "budget"
            if not leaves.complete
            else ("first fit: rivals not sought" if not leaves.exhaustive else "")
        ),
        default_budget=default_budget,
    )
    solutions = scored.solutions
    if given_order is not None:
        solutions = solutions.with_columns(given_order)
    if opt.sensor.mount is not None and len(solutions):
        # The search finds the sensor's pose (the bearings are measured from it); the caller
        # asked for the robot's.
        solutions = solutions.with_poses(
            *opt.sensor.robot_poses(solutions.poses, solutions.covariances)
        )
    return LocalizationResult(
        solutions, stats, lm, scored.ambiguous, scored.unexplained, opt.sensor.mount
    )
