"""Thread pools kept for the life of the calling thread, one per use.

The compiled kernels release the GIL, so the search's chunks and the tracker's halves of a
frame run side by side on threads. Starting a pool for each call cost more than some calls'
work: a tracker's window searches on MRCLAM (about 18 ms each) spent 1 ms of each starting
and joining two threads. So each use asks :func:`pool` for its pool, made at first use and
kept. Work handed to a pool must never wait on work of the same pool (none does: the
callers wait, the tasks do not).

Each calling thread has pools of its own: searches or trackers run from several threads at
once do not queue behind each other's work (as they did not when each call made its own),
and a thread's pools go with it (``ThreadPoolExecutor``'s workers leave when their pool is
collected).

A child made by ``fork`` has none of its parent's threads; work handed to the parent's pool
there would wait for ever, so the child forgets the pools and makes its own.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["CORES", "pool"]

#: The machine's cores (asked once: ``os.cpu_count`` reads /proc each time).
CORES = os.cpu_count() or 1

_local = threading.local()


def pool(name: str, workers: int) -> ThreadPoolExecutor:
    """The calling thread's pool of ``workers`` threads named ``name``, made at first use.

    Parameters
    ----------
    name : str
        The use (the threads' name prefix, e.g. ``"omniloc-frame"``).
    workers : int
        Its threads (at least 1).

    Returns
    -------
    ThreadPoolExecutor
        The same pool for the same ``(name, workers)`` and thread, until the process
        forks.
    """
    key = (name, max(1, int(workers)))
    pools: dict[tuple[str, int], ThreadPoolExecutor] | None = getattr(_local, "pools", None)
    if pools is None:
        pools = _local.pools = {}
    found = pools.get(key)
    if found is None:
        found = pools[key] = ThreadPoolExecutor(max_workers=key[1], thread_name_prefix=name)
    return found


def _forget() -> None:
    """In a forked child: the parent's pools have no threads here."""
    global _local
    _local = threading.local()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget)
