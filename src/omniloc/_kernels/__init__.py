"""The compiled code (numba), one file per engine; each kernel's top comment says what it
computes and in which order.

* :mod:`.geometry` -- the section-2 building blocks (pair terms, pose from the sums, rule (i),
  the 3x3 inverse, Gauss-Newton, covariances) that :mod:`omniloc.pose` and both search
  engines call: one implementation of each formula;
* :mod:`.tree` -- the paper's interpretation tree with a fixed threshold;
* :mod:`.hypotheses` -- hypothesise and verify (wildcards, chi-square gates, range limits,
  negative evidence, budgets);
* :mod:`.merge` -- merging equal poses.

Kernels take their arguments in named groups (``NamedTuple``: noise and gate, visibility,
budget, ...) and return named counters. They are compiled on first use and cached on disk.
"""
