"""Reports of evaluation results: CSV and JSON records and the figures."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from .real import DatasetResult
from .sweep import SweepResult

__all__ = ["save_report"]


def save_report(result: SweepResult | DatasetResult, out_dir: str | Path) -> list[Path]:
    """Write CSV, JSON and PNG figures of a result into ``out_dir``; return the paths.

    A sweep gives ``<name>_rows.csv``, ``<name>_trials.csv``, ``<name>.json``,
    ``<name>_success.png`` and ``<name>_rmse.png``; a dataset gives ``<kind>.csv``,
    ``<kind>.json`` and ``<kind>_errors.png``.
    """
    from ..plot import evaluation as plot_eval

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
