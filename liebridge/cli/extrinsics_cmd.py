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

``--camera cam1`` prints the second camera as the target system keeps it: VINS-Fusion
``body_T_cam1``, ORB-SLAM3 ``Stereo.T_c1_c2`` (with ``IMU.T_b_c1`` in the snippet), the whole
OKVIS ``cameras`` and Basalt ``T_imu_cam`` lists (cam0 is read from FILE too). A key FILE lacks
is one line naming FILE and the key, exit status 2.
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path
from typing import Any

from ._common import CLIError, deprecated_alias, format_matrix, one_line, say

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
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", C.OrbSlam3PrecisionWarning)
            T_cam_imu = C.read_extrinsic(
                parsed, system=src, camera=args.camera, imu_frame=args.imu_frame
            )
        for w in caught:  # one line each on stderr, never Python's two-line warning format
            say(f"liebridge extrinsics convert: warning: {one_line(str(w.message))}")
        shift = C.read_timeshift(parsed, system=src, camera=args.camera)
        earlier = _earlier(C, parsed, src, to.system, args)
    except ImportError as exc:
        raise CLIError(str(exc)) from None
    try:
        ext = C.export_extrinsic(
            T_cam_imu,
            to.system,
            timeshift_cam_imu=shift,
            camera=args.camera,
            earlier_cameras=earlier,
        )
    except ValueError as exc:
        raise CLIError(f"--camera {args.camera} --to {to.system}: {exc}") from None
    snippet = C.format_parameter(ext)
    if args.format == "json":
        out = ext.as_dict()
        out.update(camera=args.camera, from_system=src, snippet=snippet)
        print(json.dumps(out))
        return 0
    tf = ext.transform
    if ext.parameter == C.ORBSLAM3_STEREO.parameter:  # the second camera, from the first
        to = C.ORBSLAM3_STEREO
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


def _earlier(C: Any, parsed: Any, src: str, to: str, args: argparse.Namespace) -> list[Any]:
    """``T_cam_imu`` of cam0 … cam(N−1) when ``to`` stores camera N with or relative to them.

    ORB-SLAM3 keeps the second camera as ``Stereo.T_c1_c2`` (from the first), OKVIS and Basalt
    keep every camera in one list: their snippet for ``cam1`` needs ``cam0`` from FILE too.
    """
    idx = int(args.camera[3:])  # read_extrinsic has checked the camN form
    if idx == 0 or to not in ("orbslam3", "okvis", "basalt"):
        return []
    if to == "orbslam3" and idx > 1:
        return []  # export_extrinsic says that ORB-SLAM3 keeps two cameras
    if src == "opencv":  # one rvec/tvec: reading "cam0" from it would give cam1 again
        raise CLIError(
            f"--to {to} --camera {args.camera} needs cam0's extrinsic too ({to} stores "
            f"{args.camera} with the earlier cameras), but an rvec/tvec file holds one camera"
        )
    out = []
    for k in range(idx):
        try:
            with warnings.catch_warnings():  # said once already, for the camera asked for
                warnings.simplefilter("ignore", C.OrbSlam3PrecisionWarning)
                T = C.read_extrinsic(parsed, system=src, camera=f"cam{k}", imu_frame=args.imu_frame)
            out.append(T)
        except ValueError as exc:
            raise CLIError(
                f"--to {to} --camera {args.camera} needs cam{k}'s extrinsic too ({to} stores "
                f"{args.camera} with the earlier cameras): {exc}"
            ) from None
    return out


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
