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
    ``<name>_success.png``, ``<name>_rmse.png`` and ``<name>_reliability.png``; a dataset
    gives ``<kind>.csv``, ``<kind>.json``, ``<kind>_errors.png`` and
    ``<kind>_reliability.png`` (the reliability diagram of the best solution's confidence,
    with the expected calibration error).
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
        paths.append(
            plot_eval.plot_reliability(
                result.calibration(), d / f"{name}_reliability.png", title=name
            )
        )
        return paths
    if isinstance(result, DatasetResult):
        paths = [d / f"{result.kind}.csv", d / f"{result.kind}.json"]
        result.to_csv(paths[0])
        result.to_json(paths[1])
        paths.append(plot_eval.plot_dataset_errors(result, d / f"{result.kind}_errors.png"))
        paths.append(
            plot_eval.plot_reliability(
                result.calibration(), d / f"{result.kind}_reliability.png", title=result.kind
            )
        )
        return paths
    raise InputError(f"save_report takes a SweepResult or a DatasetResult, got {type(result)}")
