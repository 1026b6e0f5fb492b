"""Evaluation: Monte Carlo sweeps, real-data runs, and their reports.

* :func:`run_sweep` (:mod:`.sweep`) -- a grid of simulated conditions, each compared with the
  truth, the estimates from the true correspondences and the Cramer-Rao bound.
* :func:`evaluate_dataset` (:mod:`.real`) -- the Roh and MRCLAM recordings with the
  correspondences hidden.
* :func:`save_report` (:mod:`.report`) -- CSV, JSON and PNG figures of either.
"""

from __future__ import annotations

from .real import DATASET_DEFAULTS, DatasetResult, DatasetTrial, estimate_sensor, evaluate_dataset
from .report import save_report
from .sweep import (
    Condition,
    ConditionRow,
    SweepConfig,
    SweepResult,
    Trial,
    run_sweep,
    sensor_range,
)

__all__ = [
    "DATASET_DEFAULTS",
    "Condition",
    "ConditionRow",
    "DatasetResult",
    "DatasetTrial",
    "SweepConfig",
    "SweepResult",
    "Trial",
    "estimate_sensor",
    "evaluate_dataset",
    "run_sweep",
    "save_report",
    "sensor_range",
]
