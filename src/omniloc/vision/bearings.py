"""Bearings of vertical edges and poles from an omnidirectional image.

Vertical structures in the room become radial lines in the image of a conic mirror, so their
image angles are their bearings (seed paper, section 1). Conventions (fixed for all of
omniloc):

* pixel ``(u, v)``: u = column to the right, v = row downward, (0, 0) the centre of the
  top-left pixel;
* image angle ``phi = atan2(-(v - cy) * aspect, u - cx)`` (counter-clockwise as displayed,
  0 to the right), with the rim centre ``(cx, cy)`` and ``aspect`` = rim semi-axis along u /
  rim semi-axis along v;
* bearing ``wrap(s * (phi - forward))`` with ``s = -1`` for a mirrored sensor, else ``+1``;
  ``forward`` is the image angle of the robot's forward axis (bearing 0, mirrored or not).
  Bearings are in radians, counter-clockwise from forward, in [-pi, pi).

Method: unwrap the mirror annulus (without the camera's own reflection and the rim) to a
panorama whose columns are image angles and rows radii; take the azimuthal derivative of
every row; combine the rows by their median and keep the peaks that most rows agree with in
sign (so texture that varies along the radius cancels out); refine each peak to sub-column
accuracy with a parabola; suppress duplicates (wrap-around aware); and read each pair of
neighbouring opposite steps (a stripe) as a pole or as a narrow wall segment from what the
image shows: whether the background continues on both sides of the stripe (a pole) or two
different walls meet it (a wall segment), how well its two steps balance, and its width
against the narrowest wall segment and the widest pole. A stripe the evidence cannot decide
is reported as its two edges, flagged ``ambiguous``.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import tempfile
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from omniloc.angles import wrap
from omniloc.errors import VisionError
from omniloc.io import as_path, shorten
from omniloc.vision.calibrate import (
    MirrorCalibration,
    _check_aspect,
    _count,
    _finite_float,
    as_gray,
    as_image_array,
    calibrate_mirror,
    check_center,
)

__all__ = [
    "EdgeDetections",
    "bearings_from_image",
    "extract_bearings",
    "load_image",
    "unwrap_panorama",
]

_PAD = 16  # wrap-around padding (columns) for azimuthal filtering

#: The largest ``forward`` angle accepted, radians: beyond it wrapping loses the precision
#: of a bearing (at 1e300 every detection fell on one bearing).
MAX_FORWARD = 1e6

#: The largest ``smoothing`` (Gaussian sigma, panorama columns): a blur wider than a few
#: degrees erases the edges it looks for (1e6 took 90 s to blur everything away).
MAX_SMOOTHING = 100.0


@dataclass(frozen=True, eq=False)
class EdgeDetections:
    """Radial features found in one image, sorted by bearing.

    Attributes
    ----------
    bearings : ndarray, shape (k,)
        Bearings in the robot frame, radians in [-pi, pi).
    strength : ndarray, shape (k,)
        Contrast in 8-bit grey levels: the step height of an edge, the mean step height of
        the two sides of a pole.
    kind : ndarray of str, shape (k,)
        ``"edge"`` (an intensity step across azimuth) or ``"pole"`` (a narrow dark or bright
        stripe, reported once at its centre).
    image_angles : ndarray, shape (k,)
        Image angles ``phi`` of the detections, radians in [-pi, pi).
    calibration : MirrorCalibration
        The rim used.
    forward : float
        Image angle of the robot's forward axis, radians.
    mirrored : bool
        Whether the sense of rotation was flipped.
    ambiguous : ndarray of bool, shape (k,)
        True for the two edges of a stripe that could be a pole as well as a narrow wall
        segment (see :func:`extract_bearings`): if it is a segment both are right, if it is
        a pole both are off by half its width and the pole's centre is not reported. A
        caller can allow for that with ``max_spurious`` (up to ``ambiguous.sum()`` more
        bearings may be spurious). All False when not given.

    A result with no detections has length 0 and is falsy.
    """

    bearings: NDArray[np.float64]
    strength: NDArray[np.float64]
    kind: NDArray[np.str_]
    image_angles: NDArray[np.float64]
    calibration: MirrorCalibration
    forward: float = 0.0
    mirrored: bool = False
    ambiguous: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def __post_init__(self) -> None:
        for name in ("bearings", "strength", "kind", "image_angles"):
            arr = np.array(getattr(self, name))
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        k = self.bearings.shape[0]
        flags = np.array(self.ambiguous, dtype=bool).reshape(-1)
        if flags.size == 0:
            flags = np.zeros(k, dtype=bool)
        if flags.shape[0] != k:
            raise VisionError(
                f"ambiguous must have one flag per detection: expected {k}, got {flags.shape[0]}"
            )
        flags.setflags(write=False)
        object.__setattr__(self, "ambiguous", flags)

    def __len__(self) -> int:
        return int(self.bearings.shape[0])


@contextlib.contextmanager
def _c_stderr() -> Iterator[list[str]]:
    """Keep what C libraries (OpenCV, libpng) write to file descriptor 2 during the block off
    the terminal; the list then holds its last line (without OpenCV's log prefix), if any."""
    said: list[str] = []
    try:
        saved = os.dup(2)
    except OSError:  # no descriptor 2 to protect
        yield said
        return
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        try:
            yield said
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            lines = [ln.strip() for ln in f.read(4096).decode("utf-8", "replace").splitlines()]
            lines = [ln for ln in lines if ln]
            if lines:
                last = re.sub(r"^\[\s*\w+:\S*\]\s*(global\s+\S+\s+)?", "", lines[-1])
                said.append(shorten(last, 100).strip("'\""))


def load_image(path: str | os.PathLike[str]) -> NDArray[Any]:
    """Read an image file (PNG, JPEG, TIFF, ... anything OpenCV reads).

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    ndarray
        ``(H, W)`` grey or ``(H, W, 3)`` RGB (``(H, W, 4)`` RGBA), as stored: usually
        uint8, uint16 for 16-bit PNG/TIFF. The pixels as stored: a JPEG's EXIF orientation
        is not applied (a viewer may show the image rotated).

    Raises
    ------
    VisionError
        If the file does not exist or cannot be decoded as an image.
    """
    p = as_path(path, "image path", VisionError)
    if p.is_dir():
        raise VisionError(f"cannot read image {str(p)!r}: it is a directory")
    if not p.is_file():
        raise VisionError(f"cannot read image {str(p)!r}: no such file")
    try:
        data = np.fromfile(p, dtype=np.uint8)
    except OSError as exc:
        raise VisionError(f"cannot read image {str(p)!r}: {exc.strerror or exc}") from None
    img: NDArray[Any] | None = None
    if data.size:
        with _c_stderr() as said:
            img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if img is None:
        why = said[-1] if data.size and said else ""
        raise VisionError(
            f"cannot read image {str(p)!r}: not an image format OpenCV can decode"
            + (f" ({why})" if why else "")
        )
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    elif img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA)
    return img


def _to_8bit(image: object) -> tuple[NDArray[np.float32], NDArray[Any] | None, float]:
    """Grey float32 image in 8-bit units; for a colour image its RGB, as given; the scale.

    The scale takes the image to 8-bit units: uint16 is divided by 257, a float image is
    multiplied by 255 when its grey maximum is <= 1. The grey image is already scaled.
    """
    arr = as_image_array(image)
    gray = as_gray(arr)
    scale = 1.0
    if arr.dtype == np.uint16:
        scale = 1.0 / 257.0
    elif np.issubdtype(arr.dtype, np.floating) and float(gray.max()) <= 1.0:
        scale = 255.0
    if scale != 1.0:
        gray *= np.float32(scale)
    rgb = arr[:, :, :3] if arr.ndim == 3 and arr.shape[2] in (3, 4) else None
    return gray, rgb, scale


def _gray8(image: object) -> NDArray[np.float32]:
    """Grey float32 image in 8-bit units (uint16 divided by 257, floats in [0, 1] scaled)."""
    return _to_8bit(image)[0]


def _remap_colour(
    rgb: NDArray[Any],
    maps: tuple[NDArray[np.float32], NDArray[np.float32]],
    scale: float,
    off_image: NDArray[np.bool_],
) -> list[NDArray[np.float32]]:
    """R, G and B panoramas in 8-bit units, NaN where the grey panorama is (`off_image`).

    The image is remapped in its own type where OpenCV can (no full-size float copy).
    """
    src = rgb if rgb.dtype in (np.uint8, np.uint16, np.float32) else rgb.astype(np.float32)
    pano = cv2.remap(
        np.ascontiguousarray(src), maps[0], maps[1], cv2.INTER_LINEAR, borderValue=0
    ).astype(np.float32)
    if scale != 1.0:
        pano *= np.float32(scale)
    pano[off_image] = np.nan
    return [pano[:, :, c] for c in range(3)]


def _panorama_size(cal: MirrorCalibration, radial_range: tuple[float, float]) -> tuple[int, int]:
    """Rows and columns: about 2 px per row and 1 px per column at the outer radius."""
    r0, r1 = radial_range
    outer = r1 * cal.radius * max(cal.aspect, 1.0)
    n_cols = int(np.clip(4 * math.ceil(2 * math.pi * outer / 4), 360, 4096))
    n_rows = int(np.clip(round((r1 - r0) * cal.radius / 2.0), 8, 64))
    return n_rows, n_cols


def _check_radial_range(radial_range: object) -> tuple[float, float]:
    try:
        r0, r1 = (float(r) for r in radial_range)  # type: ignore[attr-defined]
    except (TypeError, ValueError, OverflowError):
        raise VisionError(
            f"radial_range must be (inner, outer) fractions of the rim, got {shorten(radial_range)}"
        ) from None
    if not (math.isfinite(r0) and math.isfinite(r1) and 0 <= r0 < r1 <= 1.5):
        raise VisionError(f"radial_range must satisfy 0 <= inner < outer <= 1.5, got {(r0, r1)}")
    return r0, r1


def unwrap_panorama(
    image: object,
    calibration: MirrorCalibration,
    *,
    radial_range: tuple[float, float] = (0.4, 0.95),
    n_rows: int | None = None,
    n_cols: int | None = None,
) -> NDArray[np.float32]:
    """Unwrap the mirror annulus into a panorama of image angle by radius.

    Parameters
    ----------
    image : ndarray
        ``(H, W)`` or ``(H, W, 3)`` image.
    calibration : MirrorCalibration
        The rim.
    radial_range : tuple of float
        Inner and outer radius as fractions of the rim (normalised elliptic radius).
    n_rows, n_cols : int, optional
        Panorama size; by default about 2 px per row and 1 px per column at the outer radius.

    Returns
    -------
    ndarray of float32, shape (n_rows, n_cols)
        Grey levels (8-bit units); NaN where the sample falls outside the image. Column ``j``
        is at image angle ``phi = 2 pi j / n_cols``; row ``i`` at the radius
        ``linspace(inner, outer, n_rows)[i]``.

    Raises
    ------
    VisionError
        If the image or the parameters are malformed.
    """
    gray = _gray8(image)
    if not isinstance(calibration, MirrorCalibration):
        raise VisionError(
            f"calibration must be a MirrorCalibration, got {type(calibration).__name__}"
        )
    r0, r1 = _check_radial_range(radial_range)
    rows, cols = _panorama_size(calibration, (r0, r1))
    # At most 1024 x 16384 samples (64 MiB): far beyond what an image's annulus holds.
    rows = rows if n_rows is None else _count("n_rows", n_rows, 1, 1024)
    cols = cols if n_cols is None else _count("n_cols", n_cols, 8, 16384)
    return _remap_panorama(gray, calibration, r0, r1, rows, cols)


def _panorama_maps(
    cal: MirrorCalibration, r0: float, r1: float, rows: int, cols: int
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Pixel coordinates ``(map_x, map_y)`` of every panorama sample, for ``cv2.remap``."""
    cx, cy = cal.center
    phi = np.arange(cols) * (2 * np.pi / cols)
    rho = np.linspace(r0, r1, rows)
    map_x = (cx + cal.aspect * cal.radius * rho[:, None] * np.cos(phi)[None, :]).astype(np.float32)
    map_y = (cy - cal.radius * rho[:, None] * np.sin(phi)[None, :]).astype(np.float32)
    return map_x, map_y


def _remap(
    image: NDArray[np.float32], maps: tuple[NDArray[np.float32], NDArray[np.float32]]
) -> NDArray[np.float32]:
    """The panorama of a float32 grey image; NaN off the image."""
    out: NDArray[np.float32] = np.asarray(
        cv2.remap(
            image,
            maps[0],
            maps[1],
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=float("nan"),
        ),
        dtype=np.float32,
    )
    return out


def _remap_panorama(
    gray: NDArray[np.float32],
    cal: MirrorCalibration,
    r0: float,
    r1: float,
    rows: int,
    cols: int,
) -> NDArray[np.float32]:
    return _remap(gray, _panorama_maps(cal, r0, r1, rows, cols))


def _azimuth_derivative(pano: NDArray[np.float32], sigma: float) -> NDArray[np.float32]:
    """Derivative along columns (grey levels per column) after Gaussian smoothing, wrapped."""
    padded = np.concatenate([pano[:, -_PAD:], pano, pano[:, :_PAD]], axis=1)
    if sigma > 0:
        padded = cv2.GaussianBlur(
            padded, (0, 0), sigmaX=sigma, sigmaY=1e-3, borderType=cv2.BORDER_REPLICATE
        )
    d = (padded[:, _PAD + 1 : -_PAD + 1] - padded[:, _PAD - 1 : -_PAD - 1]) * np.float32(0.5)
    return np.ascontiguousarray(d)


def _resolve_calibration(
    gray: NDArray[np.float32],
    center: object,
    aspect: object,
    calibration: MirrorCalibration | None,
) -> MirrorCalibration:
    if calibration is not None and not isinstance(calibration, MirrorCalibration):
        raise VisionError(
            f"calibration must be a MirrorCalibration, got {type(calibration).__name__}"
        )
    c = None if center is None else check_center(center, gray.shape)
    a = None if aspect is None else _check_aspect(aspect)
    if calibration is None:
        return calibrate_mirror(gray, center=c, aspect=a)
    check_center(calibration.center, gray.shape)
    return MirrorCalibration(
        calibration.center if c is None else c,
        calibration.aspect if a is None else a,
        calibration.radius,
    )


def _find_steps(
    d_med: NDArray[np.float64],
    agree: NDArray[np.float64],
    min_contrast: float,
    min_agreement: float,
    min_sep_cols: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sub-column positions and signed heights of the steps in the median derivative."""
    n = d_med.shape[0]
    mad = float(np.median(np.abs(d_med - np.median(d_med))))
    thr = max(4.0 * 1.4826 * mad, 0.05 * min_contrast)
    a = np.abs(d_med)
    left, right = np.roll(a, 1), np.roll(a, -1)
    cand = np.flatnonzero((a > thr) & (a >= left) & (a > right) & (agree >= min_agreement))
    pos: list[float] = []
    height: list[float] = []
    for j in cand:
        s = 1.0 if d_med[j] > 0 else -1.0
        # Step height: the area of the derivative lobe (same sign, contiguous, bounded).
        total = float(d_med[j])
        for direction in (1, -1):
            k = 1
            while k <= 24:
                val = float(d_med[(j + direction * k) % n])
                if val * s <= 0:
                    break
                total += val
                k += 1
        if abs(total) < min_contrast:
            continue
        y0, y1, y2 = a[(j - 1) % n], a[j], a[(j + 1) % n]
        den = y0 - 2 * y1 + y2
        delta = 0.5 * (y0 - y2) / den if den < 0 else 0.0
        pos.append(j + float(np.clip(delta, -0.5, 0.5)))
        height.append(total)
    p = np.asarray(pos)
    h = np.asarray(height)
    # Non-maximum suppression among same-sign steps, wrap-around aware.
    keep: list[int] = []
    for i in np.argsort(-np.abs(h), kind="stable"):
        ok = True
        for k in keep:
            gap = abs((p[i] - p[k] + n / 2) % n - n / 2)
            if gap < min_sep_cols and np.sign(h[i]) == np.sign(h[k]):
                ok = False
                break
        if ok:
            keep.append(int(i))
    idx = np.sort(np.asarray(keep, dtype=np.int64))
    if idx.size:
        idx = idx[np.argsort(p[idx], kind="stable")]
    return p[idx], h[idx]


# How much the two sides of one background may differ (grey levels): a floor, multiples of
# the measured standard error, and a fraction of the background's level (lighting and shading
# scale with it). On 98 rendered rooms the sides of a pole differed by at most 3 se + 2.5 %.
_SIDE_FLOOR = 1.0
_SIDE_SIGMAS = 3.0
_SIDE_RELATIVE = 0.06
# A stripe whose two steps differ by more than this fraction of the larger one contrasts with
# one side only: two unrelated edges, not a stripe.
_MAX_IMBALANCE = 0.6
# Where a side cannot be seen (another step too close), the sides are taken to differ when
# the steps differ by more than this fraction of the larger one (poles: at most 0.11).
_BLIND_IMBALANCE = 0.25
_SIDE_WINDOW = 10  # columns averaged on each side of a stripe, at most
# A stripe's measured width is within this many columns of the truth (3 standard deviations
# on rendered images: 0.1 column), so a balanced stripe measured up to this much wider than
# min_segment_width is still read as a pole.
_WIDTH_SLACK = 0.3


def _window(step: float, gap: float, outward: int, off: int) -> tuple[int, int] | None:
    """``(first column, width)`` of the background beside a step, away from the stripe.

    The window starts `off` columns from the step (past its blur) and stops `off` columns
    short of the next step, `gap` columns away, at most `_SIDE_WINDOW` wide; None if there
    is no room (the next step is so close that its blur meets this one's). The first column
    may be negative: columns wrap around.
    """
    width = int(min(_SIDE_WINDOW, math.floor(gap - 2 * off)))
    if width < 1:
        return None
    if outward > 0:
        return round(step + off), width
    return round(step - off) - width + 1, width


def _sides_differ(
    channels: NDArray[np.float32],
    left: list[tuple[int, int]],
    right: list[tuple[int, int]],
) -> NDArray[np.bool_]:
    """Whether the backgrounds in windows ``left[k]`` and ``right[k]`` differ, for every k.

    `channels` has shape ``(C, rows, columns)``; a window is ``(first column, width)``. In
    each row the two windows' means are compared, so the wall's horizontal bands and texture
    (which vary along the radius) cancel in the row's difference; the difference is the
    median over the rows (NaN samples, off the image, are left out). It must exceed
    ``floor + 3 se + 0.06 * level`` (``se`` its standard error from the rows' spread,
    ``level`` the mean of the two sides, from the channel's black: 0, or the image's minimum
    if that is negative) in at least one channel.
    """
    n = channels.shape[2]
    offsets = np.arange(_SIDE_WINDOW)

    def means(windows: list[tuple[int, int]]) -> NDArray[np.float64]:
        first = np.asarray([w[0] for w in windows])
        width = np.asarray([w[1] for w in windows])
        block = channels[:, :, (first[:, None] + offsets) % n]  # (C, rows, k, window)
        ok = (offsets < width[:, None]) & np.isfinite(block)
        with np.errstate(invalid="ignore"):  # 0 / 0: a row wholly off the image
            out = np.where(ok, block, 0.0).sum(axis=3) / ok.sum(axis=3)
        return np.ascontiguousarray(out.transpose(0, 2, 1))  # (C, k, rows)

    lv, rv = means(left), means(right)
    diff = lv - rv
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN: rim partly outside
        median = np.nanmedian if np.isnan(diff).any() else np.median
        med = median(diff, axis=2)
        spread = 1.4826 * median(np.abs(diff - med[:, :, None]), axis=2)
        level = 0.5 * (np.nanmean(lv, axis=2) + np.nanmean(rv, axis=2))
    rows = np.maximum(np.sum(np.isfinite(diff), axis=2), 1)
    se = 1.2533 * spread / np.sqrt(rows)
    tol = _SIDE_FLOOR + _SIDE_SIGMAS * se + _SIDE_RELATIVE * level
    differ: NDArray[np.bool_] = np.any(np.abs(med) > tol, axis=0)  # NaN compares False
    return differ


def _group_steps(
    pos: NDArray[np.float64],
    height: NDArray[np.float64],
    n: int,
    channels: NDArray[np.float32],
    max_width_cols: float,
    min_segment_cols: float,
    off: int,
) -> tuple[list[tuple[int, ...]], NDArray[np.bool_]]:
    """Read each stripe (two neighbouring opposite steps) as a pole, a segment or either.

    For the stripe between steps ``i`` and ``j`` (``j`` next counter-clockwise, at most
    `max_width_cols` away) the background just outside each step is compared in every
    channel (grey, and R, G, B for a colour image; see :func:`_sides_differ`). A pole stands
    in front of one wall, so its two sides show the same background; a narrow wall segment
    separates two walls, which usually differ but may happen to match. Where another step
    is too close to see a side, the sides are taken to differ if the two steps do by more
    than a quarter of the larger.

    * narrower than `min_segment_cols` (plus 0.3 column for the width's measurement):
      sides the same: a **pole**; sides different, while the stripe contrasts with both
      (imbalance ``|h_i + h_j| / max |h| <= 0.6``): a pole in front of a wall edge or a
      wall segment narrower than expected: two **ambiguous** edges; else two edges;
    * from `min_segment_cols` up: sides different: a wall segment, two edges; sides the
      same: a pole as wide or a segment between two walls alike: two **ambiguous** edges.

    Poles are taken in order of increasing imbalance (to 0.1), then width, each step used
    once; an ambiguous flag is only set on steps no pole took.

    Returns
    -------
    groups : list of tuple of int
        ``(i, j)`` for a pole, ``(i,)`` for an edge.
    ambiguous : ndarray of bool, shape (len(pos),)
        Per step.
    """
    m = pos.shape[0]
    # Stripes: (i, j, width, imbalance), and the windows beside those whose sides are seen.
    stripes: list[tuple[int, int, float, float]] = []
    seen: list[int] = []
    left: list[tuple[int, int]] = []
    right: list[tuple[int, int]] = []
    for i in range(m if m > 2 else m - 1):
        j = (i + 1) % m
        width = (pos[j] - pos[i]) % n
        hi, hj = height[i], height[j]
        if np.sign(hi) == np.sign(hj) or width > max_width_cols:
            continue
        lw = _window(pos[i], (pos[i] - pos[(i - 1) % m]) % n, -1, off)
        rw = _window(pos[j], (pos[(j + 1) % m] - pos[j]) % n, 1, off)
        if lw is not None and rw is not None:
            seen.append(len(stripes))
            left.append(lw)
            right.append(rw)
        stripes.append((i, j, width, abs(hi + hj) / max(abs(hi), abs(hj))))
    differ = np.asarray([imbalance > _BLIND_IMBALANCE for *_, imbalance in stripes], dtype=bool)
    if seen:
        differ[seen] = _sides_differ(channels, left, right)
    poles: list[tuple[float, float, int, int]] = []
    unsure: list[tuple[int, int]] = []
    for (i, j, width, imbalance), sides_differ in zip(stripes, differ, strict=True):
        if width < min_segment_cols + _WIDTH_SLACK:
            if not sides_differ:
                poles.append((round(imbalance, 1), width, i, j))
            elif imbalance <= _MAX_IMBALANCE:
                unsure.append((i, j))
        elif not sides_differ:
            unsure.append((i, j))
    used: set[int] = set()
    groups: list[tuple[int, ...]] = []
    for _, _, i, j in sorted(poles):
        if i in used or j in used:
            continue
        used.update((i, j))
        groups.append((i, j))
    ambiguous = np.zeros(m, dtype=bool)
    for i, j in unsure:
        if i not in used and j not in used:
            ambiguous[[i, j]] = True
    groups.extend((i,) for i in range(m) if i not in used)
    return groups, ambiguous


def extract_bearings(
    image: object,
    *,
    center: tuple[float, float] | None = None,
    aspect: float | None = None,
    forward: float = 0.0,
    mirrored: bool = False,
    calibration: MirrorCalibration | None = None,
    radial_range: tuple[float, float] = (0.4, 0.95),
    min_contrast: float = 10.0,
    min_agreement: float = 0.7,
    max_pole_width: float = np.deg2rad(8.0),
    min_separation: float = np.deg2rad(1.0),
    smoothing: float = 1.0,
    min_segment_width: float = np.deg2rad(5.0),
) -> EdgeDetections:
    """Detect radial edges and poles in an omnidirectional image and return their bearings.

    Parameters
    ----------
    image : ndarray
        ``(H, W)`` grey or ``(H, W, 3)`` RGB image; uint8, uint16 or float (floats with
        maximum <= 1 are taken as [0, 1]).
    center : tuple of float, optional
        Rim centre ``(cx, cy)`` in pixels; overrides `calibration` or is held fixed while the
        rest of the rim is fitted.
    aspect : float, optional
        Rim semi-axis along u / along v, in (0, 10]; same role as `center`.
    forward : float
        Image angle of the robot's forward axis, radians.
    mirrored : bool
        True if the mirror flips the sense of rotation (bearing = forward - phi).
    calibration : MirrorCalibration, optional
        A known rim; by default :func:`calibrate_mirror` finds it in `image`.
    radial_range : tuple of float
        Part of the annulus used, as fractions of the rim: excludes the camera's reflection
        (inside) and the rim itself (outside).
    min_contrast : float
        Smallest step height kept, 8-bit grey levels.
    min_agreement : float
        Smallest fraction of panorama rows whose derivative has the sign of the median, in
        [0, 1]: a radial line is consistent along the radius, texture is not.
    max_pole_width : float
        Widest stripe, radians, that may be a pole. Wider stripes are two plain edges.
    min_separation : float
        Same-sign steps closer than this (radians) are duplicates; the weaker is dropped.
    smoothing : float
        Gaussian smoothing along the azimuth before differentiation, panorama columns.
    min_segment_width : float
        Narrowest wall segment (a run of wall between two vertical wall edges) expected,
        radians. A stripe (two neighbouring opposite steps: brighter or darker than both
        sides) narrower than this whose two sides show the same background, in every colour
        channel, is a pole, reported once at its centre. A stripe from this width up to
        `max_pole_width` is a wall segment (two edges) if the walls on its two sides
        clearly differ, and otherwise could be either: its two edges are reported with
        ``ambiguous`` set, as are those of a narrower stripe whose sides differ (a pole in
        front of a wall edge, or a segment narrower than expected). Set it to
        `max_pole_width` to read every balanced stripe up to that width as a pole.

    Returns
    -------
    EdgeDetections
        Bearings (radians, robot frame), strengths, kinds, ambiguity flags, sorted by
        bearing.

    Raises
    ------
    VisionError
        If the image is malformed or shows no rim (and none is given), or a parameter is
        absurd (aspect <= 0 or > 10, centre outside the image, non-finite values).

    Examples
    --------
    >>> from omniloc.vision.render import DEMO_POSE, demo_scene, render_omni_image, true_features
    >>> img = render_omni_image(demo_scene(), DEMO_POSE, rng=0)
    >>> det = extract_bearings(img)
    >>> len(det) == len(true_features(demo_scene(), DEMO_POSE))
    True
    """
    gray, rgb, scale = _to_8bit(image)
    fwd = _finite_float("forward", forward)
    if abs(fwd) > MAX_FORWARD:
        raise VisionError(
            f"forward must be an angle in radians of magnitude at most {MAX_FORWARD:g}, got "
            f"{fwd:.4g}"
        )
    r0, r1 = _check_radial_range(radial_range)
    for name, val, hi in (
        ("min_contrast", min_contrast, math.inf),
        ("min_agreement", min_agreement, 1.0),
        ("max_pole_width", max_pole_width, math.inf),
        ("min_separation", min_separation, math.inf),
        ("smoothing", smoothing, MAX_SMOOTHING),
        ("min_segment_width", min_segment_width, math.inf),
    ):
        if not 0 <= _finite_float(name, val) <= hi:
            raise VisionError(f"{name} must be in [0, {hi:g}], got {shorten(val)}")
    min_agreement, smoothing = float(min_agreement), float(smoothing)
    cal = _resolve_calibration(gray, center, aspect, calibration)
    rows, cols = _panorama_size(cal, (r0, r1))
    maps = _panorama_maps(cal, r0, r1, rows, cols)
    pano = _remap(gray, maps)
    if not np.isfinite(pano).any():
        h, w = gray.shape
        raise VisionError(
            f"the mirror annulus ({r0:g}-{r1:g} of the rim: centre ({cal.center[0]:.1f}, "
            f"{cal.center[1]:.1f}) px, radius {cal.radius:.3g} px, aspect {cal.aspect:.3g}) lies "
            f"wholly outside the {w} x {h} image: no pixel to read bearings from (a "
            "calibration of another camera or image size?)"
        )
    channels = [pano]  # grey, then R, G, B for a colour image: compared beside stripes
    blacks = [float(gray.min())]
    if rgb is not None:
        channels += _remap_colour(rgb, maps, scale, np.isnan(pano))
        blacks += [float(v) * scale for v in rgb.min(axis=(0, 1))]
    # The sides' tolerance grows with their level above black (_sides_differ): an image with
    # negative values (a zero-centred float image) is measured from its minimum, not from 0.
    channels = [c - np.float32(b) if b < 0 else c for c, b in zip(channels, blacks, strict=True)]
    valid_rows = np.isfinite(pano).all(axis=1)
    if not valid_rows.any():
        # Rim partly outside the image: keep rows, ignoring the missing samples.
        deriv = _azimuth_derivative(np.nan_to_num(pano, nan=0.0), smoothing)
        deriv[~np.isfinite(pano)] = np.nan
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # columns wholly outside
            d_med = np.nan_to_num(np.nanmedian(deriv, axis=0))
            signs = np.sign(deriv) == np.sign(d_med)[None, :]
            agree = np.nanmean(np.where(np.isfinite(deriv), signs, np.nan), axis=0)
        agree = np.nan_to_num(agree)
    else:
        channels = [c[valid_rows] for c in channels]
        deriv = _azimuth_derivative(pano[valid_rows], smoothing)
        d_med = np.median(deriv, axis=0)
        agree = np.mean(np.sign(deriv) == np.sign(d_med)[None, :], axis=0)
    col = 2 * np.pi / cols
    pos, height = _find_steps(
        d_med.astype(np.float64),
        agree.astype(np.float64),
        float(min_contrast),
        float(min_agreement),
        float(min_separation) / col,
    )
    groups, ambiguous_step = _group_steps(
        pos,
        height,
        cols,
        np.stack(channels),
        float(max_pole_width) / col,
        float(min_segment_width) / col,
        off=math.ceil(2 + 2 * float(smoothing)),
    )
    phis: list[float] = []
    strengths: list[float] = []
    kinds: list[str] = []
    flags: list[bool] = []
    for group in groups:
        if len(group) == 2:
            i, j = group
            mid = pos[i] + ((pos[j] - pos[i]) % cols) / 2
            phis.append(mid * col)
            strengths.append(0.5 * (abs(height[i]) + abs(height[j])))
            kinds.append("pole")
            flags.append(False)
        else:
            phis.append(pos[group[0]] * col)
            strengths.append(abs(height[group[0]]))
            kinds.append("edge")
            flags.append(bool(ambiguous_step[group[0]]))
    phi_arr = np.asarray(wrap(np.asarray(phis, dtype=np.float64)), dtype=np.float64).reshape(-1)
    s = -1.0 if mirrored else 1.0
    bearings = np.asarray(wrap(s * (phi_arr - fwd)), dtype=np.float64).reshape(-1)
    order = np.argsort(bearings, kind="stable")
    return EdgeDetections(
        bearings=bearings[order],
        strength=np.asarray(strengths, dtype=np.float64)[order],
        kind=np.asarray(kinds, dtype="<U4")[order],
        image_angles=phi_arr[order],
        calibration=cal,
        forward=fwd,
        mirrored=bool(mirrored),
        ambiguous=np.asarray(flags, dtype=bool)[order],
    )


def bearings_from_image(
    image: str | os.PathLike[str] | NDArray[np.generic], **kwargs: object
) -> EdgeDetections:
    """Load an image (if given a path) and extract its bearings.

    Parameters
    ----------
    image : str, path-like or ndarray
        An image file or an image array.
    **kwargs
        Passed to :func:`extract_bearings`.

    Returns
    -------
    EdgeDetections

    Raises
    ------
    VisionError
        As :func:`load_image` and :func:`extract_bearings`.
    """
    arr = load_image(image) if isinstance(image, (str, os.PathLike)) else image
    return extract_bearings(arr, **kwargs)  # type: ignore[arg-type]
