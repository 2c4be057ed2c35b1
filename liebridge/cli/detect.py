"""``liebridge detect LIBRARY``: measure an installed library's convention, beside its preset.

Each probe wraps one of the library's own operations as ``retract(X, d) -> (4, 4)`` (a pose
``X`` as a matrix, an increment ``d`` in the library's own tangent) and hands it to
:func:`liebridge.detect_convention`, which compares it with every convention of the model at
finite increments; the quaternion storage order is measured by reading a known rotation back
out of the library. Nothing about the library is assumed: a probe prints what was measured and
the preset that claims to describe it, and says whether they agree.

Where a library has no retraction of its own (scipy, spatialmath, Modern Robotics), the probe
composes the library's exponential on one side, so the side is the probe's choice and only the
tangent order and chart are the library's; the output says so.

The probes live in :mod:`liebridge.conventions.probes`; this module formats their results.
"""

from __future__ import annotations

import argparse
from typing import Any

from ..conventions.probes import (
    LIBRARIES,
    LibraryError,
    format_result,
    import_library,
    resolve,
    run_probe,
)
from ._common import CLIError

__all__ = ["add_parser"]


def _run(args: argparse.Namespace) -> int:
    if args.list:
        for lib in LIBRARIES.values():
            aliases = f" (also: {', '.join(lib.aliases)})" if lib.aliases else ""
            print(f"{lib.name}{aliases}: pip install {lib.pip}")
        return 0
    if args.library is None:
        raise CLIError("give a LIBRARY (or 'all'); 'liebridge detect --list' lists them")
    if args.library.strip().lower() == "all":
        libs = list(LIBRARIES.values())
    else:
        try:
            libs = [resolve(args.library)]
        except LibraryError as exc:
            raise CLIError(str(exc)) from None
    status = 0
    blocks: list[str] = []
    for lib in libs:
        try:
            module, version = import_library(lib)
        except LibraryError as exc:
            if len(libs) == 1:
                raise CLIError(str(exc)) from None
            blocks.append(f"{lib.name}: skipped: {exc}")
            continue
        for probe in lib.probes:
            r = run_probe(lib, probe, module, version)
            blocks.append(format_result(r))
            if r.agrees is False:
                status = 1
    print("\n\n".join(blocks))
    return status


def add_parser(sub: Any) -> None:
    """Register ``liebridge detect``."""
    p = sub.add_parser(
        "detect",
        help="measure an installed library's convention and print it beside its preset",
        description="Measure the convention an installed library implements (with "
        "liebridge.detect_convention on the library's own retraction, and the quaternion "
        "storage order by reading a known rotation back) and print it beside the preset that "
        "claims to describe it. Exit status 1 if a measurement differs from its preset.",
    )
    p.add_argument(
        "library",
        nargs="?",
        metavar="LIBRARY",
        help=f"one of {', '.join(LIBRARIES)}, or 'all' (the installed ones)",
    )
    p.add_argument("--list", action="store_true", help="list the known libraries and exit")
    p.set_defaults(func=_run)
