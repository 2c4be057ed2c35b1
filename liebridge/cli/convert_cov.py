"""``liebridge convert-cov``: a covariance (or information matrix) at a pose, between conventions.

``Σ_B = M Σ_A Mᵀ`` with ``M = tangent_map(X, A, B)`` (``method="linear"``; exact when
:func:`liebridge.is_exactly_linear` holds), or sigma points through ``B.local(X, A.retract(X, ·))``
(``method="unscented"``); information: ``Λ_B = M⁻ᵀ Λ_A M⁻¹``. Input from the command line, a text
file or ``.npy``; batches (``(N, 4, 4)`` poses with ``(N, 6, 6)`` or one ``(6, 6)``) broadcast.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..conventions import Convention, group_input
from ..conventions.convert import convert_covariance, convert_information, is_exactly_linear
from ..io import poses as layouts
from ..io.atomic import atomic_write
from ._common import (
    CLIError,
    array_argument,
    check_output_path,
    convention_arg,
    format_matrix,
    option_value,
    save_npy,
    tangent_label,
)

__all__ = ["add_parser", "read_pose", "read_square"]

_QUAT_LAYOUTS = ("xyz_qxyzw", "xyz_qwxyz", "qxyzw_xyz", "qwxyz_xyz")


def read_pose(text: str, layout: str | None) -> FloatArray:
    """Poses ``(..., 4, 4)`` (or rotations ``(..., 3, 3)`` with ``layout="rotation"``)."""
    arr, from_file = array_argument(text, "--pose")
    if layout is None:
        if arr.shape[-2:] == (4, 4) or (not from_file and arr.size == 16):
            layout = "matrix"
        else:
            raise CLIError(
                f"--pose: {arr.size} numbers (shape {arr.shape}) need --layout "
                f"({', '.join(layouts.layouts())} or rotation): liebridge never guesses a "
                "quaternion order"
            )
    if layout == "rotation":
        shape: tuple[int, ...] = (3, 3)
    elif layout in layouts.layouts():
        shape = {"matrix": (4, 4), "kitti": (12,)}.get(layout, (7,))
    else:
        raise CLIError(
            f"--layout: unknown layout {layout!r} (known: {', '.join(layouts.layouts())}, rotation)"
        )
    n = int(np.prod(shape))
    if arr.size % n:
        raise CLIError(f"--pose: layout {layout!r} needs {n} numbers per pose, got {arr.size}")
    if from_file and arr.shape[arr.ndim - len(shape) :] == shape:
        batch = arr.shape[: arr.ndim - len(shape)]
    else:
        batch = () if arr.size == n else (arr.size // n,)
    arr = arr.reshape(*batch, *shape)
    try:
        if layout == "rotation":
            return group_input(arr, "--pose")
        return layouts.to_matrix(arr, layout=layout)
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith(("x: ", "x ")):
            msg = "--pose" + msg[1:]
        raise CLIError(msg) from None


def read_square(text: str, dim: int, what: str) -> FloatArray:
    """Read ``(..., dim, dim)``: ``dim²`` numbers (row-major), ``dim`` (the diagonal), or a file."""
    arr, from_file = array_argument(text, what)
    if from_file and arr.ndim >= 2 and arr.shape[-2:] == (dim, dim):
        return arr
    if arr.size == dim:
        return np.diag(arr.reshape(-1))
    if arr.size % (dim * dim) == 0:
        out = arr.reshape(-1, dim, dim)
        return out[0] if out.shape[0] == 1 else out
    raise CLIError(
        f"{what}: expected {dim * dim} numbers (a {dim}×{dim} matrix, row-major), {dim} (its "
        f"diagonal) or a file holding (..., {dim}, {dim}); got {arr.size} numbers"
    )


def _header(a: Convention, b: Convention, args: argparse.Namespace, exact: bool) -> list[str]:
    what = "information" if args.information else "covariance"
    if exact:
        how = "exact (the tangents differ by side, order, scale or translation frame: linear)"
    elif args.method == "unscented":
        how = (
            "unscented (fifth-degree sigma points through the exact change of tangent: the "
            "chart or rotation coordinates change, which is not linear)"
        )
    else:
        how = (
            "first order (chart or rotation coordinates change: not linear); try --method "
            "unscented for a large covariance"
        )
    return [
        f"# {what} from {a.name} [{tangent_label(a)}]",
        f"# to {b.name} [{tangent_label(b)}]",
        f"# conversion: {how}",
    ]


#: Entries whose correlation ``|A_ij| / √(A_ii A_jj)`` is below this are rounding residue of an
#: exact zero (a permutation, rotations and isotropic blocks give 1e-19 where 0 belongs): printed
#: as 0. About 16 ulps of 1: a product ``R·Σ·Rᵀ`` rounds each entry to a few ulps of its scale.
ZERO_CORRELATION = 16 * float(np.finfo(np.float64).eps)


def snap_rounding_zeros(A: FloatArray) -> tuple[FloatArray, int]:
    """Return ``A`` with its rounding-level entries set to 0, and how many were set.

    Rounding level: see :data:`ZERO_CORRELATION`. ``A`` itself is not modified.
    """
    d = np.sqrt(np.abs(np.diagonal(A, axis1=-2, axis2=-1)))
    scale = d[..., :, None] * d[..., None, :]
    small = (np.abs(A) <= ZERO_CORRELATION * scale) & (A != 0)
    return np.where(small, 0.0, A), int(small.sum())


def _run(args: argparse.Namespace) -> int:
    a, b = convention_arg(args.src, "--from"), convention_arg(args.dst, "--to")
    out_path = None
    if args.out is not None:
        out_path = check_output_path(args.out, "--out", inputs=[args.pose, args.cov])
    if args.information and args.method == "unscented":
        raise CLIError(
            "--method unscented applies to covariances; convert the inverse of the information "
            "matrix instead"
        )
    X = read_pose(args.pose, args.layout)
    n = 3 if X.shape[-2:] == (3, 3) else 6
    what = "--cov" if not args.information else "--cov (information)"
    A = read_square(args.cov, n, what)
    try:
        np.broadcast_shapes(X.shape[:-2], A.shape[:-2])
    except ValueError:
        raise CLIError(
            f"--pose batch {X.shape[:-2]} and --cov batch {A.shape[:-2]} do not broadcast"
        ) from None
    name = "info" if args.information else "cov"
    try:
        if args.information:
            out = convert_information(A, X, a, b)
        else:
            out = convert_covariance(A, X, a, b, method=args.method)
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith(f"{name}:"):
            msg = "--cov" + (" (information)" if args.information else "") + msg[len(name) :]
        raise CLIError(msg) from None
    exact = is_exactly_linear(a, b)
    header = _header(a, b, args, exact)
    shown, n_snapped = snap_rounding_zeros(out)
    if n_snapped:
        header.append(
            f"# {n_snapped} entries at rounding level (|correlation| ≤ {ZERO_CORRELATION:.1e}) "
            "printed as 0 (exact zeros; --out FILE.npy keeps the raw doubles)"
        )
    if out.ndim == 2:
        body = format_matrix(shown)
    else:
        flat = shown.reshape(-1, n, n)
        body = "\n\n".join(f"# [{k}]\n{format_matrix(m)}" for k, m in enumerate(flat))
    text = "\n".join([*header, body]) + "\n"
    if out_path is None:
        print(text, end="")
    elif out_path.suffix.lower() == ".npy":
        save_npy(out_path, out, "--out")
        print(f"wrote {out_path} (shape {out.shape}) — {header[2][2:]}")
    else:
        with atomic_write(out_path, "w", name="--out") as fh:
            fh.write(text)
        print(f"wrote {out_path} — {header[2][2:]}")
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge convert-cov``."""
    p = sub.add_parser(
        "convert-cov",
        help="convert a covariance (or information matrix) at a pose between conventions",
        description="Convert a covariance (or, with --information, an information matrix) "
        "of a perturbation at a pose from one convention's tangent to another's: "
        "Σ_B = M Σ_A Mᵀ with M = liebridge.tangent_map(pose, A, B) (or sigma points with "
        "--method unscented); Λ_B = M⁻ᵀ Λ_A M⁻¹. Output: full-precision text on stdout, or "
        "--out FILE (.npy, or text).",
        epilog="Examples:\n"
        '  liebridge convert-cov --from gtsam --to ros --pose "1 2 3 0 0 0.3826834 0.9238795" '
        '--layout xyz_qxyzw --cov "1e-4 1e-4 1e-4 0.01 0.01 0.01"\n'
        "  liebridge convert-cov --from gtsam --to barfoot --pose T.npy --cov marginals.npy "
        "--out barfoot.npy",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--from", dest="src", required=True, metavar="A", help="source convention")
    p.add_argument("--to", dest="dst", required=True, metavar="B", help="target convention")
    p.add_argument(
        "--pose",
        required=True,
        metavar="POSE",
        help="the pose the tangents live at: numbers (quoted), or a .npy/.txt file; a 4×4 "
        "matrix (16 numbers, row-major) or --layout; (N, ...) files are batches",
    )
    p.add_argument(
        "--layout",
        metavar="LAYOUT",
        help=f"how --pose stores the pose: {', '.join(layouts.layouts())}, or rotation "
        "(a 3×3 rotation matrix; then the covariance is 3×3). Required for anything but a 4×4 "
        "matrix: the quaternion order is never guessed",
    )
    p.add_argument(
        "--cov",
        required=True,
        metavar="COV",
        help="the covariance in A's tangent order: 36 numbers (row-major), 6 numbers (the "
        "diagonal: variances, not standard deviations), or a .npy/.txt file ((6, 6) or "
        "(N, 6, 6))",
    )
    p.add_argument(
        "--information",
        action="store_true",
        help="--cov is an information matrix (inverse covariance)",
    )
    p.add_argument(
        "--method",
        type=option_value,
        choices=("linear", "unscented"),
        default="linear",
        help="linear (M Σ Mᵀ, default) or unscented (sigma points through the exact map; for "
        "large covariances across a chart change)",
    )
    p.add_argument(
        "--out", metavar="FILE", help="write to FILE (.npy, else text) instead of stdout"
    )
    p.set_defaults(func=_run)
