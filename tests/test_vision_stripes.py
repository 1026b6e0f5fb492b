"""Tests for telling a pole from a narrow wall segment (omniloc.vision.bearings).

A stripe (a run of azimuth brighter or darker than both sides) is a pole when the background
continues on both sides of it, a narrow wall segment when two different walls meet it, and
undecidable (two edges flagged ``ambiguous``) when its sides match but it is as wide as a
wall segment can be.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from omniloc.angles import angdiff
from omniloc.errors import VisionError
from omniloc.vision import (
    EdgeDetections,
    MirrorCalibration,
    OmniCamera,
    OmniScene,
    Pole,
    WallEdge,
    extract_bearings,
    render_omni_image,
    true_features,
)
from omniloc.vision.render import Paint, random_stripe_scene

POSE = (0.3, -0.2, 0.4)  # theta: bearings are world azimuths minus 0.4 rad
TOL = np.deg2rad(0.1)


def scene_from_bearings(
    walls: Sequence[tuple[float, Paint]], poles: Sequence[tuple[float, float, Paint]] = ()
) -> OmniScene:
    """A scene laid out as seen from POSE, in bearings (degrees).

    Each wall starts at its bearing with its level; each pole is ``(bearing, angular width,
    paint)``, 2 m away.
    """
    x, y, theta = POSE
    edges = []
    for bearing, level in walls:
        a = theta + np.deg2rad(bearing)
        edges.append(WallEdge(x + 4.0 * np.cos(a), y + 4.0 * np.sin(a), level))
    pole_list = []
    for bearing, width, paint in poles:
        a = theta + np.deg2rad(bearing)
        r = 2.0 * np.sin(np.deg2rad(width) / 2)
        pole_list.append(Pole(x + 2.0 * np.cos(a), y + 2.0 * np.sin(a), r, paint))
    return OmniScene(poles=tuple(pole_list), edges=tuple(edges))


def detect(
    scene: OmniScene, *, color: bool = False, mirrored: bool = False, seed: int = 0, **kw: float
) -> EdgeDetections:
    cam = OmniCamera(color=color, mirrored=mirrored, forward=-0.7 if mirrored else 0.3)
    img = render_omni_image(scene, POSE, cam, rng=seed)
    assert img.ndim == (3 if color else 2)
    return extract_bearings(img, forward=cam.forward, mirrored=cam.mirrored, **kw)


def near(det: EdgeDetections, bearing_deg: float, within_deg: float) -> np.ndarray:
    err = np.abs(np.asarray(angdiff(det.bearings, np.deg2rad(bearing_deg))))
    return err < np.deg2rad(within_deg)


def assert_edge_at(
    det: EdgeDetections, bearing_deg: float, *, ambiguous: bool, tol: float = TOL
) -> None:
    err = np.abs(np.asarray(angdiff(det.bearings, np.deg2rad(bearing_deg))))
    k = int(np.argmin(err))
    assert err[k] < tol, f"no detection within {np.rad2deg(tol):.2f} deg of {bearing_deg} deg"
    assert det.kind[k] == "edge"
    assert bool(det.ambiguous[k]) is ambiguous


# Four walls around the robot; the narrow segment (or pole) is put at bearing 40-47 deg.
CORNERS = (-140.0, -50.0, 100.0)


@pytest.mark.parametrize(
    ("width", "left", "segment", "right", "color", "mirrored"),
    [
        (5.5, 100.0, 180.0, 140.0, False, False),  # brighter than both sides, 40 apart
        (5.5, 100.0, 180.0, 140.0, True, False),
        (7.9, 100.0, 180.0, 140.0, False, True),
        (6.2, 170.0, 60.0, 130.0, False, False),  # darker than both sides
        (6.2, 170.0, 60.0, 130.0, True, True),
        (5.2, 100.0, 160.0, 115.0, False, False),  # sides 15 apart (steps 60 and 45)
        (5.2, 100.0, 160.0, 115.0, False, True),
    ],
)
def test_narrow_segment_between_different_walls_is_two_edges(
    width: float, left: float, segment: float, right: float, color: bool, mirrored: bool
) -> None:
    # The old rule (opposite steps closer than 8 deg whose sizes differ by <= 60 %) read
    # every one of these as one pole at 40 + width / 2.
    walls = [(CORNERS[0], 70.0), (CORNERS[1], left), (40.0, segment), (40.0 + width, right)]
    walls.append((CORNERS[2], 210.0))
    det = detect(scene_from_bearings(walls), color=color, mirrored=mirrored)
    assert len(det) == 5
    assert not np.any(det.kind == "pole")
    assert_edge_at(det, 40.0, ambiguous=False)
    assert_edge_at(det, 40.0 + width, ambiguous=False)
    assert not det.ambiguous.any()


@pytest.mark.parametrize(
    ("width", "paint", "wall", "color", "mirrored"),
    [
        (1.6, 25.0, 120.0, False, False),
        (1.6, 235.0, 120.0, True, True),
        (5.0, 25.0, 120.0, False, False),
        (5.0, 25.0, 120.0, False, True),
        (5.0, (250.0, 200.0, 40.0), 90.0, True, False),  # a yellow pole
        (3.3, 150.0, 110.0, False, False),  # low contrast: 40 grey levels
        (3.3, 150.0, 110.0, True, True),
    ],
)
def test_pole_is_one_pole_at_its_centre(
    width: float, paint: Paint, wall: float, color: bool, mirrored: bool
) -> None:
    walls = [(CORNERS[0], 70.0), (CORNERS[1], wall), (CORNERS[2], 210.0)]
    det = detect(scene_from_bearings(walls, [(43.0, width, paint)]), color=color, mirrored=mirrored)
    close = near(det, 43.0, 5.0)
    assert close.sum() == 1
    assert det.kind[close][0] == "pole"
    assert abs(float(angdiff(det.bearings[close][0], np.deg2rad(43.0)))) < TOL
    assert not det.ambiguous.any()
    assert len(det) == 4


@pytest.mark.parametrize(("color", "mirrored"), [(False, False), (True, True)])
def test_undecidable_stripe_is_two_marked_edges(color: bool, mirrored: bool) -> None:
    # A 6.5 deg segment between two walls of the same level, and a 6.5 deg pole in front of
    # one wall: the image shows the same thing for both, so both give two flagged edges.
    walls = [(CORNERS[0], 70.0), (CORNERS[1], 120.0), (40.0, 30.0), (46.5, 120.0)]
    walls.append((CORNERS[2], 210.0))
    segment = detect(scene_from_bearings(walls), color=color, mirrored=mirrored)
    plain = [(CORNERS[0], 70.0), (CORNERS[1], 120.0), (CORNERS[2], 210.0)]
    pole = detect(scene_from_bearings(plain, [(43.25, 6.5, 30.0)]), color=color, mirrored=mirrored)
    for det in (segment, pole):
        assert len(det) == 5
        assert not np.any(det.kind == "pole")
        assert_edge_at(det, 40.0, ambiguous=True)
        assert_edge_at(det, 46.5, ambiguous=True)
        assert det.ambiguous.sum() == 2
        for corner in CORNERS:
            assert_edge_at(det, corner, ambiguous=False)


def test_colour_tells_walls_of_one_grey_apart() -> None:
    # Both sides of the segment have the grey level 104.5; one is brown, one grey. A grey
    # image cannot tell the segment from a pole; a colour image can.
    brown = (150.0, 90.0, 60.0)
    grey = 0.299 * 150.0 + 0.587 * 90.0 + 0.114 * 60.0
    walls = [(CORNERS[0], 70.0), (CORNERS[1], brown), (40.0, 30.0), (46.5, grey)]
    walls.append((CORNERS[2], 210.0))
    scene = scene_from_bearings(walls)
    in_grey = detect(scene)
    in_colour = detect(scene, color=True)
    for det, flagged in ((in_grey, True), (in_colour, False)):
        assert len(det) == 5
        assert_edge_at(det, 40.0, ambiguous=flagged)
        assert_edge_at(det, 46.5, ambiguous=flagged)


def test_same_sign_narrow_segment_is_two_plain_edges() -> None:
    # A segment between a darker and a brighter wall: two steps of one sign, no stripe.
    walls = [(CORNERS[0], 70.0), (CORNERS[1], 100.0), (40.0, 140.0), (45.5, 180.0)]
    walls.append((CORNERS[2], 220.0))
    det = detect(scene_from_bearings(walls))
    assert len(det) == 5
    assert_edge_at(det, 40.0, ambiguous=False)
    assert_edge_at(det, 45.5, ambiguous=False)


def test_min_segment_width_sets_the_widest_sure_pole() -> None:
    # With segments assumed at least 8 deg wide, a balanced 6.5 deg stripe is a pole again;
    # with segments from 3 deg, a balanced 4 deg pole is undecidable.
    plain = [(CORNERS[0], 70.0), (CORNERS[1], 120.0), (CORNERS[2], 210.0)]
    wide = scene_from_bearings(plain, [(43.25, 6.5, 30.0)])
    det = detect(wide, min_segment_width=np.deg2rad(8.0))
    assert det.kind[near(det, 43.25, 5.0)].tolist() == ["pole"]
    narrow = scene_from_bearings(plain, [(43.0, 4.0, 30.0)])
    det = detect(narrow, min_segment_width=np.deg2rad(3.0))
    close = near(det, 43.0, 5.0)
    assert det.kind[close].tolist() == ["edge", "edge"]
    assert det.ambiguous[close].all()


def test_pole_next_to_a_wall_edge_is_still_a_pole() -> None:
    # The wall edge 1.5 deg from the pole's border leaves no room to see that side: the
    # balance of the two steps decides. (The blur of the pole pulls the edge by ~0.2 deg.)
    walls = [(CORNERS[0], 70.0), (CORNERS[1], 110.0), (38.5, 160.0), (CORNERS[2], 210.0)]
    det = detect(scene_from_bearings(walls, [(42.0, 4.0, 25.0)]))
    assert det.kind[near(det, 42.0, 3.0)].tolist() == ["pole"]
    assert abs(float(angdiff(det.bearings[near(det, 42.0, 3.0)][0], np.deg2rad(42.0)))) < TOL
    assert_edge_at(det, 38.5, ambiguous=False, tol=np.deg2rad(0.5))


def test_colour_image_with_the_rim_partly_outside() -> None:
    # The rim's centre is 60 px from the top: every panorama row leaves the image somewhere,
    # and the side levels must ignore those samples. The segment is turned to face down
    # (image angle -90 deg), inside the image.
    walls = [(CORNERS[0], 70.0), (CORNERS[1], 100.0), (40.0, 180.0), (46.0, 140.0)]
    walls.append((CORNERS[2], 210.0))
    cam = OmniCamera(color=True, center=(330.0, 60.0), radius=230.0, forward=np.deg2rad(-133.0))
    img = render_omni_image(scene_from_bearings(walls), POSE, cam, rng=4)
    cal = MirrorCalibration(cam.center, cam.aspect, cam.radius)
    det = extract_bearings(img, calibration=cal, forward=cam.forward)
    assert not np.any(det.kind[near(det, 43.0, 5.0)] == "pole")
    assert_edge_at(det, 40.0, ambiguous=False)
    assert_edge_at(det, 46.0, ambiguous=False)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_random_stripe_scenes_are_read_right(seed: int) -> None:
    rng = np.random.default_rng(seed)
    scene, pose = random_stripe_scene(rng)
    cam = OmniCamera(
        forward=float(rng.uniform(-np.pi, np.pi)), mirrored=seed % 2 == 1, color=seed >= 2
    )
    det = extract_bearings(
        render_omni_image(scene, pose, cam, rng=rng), forward=cam.forward, mirrored=cam.mirrored
    )
    truth = true_features(scene, pose)
    err = np.abs(np.asarray(angdiff(det.bearings[:, None], truth.bearings[None, :])))
    assert len(det) == len(truth) == 16
    assert np.all(err.min(axis=0) < np.deg2rad(0.2))  # every edge and pole found
    assert det.kind[err.argmin(axis=0)].tolist() == truth.kind.tolist()


def test_ambiguous_flags_are_checked() -> None:
    cal = MirrorCalibration((320.0, 240.0), 1.0, 200.0)
    base = {
        "bearings": np.array([0.1, 0.2]),
        "strength": np.array([30.0, 40.0]),
        "kind": np.array(["edge", "edge"]),
        "image_angles": np.array([0.1, 0.2]),
        "calibration": cal,
    }
    assert EdgeDetections(**base).ambiguous.tolist() == [False, False]
    flagged = EdgeDetections(**base, ambiguous=np.array([True, True]))
    assert flagged.ambiguous.tolist() == [True, True]
    with pytest.raises(ValueError, match="read-only"):
        flagged.ambiguous[0] = False
    with pytest.raises(VisionError, match="expected 2, got 3"):
        EdgeDetections(**base, ambiguous=np.array([True, False, True]))


def test_min_segment_width_must_be_non_negative() -> None:
    img = render_omni_image(scene_from_bearings([(0.0, 60.0), (120.0, 150.0)]), POSE, rng=0)
    with pytest.raises(VisionError, match="min_segment_width"):
        extract_bearings(img, min_segment_width=-0.1)
