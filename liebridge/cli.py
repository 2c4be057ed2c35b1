"""The ``liebridge`` command."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from . import __version__


def _demo(_: argparse.Namespace) -> int:
    """Show the GTSAM ↔ Sophus-ordered tangent trap on one pose, measured against gtsam."""
    import gtsam
    import numpy as np

    from .lie import se3

    xi = np.array([0.1, -0.2, 0.3, 1.0, 2.0, 3.0])  # (ω, v), GTSAM order
    T = se3.exp(xi)
    err = np.abs(T - gtsam.Pose3.Expmap(xi).matrix()).max()
    print(f"liebridge {__version__}: se3.exp vs gtsam.Pose3.Expmap, max |diff| = {err:.2e}")
    back = se3.log(T)
    print(f"log(exp(ξ)) − ξ: {np.abs(back - xi).max():.2e}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser (one subparser per subcommand)."""
    p = argparse.ArgumentParser(prog="liebridge", description=__doc__)
    p.add_argument("--version", action="version", version=f"liebridge {__version__}")
    sub = p.add_subparsers(dest="command")
    d = sub.add_parser("demo", help="a small self-check against the installed GTSAM")
    d.set_defaults(func=_demo)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``liebridge`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return 0
    try:
        return int(args.func(args))
    except (ValueError, TypeError, OSError) as exc:
        print(f"liebridge: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
