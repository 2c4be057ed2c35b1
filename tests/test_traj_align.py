"""Alignment (Umeyama SE(3)/Sim(3)/4-DoF), its covariance map, interpolation, association errors."""

from __future__ import annotations

import numpy as np
import pytest
from _traj_data import sphere_poses

from liebridge import conventions as C
from liebridge import traj
from liebridge.check import numerical_jacobian
from liebridge.lie import se3, so3

PRESETS = [c.name for c in C.PRESETS]


def _sim(kind):
    rng = np.random.default_rng(5)
    if kind == "4dof":
        R = so3.exp([0.0, 0.0, 2.5])
    else:
        R = so3.exp(rng.normal(size=3))
    return traj.Alignment(kind, R, np.array([30.0, -12.0, 4.0]), 1.7 if kind == "sim3" else 1.0)


@pytest.mark.parametrize("kind", ["se3", "sim3", "4dof"])
def test_umeyama_recovers_a_known_transform(kind):
    T = sphere_poses()[:200]
    A = _sim(kind)
    B = traj.align(A.apply(T), T, kind)
    np.testing.assert_allclose(B.R_ref_est, A.R_ref_est, atol=1e-10)
    np.testing.assert_allclose(B.t_ref_est, A.t_ref_est, atol=1e-8)
    assert B.scale == pytest.approx(A.scale, rel=1e-12)


def test_4dof_is_yaw_only_and_no_worse_than_se3_restricted():
    T = sphere_poses()[:300]
    rng = np.random.default_rng(2)
    A = _sim("4dof")
    T_ref = A.apply(T)
    T_ref[:, :3, 3] += rng.normal(scale=0.3, size=(300, 3))
    B = traj.align(T_ref, T, "4dof")
    assert B.R_ref_est[2, 2] == 1.0 and np.all(B.R_ref_est[2, :2] == 0)
    # the closed form is the least-squares yaw: no yaw nearby does better
    cost = lambda R, t: np.sum((T_ref[:, :3, 3] - T[:, :3, 3] @ R.T - t) ** 2)  # noqa: E731
    c0 = cost(B.R_ref_est, B.t_ref_est)
    for dth in (-1e-3, 1e-3):
        R = so3.exp([0, 0, dth]) @ B.R_ref_est
        t = T_ref[:, :3, 3].mean(0) - R @ T[:, :3, 3].mean(0)
        assert cost(R, t) > c0


@pytest.mark.parametrize("kind", ["se3", "sim3", "4dof"])
@pytest.mark.parametrize("name", PRESETS)
def test_covariance_map_is_the_jacobian_of_the_alignment(name, kind):
    """J = ∂ conv.local(A(X), A(conv.retract(X, d)))/∂d, central differences."""
    conv = C.get(name)
    A = _sim(kind)
    X = sphere_poses()[[3, 1100]] @ se3.exp([0.0, 0.0, 0.0, 2.0, -30.0, 5.0])
    J = A.covariance_map(X, conv)
    J_num = numerical_jacobian(A.apply, X, in_convention=conv, out_convention=conv)
    np.testing.assert_allclose(J, J_num, atol=2e-6 * max(1.0, np.abs(J).max()))
    if conv.side == "right" and kind != "sim3" and conv.chart != "so3xr3_world":
        np.testing.assert_allclose(J, np.broadcast_to(np.eye(6), J.shape), atol=1e-12)


def test_covariance_map_monte_carlo_left():
    """Σ' = J Σ Jᵀ matches the sample covariance of aligned perturbed poses (world-frame conv)."""
    conv = C.get("pypose")
    A = _sim("sim3")
    X = sphere_poses()[7]
    rng = np.random.default_rng(0)
    cov = np.diag([0.01, 0.02, 0.03, 1e-4, 2e-4, 3e-4])
    d = rng.multivariate_normal(np.zeros(6), cov, size=40000)
    Y = A.apply(conv.retract(X, d))
    e = conv.local(A.apply(X), Y)
    emp = np.cov(e.T)
    pred = A.transform_covariance(X, cov, conv)
    np.testing.assert_allclose(emp, pred, atol=0.03 * np.abs(pred).max())


def test_alignment_needs_three_poses_and_non_degenerate_positions():
    T = sphere_poses()[:2]
    with pytest.raises(ValueError, match="at least 3 associated poses, got 2"):
        traj.align(T, T, "se3")
    line = np.tile(np.eye(4), (5, 1, 1))
    line[:, 0, 3] = np.arange(5.0)
    with pytest.raises(ValueError, match="degenerate"):
        traj.align(line, line, "se3")
    still = np.tile(np.eye(4), (5, 1, 1))
    with pytest.raises(ValueError, match="yaw is undetermined"):
        traj.align(still, still, "4dof")
    assert traj.align(T, T, "none").kind == "none"
    with pytest.raises(ValueError, match="kind"):
        traj.align(T, T, "sim2")


# ------------------------------------------------------------------------- association


def test_association_errors():
    with pytest.raises(ValueError, match="no overlapping timestamps"):
        traj.associate([0.0, 1.0, 2.0], [10.0, 11.0])
    with pytest.raises(ValueError, match=r"stamp 2 \(0\.5\) goes back in time"):
        traj.associate([0.0, 1.0, 0.5], [0.0, 1.0])
    with pytest.raises(ValueError, match=r"stamp 1 .* repeats"):
        traj.associate([0.0, 1.0], [0.0, 0.0, 1.0])
    i, j = traj.associate([0.0, 1.0, 2.0], [1.005, 2.02, 3.0])
    assert i.tolist() == [1] and j.tolist() == [0]


# ------------------------------------------------------------------------- interpolation


@pytest.mark.parametrize("method", ["geodesic", "lerp_slerp"])
def test_interpolation_exact_at_samples_and_on_its_path(method):
    T = sphere_poses()[:20]
    t = np.arange(20) * 0.5
    Tq = traj.interpolate_poses(t, t, T, method)
    np.testing.assert_allclose(Tq, T, atol=1e-12)
    mid = traj.interpolate_poses([0.25], t, T, method)[0]
    if method == "geodesic":
        np.testing.assert_allclose(mid, se3.interpolate(T[0], T[1], 0.5), atol=1e-12)
    else:
        np.testing.assert_allclose(mid[:3, 3], 0.5 * (T[0, :3, 3] + T[1, :3, 3]), atol=1e-12)
        w = so3.log(T[0, :3, :3].T @ T[1, :3, :3])
        np.testing.assert_allclose(mid[:3, :3], T[0, :3, :3] @ so3.exp(0.5 * w), atol=1e-12)
    with pytest.raises(ValueError, match="outside the samples' span"):
        traj.interpolate_poses([10.0], t, T, method)


def test_geodesic_and_lerp_slerp_differ_when_turning():
    T0 = np.eye(4)
    T1 = se3.exp([0.0, 0.0, 1.5, 2.0, 0.0, 0.0])
    a = traj.interpolate_poses([0.5], [0.0, 1.0], np.stack([T0, T1]), "geodesic")[0]
    b = traj.interpolate_poses([0.5], [0.0, 1.0], np.stack([T0, T1]), "lerp_slerp")[0]
    np.testing.assert_allclose(a[:3, :3], b[:3, :3], atol=1e-12)
    assert np.linalg.norm(a[:3, 3] - b[:3, 3]) > 0.05


@pytest.mark.parametrize("name", ["gtsam", "ros", "sophus", "pypose", "g2o"])
def test_interpolated_covariances_consistent_across_conventions(name):
    rng = np.random.default_rng(4)
    T = sphere_poses()[:6]
    t = np.arange(6.0)
    L = rng.normal(size=(6, 6, 6)) * 0.05
    cov_g = L @ np.swapaxes(L, -1, -2) + 1e-4 * np.eye(6)
    cov_c = C.convert_covariance(cov_g, T, "gtsam", name)
    tq = np.array([0.0, 0.3, 2.5, 5.0])
    Tq, Cg = traj.interpolate_covariances(tq, t, T, cov_g, "gtsam")
    _, Cc = traj.interpolate_covariances(tq, t, T, cov_c, name)
    np.testing.assert_allclose(C.convert_covariance(Cg, Tq, "gtsam", name), Cc, atol=1e-10)
    np.testing.assert_allclose(Cc[[0, 3]], cov_c[[0, 5]], atol=1e-12)
    assert np.linalg.eigvalsh(Cg).min() > 0


def test_synchronize_resamples_the_estimate_with_its_covariances():
    T = sphere_poses()[:40]
    t_est = np.arange(40) * 0.05
    t_ref = t_est[::4] + 0.001  # within max_diff of est samples
    rng = np.random.default_rng(1)
    L = rng.normal(size=(40, 6, 6)) * 0.05
    cov = L @ np.swapaxes(L, -1, -2) + 1e-4 * np.eye(6)
    s = traj.synchronize(
        t_ref, T[::4], t_est, T, interpolate="geodesic", cov_est=cov, convention="ros"
    )
    assert s.resampled == "est" and s.T_est.shape == (10, 4, 4) and s.cov_est.shape == (10, 6, 6)
    Tq, Cq = traj.interpolate_covariances(t_ref, t_est, T, cov, "ros", "geodesic")
    np.testing.assert_allclose(s.T_est, Tq)
    np.testing.assert_allclose(s.cov_est, Cq)
    near = traj.synchronize(t_ref, T[::4], t_est, T, cov_est=cov)
    np.testing.assert_array_equal(near.cov_est, cov[::4])
    with pytest.raises(ValueError, match="convention: needed"):
        traj.synchronize(t_ref, T[::4], t_est, T, interpolate="geodesic", cov_est=cov)
    with pytest.raises(ValueError, match="39 covariances for 40 poses"):
        traj.synchronize(t_ref, T[::4], t_est, T, cov_est=cov[1:])
