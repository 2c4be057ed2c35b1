"""One pose graph, two back ends: pyceres with liebridge's costs against GTSAM, one convention.

Problem. A pose graph (GTSAM's ``pose3example.txt``, g2o format) is solved with GTSAM's
Levenberg–Marquardt and with Ceres through ``pyceres``. In pyceres a pose is a quaternion block
(``QuaternionManifold``: left, **half-angle** tangent, ``[w, x, y, z]``) plus a world
translation block, and a Python cost function must hand Ceres Jacobians with respect to the
**stored** 4-vector and 3-vector, not the tangent. ``liebridge.ceres`` builds the costs
(residual = the convention's ``local``, Jacobians by the chain rule through the quaternion) and
reads Ceres's tangent-space covariance back into GTSAM's convention.

Conventions. Costs in ``gtsam`` (``Log(Z⁻¹ Ti⁻¹ Tj)``, ``(ω, v)``), then ``sophus`` (``(v, ω)``)
and ``barfoot`` (left, ``Ad_Z`` image): all three define the same objective, so the same optimum.
Covariances: ``liebridge.ceres.covariance(..., convention="gtsam")`` against ``gtsam.Marginals``.

What to look at. The relative cost difference and the marginals' relative errors: ~1e-9 or
below. Then two wrong readings and their numbers: the tangent Jacobian handed to Ceres as
``[J 0]`` (Ceres stops at a different point, a higher cost), and the half-angle rotation block
read as a full angle (marginal rotation block 4× too small: relative error ≈ 0.75).

Run: ``python examples/ceres_pose_graph.py [--dataset pose3example.txt]``.
"""

from __future__ import annotations

import argparse

import gtsam
import numpy as np
import pyceres

from liebridge import ceres as lbc
from liebridge.conventions import get
from liebridge.lie import se3

GTSAM = get("gtsam")
PRIOR_COV = 1e-6 * np.eye(6)  # the gauge: a prior on the first vertex, in both back ends


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


class TangentJacobianCost(lbc.costs.BetweenCost):
    """The common mistake: ∂r/∂ω (GTSAM's right tangent) padded with a zero column as ∂r/∂q."""

    def residual_and_jacobians(self, parameters):  # type: ignore[no-untyped-def]
        """Return the right residual with the quaternion Jacobians replaced by ``[0 | ∂r/∂ω]``."""
        r, J = super().residual_and_jacobians(parameters)
        Ti = lbc.pose_from_blocks(parameters[0], parameters[1])
        Tj = lbc.pose_from_blocks(parameters[2], parameters[3])
        Y = se3.inverse(Ti) @ Tj
        G = self.sqrt_information @ GTSAM.local_jacobian(self.measured, Y)  # ∂r/∂ξ_j, (ω, v)
        Gi = -G @ se3.adjoint(se3.inverse(Y))  # ∂r/∂ξ_i
        pad = np.zeros((6, 1))
        return r, [np.hstack([pad, Gi[:, :3]]), J[1], np.hstack([pad, G[:, :3]]), J[3]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default="pose3example.txt")
    args = ap.parse_args()
    g = lbc.graph_from_g2o(gtsam.findExampleDataFile(args.dataset))
    first = int(g.vertex_ids[0])

    # GTSAM: the same graph, a prior on the first vertex
    graph, init = g.to_gtsam(prior=None)  # the prior is added below
    T0 = init.atPose3(first).matrix()
    graph.add(
        gtsam.PriorFactorPose3(
            first, gtsam.Pose3(T0), gtsam.noiseModel.Gaussian.Covariance(PRIOR_COV)
        )
    )
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(0.0)  # run to convergence (LM stops when no step decreases)
    params.setAbsoluteErrorTol(0.0)
    params.setMaxIterations(500)
    result = gtsam.LevenbergMarquardtOptimizer(graph, init, params).optimize()
    marginals = gtsam.Marginals(graph, result)
    f_gtsam = graph.error(result)
    print(f"GTSAM LM: final error {f_gtsam:.10g} ({len(g.vertex_ids)} poses, {len(g.edges)} edges)")

    # pyceres: the g2o graph with liebridge's costs, in three conventions
    for convention in ("gtsam", "sophus", "barfoot"):
        cp = lbc.problem_from_values(graph, init, convention=convention)
        summary = cp.solve()
        f = cp.cost()
        dT = max(np.abs(cp.poses()[k] - result.atPose3(k).matrix()).max() for k in cp.blocks)
        print(
            f"pyceres, {convention:7s} costs: final cost {f:.10g}, relative difference "
            f"{abs(f - f_gtsam) / f_gtsam:.1e}, max pose difference {dT:.1e} "
            f"({summary.num_successful_steps} steps)"
        )
        if convention == "gtsam":
            errs = [rel(cp.covariance(k), marginals.marginalCovariance(k)) for k in cp.blocks]
            print(
                "  marginals (covariance(..., 'gtsam') vs gtsam.Marginals): max relative "
                f"error {max(errs):.1e}"
            )
            keys = sorted(cp.blocks)[1:3]
            joint = marginals.jointMarginalCovariance(gtsam.KeyVector(keys)).fullMatrix()
            print(
                f"  joint marginal of {keys}: relative error {rel(cp.covariance(*keys), joint):.1e}"
            )
            k = keys[0]
            q, t = cp.blocks[k]
            cov = pyceres.Covariance(pyceres.CovarianceOptions())
            cov.compute([(q, q)], cp.problem)
            raw = np.asarray(cov.get_covariance_block_tangent_space(q, q, cp.problem)).reshape(3, 3)
            R = cp.poses()[k][:3, :3]
            ref = marginals.marginalCovariance(k)[:3, :3]
            print(
                f"  wrong reading: half-angle rotation block as a full angle (Rᵀ Σ R): relative "
                f"error {rel(R.T @ raw @ R, ref):.2f}; right (2Rᵀ Σ 2R): "
                f"{rel(4 * R.T @ raw @ R, ref):.1e}"
            )

    # the wrong Jacobian: tangent Jacobian handed to Ceres as an ambient one
    problem = pyceres.Problem()
    blocks, keep = {}, []
    for key in init.keys():
        q, t = lbc.pose_blocks(init.atPose3(key).matrix())
        blocks[int(key)] = (q, t)
        problem.add_parameter_block(q, 4)
        problem.set_manifold(q, lbc.quaternion_manifold())
    for (i, j), Z, info in zip(g.edges.tolist(), g.measured, g.information, strict=True):
        c = TangentJacobianCost(Z, GTSAM, np.linalg.cholesky(info).T, "wxyz")
        keep.append(c)
        problem.add_residual_block(c, None, [*blocks[i], *blocks[j]])
    c = lbc.prior_cost(T0, PRIOR_COV)
    keep.append(c)
    problem.add_residual_block(c, None, list(blocks[first]))
    wrong = lbc.CeresProblem(problem, blocks, "wxyz", keep)
    wrong.solve()
    fw = wrong.cost()
    print(
        f"wrong Jacobian ([J_ω 0] as ∂r/∂q): final cost {fw:.10g}, relative difference "
        f"{abs(fw - f_gtsam) / f_gtsam:.1e}"
    )


if __name__ == "__main__":
    main()
