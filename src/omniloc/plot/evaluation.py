"""Figures for :mod:`omniloc.evaluate` results.

matplotlib is imported inside each function, and figures are plain
:class:`matplotlib.figure.Figure` objects rendered with the Agg canvas: no pyplot state, safe
without a display.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ._save import save_figure

if TYPE_CHECKING:
    from ..evaluate import DatasetResult, SweepResult
    from ..evaluate.common import Calibration

__all__ = [
    "plot_dataset_errors",
    "plot_reliability",
    "plot_rmse_vs_crlb",
    "plot_success_vs_noise",
]


def _figure(ncols: int = 1, width: float = 6.0) -> tuple[Any, list[Any]]:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width * ncols if ncols > 1 else width, 4.0), layout="constrained")
    axes = fig.subplots(1, ncols, squeeze=False)[0]
    return fig, list(axes)


def _save(fig: Any, path: str | Path) -> Path:
    return save_figure(fig, path)


def plot_success_vs_noise(result: SweepResult, path: str | Path) -> Path:
    """Success rate (solid) and true-pose-among-solutions rate (dashed) against bearing noise,
    one line per (map, N, m, spurious, miss) condition; one panel per map kind."""
    kinds = sorted({r.map_kind for r in result.rows})
    fig, axes = _figure(len(kinds), 5.0)
    for ax, kind in zip(axes, kinds, strict=True):
        groups: dict[tuple[Any, ...], list[Any]] = defaultdict(list)
        for r in result.rows:
            if r.map_kind == kind:
                groups[(r.map_size, r.n_obs, r.spurious_rate, r.miss_rate)].append(r)
        for i, (key, rows) in enumerate(sorted(groups.items())):
            rows.sort(key=lambda r: r.sigma_deg)
            x = [r.sigma_deg for r in rows]
            color = f"C{i % 10}"
            label = f"N={key[0]} m={key[1]} spur={key[2]:.0%} miss={key[3]:.0%}"
            ax.plot(x, [r.success_rate for r in rows], "o-", color=color, label=label)
            ax.plot(x, [r.in_solutions_rate for r in rows], "x--", color=color, alpha=0.6)
        ax.set_title(f"{kind} map ({result.config.name})")
        ax.set_xlabel("bearing noise sigma (deg)")
        ax.set_ylabel("rate (solid: best correct, dashed: among solutions)")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, loc="lower left")
    return _save(fig, path)


def _pooled(result: SweepResult, attr: str, kind: str) -> tuple[list[float], list[float]]:
    by_sigma: dict[float, list[float]] = defaultdict(list)
    for t in result.trials:
        if t.map_kind == kind:
            by_sigma[t.sigma_deg].append(getattr(t, attr))
    xs = sorted(by_sigma)
    ys = []
    for s in xs:
        a = np.asarray(by_sigma[s], dtype=np.float64)
        a = a[np.isfinite(a)]
        ys.append(float(np.sqrt(np.mean(a * a))) if a.size else math.nan)
    return xs, ys


def plot_rmse_vs_crlb(result: SweepResult, path: str | Path) -> Path:
    """Position RMSE of the refined and linear estimates (true correspondences) against
    sqrt(trace of the position CRLB), per noise level, pooled over each map kind's trials."""
    kinds = sorted({t.map_kind for t in result.trials})
    fig, axes = _figure(len(kinds), 5.0)
    for ax, kind in zip(axes, kinds, strict=True):
        for attr, style, label in (
            ("refined_pos_err_m", "o-", "refined (ML) RMSE"),
            ("linear_pos_err_m", "s--", "linear (eqs 1-6) RMSE"),
            ("crlb_pos_m", "k:", "sqrt(trace CRLB_pos), RMS"),
        ):
            xs, ys = _pooled(result, attr, kind)
            ax.plot(xs, ys, style, label=label)
        xs, ys = _pooled(result, "crlb_pos_m", kind)
        ax.plot(xs, [1.1 * y for y in ys], color="0.6", lw=0.8, label="1.1 x CRLB")
        ax.set_title(f"{kind} map ({result.config.name})")
        ax.set_xlabel("bearing noise sigma (deg)")
        ax.set_ylabel("position error (m)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return _save(fig, path)


def plot_dataset_errors(result: DatasetResult, path: str | Path) -> Path:
    """Histogram of the best solution's position error on a real dataset, beside the error of
    the refined pose from the true correspondences (oracle); tolerance marked."""
    fig, axes = _figure(2, 4.5)
    best = np.array([t.pos_err_m for t in result.trials], dtype=np.float64)
    orac = np.array([t.oracle_pos_err_m for t in result.trials], dtype=np.float64)
    hb = np.array([t.heading_err_deg for t in result.trials], dtype=np.float64)
    ho = np.array([t.oracle_heading_err_deg for t in result.trials], dtype=np.float64)
    for ax, (a, b, tol, unit) in zip(
        axes,
        (
            (best, orac, result.pos_tol_m, "position error (m)"),
            (hb, ho, result.heading_tol_deg, "heading error (deg)"),
        ),
        strict=True,
    ):
        a = a[np.isfinite(a)]
        b = b[np.isfinite(b)]
        hi = float(max(np.percentile(np.concatenate([a, b]), 99), 2 * tol)) if a.size else 1.0
        bins = np.linspace(0.0, hi, 40)
        ax.hist(np.clip(a, 0, hi), bins=bins, alpha=0.6, label="best solution")
        ax.hist(np.clip(b, 0, hi), bins=bins, alpha=0.6, label="true correspondences")
        ax.axvline(tol, color="k", ls=":", label="tolerance")
        ax.set_xlabel(unit)
        ax.set_ylabel("samples")
        ax.legend(fontsize=7)
    axes[0].set_title(f"{result.kind}: {result.n} samples")
    return _save(fig, path)


def plot_reliability(calibration: Calibration, path: str | Path, *, title: str = "") -> Path:
    """Reliability diagram: per confidence bin of the best solution, the fraction of cases in
    which it was correct against the bin's mean confidence (the diagonal is perfect
    calibration), with the number of cases per bin below and the expected calibration
    error in the title."""
    fig, axes = _figure(1, 5.0)
    ax = axes[0]
    c = calibration
    centres = 0.5 * (c.edges[:-1] + c.edges[1:])
    width = np.diff(c.edges)
    filled = c.counts > 0
    ax.plot([0, 1], [0, 1], color="0.6", ls="--", lw=1, label="perfect calibration")
    ax.bar(
        centres[filled],
        c.fraction_correct[filled],
        width=width[filled] * 0.9,
        alpha=0.6,
        label="fraction correct",
    )
    ax.plot(c.mean_confidence[filled], c.fraction_correct[filled], "o-", color="C3", label="by bin")
    for x, n in zip(centres[filled], c.counts[filled], strict=True):
        ax.annotate(str(int(n)), (x, 0.02), ha="center", fontsize=7, color="0.3")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("confidence of the best solution")
    ax.set_ylabel("fraction correct")
    ax.set_title(f"{title + ': ' if title else ''}expected calibration error {c.ece:.3f}")
    ax.legend(fontsize=7, loc="upper left")
    return _save(fig, path)
