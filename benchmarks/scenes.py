"""The benchmark scenes: which maps, which poses, which observations, which localize options.

(a) the demo room (12 landmarks), the paper's pose and its 4-7 visible landmarks in random
    order, noise-free (like the paper) and with sigma = 0.2 deg;
(b) 30 random landmarks in a 40 m square, a robot whose range of 12 m takes in exactly 7 of
    them, + 3 spurious bearings, sigma = 0.5 deg; localize knows the range (and p_miss);
(b360) the same numbers without a range: 30 landmarks in a 20 m square, all in view, 7 of them
    reported + 3 spurious. Bearings alone cannot tell this apart -- some 1,500 poses explain 7
    of the 10 bearings as well as the truth does -- so it is timed, not scored;
(c) 10,000 landmarks uniform at 0.01 / m^2 (1 km square, 1 m apart at least), every landmark
    within 20 m observed plus 2 spurious bearings, sigma = 0.3 deg;
(c-grid) as (c) on 10,000 landmarks laid on a jittered grid (0.01 / m^2, at least 2 m apart):
    a warehouse of racks, where many poses see similar patterns; (c) and (c-grid) run twice,
    with the tuned options above and with localize's defaults (only sigma, max_spurious and
    max_range given);
(d) the same as (c) with 100,000 landmarks (3.16 km square).

Every trial draws its own observation (and for (b) its own map and pose) from a seed that
depends only on the scene and the trial number, so runs are repeatable.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from omniloc.maps import LandmarkMap
from omniloc.pose import Pose
from omniloc.simulate import (
    DEMO_POSE,
    DEMO_VISIBLE,
    Scene,
    demo_room,
    grid_map,
    observe,
    random_map,
)

__all__ = ["CASES", "GROUPS", "Case", "build_map", "make_trial"]

DEG = float(np.deg2rad(1.0))


@dataclass(frozen=True)
class Case:
    """One row of the benchmark.

    Attributes
    ----------
    name : str
        Row key, e.g. ``"a7"`` (demo room, 7 bearings, noise-free) or ``"a7n"`` (sigma 0.2 deg).
    group : str
        Scene letter ``a``-``d``.
    label : str
        Human description for the table.
    kwargs : dict
        Options for :func:`omniloc.search.localize` (besides the map and bearings).
    sigma : float
        Bearing noise of the simulation, radians.
    m : int or None
        Number of bearings when fixed (scene a), else None.
    scenes_of : str
        Draw the trials of this case instead (the same scenes under other options); empty:
        the case's own.
    """

    name: str
    group: str
    label: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    sigma: float = 0.0
    m: int | None = None
    scenes_of: str = ""


def _a_cases() -> list[Case]:
    out = []
    for noisy in (False, True):
        for m in (4, 5, 6, 7):
            sig = 0.2 * DEG if noisy else 0.0
            out.append(
                Case(
                    name=f"a{m}{'n' if noisy else ''}",
                    group="a",
                    label=f"demo room, {m} obs, " + ("sigma 0.2 deg" if noisy else "noise-free"),
                    kwargs={"sigma": sig} if noisy else {},
                    sigma=sig,
                    m=m,
                )
            )
    return out


CASES: dict[str, Case] = {c.name: c for c in _a_cases()}
CASES["b"] = Case(
    "b",
    "b",
    "30 random landmarks, 7 in 12 m range + 3 spurious obs, sigma 0.5 deg",
    {"sigma": 0.5 * DEG, "max_spurious": 3, "max_range": 12.0, "p_miss": 0.05},
    0.5 * DEG,
)
CASES["b360"] = Case(
    "b360",
    "b",
    "30 random landmarks all in view, 7 reported + 3 spurious, sigma 0.5 deg (ambiguous)",
    {"sigma": 0.5 * DEG, "max_spurious": 3},
    0.5 * DEG,
)
#: Large maps, tuned: the first interpretation that explains all but two bearings and leaves
#: no plainly visible landmark unexplained (beyond what p_miss allows) ends the search
#: (exhaustive=False); gates at 0.9999, since with max_spurious equal to the true count a
#: single real bearing outside its gate would sink the answer. (c-default) and
#: (cgrid-default) run the same trials with the default options.
LARGE_KWARGS: dict[str, Any] = {
    "sigma": 0.3 * DEG,
    "max_spurious": 2,
    "max_range": 20.0,
    "p_miss": 0.01,
    "confidence": 0.9999,
    "exhaustive": False,
}
CASES["c"] = Case(
    "c",
    "c",
    "10,000 landmarks at 0.01/m^2, all within 20 m + 2 spurious, sigma 0.3 deg",
    LARGE_KWARGS,
    0.3 * DEG,
)
CASES["cgrid"] = Case(
    "cgrid",
    "cgrid",
    "10,000 landmarks on a jittered grid (0.01/m^2, 2 m apart), all within 20 m + 2 spurious, "
    "sigma 0.3 deg",
    LARGE_KWARGS,
    0.3 * DEG,
)
#: What a user types for (c) and (c-grid): the scene's noise, spurious count and range, every
#: other option at its default (p_detect unknown, gates at 0.999, exhaustive=None: a first fit
#: on a map this large, which says it did not look for rivals).
DEFAULT_KWARGS: dict[str, Any] = {"sigma": 0.3 * DEG, "max_spurious": 2, "max_range": 20.0}
for _g in ("c", "cgrid"):
    CASES[f"{_g}-default"] = Case(
        f"{_g}-default",
        _g,
        f"the trials of ({_g}), localize's default options",
        DEFAULT_KWARGS,
        0.3 * DEG,
        scenes_of=_g,
    )
CASES["d"] = Case(
    "d",
    "d",
    "100,000 landmarks at 0.01/m^2, all within 20 m + 2 spurious, sigma 0.3 deg",
    LARGE_KWARGS,
    0.3 * DEG,
)
GROUPS: dict[str, list[str]] = {
    g: [c.name for c in CASES.values() if c.group == g] for g in ("a", "b", "c", "cgrid", "d")
}

#: Landmark counts and seeds of the large maps.
LARGE = {"c": (10_000, 10), "cgrid": (10_000, 12), "d": (100_000, 11)}
MAX_RANGE = 20.0
#: Scene (b): map side and sensor range, metres.
B_SIZE = 40.0
B_RANGE = 12.0
MIN_SEPARATION = 1.0
#: Scene (c-grid): landmarks of the jittered grid are at least this far apart, metres.
GRID_SEPARATION = 2.0


def build_map(group: str) -> LandmarkMap | None:
    """The fixed map of a group (None for (b), whose map changes with every trial)."""
    if group == "a":
        return demo_room()
    if group == "cgrid":
        n, seed = LARGE[group]
        return grid_map(n, density=0.01, min_separation=GRID_SEPARATION, rng=seed)
    if group in LARGE:
        n, seed = LARGE[group]
        return random_map(n, density=0.01, min_separation=MIN_SEPARATION, rng=seed)
    return None


def _interior_pose(lm: LandmarkMap, gen: np.random.Generator) -> Pose:
    """A pose at least MAX_RANGE from the map's border and 0.5 m from every landmark."""
    x0, y0, x1, y1 = lm.bounds
    for _ in range(1000):
        p = gen.uniform((x0 + MAX_RANGE, y0 + MAX_RANGE), (x1 - MAX_RANGE, y1 - MAX_RANGE))
        if lm.kdtree.query(p)[0] >= 0.5:
            return Pose(float(p[0]), float(p[1]), float(gen.uniform(-np.pi, np.pi)))
    raise RuntimeError("no free pose")


def make_trial(case: Case, trial: int, lm: LandmarkMap | None) -> tuple[LandmarkMap, Scene]:
    """The map and the simulated observation of one trial of a case."""
    gen = np.random.default_rng([ord(c) for c in (case.scenes_of or case.name)] + [trial])
    if case.group == "a":
        assert lm is not None and case.m is not None
        sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, n_obs=case.m, sigma=case.sigma, rng=gen)
        return lm, sc
    if case.name == "b":
        lm_b = random_map(30, size=B_SIZE, rng=gen)
        for _ in range(10_000):
            p = gen.uniform((0.0, 0.0), (B_SIZE, B_SIZE))
            r = np.hypot(*(lm_b.xy - p).T)
            if r.min() >= 0.5 and int((r <= B_RANGE).sum()) == 7:
                break
        else:
            raise RuntimeError("no pose sees exactly 7 landmarks")
        pose = Pose(float(p[0]), float(p[1]), float(gen.uniform(-np.pi, np.pi)))
        sc = observe(lm_b, pose, max_range=B_RANGE, n_spurious=3, sigma=case.sigma, rng=gen)
        return lm_b, sc
    if case.group == "b":
        lm_b = random_map(30, size=20.0, rng=gen)
        for _ in range(100):
            x0, y0, x1, y1 = lm_b.bounds
            p = gen.uniform((x0, y0), (x1, y1))
            if np.hypot(*(lm_b.xy - p).T).min() >= 0.5:
                break
        pose = Pose(float(p[0]), float(p[1]), float(gen.uniform(-np.pi, np.pi)))
        sc = observe(lm_b, pose, n_obs=7, n_spurious=3, sigma=case.sigma, rng=gen)
        return lm_b, sc
    assert lm is not None
    for _ in range(100):
        pose = _interior_pose(lm, gen)
        sc = observe(lm, pose, max_range=MAX_RANGE, n_spurious=2, sigma=case.sigma, rng=gen)
        if sc.bearings.size - sc.n_spurious >= 4:
            return lm, sc
    raise RuntimeError("no pose sees 4 landmarks")
