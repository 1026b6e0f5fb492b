"""Tests for omniloc.vision.bearings: image -> bearings."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from omniloc.angles import angdiff, wrap
from omniloc.errors import VisionError
from omniloc.vision import (
    DEMO_POSE,
    EdgeDetections,
    MirrorCalibration,
    OmniCamera,
    OmniScene,
    Pole,
    WallEdge,
    bearings_from_image,
    calibrate_mirror,
    demo_scene,
    extract_bearings,
    load_image,
    render_omni_image,
    true_features,
    unwrap_panorama,
)

TOL = np.deg2rad(0.5)
ROOM = (WallEdge(-4, -3), WallEdge(4, -3), WallEdge(4, 3), WallEdge(-4, 3))


def match(det: EdgeDetections, truth_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-detection error for each truth, and nearest-truth error for each detection."""
    err = np.abs(np.asarray(angdiff(det.bearings[:, None], truth_b[None, :])))
    return err.min(axis=0), err.min(axis=1)


@pytest.fixture(scope="module")
def demo_image() -> np.ndarray:
    return render_omni_image(demo_scene(), DEMO_POSE, rng=1)


@pytest.mark.parametrize(
    ("forward", "mirrored", "aspect"),
    [(0.0, False, 1.0), (np.deg2rad(-70.0), False, 1.04), (2.0, True, 0.96), (0.0, True, 1.0)],
)
def test_bearings_match_truth(forward: float, mirrored: bool, aspect: float) -> None:
    cam = OmniCamera(
        center=(316.3, 243.8), aspect=aspect, radius=210.0, forward=forward, mirrored=mirrored
    )
    img = render_omni_image(demo_scene(), DEMO_POSE, cam, rng=2)
    truth = true_features(demo_scene(), DEMO_POSE)
    det = extract_bearings(img, forward=forward, mirrored=mirrored)
    per_truth, per_det = match(det, truth.bearings)
    assert len(det) == len(truth) == 14
    assert np.all(per_truth < TOL)
    assert np.all(per_det < TOL)
    assert np.median(per_truth) < np.deg2rad(0.1)
    # Same order (both sorted by bearing), same kinds.
    assert det.kind.tolist() == truth.kind.tolist()
    assert np.all((det.bearings >= -np.pi) & (det.bearings < np.pi))


def test_forward_and_mirror_transform_bearings(demo_image: np.ndarray) -> None:
    cal = calibrate_mirror(demo_image)
    plain = extract_bearings(demo_image, calibration=cal)
    turned = extract_bearings(demo_image, calibration=cal, forward=0.3, mirrored=True)
    np.testing.assert_allclose(plain.image_angles, np.sort(plain.image_angles))
    expected = np.sort(np.asarray(wrap(-(plain.image_angles - 0.3))))
    np.testing.assert_allclose(turned.bearings, expected, atol=1e-12)


def _annulus_image(pole_phi_deg: float) -> np.ndarray:
    """A conic mirror's image drawn with numpy alone (not the renderer): walls of four grey
    levels (steps at image angles 45, 160, 240 and 320 deg), one dark pole 3 deg wide at the
    image angle ``pole_phi_deg``."""
    ss, h, w, radius = 4, 480, 640, 200.0
    cx, cy = (w - 1) / 2, (h - 1) / 2
    u = (np.arange(w * ss) - (ss - 1) / 2) / ss - cx
    v = (np.arange(h * ss) - (ss - 1) / 2) / ss - cy
    du, dv = np.meshgrid(u, v)
    phi = np.degrees(np.arctan2(-dv, du)) % 360
    rho = np.hypot(du, dv) / radius
    img = np.select([phi < 45, phi < 160, phi < 240, phi < 320], [190.0, 70.0, 150.0, 100.0], 190.0)
    img[np.abs((phi - pole_phi_deg + 180) % 360 - 180) < 1.5] = 20.0
    img[rho < 0.25] = 45.0
    img[rho > 1] = 10.0
    return np.rint(img.reshape(h, ss, w, ss).mean(axis=(1, 3))).astype(np.uint8)


@pytest.mark.parametrize("mirrored", [False, True])
@pytest.mark.parametrize("forward_deg", [0.0, 60.0, -135.0])
def test_a_pole_on_the_forward_axis_is_at_bearing_zero(mirrored: bool, forward_deg: float) -> None:
    # The definition of `forward`, mirrored or not: the image angle of the robot's forward
    # axis. A pole drawn there is straight ahead; one 30 deg counter-clockwise of it in the
    # image is 30 deg to the left (a plain sensor) or to the right (a mirrored one).
    for offset in (0.0, 30.0):
        img = _annulus_image(forward_deg + offset)
        det = extract_bearings(img, forward=np.deg2rad(forward_deg), mirrored=mirrored)
        poles = det.bearings[det.kind == "pole"]
        assert poles.size == 1
        expected = np.deg2rad(-offset if mirrored else offset)
        assert abs(float(angdiff(poles[0], expected))) < np.deg2rad(0.2)


def test_a_calibration_whose_annulus_is_off_the_image_is_refused(demo_image: np.ndarray) -> None:
    # Another camera's calibration (or a smaller image): a rim of 2,000 px, whose annulus
    # has no pixel on this image, gave no detections and no error.
    far = MirrorCalibration((320.0, 240.0), 1.0, 2000.0)
    with pytest.raises(VisionError, match="wholly outside the 640 x 480 image"):
        extract_bearings(demo_image, calibration=far)
    # Partly off the image is read as far as it goes.
    cal = calibrate_mirror(demo_image)
    half = MirrorCalibration((cal.center[0] + 300.0, cal.center[1]), cal.aspect, cal.radius)
    extract_bearings(demo_image, calibration=half)


def test_pole_reported_once_at_its_centre() -> None:
    pose = (0.2, -0.1, 0.3)
    for bearing_deg, radius, intensity in ((25.0, 0.09, 20.0), (-140.0, 0.05, 245.0)):
        b = np.deg2rad(bearing_deg)
        d = 2.5
        pole = Pole(
            pose[0] + d * np.cos(pose[2] + b), pose[1] + d * np.sin(pose[2] + b), radius, intensity
        )
        scene = OmniScene(poles=(pole,), edges=ROOM)
        det = extract_bearings(render_omni_image(scene, pose, rng=3))
        near = np.abs(np.asarray(angdiff(det.bearings, b))) < np.deg2rad(3.0)
        assert near.sum() == 1
        assert det.kind[near][0] == "pole"
        assert abs(float(angdiff(det.bearings[near][0], b))) < np.deg2rad(0.1)
        assert len(det) == 5  # the pole and the four room corners
        assert np.sum(det.kind == "edge") == 4


def test_given_calibration_center_and_aspect(demo_image: np.ndarray) -> None:
    auto = extract_bearings(demo_image)
    cal = auto.calibration
    given = extract_bearings(demo_image, calibration=cal)
    np.testing.assert_allclose(given.bearings, auto.bearings)
    fixed = extract_bearings(demo_image, center=cal.center, aspect=cal.aspect)
    np.testing.assert_allclose(fixed.bearings, auto.bearings, atol=1e-3)
    assert fixed.calibration.center == cal.center
    # Explicit values override the calibration's.
    other = extract_bearings(demo_image, calibration=cal, aspect=1.02)
    assert other.calibration.aspect == 1.02
    assert other.calibration.radius == cal.radius


def test_input_types_agree(demo_image: np.ndarray) -> None:
    ref = extract_bearings(demo_image)
    rgb = np.repeat(demo_image[:, :, None], 3, axis=2)
    for img in (rgb, demo_image.astype(np.uint16) * 257, demo_image / 255.0):
        det = extract_bearings(img)
        assert len(det) == len(ref)
        np.testing.assert_allclose(det.bearings, ref.bearings, atol=np.deg2rad(0.02))


@pytest.mark.parametrize(("seed", "color"), [(0, False), (1, False), (3, True)])
def test_a_brightness_offset_changes_nothing(seed: int, color: bool) -> None:
    # A zero-centred float image: only the sides' tolerance looked at absolute levels.
    from omniloc.vision.render import random_scene, random_stripe_scene

    scene, pose = (random_stripe_scene if seed % 2 else random_scene)(seed)
    img = render_omni_image(scene, pose, OmniCamera(color=color), rng=seed).astype(np.float64)
    ref = extract_bearings(img)
    det = extract_bearings(img - 128.0)
    assert len(ref) > 5
    np.testing.assert_allclose(det.bearings, ref.bearings, atol=1e-9)
    assert det.kind.tolist() == ref.kind.tolist()
    assert det.ambiguous.tolist() == ref.ambiguous.tolist()


def test_detections_container(demo_image: np.ndarray) -> None:
    det = extract_bearings(demo_image)
    assert len(det) == det.bearings.shape[0] == det.strength.shape[0] == det.kind.shape[0]
    assert det
    assert np.all(det.strength >= 10.0)
    with pytest.raises(ValueError, match="read-only"):
        det.bearings[0] = 0.0
    empty = extract_bearings(render_omni_image(OmniScene(), (0.0, 0.0, 0.0), rng=0))
    assert len(empty) == 0
    assert not empty


def test_load_image_and_bearings_from_path(tmp_path: Path, demo_image: np.ndarray) -> None:
    grey_path = tmp_path / "omni.png"
    cv2.imwrite(str(grey_path), demo_image)
    assert np.array_equal(load_image(grey_path), demo_image)
    colour = np.stack([demo_image, demo_image // 2, demo_image // 3], axis=-1)
    colour_path = tmp_path / "omni_rgb.png"
    cv2.imwrite(str(colour_path), colour[:, :, ::-1])  # OpenCV writes BGR
    assert np.array_equal(load_image(colour_path), colour)  # load_image returns RGB
    ref = extract_bearings(demo_image)
    from_path = bearings_from_image(grey_path)
    np.testing.assert_allclose(from_path.bearings, ref.bearings)
    from_array = bearings_from_image(demo_image, forward=0.2)
    np.testing.assert_allclose(from_array.bearings, np.sort(np.asarray(wrap(ref.bearings - 0.2))))


def _with_exif_orientation(jpeg: bytes, orientation: int) -> bytes:
    """The JPEG with an APP1 Exif segment holding only the orientation tag (0x0112)."""
    tiff = (
        b"MM\x00\x2a\x00\x00\x00\x08"  # big-endian TIFF header, first IFD at 8
        + b"\x00\x01"  # one entry
        + b"\x01\x12\x00\x03\x00\x00\x00\x01"  # Orientation, SHORT, 1 value
        + orientation.to_bytes(2, "big")
        + b"\x00\x00"
        + b"\x00\x00\x00\x00"  # no next IFD
    )
    body = b"Exif\x00\x00" + tiff
    return jpeg[:2] + b"\xff\xe1" + (len(body) + 2).to_bytes(2, "big") + body + jpeg[2:]


def test_load_image_reads_pixels_as_stored(tmp_path: Path) -> None:
    # docs/vision.md: the EXIF orientation is not applied (u, v, phi are the stored pixels').
    img = np.zeros((40, 60), np.uint8)
    img[5:15, 10:50] = 200
    ok, jpeg = cv2.imencode(".jpg", img)
    assert ok
    path = tmp_path / "rotated.jpg"
    path.write_bytes(_with_exif_orientation(jpeg.tobytes(), 6))  # "rotate 90 deg to view"
    assert cv2.imread(str(path), cv2.IMREAD_GRAYSCALE).shape == (60, 40)  # a viewer turns it
    stored = load_image(path)
    assert stored.shape == (40, 60)
    assert np.abs(stored.astype(int) - img).max() < 20


def test_unreadable_files_raise(tmp_path: Path) -> None:
    with pytest.raises(VisionError, match="no such file"):
        load_image(tmp_path / "missing.png")
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"this is not a PNG")
    with pytest.raises(VisionError, match="cannot read image"):
        bearings_from_image(junk)
    empty = tmp_path / "empty.jpg"
    empty.write_bytes(b"")
    with pytest.raises(VisionError, match="cannot read image"):
        load_image(empty)
    with pytest.raises(VisionError, match="is a directory"):
        load_image(tmp_path)
    with pytest.raises(VisionError, match="is a directory"):
        bearings_from_image(tmp_path)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"aspect": 0.0}, "aspect"),
        ({"aspect": -2.0}, "aspect"),
        ({"aspect": 12.0}, "aspect"),
        ({"center": (640.0, 100.0)}, "outside"),
        ({"center": (10.0, -5.0)}, "outside"),
        ({"center": (np.nan, 3.0)}, "finite"),
        ({"center": "middle"}, "center"),
        ({"forward": np.nan}, "forward"),
        ({"min_contrast": -1.0}, "min_contrast"),
        ({"radial_range": (0.9, 0.5)}, "radial_range"),
        ({"calibration": (320, 240, 1.0)}, "MirrorCalibration"),
        ({"calibration": MirrorCalibration((900.0, 10.0), 1.0, 50.0)}, "outside"),
    ],
)
def test_bad_parameters_raise(
    kwargs: dict[str, object], message: str, demo_image: np.ndarray
) -> None:
    with pytest.raises(VisionError, match=message):
        extract_bearings(demo_image, **kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((480, 640), np.uint8), "no mirror rim"),
        (np.full((200, 200), np.nan), "NaN"),
        (np.zeros((3, 4, 5, 6)), "2-D"),
        (None, "numbers"),
        ([[1, 2], [3]], "not rectangular"),
        ([[[1, 2, 3]] * 20] * 19 + [[[1, 2]] * 20], "not rectangular"),
    ],
)
def test_bad_images_raise(image: object, message: str) -> None:
    with pytest.raises(VisionError, match=message):
        extract_bearings(image)
    with pytest.raises(VisionError, match=message):
        calibrate_mirror(image)


def test_panorama_layout(demo_image: np.ndarray) -> None:
    cal = calibrate_mirror(demo_image)
    pano = unwrap_panorama(demo_image, cal, n_rows=10, n_cols=720)
    assert pano.shape == (10, 720)
    # Column j is image angle 2 pi j / n: check against the pixel there.
    for j in (0, 100, 333):
        u, v = cal.pixel(2 * np.pi * j / 720, 0.95)
        assert abs(float(pano[-1, j]) - float(demo_image[round(v), round(u)])) < 25


def test_end_to_end_localization(demo_image: np.ndarray) -> None:
    search = pytest.importorskip("omniloc.search")
    scene = demo_scene()
    det = extract_bearings(demo_image)
    result = search.localize(scene.landmarks_xy, det.bearings, sigma=np.deg2rad(0.1))
    assert result
    pose = result.best.pose
    assert np.hypot(pose.x - DEMO_POSE[0], pose.y - DEMO_POSE[1]) < 0.1
    assert abs(float(angdiff(pose.theta, DEMO_POSE[2]))) < np.deg2rad(1.0)
