"""Angle helpers: wrapping, differences and degree/radian conversion at the edges.

Inside omniloc every angle is in radians. Bearings and headings are wrapped to [-pi, pi).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["TWO_PI", "angdiff", "deg2rad", "rad2deg", "wrap"]

TWO_PI = 2.0 * np.pi


def wrap(angle: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap angles to the half-open interval [-pi, pi).

    Parameters
    ----------
    angle : float or array_like
        Angles in radians, any shape.

    Returns
    -------
    float or ndarray
        The same angles, wrapped; a float for scalar input.

    Examples
    --------
    >>> float(wrap(3 * np.pi / 2))
    -1.5707963267948966
    >>> float(wrap(np.pi))
    -3.141592653589793
    """
    # Where 0 <= s = angle + pi < 2 pi (nearly always), the mod below returns s exactly and
    # s - pi is below pi: the same angle is s - pi, without the mod (numpy's, or Python's
    # float %, the same fmod), bit for bit.
    if isinstance(angle, float):
        s = angle + math.pi
        if 0.0 <= s < TWO_PI:
            return float(s - math.pi)
    a = np.asarray(angle, dtype=np.float64)
    s = a + np.pi
    if a.ndim and ((s >= 0.0) & (s < TWO_PI)).all():
        return s - np.pi
    out = np.mod(s, TWO_PI) - np.pi
    # np.mod can return exactly 2*pi for tiny negative inputs through rounding.
    out = np.where(out >= np.pi, out - TWO_PI, out)
    if out.ndim == 0:
        return float(out)
    return out


def angdiff(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64] | float:
    """Signed smallest difference ``a - b`` of two angles, wrapped to [-pi, pi).

    Examples
    --------
    >>> round(float(angdiff(np.deg2rad(179), np.deg2rad(-179))), 6)
    -0.034907
    """
    return wrap(np.subtract(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)))


def deg2rad(deg: ArrayLike) -> NDArray[np.float64] | float:
    """Degrees to radians (for the edges of the program: CLI and files)."""
    out = np.deg2rad(np.asarray(deg, dtype=np.float64))
    return float(out) if out.ndim == 0 else out


def rad2deg(rad: ArrayLike) -> NDArray[np.float64] | float:
    """Radians to degrees (for the edges of the program: CLI and files)."""
    out = np.rad2deg(np.asarray(rad, dtype=np.float64))
    return float(out) if out.ndim == 0 else out
