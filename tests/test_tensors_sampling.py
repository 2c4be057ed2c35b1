"""The sampling methods on torch tensors and JAX arrays: the unscented operations and Monte Carlo.

``method="unscented"`` of every uncertain operation and the Monte Carlo references of
``liebridge.check`` over numpy, torch and JAX: numpy is the reference (float64 to 1e-12 relative
to the largest entry; float32 to 2e-5), with the same seed for the Monte Carlo draws; batch
shapes (), (n,), (a, b); poses and rotations; the caller's array type and dtype returned;
gradients by ``torch.autograd.gradcheck`` and ``jax.test_util.check_grads`` (also at θ = 0);
the tensor Monte Carlo against the linear propagation, with a tolerance from the sample count;
``jax.jit`` of an unscented compose.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from liebridge import arrays, check
from liebridge import uncertain as u
from liebridge.lie import se3

HAS = {name: importlib.util.find_spec(name) is not None for name in ("torch", "jax")}
pytest.importorskip("array_api_compat")
BACKENDS = [
    "numpy",
    pytest.param("torch", marks=pytest.mark.skipif(not HAS["torch"], reason="torch extra")),
    pytest.param("jax", marks=pytest.mark.skipif(not HAS["jax"], reason="jax extra")),
]
FOREIGN = BACKENDS[1:]
#: float64 agreement with numpy; float32 (docs/tensors.md): relative to the largest entry
TOL64, TOL32 = 1e-12, 2e-5
SHAPES = [(), (3,), (2, 2)]


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
    """Make arrays of one library and read them back (as tests/test_tensors.py's)."""

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


def _close(got: np.ndarray, ref: np.ndarray, rtol: float, what: str) -> None:
    """``got`` within ``rtol`` of ``ref``, relative to ``ref``'s largest entry."""
    assert got.shape == ref.shape, what
    scale = max(float(np.abs(ref).max()), 1e-300)
    err = float(np.abs(got - ref).max()) / scale
    assert err <= rtol, f"{what}: {err:.3g} > {rtol:g}"


# ----------------------------------------------------------------------------- inputs
def _spd(rng: np.random.Generator, shape: tuple[int, ...], n: int, scale: float) -> np.ndarray:
    L = rng.normal(size=(*shape, n, n))
    return np.asarray(scale * (L @ np.swapaxes(L, -1, -2) / n + 0.2 * np.eye(n)))


def _inputs(shape: tuple[int, ...], seed: int = 0, scale: float = 1e-2) -> dict[str, np.ndarray]:
    """Poses (one of rotation angle exactly 0 in a batch), a correlated joint, a point."""
    rng = np.random.default_rng(seed)
    xi = rng.normal(size=(*shape, 3, 6))
    if shape:
        xi.reshape(-1, 3, 6)[0, 0, :3] = 0.0  # θ = 0 exactly in the batch
    T = np.asarray(se3.exp(xi))
    return {
        "TA": T[..., 0, :, :],
        "TB": T[..., 1, :, :],
        "TF": T[..., 2, :, :],
        "joint": _spd(rng, shape, 12, scale),
        "p": rng.normal(size=(*shape, 3)),
        "cov_p": _spd(rng, shape, 3, scale),
    }


OPS = [
    "compose",
    "compose_cross",
    "inverse",
    "relative_cross",
    "transform_left",
    "transform_right",
    "extrinsic",
    "act",
    "act_exact_point",
]


def _unscented(op: str, name: str, x: dict[str, np.ndarray], b: Backend, rotation: bool) -> Any:
    """Run ``op`` with ``method="unscented"`` on ``b``'s arrays (rotations: the 3×3 blocks)."""
    k = 3 if rotation else 6
    m = 3 if rotation else 4
    j = x["joint"]
    A = u.UncertainPose(b(x["TA"][..., :m, :m]), b(j[..., :k, :k]), name)
    B = u.UncertainPose(b(x["TB"][..., :m, :m]), b(j[..., 6 : 6 + k, 6 : 6 + k]), name)
    cross = b(j[..., :k, 6 : 6 + k])
    F = b(x["TF"][..., :m, :m])
    if op == "compose":
        return u.compose(A, B, method="unscented")
    if op == "compose_cross":
        return u.compose(A, B, cross, method="unscented")
    if op == "inverse":
        return u.inverse(A, method="unscented")
    if op == "relative_cross":
        return u.relative(A, B, cross, method="unscented")
    if op == "transform_left":
        return u.transform(A, F, "left", method="unscented")
    if op == "transform_right":
        return u.transform(A, F, "right", method="unscented")
    if op == "extrinsic":
        return u.transform(A, B, "left", method="unscented", cross=cross)
    if op == "act":
        return u.act(A, b(x["p"]), b(x["cov_p"]), method="unscented")
    if op == "act_exact_point":
        return u.act(A, b(x["p"]), method="unscented")
    raise AssertionError(op)


def _parts(r: Any) -> tuple[Any, Any]:
    return (r.p if isinstance(r, u.UncertainPoint) else r.T), r.cov


# ----------------------------------------------------------------------------- unscented
#: torch runs every case; JAX (op-by-op dispatch outside jit, a compilation per new shape on this
#: 2-core machine) the right, left and split world conventions on poses and rotations
@pytest.mark.parametrize("rotation", [False, True], ids=["pose", "rotation"])
@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot"])
@pytest.mark.parametrize("op", OPS)
@pytest.mark.parametrize("backend", FOREIGN)
def test_unscented_equals_numpy(
    backend: str, op: str, name: str, rotation: bool, x64: None
) -> None:
    b = Backend(backend)
    for shape in SHAPES:
        x = _inputs(shape)
        ref_mean, ref_cov = _parts(_unscented(op, name, x, Backend("numpy"), rotation))
        mean, cov = _parts(_unscented(op, name, x, b, rotation))
        _close(b.check(cov), ref_cov, TOL64, f"{op} {shape} cov")
        _close(b.check(mean), ref_mean, TOL64, f"{op} {shape} mean")


@pytest.mark.parametrize("op", ["compose_cross", "inverse", "relative_cross", "act"])
@pytest.mark.parametrize("backend", FOREIGN)
def test_unscented_float32_within_the_stated_tolerance(backend: str, op: str) -> None:
    """float32 in, float32 out: within 2e-5 of float64 numpy (relative to the largest entry)."""
    x = _inputs((4,), seed=3)
    b = Backend(backend, "float32")
    for name in ["gtsam", "ros", "barfoot"]:
        ref_mean, ref_cov = _parts(_unscented(op, name, x, Backend("numpy"), False))
        mean, cov = _parts(_unscented(op, name, x, b, False))
        _close(b.check(cov), ref_cov, TOL32, f"{name} {op} cov")
        _close(b.check(mean), ref_mean, TOL32, f"{name} {op} mean")


@pytest.mark.parametrize("backend", FOREIGN)
def test_unscented_differs_from_linear_on_tensors(backend: str, x64: None) -> None:
    """The tensor path is the cubature, not the linear path in disguise (a large covariance)."""
    x = _inputs((), seed=4, scale=0.2)
    b = Backend(backend)
    A = u.UncertainPose(b(x["TA"]), b(x["joint"][:6, :6]), "ros")
    lin = b.check(u.inverse(A).cov)
    uns = b.check(u.inverse(A, method="unscented").cov)
    assert np.abs(uns - lin).max() > 1e-3 * np.abs(lin).max()


@pytest.mark.parametrize("backend", FOREIGN)
def test_unscented_mixed_operands_give_the_tensor_type(backend: str, x64: None) -> None:
    """A numpy operand beside a tensor is moved to it; the result is the tensor's type."""
    b = Backend(backend)
    x = _inputs((2,), seed=12)
    j = x["joint"]
    A = u.UncertainPose(b(x["TA"]), b(j[..., :6, :6]), "ros")
    B = u.UncertainPose(x["TB"], j[..., 6:, 6:], "ros")  # numpy
    ref_A = u.UncertainPose(x["TA"], j[..., :6, :6], "ros")
    got = u.compose(A, B, j[..., :6, 6:], method="unscented")
    ref = u.compose(ref_A, B, j[..., :6, 6:], method="unscented")
    _close(b.check(got.cov), ref.cov, TOL64, "compose")
    q = u.act(B, b(x["p"]), method="unscented")
    _close(b.check(q.cov), u.act(B, x["p"], method="unscented").cov, TOL64, "act")
    mc = check.monte_carlo_compose(B, A, n=300, rng=np.random.default_rng(2))
    ref_mc = check.monte_carlo_compose(B, ref_A, n=300, rng=np.random.default_rng(2))
    _close(b.check(mc.cov), ref_mc.cov, TOL64, "monte_carlo_compose")


# ----------------------------------------------------------------------------- Monte Carlo
def _mc(kind: str, name: str, x: dict[str, np.ndarray], b: Backend, n: int) -> Any:
    """Run a Monte Carlo reference on ``b``'s arrays with a fresh generator of one seed."""
    rng = np.random.default_rng(17)
    j = x["joint"]
    A = u.UncertainPose(b(x["TA"]), b(j[..., :6, :6]), name)
    B = u.UncertainPose(b(x["TB"]), b(j[..., 6:, 6:]), name)
    if kind == "compose":
        return check.monte_carlo_compose(A, B, b(j[..., :6, 6:]), n=n, rng=rng)
    if kind == "inverse":
        return check.monte_carlo_inverse(A, n=n, rng=rng)
    if kind == "relative":
        return check.monte_carlo_relative(A, B, b(j[..., :6, 6:]), n=n, rng=rng)
    if kind == "transform_left":
        return check.monte_carlo_transform(A, b(x["TF"]), "left", n=n, rng=rng)
    if kind == "transform_right":
        return check.monte_carlo_transform(A, b(x["TF"]), "right", n=n, rng=rng)
    if kind == "act":
        return check.monte_carlo_act(A, b(x["p"]), b(x["cov_p"]), n=n, rng=rng)
    raise AssertionError(kind)


MC_OPS = ["compose", "inverse", "relative", "transform_left", "transform_right", "act"]


@pytest.mark.parametrize("name", ["gtsam", "ros", "barfoot"])
@pytest.mark.parametrize("kind", MC_OPS)
@pytest.mark.parametrize("backend", FOREIGN)
def test_monte_carlo_equals_numpy_for_the_same_seed(
    backend: str, kind: str, name: str, x64: None
) -> None:
    """The same draws (numpy's, moved to the device) and the same formulas: numpy's result."""
    b = Backend(backend)
    for shape in SHAPES:
        x = _inputs(shape, seed=5)
        ref_mean, ref_cov = _parts(_mc(kind, name, x, Backend("numpy"), 500))
        mean, cov = _parts(_mc(kind, name, x, b, 500))
        _close(b.check(cov), ref_cov, TOL64, f"{kind} {shape} cov")
        _close(b.check(mean), ref_mean, TOL64, f"{kind} {shape} mean")


@pytest.mark.parametrize("backend", FOREIGN)
def test_monte_carlo_rotations_fuse_and_covariance_equal_numpy(backend: str, x64: None) -> None:
    b = Backend(backend)
    x = _inputs((), seed=6)
    j, TA = x["joint"], x["TA"]
    for name in ["gtsam", "ros"]:
        for k, m in [(6, 4), (3, 3)]:
            outs = {}
            for bb in [Backend("numpy"), b]:
                A = u.UncertainPose(bb(TA[:m, :m]), bb(j[:k, :k]), name)
                A2 = u.UncertainPose(bb(TA[:m, :m]), bb(j[6 : 6 + k, 6 : 6 + k]), name)
                outs[bb.name] = [
                    check.monte_carlo_compose(A, A2, n=400, rng=np.random.default_rng(1)).cov,
                    check.monte_carlo_inverse(A, n=400, rng=np.random.default_rng(1)).cov,
                    check.monte_carlo_act(A, bb(x["p"]), n=400, rng=np.random.default_rng(1)).cov,
                    check.monte_carlo_fuse(A, A2, n=400, rng=np.random.default_rng(1)).cov,
                    check.monte_carlo_covariance(
                        bb(j[:k, :k]),
                        bb(TA[:m, :m]),
                        name,
                        "barfoot",
                        n=400,
                        rng=np.random.default_rng(1),
                    ),
                ]
            for got, ref in zip(outs[backend], outs["numpy"], strict=True):
                _close(b.check(got), ref, 1e-11, f"{name} {k}")


def _frobenius_tolerance(cov: np.ndarray, n: int, k: float = 3.0) -> float:
    """``k`` times the RMS Frobenius error of a sample covariance of ``n`` Gaussian draws.

    For Gaussian samples ``Var(Ŝ_ij) = (Σ_ij² + Σ_ii Σ_jj) / (n − 1)``, so
    ``E‖Ŝ − Σ‖²_F = (‖Σ‖²_F + (tr Σ)²) / (n − 1)``. The output of a small-covariance operation
    is Gaussian to first order; its linearisation error is of the order of the covariance's
    scale (1e-4 here) relative, far below the sampling error.
    """
    return k * float(np.sqrt((np.sum(cov**2) + np.trace(cov) ** 2) / (n - 1)))


@pytest.mark.parametrize("name", ["ros", "barfoot"])
@pytest.mark.parametrize("backend", FOREIGN)
def test_tensor_monte_carlo_agrees_with_the_linear_propagation(
    backend: str, name: str, x64: None
) -> None:
    """A real Monte Carlo test: 20 000 samples on the tensors, 3σ of the sampling error.

    The tolerance would catch the classic errors: the inverse's ``Ad_A Σ Ad_Aᵀ`` in a left
    convention, and a composition that drops the cross term.
    """
    n = 20000
    b = Backend(backend)
    x = _inputs((), seed=8, scale=1e-4)
    j = x["joint"]
    A = u.UncertainPose(b(x["TA"]), b(j[:6, :6]), name)
    B = u.UncertainPose(b(x["TB"]), b(j[6:, 6:]), name)
    X = b(j[:6, 6:])
    cases = [
        (check.monte_carlo_inverse(A, n=n), u.inverse(A)),
        (check.monte_carlo_compose(A, B, X, n=n), u.compose(A, B, X)),
        (check.monte_carlo_relative(A, B, X, n=n), u.relative(A, B, X)),
        (
            check.monte_carlo_act(A, b(x["p"]), b(x["cov_p"]), n=n),
            u.act(A, b(x["p"]), b(x["cov_p"])),
        ),
    ]
    for mc, lin in cases:
        got, ref = b.check(mc.cov), b.check(lin.cov)
        assert np.linalg.norm(got - ref) <= _frobenius_tolerance(ref, n)
    # the tolerance is tight enough to fail the wrong answers
    Ad = np.asarray(se3.adjoint(x["TA"]))
    wrong_inverse = Ad @ j[:6, :6] @ Ad.T  # right-perturbation formula, wrong for both presets
    ref = b.check(check.monte_carlo_inverse(A, n=n).cov)
    assert np.linalg.norm(wrong_inverse - ref) > _frobenius_tolerance(ref, n)
    no_cross = b.check(u.compose(A, B).cov)
    ref = b.check(check.monte_carlo_compose(A, B, X, n=n).cov)
    assert np.linalg.norm(no_cross - ref) > _frobenius_tolerance(ref, n)


@pytest.mark.parametrize("backend", FOREIGN)
def test_tensor_unscented_agrees_with_monte_carlo_at_a_large_covariance(
    backend: str, x64: None
) -> None:
    """Where linear and unscented differ, the tensor cubature is at least as close to sampling."""
    n = 40000
    b = Backend(backend)
    x = _inputs((), seed=9, scale=0.05)
    A = u.UncertainPose(b(x["TA"]), b(x["joint"][:6, :6]), "ros")
    mc = b.check(check.monte_carlo_inverse(A, n=n).cov)
    uns = b.check(u.inverse(A, method="unscented").cov)
    lin = b.check(u.inverse(A).cov)
    assert np.linalg.norm(uns - mc) <= _frobenius_tolerance(mc, n)
    assert np.linalg.norm(uns - mc) < np.linalg.norm(lin - mc)


# ----------------------------------------------------------------------------- gradients
def _grad_case(lib: str, at_zero: bool) -> tuple[Any, Any, list[np.ndarray]]:
    """Base poses and the numpy values of ``(dA, LA, dB, LB)`` (covariances ``L Lᵀ + εI``)."""
    rng = np.random.default_rng(21)
    if at_zero:  # θ = 0 exactly at the evaluation point
        T0A = T0B = np.eye(4)
        dA = dB = np.zeros(6)
    else:
        T0A = np.asarray(se3.exp(rng.normal(size=6)))
        T0B = np.asarray(se3.exp(rng.normal(size=6)))
        dA, dB = 0.1 * rng.normal(size=6), 0.1 * rng.normal(size=6)
    LA, LB = rng.normal(size=(6, 6)), rng.normal(size=(6, 6))
    return T0A, T0B, [dA, LA, dB, LB]


def _grad_fn(op: str, name: str, T0A: Any, T0B: Any, eye: Any) -> Callable[..., Any]:
    """``(dA, LA, dB, LB) -> (T, cov)`` of an unscented operation (``T0·Exp(d)``, ``εI + L Lᵀ``)."""

    def f(dA: Any, LA: Any, dB: Any, LB: Any) -> Any:
        A = u.UncertainPose(T0A @ se3.exp(dA), 1e-2 * (LA @ LA.T) + 1e-3 * eye, name)
        B = u.UncertainPose(T0B @ se3.exp(dB), 1e-2 * (LB @ LB.T) + 1e-3 * eye, name)
        r = u.compose(A, B, method="unscented") if op == "compose" else u.inverse(A, "unscented")
        return r.T, r.cov

    return f


@pytest.mark.skipif(not HAS["torch"], reason="torch extra")
@pytest.mark.parametrize("at_zero", [False, True], ids=["generic", "theta_zero"])
@pytest.mark.parametrize(
    ("op", "name"), [("compose", "ros"), ("compose", "barfoot"), ("inverse", "gtsam")]
)
def test_torch_gradcheck_unscented(op: str, name: str, at_zero: bool) -> None:
    """With respect to the means' tangents and the covariances' factors (distinct eigenvalues)."""
    import torch

    T0A, T0B, vals = _grad_case("torch", at_zero)
    args = [torch.tensor(v, requires_grad=True) for v in vals]
    if op == "inverse":
        args[2].requires_grad_(False)
        args[3].requires_grad_(False)
    f = _grad_fn(op, name, torch.tensor(T0A), torch.tensor(T0B), torch.eye(6, dtype=torch.float64))
    assert torch.autograd.gradcheck(f, tuple(args), eps=1e-6, atol=1e-6, rtol=1e-5)


@pytest.mark.skipif(not HAS["jax"], reason="jax extra")
@pytest.mark.parametrize("at_zero", [False, True], ids=["generic", "theta_zero"])
@pytest.mark.parametrize("op", ["compose", "inverse"])
def test_jax_check_grads_unscented(op: str, at_zero: bool, x64: None) -> None:
    import jax.numpy as jnp
    from jax.test_util import check_grads

    T0A, T0B, vals = _grad_case("jax", at_zero)
    f = _grad_fn(op, "ros", jnp.asarray(T0A), jnp.asarray(T0B), jnp.eye(6))
    args = [jnp.asarray(v) for v in vals]
    if op == "inverse":
        g = f
        dB, LB = args[2], args[3]
        args = args[:2]

        def f(dA: Any, LA: Any) -> Any:  # the inputs inverse reads
            return g(dA, LA, dB, LB)

    check_grads(f, tuple(args), order=1, modes=("rev",), eps=1e-6, atol=1e-5, rtol=1e-5)


@pytest.mark.skipif(not HAS["torch"], reason="torch extra")
def test_torch_gradcheck_monte_carlo_is_reparameterised() -> None:
    """The Monte Carlo reference on tensors is differentiable (fixed seed: a smooth function)."""
    import torch

    T0A, T0B, vals = _grad_case("torch", False)
    eye = torch.eye(6, dtype=torch.float64)
    TA, TB = torch.tensor(T0A), torch.tensor(T0B)

    def f(dA: Any, LA: Any) -> Any:
        A = u.UncertainPose(TA @ se3.exp(dA), 1e-2 * (LA @ LA.T) + 1e-3 * eye, "ros")
        B = u.UncertainPose(TB, 1e-3 * eye, "ros")
        r = check.monte_carlo_compose(A, B, n=64, rng=np.random.default_rng(3))
        return r.cov

    args = (torch.tensor(vals[0], requires_grad=True), torch.tensor(vals[1], requires_grad=True))
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6, rtol=1e-5)


# ----------------------------------------------------------------------------- tracing
@pytest.mark.skipif(not HAS["jax"], reason="jax extra")
def test_jax_jit_of_an_unscented_compose(x64: None) -> None:
    import jax

    x = _inputs((3,), seed=10)
    j = x["joint"]

    def f(TA: Any, TB: Any, S: Any) -> Any:
        A = u.UncertainPose(TA, S[..., :6, :6], "ros")
        B = u.UncertainPose(TB, S[..., 6:, 6:], "ros")
        return u.compose(A, B, S[..., :6, 6:], method="unscented").cov

    b = Backend("jax")
    got = jax.jit(f)(b(x["TA"]), b(x["TB"]), b(j))
    _close(b.check(got), f(x["TA"], x["TB"], j), TOL64, "jit")


def test_numpy_unscented_unchanged_by_the_generic_path() -> None:
    """numpy input keeps numpy's code: read-only float64 arrays, the pinned cubature values."""
    x = _inputs((2,), seed=11)
    A = u.UncertainPose(x["TA"], x["joint"][..., :6, :6], "gtsam")
    C = u.inverse(A, method="unscented")
    assert isinstance(C.cov, np.ndarray) and C.cov.dtype == np.float64
    assert not C.cov.flags.writeable
    # the inverse is exactly linear in GTSAM's exponential chart: the cubature equals linear
    np.testing.assert_allclose(C.cov, u.inverse(A).cov, rtol=1e-9, atol=1e-14)
