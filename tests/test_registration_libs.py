"""The registration presets' facts, measured by running Open3D, small_gicp and KISS-ICP.

Each library installs from the package index (extra ``registration``); a test is skipped where
its library is missing. Scenes: sparse random points (nearest neighbours are the intended pairs),
``T_target_source`` far from the identity so that left and right, ``(ω, v)`` and ``(v, ω)``
differ.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from liebridge import registration as reg
from liebridge.lie import se3

T_TS = se3.exp(np.array([0.5, -0.3, 0.4, 2.0, -1.0, 0.5]))
#: Initial guess near the truth: one library iteration from here is compared with liebridge.
T_0 = T_TS @ se3.exp(np.array([0.01, -0.02, 0.015, 0.05, 0.03, -0.04]))


def _scene(n: int = 300, seed: int = 1, noise: float = 0.003) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-10.0, 10.0, size=(n, 3))
    p = (q - T_TS[:3, 3]) @ T_TS[:3, :3] + noise * rng.normal(size=(n, 3))  # p ≈ T⁻¹·q
    return p, q


def _pairs(T: np.ndarray, p: np.ndarray, q: np.ndarray, tau: float) -> tuple:
    d, nn = cKDTree(q).query(p @ T[:3, :3].T + T[:3, 3])
    keep = d < tau
    return p[keep], q[nn[keep]], keep, nn


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


# --------------------------------------------------------------------------- Open3D
def _o3d():
    try:  # an installed wheel can still fail to load (its libusb-1.0 missing): skip then too
        import open3d
    except ImportError as exc:
        pytest.skip(f"open3d (extra 'open3d') not usable here: {exc}")
    return open3d


def _o3d_info(o3d, p: np.ndarray, q: np.ndarray, T: np.ndarray) -> np.ndarray:
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(q))
    reg_ = o3d.pipelines.registration
    return np.asarray(reg_.get_information_matrix_from_point_clouds(src, tgt, 0.5, T))


def test_open3d_information_is_left_rotation_first_unit_noise_on_an_aligned_pair() -> None:
    o3d = _o3d()
    p, _ = _scene(noise=0.0)
    q = p @ T_TS[:3, :3].T + T_TS[:3, 3]  # exactly aligned
    lib = _o3d_info(o3d, p, q, T_TS)
    mine = reg.information(T_TS, p, q, sigma=1.0, convention="open3d").information
    assert _rel(mine, lib) < 1e-9
    assert lib[5, 5] == pytest.approx(len(p))  # unit noise: the count of correspondences
    # the tempting readings are measurably different
    swapped = np.roll(np.roll(mine, 3, 0), 3, 1)  # "I comes first"
    assert _rel(swapped, lib) > 1e-2
    right = reg.information(T_TS, p, q, sigma=1.0, convention="small_gicp").information
    assert _rel(right, lib) > 1e-2


def test_open3d_information_is_at_target_points_not_the_hessian_off_alignment() -> None:
    o3d = _o3d()
    p, q = _scene(noise=0.003)
    lib = _o3d_info(o3d, p, q, T_TS)
    at_target = reg.information(
        T_TS, q @ T_TS[:3, :3] - T_TS[:3, 3] @ T_TS[:3, :3], q, sigma=1.0, convention="open3d"
    ).information
    hessian = reg.information(T_TS, p, q, sigma=1.0, convention="open3d").information
    assert _rel(at_target, lib) < 1e-9
    assert 1e-6 < _rel(hessian, lib) < 1e-3


def test_open3d_to_gtsam_equals_the_between_factor_hessian() -> None:
    o3d = _o3d()
    gtsam = pytest.importorskip("gtsam")
    from liebridge.gtsam import registration_factor

    p, _ = _scene(noise=0.0)
    q = p @ T_TS[:3, :3].T + T_TS[:3, 3]
    lib = _o3d_info(o3d, p, q, T_TS)
    f = registration_factor(0, 1, reg.from_open3d(lib, T_TS, sigma=0.01))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3())
    v.insert(1, gtsam.Pose3(T_TS))
    H = np.asarray(f.linearize(v).information())[6:, 6:]
    X = gtsam.Pose3(T_TS)
    cols = []
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-6
        a, b = X.retract(d).matrix(), X.retract(-d).matrix()
        cols.append(((p @ a[:3, :3].T + a[:3, 3]) - (p @ b[:3, :3].T + b[:3, 3])).ravel() / 2e-6)
    J = np.stack(cols, axis=1)
    assert _rel(H, J.T @ J / 1e-4) < 1e-6


def test_open3d_registration_result_is_read_with_its_correspondences() -> None:
    o3d = _o3d()
    p, q = _scene(noise=0.003)
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(q))
    r = o3d.pipelines.registration.registration_icp(
        src, tgt, 0.5, T_0, o3d.pipelines.registration.TransformationEstimationPointToPoint()
    )
    est = reg.from_open3d(r, source=src, target=tgt, convention="open3d")
    assert est.num_correspondences == len(np.asarray(r.correspondence_set))
    assert est.sigma == pytest.approx(0.003, rel=0.15)
    np.testing.assert_allclose(est.T, np.asarray(r.transformation))
    with pytest.raises(ValueError, match="source, target"):
        reg.from_open3d(r)


def test_open3d_quaternion_order_is_wxyz() -> None:
    o3d = _o3d()
    from liebridge.lie import quaternion

    q = np.array([0.8, 0.2, -0.4, 0.4])
    q /= np.linalg.norm(q)
    R = np.asarray(o3d.geometry.get_rotation_matrix_from_quaternion(q))
    np.testing.assert_allclose(R, quaternion.to_matrix(q, order="wxyz"), atol=1e-12)


# --------------------------------------------------------------------------- small_gicp
def _sg():
    return pytest.importorskip("small_gicp", reason="small_gicp (extra 'registration') missing")


def _covs(cloud) -> np.ndarray:
    return np.array([cloud.cov(i)[:3, :3] for i in range(cloud.size())])


@pytest.mark.parametrize("kind", ["ICP", "GICP"])
def test_small_gicp_H_is_liebridges_information_at_its_linearisation_point(kind: str) -> None:
    sg = _sg()
    p, q = _scene()
    tgt, src = sg.PointCloud(q), sg.PointCloud(p)
    sg.estimate_normals_covariances(tgt, num_neighbors=10)
    sg.estimate_normals_covariances(src, num_neighbors=10)
    r = sg.align(
        tgt,
        src,
        init_T_target_source=T_0,
        registration_type=kind,
        max_iterations=1,
        max_correspondence_distance=1.0,
    )
    ps, qs, keep, nn = _pairs(T_0, p, q, 1.0)
    assert r.num_inliers == keep.sum()
    if kind == "ICP":
        mine = reg.information(T_0, ps, qs, sigma=1.0, convention="small_gicp").information
    else:
        mine = reg.information(
            T_0, ps, qs, C_src=_covs(src)[keep], C_tgt=_covs(tgt)[nn[keep]], convention="small_gicp"
        ).information
    assert _rel(mine, np.asarray(r.H)) < 1e-9
    kiss = reg.information(T_0, ps, qs, sigma=1.0, convention="kiss_icp").information
    if kind == "ICP":
        assert _rel(kiss, np.asarray(r.H)) > 1e-2  # (ρ, ω) left is not small_gicp's tangent


@pytest.mark.parametrize("kind", ["ICP", "GICP"])
def test_small_gicp_H_into_gtsam_equals_the_between_factor_hessian(kind: str) -> None:
    """The library's own H through registration_factor = GN Hessian via ``Pose3.retract``."""
    sg = _sg()
    gtsam = pytest.importorskip("gtsam")
    from liebridge.gtsam import registration_factor

    p, q = _scene()
    tgt, src = sg.PointCloud(q), sg.PointCloud(p)
    sg.estimate_normals_covariances(tgt, num_neighbors=10)
    sg.estimate_normals_covariances(src, num_neighbors=10)
    r = sg.align(
        tgt,
        src,
        init_T_target_source=T_0,
        registration_type=kind,
        max_iterations=1,
        max_correspondence_distance=1.0,
    )
    sigma = 0.003 if kind == "ICP" else None
    f = registration_factor(0, 1, (T_0, np.asarray(r.H)), sigma=sigma, convention="small_gicp")
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3())
    v.insert(1, gtsam.Pose3(T_0))
    H = np.asarray(f.linearize(v).information())[6:, 6:]
    ps, _, keep, nn = _pairs(T_0, p, q, 1.0)  # J does not depend on q
    X = gtsam.Pose3(T_0)
    cols = []
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-6
        a, b = X.retract(d).matrix(), X.retract(-d).matrix()
        cols.append(((ps @ a[:3, :3].T + a[:3, 3]) - (ps @ b[:3, :3].T + b[:3, 3])) / 2e-6)
    J = np.stack(cols, axis=-1)  # (N, 3, 6)
    if kind == "ICP":
        W = np.broadcast_to(np.eye(3) / sigma**2, (len(ps), 3, 3))
    else:
        R = T_0[:3, :3]
        W = np.linalg.inv(_covs(tgt)[nn[keep]] + R @ _covs(src)[keep] @ R.T)
    assert _rel(H, np.einsum("nia,nij,njb->ab", J, W, J)) < 1e-6


def test_small_gicp_updates_on_the_right_with_omega_first() -> None:
    """One Levenberg–Marquardt step (λ = 1e-3): T₁ = T₀·Exp(−(H + λI)⁻¹b), δ = (ω, ρ)."""
    sg = _sg()
    p, q = _scene()
    r = sg.align(
        sg.PointCloud(q),
        sg.PointCloud(p),
        init_T_target_source=T_0,
        registration_type="ICP",
        max_iterations=1,
        max_correspondence_distance=1.0,
    )
    H, b = np.asarray(r.H), np.asarray(r.b).ravel()
    d = -np.linalg.solve(H + 1e-3 * np.eye(6), b)
    T1 = np.asarray(r.T_target_source)
    assert np.abs(T_0 @ se3.exp(d) - T1).max() < 1e-12
    assert np.abs(se3.exp(d) @ T_0 - T1).max() > 1e-3  # not left
    assert np.abs(T_0 @ se3.exp(np.r_[d[3:], d[:3]]) - T1).max() > 1e-3  # not (ρ, ω)


def test_small_gicp_covariances_are_normalised_not_metric() -> None:
    sg = _sg()
    p, _ = _scene()
    src = sg.PointCloud(p * 0.01)  # a centimetre-scale cloud: metric covariances would be ~1e-4
    sg.estimate_covariances(src, num_neighbors=10)
    lam = np.linalg.eigvalsh(_covs(src))
    np.testing.assert_allclose(lam, np.broadcast_to([1e-3, 1.0, 1.0], lam.shape), atol=1e-9)


def test_small_gicp_plane_icp_error_is_componentwise() -> None:
    """PLANE_ICP: H = Σ Jᵀ diag(n∘n) J, not the point-to-plane Σ Jᵀ n nᵀ J."""
    sg = _sg()
    p, q = _scene()
    tgt = sg.PointCloud(q)
    sg.estimate_normals(tgt, num_neighbors=10)
    r = sg.align(
        tgt,
        sg.PointCloud(p),
        init_T_target_source=T_0,
        registration_type="PLANE_ICP",
        max_iterations=1,
        max_correspondence_distance=1.0,
    )
    ps, qs, keep, nn = _pairs(T_0, p, q, 1.0)
    n = np.array([tgt.normal(i)[:3] for i in range(tgt.size())])[nn[keep]]
    _, J = reg.point_to_point(T_0, ps, qs, "small_gicp")
    comp = np.einsum("nia,ni,nib->ab", J, n * n, J)
    assert _rel(comp, np.asarray(r.H)) < 1e-9
    usual = reg.information(T_0, ps, qs, n_tgt=n, sigma=1.0, convention="small_gicp").information
    assert _rel(usual, np.asarray(r.H)) > 1e-2


def test_from_small_gicp_reads_the_result_object() -> None:
    sg = _sg()
    p, q = _scene()
    r = sg.align(
        sg.PointCloud(q),
        sg.PointCloud(p),
        init_T_target_source=T_0,
        registration_type="ICP",
        max_correspondence_distance=1.0,
    )
    est = reg.from_small_gicp(r, sigma=0.003, convention="kiss_icp")
    np.testing.assert_allclose(est.T, np.asarray(r.T_target_source))
    back = est.to("small_gicp")
    assert _rel(np.linalg.inv(back.cov), np.asarray(r.H) / 0.003**2) < 1e-9


# --------------------------------------------------------------------------- KISS-ICP
def test_kiss_icp_updates_on_the_left_translation_first_with_geman_mcclure_weights() -> None:
    pytest.importorskip("kiss_icp", reason="kiss-icp (extra 'registration') not installed")
    from kiss_icp.mapping import VoxelHashMap
    from kiss_icp.registration import Registration

    p, q = _scene(seed=2)
    vm = VoxelHashMap(voxel_size=1.0, max_distance=100.0, max_points_per_voxel=20)
    vm.add_points(q)
    qq = vm.point_cloud()
    k = 0.5
    T1 = Registration(
        max_num_iterations=1, convergence_criterion=1e-15, max_num_threads=1
    ).align_points_to_map(
        points=p, voxel_map=vm, initial_guess=T_0, max_correspondance_distance=1.5, kernel=k
    )
    ps, qs, *_ = _pairs(T_0, p, qq, 1.5)
    r, J = reg.point_to_point(T_0, ps, qs, "kiss_icp")
    w = k**2 / (k + np.sum(r * r, axis=1)) ** 2
    H = np.einsum("n,nia,nib->ab", w, J, J)
    d = -np.linalg.solve(H, np.einsum("n,nia,ni->a", w, J, r))  # (ρ, ω)
    assert np.abs(se3.exp(np.r_[d[3:], d[:3]]) @ T_0 - T1).max() < 1e-10
    assert np.abs(T_0 @ se3.exp(np.r_[d[3:], d[:3]]) - T1).max() > 1e-3  # not right
    assert np.abs(se3.exp(d) @ T_0 - T1).max() > 1e-3  # not (ω, ρ)


def test_from_kiss_icp_on_a_kiss_icp_odometry_step() -> None:
    pytest.importorskip("kiss_icp", reason="kiss-icp (extra 'registration') not installed")
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    rng = np.random.default_rng(3)
    # a box room 20 × 12 × 4 m sampled densely, seen from two poses
    faces = []
    for axis, lo, hi in ((0, -10, 10), (1, -6, 6), (2, 0, 4)):
        for v in (lo, hi):
            pts = rng.uniform([-10, -6, 0], [10, 6, 4], size=(4000, 3))
            pts[:, axis] = v
            faces.append(pts)
    room = np.vstack(faces)
    cfg = KISSConfig()
    cfg.data.deskew = False
    cfg.data.max_range = 100.0
    cfg.data.min_range = 0.0
    cfg.mapping.voxel_size = 0.5
    odo = KissICP(cfg)
    pose1 = se3.exp(np.array([0.0, 0.0, 0.1, 0.3, 0.1, 0.0]))
    odo.register_frame(room + 0.002 * rng.normal(size=room.shape), np.zeros(len(room)))
    scan = (room - pose1[:3, 3]) @ pose1[:3, :3] + 0.002 * rng.normal(size=room.shape)
    target = odo.local_map.point_cloud()
    odo.register_frame(scan, np.zeros(len(scan)))
    T = odo.last_pose
    assert np.abs(T - pose1).max() < 0.02
    src = odo.voxelize(scan)[0]
    est = reg.from_kiss_icp(src, target, T, max_correspondence_distance=1.0, convention="gtsam")
    assert est.sigma_source == "residual" and est.num_correspondences > 100
    assert np.all(np.linalg.eigvalsh(est.cov) > 0)
