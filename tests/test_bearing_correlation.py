"""benchmarks/bearing_correlation.py: how the bearing errors of one tube repeat over time."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from bearing_correlation import (
    drifting_bias_fit,
    geometry,
    lag_correlations,
    sightings,
    systematic,
)
from omniloc import LandmarkMap
from omniloc.evaluate.tracking import Segment, Stream
from omniloc.track import Frame, GroundTruth, Odometry
from omniloc.track.calibrate import turn_noise_fit


def test_an_ar1_error_has_its_correlation_at_each_lag() -> None:
    # Errors of an AR(1) process sampled every 0.25 s with correlation 0.6 per step: 0.6 at
    # 0.25 s, 0.36 at 0.5 s; a second tube's errors are independent of the first's.
    rng = np.random.default_rng(1)
    rows = []
    for tube in (0, 1):
        e = 0.0
        for i in range(40_000):
            e = 0.6 * e + math.sqrt(1 - 0.36) * rng.normal()
            rows.append((0, tube, 0.25 * i, 0.01 * e))
    out = lag_correlations(rows, (0.3, 0.6))
    assert out[0]["correlation"] == pytest.approx(0.6, abs=0.02)
    assert out[1]["correlation"] == pytest.approx(0.36, abs=0.02)
    assert out[0]["pairs"] == 2 * (40_000 - 1)


def test_sightings_are_the_known_tubes_errors_against_the_truth() -> None:
    # Robot at the origin facing +x; tube 0 straight ahead seen 1 deg to the left, tube 1
    # seen 8 deg off (left out: the tail), a clutter bearing (no id: left out).
    lm = LandmarkMap(np.array([[3.0, 0.0], [0.0, 3.0], [-3.0, 0.0]]))
    t = np.array([0.0, 1.0])
    truth = GroundTruth(t, np.zeros(2), np.zeros(2), np.zeros(2))
    z = np.array([math.radians(1.0), math.radians(98.0), 0.3])
    frame = Frame(0.5, z, truth=(0, 1, None))
    odo = Odometry(t, np.zeros(2), np.zeros(2))
    stream = Stream("s", lm, odo, [frame], (Segment(0.0, 2.0, 0.0, truth, "test"),))
    (row,) = sightings([stream])
    assert row[:3] == (0, 0, 0.5) and row[3] == pytest.approx(math.radians(1.0))


def test_the_calibration_fit_finds_each_runs_camera_and_the_clock_and_helps_held_out() -> None:
    # Two runs, each with its own camera yaw and offset on the robot, one clock offset, and
    # noise: the fit finds them, and fitted on the first halves it cuts the second halves'
    # error to the noise.
    rng = np.random.default_rng(3)
    n = 6000
    run = np.repeat([0, 1], n // 2)
    geo = np.c_[rng.uniform(-0.6, 0.6, n), rng.uniform(1, 7, n), rng.normal(0, 0.2, n)]
    yaw = np.array([math.radians(0.3), math.radians(-0.7)])[run]
    fwd = np.array([-0.03, 0.09])[run]
    left = np.array([0.01, 0.03])[run]
    b, r, w = geo.T
    noise = rng.normal(0, math.radians(0.3), n)
    e = -yaw + (fwd * np.sin(b) - left * np.cos(b)) / r + 0.04 * w + noise
    rows = [
        (int(k), 0, float(i % (n // 2)), float(v))
        for i, (k, v) in enumerate(zip(run, e, strict=True))
    ]
    out = systematic(rows, geo, 2)
    runs = out["runs"]
    assert runs[0]["camera_yaw_deg"] == pytest.approx(0.3, abs=0.05)
    assert runs[1]["camera_yaw_deg"] == pytest.approx(-0.7, abs=0.05)
    assert runs[1]["camera_forward_m"] == pytest.approx(0.09, abs=0.01)
    assert runs[1]["camera_left_m"] == pytest.approx(0.03, abs=0.01)
    assert out["clock_offset_s"] == pytest.approx(0.04, abs=0.003)
    assert out["held_out_rms_after_deg"] == pytest.approx(0.3, abs=0.02)
    assert out["held_out_rms_deg"] > 0.5
    assert np.std(out["residual"]) == pytest.approx(math.radians(0.3), rel=0.05)


def test_geometry_is_the_bearing_range_and_turn_rate_at_the_truth() -> None:
    # The robot at the origin turning at 0.2 rad/s (heading 0 at t = 0.5 s); a tube 3 m to
    # its left.
    lm = LandmarkMap(np.array([[0.0, 3.0], [5.0, 5.0], [-3.0, 0.0]]))
    t = np.linspace(0.0, 1.0, 11)
    truth = GroundTruth(t, np.zeros(11), np.zeros(11), 0.2 * (t - 0.5))
    frame = Frame(0.5, np.array([math.pi / 2]), truth=(0,))
    odo = Odometry(t, np.zeros(11), np.zeros(11))
    stream = Stream("s", lm, odo, [frame], (Segment(0.0, 1.0, 0.0, truth, "test"),))
    rows = sightings([stream])
    (g,) = geometry([stream], rows)
    assert g == pytest.approx([math.pi / 2, 3.0, 0.2])


def test_a_drifting_bias_is_fitted_and_independent_errors_gain_nothing() -> None:
    # Two tubes, each a bias of sd 0.6 deg drifting with a 5 s correlation time plus 0.3 deg
    # of white noise, sighted every 0.25 s: the fit finds the three numbers. Errors that
    # are independent gain nothing from the model (the bias sd or its time goes to zero).
    rng = np.random.default_rng(5)
    sb, tau, sw = np.deg2rad(0.6), 5.0, np.deg2rad(0.3)
    a = math.exp(-0.25 / tau)
    rows = []
    for tube in (0, 1):
        b = sb * rng.normal()
        for i in range(3000):
            b = a * b + math.sqrt(1 - a * a) * sb * rng.normal()
            rows.append((0, tube, 0.25 * i, b + sw * rng.normal()))
    fit = drifting_bias_fit(rows)
    assert fit["bias_sd"] == pytest.approx(sb, rel=0.15)
    assert fit["white_sd"] == pytest.approx(sw, rel=0.1)
    assert fit["tau_s"] == pytest.approx(tau, rel=0.4)
    assert fit["gain_per_sighting"] > 0.3
    flat = [(0, 0, 0.25 * i, float(sw * rng.normal())) for i in range(3000)]
    assert drifting_bias_fit(flat)["gain_per_sighting"] < 0.01


def test_the_noise_that_grows_with_the_turn_rate_is_fitted() -> None:
    # Errors of sd 0.4 deg standing still and 0.056 s times the turn rate on top (the
    # values measured on MRCLAM), with a few gross outliers the robust spread ignores.
    rng = np.random.default_rng(6)
    w = rng.uniform(-0.6, 0.6, 60000)
    e = rng.normal(0.0, np.hypot(np.deg2rad(0.4), 0.056 * w))
    e[::200] = rng.uniform(-0.1, 0.1, e[::200].size)
    fit = turn_noise_fit(e, w)
    assert fit["sd0"] == pytest.approx(np.deg2rad(0.4), rel=0.05)
    assert fit["turn_noise_s"] == pytest.approx(0.056, rel=0.05)
    sds = [b["sd"] for b in fit["bins"]]
    assert sds == sorted(sds)  # growing with the turn rate
    # No dependence: no turn noise.
    flat = turn_noise_fit(rng.normal(0.0, 0.01, 60000), w)
    assert flat["turn_noise_s"] < 0.01


def test_results_files_say_when_where_and_how(tmp_path: Path) -> None:
    import json

    from _results import run_meta, write_results

    meta = run_meta("bearing_correlation.py", ["--out", "x.json"], wall_s=2.0)
    write_results(tmp_path / "r.json", meta, lags=[1, 2])
    out = json.loads((tmp_path / "r.json").read_text())
    assert out["lags"] == [1, 2] and out["meta"]["wall_s"] == 2.0
    assert out["meta"]["command"] == "python benchmarks/bearing_correlation.py --out x.json"
    assert out["meta"]["date"].endswith("+00:00") and "Python" in out["meta"]["machine"]
    # ... and with which numerical libraries (their arithmetic can move a filter's draws).
    from importlib.metadata import version

    assert out["meta"]["libraries"]["numpy"] == version("numpy")
    assert set(out["meta"]["libraries"]) == {"numpy", "scipy", "numba", "llvmlite"}


def test_a_results_file_in_a_missing_folder_is_written_not_lost(tmp_path: Path) -> None:
    # A benchmark of minutes whose --out names a folder not yet made must not end in a
    # traceback with its figures lost (track_speed.py did, 2026-12-08).
    import json

    from _results import run_meta, write_results

    path = tmp_path / "new" / "deeper" / "r.json"
    write_results(path, run_meta("x.py", []), n=3)
    assert json.loads(path.read_text())["n"] == 3
