"""``liebridge extrinsics convert``: a camera–IMU extrinsic in another system's convention.

Reads FILE (a Kalibr camchain-imucam.yaml by default; any system of
:func:`liebridge.frames.system_names`, detected from its keys or given with ``--from-system``)
and prints the extrinsic as ``--to-system SYSTEM`` stores it: the matrix, its direction in words,
the frame names and the parameter in the system's own syntax. ``--format json`` prints exactly
one JSON object on stdout with ``system``, ``parameter``, ``T`` (4×4 rows), ``target_frame``,
``source_frame`` (``T`` maps ``source_frame`` coordinates to ``target_frame``), ``direction``,
``camera``, ``from_system``, ``snippet`` and, for OpenCV, ``rvec``/``tvec``; a time offset in
FILE (Kalibr ``timeshift_cam_imu``, ``t_imu = t_cam + shift``) is carried to the target's own key
(``timeshift_cam_imu``, ``td``, ``cam_time_offset_ns``) when it has one.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from ._common import CLIError, deprecated_alias, format_matrix

__all__ = ["add_parser"]


def _convert(args: argparse.Namespace) -> int:
    from ..frames import calibration as C

    try:
        to = C.system_format(args.to, "--to-system")
        src = None if args.source is None else C.system_format(args.source, "--from-system").system
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    path = Path(args.file)
    if not path.is_file():
        raise CLIError(f"FILE: no such file: {args.file}")
    try:
        parsed = C.CalibrationFile.read(path)  # parsed once for every reader below
        if src is None:
            src = parsed.system
            if src is None:
                raise CLIError(
                    f"{path}: cannot tell which system wrote it (no T_cam_imu, T_imu_cam, T_SC, "
                    "IMU.T_b_c1, body_T_camN or rvec/tvec found); give --from SYSTEM"
                )
        T_cam_imu = C.read_extrinsic(
            parsed, system=src, camera=args.camera, imu_frame=args.imu_frame
        )
        shift = C.read_timeshift(parsed, system=src, camera=args.camera)
    except ImportError as exc:
        raise CLIError(str(exc)) from None
    ext = C.export_extrinsic(T_cam_imu, to.system, timeshift_cam_imu=shift)
    snippet = C.format_parameter(ext, args.camera)
    if args.format == "json":
        out = ext.as_dict()
        out.update(camera=args.camera, from_system=src, snippet=snippet)
        print(json.dumps(out))
        return 0
    tf = ext.transform
    print(f"{to.system} {ext.parameter} (from {src} file {path}, camera {args.camera}):")
    print(format_matrix(tf.T + 0.0, "  "))
    print(f"frames: target {tf.target_frame}, source {tf.source_frame}")
    print(f"direction: {ext.direction}")
    print(f"storage: {to.storage}")
    if shift is not None:
        have = C.TIME_OFFSETS.get(to.system)
        where = f"{have[0]} = {ext.extra[have[0]]!r}" if have else f"none in {to.system}"
        print(f"time offset: t_imu = t_cam + {shift!r} s ({where})")
    print(f"use in {to.system}: {to.use}")
    print(f"source: {to.source}")
    print("snippet:")
    print(snippet.rstrip("\n"))
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge extrinsics`` and its ``convert`` subcommand."""
    from ..frames.calibration import SYSTEMS

    systems = ", ".join(SYSTEMS)
    p = sub.add_parser(
        "extrinsics",
        help="camera-IMU extrinsics between calibration conventions (Kalibr, OKVIS, ...)",
        description="Camera-IMU extrinsics between the conventions of calibration and VIO systems.",
    )
    esub = p.add_subparsers(dest="extrinsics_command", metavar="SUBCOMMAND")
    c = esub.add_parser(
        "convert",
        help="print a file's camera-IMU extrinsic as another system stores it",
        description="Read the camera-IMU extrinsic of FILE and print it as --to-system SYSTEM "
        "stores it (name, direction, frames, and a snippet in the system's syntax). "
        f"Systems: {systems}.",
    )
    c.add_argument("file", metavar="FILE", help="calibration file (Kalibr camchain-imucam.yaml...)")
    to = c.add_argument(
        "--to-system", dest="to", required=True, metavar="SYSTEM", help=f"one of: {systems}"
    )
    deprecated_alias(c, to, "--to")
    src = c.add_argument(
        "--from-system",
        dest="source",
        metavar="SYSTEM",
        default=None,
        help="FILE's system (default: detected from its keys)",
    )
    deprecated_alias(c, src, "--from")
    c.add_argument("--camera", default="cam0", help="which camera (cam0, cam1, ...; default cam0)")
    c.add_argument("--imu-frame", default="imu0", help="name of the IMU frame (default imu0)")
    c.add_argument("--format", choices=("text", "json"), default="text")
    c.set_defaults(func=_convert)
    p.set_defaults(func=lambda _args: _missing())


def _missing() -> int:
    raise CLIError("missing SUBCOMMAND (convert); see 'liebridge extrinsics --help'")
