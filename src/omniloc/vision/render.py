"""Synthetic omnidirectional images with known truth, for tests, benchmarks and demos.

The renderer is the exact inverse of the conventions used by :mod:`omniloc.vision.bearings`:
a pixel ``(u, v)`` (u = column to the right, v = row downward, (0, 0) the centre of the
top-left pixel) has the image angle ``phi = atan2(-(v - cy) * aspect, u - cx)`` and the
normalised elliptic radius ``rho = hypot((u - cx) / (aspect * radius), (v - cy) / radius)``
(1 on the mirror rim). It shows what the robot sees at the bearing
``wrap(s * (phi - forward))`` with ``s = -1`` for a mirrored sensor, else ``+1``.

The scene model is deliberately simple: every landmark is a vertical structure seen over the
whole mirror annulus. Wall edges (corners, door frames) are steps in the brightness of a
background wall; poles are cylinders of uniform brightness painted over the wall, nearer ones
over farther ones. The wall carries horizontal bands and a weak random texture that vary with
the radius but not coherently along it, so they produce no radial lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from omniloc.angles import wrap
from omniloc.errors import VisionError
from omniloc.io import finite_number, shorten

__all__ = [
    "DEMO_CAMERA",
    "DEMO_POSE",
    "OmniCamera",
    "OmniScene",
    "Paint",
    "Pole",
    "TrueFeatures",
    "WallEdge",
    "demo_scene",
    "luminance",
    "random_scene",
    "random_stripe_scene",
    "render_omni_image",
    "true_features",
]

_PROFILE_BINS = 1 << 18  # world azimuth table resolution: 0.0014 deg per bin
_SUPERSAMPLE = 3  # odd, so sub-sample offsets are symmetric about each pixel centre


def _finite(name: str, value: float) -> float:
    return finite_number(value, name, VisionError)


def _pair(name: str, value: object) -> tuple[float, float]:
    """Two finite numbers, or a VisionError naming ``name``."""
    if (
        isinstance(value, str | bytes)
        or not isinstance(value, tuple | list | np.ndarray)
        or np.ndim(value) != 1
    ):
        raise VisionError(f"{name} must be a pair of numbers, got {shorten(value)}")
    if len(value) != 2:
        raise VisionError(f"{name} must be a pair of numbers, got {len(value)} values")
    return _finite(name, value[0]), _finite(name, value[1])


#: A surface's paint: a grey level in [0, 255], or an RGB colour ``(r, g, b)`` in [0, 255].
#: A grey camera sees a colour's luminance ``0.299 r + 0.587 g + 0.114 b`` (the weights
#: :func:`omniloc.vision.calibrate.as_gray` uses); a grey level ``g`` is the colour ``(g, g, g)``.
Paint = float | tuple[float, float, float]

_LUMA = (0.299, 0.587, 0.114)


def _check_paint(name: str, value: object) -> Paint:
    """A grey level or an RGB triple, finite and in [0, 255]; raises VisionError otherwise."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, (tuple, list, np.ndarray)):
        if len(value) != 3:
            raise VisionError(f"{name} must be a grey level or (r, g, b), got {len(value)} values")
        rgb = tuple(_finite(name, v) for v in value)
        if not all(0 <= v <= 255 for v in rgb):
            raise VisionError(f"{name} must lie in [0, 255], got {rgb}")
        return (rgb[0], rgb[1], rgb[2])
    grey = _finite(name, value)  # type: ignore[arg-type]
    if not 0 <= grey <= 255:
        raise VisionError(f"{name} must be in [0, 255], got {grey}")
    return grey


def _rgb(paint: Paint) -> tuple[float, float, float]:
    return paint if isinstance(paint, tuple) else (paint, paint, paint)


def luminance(paint: Paint) -> float:
    """The grey level a grey camera sees for `paint` (a grey level is returned unchanged).

    Parameters
    ----------
    paint : float or tuple of 3 float
        A grey level, or an RGB colour, in [0, 255].

    Returns
    -------
    float
        ``0.299 r + 0.587 g + 0.114 b`` (exactly ``g`` for a grey ``(g, g, g)``).

    Examples
    --------
    >>> luminance(120.0), round(luminance((200.0, 100.0, 50.0)), 3)
    (120.0, 124.2)
    """
    r, g, b = _rgb(paint)
    if r == g == b:
        return float(r)
    return _LUMA[0] * r + _LUMA[1] * g + _LUMA[2] * b


@dataclass(frozen=True)
class Pole:
    """A vertical cylinder seen as a narrow stripe.

    Parameters
    ----------
    x, y : float
        Position of the axis in the world frame, metres.
    radius : float
        Radius in metres (> 0).
    intensity : float or tuple of 3 float
        Paint of the pole: a grey level in [0, 255] or an RGB colour (see :data:`Paint`).
    """

    x: float
    y: float
    radius: float = 0.05
    intensity: Paint = 30.0

    def __post_init__(self) -> None:
        for name in ("x", "y", "radius"):
            _finite(f"pole {name}", getattr(self, name))
        if not self.radius > 0:
            raise VisionError(f"pole radius must be > 0 m, got {self.radius}")
        object.__setattr__(self, "intensity", _check_paint("pole intensity", self.intensity))


@dataclass(frozen=True)
class WallEdge:
    """A vertical edge of the wall (a corner, a door frame): a step in wall brightness.

    Parameters
    ----------
    x, y : float
        Position in the world frame, metres.
    level : float or tuple of 3 float, optional
        Paint (grey level or RGB colour, see :data:`Paint`) of the wall that starts at this
        edge and runs counter-clockwise, as seen from the robot, to the next edge. Give it
        for every edge of a scene or for none (then the scene's ``wall_levels`` are used in
        turn).
    """

    x: float
    y: float
    level: Paint | None = None

    def __post_init__(self) -> None:
        _finite("wall edge x", self.x)
        _finite("wall edge y", self.y)
        if self.level is not None:
            object.__setattr__(self, "level", _check_paint("wall edge level", self.level))


@dataclass(frozen=True)
class OmniScene:
    """Landmarks of a synthetic room.

    Parameters
    ----------
    poles : tuple of Pole
        Cylinders, painted over the wall (nearer over farther).
    edges : tuple of WallEdge
        Vertical wall edges. Seen from the robot, the wall between two consecutive edges
        (in azimuth) has the ``level`` of the edge where it starts (clockwise end) if the
        edges carry levels, else one grey level taken in turn from `wall_levels`, chosen so
        that neighbouring segments always differ.
    wall_levels : tuple of float
        At least three distinct grey levels in [0, 255] for the wall segments (used when the
        edges carry no levels of their own).
    """

    poles: tuple[Pole, ...] = ()
    edges: tuple[WallEdge, ...] = ()
    wall_levels: tuple[float, ...] = (70.0, 105.0, 140.0, 175.0, 210.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "poles", tuple(self.poles))
        object.__setattr__(self, "edges", tuple(self.edges))
        object.__setattr__(self, "wall_levels", tuple(float(w) for w in self.wall_levels))
        if not all(isinstance(p, Pole) for p in self.poles):
            raise VisionError("scene poles must be Pole instances")
        if not all(isinstance(e, WallEdge) for e in self.edges):
            raise VisionError("scene edges must be WallEdge instances")
        if len(set(self.wall_levels)) < 3:
            raise VisionError(
                f"wall_levels needs at least 3 distinct grey levels, got {self.wall_levels}"
            )
        if not all(0 <= w <= 255 for w in self.wall_levels):
            raise VisionError(f"wall_levels must lie in [0, 255], got {self.wall_levels}")
        n_levels = sum(e.level is not None for e in self.edges)
        if 0 < n_levels < len(self.edges):
            raise VisionError(
                f"wall edge levels must be given for every edge or for none: "
                f"{n_levels} of {len(self.edges)} edges have one"
            )
        if n_levels == 1:
            raise VisionError("a wall with one edge has no second wall: levels need >= 2 edges")

    @property
    def landmarks_xy(self) -> NDArray[np.float64]:
        """All landmark positions, poles first then edges, shape (n, 2), metres."""
        pts = [(p.x, p.y) for p in self.poles] + [(e.x, e.y) for e in self.edges]
        return np.asarray(pts, dtype=np.float64).reshape(-1, 2)

    @property
    def kinds(self) -> tuple[str, ...]:
        """``"pole"`` or ``"edge"`` for each row of :attr:`landmarks_xy`."""
        return ("pole",) * len(self.poles) + ("edge",) * len(self.edges)


@dataclass(frozen=True)
class OmniCamera:
    """A camera looking at a conic mirror along its axis.

    Parameters
    ----------
    image_size : tuple of int
        ``(width, height)`` in pixels.
    center : tuple of float
        Rim centre ``(cx, cy)`` in pixels.
    aspect : float
        Rim semi-axis along u divided by rim semi-axis along v, in (0, 10].
    radius : float
        Rim semi-axis along v, pixels.
    inner_radius : float
        Radius of the camera's own reflection, as a fraction of the rim (0 <= . < 1).
    elevation_range : tuple of float
        Elevation in radians seen at `inner_radius` and at the rim (linear in between);
        the wall's horizontal bands are placed in elevation.
    forward : float
        Image angle of the robot's forward axis, radians.
    mirrored : bool
        True if the mirror flips the sense of rotation (bearing = forward - phi).
    blur_sigma : float
        Gaussian blur in pixels (0 for none).
    noise_sigma : float
        Standard deviation of additive Gaussian noise, grey levels.
    lighting_gradient : tuple of float
        Relative brightness change per rim radius along u and along v.
    texture_sigma : float
        Amplitude of the random wall texture, grey levels.
    background_level, camera_level : float
        Grey levels outside the rim and of the camera's reflection.
    color : bool
        True for an RGB camera: :func:`render_omni_image` returns ``(H, W, 3)`` and every
        paint keeps its colour; False for a grey camera, which sees each paint's luminance.
        Noise is drawn per channel, texture and lighting are the same in all channels.
    """

    image_size: tuple[int, int] = (640, 480)
    center: tuple[float, float] = (321.7, 238.4)
    aspect: float = 1.0
    radius: float = 215.0
    inner_radius: float = 0.28
    elevation_range: tuple[float, float] = (-0.6, 0.35)
    forward: float = 0.0
    mirrored: bool = False
    blur_sigma: float = 0.8
    noise_sigma: float = 2.0
    lighting_gradient: tuple[float, float] = (0.08, -0.05)
    texture_sigma: float = 3.0
    background_level: float = 12.0
    camera_level: float = 45.0
    color: bool = False

    def __post_init__(self) -> None:
        fw, fh = _pair("image_size", self.image_size)
        if not (fw.is_integer() and fh.is_integer() and 16 <= min(fw, fh) <= max(fw, fh) <= 20000):
            raise VisionError(
                f"image_size must be whole pixels between 16 and 20000, got {(fw, fh)}"
            )
        w, h = int(fw), int(fh)
        object.__setattr__(self, "image_size", (w, h))
        cx, cy = _pair("center", self.center)
        if not (0 <= cx <= w - 1 and 0 <= cy <= h - 1):
            raise VisionError(f"center {(cx, cy)} lies outside the image_size {w}x{h}")
        object.__setattr__(self, "center", (cx, cy))
        aspect = _finite("aspect", self.aspect)
        if not 1e-3 <= aspect <= 10:
            raise VisionError(f"aspect must be in (0, 10] (at least 0.001), got {aspect}")
        if not _finite("radius", self.radius) > 1:
            raise VisionError(f"radius must be > 1 px, got {self.radius}")
        if not 0 <= _finite("inner_radius", self.inner_radius) < 1:
            raise VisionError(f"inner_radius must be in [0, 1), got {self.inner_radius}")
        if abs(_finite("forward", self.forward)) > 1e6:
            raise VisionError(f"forward must be an angle in radians, got {self.forward:.4g}")
        for name in ("blur_sigma", "noise_sigma", "texture_sigma"):
            if not 0 <= _finite(name, getattr(self, name)) <= 1000:
                raise VisionError(f"{name} must be in [0, 1000], got {getattr(self, name)}")
        for name in ("background_level", "camera_level"):
            _check_paint(name, getattr(self, name))
        for name in ("elevation_range", "lighting_gradient"):
            lo, hi = _pair(name, getattr(self, name))
            if max(abs(lo), abs(hi)) > 100:
                raise VisionError(f"{name} values must lie within [-100, 100], got {(lo, hi)}")


@dataclass(frozen=True, eq=False)
class TrueFeatures:
    """What the sensor can see: the truth that detections are scored against.

    Attributes
    ----------
    bearings : ndarray, shape (k,)
        Bearings of the visible landmarks in the robot frame, radians in [-pi, pi).
    kind : ndarray of str, shape (k,)
        ``"pole"`` or ``"edge"``.
    landmarks_xy : ndarray, shape (k, 2)
        World positions of those landmarks, metres.
    index : ndarray of int, shape (k,)
        Row of each one in ``scene.landmarks_xy``.
    ambiguous : ndarray, shape (j,)
        Bearings (radians) of partly hidden features: a pole partly behind another pole, an
        edge at the border of a pole. Scoring should neither require nor penalise detections
        there.
    """

    bearings: NDArray[np.float64]
    kind: NDArray[np.str_]
    landmarks_xy: NDArray[np.float64]
    index: NDArray[np.int64]
    ambiguous: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return int(self.bearings.shape[0])


def _check_scene(scene: object) -> None:
    if not isinstance(scene, OmniScene):
        raise VisionError(f"scene must be an OmniScene, got {type(scene).__name__}")


def _check_pose(pose: object) -> tuple[float, float, float]:
    try:
        vals = [float(getattr(pose, k)) for k in ("x", "y", "theta")]
    except AttributeError:
        try:
            vals = [float(v) for v in np.asarray(pose, dtype=np.float64).reshape(-1)]
        except (TypeError, ValueError, OverflowError):
            raise VisionError(f"pose must be (x, y, theta), got {shorten(pose)}") from None
    if len(vals) != 3:
        raise VisionError(f"pose must have 3 values (x, y, theta), got {len(vals)}")
    if not all(math.isfinite(v) for v in vals):
        raise VisionError(f"pose must be finite, got {vals}")
    if max(abs(v) for v in vals) > 1e6:
        raise VisionError(f"pose must lie within 1e6 m (and radians) of the origin, got {vals}")
    return vals[0], vals[1], vals[2]


def _pole_geometry(
    scene: OmniScene, x: float, y: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """World azimuth, distance and angular half-width of every pole seen from (x, y)."""
    n = len(scene.poles)
    az = np.zeros(n)
    dist = np.zeros(n)
    half = np.zeros(n)
    for i, p in enumerate(scene.poles):
        d = math.hypot(p.x - x, p.y - y)
        if d <= p.radius * 1.001:
            raise VisionError(f"the robot at ({x:.3f}, {y:.3f}) is inside pole {i}")
        az[i] = math.atan2(p.y - y, p.x - x)
        dist[i] = d
        half[i] = math.asin(p.radius / d)
    return az, dist, half


def _in_interval(a: float, center: float, half: float) -> bool:
    return abs(float(wrap(a - center))) < half


def true_features(
    scene: OmniScene,
    pose: object,
    camera: OmniCamera | None = None,
    *,
    margin: float = np.deg2rad(0.5),
) -> TrueFeatures:
    """Bearings of the landmarks the sensor can see, with occlusion by poles.

    Parameters
    ----------
    scene : OmniScene
        The landmarks.
    pose : Pose or sequence of 3 float
        Robot pose ``(x, y, theta)``: metres, metres, radians.
    camera : OmniCamera, optional
        Unused for the geometry (every landmark spans the whole annulus); accepted so the
        call mirrors :func:`render_omni_image`.
    margin : float
        Angular margin in radians: a feature within `margin` of a pole's border is ambiguous.

    Returns
    -------
    TrueFeatures
        Visible landmarks sorted by bearing, plus the ambiguous ones.

    Raises
    ------
    VisionError
        If the pose is malformed or lies inside a pole.
    """
    del camera
    _check_scene(scene)
    x, y, theta = _check_pose(pose)
    margin = _finite("margin", margin)
    if not 0 <= margin <= math.pi:
        raise VisionError(f"margin must be an angle in [0, pi] radians, got {margin:g}")
    az, dist, half = _pole_geometry(scene, x, y)
    bearings: list[float] = []
    kinds: list[str] = []
    index: list[int] = []
    ambiguous: list[float] = []
    npoles = len(scene.poles)
    for i in range(npoles):
        hidden = False
        partial = False
        for j in range(npoles):
            if j == i or dist[j] >= dist[i]:
                continue
            gap = abs(float(wrap(az[j] - az[i])))
            if gap + half[i] <= half[j]:
                hidden = True
            elif gap < half[i] + half[j] + margin:
                partial = True
        b = float(wrap(az[i] - theta))
        if hidden:
            continue
        if partial:
            ambiguous.append(b)
            continue
        bearings.append(b)
        kinds.append("pole")
        index.append(i)
    for k, e in enumerate(scene.edges):
        a = math.atan2(e.y - y, e.x - x)
        b = float(wrap(a - theta))
        if any(_in_interval(a, az[j], half[j] - margin) for j in range(npoles)):
            continue  # well behind a pole
        if any(_in_interval(a, az[j], half[j] + margin) for j in range(npoles)):
            ambiguous.append(b)  # at a pole's border
            continue
        bearings.append(b)
        kinds.append("edge")
        index.append(npoles + k)
    order = np.argsort(bearings, kind="stable")
    xy = scene.landmarks_xy
    idx = np.asarray(index, dtype=np.int64)[order]
    return TrueFeatures(
        bearings=np.asarray(bearings, dtype=np.float64)[order],
        kind=np.asarray(kinds, dtype="<U4")[order],
        landmarks_xy=xy[idx] if len(idx) else np.zeros((0, 2)),
        index=idx,
        ambiguous=np.sort(np.asarray(ambiguous, dtype=np.float64)),
    )


def _segment_paints(
    scene: OmniScene, edge_levels: list[Paint | None]
) -> list[tuple[float, float, float]]:
    """RGB paint of each wall segment, given the levels of the edges where they start.

    With levels on the edges, a segment has the level of the edge where it starts; else the
    scene's ``wall_levels`` are used in turn, so that neighbouring segments always differ.
    """
    m = len(edge_levels)
    if all(level is not None for level in edge_levels):
        paints = [_rgb(level) for level in edge_levels if level is not None]
        for i in range(m):
            if paints[i] == paints[i - 1]:
                raise VisionError(
                    f"the walls on both sides of a wall edge have the same level {paints[i]}: "
                    f"that edge would be invisible (neighbouring walls must differ)"
                )
        return paints
    levels = scene.wall_levels
    seg_levels = [levels[i % len(levels)] for i in range(m)]
    if seg_levels[-1] == seg_levels[0] or m % len(levels) == 1:
        prev, first = seg_levels[-2], seg_levels[0]
        seg_levels[-1] = max(levels, key=lambda w: min(abs(w - prev), abs(w - first)))
    return [_rgb(v) for v in seg_levels]


def _wall_profile(
    scene: OmniScene, x: float, y: float
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """RGB paint and is-wall flag over world azimuth, tables of `_PROFILE_BINS` rows.

    Row ``i`` covers world azimuths ``[-pi + i * 2 pi / N, -pi + (i + 1) * 2 pi / N)``; the
    paint table has shape ``(N, 3)``.
    """
    n = _PROFILE_BINS
    levels = scene.wall_levels
    table = np.empty((n, 3), dtype=np.float32)
    table[:] = levels[0]
    is_wall = np.ones(n, dtype=bool)

    def to_bin(a: float) -> int:
        # The bin whose lower boundary is nearest to azimuth a, so steps sit exactly at a.
        return round((float(wrap(a)) + math.pi) / (2 * math.pi) * n) % n

    # Edges in one bin coincide: the last one's level counts.
    bin_level = {to_bin(math.atan2(e.y - y, e.x - x)): e.level for e in scene.edges}
    edge_bins = sorted(bin_level)
    m = len(edge_bins)
    if m == 1:
        # One edge only: ramp once round the robot so there is a step at the edge.
        start = edge_bins[0]
        ramp = np.linspace(levels[0], levels[1], n, dtype=np.float32)
        table[:] = np.roll(ramp, start)[:, None]
    elif m > 1:
        paints = _segment_paints(scene, [bin_level[b] for b in edge_bins])
        for i, paint in enumerate(paints):
            a, b = edge_bins[i], edge_bins[(i + 1) % m]
            if b > a:
                table[a:b] = paint
            else:
                table[a:] = paint
                table[:b] = paint
    az, dist, half = _pole_geometry(scene, x, y)
    for i in np.argsort(-dist):  # far to near
        a, b = to_bin(az[i] - half[i]), to_bin(az[i] + half[i])
        val = _rgb(scene.poles[int(i)].intensity)
        if b >= a:
            table[a:b] = val
            is_wall[a:b] = False
        else:
            table[a:] = val
            table[:b] = val
            is_wall[a:] = False
            is_wall[:b] = False
    return table, is_wall


def _luminance_table(table: NDArray[np.float32]) -> NDArray[np.float32]:
    """Grey levels of an ``(N, 3)`` paint table: the luminance, exact for grey paints."""
    grey = table[:, 0].copy()
    coloured = (table[:, 0] != table[:, 1]) | (table[:, 1] != table[:, 2])
    if coloured.any():
        grey[coloured] = (table[coloured] @ np.asarray(_LUMA)).astype(np.float32)
    return grey


def render_omni_image(
    scene: OmniScene,
    pose: object,
    camera: OmniCamera | None = None,
    *,
    rng: np.random.Generator | int | None = None,
) -> NDArray[np.uint8]:
    """Render the image the omnidirectional sensor sees (grey, or RGB for a colour camera).

    Parameters
    ----------
    scene : OmniScene
        Poles and wall edges.
    pose : Pose or sequence of 3 float
        Robot pose ``(x, y, theta)``: metres, metres, radians.
    camera : OmniCamera, optional
        Mirror and camera parameters; the default is a 640x480 image.
    rng : numpy.random.Generator or int or None
        Source of the texture and the noise, passed through ``np.random.default_rng``.

    Returns
    -------
    ndarray of uint8, shape (height, width) or (height, width, 3)
        The image: grey, or RGB if ``camera.color``.

    Raises
    ------
    VisionError
        If the pose is malformed or inside a pole, or two neighbouring walls have the same
        level (the edge between them would be invisible).

    Examples
    --------
    >>> img = render_omni_image(demo_scene(), DEMO_POSE, rng=0)
    >>> img.shape, img.dtype
    ((480, 640), dtype('uint8'))
    """
    cam = OmniCamera() if camera is None else camera
    if not isinstance(cam, OmniCamera):
        raise VisionError(f"camera must be an OmniCamera, got {type(cam).__name__}")
    _check_scene(scene)
    try:
        gen = np.random.default_rng(rng)
    except (TypeError, ValueError):
        raise VisionError(
            f"rng must be a Generator, an int seed >= 0 or None, got {shorten(rng)}"
        ) from None
    x, y, theta = _check_pose(pose)
    paints, is_wall = _wall_profile(scene, x, y)
    table = paints if cam.color else _luminance_table(paints)

    def per_pixel(a: NDArray[Any]) -> NDArray[Any]:
        """A per-pixel factor or term, broadcast over the channels of a colour image."""
        return a[..., None] if cam.color else a

    w, h = cam.image_size
    cx, cy = cam.center
    r_v = float(cam.radius)
    r_u = float(cam.aspect) * r_v
    sign = -1.0 if cam.mirrored else 1.0
    ss = _SUPERSAMPLE

    # Supersampled pixel coordinates, symmetric about each pixel centre (float32: the image
    # angle is then exact to ~1e-7 rad, far below what any test resolves).
    f32 = np.float32
    du1 = ((np.arange(w * ss) - (ss - 1) / 2) / ss - cx).astype(f32)
    dv1 = ((np.arange(h * ss) - (ss - 1) / 2) / ss - cy).astype(f32)
    du = du1[None, :]
    dv = dv1[:, None]
    phi = np.arctan2(-dv * f32(cam.aspect), du)  # the image angle, exactly as the spec writes it
    rho = np.sqrt((du1 / f32(r_u))[None, :] ** 2 + (dv1 / f32(r_v))[:, None] ** 2)
    # World azimuth of each sample in profile bins: theta + s * (phi - forward), shifted by pi.
    bins_per_rad = _PROFILE_BINS / (2 * np.pi)
    t = phi * f32(sign * bins_per_rad) + f32((theta - sign * cam.forward + np.pi) * bins_per_rad)
    idx = np.floor(t).astype(np.int64) & (_PROFILE_BINS - 1)
    val = table[idx]
    wall = is_wall[idx]

    # Elevation-dependent wall bands (skirting board, picture rail): circular, not radial.
    # Elevation is linear in rho between inner_radius and the rim, so bands are rho ranges.
    rin = cam.inner_radius
    span = max(1.0 - rin, 1e-9)
    band = np.ones_like(rho)
    band[(rho > rin + 0.08 * span) & (rho < rin + 0.16 * span)] = 0.8
    band[(rho > rin + 0.78 * span) & (rho < rin + 0.82 * span)] = 1.1
    val = np.where(per_pixel(wall), val * per_pixel(band), val)

    # Weak random texture over (elevation, world azimuth), smooth but not radially coherent.
    if cam.texture_sigma > 0:
        tex = gen.normal(0.0, 1.0, size=(48, 1024)).astype(f32)
        tex = np.concatenate([tex[:, -8:], tex, tex[:, :8]], axis=1)  # wrap in azimuth
        blurred = cv2.GaussianBlur(tex, (0, 0), 1.0, borderType=cv2.BORDER_REFLECT)
        tex = np.ascontiguousarray(blurred[:, 8:-8], dtype=f32)
        tex *= cam.texture_sigma / max(float(tex.std()), 1e-6)
        map_x = np.mod(t * f32(1024 / _PROFILE_BINS), f32(1024))
        map_y = np.clip((rho - f32(rin)) * f32(47 / span), 0, 47)
        val += per_pixel(cv2.remap(tex, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP))

    val = np.where(per_pixel(rho < rin), f32(cam.camera_level), val)
    val = np.where(per_pixel(rho > 1.0), f32(cam.background_level), val)
    gu, gv = cam.lighting_gradient
    light = 1.0 + (f32(gu / r_v) * du1)[None, :] + (f32(gv / r_v) * dv1)[:, None]
    val = (val * per_pixel(light)).astype(f32)

    # Box average over each pixel's ss x ss samples (INTER_AREA is exact for integer factors).
    img = cv2.resize(val, (w, h), interpolation=cv2.INTER_AREA)
    if cam.blur_sigma > 0:
        img = cv2.GaussianBlur(img, (0, 0), cam.blur_sigma, borderType=cv2.BORDER_REFLECT)
    if cam.noise_sigma > 0:
        img = img + gen.normal(0.0, cam.noise_sigma, size=img.shape).astype(np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def demo_scene() -> OmniScene:
    """A small room (9.8 m x 5.6 m, centred on the origin) with 6 poles and 8 wall edges.

    Returns
    -------
    OmniScene
        Four room corners, four door-frame edges and six poles (dark and bright). From
        :data:`DEMO_POSE` all 14 are visible and at least 7 degrees apart.
    """
    edges = (
        WallEdge(-4.88, -2.81),
        WallEdge(4.88, -2.81),
        WallEdge(4.88, 2.81),
        WallEdge(-4.88, 2.81),
        WallEdge(2.24, -2.81),
        WallEdge(-1.72, 2.81),
        WallEdge(-4.88, 0.07),
        WallEdge(1.2, 2.81),
    )
    poles = (
        Pole(-0.82, 0.55, 0.065, 238.0),
        Pole(-3.57, 1.14, 0.063, 26.0),
        Pole(0.46, 0.19, 0.058, 40.0),
        Pole(3.61, 2.1, 0.046, 41.0),
        Pole(3.51, 1.09, 0.067, 247.0),
        Pole(-0.02, -0.05, 0.046, 22.0),
    )
    return OmniScene(poles=poles, edges=edges)


#: A robot pose ``(x, y, theta)`` in :func:`demo_scene` that sees every landmark clearly.
DEMO_POSE = (0.09, 1.97, 2.16)


def random_scene(
    rng: np.random.Generator | int | None = None,
    *,
    n_poles: int = 5,
    n_edges: int = 7,
    min_separation: float = np.deg2rad(6.0),
    max_pole_width: float = np.deg2rad(5.0),
    max_tries: int = 2000,
) -> tuple[OmniScene, tuple[float, float, float]]:
    """A random rectangular room and a robot pose from which every landmark is well apart.

    The room is 7-10 m by 5-8 m centred on the origin; `n_edges` wall edges (its 4 corners
    first, then door-frame edges on the walls) and `n_poles` poles (radius 4-8 cm, dark or
    bright) inside. The pose is drawn until every landmark is visible and any two are at
    least `min_separation` apart in bearing (between pole borders, not centres), and every
    pole looks at most `max_pole_width` wide: the resolution a bearing detector needs.

    Parameters
    ----------
    rng : numpy.random.Generator or int or None
        Passed through ``np.random.default_rng``.
    n_poles, n_edges : int
        Numbers of landmarks (``n_edges >= 4``: the corners).
    min_separation, max_pole_width : float
        Radians.
    max_tries : int
        Poses tried per room before a new room is drawn (at most 20 rooms).

    Returns
    -------
    scene : OmniScene
    pose : tuple of float
        ``(x, y, theta)`` in metres, metres, radians.

    Raises
    ------
    VisionError
        If no such room and pose is found.
    """
    gen = np.random.default_rng(rng)
    if n_edges < 4 or n_poles < 0:
        raise VisionError(f"need n_edges >= 4 and n_poles >= 0, got {n_edges}, {n_poles}")
    for _ in range(20):
        hw, hh = gen.uniform(3.5, 5.0), gen.uniform(2.5, 4.0)
        edges = [WallEdge(-hw, -hh), WallEdge(hw, -hh), WallEdge(hw, hh), WallEdge(-hw, hh)]
        for _ in range(n_edges - 4):
            side = int(gen.integers(4))
            t = gen.uniform(-0.8, 0.8)
            x, y = [(t * hw, -hh), (hw, t * hh), (t * hw, hh), (-hw, t * hh)][side]
            edges.append(WallEdge(float(x), float(y)))
        poles = []
        for _ in range(n_poles):
            dark = bool(gen.random() < 0.5)
            poles.append(
                Pole(
                    float(gen.uniform(-hw + 0.6, hw - 0.6)),
                    float(gen.uniform(-hh + 0.6, hh - 0.6)),
                    float(gen.uniform(0.04, 0.08)),
                    float(gen.uniform(15, 45) if dark else gen.uniform(235, 250)),
                )
            )
        scene = OmniScene(poles=tuple(poles), edges=tuple(edges))
        pxy = np.array([(p.x, p.y) for p in poles]).reshape(-1, 2)
        prad = np.array([p.radius for p in poles])
        min_dist = prad / math.sin(max_pole_width / 2)
        for _ in range(max_tries):
            x = float(gen.uniform(-hw + 0.5, hw - 0.5))
            y = float(gen.uniform(-hh + 0.5, hh - 0.5))
            if len(poles) and np.any(np.hypot(pxy[:, 0] - x, pxy[:, 1] - y) < min_dist):
                continue
            theta = float(gen.uniform(-np.pi, np.pi))
            truth = true_features(scene, (x, y, theta))
            if len(truth) != n_poles + n_edges or truth.ambiguous.size:
                continue
            half = np.zeros(len(truth))
            for k, (i, kind) in enumerate(zip(truth.index, truth.kind, strict=True)):
                if kind == "pole":
                    p = poles[int(i)]
                    half[k] = math.asin(p.radius / math.hypot(p.x - x, p.y - y))
            b = truth.bearings
            gaps = np.diff(np.concatenate([b, b[:1] + 2 * np.pi]))
            clear = gaps - half - np.roll(half, -1)
            if np.all(clear >= min_separation):
                return scene, (x, y, theta)
    raise VisionError("could not draw a room and pose with well-separated landmarks")


#: Camera of the vision demo (:func:`omniloc.plot.vision_demo`): slightly elliptical,
#: off-centre, with a rotated forward axis.
DEMO_CAMERA = OmniCamera(
    center=(324.6, 236.2), aspect=1.035, radius=212.0, forward=np.deg2rad(25.0)
)


def _ray_to_room(x: float, y: float, a: float, hw: float, hh: float) -> tuple[float, float, float]:
    """Where the ray at world azimuth `a` from (x, y) meets the room's walls.

    The room is ``|x| <= hw, |y| <= hh``; returns ``(px, py, distance)`` in metres.
    """
    c, s = math.cos(a), math.sin(a)
    hits = []
    if abs(c) > 1e-12:
        hits.append(((hw if c > 0 else -hw) - x) / c)
    if abs(s) > 1e-12:
        hits.append(((hh if s > 0 else -hh) - y) / s)
    t = min(hits)
    return x + t * c, y + t * s, t


def _place_block(
    gen: np.random.Generator, blocks: list[tuple[float, float]], width: float, gap: float
) -> float | None:
    """Centre of a new block of azimuth `width` wide, at least `gap` clear of `blocks`.

    `blocks` holds ``(centre, width)`` pairs in radians; the new block is appended to it.
    None if 200 random centres all fail.
    """
    for _ in range(200):
        centre = float(gen.uniform(-np.pi, np.pi))
        if all(abs(float(wrap(centre - c))) >= (width + w) / 2 + gap for c, w in blocks):
            blocks.append((centre, width))
            return centre
    return None


def _tint(level: float, gen: np.random.Generator, chroma: float) -> Paint:
    """A random colour of luminance `level` (a grey level if `chroma` is 0)."""
    if chroma <= 0:
        return level
    c = gen.normal(size=3)
    c -= float(c @ np.asarray(_LUMA))  # no luminance: the weights sum to 1
    c *= gen.uniform(0.3, 1.0) * chroma / max(float(np.abs(c).max()), 1e-9)
    room = [(255.0 - level) / v if v > 0 else level / -v for v in c if v != 0]
    # Shrunk to stay in [0, 255]; the clip only removes rounding (~1e-14).
    rgb = np.clip(level + min(1.0, *room) * c, 0.0, 255.0)
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]))


def _stripe_wall_levels(
    narrow: list[bool], gen: np.random.Generator, step: float, lo: float, hi: float
) -> list[float] | None:
    """Grey levels of the walls in azimuth order (wall i from edge i to edge i + 1).

    Neighbouring walls differ by at least `step`. A narrow wall (its neighbours are wide) is
    between its neighbours (two steps of the same sign) one time in three where they differ
    by at least ``2 * step``, else brighter or darker than both (its two steps look like a
    pole's). Returns None if these draws do not fit, so the caller draws again.
    """
    m = len(narrow)
    levels = [math.nan] * m
    for i in range(m):
        if narrow[i]:
            continue
        near = [levels[i - 1]] if i > 0 and not narrow[i - 1] else []
        if i == m - 1 and not narrow[0]:
            near.append(levels[0])
        for _ in range(100):
            v = float(gen.uniform(lo, hi))
            if all(abs(v - u) >= step for u in near):
                levels[i] = v
                break
        else:
            return None
    for i in range(m):
        if not narrow[i]:
            continue
        a, c = levels[i - 1], levels[(i + 1) % m]
        extremes = [(max(a, c) + step, hi), (lo, min(a, c) - step)]
        extremes = [(u, v) for u, v in extremes if u <= v]
        between = (min(a, c) + step, max(a, c) - step)
        if between[0] <= between[1] and (not extremes or gen.random() < 1 / 3):
            levels[i] = float(gen.uniform(*between))
        elif extremes:
            levels[i] = float(gen.uniform(*extremes[int(gen.integers(len(extremes)))]))
        else:
            return None
    return levels


def random_stripe_scene(
    rng: np.random.Generator | int | None = None,
    *,
    n_poles: int = 4,
    n_segments: int = 4,
    pole_width: tuple[float, float] = (np.deg2rad(1.6), np.deg2rad(5.0)),
    segment_width: tuple[float, float] = (np.deg2rad(5.0), np.deg2rad(8.0)),
    min_level_step: float = 30.0,
    min_separation: float = np.deg2rad(6.0),
    chroma: float = 40.0,
    max_tries: int = 200,
) -> tuple[OmniScene, tuple[float, float, float]]:
    """A random room with narrow wall segments next to poles: stripes that look alike.

    The room is 7-10 m by 5-8 m centred on the origin, the robot at least 1 m from its walls.
    Besides the 4 corners, the walls have `n_segments` narrow segments (a run of wall between
    two vertical wall edges, `segment_width` wide as seen from the robot), and `n_poles`
    poles stand in the room, each `pole_width` wide as seen from the robot. Every wall has
    its own grey level in [40, 215], at least `min_level_step` from each neighbouring wall;
    a narrow segment is brighter or darker than both neighbours about four times in five
    (then its two steps have opposite signs, like a pole's), else between them (one time in
    three where the neighbours differ by at least ``2 * min_level_step``). Each pole's level
    in [10, 250] is at least `min_level_step` from the wall behind it. Every paint has a
    random colour of that luminance (up to `chroma` grey levels per channel), which a grey
    camera does not see. Landmarks (a narrow segment counted as one block from its first
    to its second edge, a pole from border to border) are at least `min_separation` apart,
    none hides another and :func:`true_features` lists all of them: each pole once at its
    centre, each wall edge (both edges of every narrow segment) at its bearing.

    Parameters
    ----------
    rng : numpy.random.Generator or int or None
        Passed through ``np.random.default_rng``.
    n_poles, n_segments : int
        Numbers of poles and of narrow wall segments (>= 0).
    pole_width, segment_width : tuple of float
        Ranges (radians) of the angular widths, drawn uniformly.
    min_level_step : float
        Smallest difference between neighbouring walls, and between a pole and the wall
        behind it, grey levels.
    min_separation : float
        Smallest gap between landmarks, radians.
    chroma : float
        Largest colour deviation from grey per channel, grey levels (0: grey paints).
    max_tries : int
        Rooms drawn before giving up.

    Returns
    -------
    scene : OmniScene
        Wall edges carry their levels (see :class:`WallEdge`).
    pose : tuple of float
        ``(x, y, theta)`` in metres, metres, radians.

    Raises
    ------
    VisionError
        If the parameters are out of range or no room fits after `max_tries` draws.

    Examples
    --------
    >>> scene, pose = random_stripe_scene(0)
    >>> len(true_features(scene, pose)) == 4 + 2 * 4 + 4
    True
    """
    gen = np.random.default_rng(rng)
    if n_poles < 0 or n_segments < 0:
        raise VisionError(f"need n_poles >= 0 and n_segments >= 0, got {n_poles}, {n_segments}")
    for name, (w0, w1) in (("pole_width", pole_width), ("segment_width", segment_width)):
        if not (0 < _finite(name, w0) <= _finite(name, w1) < np.pi / 2):
            raise VisionError(f"{name} must satisfy 0 < low <= high < pi/2, got {(w0, w1)}")
    if not 0 <= _finite("min_level_step", min_level_step) <= 80:
        raise VisionError(f"min_level_step must be in [0, 80] grey levels, got {min_level_step}")
    if not 0 <= _finite("min_separation", min_separation) < np.pi / 4:
        raise VisionError(f"min_separation must be in [0, pi/4) radians, got {min_separation}")
    for _ in range(max_tries):
        hw, hh = float(gen.uniform(3.5, 5.0)), float(gen.uniform(2.5, 4.0))
        x, y = float(gen.uniform(-hw + 1.0, hw - 1.0)), float(gen.uniform(-hh + 1.0, hh - 1.0))
        theta = float(gen.uniform(-np.pi, np.pi))
        corners = [(-hw, -hh), (hw, -hh), (hw, hh), (-hw, hh)]
        # Blocks of azimuth (centre, width) that other landmarks must keep clear of.
        blocks = [(math.atan2(cy - y, cx - x), 0.0) for cx, cy in corners]
        edge_az = [(b[0], False) for b in blocks]  # (azimuth, starts a narrow segment)
        ok = True
        for _ in range(n_segments):
            width = float(gen.uniform(*segment_width))
            centre = _place_block(gen, blocks, width, min_separation)
            if centre is None:
                ok = False
                break
            edge_az += [(centre - width / 2, True), (centre + width / 2, False)]
        pole_az: list[tuple[float, float]] = []
        for _ in range(n_poles if ok else 0):
            width = float(gen.uniform(*pole_width))
            centre = _place_block(gen, blocks, width, min_separation)
            if centre is None:
                ok = False
                break
            pole_az.append((centre, width))
        if not ok:
            continue
        edge_az.sort(key=lambda e: float(wrap(e[0])))
        levels = _stripe_wall_levels(
            [starts for _, starts in edge_az], gen, min_level_step, 40.0, 215.0
        )
        if levels is None:
            continue
        edges = []
        for (a, _), level in zip(edge_az, levels, strict=True):
            px, py, _ = _ray_to_room(x, y, a, hw, hh)
            edges.append(WallEdge(px, py, _tint(level, gen, chroma)))
        poles = []
        starts = np.asarray([float(wrap(a)) for a, _ in edge_az])
        for centre, width in pole_az:
            # The wall behind the pole is the one starting at the last edge before it.
            behind = levels[int(np.searchsorted(starts, float(wrap(centre)))) - 1]
            dark = (10.0, behind - min_level_step)
            bright = (behind + min_level_step, 250.0)
            sides = [r for r in (dark, bright) if r[0] <= r[1]]
            level = float(gen.uniform(*sides[int(gen.integers(len(sides)))]))
            wall_dist = _ray_to_room(x, y, centre, hw, hh)[2]
            d = float(gen.uniform(0.6, max(wall_dist - 0.4, 0.6)))
            r = d * math.sin(width / 2)
            poles.append(
                Pole(
                    x + d * math.cos(centre), y + d * math.sin(centre), r, _tint(level, gen, chroma)
                )
            )
        scene = OmniScene(poles=tuple(poles), edges=tuple(edges))
        pose = (x, y, theta)
        truth = true_features(scene, pose)
        if len(truth) == n_poles + len(edges) and truth.ambiguous.size == 0:
            return scene, pose
    raise VisionError(f"could not draw a room with these stripes in {max_tries} tries")
