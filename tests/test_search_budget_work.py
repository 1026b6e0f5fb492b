"""The search's work budget holds where one step can hold many paths (not a timed test: the
work the kernel counts is compared with the budget it was given)."""

from __future__ import annotations

from typing import Any

import pytest

import omniloc
import omniloc.search.hypotheses as hyp
from omniloc._kernels.hypotheses import LEAF_WORK, NODE_WORK
from omniloc.simulate import demo_room


def test_a_whole_map_range_stops_near_its_work_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    # A range that takes in the whole map: every landmark is a neighbour of every other and
    # one node's gate holds hundreds of complete paths. The kernel once checked its budget per
    # node only and spent 16x its work budget on such a node (25 s for a 2 s budget).
    calls: list[tuple[int, int]] = []
    kernel = hyp.hypotheses

    def counted(*args: Any) -> Any:
        out = kernel(*args)
        calls.append((int(args[-1].max_work), int(out[3].work)))
        return out

    monkeypatch.setattr(hyp, "hypotheses", counted)
    n = 20_000
    lm = omniloc.random_map(n, size=950.0, min_separation=0.0, rng=1)
    z = omniloc.predict_bearings(demo_room().xy[:5], omniloc.Pose(5.6, 2.1, 0.5))
    res = omniloc.localize(lm, z, max_range=3000.0, timeout_s=0.3)
    assert not res.complete
    limited = [(b, w) for b, w in calls if b > 0]
    assert limited
    # Past the budget by at most one step: a path (refined, then every landmark scanned),
    # a node, or a hypothesis's scans.
    slack = 4 * (n + LEAF_WORK + NODE_WORK)
    for budget, work in limited:
        assert work <= budget + slack, (budget, work)
