"""The ``liebridge`` command.

Subcommands: ``conventions`` (the presets as a table), ``detect`` (measure an installed library's
convention), ``convert-cov`` (a covariance or information matrix at a pose, between conventions),
``optimize`` (a g2o / EDGE3 pose graph in any convention; default sphere2500.txt), ``g2o convert``
(information between g2o's and GTSAM's semantics), ``bag`` (ROS bags: info, export,
write-marginals), ``traj ape|rpe|nees`` (trajectory evaluation), ``batch evaluate|convert``
(many logs into one table, on a process pool or a Dask cluster), ``extrinsics convert`` (a
camera–IMU extrinsic between Kalibr, OKVIS, ORB-SLAM3, OpenVINS, Basalt, VINS-Fusion, OpenCV),
``doctor jacobian|traj`` (diagnose the user's own Jacobian or trajectory), ``registration info``
(a saved ICP/GICP result's information in any convention) and ``demo``. Bad input gets one line
on stderr and a non-zero exit status, never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from .. import __version__
from . import (
    bag_cmd,
    batch_cmd,
    convert_cov,
    detect,
    doctor_cmd,
    extrinsics_cmd,
    g2o_cmd,
    optimize,
    registration_cmd,
    table,
    traj_cmd,
)
from ._common import CLIError, OneLineParser, one_line

__all__ = ["build_parser", "main"]


def _demo(_: argparse.Namespace) -> int:
    """Show the GTSAM ↔ Sophus-ordered tangent trap on one pose, measured against gtsam."""
    import gtsam
    import numpy as np

    from ..lie import se3

    xi = np.array([0.1, -0.2, 0.3, 1.0, 2.0, 3.0])  # (ω, v), GTSAM order
    T = se3.exp(xi)
    err = np.abs(T - gtsam.Pose3.Expmap(xi).matrix()).max()
    print(f"liebridge {__version__}: se3.exp vs gtsam.Pose3.Expmap, max |diff| = {err:.2e}")
    back = se3.log(T)
    print(f"log(exp(ξ)) − ξ: {np.abs(back - xi).max():.2e}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser (one subparser per subcommand)."""
    p = OneLineParser(
        prog="liebridge",
        description="SO(3)/SE(3) conventions as data, GTSAM as the hub. Run "
        "'liebridge SUBCOMMAND --help' for each subcommand.",
    )
    p.add_argument("--version", action="version", version=f"liebridge {__version__}")
    sub = p.add_subparsers(dest="command", metavar="SUBCOMMAND", parser_class=OneLineParser)
    table.add_parser(sub)
    detect.add_parser(sub)
    convert_cov.add_parser(sub)
    optimize.add_parser(sub)
    g2o_cmd.add_parser(sub)
    bag_cmd.add_parser(sub)
    traj_cmd.add_parser(sub)
    batch_cmd.add_parser(sub)
    extrinsics_cmd.add_parser(sub)
    doctor_cmd.add_parser(sub)
    registration_cmd.add_parser(sub)
    d = sub.add_parser(
        "demo",
        help="a one-second self-check: liebridge's SE(3) exp/log against the installed GTSAM",
        description="Compare liebridge.lie.se3.exp with gtsam.Pose3.Expmap on one twist "
        "ξ = (ω, v) = (0.1, -0.2, 0.3, 1, 2, 3) (GTSAM's rotation-first order) and print the "
        "largest entry difference (expected: rounding, ~1e-16) and the round trip "
        "log(exp(ξ)) − ξ. Use it to check an installation; it reads no file.",
    )
    d.set_defaults(func=_demo)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``liebridge`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return 0
    prog = " ".join(
        ["liebridge"]
        + [
            str(w)
            for w in (
                getattr(args, "command", None),
                getattr(args, "g2o_command", None),
                getattr(args, "bag_command", None),
                getattr(args, "traj_command", None),
                getattr(args, "batch_command", None),
                getattr(args, "extrinsics_command", None),
                getattr(args, "doctor_command", None),
                getattr(args, "registration_command", None),
            )
            if w
        ]
    )
    try:
        return int(args.func(args))
    except BrokenPipeError:  # e.g. `liebridge conventions | head`: not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except CLIError as exc:
        print(f"{prog}: error: {one_line(str(exc))}", file=sys.stderr)
        return exc.status
    except (ValueError, TypeError, OSError) as exc:  # the library's input validation
        print(f"{prog}: error: {one_line(str(exc))}", file=sys.stderr)
        return 2
    except MemoryError:
        print(
            f"{prog}: error: out of memory (the input is too large for this machine)",
            file=sys.stderr,
        )
        return 1
    except (RecursionError, OverflowError) as exc:  # numbers or nesting beyond what is handled
        print(
            f"{prog}: error: input too large or too deeply nested: {one_line(str(exc))}",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
