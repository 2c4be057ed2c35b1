"""Quaternions: explicit storage order, Hamilton product, scipy/GTSAM agreement, slerp, JPL.

Tolerance ``TOL = 1e-12`` (absolute) for every comparison of unit quaternions or rotation matrices
(entries bounded by 1). The computations are a few products and one square root; measured
≤ 1e-15. At θ = π (w = 0) q and −q are both canonical, so those comparisons are up to sign.
"""

from __future__ import annotations

import functools
import math

import _strategies as S
import gtsam
import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from liebridge.lie import quaternion as Q
from liebridge.lie import so3

pytestmark = pytest.mark.filterwarnings("error")

TOL = 1e-12
ORDERS = ("wxyz", "xyzw")


def _to_order(q_wxyz: np.ndarray, order: str) -> np.ndarray:
    return q_wxyz if order == "wxyz" else np.roll(q_wxyz, -1, axis=-1)


def _to_wxyz(q: np.ndarray, order: str) -> np.ndarray:
    return q if order == "wxyz" else np.roll(q, 1, axis=-1)


@st.composite
def unit_quaternions(draw: st.DrawFn) -> np.ndarray:
    """Unit quaternions (w, x, y, z), any sign, including w = 0 and w = ±1."""
    special = draw(st.integers(0, 5))
    if special == 0:
        return np.array([0.0, *draw(S.unit_vectors())])  # θ = π
    if special == 1:
        return np.array([draw(st.sampled_from([1.0, -1.0])), 0.0, 0.0, 0.0])
    c = st.floats(-1.0, 1.0)
    q = np.array([draw(c), draw(c), draw(c), draw(c)])
    assume(np.linalg.norm(q) > 1e-3)
    return q / np.linalg.norm(q)


def _assert_same_up_to_sign(a: np.ndarray, b: np.ndarray, what: str = "") -> None:
    err = min(np.abs(a - b).max(), np.abs(a + b).max())
    assert err < TOL, f"{what}: {a} vs {b} (err {err})"


# --------------------------------------------------------------------------- to/from matrix


@pytest.mark.parametrize("order", ORDERS)
@given(q=unit_quaternions())
def test_to_matrix_matches_scipy_and_gtsam(order: str, q: np.ndarray) -> None:
    R = Q.to_matrix(_to_order(q, order), order=order)
    np.testing.assert_allclose(
        R, Rotation.from_quat(q, scalar_first=True).as_matrix(), rtol=0, atol=TOL
    )
    np.testing.assert_allclose(R, Rotation.from_quat(np.roll(q, -1)).as_matrix(), rtol=0, atol=TOL)
    np.testing.assert_allclose(R, gtsam.Rot3.Quaternion(*q).matrix(), rtol=0, atol=TOL)


def test_storage_orders_differ() -> None:
    # the same four numbers read in the two orders are different rotations: order matters
    q = np.array([0.5, 0.5, 0.5, 0.5]) * np.array([1.0, 1.0, -1.0, 1.0])
    assert np.abs(Q.to_matrix(q, order="wxyz") - Q.to_matrix(q, order="xyzw")).max() > 0.5


@pytest.mark.parametrize("order", ORDERS)
@given(R=S.rotations())
def test_from_matrix_matches_scipy_and_gtsam(order: str, R: np.ndarray) -> None:
    q = _to_wxyz(Q.from_matrix(R, order=order), order)
    assert q[0] >= 0.0
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, rtol=0, atol=TOL)
    g = gtsam.Rot3(R).toQuaternion()
    _assert_same_up_to_sign(q, np.array([g.w(), g.x(), g.y(), g.z()]), "gtsam")
    np.testing.assert_allclose(g.coeffs(), [g.x(), g.y(), g.z(), g.w()])  # gtsam stores xyzw
    _assert_same_up_to_sign(q, Rotation.from_matrix(R).as_quat(scalar_first=True), "scipy")
    # to_matrix is independent code (closed polynomial form): round trip
    np.testing.assert_allclose(Q.to_matrix(q, order="wxyz"), R, rtol=0, atol=TOL)


@given(q=unit_quaternions())
def test_from_matrix_to_matrix_roundtrip_is_canonical(q: np.ndarray) -> None:
    back = Q.from_matrix(Q.to_matrix(q, order="wxyz"), order="wxyz")
    if abs(q[0]) > 1e-6:
        np.testing.assert_allclose(back, np.sign(q[0]) * q, rtol=0, atol=TOL)
    else:
        _assert_same_up_to_sign(back, q)


@pytest.mark.parametrize("order", ORDERS)
@given(q=unit_quaternions())
def test_canonical_sign(order: str, q: np.ndarray) -> None:
    qo = _to_order(q, order)
    c = _to_wxyz(Q.canonical(qo, order=order), order)
    assert c[0] >= 0.0
    _assert_same_up_to_sign(c, q)
    if q[0] != 0.0:
        np.testing.assert_array_equal(Q.canonical(-qo, order=order), Q.canonical(qo, order=order))


# --------------------------------------------------------------------------- Hamilton product


@pytest.mark.parametrize("order", ORDERS)
@given(R1=S.rotations(), R2=S.rotations())
def test_hamilton_property(order: str, R1: np.ndarray, R2: np.ndarray) -> None:
    q1, q2 = Q.from_matrix(R1, order=order), Q.from_matrix(R2, order=order)
    prod = Q.multiply(q1, q2, order=order)
    # q(R1 R2) = q(R1) ⊗ q(R2) (up to the sign of the double cover)
    _assert_same_up_to_sign(prod, Q.from_matrix(R1 @ R2, order=order), "q(R1R2)")
    np.testing.assert_allclose(Q.to_matrix(prod, order=order), R1 @ R2, rtol=0, atol=TOL)
    # and GTSAM composes quaternions the same way
    g = (gtsam.Rot3(R1) * gtsam.Rot3(R2)).toQuaternion()
    _assert_same_up_to_sign(_to_wxyz(prod, order), np.array([g.w(), g.x(), g.y(), g.z()]))


def test_multiply_is_not_jpl() -> None:
    # i ⊗ j = k for Hamilton (JPL has i ⊗ j = −k)
    i, j = np.array([0.0, 1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, 0.0])
    np.testing.assert_array_equal(Q.multiply(i, j, order="wxyz"), [0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize("order", ORDERS)
@given(q=unit_quaternions())
def test_conjugate_is_inverse(order: str, q: np.ndarray) -> None:
    qo = _to_order(q, order)
    c = Q.conjugate(qo, order=order)
    np.testing.assert_allclose(
        Q.multiply(qo, c, order=order), _to_order(np.array([1.0, 0, 0, 0]), order), atol=TOL
    )
    np.testing.assert_allclose(
        Q.to_matrix(c, order=order), Q.to_matrix(qo, order=order).T, rtol=0, atol=TOL
    )


# --------------------------------------------------------------------------- slerp


def _geodesic(R0: np.ndarray, R1: np.ndarray, tau: float) -> np.ndarray:
    """``R0·Exp(τ·Log(R0ᵀ R1))`` with scipy's rotation vectors (independent of liebridge)."""
    rel = Rotation.from_matrix(R0.T @ R1).as_rotvec()
    return R0 @ Rotation.from_rotvec(tau * rel).as_matrix()


@pytest.mark.parametrize("order", ORDERS)
@given(q0=unit_quaternions(), q1=unit_quaternions(), tau=st.floats(0.0, 1.0))
def test_slerp_matches_scipy_and_takes_short_arc(
    order: str, q0: np.ndarray, q1: np.ndarray, tau: float
) -> None:
    dot = float(q0 @ q1)
    assume(abs(dot) > 1e-6)  # relative rotation of exactly π: the geodesic is not unique
    a, b = _to_order(q0, order), _to_order(q1, order)
    R0, R1 = Q.to_matrix(a, order=order), Q.to_matrix(b, order=order)
    for bb in (b, -b):  # either sign of q1 is the same rotation: the result must not depend on it
        out = Q.slerp(a, bb, tau, order=order)
        np.testing.assert_allclose(np.linalg.norm(out), 1.0, rtol=0, atol=TOL)
        R = Q.to_matrix(out, order=order)
        np.testing.assert_allclose(R, _geodesic(R0, R1, tau), rtol=0, atol=1e-11)
        ref = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([R0, R1])))([tau]).as_matrix()[0]
        np.testing.assert_allclose(R, ref, rtol=0, atol=1e-11)
    # the endpoints
    np.testing.assert_allclose(Q.slerp(a, b, 0.0, order=order), a, rtol=0, atol=TOL)
    _assert_same_up_to_sign(Q.slerp(a, b, 1.0, order=order), b)


def test_slerp_short_arc_when_dot_negative() -> None:
    # q1 and −q1 are the same rotation; with dot(q0, q1) < 0 a naive slerp would pass through the
    # rotation "on the long way round" (angle > π/2 from both ends). The geodesic midpoint is at
    # half the relative angle from each end.
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    half = 0.5 * 2.5  # rotation by 2.5 rad about z
    q1 = -np.array([math.cos(half), 0.0, 0.0, math.sin(half)])
    assert q0 @ q1 < 0
    m = Q.slerp(q0, q1, 0.5, order="wxyz")
    R_mid = Q.to_matrix(m, order="wxyz")
    np.testing.assert_allclose(R_mid, so3.exp([0.0, 0.0, 1.25]), rtol=0, atol=TOL)
    np.testing.assert_allclose(
        R_mid, _geodesic(np.eye(3), so3.exp([0.0, 0.0, 2.5]), 0.5), rtol=0, atol=TOL
    )


def test_slerp_broadcasts_tau_and_batches() -> None:
    rng = np.random.default_rng(0)
    q0 = rng.normal(size=(3, 4))
    q0 /= np.linalg.norm(q0, axis=-1, keepdims=True)
    q1 = rng.normal(size=(3, 4))
    q1 /= np.linalg.norm(q1, axis=-1, keepdims=True)
    taus = np.array([[0.0], [0.25], [1.0]]) * np.ones((3, 3))
    out = Q.slerp(q0, q1, taus, order="xyzw")
    assert out.shape == (3, 3, 4)
    for i in range(3):
        for j in range(3):
            np.testing.assert_allclose(
                out[i, j], Q.slerp(q0[j], q1[j], taus[i, j], order="xyzw"), rtol=0, atol=1e-15
            )


# --------------------------------------------------------------------------- JPL


def _jpl_matrix(q: np.ndarray) -> np.ndarray:
    """Trawny & Roumeliotis (2005), TR 2005-002: ``C(q̄) = (2q₄² − 1)I − 2q₄⌊q×⌋ + 2qqᵀ``.

    ``q = (q₁, q₂, q₃, q₄)`` with the scalar last, as JPL stores it.
    """
    v, s = q[:3], q[3]
    cross = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return (2 * s * s - 1) * np.eye(3) - 2 * s * cross + 2 * np.outer(v, v)


@given(q=unit_quaternions())
def test_jpl_to_hamilton(q: np.ndarray) -> None:
    q_jpl = np.roll(q, -1)  # the four numbers, scalar last
    C = _jpl_matrix(q_jpl)
    for order in ORDERS:
        stored = q_jpl if order == "xyzw" else np.roll(q_jpl, 1)
        h = Q.jpl_to_hamilton(stored, order=order)
        np.testing.assert_allclose(Q.to_matrix(h, order=order), C, rtol=0, atol=TOL)
        np.testing.assert_allclose(Q.hamilton_to_jpl(h, order=order), stored, rtol=0, atol=0)
    # C(q̄) is the transpose of the Hamilton matrix of the same numbers (so the test can fail)
    np.testing.assert_allclose(C, Q.to_matrix(q_jpl, order="xyzw").T, rtol=0, atol=TOL)


def test_jpl_differs_from_hamilton_for_a_generic_quaternion() -> None:
    q = np.array([0.1, 0.2, 0.3, math.sqrt(1 - 0.14)])
    assert np.abs(_jpl_matrix(q) - Q.to_matrix(q, order="xyzw")).max() > 0.1


# --------------------------------------------------------------------------- order validation

_QUAT_CALLS = {
    "to_matrix": lambda order: Q.to_matrix([1.0, 0, 0, 0], order=order),
    "from_matrix": lambda order: Q.from_matrix(np.eye(3), order=order),
    "multiply": lambda order: Q.multiply([1.0, 0, 0, 0], [1.0, 0, 0, 0], order=order),
    "conjugate": lambda order: Q.conjugate([1.0, 0, 0, 0], order=order),
    "canonical": lambda order: Q.canonical([1.0, 0, 0, 0], order=order),
    "slerp": lambda order: Q.slerp([1.0, 0, 0, 0], [1.0, 0, 0, 0], 0.5, order=order),
    "jpl_to_hamilton": lambda order: Q.jpl_to_hamilton([1.0, 0, 0, 0], order=order),
    "hamilton_to_jpl": lambda order: Q.hamilton_to_jpl([1.0, 0, 0, 0], order=order),
}


def test_every_public_function_validates_order() -> None:
    assert set(_QUAT_CALLS) == set(Q.__all__)


@pytest.mark.parametrize("name", sorted(_QUAT_CALLS))
def test_order_is_read_like_every_string_option(name: str) -> None:
    """Case and surrounding spaces do not matter (as for preset names, layouts, methods)."""
    for good in ORDERS:
        np.testing.assert_array_equal(
            _QUAT_CALLS[name](f" {good.upper()} "), _QUAT_CALLS[name](good)
        )


@pytest.mark.parametrize("bad", ["xyz", "qxyzw", "", "w x y z"])
@pytest.mark.parametrize("name", sorted(_QUAT_CALLS))
def test_order_validation_error(name: str, bad: str) -> None:
    for good in ORDERS:
        _QUAT_CALLS[name](good)
    allowed = r"'wxyz' or 'xyzw'" if "jpl" in name else r"one of 'wxyz', 'xyzw', 'jpl'"
    with pytest.raises(ValueError, match=rf"order: expected {allowed}"):
        _QUAT_CALLS[name](bad)


def test_order_is_required() -> None:
    with pytest.raises(TypeError):
        Q.to_matrix([1.0, 0, 0, 0])  # type: ignore[call-arg]


# --------------------------------------------------------------------------- batching, mutation


def _q(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    q = rng.normal(size=(*shape, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _rot(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return S.random_rotations(rng, shape)


def _tau(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(0.0, 1.0, size=shape)


QUAT_PUBLIC = {
    "canonical": (Q.canonical, [_q]),
    "conjugate": (Q.conjugate, [_q]),
    "from_matrix": (Q.from_matrix, [_rot]),
    "hamilton_to_jpl": (Q.hamilton_to_jpl, [_q]),
    "jpl_to_hamilton": (Q.jpl_to_hamilton, [_q]),
    "multiply": (Q.multiply, [_q, _q]),
    "slerp": (Q.slerp, [_q, _q, _tau]),
    "to_matrix": (Q.to_matrix, [_q]),
}


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("batch", S.BATCH_SHAPES, ids=str)
@pytest.mark.parametrize("name", sorted(QUAT_PUBLIC))
def test_batched_equals_elementwise(name: str, batch: tuple[int, ...], order: str) -> None:
    fn, makers = QUAT_PUBLIC[name]
    rng = np.random.default_rng(len(name) + 7 * len(batch))
    S.assert_batched_equals_elementwise(
        functools.partial(fn, order=order), *(m(rng, batch) for m in makers), batch=batch
    )


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("name", sorted(QUAT_PUBLIC))
def test_inputs_not_mutated_and_outputs_float64(name: str, order: str) -> None:
    fn, makers = QUAT_PUBLIC[name]
    rng = np.random.default_rng(3)
    args = [m(rng, (4,)) for m in makers]
    copies = [a.copy() for a in args]
    for a in args:
        a.setflags(write=False)
    out = fn(*args, order=order)
    for a, c in zip(args, copies, strict=True):
        np.testing.assert_array_equal(a, c)
        assert not np.shares_memory(out, a), "output aliases the input"
    assert out.dtype == np.float64
