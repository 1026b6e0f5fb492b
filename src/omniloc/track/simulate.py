"""Simulated recordings: a robot driving about a map, its odometry, its frames of bearings.

:func:`simulate_run` drives a robot at constant speed with a turn rate that changes every
few seconds (and steers back towards the map when it leaves it), records noisy velocity
odometry at ``odometry_hz`` and, at ``frame_hz``, the bearings of the landmarks it sees
(range and field of view of a :class:`~omniloc.sensor.SensorModel`, each detected with
``p_detect``, Gaussian noise ``sigma``) plus Poisson clutter spread over the field of view.
A kidnapping carries the robot to another pose at a given time while its odometry goes on
as if nothing happened.

:func:`example_run` is the recording of ``omniloc demo`` and of ``examples/grid-run`` (the
scenario ``grid-360`` of ``benchmarks/track_sim.py``): a map that one frame cannot tell
apart from its half turn, a robot that wakes up there, is kidnapped half way and recovers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from .._kernels.track import occlusion_factors
from ..angles import wrap
from ..errors import InputError
from ..maps import LandmarkMap, as_landmark_map
from ..pose import Pose
from ..sensor import SensorModel
from ..simulate import symmetric_map
from .data import Frame, GroundTruth, Odometry
from .motion import MotionModel

__all__ = ["Example", "SimulatedRun", "example_run", "lookalike_run", "simulate_run"]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None


@dataclass(frozen=True)
class SimulatedRun:
    """A simulated recording.

    Attributes
    ----------
    odometry : Odometry
        Noisy velocity odometry.
    frames : list of Frame
        Bearings, with the true landmark row of each in :attr:`Frame.truth`.
    truth : GroundTruth
        The true trajectory, sampled at the odometry's rate.
    kidnap_t : float
        Time of the kidnapping (NaN without one).
    """

    odometry: Odometry
    frames: list[Frame] = field(repr=False)
    truth: GroundTruth = field(repr=False)
    kidnap_t: float = math.nan


def simulate_run(
    landmarks: LandmarkMap | NDArray[np.float64],
    sensor: SensorModel,
    start: Pose,
    *,
    duration_s: float = 60.0,
    speed: float = 0.3,
    turn_rate: float = 0.3,
    turn_every_s: float = 4.0,
    odometry_hz: float = 50.0,
    frame_hz: float = 4.0,
    v_noise: float = 0.02,
    w_noise: float = 0.02,
    kidnap: tuple[float, Pose] | None = None,
    occlusion_width: float = 0.0,
    rng: RngLike = None,
) -> SimulatedRun:
    """Simulate a robot's run.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
    sensor : SensorModel
        What the robot sees (``sigma`` or ``threshold / 3`` as noise; ``p_detect`` default 1;
        ``clutter`` default 0 per frame), from where it sits on the robot (``mount``; the
        odometry and the ground truth are the robot's).
    start : Pose
        Where the robot starts.
    duration_s : float
        Length of the run, seconds.
    speed : float
        Forward speed, m/s.
    turn_rate : float
        Largest turn rate, rad/s: a new one is drawn uniformly in [-turn_rate, turn_rate]
        every ``turn_every_s``; outside the map's bounding box (1 m margin) the robot turns
        back towards its centre.
    odometry_hz, frame_hz : float
        Rates of the odometry rows and of the frames.
    v_noise, w_noise : float
        Standard deviations of the odometry's velocity (relative, per row) and turn rate
        (rad/s, per row) errors.
    kidnap : (float, Pose), optional
        At this time the robot is carried to this pose (the odometry does not see it).
    occlusion_width : float
        Metres: a landmark in view is reported with probability ``p_detect`` times ``1 -
        exp(-l^2 / (2 w^2))`` for each nearer landmark in view, ``l`` being how far its
        line of sight passes beside that one -- the tracker's model of landmarks that hide
        each other (:attr:`~omniloc.track.TrackerConfig.occlusion_width`). 0 (default):
        none hides another (and the same draws, bit for bit, as without it).
    rng : Generator, int or None

    Returns
    -------
    SimulatedRun
    """
    lm = as_landmark_map(landmarks)
    gen = np.random.default_rng(rng)
    for name, val in (
        ("duration_s", duration_s),
        ("odometry_hz", odometry_hz),
        ("frame_hz", frame_hz),
        ("turn_every_s", turn_every_s),
    ):
        if not (math.isfinite(val) and val > 0):
            raise InputError(f"{name} must be a positive number, got {val!r}")
    for name, val in (
        ("speed", speed),
        ("v_noise", v_noise),
        ("w_noise", w_noise),
        ("occlusion_width", occlusion_width),
    ):
        if not (math.isfinite(val) and val >= 0):
            raise InputError(f"{name} must be finite and >= 0, got {val!r}")
    dt = 1.0 / odometry_hz
    n = round(duration_s * odometry_hz) + 1
    t = np.arange(n, dtype=np.float64) * dt
    x0, y0, x1, y1 = lm.bounds
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    poses = np.empty((n, 3))
    v_cmd = np.full(n, float(speed))
    w_cmd = np.empty(n)
    p = start.as_array()
    w = 0.0
    next_turn = 0.0
    k_jump = n if kidnap is None else int(np.searchsorted(t, kidnap[0]))
    for k in range(n):
        if k == k_jump and kidnap is not None:
            p = kidnap[1].as_array()
        poses[k] = p
        if t[k] >= next_turn:
            w = float(gen.uniform(-turn_rate, turn_rate))
            next_turn = t[k] + turn_every_s
        outside = not (x0 - 1 <= p[0] <= x1 + 1 and y0 - 1 <= p[1] <= y1 + 1)
        if outside:
            want = math.atan2(cy - p[1], cx - p[0])
            err = (want - p[2] + math.pi) % (2 * math.pi) - math.pi
            w = float(np.clip(2.0 * err, -max(turn_rate, 0.5), max(turn_rate, 0.5)))
        w_cmd[k] = w
        phi = w * dt
        if abs(phi) < 1e-12:
            dx, dy = speed * dt, 0.0
        else:
            dx = speed / w * math.sin(phi)
            dy = speed / w * (1 - math.cos(phi))
        c, s = math.cos(p[2]), math.sin(p[2])
        p = np.array([p[0] + c * dx - s * dy, p[1] + s * dx + c * dy, p[2] + phi])
    odo = Odometry(
        t,
        v_cmd * (1.0 + v_noise * gen.standard_normal(n)),
        w_cmd + w_noise * gen.standard_normal(n),
    )
    truth = GroundTruth(t, poses[:, 0], poses[:, 1], np.asarray(wrap(poses[:, 2])))
    p_det = 1.0 if sensor.p_detect is None else sensor.p_detect
    clutter = 0.0 if sensor.clutter is None else sensor.clutter
    half = sensor.half_fov if sensor.half_fov is not None else math.pi
    frames = []
    t_frames = np.arange(0.5 / frame_hz, t[-1], 1.0 / frame_hz)
    for tf in t_frames:
        # (The bearings are the sensor's: from where it sits on the robot, ``sensor.mount``.)
        pose = Pose.from_array(sensor.sensor_poses(truth.pose_at(float(tf))))
        vis = np.flatnonzero(sensor.visible(lm.xy, pose))
        d = lm.xy[vis] - pose.xy
        b = np.arctan2(d[:, 1], d[:, 0]) - pose.theta
        if occlusion_width > 0:
            keep = gen.random(vis.size) < p_det * occlusion_factors(d, b, occlusion_width)
        else:
            keep = gen.random(vis.size) < p_det
        vis, d, b = vis[keep], d[keep], b[keep] + sensor.noise * gen.standard_normal(keep.sum())
        spur = gen.uniform(-half, half, size=gen.poisson(clutter))
        bearings = np.concatenate([b, spur])
        who: list[int | None] = [int(i) for i in vis] + [None] * spur.size
        order = gen.permutation(bearings.size)
        frames.append(Frame(float(tf), bearings[order], tuple(who[i] for i in order)))
    return SimulatedRun(odo, frames, truth, math.nan if kidnap is None else float(kidnap[0]))


#: The example's map: a 4 x 3 grid of landmarks 4 m apart (the same under a half turn) and
#: one landmark beside it, seen only from the grid's east side, that breaks the symmetry.
EXAMPLE_MAP = LandmarkMap(np.vstack([symmetric_map("grid", size=12.0).xy, [[14.0, 2.0]]]))
#: The example's sensor: an omnidirectional camera, 5 m range, 0.5 deg noise, 90 % of the
#: landmarks in range reported, 0.3 spurious bearings a frame.
EXAMPLE_SENSOR = SensorModel(sigma=math.radians(0.5), max_range=5.0, p_detect=0.9, clutter=0.3)
#: The example's odometry noise, as the tracker is told it.
EXAMPLE_MOTION = MotionModel(
    along_per_m=0.002, across_per_m=2e-4, turn_per_rad=0.004, turn_per_m=0.002, turn_per_s=1e-6
)


@dataclass(frozen=True)
class Example:
    """A simulated recording with the models to track it with.

    Attributes
    ----------
    landmarks : LandmarkMap
    sensor : SensorModel
        What the frames were simulated with (and what the tracker should be told).
    motion : MotionModel
        The odometry's noise for the tracker.
    run : SimulatedRun
    """

    landmarks: LandmarkMap
    sensor: SensorModel
    motion: MotionModel
    run: SimulatedRun = field(repr=False)


def example_run(seed: int = 9, duration_s: float = 60.0) -> Example:
    """The example recording: on :data:`EXAMPLE_MAP`, a start drawn from ``seed`` (uniform
    over the grid's box, any heading), 0.25 m/s, a new turn rate every 4 s, odometry at
    50 Hz and frames at 4 Hz, and half way a kidnapping to a pose at least 3 m away.

    With the default seed the tracker (default configuration) is ambiguous at wake-up (the
    grid's half turn), localized after 3 s, flags the kidnapping 0.4 s after it and is
    localized and right again 5.4 s after it (``omniloc demo`` prints the time line).

    Parameters
    ----------
    seed : int
    duration_s : float
        Length of the run, seconds (the kidnapping at half of it).

    Returns
    -------
    Example
    """
    gen = np.random.default_rng(seed)
    x0, y0, x1, y1 = EXAMPLE_MAP.bounds
    start = Pose(gen.uniform(x0, x1), gen.uniform(y0, y1), gen.uniform(-math.pi, math.pi))
    while True:
        to = Pose(gen.uniform(x0, x1), gen.uniform(y0, y1), gen.uniform(-math.pi, math.pi))
        if math.hypot(to.x - start.x, to.y - start.y) >= 3.0:
            break
    run = simulate_run(
        EXAMPLE_MAP,
        EXAMPLE_SENSOR,
        start,
        duration_s=duration_s,
        speed=0.25,
        turn_rate=0.3,
        v_noise=0.02,
        w_noise=0.01,
        kidnap=(0.5 * duration_s, to),
        rng=seed,
    )
    return Example(EXAMPLE_MAP, EXAMPLE_SENSOR, EXAMPLE_MOTION, run)


def lookalike_run(seed: int) -> Example:
    """Run ``seed`` of the battery of maps with look-alike places
    (``benchmarks/track_lookalikes.py``), one of three scenes by ``seed % 3``: 0, 14 landmarks
    uniform on 12 m x 12 m and :data:`EXAMPLE_SENSOR`; 1, :data:`EXAMPLE_MAP` and that
    sensor; 2, 20 landmarks uniform on 12 m x 12 m and a 180-degree camera 0.2 m ahead of
    the robot. 60 s from a random pose at 0.25 m/s (a new turn rate every 4 s); an odd
    ``seed`` is carried to a random pose at 30 s.

    Parameters
    ----------
    seed : int

    Returns
    -------
    Example
    """
    gen = np.random.default_rng(1000 + seed)
    kind = seed % 3
    sensor = EXAMPLE_SENSOR
    if kind == 0:
        lm = LandmarkMap(gen.uniform(0, 12, size=(14, 2)))
    elif kind == 1:
        lm = EXAMPLE_MAP
    else:
        lm = LandmarkMap(gen.uniform(0, 12, size=(20, 2)))
        sensor = replace(EXAMPLE_SENSOR, fov=math.radians(180), mount=(0.2, 0.0, 0.0))
    x0, y0, x1, y1 = lm.bounds
    start = Pose(gen.uniform(x0, x1), gen.uniform(y0, y1), gen.uniform(-math.pi, math.pi))
    kidnap = None
    if seed % 2:
        to = Pose(gen.uniform(x0, x1), gen.uniform(y0, y1), gen.uniform(-math.pi, math.pi))
        kidnap = (30.0, to)
    run = simulate_run(
        lm,
        sensor,
        start,
        duration_s=60.0,
        speed=0.25,
        turn_rate=0.3,
        v_noise=0.02,
        w_noise=0.01,
        kidnap=kidnap,
        rng=seed,
    )
    return Example(lm, sensor, EXAMPLE_MOTION, run)
