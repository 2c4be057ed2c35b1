"""liebridge.uncertain: every operation against Monte Carlo, GTSAM's H matrices, finite
differences, pytransform3d, and the three public bugs; bad input."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gtsam
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liebridge import check
from liebridge import uncertain as u
from liebridge.check import numerical_jacobian
from liebridge.conventions import PRESETS, convert_covariance, get
from liebridge.lie import se3, so3

NAMES = [c.name for c in PRESETS]
T1 = se3.exp(np.r_[0.3, -0.2, 0.5, 2.0, -1.0, 0.5])
T2 = se3.exp(np.r_[-0.4, 0.3, 0.2, 1.5, 0.5, -2.0])
TF = se3.exp(np.r_[1.2, -0.7, 0.4, 0.3, -4.0, 1.0])  # a fixed transform (extrinsic / frame)
P = np.array([1.0, -2.0, 0.5])


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def _joint(scale: float, seed: int = 3, dim: int = 12) -> np.ndarray:
    L = np.random.default_rng(seed).normal(size=(dim, dim))
    return scale * (L @ L.T / dim + 0.2 * np.eye(dim))


JOINT = _joint(1e-4)
CROSS = JOINT[:6, 6:]


def _pair(name: str, joint: np.ndarray = JOINT) -> tuple[u.UncertainPose, u.UncertainPose]:
    return u.UncertainPose(T1, joint[:6, :6], name), u.UncertainPose(T2, joint[6:, 6:], name)


# ------------------------------------------------------------------ Monte Carlo, every preset
N_MC = 60000
OPS: dict[str, tuple[Callable[..., Any], Callable[..., Any]]] = {
    "compose": (
        lambda A, B: u.compose(A, B, CROSS),
        lambda A, B: check.monte_carlo_compose(A, B, CROSS, n=N_MC),
    ),
    "inverse": (lambda A, B: u.inverse(A), lambda A, B: check.monte_carlo_inverse(A, n=N_MC)),
    "relative": (
        lambda A, B: u.relative(A, B, CROSS),
        lambda A, B: check.monte_carlo_relative(A, B, CROSS, n=N_MC),
    ),
    "transform_left": (
        lambda A, B: u.transform(A, TF, "left"),
        lambda A, B: check.monte_carlo_transform(A, TF, "left", n=N_MC),
    ),
    "transform_right": (
        lambda A, B: u.transform(A, TF, "right"),
        lambda A, B: check.monte_carlo_transform(A, TF, "right", n=N_MC),
    ),
    "transform_uncertain_extrinsic": (
        lambda A, B: u.transform(A, B, "right"),
        lambda A, B: check.monte_carlo_compose(A, B, n=N_MC),
    ),
    "act": (
        lambda A, B: u.act(A, P, 1e-4 * np.eye(3)),
        lambda A, B: check.monte_carlo_act(A, P, 1e-4 * np.eye(3), n=N_MC),
    ),
}


@pytest.mark.parametrize("op", list(OPS))
@pytest.mark.parametrize("name", NAMES)
def test_linear_matches_monte_carlo_every_preset(name: str, op: str) -> None:
    A, B = _pair(name)
    lin, mc = OPS[op][0](A, B), OPS[op][1](A, B)
    assert _rel(lin.cov, mc.cov) <= 0.02
    mean_lin = lin.p if op == "act" else lin.T
    mean_mc = mc.p if op == "act" else mc.T
    np.testing.assert_allclose(mean_lin, mean_mc, atol=1e-12)


@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot", "symforce"])
def test_rotations_against_monte_carlo(name: str) -> None:
    R1, R2 = T1[:3, :3], T2[:3, :3]
    J = _joint(1e-4, dim=6)
    A = u.UncertainPose(R1, J[:3, :3], name)
    B = u.UncertainPose(R2, J[3:, 3:], name)
    X = J[:3, 3:]
    n = 60000
    assert _rel(u.compose(A, B, X).cov, check.monte_carlo_compose(A, B, X, n=n).cov) < 0.02
    assert _rel(u.inverse(A).cov, check.monte_carlo_inverse(A, n=n).cov) < 0.02
    assert _rel(u.relative(A, B, X).cov, check.monte_carlo_relative(A, B, X, n=n).cov) < 0.02
    assert (
        _rel(u.transform(A, R2, "right").cov, check.monte_carlo_transform(A, R2, "right").cov)
        < 0.02
    )
    assert _rel(u.act(A, P).cov, check.monte_carlo_act(A, P, n=n).cov) < 0.02


# ------------------------------------------------------------------ GTSAM's H propagation
def _gtsam_pose(T: np.ndarray) -> Any:
    return gtsam.Pose3(T)


def _h(*shapes: tuple[int, int]) -> list[np.ndarray]:
    return [np.zeros(s, order="F") for s in shapes]


@pytest.mark.parametrize("name", NAMES)
def test_linear_equals_gtsam_h_propagation(name: str) -> None:
    """A in any preset → GTSAM tangent → H Σ Hᵀ with GTSAM's own H → back: equals ours to 1e-9."""
    A, B = _pair(name)
    Ag, Bg = A.to("gtsam"), B.to("gtsam")
    Mg_A = get(name).to_canonical(T1)  # δ_g = M δ_c
    Mg_B = get(name).to_canonical(T2)
    Xg = Mg_A @ CROSS @ Mg_B.T
    joint = np.block([[Ag.cov, Xg], [Xg.T, Bg.cov]])
    pa, pb = _gtsam_pose(T1), _gtsam_pose(T2)

    def back(T: np.ndarray, cov: np.ndarray) -> np.ndarray:
        return convert_covariance(cov, T, "gtsam", name)

    H1, H2 = _h((6, 6), (6, 6))
    C = pa.compose(pb, H1, H2).matrix()
    H = np.hstack([H1, H2])
    np.testing.assert_allclose(u.compose(A, B, CROSS).cov, back(C, H @ joint @ H.T), atol=1e-13)

    (Hi,) = _h((6, 6))
    C = pa.inverse(Hi).matrix()
    np.testing.assert_allclose(u.inverse(A).cov, back(C, Hi @ Ag.cov @ Hi.T), atol=1e-13)

    H1, H2 = _h((6, 6), (6, 6))
    C = pa.between(pb, H1, H2).matrix()
    H = np.hstack([H1, H2])
    np.testing.assert_allclose(u.relative(A, B, CROSS).cov, back(C, H @ joint @ H.T), atol=1e-13)

    Hp, Hq = _h((3, 6), (3, 3))
    cov_p = 1e-4 * np.diag([1.0, 2.0, 3.0])
    pa.transformFrom(P, Hp, Hq)
    want = Hp @ Ag.cov @ Hp.T + Hq @ cov_p @ Hq.T
    np.testing.assert_allclose(u.act(A, P, cov_p).cov, want, atol=1e-13)
    assert np.abs(want).max() > 1e-5  # not a comparison of zeros


def test_rotation_act_equals_gtsam_rot3_rotate() -> None:
    R = T1[:3, :3]
    A = u.UncertainPose(R, 1e-3 * np.diag([1.0, 2.0, 3.0]), "gtsam")
    H1, H2 = _h((3, 3), (3, 3))
    gtsam.Rot3(R).rotate(P, H1, H2)
    np.testing.assert_allclose(u.act(A, P).cov, H1 @ A.cov @ H1.T, atol=1e-14)


# ------------------------------------------------------------------ finite differences
@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot", "symforce", "g2o", "ceres_pose"])
def test_linear_is_the_finite_difference_jacobian_sandwich(name: str) -> None:
    """J from central differences of the exact operation through the preset's retract/local."""
    c = get(name)
    A, B = _pair(name)
    kw: dict[str, Any] = {"in_convention": c, "out_convention": c}

    def sandwich(JA: np.ndarray, JB: np.ndarray) -> np.ndarray:
        J = np.hstack([JA, JB])
        return J @ JOINT @ J.T

    JA = numerical_jacobian(lambda X: X @ T2, T1, **kw)
    JB = numerical_jacobian(lambda X: T1 @ X, T2, **kw)
    np.testing.assert_allclose(u.compose(A, B, CROSS).cov, sandwich(JA, JB), atol=1e-11)
    JA = numerical_jacobian(lambda X: np.linalg.inv(X) @ T2, T1, **kw)
    JB = numerical_jacobian(lambda X: np.linalg.inv(T1) @ X, T2, **kw)
    np.testing.assert_allclose(u.relative(A, B, CROSS).cov, sandwich(JA, JB), atol=1e-11)
    Ji = numerical_jacobian(np.linalg.inv, T1, **kw)
    np.testing.assert_allclose(u.inverse(A).cov, Ji @ A.cov @ Ji.T, atol=1e-11)
    Jl = numerical_jacobian(lambda X: TF @ X, T1, **kw)
    np.testing.assert_allclose(u.transform(A, TF, "left").cov, Jl @ A.cov @ Jl.T, atol=1e-11)
    Jp = numerical_jacobian(
        lambda X: X[..., :3, :3] @ P + X[..., :3, 3], T1, retract=c.retract, out_local="euclidean"
    )
    np.testing.assert_allclose(u.act(A, P).cov, Jp @ A.cov @ Jp.T, atol=1e-11)


# ------------------------------------------------------------------ unscented
BIG_ROT = 0.3**2  # rad² on each rotation axis


def _big(name: str) -> np.ndarray:
    c = get(name)
    cov = 0.01 * np.eye(6)
    rot = slice(0, 3) if c.order == "rot_first" else slice(3, 6)
    cov[rot, rot] = BIG_ROT * np.eye(3)
    return cov


@pytest.mark.parametrize("name", ["ros", "symforce"])
@pytest.mark.parametrize("op", ["compose", "inverse", "relative", "transform_right", "act"])
def test_unscented_beats_linear_for_decoupled_charts(name: str, op: str) -> None:
    A = u.UncertainPose(T1, _big(name), name)
    B = u.UncertainPose(T2, _big(name), name)
    n = 200000
    if op == "compose":
        f: Callable[[str], Any] = lambda m: u.compose(A, B, method=m)  # noqa: E731
        mc = check.monte_carlo_compose(A, B, n=n).cov
    elif op == "inverse":
        f = lambda m: u.inverse(A, m)  # noqa: E731
        mc = check.monte_carlo_inverse(A, n=n).cov
    elif op == "relative":
        f = lambda m: u.relative(A, B, method=m)  # noqa: E731
        mc = check.monte_carlo_relative(A, B, n=n).cov
    elif op == "transform_right":
        f = lambda m: u.transform(A, TF, "right", m)  # noqa: E731
        mc = check.monte_carlo_transform(A, TF, "right", n=n).cov
    else:
        f = lambda m: u.act(A, P, method=m)  # noqa: E731
        mc = check.monte_carlo_act(A, P, n=n).cov
    e_lin, e_uns = _rel(f("linear").cov, mc), _rel(f("unscented").cov, mc)
    assert e_lin > 0.05  # the chart really is nonlinear here
    assert e_uns < 0.25 * e_lin
    assert e_uns < 0.03


@pytest.mark.parametrize("name", ["gtsam", "sophus", "barfoot", "pytransform3d_global"])
def test_inverse_exactly_linear_in_se3_exponential_charts(name: str) -> None:
    A = u.UncertainPose(T1, _big(name), name)
    lin, uns = u.inverse(A).cov, u.inverse(A, "unscented").cov
    np.testing.assert_allclose(uns, lin, atol=1e-9 * np.abs(lin).max())


def test_unscented_equals_linear_at_tiny_covariance() -> None:
    A, B = _pair("ros", _joint(1e-10))
    lin, uns = u.compose(A, B, CROSS * 1e-6), u.compose(A, B, CROSS * 1e-6, method="unscented")
    np.testing.assert_allclose(uns.cov, lin.cov, rtol=1e-4, atol=1e-16)


@pytest.mark.parametrize("n", [1, 3, 6, 12])
def test_sigma_points_integrate_degree_five_exactly(n: int) -> None:
    pts, w = u.sigma_points(n)
    assert pts.shape == (2 * n * n + 1, n)
    assert np.isclose(w.sum(), 1.0)
    rng = np.random.default_rng(n)
    # Gaussian moments: E[x_i²] = 1, E[x_i⁴] = 3, E[x_i² x_j²] = 1, odd moments 0
    np.testing.assert_allclose(np.einsum("k,ki,kj->ij", w, pts, pts), np.eye(n), atol=1e-12)
    np.testing.assert_allclose(np.einsum("k,ki->i", w, pts**4), 3.0, atol=1e-12)
    if n > 1:
        np.testing.assert_allclose(np.sum(w * pts[:, 0] ** 2 * pts[:, 1] ** 2), 1.0, atol=1e-12)
    for _ in range(5):  # random odd monomials of degree ≤ 5 vanish
        idx = rng.integers(0, n, size=rng.choice([1, 3, 5]))
        assert abs(np.sum(w * np.prod(pts[:, idx], axis=1))) < 1e-12


# ------------------------------------------------------------------ pytransform3d
def test_against_pytransform3d_invert_uncertain_transform() -> None:
    unc = pytest.importorskip("pytransform3d.uncertainty")
    A = u.UncertainPose(T1, JOINT[:6, :6], "pytransform3d_global")
    mean, cov = unc.invert_uncertain_transform(T1, JOINT[:6, :6])
    C = u.inverse(A)
    np.testing.assert_allclose(C.T, mean, atol=1e-12)
    np.testing.assert_allclose(C.cov, cov, atol=1e-14)


@pytest.mark.parametrize("scale", [1e-6, 1e-4])
def test_against_pytransform3d_concatenations(scale: float) -> None:
    """Meyer et al.'s local concatenation is first order: equal. Barfoot & Furgale's global one
    adds fourth-order terms: relative difference O(σ²) (measured 0.47·scale)."""
    unc = pytest.importorskip("pytransform3d.uncertainty")
    J = _joint(scale)
    ca, cb = J[:6, :6], J[6:, 6:]
    # globally uncertain (left, (ω, v)): T_CA = T_CB · T_BA (Barfoot & Furgale, 4th order)
    mean, cov = unc.concat_globally_uncertain_transforms(T1, ca, T2, cb)
    ours = u.compose(
        u.UncertainPose(T2, cb, "pytransform3d_global"),
        u.UncertainPose(T1, ca, "pytransform3d_global"),
    )
    np.testing.assert_allclose(ours.T, mean, atol=1e-12)
    assert 0.1 * scale < _rel(ours.cov, cov) < scale
    # locally uncertain (right, (ω, v)): T_CA = T_CB Exp(ξ_B) T_BA Exp(ξ_A) (Meyer et al.)
    mean, cov = unc.concat_locally_uncertain_transforms(T1, T2, ca, cb)
    ours = u.compose(
        u.UncertainPose(T2, cb, "pytransform3d_local"),
        u.UncertainPose(T1, ca, "pytransform3d_local"),
    )
    np.testing.assert_allclose(ours.T, mean, atol=1e-12)
    assert _rel(ours.cov, cov) < 1e-12


# ------------------------------------------------------------------ the public bugs
def test_regression_inverse_with_ad_t_is_wrong_in_a_left_convention() -> None:
    """Barfoot / Mangelson (left perturbation): Σ⁻ = Ad_{T⁻¹} Σ Ad_{T⁻¹}ᵀ, not Ad_T Σ Ad_Tᵀ."""
    A = u.UncertainPose(T1, JOINT[:6, :6], "barfoot")
    mc = check.monte_carlo_inverse(A, n=100000).cov
    P6 = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])  # (v,ω)↔(ω,v)
    wrong = P6 @ se3.adjoint(T1) @ P6 @ A.cov @ (P6 @ se3.adjoint(T1) @ P6).T
    assert _rel(u.inverse(A).cov, mc) < 0.02
    assert _rel(wrong, mc) > 0.5
    # and in a right convention the same wrong-side adjoint (Ad_{T⁻¹}) is the bug
    B = u.UncertainPose(T1, JOINT[:6, :6], "gtsam")
    Ai = se3.adjoint(se3.inverse(T1))
    mc = check.monte_carlo_inverse(B, n=100000).cov
    assert _rel(u.inverse(B).cov, mc) < 0.02
    assert _rel(Ai @ B.cov @ Ai.T, mc) > 0.5


def test_regression_composition_without_cross_term() -> None:
    """Strongly correlated A, B (joint marginal of neighbouring poses): the cross term matters."""
    s = np.random.default_rng(7).normal(size=(6, 6))
    base = 1e-4 * (s @ s.T / 6 + 0.1 * np.eye(6))
    joint = np.block([[base, 0.95 * base], [0.95 * base, base]])
    A, B = _pair("gtsam", joint)
    X = joint[:6, 6:]
    mc = check.monte_carlo_compose(A, B, X, n=100000).cov
    assert _rel(u.compose(A, B, X).cov, mc) < 0.02
    assert _rel(u.compose(A, B).cov, mc) > 0.2
    mc = check.monte_carlo_relative(A, B, X, n=100000).cov
    assert _rel(u.relative(A, B, X).cov, mc) < 0.02
    assert _rel(u.relative(A, B).cov, mc) > 0.5


def test_regression_tf2_unrotated_covariance() -> None:
    """ROS PoseWithCovariance moved to a rotated parent frame: the covariance must rotate."""
    A = u.UncertainPose(T1, np.diag([1e-2, 1e-4, 1e-4, 1e-3, 1e-5, 1e-5]), "ros")
    F = se3.exp(np.r_[0.0, 0.0, np.pi / 2, 5.0, 0.0, 0.0])  # T_map_odom: 90° about z
    mc = check.monte_carlo_transform(A, F, "left", n=100000).cov
    ours = u.transform(A, F, "left").cov
    assert _rel(ours, mc) < 0.02
    assert _rel(A.cov, mc) > 0.5  # tf2's unrotated copy
    R = F[:3, :3]
    np.testing.assert_allclose(ours[:3, :3], R @ A.cov[:3, :3] @ R.T, atol=1e-15)


# ------------------------------------------------------------------ fusion
def test_fuse_equal_means_is_information_fusion() -> None:
    for name in ("gtsam", "ros", "g2o"):
        A = u.UncertainPose(T1, JOINT[:6, :6], name)
        B = u.UncertainPose(T1, JOINT[6:, 6:], name)
        F = u.fuse(A, B)
        want = np.linalg.inv(np.linalg.inv(A.cov) + np.linalg.inv(B.cov))
        np.testing.assert_allclose(F.cov, want, rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(F.T, T1, atol=1e-12)


def test_fuse_equals_gtsam_two_priors() -> None:
    """MAP and covariance of two PriorFactorPose3 on one key, optimized and marginalized."""
    Tb = T1 @ se3.exp(np.r_[0.05, -0.03, 0.02, 0.1, 0.2, -0.1])
    A = u.UncertainPose(T1, JOINT[:6, :6], "gtsam")
    B = u.UncertainPose(Tb, JOINT[6:, 6:], "gtsam")
    graph = gtsam.NonlinearFactorGraph()
    for E in (A, B):
        noise = gtsam.noiseModel.Gaussian.Covariance(np.array(E.cov))
        graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(E.T), noise))
    init = gtsam.Values()
    init.insert(0, gtsam.Pose3(T1))
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-15)
    params.setAbsoluteErrorTol(1e-15)
    res = gtsam.LevenbergMarquardtOptimizer(graph, init, params).optimize()
    cov = gtsam.Marginals(graph, res).marginalCovariance(0)
    F = u.fuse(A, B)
    np.testing.assert_allclose(F.T, res.atPose3(0).matrix(), atol=1e-9)
    np.testing.assert_allclose(F.cov, cov, rtol=1e-7, atol=1e-13)
    # the same densities described in ROS's tangent fuse to the same pose only to first order;
    # the covariance converts exactly when the problem is posed in GTSAM and read in ROS
    Fr = u.fuse(A.to("ros"), B.to("ros"))
    assert np.abs(Fr.T - F.T).max() < 1e-3


def test_fuse_with_one_singular_covariance_and_average() -> None:
    cov_s = np.diag([1e-4, 1e-4, 1e-4, 0.0, 1e-4, 1e-4])  # v_x known exactly
    Tb = T1 @ se3.exp(np.r_[0.01, 0.0, 0.0, 0.05, 0.02, 0.0])
    A = u.UncertainPose(T1, cov_s, "gtsam")
    B = u.UncertainPose(Tb, 1e-3 * np.eye(6), "gtsam")
    F = u.fuse(A, B)
    J0 = get("gtsam").local_jacobian(T1, F.T)  # A's chart read at the fused pose
    assert (J0 @ F.cov @ J0.T)[3, 3] < 1e-16 < F.cov[4, 4] * 1e-6
    assert abs(get("gtsam").local(T1, F.T)[3]) < 1e-9  # the exact direction is kept
    G = u.fuse(B, A)
    np.testing.assert_allclose(G.T, F.T, atol=1e-10)
    np.testing.assert_allclose(G.cov, F.cov, atol=1e-12)
    C = u.UncertainPose(T1, 2e-3 * np.eye(6), "gtsam")
    avg = u.average([A, B, C])
    avg2 = u.average([C, A, B])
    np.testing.assert_allclose(avg.T, avg2.T, atol=1e-10)
    np.testing.assert_allclose(avg.cov, avg2.cov, atol=1e-12)
    assert u.average([C]).cov is not None


# ------------------------------------------------------------------ object, batches, conversion
def test_uncertain_pose_is_immutable_and_copies() -> None:
    T = T1.copy()
    cov = JOINT[:6, :6].copy()
    A = u.UncertainPose(T, cov, "ros")
    T[0, 3] = 99.0
    assert A.T[0, 3] != 99.0
    with pytest.raises(ValueError):
        A.cov[0, 0] = 1.0
    with pytest.raises(AttributeError, match="immutable"):
        A.T = T  # type: ignore[misc]
    assert A.convention is get("ros")
    assert "ros" in repr(A)


@pytest.mark.parametrize("name", ["ros", "barfoot", "symforce", "g2o"])
def test_to_round_trip_and_from_gtsam(name: str) -> None:
    A = u.UncertainPose(T1, JOINT[:6, :6], "gtsam")
    back = A.to(name).to("gtsam")
    np.testing.assert_allclose(back.cov, A.cov, rtol=1e-10, atol=1e-15)
    B = u.UncertainPose.from_gtsam(gtsam.Pose3(T1), A.cov, name)
    np.testing.assert_allclose(B.cov, convert_covariance(A.cov, T1, "gtsam", name), atol=1e-15)
    np.testing.assert_allclose(B.gtsam_cov(), A.cov, rtol=1e-10, atol=1e-15)
    # operations commute with the change of convention (first order, exact maps)
    C1 = u.compose(A, u.UncertainPose(T2, JOINT[6:, 6:], "gtsam")).to(name)
    C2 = u.compose(A.to(name), u.UncertainPose(T2, JOINT[6:, 6:], "gtsam").to(name))
    np.testing.assert_allclose(C1.cov, C2.cov, rtol=1e-9, atol=1e-15)


@settings(max_examples=10)
@given(st.sampled_from(["gtsam", "ros", "pypose", "g2o"]), st.integers(0, 10**6))
def test_batched_equals_loop(name: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    TA = se3.exp(rng.normal(size=(2, 3, 6)))
    TB = se3.exp(rng.normal(size=(3, 6)))
    L = rng.normal(size=(2, 3, 12, 12))
    J = 1e-4 * (L @ np.swapaxes(L, -1, -2) + np.eye(12))
    A = u.UncertainPose(TA, J[..., :6, :6], name)
    B = u.UncertainPose(TB, J[0, :, 6:, 6:], name)
    Q = rng.normal(size=(2, 3, 6, 6))
    X = 0.5e-4 * Q / np.linalg.norm(Q, 2, axis=(-2, -1))[..., None, None]  # joint stays PSD
    C = u.compose(A, B, X)
    R = u.relative(A, B, X)
    Q = u.act(A, P)
    assert C.batch_shape == (2, 3)
    for i in range(2):
        for k in range(3):
            Ci = u.compose(A[i, k], B[k], X[i, k])
            np.testing.assert_allclose(C.cov[i, k], Ci.cov, rtol=1e-10, atol=1e-16)
            np.testing.assert_allclose(R.cov[i, k], u.relative(A[i, k], B[k], X[i, k]).cov)
            np.testing.assert_allclose(Q.cov[i, k], u.act(A[i, k], P).cov)


@pytest.mark.parametrize("theta", [0.0, 1e-12, np.pi - 1e-6])
def test_edge_angles_and_long_translation(theta: float) -> None:
    T = se3.exp(np.r_[0.0, 0.0, theta, 30.0, -30.0, 30.0])
    A = u.UncertainPose(T, 1e-6 * np.eye(6), "ros")
    B = u.UncertainPose(T2, 1e-6 * np.eye(6), "ros")
    for C in (u.compose(A, B), u.inverse(A), u.relative(A, B), u.transform(A, TF, "right")):
        assert np.isfinite(C.cov).all()
        assert np.linalg.eigvalsh(C.cov)[0] > -1e-18
    mc = check.monte_carlo_inverse(A, n=60000).cov
    assert _rel(u.inverse(A).cov, mc) < 0.02


def test_so3_exp_at_pi_rotation_input() -> None:
    R = so3.exp(np.r_[np.pi, 0.0, 0.0])
    A = u.UncertainPose(R, 1e-6 * np.eye(3), "gtsam")
    np.testing.assert_allclose(u.inverse(A).cov, R @ A.cov @ R.T, atol=1e-18)


# ------------------------------------------------------------------ bad input
def test_indefinite_cross_is_one_clear_error() -> None:
    A, B = _pair("gtsam")
    bad = 10 * np.eye(6) * JOINT[0, 0]
    with pytest.raises(ValueError, match=r"cross .*joint covariance.*not positive semi-definite"):
        u.compose(A, B, bad)
    with pytest.raises(ValueError, match=r"cross .*not positive semi-definite at batch index"):
        u.relative(A, B, bad)
    with pytest.raises(ValueError, match=r"cross: expected shape"):
        u.compose(A, B, np.zeros((3, 3)))


def test_mismatched_conventions_groups_and_batches() -> None:
    A = u.UncertainPose(T1, JOINT[:6, :6], "gtsam")
    B = u.UncertainPose(T2, JOINT[6:, 6:], "ros")
    with pytest.raises(ValueError, match=r"B: convention 'ros'.*B\.to\(A\.convention\)"):
        u.compose(A, B)
    with pytest.raises(ValueError, match="convention"):
        u.fuse(A, B)
    Ab = u.UncertainPose(np.stack([T1] * 3), JOINT[:6, :6], "gtsam")
    Bb = u.UncertainPose(np.stack([T2] * 2), JOINT[6:, 6:], "gtsam")
    with pytest.raises(ValueError, match=r"batch shapes do not broadcast: A \(3,\), B \(2,\)"):
        u.relative(Ab, Bb)
    Rb = u.UncertainPose(T2[:3, :3], 1e-4 * np.eye(3), "gtsam")
    with pytest.raises(ValueError, match="B: a rotation, but A is a pose"):
        u.compose(A, Rb)
    with pytest.raises(TypeError, match="B: expected an UncertainPose"):
        u.compose(A, T2)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="method"):
        u.inverse(A, "ukf")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="side"):
        u.transform(A, TF, "up")  # type: ignore[arg-type]


def test_fusing_two_singular_covariances_is_one_clear_error() -> None:
    s1 = np.diag([1e-4, 1e-4, 1e-4, 0.0, 1e-4, 1e-4])
    s2 = np.diag([1e-4, 0.0, 1e-4, 1e-4, 1e-4, 1e-4])
    with pytest.raises(ValueError, match=r"every covariance is singular at batch index \(\)"):
        u.fuse(u.UncertainPose(T1, s1, "gtsam"), u.UncertainPose(T1, s2, "gtsam"))


def test_bad_construction() -> None:
    with pytest.raises(ValueError, match="cov: not positive semi-definite"):
        u.UncertainPose(T1, -np.eye(6), "gtsam")
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 6, 6\)"):
        u.UncertainPose(T1, np.eye(3), "gtsam")
    with pytest.raises(ValueError, match="T: not a rotation"):
        u.UncertainPose(2 * T1, np.eye(6), "gtsam")


# one preset per distinct retraction (presets with equal fields give identical numbers)
DISTINCT = list({c.fields: c.name for c in PRESETS}.values())


@pytest.mark.parametrize("name", DISTINCT)
def test_fuse_against_importance_sampled_monte_carlo(name: str) -> None:
    """Means about one standard deviation apart: the MAP and its inverse Hessian against the
    importance-sampled product of the two densities (posterior mean and covariance)."""
    Tb = T1 @ se3.exp(0.25 * np.r_[0.01, -0.02, 0.01, 0.02, 0.01, -0.01])
    A = u.UncertainPose(T1, JOINT[:6, :6], name)
    B = u.UncertainPose(Tb, JOINT[6:, 6:], name)
    F, mc = u.fuse(A, B), check.monte_carlo_fuse(A, B, n=100000)
    assert _rel(F.cov, mc.cov) < 0.02
    assert np.abs(get(name).local(F.T, mc.T)).max() < 5e-4  # 0.1 σ: mode ≈ mean
