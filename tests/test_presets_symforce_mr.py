"""Presets ``symforce``, ``mr_body`` and ``mr_space`` measured against the libraries they name.

Both libraries install from PyPI (test extras, see ``pyproject.toml``) and are imported directly:
a missing one is an error, not a skip.

* symforce 0.12 (``symforce-sym``, the generated numerical package ``sym``):
  ``Pose3.retract``/``local_coordinates``, ``Rot3.retract``/``local_coordinates``, the storage
  ``[qx, qy, qz, qw, x, y, z]``, and the docstring's own warning that ``retract`` is not the group
  operation (``retract(a, v) != compose(a, from_tangent(v))``).
* modern_robotics 1.1 (``modern_robotics``): ``MatrixExp6(VecTose3(V))`` with ``V = (ω, v)`` as a
  body twist ``T·e^[V_b]`` and as a space twist ``e^[V_s]·T``, ``MatrixLog6``, ``Adjoint``.
* :func:`liebridge.detect_convention` on each library's own retraction.

Inputs are built with scipy's ``Rotation`` (or mpmath), not with liebridge, so a bug in
``liebridge.lie`` cannot also corrupt the inputs. Where a library is measurably inaccurate, the
test says so with the measurement and shows against a 40-digit mpmath (or exact) reference that
liebridge is the accurate side, instead of loosening a tolerance silently. Every generator is
seeded.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import modern_robotics as mr
import mpmath
import numpy as np
import pytest
import sym
from _oracle_inputs import base_poses, pose, rot, rotvecs, translations, unit
from scipy.spatial.transform import Rotation

import liebridge as lb
from liebridge import conventions as C
from liebridge.conventions import Convention, detect_convention
from liebridge.lie import quaternion, se3

PI = math.pi

# Rounding budget for closed-form exp/log in float64 on both sides: entries reach ~60 (30 m
# translations composed), ulp(60) ≈ 7e-15, so 1e-12 leaves ~100 ulp of rounding, while a wrong
# side, order, chart or rotation coordinate differs at O(1). Measured agreement where neither
# library is degraded: symforce ≤ 1.3e-15, modern_robotics ≤ 1.3e-13 (exp; 2.2e-14 for θ ≥ 0.3)
# and ≤ 1.1e-14 (log, θ ≤ 2).
TOL = 1e-12

#: Rotation angles of the increments: 0, tiny, generic, the approach to π, π, and beyond π.
ANGLES_TINY: tuple[float, ...] = (0.0, 1e-12, 1e-9, 1e-6, 1e-4)
ANGLES_GENERIC: tuple[float, ...] = (0.3, 1.0, 2.0, 3.0)
ANGLES_NEAR_PI: tuple[float, ...] = (PI - 1e-3, PI - 1e-6, PI - 1e-9)
N_AXES = 4  # random axes per angle

# symforce's default epsilon (1e-8) in the generated code. In retract/from_tangent it enters only
# as θ_ε = sqrt(θ² + ε²) in sin(θ_ε/2)/θ_ε and cos(θ_ε/2): an O(ε²) = 1e-16 change, below rounding
# (measured ≤ 1.3e-15 for 0 ≤ θ ≤ π with 30 m). In local_coordinates it clamps
# |w| = |cos(θ/2)| ≤ 1 − ε in 2·acos(w)/sqrt(1 − w²), so below θ_c = sqrt(8ε) ≈ 2.8e-4 the factor
# is the constant 2·(1 + ε/3) instead of 2·(1 + θ²/24): an absolute error θ·(ε/3 − θ²/24), at most
# (2/3)(ε/3)·sqrt(8ε/3) = 3.6e-13 (at θ = 1.6e-4); just above θ_c, 1 − w² cancels (relative
# ~4e-16/θ²). Measured against the construction's rotation vector: symforce ≤ 4.0e-13 for
# 1e-6 ≤ θ ≤ 1e-2 (worst at 1.5e-4), liebridge ≤ 1e-16. 1e-12 (TOL) still covers it; the bound
# below is the analytic one plus rounding, so that a change in symforce's epsilon shows.
SYM_EPSILON = 1e-8
SYM_CLAMP_BOUND = (2.0 / 3.0) * (SYM_EPSILON / 3.0) * math.sqrt(8.0 * SYM_EPSILON / 3.0)
SYM_LOCAL_SMALL_TOL = SYM_CLAMP_BOUND + 1e-13

# modern_robotics' MatrixLog6 takes θ = arccos((tr R − 1)/2): near π the rounding of the trace
# (~1e-16) becomes a θ error ~1e-16/(π − θ), and θ/sin θ in MatrixLog3 amplifies it again, so the
# log's error grows like 1/(π − θ)². Measured against a 40-digit mpmath reference with 30 m
# translations: 2e-13 at π − 0.1, 4.9e-12 at π − 1e-2, 3.5e-10 at π − 1e-3, 1.1e-7 at π − 1e-4,
# 2e-3 at π − 1e-6, and at π − 1e-9 the "acosinput ≤ −1" branch returns π·(±axis) with the
# wrong sign for some axes (measured 4.4 rad in ω, 23 m in v); liebridge ≤ 1.1e-14 throughout.
# Its error against liebridge is ≤ 3.7e-14/(π − θ)² (the space log sees larger translations);
# 1e-13/(π − θ)² bounds it with margin and still rejects any convention error (O(1)) down to
# π − 1e-3.
MR_LOG_COEF = 1e-13

# modern_robotics' MatrixExp6 returns [I, v] when ‖ω‖ < 1e-6 (its NearZero): the neglected terms
# are hat(ω) in the rotation and ≈ ω×v/2 in the translation, so the error is ≤ ‖ω‖(1 + ‖v‖/2)
# (measured 2e-5 at ‖ω‖ = 9e-7 with 30 m). Just above the threshold, θ − sin θ and 1 − cos θ
# cancel: measured up to 9.3e-10 at 1.1e-6, 7.7e-12 at 1e-5, 2.2e-13 at 1e-3, i.e. ≲ 1.1e-21/θ²;
# 1e-20/θ² bounds it. liebridge ≤ 3.6e-15 against mpmath at all these angles.
MR_EXP_NEAR_ZERO = 1e-6
MR_EXP_SMALL_COEF = 1e-20


# --------------------------------------------------------------------------- inputs (no liebridge)


def _increments(rng: np.random.Generator, angles: tuple[float, ...]) -> np.ndarray:
    """``(ω, u)`` increments with the given rotation angles and translations up to 30 m."""
    w = rotvecs(rng, angles)
    return np.concatenate([w, translations(rng, len(w))], axis=-1)


def _pairs(rng: np.random.Generator, angles: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``(X, Y = X·D)`` with ``D`` rotating by the given angles (so do ``X⁻¹Y`` and ``YX⁻¹``)."""
    w = rotvecs(rng, angles)
    D = pose(rot(w), translations(rng, len(w)))
    X = base_poses(rng, len(w))
    return X, X @ D


def _mp_exp_se3(xi: np.ndarray) -> np.ndarray:
    """SE(3) exponential of an (ω, v) twist by mpmath's 40-digit ``expm``, rounded."""
    w1, w2, w3, u1, u2, u3 = (mpmath.mpf(float(c)) for c in xi)
    A = mpmath.matrix([[0, -w3, w2, u1], [w3, 0, -w1, u2], [-w2, w1, 0, u3], [0, 0, 0, 0]])
    with mpmath.workdps(40):
        return np.array(mpmath.expm(A).tolist(), dtype=np.float64)


# --------------------------------------------------------------------------- symforce wrappers


def _sym_rot(R: np.ndarray) -> sym.Rot3:
    """``sym.Rot3`` from scipy's quaternion (xyzw, symforce's documented storage)."""
    return sym.Rot3.from_storage(list(Rotation.from_matrix(R).as_quat()))


def _sym_pose(T: np.ndarray) -> sym.Pose3:
    return sym.Pose3(R=_sym_rot(T[:3, :3]), t=T[:3, 3].copy())


def _sym_pose_own(T: np.ndarray) -> sym.Pose3:
    """``sym.Pose3`` through symforce's own ``Rot3.from_rotation_matrix`` (Shepperd)."""
    return sym.Pose3(R=sym.Rot3.from_rotation_matrix(T[:3, :3].copy()), t=T[:3, 3].copy())


def _sym_matrix(P: sym.Pose3) -> np.ndarray:
    return np.asarray(P.to_homogenous_matrix(), dtype=np.float64)


def _sym_retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return _sym_matrix(_sym_pose_own(X).retract(np.asarray(d, dtype=np.float64)))


def _sym_rot3_retract(R: np.ndarray, d: np.ndarray) -> np.ndarray:
    Rs = sym.Rot3.from_rotation_matrix(R.copy())
    return np.asarray(Rs.retract(np.asarray(d, dtype=np.float64)).to_rotation_matrix())


#: (what, group, library retract, library local) — inputs built from scipy's quaternion.
SYM_ORACLES: tuple[tuple[str, str, Callable[..., Any], Callable[..., Any]], ...] = (
    (
        "sym.Pose3",
        "se3",
        lambda X, d: _sym_matrix(_sym_pose(X).retract(d)),
        lambda X, Y: _sym_pose(X).local_coordinates(_sym_pose(Y)),
    ),
    (
        "sym.Rot3",
        "so3",
        lambda R, d: np.asarray(_sym_rot(R).retract(d).to_rotation_matrix()),
        lambda R, S: _sym_rot(R).local_coordinates(_sym_rot(S)),
    ),
)


# --------------------------------------------------------------------------- symforce


@pytest.mark.parametrize(("what", "group", "retract", "local"), SYM_ORACLES, ids=["pose3", "rot3"])
def test_symforce_retract_matches_preset(what: str, group: str, retract: Any, local: Any) -> None:
    """``C.SYMFORCE.retract`` == symforce's ``retract`` for 0 ≤ θ ≤ 5 rad, 30 m translations."""
    rng = np.random.default_rng(1201)
    angles = (*ANGLES_TINY, *ANGLES_GENERIC, *ANGLES_NEAR_PI, PI, PI + 0.5, 5.0)
    d = _increments(rng, angles)
    X = base_poses(rng, len(d))
    if group == "so3":
        X, d = X[:, :3, :3].copy(), d[:, :3].copy()
    worst = 0.0
    for Xk, dk in zip(X, d, strict=True):
        got = retract(Xk.copy(), dk.copy())
        worst = max(worst, float(np.abs(got - C.SYMFORCE.retract(Xk, dk)).max()))
    assert worst <= TOL, f"{what}.retract vs symforce preset: max |diff| {worst:.3g}"


@pytest.mark.parametrize(("what", "group", "retract", "local"), SYM_ORACLES, ids=["pose3", "rot3"])
@pytest.mark.parametrize("near_pi", [False, True], ids=["generic", "near_pi"])
def test_symforce_local_matches_preset(
    what: str, group: str, retract: Any, local: Any, near_pi: bool
) -> None:
    """``C.SYMFORCE.local`` == ``local_coordinates`` (θ < π: the principal log is unique).

    Includes θ ≤ 1e-4, inside symforce's epsilon clamp (≤ 3.6e-13 there, see SYM_CLAMP_BOUND).
    """
    rng = np.random.default_rng(1202)
    angles = ANGLES_NEAR_PI if near_pi else (*ANGLES_TINY, 1e-2, *ANGLES_GENERIC)
    X, Y = _pairs(rng, angles)
    if group == "so3":
        X, Y = X[:, :3, :3].copy(), Y[:, :3, :3].copy()
    got = np.stack([np.asarray(local(a.copy(), b.copy())) for a, b in zip(X, Y, strict=True)])
    err = float(np.abs(got - C.SYMFORCE.local(X, Y)).max())
    assert err <= TOL, f"{what}.local_coordinates vs symforce preset: max |diff| {err:.3g}"


def test_symforce_local_epsilon_clamp_is_library_side() -> None:
    """For small angles symforce's ``local_coordinates`` is the inaccurate side (epsilon clamp).

    The reference is the rotation vector ``w`` the pair was built from (``R_Y = R_X·Exp(w)`` by
    scipy): liebridge recovers it to rounding, symforce within the analytic clamp bound.
    """
    rng = np.random.default_rng(1203)
    th = np.geomspace(1e-6, 1e-2, 17)
    w = np.repeat(th, N_AXES)[:, None] * unit(rng, th.size * N_AXES)
    X = base_poses(rng, len(w))
    Y = pose(X[:, :3, :3] @ rot(w), X[:, :3, 3] + translations(rng, len(w)))
    sym_err = lb_err = 0.0
    for Xk, Yk, wk in zip(X, Y, w, strict=True):
        s = _sym_pose(Xk).local_coordinates(_sym_pose(Yk))
        sym_err = max(sym_err, float(np.abs(s[:3] - wk).max()))
        lb_err = max(lb_err, float(np.abs(C.SYMFORCE.local(Xk, Yk)[:3] - wk).max()))
        np.testing.assert_array_equal(s[3:], Yk[:3, 3] - Xk[:3, 3])  # world-frame translation
    assert lb_err <= 1e-14, lb_err  # measured ≤ 1e-16
    assert sym_err <= SYM_LOCAL_SMALL_TOL, sym_err  # measured 4.0e-13
    # the clamp really acts (symforce's epsilon is 1e-8): worse than liebridge by orders
    assert sym_err > 1e3 * max(lb_err, 1e-17)


@pytest.mark.parametrize(("what", "group", "retract", "local"), SYM_ORACLES, ids=["pose3", "rot3"])
def test_symforce_local_wraps_beyond_pi_like_preset(
    what: str, group: str, retract: Any, local: Any
) -> None:
    """Retracting by ``π < θ < 2π`` and reading back gives the principal ``ω·(1 − 2π/θ)``.

    symforce picks the shortest quaternion path (``copysign(1, w)``); so does the preset's log.
    """
    rng = np.random.default_rng(1204)
    d = _increments(rng, (PI + 0.1, 4.0, 5.0, 2 * PI - 0.1))
    X = base_poses(rng, len(d))
    if group == "so3":
        X, d = X[:, :3, :3].copy(), d[:, :3].copy()
    for Xk, dk in zip(X, d, strict=True):
        th = float(np.linalg.norm(dk[:3]))
        want = dk.copy()
        want[:3] *= 1.0 - 2 * PI / th
        Yk = retract(Xk.copy(), dk.copy())
        np.testing.assert_allclose(local(Xk.copy(), Yk), want, rtol=0, atol=TOL)
        np.testing.assert_allclose(C.SYMFORCE.local(Xk, Yk), want, rtol=0, atol=TOL)


def test_symforce_storage_order() -> None:
    """``Pose3.to_storage()`` = ``[qx, qy, qz, qw, x, y, z]`` (Hamilton), ``quat_order`` xyzw."""
    assert C.SYMFORCE.quat_order == "xyzw"
    rng = np.random.default_rng(1205)
    w = rotvecs(rng, (0.3, 1.0, 2.5, PI - 1e-3, PI - 1e-6))
    X = pose(rot(w), translations(rng, len(w)))
    for Xk in X:
        s = np.asarray(_sym_pose_own(Xk).to_storage(), dtype=np.float64)
        assert s.shape == (7,)
        q, t = s[:4], s[4:]
        np.testing.assert_array_equal(t, Xk[:3, 3])
        mine = quaternion.from_matrix(Xk[:3, :3], order="xyzw")
        sign = 1.0 if float(mine @ q) >= 0.0 else -1.0
        np.testing.assert_allclose(sign * mine, q, rtol=0, atol=TOL)
        R_q = quaternion.to_matrix(q, order="xyzw")
        np.testing.assert_allclose(R_q, Xk[:3, :3], rtol=0, atol=TOL)
        # read as wxyz it is another rotation (θ > 0, so qw ≠ ±1)
        assert np.abs(quaternion.to_matrix(q, order="wxyz") - Xk[:3, :3]).max() > 1e-3
        # and from_storage of that layout, built from scipy's xyzw, is the same pose
        q_sp = Rotation.from_matrix(Xk[:3, :3]).as_quat()
        P = sym.Pose3.from_storage([*q_sp, *Xk[:3, 3]])
        np.testing.assert_allclose(_sym_matrix(P), Xk, rtol=0, atol=TOL)


def test_symforce_retract_is_not_compose_from_tangent() -> None:
    """symforce's docstring: ``retract(a, v) != compose(a, from_tangent(v))``; the preset is the
    former.

    ``from_tangent(v) = (Exp(ω), v)`` (product manifold, no SE(3) exp), so ``compose`` moves the
    translation in the body frame, ``(R·Exp(ω), t + R·v)``, while ``retract`` adds it in the world
    frame, ``(R·Exp(ω), t + v)``. Likewise ``local_coordinates(a, b) != to_tangent(between(a, b))``.
    """
    rng = np.random.default_rng(1206)
    d = _increments(rng, (0.3, 1.0, 2.0))
    X = base_poses(rng, len(d))
    body = Convention("symforce_compose", "right", "rot_first", "so3xr3_body", "exp", "xyzw")
    for Xk, dk in zip(X, d, strict=True):
        a = _sym_pose(Xk)
        ret = _sym_matrix(a.retract(dk))
        comp = _sym_matrix(a.compose(sym.Pose3.from_tangent(dk)))
        ft = _sym_matrix(sym.Pose3.from_tangent(dk))
        np.testing.assert_allclose(ft, pose(rot(dk[:3]), dk[3:]), rtol=0, atol=TOL)
        assert np.abs(ret - comp).max() > 1e-3  # the docstring's inequality
        np.testing.assert_allclose(ret, C.SYMFORCE.retract(Xk, dk), rtol=0, atol=TOL)
        np.testing.assert_allclose(comp, body.retract(Xk, dk), rtol=0, atol=TOL)
        assert np.abs(C.SYMFORCE.retract(Xk, dk) - comp).max() > 1e-3
        # neither is the SE(3) exponential X·Exp(ξ)
        assert np.abs(C.GTSAM.retract(Xk, dk) - ret).max() > 1e-3
        # the inverse side: local_coordinates != to_tangent(between)
        b = a.retract(dk)
        loc = np.asarray(a.local_coordinates(b))
        np.testing.assert_allclose(loc, dk, rtol=0, atol=TOL)
        np.testing.assert_allclose(C.SYMFORCE.local(Xk, ret), dk, rtol=0, atol=TOL)
        assert np.abs(np.asarray(a.between(b).to_tangent()) - loc).max() > 1e-3


def test_symforce_from_rotation_matrix_matches_scipy() -> None:
    """The detection wrapper's ``Rot3.from_rotation_matrix`` agrees with scipy up to ±q, near π
    too (so wrapping a matrix through it adds nothing but rounding)."""
    rng = np.random.default_rng(1207)
    w = rotvecs(rng, (0.0, 1e-9, 0.3, 2.0, PI - 1e-3, PI - 1e-9, PI))
    for R in rot(w):
        q = np.asarray(sym.Rot3.from_rotation_matrix(R.copy()).to_storage())
        ref = Rotation.from_matrix(R).as_quat()
        s = 1.0 if float(ref @ q) >= 0.0 else -1.0
        np.testing.assert_allclose(s * q, ref, rtol=0, atol=1e-15)


@pytest.mark.parametrize("prefer", [None, "symforce"])
def test_detect_convention_on_symforce(prefer: str | None) -> None:
    """``detect_convention`` on ``Pose3.retract`` (through a matrix) names the symforce preset.

    No other preset has its fields (right, (ω, t), world-frame translation, exp), so ``prefer``
    is not needed on poses.
    """
    found = detect_convention(_sym_retract, prefer=prefer)
    assert found.fields == C.SYMFORCE.fields, found.describe()
    assert found == C.SYMFORCE and found.name == "symforce", found.describe()


def test_detect_convention_on_symforce_rot3() -> None:
    """On ``Rot3.retract`` only side and rotation coordinates are measurable; prefer picks it."""
    found = detect_convention(_sym_rot3_retract, group="so3", prefer="symforce")
    assert (found.side, found.rotation) == ("right", "exp")
    assert found == C.SYMFORCE, found.describe()


# --------------------------------------------------------------------------- modern_robotics


def _mr_exp(V: np.ndarray) -> np.ndarray:
    return np.asarray(mr.MatrixExp6(mr.VecTose3(V)), dtype=np.float64)


def _mr_log(T: np.ndarray) -> np.ndarray:
    return np.asarray(mr.se3ToVec(mr.MatrixLog6(T)), dtype=np.float64)


def _mr_body_retract(X: np.ndarray, V: np.ndarray) -> np.ndarray:
    return X @ _mr_exp(V)  # T·e^[V_b]


def _mr_space_retract(X: np.ndarray, V: np.ndarray) -> np.ndarray:
    return _mr_exp(V) @ X  # e^[V_s]·T


def _mr_body_local(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return _mr_log(np.asarray(mr.TransInv(X)) @ Y)


def _mr_space_local(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return _mr_log(Y @ np.asarray(mr.TransInv(X)))


MR_ORACLES: tuple[tuple[str, Convention, Callable[..., Any], Callable[..., Any]], ...] = (
    ("body", C.MR_BODY, _mr_body_retract, _mr_body_local),
    ("space", C.MR_SPACE, _mr_space_retract, _mr_space_local),
)


def test_mr_vectose3_is_omega_v() -> None:
    """``VecTose3((ω, v))`` puts ω in the skew block and v in the last column (rotation first)."""
    V = np.array([0.1, -0.2, 0.3, 4.0, -5.0, 6.0])
    M = np.asarray(mr.VecTose3(V))
    np.testing.assert_array_equal(M[:3, 3], V[3:])
    np.testing.assert_array_equal([M[2, 1], M[0, 2], M[1, 0]], V[:3])
    np.testing.assert_array_equal(mr.se3ToVec(M), V)
    assert C.MR_BODY.order == C.MR_SPACE.order == "rot_first"


@pytest.mark.parametrize(("kind", "conv", "retract", "local"), MR_ORACLES, ids=["body", "space"])
def test_mr_retract_matches_preset(kind: str, conv: Convention, retract: Any, local: Any) -> None:
    """``T·MatrixExp6([V_b])`` == ``mr_body.retract``, ``MatrixExp6([V_s])·T`` == ``mr_space``.

    Angles where MatrixExp6 is accurate (0 and ≥ 1e-3; below, see the small-angle test).
    """
    rng = np.random.default_rng(1301)
    d = _increments(rng, (0.0, 1e-3, *ANGLES_GENERIC, *ANGLES_NEAR_PI, PI))
    X = base_poses(rng, len(d))
    worst = max(
        float(np.abs(retract(Xk.copy(), dk.copy()) - conv.retract(Xk, dk)).max())
        for Xk, dk in zip(X, d, strict=True)
    )
    assert worst <= TOL, f"{kind}: max |diff| {worst:.3g}"
    # the other side is another pose
    other = C.MR_SPACE if conv is C.MR_BODY else C.MR_BODY
    assert np.abs(retract(X[-1], d[-1]) - other.retract(X[-1], d[-1])).max() > 1e-3


@pytest.mark.parametrize(("kind", "conv", "retract", "local"), MR_ORACLES, ids=["body", "space"])
def test_mr_local_matches_preset(kind: str, conv: Convention, retract: Any, local: Any) -> None:
    """``MatrixLog6(T⁻¹Y)`` == ``mr_body.local``, ``MatrixLog6(Y·T⁻¹)`` == ``mr_space.local``.

    Tolerance ``TOL + MR_LOG_COEF/(π − θ)²``: MatrixLog6's own precision towards π (measured).
    """
    rng = np.random.default_rng(1302)
    angles = (0.0, 1e-7, 1e-4, 1e-2, *ANGLES_GENERIC, PI - 1e-2, PI - 1e-3)
    X, Y = _pairs(rng, angles)
    th = np.repeat(np.asarray(angles), N_AXES)
    for Xk, Yk, tk in zip(X, Y, th, strict=True):
        got = local(Xk.copy(), Yk.copy())
        err = float(np.abs(got - conv.local(Xk, Yk)).max())
        tol = TOL + MR_LOG_COEF / (PI - tk) ** 2
        assert err <= tol, f"{kind}: θ = {tk:.12g}, |diff| {err:.3g} > {tol:.3g}"


def test_mr_matrixlog6_near_pi_is_library_side() -> None:
    """Near π MatrixLog6 is the inaccurate side: liebridge agrees with a 40-digit reference.

    The pose is mpmath's ``expm`` of a known twist (θ < π, so its log is that twist).
    """
    rng = np.random.default_rng(1303)
    for gap in (1e-1, 1e-2, 1e-3, 1e-4):
        for w, t in zip((PI - gap) * unit(rng, 3), 30.0 * unit(rng, 3), strict=True):
            xi = np.r_[w, t]
            T = _mp_exp_se3(xi)
            lb_err = float(np.abs(C.MR_BODY.local(np.eye(4), T) - xi).max())
            mr_err = float(np.abs(_mr_log(T) - xi).max())
            assert lb_err <= TOL, (gap, lb_err)  # measured ≤ 1.1e-14
            assert mr_err <= TOL + MR_LOG_COEF / gap**2, (gap, mr_err)  # ≤ 1.5e-15/gap²


def test_mr_small_angles_are_library_side() -> None:
    """Below ‖ω‖ = 1e-6 MatrixExp6 drops ω (returns ``[I, v]``); just above it cancels.

    Below ~1.5e-8, MatrixLog6 sees ``tr R`` round to 3 and returns ``(0, p)``. The references
    are mpmath's 40-digit ``expm``; liebridge agrees with them to rounding.
    """
    rng = np.random.default_rng(1304)
    for th in (1e-9, 1e-7, 9e-7, 1.1e-6, 1e-5, 1e-3):
        for w, v in zip(th * unit(rng, 3), translations(rng, 3), strict=True):
            xi = np.r_[w, v]
            T = _mp_exp_se3(xi)
            assert np.abs(C.MR_BODY.retract(np.eye(4), xi) - T).max() <= 1e-14
            assert np.abs(C.MR_SPACE.retract(np.eye(4), xi) - T).max() <= 1e-14
            E = _mr_exp(xi)
            mr_err = float(np.abs(E - T).max())
            if th < MR_EXP_NEAR_ZERO:
                np.testing.assert_array_equal(E, pose(np.eye(3), v))  # NearZero: ω dropped
                assert mr_err <= th * (1.0 + np.linalg.norm(v) / 2) * (1 + 1e-6) + 1e-15
            else:
                assert mr_err <= TOL + MR_EXP_SMALL_COEF / th**2, (th, mr_err)
            if th <= 1e-9:  # trace rounds to 3: MatrixLog6 returns (0, p)
                np.testing.assert_array_equal(_mr_log(T), np.r_[np.zeros(3), T[:3, 3]])
                np.testing.assert_allclose(C.MR_BODY.local(np.eye(4), T), xi, rtol=0, atol=1e-14)


def test_mr_adjoint_is_tangent_map_body_to_space() -> None:
    """``mr.Adjoint(T)`` (ω, v) == ``se3.adjoint(T)`` == ``tangent_map(T, mr_body, mr_space)``.

    And the library's own identity ``e^[Ad_T V_b]·T = T·e^[V_b]`` (``V_s = Ad_T V_b``) holds with
    the preset's exact conversion.
    """
    rng = np.random.default_rng(1305)
    X = base_poses(rng, 12)
    V = _increments(rng, (0.3, 1.0, 2.0))
    for Xk, Vb in zip(X, V, strict=True):
        Ad = np.asarray(mr.Adjoint(Xk), dtype=np.float64)
        np.testing.assert_allclose(Ad, se3.adjoint(Xk), rtol=0, atol=TOL)
        np.testing.assert_allclose(Ad, lb.tangent_map(Xk, "mr_body", "mr_space"), rtol=0, atol=TOL)
        # measured ≤ 1.8e-14 (inverse), ≤ 1.5e-14 (poses), ≤ 8e-16 (tangents)
        np.testing.assert_allclose(
            np.linalg.inv(Ad), lb.tangent_map(Xk, "mr_space", "mr_body"), rtol=0, atol=TOL
        )
        Vs = Ad @ Vb
        np.testing.assert_allclose(
            _mr_space_retract(Xk, Vs), _mr_body_retract(Xk, Vb), rtol=0, atol=TOL
        )
        np.testing.assert_allclose(
            lb.convert_tangent(Vb, Xk, "mr_body", "mr_space"), Vs, rtol=0, atol=TOL
        )
    # a wrong identification: Ad_T V_b read as the body twist moves elsewhere
    Ad0 = np.asarray(mr.Adjoint(X[0]), dtype=np.float64)
    assert np.abs(_mr_body_retract(X[0], Ad0 @ V[0]) - _mr_body_retract(X[0], V[0])).max() > 1e-3


@pytest.mark.parametrize(
    ("kind", "conv", "retract", "prefer"),
    [
        ("body", C.MR_BODY, _mr_body_retract, "mr_body"),
        ("space", C.MR_SPACE, _mr_space_retract, "mr_space"),
    ],
    ids=["body", "space"],
)
def test_detect_convention_on_mr(kind: str, conv: Convention, retract: Any, prefer: str) -> None:
    """``detect_convention`` names ``mr_body``/``mr_space`` with ``prefer``; without it, an
    equivalent preset (GTSAM's fields / pytransform3d global's fields)."""
    found = detect_convention(retract, prefer=prefer)
    assert found == conv and found.name == conv.name, found.describe()
    plain = detect_convention(retract)
    assert plain.fields == conv.fields, plain.describe()
