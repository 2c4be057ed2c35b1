"""Sim(3) on numpy, torch and JAX: same values, the caller's array type, gradients, validation.

numpy is the reference (itself held to GTSAM and 50-digit arithmetic in ``test_lie_kernels.py``);
the tensor path is also held to GTSAM's ``Similarity3`` directly and, for the Jacobians, to the
exact ``φ(ad_ξ)`` in 40-digit arithmetic (mpmath), where scipy's ``expm`` of the numpy path
loses digits at large log-scales.
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
from liebridge.lie import sim3

HAS = {name: importlib.util.find_spec(name) is not None for name in ("torch", "jax")}
BACKENDS = [
    "numpy",
    pytest.param("torch", marks=pytest.mark.skipif(not HAS["torch"], reason="torch extra")),
    pytest.param("jax", marks=pytest.mark.skipif(not HAS["jax"], reason="jax extra")),
]
TENSORS = BACKENDS[1:]
#: float64 agreement with numpy; float32 (docs/tensors.md): relative to the largest entry
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


def _close(out: np.ndarray, ref: np.ndarray, tol: float = TOL64) -> None:
    assert out.shape == ref.shape
    np.testing.assert_allclose(out, ref, rtol=0, atol=tol * max(1.0, float(np.abs(ref).max())))


# ----------------------------------------------------------------------------- inputs
AXIS = np.array([0.48, -0.6, 0.64])
ANGLES = [0.0, 1e-12, 1e-6, 0.3, 1.7, np.pi - 1e-6, np.pi]
LOG_SCALES = [0.0, 1e-9, -1e-9, 0.4, 3.0, -3.0]


def _tangents() -> np.ndarray:
    """Every angle × every log-scale (θ = 0, 1e-12, 1e-6, …, π − 1e-6, π; λ = 0, ±1e-9, ±3),
    translations generic or 30 m."""
    rng = np.random.default_rng(0)
    rows = []
    for k, th in enumerate(ANGLES):
        for j, lam in enumerate(LOG_SCALES):
            u = np.array([30.0, -30.0, 12.0]) if (k + j) % 3 == 0 else rng.normal(size=3)
            rows.append(np.concatenate([th * AXIS, u, [lam]]))
    return np.array(rows)


XI = _tangents()
SHAPES = [(), (XI.shape[0],), (6, 7)]


def _batch(x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The first prod(shape) rows of ``x`` (cycled), reshaped to ``shape`` (``()``: one row)."""
    n = int(np.prod(shape)) if shape else 1
    rows = x[np.arange(n) % len(x)]
    return rows.reshape((*shape, *x.shape[1:])) if shape else rows[0]


# ----------------------------------------------------------------------------- kernels
UNARY: list[tuple[str, Callable[..., Any], str]] = [
    ("exp", sim3.exp, "xi"),
    ("jr", sim3.jr, "xi"),
    ("jl", sim3.jl, "xi"),
    ("jr_inv", sim3.jr_inv, "xi"),
    ("jl_inv", sim3.jl_inv, "xi"),
    ("hat", sim3.hat, "xi"),
    ("log", sim3.log, "X"),
    ("inverse", sim3.inverse, "X"),
    ("adjoint", sim3.adjoint, "X"),
    ("vee", sim3.vee, "X"),
]


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize(("name", "f", "kind"), UNARY, ids=[k[0] for k in UNARY])
def test_kernel_same_values_and_array_type(
    B: Backend, name: str, f: Callable[..., Any], kind: str, shape: tuple[int, ...]
) -> None:
    x = _batch(XI if kind == "xi" else sim3.exp(XI), shape)
    _close(B.check(f(B(x))), f(x))


@pytest.mark.parametrize("shape", SHAPES, ids=str)
def test_compose_act_interpolate(B: Backend, shape: tuple[int, ...]) -> None:
    X1 = _batch(sim3.exp(XI), shape)
    X2 = _batch(sim3.exp(0.5 * XI[::-1]), shape)
    p = _batch(np.random.default_rng(2).normal(size=(len(XI), 3)), shape)
    _close(B.check(sim3.compose(B(X1), B(X2))), sim3.compose(X1, X2))
    _close(B.check(sim3.act(B(X1), B(p))), sim3.act(X1, p))
    ref = sim3.interpolate(X1, X2, 0.3)
    _close(B.check(sim3.interpolate(B(X1), B(X2), 0.3)), ref, 1e-10)


@pytest.mark.parametrize("backend", TENSORS)
def test_exp_log_round_trip_and_record(backend: str, x64: None) -> None:
    """``log(exp(ξ)) = ξ`` below π; the record (``lie.group("sim3")``) runs the same kernels."""
    B = Backend(backend)
    g = lb.lie.group("sim3")
    assert g.array_api
    xi = XI[np.linalg.norm(XI[:, :3], axis=-1) < 3.0]
    _close(B.check(sim3.log(sim3.exp(B(xi)))), xi, 1e-10)
    for k in ("exp", "jr", "jl", "jr_inv", "jl_inv"):
        _close(B.check(getattr(g, k)(B(XI))), getattr(sim3, k)(XI))
    X = sim3.exp(XI)
    for k in ("log", "inverse", "adjoint"):
        _close(B.check(getattr(g, k)(B(X))), getattr(sim3, k)(X))


@pytest.mark.parametrize("backend", TENSORS)
def test_float32_within_the_documented_tolerance(backend: str, x64: None) -> None:
    B32 = Backend(backend, "float32")
    xi = XI[(np.abs(XI[:, 6]) > 0.1) & (np.linalg.norm(XI[:, :3], axis=-1) < 2.0)]
    for f, x in [(sim3.exp, xi), (sim3.log, sim3.exp(xi)), (sim3.jl, xi), (sim3.jr_inv, xi)]:
        _close(B32.check(f(B32(x))), f(x), TOL32)


# ----------------------------------------------------------------------------- exact references
def _ad(xi: np.ndarray) -> np.ndarray:
    """``ad_ξ`` written out from the bracket of ``[[hat ω + λI, u], [0, 0]]`` (test's own)."""
    w, u, lam = xi[:3], xi[3:6], xi[6]

    def H(v: np.ndarray) -> np.ndarray:
        return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])

    A = np.zeros((7, 7))
    A[:3, :3] = H(w)
    A[3:6, :3] = H(u)
    A[3:6, 3:6] = H(w) + lam * np.eye(3)
    A[3:6, 6] = -u
    return A


def _phi_mp(A: np.ndarray) -> np.ndarray:
    """``φ(A) = Σ Aᵏ/(k+1)!`` in 40 digits: the top-right block of ``expm([[A, I], [0, 0]])``."""
    mp = pytest.importorskip("mpmath")
    with mp.workdps(40):
        n = A.shape[0]
        big = mp.zeros(2 * n, 2 * n)
        for i in range(n):
            for j in range(n):
                big[i, j] = mp.mpf(float(A[i, j]))
            big[i, n + i] = 1
        E = mp.expm(big)
        return np.array([[float(E[i, n + j]) for j in range(n)] for i in range(n)])


@pytest.mark.parametrize("backend", TENSORS)
@pytest.mark.parametrize(
    ("theta", "lam"),
    [(0.0, 0.0), (1e-6, 3.0), (0.9, -1.8), (1.0, 1.9), (2.0, 0.0), (np.pi - 1e-6, 10.0),
     (np.pi - 1e-6, 30.0), (np.pi, -30.0), (0.5, 60.0)],
)  # fmt: skip
def test_jacobians_equal_the_exact_phi_of_ad(
    backend: str, theta: float, lam: float, x64: None
) -> None:
    """``jl = φ(ad_ξ)``, ``jr = φ(−ad_ξ)`` to 1e-14 relative, in every branch of the closed form.

    (|z| < 2: quadrature; θ ≥ 1: the projection form; θ < 1, |λ| > √3: ``M⁻¹P₂``.) scipy's
    ``expm`` on the numpy path is off by 2e-12 at λ = 30 with a 30 m translation.
    """
    B = Backend(backend)
    xi = np.concatenate([theta * AXIS, [30.0, -30.0, 12.0], [lam]])
    for f, ref in [(sim3.jl, _phi_mp(_ad(xi))), (sim3.jr, _phi_mp(-_ad(xi)))]:
        _close(B.check(f(B(xi))), ref, 1e-14)
    Jl = B.check(sim3.jl(B(xi)))
    _close(B.check(sim3.jl_inv(B(xi))) @ Jl, np.eye(7), 1e-12 * float(np.abs(Jl).max()))


@pytest.mark.parametrize("lam", [50.0, -50.0, 200.0])
def test_numpy_jl_inv_at_a_large_log_scale_the_dense_inverse_bug(lam: float) -> None:
    """numpy's ``jl_inv``/``jr_inv`` were ``inv`` of the 7×7 ``expm`` block: relative error 1.09
    at λ = 50, garbage at 200. Now the block inverse of the closed form, as on tensors."""
    xi = np.concatenate([0.7 * AXIS, [30.0, -30.0, 12.0], [lam]])
    for f, f_inv, A in [(sim3.jl, sim3.jl_inv, _ad(xi)), (sim3.jr, sim3.jr_inv, -_ad(xi))]:
        J = f(xi)
        _close(J, _phi_mp(A), 1e-13)
        Ji = f_inv(xi)
        _close(Ji @ J, np.eye(7), 1e-12 * float(np.abs(J).max() * np.abs(Ji).max()))
        _close(J @ Ji, np.eye(7), 1e-12 * float(np.abs(J).max() * np.abs(Ji).max()))


@pytest.mark.parametrize("backend", TENSORS)
def test_jacobians_by_central_differences(backend: str, x64: None) -> None:
    """``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr δ)`` and ``≈ Exp(jl δ)·Exp(ξ)``, through ``log``, on tensors."""
    B = Backend(backend)
    h = 1e-6
    for xi in XI[[3, 10, 20, 27, 40]]:
        X = B(sim3.exp(xi))
        Xi = sim3.inverse(X)
        E = np.eye(7)
        right = np.stack(
            [
                (B.check(sim3.log(Xi @ sim3.exp(B(xi + h * e))))
                 - B.check(sim3.log(Xi @ sim3.exp(B(xi - h * e))))) / (2 * h)
                for e in E
            ],
            axis=-1,
        )  # fmt: skip
        left = np.stack(
            [
                (B.check(sim3.log(sim3.exp(B(xi + h * e)) @ Xi))
                 - B.check(sim3.log(sim3.exp(B(xi - h * e)) @ Xi))) / (2 * h)
                for e in E
            ],
            axis=-1,
        )  # fmt: skip
        scale = max(1.0, float(np.abs(right).max()))
        np.testing.assert_allclose(B.check(sim3.jr(B(xi))), right, atol=1e-6 * scale)
        np.testing.assert_allclose(B.check(sim3.jl(B(xi))), left, atol=1e-6 * scale)


@pytest.mark.parametrize("backend", TENSORS)
def test_kernels_equal_gtsam_similarity3(backend: str, x64: None) -> None:
    """The tensor path against GTSAM's ``Similarity3`` itself (its matrix ``[R t/s; 0 1/s]``)."""
    gtsam = pytest.importorskip("gtsam")
    B = Backend(backend)
    for xi in XI:
        E = gtsam.Similarity3.Expmap(xi).matrix()
        X = B.check(sim3.exp(B(xi)))
        _close(X, E / E[3, 3])
        s = float(np.cbrt(np.linalg.det(X[:3, :3])))
        S = gtsam.Similarity3(gtsam.Rot3(X[:3, :3] / s), X[:3, 3] / s, s)
        _close(B.check(sim3.adjoint(B(X))), S.AdjointMap())
        if np.linalg.norm(xi[:3]) < np.pi - 1e-3:  # at π both ±π·u are logarithms
            _close(B.check(sim3.log(B(X))), gtsam.Similarity3.Logmap(S), 1e-10)


# ----------------------------------------------------------------------------- conventions
SIM3_CONVENTIONS = [
    n for n in lb.conventions.names() if getattr(lb.conventions.get(n), "group", None) == "sim3"
]


def test_the_sim3_conventions() -> None:
    assert {"gtsam_similarity3", "sophus_sim3", "pypose_sim3", "g2o_sim3"} <= set(SIM3_CONVENTIONS)


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize("name", SIM3_CONVENTIONS)
def test_convention_maps_same_values(B: Backend, name: str, shape: tuple[int, ...]) -> None:
    c = lb.conventions.get(name)
    assert isinstance(c, Convention)
    X = _batch(sim3.exp(XI), shape)
    d = 0.3 * _batch(np.random.default_rng(3).normal(size=(len(XI), 7)), shape)
    Y = c.retract(X, d)
    for out, ref in [
        (c.retract(B(X), B(d)), Y),
        (c.local(B(X), B(Y)), c.local(X, Y)),
        (c.local_jacobian(B(X), B(Y)), c.local_jacobian(X, Y)),
        (c.to_canonical(B(X)), c.to_canonical(X)),
        (c.from_canonical(B(X)), c.from_canonical(X)),
    ]:
        _close(B.check(out), ref, 1e-11)


PAIRS = [("gtsam_similarity3", "sophus_sim3"), ("pypose_sim3", "g2o_sim3")]


@pytest.mark.parametrize("shape", SHAPES, ids=str)
@pytest.mark.parametrize(("src", "dst"), PAIRS)
def test_conversions_same_values(B: Backend, src: str, dst: str, shape: tuple[int, ...]) -> None:
    X = _batch(sim3.exp(XI), shape)
    rng = np.random.default_rng(4)
    A = _batch(rng.normal(size=(len(XI), 7, 7)), shape)
    C = A @ np.swapaxes(A, -1, -2) + 1e-3 * np.eye(7)
    d = 0.2 * _batch(rng.normal(size=(len(XI), 7)), shape)
    for out, ref in [
        (lb.tangent_map(B(X), src, dst), lb.tangent_map(X, src, dst)),
        (lb.convert_covariance(B(C), B(X), src, dst), lb.convert_covariance(C, X, src, dst)),
        (lb.convert_tangent(B(d), B(X), src, dst), lb.convert_tangent(d, X, src, dst)),
    ]:
        _close(B.check(out), ref, 1e-11)


# ----------------------------------------------------------------------------- gradients
GRAD_POINTS = {
    "zero": np.zeros(7),
    "1e-9": 1e-9 * np.array([0.3, -0.5, 0.8, 1.0, 2.0, -1.0, 0.7]),
    "generic": np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8, 0.3]),
    "big_scale": np.array([0.1, 0.2, -0.1, 1.0, 0.5, -2.0, 2.5]),
    "near_pi": np.array([np.pi - 1e-3, 0.0, 0.0, 1.0, 2.0, 3.0, -0.4]),
}


def _fns() -> dict[str, Callable[..., Any]]:
    """Functions of a perturbation ``d`` at ``X0 = exp(ξ)`` (stays a valid similarity)."""

    def at(xi: Any, d: Any) -> Any:
        return sim3.exp(xi) @ sim3.exp(d)

    return {
        "sim3.exp": lambda xi, d: sim3.exp(xi + d),
        "sim3.log": lambda xi, d: sim3.log(at(xi, d)),
        "sim3.jl": lambda xi, d: sim3.jl(xi + d),
        "sim3.jr_inv": lambda xi, d: sim3.jr_inv(xi + d),
        "convert_covariance": lambda xi, d: lb.convert_covariance(
            sim3.jr(xi) @ arrays.mT(sim3.jr(xi)), at(xi, d), "gtsam_similarity3", "pypose_sim3"
        ),
    }


@pytest.mark.parametrize("point", list(GRAD_POINTS))
@pytest.mark.parametrize("fn", list(_fns()))
def test_torch_gradcheck(fn: str, point: str) -> None:
    torch = pytest.importorskip("torch")
    xi = torch.tensor(GRAD_POINTS[point], dtype=torch.float64)
    d = torch.zeros(7, dtype=torch.float64, requires_grad=True)
    f = _fns()[fn]
    assert torch.autograd.gradcheck(lambda d: f(xi, d), (d,))


@pytest.mark.parametrize("point", list(GRAD_POINTS))
@pytest.mark.parametrize("fn", list(_fns()))
def test_jax_check_grads(fn: str, point: str, x64: None) -> None:
    jax = pytest.importorskip("jax")
    from jax.test_util import check_grads

    xi = jax.numpy.asarray(GRAD_POINTS[point])
    f = _fns()[fn]
    check_grads(lambda d: f(xi, d), (jax.numpy.zeros(7),), order=1, modes=("fwd", "rev"))


def test_gradient_of_log_exp_at_the_identity_is_the_identity(x64: None) -> None:
    """``d/dξ log(exp(ξ))`` at ξ = 0 is I₇: no NaN of ``‖ω‖``'s derivative or ``expm1(λ)/λ``."""
    torch = pytest.importorskip("torch")
    J = torch.autograd.functional.jacobian(
        lambda x: sim3.log(sim3.exp(x)), torch.zeros(7, dtype=torch.float64)
    )
    np.testing.assert_allclose(J.numpy(), np.eye(7), atol=1e-12)
    if HAS["jax"]:
        import jax

        for jac in (jax.jacfwd, jax.jacrev):
            Jj = jac(lambda x: sim3.log(sim3.exp(x)))(jax.numpy.zeros(7))
            np.testing.assert_allclose(np.asarray(Jj), np.eye(7), atol=1e-12)


# ----------------------------------------------------------------------------- tracing
def test_jax_jit_and_vmap(x64: None) -> None:
    jax = pytest.importorskip("jax")
    X = sim3.exp(XI[:6])
    C = np.broadcast_to(np.diag([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3, 0.01]), (6, 7, 7))
    ref = lb.convert_covariance(C, X, "gtsam_similarity3", "pypose_sim3")
    tol = 1e-14 * float(np.abs(ref).max())

    def conv(C: Any, X: Any) -> Any:
        return lb.convert_covariance(C, X, "gtsam_similarity3", "pypose_sim3")

    np.testing.assert_allclose(np.asarray(jax.jit(conv)(C, X)), ref, atol=tol)
    np.testing.assert_allclose(np.asarray(jax.jit(jax.vmap(conv))(C, X)), ref, atol=tol)
    for f1, x in [(sim3.exp, XI), (sim3.jl_inv, XI), (sim3.log, sim3.exp(XI))]:
        _close(np.asarray(jax.jit(f1)(x)), f1(x))


@pytest.mark.exhaustive  # torch.compile ≈ 15 s: CI compiles in test_tensors.py and _quat
def test_torch_compile() -> None:
    torch = pytest.importorskip("torch")
    X = torch.tensor(sim3.exp(XI[:6]))
    C = torch.diag(torch.tensor([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3, 0.01], dtype=torch.float64))
    f = torch.compile(lambda C, X: lb.convert_covariance(C, X, "gtsam_similarity3", "pypose_sim3"))
    ref = lb.convert_covariance(C.numpy(), X.numpy(), "gtsam_similarity3", "pypose_sim3")
    np.testing.assert_allclose(f(C, X).numpy(), ref, atol=1e-14 * float(np.abs(ref).max()))


# ----------------------------------------------------------------------------- errors
@pytest.mark.parametrize("backend", TENSORS)
def test_validation_names_argument_and_batch_index(backend: str, x64: None) -> None:
    B = Backend(backend)
    X = sim3.exp(XI[:4])
    bad = X.copy()
    bad[2, 0, 0] += 1e-3
    with pytest.raises(ValueError, match=r"X: its linear block divided by its scale is not a "
                       r"rotation at batch index \(2,\): max\|RᵀR − I\| = "):  # fmt: skip
        sim3.log(B(bad))
    with pytest.raises(ValueError, match=r"X: its linear block .* at batch index \(2,\)"):
        lb.tangent_map(B(bad), "gtsam_similarity3", "sophus_sim3")
    nan = X.copy()
    nan[1, 0, 3] = np.nan
    with pytest.raises(ValueError, match=r"X1: contains NaN or Inf at batch index \(1,\)"):
        sim3.compose(B(nan), B(X))
    xi = XI[:3].copy()
    xi[1, 6] = -800.0
    with pytest.raises(ValueError, match=r"xi: log-scale λ = -800 at batch index \(1,\)"):
        sim3.exp(B(xi))
    with pytest.raises(ValueError, match=r"xi: log-scale λ = -800 at batch index \(1,\)"):
        sim3.jl(B(xi))
    flip = X.copy()
    flip[3, :3, :3] *= -1.0
    with pytest.raises(ValueError, match=r"X: Sim\(3\) scale .* ≤ 0 at batch index \(3,\)"):
        sim3.adjoint(B(flip))
    gtsam_form = X / 2.0
    gtsam_form[..., 3, :3] = 0.0
    with pytest.raises(ValueError, match=r"at batch index \(0,\).*GTSAM's Similarity3.matrix"):
        sim3.inverse(B(gtsam_form))
    with pytest.raises(ValueError, match=r"expected shape \(\.\.\., 7\)"):
        sim3.exp(B(np.zeros(6)))


def test_a_tiny_or_huge_scale_is_validated_without_overflow(x64: None) -> None:
    """``s³`` of ``s = e^{±300}`` is not a float64: the certificate scales by the largest entry."""
    torch = pytest.importorskip("torch")
    xi = np.array([[0.3, 0.2, -0.1, 1.0, 2.0, 3.0, 300.0], [0.3, 0.2, -0.1, 1.0, 2.0, 3.0, -300.0]])
    X = sim3.exp(xi)
    out = sim3.log(torch.tensor(X))
    np.testing.assert_allclose(out.numpy(), sim3.log(X), rtol=1e-12, atol=1e-12)


def test_jit_checks_shapes_not_values(x64: None) -> None:
    jax = pytest.importorskip("jax")
    with pytest.raises(ValueError, match=r"expected shape"):
        jax.jit(sim3.exp)(jax.numpy.zeros(6))
    out = jax.jit(sim3.exp)(jax.numpy.asarray([0.0] * 6 + [-800.0]))  # not checked while tracing
    assert out.shape == (4, 4)


def test_tensor_inputs_keep_their_graph_and_device(x64: None) -> None:
    torch = pytest.importorskip("torch")
    xi = torch.tensor(XI[:5], requires_grad=True)
    Xt = sim3.exp(xi)
    assert type(Xt) is torch.Tensor and Xt.requires_grad and Xt.device == xi.device
    sim3.log(Xt).sum().backward()
    assert xi.grad is not None and torch.isfinite(xi.grad).all()


def test_torch_func_transforms(x64: None) -> None:
    """``torch.func.jacfwd``/``jacrev``/``vmap`` (values unknown there: no value branch needed)."""
    torch = pytest.importorskip("torch")
    from torch.func import jacfwd, jacrev, vmap

    zero = torch.zeros(7, dtype=torch.float64)
    for jac in (jacfwd, jacrev):
        J = jac(lambda x: sim3.log(sim3.exp(x)))(zero)
        np.testing.assert_allclose(J.numpy(), np.eye(7), atol=1e-12)
    xi = torch.tensor(XI[:8])
    _close(vmap(sim3.jl)(xi).numpy(), sim3.jl(XI[:8]))
    X = sim3.exp(XI[3])
    c = lb.conventions.get("pypose_sim3")
    assert isinstance(c, Convention)
    D = jacfwd(lambda d: c.retract(torch.tensor(X), d))(zero)  # ∂/∂d Exp(d)·X at d = 0
    P = c.to_canonical(X)  # canonical tangent per unit of pypose's
    ref = np.einsum("ij,jkl->ikl", X, sim3.hat(np.eye(7)).transpose(1, 2, 0)) @ P
    _close(D.numpy(), ref)
