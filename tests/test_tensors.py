"""The array-generic core on numpy, torch and JAX: same values, the caller's array type, gradients.

One harness over the backends (numpy is the reference; torch and JAX run when installed: the
extras ``torch`` and ``jax``), the SO(3)/SE(3) kernels, every convention that runs on tensors and
the conversions. Expected values come from numpy (itself checked against GTSAM and 50-digit
arithmetic elsewhere) and, for the kernels, from GTSAM directly.
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
from liebridge.lie import se3, so3

HAS = {name: importlib.util.find_spec(name) is not None for name in ("torch", "jax")}
BACKENDS = [
    "numpy",
    pytest.param("torch", marks=pytest.mark.skipif(not HAS["torch"], reason="torch extra")),
    pytest.param("jax", marks=pytest.mark.skipif(not HAS["jax"], reason="jax extra")),
]
#: float64 agreement with numpy; float32 (documented in docs/tensors.md): relative to the scale
TOL64, TOL32 = 1e-12, 2e-5


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


# ----------------------------------------------------------------------------- inputs
def _rotvecs() -> np.ndarray:
    """Rotation vectors at the edge cases: 0, 1e-12, 1e-6, generic, π − 1e-6, exactly π."""
    rng = np.random.default_rng(0)
    axis = np.array([0.48, -0.6, 0.64])
    return np.stack(
        [
            np.zeros(3),
            1e-12 * axis,
            1e-6 * axis,
            0.3 * axis,
            *rng.normal(size=(3, 3)),
            (np.pi - 1e-6) * axis,
            np.pi * np.array([1.0, 0.0, 0.0]),
            np.pi * axis,
        ]
    )


def _twists() -> np.ndarray:
    w = _rotvecs()
    rng = np.random.default_rng(1)
    v = rng.normal(size=w.shape)
    v[-1] = [30.0, -30.0, 12.0]  # 30 m
    return np.concatenate([w, v], axis=-1)


SHAPES = [(), (10,), (2, 5)]


def _batch(x: np.ndarray, shape: tuple[int, ...], core: int) -> np.ndarray:
    """The first prod(shape) rows of ``x``, reshaped to ``shape`` (``()``: one element)."""
    n = int(np.prod(shape)) if shape else 1
    rows = x[np.arange(n) % len(x)]
    return rows.reshape((*shape, *x.shape[1:])) if shape else rows[0]


# ----------------------------------------------------------------------------- kernels
KERNELS: list[tuple[str, Callable[..., Any], str]] = [
    ("so3.exp", so3.exp, "w"),
    ("so3.jr", so3.jr, "w"),
    ("so3.jl", so3.jl, "w"),
    ("so3.jr_inv", so3.jr_inv, "w"),
    ("so3.jl_inv", so3.jl_inv, "w"),
    ("so3.log", so3.log, "R"),
    ("so3.inverse", so3.inverse, "R"),
    ("so3.adjoint", so3.adjoint, "R"),
    ("se3.exp", se3.exp, "xi"),
    ("se3.jr", se3.jr, "xi"),
    ("se3.jl", se3.jl, "xi"),
    ("se3.jr_inv", se3.jr_inv, "xi"),
    ("se3.jl_inv", se3.jl_inv, "xi"),
    ("se3.log", se3.log, "T"),
    ("se3.inverse", se3.inverse, "T"),
    ("se3.adjoint", se3.adjoint, "T"),
]


def _input(kind: str) -> np.ndarray:
    if kind == "w":
        return _rotvecs()
    if kind == "xi":
        return _twists()
    if kind == "R":
        return so3.exp(_rotvecs())
    return se3.exp(_twists())


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize(("name", "f", "kind"), KERNELS, ids=[k[0] for k in KERNELS])
def test_kernel_same_values_and_array_type(
    B: Backend, name: str, f: Callable[..., Any], kind: str, shape: tuple[int, ...]
) -> None:
    core = 1 if kind in ("w", "xi") else 2
    x = _batch(_input(kind), shape, core)
    ref = f(x)
    out = B.check(f(B(x)))
    assert out.shape == ref.shape
    np.testing.assert_allclose(out, ref, rtol=0, atol=TOL64 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize("backend", BACKENDS[1:])
def test_float32_within_the_documented_tolerance(backend: str, x64: None) -> None:
    B32 = Backend(backend, "float32")
    xi = _twists()[[3, 4, 5, 6]]  # generic angles (float32 cannot place π − 1e-6)
    for f, x in [(se3.exp, xi), (se3.log, se3.exp(xi)), (se3.jr_inv, xi)]:
        ref = f(x)
        out = B32.check(f(B32(x)))
        np.testing.assert_allclose(out, ref, rtol=0, atol=TOL32 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize("backend", BACKENDS[1:])
def test_kernels_equal_gtsam(backend: str, x64: None) -> None:
    """The tensor path against GTSAM itself (not only against numpy)."""
    gtsam = pytest.importorskip("gtsam")
    B = Backend(backend)
    for xi in _twists():
        P = gtsam.Pose3.Expmap(xi)
        T = B.check(se3.exp(B(xi)))
        np.testing.assert_allclose(T, P.matrix(), atol=1e-12)
        np.testing.assert_allclose(B.check(se3.adjoint(B(T))), P.AdjointMap(), atol=1e-12)
        np.testing.assert_allclose(
            B.check(se3.jr_inv(B(xi))), gtsam.Pose3.LogmapDerivative(xi), atol=1e-9
        )
        if np.linalg.norm(xi[:3]) < np.pi - 1e-3:  # at π both ±π·u are logarithms
            np.testing.assert_allclose(B.check(se3.log(B(T))), xi, atol=1e-10)


@pytest.mark.parametrize("shape", SHAPES, ids=str)
def test_compose_act_interpolate(B: Backend, shape: tuple[int, ...]) -> None:
    T1 = _batch(se3.exp(_twists()), shape, 2)
    T2 = _batch(se3.exp(_twists()[::-1].copy()), shape, 2)
    p = _batch(np.random.default_rng(2).normal(size=(12, 3)), shape, 1)
    for f, args in [
        (se3.compose, (T1, T2)),
        (se3.act, (T1, p)),
        (so3.compose, (T1[..., :3, :3], T2[..., :3, :3])),
        (so3.act, (T1[..., :3, :3], p)),
    ]:
        np.testing.assert_allclose(B.check(f(*map(B, args))), f(*args), atol=1e-12)
    ref = se3.interpolate(T1, T2, 0.3)
    np.testing.assert_allclose(B.check(se3.interpolate(B(T1), B(T2), 0.3)), ref, atol=1e-10)


# ----------------------------------------------------------------------------- conventions
def _tensor_conventions() -> list[str]:
    """Every registered convention that runs on tensors (array-API group, rotation vector).

    Embedded tangents (``ros_pose2``) included.
    """
    out = []
    for name in lb.conventions.names():
        c = lb.conventions.get(name)
        if isinstance(c, Convention) and c.record.array_api and c.rotation in ("exp", "half_exp"):
            out.append(name)
    return out


TENSOR_CONVENTIONS = _tensor_conventions()


def test_the_tensor_conventions_include_the_learned_slam_ones() -> None:
    assert {"gtsam", "pypose", "sophus", "barfoot", "theseus", "jaxlie"} <= set(TENSOR_CONVENTIONS)
    assert {"gtsam_pose2", "gtsam_rot2", "gtsam_navstate", "ros_pose2"} <= set(TENSOR_CONVENTIONS)


def _element_for(c: Convention, shape: tuple[int, ...]) -> np.ndarray:
    if c.group in ("se3", "so3"):
        T = _batch(se3.exp(_twists()), shape, 2)
        return T[..., :3, :3] if c.group == "so3" else T
    g = c.record
    xi = np.random.default_rng(7).normal(size=(12, g.dim))
    if g.rot is not None:
        xi[0, g.rot] = 0.0
        xi[1, g.rot] = np.pi / np.sqrt(g.rot.stop - g.rot.start) * 0.999
    return _batch(g.exp(xi), shape, 2)


ARRAY_API_GROUPS = [name for name, g in lb.lie.GROUPS.items() if g.array_api]


def test_the_array_api_groups() -> None:
    assert {"so2", "se2", "so3", "se3", "se23"} <= set(ARRAY_API_GROUPS)


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize("group", ARRAY_API_GROUPS)
def test_every_array_api_group_record_same_values(
    B: Backend, group: str, shape: tuple[int, ...]
) -> None:
    """The record's validated kernels of every array-API group, on each backend."""
    g = lb.lie.GROUPS[group]
    xi = np.random.default_rng(8).normal(size=(12, g.dim))
    if g.rot is not None:
        xi[0, g.rot] = 0.0
        xi[1, g.rot] = 1e-9
    xi = _batch(xi, shape, 1)
    X = g.exp(xi)
    Y = g.exp(0.5 * xi[..., ::-1].copy())
    n = g.matrix - len(g.cols)
    p = _batch(np.random.default_rng(9).normal(size=(12, n)), shape, 1)
    cases = [
        (g.exp(B(xi)), X),
        (g.log(B(X)), g.log(X)),
        (g.inverse(B(X)), g.inverse(X)),
        (g.adjoint(B(X)), g.adjoint(X)),
        (g.compose(B(X), B(Y)), g.compose(X, Y)),
        (g.act(B(X), B(p)), g.act(X, p)),
        (g.interpolate(B(X), B(Y), 0.3), g.interpolate(X, Y, 0.3)),
    ] + [(getattr(g, k)(B(xi)), getattr(g, k)(xi)) for k in ("jr", "jl", "jr_inv", "jl_inv")]
    for out, ref in cases:
        np.testing.assert_allclose(B.check(out), ref, atol=1e-11 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize("name", TENSOR_CONVENTIONS)
def test_convention_maps_same_values(B: Backend, name: str, shape: tuple[int, ...]) -> None:
    c = lb.conventions.get(name)
    assert isinstance(c, Convention)
    X = _element_for(c, shape)
    n = c.dim(X)
    d = 0.3 * _batch(np.random.default_rng(3).normal(size=(12, n)), shape, 1)
    Y = c.retract(X, d)
    cases = [
        (c.retract(B(X), B(d)), Y),
        (c.local(B(X), B(Y)), c.local(X, Y)),
        (c.local_jacobian(B(X), B(Y)), c.local_jacobian(X, Y)),
        (c.to_canonical(B(X)), c.to_canonical(X)),
        (c.from_canonical(B(X)), c.from_canonical(X)),
    ]
    for out, ref in cases:
        np.testing.assert_allclose(B.check(out), ref, atol=1e-11 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize(
    ("src", "dst"),
    [("gtsam", "barfoot"), ("pypose", "sophus"), ("theseus", "gtsam"), ("jaxlie", "pypose")],
)
def test_conversions_same_values(B: Backend, src: str, dst: str, shape: tuple[int, ...]) -> None:
    X = _batch(se3.exp(_twists()), shape, 2)
    rng = np.random.default_rng(4)
    A = _batch(rng.normal(size=(12, 6, 6)), shape, 2)
    C = A @ np.swapaxes(A, -1, -2) + 1e-3 * np.eye(6)
    d = 0.2 * _batch(rng.normal(size=(12, 6)), shape, 1)
    cases = [
        (lb.tangent_map(B(X), src, dst), lb.tangent_map(X, src, dst)),
        (lb.convert_covariance(B(C), B(X), src, dst), lb.convert_covariance(C, X, src, dst)),
        (lb.convert_information(B(C), B(X), src, dst), lb.convert_information(C, X, src, dst)),
        (
            lb.convert_jacobian(B(A), B(X), src, dst, at_output=B(X)),
            lb.convert_jacobian(A, X, src, dst, at_output=X),
        ),
        (lb.convert_tangent(B(d), B(X), src, dst), lb.convert_tangent(d, X, src, dst)),
    ]
    for out, ref in cases:
        np.testing.assert_allclose(B.check(out), ref, atol=1e-11 * max(1.0, np.abs(ref).max()))


SE3_TENSOR_CONVENTIONS = [n for n in TENSOR_CONVENTIONS if lb.conventions.get(n).group == "se3"]


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize("name", SE3_TENSOR_CONVENTIONS)
def test_se3_convention_on_a_bare_rotation_same_values(
    B: Backend, name: str, shape: tuple[int, ...]
) -> None:
    """An SE(3) convention given rotations ``(..., 3, 3)`` acts as its SO(3) part, as on numpy."""
    c = lb.conventions.get(name)
    assert isinstance(c, Convention)
    R = _batch(so3.exp(_rotvecs()), shape, 2)
    assert c.dim(B(R)) == 3
    d = 0.3 * _batch(np.random.default_rng(5).normal(size=(12, 3)), shape, 1)
    S = c.retract(R, d)
    C = np.broadcast_to(np.diag([0.1, 0.2, 0.3]), (*shape, 3, 3))
    cases = [
        (c.retract(B(R), B(d)), S),
        (c.local(B(R), B(S)), c.local(R, S)),
        (c.local_jacobian(B(R), B(S)), c.local_jacobian(R, S)),
        (c.to_canonical(B(R)), c.to_canonical(R)),
        (c.from_canonical(B(R)), c.from_canonical(R)),
        (lb.tangent_map(B(R), name, "barfoot"), lb.tangent_map(R, name, "barfoot")),
        (
            lb.convert_covariance(B(C), B(R), "gtsam", name),
            lb.convert_covariance(C, R, "gtsam", name),
        ),
    ]
    for out, ref in cases:
        np.testing.assert_allclose(B.check(out), ref, atol=1e-11 * max(1.0, np.abs(ref).max()))


def test_mixed_arguments_take_the_tensor_type(x64: None) -> None:
    torch = pytest.importorskip("torch")
    X = se3.exp(_twists()[:4])
    C = np.broadcast_to(np.eye(6), (4, 6, 6))
    out = lb.convert_covariance(C, torch.tensor(X), "gtsam", "barfoot")
    assert isinstance(out, torch.Tensor) and out.dtype == torch.float64
    ref = lb.convert_covariance(C, X, "gtsam", "barfoot")
    np.testing.assert_allclose(out.numpy(), ref, rtol=0, atol=1e-14)


# ----------------------------------------------------------------------------- gradients
GRAD_POINTS = {
    "zero": np.zeros(6),
    "1e-9": 1e-9 * np.array([0.3, -0.5, 0.8, 1.0, 2.0, -1.0]),
    "generic": np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8]),
    "near_pi": np.array([np.pi - 1e-3, 0.0, 0.0, 1.0, 2.0, 3.0]),
}


def _fns(torchlike: bool) -> dict[str, Callable[..., Any]]:
    """Functions of a tangent perturbation ``d`` at ``X0 = exp(ξ)`` (stays a valid pose)."""

    def at(xi: Any, d: Any) -> Any:
        return se3.exp(xi) @ se3.exp(d)

    return {
        "se3.exp": lambda xi, d: se3.exp(xi + d),
        "se3.log": lambda xi, d: se3.log(at(xi, d)),
        "tangent_map": lambda xi, d: lb.tangent_map(at(xi, d), "pypose", "gtsam"),
        "convert_covariance": lambda xi, d: lb.convert_covariance(
            se3.jr(xi) @ arrays.mT(se3.jr(xi)), at(xi, d), "gtsam", "barfoot"
        ),
    }


@pytest.mark.parametrize("point", list(GRAD_POINTS))
@pytest.mark.parametrize("fn", list(_fns(True)))
def test_torch_gradcheck(fn: str, point: str) -> None:
    torch = pytest.importorskip("torch")
    xi = torch.tensor(GRAD_POINTS[point], dtype=torch.float64)
    d = torch.zeros(6, dtype=torch.float64, requires_grad=True)
    f = _fns(True)[fn]
    assert torch.autograd.gradcheck(lambda d: f(xi, d), (d,))
    if fn == "se3.exp":  # the twist itself, too
        x = xi.clone().requires_grad_(True)
        assert torch.autograd.gradcheck(se3.exp, (x,))


@pytest.mark.parametrize("point", list(GRAD_POINTS))
@pytest.mark.parametrize("fn", list(_fns(False)))
def test_jax_check_grads(fn: str, point: str, x64: None) -> None:
    jax = pytest.importorskip("jax")
    from jax.test_util import check_grads

    xi = jax.numpy.asarray(GRAD_POINTS[point])
    f = _fns(False)[fn]
    check_grads(lambda d: f(xi, d), (jax.numpy.zeros(6),), order=1, modes=("fwd", "rev"))


def test_gradient_at_the_identity_is_finite_the_pypose_395_kornia_4404_bug(x64: None) -> None:
    """``d/dξ log(exp(ξ))`` at ξ = 0 is the identity: a naive ``‖ω‖`` there gives NaN."""
    torch = pytest.importorskip("torch")
    x = torch.zeros(6, dtype=torch.float64, requires_grad=True)
    J = torch.autograd.functional.jacobian(lambda x: se3.log(se3.exp(x)), x)
    assert torch.isfinite(J).all()
    np.testing.assert_allclose(J.numpy(), np.eye(6), atol=1e-12)
    R = torch.autograd.functional.jacobian(
        lambda w: so3.exp(w), torch.zeros(3, dtype=torch.float64)
    )
    assert torch.isfinite(R).all()
    if HAS["jax"]:
        import jax

        Jj = jax.jacfwd(lambda x: se3.log(se3.exp(x)))(jax.numpy.zeros(6))
        np.testing.assert_allclose(np.asarray(Jj), np.eye(6), atol=1e-12)
        Jr = jax.jacrev(lambda x: se3.log(se3.exp(x)))(jax.numpy.zeros(6))
        np.testing.assert_allclose(np.asarray(Jr), np.eye(6), atol=1e-12)


# ----------------------------------------------------------------------------- tracing
def test_jax_jit_and_vmap_of_convert_covariance(x64: None) -> None:
    jax = pytest.importorskip("jax")
    X = se3.exp(_twists()[:5])
    C = np.broadcast_to(np.diag([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3]), (5, 6, 6))
    ref = lb.convert_covariance(C, X, "gtsam", "barfoot")
    f = jax.jit(lambda C, X: lb.convert_covariance(C, X, "gtsam", "barfoot"))
    np.testing.assert_allclose(np.asarray(f(C, X)), ref, atol=1e-14)
    g = jax.jit(jax.vmap(lambda C, X: lb.convert_covariance(C, X, "gtsam", "barfoot")))
    np.testing.assert_allclose(np.asarray(g(C, X)), ref, atol=1e-14)


def test_torch_compile_of_convert_covariance() -> None:
    torch = pytest.importorskip("torch")
    X = torch.tensor(se3.exp(_twists()[:5]))
    C = torch.diag(torch.tensor([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3], dtype=torch.float64))
    f = torch.compile(lambda C, X: lb.convert_covariance(C, X, "gtsam", "barfoot"))
    ref = lb.convert_covariance(C.numpy(), X.numpy(), "gtsam", "barfoot")
    np.testing.assert_allclose(f(C, X).numpy(), ref, atol=1e-14)


# ----------------------------------------------------------------------------- errors
def test_tensor_validation_names_argument_and_batch_index(x64: None) -> None:
    torch = pytest.importorskip("torch")
    T = torch.tensor(se3.exp(_twists()[:4]))
    T[2, 0, 0] += 1e-3
    with pytest.raises(ValueError, match=r"X: not a rotation at batch index \(2,\)"):
        lb.tangent_map(T, "gtsam", "barfoot")
    with pytest.raises(ValueError, match=r"xi: contains NaN or Inf at batch index \(1,\)"):
        se3.exp(torch.tensor([[0.0] * 6, [float("nan")] + [0.0] * 5], dtype=torch.float64))
    with pytest.raises(ValueError, match=r"expected shape \(\.\.\., 6\)"):
        se3.exp(torch.zeros(5, dtype=torch.float64))


def test_jit_checks_shapes_not_values(x64: None) -> None:
    """Under ``jax.jit`` values are unknown: shapes are still checked (docs/tensors.md)."""
    jax = pytest.importorskip("jax")
    with pytest.raises(ValueError, match=r"expected shape"):
        jax.jit(se3.exp)(jax.numpy.zeros(5))
    bad = jax.numpy.asarray(2.0 * np.eye(4))
    out = jax.jit(se3.log)(bad)  # not a pose: nothing can be checked while tracing
    assert out.shape == (6,)


def test_integer_tensors_become_float64(x64: None) -> None:
    torch = pytest.importorskip("torch")
    out = se3.exp(torch.zeros(6, dtype=torch.int64))
    assert out.dtype == torch.float64


def test_library_pose_objects_are_read_wherever_a_pose_is(x64: None) -> None:
    """A PyPose ``LieTensor`` (a torch subclass) goes in as the pose it holds, graph kept."""
    torch = pytest.importorskip("torch")
    pp = pytest.importorskip("pypose")
    X = pp.randn_SE3(3, dtype=torch.float64, requires_grad=True)
    T = X.matrix()
    M = lb.tangent_map(X, "pypose", "gtsam")
    assert type(M) is torch.Tensor and M.requires_grad
    np.testing.assert_allclose(
        M.detach().numpy(), lb.tangent_map(T.detach().numpy(), "pypose", "gtsam")
    )
    np.testing.assert_allclose(se3.log(X).detach().numpy(), se3.log(T.detach().numpy()), atol=1e-12)
