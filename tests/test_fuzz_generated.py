"""Property-based fuzzing with generated values (hypothesis, derandomized: the same examples
in every run, so CI cannot flake): extreme floats, huge ints, wrong types and shapes, text and
bytes as files, and option strings on the command line. Each call must return something sane
or raise omniloc's own error on one line naming the argument (see ``_fuzz``).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import _fuzz as F
import omniloc
from omniloc.io import check_bearings, load_bearings
from omniloc.pose import (
    crlb,
    estimate_pose,
    fisher_information,
    pose_covariance,
    predict_bearings,
    refine_pose,
)
from omniloc.sensor import SensorModel

#: (Timed calls: the kernels are compiled before the first, not during it.)
pytestmark = pytest.mark.usefixtures("compiled_kernels")

# ---- strategies -----------------------------------------------------------------------------

#: Every float, NaN, infinities and subnormals included.
any_float = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)

#: Values a caller may pass where a number is expected.
numberish = st.one_of(
    any_float,
    st.integers(min_value=-(10**400), max_value=10**400),
    st.sampled_from([None, True, "x", "1.0", b"1", [0.5], (), {}, 1 + 1j, np.float32("nan")]),
    st.floats(min_value=1e-6, max_value=4.0),
)

#: Plausible-or-not positive numbers (most draws near the valid range).
positive = st.one_of(st.floats(min_value=1e-15, max_value=1e15), any_float)


def _arrays(shape: Any, elements: Any = any_float) -> Any:
    return hnp.arrays(np.float64, shape, elements=elements)


#: (n, 2) landmark arrays: near-valid shapes, every float.
landmarks = st.one_of(
    _arrays(st.tuples(st.integers(0, 6), st.just(2))),
    _arrays(st.tuples(st.integers(3, 6), st.just(2)), st.floats(-1e12, 1e12)),
    _arrays(st.tuples(st.integers(0, 4), st.integers(0, 3))),
)

#: Bearing arrays of any length with every float.
bearings = st.one_of(
    _arrays(st.integers(0, 8)),
    _arrays(st.integers(3, 8), st.floats(-10.0, 10.0)),
    st.lists(numberish, max_size=6),
)

poses = st.one_of(
    st.tuples(any_float, any_float, any_float),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-4, 4)),
    st.lists(any_float, max_size=4),
    st.builds(omniloc.Pose, st.floats(-20, 20), st.floats(-20, 20), st.floats(-3, 3)),
)


def _judge(call: Any, names: list[str], **kw: Any) -> None:
    out = F.run_call(call, names, **kw)
    assert out.kind in ("ok", "refused"), str(out)


# ---- section 2: poses from known pairs ------------------------------------------------------


@F.fuzz_settings(60)
@given(L=landmarks, b=bearings)
def test_estimate_pose(L: Any, b: Any) -> None:
    _judge(lambda: estimate_pose(L, b), ["landmark", "bearing"])


@F.fuzz_settings(60)
@given(
    b=_arrays(5, st.floats(-4.0, 4.0)),
    initial=st.one_of(st.none(), poses),
    sigma=st.one_of(st.none(), numberish),
)
def test_refine_pose(b: Any, initial: Any, sigma: Any) -> None:
    _judge(
        lambda: refine_pose(F.room_xy5(), b, initial=initial, sigma=sigma),
        ["initial", "pose", "sigma", "bearing"],
        check=lambda v: F.check_value(v, nan_covariance_ok=sigma is None),
    )


@F.fuzz_settings(60)
@given(L=landmarks, pose=poses, sigma=numberish)
def test_covariances_at_a_pose(L: Any, pose: Any, sigma: Any) -> None:
    names = ["landmark", "pose", "sigma"]
    for f in (crlb, pose_covariance, fisher_information):
        _judge(lambda f=f: f(L, pose, sigma), names)  # type: ignore[misc]


@F.fuzz_settings(60)
@given(L=landmarks, pose=poses)
def test_predict_bearings(L: Any, pose: Any) -> None:
    _judge(lambda: predict_bearings(L, pose), ["landmark", "pose"])


@F.fuzz_settings(40)
@given(x=numberish, y=numberish, theta=numberish)
def test_pose(x: Any, y: Any, theta: Any) -> None:
    _judge(lambda: omniloc.Pose(x, y, theta), ["pose"])


# ---- section 3: the search ------------------------------------------------------------------

search_keywords = st.fixed_dictionaries(
    {},
    optional={
        "sigma": st.one_of(numberish, st.floats(1e-4, 0.3)),
        "threshold": st.one_of(numberish, st.floats(1e-4, 0.3)),
        "max_spurious": st.one_of(numberish, st.integers(0, 3), st.floats(0.0, 0.99)),
        "max_range": positive,
        "min_range": positive,
        "fov": positive,
        "p_miss": numberish,
        "clutter": numberish,
        "confidence": numberish,
        "decisive": numberish,
        "max_nodes": st.one_of(st.integers(-5, 10**30), numberish),
        "timeout_s": st.one_of(st.floats(1e-6, 1.0), numberish),
        "exhaustive": st.sampled_from([True, False, None, "no", 0]),
    },
)


@F.fuzz_settings(80)
@given(b=bearings, kw=search_keywords)
def test_localize(b: Any, kw: dict[str, Any]) -> None:
    """Every keyword at once: whatever is refused is named; whatever runs keeps its budget
    (a default one when nothing bounds it) and returns finite, positive-definite answers."""
    names = ["bearing", "timeout", *kw]
    timeout = kw.get("timeout_s")
    limit = F.HANG_S
    if isinstance(timeout, float) and 0 < timeout <= 1.0:
        limit = timeout + 3.0  # the budget, plus scoring and a loaded CI machine
    _judge(lambda: omniloc.localize(F.room(), b, **kw), names, limit_s=limit)


@F.fuzz_settings(40)
@given(
    kw=st.fixed_dictionaries(
        {},
        optional={
            k: numberish for k in ("sigma", "threshold", "fov", "max_range", "min_range", "clutter")
        }
        | {"gate_confidence": numberish, "p_detect": numberish, "allow_wide": st.booleans()},
    )
)
def test_sensor_model(kw: dict[str, Any]) -> None:
    def build() -> None:
        s = SensorModel(**kw)
        F._finite([s.threshold], "threshold")

    _judge(build, list(kw) or ["sensor"])


@F.fuzz_settings(30)
@given(sigma=st.floats(0.18, 3.0), timeout=st.floats(0.05, 0.5))
def test_a_wide_gate_keeps_its_budget(sigma: float, timeout: float) -> None:
    """No call beyond its budget: a gate that accepts nearly every pairing, on 30 landmarks."""
    lm = omniloc.random_map(30, rng=1)
    z = predict_bearings(lm.xy[:6], omniloc.Pose(10.0, 10.0, 0.0))
    sensor = SensorModel(sigma=sigma, allow_wide=True)
    t0 = time.perf_counter()
    result = omniloc.localize(lm, z, sensor=sensor, timeout_s=timeout)
    assert time.perf_counter() - t0 < timeout + 2.0
    F.check_value(result)
    assert result.stats.default_budget == ""


# ---- files and arrays at the door -----------------------------------------------------------


@F.fuzz_settings(40)
@given(b=bearings, n=st.one_of(st.none(), numberish), k=st.one_of(st.none(), numberish))
def test_check_bearings(b: Any, n: Any, k: Any) -> None:
    _judge(
        lambda: check_bearings(b, n_landmarks=n, min_count=k),
        ["bearing", "n_landmarks", "min_count", "landmark"],
    )


@F.fuzz_settings(40)
@given(
    xy=landmarks, ids=st.one_of(st.none(), st.lists(st.one_of(st.integers(), st.text())), numberish)
)
def test_landmark_map(xy: Any, ids: Any) -> None:
    _judge(lambda: omniloc.LandmarkMap(xy, ids=ids), ["landmark", "ids", "id"])


file_text = st.one_of(
    st.text(max_size=200),
    st.lists(st.one_of(any_float.map(repr), st.integers().map(str)), max_size=8).map("\n".join),
    st.lists(any_float.map(repr), max_size=8).map(lambda v: "[" + ", ".join(v) + "]"),
)
file_bytes = st.one_of(file_text.map(lambda t: t.encode("utf-8")), st.binary(max_size=200))


@F.fuzz_settings(60)
@given(content=file_bytes, ext=st.sampled_from([".csv", ".txt", ".json", ".dat", ""]))
def test_load_bearings(tmp_path_factory: Any, content: bytes, ext: str) -> None:
    p = tmp_path_factory.mktemp("bearings") / f"b{ext}"
    p.write_bytes(content)
    _judge(lambda: load_bearings(p), ["file", "path", str(p.name), "bearing"])


@F.fuzz_settings(60)
@given(content=file_bytes, ext=st.sampled_from([".csv", ".json", ".txt"]))
def test_load_map(tmp_path_factory: Any, content: bytes, ext: str) -> None:
    p = tmp_path_factory.mktemp("map") / f"m{ext}"
    p.write_bytes(content)
    _judge(lambda: omniloc.LandmarkMap.load(p), ["map", "file", "path", str(p.name), "landmark"])


# ---- the command line -----------------------------------------------------------------------

option_text = st.one_of(
    any_float.map(repr),
    st.integers(min_value=-(10**60), max_value=10**60).map(str),
    st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=12),
    st.sampled_from(["nan", "-inf", "1e999", "0x10", "1_0", "", " ", "-", "--", "1e"]),
)

#: The numeric options of ``localize`` that take any float (not the image's).
NUMERIC_OPTIONS = [o for o in F.LOCALIZE_NUMERIC if o not in ("--forward", "--aspect")]


@F.fuzz_settings(60)
@given(
    options=st.lists(
        st.tuples(st.sampled_from(NUMERIC_OPTIONS), option_text), min_size=1, max_size=3
    )
)
def test_cli_localize_options(tmp_path_factory: Any, options: list[tuple[str, str]]) -> None:
    """Any option values: exit 0, or exit 1 with exactly one line ``error: ...``."""
    d: Path = tmp_path_factory.mktemp("cli")
    (d / "room.csv").write_text(F.ROOM_CSV)
    argv = ["localize", "--map", str(d / "room.csv"), "--bearings", str(F._bearings_file(d))]
    argv += ["--timeout", "2"]
    for opt, value in options:
        argv += [f"{opt}={value}"]  # '=' so that a value starting with '-' stays a value
    out = F.judge_cli(argv, d)
    assert out.kind in ("ok", "refused"), f"{argv}: {out}"
