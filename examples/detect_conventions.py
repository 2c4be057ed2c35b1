"""Measure the conventions of the installed libraries — and of your own retraction.

Problem. A library's documentation may not say which side it perturbs, in which order its
tangent is, whether its chart is the SE(3) exponential, or how it stores quaternions; and a
build flag can change the answer (GTSAM's ``GTSAM_POSE3_EXPMAP``). Measure instead of trusting.

Conventions. ``liebridge.detect_convention(retract)`` calls ``retract(X, d)`` at a generic pose
with finite increments and compares it with every convention of the model (side × order ×
chart × rotation coordinates), so even conventions that agree to first order are told apart.
The probes of ``liebridge detect`` (``liebridge.conventions.probes.LIBRARIES``) wrap each
library's own operation — GTSAM, Pinocchio, pytransform3d, scipy, symforce, Modern Robotics,
spatialmath — whichever are installed; the quaternion storage order is read back from a known
rotation.

What to look at. Each library's measured fields beside its preset (all should agree), then two
hand-written retractions: a ROS-style one (recognized as preset ``ros``) and a subtly wrong
one (a rotation applied at half its angle), which matches nothing: the error message gives the
measured first-order map so you can see what it does.

Run: ``python examples/detect_conventions.py [--libraries gtsam,scipy]``.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import liebridge as lb
from liebridge.conventions.probes import (
    LIBRARIES,
    LibraryError,
    format_result,
    import_library,
    run_probe,
)
from liebridge.lie import so3


def my_ros_style_retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Hand-written: position += d[:3] in the parent frame, rotation about the parent's axes."""
    Y = X.copy()
    Y[:3, 3] += d[:3]
    Y[:3, :3] = so3.exp(d[3:]) @ X[:3, :3]
    return Y


def my_buggy_retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Hand-written with a bug: the rotation increment is applied at half its angle."""
    Y = X.copy()
    Y[:3, 3] += X[:3, :3] @ d[:3]
    Y[:3, :3] = X[:3, :3] @ so3.exp(0.5 * d[3:])
    return Y


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--libraries",
        default=",".join(LIBRARIES),
        help=f"comma-separated subset of {', '.join(LIBRARIES)} (default: all)",
    )
    p.add_argument("--no-show", action="store_true", help="accepted for symmetry (no plot)")
    args = p.parse_args(argv)
    wanted = [s.strip() for s in args.libraries.split(",") if s.strip()]
    unknown = [w for w in wanted if w not in LIBRARIES]
    if unknown:
        p.error(f"--libraries: unknown {unknown} (known: {', '.join(LIBRARIES)})")

    summary = []
    for name in wanted:
        lib = LIBRARIES[name]
        try:
            module, version = import_library(lib)
        except LibraryError as exc:  # not installed
            print(f"{name}: skipped ({exc})\n")
            continue
        for probe in lib.probes:
            r = run_probe(lib, probe, module, version)
            print(format_result(r) + "\n")
            verdict = {True: "agrees", False: "DIFFERS", None: "no preset"}[r.agrees]
            summary.append((f"{name}: {probe.what}", verdict))

    print("your own code:")
    found = lb.detect_convention(my_ros_style_retract)
    print(f"  my_ros_style_retract -> {found.describe()}")
    try:
        lb.detect_convention(my_buggy_retract)
        print("  my_buggy_retract -> matched a convention (unexpected)")
    except lb.conventions.ConventionNotDetected as exc:
        print("  my_buggy_retract -> no convention of the model:")
        print("    " + str(exc).replace("\n", "\n    "))

    print("\nsummary:")
    for what, verdict in summary:
        print(f"  {verdict:<9} {what}")
    bad = [w for w, v in summary if v == "DIFFERS"]
    print(f"{len(summary)} probes, {len(bad)} differing from their preset")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
