"""liebridge.uncertain and liebridge.check on torch tensors and JAX arrays.

The same expected values as numpy (float64 to 1e-12, float32 to 1e-4 relative), batch shapes
(), (n,), (a, b), θ near 0 and at π; the tensor result checked on its own against central
differences through the conventions' retract/local (run on the tensors) and against the numpy
Monte Carlo references; gradients by ``torch.autograd.gradcheck`` and
``jax.test_util.check_grads`` (poses ``T0·Exp(d)``, covariances ``L Lᵀ + εI``, so perturbed
inputs stay valid), at θ = 0 exactly too; what stays numpy-only refuses tensors clearly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from liebridge import check
from liebridge import uncertain as u
from liebridge.check import numerical_jacobian
from liebridge.conventions import get
from liebridge.lie import se3

torch = pytest.importorskip("torch")
jax = pytest.importorskip("jax")
pytest.importorskip("array_api_compat")
jnp = jax.numpy

#: Presets whose retraction runs on tensors (rotation coordinates 'exp'/'half_exp'): right and
#: left, the SE(3) exponential and the split world chart, rotation or translation first.
CONVS = ["gtsam", "ros", "barfoot", "symforce", "ceres_pose", "pinocchio"]
BACKENDS = ["numpy", "torch", "jax"]
#: float32 results against float64 numpy: relative to the largest entry (a float32 rotation is
#: orthonormal to ~1e-7; products of three 6×6 matrices of O(10) entries lose a few ulps more).
F32_RTOL = 1e-4


@pytest.fixture
def x64() -> Iterator[None]:
    """JAX with float64 enabled (restored afterwards)."""
    old = jax.config.read("jax_enable_x64")
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", old)


def to(x: Any, backend: str, dtype: str = "float64") -> Any:
    """A numpy array as ``backend``'s array of ``dtype``."""
    a = np.asarray(x, dtype=dtype)
    if backend == "torch":
        return torch.tensor(a)
    if backend == "jax":
        return jnp.asarray(a)
    return a


def host(x: Any) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        return x.detach().cpu().numpy().astype(np.float64)
    return np.asarray(x, dtype=np.float64)


def kind(x: Any, backend: str) -> bool:
    if backend == "torch":
        return isinstance(x, torch.Tensor)
    if backend == "jax":
        return isinstance(x, jax.Array)
    return isinstance(x, np.ndarray)


def _spd(rng: np.random.Generator, shape: tuple[int, ...], n: int, scale: float) -> np.ndarray:
    L = rng.normal(size=(*shape, n, n))
    return np.asarray(scale * (L @ np.swapaxes(L, -1, -2) / n + 0.2 * np.eye(n)))


def _poses(rng: np.random.Generator, shape: tuple[int, ...], theta: float | None) -> np.ndarray:
    xi = rng.normal(size=(*shape, 6))
    xi[..., 3:] *= 2.0
    if theta is not None:  # rotation angle exactly theta
        w = xi[..., :3]
        xi[..., :3] = theta * w / np.linalg.norm(w, axis=-1, keepdims=True)
    return np.asarray(se3.exp(xi))


def _inputs(shape: tuple[int, ...], theta: float | None, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    joint = _spd(rng, shape, 12, 1e-3)
    return {
        "TA": _poses(rng, shape, theta),
        "TB": _poses(rng, shape, None),
        "TF": _poses(rng, shape, None),
        "joint": joint,
        "p": rng.normal(size=(*shape, 3)),
        "cov_p": _spd(rng, shape, 3, 1e-3),
    }


def _op(op: str, A: Any, B: Any, cross: Any, TF: Any, p: Any, cov_p: Any) -> Any:
    if op == "compose":
        return u.compose(A, B, cross)
    if op == "inverse":
        return u.inverse(A)
    if op == "relative":
        return u.relative(A, B, cross)
    if op == "transform_left":
        return u.transform(A, TF, "left")
    if op == "transform_right":
        return u.transform(A, TF, "right")
    if op == "extrinsic":
        return u.transform(A, B, "right", cross=cross)
    if op == "act":
        return u.act(A, p, cov_p)
    if op == "fuse":
        return u.fuse(A, B)
    raise AssertionError(op)


OPS = [
    "compose",
    "inverse",
    "relative",
    "transform_left",
    "transform_right",
    "extrinsic",
    "act",
    "fuse",
]


def _run(op: str, name: str, x: dict[str, np.ndarray], backend: str, dtype: str) -> Any:
    c = get(name)
    j = x["joint"]
    TB = x["TB"]
    if op == "fuse":  # two estimates of one pose
        TB = x["TA"] @ np.asarray(se3.exp(0.05 * np.ones(6)))
    A = u.UncertainPose(to(x["TA"], backend, dtype), to(j[..., :6, :6], backend, dtype), c)
    B = u.UncertainPose(to(TB, backend, dtype), to(j[..., 6:, 6:], backend, dtype), c)
    return _op(
        op,
        A,
        B,
        to(j[..., :6, 6:], backend, dtype),
        to(x["TF"], backend, dtype),
        to(x["p"], backend, dtype),
        to(x["cov_p"], backend, dtype),
    )


def _mean(r: Any) -> Any:
    return r.p if isinstance(r, u.UncertainPoint) else r.T


# ------------------------------------------------------------------ the numpy values, every backend
#: JAX dispatches op by op outside ``jit`` (each new shape costs a compilation on this 2-core
#: machine): it runs the three most distinct presets, torch all of them.
CASES = [("torch", n) for n in CONVS] + [("jax", n) for n in ["gtsam", "ros", "ceres_pose"]]


@pytest.mark.parametrize("op", OPS)
@pytest.mark.parametrize(("backend", "name"), CASES)
def test_linear_operations_equal_numpy(op: str, name: str, backend: str, x64: None) -> None:
    for shape in [(), (3,), (2, 2)]:
        x = _inputs(shape, None)
        ref = _run(op, name, x, "numpy", "float64")
        got = _run(op, name, x, backend, "float64")
        assert kind(got.cov, backend) and kind(_mean(got), backend)
        assert got.cov.dtype == (torch.float64 if backend == "torch" else jnp.float64)
        assert tuple(got.cov.shape) == ref.cov.shape
        np.testing.assert_allclose(host(got.cov), ref.cov, rtol=0, atol=1e-12)
        np.testing.assert_allclose(host(_mean(got)), _mean(ref), rtol=0, atol=1e-12)


@pytest.mark.parametrize("theta", [0.0, 1e-9, 1e-4, math.pi - 1e-6, math.pi])
@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot", "ceres_pose"])
@pytest.mark.parametrize("backend", ["torch", "jax"])
def test_edge_angles_equal_numpy(theta: float, name: str, backend: str, x64: None) -> None:
    x = _inputs((4,), theta, seed=1)
    for op in ["compose", "inverse", "relative", "transform_right", "act"]:
        ref = _run(op, name, x, "numpy", "float64")
        got = _run(op, name, x, backend, "float64")
        assert np.isfinite(host(got.cov)).all()
        np.testing.assert_allclose(host(got.cov), ref.cov, rtol=0, atol=1e-12, err_msg=op)


@pytest.mark.parametrize("op", OPS)
@pytest.mark.parametrize("backend", ["torch", "jax"])
def test_float32_within_the_stated_tolerance(op: str, backend: str) -> None:
    """float32 in, float32 out; within F32_RTOL (relative to the largest entry) of float64."""
    x = _inputs((5,), None, seed=2)
    for name in ["gtsam", "ros", "barfoot"]:
        ref = _run(op, name, x, "numpy", "float64")
        got = _run(op, name, x, backend, "float32")
        assert got.cov.dtype == (torch.float32 if backend == "torch" else jnp.float32)
        scale = np.abs(ref.cov).max()
        np.testing.assert_allclose(host(got.cov), ref.cov, rtol=0, atol=F32_RTOL * scale)
        np.testing.assert_allclose(host(_mean(got)), _mean(ref), rtol=0, atol=1e-5)


@pytest.mark.parametrize("backend", ["torch", "jax"])
def test_rotations_equal_numpy(backend: str, x64: None) -> None:
    rng = np.random.default_rng(5)
    R1 = _poses(rng, (3,), None)[..., :3, :3]
    R2 = _poses(rng, (3,), 1e-9)[..., :3, :3]
    S = _spd(rng, (3,), 6, 1e-3)
    for name in ["gtsam", "ros", "barfoot", "ceres_pose"]:
        outs = {}
        for b in ["numpy", backend]:
            A = u.UncertainPose(to(R1, b), to(S[..., :3, :3], b), name)
            B = u.UncertainPose(to(R2, b), to(S[..., 3:, 3:], b), name)
            X = to(S[..., :3, 3:], b)
            outs[b] = [
                u.compose(A, B, X).cov,
                u.inverse(A).cov,
                u.relative(A, B, X).cov,
                u.act(A, to(np.ones(3), b)).cov,
                u.fuse(A, u.UncertainPose(to(R1, b), to(S[..., 3:, 3:], b), name)).cov,
                A.to("gtsam").cov,
            ]
        for got, ref in zip(outs[backend], outs["numpy"], strict=True):
            assert kind(got, backend)
            np.testing.assert_allclose(host(got), ref, rtol=0, atol=1e-12)


def test_mixed_numpy_and_tensor_operands_give_tensors() -> None:
    x = _inputs((2,), None)
    c = "ros"
    A = u.UncertainPose(torch.tensor(x["TA"]), x["joint"][..., :6, :6], c)  # numpy cov
    assert isinstance(A.cov, torch.Tensor)
    B = u.UncertainPose(x["TB"], x["joint"][..., 6:, 6:], c)  # all numpy
    C = u.compose(A, B)
    assert isinstance(C.cov, torch.Tensor)
    ref = u.compose(u.UncertainPose(x["TA"], x["joint"][..., :6, :6], c), B)
    np.testing.assert_allclose(host(C.cov), ref.cov, atol=1e-12)
    q = u.act(B, torch.tensor(x["p"]))
    assert isinstance(q.cov, torch.Tensor)


# ------------------------------------------------------------------ the tensor path on its own
@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot", "ceres_pose"])
def test_tensor_covariances_are_the_finite_difference_sandwich(name: str) -> None:
    """J by central differences through the preset's retract/local, run on the tensors."""
    c = get(name)
    x = _inputs((), None, seed=4)
    t = {k: torch.tensor(v) for k, v in x.items()}
    joint, TA, TB, TF = t["joint"], t["TA"], t["TB"], t["TF"]
    A = u.UncertainPose(TA, joint[:6, :6], c)
    B = u.UncertainPose(TB, joint[6:, 6:], c)
    cross = joint[:6, 6:]
    kw: dict[str, Any] = {"in_convention": c, "out_convention": c}
    JA = numerical_jacobian(lambda X: X @ TB, TA, **kw)
    JB = numerical_jacobian(lambda X: TA @ X, TB, **kw)
    assert isinstance(JA, torch.Tensor)
    J = torch.cat([JA, JB], dim=-1)
    fd = (J @ joint @ J.T).numpy()
    np.testing.assert_allclose(host(u.compose(A, B, cross).cov), fd, atol=1e-10)
    Ji = numerical_jacobian(torch.linalg.inv, TA, **kw)
    np.testing.assert_allclose(host(u.inverse(A).cov), (Ji @ A.cov @ Ji.T).numpy(), atol=1e-10)
    Jr = numerical_jacobian(lambda X: X @ TF, TA, **kw)
    np.testing.assert_allclose(
        host(u.transform(A, TF, "right").cov), (Jr @ A.cov @ Jr.T).numpy(), atol=1e-10
    )
    p = t["p"]
    Jp = numerical_jacobian(
        lambda X: X[..., :3, :3] @ p + X[..., :3, 3], TA, retract=c.retract, out_local="euclidean"
    )
    np.testing.assert_allclose(host(u.act(A, p).cov), (Jp @ A.cov @ Jp.T).numpy(), atol=1e-10)


@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot"])
@pytest.mark.parametrize("backend", ["torch", "jax"])
def test_tensor_compose_matches_monte_carlo(name: str, backend: str, x64: None) -> None:
    """The tensor path's linear compose (with a cross term) against the numpy sampling reference."""
    rng = np.random.default_rng(7)
    joint = _spd(rng, (), 12, 1e-4)
    TA, TB = _poses(rng, (), None), _poses(rng, (), None)
    A = u.UncertainPose(to(TA, backend), to(joint[:6, :6], backend), name)
    B = u.UncertainPose(to(TB, backend), to(joint[6:, 6:], backend), name)
    lin = u.compose(A, B, to(joint[:6, 6:], backend))
    mc = check.monte_carlo_compose(
        u.UncertainPose(TA, joint[:6, :6], name),
        u.UncertainPose(TB, joint[6:, 6:], name),
        joint[:6, 6:],
        n=60000,
    )
    got = host(lin.cov)
    assert np.linalg.norm(got - mc.cov) / np.linalg.norm(mc.cov) <= 0.02
    np.testing.assert_allclose(host(lin.T), mc.T, atol=1e-12)


# ------------------------------------------------------------------ gradients
def _pose_t(T0: Any, d: Any) -> Any:
    return T0 @ se3.exp(d)


def _cov_t(L: Any, eye: Any) -> Any:
    return 1e-2 * (L @ L.T) + 1e-3 * eye


def _grad_fn(op: str, name: str, lib: Any, T0A: Any, T0B: Any, TF: Any, p: Any) -> Callable:
    """``(dA, LA[, dB, LB[, LX]]) -> outputs`` (poses T0·Exp(d), covariances L Lᵀ + εI)."""

    def f(dA: Any, LA: Any, dB: Any = None, LB: Any = None, LX: Any = None) -> Any:
        eye = lib.eye(6, dtype=dA.dtype)
        A = u.UncertainPose(_pose_t(T0A, dA), _cov_t(LA, eye), name)
        if dB is not None:
            B = u.UncertainPose(_pose_t(T0B, dB), _cov_t(LB, eye), name)
        cross = None if LX is None else 1e-4 * LX  # small: the joint stays positive definite
        if op == "compose":
            r = u.compose(A, B, cross)
        elif op == "inverse":
            r = u.inverse(A)
        elif op == "relative":
            r = u.relative(A, B, cross)
        elif op == "transform_left":
            r = u.transform(A, TF, "left")
        elif op == "transform_right":
            r = u.transform(A, TF, "right")
        elif op == "act":
            r = u.act(A, p)
        elif op == "fuse":
            r = u.fuse(A, B)
        else:
            raise AssertionError(op)
        return _mean(r), r.cov

    return f


GRAD_OPS = ["compose", "inverse", "relative", "transform_left", "transform_right", "act", "fuse"]
#: every operation in GTSAM's convention; in ros and barfoot all but ``fuse`` (its Gauss–Newton
#: loop costs a minute of gradchecks per convention and goes through the same conversions)
GRAD_CASES = [("gtsam", op) for op in GRAD_OPS] + [
    (name, op) for name in ("ros", "barfoot") for op in GRAD_OPS if op != "fuse"
]


def _grad_args(op: str, dA: Any, dB: Any, LA: Any, LB: Any, LX: Any) -> tuple[Any, ...]:
    """The inputs the operation reads (gradcheck perturbs each entry: none unused)."""
    if op in ("compose", "relative"):
        return (dA, LA, dB, LB, LX)
    if op == "fuse":
        return (dA, LA, dB, LB)
    return (dA, LA)


@pytest.mark.parametrize("at_zero", [False, True], ids=["generic", "theta_zero"])
@pytest.mark.parametrize(("name", "op"), GRAD_CASES)
def test_torch_gradcheck(name: str, op: str, at_zero: bool) -> None:
    rng = np.random.default_rng(11)
    if at_zero:  # θ = 0 exactly at the evaluation point (identity means, zero increments)
        T0A = T0B = torch.eye(4, dtype=torch.float64)
        dA = torch.zeros(6, dtype=torch.float64, requires_grad=True)
        dB = torch.zeros(6, dtype=torch.float64, requires_grad=True)
    else:
        T0A = torch.tensor(_poses(rng, (), None))
        T0B = T0A @ torch.tensor(np.asarray(se3.exp(0.1 * rng.normal(size=6))))
        dA = torch.tensor(0.1 * rng.normal(size=6), requires_grad=True)
        dB = torch.tensor(0.1 * rng.normal(size=6), requires_grad=True)
    LA, LB, LX = (torch.tensor(rng.normal(size=(6, 6)), requires_grad=True) for _ in range(3))
    TF = torch.tensor(_poses(rng, (), None))
    p = torch.tensor(rng.normal(size=3))
    f = _grad_fn(op, name, torch, T0A, T0B, TF, p)
    args = _grad_args(op, dA, dB, LA, LB, LX)
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6, rtol=1e-5)


def test_torch_gradient_of_a_batch_and_no_nan_at_theta_zero() -> None:
    """A regression of the NaN-gradient kind (‖ω‖ differentiated at 0): finite, and correct."""
    d = torch.zeros(3, 6, dtype=torch.float64, requires_grad=True)
    A = u.UncertainPose(se3.exp(d), 1e-2 * torch.eye(6, dtype=torch.float64), "barfoot")
    C = u.compose(A, A)
    C.cov.sum().backward()
    assert d.grad is not None and torch.isfinite(d.grad).all()


@pytest.mark.parametrize("at_zero", [False, True], ids=["generic", "theta_zero"])
@pytest.mark.parametrize(("name", "op"), GRAD_CASES)
def test_jax_check_grads(name: str, op: str, at_zero: bool, x64: None) -> None:
    from jax.test_util import check_grads

    rng = np.random.default_rng(13)
    if at_zero:
        T0A = T0B = jnp.eye(4)
        dA = dB = jnp.zeros(6)
    else:
        T0A = jnp.asarray(_poses(rng, (), None))
        T0B = T0A @ jnp.asarray(np.asarray(se3.exp(0.1 * rng.normal(size=6))))
        dA, dB = jnp.asarray(0.1 * rng.normal(size=6)), jnp.asarray(0.1 * rng.normal(size=6))
    LA, LB, LX = (jnp.asarray(rng.normal(size=(6, 6))) for _ in range(3))
    TF = jnp.asarray(_poses(rng, (), None))
    p = jnp.asarray(rng.normal(size=3))
    f = _grad_fn(op, name, jnp, T0A, T0B, TF, p)
    args = _grad_args(op, dA, dB, LA, LB, LX)
    check_grads(f, args, order=1, modes=("rev",), eps=1e-6, atol=1e-5, rtol=1e-5)


@pytest.mark.exhaustive  # ≈ 30 s of JAX compilation: CI jits convert_covariance in test_tensors
def test_jax_jit_and_vmap_of_compose_and_fuse(x64: None) -> None:
    x = _inputs((3,), None, seed=8)
    j = x["joint"]

    def f(TA: Any, TB: Any, S: Any) -> Any:
        A = u.UncertainPose(TA, S[..., :6, :6], "ros")
        B = u.UncertainPose(TB, S[..., 6:, 6:], "ros")
        return u.compose(A, B, S[..., :6, 6:]).cov, u.fuse(A, B).cov

    got = jax.jit(f)(jnp.asarray(x["TA"]), jnp.asarray(x["TB"]), jnp.asarray(j))
    ref = f(x["TA"], x["TB"], j)
    for g, r in zip(got, ref, strict=True):
        np.testing.assert_allclose(host(g), r, atol=1e-10)
    vm = jax.vmap(f)(jnp.asarray(x["TA"]), jnp.asarray(x["TB"]), jnp.asarray(j))
    np.testing.assert_allclose(host(vm[0]), ref[0], atol=1e-12)
    np.testing.assert_allclose(host(vm[1]), ref[1], atol=1e-10)


# ------------------------------------------------------------------ check on tensors
@pytest.mark.parametrize("backend", BACKENDS)
def test_numerical_jacobian_returns_the_callers_type(backend: str, x64: None) -> None:
    x = _inputs((2, 3), None, seed=9)
    T = to(x["TA"], backend)
    J = numerical_jacobian(lambda X: X @ X, T, in_convention="ros")
    ref = numerical_jacobian(lambda X: X @ X, x["TA"], in_convention="ros")
    assert kind(J, backend) and tuple(J.shape) == (2, 3, 6, 6)
    np.testing.assert_allclose(host(J), ref, atol=1e-12)
    v = to(x["p"], backend)
    Jv = numerical_jacobian(lambda y: y * y, v)
    assert kind(Jv, backend)
    np.testing.assert_allclose(host(Jv), 2 * x["p"][..., None] * np.eye(3), atol=1e-8)


@pytest.mark.parametrize("backend", ["torch", "jax"])
def test_numerical_jacobian_float32_and_graph(backend: str) -> None:
    """float32: the default step adapts (3e-3); error ≤ 1e-3 on an O(1) function."""
    v = to(np.array([[0.3, -1.2, 2.0], [0.1, 0.5, -0.7]]), backend, "float32")
    J = numerical_jacobian(lambda y: y**3, v)
    assert J.dtype == v.dtype
    np.testing.assert_allclose(host(J), 3 * host(v)[..., None] ** 2 * np.eye(3), atol=1e-3)
    if backend == "torch":  # differentiable: the differences keep the autograd graph
        w = torch.tensor([0.3, -1.2], dtype=torch.float64, requires_grad=True)
        numerical_jacobian(lambda y: y**3, w).trace().backward()
        np.testing.assert_allclose(w.grad.numpy(), 6 * w.detach().numpy(), atol=1e-6)


def test_assert_jacobian_reads_tensors() -> None:
    a = torch.ones(2, 2, requires_grad=True)
    check.assert_jacobian(a, np.ones((2, 2)))
    with pytest.raises(AssertionError, match=r"worst entry \(1, 0\)"):
        check.assert_jacobian(a, jnp.asarray([[1.0, 1.0], [2.0, 1.0]]))


# ------------------------------------------------------------------ numpy-only, bad input
@pytest.mark.parametrize("rotation", [False, True], ids=["pose", "rotation"])
def test_unscented_change_of_convention_on_tensors_equals_numpy(rotation: bool, x64: None) -> None:
    """``UncertainPose.to(method="unscented")`` (``convert_covariance``'s) on torch and JAX."""
    rng = np.random.default_rng(11)
    T = se3.exp(rng.normal(size=(3, 6)))
    A = 0.2 * rng.normal(size=(3, 6, 6))
    C = A @ np.swapaxes(A, -1, -2) + 1e-4 * np.eye(6)
    if rotation:
        T, C = T[:, :3, :3], C[:, :3, :3]
    ref = u.UncertainPose(T, C, "gtsam").to("ros", method="unscented").cov
    for backend in ("torch", "jax"):
        out = u.UncertainPose(to(T, backend), to(C, backend), "gtsam").to("ros", method="unscented")
        assert not isinstance(out.cov, np.ndarray)
        np.testing.assert_allclose(host(out.cov), ref, rtol=0, atol=1e-12)


def test_tensor_bad_input_names_argument_and_batch_index() -> None:
    T = torch.eye(4, dtype=torch.float64).expand(3, 4, 4)
    cov = torch.eye(6, dtype=torch.float64).repeat(3, 1, 1)
    cov[1, 2, 2] = -1.0
    with pytest.raises(ValueError, match=r"cov: .*batch index \(1,\)"):
        u.UncertainPose(T, cov, "gtsam")
    bad = T.clone()
    bad[2, 0, 0] = 2.0
    with pytest.raises(ValueError, match=r"T: .*batch index \(2,\)"):
        u.UncertainPose(bad, torch.eye(6, dtype=torch.float64), "gtsam")
    with pytest.raises(TypeError, match=r"cov: dtype torch\.float32 differs from T.s"):
        u.UncertainPose(T, torch.eye(6), "gtsam")
    A = u.UncertainPose(T, torch.eye(6, dtype=torch.float64), "gtsam")
    with pytest.raises(TypeError, match=r"B\.T: dtype"):
        u.compose(A, u.UncertainPose(torch.eye(4), torch.eye(6), "gtsam"))


def test_tensor_pose_is_not_an_alias_of_the_callers_tensor() -> None:
    T = torch.eye(4, dtype=torch.float64)
    cov = torch.eye(6, dtype=torch.float64)
    A = u.UncertainPose(T, cov, "gtsam")
    cov[0, 0] = 5.0
    assert float(A.cov[0, 0]) == 1.0


def test_docs_section_runs() -> None:
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "tensors.md").read_text("utf-8")
    start = text.index("## Uncertain poses and checks on tensors")
    end = text.find("\n## ", start + 1)
    section = text[start : None if end < 0 else end]
    blocks = re.findall(r"^```python\n(.*?)^```", section, re.M | re.S)
    assert blocks
    namespace: dict[str, Any] = {"__name__": "docs_tensors_uncertain"}
    for n, code in enumerate(blocks):
        exec(compile(code, f"tensors.md[uncertain block {n}]", "exec"), namespace)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_results_stay_on_the_callers_cuda_device() -> None:
    x = _inputs((4,), None, seed=12)
    dev = torch.device("cuda")
    t = {k: torch.tensor(v, device=dev) for k, v in x.items()}
    A = u.UncertainPose(t["TA"], t["joint"][..., :6, :6], "ros")
    B = u.UncertainPose(t["TB"], t["joint"][..., 6:, 6:], "ros")
    near = u.UncertainPose(t["TA"] @ se3.exp(0.05 * t["p"].new_ones(6)), A.cov, "ros")
    for r in [u.compose(A, B), u.relative(A, B), u.inverse(A), u.act(A, t["p"]), u.fuse(A, near)]:
        assert r.cov.device.type == "cuda"
    J = numerical_jacobian(lambda X: X @ t["TB"], t["TA"], in_convention="ros")
    assert J.device.type == "cuda"
    ref = u.compose(
        u.UncertainPose(x["TA"], x["joint"][..., :6, :6], "ros"),
        u.UncertainPose(x["TB"], x["joint"][..., 6:, 6:], "ros"),
    )
    np.testing.assert_allclose(host(u.compose(A, B).cov), ref.cov, atol=1e-12)


def test_plots_read_a_host_copy_of_tensors() -> None:
    """position() keeps the tensor type; the drawing reads a detached copy (equal to numpy's)."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from liebridge.uncertain import plot as uplot

    x = _inputs((2,), None, seed=14)
    d = torch.zeros(6, dtype=torch.float64, requires_grad=True)
    A = u.UncertainPose(
        torch.tensor(x["TA"]) @ se3.exp(d), torch.tensor(x["joint"][..., :6, :6]), "ros"
    )
    An = u.UncertainPose(x["TA"], x["joint"][..., :6, :6], "ros")
    pos = uplot.position(A)
    assert isinstance(pos.cov, torch.Tensor) and pos.cov.requires_grad
    np.testing.assert_allclose(host(pos.cov), uplot.position(An).cov, atol=1e-12)
    fig, ax = plt.subplots()
    lines = uplot.plot_position_ellipse(ax, A)
    ref = uplot.plot_position_ellipse(ax, An)
    for a, b in zip(lines, ref, strict=True):
        np.testing.assert_allclose(a.get_xydata(), b.get_xydata(), atol=1e-12)
    plt.close(fig)
    e = uplot.ellipse_points(pos.p[0, :2], pos.cov[0, :2, :2])
    assert isinstance(e, np.ndarray) and e.shape == (100, 2)
