"""What the diagnosis scripts of ``benchmarks/`` write beside their figures: when, on what
machine, by which command -- one implementation, so every results file says it the same way."""

from __future__ import annotations

import json
import platform
import sys
from collections.abc import Sequence
from datetime import datetime, timezone
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

__all__ = ["libraries", "run_meta", "write_results"]

#: The libraries whose arithmetic the figures depend on: a compiled kernel or a random
#: generator of another version can sum in another order and move a particle filter's draws
#: (the states of benchmarks/track_sim.py stayed, its weights' calibration moved between
#: the venvs of 2026-12-05 and 2026-12-06).
LIBRARIES = ("numpy", "scipy", "numba", "llvmlite")


def libraries() -> dict[str, str]:
    """The installed versions of :data:`LIBRARIES` ("not installed" for one that is not).

    Examples
    --------
    >>> sorted(libraries()) == sorted(LIBRARIES)
    True
    """
    out = {}
    for name in LIBRARIES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def run_meta(script: str, argv: Sequence[str] | None, **extra: Any) -> dict[str, Any]:
    """The ``meta`` block of a results file: the date (UTC), the machine, the command that
    wrote it (``argv``: the script's arguments, None for the command line's), the versions
    of the numerical libraries (:func:`libraries`) and ``extra``.

    Examples
    --------
    >>> m = run_meta("x.py", ["--fast"], wall_s=1.5)
    >>> m["command"], m["wall_s"]
    ('python benchmarks/x.py --fast', 1.5)
    """
    args = list(argv) if argv is not None else sys.argv[1:]
    return {
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "machine": f"{platform.machine()}, Python {platform.python_version()}",
        "command": " ".join(["python", f"benchmarks/{script}", *args]),
        "libraries": libraries(),
        **extra,
    }


def write_results(path: str | Path, meta: dict[str, Any], **payload: Any) -> None:
    """Write ``{"meta": meta, **payload}`` as indented JSON to ``path`` and say so; the
    folder is made if it is missing (a run of minutes should not end in a traceback)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps({"meta": meta, **payload}, indent=1) + "\n")
    print(f"wrote {path}")
