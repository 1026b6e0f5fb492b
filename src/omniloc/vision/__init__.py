"""Omnidirectional vision front end: image of a conic mirror -> landmark bearings.

Vertical edges of the room (door frames, wall corners, poles) are radial lines in the image
of a camera looking at a conic mirror along its axis, so their image angles are bearings
(seed paper, section 1). This package finds the mirror rim (:func:`calibrate_mirror`),
extracts the bearings of radial edges and poles (:func:`extract_bearings`) and renders
synthetic images with known truth (:func:`render_omni_image`, :func:`true_features`). It knows
nothing of the search and draws nothing: the figures are in :mod:`omniloc.plot.vision`.
Conventions are in ``docs/vision.md``.
"""

from __future__ import annotations

from omniloc.vision.bearings import (
    EdgeDetections,
    bearings_from_image,
    extract_bearings,
    load_image,
    unwrap_panorama,
)
from omniloc.vision.calibrate import MirrorCalibration, calibrate_mirror
from omniloc.vision.render import (
    DEMO_CAMERA,
    DEMO_POSE,
    OmniCamera,
    OmniScene,
    Paint,
    Pole,
    TrueFeatures,
    WallEdge,
    demo_scene,
    luminance,
    random_scene,
    random_stripe_scene,
    render_omni_image,
    true_features,
)

__all__ = [
    "DEMO_CAMERA",
    "DEMO_POSE",
    "EdgeDetections",
    "MirrorCalibration",
    "OmniCamera",
    "OmniScene",
    "Paint",
    "Pole",
    "TrueFeatures",
    "WallEdge",
    "bearings_from_image",
    "calibrate_mirror",
    "demo_scene",
    "extract_bearings",
    "load_image",
    "luminance",
    "random_scene",
    "random_stripe_scene",
    "render_omni_image",
    "true_features",
    "unwrap_panorama",
]
