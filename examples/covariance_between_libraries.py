"""GTSAM marginal covariances carried into Sophus, Barfoot, ROS and symforce conventions.

Problem. ``gtsam.Marginals.marginalCovariance(key)`` is the covariance of ``ξ`` in ``X̂·Exp(ξ)``,
``ξ = (ω, v)``: rotation first, right perturbation. Handing that 6×6 matrix to code in another
convention — a Sophus ``(v, ω)`` tangent, Barfoot's left ``(ρ, φ)``, a ROS
``PoseWithCovariance`` (parent-frame position, fixed-axis rotation), a symforce ``Pose3``
(world-frame translation increment) — needs a reorder at least, and for the left and world-frame
conventions a rotation/adjoint that couples the blocks; the uncertainty of a pose 100 m from the
origin is dominated by that coupling.

Conventions. The covariance is converted with ``liebridge.marginals(graph, values, keys,
convention)`` (``M Σ Mᵀ``, ``M = tangent_map(X̂, "gtsam", convention)``). The reference is a Monte
Carlo run (``liebridge.check.monte_carlo_covariance``): samples ``X̂·Exp(ξ)``, ``ξ ~ N(0, Σ)``,
read back with the target convention's own ``local``.

What to look at. The table: the whitened gap ``‖L⁻¹ Σ_claim L⁻ᵀ − I‖₂`` to the Monte Carlo
covariance (``L Lᵀ`` = Monte Carlo) is at sampling noise for the converted covariance and large
for the naive copy and the reorder-only copy. The plot: for each convention, the cloud of sampled
positions (the truth, the same in every panel) and the 2σ position ellipses implied by each
claimed covariance (sampled in that convention and retracted with its own ``retract``): the
converted one lies on the truth, the naive ones do not.

Run: ``python examples/covariance_between_libraries.py [--max-poses 100] [--samples 500]
[--out DIR]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import gtsam
import numpy as np

import liebridge as lb
from liebridge import conventions as C

TARGETS = (C.SOPHUS, C.BARFOOT, C.ROS, C.SYMFORCE)
SWAP = np.r_[3, 4, 5, 0, 1, 2]  # (ω, v) <-> (v, ω)


def optimized_graph(dataset: str, max_poses: int | None) -> tuple[Any, Any, list[int]]:
    """Optimize ``dataset`` (first ``max_poses`` poses) in GTSAM; return graph, values, keys."""
    path = Path(dataset) if Path(dataset).is_file() else Path(gtsam.findExampleDataFile(dataset))
    g = lb.io.g2o.read(path)
    keys = np.sort(g.vertex_ids)
    if max_poses is not None:
        keys = keys[:max_poses]
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    full, init = g.to_gtsam(prior=None)
    for k in range(full.size()):
        f = full.at(k)
        if all(int(key) in set(keys.tolist()) for key in f.keys()):
            graph.add(f)
    for k in keys.tolist():
        values.insert(int(k), init.atPose3(int(k)))
    noise = gtsam.noiseModel.Isotropic.Sigma(6, 1e-4)
    graph.add(gtsam.PriorFactorPose3(int(keys[0]), init.atPose3(int(keys[0])), noise))
    result = lb.gtsam.optimize(graph, values, progress=False)
    return graph, result.values, [int(k) for k in keys]


def pick_pose(marg: Any, values: Any, keys: list[int]) -> int:
    """Pick a pose where the frame matters: body- and world-frame position covariances differ.

    Among up to 100 poses of the second half of the trajectory (uncertain, far from the gauge),
    the one maximizing ``‖R Σ_vv Rᵀ − Σ_vv‖ / ‖Σ_vv‖`` (a flat position ellipsoid whose body
    axes are not the world's), so that a frame mix-up shows in a position plot.
    """
    half = keys[len(keys) // 2 :]
    cands = half[:: max(1, len(half) // 100)]
    best, best_score = cands[-1], -1.0
    for k in cands:
        R = values.atPose3(k).rotation().matrix()
        S = np.asarray(marg.marginalCovariance(k))[3:, 3:]
        score = float(np.linalg.norm(R @ S @ R.T - S) / np.linalg.norm(S))
        if score > best_score:
            best, best_score = k, score
    return int(best)


def whitened_gap(claim: np.ndarray, reference: np.ndarray) -> float:
    """``‖L⁻¹ claim L⁻ᵀ − I‖₂`` with ``L Lᵀ = reference``: 0 when they agree, scale-free."""
    L = np.linalg.cholesky(reference)
    W = np.linalg.solve(L, np.linalg.solve(L, claim).T)
    return float(np.linalg.norm(W - np.eye(claim.shape[0]), 2))


def claims(cov_g: np.ndarray, converted: np.ndarray, conv: Any) -> dict[str, np.ndarray]:
    """Return the converted covariance and the tempting wrong ones."""
    out = {"converted": converted, "naive copy": cov_g}
    reordered = cov_g[np.ix_(SWAP, SWAP)] if conv.order != "rot_first" else cov_g
    if not np.allclose(reordered, converted, rtol=1e-9, atol=0) and conv.order != "rot_first":
        out["reordered only"] = reordered
    return out


def positions(conv: Any, X: np.ndarray, cov: np.ndarray, z: np.ndarray) -> np.ndarray:
    """World positions of ``conv.retract(X, d)`` for ``d = S z`` (``S Sᵀ = cov``)."""
    lam, U = np.linalg.eigh(cov)
    S = U * np.sqrt(np.clip(lam, 0.0, None))
    return conv.retract(X, z @ S.T)[:, :3, 3]


def ellipse(points: np.ndarray, basis: np.ndarray, center: np.ndarray) -> np.ndarray:
    """Return the 2σ ellipse of ``points`` projected on ``basis`` (3×2), about ``center``."""
    P = (points - center) @ basis
    lam, U = np.linalg.eigh(np.cov(P.T))
    t = np.linspace(0, 2 * np.pi, 100)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (U @ (2 * np.sqrt(lam)[:, None] * circle)).T + P.mean(axis=0)


def plot(
    X: np.ndarray,
    cov_g: np.ndarray,
    results: list[tuple[Any, dict[str, np.ndarray], dict[str, float]]],
    n: int,
    path: Path,
    title: str,
) -> None:
    """One panel per convention: the true position cloud and each claim's 2σ ellipse."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(7)
    z = rng.standard_normal((n, 6))
    truth = positions(C.GTSAM, X, cov_g, z)
    center = truth.mean(axis=0)
    _, U = np.linalg.eigh(np.cov(truth.T))
    basis = U[:, ::-1][:, :2]  # the two largest axes of the true position covariance
    styles = {
        "converted": ("tab:green", "-", 1.6),
        "naive copy": ("tab:red", "--", 1.6),
        "reordered only": ("tab:orange", ":", 2.0),
    }
    fig, axes = plt.subplots(2, 2, figsize=(12, 11))
    for ax, (conv, cl, gaps) in zip(axes.ravel(), results, strict=True):
        P = (truth - center) @ basis
        ax.scatter(P[:, 0], P[:, 1], s=3, color="0.6", alpha=0.5, label="samples X̂·Exp(ξ) (truth)")
        E = ellipse(truth, basis, center)
        ax.plot(E[:, 0], E[:, 1], color="k", lw=4.0, alpha=0.5, label="truth, 2σ")
        extent = np.abs(E).max()
        limit = 2.5 * extent  # the truth's scale: a wildly wrong claim is reported, not drawn
        for name, cov in cl.items():
            color, ls, lw = styles[name]
            pts = positions(conv, X, cov, z)
            Ec = ellipse(pts, basis, center)
            size = np.abs(Ec).max()
            label = f"{name} (gap {gaps[name]:.2g})"
            if size > limit:
                label += f": 2σ reaches {size:.3g} m, off the axes"
            elif size < 0.1 * extent:
                label += f": 2σ only {size:.2g} m"
            ax.plot(Ec[:, 0], Ec[:, 1], color=color, ls=ls, lw=lw, label=label)
        ax.set_xlim(-limit, limit)
        ax.set_ylim(-limit, limit)
        ax.set_aspect("equal")
        order = "(ω, v)" if conv.order == "rot_first" else "(v, ω)"
        ax.set_title(f"{conv.name}: {conv.side}, {order}, {conv.chart}")
        ax.set_xlabel("position, largest axis [m]")
        ax.set_ylabel("position, second axis [m]")
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dataset", default="sphere2500.txt", help="g2o/EDGE3 file or GTSAM example")
    p.add_argument("--max-poses", type=int, default=None, help="keep the first N poses only")
    p.add_argument("--samples", type=int, default=20000, help="Monte Carlo samples")
    p.add_argument("--pose", type=int, default=None, help="vertex id (default: picked, see code)")
    p.add_argument("--out", type=Path, default=Path("."), help="directory for the PNG")
    p.add_argument("--no-show", action="store_true", help="accepted for symmetry; never shows")
    args = p.parse_args(argv)
    if args.samples < 50:
        p.error("--samples: need at least 50")
    args.out.mkdir(parents=True, exist_ok=True)

    graph, values, keys = optimized_graph(args.dataset, args.max_poses)
    marg = gtsam.Marginals(graph, values)
    key = pick_pose(marg, values, keys) if args.pose is None else args.pose
    if key not in keys:
        p.error(f"--pose: {key} is not a vertex of the graph")
    X = values.atPose3(key).matrix()
    cov_g = np.asarray(marg.marginalCovariance(key))
    cov_g = 0.5 * (cov_g + cov_g.T)
    print(
        f"pose {key} at t = {np.round(X[:3, 3], 2)} m; GTSAM marginal std (ω, v): "
        f"{np.array2string(np.sqrt(np.diag(cov_g)), precision=3)}"
    )
    rng = np.random.default_rng(0)
    results = []
    print(
        f"whitened gap to Monte Carlo ({args.samples} samples; sampling noise ≈ "
        f"{6 * np.sqrt(2 / args.samples):.2f}):"
    )
    print(
        f"  {'convention':<10} {'exact':<6} {'converted':>10} {'naive copy':>11} "
        f"{'reordered only':>15}"
    )
    for conv in TARGETS:
        converted = lb.gtsam.marginals(graph, values, [key], conv, marginals_object=marg)[0]
        mc = lb.check.monte_carlo_covariance(cov_g, X, "gtsam", conv, n=args.samples, rng=rng)
        cl = claims(cov_g, converted, conv)
        gaps = {name: whitened_gap(c, mc) for name, c in cl.items()}
        results.append((conv, cl, gaps))
        exact = "yes" if lb.is_exactly_linear("gtsam", conv) else "no"
        reo = f"{gaps['reordered only']:15.3g}" if "reordered only" in gaps else f"{'-':>15}"
        print(
            f"  {conv.name:<10} {exact:<6} {gaps['converted']:10.3g} "
            f"{gaps['naive copy']:11.3g} {reo}"
        )
    png = args.out / "covariance_between_libraries.png"
    title = (
        f"GTSAM marginal of pose {key} ({Path(args.dataset).name}) in other conventions: "
        "2σ position ellipses"
    )
    plot(X, cov_g, results, args.samples, png, title)
    print(f"plot: {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
