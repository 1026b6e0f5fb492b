"""Shared fixtures: a seeded generator and the shared real-data folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(f"the shared real-data folder is not at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture(scope="session")
def compiled_kernels() -> None:
    """The compiled kernels loaded -- compiled, in a fresh clone's first run -- before the
    tests that time their calls (the fuzz suites judge a call over 10 s a hang). With ``make
    test``'s two processes a worker may reach such a test first and count the compilation
    (10-30 s on this machine) against it; one process reached them after tests that had
    compiled everything."""
    import omniloc
    from omniloc.track.simulate import example_run

    room = omniloc.demo_room()
    pose = omniloc.Pose(4.0, 3.0, 0.5)
    bearings = omniloc.predict_bearings(room.xy, pose)
    for method in omniloc.Method:
        omniloc.localize(room, bearings, method=method)
    omniloc.localize(room, bearings[:-1], max_spurious=1)
    ex = example_run(duration_s=20.0)
    omniloc.track(
        ex.landmarks,
        ex.run.odometry,
        ex.run.frames,
        sensor=ex.sensor,
        motion=ex.motion,
        backward_s=5.0,
    )
