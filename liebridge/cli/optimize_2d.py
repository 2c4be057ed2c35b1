"""``liebridge optimize FILE`` on a 2-D graph (``VERTEX_SE2``/``EDGE_SE2``/``EDGE2``).

The graph is read by :func:`liebridge.io.g2o2d.read` (information over GTSAM's Pose2 tangent
``(vx, vy, ω)``, ``EDGE2`` number order detected) and built in the SE(2) convention given with
``--convention`` (default ``gtsam_pose2``), like the 3-D path: native ``gtsam.BetweenFactorPose2``
when the conversion to GTSAM's tangent is exact (:func:`liebridge.is_exactly_linear`: GTSAM,
Sophus, manif, jaxlie, Theseus), else liebridge's custom factors with the convention's own
residual (``g2o_se2_edge``: g2o's ``(x, y, θ)`` of ``Z⁻¹Ti⁻¹Tj``; ``g2o_se2``, ``symforce_pose2``,
``ros_pose2``)
and each edge's covariance converted to that convention at its measurement; a prior on the
``FIX`` vertices (else the first vertex) fixes the gauge. It is optimized by
:func:`liebridge.gtsam.optimize`, and its marginals (``gtsam.Marginals``, over GTSAM's Pose2
tangent) are converted to the convention. The plot shows the initial and optimized trajectories
with the 2σ position ellipses of the marginals.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..io.g2o import GAUGE_PRIOR_SIGMA, gauge_keys
from ..lie import se2
from ._common import CLIError, check_connected, need_matplotlib, save_figure, save_npy, say

#: σ of the gauge prior on the ``FIX`` vertices (else the first), in each of (vx, vy, ω): the
#: default of ``G2OGraph2D.to_gtsam(prior="gauge")``.
PRIOR_SIGMA = GAUGE_PRIOR_SIGMA
#: Above this many poses the plot shows no ellipses unless --out-cov marginals were computed.
PLOT_ELLIPSES_MAX = 3000


def _se2_convention(name: str) -> Any:
    from ..conventions import get

    try:
        conv = get(name)
    except ValueError as exc:
        raise CLIError(f"--convention: {exc}") from None
    group = getattr(conv, "group", None)
    if group != se2.GROUP.name:
        raise CLIError(
            f"--convention: {conv.name!r} is a convention of {group}, and this is a 2D graph: "
            "give an SE(2) one (e.g. gtsam_pose2, ros_pose2; 'liebridge conventions' lists them)"
        )
    return conv


def factor_kind_2d(conv: Any) -> str:
    """Describe in one line what :func:`build_2d` builds for ``conv``."""
    from ..conventions.convert import is_exactly_linear
    from ..gtsam.build import gtsam_convention_of

    if is_exactly_linear(conv, gtsam_convention_of(se2.GROUP.name)):
        return "native BetweenFactorPose2 (the conversion to GTSAM's tangent is exact)"
    return (
        f"liebridge custom factors ({conv.name}'s own residual, exact Jacobians): the conversion "
        "to GTSAM's tangent is not linear"
    )


def build_2d(g: Any, conv: Any) -> tuple[Any, Any]:
    """GTSAM graph and values of the 2-D graph ``g`` with factors in ``conv``, plus the gauge prior.

    Native ``BetweenFactorPose2`` (``g.to_gtsam(prior=None)``) when the conversion to GTSAM's
    tangent is exact, else :func:`liebridge.gtsam.between` custom factors in ``conv`` with each
    edge's covariance (``Λ⁻¹`` over GTSAM's tangent) converted at its measurement. The gauge
    prior is GTSAM's ``PriorFactorPose2`` on the ``FIX`` vertices (else the first), σ =
    :data:`PRIOR_SIGMA`: the prior ``g.to_gtsam()`` adds by default.
    """
    import gtsam

    from ..conventions import convert_covariance
    from ..conventions.convert import is_exactly_linear
    from ..gtsam import between
    from ..gtsam.build import gtsam_convention_of
    from ..gtsam.glue import to_values

    hub = gtsam_convention_of(se2.GROUP.name)
    if is_exactly_linear(conv, hub):
        graph, values = g.to_gtsam(prior=None)  # the gauge prior is added below
    else:
        values = to_values(g.poses, g.vertex_ids.tolist(), group="se2")
        graph = gtsam.NonlinearFactorGraph()
        Z = g.measured
        cov = convert_covariance(np.linalg.inv(g.information), Z, hub, conv)
        for (i, j), Zk, c in zip(g.edges.tolist(), Z, cov, strict=True):
            graph.add(between(int(i), int(j), Zk, c, conv, native=False))
    for k in gauge_keys(g.vertex_ids, g.fixed):
        graph.add(
            gtsam.PriorFactorPose2(
                k, values.atPose2(k), gtsam.noiseModel.Isotropic.Sigma(3, PRIOR_SIGMA)
            )
        )
    return graph, values


def _marginals(graph: Any, values: Any, keys: list[int]) -> FloatArray:
    import gtsam

    m = gtsam.Marginals(graph, values)
    return np.stack([np.asarray(m.marginalCovariance(k), dtype=np.float64) for k in keys])


def plot_2d(
    initial: FloatArray,
    optimized: FloatArray,
    cov_xy: FloatArray | None,
    path: Path,
    title: str,
    *,
    plt: Any,
) -> None:
    """Plot initial and optimized (x, y) in metres, with 2σ position ellipses of the marginals."""
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2))
    for ax, P, label, color in (
        (axes[0], initial, "initial", "tab:red"),
        (axes[1], optimized, "optimized", "tab:blue"),
    ):
        marker = "o" if P.shape[0] <= 100 else None
        ax.plot(P[:, 0], P[:, 1], color=color, linewidth=0.6, marker=marker, markersize=3)
        ax.scatter(P[:1, 0], P[:1, 1], color="k", s=20, label="first vertex", zorder=3)
        ax.set_title(f"{label} ({P.shape[0]} poses)")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(loc="best")
    if cov_xy is not None:
        t = np.linspace(0.0, 2.0 * np.pi, 48)
        circle = np.stack([np.cos(t), np.sin(t)])
        step = max(1, optimized.shape[0] // 400)
        for k in range(0, optimized.shape[0], step):
            w, V = np.linalg.eigh(cov_xy[k])
            e = optimized[k, :2, None] + 2.0 * (V * np.sqrt(np.maximum(w, 0.0))) @ circle
            axes[1].plot(e[0], e[1], color="tab:orange", linewidth=0.5)
        axes[1].plot([], [], color="tab:orange", label="2σ position (marginals)")
        axes[1].legend(loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def run(args: argparse.Namespace, path: Path, params: Any, plt: Any, t_start: float) -> int:
    """Read, optimize and report a 2-D graph (the 3-D path's output lines, for SE(2))."""
    from ..conventions import convert_covariance
    from ..gtsam import from_values, optimize
    from ..io import g2o2d

    conv_name = "gtsam_pose2" if args.convention in (None, "gtsam") else args.convention
    conv = _se2_convention(conv_name)
    t0 = time.perf_counter()
    try:
        g = g2o2d.read(path, edge2=args.edge2)
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    t_read = time.perf_counter() - t0
    n, m = g.vertex_ids.shape[0], g.edges.shape[0]
    if n == 0 or m == 0:
        raise CLIError(f"{path}: no 2D pose graph in it ({n} vertices, {m} edges)")
    origin = "chained from the odometry edges" if g.vertices_from_odometry else "from the file"
    print(f"file: {path}")
    print(f"graph: 2D, {n} poses, {m} edges; initial values {origin}")
    skipped = ", ".join(f"{c} {t} lines" for t, c in g.skipped)
    if skipped:
        print(f"skipped: {skipped} (TORO vertex equivalences; gtsam.readG2o skips them too)")
    order = {
        "none": "",
        "g2o": "; EDGE2 numbers in g2o's order",
        "toro": "; EDGE2 numbers in TORO's order (gtsam.readG2o refuses this file)",
    }[g.edge2_order]
    print(
        "information: over (x, y, θ) of Z⁻¹·Ti⁻¹·Tj — the same matrix in g2o's and GTSAM's "
        f"readings (they agree to first order at zero error){order}"
    )
    print(f"convention: {conv.name} — {factor_kind_2d(conv)}; marginals in its tangent")
    check_connected(g.vertex_ids.tolist(), g.edges.tolist(), gauge_keys(g.vertex_ids, g.fixed))
    gauge = ", ".join(str(k) for k in gauge_keys(g.vertex_ids, g.fixed))
    print(f"gauge: prior on vertex {gauge} (σ = {PRIOR_SIGMA:g})")
    if args.dry_run:
        print("dry run: nothing optimized")
        return 0
    graph, values = build_2d(g, conv)

    def progress(line: str) -> None:
        say("  " + line.removeprefix("liebridge.optimize: "))

    say(f"optimizing {n} poses, {m} edges (Levenberg–Marquardt) ...")
    try:
        result = optimize(graph, values, params, progress=progress)
    except RuntimeError as exc:
        raise CLIError(f"GTSAM failed during the optimization: {exc}") from None
    print(f"initial error: {result.initial_error:.6f}")
    print(f"final error: {result.final_error:.6f}")
    print(f"iterations: {result.iterations} (converged: {'yes' if result.converged else 'no'})")
    timings = [f"read {t_read:.2f} s", f"optimize {result.seconds:.2f} s"]
    keys = [int(k) for k in g.vertex_ids]
    X = from_values(result.values, keys, group="se2")
    cov = None
    if args.marginals is not None or (args.plot is not None and n <= PLOT_ELLIPSES_MAX):
        t0 = time.perf_counter()
        say(f"marginal covariances of {n} poses (gtsam.Marginals) ...")
        try:
            cov_gtsam = _marginals(graph, result.values, keys)
        except RuntimeError as exc:
            raise CLIError(f"GTSAM failed during the marginal covariances: {exc}") from None
        cov = convert_covariance(cov_gtsam, X, "gtsam_pose2", conv)
        timings.append(f"marginals {time.perf_counter() - t0:.2f} s")
        if args.marginals is not None:
            save_npy(args.marginals, cov, "--out-cov")
            print(f"marginals: {args.marginals} (shape {cov.shape}, {conv.name}'s tangent)")
    if args.plot is not None:
        t0 = time.perf_counter()
        cov_xy = None
        if cov is not None:  # positions in the world frame: from GTSAM's body-frame (vx, vy)
            R = X[:, :2, :2]
            cov_xy = R @ cov_gtsam[:, :2, :2] @ np.swapaxes(R, -1, -2)
        title = (
            f"{path.name}: error {result.initial_error:.6g} → {result.final_error:.6g} in "
            f"{result.iterations} iterations"
        )
        P0 = np.c_[g.vertex_xytheta[:, :2]]
        P1 = X[:, :2, 2]
        plot_2d(P0, P1, cov_xy, Path(args.plot), title, plt=plt or need_matplotlib())
        timings.append(f"plot {time.perf_counter() - t0:.2f} s")
        print(f"plot: {args.plot}")
    timings.append(f"total {time.perf_counter() - t_start:.2f} s")
    print("timings: " + ", ".join(timings))
    return 0
