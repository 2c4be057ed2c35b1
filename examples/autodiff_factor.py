"""A pose graph whose between factor is written in torch or JAX: GTSAM gets autodiff Jacobians.

Problem. You have a residual in torch or JAX (here GTSAM's own between error,
``Log(Z⁻¹·X_i⁻¹·X_j)``, but it could be anything of your poses) and want it in a GTSAM graph.
``gtsam.CustomFactor`` needs Jacobians by hand, in GTSAM's tangent: right perturbation
``X·Exp(ξ)``, ξ = (ω, v), rotation first — the usual mistakes are the order, the side, and the
``Jr⁻¹`` left out.

Conventions. ``liebridge.gtsam.autodiff_factor(residual, keys, noise, convention, backend)``
differentiates ``residual`` through the named convention's retraction (``--convention``: PyPose's
left, translation-first ``Exp(d)·X``; GTSAM's own; Sophus; SymForce's split chart) with
``jacfwd`` and maps the columns to GTSAM's tangent with ``convention.from_canonical(X)``: the
factor's Jacobians are the same whichever convention the derivative was taken in.
``liebridge.gtsam.optimize`` evaluates all the factors of one residual function in one ``vmap``
call per pass.

Data. The first ``--max-poses`` poses of GTSAM's shipped ``sphere2500.txt`` (its edges, their
information over GTSAM's tangent).

What to look at. The Jacobians of one factor against ``BetweenFactorPose3``'s (to 1e-9), then the
same graph optimized with native factors and with autodiff factors: the same final error, poses
equal to ~1e-9.

Run: ``python examples/autodiff_factor.py [--backend torch|jax] [--convention pypose]
[--max-poses 100]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import gtsam
import numpy as np

import liebridge as lb


# ------------------------------------------------------------------ what the user writes
# One function for both frameworks (``xp`` is ``torch`` or ``jax.numpy``), of one pose at a time:
# the factor vectorises it with vmap. No Python ``if`` on values (vmap and jit cannot see them):
# the small-angle branches are chosen with ``where``, their arguments made safe by a second
# ``where`` so that no sqrt or division at zero enters the derivative (a NaN gradient otherwise).
def se3_inverse(T: Any, xp: Any) -> Any:
    """``T⁻¹`` of a (4, 4) pose ``[R t; 0 1]``: ``[Rᵀ −Rᵀt; 0 1]``."""
    Rt = T[:3, :3].mT
    t = -(Rt @ T[:3, 3:4])
    return xp.concatenate([xp.concatenate([Rt, t], -1), T[3:4, :]], -2)


def se3_log(T: Any, xp: Any) -> Any:
    """GTSAM's ``Pose3.Logmap``: ``(ω, v)`` with ``T = Exp(ω, v)``, for angles below π − 1e-6."""
    R, t = T[:3, :3], T[:3, 3]
    a = xp.stack([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])  # 2 sinθ·axis
    a2 = (a * a).sum()
    small = a2 < 1e-12
    s = xp.sqrt(xp.where(small, xp.ones_like(a2), a2)) / 2  # sinθ (safe)
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1) / 2  # cosθ
    th = xp.arctan2(s, c)
    w = xp.where(small, 0.5 + a2 / 48, th / (2 * s)) * a  # θ/(2 sinθ) = 1/2 + θ²/12 + …
    t2 = (w * w).sum()
    small2 = t2 < 1e-6
    safe = xp.where(small2, xp.ones_like(t2), t2)
    th2 = xp.sqrt(safe)
    # V⁻¹ = I − W/2 + D·W², D = (1 − θ sinθ / (2(1 − cosθ))) / θ²
    D = xp.where(
        small2,
        1 / 12 + t2 / 720 + t2 * t2 / 30240,
        (1 - th2 * xp.sin(th2) / (2 * (1 - xp.cos(th2)))) / safe,
    )
    Wt = xp.stack([w[1] * t[2] - w[2] * t[1], w[2] * t[0] - w[0] * t[2], w[0] * t[1] - w[1] * t[0]])
    WWt = xp.stack(
        [w[1] * Wt[2] - w[2] * Wt[1], w[2] * Wt[0] - w[0] * Wt[2], w[0] * Wt[1] - w[1] * Wt[0]]
    )
    return xp.concatenate([w, t - Wt / 2 + D * WWt])


def between_torch(X_i: Any, X_j: Any, Z: Any) -> Any:
    """GTSAM's between error ``Log(Z⁻¹·X_i⁻¹·X_j)`` in torch."""
    import torch

    return se3_log(se3_inverse(Z, torch) @ se3_inverse(X_i, torch) @ X_j, torch)


def between_jax(X_i: Any, X_j: Any, Z: Any) -> Any:
    """GTSAM's between error ``Log(Z⁻¹·X_i⁻¹·X_j)`` in JAX."""
    import jax.numpy as jnp

    return se3_log(se3_inverse(Z, jnp) @ se3_inverse(X_i, jnp) @ X_j, jnp)


BETWEEN = {"torch": between_torch, "jax": between_jax}


# ------------------------------------------------------------------ the graph
def load(max_poses: int) -> lb.io.g2o.G2OGraph:
    """Read the first ``max_poses`` poses of sphere2500 and the edges among them."""
    g = lb.io.g2o.read(gtsam.findExampleDataFile("sphere2500.txt"))
    keep = np.sort(g.vertex_ids)[:max_poses]
    v, e = np.isin(g.vertex_ids, keep), np.isin(g.edges, keep).all(axis=1)
    return lb.io.g2o.G2OGraph(
        vertex_ids=g.vertex_ids[v],
        vertex_xyz_qxyzw=g.vertex_xyz_qxyzw[v],
        edges=g.edges[e],
        measured_xyz_qxyzw=g.measured_xyz_qxyzw[e],
        information=g.information[e],
        information_reading=g.information_reading,
    )


def graphs(g: lb.io.g2o.G2OGraph, backend: str, convention: str) -> tuple[Any, Any, Any]:
    """``(native graph, autodiff graph, initial values)``: the same objective twice."""
    native, auto = gtsam.NonlinearFactorGraph(), gtsam.NonlinearFactorGraph()
    first = int(g.vertex_ids[0])
    prior = gtsam.noiseModel.Isotropic.Sigma(6, 1e-4)
    for graph in (native, auto):
        graph.add(gtsam.PriorFactorPose3(first, gtsam.Pose3(g.poses[0]), prior))
    for (i, j), Z, info in zip(g.edges.tolist(), g.measured, g.information, strict=True):
        noise = gtsam.noiseModel.Gaussian.Information(info)
        native.add(gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Z), noise))
        auto.add(
            lb.gtsam.autodiff_factor(
                BETWEEN[backend], [i, j], noise, convention, backend, data=(Z,)
            )
        )
    values = gtsam.Values()
    for k, T in zip(g.vertex_ids.tolist(), g.poses, strict=True):
        values.insert(k, gtsam.Pose3(T))
    return native, auto, values


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--backend", choices=sorted(BETWEEN), default="torch")
    p.add_argument("--convention", default="pypose")
    p.add_argument("--max-poses", type=int, default=100)
    a = p.parse_args(argv)
    g = load(a.max_poses)
    native, auto, values = graphs(g, a.backend, a.convention)
    print(
        f"{len(g.vertex_ids)} poses, {len(g.edges)} between factors ({a.backend}, {a.convention})"
    )

    # one factor against GTSAM's: error and whitened Jacobians (A, b) of the linearization
    mine, ref = auto.at(1).linearize(values), native.at(1).linearize(values)
    (A, b), (A_ref, b_ref) = mine.jacobian(), ref.jacobian()
    print(f"one factor vs BetweenFactorPose3: max |ΔA| = {np.abs(A - A_ref).max():.2e}, ", end="")
    print(f"max |Δb| = {np.abs(b - b_ref).max():.2e}")

    t0 = time.perf_counter()
    r_native = lb.gtsam.optimize(native, values)
    t1 = time.perf_counter()
    r_auto = lb.gtsam.optimize(auto, values)
    t2 = time.perf_counter()
    dT = max(
        np.abs(r_native.values.atPose3(k).matrix() - r_auto.values.atPose3(k).matrix()).max()
        for k in g.vertex_ids.tolist()
    )
    print(f"native:   error {r_native.initial_error:.6f} -> {r_native.final_error:.9f}, ", end="")
    print(f"{r_native.iterations} iterations, {t1 - t0:.2f} s")
    print(f"autodiff: error {r_auto.initial_error:.6f} -> {r_auto.final_error:.9f}, ", end="")
    print(f"{r_auto.iterations} iterations, {t2 - t1:.2f} s (JAX: includes jit compilation)")
    print(f"max |ΔT| between the two optima: {dT:.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
