"""g2o / EDGE3 files: information semantics against GTSAM, g2o's χ² and the sphere2500 ground truth.

Expected values come from GTSAM (``readG2o``, ``Pose3``), scipy's quaternions and Euler angles,
and the test's own parsing of the files, never from liebridge.
"""

from functools import cache
from pathlib import Path

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import liebridge as lb
from liebridge.io import g2o

QUAT_FILES = ["pose3example.txt", "pose3example-offdiagonal.txt"]
ALL_FILES = [*QUAT_FILES, "sphere2500.txt"]
TRIU = np.triu_indices(6)


def data(name: str) -> str:
    return gtsam.findExampleDataFile(name)


@cache
def read(name: str, information: str = "g2o") -> g2o.G2OGraph:
    return g2o.read(data(name), information)  # type: ignore[arg-type]


# ---------------------------------------------------------------- independent helpers


def file_edges(name: str) -> list[tuple[str, int, int, np.ndarray, np.ndarray]]:
    """(tag, i, j, pose numbers, 21 information numbers) straight from the text."""
    out = []
    for line in Path(data(name)).read_text().splitlines():
        f = line.split()
        if f and f[0] in ("EDGE_SE3:QUAT", "EDGE3"):
            nums = np.array([float(x) for x in f[3:]])
            k = 7 if f[0] == "EDGE_SE3:QUAT" else 6
            out.append((f[0], int(f[1]), int(f[2]), nums[:k], nums[k:]))
    return out


def sym(upper21: np.ndarray) -> np.ndarray:
    m = np.zeros((6, 6))
    m[TRIU] = upper21
    return m + np.triu(m, 1).T


def g2o_error(D: np.ndarray) -> np.ndarray:
    """g2o's EDGE_SE3:QUAT error vector of D = Z⁻¹·Ti⁻¹·Tj: (t, qvec) with w ≥ 0."""
    q = Rotation.from_matrix(D[:3, :3]).as_quat()  # x y z w
    if q[3] < 0:
        q = -q
    return np.concatenate([D[:3, 3], q[:3]])


def rpy_params(T: np.ndarray) -> np.ndarray:
    """(x, y, z, roll, pitch, yaw) with R = Rz(yaw) Ry(pitch) Rx(roll) (scipy intrinsic ZYX)."""
    yaw, pitch, roll = Rotation.from_matrix(T[:3, :3]).as_euler("ZYX")
    return np.array([*T[:3, 3], roll, pitch, yaw])


def elementary_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    c, s = np.cos, np.sin
    Rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    Ry = np.array([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    Rz = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def exp(xi: np.ndarray) -> np.ndarray:
    return gtsam.Pose3.Expmap(xi).matrix()


def fd_jacobian(f, n: int = 6, h: float = 1e-6) -> np.ndarray:  # type: ignore[no-untyped-def]
    cols = []
    for k in range(n):
        d = np.zeros(n)
        d[k] = h
        cols.append((f(d) - f(-d)) / (2 * h))
    return np.stack(cols, axis=-1)


M_LITERAL = np.block([[np.zeros((3, 3)), np.eye(3)], [0.5 * np.eye(3), np.zeros((3, 3))]])


# ---------------------------------------------------------------- acceptance against GTSAM


@pytest.mark.parametrize("name", ALL_FILES)
def test_gtsam_reading_reproduces_readG2o_factor_by_factor(name: str) -> None:
    ours, ours_values = read(name, "gtsam").to_gtsam(prior=None)
    ref, ref_values = gtsam.readG2o(data(name), True)
    assert ours.size() == ref.size()
    for k in range(ref.size()):
        a, b = ours.at(k), ref.at(k)
        assert list(a.keys()) == list(b.keys())
        assert np.allclose(a.measured().matrix(), b.measured().matrix(), atol=1e-15, rtol=0)
        na, nb = a.noiseModel(), b.noiseModel()
        assert type(na) is type(nb)
        assert np.allclose(na.R(), nb.R(), atol=0, rtol=1e-14)
        assert np.allclose(na.information(), nb.information(), atol=0, rtol=1e-14)
    for key in ref_values.keys():  # sphere2500: GTSAM gives no values; ours are chained
        assert np.allclose(
            ours_values.atPose3(key).matrix(), ref_values.atPose3(key).matrix(), atol=1e-15
        )


@pytest.mark.parametrize("name", QUAT_FILES)
def test_g2o_reading_quarters_rotation_and_halves_cross_blocks(name: str) -> None:
    lam_g, lam_t = read(name, "g2o").information, read(name, "gtsam").information
    assert np.array_equal(lam_g[:, :3, :3], lam_t[:, :3, :3] / 4)
    assert np.array_equal(lam_g[:, :3, 3:], lam_t[:, :3, 3:] / 2)
    assert np.array_equal(lam_g[:, 3:, :3], lam_t[:, 3:, :3] / 2)
    assert np.array_equal(lam_g[:, 3:, 3:], lam_t[:, 3:, 3:])
    # and both against the file: Λ_gtsam = Mᵀ Λ_file M with the literal M
    for lam, (_, _, _, _, upper) in zip(lam_g, file_edges(name), strict=True):
        assert np.allclose(lam, M_LITERAL.T @ sym(upper) @ M_LITERAL, atol=0, rtol=1e-15)


def test_g2o_error_map_by_finite_differences() -> None:
    # e(ξ) = g2o error of Z⁻¹·Ti⁻¹·Tj with Tj = Ti·Z·Exp(ξ); M = de/dξ at 0, for any Ti, Z
    rng = np.random.default_rng(0)
    for _ in range(3):
        Ti, Z = exp(rng.normal(size=6)), exp(rng.normal(size=6))

        def e(xi: np.ndarray, Ti: np.ndarray = Ti, Z: np.ndarray = Z) -> np.ndarray:
            Tj = Ti @ Z @ exp(xi)
            return g2o_error(np.linalg.inv(Z) @ np.linalg.inv(Ti) @ Tj)

        M = fd_jacobian(e)
        assert np.allclose(M, M_LITERAL, atol=1e-8)
        assert np.allclose(lb.tangent_map(Z, "gtsam", "g2o"), M, atol=1e-8)


@pytest.mark.parametrize("seed", range(3))
def test_error_map_is_the_format_literal_at_any_measurement(seed: int) -> None:
    """The conversion core's GTSAM → g2o tangent map is the format's literal [[0, I], [I/2, 0]],
    wherever it is evaluated (the g2o preset is the error's chart), and its inverse the reverse map.
    """
    Z = exp(np.random.default_rng(seed).normal(size=6))
    M = lb.tangent_map(Z, "gtsam", "g2o")
    assert np.array_equal(M, M_LITERAL)  # entries 0, 1, ½: exact in floating point
    assert np.array_equal(lb.tangent_map(Z, "g2o", "gtsam") @ M_LITERAL, np.eye(6))


@pytest.mark.parametrize("name", QUAT_FILES)
def test_chi2_matches_g2o_at_file_values_within_second_order(name: str) -> None:
    """Per edge, |0.5 eᵀΛe − error| ≤ ‖Λ‖(|Mξ||Δ| + |Δ|²/2), Δ = e − Mξ, at the file's values.

    This is an identity bound if Λ_gtsam = Mᵀ Λ_g2o M; it is tight where residuals are small
    (here ~1e-6 on the chained edges), where the 4× gtsam reading violates it.
    """
    graph, values = read(name, "g2o").to_gtsam(prior=None)
    graph_t, _ = read(name, "gtsam").to_gtsam(prior=None)
    total_ours = total_g2o = total_bound = 0.0
    caught = 0
    for k, (_, i, j, _, upper) in enumerate(file_edges(name)):
        lam = sym(upper)
        Z = graph.at(k).measured().matrix()
        D = (
            np.linalg.inv(Z)
            @ np.linalg.inv(values.atPose3(i).matrix())
            @ values.atPose3(j).matrix()
        )
        e = g2o_error(D)
        xi = gtsam.Pose3.Logmap(gtsam.Pose3(D))
        delta = e - M_LITERAL @ xi
        chi_g2o = 0.5 * e @ lam @ e
        ours = graph.at(k).error(values)
        norm = np.linalg.norm(lam, 2)
        bound = norm * (
            np.linalg.norm(M_LITERAL @ xi) * np.linalg.norm(delta) + 0.5 * delta @ delta
        )
        bound += 1e-12 * max(chi_g2o, 1e-12)  # rounding in the 6x6 products
        assert abs(ours - chi_g2o) <= bound, (k, ours, chi_g2o, bound)
        caught += abs(graph_t.at(k).error(values) - chi_g2o) > 10 * bound
        total_ours, total_g2o, total_bound = (
            total_ours + ours,
            total_g2o + chi_g2o,
            total_bound + bound,
        )
    assert abs(graph.error(values) - total_ours) <= 1e-12 * total_ours
    assert abs(total_ours - total_g2o) <= total_bound
    if name == "pose3example.txt":
        assert caught >= 1  # the gtsam reading is measurably not g2o's χ²


@pytest.mark.parametrize("name", QUAT_FILES)
def test_chi2_matches_g2o_at_small_residuals_per_edge(name: str) -> None:
    graph, values = read(name, "g2o").to_gtsam(prior=None)
    graph_t, _ = read(name, "gtsam").to_gtsam(prior=None)
    rng = np.random.default_rng(1)
    s = 1e-6  # residual size: relative second-order error ~ s·cond(Λ)^(1/2) ~ 1e-5 at most
    for k, (_, i, j, _, upper) in enumerate(file_edges(name)):
        Ti = values.atPose3(i).matrix()
        Z = graph.at(k).measured().matrix()
        xi0 = rng.normal(size=6)
        v = gtsam.Values()
        v.insert(i, gtsam.Pose3(Ti))
        v.insert(j, gtsam.Pose3(Ti @ Z @ exp(s * xi0)))
        Tj = v.atPose3(j).matrix()
        e = g2o_error(np.linalg.inv(Z) @ np.linalg.inv(Ti) @ Tj)
        chi_g2o = 0.5 * e @ sym(upper) @ e
        assert graph.at(k).error(v) == pytest.approx(chi_g2o, rel=1e-4)
        assert graph_t.at(k).error(v) != pytest.approx(chi_g2o, rel=0.05)


def write_g2o_text(path: Path, T: np.ndarray, edges: list, Z: np.ndarray, info: np.ndarray) -> None:
    """A g2o file written by the test itself (repr precision, xyzw quaternions)."""

    def text(nums: list) -> str:
        return " ".join(repr(float(x)) for x in nums)

    lines = []
    for k, Tk in enumerate(T):
        q = Rotation.from_matrix(Tk[:3, :3]).as_quat()
        lines.append(f"VERTEX_SE3:QUAT {k} {text([*Tk[:3, 3], *q])}")
    for (i, j), Zk, L in zip(edges, Z, info, strict=True):
        q = Rotation.from_matrix(Zk[:3, :3]).as_quat()
        lines.append(f"EDGE_SE3:QUAT {i} {j} {text([*Zk[:3, 3], *q, *L[TRIU]])}")
    path.write_text("\n".join(lines) + "\n")


def test_chi2_matches_g2o_on_a_whole_graph_with_small_residuals(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    n = 30
    T = [np.eye(4)]
    for _ in range(n - 1):
        T.append(T[-1] @ exp(np.concatenate([0.3 * rng.normal(size=3), rng.normal(size=3)])))
    T = np.array(T)
    edges = [(k, k + 1) for k in range(n - 1)] + [
        (int(a), int(b)) for a, b in rng.integers(0, n, size=(30, 2)) if a != b
    ]
    Z, info = [], []
    for i, j in edges:
        Z.append(np.linalg.inv(T[i]) @ T[j] @ exp(1e-5 * rng.normal(size=6)))
        A = rng.normal(size=(6, 6))
        info.append(A @ A.T + 6 * np.eye(6))  # full, with translation-quaternion cross terms
    Z, info = np.array(Z), np.array(info)
    p = tmp_path / "graph.g2o"
    write_g2o_text(p, T, edges, Z, info)
    graph, values = g2o.read(p).to_gtsam(prior=None)
    chi2 = 0.0
    for (i, j), Zk, L in zip(edges, Z, info, strict=True):
        e = g2o_error(np.linalg.inv(Zk) @ np.linalg.inv(T[i]) @ T[j])
        chi2 += 0.5 * e @ L @ e
    # residuals ~1e-5: relative second-order difference ≲ 1e-4
    assert graph.error(values) == pytest.approx(chi2, rel=1e-3)
    graph_t, _ = g2o.read(p, "gtsam").to_gtsam(prior=None)
    assert graph_t.error(values) != pytest.approx(chi2, rel=0.1)


# ---------------------------------------------------------------- EDGE3 / VERTEX3


def test_edge3_rotation_is_rz_ry_rx(tmp_path: Path) -> None:
    p = tmp_path / "e3.txt"
    rpy = (0.4, -0.7, 2.0)
    info = " ".join(["1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1"])
    p.write_text(f"VERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 1 2 3 {' '.join(map(str, rpy))}\n")
    p.write_text(p.read_text() + f"EDGE3 0 1 1 2 3 {' '.join(map(str, rpy))} {info}\n")
    G = g2o.read(p)
    R = elementary_rpy(*rpy)
    assert np.allclose(G.poses[1, :3, :3], R, atol=1e-15)
    assert np.allclose(G.measured[0, :3, :3], R, atol=1e-15)
    assert np.array_equal(G.poses[1, :3, 3], [1.0, 2.0, 3.0])
    assert np.allclose(R, gtsam.Rot3.Ypr(rpy[2], rpy[1], rpy[0]).matrix(), atol=1e-15)


def test_sphere2500_ground_truth_decides_the_edge3_reading() -> None:
    meas, gt = read("sphere2500.txt"), read("sphere2500_groundtruth.txt")
    # 1. the composition: chained ground-truth odometry closes every loop with Rz·Ry·Rx ...
    T = gt.poses
    ids = {int(k): n for n, k in enumerate(gt.vertex_ids)}
    loops = [(k, i, j) for k, (i, j) in enumerate(gt.edges) if j != i + 1]
    err = max(
        np.abs(np.linalg.inv(T[ids[i]]) @ T[ids[j]] - gt.measured[k]).max() for k, i, j in loops
    )
    assert err < 1e-3  # 6-digit file, chains of ~hundreds of edges
    # ... and not with Rx·Ry·Rz (the control: the data can tell the two apart)
    raw = file_edges("sphere2500_groundtruth.txt")
    Zx = []
    for _, _, _, nums, _ in raw:
        Zk = np.eye(4)
        Zk[:3, :3] = Rotation.from_euler("XYZ", nums[3:6]).as_matrix()  # intrinsic: Rx·Ry·Rz
        Zk[:3, 3] = nums[:3]
        Zx.append(Zk)
    Tx = {0: np.eye(4)}
    for (_, i, j, _, _), Zk in zip(raw, Zx, strict=True):
        if j == i + 1:
            Tx[j] = Tx[i] @ Zk
    err_x = max(np.abs(np.linalg.inv(Tx[i]) @ Tx[j] - Zx[k]).max() for k, i, j in loops)
    assert err_x > 1.0
    # 2. the noise: raw parameter differences have std = 1 / (the 21 numbers' diagonal)
    d = np.array(
        [rpy_params(Zm) - rpy_params(Zg) for Zm, Zg in zip(meas.measured, gt.measured, strict=True)]
    )
    diag = file_edges("sphere2500.txt")[0][4][[0, 6, 11, 15, 18, 20]]
    assert np.allclose(d.std(axis=0), 1.0 / diag, rtol=0.05)
    # 3. whitened with our information, the errors are χ² with 6 degrees of freedom
    xi = np.array(
        [
            gtsam.Pose3.Logmap(gtsam.Pose3(np.linalg.inv(Zm) @ Zg))
            for Zm, Zg in zip(meas.measured, gt.measured, strict=True)
        ]
    )
    chi = np.einsum("ni,nij,nj->n", xi, meas.information, xi)
    assert abs(chi.mean() - 6.0) < 0.3  # std of the mean of 4949 χ²₆ samples: 0.05
    lam_t = read("sphere2500.txt", "gtsam").information
    chi_t = np.einsum("ni,nij,nj->n", xi, lam_t, xi)
    assert abs(chi_t.mean() - 6.0) > 2.0  # GTSAM's reading is not calibrated


def edge3_file(tmp_path: Path, rpy: tuple, upper: np.ndarray) -> Path:
    p = tmp_path / "e3.txt"
    nums = " ".join(repr(float(x)) for x in [0.3, -0.2, 0.5, *rpy, *upper])
    p.write_text(f"EDGE3 0 1 {nums}\n")
    return p


@pytest.mark.parametrize("rpy", [(0.01, -0.02, 0.15), (0.4, -0.7, 2.0), (-2.5, 1.2, -3.0)])
def test_edge3_information_map_by_finite_differences(tmp_path: Path, rpy: tuple) -> None:
    rng = np.random.default_rng(3)
    S = np.triu(rng.normal(size=(6, 6))) + 5 * np.eye(6)  # off-diagonal sqrt information
    p = edge3_file(tmp_path, rpy, S[TRIU])
    Z = np.eye(4)
    Z[:3, :3] = elementary_rpy(*rpy)
    Z[:3, 3] = [0.3, -0.2, 0.5]
    base = rpy_params(Z)

    def params(xi: np.ndarray) -> np.ndarray:
        d = rpy_params(Z @ exp(xi)) - base
        d[3:] = (d[3:] + np.pi) % (2 * np.pi) - np.pi
        return d

    E = fd_jacobian(params)
    G = g2o.read(p)
    assert np.allclose(G.information[0], E.T @ S.T @ S @ E, rtol=1e-6, atol=1e-6)
    A = S.T @ S  # the same numbers read as information (g2o's EdgeSE3Euler)
    p2 = edge3_file(tmp_path, rpy, A[TRIU])
    G2 = g2o.read(p2, edge3="information")
    assert np.allclose(G2.information[0], E.T @ A @ E, rtol=1e-6, atol=1e-6)
    assert np.allclose(G2.information[0], G.information[0], rtol=1e-12)
    # and the gtsam reading takes the numbers as they are
    assert np.array_equal(g2o.read(p2, "gtsam").information[0], A)


def test_edge3_chi2_matches_isam_error_at_small_residuals() -> None:
    G = read("sphere2500.txt")
    graph, values = G.to_gtsam(prior=None)
    rng = np.random.default_rng(4)
    edges = file_edges("sphere2500.txt")
    for k in rng.choice(len(edges), size=20, replace=False):
        _, i, j, nums, upper = edges[k]
        S = np.zeros((6, 6))
        S[TRIU] = upper
        Z = np.eye(4)
        Z[:3, :3] = elementary_rpy(*nums[3:6])
        Z[:3, 3] = nums[:3]
        Ti = values.atPose3(i).matrix()
        v = gtsam.Values()
        v.insert(i, gtsam.Pose3(Ti))
        v.insert(j, gtsam.Pose3(Ti @ Z @ exp(1e-6 * rng.normal(size=6))))
        rel = np.linalg.inv(Ti) @ v.atPose3(j).matrix()
        e = rpy_params(rel) - np.array([*nums[:3], *nums[3:6]])  # iSAM: vector(p2 ⊖ p1) − z
        chi_isam = 0.5 * e @ S.T @ S @ e
        assert graph.at(int(k)).error(v) == pytest.approx(chi_isam, rel=1e-4)


def test_edge3_gimbal_lock_raises(tmp_path: Path) -> None:
    p = edge3_file(tmp_path, (0.1, np.pi / 2, 0.3), np.eye(6)[TRIU])
    with pytest.raises(ValueError, match=r"e3.txt:1: pitch = ±π/2"):
        g2o.read(p)
    assert g2o.read(p, "gtsam").information.shape == (1, 6, 6)  # GTSAM's reading has no map


def test_sphere2500_initial_values_chain_the_odometry() -> None:
    G = read("sphere2500.txt")
    assert G.vertices_from_odometry
    assert np.array_equal(G.vertex_ids, np.arange(2500))
    ref, _ = gtsam.readG2o(data("sphere2500.txt"), True)
    chain = {0: gtsam.Pose3()}
    for k in range(ref.size()):
        f = ref.at(k)
        i, j = f.keys()
        if j == i + 1:
            chain[j] = chain[i].compose(f.measured())
    T = np.stack([chain[k].matrix() for k in range(2500)])
    assert np.allclose(G.poses, T, atol=1e-9)


def test_odometry_gap_is_an_error(tmp_path: Path) -> None:
    p = tmp_path / "gap.txt"
    p.write_text(f"EDGE3 0 1 1 0 0 0 0 0 {INFO}\nEDGE3 2 3 1 0 0 0 0 0 {INFO}\n")
    with pytest.raises(ValueError, match="no odometry edge 1 -> 2"):
        g2o.read(p)


# ---------------------------------------------------------------- writing


@pytest.mark.parametrize("name", ALL_FILES)
@pytest.mark.parametrize("information", ["g2o", "gtsam"])
def test_write_read_round_trip_is_bit_exact(tmp_path: Path, name: str, information: str) -> None:
    G = read(name, information)
    p = tmp_path / "out.g2o"
    g2o.write(p, G)
    H = g2o.read(p, information)  # type: ignore[arg-type]
    for attr in (
        "vertex_ids",
        "vertex_xyz_qxyzw",
        "edges",
        "measured_xyz_qxyzw",
        "information",
        "poses",
        "measured",
    ):
        assert np.array_equal(getattr(G, attr), getattr(H, attr)), attr
    assert H.information_reading == information
    p2 = tmp_path / "out2.g2o"
    g2o.write(p2, H)
    assert p2.read_text() == p.read_text()


def test_write_keeps_full_precision_unlike_writeG2o(tmp_path: Path) -> None:
    T = np.eye(4)
    T[:3, 3] = [1234.5678901234567, -0.1, 1e-17]
    G = g2o.G2OGraph.from_matrices(
        [0, 1], np.stack([np.eye(4), T]), [[0, 1]], T[None], np.eye(6)[None]
    )
    p = tmp_path / "ours.g2o"
    g2o.write(p, G)
    assert np.array_equal(g2o.read(p).poses[1, :3, 3], T[:3, 3])
    graph, values = G.to_gtsam(prior=None)
    q = tmp_path / "gtsam.g2o"
    gtsam.writeG2o(graph, values, str(q))
    assert "1234.57" in q.read_text() and "1234.5678901234567" in p.read_text()


def test_from_matrices_then_write_and_read(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    T = np.stack([exp(rng.normal(size=6)) for _ in range(4)])
    Z = np.stack([np.linalg.inv(T[0]) @ T[k] for k in (1, 2, 3)])
    A = rng.normal(size=(3, 6, 6))
    info = A @ np.swapaxes(A, 1, 2) + np.eye(6)
    for reading in ("g2o", "gtsam"):
        G = g2o.G2OGraph.from_matrices(
            [10, 11, 12, 13],
            T,
            [[10, 11], [10, 12], [10, 13]],
            Z,
            info,
            information_reading=reading,  # type: ignore[arg-type]
        )
        p = tmp_path / f"{reading}.g2o"
        g2o.write(p, G)
        H = g2o.read(p, reading)  # type: ignore[arg-type]
        assert np.allclose(H.poses, T, atol=1e-14, rtol=0)
        assert np.allclose(H.measured, Z, atol=1e-14, rtol=0)
        assert np.array_equal(H.information, G.information)
        assert np.allclose(H.information, info, rtol=1e-15, atol=0)
    # the file holds g2o's (t, q) information: translation block first, rotation block ×4
    text = (tmp_path / "g2o.g2o").read_text().splitlines()[4].split()
    upper = np.array([float(x) for x in text[10:]])
    assert np.allclose(sym(upper), np.linalg.inv(M_LITERAL).T @ info[0] @ np.linalg.inv(M_LITERAL))


def test_fix_lines_round_trip(tmp_path: Path) -> None:
    src = Path(data("pose3example.txt")).read_text() + "\nFIX 0\n"
    p = tmp_path / "fixed.g2o"
    p.write_text(src)
    G = g2o.read(p)
    assert G.fixed == (0,)
    g2o.write(tmp_path / "w.g2o", G)
    assert g2o.read(tmp_path / "w.g2o").fixed == (0,)


def test_graph_arrays_are_read_only() -> None:
    G = read("pose3example.txt")
    with pytest.raises(ValueError):
        G.poses[0, 0, 0] = 2.0
    with pytest.raises(ValueError):
        G.information[0, 0, 0] = 2.0


# ---------------------------------------------------------------- malformed input

V0 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1"
V1 = "VERTEX_SE3:QUAT 1 1 0 0 0 0 0 1"
INFO = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1"


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("VERTEX_SE3:QUAT 1 1 0 0 0 0 1", "expects 7 values"),
        ("VERTEX_SE3:QUAT 1 1 0 0 0 0 0 one", "not a number: 'one'"),
        ("VERTEX_SE3:QUAT 1 1 0 0 0 0 0 nan", "NaN or Inf"),
        ("VERTEX_SE3:QUAT 1 1 0 0 1 1 0 0", "quaternion norm off by 0.414"),
        ("VERTEX_SE3:QUAT x 1 0 0 0 0 0 1", "vertex id 'x' is not an integer"),
        ("VERTEX_SE3:QUAT 0 1 0 0 0 0 0 1", "vertex 0 already defined on line 1"),
        (f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 {INFO} 7", "expects 28 values"),
        (f"EDGE_SE3:QUAT 0 0 1 0 0 0 0 0 1 {INFO}", "from vertex 0 to itself"),
        (f"EDGE_SE3:QUAT 0 5 1 0 0 0 0 0 1 {INFO}", "vertex 5, which has no VERTEX line"),
        (f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 -{INFO}", "positive semi-definite"),
        (f"EDGE3 0 1 1 0 0 0 0 0 {INFO} 1", "expects 27 values"),
        ("VERTEX_SE2 1 0 0 0", "2-D type VERTEX_SE2 in a 3-D file: read it with"),
        ("PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1", "unsupported tag 'PARAMS_SE3OFFSET'"),
    ],
)
def test_malformed_line_names_file_and_line(tmp_path: Path, line: str, match: str) -> None:
    p = tmp_path / "bad.g2o"
    p.write_text(f"{V0}\n{line}\n")
    with pytest.raises(ValueError, match=match) as exc:
        g2o.read(p)
    assert f"{p}:2:" in str(exc.value)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="information"):
        g2o.read(data("pose3example.txt"), "sqrt")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="edge3"):
        g2o.read(data("pose3example.txt"), edge3="isam")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="G2OGraph"):
        g2o.write("x.g2o", object())  # type: ignore[arg-type]


def test_fix_of_missing_vertex(tmp_path: Path) -> None:
    p = tmp_path / "fix.g2o"
    p.write_text(f"{V0}\n{V1}\nFIX 9\n")
    with pytest.raises(ValueError, match="FIX refers to vertex 9"):
        g2o.read(p)
