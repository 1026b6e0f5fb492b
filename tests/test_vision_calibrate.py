"""Tests for omniloc.vision.calibrate: finding the mirror rim."""

from __future__ import annotations

import numpy as np
import pytest

from omniloc.errors import VisionError
from omniloc.vision import (
    DEMO_POSE,
    MirrorCalibration,
    OmniCamera,
    OmniScene,
    calibrate_mirror,
    demo_scene,
    random_scene,
    render_omni_image,
)
from omniloc.vision.calibrate import _check_rim_sides, as_gray


def render(cam: OmniCamera, seed: int = 0) -> np.ndarray:
    return render_omni_image(demo_scene(), DEMO_POSE, cam, rng=seed)


def assert_close(cal: MirrorCalibration, cam: OmniCamera) -> None:
    np.testing.assert_allclose(cal.center, cam.center, atol=0.5)
    assert abs(cal.aspect / cam.aspect - 1) < 0.005
    assert abs(cal.radius - cam.radius) < 0.5


@pytest.mark.parametrize(
    ("size", "center", "aspect", "radius"),
    [
        ((640, 480), (321.7, 238.4), 1.0, 215.0),
        ((640, 480), (300.2, 251.9), 1.07, 205.0),
        ((640, 480), (338.8, 229.1), 0.94, 220.0),
        ((517, 389), (260.3, 190.6), 1.02, 170.0),  # odd size
        ((301, 403), (150.9, 200.2), 0.7, 185.0),  # portrait, squashed along u
    ],
)
def test_recovers_rim(
    size: tuple[int, int], center: tuple[float, float], aspect: float, radius: float
) -> None:
    cam = OmniCamera(image_size=size, center=center, aspect=aspect, radius=radius)
    img = render(cam, seed=len(size) + int(center[0]))
    assert_close(calibrate_mirror(img), cam)


def test_colour_uint16_and_float_inputs_agree() -> None:
    cam = OmniCamera(center=(310.4, 244.7), aspect=1.03, radius=208.0)
    grey = render(cam, seed=3)
    colour = np.stack([grey, (grey * 0.8).astype(np.uint8), (grey * 0.6).astype(np.uint8)], -1)
    for img in (colour, grey.astype(np.uint16) * 257, grey / 255.0, grey[:, :, None]):
        assert_close(calibrate_mirror(img), cam)


def test_given_parameters_are_held_fixed() -> None:
    cam = OmniCamera(center=(315.0, 240.0), aspect=1.05, radius=200.0)
    img = render(cam, seed=4)
    cal = calibrate_mirror(img, aspect=1.05)
    assert cal.aspect == 1.05
    assert_close(cal, cam)
    cal = calibrate_mirror(img, center=(315.0, 240.0))
    assert cal.center == (315.0, 240.0)
    assert_close(cal, cam)
    full = calibrate_mirror(img, center=(1.0, 2.0), aspect=2.0, radius=30.0)
    assert full == MirrorCalibration((1.0, 2.0), 2.0, 30.0)


def test_bright_outside_dark_mirror() -> None:
    cam = OmniCamera(center=(330.0, 236.0), aspect=1.02, radius=200.0, background_level=250.0)
    img = 255 - render(cam, seed=8)  # everything inverted: the outside is now bright
    assert_close(calibrate_mirror(img), cam)


def dim_room(seed: int, wall_levels: tuple[float, ...]) -> tuple[np.ndarray, OmniCamera]:
    """A dim room (walls 6-36 grey levels above the outside) with a bright camera reflection."""
    scene, pose = random_scene(seed)
    dim = OmniScene(poles=scene.poles, edges=scene.edges, wall_levels=wall_levels)
    cam = OmniCamera(camera_level=220.0, background_level=8.0)
    return render_omni_image(dim, pose, cam, rng=seed), cam


# Rooms of /work/diag/s36/h3/repro_dim_rim.py and its sweep: the first five were fitted
# silently wrong (the camera disc, aspect 2, radius 98; the hull of bright poles); 0 was
# refused, 1 was calibrated correctly.
DIM_ROOMS = [
    (5, (14.0, 28.0, 32.0, 36.0, 38.0)),
    (8, (19.0, 20.0, 23.0, 33.0, 43.0)),
    (24, (22.0, 24.0, 27.0, 31.0, 43.0)),
    (25, (18.0, 21.0, 21.0, 23.0, 41.0)),
    (28, (18.0, 26.0, 31.0, 32.0, 39.0)),
    (0, (14.0, 15.0, 22.0, 33.0, 38.0)),
    (1, (30.0, 32.0, 36.0, 41.0, 42.0)),
]


@pytest.mark.parametrize(("seed", "wall_levels"), DIM_ROOMS)
def test_dim_walls_count_as_mirror(seed: int, wall_levels: tuple[float, ...]) -> None:
    # Calibrated correctly, not just refused (before, five of these were fitted silently
    # wrong, and then refused): the mirror mask's threshold comes from the typical mirror
    # pixel, not from the bright camera disc.
    img, cam = dim_room(seed, wall_levels)
    assert_close(calibrate_mirror(img), cam)


def test_fit_with_mirror_outside_it_is_refused() -> None:
    img, cam = dim_room(5, DIM_ROOMS[0][1])
    gray = as_gray(img)
    (cx, cy), r = cam.center, cam.radius
    _check_rim_sides(gray, cx, cy, r, 1.0)  # the true rim passes
    # The camera's reflection: a perfect ellipse, with the room's walls just outside it.
    with pytest.raises(VisionError, match="outside the fitted ellipse"):
        _check_rim_sides(gray, cx, cy, cam.inner_radius * r, 1.0)
    # The wrong fit the report found (centre (350.2, 195.4), aspect 1.997, radius 98.6).
    with pytest.raises(VisionError, match="image border's level"):
        _check_rim_sides(gray, 350.2, 195.4, 98.6, 1.997)


def test_calibrate_mirror_refuses_a_rim_fitted_on_the_camera_s_reflection(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The rough ellipse put on the camera's bright reflection (as a dim room made it before
    # the mask's threshold came from the typical mirror pixel): the refinement fits that
    # disc to the pixel, and only the check of the rim's two sides tells it is no rim.
    import omniloc.vision.calibrate as calibrate

    img, cam = dim_room(5, DIM_ROOMS[0][1])
    rough = calibrate._rough_ellipse(as_gray(img))
    disc = (cam.center[0], cam.center[1], cam.inner_radius * cam.radius, 1.0, rough[4])
    monkeypatch.setattr(calibrate, "_rough_ellipse", lambda gray: disc)
    with pytest.raises(VisionError, match="no clear mirror rim"):
        calibrate_mirror(img)


def test_calibration_helpers() -> None:
    cal = MirrorCalibration((100.0, 80.0), 1.25, 40.0)
    assert cal.semi_axes == (50.0, 40.0)
    for phi in np.linspace(-3, 3, 7):
        u, v = cal.pixel(float(phi), 0.8)
        assert abs(cal.image_angle(u, v) - phi) < 1e-12


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((100, 120), np.uint8), "no mirror rim"),
        (np.full((100, 120, 3), 77, np.uint8), "no mirror rim"),
        (np.full((100, 120), np.nan), "NaN"),
        (np.zeros(100), "2-D"),
        (np.zeros((50, 60, 5)), "channels"),
        (np.zeros((8, 8)), "too small"),
        (np.array([["a"] * 20] * 20), "numbers"),
    ],
)
def test_bad_images_raise(image: np.ndarray, message: str) -> None:
    with pytest.raises(VisionError, match=message):
        calibrate_mirror(image)


def test_noise_without_rim_raises() -> None:
    noise = np.random.default_rng(0).normal(128, 3, size=(120, 160)).clip(0, 255)
    with pytest.raises(VisionError, match="no mirror rim"):
        calibrate_mirror(noise.astype(np.uint8))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"aspect": 0.0}, r"aspect must be in \(0, 10\]"),
        ({"aspect": -1.0}, "aspect"),
        ({"aspect": 10.5}, "aspect"),
        ({"aspect": float("nan")}, "finite"),
        ({"center": (700.0, 100.0)}, "outside the 640x480 image"),
        ({"center": (-1.0, 100.0)}, "outside"),
        ({"center": (float("nan"), 100.0)}, "finite"),
        ({"center": (1.0, 2.0, 3.0)}, "2 values"),
        ({"radius": 0.0}, "radius"),
    ],
)
def test_absurd_parameters_raise(kwargs: dict[str, object], message: str) -> None:
    img = np.zeros((480, 640), np.uint8)
    with pytest.raises(VisionError, match=message):
        calibrate_mirror(img, **kwargs)  # type: ignore[arg-type]


def test_bad_calibration_values_raise() -> None:
    with pytest.raises(VisionError, match="aspect"):
        MirrorCalibration((1.0, 1.0), 0.0, 10.0)
    with pytest.raises(VisionError, match="radius"):
        MirrorCalibration((1.0, 1.0), 1.0, -10.0)
    with pytest.raises(VisionError, match="finite"):
        MirrorCalibration((np.inf, 1.0), 1.0, 10.0)
