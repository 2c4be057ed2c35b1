"""The batched linearization of :func:`liebridge.gtsam.optimize` changes no number.

* the fused SE(3)-chart residual/Jacobians (one logarithm for both) equal the generic
  ``factor_math`` path and central differences through GTSAM's retraction;
* pairs of factors sharing their first-eliminated key, handed to GTSAM as one three-key
  ``JacobianFactor``, and shared damping factors leave the Hessian and the damped step unchanged;
* the numpy linear error equals GTSAM's ``GaussianFactorGraph.error``;
* the LM stays GTSAM's: same iterations and final error (1e-9 relative) as GTSAM's own
  ``LevenbergMarquardtOptimizer`` on a piece of sphere2500, for exactly-linear conventions
  against GTSAM's native factors and for the others against the same custom graph.
"""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from liebridge.check import numerical_jacobian
from liebridge.conventions import convert_covariance, get
from liebridge.gtsam import between, optimize, prior
from liebridge.gtsam import factor_math as F
from liebridge.gtsam.batch import poses_of
from liebridge.gtsam.optimize import _Damping, _SplitGraph
from liebridge.lie import se3
from liebridge.lie import unchecked as U

SE3_CHART = ["gtsam", "barfoot", "sophus", "manif"]


def _twists(n: int, rng: np.random.Generator) -> np.ndarray:
    """Twists with fixed edge-case angles (0, 1e-12, 1e-6, 1, near π) and 30 m translations."""
    angles = np.array([0.0, 1e-12, 1e-6, 1.0, np.pi - 1e-6])
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    w = axis * angles[np.arange(n) % len(angles), None]
    v = rng.uniform(-30.0, 30.0, size=(n, 3))
    return np.concatenate([w, v], axis=-1)


@pytest.mark.parametrize("conv", SE3_CHART)
@pytest.mark.parametrize("shape", [(10,), (2, 5)])
def test_fused_se3_chart_equals_the_generic_path(conv: str, shape: tuple[int, ...]) -> None:
    c = get(conv)
    rng = np.random.default_rng(len(conv))
    n = int(np.prod(shape))
    Z = U.se3_exp(_twists(n, rng)).reshape(*shape, 4, 4)
    # H near Z (the residual inside every chart, edge-case sizes) and far from it
    for H in (
        Z @ U.se3_exp(_twists(n, rng) * 1e-2).reshape(*shape, 4, 4),
        U.se3_exp(_twists(n, rng) * 0.5).reshape(*shape, 4, 4),
    ):
        xi = F.se3_chart_log(c, U.se3_inverse(Z), H)
        p = F.order_permutation(c)
        np.testing.assert_allclose(xi[..., p], F.residual(c, Z, H), atol=1e-9)
        for between_ in (True, False):
            Ji, Jj = F.jacobians(c, Z, H, between=between_)
            Fi, Fj = F.se3_chart_jacobians(c, xi, H, between_)
            scale = 1.0 + np.abs(Ji).max()
            np.testing.assert_allclose(Fi[..., p, :], Ji, atol=1e-9 * scale)
            if between_:
                assert Jj is not None and Fj is not None
                np.testing.assert_allclose(Fj[..., p, :], Jj, atol=1e-9 * scale)
            else:
                assert Fj is None
            # the whitening folded in before the adjoint is the same as after
            R = rng.normal(size=(*shape, 6, 6))
            Wi, Wj = F.se3_chart_jacobians(c, xi, H, between_, R)
            np.testing.assert_allclose(Wi, R @ Fi, atol=1e-9 * scale * 10)
            if between_:
                np.testing.assert_allclose(Wj, R @ Fj, atol=1e-9 * scale * 10)


def test_se3_jl_inv_equals_liebridges() -> None:
    xi = _twists(200, np.random.default_rng(0))
    ref = U.se3_jl_inv(xi)
    np.testing.assert_allclose(F.se3_jl_inv(xi), ref, atol=1e-12 * (1 + np.abs(ref).max()))
    w, v = xi[:, :3], xi[:, 3:]
    # Q is the lower-left block of Jl (liebridge.lie.unchecked.se3_jl), in (ω, v) order
    np.testing.assert_allclose(F.se3_q(w, v), U.se3_jl(xi)[:, 3:, :3], atol=1e-12)


@pytest.mark.parametrize("conv", SE3_CHART)
@pytest.mark.parametrize("seed", [0, 1])
def test_fused_jacobians_match_finite_differences(conv: str, seed: int) -> None:
    c = get(conv)
    rng = np.random.default_rng(seed)
    Ti, Tj = U.se3_exp(rng.normal(size=6) * 2), U.se3_exp(rng.normal(size=6) * 2)
    Z = c.retract(se3.inverse(Ti) @ Tj, rng.uniform(-0.3, 0.3, 6))
    Z_inv = se3.inverse(Z)
    p = F.order_permutation(c)
    gtsam_retract = get("gtsam").retract  # GTSAM's Pose3 retraction: T·Exp(ξ)

    def e_of_j(Tj_: np.ndarray) -> np.ndarray:
        return F.se3_chart_log(c, Z_inv, se3.inverse(Ti) @ Tj_)[..., p]

    def e_of_i(Ti_: np.ndarray) -> np.ndarray:
        return F.se3_chart_log(c, Z_inv, se3.inverse(Ti_) @ Tj)[..., p]

    H = se3.inverse(Ti) @ Tj
    Ji, Jj = F.se3_chart_jacobians(c, F.se3_chart_log(c, Z_inv, H), H, True)
    assert Jj is not None
    num_j = numerical_jacobian(e_of_j, Tj, retract=gtsam_retract, out_local="euclidean")
    num_i = numerical_jacobian(e_of_i, Ti, retract=gtsam_retract, out_local="euclidean")
    np.testing.assert_allclose(Jj[p], num_j, atol=1e-7)
    np.testing.assert_allclose(Ji[p], num_i, atol=1e-7)


def _circle(conv: str, seed: int, n: int = 12) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    """A circle with odometry and skip-two edges, initialized off: many factor pairs."""
    rng = np.random.default_rng(seed)
    T = [np.eye(4)]
    for _ in range(1, n):
        T.append(T[-1] @ se3.exp(np.r_[0, 0, 2 * np.pi / n, 2 * np.sin(np.pi / n), 0, 0]))
    g = gtsam.NonlinearFactorGraph()
    g.add(prior(0, T[0], np.eye(6) * 1e-4, conv, native=False))
    cov = np.diag([0.01, 0.01, 0.01, 0.04, 0.04, 0.04])
    for i in range(n):
        for j in (i + 1, i + 3):
            if j < n:
                Z = se3.inverse(T[i]) @ T[j] @ se3.exp(rng.normal(scale=0.05, size=6))
                g.add(between(i, j, Z, cov, conv, native=False))
    v = gtsam.Values()
    for k in range(n):
        v.insert(k, gtsam.Pose3(T[k] @ se3.exp(rng.normal(scale=0.2, size=6))))
    return g, v


@pytest.mark.parametrize("conv", ["barfoot", "g2o", "ros"])
def test_factor_pairs_and_shared_damping_leave_the_step_unchanged(conv: str) -> None:
    g, v = _circle(conv, 0)
    ordering = gtsam.Ordering.ColamdNonlinearFactorGraph(g)
    split = _SplitGraph(g, v, True, ordering)
    assert split.batch is not None
    plan = split.batch.plans["se3"]
    assert len(plan.pairs) >= 5  # the property below is exercised
    assert len(split.damping_groups()) > 0
    model = split.linear_model(v, None)
    ref = g.linearize(v)  # GTSAM, factor by factor, through the callbacks
    H, H_ref = model.graph.hessian(ordering), ref.hessian(ordering)
    np.testing.assert_allclose(H[0], H_ref[0], rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(H[1], H_ref[1], rtol=1e-10, atol=1e-8)
    keys = sorted(int(k) for k in g.keyVector())
    shared = _Damping(v, keys, split.damping_groups())
    plain = _Damping(v, keys)
    assert len(shared.blocks) < len(plain.blocks)
    for lam in (1e-5, 1.0):
        ours = shared.damped(model.graph, lam).optimize(ordering)
        theirs = plain.damped(ref, lam).optimize(ordering)
        for k in keys:
            np.testing.assert_allclose(ours.at(k), theirs.at(k), rtol=1e-9, atol=1e-12)
        # the linear error in numpy is GTSAM's
        assert model.error(ours) == pytest.approx(ref.error(ours), rel=1e-12)
        assert model.error_at_zero(ours) == pytest.approx(
            ref.error(gtsam.VectorValues.Zero(ours)), rel=1e-12
        )


def test_poses_of_refuses_stale_keys() -> None:
    v = gtsam.Values()
    for k in range(3):
        v.insert(k, gtsam.Pose3())
    keys, _ = poses_of(v)
    v.insert(7, gtsam.Pose3())
    with pytest.raises(ValueError, match="4 Pose3 entries, expected 3"):
        poses_of(v, "se3", keys)


# ----------------------------------------------------------- the LM stays GTSAM's (sphere2500)
def _sphere_piece(n: int) -> tuple[list[gtsam.BetweenFactorPose3], gtsam.Values]:
    graph, _ = gtsam.readG2o(gtsam.findExampleDataFile("sphere2500.txt"), True)
    edges = []
    for k in range(graph.size()):
        f = graph.at(k)
        i, j = f.keys()
        if i < n and j < n:
            edges.append(f)
    init = gtsam.Values()
    init.insert(0, gtsam.Pose3())
    for f in edges:
        i, j = f.keys()
        if j == i + 1 and not init.exists(j):
            init.insert(j, init.atPose3(i).compose(f.measured()))
    return edges, init


def _custom(edges: list, conv: str) -> gtsam.NonlinearFactorGraph:
    g = gtsam.NonlinearFactorGraph()
    prior_cov = np.eye(6) * 1e-8
    g.add(
        prior(
            0,
            np.eye(4),
            convert_covariance(prior_cov, np.eye(4), "gtsam", conv),
            conv,
            native=False,
        )
    )
    for f in edges:
        i, j = f.keys()
        M = f.measured().matrix()
        cov = convert_covariance(f.noiseModel().covariance(), M, "gtsam", conv)
        g.add(between(i, j, M, cov, conv, native=False))
    return g


@pytest.mark.parametrize("conv", ["barfoot", "sophus"])
def test_lm_equals_gtsams_native_lm_on_sphere2500_piece(conv: str) -> None:
    edges, init = _sphere_piece(400)
    native = gtsam.NonlinearFactorGraph()
    noise = gtsam.noiseModel.Gaussian.Covariance(np.eye(6) * 1e-8)
    native.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(), noise))
    for f in edges:
        native.add(f)
    custom = _custom(edges, conv)  # exactly linear: the same objective as GTSAM's factors
    p = gtsam.LevenbergMarquardtParams()
    opt = gtsam.LevenbergMarquardtOptimizer(native, init, p)
    ref = opt.optimize()
    ours = optimize(custom, init, p, progress=False)
    assert ours.iterations == opt.iterations() >= 5
    assert ours.final_error == pytest.approx(native.error(ref), rel=1e-9)


@pytest.mark.parametrize("conv", ["g2o", "ros"])
def test_lm_equals_gtsams_lm_on_the_same_custom_graph(conv: str) -> None:
    edges, init = _sphere_piece(80)  # GTSAM's LM pays a Values copy per callback: keep it small
    custom = _custom(edges, conv)
    p = gtsam.LevenbergMarquardtParams()
    opt = gtsam.LevenbergMarquardtOptimizer(custom, init, p)
    ref = opt.optimize()
    ours = optimize(custom, init, p, progress=False)
    assert ours.iterations == opt.iterations() >= 5  # loop closures: a real run
    assert ours.final_error == pytest.approx(custom.error(ref), rel=1e-9)


@pytest.mark.parametrize("ordering_type", ["COLAMD", "METIS"])  # NATURAL: GTSAM 4.3 refuses it
def test_ordering_type_is_gtsams(ordering_type: str) -> None:
    g, v = _circle("g2o", 3)
    p = gtsam.LevenbergMarquardtParams()
    p.setOrderingType(ordering_type)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v, p)
    ref = opt.optimize()
    ours = optimize(g, v, p, progress=False)
    assert ours.iterations == opt.iterations()
    assert ours.final_error == pytest.approx(g.error(ref), rel=1e-9)


def test_custom_ordering_is_refused_by_name() -> None:
    g, v = _circle("g2o", 0)
    p = gtsam.LevenbergMarquardtParams()
    p.setOrdering(gtsam.Ordering.ColamdNonlinearFactorGraph(g))
    with pytest.raises(ValueError, match=r"params\.orderingType: CUSTOM"):
        optimize(g, v, p, progress=False)


@pytest.mark.parametrize("rel", [1e-5, 0.3])
@pytest.mark.parametrize("lam0", [1e-12, 1e2])
@pytest.mark.parametrize("at_optimum", [False, True])
def test_lm_equals_gtsams_across_parameters_and_starts(
    rel: float, lam0: float, at_optimum: bool
) -> None:
    # the end game too: a start at GTSAM's optimum, loose tolerances, extreme initial λ
    g, v = _circle("ros", 1)
    if at_optimum:
        v = gtsam.LevenbergMarquardtOptimizer(g, v, gtsam.LevenbergMarquardtParams()).optimize()
    p = gtsam.LevenbergMarquardtParams()
    p.setRelativeErrorTol(rel)
    p.setlambdaInitial(lam0)
    p.setMaxIterations(50)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v, p)
    ref = opt.optimize()
    ours = optimize(g, v, p, progress=False)
    assert ours.iterations == opt.iterations()
    assert ours.final_error == pytest.approx(g.error(ref), rel=1e-9, abs=1e-12)
