"""Figures of maps, bearings and solutions (like the seed paper's Figs. 4-6).

matplotlib is imported only inside the functions, with the object-oriented API (no pyplot
state), so they work headless and in threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InputError
from ..io import check_bearings, shorten
from ..maps import LandmarkMap, as_landmark_map
from ..pose import Pose, compose
from ._save import save_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..search import LocalizationResult

__all__ = ["plot_localization", "plot_solutions_grid"]


def _new_figure(ncols: int = 1, size: float = 5.0) -> tuple[Figure, list[Axes]]:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size * ncols, size), layout="constrained")
    axes = [fig.add_subplot(1, ncols, i + 1) for i in range(ncols)]
    return fig, axes


def _draw_robot(ax: Axes, pose: Pose, *, color: str, size: float, label: str | None) -> None:
    ax.plot(pose.x, pose.y, "o", color=color, ms=7, label=label, zorder=5)
    ax.annotate(
        "",
        xy=(pose.x + size * np.cos(pose.theta), pose.y + size * np.sin(pose.theta)),
        xytext=(pose.x, pose.y),
        arrowprops={"arrowstyle": "->", "color": color, "lw": 2},
        zorder=5,
    )


def _draw_rays(
    ax: Axes,
    L: np.ndarray,
    bearings: np.ndarray,
    eye: Pose,
    assignment: Sequence[int | None] | None,
    *,
    color: str,
    length: float,
) -> None:
    """A ray from ``eye`` along each bearing: to its landmark if matched, else dotted."""
    for k, beta in enumerate(bearings):
        ang = eye.theta + beta
        lm_i = None if assignment is None else assignment[k]
        if lm_i is None:
            end = (eye.x + length * np.cos(ang), eye.y + length * np.sin(ang))
        else:
            end = (L[lm_i, 0], L[lm_i, 1])
        ax.plot(
            [eye.x, end[0]],
            [eye.y, end[1]],
            ":" if lm_i is None else "-",
            color=color,
            lw=1.0,
            alpha=0.8,
        )


def draw_scene(
    ax: Axes,
    landmarks: LandmarkMap,
    bearings: ArrayLike,
    pose: Pose | None,
    assignment: Sequence[int | None] | None = None,
    *,
    color: str = "tab:blue",
    true_pose: Pose | None = None,
    title: str | None = None,
    sensor_pose: Pose | None = None,
) -> None:
    """Draw the map, a pose, its rays along the measured bearings and the matched landmarks
    (the rays from ``sensor_pose`` when the sensor sits elsewhere on the robot).

    With ``pose`` None (no solution) only the map and the true pose are drawn. The axes
    take in the landmarks and every pose drawn, however far from the map.
    """
    L = landmarks.xy
    b = np.asarray(bearings, dtype=float)
    drawn = [q for q in (pose, sensor_pose, true_pose) if q is not None]
    pts = np.vstack([L, *([q.x, q.y] for q in drawn)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = float((hi - lo).max()) or 1.0
    ax.plot(L[:, 0], L[:, 1], "ks", ms=6, label="landmarks")
    for i, lid in enumerate(landmarks.ids):
        ax.annotate(str(lid), L[i], textcoords="offset points", xytext=(4, 4), fontsize=8)
    eye = pose if sensor_pose is None else sensor_pose
    if eye is not None:
        _draw_rays(ax, L, b, eye, assignment, color=color, length=1.5 * span)
    if true_pose is not None:
        _draw_robot(ax, true_pose, color="tab:green", size=0.08 * span, label="true pose")
    if pose is not None:
        _draw_robot(ax, pose, color=color, size=0.08 * span, label="solution")
    pad = 0.1 * span
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)


def _sensor_pose(result: LocalizationResult, pose: Pose) -> Pose | None:
    """Where the sensor was when the robot is at ``pose`` (None: at the robot's origin)."""
    if result.mount is None:
        return None
    return Pose.from_array(compose(pose.as_array(), np.asarray(result.mount)))


def plot_localization(
    result: LocalizationResult,
    bearings: ArrayLike,
    path: str | Path | None = None,
    *,
    true_pose: Pose | None = None,
    max_solutions: int = 6,
    title: str | None = None,
) -> Figure:
    """The map, the true pose (if known) and every solution with its rays (paper Figs. 4-6).

    Parameters
    ----------
    result : LocalizationResult
        From :func:`omniloc.localize`.
    bearings : array_like, shape (m,)
        The bearings that were localized, radians.
    path : str or Path, optional
        Where to save a PNG.
    true_pose : Pose, optional
        Drawn in green when known (simulation).
    max_solutions : int
        At most this many solutions get a panel each.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..search import LocalizationResult

    if not isinstance(result, LocalizationResult):
        raise InputError(f"result must be a LocalizationResult, got {type(result).__name__}")
    lm = as_landmark_map(result.landmarks)
    b = check_bearings(bearings, min_count=0)
    if result.solutions and b.shape != (len(result.solutions[0].assignment),):
        raise InputError(
            f"bearings must be the {len(result.solutions[0].assignment)} that were localized, "
            f"got shape {b.shape}"
        )
    if isinstance(max_solutions, bool) or not isinstance(max_solutions, int | np.integer):
        raise InputError(f"max_solutions must be an int >= 1, got {shorten(max_solutions)}")
    if max_solutions < 1:
        raise InputError(f"max_solutions must be >= 1, got {max_solutions}")
    sols = result.solutions[:max_solutions]
    n = max(1, len(sols))
    fig, axes = _new_figure(ncols=n, size=4.5)
    if not sols:
        draw_scene(axes[0], lm, np.zeros(0), None, true_pose=true_pose, title="no solution")
    palette = ["tab:blue", "tab:orange", "tab:red", "tab:purple", "tab:brown", "tab:pink"]
    for k, (ax, sol) in enumerate(zip(axes, sols, strict=False)):
        p = sol.pose
        draw_scene(
            ax,
            lm,
            b,
            p,
            sol.assignment,
            color=palette[k % len(palette)],
            true_pose=true_pose,
            sensor_pose=_sensor_pose(result, p),
            title=(
                f"solution {k + 1}/{len(result.solutions)}: ({p.x:.2f}, {p.y:.2f}, "
                f"{np.rad2deg(p.theta):.1f} deg)\nconfidence {sol.confidence:.2f}"
            ),
        )
    axes[0].legend(loc="best", fontsize=7)
    if title:
        fig.suptitle(title)
    if path is not None:
        _save(fig, path)
    return fig


def plot_solutions_grid(
    panels: Sequence[tuple[str, LocalizationResult, ArrayLike, Pose | None]],
    path: str | Path | None = None,
) -> Figure:
    """One panel per run: its best solution (and the true pose) on the map.

    ``panels`` holds ``(title, result, bearings, true_pose)`` tuples.
    """
    if not panels:
        raise InputError("plot_solutions_grid needs at least one panel")
    fig, axes = _new_figure(ncols=len(panels), size=4.0)
    for ax, (ttl, res, b, truth) in zip(axes, panels, strict=True):
        lm = as_landmark_map(res.landmarks)
        best = res.best
        if best is None:
            draw_scene(ax, lm, np.zeros(0), None, true_pose=truth, title=f"{ttl}: none")
            continue
        draw_scene(
            ax,
            lm,
            b,
            best.pose,
            best.assignment,
            true_pose=truth,
            title=ttl,
            sensor_pose=_sensor_pose(res, best.pose),
        )
    if path is not None:
        _save(fig, path)
    return fig


def _save(fig: Any, path: str | Path) -> None:
    save_figure(fig, path)
