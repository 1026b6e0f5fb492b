"""Recordings simulated for the tests of the motion model and of the benchmarks that read
odometry against a true track."""

from __future__ import annotations

import numpy as np

from omniloc.track import GroundTruth, MotionModel, Odometry
from omniloc.track.motion import compose, integrate


def lagging_recording(delay_var: float, seed: int = 5) -> tuple[Odometry, GroundTruth]:
    """900 s of odometry rows at 10 Hz whose velocities change every second, and the true
    track of a robot that answers each change 0.2 s after its row plus a response error of
    variance ``delay_var`` (the boundary between the two twists moved, not a noise drawn
    from the model), its heading drifting by 1e-5 rad^2/s."""
    rng = np.random.default_rng(seed)
    dt, seconds, hold = 0.1, 900.0, 10
    n = int(seconds / dt)
    t = np.arange(n) * dt
    v = np.repeat(rng.uniform(0.05, 0.4, n // hold + 1), hold)[:n]
    w = np.repeat(rng.choice([-0.5, -0.25, 0.0, 0.25, 0.5], n // hold + 1), hold)[:n]
    # The true twist switches at each change's time plus its error (clipped to 0.2 s).
    change = np.flatnonzero(np.diff(v) != 0) + 1
    starts = t.copy()
    starts[change] += np.clip(rng.normal(0.0, np.sqrt(delay_var), change.size), -0.2, 0.2)
    grid = np.arange(n + 1) * dt
    cuts = np.unique(np.concatenate([grid, starts]))
    which = np.searchsorted(starts, cuts[:-1], side="right") - 1
    poses = np.zeros((n + 1, 3))
    pose = np.zeros(3)
    k = 0
    for a, b, j in zip(cuts[:-1], cuts[1:], which, strict=True):
        d, _ = integrate([b - a], [v[j]], [w[j]], MotionModel())
        drift = rng.normal(0.0, np.sqrt(1e-5 * (b - a)))
        pose = compose(pose, d + np.array([0.0, 0.0, drift]))
        if np.isclose(b, grid[k + 1]):
            k += 1
            poses[k] = pose
    truth_t = grid + 0.2
    return Odometry(t, v, w), GroundTruth(truth_t, poses[:, 0], poses[:, 1], poses[:, 2])
