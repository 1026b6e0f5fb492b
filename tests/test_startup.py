"""What ``import omniloc`` costs: the quantiles it needs come from ``scipy.special``, not
``scipy.stats`` (most of a second of start-up for every command-line call): the chi-square
quantiles bit for bit, the binomial median exactly."""

from __future__ import annotations

import subprocess
import sys
from fractions import Fraction
from math import comb

import pytest
from scipy.stats import binom, chi2


def test_import_omniloc_does_not_import_scipy_stats() -> None:
    code = "import sys, omniloc, omniloc.cli, omniloc.track; print('scipy.stats' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_the_chi_square_quantiles_are_scipy_stats_own() -> None:
    from omniloc.evaluate.tracking import CHI2_3DOF_50, CHI2_3DOF_99
    from omniloc.search.scoring import SAME_PLACE_CHI2

    assert SAME_PLACE_CHI2 == float(chi2.ppf(0.9999, 3))
    assert CHI2_3DOF_50 == float(chi2.ppf(0.5, 3))
    assert CHI2_3DOF_99 == float(chi2.ppf(0.99, 3))


def _exact_median(n: int, p: float) -> int:
    """The smallest k with P(Binomial(n, p) <= k) >= 1/2, in exact rational arithmetic."""
    q = Fraction(p)
    total = Fraction(0)
    for k in range(n + 1):
        total += comb(n, k) * q**k * (1 - q) ** (n - k)
        if total >= Fraction(1, 2):
            return k
    return n


@pytest.mark.parametrize("p", [0.0, 0.01, 0.1, 0.25, 0.3, 0.5, 0.59, 0.6, 0.75, 0.9, 0.99, 1.0])
def test_the_binomial_median_is_exact(p: float) -> None:
    # And scipy.stats's own wherever the distribution function does not sit exactly on 1/2
    # (there, p 1/2 and n odd from 35 on, scipy's rounding gives the next k).
    from omniloc.search.hypotheses import binomial_median

    for n in range(0, 80):
        k = binomial_median(n, p)
        assert k == _exact_median(n, p), (n, p)
        tie = p == 0.5 and n % 2 == 1
        if not tie:
            assert k == int(binom.ppf(0.5, n, p)), (n, p)
