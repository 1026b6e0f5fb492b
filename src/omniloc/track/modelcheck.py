"""Whether a place's recent frames fit the sensor model: :func:`misfit`
(``TrackerConfig.model_check``).

The tracker's weights compare the places it holds. When the true place is in none of them --
a search missed it, or a look-alike was found first after a kidnapping -- the best of them
can hold all the mass and be called ``localized`` with probability 1.0000. Such a place
gives itself away by what the sensor model says a true place would show: it predicts
landmarks plainly in view that the camera does not report, frame after frame, or it leaves
bearings unexplained far beyond the clutter rate. :func:`misfit` tests both counts over the
frames since the place was found, from the place carried back along the odometry:

* the landmarks plainly in view (a gate's width inside the view's edges, ``RANGE_MARGIN``
  inside the range's), each matched to its own bearing within the gate (a maximum bipartite
  matching: two landmarks in one direction, both seen, give two bearings), against a
  binomial at the sensor's ``p_detect``;
* the bearings that no landmark in view explains, against a Poisson of the sensor's clutter
  rate.

A place is right within the tolerances, not to the gate's width (a tracked pose 2 deg off
in heading is right, and would put every bearing outside a 1.7-deg gate): when the counts
at the place fail, the place is fitted to the window's bearings (each to the nearest
landmark in view within the gate widened by the tolerances; Gauss-Newton on every frame's
own pose, :func:`~omniloc.track.relocalize.refine_on_frames`) and counted again from the
fit, if the fit stays within the tolerances of the place.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching
from scipy.special import bdtr, pdtrc

from ..angles import wrap
from ..maps import LandmarkMap
from ..sensor import SensorModel
from .motion import between, compose
from .relocalize import refine_on_frames
from .window import WindowFrame

__all__ = ["RANGE_MARGIN", "misfit"]

FloatArray = NDArray[np.float64]

#: A landmark counts as plainly in view only this share inside the range's limits (one at
#: the range's edge may be seen or not, whatever the model says).
RANGE_MARGIN = 0.05


def misfit(
    landmarks: LandmarkMap,
    sensor: SensorModel,
    mu: FloatArray,
    P: FloatArray,
    frames: list[WindowFrame],
    *,
    level: float,
    tolerance_m: float,
    tolerance_heading: float,
) -> str | None:
    """Whether ``frames`` (the newest last) fit the sensor model from the place ``mu`` (a
    sensor pose at the newest frame, covariance ``P``): None if they do, else why not.

    Each count is tested at ``level`` (a p-value) and only against a rate the sensor states
    (``sensor.p_detect``, ``sensor.clutter`` bearings a frame: the frame model's defaults
    for an unstated one are a guess, not a model to hold a place to). A stated rate of 0 or
    1 is taken a hair inside it, as the frame model takes it: a sensor said never to miss
    a landmark in view, or never to report clutter, has a place held by one such frame.
    """
    if not frames or (sensor.p_detect is None and sensor.clutter is None):
        return None
    rel = between(frames[-1].odom, np.array([f.odom for f in frames]))
    reach = tolerance_m + float(np.max(np.hypot(rel[:, 0], rel[:, 1])))
    if sensor.max_range is None:
        idx = np.arange(landmarks.n)
    else:
        near = landmarks.kdtree.query_ball_point(mu[:2], sensor.max_range + reach)
        idx = np.sort(np.asarray(near, dtype=np.int64))
    L = np.asarray(landmarks.xy, dtype=float)[idx]
    fidx = np.repeat(np.arange(len(frames)), [f.bearings.size for f in frames])
    z = np.concatenate([f.bearings for f in frames])
    # Each frame's bearing variance from the place: the sensor's, the place's heading and
    # the odometry's noise between the frame and now (its heading, and its position seen
    # from the landmark's range).
    Qs = np.array([f.Q for f in frames])
    after = np.cumsum(Qs[::-1], axis=0)[::-1] - Qs  # (the motion after each frame)
    var0 = sensor.noise**2 + max(float(P[2, 2]), 0.0) + after[:, 2, 2][:, None]
    var_xy = (after[:, 0, 0] + after[:, 1, 1])[:, None]
    p_detect = min(max(sensor.p_detect, 1e-9), 1.0 - 1e-9) if sensor.p_detect is not None else 0.0
    rate = max(sensor.clutter, 1e-12) if sensor.clutter is not None else 0.0

    def geometry(m: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
        """From the place ``m``: the landmarks' ranges, predicted bearings and bearing
        variances at each frame (F, N), and which are in view."""
        poses = compose(m, rel)
        d = L[None, :, :] - poses[:, None, :2]
        rng = np.maximum(np.hypot(d[..., 0], d[..., 1]), 1e-9)
        pred = np.asarray(wrap(np.arctan2(d[..., 1], d[..., 0]) - poses[:, None, 2]))
        view = np.asarray(sensor.visible(np.broadcast_to(L, (len(frames), *L.shape)), poses))
        return rng, pred, var0 + var_xy / rng**2, view

    def verdict(
        rng: FloatArray, pred: FloatArray, var: FloatArray, view: NDArray[np.bool_]
    ) -> str | None:
        gate = np.sqrt(sensor.gate_chi2 * var)
        plain = np.ones(pred.shape, dtype=bool)
        if sensor.max_range is not None:
            plain &= rng <= sensor.max_range * (1.0 - RANGE_MARGIN)
        if sensor.min_range is not None:
            plain &= rng >= sensor.min_range * (1.0 + RANGE_MARGIN)
        if sensor.fov is not None:
            plain &= np.abs(pred) <= 0.5 * sensor.fov - gate
        expected = int(plain.sum())
        newest = len(frames) == 1
        over = "in the newest frame" if newest else f"over the last {len(frames)} frames"
        of = "of the newest frame" if newest else f"of the last {len(frames)} frames"
        seen, unexplained = 0, int(z.size)  # (no landmark in reach: every bearing unexplained)
        if z.size and idx.size:
            near = np.abs(np.asarray(wrap(z[:, None] - pred[fidx]))) <= gate[fidx]
            unexplained = int(np.count_nonzero(~(near & view[fidx]).any(axis=1)))
            hit = near & plain[fidx]
            # Where no bearing is near two such landmarks and no landmark near two bearings
            # of its frame, each near pair is a sighting; elsewhere the matching decides.
            per_landmark = np.zeros(pred.shape, dtype=np.int64)
            np.add.at(per_landmark, fidx, hit)
            tangled = np.zeros(len(frames), dtype=bool)
            tangled[fidx[hit.sum(axis=1) > 1]] = True
            tangled |= (per_landmark > 1).any(axis=1)
            seen = int(hit[~tangled[fidx]].sum())
            for k in np.flatnonzero(tangled):
                match = maximum_bipartite_matching(csr_matrix(hit[fidx == k]), perm_type="column")
                seen += int(np.count_nonzero(match >= 0))
        if sensor.p_detect is not None and expected:
            p_low = float(bdtr(seen, expected, p_detect))
            if p_low < level:
                return (
                    f"the best place does not fit the sensor: of the {expected} "
                    f"sighting{'s' if expected != 1 else ''} of "
                    f"landmarks plainly in view it predicts {over}, {seen} "
                    f"{'was' if seen == 1 else 'were'} seen (p = {p_low:.2g} at p_detect "
                    f"{p_detect:.2g})"
                )
        clutter = rate * len(frames)
        if sensor.clutter is not None and unexplained:
            p_high = float(pdtrc(unexplained - 1, clutter))
            if p_high < level:
                return (
                    f"the best place does not fit the sensor: it leaves {unexplained} of the "
                    f"{z.size} bearings {of} unexplained, "
                    f"{clutter:.2g} expected as clutter (p = {p_high:.2g})"
                )
        return None

    rng, pred, var, view = geometry(mu)
    why = verdict(rng, pred, var, view)
    if why is None or z.size < 3 or idx.size == 0:
        return why
    # Fitted within the tolerances, the place may fit after all.
    wide = np.sqrt(sensor.gate_chi2 * var[fidx]) + (
        tolerance_heading + np.arctan2(tolerance_m, rng[fidx])
    )
    diff = np.abs(np.asarray(wrap(z[:, None] - pred[fidx])))
    diff[~view[fidx]] = np.inf
    j = np.argmin(diff, axis=1)
    pick = diff[np.arange(z.size), j] <= wide[np.arange(z.size), j]
    if int(pick.sum()) < 3:
        return why
    assign = np.where(pick, idx[j], -1)[None, :]
    fit, _ = refine_on_frames(
        landmarks.xy, frames, np.arange(z.size), assign, mu[None], sensor.noise
    )
    gap = fit[0] - mu
    if not (
        np.isfinite(fit).all()
        and math.hypot(gap[0], gap[1]) <= tolerance_m
        and abs(float(wrap(gap[2]))) <= tolerance_heading
    ):
        return why
    return verdict(*geometry(fit[0]))
