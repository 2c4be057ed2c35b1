"""``liebridge registration info``: a saved registration result in any convention.

The ``.npz`` file holds ``T`` (``T_target_source``, 4×4), ``H`` or ``information`` (6×6, over the
tangent of ``library``), ``library`` (``open3d``, ``small_gicp``, ``kiss_icp``,
``hdl_graph_slam`` or any preset name) and optionally ``sigma`` (the residual standard deviation
for unit-noise matrices: required for Open3D's). The information and covariance are printed in
the ``--to`` convention's tangent, as ``convert-cov`` does.
"""

from __future__ import annotations

import argparse
import zipfile
from typing import Any

import numpy as np

from ..registration import RegistrationPose, from_open3d, from_small_gicp
from ._common import CLIError, convention_arg, format_matrix, tangent_label
from .convert_cov import snap_rounding_zeros

__all__ = ["add_parser"]


def _load(path: str) -> dict[str, Any]:
    try:
        with np.load(path, allow_pickle=False) as z:
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise CLIError(f"FILE: {path} is a .npy array, not a .npz archive of named arrays")
            return {k: z[k] for k in z.files}
    except (zipfile.BadZipFile, ValueError) as exc:
        raise CLIError(f"FILE: {path} is not a readable .npz archive ({exc})") from None


def _info(args: argparse.Namespace) -> int:
    d = _load(args.file)
    if "T" not in d:
        raise CLIError(f"FILE: no array 'T' (T_target_source) in {args.file} (has: {sorted(d)})")
    keys = [k for k in ("H", "information") if k in d]
    if len(keys) != 1:
        raise CLIError(
            f"FILE: expected exactly one of 'H' or 'information' in {args.file}, found "
            f"{keys or 'neither'}"
        )
    library = args.library
    if library is None:
        if "library" not in d:
            raise CLIError(f"FILE: no 'library' entry in {args.file}; pass --library")
        library = str(d["library"])
    src = convention_arg(library, "--library")
    dst = convention_arg(args.to, "--to")
    sigma = args.sigma if args.sigma is not None else d.get("sigma")
    if sigma is not None:
        sigma = float(np.asarray(sigma))
    T, H = d["T"], d[keys[0]]
    if src.name == "open3d":
        if sigma is None:
            raise CLIError(
                "--sigma: Open3D's information matrix has unit noise; give the residual standard "
                "deviation (m) with --sigma or a 'sigma' entry in the file"
            )
        est = from_open3d(H, T, sigma=sigma, convention=dst)
    elif src.name == "small_gicp":
        est = from_small_gicp((T, H), sigma, convention=dst)
    else:
        H = np.asarray(H, dtype=np.float64)
        s2 = 1.0 if sigma is None else sigma * sigma
        est = RegistrationPose(T, H / s2, src, sigma=np.sqrt(s2)).to(dst)  # type: ignore[assignment]
    info = np.linalg.inv(est.cov)
    info = 0.5 * (info + info.T)
    scale = "as stored" if sigma is None else f"divided by sigma² (sigma = {sigma!r} m)"
    print(f"# registration result from {src.name} [{tangent_label(src)}], {keys[0]} {scale}")
    print("# T_target_source")
    print(format_matrix(np.asarray(est.T)))
    print(f"# information in {dst.name} [{tangent_label(dst)}]")
    print(format_matrix(snap_rounding_zeros(info)[0]))
    print(f"# covariance in {dst.name}")
    print(format_matrix(snap_rounding_zeros(np.asarray(est.cov))[0]))
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge registration`` and its ``info`` subcommand."""
    p = sub.add_parser(
        "registration",
        help="point-cloud registration results (Open3D, small_gicp, KISS-ICP) in any convention",
        description="Point-cloud registration results.",
    )
    rsub = p.add_subparsers(dest="registration_command", metavar="SUBCOMMAND")
    i = rsub.add_parser(
        "info",
        help="print a saved registration result's information and covariance in a convention",
        description="Read FILE (.npz with T = T_target_source, H or information over LIBRARY's "
        "tangent, library, optional sigma) and print T, the information and the covariance in "
        "the --to convention's tangent. Open3D's information (left, (ω, t), unit noise) needs "
        "sigma; small_gicp's H (right, (ω, ρ)) is used as it is unless sigma is given.",
    )
    i.add_argument("file", metavar="FILE", help="the .npz file")
    i.add_argument("--to", default="gtsam", metavar="CONVENTION", help="default: gtsam")
    i.add_argument(
        "--library",
        default=None,
        metavar="NAME",
        help="override the file's 'library' (open3d, small_gicp, kiss_icp, hdl_graph_slam, ...)",
    )
    i.add_argument("--sigma", type=float, default=None, help="residual standard deviation (m)")
    i.set_defaults(func=_info)
    p.set_defaults(func=lambda _args: _missing())


def _missing() -> int:
    raise CLIError("missing SUBCOMMAND (info); see 'liebridge registration --help'")
