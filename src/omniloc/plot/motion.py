"""The figure of a motion model checked against a ground truth
(:func:`~omniloc.track.check_motion`).

Left: each stretch's heading error (the truth's turn less the model's) over time, with the
band the model's 99 % region gives it; right: how often the squared errors in the model's
covariance stay below each value, for the position and the heading, against the chi-square
curves an honest model follows (a curve below its chi-square is a model too sure of the
odometry, one above it a model wider than it needs).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ._save import save_figure

if TYPE_CHECKING:
    from ..track.calibrate import MotionCheck

__all__ = ["plot_motion_check"]


def plot_motion_check(check: MotionCheck, path: str | Path, *, title: str | None = None) -> Path:
    """Draw a :class:`~omniloc.track.MotionCheck` and save it (the format from the
    extension).

    Parameters
    ----------
    check : MotionCheck
    path : str or Path
        Where to write the figure (folders are created).
    title : str, optional

    Returns
    -------
    Path
        The file written.
    """
    from matplotlib.figure import Figure
    from scipy.stats import chi2

    fig = Figure(figsize=(11.0, 4.0), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=(1.6, 1.0))
    z99 = float(np.sqrt(chi2.ppf(0.99, 1)))
    for k in np.unique(check.run):
        mine = check.run == k
        t = check.start[mine] - check.start[mine][0]
        sd = np.sqrt(check.covariance[mine, 2, 2])
        left.fill_between(
            t, -z99 * np.degrees(sd), z99 * np.degrees(sd), color=f"C{k % 10}", alpha=0.15, lw=0
        )
        left.plot(
            t,
            np.degrees(check.errors[mine, 2]),
            ".",
            ms=2.5,
            color=f"C{k % 10}",
            label=f"run {k + 1}" if check.run.max() > 0 else None,
        )
    left.set_xlabel("stretch start, s from the run's first")
    left.set_ylabel("heading error, deg")
    left.set_title(f"heading over {check.length:g}-s stretches, the model's 99 % band shaded")
    if check.run.max() > 0:
        left.legend(fontsize=7, loc="upper right", markerscale=3)
    for part, dof, colour in (("position", 2, "C0"), ("heading", 1, "C3")):
        q = np.sort(check.squared(part))
        share = np.arange(1, q.size + 1) / q.size
        right.step(q, share, where="post", color=colour, label=f"{part} (measured)")
        x = np.geomspace(max(float(q[0]), 1e-4), max(float(q[-1]), chi2.ppf(0.999, dof)), 200)
        right.plot(x, chi2.cdf(x, dof), "--", color=colour, lw=1, label=f"chi-square, {dof} dof")
    right.axhline(0.99, color="0.6", lw=0.8)
    right.set_xscale("log")
    right.set_ylim(0.0, 1.0)
    right.set_xlabel("squared error in the model's covariance")
    right.set_ylabel("share of stretches at or below")
    right.set_title(
        f"inside the 99 % region: position {100 * check.inside(0.99, 'position'):.1f} %, "
        f"heading {100 * check.inside(0.99, 'heading'):.1f} %",
        fontsize=9,
    )
    right.legend(fontsize=7, loc="lower right")
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)
