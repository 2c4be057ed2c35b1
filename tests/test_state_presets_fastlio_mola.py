"""FAST-LIO's 23-dimensional state (S² gravity) and MOLA's preintegration chart.

* S²: GTSAM's ``Unit3`` (the real library) and MTK's ``S2`` (``S2_Bx``, ``boxplus``,
  ``boxminus`` transcribed from IKFoM_toolkit/mtk/types/S2.hpp) against ``Sphere``; round trips,
  first-order maps and ``local_jacobian`` against central differences; Monte Carlo.
* ``fastlio``: ``state_ikfom``'s ``boxplus``/``boxminus`` transcribed component by component
  against the preset; Monte Carlo and round trips against a 23-dim bundle of GTSAM charts; the
  IMU marginal carried into every 15-dimensional preset, checked by Monte Carlo *in the
  23-dimensional state*.
* ``mola``: ``ImuPreintegrator::integrate_measurement`` re-implemented (state, covariance) and
  its covariance checked against Monte Carlo of noisy readings read in the preset's chart;
  conversions to the other 9-dimensional charts.
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
from liebridge.conventions.sphere import SPHERE_BASES
from liebridge.lie import quaternion as Q
from liebridge.lie import s2, so3

G_LEN = 98090 / 10000  # MTK::S2<double, 98090, 10000, 1>: length = den / num
STATES15 = [c.name for c in C.STATE_PRESETS_15]


def _cov(rng: np.random.Generator, n: int, scale: float = 0.01) -> np.ndarray:
    A = rng.normal(size=(n, n)) * scale
    return A @ A.T + np.eye(n) * scale**2


def _unit(rng: np.random.Generator, *shape: int) -> np.ndarray:
    x = rng.normal(size=(*shape, 3))
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _block(g: np.ndarray) -> np.ndarray:
    X = np.zeros((*g.shape[:-1], 4, 4))
    X[..., :, :] = np.eye(4)
    X[..., :3, 3] = g
    return X


# ----------------------------------------------------------------------------- MTK, transcribed
def _mtk_S2_Bx(vec: np.ndarray, L: float, typ: int) -> np.ndarray:
    """S2::S2_Bx, IKFoM_toolkit/mtk/types/S2.hpp, written out branch by branch."""
    tol = 1e-11  # MTK::tolerance<double>()
    v0, v1, v2 = vec
    res = np.zeros((3, 2))
    if typ == 3:
        if v2 + L > tol:
            res[:] = [
                [L - v0 * v0 / (L + v2), -v0 * v1 / (L + v2)],
                [-v0 * v1 / (L + v2), L - v1 * v1 / (L + v2)],
                [-v0, -v1],
            ]
            return res / L
    elif typ == 2:
        if v1 + L > tol:
            res[:] = [
                [L - v0 * v0 / (L + v1), -v0 * v2 / (L + v1)],
                [-v0, -v2],
                [-v0 * v2 / (L + v1), L - v2 * v2 / (L + v1)],
            ]
            return res / L
    else:
        if v0 + L > tol:
            res[:] = [
                [-v1, -v2],
                [L - v1 * v1 / (L + v0), -v2 * v1 / (L + v0)],
                [-v2 * v1 / (L + v0), L - v2 * v2 / (L + v0)],
            ]
            return res / L
    res[1, 1] = -1
    res[2, 0] = 1
    return res


def _mtk_exp_quat(v: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """SO3::exp: MTK::exp(res.vec(), v, scale/2): w = cos(|v|/2), xyz = sin(|v|/2)/|v| · v."""
    t = np.linalg.norm(v) * scale / 2
    sinc = np.sin(t) / t if t > 0 else 1.0
    return np.array([np.cos(t), *(sinc * scale / 2 * v)])  # (w, x, y, z), Eigen's quaternion


def _R(q_wxyz: np.ndarray) -> np.ndarray:
    return Q.to_matrix(q_wxyz, order="wxyz")


def _mtk_s2_boxplus(vec: np.ndarray, delta: np.ndarray, L: float, typ: int) -> np.ndarray:
    Bu = _mtk_S2_Bx(vec, L, typ) @ delta
    return _R(_mtk_exp_quat(Bu)) @ vec


def _mtk_s2_boxminus(vec: np.ndarray, other: np.ndarray, L: float, typ: int) -> np.ndarray:
    """``vec.boxminus(res, other)``: vec ⊟ other, in other's basis."""
    v_sin = np.linalg.norm(so3.hat(vec) @ other)
    v_cos = vec @ other
    theta = np.arctan2(v_sin, v_cos)
    if v_sin < 1e-11:
        return np.array([3.1415926, 0.0]) if abs(theta) > 1e-11 else np.zeros(2)
    Bx = _mtk_S2_Bx(other, L, typ)
    return np.asarray(theta / v_sin * Bx.T @ so3.hat(other) @ vec)


def _mtk_so3_log(q: np.ndarray) -> np.ndarray:
    """SO3::log: MTK::log(res, w, vec, 2, true) = 2·atan(|v|/w)/|v| · v."""
    w, v = q[0], q[1:]
    nv = max(np.linalg.norm(v), 1e-11)
    return np.asarray(2.0 / nv * np.arctan(nv / w) * v)


# ----------------------------------------------------------------------------- S² kernel
def test_unit3_basis_retract_local_are_gtsams() -> None:
    rng = np.random.default_rng(0)
    ns = np.concatenate(
        [_unit(rng, 30), np.eye(3), -np.eye(3), [[1, 1, 1] / np.sqrt(3), [0, -0.6, -0.8]]]
    )
    sph = C.Sphere(G_LEN, "gtsam")
    for n in ns:
        u = gtsam.Unit3(n)
        np.testing.assert_allclose(s2.unit3_basis(n), u.basis(), atol=1e-15)
        v = rng.normal(size=2) * 0.7
        np.testing.assert_allclose(
            sph.retract(G_LEN * n, v), G_LEN * u.retract(v).point3(), atol=1e-12
        )
        m = u.retract(v).point3()
        np.testing.assert_allclose(sph.local(G_LEN * n, G_LEN * m), u.localCoordinates(
            gtsam.Unit3(m)), atol=1e-9)  # fmt: skip


@pytest.mark.parametrize("typ", [1, 2, 3])
def test_mtk_basis_boxplus_boxminus_are_mtks(typ: int) -> None:
    rng = np.random.default_rng(typ)
    sph = C.Sphere(G_LEN, f"mtk_{'xyz'[typ - 1]}")
    axis = np.eye(3)[typ - 1]
    ns = np.concatenate([_unit(rng, 30), [axis, [0, 0.6, -0.8], [0.6, 0.0, -0.8]]])
    for n in ns:
        g = G_LEN * n
        np.testing.assert_allclose(
            s2.mtk_basis(n, typ, G_LEN), _mtk_S2_Bx(g, G_LEN, typ), atol=1e-15
        )
        for scale in (1e-12, 0.3, 2.5):
            d = rng.normal(size=2)
            d *= scale / np.linalg.norm(d)
            h = _mtk_s2_boxplus(g, d, G_LEN, typ)
            np.testing.assert_allclose(sph.retract(g, d), h, atol=1e-12)
            np.testing.assert_allclose(sph.local(g, h), _mtk_s2_boxminus(h, g, G_LEN, typ),
                                       atol=1e-12)  # fmt: skip
            np.testing.assert_allclose(sph.local(g, h), d, atol=1e-10)
    if typ == 1:  # MTK's fallback at −x is a tangent basis there
        g = -G_LEN * axis
        d = np.array([0.2, -0.1])
        np.testing.assert_allclose(sph.retract(g, d), _mtk_s2_boxplus(g, d, G_LEN, 1), atol=1e-12)
    else:  # ... and not for S2_typ 2, 3: one clear error instead of a wrong chart
        with pytest.raises(ValueError, match="not tangent to the sphere"):
            sph.retract(-G_LEN * axis, [0.1, 0.0])


def test_mtk_delta_is_an_axis_not_the_motion() -> None:
    """The tempting false identity: g + L·Bδ (normalised) is *not* MTK's boxplus."""
    n = np.array([0.1, 0.2, -0.97])
    n /= np.linalg.norm(n)
    g, d = G_LEN * n, np.array([0.05, 0.0])
    B = _mtk_S2_Bx(g, G_LEN, 1)
    false = g + G_LEN * B @ d
    false *= G_LEN / np.linalg.norm(false)
    got = C.Sphere(G_LEN, "mtk_x").retract(g, d)
    assert np.linalg.norm(got - false) > 0.3  # rotated by 90° in the tangent plane
    np.testing.assert_allclose(np.dot(got - g, B @ d), 0.0, atol=1e-3)


@pytest.mark.parametrize("basis", SPHERE_BASES)
def test_sphere_first_order_maps_and_jacobian(basis: str) -> None:
    rng = np.random.default_rng(4)
    sph = C.Sphere(G_LEN, basis)
    gt = C.Sphere(G_LEN, "gtsam")
    for n in _unit(rng, 6):
        if basis != "gtsam" and n["xyz".index(basis[-1])] < -0.9:
            n = -n  # away from MTK's fallback point
        X = _block(G_LEN * n)
        M = numerical_jacobian(lambda Z: Z, X, retract=sph._retract, local=gt._local, dim=2)
        np.testing.assert_allclose(sph._to_canonical(X), M, atol=1e-8)
        np.testing.assert_allclose(sph._from_canonical(X) @ sph._to_canonical(X), np.eye(2),
                                   atol=1e-12)  # fmt: skip
        Y = sph._retract(X, rng.normal(size=2) * 0.8)
        J = numerical_jacobian(
            lambda Z: Z, Y, retract=sph._retract, local=lambda _y, Z, X=X: sph._local(X, Z), dim=2
        )
        np.testing.assert_allclose(sph._local_jacobian(X, Y), J, atol=1e-7)
        np.testing.assert_allclose(sph._local_jacobian(X, X), np.eye(2), atol=1e-12)


def test_sphere_bad_input() -> None:
    sph = C.Sphere(G_LEN, "mtk_x")
    with pytest.raises(
        ValueError, match=r"g: not on the sphere of radius 9.809 at batch index \(1,\)"
    ):
        sph.retract([[0, 0, -G_LEN], [0, 0, -9.81]], np.zeros((2, 2)))
    with pytest.raises(ValueError, match="antipodal"):
        sph.local([0, 0, -G_LEN], [0, 0, G_LEN])
    with pytest.raises(ValueError, match="basis"):
        C.Sphere(1.0, "mtk_w")
    with pytest.raises(ValueError, match=r"w: not tangent at n .* batch index \(1,\)"):
        s2.exp([[0, 0, 1.0], [0, 0, 1.0]], [[0.1, 0, 0], [0.1, 0, 0.2]])
    with pytest.raises(ValueError, match=r"n: not a unit vector at batch index \(\)"):
        s2.log([0, 0, 2.0], [0, 0, 1.0])
    with pytest.raises(ValueError, match="length must be positive"):
        C.Sphere(-1.0)


# ----------------------------------------------------------------------------- FAST-LIO
#: A 23-dim state of the same blocks in GTSAM's charts (NavState, Pose3, Unit3).
GTSAM23 = C.Bundle.of(
    "gtsam23",
    [
        ("nav", C.GTSAM_NAVSTATE),
        ("b_a", C.Vector(3)),
        ("b_g", C.Vector(3)),
        ("T_imu_lidar", C.GTSAM),
        ("gravity", C.Sphere(G_LEN, "gtsam")),
    ],
)


def _fastlio_state(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """state_ikfom's members (FAST-LIO's own names)."""
    g = np.array([0.3, -0.2, -9.7])
    return {
        "pos": rng.normal(size=3) * 30.0,
        "rot": so3.exp(rng.normal(size=3)),
        "offset_R_L_I": so3.exp(rng.normal(size=3) * 0.1),
        "offset_T_L_I": np.array([0.04165, 0.02326, -0.0284]),  # Avia, use-ikfom.hpp
        "vel": rng.normal(size=3) * 3.0,
        "bg": rng.normal(size=3) * 0.01,
        "ba": rng.normal(size=3) * 0.1,
        "grav": G_LEN * g / np.linalg.norm(g),
    }


def _element(s: dict[str, np.ndarray]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = s["offset_R_L_I"], s["offset_T_L_I"]
    return C.FASTLIO.assemble(
        nav=C.nav_state(s["rot"], s["pos"], s["vel"]),
        b_a=s["ba"],
        b_g=s["bg"],
        T_imu_lidar=T,
        gravity=s["grav"],
    )


def _members(X: np.ndarray) -> dict[str, np.ndarray]:
    p = C.FASTLIO.split(X)
    return {
        "pos": p["nav"][:3, 3],
        "rot": p["nav"][:3, :3],
        "offset_R_L_I": p["T_imu_lidar"][:3, :3],
        "offset_T_L_I": p["T_imu_lidar"][:3, 3],
        "vel": p["nav"][:3, 4],
        "bg": p["b_g"],
        "ba": p["b_a"],
        "grav": p["gravity"],
    }


def _ikfom_boxplus(s: dict[str, np.ndarray], d: np.ndarray) -> dict[str, np.ndarray]:
    """state_ikfom::boxplus: each member's boxplus on its slice, in MTK_BUILD_MANIFOLD order."""
    return {
        "pos": s["pos"] + d[0:3],  # vect: +
        "rot": s["rot"] @ _R(_mtk_exp_quat(d[3:6])),  # SO3: *this * exp(vec)
        "offset_R_L_I": s["offset_R_L_I"] @ _R(_mtk_exp_quat(d[6:9])),
        "offset_T_L_I": s["offset_T_L_I"] + d[9:12],
        "vel": s["vel"] + d[12:15],
        "bg": s["bg"] + d[15:18],
        "ba": s["ba"] + d[18:21],
        "grav": _mtk_s2_boxplus(s["grav"], d[21:23], G_LEN, 1),
    }


def _ikfom_boxminus(y: dict[str, np.ndarray], x: dict[str, np.ndarray]) -> np.ndarray:
    """y ⊟ x, member by member (SO3: log(x.conjugate() * y))."""
    qx = Q.from_matrix(x["rot"], order="wxyz")
    qy = Q.from_matrix(y["rot"], order="wxyz")
    qxo = Q.from_matrix(x["offset_R_L_I"], order="wxyz")
    qyo = Q.from_matrix(y["offset_R_L_I"], order="wxyz")
    conj = np.array([1.0, -1, -1, -1])
    return np.concatenate(
        [
            y["pos"] - x["pos"],
            _mtk_so3_log(Q.multiply(qx * conj, qy, order="wxyz")),
            _mtk_so3_log(Q.multiply(qxo * conj, qyo, order="wxyz")),
            y["offset_T_L_I"] - x["offset_T_L_I"],
            y["vel"] - x["vel"],
            y["bg"] - x["bg"],
            y["ba"] - x["ba"],
            _mtk_s2_boxminus(y["grav"], x["grav"], G_LEN, 1),
        ]
    )


def test_fastlio_is_state_ikfoms_boxplus_and_boxminus() -> None:
    rng = np.random.default_rng(10)
    s = _fastlio_state(rng)
    X = _element(s)
    assert C.FASTLIO.dim() == 23
    for scale in (1e-12, 0.1, 0.5):
        d = rng.normal(size=23) * scale
        Y = C.FASTLIO.retract(X, d)
        want = _ikfom_boxplus(s, d)
        got = _members(Y)
        for k in want:
            np.testing.assert_allclose(got[k], want[k], atol=1e-12, err_msg=k)
        np.testing.assert_allclose(C.FASTLIO.local(X, Y), _ikfom_boxminus(want, s), atol=1e-12)
        np.testing.assert_allclose(C.FASTLIO.local(X, Y), d, atol=1e-10)


def test_fastlio_imu_is_fastlios_imu_part() -> None:
    rng = np.random.default_rng(11)
    X = _element(_fastlio_state(rng))
    keep = ["nav", "b_a", "b_g"]
    X15 = C.FASTLIO.sub_element(X, keep)
    d = rng.normal(size=23) * 0.3
    entries = [*range(6), *range(12, 21)]  # p, θ, v, bg, ba in FAST-LIO's P
    np.testing.assert_allclose(
        C.FASTLIO.sub_element(C.FASTLIO.retract(X, d), keep),
        C.FASTLIO_IMU.retract(X15, d[entries]),
        atol=1e-12,
    )
    P = _cov(rng, 23)
    np.testing.assert_allclose(C.FASTLIO.marginal(P, keep), P[np.ix_(entries, entries)])
    assert C.FASTLIO_IMU.dim() == 15
    assert lb.is_exactly_linear("fastlio_imu", "basalt")  # side and order only
    assert not lb.is_exactly_linear("fastlio_imu", "gtsam_imu_keys")  # split vs coupled SE(3)


@pytest.mark.parametrize("dst", STATES15)
def test_fastlio_marginal_into_every_15_dim_preset_monte_carlo(dst: str) -> None:
    """Sample in FAST-LIO's 23-dim chart, read the IMU part in ``dst``'s chart."""
    rng = np.random.default_rng(12 + STATES15.index(dst))
    X = _element(_fastlio_state(rng))
    P = _cov(rng, 23, 0.01)
    keep = ["nav", "b_a", "b_g"]
    X15 = C.FASTLIO.sub_element(X, keep)
    n = 20_000
    d = rng.multivariate_normal(np.zeros(23), P, size=n)
    Y15 = C.FASTLIO.sub_element(C.FASTLIO.retract(X, d), keep)
    mc = np.cov(C.get(dst).local(X15, Y15).T)
    lin = lb.convert_covariance(C.FASTLIO.marginal(P, keep), X15, "fastlio_imu", dst)
    Li = np.linalg.inv(np.linalg.cholesky(lin))
    assert np.abs(Li @ mc @ Li.T - np.eye(15)).max() < 0.06


def test_fastlio_round_trips_and_monte_carlo_against_gtsam_charts() -> None:
    rng = np.random.default_rng(13)
    S = np.stack([_element(_fastlio_state(rng)) for _ in range(3)])
    P = np.stack([_cov(rng, 23, 0.02) for _ in range(3)])
    assert lb.is_exactly_linear(C.FASTLIO, GTSAM23) is False  # world-frame position
    there = lb.convert_covariance(P, S, C.FASTLIO, GTSAM23)
    np.testing.assert_allclose(lb.convert_covariance(there, S, GTSAM23, C.FASTLIO), P,
                               atol=1e-14)  # fmt: skip
    info = np.linalg.inv(P)
    back = lb.convert_information(
        lb.convert_information(info, S, C.FASTLIO, GTSAM23), S, GTSAM23, C.FASTLIO
    )
    np.testing.assert_allclose(back, info, rtol=1e-9, atol=1e-9 * np.abs(info).max())
    d = rng.normal(size=(3, 23)) * 0.1
    e = lb.convert_tangent(d, S, C.FASTLIO, GTSAM23)
    np.testing.assert_allclose(lb.convert_tangent(e, S, GTSAM23, C.FASTLIO), d, atol=1e-12)
    np.testing.assert_allclose(
        lb.tangent_map(S, C.FASTLIO, GTSAM23) @ lb.tangent_map(S, GTSAM23, C.FASTLIO),
        np.broadcast_to(np.eye(23), (3, 23, 23)),
        atol=1e-12,
    )
    small = _cov(rng, 23, 0.003)  # linear: not exact (split vs coupled SE(3) extrinsic)
    for src, dst in itertools.permutations([C.FASTLIO, GTSAM23]):
        mc = monte_carlo_covariance(small, S[0], src, dst, n=20_000, rng=rng)
        lin = lb.convert_covariance(small, S[0], src, dst)
        Li = np.linalg.inv(np.linalg.cholesky(lin))
        assert np.abs(Li @ mc @ Li.T - np.eye(23)).max() < 0.06
        mc = monte_carlo_covariance(P[0], S[0], src, dst, n=20_000, rng=rng)  # σ_θ ≈ 0.1 rad
        uns = lb.convert_covariance(P[0], S[0], src, dst, method="unscented")
        Lu = np.linalg.inv(np.linalg.cholesky(uns))
        assert np.abs(Lu @ mc @ Lu.T - np.eye(23)).max() < 0.06


def test_fastlio_first_order_map_and_jacobian() -> None:
    rng = np.random.default_rng(14)
    X = _element(_fastlio_state(rng))
    M = numerical_jacobian(lambda Z: Z, X, retract=C.FASTLIO.retract, local=GTSAM23.local, dim=23)
    np.testing.assert_allclose(lb.tangent_map(X, C.FASTLIO, GTSAM23), M, atol=1e-7)
    Y = C.FASTLIO.retract(X, rng.normal(size=23) * 0.2)
    J = numerical_jacobian(
        lambda Z: Z, Y, retract=C.FASTLIO.retract, local=lambda _y, Z: C.FASTLIO.local(X, Z),
        dim=23,
    )  # fmt: skip
    np.testing.assert_allclose(C.FASTLIO.local_jacobian(X, Y), J, atol=1e-6)


def test_naive_reordering_of_fastlios_block_is_wrong() -> None:
    rng = np.random.default_rng(15)
    X = _element(_fastlio_state(rng))
    P = _cov(rng, 23, 0.02)
    X15 = C.FASTLIO.sub_element(X, ["nav", "b_a", "b_g"])
    P15 = C.FASTLIO.marginal(P, ["nav", "b_a", "b_g"])
    right = lb.convert_covariance(P15, X15, "fastlio_imu", "gtsam_combined")
    order = [3, 4, 5, 0, 1, 2, 12, 13, 14, 18, 19, 20, 15, 16, 17]  # (θ, p, v, ba, bg)
    naive = P[np.ix_(order, order)]
    assert np.abs(naive - right).max() > 0.1 * np.abs(right).max()
    # into OpenVINS (right rotation, world p and v, Cayley ≈ exp to second order) the
    # first-order map *is* the reordering: (θ, p, v, bg, ba)
    ov = lb.convert_covariance(P15, X15, "fastlio_imu", "openvins")
    order = [3, 4, 5, 0, 1, 2, 12, 13, 14, 15, 16, 17, 18, 19, 20]
    np.testing.assert_allclose(ov, P[np.ix_(order, order)], atol=1e-15)


def test_fastlio_bad_input() -> None:
    rng = np.random.default_rng(16)
    X = _element(_fastlio_state(rng))
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 23, 23\)"):
        lb.convert_covariance(np.eye(15), X, "fastlio", GTSAM23)
    with pytest.raises(ValueError, match="cannot be converted"):
        lb.convert_covariance(np.eye(23), X, "fastlio", "openvins")
    with pytest.raises(ValueError, match=r"gravity: not on the sphere of radius 9\.809"):
        s = _fastlio_state(rng)
        s["grav"] = np.array([0.0, 0.0, -9.81])
        _element(s)
    with pytest.raises(ValueError, match="keep must name distinct blocks"):
        C.FASTLIO.marginal(np.eye(23), ["nav", "bias"])
    with pytest.raises(ValueError, match=r"d: expected shape \(\.\.\., 23\)"):
        C.FASTLIO.retract(X, np.zeros(24))  # FAST-LIO's 24 rows are get_f's, not the state's


# ----------------------------------------------------------------------------- MOLA
def _mola_integrate(acc: np.ndarray, gyro: np.ndarray, dt: float, cov_g: np.ndarray,
                    cov_a: np.ndarray) -> tuple[np.ndarray, ...]:  # fmt: skip
    """ImuPreintegrator::integrate_measurement (zero bias), batched over leading dims of acc."""
    batch = acc.shape[:-2]
    dR = np.broadcast_to(np.eye(3), (*batch, 3, 3)).copy()
    dV = np.zeros((*batch, 3))
    dP = np.zeros((*batch, 3))
    cov = np.zeros((9, 9))
    for k in range(acc.shape[-2]):
        a, w = acc[..., k, :], gyro[..., k, :]
        phi = w * dt
        incR = so3.exp(phi)
        if not batch:  # the covariance of the nominal run only
            Jr = so3.jr(phi)
            A = np.eye(9)
            A[0:3, 0:3] = incR.T
            A[3:6, 0:3] = -dR @ so3.hat(a) * dt
            A[6:9, 0:3] = -0.5 * dR @ so3.hat(a) * dt * dt
            A[6:9, 3:6] = np.eye(3) * dt
            Bg = np.zeros((9, 3))
            Bg[0:3] = Jr * dt
            Ba = np.zeros((9, 3))
            Ba[3:6] = dR * dt
            Ba[6:9] = 0.5 * dR * dt * dt
            cov = A @ cov @ A.T + Bg @ (cov_g / dt) @ Bg.T + Ba @ (cov_a / dt) @ Ba.T
        Ra = np.einsum("...ij,...j->...i", dR, a)
        dP = dP + dV * dt + 0.5 * Ra * dt * dt
        dV = dV + Ra * dt
        dR = dR @ incR
    return dR, dV, dP, cov


def test_mola_retract_is_molas_perturbation() -> None:
    """(ΔR·Exp(δθ), Δv + δv, Δp + δp), d = (θ, v, p): as bias_corrected and the A matrix."""
    rng = np.random.default_rng(20)
    R, v, p = so3.exp(rng.normal(size=3)), rng.normal(size=3), rng.normal(size=3) * 10
    X = C.nav_state(R, p, v)
    for scale in (0.0, 1e-12, 0.4):
        d = rng.normal(size=9) * scale
        Y = C.MOLA.retract(X, d)
        np.testing.assert_allclose(Y[:3, :3], R @ so3.exp(d[0:3]), atol=1e-12)
        np.testing.assert_allclose(Y[:3, 4], v + d[3:6], atol=1e-12)
        np.testing.assert_allclose(Y[:3, 3], p + d[6:9], atol=1e-12)
        np.testing.assert_allclose(C.MOLA.local(X, Y), d, atol=1e-12)


def test_molas_propagated_covariance_is_in_the_mola_chart() -> None:
    """Monte Carlo of noisy readings integrated by MOLA's own update, read in ``mola``."""
    rng = np.random.default_rng(21)
    steps, dt = 40, 0.01
    t = np.arange(steps) * dt
    gyro = np.stack([0.8 + 0 * t, -0.5 + np.sin(5 * t), 1.2 * np.cos(3 * t)], axis=-1)
    acc = np.stack([2.0 + 0 * t, -1.0 + 3 * t, 9.81 + np.sin(7 * t)], axis=-1)
    cov_g, cov_a = np.eye(3) * 1e-3, np.eye(3) * 4e-2  # densities (rad²/s, m²/s³)
    dR, dV, dP, cov = _mola_integrate(acc, gyro, dt, cov_g, cov_a)
    X = C.nav_state(dR, dP, dV)
    n = 20_000
    ng = rng.normal(size=(n, steps, 3)) * np.sqrt(1e-3 / dt)
    na = rng.normal(size=(n, steps, 3)) * np.sqrt(4e-2 / dt)
    R2, V2, P2, _ = _mola_integrate(acc + na, gyro + ng, dt, cov_g, cov_a)
    Y = C.nav_state(R2, P2, V2)
    Li = np.linalg.inv(np.linalg.cholesky(cov))
    mc = np.cov(C.MOLA.local(X, Y).T)
    assert np.abs(Li @ mc @ Li.T - np.eye(9)).max() < 0.06
    # the tempting false reading: GTSAM's NavState chart (θ, p, v), body-frame increments
    wrong = np.cov(C.GTSAM_NAVSTATE.local(X, Y).T)
    assert np.abs(Li @ wrong @ Li.T - np.eye(9)).max() > 0.5


NAV9 = ["mola", "gtsam_navstate", "manif_se23"]


@pytest.mark.parametrize("src,dst", list(itertools.permutations(NAV9, 2)))
def test_mola_converts_to_the_other_9_dim_charts(src: str, dst: str) -> None:
    rng = np.random.default_rng(22 + NAV9.index(src) * 3 + NAV9.index(dst))
    X = C.nav_state(so3.exp(rng.normal(size=3)), rng.normal(size=3) * 30, rng.normal(size=3))
    cov = _cov(rng, 9, 0.02)
    mc = monte_carlo_covariance(cov, X, src, dst, n=20_000, rng=rng)
    lin = lb.convert_covariance(cov, X, src, dst)
    Li = np.linalg.inv(np.linalg.cholesky(lin))
    assert np.abs(Li @ mc @ Li.T - np.eye(9)).max() < 0.06
    np.testing.assert_allclose(lb.convert_covariance(lin, X, dst, src), cov, atol=1e-14)
    M = numerical_jacobian(lambda Z: Z, X, retract=C.get(src).retract, local=C.get(dst).local,
                           dim=9)  # fmt: skip
    np.testing.assert_allclose(lb.tangent_map(X, src, dst), M, atol=1e-6)


def test_mola_jacobian_and_15_dim_nav_blocks() -> None:
    rng = np.random.default_rng(23)
    X = C.nav_state(so3.exp(rng.normal(size=3)), rng.normal(size=3) * 30, rng.normal(size=3))
    Y = C.MOLA.retract(X, rng.normal(size=9) * 0.3)
    J = numerical_jacobian(
        lambda Z: Z, Y, retract=C.MOLA.retract, local=lambda _y, Z: C.MOLA.local(X, Z), dim=9
    )
    np.testing.assert_allclose(C.MOLA.local_jacobian(X, Y), J, atol=1e-6)
    cov = _cov(rng, 9)
    for name in STATES15:
        nav = C.get(name).blocks[0][1]
        back = lb.convert_covariance(lb.convert_covariance(cov, X, "mola", nav), X, nav, "mola")
        np.testing.assert_allclose(back, cov, atol=1e-14)
    with pytest.raises(ValueError, match=r"cov: expected shape \(\.\.\., 9, 9\)"):
        lb.convert_covariance(np.eye(15), X, "mola", "gtsam_navstate")


@pytest.mark.parametrize("name", ["mola", "fastlio", "fastlio_imu"])
def test_cli_describes_the_new_presets(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    from liebridge.cli import main

    for fmt in ("table", "json", "markdown"):
        assert main(["conventions", name, "--format", fmt]) == 0
        out = capsys.readouterr().out
        assert name in out and ("467fc53" in out or "1087a72" in out)


@pytest.mark.parametrize(
    "a,b",
    [
        ("mola", "gtsam_navstate"),
        ("mola", "manif_se23"),
        ("gtsam_imu_keys", "basalt"),
        ("gtsam_imu_keys", "gtsam_combined"),
        ("fastlio_imu", "orbslam3"),
        ("fastlio_imu", "kimera"),
        ("basalt", "orbslam3"),
    ],
)
def test_exactly_linear_is_measured_for_navigation_charts(a: str, b: str) -> None:
    """``is_exactly_linear`` of NavCharts follows their pose charts: exact vs linear tangents."""
    rng = np.random.default_rng(30)
    conv = C.get(a)
    if conv.dim() == 9:
        X = C.nav_state(so3.exp(rng.normal(size=3)), rng.normal(size=3) * 30, rng.normal(size=3))
    else:
        X = C.FASTLIO.sub_element(_element(_fastlio_state(rng)), ["nav", "b_a", "b_g"])
    d = rng.normal(size=(8, conv.dim())) * 0.5
    exact = lb.convert_tangent(d, X, a, b)
    first = lb.convert_tangent(d, X, a, b, exact=False)
    agree = np.allclose(exact, first, atol=1e-9)
    assert lb.is_exactly_linear(a, b) == agree
    assert lb.is_exactly_linear(C.GTSAM_IMU_KEYS.blocks[0][1], "gtsam_navstate") is False


@pytest.mark.parametrize("name", ["gtsam_navstate", "manif_se23", "gtsam_pose2", "mola"])
def test_markdown_of_a_group_preset_is_one_table(
    name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from liebridge.cli import main

    assert main(["conventions", name, "--format", "markdown"]) == 0
    out = capsys.readouterr().out
    assert f"| `{name}` |" in out and "- **source**:" in out and "**[[" not in out


def test_group_all_lists_the_whole_state_presets() -> None:
    from liebridge.cli.table import render

    for fmt in ("table", "markdown"):
        text = render(fmt, "all")
        for c in C.STATE_PRESETS:
            assert f"{c.name} ({c.dim()})" in text
        assert "fastlio (23)" in text and "mola (9)" in text and "openvins (15)" in text


@given(
    n=st.tuples(*(st.floats(-1.0, 1.0) for _ in range(3))).filter(
        lambda v: 0.1 < float(np.linalg.norm(v))
    ),
    d=st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)),
)
@pytest.mark.parametrize("basis", ["gtsam", "mtk_x"])
def test_sphere_round_trip_hypothesis(
    basis: str, n: tuple[float, ...], d: tuple[float, float]
) -> None:
    sph = C.Sphere(G_LEN, basis)
    g = G_LEN * np.array(n) / np.linalg.norm(n)
    if basis == "mtk_x" and g[0] < -0.999 * G_LEN:
        g = -g  # MTK's basis switches to its fallback at −x (continuous elsewhere)
    h = sph.retract(g, d)
    assert abs(np.linalg.norm(h) - G_LEN) < 1e-12
    np.testing.assert_allclose(sph.local(g, h), d, atol=1e-9)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-6, 1.0, np.pi - 1e-6])
def test_sphere_edge_angles_and_batches(angle: float) -> None:
    rng = np.random.default_rng(31)
    for basis in SPHERE_BASES:
        sph = C.Sphere(G_LEN, basis)
        g = G_LEN * np.array([0.3, -0.2, -0.93]) / np.linalg.norm([0.3, -0.2, -0.93])
        d = angle * np.array([0.6, 0.8])
        h = sph.retract(g, d)
        np.testing.assert_allclose(np.arccos(np.clip(h @ g / G_LEN**2, -1, 1)), angle, atol=1e-7)
        np.testing.assert_allclose(sph.local(g, h), d, atol=1e-6 if angle > 3 else 1e-12)
    sph = C.Sphere(G_LEN, "mtk_x")
    gs = G_LEN * _unit(rng, 2, 3)
    ds = rng.normal(size=(2, 3, 2))
    hs = sph.retract(gs, ds)
    assert hs.shape == (2, 3, 3)
    np.testing.assert_allclose(sph.retract(gs[1, 2], ds[1, 2]), hs[1, 2], atol=1e-15)
    np.testing.assert_allclose(sph.local(gs, hs), ds, atol=1e-9)


@pytest.mark.parametrize("name", STATES15)
def test_mola_monte_carlo_to_every_15_dim_presets_nav_chart(name: str) -> None:
    rng = np.random.default_rng(40 + STATES15.index(name))
    X = C.nav_state(so3.exp(rng.normal(size=3)), rng.normal(size=3) * 30, rng.normal(size=3))
    nav = C.get(name).blocks[0][1]
    cov = _cov(rng, 9, 0.02)
    for src, dst in ((C.MOLA, nav), (nav, C.MOLA)):
        mc = monte_carlo_covariance(cov, X, src, dst, n=20_000, rng=rng)
        uns = lb.convert_covariance(cov, X, src, dst, method="unscented")
        Li = np.linalg.inv(np.linalg.cholesky(uns))
        assert np.abs(Li @ mc @ Li.T - np.eye(9)).max() < 0.06
