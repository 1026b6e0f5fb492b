"""Figures: the only package of omniloc that imports matplotlib.

matplotlib is imported inside each function, and figures are plain
:class:`matplotlib.figure.Figure` objects rendered with the Agg canvas: no pyplot state, safe
without a display and in threads.

* :mod:`.scene` -- maps, bearings and solutions (like the seed paper's Figs. 4-6);
* :mod:`.evaluation` -- figures of Monte Carlo sweeps and real-data runs;
* :mod:`.vision` -- the vision front end's detections, its conventions, and the vision demo;
* :mod:`.track` -- a run over time; :mod:`.motion` and :mod:`.sensor` -- a motion model and
  a bearing sensor model checked against a ground truth.
"""

from __future__ import annotations

from .evaluation import (
    plot_dataset_errors,
    plot_reliability,
    plot_rmse_vs_crlb,
    plot_success_vs_noise,
)
from .motion import plot_motion_check
from .scene import draw_scene, plot_localization, plot_solutions_grid
from .sensor import plot_sensor_check
from .vision import plot_conventions, plot_detections, vision_demo

__all__ = [
    "draw_scene",
    "plot_conventions",
    "plot_dataset_errors",
    "plot_detections",
    "plot_localization",
    "plot_motion_check",
    "plot_reliability",
    "plot_rmse_vs_crlb",
    "plot_sensor_check",
    "plot_solutions_grid",
    "plot_success_vs_noise",
    "vision_demo",
]
