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
