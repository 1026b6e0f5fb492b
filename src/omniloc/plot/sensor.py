"""The figure of a bearing sensor model checked against a ground truth
(:func:`~omniloc.track.check_sensor`).

Left: the bearing errors' density (a histogram, log scale) against the model's, cut at the
gate as the errors are; right: the share of the errors inside each of the model's central
regions against the region's probability (an honest model's curve follows the diagonal; one
below it is too sure of the bearings, one above it wider than it needs).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ._save import save_figure

if TYPE_CHECKING:
    from ..track.calibrate import SensorCheck

__all__ = ["plot_sensor_check"]

#: Bearings whose model density is summed at once (the density's grid times this many
#: values in memory).
DENSITY_CHUNK = 4096


def plot_sensor_check(check: SensorCheck, path: str | Path, *, title: str | None = None) -> Path:
    """Draw a :class:`~omniloc.track.SensorCheck` and save it (the format from the
    extension).

    Parameters
    ----------
    check : SensorCheck
    path : str or Path
        Where to write the figure (folders are created).
    title : str, optional

    Returns
    -------
    Path
        The file written.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11.0, 4.0), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=(1.4, 1.0))
    gate = np.degrees(check.gate)
    edges = np.linspace(-gate, gate, 61)
    left.hist(
        np.degrees(check.errors),
        bins=edges,
        density=True,
        color="C0",
        alpha=0.6,
        label=f"measured ({check.errors.size} bearings)",
    )
    # The model's density of the errors pooled: each bearing's mixture, cut at the gate.
    x = np.radians(np.linspace(-gate, gate, 301))
    cut = np.maximum(check.below(check.gate), 1e-300)
    density = np.zeros(x.size)
    for share, sd in ((1.0 - check.core_share, check.sd), (check.core_share, check.core_sd)):
        if not share > 0:
            continue
        for lo in range(0, sd.size, DENSITY_CHUNK):  # (a long recording: in blocks)
            s, c = sd[lo : lo + DENSITY_CHUNK], cut[lo : lo + DENSITY_CHUNK]
            g = np.exp(-0.5 * (x[:, None] / s) ** 2) / (np.sqrt(2.0 * np.pi) * s)
            density += share * np.sum(g / c, axis=1) / sd.size
    left.plot(np.degrees(x), np.radians(1.0) * density, color="C3", lw=1.2, label="the model")
    left.set_yscale("log")
    left.set_xlabel("bearing error, deg (less the run's median)")
    left.set_ylabel("density, per deg")
    left.set_title(f"errors within the {gate:g}-deg gate")
    left.legend(fontsize=7, loc="upper right")
    levels = np.sort(check.levels())
    below = np.arange(1, levels.size + 1) / levels.size
    right.step(levels, below, where="post", color="C0", label="measured")
    right.plot([0.0, 1.0], [0.0, 1.0], "--", color="0.5", lw=1, label="an honest model")
    right.axvline(0.99, color="0.6", lw=0.8)
    right.set_xlim(0.0, 1.0)
    right.set_ylim(0.0, 1.0)
    right.set_xlabel("probability of the model's central region")
    right.set_ylabel("share of the errors inside it")
    right.set_title(
        f"inside the 50 % region {100 * check.inside(0.5):.1f} %, the 99 % "
        f"{100 * check.inside(0.99):.1f} %",
        fontsize=9,
    )
    right.legend(fontsize=7, loc="lower right")
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)
