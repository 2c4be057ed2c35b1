"""The doctor names the planted mistake in a Jacobian, and raises no false alarm on a correct one.

Every planted bug is a deliberately wrong user Jacobian written out by hand (the mistake a user
makes), next to the correct one written from the textbook formula; both directions are tested.
The correct Jacobians of the no-false-alarm sweep come from a hand-written GTSAM-convention
formula converted with ``lb.convert_jacobian`` (closed-form tangent maps), never from the
doctor's finite differences.
"""

from __future__ import annotations

import numpy as np
import pytest

import liebridge as lb
from liebridge.conventions import GROUP_PRESETS, PRESETS
from liebridge.doctor import diagnose_jacobian
from liebridge.lie import se2, se3, so3

X = se3.exp([0.3, -0.2, 0.1, 1.0, 2.0, 3.0])
R = X[:3, :3]
P = np.array([0.5, -1.0, 2.0])
SWAP = np.eye(6)[[3, 4, 5, 0, 1, 2]]  # (ω, v) ↔ (v, ω)


def act(T):
    return T[:3, :3] @ P + T[:3, 3]


def act_right(T):  # d(T·p) for T·Exp(δ), δ = (ω, v): [-R·hat(p), R]
    return np.hstack([-T[:3, :3] @ so3.hat(P), T[:3, :3]])


def act_left(T):  # d(T·p) for Exp(δ)·T, δ = (ω, v): [-hat(T·p), I]
    return np.hstack([-so3.hat(act(T)), np.eye(3)])


def old_hat(w):  # the skew matrix of the old sign: old_hat(w)·p = −w×p
    return -so3.hat(w)


# ------------------------------------------------------------------ side, order, skew sign


def test_correct_right_jacobian_is_correct_for_gtsam():
    d = diagnose_jacobian(act, act_right, X, solver_convention="gtsam")
    assert d.verdict == "correct", d
    assert d.ok and d.evidence["best"]["error"] < 1e-7


def test_right_jacobian_with_a_left_solver_is_a_side_mismatch():
    d = diagnose_jacobian(act, act_right, X, solver_convention="pytransform3d_global")
    assert (d.verdict, d.cause) == ("convention_mismatch", "right_vs_left"), d
    assert "Ad_X⁻¹ on the right" in d.explanation


def test_left_jacobian_with_a_right_solver_is_a_side_mismatch():
    d = diagnose_jacobian(act, act_left, X, solver_convention="gtsam")
    assert (d.verdict, d.cause) == ("convention_mismatch", "right_vs_left"), d
    assert diagnose_jacobian(act, act_left, X, solver_convention="mr_space").verdict == "correct"


def test_rotation_first_jacobian_with_a_translation_first_solver_is_an_order_mismatch():
    d = diagnose_jacobian(act, act_right, X, solver_convention="sophus")
    assert (d.verdict, d.cause) == ("convention_mismatch", "order"), d
    assert "swap the rotation and translation column blocks" in d.explanation
    # the (v, ω) Jacobian is what Sophus needs
    d = diagnose_jacobian(act, lambda T: act_right(T) @ SWAP, X, solver_convention="sophus")
    assert d.verdict == "correct", d


def test_both_side_and_order_wrong():
    d = diagnose_jacobian(act, act_right, X, solver_convention="barfoot")
    assert d.cause == "right_vs_left+order", d


def test_old_skew_sign_is_named():
    def J(T):
        return np.hstack([-T[:3, :3] @ old_hat(P), T[:3, :3]])

    d = diagnose_jacobian(act, J, X, solver_convention="gtsam")
    assert (d.verdict, d.cause) == ("mistake", "skew_sign"), d
    assert "hat(e1)·e2 = e3" in d.explanation


def test_old_skew_sign_on_a_rotation():
    d = diagnose_jacobian(
        lambda Rm: Rm @ P, lambda Rm: -Rm @ old_hat(P), R, solver_convention="gtsam"
    )
    assert d.cause == "skew_sign", d
    ok = diagnose_jacobian(
        lambda Rm: Rm @ P, lambda Rm: -Rm @ so3.hat(P), R, solver_convention="gtsam"
    )
    assert ok.verdict == "correct", ok


# ------------------------------------------------------------------ adjoints


def test_ad_for_ad_inverse_in_a_side_conversion():
    # the user had the right Jacobian and wanted the left one: J_left = J_right·Ad_X⁻¹; wrote Ad_X
    d = diagnose_jacobian(
        act, lambda T: act_right(T) @ se3.adjoint(T), X, solver_convention="pytransform3d_global"
    )
    assert (d.verdict, d.cause) == ("mistake", "inverse_adjoint"), d
    ok = diagnose_jacobian(
        act,
        lambda T: act_right(T) @ se3.adjoint(se3.inverse(T)),
        X,
        solver_convention="pytransform3d_global",
    )
    assert ok.verdict == "correct", ok


def inverse(T):
    return se3.inverse(T)


def test_adjoint_on_the_wrong_side():
    # r(T_j) = Log(Z⁻¹·T_i⁻¹·T_j): right Jacobian Jr⁻¹(r); a left solver needs J_R·Ad_Tj⁻¹ —
    # the user multiplied Ad_Tj⁻¹ on the left
    def r(Tj):
        return between(X, Tj)

    def J_right(Tj):
        return se3.jr_inv(r(Tj))

    def J_bad(Tj):
        return se3.adjoint(se3.inverse(Tj)) @ J_right(Tj)

    def J_good(Tj):
        return J_right(Tj) @ se3.adjoint(se3.inverse(Tj))

    d = diagnose_jacobian(r, J_bad, TJ, solver_convention="pytransform3d_global")
    assert (d.verdict, d.cause) == ("mistake", "adjoint_wrong_side"), d
    ok = diagnose_jacobian(r, J_good, TJ, solver_convention="pytransform3d_global")
    assert ok.verdict == "correct", ok


def test_transpose():
    def r(Tj):
        return between(X, Tj)

    d = diagnose_jacobian(r, lambda Tj: se3.jr_inv(r(Tj)).T, TJ, solver_convention="gtsam")
    assert (d.verdict, d.cause) == ("mistake", "transpose"), d
    ok = diagnose_jacobian(r, lambda Tj: se3.jr_inv(r(Tj)), TJ, solver_convention="gtsam")
    assert ok.verdict == "correct", ok


# ------------------------------------------------------------------ Jr⁻¹ and the relative pose

Z = se3.exp([0.1, 0.2, -0.1, 1.0, 0.0, 0.0])
TJ = se3.exp([0.5, 0.1, 0.2, 2.0, 1.0, 3.0])


def between(Ti, Tj):
    return se3.log(se3.inverse(Z) @ se3.inverse(Ti) @ Tj)


def between_J(Ti, Tj):  # errata 6: ∂r/∂ξ_i = −Jr⁻¹(r)·Ad(T_j⁻¹T_i), ∂r/∂ξ_j = Jr⁻¹(r)
    Ji = se3.jr_inv(between(Ti, Tj))
    return np.hstack([-Ji @ se3.adjoint(se3.inverse(Tj) @ Ti), Ji])


def test_between_residual_with_exact_jacobians_is_correct():
    d = diagnose_jacobian(between, between_J, (X, TJ), solver_convention="gtsam")
    assert d.verdict == "correct", d


def test_between_residual_without_jr_inverse():
    def J(Ti, Tj):
        return np.hstack([-se3.adjoint(se3.inverse(Tj) @ Ti), np.eye(6)])

    d = diagnose_jacobian(between, J, (X, TJ), solver_convention="gtsam")
    assert (d.verdict, d.cause) == ("mistake", "jr_inv_omitted"), d


def test_between_residual_with_the_design_notes_wrong_formula_is_not_called_correct():
    # the note's §9.2 as printed: −Ad(T_j⁻¹T_i)⁻¹·Jr⁻¹(r) (errata 6): wrong, never "correct"
    def J(Ti, Tj):
        Ji = se3.jr_inv(between(Ti, Tj))
        return np.hstack([-np.linalg.inv(se3.adjoint(se3.inverse(Tj) @ Ti)) @ Ji, Ji])

    d = diagnose_jacobian(between, J, (X, TJ), solver_convention="gtsam")
    assert not d.ok, d


def test_so3_log_residual_without_jr_inverse():
    Zr = so3.exp([0.2, -0.1, 0.4])

    def r(Rm):
        return so3.log(Zr.T @ Rm)

    d = diagnose_jacobian(r, lambda Rm: np.eye(3), R, solver_convention="gtsam")
    assert (d.verdict, d.cause) == ("mistake", "jr_inv_omitted"), d
    ok = diagnose_jacobian(r, lambda Rm: so3.jr_inv(r(Rm)), R, solver_convention="gtsam")
    assert ok.verdict == "correct", ok


# ------------------------------------------------------------------ half angle, small angle, J = I


def test_half_angle_jacobian_for_a_rotation_vector_solver():
    # Ceres's QuaternionManifold (left, half angle): d(Exp(2δ)R·p) = −2·hat(R·p)
    def J_half(Rm):
        return -2.0 * so3.hat(Rm @ P)

    d = diagnose_jacobian(lambda Rm: Rm @ P, J_half, R, solver_convention="barfoot")
    assert (d.verdict, d.cause) == ("convention_mismatch", "half_angle"), d
    assert "half-angle factor" in d.explanation
    ok = diagnose_jacobian(lambda Rm: Rm @ P, J_half, R, solver_convention="ceres_quaternion")
    assert ok.verdict == "correct", ok


def test_small_angle_jacobian_holds_only_near_zero():
    def r(Rm):
        return so3.log(Rm)

    def J_small(Rm):  # Jr⁻¹ ≈ I + hat(r)/2: the first-order truncation
        return np.eye(3) + 0.5 * so3.hat(r(Rm))

    d = diagnose_jacobian(r, J_small, R, solver_convention="gtsam")
    assert (d.verdict, d.cause) == ("small_angle_only", "small_angle_only"), d
    errs = d.evidence["best"]["errors"]
    assert errs["0°"] < 1e-7 and errs["179°"] > 1e-2
    ok = diagnose_jacobian(r, lambda Rm: so3.jr_inv(r(Rm)), R, solver_convention="gtsam")
    assert ok.verdict == "correct" and ok.evidence["points"][-1] == "179°", ok


def _reintegrate(b, omegas, dt):
    """ΔR(b) = Π Exp((ω_k − b)·dt): the re-integrated rotation for gyro bias b."""
    Rm = np.eye(3)
    for w in omegas:
        Rm = Rm @ so3.exp((w - b) * dt)
    return Rm


def test_bias_jacobian_set_to_identity():
    rng = np.random.default_rng(3)
    omegas = rng.normal(0.0, 1.5, size=(40, 3))
    dt, b0 = 0.01, np.array([0.01, -0.02, 0.005])

    def f(b):
        return _reintegrate(b, omegas, dt)

    def J_b(b):  # Forster et al.: ∂ΔR/∂b = −Σ ΔR_{k+1,j}ᵀ·Jr((ω_k − b)dt)·dt (right)
        out = np.zeros((3, 3))
        for k in range(len(omegas)):
            Rk1j = _reintegrate(b, omegas[k + 1 :], dt)
            out -= Rk1j.T @ so3.jr((omegas[k] - b) * dt) * dt
        return out

    d = diagnose_jacobian(
        f, lambda b: -np.eye(3) * dt * len(omegas) * 0 + np.eye(3), b0, solver_convention="gtsam"
    )
    assert (d.verdict, d.cause) == ("mistake", "identity_substitution"), d
    ok = diagnose_jacobian(f, J_b, b0, solver_convention="gtsam")
    assert ok.verdict == "correct", ok


# ------------------------------------------------------------------ output conventions, SE(2)


def compose(T):
    return T @ Z


def test_pose_output_in_the_other_order():
    # right Jacobian of T·Z in (ω, v) in and out: Ad_{Z⁻¹}; given in (v, ω) to a gtsam solver
    def J_sophus(T):
        return SWAP @ se3.adjoint(se3.inverse(Z)) @ SWAP

    d = diagnose_jacobian(compose, J_sophus, X, solver_convention="gtsam")
    assert d.verdict == "convention_mismatch" and "order" in d.cause, d
    ok = diagnose_jacobian(compose, J_sophus, X, solver_convention="sophus")
    assert ok.verdict == "correct", ok


P2 = np.array([0.7, -1.2])
X2 = se2.exp([1.0, 2.0, 0.6])


def act2(T):
    return T[:2, :2] @ P2 + T[:2, 2]


def act2_right(T):  # gtsam_pose2: X·Exp(δ), δ = (x, y, θ): [R, R·J·p] with J = [[0,-1],[1,0]]
    Rm = T[:2, :2]
    return np.hstack([Rm, (Rm @ np.array([[0.0, -1.0], [1.0, 0.0]]) @ P2)[:, None]])


def test_se2_correct_and_side_mismatch():
    d = diagnose_jacobian(act2, act2_right, X2, solver_convention="gtsam_pose2")
    assert d.verdict == "correct", d
    bad = diagnose_jacobian(act2, act2_right, X2, solver_convention="ros_pose2")
    assert bad.verdict != "correct", bad
    flipped = diagnose_jacobian(
        act2, lambda T: act2_right(T) * [1, 1, -1], X2, solver_convention="gtsam_pose2"
    )
    assert flipped.cause == "skew_sign", flipped


# ------------------------------------------------------------------ no false alarm, every preset


@pytest.mark.parametrize("preset", [p for p in PRESETS if not p.is_euler], ids=lambda p: p.name)
def test_no_false_alarm_se3_and_so3(preset):
    J = lb.convert_jacobian(act_right(X), X, "gtsam", preset)
    d = diagnose_jacobian(act, J, X, solver_convention=preset)
    assert d.verdict == "correct", d
    Jr_ = lb.convert_jacobian(-R @ so3.hat(P), R, "gtsam", preset)
    d = diagnose_jacobian(lambda Rm: Rm @ P, Jr_, R, solver_convention=preset)
    assert d.verdict == "correct", d


@pytest.mark.parametrize(
    "preset", [p for p in GROUP_PRESETS if p.group == "se2"], ids=lambda p: p.name
)
def test_no_false_alarm_se2(preset):
    J = lb.convert_jacobian(act2_right(X2), X2, "gtsam_pose2", preset)
    d = diagnose_jacobian(act2, J, X2, solver_convention=preset)
    assert d.verdict == "correct", d


# ------------------------------------------------------------------ bad input


def test_function_that_raises():
    def f(T):
        raise ZeroDivisionError("boom")

    with pytest.raises(ValueError, match=r"f: raised ZeroDivisionError at the probe point X"):
        diagnose_jacobian(f, act_right, X)


def test_function_that_returns_nan():
    with pytest.raises(ValueError, match=r"f: returned 3 NaN/Inf entries"):
        diagnose_jacobian(lambda T: np.full(3, np.nan), act_right, X)


def test_jacobian_of_the_wrong_shape():
    with pytest.raises(ValueError, match=r"J: expected shape \(3, 6\).*got \(3, 3\)"):
        diagnose_jacobian(act, np.eye(3), X)


def test_jacobian_that_raises():
    def J(T):
        raise RuntimeError("no")

    with pytest.raises(ValueError, match=r"J: raised RuntimeError"):
        diagnose_jacobian(act, J, X)


def test_not_callable():
    with pytest.raises(TypeError, match="f: expected a callable"):
        diagnose_jacobian(3, act_right, X)


def test_gtsam_objects_are_handed_back():
    gtsam = pytest.importorskip("gtsam")
    seen = []

    def f(pose):
        seen.append(type(pose))
        return pose.transformFrom(P)

    d = diagnose_jacobian(
        f, lambda pose: act_right(pose.matrix()), gtsam.Pose3(X), solver_convention="gtsam"
    )
    assert d.verdict == "correct", d
    assert set(seen) == {gtsam.Pose3}


def test_result_is_json_ready():
    import json

    d = diagnose_jacobian(act, act_right, X, solver_convention="barfoot")
    back = json.loads(d.to_json())
    assert back["verdict"] == "convention_mismatch"
    assert back["evidence"]["candidates"][0]["error"] < 1e-7


# ------------------------------------------------------------------ every side/order/chart pair

DISTINCT = {}
for _p in PRESETS:
    if not _p.is_euler and _p.stores == "pose":  # the doctor's words: side, order, chart
        DISTINCT.setdefault(_p.fields, _p)  # one preset per retraction
PAIRS = [
    (a, b)
    for a in DISTINCT.values()
    for b in DISTINCT.values()
    if np.abs(lb.tangent_map(X, a, b) - np.eye(6)).max() > 1e-9  # distinguishable at X
]


def _fields_cause(found, want):
    parts = []
    if found.side != want.side:
        parts.append("right_vs_left")
    if found.order != want.order:
        parts.append("order")
    if found.rotation_scale != want.rotation_scale:
        parts.append("half_angle")
    if found.chart != want.chart:
        parts.append("chart")
    return parts


@pytest.mark.parametrize("wrote, solver", PAIRS, ids=lambda p: p.name)
def test_a_jacobian_of_one_convention_given_to_a_solver_of_another(wrote, solver):
    """The user's Jacobian is right for ``wrote``; the solver retracts like ``solver``."""
    J = lb.convert_jacobian(act_right(X), X, "gtsam", wrote)
    d = diagnose_jacobian(act, J, X, solver_convention=solver)
    assert d.verdict == "convention_mismatch", d
    assert wrote.name in d.explanation  # the class found names the preset the user wrote for
    named = set(d.cause.split("+"))
    expected = set(_fields_cause(wrote, solver))
    # a chart difference that is invisible at first order is reported as the other fields
    assert named <= expected | {"chart"} and named & expected, (named, expected)
    # the fix it prints is right: J·tangent_map(X, solver, found) is the solver's Jacobian
    fixed = J @ lb.tangent_map(X, solver, wrote)
    assert diagnose_jacobian(act, fixed, X, solver_convention=solver).verdict == "correct"


@pytest.mark.parametrize("preset", list(DISTINCT.values()), ids=lambda p: p.name)
def test_old_skew_sign_in_every_convention(preset):
    J = lb.convert_jacobian(act_right(X), X, "gtsam", preset)
    rot = [0, 1, 2] if preset.order == "rot_first" else [3, 4, 5]
    J_bad = J.copy()
    J_bad[:, rot] *= -1.0
    d = diagnose_jacobian(act, J_bad, X, solver_convention=preset)
    assert (d.verdict, d.cause) == ("mistake", "skew_sign"), d


def test_solver_given_as_its_own_retraction_is_measured():
    gtsam = pytest.importorskip("gtsam")

    def retract(T, d):
        return gtsam.Pose3(T).retract(d).matrix()

    d = diagnose_jacobian(act, act_left, X, solver_convention=retract)
    assert (d.verdict, d.cause) == ("convention_mismatch", "right_vs_left"), d
    assert d.evidence["solver_measured"] and "measured" in d.explanation
    assert diagnose_jacobian(act, act_right, X, solver_convention=retract).verdict == "correct"


def test_solver_retraction_that_is_not_one():
    with pytest.raises(ValueError, match="solver_convention: "):
        diagnose_jacobian(act, act_right, X, solver_convention=lambda T, d: T * 2.0)


def test_gtsam_pose2_objects_are_handed_back():
    gtsam = pytest.importorskip("gtsam")

    def f(pose):
        assert isinstance(pose, gtsam.Pose2)
        return pose.transformFrom(P2)

    d = diagnose_jacobian(
        f,
        lambda pose: act2_right(pose.matrix()),
        gtsam.Pose2(1.0, 2.0, 0.6),
        solver_convention="gtsam_pose2",
    )
    assert d.verdict == "correct", d


def test_rotation_output_conventions():
    Zr = so3.exp([0.4, -0.3, 0.2])

    def f(Rm):
        return Rm @ Zr

    ok = diagnose_jacobian(f, lambda Rm: Zr.T, R, solver_convention="gtsam")  # right: Zᵀ
    assert ok.verdict == "correct", ok
    d = diagnose_jacobian(f, lambda Rm: np.eye(3), R, solver_convention="gtsam")  # left: I
    assert (d.verdict, d.cause) == ("convention_mismatch", "right_vs_left"), d
    assert diagnose_jacobian(f, lambda Rm: np.eye(3), R, solver_convention="barfoot").ok


def test_identity_pose_is_flagged_as_uninformative():
    # at X = I the left and right Jacobians coincide: the doctor says so instead of guessing
    J = act_left(np.eye(4))
    d = diagnose_jacobian(act, J, np.eye(4), solver_convention="gtsam")
    assert d.verdict == "correct" and "generic pose" in d.explanation, d
    # a function J adds the probe angles, where left and right differ
    bad = diagnose_jacobian(act, act_left, np.eye(4), solver_convention="gtsam")
    assert bad.cause == "right_vs_left", bad


def test_a_pose_and_a_bias_together():
    # a bias-corrected point: f(T, b) = T·(p − b); columns (δ_T, δ_b)
    def f(T, b):
        return T[:3, :3] @ (P - b) + T[:3, 3]

    def J(T, b):
        Rm = T[:3, :3]
        return np.hstack([-Rm @ so3.hat(P - b), Rm, -Rm])

    b = np.array([0.01, -0.02, 0.03])
    assert diagnose_jacobian(f, J, (X, b), solver_convention="gtsam").verdict == "correct"

    def J_blocks(T, b):  # one block per input is accepted too
        full = J(T, b)
        return full[:, :6], full[:, 6:]

    assert diagnose_jacobian(f, J_blocks, (X, b), solver_convention="gtsam").verdict == "correct"
    d = diagnose_jacobian(
        f, lambda T, b: J(T, b) * [-1, -1, -1, 1, 1, 1, 1, 1, 1], (X, b), solver_convention="gtsam"
    )
    assert d.cause == "skew_sign", d
    d = diagnose_jacobian(
        f, lambda T, b: J(T, b) @ np.diag([1.0] * 6 + [-1.0] * 3), (X, b), solver_convention="gtsam"
    )
    assert not d.ok, d  # the bias block's sign: no convention explains it


def test_the_printed_fix_for_input_and_output_sides_is_right():
    # T ↦ T·Z with left perturbations in and out: J = I; a GTSAM solver needs Ad_{Z⁻¹}
    d = diagnose_jacobian(compose, lambda T: np.eye(6), X, solver_convention="gtsam")
    assert d.verdict == "convention_mismatch" and d.cause == "right_vs_left", d
    assert "lb.tangent_map(X, 'gtsam', 'pytransform3d_global')" in d.explanation
    assert "lb.tangent_map(Y, 'pytransform3d_global', 'gtsam')·J" in d.explanation
    Y = compose(X)
    fixed = (
        lb.tangent_map(Y, "pytransform3d_global", "gtsam")
        @ np.eye(6)
        @ lb.tangent_map(X, "gtsam", "pytransform3d_global")
    )
    np.testing.assert_allclose(fixed, se3.adjoint(se3.inverse(Z)), atol=1e-12)
    assert diagnose_jacobian(compose, fixed, X, solver_convention="gtsam").verdict == "correct"


def test_a_pypose_jacobian_given_to_a_solver_on_world_to_camera_poses():
    """A solver that updates the stored inverse (dpvo): the cause names the stored inverse."""
    J = lb.convert_jacobian(act_right(X), X, "gtsam", "pypose")
    d = diagnose_jacobian(act, J, X, solver_convention="dpvo")
    assert d.verdict == "convention_mismatch" and "pypose" in d.explanation, d
    assert d.cause == "stored_inverse", d
    fixed = J @ lb.tangent_map(X, "dpvo", "pypose")
    assert diagnose_jacobian(act, fixed, X, solver_convention="dpvo").verdict == "correct"
