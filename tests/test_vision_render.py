"""Tests for omniloc.vision.render: the synthetic omnidirectional images and their truth."""

from __future__ import annotations

import numpy as np
import pytest

from omniloc.angles import angdiff, wrap
from omniloc.errors import VisionError
from omniloc.vision import (
    DEMO_POSE,
    OmniCamera,
    OmniScene,
    Pole,
    WallEdge,
    demo_scene,
    extract_bearings,
    random_scene,
    render_omni_image,
    true_features,
)
from omniloc.vision.render import luminance, random_stripe_scene

ROOM = (WallEdge(-4, -3), WallEdge(4, -3), WallEdge(4, 3), WallEdge(-4, 3))


def clean_camera(**kw: object) -> OmniCamera:
    """No blur, noise, texture or lighting: pixel values are exact."""
    base: dict[str, object] = {
        "blur_sigma": 0.0,
        "noise_sigma": 0.0,
        "texture_sigma": 0.0,
        "lighting_gradient": (0.0, 0.0),
    }
    base.update(kw)
    return OmniCamera(**base)  # type: ignore[arg-type]


def test_shape_dtype_and_levels() -> None:
    cam = clean_camera(image_size=(333, 251), center=(170.2, 120.9), radius=110.0)
    img = render_omni_image(demo_scene(), DEMO_POSE, cam, rng=0)
    assert img.shape == (251, 333)
    assert img.dtype == np.uint8
    assert img[0, 0] == round(cam.background_level)
    assert img[121, 170] == round(cam.camera_level)


def test_seeded_rng_is_reproducible() -> None:
    a = render_omni_image(demo_scene(), DEMO_POSE, rng=5)
    b = render_omni_image(demo_scene(), DEMO_POSE, rng=np.random.default_rng(5))
    c = render_omni_image(demo_scene(), DEMO_POSE, rng=6)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize(
    ("forward", "mirrored", "aspect"),
    [(0.0, False, 1.0), (1.1, False, 1.2), (-2.5, True, 0.9), (0.4, True, 1.05)],
)
def test_renderer_inverts_the_bearing_convention(
    forward: float, mirrored: bool, aspect: float
) -> None:
    # One bright pole straight at bearing b; its stripe must lie at phi = s * b + forward.
    pose = (0.3, -0.2, 0.7)
    b = np.deg2rad(40.0)
    d = 2.0
    ang = pose[2] + b
    pole = Pole(pose[0] + d * np.cos(ang), pose[1] + d * np.sin(ang), 0.1, 250.0)
    cam = clean_camera(aspect=aspect, radius=180.0, forward=forward, mirrored=mirrored)
    img = render_omni_image(OmniScene(poles=(pole,), edges=ROOM), pose, cam, rng=0)
    s = -1.0 if mirrored else 1.0
    phi = float(wrap(s * b + forward))
    cx, cy = cam.center
    for rho in (0.5, 0.7, 0.9):
        u = cx + aspect * cam.radius * rho * np.cos(phi)
        v = cy - cam.radius * rho * np.sin(phi)
        assert img[round(v), round(u)] == 250
        # The convention itself: the image angle of that pixel is phi.
        assert abs(np.arctan2(-(v - cy) * aspect, u - cx) - phi) < 1e-9
    # And the opposite direction shows wall, not the pole.
    u = cx - aspect * cam.radius * 0.7 * np.cos(phi)
    v = cy + cam.radius * 0.7 * np.sin(phi)
    assert img[round(v), round(u)] != 250


def test_true_features_occlusion() -> None:
    pose = (0.0, 0.0, 0.0)
    near = Pole(1.0, 0.0, 0.1, 20.0)  # hides everything within 5.7 deg of bearing 0
    far = Pole(3.0, 0.05, 0.05, 240.0)  # fully behind `near`
    side = Pole(2.0, 0.2, 0.1, 240.0)  # 5.7 deg: partly behind `near` -> ambiguous
    other = Pole(-2.0, 1.0, 0.05, 30.0)
    hidden_edge = WallEdge(4.0, 0.1)
    scene = OmniScene(poles=(near, far, side, other), edges=(*ROOM, hidden_edge))
    truth = true_features(scene, pose)
    assert sorted(truth.index.tolist()) == [0, 3, 4, 5, 6, 7]
    assert truth.ambiguous.size == 1
    assert abs(float(angdiff(truth.ambiguous[0], np.arctan2(0.2, 2.0)))) < 1e-12
    pole_b = truth.bearings[truth.kind == "pole"]
    np.testing.assert_allclose(np.sort(pole_b), np.sort([0.0, np.arctan2(1.0, -2.0)]))
    expected_edges = [np.arctan2(y, x) for x, y in [(-4, -3), (4, -3), (4, 3), (-4, 3)]]
    np.testing.assert_allclose(
        np.sort(truth.bearings[truth.kind == "edge"]), sorted(expected_edges)
    )
    # Truth is in the robot frame: turning the robot shifts every bearing.
    turned = true_features(scene, (0.0, 0.0, 0.5))
    np.testing.assert_allclose(
        np.sort(np.asarray(wrap(turned.bearings + 0.5))), np.sort(truth.bearings)
    )


def test_texture_and_lighting_make_no_spurious_detections() -> None:
    # A room with no landmarks but a strongly textured, unevenly lit wall: nothing to find.
    cam = OmniCamera(texture_sigma=8.0, lighting_gradient=(0.2, -0.15))
    for seed in range(3):
        img = render_omni_image(OmniScene(), (0.0, 0.0, 0.0), cam, rng=seed)
        assert len(extract_bearings(img)) == 0


def test_random_scene_spurious_rate_below_five_percent() -> None:
    rng = np.random.default_rng(11)
    total = spurious = 0
    for _ in range(4):
        scene, pose = random_scene(rng)
        cam = OmniCamera(texture_sigma=5.0, forward=float(rng.uniform(-np.pi, np.pi)))
        det = extract_bearings(render_omni_image(scene, pose, cam, rng=rng), forward=cam.forward)
        truth = true_features(scene, pose)
        err = np.abs(np.asarray(angdiff(det.bearings[:, None], truth.bearings[None, :])))
        spurious += int(np.sum(err.min(axis=1) > np.deg2rad(0.5)))
        total += len(det)
    assert total > 40
    assert spurious <= 0.05 * total


def test_random_scene_is_well_separated() -> None:
    scene, pose = random_scene(3, n_poles=4, n_edges=6)
    truth = true_features(scene, pose)
    assert len(truth) == 10
    b = np.sort(truth.bearings)
    assert np.min(np.diff(np.concatenate([b, b[:1] + 2 * np.pi]))) > np.deg2rad(6.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"aspect": 0.0}, "aspect"),
        ({"aspect": 11.0}, "aspect"),
        ({"center": (700.0, 10.0)}, "outside"),
        ({"center": (np.nan, 10.0)}, "finite"),
        ({"radius": -3.0}, "radius"),
        ({"noise_sigma": -1.0}, "noise_sigma"),
        ({"image_size": (8, 8)}, "image_size"),
    ],
)
def test_bad_camera_raises(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(VisionError, match=message):
        OmniCamera(**kwargs)  # type: ignore[arg-type]


def test_bad_scene_and_pose_raise() -> None:
    with pytest.raises(VisionError, match="inside pole"):
        render_omni_image(OmniScene(poles=(Pole(0.0, 0.0, 0.2),)), (0.1, 0.0, 0.0))
    with pytest.raises(VisionError, match="pose"):
        true_features(demo_scene(), (0.0, 1.0))
    with pytest.raises(VisionError, match="finite"):
        true_features(demo_scene(), (0.0, np.nan, 0.0))
    with pytest.raises(VisionError, match="radius"):
        Pole(0.0, 0.0, 0.0)
    with pytest.raises(VisionError, match="wall_levels"):
        OmniScene(wall_levels=(10.0, 10.0, 20.0))


def test_wall_edge_levels_paint_the_walls_they_start() -> None:
    # Seen from the origin, edges at 0, 90, 200 deg: the wall from 0 to 90 deg is 60, from
    # 90 to 200 deg is 180, from 200 to 360 deg is 120.
    az = np.deg2rad([0.0, 90.0, 200.0])
    levels = (60.0, 180.0, 120.0)
    edges = tuple(
        WallEdge(3 * np.cos(a), 3 * np.sin(a), level) for a, level in zip(az, levels, strict=True)
    )
    cam = clean_camera()
    img = render_omni_image(OmniScene(edges=edges), (0.0, 0.0, 0.0), cam, rng=0)
    cx, cy = cam.center
    for bearing_deg, level in ((45.0, 60), (150.0, 180), (290.0, 120)):
        phi = np.deg2rad(bearing_deg)
        u = cx + cam.radius * 0.6 * np.cos(phi)
        v = cy - cam.radius * 0.6 * np.sin(phi)
        assert img[round(v), round(u)] == level


def test_colour_camera_sees_colours_and_grey_camera_their_luminance() -> None:
    red, blue, green = (200.0, 40.0, 40.0), (30.0, 60.0, 220.0), (50.0, 160.0, 60.0)
    az = np.deg2rad([10.0, 130.0, 250.0])
    edges = tuple(
        WallEdge(3 * np.cos(a), 3 * np.sin(a), c)
        for a, c in zip(az, (red, blue, green), strict=True)
    )
    pole = Pole(2.0 * np.cos(1.2), 2.0 * np.sin(1.2), 0.1, (240.0, 200.0, 20.0))
    scene = OmniScene(poles=(pole,), edges=edges)
    rgb = render_omni_image(scene, (0.0, 0.0, 0.0), clean_camera(color=True), rng=0)
    grey = render_omni_image(scene, (0.0, 0.0, 0.0), clean_camera(), rng=0)
    assert rgb.shape == (480, 640, 3) and rgb.dtype == np.uint8
    assert grey.shape == (480, 640)
    cam = clean_camera()
    cx, cy = cam.center
    for bearing_deg, paint in ((40.0, red), (190.0, blue), (300.0, green), (68.75, pole.intensity)):
        phi = np.deg2rad(bearing_deg)
        u = round(cx + cam.radius * 0.6 * np.cos(phi))
        v = round(cy - cam.radius * 0.6 * np.sin(phi))
        assert rgb[v, u].tolist() == [round(c) for c in paint]
        assert grey[v, u] == round(luminance(paint))
    # as_gray of the colour image is the grey image, up to the rounding of each channel.
    from omniloc.vision.calibrate import as_gray

    assert np.max(np.abs(as_gray(rgb) - grey.astype(np.float32))) <= 1.0


def test_luminance() -> None:
    assert luminance(77.0) == 77.0
    assert luminance((77.0, 77.0, 77.0)) == 77.0
    assert luminance((255.0, 0.0, 0.0)) == pytest.approx(0.299 * 255)
    assert luminance((10.0, 20.0, 30.0)) == pytest.approx(0.299 * 10 + 0.587 * 20 + 0.114 * 30)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Pole(0.0, 0.0, 0.1, (10.0, 20.0)), "grey level or"),
        (lambda: Pole(0.0, 0.0, 0.1, (10.0, 300.0, 20.0)), r"\[0, 255\]"),
        (lambda: Pole(0.0, 0.0, 0.1, 256.0), r"\[0, 255\]"),
        (lambda: WallEdge(1.0, 0.0, np.nan), "finite"),
        (lambda: OmniScene(edges=(WallEdge(1, 0, 50.0), WallEdge(0, 1))), "1 of 2 edges"),
        (lambda: OmniScene(edges=(WallEdge(1, 0, 50.0),)), ">= 2 edges"),
    ],
)
def test_bad_paints_raise(make: object, message: str) -> None:
    with pytest.raises(VisionError, match=message):
        make()  # type: ignore[operator]


def test_neighbouring_walls_with_one_level_raise() -> None:
    edges = (WallEdge(3, 0, 100.0), WallEdge(0, 3, 100.0), WallEdge(-3, 0, 150.0))
    with pytest.raises(VisionError, match="same level"):
        render_omni_image(OmniScene(edges=edges), (0.0, 0.0, 0.0))


def test_random_stripe_scene_draws_what_it_promises() -> None:
    step = 30.0
    for seed in range(6):
        # Landmarks 9 deg apart: only the narrow segments are 5-8 deg wide.
        scene, pose = random_stripe_scene(
            seed, n_poles=3, n_segments=4, min_level_step=step, min_separation=np.deg2rad(9.0)
        )
        truth = true_features(scene, pose)
        assert len(truth) == 3 + 4 + 2 * 4  # poles, corners, two edges per narrow segment
        assert truth.ambiguous.size == 0
        assert np.sum(truth.kind == "pole") == 3
        x, y, _ = pose
        # Pole widths as seen from the robot.
        widths = [2 * np.arcsin(p.radius / np.hypot(p.x - x, p.y - y)) for p in scene.poles]
        assert np.all((np.rad2deg(widths) >= 1.6 - 1e-9) & (np.rad2deg(widths) <= 5.0 + 1e-9))
        # Walls in azimuth order: neighbours differ by >= step; exactly 4 are 5-8 deg wide.
        az = np.array([np.arctan2(e.y - y, e.x - x) for e in scene.edges])
        order = np.argsort(az)
        lum = np.array([luminance(scene.edges[i].level) for i in order])
        assert np.all(np.abs(lum - np.roll(lum, 1)) >= step - 1e-6)
        gaps = np.rad2deg(np.diff(np.concatenate([az[order], az[order][:1] + 2 * np.pi])))
        narrow = (gaps >= 5.0 - 1e-9) & (gaps <= 8.0 + 1e-9)
        assert narrow.sum() == 4
        assert np.all(gaps[~narrow] >= 9.0)  # other walls are at least min_separation wide
        # Each pole's level is >= step from the wall behind it.
        for p in scene.poles:
            a = np.arctan2(p.y - y, p.x - x)
            behind = order[np.searchsorted(az[order], a) - 1]
            wall = luminance(scene.edges[behind].level)
            assert abs(luminance(p.intensity) - wall) >= step - 1e-6
    a = random_stripe_scene(3)
    b = random_stripe_scene(np.random.default_rng(3))
    assert a == b


def test_random_stripe_scene_makes_pole_like_segments() -> None:
    # A narrow segment is brighter or darker than both neighbours about 4 times in 5 (81 %
    # over 300 other seeds), else between them: both kinds occur.
    extreme = between = 0
    for seed in range(10):
        scene, pose = random_stripe_scene(seed, min_separation=np.deg2rad(9.0))
        x, y, _ = pose
        az = np.array([np.arctan2(e.y - y, e.x - x) for e in scene.edges])
        order = np.argsort(az)
        lum = np.array([luminance(scene.edges[i].level) for i in order])
        gaps = np.diff(np.concatenate([az[order], az[order][:1] + 2 * np.pi]))
        for k in np.flatnonzero(gaps <= np.deg2rad(8.0) + 1e-9):
            a, b, c = lum[k - 1], lum[k], lum[(k + 1) % len(lum)]
            if (b - a) * (b - c) > 0:
                extreme += 1
            else:
                between += 1
    assert extreme + between == 40
    assert 24 <= extreme <= 38


def test_random_stripe_scene_bad_parameters_raise() -> None:
    with pytest.raises(VisionError, match="n_poles"):
        random_stripe_scene(0, n_poles=-1)
    with pytest.raises(VisionError, match="segment_width"):
        random_stripe_scene(0, segment_width=(0.2, 0.1))
    with pytest.raises(VisionError, match="min_level_step"):
        random_stripe_scene(0, min_level_step=120.0)
    with pytest.raises(VisionError, match="could not draw"):
        random_stripe_scene(0, n_segments=40, max_tries=3)
