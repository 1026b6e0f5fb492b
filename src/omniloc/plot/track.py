"""The figure of a run over time: map and trajectories, and a time line of state and error.

Left: the landmarks, the true trajectory (when known), the ``localized`` estimates (dots
coloured by state), and, every few seconds while ``ambiguous``, the competing hypotheses
(small arrows, opacity by weight). Right, top: the state over time (lost / ambiguous /
localized, the frames flagged ``kidnapped`` and those localized by the pass backward over
the recording); bottom: the position and heading errors of
the reported pose (localized frames solid, ambiguous ones faint), with the 0.3 m / 5 degree
tolerance drawn.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError
from ..maps import LandmarkMap
from ..track.records import TrackEstimate, TrackState
from ._save import save_figure

if TYPE_CHECKING:
    from ..track.data import GroundTruth

__all__ = ["plot_track"]

_COLOURS = {
    TrackState.LOST: "tab:red",
    TrackState.AMBIGUOUS: "tab:orange",
    TrackState.LOCALIZED: "tab:green",
}


def plot_track(
    landmarks: LandmarkMap,
    estimates: Sequence[TrackEstimate],
    path: str | Path,
    *,
    truth: GroundTruth | None = None,
    title: str | None = None,
    hypotheses_every_s: float = 5.0,
    pos_tol_m: float = 0.3,
    heading_tol_deg: float = 5.0,
) -> Path:
    """Draw a run and save it as a PNG.

    Parameters
    ----------
    landmarks : LandmarkMap
    estimates : sequence of TrackEstimate
        The tracker's reports, in time order.
    path : str or Path
        Where to write the figure (folders are created).
    truth : GroundTruth, optional
        The true trajectory: drawn, and the errors computed against it.
    title : str, optional
    hypotheses_every_s : float
        Draw the hypotheses of an ambiguous frame at most this often, seconds.
    pos_tol_m, heading_tol_deg : float
        The tolerance lines of the error panel.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        No estimates.
    """
    from matplotlib.figure import Figure

    if not estimates:
        raise InputError("plot_track needs at least one estimate")
    t = np.array([e.t for e in estimates])
    t0 = float(t[0])
    fig = Figure(figsize=(13.0, 6.0), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=[1.0, 1.3], height_ratios=[1.0, 2.0])
    ax_map = fig.add_subplot(gs[:, 0])
    ax_state = fig.add_subplot(gs[0, 1])
    ax_err = fig.add_subplot(gs[1, 1], sharex=ax_state)

    L = landmarks.xy
    ax_map.plot(L[:, 0], L[:, 1], "ks", ms=5, label="landmarks", zorder=4)
    if truth is not None:
        sel = (truth.t >= t0 - 1.0) & (truth.t <= float(t[-1]) + 1.0)
        ax_map.plot(truth.x[sel], truth.y[sel], "-", color="0.6", lw=1.0, label="truth")
    pose = np.array([e.pose.as_array() if e.pose is not None else (np.nan,) * 3 for e in estimates])
    state = [e.state for e in estimates]
    for st in (TrackState.AMBIGUOUS, TrackState.LOCALIZED):
        m = np.array([s is st for s in state])
        if m.any():
            ax_map.plot(
                pose[m, 0],
                pose[m, 1],
                ".",
                ms=3 if st is TrackState.LOCALIZED else 2,
                color=_COLOURS[st],
                alpha=1.0 if st is TrackState.LOCALIZED else 0.3,
                label=f"{st.value} (best pose)",
            )
    _draw_hypotheses(ax_map, estimates, hypotheses_every_s)
    ax_map.set_aspect("equal", adjustable="datalim")
    ax_map.set_xlabel("x (m)")
    ax_map.set_ylabel("y (m)")
    ax_map.legend(loc="best", fontsize=7)
    ax_map.grid(alpha=0.3)

    level = {TrackState.LOST: 0, TrackState.AMBIGUOUS: 1, TrackState.LOCALIZED: 2}
    y = np.array([level[s] for s in state])
    ax_state.step(t - t0, y, where="post", color="0.3", lw=0.8)
    for st, lv in level.items():
        m = y == lv
        ax_state.plot(t[m] - t0, y[m], "|", color=_COLOURS[st], ms=8)
    back = np.array([e.backward for e in estimates])
    if back.any():
        # (Localized by the pass backward over the recording, not by the frames before.)
        ax_state.plot(
            t[back] - t0,
            np.full(int(back.sum()), 2.2),
            "|",
            color="tab:olive",
            ms=5,
            label="localized by the pass backward",
        )
    kid = np.array([e.kidnapped for e in estimates])
    if kid.any():
        ax_state.plot(t[kid] - t0, np.full(int(kid.sum()), 2.4), "v", color="k", label="kidnapped")
    if kid.any() or back.any():
        ax_state.legend(loc="upper right", fontsize=7)
    ax_state.set_yticks([0, 1, 2], ["lost", "ambiguous", "localized"])
    ax_state.set_ylim(-0.5, 2.8)
    ax_state.grid(alpha=0.3)
    # Beside the state: the confidence (the tracker's own probability where it has no
    # confidence tables), which says how far to trust the pose of each frame.
    conf = np.array([np.nan if e.confidence is None else e.confidence for e in estimates])
    label = "confidence"
    if np.isnan(conf).all():
        conf = np.array([np.nan if e.probability is None else e.probability for e in estimates])
        label = "own probability (uncalibrated)"
    if not np.isnan(conf).all():
        ax_c = ax_state.twinx()
        ax_c.plot(t - t0, conf, "-", color="tab:cyan", lw=0.6, alpha=0.9)
        ax_c.set_ylim(-0.25, 1.4)
        ax_c.set_yticks([0.0, 0.5, 1.0])
        ax_c.set_ylabel(label, color="tab:cyan", fontsize=8)

    if truth is not None:
        true, _ = truth.at(t)
        d_pos = np.hypot(pose[:, 0] - true[:, 0], pose[:, 1] - true[:, 1])
        d_hdg = np.degrees(np.abs(np.mod(pose[:, 2] - true[:, 2] + np.pi, 2 * np.pi) - np.pi))
        loc = np.array([s is TrackState.LOCALIZED for s in state])
        ax_err.semilogy(t - t0, np.where(loc, d_pos, np.nan), ".", ms=2, color="tab:blue")
        ax_err.semilogy(
            t - t0, np.where(~loc, d_pos, np.nan), ".", ms=1, color="tab:blue", alpha=0.2
        )
        ax_err.axhline(pos_tol_m, color="tab:blue", ls="--", lw=0.8)
        ax_err.set_ylabel("position error (m)", color="tab:blue")
        ax_h = ax_err.twinx()
        ax_h.semilogy(t - t0, np.where(loc, d_hdg, np.nan), ".", ms=2, color="tab:purple")
        ax_h.axhline(heading_tol_deg, color="tab:purple", ls="--", lw=0.8)
        ax_h.set_ylabel("heading error (deg)", color="tab:purple")
    else:
        sd = np.array(
            [
                np.sqrt(np.linalg.eigvalsh(e.covariance[:2, :2])[-1])
                if e.covariance is not None
                else np.nan
                for e in estimates
            ]
        )
        ax_err.semilogy(t - t0, sd, ".", ms=2, color="tab:blue")
        ax_err.set_ylabel("position s.d. (m), no ground truth")
    ax_err.set_xlabel("time from the first frame (s)")
    ax_err.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def _draw_hypotheses(ax: Any, estimates: Sequence[TrackEstimate], every_s: float) -> None:
    last = -np.inf
    labelled = False
    for e in estimates:
        if e.state is not TrackState.AMBIGUOUS or e.t - last < every_s:
            continue
        last = e.t
        for h in e.hypotheses:
            a = float(np.clip(h.weight, 0.1, 1.0))
            ax.arrow(
                h.pose.x,
                h.pose.y,
                0.25 * np.cos(h.pose.theta),
                0.25 * np.sin(h.pose.theta),
                width=0.01,
                head_width=0.06,
                color="tab:orange",
                alpha=a,
                length_includes_head=True,
                label=None if labelled else "hypotheses (ambiguous)",
            )
            labelled = True
