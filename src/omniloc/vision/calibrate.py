"""Mirror calibration: find the elliptical rim of the mirror in an omnidirectional image.

The rim is an ellipse with axes along u (columns) and v (rows)::

    ((u - cx) / (aspect * radius))**2 + ((v - cy) / radius)**2 = 1

so ``aspect`` is the rim semi-axis along u divided by the one along v, and ``radius`` the one
along v, in pixels. The seed paper (section 1) notes that the aspect ratio "can be found
easily by measuring ellipticity of the mirror in the image"; this module does that.

Method: a rough ellipse from the moments of the convex hull of the mirror's pixels (Otsu
threshold, the class that does not own the image border), then rays cast from the centre with
the sub-pixel position of the strongest rim step along each, then a robust (soft-L1, then
inlier-only) least-squares fit of the four parameters to those points; twice, the second time
casting rays from the refined ellipse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from omniloc.errors import VisionError
from omniloc.io import finite_number, shorten

__all__ = ["MirrorCalibration", "as_gray", "as_image_array", "calibrate_mirror", "check_center"]

_MAX_ASPECT = 10.0
_MIN_ASPECT = 1e-3


#: The largest side of an image, pixels: OpenCV's remap addresses pixels with shorts.
MAX_IMAGE_SIDE = 32766


def _finite_float(name: str, value: object) -> float:
    return finite_number(value, name, VisionError)


def _count(name: str, value: object, lo: int, hi: int) -> int:
    """An int in [lo, hi] (an integral float is accepted), or a VisionError naming ``name``."""
    v = _finite_float(name, value)
    if not v.is_integer() or not lo <= v <= hi:
        raise VisionError(f"{name} must be a whole number in [{lo}, {hi}], got {shorten(value)}")
    return int(v)


def _check_aspect(aspect: object) -> float:
    a = _finite_float("aspect", aspect)
    if not _MIN_ASPECT <= a <= _MAX_ASPECT:
        # (a denormal aspect divided by zero in the rim fit)
        raise VisionError(
            f"aspect must be in (0, {_MAX_ASPECT:g}] (at least {_MIN_ASPECT:g}), got {a}"
        )
    return a


def _check_center_pair(center: object) -> tuple[float, float]:
    try:
        vals = np.asarray(center, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise VisionError(f"center must be (cx, cy) in pixels, got {shorten(center)}") from None
    if vals.shape != (2,):
        raise VisionError(f"center must have 2 values (cx, cy), got {vals.size}")
    if not np.all(np.isfinite(vals)):
        raise VisionError(f"center must be finite, got {tuple(vals.tolist())}")
    return float(vals[0]), float(vals[1])


def check_center(center: object, shape: tuple[int, ...]) -> tuple[float, float]:
    """Validate a rim centre ``(cx, cy)`` against an image of the given shape.

    Parameters
    ----------
    center : sequence of 2 float
        ``(cx, cy)`` in pixels.
    shape : tuple of int
        The image shape ``(height, width[, channels])``.

    Returns
    -------
    tuple of float
        ``(cx, cy)``.

    Raises
    ------
    VisionError
        If the centre is malformed, not finite, or outside the image.
    """
    cx, cy = _check_center_pair(center)
    h, w = shape[0], shape[1]
    if not (0 <= cx <= w - 1 and 0 <= cy <= h - 1):
        raise VisionError(
            f"center ({cx:g}, {cy:g}) lies outside the {w}x{h} image "
            f"(expected 0 <= cx <= {w - 1}, 0 <= cy <= {h - 1})"
        )
    return cx, cy


@dataclass(frozen=True)
class MirrorCalibration:
    """The mirror rim: an ellipse with axes along u and v.

    Parameters
    ----------
    center : tuple of float
        Rim centre ``(cx, cy)`` in pixels (u to the right, v downward).
    aspect : float
        Rim semi-axis along u divided by rim semi-axis along v, in (0, 10].
    radius : float
        Rim semi-axis along v, pixels (> 0).

    Examples
    --------
    >>> cal = MirrorCalibration((320.0, 240.0), 1.1, 200.0)
    >>> cal.pixel(0.0, 1.0)
    (540.0, 240.0)
    >>> round(cal.image_angle(320.0, 40.0), 6)  # straight up in the image
    1.570796
    """

    center: tuple[float, float]
    aspect: float
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _check_center_pair(self.center))
        object.__setattr__(self, "aspect", _check_aspect(self.aspect))
        r = _finite_float("radius", self.radius)
        if not r > 0:
            raise VisionError(f"radius must be > 0 px, got {r}")
        object.__setattr__(self, "radius", r)

    @property
    def semi_axes(self) -> tuple[float, float]:
        """Rim semi-axes ``(along u, along v)`` in pixels."""
        return self.aspect * self.radius, self.radius

    def image_angle(self, u: float, v: float) -> float:
        """Image angle ``phi = atan2(-(v - cy) * aspect, u - cx)`` of pixel (u, v), radians."""
        cx, cy = self.center
        return math.atan2(-(v - cy) * self.aspect, u - cx)

    def pixel(self, phi: float, rho: float) -> tuple[float, float]:
        """Pixel ``(u, v)`` at image angle `phi` (radians) and fraction `rho` of the rim."""
        cx, cy = self.center
        return (
            cx + self.aspect * self.radius * rho * math.cos(phi),
            cy - self.radius * rho * math.sin(phi),
        )


def as_image_array(image: object) -> NDArray[Any]:
    """``image`` as a numpy array, or a VisionError (a ragged nested list cannot be one).

    Parameters
    ----------
    image : array_like
        The image.

    Returns
    -------
    ndarray
        ``image`` itself if it is an ndarray.

    Raises
    ------
    VisionError
        If numpy cannot make a rectangular array of it.
    """
    if isinstance(image, np.ndarray):
        return image
    try:
        return np.asarray(image)
    except (TypeError, ValueError):
        raise VisionError(
            f"image must be an array (H, W) or (H, W, C), got a {type(image).__name__} that is "
            "not rectangular (rows of different lengths?)"
        ) from None


def as_gray(image: object) -> NDArray[np.float32]:
    """Validate an image and convert it to a float32 grey image.

    Parameters
    ----------
    image : array_like
        ``(H, W)`` grey, ``(H, W, 1)``, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA; uint8,
        uint16, bool or float (any range, finite).

    Returns
    -------
    ndarray of float32, shape (H, W)
        Grey levels in the input's units.

    Raises
    ------
    VisionError
        For a wrong shape or dtype, a too small image, or non-finite values.
    """
    arr = as_image_array(image)
    if arr.dtype == bool:
        arr = arr.astype(np.uint8)
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise VisionError(f"image must hold numbers, got dtype {arr.dtype}")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim == 3 and arr.shape[2] not in (3, 4):
        raise VisionError(
            f"image must have 1, 3 or 4 channels, got shape {arr.shape} "
            f"(expected (H, W) or (H, W, 3))"
        )
    if arr.ndim not in (2, 3):
        raise VisionError(f"image must be 2-D (H, W) or 3-D (H, W, C), got shape {arr.shape}")
    if arr.shape[0] < 16 or arr.shape[1] < 16:
        raise VisionError(f"image is too small: {arr.shape[1]}x{arr.shape[0]}, need >= 16x16")
    if max(arr.shape[:2]) > MAX_IMAGE_SIDE:
        raise VisionError(
            f"image is too large: {arr.shape[1]}x{arr.shape[0]}, at most {MAX_IMAGE_SIDE} px "
            "a side (scale it down)"
        )
    f = arr.astype(np.float32, copy=False)
    if not np.all(np.isfinite(f)):
        raise VisionError("image contains NaN or infinite values")
    if f.ndim == 3:
        f = (
            f[:, :, 0] * np.float32(0.299)
            + f[:, :, 1] * np.float32(0.587)
            + f[:, :, 2] * (np.float32(0.114))
        )
    return np.ascontiguousarray(f, dtype=np.float32)


def _rough_ellipse(gray: NDArray[np.float32]) -> tuple[float, float, float, float, float]:
    """Rough ``(cx, cy, radius_v, aspect, outside_sign)`` from the mirror's convex hull.

    ``outside_sign`` is -1 if the outside is darker than the mirror, +1 if brighter.
    """
    h, w = gray.shape
    if float(gray.max()) == float(gray.min()):
        raise VisionError("no mirror rim found: the image is uniform")
    small = gray
    scale = 1.0
    if min(h, w) >= 256:  # the rough ellipse needs only pixel accuracy: work at half size
        small = np.asarray(
            cv2.resize(gray, (w // 2, h // 2), interpolation=cv2.INTER_AREA), dtype=np.float32
        )
        scale = 2.0
    small = np.asarray(cv2.GaussianBlur(small, (0, 0), 1.0), dtype=np.float32)
    bg, noise = _border_level(small)
    outside_bright = bg > float(np.median(small))
    far = float(np.percentile(small[::2, ::2], 1 if outside_bright else 99))
    contrast = abs(far - bg)
    if contrast <= max(6.0 * noise, 1e-6 * max(1.0, abs(bg))):
        raise VisionError(
            "no mirror rim found: nothing in the image stands out from the border "
            f"(contrast {contrast:.3g}, border noise {noise:.3g})"
        )
    # Anything clearly unlike the border is mirror: a dark wall sector must count too. The
    # relative part of the threshold is taken from the typical mirror pixel, not from the
    # extreme one: a bright camera reflection must not push a dim room's walls below it.
    dev = np.abs(small - bg)
    clear = dev > 5.0 * noise
    typical = float(np.median(dev[clear])) if np.any(clear) else contrast
    inside = dev > max(5.0 * noise, 0.12 * min(typical, contrast))
    inside_u8 = inside.astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(inside_u8, connectivity=8)
    if n < 2:
        raise VisionError("no mirror rim found: nothing stands out from the image border")
    # Dark poles can cut the mirror into sectors: keep every sizeable piece, then take the
    # convex hull of them all.
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = 1 + np.flatnonzero(areas >= max(0.002 * h * w / scale**2, 0.05 * float(areas.max())))
    comp = np.isin(labels, keep).astype(np.uint8)
    contours, _ = cv2.findContours(comp, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    hull = cv2.convexHull(np.concatenate(contours, axis=0))
    filled = np.zeros_like(comp)
    cv2.fillConvexPoly(filled, hull, 1)
    m = cv2.moments(filled, binaryImage=True)
    area = m["m00"]
    frac = area * scale * scale / (h * w)
    if frac < 0.01 or area < 50:
        raise VisionError(
            f"no mirror rim found: the mirror region covers only {frac:.1%} of the image"
        )
    # Pixel centres of the half-size image sit at 2 i + 0.5 in full-size pixels.
    cx = m["m10"] / area * scale + (scale - 1) / 2
    cy = m["m01"] / area * scale + (scale - 1) / 2
    # For a filled ellipse, mu20 / m00 = a_u**2 / 4 and mu02 / m00 = a_v**2 / 4.
    a_u = 2.0 * scale * math.sqrt(max(m["mu20"] / area, 1e-9))
    a_v = 2.0 * scale * math.sqrt(max(m["mu02"] / area, 1e-9))
    return cx, cy, a_v, a_u / a_v, (1.0 if outside_bright else -1.0)


def _rim_points(
    gray: NDArray[np.float32],
    cx: float,
    cy: float,
    radius: float,
    aspect: float,
    outside_sign: float,
    n_rays: int,
    search: float,
) -> NDArray[np.float64]:
    """Sub-pixel rim points ``(k, 2)`` (u, v): the strongest rim step along each ray."""
    step = 0.5  # px along v-radius units
    half = max(search * radius, 4.0)
    offs = np.arange(-half, half + step / 2, step)
    t = np.linspace(0.0, 2 * np.pi, n_rays, endpoint=False)
    rr = radius + offs  # v-radius of each sample
    map_x = (cx + aspect * np.cos(t)[:, None] * rr[None, :]).astype(np.float32)
    map_y = (cy - np.sin(t)[:, None] * rr[None, :]).astype(np.float32)
    prof = cv2.remap(
        gray,
        map_x,
        map_y,
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=float("nan"),
    )
    prof = cv2.GaussianBlur(prof, (0, 0), sigmaX=1.5, sigmaY=0.01)
    # The rim step goes from the mirror to the outside: mirror - outside has sign -outside_sign.
    d = np.zeros_like(prof)
    d[:, 1:-1] = (prof[:, 2:] - prof[:, :-2]) * 0.5
    score = d * outside_sign  # large where the profile steps towards the outside level
    score[~np.isfinite(score)] = -np.inf
    score[:, :2] = -np.inf
    score[:, -2:] = -np.inf
    j = np.argmax(score, axis=1)
    rows = np.arange(n_rays)
    peak = score[rows, j]
    ok = np.isfinite(peak) & (peak > 0)
    if not np.any(ok):
        return np.zeros((0, 2))
    level = np.median(peak[ok])
    ok &= peak > 0.3 * level
    jj = np.clip(j, 1, score.shape[1] - 2)
    s0, s1, s2 = score[rows, jj - 1], score[rows, jj], score[rows, jj + 1]
    with np.errstate(invalid="ignore", divide="ignore"):  # -inf where a ray left the image
        den = s0 - 2 * s1 + s2
        delta = np.where(
            np.isfinite(den) & (den < 0), 0.5 * (s0 - s2) / np.where(den == 0, 1, den), 0.0
        )
    delta = np.clip(np.nan_to_num(delta), -1.0, 1.0)
    r_hit = radius + offs[0] + (jj + delta) * step
    u = cx + aspect * np.cos(t) * r_hit
    v = cy - np.sin(t) * r_hit
    return np.column_stack([u, v])[ok]


#: Sectors of the rim checked on both sides, and the share of the visible ones outside the
#: fitted rim that must look like the image border.
_SIDE_SECTORS = 32
_MIN_OUTSIDE_LIKE_BORDER = 0.9


def _border_level(img: NDArray[np.float32]) -> tuple[float, float]:
    """The level of the image border (its median) and its noise (1.4826 median absolute
    deviations, a Gaussian's sd; written out: ``scipy.stats`` costs ``import omniloc`` most of
    a second): the outside of the rim owns the border."""
    border = np.concatenate([img[0], img[-1], img[:, 0], img[:, -1]])
    bg = float(np.median(border))
    return bg, 1.4826 * float(np.median(np.abs(border - bg)))


def _check_rim_sides(gray: NDArray[np.float32], cx: float, cy: float, r: float, a: float) -> None:
    """Refuse a fitted rim whose outside does not look like the image border.

    The outside of the true rim owns the image border, so just outside it the image is at
    the border's level, and just inside it mostly is not. A fit that locked onto something
    inside the mirror (the camera's reflection, the hull of a few bright poles) has mirror
    (walls) just outside it. The band from ``d1`` to ``d2`` px on each side is sampled in
    `_SIDE_SECTORS` sectors; a sector's level is the median of its samples, and it looks
    like the border when within ``3 * noise + 0.05 * contrast`` of the border's level
    (``noise`` the border's MAD scale, ``contrast`` the inside band's median distance from
    the border level). Sectors mostly off the image are skipped.

    Raises
    ------
    VisionError
        If fewer than `_MIN_OUTSIDE_LIKE_BORDER` of the visible sectors outside the rim
        look like the border, or if none inside the rim is unlike it.
    """
    g = np.asarray(cv2.GaussianBlur(gray, (0, 0), 1.0), dtype=np.float32)
    bg, noise = _border_level(g)
    d1 = max(3.0, 0.04 * r)
    d2 = d1 + max(4.0, 0.06 * r)
    per_sector = 8
    t = np.linspace(0.0, 2 * np.pi, _SIDE_SECTORS * per_sector, endpoint=False)

    def sector_levels(lo: float, hi: float) -> NDArray[np.float64]:
        rr = np.linspace(max(lo, 0.0), hi, 6)
        map_x = (cx + a * np.cos(t)[:, None] * rr[None, :]).astype(np.float32)
        map_y = (cy - np.sin(t)[:, None] * rr[None, :]).astype(np.float32)
        prof = cv2.remap(
            g,
            map_x,
            map_y,
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=float("nan"),
        ).reshape(_SIDE_SECTORS, -1)
        levels = [
            float(np.median(row[np.isfinite(row)]))
            for row in prof
            if np.isfinite(row).mean() >= 0.5
        ]
        return np.asarray(levels, dtype=np.float64)

    outside = sector_levels(r + d1, r + d2)
    inside = sector_levels(r - d2, r - d1)
    if len(outside) < 4 or len(inside) < 4:
        return  # too little of the rim's surroundings on the image to tell
    contrast = float(np.median(np.abs(inside - bg)))
    tol = 3.0 * noise + 0.05 * contrast
    like_outside = float(np.mean(np.abs(outside - bg) <= tol))
    unlike_inside = float(np.mean(np.abs(inside - bg) > tol))
    fitted = f"the fitted ellipse (centre ({cx:.1f}, {cy:.1f}), aspect {a:.3g}, radius {r:.3g} px)"
    if like_outside < _MIN_OUTSIDE_LIKE_BORDER:
        raise VisionError(
            f"no clear mirror rim: only {like_outside:.0%} of the band just outside {fitted} "
            f"is at the image border's level (need {_MIN_OUTSIDE_LIKE_BORDER:.0%}); it is "
            "probably something inside the mirror (the camera's reflection, bright poles). "
            "Pass the calibration if it is known"
        )
    if unlike_inside == 0.0:
        raise VisionError(
            f"no clear mirror rim: the band just inside {fitted} is all at the image border's level"
        )


def _fit_ellipse(
    pts: NDArray[np.float64],
    init: tuple[float, float, float, float],
    fixed: dict[str, float],
    iterations: int = 12,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Robust fit of ``(cx, cy, radius, aspect)``; returns parameters and residuals (px).

    Gauss-Newton with an analytic Jacobian, iteratively reweighted (Huber weights at the
    MAD scale of the residuals), then refitted on the inliers (within 3 scales). The residual
    of a point is its normalised elliptic radius minus 1, times `radius`: about its distance
    from the rim in pixels.
    """
    names = ("cx", "cy", "radius", "aspect")
    free = np.array([k not in fixed for k in names])
    p = np.array([fixed.get(k, init[i]) for i, k in enumerate(names)], dtype=np.float64)
    u, v = pts[:, 0], pts[:, 1]

    def resid_jac(q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        cx, cy, r, a = q
        xn = (u - cx) / (a * r)
        yn = (v - cy) / r
        rho = np.maximum(np.sqrt(xn * xn + yn * yn), 1e-12)
        res = (rho - 1.0) * r
        jac = np.column_stack(
            [-xn / (a * rho), -yn / rho, -np.ones_like(rho), -r * xn * xn / (a * rho)]
        )
        return res, jac

    def solve(q: NDArray[np.float64], weight_fn: object) -> NDArray[np.float64]:
        for _ in range(iterations):
            res, jac = resid_jac(q)
            wts = weight_fn(res)  # type: ignore[operator]
            jf = jac[:, free] * wts[:, None]
            lhs = jf.T @ jac[:, free]
            rhs = -(jf.T @ res)
            lhs += 1e-9 * np.eye(lhs.shape[0]) * max(float(np.trace(lhs)), 1e-12)
            try:
                step = np.linalg.solve(lhs, rhs)
            except np.linalg.LinAlgError:
                break
            q = q.copy()
            q[free] += step
            q[2] = max(q[2], 1.0)
            q[3] = min(max(q[3], 0.05), 20.0)
            if float(np.max(np.abs(step))) < 1e-6:
                break
        return q

    if not free.any():
        return p, resid_jac(p)[0]
    res0 = resid_jac(p)[0]
    scale = max(1.4826 * float(np.median(np.abs(res0 - np.median(res0)))), 0.5)

    def huber(res: NDArray[np.float64]) -> NDArray[np.float64]:
        k = 1.345 * scale
        a = np.abs(res)
        return np.where(a <= k, 1.0, k / np.maximum(a, 1e-12))

    p = solve(p, huber)
    res = resid_jac(p)[0]
    scale = max(1.4826 * float(np.median(np.abs(res))), 0.25)
    p = solve(p, huber)
    res = resid_jac(p)[0]
    inl = (np.abs(res) < 3.0 * scale).astype(np.float64)
    if inl.sum() >= 8:
        p = solve(p, lambda _r: inl)
    return p, resid_jac(p)[0]


def calibrate_mirror(
    image: object,
    *,
    center: tuple[float, float] | None = None,
    aspect: float | None = None,
    radius: float | None = None,
    n_rays: int = 720,
) -> MirrorCalibration:
    """Find the mirror rim (centre, aspect ratio, radius) to sub-pixel accuracy.

    Parameters
    ----------
    image : ndarray
        ``(H, W)`` grey or ``(H, W, 3)`` colour image (uint8, uint16 or float).
    center : tuple of float, optional
        Known rim centre ``(cx, cy)`` in pixels; only the other parameters are fitted.
    aspect : float, optional
        Known aspect ratio (rim semi-axis along u / along v), in (0, 10].
    radius : float, optional
        Known rim semi-axis along v, pixels.
    n_rays : int
        Number of rays cast to find rim points (>= 16).

    Returns
    -------
    MirrorCalibration
        The fitted rim; fixed parameters are returned as given.

    Raises
    ------
    VisionError
        If the image is malformed, uniform, or shows no clear elliptical rim; or if a given
        parameter is absurd (aspect <= 0 or > 10, centre outside the image, NaN).

    Examples
    --------
    >>> from omniloc.vision.render import DEMO_POSE, OmniCamera, demo_scene, render_omni_image
    >>> cam = OmniCamera(center=(318.2, 243.6), aspect=1.04, radius=210.0)
    >>> cal = calibrate_mirror(render_omni_image(demo_scene(), DEMO_POSE, cam, rng=1))
    >>> [round(c) for c in cal.center], round(cal.aspect, 2), round(cal.radius)
    ([318, 244], 1.04, 210)
    """
    gray = as_gray(image)
    h, w = gray.shape
    fixed: dict[str, float] = {}
    if center is not None:
        fixed["cx"], fixed["cy"] = check_center(center, gray.shape)
    if aspect is not None:
        fixed["aspect"] = _check_aspect(aspect)
    if radius is not None:
        r = _finite_float("radius", radius)
        if not 1 <= r <= 10 * max(h, w):
            raise VisionError(f"radius must be in [1, {10 * max(h, w)}] px, got {r}")
        fixed["radius"] = r
    n_rays = _count("n_rays", n_rays, 16, MAX_IMAGE_SIDE)
    if len(fixed) == 4:
        return MirrorCalibration((fixed["cx"], fixed["cy"]), fixed["aspect"], fixed["radius"])

    cx, cy, r0, a0, outside_sign = _rough_ellipse(gray)
    params = np.array(
        [
            fixed.get("cx", cx),
            fixed.get("cy", cy),
            fixed.get("radius", r0),
            fixed.get("aspect", a0),
        ]
    )
    inlier_frac = 0.0
    rms = float("inf")
    for search, rays in ((0.15, max(int(n_rays) // 4, 16)), (0.04, int(n_rays))):
        cx0, cy0, r_0, a_0 = (float(q) for q in params)
        pts = _rim_points(gray, cx0, cy0, r_0, a_0, outside_sign, rays, search)
        if len(pts) < 12:
            raise VisionError(f"no mirror rim found: only {len(pts)} rim points (need >= 12)")
        p0 = (float(params[0]), float(params[1]), float(params[2]), float(params[3]))
        params, res = _fit_ellipse(pts, p0, fixed)
        inl = np.abs(res) < 1.5
        inlier_frac = float(np.sum(inl)) / rays
        rms = float(np.sqrt(np.mean(res[inl] ** 2))) if np.any(inl) else float("inf")
    cx, cy, r, a = (float(p) for p in params)
    if inlier_frac < 0.3 or not math.isfinite(rms):
        raise VisionError(
            f"no clear elliptical mirror rim: only {inlier_frac:.0%} of the rays "
            "found a rim edge on a common ellipse"
        )
    if not (0 <= cx <= w - 1 and 0 <= cy <= h - 1):
        raise VisionError(f"no mirror rim found: fitted centre ({cx:.1f}, {cy:.1f}) is off-image")
    if not 0 < a <= _MAX_ASPECT:
        raise VisionError(f"no mirror rim found: fitted aspect {a:.3g} is implausible")
    if not 4 <= r <= 10 * max(h, w):
        raise VisionError(f"no mirror rim found: fitted radius {r:.3g} px is implausible")
    _check_rim_sides(gray, cx, cy, r, a)
    return MirrorCalibration((cx, cy), a, r)
