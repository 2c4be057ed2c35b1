"""``liebridge optimize``: a g2o / EDGE3 pose graph optimized in any convention.

Without ``--convention`` the file's information (over GTSAM's tangent, by the semantics chosen
with ``--information``) goes into native ``BetweenFactorPose3`` factors as read
(:meth:`liebridge.g2o.G2OGraph.to_gtsam`). With ``--convention NAME`` the graph is built the way
a user of NAME would build it: each edge's information is converted from GTSAM's tangent at the
measurement into NAME's (:func:`liebridge.convert_information`), and the factors are added through
:class:`liebridge.ConventionGraph`, which picks a native GTSAM factor when that conversion is
exact and liebridge's custom factor (NAME's own residual, exact Jacobians) otherwise. Either way
:func:`liebridge.gtsam.optimize` runs Levenberg–Marquardt; marginals come out in NAME's tangent.

The gauge is fixed by a prior (σ = 1e-4 in every GTSAM tangent direction) on the ``FIX``
vertices, or on the first vertex when the file has none.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..io.g2o import GAUGE_PRIOR_SIGMA, gauge_keys
from ..lie import se3
from ._common import (
    CLIError,
    check_connected,
    check_output_path,
    convention_arg,
    deprecated_alias,
    need_matplotlib,
    option_value,
    save_figure,
    save_npy,
    say,
)

__all__ = [
    "DEFAULT_DATASET",
    "add_parser",
    "plot_trajectories",
    "position_sigma",
    "resolve_dataset",
]

#: The file ``liebridge optimize`` reads without arguments (from the installed GTSAM's data).
DEFAULT_DATASET = "sphere2500.txt"
#: Gauge prior standard deviation (every direction of GTSAM's tangent): the default of
#: ``G2OGraph.to_gtsam(prior="gauge")``.
PRIOR_SIGMA = GAUGE_PRIOR_SIGMA
_PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def resolve_dataset(name: str | None, what: str = "FILE") -> Path:
    """Return ``name`` if it is a file, else the file of that name in GTSAM's example data.

    Used by every subcommand that reads a pose-graph file (``optimize``, ``g2o convert``);
    ``what`` names the argument in the error.
    """
    if name is None:
        name = DEFAULT_DATASET
    path = Path(name)
    if path.is_file():
        return path
    if path.is_dir():
        raise CLIError(f"{what}: {name!r} is a directory")
    if path.name == name:  # a bare name: look in GTSAM's example data
        import gtsam

        try:
            return Path(gtsam.findExampleDataFile(name))
        except (OSError, RuntimeError, ValueError, IndexError):
            pass
    raise CLIError(f"{what}: no such file: {name} (nor in GTSAM's example data)")


def _params(max_iterations: int) -> Any:
    import gtsam

    p = gtsam.LevenbergMarquardtParams()
    p.setMaxIterations(max_iterations)
    return p


def _factor_kind(conv: Any) -> str:
    from ..conventions.convert import is_exactly_linear
    from ..gtsam.build import gtsam_convention

    if is_exactly_linear(conv, gtsam_convention()):
        return "native BetweenFactorPose3 (the conversion to GTSAM's tangent is exact)"
    return (
        f"liebridge custom factors ({conv.name}'s own residual, exact Jacobians, evaluated in "
        "one batched pass): the conversion to GTSAM's tangent is not linear"
    )


def _semantics_line(information: str) -> str:
    """One line: which information semantics the errors above are in, and how to get the other."""
    if information == "g2o":
        return (
            "semantics: the file format's own information (g2o's definition), not gtsam.readG2o's "
            "(which weighs EDGE_SE3:QUAT rotations 4×, EDGE3 as-is): --information gtsam gives "
            "GTSAM's numbers"
        )
    return (
        "semantics: the information as gtsam.readG2o reads it (GTSAM's numbers); "
        "--information g2o follows the file format's own definition"
    )


def _gauge_keys(g: Any) -> list[int]:
    return gauge_keys(g.vertex_ids, g.fixed)


def _check_connected(g: Any) -> None:
    """Fail clearly (before GTSAM does, deep inside) if some vertex is not tied to the gauge."""
    check_connected(g.vertex_ids.tolist(), g.edges.tolist(), _gauge_keys(g))


def _gtsam_error(exc: RuntimeError, during: str) -> CLIError:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return CLIError(f"GTSAM failed during {during}: {' '.join(lines[:2]) or type(exc).__name__}")


def _build(g: Any, conv: Any) -> Any:
    """Build a ConventionGraph holding ``g`` in ``conv``, with the gauge prior."""
    from ..conventions.convert import convert_covariance, convert_information
    from ..gtsam.glue import to_values
    from ..gtsam.graph import ConventionGraph

    key_index = {int(k): n for n, k in enumerate(g.vertex_ids.tolist())}
    prior_cov = np.eye(6) * PRIOR_SIGMA**2
    if conv.name == "gtsam":
        graph, values = g.to_gtsam(prior=None)  # the gauge prior is added below, in conv
        cg = ConventionGraph(conv, graph, values)
    else:
        cg = ConventionGraph(conv, values=to_values(g.poses, g.vertex_ids.tolist()))
        info = convert_information(g.information, g.measured, "gtsam", conv)
        try:
            cov = np.linalg.inv(np.linalg.cholesky(info))  # L⁻¹, raises if not positive definite
        except np.linalg.LinAlgError:
            bad = next(k for k, lam in enumerate(info) if np.linalg.eigvalsh(lam)[0] <= 0)
            i, j = g.edges[bad]
            raise CLIError(
                f"edge {bad} ({i} -> {j}): its information is not positive definite, so it has "
                "no covariance to give a factor"
            ) from None
        cov = np.swapaxes(cov, -1, -2) @ cov  # Λ⁻¹ = L⁻ᵀ L⁻¹
        cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
        for (i, j), Z, c in zip(g.edges.tolist(), g.measured, cov, strict=True):
            cg.add_between(int(i), int(j), Z, c)
    for k in _gauge_keys(g):
        T = g.poses[key_index[k]]
        cg.add_prior(k, T, convert_covariance(prior_cov, T, "gtsam", conv))
    return cg


def position_sigma(cov: FloatArray, poses: FloatArray, conv: Any) -> FloatArray:
    """``√trace`` of each pose's world-frame position covariance, from marginals in ``conv``.

    The position block of the marginal mapped to ROS's tangent (position in the parent frame,
    :func:`liebridge.convert_covariance` to ``"ros"``, first order): the same for every
    convention the marginals were computed in.
    """
    from ..conventions.convert import convert_covariance

    pos = convert_covariance(cov, poses, conv, "ros")[..., :3, :3]
    return np.asarray(np.sqrt(np.trace(pos, axis1=-2, axis2=-1)), dtype=np.float64)


def plot_trajectories(
    initial: FloatArray,
    optimized: FloatArray,
    path: Path,
    title: str,
    *,
    plt: Any = None,
    sigma: FloatArray | None = None,
) -> None:
    """Two 3D panels: initial and optimized vertex positions, joined in vertex order.

    Axes in the file's length unit (metres for GTSAM's example data). With ``sigma`` (one value
    per pose, see :func:`position_sigma`) the optimized poses are coloured by their position
    standard deviation from the marginals, with a colour bar.
    """
    plt = plt if plt is not None else need_matplotlib()
    fig = plt.figure(figsize=(13, 6.2))
    for n, (P, label, color) in enumerate(
        ((initial, "initial", "tab:red"), (optimized, "optimized", "tab:blue"))
    ):
        ax = fig.add_subplot(1, 2, n + 1, projection="3d")
        x, y, z = P[:, 0, 3], P[:, 1, 3], P[:, 2, 3]
        marker = "o" if P.shape[0] <= 100 else None
        ax.plot(x, y, z, color=color, linewidth=0.6, marker=marker, markersize=3)
        ax.scatter(x[:1], y[:1], z[:1], color="k", s=20, label="first vertex")
        ax.set_title(f"{label} ({P.shape[0]} poses)")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_zlabel("z [m]")
        if sigma is not None and label == "optimized":
            sc = ax.scatter(x, y, z, c=sigma, cmap="viridis", s=6, depthshade=False)
            fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.1, label="position σ [m] (marginals)")
        span = np.ptp(P[:, :3, 3], axis=0).max() / 2 or 1.0
        mid = (P[:, :3, 3].max(axis=0) + P[:, :3, 3].min(axis=0)) / 2
        ax.set_xlim(mid[0] - span, mid[0] + span)
        ax.set_ylim(mid[1] - span, mid[1] + span)
        ax.set_zlim(mid[2] - span, mid[2] + span)
        ax.set_box_aspect((1, 1, 1))
        ax.legend(loc="upper left")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _run(args: argparse.Namespace) -> int:
    t_start = time.perf_counter()
    conv = convention_arg(args.convention, "--convention")
    plt = None
    if args.plot is not None:
        check_output_path(args.plot, "--plot", _PLOT_SUFFIXES, inputs=[args.file])
        plt = need_matplotlib()  # fail before the long part, not after
    if args.marginals is not None:
        check_output_path(args.marginals, "--out-cov", (".npy",), inputs=[args.file])
    path = resolve_dataset(args.file)

    from ..io import g2o as g2o_io
    from ..io import g2o2d

    if g2o2d.is_2d(path):  # VERTEX_SE2 / EDGE_SE2 / VERTEX2 / EDGE2
        from . import optimize_2d

        return optimize_2d.run(args, path, _params(args.max_iterations), plt, t_start)
    if getattr(conv, "group", None) != se3.GROUP.name:
        raise CLIError(
            f"--convention: {conv.name!r} is a convention of {conv.group}, and {path.name} is a "
            "3D graph: give an SE(3) one ('liebridge conventions' lists them)"
        )

    t0 = time.perf_counter()
    g = g2o_io.read(path, information=args.information, edge3=args.edge3)
    t_read = time.perf_counter() - t0
    n, m = g.vertex_ids.shape[0], g.edges.shape[0]
    if n == 0 or m == 0:
        raise CLIError(f"{path}: no 3D pose graph in it ({n} vertices, {m} edges)")
    origin = "chained from the odometry edges" if g.vertices_from_odometry else "from the file"
    print(f"file: {path}")
    print(f"graph: {n} poses, {m} edges; initial values {origin}")
    print(
        f"information: read as {args.information!r}"
        + (
            f" (the format's definition; EDGE3 numbers, if any, as {args.edge3.replace('_', ' ')})"
            if args.information == "g2o"
            else " (as gtsam.readG2o reads it)"
        )
    )
    print(f"convention: {conv.name} — {_factor_kind(conv)}")
    _check_connected(g)
    gauge = ", ".join(str(k) for k in _gauge_keys(g))
    print(f"gauge: prior on vertex {gauge} (σ = {PRIOR_SIGMA:g})")
    if args.dry_run:
        print("dry run: nothing optimized")
        return 0

    t0 = time.perf_counter()
    say(f"building the graph in {conv.name}'s convention ...")
    cg = _build(g, conv)
    t_build = time.perf_counter() - t0

    def progress(line: str) -> None:
        say("  " + line.removeprefix("liebridge.optimize: "))

    say(
        f"optimizing {n} poses, {m} edges (Levenberg–Marquardt, at most {args.max_iterations} "
        "iterations) ..."
    )
    try:
        result = cg.optimize(_params(args.max_iterations), progress=progress)
    except RuntimeError as exc:  # e.g. a factor that cannot be evaluated
        raise _gtsam_error(exc, "the optimization") from None
    print(f"initial error: {result.initial_error:.6f}")
    print(f"final error: {result.final_error:.6f}")
    print(_semantics_line(args.information))
    print(f"iterations: {result.iterations} (converged: {'yes' if result.converged else 'no'})")
    timings = [f"read {t_read:.2f} s", f"build {t_build:.2f} s", f"optimize {result.seconds:.2f} s"]

    keys = g.vertex_ids.tolist()
    sigma = None
    if args.marginals is not None:
        t0 = time.perf_counter()
        say(f"marginal covariances of {n} poses (gtsam.Marginals), in {conv.name}'s tangent ...")
        try:
            cov = cg.marginal_covariances(keys)
        except RuntimeError as exc:  # an ill-conditioned system at the optimum
            raise _gtsam_error(exc, "the marginal covariances") from None
        save_npy(args.marginals, cov, "--out-cov")
        sigma = position_sigma(cov, cg.poses(keys), conv)
        timings.append(f"marginals {time.perf_counter() - t0:.2f} s")
        print(
            f"marginals: {args.marginals} (shape {cov.shape}, {conv.name}'s tangent, vertex order)"
        )
    if args.plot is not None:
        t0 = time.perf_counter()
        title = (
            f"{path.name} in {conv.name}'s convention: error {result.initial_error:.6g} → "
            f"{result.final_error:.6g} in {result.iterations} iterations"
        )
        plot_trajectories(g.poses, cg.poses(keys), Path(args.plot), title, plt=plt, sigma=sigma)
        timings.append(f"plot {time.perf_counter() - t0:.2f} s")
        print(f"plot: {args.plot}")
    timings.append(f"total {time.perf_counter() - t_start:.2f} s")
    print("timings: " + ", ".join(timings))
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge optimize``."""
    p = sub.add_parser(
        "optimize",
        help="optimize a 3D or 2D g2o / TORO pose graph (default: sphere2500.txt, GTSAM's data)",
        description="Read a 3D g2o (VERTEX_SE3:QUAT / EDGE_SE3:QUAT) or TORO/iSAM (EDGE3) pose "
        "graph, optimize it with Levenberg–Marquardt (liebridge.gtsam.optimize) and print the "
        "initial and final error, the iterations and the timings. With --convention NAME the "
        "graph is built in NAME's convention (information converted from GTSAM's tangent at "
        "each measurement; native factors where exact, liebridge's custom factors otherwise) "
        "and --out-cov marginals are written in NAME's tangent. A 2D file (VERTEX_SE2 / "
        "EDGE_SE2, TORO's VERTEX2 / EDGE2) is detected and optimized as Pose2 factors; its "
        "--convention is an SE(2) one (default gtsam_pose2) and its plot is planar. Progress "
        "goes to stderr.",
    )
    p.add_argument(
        "file",
        nargs="?",
        metavar="FILE",
        help=f"the graph file, or the name of a file in GTSAM's example data "
        f"(default: {DEFAULT_DATASET})",
    )
    p.add_argument(
        "--information",
        type=option_value,
        choices=("g2o", "gtsam"),
        default="g2o",
        help="what the file's information numbers mean: g2o = the format's own definition "
        "(default; EDGE_SE3:QUAT over (t, quaternion vector part), EDGE3 per --edge3), gtsam = "
        "as gtsam.readG2o reads them (rotation weight 4× g2o's for EDGE_SE3:QUAT)",
    )
    p.add_argument(
        "--edge3",
        type=option_value,
        choices=("sqrt_information", "information"),
        default="sqrt_information",
        help="with --information g2o: EDGE3's 21 numbers are iSAM's square-root information "
        "(default; what sphere2500.txt holds) or g2o EdgeSE3Euler's information",
    )
    p.add_argument(
        "--edge2",
        choices=("auto", "g2o", "toro"),
        default="auto",
        help="2D files: the order of EDGE2's six information numbers, g2o's (I11 I12 I13 I22 I23 "
        "I33) or TORO's (Ixx Ixy Iyy Itt Ixt Iyt); auto (default) takes the one that gives "
        "positive-definite matrices",
    )
    p.add_argument(
        "--convention",
        default="gtsam",
        metavar="NAME",
        help="build the graph in this convention (see 'liebridge conventions'; default gtsam, "
        "for a 2D file gtsam_pose2: an SE(2) convention, used for the marginals)",
    )
    p.add_argument(
        "--plot",
        metavar="OUT.png",
        help="write a 3D plot of the initial and optimized trajectories, axes in the file's "
        "length unit (m); with --out-cov the optimized poses are coloured by their position σ "
        '(needs matplotlib: pip install ".[plot]" from the checkout)',
    )
    cov = p.add_argument(
        "--out-cov",
        dest="marginals",
        metavar="OUT.npy",
        help="write the marginal covariances (N, 6, 6), in the convention's tangent, vertex order",
    )
    deprecated_alias(p, cov, "--marginals")
    from ._common import positive_int

    p.add_argument(
        "--max-iterations",
        type=positive_int,
        default=100,
        metavar="N",
        help="Levenberg–Marquardt iterations at most (default 100)",
    )
    p.add_argument(
        "--dry-run",
        action="store_true",
        help="read the file and print what would be done, without optimizing",
    )
    p.set_defaults(func=_run)
