"""Synthetic maps and observations, and the seed paper's experiment (its section 4, Table 1).

Everything random takes ``rng: np.random.Generator | int | None`` and goes through
``np.random.default_rng(rng)``; nothing touches numpy's global generator.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .angles import TWO_PI, wrap
from .errors import InputError
from .io import MAX_COORDINATE, finite_number, shorten
from .maps import LandmarkMap, as_landmark_map
from .pose import Pose

__all__ = [
    "MapKind",
    "Scene",
    "Table1Row",
    "demo_room",
    "grid_map",
    "make_map",
    "observe",
    "paper_experiment",
    "random_map",
    "random_pose",
    "symmetric_map",
]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | None

#: The pose and the order in which landmarks come into view in the demo experiment.
DEMO_POSE = Pose(5.6, 2.1, np.deg2rad(30.0))
DEMO_VISIBLE = (10, 3, 0, 6, 8, 4, 11)  # landmark indices (ids 11, 4, 1, 7, 9, 5, 12)


class MapKind(str, enum.Enum):
    """Kinds of map :func:`make_map` builds (values are the CLI choices)."""

    RANDOM = "random"
    ROOM = "room"
    SYMMETRIC = "symmetric"


def demo_room() -> LandmarkMap:
    """The 12-landmark demo room shipped with omniloc (an L-shaped 10 m x 8 m lab).

    Examples
    --------
    >>> len(demo_room())
    12
    """
    ref = resources.files("omniloc") / "data" / "demo_room.csv"
    with resources.as_file(ref) as path:
        return LandmarkMap.from_csv(path)


#: The most landmarks or bearings a simulation makes (a larger count is a typo, not a test).
MAX_COUNT = 10_000_000


def _check_count(name: str, n: object, minimum: int, maximum: int = MAX_COUNT) -> int:
    if (
        isinstance(n, bool)
        or not isinstance(n, (int, np.integer))
        or not minimum <= int(n) <= maximum
    ):
        raise InputError(
            f"{name} must be an integer >= {minimum} (and <= {maximum:,}), got {shorten(n)}"
        )
    return int(n)


def _length(name: str, value: object, *, zero: bool = False) -> float:
    """A length (or density): finite, > 0 (>= 0 with ``zero``), at most MAX_COORDINATE."""
    v = finite_number(value, name)
    if not (0 <= v if zero else 0 < v) or v > MAX_COORDINATE:
        rel = ">= 0" if zero else "positive"
        raise InputError(f"{name} must be {rel} (and <= {MAX_COORDINATE:.0e}), got {v:g}")
    return v


def _generator(rng: object) -> np.random.Generator:
    """``np.random.default_rng(rng)``, or an InputError naming ``rng``."""
    try:
        return np.random.default_rng(rng)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(
            f"rng must be a numpy Generator, an int seed >= 0 or None, got {shorten(rng)}"
        ) from None


def random_map(
    n: int,
    *,
    size: float | tuple[float, float] | None = None,
    density: float | None = None,
    min_separation: float = 0.5,
    rng: RngLike = None,
) -> LandmarkMap:
    """Landmarks uniform in a rectangle, no two closer than ``min_separation``.

    Parameters
    ----------
    n : int
        Number of landmarks, >= 3.
    size : float or (float, float), optional
        Side(s) of the rectangle in metres. Default: a 20 m square, or from ``density``.
    density : float, optional
        Landmarks per square metre; sets a square of side ``sqrt(n / density)``.
    min_separation : float
        Metres; candidates closer than this to an earlier landmark are redrawn.
    rng : Generator, int or None

    Returns
    -------
    LandmarkMap
    """
    n = _check_count("n", n, 3)
    gen = _generator(rng)
    min_separation = _length("min_separation", min_separation, zero=True)
    if density is not None:
        side = math.sqrt(n / _length("density", density))
        w = h = _length("the side sqrt(n / density)", side)
    elif size is None:
        w = h = 20.0
    elif isinstance(size, tuple | list):
        if len(size) != 2:
            raise InputError(f"size must be one side or (width, height), got {shorten(size)}")
        w, h = _length("size", size[0]), _length("size", size[1])
    else:
        w = h = _length("size", size)
    if min_separation > 0 and n * math.pi * (min_separation / 2) ** 2 > 0.5 * w * h:
        raise InputError(
            f"{n} landmarks {min_separation} m apart do not fit in {w:.1f} m x {h:.1f} m"
        )
    from scipy.spatial import cKDTree

    pts = gen.uniform((0.0, 0.0), (w, h), size=(n, 2))
    for _ in range(100):
        if min_separation <= 0:
            return LandmarkMap(pts)
        pairs = cKDTree(pts).query_pairs(min_separation, output_type="ndarray")
        if pairs.size == 0:
            return LandmarkMap(pts)
        redo = np.unique(pairs[:, 1])
        pts[redo] = gen.uniform((0.0, 0.0), (w, h), size=(redo.size, 2))
    raise InputError(
        f"could not place {n} landmarks {min_separation} m apart in {w:.1f} m x {h:.1f} m "
        "in 100 rounds; use a smaller min_separation or a larger area"
    )


def grid_map(
    n: int, *, density: float = 0.01, min_separation: float = 2.0, rng: RngLike = None
) -> LandmarkMap:
    """Landmarks on a jittered square grid: racks of a warehouse rather than a uniform spread.

    The grid's spacing is ``1 / sqrt(density)``; each landmark lies uniformly within
    ``(spacing - min_separation) / 2`` of its node in x and in y, so no two are closer than
    ``min_separation``. The ``n`` landmarks fill the nodes of a square grid row by row.

    Parameters
    ----------
    n : int
        Number of landmarks, >= 3.
    density : float
        Landmarks per square metre (0.01: one per 10 m x 10 m cell).
    min_separation : float
        Metres, smaller than the spacing.
    rng : Generator, int or None

    Examples
    --------
    >>> lm = grid_map(100, density=0.01, min_separation=2.0, rng=0)
    >>> lm.n, round(float(lm.kdtree.query(lm.xy, k=2)[0][:, 1].min()), 1) >= 2.0
    (100, True)
    """
    n = _check_count("n", n, 3)
    density = _length("density", density)
    spacing = 1.0 / math.sqrt(density)
    _length("the grid's side at this density", spacing * math.sqrt(n))
    min_separation = _length("min_separation", min_separation, zero=True)
    if not 0.0 <= min_separation < spacing:
        raise InputError(
            f"min_separation must lie in [0, {spacing:g}) m (the grid's spacing at density "
            f"{density:g}), got {min_separation!r}"
        )
    gen = _generator(rng)
    side = math.ceil(math.sqrt(n))
    k = np.arange(n)
    nodes = np.stack([k % side, k // side], axis=1) * spacing
    half = 0.5 * (spacing - min_separation)
    return LandmarkMap(nodes + gen.uniform(-half, half, size=(n, 2)))


def symmetric_map(kind: str = "square", *, size: float = 6.0) -> LandmarkMap:
    """A map with rotational symmetry, where bearings alone cannot tell poses apart.

    ``"square"``: the 4 corners of a square (Roh's beacon layout, 4-fold ambiguity);
    ``"octagon"``: 8 points on a regular octagon; ``"grid"``: a 4 x 3 grid (2-fold).
    """
    size = _length("size", size)
    if size < 1e-6:
        raise InputError(
            f"size must be at least 1e-6 m (the landmarks would coincide), got {size:g}"
        )
    if kind == "square":
        xy = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float) * size
    elif kind == "octagon":
        a = np.arange(8) * TWO_PI / 8
        xy = 0.5 * size * np.stack([np.cos(a), np.sin(a)], axis=1)
    elif kind == "grid":
        gx, gy = np.meshgrid(np.arange(4), np.arange(3))
        xy = np.stack([gx.ravel(), gy.ravel()], axis=1).astype(np.float64) * (size / 3.0)
    else:
        raise InputError(f"unknown symmetric map {shorten(kind)}; choose square, octagon or grid")
    return LandmarkMap(xy)


def make_map(
    kind: MapKind | str, n: int = 12, *, rng: RngLike = None, size: float = 20.0
) -> LandmarkMap:
    """A map of a given kind: ``random`` (n landmarks in a ``size`` m square), ``room`` (the
    demo room, n ignored) or ``symmetric`` (a 4 x 3 grid, n ignored)."""
    try:
        k = MapKind(kind)
    except ValueError as exc:
        raise InputError(f"map kind must be one of {[m.value for m in MapKind]}") from exc
    if k is MapKind.ROOM:
        return demo_room()
    if k is MapKind.SYMMETRIC:
        return symmetric_map("grid", size=12.0)
    return random_map(n, size=size, rng=rng)


def random_pose(
    landmarks: LandmarkMap | ArrayLike, *, clearance: float = 0.5, rng: RngLike = None
) -> Pose:
    """A pose uniform in the map's bounding box, at least ``clearance`` from every landmark,
    with a uniform heading."""
    lm = as_landmark_map(landmarks)
    gen = _generator(rng)
    clearance = _length("clearance", clearance, zero=True)
    x0, y0, x1, y1 = lm.bounds
    for _ in range(1000):
        p = gen.uniform((x0, y0), (x1, y1))
        if np.hypot(*(lm.xy - p).T).min() >= clearance:
            return Pose(float(p[0]), float(p[1]), float(gen.uniform(-np.pi, np.pi)))
    raise InputError(f"no point of the map's bounding box is {clearance} m from every landmark")


@dataclass(frozen=True)
class Scene:
    """A simulated observation with its truth.

    Attributes
    ----------
    bearings : ndarray, shape (m,)
        What the robot reports, radians, in random order.
    assignment : tuple of (int or None)
        True landmark index of each bearing; None for a spurious bearing.
    pose : Pose
        The true pose.
    """

    bearings: FloatArray
    assignment: tuple[int | None, ...]
    pose: Pose

    @property
    def n_spurious(self) -> int:
        """Number of spurious bearings."""
        return sum(a is None for a in self.assignment)


def visible_landmarks(
    lm: LandmarkMap,
    pose: Pose,
    *,
    max_range: float | None = None,
    min_range: float | None = None,
    fov: float | None = None,
) -> NDArray[np.int64]:
    """Indices of the landmarks in range and in the field of view of a pose."""
    d = lm.xy - pose.xy
    r = np.hypot(d[:, 0], d[:, 1])
    ok = r > 1e-9
    if max_range is not None:
        ok &= r <= max_range
    if min_range is not None:
        ok &= r >= min_range
    if fov is not None:
        b = np.asarray(wrap(np.arctan2(d[:, 1], d[:, 0]) - pose.theta))
        ok &= np.abs(b) <= fov / 2
    return np.flatnonzero(ok)


def observe(
    landmarks: LandmarkMap | ArrayLike,
    pose: Pose,
    *,
    visible: ArrayLike | None = None,
    n_obs: int | None = None,
    sigma: float = 0.0,
    n_spurious: int = 0,
    p_miss: float = 0.0,
    max_range: float | None = None,
    min_range: float | None = None,
    fov: float | None = None,
    shuffle: bool = True,
    rng: RngLike = None,
) -> Scene:
    """Bearings a robot at ``pose`` would report.

    Parameters
    ----------
    landmarks : LandmarkMap or array_like, shape (N, 2)
    pose : Pose
        True pose.
    visible : array_like of int, optional
        Landmark indices to observe (in this order before shuffling); by default every
        landmark in range and field of view.
    n_obs : int, optional
        Keep a random subset of this many of the visible landmarks.
    sigma : float
        Standard deviation of Gaussian bearing noise, radians.
    n_spurious : int
        Bearings of things not on the map, uniform on the field of view.
    p_miss : float
        Probability of missing each visible landmark.
    shuffle : bool
        Report bearings in random order (the robot does not know which is which).
    rng : Generator, int or None
    """
    lm = as_landmark_map(landmarks)
    gen = _generator(rng)
    if not isinstance(pose, Pose):
        try:
            pose = Pose.from_array(pose)
        except InputError as exc:
            raise InputError(f"pose: {exc}") from None
    sigma = finite_number(sigma, "sigma")
    if not 0.0 <= sigma <= math.pi:
        raise InputError(f"sigma must be >= 0 (and <= pi radians), got {sigma:g}")
    p_miss = finite_number(p_miss, "p_miss")
    if not 0.0 <= p_miss < 1.0:
        raise InputError(f"p_miss must lie in [0, 1), got {p_miss}")
    max_range = None if max_range is None else _length("max_range", max_range)
    min_range = None if min_range is None else _length("min_range", min_range, zero=True)
    if fov is not None:
        fov = finite_number(fov, "fov")
        if not 0.0 < fov <= TWO_PI:
            raise InputError(f"fov is a full angle in radians in (0, 2 pi], got {fov:g}")
    n_spurious = _check_count("n_spurious", n_spurious, 0)
    if visible is None:
        idx = visible_landmarks(lm, pose, max_range=max_range, min_range=min_range, fov=fov)
    else:
        try:
            arr = np.asarray(visible)
        except (TypeError, ValueError):
            arr = np.asarray([None])
        if arr.size and arr.dtype.kind not in "iu":
            raise InputError(f"visible must list landmark indices (ints), got {shorten(visible)}")
        idx = arr.astype(np.int64)
        if idx.ndim != 1 or (idx.size and (idx.min() < 0 or idx.max() >= lm.n)):
            raise InputError(f"visible must list landmark indices in [0, {lm.n})")
    if p_miss > 0:
        idx = idx[gen.random(idx.size) >= p_miss]
    if n_obs is not None:
        n_obs = _check_count("n_obs", n_obs, 0)
        if n_obs > idx.size:
            raise InputError(f"n_obs={n_obs} but only {idx.size} landmarks are visible")
        idx = gen.choice(idx, size=n_obs, replace=False) if visible is None else idx[:n_obs]
    d = lm.xy[idx] - pose.xy
    b = np.arctan2(d[:, 1], d[:, 0]) - pose.theta
    if sigma > 0:
        b = b + gen.normal(0.0, sigma, size=b.shape)
    half = np.pi if fov is None else fov / 2
    spur = gen.uniform(-half, half, size=n_spurious)
    bearings = np.asarray(wrap(np.concatenate([b, spur])))
    truth: list[int | None] = [int(i) for i in idx] + [None] * spur.size
    if shuffle:
        perm = gen.permutation(bearings.size)
        bearings = bearings[perm]
        truth = [truth[i] for i in perm]
    return Scene(bearings, tuple(truth), pose)


@dataclass(frozen=True)
class Table1Row:
    """One row of the paper's Table 1, as omniloc measures it."""

    n_obs: int
    total_paths: int
    examined_paths: int
    solutions: int
    true_pose_found: bool
    elapsed_s: float


def paper_experiment(
    n_obs: tuple[int, ...] = (4, 5, 6, 7),
    *,
    threshold: float = float(np.deg2rad(1.0)),
    sigma: float = 0.0,
    rng: RngLike = 0,
) -> tuple[list[Table1Row], dict[int, tuple[Scene, Any]]]:
    """The seed paper's simulation (section 4): the demo room, 4-7 observations.

    The robot stands at :data:`DEMO_POSE` and sees the landmarks of :data:`DEMO_VISIBLE` in an
    order shuffled once by ``rng``; with m observations it reports the first m of them, so
    each row adds one observation to the previous one, as in the paper. Bearings carry
    Gaussian noise ``sigma`` (the paper's simulation is noise-free). The search is the
    paper's own (``method="paper"``).

    Returns
    -------
    rows : list of Table1Row
    runs : dict
        For each m, the scene and the :class:`~omniloc.search.LocalizationResult`.
    """
    from .search import localize

    lm = demo_room()
    gen = _generator(rng)
    full = observe(lm, DEMO_POSE, visible=DEMO_VISIBLE, sigma=sigma, rng=gen)
    rows: list[Table1Row] = []
    runs: dict[int, tuple[Scene, Any]] = {}
    if isinstance(n_obs, str | bytes) or not isinstance(n_obs, tuple | list):
        raise InputError(f"n_obs must be a tuple of observation counts, got {shorten(n_obs)}")
    for m in n_obs:
        if isinstance(m, bool) or not isinstance(m, int | np.integer):
            raise InputError(f"n_obs must hold ints (observation counts), got {shorten(m)}")
        if not 3 <= m <= len(full.bearings):
            raise InputError(f"the demo sees 3 to {len(full.bearings)} landmarks, not {m}")
        scene = Scene(full.bearings[:m], full.assignment[:m], DEMO_POSE)
        res = localize(lm, scene.bearings, threshold=threshold, method="paper")
        found = any(
            s.pose.distance_to(DEMO_POSE)[0] < 0.1
            and s.pose.distance_to(DEMO_POSE)[1] < np.deg2rad(1.0)
            for s in res.solutions
        )
        rows.append(
            Table1Row(
                n_obs=m,
                total_paths=res.stats.total_paths,
                examined_paths=res.stats.examined_paths,
                solutions=len(res.solutions),
                true_pose_found=found,
                elapsed_s=res.stats.elapsed_s,
            )
        )
        runs[m] = (scene, res)
    return rows, runs
