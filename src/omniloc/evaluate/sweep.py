"""Monte Carlo sweeps on synthetic scenes.

:func:`run_sweep` runs a grid of conditions (noise, spurious and missed rates, number of
observations, map size and kind); per trial it draws a map and a pose, observes, runs
:func:`~omniloc.search.localize`, and compares with the truth, with the linear and refined
estimates from the true correspondences, and with the Cramer-Rao bound
(:func:`~omniloc.pose.crlb`).

Success of a trial is defined once, here: the BEST solution lies within ``success_pos_m``
(0.1 m) and ``success_heading_deg`` (1 degree) of the true pose.
"""

from __future__ import annotations

import itertools
import json
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..maps import LandmarkMap
from ..pose import Pose
from ..search import localize
from ..simulate import make_map, observe, random_pose, visible_landmarks
from .common import (
    NAN,
    Calibration,
    calibration,
    jsonable,
    known_pairs_errors,
    matching_solutions,
    oracle_pose,
    progress_bar,
    rms,
    text_table,
    write_records_csv,
)

__all__ = [
    "Condition",
    "ConditionRow",
    "SweepConfig",
    "SweepResult",
    "Trial",
    "run_sweep",
    "sensor_range",
]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None

#: Sigma handed to the search when the simulated noise is exactly zero (radians): a tiny
#: positive value keeps the chi-square gate meaningful for round-off.
ZERO_NOISE_SIGMA = float(np.deg2rad(0.01))

#: Miss probability handed to the search with ``sensing="range"`` when the simulation itself
#: misses nothing (a small value: negative evidence without ruling a miss out).
RANGE_P_MISS = 0.05


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepConfig:
    """A grid of simulated conditions; every combination is run ``trials`` times.

    Attributes
    ----------
    name : str
    sigmas_deg : tuple of float
        Gaussian bearing noise standard deviations, degrees.
    spurious_rates : tuple of float
        Fraction of the ``n_obs`` observations that are spurious (rounded to a count).
    miss_rates : tuple of float
        Probability that each chosen landmark is not detected (fewer observations).
    n_obs : tuple of int
        Number of observations requested (true + spurious), capped by the map size.
    map_sizes : tuple of int
        Landmarks of a ``random`` map; ignored by the other kinds.
    map_square_m : float
        Side of a ``random`` map's square, metres (20 by default).
    map_kinds : tuple of str
        ``random``, ``room`` (the 12-landmark demo room) or ``symmetric`` (a 4 x 3 grid).
    trials : int
        Monte Carlo trials per condition.
    success_pos_m, success_heading_deg : float
        A trial succeeds when the best solution is within both of the true pose.
    correct_pos_m, correct_heading_deg : float
        The honesty figures' "correct" (0.3 m and 3 degrees): a best solution outside both is
        *wrong*, and ``confidently wrong`` when the answer was not ambiguous.
    timeout_s, max_nodes : optional
        Search budget per localization.
    sensing : {"chosen", "range"}
        Which landmarks the robot observes. ``chosen``: the true observations are drawn at
        random among every landmark in view (all of a map without walls), so nothing says
        which others the robot should have seen. ``range``: the robot observes exactly the
        landmarks within its sensor's range, a radius that holds the requested number of true
        observations on average at the map's density; poses are drawn until exactly that many
        are in range, and the search is told ``max_range`` and ``p_miss`` (the miss rate, or
        RANGE_P_MISS), so that a pose which should have seen more landmarks is penalised.
    confidence : float, optional
        The search's gate confidence (None: the library default, 0.99). With
        ``max_spurious`` equal to the true count every true bearing must pass its gate, so
        the truth is lost in about m (1 - confidence) of the trials.
    """

    name: str = "custom"
    sigmas_deg: tuple[float, ...] = (0.0, 0.5, 1.0)
    spurious_rates: tuple[float, ...] = (0.0,)
    miss_rates: tuple[float, ...] = (0.0,)
    n_obs: tuple[int, ...] = (6,)
    map_sizes: tuple[int, ...] = (12,)
    map_kinds: tuple[str, ...] = ("random",)
    trials: int = 20
    success_pos_m: float = 0.1
    success_heading_deg: float = 1.0
    correct_pos_m: float = 0.3
    correct_heading_deg: float = 3.0
    map_square_m: float = 20.0
    timeout_s: float | None = 5.0
    max_nodes: int | None = None
    sensing: str = "chosen"
    confidence: float | None = None

    def __post_init__(self) -> None:
        if self.confidence is not None and not 0.0 < self.confidence < 1.0:
            raise InputError(f"confidence must lie in (0, 1), got {self.confidence}")
        if self.sensing not in ("chosen", "range"):
            raise InputError(f"sensing must be 'chosen' or 'range', got {self.sensing!r}")
        if self.trials < 1:
            raise InputError(f"trials must be >= 1, got {self.trials}")
        for s in self.sigmas_deg:
            if not (math.isfinite(s) and s >= 0):
                raise InputError(f"sigmas_deg must be >= 0, got {s}")
        for r in (*self.spurious_rates, *self.miss_rates):
            if not 0.0 <= r < 1.0:
                raise InputError(f"spurious and miss rates must lie in [0, 1), got {r}")
        for n in self.n_obs:
            if n < 3:
                raise InputError(f"n_obs must be >= 3, got {n}")
        for k in self.map_kinds:
            if k not in ("random", "room", "symmetric"):
                raise InputError(f"map kind must be random, room or symmetric, got {k!r}")

    def with_trials(self, trials: int) -> SweepConfig:
        """The same grid with another number of trials per condition."""
        return replace(self, trials=int(trials))

    def conditions(self) -> list[Condition]:
        """The distinct conditions of the grid (map size collapses for fixed maps)."""
        out: list[Condition] = []
        seen: set[Condition] = set()
        for kind, size, n, sig, spur, miss in itertools.product(
            self.map_kinds,
            self.map_sizes,
            self.n_obs,
            self.sigmas_deg,
            self.spurious_rates,
            self.miss_rates,
        ):
            c = Condition(kind, size if kind == "random" else 12, n, sig, spur, miss)
            if c not in seen:
                seen.add(c)
                out.append(c)
        return out

    @classmethod
    def quick(cls) -> SweepConfig:
        """A few seconds: used by the tests and demos."""
        return cls(
            name="quick",
            sigmas_deg=(0.0, 1.0),
            spurious_rates=(0.0, 0.2),
            n_obs=(5,),
            map_kinds=("room",),
            trials=5,
            timeout_s=2.0,
        )

    @classmethod
    def default(cls) -> SweepConfig:
        """A few minutes on 2 cores: noise 0-3 degrees, 0-50 % spurious, misses, map kinds."""
        return cls(
            name="default",
            sigmas_deg=(0.0, 0.5, 1.0, 2.0, 3.0),
            spurious_rates=(0.0, 0.25, 0.5),
            miss_rates=(0.0,),
            n_obs=(8,),
            map_sizes=(12,),
            map_kinds=("random", "room", "symmetric"),
            trials=8,
            timeout_s=3.0,
        )

    @classmethod
    def targets_spurious(
        cls, trials: int = 250, sensing: str = "chosen", confidence: float | None = None
    ) -> SweepConfig:
        """Issue target: random maps of 12-30 landmarks, 8 observations of which 2 spurious,
        sigma 0.5 degrees; 4 map sizes x ``trials`` (default 1,000 trials in all).

        ``sensing="range"`` reads it with a range-limited sensor: the 6 true observations are
        the landmarks within range (see :class:`SweepConfig`)."""
        name = "targets_spurious" if sensing == "chosen" else "targets_spurious_range"
        if confidence is not None:
            name += f"_conf{confidence:g}"
        return cls(
            name=name,
            sensing=sensing,
            confidence=confidence,
            sigmas_deg=(0.5,),
            spurious_rates=(0.25,),
            n_obs=(8,),
            map_sizes=(12, 18, 24, 30),
            map_kinds=("random",),
            trials=trials,
            timeout_s=10.0,
        )

    @classmethod
    def targets_honest(cls, trials: int = 250) -> SweepConfig:
        """Honesty target: random maps of 12-30 landmarks in a 12 m square, the robot sees 6
        of them (chosen at random, 360 degrees, no range) plus 2 spurious bearings, sigma 0.5
        degrees, ``localize(map, b, sigma=..., max_spurious=2)``: 4 map sizes x ``trials``
        (1,000 by default). Few bearings among many landmarks: mostly ambiguous, and the
        answer must say so."""
        return cls(
            name="targets_honest_360",
            sigmas_deg=(0.5,),
            spurious_rates=(0.25,),
            n_obs=(8,),
            map_sizes=(12, 18, 24, 30),
            map_kinds=("random",),
            map_square_m=12.0,
            trials=trials,
            timeout_s=10.0,
        )

    @classmethod
    def targets_honest_room(cls, trials: int = 500) -> SweepConfig:
        """Honesty target: the demo room, 7 of the landmarks in view from random poses,
        noise-free and sigma 0.2 degrees (decisive and correct in >= 99 %)."""
        return cls(
            name="targets_honest_room",
            sigmas_deg=(0.0, 0.2),
            n_obs=(7,),
            map_kinds=("room",),
            trials=trials,
            timeout_s=5.0,
        )

    @classmethod
    def targets_crlb(cls, trials: int = 1000) -> SweepConfig:
        """Issue target: 8 correctly matched observations, sigma 1 degree; the refined
        estimate's position RMSE against 1.1 x sqrt(trace of the position CRLB)."""
        return cls(
            name="targets_crlb",
            sigmas_deg=(1.0,),
            spurious_rates=(0.0,),
            n_obs=(8,),
            map_sizes=(12,),
            map_kinds=("random",),
            trials=trials,
            timeout_s=5.0,
        )


@dataclass(frozen=True)
class Condition:
    """One cell of the sweep grid."""

    map_kind: str
    map_size: int
    n_obs: int
    sigma_deg: float
    spurious_rate: float
    miss_rate: float


@dataclass(frozen=True)
class Trial:
    """The outcome of one Monte Carlo trial (errors in metres and degrees; NaN when there is
    no estimate)."""

    map_kind: str
    map_size: int
    n_obs: int
    sigma_deg: float
    spurious_rate: float
    miss_rate: float
    trial: int
    seed: int
    n_true: int
    n_spurious: int
    solved: bool
    success: bool
    in_solutions: bool
    ambiguous: bool
    complete: bool
    n_solutions: int
    pos_err_m: float
    heading_err_deg: float
    correct: bool
    decisive: bool
    best_confidence: float
    oracle_in_solutions: bool
    linear_pos_err_m: float
    linear_heading_err_deg: float
    refined_pos_err_m: float
    refined_heading_err_deg: float
    crlb_pos_m: float
    crlb_heading_deg: float
    sensor_range_m: float
    time_s: float


@dataclass(frozen=True)
class ConditionRow:
    """Aggregates over the trials of one condition (RMSE over trials with an estimate)."""

    map_kind: str
    map_size: int
    n_obs: int
    sigma_deg: float
    spurious_rate: float
    miss_rate: float
    n_trials: int
    success_rate: float
    in_solutions_rate: float
    ambiguous_rate: float
    complete_rate: float
    correct_rate: float
    confidently_wrong_rate: float
    decisive_correct_rate: float
    oracle_in_solutions_rate: float
    ece: float
    pos_rmse_m: float
    heading_rmse_deg: float
    pos_rmse_success_m: float
    refined_pos_rmse_m: float
    refined_heading_rmse_deg: float
    linear_pos_rmse_m: float
    linear_heading_rmse_deg: float
    crlb_pos_m: float
    crlb_heading_deg: float
    time_median_s: float
    time_p95_s: float


def _aggregate(cond: Condition, trials: Sequence[Trial]) -> ConditionRow:
    t = np.array([r.time_s for r in trials])
    return ConditionRow(
        **asdict(cond),
        n_trials=len(trials),
        success_rate=float(np.mean([r.success for r in trials])),
        in_solutions_rate=float(np.mean([r.in_solutions for r in trials])),
        ambiguous_rate=float(np.mean([r.ambiguous for r in trials])),
        complete_rate=float(np.mean([r.complete for r in trials])),
        correct_rate=float(np.mean([r.correct for r in trials])),
        confidently_wrong_rate=float(np.mean([r.decisive and not r.correct for r in trials])),
        decisive_correct_rate=float(np.mean([r.decisive and r.correct for r in trials])),
        oracle_in_solutions_rate=float(np.mean([r.oracle_in_solutions for r in trials])),
        ece=calibration([r.best_confidence for r in trials], [r.correct for r in trials]).ece,
        pos_rmse_m=rms(r.pos_err_m for r in trials),
        heading_rmse_deg=rms(r.heading_err_deg for r in trials),
        pos_rmse_success_m=rms(r.pos_err_m for r in trials if r.success),
        refined_pos_rmse_m=rms(r.refined_pos_err_m for r in trials),
        refined_heading_rmse_deg=rms(r.refined_heading_err_deg for r in trials),
        linear_pos_rmse_m=rms(r.linear_pos_err_m for r in trials),
        linear_heading_rmse_deg=rms(r.linear_heading_err_deg for r in trials),
        crlb_pos_m=rms(r.crlb_pos_m for r in trials),
        crlb_heading_deg=rms(r.crlb_heading_deg for r in trials),
        time_median_s=float(np.median(t)),
        time_p95_s=float(np.percentile(t, 95)),
    )


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepResult:
    """What :func:`run_sweep` measured: per-condition ``rows`` and per-trial ``trials``."""

    config: SweepConfig
    rows: list[ConditionRow]
    trials: list[Trial]
    elapsed_s: float = 0.0

    def to_csv(self, path: str | Path, *, trials_path: str | Path | None = None) -> None:
        """Write the per-condition rows (and, if asked, the trials) as CSV."""
        write_records_csv(Path(path), self.rows)
        if trials_path is not None:
            write_records_csv(Path(trials_path), self.trials)

    def to_json(self, path: str | Path) -> None:
        """Write config, rows and trials as JSON (NaN as null)."""
        data = {
            "config": asdict(self.config),
            "elapsed_s": self.elapsed_s,
            "rows": [{k: jsonable(v) for k, v in asdict(r).items()} for r in self.rows],
            "trials": [{k: jsonable(v) for k, v in asdict(t).items()} for t in self.trials],
        }
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(data, indent=1))

    def calibration(self, bins: int = 10) -> Calibration:
        """Reliability of the best solution's confidence over every trial."""
        return calibration(
            [t.best_confidence for t in self.trials], [t.correct for t in self.trials], bins
        )

    def honesty(self) -> dict[str, float]:
        """Over every trial: correct, confidently wrong, decisive and correct, oracle among
        the solutions (rates) and the expected calibration error."""
        t = self.trials
        return {
            "correct_rate": float(np.mean([r.correct for r in t])),
            "confidently_wrong_rate": float(np.mean([r.decisive and not r.correct for r in t])),
            "decisive_correct_rate": float(np.mean([r.decisive and r.correct for r in t])),
            "oracle_in_solutions_rate": float(np.mean([r.oracle_in_solutions for r in t])),
            "ece": self.calibration().ece,
        }

    def summary(self) -> str:
        """A plain-text table of the per-condition rows, and the honesty figures."""
        cols = [
            ("map_kind", "map"),
            ("map_size", "N"),
            ("n_obs", "m"),
            ("sigma_deg", "sig"),
            ("spurious_rate", "spur"),
            ("miss_rate", "miss"),
            ("n_trials", "n"),
            ("success_rate", "success"),
            ("in_solutions_rate", "in_sols"),
            ("ambiguous_rate", "ambig"),
            ("confidently_wrong_rate", "conf_wrong"),
            ("decisive_correct_rate", "dec_ok"),
            ("oracle_in_solutions_rate", "oracle_in"),
            ("ece", "ece"),
            ("complete_rate", "complete"),
            ("pos_rmse_success_m", "pos_rmse_ok"),
            ("refined_pos_rmse_m", "refined"),
            ("linear_pos_rmse_m", "linear"),
            ("crlb_pos_m", "crlb_pos"),
            ("refined_heading_rmse_deg", "ref_hdg"),
            ("crlb_heading_deg", "crlb_hdg"),
            ("time_median_s", "t_med"),
            ("time_p95_s", "t_p95"),
        ]
        h = self.honesty()
        cfg = self.config
        return (
            f"sweep {cfg.name}: {len(self.trials)} trials in {self.elapsed_s:.1f} s; "
            f"success = best within {cfg.success_pos_m} m and "
            f"{cfg.success_heading_deg} deg\n" + text_table(self.rows, cols) + "\n"
            f"honesty (correct = best within {cfg.correct_pos_m} m and "
            f"{cfg.correct_heading_deg} deg): correct {h['correct_rate']:.3f}, confidently "
            f"wrong {h['confidently_wrong_rate']:.4f}, decisive and correct "
            f"{h['decisive_correct_rate']:.3f}, oracle among solutions "
            f"{h['oracle_in_solutions_rate']:.4f}, calibration error {h['ece']:.3f}"
        )


# --------------------------------------------------------------------------------------------
# One trial
# --------------------------------------------------------------------------------------------


def sensor_range(lm: LandmarkMap, n_true: int) -> float:
    """The radius that holds ``n_true`` landmarks on average at the map's density (bounding
    box area / landmarks), metres."""
    x0, y0, x1, y1 = lm.bounds
    area = max((x1 - x0) * (y1 - y0), 1e-12)
    return math.sqrt(n_true * area / (math.pi * lm.n))


def _range_pose(lm: LandmarkMap, n_true: int, gen: np.random.Generator) -> Pose | None:
    """A random pose with exactly ``n_true`` landmarks within :func:`sensor_range` (None if
    2,000 draws find none: a clustered map)."""
    r = sensor_range(lm, n_true)
    for _ in range(2000):
        pose = random_pose(lm, rng=gen)
        if int(lm.kdtree.query_ball_point((pose.x, pose.y), r, return_length=True)) == n_true:
            return pose
    return None


def _run_trial(cfg: SweepConfig, cond: Condition, k: int, seed: int) -> Trial:
    gen = np.random.default_rng(seed)
    lm = make_map(cond.map_kind, cond.map_size, rng=gen, size=cfg.map_square_m)
    n_obs = min(cond.n_obs, lm.n + round(cond.spurious_rate * cond.n_obs))
    n_spur = round(cond.spurious_rate * n_obs)
    n_real = min(n_obs - n_spur, lm.n)
    sigma = math.radians(cond.sigma_deg)
    rng_m = NAN
    search_kw: dict[str, Any] = {}
    chosen = None
    if cfg.confidence is not None:
        search_kw["confidence"] = cfg.confidence
    if cfg.sensing == "range" and n_real < lm.n:
        found = _range_pose(lm, n_real, gen)
        for _ in range(20):
            if found is not None or cond.map_kind != "random":
                break
            lm = make_map(cond.map_kind, cond.map_size, rng=gen, size=cfg.map_square_m)
            found = _range_pose(lm, n_real, gen)
        if found is None:
            raise InputError(f"no pose of the {cond.map_kind} map sees exactly {n_real} landmarks")
        pose, rng_m = found, sensor_range(lm, n_real)
        search_kw["max_range"] = rng_m
        search_kw["p_miss"] = cond.miss_rate if cond.miss_rate > 0 else RANGE_P_MISS
    else:
        pose = random_pose(lm, rng=gen)
        vis = visible_landmarks(lm, pose)
        chosen = gen.choice(vis, size=min(n_real, vis.size), replace=False)
    scene = observe(
        lm,
        pose,
        visible=chosen,
        max_range=search_kw.get("max_range"),
        sigma=sigma,
        n_spurious=n_spur,
        p_miss=cond.miss_rate,
        rng=gen,
    )
    n_true = len(scene.assignment) - scene.n_spurious
    known = known_pairs_errors(lm, scene.bearings, scene.assignment, pose, sigma)
    pos_tol, hdg_tol = cfg.success_pos_m, math.radians(cfg.success_heading_deg)
    base = dict(
        **asdict(cond),
        trial=k,
        seed=seed,
        n_true=n_true,
        n_spurious=scene.n_spurious,
        linear_pos_err_m=known[0],
        linear_heading_err_deg=known[1],
        refined_pos_err_m=known[2],
        refined_heading_err_deg=known[3],
        crlb_pos_m=known[4],
        crlb_heading_deg=known[5],
        sensor_range_m=rng_m,
    )
    if n_true < 3:
        # Too few true landmarks survived the misses: no pose can be right; a failure.
        return Trial(
            **base,
            solved=False,
            success=False,
            in_solutions=False,
            ambiguous=False,
            complete=True,
            n_solutions=0,
            pos_err_m=NAN,
            heading_err_deg=NAN,
            correct=False,
            decisive=False,
            best_confidence=0.0,
            oracle_in_solutions=False,
            time_s=0.0,
        )
    t0 = time.perf_counter()
    res = localize(
        lm,
        scene.bearings,
        sigma=max(sigma, ZERO_NOISE_SIGMA),
        max_spurious=scene.n_spurious,
        timeout_s=cfg.timeout_s,
        max_nodes=cfg.max_nodes,
        **search_kw,
    )
    dt = time.perf_counter() - t0
    good = matching_solutions(res, pose, pos_tol, hdg_tol)
    best = res.best
    err = best.pose.distance_to(pose) if best is not None else (NAN, NAN)
    c_pos, c_hdg = cfg.correct_pos_m, math.radians(cfg.correct_heading_deg)
    oracle = oracle_pose(lm, scene.bearings, scene.assignment) or pose
    return Trial(
        **base,
        solved=bool(res),
        success=bool(good) and good[0],
        in_solutions=any(good),
        ambiguous=res.ambiguous,
        complete=res.complete,
        n_solutions=len(res),
        pos_err_m=err[0],
        heading_err_deg=math.degrees(err[1]),
        correct=bool(best is not None and err[0] <= c_pos and err[1] <= c_hdg),
        decisive=bool(res) and not res.ambiguous,
        best_confidence=best.confidence if best is not None else 0.0,
        oracle_in_solutions=any(matching_solutions(res, oracle, c_pos, c_hdg)),
        time_s=dt,
    )


def _run_chunk(args: tuple[SweepConfig, list[tuple[Condition, int, int]]]) -> list[Trial]:
    cfg, jobs = args
    return [_run_trial(cfg, c, k, s) for c, k, s in jobs]


def run_sweep(
    config: SweepConfig, *, rng: RngLike = 0, progress: bool = True, workers: int = 1
) -> SweepResult:
    """Run a Monte Carlo sweep.

    Parameters
    ----------
    config : SweepConfig
        The grid (see the presets :meth:`SweepConfig.quick`, :meth:`SweepConfig.default`,
        :meth:`SweepConfig.targets_spurious`, :meth:`SweepConfig.targets_crlb`).
    rng : Generator, int or None
        Seeds every trial; the same value gives the same numbers (times aside), whatever
        ``workers`` is.
    progress : bool
        Show a tqdm bar on stderr (only when it is a terminal).
    workers : int
        Processes to spread the trials over (1: in this process).

    Returns
    -------
    SweepResult
    """
    gen = np.random.default_rng(rng)
    conds = config.conditions()
    seeds = gen.integers(0, 2**63 - 1, size=(len(conds), config.trials))
    jobs = [(c, k, int(seeds[i, k])) for i, c in enumerate(conds) for k in range(config.trials)]
    t0 = time.perf_counter()
    trials: list[Trial] = []
    bar = progress_bar(len(jobs), progress, f"sweep {config.name}")
    try:
        if workers <= 1:
            for c, k, s in jobs:
                trials.append(_run_trial(config, c, k, s))
                bar.update(1)
        else:
            from concurrent.futures import ProcessPoolExecutor

            size = max(1, min(config.trials, 10))
            chunks = [(config, jobs[i : i + size]) for i in range(0, len(jobs), size)]
            with ProcessPoolExecutor(max_workers=workers) as ex:
                for part in ex.map(_run_chunk, chunks):
                    trials.extend(part)
                    bar.update(len(part))
    finally:
        bar.close()
    rows = []
    for i, c in enumerate(conds):
        rows.append(_aggregate(c, trials[i * config.trials : (i + 1) * config.trials]))
    return SweepResult(config, rows, trials, time.perf_counter() - t0)
