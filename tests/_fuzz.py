"""What the fuzz suite (``tests/test_fuzz_*.py``) and ``benchmarks/fuzz_census.py`` share.

A *case* calls one public function (or the command line) with one argument replaced by a bad,
extreme or malformed value, the others valid. Its *outcome* is one of

``ok``
    it returned, and what it returned is sane: finite poses, finite positive-definite
    covariances, confidences in [0, 1], bearings in [-pi, pi) ...;
``refused``
    it raised an :class:`omniloc.OmnilocError` whose message is one line and names the
    argument (or the file) -- or a :class:`omniloc.DegenerateGeometryError`, which names the
    geometry;
``bad``
    anything else: another exception (a traceback for the user), a message that does not say
    what is wrong, an insane result, a command line that does not print exactly one line and
    exit 1, or a call that overran its time.

The value pools are plain lists of ``(label, value)`` so that the census can name a case and
rebuild it in another process; hypothesis draws from the same pools (and from its own
generators) in the tests.
"""

from __future__ import annotations

import contextlib
import functools
import io
import logging
import math
import os
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import HealthCheck, settings

import omniloc
from omniloc import DegenerateGeometryError, OmnilocError

# --------------------------------------------------------------------------------------------
# Hypothesis: one profile for the whole suite, reproducible in CI
# --------------------------------------------------------------------------------------------

settings.register_profile(
    "omniloc-fuzz",
    derandomize=True,
    database=None,
    deadline=None,
    print_blob=False,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
        HealthCheck.function_scoped_fixture,
    ],
)


def fuzz_settings(max_examples: int) -> settings:
    """The suite's profile (derandomized: the same examples in every run) with a count."""
    return settings(settings.get_profile("omniloc-fuzz"), max_examples=max_examples)


# --------------------------------------------------------------------------------------------
# Outcomes
# --------------------------------------------------------------------------------------------

#: A call that takes longer than this is a hang (the issue's measure was 20 s; inputs here
#: are small, so 10 s is generous).
HANG_S = 10.0

#: An error message longer than this does not say what is wrong (it quotes a 300-digit
#: number or a whole file).
MAX_MESSAGE = 400


@dataclass
class Outcome:
    """``kind`` is ``ok``, ``refused`` or ``bad``; ``detail`` says why."""

    kind: str
    detail: str = ""
    elapsed: float = 0.0

    def __str__(self) -> str:
        return f"{self.kind} ({self.elapsed:.2f} s): {self.detail}"


class Insane(AssertionError):
    """A result that no caller should get (a non-finite pose, a covariance that is not
    positive definite ...)."""


def _finite(x: Any, what: str) -> None:
    a = np.asarray(x, dtype=np.float64)
    if not np.isfinite(a).all():
        raise Insane(f"{what} is not finite: {a!r}")


def _positive_definite(c: Any, what: str) -> None:
    c = np.asarray(c, dtype=np.float64)
    _finite(c, what)
    if c.shape != (3, 3) or not np.allclose(c, c.T, rtol=1e-8, atol=0.0):
        raise Insane(f"{what} is not a symmetric 3x3 matrix: {c!r}")
    w = np.linalg.eigvalsh(c)
    if not w[0] > 0:
        raise Insane(f"{what} is not positive definite (eigenvalues {w})")


def check_pose(p: Any, what: str = "pose") -> None:
    _finite([p.x, p.y, p.theta], what)
    if not -math.pi <= p.theta < math.pi:
        raise Insane(f"{what}.theta {p.theta} is not in [-pi, pi)")


def check_bearings_out(b: Any, what: str = "bearings") -> None:
    a = np.asarray(b, dtype=np.float64)
    _finite(a, what)
    if a.size and not ((a >= -math.pi) & (a < math.pi)).all():
        raise Insane(f"{what} not wrapped to [-pi, pi): {a}")


def check_value(v: Any, *, nan_covariance_ok: bool = False) -> None:
    """Raise :class:`Insane` unless ``v`` (whatever a public function returned) is sane."""
    from omniloc.search import LocalizationResult, Solution
    from omniloc.vision import EdgeDetections, MirrorCalibration

    if isinstance(v, omniloc.Pose):
        check_pose(v)
    elif isinstance(v, LocalizationResult):
        total = v.unexplained
        _finite(total, "unexplained")
        for s in v.solutions:
            check_value(s)
            total += s.confidence
        if v.solutions and not abs(total - 1.0) < 1e-6:
            raise Insane(f"confidences and unexplained sum to {total}, not 1")
        _finite(v.stats.elapsed_s, "stats.elapsed_s")
    elif isinstance(v, Solution):
        check_pose(v.pose, "solution pose")
        _positive_definite(v.covariance, "solution covariance")
        _finite([v.confidence, v.residual_rms, v.cost], "solution numbers")
        if not 0.0 <= v.confidence <= 1.0:
            raise Insane(f"confidence {v.confidence} outside [0, 1]")
    elif isinstance(v, EdgeDetections):
        check_bearings_out(v.bearings, "detections.bearings")
        _finite(v.strength, "detections.strength")
        check_value(v.calibration)
    elif isinstance(v, MirrorCalibration):
        _finite([*v.center, v.aspect, v.radius], "calibration")
        if not (v.aspect > 0 and v.radius > 0):
            raise Insane(f"calibration {v}")
    elif isinstance(v, tuple) and len(v) == 2 and isinstance(v[0], omniloc.Pose):
        # refine_pose: (pose, covariance); all NaN is the documented "unknown" covariance.
        check_pose(v[0])
        c = np.asarray(v[1], dtype=np.float64)
        if not (nan_covariance_ok and c.shape == (3, 3) and np.isnan(c).all()):
            _positive_definite(c, "covariance")
    elif isinstance(v, np.ndarray) and v.dtype.kind in "fc":
        _finite(v, "array")
    elif isinstance(v, (list, tuple)):
        for item in v:
            check_value(item)
    elif isinstance(v, float):
        _finite(v, "number")


def _one_line(msg: str) -> str | None:
    """Why a message is not a good one-line message, or None."""
    if not msg.strip():
        return "empty message"
    if "\n" in msg or "\r" in msg:
        return "message spans several lines"
    if len(msg) > MAX_MESSAGE:
        return f"message of {len(msg)} characters"
    return None


def judge_error(exc: BaseException, names: Sequence[str]) -> Outcome:
    """``refused`` for an omniloc error that names one of ``names`` (case-insensitive) on one
    line; ``bad`` otherwise."""
    msg = str(exc)
    if not isinstance(exc, OmnilocError):
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return Outcome("bad", f"foreign {tb[:300]}")
    why = _one_line(msg)
    if why:
        return Outcome("bad", f"{type(exc).__name__}: {why}: {msg[:200]!r}")
    if isinstance(exc, DegenerateGeometryError):
        return Outcome("refused", f"{type(exc).__name__}: {msg}")
    low = msg.lower()
    if names and not any(n.lower() in low for n in names):
        return Outcome("bad", f"{type(exc).__name__} names none of {list(names)}: {msg!r}")
    return Outcome("refused", f"{type(exc).__name__}: {msg}")


def run_call(
    fn: Callable[[], Any],
    names: Sequence[str],
    *,
    check: Callable[[Any], None] = check_value,
    limit_s: float = HANG_S,
) -> Outcome:
    """Call ``fn`` and judge what happens (see the module's documentation)."""
    t0 = time.perf_counter()
    try:
        value = fn()
    except Exception as exc:
        out = judge_error(exc, names)
    else:
        try:
            check(value)
        except Insane as exc:
            out = Outcome("bad", f"insane result: {exc}"[:400])
        except Exception as exc:
            out = Outcome("bad", f"unexpected result ({type(exc).__name__}: {exc})"[:400])
        else:
            out = Outcome("ok", type(value).__name__)
    out.elapsed = time.perf_counter() - t0
    if out.elapsed > limit_s:
        out = Outcome("bad", f"took {out.elapsed:.1f} s (limit {limit_s:g} s); {out.detail}")
        out.elapsed = time.perf_counter() - t0
    return out


# --------------------------------------------------------------------------------------------
# The command line: exit status and exactly what reaches stderr (file descriptor 2 too)
# --------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _capture_fd2() -> Any:
    """Everything written to file descriptor 2 (OpenCV, libpng ...) during the block."""
    sys.stderr.flush()
    with tempfile.TemporaryFile() as f:
        saved = os.dup(2)
        os.dup2(f.fileno(), 2)
        box: list[str] = []
        try:
            yield box
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            box.append(f.read().decode("utf-8", "replace"))


def run_cli(
    argv: Sequence[str], folder: Path, *, limit_s: float = HANG_S
) -> tuple[int | None, str, str, float]:
    """``omniloc.cli.main(argv)`` in this process, run from ``folder`` (so that an empty or
    relative output path lands there, never in the checkout): (status or None on an
    exception, stdout, stderr including what C libraries wrote to fd 2 (a traceback for an
    exception), seconds)."""
    from omniloc.cli import main

    out, err = io.StringIO(), io.StringIO()
    root = logging.getLogger()
    saved_handlers, saved_level = root.handlers[:], root.level
    root.handlers = []
    t0 = time.perf_counter()
    code: int | None
    with contextlib.chdir(folder), _capture_fd2() as fd2:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in argv])
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 1
                err.write(f"[SystemExit {exc.code!r}]\n")
            except Exception:
                code = None
                err.write(traceback.format_exc())
        for h in root.handlers:
            h.flush()
    root.handlers, root.level = saved_handlers, saved_level
    return code, out.getvalue(), fd2[0] + err.getvalue(), time.perf_counter() - t0


def judge_cli(argv: Sequence[str], folder: Path, *, limit_s: float = HANG_S) -> Outcome:
    """``ok`` for exit 0; ``refused`` for exit 1 with one line ``error: ...`` on stderr and
    nothing else; ``bad`` otherwise (a traceback, two lines, another status, too slow)."""
    code, _out, err, dt = run_cli(argv, folder, limit_s=limit_s)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code == 0:
        out = Outcome("ok", f"exit 0, {len(lines)} stderr lines", dt)
    elif code is None:
        last = lines[-1] if lines else ""
        out = Outcome("bad", f"traceback: {last[:300]}", dt)
    elif code != 1:
        out = Outcome("bad", f"exit {code}: {err[-300:]!r}", dt)
    elif len(lines) != 1 or not lines[0].startswith("error: "):
        out = Outcome("bad", f"exit 1 with {len(lines)} stderr lines: {err[:300]!r}", dt)
    elif len(lines[0]) > MAX_MESSAGE + 10:
        out = Outcome("bad", f"a {len(lines[0])}-character line: {lines[0][:200]!r}", dt)
    else:
        out = Outcome("refused", lines[0], dt)
    if dt > limit_s:
        out = Outcome("bad", f"took {dt:.1f} s; {out.detail}", dt)
    return out


# --------------------------------------------------------------------------------------------
# Values: built lazily (arrays, images, files) so that pools are cheap to import
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Lazy:
    """A value built when a case runs: ``make()``, or ``make(folder)`` when ``needs_dir``."""

    make: Callable[..., Any]
    needs_dir: bool = False


def resolve(value: Any, folder: Path) -> Any:
    if isinstance(value, Lazy):
        return value.make(folder) if value.needs_dir else value.make()
    return value


def file_with(name: str, content: str | bytes) -> Lazy:
    """A file ``name`` in the case's folder holding ``content`` (text is written as UTF-8)."""

    def make(folder: Path) -> Path:
        p = folder / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(content.encode("utf-8") if isinstance(content, str) else content)
        return p

    return Lazy(make, needs_dir=True)


def in_dir(rel: str) -> Lazy:
    """A path relative to the case's folder (nothing is created)."""
    return Lazy(lambda folder: folder / rel, needs_dir=True)


Pool = tuple[tuple[str, Any], ...]


@functools.cache
def room() -> omniloc.LandmarkMap:
    return omniloc.demo_room()


ROOM_POSE = omniloc.Pose(5.6, 2.1, math.radians(30.0))
SEEN = [10, 3, 0, 6, 8]


@functools.cache
def room_xy5() -> np.ndarray:
    return np.array(room().xy[SEEN])


@functools.cache
def z5() -> np.ndarray:
    """Five exact bearings of the demo room."""
    return np.asarray(omniloc.predict_bearings(room_xy5(), ROOM_POSE))


NUMBERS: Pool = (
    ("nan", float("nan")),
    ("inf", float("inf")),
    ("-inf", float("-inf")),
    ("zero", 0.0),
    ("int zero", 0),
    ("negative", -1.0),
    ("1e300", 1e300),
    ("-1e300", -1e300),
    ("denormal", 5e-324),
    ("1e-300", 1e-300),
    ("2**64", 2**64),
    ("400-digit int", 10**400),
    ("True", True),
    ("None", None),
    ("string", "x"),
    ("numeric string", "1.0"),
    ("list", [1.0]),
    ("complex", 1 + 1j),
    ("float32 nan", np.float32("nan")),
    ("numpy int -5", np.int64(-5)),
    ("object", object()),
    ("0-d array", np.array(0.5)),
    ("small", 0.01),
    ("ten", 10.0),
    ("thirty (degrees?)", 30.0),
    ("pi", math.pi),
    ("bytes", b"1"),
    ("dict", {}),
    ("array of two", np.array([0.1, 0.2])),
)

COUNTS: Pool = (
    ("-1", -1),
    ("0", 0),
    ("1", 1),
    ("2", 2),
    ("3", 3),
    ("2**64", 2**64),
    ("400-digit int", 10**400),
    ("1.5", 1.5),
    ("nan", float("nan")),
    ("inf", float("inf")),
    ("string", "3"),
    ("True", True),
    ("None", None),
    ("numpy int", np.int64(5)),
    ("million", 10**6),
    ("object", object()),
)

PROBABILITIES: Pool = (
    ("0", 0.0),
    ("1", 1.0),
    ("0.5", 0.5),
    ("1 - 1e-16", 1.0 - 1e-16),
    ("1e-300", 1e-300),
    ("-0.1", -0.1),
    ("1.5", 1.5),
    ("nan", float("nan")),
    ("string", "x"),
    ("None", None),
    ("True", True),
    ("complex", 0.5 + 0j),
)


def merged(*pools: Pool) -> Pool:
    """The pools one after the other, a repeated label taking its pool's number ("nan #2")."""
    out: list[tuple[str, Any]] = []
    seen: set[str] = set()
    for k, pool in enumerate(pools, 1):
        for label, value in pool:
            name = label if label not in seen else f"{label} #{k}"
            seen.add(name)
            out.append((name, value))
    return tuple(out)


LANDMARKS: Pool = (
    ("nan row", Lazy(lambda: np.vstack([room_xy5()[:4], [[np.nan, 1.0]]]))),
    ("inf row", Lazy(lambda: np.vstack([room_xy5()[:4], [[np.inf, 1.0]]]))),
    ("two landmarks", Lazy(lambda: room_xy5()[:2])),
    ("shape (5, 3)", np.zeros((5, 3))),
    ("1-D", np.arange(10.0)),
    ("3-D", np.zeros((2, 5, 2))),
    ("scalar", 3.0),
    ("strings", [["a", "b"]] * 5),
    ("complex", Lazy(lambda: room_xy5() + 1j)),
    ("ragged", [[0.0, 1.0], [2.0], [3.0, 4.0], [1.0, 1.0], [5.0, 5.0]]),
    ("empty", np.zeros((0, 2))),
    ("coincident", [[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [3.0, 3.0]]),
    ("collinear", [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [4.0, 0.0]]),
    ("1e200 scale", Lazy(lambda: room_xy5() * 1e200)),
    ("1e15 scale", Lazy(lambda: room_xy5() * 1e15)),
    ("1e-300 scale", Lazy(lambda: room_xy5() * 1e-300)),
    ("1e-12 spacing", Lazy(lambda: room_xy5() * 1e-12)),
    ("bool", np.ones((5, 2), dtype=bool)),
    ("object with None", [[0.0, None]] * 5),
    ("None", None),
    ("string", "map.csv"),
    ("dict", {"x": [1, 2, 3]}),
    ("int8 overflow-prone", np.array([[0, 0], [100, 0], [0, 100], [100, 100], [50, 127]], np.int8)),
    ("float16", Lazy(lambda: room_xy5().astype(np.float16))),
)

BEARINGS: Pool = (
    ("wrong length", Lazy(lambda: z5()[:4])),
    ("nan", Lazy(lambda: np.where(np.arange(5) == 2, np.nan, z5()))),
    ("inf", Lazy(lambda: np.where(np.arange(5) == 2, np.inf, z5()))),
    ("complex", Lazy(lambda: z5() + 0j)),
    ("complex imag", Lazy(lambda: z5() + 1j)),
    ("strings", ["a"] * 5),
    ("2-D", Lazy(lambda: z5()[None])),
    ("empty", []),
    ("all 0.3", [0.3] * 5),
    ("all zero", [0.0] * 5),
    ("all denormal", [5e-324] * 5),
    ("1e300", [1e300, -1e300, 1e299, 3.0, -2.0]),
    ("degrees", Lazy(lambda: np.rad2deg(z5()))),
    ("bool", [True, False, True, False, True]),
    ("None", None),
    ("scalar", 0.5),
    ("object", [object()] * 5),
    ("three equal", [0.1, 0.1, 0.1, 1.0, 2.0]),
    ("two pairs equal", [0.1, 0.1, 2.0, 2.0, -2.0]),
    ("ints", [0, 1, 2, 3, -3]),
    ("float32", Lazy(lambda: z5().astype(np.float32))),
    ("permuted", Lazy(lambda: z5()[::-1].copy())),
    ("all pi", [math.pi] * 5),
    ("-pi and pi", [-math.pi, math.pi, 0.0, 1.0, -1.0]),
)

POSES: Pool = (
    ("nan", (float("nan"), 0.0, 0.0)),
    ("inf", (float("inf"), 0.0, 0.0)),
    ("1e300 away", (1e300, 0.0, 0.0)),
    ("1e9 away", (1e9, 0.0, 0.0)),
    ("on a landmark", Lazy(lambda: (*room_xy5()[0], 0.0))),
    ("2 values", (1.0, 2.0)),
    ("4 values", (1.0, 2.0, 3.0, 4.0)),
    ("string", "pose"),
    ("strings", ("a", "b", "c")),
    ("None", None),
    ("dict", {"x": 1.0, "y": 2.0, "theta": 0.0}),
    ("complex", (1 + 1j, 0.0, 0.0)),
    ("huge heading", (5.0, 5.0, 1e300)),
    ("heading degrees", (5.0, 5.0, 30.0)),
    ("array (1, 3)", np.array([[5.0, 5.0, 0.0]])),
    ("on the circle", Lazy(lambda: _on_circle_pose())),
    ("inside", (5.0, 4.0, 0.3)),
)


#: Poses and covariances for functions that take arrays of them.
POSE_ARRAYS: Pool = (
    *POSES,
    ("(2, 3)", np.zeros((2, 3))),
    ("(3, 3)", np.eye(3)),
    ("(2, 3, 3)", np.zeros((2, 3, 3))),
    ("empty (0, 3)", np.zeros((0, 3))),
    ("ragged", [[1.0, 2.0, 3.0], [1.0]]),
    ("bools", [True, False, True]),
)


def _on_circle_pose() -> tuple[float, float, float]:
    """A pose on the circle through the first three landmarks of room_xy5()."""
    a, b, c = room_xy5()[:3]
    ax, ay, bx, by, cx, cy = *a, *b, *c
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    ux = (
        (ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)
    ) / d
    uy = (
        (ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)
    ) / d
    r = math.hypot(ax - ux, ay - uy)
    t = math.atan2(ay - uy, ax - ux) + 0.7
    return (ux + r * math.cos(t), uy + r * math.sin(t), 0.2)


SIGMAS: Pool = (*NUMBERS, ("1 degree", math.radians(1.0)), ("1e-20", 1e-20), ("4 (> pi)", 4.0))


# --------------------------------------------------------------------------------------------
# Targets: a public function, its valid arguments, and the pools of its fuzzed arguments
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Arg:
    """A fuzzed argument: what an error message may call it, and its pool of values."""

    names: tuple[str, ...]
    pool: Pool


@dataclass(frozen=True)
class Target:
    name: str
    call: Callable[[dict[str, Any]], Any]
    base: Callable[[], dict[str, Any]]
    args: dict[str, Arg]
    check: Callable[[dict[str, Any], Any], None] = field(default=lambda kw, v: check_value(v))
    limit_s: float = HANG_S


def run_target(target: Target, arg: str, value: Any, folder: Path) -> Outcome:
    """Call ``target`` with ``arg`` set to ``value`` (resolved in ``folder``) and judge it."""
    kwargs = {k: resolve(v, folder) for k, v in target.base().items()}
    kwargs[arg] = resolve(value, folder)
    names = target.args[arg].names
    return run_call(
        lambda: target.call(kwargs),
        names,
        check=lambda v: target.check(kwargs, v),
        limit_s=target.limit_s,
    )


def _refine_check(kw: dict[str, Any], v: Any) -> None:
    # Without sigma an all-NaN covariance is the documented "unknown" (three pairs, or an
    # exact fit whose residuals say nothing of the noise).
    check_value(v, nan_covariance_ok=kw.get("sigma") is None)


def _pose_targets() -> list[Target]:
    from omniloc import pose as P

    pairs = {
        "landmarks_xy": Arg(("landmark",), LANDMARKS),
        "bearings": Arg(("bearing",), BEARINGS),
    }
    at_pose = {
        "landmarks_xy": Arg(("landmark",), LANDMARKS),
        "pose": Arg(("pose",), POSES),
        "sigma": Arg(("sigma",), SIGMAS),
    }
    base_pairs = lambda: {"landmarks_xy": Lazy(room_xy5), "bearings": Lazy(z5)}  # noqa: E731
    base_at = lambda: {  # noqa: E731
        "landmarks_xy": Lazy(room_xy5),
        "pose": ROOM_POSE,
        "sigma": math.radians(0.5),
    }
    return [
        Target("estimate_pose", lambda kw: P.estimate_pose(**kw), base_pairs, pairs),
        Target(
            "refine_pose",
            lambda kw: P.refine_pose(**kw),
            lambda: {**base_pairs(), "initial": None, "sigma": None},
            {
                **pairs,
                "initial": Arg(("initial", "pose"), POSES),
                "sigma": Arg(("sigma",), SIGMAS),
            },
            check=_refine_check,
        ),
        Target("crlb", lambda kw: P.crlb(**kw), base_at, at_pose),
        Target("pose_covariance", lambda kw: P.pose_covariance(**kw), base_at, at_pose),
        Target("fisher_information", lambda kw: P.fisher_information(**kw), base_at, at_pose),
        Target(
            "predict_bearings",
            lambda kw: P.predict_bearings(**kw),
            lambda: {"landmarks_xy": Lazy(room_xy5), "pose": ROOM_POSE},
            {"landmarks_xy": at_pose["landmarks_xy"], "pose": at_pose["pose"]},
        ),
        Target(
            "Pose",
            lambda kw: omniloc.Pose(**kw),
            lambda: {"x": 1.0, "y": 2.0, "theta": 0.5},
            {k: Arg((k, "pose"), NUMBERS) for k in ("x", "y", "theta")},
        ),
        Target(
            "poses_from_pairs",
            lambda kw: P.poses_from_pairs(**kw),
            lambda: {
                "landmarks_xy": Lazy(lambda: room_xy5()[None]),
                "bearings": Lazy(lambda: z5()[None]),
            },
            {
                # a landmark array of another shape than the bearings: either may be named
                "landmarks_xy": Arg(("landmark", "bearing"), LANDMARKS),
                "bearings": Arg(("bearing",), BEARINGS),
                "scale": Arg(("scale",), NUMBERS),
            },
            check=lambda kw, v: _finite(v[0][v[1]], "poses where ok"),
        ),
        Target(
            "bearing_jacobian",
            lambda kw: P.bearing_jacobian(**kw),
            lambda: {"landmarks_xy": Lazy(room_xy5), "poses": ROOM_POSE.as_array()},
            {
                "landmarks_xy": Arg(("landmark", "pose"), LANDMARKS),
                "poses": Arg(("pose",), POSES),
            },
        ),
    ]


def _localize_check(kw: dict[str, Any], v: Any) -> None:
    check_value(v)
    if v.solutions and not v.complete and not v.ambiguous:
        raise Insane("an incomplete search gave an unambiguous answer")


#: Values for ``clutter_by_detections`` (a sequence of expected clutter counts).
CLUTTER_TABLES: Pool = (
    ("empty", []),
    ("string", "0.3"),
    ("number", 0.3),
    ("None", None),
    ("dict", {"a": 1}),
    ("nan entry", [0.3, float("nan")]),
    ("inf entry", [float("inf")]),
    ("negative", [-1.0]),
    ("1e300", [1e300, 1e300]),
    ("denormal", [5e-324, 1.0]),
    ("zeros", [0.0, 0.0, 0.0]),
    ("400-digit int", [10**400]),
    ("nested", [[0.1, 0.2]]),
    ("strings", ["a", "b"]),
    ("bools", [True, False]),
    ("complex", [1j]),
    ("2,000 entries", [0.5] * 2000),
    ("numpy", Lazy(lambda: np.array([0.3, 0.9, 1.2]))),
    ("numpy 2-D", Lazy(lambda: np.ones((2, 2)))),
    ("numpy 0-D", Lazy(lambda: np.array(0.3))),
    ("set", {0.3, 0.9}),
    ("range", range(3)),
    ("generator", Lazy(lambda: (x for x in (0.3, 0.9)))),
)


def _clutter_table_check(v: Any) -> None:
    """A clutter table: a non-empty tuple of finite numbers >= 0."""
    if not (isinstance(v, tuple) and v and all(math.isfinite(x) and x >= 0 for x in v)):
        raise Insane(f"not a table of finite clutter rates: {v!r}")


#: A sensor's place on the robot (``SensorModel.mount``, ``localize``'s ``mount``, the sensor
#: fit's): three numbers, metres and radians.
MOUNTS: Pool = (
    ("valid", (0.2, 0.0, 0.1)),
    ("origin", (0.0, 0.0, 0.0)),
    ("two numbers", (0.2, 0.0)),
    ("four numbers", [0.1, 0.0, 0.0, 0.0]),
    ("empty", []),
    ("string", "0.2,0,0"),
    ("number", 0.2),
    ("dict", {"x": 0.2}),
    ("set", {0.2, 0.0, 0.1}),
    ("nan", [float("nan"), 0.0, 0.0]),
    ("inf", [0.0, float("inf"), 0.0]),
    ("1e300", [1e300, 0.0, 0.0]),
    ("degrees", [0.1, 0.0, 90.0]),
    ("400-digit int", [10**400, 0, 0]),
    ("bools", [True, False, True]),
    ("strings", ["a", "b", "c"]),
    ("complex", [1j, 0, 0]),
    ("nested", [[0.1], [0.0], [0.0]]),
    ("numpy", Lazy(lambda: np.array([0.1, 0.0, 0.2]))),
    ("numpy 2-D", Lazy(lambda: np.zeros((1, 3)))),
    ("numpy 0-D", Lazy(lambda: np.array(0.3))),
    ("None", None),
)


def _search_targets() -> list[Target]:
    from omniloc.pose import between, compose, compose_jacobians, inverse
    from omniloc.search import Budget
    from omniloc.sensor import SensorModel, clutter_by_detections

    sensors: Pool = (
        ("default", Lazy(SensorModel)),
        ("wide threshold allowed", Lazy(lambda: SensorModel(threshold=0.5, allow_wide=True))),
        ("wide sigma allowed", Lazy(lambda: SensorModel(sigma=0.3, allow_wide=True))),
        ("string", "sensor"),
        ("dict", {"sigma": 0.01}),
        ("None", None),
    )
    budgets: Pool = (
        ("nodes 1", Lazy(lambda: Budget(max_nodes=1))),
        ("tiny time", Lazy(lambda: Budget(timeout_s=1e-9))),
        ("dict", {"timeout_s": 1}),
        ("number", 5),
    )
    keywords = {
        k: Arg((k.replace("_s", "") if k == "timeout_s" else k,), NUMBERS)
        for k in ("threshold", "sigma", "max_range", "min_range", "fov", "clutter", "timeout_s")
    }
    keywords.update(
        {
            k: Arg((k,), merged(PROBABILITIES, NUMBERS))
            for k in ("confidence", "p_miss", "p_detect", "decisive")
        }
    )
    keywords["clutter_by_detections"] = Arg(("clutter_by_detections",), CLUTTER_TABLES)
    keywords["mount"] = Arg(("mount",), MOUNTS)
    args = {
        "landmarks": Arg(("landmark", "map"), LANDMARKS),
        "bearings": Arg(("bearing",), BEARINGS),
        "sensor": Arg(("sensor",), sensors),
        "budget": Arg(("budget",), budgets),
        "max_spurious": Arg(("max_spurious",), merged(COUNTS, PROBABILITIES)),
        "max_nodes": Arg(("max_nodes",), COUNTS),
        "ordering": Arg(("ordering",), (("string", "yes"), ("None", None), ("int 2", 2))),
        "method": Arg(("method",), (("unknown", "fast"), ("None", None), ("int", 1))),
        "strategy": Arg(("strategy",), (("unknown", "fast"), ("None", None), ("list", []))),
        "exhaustive": Arg(("exhaustive",), (("string", "no"), ("None", None), ("float", 0.0))),
        "check_view": Arg(("check_view",), (("string", "no"), ("None", None), ("int 1", 1))),
        "contested_wildcards": Arg(
            ("contested_wildcards",), (("string", "yes"), ("None", None), ("int 0", 0))
        ),
        **keywords,
    }
    return [
        Target(
            "localize",
            lambda kw: omniloc.localize(**kw),
            lambda: {"landmarks": Lazy(room), "bearings": Lazy(z5)},
            args,
            check=_localize_check,
        ),
        Target(
            "SensorModel",
            lambda kw: SensorModel(**kw),
            dict,
            {
                k: Arg((k,), NUMBERS)
                for k in ("sigma", "threshold", "fov", "max_range", "min_range", "clutter")
            }
            | {k: Arg((k,), PROBABILITIES) for k in ("gate_confidence", "p_detect")}
            | {"allow_wide": Arg(("allow_wide",), (("string", "yes"), ("None", None)))}
            | {"clutter_by_detections": Arg(("clutter_by_detections",), CLUTTER_TABLES)}
            | {"mount": Arg(("mount",), MOUNTS)},
            check=lambda kw, v: None,
        ),
        Target(
            "SensorModel.robot_poses",
            lambda kw: SensorModel(mount=(0.2, 0.0, 0.1)).robot_poses(**kw),
            lambda: {"sensor_poses": [1.0, 2.0, 0.3], "covariances": np.eye(3) * 0.01},
            {
                "sensor_poses": Arg(("sensor_poses",), POSE_ARRAYS),
                "covariances": Arg(("covariances",), POSE_ARRAYS),
            },
            check=lambda kw, v: None,
        ),
        Target(
            "SensorModel.sensor_poses",
            lambda kw: SensorModel(mount=(0.2, 0.0, 0.1)).sensor_poses(**kw),
            lambda: {"robot_poses": [1.0, 2.0, 0.3]},
            {"robot_poses": Arg(("robot_poses",), POSE_ARRAYS)},
            check=lambda kw, v: None,
        ),
        *(
            Target(
                f"pose.{name}",
                lambda kw, fn=fn: fn(**kw),
                lambda a=a, b=b: {a: [1.0, 2.0, 0.3], b: [0.5, 0.1, -0.2]},
                {a: Arg((a,), POSE_ARRAYS), b: Arg((b,), POSE_ARRAYS)},
                check=lambda kw, v: None,
            )
            for name, fn, a, b in (
                ("compose", compose, "pose", "delta"),
                ("compose_jacobians", compose_jacobians, "pose", "delta"),
                ("between", between, "a", "b"),
            )
        ),
        Target(
            "pose.inverse",
            lambda kw: inverse(**kw),
            lambda: {"delta": [0.5, 0.1, -0.2]},
            {"delta": Arg(("delta",), POSE_ARRAYS)},
            check=lambda kw, v: None,
        ),
        Target(
            "clutter_by_detections",
            lambda kw: clutter_by_detections(**kw),
            lambda: {"detected": [1, 2, 3] * 20, "spurious": [0, 1, 1] * 20},
            {
                "detected": Arg(("detected", "count"), merged(BEARINGS, CLUTTER_TABLES)),
                "spurious": Arg(("spurious", "count"), merged(BEARINGS, CLUTTER_TABLES)),
            },
            check=lambda kw, v: _clutter_table_check(v),
        ),
        Target(
            "Budget",
            lambda kw: Budget(**kw),
            dict,
            {"max_nodes": Arg(("max_nodes",), COUNTS), "timeout_s": Arg(("timeout",), NUMBERS)},
            check=lambda kw, v: None,
        ),
    ]


TEXT_FILES: Pool = (
    ("missing", in_dir("nothing/here.csv")),
    ("directory", Lazy(lambda folder: folder, needs_dir=True)),
    ("empty", file_with("empty.csv", "")),
    ("binary", file_with("binary.csv", bytes(range(256)) * 4)),
    ("latin-1", file_with("latin1.csv", "bearing\n0.1\n\xe9\xe8 0.2\n".encode("latin-1"))),
    ("utf-16", file_with("utf16.csv", "bearing\n0.1\n0.2\n0.3\n".encode("utf-16"))),
    ("NUL in the name", "bad\x00name.csv"),
    ("int path", 5),
    ("None path", None),
    ("bytes path", b"/nonexistent/bytes.csv"),
    ("1e999", file_with("big.txt", "1e999\n0.1\n0.2\n")),
    ("400-digit json", file_with("big.json", "[1" + "0" * 400 + ", 0, 1]")),
    ("nan text", file_with("nan.txt", "nan\n0.1\n0.2\n")),
    ("header only", file_with("header.csv", "bearing\n")),
    ("wrong columns", file_with("cols.csv", "a,b\n1,2\n")),
    ("unbalanced quote", file_with("quote.csv", 'bearing\n"0.1\n')),
    ("long line", file_with("long.txt", "0.1," * 100_000)),
    ("deep json", file_with("deep.json", "[" * 100_000 + "]" * 100_000)),
    ("json null", file_with("null.json", "null")),
    ("json object", file_with("obj.json", '{"x": 1}')),
    ("json strings", file_with("strs.json", '["a", "b", "c"]')),
    ("json bools", file_with("bools.json", "[true, false, true]")),
    ("json nested", file_with("nested.json", "[[1, 2], [3, 4], [5, 6]]")),
    ("json NaN", file_with("nan.json", "[NaN, 1, 2]")),
    ("json 1e400", file_with("e400.json", "[1e400, 1, 2]")),
    ("crlf", file_with("crlf.csv", "bearing\r\n0.1\r\n0.2\r\n0.3\r\n")),
    ("bom", file_with("bom.csv", "\ufeffbearing\n0.1\n0.2\n0.3\n")),
    ("many columns", file_with("wide.csv", ",".join(f"c{i}" for i in range(5000)) + "\n")),
    ("png bytes", file_with("img.csv", b"\x89PNG\r\n\x1a\n" + b"\0" * 64)),
)

MAP_FILES: Pool = (
    *TEXT_FILES,
    ("no extension", file_with("map", "id,x,y\n1,0,0\n2,1,0\n3,0,1\n")),
    (
        "400-digit coordinate",
        file_with("m.json", '{"xy": [[1' + "0" * 400 + ", 0], [1, 0], [0, 1]]}"),
    ),
    ("coordinate 1e300", file_with("m.csv", "id,x,y\n1,1e300,0\n2,1,0\n3,0,1\n")),
    ("400-digit id", file_with("id.csv", "id,x,y\n1" + "0" * 400 + ",0,0\n2,1,0\n3,0,1\n")),
    ("duplicate ids", file_with("dup.csv", "id,x,y\n1,0,0\n1,1,0\n3,0,1\n")),
    ("two landmarks", file_with("two.csv", "id,x,y\n1,0,0\n2,1,0\n")),
    ("json id float", file_with("f.json", '[{"id": 1.5, "x": 0, "y": 0}]')),
    ("json ids null", file_with("n.json", '{"xy": [[0, 0], [1, 0], [0, 1]], "ids": [null, 2, 3]}')),
    ("json xy triples", file_with("t.json", '{"xy": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}')),
    ("json landmarks dict", file_with("d.json", '{"landmarks": {"a": 1}}')),
    ("csv missing y", file_with("noy.csv", "id,x\n1,0\n2,1\n3,0\n")),
)


def _io_targets() -> list[Target]:
    from omniloc.io import check_bearings, load_bearings, save_bearings

    flags: Pool = (("string", "yes"), ("None", None), ("int 2", 2), ("nan", float("nan")))
    return [
        Target(
            "load_bearings",
            lambda kw: load_bearings(**kw),
            lambda: {"path": file_with("ok.csv", "bearing\n0.1\n0.2\n0.3\n"), "degrees": False},
            {
                "path": Arg(("file", ".csv", ".json", ".txt", "path"), TEXT_FILES),
                "degrees": Arg(("degrees",), flags),
            },
        ),
        Target(
            "save_bearings",
            lambda kw: save_bearings(**kw),
            lambda: {"path": in_dir("out.csv"), "bearings": Lazy(z5), "degrees": False},
            {
                "path": Arg(
                    ("path", "file", "write", "folder", "directory", ".csv", ".json"),
                    (
                        ("into a missing folder", in_dir("no/such/dir/out.csv")),
                        ("a directory", Lazy(lambda f: f, needs_dir=True)),
                        ("under a file", Lazy(lambda f: _a_file(f) / "out.csv", needs_dir=True)),
                        ("NUL", "bad\x00.csv"),
                        ("int", 7),
                        ("None", None),
                    ),
                ),
                "bearings": Arg(("bearing",), BEARINGS),
                "degrees": Arg(("degrees",), flags),
            },
        ),
        Target(
            "check_bearings",
            lambda kw: check_bearings(**kw),
            lambda: {"bearings": Lazy(z5)},
            {
                "bearings": Arg(("bearing",), BEARINGS),
                "n_landmarks": Arg(("n_landmarks", "landmark"), COUNTS),
                "min_count": Arg(("min_count", "at least"), COUNTS),
                "name": Arg(("name",), (("int", 5), ("None", None), ("long", "b" * 1000))),
            },
        ),
        Target(
            "LandmarkMap",
            lambda kw: omniloc.LandmarkMap(**kw),
            lambda: {"xy": Lazy(room_xy5)},
            {
                "xy": Arg(("landmark",), LANDMARKS),
                "ids": Arg(
                    ("ids", "id"),
                    (
                        ("int", 5),
                        ("string", "abcde"),
                        ("too few", [1, 2]),
                        ("floats", [1.5, 2.5, 3.5, 4.5, 5.5]),
                        ("None items", [None] * 5),
                        ("duplicates", [1, 1, 2, 3, 4]),
                        ("dict", {1: 2}),
                        ("generator", Lazy(lambda: (i for i in range(5)))),
                        ("bools", [True, False, True, False, True]),
                        ("empty strings", ["", "a", "b", "c", "d"]),
                        ("2-D array", np.arange(10).reshape(5, 2)),
                        ("object", object()),
                    ),
                ),
                "names": Arg(
                    ("names", "name"),
                    (
                        ("int", 5),
                        ("string", "abcde"),
                        ("too few", ["a"]),
                        ("ints", [1, 2, 3, 4, 5]),
                    ),
                ),
            },
        ),
        Target(
            "LandmarkMap.load",
            lambda kw: omniloc.LandmarkMap.load(**kw),
            lambda: {"path": file_with("map.csv", "id,x,y\n1,0,0\n2,1,0\n3,0,1\n")},
            {
                "path": Arg(
                    ("map", ".csv", ".json", "file", "path", "landmark", "extension"), MAP_FILES
                )
            },
        ),
    ]


def _a_file(folder: Path) -> Path:
    p = folder / "a-file"
    p.write_text("not a folder\n")
    return p


# --------------------------------------------------------------------------------------------
# Vision
# --------------------------------------------------------------------------------------------


@functools.cache
def demo_image() -> np.ndarray:
    from omniloc.vision import DEMO_POSE, demo_scene, render_omni_image

    img = render_omni_image(demo_scene(), DEMO_POSE, rng=0)
    img.setflags(write=False)
    return img


def _wide(h: int, w: int) -> np.ndarray:
    """A thin image with a bright ellipse: a mirror rim OpenCV cannot remap (a side > 32767)."""
    img = np.full((h, w), 10, np.uint8)
    yy, xx = np.ogrid[:h, :w]
    inside = ((xx - w / 2) / (w / 2.2)) ** 2 + ((yy - h / 2) / (h / 2.2)) ** 2 <= 1
    img[inside] = 200
    return img


IMAGES: Pool = (
    ("15x15", np.zeros((15, 15), np.uint8)),
    ("16x16 uniform", np.zeros((16, 16), np.uint8)),
    ("1-D", np.zeros(1000, np.uint8)),
    ("4-D", np.zeros((2, 32, 32, 3), np.uint8)),
    ("2 channels", np.zeros((64, 64, 2), np.uint8)),
    ("5 channels", np.zeros((64, 64, 5), np.uint8)),
    ("bool", Lazy(lambda: demo_image() > 100)),
    ("complex", Lazy(lambda: demo_image() + 0j)),
    ("object", np.full((32, 32), None, dtype=object)),
    ("strings", np.full((32, 32), "a")),
    ("float nan", Lazy(lambda: np.where(demo_image() > 250, np.nan, demo_image() / 255.0))),
    ("float inf", Lazy(lambda: np.where(demo_image() > 250, np.inf, 1.0))),
    ("float [0, 1]", Lazy(lambda: demo_image() / 255.0)),
    ("float 1e30", Lazy(lambda: demo_image() * 1e30)),
    ("float -1e30", Lazy(lambda: demo_image() * -1e30)),
    ("uint16", Lazy(lambda: demo_image().astype(np.uint16) * 257)),
    ("int64 negative", Lazy(lambda: -demo_image().astype(np.int64))),
    ("int8", Lazy(lambda: (demo_image() // 2).astype(np.int8))),
    ("float16", Lazy(lambda: demo_image().astype(np.float16))),
    ("wide 20x40000", Lazy(lambda: _wide(20, 40000))),
    ("tall 40000x20", Lazy(lambda: _wide(40000, 20))),
    ("empty", np.zeros((0, 0), np.uint8)),
    ("list of lists", [[0, 1] * 10] * 20),
    ("None", None),
    ("string", "image.png"),
    ("noise", Lazy(lambda: np.random.default_rng(0).integers(0, 256, (120, 160), dtype=np.uint8))),
    ("checkerboard", Lazy(lambda: (np.indices((64, 64)).sum(axis=0) % 2 * 255).astype(np.uint8))),
    (
        "rgba",
        Lazy(lambda: np.dstack([demo_image()] * 3 + [np.full(demo_image().shape, 255, np.uint8)])),
    ),
    ("non-contiguous", Lazy(lambda: np.asfortranarray(demo_image())[:, ::2])),
)

IMAGE_FILES: Pool = (
    *TEXT_FILES,
    (
        "corrupt png",
        file_with(
            "corrupt.png",
            b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x10\x00\x00\x00\x10\x08\x00\x00\x00\x00garbage"
            * 3,
        ),
    ),
    ("truncated png", Lazy(lambda f: _truncated_png(f), needs_dir=True)),
    ("png of a text", file_with("text.png", "hello\n")),
    ("zero bytes png", file_with("zero.png", b"")),
    ("jpeg header only", file_with("x.jpg", b"\xff\xd8\xff\xe0" + b"\x00" * 20)),
)


def _truncated_png(folder: Path) -> Path:
    import cv2

    ok, buf = cv2.imencode(".png", demo_image())
    assert ok
    p = folder / "truncated.png"
    p.write_bytes(buf.tobytes()[: len(buf) // 2])
    return p


ANGLES: Pool = (*NUMBERS, ("90 (degrees?)", 90.0), ("7", 7.0), ("-7", -7.0))


def _vision_targets() -> list[Target]:
    from omniloc import vision as V

    cal = Lazy(lambda: V.MirrorCalibration((321.7, 238.4), 1.0, 215.0))
    calibrations: Pool = (
        ("string", "cal"),
        ("None", None),
        ("dict", {"center": (1, 2)}),
        ("off-image", Lazy(lambda: V.MirrorCalibration((5000.0, 5000.0), 1.0, 215.0))),
        ("huge radius", Lazy(lambda: V.MirrorCalibration((321.7, 238.4), 1.0, 1e12))),
        ("tiny radius", Lazy(lambda: V.MirrorCalibration((321.7, 238.4), 1.0, 1e-9))),
        ("tuple", ((321.7, 238.4), 1.0, 215.0)),
    )
    centers: Pool = (
        *NUMBERS,
        ("outside", (5000.0, 5000.0)),
        ("nan pair", (float("nan"), 1.0)),
        ("3 values", (1.0, 2.0, 3.0)),
        ("strings", ("a", "b")),
        ("edge", (0.0, 0.0)),
    )
    ranges: Pool = (
        *NUMBERS,
        ("reversed", (0.9, 0.4)),
        ("equal", (0.5, 0.5)),
        ("above 1.5", (0.4, 3.0)),
        ("negative inner", (-0.5, 0.9)),
        ("three", (0.1, 0.2, 0.3)),
        ("nan inner", (float("nan"), 0.9)),
        ("tiny", (0.0, 1e-12)),
    )
    extract_args = {
        "image": Arg(("image",), IMAGES),
        # a valid but wrong centre or aspect may leave no rim to find: "rim" names that
        "center": Arg(("center", "rim"), centers),
        "aspect": Arg(("aspect", "rim"), NUMBERS),
        "forward": Arg(("forward",), ANGLES),
        "mirrored": Arg(("mirrored",), (("string", "yes"), ("None", None), ("nan", float("nan")))),
        "calibration": Arg(("calibration", "center", "radius"), calibrations),
        "radial_range": Arg(("radial_range",), ranges),
        **{
            k: Arg((k,), NUMBERS)
            for k in (
                "min_contrast",
                "min_agreement",
                "max_pole_width",
                "min_separation",
                "smoothing",
                "min_segment_width",
            )
        },
    }
    cameras: Pool = (
        ("string", "camera"),
        ("None", None),
        ("dict", {"radius": 5}),
    )
    return [
        Target(
            "extract_bearings",
            lambda kw: V.extract_bearings(**kw),
            lambda: {"image": Lazy(demo_image)},
            extract_args,
        ),
        Target(
            "unwrap_panorama",
            lambda kw: V.unwrap_panorama(**kw),
            lambda: {"image": Lazy(demo_image), "calibration": cal},
            {
                "image": Arg(("image",), IMAGES),
                "calibration": Arg(("calibration",), calibrations),
                "radial_range": Arg(("radial_range",), ranges),
                "n_rows": Arg(("n_rows", "panorama"), COUNTS),
                "n_cols": Arg(("n_cols", "panorama"), COUNTS),
            },
            check=lambda kw, v: None,  # NaN marks samples off the image (documented)
        ),
        Target(
            "calibrate_mirror",
            lambda kw: V.calibrate_mirror(**kw),
            lambda: {"image": Lazy(demo_image)},
            {
                "image": Arg(("image", "rim", "mirror"), IMAGES),
                "center": Arg(("center", "rim"), centers),
                "aspect": Arg(("aspect", "rim"), NUMBERS),
                "radius": Arg(("radius",), NUMBERS),
                "n_rays": Arg(("n_rays",), COUNTS),
            },
        ),
        Target(
            "load_image",
            lambda kw: V.load_image(**kw),
            lambda: {},
            {"path": Arg(("image", "file", "path"), IMAGE_FILES)},
            check=lambda kw, v: None,
        ),
        Target(
            "MirrorCalibration",
            lambda kw: V.MirrorCalibration(**kw),
            lambda: {"center": (321.7, 238.4), "aspect": 1.0, "radius": 215.0},
            {
                "center": Arg(("center",), centers),
                "aspect": Arg(("aspect",), NUMBERS),
                "radius": Arg(("radius",), NUMBERS),
            },
        ),
        Target(
            "render_omni_image",
            lambda kw: V.render_omni_image(**kw),
            lambda: {"scene": Lazy(V.demo_scene), "pose": V.DEMO_POSE, "rng": 0},
            {
                "scene": Arg(("scene",), (("string", "room"), ("None", None), ("map", Lazy(room)))),
                "pose": Arg(("pose",), POSES),
                "camera": Arg(("camera",), cameras),
                "rng": Arg(("rng", "seed"), (("string", "x"), ("negative", -1), ("float", 0.5))),
            },
            check=lambda kw, v: None,
        ),
        Target(
            "OmniCamera",
            lambda kw: V.OmniCamera(**kw),
            dict,
            {
                "image_size": Arg(
                    ("image_size",),
                    (
                        *NUMBERS,
                        ("huge", (10**9, 10**9)),
                        ("strings", ("a", "b")),
                        ("floats", (64.5, 64.5)),
                    ),
                ),
                "center": Arg(("center",), centers),
                **{
                    k: Arg((k,), NUMBERS)
                    for k in (
                        "aspect",
                        "radius",
                        "inner_radius",
                        "forward",
                        "blur_sigma",
                        "noise_sigma",
                        "texture_sigma",
                        "background_level",
                        "camera_level",
                    )
                },
                "elevation_range": Arg(("elevation_range",), ranges),
                "lighting_gradient": Arg(("lighting_gradient",), ranges),
            },
            check=lambda kw, v: None,
        ),
        Target(
            "true_features",
            lambda kw: V.true_features(**kw),
            lambda: {"scene": Lazy(V.demo_scene), "pose": V.DEMO_POSE},
            {"pose": Arg(("pose",), POSES), "margin": Arg(("margin",), NUMBERS)},
            check=lambda kw, v: check_bearings_out(v.bearings),
        ),
        Target(
            "Pole",
            lambda kw: V.Pole(**kw),
            lambda: {"x": 1.0, "y": 1.0},
            {
                "x": Arg(("pole x",), NUMBERS),
                "radius": Arg(("radius",), NUMBERS),
                "intensity": Arg(
                    ("intensity",), (*NUMBERS, ("rgb bad", (1, 2)), ("rgb 300", (300, 0, 0)))
                ),
            },
            check=lambda kw, v: None,
        ),
    ]


# --------------------------------------------------------------------------------------------
# Simulation, recordings over time, real datasets, figures, evaluation
# --------------------------------------------------------------------------------------------


def _simulate_targets() -> list[Target]:
    from omniloc import simulate as S

    rngs: Pool = (("string", "seed"), ("negative", -1), ("float", 0.5), ("list", [1, 2]))
    return [
        Target(
            "random_map",
            lambda kw: S.random_map(**kw),
            lambda: {"n": 12, "rng": 0},
            {
                "n": Arg(("n",), COUNTS),
                "size": Arg(
                    ("size", "do not fit"),
                    (*NUMBERS, ("pair", (1e300, 1.0)), ("triple", (1, 2, 3))),
                ),
                "density": Arg(("density", "do not fit"), NUMBERS),
                "min_separation": Arg(("min_separation", "do not fit"), NUMBERS),
                "rng": Arg(("rng", "seed"), rngs),
            },
            check=lambda kw, v: _finite(v.xy, "map"),
        ),
        Target(
            "grid_map",
            lambda kw: S.grid_map(**kw),
            lambda: {"n": 12, "rng": 0},
            {
                "n": Arg(("n",), COUNTS),
                "density": Arg(("density",), NUMBERS),
                "min_separation": Arg(("min_separation",), NUMBERS),
            },
            check=lambda kw, v: _finite(v.xy, "map"),
        ),
        Target(
            "symmetric_map",
            lambda kw: S.symmetric_map(**kw),
            lambda: {"kind": "square"},
            {
                "kind": Arg(("kind", "symmetric"), (("unknown", "circle"), ("None", None))),
                "size": Arg(("size",), NUMBERS),
            },
            check=lambda kw, v: _finite(v.xy, "map"),
        ),
        Target(
            "random_pose",
            lambda kw: S.random_pose(**kw),
            lambda: {"landmarks": Lazy(room), "rng": 0},
            {
                "landmarks": Arg(("landmark", "map"), LANDMARKS),
                "clearance": Arg(("clearance", "from every landmark"), NUMBERS),
            },
        ),
        Target(
            "observe",
            lambda kw: S.observe(**kw),
            lambda: {"landmarks": Lazy(room), "pose": ROOM_POSE, "rng": 0},
            {
                "landmarks": Arg(("landmark", "map"), LANDMARKS),
                "pose": Arg(("pose",), POSES),
                "visible": Arg(
                    ("visible",),
                    (
                        ("out of range", [99]),
                        ("strings", ["a"]),
                        ("2-D", [[1, 2]]),
                        ("floats", [1.5]),
                        ("negative", [-1]),
                    ),
                ),
                "n_obs": Arg(("n_obs",), COUNTS),
                "sigma": Arg(("sigma",), NUMBERS),
                "n_spurious": Arg(("n_spurious",), COUNTS),
                "p_miss": Arg(("p_miss",), PROBABILITIES),
                "max_range": Arg(("max_range",), NUMBERS),
                "min_range": Arg(("min_range",), NUMBERS),
                "fov": Arg(("fov",), NUMBERS),
            },
            check=lambda kw, v: check_bearings_out(v.bearings),
        ),
        Target(
            "paper_experiment",
            lambda kw: S.paper_experiment(**kw),
            lambda: {"n_obs": (4,)},
            {
                "n_obs": Arg(
                    ("n_obs", "demo sees", "observations"),
                    (*COUNTS, ("too many", (99,)), ("empty", ())),
                ),
                "threshold": Arg(("threshold",), NUMBERS),
                "sigma": Arg(("sigma",), NUMBERS),
            },
            check=lambda kw, v: None,
        ),
    ]


ODOMETRY_FILES: Pool = (
    *TEXT_FILES,
    ("decreasing t", file_with("odo.csv", "t,v,w\n1,0,0\n0,0,0\n")),
    ("missing w", file_with("odo.csv", "t,v\n1,0\n")),
    ("t 1e999", file_with("odo.csv", "t,v,w\n1e999,0,0\n")),
    ("no rows", file_with("odo.csv", "t,v,w\n")),
    ("poses: equal times", file_with("odo.csv", "t,x,y,theta\n0,0,0,0\n0,1,0,0\n")),
    ("poses: theta nan", file_with("odo.csv", "t,x,y,theta\n0,0,0,nan\n")),
    ("poses: no rows", file_with("odo.csv", "t,x,y,theta\n")),
    ("poses and velocities", file_with("odo.csv", "t,x,y,theta,v,w\n0,0,0,0,0,0\n")),
    ("vy nan", file_with("odo.csv", "t,v,w,vy\n0,0,0,nan\n")),
    ("vy empty", file_with("odo.csv", "t,v,w,vy\n0,0,0,\n")),
    ("tum: 7 numbers", file_with("odo.tum", "0 0 0 0 0 0 1\n")),
    ("tum: then 9", file_with("odo.tum", "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1 5\n")),
    ("tum: zero quaternion", file_with("odo.tum", "0 0 0 0 0 0 0 0\n")),
    ("tum: upside down", file_with("odo.tum", "0 0 0 0 1 0 0 0\n")),
    ("tum: inf", file_with("odo.tum", "0 0 0 0 0 0 0 1\n1 inf 0 0 0 0 0 1\n")),
    ("tum: decreasing", file_with("odo.tum", "1 0 0 0 0 0 0 1\n0 0 0 0 0 0 0 1\n")),
    ("tum: a half turn", file_with("odo.tum", "0 0 0 0 0 0 0 1\n0 0 0 0 0 0 1 0\n")),
)
GROUNDTRUTH_FILES: Pool = (
    *TEXT_FILES,
    ("one row", file_with("gt.csv", "t,x,y,theta\n0,0,0,0\n")),
    ("equal times", file_with("gt.csv", "t,x,y,theta\n0,0,0,0\n0,1,1,1\n")),
    ("gap nan", file_with("gt.csv", "t,x,y,theta,gap\n0,0,0,0,nan\n1,1,1,1,0\n")),
    ("tum: equal times", file_with("gt.tum", "0 0 0 0 0 0 0 1\n0 1 0 0 0 0 0 1\n")),
    ("tum: leaning", file_with("gt.tum", "0 0 0 0 0.5 0 0 0.866\n")),
    ("tum: nan", file_with("gt.tum", "0 0 0 0 0 0 0 1\n1 nan 0 0 0 0 0 1\n")),
    ("tum: then a csv line", file_with("gt.tum", "0 0 0 0 0 0 0 1\n1,0,0,0\n")),
)
FRAME_FILES: Pool = (
    *TEXT_FILES,
    ("no t", file_with("fr.csv", "bearing\n0.1\n")),
    ("mrclam bad entry", file_with("fr.csv", "t,landmarks,robot_detections\n0,6:abc:1,\n")),
    ("mrclam no colon", file_with("fr.csv", "t,landmarks,robot_detections\n0,6,\n")),
    ("rad and degrees", file_with("fr.csv", "t,bearing_rad\n0,0.1\n")),
)


def _roh_folder(folder: Path, measurements: str) -> Path:
    d = folder / "roh"
    d.mkdir(exist_ok=True)
    (d / "landmarks.csv").write_text("id,x,y\n1,0,0\n2,6,0\n3,6,6\n4,0,6\n")
    (d / "measurements.csv").write_text(measurements)
    return d


ROH_HEADER = "gt_x,gt_y,gt_theta,bearing_lm1,bearing_lm2,bearing_lm3,bearing_lm4\n"
ROH_FOLDERS: Pool = (
    *TEXT_FILES,
    ("no samples", Lazy(lambda f: _roh_folder(f, ROH_HEADER), needs_dir=True)),
    ("bad number", Lazy(lambda f: _roh_folder(f, ROH_HEADER + "1,1,0,a,1,2,3\n"), needs_dir=True)),
    ("short row", Lazy(lambda f: _roh_folder(f, ROH_HEADER + "1,1,0\n"), needs_dir=True)),
    ("latin-1 row", Lazy(lambda f: _roh_folder(f, ROH_HEADER + "1,1,0,é,1,2,3\n"), needs_dir=True)),
    ("binary measurements", Lazy(lambda f: _roh_bytes(f), needs_dir=True)),
    (
        "huge value",
        Lazy(lambda f: _roh_folder(f, ROH_HEADER + "1,1,0,1e999,1,2,3\n"), needs_dir=True),
    ),
)


def _roh_bytes(folder: Path) -> Path:
    d = _roh_folder(folder, ROH_HEADER)
    (d / "measurements.csv").write_bytes(ROH_HEADER.encode() + bytes(range(256)))
    return d


def _roh_ok(folder: Path) -> Path:
    rows = "".join(
        f"{x},{y},0.1,{b[0]},{b[1]},{b[2]},{b[3]}\n"
        for x, y in ((2.0, 2.0), (3.0, 1.5))
        for b in [
            omniloc.predict_bearings([[0, 0], [6, 0], [6, 6], [0, 6]], omniloc.Pose(x, y, 0.1))
        ]
    )
    return _roh_folder(folder, ROH_HEADER + rows)


def _mrclam_ok(folder: Path) -> Path:
    """An MRCLAM folder: the Roh landmarks and one robot's frames seeing all four."""
    d = _roh_ok(folder)
    rows = "".join(
        f"{x},{y},0.1," + ";".join(f"{i + 1}:{float(v)!r}:3.0" for i, v in enumerate(b)) + ",\n"
        for x, y in ((2.0, 2.0), (3.0, 1.5))
        for b in [omniloc.predict_bearings([[0, 0], [6, 0], [6, 6], [0, 6]], (x, y, 0.1))]
    )
    (d / "robot1_frames.csv").write_text("gt_x,gt_y,gt_theta,landmarks,robot_detections\n" + rows)
    return d


def _track_targets() -> list[Target]:
    from omniloc import datasets as D
    from omniloc.track import GroundTruth, Odometry, load_frames, load_groundtruth, load_odometry

    arrays: Pool = (
        ("nan", [0.0, float("nan")]),
        ("strings", ["a", "b"]),
        ("2-D", [[1.0, 2.0]]),
        ("None", None),
        ("empty", []),
        ("decreasing", [1.0, 0.0]),
        ("complex", [1j, 2j]),
    )
    return [
        Target(
            "load_odometry",
            lambda kw: load_odometry(**kw),
            dict,
            {"path": Arg(("odometry", "file", ".csv", "path", "line", "column"), ODOMETRY_FILES)},
            check=lambda kw, v: None,
        ),
        Target(
            "load_groundtruth",
            lambda kw: load_groundtruth(**kw),
            dict,
            {
                "path": Arg(
                    ("ground truth", "file", ".csv", "path", "line", "column"), GROUNDTRUTH_FILES
                )
            },
            check=lambda kw, v: None,
        ),
        Target(
            "load_frames",
            lambda kw: load_frames(**kw),
            lambda: {"path": file_with("frames.csv", "t,bearing\n0,0.1\n0,0.2\n1,0.3\n")},
            {
                "path": Arg(("frames", "file", ".csv", "path", "line"), FRAME_FILES),
                "degrees": Arg(("degrees",), (("string", "yes"), ("None", None))),
                "landmark_ids": Arg(("landmark_ids",), (("list", [1, 2]), ("string", "x"))),
            },
            check=lambda kw, v: [check_bearings_out(f.bearings) for f in v],
        ),
        Target(
            "Odometry",
            lambda kw: Odometry(**kw),
            lambda: {"t": [0.0, 1.0], "v": [0.0, 0.1], "w": [0.0, 0.0]},
            {k: Arg((f"odometry {k}", "odometry"), arrays) for k in ("t", "v", "w", "vy")},
            check=lambda kw, v: None,
        ),
        Target(
            "Odometry.from_poses",
            lambda kw: Odometry.from_poses(**kw),
            lambda: {"t": [0.0, 1.0], "x": [0.0, 0.1], "y": [0.0, 0.0], "theta": [0.0, 0.1]},
            {k: Arg(("odometry poses", "odometry"), arrays) for k in ("t", "x", "y", "theta")},
            check=lambda kw, v: [_finite(a, "odometry") for a in (v.t, v.v, v.w)],
        ),
        Target(
            "GroundTruth",
            lambda kw: GroundTruth(**kw),
            lambda: {"t": [0.0, 1.0], "x": [0.0, 0.1], "y": [0.0, 0.0], "theta": [0.0, 0.0]},
            {k: Arg(("ground truth",), arrays) for k in ("t", "x", "theta", "gap")},
            check=lambda kw, v: None,
        ),
        Target(
            "load_roh",
            lambda kw: D.load_roh(**kw),
            lambda: {"path": Lazy(_roh_ok, needs_dir=True)},
            {
                "path": Arg(
                    ("roh", "file", "folder", ".csv", "path", "measurements", "landmarks"),
                    ROH_FOLDERS,
                )
            },
            check=lambda kw, v: _finite(v.bearings, "bearings"),
        ),
        Target(
            "load_mrclam",
            lambda kw: D.load_mrclam(**kw),
            lambda: {"path": Lazy(_mrclam_ok, needs_dir=True), "robots": (1,)},
            {
                "path": Arg(
                    ("mrclam", "file", "folder", ".csv", "path", "landmarks", "robot"), TEXT_FILES
                ),
                "robots": Arg(("robot",), (("strings", ("a",)), ("None", None), ("int", 3))),
                "min_landmarks": Arg(("min_landmarks",), COUNTS),
            },
            check=lambda kw, v: None,
        ),
    ]


def _settings_targets() -> list[Target]:
    """Settings by name, their file, and the motion model fitted to a recording."""
    from omniloc.track import (
        Frame,
        GroundTruth,
        MotionModel,
        Odometry,
        check_motion,
        check_sensor,
        estimate_frame_sensor,
        estimate_motion,
        estimate_mount,
        load_settings,
        preset,
    )
    from omniloc.track import with_settings as ws
    from omniloc.track.calibrate import bias_by_bearing, fit_core_and_tail

    fields = ("setting", "settings", "must", "sigma", "min_age_s", "region", "v_scale", "fov")
    t = np.arange(0.0, 60.0, 0.1)
    odo = Odometry(t, np.full(t.size, 0.2), np.full(t.size, 0.1))
    th = 0.1 * t
    good = GroundTruth(t, 2.0 * np.sin(th), 2.0 - 2.0 * np.cos(th), th)
    z = omniloc.predict_bearings(room().xy, ROOM_POSE)
    frames = [Frame(0.1 * k, z) for k in range(10)]
    p = ROOM_POSE
    still = GroundTruth([0.0, 2.0], [p.x, p.x], [p.y, p.y], [p.theta, p.theta])
    # A second run of the robot, later on the same clock; a short and a far-away track.
    odo_later = Odometry(t + 100.0, odo.v, odo.w)
    good_later = GroundTruth(t + 100.0, good.x, good.y, good.theta)
    short = GroundTruth(t[:20], t[:20], t[:20], t[:20])
    far = GroundTruth(t + 1e6, t, t, t)

    def view_arg(k: str) -> Arg:
        return Arg((k,), (("nan", float("nan")), ("zero", 0.0), ("huge", 1e300), ("bool", True)))

    def sensor_fit_args(also: tuple[str, ...] = ()) -> dict[str, Arg]:
        """The arguments the two sensor fits share: the recording and the view."""
        return {
            "frames": Arg(
                ("frames", "too few", *also),
                (("None", None), ("a string", "frames.csv"), ("empty", []), ("ints", [1, 2])),
            ),
            "truth": Arg(
                ("truth", "GroundTruth", "too few", "recording", *also),
                (("None", None), ("list", [1]), ("two tracks", [still, still]), ("no tracks", [])),
            ),
            "landmarks": Arg(("landmark", "map", "positions"), (("nan", [[float("nan"), 0]]),)),
            **{k: view_arg(k) for k in ("fov", "max_range", "gate", "max_gap_s")},
        }

    return [
        Target(
            "with_settings",
            lambda kw: ws(*preset("generic"), kw["settings"]),
            lambda: {"settings": {}},
            {
                "settings": Arg(
                    fields,
                    (
                        ("a list", [("min_age_s", 1.0)]),
                        ("unknown", {"nope": 1}),
                        ("None key", {None: 1}),
                        ("string value", {"sigma": "x"}),
                        ("nan", {"min_age_s": float("nan")}),
                        ("1e999", {"v_scale": 1e999}),
                        ("huge count", {"elsewhere_samples": 10**400}),
                        ("nested", {"region": [[1, 2], [3, 4]]}),
                        ("None", {"fov": None, "sigma": None}),
                    ),
                )
            },
            check=lambda kw, v: None,
        ),
        Target(
            "load_settings",
            lambda kw: load_settings(**kw),
            lambda: {"path": file_with("s.json", "{}")},
            {"path": Arg(("settings", "file", "path", "JSON", ".json", ".csv"), TEXT_FILES)},
            check=lambda kw, v: None,
        ),
        Target(
            "estimate_frame_sensor",
            lambda kw: estimate_frame_sensor(**kw),
            lambda: {"landmarks": room(), "frames": frames, "truth": still},
            {**sensor_fit_args(), "frame_period_s": view_arg("frame_period_s")}
            | {"mount": Arg(("mount",), MOUNTS)},
            check=lambda kw, v: None,
        ),
        Target(
            "estimate_mount",
            lambda kw: estimate_mount(**kw),
            lambda: {"landmarks": room(), "frames": frames, "truth": still},
            sensor_fit_args(("nothing to fit",)) | {"initial": Arg(("mount", "initial"), MOUNTS)},
            check=lambda kw, v: None,
        ),
        Target(
            "fit_core_and_tail",
            lambda kw: fit_core_and_tail(**kw),
            lambda: {"errors": np.linspace(-0.02, 0.02, 50)},
            {
                "errors": Arg(
                    ("errors", "too few", "numbers"),
                    (
                        ("None", None),
                        ("a string", "errors"),
                        ("empty", []),
                        ("nan", [float("nan")] * 30),
                        ("equal", [0.01] * 30),
                        ("1e300", [1e300] * 15 + [0.0] * 15),
                        ("2-D", [[0.01, -0.01]] * 15),
                        ("complex", [1j] * 30),
                    ),
                )
            },
            check=lambda kw, v: None,
        ),
        Target(
            "bias_by_bearing",
            lambda kw: bias_by_bearing(**kw),
            lambda: {"bearings": np.linspace(-1.0, 1.0, 60), "errors": np.zeros(60)},
            {
                k: Arg(
                    ("bearing", "error", "numbers"),
                    (
                        ("None", None),
                        ("a string", "x"),
                        ("shorter", [0.1]),
                        ("nan", [float("nan")] * 60),
                        ("1e300", [1e300] * 60),
                        ("2-D", np.zeros((30, 2))),
                    ),
                )
                for k in ("bearings", "errors")
            },
            check=lambda kw, v: None,
        ),
        Target(
            "estimate_motion",
            lambda kw: estimate_motion(**kw),
            lambda: {"odometry": odo, "truth": good},
            {
                "odometry": Arg(
                    ("Odometry",),
                    (
                        ("None", None),
                        ("list", [1, 2]),
                        ("two runs", [odo, odo]),
                        ("a list of one", [odo]),
                    ),
                ),
                "truth": Arg(
                    ("GroundTruth", "overlap", "truth"),
                    (
                        ("None", None),
                        ("short", short),
                        ("far away in time", far),
                        ("a list of one", [good]),
                    ),
                ),
                "stretch_s": Arg(
                    ("stretch_s",),
                    (
                        ("nan", [float("nan")]),
                        ("empty", []),
                        ("words", "ab"),
                        ("longer than the run", [100.0]),
                        ("tiny", [1e-300]),
                    ),
                ),
                "delays": Arg(("delays",), (("inf", [float("inf")]), ("2-D", [[0.1]]))),
                "max_gap_s": Arg(("max_gap_s",), (("zero", 0.0), ("nan", float("nan")))),
                "delay_stretch_s": Arg(
                    ("delay_stretch_s", "overlap"),
                    (("huge", 1e300), ("negative", -1.0), ("tiny", 1e-300)),
                ),
                "turn_scales": Arg(
                    ("turn_scales",), (("a string", "yes"), ("an int", 1), ("None", None))
                ),
            },
            check=lambda kw, v: _finite(
                np.array(
                    [v.model.delay_s, v.model.v_scale, v.model.w_scale, v.model.turn_slowdown]
                ),
                "model",
            ),
            limit_s=60.0,
        ),
        Target(
            "estimate_motion runs",
            lambda kw: estimate_motion(**kw),
            lambda: {"odometry": [odo, odo_later], "truth": [good, good_later]},
            {
                "odometry": Arg(
                    ("Odometry",),
                    (
                        ("one run", [odo]),
                        ("empty", []),
                        ("a track among them", [odo, good]),
                        ("None among them", [odo, None]),
                        ("not a list", odo),
                        ("a tuple", (odo, odo_later)),
                        ("a dict", {"a": odo, "b": odo_later}),
                    ),
                ),
                "truth": Arg(
                    ("GroundTruth", "overlap", "truth"),
                    (
                        ("one track", [good]),
                        ("empty", []),
                        ("odometry among them", [good, odo]),
                        ("in the other order", [good_later, good]),
                        ("one far away in time", [good, far]),
                        ("both far away in time", [far, far]),
                        ("one short", [good, short]),
                        ("not a list", good),
                    ),
                ),
                "stretch_s": Arg(("stretch_s",), (("longer than the runs", [100.0]),)),
            },
            check=lambda kw, v: _finite(np.array([v.model.delay_s, v.model.v_scale]), "model"),
            limit_s=60.0,
        ),
        Target(
            "check_motion",
            lambda kw: check_motion(**kw),
            lambda: {"odometry": odo, "truth": good, "model": MotionModel()},
            {
                "odometry": Arg(
                    ("Odometry", "odometry"),
                    (("None", None), ("list", [1, 2]), ("two runs", [odo, odo])),
                ),
                "truth": Arg(
                    ("GroundTruth", "overlap", "truth"),
                    (("None", None), ("short", short), ("far away in time", far)),
                ),
                "model": Arg(
                    ("model", "MotionModel"), (("None", None), ("a dict", {"delay_s": 0.1}))
                ),
                "length": Arg(
                    ("length", "stretch"),
                    (
                        ("nan", float("nan")),
                        ("zero", 0.0),
                        ("longer than the run", 100.0),
                        ("huge", 1e300),
                        ("tiny", 1e-300),
                        ("a string", "2"),
                    ),
                ),
                "max_gap_s": Arg(("max_gap_s",), (("zero", 0.0), ("inf", float("inf")))),
                "skip_s": Arg(
                    ("skip_s", "stretch"),
                    (("negative", -1.0), ("nan", float("nan")), ("the whole run", 1000.0)),
                ),
            },
            check=lambda kw, v: _finite(
                np.array([v.inside(0.99), v.inside(0.5, "heading")]), "share"
            ),
        ),
        Target(
            "check_sensor",
            lambda kw: check_sensor(**kw),
            lambda: {
                "landmarks": room(),
                "frames": frames,
                "truth": still,
                "sensor": omniloc.SensorModel(sigma=0.01),
            },
            {
                **{
                    k: v
                    for k, v in sensor_fit_args(("no bearing",)).items()
                    if k not in ("fov", "max_range")
                },
                "sensor": Arg(
                    ("sensor", "SensorModel"), (("None", None), ("a dict", {"sigma": 0.01}))
                ),
                "config": Arg(
                    ("config", "TrackerConfig"),
                    (("a dict", {"core_share": 0.5}), ("a string", "x")),
                ),
                "frame_period_s": view_arg("frame_period_s"),
            },
            check=lambda kw, v: _finite(
                np.array(
                    [v.inside(0.99), v.inside(0.5), v.clutter_per_frame()]
                    + ([v.detected()] if v.visible.sum() else [])
                ),
                "share",
            ),
        ),
    ]


def _tracker_targets() -> list[Target]:
    """The tracker's configuration and motion model, each value tried on a tracker that takes
    odometry and a few frames of the demo room (a value accepted must not blow up later)."""
    import dataclasses

    from omniloc.track import MotionModel, Tracker, TrackerConfig
    from omniloc.track.config import _COUNTS, _INTS, _PROBABILITIES, _SHARES

    def run(config: dict[str, Any] | None = None, motion: dict[str, Any] | None = None) -> Any:
        tr = Tracker(
            room(),
            omniloc.SensorModel(sigma=math.radians(0.5)),
            MotionModel(**(motion or {})),
            TrackerConfig(**{"search_interval_s": 0.0, **(config or {})}),
        )
        z = omniloc.predict_bearings(room().xy, ROOM_POSE)
        tr.odometry([0.0, 0.25, 0.5], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        return [tr.frame(0.25 * k, z) for k in range(3)]

    def check(kw: dict[str, Any], v: Any) -> None:
        for est in v:
            if est.pose is not None:
                _finite(est.pose.as_array(), "pose")

    regions: Pool = (
        ("reversed", (1.0, 0.0, 0.0, 1.0)),
        ("nan", (0.0, float("nan"), 0.0, 1.0)),
        ("three", (0.0, 1.0, 0.0)),
        ("string", "region"),
        ("1e300", (-1e300, 1e300, -1e300, 1e300)),
    )
    tables: Pool = (
        ("valid", ((0.5, 0.2), (0.99, 0.9))),
        ("nan", ((0.5, float("nan")),)),
        ("probabilities not increasing", ((0.9, 0.2), (0.5, 0.3))),
        ("confidence decreasing", ((0.5, 0.9), (0.9, 0.2))),
        ("above 1", ((0.5, 1.5),)),
        ("three columns", ((0.5, 0.2, 0.1),)),
        ("flat", (0.5, 0.2)),
        ("string", "table"),
        ("1e300", ((1e300, 0.5),)),
        ("400-digit int", ((10**400, 0.5),)),
        ("a thousand knots", tuple((k / 1000, k / 1000) for k in range(1000))),
        ("empty", ()),
    )
    cfg: dict[str, Arg] = {}
    LEVELS = ("search_miss", "model_check")  # (probabilities that may be None)
    for f in dataclasses.fields(TrackerConfig):
        if f.name == "region":
            pool = regions
        elif f.name.startswith("confidence_") and f.name != "confidence_recent_s":
            pool = tables
        elif f.name in _INTS or f.name in _COUNTS:
            pool = COUNTS
        elif f.name in _PROBABILITIES or f.name in _SHARES or f.name in LEVELS:
            pool = PROBABILITIES
        else:
            pool = NUMBERS
        cfg[f.name] = Arg((f.name,), pool)
    motion = {f.name: Arg((f.name,), NUMBERS) for f in dataclasses.fields(MotionModel)}
    arrays: Pool = (
        ("nan", [0.1, float("nan")]),
        ("inf", [0.1, float("inf")]),
        ("strings", ["a", "b"]),
        ("2-D", [[0.1, 0.2]]),
        ("None", None),
        ("complex", [1j, 2j]),
        ("1e300", [1e300, -1e300]),
        ("400-digit int", [10**400]),
        ("a million", np.zeros(1_000_000)),
    )

    def frame(kw: dict[str, Any]) -> Any:
        tr = Tracker(room(), omniloc.SensorModel(sigma=math.radians(0.5)))
        tr.odometry([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        return [tr.frame(kw["t"], kw["bearings"])]

    def odometry(kw: dict[str, Any]) -> Any:
        tr = Tracker(room(), omniloc.SensorModel(sigma=math.radians(0.5)))
        tr.odometry(kw["t"], kw["v"], kw["w"], kw.get("vy"))
        return [tr.frame(3.0, omniloc.predict_bearings(room().xy, ROOM_POSE))]

    def odometry_poses(kw: dict[str, Any]) -> Any:
        tr = Tracker(room(), omniloc.SensorModel(sigma=math.radians(0.5)))
        tr.odometry_poses(kw["t"], kw["x"], kw["y"], kw["theta"])
        return [tr.frame(3.0, omniloc.predict_bearings(room().xy, ROOM_POSE))]

    def set_pose(kw: dict[str, Any]) -> Any:
        tr = Tracker(room(), omniloc.SensorModel(sigma=math.radians(0.5)))
        tr.odometry([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        tr.set_pose(**kw)
        return [tr.frame(1.0, omniloc.predict_bearings(room().xy, ROOM_POSE))]

    return [
        Target(
            "Tracker.set_pose",
            set_pose,
            lambda: {"pose": ROOM_POSE, "covariance": np.diag([1e-3, 1e-3, 1e-4])},
            {
                "pose": Arg(("pose",), POSES),
                "covariance": Arg(("covariance",), MATRICES),
                "mass": Arg(("mass",), PROBABILITIES),
            },
            check=check,
        ),
        Target("TrackerConfig", lambda kw: run(config=kw), dict, cfg, check=check, limit_s=20.0),
        Target("MotionModel", lambda kw: run(motion=kw), dict, motion, check=check, limit_s=20.0),
        Target(
            "Tracker.frame",
            frame,
            lambda: {"t": 1.0, "bearings": [0.1, 0.2, 0.3]},
            {"t": Arg(("frame time", "time"), NUMBERS), "bearings": Arg(("bearings",), arrays)},
            check=check,
        ),
        Target(
            "Tracker.odometry",
            odometry,
            lambda: {"t": [0.0, 1.0], "v": [0.0, 0.1], "w": [0.0, 0.0]},
            {k: Arg(("odometry",), arrays) for k in ("t", "v", "w", "vy")},
            check=check,
        ),
        Target(
            "Tracker.odometry_poses",
            odometry_poses,
            lambda: {"t": [0.0, 1.0], "x": [0.0, 0.1], "y": [0.0, 0.0], "theta": [0.0, 0.1]},
            {k: Arg(("odometry poses", "odometry"), arrays) for k in ("t", "x", "y", "theta")},
            check=check,
        ),
    ]


def _writer_targets() -> list[Target]:
    """Recordings written back to files (``omniloc.track.write_*``)."""
    from omniloc.track import (
        Frame,
        GroundTruth,
        Odometry,
        write_frames,
        write_groundtruth,
        write_odometry,
        write_tum_truth,
    )

    def odo() -> Odometry:
        return Odometry([0.0, 1.0], [0.1, 0.2], [0.0, 0.1])

    def truth() -> GroundTruth:
        return GroundTruth([0.0, 1.0], [0.0, 0.1], [0.0, 0.0], [0.0, 0.1])

    paths: Pool = (
        ("under a file", Lazy(lambda f: _a_file(f) / "out.csv", needs_dir=True)),
        ("a directory", Lazy(lambda f: f, needs_dir=True)),
        ("no folder", in_dir("missing/out.csv")),
        ("NUL", "bad\x00.csv"),
        ("int", 5),
        ("None", None),
    )
    things: Pool = (
        ("None", None),
        ("string", "odometry.csv"),
        ("list", [0.0, 1.0]),
        ("dict", {"t": [0.0]}),
    )
    frame_lists: Pool = (
        ("not frames", [0.1, 0.2]),
        ("a frame and a number", [Frame(0.0, [0.1]), 1.0]),
        ("out of order", [Frame(1.0, [0.1]), Frame(0.5, [0.2])]),
        ("two at one time", [Frame(1.0, [0.1]), Frame(1.0, [0.2])]),
        ("None", None),
        ("int", 3),
    )
    times: Pool = (
        ("nan", [0.5, float("nan")]),
        ("strings", ["a"]),
        ("None", None),
        ("complex", [1j]),
        ("huge", [1e300]),
        ("2-D", [[0.5, 0.7]]),
    )
    path_names = ("path", "file", "folder", "directory", "cannot write")
    return [
        Target(
            "write_odometry",
            lambda kw: write_odometry(**kw),
            lambda: {"path": in_dir("o.csv"), "odometry": Lazy(odo)},
            {
                "path": Arg(path_names, paths),
                "odometry": Arg(("odometry", "Odometry"), things),
            },
            check=lambda kw, v: None,
        ),
        Target(
            "write_groundtruth",
            lambda kw: write_groundtruth(**kw),
            lambda: {"path": in_dir("g.csv"), "truth": Lazy(truth)},
            {
                "path": Arg(path_names, paths),
                "truth": Arg(("GroundTruth", "ground truth"), things),
            },
            check=lambda kw, v: None,
        ),
        Target(
            "write_frames",
            lambda kw: write_frames(**kw),
            lambda: {"path": in_dir("f.csv"), "frames": [Frame(0.0, [0.1]), Frame(0.5, [])]},
            {
                "path": Arg(path_names, paths),
                "frames": Arg(("frame", "Frame", "time", "iterable"), frame_lists),
            },
            check=lambda kw, v: None,
        ),
        Target(
            "write_tum_truth",
            lambda kw: write_tum_truth(**kw),
            lambda: {"path": in_dir("g.tum"), "truth": Lazy(truth), "times": [0.5]},
            {
                "path": Arg(path_names, paths),
                "truth": Arg(("GroundTruth",), things),
                "times": Arg(("times",), times),
            },
            check=lambda kw, v: None,
        ),
    ]


def _plot_targets() -> list[Target]:
    from omniloc.plot import plot_localization

    def result() -> Any:
        return omniloc.localize(room(), z5())

    paths: Pool = (
        ("unknown extension", in_dir("out.unknownext")),
        ("no extension", in_dir("out")),
        ("under a file", Lazy(lambda f: _a_file(f) / "out.png", needs_dir=True)),
        ("a directory", Lazy(lambda f: f, needs_dir=True)),
        ("NUL", "bad\x00.png"),
        ("int", 5),
    )
    return [
        Target(
            "plot_localization",
            lambda kw: plot_localization(**kw),
            lambda: {"result": Lazy(result), "bearings": Lazy(z5), "path": in_dir("ok.png")},
            {
                "path": Arg(
                    ("figure", "path", "file", "format", "extension", "folder", "directory"), paths
                ),
                "bearings": Arg(("bearing",), BEARINGS),
                "result": Arg(("result",), (("None", None), ("string", "x"))),
                "max_solutions": Arg(("max_solutions",), COUNTS),
            },
            check=lambda kw, v: None,
            limit_s=30.0,
        ),
    ]


def _within(bound_s: float, fn: Callable[[], Any]) -> Callable[[], Any]:
    """``fn`` as a case whose call must return within ``bound_s`` seconds (a budget kept)."""

    def call() -> Any:
        t0 = time.perf_counter()
        value = fn()
        dt = time.perf_counter() - t0
        if dt > bound_s:
            raise Insane(f"took {dt:.1f} s, more than {bound_s:g} s")
        return value

    return call


def _scenario_targets() -> list[Target]:
    """The issue's named hangs and silent answers, each a whole call."""
    from omniloc.sensor import SensorModel
    from omniloc.vision import extract_bearings

    def thirty() -> tuple[omniloc.LandmarkMap, np.ndarray]:
        lm = omniloc.random_map(30, rng=1)
        return lm, omniloc.predict_bearings(lm.xy[:6], omniloc.Pose(10.0, 10.0, 0.0))

    def wide(**kw: Any) -> Any:
        lm, z = thirty()
        return omniloc.localize(lm, z, sensor=SensorModel(allow_wide=True, **kw))

    def many_bearings() -> Any:
        lm = omniloc.random_map(1000, size=200.0, rng=1)
        z = np.random.default_rng(0).uniform(-3.0, 3.0, 1000)
        return omniloc.localize(lm, z, max_spurious=0.99, timeout_s=1.0)

    def dense_range() -> Any:
        lm = omniloc.random_map(200_000, size=3000.0, min_separation=0.0, rng=1)
        return omniloc.localize(lm, z5(), max_range=3000.0, timeout_s=2.0)

    def big_map() -> Any:
        lm = omniloc.random_map(5000, size=300.0, rng=1)
        z = omniloc.predict_bearings(lm.xy[:5], omniloc.Pose(150.0, 150.0, 0.0))
        return omniloc.localize(lm, z)

    def many_exact(timeout: float) -> Any:
        lm = omniloc.random_map(300, size=100.0, rng=1)
        z = omniloc.predict_bearings(lm.xy, omniloc.Pose(50.0, 50.0, 0.0))
        return omniloc.localize(lm, z, timeout_s=timeout)

    pool: Pool = (
        ("sigma 0.2 rad allowed, 30 landmarks, no budget", Lazy(lambda: lambda: wide(sigma=0.2))),
        ("threshold 0.5 rad allowed, 30 landmarks", Lazy(lambda: lambda: wide(threshold=0.5))),
        ("1000 bearings, max_spurious 0.99, 1 s", Lazy(lambda: _within(6.0, many_bearings))),
        ("max_range 3000 on 200,000 landmarks, 2 s", Lazy(lambda: _within(12.0, dense_range))),
        ("5000 landmarks, no range, no budget", Lazy(lambda: big_map)),
        ("300 exact bearings, 1 s", Lazy(lambda: _within(15.0, lambda: many_exact(1.0)))),
        ("smoothing 1e6", Lazy(lambda: lambda: extract_bearings(demo_image(), smoothing=1e6))),
        ("all bearings 0.3", Lazy(lambda: lambda: omniloc.localize(room(), [0.3] * 5))),
        (
            "threshold 1e300 allowed",
            Lazy(
                lambda: (
                    lambda: omniloc.localize(
                        room(), z5(), sensor=SensorModel(threshold=1e300, allow_wide=True)
                    )
                )
            ),
        ),
    )
    return [
        Target("scenario", lambda kw: kw["case"](), dict, {"case": Arg(("",), pool)}, limit_s=20.0)
    ]


ARRAYS_OF_NUMBERS: Pool = (
    ("nan", [0.1, float("nan")]),
    ("strings", ["a", "b"]),
    ("2-D", [[0.1, 0.2]]),
    ("None", None),
    ("empty", []),
    ("complex", [1j, 2j]),
    ("1e300", [1e300, 1e300]),
    ("negative", [-1.0, 1.0]),
    ("400-digit", [10**400, 1]),
    ("three", [0.1, 0.2, 0.3]),
    ("halves", [0.5, 1.5]),
)

MATRICES: Pool = (
    ("nan", np.full((3, 3), np.nan)),
    ("inf", np.diag([np.inf, 1.0, 1.0])),
    ("1e300", np.eye(3) * 1e300),
    ("zeros", np.zeros((3, 3))),
    ("2 x 2", np.eye(2)),
    ("flat", [1.0] * 9),
    ("strings", [["a"] * 3] * 3),
    ("None", None),
    ("indefinite", np.diag([1.0, -1.0, 1.0])),
    ("asymmetric", np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])),
    ("denormal", np.eye(3) * 5e-324),
    ("complex", np.eye(3) + 1j),
    ("stack of two", np.stack([np.eye(3)] * 2)),
)


def _bound_steps() -> Any:
    """A robot standing still seeing three landmarks, one a frame, for nine frames."""
    from omniloc.evaluate.bounds import BoundSteps

    L = np.array([[3.0, 0.5], [2.5, -1.5], [4.0, 2.0]])
    G = np.stack([omniloc.bearing_jacobian(L[[k % 3]], np.zeros(3))[1] for k in range(9)])
    N = np.zeros((9, 3, 3))
    N[1:] = np.diag([1e-6, 1e-6, 1e-5])
    return BoundSteps(
        np.arange(9) * 0.25,
        np.tile(np.eye(3), (9, 1, 1)),
        N,
        np.einsum("kij,kil->kjl", G, G),
        np.ones(9, dtype=np.int64),
        np.arange(9, dtype=np.int64) % 3,
        G.reshape(9, 3),
    )


def _repeats() -> Pool:
    """Values for a bound's ``repeat``: models from none to all but independent, and
    what is not one."""
    from omniloc.evaluate.bounds import MAX_SHARE, RepeatingErrors

    return (
        ("None", None),
        ("MRCLAM's", RepeatingErrors(0.783, 13.9)),
        ("nearly all, slow", RepeatingErrors(MAX_SHARE, 3.2e7)),
        ("tiny share", RepeatingErrors(1e-300, 1.0)),
        ("forgotten at once", RepeatingErrors(0.9, 1e-300)),
        ("MRCLAM's shared", RepeatingErrors(0.13, 18.1, 0.68, 13.8, 0.16)),
        ("nearly all common, slow", RepeatingErrors(0.0, 1.0, MAX_SHARE, 3.2e7)),
        ("nearly all the frame's", RepeatingErrors(0.0, 1.0, frame_share=MAX_SHARE)),
        ("common forgotten at once", RepeatingErrors(0.3, 5.0, 0.6, 1e-300, 0.09)),
        ("tiny shared shares", RepeatingErrors(0.0, 1.0, 1e-300, 1.0, 1e-300)),
        ("a number", 0.5),
        ("a string", "mrclam"),
    )


def _bounds_targets() -> list[Target]:
    from omniloc.evaluate import bounds as B

    def prob_check(kw: dict[str, Any], v: Any) -> None:
        if not 0.0 <= v <= 1.0:
            raise Insane(f"probability {v}")

    filt = {
        "info": Arg(("info",), NUMBERS),
        "p_min": Arg(("p_min",), PROBABILITIES),
        "tol_m": Arg(("tol_m",), NUMBERS),
        "tol_heading": Arg(("tol_heading",), ANGLES),
        "repeat": Arg(("repeat",), _repeats()),
    }
    base = lambda: {  # noqa: E731
        "steps": Lazy(_bound_steps),
        "info": 1 / math.radians(0.3) ** 2,
        "p_min": 0.99,
        "tol_m": 0.3,
        "tol_heading": math.radians(5.0),
        "repeat": None,
    }
    return [
        Target(
            "bearing_information",
            lambda kw: B.bearing_information(**kw),
            lambda: {"shares": [0.57, 0.43], "sds": [0.006, 0.018]},
            {
                "shares": Arg(("shares",), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
                "sds": Arg(("sds",), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
            },
        ),
        Target(
            "tolerance_probability",
            lambda kw: B.tolerance_probability(**kw),
            lambda: {"cov": np.diag([0.01, 0.01, 0.001]), "tol_m": 0.3, "tol_heading": 0.09},
            {
                "cov": Arg(("cov",), MATRICES),
                "tol_m": Arg(("tol_m",), NUMBERS),
                "tol_heading": Arg(("tol_heading",), ANGLES),
            },
            check=prob_check,
        ),
        Target(
            "RepeatingErrors",
            lambda kw: B.RepeatingErrors(**kw),
            lambda: {"share": 0.78, "tau_s": 13.9},
            {"share": Arg(("share",), NUMBERS), "tau_s": Arg(("tau_s",), NUMBERS)},
            check=lambda kw, v: None,
        ),
        Target(
            "predict_information",
            lambda kw: B.predict_information(**kw),
            lambda: {"Y": np.eye(3), "F": np.eye(3), "N": np.eye(3) * 1e-3},
            {k: Arg(("predict_information", k), MATRICES) for k in ("Y", "F", "N")},
        ),
        Target(
            "confident_frames",
            lambda kw: B.confident_frames(**kw),
            lambda: {**base(), "restarts": ()},
            {**filt, "restarts": Arg(("restarts",), merged(ARRAYS_OF_NUMBERS, NUMBERS))},
            check=lambda kw, v: None,
        ),
        Target(
            "times_to_localize",
            lambda kw: B.times_to_localize(**kw),
            lambda: {**base(), "starts": [0, 3]},
            {**filt, "starts": Arg(("starts",), merged(ARRAYS_OF_NUMBERS, COUNTS))},
            check=lambda kw, v: None,  # inf: never
        ),
    ]


def _bearing_errors_targets() -> list[Target]:
    """How a recording's bearing errors repeat: sightings, the shared-bias fit and its
    likelihood."""
    from omniloc.evaluate import bearing_errors as E

    def sightings() -> Any:
        rng = np.random.default_rng(0)
        t = np.repeat(np.arange(12) * 0.25, 2)
        return E.Sightings(np.zeros(24, int), np.tile([0, 1], 12), t, rng.normal(0, 0.01, 24))

    def fit_check(kw: dict[str, Any], v: Any) -> None:
        _finite(
            [
                v.common_sd,
                v.common_tau_s,
                v.landmark_sd,
                v.landmark_tau_s,
                v.frame_sd,
                v.white_sd,
                v.gain_per_sighting,
            ],
            "shared-bias fit",
        )
        v.repeating()

    def nll_check(kw: dict[str, Any], v: Any) -> None:
        if not (isinstance(v, float) and not math.isnan(v)):
            raise Insane(f"likelihood {v!r}")

    arrays = merged(ARRAYS_OF_NUMBERS, NUMBERS)
    return [
        Target(
            "Sightings",
            lambda kw: E.Sightings(**kw),
            lambda: {
                "run": [0, 0, 1],
                "landmark": [0, 1, 0],
                "t": [0.0, 0.0, 1.0],
                "error": [0.01, -0.01, 0.0],
            },
            {k: Arg(("Sightings", k), arrays) for k in ("run", "landmark", "t", "error")},
            check=lambda kw, v: None,
        ),
        Target(
            "fit_shared_biases",
            lambda kw: E.fit_shared_biases(**kw),
            lambda: {"s": sightings(), "max_evaluations": 50},
            {"max_evaluations": Arg(("max_evaluations",), COUNTS)},
            check=fit_check,
        ),
        Target(
            "shared_bias_likelihood",
            lambda kw: E.shared_bias_likelihood(**kw),
            lambda: {"s": sightings(), "fit": (0.01, 5.0, 0.005, 5.0, 0.004, 0.002)},
            {"fit": Arg(("six positive numbers", "fit"), arrays)},
            check=nll_check,
        ),
    ]


def _confidence_targets() -> list[Target]:
    """The tracker's confidence tables: fitted on frames, held out by run, applied."""
    from omniloc.track import confidence as C

    states: Pool = (
        ("valid", ["localized", "ambiguous", "lost", "ambiguous"]),
        ("unknown state", ["localized", "moving", "lost", "ambiguous"]),
        ("all lost", ["lost"] * 4),
        ("numbers", [1, 2, 3, 4]),
        ("None", None),
        ("string", "localized"),
        ("one", ["localized"]),
    )
    rights: Pool = (
        ("valid", [True, False, True, True]),
        ("counts", [2, 0, 1, 1]),
        ("nan", [float("nan")] * 4),
        ("strings", ["a", "b", "c", "d"]),
        ("None", None),
        ("2-D", [[True, False], [True, True]]),
    )
    frames = {
        "states": Arg(("states",), states),
        "probabilities": Arg(("probabilities", "frame"), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
        "right": Arg(("right",), rights),
        "since_localized": Arg(("since_localized",), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
        "recent_s": Arg(("recent_s",), NUMBERS),
    }
    base = lambda: {  # noqa: E731
        "states": ["localized", "ambiguous", "lost", "ambiguous"],
        "probabilities": [0.99, 0.4, float("nan"), 0.7],
        "right": [True, False, False, True],
        "since_localized": [0.0, 3.0, None, 40.0],
        "recent_s": 20.0,
    }
    return [
        Target(
            "fit_confidence",
            lambda kw: C.fit_confidence(**kw),
            lambda: {
                **base(),
                "hypothesis_weights": [0.9, 0.2],
                "hypothesis_right": [True, False],
                "hypothesis_since_localized": [0.0, 50.0],
            },
            {
                **frames,
                "hypothesis_weights": Arg(
                    ("hypothesis_weights",), merged(ARRAYS_OF_NUMBERS, NUMBERS)
                ),
                "hypothesis_since_localized": Arg(
                    ("hypothesis_since_localized",), merged(ARRAYS_OF_NUMBERS, NUMBERS)
                ),
            },
        ),
        Target(
            "held_out_confidence",
            lambda kw: C.held_out_confidence(**kw),
            lambda: {**base(), "groups": [0, 0, 1, 1]},
            {
                **frames,
                "groups": Arg(("groups", "two runs"), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
            },
            check=lambda kw, v: None,  # (NaN: a lost frame)
        ),
        Target(
            "fit_table",
            lambda kw: C.fit_table(**kw),
            lambda: {"values": [0.2, 0.9, 0.9], "right": [False, True, True]},
            {
                "values": Arg(("values", "probabilities"), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
                "right": Arg(("right", "one entry per frame"), rights),
            },
        ),
        Target(
            "held_out_table",
            lambda kw: C.held_out_table(**kw),
            lambda: {
                "values": [0.2, 0.9, 0.9, 0.4],
                "right": [False, True, True, True],
                "groups": [0, 0, 1, 1],
            },
            {
                "values": Arg(("values", "probabilities"), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
                "groups": Arg(("groups", "two runs"), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
                "contexts": Arg(("contexts",), merged(ARRAYS_OF_NUMBERS, NUMBERS)),
            },
            check=lambda kw, v: None,  # (NaN: no case in the other runs)
        ),
        Target(
            "confidence_of",
            lambda kw: C.confidence_of(**kw),
            lambda: {"table": ((0.5, 0.2), (0.9, 0.6)), "probability": 0.7},
            {"probability": Arg(("probability",), NUMBERS)},
            check=_confidence_check,
        ),
    ]


def _confidence_check(kw: dict[str, Any], v: Any) -> None:
    if v is not None and not 0.0 <= v <= 1.0:
        raise Insane(f"confidence {v}")


def all_targets() -> dict[str, Target]:
    """Every target by name (the census walks them all)."""
    out: dict[str, Target] = {}
    for t in (
        _pose_targets()
        + _search_targets()
        + _io_targets()
        + _vision_targets()
        + _simulate_targets()
        + _track_targets()
        + _writer_targets()
        + _tracker_targets()
        + _settings_targets()
        + _plot_targets()
        + _scenario_targets()
        + _bounds_targets()
        + _bearing_errors_targets()
        + _confidence_targets()
    ):
        out[t.name] = t
    return out


# --------------------------------------------------------------------------------------------
# The command line
# --------------------------------------------------------------------------------------------

#: Values of numeric options, as a user might type them.
CLI_NUMBERS: Pool = (
    ("nan", "nan"),
    ("inf", "inf"),
    ("-inf", "-inf"),
    ("0", "0"),
    ("-1", "-1"),
    ("1e300", "1e300"),
    ("-1e300", "-1e300"),
    ("denormal", "5e-324"),
    ("1e-300", "1e-300"),
    ("400 digits", "1" + "0" * 400),
    ("word", "x"),
    ("empty", ""),
    ("space", " "),
    ("hex", "0x10"),
    ("underscores", "1_000"),
    ("arabic digits", "\u0661\u0662"),
    ("1e", "1e"),
    ("dash", "-"),
    ("half", "0.5"),
    ("thirty", "30"),
    ("million", "1000000"),
    ("2**64", str(2**64)),
)

CLI_PLOTS: Pool = (
    ("unknown extension", in_dir("out.unknownext")),
    ("no extension", in_dir("figure")),
    ("under a file", Lazy(lambda f: _a_file(f) / "out.png", needs_dir=True)),
    ("a directory", Lazy(lambda f: f, needs_dir=True)),
    ("empty", ""),
)

CLI_OUT_DIRS: Pool = (
    ("a file", Lazy(_a_file, needs_dir=True)),
    ("under a file", Lazy(lambda f: _a_file(f) / "sub", needs_dir=True)),
    ("empty", ""),
)

ROOM_CSV = "id,x,y\n" + "".join(
    f"{i + 1},{x!r},{y!r}\n" for i, (x, y) in enumerate(omniloc.demo_room().xy.tolist())
)


def _bearings_file(folder: Path) -> Path:
    p = folder / "bearings.txt"
    p.write_text("\n".join(f"{float(v)!r}" for v in z5()) + "\n")
    return p


def _image_file(folder: Path) -> Path:
    import cv2

    p = folder / "omni.png"
    cv2.imwrite(str(p), demo_image())
    return p


@dataclass(frozen=True)
class CliTarget:
    """A subcommand: its valid argv as (option, value) pairs (option None: a positional;
    value None: a switch), and the pools of the options fuzzed."""

    name: str
    base: tuple[tuple[str | None, Any], ...]
    options: dict[str, Pool]
    limit_s: float = HANG_S


def cli_argv(target: CliTarget, option: str, value: Any, folder: Path) -> list[str]:
    """The argv of a case: the base with ``option`` replaced by (or given) ``value``; option
    ``"<name>"`` is a positional of the base."""
    argv: list[str] = []
    replaced = False
    for flag, v in target.base:
        if flag == option or (flag is None and option == "<positional>"):
            v, replaced = value, True
        argv += _given(flag, v, folder)
    if not replaced:
        argv += _given(option, value, folder)
    return [target.name, *argv]


def _given(flag: str | None, value: Any, folder: Path) -> list[str]:
    """``flag value`` as argv; a tuple of values gives the flag once for each (an option
    that may be repeated)."""
    out: list[str] = []
    for v in value if isinstance(value, tuple) else (value,):
        if flag is not None:
            out.append(flag)
        if v is not None:
            out.append(str(resolve(v, folder)))
    return out


#: ``--mount X,Y,YAW`` (metres, metres, degrees).
CLI_MOUNTS: Pool = (
    *CLI_NUMBERS,
    ("valid", "0.2,0,10"),
    ("two numbers", "0.2,0"),
    ("four numbers", "0.2,0,0,0"),
    ("empty entries", ",,"),
    ("a word among numbers", "0.2,x,0"),
    ("nan x", "nan,0,0"),
    ("yaw 400", "0,0,400"),
    ("x 1e300", "1e300,0,0"),
    ("x of 400 digits", "1" + "0" * 400 + ",0,0"),
)

#: The numeric options of ``omniloc localize``.
LOCALIZE_NUMERIC = (
    "--threshold",
    "--sigma",
    "--max-spurious",
    "--max-range",
    "--min-range",
    "--fov",
    "--p-miss",
    "--p-detect",
    "--clutter",
    "--confidence",
    "--decisive",
    "--max-nodes",
    "--timeout",
    "--forward",
    "--aspect",
)


def cli_targets() -> dict[str, CliTarget]:
    localize = CliTarget(
        "localize",
        (
            ("--map", file_with("room.csv", ROOM_CSV)),
            ("--bearings", Lazy(_bearings_file, needs_dir=True)),
            ("--timeout", "5"),
        ),
        {
            "--map": MAP_FILES,
            "--bearings": TEXT_FILES,
            "--image": IMAGE_FILES,
            "--plot": CLI_PLOTS,
            "--method": (("unknown", "fast"), ("empty", "")),
            "--strategy": (("unknown", "fast"), ("upper case", "TREE")),
            "--center": (("one value", "5"), ("word", "x")),
            "--clutter-by-detections": (
                *CLI_NUMBERS,
                ("list", "0.3,0.9,1.2"),
                ("empty entries", ",,"),
                ("word in list", "0.3,x"),
                ("negative in list", "0.3,-1"),
                ("nan in list", "0.3,nan"),
                ("2,000 entries", ",".join(["0.5"] * 2000)),
                ("1e999", "1e999,1"),
            ),
            **{k: CLI_NUMBERS for k in LOCALIZE_NUMERIC},
            "--mount": CLI_MOUNTS,
        },
    )
    bearings = CliTarget(
        "bearings",
        ((None, Lazy(_image_file, needs_dir=True)),),
        {
            "<positional>": IMAGE_FILES,
            "--plot": CLI_PLOTS,
            **{k: CLI_NUMBERS for k in ("--forward", "--aspect")},
        },
    )
    demo = CliTarget("demo", (("--no-vision", None),), {"--out": CLI_OUT_DIRS})
    evaluate = CliTarget(
        "evaluate",
        (("--dataset", "roh"), (None, Lazy(_roh_ok, needs_dir=True)), ("--out", in_dir("ev"))),
        {
            "--out": CLI_OUT_DIRS,
            "--dataset": (("unknown", "foo"),),
            "--trials": CLI_NUMBERS,
            "--workers": CLI_NUMBERS,
            "--max-samples": CLI_NUMBERS,
            "--min-landmarks": CLI_NUMBERS,
            "--seed": CLI_NUMBERS,
            "--preset": (("unknown", "fast"),),
            # the tracker's settings, given to a single-frame dataset
            "--set": (("valid", "min_age_s=3"), ("unknown", "nope=1"), ("no value", "x")),
            "--config": (
                ("missing", in_dir("nothing/s.json")),
                ("valid", file_with("s.json", "{}")),
            ),
        },
        limit_s=30.0,
    )
    z = omniloc.predict_bearings(room().xy, ROOM_POSE)
    frames_csv = "t,bearing\n" + "".join(f"{t},{b!r}\n" for t in (0.5, 1.0, 1.5) for b in z)
    track = CliTarget(
        "track",
        (
            ("--map", file_with("room.csv", ROOM_CSV)),
            ("--odometry", file_with("odo.csv", "t,v,w\n0,0,0\n1,0,0\n2,0,0\n")),
            ("--frames", file_with("frames.csv", frames_csv)),
        ),
        {
            "--map": MAP_FILES,
            "--odometry": ODOMETRY_FILES,
            "--frames": FRAME_FILES,
            "--groundtruth": GROUNDTRUTH_FILES,
            "--out": (
                ("a directory", Lazy(lambda f: f, needs_dir=True)),
                ("under a file", Lazy(lambda f: _a_file(f) / "traj.tum", needs_dir=True)),
                ("empty", ""),
            ),
            "--plot": CLI_PLOTS,
            # (without --groundtruth in the base case: refused for that, or for the path)
            "--truth-out": (
                ("a directory", Lazy(lambda f: f, needs_dir=True)),
                ("under a file", Lazy(lambda f: _a_file(f) / "gt.tum", needs_dir=True)),
                ("empty", ""),
                ("fine", in_dir("gt.tum")),
            ),
            "--preset": (("unknown", "fast"), ("empty", "")),
            **{k: CLI_NUMBERS for k in ("--sigma", "--fov", "--max-range")},
            "--mount": CLI_MOUNTS,
            "--initial-pose": CLI_MOUNTS,
            "--initial-sd": (
                *CLI_NUMBERS,
                ("valid", "0.1,5"),
                ("three numbers", "0.1,5,5"),
                ("negative", "-0.1,5"),
                ("heading 400", "0.1,400"),
                ("nan position sd", "nan,5"),
            ),
            "--config": (
                *TEXT_FILES,
                ("json array", file_with("s.json", "[1, 2]")),
                ("unknown name", file_with("s.json", '{"nope": 1}')),
                ("int key value nan", file_with("s.json", '{"min_age_s": NaN}')),
                ("400-digit value", file_with("s.json", '{"max_hypotheses": 1' + "0" * 400 + "}")),
                ("huge particles", file_with("s.json", '{"elsewhere_samples": 1000000000}')),
                ("string value", file_with("s.json", '{"sigma": "0.01"}')),
                ("nested", file_with("s.json", '{"sigma": {"a": 1}}')),
                ("null", file_with("s.json", '{"fov": null, "max_range": null}')),
            ),
            "--set": (
                ("no value", "min_age_s"),
                ("no name", "=3"),
                ("unknown", "nope=1"),
                ("word", "min_age_s=abc"),
                ("nan", "sigma=NaN"),
                ("inf", "delay_s=Infinity"),
                ("1e999", "kidnap_rate=1e999"),
                ("400 digits", "max_hypotheses=1" + "0" * 400),
                ("negative", "turn_noise_s=-1"),
                ("bool", "evidence_weight=true"),
                ("list", "region=[1,2,3,4,5]"),
                ("deep list", "region=" + "[" * 100_000 + "]" * 100_000),
                ("null", "sigma=null"),
                ("wide sigma", "sigma=1"),
                ("empty value", "min_age_s="),
            ),
        },
    )
    tt = [0.1 * k for k in range(400)]
    fit_odo = "t,v,w\n" + "".join(f"{t!r},0.2,0.1\n" for t in tt)
    fit_gt = "t,x,y,theta\n" + "".join(
        f"{t!r},{2 * math.sin(0.1 * t)!r},{2 - 2 * math.cos(0.1 * t)!r},{0.1 * t!r}\n" for t in tt
    )
    fit_odo_file, fit_gt_file = file_with("odo.csv", fit_odo), file_with("gt.csv", fit_gt)
    # (The runs fit-motion and check-motion read: one odometry and one track each.)
    run_base = (("--odometry", fit_odo_file), ("--groundtruth", fit_gt_file))
    run_files: dict[str, Pool] = {
        "--odometry": (*ODOMETRY_FILES, ("two for one track", (fit_odo_file, fit_odo_file))),
        "--groundtruth": (*GROUNDTRUTH_FILES, ("two for one run", (fit_gt_file, fit_gt_file))),
    }
    fit_motion = CliTarget(
        "fit-motion",
        run_base,
        {
            **run_files,
            "--out": (
                ("a directory", Lazy(lambda f: f, needs_dir=True)),
                ("under a file", Lazy(lambda f: _a_file(f) / "s.json", needs_dir=True)),
                ("empty", ""),
            ),
        },
        limit_s=60.0,
    )
    check_motion = CliTarget(
        "check-motion",
        run_base,
        {**run_files, "--length": CLI_NUMBERS, "--plot": CLI_PLOTS},
    )
    sensor_frames = "t,bearing\n" + "".join(
        f"{0.2 * k!r},{b!r}\n" for k in range(8) for b in z.tolist()
    )
    p = ROOM_POSE
    still_gt = f"t,x,y,theta\n0,{p.x!r},{p.y!r},{p.theta!r}\n2,{p.x!r},{p.y!r},{p.theta!r}\n"
    # (The recording fit-sensor and check-sensor read: the room seen from one pose.)
    sensor_run = (
        ("--map", file_with("room.csv", ROOM_CSV)),
        ("--frames", file_with("frames.csv", sensor_frames)),
        ("--groundtruth", file_with("gt.csv", still_gt)),
    )
    sensor_files: dict[str, Pool] = {
        "--map": MAP_FILES,
        "--frames": FRAME_FILES,
        "--groundtruth": GROUNDTRUTH_FILES,
    }
    fit_sensor = CliTarget(
        "fit-sensor",
        sensor_run,
        {
            **sensor_files,
            "--out": (
                ("a directory", Lazy(lambda f: f, needs_dir=True)),
                ("under a file", Lazy(lambda f: _a_file(f) / "s.json", needs_dir=True)),
            ),
            **{k: CLI_NUMBERS for k in ("--fov", "--max-range", "--gate", "--frame-period")},
            "--mount": CLI_MOUNTS,
        },
    )
    check_sensor = CliTarget(
        "check-sensor",
        sensor_run,
        {
            **sensor_files,
            **{k: CLI_NUMBERS for k in ("--gate", "--frame-period")},
            "--plot": CLI_PLOTS,
        },
    )
    targets = (
        localize,
        bearings,
        demo,
        evaluate,
        track,
        fit_motion,
        check_motion,
        fit_sensor,
        check_sensor,
    )
    return {t.name: t for t in targets}
