"""Figures for the vision front end, and the vision demo.

matplotlib is imported inside the functions, and only its object-oriented API is used (a
``Figure`` with an Agg canvas), so nothing here touches pyplot's global state or needs a
display.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..angles import wrap
from ..errors import VisionError
from ..vision.bearings import EdgeDetections, _to_8bit, extract_bearings, unwrap_panorama
from ..vision.calibrate import MirrorCalibration
from ..vision.render import (
    DEMO_CAMERA,
    DEMO_POSE,
    OmniCamera,
    OmniScene,
    demo_scene,
    render_omni_image,
    true_features,
)
from ._save import save_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_conventions", "plot_detections", "vision_demo"]

KIND_COLORS = {"edge": "tab:orange", "pole": "tab:cyan"}


def _new_figure(nrows: int, figsize: tuple[float, float]) -> tuple[Figure, list[Axes]]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    if nrows == 2:
        axes = list(fig.subplots(2, 1, height_ratios=[3, 1]))
    else:
        axes = [fig.subplots(1, 1)]
    return fig, axes


def _draw_rim(ax: Axes, cal: MirrorCalibration, **kw: Any) -> None:
    from matplotlib.patches import Ellipse

    a_u, a_v = cal.semi_axes
    ax.add_patch(Ellipse(cal.center, 2 * a_u, 2 * a_v, fill=False, **kw))


def _display_image(image: NDArray[Any]) -> NDArray[np.uint8]:
    """The image as the detector reads it, in 8-bit units: grey ``(H, W)`` or RGB ``(H, W, 3)``.

    uint16 is divided by 257 and a float image in [0, 1] multiplied by 255, as for the
    detections (:func:`~omniloc.vision.bearings.extract_bearings`), and like the panorama
    below it; an image with negative values is shifted to start at 0. Alpha is dropped.
    """
    gray, rgb, scale = _to_8bit(image)
    shown = gray if rgb is None else rgb.astype(np.float32) * np.float32(scale)
    low = float(shown.min())
    if low < 0:
        shown = shown - np.float32(low)
    return np.clip(np.rint(shown), 0, 255).astype(np.uint8)


def plot_detections(
    image: NDArray[np.generic],
    detections: EdgeDetections,
    path_or_ax: str | os.PathLike[str] | Axes,
    *,
    radial_range: tuple[float, float] = (0.4, 0.95),
    title: str | None = None,
) -> Figure:
    """Draw the detections on the image, and on the unwrapped panorama below it.

    Parameters
    ----------
    image : ndarray
        ``(H, W)`` grey or ``(H, W, 3)`` RGB image the detections come from; drawn in 8-bit
        units as the detector reads it (uint16 / 257, a float image in [0, 1] times 255).
    detections : EdgeDetections
        From :func:`~omniloc.vision.bearings.extract_bearings`.
    path_or_ax : str, path-like or matplotlib Axes
        A PNG file to write (a new figure is made), or an Axes to draw the image into (the
        panorama goes into an inset below it; nothing is saved).
    radial_range : tuple of float
        Radii (fractions of the rim) of the panorama and of the drawn lines' inner end.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn on.

    Raises
    ------
    VisionError
        If the image is malformed or `detections` is not an EdgeDetections.
    """
    if not isinstance(detections, EdgeDetections):
        raise VisionError(f"detections must be an EdgeDetections, got {type(detections).__name__}")
    img = np.asarray(image)
    cal = detections.calibration
    pano = unwrap_panorama(img, cal, radial_range=radial_range)
    save_to: Path | None = None
    if isinstance(path_or_ax, (str, os.PathLike)):
        save_to = Path(path_or_ax)
        h, w = img.shape[:2]
        fig, (ax_img, ax_pan) = _new_figure(2, (7.0, 7.0 * h / w * 0.75 + 2.4))
    else:
        ax_img = path_or_ax
        fig = ax_img.figure  # type: ignore[assignment]
        ax_pan = ax_img.inset_axes((0.0, -0.42, 1.0, 0.3))

    ax_img.imshow(_display_image(img), cmap="gray", vmin=0, vmax=255)
    _draw_rim(ax_img, cal, edgecolor="tab:green", linestyle="--", linewidth=0.8)
    ax_img.plot(*cal.center, "+", color="tab:green", markersize=8)
    fu, fv = cal.pixel(detections.forward, 1.05)
    ax_img.annotate(
        "forward",
        xy=(fu, fv),
        xytext=cal.center,
        color="tab:red",
        fontsize=8,
        arrowprops={"arrowstyle": "->", "color": "tab:red"},
    )
    for phi, kind in zip(detections.image_angles, detections.kind, strict=True):
        p0 = cal.pixel(float(phi), radial_range[0])
        p1 = cal.pixel(float(phi), 1.0)
        ax_img.plot([p0[0], p1[0]], [p0[1], p1[1]], color=KIND_COLORS[str(kind)], lw=1.2)
    ax_img.set_xlim(-0.5, img.shape[1] - 0.5)
    ax_img.set_ylim(img.shape[0] - 0.5, -0.5)
    ax_img.set_axis_off()

    # Panorama in bearing order, -180 to 180 degrees left to right.
    cols = pano.shape[1]
    s = -1.0 if detections.mirrored else 1.0
    b = np.asarray(wrap(s * (np.arange(cols) * (2 * np.pi / cols) - detections.forward)))
    order = np.argsort(b)
    ax_pan.imshow(
        np.nan_to_num(pano[:, order]),
        cmap="gray",
        aspect="auto",
        extent=(float(np.rad2deg(b[order[0]])), float(np.rad2deg(b[order[-1]])), 0, 1),
        origin="lower",
        vmin=0,
        vmax=255,
    )
    for bearing, kind in zip(detections.bearings, detections.kind, strict=True):
        deg = math.degrees(float(bearing))
        color = KIND_COLORS[str(kind)]
        ax_pan.plot([deg, deg], [1.0, 1.12], color=color, lw=1.5, clip_on=False)
        ax_pan.plot([deg, deg], [-0.12, 0.0], color=color, lw=1.5, clip_on=False)
    ax_pan.set_xlim(-180, 180)
    ax_pan.set_xticks(np.arange(-180, 181, 45))
    ax_pan.set_yticks([])
    ax_pan.set_xlabel("bearing (deg, counter-clockwise from forward)")
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=c, label=k) for k, c in KIND_COLORS.items()]
    ax_img.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.8)
    if title:
        fig.suptitle(title, fontsize=10)
    if save_to is not None:
        save_figure(fig, save_to, VisionError)
    return fig


def plot_conventions(path: str | os.PathLike[str]) -> Figure:
    """Draw the image conventions: u, v, the rim ellipse, centre, phi, forward, a bearing.

    Parameters
    ----------
    path : str or path-like
        PNG file to write (``docs/vision-conventions.png`` in the repository).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    fig = Figure(figsize=(7.0, 6.2))
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.02, 0.02, 0.96, 0.9))
    w, h = 640, 480
    cal = MirrorCalibration((330.0, 235.0), 1.3, 165.0)
    cx, cy = cal.center
    a_u, a_v = cal.semi_axes
    ax.add_patch(Rectangle((-0.5, -0.5), w, h, fill=False, edgecolor="0.3"))
    _draw_rim(ax, cal, edgecolor="tab:green", linewidth=2)
    ax.text(cx + a_u * 0.72, cy + a_v * 0.8, "rim ellipse", color="tab:green", fontsize=9)
    ax.plot(cx, cy, "+", color="k", markersize=12)
    ax.text(cx + 6, cy + 22, "centre (cx, cy)", fontsize=9)
    # Image axes from the top-left pixel.
    arrow = {"arrowstyle": "->", "lw": 1.5}
    ax.annotate("", xy=(110, 0), xytext=(0, 0), arrowprops=arrow)
    ax.annotate("", xy=(0, 110), xytext=(0, 0), arrowprops=arrow)
    ax.text(115, 8, "u (column)", fontsize=9, va="center")
    ax.text(6, 122, "v (row)", fontsize=9)
    ax.text(6, -12, "(0, 0) = centre of the top-left pixel", fontsize=8)
    # Semi-axes.
    ax.plot([cx, cx + a_u], [cy, cy], color="tab:green", lw=1, ls=":")
    ax.plot([cx, cx], [cy, cy - a_v], color="tab:green", lw=1, ls=":")
    ax.text(cx + a_u * 0.7, cy - 5, "aspect * radius", fontsize=8, ha="center", color="tab:green")
    ax.text(cx - 4, cy - a_v * 0.6, "radius", ha="right", fontsize=8, color="tab:green")
    # phi = 0 direction, forward and a landmark line.
    forward = math.radians(35.0)
    phi_l = math.radians(120.0)
    for ang, color, label in (
        (forward, "tab:red", "forward (image angle)"),
        (phi_l, "tab:blue", "radial line of a landmark"),
    ):
        u1, v1 = cal.pixel(ang, 1.0)
        ax.annotate("", xy=(u1, v1), xytext=(cx, cy), arrowprops={**arrow, "color": color})
        ax.text(u1 + 4, v1 - 6, label, color=color, fontsize=9)
    # Arcs follow the rim's ellipse, so they end on the radial lines whatever the aspect.
    for rho, t0, t1, color, label, rho_text in (
        (0.3, 0.0, phi_l, "tab:blue", "phi", 0.36),
        (0.5, forward, phi_l, "tab:purple", "bearing", 0.56),
    ):
        t = np.linspace(t0, t1, 60)
        pts = np.array([cal.pixel(float(a), rho) for a in t])
        ax.plot(pts[:, 0], pts[:, 1], color=color, lw=1.5)
        ax.annotate("", xy=pts[-1], xytext=pts[-3], arrowprops={**arrow, "color": color})
        tu, tv = cal.pixel(float(t[len(t) // 2]), rho_text)
        ax.text(tu, tv, label, color=color, fontsize=10, ha="center", va="center")
    ax.text(
        -0.5,
        h + 30,
        "phi = atan2(-(v - cy) * aspect, u - cx)   (counter-clockwise as displayed)\n"
        "bearing = wrap(s * (phi - forward)),  s = -1 if mirrored else +1",
        fontsize=9,
        family="monospace",
        va="top",
    )
    ax.set_xlim(-20, w + 20)
    ax.set_ylim(h + 80, -30)
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title("omniloc.vision image conventions (aspect exaggerated to 1.3)", fontsize=11)
    save_figure(fig, path, VisionError)
    return fig


def vision_demo(
    out_dir: str | os.PathLike[str],
    rng: np.random.Generator | int | None = 0,
    *,
    scene: OmniScene | None = None,
    pose: tuple[float, float, float] | None = None,
    camera: OmniCamera | None = None,
) -> str:
    """Render a room, find the mirror and the bearings, save ``vision.png``, summarise.

    Parameters
    ----------
    out_dir : str or path-like
        Directory for ``vision.png`` (the detections) and ``vision-input.png`` (the rendered
        image); created if missing.
    rng : numpy.random.Generator or int or None
        Texture and noise of the rendered image.
    scene, pose, camera : optional
        The room (default :func:`~omniloc.vision.render.demo_scene`: 6 poles, 8 wall edges),
        the robot pose ``(x, y, theta)`` (metres, radians) and the camera (default
        :data:`DEMO_CAMERA`).

    Returns
    -------
    str
        A few lines: calibration found versus true, number of detections, median bearing
        error in degrees.

    Raises
    ------
    VisionError
        If the image cannot be interpreted.
    """
    import cv2

    from ..angles import angdiff

    scn = demo_scene() if scene is None else scene
    p = DEMO_POSE if pose is None else pose
    cam = DEMO_CAMERA if camera is None else camera
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    image = render_omni_image(scn, p, cam, rng=rng)
    # OpenCV writes BGR(A): a colour camera's RGB must be swapped, or load_image reads the
    # file back with red and blue exchanged.
    cv2.imwrite(
        str(out / "vision-input.png"),
        cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image,
    )
    det = extract_bearings(image, forward=cam.forward, mirrored=cam.mirrored)
    truth = true_features(scn, p, cam)
    plot_detections(image, det, out / "vision.png", title="omniloc vision demo")
    cal = det.calibration
    if len(det) and len(truth):
        err = np.abs(np.asarray(angdiff(det.bearings[:, None], truth.bearings[None, :])))
        nearest = np.rad2deg(err.min(axis=0))
        matched = nearest < 0.5
        median = f"{float(np.median(nearest[matched])):.3f} deg" if matched.any() else "n/a"
        n_matched = int(matched.sum())
        n_spurious = int(np.sum(np.rad2deg(err.min(axis=1)) >= 0.5))
    else:
        median, n_matched, n_spurious = "n/a", 0, len(det)
    n_poles = int(np.sum(det.kind == "pole"))
    return "\n".join(
        [
            f"image: {cam.image_size[0]}x{cam.image_size[1]} px, robot at "
            f"({p[0]:.2f} m, {p[1]:.2f} m, {math.degrees(p[2]):.1f} deg)",
            f"mirror centre: ({cal.center[0]:.2f}, {cal.center[1]:.2f}) px "
            f"(true ({cam.center[0]:.2f}, {cam.center[1]:.2f}))",
            f"aspect: {cal.aspect:.4f} (true {cam.aspect:.4f}), radius: {cal.radius:.2f} px "
            f"(true {cam.radius:.2f})",
            f"detections: {len(det)} ({n_poles} poles, {len(det) - n_poles} edges); "
            f"{len(truth)} landmarks visible, {n_matched} found within 0.5 deg, "
            f"{n_spurious} spurious",
            f"median bearing error: {median}",
            f"figure: {out / 'vision.png'}",
        ]
    )
