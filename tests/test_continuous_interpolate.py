"""Interpolation between two poses: endpoints, Jacobians (every SE(3) preset), edge cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation, Slerp

from liebridge.check import numerical_jacobian
from liebridge.continuous import interpolate
from liebridge.conventions import PRESETS, get

SE3_PRESETS = [c.name for c in PRESETS if c.group == "se3"]
RNG = np.random.default_rng(20261127)


def _pose(rotvec: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = t
    return T


def _pair(angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Two poses whose relative rotation turns by ``angle`` about a random axis."""
    axis = RNG.normal(size=3)
    axis /= np.linalg.norm(axis)
    T0 = _pose(RNG.normal(size=3), RNG.normal(size=3) * 3.0)
    T1 = T0 @ _pose(angle * axis, RNG.normal(size=3) * 2.0)
    return T0, T1


ANGLES = [0.0, 1e-9, 0.7, 2.5, math.pi - 1e-3]


@pytest.mark.parametrize("method", ["se3", "split"])
@pytest.mark.parametrize("angle", ANGLES)
def test_endpoints_are_exact(method: str, angle: float) -> None:
    T0, T1 = _pair(angle)
    out = interpolate(T0, T1, [0.0, 1.0], method=method)
    assert np.array_equal(out.T[0], T0)
    assert np.array_equal(out.T[1], T1)
    # and the formula itself, not only the substitution, is within 1e-15 of them
    near = interpolate(T0, T1, [1e-300, 1.0 - 1e-16], method=method, jacobians=False).T
    assert np.abs(near[0] - T0).max() < 1e-14
    assert np.abs(near[1] - T1).max() < 1e-13


@pytest.mark.parametrize("conv", SE3_PRESETS)
@pytest.mark.parametrize("method", ["se3", "split"])
@pytest.mark.parametrize("angle", [0.0, 0.9, math.pi - 1e-3])
@pytest.mark.parametrize("tau", [0.0, 0.37, 1.0, 1.3])
def test_jacobians_match_central_differences(
    conv: str, method: str, angle: float, tau: float
) -> None:
    c = get(conv)
    T0, T1 = _pair(angle)
    out = interpolate(T0, T1, tau, method=method, convention=c)
    f0 = lambda X: interpolate(X, T1, tau, method=method, jacobians=False).T  # noqa: E731
    f1 = lambda X: interpolate(T0, X, tau, method=method, jacobians=False).T  # noqa: E731
    N0 = numerical_jacobian(f0, T0, in_convention=c, out_convention=c, eps=1e-7)
    N1 = numerical_jacobian(f1, T1, in_convention=c, out_convention=c, eps=1e-7)
    assert out.J_T_T0 is not None and out.J_T_T1 is not None and out.J_T_tau is not None
    np.testing.assert_allclose(out.J_T_T0, N0, atol=2e-6)
    np.testing.assert_allclose(out.J_T_T1, N1, atol=2e-6)
    h = 1e-7
    Tp = interpolate(T0, T1, tau + h, method=method, jacobians=False).T
    Tm = interpolate(T0, T1, tau - h, method=method, jacobians=False).T
    Nt = (c.local(out.T, Tp) - c.local(out.T, Tm)) / (2 * h)
    np.testing.assert_allclose(out.J_T_tau, Nt, atol=2e-6)


def test_jacobians_are_not_the_linear_weights() -> None:
    """The tempting (1 − τ)·I, τ·I holds without motion (and, for "split", for a pure
    translation); a pure translation already couples the "se3" Jacobian's blocks."""
    T0, T1 = _pair(1.2)
    out = interpolate(T0, T1, 0.3)
    assert np.abs(out.J_T_T1 - 0.3 * np.eye(6)).max() > 1e-2
    Tt = np.eye(4)
    Tt[:3, 3] = [1.0, 2.0, 3.0]
    lin = interpolate(np.eye(4), Tt, 0.3, method="split")
    np.testing.assert_allclose(lin.J_T_T1, 0.3 * np.eye(6), atol=1e-15)
    np.testing.assert_allclose(lin.J_T_T0, 0.7 * np.eye(6), atol=1e-15)
    assert np.abs(interpolate(np.eye(4), Tt, 0.3).J_T_T1 - 0.3 * np.eye(6)).max() > 0.1
    still = interpolate(Tt, Tt, 0.3)
    np.testing.assert_allclose(still.J_T_T1, 0.3 * np.eye(6), atol=1e-15)


def test_batched_over_tau_and_pairs() -> None:
    A = np.stack([_pair(0.5)[0] for _ in range(3)])
    B = np.stack([_pair(0.5)[1] for _ in range(3)])
    tau = np.array([[0.1], [0.6]])  # (2, 1) × (3,) → (2, 3)
    out = interpolate(A, B, tau, method="split", convention="sophus")
    assert out.T.shape == (2, 3, 4, 4) and out.J_T_T0.shape == (2, 3, 6, 6)
    one = interpolate(A[2], B[2], 0.6, method="split", convention="sophus")
    np.testing.assert_allclose(out.T[1, 2], one.T, atol=1e-15)
    np.testing.assert_allclose(out.J_T_T0[1, 2], one.J_T_T0, atol=1e-14)


def test_split_matches_scipy_slerp_and_lerp() -> None:
    T0, T1 = _pair(2.9)
    taus = np.linspace(0, 1, 9)
    out = interpolate(T0, T1, taus, method="split", jacobians=False).T
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]])))
    np.testing.assert_allclose(out[:, :3, :3], slerp(taus).as_matrix(), atol=1e-12)
    lerp = (1 - taus)[:, None] * T0[:3, 3] + taus[:, None] * T1[:3, 3]
    np.testing.assert_allclose(out[:, :3, 3], lerp, atol=1e-12)


def test_split_spin_takes_the_short_way_across_antipodal_quaternions() -> None:
    """A 360° spin sampled every 90°: stored quaternions flip sign (q and −q are one rotation),
    and SLERP on raw quaternions would then go the long way (−270°)."""
    stamps = np.linspace(0.0, 2 * math.pi, 5)
    q = Rotation.from_rotvec(stamps[:, None] * np.array([0.0, 0.0, 1.0])).as_quat()
    q[2:] *= -1.0  # what a file may hold: the same rotations, sign-flipped
    Rm = Rotation.from_quat(q).as_matrix()
    for k in range(4):
        T0, T1 = np.eye(4), np.eye(4)
        T0[:3, :3], T1[:3, :3] = Rm[k], Rm[k + 1]
        mid = interpolate(T0, T1, 0.5, method="split", jacobians=False).T
        expected = Rotation.from_rotvec([0, 0, stamps[k] + math.pi / 4]).as_matrix()
        np.testing.assert_allclose(mid[:3, :3], expected, atol=1e-12)


def test_se3_and_split_differ_when_the_rotation_turns() -> None:
    T0, T1 = _pair(1.5)
    a = interpolate(T0, T1, 0.5, "se3", jacobians=False).T
    b = interpolate(T0, T1, 0.5, "split", jacobians=False).T
    np.testing.assert_allclose(a[:3, :3], b[:3, :3], atol=1e-12)  # same rotation
    assert np.linalg.norm(a[:3, 3] - b[:3, 3]) > 1e-2  # helix vs chord


def test_bad_input_is_named() -> None:
    with pytest.raises(ValueError, match="method"):
        interpolate(np.eye(4), np.eye(4), 0.5, method="slerp")
    with pytest.raises(ValueError, match="tau"):
        interpolate(np.eye(4), np.eye(4), [0.5, np.nan])
    with pytest.raises(ValueError, match="T1"):
        interpolate(np.eye(4), np.ones((4, 4)), 0.5)
    with pytest.raises(ValueError, match="do not broadcast"):
        interpolate(np.stack([np.eye(4)] * 3), np.eye(4), [0.1, 0.2])
    with pytest.raises(ValueError, match="SE\\(3\\) convention"):
        interpolate(np.eye(4), np.eye(4), 0.5, convention="gtsam_pose2")


@pytest.mark.parametrize("method", ["se3", "split"])
def test_exactly_pi_relative_rotation(method: str) -> None:
    """At exactly π the two half-way rotations ±π/2 are both geodesic; either is accepted, the
    endpoints stay exact and nothing is NaN."""
    axis = np.array([0.0, 0.6, 0.8])
    T0 = _pose(np.array([0.3, -0.2, 0.1]), np.array([1.0, 2.0, 3.0]))
    T1 = T0.copy()
    T1[:3, :3] = T0[:3, :3] @ (2 * np.outer(axis, axis) - np.eye(3))  # exactly π about axis
    out = interpolate(T0, T1, [0.0, 0.5, 1.0], method=method)
    assert np.array_equal(out.T[0], T0) and np.array_equal(out.T[2], T1)
    assert np.isfinite(out.J_T_T0).all() and np.isfinite(out.J_T_T1).all()
    rel = Rotation.from_matrix(T0[:3, :3].T @ out.T[1, :3, :3]).as_rotvec()
    assert min(np.abs(rel - np.pi / 2 * axis).max(), np.abs(rel + np.pi / 2 * axis).max()) < 1e-9


@settings(max_examples=25, deadline=None)
@given(
    xi0=arrays(np.float64, 6, elements=st.floats(-2.0, 2.0)),
    xi1=arrays(np.float64, 6, elements=st.floats(-1.0, 1.0)),
    tau=st.floats(-0.5, 1.5),
    method=st.sampled_from(["se3", "split"]),
)
def test_jacobians_property(xi0: np.ndarray, xi1: np.ndarray, tau: float, method: str) -> None:
    from liebridge.lie import se3

    T0 = se3.exp(xi0)
    T1 = T0 @ se3.exp(xi1)  # relative rotation below √3 rad
    out = interpolate(T0, T1, tau, method=method, convention="barfoot")
    c = get("barfoot")
    N1 = numerical_jacobian(
        lambda X: interpolate(T0, X, tau, method=method, jacobians=False).T,
        T1,
        in_convention=c,
        out_convention=c,
    )
    np.testing.assert_allclose(out.J_T_T1, N1, atol=1e-5)


def test_string_options_ignore_case_and_spaces() -> None:
    """Every string option of liebridge reads "SE3", " se3 " and "se3" as one value."""
    from liebridge.continuous import Spline, deskew
    from liebridge.lie import se3

    T0, T1 = _pair(1.0)
    for a, b in (("SE3", "se3"), (" Split ", "split")):
        np.testing.assert_array_equal(
            interpolate(T0, T1, 0.3, method=a).T, interpolate(T0, T1, 0.3, method=b).T
        )
    pts = np.ones((3, 3))
    st = np.array([0.0, 0.05, 0.1])
    np.testing.assert_array_equal(
        deskew(pts, st, T0, T1, " CT_ICP ").points, deskew(pts, st, T0, T1, "ct_icp").points
    )
    np.testing.assert_array_equal(
        deskew(pts, st, T0, T1, "Generic", reference=" MID ", method="SPLIT").points,
        deskew(pts, st, T0, T1, "generic", reference="mid", method="split").points,
    )
    K = se3.exp(np.random.default_rng(0).normal(size=(5, 6)) * 0.3)
    sp = Spline(K, 0.0, 1.0, 4, " Split ", form="PRODUCT")
    assert sp.kind == "split" and sp.form == "product"
    assert Spline.from_preset("Kontiki", K, 0.0, 1.0).preset == "kontiki"
