"""The doctor names planted mistakes in residuals and covariance propagations, not correct ones."""

from __future__ import annotations

import numpy as np
import pytest

import liebridge as lb
from liebridge.doctor import diagnose_covariance, diagnose_residual
from liebridge.lie import se2, se3, so3

inv = np.linalg.inv


# ------------------------------------------------------------------ residuals


def between_right(Ti, Tj, Z):  # GTSAM's BetweenFactor: Log(Z⁻¹·T_i⁻¹·T_j)
    return se3.log(inv(Z) @ inv(Ti) @ Tj)


def test_correct_body_frame_residual():
    d = diagnose_residual(between_right)
    assert d.verdict == "correct", d
    step = d.evidence["step"]
    assert step["error_ratio"] < 1e-3 and step["direction_cosine"] > 0.99
    assert d.evidence["left_invariance_error"] < 1e-12


def test_correct_residual_in_another_convention():
    sophus = lb.conventions.get("sophus")
    d = diagnose_residual(lambda Ti, Tj, Z: sophus.local(Z, inv(Ti) @ Tj), convention="sophus")
    assert d.verdict == "correct", d


def test_correct_world_frame_residual_with_a_left_solver():
    d = diagnose_residual(lambda Ti, Tj, Z: se3.log(Tj @ inv(Ti) @ inv(Z)), convention="barfoot")
    assert d.verdict == "correct" and d.evidence["form"] == "world", d


@pytest.mark.parametrize(
    "bad",
    [
        lambda Ti, Tj, Z: se3.log(Z @ inv(Ti) @ Tj),  # Z where Z⁻¹ belongs
        lambda Ti, Tj, Z: se3.log(inv(Z) @ inv(Tj) @ Ti),  # T_j⁻¹T_i where T_i⁻¹T_j belongs
    ],
    ids=["measurement-inverted", "relative-pose-inverted"],
)
def test_inverted_residual_moves_the_graph_the_wrong_way(bad):
    d = diagnose_residual(bad)
    assert (d.verdict, d.cause) == ("mistake", "inverted_residual"), d
    assert d.evidence["step"]["direction_cosine"] < -0.9


def test_translation_error_in_the_world_frame_is_not_frame_invariant():
    def r(Ti, Tj, Z):
        rot = so3.log(Z[:3, :3].T @ Ti[:3, :3].T @ Tj[:3, :3])
        return np.concatenate([rot, Tj[:3, 3] - Ti[:3, 3] - Ti[:3, :3] @ Z[:3, 3]])

    d = diagnose_residual(r)
    assert (d.verdict, d.cause) == ("mistake", "not_frame_invariant"), d

    def r_ok(Ti, Tj, Z):  # the same written in the body frame of i
        rot = so3.log(Z[:3, :3].T @ Ti[:3, :3].T @ Tj[:3, :3])
        return np.concatenate([rot, Ti[:3, :3].T @ (Tj[:3, 3] - Ti[:3, 3]) - Z[:3, 3]])

    assert diagnose_residual(r_ok).verdict == "correct"


def test_residual_not_zero_at_the_measurement():
    d = diagnose_residual(lambda Ti, Tj, Z: se3.log(inv(Ti) @ Tj))  # forgot Z
    assert (d.verdict, d.cause) == ("mistake", "not_zero_at_measurement"), d


def test_jacobian_of_the_wrong_sign_steps_the_wrong_way():
    def J_bad(Ti, Tj, Z):
        return -se3.jr_inv(between_right(Ti, Tj, Z))

    def J_good(Ti, Tj, Z):
        return se3.jr_inv(between_right(Ti, Tj, Z))

    d = diagnose_residual(between_right, jacobian=J_bad)
    assert (d.verdict, d.cause) == ("mistake", "step_wrong_direction"), d
    assert diagnose_residual(between_right, jacobian=J_good).verdict == "correct"


def test_se2_residual_inverted_and_correct():
    def ok(Ti, Tj, Z):
        return se2.log(inv(Z) @ inv(Ti) @ Tj)

    def bad(Ti, Tj, Z):
        return se2.log(Z @ inv(Ti) @ Tj)

    assert diagnose_residual(ok, group="se2", convention="gtsam_pose2").verdict == "correct"
    d = diagnose_residual(bad, group="se2", convention="gtsam_pose2")
    assert d.cause == "inverted_residual", d


def test_residual_bad_input():
    with pytest.raises(ValueError, match="residual: raised KeyError"):
        diagnose_residual(lambda Ti, Tj, Z: {}["x"])
    with pytest.raises(ValueError, match="residual: returned 6 NaN/Inf"):
        diagnose_residual(lambda Ti, Tj, Z: np.full(6, np.nan))
    with pytest.raises(ValueError, match=r"jacobian: expected shape \(6, 6\)"):
        diagnose_residual(between_right, jacobian=lambda Ti, Tj, Z: np.eye(3))


# ------------------------------------------------------------------ covariance propagations

T = se3.exp([0.3, -0.2, 0.1, 1.0, 2.0, 3.0])
C = np.diag([1e-3, 2e-3, 3e-3, 1e-2, 2e-2, 3e-2])
SWAP = np.eye(6)[[3, 4, 5, 0, 1, 2]]


def ad_wv(T):  # (ω, v): [[R, 0], [hat(t)R, R]]
    R, t = T[:3, :3], T[:3, 3]
    return np.block([[R, np.zeros((3, 3))], [so3.hat(t) @ R, R]])


def ad_vw(T):  # (v, ω) = (ρ, φ): [[R, hat(t)R], [0, R]] (errata 4)
    R, t = T[:3, :3], T[:3, 3]
    return np.block([[R, so3.hat(t) @ R], [np.zeros((3, 3)), R]])


def test_right_to_left_frame_change_is_correct_and_matches_monte_carlo():
    d = diagnose_covariance(
        lambda c, X: ad_wv(X) @ c @ ad_wv(X).T, T, C, src="gtsam", dst="pytransform3d_global"
    )
    assert d.verdict == "correct", d
    mc = d.evidence["monte_carlo"]
    assert mc["relative_error"] < 5 * mc["sampling_error"]


def test_missing_adjoint():
    d = diagnose_covariance(lambda c, X: c, T, C, src="gtsam", dst="pytransform3d_global")
    assert (d.verdict, d.cause) == ("mistake", "missing_adjoint"), d
    assert d.evidence["monte_carlo"]["relative_error"] > 0.2


def test_wrong_six_vector_order():
    # GTSAM marginal (ω, v) to Barfoot's left (ρ, φ): the user forgot the permutation
    d = diagnose_covariance(
        lambda c, X: ad_wv(X) @ c @ ad_wv(X).T, T, C, src="gtsam", dst="barfoot"
    )
    assert (d.verdict, d.cause) == ("mistake", "wrong_order"), d
    ok = diagnose_covariance(
        lambda c, X: SWAP @ ad_wv(X) @ c @ ad_wv(X).T @ SWAP.T, T, C, src="gtsam", dst="barfoot"
    )
    assert ok.verdict == "correct", ok


def test_adjoint_block_layout_of_the_other_order():
    # Sophus (v, ω) right → Barfoot (ρ, φ) left with the (ω, v) layout (common-formula-errors E4)
    d = diagnose_covariance(
        lambda c, X: ad_wv(X) @ c @ ad_wv(X).T, T, C, src="sophus", dst="barfoot"
    )
    assert (d.verdict, d.cause) == ("mistake", "adjoint_block_layout"), d
    ok = diagnose_covariance(
        lambda c, X: ad_vw(X) @ c @ ad_vw(X).T, T, C, src="sophus", dst="barfoot"
    )
    assert ok.verdict == "correct", ok


def test_inverse_adjoint():
    Ai = ad_wv(se3.inverse(T))
    d = diagnose_covariance(
        lambda c, X: Ai @ c @ Ai.T, T, C, src="gtsam", dst="pytransform3d_global"
    )
    assert (d.verdict, d.cause) == ("mistake", "inverse_adjoint"), d


def test_without_src_and_dst_the_pair_is_named():
    d = diagnose_covariance(lambda c, X: ad_wv(X) @ c @ ad_wv(X).T, T, C)
    assert d.verdict == "correct", d
    assert "pytransform3d_global" in d.explanation and "gtsam" in d.explanation


def test_rotation_covariance_half_angle():
    R = T[:3, :3]
    Cr = np.diag([1e-3, 2e-3, 3e-3])
    d = diagnose_covariance(lambda c, X: X @ c @ X.T, R, Cr, src="gtsam", dst="ceres_quaternion")
    # Ceres's tangent is the half angle: the map is R/2, the user's R is the exp tangent's
    assert (d.verdict, d.cause) == ("convention_mismatch", "half_angle"), d
    ok = diagnose_covariance(
        lambda c, X: X @ c @ X.T / 4, R, Cr, src="gtsam", dst="ceres_quaternion"
    )
    assert ok.verdict == "correct", ok


def test_covariance_bad_input():
    with pytest.raises(ValueError, match=r"propagate: returned shape \(3, 3\)"):
        diagnose_covariance(lambda c, X: np.eye(3), T, C)
    with pytest.raises(ValueError, match="propagate: raised"):
        diagnose_covariance(lambda c, X: 1 / 0, T, C)
    with pytest.raises(ValueError, match="cov"):
        diagnose_covariance(lambda c, X: c, T, -C)


# ------------------------------------------------------------------ interpolation

T0 = se3.exp([0.1, 0.2, 0.3, 1.0, 0.0, 0.5])
T1 = se3.exp([0.4, -0.1, 0.6, 2.0, 1.0, 0.0])


def test_geodesic_and_split_interpolations_are_correct():
    from liebridge.doctor import diagnose_interpolation

    d = diagnose_interpolation(lambda A, B, s: A @ se3.exp(s * se3.log(inv(A) @ B)), T0, T1)
    assert d.verdict == "correct" and "geodesic" in d.explanation, d
    d = diagnose_interpolation(lambda A, B, s: se3.exp(s * se3.log(B @ inv(A))) @ A, T0, T1)
    assert d.verdict == "correct", d
    d = diagnose_interpolation(lambda A, B, s: se3.interpolate(A, B, s), T0, T1)
    assert d.verdict == "correct", d

    def split(A, B, s):
        out = np.eye(4)
        out[:3, :3] = A[:3, :3] @ so3.exp(s * so3.log(A[:3, :3].T @ B[:3, :3]))
        out[:3, 3] = (1 - s) * A[:3, 3] + s * B[:3, 3]
        return out

    d = diagnose_interpolation(split, T0, T1)
    assert d.verdict == "correct" and "separately" in d.explanation, d


@pytest.mark.parametrize(
    "bad, cause",
    [
        (lambda A, B, s: se3.exp(s * se3.log(inv(A) @ B)) @ A, "endpoint"),  # sides mixed
        (lambda A, B, s: A @ se3.exp(s / 0.1 * se3.log(inv(A) @ B)), "endpoint"),  # τ in 0.1 s
        (lambda A, B, s: (1 - s) * A + s * B, "not_a_pose"),  # matrices blended
        (lambda A, B, s: A @ se3.exp(s**2 * se3.log(inv(A) @ B)), "not_geodesic"),
    ],
    ids=["mixed-sides", "tau-not-normalized", "matrix-lerp", "not-geodesic"],
)
def test_interpolation_mistakes(bad, cause):
    from liebridge.doctor import diagnose_interpolation

    d = diagnose_interpolation(bad, T0, T1)
    assert (d.verdict, d.cause) == ("mistake", cause), d


def test_interpolation_bad_input():
    from liebridge.doctor import diagnose_interpolation

    with pytest.raises(ValueError, match=r"interpolate: raised ZeroDivisionError at tau = 0"):
        diagnose_interpolation(lambda A, B, s: 1 / 0, T0, T1)
    with pytest.raises(ValueError, match=r"interpolate: returned 16 NaN/Inf entries at tau = 0"):
        diagnose_interpolation(lambda A, B, s: np.full((4, 4), np.nan), T0, T1)
    with pytest.raises(ValueError, match=r"interpolate: returned shape \(3, 3\)"):
        diagnose_interpolation(lambda A, B, s: np.eye(3), T0, T1)
    with pytest.raises(ValueError, match=r"T0, T1: expected two"):
        diagnose_interpolation(lambda A, B, s: A, T0, T1[:3, :3])
