"""Monte Carlo sweeps on synthetic scenes, and correspondence-free evaluation on real data.

* :func:`run_sweep` -- a grid of conditions (noise, spurious and missed rates, number of
  observations, map size and kind); per trial: draw a map and a pose, observe, run
  :func:`~omniloc.search.localize`, and compare with the truth, with the linear and refined
  estimates from the true correspondences, and with the Cramer-Rao bound
  (:func:`~omniloc.pose.crlb`).
* :func:`evaluate_dataset` -- the Roh and MRCLAM recordings with correspondences hidden.
* :func:`save_report` -- CSV + JSON + PNG figures for either result.

Success of a trial is defined once, here: the BEST solution lies within ``success_pos_m``
(0.1 m) and ``success_heading_deg`` (1 degree) of the true pose.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InputError, OmnilocError
from .maps import LandmarkMap
from .pose import Pose, crlb, estimate_pose, refine_pose
from .search import LocalizationResult, localize
from .simulate import make_map, observe, random_pose, visible_landmarks

__all__ = [
    "DatasetResult",
    "DatasetTrial",
    "SweepConfig",
    "SweepResult",
    "Trial",
    "evaluate_dataset",
    "run_sweep",
    "save_report",
]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None
NAN = float("nan")

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
        Landmarks of a ``random`` map (20 m square); ignored by the other kinds.
    map_kinds : tuple of str
        ``random``, ``room`` (the 12-landmark demo room) or ``symmetric`` (a 4 x 3 grid).
    trials : int
        Monte Carlo trials per condition.
    success_pos_m, success_heading_deg : float
        A trial succeeds when the best solution is within both of the true pose.
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


def _rms(x: Iterable[float]) -> float:
    a = np.asarray(list(x), dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a * a))) if a.size else NAN


def _aggregate(cond: Condition, trials: Sequence[Trial]) -> ConditionRow:
    t = np.array([r.time_s for r in trials])
    return ConditionRow(
        **asdict(cond),
        n_trials=len(trials),
        success_rate=float(np.mean([r.success for r in trials])),
        in_solutions_rate=float(np.mean([r.in_solutions for r in trials])),
        ambiguous_rate=float(np.mean([r.ambiguous for r in trials])),
        complete_rate=float(np.mean([r.complete for r in trials])),
        pos_rmse_m=_rms(r.pos_err_m for r in trials),
        heading_rmse_deg=_rms(r.heading_err_deg for r in trials),
        pos_rmse_success_m=_rms(r.pos_err_m for r in trials if r.success),
        refined_pos_rmse_m=_rms(r.refined_pos_err_m for r in trials),
        refined_heading_rmse_deg=_rms(r.refined_heading_err_deg for r in trials),
        linear_pos_rmse_m=_rms(r.linear_pos_err_m for r in trials),
        linear_heading_rmse_deg=_rms(r.linear_heading_err_deg for r in trials),
        crlb_pos_m=_rms(r.crlb_pos_m for r in trials),
        crlb_heading_deg=_rms(r.crlb_heading_deg for r in trials),
        time_median_s=float(np.median(t)),
        time_p95_s=float(np.percentile(t, 95)),
    )


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)


def _write_csv(path: Path, records: Sequence[Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        if not records:
            return
        w = csv.writer(fh)
        names = [f.name for f in fields(records[0])]
        w.writerow(names)
        for r in records:
            w.writerow([getattr(r, n) for n in names])


def _jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _table(records: Sequence[Any], cols: Sequence[tuple[str, str]]) -> str:
    head = [h for _, h in cols]
    body = [[_fmt(getattr(r, c)) for c, _ in cols] for r in records]
    widths = [
        max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)
    ]
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths, strict=True)) for b in body]
    return "\n".join(lines)


@dataclass(frozen=True)
class SweepResult:
    """What :func:`run_sweep` measured: per-condition ``rows`` and per-trial ``trials``."""

    config: SweepConfig
    rows: list[ConditionRow]
    trials: list[Trial]
    elapsed_s: float = 0.0

    def to_csv(self, path: str | Path, *, trials_path: str | Path | None = None) -> None:
        """Write the per-condition rows (and, if asked, the trials) as CSV."""
        _write_csv(Path(path), self.rows)
        if trials_path is not None:
            _write_csv(Path(trials_path), self.trials)

    def to_json(self, path: str | Path) -> None:
        """Write config, rows and trials as JSON (NaN as null)."""
        data = {
            "config": asdict(self.config),
            "elapsed_s": self.elapsed_s,
            "rows": [{k: _jsonable(v) for k, v in asdict(r).items()} for r in self.rows],
            "trials": [{k: _jsonable(v) for k, v in asdict(t).items()} for t in self.trials],
        }
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(data, indent=1))

    def summary(self) -> str:
        """A plain-text table of the per-condition rows."""
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
        return (
            f"sweep {self.config.name}: {len(self.trials)} trials in {self.elapsed_s:.1f} s; "
            f"success = best within {self.config.success_pos_m} m and "
            f"{self.config.success_heading_deg} deg\n" + _table(self.rows, cols)
        )


# --------------------------------------------------------------------------------------------
# One trial
# --------------------------------------------------------------------------------------------


def _known_pairs(
    lm: LandmarkMap,
    bearings: FloatArray,
    assignment: Sequence[int | None],
    pose: Pose,
    sigma: float,
) -> tuple[float, float, float, float, float, float]:
    """Errors of the linear and refined estimates from the true pairs, and the CRLB."""
    keep = [i for i, a in enumerate(assignment) if a is not None]
    if len(keep) < 3:
        return (NAN,) * 6
    L = lm.xy[[int(a) for a in assignment if a is not None]]
    b = bearings[keep]
    out = [NAN] * 6
    try:
        lin = estimate_pose(L, b)
        d = lin.distance_to(pose)
        out[0], out[1] = d[0], math.degrees(d[1])
        ref, _ = refine_pose(L, b)
        d = ref.distance_to(pose)
        out[2], out[3] = d[0], math.degrees(d[1])
    except OmnilocError:
        pass
    try:
        # The bound scales linearly with sigma; sigma = 0 gives a zero bound.
        C = crlb(L, pose, 1.0)
        out[4] = sigma * math.sqrt(max(C[0, 0] + C[1, 1], 0.0))
        out[5] = math.degrees(sigma * math.sqrt(max(C[2, 2], 0.0)))
    except OmnilocError:
        pass
    return tuple(out)  # type: ignore[return-value]


def _match(res: LocalizationResult, pose: Pose, pos_tol: float, hdg_tol: float) -> list[bool]:
    return [
        d[0] <= pos_tol and d[1] <= hdg_tol
        for d in (s.pose.distance_to(pose) for s in res.solutions)
    ]


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
    lm = make_map(cond.map_kind, cond.map_size, rng=gen)
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
            lm = make_map(cond.map_kind, cond.map_size, rng=gen)
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
    known = _known_pairs(lm, scene.bearings, scene.assignment, pose, sigma)
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
    good = _match(res, pose, pos_tol, hdg_tol)
    best = res.best
    err = best.pose.distance_to(pose) if best is not None else (NAN, NAN)
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
        time_s=dt,
    )


def _run_chunk(args: tuple[SweepConfig, list[tuple[Condition, int, int]]]) -> list[Trial]:
    cfg, jobs = args
    return [_run_trial(cfg, c, k, s) for c, k, s in jobs]


def _progress(total: int, enabled: bool, desc: str) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=not (enabled and sys.stderr.isatty()))


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
    bar = _progress(len(jobs), progress, f"sweep {config.name}")
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


# --------------------------------------------------------------------------------------------
# Real data
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DatasetTrial:
    """One real sample localized without correspondences (errors in metres and degrees)."""

    source: str
    n_bearings: int
    n_spurious: int
    n_solutions: int
    best_ok: bool
    in_solutions: bool
    true_assignment_found: bool
    ambiguous: bool
    complete: bool
    pos_err_m: float
    heading_err_deg: float
    oracle_pos_err_m: float
    oracle_heading_err_deg: float
    oracle_ok: bool
    best_near_oracle: bool
    oracle_in_solutions: bool
    time_s: float


@dataclass(frozen=True)
class DatasetResult:
    """What :func:`evaluate_dataset` measured.

    ``best_rate``: the best solution is within tolerance of the ground truth;
    ``in_solutions_rate``: some solution is; ``assignment_rate``: some solution has exactly
    the true correspondences (spurious bearings as None); ``oracle_rate``: the refined pose
    from the TRUE correspondences is within tolerance (what any solver could reach at this
    tolerance); ``best_near_oracle_rate`` / ``oracle_in_solutions_rate``: the best / some
    solution is within tolerance of that oracle pose (judges the search alone, not the
    sensor's biases or the ground truth's placement errors).
    """

    kind: str
    options: dict[str, Any]
    pos_tol_m: float
    heading_tol_deg: float
    trials: list[DatasetTrial] = field(repr=False)
    elapsed_s: float = 0.0

    @property
    def n(self) -> int:
        return len(self.trials)

    def _rate(self, name: str) -> float:
        return float(np.mean([getattr(t, name) for t in self.trials])) if self.trials else NAN

    @property
    def best_rate(self) -> float:
        return self._rate("best_ok")

    @property
    def in_solutions_rate(self) -> float:
        return self._rate("in_solutions")

    @property
    def assignment_rate(self) -> float:
        return self._rate("true_assignment_found")

    @property
    def ambiguous_rate(self) -> float:
        return self._rate("ambiguous")

    @property
    def complete_rate(self) -> float:
        return self._rate("complete")

    @property
    def oracle_rate(self) -> float:
        return self._rate("oracle_ok")

    @property
    def best_near_oracle_rate(self) -> float:
        return self._rate("best_near_oracle")

    @property
    def oracle_in_solutions_rate(self) -> float:
        return self._rate("oracle_in_solutions")

    @property
    def time_median_s(self) -> float:
        return float(np.median([t.time_s for t in self.trials])) if self.trials else NAN

    @property
    def time_p95_s(self) -> float:
        return float(np.percentile([t.time_s for t in self.trials], 95)) if self.trials else NAN

    def as_dict(self) -> dict[str, Any]:
        """Aggregates as a plain dictionary."""
        return {
            "kind": self.kind,
            "n": self.n,
            "pos_tol_m": self.pos_tol_m,
            "heading_tol_deg": self.heading_tol_deg,
            "best_rate": self.best_rate,
            "in_solutions_rate": self.in_solutions_rate,
            "assignment_rate": self.assignment_rate,
            "ambiguous_rate": self.ambiguous_rate,
            "complete_rate": self.complete_rate,
            "oracle_rate": self.oracle_rate,
            "best_near_oracle_rate": self.best_near_oracle_rate,
            "oracle_in_solutions_rate": self.oracle_in_solutions_rate,
            "time_median_s": self.time_median_s,
            "time_p95_s": self.time_p95_s,
            "elapsed_s": self.elapsed_s,
            "options": self.options,
        }

    def to_csv(self, path: str | Path) -> None:
        """Write the per-sample records as CSV."""
        _write_csv(Path(path), self.trials)

    def to_json(self, path: str | Path) -> None:
        """Write aggregates and per-sample records as JSON (NaN as null)."""
        data = {k: _jsonable(v) for k, v in self.as_dict().items()}
        data["trials"] = [{k: _jsonable(v) for k, v in asdict(t).items()} for t in self.trials]
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(data, indent=1))

    def summary(self) -> str:
        """One plain-text paragraph of the aggregates."""
        d = self.as_dict()
        return (
            f"{self.kind}: {d['n']} samples in {self.elapsed_s:.1f} s, tolerance "
            f"{self.pos_tol_m} m / {self.heading_tol_deg} deg\n"
            f"  best solution correct   {d['best_rate']:.3f}\n"
            f"  true pose among sols    {d['in_solutions_rate']:.3f}\n"
            f"  true assignment found   {d['assignment_rate']:.3f}\n"
            f"  ambiguity reported      {d['ambiguous_rate']:.3f}\n"
            f"  search complete         {d['complete_rate']:.3f}\n"
            f"  oracle within tolerance {d['oracle_rate']:.3f}\n"
            f"  best near oracle pose   {d['best_near_oracle_rate']:.3f}\n"
            f"  oracle pose among sols  {d['oracle_in_solutions_rate']:.3f}\n"
            f"  time median / p95       {d['time_median_s']:.3f} s / {d['time_p95_s']:.3f} s"
        )


#: Solver options and tolerances per dataset (see docs/evaluation.md for the reasons).
DATASET_DEFAULTS: dict[str, dict[str, Any]] = {
    "roh": {
        "options": {"sigma": float(np.deg2rad(2.0)), "method": "robust", "timeout_s": 5.0},
        "pos_tol_m": 0.3,
        "heading_tol_deg": 10.0,
    },
    "mrclam": {
        "options": {
            "sigma": float(np.deg2rad(0.5)),
            "fov": float(np.deg2rad(67.0)),
            "max_range": 8.0,
            "timeout_s": 5.0,
        },
        "pos_tol_m": 0.3,
        "heading_tol_deg": 5.0,
    },
}


def _oracle_pose(lm: LandmarkMap, s: Any) -> Pose:
    """ML pose from the sample's TRUE correspondences (ground truth if that fails)."""
    pose: Pose = s.pose
    keep = [i for i, a in enumerate(s.assignment) if a is not None]
    try:
        rows = [int(a) for a in s.assignment if a is not None]
        return refine_pose(lm.xy[rows], s.bearings[keep])[0]
    except OmnilocError:
        return pose


def evaluate_dataset(
    kind: str,
    path: str | Path,
    *,
    max_samples: int | None = None,
    rng: RngLike = 0,
    progress: bool = True,
    options: dict[str, Any] | None = None,
    pos_tol_m: float | None = None,
    heading_tol_deg: float | None = None,
    include_robots: bool = True,
) -> DatasetResult:
    """Correspondence-free localization on a real recording.

    Parameters
    ----------
    kind : {"roh", "mrclam"}
    path : str or Path
        The dataset folder.
    max_samples : int, optional
        Use the first samples only.
    rng : Generator, int or None
        Shuffles the bearings of each sample.
    options : dict, optional
        Overrides of the :func:`~omniloc.search.localize` options in
        :data:`DATASET_DEFAULTS`. For MRCLAM ``max_spurious`` is the number of robot
        detections in the frame unless given here.
    pos_tol_m, heading_tol_deg : float, optional
        A solution is correct within these of the ground truth.
    include_robots : bool
        MRCLAM: add the other robots' bearings as spurious observations.

    Returns
    -------
    DatasetResult
    """
    from .datasets import load_mrclam, load_roh

    if kind not in DATASET_DEFAULTS:
        raise InputError(f"dataset kind must be 'roh' or 'mrclam', got {kind!r}")
    if max_samples is not None and max_samples < 1:
        raise InputError(f"max_samples must be >= 1, got {max_samples}")
    dflt = DATASET_DEFAULTS[kind]
    opts: dict[str, Any] = {**dflt["options"], **(options or {})}
    ptol = float(dflt["pos_tol_m"] if pos_tol_m is None else pos_tol_m)
    htol = float(dflt["heading_tol_deg"] if heading_tol_deg is None else heading_tol_deg)
    if kind == "roh":
        ds_r = load_roh(path)
        lm = ds_r.landmarks
        n_total = len(ds_r) if max_samples is None else min(len(ds_r), max_samples)
        samples = ds_r.samples(rng, max_samples=max_samples)
    else:
        ds_m = load_mrclam(path, include_robots=include_robots)
        lm = ds_m.landmarks
        n_total = len(ds_m) if max_samples is None else min(len(ds_m), max_samples)
        samples = ds_m.samples(rng, max_samples=max_samples)
    t_all = time.perf_counter()
    out: list[DatasetTrial] = []
    bar = _progress(n_total, progress, f"dataset {kind}")
    try:
        for s in samples:
            kw = dict(opts)
            kw.setdefault("max_spurious", s.n_spurious)
            t0 = time.perf_counter()
            res = localize(lm, s.bearings, **kw)
            dt = time.perf_counter() - t0
            good = _match(res, s.pose, ptol, math.radians(htol))
            best = res.best
            err = best.pose.distance_to(s.pose) if best is not None else (NAN, NAN)
            known = _known_pairs(lm, s.bearings, s.assignment, s.pose, 1.0)
            near = _match(res, _oracle_pose(lm, s), ptol, math.radians(htol))
            out.append(
                DatasetTrial(
                    source=s.source,
                    n_bearings=int(s.bearings.size),
                    n_spurious=s.n_spurious,
                    n_solutions=len(res),
                    best_ok=bool(good) and good[0],
                    in_solutions=any(good),
                    true_assignment_found=any(
                        sol.assignment == s.assignment for sol in res.solutions
                    ),
                    ambiguous=res.ambiguous,
                    complete=res.complete,
                    pos_err_m=err[0],
                    heading_err_deg=math.degrees(err[1]),
                    oracle_pos_err_m=known[2],
                    oracle_heading_err_deg=known[3],
                    oracle_ok=bool(known[2] <= ptol and known[3] <= htol),
                    best_near_oracle=bool(near) and near[0],
                    oracle_in_solutions=any(near),
                    time_s=dt,
                )
            )
            bar.update(1)
    finally:
        bar.close()
    return DatasetResult(kind, opts, ptol, htol, out, time.perf_counter() - t_all)


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def save_report(result: SweepResult | DatasetResult, out_dir: str | Path) -> list[Path]:
    """Write CSV, JSON and PNG figures of a result into ``out_dir``; return the paths.

    A sweep gives ``<name>_rows.csv``, ``<name>_trials.csv``, ``<name>.json``,
    ``<name>_success.png`` and ``<name>_rmse.png``; a dataset gives ``<kind>.csv``,
    ``<kind>.json`` and ``<kind>_errors.png``.
    """
    from . import plot_eval

    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    if isinstance(result, SweepResult):
        name = result.config.name
        paths = [d / f"{name}_rows.csv", d / f"{name}_trials.csv", d / f"{name}.json"]
        result.to_csv(paths[0], trials_path=paths[1])
        result.to_json(paths[2])
        paths.append(plot_eval.plot_success_vs_noise(result, d / f"{name}_success.png"))
        paths.append(plot_eval.plot_rmse_vs_crlb(result, d / f"{name}_rmse.png"))
        return paths
    if isinstance(result, DatasetResult):
        paths = [d / f"{result.kind}.csv", d / f"{result.kind}.json"]
        result.to_csv(paths[0])
        result.to_json(paths[1])
        paths.append(plot_eval.plot_dataset_errors(result, d / f"{result.kind}_errors.png"))
        return paths
    raise InputError(f"save_report takes a SweepResult or a DatasetResult, got {type(result)}")
