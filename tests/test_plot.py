"""Figures (omniloc.plot): what is drawn, where it is saved, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from omniloc import vision
from omniloc.errors import InputError, VisionError
from omniloc.plot import plot_detections, plot_localization, plot_solutions_grid, vision_demo
from omniloc.pose import Pose, predict_bearings
from omniloc.search import localize
from omniloc.simulate import DEMO_POSE, DEMO_VISIBLE, demo_room, observe

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _rays(ax: object) -> int:
    """Two-point lines in a panel: the rays (landmarks and robots are markers)."""
    lines = ax.get_lines()  # type: ignore[attr-defined]
    return sum(1 for ln in lines if len(ln.get_xdata()) == 2)


def test_one_panel_per_solution_with_a_ray_per_bearing(tmp_path: Path) -> None:
    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE[:4], rng=0)
    res = localize(lm, sc.bearings, method="paper")
    assert len(res) > 2  # four bearings in the demo room are ambiguous
    out = tmp_path / "sub" / "sols.png"
    fig = plot_localization(res, sc.bearings, out, true_pose=DEMO_POSE, max_solutions=2)
    assert out.read_bytes()[:8] == PNG_MAGIC
    axes = fig.get_axes()
    assert len(axes) == 2
    for ax, sol in zip(axes, res.solutions, strict=False):
        assert _rays(ax) == 4
        assert f"{sol.pose.x:.2f}" in ax.get_title() and f"/{len(res)}:" in ax.get_title()
    # The rays of a matched bearing end at its landmark.
    best = res.solutions[0]
    ends = {
        tuple(np.round(ln.get_xydata()[1], 6))
        for ln in axes[0].get_lines()
        if len(ln.get_xdata()) == 2
    }
    for a in best.assignment:
        assert a is not None and tuple(np.round(lm.xy[a], 6)) in ends


def _labels(ax: object) -> list[str]:
    return [str(ln.get_label()) for ln in ax.get_lines()]  # type: ignore[attr-defined]


def test_no_solution_gets_one_titled_panel() -> None:
    lm = demo_room()
    res = localize(lm, np.array([0.0, 0.01, 0.02, 3.0]), method="paper")
    assert not res
    fig = plot_localization(res, np.array([0.0, 0.01, 0.02, 3.0]))
    assert [ax.get_title() for ax in fig.get_axes()] == ["no solution"]
    # No robot is drawn where there is no solution (it was one labelled "solution" at 0, 0).
    assert "solution" not in _labels(fig.get_axes()[0])
    fig = plot_localization(res, np.array([0.0, 0.01, 0.02, 3.0]), true_pose=DEMO_POSE)
    labels = _labels(fig.get_axes()[0])
    assert "solution" not in labels and labels.count("true pose") == 1
    grid = plot_solutions_grid([("none", res, np.zeros(4), None)])
    assert "solution" not in _labels(grid.get_axes()[0])


def test_solutions_far_from_the_map_are_in_view() -> None:
    lm = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [2.0, 6.0]])
    bearings = predict_bearings(lm, Pose(80.0, -30.0, 0.4))
    res = localize(lm, bearings)
    sols = res.solutions[:6]
    assert max(abs(s.pose.x) + abs(s.pose.y) for s in sols) > 50  # far outside the map
    truth = Pose(60.0, 50.0, 0.0)
    fig = plot_localization(res, bearings, true_pose=truth)
    for ax, sol in zip(fig.get_axes(), sols, strict=True):
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        for p in (sol.pose, truth, Pose(0.0, 0.0, 0.0), Pose(4.0, 6.0, 0.0)):
            assert x0 < p.x < x1 and y0 < p.y < y1


def test_plot_input_is_checked(tmp_path: Path) -> None:
    lm = demo_room()
    sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE[:5], rng=0)
    res = localize(lm, sc.bearings)
    with pytest.raises(InputError, match="bearings must be the 5 that were localized"):
        plot_localization(res, sc.bearings[:4])
    with pytest.raises(InputError, match="max_solutions"):
        plot_localization(res, sc.bearings, max_solutions=0)
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(InputError, match="cannot write figure"):
        plot_localization(res, sc.bearings, blocker / "x.png")
    with pytest.raises(InputError, match="at least one panel"):
        plot_solutions_grid([])


def test_grid_shows_each_runs_best(tmp_path: Path) -> None:
    lm = demo_room()
    panels = []
    for m in (5, 6):
        sc = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE[:m], rng=1)
        panels.append((f"{m} bearings", localize(lm, sc.bearings), sc.bearings, DEMO_POSE))
    fig = plot_solutions_grid(panels, tmp_path / "grid.png")
    assert [ax.get_title() for ax in fig.get_axes()] == ["5 bearings", "6 bearings"]
    assert [_rays(ax) for ax in fig.get_axes()] == [5, 6]
    assert (tmp_path / "grid.png").read_bytes()[:8] == PNG_MAGIC
    assert math.isfinite(fig.get_axes()[0].get_xlim()[0])


def test_plot_detections_and_demo(tmp_path: Path) -> None:
    demo_image = vision.render_omni_image(vision.demo_scene(), vision.DEMO_POSE, rng=1)
    det = vision.extract_bearings(demo_image)
    out = tmp_path / "det.png"
    fig = plot_detections(demo_image, det, out)
    assert out.stat().st_size > 10_000
    assert len(fig.axes) == 2
    from matplotlib.figure import Figure

    ax = Figure().subplots()
    plot_detections(demo_image, det, ax)
    assert len(ax.lines) >= len(det)
    with pytest.raises(VisionError, match="EdgeDetections"):
        plot_detections(demo_image, det.bearings, out)  # type: ignore[arg-type]
    text = vision_demo(tmp_path / "demo", rng=0)
    assert (tmp_path / "demo" / "vision.png").exists()
    assert "14 found within 0.5 deg" in text
    assert "median bearing error" in text


def test_vision_demo_saves_the_rendered_colour_image(tmp_path: Path) -> None:
    cam = vision.OmniCamera(color=True)
    vision_demo(tmp_path, rng=3, camera=cam)
    rendered = vision.render_omni_image(vision.demo_scene(), vision.DEMO_POSE, cam, rng=3)
    assert rendered.ndim == 3
    assert not np.array_equal(rendered[:, :, 0], rendered[:, :, 2])  # red differs from blue
    np.testing.assert_array_equal(vision.load_image(tmp_path / "vision-input.png"), rendered)


def test_plot_detections_shows_16_bit_and_float_colour_as_8_bit() -> None:
    from matplotlib.figure import Figure

    cam = vision.OmniCamera(color=True)
    rgb = vision.render_omni_image(vision.demo_scene(), vision.DEMO_POSE, cam, rng=2)
    det = vision.extract_bearings(rgb)

    def shown(image: np.ndarray) -> np.ndarray:
        ax = Figure().subplots()
        plot_detections(image, det, ax)
        return np.asarray(ax.get_images()[0].get_array())

    ref = shown(rgb)
    np.testing.assert_array_equal(ref, rgb)  # a uint8 image is drawn as it is
    rgba = np.concatenate([rgb, np.zeros_like(rgb[:, :, :1])], axis=2)  # alpha 0
    for image in (rgb.astype(np.uint16) * 257, rgb.astype(np.float32), rgb / 255.0, rgba):
        np.testing.assert_array_equal(shown(image), ref)
    grey = rgb[:, :, 1]
    np.testing.assert_array_equal(shown(grey.astype(np.uint16) * 257), shown(grey))
