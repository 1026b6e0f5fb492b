"""The plain depth-first reading of the seed paper's section 3: the reference baseline.

A recursive Python depth-first search over ordered assignments of distinct landmarks to the
observations, in the observations' given order. Nothing is batched, cached or reordered:

* at every node the path's pairs go through the paper's own pose estimate,
  :func:`omniloc.pose.estimate_pose` (eqs. 1-6), from scratch;
* rule (i): at depth 3 a pose must exist -- ``estimate_pose`` raising
  :class:`~omniloc.errors.DegenerateGeometryError` (a distance ratio ``r_i <= 0``, a singular
  sum of ``P_i``, a robot at infinity) prunes the node;
* rule (ii): at depth > 3 the bearing of the new landmark predicted from the pose of the
  path's earlier pairs must satisfy ``|wrap(predicted - measured)| <= threshold``;
* a validated node re-estimates the pose from all its pairs for the nodes below it. When that
  re-estimate does not exist (``estimate_pose`` raises below depth 3, which the paper does not
  discuss) the node keeps its parent's pose and the event is counted in
  ``stats["reestimate_failed"]``;
* every complete path that survives is a solution: its assignment and its linear pose.

``nodes`` counts every child generated and tested, at any depth; ``examined_paths`` counts the
nodes at depth >= 4 (the paths traced more than three nodes deep, the paper's Table 1).

Run ``python benchmarks/plain_reading.py`` to print the paper's Table 1 for the demo room.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from omniloc.angles import wrap
from omniloc.errors import DegenerateGeometryError
from omniloc.pose import Pose, estimate_pose

__all__ = ["plain_localize"]


def plain_localize(
    landmarks_xy: ArrayLike,
    bearings: ArrayLike,
    threshold: float,
    *,
    timeout_s: float | None = None,
) -> tuple[list[tuple[tuple[int, ...], Pose]], dict[str, Any]]:
    """Interpretation-tree search exactly as the seed paper describes it, one node at a time.

    Parameters
    ----------
    landmarks_xy : array_like, shape (N, 2)
        The map, metres.
    bearings : array_like, shape (m,)
        Observed bearings in the robot frame, radians, searched in the order given. m >= 3.
    threshold : float
        Rule (ii) tolerance on ``|wrap(predicted - measured)|``, radians.
    timeout_s : float, optional
        Wall-clock budget (for the benchmark); past it the search stops and
        ``stats["complete"]`` is False.

    Returns
    -------
    solutions : list of (assignment, Pose)
        Every consistent complete path in depth-first order: the landmark index of each
        observation and the linear pose (eqs. 1-6) from all m pairs.
    stats : dict
        ``total_paths`` (N! / (N - m)!), ``examined_paths``, ``nodes``, ``triples_solved``,
        ``pruned_existence`` (rule i), ``pruned_gate`` (rule ii), ``reestimate_failed``,
        ``complete`` and ``elapsed_s``.

    Examples
    --------
    >>> from omniloc.pose import predict_bearings
    >>> L = np.array([[0, 0], [6, 0], [6, 4], [0, 4], [3, 7], [-2, 2]], dtype=float)
    >>> z = predict_bearings(L[[1, 4, 0, 2]], Pose(2.0, 1.5, 0.4))
    >>> sols, stats = plain_localize(L, z, np.deg2rad(1.0))
    >>> [a for a, _ in sols]
    [(1, 4, 0, 2)]
    """
    L = np.asarray(landmarks_xy, dtype=np.float64)
    b = np.asarray(bearings, dtype=np.float64)
    n, m = L.shape[0], b.shape[0]
    if L.ndim != 2 or L.shape[1] != 2:
        raise ValueError(f"landmarks_xy must have shape (N, 2), got {L.shape}")
    if b.ndim != 1 or not 3 <= m <= n:
        raise ValueError(f"need 3 <= m <= N bearings, got m={m} with N={n}")
    thr = float(threshold)
    stats = {
        "total_paths": math.perm(n, m),
        "examined_paths": 0,
        "nodes": 0,
        "triples_solved": 0,
        "pruned_existence": 0,
        "pruned_gate": 0,
        "reestimate_failed": 0,
    }
    solutions: list[tuple[tuple[int, ...], Pose]] = []
    path: list[int] = []
    t0 = time.perf_counter()
    deadline = math.inf if timeout_s is None else t0 + timeout_s

    class _Stop(Exception):
        pass

    def visit(depth: int, pose: Pose | None) -> None:
        # ``depth`` is the depth of the children generated here (1-based); ``pose`` is the
        # estimate from the ``depth - 1`` pairs on the path (None above depth 3).
        beta = float(b[depth - 1])
        if depth == 3 and time.perf_counter() > deadline:
            raise _Stop
        for j in range(n):
            if j in path:
                continue
            stats["nodes"] += 1
            if depth >= 4:
                stats["examined_paths"] += 1
            new_pose = pose
            if depth == 3:
                stats["triples_solved"] += 1
                try:
                    new_pose = estimate_pose(L[[*path, j]], b[:3])
                except DegenerateGeometryError:
                    stats["pruned_existence"] += 1
                    continue
            elif depth > 3:
                assert pose is not None
                pred = math.atan2(L[j, 1] - pose.y, L[j, 0] - pose.x) - pose.theta
                if abs(float(wrap(pred - beta))) > thr:
                    stats["pruned_gate"] += 1
                    continue
                try:
                    new_pose = estimate_pose(L[[*path, j]], b[:depth])
                except DegenerateGeometryError:
                    stats["reestimate_failed"] += 1
                    new_pose = pose
            path.append(j)
            if depth == m:
                assert new_pose is not None
                solutions.append((tuple(path), new_pose))
            else:
                visit(depth + 1, new_pose)
            path.pop()

    try:
        visit(1, None)
        stats["complete"] = True
    except _Stop:
        stats["complete"] = False
    stats["elapsed_s"] = time.perf_counter() - t0
    return solutions, stats


def _main() -> int:
    from omniloc.simulate import DEMO_POSE, DEMO_VISIBLE, demo_room, observe

    lm = demo_room()
    print("| m | total paths | examined paths | nodes | solutions | time (s) |")
    print("|---|---|---|---|---|---|")
    for m in (4, 5, 6, 7):
        scene = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=m, rng=m)
        sols, st = plain_localize(lm.xy, scene.bearings, np.deg2rad(1.0))
        print(
            f"| {m} | {st['total_paths']} | {st['examined_paths']} | {st['nodes']} "
            f"| {len(sols)} | {st['elapsed_s']:.2f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(_main())
