"""Tests of the real-dataset loaders (Roh IR beacons, UTIAS MRCLAM set 6)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from omniloc.datasets import DatasetSample, load_mrclam, load_roh
from omniloc.errors import InputError
from omniloc.pose import predict_bearings, refine_pose
from omniloc.search import localize

DATA = Path("/work/shared/data")
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="shared datasets not present")


def _found(sample: DatasetSample, sols: list, pos: float, hdg_deg: float) -> bool:
    return any(
        d[0] <= pos and d[1] <= np.deg2rad(hdg_deg)
        for d in (s.pose.distance_to(sample.pose) for s in sols)
    )


def test_roh_loads_and_columns_are_true_bearings() -> None:
    ds = load_roh(DATA / "roh")
    assert len(ds) == 1800
    assert ds.landmarks.n == 4
    assert ds.poses.shape == (1800, 3) and ds.bearings.shape == (1800, 4)
    # Column k is landmark k: the error against the prediction is a few degrees at most.
    pred = predict_bearings(ds.landmarks.xy, ds.poses[0])
    err = np.angle(np.exp(1j * (ds.bearings[0] - pred)))
    assert np.abs(np.rad2deg(err)).max() < 10.0


def test_roh_samples_hide_the_correspondences() -> None:
    ds = load_roh(DATA / "roh")
    samples = list(ds.samples(0, max_samples=20))
    assert len(samples) == 20
    assert any(s.assignment != (0, 1, 2, 3) for s in samples)
    for k, s in enumerate(samples):
        assert sorted(s.assignment) == [0, 1, 2, 3]
        np.testing.assert_allclose(s.bearings, ds.bearings[k][list(s.assignment)])
        assert s.source.startswith("measurements.csv:")
    again = [s.assignment for s in ds.samples(0, max_samples=20)]
    assert again == [s.assignment for s in samples]


def test_roh_true_pose_among_solutions() -> None:
    ds = load_roh(DATA / "roh")
    hits = amb = 0
    for s in ds.samples(1, max_samples=20):
        res = localize(ds.landmarks, s.bearings, sigma=np.deg2rad(2.0))
        hits += _found(s, res.solutions, 0.3, 10.0)
        amb += res.ambiguous
    assert hits >= 18
    assert amb >= 18


def test_mrclam_loads_frames_with_robots_as_spurious() -> None:
    ds = load_mrclam(DATA / "mrclam-ds6")
    assert ds.landmarks.n == 15
    assert len(ds) == 727  # the README: 727 frames with >= 4 distinct landmarks
    f = ds.frames[0]
    lm = [a for a in f.assignment if a is not None]
    assert len(lm) >= 4 and len(set(lm)) == len(lm)
    assert sum(s.n_spurious for s in ds.frames) > 0
    # Landmark entries come first, robots after, before shuffling.
    assert all(
        a is None for s in ds.frames for a in s.assignment[len(s.assignment) - s.n_spurious :]
    )
    bare = load_mrclam(DATA / "mrclam-ds6", robots=(1,), include_robots=False, min_landmarks=3)
    assert all(s.n_spurious == 0 for s in bare.frames)
    assert all(s.source.startswith("robot1_frames.csv:") for s in bare.frames)


def test_mrclam_bearings_match_ground_truth() -> None:
    ds = load_mrclam(DATA / "mrclam-ds6", robots=(3,))
    errs = []
    for s in ds.frames[:50]:
        idx = [a for a in s.assignment if a is not None]
        pred = predict_bearings(ds.landmarks.xy[idx], s.pose)
        errs += list(np.angle(np.exp(1j * (s.bearings[: len(idx)] - pred))))
    assert np.median(np.abs(np.rad2deg(errs))) < 1.0


def test_mrclam_true_pose_among_solutions_in_most_frames() -> None:
    ds = load_mrclam(DATA / "mrclam-ds6", include_robots=False)
    hits = 0
    samples = list(ds.samples(0, max_samples=20))
    for s in samples:
        res = localize(
            ds.landmarks,
            s.bearings,
            sigma=np.deg2rad(1.0),
            fov=np.deg2rad(67.0),
            max_range=8.0,
            timeout_s=5.0,
        )
        # Judge the search against the ML pose from the TRUE correspondences: the clustered
        # tubes leave that pose 0.3 m or more from Vicon in about a third of the frames.
        idx = [a for a in s.assignment if a is not None]
        oracle, _ = refine_pose(ds.landmarks.xy[idx], s.bearings)
        hits += _found(replace(s, pose=oracle), res.solutions, 0.3, 5.0)
    assert hits >= 10


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_roh_malformed_row_names_file_and_line(tmp_path: Path) -> None:
    _write(tmp_path / "landmarks.csv", "id,x,y\n1,0,0\n2,6,0\n3,6,6\n4,0,6\n")
    _write(
        tmp_path / "measurements.csv",
        "gt_x,gt_y,gt_theta,sample,bearing_lm1,bearing_lm2,bearing_lm3,bearing_lm4\n"
        "1.5,1.5,0,0,0.1,0.2,0.3,0.4\n"
        "1.5,1.5,0,1,0.1,oops,0.3,0.4\n",
    )
    with pytest.raises(InputError, match=r"measurements\.csv:3.*bearing_lm2"):
        load_roh(tmp_path)
    _write(tmp_path / "measurements.csv", "gt_x,gt_y,sample\n1,2,3\n")
    with pytest.raises(InputError, match=r"measurements\.csv:1: missing column"):
        load_roh(tmp_path)


def test_mrclam_malformed_rows_name_file_and_line(tmp_path: Path) -> None:
    _write(tmp_path / "landmarks.csv", "id,x,y\n6,0,0\n7,1,0\n8,0,1\n9,1,1\n")
    head = "frame_id,t,gt_x,gt_y,gt_theta,landmarks,robot_detections\n"
    ok = "0,0.0,0.5,0.5,0.0,6:0.1:1.0;7:0.2:1.0;8:0.3:1.0;9:0.4:1.0,2:0.05:2.0\n"
    f = _write(tmp_path / "robot1_frames.csv", head + ok + "1,0.1,0.5,0.5,0.0,6:0.1;7:0.2:1,\n")
    with pytest.raises(InputError, match=r"robot1_frames\.csv:3.*id:bearing:range"):
        load_mrclam(tmp_path, robots=(1,))
    _write(f, head + ok + ok + "2,0.2,0.5,0.5,0.0,6:0.1:1;42:0.2:1,\n")
    with pytest.raises(InputError, match=r"robot1_frames\.csv:4.*'42'"):
        load_mrclam(f)
    _write(f, head + "0,0.0,nan?,0.5,0.0,6:0.1:1,\n")
    with pytest.raises(InputError, match=r"robot1_frames\.csv:2.*gt_x"):
        load_mrclam(tmp_path, robots=(1,))
    _write(f, head + ok)
    ds = load_mrclam(f)
    assert len(ds) == 1 and ds.frames[0].n_spurious == 1
    assert ds.frames[0].assignment == (0, 1, 2, 3, None)
    with pytest.raises(InputError, match=r"robot2_frames\.csv: no such file"):
        load_mrclam(tmp_path, robots=(2,))


@pytest.mark.parametrize("loader", [load_roh, load_mrclam])
def test_a_missing_dataset_path_is_named(tmp_path: Path, loader: Callable[[Path], object]) -> None:
    gone = tmp_path / "no-such-dataset"
    with pytest.raises(InputError, match=r"no-such-dataset: no such folder or file"):
        loader(gone)
