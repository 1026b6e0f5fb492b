"""The ``omniloc`` command: ``localize``, ``bearings``, ``demo``, ``evaluate``, ``track``.

Each subcommand calls one library function. Errors that omniloc raises on purpose
(:class:`~omniloc.errors.OmnilocError`) become one line on stderr and exit status 1; anything
else keeps its traceback, because it is a bug.
"""

from __future__ import annotations

import argparse
import functools
import json
import logging
import math
import os
import re
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from . import __version__
from .errors import InputError, OmnilocError
from .io import make_folder, shorten, write_json
from .pose import Pose
from .search import Method, Strategy

if TYPE_CHECKING:
    from .evaluate.tracking import TrackingReport

log = logging.getLogger("omniloc")

#: Human output lists at most this many solutions.
MAX_PRINTED = 20

#: What --odometry reads (omniloc.track.load_odometry).
ODOMETRY_HELP = (
    "odometry: CSV t,v,w (velocities), or a pose track in the odometry's frame: CSV "
    "t,x,y,theta or a TUM file (t x y z qx qy qz qw, e.g. evo_traj's of a bag's /odom)"
)


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line and exit status 1."""

    def error(self, message: str) -> NoReturn:
        raise InputError(f"{self.prog}: {message}")


def _number(text: str) -> float:
    """A finite number from the command line (argparse names the option on error)."""
    try:
        v = float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not a number: {shorten(text, 40)}") from exc
    if not np.isfinite(v):
        raise argparse.ArgumentTypeError(f"not finite: {shorten(text, 40)}")
    return v


def _seed(text: str) -> int:
    """A seed for numpy's generator: an int >= 0."""
    try:
        v = int(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not an integer: {shorten(text, 40)}") from exc
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {v}")
    return v


def _out_path(text: str) -> Path:
    """An output file or folder name (an empty one would write into the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path")
    return Path(text)


def _positive(text: str) -> float:
    """A finite number > 0, checked in the user's units (degrees, metres, seconds)."""
    v = _number(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return v


def _nonnegative(text: str) -> float:
    v = _number(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return v


def _nonnegative_list(text: str) -> tuple[float, ...]:
    parts = [t for t in text.replace(" ", "").split(",") if t]
    if not parts:
        raise argparse.ArgumentTypeError(f"a comma-separated list of numbers, got {text!r}")
    return tuple(_nonnegative(t) for t in parts)


def _xy_angle_deg(text: str, what: str, angle: str, limit: float) -> tuple[float, float, float]:
    """Three numbers ``X,Y,ANGLE``: metres, metres and degrees (at most ``limit`` either way),
    the angle returned in radians; ``what`` names them in the error."""
    parts = [t for t in text.replace(" ", "").split(",")]
    if len(parts) != 3 or not all(parts):
        raise argparse.ArgumentTypeError(
            f"{what} (metres, metres, degrees), got {shorten(text, 40)}"
        )
    x, y, a = (_number(t) for t in parts)
    if abs(a) > limit:
        raise argparse.ArgumentTypeError(
            f"{angle} is in degrees, at most {limit:g} either way, got {shorten(text, 40)}"
        )
    return x, y, math.radians(a)


def _mount_deg(text: str) -> tuple[float, float, float]:
    """``X,Y,YAW``: the sensor's place on the robot, metres and degrees (as radians)."""
    return _xy_angle_deg(text, "the sensor's X,Y,YAW on the robot", "YAW", 180.0)


MOUNT_HELP = (
    "where the sensor sits on the robot: X,Y (metres forward and to the left of the robot's "
    "origin) and YAW (degrees, counter-clockwise from the robot's forward axis), as ROS's "
    "base_link -> camera_link; the bearings are the sensor's, the poses the robot's"
)


def _fov_deg(text: str) -> float:
    v = _positive(text)
    if v > 360:
        raise argparse.ArgumentTypeError(
            f"a full field of view in degrees, at most 360, got {text!r}"
        )
    return v


def _pose_deg(text: str) -> tuple[float, float, float]:
    """``X,Y,THETA``: a pose, metres and degrees (as radians)."""
    return _xy_angle_deg(text, "the robot's X,Y,THETA", "THETA", 360.0)


def _sd_deg(text: str) -> tuple[float, float]:
    """``SD_M,SD_DEG``: a pose's position and heading standard deviations."""
    parts = [t for t in text.replace(" ", "").split(",")]
    if len(parts) != 2 or not all(parts):
        raise argparse.ArgumentTypeError(
            f"the pose's SD_M,SD_DEG (metres, degrees), got {shorten(text, 40)}"
        )
    sd_m, sd_deg = (_positive(t) for t in parts)
    if sd_deg > 180:
        raise argparse.ArgumentTypeError(
            f"SD_DEG is in degrees, at most 180, got {shorten(text, 40)}"
        )
    return sd_m, math.radians(sd_deg)


#: ``--backward``'s help (``track`` and ``evaluate --dataset mrclam-track``).
BACKWARD_HELP = (
    "offline: a second pass backward in time reports the frames within S seconds before a "
    'sure localized frame that it holds localized (docs/tracking.md, "Offline: a second '
    'pass backward"); without it the forward pass alone, each frame placed by what came '
    "before it, as online"
)

#: ``--initial-sd``'s default: AMCL's initial covariance (0.25 m^2, 0.068 rad^2).
INITIAL_SD = (0.5, math.radians(15.0))


def _probability(text: str) -> float:
    v = _number(text)
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"must lie strictly between 0 and 1, got {text!r}")
    return v


def _add_image_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("image options (conic-mirror camera)")
    g.add_argument("--center", nargs=2, type=_number, metavar=("CX", "CY"), help="rim centre, px")
    g.add_argument("--aspect", type=_positive, help="rim semi-axis along u / along v")
    g.add_argument(
        "--forward", type=_number, default=0.0, help="image angle of the robot's forward axis, deg"
    )
    g.add_argument("--mirrored", action="store_true", help="the mirror flips the rotation sense")


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="omniloc",
        description="Absolute localization of a mobile robot from unlabelled landmark bearings.",
    )
    parser.add_argument("--version", action="version", version=f"omniloc {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress, warnings only")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("localize", help="find the pose and correspondences from bearings")
    p.add_argument("--map", required=True, type=Path, help="landmark map, CSV (id,x,y) or JSON")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--bearings", type=Path, help="bearings file: CSV, JSON or plain text")
    src.add_argument("--image", type=Path, help="an omnidirectional (conic-mirror) image")
    p.add_argument(
        "--degrees",
        action="store_true",
        help="the bearings file is in degrees, and human output shows degrees",
    )
    p.add_argument(
        "--threshold", type=_positive, default=1.0, help="rule (ii) gate, deg (default 1)"
    )
    p.add_argument("--sigma", type=_positive, help="bearing noise std, deg: chi-square gating")
    p.add_argument("--method", choices=[m.value for m in Method], default=Method.ROBUST.value)
    p.add_argument(
        "--max-spurious", type=float, default=0, help="spurious bearings allowed (int or fraction)"
    )
    p.add_argument("--ordering", action="store_true", help="apply the angular ordering constraint")
    p.add_argument("--max-range", type=_positive, help="sensor range, m")
    p.add_argument("--min-range", type=_positive, help="minimum sensor range, m")
    p.add_argument("--fov", type=_fov_deg, help="full field of view, deg (omit for 360)")
    p.add_argument("--p-miss", type=_probability, help="probability of missing a visible landmark")
    p.add_argument(
        "--p-detect",
        type=_probability,
        help="probability of detecting a plainly visible landmark (instead of --p-miss)",
    )
    p.add_argument(
        "--clutter",
        type=_nonnegative,
        help="expected spurious bearings per frame (default: --max-spurious, at least 0.5)",
    )
    p.add_argument(
        "--clutter-by-detections",
        type=_nonnegative_list,
        metavar="N1,N2,...",
        help="expected spurious bearings per frame in frames that report 1, 2, ... landmarks "
        "(the last for more), where clutter comes with the landmarks; omniloc fit-sensor "
        "prints it for a recording",
    )
    p.add_argument("--mount", type=_mount_deg, metavar="X,Y,YAW", help=MOUNT_HELP)
    p.add_argument(
        "--confidence",
        type=_probability,
        default=0.999,
        help="confidence of the chi-square gates (default 0.999)",
    )
    p.add_argument(
        "--decisive",
        type=_probability,
        default=0.95,
        help="share of the posterior the best must hold not to be ambiguous (default 0.95)",
    )
    p.add_argument("--max-nodes", type=int, help="node budget")
    p.add_argument("--timeout", type=_positive, help="time budget, s")
    p.add_argument(
        "--strategy",
        choices=[s.value for s in Strategy],
        default=Strategy.AUTO.value,
        help="search strategy (default auto: compiled where numba is installed)",
    )
    p.add_argument(
        "--first-fit",
        action="store_true",
        help="stop at the first interpretation that explains all but --max-spurious bearings "
        "(large maps; rivals are not sought)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--plot", type=_out_path, metavar="OUT.png", help="save a figure of the solutions"
    )
    _add_image_options(p)

    b = sub.add_parser("bearings", help="extract landmark bearings from an omnidirectional image")
    b.add_argument("image", type=Path)
    _add_image_options(b)
    b.add_argument("--degrees", action="store_true", help="print degrees rather than radians")
    b.add_argument("--json", action="store_true", help="machine-readable output")
    b.add_argument(
        "--plot", type=_out_path, metavar="OUT.png", help="image with the detected lines"
    )

    d = sub.add_parser("demo", help="reproduce the paper's Table 1 and show the vision chain")
    d.add_argument("--out", type=_out_path, default=Path("demo-output"), help="folder for figures")
    d.add_argument("--no-vision", action="store_true", help="skip the vision section")

    e = sub.add_parser("evaluate", help="Monte Carlo sweeps and real-data evaluation")
    e.add_argument(
        "--preset",
        choices=[
            "quick",
            "default",
            "targets-spurious",
            "targets-spurious-range",
            "targets-spurious-range-0.9999",
            "targets-crlb",
            "targets-honest",
            "targets-honest-room",
        ],
        default="quick",
        help="which sweep to run (default: quick)",
    )
    e.add_argument("--trials", type=int, help="trials per condition (overrides the preset)")
    e.add_argument(
        "--dataset",
        nargs=2,
        metavar=("KIND", "PATH"),
        help="evaluate on real data instead: KIND is roh, mrclam or mrclam-track",
    )
    e.add_argument(
        "--kidnap",
        type=int,
        default=100,
        help="mrclam-track: kidnapped streams (and as many without a jump), default 100",
    )
    e.add_argument(
        "--tracker-seeds",
        type=_seed,
        nargs="+",
        metavar="N",
        help="mrclam-track: run once per seed of the tracker's random particles "
        "(TrackerConfig.seed) and report each figure's range over them (--seed seeds the "
        "kidnapped streams)",
    )
    _add_settings_options(e, "mrclam-track: ")
    e.add_argument(
        "--backward",
        type=_nonnegative,
        metavar="S",
        help="mrclam-track, " + BACKWARD_HELP,
    )
    e.add_argument("--max-samples", type=int, help="use at most this many dataset samples")
    e.add_argument(
        "--min-landmarks",
        type=int,
        default=4,
        help="MRCLAM: use the frames that see at least this many landmarks (default 4)",
    )
    e.add_argument("--seed", type=_seed, default=0)
    e.add_argument("--workers", type=int, default=1, help="processes for a sweep (default 1)")
    e.add_argument("--out", type=_out_path, default=Path("evaluation"), help="folder for results")
    _add_track_parser(sub)
    f = sub.add_parser(
        "fit-motion",
        help="fit the motion model to odometry and a ground-truth track (settings for track)",
    )
    f.add_argument(
        "--odometry",
        required=True,
        type=Path,
        action="append",
        help=f"{ODOMETRY_HELP}; repeat it with --groundtruth to fit several runs of one robot "
        "together",
    )
    f.add_argument(
        "--groundtruth",
        required=True,
        type=Path,
        action="append",
        help="true track of the same run: CSV t,x,y,theta or a TUM file (one per --odometry, in "
        "their order)",
    )
    _add_settings_out(f)
    _add_check_motion_parser(sub)
    fs = sub.add_parser(
        "fit-sensor",
        help="fit the bearing sensor to frames and a ground-truth track (settings for track)",
    )
    fs.add_argument("--map", required=True, type=Path, help="landmark map, CSV (id,x,y) or JSON")
    fs.add_argument(
        "--frames",
        required=True,
        type=Path,
        action="append",
        help="frames: CSV t,bearing or MRCLAM robotR_frames.csv (landmark ids not used); "
        "repeat it with --groundtruth to fit several runs of one sensor together",
    )
    fs.add_argument(
        "--groundtruth",
        required=True,
        type=Path,
        action="append",
        help="true track of the same run: CSV t,x,y,theta or a TUM file (one per --frames, in "
        "their order)",
    )
    fs.add_argument("--degrees", action="store_true", help="the frames' bearings are in degrees")
    fs.add_argument(
        "--fov",
        type=_fov_deg,
        help="full field of view, deg (default: all around); p_detect and clutter are for it, "
        "and --out writes it",
    )
    fs.add_argument(
        "--max-range",
        type=_positive,
        help="sensor range, m; p_detect and clutter are for it, and --out writes it",
    )
    fs.add_argument("--mount", type=_mount_deg, metavar="X,Y,YAW", help=MOUNT_HELP)
    fs.add_argument(
        "--fit-mount",
        action="store_true",
        help="fit the sensor's mount on the robot (X, Y, YAW) to the frames and the truth "
        "first (from --mount as a guess within about 0.3 m, default the origin; any yaw), then "
        "the sensor from it; --out writes the mount too",
    )
    fs.add_argument(
        "--gate",
        type=_positive,
        default=3.0,
        help="a bearing within this of a landmark is taken as it, deg (default 3)",
    )
    fs.add_argument(
        "--frame-period",
        type=_positive,
        metavar="S",
        help="the camera's frame period, s, for a log that lists only frames with a bearing "
        "(MRCLAM: 0.237): its gaps are frames that saw nothing, and p_detect and clutter are "
        "per camera frame; --out then sets nonempty_frames",
    )
    fs.add_argument(
        "--mixture",
        action="store_true",
        help="--out writes the errors as a sharp core and a wider tail (sigma, core_share, "
        "core_sigma, and core_update false: the core weighs, it does not narrow) instead of "
        "one robust sigma. Check the result on runs it was not fitted "
        "on: on MRCLAM a sharp core (the fit: 57 %% at 0.33 deg, the rest at 1 deg) localized "
        "more frames, but robot 1 0.3 m off in up to 4 %% of its frames, and the mrclam preset "
        "keeps one Gaussian (docs/tracking.md, 'A sharp core and a heavier tail')",
    )
    _add_settings_out(fs)
    _add_check_sensor_parser(sub)
    _add_fit_confidence_parser(sub)
    return parser


def _add_run_files(p: argparse.ArgumentParser, *files: tuple[str, str]) -> None:
    """Required file options (name, what it holds) given once per run, for several runs."""
    for name, what in files:
        p.add_argument(
            name,
            required=True,
            type=Path,
            action="append",
            help=f"{what}; one per run, repeated for several runs (in the same order)",
        )


def _add_check_motion_parser(sub: Any) -> None:
    cm = sub.add_parser(
        "check-motion",
        help="check a motion model (a preset, fit-motion's settings) against odometry and a "
        "ground-truth track it was not fitted on",
    )
    _add_run_files(
        cm,
        ("--odometry", ODOMETRY_HELP),
        ("--groundtruth", "true track of the same run: CSV t,x,y,theta or a TUM file"),
    )
    _add_preset_and_settings(cm, "the motion model checked, before --config and --set")
    cm.add_argument(
        "--length",
        type=_positive,
        default=2.0,
        metavar="S",
        help="length of the stretches the motion is checked over, seconds (default 2)",
    )
    cm.add_argument(
        "--plot",
        type=_out_path,
        metavar="OUT.png",
        help="save a figure: the heading errors against the model's band, and the squared "
        "errors against the chi-square curves",
    )


def _add_check_sensor_parser(sub: Any) -> None:
    cs = sub.add_parser(
        "check-sensor",
        help="check a bearing sensor model (a preset, fit-sensor's settings) against frames and "
        "a ground-truth track it was not fitted on",
    )
    cs.add_argument("--map", required=True, type=Path, help="landmark map, CSV (id,x,y) or JSON")
    _add_run_files(
        cs,
        ("--frames", "frames: CSV t,bearing or MRCLAM robotR_frames.csv (landmark ids not used)"),
        ("--groundtruth", "true track of the same run: CSV t,x,y,theta or a TUM file"),
    )
    cs.add_argument("--degrees", action="store_true", help="the frames' bearings are in degrees")
    _add_preset_and_settings(
        cs,
        "the sensor model checked (and the tracker's core_share, core_sigma, turn_noise_s), "
        "before --config and --set",
    )
    cs.add_argument(
        "--gate",
        type=_positive,
        default=3.0,
        help="a bearing within this of a landmark is taken as it, deg (default 3)",
    )
    cs.add_argument(
        "--frame-period",
        type=_positive,
        metavar="S",
        help="the camera's frame period, s, for a model whose rates are per camera frame "
        "(nonempty_frames true, as fit-sensor --frame-period writes it)",
    )
    cs.add_argument(
        "--plot",
        type=_out_path,
        metavar="OUT.png",
        help="save a figure: the errors against the model's density, and the share inside each "
        "of the model's regions",
    )


def _add_fit_confidence_parser(sub: Any) -> None:

    fc = sub.add_parser(
        "fit-confidence",
        help="fit the tracker's confidence tables on recordings with a ground truth "
        "(settings for track)",
    )
    fc.add_argument("--map", required=True, type=Path, help="landmark map, CSV (id,x,y) or JSON")
    _add_run_files(
        fc,
        ("--odometry", ODOMETRY_HELP),
        ("--frames", "frames: CSV t,bearing or MRCLAM robotR_frames.csv"),
        ("--groundtruth", "true track: CSV t,x,y,theta or a TUM file"),
    )
    _add_tracker_options(fc)
    fc.add_argument(
        "--backward",
        type=_nonnegative,
        metavar="S",
        help="run each recording with the pass backward over S seconds (as track --backward "
        "S) and fit the table of the frames it reports (confidence_backward) beside the others",
    )
    _add_settings_out(fc)


def _add_tracker_options(p: argparse.ArgumentParser) -> None:
    """``--degrees``, ``--preset``, ``--config`` and ``--set`` of the commands that run the
    tracker."""
    p.add_argument("--degrees", action="store_true", help="the frames' bearings are in degrees")
    _add_preset_and_settings(p, "sensor, motion and tracker parameters")


def _add_preset_and_settings(p: argparse.ArgumentParser, what: str) -> None:
    """``--preset`` (``what`` it gives), then ``--config`` and ``--set``."""
    from .track.presets import Preset

    p.add_argument(
        "--preset",
        choices=[q.value for q in Preset],
        default=Preset.GENERIC.value,
        help=f"{what} (default generic)",
    )
    _add_settings_options(p)


def _add_settings_out(p: argparse.ArgumentParser) -> None:
    """``--out`` of the fit commands: their values as a settings file."""
    p.add_argument(
        "--out",
        type=_out_path,
        metavar="SETTINGS.json",
        help="write the fitted values as settings (omniloc track --config SETTINGS.json)",
    )


def _add_settings_options(p: argparse.ArgumentParser, scope: str = "") -> None:
    """``--config`` and ``--set``: values of the tracker's preset changed by name."""
    p.add_argument(
        "--config",
        type=Path,
        action="append",
        default=[],
        metavar="SETTINGS.json",
        help=f"{scope}a JSON object of settings (name: value, the library's units: rad, m, s) "
        "applied to the tracker's preset; repeatable (e.g. fit-motion's and fit-sensor's), "
        "later files win",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help=f"{scope}one setting of the sensor, motion or tracker model (a field of "
        "SensorModel, MotionModel or TrackerConfig; the value in JSON, the library's units), "
        "after --config; repeatable, e.g. --set min_age_s=10 --set region=[-1,5.5,-6,6.5]",
    )


def _preset_and_settings(args: argparse.Namespace) -> tuple[Any, Any, Any]:
    """The sensor model, motion model and tracker configuration of ``--preset``, changed by
    ``--config`` and ``--set`` (refused before any file is read)."""
    from .track import preset, with_settings

    sensor, motion, config = preset(args.preset)
    settings = _settings(args)
    if settings:
        sensor, motion, config = with_settings(sensor, motion, config, settings)
    return sensor, motion, config


def _given(args: argparse.Namespace) -> str:
    """What a figure's title says it shows: the preset, the settings files, the settings."""
    return ", ".join([f"the {args.preset} preset", *(str(p.name) for p in args.config), *args.set])


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    """The settings of ``--config`` then ``--set``."""
    from .track import load_settings

    settings: dict[str, Any] = {}
    for path in args.config:
        settings.update(load_settings(path))
    for item in args.set:
        settings.update(_setting(item))
    return settings


def _add_track_parser(sub: Any) -> None:

    t = sub.add_parser("track", help="localize over time from odometry and frames of bearings")
    t.add_argument("--map", required=True, type=Path, help="landmark map, CSV (id,x,y) or JSON")
    t.add_argument("--odometry", required=True, type=Path, help=ODOMETRY_HELP)
    t.add_argument(
        "--frames",
        required=True,
        type=Path,
        help="frames: CSV t,bearing (rows with equal t form a frame) or MRCLAM robotR_frames.csv",
    )
    _add_tracker_options(t)
    t.add_argument("--sigma", type=_positive, help="bearing noise std, deg (overrides the preset)")
    t.add_argument("--fov", type=_fov_deg, help="full field of view, deg (overrides the preset)")
    t.add_argument("--max-range", type=_positive, help="sensor range, m (overrides the preset)")
    t.add_argument("--mount", type=_mount_deg, metavar="X,Y,YAW", help=MOUNT_HELP)
    t.add_argument(
        "--initial-pose",
        type=_pose_deg,
        metavar="X,Y,THETA",
        help="where the robot is at the first frame (metres, metres, degrees), as ROS's "
        "/initialpose tells AMCL: tracked from there, called localized once the bearings "
        "agree; without it the robot is localized globally",
    )
    t.add_argument(
        "--initial-sd",
        type=_sd_deg,
        metavar="SD_M,SD_DEG",
        help="with --initial-pose: its standard deviations, metres (x and y) and degrees "
        f"(default {INITIAL_SD[0]:g},{math.degrees(INITIAL_SD[1]):g}, AMCL's)",
    )
    t.add_argument(
        "--groundtruth",
        type=Path,
        help="true track (CSV t,x,y,theta or a TUM file): errors in the summary and figure; "
        "with frames that name their landmarks (MRCLAM's), also what the data allow a "
        "localizer told them",
    )
    t.add_argument("--out", type=_out_path, metavar="TRAJ.tum", help="localized poses, TUM format")
    t.add_argument(
        "--truth-out",
        type=_out_path,
        metavar="GT.tum",
        help="with --groundtruth: the true poses at the frames' times, TUM format (the "
        "reference for evo_ape tum GT.tum TRAJ.tum)",
    )
    t.add_argument(
        "--json", action="store_true", help="one JSON object per frame on stdout (JSON lines)"
    )
    t.add_argument("--plot", type=_out_path, metavar="OUT.png", help="save a figure of the run")
    t.add_argument("--backward", type=_nonnegative, metavar="S", help=BACKWARD_HELP)


# --------------------------------------------------------------------------------------------
# Subcommands
# --------------------------------------------------------------------------------------------


def _fmt_angle(rad: float, degrees: bool) -> str:
    return f"{np.rad2deg(rad):.3f} deg" if degrees else f"{rad:.5f} rad"


def _cmd_localize(args: argparse.Namespace) -> int:
    from .io import read_bearings, to_jsonable
    from .maps import LandmarkMap
    from .search import localize

    lm = LandmarkMap.load(args.map)
    if args.image is not None:
        from .vision import bearings_from_image

        det = bearings_from_image(
            args.image,
            center=None if args.center is None else tuple(args.center),
            aspect=args.aspect,
            forward=float(np.deg2rad(args.forward)),
            mirrored=args.mirrored,
        )
        bearings = det.bearings
        if bearings.size < 3:
            raise InputError(
                f"{args.image}: found {bearings.size} bearings in the image, need at least 3"
            )
        # Edges of a stripe that could be a pole or a narrow wall segment are flagged: if it
        # was a pole, both are wrong, so each flagged edge may be spurious.
        flagged = int(np.count_nonzero(det.ambiguous))
    else:
        # (A file of omniloc bearings --json flags its ambiguous edges, as --image does.)
        bearings, ambiguous = read_bearings(args.bearings, degrees=args.degrees)
        flagged = int(np.count_nonzero(ambiguous))
    ms = args.max_spurious
    max_spurious: int | float = int(ms) if float(ms).is_integer() else float(ms)
    if flagged:
        if isinstance(max_spurious, float):
            max_spurious = math.floor(max_spurious * bearings.size)
        max_spurious += flagged
    result = localize(
        lm,
        bearings,
        threshold=float(np.deg2rad(args.threshold)),
        method=args.method,
        sigma=None if args.sigma is None else float(np.deg2rad(args.sigma)),
        max_spurious=max_spurious,
        ordering=args.ordering,
        max_range=args.max_range,
        min_range=args.min_range,
        fov=None if args.fov is None else float(np.deg2rad(args.fov)),
        p_miss=args.p_miss,
        p_detect=args.p_detect,
        clutter=args.clutter,
        clutter_by_detections=args.clutter_by_detections,
        mount=args.mount,
        confidence=args.confidence,
        decisive=args.decisive,
        max_nodes=args.max_nodes,
        timeout_s=args.timeout,
        strategy=args.strategy,
        exhaustive=not args.first_fit,
    )
    if args.plot is not None:
        from .plot.scene import plot_localization

        plot_localization(result, bearings, args.plot)
    if args.json:
        out = {
            "units": "metres and radians",
            "bearings": bearings,
            "solutions": [
                {
                    "x": s.pose.x,
                    "y": s.pose.y,
                    "theta": s.pose.theta,
                    "assignment": result.assignment_ids(s),
                    "residual_rms": s.residual_rms,
                    "matched": s.matched,
                    "missed": s.missed,
                    "confidence": s.confidence,
                    "covariance": s.covariance,
                }
                for s in result.solutions
            ],
            "ambiguous": result.ambiguous,
            "competing": result.competing,
            "unexplained": result.unexplained,
            "complete": result.complete,
            "stats": result.stats.as_dict(),
        }
        if result.mount is not None:
            out["mount"] = list(result.mount)  # (the poses are the robot's, seen from it)
        print(json.dumps(to_jsonable(out), indent=2))
        return 0
    deg = args.degrees
    n = len(bearings)
    st = result.stats
    if not result:
        print(
            f"No pose is consistent with these {n} bearings "
            f"({st.nodes} nodes searched in {st.elapsed_s * 1e3:.1f} ms"
            + ("" if st.complete else ", stopped by the budget")
            + ")."
        )
        return 0
    best = result.solutions[0]
    share = f"the best holds {100 * best.confidence:.1f} % of the posterior"
    if not result.ambiguous:
        verdict = f"decisive: {share}"
    elif not st.complete:
        verdict = (
            f"AMBIGUOUS: the search was stopped by its budget (rivals may be missing); {share}"
        )
    elif not st.exhaustive:
        verdict = f"AMBIGUOUS: first fit, rivals not sought; {share}"
    elif result.competing > 1:
        verdict = f"AMBIGUOUS: {result.competing} distinct poses compete; {share}"
    else:
        verdict = (
            f"AMBIGUOUS: {share}, too little to rule out that none is right (a chance fit "
            "elsewhere on the map; more bearings, --max-range or --p-detect help)"
        )
    print(
        f"{len(result)} solution{'s' if len(result) != 1 else ''} for {n} bearings "
        f"({st.nodes} nodes, {st.examined_paths} paths examined, "
        f"{st.elapsed_s * 1e3:.1f} ms) -- {verdict}"
    )
    shown = result.solutions[:MAX_PRINTED]
    for k, s in enumerate(shown, 1):
        ids = ["-" if i is None else str(i) for i in result.assignment_ids(s)]
        print(
            f"  #{k}: x = {s.pose.x:.3f} m, y = {s.pose.y:.3f} m, "
            f"theta = {_fmt_angle(s.pose.theta, deg)}; "
            f"landmarks [{', '.join(ids)}]; residual rms {_fmt_angle(s.residual_rms, deg)}; "
            f"confidence {s.confidence:.3f}"
        )
    if len(result) > len(shown):
        print(f"  ... and {len(result) - len(shown)} more (all of them with --json)")
    if result.mount is not None:
        x, y, yaw = result.mount
        print(
            f"(the robot's poses; the sensor at x = {x:.3f} m, y = {y:.3f} m, "
            f"yaw = {_fmt_angle(yaw, deg)} on it)"
        )
    return 0


def _cmd_bearings(args: argparse.Namespace) -> int:
    from .io import to_jsonable
    from .vision import bearings_from_image, load_image

    image = load_image(args.image)
    det = bearings_from_image(
        image,
        center=None if args.center is None else tuple(args.center),
        aspect=args.aspect,
        forward=float(np.deg2rad(args.forward)),
        mirrored=args.mirrored,
    )
    if args.plot is not None:
        from .plot.vision import plot_detections

        plot_detections(image, det, args.plot)
    cal = det.calibration
    conv = np.rad2deg if args.degrees else (lambda a: a)
    if args.json:
        out = {
            "units": "degrees" if args.degrees else "radians",
            "calibration": {"center": cal.center, "aspect": cal.aspect, "radius": cal.radius},
            "detections": [
                {
                    "bearing": float(conv(b)),
                    "strength": float(s),
                    "kind": str(k),
                    "ambiguous": bool(a),
                }
                for b, s, k, a in zip(
                    det.bearings, det.strength, det.kind, det.ambiguous, strict=True
                )
            ],
        }
        print(json.dumps(to_jsonable(out), indent=2))
        return 0
    unit = "deg" if args.degrees else "rad"
    print(
        f"mirror rim: centre ({cal.center[0]:.2f}, {cal.center[1]:.2f}) px, "
        f"aspect {cal.aspect:.4f}, radius {cal.radius:.1f} px; {len(det)} detections"
    )
    for b, s, k, a in zip(det.bearings, det.strength, det.kind, det.ambiguous, strict=True):
        mark = "  ambiguous" if a else ""
        print(f"  {float(conv(b)):10.5f} {unit}  {k:4s}  strength {float(s):.1f}{mark}")
    n_amb = int(det.ambiguous.sum())
    if n_amb:
        print(
            f"({n_amb} ambiguous: edges of a stripe that may be a pole; "
            "allow them as spurious bearings)"
        )
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from .plot.scene import plot_localization
    from .pose import predict_bearings
    from .search import localize
    from .simulate import DEMO_POSE, demo_room, observe, paper_experiment

    out = make_folder(args.out, "--out")
    print("omniloc demo: the seed paper's experiment (Lee & Chung, section 4, Table 1)")
    print(
        f"Demo room: {len(demo_room())} landmarks; robot at ({DEMO_POSE.x}, {DEMO_POSE.y}) "
        f"heading {np.rad2deg(DEMO_POSE.theta):.0f} deg; noise-free bearings; threshold 1 deg."
    )
    # The first search in a process loads the compiled tree; time that apart from the table.
    t0 = time.perf_counter()
    warm = predict_bearings(demo_room().xy[:4], DEMO_POSE)
    localize(demo_room(), warm, method="paper")
    localize(demo_room(), warm, sigma=np.deg2rad(0.3), max_spurious=1)  # the hypotheses search
    startup_ms = (time.perf_counter() - t0) * 1e3
    rows, runs = paper_experiment()
    header = (
        "| observations | total paths in IT | examined paths | solutions | true pose found "
        "| time (ms) |"
    )
    print()
    print(header)
    print("|---:|---:|---:|---:|:---:|---:|")
    for r in rows:
        print(
            f"| {r.n_obs} | {r.total_paths} | {r.examined_paths} | {r.solutions} | "
            f"{'yes' if r.true_pose_found else 'NO'} | {r.elapsed_s * 1e3:.1f} |"
        )
    print()
    print("(examined paths = nodes the search visited at depth 4 or deeper, as in the paper;")
    print(f" times are the searches alone: loading the compiled search took {startup_ms:.0f} ms)")
    for m, (scene, res) in runs.items():
        path = out / f"solutions-{m}-observations.png"
        plot_localization(
            res,
            scene.bearings,
            path,
            true_pose=DEMO_POSE,
            title=f"{m} observations: {len(res)} solution(s)",
        )
    print(f"Figures like the paper's Figs. 4-6: {out}/solutions-*-observations.png")

    # Beyond the paper: a noisy scene with two spurious bearings.
    lm = demo_room()
    scene = observe(
        lm, DEMO_POSE, n_obs=7, sigma=np.deg2rad(0.3), n_spurious=2, rng=np.random.default_rng(7)
    )
    res = localize(lm, scene.bearings, sigma=np.deg2rad(0.3), max_spurious=2)
    print()
    print(
        "Beyond the paper: 7 landmarks + 2 spurious bearings, noise 0.3 deg, "
        "localize(..., sigma=0.3 deg, max_spurious=2):"
    )
    best = res.best
    if best is None:
        print("  no solution")
    else:
        err_xy, err_th = best.pose.distance_to(DEMO_POSE)
        print(
            f"  best pose ({best.pose.x:.3f}, {best.pose.y:.3f}, "
            f"{np.rad2deg(best.pose.theta):.2f} deg): error {err_xy * 100:.1f} cm, "
            f"{np.rad2deg(err_th):.2f} deg; spurious bearings found: "
            f"{[k for k, a in enumerate(best.assignment) if a is None]} "
            f"(truth {[k for k, a in enumerate(scene.assignment) if a is None]}); "
            f"{res.stats.elapsed_s * 1e3:.1f} ms"
        )
    if not args.no_vision:
        from .plot.vision import vision_demo

        print()
        print("Vision front end (rendered conic-mirror image -> bearings):")
        print("  " + vision_demo(out).replace("\n", "\n  "))
        _demo_image_to_pose()
    _demo_over_time(out)
    return 0


def _demo_over_time(out: Path) -> None:
    """The tracker on the example recording: its time line, and a figure."""
    from .evaluate.tracking import errors_against
    from .plot.track import plot_track
    from .track import track
    from .track.backward import refine
    from .track.simulate import example_run

    ex = example_run()
    run = track(
        ex.landmarks,
        ex.run.odometry,
        ex.run.frames,
        sensor=ex.sensor,
        motion=ex.motion,
    )
    est = run.estimates
    ok, d_pos, d_hdg = errors_against(ex.run.truth, est)
    print()
    print(
        "Over time (omniloc.track): a robot wakes up on a grid that one frame cannot tell from "
        f"its half turn and is carried off at {ex.run.kidnap_t:.0f} s "
        "(examples/grid-run; omniloc track on its files prints the same):"
    )
    last = None
    for k, e in enumerate(est):
        if (e.state, e.kidnapped) == last:
            continue
        last = (e.state, e.kidnapped)
        off = f"{d_pos[k]:.2f} m and {d_hdg[k]:.1f} deg off"
        if e.pose is None:
            off = "no pose"
        elif e.localized:
            off = f"{'right' if ok[k] else 'WRONG'}: {off}"
        else:
            off = f"its best place {off}"
        state = "KIDNAPPED" if e.kidnapped else e.state.value
        print(f"  {e.t:5.1f} s  {state:<10} ({off}): {e.reason}")
    loc = np.array([e.localized for e in est])
    span = est[-1].t - est[0].t
    print(
        f"  localized in {loc.sum()} of {len(est)} frames, right (0.3 m, 5 deg) in "
        f"{ok[loc].sum()} of them, position RMSE {np.sqrt(np.mean(d_pos[loc] ** 2)):.3f} m; "
        f"{span:.0f} s of recording in {run.cpu_s:.1f} s of CPU"
    )
    # Offline, the pass backward from each sure frame over the same forward estimates (what
    # track(..., backward_s=20) does after its forward pass).
    both = refine(
        ex.landmarks,
        ex.run.odometry,
        ex.run.frames,
        est,
        horizon_s=20.0,
        sensor=ex.sensor,
        motion=ex.motion,
    )
    ok2, _, _ = errors_against(ex.run.truth, both)
    loc2 = np.array([e.localized for e in both])
    n_back = sum(e.backward for e in both)
    n_given = sum(f.localized and o is not f for f, o in zip(est, both, strict=True))
    print(
        f"  offline, with the pass backward (--backward 20): localized in {loc2.sum()} of "
        f"{len(est)} frames ({n_back} by the pass backward; {n_given} localized forward at a "
        f"place given up within 10 s after), right in {ok2[loc2].sum()} of them"
    )
    path = out / "track.png"
    plot_track(ex.landmarks, est, path, truth=ex.run.truth, title="the example recording")
    print(f"  figure: {path}")


def _demo_image_to_pose() -> None:
    """The whole chain on the vision demo's room: image -> bearings -> pose."""
    from .search import localize
    from .vision import DEMO_CAMERA, DEMO_POSE, demo_scene, extract_bearings, render_omni_image

    scene = demo_scene()
    image = render_omni_image(scene, DEMO_POSE, DEMO_CAMERA, rng=0)
    det = extract_bearings(image, forward=DEMO_CAMERA.forward, mirrored=DEMO_CAMERA.mirrored)
    res = localize(scene.landmarks_xy, det.bearings, sigma=float(np.deg2rad(0.1)))
    truth = Pose(*DEMO_POSE)
    best = res.best
    if best is None:
        print("  image -> pose: no solution")
        return
    err_xy, err_th = best.pose.distance_to(truth)
    print(
        f"  image -> pose: ({best.pose.x:.3f} m, {best.pose.y:.3f} m, "
        f"{np.rad2deg(best.pose.theta):.2f} deg), error {err_xy * 100:.1f} cm and "
        f"{np.rad2deg(err_th):.2f} deg, {len(res)} solution(s), "
        f"{res.stats.elapsed_s * 1e3:.0f} ms search"
    )


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from . import evaluate as ev

    progress = not args.quiet
    if (args.config or args.set) and (args.dataset is None or args.dataset[0] != "mrclam-track"):
        raise InputError(
            "--config and --set change the tracker's settings: they apply to --dataset "
            "mrclam-track only"
        )
    if args.tracker_seeds and (args.dataset is None or args.dataset[0] != "mrclam-track"):
        raise InputError("--tracker-seeds applies to --dataset mrclam-track only")
    if args.backward is not None and (args.dataset is None or args.dataset[0] != "mrclam-track"):
        raise InputError("--backward applies to --dataset mrclam-track only")
    track_settings: dict[str, Any] = {}
    if args.dataset is not None and args.dataset[0] == "mrclam-track":
        from .track import preset, with_settings

        track_settings = _settings(args)
        with_settings(*preset("mrclam"), track_settings)  # refused before anything is made
    make_folder(args.out, "--out")  # before the run, not after it
    if args.dataset is not None and args.dataset[0] == "mrclam-track":
        return _cmd_evaluate_track(args, track_settings)
    if args.dataset is not None:
        kind, path = args.dataset
        if args.min_landmarks < 3:
            raise InputError(f"--min-landmarks must be >= 3, got {args.min_landmarks}")
        res: Any = ev.evaluate_dataset(
            kind,
            path,
            max_samples=args.max_samples,
            rng=args.seed,
            progress=progress,
            min_landmarks=args.min_landmarks,
        )
    else:
        presets: dict[str, Callable[[], ev.SweepConfig]] = {
            "quick": ev.SweepConfig.quick,
            "default": ev.SweepConfig.default,
            "targets-spurious": ev.SweepConfig.targets_spurious,
            "targets-spurious-range": functools.partial(
                ev.SweepConfig.targets_spurious, sensing="range"
            ),
            "targets-spurious-range-0.9999": functools.partial(
                ev.SweepConfig.targets_spurious, sensing="range", confidence=0.9999
            ),
            "targets-crlb": ev.SweepConfig.targets_crlb,
            "targets-honest": ev.SweepConfig.targets_honest,
            "targets-honest-room": ev.SweepConfig.targets_honest_room,
        }
        config = presets[args.preset]()
        if args.trials is not None:
            if args.trials < 1:
                raise InputError(f"--trials must be >= 1, got {args.trials}")
            config = config.with_trials(args.trials)
        if args.workers < 1:
            raise InputError(f"--workers must be >= 1, got {args.workers}")
        res = ev.run_sweep(config, rng=args.seed, progress=progress, workers=args.workers)
    print(res.summary())
    written = ev.save_report(res, args.out)
    print(f"written: {', '.join(str(p) for p in written)}")
    return 0


def _cmd_evaluate_track(args: argparse.Namespace, settings: dict[str, Any]) -> int:
    from .evaluate.tracking import evaluate_mrclam_tracking, tracking_summary

    if args.kidnap < 0:
        raise InputError(f"--kidnap must be >= 0, got {args.kidnap}")
    if args.tracker_seeds:
        return _cmd_evaluate_track_seeds(args, settings)
    res, _ = evaluate_mrclam_tracking(
        args.dataset[1],
        kidnapped=args.kidnap,
        rng=args.seed,
        settings=settings,
        progress=not args.quiet,
        backward_s=args.backward,
    )
    print(tracking_summary(res))
    written = _write_track_report(res, args.out)  # (made by _cmd_evaluate before the run)
    print(f"written: {', '.join(map(str, written))}")
    return 0


def _write_track_report(res: TrackingReport, folder: Path) -> tuple[Path, Path]:
    """A tracking report's runs (CSV) and totals (JSON) in ``folder``."""
    csv_path, json_path = folder / "mrclam_track_runs.csv", folder / "mrclam_track.json"
    res.to_csv(csv_path)
    json_path.write_text(json.dumps(res.as_dict(), indent=1))
    return csv_path, json_path


def _cmd_evaluate_track_seeds(args: argparse.Namespace, settings: dict[str, Any]) -> int:
    """``--tracker-seeds``: the evaluation once per seed (each in ``OUT/seed-N``), then each
    figure's range over the seeds (``OUT/mrclam_track_seeds.md`` and ``.json``)."""
    from .evaluate.tracking import (
        evaluate_mrclam_tracking,
        seed_spread,
        seed_spread_table,
        tracking_summary,
    )
    from .track import preset, with_settings

    seeds = list(dict.fromkeys(args.tracker_seeds))  # each once, in the order given
    if "seed" in settings:
        raise InputError("--tracker-seeds sets the tracker's seed: leave seed out of --set")
    for seed in seeds:  # every seed refused before the first run, not after it
        with_settings(*preset("mrclam"), {**settings, "seed": seed})
    out: Path = args.out
    reports = {}
    for seed in seeds:
        print(f"== tracker seed {seed}")
        res, _ = evaluate_mrclam_tracking(
            args.dataset[1],
            kidnapped=args.kidnap,
            rng=args.seed,
            settings={**settings, "seed": seed},
            progress=not args.quiet,
            backward_s=args.backward,
        )
        print(tracking_summary(res))
        _write_track_report(res, make_folder(out / f"seed-{seed}", "--out"))
        reports[seed] = res
    spread = seed_spread(reports)
    table = seed_spread_table(spread)
    print(f"over the tracker's seeds {', '.join(map(str, seeds))}:")
    print(table)
    (out / "mrclam_track_seeds.md").write_text(table + "\n")
    # (null: NaN, no value, or inf, a median time that is "never")
    write_json(out / "mrclam_track_seeds.json", spread)
    print(f"written: {out / 'mrclam_track_seeds.md'}, {out / 'mrclam_track_seeds.json'}, seed-N/")
    return 0


def _setting(item: str) -> dict[str, Any]:
    """``NAME=VALUE`` of ``--set``, the value read as JSON."""
    import json

    name, sep, text = item.partition("=")
    if not sep or not name.strip():
        raise InputError(f"--set {shorten(item)}: expected NAME=VALUE, e.g. --set min_age_s=10")
    try:
        value = json.loads(text)
    except (json.JSONDecodeError, RecursionError, ValueError) as exc:
        raise InputError(
            f"--set {shorten(name)}=...: the value must be JSON (a number, true/false, null or a "
            f"list), got {shorten(text)}"
        ) from exc
    return {name.strip(): value}


def _cmd_track(args: argparse.Namespace) -> int:
    from .evaluate.common import progress_bar
    from .maps import LandmarkMap
    from .track import (
        load_groundtruth,
        load_odometry,
        track,
    )
    from .track.io import write_json_lines, write_tum, write_tum_truth

    sensor, motion, config = _preset_and_settings(args)
    lm = LandmarkMap.load(args.map)
    odo = load_odometry(args.odometry)
    if args.truth_out is not None and args.groundtruth is None:
        raise InputError("--truth-out writes the ground truth: give it with --groundtruth")
    truth = load_groundtruth(args.groundtruth) if args.groundtruth is not None else None
    frames = _frames_for_track(args, lm, truth is not None)
    if not frames:
        raise InputError(f"{args.frames}: no frames")
    if truth is not None and not (frames[0].t <= truth.t[-1] and truth.t[0] <= frames[-1].t):
        raise InputError(
            f"{args.groundtruth}: the ground truth (t = {float(truth.t[0]):.12g} to "
            f"{float(truth.t[-1]):.12g} s) and the frames (t = {frames[0].t:.12g} to "
            f"{frames[-1].t:.12g} s) share no time: are they stamped by one clock, in seconds?"
        )
    changes: dict[str, Any] = {}
    if args.sigma is not None:
        changes["sigma"] = float(np.deg2rad(args.sigma))
    if args.fov is not None:
        changes["fov"] = float(np.deg2rad(args.fov))
    if args.max_range is not None:
        changes["max_range"] = args.max_range
    if args.mount is not None:
        changes["mount"] = args.mount
    if changes:
        sensor = sensor.replace(**changes)
    initial: dict[str, Any] = {}
    if args.initial_sd is not None and args.initial_pose is None:
        raise InputError("--initial-sd is the spread of --initial-pose: give the pose too")
    if args.initial_pose is not None:
        sd_m, sd_h = args.initial_sd if args.initial_sd is not None else INITIAL_SD
        initial = {
            "initial_pose": args.initial_pose,
            "initial_covariance": np.diag([sd_m**2, sd_m**2, sd_h**2]),
        }
    bar = progress_bar(len(frames), not args.quiet, "tracking")
    try:
        run = track(
            lm,
            odo,
            frames,
            sensor=sensor,
            motion=motion,
            config=config,
            progress=lambda n: bar.update(1),
            backward_s=args.backward,
            **initial,
        )
    finally:
        bar.close()
    est = run.estimates
    if args.out is not None:
        n = write_tum(args.out, est)
        log.info("%s: %d localized poses (TUM)", args.out, n)
    if args.truth_out is not None and truth is not None:
        n = write_tum_truth(args.truth_out, truth, [e.t for e in est])
        log.info("%s: %d true poses at the frames' times (TUM)", args.truth_out, n)
    if args.plot is not None:
        from .plot.track import plot_track

        plot_track(lm, est, args.plot, truth=truth, title=f"{args.frames.name}")
    if args.json:
        write_json_lines(sys.stdout, est)
        return 0
    span = est[-1].t - est[0].t
    print(
        f"{len(est)} frames over {span:.1f} s in {run.wall_s:.2f} s "
        f"({span / run.wall_s if run.wall_s > 0 else float('inf'):.0f}x real time; "
        f"{run.cpu_s:.2f} s CPU), "
        f"{run.searches} searches: localized {100 * run.share('localized'):.1f} %, "
        f"ambiguous {100 * run.share('ambiguous'):.1f} %, lost {100 * run.share('lost'):.1f} %"
    )
    if args.backward is not None:
        print(
            f"the pass backward ({args.backward:g} s before each sure frame) localized "
            f"{run.backward} of them; {run.given_up} localized at a place the forward pass "
            "gave up within 10 s are not"
        )
    first = next((e for e in est if e.localized), None)
    if first is not None:
        after = first.t - est[0].t
        print(f"first localized at t = {first.t:.3f} s ({after:.1f} s after the first frame)")
    kid = [e.t for e in est if e.kidnapped]
    if kid:
        print(f"kidnapping flagged at t = {', '.join(f'{x:.1f}' for x in kid[:10])}")
    if truth is not None:
        from .evaluate.tracking import errors_against

        ok, d_pos, d_hdg = errors_against(truth, est)
        loc = np.array([e.localized for e in est])
        # (Localized frames outside the ground truth's time have no error to count.)
        scored = loc & np.isfinite(d_pos)
        if scored.any():
            beyond = int(loc.sum() - scored.sum())
            print(
                f"against the ground truth: localized and within 0.3 m / 5 deg "
                f"{100 * np.mean(ok[scored]):.1f} % of localized frames; position RMSE "
                f"{np.sqrt(np.mean(d_pos[scored] ** 2)):.3f} m, heading RMSE "
                f"{np.sqrt(np.mean(d_hdg[scored] ** 2)):.2f} deg"
                + (
                    f" ({beyond} localized frames outside the ground truth's time)"
                    if beyond
                    else ""
                )
            )
        elif loc.any():
            print(
                f"against the ground truth: none of the {int(loc.sum())} localized frames lies "
                f"within its time (t = {float(truth.t[0]):.12g} to {float(truth.t[-1]):.12g} s)"
            )
        said = _what_the_data_allow(lm, odo, frames, truth, sensor, motion, config, est[0].t)
        if said:
            print(said)
    print(_last_frame_line(est[-1]))
    if sensor.mount is not None:
        x, y, yaw = sensor.mount
        print(
            f"(the robot's poses; the sensor at x = {x:.3f} m, y = {y:.3f} m, "
            f"yaw = {np.rad2deg(yaw):.2f} deg on it)"
        )
    return 0


def _last_frame_line(last: Any) -> str:
    """The summary's last line: the last estimate's state, pose, when it was last localized
    (if it is not now) and confidence, and its reason."""
    where = "no pose"
    if last.pose is not None:
        p = last.pose
        where = f"x = {p.x:.3f} m, y = {p.y:.3f} m, theta = {np.rad2deg(p.theta):.2f} deg"
    if not last.localized and last.since_localized is not None:
        where += f", last localized {last.since_localized:.1f} s before"
    if last.confidence is not None:
        where += f", confidence {last.confidence:.4f}"
    return f"last frame: {last.state.value}: {where} ({last.reason})"


def _frames_for_track(args: argparse.Namespace, lm: Any, with_truth: bool) -> list[Any]:
    """The frames of ``omniloc track``: with a ground truth, an MRCLAM frames file's landmark
    ids are kept as each bearing's truth (for the bound; the tracker never reads them),
    unless the map does not hold them all."""
    from .track import load_frames

    if with_truth:
        ids = {str(i): k for k, i in enumerate(lm.ids)}
        try:
            return load_frames(args.frames, degrees=args.degrees, landmark_ids=ids)
        except InputError:
            pass  # an id the map lacks (or a bad file: read again below, and refused there)
    return load_frames(args.frames, degrees=args.degrees)


def _what_the_data_allow(
    lm: Any,
    odo: Any,
    frames: list[Any],
    truth: Any,
    sensor: Any,
    motion: Any,
    config: Any,
    t0: float,
) -> str | None:
    """The summary's line on what the recording allows a localizer told each bearing's
    landmark, under the tracker's own models (:mod:`omniloc.evaluate.bounds`); None when
    the frames carry no landmark truth, or the bound cannot be computed (said in the log)."""
    from .errors import OmnilocError
    from .evaluate.bounds import bearing_information, stream_bound
    from .evaluate.tracking import whole_run

    if not any(f.truth for f in frames):
        return None
    share = float(config.core_share)  # the bearing errors as the tracker weighs them
    if share > 0:
        shares, sds = [share, 1.0 - share], [config.core_sigma, sensor.sigma]
    else:
        shares, sds = [1.0], [sensor.sigma]
    try:
        info = bearing_information(shares, sds)
        b = stream_bound(
            whole_run("run", lm, odo, frames, truth),
            motion,
            info,
            float(config.localized_probability),
            tol_m=float(config.tolerance_m),
            tol_heading=float(config.tolerance_heading),
            mount=sensor.mount,
        )
    except OmnilocError as exc:
        log.warning("what the data allow: not computed (%s)", exc)
        return None
    start = min(float(odo.t[0]), frames[0].t)
    if not np.isfinite(b.time_to_localize_s):
        return (
            "what the data allow (told each bearing's landmark, under the tracker's models): "
            "never sure enough to be localized in this recording"
        )
    first = start + b.time_to_localize_s
    return (
        f"what the data allow (told each bearing's landmark, under the tracker's models): "
        f"sure enough to be localized from t = {first:.3f} s ({first - t0:.1f} s after the "
        f"first frame), then in {100 * b.correct_after_rate:.1f} % of the frames"
    )


def _cmd_fit_motion(args: argparse.Namespace) -> int:
    import dataclasses

    from .io import write_text
    from .track import check_motion, estimate_motion

    odometry, truths = _odometry_and_truths(args)
    fit = estimate_motion(
        odometry[0] if len(odometry) == 1 else odometry,
        truths[0] if len(truths) == 1 else truths,
    )
    values = {f.name: getattr(fit.model, f.name) for f in dataclasses.fields(fit.model)}
    if len(odometry) > 1:
        counts = ", ".join(str(n) for n in fit.stretches_by_run)
        none = " (0: that run's odometry and truth share too little time)"
        print(
            f"{len(odometry)} runs pooled; the stretches each gave, in their order (before "
            f"outliers were left out): {counts}{none if 0 in fit.stretches_by_run else ''}"
        )
    if fit.jumps:
        print(
            f"{fit.jumps} stretches of the latency's length with a jump in the truth (a "
            "kidnapping, a tracking system's swap) left out of the latency and the scales"
        )
    print(
        f"fitted on {fit.stretches} stretches ({fit.left_out} left out as outliers): "
        f"the odometry's rows describe the motion {values['delay_s']:+.2f} s after their time "
        f"stamps, its velocities x {values['v_scale']:.3f}"
        + (
            f" less {100 * values['turn_slowdown']:.0f} % per rad/s of turn"
            if values["turn_slowdown"]
            else ""
        )
        + f", its turn rates x {values['w_scale']:.3f}"
    )
    for name, v in values.items():
        if name not in ("delay_s", "v_scale", "w_scale", "turn_slowdown"):
            print(f"  {name:<13} {v:.3g}")
    if any(v == 0.0 for v in values.values()):
        print(
            "  (0: the recording cannot tell that noise from none; the tracker needs some -- "
            "docs/tracking.md, 'Calibrating a robot of your own')"
        )
    try:
        check = check_motion(odometry, truths, fit.model)
    except InputError as exc:  # (a fit on stretches shorter than the check's 2 s)
        print(f"not checked in sample: {exc}")
    else:
        print(
            _motion_check_line(check, "of the runs it was fitted on (in sample)")
            + " (check it on other runs: omniloc check-motion --config SETTINGS.json)"
        )
    if args.out is not None:
        write_text(args.out, json.dumps(values, indent=1) + "\n", InputError)
        print(f"written: {args.out} (omniloc track --config {args.out})")
    return 0


def _motion_check_line(check: Any, where: str) -> str:
    """How often ``check``'s stretches lie inside the model's 50 % and 99 % regions."""
    share = {
        (part, p): 100 * check.inside(p, part)
        for part in ("position", "heading")
        for p in (0.5, 0.99)
    }
    where = f" {where}" if where else ""
    return (
        f"the truth inside the model's 50 % / 99 % regions over {check.start.size} stretches of "
        f"{check.length:g} s{where}: position {share['position', 0.5]:.1f} / "
        f"{share['position', 0.99]:.1f} %, heading {share['heading', 0.5]:.1f} / "
        f"{share['heading', 0.99]:.1f} %"
    )


def _odometry_and_truths(args: argparse.Namespace) -> tuple[list[Any], list[Any]]:
    """The runs of ``--odometry`` and ``--groundtruth``, one of each per run, read."""
    from .track import load_groundtruth, load_odometry

    if len(args.odometry) != len(args.groundtruth):
        raise InputError(
            f"{len(args.odometry)} --odometry and {len(args.groundtruth)} --groundtruth: give "
            "one ground-truth track per odometry file, in the same order"
        )
    odometry = [load_odometry(path) for path in args.odometry]
    return odometry, [load_groundtruth(path) for path in args.groundtruth]


#: Fewest stretches on which ``check-motion`` judges a model: with 100, the share inside an
#: honest model's 99 % regions falls below 95 % about once in two thousand checks.
MIN_MOTION_CHECK = 100


def _cmd_check_motion(args: argparse.Namespace) -> int:
    from .track import check_motion

    _, motion, _ = _preset_and_settings(args)
    odometry, truths = _odometry_and_truths(args)
    check = check_motion(odometry, truths, motion, length=args.length)
    for k, path in enumerate(args.odometry):
        run = check.of_run(k)
        if not run.start.size:
            print(f"{path}: no stretch of {args.length:g} s the odometry and the truth share")
            continue
        err = run.errors
        line = (
            f"{path}: {run.start.size} stretches, position error RMS "
            f"{float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1)))):.3f} m, heading "
            f"{float(np.degrees(np.sqrt(np.mean(err[:, 2] ** 2)))):.2f} deg"
        )
        if len(odometry) > 1:
            line += (
                f"; inside the 99 % regions: position {100 * run.inside(0.99, 'position'):.1f}"
                f" %, heading {100 * run.inside(0.99, 'heading'):.1f} %"
            )
        print(line)
    print(_motion_check_line(check, "in all" if len(odometry) > 1 else ""))
    low = check.inside(0.99, "position") < 0.95 or check.inside(0.99, "heading") < 0.95
    if check.start.size < MIN_MOTION_CHECK:
        print(
            f"{check.start.size} stretches: too few to tell a model too sure from an honest one "
            f"(at least {MIN_MOTION_CHECK}: a longer recording, or a shorter --length)"
        )
    elif low:
        print(
            "the model is too sure of this odometry: widen its noise (--set, e.g. turn_per_s "
            "or along_per_m) until its 99 % regions hold about 99 % of the stretches (or are "
            "the odometry and the truth of one run, on one clock?)"
        )
    else:
        print("the model's 99 % regions hold the truth in at least 95 % of the stretches")
    if args.plot is not None:
        from .plot.motion import plot_motion_check

        print(f"figure: {plot_motion_check(check, args.plot, title=_given(args))}")
    return 0


def _frames_and_truths(args: argparse.Namespace) -> tuple[list[Any], list[Any]]:
    """The runs of ``--frames`` and ``--groundtruth``, one of each per run, read."""
    from .track import load_frames, load_groundtruth

    if len(args.frames) != len(args.groundtruth):
        raise InputError(
            f"{len(args.frames)} --frames and {len(args.groundtruth)} --groundtruth: give one "
            "ground-truth track per frames file, in the same order"
        )
    frames = [load_frames(path, degrees=args.degrees) for path in args.frames]
    for path, run in zip(args.frames, frames, strict=True):
        if not run:
            raise InputError(f"{path}: no frames")
    return frames, [load_groundtruth(path) for path in args.groundtruth]


def _sensor_check_line(check: Any, where: str) -> str:
    """How often ``check``'s bearing errors lie inside the model's 50 % and 99 % regions."""
    where = f" {where}" if where else ""
    return (
        f"the bearing errors inside the model's 50 % / 99 % regions over {check.errors.size} "
        f"bearings{where}: {100 * check.inside(0.5):.1f} / {100 * check.inside(0.99):.1f} %"
    )


def _reported(check: Any) -> str:
    """The share of the landmarks plainly in view that ``check``'s frames reported, said."""
    if not check.visible.sum():
        return "no landmark plainly in view"
    return f"{100 * check.detected():.1f} % of the landmarks in view reported"


#: Fewest bearings on which ``check-sensor`` judges a model (as ``check-motion``'s
#: stretches; a recording's errors repeat from frame to frame, so many more are worth less
#: than they look).
MIN_SENSOR_CHECK = 100
#: Below this share of the errors inside its 50 % regions, ``check-sensor`` calls a model too
#: sure at its centre (a sharp core that the bearings do not have).
MIN_SENSOR_HALF = 0.4


def _cmd_check_sensor(args: argparse.Namespace) -> int:
    from .maps import LandmarkMap
    from .track import check_sensor

    sensor, _, config = _preset_and_settings(args)
    frames, truths = _frames_and_truths(args)
    lm = LandmarkMap.load(args.map)
    check = check_sensor(
        lm,
        frames[0] if len(frames) == 1 else frames,
        truths[0] if len(truths) == 1 else truths,
        sensor,
        config,
        gate=float(np.deg2rad(args.gate)),
        frame_period_s=args.frame_period,
    )
    for k, path in enumerate(args.frames):
        run = check.of_run(k)
        if not run.errors.size:
            print(f"{path}: no bearing within {args.gate:g} deg of a landmark in view of the truth")
            continue
        line = (
            f"{path}: {run.errors.size} bearings within {args.gate:g} deg of a landmark (their "
            f"median {np.rad2deg(run.offset[0]):+.2f} deg left out: a turn of the camera, which "
            f"the heading takes in), {run.frame_run.size} frames: {_reported(run)}, "
            f"{run.clutter_per_frame():.2f} bearings a frame taken as clutter"
        )
        if len(frames) > 1:
            line += f"; inside the 99 % region: {100 * run.inside(0.99):.1f} %"
        print(line)
    measured = f"{check.detected():.3f}" if check.visible.sum() else "none in view"
    print(
        f"the model: p_detect {check.p_detect:.3f} (measured {measured}), clutter "
        f"{check.clutter_rate:.3f} bearings a frame (measured {check.clutter_per_frame():.3f})"
    )
    print(_sensor_check_line(check, "in all" if len(frames) > 1 else ""))
    if check.errors.size < MIN_SENSOR_CHECK:
        print(
            f"{check.errors.size} bearings: too few to tell a model too sure from an honest one "
            f"(at least {MIN_SENSOR_CHECK}: a longer recording)"
        )
    elif check.inside(0.99) < 0.95:
        print(
            "the model is too sure of these bearings: widen it (--set sigma=..., the tail of a "
            "core_share mixture) until its 99 % regions hold about 99 % of the errors (or do "
            "the frames, the truth and the sensor's mount belong together?)"
        )
    elif check.inside(0.5) < MIN_SENSOR_HALF:
        print(
            f"the model is too sure of these bearings at its centre: its 50 % regions hold "
            f"{100 * check.inside(0.5):.1f} % of the errors (a core too sharp or too large a "
            "share: --set core_sigma=..., core_share=...)"
        )
    else:
        print(
            "the model's 99 % regions hold at least 95 % of the bearing errors, its 50 % "
            f"regions at least {100 * MIN_SENSOR_HALF:.0f} %"
        )
    if args.plot is not None:
        from .plot.sensor import plot_sensor_check

        print(f"figure: {plot_sensor_check(check, args.plot, title=_given(args))}")
    return 0


def _cmd_fit_sensor(args: argparse.Namespace) -> int:
    from .io import write_text
    from .maps import LandmarkMap
    from .track import check_sensor, estimate_frame_sensor, estimate_mount, preset, with_settings

    frames, truths = _frames_and_truths(args)
    lm = LandmarkMap.load(args.map)
    fov = None if args.fov is None else float(np.deg2rad(args.fov))
    gate = float(np.deg2rad(args.gate))
    mount = args.mount
    runs = (
        lm,
        frames[0] if len(frames) == 1 else frames,
        truths[0] if len(truths) == 1 else truths,
    )
    view = {"fov": fov, "max_range": args.max_range, "gate": gate}
    if args.fit_mount:
        seat = estimate_mount(*runs, **view, initial=args.mount)
        mount = seat.mount
        naive = "" if seat.bootstrapped else ", from the least squares alone: likely too small"
        print(
            f"mount  x {seat.mount[0]:.3f} m, y {seat.mount[1]:.3f} m, yaw "
            f"{np.rad2deg(seat.mount[2]):.2f} deg (standard errors {seat.sd[0]:.3f} m, "
            f"{seat.sd[1]:.3f} m, {np.rad2deg(seat.sd[2]):.2f} deg{naive}; {seat.matched} of "
            f"{seat.bearings} bearings within {args.gate:g} deg of a landmark; omniloc track "
            f"--mount {seat.mount[0]:.3f},{seat.mount[1]:.3f},{np.rad2deg(seat.mount[2]):.2f})"
        )
    fit = estimate_frame_sensor(*runs, **view, frame_period_s=args.frame_period, mount=mount)
    print(
        f"{fit.frames} frames with a true pose, {fit.matched} of their {fit.bearings} bearings "
        f"within {args.gate:g} deg of a landmark"
    )
    if args.frame_period is not None:
        print(
            f"  of them {fit.empty_frames} saw nothing (gaps of the log, at one frame per "
            f"{args.frame_period:g} s): the rates below are per camera frame (omniloc track "
            "--set nonempty_frames=true)"
        )
    print(
        f"  sigma         {np.rad2deg(fit.sigma):.3f} deg (the robust spread; real cameras' "
        "tails are heavier: the mrclam preset takes 1 deg for a robust 0.3-0.7)"
    )
    print(f"  turn_noise_s  {fit.turn_noise_s:.3f} s (extra noise per rad/s of turn)")
    print(f"  p_detect      {fit.p_detect:.3f} (of the landmarks in view)")
    print(f"  clutter       {fit.clutter:.3f} bearings per frame")
    table = ",".join(f"{v:.2f}" for v in fit.clutter_by_detections)
    print(
        f"  by landmarks reported (1, 2, ...): {table} (single frames, where clutter comes "
        f"with the landmarks: omniloc localize --clutter-by-detections {table})"
    )
    if fit.core_share > 0:
        print(
            f"  core and tail  {100 * fit.core_share:.0f} % at {np.rad2deg(fit.core_sigma):.2f} "
            f"deg, {100 * (1 - fit.core_share):.0f} % at {np.rad2deg(fit.tail_sigma):.2f} deg "
            f"(EM; omniloc track --set core_share={fit.core_share:.2f} "
            f"--set core_sigma={fit.core_sigma:.4f} --set sigma={fit.tail_sigma:.4f} "
            "--set core_update=false)"
        )
    else:
        print("  core and tail  one Gaussian fits as well (no sharp core)")
    if fit.bias_by_bearing:
        bins = ", ".join(
            f"{np.rad2deg(lo):+.0f}..{np.rad2deg(hi):+.0f} {np.rad2deg(m):+.2f}"
            for lo, hi, m, _ in fit.bias_by_bearing
        )
        print(
            f"  by bearing    {bins} deg (median error where the landmark was seen, around "
            "the median: a pattern is a camera calibration off, which no setting takes in)"
        )
    settings: dict[str, Any] = fit.mixture_settings() if args.mixture else fit.settings()
    if mount is not None:
        settings["mount"] = list(mount)  # (the tracker needs it too)
    fitted = with_settings(*preset("generic"), settings)
    # (The rates are per camera frame only where the log's gaps held frames that saw nothing.)
    period = args.frame_period if settings.get("nonempty_frames") else None
    try:
        check = check_sensor(lm, *runs[1:], fitted[0], fitted[2], gate=gate, frame_period_s=period)
    except InputError as exc:  # (the settings are still written)
        print(f"not checked in sample: {exc}")
    else:
        print(
            _sensor_check_line(check, "of the runs it was fitted on (in sample)")
            + f" under the settings {'--mixture writes' if args.mixture else '--out writes'} "
            "(check them on other runs: omniloc check-sensor --config SETTINGS.json)"
        )
    if args.out is not None:
        write_text(args.out, json.dumps(settings, indent=1) + "\n", InputError)
        print(f"written: {args.out} (omniloc track --config {args.out})")
    return 0


def _since_or_nan(estimate: Any) -> float:
    """An estimate's ``since_localized``, NaN for None (never localized)."""
    return np.nan if estimate.since_localized is None else float(estimate.since_localized)


def _cmd_fit_confidence(args: argparse.Namespace) -> int:
    from .evaluate.common import calibration
    from .evaluate.tracking import errors_against, hypothesis_outcomes
    from .io import write_text
    from .maps import LandmarkMap
    from .track import (
        fit_confidence,
        load_frames,
        load_groundtruth,
        load_odometry,
        preset,
        track,
        with_settings,
    )
    from .track.confidence import held_out_confidence, held_out_table, is_recent

    n = len(args.odometry)
    if not n == len(args.frames) == len(args.groundtruth):
        raise InputError(
            f"{n} --odometry, {len(args.frames)} --frames and {len(args.groundtruth)} "
            "--groundtruth: give the three files of each run, in the same order"
        )
    sensor, motion, config = preset(args.preset)
    settings = {
        **_settings(args),
        # (The tables being fitted must not be read from the settings: they change no
        # decision, and the fit reads the model's own probability.)
        "confidence_localized": None,
        "confidence_ambiguous": None,
        "confidence_recent": None,
        "confidence_hypothesis": None,
        "confidence_hypothesis_recent": None,
        "confidence_backward": None,
    }
    sensor, motion, config = with_settings(sensor, motion, config, settings)
    span = config.confidence_recent_s
    lm = LandmarkMap.load(args.map)
    runs = [
        (load_odometry(o), load_frames(f, degrees=args.degrees), load_groundtruth(g))
        for o, f, g in zip(args.odometry, args.frames, args.groundtruth, strict=True)
    ]
    states: list[str] = []
    probs: list[float] = []
    right: list[bool] = []
    since: list[float] = []
    back: list[bool] = []
    group: list[int] = []
    h_weight: list[float] = []
    h_right: list[bool] = []
    h_group: list[int] = []
    h_since: list[float] = []
    tol_hdg = float(np.rad2deg(config.tolerance_heading))
    for k, (odo, frames, truth) in enumerate(runs):
        if not frames:
            raise InputError(f"{args.frames[k]}: no frames")
        est = track(
            lm, odo, frames, sensor=sensor, motion=motion, config=config, backward_s=args.backward
        ).estimates
        ok, d_pos, _ = errors_against(truth, est, config.tolerance_m, tol_hdg)
        true, _ = truth.at(np.array([e.t for e in est]))
        hyps = hypothesis_outcomes(
            est, true, np.asarray(np.isfinite(true).all(axis=1)), config.tolerance_m, tol_hdg
        )
        h_weight += hyps.weights.tolist()
        h_right += hyps.right.tolist()
        h_group += [k] * hyps.right.size
        h_since += [_since_or_nan(est[i]) for i in hyps.frame.tolist()]
        for e, r, d in zip(est, ok, d_pos, strict=True):
            if e.probability is None or not np.isfinite(d):
                continue  # (lost, or no truth at that time)
            states.append(e.state.value)
            probs.append(e.probability)
            right.append(bool(r))
            since.append(_since_or_nan(e))
            back.append(bool(e.backward))
            group.append(k)
    if not states:
        raise InputError("no frame with a pose and a ground truth: nothing to fit on")
    fit = fit_confidence(
        states,
        probs,
        right,
        since_localized=since,
        recent_s=span,
        hypothesis_weights=h_weight if h_weight else None,
        hypothesis_right=h_right if h_weight else None,
        hypothesis_since_localized=h_since if h_weight else None,
        backward=back if args.backward is not None else None,
    )
    tol = (
        f"within {config.tolerance_m:g} m and {np.rad2deg(config.tolerance_heading):g} deg of "
        "the truth"
    )
    kinds = [
        ("localized", "localized" if args.backward is None else "localized by the forward pass"),
        ("recent", f"ambiguous within {span:g} s of a localized frame"),
        ("ambiguous", "ambiguous, other"),
    ]
    if args.backward is not None:
        kinds.append(("backward", "localized by the pass backward"))
    for name, what in kinds:
        print(
            f"{what}: {fit.frames[name]} frames, {fit.right[name]} of them {tol}; table of "
            f"{len(getattr(fit, name) or ())} knots"
        )
    print(
        f"the tracker's own probability against the truth: expected calibration error "
        f"{calibration(probs, right).ece:.3f} over {len(probs)} frames"
    )
    if h_weight:
        print(
            f"every hypothesis's weight against the truth: expected calibration error "
            f"{calibration(h_weight, h_right).ece:.3f} over {len(h_weight)} hypotheses "
            f"({fit.frames['hypothesis_recent']} of them in frames within {span:g} s of a "
            "localized one: a table of their own)"
        )
    if n > 1:
        held = held_out_confidence(
            states,
            probs,
            right,
            group,
            since_localized=since,
            recent_s=span,
            backward=back if args.backward is not None else None,
        )
        use = np.isfinite(held)
        print(
            f"tables fitted on the other runs, each run's frames: expected calibration error "
            f"{calibration(held[use].tolist(), np.asarray(right)[use].tolist()).ece:.3f} over "
            f"{int(use.sum())} frames (what to expect on a run not fitted on)"
        )
        if h_weight and len(set(h_group)) > 1:
            h_held = held_out_table(h_weight, h_right, h_group, contexts=is_recent(h_since, span))
            use = np.isfinite(h_held)
            print(
                f"  and each run's hypotheses: expected calibration error "
                f"{calibration(h_held[use].tolist(), np.asarray(h_right)[use].tolist()).ece:.3f}"
                f" over {int(use.sum())} hypotheses"
            )
    else:
        print(
            "one run: the tables are fitted on the frames they would be checked on; give "
            "several runs to see how they do on a run they were not fitted on"
        )
    if args.out is not None:
        write_text(args.out, json.dumps(fit.settings(), indent=1) + "\n", InputError)
        print(f"written: {args.out} (omniloc track --config {args.out})")
    return 0


_COMMANDS = {
    "localize": _cmd_localize,
    "bearings": _cmd_bearings,
    "demo": _cmd_demo,
    "evaluate": _cmd_evaluate,
    "track": _cmd_track,
    "fit-motion": _cmd_fit_motion,
    "check-motion": _cmd_check_motion,
    "fit-sensor": _cmd_fit_sensor,
    "check-sensor": _cmd_check_sensor,
    "fit-confidence": _cmd_fit_confidence,
}


#: Options whose value may start with a minus sign followed by a digit (a negative X):
#: argparse takes ``--initial-pose -1,2,30`` for an option followed by another option
#: (only plain numbers such as ``-1`` or ``-0.5`` count as negative numbers for it).
NEGATIVE_VALUE_OPTIONS = frozenset({"--initial-pose", "--initial-sd", "--mount"})


def _join_negative_values(argv: Sequence[str]) -> list[str]:
    """``argv`` with each ``OPTION VALUE`` pair of :data:`NEGATIVE_VALUE_OPTIONS` whose value
    starts with ``-`` and a digit (or ``-.`` and a digit) written ``OPTION=VALUE``, which
    argparse reads as the option's value."""
    out: list[str] = []
    k = 0
    while k < len(argv):
        a = argv[k]
        if a == "--":  # (the rest are arguments, as given)
            return [*out, *argv[k:]]
        if (
            a in NEGATIVE_VALUE_OPTIONS
            and k + 1 < len(argv)
            and re.match(r"-\.?\d", argv[k + 1]) is not None
        ):
            out.append(f"{a}={argv[k + 1]}")
            k += 2
            continue
        out.append(a)
        k += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status.

    Output piped into a reader that stops early (``omniloc ... | head``) ends the command
    quietly with status 1, as Python's documentation recommends for a broken pipe.
    """
    try:
        status = _run(argv)
        sys.stdout.flush()  # a closed pipe shows here, not at the interpreter's exit
    except BrokenPipeError:
        # Nothing more can be written: point stdout at devnull so that the flush at exit
        # does not raise again (not possible where stdout has no file, e.g. under capture).
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 1
    return status


def _run(argv: Sequence[str] | None) -> int:
    parser = _build_parser()
    try:
        args = parser.parse_args(_join_negative_values(sys.argv[1:] if argv is None else argv))
    except OmnilocError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    level = logging.WARNING if args.quiet else (logging.INFO if args.verbose else logging.WARNING)
    if args.verbose > 1:
        level = logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return _COMMANDS[args.command](args)
    except OmnilocError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
