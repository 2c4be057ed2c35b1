"""SE(3) kernel: agreement with GTSAM and Pinocchio, finite differences, identities, batching.

Canonical form is GTSAM's: ξ = (ω, v), rotation first, right perturbation ``X·Exp(ξ)``, true SE(3)
exponential. Pinocchio's motion vectors are (v, ω); ``P`` below swaps the two blocks (``P = P⁻¹``),
so ``pin.exp6(P ξ)`` is our ``exp(ξ)`` and a Pinocchio Jacobian ``J`` reads ``P J P`` in our order.

Tolerances. Translations go up to 30 m, and every quantity that carries a translation (the
translation of ``Exp``, the ``v`` part of ``Log``, the lower-left blocks of ``Ad`` and of the
Jacobians) is linear in it, so its rounding error grows with it. All bounds are therefore
``tol · scale`` with ``scale = max(1, ‖v‖, ‖t‖)`` — a relative tolerance for large translations
and an absolute one below 1 m:

* ``ORACLE_TOL = 1e-12`` against GTSAM / Pinocchio (measured ≤ 2e-15 · scale for GTSAM).
* Where GTSAM or Pinocchio are measurably less accurate (GTSAM's near-π Taylor polynomial for
  D(θ) enters ``Pose3.Logmap``, ``LogmapDerivative`` and ``slerp`` through ``V⁻¹ = J_l⁻¹``;
  Pinocchio's ``Jexp6``/``Jlog6`` lose up to 4e-5 · scale at θ ≈ 1.3e-4 to cancellation, and
  its ``log6`` up to 5e-11 near π), the measured allowances of
  ``_strategies.gtsam_near_pi_allowance`` / ``_strategies.pinocchio_allowance`` are added
  (times the scale), and ``test_jacobians_match_mpmath`` pins the kernel to 60-digit arithmetic
  at those angles; GTSAM stays at 1e-12 wherever Pinocchio needs an allowance.
* ``FD_TOL = 1e-8`` for central differences with step 1e-6: rounding ≈ ``eps_mach · scale / ε``
  ≈ 6e-9 at 30 m would be too close, so the bound is ``FD_TOL · scale`` (measured ≤ 2e-9 · scale).
* ``ID_TOL = 1e-12`` for identities between kernel outputs (products of a few 6×6 matrices with
  entries up to ~100: measured ≤ 5e-14 · scale).
"""

from __future__ import annotations

import math
import zlib

import _strategies as S
import gtsam
import mpmath
import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg
from hypothesis import given
from hypothesis import strategies as st

from liebridge.check import assert_jacobian, numerical_jacobian
from liebridge.lie import se3, so3

pytestmark = pytest.mark.filterwarnings("error")

ORACLE_TOL = 1e-12
FD_TOL = 1e-8
ID_TOL = 1e-12
PI = math.pi

#: (ω, v) ↔ (v, ω); its own inverse.
P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])


def _scale(*vectors: np.ndarray) -> float:
    return max([1.0, *(float(np.linalg.norm(x)) for x in vectors)])


def _theta(xi: np.ndarray) -> float:
    return float(np.linalg.norm(xi[:3]))


def _pin_exp(xi: np.ndarray) -> np.ndarray:
    return np.asarray(pin.exp6(P @ xi).homogeneous)


# name -> (kernel, [(oracle, fn, max angle, which allowance applies: "gtsam", a Pinocchio function
# name for _strategies.pinocchio_allowance, or "")])
SE3_ORACLES = {
    "exp": (
        se3.exp,
        [
            ("gtsam", lambda xi: gtsam.Pose3.Expmap(xi).matrix(), PI, ""),
            ("pinocchio", _pin_exp, PI, ""),
        ],
    ),
    "jr": (
        se3.jr,
        [
            ("gtsam", gtsam.Pose3.ExpmapDerivative, PI, ""),
            # pin.Jexp6 is the right Jacobian in (v, ω): see test_pinocchio_jexp6_is_right_jacobian
            ("pinocchio", lambda xi: P @ pin.Jexp6(P @ xi) @ P, PI, "Jexp6"),
        ],
    ),
    "jl": (
        se3.jl,
        [
            (
                "gtsam",
                lambda xi: gtsam.Pose3.Expmap(xi).AdjointMap() @ gtsam.Pose3.ExpmapDerivative(xi),
                PI,
                "",
            )
        ],
    ),
    "jr_inv": (
        se3.jr_inv,
        [
            ("gtsam", gtsam.Pose3.LogmapDerivative, PI, "gtsam"),
            # Jlog6(T) = J_r⁻¹(log T); log6 picks one of the two logs at π itself
            (
                "pinocchio",
                lambda xi: P @ pin.Jlog6(pin.SE3(_pin_exp(xi))) @ P,
                PI - 1e-12,
                "Jlog6",
            ),
        ],
    ),
    "ad": (se3.ad, [("gtsam", gtsam.Pose3.adjointMap, 4 * PI, "")]),
}


def _check_against_oracles(name: str, xi: np.ndarray) -> None:
    ours_fn, oracles = SE3_ORACLES[name]
    ours = ours_fn(xi)
    theta, scale = _theta(xi), _scale(xi[3:])
    for oracle, fn, max_angle, allowance in oracles:
        if theta > max_angle:
            continue
        tol = ORACLE_TOL
        if allowance == "gtsam":
            tol += S.gtsam_near_pi_allowance(theta)
        elif allowance:
            tol += S.pinocchio_allowance(allowance, theta)
        np.testing.assert_allclose(
            ours, fn(xi), rtol=0, atol=tol * scale, err_msg=f"{name} vs {oracle} at θ={theta!r}"
        )


def test_pinocchio_jexp6_is_right_jacobian_in_v_omega() -> None:
    # Establish what pin.Jexp6 is before trusting it as an oracle: central differences of
    # pin.exp6 in Pinocchio's own (v, ω) order through the right local map log6(Y0⁻¹ Y).
    rng = np.random.default_rng(1)
    for xi in S.random_twists(rng, (6,), max_norm=3.0):
        nu = P @ xi
        fd = numerical_jacobian(
            lambda x: pin.exp6(x).homogeneous,
            nu,
            out_local=lambda Y0, Y: pin.log6(np.linalg.inv(Y0) @ Y).vector,
        )
        left = numerical_jacobian(
            lambda x: pin.exp6(x).homogeneous,
            nu,
            out_local=lambda Y0, Y: pin.log6(Y @ np.linalg.inv(Y0)).vector,
        )
        J = pin.Jexp6(nu)
        assert_jacobian(J, fd, atol=FD_TOL * 10, rtol=0, name="pin.Jexp6")
        assert np.abs(J - left).max() > 1e-2  # not the left Jacobian


def _jl_mp(xi: np.ndarray) -> mpmath.matrix:
    """60-digit SE(3) left Jacobian ``[[J_l, 0], [Q, J_l]]`` (Barfoot's Q, rearranged to (ω, v))."""
    w = [mpmath.mpf(float(x)) for x in xi[:3]]
    u = [mpmath.mpf(float(x)) for x in xi[3:]]

    def hat(a: list[mpmath.mpf]) -> mpmath.matrix:
        return mpmath.matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])

    th = mpmath.sqrt(sum(x * x for x in w))
    W, U = hat(w), hat(u)
    b = (1 - mpmath.cos(th)) / th**2
    c1 = (th - mpmath.sin(th)) / th**3
    c2 = (th**2 + 2 * mpmath.cos(th) - 2) / (2 * th**4)
    c3 = (2 * th - 3 * mpmath.sin(th) + th * mpmath.cos(th)) / (2 * th**5)
    J = mpmath.eye(3) + b * W + c1 * W * W
    Qm = (
        U / 2
        + c1 * (W * U + U * W + W * U * W)
        + c2 * (W * W * U + U * W * W - 3 * W * U * W)
        + c3 * (W * U * W * W + W * W * U * W)
    )
    M = mpmath.zeros(6, 6)
    for i in range(3):
        for j in range(3):
            M[i, j] = M[i + 3, j + 3] = J[i, j]
            M[i + 3, j] = Qm[i, j]
    return M


@pytest.mark.parametrize(
    "theta", [1e-8, 1e-6, 1e-4, 1.26e-4, 1e-3, 1e-2, 0.3, 1.0, 3.0, PI - 4e-3, PI - 1e-3, PI - 1e-9]
)
def test_jacobians_match_mpmath(theta: float) -> None:
    # where GTSAM and Pinocchio disagree with each other, 60-digit arithmetic decides
    rng = np.random.default_rng(zlib.crc32(repr(theta).encode()))
    for u, v in zip(S.random_unit(rng, (3,)), S.random_twists(rng, (3,))[:, 3:], strict=True):
        xi = np.concatenate([theta * u, v])
        with mpmath.workdps(60):
            M = _jl_mp(-xi)  # J_r(ξ) = J_l(−ξ)
            jr_ref = np.array(M.tolist(), dtype=np.float64)
            jr_inv_ref = np.array((M**-1).tolist(), dtype=np.float64)
        tol = ORACLE_TOL * _scale(v)
        np.testing.assert_allclose(se3.jr(xi), jr_ref, rtol=0, atol=tol)
        np.testing.assert_allclose(se3.jr_inv(xi), jr_inv_ref, rtol=0, atol=tol)


@pytest.mark.parametrize("angle", S.EDGE_ANGLES)
@pytest.mark.parametrize("name", sorted(SE3_ORACLES))
def test_matches_gtsam_and_pinocchio_at_edge_angles(name: str, angle: float) -> None:
    rng = np.random.default_rng(zlib.crc32(f"{name}{angle!r}".encode()))
    v = S.random_twists(rng, (4,))[:, 3:]
    for u, vk in zip(S.random_unit(rng, (4,)), v, strict=True):
        _check_against_oracles(name, np.concatenate([angle * u, vk]))


@pytest.mark.parametrize("name", sorted(SE3_ORACLES))
@given(xi=S.twists())
def test_matches_gtsam_and_pinocchio_random(name: str, xi: np.ndarray) -> None:
    _check_against_oracles(name, xi)


@given(T=S.poses())
def test_adjoint_matches_gtsam(T: np.ndarray) -> None:
    np.testing.assert_allclose(
        se3.adjoint(T), gtsam.Pose3(T).AdjointMap(), rtol=0, atol=ORACLE_TOL * _scale(T[:3, 3])
    )


# --------------------------------------------------------------------------- log


def _assert_log_matches(ours: np.ndarray, ref: np.ndarray, T: np.ndarray, what: str) -> None:
    theta, scale = _theta(ref), _scale(T[:3, 3], ref[3:])
    tol = ORACLE_TOL * scale
    if PI - theta < 1e-14:
        # both (πu, V(πu)⁻¹t) and (−πu, V(−πu)⁻¹t) are logarithms: compare the angle, the axis up
        # to sign, and that each really is a logarithm of T
        assert abs(_theta(ours) - PI) < ORACLE_TOL, what
        err = min(np.abs(ours[:3] - ref[:3]).max(), np.abs(ours[:3] + ref[:3]).max())
        assert err < ORACLE_TOL, f"{what}: ±axis differ by {err}"
        np.testing.assert_allclose(se3.exp(ref), T, rtol=0, atol=tol, err_msg=what)
    else:
        if "gtsam" in what:
            tol += S.gtsam_near_pi_allowance(theta) * scale
        else:
            tol += S.pinocchio_allowance("log6", theta) * scale
        np.testing.assert_allclose(ours, ref, rtol=0, atol=tol, err_msg=what)
    np.testing.assert_allclose(se3.exp(ours), T, rtol=0, atol=ORACLE_TOL * scale, err_msg=what)


def _check_log(T: np.ndarray) -> None:
    ours = se3.log(T)
    _assert_log_matches(ours, gtsam.Pose3.Logmap(gtsam.Pose3(T)), T, "log vs gtsam")
    _assert_log_matches(ours, P @ pin.log6(pin.SE3(T)).vector, T, "log vs pinocchio")


@pytest.mark.parametrize("angle", S.EDGE_ANGLES)
def test_log_matches_gtsam_and_pinocchio_at_edge_angles(angle: float) -> None:
    rng = np.random.default_rng(zlib.crc32(repr(angle).encode()))
    R = S.rotation_from_rotvec(angle * S.random_unit(rng, (4,)))
    for T in S.assemble(R, S.random_twists(rng, (4,))[:, 3:]):
        _check_log(T)


@pytest.mark.parametrize("R", list(S.pi_rotations()), ids=lambda R: str(np.round(np.diag(R), 2)))
def test_log_at_exactly_pi(R: np.ndarray) -> None:
    for t in ([0.0, 0.0, 0.0], [1.0, -2.0, 3.0], [30.0, 0.0, 0.0]):
        T = S.assemble(R, t)
        _check_log(T)
        assert np.isfinite(se3.log(T)).all()


@given(T=S.poses())
def test_log_matches_gtsam_and_pinocchio_random(T: np.ndarray) -> None:
    _check_log(T)


@given(xi=S.twists(max_angle=PI - 1e-9))
def test_log_exp_roundtrip(xi: np.ndarray) -> None:
    np.testing.assert_allclose(se3.log(se3.exp(xi)), xi, rtol=0, atol=ORACLE_TOL * _scale(xi[3:]))


@given(xi=S.twists())
def test_exp_is_the_matrix_exponential(xi: np.ndarray) -> None:
    # the true SE(3) exponential: Exp(ξ) = expm(hat(ξ)), independent of any closed form
    np.testing.assert_allclose(
        se3.exp(xi), scipy.linalg.expm(se3.hat(xi)), rtol=0, atol=ORACLE_TOL * _scale(xi[3:])
    )


# --------------------------------------------------------------------------- Jacobians


# --------------------------------------------------------------------------- adjoints


@given(T1=S.poses(), T2=S.poses())
def test_adjoint_is_a_homomorphism(T1: np.ndarray, T2: np.ndarray) -> None:
    tol = ID_TOL * _scale(T1[:3, 3]) * _scale(T2[:3, 3])
    np.testing.assert_allclose(
        se3.adjoint(T1 @ T2), se3.adjoint(T1) @ se3.adjoint(T2), rtol=0, atol=tol
    )
    np.testing.assert_allclose(
        se3.adjoint(se3.inverse(T1)), np.linalg.inv(se3.adjoint(T1)), rtol=0, atol=tol
    )


@given(xi=S.twists())
def test_ad_is_the_derivative_of_adjoint(xi: np.ndarray) -> None:
    # d/ds Ad(Exp(s ξ)) at s = 0, central differences in s; truncation h²/6·‖ad_ξ‖³ ≤ 1e-9 and
    # rounding eps_mach·‖Ad‖/h ≈ 1e-8 at 30 m, so 1e-7 relative to the scale
    fd = numerical_jacobian(lambda s: se3.adjoint(se3.exp(s * xi)), np.zeros(1))[..., 0]
    np.testing.assert_allclose(se3.ad(xi), fd, rtol=0, atol=1e-7 * _scale(xi[3:]))
    # and ad_ξ η is the Lie bracket [hat ξ, hat η]
    eta = np.arange(1.0, 7.0)
    X, Y = se3.hat(xi), se3.hat(eta)
    np.testing.assert_allclose(
        se3.hat(se3.ad(xi) @ eta), X @ Y - Y @ X, rtol=0, atol=ID_TOL * _scale(xi[3:])
    )


# --------------------------------------------------------------------------- group operations


@given(T1=S.poses(), T2=S.poses(), p=S.translations())
def test_compose_inverse_act_match_gtsam(T1: np.ndarray, T2: np.ndarray, p: np.ndarray) -> None:
    tol = ORACLE_TOL * _scale(T1[:3, 3]) * _scale(T2[:3, 3], p)
    g1, g2 = gtsam.Pose3(T1), gtsam.Pose3(T2)
    np.testing.assert_allclose(se3.compose(T1, T2), g1.compose(g2).matrix(), rtol=0, atol=tol)
    np.testing.assert_allclose(se3.inverse(T1), g1.inverse().matrix(), rtol=0, atol=tol)
    np.testing.assert_allclose(se3.act(T1, p), g1.transformFrom(p), rtol=0, atol=tol)
    np.testing.assert_allclose(se3.compose(T1, se3.inverse(T1)), np.eye(4), rtol=0, atol=tol)


@given(xi=S.twists(), p=S.translations())
def test_hat_vee_match_gtsam(xi: np.ndarray, p: np.ndarray) -> None:
    np.testing.assert_array_equal(se3.hat(xi), gtsam.Pose3.Hat(xi))
    np.testing.assert_array_equal(se3.vee(se3.hat(xi)), xi)
    np.testing.assert_array_equal(gtsam.Pose3.Vee(se3.hat(xi)), xi)
    # hat(ξ) acting on a homogeneous point is ω × p + v
    np.testing.assert_allclose(
        (se3.hat(xi) @ np.append(p, 1.0))[:3],
        np.cross(xi[:3], p) + xi[3:],
        rtol=0,
        atol=ID_TOL * _scale(xi[3:], p),
    )


@given(T0=S.poses(), xi=S.twists(max_angle=PI - 1e-3), tau=st.floats(0.0, 1.0))
def test_interpolate(T0: np.ndarray, xi: np.ndarray, tau: float) -> None:
    T1 = T0 @ se3.exp(xi)
    tol = ORACLE_TOL * _scale(T0[:3, 3]) * _scale(xi[3:])
    np.testing.assert_allclose(se3.interpolate(T0, T1, 0.0), T0, rtol=0, atol=tol)
    np.testing.assert_allclose(se3.interpolate(T0, T1, 1.0), T1, rtol=0, atol=tol)
    # the midpoint M is halfway along the screw: T0·(T0⁻¹M)² = T1
    M = se3.interpolate(T0, T1, 0.5)
    half = se3.inverse(T0) @ M
    np.testing.assert_allclose(T0 @ half @ half, T1, rtol=0, atol=tol)
    # GTSAM's Pose3.slerp is the same geodesic (through Pose3.Logmap, hence the near-π allowance)
    g = gtsam.Pose3(T0).slerp(tau, gtsam.Pose3(T1)).matrix()
    g_tol = tol + S.gtsam_near_pi_allowance(_theta(xi)) * _scale(T0[:3, 3]) * _scale(xi[3:])
    np.testing.assert_allclose(se3.interpolate(T0, T1, tau), g, rtol=0, atol=g_tol)


def test_interpolate_broadcasts_tau() -> None:
    rng = np.random.default_rng(4)
    T0, T1 = S.random_poses(rng, (2,))
    taus = np.linspace(0.0, 1.0, 7)
    out = se3.interpolate(T0, T1, taus)
    assert out.shape == (7, 4, 4)
    for k, tau in enumerate(taus):
        np.testing.assert_allclose(out[k], se3.interpolate(T0, T1, tau), rtol=0, atol=1e-13)


def test_compose_broadcasts() -> None:
    rng = np.random.default_rng(2)
    A = S.random_poses(rng, (5,))
    B = S.random_poses(rng)
    out = se3.compose(A, B)
    assert out.shape == (5, 4, 4)
    for k in range(5):
        np.testing.assert_allclose(out[k], A[k] @ B, rtol=0, atol=1e-13)


# --------------------------------------------------------------------------- no NaN anywhere


def test_no_nan_at_any_angle() -> None:
    rng = np.random.default_rng(9)
    th = np.concatenate([np.linspace(0.0, PI, 1001), np.asarray(S.EDGE_ANGLES)])
    w = th[:, None] * S.random_unit(rng, th.shape)
    w = np.concatenate([w, PI * np.asarray(S.PI_AXES), so3.log(S.pi_rotations())])
    xi = np.concatenate([w, S.random_twists(rng, (len(w),))[:, 3:]], axis=-1)
    Rs = np.concatenate([so3.exp(w), S.pi_rotations()])
    T = S.assemble(Rs, S.random_twists(rng, (len(Rs),))[:, 3:])
    for name, out in [
        ("exp", se3.exp(xi)),
        ("log", se3.log(T)),
        ("jr", se3.jr(xi)),
        ("jl", se3.jl(xi)),
        ("jr_inv", se3.jr_inv(xi)),
        ("jl_inv", se3.jl_inv(xi)),
        ("jr_inv(log)", se3.jr_inv(se3.log(T))),
        ("interpolate", se3.interpolate(np.eye(4), T, 0.5)),
    ]:
        assert np.isfinite(out).all(), name
    scale = np.maximum(1.0, np.linalg.norm(T[:, :3, 3], axis=-1))[:, None, None]
    assert (np.abs(se3.exp(se3.log(T)) - T) <= ORACLE_TOL * scale).all()


# --------------------------------------------------------------------------- batching, mutation


def _measure(n_random: int = 2000) -> None:  # pragma: no cover - a report, not a test
    """Print the max errors of the kernel against GTSAM and Pinocchio (``python <this file>``).

    Over every edge angle × 20 axes and ``n_random`` uniform angles in [0, π], translations up to
    30 m; SE(3) errors are divided by ``max(1, ‖v‖)``. θ = π is left out of the log comparisons
    (two valid logs). Two columns: the max over all inputs, and the max over the inputs where no
    documented allowance (``_strategies.gtsam_near_pi_allowance`` / ``pinocchio_allowance``)
    applies.
    """
    rng = np.random.default_rng(0)
    w = np.concatenate([S.edge_rotvecs(rng, 20), S.random_rotvecs(rng, (n_random,))])
    v = S.random_twists(rng, (len(w),))[:, 3:]
    worst: dict[str, list[float]] = {}

    def put(key: str, err: float, allowance: float = 0.0) -> None:
        row = worst.setdefault(key, [0.0, 0.0])
        row[0] = max(row[0], float(err))
        if allowance == 0.0:
            row[1] = max(row[1], float(err))

    for wk, vk in zip(w, v, strict=True):
        th, s, xi = float(np.linalg.norm(wk)), _scale(vk), np.concatenate([wk, vk])
        R, T = so3.exp(wk), se3.exp(xi)
        g_pi = S.gtsam_near_pi_allowance(th)
        put("so3.exp    gtsam", np.abs(R - gtsam.Rot3.Expmap(wk).matrix()).max())
        put("so3.exp    pin  ", np.abs(R - pin.exp3(wk)).max())
        put("so3.jr     gtsam", np.abs(so3.jr(wk) - gtsam.Rot3.ExpmapDerivative(wk)).max())
        put("so3.jr     pin  ", np.abs(so3.jr(wk) - pin.Jexp3(wk)).max())
        err = np.abs(so3.jr_inv(wk) - gtsam.Rot3.LogmapDerivative(wk)).max()
        put("so3.jr_inv gtsam", err, g_pi)
        put("se3.exp    gtsam", np.abs(T - gtsam.Pose3.Expmap(xi).matrix()).max() / s)
        put("se3.exp    pin  ", np.abs(T - _pin_exp(xi)).max() / s)
        put("se3.jr     gtsam", np.abs(se3.jr(xi) - gtsam.Pose3.ExpmapDerivative(xi)).max() / s)
        err = np.abs(se3.jr(xi) - P @ pin.Jexp6(P @ xi) @ P).max() / s
        put("se3.jr     pin  ", err, S.pinocchio_allowance("Jexp6", th))
        err = np.abs(se3.jr_inv(xi) - gtsam.Pose3.LogmapDerivative(xi)).max() / s
        put("se3.jr_inv gtsam", err, g_pi)
        put("se3.Ad     gtsam", np.abs(se3.adjoint(T) - gtsam.Pose3(T).AdjointMap()).max() / s)
        put("se3.ad     gtsam", np.abs(se3.ad(xi) - gtsam.Pose3.adjointMap(xi)).max() / s)
        if th < PI - 1e-13:
            put("so3.log    gtsam", np.abs(so3.log(R) - gtsam.Rot3.Logmap(gtsam.Rot3(R))).max())
            err = np.abs(so3.log(R) - pin.log3(R)).max()
            put("so3.log    pin  ", err, S.pinocchio_allowance("log3", th))
            err = np.abs(so3.jr_inv(wk) - pin.Jlog3(R)).max()
            put("so3.jr_inv pin  ", err, S.pinocchio_allowance("Jlog3", th))
            err = np.abs(se3.log(T) - gtsam.Pose3.Logmap(gtsam.Pose3(T))).max() / s
            put("se3.log    gtsam", err, g_pi)
            err = np.abs(se3.log(T) - P @ pin.log6(pin.SE3(T)).vector).max() / s
            put("se3.log    pin  ", err, S.pinocchio_allowance("log6", th))
            err = np.abs(se3.jr_inv(xi) - P @ pin.Jlog6(pin.SE3(T)) @ P).max() / s
            put("se3.jr_inv pin  ", err, S.pinocchio_allowance("Jlog6", th))
    print("function   oracle  max err   max err without allowance")
    for key in sorted(worst):
        print(f"{key}  {worst[key][0]:.2e}  {worst[key][1]:.2e}")


if __name__ == "__main__":  # pragma: no cover
    _measure()
