"""Navigation states across VIO/LIO systems (conventions part).

* Euler-angle rotation coordinates ``euler_zyx`` / ``euler_rpy``: round trips, first-order maps
  and ``local_jacobian`` against central differences, GTSAM's ``Rot3.Ypr`` and scipy as oracles,
  detection, gimbal lock as one clear error.
* JPL quaternion storage: Trawny's ``C(q̄)`` and JPL product written out independently.
* Whole-state presets: each system's update transcribed from its source (OpenVINS
  ``JPLQuat::update``, VINS ``PoseLocalParameterization::Plus``, Basalt ``incPose``, ORB-SLAM3
  ``ImuCamPose::Update``,
  GTSAM ``NavState.retract`` / ``Pose3.retract``) against the preset's retraction; Monte Carlo of
  every pair's covariance conversion; round trips; Jacobians; bad input.
"""

from __future__ import annotations

import itertools

import gtsam
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import liebridge as lb
from liebridge import conventions as C
from liebridge.check import monte_carlo_covariance, numerical_jacobian
from liebridge.conventions.rotation_coords import euler_rate_map, euler_to_matrix
from liebridge.lie import quaternion as Q
from liebridge.lie import so3

EULER = ("euler_zyx", "euler_rpy")
STATES = [c.name for c in C.STATE_PRESETS_15]


def _euler_conv(kind: str, chart: str = "so3xr3_body", order: str = "rot_first") -> C.Convention:
    return C.Convention(
        name=f"test_{kind}", side="right", order=order, chart=chart, rotation=kind,  # type: ignore[arg-type]
        quat_order="xyzw",
    )  # fmt: skip


def _pose(rng: np.random.Generator, pitch_max: float = 1.2) -> np.ndarray:
    e = rng.uniform([-3, -pitch_max, -3], [3, pitch_max, 3])  # (yaw, pitch, roll)
    T = np.eye(4)
    T[:3, :3] = euler_to_matrix(e, "euler_zyx")
    T[:3, 3] = rng.normal(size=3) * 30.0  # 30 m translations
    return T


def _state(rng: np.random.Generator) -> np.ndarray:
    T = _pose(rng)
    X = C.nav_state(T[:3, :3], T[:3, 3], rng.normal(size=3) * 5.0)
    return C.OPENVINS.assemble(nav=X, b_a=rng.normal(size=3) * 0.1, b_g=rng.normal(size=3) * 0.01)


def _cov(rng: np.random.Generator, n: int, scale: float = 0.01) -> np.ndarray:
    A = rng.normal(size=(n, n)) * scale
    return A @ A.T + np.eye(n) * scale**2


# ----------------------------------------------------------------------------- Euler angles
def test_constructor_with_group() -> None:
    c = C.Convention(
        name="mrpt_rot", side="right", order="rot_first", chart="so3xr3_body",
        rotation="euler_zyx", quat_order="xyzw", group="so3",
    )  # fmt: skip
    R = so3.exp([0.3, -0.2, 0.5])
    np.testing.assert_allclose(c.local(R, c.retract(R, [0.1, 0.2, -0.3])), [0.1, 0.2, -0.3])


@pytest.mark.parametrize("kind", EULER)
def test_euler_matrix_matches_gtsam_and_scipy(kind: str) -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    for _ in range(20):
        y, p, r = rng.uniform([-3, -1.5, -3], [3, 1.5, 3])
        e = [y, p, r] if kind == "euler_zyx" else [r, p, y]
        R = euler_to_matrix(np.array(e), kind)
        np.testing.assert_allclose(R, gtsam.Rot3.Ypr(y, p, r).matrix(), atol=1e-14)
        np.testing.assert_allclose(R, Rotation.from_euler("ZYX", [y, p, r]).as_matrix(), atol=1e-14)


@pytest.mark.parametrize("kind", EULER)
@pytest.mark.parametrize("chart", ["so3xr3_body", "so3xr3_world"])
@pytest.mark.parametrize("order", ["rot_first", "trans_first"])
def test_euler_round_trip_and_first_order(kind: str, chart: str, order: str) -> None:
    rng = np.random.default_rng(1)
    c = _euler_conv(kind, chart, order)
    X = np.stack([_pose(rng) for _ in range(8)])
    d = rng.normal(size=(8, 6)) * 0.2
    rot = slice(0, 3) if order == "rot_first" else slice(3, 6)
    d[..., rot] = np.clip(d[..., rot], -0.3, 0.3)  # pitch stays within (−π/2, π/2)
    np.testing.assert_allclose(c.local(X, c.retract(X, d)), d, atol=1e-9)
    np.testing.assert_allclose(c.retract(X, c.local(X, X[::-1])), X[::-1], atol=1e-9)
    for k in range(3):
        M = numerical_jacobian(lambda Z: Z, X[k], retract=c.retract, local=C.GTSAM.local, dim=6)
        np.testing.assert_allclose(c.to_canonical(X[k]), M, atol=1e-6)
        np.testing.assert_allclose(
            c.from_canonical(X[k]) @ c.to_canonical(X[k]), np.eye(6), atol=1e-12
        )
        Y = c.retract(X[k], d[k])
        J = numerical_jacobian(
            lambda Z: Z, Y, retract=c.retract, local=lambda _y, Z, k=k: c.local(X[k], Z), dim=6
        )
        np.testing.assert_allclose(c.local_jacobian(X[k], Y), J, atol=1e-6)
    # batched first-order map equals the per-element one
    np.testing.assert_allclose(c.to_canonical(X)[2], c.to_canonical(X[2]), atol=1e-15)


@pytest.mark.parametrize("kind", EULER)
def test_euler_rate_map_against_finite_differences(kind: str) -> None:
    rng = np.random.default_rng(2)
    c = _euler_conv(kind)
    for pitch in (0.0, 1e-12, 0.7, -1.5):
        e = np.array([0.4, pitch, -2.0]) if kind == "euler_zyx" else np.array([-2.0, pitch, 0.4])
        R = euler_to_matrix(e, kind)
        w = rng.normal(size=3)
        h = 1e-6
        num = (c.local(R, R @ so3.exp(h * w)) - c.local(R, R @ so3.exp(-h * w))) / (2 * h)
        np.testing.assert_allclose(
            num, euler_rate_map(e, kind) @ w, atol=1e-6 * (1 + 1 / np.cos(pitch))
        )


def test_euler_orders_are_a_permutation() -> None:
    rng = np.random.default_rng(3)
    zyx, rpy = _euler_conv("euler_zyx"), _euler_conv("euler_rpy")
    X = _pose(rng)
    assert lb.is_exactly_linear(zyx, rpy) and not lb.is_exactly_linear(zyx, "gtsam")
    P = np.eye(6)[[2, 1, 0, 3, 4, 5]]
    np.testing.assert_allclose(lb.tangent_map(X, zyx, rpy), P, atol=1e-12)
    S = _cov(rng, 6, 0.05)
    mc = monte_carlo_covariance(S, X, zyx, "gtsam", n=100_000, rng=rng)
    uns = lb.convert_covariance(S, X, zyx, "gtsam", method="unscented")
    np.testing.assert_allclose(uns, mc, atol=0.03 * np.abs(mc).max())


@pytest.mark.parametrize("kind", EULER)
def test_detect_distinguishes_the_euler_orders(kind: str) -> None:
    def retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:  # an MRPT/robot_localization style
        from scipy.spatial.transform import Rotation

        ypr = Rotation.from_matrix(X[:3, :3]).as_euler("ZYX")
        e = ypr if kind == "euler_zyx" else ypr[::-1]
        R = euler_to_matrix(e + d[3:], kind)
        Y = np.eye(4)
        Y[:3, :3], Y[:3, 3] = R, X[:3, 3] + d[:3]
        return Y

    got = lb.detect_convention(retract)
    assert (got.rotation, got.chart, got.order) == (kind, "so3xr3_world", "trans_first")


@pytest.mark.parametrize("kind", EULER)
def test_gimbal_lock_is_one_clear_error(kind: str) -> None:
    c = _euler_conv(kind)
    for pitch in (np.pi / 2, -np.pi / 2):
        e = np.array([0.3, pitch, 0.1])
        X = np.eye(4)
        X[:3, :3] = euler_to_matrix(e, kind)
        for call in (
            lambda X=X: c.retract(X, np.zeros(6)),
            lambda X=X: c.local(X, np.eye(4)),
            lambda X=X: c.to_canonical(X),
            lambda X=X: c.from_canonical(X),
            lambda X=X: lb.convert_covariance(np.eye(6), X, c, "gtsam"),
            lambda X=X: lb.tangent_map(X, "gtsam", c),
        ):
            with pytest.raises(ValueError, match=r"pitch = ±90°.*gimbal lock"):
                call()
        with pytest.raises(ValueError, match="gimbal lock"):
            euler_rate_map(e, kind)


def test_euler_is_refused_outside_so3_se3() -> None:
    with pytest.raises(ValueError, match="Euler-angle coordinates"):
        C.Convention("x", "right", "rot_first", "split_body", "euler_zyx", "xyzw", group="se23")


# ----------------------------------------------------------------------------- JPL storage
def _trawny_C(q: np.ndarray) -> np.ndarray:
    """Trawny & Roumeliotis eq. 62, written out: C(q̄) = (2q4² − 1)I − 2q4⌊q×⌋ + 2qqᵀ."""
    v, q4 = q[:3], q[3]
    return (2 * q4**2 - 1) * np.eye(3) - 2 * q4 * so3.hat(v) + 2 * np.outer(v, v)


def _trawny_L(q: np.ndarray) -> np.ndarray:
    """Trawny eq. 10: q̄ ⊗ p̄ = L(q̄) p̄, L = [[q4 I − ⌊q×⌋, q], [−qᵀ, q4]]."""
    L = np.zeros((4, 4))
    L[:3, :3] = q[3] * np.eye(3) - so3.hat(q[:3])
    L[:3, 3] = q[:3]
    L[3, :3] = -q[:3]
    L[3, 3] = q[3]
    return L


def _unit(rng: np.random.Generator, n: int = 1) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def test_jpl_matrix_is_trawny_and_the_transpose_of_hamilton() -> None:
    rng = np.random.default_rng(4)
    q = _unit(rng, 16)
    C_jpl = Q.to_matrix(q, order="jpl")
    np.testing.assert_allclose(C_jpl, np.stack([_trawny_C(x) for x in q]), atol=1e-14)
    np.testing.assert_allclose(C_jpl, np.swapaxes(Q.to_matrix(q, order="xyzw"), -1, -2))
    R = so3.exp(rng.normal(size=(16, 3)))
    qj = Q.from_matrix(R, order="jpl")
    np.testing.assert_allclose(Q.to_matrix(qj, order="jpl"), R, atol=1e-14)
    assert (qj[..., 3] >= 0).all()


def test_jpl_read_as_hamilton_is_the_inverse_rotation() -> None:
    R_ItoG = so3.exp([0.3, -1.1, 2.0])
    q_GtoI = Q.from_matrix(R_ItoG.T, order="jpl")  # OpenVINS stores JPL q_GtoI
    np.testing.assert_allclose(Q.to_matrix(q_GtoI, order="xyzw"), R_ItoG, atol=1e-14)
    np.testing.assert_allclose(Q.to_matrix(q_GtoI, order="jpl"), R_ItoG.T, atol=1e-14)
    assert not np.allclose(Q.to_matrix(q_GtoI, order="xyzw"), R_ItoG.T, atol=1e-3)


def test_jpl_product_is_trawnys() -> None:
    rng = np.random.default_rng(5)
    a, b = _unit(rng, 2)
    ab = Q.multiply(a, b, order="jpl")
    np.testing.assert_allclose(ab, _trawny_L(a) @ b, atol=1e-15)
    np.testing.assert_allclose(
        Q.to_matrix(ab, order="jpl"), Q.to_matrix(a, order="jpl") @ Q.to_matrix(b, order="jpl"),
        atol=1e-14,
    )  # fmt: skip


def test_non_unit_jpl_is_one_clear_error() -> None:
    with pytest.raises(ValueError, match=r"q: .*norm"):
        Q.to_matrix([[0, 0, 0, 1.0], [0.1, 0.2, 0.3, 1.0]], order="jpl")
    c = C.Convention("ov", "right", "rot_first", "so3xr3_world", "cayley", quat_order="jpl")
    assert c.quat_order == "jpl"


# ----------------------------------------------------------------------------- sources
def _cayley(r: np.ndarray) -> np.ndarray:
    """Hamilton (w, x, y, z) of normalize(1, r/2) as a matrix (VINS deltaQ, normalised)."""
    q = np.array([1.0, *(0.5 * r)])
    return Q.to_matrix(q / np.linalg.norm(q), order="wxyz")


def _openvins_update(R_ItoG, p, v, bg, ba, dx):  # type: ignore[no-untyped-def]
    """ov_type::IMU::update / JPLQuat::update, transcribed (JPL q_GtoI, Trawny's product)."""
    q = Q.from_matrix(R_ItoG.T, order="jpl")
    dq = np.array([*(0.5 * dx[:3]), 1.0])
    dq = dq / np.linalg.norm(dq)
    if dq[3] < 0:
        dq = -dq
    q2 = _trawny_L(dq) @ q
    return Q.to_matrix(q2, order="jpl").T, p + dx[3:6], v + dx[6:9], bg + dx[9:12], ba + dx[12:]


def _split(conv: C.Bundle, S: np.ndarray) -> tuple[np.ndarray, ...]:
    parts = conv.split(S)
    X = parts["nav"]
    return X[:3, :3], X[:3, 3], X[:3, 4], parts["b_a"], parts["b_g"]


def test_presets_equal_each_systems_update() -> None:
    rng = np.random.default_rng(6)
    S = _state(rng)
    R, p, v, ba, bg = _split(C.OPENVINS, S)
    for _ in range(5):
        d = rng.normal(size=15) * 0.3
        # OpenVINS: (θ, p, v, b_g, b_a)
        R2, p2, v2, bg2, ba2 = _openvins_update(R, p, v, bg, ba, d)
        got = _split(C.OPENVINS, C.OPENVINS.retract(S, d))
        for a, b in zip(got, (R2, p2, v2, ba2, bg2), strict=True):
            np.testing.assert_allclose(a, b, atol=1e-12)
        # VINS PoseLocalParameterization::Plus + SpeedBias: (p, θ, v, b_a, b_g)
        want = (R @ _cayley(d[3:6]), p + d[:3], v + d[6:9], ba + d[9:12], bg + d[12:])
        for a, b in zip(_split(C.VINS, C.VINS.retract(S, d)), want, strict=True):
            np.testing.assert_allclose(a, b, atol=1e-12)
        # Basalt incPose + applyInc: (p, θ, v, b_g, b_a), R' = Exp(θ)R
        want = (so3.exp(d[3:6]) @ R, p + d[:3], v + d[6:9], ba + d[12:], bg + d[9:12])
        for a, b in zip(_split(C.BASALT, C.BASALT.retract(S, d)), want, strict=True):
            np.testing.assert_allclose(a, b, atol=1e-12)
        # ORB-SLAM3 ImuCamPose::Update (twb += Rwb ut; Rwb = Rwb Exp(ur)), velocity/bias vertices
        want = (R @ so3.exp(d[:3]), p + R @ d[3:6], v + d[6:9], ba + d[12:], bg + d[9:12])
        for a, b in zip(_split(C.ORBSLAM3, C.ORBSLAM3.retract(S, d)), want, strict=True):
            np.testing.assert_allclose(a, b, atol=1e-12)


def test_gtsam_presets_equal_gtsam() -> None:
    rng = np.random.default_rng(7)
    S = _state(rng)
    R, p, v, ba, bg = _split(C.GTSAM_COMBINED, S)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    nav = gtsam.NavState(gtsam.Pose3(T), v)
    bias = gtsam.imuBias.ConstantBias(ba, bg)
    for _ in range(5):
        d = rng.normal(size=15) * 0.3
        n2 = nav.retract(d[:9])
        b2 = bias + gtsam.imuBias.ConstantBias(d[9:12], d[12:])  # vector() = (acc, gyro)
        want = (
            n2.attitude().matrix(),
            n2.position(),
            n2.velocity(),
            b2.accelerometer(),
            b2.gyroscope(),
        )
        for a, b in zip(
            _split(C.GTSAM_COMBINED, C.GTSAM_COMBINED.retract(S, d)), want, strict=True
        ):
            np.testing.assert_allclose(a, b, atol=1e-10)
        T2 = gtsam.Pose3(T).retract(d[:6])
        want = (T2.rotation().matrix(), T2.translation(), v + d[6:9], ba + d[9:12], bg + d[12:])
        for name in ("gtsam_imu_keys", "kimera"):
            conv = C.get(name)
            for a, b in zip(_split(conv, conv.retract(S, d)), want, strict=True):
                np.testing.assert_allclose(a, b, atol=1e-10)


def test_gtsam_imu_keys_is_what_marginals_gives() -> None:
    """A graph whose posterior is a Gaussian of known covariance in the key charts."""
    from gtsam.symbol_shorthand import B, V, X

    rng = np.random.default_rng(8)
    S = _state(rng)
    R, p, v, ba, bg = _split(C.GTSAM_IMU_KEYS, S)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    cov = _cov(rng, 15, 0.05)
    graph = gtsam.NonlinearFactorGraph()
    prior = gtsam.noiseModel.Gaussian.Covariance(cov)
    keys = [X(0), V(0), B(0)]

    def error(this: gtsam.CustomFactor, values: gtsam.Values, H: list | None) -> np.ndarray:
        d = np.concatenate(
            [
                gtsam.Pose3(T).localCoordinates(values.atPose3(X(0))),
                values.atVector(V(0)) - v,
                values.atConstantBias(B(0)).vector() - np.concatenate([ba, bg]),
            ]
        )
        if H is not None:
            J = numerical_jacobian(
                lambda dd: np.concatenate(
                    [gtsam.Pose3(T).localCoordinates(values.atPose3(X(0)).retract(dd[:6])),
                     dd[6:] + 0.0]
                ),
                np.zeros(15),
            )  # fmt: skip
            H[0], H[1], H[2] = J[:, :6], J[:, 6:9], J[:, 9:]
        return d

    graph.add(gtsam.CustomFactor(prior, keys, error))
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose3(T))
    values.insert(V(0), v)
    values.insert(B(0), gtsam.imuBias.ConstantBias(ba, bg))
    m = gtsam.Marginals(graph, values)
    got = m.jointMarginalCovariance(gtsam.KeyVector(keys)).fullMatrix()
    np.testing.assert_allclose(got, cov, rtol=1e-6, atol=1e-12)


# ----------------------------------------------------------------------------- conversions
@pytest.mark.parametrize("src,dst", list(itertools.permutations(STATES, 2)))
def test_monte_carlo_every_pair(src: str, dst: str) -> None:
    rng = np.random.default_rng(STATES.index(src) * 31 + STATES.index(dst))
    S = _state(rng)
    cov = _cov(rng, 15, 0.01)
    mc = monte_carlo_covariance(cov, S, src, dst, n=20_000, rng=rng)
    lin = lb.convert_covariance(cov, S, src, dst)
    Li = np.linalg.inv(np.linalg.cholesky(lin))
    # whitened by the linear answer: sampling error ≈ √(2/n) ≈ 0.01 per entry
    assert np.abs(Li @ mc @ Li.T - np.eye(15)).max() < 0.06
    uns = lb.convert_covariance(cov, S, src, dst, method="unscented")
    assert np.abs(Li @ uns @ Li.T - np.eye(15)).max() < 0.01


@pytest.mark.parametrize("src,dst", list(itertools.combinations(STATES, 2)))
def test_round_trips_are_the_identity(src: str, dst: str) -> None:
    rng = np.random.default_rng(9)
    S = np.stack([_state(rng) for _ in range(3)])
    cov = np.stack([_cov(rng, 15) for _ in range(3)])
    there = lb.convert_covariance(cov, S, src, dst)
    np.testing.assert_allclose(lb.convert_covariance(there, S, dst, src), cov, atol=1e-14)
    info = np.linalg.inv(cov)
    back = lb.convert_information(lb.convert_information(info, S, src, dst), S, dst, src)
    np.testing.assert_allclose(back, info, rtol=1e-9, atol=1e-9 * np.abs(info).max())
    d = rng.normal(size=(3, 15)) * 0.1
    e = lb.convert_tangent(d, S, src, dst)
    np.testing.assert_allclose(lb.convert_tangent(e, S, dst, src), d, atol=1e-12)
    np.testing.assert_allclose(
        lb.tangent_map(S, src, dst) @ lb.tangent_map(S, dst, src),
        np.broadcast_to(np.eye(15), (3, 15, 15)),
        atol=1e-12,
    )


@pytest.mark.parametrize(
    "src,dst", [("openvins", "gtsam_imu_keys"), ("vins", "gtsam_combined"), ("basalt", "orbslam3")]
)
def test_convert_jacobian_of_a_state_map(src: str, dst: str) -> None:
    """f(S) = S·G (block-diagonal product): its Jacobian converted equals the one measured."""
    rng = np.random.default_rng(10)
    S, G = _state(rng), _state(rng)
    a, b = C.get(src), C.get(dst)

    def f(Z: np.ndarray) -> np.ndarray:
        return np.asarray(Z @ G)

    J_a = numerical_jacobian(f, S, retract=a.retract, local=a.local, dim=15)
    J_b = numerical_jacobian(f, S, retract=b.retract, local=b.local, dim=15)
    got = lb.convert_jacobian(J_a, S, a, b, at_output=f(S))
    np.testing.assert_allclose(got, J_b, atol=2e-6 * np.abs(J_b).max())


def test_nine_dimensional_states_convert_to_each_other() -> None:
    rng = np.random.default_rng(11)
    X = C.OPENVINS.split(_state(rng))["nav"]
    navs = ["gtsam_navstate", "manif_se23", *(C.get(n).blocks[0][1] for n in STATES)]
    cov = _cov(rng, 9, 0.02)
    for a, b in itertools.permutations(navs[:4], 2):
        mc = monte_carlo_covariance(cov, X, a, b, n=20_000, rng=rng)
        uns = lb.convert_covariance(cov, X, a, b, method="unscented")
        Li = np.linalg.inv(np.linalg.cholesky(uns))
        assert np.abs(Li @ mc @ Li.T - np.eye(9)).max() < 0.06


def test_naive_reordering_is_wrong() -> None:
    """Reordering an OpenVINS covariance into GTSAM's order is not the conversion."""
    rng = np.random.default_rng(12)
    S = _state(rng)
    cov = _cov(rng, 15, 0.01)
    right = lb.convert_covariance(cov, S, "openvins", "gtsam_combined")
    perm = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 13, 14, 9, 10, 11]  # (θ, p, v, b_a, b_g)
    naive = cov[np.ix_(perm, perm)]
    assert np.abs(naive - right).max() > 0.1 * np.abs(right).max()
    # the bias blocks are only reordered
    np.testing.assert_allclose(naive[9:, 9:], right[9:, 9:], atol=1e-15)


def test_state_bad_input() -> None:
    rng = np.random.default_rng(13)
    S = _state(rng)
    X = C.OPENVINS.split(S)["nav"]
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 9, 9\)"):
        lb.convert_covariance(np.eye(15), X, "gtsam_navstate", "manif_se23")
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 15, 15\)"):
        lb.convert_covariance(np.eye(9), S, "openvins", "vins")
    with pytest.raises(ValueError, match=r"X: expected shape \(\.\.\., 13, 13\)"):
        lb.convert_covariance(np.eye(15), X, "openvins", "vins")
    with pytest.raises(ValueError, match="cannot be converted"):
        lb.convert_covariance(np.eye(15), S, "openvins", "gtsam_navstate")
    with pytest.raises(ValueError, match=r"d: expected shape \(\.\.\., 15\)"):
        C.VINS.retract(S, np.zeros(9))
    before = S.copy()
    lb.convert_covariance(np.eye(15) * 1e-4, S, "openvins", "vins", method="unscented")
    np.testing.assert_array_equal(S, before)


@pytest.mark.parametrize("fmt", ["table", "json", "markdown"])
@pytest.mark.parametrize("name", ["openvins", "gtsam_imu_keys"])
def test_cli_describes_a_state_preset(
    name: str, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from liebridge.cli import main

    assert main(["conventions", name, "--format", fmt]) == 0
    out = capsys.readouterr().out
    assert name in out and "b_g" in out


@given(
    e=st.tuples(st.floats(-3.1, 3.1), st.floats(-1.4, 1.4), st.floats(-3.1, 3.1)),
    d=st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.15), st.floats(-0.15, 0.15)),
)
@pytest.mark.parametrize("kind", EULER)
def test_euler_round_trip_hypothesis(kind: str, e: tuple[float, ...], d: tuple[float, ...]) -> None:
    c = _euler_conv(kind, "so3xr3_world")
    R = euler_to_matrix(np.array(e), kind)
    np.testing.assert_allclose(c.local(R, c.retract(R, np.array(d))), d, atol=1e-9)


def test_near_gimbal_lock_is_finite_and_exactly_there_is_an_error() -> None:
    c = _euler_conv("euler_zyx")
    for pitch in (np.pi / 2 - 1e-6, -np.pi / 2 + 1e-6):
        R = euler_to_matrix(np.array([0.3, pitch, 0.1]), "euler_zyx")
        M = c.to_canonical(R)
        assert np.isfinite(M).all() and np.abs(M).max() < 10
        assert np.isfinite(c.from_canonical(R)).all()  # large (1/cos pitch) but finite


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1.0, np.pi - 1e-6])
def test_state_round_trip_at_rotation_edge_cases(angle: float) -> None:
    rng = np.random.default_rng(14)
    S = _state(rng)
    for name in STATES:
        conv = C.get(name)
        d = np.zeros(15)
        rot = slice(3, 6) if name in ("vins", "basalt") else slice(0, 3)
        d[rot] = angle * np.array([0.0, 0.6, 0.8])
        np.testing.assert_allclose(conv.local(S, conv.retract(S, d)), d, atol=1e-7)


def test_cayley_chart_at_a_half_turn_is_one_clear_error() -> None:
    rng = np.random.default_rng(15)
    S = _state(rng)
    half_turn = np.zeros(15)
    half_turn[:3] = [np.pi, 0.0, 0.0]
    Y = C.ORBSLAM3.retract(S, half_turn)  # rotated by π: outside the Cayley chart
    with pytest.raises(ValueError, match="Cayley coordinates are undefined"):
        C.OPENVINS.local(S, Y)
