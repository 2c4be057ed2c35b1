"""The rotation-coordinate layer on numpy, torch and JAX: quaternions, hat/vee, rotation coords.

One harness over the backends (numpy is the reference; torch and JAX run when installed: the
extras ``torch`` and ``jax``): :mod:`liebridge.lie.quaternion` in every storage order, the
``hat``/``vee``/``ad`` of the array-API groups, the Cayley, quaternion-vector and Euler-angle
coordinates of :mod:`liebridge.conventions.rotation_coords` and the conventions built on them.
Expected values come from numpy (itself checked elsewhere) and, for the quaternions, from scipy's
``Rotation`` (``xyzw``) run on the values the tensors return.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

import liebridge as lb
from liebridge import arrays
from liebridge.conventions import Convention
from liebridge.conventions import rotation_coords as rc
from liebridge.lie import quaternion as Q
from liebridge.lie import se2, se3, se23, so2, so3

HAS = {name: importlib.util.find_spec(name) is not None for name in ("torch", "jax")}
BACKENDS = [
    "numpy",
    pytest.param("torch", marks=pytest.mark.skipif(not HAS["torch"], reason="torch extra")),
    pytest.param("jax", marks=pytest.mark.skipif(not HAS["jax"], reason="jax extra")),
]
#: float64 agreement with numpy; float32 (documented in docs/tensors.md): relative to the scale
TOL64, TOL32 = 1e-12, 2e-5
ORDERS = ["wxyz", "xyzw", "jpl"]
SHAPES = [(), (10,), (2, 5)]


@pytest.fixture
def x64() -> Iterator[None]:
    """JAX in float64 for the test (restored after)."""
    if not HAS["jax"]:
        yield
        return
    import jax

    old = bool(jax.config.read("jax_enable_x64"))
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", old)


class Backend:
    """Make arrays of one library and read them back."""

    def __init__(self, name: str, dtype: str = "float64") -> None:
        self.name, self.dtype = name, dtype

    def __call__(self, a: Any) -> Any:
        a = np.asarray(a, dtype=np.float64)
        if self.name == "numpy":
            return a.astype(self.dtype)
        if self.name == "torch":
            import torch

            return torch.tensor(a, dtype=getattr(torch, self.dtype))
        import jax.numpy as jnp

        return jnp.asarray(a, dtype=getattr(jnp, self.dtype))

    def check(self, out: Any) -> np.ndarray:
        """``out`` is of this backend (and dtype); return it as float64 numpy."""
        if self.name == "numpy":
            assert isinstance(out, np.ndarray)
        else:
            assert arrays.backend_of(out) == self.name, type(out)
            assert str(out.dtype).endswith(self.dtype), out.dtype
        return np.asarray(arrays.to_numpy(out), dtype=np.float64)


@pytest.fixture(params=BACKENDS)
def B(request: pytest.FixtureRequest, x64: None) -> Backend:
    return Backend(request.param)


def _close(out: np.ndarray, ref: np.ndarray, tol: float = TOL64) -> None:
    assert out.shape == ref.shape
    np.testing.assert_allclose(out, ref, rtol=0, atol=tol * max(1.0, np.abs(ref).max()))


def _batch(x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The first prod(shape) rows of ``x``, reshaped to ``shape`` (``()``: one element)."""
    n = int(np.prod(shape)) if shape else 1
    rows = x[np.arange(n) % len(x)]
    return rows.reshape((*shape, *x.shape[1:])) if shape else rows[0]


# ----------------------------------------------------------------------------- inputs
AXIS = np.array([0.48, -0.6, 0.64])


def _rotvecs() -> np.ndarray:
    """Identity, 1e-12, generic, half turns about x, y, z, a generic axis and two tie axes."""
    rng = np.random.default_rng(0)
    return np.stack(
        [
            np.zeros(3),
            1e-12 * AXIS,
            0.3 * AXIS,
            *rng.normal(size=(3, 3)),
            np.pi * np.array([1.0, 0.0, 0.0]),
            np.pi * np.array([0.0, 1.0, 0.0]),
            np.pi * np.array([0.0, 0.0, 1.0]),
            np.pi * AXIS,
            np.pi * np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0),  # R₀₀ = R₁₁: argmax's tie
            (np.pi - 1e-6) * AXIS,
        ]
    )


def _quats(order: str) -> np.ndarray:
    """Unit quaternions of :func:`_rotvecs` in ``order``, every other one with ``w < 0``."""
    q = Q.from_matrix(so3.exp(_rotvecs()), order=order)
    sign = np.where(np.arange(len(q)) % 2 == 1, -1.0, 1.0)
    return sign[:, None] * q


# ----------------------------------------------------------------------------- quaternions
@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize("order", ORDERS)
def test_quaternion_functions_same_values(B: Backend, order: str, shape: tuple[int, ...]) -> None:
    q1 = _batch(_quats(order), shape)
    q2 = _batch(_quats(order)[::-1].copy(), shape)
    R = _batch(so3.exp(_rotvecs()), shape)
    tau = _batch(np.linspace(-0.2, 1.3, 12), shape)
    cases = [
        (Q.to_matrix(B(q1), order=order), Q.to_matrix(q1, order=order)),
        (Q.from_matrix(B(R), order=order), Q.from_matrix(R, order=order)),
        (Q.multiply(B(q1), B(q2), order=order), Q.multiply(q1, q2, order=order)),
        (Q.conjugate(B(q1), order=order), Q.conjugate(q1, order=order)),
        (Q.canonical(B(q1), order=order), Q.canonical(q1, order=order)),
        (Q.slerp(B(q1), B(q2), 0.3, order=order), Q.slerp(q1, q2, 0.3, order=order)),
        (Q.slerp(B(q1), B(q2), B(tau), order=order), Q.slerp(q1, q2, tau, order=order)),
        (Q.slerp(B(q1), B(q1), 0.7, order=order), Q.slerp(q1, q1, 0.7, order=order)),
    ]
    if order != "jpl":
        cases += [
            (Q.jpl_to_hamilton(B(q1), order=order), Q.jpl_to_hamilton(q1, order=order)),
            (Q.hamilton_to_jpl(B(q1), order=order), Q.hamilton_to_jpl(q1, order=order)),
        ]
    for out, ref in cases:
        _close(B.check(out), ref)


def test_from_matrix_keeps_the_hemisphere_and_sign_at_half_turns(B: Backend) -> None:
    """``w ≥ 0``; at ``w = 0`` the selected formula's component is positive (scipy's choice)."""
    R = so3.exp(_rotvecs())
    q = B.check(Q.from_matrix(B(R), order="wxyz"))
    assert (q[:, 0] >= 0.0).all()
    np.testing.assert_allclose(q[6], [0.0, 1.0, 0.0, 0.0], atol=1e-15)  # half turn about x
    np.testing.assert_allclose(q[7], [0.0, 0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(q[8], [0.0, 0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(q[10], [0.0, 1.0, -1.0, 0.0] / np.sqrt(2.0), atol=1e-15)
    # exact half turns 2uuᵀ − I (w = 0 exactly: the sign is the selected formula's, and where
    # R₀₀ = R₁₁ ties, the first of them, as scipy's argmax)
    exact = np.stack([2.0 * np.outer(u, u) - np.eye(3) for u in _HALF_TURN_AXES])
    for order in ORDERS:
        _close(B.check(Q.from_matrix(B(exact), order=order)), Q.from_matrix(exact, order=order))
    q = B.check(Q.from_matrix(B(exact), order="wxyz"))
    np.testing.assert_array_equal(q[:, 0], 0.0)
    np.testing.assert_allclose(q[3], [0.0, 1.0, -1.0, 0.0] / np.sqrt(2.0), atol=1e-15)
    np.testing.assert_allclose(q[5], [0.0, 0.0, 1.0, -1.0] / np.sqrt(2.0), atol=1e-15)


_HALF_TURN_AXES = [
    np.array([1.0, 0.0, 0.0]),
    np.array([0.0, 1.0, 0.0]),
    np.array([0.0, 0.0, 1.0]),
    np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0),
    np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0),
    np.array([0.0, 1.0, -1.0]) / np.sqrt(2.0),
    np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0),
]


def test_from_matrix_of_a_slightly_non_orthogonal_matrix_equals_scipys_projection(
    B: Backend,
) -> None:
    """scipy projects onto SO(3) first (``U Vᵀ``); the tensor path's Newton step does the same.

    At the validation bound (``max|RᵀR − I|`` just below 1e-6), where one step is the least exact.
    """
    R0 = so3.exp(_rotvecs()[:6])  # (at a half turn w ≈ 0: its sign is not the projection's)
    S = np.random.default_rng(5).normal(size=(6, 3, 3))
    E = 1e-7 * (S + np.swapaxes(S, -1, -2))  # symmetric: the part a projection removes
    M = R0 @ (np.eye(3) + E)
    err = np.abs(np.swapaxes(M, -1, -2) @ M - np.eye(3)).max(axis=(-1, -2))
    R = R0 @ (np.eye(3) + E * (0.98e-6 / err)[:, None, None])
    for order in ORDERS:
        _close(B.check(Q.from_matrix(B(R), order=order)), Q.from_matrix(R, order=order))


def _up_to_sign(a: np.ndarray, b: np.ndarray, tol: float = 1e-12) -> None:
    s = np.where(np.sum(a * b, axis=-1) < 0.0, -1.0, 1.0)[..., None]
    np.testing.assert_allclose(a, s * b, rtol=0, atol=tol)


@pytest.mark.parametrize("backend", BACKENDS)
def test_quaternions_on_tensors_equal_scipy_rotation(backend: str, x64: None) -> None:
    """scipy's ``Rotation`` (Hamilton, ``xyzw``) as the oracle, on values read from the tensors."""
    from scipy.spatial.transform import Rotation, Slerp

    B = Backend(backend)
    R = so3.exp(_rotvecs())
    q = _quats("xyzw")
    p = q[::-1].copy()
    ref_R = Rotation.from_quat(q).as_matrix()
    np.testing.assert_allclose(B.check(Q.to_matrix(B(q), order="xyzw")), ref_R, atol=1e-14)
    wxyz = np.roll(q, 1, axis=-1)
    np.testing.assert_allclose(B.check(Q.to_matrix(B(wxyz), order="wxyz")), ref_R, atol=1e-14)
    # JPL: the same four numbers (x, y, z, w) are the inverse rotation
    jpl = B.check(Q.to_matrix(B(q), order="jpl"))
    np.testing.assert_allclose(jpl, np.swapaxes(ref_R, -1, -2), atol=1e-14)
    # from_matrix: scipy's quaternion up to its sign, with w ≥ 0
    out = B.check(Q.from_matrix(B(R), order="xyzw"))
    _up_to_sign(out, Rotation.from_matrix(R).as_quat())
    assert (out[:, 3] >= 0.0).all()
    # multiply: composition of rotations
    prod = B.check(Q.multiply(B(q), B(p), order="xyzw"))
    _up_to_sign(prod, (Rotation.from_quat(q) * Rotation.from_quat(p)).as_quat())
    jprod = B.check(Q.multiply(B(q), B(p), order="jpl"))  # C(q ⊗ p) = C(q) C(p)
    np.testing.assert_allclose(
        Rotation.from_quat(jprod).as_matrix().swapaxes(-1, -2),
        np.swapaxes(ref_R, -1, -2) @ Rotation.from_quat(p).as_matrix().swapaxes(-1, -2),
        atol=1e-13,
    )
    # slerp: scipy's Slerp between each pair (short arc)
    for tau in (0.0, 0.25, 0.7, 1.0):
        out = B.check(Q.slerp(B(q), B(p), tau, order="xyzw"))
        for k in range(len(q)):
            if np.isclose(abs(q[k] @ p[k]), 0.0, atol=1e-9):
                continue  # opposite rotations by π: two short arcs
            ref = Slerp([0.0, 1.0], Rotation.from_quat([q[k], p[k]]))([tau]).as_quat()[0]
            _up_to_sign(out[k], ref, 1e-11)


@pytest.mark.parametrize("backend", BACKENDS[1:])
def test_quaternion_float32_within_the_documented_tolerance(backend: str, x64: None) -> None:
    B32 = Backend(backend, "float32")
    R = so3.exp(_rotvecs()[:9])
    for order in ORDERS:
        q = Q.from_matrix(R, order=order)
        p = q[::-1].copy()
        for out, ref in [
            (Q.to_matrix(B32(q), order=order), Q.to_matrix(q, order=order)),
            (Q.from_matrix(B32(R), order=order), q),
            (Q.multiply(B32(q), B32(p), order=order), Q.multiply(q, p, order=order)),
            (Q.slerp(B32(q), B32(p), 0.3, order=order), Q.slerp(q, p, 0.3, order=order)),
        ]:
            _close(B32.check(out), ref, TOL32)


def test_swapped_storage_order_is_a_different_rotation(B: Backend) -> None:
    """The learned-SLAM bug: an ``xyzw`` array read as ``wxyz`` is another rotation, silently."""
    q = _quats("xyzw")[3]
    right = B.check(Q.to_matrix(B(q), order="xyzw"))
    wrong = B.check(Q.to_matrix(B(q), order="wxyz"))
    assert np.abs(right - wrong).max() > 0.1
    back = B.check(Q.from_matrix(B(right), order="wxyz"))
    _up_to_sign(np.roll(back, -1), q)


def test_quaternion_errors_on_tensors_name_argument_and_batch_index(x64: None) -> None:
    torch = pytest.importorskip("torch")
    q = torch.tensor(_quats("wxyz")[:4])
    q[2, 0] += 1e-3
    with pytest.raises(ValueError, match=r"q: quaternion norm off by .* at batch index \(2,\)"):
        Q.to_matrix(q, order="wxyz")
    with pytest.raises(ValueError, match=r"q1: quaternion norm off"):
        Q.multiply(q, q.flip(0), order="xyzw")
    with pytest.raises(ValueError, match=r"order: expected one of"):
        Q.to_matrix(torch.tensor([1.0, 0.0, 0.0, 0.0]), order="wxzy")
    R = torch.tensor(so3.exp(_rotvecs()[:3]))
    with pytest.raises(ValueError, match=r"R: not a rotation at batch index \(1,\)"):
        Q.from_matrix(
            R * torch.tensor([1.0, 1.1, 1.0], dtype=torch.float64)[:, None, None], order="xyzw"
        )


# ----------------------------------------------------------------------------- gradients
def _unit(p: Any) -> Any:
    return p / (p * p).sum(-1, keepdims=True) ** 0.5


def _quat_fns() -> dict[str, tuple[Callable[..., Any], int]]:
    """Functions of a perturbation (``(n,)``) at a base point: ``name → (f(base, d), n)``."""
    return {
        # q = normalise(q₀ + d): stays a unit quaternion under finite differences
        "to_matrix": (lambda q0, d: Q.to_matrix(_unit(q0 + d), order="wxyz"), 4),
        "to_matrix_jpl": (lambda q0, d: Q.to_matrix(_unit(q0 + d), order="jpl"), 4),
        "multiply": (lambda q0, d: Q.multiply(_unit(q0 + d), q0, order="xyzw"), 4),
        "slerp": (lambda q0, d: Q.slerp(q0, _unit(q0 + d), 0.3, order="wxyz"), 4),
    }


GRAD_QUATS = {
    "identity": np.array([1.0, 0.0, 0.0, 0.0]),
    "generic": Q.from_matrix(so3.exp(np.array([0.4, -0.7, 0.5])), order="wxyz"),
    "half_turn": np.array([0.0, 0.0, 1.0, 0.0]),
}
GRAD_ROTATIONS = {
    "identity": np.zeros(3),
    "generic": np.array([0.4, -0.7, 0.5]),
    "half_turn_x": np.array([np.pi, 0.0, 0.0]),
    "half_turn_axis": np.pi * AXIS,
}


def _from_matrix_outer(R0: Any, d: Any, xp: Any) -> Any:
    """``q qᵀ`` of ``from_matrix(R₀·Exp(d))``: smooth through the hemisphere flip at ``w = 0``."""
    q = Q.from_matrix(R0 @ so3.exp(d), order="wxyz")
    return q[..., :, None] * q[..., None, :]


@pytest.mark.parametrize("point", list(GRAD_QUATS))
@pytest.mark.parametrize("fn", list(_quat_fns()))
def test_quaternion_torch_gradcheck(fn: str, point: str) -> None:
    torch = pytest.importorskip("torch")
    q0 = torch.tensor(GRAD_QUATS[point], dtype=torch.float64)
    f, n = _quat_fns()[fn]
    d = torch.zeros(n, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda d: f(q0, d), (d,))


@pytest.mark.parametrize("point", list(GRAD_QUATS))
@pytest.mark.parametrize("fn", list(_quat_fns()))
def test_quaternion_jax_check_grads(fn: str, point: str, x64: None) -> None:
    jax = pytest.importorskip("jax")
    from jax.test_util import check_grads

    q0 = jax.numpy.asarray(GRAD_QUATS[point])
    f, n = _quat_fns()[fn]
    check_grads(lambda d: f(q0, d), (jax.numpy.zeros(n),), order=1, modes=("fwd", "rev"))


@pytest.mark.parametrize("point", list(GRAD_ROTATIONS))
def test_from_matrix_gradients_finite_at_identity_and_half_turns(point: str, x64: None) -> None:
    """No NaN from a discarded formula (three are 0 at the identity) or from a norm at 0."""
    torch = pytest.importorskip("torch")
    R0 = torch.tensor(so3.exp(GRAD_ROTATIONS[point]))
    d = torch.zeros(3, dtype=torch.float64, requires_grad=True)
    J = torch.autograd.functional.jacobian(
        lambda d: Q.from_matrix(R0 @ so3.exp(d), order="wxyz"), d
    )
    assert torch.isfinite(J).all()
    # the derivative of q(R₀·Exp(d)) is q₀ ⊗ (0, δ/2): J = ½·[−u₀ᵀ; w₀ I + hat(u₀)]
    q0 = Q.from_matrix(R0.numpy(), order="wxyz")
    w0, u0 = q0[0], q0[1:]
    expected = 0.5 * np.vstack([-u0[None, :], w0 * np.eye(3) + so3.hat(u0)])
    np.testing.assert_allclose(J.numpy(), expected, atol=1e-9)
    assert torch.autograd.gradcheck(lambda d: _from_matrix_outer(R0, d, torch), (d,))
    if HAS["jax"]:
        import jax
        from jax.test_util import check_grads

        R0j = jax.numpy.asarray(R0.numpy())
        Jj = jax.jacrev(lambda d: Q.from_matrix(R0j @ so3.exp(d), order="wxyz"))(jax.numpy.zeros(3))
        np.testing.assert_allclose(np.asarray(Jj), expected, atol=1e-9)
        check_grads(
            lambda d: _from_matrix_outer(R0j, d, jax.numpy),
            (jax.numpy.zeros(3),),
            order=1,
            modes=("fwd", "rev"),
        )


def test_to_matrix_gradient_at_the_identity_and_a_half_turn_is_exact(x64: None) -> None:
    """``∂R/∂q`` of the polynomial form: e.g. ``∂R/∂x = 2·[[x, y, z], [y, −x, −w], [z, w, −x]]``."""
    torch = pytest.importorskip("torch")
    for q0 in (GRAD_QUATS["identity"], GRAD_QUATS["half_turn"]):
        w, x, y, z = q0
        J = torch.autograd.functional.jacobian(
            lambda q: Q.to_matrix(q, order="wxyz"), torch.tensor(q0)
        ).numpy()
        dx = 2.0 * np.array([[x, y, z], [y, -x, -w], [z, w, -x]])
        np.testing.assert_allclose(J[..., 1], dx, atol=1e-15)


# ----------------------------------------------------------------------------- tracing
def test_jax_jit_of_to_matrix_and_of_a_cayley_convert_covariance(x64: None) -> None:
    jax = pytest.importorskip("jax")
    q = _quats("xyzw")
    f = jax.jit(lambda q: Q.to_matrix(q, order="xyzw"))
    np.testing.assert_allclose(np.asarray(f(q)), Q.to_matrix(q, order="xyzw"), atol=1e-15)
    g = jax.jit(lambda R: Q.from_matrix(R, order="wxyz"))
    R = so3.exp(_rotvecs())
    np.testing.assert_allclose(np.asarray(g(R)), Q.from_matrix(R, order="wxyz"), atol=1e-15)
    X = se3.exp(np.concatenate([_rotvecs()[:8], np.ones((8, 3))], axis=-1))
    C = np.broadcast_to(np.diag([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3]), (8, 6, 6))
    ref = lb.convert_covariance(C, X, "gtsam_cayley", "gtsam")
    h = jax.jit(lambda C, X: lb.convert_covariance(C, X, "gtsam_cayley", "gtsam"))
    np.testing.assert_allclose(np.asarray(h(C, X)), ref, atol=1e-14)
    v = jax.jit(jax.vmap(lambda C, X: lb.convert_covariance(C, X, "g2o", "gtsam")))
    np.testing.assert_allclose(
        np.asarray(v(C, X)), lb.convert_covariance(C, X, "g2o", "gtsam"), atol=1e-14
    )


@pytest.mark.exhaustive  # torch.compile: CI compiles in test_tensors.py
def test_torch_compile_of_to_matrix_and_of_a_cayley_convert_covariance() -> None:
    torch = pytest.importorskip("torch")
    q = _quats("wxyz")
    f = torch.compile(lambda q: Q.to_matrix(q, order="wxyz"))
    np.testing.assert_allclose(f(torch.tensor(q)).numpy(), Q.to_matrix(q, order="wxyz"))
    X = se3.exp(np.concatenate([_rotvecs()[:8], np.ones((8, 3))], axis=-1))
    C = np.diag([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3])
    g = torch.compile(lambda C, X: lb.convert_covariance(C, X, "gtsam_cayley", "gtsam"))
    out = g(torch.tensor(C), torch.tensor(X))
    ref = lb.convert_covariance(C, X, "gtsam_cayley", "gtsam")
    np.testing.assert_allclose(out.numpy(), ref, atol=1e-14)


# ----------------------------------------------------------------------------- hat, vee, ad
HAT_GROUPS = [(so2, 1), (se2, 3), (so3, 3), (se3, 6), (se23, 9)]


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize(("mod", "dim"), HAT_GROUPS, ids=[m.__name__[13:] for m, _ in HAT_GROUPS])
def test_hat_vee_ad_same_values(B: Backend, mod: Any, dim: int, shape: tuple[int, ...]) -> None:
    xi = _batch(np.random.default_rng(6).normal(size=(12, dim)), shape)
    X = mod.hat(xi)
    _close(B.check(mod.hat(B(xi))), X)
    _close(B.check(mod.vee(B(X))), xi)
    noisy = X + 1e-3 * _batch(np.random.default_rng(7).normal(size=(12, *X.shape[-2:])), shape)
    _close(B.check(mod.vee(B(noisy))), mod.vee(noisy))  # the skew part of a non-skew input
    if mod is se3:
        _close(B.check(se3.ad(B(xi))), se3.ad(xi))


def test_se3_ad_is_the_derivative_of_the_adjoint_on_tensors(x64: None) -> None:
    """``d/ds Ad(Exp(sξ))|₀ = ad_ξ``, by autodiff through the array-generic kernels."""
    torch = pytest.importorskip("torch")
    xi = torch.tensor([0.3, -0.2, 0.5, 1.0, -2.0, 0.7], dtype=torch.float64)
    J = torch.autograd.functional.jacobian(
        lambda s: se3.adjoint(se3.exp(s * xi)), torch.zeros((), dtype=torch.float64)
    )
    np.testing.assert_allclose(J.numpy(), se3.ad(xi).numpy(), atol=1e-12)


# ----------------------------------------------------------------------------- rotation coords
ROTATION_COORD_CONVENTIONS = [
    name
    for name in lb.conventions.names()
    if isinstance(lb.conventions.get(name), Convention)
    and lb.conventions.get(name).rotation in ("cayley", "quat_vec")
]


def test_the_cayley_and_quaternion_vector_presets() -> None:
    assert {"gtsam_cayley", "g2o", "hdl_graph_slam"} <= set(ROTATION_COORD_CONVENTIONS)


def _pose_batch(shape: tuple[int, ...], scale: float = 0.8) -> np.ndarray:
    rng = np.random.default_rng(11)
    w = scale * rng.normal(size=(12, 3))
    w[0] = 0.0
    w[1] = 1e-12 * AXIS
    return _batch(se3.exp(np.concatenate([w, 5.0 * rng.normal(size=(12, 3))], axis=-1)), shape)


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize("name", ROTATION_COORD_CONVENTIONS)
def test_rotation_coordinate_conventions_same_values(
    B: Backend, name: str, shape: tuple[int, ...]
) -> None:
    c = lb.conventions.get(name)
    assert isinstance(c, Convention)
    X = _pose_batch(shape)
    d = 0.15 * _batch(np.random.default_rng(3).normal(size=(12, 6)), shape)
    Y = c.retract(X, d)
    rng = np.random.default_rng(4)
    A = _batch(rng.normal(size=(12, 6, 6)), shape)
    C = A @ np.swapaxes(A, -1, -2) + 1e-3 * np.eye(6)
    cases = [
        (c.retract(B(X), B(d)), Y),
        (c.local(B(X), B(Y)), c.local(X, Y)),
        (c.local_jacobian(B(X), B(Y)), c.local_jacobian(X, Y)),
        (c.to_canonical(B(X)), c.to_canonical(X)),
        (c.from_canonical(B(X)), c.from_canonical(X)),
        (lb.tangent_map(B(X), name, "gtsam"), lb.tangent_map(X, name, "gtsam")),
        (lb.tangent_map(B(X), "pypose", name), lb.tangent_map(X, "pypose", name)),
        (lb.convert_covariance(B(C), B(X), name, "barfoot"),
         lb.convert_covariance(C, X, name, "barfoot")),
        (lb.convert_covariance(B(C), B(X), "gtsam", name),
         lb.convert_covariance(C, X, "gtsam", name)),
    ]  # fmt: skip
    for out, ref in cases:
        _close(B.check(out), ref, 1e-11)


@pytest.mark.parametrize("kind", ["cayley", "quat_vec"])
@pytest.mark.parametrize("side", ["right", "left"])
def test_rotation_coordinate_maps_same_values(B: Backend, kind: str, side: str) -> None:
    r = 0.3 * np.random.default_rng(12).normal(size=(12, 3))
    r[0] = 0.0
    r[1] = 1e-12 * AXIS
    if kind == "quat_vec":
        r[2] = AXIS / np.linalg.norm(AXIS)  # ‖r‖ = 1: a half turn, w = 0
    R = rc.to_rotation(r, kind)
    for out, ref in [
        (rc.to_rotation(B(r), kind), R),
        (rc.from_rotation(B(R), kind), rc.from_rotation(R, kind)),
        (rc.d_from_rotation(B(R), kind, side), rc.d_from_rotation(R, kind, side)),
    ]:
        _close(B.check(out), ref)


@pytest.mark.parametrize("kind", rc.EULER_COORDS)
def test_euler_coordinates_same_values(B: Backend, kind: str) -> None:
    e = np.random.default_rng(13).normal(size=(12, 3))
    e[:, 1] *= 0.5  # pitch within (−π/2, π/2)
    e[0] = 0.0
    e[1] = [3.1, 0.2, -3.1]  # yaw and roll near ±π: the wrap
    R = rc.euler_to_matrix(e, kind)
    R2 = R[::-1].copy()
    for out, ref in [
        (rc.euler_to_matrix(B(e), kind), R),
        (rc.matrix_to_euler(B(R), kind), rc.matrix_to_euler(R, kind)),
        (rc.euler_rate_map(B(e), kind), rc.euler_rate_map(e, kind)),
        (rc.euler_rate_map_inv(B(e), kind), rc.euler_rate_map_inv(e, kind)),
        (rc.euler_local(B(R), B(R2), kind), rc.euler_local(R, R2, kind)),
        (rc.euler_retract(B(R), B(0.1 * e), kind), rc.euler_retract(R, 0.1 * e, kind)),
    ]:
        _close(B.check(out), ref)


def test_euler_rate_map_is_the_derivative_of_the_euler_angles_on_tensors(x64: None) -> None:
    """``ė = W ω_body``: autodiff of ``e(R·Exp(δ))`` at 0, against :func:`euler_rate_map`."""
    torch = pytest.importorskip("torch")
    for kind in rc.EULER_COORDS:
        e = torch.tensor([0.3, -0.4, 1.2], dtype=torch.float64)
        R = rc.euler_to_matrix(e, kind)
        J = torch.autograd.functional.jacobian(
            lambda d, R=R, kind=kind: rc.matrix_to_euler(R @ so3.exp(d), kind),
            torch.zeros(3, dtype=torch.float64),
        )
        np.testing.assert_allclose(J.numpy(), rc.euler_rate_map(e, kind).numpy(), atol=1e-12)
        Wi = rc.euler_rate_map_inv(e, kind).numpy()
        np.testing.assert_allclose(Wi @ J.numpy(), np.eye(3), atol=1e-12)


def test_rotation_coordinate_errors_on_tensors_match_numpy(x64: None) -> None:
    """Checks certified on the device; the host copy words numpy's message."""
    torch = pytest.importorskip("torch")
    r = torch.tensor([[0.1, 0.2, 0.3], [0.9, 0.5, 0.0]], dtype=torch.float64)
    with pytest.raises(ValueError, match=r"need ‖r‖ ≤ 1, got ‖r‖ = 1.0\d* at batch index \(1,\)"):
        rc.to_rotation(r, "quat_vec")
    R = torch.tensor(so3.exp(np.array([[0.1, 0.0, 0.0], [np.pi, 0.0, 0.0]])))
    with pytest.raises(ValueError, match=r"Cayley coordinates are undefined .* index \(1,\)"):
        rc.from_rotation(R, "cayley")
    with pytest.raises(ValueError, match=r"Cayley coordinates are undefined"):
        lb.conventions.get("gtsam_cayley").local(torch.eye(3, dtype=torch.float64), R)
    G = torch.tensor(
        rc.euler_to_matrix(np.array([[0.1, 0.2, 0.3], [0.1, np.pi / 2, 0.2]]), "euler_rpy")
    )
    with pytest.raises(ValueError, match=r"pitch = ±90° .* at batch index \(1,\)\): gimbal lock"):
        rc.matrix_to_euler(G, "euler_rpy")
    with pytest.raises(ValueError, match=r"pitch = ±90°"):
        rc.euler_rate_map(torch.tensor([0.1, np.pi / 2, 0.2], dtype=torch.float64), "euler_rpy")


def test_euler_angles_are_not_an_increment_on_tensors(x64: None) -> None:
    """The record-driven engine would compose ``R·E(r)``: refused, never a wrong answer."""
    torch = pytest.importorskip("torch")
    with pytest.raises(TypeError, match=r"absolute Euler angles, not an increment"):
        rc.to_rotation(torch.zeros(3, dtype=torch.float64), "euler_zyx")
    with pytest.raises(TypeError, match=r"absolute Euler angles"):
        rc.d_from_rotation(torch.eye(3, dtype=torch.float64), "euler_rpy", "right")


ROT_GRAD_POINTS = {"zero": np.zeros(6), "generic": np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8])}


def _coord_fns() -> dict[str, Callable[..., Any]]:
    def at(xi: Any, d: Any) -> Any:
        return se3.exp(xi) @ se3.exp(d)

    C = np.diag([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3])
    return {
        "cayley.tangent_map": lambda xi, d: lb.tangent_map(at(xi, d), "gtsam_cayley", "gtsam"),
        "cayley.local_jacobian": lambda xi, d: lb.conventions.get("gtsam_cayley").local_jacobian(
            se3.exp(xi), at(xi, d)
        ),
        "g2o.tangent_map": lambda xi, d: lb.tangent_map(at(xi, d), "g2o", "pypose"),
        "g2o.convert_covariance": lambda xi, d: lb.convert_covariance(C, at(xi, d), "g2o", "gtsam"),
        "g2o.local": lambda xi, d: lb.conventions.get("g2o").local(se3.exp(xi), at(xi, d)),
        "euler.rate_map": lambda xi, d: rc.euler_rate_map(
            rc.matrix_to_euler(at(xi, d)[..., :3, :3], "euler_zyx"), "euler_zyx"
        ),
    }


@pytest.mark.parametrize("point", list(ROT_GRAD_POINTS))
@pytest.mark.parametrize("fn", list(_coord_fns()))
def test_rotation_coordinates_torch_gradcheck(fn: str, point: str) -> None:
    torch = pytest.importorskip("torch")
    xi = torch.tensor(ROT_GRAD_POINTS[point], dtype=torch.float64)
    d = torch.zeros(6, dtype=torch.float64, requires_grad=True)
    f = _coord_fns()[fn]
    assert torch.autograd.gradcheck(lambda d: f(xi, d), (d,))


@pytest.mark.parametrize("point", list(ROT_GRAD_POINTS))
@pytest.mark.parametrize("fn", list(_coord_fns()))
def test_rotation_coordinates_jax_check_grads(fn: str, point: str, x64: None) -> None:
    jax = pytest.importorskip("jax")
    from jax.test_util import check_grads

    xi = jax.numpy.asarray(ROT_GRAD_POINTS[point])
    f = _coord_fns()[fn]
    check_grads(lambda d: f(xi, d), (jax.numpy.zeros(6),), order=1, modes=("fwd", "rev"))


@pytest.mark.parametrize("backend", ["torch", "jax"])
@pytest.mark.parametrize("convention", ["gtsam_cayley", "g2o"])
def test_autodiff_between_factor_through_cayley_and_quat_vec_equals_gtsam(
    backend: str, convention: str
) -> None:
    """The autodiff factor's Jacobians, taken through these retractions on tensors, are GTSAM's."""
    gtsam = pytest.importorskip("gtsam")
    pytest.importorskip(backend)
    import importlib.util as iu
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "autodiff_factor.py"
    spec = iu.spec_from_file_location("autodiff_example_quat", path)
    assert spec is not None and spec.loader is not None
    example = iu.module_from_spec(spec)
    spec.loader.exec_module(example)
    sigmas = np.array([0.01, 0.02, 0.03, 0.1, 0.2, 0.3])
    noise = gtsam.noiseModel.Diagonal.Sigmas(sigmas)
    Xi = se3.exp(np.array([0.3, -1.0, 0.4, 1.0, 2.0, -0.5]))
    Xj = se3.exp(np.array([-0.2, 0.5, 1.1, 4.0, -1.0, 0.5]))
    Z = np.linalg.inv(Xi) @ Xj @ se3.exp(np.array([0.05, -0.1, 0.2, 0.1, 0.0, -0.2]))
    values = gtsam.Values()
    values.insert(1, gtsam.Pose3(Xi))
    values.insert(2, gtsam.Pose3(Xj))
    mine = lb.gtsam.autodiff_factor(
        example.BETWEEN[backend], [1, 2], noise, convention, backend, data=(Z,)
    )
    ref = gtsam.BetweenFactorPose3(1, 2, gtsam.Pose3(Z), noise)
    A, b = mine.linearize(values).jacobian()
    A_ref, b_ref = ref.linearize(values).jacobian()
    np.testing.assert_allclose(sigmas[:, None] * A, sigmas[:, None] * A_ref, atol=1e-9)
    np.testing.assert_allclose(sigmas * b, sigmas * b_ref, atol=1e-9)


def test_mixed_quaternion_arguments_take_the_tensor_type(x64: None) -> None:
    torch = pytest.importorskip("torch")
    q = _quats("xyzw")
    p = q[::-1].copy()
    out = Q.multiply(torch.tensor(q), p, order="xyzw")
    assert isinstance(out, torch.Tensor) and out.dtype == torch.float64
    np.testing.assert_allclose(out.numpy(), Q.multiply(q, p, order="xyzw"), atol=1e-15)
    out = Q.slerp(q, torch.tensor(p), np.full(12, 0.4), order="xyzw")
    assert isinstance(out, torch.Tensor)
    np.testing.assert_allclose(out.numpy(), Q.slerp(q, p, 0.4, order="xyzw"), atol=1e-14)


def test_numpy_quaternion_results_stay_numpy() -> None:
    """numpy in, numpy float64 out, the input untouched (today's behaviour)."""
    q = _quats("xyzw")
    keep = q.copy()
    for out in (
        Q.to_matrix(q, order="xyzw"),
        Q.from_matrix(so3.exp(_rotvecs()), order="xyzw"),
        Q.multiply(q, q, order="wxyz"),
        Q.slerp(q, q[::-1], 0.5, order="xyzw"),
        so3.hat(q[:, :3]),
        se3.vee(se3.hat(np.ones(6))),
    ):
        assert type(out) is np.ndarray and out.dtype == np.float64
    np.testing.assert_array_equal(q, keep)


def test_bench_quaternion_tensors_smoke(x64: None) -> None:
    """The benchmark runs and both sides agree (its timings are not asserted)."""
    if not (HAS["torch"] or HAS["jax"]):
        pytest.skip("torch or jax extra")
    import importlib.util as iu
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_quaternion_tensors.py"
    spec = iu.spec_from_file_location("bench_quaternion_tensors", path)
    assert spec is not None and spec.loader is not None
    bench = iu.module_from_spec(spec)
    spec.loader.exec_module(bench)
    rows = bench.run([200], 1)
    assert {r["op"] for r in rows} == {"to_matrix", "from_matrix"}
    assert all(r["max_abs_diff"] <= 1e-9 and r["liebridge_ms"] > 0 for r in rows)
