"""Synthetic omnidirectional images with known truth, for tests, benchmarks and demos.

The renderer is the exact inverse of the conventions used by :mod:`omniloc.vision.bearings`:
a pixel ``(u, v)`` (u = column to the right, v = row downward, (0, 0) the centre of the
top-left pixel) has the image angle ``phi = atan2(-(v - cy) * aspect, u - cx)`` and the
normalised elliptic radius ``rho = hypot((u - cx) / (aspect * radius), (v - cy) / radius)``
(1 on the mirror rim). It shows what the robot sees at the bearing
``wrap(s * phi - forward)`` with ``s = -1`` for a mirrored sensor, else ``+1``.

The scene model is deliberately simple: every landmark is a vertical structure seen over the
whole mirror annulus. Wall edges (corners, door frames) are steps in the brightness of a
background wall; poles are cylinders of uniform brightness painted over the wall, nearer ones
over farther ones. The wall carries horizontal bands and a weak random texture that vary with
the radius but not coherently along it, so they produce no radial lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from omniloc.angles import wrap
from omniloc.errors import VisionError

__all__ = [
    "DEMO_CAMERA",
    "DEMO_POSE",
    "OmniCamera",
    "OmniScene",
    "Pole",
    "TrueFeatures",
    "WallEdge",
    "demo_scene",
    "random_scene",
    "render_omni_image",
    "true_features",
]

_PROFILE_BINS = 1 << 18  # world azimuth table resolution: 0.0014 deg per bin
_SUPERSAMPLE = 3  # odd, so sub-sample offsets are symmetric about each pixel centre


def _finite(name: str, value: float) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise VisionError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(out):
        raise VisionError(f"{name} must be finite, got {out}")
    return out


@dataclass(frozen=True)
class Pole:
    """A vertical cylinder seen as a narrow stripe.

    Parameters
    ----------
    x, y : float
        Position of the axis in the world frame, metres.
    radius : float
        Radius in metres (> 0).
    intensity : float
        Grey level of the pole in [0, 255].
    """

    x: float
    y: float
    radius: float = 0.05
    intensity: float = 30.0

    def __post_init__(self) -> None:
        for name in ("x", "y", "radius", "intensity"):
            _finite(f"pole {name}", getattr(self, name))
        if not self.radius > 0:
            raise VisionError(f"pole radius must be > 0 m, got {self.radius}")
        if not 0 <= self.intensity <= 255:
            raise VisionError(f"pole intensity must be in [0, 255], got {self.intensity}")


@dataclass(frozen=True)
class WallEdge:
    """A vertical edge of the wall (a corner, a door frame): a step in wall brightness.

    Parameters
    ----------
    x, y : float
        Position in the world frame, metres.
    """

    x: float
    y: float

    def __post_init__(self) -> None:
        _finite("wall edge x", self.x)
        _finite("wall edge y", self.y)


@dataclass(frozen=True)
class OmniScene:
    """Landmarks of a synthetic room.

    Parameters
    ----------
    poles : tuple of Pole
        Cylinders, painted over the wall (nearer over farther).
    edges : tuple of WallEdge
        Vertical wall edges. Seen from the robot, the wall between two consecutive edges
        (in azimuth) has one grey level taken in turn from `wall_levels`, chosen so that
        neighbouring segments always differ.
    wall_levels : tuple of float
        At least three distinct grey levels in [0, 255] for the wall segments.
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
        True if the mirror flips the sense of rotation (bearing = -phi - forward).
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

    def __post_init__(self) -> None:
        if len(self.image_size) != 2:
            raise VisionError(f"image_size must be (width, height), got {self.image_size!r}")
        w, h = (int(s) for s in self.image_size)
        if w < 16 or h < 16 or w > 20000 or h > 20000:
            raise VisionError(f"image_size must be between 16 and 20000 px, got {(w, h)}")
        object.__setattr__(self, "image_size", (w, h))
        if len(self.center) != 2:
            raise VisionError(f"center must be (cx, cy), got {self.center!r}")
        cx, cy = (_finite("center", c) for c in self.center)
        if not (0 <= cx <= w - 1 and 0 <= cy <= h - 1):
            raise VisionError(f"center {(cx, cy)} lies outside the {w}x{h} image")
        object.__setattr__(self, "center", (cx, cy))
        aspect = _finite("aspect", self.aspect)
        if not 0 < aspect <= 10:
            raise VisionError(f"aspect must be in (0, 10], got {aspect}")
        if not _finite("radius", self.radius) > 1:
            raise VisionError(f"radius must be > 1 px, got {self.radius}")
        if not 0 <= _finite("inner_radius", self.inner_radius) < 1:
            raise VisionError(f"inner_radius must be in [0, 1), got {self.inner_radius}")
        for name in ("forward", "blur_sigma", "noise_sigma", "texture_sigma"):
            _finite(name, getattr(self, name))
        for name in ("blur_sigma", "noise_sigma", "texture_sigma"):
            if getattr(self, name) < 0:
                raise VisionError(f"{name} must be >= 0, got {getattr(self, name)}")
        if len(self.elevation_range) != 2 or len(self.lighting_gradient) != 2:
            raise VisionError("elevation_range and lighting_gradient need two values each")
        for v in (*self.elevation_range, *self.lighting_gradient):
            _finite("elevation_range/lighting_gradient", v)


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


def _check_pose(pose: object) -> tuple[float, float, float]:
    try:
        vals = [float(getattr(pose, k)) for k in ("x", "y", "theta")]
    except AttributeError:
        try:
            vals = [float(v) for v in np.asarray(pose, dtype=np.float64).reshape(-1)]
        except (TypeError, ValueError):
            raise VisionError(f"pose must be (x, y, theta), got {pose!r}") from None
    if len(vals) != 3:
        raise VisionError(f"pose must have 3 values (x, y, theta), got {len(vals)}")
    if not all(math.isfinite(v) for v in vals):
        raise VisionError(f"pose must be finite, got {vals}")
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
    x, y, theta = _check_pose(pose)
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


def _wall_profile(
    scene: OmniScene, x: float, y: float
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Grey level and is-wall flag over world azimuth, tables of `_PROFILE_BINS` bins.

    Bin ``i`` covers world azimuths ``[-pi + i * 2 pi / N, -pi + (i + 1) * 2 pi / N)``.
    """
    n = _PROFILE_BINS
    levels = scene.wall_levels
    table = np.full(n, levels[0], dtype=np.float32)
    is_wall = np.ones(n, dtype=bool)

    def to_bin(a: float) -> int:
        # The bin whose lower boundary is nearest to azimuth a, so steps sit exactly at a.
        return round((float(wrap(a)) + math.pi) / (2 * math.pi) * n) % n

    edge_bins = sorted({to_bin(math.atan2(e.y - y, e.x - x)) for e in scene.edges})
    m = len(edge_bins)
    if m == 1:
        # One edge only: ramp once round the robot so there is a step at the edge.
        start = edge_bins[0]
        ramp = np.linspace(levels[0], levels[1], n, dtype=np.float32)
        table = np.roll(ramp, start)
    elif m > 1:
        seg_levels = [levels[i % len(levels)] for i in range(m)]
        if seg_levels[-1] == seg_levels[0] or m % len(levels) == 1:
            prev, first = seg_levels[-2], seg_levels[0]
            seg_levels[-1] = max(levels, key=lambda w: min(abs(w - prev), abs(w - first)))
        for i in range(m):
            a, b = edge_bins[i], edge_bins[(i + 1) % m]
            if b > a:
                table[a:b] = seg_levels[i]
            else:
                table[a:] = seg_levels[i]
                table[:b] = seg_levels[i]
    az, dist, half = _pole_geometry(scene, x, y)
    for i in np.argsort(-dist):  # far to near
        a, b = to_bin(az[i] - half[i]), to_bin(az[i] + half[i])
        val = scene.poles[int(i)].intensity
        if b >= a:
            table[a:b] = val
            is_wall[a:b] = False
        else:
            table[a:] = val
            table[:b] = val
            is_wall[a:] = False
            is_wall[:b] = False
    return table, is_wall


def render_omni_image(
    scene: OmniScene,
    pose: object,
    camera: OmniCamera | None = None,
    *,
    rng: np.random.Generator | int | None = None,
) -> NDArray[np.uint8]:
    """Render the grey image the omnidirectional sensor sees.

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
    ndarray of uint8, shape (height, width)
        The image.

    Raises
    ------
    VisionError
        If the pose is malformed or inside a pole.

    Examples
    --------
    >>> img = render_omni_image(demo_scene(), DEMO_POSE, rng=0)
    >>> img.shape, img.dtype
    ((480, 640), dtype('uint8'))
    """
    cam = OmniCamera() if camera is None else camera
    gen = np.random.default_rng(rng)
    x, y, theta = _check_pose(pose)
    table, is_wall = _wall_profile(scene, x, y)
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
    # World azimuth of each sample in profile bins: theta + (s * phi - forward), shifted by pi.
    bins_per_rad = _PROFILE_BINS / (2 * np.pi)
    t = phi * f32(sign * bins_per_rad) + f32((theta - cam.forward + np.pi) * bins_per_rad)
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
    val = np.where(wall, val * band, val)

    # Weak random texture over (elevation, world azimuth), smooth but not radially coherent.
    if cam.texture_sigma > 0:
        tex = gen.normal(0.0, 1.0, size=(48, 1024)).astype(f32)
        tex = np.concatenate([tex[:, -8:], tex, tex[:, :8]], axis=1)  # wrap in azimuth
        blurred = cv2.GaussianBlur(tex, (0, 0), 1.0, borderType=cv2.BORDER_REFLECT)
        tex = np.ascontiguousarray(blurred[:, 8:-8], dtype=f32)
        tex *= cam.texture_sigma / max(float(tex.std()), 1e-6)
        map_x = np.mod(t * f32(1024 / _PROFILE_BINS), f32(1024))
        map_y = np.clip((rho - f32(rin)) * f32(47 / span), 0, 47)
        val += cv2.remap(tex, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)

    val = np.where(rho < rin, f32(cam.camera_level), val)
    val = np.where(rho > 1.0, f32(cam.background_level), val)
    gu, gv = cam.lighting_gradient
    light = 1.0 + (f32(gu / r_v) * du1)[None, :] + (f32(gv / r_v) * dv1)[:, None]
    val = (val * light).astype(f32)

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
