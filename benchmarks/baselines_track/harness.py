"""Running a localizer that needs to know its stream through the one scoring code.

:func:`omniloc.evaluate.tracking.evaluate_tracking` builds each localizer from the map and
the start pose only; the EKF with known correspondences also needs the stream's frames (their
:attr:`~omniloc.track.Frame.truth`). :func:`evaluate_streams` calls ``evaluate_tracking`` on
one stream at a time with a factory that knows the stream, and gathers the scores into one
:class:`~omniloc.evaluate.tracking.TrackingResult`: the scoring is the harness's, untouched.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

from omniloc.evaluate.bounds import StreamBound
from omniloc.evaluate.tracking import (
    LocalizerOverTime,
    RunScore,
    Stream,
    TrackingResult,
    evaluate_tracking,
)
from omniloc.pose import Pose

__all__ = ["evaluate_streams"]

StreamFactory = Callable[[Stream, Pose | None], LocalizerOverTime]


def evaluate_streams(
    streams: Sequence[Stream],
    make: StreamFactory,
    *,
    name: str,
    oracle_start: bool = False,
    progress: bool = True,
    bound: Callable[[Stream], StreamBound] | None = None,
) -> TrackingResult:
    """Score ``make(stream, start)`` on every stream with ``evaluate_tracking`` (and
    ``bound``, what the data allow, beside it when given)."""
    runs: list[RunScore] = []
    for k, s in enumerate(streams):

        def factory(_landmarks: object, start: Pose | None, s: Stream = s) -> LocalizerOverTime:
            return make(s, start)

        res, _ = evaluate_tracking(
            [s], factory, name=name, oracle_start=oracle_start, progress=False, bound=bound
        )
        runs.extend(res.runs)
        if progress and sys.stderr.isatty():
            print(f"\r  {name}: {k + 1}/{len(streams)} streams", end="", file=sys.stderr)
    if progress and sys.stderr.isatty():
        print(file=sys.stderr)
    return TrackingResult(name, runs)
