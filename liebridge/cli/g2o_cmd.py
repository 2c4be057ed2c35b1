"""``liebridge g2o convert``: rewrite a g2o file with its information in the other semantics.

``EDGE_SE3:QUAT`` information is defined by g2o over ``(t, quaternion vector part)``;
``gtsam.readG2o`` reads the same numbers as information over ``(v, ω)`` after a block swap, a
rotation weight 4× heavier (see :mod:`liebridge.io.g2o`). ``--information g2o:gtsam`` reads
IN by g2o's definition and writes OUT so that a GTSAM-semantics reader (``gtsam.readG2o``) gets
the same information: the rotation block ×1/4 and the cross blocks ×1/2 relative to IN;
``gtsam:g2o`` the other way. Every number is written at full precision (``repr``).
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

import numpy as np

from ._common import CLIError, check_output_path, option_value

__all__ = ["add_parser"]

_READINGS = ("g2o", "gtsam")


def _pair(text: str) -> tuple[str, str]:
    src, sep, dst = option_value(text).partition(":")
    if not sep or src not in _READINGS or dst not in _READINGS:
        raise argparse.ArgumentTypeError(
            f"expected FROM:TO with FROM and TO each g2o or gtsam (e.g. g2o:gtsam), got {text!r}"
        )
    return src, dst


def _convert(args: argparse.Namespace) -> int:
    from ..io import g2o as g2o_io

    src, dst = args.information
    from .optimize import resolve_dataset

    inp = resolve_dataset(args.input, "IN")  # a file, or a name in GTSAM's example data
    out = check_output_path(args.output, "OUT", inputs=[inp])
    g = g2o_io.read(inp, information=src, edge3=args.edge3)
    g_out = dataclasses.replace(g, information_reading=dst)
    g2o_io.write(out, g_out)
    n, m = g.vertex_ids.shape[0], g.edges.shape[0]
    print(f"read {inp}: {n} vertices, {m} edges, information read as {src!r}")
    print(f"wrote {out}: information for {dst!r} readers, full precision")
    if m and out.is_file():  # not /dev/null or a pipe: read back what was written
        back = g2o_io.read(out, information=dst, edge3=args.edge3)
        gap = float(np.abs(back.information - g.information).max())
        scale = float(np.abs(g.information).max())
        print(
            f"check: {out.name} read as {dst!r} gives the same information over GTSAM's tangent "
            f"(max |difference| {gap:.3g}, relative {gap / scale:.3g})"
        )
    if src == dst:
        print("note: FROM = TO: the information is unchanged (the file is rewritten in g2o types)")
    if g.vertices_from_odometry:
        print(
            f"note: {inp.name} has no vertices; VERTEX_SE3:QUAT lines chained from odometry added"
        )
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge g2o`` and its subcommands."""
    p = sub.add_parser(
        "g2o",
        help="g2o file tools (convert information between g2o's and GTSAM's semantics)",
        description="g2o file tools.",
    )
    gsub = p.add_subparsers(dest="g2o_command", metavar="SUBCOMMAND")
    c = gsub.add_parser(
        "convert",
        help="rewrite a file with its information converted between the two semantics",
        description="Rewrite IN as OUT (VERTEX_SE3:QUAT / EDGE_SE3:QUAT lines, full precision) "
        "with the information converted: --information FROM:TO reads IN's numbers as FROM "
        "means them and writes numbers that a TO reader turns into the same information. "
        "g2o = the format's definition (over (t, quaternion vector part)); gtsam = how "
        "gtsam.readG2o reads them (block swap only: a 4× rotation weight). "
        "E.g. g2o:gtsam makes a g2o file read correctly by gtsam.readG2o.",
    )
    c.add_argument(
        "input",
        metavar="IN",
        help="the g2o (or EDGE3) file to read; a bare name not found here is looked up in the "
        "installed GTSAM's example data (e.g. sphere2500.txt), as liebridge optimize does",
    )
    c.add_argument("output", metavar="OUT", help="the file to write")
    c.add_argument(
        "--information",
        type=_pair,
        required=True,
        metavar="FROM:TO",
        help="g2o:gtsam or gtsam:g2o (g2o:g2o and gtsam:gtsam rewrite unchanged)",
    )
    c.add_argument(
        "--edge3",
        type=option_value,
        choices=("sqrt_information", "information"),
        default="sqrt_information",
        help="for EDGE3 input read as g2o: the 21 numbers are iSAM's square-root information "
        "(default) or g2o EdgeSE3Euler's information",
    )
    c.set_defaults(func=_convert)
    p.set_defaults(func=lambda _args: _missing(p))


def _missing(p: argparse.ArgumentParser) -> int:
    raise CLIError("missing SUBCOMMAND (convert); see 'liebridge g2o --help'")
