"""Registration residuals, Jacobians and information in any convention (numpy only).

Jacobians: central differences through each convention's own ``retract``. Covariances: Monte
Carlo — closed-form (Kabsch) registrations of noisy point sets, and sampled changes of chart.
"""

from __future__ import annotations

import _strategies
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from liebridge import check
from liebridge import registration as reg
from liebridge.conventions import get, names, tangent_map
from liebridge.io import g2o as g2o_io
from liebridge.lie import se3

SE3_CONVENTIONS = [n for n in names("se3") if get(n).embed is None]
T_TS = se3.exp(np.array([0.4, -0.7, 1.1, 3.0, -2.0, 30.0]))  # 30 m away, 1.3 rad


def _scene(n: int = 40, seed: int = 0, T: np.ndarray = T_TS, noise: float = 0.0) -> tuple:
    rng = np.random.default_rng(seed)
    p = rng.uniform(-5.0, 5.0, size=(n, 3))
    q = p @ T[:3, :3].T + T[:3, 3] + noise * rng.normal(size=(n, 3))
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    A = rng.normal(size=(n, 3, 3)) * 0.1
    Cs = A @ np.swapaxes(A, -1, -2) + 1e-3 * np.eye(3)
    B = rng.normal(size=(n, 3, 3)) * 0.1
    Ct = B @ np.swapaxes(B, -1, -2) + 1e-3 * np.eye(3)
    return p, q, nrm, Cs, Ct


def _central(f, T, conv, h: float = 1e-6) -> np.ndarray:
    c = get(conv)
    cols = []
    for k in range(6):
        d = np.zeros(6)
        d[k] = h
        cols.append((f(c.retract(T, d)) - f(c.retract(T, -d))) / (2 * h))
    return np.stack(cols, axis=-1)


# --------------------------------------------------------------------------- Jacobians
NEAR_PI = se3.exp(
    np.array([0.0, (np.pi - 1e-9) / np.sqrt(2), (np.pi - 1e-9) / np.sqrt(2), 1, 2, 3])
)
TINY = se3.exp(np.array([1e-12, 0.0, -1e-12, 30.0, 0.0, 0.0]))


@pytest.mark.parametrize("conv", SE3_CONVENTIONS)
@pytest.mark.parametrize(
    "T", [np.eye(4), T_TS, NEAR_PI, TINY], ids=["identity", "far", "near_pi", "tiny_30m"]
)
def test_point_to_point_jacobian_matches_central_differences(conv: str, T: np.ndarray) -> None:
    p, q, *_ = _scene(noise=0.01)
    r, J = reg.point_to_point(T, p, q, conv)
    assert r.shape == (40, 3) and J.shape == (40, 3, 6)
    Jn = _central(lambda X: reg.point_to_point(X, p, q, conv)[0], T, conv)
    np.testing.assert_allclose(J, Jn, atol=2e-6 * max(1.0, np.abs(J).max()))


@pytest.mark.parametrize("conv", SE3_CONVENTIONS)
def test_point_to_plane_jacobian_matches_central_differences(conv: str) -> None:
    p, q, nrm, *_ = _scene(noise=0.01)
    r, J = reg.point_to_plane(T_TS, p, q, nrm, conv)
    assert r.shape == (40,) and J.shape == (40, 6)
    Jn = _central(lambda X: reg.point_to_plane(X, p, q, nrm, conv)[0], T_TS, conv)
    np.testing.assert_allclose(J, Jn, atol=2e-6 * np.abs(J).max())


@pytest.mark.parametrize("conv", SE3_CONVENTIONS)
def test_gicp_jacobian_matches_central_differences(conv: str) -> None:
    p, q, _, Cs, Ct = _scene(noise=0.01)
    r, J, W = reg.gicp(T_TS, p, q, Cs, Ct, conv)
    assert r.shape == (40, 3) and W.shape == (40, 3, 3)
    Jn = _central(lambda X: reg.gicp(X, p, q, Cs, Ct, conv)[0], T_TS, conv)
    np.testing.assert_allclose(J, Jn, atol=2e-6 * np.abs(J).max())
    R = T_TS[:3, :3]
    np.testing.assert_allclose(
        W @ (Ct + R @ Cs @ R.T), np.broadcast_to(np.eye(3), W.shape), atol=1e-9
    )


def test_batched_poses_give_the_per_pose_results() -> None:
    p, q, nrm, *_ = _scene()
    Ts = np.stack([np.eye(4), T_TS, se3.exp(np.array([0.1, 0.2, -0.3, 1.0, 0.0, 2.0]))])
    r, J = reg.point_to_plane(Ts, p, q, nrm, "kiss_icp")
    assert r.shape == (3, 40) and J.shape == (3, 40, 6)
    for i, T in enumerate(Ts):
        ri, Ji = reg.point_to_plane(T, p, q, nrm, "kiss_icp")
        np.testing.assert_allclose(r[i], ri, atol=1e-12)
        np.testing.assert_allclose(J[i], Ji, atol=1e-12)
    _, J3 = reg.point_to_point(Ts, p, q, "gtsam")
    np.testing.assert_allclose(J3[1], reg.point_to_point(T_TS, p, q, "gtsam")[1], atol=1e-12)


def _hat(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def test_information_batched_over_poses_is_the_per_pose_information() -> None:
    p, q, nrm, *_ = _scene(noise=0.01)
    Ts = np.stack([T_TS, se3.exp(np.array([0.1, 0.2, -0.3, 1.0, 0.0, 2.0]))])
    est = reg.information(Ts, p, q, n_tgt=nrm, convention="kiss_icp")
    assert est.batch_shape == (2,) and est.sigma.shape == (2,)
    for i in range(2):
        one = reg.information(Ts[i], p, q, n_tgt=nrm, convention="kiss_icp")
        _close(est.information[i], one.information, 1e-12)
        assert est.sigma[i] == pytest.approx(one.sigma)


def test_point_to_plane_left_form_of_the_design_note() -> None:
    """Left perturbation Exp(δ)·T, δ = (ω, v): J = nᵀ[−hat(T·p) I]."""
    p, q, nrm, *_ = _scene()
    _, J = reg.point_to_plane(T_TS, p, q, nrm, "open3d")
    s = p @ T_TS[:3, :3].T + T_TS[:3, 3]
    want = np.stack([nrm[i] @ np.hstack([-_hat(s[i]), np.eye(3)]) for i in range(len(p))])
    np.testing.assert_allclose(J, want, atol=1e-12)


def test_point_to_plane_right_form_of_the_design_note() -> None:
    """Right perturbation T·Exp(δ), δ = (ω, v): J = nᵀR[−hat(p) I]."""
    p, q, nrm, *_ = _scene()
    _, J = reg.point_to_plane(T_TS, p, q, nrm, "gtsam")
    R = T_TS[:3, :3]
    want = np.stack([nrm[i] @ R @ np.hstack([-_hat(p[i]), np.eye(3)]) for i in range(len(p))])
    np.testing.assert_allclose(J, want, atol=1e-12)


def test_left_form_in_right_code_is_the_common_error() -> None:
    """Copying the left Jacobian into a right-perturbation solver is wrong away from T = I."""
    p, q, nrm, *_ = _scene()
    _, J_left = reg.point_to_plane(T_TS, p, q, nrm, "open3d")
    Jn_right = _central(lambda X: reg.point_to_plane(X, p, q, nrm, "gtsam")[0], T_TS, "gtsam")
    assert np.abs(J_left - Jn_right).max() > 1.0
    _, J_left_id = reg.point_to_plane(np.eye(4), p, q, nrm, "open3d")
    _, J_right_id = reg.point_to_plane(np.eye(4), p, q, nrm, "gtsam")
    np.testing.assert_allclose(J_left_id, J_right_id, atol=1e-12)


# --------------------------------------------------------------------------- information
def _close(a: np.ndarray, b: np.ndarray, rel: float) -> None:
    """Equal to ``rel`` of the largest entry (entries span orders of magnitude)."""
    np.testing.assert_allclose(a, b, rtol=0, atol=rel * np.abs(b).max())


@pytest.mark.parametrize("conv", ["gtsam", "open3d", "kiss_icp", "hdl_graph_slam", "ros"])
def test_information_is_the_gauss_newton_hessian_over_sigma_squared(conv: str) -> None:
    p, q, nrm, Cs, Ct = _scene(noise=0.01)
    est = reg.information(T_TS, p, q, sigma=0.01, convention=conv)
    Jn = _central(lambda X: reg.point_to_point(X, p, q, conv)[0].reshape(-1), T_TS, conv)
    _close(est.information, Jn.T @ Jn / 1e-4, 1e-6)
    np.testing.assert_allclose(est.cov @ est.information, np.eye(6), atol=1e-8)
    assert est.convention.name == conv and est.sigma == 0.01 and est.sigma_source == "given"
    plane = reg.information(T_TS, p, q, n_tgt=nrm, sigma=0.02, convention=conv)
    Jp = _central(lambda X: reg.point_to_plane(X, p, q, nrm, conv)[0], T_TS, conv)
    _close(plane.information, Jp.T @ Jp / 4e-4, 1e-6)
    g = reg.information(T_TS, p, q, C_src=Cs, C_tgt=Ct, convention=conv)
    _, _, W = reg.gicp(T_TS, p, q, Cs, Ct, conv)
    Jg = _central(lambda X: reg.gicp(X, p, q, Cs, Ct, conv)[0], T_TS, conv)
    want = np.einsum("nia,nij,njb->ab", Jg, W, Jg)
    _close(g.information, want, 1e-6)
    assert g.sigma_source == "metric"


def test_information_in_two_conventions_is_one_conversion_apart() -> None:
    p, q, *_ = _scene(noise=0.01)
    a = reg.information(T_TS, p, q, sigma=0.01, convention="open3d")
    b = reg.information(T_TS, p, q, sigma=0.01, convention="gtsam")
    M = tangent_map(T_TS, "gtsam", "open3d")  # δ_open3d = M δ_gtsam
    _close(M.T @ a.information @ M, b.information, 1e-12)
    _close(b.to("open3d").cov, a.cov, 1e-9)


def _kabsch(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Least-squares rigid T with q ≈ T·p (closed form, independent of liebridge)."""
    mp, mq = p.mean(0), q.mean(0)
    U, _, Vt = np.linalg.svd((q - mq).T @ (p - mp))
    D = np.diag([1.0, 1.0, np.linalg.det(U @ Vt)])
    R = U @ D @ Vt
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, mq - R @ mp
    return T


@pytest.mark.parametrize("conv", ["gtsam", "open3d", "kiss_icp", "g2o"])
def test_information_covariance_matches_monte_carlo_registrations(conv: str) -> None:
    """The spread of closed-form registrations of noisy copies equals σ²·H⁻¹ in each chart."""
    rng = np.random.default_rng(7)
    sigma, n, runs = 0.02, 60, 3000
    p, q0, *_ = _scene(n=n, seed=3)
    c = get(conv)
    errs = np.empty((runs, 6))
    for k in range(runs):
        T_hat = _kabsch(p, q0 + sigma * rng.normal(size=q0.shape))
        errs[k] = c.local(T_TS, T_hat)
    est = reg.information(T_TS, p, q0, sigma=sigma, convention=conv)
    L = np.linalg.cholesky(est.cov)
    W = np.linalg.solve(L, np.linalg.solve(L, np.cov(errs.T)).T)
    assert np.abs(W - np.eye(6)).max() < 0.12, W
    # the same matrix read in another convention's tangent is not consistent (a test that fails)
    other = "kiss_icp" if conv != "kiss_icp" else "gtsam"
    wrong = reg.information(T_TS, p, q0, sigma=sigma, convention=other)
    L2 = np.linalg.cholesky(wrong.cov)
    W2 = np.linalg.solve(L2, np.linalg.solve(L2, np.cov(errs.T)).T)
    assert np.abs(W2 - np.eye(6)).max() > 0.5


def test_sigma_is_estimated_from_the_residuals_and_reported() -> None:
    p, q, *_ = _scene(n=2000, seed=4, noise=0.03)
    est = reg.information(T_TS, p, q, convention="gtsam")
    assert est.sigma_source == "residual"
    assert abs(est.sigma - 0.03) < 0.002
    given = reg.information(T_TS, p, q, sigma=est.sigma, convention="gtsam")
    _close(given.information, est.information, 1e-12)
    assert "residual" in repr(est) and est.num_correspondences == 2000


@pytest.mark.parametrize(
    "src, dst",
    [
        ("open3d", "gtsam"),
        ("small_gicp", "kiss_icp"),
        ("kiss_icp", "hdl_graph_slam"),
        ("open3d", "g2o"),
    ],
)
def test_covariance_conversion_between_registration_presets_matches_monte_carlo(
    src: str, dst: str
) -> None:
    p, q, *_ = _scene(noise=0.01)
    est = reg.information(T_TS, p, q, sigma=0.05, convention=src)
    mc = check.monte_carlo_covariance(
        est.cov, T_TS, src, dst, n=20000, rng=np.random.default_rng(1)
    )
    got = est.to(dst).cov
    L = np.linalg.cholesky(got)
    W = np.linalg.solve(L, np.linalg.solve(L, mc).T)
    assert np.abs(W - np.eye(6)).max() < 0.08, W


def test_readers_take_plain_pairs_and_convert() -> None:
    p, q, *_ = _scene(noise=0.01)
    o3d_info = reg.information(T_TS, p, q, sigma=1.0, convention="open3d").information
    a = reg.from_open3d(o3d_info, T_TS, sigma=0.01, convention="gtsam")
    b = reg.from_open3d((T_TS, o3d_info), sigma=0.01, convention="gtsam")
    want = reg.information(T_TS, p, q, sigma=0.01, convention="gtsam").information
    _close(a.information, want, 1e-12)
    _close(b.information, want, 1e-12)
    # Λ_gtsam = Ad_Tᵀ·Λ_open3d·Ad_T / σ², Ad_T rotation first
    R, t = T_TS[:3, :3], T_TS[:3, 3]
    Ad = np.block([[R, np.zeros((3, 3))], [_hat(t) @ R, R]])
    _close(a.information, Ad.T @ o3d_info @ Ad / 1e-4, 1e-12)
    H = reg.information(T_TS, p, q, sigma=1.0, convention="small_gicp").information
    s = reg.from_small_gicp((T_TS, H), sigma=0.01, convention="kiss_icp")
    _close(
        s.information,
        reg.information(T_TS, p, q, sigma=0.01, convention="kiss_icp").information,
        1e-12,
    )
    raw = reg.from_small_gicp((T_TS, H))
    assert raw.sigma_source == "library"
    _close(raw.information, H, 1e-12)


def test_from_kiss_icp_finds_the_correspondences() -> None:
    p, q, *_ = _scene(n=200, seed=5, noise=0.005)
    rng = np.random.default_rng(0)
    target = rng.permutation(q)
    est = reg.from_kiss_icp(p, target, T_TS, convention="kiss_icp")
    want = reg.information(T_TS, p, q, convention="kiss_icp")
    assert est.num_correspondences >= 190
    np.testing.assert_allclose(est.sigma, want.sigma, rtol=0.1)


def test_inflate_residual_and_nees() -> None:
    p, q, _, Cs, Ct = _scene(n=200, seed=6, noise=0.05)
    metric = reg.information(T_TS, p, q, C_src=Cs, C_tgt=Ct)
    res = reg.information(T_TS, p, q, C_src=Cs, C_tgt=Ct, inflate="residual")
    assert res.sigma_source == "residual"
    _close(res.cov, metric.cov * res.sigma**2, 1e-9)
    rng = np.random.default_rng(1)
    C = metric.cov
    errs = rng.multivariate_normal(np.zeros(6), 4.0 * C, size=4000)
    k = reg.nees_scale(errs, C)
    assert 3.7 < k < 4.3
    nees = reg.information(T_TS, p, q, C_src=Cs, C_tgt=Ct, inflate="nees", holdout=(errs, C))
    _close(nees.cov, k * C, 1e-9)
    assert nees.inflation == pytest.approx(k)


# --------------------------------------------------------------------------- g2o
def test_g2o_edge_reads_back_as_gtsam_information(tmp_path) -> None:
    p, q, *_ = _scene(noise=0.01)
    est = reg.information(T_TS, p, q, sigma=0.01, convention="open3d")
    f = tmp_path / "loop.g2o"
    I7 = "0 0 0 0 0 0 1"
    tq = " ".join(
        repr(float(x)) for x in __import__("liebridge").poses.from_matrix(T_TS, layout="xyz_qxyzw")
    )
    f.write_text(
        f"VERTEX_SE3:QUAT 3 {I7}\nVERTEX_SE3:QUAT 8 {tq}\n" + reg.g2o_edge(3, 8, est) + "\n"
    )
    g = g2o_io.read(f, information="g2o")
    np.testing.assert_allclose(g.edges, [[3, 8]])
    np.testing.assert_allclose(g.measured[0], T_TS, atol=1e-12)
    want = est.to("gtsam")
    _close(g.information[0], np.linalg.inv(want.cov), 1e-9)


# --------------------------------------------------------------------------- bad input
def test_bad_input_gets_one_clear_error_each() -> None:
    p, q, nrm, Cs, _ = _scene()
    with pytest.raises(ValueError, match=r"q_tgt: 39 points, but p_src has 40"):
        reg.point_to_point(T_TS, p, q[:39])
    bad = nrm.copy()
    bad[7] *= 1.1
    with pytest.raises(ValueError, match=r"n_tgt: normal at index \(7,\) has norm 1.1"):
        reg.point_to_plane(T_TS, p, q, bad)
    nanp = p.copy()
    nanp[12, 1] = np.nan
    with pytest.raises(ValueError, match=r"p_src: NaN or Inf at point index \(12,\) of 40"):
        reg.information(T_TS, nanp, q)
    sheared = T_TS.copy()
    sheared[0, 1] += 0.1
    with pytest.raises(ValueError, match=r"^T: "):
        reg.point_to_point(sheared, p, q)
    with pytest.raises(ValueError, match="C_src, C_tgt: GICP needs both"):
        reg.information(T_TS, p, q, C_src=Cs)
    with pytest.raises(ValueError, match="sigma: Open3D's information matrix has unit noise"):
        reg.from_open3d(np.eye(6), T_TS)
    with pytest.raises(ValueError, match="convention: registration estimates an SE"):
        reg.point_to_point(T_TS, p, q, "gtsam_pose2")
    with pytest.raises(ValueError, match="inflate: expected"):
        reg.information(T_TS, p, q, inflate="chi2")
    with pytest.raises(ValueError, match="sigma: the residuals are all zero"):
        reg.information(T_TS, p, p @ T_TS[:3, :3].T + T_TS[:3, 3])


def test_single_plane_names_the_unobservable_directions() -> None:
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(-5, 5, 100), rng.uniform(-5, 5, 100), np.zeros(100)])
    nrm = np.tile([0.0, 0.0, 1.0], (100, 1))
    with pytest.raises(ValueError) as exc:
        reg.information(np.eye(4), q, q, n_tgt=nrm, sigma=0.01, convention="gtsam")
    msg = str(exc.value)
    assert "singular" in msg and "degenerate geometry" in msg
    dirs = reg.unobservable_directions(
        sum(np.outer(j, j) for j in reg.point_to_plane(np.eye(4), q, q, nrm)[1]), "gtsam"
    )
    assert len(dirs) == 3 and any("ωz" in d for d in dirs)
    for d in dirs:
        assert "vz" not in d and "ωx" not in d and "ωy" not in d
    assert all(f"[{d}]" in msg for d in dirs)
    # kiss_icp order: the same directions, translation first
    with pytest.raises(ValueError, match=r"kiss_icp tangent: .*vx"):
        reg.information(np.eye(4), q, q, n_tgt=nrm, sigma=0.01, convention="kiss_icp")


def test_inputs_are_not_mutated() -> None:
    p, q, nrm, Cs, Ct = _scene()
    copies = [a.copy() for a in (p, q, nrm, Cs, Ct, T_TS)]
    reg.information(T_TS, p, q, C_src=Cs, C_tgt=Ct, convention="kiss_icp")
    reg.information(T_TS, p, q, n_tgt=nrm, sigma=0.1, convention="ros")
    for a, b in zip((p, q, nrm, Cs, Ct, T_TS), copies, strict=True):
        np.testing.assert_array_equal(a, b)


def test_presets_are_in_the_registry() -> None:
    for name, fields in {
        "open3d": ("left", "rot_first", "se3", "exp"),
        "small_gicp": ("right", "rot_first", "se3", "exp"),
        "kiss_icp": ("left", "trans_first", "se3", "exp"),
        "hdl_graph_slam": ("right", "trans_first", "so3xr3_body", "quat_vec"),
    }.items():
        c = get(name)
        assert c.fields == fields
        assert "False" in c.notes and c.source


@given(
    w=_strategies.rotvecs(),
    t=_strategies.translations(),
    conv=st.sampled_from(SE3_CONVENTIONS),
    seed=st.integers(0, 2**16),
)
def test_point_to_plane_jacobian_property(w, t, conv, seed) -> None:
    """Any pose (angles up to π, 30 m), any preset: the Jacobian is the central difference."""
    T = _strategies.assemble(_strategies.rotation_from_rotvec(w), t)
    p, q, nrm, *_ = _scene(n=8, seed=seed, noise=0.05)
    _, J = reg.point_to_plane(T, p, q, nrm, conv)
    Jn = _central(lambda X: reg.point_to_plane(X, p, q, nrm, conv)[0], T, conv)
    np.testing.assert_allclose(J, Jn, rtol=0, atol=5e-6 * max(1.0, np.abs(J).max()))
