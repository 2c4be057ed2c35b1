"""Presets measured against the libraries they name (the ones that install from PyPI).

A preset is a claim about a library; this file measures it. Every library is imported directly
(they are test extras, see ``pyproject.toml``): a missing one is an error, not a skip.

* GTSAM 4.3 (``gtsam``; ``pytransform3d_local`` and ``mr_body`` have the same fields):
  ``Pose3.retract``/``localCoordinates``, ``Rot3.retract``/``localCoordinates``,
  ``Rot3.Quaternion``/``toQuaternion``, and the tangent of ``Marginals.marginalCovariance``
  (Monte Carlo through a prior + between graph).
* Pinocchio 4.1 (``pinocchio``, ``pinocchio_r3xso3``): free-flyer ``integrate``/``difference``,
  ``liegroups.SE3``/``SO3``/``R3 × SO3``, ``exp6``/``log6``, XYZQUAT storage.
* pytransform3d 3.17 (``pytransform3d_global``/``_local``): exponential coordinates and the two
  ``concat_*_uncertain_transforms`` (Monte Carlo), ``pq`` storage.
* spatialmath-python 1.1 (``Twist3`` = (v, ω), ``UnitQuaternion.vec`` = wxyz) and scipy 1.17
  (``Rotation``, ``RigidTransform.from_exp_coords`` = (ω, v), ``as_quat`` orders): no preset, but
  facts of ``docs/library-facts.md`` that liebridge's kernel and layouts rely on.
* :func:`liebridge.detect_convention` on each library's own retraction.

Inputs are built with scipy's ``Rotation.from_rotvec`` (or mpmath), not with liebridge, so a bug in
``liebridge.lie`` cannot also corrupt the inputs. Every random generator is seeded.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import gtsam
import mpmath
import numpy as np
import pinocchio as pin
import pytest
import pytransform3d.transformations as pt
import pytransform3d.uncertainty as pu
from _oracle_inputs import base_poses, pose, rot, rotvecs, translations, unit
from scipy.spatial.transform import RigidTransform, Rotation
from spatialmath import SE3, Twist3, UnitQuaternion

import liebridge as lb
from liebridge import conventions as C
from liebridge.conventions import Convention, ConventionNotDetected, detect_convention
from liebridge.lie import quaternion, se3, so3

PI = math.pi

# Rounding budget for closed-form exp/log in float64 on both sides: entries reach ~60 (30 m
# translations composed), ulp(60) ≈ 7e-15, so 1e-12 leaves ~100 ulp of rounding, while a wrong
# side, order, chart or rotation coordinate differs at O(1). Measured agreement: ≤ 5e-14.
TOL = 1e-12

#: Relative rotation angles of the probes: 0, tiny, generic, and the approach to π.
ANGLES_GENERIC: tuple[float, ...] = (0.0, 1e-9, 0.3, 1.0, 2.0, 3.0)
ANGLES_NEAR_PI: tuple[float, ...] = (PI - 1e-3, PI - 1e-6, PI - 1e-9)
N_AXES = 4  # random axes per angle

# pytransform3d's SE(3) log loses accuracy approaching π (against a 40-digit mpmath reference:
# 7e-13 at π - 1e-3, 1e-11 at π - 1e-4, 2.5e-9 at π - 1e-6, while liebridge stays ≤ 8e-15;
# 4.3e-9 against liebridge on this file's near-π probes). 2e-8 bounds it with margin and still
# rejects any convention error (O(1)).
PT_LOG_NEAR_PI_TOL = 2e-8


# --------------------------------------------------------------------------- inputs (no liebridge)


def _increments(rng: np.random.Generator, angles: tuple[float, ...], group: str) -> np.ndarray:
    """Canonical (ω, v) increments (ω only for so3) with the given rotation angles."""
    w = rotvecs(rng, angles)
    if group == "so3":
        return w
    return np.concatenate([w, translations(rng, len(w))], axis=-1)


def _to_order(xi: np.ndarray, conv: Convention) -> np.ndarray:
    """A canonical-order increment in ``conv``'s order (rotation vector coordinates only)."""
    if xi.shape[-1] == 3 or conv.order == "rot_first":
        return xi
    return np.concatenate([xi[..., 3:], xi[..., :3]], axis=-1)


# --------------------------------------------------------------------------- library wrappers

_FF_MODEL = pin.Model()
_FF_MODEL.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "free_flyer")
_R3XSO3 = pin.liegroups.R3() * pin.liegroups.SO3()
_PIN_SE3 = pin.liegroups.SE3()
_PIN_SO3 = pin.liegroups.SO3()


def _xyzquat(T: np.ndarray) -> np.ndarray:
    return np.asarray(pin.SE3ToXYZQUAT(pin.SE3(np.array(T, dtype=np.float64))))


def _from_xyzquat(q: np.ndarray) -> np.ndarray:
    return np.asarray(pin.XYZQUATToSE3(np.asarray(q, dtype=np.float64)).homogeneous)


def _quat_xyzw(R: np.ndarray) -> np.ndarray:
    return _xyzquat(pose(R, np.zeros(3)))[3:]


def _rot_from_quat_xyzw(q: np.ndarray) -> np.ndarray:
    return _from_xyzquat(np.r_[np.zeros(3), q])[:3, :3]


def _pt_inv(T: np.ndarray) -> np.ndarray:
    return np.asarray(pt.invert_transform(T, check=False))


def _pt_exp(xi: np.ndarray) -> np.ndarray:
    return np.asarray(pt.transform_from_exponential_coordinates(xi))


def _pt_log(T: np.ndarray) -> np.ndarray:
    return np.asarray(pt.exponential_coordinates_from_transform(T, check=False))


Fn = Callable[[np.ndarray, np.ndarray], Any]


def _gtsam_retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return np.asarray(gtsam.Pose3(X).retract(d).matrix())


def _gtsam_local(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return np.asarray(gtsam.Pose3(X).localCoordinates(gtsam.Pose3(Y)))


def _pin_ff_integrate(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return _from_xyzquat(pin.integrate(_FF_MODEL, _xyzquat(X), d))


def _pin_ff_difference(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return np.asarray(pin.difference(_FF_MODEL, _xyzquat(X), _xyzquat(Y)))


def _r3xso3_integrate(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return _from_xyzquat(_R3XSO3.integrate(_xyzquat(X), d))


def _r3xso3_difference(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return np.asarray(_R3XSO3.difference(_xyzquat(X), _xyzquat(Y)))


def _pt_global_retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return np.asarray(pt.concat(X, _pt_exp(d)))  # concat(A2B, B2C) = B2C·A2B: Exp(d)·X


def _pt_local_retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return np.asarray(pt.concat(_pt_exp(d), X))  # X·Exp(d)


def _pt_global_local(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return _pt_log(Y @ _pt_inv(X))


def _pin_se3_integrate(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    return _from_xyzquat(_PIN_SE3.integrate(_xyzquat(X), d))


def _pin_so3_integrate(R: np.ndarray, d: np.ndarray) -> np.ndarray:
    return _rot_from_quat_xyzw(_PIN_SO3.integrate(_quat_xyzw(R), d))


def _rot3_retract(R: np.ndarray, d: np.ndarray) -> np.ndarray:
    return np.asarray(gtsam.Rot3(R).retract(d).matrix())


@dataclass(frozen=True)
class Oracle:
    """A library's retraction (``X, d -> Y``) or local (``X, Y -> d``), in its own tangent."""

    name: str
    group: str  # "se3" or "so3"
    fn: Fn
    preset: Convention
    near_pi_tol: float = TOL  # the library's own measured precision near θ = π, if worse


RETRACTS: tuple[Oracle, ...] = (
    Oracle("gtsam.Pose3.retract", "se3", _gtsam_retract, C.GTSAM),
    Oracle("gtsam.Rot3.retract", "so3", _rot3_retract, C.GTSAM),
    # mr_body: the modern_robotics package is not a test extra; its body-twist formula T·e^[V_b],
    # V_b = (ω, v), is GTSAM's retract (the preset shares GTSAM's fields), measured here.
    Oracle("gtsam.Pose3.retract as mr_body", "se3", _gtsam_retract, C.MR_BODY),
    Oracle("pin.integrate(free-flyer)", "se3", _pin_ff_integrate, C.PINOCCHIO),
    Oracle("pin.liegroups.SE3.integrate", "se3", _pin_se3_integrate, C.PINOCCHIO),
    Oracle("pin.liegroups.SO3.integrate", "so3", _pin_so3_integrate, C.PINOCCHIO),
    Oracle(
        "X·pin.exp6(Motion(v, ω))",
        "se3",
        lambda X, d: X @ pin.exp6(pin.Motion(d[:3], d[3:])).homogeneous,
        C.PINOCCHIO,
    ),
    Oracle("(R3×SO3).integrate", "se3", _r3xso3_integrate, C.PINOCCHIO_R3XSO3),
    Oracle(
        "pt.transform_from_exponential_coordinates(d)·X",
        "se3",
        _pt_global_retract,
        C.PYTRANSFORM3D_GLOBAL,
    ),
    Oracle(
        "X·pt.transform_from_exponential_coordinates(d)",
        "se3",
        _pt_local_retract,
        C.PYTRANSFORM3D_LOCAL,
    ),
)

LOCALS: tuple[Oracle, ...] = (
    # GTSAM's Pose3 log loses up to ~1e-6 in the translation for π - 1e-2 ≲ θ ≲ π - 1e-5 at 30 m
    # (its rotation part is exact); see test_gtsam_pose3_log_near_pi_against_mpmath, which
    # shows liebridge is the accurate side there. 5e-6 = that measured error (≤ 1.6e-6) × 3.
    Oracle("gtsam.Pose3.localCoordinates", "se3", _gtsam_local, C.GTSAM, near_pi_tol=5e-6),
    Oracle(
        "gtsam.Rot3.localCoordinates",
        "so3",
        lambda X, Y: gtsam.Rot3(X).localCoordinates(gtsam.Rot3(Y)),
        C.GTSAM,
    ),
    Oracle("pin.difference(free-flyer)", "se3", _pin_ff_difference, C.PINOCCHIO),
    Oracle(
        "pin.liegroups.SE3.difference",
        "se3",
        lambda X, Y: _PIN_SE3.difference(_xyzquat(X), _xyzquat(Y)),
        C.PINOCCHIO,
    ),
    Oracle(
        "pin.liegroups.SO3.difference",
        "so3",
        lambda X, Y: _PIN_SO3.difference(_quat_xyzw(X), _quat_xyzw(Y)),
        C.PINOCCHIO,
    ),
    Oracle("(R3×SO3).difference", "se3", _r3xso3_difference, C.PINOCCHIO_R3XSO3),
    Oracle(
        "pt.exponential_coordinates_from_transform(Y·X⁻¹)",
        "se3",
        _pt_global_local,
        C.PYTRANSFORM3D_GLOBAL,
        near_pi_tol=PT_LOG_NEAR_PI_TOL,
    ),
    Oracle(
        "pt.exponential_coordinates_from_transform(X⁻¹·Y)",
        "se3",
        lambda X, Y: _pt_log(_pt_inv(X) @ Y),
        C.PYTRANSFORM3D_LOCAL,
        near_pi_tol=PT_LOG_NEAR_PI_TOL,
    ),
)


def _ids(oracles: tuple[Oracle, ...]) -> list[str]:
    return [f"{o.preset.name}:{o.name}" for o in oracles]


# --------------------------------------------------------------------------- retract / local


@pytest.mark.parametrize("oracle", RETRACTS, ids=_ids(RETRACTS))
def test_retract_matches_library(oracle: Oracle) -> None:
    """``preset.retract(X, d)`` == the library's retraction, up to θ = π and 30 m translations."""
    rng = np.random.default_rng(101)
    angles = (*ANGLES_GENERIC, *ANGLES_NEAR_PI, PI)  # exp is unambiguous at π itself
    xi = _increments(rng, angles, oracle.group)
    X = base_poses(rng, len(xi))
    if oracle.group == "so3":
        X = X[:, :3, :3].copy()
    worst = 0.0
    for Xk, xk in zip(X, xi, strict=True):
        d = _to_order(xk, oracle.preset)
        got = np.asarray(oracle.fn(Xk.copy(), d.copy()), dtype=np.float64)
        want = oracle.preset.retract(Xk, d)
        worst = max(worst, float(np.abs(got - want).max()))
    assert worst <= TOL, f"{oracle.name} vs {oracle.preset.name}.retract: max |diff| {worst:.3g}"


@pytest.mark.parametrize("oracle", LOCALS, ids=_ids(LOCALS))
@pytest.mark.parametrize("near_pi", [False, True], ids=["generic", "near_pi"])
def test_local_matches_library(oracle: Oracle, near_pi: bool) -> None:
    """``preset.local(X, Y)`` == the library's inverse retraction (θ < π: the log is unique)."""
    rng = np.random.default_rng(202)
    angles = ANGLES_NEAR_PI if near_pi else ANGLES_GENERIC
    w = rotvecs(rng, angles)
    D = pose(rot(w), translations(rng, len(w)))
    X = base_poses(rng, len(w))
    Y = X @ D  # X⁻¹Y and YX⁻¹ (a conjugate) both rotate by the chosen angle
    if oracle.group == "so3":
        X, Y = X[:, :3, :3].copy(), Y[:, :3, :3].copy()
    tol = oracle.near_pi_tol if near_pi else TOL
    got = np.stack([np.asarray(oracle.fn(a.copy(), b.copy())) for a, b in zip(X, Y, strict=True)])
    want = oracle.preset.local(X, Y)
    err = float(np.abs(got - want).max())
    assert err <= tol, f"{oracle.name} vs {oracle.preset.name}.local: max |diff| {err:.3g}"


def _mp_exp_se3(xi: np.ndarray) -> np.ndarray:
    """SE(3) exponential of a canonical (ω, v) twist by mpmath's 40-digit ``expm``, rounded."""
    w, u = (mpmath.mpf(float(c)) for c in xi[:3]), (mpmath.mpf(float(c)) for c in xi[3:])
    (w1, w2, w3), (u1, u2, u3) = w, u
    A = mpmath.matrix([[0, -w3, w2, u1], [w3, 0, -w1, u2], [-w2, w1, 0, u3], [0, 0, 0, 0]])
    return np.array(mpmath.expm(A).tolist(), dtype=np.float64)


def test_gtsam_pose3_log_near_pi_against_mpmath() -> None:
    """Near θ = π, GTSAM's Pose3 log is the inaccurate one; liebridge's agrees with mpmath.

    The reference pose is ``expm`` at 40 digits of a known twist, so the true log is that twist
    (θ < π). Measured: liebridge ≤ 8e-15; pinocchio's log6 up to 2.7e-11 at π - 1e-2 (≤ 4e-15
    closer to π); GTSAM up to 8e-7 in the translation at θ = π - 1e-3 with 30 m (its rotation
    part is exact).
    """
    rng = np.random.default_rng(303)
    with mpmath.workdps(40):
        for gap in (1e-2, 1e-3, 1e-4, 1e-6):
            for w, t in zip((PI - gap) * unit(rng, 2), 30.0 * unit(rng, 2), strict=True):
                xi = np.r_[w, t]
                T = _mp_exp_se3(xi)
                lb_err = np.abs(C.GTSAM.local(np.eye(4), T) - xi).max()
                g_log = gtsam.Pose3.Logmap(gtsam.Pose3(T))
                p_log = pin.log6(pin.SE3(T))
                p_err = np.abs(np.r_[p_log.angular, p_log.linear] - xi).max()
                # 1e-12: float64 rounding of T (entries ≤ 30) amplified by the log's O(1)
                # conditioning below π; liebridge measured ≤ 8e-15.
                assert lb_err <= TOL, (gap, lb_err)
                assert p_err <= 1e-10, (gap, p_err)  # pinocchio: measured ≤ 2.7e-11
                assert np.abs(g_log[:3] - xi[:3]).max() <= TOL, (gap, g_log - xi)
                # GTSAM's translation: the measured inaccuracy (not a convention difference).
                assert np.abs(g_log[3:] - xi[3:]).max() <= 5e-6, (gap, g_log - xi)


# --------------------------------------------------------------------------- exp/log kernels


def test_pinocchio_exp6_log6_are_linear_angular() -> None:
    """``pin.Motion`` stores (linear, angular) = (v, ω); ``exp6``/``log6`` are the SE(3) exp/log."""
    rng = np.random.default_rng(404)
    xi = _increments(rng, (*ANGLES_GENERIC, *ANGLES_NEAR_PI), "se3")  # canonical (ω, v)
    for x in xi:
        m = pin.Motion(np.r_[x[3:], x[:3]])
        assert np.array_equal(m.linear, x[3:]) and np.array_equal(m.angular, x[:3])
        T = pin.exp6(m).homogeneous
        np.testing.assert_allclose(T, se3.exp(x), rtol=0, atol=TOL)
        lg = pin.log6(pin.SE3(T))
        np.testing.assert_allclose(np.r_[lg.angular, lg.linear], se3.log(T), rtol=0, atol=TOL)
        # tangents stored (v, ω): the order-swapped vector is not the same pose
        if np.linalg.norm(x[:3]) > 0.1:
            assert np.abs(pin.exp6(pin.Motion(x)).homogeneous - T).max() > 1e-3


def test_pytransform3d_exponential_coordinates_are_omega_v() -> None:
    """``Sθ = (ω̂θ, vθ)`` in pytransform3d is the canonical twist (ω, v) (rotation first)."""
    rng = np.random.default_rng(505)
    xi = _increments(rng, (*ANGLES_GENERIC, *ANGLES_NEAR_PI), "se3")
    for x in xi:
        T = _pt_exp(x)
        np.testing.assert_allclose(T, se3.exp(x), rtol=0, atol=TOL)
        near_pi = np.linalg.norm(x[:3]) > 3.0
        tol = PT_LOG_NEAR_PI_TOL if near_pi else TOL
        np.testing.assert_allclose(_pt_log(T), se3.log(T), rtol=0, atol=tol)
        # Ad in (ω, v), the block order its uncertainty functions use
        np.testing.assert_allclose(pt.adjoint_from_transform(T), se3.adjoint(T), rtol=0, atol=TOL)


def test_spatialmath_twist3_is_v_omega() -> None:
    """``Twist3(v, w)`` stores ``S = (v, ω)``; ``exp``/``SE3.Exp``/``log`` are the SE(3) ones.

    Angles from 0.01 up: spatialmath's ``trexp``/``trlog`` lose accuracy for tiny non-zero
    angles (against a 40-digit mpmath reference at 30 m: 1.3e-8 at θ = 1e-9, 1.3e-9 at 1e-6,
    7.5e-12 at 1e-4, ≤ 4e-14 from 1e-2 on; liebridge ≤ 4e-15 throughout). θ = 0 is exact. Its
    log also degrades towards π (up to 1.3e-12 at θ = 3, 6e-9 at π - 1e-3, 2e-3 at π - 1e-6;
    liebridge ≤ 1.1e-14), so its log is compared at θ ≤ 2 only: the order is what is measured.
    """
    rng = np.random.default_rng(606)
    xi = _increments(rng, (0.0, 0.01, 0.3, 1.0, 2.0, 3.0, PI - 1e-3), "se3")
    for x in xi:
        w, v = x[:3], x[3:]
        tw = Twist3(v, w)
        assert np.array_equal(tw.S, np.r_[v, w])
        T = se3.exp(x)
        tol = TOL * max(1.0, float(np.linalg.norm(v)))  # translation errors scale with ‖v‖
        np.testing.assert_allclose(tw.exp().A, T, rtol=0, atol=tol)
        np.testing.assert_allclose(SE3.Exp(np.r_[v, w]).A, T, rtol=0, atol=tol)
        lg = se3.log(T)
        if np.linalg.norm(w) <= 2.0:
            sm_log = SE3(T, check=False).log(twist=True)
            np.testing.assert_allclose(sm_log, np.r_[lg[3:], lg[:3]], rtol=0, atol=tol)
        if np.linalg.norm(w) > 0.1:  # read in GTSAM's (ω, v) order it is another pose
            assert np.abs(Twist3(w, v).exp().A - T).max() > 1e-3


def test_scipy_rotation_and_rigid_transform_exp_coords() -> None:
    """``from_rotvec``/``as_rotvec`` = so3 exp/log; ``from_exp_coords`` takes (ω, v)."""
    rng = np.random.default_rng(707)
    xi = _increments(rng, (*ANGLES_GENERIC, *ANGLES_NEAR_PI), "se3")
    R = Rotation.from_rotvec(xi[:, :3])
    np.testing.assert_allclose(R.as_matrix(), so3.exp(xi[:, :3]), rtol=0, atol=TOL)
    np.testing.assert_allclose(
        R.as_rotvec(), so3.log(R.as_matrix()), rtol=0, atol=TOL
    )  # θ < π: unique log
    T = RigidTransform.from_exp_coords(xi)
    np.testing.assert_allclose(T.as_matrix(), se3.exp(xi), rtol=0, atol=TOL)
    np.testing.assert_allclose(
        RigidTransform.from_matrix(se3.exp(xi)).as_exp_coords(),
        se3.log(se3.exp(xi)),
        rtol=0,
        atol=TOL,
    )


# --------------------------------------------------------------------------- quaternion storage


def _gtsam_quat_wxyz_in(R: np.ndarray) -> np.ndarray:
    """The 4 numbers that ``gtsam.Rot3.Quaternion(a, b, c, d)`` turns back into ``R``."""
    q = Rotation.from_matrix(R).as_quat(scalar_first=True)
    assert np.allclose(gtsam.Rot3.Quaternion(*q).matrix(), R, atol=TOL)
    return q


QUAT_STORAGE: tuple[tuple[str, Callable[[np.ndarray], np.ndarray], str], ...] = (
    ("gtsam Rot3.Quaternion(w, x, y, z) in", _gtsam_quat_wxyz_in, C.GTSAM.quat_order),
    ("gtsam toQuaternion().coeffs() out", lambda R: gtsam.Rot3(R).toQuaternion().coeffs(), "xyzw"),
    ("pinocchio SE3ToXYZQUAT[3:]", _quat_xyzw, C.PINOCCHIO.quat_order),
    ("pinocchio R3xSO3 q[3:]", _quat_xyzw, C.PINOCCHIO_R3XSO3.quat_order),
    (
        "pytransform3d pq_from_transform[3:]",
        lambda R: pt.pq_from_transform(pose(R, np.zeros(3)))[3:],
        C.PYTRANSFORM3D_GLOBAL.quat_order,
    ),
    (
        "pytransform3d (local) pq_from_transform[3:]",
        lambda R: pt.pq_from_transform(pose(R, np.zeros(3)))[3:],
        C.PYTRANSFORM3D_LOCAL.quat_order,
    ),
    ("spatialmath UnitQuaternion.vec", lambda R: UnitQuaternion(R).vec, "wxyz"),
    ("scipy as_quat()", lambda R: Rotation.from_matrix(R).as_quat(), "xyzw"),
    (
        "scipy as_quat(scalar_first=True)",
        lambda R: Rotation.from_matrix(R).as_quat(scalar_first=True),
        "wxyz",
    ),
)


@pytest.mark.parametrize(("what", "get_q", "order"), QUAT_STORAGE, ids=[q[0] for q in QUAT_STORAGE])
def test_quaternion_storage_order(
    what: str, get_q: Callable[[np.ndarray], np.ndarray], order: str
) -> None:
    """The library's quaternion, read in the claimed order, is the rotation (Hamilton).

    ``quaternion.to_matrix`` is liebridge's closed-form polynomial (independent of scipy);
    ``from_matrix`` (scipy-backed) must agree up to the sign ``±q``.
    """
    rng = np.random.default_rng(808)
    R = rot(rotvecs(rng, (0.3, 1.0, 2.5, PI - 1e-6)))
    for Rk in R:
        q = np.asarray(get_q(Rk.copy()), dtype=np.float64)
        np.testing.assert_allclose(quaternion.to_matrix(q, order=order), Rk, rtol=0, atol=TOL)
        mine = quaternion.from_matrix(Rk, order=order)
        s = 1.0 if float(mine @ q) >= 0.0 else -1.0
        np.testing.assert_allclose(s * mine, q, rtol=0, atol=TOL)
        # the other storage order is a different rotation (θ > 0, so the scalar part ≠ ±1)
        other = "xyzw" if order == "wxyz" else "wxyz"
        assert np.abs(quaternion.to_matrix(q, order=other) - Rk).max() > 1e-3


# --------------------------------------------------------------------------- Monte Carlo helpers


def _whitened_gap(S_emp: np.ndarray, S_claim: np.ndarray) -> float:
    """``max |L⁻¹ S_emp L⁻ᵀ − I|`` with ``S_claim = L Lᵀ``.

    Under the claim and N Gaussian samples, each entry of ``L⁻¹ S_emp L⁻ᵀ`` has standard
    deviation ≤ sqrt(2/N) (diagonal; sqrt(1/N) off-diagonal), whatever the scales of the six
    coordinates. The statistic is invariant under a linear map applied to both covariances, so a
    wrong map (side, order, adjoint) shows as O(1)-or-larger gaps.
    """
    L = np.linalg.cholesky(S_claim)
    A = np.linalg.solve(L, S_emp)
    W = np.linalg.solve(L, A.T)
    return float(np.abs(W - np.eye(len(W))).max())


def _correlated_cov(rng: np.random.Generator, sigma_rot: float, sigma_trans: float) -> np.ndarray:
    D = np.diag([sigma_rot] * 3 + [sigma_trans] * 3)
    return D @ np.corrcoef(rng.normal(size=(6, 12))) @ D  # a dense, well-conditioned correlation


N_MC = 20_000
# Sampling: 5·sqrt(2/N) = 0.050 (5 σ on each of 21 entries). Nonlinearity: with σ_rot = 0.01 rad
# the neglected second-order terms are ~σ_rot relative (≈ 0.01). Measured gaps: 0.015 to 0.027.
MC_TOL = 0.06
# A wrong reading must miss by far more than the tolerance (measured: 15 to 1500).
MC_WRONG = 1.0


# --------------------------------------------------------------------------- GTSAM marginals


@dataclass(frozen=True)
class MarginalRun:
    X_hat: np.ndarray  # marginal mean of pose 2 (4×4)
    cov: np.ndarray  # gtsam.Marginals.marginalCovariance(2)
    samples: np.ndarray  # (N, 4, 4): the posterior of pose 2, sampled through the factors


@cache
def _gtsam_marginal_run() -> MarginalRun:
    """Prior on x1 (dense 6×6 covariance, 30 m from the origin) and a between x1→x2.

    The graph is a tree, so its posterior is sampled exactly by pushing the factors' noise
    through their own error definitions (GTSAM's, not liebridge's): ``PriorFactor`` error =
    ``localCoordinates(prior, x1)`` → ``x1 = prior.retract(n0)``; ``BetweenFactor`` error =
    ``localCoordinates(Z, x1⁻¹x2)`` → ``x2 = x1·Z.retract(nb)``. Nothing about the tangent of
    ``Marginals`` is assumed: that is what the sample covariance measures.
    """
    rng = np.random.default_rng(909)
    prior = pose(rot(np.array([0.4, -1.1, 2.0])), np.array([25.0, -12.0, 8.0]))
    Z = pose(rot(np.array([0.9, 0.3, -0.5])), np.array([4.0, -2.0, 1.5]))
    S0 = _correlated_cov(rng, 0.01, 0.05)
    Sb = np.diag([0.005, 0.008, 0.006, 0.03, 0.02, 0.04]) ** 2
    graph = gtsam.NonlinearFactorGraph()
    graph.add(
        gtsam.PriorFactorPose3(1, gtsam.Pose3(prior), gtsam.noiseModel.Gaussian.Covariance(S0))
    )
    graph.add(
        gtsam.BetweenFactorPose3(1, 2, gtsam.Pose3(Z), gtsam.noiseModel.Gaussian.Covariance(Sb))
    )
    init = gtsam.Values()
    init.insert(1, gtsam.Pose3(prior).retract(np.full(6, 0.05)))
    init.insert(2, gtsam.Pose3(prior @ Z).retract(np.full(6, -0.05)))
    result = gtsam.LevenbergMarquardtOptimizer(graph, init).optimize()
    X_hat = result.atPose3(2).matrix()
    cov = gtsam.Marginals(graph, result).marginalCovariance(2)
    n0 = rng.multivariate_normal(np.zeros(6), S0, size=N_MC)
    nb = rng.multivariate_normal(np.zeros(6), Sb, size=N_MC)
    gZ, gP = gtsam.Pose3(Z), gtsam.Pose3(prior)
    samples = np.stack(
        [gP.retract(a).compose(gZ).retract(b).matrix() for a, b in zip(n0, nb, strict=True)]
    )
    return MarginalRun(X_hat, cov, samples)


def _loop(fn: Callable[[np.ndarray, np.ndarray], Any]) -> Callable[[np.ndarray, np.ndarray], Any]:
    return lambda X, Ys: np.stack([np.asarray(fn(X, Y)) for Y in Ys])


#: (destination preset, how its tangent of a sample is measured, the measuring function)
MARGINAL_READERS: tuple[tuple[str, str, Callable[[np.ndarray, np.ndarray], Any]], ...] = (
    ("gtsam", "C.GTSAM.local", C.GTSAM.local),
    ("gtsam", "gtsam.Pose3.localCoordinates", _loop(_gtsam_local)),
    ("barfoot", "C.BARFOOT.local", C.BARFOOT.local),
    ("pinocchio", "pin.difference(free-flyer)", _loop(_pin_ff_difference)),
    ("pinocchio_r3xso3", "(R3×SO3).difference", _loop(_r3xso3_difference)),
    ("pytransform3d_global", "pt exponential coords of Y·X⁻¹", _loop(_pt_global_local)),
)


@pytest.mark.parametrize(
    ("dst", "reader", "read"), MARGINAL_READERS, ids=[f"{d}:{r}" for d, r, _ in MARGINAL_READERS]
)
def test_gtsam_marginal_covariance_tangent(dst: str, reader: str, read: Any) -> None:
    """``Marginals.marginalCovariance`` is over GTSAM's right (ω, v) tangent at the estimate.

    With ``dst = "gtsam"`` this measures GTSAM's semantics; for the others it checks
    ``lb.convert_covariance(Σ, X̂, "gtsam", dst)`` against the spread of the same samples read
    in ``dst``'s tangent (by the library itself where it has one).
    """
    run = _gtsam_marginal_run()
    d = np.asarray(read(run.X_hat, run.samples))
    S_emp = np.cov(d.T)
    S_claim = lb.convert_covariance(run.cov, run.X_hat, "gtsam", dst)
    gap = _whitened_gap(S_emp, S_claim)
    assert gap <= MC_TOL, f"{reader}: whitened gap {gap:.3g}\nempirical\n{S_emp}\nclaim\n{S_claim}"


@pytest.mark.parametrize(
    "wrong", [C.PYTRANSFORM3D_GLOBAL, C.SOPHUS, C.BARFOOT], ids=lambda c: c.name
)
def test_gtsam_marginal_covariance_rejects_other_tangents(wrong: Convention) -> None:
    """The same statistic rejects reading the marginal as a left, (v, ω) or Barfoot tangent."""
    run = _gtsam_marginal_run()
    S_emp = np.cov(wrong.local(run.X_hat, run.samples).T)
    assert _whitened_gap(S_emp, run.cov) > MC_WRONG


# --------------------------------------------------------------------------- pytransform3d concat


def _pt_concat_case(kind: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, Convention]:
    """Monte Carlo of pytransform3d's concatenation: (its mean, its cov, samples, convention)."""
    rng = np.random.default_rng(1010 if kind == "global" else 1111)
    A2B = pose(rot(np.array([0.4, -1.1, 2.0])), np.array([25.0, -12.0, 8.0]))
    B2C = pose(rot(np.array([0.9, 0.3, -0.5])), np.array([4.0, -2.0, 1.5]))
    S1 = _correlated_cov(rng, 0.01, 0.05)
    S2 = _correlated_cov(rng, 0.01, 0.05)
    n1 = rng.multivariate_normal(np.zeros(6), S1, size=N_MC)
    n2 = rng.multivariate_normal(np.zeros(6), S2, size=N_MC)
    if kind == "global":
        # T_A2B = Exp(ξ_B)·T̄_A2B, cov_A2B in frame B; T_B2C likewise in C; result in C
        conv = C.PYTRANSFORM3D_GLOBAL
        mean, cov = pu.concat_globally_uncertain_transforms(A2B, S1, B2C, S2)
    else:
        # T_A2B = T̄_A2B·Exp(ξ_A) (cov_A), T_B2C = T̄_B2C·Exp(ξ_B) (cov_B); result in frame A
        conv = C.PYTRANSFORM3D_LOCAL
        mean, cov = pu.concat_locally_uncertain_transforms(A2B, B2C, S1, S2)
    np.testing.assert_allclose(mean, B2C @ A2B, rtol=0, atol=TOL)
    T = conv.retract(B2C, n2) @ conv.retract(A2B, n1)
    return mean, cov, T, conv


@pytest.mark.parametrize("kind", ["global", "local"])
def test_pytransform3d_concat_uncertain_transforms(kind: str) -> None:
    """``concat_{globally,locally}_uncertain_transforms`` covariances are in the preset's tangent.

    Samples are drawn with the preset's retract (checked against pytransform3d's exponential
    coordinates above), composed, and read with the preset's local at the returned mean. Its
    covariance is a 4th-order (global) / 2nd-order (local) approximation; with σ_rot = 0.01 the
    approximation error is far below the sampling error (see ``MC_TOL``). A wrong side or order
    is rejected by the same statistic.
    """
    mean, cov, T, conv = _pt_concat_case(kind)
    S_emp = np.cov(conv.local(mean, T).T)
    gap = _whitened_gap(S_emp, cov)
    assert gap <= MC_TOL, f"{conv.name}: whitened gap {gap:.3g}"
    # the same samples read with the other side, or with (v, ω) order, do not match
    other_side = C.PYTRANSFORM3D_LOCAL if kind == "global" else C.PYTRANSFORM3D_GLOBAL
    other_order = C.BARFOOT if kind == "global" else C.SOPHUS  # same side, (v, ω)
    for wrong in (other_side, other_order):
        gap_wrong = _whitened_gap(np.cov(wrong.local(mean, T).T), cov)
        assert gap_wrong > MC_WRONG, f"{wrong.name} not rejected: {gap_wrong:.3g}"


# --------------------------------------------------------------------------- detection


def _sm_right(X: np.ndarray, d: np.ndarray) -> np.ndarray:
    # spatialmath has no retraction; X·exp(Twist3(S)) reads d in Twist3's own storage order
    return np.asarray(X @ Twist3(d).exp().A)


DETECTIONS: tuple[tuple[str, str, Fn, str | None, Convention], ...] = (
    ("gtsam.Pose3.retract", "se3", _gtsam_retract, None, C.GTSAM),
    ("gtsam.Pose3 (object returned)", "se3", lambda X, d: gtsam.Pose3(X).retract(d), None, C.GTSAM),
    ("gtsam.Rot3.retract", "so3", _rot3_retract, None, C.GTSAM),
    ("pin.integrate(free-flyer)", "se3", _pin_ff_integrate, "pinocchio", C.PINOCCHIO),
    ("pin.liegroups.SE3.integrate", "se3", _pin_se3_integrate, "pinocchio", C.PINOCCHIO),
    ("pin.liegroups.SO3.integrate", "so3", _pin_so3_integrate, "pinocchio", C.PINOCCHIO),
    ("(R3×SO3).integrate", "se3", _r3xso3_integrate, None, C.PINOCCHIO_R3XSO3),
    ("pt Exp(d)·X", "se3", _pt_global_retract, "pytransform3d_global", C.PYTRANSFORM3D_GLOBAL),
    ("pt X·Exp(d)", "se3", _pt_local_retract, "pytransform3d_local", C.PYTRANSFORM3D_LOCAL),
    (
        "scipy RigidTransform X * from_exp_coords(d)",
        "se3",
        lambda X, d: (
            RigidTransform.from_matrix(X) * RigidTransform.from_exp_coords(d)
        ).as_matrix(),
        None,
        C.GTSAM,
    ),
    (
        "scipy Rotation R * from_rotvec(d)",
        "so3",
        lambda R, d: (Rotation.from_matrix(R) * Rotation.from_rotvec(d)).as_matrix(),
        None,
        C.GTSAM,
    ),
    ("spatialmath X·Twist3(d).exp()", "se3", _sm_right, "pinocchio", C.PINOCCHIO),
)


@pytest.mark.parametrize(
    ("what", "group", "fn", "prefer", "expected"), DETECTIONS, ids=[d[0] for d in DETECTIONS]
)
def test_detect_convention_on_library(
    what: str, group: str, fn: Fn, prefer: str | None, expected: Convention
) -> None:
    """``detect_convention`` names the preset of each library's own retraction."""
    found = detect_convention(fn, group=group, prefer=prefer)  # type: ignore[arg-type]
    if group == "so3":  # only side and rotation coordinates are measurable on a rotation
        assert (found.side, found.rotation) == (expected.side, expected.rotation)
    assert found.fields == expected.fields, found.describe()
    assert found == expected and found.name == expected.name, found.describe()


def test_detect_without_prefer_returns_first_equivalent_preset() -> None:
    """Pinocchio's free-flyer has Sophus's fields; without ``prefer`` the first one is returned."""
    found = detect_convention(_pin_ff_integrate)
    assert found.fields == C.PINOCCHIO.fields
    assert found.name in {c.name for c in C.matching_presets(C.PINOCCHIO)}


def _parse_matrix(msg: str, n: int) -> np.ndarray:
    block = msg.split("probe pose:")[1].split("closest")[0]
    nums = re.findall(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?", block)
    assert len(nums) == n * n, block
    return np.array([float(x) for x in nums]).reshape(n, n)


NOT_IN_MODEL: tuple[tuple[str, str, Fn, np.ndarray], ...] = (
    (
        "gtsam Pose3 with translation ×2",
        "se3",
        lambda X, d: gtsam.Pose3(X).retract(np.r_[d[:3], 2.0 * d[3:]]).matrix(),
        np.diag([1.0, 1.0, 1.0, 2.0, 2.0, 2.0]),
    ),
    (
        "gtsam Rot3 with angle ×3",
        "so3",
        lambda R, d: gtsam.Rot3(R).retract(3.0 * d).matrix(),
        3.0 * np.eye(3),
    ),
)


@pytest.mark.parametrize(
    ("what", "group", "fn", "map_"), NOT_IN_MODEL, ids=[c[0] for c in NOT_IN_MODEL]
)
def test_detect_reports_measured_map_for_unknown_retraction(
    what: str, group: str, fn: Fn, map_: np.ndarray
) -> None:
    """A retraction outside the model raises, and the message carries the measured map."""
    with pytest.raises(ConventionNotDetected) as info:
        detect_convention(fn, group=group)  # type: ignore[arg-type]
    M = _parse_matrix(str(info.value), len(map_))
    # printed with 4 significant digits; the finite-difference error is ~1e-10
    np.testing.assert_allclose(M, map_, rtol=0, atol=1e-3)
