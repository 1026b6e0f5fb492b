"""The compiled code (numba), one file per engine; each kernel's top comment says what it
computes and in which order.

* :mod:`.geometry` -- the section-2 building blocks (pair terms, pose from the sums, rule (i),
  the 3x3 inverse, Gauss-Newton, covariances) that :mod:`omniloc.pose` and both search
  engines call: one implementation of each formula;
* :mod:`.tree` -- the paper's interpretation tree with a fixed threshold;
* :mod:`.hypotheses` -- hypothesise and verify (wildcards, chi-square gates, range limits,
  negative evidence, budgets);
* :mod:`.merge` -- merging equal poses;
* :mod:`.errors` -- the likelihood of bearing errors whose biases are shared.

Kernels take their arguments in named groups (``NamedTuple``: noise and gate, visibility,
budget, ...) and return named counters. They are compiled on first use and cached on disk.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

#: The file in each ``__pycache__`` that names the kernel sources its compiled code is from.
STAMP = "omniloc-kernels.sha256"


def clear_stale_cache(folder: Path) -> bool:
    """Drop numba's cached code in ``folder/__pycache__`` unless it was compiled from the
    ``*.py`` sources that ``folder`` holds now; returns whether it was dropped.

    numba checks each cached function against its own file's timestamp only, not against
    the files of the functions it calls (numba issue 1833; its documentation's "cache
    invalidation fails to recognize changes in symbols defined in a different file"): after
    an edit of ``geometry.py`` the search kernels, which inline its Gauss-Newton, ran the
    old one (a timing comparison measured code that no longer existed, and the tests would
    have run it too). So a change to any kernel's source recompiles them all (about 20 s,
    once). Where the folder cannot be written
    (a read-only install), nothing is done: numba then caches elsewhere, and installed
    sources do not change in place.
    """
    digest = hashlib.sha256()
    try:
        for source in sorted(folder.glob("*.py")):
            digest.update(source.name.encode() + b"\0" + source.read_bytes() + b"\0")
        cache = folder / "__pycache__"
        stamp = cache / STAMP
        if stamp.is_file() and stamp.read_text() == digest.hexdigest():
            return False
        for pattern in ("*.nbi", "*.nbc"):
            for stale in cache.glob(pattern):
                stale.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:
        return False
    return True


clear_stale_cache(Path(__file__).parent)
