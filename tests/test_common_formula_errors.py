"""Regression tests for the errors E1–E6 of ``docs/common-formula-errors.md``.

One test per erratum. Each shows that the corrected formula matches central finite differences
through the stated retraction (or the installed GTSAM) *and* that the wrong formula does
not, so implementing the wrong version makes the test fail.

Tolerances: ``FD_TOL = 1e-7`` for central differences (step 1e-6; rounding ≈ eps_mach·|f|/ε ≈ 1e-9
for the O(10) quantities here, truncation ≈ ε²·|f'''| ≈ 1e-11), ``TOL = 1e-12`` for exact
identities, and ``WRONG = 1e-2``: the wrong formulas are off by O(1) at the generic points used,
far above either tolerance.
"""

from __future__ import annotations

from collections.abc import Callable

import _strategies as S
import gtsam
import numpy as np
import pytest

from liebridge.check import assert_jacobian, numerical_jacobian
from liebridge.lie import se3, so3

pytestmark = pytest.mark.filterwarnings("error")

FD_TOL = 1e-7
TOL = 1e-12
WRONG = 1e-2

#: (ω, v) ↔ (v, ω) = (ρ, ω); its own inverse.
P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
I3 = np.eye(3)
Z3 = np.zeros((3, 3))


def _poses(seed: int, n: int = 4, max_norm: float = 5.0) -> np.ndarray:
    return S.random_poses(np.random.default_rng(seed), (n,), max_norm=max_norm)


def _assert_wrong(wrong: np.ndarray, truth: np.ndarray, what: str) -> None:
    diff = float(np.abs(np.asarray(wrong) - np.asarray(truth)).max())
    assert diff > WRONG, f"the wrong {what} agrees with the truth (diff {diff:.3g})"


def _right(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return X @ se3.exp(d)


def _left(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return se3.exp(d) @ X


# --------------------------------------------------------------------------- erratum 1


def test_erratum_1_gtsam_retract_is_right_side_rotation_first() -> None:
    """§6.4/§8.3 claim GTSAM retracts on the left, ``Exp(ξ)·X``; it is ``X·Exp(ξ)``, ξ = (ω, v)."""
    rng = np.random.default_rng(101)  # not _poses' seed: ξ must not share R's axis
    for X, xi in zip(_poses(1), S.random_twists(rng, (4,), max_norm=5.0), strict=True):
        Y = gtsam.Pose3(X).retract(xi).matrix()
        scale = 1 + np.abs(X).max() + np.abs(xi).max()
        np.testing.assert_allclose(Y, X @ se3.exp(xi), rtol=0, atol=TOL * scale)
        _assert_wrong(Y, se3.exp(xi) @ X, "left retraction Exp(ξ)·X")
        _assert_wrong(Y, X @ se3.exp(P @ xi), "(v, ω) order")
        # localCoordinates is the matching right chart Log(X⁻¹ Y)
        np.testing.assert_allclose(
            gtsam.Pose3(X).localCoordinates(gtsam.Pose3(Y)), xi, rtol=0, atol=TOL * scale
        )
        # the same for Rot3
        R, w = X[:3, :3], xi[:3]
        Rr = gtsam.Rot3(R).retract(w).matrix()
        np.testing.assert_allclose(Rr, R @ so3.exp(w), rtol=0, atol=TOL)
        _assert_wrong(Rr, so3.exp(w) @ R, "left Rot3 retraction")

    # finite differences: through the right chart the derivative of GTSAM's retract at 0 is I;
    # through a left chart it would be I as well only if Ad_X = I
    X = _poses(2, 1)[0]

    def gtsam_retract(T: np.ndarray, d: np.ndarray) -> np.ndarray:
        return gtsam.Pose3(T).retract(d).matrix()

    def ident(T: np.ndarray) -> np.ndarray:
        return T

    J_right = numerical_jacobian(
        ident, X, retract=gtsam_retract, local=lambda Y0, Y: se3.log(se3.inverse(Y0) @ Y)
    )
    J_left = numerical_jacobian(
        ident, X, retract=gtsam_retract, local=lambda Y0, Y: se3.log(Y @ se3.inverse(Y0))
    )
    assert_jacobian(J_right, np.eye(6), atol=FD_TOL, rtol=0, name="d local_right(retract)")
    _assert_wrong(J_left, np.eye(6), "left chart")
    # rotation first: the first three coordinates rotate (the translation stays put)
    Yw = gtsam.Pose3(X).retract(np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])).matrix()
    np.testing.assert_allclose(Yw[:3, 3], X[:3, 3], rtol=0, atol=TOL * 10)


# --------------------------------------------------------------------------- erratum 2


def test_erratum_2_rotated_point_jacobians_not_swapped() -> None:
    """§7.1 swaps them: right ``R·Exp(δ)``: ``−R·hat(p)``; left ``Exp(δ)·R``: ``−hat(R·p)``."""
    rng = np.random.default_rng(2)
    Rs = S.random_rotations(rng, (4,))
    ps = rng.uniform(-5.0, 5.0, size=(4, 3))
    for R, p in zip(Rs, ps, strict=True):
        right_fd = numerical_jacobian(lambda d, R=R, p=p: R @ so3.exp(d) @ p, np.zeros(3))
        left_fd = numerical_jacobian(lambda d, R=R, p=p: so3.exp(d) @ R @ p, np.zeros(3))
        right, left = -R @ so3.hat(p), -so3.hat(R @ p)
        assert_jacobian(right, right_fd, atol=FD_TOL, rtol=0, name="right")
        assert_jacobian(left, left_fd, atol=FD_TOL, rtol=0, name="left")
        # the swapped pair
        _assert_wrong(-so3.hat(R @ p), right_fd, "right Jacobian −hat(R p)")
        _assert_wrong(-R @ so3.hat(p), left_fd, "left Jacobian −R hat(p)")


# --------------------------------------------------------------------------- erratum 3


def test_erratum_3_se3_point_jacobian_columns_are_rotation_first() -> None:
    """§7.2/§9.1: ``R[−hat(p), I]``, ``[−hat(T p), I]`` are in (ω, v), not the declared (ρ, ω)."""
    rng = np.random.default_rng(103)
    for T, p in zip(_poses(3), rng.uniform(-5.0, 5.0, size=(4, 3)), strict=True):
        R = T[:3, :3]
        Tp = se3.act(T, p)
        right_wv = numerical_jacobian(lambda d, T=T, p=p: se3.act(T @ se3.exp(d), p), np.zeros(6))
        left_wv = numerical_jacobian(lambda d, T=T, p=p: se3.act(se3.exp(d) @ T, p), np.zeros(6))
        right_vw = numerical_jacobian(
            lambda d, T=T, p=p: se3.act(T @ se3.exp(P @ d), p), np.zeros(6)
        )
        left_vw = numerical_jacobian(
            lambda d, T=T, p=p: se3.act(se3.exp(P @ d) @ T, p), np.zeros(6)
        )
        right = R @ np.hstack([-so3.hat(p), I3])
        left = np.hstack([-so3.hat(Tp), I3])
        assert_jacobian(right, right_wv, atol=FD_TOL, rtol=0, name="right, (ω, v)")
        assert_jacobian(left, left_wv, atol=FD_TOL, rtol=0, name="left, (ω, v)")
        # in the (ρ, ω) order the note declares, the blocks are the other way round
        assert_jacobian(R @ np.hstack([I3, -so3.hat(p)]), right_vw, atol=FD_TOL, rtol=0)
        assert_jacobian(np.hstack([I3, -so3.hat(Tp)]), left_vw, atol=FD_TOL, rtol=0)
        _assert_wrong(right, right_vw, "R[−hat(p), I] read as (ρ, ω)")
        _assert_wrong(left, left_vw, "[−hat(T p), I] read as (ρ, ω)")


# --------------------------------------------------------------------------- erratum 4


def _ad_vw_correct(T: np.ndarray) -> np.ndarray:
    R, t = T[:3, :3], T[:3, 3]
    return np.block([[R, so3.hat(t) @ R], [Z3, R]])


def _ad_vw_note(T: np.ndarray) -> np.ndarray:
    R, t = T[:3, :3], T[:3, 3]
    return np.block([[R, Z3], [so3.hat(t) @ R, R]])


def test_erratum_4_adjoint_block_layout_follows_the_order() -> None:
    """§7.3: in (ρ, ω), ``Ad = [[R, hat(t)R], [0, R]]``, ``ad = [[hat ω, hat ρ], [0, hat ω]]``."""

    def exp_vw(d: np.ndarray) -> np.ndarray:
        return se3.exp(P @ d)

    def log_vw(T: np.ndarray) -> np.ndarray:
        return P @ se3.log(T)

    rng = np.random.default_rng(104)
    for T, eta in zip(_poses(4), S.random_twists(rng, (4,), max_norm=3.0), strict=True):
        # Ad_T in (ρ, ω) is d/dδ Log(T·Exp(δ)·T⁻¹) at 0, all in (ρ, ω) coordinates
        Ti = se3.inverse(T)
        fd = numerical_jacobian(lambda d, T=T, Ti=Ti: log_vw(T @ exp_vw(d) @ Ti), np.zeros(6))
        assert_jacobian(_ad_vw_correct(T), fd, atol=FD_TOL, rtol=0, name="Ad (ρ, ω)")
        _assert_wrong(_ad_vw_note(T), fd, "Ad layout for (ρ, ω)")
        # and exactly: T·Exp(η)·T⁻¹ = Exp(Ad η) for a finite η in (ρ, ω)
        scale = 1 + np.abs(T).max() * (1 + np.abs(eta).max())
        lhs = T @ exp_vw(eta) @ Ti
        np.testing.assert_allclose(lhs, exp_vw(_ad_vw_correct(T) @ eta), rtol=0, atol=TOL * scale)
        _assert_wrong(exp_vw(_ad_vw_note(T) @ eta), lhs, "Ad for (ρ, ω) on a finite twist")

        # ad_ξ in (ρ, ω) is d/ds Ad(Exp(s ξ)) at 0
        rho, w = eta[:3], eta[3:]
        fd_ad = numerical_jacobian(lambda s, eta=eta: _ad_vw_correct(exp_vw(s * eta)), np.zeros(1))[
            ..., 0
        ]
        ad_correct = np.block([[so3.hat(w), so3.hat(rho)], [Z3, so3.hat(w)]])
        ad_note = np.block([[so3.hat(w), Z3], [so3.hat(rho), so3.hat(w)]])
        assert_jacobian(ad_correct, fd_ad, atol=FD_TOL, rtol=0, name="ad (ρ, ω)")
        _assert_wrong(ad_note, fd_ad, "ad layout for (ρ, ω)")
        # the wrong matrices are the (ω, v) layouts: what the canonical kernel returns
        np.testing.assert_allclose(P @ _ad_vw_note(T) @ P, _ad_vw_correct(T), rtol=0, atol=0)
        np.testing.assert_allclose(_ad_vw_note(T), se3.adjoint(T), rtol=0, atol=TOL * scale)
        np.testing.assert_allclose(ad_note, se3.ad(P @ eta), rtol=0, atol=0)


# --------------------------------------------------------------------------- erratum 5


def _first_order_errors(
    compose_log: Callable[[np.ndarray, np.ndarray], np.ndarray],
    linear: Callable[[np.ndarray], np.ndarray],
    w: np.ndarray,
    d: np.ndarray,
) -> list[float]:
    """``|Log(composition) − (w + L(w) δ)|`` for ``δ = h·d``, h = 1e-2, 1e-3, 1e-4."""
    return [
        float(np.abs(compose_log(w, h * d) - (w + linear(w) @ (h * d))).max())
        for h in (1e-2, 1e-3, 1e-4)
    ]


@pytest.mark.parametrize("group", ["so3", "se3"])
def test_erratum_5_bch_first_order_uses_the_matching_side(group: str) -> None:
    """§7.5 swaps them: ``Exp(w)Exp(δ) ≈ Exp(w + J_R⁻¹δ)``, ``Exp(δ)Exp(w) ≈ Exp(w + J_L⁻¹δ)``."""
    G = so3 if group == "so3" else se3
    n = 3 if group == "so3" else 6
    rng = np.random.default_rng(5)
    ws = S.random_twists(rng, (4,), max_angle=2.5, max_norm=3.0)[:, :n]
    ds = rng.normal(size=(4, n))

    def right_log(w: np.ndarray, d: np.ndarray) -> np.ndarray:
        return G.log(G.exp(w) @ G.exp(d))

    def left_log(w: np.ndarray, d: np.ndarray) -> np.ndarray:
        return G.log(G.exp(d) @ G.exp(w))

    for w, d in zip(ws, ds, strict=True):
        # finite differences of the exact composition at δ = 0
        fd_r = numerical_jacobian(lambda x, w=w: right_log(w, x), np.zeros(n))
        fd_l = numerical_jacobian(lambda x, w=w: left_log(w, x), np.zeros(n))
        assert_jacobian(G.jr_inv(w), fd_r, atol=FD_TOL, rtol=0, name="right: J_R⁻¹")
        assert_jacobian(G.jl_inv(w), fd_l, atol=FD_TOL, rtol=0, name="left: J_L⁻¹")
        _assert_wrong(G.jl_inv(w), fd_r, "right BCH with J_L⁻¹")
        _assert_wrong(G.jr_inv(w), fd_l, "left BCH with J_R⁻¹")

        # first order: the error of the correct form falls like |δ|² (×1/100 per decade), the
        # the wrong one's like |δ| (×1/10 per decade)
        cases = ((right_log, G.jr_inv, G.jl_inv), (left_log, G.jl_inv, G.jr_inv))
        for compose_log, good, bad in cases:
            e_good = _first_order_errors(compose_log, good, w, d)
            e_bad = _first_order_errors(compose_log, bad, w, d)
            assert e_good[1] / e_good[2] > 50 and e_good[0] / e_good[1] > 50, e_good
            assert 5 < e_bad[1] / e_bad[2] < 20, e_bad
            assert e_bad[2] > 100 * e_good[2], (e_good, e_bad)


# --------------------------------------------------------------------------- erratum 6


def _between_case(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    Ti, Tj = S.random_poses(rng, (2,), max_norm=5.0)
    # a measurement that disagrees with T_i⁻¹T_j by a sizeable residual (≈ 1 rad, 1 m): at r = 0
    # J_R(r)⁻¹ = I and the wrong formula would agree by accident
    Zm = se3.inverse(Ti) @ Tj @ se3.exp(np.array([0.6, -0.5, 0.4, 1.0, -0.5, 0.8]))
    return Ti, Tj, Zm


@pytest.mark.parametrize("seed", [60, 61, 62])
def test_erratum_6_between_residual_jacobians(seed: int) -> None:
    """§9.2: ``∂r/∂ξ_i = −J_R(r)⁻¹·Ad(T_j⁻¹T_i)`` (not ``−Ad(T_j⁻¹T_i)⁻¹·J_R(r)⁻¹``)."""
    Ti, Tj, Zm = _between_case(seed)
    Zi = se3.inverse(Zm)

    def residual(Ti_: np.ndarray, Tj_: np.ndarray) -> np.ndarray:
        return se3.log(Zi @ se3.inverse(Ti_) @ Tj_)

    r = residual(Ti, Tj)
    assert np.linalg.norm(r[:3]) > 0.5
    fd_i = numerical_jacobian(lambda X: residual(X, Tj), Ti, retract=_right)
    fd_j = numerical_jacobian(lambda X: residual(Ti, X), Tj, retract=_right)

    Jr_inv = se3.jr_inv(r)
    Ad = se3.adjoint(se3.inverse(Tj) @ Ti)
    H_i, H_j = -Jr_inv @ Ad, Jr_inv
    H_i_note = -np.linalg.inv(Ad) @ Jr_inv
    assert_jacobian(H_i, fd_i, atol=FD_TOL, rtol=0, name="∂r/∂ξ_i")
    assert_jacobian(H_j, fd_j, atol=FD_TOL, rtol=0, name="∂r/∂ξ_j")
    _assert_wrong(H_i_note, fd_i, "∂r/∂ξ_i = −Ad(T_j⁻¹T_i)⁻¹·J_R(r)⁻¹")

    # GTSAM's BetweenFactorPose3: same residual, same Jacobians (H must be pre-sized: an empty
    # JacobianVector crashes the process)
    factor = gtsam.BetweenFactorPose3(1, 2, gtsam.Pose3(Zm), gtsam.noiseModel.Unit.Create(6))
    values = gtsam.Values()
    values.insert(1, gtsam.Pose3(Ti))
    values.insert(2, gtsam.Pose3(Tj))
    H = gtsam.JacobianVector([np.zeros((6, 6)), np.zeros((6, 6))])
    err = factor.unwhitenedError(values, H)
    np.testing.assert_allclose(err, r, rtol=0, atol=TOL * 100)
    assert_jacobian(np.asarray(H[0]), H_i, atol=TOL * 100, rtol=0, name="gtsam H1")
    assert_jacobian(np.asarray(H[1]), H_j, atol=TOL * 100, rtol=0, name="gtsam H2")
    _assert_wrong(np.asarray(H[0]), H_i_note, "∂r/∂ξ_i vs GTSAM")
