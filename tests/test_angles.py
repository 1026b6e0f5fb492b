from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from omniloc.angles import angdiff, deg2rad, rad2deg, wrap


@given(st.floats(min_value=-1e4, max_value=1e4, allow_nan=False))
def test_wrap_range_and_equivalence(a: float) -> None:
    w = wrap(a)
    assert -np.pi <= w < np.pi
    assert abs(np.sin(w) - np.sin(a)) < 1e-9 and abs(np.cos(w) - np.cos(a)) < 1e-9


def test_wrap_edges() -> None:
    assert wrap(np.pi) == -np.pi
    assert wrap(-np.pi) == -np.pi
    assert wrap(np.nextafter(-np.pi, 0)) == np.nextafter(-np.pi, 0)
    arr = wrap(np.array([0.0, 2 * np.pi, -3 * np.pi, 7.0]))
    assert isinstance(arr, np.ndarray)
    assert np.allclose(arr, [0.0, 0.0, -np.pi, 7.0 - 2 * np.pi])


def test_angdiff_and_units() -> None:
    assert np.isclose(angdiff(np.deg2rad(179), np.deg2rad(-179)), np.deg2rad(-2))
    assert np.isclose(rad2deg(deg2rad(123.0)), 123.0)


def _angle_cases(rng: np.random.Generator) -> np.ndarray:
    """Random angles and the edges of wrapping: +-pi and their neighbours, signed zeros,
    tiny and huge values, infinities and NaN."""
    pi = np.pi
    edges = [0.0, -0.0, 1e-300, -1e-300, 1e-20, -1e-20, pi, -pi, 2 * pi, -2 * pi, 3 * pi]
    edges += [np.nextafter(pi, 0), np.nextafter(pi, 4), np.nextafter(-pi, 0)]
    edges += [np.nextafter(-pi, -4), np.nextafter(-3 * pi, 0), 1e10, -1e10, 1e300, -1e300]
    edges += [np.inf, -np.inf, np.nan]
    # One turn out either way (the difference of two wrapped angles), and its edges.
    edges += [3 * pi, np.nextafter(3 * pi, 0), np.nextafter(3 * pi, 10), -3 * pi]
    edges += [np.nextafter(-3 * pi, -10), -pi - 1e-17, -pi - 1e-300, np.nextafter(-pi, -4)]
    near = np.concatenate(
        [pi + rng.normal(0, 1e-15, 200), -pi + rng.normal(0, 1e-15, 200)]
        + [c + rng.normal(0, 1e-15, 200) for c in (3 * pi, -3 * pi)]
    )
    ends = np.array([-pi, np.nextafter(pi, 0), 0.0, -1e-300, 1e-300])
    turns = np.subtract.outer(ends, ends).ravel()
    diffs = rng.uniform(-pi, pi, 3000) - rng.uniform(-pi, pi, 3000)
    return np.concatenate(
        [edges, near, turns, diffs, rng.uniform(-10, 10, 5000), rng.normal(0, 1e3, 500)]
    )


def test_wrap_float_is_wrap_angle_bit_for_bit(rng: np.random.Generator) -> None:
    # The compiled kernels' fast wrap of one float against the element-wise wrap it replaces.
    from omniloc._kernels.geometry import wrap_angle, wrap_float

    a = _angle_cases(rng)
    compiled = np.array([wrap_angle(float(x)) for x in a])
    with np.errstate(invalid="ignore"):
        readable = np.asarray(wrap_angle.py_func(a))
    fast = np.array([wrap_float(float(x)) for x in a])
    assert np.array_equal(fast.view(np.int64), compiled.view(np.int64))
    assert np.array_equal(fast.view(np.int64), readable.view(np.int64))


def test_wrap_fast_paths_are_the_mod_bit_for_bit(rng: np.random.Generator) -> None:
    # wrap skips np.mod where it returns its input; the oracle is the plain formula.
    a = _angle_cases(rng)
    with np.errstate(invalid="ignore"):
        ref = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    ref = np.where(ref >= np.pi, ref - 2.0 * np.pi, ref)
    bits = ref.view(np.int64)
    with np.errstate(invalid="ignore"):
        scalars = np.array([wrap(float(x)) for x in a])
        numpy_scalars = np.array([wrap(np.float64(x)) for x in a])
        inside = np.asarray(wrap(a[np.abs(a) < 3.0]))
        whole = np.asarray(wrap(a))
    assert np.array_equal(scalars.view(np.int64), bits)
    assert np.array_equal(numpy_scalars.view(np.int64), bits)
    assert np.array_equal(inside.view(np.int64), bits[np.abs(a) < 3.0])
    assert np.array_equal(whole.view(np.int64), bits)
    assert isinstance(wrap(0.5), float) and isinstance(wrap(np.float64(0.5)), float)
